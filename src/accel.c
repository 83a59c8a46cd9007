/*
 * accel.c - visibility queries: a BVH over the bounded primitives, and a
 * plain loop over the unbounded ones (planes), or over every one.
 */
#include "lancer/accel.h"

#include <stdlib.h>

#include "lancer/bvh.h"

#if ACCEL_PACKET != BVH_PACKET
#error "accel.h's packet must be the BVH's"
#endif

struct Accel {
    const Prim *prims;   /* the scene's, indexed by the answers */
    PrimVariant variant; /* which intersection routines answer */
    Bvh bvh;
    int *unbounded; /* scene indices of the planes (of every primitive, for a loop) */
    int nunbounded;
};

Accel *accel_build(const Scene *s, PrimVariant v, int threads) { return accel_build_as(s, v, threads, 0); }

Accel *accel_build_as(const Scene *s, PrimVariant v, int threads, int loop)
{
    Accel *a = calloc(1, sizeof *a);
    if (!a)
        return NULL;
    a->prims = s->prims;
    a->variant = v;
    a->unbounded = malloc(sizeof(int) * (size_t)(s->nprims > 0 ? s->nprims : 1));
    float lo[3], hi[3];
    for (int i = 0; a->unbounded && i < s->nprims; i++)
        if (loop || !bvh_prim_bounds(&s->prims[i], lo, hi))
            a->unbounded[a->nunbounded++] = i;
    /* the loop answers as the tree does: the nearest hit, ties to the lowest index */
    if (!a->unbounded || bvh_build(&a->bvh, s->prims, loop ? 0 : s->nprims, v, threads) != 0) {
        free(a->unbounded);
        free(a);
        return NULL;
    }
    return a;
}

void accel_free(Accel *a)
{
    if (!a)
        return;
    bvh_free(&a->bvh);
    free(a->unbounded);
    free(a);
}

PrimVariant accel_variant(const Accel *a) { return a->variant; }

int accel_bounds(const Accel *a, Vec3 *lo, Vec3 *hi)
{
    if (a->bvh.nnodes == 0)
        return -1;
    *lo = vec3(a->bvh.lo[0], a->bvh.lo[1], a->bvh.lo[2]);
    *hi = vec3(a->bvh.hi[0], a->bvh.hi[1], a->bvh.hi[2]);
    return 0;
}

size_t accel_bytes(const Accel *a) { return bvh_bytes(&a->bvh) + sizeof(int) * (size_t)a->nunbounded; }

/* The planes after the BVH's answer best (h): a plane hit nearer, or as
 * near with a lower index, replaces it. */
static int closest_unbounded(const Accel *a, const Ray *r, int best, PrimHit *h, RayStats *st)
{
    if (a->nunbounded == 0) /* a mesh alone: no pass at all */
        return best;
    Ray q = *r; /* tmax: past the nearest hit so far, to see ties */
    if (best >= 0)
        q.tmax = prim_tmax_past(h->t, r->tmax);
    PrimHit cur;
    for (int k = 0; k < a->nunbounded; k++) {
        int i = a->unbounded[k];
        if (prim_intersect(&a->prims[i], &q, a->variant, &cur) && prim_hit_wins(cur.t, i, h->t, best)) {
            best = i;
            *h = cur;
            q.tmax = prim_tmax_past(cur.t, r->tmax);
        }
    }
    st->isect_tests += (unsigned long long)a->nunbounded;
    return best;
}

#ifdef __GNUC__
__attribute__((noinline)) /* so that accel_closest stays a test and a jump */
#endif
static int closest_with_planes(const Accel *a, const Ray *r, PrimHit *h, RayStats *st)
{
    return closest_unbounded(a, r, bvh_closest(&a->bvh, r, h, &st->isect_tests), h, st);
}

int accel_closest(const Accel *a, const Ray *r, PrimHit *h, RayStats *st)
{
    /* Without planes, a tail call: a call that returned here to test for
     * planes would keep a frame for every ray. */
    return a->nunbounded ? closest_with_planes(a, r, h, st) : bvh_closest(&a->bvh, r, h, &st->isect_tests);
}

void accel_closest_packet(const Accel *a, const Ray *r, int n, PrimHit *h, int *best, RayStats *st)
{
    bvh_closest_packet(&a->bvh, r, n, h, best, &st->isect_tests);
    for (int k = 0; k < n; k++)
        best[k] = closest_unbounded(a, &r[k], best[k], &h[k], st);
}

/* 1 when a plane blocks r (any hit will do). */
static inline int unbounded_blocks(const Accel *a, const Ray *r, RayStats *st)
{
    PrimHit cur;
    for (int k = 0; k < a->nunbounded; k++) {
        st->isect_tests++;
        if (prim_intersect(&a->prims[a->unbounded[k]], r, a->variant, &cur))
            return 1;
    }
    return 0;
}

#ifdef __GNUC__
__attribute__((noinline)) /* so that accel_occluded stays a test and a jump */
#endif
static int occluded_with_planes(const Accel *a, const Ray *r, RayStats *st)
{
    return unbounded_blocks(a, r, st) || bvh_occluded(&a->bvh, r, &st->isect_tests);
}

int accel_occluded(const Accel *a, const Ray *r, RayStats *st)
{
    /* Without planes, a tail call, as accel_closest: the planes' loop
     * would keep a frame of saved registers for every ray. */
    return a->nunbounded ? occluded_with_planes(a, r, st) : bvh_occluded(&a->bvh, r, &st->isect_tests);
}

unsigned accel_occluded_packet(const Accel *a, const Ray *r, int n, RayStats *st)
{
    if (n > BVH_PACKET) /* at most BVH_PACKET at a time */
        return accel_occluded_packet(a, r, BVH_PACKET, st) |
               accel_occluded_packet(a, r + BVH_PACKET, n - BVH_PACKET, st) << BVH_PACKET;
    /* the planes first, ray by ray, as accel_occluded; the rest together */
    unsigned hit = 0;
    for (int k = 0; k < n; k++)
        hit |= (unsigned)unbounded_blocks(a, &r[k], st) << k;
    if (!hit) /* the common case: no copies */
        return bvh_occluded_packet(&a->bvh, r, n, &st->isect_tests);
    Ray rest[BVH_PACKET];
    int who[BVH_PACKET], m = 0;
    for (int k = 0; k < n; k++)
        if (!(hit >> k & 1)) {
            rest[m] = r[k];
            who[m++] = k;
        }
    unsigned in_bvh = m ? bvh_occluded_packet(&a->bvh, rest, m, &st->isect_tests) : 0;
    for (int j = 0; j < m; j++)
        hit |= (in_bvh >> j & 1u) << who[j];
    return hit;
}
