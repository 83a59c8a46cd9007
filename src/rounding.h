/*
 * rounding.h - the rounding helpers of the robust routines (private to src/).
 *
 * Error analysis follows Higham's gamma(n) = n u / (1 - n u), u the unit
 * roundoff (2^-24 for float, 2^-53 for double), as pbrt-v4 does: a sum or
 * product chain of n roundings has relative error at most gamma(n). The
 * constants are written once, here, for the scalar routines (prim.c, tri.c)
 * and the SIMD lanes (tri4.h) alike, so that both round the same bounds.
 */
#ifndef LANCER_ROUNDING_H
#define LANCER_ROUNDING_H

#include <float.h>
#include <math.h>
#include <stdint.h>
#include <string.h>

#define UNIT_F (0.5 * (double)FLT_EPSILON)
#define UNIT_D (0.5 * DBL_EPSILON)

/* gamma(n) in float and in double, as constant expressions. */
#define GAMMA_F(n) ((float)((n) * UNIT_F / (1.0 - (n) * UNIT_F)))
#define GAMMA_D(n) ((n) * UNIT_D / (1.0 - (n) * UNIT_D))

static inline double gamma_d(int n) { return GAMMA_D(n); }
static inline float gamma_f(int n) { return GAMMA_F(n); }

/* fmin(a, b) and fmax(a, b), NaN handling included (a NaN loses), without
 * the libm call that each is without -ffast-math; of two equal arguments
 * (zeros of either sign) a, as glibc's give it (float_max's form). */
static inline double double_min(double a, double b) { return b < a || a != a ? b : a; }
static inline double double_max(double a, double b) { return b > a || a != a ? b : a; }

/* nextafterf(x, up ? INFINITY : -INFINITY), without the call: a finite
 * non-zero float's neighbours are one step away in its bits. */
static inline float float_next(float x, int up)
{
    if (!isfinite(x))
        return nextafterf(x, up ? INFINITY : -INFINITY);
    if (x == 0.0f)
        return up ? 0x1p-149f : -0x1p-149f;
    uint32_t b;
    memcpy(&b, &x, sizeof b);
    b = (x > 0.0f) == (up != 0) ? b + 1 : b - 1;
    memcpy(&x, &b, sizeof x);
    return x;
}

/* A float >= x, for x >= 0: x rounded, and one ulp more when that rounded
 * down (f * (1 + 2^-23) is at least the next float for a normal f, and
 * avoids float_next's branches on this hot path). Both are computed and
 * one is picked by a mask: whether x rounded down is a coin toss, and a
 * branch on it would be mispredicted half the time. (The branch left, on a
 * normal f, goes the same way almost always.) */
static inline float float_up(double x)
{
    float f = (float)x;
    float g = f >= FLT_MIN ? f * (1.0f + FLT_EPSILON) : float_next(f, 1);
    /* (double)f >= x ? f : g, by a mask: compilers branch on the ?: */
    uint32_t bf, bg, keep = -(uint32_t)((double)f >= x);
    memcpy(&bf, &f, sizeof bf);
    memcpy(&bg, &g, sizeof bg);
    bf = (bf & keep) | (bg & ~keep);
    memcpy(&f, &bf, sizeof f);
    return f;
}

#endif
