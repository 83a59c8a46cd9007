/*
 * ray_lanes.h - rays' fields loaded into SIMD lanes, one ray a lane, for
 * the four- and eight-lane routines of prim.c, pntri.c and the packets of
 * bvh_traverse.c (private to src/). Each includes it where it has decided
 * to build its AVX forms (x86-64 with GCC or Clang), after <immintrin.h>.
 */
#ifndef LANCER_RAY_LANES_H
#define LANCER_RAY_LANES_H

#include <stddef.h>

#include "lancer/ray.h"

/* 1 where the AVX-512 forms run: prim.c's eight lanes and the traversal's
 * two rays a leaf. They pay on an AMD processor with AVX-512F and DQ; on an
 * Intel Xeon with AVX-512 the eight lanes ran slower than two calls of four
 * (docs/performance.md). */
static inline int avx512_lanes_pay(void)
{
    return __builtin_cpu_is("amd") && __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512dq");
}

/* A ray's fields, in floats from its start: the origin's axis a at RAY_O +
 * a, the direction's at RAY_D + a, then tmax. The loads below read a ray
 * as these seven floats. */
enum {
    RAY_O = (int)(offsetof(Ray, o) / sizeof(float)),
    RAY_D = (int)(offsetof(Ray, d) / sizeof(float)),
    RAY_TMAX = (int)(offsetof(Ray, tmax) / sizeof(float)),
    RAY_FIELDS = 7
};
typedef char ray_is_seven_floats[RAY_O == 0 && RAY_D == 3 && RAY_TMAX == 6 && sizeof(Ray) == RAY_FIELDS * sizeof(float)
                                     ? 1
                                     : -1];

/* The rays r[k[0 .. 3]], a lane each: field i (RAY_O + a, RAY_D + a,
 * RAY_TMAX) into f[i]. Two loads of four floats a ray (o and d.x, then d
 * and tmax), transposed: a load a field and a lane took longer. */
__attribute__((target("avx"))) static inline void ray_fields(const Ray *r, const int k[4], __m128 f[RAY_FIELDS])
{
    __m128 a[4], b[4];
    for (int j = 0; j < 4; j++) {
        const float *p = (const float *)&r[k[j]];
        a[j] = _mm_loadu_ps(p);
        b[j] = _mm_loadu_ps(p + RAY_D);
    }
    _MM_TRANSPOSE4_PS(a[0], a[1], a[2], a[3]);
    _MM_TRANSPOSE4_PS(b[0], b[1], b[2], b[3]);
    for (int i = 0; i < 3; i++)
        f[RAY_O + i] = a[i];
    for (int i = 0; i < 4; i++)
        f[RAY_D + i] = b[i];
}

/* Four records of four floats a half: half h of row[j] holds record j of
 * that half. Field i of every record into out[i], i < m, record j in lane
 * j of each half. */
__attribute__((target("avx"))) static inline void transpose8(const __m256 row[4], int m, __m256 *out)
{
    const __m256 t0 = _mm256_unpacklo_ps(row[0], row[1]), t1 = _mm256_unpacklo_ps(row[2], row[3]);
    const __m256 t2 = _mm256_unpackhi_ps(row[0], row[1]), t3 = _mm256_unpackhi_ps(row[2], row[3]);
    out[0] = _mm256_shuffle_ps(t0, t1, _MM_SHUFFLE(1, 0, 1, 0));
    out[1] = _mm256_shuffle_ps(t0, t1, _MM_SHUFFLE(3, 2, 3, 2));
    out[2] = _mm256_shuffle_ps(t2, t3, _MM_SHUFFLE(1, 0, 1, 0));
    if (m > 3)
        out[3] = _mm256_shuffle_ps(t2, t3, _MM_SHUFFLE(3, 2, 3, 2));
}

/* ray_fields for the rays r[k[0 .. 7]], rays k[j] and k[j + 4] loaded into
 * one register. */
__attribute__((target("avx"))) static inline void ray_fields8(const Ray *r, const int k[8], __m256 f[RAY_FIELDS])
{
    __m256 a[4], b[4];
    for (int j = 0; j < 4; j++) {
        const float *p = (const float *)&r[k[j]], *q = (const float *)&r[k[j + 4]];
        a[j] = _mm256_insertf128_ps(_mm256_castps128_ps256(_mm_loadu_ps(p)), _mm_loadu_ps(q), 1);
        b[j] = _mm256_insertf128_ps(_mm256_castps128_ps256(_mm_loadu_ps(p + RAY_D)), _mm_loadu_ps(q + RAY_D), 1);
    }
    transpose8(a, 3, f + RAY_O);
    transpose8(b, 4, f + RAY_D);
}

#endif
