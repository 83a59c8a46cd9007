/*
 * bench.h - ray-casting benchmarks: rays framing a scene, and timed passes.
 * A client of the library, beside the command line (lancer bench) and the
 * benchmark programs in tests/bench.
 *
 *     RaySet primary, shadow, diffuse;
 *     bench_gen_rays(&scene, accel, 1024, 1024, 0, 1, &primary, &shadow, &diffuse);  (0: loose)
 *     BenchResult res;
 *     bench_trace(accel, primary.rays, primary.n, BENCH_CLOSEST, 3, &res);
 *     ... res.mrays, res.hits ...
 *     bench_free(&primary); ...
 *
 * The rays are the usual three sets of CPU ray-tracing benchmarks, so that
 * figures can be set beside Embree's on the same files (rayfile.h):
 *
 * - primary: a camera framing the scene's bounds, one ray per pixel centre;
 *   loosely (the whole bounds in view, many rays miss) or tightly (a
 *   narrower view of the surface, where BENCH_TIGHT_HITS of the rays hit);
 * - shadow: from each primary hit to one point light, tmax = the distance;
 * - diffuse: from each primary hit in a uniformly random direction of the
 *   hemisphere its geometric normal faces, shuffled so that neighbouring
 *   rays are unrelated.
 *
 * Secondary rays start at prim_spawn_origin, so they begin strictly off
 * their surface and need no t_min.
 */
#ifndef LANCER_CLI_BENCH_H
#define LANCER_CLI_BENCH_H

#include <stddef.h>

#include "lancer/accel.h"
#include "lancer/stream.h"

typedef struct {
    Ray *rays;
    size_t n;
} RaySet;

typedef struct {
    double mrays; /* the best pass, millions of rays per second */
    size_t hits;
    double sumt; /* the sum of t over hits (closest hit only) */
} BenchResult;

/* The share of camera rays that hit in a tight framing, when some view
 * reaches it. */
#define BENCH_TIGHT_HITS 0.9

/* Generates the three sets for a w x h camera framing scene s, whose
 * queries a answers, loosely or tightly (the seed fixes the diffuse
 * directions and their order). Returns 0, or -1 when memory runs out or
 * the scene has no bounded primitive to frame. */
int bench_gen_rays(const Scene *s, const Accel *a, int w, int h, int tight, unsigned long long seed, RaySet *primary,
                   RaySet *shadow, RaySet *diffuse);

typedef enum {
    BENCH_CLOSEST, /* closest hits, ray by ray */
    BENCH_ANY,     /* any hit, ray by ray */
    BENCH_PACKET,  /* closest hits, ACCEL_PACKET neighbours at a time */
    BENCH_STREAM   /* closest hits, the whole file at once (stream.h) */
} BenchKind;

/* Traces the rays on the calling thread: one warm-up pass, then `passes`
 * timed ones. Returns 0, or -1 when memory runs out. */
int bench_trace(const Accel *a, const Ray *rays, size_t n, BenchKind kind, int passes, BenchResult *res);

/* One pass of bench_trace: the seconds it took; the hits, and for closest
 * hit the sum of their t, into *hits and *sumt. */
double bench_pass(const Accel *a, const Ray *rays, size_t n, int any, size_t *hits, double *sumt);

/* bench_pass for closest hits, ACCEL_PACKET rays at a time in their order
 * (accel_closest_packet), as the renderer traces neighbouring camera rays. */
double bench_pass_packet(const Accel *a, const Ray *rays, size_t n, size_t *hits, double *sumt);

/* bench_pass for closest hits, all n rays in one accel_closest_stream
 * through s, which holds room for n; h and best hold n answers. */
double bench_pass_stream(const Accel *a, AccelStream *s, const Ray *rays, size_t n, PrimHit *h, int *best, size_t *hits,
                         double *sumt);

void bench_free(RaySet *s);

#endif
