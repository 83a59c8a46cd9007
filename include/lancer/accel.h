/*
 * accel.h - visibility queries over all primitives of a scene.
 *
 *     Accel a;
 *     if (accel_build(&a, &scene) != 0) ... out of memory ...
 *     PrimHit h;
 *     int i = accel_closest(&a, &ray, &h, &stats);     -1: nothing hit
 *     int blocked = accel_occluded(&a, &shadow_ray, &stats);
 *     accel_free(&a);
 *
 * Bounded primitives go into a BVH (bvh.h); unbounded ones (planes) are
 * tested one by one beside it. The Accel borrows the scene's arrays, which
 * must outlive it.
 */
#ifndef LANCER_ACCEL_H
#define LANCER_ACCEL_H

#include "lancer/bvh.h"
#include "lancer/scene.h"

typedef struct {
    const Prim *prims; /* the scene's, indexed by the answers */
    PrimVariant variant; /* which intersection routines answer */
    Bvh bvh;
    int *unbounded; /* scene indices of the planes */
    int nunbounded;
} Accel;

/* Uses the scene's intersection variant (robust unless it asks for classic),
 * building on up to `threads` threads. Returns 0, or -1 when memory runs
 * out. */
int accel_build(Accel *a, const Scene *s, int threads);
void accel_free(Accel *a);

/* The primitive with the nearest hit in (0, r->tmax) and its PrimHit, or -1. */
int accel_closest(const Accel *a, const Ray *r, PrimHit *h, RayStats *st);

/* accel_closest for each of r[0 .. n-1]: best[k] and h[k]. Neighbouring
 * rays, such as camera rays and their mirror rays, are traced through the
 * BVH together (bvh_closest_packet). */
void accel_closest_packet(const Accel *a, const Ray *r, int n, PrimHit *h, int *best, RayStats *st);

/* 1 when anything is hit in (0, r->tmax): stops at the first hit found. */
int accel_occluded(const Accel *a, const Ray *r, RayStats *st);

/* accel_occluded for each of r[0 .. n-1], n <= 32: bit k of the result
 * for ray k. Neighbouring shadow rays go through the BVH together
 * (bvh_occluded_packet). */
unsigned accel_occluded_packet(const Accel *a, const Ray *r, int n, RayStats *st);

#endif
