/*
 * ray_lanes.h - rays' fields gathered into SIMD lanes, one ray a lane, for
 * the four- and eight-lane routines of prim.c and pntri.c (private to src/). Each
 * includes it where it has decided to build its AVX forms (x86-64 with
 * GCC or Clang), after <immintrin.h>.
 */
#ifndef LANCER_RAY_LANES_H
#define LANCER_RAY_LANES_H

#include <stddef.h>

#include "lancer/ray.h"

/* A ray's fields, in floats from its start: the origin's axis a at RAY_O +
 * a, the direction's at RAY_D + a, then tmax. */
typedef char ray_is_floats[sizeof(Ray) % sizeof(float) == 0 ? 1 : -1];
enum {
    RAY_O = (int)(offsetof(Ray, o) / sizeof(float)),
    RAY_D = (int)(offsetof(Ray, d) / sizeof(float)),
    RAY_TMAX = (int)(offsetof(Ray, tmax) / sizeof(float))
};

/* Field at of the rays r[k[0 .. 3]], a lane each. */
__attribute__((target("avx"))) static inline __m128 ray_lanes(const Ray *r, const int k[4], int at)
{
    const float *f = (const float *)r + at;
    const int s = (int)(sizeof(Ray) / sizeof(float));
    return _mm_setr_ps(f[k[0] * s], f[k[1] * s], f[k[2] * s], f[k[3] * s]);
}

/* The same in double. */
__attribute__((target("avx"))) static inline __m256d ray_lanes_pd(const Ray *r, const int k[4], int at)
{
    return _mm256_cvtps_pd(ray_lanes(r, k, at));
}

/* Field at of the rays r[k[0 .. 7]], a lane each. */
__attribute__((target("avx"))) static inline __m256 ray_lanes8(const Ray *r, const int k[8], int at)
{
    const float *f = (const float *)r + at;
    const int s = (int)(sizeof(Ray) / sizeof(float));
    return _mm256_setr_ps(f[k[0] * s], f[k[1] * s], f[k[2] * s], f[k[3] * s], f[k[4] * s], f[k[5] * s], f[k[6] * s],
                          f[k[7] * s]);
}

/* The same in double, eight lanes of AVX-512. */
__attribute__((target("avx512f"))) static inline __m512d ray_lanes8_pd(const Ray *r, const int k[8], int at)
{
    return _mm512_cvtps_pd(ray_lanes8(r, k, at));
}

#endif
