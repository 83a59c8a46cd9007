/*
 * bvh.c - binned-SAH bounding volume hierarchy (see bvh.h for the layout).
 *
 * Build: Wald, "On fast Construction of SAH-based Bounding Volume
 * Hierarchies", IEEE RT 2007. Each node's primitives are sorted into
 * BVH_BINS bins by centroid along each axis, and the best of the bin
 * boundaries by the surface area heuristic becomes the split.
 *
 * The binary tree is then collapsed into BVH_WIDTH-wide nodes and leaves of
 * up to BVH_LEAF_MAX primitives (bvh.h), by the collapse of least SAH cost
 * (Ylitie, Karras and Laine, HPG 2017; plan_collapse), and dropped.
 *
 * Traversal is in bvh_traverse.c.
 */
#include "lancer/bvh.h"

#include <float.h>
#if defined(__SSE2__) && !defined(LANCER_NO_SIMD)
#define BVH_SSE 1
#include <emmintrin.h>
#endif
#include <pthread.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "lancer/pntri.h"
#include "lancer/thread.h"
#include "bigmem.h"
#include "dvec.h"

/* 8 bins: Wald reports SAH quality within a few percent of a full sweep
 * from 8-32 bins, and more bins cost build time without saving node visits
 * (docs/performance.md). */
#define BVH_BINS 8
/* Leaves of up to BVH_LEAF_MAX = 8 primitives, the lanes of one AVX2
 * triangle test. The SAH counts primitives in blocks of 8, as Embree counts
 * them in blocks of its leaf test's width: testing 8 costs what testing 1
 * does. So a node of at most 8 triangles is always a leaf (splitting it would add a
 * box test and save no triangle test), and a larger one is always split,
 * where sum(area(child) * blocks(child)) is least; the traversal and
 * intersection costs of the SAH then drop out. (Leaves of 8 also make rays
 * visit fewer nodes than leaves of 4: docs/performance.md.) */
#define BVH_BLOCKS(n) (((n) + BVH_LEAF_MAX - 1) / BVH_LEAF_MAX)
/* A primitive that the leaf does not test in lanes (a sphere, a box, a PN
 * patch: anything but a triangle) costs a test of its own, as much as a
 * block or more; so it counts as a block, and a leaf holds at most one,
 * where the node's box test culls the others (a ref's lo[3] is 1 for
 * such a primitive, else 0). The cost of a bin count (split()): its
 * primitives n in the low 32 bits, the costly c among them in the high. */
#define BVH_TESTS(nc) (BVH_BLOCKS((int)((nc) & 0xffffffffu) - (int)((nc) >> 32)) + (int)((nc) >> 32))
/* A ref's lo[3] for a PN patch: costly, and kept beside its triangles (parts()). */
#define BVH_PN 2.0f
/* Below this many primitives a subtree is built on the calling thread:
 * starting a thread costs more than it saves. */
#define BVH_PARALLEL_MIN 4096
/* Past this depth, nodes are halved by index instead of split by the SAH,
 * so no input can make the tree deeper than BVH_SAH_DEPTH + 32 (2^32 >
 * any primitive count) = BVH_MAX_DEPTH. */
#define BVH_SAH_DEPTH (BVH_MAX_DEPTH - 32)

/* bvh.h's pads, P = 1 + p u and R = 1 + r u with u = 2^-24, checked by the
 * compiler. The slab pad needs P (1 - u)^4 >= (1 + u)^3; the left side is
 * at least 1 + (p - 4) u - 4 p u^2 and the right at most 1 + 3u + 4u^2, so
 * p >= 8 is enough while (4p + 4) u < 1. The reach needs R (1 - u) >=
 * (1 + 2^-18)(1 + u)^3, with 2^-18 = 64u: the left side is 1 + (r - 1) u -
 * r u^2 and the right at most 1 + 67u + 197u^2, so r >= 69 is enough while
 * (r + 197) u < 1. */
typedef char bvh_slab_pad_suffices[BVH_SLAB_PAD_U >= 8 && BVH_SLAB_PAD_U < 1024 ? 1 : -1];
typedef char bvh_reach_suffices[BVH_REACH_U >= 69 && BVH_REACH_U < 1024 ? 1 : -1];

/* A primitive's bounds, as four lanes (the fourth is 0); the builder
 * works on lo + hi, twice the centroid, which bins the same. */
typedef struct {
    float lo[4], hi[4];
} Ref;

/* The binary tree of the build: a leaf has count > 0 and holds
 * refs[first .. first + count - 1]; an inner node has count 0 and children
 * first and first + 1. */
typedef struct {
    float lo[3], hi[3];
    uint32_t first;
    uint32_t count;
} BvhNode;

typedef struct {
    Ref *refs;
    int *ids; /* ids[i]: the caller's index of refs[i] */
    BvhNode *nodes;
    int nnodes, cap;
    int costly; /* 1 when some ref costs a test of its own (BVH_TESTS) */
} Builder;

/* Four-lane min, max, add, sub and mul for the build: SSE, or a loop.
 * MIN and MAX return b when a lane of a is NaN, as MINPS and MAXPS do,
 * so both paths bin alike. */
#ifdef BVH_SSE
typedef __m128 V4;
static inline V4 v4_load(const float *p) { return _mm_load_ps(p); }
static inline void v4_store(float *p, V4 a) { _mm_store_ps(p, a); }
static inline V4 v4_set(float x) { return _mm_set1_ps(x); }
static inline V4 v4_min(V4 a, V4 b) { return _mm_min_ps(a, b); }
static inline V4 v4_max(V4 a, V4 b) { return _mm_max_ps(a, b); }
static inline V4 v4_add(V4 a, V4 b) { return _mm_add_ps(a, b); }
static inline V4 v4_sub(V4 a, V4 b) { return _mm_sub_ps(a, b); }
static inline V4 v4_mul(V4 a, V4 b) { return _mm_mul_ps(a, b); }
#else
typedef struct {
    float v[4];
} V4;
static inline V4 v4_load(const float *p)
{
    V4 r;
    memcpy(r.v, p, sizeof r.v);
    return r;
}
static inline void v4_store(float *p, V4 a) { memcpy(p, a.v, sizeof a.v); }
static inline V4 v4_set(float x) { return (V4){{x, x, x, x}}; }
#define V4_OP(name, expr)                        \
    static inline V4 name(V4 a, V4 b)            \
    {                                            \
        V4 r;                                    \
        for (int i = 0; i < 4; i++) {            \
            float x = a.v[i], y = b.v[i];        \
            r.v[i] = expr;                       \
        }                                        \
        return r;                                \
    }
V4_OP(v4_min, x < y ? x : y)
V4_OP(v4_max, x > y ? x : y)
V4_OP(v4_add, x + y)
V4_OP(v4_sub, x - y)
V4_OP(v4_mul, x * y)
#undef V4_OP
#endif

/* ---- bounds ---- */

static float down(double x)
{
    float f = (float)x;
    return (double)f > x ? nextafterf(f, -INFINITY) : f;
}

static float up(double x)
{
    float f = (float)x;
    return (double)f < x ? nextafterf(f, INFINITY) : f;
}

static float min3(const float v[3])
{
    float m = v[1] < v[0] ? v[1] : v[0];
    return v[2] < m ? v[2] : m;
}

static float max3(const float v[3])
{
    float m = v[1] > v[0] ? v[1] : v[0];
    return v[2] > m ? v[2] : m;
}

int bvh_prim_bounds(const Prim *p, float lo[3], float hi[3])
{
    double l[3], h[3];
    switch (p->kind) {
    case PRIM_PLANE:
        return 0;
    case PRIM_SPHERE: {
        const Sphere *s = &p->g.sphere;
        const float c[3] = {s->c.x, s->c.y, s->c.z};
        for (int i = 0; i < 3; i++) {
            l[i] = (double)c[i] - s->r; /* exact in double, rounded outwards below */
            h[i] = (double)c[i] + s->r;
        }
        break;
    }
    case PRIM_TRIANGLE:
    case PRIM_SMOOTH_TRIANGLE: { /* the vertices' own floats: nothing to round */
        const Triangle *t = &p->g.tri;
        const float x[3] = {t->a.x, t->b.x, t->c.x}, y[3] = {t->a.y, t->b.y, t->c.y}, z[3] = {t->a.z, t->b.z, t->c.z};
        lo[0] = min3(x);
        lo[1] = min3(y);
        lo[2] = min3(z);
        hi[0] = max3(x);
        hi[1] = max3(y);
        hi[2] = max3(z);
        return 1;
    }
    case PRIM_PN: { /* the box of its control net, the net's own floats */
        if (p->g.pn.piece) { /* a piece's box, in double, rounded outwards below */
            memcpy(l, p->g.pn.piece->lo, sizeof l);
            memcpy(h, p->g.pn.piece->hi, sizeof h);
            break;
        }
        Vec3 l3, h3;
        pn_bounds(p->g.pn.patch, &l3, &h3);
        lo[0] = l3.x, lo[1] = l3.y, lo[2] = l3.z;
        hi[0] = h3.x, hi[1] = h3.y, hi[2] = h3.z;
        return 1;
    }
    case PRIM_ELLIPSOID: {
        /* x = M y + t for |y| = 1 spans t_i +- |row i of M|. M is A^-1 to
         * within a relative cond(A) * few double ulps (A, as stored, is the
         * primitive), covered by the pad. */
        const Ellipsoid *e = p->g.ell.e;
        double na = 0.0, nm = 0.0;
        for (int k = 0; k < 9; k++) {
            na += fabs(e->a[k]);
            nm += fabs(e->m[k]);
        }
        double pad = 1.0 + 1e-13 * na * nm;
        for (int i = 0; i < 3; i++) {
            const double *row = e->m + 3 * i;
            double ext = sqrt(d3_dot(row, row)) * pad;
            l[i] = e->m[9 + i] - ext - 1e-15 * fabs(e->m[9 + i]);
            h[i] = e->m[9 + i] + ext + 1e-15 * fabs(e->m[9 + i]);
        }
        break;
    }
    case PRIM_BOX: {
        const Box *b = &p->g.box;
        l[0] = b->lo.x, l[1] = b->lo.y, l[2] = b->lo.z;
        h[0] = b->hi.x, h[1] = b->hi.y, h[2] = b->hi.z;
        break;
    }
    case PRIM_OBOX: {
        const OBox *b = &p->g.obox;
        const float c[3] = {b->c.x, b->c.y, b->c.z};
        const Vec3 ax[3] = {b->u, b->v, b->w};
        for (int i = 0; i < 3; i++) {
            double e = 0.0; /* |u_i| + |v_i| + |w_i|: a few roundings, covered by 1e-15 */
            for (int k = 0; k < 3; k++)
                e += fabs((double)(i == 0 ? ax[k].x : i == 1 ? ax[k].y : ax[k].z));
            e *= 1.0 + 1e-15;
            l[i] = c[i] - e;
            h[i] = c[i] + e;
        }
        break;
    }
    }
    for (int i = 0; i < 3; i++) {
        lo[i] = down(l[i]);
        hi[i] = up(h[i]);
    }
    return 1;
}

static float area(const float lo[3], const float hi[3])
{
    float dx = hi[0] - lo[0], dy = hi[1] - lo[1], dz = hi[2] - lo[2];
    if (!(dx >= 0.0f))
        return 0.0f; /* an empty box */
    return dx * dy + dy * dz + dz * dx;
}

/* ---- build ---- */

/* Two new nodes side by side: a node's children are first and first + 1. */
static int new_pair(Builder *B)
{
    if (B->nnodes + 2 > B->cap) {
        int cap = B->cap ? B->cap * 2 : 64;
        BvhNode *n = big_realloc(B->nodes, sizeof(BvhNode) * (size_t)B->nnodes, sizeof(BvhNode) * (size_t)cap);
        if (!n)
            return -1;
        B->nodes = n;
        B->cap = cap;
    }
    B->nnodes += 2;
    return B->nnodes - 2;
}

static void make_leaf(BvhNode *n, int begin, int end)
{
    n->first = (uint32_t)begin;
    n->count = (uint32_t)(end - begin);
}

/* The box of refs[begin, end) into node, and the box of their lo + hi. */
static void bounds(const Builder *B, BvhNode *node, int begin, int end, V4 *clo, V4 *chi)
{
    V4 lo = v4_set(INFINITY), hi = v4_set(-INFINITY), cl = lo, ch = hi;
    for (int i = begin; i < end; i++) {
        V4 l = v4_load(B->refs[i].lo), h = v4_load(B->refs[i].hi), c = v4_add(l, h);
        lo = v4_min(l, lo);
        hi = v4_max(h, hi);
        cl = v4_min(c, cl);
        ch = v4_max(c, ch);
    }
    float l4[4], h4[4];
    v4_store(l4, lo);
    v4_store(h4, hi);
    memcpy(node->lo, l4, sizeof node->lo);
    memcpy(node->hi, h4, sizeof node->hi);
    *clo = cl;
    *chi = ch;
}

/* The bins of a ref along each axis: (lo + hi - clo) * scale, clamped to
 * [0, BVH_BINS - 1] and truncated. */
static inline V4 bin_of(const Ref *r, V4 clo, V4 scale)
{
    V4 c = v4_add(v4_load(r->lo), v4_load(r->hi));
    return v4_max(v4_min(v4_mul(v4_sub(c, clo), scale), v4_set((float)(BVH_BINS - 1))), v4_set(0.0f));
}

/* The primitives among refs[begin, end) that cost a test of their own. */
static int costly(const Ref *refs, int begin, int end)
{
    int c = 0;
    for (int i = begin; i < end; i++)
        c += refs[i].lo[3] != 0.0f;
    return c;
}

/* refs[begin, end), at most a leaf's worth, hold one primitive with a test
 * of its own among triangles, and it may leave them: it is not a PN patch
 * (BVH_PN), whose t depends a little on the ray's tmax, so that a patch
 * tested in another order than beside its triangles could give other bits
 * (bvh_traverse.c, other_together). Such a leaf is parted where the SAH
 * finds it cheaper: a sphere beside a distant triangle then no longer
 * makes the rays that reach the one test the other. */
static int parts(const Ref *refs, int begin, int end)
{
    int c = 0, pn = 0;
    for (int i = begin; i < end; i++) {
        c += refs[i].lo[3] != 0.0f;
        pn |= refs[i].lo[3] == BVH_PN;
    }
    return end - begin > 1 && c == 1 && !pn;
}

/* Chooses a split of refs[begin, end) (box node, centroid box clo, chi,
 * doubled) and partitions them; returns the index where the right half starts, or -1
 * to make a leaf. All three axes are binned in one pass. */
static int split(Builder *B, const BvhNode *node, int begin, int end, int depth, V4 clo, V4 chi)
{
    Ref *refs = B->refs;
    int count = end - begin;
    const int part = B->costly && count <= BVH_LEAF_MAX && parts(refs, begin, end);
    if (!part && count <= BVH_LEAF_MAX && (!B->costly || costly(refs, begin, end) <= 1))
        return -1;
    if (depth >= BVH_SAH_DEPTH)
        return begin + count / 2;
    float ext[4], sc[4];
    v4_store(ext, v4_sub(chi, clo));
    for (int a = 0; a < 4; a++)
        sc[a] = a < 3 && ext[a] > 0.0f ? (float)BVH_BINS / ext[a] : 0.0f;
    V4 scale = v4_load(sc);
    /* Two sets of bins, for even and odd refs, merged after: consecutive
     * refs often fall in the same bin, and one set would make each update
     * wait for the previous one to be stored. */
    V4 blo[2][3][BVH_BINS], bhi[2][3][BVH_BINS];
    /* a bin's refs in the low 32 bits, the costly among them in the high:
     * one addition counts both */
    uint64_t bcount[2][3][BVH_BINS] = {{{0}}};
    for (int s = 0; s < 2; s++)
        for (int a = 0; a < 3; a++)
            for (int k = 0; k < BVH_BINS; k++) {
                blo[s][a][k] = v4_set(INFINITY);
                bhi[s][a][k] = v4_set(-INFINITY);
            }
    for (int i = begin; i < end; i++) {
        float kf[4];
        int s = i & 1;
        v4_store(kf, bin_of(&refs[i], clo, scale));
        V4 l = v4_load(refs[i].lo), h = v4_load(refs[i].hi);
        uint64_t one = 1 + ((uint64_t)(B->costly && refs[i].lo[3] != 0.0f) << 32);
        for (int a = 0; a < 3; a++) {
            int k = (int)kf[a];
            bcount[s][a][k] += one;
            blo[s][a][k] = v4_min(l, blo[s][a][k]);
            bhi[s][a][k] = v4_max(h, bhi[s][a][k]);
        }
    }
    for (int a = 0; a < 3; a++)
        for (int k = 0; k < BVH_BINS; k++) {
            bcount[0][a][k] += bcount[1][a][k];
            blo[0][a][k] = v4_min(blo[1][a][k], blo[0][a][k]);
            bhi[0][a][k] = v4_max(bhi[1][a][k], bhi[0][a][k]);
        }
    float best_cost = INFINITY;
    int best_axis = -1, best_bin = 0;
    for (int axis = 0; axis < 3; axis++) {
        if (!(ext[axis] > 0.0f))
            continue;
        /* sweep: areas and counts to the right of each boundary */
        float rarea[BVH_BINS], b4[2][4];
        uint64_t rcount[BVH_BINS], n = 0;
        V4 lo = v4_set(INFINITY), hi = v4_set(-INFINITY);
        for (int k = BVH_BINS - 1; k > 0; k--) {
            lo = v4_min(blo[0][axis][k], lo);
            hi = v4_max(bhi[0][axis][k], hi);
            v4_store(b4[0], lo);
            v4_store(b4[1], hi);
            n += bcount[0][axis][k];
            rarea[k] = area(b4[0], b4[1]);
            rcount[k] = n;
        }
        lo = v4_set(INFINITY);
        hi = v4_set(-INFINITY);
        n = 0;
        for (int k = 0; k < BVH_BINS - 1; k++) {
            lo = v4_min(blo[0][axis][k], lo);
            hi = v4_max(bhi[0][axis][k], hi);
            n += bcount[0][axis][k];
            if (n == 0 || rcount[k + 1] == 0)
                continue;
            v4_store(b4[0], lo);
            v4_store(b4[1], hi);
            float cost = area(b4[0], b4[1]) * (float)BVH_TESTS(n) + rarea[k + 1] * (float)BVH_TESTS(rcount[k + 1]);
            if (cost < best_cost) {
                best_cost = cost;
                best_axis = axis;
                best_bin = k;
            }
        }
    }
    /* parted only when that costs less than the leaf's two tests */
    if (part && !(best_cost < area(node->lo, node->hi) * (float)BVH_TESTS(count + (1ull << 32))))
        return -1;
    if (best_axis >= 0) {
        /* bin_of on one axis, operation for operation; then Lomuto's
         * partition with a swap whatever the side, which costs less than
         * the branch it replaces (half of them would be mispredicted) */
        float c0[4];
        v4_store(c0, clo);
        const float lo = c0[best_axis], k = sc[best_axis], top = (float)(BVH_BINS - 1);
        int *ids = B->ids, i = begin;
        for (int j = begin; j < end; j++) {
            float f = (refs[j].lo[best_axis] + refs[j].hi[best_axis] - lo) * k;
            f = f < top ? f : top;
            f = f > 0.0f ? f : 0.0f;
            Ref t = refs[j];
            refs[j] = refs[i];
            refs[i] = t;
            int id = ids[j];
            ids[j] = ids[i];
            ids[i] = id;
            i += (int)f <= best_bin;
        }
        if (i > begin && i < end)
            return i;
    }
    /* All centroids coincide (or binning failed): halve by index, which
     * keeps the depth logarithmic whatever the input. */
    return part ? -1 : begin + count / 2;
}

static int build_node(Builder *B, int ni, int begin, int end, int depth)
{
    V4 clo, chi;
    bounds(B, &B->nodes[ni], begin, end, &clo, &chi);
    int mid = split(B, &B->nodes[ni], begin, end, depth, clo, chi);
    if (mid < 0) {
        make_leaf(&B->nodes[ni], begin, end);
        return 0;
    }
    int c = new_pair(B);
    if (c < 0)
        return -1;
    B->nodes[ni].first = (uint32_t)c; /* (new_pair may have moved the array) */
    B->nodes[ni].count = 0;
    if (build_node(B, c, begin, mid, depth + 1) != 0)
        return -1;
    return build_node(B, c + 1, mid, end, depth + 1);
}

typedef struct {
    Builder b;
    int begin, end, rc;
} Task;

static void *build_task(void *arg)
{
    Task *t = arg;
    t->b.nnodes = 1;
    t->rc = build_node(&t->b, 0, t->begin, t->end, 1);
    return NULL;
}

/* Builds the root on this thread and, for large inputs, its right subtree
 * on a second thread; the subtree's nodes are then appended, renumbered. */
static int build_tree(Builder *B, int n, int threads)
{
    B->cap = 64;
    B->nodes = malloc(sizeof(BvhNode) * (size_t)B->cap);
    if (!B->nodes)
        return -1;
    B->nnodes = 1;
    if (threads <= 1 || n < BVH_PARALLEL_MIN)
        return build_node(B, 0, 0, n, 0);
    V4 clo, chi;
    bounds(B, &B->nodes[0], 0, n, &clo, &chi);
    int mid = split(B, &B->nodes[0], 0, n, 0, clo, chi); /* n > BVH_LEAF_MAX: always a split */
    int c = new_pair(B);
    if (c < 0)
        return -1;
    B->nodes[0].first = (uint32_t)c;
    B->nodes[0].count = 0;
    Task right;
    memset(&right, 0, sizeof right);
    right.b.refs = B->refs;
    right.b.ids = B->ids;
    right.b.costly = B->costly;
    right.b.cap = 64;
    right.b.nodes = malloc(sizeof(BvhNode) * 64);
    right.begin = mid;
    right.end = n;
    pthread_t tid;
    const int alloc_ok = right.b.nodes != NULL; /* (read before the thread may grow them) */
    int threaded = alloc_ok && thread_start(&tid, build_task, &right) == 0;
    if (alloc_ok && !threaded)
        build_task(&right);
    int rc = build_node(B, c, 0, mid, 1);
    if (threaded)
        pthread_join(tid, NULL);
    if (!right.b.nodes || right.rc != 0 || rc != 0) {
        free(right.b.nodes);
        return -1;
    }
    /* Append the right subtree: its local node j >= 1 goes to base + j,
     * and its local root to node c + 1. */
    int base = B->nnodes - 1, extra = right.b.nnodes - 1;
    if (B->nnodes + extra > B->cap) {
        BvhNode *nn =
            big_realloc(B->nodes, sizeof(BvhNode) * (size_t)B->nnodes, sizeof(BvhNode) * (size_t)(B->nnodes + extra));
        if (!nn) {
            free(right.b.nodes);
            return -1;
        }
        B->nodes = nn;
        B->cap = B->nnodes + extra;
    }
    for (int j = 0; j < right.b.nnodes; j++) {
        BvhNode nd = right.b.nodes[j];
        if (nd.count == 0)
            nd.first = (uint32_t)(base + (int)nd.first);
        B->nodes[j == 0 ? c + 1 : base + j] = nd;
    }
    B->nnodes += extra;
    free(right.b.nodes);
    return 0;
}

/* ---- the wide tree ---- */

/* How binary node n's subtree is best laid out in i slots of a wide node
 * (at most i of its nodes side by side), for i = 1 .. BVH_WIDTH. The
 * costs that decide it are kept apart (Cost): they are done with before
 * the tree is written, and can lie where it goes. */
typedef struct {
    uint8_t left[BVH_WIDTH]; /* left[i - 1]: 0 for n itself in one slot, else the slots of
                              * its left child (the right child takes the other i - left) */
    uint8_t wide_left; /* n as a wide node: the slots of its left child among its own */
} Plan;

/* cost[i - 1]: the least sum of the areas of the wide nodes made of n's
 * subtree in i slots. */
typedef struct {
    double cost[BVH_WIDTH];
} Cost;

typedef struct {
    Bvh *b;
    const BvhNode *bin; /* the binary tree */
    const Plan *plan;
} Collapse;

static void slot_box(BvhWideNode *n, int i, const BvhNode *src)
{
    for (int a = 0; a < 3; a++) {
        n->lo[a][i] = src ? src->lo[a] : INFINITY; /* an empty box: never entered */
        n->hi[a][i] = src ? src->hi[a] : -INFINITY;
    }
}

/* A leaf from binary leaf c: its primitives (fill_leaves copies the
 * triangles). */
static int32_t add_leaf(Bvh *b, const BvhNode *c)
{
    BvhLeaf *L = &b->leaves[b->nleaves];
    memset(L, 0, sizeof *L);
    L->first = (int32_t)c->first;
    L->count = (uint8_t)c->count;
    return -1 - b->nleaves++;
}

/* Copies each leaf's triangles side by side. In a pass of its own, whose
 * reads of the caller's primitives (in no useful order) can overlap. */
static void fill_leaves(Bvh *b)
{
    if (b->variant != PRIM_ROBUST)
        return;
    for (int l = 0; l < b->nleaves; l++) {
        BvhLeaf *L = &b->leaves[l];
        for (int i = 0; i < L->count; i++) {
            const Prim *p = &b->prims[b->order[L->first + i]];
            if (p->kind != PRIM_TRIANGLE && p->kind != PRIM_SMOOTH_TRIANGLE)
                continue;
            L->tris |= (uint8_t)(1 << i);
            const Vec3 v[3] = {p->g.tri.a, p->g.tri.b, p->g.tri.c};
            for (int k = 0; k < 3; k++) {
                L->tri.v[k][0][i] = v[k].x;
                L->tri.v[k][1][i] = v[k].y;
                L->tri.v[k][2][i] = v[k].z;
            }
        }
    }
}

/* The least cost of a and b in `slots` slots together, and the slots a
 * takes then (ties: the fewest). Seeded with the first split, so that the
 * answer is a valid split even when every cost is infinite or not a number
 * (a box too large for its area in float): the plan must place every
 * node whatever the costs. */
static double share(const Cost *a, const Cost *b, int slots, uint8_t *left)
{
    double best = a->cost[0] + b->cost[slots - 2];
    *left = 1;
    for (int k = 2; k < slots; k++) {
        double c = a->cost[k - 1] + b->cost[slots - k - 1];
        if (c < best) {
            best = c;
            *left = (uint8_t)k;
        }
    }
    return best;
}

/* The collapse into wide nodes that is optimal under the SAH (Ylitie,
 * Karras and Laine, "Efficient Incoherent Ray Traversal on GPUs Through
 * Compressed Wide BVHs", HPG 2017), by dynamic programming from the
 * leaves up. Every binary leaf stays a leaf whatever the collapse, and a
 * wide node costs one box test of all its slots, however many are used;
 * so the cost is the sum of the wide nodes' areas (the chance that a ray
 * enters each). Greedily opening the largest child left many nodes with two
 * children of eight. Children follow their parents in
 * bin[], so one backward pass sees children first. */
static void plan_collapse(const BvhNode *bin, int nbin, Cost *cost, Plan *plan)
{
    for (int n = nbin - 1; n >= 0; n--) {
        Plan *p = &plan[n];
        double *pc = cost[n].cost;
        memset(p->left, 0, sizeof p->left);
        p->wide_left = 0;
        if (bin[n].count > 0) { /* a leaf: one slot, no wide node */
            for (int i = 0; i < BVH_WIDTH; i++)
                pc[i] = 0.0;
            continue;
        }
        const Cost *l = &cost[bin[n].first], *r = &cost[bin[n].first + 1];
        const float *lo = bin[n].lo, *hi = bin[n].hi; /* the area in double: no overflow */
        double dx = (double)hi[0] - lo[0], dy = (double)hi[1] - lo[1], dz = (double)hi[2] - lo[2];
        pc[0] = dx * dy + dy * dz + dz * dx + share(l, r, BVH_WIDTH, &p->wide_left);
        for (int i = 2; i <= BVH_WIDTH; i++) {
            uint8_t k = 1;
            double c = share(l, r, i, &k);
            pc[i - 1] = pc[i - 2];
            p->left[i - 1] = p->left[i - 2];
            if (c < pc[i - 1]) {
                pc[i - 1] = c;
                p->left[i - 1] = k;
            }
        }
    }
}

/* The binary nodes that fill `slots` slots for node n, by its plan. */
static void gather(const Collapse *C, int n, int slots, int *kids, int *nk)
{
    int k = C->plan[n].left[slots - 1];
    if (k == 0) {
        kids[(*nk)++] = n;
        return;
    }
    gather(C, (int)C->bin[n].first, k, kids, nk);
    gather(C, (int)C->bin[n].first + 1, slots - k, kids, nk);
}

static void collapse(Collapse *C, int ni, int at);

/* Fills nodes[at] with binary nodes kids[0 .. nk-1], one a slot: a leaf
 * becomes a leaf, an inner node a wide node in turn. */
static void fill_node(Collapse *C, const int *kids, int nk, int at)
{
    Bvh *b = C->b;
    memset(&b->nodes[at], 0, sizeof(BvhWideNode));
    for (int i = 0; i < BVH_WIDTH; i++) {
        const BvhNode *c = i < nk ? &C->bin[kids[i]] : NULL;
        slot_box(&b->nodes[at], i, c);
        /* An unused slot's box is never entered, but a ray of NaNs enters
         * every box: its child is leaf 0, which is harmless to test, and
         * not node 0, whose revisits would grow the traversal's stack
         * without end. Every other child lies below its parent. */
        b->nodes[at].child[i] = -1;
        if (c && c->count > 0) {
            b->nodes[at].child[i] = add_leaf(b, c);
        } else if (c) {
            int sub = b->nnodes++;
            b->nodes[at].child[i] = sub;
            collapse(C, kids[i], sub);
        }
    }
}

/* The binary nodes in the slots of inner node ni's wide node, by the
 * plan, into kids; returns how many. */
static int wide_kids(const Collapse *C, int ni, int *kids)
{
    int nk = 0, k = C->plan[ni].wide_left;
    gather(C, (int)C->bin[ni].first, k, kids, &nk);
    gather(C, (int)C->bin[ni].first + 1, BVH_WIDTH - k, kids, &nk);
    return nk;
}

/* Fills nodes[at] from binary node ni, an inner node, by the plan. */
static void collapse(Collapse *C, int ni, int at)
{
    int kids[BVH_WIDTH], nk = wide_kids(C, ni, kids);
    fill_node(C, kids, nk, at);
}

/* The wide nodes the plan makes of inner node ni's subtree: ni's own and
 * those of the inner nodes in its slots, as collapse() will make them. */
static int count_wide(const Collapse *C, int ni)
{
    int kids[BVH_WIDTH], nk = wide_kids(C, ni, kids), n = 1;
    for (int i = 0; i < nk; i++)
        if (C->bin[kids[i]].count == 0)
            n += count_wide(C, kids[i]);
    return n;
}

/* Grows block *m of *size bytes to `need` when it is smaller, its last
 * `tail` bytes moved to the new end. */
static int grow(char **m, size_t *size, size_t need, size_t tail)
{
    if (need <= *size)
        return 0;
    char *g = big_realloc(*m, *size, need);
    if (!g)
        return -1;
    memmove(g + need - tail, g + *size - tail, tail);
    *m = g;
    *size = need;
    return 0;
}

/* Builds b->nodes and b->leaves from the binary tree of nbin nodes, in
 * *block (size bytes), the build's references, done with by now: the tree
 * goes into pages the build has faulted in already (docs/performance.md).
 * The collapse's plan lies at the block's end, and its costs, done with
 * before the tree is written, at its start; the block grows when they or
 * the tree do not fit. The pages past the tree, the plan's among them, are
 * then given back (big_release), but the block keeps its size: the next
 * build's block then fits where this one was. On success b->mem owns the
 * block and *block is NULL; on failure *block is the caller's to free. */
static int build_wide(Bvh *b, const BvhNode *bin, int nbin, void **block, size_t size)
{
    char *m = *block;
    const size_t plan_bytes = sizeof(Plan) * (size_t)nbin;
    if (grow(&m, &size, sizeof(Cost) * (size_t)nbin + plan_bytes, 0) != 0)
        return -1;
    *block = m;
    plan_collapse(bin, nbin, (Cost *)m, (Plan *)(m + size - plan_bytes));
    Collapse C = {b, bin, (Plan *)(m + size - plan_bytes)};
    /* Every binary leaf is a leaf; the wide nodes are counted first, so
     * that the tree is written once, in its place: a copy would fault its
     * pages twice. The first 64 bytes align it to cache lines. */
    const int root = 0, nwide = bin[0].count > 0 ? 1 : count_wide(&C, 0);
    const size_t leaf_bytes = sizeof(BvhLeaf) * (size_t)((nbin + 1) / 2);
    const size_t tree_bytes = leaf_bytes + sizeof(BvhWideNode) * (size_t)nwide;
    if (grow(&m, &size, 64 + tree_bytes + plan_bytes, plan_bytes) != 0)
        return -1;
    *block = NULL;
    b->mem = m;
    C.plan = (Plan *)(m + size - plan_bytes);
    size_t skew = (64 - (uintptr_t)m % 64) % 64;
    b->leaves = (BvhLeaf *)(m + skew);
    b->nodes = (BvhWideNode *)(m + skew + leaf_bytes);
    b->nnodes = 1;
    if (bin[0].count > 0)
        fill_node(&C, &root, 1, 0); /* a leaf root stays alone in slot 0 */
    else
        collapse(&C, 0, 0);
    for (int a = 0; a < 3; a++) {
        b->lo[a] = bin[0].lo[a];
        b->hi[a] = bin[0].hi[a];
    }
    b->lo[3] = b->hi[3] = 0.0f;
    fill_leaves(b);
    /* what the build touched past the tree, huge pages held whole */
    big_release(m, skew + tree_bytes, size);
    return 0;
}

void bvh_free(Bvh *b)
{
    free(b->mem);
    free(b->order);
    memset(b, 0, sizeof *b);
}

size_t bvh_bytes(const Bvh *b)
{
    /* the block up to the tree's end (the nodes follow the leaves), which
     * build_wide keeps */
    const size_t kept = b->mem ? (size_t)((const char *)(b->nodes + b->nnodes) - (const char *)b->mem) : 0;
    return kept + sizeof(int) * (size_t)b->nprims;
}

int bvh_build(Bvh *b, const Prim *prims, int n, PrimVariant v, int threads)
{
    memset(b, 0, sizeof *b);
    b->variant = v;
    b->prims = prims;
    Builder B;
    memset(&B, 0, sizeof B);
    /* The refs' block becomes the tree's (build_wide), with room for the
     * tree of a mesh (about 56 bytes a triangle); in huge pages when it is
     * large (bigmem.h), so that filling it faults once every 2 MiB. */
    size_t size = 16 + 2 * sizeof(Ref) * (size_t)(n > 0 ? n : 1);
    void *block = big_realloc(NULL, 0, size);
    if (!block)
        return -1;
    B.refs = (Ref *)((char *)block + (16 - (uintptr_t)block % 16) % 16);
    B.ids = malloc(sizeof(int) * (size_t)(n > 0 ? n : 1));
    if (!B.ids) {
        free(block);
        return -1;
    }
    int m = 0;
    for (int i = 0; i < n; i++) {
        Ref *r = &B.refs[m];
        if (!bvh_prim_bounds(&prims[i], r->lo, r->hi))
            continue;
        r->lo[3] = prims[i].kind == PRIM_TRIANGLE || prims[i].kind == PRIM_SMOOTH_TRIANGLE ? 0.0f
                   : prims[i].kind == PRIM_PN                                             ? BVH_PN
                                                                                         : 1.0f;
        r->hi[3] = 0.0f;
        B.ids[m++] = i;
        B.costly |= r->lo[3] != 0.0f;
    }
    int rc = 0;
    if (m > 0) {
        rc = build_tree(&B, m, threads);
        if (rc == 0) { /* the ids, in leaf order now, are the order */
            int *order = realloc(B.ids, sizeof(int) * (size_t)m);
            b->order = order ? order : B.ids;
            B.ids = NULL;
            b->nprims = m;
            rc = build_wide(b, B.nodes, B.nnodes, &block, size);
        }
    }
    free(block);
    free(B.ids);
    free(B.nodes);
    if (rc != 0) {
        bvh_free(b);
        return -1;
    }
    return 0;
}

/* ---- validation ---- */

static int inside(const float lo[3], const float hi[3], const float l[3], const float h[3])
{
    for (int i = 0; i < 3; i++)
        if (!(l[i] >= lo[i] && h[i] <= hi[i]))
            return 0;
    return 1;
}

/* Checks leaf li, in a slot of box lo, hi; seen[] counts references. */
static int validate_leaf(const Bvh *b, int li, const float lo[3], const float hi[3], int *seen, char *err,
                         size_t errlen)
{
    if (li < 0 || li >= b->nleaves)
        return snprintf(err, errlen, "leaf %d does not exist", li), -1;
    const BvhLeaf *L = &b->leaves[li];
    if (L->count < 1 || L->count > BVH_LEAF_MAX || L->first < 0 || L->first + L->count > b->nprims)
        return snprintf(err, errlen, "leaf %d refers past the primitives", li), -1;
    for (int i = 0; i < L->count; i++) {
        int k = L->first + i, idx = b->order[k];
        float l[3], h[3];
        if (seen[k]++)
            return snprintf(err, errlen, "primitive %d is referenced twice", k), -1;
        const Prim *p = &b->prims[idx];
        if (!bvh_prim_bounds(p, l, h) || !inside(lo, hi, l, h))
            return snprintf(err, errlen, "primitive %d lies outside leaf %d", idx, li), -1;
        int tri = b->variant == PRIM_ROBUST && (p->kind == PRIM_TRIANGLE || p->kind == PRIM_SMOOTH_TRIANGLE);
        if (tri != (L->tris >> i & 1))
            return snprintf(err, errlen, "leaf %d marks primitive %d wrongly as triangle or not", li, idx), -1;
        const Vec3 v[3] = {p->g.tri.a, p->g.tri.b, p->g.tri.c};
        const PrimTri8 *t = &L->tri;
        for (int c = 0; tri && c < 3; c++)
            if (t->v[c][0][i] != v[c].x || t->v[c][1][i] != v[c].y || t->v[c][2][i] != v[c].z)
                return snprintf(err, errlen, "leaf %d holds other vertices than primitive %d", li, idx), -1;
    }
    return 0;
}

int bvh_validate(const Bvh *b, char *err, size_t errlen)
{
    if (b->nprims == 0)
        return b->nnodes == 0 ? 0 : (snprintf(err, errlen, "nodes without primitives"), -1);
    if ((uintptr_t)b->nodes % 64 != 0 || (uintptr_t)b->leaves % 64 != 0)
        return snprintf(err, errlen, "nodes or leaves not on cache lines (the traversal's aligned loads)"), -1;
    int *seen = calloc((size_t)b->nprims, sizeof(int));
    int *stack = malloc(sizeof(int) * (size_t)(BVH_WIDTH * b->nnodes + 1));
    float(*box)[2][3] = malloc(sizeof *box * (size_t)(BVH_WIDTH * b->nnodes + 1)); /* each entry's parent slot box */
    int rc = 0, sp = 0, visited = 0;
    if (!seen || !stack || !box) {
        snprintf(err, errlen, "out of memory");
        rc = -1;
        goto done;
    }
    stack[sp] = 0;
    memcpy(box[sp][0], b->lo, sizeof box[sp][0]);
    memcpy(box[sp++][1], b->hi, sizeof box[sp][1]);
    while (sp > 0 && rc == 0) {
        int ni = stack[--sp];
        if (ni >= b->nnodes || ++visited > b->nnodes) {
            snprintf(err, errlen, "node %d does not exist or is reached twice", ni);
            rc = -1;
            break;
        }
        const BvhWideNode *n = &b->nodes[ni];
        float plo[3], phi[3], slo[BVH_WIDTH][3], shi[BVH_WIDTH][3]; /* (box[sp] is overwritten below) */
        memcpy(plo, box[sp][0], sizeof plo);
        memcpy(phi, box[sp][1], sizeof phi);
        for (int k = 0; k < BVH_WIDTH; k++)
            for (int a = 0; a < 3; a++) {
                slo[k][a] = n->lo[a][k];
                shi[k][a] = n->hi[a][k];
            }
        for (int k = 0; k < BVH_WIDTH && rc == 0; k++) {
            int empty = 1;
            for (int a = 0; a < 3; a++)
                empty &= slo[k][a] == INFINITY && shi[k][a] == -INFINITY;
            if (empty && n->child[k] != -1) {
                snprintf(err, errlen, "unused slot %d of node %d leads to %d, not to leaf 0", k, ni, n->child[k]);
                rc = -1;
            }
            if (empty)
                continue;
            if (!inside(plo, phi, slo[k], shi[k])) {
                snprintf(err, errlen, "slot %d of node %d lies outside its parent", k, ni);
                rc = -1;
            } else if (n->child[k] < 0) {
                rc = validate_leaf(b, -1 - n->child[k], slo[k], shi[k], seen, err, errlen);
            } else if (n->child[k] <= ni) {
                snprintf(err, errlen, "node %d has child %d out of order", ni, n->child[k]);
                rc = -1;
            } else {
                stack[sp] = n->child[k];
                memcpy(box[sp][0], slo[k], sizeof slo[k]);
                memcpy(box[sp++][1], shi[k], sizeof shi[k]);
            }
        }
    }
    for (int k = 0; rc == 0 && k < b->nprims; k++)
        if (!seen[k]) {
            snprintf(err, errlen, "primitive %d is in no leaf", b->order[k]);
            rc = -1;
        }
done:
    free(seen);
    free(stack);
    free(box);
    return rc;
}
