/*
 * tri4.h - the SIMD watertight triangle test, inline so that the BVH
 * traversal compiles it into its loop: no call there, and in the AVX2 build
 * of bvh_traverse.c, VEX code and eight lanes. The same operations in the
 * same order at every width and in every build: the lanes' bits never
 * depend on it. Lanes it cannot decide go to the scalar routine (tri.c,
 * prim_tri8_lane_hit). Included by bvh_traverse.c and test_prim.c.
 */
#ifndef LANCER_TRI4_H
#define LANCER_TRI4_H

#include <float.h>
#include <math.h>
#include <stdint.h>

#include "lancer/prim.h"
#include "rounding.h"
#include "tri_ray.h"

/* The lowest set bit of a non-zero mask. */
static inline int tri_low_bit(unsigned m)
{
#ifdef __GNUC__
    return __builtin_ctz(m);
#else
    int i = 0;
    while (!(m >> i & 1))
        i++;
    return i;
#endif
}

/* Lane at + i of t (bit i of lanes) through the scalar routine; its hit
 * into the arrays at i. Returns the lanes hit. */
static inline int tri_scalar_lanes(const PrimTri8 *t, int at, int lanes, const PrimTriRay *p, const Ray *r, float *ht,
                                   float *hterr, float *hu, float *hv)
{
    int hit = 0;
    for (unsigned m = (unsigned)lanes; m; m &= m - 1) {
        int i = tri_low_bit(m);
        PrimHit g;
        if (prim_tri8_lane_hit(t, at + i, p, r, &g)) {
            ht[i] = g.t;
            hterr[i] = g.terr;
            hu[i] = g.u;
            hv[i] = g.v;
            hit |= 1 << i;
        }
    }
    return hit;
}

/* The lanes' functions take blk, a lane of a PrimTri8 (&t->v[0][0][at]),
 * and test the lanes from there: vertex k's axis a at TRI_ROW(blk, k, a). */
#define TRI_ROW(blk, k, a) ((blk) + 8 * (3 * (k) + (a)))

#if defined(__SSE2__) && !defined(LANCER_NO_SIMD)
#define TRI4_SSE 1
#include <emmintrin.h>
#define V __m128
#define V_LOAD(blk, k, a) _mm_loadu_ps(TRI_ROW(blk, k, a))
#define V_STORE _mm_storeu_ps
#define V_SET1 _mm_set1_ps
#define V_ADD _mm_add_ps
#define V_SUB _mm_sub_ps
#define V_MUL _mm_mul_ps
#define V_DIV _mm_div_ps
#define V_MIN _mm_min_ps /* the second operand when one is NaN */
#define V_MAX _mm_max_ps
/* A comparison's lanes (M): all ones or all zeros, as a vector. */
#define M __m128
#define M_AND _mm_and_ps
#define M_OR _mm_or_ps
#define M_ANDNOT _mm_andnot_ps /* ~a & b */
#define M_BITS _mm_movemask_ps
#define V_SEL(m, a, b) _mm_or_ps(_mm_and_ps(m, a), _mm_andnot_ps(m, b)) /* a where m, else b */
#define V_ABS(x) _mm_andnot_ps(_mm_set1_ps(-0.0f), x)
#define V_LT _mm_cmplt_ps
#define V_LE _mm_cmple_ps
#define V_GT _mm_cmpgt_ps
#define V_GE _mm_cmpge_ps
#define V_EQ _mm_cmpeq_ps
#define V_TERR_UP terr_up4
/* prim_terr_up for four lanes, the same operations lane by lane (for a
 * hit's terr, t >= 0; the other lanes' results are not read): x = terr +
 * gamma_d(1) t in double, f = x rounded, and f when it is >= x, else one
 * ulp more as float_up takes it (f (1 + 2^-23), or the next float's bits
 * for f below FLT_MIN). */
static inline __m128 terr_up4(__m128 terr, __m128 t)
{
    const __m128d g = _mm_set1_pd(GAMMA_D(1));
    const __m128d xl = _mm_add_pd(_mm_cvtps_pd(terr), _mm_mul_pd(g, _mm_cvtps_pd(t)));
    const __m128d xh = _mm_add_pd(_mm_cvtps_pd(_mm_movehl_ps(terr, terr)), _mm_mul_pd(g, _mm_cvtps_pd(_mm_movehl_ps(t, t))));
    const __m128 f = _mm_movelh_ps(_mm_cvtpd_ps(xl), _mm_cvtpd_ps(xh));
    const __m128d kl = _mm_cmpge_pd(_mm_cvtps_pd(f), xl), kh = _mm_cmpge_pd(_mm_cvtps_pd(_mm_movehl_ps(f, f)), xh);
    const __m128 keep = _mm_shuffle_ps(_mm_castpd_ps(kl), _mm_castpd_ps(kh), _MM_SHUFFLE(2, 0, 2, 0));
    const __m128 sub = _mm_cmplt_ps(f, _mm_set1_ps(FLT_MIN));
    const __m128 next = _mm_castsi128_ps(_mm_add_epi32(_mm_castps_si128(f), _mm_set1_epi32(1)));
    const __m128 up = _mm_or_ps(_mm_and_ps(sub, next), _mm_andnot_ps(sub, _mm_mul_ps(f, _mm_set1_ps(1.0f + FLT_EPSILON))));
    return _mm_or_ps(_mm_and_ps(keep, f), _mm_andnot_ps(keep, up));
}
#define TRI_LANES tri4_lanes
#include "tri_lanes.h"
#endif

#if defined(__AVX2__) && !defined(LANCER_NO_SIMD)
/* The same eight lanes wide: each row one load. The comparisons are the
 * SSE ones' predicates (ordered: false on NaN). */
#define TRI4_AVX 1
#include <immintrin.h>
#define V __m256
#define V_LOAD(blk, k, a) _mm256_loadu_ps(TRI_ROW(blk, k, a))
#define V_STORE _mm256_storeu_ps
#define V_SET1 _mm256_set1_ps
#define V_ADD _mm256_add_ps
#define V_SUB _mm256_sub_ps
#define V_MUL _mm256_mul_ps
#define V_DIV _mm256_div_ps
#define V_MIN _mm256_min_ps
#define V_MAX _mm256_max_ps
#define M __m256
#define M_AND _mm256_and_ps
#define M_OR _mm256_or_ps
#define M_ANDNOT _mm256_andnot_ps
#define M_BITS _mm256_movemask_ps
#define V_SEL(m, a, b) _mm256_blendv_ps(b, a, m)
#define V_ABS(x) _mm256_andnot_ps(_mm256_set1_ps(-0.0f), x)
#define V_LT(a, b) _mm256_cmp_ps(a, b, _CMP_LT_OS)
#define V_LE(a, b) _mm256_cmp_ps(a, b, _CMP_LE_OS)
#define V_GT(a, b) _mm256_cmp_ps(a, b, _CMP_GT_OS)
#define V_GE(a, b) _mm256_cmp_ps(a, b, _CMP_GE_OS)
#define V_EQ(a, b) _mm256_cmp_ps(a, b, _CMP_EQ_OQ)
#define V_TERR_UP terr_up8
/* terr_up4, eight lanes wide. */
static inline __m256 terr_up8(__m256 terr, __m256 t)
{
    const __m256d g = _mm256_set1_pd(GAMMA_D(1));
    const __m256d xl = _mm256_add_pd(_mm256_cvtps_pd(_mm256_castps256_ps128(terr)),
                                     _mm256_mul_pd(g, _mm256_cvtps_pd(_mm256_castps256_ps128(t))));
    const __m256d xh = _mm256_add_pd(_mm256_cvtps_pd(_mm256_extractf128_ps(terr, 1)),
                                     _mm256_mul_pd(g, _mm256_cvtps_pd(_mm256_extractf128_ps(t, 1))));
    const __m128 fl = _mm256_cvtpd_ps(xl), fh = _mm256_cvtpd_ps(xh);
    const __m256 f = _mm256_set_m128(fh, fl);
    const __m256d kl = _mm256_cmp_pd(_mm256_cvtps_pd(fl), xl, _CMP_GE_OQ);
    const __m256d kh = _mm256_cmp_pd(_mm256_cvtps_pd(fh), xh, _CMP_GE_OQ);
    /* each 64-bit mask's low word, lanes 0 to 3 from kl and 4 to 7 from kh */
    const __m256i low = _mm256_setr_epi32(0, 2, 4, 6, 1, 3, 5, 7);
    const __m256 keep = _mm256_set_m128(_mm256_castps256_ps128(_mm256_permutevar8x32_ps(_mm256_castpd_ps(kh), low)),
                                        _mm256_castps256_ps128(_mm256_permutevar8x32_ps(_mm256_castpd_ps(kl), low)));
    const __m256 next = _mm256_castsi256_ps(_mm256_add_epi32(_mm256_castps_si256(f), _mm256_set1_epi32(1)));
    const __m256 up = _mm256_blendv_ps(_mm256_mul_ps(f, _mm256_set1_ps(1.0f + FLT_EPSILON)), next,
                                       _mm256_cmp_ps(f, _mm256_set1_ps(FLT_MIN), _CMP_LT_OQ));
    return _mm256_blendv_ps(up, f, keep);
}
#define TRI_LANES tri8_lanes
#include "tri_lanes.h"

#if defined(__GNUC__) && defined(__x86_64__)
/* Two rays at once, sixteen lanes of AVX-512: tri8_lanes for ray p in the
 * low half and for ray p2 in the high, which share the axes kx, ky, kz.
 * Built for AVX-512F and DQ whatever the file's target, and not inlined
 * (its caller is not): the caller checks the processor. A comparison's
 * lanes are a mask register (M), combined as the narrower forms combine
 * their vectors of all ones or all zeros: the same bits. */
#define TRI4_AVX512 1
#define TRI_AVX512 __attribute__((target("avx512f,avx512dq")))
#define TRI_LANES_DECL static TRI_AVX512
#define TRI_LANES_RAY2 const PrimTriRay *p2, const Ray *r2,
#define V_RAY(a, b) _mm512_insertf32x8(_mm512_set1_ps(a), _mm256_set1_ps(b), 1)
#define V __m512
#define V_LOAD(blk, k, a) _mm512_broadcast_f32x8(_mm256_loadu_ps(TRI_ROW(blk, k, a)))
#define V_STORE _mm512_storeu_ps
#define V_SET1 _mm512_set1_ps
#define V_ADD _mm512_add_ps
#define V_SUB _mm512_sub_ps
#define V_MUL _mm512_mul_ps
#define V_DIV _mm512_div_ps
#define V_MIN _mm512_min_ps
#define V_MAX _mm512_max_ps
#define M __mmask16
#define M_AND(a, b) ((__mmask16)((a) & (b)))
#define M_OR(a, b) ((__mmask16)((a) | (b)))
#define M_ANDNOT(a, b) ((__mmask16)(~(a) & (b)))
#define M_BITS(m) ((int)(m))
#define V_SEL(m, a, b) _mm512_mask_blend_ps(m, b, a)
#define V_ABS(x) _mm512_andnot_ps(_mm512_set1_ps(-0.0f), x)
#define V_LT(a, b) _mm512_cmp_ps_mask(a, b, _CMP_LT_OS)
#define V_LE(a, b) _mm512_cmp_ps_mask(a, b, _CMP_LE_OS)
#define V_GT(a, b) _mm512_cmp_ps_mask(a, b, _CMP_GT_OS)
#define V_GE(a, b) _mm512_cmp_ps_mask(a, b, _CMP_GE_OS)
#define V_EQ(a, b) _mm512_cmp_ps_mask(a, b, _CMP_EQ_OQ)
#define V_TERR_UP terr_up16
/* terr_up4, sixteen lanes wide. */
TRI_AVX512 static inline __m512 terr_up16(__m512 terr, __m512 t)
{
    const __m512d g = _mm512_set1_pd(GAMMA_D(1));
    const __m512d xl = _mm512_add_pd(_mm512_cvtps_pd(_mm512_castps512_ps256(terr)),
                                     _mm512_mul_pd(g, _mm512_cvtps_pd(_mm512_castps512_ps256(t))));
    const __m512d xh = _mm512_add_pd(_mm512_cvtps_pd(_mm512_extractf32x8_ps(terr, 1)),
                                     _mm512_mul_pd(g, _mm512_cvtps_pd(_mm512_extractf32x8_ps(t, 1))));
    const __m256 fl = _mm512_cvtpd_ps(xl), fh = _mm512_cvtpd_ps(xh);
    const __m512 f = _mm512_insertf32x8(_mm512_castps256_ps512(fl), fh, 1);
    const __mmask16 keep = (__mmask16)(_mm512_cmp_pd_mask(_mm512_cvtps_pd(fl), xl, _CMP_GE_OQ) |
                                       _mm512_cmp_pd_mask(_mm512_cvtps_pd(fh), xh, _CMP_GE_OQ) << 8);
    const __m512 next = _mm512_castsi512_ps(_mm512_add_epi32(_mm512_castps_si512(f), _mm512_set1_epi32(1)));
    const __m512 up = _mm512_mask_blend_ps(_mm512_cmp_ps_mask(f, _mm512_set1_ps(FLT_MIN), _CMP_LT_OQ),
                                           _mm512_mul_ps(f, _mm512_set1_ps(1.0f + FLT_EPSILON)), next);
    return _mm512_mask_blend_ps(keep, up, f);
}
#define TRI_LANES tri16_lanes
#include "tri_lanes.h"
#undef TRI_AVX512
#endif
#endif

/* Four lanes of t from lane at (0 or 4; bit i of lanes for lane at + i),
 * each judged exactly as the scalar routine judges it; hits into the
 * arrays at i. */
static inline int tri4_hit_watertight(const PrimTri8 *t, int at, int lanes, const PrimTriRay *p, const Ray *r,
                                      float *ht, float *hterr, float *hu, float *hv)
{
    int hit = 0, slow = lanes;
#ifdef TRI4_SSE
    if (p->simd)
        hit = tri4_lanes(&t->v[0][0][at], lanes, p, r, ht, hterr, hu, hv, &slow);
#endif
    return hit | tri_scalar_lanes(t, at, slow, p, r, ht, hterr, hu, hv);
}

#endif
