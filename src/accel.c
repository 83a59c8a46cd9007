/*
 * accel.c - visibility queries: a BVH over the bounded primitives, and a
 * plain loop over the unbounded ones (planes), or over every one.
 */
#include "lancer/accel.h"

#include <stdlib.h>
#include <string.h>

#include "lancer/bvh.h"
#include "lancer/pntri.h"

#if ACCEL_PACKET != BVH_PACKET
#error "accel.h's packet must be the BVH's"
#endif

typedef struct Piece Piece;

struct Accel {
    const Prim *prims;   /* the BVH's and the loop's: the scene's, or own */
    PrimVariant variant; /* which intersection routines answer */
    Bvh bvh;
    int *unbounded; /* indices into prims of the planes (of every primitive, for a loop) */
    int nunbounded;
    int nscene;     /* the scene's primitives: the BVH's first ones */
    Prim *own;      /* NULL, or the BVH's primitives: the scene's, then pieces of PN patches */
    int *owner;     /* own[nscene + k] is a piece of scene primitive owner[k] */
    struct Piece *pieces; /* the split patches' pieces */
    int nown, npieces;
};

/* An index into prims as the scene's. */
static inline int scene_index(const Accel *a, int i) { return i >= a->nscene ? a->owner[i - a->nscene] : i; }

/* PN patches split ahead of rays. Exact mode splits a patch, for every
 * ray that meets it, until its pieces can be proven crossed once
 * (pntri.c); the pieces of the first splits are the same for every ray,
 * so they are made once here and put in the BVH in the patch's place,
 * which then culls them as it culls triangles. A ray starts from the
 * pieces it meets and finds the same hits; fast mode's Newton steps start
 * there too, nearer the hit. Pieces whose slope is above ACCEL_PN_SLOPE
 * are split, up to ACCEL_PN_DEPTH times, a whole level of them at a time
 * and only while the pieces added stay within ACCEL_PN_PIECES: a scene of
 * many gently curved patches (a scanned mesh) gains little from it and
 * would pay its memory. The classic variant traces patches whole. */
#define ACCEL_PN_SLOPE 0.1
#define ACCEL_PN_DEPTH 4
#define ACCEL_PN_PIECES 16384

struct Piece {
    PnPiece pc;
    double slope;
    int owner; /* the scene's primitive */
};

static int splits_ahead(const Prim *p, PrimVariant v)
{
    return v == PRIM_ROBUST && p->kind == PRIM_PN;
}

static int too_steep(double slope) { return !(slope <= ACCEL_PN_SLOPE); }

/* Fills a->own, a->owner and a->pieces when a patch is split. Returns the
 * BVH's primitives (the scene's when none is), or -1 when memory runs out. */
static int split_ahead(Accel *a, const Scene *s, PrimVariant v)
{
    /* a count first, so that a scene whose first level does not fit (a
     * scanned mesh) allocates nothing; the second pass makes the roots again */
    int n = 0;
    for (int i = 0; i < s->nprims && n <= ACCEL_PN_PIECES / 3; i++)
        if (splits_ahead(&s->prims[i], v)) {
            PnNet root;
            pn_net_root(s->prims[i].g.pn.patch, &root);
            n += too_steep(pn_net_slope(s->prims[i].g.pn.patch, &root));
        }
    if (n == 0 || n > ACCEL_PN_PIECES / 3)
        return s->nprims;
    int cap = n + ACCEL_PN_PIECES, np = 0;
    Piece *pc = malloc(sizeof *pc * (size_t)cap);
    int *split = calloc((size_t)s->nprims, sizeof *split); /* pieces of each primitive so far */
    if (!pc || !split) {
        free(pc);
        free(split);
        return -1;
    }
    for (int i = 0; i < s->nprims; i++)
        if (splits_ahead(&s->prims[i], v)) {
            Piece *q = &pc[np];
            pn_net_root(s->prims[i].g.pn.patch, &q->pc.net);
            q->slope = pn_net_slope(s->prims[i].g.pn.patch, &q->pc.net);
            q->owner = i;
            q->pc.depth = 0;
            np += too_steep(q->slope);
        }
    for (int depth = 0; depth < ACCEL_PN_DEPTH; depth++) {
        int nc = 0, end = np;
        for (int k = 0; k < np; k++)
            nc += pc[k].pc.depth == depth && too_steep(pc[k].slope);
        if (nc == 0 || np + 3 * nc > cap)
            break;
        for (int k = 0; k < end; k++) {
            if (pc[k].pc.depth != depth || !too_steep(pc[k].slope))
                continue;
            const PnPatch *pn = s->prims[pc[k].owner].g.pn.patch;
            PnNet child[4];
            pn_net_split(&pc[k].pc.net, child);
            for (int j = 0; j < 4; j++) {
                Piece *o = j == 0 ? &pc[k] : &pc[np++];
                o->pc.net = child[j];
                o->pc.depth = depth + 1;
                o->slope = pn_net_slope(pn, &o->pc.net);
                o->owner = pc[k].owner;
            }
        }
    }
    /* the first piece of a patch takes its place, the rest follow the scene's */
    int m = s->nprims + np - n;
    a->own = malloc(sizeof *a->own * (size_t)m);
    a->owner = malloc(sizeof *a->owner * (size_t)(np - n));
    if (!a->own || !a->owner) {
        free(pc);
        free(split);
        return -1;
    }
    memcpy(a->own, s->prims, sizeof *a->own * (size_t)s->nprims);
    m = s->nprims;
    for (int k = 0; k < np; k++) {
        int i = pc[k].owner;
        Prim *p = &a->own[i];
        if (split[i]++) {
            p = &a->own[m];
            *p = s->prims[i];
            a->owner[m++ - s->nprims] = i;
        }
        pn_piece_init(&pc[k].pc, s->prims[i].g.pn.patch);
        p->g.pn.piece = &pc[k].pc;
    }
    free(split);
    a->pieces = pc;
    a->npieces = np;
    a->nown = m;
    return m;
}

Accel *accel_build(const Scene *s, PrimVariant v, int threads) { return accel_build_as(s, v, threads, 0); }

Accel *accel_build_as(const Scene *s, PrimVariant v, int threads, int loop)
{
    Accel *a = calloc(1, sizeof *a);
    if (!a)
        return NULL;
    a->variant = v;
    a->nscene = s->nprims;
    /* the loop splits patches too, so that it answers as the tree does */
    int nb = split_ahead(a, s, v);
    if (nb < 0) {
        accel_free(a);
        return NULL;
    }
    a->prims = a->own ? a->own : s->prims;
    a->unbounded = malloc(sizeof(int) * (size_t)(nb > 0 ? nb : 1));
    float lo[3], hi[3];
    for (int i = 0; a->unbounded && i < nb; i++)
        if (loop || !bvh_prim_bounds(&a->prims[i], lo, hi))
            a->unbounded[a->nunbounded++] = i;
    /* the loop answers as the tree does: the nearest hit, ties to the lowest index */
    if (!a->unbounded || bvh_build(&a->bvh, a->prims, loop ? 0 : nb, v, threads) != 0) {
        accel_free(a);
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
    free(a->own);
    free(a->owner);
    free(a->pieces);
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

size_t accel_bytes(const Accel *a)
{
    size_t own = sizeof(Prim) * (size_t)a->nown + sizeof(int) * (size_t)(a->nown - a->nscene) +
                 sizeof(struct Piece) * (size_t)a->npieces;
    return bvh_bytes(&a->bvh) + sizeof(int) * (size_t)a->nunbounded + (a->own ? own : 0);
}

int accel_pn_split(const Accel *a, int *pieces)
{
    *pieces = a->own ? a->npieces : 0;
    return a->own ? a->npieces - (a->nown - a->nscene) : 0; /* a patch's first piece takes its place */
}

/* Plane i (unbounded) against the rays r[0 .. n-1] up to tmax[k], n <=
 * ACCEL_PACKET: bit k when ray k hits it, at cur[k]. Robust planes take
 * the rays together. */
static unsigned unbounded_rays(const Accel *a, int i, const Ray *r, const float *tmax, int n, PrimHit *cur)
{
    const Prim *p = &a->prims[i];
    if (p->kind == PRIM_PLANE && a->variant == PRIM_ROBUST)
        return prim_plane_hit_robust_rays(&p->g.plane, r, tmax, n, cur);
    unsigned hit = 0;
    for (int k = 0; k < n; k++) {
        Ray q = r[k];
        q.tmax = tmax[k];
        hit |= (unsigned)prim_intersect(p, &q, a->variant, &cur[k]) << k;
    }
    return hit;
}

/* The planes after the BVH's answers best[k] (h[k]), indices into prims,
 * for the rays r[0 .. n-1], n <= ACCEL_PACKET, a plane at a time for all
 * of them: a plane hit nearer, or as near with a lower index, replaces it. */
static void closest_unbounded(const Accel *a, const Ray *r, int n, int *best, PrimHit *h, RayStats *st)
{
    for (int u = 0; u < a->nunbounded; u++) {
        const int i = a->unbounded[u];
        float tmax[ACCEL_PACKET];
        PrimHit cur[ACCEL_PACKET];
        for (int k = 0; k < n; k++) /* past the nearest hit so far, to see ties */
            tmax[k] = best[k] >= 0 ? prim_tmax_past(h[k].t, r[k].tmax) : r[k].tmax;
        unsigned m = unbounded_rays(a, i, r, tmax, n, cur);
        for (int k = 0; k < n; k++)
            if ((m >> k & 1) && prim_hit_wins(cur[k].t, i, h[k].t, best[k])) {
                best[k] = i;
                h[k] = cur[k];
            }
    }
    st->isect_tests += (unsigned long long)a->nunbounded * (unsigned long long)n;
}

#ifdef __GNUC__
__attribute__((noinline)) /* so that accel_closest stays a test and a jump */
#endif
static int closest_with_planes(const Accel *a, const Ray *r, PrimHit *h, RayStats *st)
{
    int i = bvh_closest(&a->bvh, r, h, &st->isect_tests);
    closest_unbounded(a, r, 1, &i, h, st);
    return i < 0 ? i : scene_index(a, i);
}

int accel_closest(const Accel *a, const Ray *r, PrimHit *h, RayStats *st)
{
    /* Without planes, a tail call: a call that returned here to test for
     * planes would keep a frame for every ray. */
    if (a->nunbounded || a->own)
        return closest_with_planes(a, r, h, st);
    return bvh_closest(&a->bvh, r, h, &st->isect_tests);
}

void accel_closest_packet(const Accel *a, const Ray *r, int n, PrimHit *h, int *best, RayStats *st)
{
    if (n == 1) { /* a packet's set-up costs more than one ray saves */
        best[0] = accel_closest(a, r, h, st);
        return;
    }
    bvh_closest_packet(&a->bvh, r, n, h, best, &st->isect_tests);
    for (int k = 0; k < n; k += ACCEL_PACKET)
        closest_unbounded(a, r + k, n - k < ACCEL_PACKET ? n - k : ACCEL_PACKET, best + k, h + k, st);
    for (int k = 0; k < n; k++)
        best[k] = best[k] < 0 ? best[k] : scene_index(a, best[k]);
}

/* The scene's primitives accel_closest_except passes over. */
typedef struct {
    const Accel *a;
    const int *skip;
    int n;
} Skip;

static int skipped(void *ctx, int i)
{
    const Skip *k = ctx;
    const int id = scene_index(k->a, i);
    for (int j = 0; j < k->n; j++)
        if (k->skip[j] == id)
            return 1;
    return 0;
}

int accel_closest_except(const Accel *a, const Ray *r, const int *skip, int nskip, PrimHit *h, RayStats *st)
{
    Skip k = {a, skip, nskip};
    int i = bvh_closest_except(&a->bvh, r, skipped, &k, h, &st->isect_tests);
    for (int u = 0; u < a->nunbounded; u++) { /* the planes, as closest_unbounded */
        const int j = a->unbounded[u];
        PrimHit cur;
        Ray q = *r;
        if (skipped(&k, j))
            continue;
        st->isect_tests++;
        if (i >= 0)
            q.tmax = prim_tmax_past(h->t, r->tmax);
        if (prim_intersect(&a->prims[j], &q, a->variant, &cur) && prim_hit_wins(cur.t, j, h->t, i)) {
            i = j;
            *h = cur;
        }
    }
    return i < 0 ? i : scene_index(a, i);
}

/* 1 when a plane blocks r (any hit will do): one ray's own loop, which
 * stops at the first; unbounded_rays costs the rays that go one by one
 * (an adaptive area light's) more. */
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
    if (n == 1) /* as accel_closest_packet */
        return (unsigned)accel_occluded(a, r, st);
    /* the planes first, as accel_occluded, a plane at a time for the rays
     * it has not blocked yet; the rest together */
    unsigned hit = 0;
    float tmax[BVH_PACKET];
    for (int k = 0; k < n; k++)
        tmax[k] = r[k].tmax;
    for (int u = 0; u < a->nunbounded && hit != (1u << n) - 1; u++) {
        PrimHit cur[BVH_PACKET];
        for (int k = 0; k < n; k++) /* as unbounded_blocks counts */
            st->isect_tests += !(hit >> k & 1);
        hit |= unbounded_rays(a, a->unbounded[u], r, tmax, n, cur);
    }
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
