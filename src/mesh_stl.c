/*
 * mesh_stl.c - the STL reader, ASCII and binary (the formats read are in
 * mesh.h).
 *
 * STL stores every facet with three vertices of its own. Vertices with
 * exactly the same coordinates are welded into one (-0 and +0 alike), so
 * that a closed solid loads as a closed mesh and smooth shading finds the
 * triangles around each vertex. The facet normals are not read: they are
 * often zero or stale, and the winding already gives each facet's side.
 *
 * Binary STL: an 80-byte header, a little-endian uint32 triangle count n,
 * then n records of 50 bytes (a normal and three vertices as 12
 * little-endian float32, and a uint16 attribute), and nothing after. A
 * file is read as binary when its size is exactly 84 + 50 n; otherwise as
 * ASCII when its first word is "solid"; otherwise it is an error. (Binary
 * headers often begin with "solid" too, so the word alone decides nothing.)
 */
#include "mesh_read.h"

#include <limits.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#define STL_HEADER 84 /* the header and the count */
#define STL_RECORD 50

/* Welds vertices: an open-addressing table of indices into B->m.v, keyed
 * by the coordinates' bits. */
typedef struct {
    int *slot; /* -1: empty */
    size_t mask;
    uint64_t seed; /* this table's (lex_hash_seed) */
} Weld;

static int weld_init(const LexReader *R, Weld *W, size_t nmax)
{
    size_t n = 16;
    while (n < 2 * nmax)
        n *= 2;
    W->mask = n - 1;
    W->slot = mesh_array(NULL, 0, n, sizeof *W->slot);
    if (!W->slot)
        return lex_fail(R, 1, R->data, "out of memory for %zu vertices", nmax);
    memset(W->slot, 0xff, n * sizeof *W->slot);
    W->seed = lex_hash_seed();
    return 0;
}

static uint32_t bits(float x)
{
    uint32_t b;
    x = x == 0.0f ? 0.0f : x; /* -0 welds with +0 */
    memcpy(&b, &x, sizeof b);
    return b;
}

uint64_t mesh_weld_hash(Vec3 p, uint64_t seed)
{
    /* Whole numbers and halves, as CAD and voxel exports write, have
     * floats whose low mantissa bits are all 0: every bit must reach the
     * low ones the table takes, which lex_mix64 does. The seed is mixed
     * in before the first coordinate, so that no two points' hashes are
     * equal whatever the seed (a fixed mix of all three, which a file can
     * make equal, then a seed, would not separate them). */
    return lex_mix64(lex_mix64(lex_mix64(seed ^ bits(p.x)) ^ bits(p.y)) ^ bits(p.z));
}

/* The index of vertex p, a new one when no vertex has its coordinates. */
static int weld(Weld *W, Mesh *m, Vec3 p)
{
    uint32_t x = bits(p.x), y = bits(p.y), z = bits(p.z);
    for (size_t h = (size_t)mesh_weld_hash(p, W->seed) & W->mask;; h = (h + 1) & W->mask) {
        int i = W->slot[h];
        if (i < 0) {
            m->v[m->nv] = p;
            return W->slot[h] = m->nv++;
        }
        if (bits(m->v[i].x) == x && bits(m->v[i].y) == y && bits(m->v[i].z) == z)
            return i;
    }
}

/* Room for nmax vertices and ntri triangles, and the weld table. */
static int stl_alloc(const LexReader *R, MeshBuild *B, Weld *W, size_t nmax, size_t ntri)
{
    if (nmax == 0)
        return 0;
    if (nmax > INT_MAX)
        return lex_fail(R, 1, R->data, "more than %d vertices", INT_MAX);
    B->m.v = mesh_array(NULL, 0, nmax, sizeof *B->m.v);
    if (!B->m.v)
        return lex_fail(R, 1, R->data, "out of memory for %zu vertices", nmax);
    if (weld_init(R, W, nmax) != 0)
        return -1;
    return mesh_reserve_tris(R, 1, B, ntri);
}

/* Trims the vertex array to the welded count. */
static void stl_trim(MeshBuild *B)
{
    if (B->m.nv == 0) {
        MESH_FREE(B->m.v);
        B->m.v = NULL;
        return;
    }
    void *v = mesh_array(B->m.v, (size_t)B->m.nv, (size_t)B->m.nv, sizeof *B->m.v);
    if (v) /* failure only means the memory stays */
        B->m.v = v;
}

static uint32_t le32(const unsigned char *b)
{
    return (uint32_t)b[0] | (uint32_t)b[1] << 8 | (uint32_t)b[2] << 16 | (uint32_t)b[3] << 24;
}

static float lef32(const unsigned char *b)
{
    uint32_t u = le32(b);
    float f;
    memcpy(&f, &u, sizeof f);
    return f;
}

static int stl_binary(LexReader *R, MeshBuild *B, uint32_t n)
{
    const unsigned char *d = (const unsigned char *)R->data;
    Weld W = {NULL, 0, 0};
    if ((size_t)n * 3 > INT_MAX)
        return lex_fail(R, 1, R->data, "binary STL of %lu triangles: more than %d vertices", (unsigned long)n, INT_MAX);
    int rc = stl_alloc(R, B, &W, (size_t)n * 3, n);
    for (uint32_t i = 0; rc == 0 && i < n; i++) {
        size_t off = STL_HEADER + (size_t)i * STL_RECORD + 12; /* after the facet normal */
        int c[3];
        for (int k = 0; k < 3 && rc == 0; k++, off += 12) {
            float x[3];
            for (int j = 0; j < 3 && rc == 0; j++)
                if (!isfinite(x[j] = lef32(d + off + 4 * (size_t)j)))
                    rc = lex_fail_at(R, 1, R->data, off + 4 * (size_t)j, "non-finite coordinate in triangle %lu",
                                     (unsigned long)i);
            if (rc == 0)
                c[k] = weld(&W, &B->m, vec3(x[0], x[1], x[2]));
        }
        if (rc == 0)
            rc = mesh_push_tri(R, B, c, NULL);
    }
    MESH_FREE(W.slot);
    stl_trim(B);
    return rc;
}

/* ASCII STL's tokens, which may be split across lines any way. */
typedef struct {
    LexReader *R;
    const char *q, *e; /* the rest of the current line */
} Toks;

/* The next token, on whichever line it is (R->line is then its line). */
static int next(Toks *T, LexTok *t)
{
    while (!lex_next_tok(&T->q, T->e, t))
        if (!lex_next_line(T->R, &T->q, &T->e))
            return 0;
    return 1;
}

/* t is word, in any case (some writers shout). */
static int is(LexTok t, const char *word)
{
    size_t n = strlen(word);
    if (t.len != n)
        return 0;
    for (size_t i = 0; i < n; i++)
        if ((t.s[i] | 0x20) != word[i])
            return 0;
    return 1;
}

/* The next token, which must be word. */
static int expect(Toks *T, const char *word, const char *after)
{
    LexTok t;
    char q[LEX_QUOTE_LEN];
    if (!next(T, &t))
        return lex_fail_eof(T->R, "file ends where '%s' should follow %s", word, after);
    if (!is(t, word))
        return lex_fail(T->R, T->R->line, t.s, "expected '%s' after %s, got '%s'", word, after, lex_quote(t, q));
    return 0;
}

/* Three numbers after `what`: coordinates into p, or, without p, numbers
 * that are only checked (a facet normal). */
static int numbers(Toks *T, const char *what, Vec3 *p)
{
    float v[3];
    for (int k = 0; k < 3; k++) {
        LexTok t;
        if (!next(T, &t))
            return lex_fail_eof(T->R, "file ends inside '%s' (3 numbers)", what);
        if (p ? mesh_read_coord(T->R, t, "coordinate", &v[k]) : mesh_check_number(T->R, t))
            return -1;
    }
    if (p)
        *p = vec3(v[0], v[1], v[2]);
    return 0;
}

/* One facet, after its "facet" keyword: a polygon fanned into triangles. */
static int facet(Toks *T, MeshBuild *B, Weld *W)
{
    LexTok t;
    char q[LEX_QUOTE_LEN];
    if (expect(T, "normal", "'facet'") || numbers(T, "facet normal", NULL) || expect(T, "outer", "the facet normal") ||
        expect(T, "loop", "'outer'"))
        return -1;
    int c[3] = {0, 0, 0};
    long long k = 0;
    for (;;) {
        if (!next(T, &t))
            return lex_fail_eof(T->R, "file ends inside a facet's loop");
        if (is(t, "endloop"))
            break;
        if (!is(t, "vertex"))
            return lex_fail(T->R, T->R->line, t.s, "expected 'vertex' or 'endloop', got '%s'", lex_quote(t, q));
        Vec3 p;
        if (numbers(T, "vertex", &p) != 0 || mesh_fan_corner(T->R, B, k++, weld(W, &B->m, p), 0, c, NULL) != 0)
            return -1;
    }
    if (k < 3)
        return lex_fail(T->R, T->R->line, NULL, "facet with %lld vertices (at least 3 needed)", k);
    return expect(T, "endfacet", "'endloop'");
}

static int stl_ascii(LexReader *R, MeshBuild *B)
{
    /* pass 1: the vertices, at most (every one may be new) */
    const char *start = R->p;
    Toks T = {R, R->p, R->p};
    LexTok t;
    size_t nmax = 0;
    while (next(&T, &t))
        nmax += is(t, "vertex");
    Weld W = {NULL, 0, 0};
    int rc = stl_alloc(R, B, &W, nmax, nmax / 3);
    /* pass 2: one or more solids, each "solid [name] facet* endsolid [name]" */
    R->p = start;
    R->line = 0;
    T.q = T.e = start;
    char q[LEX_QUOTE_LEN];
    int solids = 0;
    while (rc == 0 && next(&T, &t)) {
        if (!is(t, "solid")) {
            rc = lex_fail(R, R->line, t.s,
                          solids ? "expected 'solid' or the end of the file, got '%s'"
                                 : "not an STL file: expected 'solid', got '%s'",
                          lex_quote(t, q));
            break;
        }
        solids++;
        T.q = T.e; /* the solid's name: the rest of its line */
        for (;;) {
            if (!next(&T, &t)) {
                rc = lex_fail_eof(R, "file ends before 'endsolid'");
                break;
            }
            if (is(t, "endsolid")) {
                T.q = T.e;
                break;
            }
            if (!is(t, "facet")) {
                rc = lex_fail(R, R->line, t.s, "expected 'facet' or 'endsolid', got '%s'", lex_quote(t, q));
                break;
            }
            if ((rc = facet(&T, B, &W)) != 0)
                break;
        }
    }
    if (rc == 0 && solids == 0)
        rc = lex_fail_eof(R, "empty file: no 'solid'");
    MESH_FREE(W.slot);
    stl_trim(B);
    return rc;
}

int mesh_read_stl(LexReader *R, MeshBuild *B)
{
    size_t len = (size_t)(R->end - R->data);
    uint32_t n = len >= STL_HEADER ? le32((const unsigned char *)R->data + 80) : 0;
    int rc;
    if (len >= STL_HEADER && (len - STL_HEADER) % STL_RECORD == 0 && (len - STL_HEADER) / STL_RECORD == n) {
        rc = stl_binary(R, B, n);
    } else {
        LexReader first = *R; /* the first word, on whichever line */
        Toks T = {&first, R->p, R->p};
        LexTok t;
        if (next(&T, &t) && is(t, "solid"))
            rc = stl_ascii(R, B);
        else if (len < STL_HEADER)
            rc = lex_fail(R, 1, R->data,
                          "not an STL file: %zu bytes, and no 'solid' for ASCII STL (binary STL takes at least "
                          "%d bytes)",
                          len, STL_HEADER);
        else
            rc = lex_fail(R, 1, R->data,
                          "binary STL announces %lu triangles, which take %llu bytes, but the file has %zu (and it "
                          "does not begin with 'solid' for ASCII STL)",
                          (unsigned long)n, (unsigned long long)STL_HEADER + (unsigned long long)n * STL_RECORD, len);
    }
    return rc != 0 ? -1 : mesh_finish(R, B, 0);
}
