/*
 * tri_ray.h - the ray's set-up for the watertight triangle test (private to
 * src/): the axes and shear of Woop, Benthin and Wald 2013, computed once
 * per ray (PrimTriRay, prim.h). tri.c's scalar test and tri4.h's SIMD lanes
 * both read it; the any-hit traversal inlines it, so that it sets its ray up
 * without a call.
 */
#ifndef LANCER_TRI_RAY_H
#define LANCER_TRI_RAY_H

#include <float.h>
#include <math.h>
#include <stdint.h>

#include "lancer/prim.h"

#if defined(__AVX2__) && !defined(LANCER_NO_SIMD)
#include <immintrin.h>
#include "ray_lanes.h"
#endif

/* Inline even where GCC would call: in the traversal's loops a call
 * costs the registers it saves, and the leaf test is the innermost work. */
#ifdef __GNUC__
#define TRI_INLINE static inline __attribute__((always_inline))
#else
#define TRI_INLINE static inline
#endif

/* Directions whose largest component is shorter or longer than these are
 * scaled by a power of two before the watertight test's shear (1/dz could
 * overflow), and the SIMD lanes leave them to the scalar routine. */
#define TRI_RESCALE_MIN 0x1p-60f
#define TRI_RESCALE_MAX 0x1p60f

/* The watertight test past float's normal range (tri.c, and the lanes the
 * same). The shear's error is taken from coordinates no less than
 * TRI_SHEAR_FLOOR: each edge bound is then at least 2 (gamma(5) 2^-30)^2
 * > 2^-103, more than its products' underflow (2^-150 each, where no
 * relative bound holds), and an edge function the test is sure of is a
 * normal float. And t's float bound stops holding past TRI_T_HUGE, where
 * |t det| overflows or is a NaN (vertices about 2^42 from the ray's
 * origin; |t det| is at most 2^23 times its bound), or where the bound or
 * the largest edge function is below TRI_T_TINY and products underflow:
 * such a t is taken in double. */
#define TRI_SHEAR_FLOOR 0x1p-30f
#define TRI_T_TINY 0x1p-104f
#define TRI_T_HUGE 0x1p100f

static inline int tri_t_out_of_range(float tserr, float me)
{
    /* (a NaN tserr fails the second test; the lanes test tserr alone, since
     * an me they are sure of is at least TRI_T_TINY) */
    const float least = tserr < me ? tserr : me;
    return !(least >= TRI_T_TINY && tserr <= TRI_T_HUGE);
}

/* prim_triray_init (prim.h), which calls this. kz is the axis of the
 * largest |d|, from a = |dx| > |dy|, b = |dx| > |dz| and c = |dy| > |dz|:
 * kz = a & b ? 0 : !a & c ? 1 : 2 (a NaN, false in every comparison, gives
 * 2), and kx, ky the next two, keeping the winding; without branches (a
 * random ray's were mispredicted). */
TRI_INLINE void tri_ray_init(PrimTriRay *p, const Ray *r)
{
    const float d[3] = {r->d.x, r->d.y, r->d.z};
#if defined(__AVX2__) && !defined(LANCER_NO_SIMD)
    static const uint8_t axes[8] = {0x24, 0x24, 0x12, 0x24, 0x24, 0x09, 0x12, 0x09}; /* kx | ky << 2 | kz << 4 */
    /* With AVX2, the comparisons four lanes at once and the three
     * divisions in one (each lane rounds as alone). Built for SSE2 alone,
     * this form would take more instructions than the scalar one. */
    const __m128 ad = _mm_andnot_ps(_mm_set1_ps(-0.0f), _mm_setr_ps(d[0], d[1], d[2], 0.0f));
    int ac = _mm_movemask_ps(_mm_cmpgt_ps(ad, _mm_shuffle_ps(ad, ad, _MM_SHUFFLE(3, 2, 2, 1)))) & 3;
    int b = _mm_movemask_ps(_mm_cmpgt_ps(ad, _mm_shuffle_ps(ad, ad, _MM_SHUFFLE(3, 2, 2, 2)))) & 1;
    int k = axes[ac | b << 2];
    /* the largest |d| within the bounds and every |d| finite: every |d| <=
     * the upper one (false for inf and NaN), and one >= the lower */
    int below = _mm_movemask_ps(_mm_cmple_ps(ad, _mm_set1_ps(TRI_RESCALE_MAX))) & 7;
    int above = _mm_movemask_ps(_mm_cmpge_ps(ad, _mm_set1_ps(TRI_RESCALE_MIN))) & 7;
    int simd = below == 7 && above != 0;
    int kx = k & 3, ky = k >> 2 & 3, kz = k >> 4;
#else
    /* by arithmetic here: fewer instructions than by table */
    int a = fabsf(d[0]) > fabsf(d[1]), b = fabsf(d[0]) > fabsf(d[2]), c = fabsf(d[1]) > fabsf(d[2]);
    int kz = 2 - 2 * (a & b) - ((1 - a) & c);
    static const int next[3] = {1, 2, 0};
    int kx = next[kz], ky = next[kx];
    float m = fabsf(d[kz]);
#endif
    p->kx = kx;
    p->ky = ky;
    p->kz = kz;
    p->o[0] = r->o.x;
    p->o[1] = r->o.y;
    p->o[2] = r->o.z;
#if defined(__AVX2__) && !defined(LANCER_NO_SIMD)
    p->simd = simd;
    float q[4];
    _mm_storeu_ps(q, _mm_div_ps(_mm_setr_ps(-d[kx], -d[ky], 1.0f, 1.0f), _mm_setr_ps(d[kz], d[kz], d[kz], 1.0f)));
    p->sx = q[0];
    p->sy = q[1];
    p->sz = q[2];
#else
    p->simd = !(m < TRI_RESCALE_MIN || m > TRI_RESCALE_MAX) && isfinite(r->d.x) && isfinite(r->d.y) && isfinite(r->d.z);
    p->sx = -d[kx] / d[kz];
    p->sy = -d[ky] / d[kz];
    p->sz = 1.0f / d[kz];
#endif
}

#if defined(__AVX2__) && !defined(LANCER_NO_SIMD)
/* tri_ray_init for the rays r[0 .. n-1] (n <= 8) at once, a ray a lane,
 * into *p[k]: the same comparisons and divisions, lane by lane, so the
 * same bits. A packet's rays set up together where most of them go on to
 * test triangles: one division of eight lanes for each of sx, sy and sz
 * instead of one of four per ray. */
TRI_INLINE void tri_ray_init8(const Ray *r, int n, PrimTriRay *const p[8])
{
    int at[8];
    for (int k = 0; k < 8; k++)
        at[k] = k < n ? k : 0;
    __m256 f[RAY_FIELDS];
    ray_fields8(r, at, f);
    const __m256 sign = _mm256_set1_ps(-0.0f), dx = f[RAY_D], dy = f[RAY_D + 1], dz = f[RAY_D + 2];
    const __m256 ax = _mm256_andnot_ps(sign, dx), ay = _mm256_andnot_ps(sign, dy), az = _mm256_andnot_ps(sign, dz);
    /* kz = a & b ? 0 : !a & c ? 1 : 2, as tri_ray_init's table: x where
     * kz is 0, y where it is 1 */
    const __m256 a = _mm256_cmp_ps(ax, ay, _CMP_GT_OS), c = _mm256_cmp_ps(ay, az, _CMP_GT_OS);
    const __m256 x = _mm256_and_ps(a, _mm256_cmp_ps(ax, az, _CMP_GT_OS)), y = _mm256_andnot_ps(a, c);
    const __m256 dkz = _mm256_blendv_ps(_mm256_blendv_ps(dz, dy, y), dx, x);
    const __m256 dkx = _mm256_blendv_ps(_mm256_blendv_ps(dx, dz, y), dy, x);
    const __m256 dky = _mm256_blendv_ps(_mm256_blendv_ps(dy, dx, y), dz, x);
    float s[3][8];
    _mm256_storeu_ps(s[0], _mm256_div_ps(_mm256_xor_ps(dkx, sign), dkz));
    _mm256_storeu_ps(s[1], _mm256_div_ps(_mm256_xor_ps(dky, sign), dkz));
    _mm256_storeu_ps(s[2], _mm256_div_ps(_mm256_set1_ps(1.0f), dkz));
    const __m256 hi = _mm256_set1_ps(TRI_RESCALE_MAX), lo = _mm256_set1_ps(TRI_RESCALE_MIN);
    /* every |d| <= the upper bound (false for inf and NaN), and one >= the lower */
    const __m256 below = _mm256_and_ps(_mm256_cmp_ps(ax, hi, _CMP_LE_OS), _mm256_cmp_ps(ay, hi, _CMP_LE_OS));
    const __m256 above = _mm256_or_ps(_mm256_cmp_ps(ax, lo, _CMP_GE_OS), _mm256_cmp_ps(ay, lo, _CMP_GE_OS));
    const int simd = _mm256_movemask_ps(_mm256_and_ps(_mm256_and_ps(below, _mm256_cmp_ps(az, hi, _CMP_LE_OS)),
                                                      _mm256_or_ps(above, _mm256_cmp_ps(az, lo, _CMP_GE_OS))));
    const int mx = _mm256_movemask_ps(x), my = _mm256_movemask_ps(y);
    for (int k = 0; k < n; k++) {
        PrimTriRay *q = p[k];
        const int kz = mx >> k & 1 ? 0 : my >> k & 1 ? 1 : 2;
        q->kx = kz == 2 ? 0 : kz + 1;
        q->ky = kz == 0 ? 2 : kz - 1;
        q->kz = kz;
        q->o[0] = r[k].o.x;
        q->o[1] = r[k].o.y;
        q->o[2] = r[k].o.z;
        q->simd = simd >> k & 1;
        q->sx = s[0][k];
        q->sy = s[1][k];
        q->sz = s[2][k];
    }
}
#endif

#endif
