/*
 * mesh_obj.c - the OBJ reader (the formats read are in mesh.h).
 */
#include "mesh_read.h"

#include <limits.h>
#include <stdlib.h>
#include <string.h>

typedef struct {
    const char *what, *plural; /* "vertex", "vertices" */
    long long so_far, total;
} ObjIndexKind;

/* Resolves OBJ index text t (1-based or negative) to a 0-based index. */
static int obj_index(const LexReader *R, LexTok t, const ObjIndexKind *k, int *out)
{
    char q[LEX_QUOTE_LEN];
    long long i;
    if (lex_parse_int(t, &i) != 0)
        return lex_fail(R, R->line, t.s, "malformed %s index '%s'", k->what, lex_quote(t, q));
    if (i == 0)
        return lex_fail(R, R->line, t.s, "%s index 0 is invalid (OBJ indices start at 1)", k->what);
    if (i > 0) {
        if (i > k->total)
            return lex_fail(R, R->line, t.s, "%s index %s out of range (%lld %s)", k->what, lex_quote(t, q), k->total,
                            k->plural);
        *out = (int)(i - 1);
    } else {
        if (-i > k->so_far)
            return lex_fail(R, R->line, t.s, "relative %s index %s out of range (%lld %s defined so far)", k->what,
                            lex_quote(t, q), k->so_far, k->plural);
        *out = (int)(k->so_far + i);
    }
    return 0;
}

/* Reads corner t: v, v/vt, v//vn or v/vt/vn. *ni is -1 without a normal. */
static int obj_corner(const LexReader *R, LexTok t, const ObjIndexKind kinds[3], int *vi, int *ni)
{
    char q[LEX_QUOTE_LEN];
    LexTok part[3];
    int np = 0;
    size_t start = 0;
    *ni = -1;
    for (size_t i = 0; i <= t.len; i++) {
        if (i == t.len || t.s[i] == '/') {
            if (np == 3)
                return lex_fail(R, R->line, t.s, "malformed face corner '%s'", lex_quote(t, q));
            part[np].s = t.s + start;
            part[np].len = i - start;
            np++;
            start = i + 1;
        }
    }
    /* the vertex is always there; v/ and v/vt/ and v// are not corners */
    if (part[0].len == 0 || (np >= 2 && part[np - 1].len == 0))
        return lex_fail(R, R->line, t.s, "malformed face corner '%s'", lex_quote(t, q));
    int unused;
    if (obj_index(R, part[0], &kinds[0], vi) != 0)
        return -1;
    if (np >= 2 && part[1].len > 0 && obj_index(R, part[1], &kinds[1], &unused) != 0)
        return -1;
    if (np == 3 && obj_index(R, part[2], &kinds[2], ni) != 0)
        return -1;
    return 0;
}

int mesh_read_obj(LexReader *R, MeshBuild *B)
{
    Mesh *m = &B->m;
    const char *s, *e, *q, *start = R->p;
    char qb[LEX_QUOTE_LEN];
    LexTok t, tk[8];
    long long nv = 0, nn = 0, nvt = 0, ntris = 0;

    /* pass 1: how many of each */
    while (lex_next_text_line(R, &s, &e, 1)) {
        q = s;
        lex_next_tok(&q, e, &t);
        if (lex_tok_is(t, "v")) {
            if (++nv > INT_MAX)
                return lex_fail(R, R->line, NULL, "more than %d vertices", INT_MAX);
        } else if (lex_tok_is(t, "vn")) {
            if (++nn > INT_MAX)
                return lex_fail(R, R->line, NULL, "more than %d normals", INT_MAX);
        } else if (lex_tok_is(t, "vt")) {
            nvt++;
        } else if (lex_tok_is(t, "f")) {
            int k = lex_split(q, e, tk, 0);
            if (k > 2 && (ntris += k - 2) > INT_MAX)
                return lex_fail(R, R->line, NULL, "more than %d triangles", INT_MAX);
        }
    }
    if (mesh_alloc_vertices(R, 1, B, nv, 0) != 0)
        return -1;
    if (nn > 0) {
        m->n = mesh_array(NULL, 0, (size_t)nn, sizeof *m->n);
        if (!m->n)
            return lex_fail(R, 1, R->data, "out of memory for %lld normals", nn);
        m->nn = (int)nn;
        B->track_n = 1;
    }
    if (ntris > 0 && mesh_reserve_tris(R, 1, B, (size_t)ntris) != 0)
        return -1;

    /* pass 2: read them */
    R->p = start;
    R->line = 0;
    ObjIndexKind kinds[3] = {{"vertex", "vertices", 0, nv},
                             {"texture coordinate", "texture coordinates", 0, nvt},
                             {"normal", "normals", 0, nn}};
    long long faces_without_normals = 0;
    while (lex_next_text_line(R, &s, &e, 1)) {
        q = s;
        lex_next_tok(&q, e, &t);
        if (lex_tok_is(t, "v")) {
            int n = lex_split(q, e, tk, 7);
            if (n != 3 && n != 4 && n != 6)
                return lex_fail(R, R->line, NULL, "'v' takes 3 or 4 numbers (or 6 with a colour), got %d", n);
            Vec3 *p = &m->v[kinds[0].so_far++];
            if (mesh_read_coord(R, tk[0], "coordinate", &p->x) != 0 || mesh_read_coord(R, tk[1], "coordinate", &p->y) != 0 ||
                mesh_read_coord(R, tk[2], "coordinate", &p->z) != 0)
                return -1;
            for (int j = 3; j < n; j++)
                if (mesh_check_number(R, tk[j]) != 0)
                    return -1;
        } else if (lex_tok_is(t, "vn")) {
            int n = lex_split(q, e, tk, 3);
            if (n != 3)
                return lex_fail(R, R->line, NULL, "'vn' takes 3 numbers, got %d", n);
            Vec3 *p = &m->n[kinds[2].so_far++];
            if (mesh_read_coord(R, tk[0], "normal component", &p->x) != 0 ||
                mesh_read_coord(R, tk[1], "normal component", &p->y) != 0 ||
                mesh_read_coord(R, tk[2], "normal component", &p->z) != 0)
                return -1;
        } else if (lex_tok_is(t, "vt")) {
            kinds[1].so_far++;
        } else if (lex_tok_is(t, "f")) {
            int c[3] = {0, 0, 0}, nc[3] = {0, 0, 0}, k = 0, with_n = 0;
            while (lex_next_tok(&q, e, &t)) {
                int vi = 0, ni = -1;
                if (obj_corner(R, t, kinds, &vi, &ni) != 0)
                    return -1;
                if (k == 0)
                    with_n = ni >= 0;
                else if (with_n != (ni >= 0))
                    return lex_fail(R, R->line, t.s, "face mixes corners with and without normals");
                if (mesh_fan_corner(R, B, k, vi, ni < 0 ? 0 : ni, c, nc) != 0)
                    return -1;
                k++;
            }
            if (k < 3)
                return lex_fail(R, R->line, NULL, "face with %d corners (at least 3 needed)", k);
            faces_without_normals += !with_n;
        } else if (!((t.s[0] >= 'a' && t.s[0] <= 'z') || (t.s[0] >= 'A' && t.s[0] <= 'Z'))) {
            return lex_fail(R, R->line, t.s, "unknown statement '%s'", lex_quote(t, qb));
        } /* any other statement: ignored */
    }
    if (faces_without_normals > 0) /* (no triangles at all: finish drops them) */
        mesh_drop_normals(m);
    return mesh_finish(R, B, 0);
}

