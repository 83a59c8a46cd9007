/*
 * mesh_build.c - what the mesh readers share (mesh_read.h): the one
 * allocation point, the numbers they read, the triangle array, and the
 * drop of degenerate triangles that ends every read.
 *
 * The invariant every reader keeps: nothing is allocated from a number the
 * file announces until that number has been checked against what the bytes
 * that follow can hold (each reader says what a record takes at least), so
 * a 100-byte file that announces 10^12 vertices fails at once, and every
 * array is O(file size). Triangles from polygons can still outnumber faces,
 * so the triangle array grows as it fills; its length is checked against
 * INT_MAX.
 *
 * mesh_finish() drops triangles of zero area, but for the collinear ones
 * of distinct corners, which it keeps after the others (mesh.h). The test
 * is exact: the cross product (b-a) x (c-a) equals a x b + b x c + c x a,
 * and each component of that is a sum of six products of two floats. A
 * product of two floats is exact in double (24 + 24 bits < 53, and its
 * exponent is in range), and the six-term sum is evaluated exactly as a
 * floating-point expansion (Shewchuk, "Adaptive precision floating-point
 * arithmetic and fast robust geometric predicates", 1997) whenever a cheap
 * error bound cannot already show it nonzero.
 */
#include "mesh_read.h"

#include <limits.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

/* First size of a triangle array grown from nothing; it doubles from there. */
#define TRI_CAP_MIN 256

/* ---- the one allocation point ---- */

void *mesh_array(void *p, size_t used, size_t n, size_t size)
{
    if (n == 0 || n > SIZE_MAX / size || used > n)
        return NULL;
    return MESH_REALLOC(p, used * size, n * size);
}

void *mesh_grow(void *p, int *cap, int n, int first, size_t size)
{
    if (n < *cap)
        return p;
    int c = *cap ? *cap * 2 : first;
    void *q = mesh_array(p, (size_t)n, (size_t)c, size);
    if (q)
        *cap = c;
    return q;
}

/* ---- numbers ---- */

int mesh_read_coord(const LexReader *R, LexTok t, const char *what, float *out)
{
    char q[LEX_QUOTE_LEN];
    switch (lex_parse_float(t, out)) {
    case LEX_NUM_OK:
        return 0;
    case LEX_NUM_NONFINITE:
        return lex_fail(R, R->line, t.s, "non-finite %s '%s'", what, lex_quote(t, q));
    case LEX_NUM_LONG:
        return lex_fail(R, R->line, t.s, "number longer than %d characters '%s'", LIMIT_NUMBER_CHARS, lex_quote(t, q));
    default:
        return lex_fail(R, R->line, t.s, "malformed number '%s'", lex_quote(t, q));
    }
}

int mesh_check_number(const LexReader *R, LexTok t)
{
    char q[LEX_QUOTE_LEN];
    if (lex_is_decimal(t) || lex_is_nonfinite_word(t))
        return 0;
    return lex_fail(R, R->line, t.s, "malformed number '%s'", lex_quote(t, q));
}

/* ---- building the mesh ---- */

int mesh_reserve_tris(const LexReader *R, long line, MeshBuild *B, size_t n)
{
    if (n <= B->cap_t)
        return 0;
    void *t = mesh_array(B->m.tri, (size_t)B->m.nt, n, sizeof *B->m.tri);
    if (!t)
        return lex_fail(R, line, NULL, "out of memory for %zu triangles", n);
    B->m.tri = t;
    if (B->track_n) {
        t = mesh_array(B->m.ntri, (size_t)B->m.nt, n, sizeof *B->m.ntri);
        if (!t)
            return lex_fail(R, line, NULL, "out of memory for %zu triangles", n);
        B->m.ntri = t;
    }
    B->cap_t = n;
    return 0;
}

int mesh_push_tri(const LexReader *R, MeshBuild *B, const int c[3], const int nc[3])
{
    if ((size_t)B->m.nt == B->cap_t) {
        if (B->m.nt == INT_MAX)
            return lex_fail(R, R->line, NULL, "more than %d triangles", INT_MAX);
        size_t cap = B->cap_t < TRI_CAP_MIN ? TRI_CAP_MIN : B->cap_t * 2;
        if (cap > INT_MAX)
            cap = INT_MAX;
        if (mesh_reserve_tris(R, R->line, B, cap) != 0)
            return -1;
    }
    memcpy(B->m.tri[B->m.nt], c, sizeof B->m.tri[0]);
    if (B->track_n)
        memcpy(B->m.ntri[B->m.nt], nc, sizeof B->m.ntri[0]);
    B->m.nt++;
    return 0;
}

int mesh_fan_corner(const LexReader *R, MeshBuild *B, long long j, int v, int n, int c[3], int nc[3])
{
    int at = j < 2 ? (int)j : 2;
    c[at] = v;
    if (nc)
        nc[at] = n;
    if (j < 2)
        return 0;
    if (mesh_push_tri(R, B, c, nc) != 0)
        return -1;
    c[1] = c[2];
    if (nc)
        nc[1] = nc[2];
    return 0;
}

/* Two-sum (Knuth): a + b == *s + *e exactly, |*e| <= ulp(*s) / 2. */
static void two_sum(double a, double b, double *s, double *e)
{
    double x = a + b;
    double bv = x - a;
    double av = x - bv;
    *e = (a - av) + (b - bv);
    *s = x;
}

/* 1 when t[0] + ... + t[5] is exactly zero. The terms are folded into a
 * nonoverlapping expansion (Shewchuk's Grow-Expansion), whose sum is zero
 * exactly when every component is. */
static int sum6_is_zero(const double t[6])
{
    double e[6];
    int m = 0;
    for (int i = 0; i < 6; i++) {
        double q = t[i];
        for (int j = 0; j < m; j++)
            two_sum(q, e[j], &q, &e[j]);
        e[m++] = q;
    }
    for (int j = 0; j < m; j++)
        if (e[j] != 0)
            return 0;
    return 1;
}

/* 1 when a, b, c are collinear (or repeated), decided exactly. */
static int collinear(Vec3 a, Vec3 b, Vec3 c)
{
    const float A[3] = {a.x, a.y, a.z}, B[3] = {b.x, b.y, b.z}, C[3] = {c.x, c.y, c.z};
    for (int k = 0; k < 3; k++) {
        int i = (k + 1) % 3, j = (k + 2) % 3; /* (u x w)_k = u_i w_j - u_j w_i */
        const double t[6] = {
            (double)A[i] * B[j], -((double)A[j] * B[i]), (double)B[i] * C[j],
            -((double)B[j] * C[i]), (double)C[i] * A[j], -((double)C[j] * A[i]),
        };
        /* Summing 6 terms in order errs by at most 5u * sum|t| (u = 2^-53). */
        double s = 0, mag = 0;
        for (int q = 0; q < 6; q++)
            s += t[q], mag += fabs(t[q]);
        if (fabs(s) > mag * 1e-15)
            return 0;
        if (!sum6_is_zero(t))
            return 0;
    }
    return 1;
}

int mesh_tri_degenerate(const Vec3 *v, const int c[3])
{
    return c[0] == c[1] || c[1] == c[2] || c[0] == c[2] || collinear(v[c[0]], v[c[1]], v[c[2]]);
}

/* A degenerate triangle (mesh_tri_degenerate) that mesh_finish keeps:
 * three distinct corners, not all at one point (so collinear). */
static int line_corners(const Vec3 *v, const int c[3])
{
    const Vec3 a = v[c[0]], b = v[c[1]], d = v[c[2]];
    const int one_point = a.x == b.x && a.y == b.y && a.z == b.z && a.x == d.x && a.y == d.y && a.z == d.z;
    return c[0] != c[1] && c[1] != c[2] && c[0] != c[2] && !one_point;
}

int mesh_tri_line(const Vec3 *v, const int c[3]) { return line_corners(v, c) && mesh_tri_degenerate(v, c); }

void mesh_drop_normals(Mesh *m)
{
    MESH_FREE(m->n);
    MESH_FREE(m->ntri);
    m->n = NULL;
    m->ntri = NULL;
    m->nn = 0;
}

int mesh_finish(const LexReader *R, MeshBuild *B, int vertex_normals)
{
    Mesh *m = &B->m;
    /* The triangles with area first, in the file's order, then the
     * collinear ones of distinct corners (mesh.h), set aside meanwhile. */
    int(*line)[3] = NULL, (*line_n)[3] = NULL, cap = 0, cap_n = 0, nline = 0, k = 0;
    for (int i = 0; i < m->nt; i++) {
        if (mesh_tri_degenerate(m->v, m->tri[i])) {
            if (!line_corners(m->v, m->tri[i])) {
                m->degenerate++;
                continue;
            }
            int(*g)[3] = mesh_grow(line, &cap, nline, 16, sizeof *line);
            int(*gn)[3] = g && m->ntri ? mesh_grow(line_n, &cap_n, nline, 16, sizeof *line_n) : line_n;
            line = g ? g : line;
            line_n = gn ? gn : line_n;
            if (!g || (m->ntri && !gn)) {
                MESH_FREE(line);
                MESH_FREE(line_n);
                return lex_fail_eof(R, "out of memory for %d triangles", nline + 1);
            }
            memcpy(line[nline], m->tri[i], sizeof line[0]);
            if (m->ntri)
                memcpy(line_n[nline], m->ntri[i], sizeof line_n[0]);
            nline++;
            continue;
        }
        if (k != i) {
            memcpy(m->tri[k], m->tri[i], sizeof m->tri[0]);
            if (m->ntri)
                memcpy(m->ntri[k], m->ntri[i], sizeof m->ntri[0]);
        }
        k++;
    }
    if (k == 0) { /* no triangle with area: none at all (mesh.h) */
        m->degenerate += nline;
        nline = 0;
    }
    if (nline) { /* (into the room the dropped and set-aside ones left) */
        memcpy(m->tri + k, line, (size_t)nline * sizeof *line);
        if (m->ntri)
            memcpy(m->ntri + k, line_n, (size_t)nline * sizeof *line_n);
    }
    MESH_FREE(line);
    MESH_FREE(line_n);
    m->nt = k;
    m->nline = nline;
    if (k == 0) {
        MESH_FREE(m->tri);
        m->tri = NULL;
        mesh_drop_normals(m);
        return 0;
    }
    const int all = k + nline;
    if ((size_t)all < B->cap_t) { /* shrinking: failure only means the memory stays */
        void *t = mesh_array(m->tri, (size_t)all, (size_t)all, sizeof *m->tri);
        if (t)
            m->tri = t;
        if (m->ntri && (t = mesh_array(m->ntri, (size_t)all, (size_t)all, sizeof *m->ntri)) != NULL)
            m->ntri = t;
    }
    if (vertex_normals && m->n) {
        m->ntri = mesh_array(NULL, 0, (size_t)all, sizeof *m->ntri);
        if (!m->ntri)
            return lex_fail_eof(R, "out of memory for %d triangles", all);
        memcpy(m->ntri, m->tri, (size_t)all * sizeof *m->tri);
    }
    return 0;
}

long long mesh_text_cap(long long count, size_t rem, unsigned long long min)
{
    unsigned long long cap = ((unsigned long long)rem + 1) / min + 1;
    return (unsigned long long)count < cap ? count : (long long)cap;
}

int mesh_alloc_vertices(const LexReader *R, long line, MeshBuild *B, long long nv, int normals)
{
    B->m.nv = (int)nv;
    if (nv == 0)
        return 0;
    B->m.v = mesh_array(NULL, 0, (size_t)nv, sizeof *B->m.v);
    if (!B->m.v)
        return lex_fail(R, line, NULL, "out of memory for %lld vertices", nv);
    if (normals) {
        B->m.n = mesh_array(NULL, 0, (size_t)nv, sizeof *B->m.n);
        if (!B->m.n)
            return lex_fail(R, line, NULL, "out of memory for %lld normals", nv);
        B->m.nn = (int)nv;
    }
    return 0;
}
