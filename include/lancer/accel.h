/*
 * accel.h - visibility queries over all primitives of a scene.
 *
 *     Accel *a = accel_build(&scene, PRIM_ROBUST, threads);
 *     if (!a) ... out of memory ...
 *     PrimHit h;
 *     int i = accel_closest(a, &ray, &h, &stats);     -1: nothing hit
 *     int blocked = accel_occluded(a, &shadow_ray, &stats);
 *     accel_free(a);
 *
 * Bounded primitives go into a BVH (bvh.h); unbounded ones (planes) are
 * tested one by one beside it. The answers are scene indices. The Accel
 * borrows the scene's arrays, which must outlive it. Its layout is its
 * own (accel.c): callers use the functions below.
 */
#ifndef LANCER_ACCEL_H
#define LANCER_ACCEL_H

#include <stddef.h>

#include "lancer/scene.h"

typedef struct Accel Accel;

/* Builds the queries over s's primitives, answered by the routines of
 * variant v, on up to `threads` threads. Returns NULL when memory runs
 * out. */
Accel *accel_build(const Scene *s, PrimVariant v, int threads);

/* The same, or with loop set no BVH at all: every primitive is tested in
 * a plain loop, which answers every query as the BVH does (the same
 * nearest hit, ties to the lowest index) and is faster for a handful of
 * them (the render plan decides: plan.h). */
Accel *accel_build_as(const Scene *s, PrimVariant v, int threads, int loop);
void accel_free(Accel *a);

/* The variant whose routines answer. */
PrimVariant accel_variant(const Accel *a);

/* The box of the bounded primitives, rounded outwards. Returns 0, or -1
 * when there are none (lo and hi are then unset). */
int accel_bounds(const Accel *a, Vec3 *lo, Vec3 *hi);

/* The memory the structure holds, in bytes (not the scene's). */
size_t accel_bytes(const Accel *a);

/* How many PN patches were split ahead of rays (accel.c), and into how
 * many pieces in all (*pieces); 0 and 0 when none was. */
int accel_pn_split(const Accel *a, int *pieces);

/* Rays that the packet queries below trace through the BVH together. */
#define ACCEL_PACKET 8

/* The primitive with the nearest hit in (0, r->tmax) and its PrimHit, or -1. */
int accel_closest(const Accel *a, const Ray *r, PrimHit *h, RayStats *st);

/* accel_closest, passing over the primitives skip[0 .. nskip-1] (the
 * scene's indices): for the few rays that must go past surfaces they start
 * on (shade.c). Slower, with the same hits otherwise. */
int accel_closest_except(const Accel *a, const Ray *r, const int *skip, int nskip, PrimHit *h, RayStats *st);

/* accel_closest for each of r[0 .. n-1]: best[k] and h[k]. Neighbouring
 * rays, such as camera rays and their mirror rays, are traced through the
 * BVH together . */
void accel_closest_packet(const Accel *a, const Ray *r, int n, PrimHit *h, int *best, RayStats *st);

/* 1 when anything is hit in (0, r->tmax): stops at the first hit found. */
int accel_occluded(const Accel *a, const Ray *r, RayStats *st);

/* accel_occluded for each of r[0 .. n-1], n <= 32: bit k of the result
 * for ray k. Neighbouring shadow rays go through the BVH together
 * (bvh_occluded_packet). */
unsigned accel_occluded_packet(const Accel *a, const Ray *r, int n, RayStats *st);

#endif
