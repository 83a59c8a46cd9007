/*
 * tri.c - ray/triangle intersection, both variants (see prim.h for the
 * contract each keeps): Moller and Trumbore's classic test, and the
 * watertight test of Woop, Benthin and Wald 2013 with its error bounds,
 * the scalar routine that the SIMD lanes (tri4.h) reproduce bit for bit
 * and fall back to.
 */
#include "lancer/prim.h"

#include <float.h>
#include <math.h>

#include "rounding.h"
#include "tri_ray.h"

int prim_triangle_hit(const Triangle *tr, const Ray *r, PrimHit *h)
{
    Vec3 e1 = vec_sub(tr->b, tr->a);
    Vec3 e2 = vec_sub(tr->c, tr->a);
    Vec3 pvec = vec_cross(r->d, e2);
    float det = vec_dot(e1, pvec);
    /* The paper rejects |det| < 1e-6; that epsilon depends on the scene's
     * scale, so only the exactly parallel case is rejected here. */
    if (det == 0.0f)
        return 0;
    float inv_det = 1.0f / det;
    Vec3 tvec = vec_sub(r->o, tr->a);
    float uu = vec_dot(tvec, pvec) * inv_det;
    if (uu < 0.0f || uu > 1.0f)
        return 0;
    Vec3 qvec = vec_cross(tvec, e1);
    float vv = vec_dot(r->d, qvec) * inv_det;
    if (vv < 0.0f || uu + vv > 1.0f)
        return 0;
    float th = vec_dot(e2, qvec) * inv_det;
    if (!(th > 0.0f && th < r->tmax))
        return 0;
    *h = (PrimHit){th, 0.0f, uu, vv, 0};
    return 1;
}

/* fmaxf(a, fmaxf(b, c)), without the libm calls. */
static float max3(float a, float b, float c) { return float_max(a, float_max(b, c)); }

/* A bound on the rounding of the edge function xi yj - yi xj when each
 * coordinate is off by its e: the products' own rounding, and first and
 * second order terms of the coordinate errors. Symmetric in (i, j). (The
 * products' underflow: TRI_SHEAR_FLOOR.) */
static float edge_err(float xi, float yi, float exi, float eyi, float xj, float yj, float exj, float eyj)
{
    float m = fabsf(xi * yj) + fabsf(yi * xj);
    float d = exi * fabsf(yj) + eyj * fabsf(xi) + eyi * fabsf(xj) + exj * fabsf(yi) + exi * eyj + eyi * exj;
    return gamma_f(3) * m + d * (1.0f + gamma_f(3));
}

/* An edge function taken again in double, as a float of the same sign: a
 * value below the least float would round to 0 and lose its sign. */
static float edge_float(double e)
{
    float f = (float)e;
    return f != 0.0f || e == 0.0 ? f : e > 0.0 ? 0x1p-149f : -0x1p-149f;
}

static int watertight(const Vec3 v[3], const Ray *r, const PrimTriRay *p, PrimHit *h);

/* The vertices translated to the ray origin and sheared as in
 * watertight(), in double: X and Y carry the shear, Z is z / dz. */
static void shear_double(const Vec3 v[3], const Ray *r, const PrimTriRay *p, double X[3], double Y[3], double Z[3])
{
    double dz = vec_comp(r->d, p->kz), dsx = -(double)vec_comp(r->d, p->kx) / dz, dsy = -(double)vec_comp(r->d, p->ky) / dz;
    for (int k = 0; k < 3; k++) {
        double px = (double)vec_comp(v[k], p->kx) - vec_comp(r->o, p->kx), py = (double)vec_comp(v[k], p->ky) - vec_comp(r->o, p->ky);
        double pz = (double)vec_comp(v[k], p->kz) - vec_comp(r->o, p->kz);
        X[k] = px + dsx * pz;
        Y[k] = py + dsy * pz;
        Z[k] = pz / dz;
    }
}

/* t, u and v of watertight() in double, for a t too close to 0 or tmax to
 * trust in float; 0 if it is outside (0, tmax) all the same. With terr,
 * also watertight()'s bound on t's error, taken in double from the
 * double coordinates (the same roundings, each smaller), for a triangle
 * whose float products over- or underflow. */
static int t_double(const Vec3 v[3], const Ray *r, const PrimTriRay *p, float *t, float *u, float *w, float *terr)
{
    double X[3], Y[3], Z[3];
    shear_double(v, r, p, X, Y, Z);
    double e0 = X[1] * Y[2] - Y[1] * X[2], e1 = X[2] * Y[0] - Y[2] * X[0], e2 = X[0] * Y[1] - Y[0] * X[1];
    double det = e0 + e1 + e2;
    if (det == 0.0)
        return 0;
    const double tdd = (e0 * Z[0] + e1 * Z[1] + e2 * Z[2]) / det;
    float td = (float)tdd;
    if (!(td > 0.0f && td < r->tmax))
        return 0;
    *t = td;
    *u = (float)(e1 / det);
    *w = (float)(e2 / det);
    if (terr) {
        const double dz = fabs((double)vec_comp(r->d, p->kz));
        double mx = 0.0, my = 0.0, mz = 0.0;
        for (int k = 0; k < 3; k++) {
            mx = double_max(mx, fabs(X[k]));
            my = double_max(my, fabs(Y[k]));
            mz = double_max(mz, fabs(Z[k]));
        }
        const double mz_len = mz * dz, me = double_max(fabs(e0), double_max(fabs(e1), fabs(e2)));
        const double dxe = GAMMA_D(5) * (mx + mz_len), dye = GAMMA_D(5) * (my + mz_len), dze = GAMMA_D(3) * mz;
        const double de = 2.0 * (GAMMA_D(2) * mx * my + dye * mx + dxe * my);
        /* and t's rounding to float */
        *terr = float_up(3.0 * (GAMMA_D(3) * me * mz + de * mz + dze * me) / fabs(det) * (1.0 + GAMMA_D(4)) +
                         fabs(tdd - (double)td));
    }
    return 1;
}

int prim_triangle_hit_watertight(const Triangle *tr, const Ray *r, PrimHit *h)
{
    const Vec3 v[3] = {tr->a, tr->b, tr->c};
    return prim_triangle_hit_watertight3(v, r, h);
}

/* A direction whose largest component m is this short or long is scaled
 * by a power of two before the shear (1/dz could overflow); the SIMD lanes
 * leave such rays to the scalar routine. */
static int dir_needs_rescale(float m) { return m < TRI_RESCALE_MIN || m > TRI_RESCALE_MAX; }

int prim_triangle_hit_watertight3(const Vec3 v[3], const Ray *r, PrimHit *h)
{
    /* The float shear divides by the largest direction component: scale a
     * very short or very long direction by a power of two first (exact),
     * so that 1/dz cannot overflow, and scale t back. */
    float m = max3(fabsf(r->d.x), fabsf(r->d.y), fabsf(r->d.z));
    PrimTriRay p;
    if (!dir_needs_rescale(m)) {
        prim_triray_init(&p, r);
        return watertight(v, r, &p, h);
    }
    int e;
    frexpf(m, &e);
    double k = ldexp(1.0, -e); /* d' = k d, so t = k t'; in double, since k may exceed FLT_MAX */
    Vec3 d = vec3((float)(r->d.x * k), (float)(r->d.y * k), (float)(r->d.z * k));
    Ray q = ray_make(r->o, d, float_up(r->tmax / k)); /* rounded up: no hit lost */
    prim_triray_init(&p, &q);
    if (!watertight(v, &q, &p, h))
        return 0;
    h->t = (float)(h->t * k);
    h->terr = float_up(h->terr * k);
    return h->t < r->tmax && h->t > 0.0f;
}

static int watertight(const Vec3 v[3], const Ray *r, const PrimTriRay *p, PrimHit *h)
{
    /* Woop et al.: translate to the ray origin, make the largest direction
     * component z (keeping the winding), and shear so the ray runs along
     * +z (prim_triray_init). Written as in pbrt-v3/v4, whose error analysis
     * bounds t below. */
    int kx = p->kx, ky = p->ky, kz = p->kz;
    float dz = vec_comp(r->d, kz);
    if (dz == 0.0f)
        return 0; /* a zero direction */
    float sx = p->sx, sy = p->sy, sz = p->sz;
    Vec3 A = vec_sub(v[0], r->o), B = vec_sub(v[1], r->o), C = vec_sub(v[2], r->o);
    float az = vec_comp(A, kz), bz = vec_comp(B, kz), cz = vec_comp(C, kz);
    float ax = vec_comp(A, kx) + sx * az, ay = vec_comp(A, ky) + sy * az;
    float bx = vec_comp(B, kx) + sx * bz, by = vec_comp(B, ky) + sy * bz;
    float cx = vec_comp(C, kx) + sx * cz, cy = vec_comp(C, ky) + sy * cz;
    /* Edge functions: a shared edge gives exactly opposite values in its two
     * triangles (the same products, subtracted the other way round), which
     * is what makes meshes watertight; -ffp-contract=off keeps it so. */
    float e0 = bx * cy - by * cx, e1 = cx * ay - cy * ax, e2 = ax * by - ay * bx;
    /* An edge function within its rounding bound of 0 has an uncertain
     * sign: it is decided again in double, from coordinates sheared in
     * double. The bound of an edge depends only on its two vertices, and is
     * the same whichever way round the edge is taken, so the two triangles
     * sharing an edge always decide it by the same computation and still
     * get exactly opposite signs. */
    /* (a coordinate's x and y no less than TRI_SHEAR_FLOOR, which covers
     * the underflow of the shear's products and the edge functions') */
    float g5 = gamma_f(5), lo = TRI_SHEAR_FLOOR;
#define SHEAR_ERR(P, k) (g5 * (float_max(fabsf(vec_comp(P, k)), lo) + fabsf(vec_comp(P, kz))))
    float exa = SHEAR_ERR(A, kx), eya = SHEAR_ERR(A, ky);
    float exb = SHEAR_ERR(B, kx), eyb = SHEAR_ERR(B, ky);
    float exc = SHEAR_ERR(C, kx), eyc = SHEAR_ERR(C, ky);
#undef SHEAR_ERR
    int u0 = !(fabsf(e0) > edge_err(bx, by, exb, eyb, cx, cy, exc, eyc)); /* (a NaN, past 2^63: unsure) */
    int u1 = !(fabsf(e1) > edge_err(cx, cy, exc, eyc, ax, ay, exa, eya));
    int u2 = !(fabsf(e2) > edge_err(ax, ay, exa, eya, bx, by, exb, eyb));
    if (u0 || u1 || u2) {
        double X[3], Y[3], Z[3];
        shear_double(v, r, p, X, Y, Z);
        if (u0)
            e0 = edge_float(X[1] * Y[2] - Y[1] * X[2]);
        if (u1)
            e1 = edge_float(X[2] * Y[0] - Y[2] * X[0]);
        if (u2)
            e2 = edge_float(X[0] * Y[1] - Y[0] * X[1]);
    }
    if ((e0 < 0.0f || e1 < 0.0f || e2 < 0.0f) && (e0 > 0.0f || e1 > 0.0f || e2 > 0.0f))
        return 0;
    float det = e0 + e1 + e2;
    if (det == 0.0f)
        return 0;
    /* The shear errors are in length units: they take the z extent before
     * it is scaled by 1/dz (pbrt takes it after, which is wrong whenever
     * |d| is not 1: too large a bound for short directions, too small for
     * long ones). */
    float mz_len = max3(fabsf(az), fabsf(bz), fabsf(cz));
    az *= sz;
    bz *= sz;
    cz *= sz;
    float tscaled = e0 * az + e1 * bz + e2 * cz;
    float inv = 1.0f / det, t = tscaled * inv;
    /* pbrt's bound on the error of t, from the errors of the sheared
     * coordinates (gamma(5) in x and y, gamma(3) in z) and of the edge
     * functions. A t within it of 0 is kept, as in the other routines: the
     * exit of a closed mesh close to the origin is a real hit, and spawned
     * rays are kept off their surface by their offset, not by rejecting. */
    float mz = max3(fabsf(az), fabsf(bz), fabsf(cz));
    float mx = max3(fabsf(ax), fabsf(bx), fabsf(cx)), my = max3(fabsf(ay), fabsf(by), fabsf(cy));
    float dxe = gamma_f(5) * (mx + mz_len), dye = gamma_f(5) * (my + mz_len), dze = gamma_f(3) * mz;
    float de = 2.0f * (gamma_f(2) * mx * my + dye * mx + dxe * my);
    float me = max3(fabsf(e0), fabsf(e1), fabsf(e2));
    float tserr = 3.0f * (gamma_f(3) * me * mz + de * mz + dze * me); /* terr times |det| */
    float terr = tserr * fabsf(inv);
    float u = e1 * inv, w = e2 * inv;
    int out = det < 0.0f ? (tscaled >= 0.0f || tscaled < r->tmax * det) : (tscaled <= 0.0f || tscaled > r->tmax * det);
    if (tri_t_out_of_range(tserr, me)) {
        /* Past float's range (about 2^42 from the ray's origin, where
         * tscaled's products overflow, or products below 2^-104), t and
         * its bound are taken in double. */
        if (!t_double(v, r, p, &t, &u, &w, &terr))
            return 0;
    } else if (out || !(t > 0.0f) || !(t < r->tmax)) {
        /* Outside (0, tmax), but maybe only by t's rounding: a triangle
         * seen almost edge-on has a t far less accurate than its edge
         * signs, and if the shared edge went to it, dropping it would leak
         * the ray between two triangles. Within terr (compared times |det|,
         * so that the lanes need no division), t is taken again in double;
         * the signs stay as decided. */
        float ts = det < 0.0f ? -tscaled : tscaled, reach = r->tmax * fabsf(det) + tserr;
        if (!(ts > -tserr && ts < reach) || !t_double(v, r, p, &t, &u, &w, NULL))
            return 0;
    }
    *h = (PrimHit){t, prim_terr_up(terr, t), u, w, 0}; /* terr: and the rounding of t itself */
    return 1;
}

void prim_triray_init(PrimTriRay *p, const Ray *r) { tri_ray_init(p, r); }

int prim_tri8_lane_hit(const PrimTri8 *t, int lane, const PrimTriRay *p, const Ray *r, PrimHit *h)
{
    Vec3 v[3];
    for (int k = 0; k < 3; k++)
        v[k] = vec3(t->v[k][0][lane], t->v[k][1][lane], t->v[k][2][lane]);
    return p->simd ? watertight(v, r, p, h) : prim_triangle_hit_watertight3(v, r, h);
}

float prim_terr_up(float terr, float t) { return float_up((double)terr + gamma_d(1) * t); }
