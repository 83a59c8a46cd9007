/*
 * bvh.c - binned-SAH bounding volume hierarchy (see bvh.h for the layout).
 *
 * Build: Wald, "On fast Construction of SAH-based Bounding Volume
 * Hierarchies", IEEE RT 2007. Each node's primitives are sorted into
 * BVH_BINS bins by centroid along each axis, and the best of the bin
 * boundaries by the surface area heuristic becomes the split.
 *
 * Traversal: on a 4-wide copy of the tree (Bvh4Node), a stack, nearer
 * children first by entry distance, four boxes tested at once with the slab
 * test made conservative after Ize 2013 (see bvh.h); SSE where available,
 * else a scalar loop (build with -DLANCER_NO_SIMD to force it).
 */
#include "lancer/bvh.h"

#include <float.h>
#if defined(__SSE2__) && !defined(LANCER_NO_SIMD)
#define BVH_SSE 1
#include <emmintrin.h>
#endif
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* 16 bins: Wald reports SAH quality within a few percent of a full sweep
 * from 8-32 bins; 16 keeps the binning pass cheap. */
#define BVH_BINS 16
/* Leaves of at most 4 primitives: more makes leaves slow to test, fewer
 * makes the tree deep; the SAH may stop earlier. */
#define BVH_MAX_LEAF 4
/* SAH costs: one box test against one primitive test. Watertight triangle
 * and box tests cost about the same as a slab test pair. */
#define BVH_TRAVERSAL_COST 1.0f
#define BVH_INTERSECT_COST 1.0f
/* Below this many primitives a subtree is built on the calling thread:
 * starting a thread costs more than it saves. */
#define BVH_PARALLEL_MIN 4096
/* Past this depth, nodes are halved by index instead of split by the SAH,
 * so no input can make the tree deeper than BVH_SAH_DEPTH + 32 (2^32 >
 * any primitive count), which bounds the traversal stack. */
#define BVH_SAH_DEPTH 64

typedef struct {
    float lo[3], hi[3];
    float c[3]; /* centroid */
    int idx;    /* the caller's index */
} Ref;

typedef struct {
    Ref *refs;
    BvhNode *nodes;
    int nnodes, cap;
} Builder;

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
    case PRIM_SMOOTH_TRIANGLE: {
        const Vec3 v[3] = {p->g.tri.a, p->g.tri.b, p->g.tri.c};
        for (int i = 0; i < 3; i++) {
            float a = i == 0 ? v[0].x : i == 1 ? v[0].y : v[0].z;
            l[i] = h[i] = a;
            for (int k = 1; k < 3; k++) {
                float b = i == 0 ? v[k].x : i == 1 ? v[k].y : v[k].z;
                l[i] = b < l[i] ? b : l[i];
                h[i] = b > h[i] ? b : h[i];
            }
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

static void box_empty(float lo[3], float hi[3])
{
    for (int i = 0; i < 3; i++) {
        lo[i] = INFINITY;
        hi[i] = -INFINITY;
    }
}

static void box_grow(float lo[3], float hi[3], const float l[3], const float h[3])
{
    for (int i = 0; i < 3; i++) {
        lo[i] = l[i] < lo[i] ? l[i] : lo[i];
        hi[i] = h[i] > hi[i] ? h[i] : hi[i];
    }
}

/* ---- build ---- */

/* Children come in pairs at even indices, so that with the array aligned
 * to 64 bytes a pair of 32-byte nodes shares one cache line: traversal
 * reads both children at once. */
static int new_pair(Builder *B)
{
    if (B->nnodes + 3 > B->cap) {
        int cap = B->cap ? B->cap * 2 : 64;
        BvhNode *n = realloc(B->nodes, sizeof(BvhNode) * (size_t)cap);
        if (!n)
            return -1;
        B->nodes = n;
        B->cap = cap;
    }
    if (B->nnodes & 1) /* skip a slot, zeroed so that it reads as nothing */
        memset(&B->nodes[B->nnodes++], 0, sizeof(BvhNode));
    B->nnodes += 2;
    return B->nnodes - 2;
}

static void make_leaf(BvhNode *n, int begin, int end)
{
    n->first = (uint32_t)begin;
    n->count = (uint16_t)(end - begin);
    n->axis = 0;
}

/* Chooses a split of refs[begin, end) and partitions them; returns the
 * index where the right half starts, or -1 to make a leaf. */
static int split(Builder *B, BvhNode *node, int begin, int end, int depth)
{
    Ref *refs = B->refs;
    int count = end - begin;
    if (depth >= BVH_SAH_DEPTH) {
        node->axis = 0;
        return count <= BVH_MAX_LEAF ? -1 : begin + count / 2;
    }
    float clo[3], chi[3];
    box_empty(clo, chi);
    for (int i = begin; i < end; i++)
        box_grow(clo, chi, refs[i].c, refs[i].c);
    float best_cost = INFINITY;
    int best_axis = -1, best_bin = 0;
    float parent = area(node->lo, node->hi);
    for (int axis = 0; axis < 3; axis++) {
        float extent = chi[axis] - clo[axis];
        if (!(extent > 0.0f))
            continue;
        float blo[BVH_BINS][3], bhi[BVH_BINS][3];
        int bcount[BVH_BINS] = {0};
        for (int k = 0; k < BVH_BINS; k++)
            box_empty(blo[k], bhi[k]);
        float scale = (float)BVH_BINS / extent;
        for (int i = begin; i < end; i++) {
            int k = (int)((refs[i].c[axis] - clo[axis]) * scale);
            k = k < 0 ? 0 : k >= BVH_BINS ? BVH_BINS - 1 : k;
            bcount[k]++;
            box_grow(blo[k], bhi[k], refs[i].lo, refs[i].hi);
        }
        /* sweep: areas and counts to the right of each boundary */
        float rarea[BVH_BINS], llo[3], lhi[3], rlo[3], rhi[3];
        int rcount[BVH_BINS], n = 0;
        box_empty(rlo, rhi);
        for (int k = BVH_BINS - 1; k > 0; k--) {
            box_grow(rlo, rhi, blo[k], bhi[k]);
            n += bcount[k];
            rarea[k] = area(rlo, rhi);
            rcount[k] = n;
        }
        box_empty(llo, lhi);
        n = 0;
        for (int k = 0; k < BVH_BINS - 1; k++) {
            box_grow(llo, lhi, blo[k], bhi[k]);
            n += bcount[k];
            if (n == 0 || rcount[k + 1] == 0)
                continue;
            float cost = area(llo, lhi) * (float)n + rarea[k + 1] * (float)rcount[k + 1];
            if (cost < best_cost) {
                best_cost = cost;
                best_axis = axis;
                best_bin = k;
            }
        }
    }
    float leaf_cost = BVH_INTERSECT_COST * (float)count;
    if (best_axis >= 0) {
        float cost = BVH_TRAVERSAL_COST + BVH_INTERSECT_COST * best_cost / (parent > 0.0f ? parent : 1.0f);
        if (cost >= leaf_cost && count <= BVH_MAX_LEAF)
            return -1;
        float scale = (float)BVH_BINS / (chi[best_axis] - clo[best_axis]);
        int i = begin, j = end - 1;
        while (i <= j) {
            int k = (int)((refs[i].c[best_axis] - clo[best_axis]) * scale);
            k = k < 0 ? 0 : k >= BVH_BINS ? BVH_BINS - 1 : k;
            if (k <= best_bin) {
                i++;
            } else {
                Ref t = refs[i];
                refs[i] = refs[j];
                refs[j--] = t;
            }
        }
        node->axis = (uint16_t)best_axis;
        if (i > begin && i < end)
            return i;
    }
    if (count <= BVH_MAX_LEAF)
        return -1;
    /* All centroids coincide (or binning failed): halve by index, which
     * keeps the depth logarithmic whatever the input. */
    node->axis = 0;
    return begin + count / 2;
}

static int build_node(Builder *B, int ni, int begin, int end, int depth)
{
    BvhNode *node = &B->nodes[ni];
    box_empty(node->lo, node->hi);
    for (int i = begin; i < end; i++)
        box_grow(node->lo, node->hi, B->refs[i].lo, B->refs[i].hi);
    int mid = split(B, node, begin, end, depth);
    if (mid < 0) {
        make_leaf(node, begin, end);
        return 0;
    }
    int c = new_pair(B);
    if (c < 0)
        return -1;
    node = &B->nodes[ni]; /* new_pair may have moved the array */
    node->first = (uint32_t)c;
    node->count = 0;
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
    BvhNode *root = &B->nodes[0];
    box_empty(root->lo, root->hi);
    for (int i = 0; i < n; i++)
        box_grow(root->lo, root->hi, B->refs[i].lo, B->refs[i].hi);
    int mid = threads > 1 && n >= BVH_PARALLEL_MIN ? split(B, root, 0, n, 0) : -1;
    if (mid < 0) {
        B->nnodes = 1;
        return build_node(B, 0, 0, n, 0);
    }
    int c = new_pair(B);
    if (c < 0)
        return -1;
    B->nodes[0].first = (uint32_t)c;
    B->nodes[0].count = 0;
    Task right;
    memset(&right, 0, sizeof right);
    right.b.refs = B->refs;
    right.b.cap = 64;
    right.b.nodes = malloc(sizeof(BvhNode) * 64);
    right.begin = mid;
    right.end = n;
    pthread_t tid;
    int threaded = right.b.nodes && pthread_create(&tid, NULL, build_task, &right) == 0;
    if (right.b.nodes && !threaded)
        build_task(&right);
    int rc = build_node(B, c, 0, mid, 1);
    if (threaded)
        pthread_join(tid, NULL);
    if (!right.b.nodes || right.rc != 0 || rc != 0) {
        free(right.b.nodes);
        return -1;
    }
    /* Append the right subtree: its local node j >= 1 goes to base + j
     * (base even, so its pairs stay on even indices), and its local root
     * to node c + 1. */
    int base = B->nnodes + (B->nnodes & 1), extra = right.b.nnodes + base - B->nnodes;
    if (B->nnodes + extra > B->cap) {
        BvhNode *nn = realloc(B->nodes, sizeof(BvhNode) * (size_t)(B->nnodes + extra));
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
    /* the slots left unused (padding, and base + 0) read as nothing */
    memset(&B->nodes[B->nnodes], 0, sizeof(BvhNode) * (size_t)(base + 1 - B->nnodes));
    B->nnodes += extra;
    free(right.b.nodes);
    return 0;
}

/* ---- the 4-wide copy ---- */

static void slot_box(Bvh4Node *n, int i, const BvhNode *src)
{
    for (int a = 0; a < 3; a++) {
        n->lo[a][i] = src ? src->lo[a] : INFINITY; /* an empty box: never hit */
        n->hi[a][i] = src ? src->hi[a] : -INFINITY;
    }
}

/* Fills nodes4[at] from binary node ni (an inner node): its children are
 * opened, largest surface area first, until four slots are taken, and every
 * inner one among them becomes a 4-wide node in turn. */
static void collapse(Bvh *b, int ni, int at)
{
    int kids[4] = {(int)b->nodes[ni].first, (int)b->nodes[ni].first + 1, -1, -1}, nk = 2;
    while (nk < 4) {
        int best = -1;
        float area_best = -1.0f;
        for (int k = 0; k < nk; k++) {
            const BvhNode *c = &b->nodes[kids[k]];
            float a = area(c->lo, c->hi);
            if (c->count == 0 && a > area_best) {
                area_best = a;
                best = k;
            }
        }
        if (best < 0)
            break; /* only leaves left */
        int c = kids[best];
        kids[best] = (int)b->nodes[c].first;
        kids[nk++] = (int)b->nodes[c].first + 1;
    }
    Bvh4Node *n = &b->nodes4[at];
    memset(n, 0, sizeof *n);
    for (int k = 0; k < 4; k++) {
        const BvhNode *c = k < nk ? &b->nodes[kids[k]] : NULL;
        slot_box(n, k, c);
        n->child[k] = -1;
        if (c && c->count > 0) {
            n->child[k] = -1 - (int32_t)c->first;
            n->count[k] = (uint8_t)c->count;
        } else if (c) {
            int sub = b->nnodes4++;
            n->child[k] = sub;
            collapse(b, kids[k], sub);
            n = &b->nodes4[at]; /* (the array does not move: sized up front) */
        }
    }
}

static int build4(Bvh *b)
{
    /* never more 4-wide nodes than binary inner nodes, plus the root */
    void *mem = NULL;
    if (posix_memalign(&mem, 64, sizeof(Bvh4Node) * (size_t)(b->nnodes + 1)) != 0)
        return -1;
    b->nodes4 = mem;
    b->nnodes4 = 1;
    const BvhNode *root = &b->nodes[0];
    if (root->count > 0) { /* a single leaf */
        Bvh4Node *n = &b->nodes4[0];
        memset(n, 0, sizeof *n);
        for (int k = 0; k < 4; k++) {
            slot_box(n, k, k == 0 ? root : NULL);
            n->child[k] = -1;
        }
        n->child[0] = -1 - (int32_t)root->first;
        n->count[0] = (uint8_t)root->count;
        return 0;
    }
    collapse(b, 0, 0);
    return 0;
}

/* Triangles in leaves: their 36 bytes of vertices, side by side in leaf
 * order, are all a leaf test reads, where a Prim would take 92 bytes, most
 * of a second cache line; a byte per primitive says which are triangles. */
static int compact_triangles(Bvh *b)
{
    if (b->variant != PRIM_ROBUST)
        return 0;
    b->tri = malloc(sizeof *b->tri * (size_t)b->nprims);
    b->is_tri = malloc((size_t)b->nprims);
    if (!b->tri || !b->is_tri)
        return -1;
    for (int i = 0; i < b->nprims; i++) {
        const Prim *p = &b->prims[i];
        b->is_tri[i] = p->kind == PRIM_TRIANGLE || p->kind == PRIM_SMOOTH_TRIANGLE;
        Vec3 zero = vec3(0, 0, 0);
        b->tri[i][0] = b->is_tri[i] ? p->g.tri.a : zero;
        b->tri[i][1] = b->is_tri[i] ? p->g.tri.b : zero;
        b->tri[i][2] = b->is_tri[i] ? p->g.tri.c : zero;
    }
    return 0;
}

void bvh_free(Bvh *b)
{
    free(b->tri);
    free(b->is_tri);
    free(b->nodes4);
    free(b->nodes);
    free(b->prims);
    free(b->order);
    memset(b, 0, sizeof *b);
}

int bvh_build(Bvh *b, const Prim *prims, int n, PrimVariant v, int threads)
{
    memset(b, 0, sizeof *b);
    b->variant = v;
    Builder B;
    memset(&B, 0, sizeof B);
    B.refs = malloc(sizeof(Ref) * (size_t)(n > 0 ? n : 1));
    if (!B.refs)
        return -1;
    int m = 0;
    for (int i = 0; i < n; i++) {
        Ref *r = &B.refs[m];
        if (!bvh_prim_bounds(&prims[i], r->lo, r->hi))
            continue;
        for (int k = 0; k < 3; k++)
            r->c[k] = 0.5f * r->lo[k] + 0.5f * r->hi[k];
        r->idx = i;
        m++;
    }
    int rc = 0;
    if (m > 0) {
        rc = build_tree(&B, m, threads);
        b->prims = malloc(sizeof(Prim) * (size_t)m);
        b->order = malloc(sizeof(int) * (size_t)m);
        if (rc != 0 || !b->prims || !b->order) {
            free(B.refs);
            free(B.nodes);
            bvh_free(b);
            return -1;
        }
        for (int i = 0; i < m; i++) {
            b->prims[i] = prims[B.refs[i].idx];
            b->order[i] = B.refs[i].idx;
        }
        /* the final array, aligned to a cache line (see new_pair) */
        void *aligned = NULL;
        if (posix_memalign(&aligned, 64, sizeof(BvhNode) * (size_t)B.nnodes) != 0) {
            free(B.refs);
            free(B.nodes);
            bvh_free(b);
            return -1;
        }
        memcpy(aligned, B.nodes, sizeof(BvhNode) * (size_t)B.nnodes);
        free(B.nodes);
        b->nodes = aligned;
        b->nnodes = B.nnodes;
        b->nprims = m;
        if (build4(b) != 0 || compact_triangles(b) != 0) {
            free(B.refs);
            bvh_free(b);
            return -1;
        }
    }
    free(B.refs);
    b->variant = v;
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

int bvh_validate(const Bvh *b, char *err, size_t errlen)
{
    if (b->nprims == 0)
        return b->nnodes == 0 ? 0 : (snprintf(err, errlen, "nodes without primitives"), -1);
    int *seen = calloc((size_t)b->nprims, sizeof(int));
    int *stack = malloc(sizeof(int) * (size_t)b->nnodes);
    int rc = 0, sp = 0, visited = 0;
    if (!seen || !stack) {
        snprintf(err, errlen, "out of memory");
        rc = -1;
        goto done;
    }
    stack[sp++] = 0;
    while (sp > 0 && rc == 0) {
        int ni = stack[--sp];
        const BvhNode *n = &b->nodes[ni];
        if (++visited > b->nnodes) {
            snprintf(err, errlen, "node %d reached twice: the tree has a cycle", ni);
            rc = -1;
            break;
        }
        if (n->count > 0) {
            if ((int)n->first + n->count > b->nprims) {
                snprintf(err, errlen, "leaf %d refers past the primitives", ni);
                rc = -1;
                break;
            }
            for (int k = (int)n->first; k < (int)n->first + n->count; k++) {
                float lo[3], hi[3];
                if (seen[k]++) {
                    snprintf(err, errlen, "primitive %d is referenced twice", k);
                    rc = -1;
                } else if (!bvh_prim_bounds(&b->prims[k], lo, hi) || !inside(n->lo, n->hi, lo, hi)) {
                    snprintf(err, errlen, "primitive %d lies outside leaf %d", k, ni);
                    rc = -1;
                }
            }
            continue;
        }
        int c = (int)n->first;
        if (c <= ni || c + 1 >= b->nnodes) {
            snprintf(err, errlen, "inner node %d has children %d, %d out of order or range", ni, c, c + 1);
            rc = -1;
            break;
        }
        for (int k = 0; k < 2; k++) {
            if (!inside(n->lo, n->hi, b->nodes[c + k].lo, b->nodes[c + k].hi)) {
                snprintf(err, errlen, "node %d lies outside its parent %d", c + k, ni);
                rc = -1;
            }
            stack[sp++] = c + k;
        }
    }
    for (int k = 0; rc == 0 && k < b->nprims; k++)
        if (!seen[k]) {
            snprintf(err, errlen, "primitive %d is in no leaf", k);
            rc = -1;
        }
done:
    free(seen);
    free(stack);
    return rc;
}

/* ---- traversal ---- */

typedef struct {
    float o[3], inv[3];
    int neg[3];
} RayPre;

static void ray_pre(const Ray *r, RayPre *p)
{
    const float o[3] = {r->o.x, r->o.y, r->o.z}, d[3] = {r->d.x, r->d.y, r->d.z};
    for (int i = 0; i < 3; i++) {
        p->o[i] = o[i];
        p->inv[i] = 1.0f / d[i];
        p->neg[i] = p->inv[i] < 0.0f;
    }
}

/* Ize 2013: each slab distance is within gamma(3) of exact. */
#define BVH_PAD (1.0f + 2.0f * (float)(3.0 * 0.5 * FLT_EPSILON / (1.0 - 3.0 * 0.5 * FLT_EPSILON)))

/* Entry distances of a 4-wide node's four slots within [0, tmax] into tn;
 * bit i of the result is set when slot i is entered. The comparisons are
 * written so that a NaN distance (0 * inf: an origin on a slab plane,
 * parallel to it) leaves the running bound as it was: such a ray lies in
 * the closed slab. */
static inline int slots_enter(const Bvh4Node *n, const RayPre *p, float tmax, float tn[4])
{
#ifdef BVH_SSE
    const __m128 pad = _mm_set1_ps(BVH_PAD);
    __m128 lo = _mm_setzero_ps(), hi = _mm_set1_ps(tmax);
    for (int a = 0; a < 3; a++) {
        __m128 o = _mm_set1_ps(p->o[a]), inv = _mm_set1_ps(p->inv[a]);
        __m128 t0 = _mm_mul_ps(_mm_sub_ps(_mm_load_ps(p->neg[a] ? n->hi[a] : n->lo[a]), o), inv);
        __m128 t1 = _mm_mul_ps(_mm_mul_ps(_mm_sub_ps(_mm_load_ps(p->neg[a] ? n->lo[a] : n->hi[a]), o), inv), pad);
        lo = _mm_max_ps(t0, lo); /* MAXPS/MINPS return the second operand when */
        hi = _mm_min_ps(t1, hi); /* the first is NaN: the bound is kept */
    }
    _mm_storeu_ps(tn, lo);
    return _mm_movemask_ps(_mm_cmple_ps(lo, hi));
#else
    int mask = 0;
    for (int i = 0; i < 4; i++) {
        float lo = 0.0f, hi = tmax;
        for (int a = 0; a < 3; a++) {
            float t0 = ((p->neg[a] ? n->hi[a][i] : n->lo[a][i]) - p->o[a]) * p->inv[a];
            float t1 = ((p->neg[a] ? n->lo[a][i] : n->hi[a][i]) - p->o[a]) * p->inv[a] * BVH_PAD;
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

/* A traversal stack entry: a 4-wide node (count 0) or a leaf's primitives,
 * and the distance at which the ray enters it. Each node pushes at most 4
 * entries and pops 1, and the tree is at most BVH_SAH_DEPTH + 32 deep, so
 * 3 (BVH_SAH_DEPTH + 32) + 4 entries always suffice. */
typedef struct {
    int32_t code;
    int count;
    float t;
} Entry;

#define BVH_ENTRIES (3 * (BVH_SAH_DEPTH + 32) + 4)

int bvh_closest(const Bvh *b, const Ray *r, PrimHit *h, unsigned long long *tests)
{
    if (b->nnodes4 == 0)
        return -1;
    RayPre p;
    ray_pre(r, &p);
    Ray q = *r; /* tmax shrinks to the nearest hit so far */
    int best = -1;
    unsigned long long nt = 0;
    Entry stack[BVH_ENTRIES];
    int sp = 0;
    stack[sp++] = (Entry){0, 0, 0.0f};
    while (sp > 0) {
        Entry e = stack[--sp];
        if (e.t > q.tmax) /* q.tmax: the nearest hit so far */
            continue;
        if (e.count > 0) {
            PrimHit cur;
            for (int k = -1 - e.code; k < -1 - e.code + e.count; k++) {
                nt++;
                int got = b->tri && b->is_tri[k] ? prim_triangle_hit_watertight3(b->tri[k], &q, &cur)
                                                 : prim_intersect(&b->prims[k], &q, b->variant, &cur);
                if (got &&
                    (best < 0 || cur.t < h->t || b->order[k] < b->order[best])) {
                    best = k;
                    *h = cur;
                    /* one float further, so that a hit at the same t is still
                     * found and the tie goes to the lower index */
                    q.tmax = nextafterf(cur.t, INFINITY);
                }
            }
            continue;
        }
        const Bvh4Node *n = &b->nodes4[e.code];
        float tn[4];
        int mask = slots_enter(n, &p, q.tmax, tn), idx[4], k = 0;
        for (int i = 0; i < 4; i++)
            if (mask >> i & 1) /* farthest first on the stack, nearest on top */
                for (int j = k++; j >= 0; j--) {
                    if (j == 0 || tn[idx[j - 1]] >= tn[i]) {
                        idx[j] = i;
                        break;
                    }
                    idx[j] = idx[j - 1];
                }
        for (int i = 0; i < k; i++)
            stack[sp++] = (Entry){n->child[idx[i]], n->count[idx[i]], tn[idx[i]]};
    }
    *tests += nt;
    return best < 0 ? -1 : b->order[best];
}

int bvh_occluded(const Bvh *b, const Ray *r, unsigned long long *tests)
{
    if (b->nnodes4 == 0)
        return 0;
    RayPre p;
    ray_pre(r, &p);
    Entry stack[BVH_ENTRIES];
    int sp = 0, hit = 0;
    unsigned long long nt = 0;
    stack[sp++] = (Entry){0, 0, 0.0f};
    while (sp > 0 && !hit) {
        Entry e = stack[--sp];
        if (e.count > 0) {
            PrimHit cur;
            for (int k = -1 - e.code; k < -1 - e.code + e.count && !hit; k++) {
                nt++;
                hit = b->tri && b->is_tri[k] ? prim_triangle_hit_watertight3(b->tri[k], r, &cur)
                                             : prim_intersect(&b->prims[k], r, b->variant, &cur);
            }
            continue;
        }
        const Bvh4Node *n = &b->nodes4[e.code];
        float tn[4];
        int mask = slots_enter(n, &p, r->tmax, tn);
        for (int i = 0; i < 4; i++)
            if (mask >> i & 1)
                stack[sp++] = (Entry){n->child[i], n->count[i], tn[i]};
    }
    *tests += nt;
    return hit;
}
