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
 * Layout. Nodes are 32 bytes: a float box, then `first` and `count`. A leaf
 * has count > 0 and holds prims[first .. first + count - 1], a copy of the
 * primitives in leaf order (order[] maps each back to the caller's index).
 * An inner node has count == 0; its children are nodes[first] and
 * nodes[first + 1], and `axis` is the axis it was split on. Node 0 is the
 * root. Unbounded primitives (planes) are not in the tree: bvh_build skips
 * them, and the caller tests them separately.
 *
 * Traversal runs on Bvh4Node, a 4-wide copy of the binary tree.
 *
 * Conservative traversal (Ize, "Robust BVH Ray Traversal", JCGT 2013): box
 * bounds are rounded outwards when built, and every slab's far distance is
 * grown by 1 + 2 gamma(3), so the tree never culls a hit that the
 * primitive's own routine would find.
 */
#ifndef LANCER_BVH_H
#define LANCER_BVH_H

#include <stddef.h>
#include <stdint.h>

#include "lancer/prim.h"

typedef struct {
    float lo[3], hi[3];
    uint32_t first;
    uint16_t count;
    uint16_t axis;
} BvhNode;

/* The 4-wide layout traversal uses, collapsed from the binary tree: four
 * child boxes side by side per axis, so one node's boxes are tested at once
 * (with SSE where the compiler offers it, else lane by lane). child[i] >= 0
 * is an inner node; a leaf slot has child[i] = -1 - first and count[i] > 0;
 * an empty slot has count 0, child -1 and an empty box. */
typedef struct {
    float lo[3][4], hi[3][4];
    int32_t child[4];
    uint8_t count[4];
    uint8_t pad[12];
} Bvh4Node;

typedef struct {
    BvhNode *nodes;
    int nnodes;
    Bvh4Node *nodes4;
    int nnodes4;
    Prim *prims; /* bounded primitives in leaf order */
    int *order;  /* order[i]: the caller's index of prims[i] */
    Vec3 (*tri)[3]; /* robust variant: triangles' vertices, compact, in leaf
                     * order (unused for other kinds) */
    unsigned char *is_tri; /* robust variant: 1 where prims[i] is a triangle */
    int nprims;
    PrimVariant variant;
} Bvh;

/* Builds the tree over the bounded primitives among prims[0 .. n-1] with
 * binned SAH, on up to `threads` threads. Returns 0, or -1 when memory runs
 * out (b is then empty and bvh_free is safe). */
int bvh_build(Bvh *b, const Prim *prims, int n, PrimVariant v, int threads);
void bvh_free(Bvh *b);

/* Checks the invariants: every child box lies inside its parent's, every
 * leaf box holds its primitives' bounds, and every primitive is referenced
 * exactly once. Returns 0, or -1 with what is wrong in err. */
int bvh_validate(const Bvh *b, char *err, size_t errlen);

/* The caller's index of the primitive with the nearest hit in (0, r->tmax),
 * and its PrimHit; -1 when nothing is hit. Of hits at exactly the same t,
 * the lowest index wins, so the answer does not depend on the tree. */
int bvh_closest(const Bvh *b, const Ray *r, PrimHit *h, unsigned long long *tests);

/* 1 when any primitive is hit in (0, r->tmax): stops at the first found. */
int bvh_occluded(const Bvh *b, const Ray *r, unsigned long long *tests);

/* The primitive's bounds, rounded outwards; 0 for an unbounded one. */
int bvh_prim_bounds(const Prim *p, float lo[3], float hi[3]);

#endif
