/*
 * bvh_traverse.c - closest-hit and any-hit traversal of the tree that
 * bvh.c builds (see bvh.h for the layout).
 *
 * A stack; closest-hit rays visit the nearest entered child next, the
 * others wait farthest deepest. A node's boxes are tested at once with the
 * slab test made conservative after Ize 2013 (bvh.h), a leaf's triangles
 * at once by the SIMD watertight test (tri4.h).
 *
 * This file is compiled up to three ways: with SSE (the baseline on
 * x86-64, or -DLANCER_NO_SIMD for a scalar loop), and on x86-64 once more
 * with -mavx2 -mbmi -DLANCER_AVX2_VARIANT, which tests eight boxes in one
 * register. The baseline object picks the AVX2 one at run time when the
 * processor has it (not with -DLANCER_NO_AVX2). All give the same answers:
 * the same operations, lane by lane, with no FMA. On an AMD processor with
 * AVX-512, a packet's rays take a leaf of triangles two at a time, sixteen
 * lanes of the same test (tri4.h).
 */
#include "lancer/bvh.h"
#include "tri4.h"

#include <float.h>
#include <stddef.h>
#if defined(__SSE2__) && !defined(LANCER_NO_SIMD)
#define BVH_SSE 1
#include <emmintrin.h>
#endif
#if defined(LANCER_AVX2_VARIANT)
#include <immintrin.h>
#include "ray_lanes.h"
#define BVH_AVX 1
#define CLOSEST bvh_closest_avx2
#define OCCLUDED bvh_occluded_avx2
#elif defined(BVH_SSE) && defined(__x86_64__) && defined(__GNUC__) && !defined(LANCER_NO_AVX2)
#define BVH_DISPATCH 1
#define CLOSEST closest_base
#define OCCLUDED occluded_base
#else
#define CLOSEST closest_one
#define OCCLUDED occluded_one
#endif

#if defined(BVH_AVX) || defined(BVH_DISPATCH)
/* The AVX2 object's functions: what it defines, what the baseline calls. */
int bvh_closest_avx2(const Bvh *b, const Ray *r, PrimHit *h, unsigned long long *tests);
int bvh_occluded_avx2(const Bvh *b, const Ray *r, unsigned long long *tests);
void bvh_closest_packet_avx2(const Bvh *b, const Ray *r, int n, PrimHit *h, int *best, unsigned long long *tests);
unsigned bvh_occluded_packet_avx2(const Bvh *b, const Ray *r, int n, unsigned long long *tests);
#endif

/* ---- traversal ---- */

typedef struct {
#ifdef BVH_AVX
    __m256 o8[3], inv8[3], ipad8[3];
#elif defined(BVH_SSE)
    __m128 o4[3], inv4[3], ipad4[3];
#endif
    float o[3], inv[3], ipad[3]; /* ipad: inv * BVH_SLAB_PAD (bvh.h), one product less per far plane */
    int near[3], far[3]; /* byte offsets in a node of the near and far planes, by axis */
} RayPre;

/* What the leaves' triangle test needs, set up at the first leaf: many
 * rays reach none. Kept apart from RayPre, whose address never escapes,
 * so that the compiler keeps RayPre in registers. */
typedef struct {
    PrimTriRay tri;
    int ready;
} TriPre;

/* 1 / d by axis into inv[0 .. 2] (inv[3] is scratch). Where d is not 0
 * but 1 / d overflows (|d| at most 2^-128), a NaN: the ray drifts along
 * that axis too slowly for float distances to follow, and a NaN distance
 * leaves the slab test's bounds as they were, so that axis culls nothing
 * (an infinity would take the ray as parallel to the slab, and cull the
 * boxes it drifts into). */
static inline void inverse_dir(const Ray *r, float inv[4])
{
#ifdef BVH_SSE
    /* one division for the three axes (lane 3 is 1/1) */
    const __m128 d = _mm_setr_ps(r->d.x, r->d.y, r->d.z, 1.0f), q = _mm_div_ps(_mm_set1_ps(1.0f), d);
    /* from d, beside the division: 1 / d overflows just where |d| <= 2^-128 */
    const __m128 over = _mm_and_ps(_mm_cmple_ps(_mm_andnot_ps(_mm_set1_ps(-0.0f), d), _mm_set1_ps(0x1p-128f)),
                                   _mm_cmpneq_ps(d, _mm_setzero_ps()));
    _mm_storeu_ps(inv, _mm_or_ps(q, over)); /* (all ones: a NaN) */
#else
    for (int a = 0; a < 3; a++) {
        const float d = vec_comp(r->d, a);
        inv[a] = 1.0f / d;
        if (isinf(inv[a]) && d != 0.0f)
            inv[a] = NAN;
    }
    inv[3] = 1.0f;
#endif
}

/* The byte offsets in a node of axis a's near and far planes, for a
 * direction of that sign (neg: negative). By arithmetic: a branch on a
 * random ray's signs mispredicts half the time. */
static inline void slab_planes(int a, int neg, int *near, int *far)
{
    int lo = (int)(offsetof(BvhWideNode, lo) + sizeof(float[BVH_WIDTH]) * (size_t)a);
    int hi = (int)(offsetof(BvhWideNode, hi) + sizeof(float[BVH_WIDTH]) * (size_t)a);
    *near = lo + neg * (hi - lo);
    *far = hi - neg * (hi - lo);
}

static inline void ray_pre(const Ray *r, RayPre *p)
{
    const float o[3] = {r->o.x, r->o.y, r->o.z};
    float inv[4];
    inverse_dir(r, inv);
    for (int i = 0; i < 3; i++) {
        p->o[i] = o[i];
        p->inv[i] = inv[i];
        p->ipad[i] = inv[i] * BVH_SLAB_PAD;
        slab_planes(i, inv[i] < 0.0f, &p->near[i], &p->far[i]);
#ifdef BVH_AVX
        p->o8[i] = _mm256_set1_ps(o[i]);
        p->inv8[i] = _mm256_set1_ps(inv[i]);
        p->ipad8[i] = _mm256_set1_ps(p->ipad[i]);
#elif defined(BVH_SSE)
        p->o4[i] = _mm_set1_ps(o[i]);
        p->inv4[i] = _mm_set1_ps(inv[i]);
        p->ipad4[i] = _mm_set1_ps(p->ipad[i]);
#endif
    }
}

#ifdef BVH_SSE
/* Starts loading a child the ray will visit, while the current node is
 * still being worked on: a leaf's five cache lines, or a node's four (and
 * the next one's first). Always five, without a loop: a loop of four or five
 * by the child's kind mispredicted its exit. */
static inline void prefetch_child(const Bvh *b, int32_t c)
{
    const char *m = c >= 0 ? (const char *)&b->nodes[c] : (const char *)&b->leaves[-1 - c];
    for (int k = 0; k < 5; k++) /* (a node's fifth line starts one past it: still a valid pointer) */
        _mm_prefetch(m + 64 * k, _MM_HINT_T0);
}
typedef char prefetch_covers_a_child[sizeof(BvhLeaf) <= 5 * 64 && sizeof(BvhWideNode) <= 5 * 64 ? 1 : -1];
#else
static inline void prefetch_child(const Bvh *b, int32_t c)
{
    (void)b;
    (void)c;
}
#endif

static inline const float *plane(const BvhWideNode *n, int offset) { return (const float *)((const char *)n + offset); }

#if defined(BVH_SSE) && !defined(BVH_AVX)
/* Slots 4h .. 4h + 3 of slots_enter. MAXPS/MINPS return the second
 * operand when the first is NaN: the bound is kept. (Written out: the
 * loops are not unrolled at -O2.) */
static inline int slots_enter4(const BvhWideNode *n, const RayPre *p, __m128 tmax, int h, float tn[4])
{
    __m128 lo = _mm_setzero_ps(), hi = tmax;
    const int at = 16 * h;
#define SLAB(a)                                                                                                \
    lo = _mm_max_ps(_mm_mul_ps(_mm_sub_ps(_mm_load_ps(plane(n, p->near[a] + at)), p->o4[a]), p->inv4[a]), lo); \
    hi = _mm_min_ps(_mm_mul_ps(_mm_sub_ps(_mm_load_ps(plane(n, p->far[a] + at)), p->o4[a]), p->ipad4[a]), hi)
    SLAB(0);
    SLAB(1);
    SLAB(2);
#undef SLAB
    _mm_storeu_ps(tn, lo);
    return _mm_movemask_ps(_mm_cmple_ps(lo, hi));
}
#endif

/* Entry distances of a node's slots within [0, tmax] into tn; bit i of
 * the result is set when slot i is entered. The comparisons are written
 * so that a NaN distance (0 * inf: an origin on a slab plane, parallel to
 * it) leaves the running bound as it was: such a ray lies in the closed
 * slab. */
static inline int slots_enter(const BvhWideNode *n, const RayPre *p, float tmax, float tn[BVH_WIDTH])
{
#ifdef BVH_AVX
    /* as slots_enter4, eight at once */
    __m256 lo = _mm256_setzero_ps(), hi = _mm256_set1_ps(tmax);
#define SLAB(a)                                                                                                     \
    lo = _mm256_max_ps(_mm256_mul_ps(_mm256_sub_ps(_mm256_load_ps(plane(n, p->near[a])), p->o8[a]), p->inv8[a]), lo); \
    hi = _mm256_min_ps(_mm256_mul_ps(_mm256_sub_ps(_mm256_load_ps(plane(n, p->far[a])), p->o8[a]), p->ipad8[a]), hi)
    SLAB(0);
    SLAB(1);
    SLAB(2);
#undef SLAB
    _mm256_storeu_ps(tn, lo);
    return _mm256_movemask_ps(_mm256_cmp_ps(lo, hi, _CMP_LE_OQ));
#elif defined(BVH_SSE)
    const __m128 tm = _mm_set1_ps(tmax);
#if BVH_WIDTH == 8
    return slots_enter4(n, p, tm, 0, tn) | slots_enter4(n, p, tm, 1, tn + 4) << 4;
#else
    return slots_enter4(n, p, tm, 0, tn);
#endif
#else
    int mask = 0;
    for (int i = 0; i < BVH_WIDTH; i++) {
        float lo = 0.0f, hi = tmax;
        for (int a = 0; a < 3; a++) {
            float t0 = (plane(n, p->near[a])[i] - p->o[a]) * p->inv[a];
            float t1 = (plane(n, p->far[a])[i] - p->o[a]) * p->ipad[a];
            if (t0 > lo)
                lo = t0;
            if (t1 < hi)
                hi = t1;
        }
        tn[i] = lo;
        mask |= (lo <= hi) << i;
    }
    return mask;
#endif
}

/* A traversal stack entry: a node (code >= 0) or a leaf (-1 - code), and
 * the distance at which the ray enters it. Each node pushes at most
 * BVH_WIDTH entries and pops 1, and the tree is at most BVH_MAX_DEPTH deep,
 * so this many entries always suffice. */
typedef struct {
    int32_t code;
    float t;
} Entry;

#define BVH_ENTRIES ((BVH_WIDTH - 1) * BVH_MAX_DEPTH + BVH_WIDTH)

/* A leaf's lanes hit: t[i] for lane i, and so on. */
typedef struct {
    float t[BVH_LEAF_MAX], terr[BVH_LEAF_MAX], u[BVH_LEAF_MAX], v[BVH_LEAF_MAX];
} LeafHits;

/* The leaf's triangles: one eight-lane test with AVX2, two of four with
 * SSE (the second only when it has lanes), or lane by lane. */
TRI_INLINE int leaf_tris(const BvhLeaf *L, TriPre *p, const Ray *r, LeafHits *h)
{
    if (!p->ready) {
        tri_ray_init(&p->tri, r);
        p->ready = 1;
    }
#ifdef TRI4_AVX
    int hit = 0, slow = L->tris;
    if (p->tri.simd)
        hit = tri8_lanes(L->tri.v[0][0], L->tris, &p->tri, r, h->t, h->terr, h->u, h->v, &slow);
    return hit | tri_scalar_lanes(&L->tri, 0, slow, &p->tri, r, h->t, h->terr, h->u, h->v);
#else
    int hit = tri4_hit_watertight(&L->tri, 0, L->tris & 15, &p->tri, r, h->t, h->terr, h->u, h->v);
    if (L->tris >> 4)
        hit |= tri4_hit_watertight(&L->tri, 4, L->tris >> 4, &p->tri, r, h->t + 4, h->terr + 4, h->u + 4, h->v + 4)
               << 4;
    return hit;
#endif
}

/* A hit cur of primitive id becomes *best (h) when it wins (prim_hit_wins),
 * and q's tmax moves just past it (r: the ray as given). */
TRI_INLINE void keep_nearer(int id, const PrimHit *cur, const Ray *r, Ray *q, int *best, PrimHit *h)
{
    if (prim_hit_wins(cur->t, id, h->t, *best)) {
        *best = id;
        *h = *cur;
        q->tmax = prim_tmax_past(cur->t, r->tmax);
    }
}

/* keep_nearer for a triangle's hit. With prefetch, a packet's ray: the
 * renderer, which traces packets, shades the triangle hit next, and a
 * mesh's triangles are many, so its load starts as soon as it wins, while
 * the rest of the tree is searched. One ray at a time (shadow rays, the
 * benchmarks' single rays) nobody reads it: prefetch 0 (a constant). */
TRI_INLINE void keep_nearer_tri(const Bvh *b, int prefetch, int id, const PrimHit *cur, const Ray *r, Ray *q,
                                int *best, PrimHit *h)
{
    if (prefetch && prim_hit_wins(cur->t, id, h->t, *best)) /* the load first, as early as can be */
        prim_prefetch(&b->prims[id]);
    keep_nearer(id, cur, r, q, best, h);
}

/* Leaf L for closest-hit: its triangles' lanes hit, then the primitives
 * that are not triangles (most leaves have neither). A hit nearer than
 * *best's h->t, or as near with a lower index, becomes *best, and q's tmax
 * moves just past it (r: the ray as given); with prefetch, a triangle's
 * as keep_nearer_tri says. Returns the tests made. */
TRI_INLINE int leaf_closest(const Bvh *b, int prefetch, const BvhLeaf *L, TriPre *tp, const Ray *r, Ray *q, int *best,
                            PrimHit *h)
{
    LeafHits lh;
    unsigned hits = L->tris ? (unsigned)leaf_tris(L, tp, q, &lh) : 0;
    unsigned others = ((1u << L->count) - 1) & ~(unsigned)L->tris;
    for (unsigned m = hits | others; m; m &= m - 1) {
        int i = tri_low_bit(m), id = b->order[L->first + i];
        PrimHit cur;
        if (hits >> i & 1) {
            cur = (PrimHit){lh.t[i], lh.terr[i], lh.u[i], lh.v[i], 0};
            keep_nearer_tri(b, prefetch, id, &cur, r, q, best, h);
        } else if (prim_intersect(&b->prims[id], q, b->variant, &cur))
            keep_nearer(id, &cur, r, q, best, h);
    }
    return L->count;
}

#ifndef BVH_AVX
static
#endif
int CLOSEST(const Bvh *b, const Ray *r, PrimHit *h, unsigned long long *tests)
{
    if (b->nnodes == 0)
        return -1;
    RayPre p;
    ray_pre(r, &p);
    TriPre tp;
    tp.ready = 0;
    Ray q = *r; /* tmax: past the nearest hit so far, to see ties */
    float reach = q.tmax * BVH_REACH;
    int best = -1;
    unsigned long long nt = 0;
    Entry stack[BVH_ENTRIES];
    int sp = 0;
    int32_t code = 0; /* what is visited next: the nearest entered child */
    for (;;) {
        if (code >= 0) {
            /* The nearest entered child is visited next, the others wait on
             * the stack, farthest deepest; one or two entered (the common
             * cases) take no loop. */
            const BvhWideNode *n = &b->nodes[code];
            float tn[BVH_WIDTH];
            unsigned mask = (unsigned)slots_enter(n, &p, reach, tn);
            if (mask) {
                int i0 = tri_low_bit(mask);
                mask &= mask - 1;
                if (!mask) {
                    code = n->child[i0];
                    continue;
                }
                int i1 = tri_low_bit(mask);
                mask &= mask - 1;
                if (!mask) {
                    int near = tn[i1] < tn[i0] ? i1 : i0, far = near == i0 ? i1 : i0;
                    prefetch_child(b, n->child[far]);
                    stack[sp++] = (Entry){n->child[far], tn[far]};
                    code = n->child[near];
                    continue;
                }
                int32_t c[BVH_WIDTH] = {n->child[i0], n->child[i1]};
                float t[BVH_WIDTH] = {tn[i0], tn[i1]};
                int k = 2;
                for (; mask; mask &= mask - 1, k++) {
                    c[k] = n->child[tri_low_bit(mask)];
                    t[k] = tn[tri_low_bit(mask)];
                }
                for (int i = 1; i < k; i++) /* insertion sort */
                    for (int j = i; j > 0 && t[j] < t[j - 1]; j--) {
                        float tt = t[j];
                        int32_t cc = c[j];
                        t[j] = t[j - 1];
                        c[j] = c[j - 1];
                        t[j - 1] = tt;
                        c[j - 1] = cc;
                    }
                for (int i = k - 1; i > 0; i--) {
                    prefetch_child(b, c[i]);
                    stack[sp++] = (Entry){c[i], t[i]};
                }
                code = c[0];
                continue;
            }
        } else {
            nt += leaf_closest(b, 0, &b->leaves[-1 - code], &tp, r, &q, &best, h);
            reach = q.tmax * BVH_REACH;
        }
        while (sp > 0 && stack[sp - 1].t > reach) /* entered past the nearest hit */
            sp--;
        if (sp == 0)
            break;
        code = stack[--sp].code;
    }
    *tests += nt;
    return best;
}

/* 1 when ray r hits a primitive of leaf L: its triangles' lanes, then the
 * primitives that are not triangles (most leaves have none). */
TRI_INLINE int leaf_any(const Bvh *b, const BvhLeaf *L, TriPre *tp, const Ray *r)
{
    LeafHits lh;
    int hit = L->tris && leaf_tris(L, tp, r, &lh);
    unsigned others = ((1u << L->count) - 1) & ~(unsigned)L->tris;
    for (; others && !hit; others &= others - 1) {
        PrimHit cur;
        hit = prim_intersect(&b->prims[b->order[L->first + tri_low_bit(others)]], r, b->variant, &cur);
    }
    return hit;
}

#ifndef BVH_AVX
static
#endif
int OCCLUDED(const Bvh *b, const Ray *r, unsigned long long *tests)
{
    if (b->nnodes == 0)
        return 0;
    RayPre p;
    ray_pre(r, &p);
    /* The triangle test's set-up now, not at the first leaf as for closest
     * hits: nearly every shadow ray reaches a leaf (its own surface's), so
     * the set-up is never wasted and leaves the leaf's critical path.
     * Closest-hit camera rays, which often reach no leaf, lose by it
     * (docs/performance.md). */
    TriPre tp;
    tri_ray_init(&tp.tri, r);
    tp.ready = 1;
    int32_t stack[BVH_ENTRIES]; /* any hit will do: no distances, no order */
    const float reach = r->tmax * BVH_REACH;
    int sp = 0, hit = 0;
    unsigned long long nt = 0;
    stack[sp++] = 0;
    while (sp > 0 && !hit) {
        int32_t code = stack[--sp];
        if (code < 0) {
            const BvhLeaf *L = &b->leaves[-1 - code];
            nt += L->count;
            hit = leaf_any(b, L, &tp, r);
            continue;
        }
        const BvhWideNode *n = &b->nodes[code];
        float tn[BVH_WIDTH];
        int mask = slots_enter(n, &p, reach, tn);
        /* A branch per slot, not a loop over the mask's set bits nor a
         * branch-free push: the branches are predicted, so the next node's
         * address is known before the box test ends and its load can start
         * (both other forms were slower: docs/performance.md). */
        for (int i = 0; i < BVH_WIDTH; i++)
            if (mask >> i & 1)
                stack[sp++] = n->child[i];
    }
    *tests += nt;
    return hit;
}

/* ---- packets: neighbouring rays ---- */

#ifdef BVH_AVX
/* A packet's rays as intervals (Wald, Boulos and Shirley, "Ray Tracing
 * Deformable Scenes Using Dynamic Bounding Volume Hierarchies", ACM TOG
 * 2007: interval arithmetic over the packet). A slab distance
 * (plane - o) * inv rounds monotonically in o and in inv, so over origins
 * in [omin, omax] and inverse directions in [imin, imax] of one sign the
 * least is at their ends: the near distance's lower end takes the far end
 * of the origins (omax for a positive direction) and the far distance's
 * upper end the near end (omin). So the packet's entry distance is at most
 * each ray's own, its exit at least each ray's, and the packet enters every
 * box that any of its rays would (with the same padding); with one origin
 * (camera rays) both ends are it. Leaves (and, for shadow rays, every slot)
 * are then tested ray by ray with the single-ray slab test, lanes for
 * rays. */
typedef struct {
    __m256 on8[3], of8[3];     /* the origins' ends for the near and the far planes */
    __m256 o8[3];              /* lane k: ray k's origin */
    __m256 imin8[3], imax8[3]; /* the ends of the packet's inverse directions, by axis */
    __m256 inv8[3];            /* lane k: ray k's inverse direction */
    __m256 pmin8[3], pmax8[3], ipad8[3]; /* the same times BVH_SLAB_PAD, as RayPre's ipad */
    int near[3], far[3];       /* as in RayPre: all rays share each axis's sign */
} PacketPre;

/* The least and greatest lane of v, in every lane. */
static inline void lane_range(__m256 v, __m256 *lo, __m256 *hi)
{
    __m256 l = _mm256_min_ps(v, _mm256_permute2f128_ps(v, v, 1));
    __m256 h = _mm256_max_ps(v, _mm256_permute2f128_ps(v, v, 1));
    l = _mm256_min_ps(l, _mm256_permute_ps(l, 0x4e));
    h = _mm256_max_ps(h, _mm256_permute_ps(h, 0x4e));
    *lo = _mm256_min_ps(l, _mm256_permute_ps(l, 0xb1));
    *hi = _mm256_max_ps(h, _mm256_permute_ps(h, 0xb1));
}

/* 0 when the rays do not share a direction's sign on some axis, or one is
 * parallel to an axis plane or not a number, or an origin is not finite
 * (or there are none): those go one by one. -1 when every ray misses the
 * root box (b->lo, b->hi) by its own slab test, as misses_root decides for
 * one ray: the packet then misses every slot, and needs nothing more. */
static int packet_pre(const Bvh *b, const Ray *r, int n, PacketPre *p)
{
    if (n < 1)
        return 0;
    const __m256 zero = _mm256_setzero_ps(), fmax = _mm256_set1_ps(FLT_MAX), one = _mm256_set1_ps(1.0f);
    const __m256 pad = _mm256_set1_ps(BVH_SLAB_PAD), abs = _mm256_set1_ps(-0.0f);
    /* lane k: ray k (ray 0 past n) */
    int at[BVH_PACKET];
    for (int k = 0; k < BVH_PACKET; k++)
        at[k] = k < n ? k : 0;
    __m256 f[RAY_FIELDS], iv[3];
    ray_fields8(r, at, f);
    const __m256 *oa = f + RAY_O;
    /* Every division first, the checks after: the three divisions then
     * overlap instead of each waiting for the last axis's checks (the
     * compiler may not start a division before a branch). */
    for (int a = 0; a < 3; a++)
        iv[a] = _mm256_div_ps(one, f[RAY_D + a]); /* as ray_pre divides (lane by lane) */
    /* each ray's entry and exit of the root box, as packet_rays_enter's */
    __m256 tn = zero, tf = _mm256_mul_ps(f[RAY_TMAX], _mm256_set1_ps(BVH_REACH));
    int neg[3];
    for (int a = 0; a < 3; a++) {
        const __m256 inv = iv[a];
        /* every lane finite, non-zero and of ray 0's sign: a NaN would
         * slip past the min and max below */
        __m256 bad = _mm256_or_ps(_mm256_cmp_ps(_mm256_andnot_ps(abs, inv), fmax, _CMP_NLE_UQ),
                                  _mm256_cmp_ps(inv, zero, _CMP_EQ_OQ));
        bad = _mm256_or_ps(bad, _mm256_cmp_ps(_mm256_andnot_ps(abs, oa[a]), fmax, _CMP_NLE_UQ));
        neg[a] = _mm256_movemask_ps(_mm256_cmp_ps(inv, zero, _CMP_LT_OQ));
        if (_mm256_movemask_ps(bad) || (neg[a] != 0 && neg[a] != 0xff))
            return 0;
        const __m256 pn = _mm256_set1_ps(neg[a] ? b->hi[a] : b->lo[a]);
        const __m256 pf = _mm256_set1_ps(neg[a] ? b->lo[a] : b->hi[a]);
        tn = _mm256_max_ps(_mm256_mul_ps(_mm256_sub_ps(pn, oa[a]), inv), tn);
        tf = _mm256_min_ps(_mm256_mul_ps(_mm256_sub_ps(pf, oa[a]), _mm256_mul_ps(inv, pad)), tf);
    }
    if (!_mm256_movemask_ps(_mm256_cmp_ps(tn, tf, _CMP_LE_OQ)))
        return -1;
    for (int a = 0; a < 3; a++) {
        __m256 omin, omax, inv = iv[a];
        lane_range(oa[a], &omin, &omax);
        __m256 lo, hi;
        lane_range(inv, &lo, &hi);
        slab_planes(a, neg[a] != 0, &p->near[a], &p->far[a]);
        p->o8[a] = oa[a];
        p->on8[a] = neg[a] ? omin : omax;
        p->of8[a] = neg[a] ? omax : omin;
        p->imin8[a] = lo;
        p->imax8[a] = hi;
        p->inv8[a] = inv;
        p->pmin8[a] = _mm256_mul_ps(lo, pad);
        p->pmax8[a] = _mm256_mul_ps(hi, pad);
        p->ipad8[a] = _mm256_mul_ps(inv, pad);
    }
    return 1;
}

/* slots_enter for the packet: the slots some ray may enter before tmax
 * (the farthest any ray still looks), and the packet's entry distances. */
static inline unsigned packet_enter(const BvhWideNode *n, const PacketPre *p, float tmax, float tn[BVH_WIDTH])
{
    __m256 lo = _mm256_setzero_ps(), hi = _mm256_set1_ps(tmax);
    for (int a = 0; a < 3; a++) {
        __m256 pn = _mm256_sub_ps(_mm256_load_ps(plane(n, p->near[a])), p->on8[a]);
        __m256 pf = _mm256_sub_ps(_mm256_load_ps(plane(n, p->far[a])), p->of8[a]);
        __m256 t0 = _mm256_min_ps(_mm256_mul_ps(pn, p->imin8[a]), _mm256_mul_ps(pn, p->imax8[a]));
        __m256 t1 = _mm256_max_ps(_mm256_mul_ps(pf, p->pmin8[a]), _mm256_mul_ps(pf, p->pmax8[a]));
        lo = _mm256_max_ps(t0, lo);
        hi = _mm256_min_ps(t1, hi);
    }
    _mm256_storeu_ps(tn, lo);
    return (unsigned)_mm256_movemask_ps(_mm256_cmp_ps(lo, hi, _CMP_LE_OQ));
}

/* The rays (lanes) that enter slot i of n before their own tmax: each
 * lane is slots_enter's test of that slot for that ray, bit for bit. */
static inline unsigned packet_rays_enter(const BvhWideNode *n, int i, const PacketPre *p, __m256 tmax)
{
    __m256 lo = _mm256_setzero_ps(), hi = tmax;
    for (int a = 0; a < 3; a++) {
        __m256 pn = _mm256_sub_ps(_mm256_set1_ps(plane(n, p->near[a])[i]), p->o8[a]);
        __m256 pf = _mm256_sub_ps(_mm256_set1_ps(plane(n, p->far[a])[i]), p->o8[a]);
        lo = _mm256_max_ps(_mm256_mul_ps(pn, p->inv8[a]), lo);
        hi = _mm256_min_ps(_mm256_mul_ps(pf, p->ipad8[a]), hi);
    }
    return (unsigned)_mm256_movemask_ps(_mm256_cmp_ps(lo, hi, _CMP_LE_OQ));
}

/* A packet's stack entry: a node or leaf as in Entry, and for a leaf the
 * rays that enter it. */
typedef struct {
    int32_t code;
    float t;
    unsigned rays;
} PacketEntry;

/* Two rays or more enter leaf L, which holds one primitive that is not a
 * triangle: prim_intersect_rays tests them together (a sphere's four at
 * once). With triangles beside it, not when it is a PN patch, whose t
 * depends a little on the ray's tmax: the others' do not, so the nearest
 * hit does not depend on the order of the tests (prim_hit_wins). */
static inline int other_together(const Bvh *b, const BvhLeaf *L, unsigned rays)
{
    const unsigned others = ((1u << L->count) - 1) & ~(unsigned)L->tris;
    if (!(rays & (rays - 1)) || !others || (others & (others - 1)))
        return 0;
    return L->count == 1 || b->prims[b->order[L->first + tri_low_bit(others)]].kind != PRIM_PN;
}

/* leaf_closest for the rays in the mask together, at such a leaf: each
 * ray's triangles, then the other primitive for all of them; q[k], best[k],
 * h[k] and qt[k] as leaf_closest leaves them. Returns the tests. */
static unsigned long long leaf_closest_rays(const Bvh *b, const BvhLeaf *L, TriPre *tp, const Ray *r, Ray *q,
                                            unsigned rays, int *best, PrimHit *h, float *qt)
{
    const unsigned others = ((1u << L->count) - 1) & ~(unsigned)L->tris;
    for (unsigned m = L->tris ? rays : 0; m; m &= m - 1) {
        int k = tri_low_bit(m);
        LeafHits lh;
        for (unsigned t = (unsigned)leaf_tris(L, &tp[k], &q[k], &lh); t; t &= t - 1) {
            int i = tri_low_bit(t);
            PrimHit cur = {lh.t[i], lh.terr[i], lh.u[i], lh.v[i], 0};
            keep_nearer_tri(b, 1, b->order[L->first + i], &cur, &r[k], &q[k], &best[k], &h[k]);
        }
    }
    const int id = b->order[L->first + tri_low_bit(others)];
    PrimHit cur[BVH_PACKET];
    for (unsigned m = prim_intersect_rays(&b->prims[id], q, rays, b->variant, cur); m; m &= m - 1) {
        int k = tri_low_bit(m);
        keep_nearer(id, &cur[k], &r[k], &q[k], &best[k], &h[k]);
    }
    for (unsigned m = rays; m; m &= m - 1)
        qt[tri_low_bit(m)] = q[tri_low_bit(m)].tmax * BVH_REACH;
    return (unsigned long long)L->count * (unsigned long long)__builtin_popcount(rays);
}

#ifdef TRI4_AVX512
/* leaf_closest for rays k1 and k2 together, at a leaf of triangles alone,
 * both rays set up for the SIMD test and of the same axes: each ray's
 * lanes as leaf_tris finds them, then its hits in lane order, as
 * leaf_closest takes them. */
static void leaf_closest2(const Bvh *b, const BvhLeaf *L, const TriPre *tp, const Ray *r, Ray *q, int k1, int k2,
                          int *best, PrimHit *h)
{
    float t[16], terr[16], u[16], v[16];
    int slow;
    const int hit = tri16_lanes(L->tri.v[0][0], L->tris | L->tris << 8, &tp[k1].tri, &q[k1], &tp[k2].tri, &q[k2], t,
                                terr, u, v, &slow);
    const int ks[2] = {k1, k2};
    for (int j = 0; j < 2; j++) {
        const int k = ks[j], at = 8 * j;
        unsigned m = (unsigned)(hit >> at & 0xff);
        m |= (unsigned)tri_scalar_lanes(&L->tri, 0, slow >> at & 0xff, &tp[k].tri, &q[k], t + at, terr + at, u + at,
                                        v + at);
        for (; m; m &= m - 1) {
            const int i = tri_low_bit(m);
            const PrimHit cur = {t[at + i], terr[at + i], u[at + i], v[at + i], 0};
            keep_nearer_tri(b, 1, b->order[L->first + i], &cur, &r[k], &q[k], &best[k], &h[k]);
        }
    }
}

/* Rays k1 and k2 can take the triangle test together: both in SIMD lanes,
 * with the same axes. They are set up already: a leaf of triangles sets up
 * its packet's rays before any is tested (packet_tri_pre). */
static int pairable(const TriPre *tp, int k1, int k2)
{
    const PrimTriRay *a = &tp[k1].tri, *c = &tp[k2].tri;
    return a->simd && c->simd && a->kx == c->kx && a->ky == c->ky && a->kz == c->kz;
}

/* The rays of `rays` two at a time through leaf L (triangles alone) where
 * leaf_closest2 can take them; returns the rays left. Out of line: inlined,
 * it made the packet's frame larger, and every frame's shading slower, the
 * leaves of no triangles included. */
__attribute__((noinline)) static unsigned leaf_pairs(const Bvh *b, const BvhLeaf *L, const TriPre *tp, const Ray *r,
                                                     Ray *q, unsigned rays, int *best, PrimHit *h, float *qt)
{
    unsigned left = 0;
    while (rays & (rays - 1)) {
        const int k1 = tri_low_bit(rays);
        rays &= rays - 1;
        const int k2 = tri_low_bit(rays);
        rays &= rays - 1;
        if (!pairable(tp, k1, k2)) {
            left |= 1u << k1 | 1u << k2;
            continue;
        }
        leaf_closest2(b, L, tp, r, q, k1, k2, best, h);
        qt[k1] = q[k1].tmax * BVH_REACH;
        qt[k2] = q[k2].tmax * BVH_REACH;
    }
    return left | rays;
}

/* leaf_any for the rays of `rays`, two at a time where they can share the
 * sixteen lanes, at a leaf of triangles alone: the rays hit into *hit;
 * returns the rays left. */
__attribute__((noinline)) static unsigned any_pairs(const BvhLeaf *L, const TriPre *tp, const Ray *r, unsigned rays,
                                                    unsigned *hit)
{
    unsigned left = 0;
    while (rays & (rays - 1)) {
        const int k1 = tri_low_bit(rays);
        rays &= rays - 1;
        const int k2 = tri_low_bit(rays);
        rays &= rays - 1;
        if (!pairable(tp, k1, k2)) {
            left |= 1u << k1 | 1u << k2;
            continue;
        }
        float t[16], terr[16], u[16], v[16];
        int slow;
        const int got = tri16_lanes(L->tri.v[0][0], L->tris | L->tris << 8, &tp[k1].tri, &r[k1], &tp[k2].tri, &r[k2],
                                    t, terr, u, v, &slow);
        const int ks[2] = {k1, k2};
        for (int j = 0; j < 2; j++) {
            const int k = ks[j], at = 8 * j;
            if ((got >> at & 0xff) ||
                tri_scalar_lanes(&L->tri, 0, slow >> at & 0xff, &tp[k].tri, &r[k], t + at, terr + at, u + at, v + at))
                *hit |= 1u << k;
        }
    }
    return left | rays;
}
#endif

/* The packet's rays set up for the triangle test together, at the first
 * leaf of triangles one of them reaches: most of the others reach such
 * leaves too. */
static void packet_tri_pre(const Ray *r, int n, TriPre *tp)
{
    PrimTriRay *p[BVH_PACKET];
    for (int k = 0; k < BVH_PACKET; k++)
        p[k] = &tp[k].tri;
    tri_ray_init8(r, n, p);
    for (int k = 0; k < n; k++)
        tp[k].ready = 1;
}

void bvh_closest_packet_avx2(const Bvh *b, const Ray *r, int n, PrimHit *h, int *best, unsigned long long *tests)
{
    PacketPre p;
    const int pre = b->nnodes ? packet_pre(b, r, n, &p) : 0;
    if (pre <= 0) {
        for (int k = 0; k < n; k++)
            best[k] = pre ? -1 : bvh_closest_avx2(b, &r[k], &h[k], tests);
        return;
    }
    const unsigned all = (1u << n) - 1;
#ifdef TRI4_AVX512
    const int pairs = avx512_lanes_pay();
#endif
    Ray q[BVH_PACKET];
    TriPre tp[BVH_PACKET];
    float qt[BVH_PACKET]; /* lane k: ray k's q.tmax * BVH_REACH (rays past n: -1, never entering) */
    for (int k = 0; k < BVH_PACKET; k++) {
        qt[k] = -1.0f;
        tp[k].ready = 0;
    }
    float far = 0.0f; /* the largest qt */
    for (int k = 0; k < n; k++) {
        q[k] = r[k];
        qt[k] = r[k].tmax * BVH_REACH;
        far = qt[k] > far ? qt[k] : far;
        best[k] = -1;
    }
    unsigned long long nt = 0;
    PacketEntry stack[BVH_ENTRIES];
    int sp = 0;
    stack[sp++] = (PacketEntry){0, 0.0f, all};
    while (sp > 0) {
        PacketEntry e = stack[--sp];
        if (e.t > far) /* entered past every ray's nearest hit */
            continue;
        if (e.code < 0) {
            const BvhLeaf *L = &b->leaves[-1 - e.code];
            if (L->tris && !tp[0].ready)
                packet_tri_pre(r, n, tp);
            if (other_together(b, L, e.rays)) /* as leaf_closest would one by one */
                nt += leaf_closest_rays(b, L, tp, r, q, e.rays, best, h, qt);
            else {
                unsigned m = e.rays;
#ifdef TRI4_AVX512
                if (pairs && L->tris == (1u << L->count) - 1) { /* triangles alone */
                    m = leaf_pairs(b, L, tp, r, q, m, best, h, qt);
                    nt += (unsigned long long)L->count * (unsigned long long)__builtin_popcount(e.rays & ~m);
                }
#endif
                for (; m; m &= m - 1) {
                    int k = tri_low_bit(m);
                    nt += (unsigned long long)leaf_closest(b, 1, L, &tp[k], &r[k], &q[k], &best[k], &h[k]);
                    qt[k] = q[k].tmax * BVH_REACH;
                }
            }
            far = 0.0f;
            for (int k = 0; k < n; k++)
                far = qt[k] > far ? qt[k] : far;
            continue;
        }
        const BvhWideNode *nd = &b->nodes[e.code];
        float tn[BVH_WIDTH];
        unsigned mask = packet_enter(nd, &p, far, tn);
        __m256 qt8 = _mm256_loadu_ps(qt);
        for (int base = sp; mask; mask &= mask - 1) {
            int i = tri_low_bit(mask);
            unsigned rays = all;
            if (nd->child[i] < 0 && !(rays = packet_rays_enter(nd, i, &p, qt8)))
                continue;
            /* onto the stack by insertion, the nearest on top */
            int j = sp++;
            for (; j > base && stack[j - 1].t < tn[i]; j--)
                stack[j] = stack[j - 1];
            stack[j] = (PacketEntry){nd->child[i], tn[i], rays};
        }
    }
    *tests += nt;
}

/* bvh_occluded for rays r[0 .. n-1] (n <= BVH_PACKET) together, from any
 * origins (the shadow rays of neighbouring pixels): bit k of the result for
 * ray k. The packet's box test picks the slots some ray may enter, and each
 * is then visited by the rays that enter it by their own single-ray test,
 * so a ray reaches every leaf it would reach alone, tests it on its own,
 * and leaves the packet at its first hit: the same verdict. Together, the
 * shadow rays of a packet of camera rays visit far fewer nodes and leaves
 * than one by one. */
unsigned bvh_occluded_packet_avx2(const Bvh *b, const Ray *r, int n, unsigned long long *tests)
{
    PacketPre p;
    unsigned hit = 0;
    const int pre = b->nnodes ? packet_pre(b, r, n, &p) : 0;
    if (pre < 0)
        return 0;
    if (pre == 0) {
        for (int k = 0; k < n; k++)
            hit |= (unsigned)bvh_occluded_avx2(b, &r[k], tests) << k;
        return hit;
    }
    TriPre tp[BVH_PACKET];
    float qt[BVH_PACKET]; /* lane k: ray k's tmax * BVH_REACH (rays past n: -1, never entering) */
    float far = 0.0f;     /* the largest */
    for (int k = 0; k < BVH_PACKET; k++) {
        qt[k] = k < n ? r[k].tmax * BVH_REACH : -1.0f;
        far = qt[k] > far ? qt[k] : far;
        tp[k].ready = 0;
    }
    const __m256 qt8 = _mm256_loadu_ps(qt);
    const unsigned all = (1u << n) - 1;
#ifdef TRI4_AVX512
    const int pairs = avx512_lanes_pay();
#endif
    unsigned long long nt = 0;
    struct {
        int32_t code;
        unsigned rays; /* the rays that enter it */
    } stack[BVH_ENTRIES];
    int sp = 0;
    stack[sp].code = 0;
    stack[sp++].rays = all;
    while (sp > 0 && hit != all) {
        --sp;
        const int32_t code = stack[sp].code;
        const unsigned rays = stack[sp].rays & ~hit;
        if (!rays)
            continue;
        if (code < 0) {
            const BvhLeaf *L = &b->leaves[-1 - code];
            if (L->tris && !tp[0].ready)
                packet_tri_pre(r, n, tp);
            if (L->count == 1 && !L->tris && (rays & (rays - 1))) { /* as leaf_any would one by one */
                PrimHit cur[BVH_PACKET];
                nt += (unsigned long long)__builtin_popcount(rays);
                hit |= prim_intersect_rays(&b->prims[b->order[L->first]], r, rays, b->variant, cur);
                continue;
            }
            unsigned m = rays;
#ifdef TRI4_AVX512
            if (pairs && L->tris == (1u << L->count) - 1) { /* triangles alone */
                m = any_pairs(L, tp, r, m, &hit);
                nt += (unsigned long long)L->count * (unsigned long long)__builtin_popcount(rays & ~m);
            }
#endif
            for (; m; m &= m - 1) {
                int k = tri_low_bit(m);
                nt += L->count;
                hit |= (unsigned)leaf_any(b, L, &tp[k], &r[k]) << k;
            }
            continue;
        }
        const BvhWideNode *nd = &b->nodes[code];
        float tn[BVH_WIDTH];
        for (unsigned mask = packet_enter(nd, &p, far, tn); mask; mask &= mask - 1) {
            int i = tri_low_bit(mask);
            unsigned in = rays & packet_rays_enter(nd, i, &p, qt8);
            if (!in)
                continue;
            stack[sp].code = nd->child[i];
            stack[sp++].rays = in;
        }
    }
    *tests += nt;
    return hit;
}
#endif

#ifdef BVH_DISPATCH
/* The AVX2 object (bvh_traverse.c again, with -mavx2 -mbmi) when the
 * processor runs it. Every AVX2 processor made has BMI1 too (TZCNT and
 * BLSR for the masks), but it is checked all the same. */
static inline int has_avx2(void) { return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("bmi"); }
#endif

#ifndef BVH_AVX
/* 1 when the ray certainly misses the root box (b->lo, b->hi) by
 * slots_enter's own test. Every slot of the root node lies inside that box,
 * and each slab distance rounds monotonically in its plane, so such a ray
 * misses every slot, and the traversal and its set-up are saved: about
 * half the rays of a camera framing a mesh miss its box.
 * A ray from inside the box (shadow and secondary rays) is not tested. */
static inline int misses_root(const Bvh *b, const Ray *r)
{
    float inv[4];
#ifdef BVH_SSE
    /* lane 3 (d.x of the ray, the 0 of the box) is never looked at */
    const __m128 o = _mm_loadu_ps(&r->o.x), lo = _mm_loadu_ps(b->lo), hi = _mm_loadu_ps(b->hi);
    if ((_mm_movemask_ps(_mm_and_ps(_mm_cmple_ps(lo, o), _mm_cmple_ps(o, hi))) & 7) == 7)
        return 0;
    inverse_dir(r, inv);
    const __m128 iv = _mm_loadu_ps(inv), neg = _mm_cmplt_ps(iv, _mm_setzero_ps()); /* as slab_planes */
    const __m128 pn = _mm_or_ps(_mm_and_ps(neg, hi), _mm_andnot_ps(neg, lo));
    const __m128 pf = _mm_or_ps(_mm_and_ps(neg, lo), _mm_andnot_ps(neg, hi));
    const __m128 t0 = _mm_mul_ps(_mm_sub_ps(pn, o), iv);
    const __m128 t1 = _mm_mul_ps(_mm_sub_ps(pf, o), _mm_mul_ps(iv, _mm_set1_ps(BVH_SLAB_PAD)));
    /* lanes 0 to 2 in slots_enter's order, each as the first operand: a
     * NaN leaves the bound as it was */
    __m128 tn = _mm_max_ss(t0, _mm_setzero_ps()), tf = _mm_min_ss(t1, _mm_set_ss(r->tmax * BVH_REACH));
    tn = _mm_max_ss(_mm_shuffle_ps(t0, t0, 1), tn);
    tf = _mm_min_ss(_mm_shuffle_ps(t1, t1, 1), tf);
    tn = _mm_max_ss(_mm_shuffle_ps(t0, t0, 2), tn);
    tf = _mm_min_ss(_mm_shuffle_ps(t1, t1, 2), tf);
    return !(_mm_movemask_ps(_mm_cmple_ss(tn, tf)) & 1);
#else
    const float o[3] = {r->o.x, r->o.y, r->o.z};
    if (o[0] >= b->lo[0] && o[0] <= b->hi[0] && o[1] >= b->lo[1] && o[1] <= b->hi[1] && o[2] >= b->lo[2] &&
        o[2] <= b->hi[2])
        return 0;
    inverse_dir(r, inv);
    float tn = 0.0f, tf = r->tmax * BVH_REACH;
    for (int a = 0; a < 3; a++) {
        int neg = inv[a] < 0.0f;
        float t0 = ((neg ? b->hi[a] : b->lo[a]) - o[a]) * inv[a];
        float t1 = ((neg ? b->lo[a] : b->hi[a]) - o[a]) * (inv[a] * BVH_SLAB_PAD);
        if (t0 > tn)
            tn = t0;
        if (t1 < tf)
            tf = t1;
    }
    return !(tn <= tf);
#endif
}

int bvh_closest(const Bvh *b, const Ray *r, PrimHit *h, unsigned long long *tests)
{
    if (b->nnodes == 0 || misses_root(b, r))
        return -1;
#ifdef BVH_DISPATCH
    return has_avx2() ? bvh_closest_avx2(b, r, h, tests) : closest_base(b, r, h, tests);
#else
    return closest_one(b, r, h, tests);
#endif
}

int bvh_occluded(const Bvh *b, const Ray *r, unsigned long long *tests)
{
    if (b->nnodes == 0 || misses_root(b, r))
        return 0;
#ifdef BVH_DISPATCH
    return has_avx2() ? bvh_occluded_avx2(b, r, tests) : occluded_base(b, r, tests);
#else
    return occluded_one(b, r, tests);
#endif
}

int bvh_closest_except(const Bvh *b, const Ray *r, int (*skip)(void *ctx, int i), void *ctx, PrimHit *h,
                       unsigned long long *tests)
{
    if (b->nnodes == 0 || misses_root(b, r))
        return -1;
    RayPre p;
    ray_pre(r, &p);
    Ray q = *r; /* tmax: past the nearest hit so far, as CLOSEST's */
    int best = -1;
    int32_t stack[BVH_ENTRIES]; /* every entered child, in no order: few rays come here */
    int sp = 0;
    stack[sp++] = 0;
    while (sp > 0) {
        const int32_t code = stack[--sp];
        if (code < 0) {
            const BvhLeaf *L = &b->leaves[-1 - code];
            for (int k = 0; k < L->count; k++) {
                const int id = b->order[L->first + k];
                PrimHit cur;
                if (skip(ctx, id))
                    continue;
                *tests += 1;
                if (prim_intersect(&b->prims[id], &q, b->variant, &cur))
                    keep_nearer(id, &cur, r, &q, &best, h);
            }
            continue;
        }
        float tn[BVH_WIDTH];
        const int mask = slots_enter(&b->nodes[code], &p, q.tmax * BVH_REACH, tn);
        for (int i = 0; i < BVH_WIDTH; i++)
            if (mask >> i & 1)
                stack[sp++] = b->nodes[code].child[i];
    }
    return best;
}

/* Packets of at most BVH_PACKET with AVX2; else ray by ray. */
void bvh_closest_packet(const Bvh *b, const Ray *r, int n, PrimHit *h, int *best, unsigned long long *tests)
{
#ifdef BVH_DISPATCH
    if (has_avx2()) {
        for (int k = 0; k < n; k += BVH_PACKET)
            bvh_closest_packet_avx2(b, r + k, n - k < BVH_PACKET ? n - k : BVH_PACKET, h + k, best + k, tests);
        return;
    }
#endif
    for (int k = 0; k < n; k++)
        best[k] = bvh_closest(b, &r[k], &h[k], tests);
}

unsigned bvh_occluded_packet(const Bvh *b, const Ray *r, int n, unsigned long long *tests)
{
    unsigned hit = 0;
#ifdef BVH_DISPATCH
    if (has_avx2()) {
        for (int k = 0; k < n; k += BVH_PACKET)
            hit |= bvh_occluded_packet_avx2(b, r + k, n - k < BVH_PACKET ? n - k : BVH_PACKET, tests) << k;
        return hit;
    }
#endif
    for (int k = 0; k < n; k++)
        hit |= (unsigned)bvh_occluded(b, &r[k], tests) << k;
    return hit;
}
#endif
