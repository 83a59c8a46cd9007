/*
 * dvec.h - 3-vectors of double as arrays, for the tests that must not round
 * like floats: a triangle's normal from float vertices (whose differences
 * are exact in double), orientations, determinants.
 *
 *     double e1[3], e2[3], n[3];
 *     d3_sub(e1, t->b, t->a);
 *     d3_sub(e2, t->c, t->a);
 *     d3_cross(n, e1, e2);
 *
 * The operations are written out in one order, and the build contracts
 * nothing into FMAs, so every caller gets the same bits it computed inline.
 */
#ifndef LANCER_DVEC_H
#define LANCER_DVEC_H

#include "lancer/vec.h"

/* r = a - b, from floats: exact in double. */
static inline void d3_sub(double r[3], Vec3 a, Vec3 b)
{
    r[0] = (double)a.x - b.x;
    r[1] = (double)a.y - b.y;
    r[2] = (double)a.z - b.z;
}

/* r = u x w; r may not alias u or w. */
static inline void d3_cross(double r[3], const double u[3], const double w[3])
{
    r[0] = u[1] * w[2] - u[2] * w[1];
    r[1] = u[2] * w[0] - u[0] * w[2];
    r[2] = u[0] * w[1] - u[1] * w[0];
}

static inline double d3_dot(const double u[3], const double w[3]) { return u[0] * w[0] + u[1] * w[1] + u[2] * w[2]; }

#endif
