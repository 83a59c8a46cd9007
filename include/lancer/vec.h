/*
 * vec.h - 3-vectors of float, used for points, directions and colours.
 *
 *     Vec3 d = vec_normalize(vec_sub(target, eye));
 *     float cosang = vec_dot(n, d);
 *
 * Everything is static inline so that the hot loops in the intersection
 * routines see through it. Geometry is single precision on purpose: it is
 * what production kernels (and the ray files of the benchmark) use, and the
 * exact judge reasons about the float bits the routines actually saw.
 */
#ifndef LANCER_VEC_H
#define LANCER_VEC_H

#include <math.h>

typedef struct {
    float x, y, z;
} Vec3;

static inline Vec3 vec3(float x, float y, float z)
{
    Vec3 v;
    v.x = x;
    v.y = y;
    v.z = z;
    return v;
}

static inline Vec3 vec_add(Vec3 a, Vec3 b) { return vec3(a.x + b.x, a.y + b.y, a.z + b.z); }
static inline Vec3 vec_sub(Vec3 a, Vec3 b) { return vec3(a.x - b.x, a.y - b.y, a.z - b.z); }
static inline Vec3 vec_mul(Vec3 a, Vec3 b) { return vec3(a.x * b.x, a.y * b.y, a.z * b.z); }
static inline Vec3 vec_scale(Vec3 a, float s) { return vec3(a.x * s, a.y * s, a.z * s); }
static inline Vec3 vec_neg(Vec3 a) { return vec3(-a.x, -a.y, -a.z); }
/* a + s*b, the ubiquitous "point along a ray". */
static inline Vec3 vec_madd(Vec3 a, Vec3 b, float s) { return vec3(a.x + s * b.x, a.y + s * b.y, a.z + s * b.z); }
static inline float vec_dot(Vec3 a, Vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }

static inline Vec3 vec_cross(Vec3 a, Vec3 b)
{
    return vec3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}

static inline float vec_length(Vec3 a) { return sqrtf(vec_dot(a, a)); }

/* Returns a unchanged when it has zero length, so callers that must reject
 * degenerate input check the length themselves first. */
static inline Vec3 vec_normalize(Vec3 a)
{
    float len = vec_length(a);
    return len > 0.0f ? vec_scale(a, 1.0f / len) : a;
}

/* fmaxf(a, b), NaN handling included (a NaN loses), without the libm call
 * that fmaxf is without -ffast-math. */
static inline float float_max(float a, float b) { return b > a || a != a ? b : a; }

static inline float vec_max_abs(Vec3 a)
{
    float m = fabsf(a.x);
    if (fabsf(a.y) > m)
        m = fabsf(a.y);
    if (fabsf(a.z) > m)
        m = fabsf(a.z);
    return m;
}

/* Component i (0: x, 1: y, 2: z). */
static inline float vec_comp(Vec3 v, int i) { return i == 0 ? v.x : i == 1 ? v.y : v.z; }

static inline int vec_is_finite(Vec3 a) { return isfinite(a.x) && isfinite(a.y) && isfinite(a.z); }

/* Mirror direction d about the unit normal n: d - 2(d.n)n. */
static inline Vec3 vec_reflect(Vec3 d, Vec3 n) { return vec_madd(d, n, -2.0f * vec_dot(d, n)); }

#endif
