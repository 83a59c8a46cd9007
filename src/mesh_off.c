/*
 * mesh_off.c - the OFF reader (the formats read are in mesh.h).
 */
#include "mesh_read.h"

#include <limits.h>
#include <stdlib.h>
#include <string.h>

/* Reads the header keyword t: [C][N]OFF (either order). */
static int off_header(const LexReader *R, LexTok t, int *normals, int *colour)
{
    char q[LEX_QUOTE_LEN];
    if (t.len >= 3 && memcmp(t.s + t.len - 3, "OFF", 3) == 0) {
        size_t i;
        for (i = 0; i + 3 < t.len; i++) {
            if (t.s[i] == 'C' && !*colour)
                *colour = 1;
            else if (t.s[i] == 'N' && !*normals)
                *normals = 1;
            else
                break;
        }
        if (i + 3 == t.len)
            return 0;
        return lex_fail(R, R->line, t.s, "unsupported OFF variant '%s' (OFF, COFF, NOFF and CNOFF are read)",
                        lex_quote(t, q));
    }
    return lex_fail(R, R->line, t.s, "expected an OFF header or the counts line, got '%s'", lex_quote(t, q));
}

int mesh_read_off(LexReader *R, MeshBuild *B)
{
    Mesh *m = &B->m;
    const char *s, *e, *q;
    char qb[LEX_QUOTE_LEN];
    LexTok t, tk[11];
    int normals = 0, colour = 0;

    if (!lex_next_text_line(R, &s, &e, 1))
        return lex_fail_eof(R, "empty file: no OFF header or counts line");
    long long unused;
    q = s;
    lex_next_tok(&q, e, &t);
    if (lex_parse_int(t, &unused) != 0) { /* not the counts: a header */
        if (off_header(R, t, &normals, &colour) != 0)
            return -1;
        const char *q2 = q;
        if (lex_next_tok(&q2, e, &t)) {
            if (lex_tok_is(t, "BINARY"))
                return lex_fail(R, R->line, t.s, "binary OFF is not supported");
            s = q; /* the counts follow the keyword on its line */
        } else if (!lex_next_text_line(R, &s, &e, 1)) {
            return lex_fail_eof(R, "file ends before the counts line");
        }
    }

    /* counts: nv nf ne */
    long long cnt[3];
    int nc = lex_split(s, e, tk, 3);
    if (nc != 3)
        return lex_fail(R, R->line, nc > 0 ? tk[0].s : NULL,
                        "counts line has %d values, expected 3 (vertices faces edges)", nc);
    for (int i = 0; i < 3; i++) {
        if (lex_parse_int(tk[i], &cnt[i]) != 0)
            return lex_fail(R, R->line, tk[i].s, "malformed count '%s'", lex_quote(tk[i], qb));
        if (cnt[i] < 0)
            return lex_fail(R, R->line, tk[i].s, "negative count '%s'", lex_quote(tk[i], qb));
    }
    long long nv = cnt[0], nf = cnt[1];
    LexTok nf_text = tk[1]; /* (tk is reused below) */
    long cline = R->line;
    if (nv > INT_MAX) /* (quoted as written: a count may have saturated) */
        return lex_fail(R, cline, tk[0].s, "%s vertices announced, more than %d", lex_quote(tk[0], qb), INT_MAX);
    /* a vertex line takes at least a digit and a separator a value, a face
     * line of 3 corners ("3 0 1 2\n") 8 bytes: the faces read past these
     * grow the arrays as they need */
    size_t rem = (size_t)(R->end - R->p);
    int nvals = 3 + 3 * normals; /* values a vertex needs */
    if (mesh_alloc_vertices(R, cline, B, mesh_text_cap(nv, rem, 2 * (unsigned)nvals), normals) != 0)
        return -1;
    long long reserve = mesh_text_cap(nf, rem, 8);
    if (reserve > 0 && mesh_reserve_tris(R, cline, B, (size_t)(reserve < INT_MAX ? reserve : INT_MAX)) != 0)
        return -1;

    static const char *const expect[2][2] = {{"3", "6 (position, normal)"},
                                             {"6 or 7 (position, colour)", "9 or 10 (position, normal, colour)"}};
    for (int i = 0; i < nv; i++) {
        if (!lex_next_text_line(R, &s, &e, 1))
            return lex_fail_eof(R, "file ends after %d of %lld vertices", i, nv);
        int n = lex_split(s, e, tk, 11);
        if (colour ? n != nvals + 3 && n != nvals + 4 : n != nvals) {
            int ints = n > nvals; /* more values, all integers: looks like a face */
            for (int j = 0; j < n && j < 11; j++)
                ints &= lex_parse_int(tk[j], &unused) == 0;
            return lex_fail(R, R->line, NULL, "vertex line has %d values, expected %s%s", n, expect[colour][normals],
                            ints ? " (a face line: fewer vertices than announced?)" : "");
        }
        if (mesh_read_coord(R, tk[0], "coordinate", &m->v[i].x) != 0 ||
            mesh_read_coord(R, tk[1], "coordinate", &m->v[i].y) != 0 ||
            mesh_read_coord(R, tk[2], "coordinate", &m->v[i].z) != 0)
            return -1;
        if (normals && (mesh_read_coord(R, tk[3], "normal component", &m->n[i].x) != 0 ||
                        mesh_read_coord(R, tk[4], "normal component", &m->n[i].y) != 0 ||
                        mesh_read_coord(R, tk[5], "normal component", &m->n[i].z) != 0))
            return -1;
        for (int j = nvals; j < n; j++)
            if (mesh_check_number(R, tk[j]) != 0)
                return -1;
    }

    for (long long f = 0; f < nf; f++) {
        if (!lex_next_text_line(R, &s, &e, 1))
            return lex_fail_eof(R, "file ends after %lld of %s faces", f, lex_quote(nf_text, qb));
        long long k, idx;
        q = s;
        lex_next_tok(&q, e, &t);
        if (lex_parse_int(t, &k) != 0)
            return lex_fail(R, R->line, t.s, "malformed corner count '%s'%s", lex_quote(t, qb),
                            lex_is_decimal(t) ? " (a vertex line: more vertices than announced?)" : "");
        if (k < 3)
            return lex_fail(R, R->line, NULL, "face with %lld corners (at least 3 needed)", k);
        int c[3] = {0, 0, 0};
        for (long long j = 0; j < k; j++) {
            if (!lex_next_tok(&q, e, &t))
                return lex_fail(R, R->line, NULL, "face lists %lld of its %lld corners", j, k);
            if (lex_parse_int(t, &idx) != 0)
                return lex_fail(R, R->line, t.s, "malformed vertex index '%s'", lex_quote(t, qb));
            if (idx < 0 || idx >= nv)
                return lex_fail(R, R->line, t.s, "vertex index %s out of range (%lld vertices)", lex_quote(t, qb), nv);
            if (mesh_fan_corner(R, B, j, (int)idx, 0, c, NULL) != 0)
                return -1;
        }
        int extra = 0;
        while (lex_next_tok(&q, e, &t)) {
            if (mesh_check_number(R, t) != 0)
                return -1;
            extra++;
        }
        if (extra > 4)
            return lex_fail(R, R->line, NULL, "face has %d values after its %lld corners, at most 4 (a colour) allowed",
                            extra, k);
    }
    if (lex_next_text_line(R, &s, &e, 1))
        return lex_fail(R, R->line, NULL, "extra data after the %lld face%s announced", nf, nf == 1 ? "" : "s");
    return mesh_finish(R, B, normals);
}

