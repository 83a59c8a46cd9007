/*
 * stream.h - closest hits for a large batch of incoherent rays.
 *
 *     AccelStream *s = accel_stream_new(n);
 *     if (!s) ... out of memory ...
 *     accel_closest_stream(a, s, rays, n, hits, best, &stats);
 *     accel_stream_free(s);
 *
 * Rays scattered over a scene (diffuse bounces, a file of them in any
 * order) each read their own path of the BVH from memory. Traced in an
 * order of the stream's own, rays that start near each other and head into
 * the same octant go one after another and find the nodes their neighbours
 * read still in the caches (ray sorting by a hash of the quantised origin
 * and direction: Garanzha and Loop, "Fast Ray Sorting and Breadth-First
 * Packet Traversal for GPU Ray Tracing", Eurographics 2010). Coherent rays
 * (camera rays, shadow rays in pixel order) gain nothing from it: use
 * accel_closest_packet or accel_closest.
 */
#ifndef LANCER_STREAM_H
#define LANCER_STREAM_H

#include <stddef.h>

#include "lancer/accel.h"

typedef struct AccelStream AccelStream;

/* The most rays one call may take. */
#define ACCEL_STREAM_MAX ((size_t)1 << 31)

/* Room to order up to max rays (max <= ACCEL_STREAM_MAX), 40 bytes a ray,
 * its pages touched here rather than in the first trace. NULL when memory
 * runs out or max is too large. */
AccelStream *accel_stream_new(size_t max);
void accel_stream_free(AccelStream *s);

/* accel_closest for each of r[0 .. n-1]: best[k] and h[k], the same
 * answers in the caller's order. The first rays go in the caller's order,
 * and tell whether sorting the rest would pay (it costs about what a ray
 * that tests a few primitives does). Returns 1 when the rest went in the
 * stream's order, 0 when every ray went in the caller's (as all do when n
 * is above the stream's max). */
int accel_closest_stream(const Accel *a, AccelStream *s, const Ray *r, size_t n, PrimHit *h, int *best,
                         RayStats *st);

#endif
