/*
 * bvh.h - a bounding volume hierarchy over bounded primitives.
 *
 *     Bvh b;
 *     if (bvh_build(&b, scene.prims, scene.nprims, PRIM_ROBUST, threads) != 0) ... out of memory ...
 *     PrimHit h;
 *     int i = bvh_closest(&b, &ray, &h, &stats);   scene index of the nearest hit, or -1
 *     int blocked = bvh_occluded(&b, &shadow_ray, &stats);
 *     bvh_free(&b);
 *
 * The tree is built binary (binned SAH) and collapsed into BVH_WIDTH-wide
 * nodes, which are what traversal reads: the child boxes side by side per
 * axis, tested at once (bvh_traverse.c: AVX2 when the processor has it,
 * else SSE where the compiler offers it, else lane by lane).
 * A slot's child is an inner node (child >= 0) or a leaf (-1 - leaf index);
 * an unused slot has an empty box (lo = +inf, hi = -inf), which no finite
 * ray enters, and leads to leaf 0. Node 0 is the root.
 *
 * A leaf holds one to BVH_LEAF_MAX primitives, order[first .. first +
 * count - 1] in the caller's numbering; the triangles among them (robust
 * variant) are copied into the leaf side by side, so that one SIMD test
 * judges them all (tri4.h). The caller's primitives are not copied: they
 * must outlive the tree. Unbounded primitives (planes) are not in the
 * tree: bvh_build skips them, and the caller tests them separately.
 *
 * Conservative traversal (Ize, "Robust BVH Ray Traversal", JCGT 2013): box
 * bounds are rounded outwards when built, every slab's far distance is
 * grown by BVH_SLAB_PAD, and boxes are entered up to tmax grown by
 * BVH_REACH, so the tree never culls a hit that the primitive's own
 * routine would find.
 */
#ifndef LANCER_BVH_H
#define LANCER_BVH_H

#include <stddef.h>
#include <stdint.h>

#include "lancer/prim.h"

/* With u = 2^-24: a slab's near distance (plane - o) * (1 / d) carries
 * three roundings, so it is at most (1 + u)^3 times the exact one; its far
 * distance (plane - o) * ((1 / d) * BVH_SLAB_PAD) carries four, so it is at
 * least (1 - u)^4 BVH_SLAB_PAD times the exact one. A ray that touches a box
 * (exact near <= exact far) keeps it when BVH_SLAB_PAD >= (1 + u)^3 / (1 -
 * u)^4, about 1 + 7u: 1 + 8u, 1 + 2 gamma(4) rounded. (Ize's 1 + 2 gamma(3)
 * is short by one rounding for a ray through a box's edge: found by
 * review.) The pads are written as whole numbers of u, so that bvh.c can
 * check these conditions at compile time. */
#define BVH_SLAB_PAD_U 8
#define BVH_SLAB_PAD (1.0f + BVH_SLAB_PAD_U * 0x1p-24f)
/* Boxes are entered up to the ray's tmax grown by this much: a hit the
 * primitive's routine places just before tmax may have its box's entry
 * computed just after it, by the three roundings above (a triangle in an
 * axis plane, whose box face is its plane, lost hits placed one float
 * before tmax). It covers those roundings, tmax * BVH_REACH's own, and a
 * hit's error of up to 2^-18 of its t; a hit less certain than that may
 * lie on either side of tmax anyway: BVH_REACH (1 - u) >= (1 + 2^-18) (1 +
 * u)^3. */
#define BVH_REACH_U 128
#define BVH_REACH (1.0f + BVH_REACH_U * 0x1p-24f)

/* Children per node: 8, one AVX register or two SSE ones per plane. */
#define BVH_WIDTH 8
/* No input makes the tree deeper (bvh.c), which bounds traversal stacks. */
#define BVH_MAX_DEPTH 96

typedef struct {
    float lo[3][BVH_WIDTH], hi[3][BVH_WIDTH];
    int32_t child[BVH_WIDTH];
    uint8_t pad[(64 - 28 * BVH_WIDTH % 64) % 64]; /* to whole cache lines */
} BvhWideNode;

/* Primitives per leaf: eight lanes, tested at once by AVX2 (in two halves
 * by SSE). */
#define BVH_LEAF_MAX 8

typedef struct {
    PrimTri8 tri;    /* lane i: primitive first + i, when bit i of tris is set */
    int32_t first;   /* into order[] */
    uint8_t count;   /* 1 to BVH_LEAF_MAX */
    uint8_t tris;    /* bit i: primitive first + i is a triangle (robust only) */
    uint8_t pad[26]; /* to whole cache lines */
} BvhLeaf;

typedef struct {
    void *mem; /* one block: the leaves and the nodes, from its start; its pages past them are given back */
    BvhWideNode *nodes;
    int nnodes;
    BvhLeaf *leaves;
    int nleaves;
    const Prim *prims; /* the caller's array */
    int *order;        /* order[i]: the caller's index of the i-th primitive in leaf order */
    int nprims;        /* bounded primitives: the length of order[] */
    float lo[4], hi[4]; /* the root box: x, y, z and a 0 (for SIMD loads) */
    PrimVariant variant;
} Bvh;

/* Builds the tree over the bounded primitives among prims[0 .. n-1] with
 * binned SAH, on up to `threads` threads. Returns 0, or -1 when memory runs
 * out (b is then empty and bvh_free is safe). prims must outlive b. */
int bvh_build(Bvh *b, const Prim *prims, int n, PrimVariant v, int threads);
void bvh_free(Bvh *b);

/* The memory the tree holds, in bytes (not counting the caller's prims). */
size_t bvh_bytes(const Bvh *b);

/* Checks the invariants: every slot's box lies inside its parent slot's,
 * every leaf's box holds its primitives' bounds and its copied vertices
 * are theirs, every primitive is referenced exactly once, every inner
 * child lies after its parent and every unused slot leads to leaf 0, so
 * that no ray, not even one of NaNs, can revisit a node. Returns 0, or -1
 * with what is wrong in err. */
int bvh_validate(const Bvh *b, char *err, size_t errlen);

/* The caller's index of the primitive with the nearest hit in (0, r->tmax),
 * and its PrimHit; -1 when nothing is hit. Of hits at exactly the same t,
 * the lowest index wins, so the answer does not depend on the tree. */
int bvh_closest(const Bvh *b, const Ray *r, PrimHit *h, unsigned long long *tests);

/* bvh_closest, passing over every primitive i for which skip(ctx, i) is
 * nonzero: for the few rays that must go past surfaces they start on
 * (shade.c). Leaf after leaf in no order, and each primitive by its own
 * routine: slower than bvh_closest, with the same hits. */
int bvh_closest_except(const Bvh *b, const Ray *r, int (*skip)(void *ctx, int i), void *ctx, PrimHit *h,
                       unsigned long long *tests);

/* Rays traced together by bvh_closest_packet, at most. */
#define BVH_PACKET 8

/* bvh_closest for each of r[0 .. n-1]: best[k] and h[k], the same answers.
 * BVH_PACKET at a time, rays whose directions share their signs
 * (neighbouring camera rays, or their mirror rays) are traced as a packet,
 * one box test for all (with AVX2); any others one by one. */
void bvh_closest_packet(const Bvh *b, const Ray *r, int n, PrimHit *h, int *best, unsigned long long *tests);

/* 1 when any primitive is hit in (0, r->tmax): stops at the first found. */
int bvh_occluded(const Bvh *b, const Ray *r, unsigned long long *tests);

/* bvh_occluded for each of r[0 .. n-1], n <= 32: bit k of the result for
 * ray k, the same verdicts. BVH_PACKET at a time, rays whose directions
 * share their signs (neighbouring shadow rays, from any origins) are traced
 * as a packet, one box test for all (with AVX2); any others one by one. */
unsigned bvh_occluded_packet(const Bvh *b, const Ray *r, int n, unsigned long long *tests);

/* The primitive's bounds, rounded outwards; 0 for an unbounded one. */
int bvh_prim_bounds(const Prim *p, float lo[3], float hi[3]);

#endif
