/*
 * mesh_ply.c - the PLY reader, ascii and binary little-endian (the formats read are in
 * mesh.h).
 */
#include "mesh_read.h"
#include "lancer/limits.h"

#include <limits.h>
#include <stdlib.h>
#include <string.h>
#include <stdint.h>
#include <math.h>

typedef enum { PT_NONE, PT_I8, PT_U8, PT_I16, PT_U16, PT_I32, PT_U32, PT_F32, PT_F64 } PlyType;

static const struct {
    const char *name, *sized;
    int size;
} ply_types[] = {
    {"", "", 0},
    {"char", "int8", 1},   {"uchar", "uint8", 1},   {"short", "int16", 2},     {"ushort", "uint16", 2},
    {"int", "int32", 4},   {"uint", "uint32", 4},   {"float", "float32", 4},   {"double", "float64", 8},
};

static int ply_is_int(PlyType t) { return t >= PT_I8 && t <= PT_U32; }

typedef struct {
    LexTok name;
    PlyType type;  /* a scalar's type, or a list's item type */
    PlyType count; /* a list's count type; PT_NONE for a scalar */
} PlyProp;

typedef struct {
    LexTok name;
    long long count;
    LexTok count_text; /* as written, for messages: count may have saturated */
    long line;      /* of its "element" statement */
    PlyProp *props;
    int nprops, cap;
} PlyElem;

typedef struct {
    LexReader *R;
    MeshBuild *B;
    int binary;
    PlyElem *el;
    int nel, cap;
    int declared;       /* elements and properties so far */
    long end_line;      /* of "end_header" */
    int vertex, face;   /* indices into el, or -1 */
    int pos[3], nrm[3]; /* vertex properties x y z and nx ny nz, or -1 */
    int idx;            /* face property vertex_indices, or -1 */
} Ply;

static PlyType ply_type(LexTok t)
{
    for (int i = PT_I8; i <= PT_F64; i++)
        if (lex_tok_is(t, ply_types[i].name) || lex_tok_is(t, ply_types[i].sized))
            return (PlyType)i;
    return PT_NONE;
}

static void ply_free(Ply *P)
{
    for (int i = 0; i < P->nel; i++)
        MESH_FREE(P->el[i].props);
    MESH_FREE(P->el);
}

static int ply_find(const PlyElem *E, const char *name)
{
    for (int i = 0; i < E->nprops; i++)
        if (lex_tok_is(E->props[i].name, name))
            return i;
    return -1;
}

/* Reads one "element" or "property" statement of n tokens tk. */
static int ply_declare(Ply *P, const LexTok *tk, int n)
{
    LexReader *R = P->R;
    char q[LEX_QUOTE_LEN], q2[LEX_QUOTE_LEN];
    if (++P->declared > LIMIT_PLY_DECLARATIONS)
        return lex_fail(R, R->line, NULL, "more than %d elements and properties in the header", LIMIT_PLY_DECLARATIONS);
    if (lex_tok_is(tk[0], "element")) {
        long long count;
        if (n != 3)
            return lex_fail(R, R->line, NULL, "'element' takes a name and a count, got %d values", n - 1);
        if (lex_parse_int(tk[2], &count) != 0 || count < 0)
            return lex_fail(R, R->line, tk[2].s, "malformed element count '%s'", lex_quote(tk[2], q));
        for (int i = 0; i < P->nel; i++)
            if (lex_tok_same(P->el[i].name, tk[1]))
                return lex_fail(R, R->line, tk[1].s, "second '%s' element", lex_quote(tk[1], q));
        void *p = mesh_grow(P->el, &P->cap, P->nel, 4, sizeof *P->el);
        if (!p)
            return lex_fail(R, R->line, NULL, "out of memory");
        P->el = p;
        PlyElem *E = &P->el[P->nel++];
        memset(E, 0, sizeof *E);
        E->name = tk[1];
        E->count = count;
        E->count_text = tk[2];
        E->line = R->line;
        return 0;
    }
    /* property */
    if (P->nel == 0)
        return lex_fail(R, R->line, NULL, "'property' before any 'element'");
    PlyElem *E = &P->el[P->nel - 1];
    PlyProp pr;
    if (n >= 2 && lex_tok_is(tk[1], "list")) {
        if (n != 5)
            return lex_fail(R, R->line, NULL, "'property list' takes a count type, an item type and a name");
        pr.count = ply_type(tk[2]);
        pr.type = ply_type(tk[3]);
        pr.name = tk[4];
        if (pr.count == PT_NONE)
            return lex_fail(R, R->line, tk[2].s, "unknown property type '%s'", lex_quote(tk[2], q));
        if (pr.type == PT_NONE)
            return lex_fail(R, R->line, tk[3].s, "unknown property type '%s'", lex_quote(tk[3], q));
        if (!ply_is_int(pr.count))
            return lex_fail(R, R->line, tk[2].s, "list count type must be an integer type, not '%s'",
                            lex_quote(tk[2], q));
    } else {
        if (n != 3)
            return lex_fail(R, R->line, NULL, "'property' takes a type and a name");
        pr.count = PT_NONE;
        pr.type = ply_type(tk[1]);
        pr.name = tk[2];
        if (pr.type == PT_NONE)
            return lex_fail(R, R->line, tk[1].s, "unknown property type '%s'", lex_quote(tk[1], q));
    }
    for (int i = 0; i < E->nprops; i++)
        if (lex_tok_same(E->props[i].name, pr.name))
            return lex_fail(R, R->line, pr.name.s, "second property '%s' in element '%s'", lex_quote(pr.name, q),
                            lex_quote(E->name, q2));
    void *p = mesh_grow(E->props, &E->cap, E->nprops, 8, sizeof *E->props);
    if (!p)
        return lex_fail(R, R->line, NULL, "out of memory");
    E->props = p;
    E->props[E->nprops++] = pr;
    return 0;
}

/* Reads the header up to end_header and works out where x y z ... are. */
static int ply_header(Ply *P)
{
    LexReader *R = P->R;
    const char *s, *e;
    char q[LEX_QUOTE_LEN];
    LexTok tk[6];
    int have_format = 0;
    if (!lex_next_line(R, &s, &e) || lex_split(s, e, tk, 2) != 1 || tk[0].s != s || !lex_tok_is(tk[0], "ply"))
        return lex_fail(R, 1, R->data, "not a PLY file (the first line must be 'ply')");
    for (;;) {
        if (!lex_next_line(R, &s, &e))
            return lex_fail_eof(R, "header has no 'end_header' line");
        int n = lex_split(s, e, tk, 6);
        if (n == 0)
            continue;
        if (lex_tok_is(tk[0], "comment") || lex_tok_is(tk[0], "obj_info"))
            continue;
        if (lex_tok_is(tk[0], "end_header")) {
            if (n != 1)
                return lex_fail(R, R->line, tk[1].s, "unexpected text after 'end_header'");
            break;
        }
        if (lex_tok_is(tk[0], "format")) {
            if (have_format)
                return lex_fail(R, R->line, NULL, "second 'format' line");
            if (n != 3)
                return lex_fail(R, R->line, NULL, "'format' takes a format and a version, got %d values", n - 1);
            if (lex_tok_is(tk[1], "binary_big_endian"))
                return lex_fail(R, R->line, tk[1].s,
                                "binary_big_endian PLY is not supported (ascii and binary_little_endian are)");
            if (lex_tok_is(tk[1], "binary_little_endian"))
                P->binary = 1;
            else if (!lex_tok_is(tk[1], "ascii"))
                return lex_fail(R, R->line, tk[1].s, "unknown PLY format '%s'", lex_quote(tk[1], q));
            if (!lex_tok_is(tk[2], "1.0"))
                return lex_fail(R, R->line, tk[2].s, "unsupported PLY version '%s' (1.0 is read)", lex_quote(tk[2], q));
            have_format = 1;
            continue;
        }
        if (lex_tok_is(tk[0], "element") || lex_tok_is(tk[0], "property")) {
            if (ply_declare(P, tk, n) != 0)
                return -1;
            continue;
        }
        return lex_fail(R, R->line, tk[0].s, "unknown header keyword '%s'", lex_quote(tk[0], q));
    }
    P->end_line = R->line;
    if (!have_format)
        return lex_fail(R, R->line, NULL, "the header has no 'format' line");

    /* the elements that make the mesh */
    static const char *const pos[3] = {"x", "y", "z"}, *const nrm[3] = {"nx", "ny", "nz"};
    P->vertex = P->face = P->idx = -1;
    for (int i = 0; i < P->nel; i++) {
        if (lex_tok_is(P->el[i].name, "vertex"))
            P->vertex = i;
        else if (lex_tok_is(P->el[i].name, "face"))
            P->face = i;
    }
    if (P->vertex < 0)
        return lex_fail(R, P->end_line, NULL, "no 'vertex' element");
    PlyElem *V = &P->el[P->vertex];
    int nnrm = 0;
    for (int k = 0; k < 3; k++) {
        P->pos[k] = ply_find(V, pos[k]);
        P->nrm[k] = ply_find(V, nrm[k]);
        if (P->pos[k] < 0)
            return lex_fail(R, V->line, V->name.s, "'vertex' element has no property '%s'", pos[k]);
        if (V->props[P->pos[k]].count != PT_NONE)
            return lex_fail(R, V->line, V->name.s, "vertex property '%s' is a list, not a number", pos[k]);
        if (P->nrm[k] >= 0) {
            nnrm++;
            if (V->props[P->nrm[k]].count != PT_NONE)
                return lex_fail(R, V->line, V->name.s, "vertex property '%s' is a list, not a number", nrm[k]);
        }
    }
    if (nnrm != 0 && nnrm != 3)
        return lex_fail(R, V->line, V->name.s, "'vertex' element has some of nx, ny, nz but not all three");
    if (P->face >= 0) {
        PlyElem *F = &P->el[P->face];
        P->idx = ply_find(F, "vertex_indices");
        if (P->idx < 0)
            P->idx = ply_find(F, "vertex_index");
        if (P->idx < 0)
            return lex_fail(R, F->line, F->name.s, "'face' element has no 'vertex_indices' list");
        if (F->props[P->idx].count == PT_NONE)
            return lex_fail(R, F->line, F->name.s, "face property '%s' is a number, not a list",
                            lex_quote(F->props[P->idx].name, q));
        if (!ply_is_int(F->props[P->idx].type))
            return lex_fail(R, F->line, F->name.s, "face property '%s' must have an integer item type",
                            lex_quote(F->props[P->idx].name, q));
    }
    return 0;
}

/* Fewest bytes one instance of element ei can take (faces need 3 corners). */
static unsigned long long ply_min_bytes(const Ply *P, int ei)
{
    const PlyElem *E = &P->el[ei];
    unsigned long long b = 0;
    for (int j = 0; j < E->nprops; j++) {
        const PlyProp *pr = &E->props[j];
        int corners = ei == P->face && j == P->idx ? 3 : 0;
        if (P->binary)
            b += pr->count == PT_NONE ? (unsigned)ply_types[pr->type].size
                                      : (unsigned)(ply_types[pr->count].size + corners * ply_types[pr->type].size);
        else
            b += 2u * (unsigned)(1 + corners); /* a digit and a separator per value */
    }
    return b;
}

/* Allocates the vertices and the triangles. A binary file's counts are
 * checked first against the bytes after the header, and refused at the
 * header line that announced them; a text file's are not (mesh_text_cap). */
static int ply_alloc(Ply *P)
{
    LexReader *R = P->R;
    char q[LEX_QUOTE_LEN], q2[LEX_QUOTE_LEN];
    size_t rem = (size_t)(R->end - R->p);
    unsigned long long room = rem;
    for (int i = 0; i < P->nel && P->binary; i++) {
        unsigned long long min = ply_min_bytes(P, i);
        const PlyElem *E = &P->el[i];
        if (min == 0) /* no properties: an instance is nothing to read */
            continue;
        if ((unsigned long long)E->count > room / min)
            return lex_fail(R, E->line, E->count_text.s,
                            "%s '%s' elements announced, more than the %zu bytes after the header can hold",
                            lex_quote(E->count_text, q2), lex_quote(E->name, q), rem);
        room -= (unsigned long long)E->count * min;
    }
    const PlyElem *V = &P->el[P->vertex];
    if (V->count > INT_MAX)
        return lex_fail(R, V->line, V->count_text.s, "%s vertices announced, more than %d", lex_quote(V->count_text, q),
                        INT_MAX);
    long long nv = P->binary ? V->count : mesh_text_cap(V->count, rem, ply_min_bytes(P, P->vertex));
    if (mesh_alloc_vertices(R, V->line, P->B, nv, P->nrm[0] >= 0) != 0)
        return -1;
    if (P->face >= 0 && P->el[P->face].count > 0) {
        long long nf = P->el[P->face].count;
        if (!P->binary)
            nf = mesh_text_cap(nf, rem, ply_min_bytes(P, P->face));
        if (mesh_reserve_tris(R, P->el[P->face].line, P->B, (size_t)(nf < INT_MAX ? nf : INT_MAX)) != 0)
            return -1;
    }
    return 0;
}

/* The vertex coordinate or normal that property j of vertex i stands for,
 * or NULL. */
static float *ply_slot(Ply *P, int j, long long i)
{
    Mesh *m = &P->B->m;
    for (int k = 0; k < 3; k++) {
        if (P->pos[k] == j)
            return k == 0 ? &m->v[i].x : k == 1 ? &m->v[i].y : &m->v[i].z;
        if (P->nrm[k] == j) /* -1 when the file has no normals */
            return k == 0 ? &m->n[i].x : k == 1 ? &m->n[i].y : &m->n[i].z;
    }
    return NULL;
}

static const char *ply_slot_name(const Ply *P, int j)
{
    return j == P->pos[0] || j == P->pos[1] || j == P->pos[2] ? "coordinate" : "normal component";
}

/* Checks that ASCII token t is a value of type `type`. */
static int ply_check_ascii(const LexReader *R, LexTok t, PlyType type)
{
    char q[LEX_QUOTE_LEN];
    long long v;
    if (ply_is_int(type))
        return lex_parse_int(t, &v) == 0 ? 0 : lex_fail(R, R->line, t.s, "malformed integer '%s'", lex_quote(t, q));
    return mesh_check_number(R, t);
}

static int ply_ascii(Ply *P)
{
    LexReader *R = P->R;
    long long nv = P->el[P->vertex].count; /* as announced: m.nv may be fewer (ply_alloc) */
    const char *s, *e, *q;
    char q1[LEX_QUOTE_LEN], q2[LEX_QUOTE_LEN];
    LexTok t;
    for (int ei = 0; ei < P->nel; ei++) {
        const PlyElem *E = &P->el[ei];
        if (E->nprops == 0)
            continue;
        for (long long i = 0; i < E->count; i++) {
            if (!lex_next_text_line(R, &s, &e, 0))
                return lex_fail_eof(R, "file ends after %lld of %s '%s' elements", i, lex_quote(E->count_text, q2),
                                    lex_quote(E->name, q1));
            q = s;
            for (int j = 0; j < E->nprops; j++) {
                const PlyProp *pr = &E->props[j];
                if (!lex_next_tok(&q, e, &t))
                    return lex_fail(R, R->line, NULL, "too few values for a '%s' element (no '%s')",
                                    lex_quote(E->name, q1), lex_quote(pr->name, q2));
                if (pr->count == PT_NONE) {
                    float *slot = ei == P->vertex ? ply_slot(P, j, i) : NULL;
                    if (slot && ply_is_int(pr->type) && ply_check_ascii(R, t, pr->type) != 0)
                        return -1;
                    if (slot ? mesh_read_coord(R, t, ply_slot_name(P, j), slot) : ply_check_ascii(R, t, pr->type))
                        return -1;
                    continue;
                }
                long long c;
                if (lex_parse_int(t, &c) != 0)
                    return lex_fail(R, R->line, t.s, "malformed list count '%s'", lex_quote(t, q1));
                if (c < 0)
                    return lex_fail(R, R->line, t.s, "negative list count %lld", c);
                int is_idx = ei == P->face && j == P->idx;
                if (is_idx && c < 3)
                    return lex_fail(R, R->line, t.s, "face with %lld corners (at least 3 needed)", c);
                int corner[3] = {0, 0, 0};
                for (long long k = 0; k < c; k++) {
                    if (!lex_next_tok(&q, e, &t)) {
                        if (is_idx)
                            return lex_fail(R, R->line, NULL, "face lists %lld of its %lld corners", k, c);
                        return lex_fail(R, R->line, NULL,
                                        "too few values for a '%s' element (list '%s' announces %lld)",
                                        lex_quote(E->name, q1), lex_quote(pr->name, q2), c);
                    }
                    if (!is_idx) {
                        if (ply_check_ascii(R, t, pr->type) != 0)
                            return -1;
                        continue;
                    }
                    long long idx;
                    if (lex_parse_int(t, &idx) != 0)
                        return lex_fail(R, R->line, t.s, "malformed vertex index '%s'", lex_quote(t, q1));
                    if (idx < 0 || idx >= nv)
                        return lex_fail(R, R->line, t.s, "vertex index %s out of range (%lld vertices)",
                                        lex_quote(t, q1), nv);
                    if (mesh_fan_corner(P->R, P->B, k, (int)idx, 0, corner, NULL) != 0)
                        return -1;
                }
            }
            if (lex_next_tok(&q, e, &t))
                return lex_fail(R, R->line, t.s, "too many values for a '%s' element", lex_quote(E->name, q1));
        }
    }
    if (lex_next_text_line(R, &s, &e, 0))
        return lex_fail(R, R->line, NULL, "extra data after the announced elements");
    return 0;
}

/* Value of a little-endian scalar of type t at b. */
static double ply_get(const unsigned char *b, PlyType t)
{
    uint32_t u;
    switch (t) {
    case PT_I8:
        return b[0] < 0x80 ? (double)b[0] : (double)b[0] - 0x100;
    case PT_U8:
        return b[0];
    case PT_I16:
        u = (uint32_t)b[0] | (uint32_t)b[1] << 8;
        return u < 0x8000 ? (double)u : (double)u - 0x10000;
    case PT_U16:
        return (uint32_t)b[0] | (uint32_t)b[1] << 8;
    case PT_I32:
    case PT_U32:
    case PT_F32:
        u = (uint32_t)b[0] | (uint32_t)b[1] << 8 | (uint32_t)b[2] << 16 | (uint32_t)b[3] << 24;
        if (t == PT_U32)
            return u;
        if (t == PT_I32)
            return u < 0x80000000u ? (double)u : (double)u - 4294967296.0;
        {
            float f;
            memcpy(&f, &u, sizeof f); /* integer and float byte orders agree */
            return f;
        }
    case PT_F64: {
        uint64_t w = 0;
        double d;
        for (int i = 7; i >= 0; i--)
            w = w << 8 | b[i];
        memcpy(&d, &w, sizeof d);
        return d;
    }
    case PT_NONE:
        break;
    }
    return 0;
}

static int ply_binary(Ply *P)
{
    LexReader *R = P->R;
    const unsigned char *base = (const unsigned char *)R->data;
    size_t off = (size_t)(R->p - R->data), len = (size_t)(R->end - R->data);
    int nv = P->B->m.nv;
    char q1[LEX_QUOTE_LEN];
    for (int ei = 0; ei < P->nel; ei++) {
        const PlyElem *E = &P->el[ei];
        int lists = 0;
        for (int j = 0; j < E->nprops; j++)
            lists += E->props[j].count != PT_NONE;
        if (E->nprops == 0)
            continue;
        if (!lists && ei != P->vertex) { /* fixed size and nothing to keep: skip it whole */
            size_t size = (size_t)ply_min_bytes(P, ei);
            if ((unsigned long long)E->count > (len - off) / size)
                return lex_fail_at(R, E->line, E->name.s, len, "file ends after %zu of %lld '%s' elements",
                                   (len - off) / size, E->count, lex_quote(E->name, q1));
            off += (size_t)E->count * size;
            continue;
        }
        for (long long i = 0; i < E->count; i++) {
            for (int j = 0; j < E->nprops; j++) {
                const PlyProp *pr = &E->props[j];
                size_t size = (size_t)ply_types[pr->type].size;
                if (pr->count == PT_NONE) {
                    if (len - off < size)
                        return lex_fail_at(R, E->line, E->name.s, len, "file ends after %lld of %lld '%s' elements", i,
                                           E->count, lex_quote(E->name, q1));
                    float *slot = ei == P->vertex ? ply_slot(P, j, i) : NULL;
                    if (slot) {
                        double d = ply_get(base + off, pr->type);
                        if (lex_to_float(d, slot) != 0)
                            return lex_fail_at(R, E->line, E->name.s, off, "non-finite %s %g in vertex %lld",
                                               ply_slot_name(P, j), d, i);
                    }
                    off += size;
                    continue;
                }
                size_t csize = (size_t)ply_types[pr->count].size;
                if (len - off < csize)
                    return lex_fail_at(R, E->line, E->name.s, len, "file ends after %lld of %lld '%s' elements", i,
                                       E->count, lex_quote(E->name, q1));
                long long c = (long long)ply_get(base + off, pr->count);
                if (c < 0)
                    return lex_fail_at(R, E->line, E->name.s, off, "negative list count %lld", c);
                int is_idx = ei == P->face && j == P->idx;
                if (is_idx && c < 3)
                    return lex_fail_at(R, E->line, E->name.s, off, "face with %lld corners (at least 3 needed)", c);
                off += csize;
                if ((unsigned long long)c > (len - off) / size)
                    return lex_fail_at(R, E->line, E->name.s, len, "file ends after %lld of %lld '%s' elements", i,
                                       E->count, lex_quote(E->name, q1));
                if (!is_idx) {
                    off += (size_t)c * size;
                    continue;
                }
                int corner[3] = {0, 0, 0};
                for (long long k = 0; k < c; k++, off += size) {
                    long long idx = (long long)ply_get(base + off, pr->type);
                    if (idx < 0 || idx >= nv)
                        return lex_fail_at(R, E->line, E->name.s, off, "vertex index %lld out of range (%d vertices)",
                                           idx, nv);
                    if (mesh_fan_corner(P->R, P->B, k, (int)idx, 0, corner, NULL) != 0)
                        return -1;
                }
            }
        }
    }
    if (off != len)
        return lex_fail_at(R, P->end_line, NULL, off, "%zu byte%s of extra data after the announced elements",
                           len - off, len - off == 1 ? "" : "s");
    return 0;
}

int mesh_read_ply(LexReader *R, MeshBuild *B)
{
    Ply P;
    memset(&P, 0, sizeof P);
    P.R = R;
    P.B = B;
    int rc = ply_header(&P);
    if (rc == 0)
        rc = ply_alloc(&P);
    if (rc == 0)
        rc = P.binary ? ply_binary(&P) : ply_ascii(&P);
    int normals = P.nrm[0] >= 0;
    ply_free(&P);
    return rc != 0 ? -1 : mesh_finish(R, B, normals);
}

