/*
 * mesh.c - OFF, OBJ and PLY readers producing one triangle Mesh.
 *
 * The invariant every reader keeps: nothing is allocated from a number the
 * file announces until that number has been checked against what the bytes
 * that follow can hold. An OFF vertex line takes at least 6 bytes ("0 0 0\n"),
 * a face line 8 ("3 0 1 2\n"), an ASCII PLY value 2, a binary PLY instance the
 * sum of its scalar sizes; so a 100-byte file that announces 10^12 vertices
 * fails at once, and every array is O(file size). OBJ announces nothing: a
 * first pass counts the statements, a second fills arrays of exactly that size.
 * Triangles from polygons can still outnumber faces, so the triangle array
 * grows as it fills; its length is checked against INT_MAX.
 *
 * Input is read as a byte range [data, end) that need not end in a NUL, so
 * numbers are copied into a bounded buffer before strtof sees them, and no
 * routine looks past `end`. Text formats are read one line at a time (lines
 * end in "\n" or "\r\n"); a line is then split into blank-separated tokens.
 *
 * All errors go through fail(), which prefixes "name:line: ". Binary PLY data
 * has no lines: fail_at() uses the line of the header's "element" statement
 * for that data and appends " at byte offset N" (0-based, from the start of
 * the file, BOM included).
 *
 * After parsing, finish() drops triangles of zero area. The test is exact:
 * the cross product (b-a) x (c-a) equals a x b + b x c + c x a, and each
 * component of that is a sum of six products of two floats. A product of two
 * floats is exact in double (24 + 24 bits < 53, and its exponent is in range), and the six-term sum is
 * evaluated exactly as a floating-point expansion (Shewchuk, "Adaptive
 * precision floating-point arithmetic and fast robust geometric predicates",
 * 1997) whenever a cheap error bound cannot already show it nonzero.
 */
#include "lancer/mesh.h"

#include "lancer/afile.h"

#include <errno.h>
#include <float.h>
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Longest number token read; longer ones are an error rather than a heap
 * copy (round-trip output of a double, what writers print, is under 30). */
#define NUM_MAX 255
/* Room for a token quoted in a message: 40 bytes plus "...". */
#define QUOTE_LEN 48
/* First size of a triangle array grown from nothing; it doubles from there. */
#define TRI_CAP_MIN 256
/* Integers saturate here, so that "99999999999999999999" fails a range
 * check instead of wrapping around. */
#define INT_SAT 1000000000000000000LL

#if defined(__GNUC__)
#define MESH_PRINTF(f, a) __attribute__((format(printf, f, a)))
#else
#define MESH_PRINTF(f, a)
#endif

/* ---- the one allocation point ---- */

#ifndef MESH_REALLOC
#define MESH_REALLOC(p, size) realloc(p, size)
#define MESH_FREE(p) free(p)
#endif

/* Resizes p to n elements of `size` bytes. Returns NULL when out of memory
 * or when n * size overflows; p is then untouched. n must be > 0. */
static void *mesh_array(void *p, size_t n, size_t size)
{
    if (n == 0 || n > SIZE_MAX / size)
        return NULL;
    return MESH_REALLOC(p, n * size);
}

/* Room for item n of the array p, of *cap items so far: p, doubled from
 * `first` items when full, or NULL when out of memory (p untouched). */
static void *mesh_grow(void *p, int *cap, int n, int first, size_t size)
{
    if (n < *cap)
        return p;
    int c = *cap ? *cap * 2 : first;
    void *q = mesh_array(p, (size_t)c, size);
    if (q)
        *cap = c;
    return q;
}

/* ---- reading lines and tokens, reporting errors ---- */

typedef struct {
    const char *name;
    const char *data, *end; /* the whole input */
    const char *p;          /* start of the next line */
    long line;              /* number of the line last returned, 0 before the first */
    char *err;
    size_t errlen;
} Reader;

typedef struct {
    const char *s;
    size_t len;
} Tok;

MESH_PRINTF(3, 0) static int vfail(const Reader *R, long line, const char *fmt, va_list ap)
{
    if (R->errlen == 0)
        return -1;
    int n = snprintf(R->err, R->errlen, "%s:%ld: ", R->name, line);
    if (n >= 0 && (size_t)n < R->errlen)
        vsnprintf(R->err + n, R->errlen - (size_t)n, fmt, ap);
    return -1;
}

/* Writes "name:line: message" to the error buffer; returns -1. */
MESH_PRINTF(3, 4) static int fail(const Reader *R, long line, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vfail(R, line, fmt, ap);
    va_end(ap);
    return -1;
}

/* fail() for binary data: the message ends with " at byte offset N". */
MESH_PRINTF(4, 5) static int fail_at(const Reader *R, long line, size_t off, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vfail(R, line, fmt, ap);
    va_end(ap);
    if (R->errlen > 0) {
        size_t n = strlen(R->err);
        if (n + 1 < R->errlen)
            snprintf(R->err + n, R->errlen - n, " at byte offset %zu", off);
    }
    return -1;
}

/* The line an "unexpected end of file" is reported on: the last one. */
static long eof_line(const Reader *R) { return R->line > 0 ? R->line : 1; }

/* Next line as [*ls, *le), without "\n" or "\r\n". Returns 0 at the end. */
static int next_line(Reader *R, const char **ls, const char **le)
{
    if (R->p >= R->end)
        return 0;
    const char *s = R->p;
    const char *nl = memchr(s, '\n', (size_t)(R->end - s));
    const char *e = nl ? nl : R->end;
    R->p = nl ? nl + 1 : R->end;
    R->line++;
    if (e > s && e[-1] == '\r')
        e--;
    *ls = s;
    *le = e;
    return 1;
}

static int is_blank(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; }

/* Next blank-separated token of [*q, e); advances *q. Returns 0 when none is left. */
static int next_tok(const char **q, const char *e, Tok *t)
{
    const char *p = *q;
    while (p < e && is_blank(*p))
        p++;
    if (p >= e) {
        *q = p;
        return 0;
    }
    t->s = p;
    while (p < e && !is_blank(*p))
        p++;
    t->len = (size_t)(p - t->s);
    *q = p;
    return 1;
}

/* Number of tokens in [s, e); the first `max` are stored in tk. */
static int split(const char *s, const char *e, Tok *tk, int max)
{
    int n = 0;
    Tok t;
    while (next_tok(&s, e, &t)) {
        if (n < max)
            tk[n] = t;
        if (n < INT_MAX)
            n++;
    }
    return n;
}

/* Next line that holds a token. With `comments`, '#' cuts the rest of a
 * line first (OFF and OBJ; the PLY body has no comments). */
static int next_text_line(Reader *R, const char **ls, const char **le, int comments)
{
    const char *s, *e;
    while (next_line(R, &s, &e)) {
        if (comments) {
            const char *h = memchr(s, '#', (size_t)(e - s));
            if (h)
                e = h;
        }
        const char *q = s;
        Tok t;
        if (next_tok(&q, e, &t)) {
            *ls = s;
            *le = e;
            return 1;
        }
    }
    return 0;
}

static int tok_same(Tok a, Tok b) { return a.len == b.len && memcmp(a.s, b.s, a.len) == 0; }

static int tok_is(Tok t, const char *word) { return tok_same(t, (Tok){word, strlen(word)}); }

/* t for a message: at most 40 bytes, bytes other than printable ASCII as '?'. */
static const char *quote(Tok t, char buf[QUOTE_LEN])
{
    size_t n = t.len > 40 ? 40 : t.len, i;
    for (i = 0; i < n; i++) {
        unsigned char c = (unsigned char)t.s[i];
        buf[i] = c >= 0x20 && c < 0x7f ? (char)c : '?';
    }
    if (n < t.len)
        memcpy(buf + i, "...", 3), i += 3;
    buf[i] = '\0';
    return buf;
}

/* ---- numbers ---- */

static int is_digit(char c) { return c >= '0' && c <= '9'; }

/* 1 when all of t is [+-] digits [. digits] [(e|E) [+-] digits] with a digit
 * before the exponent: what C's printf writes, without hex or nan. */
static int is_decimal(Tok t)
{
    size_t i = 0, digits = 0;
    if (i < t.len && (t.s[i] == '+' || t.s[i] == '-'))
        i++;
    while (i < t.len && is_digit(t.s[i]))
        i++, digits++;
    if (i < t.len && t.s[i] == '.') {
        i++;
        while (i < t.len && is_digit(t.s[i]))
            i++, digits++;
    }
    if (digits == 0)
        return 0;
    if (i < t.len && (t.s[i] == 'e' || t.s[i] == 'E')) {
        size_t ed = 0;
        i++;
        if (i < t.len && (t.s[i] == '+' || t.s[i] == '-'))
            i++;
        while (i < t.len && is_digit(t.s[i]))
            i++, ed++;
        if (ed == 0)
            return 0;
    }
    return i == t.len;
}

/* 1 for nan, inf, infinity with an optional sign, in any case: how C
 * libraries print non-finite values, so worth a message of their own. */
static int is_nonfinite_word(Tok t)
{
    static const char *const words[] = {"nan", "inf", "infinity"};
    size_t i = t.len > 0 && (t.s[0] == '+' || t.s[0] == '-');
    for (size_t w = 0; w < 3; w++) {
        size_t n = strlen(words[w]), k;
        if (t.len - i != n)
            continue;
        for (k = 0; k < n; k++)
            if ((t.s[i + k] | 0x20) != words[w][k])
                break;
        if (k == n)
            return 1;
    }
    return 0;
}

/* Parses [+-]digits. Returns 0, or -1 when t is not an integer. Saturates at
 * +-INT_SAT. */
static int parse_int(Tok t, long long *out)
{
    size_t i = 0;
    int neg = 0;
    long long v = 0;
    if (i < t.len && (t.s[i] == '+' || t.s[i] == '-'))
        neg = t.s[i++] == '-';
    if (i == t.len)
        return -1;
    for (; i < t.len; i++) {
        if (!is_digit(t.s[i]))
            return -1;
        v = v > INT_SAT / 10 ? INT_SAT : v * 10 + (t.s[i] - '0');
    }
    if (v > INT_SAT)
        v = INT_SAT;
    *out = neg ? -v : v;
    return 0;
}

/* double -> float as IEEE rounding would do it, without the undefined
 * behaviour C gives an out-of-range conversion. Returns 0, or -1 when the
 * result is not finite. */
static int to_float(double d, float *f)
{
    /* Values below FLT_MAX + half an ulp round to FLT_MAX; the halfway point
     * rounds to even, which is infinity (FLT_MAX's significand is odd). */
    const double lim = (double)FLT_MAX + 0x1p103;
    if (isnan(d) || fabs(d) >= lim)
        return -1;
    *f = fabs(d) > FLT_MAX ? (d > 0 ? FLT_MAX : -FLT_MAX) : (float)d;
    return 0;
}

enum { NUM_OK = 0, NUM_MALFORMED = -1, NUM_NONFINITE = -2, NUM_LONG = -3 };

/* The float nearest to decimal token t. Returns a NUM_ code. */
static int parse_float(Tok t, float *out)
{
    if (!is_decimal(t))
        return is_nonfinite_word(t) ? NUM_NONFINITE : NUM_MALFORMED;
    if (t.len > NUM_MAX)
        return NUM_LONG;
    char buf[NUM_MAX + 1], *end;
    memcpy(buf, t.s, t.len);
    buf[t.len] = '\0';
    float f = strtof(buf, &end);
    if (end != buf + t.len) /* a locale whose decimal point is not '.' */
        return NUM_MALFORMED;
    if (!isfinite(f))
        return NUM_NONFINITE;
    *out = f;
    return NUM_OK;
}

/* Reads a coordinate (what = "coordinate") or a normal component. */
static int read_coord(const Reader *R, Tok t, const char *what, float *out)
{
    char q[QUOTE_LEN];
    switch (parse_float(t, out)) {
    case NUM_OK:
        return 0;
    case NUM_NONFINITE:
        return fail(R, R->line, "non-finite %s '%s'", what, quote(t, q));
    case NUM_LONG:
        return fail(R, R->line, "number longer than %d characters '%s'", NUM_MAX, quote(t, q));
    default:
        return fail(R, R->line, "malformed number '%s'", quote(t, q));
    }
}

/* Checks that t is a number (an ignored colour, w, or PLY property). */
static int check_number(const Reader *R, Tok t)
{
    char q[QUOTE_LEN];
    if (is_decimal(t) || is_nonfinite_word(t))
        return 0;
    return fail(R, R->line, "malformed number '%s'", quote(t, q));
}

/* ---- building the mesh ---- */

typedef struct {
    Mesh m;
    size_t cap_t; /* room in m.tri, and in m.ntri when track_n */
    int track_n;  /* every triangle also gets a row in m.ntri */
} Build;

/* Makes room for n triangles in all. Returns 0 or -1 (out of memory). */
static int reserve_tris(const Reader *R, long line, Build *B, size_t n)
{
    if (n <= B->cap_t)
        return 0;
    void *t = mesh_array(B->m.tri, n, sizeof *B->m.tri);
    if (!t)
        return fail(R, line, "out of memory for %zu triangles", n);
    B->m.tri = t;
    if (B->track_n) {
        t = mesh_array(B->m.ntri, n, sizeof *B->m.ntri);
        if (!t)
            return fail(R, line, "out of memory for %zu triangles", n);
        B->m.ntri = t;
    }
    B->cap_t = n;
    return 0;
}

/* Appends triangle c (and its normal indices nc when track_n). */
static int push_tri(const Reader *R, Build *B, const int c[3], const int nc[3])
{
    if ((size_t)B->m.nt == B->cap_t) {
        if (B->m.nt == INT_MAX)
            return fail(R, R->line, "more than %d triangles", INT_MAX);
        size_t cap = B->cap_t < TRI_CAP_MIN ? TRI_CAP_MIN : B->cap_t * 2;
        if (cap > INT_MAX)
            cap = INT_MAX;
        if (reserve_tris(R, R->line, B, cap) != 0)
            return -1;
    }
    memcpy(B->m.tri[B->m.nt], c, sizeof B->m.tri[0]);
    if (B->track_n)
        memcpy(B->m.ntri[B->m.nt], nc, sizeof B->m.ntri[0]);
    B->m.nt++;
    return 0;
}

/* Corner j of a polygon fanned into triangles from its first corner:
 * vertex v (and normal n, when nc is given) into c (nc); from the third
 * corner on, each closes a triangle. */
static int fan_corner(const Reader *R, Build *B, long long j, int v, int n, int c[3], int nc[3])
{
    int at = j < 2 ? (int)j : 2;
    c[at] = v;
    if (nc)
        nc[at] = n;
    if (j < 2)
        return 0;
    if (push_tri(R, B, c, nc) != 0)
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

static int tri_degenerate(const Vec3 *v, const int c[3])
{
    return c[0] == c[1] || c[1] == c[2] || c[0] == c[2] || collinear(v[c[0]], v[c[1]], v[c[2]]);
}

static void drop_normals(Mesh *m)
{
    MESH_FREE(m->n);
    MESH_FREE(m->ntri);
    m->n = NULL;
    m->ntri = NULL;
    m->nn = 0;
}

/* Drops degenerate triangles, trims the arrays, and with vertex_normals
 * (NOFF, PLY nx ny nz) gives ntri its copy of tri. A mesh without
 * triangles keeps no normals. */
static int finish(const Reader *R, Build *B, int vertex_normals)
{
    Mesh *m = &B->m;
    int k = 0;
    for (int i = 0; i < m->nt; i++) {
        if (tri_degenerate(m->v, m->tri[i])) {
            m->degenerate++;
            continue;
        }
        if (k != i) {
            memcpy(m->tri[k], m->tri[i], sizeof m->tri[0]);
            if (m->ntri)
                memcpy(m->ntri[k], m->ntri[i], sizeof m->ntri[0]);
        }
        k++;
    }
    m->nt = k;
    if (k == 0) {
        MESH_FREE(m->tri);
        m->tri = NULL;
        drop_normals(m);
        return 0;
    }
    if ((size_t)k < B->cap_t) { /* shrinking: failure only means the memory stays */
        void *t = mesh_array(m->tri, (size_t)k, sizeof *m->tri);
        if (t)
            m->tri = t;
        if (m->ntri && (t = mesh_array(m->ntri, (size_t)k, sizeof *m->ntri)) != NULL)
            m->ntri = t;
    }
    if (vertex_normals && m->n) {
        m->ntri = mesh_array(NULL, (size_t)k, sizeof *m->ntri);
        if (!m->ntri)
            return fail(R, eof_line(R), "out of memory for %d triangles", k);
        memcpy(m->ntri, m->tri, (size_t)k * sizeof *m->tri);
    }
    return 0;
}

/* Allocates m->v (and m->n with normals) for nv vertices, nv <= INT_MAX. */
static int alloc_vertices(const Reader *R, long line, Build *B, long long nv, int normals)
{
    B->m.nv = (int)nv;
    if (nv == 0)
        return 0;
    B->m.v = mesh_array(NULL, (size_t)nv, sizeof *B->m.v);
    if (!B->m.v)
        return fail(R, line, "out of memory for %lld vertices", nv);
    if (normals) {
        B->m.n = mesh_array(NULL, (size_t)nv, sizeof *B->m.n);
        if (!B->m.n)
            return fail(R, line, "out of memory for %lld normals", nv);
        B->m.nn = (int)nv;
    }
    return 0;
}

/* ---- OFF ---- */

/* Reads the header keyword t: [C][N]OFF (either order). */
static int off_header(const Reader *R, Tok t, int *normals, int *colour)
{
    char q[QUOTE_LEN];
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
        return fail(R, R->line, "unsupported OFF variant '%s' (OFF, COFF, NOFF and CNOFF are read)", quote(t, q));
    }
    return fail(R, R->line, "expected an OFF header or the counts line, got '%s'", quote(t, q));
}

static int parse_off(Reader *R, Build *B)
{
    Mesh *m = &B->m;
    const char *s, *e, *q;
    char qb[QUOTE_LEN];
    Tok t, tk[11];
    int normals = 0, colour = 0;

    if (!next_text_line(R, &s, &e, 1))
        return fail(R, eof_line(R), "empty file: no OFF header or counts line");
    long long unused;
    q = s;
    next_tok(&q, e, &t);
    if (parse_int(t, &unused) != 0) { /* not the counts: a header */
        if (off_header(R, t, &normals, &colour) != 0)
            return -1;
        const char *q2 = q;
        if (next_tok(&q2, e, &t)) {
            if (tok_is(t, "BINARY"))
                return fail(R, R->line, "binary OFF is not supported");
            s = q; /* the counts follow the keyword on its line */
        } else if (!next_text_line(R, &s, &e, 1)) {
            return fail(R, eof_line(R), "file ends before the counts line");
        }
    }

    /* counts: nv nf ne */
    long long cnt[3];
    int nc = split(s, e, tk, 3);
    if (nc != 3)
        return fail(R, R->line, "counts line has %d values, expected 3 (vertices faces edges)", nc);
    for (int i = 0; i < 3; i++) {
        if (parse_int(tk[i], &cnt[i]) != 0)
            return fail(R, R->line, "malformed count '%s'", quote(tk[i], qb));
        if (cnt[i] < 0)
            return fail(R, R->line, "negative count '%s'", quote(tk[i], qb));
    }
    long long nv = cnt[0], nf = cnt[1];
    long cline = R->line;
    size_t rem = (size_t)(R->end - R->p);
    unsigned long long room = (unsigned long long)rem + 1; /* the last line needs no '\n' */
    int nvals = 3 + 3 * normals;                           /* values a vertex needs */
    unsigned long long vmin = 2 * (unsigned long long)nvals, fmin = 8;
    char qb2[QUOTE_LEN]; /* counts are quoted as written: they may have saturated */
    if ((unsigned long long)nv > room / vmin)
        return fail(R, cline, "%s vertices announced, more than the %zu bytes after the counts line can hold",
                    quote(tk[0], qb), rem);
    room -= (unsigned long long)nv * vmin;
    if ((unsigned long long)nf > room / fmin)
        return fail(R, cline,
                    "%s vertices and %s faces announced, more than the %zu bytes after the counts line can hold",
                    quote(tk[0], qb), quote(tk[1], qb2), rem);
    if (nv > INT_MAX)
        return fail(R, cline, "%lld vertices announced, more than %d", nv, INT_MAX);
    if (alloc_vertices(R, cline, B, nv, normals) != 0)
        return -1;
    if (nf > 0 && reserve_tris(R, cline, B, (size_t)(nf < INT_MAX ? nf : INT_MAX)) != 0)
        return -1;

    static const char *const expect[2][2] = {{"3", "6 (position, normal)"},
                                             {"6 or 7 (position, colour)", "9 or 10 (position, normal, colour)"}};
    for (int i = 0; i < nv; i++) {
        if (!next_text_line(R, &s, &e, 1))
            return fail(R, eof_line(R), "file ends after %d of %lld vertices", i, nv);
        int n = split(s, e, tk, 11);
        if (colour ? n != nvals + 3 && n != nvals + 4 : n != nvals) {
            int ints = n > nvals; /* more values, all integers: looks like a face */
            for (int j = 0; j < n && j < 11; j++)
                ints &= parse_int(tk[j], &unused) == 0;
            return fail(R, R->line, "vertex line has %d values, expected %s%s", n, expect[colour][normals],
                        ints ? " (a face line: fewer vertices than announced?)" : "");
        }
        if (read_coord(R, tk[0], "coordinate", &m->v[i].x) != 0 ||
            read_coord(R, tk[1], "coordinate", &m->v[i].y) != 0 ||
            read_coord(R, tk[2], "coordinate", &m->v[i].z) != 0)
            return -1;
        if (normals && (read_coord(R, tk[3], "normal component", &m->n[i].x) != 0 ||
                        read_coord(R, tk[4], "normal component", &m->n[i].y) != 0 ||
                        read_coord(R, tk[5], "normal component", &m->n[i].z) != 0))
            return -1;
        for (int j = nvals; j < n; j++)
            if (check_number(R, tk[j]) != 0)
                return -1;
    }

    for (long long f = 0; f < nf; f++) {
        if (!next_text_line(R, &s, &e, 1))
            return fail(R, eof_line(R), "file ends after %lld of %lld faces", f, nf);
        long long k, idx;
        q = s;
        next_tok(&q, e, &t);
        if (parse_int(t, &k) != 0)
            return fail(R, R->line, "malformed corner count '%s'%s", quote(t, qb),
                        is_decimal(t) ? " (a vertex line: more vertices than announced?)" : "");
        if (k < 3)
            return fail(R, R->line, "face with %lld corners (at least 3 needed)", k);
        int c[3] = {0, 0, 0};
        for (long long j = 0; j < k; j++) {
            if (!next_tok(&q, e, &t))
                return fail(R, R->line, "face lists %lld of its %lld corners", j, k);
            if (parse_int(t, &idx) != 0)
                return fail(R, R->line, "malformed vertex index '%s'", quote(t, qb));
            if (idx < 0 || idx >= nv)
                return fail(R, R->line, "vertex index %lld out of range (%lld vertices)", idx, nv);
            if (fan_corner(R, B, j, (int)idx, 0, c, NULL) != 0)
                return -1;
        }
        int extra = 0;
        while (next_tok(&q, e, &t)) {
            if (check_number(R, t) != 0)
                return -1;
            extra++;
        }
        if (extra > 4)
            return fail(R, R->line, "face has %d values after its %lld corners, at most 4 (a colour) allowed", extra,
                        k);
    }
    if (next_text_line(R, &s, &e, 1))
        return fail(R, R->line, "extra data after the %lld face%s announced", nf, nf == 1 ? "" : "s");
    return finish(R, B, normals);
}

/* ---- OBJ ---- */

typedef struct {
    const char *what, *plural; /* "vertex", "vertices" */
    long long so_far, total;
} ObjIndexKind;

/* Resolves OBJ index text t (1-based or negative) to a 0-based index. */
static int obj_index(const Reader *R, Tok t, const ObjIndexKind *k, int *out)
{
    char q[QUOTE_LEN];
    long long i;
    if (parse_int(t, &i) != 0)
        return fail(R, R->line, "malformed %s index '%s'", k->what, quote(t, q));
    if (i == 0)
        return fail(R, R->line, "%s index 0 is invalid (OBJ indices start at 1)", k->what);
    if (i > 0) {
        if (i > k->total)
            return fail(R, R->line, "%s index %lld out of range (%lld %s)", k->what, i, k->total, k->plural);
        *out = (int)(i - 1);
    } else {
        if (-i > k->so_far)
            return fail(R, R->line, "relative %s index %lld out of range (%lld %s defined so far)", k->what, i,
                        k->so_far, k->plural);
        *out = (int)(k->so_far + i);
    }
    return 0;
}

/* Reads corner t: v, v/vt, v//vn or v/vt/vn. *ni is -1 without a normal. */
static int obj_corner(const Reader *R, Tok t, const ObjIndexKind kinds[3], int *vi, int *ni)
{
    char q[QUOTE_LEN];
    Tok part[3];
    int np = 0;
    size_t start = 0;
    *ni = -1;
    for (size_t i = 0; i <= t.len; i++) {
        if (i == t.len || t.s[i] == '/') {
            if (np == 3)
                return fail(R, R->line, "malformed face corner '%s'", quote(t, q));
            part[np].s = t.s + start;
            part[np].len = i - start;
            np++;
            start = i + 1;
        }
    }
    /* the vertex is always there; v/ and v/vt/ and v// are not corners */
    if (part[0].len == 0 || (np >= 2 && part[np - 1].len == 0))
        return fail(R, R->line, "malformed face corner '%s'", quote(t, q));
    int unused;
    if (obj_index(R, part[0], &kinds[0], vi) != 0)
        return -1;
    if (np >= 2 && part[1].len > 0 && obj_index(R, part[1], &kinds[1], &unused) != 0)
        return -1;
    if (np == 3 && obj_index(R, part[2], &kinds[2], ni) != 0)
        return -1;
    return 0;
}

static int parse_obj(Reader *R, Build *B)
{
    Mesh *m = &B->m;
    const char *s, *e, *q, *start = R->p;
    char qb[QUOTE_LEN];
    Tok t, tk[8];
    long long nv = 0, nn = 0, nvt = 0, ntris = 0;

    /* pass 1: how many of each */
    while (next_text_line(R, &s, &e, 1)) {
        q = s;
        next_tok(&q, e, &t);
        if (tok_is(t, "v")) {
            if (++nv > INT_MAX)
                return fail(R, R->line, "more than %d vertices", INT_MAX);
        } else if (tok_is(t, "vn")) {
            if (++nn > INT_MAX)
                return fail(R, R->line, "more than %d normals", INT_MAX);
        } else if (tok_is(t, "vt")) {
            nvt++;
        } else if (tok_is(t, "f")) {
            int k = split(q, e, tk, 0);
            if (k > 2 && (ntris += k - 2) > INT_MAX)
                return fail(R, R->line, "more than %d triangles", INT_MAX);
        }
    }
    if (alloc_vertices(R, 1, B, nv, 0) != 0)
        return -1;
    if (nn > 0) {
        m->n = mesh_array(NULL, (size_t)nn, sizeof *m->n);
        if (!m->n)
            return fail(R, 1, "out of memory for %lld normals", nn);
        m->nn = (int)nn;
        B->track_n = 1;
    }
    if (ntris > 0 && reserve_tris(R, 1, B, (size_t)ntris) != 0)
        return -1;

    /* pass 2: read them */
    R->p = start;
    R->line = 0;
    ObjIndexKind kinds[3] = {{"vertex", "vertices", 0, nv},
                             {"texture coordinate", "texture coordinates", 0, nvt},
                             {"normal", "normals", 0, nn}};
    long long faces_without_normals = 0;
    while (next_text_line(R, &s, &e, 1)) {
        q = s;
        next_tok(&q, e, &t);
        if (tok_is(t, "v")) {
            int n = split(q, e, tk, 7);
            if (n != 3 && n != 4 && n != 6)
                return fail(R, R->line, "'v' takes 3 or 4 numbers (or 6 with a colour), got %d", n);
            Vec3 *p = &m->v[kinds[0].so_far++];
            if (read_coord(R, tk[0], "coordinate", &p->x) != 0 || read_coord(R, tk[1], "coordinate", &p->y) != 0 ||
                read_coord(R, tk[2], "coordinate", &p->z) != 0)
                return -1;
            for (int j = 3; j < n; j++)
                if (check_number(R, tk[j]) != 0)
                    return -1;
        } else if (tok_is(t, "vn")) {
            int n = split(q, e, tk, 3);
            if (n != 3)
                return fail(R, R->line, "'vn' takes 3 numbers, got %d", n);
            Vec3 *p = &m->n[kinds[2].so_far++];
            if (read_coord(R, tk[0], "normal component", &p->x) != 0 ||
                read_coord(R, tk[1], "normal component", &p->y) != 0 ||
                read_coord(R, tk[2], "normal component", &p->z) != 0)
                return -1;
        } else if (tok_is(t, "vt")) {
            kinds[1].so_far++;
        } else if (tok_is(t, "f")) {
            int c[3] = {0, 0, 0}, nc[3] = {0, 0, 0}, k = 0, with_n = 0;
            while (next_tok(&q, e, &t)) {
                int vi = 0, ni = -1;
                if (obj_corner(R, t, kinds, &vi, &ni) != 0)
                    return -1;
                if (k == 0)
                    with_n = ni >= 0;
                else if (with_n != (ni >= 0))
                    return fail(R, R->line, "face mixes corners with and without normals");
                if (fan_corner(R, B, k, vi, ni < 0 ? 0 : ni, c, nc) != 0)
                    return -1;
                k++;
            }
            if (k < 3)
                return fail(R, R->line, "face with %d corners (at least 3 needed)", k);
            faces_without_normals += !with_n;
        } else if (!((t.s[0] >= 'a' && t.s[0] <= 'z') || (t.s[0] >= 'A' && t.s[0] <= 'Z'))) {
            return fail(R, R->line, "unknown statement '%s'", quote(t, qb));
        } /* any other statement: ignored */
    }
    if (faces_without_normals > 0) /* (no triangles at all: finish drops them) */
        drop_normals(m);
    return finish(R, B, 0);
}

/* ---- PLY ---- */

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
    Tok name;
    PlyType type;  /* a scalar's type, or a list's item type */
    PlyType count; /* a list's count type; PT_NONE for a scalar */
} PlyProp;

typedef struct {
    Tok name;
    long long count;
    Tok count_text; /* as written, for messages: count may have saturated */
    long line;      /* of its "element" statement */
    PlyProp *props;
    int nprops, cap;
} PlyElem;

typedef struct {
    Reader *R;
    Build *B;
    int binary;
    PlyElem *el;
    int nel, cap;
    long end_line;      /* of "end_header" */
    int vertex, face;   /* indices into el, or -1 */
    int pos[3], nrm[3]; /* vertex properties x y z and nx ny nz, or -1 */
    int idx;            /* face property vertex_indices, or -1 */
} Ply;

static PlyType ply_type(Tok t)
{
    for (int i = PT_I8; i <= PT_F64; i++)
        if (tok_is(t, ply_types[i].name) || tok_is(t, ply_types[i].sized))
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
        if (tok_is(E->props[i].name, name))
            return i;
    return -1;
}

/* Reads one "element" or "property" statement of n tokens tk. */
static int ply_declare(Ply *P, const Tok *tk, int n)
{
    Reader *R = P->R;
    char q[QUOTE_LEN], q2[QUOTE_LEN];
    if (tok_is(tk[0], "element")) {
        long long count;
        if (n != 3)
            return fail(R, R->line, "'element' takes a name and a count, got %d values", n - 1);
        if (parse_int(tk[2], &count) != 0 || count < 0)
            return fail(R, R->line, "malformed element count '%s'", quote(tk[2], q));
        for (int i = 0; i < P->nel; i++)
            if (tok_same(P->el[i].name, tk[1]))
                return fail(R, R->line, "second '%s' element", quote(tk[1], q));
        void *p = mesh_grow(P->el, &P->cap, P->nel, 4, sizeof *P->el);
        if (!p)
            return fail(R, R->line, "out of memory");
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
        return fail(R, R->line, "'property' before any 'element'");
    PlyElem *E = &P->el[P->nel - 1];
    PlyProp pr;
    if (n >= 2 && tok_is(tk[1], "list")) {
        if (n != 5)
            return fail(R, R->line, "'property list' takes a count type, an item type and a name");
        pr.count = ply_type(tk[2]);
        pr.type = ply_type(tk[3]);
        pr.name = tk[4];
        if (pr.count == PT_NONE)
            return fail(R, R->line, "unknown property type '%s'", quote(tk[2], q));
        if (pr.type == PT_NONE)
            return fail(R, R->line, "unknown property type '%s'", quote(tk[3], q));
        if (!ply_is_int(pr.count))
            return fail(R, R->line, "list count type must be an integer type, not '%s'", quote(tk[2], q));
    } else {
        if (n != 3)
            return fail(R, R->line, "'property' takes a type and a name");
        pr.count = PT_NONE;
        pr.type = ply_type(tk[1]);
        pr.name = tk[2];
        if (pr.type == PT_NONE)
            return fail(R, R->line, "unknown property type '%s'", quote(tk[1], q));
    }
    for (int i = 0; i < E->nprops; i++)
        if (tok_same(E->props[i].name, pr.name))
            return fail(R, R->line, "second property '%s' in element '%s'", quote(pr.name, q), quote(E->name, q2));
    void *p = mesh_grow(E->props, &E->cap, E->nprops, 8, sizeof *E->props);
    if (!p)
        return fail(R, R->line, "out of memory");
    E->props = p;
    E->props[E->nprops++] = pr;
    return 0;
}

/* Reads the header up to end_header and works out where x y z ... are. */
static int ply_header(Ply *P)
{
    Reader *R = P->R;
    const char *s, *e;
    char q[QUOTE_LEN];
    Tok tk[6];
    int have_format = 0;
    if (!next_line(R, &s, &e) || e - s != 3 || memcmp(s, "ply", 3) != 0)
        return fail(R, 1, "not a PLY file (the first line must be 'ply')");
    for (;;) {
        if (!next_line(R, &s, &e))
            return fail(R, eof_line(R), "header has no 'end_header' line");
        int n = split(s, e, tk, 6);
        if (n == 0)
            continue;
        if (tok_is(tk[0], "comment") || tok_is(tk[0], "obj_info"))
            continue;
        if (tok_is(tk[0], "end_header")) {
            if (n != 1)
                return fail(R, R->line, "unexpected text after 'end_header'");
            break;
        }
        if (tok_is(tk[0], "format")) {
            if (have_format)
                return fail(R, R->line, "second 'format' line");
            if (n != 3)
                return fail(R, R->line, "'format' takes a format and a version, got %d values", n - 1);
            if (tok_is(tk[1], "binary_big_endian"))
                return fail(R, R->line, "binary_big_endian PLY is not supported (ascii and binary_little_endian are)");
            if (tok_is(tk[1], "binary_little_endian"))
                P->binary = 1;
            else if (!tok_is(tk[1], "ascii"))
                return fail(R, R->line, "unknown PLY format '%s'", quote(tk[1], q));
            if (!tok_is(tk[2], "1.0"))
                return fail(R, R->line, "unsupported PLY version '%s' (1.0 is read)", quote(tk[2], q));
            have_format = 1;
            continue;
        }
        if (tok_is(tk[0], "element") || tok_is(tk[0], "property")) {
            if (ply_declare(P, tk, n) != 0)
                return -1;
            continue;
        }
        return fail(R, R->line, "unknown header keyword '%s'", quote(tk[0], q));
    }
    P->end_line = R->line;
    if (!have_format)
        return fail(R, R->line, "the header has no 'format' line");

    /* the elements that make the mesh */
    static const char *const pos[3] = {"x", "y", "z"}, *const nrm[3] = {"nx", "ny", "nz"};
    P->vertex = P->face = P->idx = -1;
    for (int i = 0; i < P->nel; i++) {
        if (tok_is(P->el[i].name, "vertex"))
            P->vertex = i;
        else if (tok_is(P->el[i].name, "face"))
            P->face = i;
    }
    if (P->vertex < 0)
        return fail(R, P->end_line, "no 'vertex' element");
    PlyElem *V = &P->el[P->vertex];
    int nnrm = 0;
    for (int k = 0; k < 3; k++) {
        P->pos[k] = ply_find(V, pos[k]);
        P->nrm[k] = ply_find(V, nrm[k]);
        if (P->pos[k] < 0)
            return fail(R, V->line, "'vertex' element has no property '%s'", pos[k]);
        if (V->props[P->pos[k]].count != PT_NONE)
            return fail(R, V->line, "vertex property '%s' is a list, not a number", pos[k]);
        if (P->nrm[k] >= 0) {
            nnrm++;
            if (V->props[P->nrm[k]].count != PT_NONE)
                return fail(R, V->line, "vertex property '%s' is a list, not a number", nrm[k]);
        }
    }
    if (nnrm != 0 && nnrm != 3)
        return fail(R, V->line, "'vertex' element has some of nx, ny, nz but not all three");
    if (P->face >= 0) {
        PlyElem *F = &P->el[P->face];
        P->idx = ply_find(F, "vertex_indices");
        if (P->idx < 0)
            P->idx = ply_find(F, "vertex_index");
        if (P->idx < 0)
            return fail(R, F->line, "'face' element has no 'vertex_indices' list");
        if (F->props[P->idx].count == PT_NONE)
            return fail(R, F->line, "face property '%s' is a number, not a list", quote(F->props[P->idx].name, q));
        if (!ply_is_int(F->props[P->idx].type))
            return fail(R, F->line, "face property '%s' must have an integer item type",
                        quote(F->props[P->idx].name, q));
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

/* Checks every count against the bytes after the header, then allocates. */
static int ply_alloc(Ply *P)
{
    Reader *R = P->R;
    char q[QUOTE_LEN], q2[QUOTE_LEN];
    size_t rem = (size_t)(R->end - R->p);
    unsigned long long room = (unsigned long long)rem + !P->binary; /* a text file's last '\n' is optional */
    for (int i = 0; i < P->nel; i++) {
        unsigned long long min = ply_min_bytes(P, i);
        const PlyElem *E = &P->el[i];
        if (min == 0) /* no properties: an instance is nothing to read */
            continue;
        if ((unsigned long long)E->count > room / min)
            return fail(R, E->line, "%s '%s' elements announced, more than the %zu bytes after the header can hold",
                        quote(E->count_text, q2), quote(E->name, q), rem);
        room -= (unsigned long long)E->count * min;
    }
    const PlyElem *V = &P->el[P->vertex];
    if (V->count > INT_MAX)
        return fail(R, V->line, "%lld vertices announced, more than %d", V->count, INT_MAX);
    if (alloc_vertices(R, V->line, P->B, V->count, P->nrm[0] >= 0) != 0)
        return -1;
    if (P->face >= 0 && P->el[P->face].count > 0) {
        long long nf = P->el[P->face].count;
        if (reserve_tris(R, P->el[P->face].line, P->B, (size_t)(nf < INT_MAX ? nf : INT_MAX)) != 0)
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
static int ply_check_ascii(const Reader *R, Tok t, PlyType type)
{
    char q[QUOTE_LEN];
    long long v;
    if (ply_is_int(type))
        return parse_int(t, &v) == 0 ? 0 : fail(R, R->line, "malformed integer '%s'", quote(t, q));
    return check_number(R, t);
}

static int ply_ascii(Ply *P)
{
    Reader *R = P->R;
    int nv = P->B->m.nv;
    const char *s, *e, *q;
    char q1[QUOTE_LEN], q2[QUOTE_LEN];
    Tok t;
    for (int ei = 0; ei < P->nel; ei++) {
        const PlyElem *E = &P->el[ei];
        if (E->nprops == 0)
            continue;
        for (long long i = 0; i < E->count; i++) {
            if (!next_text_line(R, &s, &e, 0))
                return fail(R, eof_line(R), "file ends after %lld of %lld '%s' elements", i, E->count,
                            quote(E->name, q1));
            q = s;
            for (int j = 0; j < E->nprops; j++) {
                const PlyProp *pr = &E->props[j];
                if (!next_tok(&q, e, &t))
                    return fail(R, R->line, "too few values for a '%s' element (no '%s')", quote(E->name, q1),
                                quote(pr->name, q2));
                if (pr->count == PT_NONE) {
                    float *slot = ei == P->vertex ? ply_slot(P, j, i) : NULL;
                    if (slot && ply_is_int(pr->type) && ply_check_ascii(R, t, pr->type) != 0)
                        return -1;
                    if (slot ? read_coord(R, t, ply_slot_name(P, j), slot) : ply_check_ascii(R, t, pr->type))
                        return -1;
                    continue;
                }
                long long c;
                if (parse_int(t, &c) != 0)
                    return fail(R, R->line, "malformed list count '%s'", quote(t, q1));
                if (c < 0)
                    return fail(R, R->line, "negative list count %lld", c);
                int is_idx = ei == P->face && j == P->idx;
                if (is_idx && c < 3)
                    return fail(R, R->line, "face with %lld corners (at least 3 needed)", c);
                int corner[3] = {0, 0, 0};
                for (long long k = 0; k < c; k++) {
                    if (!next_tok(&q, e, &t)) {
                        if (is_idx)
                            return fail(R, R->line, "face lists %lld of its %lld corners", k, c);
                        return fail(R, R->line, "too few values for a '%s' element (list '%s' announces %lld)",
                                    quote(E->name, q1), quote(pr->name, q2), c);
                    }
                    if (!is_idx) {
                        if (ply_check_ascii(R, t, pr->type) != 0)
                            return -1;
                        continue;
                    }
                    long long idx;
                    if (parse_int(t, &idx) != 0)
                        return fail(R, R->line, "malformed vertex index '%s'", quote(t, q1));
                    if (idx < 0 || idx >= nv)
                        return fail(R, R->line, "vertex index %lld out of range (%d vertices)", idx, nv);
                    if (fan_corner(P->R, P->B, k, (int)idx, 0, corner, NULL) != 0)
                        return -1;
                }
            }
            if (next_tok(&q, e, &t))
                return fail(R, R->line, "too many values for a '%s' element", quote(E->name, q1));
        }
    }
    if (next_text_line(R, &s, &e, 0))
        return fail(R, R->line, "extra data after the announced elements");
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
    Reader *R = P->R;
    const unsigned char *base = (const unsigned char *)R->data;
    size_t off = (size_t)(R->p - R->data), len = (size_t)(R->end - R->data);
    int nv = P->B->m.nv;
    char q1[QUOTE_LEN];
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
                return fail_at(R, E->line, len, "file ends after %zu of %lld '%s' elements", (len - off) / size,
                               E->count, quote(E->name, q1));
            off += (size_t)E->count * size;
            continue;
        }
        for (long long i = 0; i < E->count; i++) {
            for (int j = 0; j < E->nprops; j++) {
                const PlyProp *pr = &E->props[j];
                size_t size = (size_t)ply_types[pr->type].size;
                if (pr->count == PT_NONE) {
                    if (len - off < size)
                        return fail_at(R, E->line, len, "file ends after %lld of %lld '%s' elements", i, E->count,
                                       quote(E->name, q1));
                    float *slot = ei == P->vertex ? ply_slot(P, j, i) : NULL;
                    if (slot) {
                        double d = ply_get(base + off, pr->type);
                        if (to_float(d, slot) != 0)
                            return fail_at(R, E->line, off, "non-finite %s %g in vertex %lld", ply_slot_name(P, j), d,
                                           i);
                    }
                    off += size;
                    continue;
                }
                size_t csize = (size_t)ply_types[pr->count].size;
                if (len - off < csize)
                    return fail_at(R, E->line, len, "file ends after %lld of %lld '%s' elements", i, E->count,
                                   quote(E->name, q1));
                long long c = (long long)ply_get(base + off, pr->count);
                if (c < 0)
                    return fail_at(R, E->line, off, "negative list count %lld", c);
                int is_idx = ei == P->face && j == P->idx;
                if (is_idx && c < 3)
                    return fail_at(R, E->line, off, "face with %lld corners (at least 3 needed)", c);
                off += csize;
                if ((unsigned long long)c > (len - off) / size)
                    return fail_at(R, E->line, len, "file ends after %lld of %lld '%s' elements", i, E->count,
                                   quote(E->name, q1));
                if (!is_idx) {
                    off += (size_t)c * size;
                    continue;
                }
                int corner[3] = {0, 0, 0};
                for (long long k = 0; k < c; k++, off += size) {
                    long long idx = (long long)ply_get(base + off, pr->type);
                    if (idx < 0 || idx >= nv)
                        return fail_at(R, E->line, off, "vertex index %lld out of range (%d vertices)", idx, nv);
                    if (fan_corner(P->R, P->B, k, (int)idx, 0, corner, NULL) != 0)
                        return -1;
                }
            }
        }
    }
    if (off != len)
        return fail_at(R, P->end_line, off, "%zu byte%s of extra data after the announced elements", len - off,
                       len - off == 1 ? "" : "s");
    return 0;
}

static int parse_ply(Reader *R, Build *B)
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
    return rc != 0 ? -1 : finish(R, B, normals);
}

/* ---- public ---- */

int mesh_parse(const char *name, const char *data, size_t len, MeshFormat fmt, Mesh *m, char *err, size_t errlen)
{
    Reader R;
    Build B;
    memset(m, 0, sizeof *m);
    memset(&B, 0, sizeof B);
    if (errlen > 0)
        err[0] = '\0';
    if (!data)
        data = "", len = 0;
    R.name = name;
    R.data = data;
    R.end = data + len;
    R.p = data;
    R.line = 0;
    R.err = err;
    R.errlen = errlen;
    if (len >= 3 && memcmp(data, "\xef\xbb\xbf", 3) == 0) /* a UTF-8 byte-order mark */
        R.p += 3;
    int rc;
    switch (fmt) {
    case MESH_OFF:
        rc = parse_off(&R, &B);
        break;
    case MESH_OBJ:
        rc = parse_obj(&R, &B);
        break;
    case MESH_PLY:
        rc = parse_ply(&R, &B);
        break;
    default:
        rc = fail(&R, 1, "unknown mesh format %d", (int)fmt);
        break;
    }
    if (rc != 0) {
        mesh_free(&B.m);
        return -1;
    }
    *m = B.m;
    return 0;
}

int mesh_format_from_path(const char *path, MeshFormat *fmt)
{
    static const struct {
        const char *ext;
        MeshFormat fmt;
    } exts[] = {{"off", MESH_OFF}, {"obj", MESH_OBJ}, {"ply", MESH_PLY}};
    const char *dot = strrchr(path, '.');
    if (!dot || strchr(dot, '/') || strlen(dot + 1) != 3)
        return -1;
    for (size_t i = 0; i < sizeof exts / sizeof exts[0]; i++) {
        size_t k;
        for (k = 0; k < 3; k++)
            if ((dot[1 + k] | 0x20) != exts[i].ext[k])
                break;
        if (k == 3) {
            *fmt = exts[i].fmt;
            return 0;
        }
    }
    return -1;
}

int mesh_load(const char *path, Mesh *m, char *err, size_t errlen)
{
    MeshFormat fmt;
    char *buf;
    size_t len;
    memset(m, 0, sizeof *m);
    if (mesh_format_from_path(path, &fmt) != 0) {
        snprintf(err, errlen, "%s: unknown mesh format (the name must end in .off, .obj or .ply)", path);
        return -1;
    }
    if (afile_read(path, MESH_MAX_BYTES, "meshes", &buf, &len, err, errlen) != 0)
        return -1;
    int rc = mesh_parse(path, buf, len, fmt, m, err, errlen);
    free(buf);
    return rc;
}

void mesh_free(Mesh *m)
{
    MESH_FREE(m->v);
    MESH_FREE(m->n);
    MESH_FREE(m->tri);
    MESH_FREE(m->ntri);
    memset(m, 0, sizeof *m);
}

static void d3_sub(double r[3], Vec3 a, Vec3 b)
{
    r[0] = (double)a.x - b.x;
    r[1] = (double)a.y - b.y;
    r[2] = (double)a.z - b.z;
}

static void d3_cross(double r[3], const double u[3], const double w[3])
{
    r[0] = u[1] * w[2] - u[2] * w[1];
    r[1] = u[2] * w[0] - u[0] * w[2];
    r[2] = u[0] * w[1] - u[1] * w[0];
}

static double d3_dot(const double u[3], const double w[3]) { return u[0] * w[0] + u[1] * w[1] + u[2] * w[2]; }

/* The angle between u and w, well conditioned near 0 and pi. */
static double d3_angle(const double u[3], const double w[3])
{
    double c[3];
    d3_cross(c, u, w);
    return atan2(sqrt(d3_dot(c, c)), d3_dot(u, w));
}

/* Unit normal of triangle i into fn. Returns 0, or -1 when it has no
 * direction in double (a sliver whose cross product rounds to zero). */
static int face_normal(const Mesh *m, int i, double fn[3], double e[3][3])
{
    const int *c = m->tri[i];
    d3_sub(e[0], m->v[c[1]], m->v[c[0]]); /* c0 -> c1 */
    d3_sub(e[1], m->v[c[2]], m->v[c[1]]); /* c1 -> c2 */
    d3_sub(e[2], m->v[c[0]], m->v[c[2]]); /* c2 -> c0 */
    d3_cross(fn, e[0], e[1]);
    double len = sqrt(d3_dot(fn, fn));
    if (!(len > 0) || !isfinite(len))
        return -1;
    for (int k = 0; k < 3; k++)
        fn[k] /= len;
    return 0;
}

int mesh_vertex_normals(Mesh *m, char *err, size_t errlen)
{
    if (m->nt == 0 || m->nv == 0) {
        drop_normals(m);
        return 0;
    }
    size_t nv = (size_t)m->nv, nt = (size_t)m->nt;
    double *acc = mesh_array(NULL, nv, 3 * sizeof *acc);
    unsigned char *state = mesh_array(NULL, nv, 1); /* 0 unused, 1 used, 2 waiting for a fallback */
    Vec3 *n = mesh_array(NULL, nv, sizeof *n);
    int(*ntri)[3] = mesh_array(NULL, nt, sizeof *ntri);
    if (!acc || !state || !n || !ntri) {
        MESH_FREE(acc), MESH_FREE(state), MESH_FREE(n), MESH_FREE(ntri);
        snprintf(err, errlen, "out of memory for the normals of %d vertices", m->nv);
        return -1;
    }
    memset(acc, 0, nv * 3 * sizeof *acc);
    memset(state, 0, nv);
    for (size_t i = 0; i < nt; i++) {
        double fn[3], e[3][3];
        for (int k = 0; k < 3; k++)
            state[m->tri[i][k]] = 1;
        if (face_normal(m, (int)i, fn, e) != 0)
            continue;
        for (int k = 0; k < 3; k++) {
            /* corner k lies between edge k (leaving it) and edge k-1 (arriving) */
            double in[3], *out = e[k], *prev = e[(k + 2) % 3];
            for (int a = 0; a < 3; a++)
                in[a] = -prev[a];
            double w = d3_angle(out, in);
            double *s = acc + 3 * (size_t)m->tri[i][k];
            for (int a = 0; a < 3; a++)
                s[a] += w * fn[a];
        }
    }
    int waiting = 0;
    for (size_t v = 0; v < nv; v++) {
        double *s = acc + 3 * v, len = sqrt(d3_dot(s, s));
        if (len > 0 && isfinite(len)) {
            n[v] = vec3((float)(s[0] / len), (float)(s[1] / len), (float)(s[2] / len));
        } else {
            n[v] = vec3(0, 0, 0);
            if (state[v] == 1)
                state[v] = 2, waiting++;
        }
    }
    for (size_t i = 0; i < nt && waiting > 0; i++) { /* sums that cancelled: the first triangle's normal */
        double fn[3], e[3][3];
        if (face_normal(m, (int)i, fn, e) != 0)
            continue;
        for (int k = 0; k < 3; k++) {
            int v = m->tri[i][k];
            if (state[v] == 2) {
                n[v] = vec3((float)fn[0], (float)fn[1], (float)fn[2]);
                state[v] = 1, waiting--;
            }
        }
    }
    memcpy(ntri, m->tri, nt * sizeof *ntri);
    MESH_FREE(acc);
    MESH_FREE(state);
    drop_normals(m);
    m->n = n;
    m->nn = m->nv;
    m->ntri = ntri;
    return 0;
}

int mesh_validate(const Mesh *m, char *err, size_t errlen)
{
#define BAD(...) return snprintf(err, errlen, __VA_ARGS__), -1
    if (m->nv < 0 || m->nn < 0 || m->nt < 0 || m->degenerate < 0)
        BAD("negative count");
    if ((m->nv > 0) != (m->v != NULL))
        BAD("nv is %d but v is %s", m->nv, m->v ? "set" : "NULL");
    if ((m->nt > 0) != (m->tri != NULL))
        BAD("nt is %d but tri is %s", m->nt, m->tri ? "set" : "NULL");
    if ((m->n != NULL) != (m->ntri != NULL) || (m->n != NULL) != (m->nn > 0))
        BAD("normals half present (n %s, nn %d, ntri %s)", m->n ? "set" : "NULL", m->nn, m->ntri ? "set" : "NULL");
    if (m->ntri && m->nt == 0)
        BAD("normals without triangles");
    for (int i = 0; i < m->nv; i++)
        if (!vec_is_finite(m->v[i]))
            BAD("vertex %d is not finite", i);
    for (int i = 0; i < m->nn; i++)
        if (!vec_is_finite(m->n[i]))
            BAD("normal %d is not finite", i);
    for (int i = 0; i < m->nt; i++) {
        for (int k = 0; k < 3; k++) {
            if (m->tri[i][k] < 0 || m->tri[i][k] >= m->nv)
                BAD("triangle %d: vertex index %d out of range (%d vertices)", i, m->tri[i][k], m->nv);
            if (m->ntri && (m->ntri[i][k] < 0 || m->ntri[i][k] >= m->nn))
                BAD("triangle %d: normal index %d out of range (%d normals)", i, m->ntri[i][k], m->nn);
        }
        if (tri_degenerate(m->v, m->tri[i]))
            BAD("triangle %d has zero area", i);
    }
#undef BAD
    return 0;
}
