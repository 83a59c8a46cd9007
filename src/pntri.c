/*
 * pntri.c - PN triangles (see pntri.h for the control net's order and the
 * patch's contract).
 *
 * Exact mode follows Dammertz and Keller, "Improving Ray Tracing Precision
 * by Object Space Intersection Computation", IEEE RT 2006: the parametric
 * domain is split, each sub-patch bounded by the box of its control points,
 * and only the sub-patches whose box the ray enters are split further,
 * nearest first, until their boxes reach float precision. The nets are
 * split in double by de Casteljau steps (Farin, "Curves and Surfaces for
 * CAGD", the blossom of a triangular patch), each a chain of at most three
 * averages, so a child's points carry its parent's error plus gamma(3) of
 * the parent's largest coordinate (Higham, "Accuracy and Stability of
 * Numerical Algorithms", lemma 3.1); the box grows by that bound and holds
 * the exact sub-patch. A piece stops being split when it is flat to float
 * precision (its net within a float spacing of its corners' triangle, a
 * distance that falls four times a level where the box's side halves), or
 * when its box is that small.
 */
#include "lancer/pntri.h"

#include <float.h>
#include <math.h>
#include <stddef.h>
#include <string.h>

#include "dvec.h"
#include "rounding.h"

/* Inline where the hit loop uses it, though other callers share it. */
#ifdef __GNUC__
#define PN_INLINE static inline __attribute__((always_inline))
#else
#define PN_INLINE static inline
#endif

/* The split's averages and the evaluation's de Casteljau steps four
 * doubles at a time with AVX, when the processor has it (picked at run
 * time: the rest of the file is built for the baseline); the same
 * operations lane by lane as the loops. */
#if defined(__GNUC__) && defined(__x86_64__) && !defined(LANCER_NO_SIMD)
#define PN_AVX 1
#include <immintrin.h>

#include "ray_lanes.h"
#endif

/* Splits, at most: a domain side of 2^-PN_MAX_DEPTH is far below what a
 * float (u, v) resolves, and the stack of pn_hit stays small. */
#define PN_MAX_DEPTH 40
/* Splits for one ray, at most. A patch whose rounding bound outgrows a
 * side (a needle 10^15 times longer than wide) has boxes that no split
 * separates from the ray, and they would double each level; past this
 * budget the pieces left become leaves, their boxes' intervals the hits. */
#define PN_MAX_SPLITS 16384
/* PN_FAST: Newton's steps. Newton's method takes over at the top, the
 * patch or a piece split ahead of rays: from there it converges for most
 * rays, and a deeper start only costs splits (docs/performance.md). */
#define PN_NEWTON_STEPS 8
/* Newton's hits whose ray meets the surface at an angle's cosine below
 * this are handed to subdivision (see newton). */
#define PN_NEWTON_GRAZING 0.25

/* ---- the patch ---- */

static void to_d(Vec3 a, double o[3])
{
    o[0] = a.x;
    o[1] = a.y;
    o[2] = a.z;
}

/* The inner control point of edge (pi, pj) next to pi: a third of the way,
 * projected into pi's tangent plane. Only this function computes edge
 * points, from exactly these inputs, so both patches of an edge get the
 * same bits. */
static void edge_point(const double pi[3], const double pj[3], const double ni[3], double out[3])
{
    double d[3] = {pj[0] - pi[0], pj[1] - pi[1], pj[2] - pi[2]};
    double w = d3_dot(d, ni);
    for (int a = 0; a < 3; a++)
        out[a] = (2.0 * pi[a] + pj[a] - w * ni[a]) / 3.0;
}

static Vec3 normalized_or(double x, double y, double z, Vec3 fallback)
{
    double len = sqrt(x * x + y * y + z * z);
    if (!(len > 0.0) || !isfinite(len))
        return fallback;
    return vec3((float)(x / len), (float)(y / len), (float)(z / len));
}

/* n_ij of the normal field: Ni + Nj mirrored in the plane normal to the
 * edge (v_ij = 2 (Pj - Pi).(Ni + Nj) / |Pj - Pi|^2). */
static Vec3 edge_normal(const double pi[3], const double pj[3], Vec3 ni, Vec3 nj)
{
    double d[3] = {pj[0] - pi[0], pj[1] - pi[1], pj[2] - pi[2]};
    double s[3] = {(double)ni.x + nj.x, (double)ni.y + nj.y, (double)ni.z + nj.z};
    double dd = d3_dot(d, d);
    double v = dd > 0.0 ? 2.0 * d3_dot(d, s) / dd : 0.0;
    Vec3 sum = normalized_or(s[0], s[1], s[2], ni);
    return normalized_or(s[0] - v * d[0], s[1] - v * d[1], s[2] - v * d[2], sum);
}

int pn_mode_named(const char *name)
{
    return strcmp(name, "exact") == 0 ? PN_EXACT : strcmp(name, "fast") == 0 ? PN_FAST : -1;
}

void pn_patch_init(PnPatch *pn, const Vec3 p[3], const Vec3 n[3])
{
    double P[3][3], N[3][3], e[6][3];
    for (int i = 0; i < 3; i++) {
        to_d(p[i], P[i]);
        to_d(n[i], N[i]);
    }
    /* e: b210, b120, b021, b012, b102, b201 */
    edge_point(P[0], P[1], N[0], e[0]);
    edge_point(P[1], P[0], N[1], e[1]);
    edge_point(P[1], P[2], N[1], e[2]);
    edge_point(P[2], P[1], N[2], e[3]);
    edge_point(P[2], P[0], N[2], e[4]);
    edge_point(P[0], P[2], N[0], e[5]);
    double c[3];
    for (int a = 0; a < 3; a++) {
        double E = (e[0][a] + e[1][a] + e[2][a] + e[3][a] + e[4][a] + e[5][a]) / 6.0;
        double V = (P[0][a] + P[1][a] + P[2][a]) / 3.0;
        c[a] = E + (E - V) / 2.0;
    }
    const double *pts[10];
    pts[PN_AT(3, 0)] = P[0];
    pts[PN_AT(0, 0)] = P[1];
    pts[PN_AT(0, 3)] = P[2];
    pts[PN_AT(2, 0)] = e[0]; /* b210 */
    pts[PN_AT(1, 0)] = e[1]; /* b120 */
    pts[PN_AT(0, 1)] = e[2]; /* b021 */
    pts[PN_AT(0, 2)] = e[3]; /* b012 */
    pts[PN_AT(1, 2)] = e[4]; /* b102 */
    pts[PN_AT(2, 1)] = e[5]; /* b201 */
    pts[PN_AT(1, 1)] = c;
    for (int i = 0; i < 10; i++)
        pn->b[i] = vec3((float)pts[i][0], (float)pts[i][1], (float)pts[i][2]);
    pn->n[0] = n[0];
    pn->n[1] = n[1];
    pn->n[2] = n[2];
    pn->n[3] = edge_normal(P[0], P[1], n[0], n[1]);
    pn->n[4] = edge_normal(P[1], P[2], n[1], n[2]);
    pn->n[5] = edge_normal(P[2], P[0], n[2], n[0]);
}

/* ---- evaluation ---- */

static int split_avx(void);

#ifdef PN_AVX
/* pn_eval with x, y, z in the lanes of one register. Its loads read a
 * float past each point (the next one's, or n[0]'s): lane 3, never
 * stored. */
typedef char eval_avx_reads_within_the_patch[sizeof(PnPatch) >= offsetof(PnPatch, b) + sizeof(float) * 31 ? 1 : -1];
__attribute__((target("avx"))) static void eval_avx(const PnPatch *pn, double u, double v, double pt[3], double du[3],
                                                    double dv[3])
{
    const __m256d W = _mm256_set1_pd(1.0 - u - v), U = _mm256_set1_pd(u), V = _mm256_set1_pd(v);
    __m256d b[10];
    for (int i = 0; i < 10; i++)
        b[i] = _mm256_cvtps_pd(_mm_loadu_ps(&pn->b[i].x));
#define STEP(x, y, z) _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(W, x), _mm256_mul_pd(U, y)), _mm256_mul_pd(V, z))
    __m256d q0 = STEP(b[0], b[1], b[2]), q1 = STEP(b[1], b[3], b[4]), q2 = STEP(b[2], b[4], b[5]);
    __m256d q3 = STEP(b[3], b[6], b[7]), q4 = STEP(b[4], b[7], b[8]), q5 = STEP(b[5], b[8], b[9]);
    __m256d rw = STEP(q0, q1, q2), ru = STEP(q1, q3, q4), rv = STEP(q2, q4, q5);
    double x[4];
    if (pt) {
        _mm256_storeu_pd(x, STEP(rw, ru, rv));
        memcpy(pt, x, 3 * sizeof *pt);
    }
#undef STEP
    const __m256d three = _mm256_set1_pd(3.0);
    if (du) {
        _mm256_storeu_pd(x, _mm256_mul_pd(three, _mm256_sub_pd(ru, rw)));
        memcpy(du, x, 3 * sizeof *du);
    }
    if (dv) {
        _mm256_storeu_pd(x, _mm256_mul_pd(three, _mm256_sub_pd(rv, rw)));
        memcpy(dv, x, 3 * sizeof *dv);
    }
}
#endif

/* Two de Casteljau steps at (w, u, v) leave the linear net r_w, r_u, r_v:
 * the point is w r_w + u r_u + v r_v, and dB/du = 3 (r_u - r_w),
 * dB/dv = 3 (r_v - r_w). */
void pn_eval(const PnPatch *pn, double u, double v, double pt[3], double du[3], double dv[3])
{
#ifdef PN_AVX
    if (split_avx()) {
        eval_avx(pn, u, v, pt, du, dv);
        return;
    }
#endif
    double w = 1.0 - u - v, b[10][3];
    for (int i = 0; i < 10; i++) {
        b[i][0] = pn->b[i].x;
        b[i][1] = pn->b[i].y;
        b[i][2] = pn->b[i].z;
    }
    for (int a = 0; a < 3; a++) {
        /* degree 2, at PN_AT-like index (2-i)(3-i)/2 + k */
        double q0 = w * b[0][a] + u * b[1][a] + v * b[2][a];
        double q1 = w * b[1][a] + u * b[3][a] + v * b[4][a];
        double q2 = w * b[2][a] + u * b[4][a] + v * b[5][a];
        double q3 = w * b[3][a] + u * b[6][a] + v * b[7][a];
        double q4 = w * b[4][a] + u * b[7][a] + v * b[8][a];
        double q5 = w * b[5][a] + u * b[8][a] + v * b[9][a];
        /* degree 1: r_w = (1,0,0), r_u = (0,1,0), r_v = (0,0,1) */
        double rw = w * q0 + u * q1 + v * q2;
        double ru = w * q1 + u * q3 + v * q4;
        double rv = w * q2 + u * q4 + v * q5;
        if (pt)
            pt[a] = w * rw + u * ru + v * rv;
        if (du)
            du[a] = 3.0 * (ru - rw);
        if (dv)
            dv[a] = 3.0 * (rv - rw);
    }
}

Vec3 pn_shading_normal(const PnPatch *pn, float u, float v)
{
    double U = u, V = v, W = 1.0 - U - V;
    const double c[6] = {W * W, U * U, V * V, W * U, U * V, W * V};
    double s[3] = {0, 0, 0};
    for (int i = 0; i < 6; i++) {
        s[0] += c[i] * pn->n[i].x;
        s[1] += c[i] * pn->n[i].y;
        s[2] += c[i] * pn->n[i].z;
    }
    return normalized_or(s[0], s[1], s[2], pn->n[0]);
}

Vec3 pn_geometric_normal(const PnPatch *pn, float u, float v)
{
    double du[3], dv[3];
    pn_eval(pn, u, v, NULL, du, dv);
    double g[3];
    d3_cross(g, du, dv);
    return normalized_or(g[0], g[1], g[2], pn_shading_normal(pn, u, v));
}

void pn_bounds(const PnPatch *pn, Vec3 *lo, Vec3 *hi)
{
    Vec3 l = pn->b[0], h = l;
    for (int i = 1; i < 10; i++) { /* comparisons, not fminf: a libm call each without -ffast-math */
        Vec3 p = pn->b[i];
        l.x = p.x < l.x ? p.x : l.x, l.y = p.y < l.y ? p.y : l.y, l.z = p.z < l.z ? p.z : l.z;
        h.x = p.x > h.x ? p.x : h.x, h.y = p.y > h.y ? p.y : h.y, h.z = p.z > h.z ? p.z : h.z;
    }
    *lo = l;
    *hi = h;
}

/* ---- tessellation ---- */

void pn_tessellate(const PnPatch *pn, int n, Vec3 *pts, Vec3 *nrm, int (*faces)[3])
{
    int k = 0;
    for (int a = 0; a <= n; a++)
        for (int b = 0; a + b <= n; b++, k++) {
            double pt[3];
            pn_eval(pn, (double)a / n, (double)b / n, pt, NULL, NULL);
            pts[k] = vec3((float)pt[0], (float)pt[1], (float)pt[2]);
            nrm[k] = pn_shading_normal(pn, (float)a / (float)n, (float)b / (float)n);
        }
    /* point (a, b) is number a (n + 1) - a (a - 1) / 2 + b */
#define PN_V(a, b) ((a) * (n + 1) - (a) * ((a) - 1) / 2 + (b))
    k = 0;
    for (int a = 0; a < n; a++)
        for (int b = 0; a + b < n; b++) {
            faces[k][0] = PN_V(a, b), faces[k][1] = PN_V(a + 1, b), faces[k][2] = PN_V(a, b + 1);
            k++;
            if (a + b < n - 1) {
                faces[k][0] = PN_V(a + 1, b), faces[k][1] = PN_V(a + 1, b + 1), faces[k][2] = PN_V(a, b + 1);
                k++;
            }
        }
#undef PN_V
}

/* ---- subdivision ---- */

void pn_net_root(const PnPatch *pn, PnNet *net)
{
    for (int i = 0; i < 10; i++)
        to_d(pn->b[i], net->b[i]);
    net->err = 0.0; /* the float net is the patch */
    net->u0 = 0.0;
    net->v0 = 0.0;
    net->s = 1.0;
    net->flip = 0;
}

/* ---- the split as a straight-line program ----
 *
 * A child's point b(C0^i, C1^j, C2^k) is the blossom of the parent's net:
 * three de Casteljau steps, one per argument, corners (which only select)
 * before midpoints. A midpoint averages two points, (a + b) * 0.5, which
 * gives the same bits whichever comes first. Written out once, the
 * children's 40 points are averages of averages of the parent's 10: the
 * program below computes each distinct average once, into a pool whose
 * first 10 entries are the parent's net. A point on a parent's edge comes
 * from that edge's four points by the curve's own de Casteljau averages,
 * whichever patch computes it: patches sharing an edge split it into the
 * same bits. Every child point is at most three averages deep.
 *
 * The program is written out as constant tables, which lets the compiler
 * unroll the split into straight-line code; test_pntri derives it again
 * from the blossom and compares. Pool entry 10 + n is the average of
 * entries op[n][0] and op[n][1]; child c (at P1, P2, P3, then the middle
 * one, turned half round) is made of the entries child[c]; own[c] lists
 * the ops that child's points need, in order, and own[PN_ALL] every op. */
#define PN_OPS 46
#define PN_POOL (10 + PN_OPS)
static const unsigned char split_op[PN_OPS][2] = {
    {3, 6},   {4, 7},   {5, 8},   {1, 3},   {2, 4},   {0, 1},   {10, 13}, {11, 14}, {13, 15}, {16, 18},
    {3, 7},   {4, 8},   {5, 9},   {1, 4},   {2, 5},   {0, 2},   {20, 23}, {21, 24}, {23, 25}, {26, 28},
    {21, 23}, {22, 24}, {24, 25}, {30, 32}, {31, 32}, {6, 7},   {7, 8},   {3, 4},   {35, 36}, {8, 9},
    {4, 5},   {1, 2},   {36, 39}, {37, 40}, {38, 42}, {35, 37}, {38, 43}, {36, 40}, {37, 41}, {45, 48},
    {42, 43}, {39, 40}, {36, 37}, {40, 41}, {51, 53}, {52, 53},
};
static const unsigned char split_child[4][10] = {
    {0, 15, 25, 18, 28, 32, 19, 29, 33, 34},
    {19, 16, 49, 10, 45, 46, 6, 35, 38, 44},
    {34, 54, 31, 50, 51, 22, 44, 42, 39, 9},
    {44, 50, 46, 54, 55, 49, 34, 33, 29, 19},
};
#define PN_ALL 4 /* every op, in order, for all four children */
static const int split_nown[5] = {20, 20, 20, 40, PN_OPS};
static const unsigned char split_own[5][PN_OPS] = {
    {0, 3, 5, 6, 8, 9, 10, 11, 12, 13, 14, 15, 16, 18, 19, 20, 21, 22, 23, 24},
    {0, 3, 5, 6, 8, 9, 25, 26, 27, 28, 29, 30, 31, 32, 33, 34, 35, 36, 38, 39},
    {12, 14, 15, 21, 22, 24, 25, 26, 27, 28, 29, 30, 31, 32, 33, 34, 40, 41, 43, 44},
    {0,  3,  5,  6,  8,  9,  10, 11, 12, 13, 14, 15, 16, 18, 19, 20, 21, 22, 23, 24,
     25, 26, 27, 28, 29, 30, 31, 32, 33, 34, 35, 36, 38, 39, 40, 41, 42, 43, 44, 45},
    {0,  1,  2,  3,  4,  5,  6,  7,  8,  9,  10, 11, 12, 13, 14, 15, 16, 17, 18, 19, 20, 21, 22,
     23, 24, 25, 26, 27, 28, 29, 30, 31, 32, 33, 34, 35, 36, 37, 38, 39, 40, 41, 42, 43, 44, 45},
};

void pn_split_program(PnSplitProgram *g)
{
    g->nops = PN_OPS;
    memcpy(g->op, split_op, sizeof split_op);
    memcpy(g->child, split_child, sizeof split_child);
    for (int c = 0; c < 4; c++) {
        g->nown[c] = split_nown[c];
        memcpy(g->own[c], split_own[c], (size_t)split_nown[c]);
    }
}

/* A pool of points, x, y, z and a 0, so that a point is one AVX register. */
typedef double PnPool[PN_POOL][4];

/* Set by a test to keep the split and the evaluation off AVX
 * (pn_split_avx). */
static int split_no_avx;

int pn_split_avx(int allow)
{
    split_no_avx = !allow;
#ifdef PN_AVX
    return __builtin_cpu_supports("avx");
#else
    return 0;
#endif
}

/* 1 when the split and the evaluation run with AVX: the processor has
 * it, and no test turned it off. */
static int split_avx(void)
{
#ifdef PN_AVX
    return !split_no_avx && __builtin_cpu_supports("avx");
#else
    return 0;
#endif
}

#ifdef PN_AVX
/* The ops list[0..n-1] on the pool, four lanes at once: with constant
 * arguments, straight-line code. */
__attribute__((target("avx"), always_inline)) static inline void ops_avx(PnPool pool, const unsigned char *list,
                                                                         int n)
{
    const __m256d half = _mm256_set1_pd(0.5);
#pragma GCC unroll 48
    for (int k = 0; k < n; k++) {
        int o = list[k];
        __m256d a = _mm256_loadu_pd(pool[split_op[o][0]]), b = _mm256_loadu_pd(pool[split_op[o][1]]);
        _mm256_storeu_pd(pool[10 + o], _mm256_mul_pd(_mm256_add_pd(a, b), half));
    }
}

/* split_pool's work: the parent's net into the pool, then the averages;
 * returns the net's largest coordinate (MAXPD keeps the running one
 * against a NaN, as the comparison does). */
__attribute__((target("avx"))) static double pool_ops_avx(const PnNet *parent, PnPool pool, int which)
{
    const __m256d sign = _mm256_set1_pd(-0.0);
    __m256d m = _mm256_setzero_pd();
    for (int i = 0; i < 10; i++) {
        __m256d x = _mm256_setr_pd(parent->b[i][0], parent->b[i][1], parent->b[i][2], 0.0);
        _mm256_storeu_pd(pool[i], x);
        m = _mm256_max_pd(_mm256_andnot_pd(sign, x), m);
    }
    switch (which) { /* each case's list a constant */
    case 0: ops_avx(pool, split_own[0], split_nown[0]); break;
    case 1: ops_avx(pool, split_own[1], split_nown[1]); break;
    case 2: ops_avx(pool, split_own[2], split_nown[2]); break;
    case 3: ops_avx(pool, split_own[3], split_nown[3]); break;
    default: ops_avx(pool, split_own[PN_ALL], split_nown[PN_ALL]); break;
    }
    double ms[4];
    _mm256_storeu_pd(ms, m);
    double mx = ms[0] > ms[1] ? ms[0] : ms[1];
    return ms[2] > mx ? ms[2] : mx;
}
#endif

/* The split's pool: the parent's net, then the averages of own[which]
 * (which is PN_ALL for all four children), with AVX when avx is 1.
 * Returns the children's error bound. */
static double split_pool(const PnNet *parent, PnPool pool, int which, int avx)
{
    double m = 0.0;
    (void)avx;
#ifdef PN_AVX
    if (avx) {
        m = pool_ops_avx(parent, pool, which);
        return parent->err + gamma_d(3) * m + 3.0 * 0x1p-1074;
    }
#endif
    for (int i = 0; i < 10; i++) {
        for (int a = 0; a < 3; a++) {
            pool[i][a] = parent->b[i][a];
            double x = fabs(parent->b[i][a]);
            m = x > m ? x : m;
        }
        pool[i][3] = 0.0;
    }
    for (int k = 0; k < split_nown[which]; k++) {
        int o = split_own[which][k];
        const double *a = pool[split_op[o][0]], *b = pool[split_op[o][1]];
        pool[10 + o][0] = (a[0] + b[0]) * 0.5;
        pool[10 + o][1] = (a[1] + b[1]) * 0.5;
        pool[10 + o][2] = (a[2] + b[2]) * 0.5;
    }
    /* three averages a point; halving a subnormal rounds, absolutely */
    return parent->err + gamma_d(3) * m + 3.0 * 0x1p-1074;
}

/* Child c's net from the pool, and its domain from the parent's, dom (only
 * its u0, v0, s and flip are read). */
static void split_child_net(const PnNet *dom, PnPool pool, double err, int c, PnNet *ch)
{
    const unsigned char *idx = split_child[c];
    double h = 0.5 * dom->s, sg = dom->flip ? -h : h;
    ch->u0 = dom->u0 + (c == 1 || c == 3 ? sg : 0.0);
    ch->v0 = dom->v0 + (c == 2 || c == 3 ? sg : 0.0);
    ch->s = h;
    ch->flip = dom->flip ^ (c == 3);
    ch->err = err;
    for (int i = 0; i < 10; i++)
        memcpy(ch->b[i], pool[idx[i]], sizeof ch->b[i]);
}

void pn_net_split(const PnNet *parent, PnNet child[4])
{
    PnPool pool;
    double err = split_pool(parent, pool, PN_ALL, split_avx());
    for (int c = 0; c < 4; c++)
        split_child_net(parent, pool, err, c, &child[c]);
}

/* The box of points idx[0..9] of pts (x, y, z each, `stride` doubles
 * apart) grown by err, as pn_net_box. */
static void points_box(const double *pts, int stride, const unsigned char *idx, double err, double lo[3], double hi[3])
{
    for (int a = 0; a < 3; a++) {
        double l = pts[stride * idx[0] + a], u = l;
        for (int i = 1; i < 10; i++) {
            double x = pts[stride * idx[i] + a];
            l = x < l ? x : l;
            u = x > u ? x : u;
        }
        /* the error bound, and the rounding of the two sums below */
        double pad = err + DBL_EPSILON * (-l > u ? -l : u);
        lo[a] = l - pad;
        hi[a] = u + pad;
    }
}

#ifdef PN_AVX
/* points_box on a pool, four lanes at once: the same operations, lane by
 * lane (MAXPD and MINPD pick as the comparisons above do). */
__attribute__((target("avx"), always_inline)) static inline void box_avx(PnPool pool, const unsigned char *idx,
                                                                         double err, double lo[3], double hi[3])
{
    __m256d l = _mm256_loadu_pd(pool[idx[0]]), u = l;
    for (int i = 1; i < 10; i++) {
        __m256d x = _mm256_loadu_pd(pool[idx[i]]);
        l = _mm256_min_pd(x, l);
        u = _mm256_max_pd(x, u);
    }
    __m256d big = _mm256_max_pd(_mm256_xor_pd(l, _mm256_set1_pd(-0.0)), u);
    __m256d pad = _mm256_add_pd(_mm256_set1_pd(err), _mm256_mul_pd(_mm256_set1_pd(DBL_EPSILON), big));
    double out[2][4];
    _mm256_storeu_pd(out[0], _mm256_sub_pd(l, pad));
    _mm256_storeu_pd(out[1], _mm256_add_pd(u, pad));
    memcpy(lo, out[0], sizeof(double[3]));
    memcpy(hi, out[1], sizeof(double[3]));
}

/* Child c's box, its points' places in the pool constants. */
__attribute__((target("avx"))) static void pool_box_avx(PnPool pool, int c, double err, double lo[3], double hi[3])
{
    switch (c) {
    case 0: box_avx(pool, split_child[0], err, lo, hi); break;
    case 1: box_avx(pool, split_child[1], err, lo, hi); break;
    case 2: box_avx(pool, split_child[2], err, lo, hi); break;
    default: box_avx(pool, split_child[3], err, lo, hi); break;
    }
}
#endif

/* The box of child c's points in pool, with AVX when avx is 1. */
static void pool_box(PnPool pool, int c, double err, double lo[3], double hi[3], int avx)
{
    (void)avx;
#ifdef PN_AVX
    if (avx) {
        pool_box_avx(pool, c, err, lo, hi);
        return;
    }
#endif
    points_box(&pool[0][0], 4, split_child[c], err, lo, hi);
}

void pn_net_box(const PnNet *net, double lo[3], double hi[3])
{
    static const unsigned char all[10] = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9};
    points_box(&net->b[0][0], 3, all, net->err, lo, hi);
}

/* ---- intersection ---- */

/* The ray's parameter interval inside the box [lo, hi], conservative: the
 * slab test in double (Williams et al. 2005), widened by its roundings
 * (Ize 2013). Returns 0 when the ray misses it within (0, tmax). */
static int slab(const double lo[3], const double hi[3], const double o[3], const double d[3], const double inv[3],
                double tmax, double *tn, double *tf)
{
    double n = -INFINITY, f = INFINITY;
    for (int a = 0; a < 3; a++) {
        if (d[a] == 0.0) {
            if (o[a] < lo[a] || o[a] > hi[a])
                return 0;
            continue;
        }
        double t0 = (lo[a] - o[a]) * inv[a], t1 = (hi[a] - o[a]) * inv[a];
        if (t0 > t1) {
            double x = t0;
            t0 = t1;
            t1 = x;
        }
        n = t0 > n ? t0 : n;
        f = t1 < f ? t1 : f;
    }
    /* three roundings each: the difference, the reciprocal, the product */
    n -= fabs(n) * (4.0 * DBL_EPSILON);
    f += fabs(f) * (4.0 * DBL_EPSILON);
    if (n > f || f <= 0.0 || n >= tmax)
        return 0;
    *tn = n;
    *tf = f;
    return 1;
}

/* max(a, b) by a comparison: fmax is a libm call without -ffast-math */
static double max2(double a, double b) { return a > b ? a : b; }

static double maxabs3(const double v[3]) { return max2(fabs(v[0]), max2(fabs(v[1]), fabs(v[2]))); }

/* 1 when every side of the box is within a few float spacings of its
 * largest coordinate m: a split would no longer tell float points apart (a
 * patch lying in a plane through 0 has one coordinate far finer, which a
 * float hit point could not use). */
static int at_float_precision(const double lo[3], const double hi[3], double m)
{
    double ulp = max2(m, 0x1p-149 / (double)FLT_EPSILON) * (double)FLT_EPSILON;
    for (int a = 0; a < 3; a++)
        if (hi[a] - lo[a] > 4.0 * ulp)
            return 0;
    return 1;
}

/* Rounding allowance of the flat test below: every double rounding in it
 * is far smaller than 2^-40 of the magnitudes it involves, and adding that
 * much costs nothing at float precision. */
#define PN_SLACK 0x1p-40

static double norm1(const double v[3]) { return fabs(v[0]) + fabs(v[1]) + fabs(v[2]); }


/* The barycentrics (of B and C) of the point of the triangle A, A + e1,
 * A + e2 nearest to A + q, for a q whose projection falls outside it: the
 * nearest point of one of its edges. (Clamping the barycentrics one by one
 * would move the point along a thin triangle by far more than its distance
 * outside.) */
static void nearest_on_triangle(const double q[3], const double e1[3], const double e2[3], double *lb, double *lc)
{
    const double zero[3] = {0.0, 0.0, 0.0};
    double bc[3];
    for (int a = 0; a < 3; a++)
        bc[a] = e2[a] - e1[a];
    /* the edges A B, A C and B C, as start + s dir */
    const double *start[3] = {zero, zero, e1}, *dir[3] = {e1, e2, bc};
    double best = INFINITY;
    for (int k = 0; k < 3; k++) {
        double w[3], wd = 0.0, dd = 0.0;
        for (int a = 0; a < 3; a++) {
            w[a] = q[a] - start[k][a];
            wd += w[a] * dir[k][a];
            dd += dir[k][a] * dir[k][a];
        }
        double s = dd > 0.0 ? wd / dd : 0.0, d2 = 0.0;
        s = s < 0.0 ? 0.0 : s > 1.0 ? 1.0 : s;
        for (int a = 0; a < 3; a++) {
            double x = w[a] - s * dir[k][a];
            d2 += x * x;
        }
        if (d2 < best) {
            best = d2;
            *lb = k == 0 ? s : k == 1 ? 0.0 : 1.0 - s;
            *lc = k == 0 ? 0.0 : s;
        }
    }
}

/* A piece's corner triangle T = A, B, C against the ray: its edges, its
 * normal n = e1 x e2 (|n|^2 = nn2), the origin from A and n.d. The flat
 * test and the proof both start from it. */
typedef struct {
    const double *A;
    double e1[3], e2[3], q[3], n[3], nn2, nd;
} PnFrame;

PN_INLINE void piece_frame(const PnNet *net, const double o[3], const double d[3], PnFrame *f)
{
    const double *A = net->b[PN_AT(3, 0)], *B = net->b[PN_AT(0, 0)], *C = net->b[PN_AT(0, 3)];
    f->A = A;
    for (int a = 0; a < 3; a++) {
        f->e1[a] = B[a] - A[a];
        f->e2[a] = C[a] - A[a];
        f->q[a] = o[a] - A[a];
    }
    d3_cross(f->n, f->e1, f->e2);
    f->nn2 = d3_dot(f->n, f->n);
    f->nd = d3_dot(f->n, d);
}

/* The bound dev of flat_piece (below): how far the piece's exact surface
 * strays, on any axis, from the triangle T of its corners; m is its box's
 * largest coordinate. */
PN_INLINE double piece_dev(const PnNet *net, const PnFrame *f, double m)
{
    const double *A = f->A, *e1 = f->e1, *e2 = f->e2;
    /* T raised to degree 3: A + j (B - A) / 3 + k (C - A) / 3 at b_ijk */
    double sb[3], sc[3], dev = 0.0;
    for (int a = 0; a < 3; a++) {
        sb[a] = e1[a] * (1.0 / 3.0);
        sc[a] = e2[a] * (1.0 / 3.0);
    }
    /* the seven points off the corners (which lie on T exactly), b_ijk
     * against A + j sb + k sc */
    const double *b210 = net->b[PN_AT(2, 0)], *b201 = net->b[PN_AT(2, 1)], *b120 = net->b[PN_AT(1, 0)],
                 *b111 = net->b[PN_AT(1, 1)], *b102 = net->b[PN_AT(1, 2)], *b021 = net->b[PN_AT(0, 1)],
                 *b012 = net->b[PN_AT(0, 2)];
    for (int a = 0; a < 3; a++) {
        double s1 = A[a] + sb[a], s2 = A[a] + 2.0 * sb[a];
        double x[7] = {b210[a] - s1,           b201[a] - (A[a] + sc[a]), b120[a] - s2,
                       b111[a] - (s1 + sc[a]), b102[a] - (A[a] + 2.0 * sc[a]), b021[a] - (s2 + sc[a]),
                       b012[a] - (s1 + 2.0 * sc[a])};
        for (int k = 0; k < 7; k++) {
            double y = fabs(x[k]);
            dev = y > dev ? y : dev;
        }
    }
    dev += net->err + PN_SLACK * m;
    return dev;
}

/* T's edges: |AB|, |AC| and |BC|. */
PN_INLINE void piece_lengths(const PnFrame *f, double len[3])
{
    const double *e1 = f->e1, *e2 = f->e2;
    len[0] = sqrt(d3_dot(e1, e1));
    len[1] = sqrt(d3_dot(e2, e2));
    len[2] = sqrt((e2[0] - e1[0]) * (e2[0] - e1[0]) + (e2[1] - e1[1]) * (e2[1] - e1[1]) +
                  (e2[2] - e1[2]) * (e2[2] - e1[2]));
}

/* A piece's exact surface lies within dev, on every axis, of the triangle
 * T of its corners: the net's points are within dev of those of T raised
 * to degree 3, and the difference of two Bezier triangles lies in the
 * convex hull of the differences of their nets. The ray is tested against
 * T thickened by dev, a far tighter bound than the box once a piece is
 * nearly flat: the slab |n.(p - A)| <= h around T's plane gives t's
 * interval, and the ray's point in it must lie within reach of T. Returns
 * 0 when the ray misses the thickened triangle in (0, tmax); 1 when the
 * piece is flat to float precision (dev within a float spacing of m, its
 * box's largest coordinate) and the ray meets it, with the hit's t, its
 * bound and the domain point; -1 otherwise (split on), and for every ray
 * that meets T's plane at a cosine below 1/4 and is not culled. dd is
 * |d|, computed once a ray; dev and len are piece_dev's and
 * piece_lengths'. */
static int flat_piece(const PnNet *net, const PnFrame *f, const double d[3], double dd, double tmax, double m,
                      double dev, const double len[3], double *t, double *terr, double *u, double *v, int *only)
{
    *only = -1;
    const double *e1 = f->e1, *e2 = f->e2, *q = f->q, *n = f->n;
    int flat = dev <= m * (double)FLT_EPSILON;
    double nn2 = f->nn2, nn = sqrt(nn2), nd = f->nd;
    if (!(nn > 0.0))
        return -1;
    /* A ray that meets T's plane at a cosine below 1/4 is only culled
     * here: a hit would have a loose bound (and a ray in the plane, nd = 0,
     * gets infinite or NaN ends, which cull nothing). */
    int steep = fabs(nd) >= 0.25 * nn * dd;
    /* |n.w| <= |n|_1 dev for an offset w of at most dev on each axis; the
     * slack covers n's rounding against the edges and the sums below */
    double qm = maxabs3(q);
    double h = norm1(n) * (dev + PN_SLACK * (m + qm));
    double nq = d3_dot(n, q);
    double t1 = (-h - nq) / nd, t2 = (h - nq) / nd;
    if (t1 > t2) {
        double x = t1;
        t1 = t2;
        t2 = x;
    }
    t1 -= fabs(t1) * PN_SLACK;
    t2 += fabs(t2) * PN_SLACK;
    /* behind the origin or beyond tmax: a miss, whatever the piece; an
     * origin in a flat piece's slab is on the surface to float precision,
     * a spawned ray that does not hit its own spot (as a box at float
     * precision) */
    if (t2 <= 0.0 || t1 >= tmax || (flat && steep && t1 <= 0.0))
        return 0;
    /* where a hit can be: the part of [t1, t2] in (0, tmax) */
    double ta = t1 > 0.0 ? t1 : 0.0, tb = t2 < tmax ? t2 : tmax;
    double tm = 0.5 * (ta + tb), p[3];
    for (int a = 0; a < 3; a++)
        p[a] = q[a] + tm * d[a];
    /* the barycentrics of p's projection on T's plane */
    double c2[3], c1[3];
    d3_cross(c2, p, e2);
    d3_cross(c1, e1, p);
    double lb = d3_dot(c2, n) / nn2;
    double lc = d3_dot(c1, n) / nn2, la = 1.0 - lb - lc;
    /* A hit point of the piece is within dev of T on each axis, and within
     * (t2 - t1) / 2 of p along the ray: p's projection is within rad of T,
     * so no barycentric falls below -rad over its vertex's altitude. */
    double pm = maxabs3(p);
    double rad = dev * 1.7320508075688774 + 0.5 * (tb - ta) * dd + PN_SLACK * (pm + m);
    double l1 = len[0], l2 = len[1], l3 = len[2];
    /* altitude of A = |n| / |BC|, of B = |n| / |AC|, of C = |n| / |AB| */
    double g = (1.0 + PN_SLACK) * rad / nn;
    if (la < -g * l3 || lb < -g * l2 || lc < -g * l1)
        return 0;
    if (!flat || !steep) {
        /* The same reach, from the lines that part the children (a
         * barycentric of 1/2): when it lies wholly on one child's side,
         * only that child can hold a hit (NaN, for a ray in T's plane,
         * picks none). */
        if (la - 0.5 > g * l3)
            *only = 0;
        else if (lb - 0.5 > g * l2)
            *only = 1;
        else if (lc - 0.5 > g * l1)
            *only = 2;
        else if (0.5 - la > g * l3 && 0.5 - lb > g * l2 && 0.5 - lc > g * l1)
            *only = 3;
        return -1;
    }
    *t = 0.5 * (t1 + t2);
    *terr = 0.5 * (t2 - t1);
    if (la < 0.0 || lb < 0.0 || lc < 0.0)
        nearest_on_triangle(p, e1, e2, &lb, &lc);
    double sg = net->flip ? -net->s : net->s;
    *u = net->u0 + sg * lb;
    *v = net->v0 + sg * lc;
    return 1;
}

typedef struct {
    const PnNet *net; /* own, or the start piece's (the root's: not copied) */
    PnNet own;
    double lo[3], hi[3]; /* pn_net_box of net */
    double tn, tf;       /* the ray's interval in that box */
    int depth;
    int tried; /* a proof's Newton point fell outside an ancestor: none is tried here */
} PnNode;

typedef struct {
    double o[3], d[3], inv[3];
    double tmax;
} PnRay;

/* Newton's method on F(u, v) = (a . (B - o), b . (B - o)) = 0, a and b two
 * unit vectors normal to the ray and to each other, from the node's
 * domain centre. Returns 1 when it converges, with (u, v). */
static int newton_uv(const PnPatch *pn, const PnRay *r, const PnNet *net, double lu0, double lv0, double *uo,
                     double *vo)
{
    double ax[3], bx[3];
    const double *d = r->d;
    if (fabs(d[0]) > fabs(d[1]) && fabs(d[0]) > fabs(d[2])) {
        ax[0] = d[1], ax[1] = -d[0], ax[2] = 0.0;
    } else {
        ax[0] = 0.0, ax[1] = d[2], ax[2] = -d[1];
    }
    double la = sqrt(d3_dot(ax, ax));
    for (int c = 0; c < 3; c++)
        ax[c] /= la;
    d3_cross(bx, ax, d);
    double lb = sqrt(d3_dot(bx, bx));
    for (int c = 0; c < 3; c++)
        bx[c] /= lb;
    double sg = net->flip ? -net->s : net->s;
    double u = net->u0 + sg * lu0, v = net->v0 + sg * lv0;
    for (int it = 0; it < PN_NEWTON_STEPS; it++) {
        double p[3], du[3], dv[3];
        pn_eval(pn, u, v, p, du, dv);
        double q[3] = {p[0] - r->o[0], p[1] - r->o[1], p[2] - r->o[2]};
        double f1 = d3_dot(ax, q);
        double f2 = d3_dot(bx, q);
        double j11 = d3_dot(ax, du);
        double j12 = d3_dot(ax, dv);
        double j21 = d3_dot(bx, du);
        double j22 = d3_dot(bx, dv);
        double det = j11 * j22 - j12 * j21;
        if (!(fabs(det) > 0.0))
            return 0;
        double su = (j22 * f1 - j12 * f2) / det, sv = (j11 * f2 - j21 * f1) / det;
        u -= su;
        v -= sv;
        if (!isfinite(u) || !isfinite(v))
            return 0;
        if (fabs(su) + fabs(sv) <= 1e-7 * net->s) {
            *uo = u;
            *vo = v;
            return 1;
        }
    }
    return 0;
}

/* Newton's method as newton_uv, from the centre of the node's domain.
 * Returns 1 with the hit when it converges inside the patch's domain:
 * a root of the patch, though it may lie outside the node (a piece split
 * ahead of rays, whose neighbour the ray crosses). */
static int newton(const PnPatch *pn, const PnRay *r, const PnNet *net, double *t, double *uo, double *vo)
{
    double u, v, p[3], du[3], dv[3];
    if (!newton_uv(pn, r, net, 1.0 / 3.0, 1.0 / 3.0, &u, &v))
        return 0;
    if (u < 0.0 || v < 0.0 || u + v > 1.0)
        return 0;
    pn_eval(pn, u, v, p, du, dv);
    const double *d = r->d;
    double dd = d3_dot(d, d);
    /* A ray that meets the surface at a grazing angle may meet it twice in
     * one node, and Newton may have found the far one: subdivide there
     * instead. */
    double g[3];
    d3_cross(g, du, dv);
    double gd = d3_dot(g, d), gg = d3_dot(g, g);
    if (gd * gd < PN_NEWTON_GRAZING * PN_NEWTON_GRAZING * gg * dd)
        return 0;
    *t = ((p[0] - r->o[0]) * d[0] + (p[1] - r->o[1]) * d[1] + (p[2] - r->o[2]) * d[2]) / dd;
    *uo = u;
    *vo = v;
    return *t > 0.0 && *t < r->tmax;
}

/* The whole patch as a piece: its net, its box, and as its magnitude the
 * box's largest coordinate, which bounds every piece's. */
static void whole_piece(const PnPatch *pn, PnPiece *w)
{
    pn_net_root(pn, &w->net);
    pn_net_box(&w->net, w->lo, w->hi);
    w->mag = max2(maxabs3(w->lo), maxabs3(w->hi));
    w->depth = 0;
    w->shaped = 0; /* a ray's own copy: its shape would cost what it saves */
}

/* The piece as the graph of a function over its corner triangle's plane
 * (pn_certify): kappa, the least a domain step of length |w| moves its
 * point's projection onto that plane, over |w|, and L, the graph's slope;
 * kappa <= 0 when the bounds below do not make it a graph. mroot bounds
 * the patch's coordinates. */
typedef struct {
    double kappa, L;
} PnSlope;

PN_INLINE PnSlope piece_slope(const PnNet *net, const PnFrame *f, double mroot)
{
    const double *e1 = f->e1, *e2 = f->e2, *n = f->n;
    /* sigma^2, the Gram matrix's least eigenvalue, 2 det / (tr + sqrt(tr^2 -
     * 4 det)); the square root grown over the roundings of tr^2 - 4 det */
    double det = f->nn2, nn = sqrt(det);
    double l1 = d3_dot(e1, e1), l2 = d3_dot(e2, e2);
    double tr = l1 + l2, root = sqrt(max2(0.0, tr * tr - 4.0 * det) + 0x1p-48 * tr * tr);
    /* n's rounding tilts it from T's true normal by at most |e1| |e2| 2^-48
     * / |n|, which moves a step E w by tilt |w| out of T's plane */
    double tilt = 0x1p-48 * sqrt(l1 * l2) / nn * sqrt(tr);
    double sigma = sqrt(2.0 * det / (tr + root)) * (1.0 - PN_SLACK) - tilt - 16.0 * PN_SLACK * mroot;
    /* the control vectors' parts along n and in T's plane; the exact net's
     * offsets (err on each axis, eight of them in a control vector) and
     * n's own rounding grow both */
    double grow = 8.0 * 1.7320508075688774 * net->err + 16.0 * PN_SLACK * mroot;
    double ns_ = 0.0, nt_ = 0.0, ps_ = 0.0, pt_ = 0.0;
    for (int i = 0; i <= 2; i++)
        for (int k = 0; k <= 2 - i; k++) {
            const double *p = net->b[PN_AT(i + 1, k)], *ps = net->b[PN_AT(i, k)], *pt = net->b[PN_AT(i, k + 1)];
            double ys[3], yt[3];
            for (int a = 0; a < 3; a++) {
                ys[a] = 3.0 * (ps[a] - p[a]) - e1[a];
                yt[a] = 3.0 * (pt[a] - p[a]) - e2[a];
            }
            /* the part in T's plane from |y|^2 - (n.y)^2 / |n|^2, grown over
             * its cancellation below */
            double ns = d3_dot(n, ys), nt = d3_dot(n, yt);
            double ss = d3_dot(ys, ys);
            double tt = d3_dot(yt, yt);
            ns_ = max2(ns_, fabs(ns));
            nt_ = max2(nt_, fabs(nt));
            ps_ = max2(ps_, ss * (1.0 + 0x1p-46) - ns * ns / det);
            pt_ = max2(pt_, tt * (1.0 + 0x1p-46) - nt * nt / det);
        }
    ns_ = ns_ / nn * (1.0 + PN_SLACK) + grow;
    nt_ = nt_ / nn * (1.0 + PN_SLACK) + grow;
    ps_ = sqrt(ps_) * (1.0 + PN_SLACK) + grow;
    pt_ = sqrt(pt_) * (1.0 + PN_SLACK) + grow;
    double Mn = sqrt(ns_ * ns_ + nt_ * nt_) * (1.0 + PN_SLACK) + tilt;
    double Mp = sqrt(ps_ * ps_ + pt_ * pt_) * (1.0 + PN_SLACK);
    PnSlope sl = {sigma - Mp, 0.0};
    sl.L = Mn / sl.kappa * (1.0 + PN_SLACK);
    return sl;
}

double pn_net_slope(const PnPatch *pn, const PnNet *net)
{
    const double zero[3] = {0.0, 0.0, 0.0};
    PnFrame f;
    piece_frame(net, zero, zero, &f);
    PnPiece w;
    whole_piece(pn, &w);
    PnSlope sl = piece_slope(net, &f, w.mag);
    return sl.kappa > 0.0 ? sl.L : INFINITY;
}

/* What pn_certify proved of a piece. */
enum { PN_UNSURE = 0, PN_CERT_HIT, PN_CERT_MISS, PN_UNSURE_OUTSIDE };

/* A proof of where the ray meets the piece, when one is found: its only
 * crossing, at t within terr (PN_CERT_HIT, with the domain point (u, v)),
 * or none in (0, tmax) (PN_CERT_MISS). PN_UNSURE_OUTSIDE when Newton's
 * point lies outside the piece's domain (so outside its children's too).
 *
 * Write the piece as T + D, T(s, t) = A + s e1 + t e2 the plane of its
 * corners A, B, C (e1 = B - A, e2 = C - A) over its local coordinates. Its
 * partial derivatives are e1 + D_s and e2 + D_t, D_s and D_t quadratic
 * Bezier triangles whose control vectors are 3 (b_i,j+1,k - b_i+1,j,k) - e1
 * and 3 (b_i,j,k+1 - b_i+1,j,k) - e2. Mn and Mp bound the parts of
 * D_s w1 + D_t w2 along T's unit normal n and in T's plane, over |w|, the
 * exact net's offsets of up to err included. With sigma at most the least
 * singular value of [e1 e2] and kappa = sigma - Mp > 0, a segment w of the
 * convex domain moves the point's projection onto T's plane by at least
 * kappa |w| and its height over the plane by at most Mn |w|: the piece is
 * the graph of a function of slope at most L = Mn / kappa over the plane,
 * one to one. A ray steeper than that, rate = |n.d| - L |n x d| > 0, has a
 * height over the graph (extended to the whole plane at the same slope)
 * that changes monotonically, at least at that rate: it crosses the piece
 * at most once. Newton's point S of the patch in the piece, at distance
 * rho from the ray's point R at t_S, bounds that crossing: the height at
 * t_S is within (1 + L) rho of 0, so the crossing is within
 * w = (1 + L) rho / rate of t_S. It is on the piece when its projection
 * lies within kappa times S's domain point's distance to the domain's
 * edges of S's projection (the projection of the domain's disc around that
 * point covers the disc kappa times as wide around S's projection): when
 * |n x d| w + rho is below that.
 *
 * mroot bounds the patch's coordinates; every rounding here is far below
 * PN_SLACK of the magnitudes it involves, but for the local coordinates'
 * (lu - its rounding is a float spacing of u, over the side s). shaped:
 * the piece, when net is a PnPiece's that keeps its slope, or NULL. */
static int pn_certify(const PnPatch *pn, const PnRay *r, const PnNet *net, const PnFrame *f, const PnPiece *shaped,
                      double dd, double tmax, double mroot, double *t, double *terr, double *u, double *v)
{
    const double *o = r->o, *d = r->d, *e1 = f->e1, *e2 = f->e2, *n = f->n;
    double det = f->nn2, nn = sqrt(det);
    /* where the ray meets T's plane, Newton's start below */
    double nd = f->nd, tp = -d3_dot(n, f->q) / nd, q[3];
    for (int a = 0; a < 3; a++)
        q[a] = f->q[a] + tp * d[a];
    double c2[3], c1[3];
    d3_cross(c2, q, e2);
    d3_cross(c1, e1, q);
    double lu0 = d3_dot(c2, n) / det;
    double lv0 = d3_dot(c1, n) / det;
    if (!(lu0 > -0.5 && lv0 > -0.5 && lu0 + lv0 < 1.5)) /* far from the piece: Newton would leave it */
        return PN_UNSURE;
    PnSlope sl = shaped ? (PnSlope){shaped->kappa, shaped->slope} : piece_slope(net, f, mroot);
    if (!(sl.kappa > 0.0))
        return PN_UNSURE;
    double L = sl.L, kappa = sl.kappa;
    double nxd[3];
    d3_cross(nxd, n, d);
    double dxi = sqrt(d3_dot(nxd, nxd)) / nn * (1.0 + PN_SLACK) + PN_SLACK * dd;
    double rate = fabs(nd) / nn - L * dxi - PN_SLACK * dd * (1.0 + L);
    if (!(rate > 0.0))
        return PN_UNSURE;
    double nu, nv;
    if (!newton_uv(pn, r, net, lu0, lv0, &nu, &nv))
        return PN_UNSURE;
    double sg = net->flip ? -net->s : net->s;
    double lu = (nu - net->u0) / sg, lv = (nv - net->v0) / sg;
    /* S's domain point's distance to the domain's edges */
    double edge = lu < lv ? lu : lv, far = (1.0 - lu - lv) * 0.7071067811865476;
    edge = (far < edge ? far : edge) - 4.0 * DBL_EPSILON / net->s - PN_SLACK;
    if (!(edge > 0.0))
        return PN_UNSURE_OUTSIDE;
    double S[3];
    pn_eval(pn, nu, nv, S, NULL, NULL);
    double ts = ((S[0] - o[0]) * d[0] + (S[1] - o[1]) * d[1] + (S[2] - o[2]) * d[2]) / (dd * dd), rho = 0.0;
    for (int a = 0; a < 3; a++) {
        double x = o[a] + ts * d[a] - S[a];
        rho += x * x;
    }
    /* S's roundings (pn_eval's) and R's */
    rho = sqrt(rho) * (1.0 + PN_SLACK) + 1.7320508075688774 * PN_SLACK * (mroot + maxabs3(o) + fabs(ts) * dd);
    double w = (1.0 + L) * rho / rate * (1.0 + PN_SLACK);
    if (ts + w < 0.0 || ts - w > tmax)
        return PN_CERT_MISS;
    /* a hit, with t to float precision, when the crossing is on the piece */
    if (!(ts - w > 0.0 && ts + w < tmax && w <= ts * (0.5 * (double)FLT_EPSILON) &&
          dxi * w + rho < kappa * edge * (1.0 - PN_SLACK)))
        return PN_UNSURE;
    *t = ts;
    *terr = w;
    *u = nu;
    *v = nv;
    return PN_CERT_HIT;
}

/* The nearest hit so far: t (the ray's tmax while there is none), its
 * bound and its domain point. */
typedef struct {
    double t, err, u, v;
} PnBest;

static void best_keep(PnBest *b, double t, double err, double u, double v)
{
    if (t < b->t) {
        b->t = t;
        b->err = err;
        b->u = u;
        b->v = v;
    }
}

/* What pn_hit_piece_rays settled of a ray at its start piece: the flat
 * test and the proof, which left a split to do (flat_piece's only) and
 * whether the proof's Newton point fell outside the piece. */
typedef struct {
    int only, tried;
} PnStartLeft;

static int trace(const PnPatch *pn, const PnPiece *start, const Ray *ray, PnMode mode, int proofs,
                 const PnStartLeft *left, PnHit *h, long *proven);

int pn_hit(const PnPatch *pn, const Ray *ray, PnMode mode, PnHit *h) { return pn_hit_with(pn, ray, mode, 1, h, NULL); }

int pn_hit_with(const PnPatch *pn, const Ray *ray, PnMode mode, int proofs, PnHit *h, long *proven)
{
    PnPiece w;
    whole_piece(pn, &w);
    return trace(pn, &w, ray, mode, proofs, NULL, h, proven);
}

/* The shape of a piece whose net, box and magnitude are set, as trace
 * measures it for a ray, from the parts of its frame that do not depend on
 * the ray. */
static void piece_shape(PnPiece *pc)
{
    const double zero[3] = {0.0, 0.0, 0.0};
    PnFrame f;
    piece_frame(&pc->net, zero, zero, &f);
    pc->dev = piece_dev(&pc->net, &f, max2(maxabs3(pc->lo), maxabs3(pc->hi)));
    piece_lengths(&f, pc->len);
    PnSlope sl = piece_slope(&pc->net, &f, pc->mag);
    pc->kappa = sl.kappa;
    pc->slope = sl.L;
    pc->shaped = 1;
}

void pn_piece_init(PnPiece *pc, const PnPatch *pn)
{
    PnPiece w;
    whole_piece(pn, &w);
    pn_net_box(&pc->net, pc->lo, pc->hi);
    pc->mag = w.mag;
    piece_shape(pc);
}

int pn_hit_piece(const PnPatch *pn, const PnPiece *piece, const Ray *ray, PnMode mode, PnHit *h)
{
    return trace(pn, piece, ray, mode, 1, NULL, h, NULL);
}

/* The hit that trace returns for the nearest crossing kept, if any: 1 and
 * h when its t, rounded to a float, lies in (0, ray->tmax). */
static int best_hit(const PnBest *best, const Ray *ray, PnHit *h)
{
    if (!(best->t < ray->tmax)) /* none found */
        return 0;
    h->t = (float)best->t;
    if (!(h->t < ray->tmax) || !(h->t > 0.0f))
        return 0;
    h->terr = best->err > 0.0 ? float_up(best->err + fabs(best->t - (double)h->t)) : 0.0f;
    h->u = (float)best->u;
    h->v = (float)best->v;
    return 1;
}

/* Visits the sub-patches of the piece start (the whole patch, or a piece
 * split ahead of rays) whose box the ray enters, nearest first, and keeps
 * the nearest hit. With left, the start's own flat test and proof are
 * done, and left says what they left. */
static int trace(const PnPatch *pn, const PnPiece *start, const Ray *ray, PnMode mode, int proofs,
                 const PnStartLeft *left, PnHit *h, long *proven)
{
    PnRay r;
    to_d(ray->o, r.o);
    to_d(ray->d, r.d);
    for (int a = 0; a < 3; a++)
        r.inv[a] = 1.0 / r.d[a];
    r.tmax = ray->tmax;
    double dd = sqrt(d3_dot(r.d, r.d));
    int avx = split_avx();
    /* a depth-first stack: each split pushes at most four children */
    PnNode stack[3 * PN_MAX_DEPTH + 4];
    int top = 0;
    PnBest best = {r.tmax, 0.0, 0.0, 0.0};
    PnNode *root = &stack[top];
    /* its box first (the root reads the start's net where it lies) */
    if (!slab(start->lo, start->hi, r.o, r.d, r.inv, best.t, &root->tn, &root->tf))
        return 0;
    root->net = &start->net;
    memcpy(root->lo, start->lo, sizeof root->lo);
    memcpy(root->hi, start->hi, sizeof root->hi);
    double mroot = start->mag; /* the patch's largest coordinate */
    int depth0 = start->depth;
    root->depth = depth0;
    root->tried = 0;
    top++;
    PnPool pool;
    int splits = 0;
    const PnPiece *kept = start->shaped ? start : NULL; /* the root, popped first, may keep its shape */
    while (top > 0) {
        const PnNode *node = &stack[--top]; /* read before any push overwrites it */
        const PnPiece *shaped = kept;
        kept = NULL;
        if (node->tn >= best.t)
            continue;
        const PnNet *net = node->net;
        double m = max2(maxabs3(node->lo), maxabs3(node->hi)); /* the box's largest coordinate */
        int only, tried = node->tried;
        if (left) { /* the start's tests, done */
            only = left->only;
            tried = left->tried;
            left = NULL;
        } else {
            PnFrame frame;
            piece_frame(net, r.o, r.d, &frame);
            { /* culls a piece the ray misses before Newton's steps are spent on it */
                double t, e, u, v, own[3];
                const double *len = shaped ? shaped->len : own;
                double dev = shaped ? shaped->dev : piece_dev(net, &frame, m);
                if (!shaped)
                    piece_lengths(&frame, own);
                int f = flat_piece(net, &frame, r.d, dd, best.t, m, dev, len, &t, &e, &u, &v, &only);
                if (f == 1) /* (its interval starts before best, its midpoint may not) */
                    best_keep(&best, t, e, u, v);
                if (f >= 0)
                    continue;
            }
            /* A proof of the piece's only crossing, in exact mode, and of
             * none ahead for a ray leaving the surface (an origin in the
             * box), in both modes (fast mode's Newton below waits for the
             * origin to leave the box) */
            if (!tried && proofs && (mode == PN_EXACT || node->tn <= 0.0)) {
                double t, e, u, v;
                int c = pn_certify(pn, &r, net, &frame, shaped, dd, best.t, mroot, &t, &e, &u, &v);
                if (c == PN_CERT_MISS || (c == PN_CERT_HIT && mode == PN_EXACT)) {
                    if (proven)
                        ++*proven;
                    if (c == PN_CERT_HIT)
                        best_keep(&best, t, e, u, v);
                    continue;
                }
                tried = c == PN_UNSURE_OUTSIDE;
            }
        }
        /* Newton's method, from outside the start's box: a ray that starts
         * in it (a spawned ray, leaving the surface) needs the split that
         * culls its own spot, and Newton's steps would be spent first */
        if (mode == PN_FAST && node->depth == depth0 && node->tn > 0.0) {
            double t, u, v;
            if (newton(pn, &r, net, &t, &u, &v)) {
                best_keep(&best, t, 0.0, u, v);
                continue;
            }
            /* Newton failed here: subdivide as exact mode does */
        }
        if (node->depth == PN_MAX_DEPTH || splits == PN_MAX_SPLITS || at_float_precision(node->lo, node->hi, m)) {
            /* The exact sub-patch is inside this box: where the ray meets
             * it lies within the box's interval, in front of the origin
             * (an origin inside the box is on the surface to float
             * precision: a spawned ray, which does not hit its own spot). */
            if (node->tn > 0.0) {
                double sg = net->flip ? -net->s : net->s;
                best_keep(&best, 0.5 * (node->tn + node->tf), 0.5 * (node->tf - node->tn), net->u0 + sg / 3.0,
                          net->v0 + sg / 3.0);
            }
            continue;
        }
        /* The children's boxes straight from the pool; only those the ray
         * enters are written out, the farthest first, so that the nearest
         * comes off the stack first. */
        splits++;
        double err = split_pool(net, pool, only >= 0 ? only : PN_ALL, avx);
        double lo[4][3], hi[4][3], tn[4], tf[4];
        int order[4], n = 0;
        for (int c = only >= 0 ? only : 0; c < (only >= 0 ? only + 1 : 4); c++) {
            pool_box(pool, c, err, lo[c], hi[c], avx);
            if (slab(lo[c], hi[c], r.o, r.d, r.inv, best.t, &tn[c], &tf[c])) {
                int j = n++;
                for (; j > 0 && tn[c] > tn[order[j - 1]]; j--)
                    order[j] = order[j - 1];
                order[j] = c;
            }
        }
        /* The first child takes the parent's slot: keep its domain. */
        PnNet dom;
        dom.u0 = net->u0;
        dom.v0 = net->v0;
        dom.s = net->s;
        dom.flip = net->flip;
        int depth = node->depth + 1;
        for (int i = 0; i < n; i++) {
            int c = order[i];
            PnNode *k = &stack[top++];
            split_child_net(&dom, pool, err, c, &k->own);
            k->net = &k->own;
            memcpy(k->lo, lo[c], sizeof k->lo);
            memcpy(k->hi, hi[c], sizeof k->hi);
            k->tn = tn[c];
            k->tf = tf[c];
            k->depth = depth;
            k->tried = tried;
        }
    }
    return best_hit(&best, ray, h);
}

/* ---- four rays at a piece ---- */

#ifdef PN_AVX
/* The scalar code's operations on four doubles, one ray in each lane. */
#define PN_ADD(a, b) _mm256_add_pd(a, b)
#define PN_SUB(a, b) _mm256_sub_pd(a, b)
#define PN_MUL(a, b) _mm256_mul_pd(a, b)
#define PN_DIV(a, b) _mm256_div_pd(a, b)
#define PN_SET(x) _mm256_set1_pd(x)
#define PN_CMP(a, b, op) _mm256_cmp_pd(a, b, op)
#define PN_AND(a, b) _mm256_and_pd(a, b)
#define PN_OR(a, b) _mm256_or_pd(a, b)
#define PN_NOT_AND(a, b) _mm256_andnot_pd(a, b) /* b and not a */
/* a . b of three lanes each, summed as the scalar code sums them */
#define PN_DOT(a, b) PN_ADD(PN_ADD(PN_MUL((a)[0], (b)[0]), PN_MUL((a)[1], (b)[1])), PN_MUL((a)[2], (b)[2]))

__attribute__((target("avx"))) static inline __m256d abs4(__m256d x)
{
    return _mm256_andnot_pd(_mm256_set1_pd(-0.0), x);
}

/* max2 and its like lane by lane: MAXPD and MINPD return their second
 * operand unless the first is greater (less), as a > b ? a : b does. */
__attribute__((target("avx"))) static inline __m256d maxabs3_4(const __m256d v[3])
{
    return _mm256_max_pd(abs4(v[0]), _mm256_max_pd(abs4(v[1]), abs4(v[2])));
}

/* pn_eval for the four points (u, v) in lanes, one axis at a time: the same
 * operations as pn_eval's loop, lane by lane. */
__attribute__((target("avx"))) static inline void eval_lanes(const PnPatch *pn, __m256d u, __m256d v, __m256d pt[3],
                                                             __m256d du[3], __m256d dv[3])
{
    const float *bf = &pn->b[0].x;
    const __m256d w = PN_SUB(PN_SUB(PN_SET(1.0), u), v), three = PN_SET(3.0);
#define STEP(x, y, z) PN_ADD(PN_ADD(PN_MUL(w, x), PN_MUL(u, y)), PN_MUL(v, z))
    for (int a = 0; a < 3; a++) {
        __m256d b[10];
        for (int i = 0; i < 10; i++)
            b[i] = PN_SET((double)bf[3 * i + a]);
        __m256d q0 = STEP(b[0], b[1], b[2]), q1 = STEP(b[1], b[3], b[4]), q2 = STEP(b[2], b[4], b[5]);
        __m256d q3 = STEP(b[3], b[6], b[7]), q4 = STEP(b[4], b[7], b[8]), q5 = STEP(b[5], b[8], b[9]);
        __m256d rw = STEP(q0, q1, q2), ru = STEP(q1, q3, q4), rv = STEP(q2, q4, q5);
        if (pt)
            pt[a] = STEP(rw, ru, rv);
        if (du)
            du[a] = PN_MUL(three, PN_SUB(ru, rw));
        if (dv)
            dv[a] = PN_MUL(three, PN_SUB(rv, rw));
    }
#undef STEP
}

/* newton_uv for the rays in lanes, from (lu0, lv0) of the net's domain:
 * each lane stops where the scalar loop would. Returns the mask of lanes
 * that converged, with (u, v) there. */
__attribute__((target("avx"))) static __m256d newton_lanes(const PnPatch *pn, const __m256d o[3], const __m256d d[3],
                                                           const PnNet *net, __m256d lu0, __m256d lv0, __m256d active,
                                                           __m256d *uo, __m256d *vo)
{
    const __m256d zero = _mm256_setzero_pd(), sign = PN_SET(-0.0), big = PN_SET(DBL_MAX);
    /* ax = (d1, -d0, 0) where |d0| is the largest, else (0, d2, -d1) */
    __m256d x0 = PN_AND(PN_CMP(abs4(d[0]), abs4(d[1]), _CMP_GT_OQ), PN_CMP(abs4(d[0]), abs4(d[2]), _CMP_GT_OQ));
    __m256d ax[3] = {_mm256_blendv_pd(zero, d[1], x0), _mm256_blendv_pd(d[2], _mm256_xor_pd(d[0], sign), x0),
                     _mm256_blendv_pd(_mm256_xor_pd(d[1], sign), zero, x0)};
    __m256d la = _mm256_sqrt_pd(PN_DOT(ax, ax));
    for (int c = 0; c < 3; c++)
        ax[c] = PN_DIV(ax[c], la);
    __m256d bx[3] = {PN_SUB(PN_MUL(ax[1], d[2]), PN_MUL(ax[2], d[1])), PN_SUB(PN_MUL(ax[2], d[0]), PN_MUL(ax[0], d[2])),
                     PN_SUB(PN_MUL(ax[0], d[1]), PN_MUL(ax[1], d[0]))};
    __m256d lb = _mm256_sqrt_pd(PN_DOT(bx, bx));
    for (int c = 0; c < 3; c++)
        bx[c] = PN_DIV(bx[c], lb);
    const double sg = net->flip ? -net->s : net->s;
    __m256d u = PN_ADD(PN_SET(net->u0), PN_MUL(PN_SET(sg), lu0));
    __m256d v = PN_ADD(PN_SET(net->v0), PN_MUL(PN_SET(sg), lv0));
    const __m256d tol = PN_SET(1e-7 * net->s);
    __m256d done = zero;
    for (int it = 0; it < PN_NEWTON_STEPS && _mm256_movemask_pd(active); it++) {
        __m256d p[3], du[3], dv[3], q[3];
        eval_lanes(pn, u, v, p, du, dv);
        for (int c = 0; c < 3; c++)
            q[c] = PN_SUB(p[c], o[c]);
        __m256d f1 = PN_DOT(ax, q), f2 = PN_DOT(bx, q);
        __m256d j11 = PN_DOT(ax, du), j12 = PN_DOT(ax, dv), j21 = PN_DOT(bx, du), j22 = PN_DOT(bx, dv);
        __m256d det = PN_SUB(PN_MUL(j11, j22), PN_MUL(j12, j21));
        __m256d go = PN_AND(active, PN_CMP(abs4(det), zero, _CMP_GT_OQ)); /* else the scalar loop fails */
        __m256d su = PN_DIV(PN_SUB(PN_MUL(j22, f1), PN_MUL(j12, f2)), det);
        __m256d sv = PN_DIV(PN_SUB(PN_MUL(j11, f2), PN_MUL(j21, f1)), det);
        u = _mm256_blendv_pd(u, PN_SUB(u, su), go);
        v = _mm256_blendv_pd(v, PN_SUB(v, sv), go);
        __m256d finite = PN_AND(PN_CMP(abs4(u), big, _CMP_LE_OQ), PN_CMP(abs4(v), big, _CMP_LE_OQ));
        __m256d conv = PN_AND(PN_AND(go, finite), PN_CMP(PN_ADD(abs4(su), abs4(sv)), tol, _CMP_LE_OQ));
        done = PN_OR(done, conv);
        active = PN_NOT_AND(conv, PN_AND(go, finite));
    }
    *uo = u;
    *vo = v;
    return done;
}

/* The barycentrics of B and C (flat_piece's lb and lc, pn_certify's lu0
 * and lv0) of p's projection on the plane of A, A + e1, A + e2, p from A. */
__attribute__((target("avx"))) static inline void bary_lanes(const __m256d p[3], const __m256d e1[3],
                                                             const __m256d e2[3], const __m256d n[3], __m256d nn2,
                                                             __m256d *lb, __m256d *lc)
{
    __m256d c2[3] = {PN_SUB(PN_MUL(p[1], e2[2]), PN_MUL(p[2], e2[1])), PN_SUB(PN_MUL(p[2], e2[0]), PN_MUL(p[0], e2[2])),
                     PN_SUB(PN_MUL(p[0], e2[1]), PN_MUL(p[1], e2[0]))};
    __m256d c1[3] = {PN_SUB(PN_MUL(e1[1], p[2]), PN_MUL(e1[2], p[1])), PN_SUB(PN_MUL(e1[2], p[0]), PN_MUL(e1[0], p[2])),
                     PN_SUB(PN_MUL(e1[0], p[1]), PN_MUL(e1[1], p[0]))};
    *lb = PN_DIV(PN_DOT(c2, n), nn2);
    *lc = PN_DIV(PN_DOT(c1, n), nn2);
}

/* What start_lanes settled of a ray at its start piece. */
enum { PN_LANE_MISS, PN_LANE_HIT, PN_LANE_LEFT, PN_LANE_ALONE };

/* slab for the rays in lanes: the lanes that enter the box before tmax,
 * with their entry distances in tn. */
__attribute__((target("avx"))) static inline __m256d slab_lanes(const double lo[3], const double hi[3],
                                                                const __m256d o[3], const __m256d d[3],
                                                                const __m256d inv[3], __m256d tmax, __m256d *tn)
{
    const __m256d zero = _mm256_setzero_pd(), pad = PN_SET(4.0 * DBL_EPSILON);
    __m256d n = PN_SET(-INFINITY), f = PN_SET(INFINITY), out = zero;
    for (int a = 0; a < 3; a++) {
        __m256d l = PN_SET(lo[a]), h = PN_SET(hi[a]);
        /* parallel to the slab: outside it, a miss; inside, no bound */
        __m256d par = PN_CMP(d[a], zero, _CMP_EQ_OQ);
        out = PN_OR(out, PN_AND(par, PN_OR(PN_CMP(o[a], l, _CMP_LT_OQ), PN_CMP(o[a], h, _CMP_GT_OQ))));
        __m256d t0 = PN_MUL(PN_SUB(l, o[a]), inv[a]), t1 = PN_MUL(PN_SUB(h, o[a]), inv[a]);
        __m256d sw = PN_CMP(t0, t1, _CMP_GT_OQ), a0 = _mm256_blendv_pd(t0, t1, sw), a1 = _mm256_blendv_pd(t1, t0, sw);
        n = _mm256_blendv_pd(_mm256_max_pd(a0, n), n, par);
        f = _mm256_blendv_pd(_mm256_min_pd(a1, f), f, par);
    }
    n = PN_SUB(n, PN_MUL(abs4(n), pad));
    f = PN_ADD(f, PN_MUL(abs4(f), pad));
    *tn = n;
    __m256d miss = PN_OR(PN_OR(PN_CMP(n, f, _CMP_GT_OQ), PN_CMP(f, zero, _CMP_LE_OQ)), PN_CMP(n, tmax, _CMP_GE_OQ));
    return PN_NOT_AND(PN_OR(out, miss), _mm256_castsi256_pd(_mm256_set1_epi64x(-1)));
}

/* trace's first steps for the rays ray[k[0..3]] at a shaped piece pc:
 * slab, piece_frame, flat_piece and pn_certify, the same operations lane
 * by lane. state[j] for ray k[j]: a miss; a hit (best[j]); the split left
 * (left[j]); or PN_LANE_ALONE, a piece flat to float precision, which
 * trace settles. */
__attribute__((target("avx"))) static void start_lanes(const PnPatch *pn, const PnPiece *pc, const Ray *ray,
                                                        const int k[4], PnMode mode, int state[4], PnBest best[4],
                                                        PnStartLeft left[4])
{
    const PnNet *net = &pc->net;
    const __m256d zero = _mm256_setzero_pd(), S = PN_SET(PN_SLACK), one = PN_SET(1.0);
    __m128 rf[RAY_FIELDS];
    ray_fields(ray, k, rf);
    __m256d o[3], d[3], inv[3];
    for (int a = 0; a < 3; a++) {
        o[a] = _mm256_cvtps_pd(rf[RAY_O + a]);
        d[a] = _mm256_cvtps_pd(rf[RAY_D + a]);
        inv[a] = PN_DIV(one, d[a]);
    }
    const __m256d tmax = _mm256_cvtps_pd(rf[RAY_TMAX]);
    __m256d tn, enter = slab_lanes(pc->lo, pc->hi, o, d, inv, tmax, &tn);
    const __m256d dd = _mm256_sqrt_pd(PN_DOT(d, d));
    /* piece_frame: all but q and n.d the piece's own */
    const double zo[3] = {0.0, 0.0, 0.0};
    PnFrame f;
    piece_frame(net, zo, zo, &f);
    const double m = max2(maxabs3(pc->lo), maxabs3(pc->hi)), dev = pc->dev;
    __m256d q[3], e1[3], e2[3], n[3];
    for (int a = 0; a < 3; a++) {
        q[a] = PN_SUB(o[a], PN_SET(f.A[a]));
        e1[a] = PN_SET(f.e1[a]);
        e2[a] = PN_SET(f.e2[a]);
        n[a] = PN_SET(f.n[a]);
    }
    const __m256d nd = PN_DOT(n, d), nn2 = PN_SET(f.nn2);
    const double nns = sqrt(f.nn2);
    const __m256d nn = PN_SET(nns);
    const int me = _mm256_movemask_pd(enter);
    for (int j = 0; j < 4; j++) {
        state[j] = me >> j & 1 ? PN_LANE_LEFT : PN_LANE_MISS;
        left[j] = (PnStartLeft){-1, 0};
        best[j] = (PnBest){ray[k[j]].tmax, 0.0, 0.0, 0.0};
    }
    if (!me)
        return;
    /* flat_piece */
    __m256d undecided = enter; /* lanes neither culled nor flat */
    __m256d only = PN_SET(-1.0);
    __m256d nq = PN_DOT(n, q);
    if (nns > 0.0) {
        const int flat = dev <= m * (double)FLT_EPSILON;
        __m256d steep = PN_CMP(abs4(nd), PN_MUL(PN_MUL(PN_SET(0.25), nn), dd), _CMP_GE_OQ);
        __m256d qm = maxabs3_4(q);
        __m256d h = PN_MUL(PN_SET(norm1(f.n)), PN_ADD(PN_SET(dev), PN_MUL(S, PN_ADD(PN_SET(m), qm))));
        __m256d t1 = PN_DIV(PN_SUB(_mm256_xor_pd(h, PN_SET(-0.0)), nq), nd), t2 = PN_DIV(PN_SUB(h, nq), nd);
        __m256d sw = PN_CMP(t1, t2, _CMP_GT_OQ), lo1 = _mm256_blendv_pd(t1, t2, sw), hi2 = _mm256_blendv_pd(t2, t1, sw);
        t1 = PN_SUB(lo1, PN_MUL(abs4(lo1), S));
        t2 = PN_ADD(hi2, PN_MUL(abs4(hi2), S));
        __m256d cull = PN_OR(PN_CMP(t2, zero, _CMP_LE_OQ), PN_CMP(t1, tmax, _CMP_GE_OQ));
        if (flat)
            cull = PN_OR(cull, PN_AND(steep, PN_CMP(t1, zero, _CMP_LE_OQ)));
        __m256d ta = _mm256_max_pd(t1, zero), tb = _mm256_min_pd(t2, tmax);
        __m256d tm = PN_MUL(PN_SET(0.5), PN_ADD(ta, tb)), p[3];
        for (int a = 0; a < 3; a++)
            p[a] = PN_ADD(q[a], PN_MUL(tm, d[a]));
        __m256d lb, lc;
        bary_lanes(p, e1, e2, n, nn2, &lb, &lc);
        __m256d la = PN_SUB(PN_SUB(one, lb), lc);
        __m256d pm = maxabs3_4(p);
        __m256d rad = PN_ADD(PN_ADD(PN_MUL(PN_SET(dev), PN_SET(1.7320508075688774)),
                                    PN_MUL(PN_MUL(PN_SET(0.5), PN_SUB(tb, ta)), dd)),
                             PN_MUL(S, PN_ADD(pm, PN_SET(m))));
        __m256d g = PN_DIV(PN_MUL(PN_SET(1.0 + PN_SLACK), rad), nn), ng = _mm256_xor_pd(g, PN_SET(-0.0));
        const __m256d l1 = PN_SET(pc->len[0]), l2 = PN_SET(pc->len[1]), l3 = PN_SET(pc->len[2]);
        cull = PN_OR(cull, PN_OR(PN_CMP(la, PN_MUL(ng, l3), _CMP_LT_OQ),
                                 PN_OR(PN_CMP(lb, PN_MUL(ng, l2), _CMP_LT_OQ), PN_CMP(lc, PN_MUL(ng, l1), _CMP_LT_OQ))));
        __m256d gl3 = PN_MUL(g, l3), gl2 = PN_MUL(g, l2), gl1 = PN_MUL(g, l1), half = PN_SET(0.5);
        /* flat_piece's only, picked in its order: the first that holds */
        __m256d o0 = PN_CMP(PN_SUB(la, half), gl3, _CMP_GT_OQ), o1 = PN_CMP(PN_SUB(lb, half), gl2, _CMP_GT_OQ);
        __m256d o2 = PN_CMP(PN_SUB(lc, half), gl1, _CMP_GT_OQ);
        __m256d o3 = PN_AND(PN_CMP(PN_SUB(half, la), gl3, _CMP_GT_OQ),
                            PN_AND(PN_CMP(PN_SUB(half, lb), gl2, _CMP_GT_OQ), PN_CMP(PN_SUB(half, lc), gl1, _CMP_GT_OQ)));
        only = _mm256_blendv_pd(only, PN_SET(3.0), o3);
        only = _mm256_blendv_pd(only, PN_SET(2.0), o2);
        only = _mm256_blendv_pd(only, PN_SET(1.0), o1);
        only = _mm256_blendv_pd(only, zero, o0);
        __m256d alone = flat ? PN_NOT_AND(cull, steep) : zero; /* flat to float precision: a hit */
        undecided = PN_NOT_AND(PN_OR(cull, alone), undecided);
        int mc = _mm256_movemask_pd(cull), ma = _mm256_movemask_pd(alone);
        for (int j = 0; j < 4; j++) {
            if (mc >> j & 1)
                state[j] = PN_LANE_MISS;
            else if ((ma & me) >> j & 1)
                state[j] = PN_LANE_ALONE;
        }
    }
    double onl[4];
    _mm256_storeu_pd(onl, only);
    for (int j = 0; j < 4; j++)
        left[j].only = (int)onl[j];
    /* pn_certify, where trace tries it */
    __m256d act = mode == PN_EXACT ? undecided : PN_AND(undecided, PN_CMP(tn, zero, _CMP_LE_OQ));
    if (!_mm256_movemask_pd(act) || !(pc->kappa > 0.0))
        return;
    const double L = pc->slope, kappa = pc->kappa;
    __m256d tp = PN_DIV(_mm256_xor_pd(nq, PN_SET(-0.0)), nd), qq[3];
    for (int a = 0; a < 3; a++)
        qq[a] = PN_ADD(q[a], PN_MUL(tp, d[a]));
    __m256d lu0, lv0;
    bary_lanes(qq, e1, e2, n, nn2, &lu0, &lv0);
    __m256d go = PN_AND(act, PN_AND(PN_AND(PN_CMP(lu0, PN_SET(-0.5), _CMP_GT_OQ), PN_CMP(lv0, PN_SET(-0.5), _CMP_GT_OQ)),
                                    PN_CMP(PN_ADD(lu0, lv0), PN_SET(1.5), _CMP_LT_OQ)));
    __m256d nxd[3] = {PN_SUB(PN_MUL(n[1], d[2]), PN_MUL(n[2], d[1])), PN_SUB(PN_MUL(n[2], d[0]), PN_MUL(n[0], d[2])),
                      PN_SUB(PN_MUL(n[0], d[1]), PN_MUL(n[1], d[0]))};
    __m256d dxi = PN_ADD(PN_MUL(PN_DIV(_mm256_sqrt_pd(PN_DOT(nxd, nxd)), nn), PN_SET(1.0 + PN_SLACK)), PN_MUL(S, dd));
    __m256d rate = PN_SUB(PN_SUB(PN_DIV(abs4(nd), nn), PN_MUL(PN_SET(L), dxi)), PN_MUL(PN_MUL(S, dd), PN_SET(1.0 + L)));
    go = PN_AND(go, PN_CMP(rate, zero, _CMP_GT_OQ));
    if (!_mm256_movemask_pd(go))
        return;
    __m256d nu, nv;
    go = newton_lanes(pn, o, d, net, lu0, lv0, go, &nu, &nv);
    if (!_mm256_movemask_pd(go))
        return;
    const double sg = net->flip ? -net->s : net->s;
    __m256d lu = PN_DIV(PN_SUB(nu, PN_SET(net->u0)), PN_SET(sg)), lv = PN_DIV(PN_SUB(nv, PN_SET(net->v0)), PN_SET(sg));
    __m256d edge = _mm256_min_pd(lu, lv), far = PN_MUL(PN_SUB(PN_SUB(one, lu), lv), PN_SET(0.7071067811865476));
    edge = PN_SUB(PN_SUB(_mm256_min_pd(far, edge), PN_SET(4.0 * DBL_EPSILON / net->s)), S);
    __m256d outside = PN_NOT_AND(PN_CMP(edge, zero, _CMP_GT_OQ), go);
    go = PN_NOT_AND(outside, go);
    __m256d P[3];
    eval_lanes(pn, nu, nv, P, NULL, NULL);
    __m256d ts = PN_DIV(PN_ADD(PN_ADD(PN_MUL(PN_SUB(P[0], o[0]), d[0]), PN_MUL(PN_SUB(P[1], o[1]), d[1])),
                               PN_MUL(PN_SUB(P[2], o[2]), d[2])),
                        PN_MUL(dd, dd));
    __m256d rho = zero;
    for (int a = 0; a < 3; a++) {
        __m256d x = PN_SUB(PN_ADD(o[a], PN_MUL(ts, d[a])), P[a]);
        rho = a ? PN_ADD(rho, PN_MUL(x, x)) : PN_MUL(x, x); /* 0.0 + x * x is x * x */
    }
    rho = PN_ADD(PN_MUL(_mm256_sqrt_pd(rho), PN_SET(1.0 + PN_SLACK)),
                 PN_MUL(PN_SET(1.7320508075688774 * PN_SLACK),
                        PN_ADD(PN_ADD(PN_SET(pc->mag), maxabs3_4(o)), PN_MUL(abs4(ts), dd))));
    __m256d w = PN_MUL(PN_DIV(PN_MUL(PN_SET(1.0 + L), rho), rate), PN_SET(1.0 + PN_SLACK));
    __m256d tlo = PN_SUB(ts, w), thi = PN_ADD(ts, w);
    __m256d miss = PN_AND(go, PN_OR(PN_CMP(thi, zero, _CMP_LT_OQ), PN_CMP(tlo, tmax, _CMP_GT_OQ)));
    __m256d hit = PN_AND(PN_CMP(tlo, zero, _CMP_GT_OQ), PN_CMP(thi, tmax, _CMP_LT_OQ));
    hit = PN_AND(hit, PN_CMP(w, PN_MUL(ts, PN_SET(0.5 * (double)FLT_EPSILON)), _CMP_LE_OQ));
    hit = PN_AND(hit, PN_CMP(PN_ADD(PN_MUL(dxi, w), rho), PN_MUL(PN_MUL(PN_SET(kappa), edge), PN_SET(1.0 - PN_SLACK)),
                             _CMP_LT_OQ));
    hit = PN_NOT_AND(miss, PN_AND(go, hit));
    int mm = _mm256_movemask_pd(miss), mh = _mm256_movemask_pd(hit), mo = _mm256_movemask_pd(outside);
    double tsv[4], wv[4], uv[4], vv[4];
    _mm256_storeu_pd(tsv, ts);
    _mm256_storeu_pd(wv, w);
    _mm256_storeu_pd(uv, nu);
    _mm256_storeu_pd(vv, nv);
    for (int j = 0; j < 4; j++) {
        if (mm >> j & 1)
            state[j] = PN_LANE_MISS;
        else if ((mh >> j & 1) && mode == PN_EXACT) {
            state[j] = PN_LANE_HIT;
            best[j] = (PnBest){tsv[j], wv[j], uv[j], vv[j]};
        } else if (mo >> j & 1)
            left[j].tried = 1;
    }
}
#endif

unsigned pn_hit_piece_rays(const PnPatch *pn, const PnPiece *piece, const Ray *ray, unsigned rays, PnMode mode,
                           PnHit *h)
{
    unsigned hit = 0;
#ifdef PN_AVX
    const int avx = split_avx();
    PnPiece whole;
    if (!piece && (rays & (rays - 1)) && avx) { /* the whole patch, its shape measured once for all */
        whole_piece(pn, &whole);
        piece_shape(&whole);
        piece = &whole;
    }
    if (piece && piece->shaped && avx)
        while (rays & (rays - 1)) { /* two rays or more: up to four at a time (lanes past n repeat the first) */
            int k[4] = {0, 0, 0, 0}, n = 0;
            for (; n < 4 && rays; rays &= rays - 1)
                k[n++] = __builtin_ctz(rays);
            for (int j = n; j < 4; j++)
                k[j] = k[0];
            int state[4];
            PnBest best[4];
            PnStartLeft left[4];
            start_lanes(pn, piece, ray, k, mode, state, best, left);
            for (int j = 0; j < n; j++) {
                int got = 0;
                if (state[j] == PN_LANE_HIT)
                    got = best_hit(&best[j], &ray[k[j]], &h[k[j]]);
                else if (state[j] != PN_LANE_MISS)
                    got = trace(pn, piece, &ray[k[j]], mode, 1, state[j] == PN_LANE_LEFT ? &left[j] : NULL, &h[k[j]],
                                NULL);
                hit |= (unsigned)got << k[j];
            }
        }
#endif
    for (; rays; rays &= rays - 1) { /* the rest one by one */
        int j = __builtin_ctz(rays);
        hit |= (unsigned)(piece ? trace(pn, piece, &ray[j], mode, 1, NULL, &h[j], NULL) : pn_hit(pn, &ray[j], mode, &h[j]))
               << j;
    }
    return hit;
}
