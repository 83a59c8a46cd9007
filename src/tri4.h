/*
 * tri4.h - the body of prim_tri4_hit_watertight (prim.h), inline so that
 * the BVH traversal compiles it into its loop: no call there, and in the
 * AVX2 build of bvh_traverse.c, VEX code. Only prim.c and bvh_traverse.c
 * include it. The same operations in the same order in every build: the
 * lanes' bits never depend on it.
 */
#ifndef LANCER_TRI4_H
#define LANCER_TRI4_H

#include <float.h>

#include "lancer/prim.h"

#if defined(__SSE2__) && !defined(LANCER_NO_SIMD)
#define TRI4_SSE 1
#include <emmintrin.h>
#endif

/* prim.c's gamma_f(n), as a constant */
#define TRI4_GAMMA(n) ((float)((n) * (0.5 * (double)FLT_EPSILON) / (1.0 - (n) * (0.5 * (double)FLT_EPSILON))))

#ifdef TRI4_SSE
#define TRI4_ABS(x) _mm_andnot_ps(_mm_set1_ps(-0.0f), x)

/* prim.c's edge_err() on four lanes, operation for operation. */
static inline __m128 tri4_edge_err(__m128 xi, __m128 yi, __m128 exi, __m128 eyi, __m128 xj, __m128 yj, __m128 exj, __m128 eyj)
{
    __m128 m = _mm_add_ps(TRI4_ABS(_mm_mul_ps(xi, yj)), TRI4_ABS(_mm_mul_ps(yi, xj)));
    __m128 d = _mm_add_ps(_mm_mul_ps(exi, TRI4_ABS(yj)), _mm_mul_ps(eyj, TRI4_ABS(xi)));
    d = _mm_add_ps(d, _mm_mul_ps(eyi, TRI4_ABS(xj)));
    d = _mm_add_ps(d, _mm_mul_ps(exj, TRI4_ABS(yi)));
    d = _mm_add_ps(d, _mm_mul_ps(exi, eyj));
    d = _mm_add_ps(d, _mm_mul_ps(eyi, exj));
    return _mm_add_ps(_mm_mul_ps(_mm_set1_ps(TRI4_GAMMA(3)), m), _mm_mul_ps(d, _mm_set1_ps(1.0f + TRI4_GAMMA(3))));
}
#endif

static inline int tri4_hit_watertight(const PrimTri4 *t, int lanes, const PrimTriRay *p, const Ray *r, PrimHit4 *h)
{
    int hit = 0, slow = lanes;
#ifdef TRI4_SSE
    if (p->simd) {
        /* prim.c's watertight() on four lanes, in the same operations and order, so
         * each lane gets the same bits; lanes with an uncertain edge take
         * the scalar routine and its double path. */
        const __m128 g5 = _mm_set1_ps(TRI4_GAMMA(5)), zero = _mm_setzero_ps();
        const __m128 ox = _mm_set1_ps(p->o[p->kx]), oy = _mm_set1_ps(p->o[p->ky]), oz = _mm_set1_ps(p->o[p->kz]);
        const __m128 sx = _mm_set1_ps(p->sx), sy = _mm_set1_ps(p->sy);
        /* One bound for the three edges, from the largest magnitudes:
         * edge_err is monotone in each argument and rounding is monotone,
         * so it is at least each edge's own bound, at a third of the cost.
         * A lane it cannot decide takes the scalar routine, which applies
         * the per-edge bounds: the verdict's bits are the same. */
        __m128 mx0 = zero, my0 = zero, mz_len = zero;
        /* (written out: a loop over arrays of vectors is not unrolled at -O2) */
#define VERTEX(k, X, Y, Z)                                                                              \
    __m128 X = _mm_sub_ps(_mm_loadu_ps(t->v[k][p->kx]), ox), Y = _mm_sub_ps(_mm_loadu_ps(t->v[k][p->ky]), oy); \
    __m128 Z = _mm_sub_ps(_mm_loadu_ps(t->v[k][p->kz]), oz);                                            \
    mx0 = _mm_max_ps(mx0, TRI4_ABS(X));                                                                 \
    my0 = _mm_max_ps(my0, TRI4_ABS(Y));                                                                 \
    mz_len = _mm_max_ps(mz_len, TRI4_ABS(Z));                                                           \
    X = _mm_add_ps(X, _mm_mul_ps(sx, Z));                                                               \
    Y = _mm_add_ps(Y, _mm_mul_ps(sy, Z))
        VERTEX(0, ax, ay, az);
        VERTEX(1, bx, by, bz);
        VERTEX(2, cx, cy, cz);
#undef VERTEX
#define MAX3(a, b, c) _mm_max_ps(TRI4_ABS(a), _mm_max_ps(TRI4_ABS(b), TRI4_ABS(c)))
        __m128 mx = MAX3(ax, bx, cx), my = MAX3(ay, by, cy);
        __m128 ex = _mm_mul_ps(g5, _mm_add_ps(mx0, mz_len)), ey = _mm_mul_ps(g5, _mm_add_ps(my0, mz_len));
        __m128 e[3];
        e[0] = _mm_sub_ps(_mm_mul_ps(bx, cy), _mm_mul_ps(by, cx));
        e[1] = _mm_sub_ps(_mm_mul_ps(cx, ay), _mm_mul_ps(cy, ax));
        e[2] = _mm_sub_ps(_mm_mul_ps(ax, by), _mm_mul_ps(ay, bx));
        __m128 emin = _mm_min_ps(TRI4_ABS(e[0]), _mm_min_ps(TRI4_ABS(e[1]), TRI4_ABS(e[2])));
        __m128 unsure = _mm_cmple_ps(emin, tri4_edge_err(mx, my, ex, ey, mx, my, ex, ey));
        /* edges of both signs: the ray passes outside (a NaN lane, from
         * an overflow, is never hit: its t is NaN too) */
        __m128 emn = _mm_min_ps(e[0], _mm_min_ps(e[1], e[2])), emx = _mm_max_ps(e[0], _mm_max_ps(e[1], e[2]));
        __m128 det = _mm_add_ps(_mm_add_ps(e[0], e[1]), e[2]);
        __m128 sz = _mm_set1_ps(p->sz);
        __m128 azs = _mm_mul_ps(az, sz), bzs = _mm_mul_ps(bz, sz), czs = _mm_mul_ps(cz, sz);
        __m128 ts = _mm_add_ps(_mm_add_ps(_mm_mul_ps(e[0], azs), _mm_mul_ps(e[1], bzs)), _mm_mul_ps(e[2], czs));
        __m128 tmax = _mm_set1_ps(r->tmax), tmd = _mm_mul_ps(tmax, det);
        __m128 neg = _mm_cmplt_ps(det, zero);
        __m128 out_neg = _mm_or_ps(_mm_cmpge_ps(ts, zero), _mm_cmplt_ps(ts, tmd));
        __m128 out_pos = _mm_or_ps(_mm_cmple_ps(ts, zero), _mm_cmpgt_ps(ts, tmd));
        __m128 out = _mm_or_ps(_mm_and_ps(_mm_cmplt_ps(emn, zero), _mm_cmpgt_ps(emx, zero)), _mm_cmpeq_ps(det, zero));
        out = _mm_or_ps(out, _mm_or_ps(_mm_and_ps(neg, out_neg), _mm_andnot_ps(neg, out_pos)));
        int u = _mm_movemask_ps(unsure);
        slow = lanes & u;
        hit = lanes & ~u & ~_mm_movemask_ps(out);
        if (hit) { /* most leaves a ray reaches are missed by here: no division */
            __m128 inv = _mm_div_ps(_mm_set1_ps(1.0f), det), tv = _mm_mul_ps(ts, inv);
            hit &= _mm_movemask_ps(_mm_and_ps(_mm_cmpgt_ps(tv, zero), _mm_cmplt_ps(tv, tmax)));
            _mm_storeu_ps(h->t, tv);
            if (hit) {
                /* the rest of watertight() for the lanes hit, in its order (a
                 * lane hit has no NaN, so MAXPS is max3 there) */
                __m128 mz = MAX3(azs, bzs, czs), me = MAX3(e[0], e[1], e[2]);
#undef MAX3
                __m128 dxe = _mm_mul_ps(g5, _mm_add_ps(mx, mz_len)), dye = _mm_mul_ps(g5, _mm_add_ps(my, mz_len));
                __m128 g3 = _mm_set1_ps(TRI4_GAMMA(3)), dze = _mm_mul_ps(g3, mz);
                __m128 de = _mm_add_ps(_mm_mul_ps(_mm_mul_ps(_mm_set1_ps(TRI4_GAMMA(2)), mx), my), _mm_mul_ps(dye, mx));
                de = _mm_mul_ps(_mm_set1_ps(2.0f), _mm_add_ps(de, _mm_mul_ps(dxe, my)));
                __m128 te = _mm_add_ps(_mm_mul_ps(_mm_mul_ps(g3, me), mz), _mm_mul_ps(de, mz));
                te = _mm_mul_ps(_mm_mul_ps(_mm_set1_ps(3.0f), _mm_add_ps(te, _mm_mul_ps(dze, me))), TRI4_ABS(inv));
                _mm_storeu_ps(h->terr, te);
                _mm_storeu_ps(h->u, _mm_mul_ps(e[1], inv));
                _mm_storeu_ps(h->v, _mm_mul_ps(e[2], inv));
                for (int i = 0; i < 4; i++)
                    if (hit >> i & 1)
                        h->terr[i] = prim_terr_up(h->terr[i], h->t[i]);
            }
        }
    }
#else
    (void)p;
#endif
    for (int i = 0; i < 4; i++) {
        PrimHit g;
        if (slow >> i & 1 && prim_tri4_lane_hit(t, i, p, r, &g)) {
            h->t[i] = g.t;
            h->terr[i] = g.terr;
            h->u[i] = g.u;
            h->v[i] = g.v;
            hit |= 1 << i;
        }
    }
    return hit;
}

#endif
