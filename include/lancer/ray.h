/*
 * ray.h - rays and the statistics counters that follow them around.
 *
 *     Ray r = ray_make(origin, unit_direction, INFINITY);
 *
 * A ray accepts hits with 0 < t < tmax. Its direction needs a component of
 * at least FLT_MIN in magnitude (rayfile_ray_ok): the BVH's box test takes
 * the reciprocal. There is no t_min epsilon: secondary rays start from an
 * origin already pushed off their surface (see shade.c), so a fixed epsilon
 * would only skip real hits at small scales.
 */
#ifndef LANCER_RAY_H
#define LANCER_RAY_H

#include "lancer/vec.h"

typedef struct {
    Vec3 o, d;
    float tmax;
} Ray;

static inline Ray ray_make(Vec3 o, Vec3 d, float tmax)
{
    Ray r;
    r.o = o;
    r.d = d;
    r.tmax = tmax;
    return r;
}

static inline Vec3 ray_at(const Ray *r, float t) { return vec_madd(r->o, r->d, t); }

/* Per-thread counters, summed after rendering; plain integers because every
 * thread owns its own copy. */
typedef struct {
    unsigned long long camera, shadow, reflection, refraction;
    unsigned long long isect_tests; /* primitive intersection routines called */
    unsigned long long cut;         /* secondary rays not traced: their weight was below adc_bailout */
    unsigned long long supersampled; /* pixels adaptive anti-aliasing supersampled */
    unsigned long long too_deep;     /* refracted rays into a solid past LIMIT_INTERIORS nested ones */
    unsigned long long shadow_cut;   /* shadow rays past LIMIT_SHADOW_CROSSINGS transparent surfaces, dark */
} RayStats;

static inline void raystats_add(RayStats *sum, const RayStats *s)
{
    sum->camera += s->camera;
    sum->shadow += s->shadow;
    sum->reflection += s->reflection;
    sum->refraction += s->refraction;
    sum->isect_tests += s->isect_tests;
    sum->cut += s->cut;
    sum->supersampled += s->supersampled;
    sum->too_deep += s->too_deep;
    sum->shadow_cut += s->shadow_cut;
}

#endif
