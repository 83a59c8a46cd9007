/* Tests for bvh.c: the invariants after every build (bvh_validate), that
 * bvh_validate catches broken trees, that the wide nodes are full, that
 * the BVH and brute force agree on the closest primitive for 10^6 random
 * rays (and on rays ending just past a hit, and among huge boxes), that
 * the slab padding covers its roundings, and that packets of rays get
 * what each ray gets alone. */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>

#include "testutil.h"

#include "lancer/bvh.h"
#include "lancer/pntri.h"

static unsigned long long rng = 0x9E3779B97F4A7C15ULL;

/* n primitives of every bounded kind, plus a plane, scattered in a cube.
 * The ellipsoids live in the same block, after the primitives, so that
 * one free releases both. */
static Prim *random_prims(int n)
{
    Prim *p = calloc(1, sizeof(Prim) * ((size_t)n + 1) + sizeof(Ellipsoid) * (size_t)n);
    assert_non_null(p);
    Ellipsoid *ells = (Ellipsoid *)(void *)(p + n + 1);
    for (int i = 0; i < n; i++) {
        Vec3 c = test_rvec(&rng, -10, 10);
        switch (i % 4) {
        case 0:
            p[i].kind = PRIM_SPHERE;
            p[i].g.sphere.c = c;
            p[i].g.sphere.r = test_uniform(&rng, 0.1f, 1.5f);
            if (i % 8 == 4) { /* every other one an ellipsoid: any map of the unit sphere */
                Ellipsoid *e = &ells[i];
                for (int k = 0; k < 9; k++)
                    e->m[k] = test_uniform(&rng, -1.5f, 1.5f);
                e->m[9] = c.x, e->m[10] = c.y, e->m[11] = c.z;
                if (prim_ellipsoid_init(e) == 0) {
                    p[i].kind = PRIM_ELLIPSOID;
                    p[i].g.ell.e = e;
                    p[i].g.ell.index = i;
                }
            }
            break;
        case 1:
            p[i].kind = PRIM_TRIANGLE;
            p[i].g.tri.a = c;
            p[i].g.tri.b = vec_add(c, test_rvec(&rng, -2, 2));
            p[i].g.tri.c = vec_add(c, test_rvec(&rng, -2, 2));
            break;
        case 2:
            p[i].kind = PRIM_BOX;
            p[i].g.box.lo = c;
            p[i].g.box.hi = vec_add(c, test_rvec(&rng, 0.1f, 2));
            break;
        default:
            p[i].kind = PRIM_OBOX;
            p[i].g.obox.c = c;
            p[i].g.obox.u = test_rvec(&rng, -1, 1);
            p[i].g.obox.v = test_rvec(&rng, -1, 1);
            p[i].g.obox.w = test_rvec(&rng, -1, 1);
            if (prim_obox_init(&p[i].g.obox) != 0) { /* flat by chance: make it a sphere */
                p[i].kind = PRIM_SPHERE;
                p[i].g.sphere.c = c;
                p[i].g.sphere.r = 1;
            }
        }
    }
    /* Every fourth triangle spans the bounds of the box after it, corner to
     * corner: the two share their box, so the SAH keeps them in one leaf,
     * where a ray tests the triangle in lanes and the box on its own. */
    for (int i = 1; i + 1 < n; i += 16)
        if (p[i].kind == PRIM_TRIANGLE && p[i + 1].kind == PRIM_BOX) {
            const Vec3 lo = p[i + 1].g.box.lo, hi = p[i + 1].g.box.hi;
            p[i].g.tri.a = lo;
            p[i].g.tri.b = vec3(hi.x, hi.y, lo.z);
            p[i].g.tri.c = vec3(lo.x, hi.y, hi.z);
        }
    p[n].kind = PRIM_PLANE; /* unbounded: left out of the tree */
    p[n].g.plane.n = vec3(0, 1, 0);
    p[n].g.plane.d = -12;
    return p;
}

static void build_ok(Bvh *b, const Prim *p, int n, int threads)
{
    char err[256];
    assert_int_equal(bvh_build(b, p, n, PRIM_ROBUST, threads), 0);
    if (bvh_validate(b, err, sizeof err) != 0) {
        print_error("bvh_validate: %s\n", err);
        fail();
    }
}

static void test_validate_after_builds(void **state)
{
    (void)state;
    const int sizes[] = {0, 1, 2, 5, 17, 300, 5000, 20000};
    for (size_t k = 0; k < sizeof sizes / sizeof sizes[0]; k++) {
        for (int threads = 1; threads <= 2; threads++) { /* 2: the parallel path from 4096 up */
            Prim *p = random_prims(sizes[k]);
            Bvh b;
            build_ok(&b, p, sizes[k] + 1, threads);
            assert_int_equal(b.nprims, sizes[k]); /* the plane is not in the tree */
            bvh_free(&b);
            free(p);
        }
    }
}

static void test_wide_nodes_are_full(void **state)
{
    (void)state;
    /* The collapse into wide nodes is planned for the least SAH cost: few
     * wide nodes, most of their slots used. On this input, opening the
     * largest child greedily used 5.1 of 8 slots per node; the plan, 6.3
     * (6.0 since each primitive but a triangle is a leaf of its own, and
     * a triangle beside one of them too, unless they share a box). */
    const int n = 20000;
    Prim *p = random_prims(n);
    Bvh b;
    build_ok(&b, p, n, 1);
    int used = 0;
    for (int i = 0; i < b.nnodes; i++)
        for (int k = 0; k < BVH_WIDTH; k++)
            used += b.nodes[i].lo[0][k] <= b.nodes[i].hi[0][k];
    assert_true(used == b.nnodes - 1 + b.nleaves); /* every node and leaf in one slot */
    assert_true(used >= 6 * b.nnodes);
    bvh_free(&b);
    free(p);
}

/* The levels of wide nodes from node i down to its deepest leaf. */
static int tree_depth(const Bvh *b, int i)
{
    int d = 0;
    for (int k = 0; k < BVH_WIDTH; k++) {
        int c = b->nodes[i].child[k];
        if (b->nodes[i].lo[0][k] <= b->nodes[i].hi[0][k] && c >= 0) {
            int dc = tree_depth(b, c);
            d = dc > d ? dc : d;
        }
    }
    return d + 1;
}

static void test_coincident_centroids(void **state)
{
    (void)state;
    /* 1000 copies of one sphere: no split separates them, so the builder
     * halves by index, and the tree stays as shallow as a balanced one:
     * 1000 leaves of one sphere each under binary halving are 10 binary
     * levels; the collapse into 8-wide nodes, which counts nodes and not
     * levels, folds them into no more (6 here), where a chain would be 143
     * deep. */
    Prim *p = calloc(1000, sizeof(Prim));
    assert_non_null(p);
    for (int i = 0; i < 1000; i++) {
        p[i].kind = PRIM_SPHERE;
        p[i].g.sphere.c = vec3(1, 2, 3);
        p[i].g.sphere.r = 1;
    }
    Bvh b;
    build_ok(&b, p, 1000, 1);
    assert_int_equal(b.nleaves, 1000);
    assert_true(tree_depth(&b, 0) <= 10);
    unsigned long long tests = 0;
    PrimHit h;
    Ray r = ray_make(vec3(1, 2, -10), vec3(0, 0, 1), INFINITY);
    assert_int_equal(bvh_closest(&b, &r, &h, &tests), 0); /* a tie: the lowest index */
    assert_float_equal(h.t, 12, 1e-5);
    bvh_free(&b);
    free(p);
}

static void test_costly_primitives_get_leaves_of_their_own(void **state)
{
    (void)state;
    /* A leaf tests its triangles together but every other primitive on
     * its own, each as costly as a node's box test or more: so a leaf
     * holds at most one such primitive, and the node's box test culls
     * the rest. Triangles still share leaves: they still fill them. */
    const int n = 20000;
    Prim *p = random_prims(n);
    Bvh b;
    build_ok(&b, p, n, 1);
    for (int i = 0; i < b.nleaves; i++) {
        const BvhLeaf *L = &b.leaves[i];
        int costly = 0;
        for (int k = 0; k < L->count; k++)
            costly += p[b.order[L->first + k]].kind != PRIM_TRIANGLE;
        assert_true(costly <= 1);
    }
    bvh_free(&b);
    /* the triangles alone */
    int m = 0;
    for (int i = 0; i < n; i++)
        if (p[i].kind == PRIM_TRIANGLE)
            p[m++] = p[i];
    build_ok(&b, p, m, 1);
    assert_true(m > 6 * b.nleaves); /* 7.1 a leaf */
    bvh_free(&b);
    free(p);
}

/* The leaves' sizes in a tree over n primitives: sizes[k] leaves of k + 1. */
static void leaf_sizes(const Prim *p, int n, int sizes[2])
{
    Bvh b;
    build_ok(&b, p, n, 1);
    sizes[0] = sizes[1] = 0;
    for (int i = 0; i < b.nleaves; i++) {
        assert_true(b.leaves[i].count <= 2);
        sizes[b.leaves[i].count - 1]++;
    }
    bvh_free(&b);
}

static void test_a_primitive_leaves_the_triangles_beside_it(void **state)
{
    (void)state;
    /* A sphere and a triangle far from it: in one leaf, every ray that
     * reaches either tests both. Apart, each is tested by the rays that
     * reach its own box, which the SAH finds cheaper. */
    Prim p[2];
    memset(p, 0, sizeof p);
    p[0].kind = PRIM_SPHERE;
    p[0].g.sphere.c = vec3(0, 0, 0);
    p[0].g.sphere.r = 1;
    p[1].kind = PRIM_TRIANGLE;
    p[1].g.tri.a = vec3(6, 0, 0);
    p[1].g.tri.b = vec3(7, 0, 0);
    p[1].g.tri.c = vec3(6, 1, 0);
    int sizes[2];
    leaf_sizes(p, 2, sizes);
    assert_int_equal(sizes[0], 2);
    assert_int_equal(sizes[1], 0);
    /* A triangle from corner to corner of a box, with the box's own
     * bounds: apart, both leaves would have them, so they stay together. */
    p[0].kind = PRIM_BOX;
    p[0].g.box.lo = vec3(-1, -1, -1);
    p[0].g.box.hi = vec3(1, 1, 1);
    p[1].g.tri.a = vec3(-1, -1, -1);
    p[1].g.tri.b = vec3(1, 1, -1);
    p[1].g.tri.c = vec3(-1, 1, 1);
    leaf_sizes(p, 2, sizes);
    assert_int_equal(sizes[1], 1);
    /* A PN patch stays beside its triangles, far or not: its t depends a
     * little on the ray's tmax, so the order of the tests must not change
     * with the tree. */
    const Vec3 v[3] = {vec3(0, 0, 0), vec3(1, 0, 0), vec3(0, 1, 0)};
    const Vec3 nv[3] = {vec3(0, 0, 1), vec3(0, 0, 1), vec3(0, 0, 1)};
    PnPatch pn;
    pn_patch_init(&pn, v, nv);
    memset(&p[0], 0, sizeof p[0]);
    p[0].kind = PRIM_PN;
    p[0].g.pn.patch = &pn;
    p[1].g.tri.a = vec3(6, 0, 0);
    p[1].g.tri.b = vec3(7, 0, 0);
    p[1].g.tri.c = vec3(6, 1, 0);
    leaf_sizes(p, 2, sizes);
    assert_int_equal(sizes[1], 1);
}

static void test_validate_catches_damage(void **state)
{
    (void)state;
    Prim *p = random_prims(200);
    Bvh b;
    char err[256];
    build_ok(&b, p, 200, 1);
    /* a slot box sticking out of its parent slot: the first inner node
     * under the root, its first slot */
    int k = 0;
    while (b.nodes[0].child[k] <= 0)
        k++;
    BvhWideNode *c = &b.nodes[b.nodes[0].child[k]];
    float saved = c->hi[0][0];
    c->hi[0][0] = b.nodes[0].hi[0][k] + 1;
    assert_int_equal(bvh_validate(&b, err, sizeof err), -1);
    assert_non_null(strstr(err, "outside its parent"));
    c->hi[0][0] = saved;
    assert_int_equal(bvh_validate(&b, err, sizeof err), 0);
    /* a leaf's copied vertex that is not its triangle's */
    int l = 0;
    while (b.leaves[l].tris == 0)
        l++;
    int lane = 0;
    while (!(b.leaves[l].tris >> lane & 1))
        lane++;
    float *copied = &b.leaves[l].tri.v[1][2][lane];
    saved = *copied;
    *copied = saved + 1;
    assert_int_equal(bvh_validate(&b, err, sizeof err), -1);
    assert_non_null(strstr(err, "other vertices"));
    *copied = saved;
    /* an unused slot leading back to the root, where a ray of NaNs would
     * loop */
    int ni = 0, e = BVH_WIDTH;
    for (; ni < b.nnodes && e == BVH_WIDTH; ni += e == BVH_WIDTH)
        for (e = 0; e < BVH_WIDTH && b.nodes[ni].lo[0][e] <= b.nodes[ni].hi[0][e]; e++)
            ;
    assert_true(ni < b.nnodes);
    b.nodes[ni].child[e] = 0;
    assert_int_equal(bvh_validate(&b, err, sizeof err), -1);
    assert_non_null(strstr(err, "not to leaf 0"));
    b.nodes[ni].child[e] = -1;
    /* a primitive referenced twice (and so another not at all) */
    b.leaves[0].first = b.leaves[0].first == 0 ? 1 : 0;
    assert_int_equal(bvh_validate(&b, err, sizeof err), -1);
    bvh_free(&b);
    free(p);
}

/* Rays of NaNs and infinities, and primitives whose bounds overflow to
 * infinity: the traversal answers, and its stack never overflows. (A NaN
 * ray enters every box; unused slots once led back to the root, and such a
 * ray crashed the renderer on a scene scaled by 1e38.) */
static void test_non_finite_rays_and_boxes(void **state)
{
    (void)state;
    const float bad[] = {NAN, INFINITY, -INFINITY};
    for (int n = 1; n <= 2000; n += 1999) {
        Prim *p = random_prims(n);
        p[0].kind = PRIM_SPHERE; /* bounds beyond float: infinite */
        p[0].g.sphere.c = vec3(0, -1e38f, 3e38f);
        p[0].g.sphere.r = 1e38f;
        Bvh b;
        build_ok(&b, p, n, 1);
        for (int k = 0; k < 3; k++)
            for (int which = 0; which < 2; which++) {
                Ray r[BVH_PACKET];
                for (int j = 0; j < BVH_PACKET; j++)
                    r[j] = ray_make(vec3(0.1f * (float)j, 0, -5), vec_normalize(vec3(0.01f * (float)j, 0.02f, 1)),
                                    INFINITY);
                if (which)
                    r[0].o.y = bad[k];
                else
                    r[0].d.x = bad[k];
                unsigned long long tests = 0;
                PrimHit h[BVH_PACKET];
                int best[BVH_PACKET];
                bvh_closest(&b, &r[0], &h[0], &tests);
                bvh_occluded(&b, &r[0], &tests);
                bvh_closest_packet(&b, r, BVH_PACKET, h, best, &tests);
                bvh_occluded_packet(&b, r, BVH_PACKET, &tests);
            }
        bvh_free(&b);
        free(p);
    }
}

/* The closest hit by brute force: each primitive tested with the ray
 * itself, the smallest t kept, ties to the lowest index. */
static int brute_closest(const Prim *p, int n, const Ray *r, PrimHit *h)
{
    int want = -1;
    PrimHit c;
    for (int i = 0; i < n; i++)
        if (prim_intersect(&p[i], r, PRIM_ROBUST, &c) && (want < 0 || c.t < h->t)) {
            want = i;
            *h = c;
        }
    return want;
}

/* Whether two hits on primitive p are the same, bit for bit, in what p's
 * routine sets. */
static int same_hit(const Prim *p, const PrimHit *a, const PrimHit *b)
{
    int tri = p->kind == PRIM_TRIANGLE || p->kind == PRIM_SMOOTH_TRIANGLE;
    int box = p->kind == PRIM_BOX || p->kind == PRIM_OBOX;
    return a->t == b->t && a->terr == b->terr && (!tri || (a->u == b->u && a->v == b->v)) && (!box || a->face == b->face);
}

/* Whether closest-hit answers got (h) and want (w) differ: in the
 * primitive, or in its hit, bit for bit. */
static int closest_differs(const Prim *p, int got, const PrimHit *h, int want, const PrimHit *w)
{
    return got != want || (want >= 0 && !same_hit(&p[want], h, w));
}

/* Traces `rays` random rays aimed into the primitives through the BVH and by
 * brute force and counts the rays on which they disagree: on the closest
 * primitive, its hit (t, terr, u and v, bit for bit: the SIMD leaf tests
 * must give what each primitive's own routine gives), or whether anything
 * is hit. Sets *hits to the rays that
 * hit something. */
static int disagreements(const Bvh *b, const Prim *p, int n, int rays, int *hits)
{
    unsigned long long tests = 0;
    int bad = 0;
    *hits = 0;
    for (int k = 0; k < rays; k++) {
        Vec3 o = test_rvec(&rng, -14, 14);
        Ray r = ray_make(o, vec_normalize(vec_sub(test_rvec(&rng, -10, 10), o)), k % 3 ? INFINITY : test_uniform(&rng, 1, 20));
        PrimHit h, w = {0, 0, 0, 0, 0};
        int got = bvh_closest(b, &r, &h, &tests), want = brute_closest(p, n, &r, &w);
        *hits += want >= 0;
        bad += closest_differs(p, got, &h, want, &w) || bvh_occluded(b, &r, &tests) != (want >= 0);
    }
    return bad;
}

static void test_agrees_with_brute_force(void **state)
{
    (void)state;
    const int n = 60, rays = 1000000;
    Prim *p = random_prims(n);
    Bvh b;
    int hits;
    build_ok(&b, p, n, 2);
    int mixed = 0; /* leaves whose triangles take the SIMD test and the rest their own */
    for (int l = 0; l < b.nleaves; l++)
        mixed += b.leaves[l].tris != 0 && b.leaves[l].tris != (1 << b.leaves[l].count) - 1;
    assert_true(mixed > 0);
    assert_int_equal(disagreements(&b, p, n, rays, &hits), 0);
    assert_true(hits > rays / 10);
    bvh_free(&b);
    free(p);
}

static void test_huge_boxes(void **state)
{
    (void)state;
    /* Spheres of radius 1e20 among small primitives: their boxes' areas
     * overflow a float. The collapse's plan must still place every node
     * (it once read out of bounds, and lost primitives, when all its costs
     * were infinite), and the tree must answer as brute force does. */
    const int n = 3000;
    Prim *p = random_prims(n);
    for (int i = 0; i < n; i += 500) {
        p[i].kind = PRIM_SPHERE;
        p[i].g.sphere.c = vec3(0, -1e20f - 20.0f * (float)i, 0);
        p[i].g.sphere.r = 1e20f;
    }
    Bvh b;
    int hits;
    build_ok(&b, p, n, 1);
    assert_int_equal(b.nprims, n);
    assert_int_equal(disagreements(&b, p, n, 20000, &hits), 0);
    assert_true(hits > 20000 / 10);
    bvh_free(&b);
    free(p);
}

/* A random triangle: a corner in [-10, 10]^3, the others within 2 of it. */
static Triangle random_triangle(void)
{
    Triangle t;
    memset(&t, 0, sizeof t);
    t.a = test_rvec(&rng, -10, 10);
    t.b = vec_add(t.a, test_rvec(&rng, -2, 2));
    t.c = vec_add(t.a, test_rvec(&rng, -2, 2));
    return t;
}

/* n random triangles (random_triangle), of kind PRIM_TRIANGLE. */
static Prim *random_triangles(int n)
{
    Prim *p = calloc((size_t)n, sizeof(Prim));
    assert_non_null(p);
    for (int i = 0; i < n; i++) {
        p[i].kind = PRIM_TRIANGLE;
        p[i].g.tri = random_triangle();
    }
    return p;
}

static void test_hits_just_before_tmax(void **state)
{
    (void)state;
    /* Triangles in axis planes, whose box face is the triangle's plane, and
     * rays ending one float past a hit: the box's entry distance, rounded
     * on its own, may land after tmax where the triangle's t lands before
     * it. The tree must still find the hit (some were lost before boxes were
     * entered up to a grown tmax). */
    const int n = 200, rays = 40000;
    Prim *p = random_triangles(n);
    for (int i = 0; i < n; i++) { /* in the plane of constant coordinate i % 3 */
        Triangle *t = &p[i].g.tri;
        (&t->b.x)[i % 3] = (&t->c.x)[i % 3] = (&t->a.x)[i % 3];
    }
    Bvh b;
    build_ok(&b, p, n, 1);
    unsigned long long tests = 0;
    int bad = 0, tried = 0;
    for (int k = 0; k < rays; k++) {
        const Triangle *tr = &p[k % n].g.tri;
        Vec3 o = test_rvec(&rng, -14, 14);
        Vec3 target = vec_add(tr->a, vec_add(vec_scale(vec_sub(tr->b, tr->a), 0.3f), vec_scale(vec_sub(tr->c, tr->a), 0.3f)));
        Ray r = ray_make(o, vec_sub(target, o), INFINITY);
        PrimHit h, w = {0, 0, 0, 0, 0};
        if (!prim_intersect(&p[k % n], &r, PRIM_ROBUST, &h))
            continue;
        r.tmax = nextafterf(h.t, INFINITY);
        tried++;
        int got = bvh_closest(&b, &r, &h, &tests), want = brute_closest(p, n, &r, &w);
        bad += want < 0 || closest_differs(p, got, &h, want, &w) || !bvh_occluded(&b, &r, &tests);
    }
    assert_true(tried > rays / 2);
    assert_int_equal(bad, 0);
    bvh_free(&b);
    free(p);
}

/* Lone primitives where a plausible slip in the box test or the boxes
 * changes the answer, which a review's mutations found no other test to
 * see; each through the tree, closest and any hit. */
static void lone_hit(const Prim *p, const Ray *r, float t)
{
    Bvh b;
    build_ok(&b, p, 1, 1);
    unsigned long long tests = 0;
    PrimHit h;
    int got = bvh_closest(&b, r, &h, &tests);
    if (t > 0.0f) {
        assert_int_equal(got, 0);
        assert_true(h.t == t);
        assert_true(bvh_occluded(&b, r, &tests));
    } else {
        assert_int_equal(got, -1);
        assert_false(bvh_occluded(&b, r, &tests));
    }
    bvh_free(&b);
}

static void test_lone_primitives_at_the_box_tests_edges(void **state)
{
    (void)state;
    Prim p[1];
    memset(p, 0, sizeof p);
    p[0].kind = PRIM_TRIANGLE;
    { /* entry and exit distances both overflow to infinity: a box entered
       * where they are equal (<=, not <) */
        p[0].g.tri.a = vec3(0x1p127f, -1, -1);
        p[0].g.tri.b = vec3(0x1p127f, 1, -1);
        p[0].g.tri.c = vec3(0x1p127f, 0, 1);
        Ray r = ray_make(vec3(-0x1p127f, 0, 0), vec3(1024, 0, 0), INFINITY);
        lone_hit(p, &r, 0x1p118f);
    }
    { /* a direction component of exactly 2^-128, whose reciprocal
       * overflows: that axis culls nothing (inverse_dir) */
        p[0].g.tri.a = vec3(1024, 0x1p-120f, -1);
        p[0].g.tri.b = vec3(1024, 1, -1);
        p[0].g.tri.c = vec3(1024, 0x1p-120f, 1);
        Ray r = ray_make(vec3(0, 0, 0), vec3(1, 0x1p-128f, 0), INFINITY);
        lone_hit(p, &r, 1024);
    }
    { /* a hit at exactly tmax is no hit, in the leaves' lanes too */
        p[0].g.tri.a = vec3(-1, -1, 1);
        p[0].g.tri.b = vec3(1, -1, 1);
        p[0].g.tri.c = vec3(0, 1, 1);
        Ray r = ray_make(vec3(0, 0, 0), vec3(0, 0, 1), 1.0f);
        lone_hit(p, &r, 0);
        r.tmax = nextafterf(1.0f, INFINITY);
        lone_hit(p, &r, 1);
    }
    { /* a sphere 2^-30 across at x = 1: its box's corners are rounded
       * outward from double (1 - 2^-30 is no float), and the ray that
       * grazes its side is hit at t = 1 */
        p[0].kind = PRIM_SPHERE;
        p[0].g.sphere.c = vec3(1, 0, 0);
        p[0].g.sphere.r = 0x1p-30f;
        Ray r = ray_make(vec3(1.0f - 0x1p-24f, -1, 0), vec3(0x1p-24f - 0x1p-31f, 1, 0), INFINITY);
        PrimHit h;
        assert_true(prim_intersect(p, &r, PRIM_ROBUST, &h));
        lone_hit(p, &r, h.t);
    }
}

static void test_rays_from_outside_touching_the_root_box(void **state)
{
    (void)state;
    /* A tree of one triangle in an axis plane, so its root box is flat,
     * and rays from outside aimed at the triangle's vertices and edges,
     * which lie on the box's faces: a ray then enters the box and leaves
     * it at the same t. The test of the root box that spares rays missing
     * it their traversal must keep the slab test's padding, or it drops
     * such rays where the triangle test finds a hit. */
    const int trees = 2000, rays = 40;
    int bad = 0, hits = 0, split = 0, missed = 0; /* packets: some rays hit, or none */
    unsigned long long tests = 0;
    for (int i = 0; i < trees; i++) {
        Prim *p = random_triangles(1);
        Triangle *t = &p->g.tri;
        (&t->b.x)[i % 3] = (&t->c.x)[i % 3] = (&t->a.x)[i % 3];
        Bvh b;
        build_ok(&b, p, 1, 1);
        for (int k = 0; k < rays; k++) {
            const Vec3 v[3] = {t->a, t->b, t->c};
            float s = k % 2 ? 0.0f : test_uniform(&rng, 0, 1);
            Vec3 target = vec_add(v[k % 3], vec_scale(vec_sub(v[(k + 1) % 3], v[k % 3]), s));
            Vec3 o = test_rvec(&rng, -14, 14);
            Ray r = ray_make(o, vec_sub(target, o), INFINITY);
            PrimHit h, w = {0, 0, 0, 0, 0};
            int want = brute_closest(p, 1, &r, &w), got = bvh_closest(&b, &r, &h, &tests);
            bad += closest_differs(p, got, &h, want, &w) || bvh_occluded(&b, &r, &tests) != (want >= 0);
            hits += want >= 0;
        }
        /* Packets too, whose rays the root box's test may all send away
         * at once: eight rays from one origin towards a vertex or an edge,
         * a few ulps apart, so that some enter the box and some pass it. */
        for (int k = 0; k < rays / BVH_PACKET; k++) {
            const Vec3 v[3] = {t->a, t->b, t->c};
            Vec3 target = vec_add(v[k % 3], vec_scale(vec_sub(v[(k + 1) % 3], v[k % 3]), 0.5f * (float)(k % 2)));
            Vec3 o = test_rvec(&rng, -14, 14);
            Ray r[BVH_PACKET];
            for (int j = 0; j < BVH_PACKET; j++)
                r[j] = ray_make(o, vec_sub(vec_add(target, test_rvec(&rng, -0x1p-20f, 0x1p-20f)), o), INFINITY);
            PrimHit h[BVH_PACKET], w = {0, 0, 0, 0, 0};
            int got[BVH_PACKET], in = 0;
            bvh_closest_packet(&b, r, BVH_PACKET, h, got, &tests);
            const unsigned dark = bvh_occluded_packet(&b, r, BVH_PACKET, &tests);
            for (int j = 0; j < BVH_PACKET; j++) {
                int want = brute_closest(p, 1, &r[j], &w);
                bad += closest_differs(p, got[j], &h[j], want, &w) || (int)(dark >> j & 1) != (want >= 0);
                in += want >= 0;
            }
            split += in > 0 && in < BVH_PACKET;
            missed += in == 0;
        }
        bvh_free(&b);
        free(p);
    }
    assert_true(hits > trees * rays / 4);
    assert_true(split > 100 && missed > 100);
    assert_int_equal(bad, 0);
}

static void test_mesh_leaves_agree_with_brute_force(void **state)
{
    (void)state;
    /* triangles only: every leaf is one SIMD test */
    const int n = 400, rays = 200000;
    Prim *p = random_triangles(n);
    for (int i = 0; i < n; i += 2)
        p[i].kind = PRIM_SMOOTH_TRIANGLE;
    Bvh b;
    int hits;
    build_ok(&b, p, n, 1);
    for (int l = 0; l < b.nleaves; l++)
        assert_int_equal(b.leaves[l].tris, (1 << b.leaves[l].count) - 1);
    assert_int_equal(disagreements(&b, p, n, rays, &hits), 0);
    assert_true(hits > rays / 10);
    bvh_free(&b);
    free(p);
}

/* The tree is written into the block of the build's references: in
 * place for a mesh, whose tree fits the room reserved with them, and after
 * the block grows for primitives that are each a leaf. Either way the
 * leaves start on the block's first cache line and the nodes follow them
 * (bvh_validate checks the alignment). */
static void test_tree_lies_in_the_refs_block(void **state)
{
    (void)state;
    for (int costly = 0; costly <= 1; costly++) {
        const int n = 5000;
        Prim *p = costly ? random_prims(n) : random_triangles(n);
        Bvh b;
        build_ok(&b, p, n, 1);
        ptrdiff_t at = (const char *)b.leaves - (const char *)b.mem;
        assert_true(at >= 0 && at < 64);
        assert_ptr_equal(b.nodes, (const void *)(b.leaves + b.nleaves));
        assert_true(bvh_bytes(&b) > sizeof(BvhLeaf) * (size_t)b.nleaves + sizeof(BvhWideNode) * (size_t)b.nnodes);
        if (!costly) /* the tree fits twice the refs' bytes */
            assert_true(sizeof(BvhLeaf) * (size_t)b.nleaves + sizeof(BvhWideNode) * (size_t)b.nnodes <
                        64 * (size_t)n);
        else /* a leaf for each but the triangles (one in four): the block grew */
            assert_true(b.nleaves >= 3 * n / 4);
        bvh_free(&b);
        free(p);
    }
}

/* The grid of the closed-mesh tests' cube. */
#define CUBE_G 8

/* The surface of the cube [-1, 1]^3, each face a g x g grid of quads split
 * into two triangles; returns the triangle count (12 g^2). */
static int grid_cube(Prim *p, int g)
{
    int n = 0;
    for (int axis = 0; axis < 3; axis++)
        for (int side = -1; side <= 1; side += 2)
            for (int i = 0; i < g; i++)
                for (int j = 0; j < g; j++) {
                    Vec3 q[4];
                    for (int c = 0; c < 4; c++) {
                        float u = -1 + 2 * (float)(i + (c == 1 || c == 2)) / (float)g;
                        float v = -1 + 2 * (float)(j + (c >= 2)) / (float)g, w[3];
                        w[axis] = (float)side;
                        w[(axis + 1) % 3] = u;
                        w[(axis + 2) % 3] = v;
                        q[c] = vec3(w[0], w[1], w[2]);
                    }
                    for (int t = 0; t < 2; t++) {
                        p[n].kind = PRIM_TRIANGLE;
                        p[n].g.tri.a = q[0];
                        p[n].g.tri.b = q[t ? 2 : 1];
                        p[n].g.tri.c = q[t ? 3 : 2];
                        n++;
                    }
                }
    return n;
}

/* grid_cube's triangles into *p (the caller frees them) and their tree
 * into b; returns the triangle count. */
static int cube_tree(Prim **p, Bvh *b)
{
    *p = calloc(12 * CUBE_G * CUBE_G, sizeof(Prim));
    assert_non_null(*p);
    int n = grid_cube(*p, CUBE_G);
    build_ok(b, *p, n, 1);
    return n;
}

static void test_closed_mesh_has_no_leaks(void **state)
{
    (void)state;
    /* Rays from inside a closed mesh aimed at its vertices and at points
     * of its edges, whose lanes' edge functions are 0 or nearly: every ray
     * must hit, and the BVH must agree with brute force, ties included (a
     * ray through a shared edge hits two triangles at the same t; before
     * prim_tmax_past, the one the traversal met first could win). */
    const int rays = 100000;
    Prim *p;
    Bvh b;
    int n = cube_tree(&p, &b);
    unsigned long long tests = 0;
    int bad = 0, leaks = 0;
    for (int k = 0; k < rays; k++) {
        const Triangle *tr = &p[k % n].g.tri;
        float s = test_uniform(&rng, 0, 1);
        Vec3 target = k % 3 == 0 ? tr->a : k % 3 == 1 ? vec_add(tr->a, vec_scale(vec_sub(tr->b, tr->a), s))
                                                      : vec_add(tr->b, vec_scale(vec_sub(tr->c, tr->b), s));
        Vec3 o = test_rvec(&rng, -0.9f, 0.9f);
        Ray r = ray_make(o, vec_sub(target, o), INFINITY);
        PrimHit h, w = {0, 0, 0, 0, 0};
        int got = bvh_closest(&b, &r, &h, &tests), want = brute_closest(p, n, &r, &w);
        leaks += got < 0 || !bvh_occluded(&b, &r, &tests);
        bad += closest_differs(p, got, &h, want, &w);
    }
    assert_int_equal(leaks, 0);
    assert_int_equal(bad, 0);
    bvh_free(&b);
    free(p);
}

/* For odd 6, 7 and 8, a direction of the last of n > 1 rays that sends it
 * one by one: a NaN, a zero or an infinity in it. */
static void spoil_last(Ray *r, int n, int odd)
{
    if (n > 1 && odd == 6)
        r[n - 1].d.x = NAN;
    if (n > 1 && odd == 7)
        r[n - 1].d.y = 0.0f;
    if (n > 1 && odd == 8)
        r[n - 1].d.z = -INFINITY;
}

/* Counts the rays of `packets` packets on which bvh_closest_packet and
 * bvh_closest disagree (primitive or hit, bit for bit). Packets of 1 to
 * BVH_PACKET rays from one origin, narrow and wide cones (traced together
 * unless their directions' signs differ), from two origins, or from
 * origins spread as mirror rays' are, and rays that must go one by one:
 * with a NaN, an infinity or a zero in a direction. Aims at target(p, k)
 * when given, else into the cube [-10, 10]^3. */
static int packet_disagreements(const Bvh *b, const Prim *p, int packets, Vec3 (*target)(const Prim *, int))
{
    unsigned long long tests = 0;
    int bad = 0;
    for (int k = 0; k < packets; k++) {
        int n = 1 + k % BVH_PACKET, odd = k / BVH_PACKET % 9;
        float spread = k % 3 == 0 ? 0.01f : k % 3 == 1 ? 0.3f : 3.0f;
        Vec3 o = target ? test_rvec(&rng, -0.9f, 0.9f) : test_rvec(&rng, -14, 14);
        Vec3 aim = target ? o : test_rvec(&rng, -10, 10);
        Ray r[BVH_PACKET];
        for (int j = 0; j < n; j++) {
            Vec3 at = target ? target(p, k + j) : vec_add(aim, test_rvec(&rng, -spread, spread));
            r[j] = ray_make(o, vec_normalize(vec_sub(at, o)), j % 3 ? INFINITY : test_uniform(&rng, 1, 20));
        }
        if (n > 1 && odd == 5)
            r[n - 1].o.z += 1e-3f;
        for (int j = 1; j < n && odd == 4; j++)
            r[j].o = vec_add(r[j].o, test_rvec(&rng, -spread, spread));
        spoil_last(r, n, odd);
        PrimHit h[BVH_PACKET], w;
        int got[BVH_PACKET];
        bvh_closest_packet(b, r, n, h, got, &tests);
        for (int j = 0; j < n; j++) {
            int want = bvh_closest(b, &r[j], &w, &tests);
            bad += closest_differs(p, got[j], &h[j], want, &w);
        }
    }
    return bad;
}

/* Counts the rays of `packets` packets on which bvh_occluded_packet and
 * bvh_occluded disagree. Shadow-like packets of 1 to BVH_PACKET rays from
 * origins spread over a small or a large box towards one point (traced
 * together unless their directions' signs differ), with tmax short of it
 * or past it; and rays that must go one by one: with a NaN, an infinity or
 * a zero in a direction, or an infinite origin. Aims at target(p, k) when
 * given (points on the primitives' edges), else into the cube [-10, 10]^3. */
static int occluded_packet_disagreements(const Bvh *b, const Prim *p, int packets, Vec3 (*target)(const Prim *, int))
{
    unsigned long long tests = 0;
    int bad = 0;
    for (int k = 0; k < packets; k++) {
        int n = 1 + k % BVH_PACKET, odd = k / BVH_PACKET % 10;
        float spread = k % 3 == 0 ? 0.01f : k % 3 == 1 ? 0.3f : 3.0f;
        Vec3 c = target ? test_rvec(&rng, -0.9f, 0.9f) : test_rvec(&rng, -14, 14);
        Vec3 light = target ? target(p, k) : test_rvec(&rng, -10, 10);
        Ray r[BVH_PACKET];
        for (int j = 0; j < n; j++) {
            Vec3 o = vec_add(c, test_rvec(&rng, -spread, spread));
            if (target && j % 2)
                o = target(p, k + j); /* from an edge */
            Vec3 d = vec_sub(light, o);
            float len = vec_length(d);
            r[j] = ray_make(o, vec_scale(d, 1.0f / len), j % 3 ? len : len * test_uniform(&rng, 0.2f, 1.5f));
        }
        if (n > 1 && odd == 5)
            r[n - 1].o.x = INFINITY;
        spoil_last(r, n, odd);
        if (n > 1 && odd == 9)
            r[n - 1].d = vec_neg(r[n - 1].d);
        unsigned got = bvh_occluded_packet(b, r, n, &tests);
        for (int j = 0; j < n; j++)
            bad += (int)(got >> j & 1) != bvh_occluded(b, &r[j], &tests);
        bad += got >> n != 0;
    }
    return bad;
}

/* A vertex, or a point on an edge, of triangle k % count of grid_cube's. */
static Vec3 cube_edge_point(const Prim *p, int k)
{
    const Triangle *tr = &p[k % (12 * CUBE_G * CUBE_G)].g.tri;
    return k % 2 ? tr->a : vec_add(tr->b, vec_scale(vec_sub(tr->c, tr->b), 0.5f));
}

/* A packet check: the rays of `packets` packets on which a packet query
 * and its rays one by one disagree (below). */
typedef int (*PacketCheck)(const Bvh *b, const Prim *p, int packets, Vec3 (*target)(const Prim *, int));

/* Runs check on random trees, one of a single node and one deep enough for
 * the stack and culling, and through a closed mesh's shared edges (ties). */
static void packets_agree(PacketCheck check)
{
    for (int n = 60; n <= 3000; n *= 50) {
        Prim *p = random_prims(n);
        Bvh b;
        build_ok(&b, p, n, 1);
        assert_int_equal(check(&b, p, 50000, NULL), 0);
        bvh_free(&b);
        free(p);
    }
    Prim *p;
    Bvh b;
    cube_tree(&p, &b);
    assert_int_equal(check(&b, p, 20000, cube_edge_point), 0);
    bvh_free(&b);
    free(p);
}

static void test_packets_agree_with_single_rays(void **state)
{
    (void)state;
    packets_agree(packet_disagreements);
}

/* Camera packets of eight rays from one origin, inside the closed mesh
 * or outside it, in a cone so narrow that all eight reach the same leaves
 * (two rays to a leaf test on AMD processors with AVX-512), aimed at a
 * vertex or an edge, where lanes go to the scalar routine: each ray must
 * get its hit one by one, bit for bit. */
static void test_narrow_packets_through_edges(void **state)
{
    (void)state;
    Prim *p;
    Bvh b;
    cube_tree(&p, &b);
    unsigned long long tests = 0;
    int bad = 0, hits = 0;
    for (int k = 0; k < 20000; k++) {
        Vec3 o = k % 2 ? test_rvec(&rng, -0.9f, 0.9f) : vec_scale(test_rvec(&rng, -1, 1), 3.0f);
        Vec3 at = cube_edge_point(p, k);
        float spread = k % 3 == 0 ? 0x1p-20f : k % 3 == 1 ? 0x1p-12f : 0.0f;
        Ray r[BVH_PACKET];
        for (int j = 0; j < BVH_PACKET; j++)
            r[j] = ray_make(o, vec_sub(vec_add(at, test_rvec(&rng, -spread, spread)), o),
                            k % 5 ? INFINITY : test_uniform(&rng, 0.5f, 1.5f));
        PrimHit h[BVH_PACKET], w;
        int got[BVH_PACKET];
        bvh_closest_packet(&b, r, BVH_PACKET, h, got, &tests);
        for (int j = 0; j < BVH_PACKET; j++) {
            int want = bvh_closest(&b, &r[j], &w, &tests);
            bad += closest_differs(p, got[j], &h[j], want, &w);
            hits += want >= 0;
        }
    }
    assert_int_equal(bad, 0);
    assert_true(hits > 100000);
    bvh_free(&b);
    free(p);
}

/* The same with bvh_occluded_packet and bvh_occluded: shadow rays between
 * random points of random trees (many occluded, many not), and between
 * points on a closed mesh's edges. */
static void test_occluded_packets_agree_with_single_rays(void **state)
{
    (void)state;
    packets_agree(occluded_packet_disagreements);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_validate_after_builds),
        cmocka_unit_test(test_wide_nodes_are_full),
        cmocka_unit_test(test_huge_boxes),
        cmocka_unit_test(test_coincident_centroids),
        cmocka_unit_test(test_costly_primitives_get_leaves_of_their_own),
        cmocka_unit_test(test_a_primitive_leaves_the_triangles_beside_it),
        cmocka_unit_test(test_validate_catches_damage),
        cmocka_unit_test(test_non_finite_rays_and_boxes),
        cmocka_unit_test(test_agrees_with_brute_force),
        cmocka_unit_test(test_hits_just_before_tmax),
        cmocka_unit_test(test_lone_primitives_at_the_box_tests_edges),
        cmocka_unit_test(test_rays_from_outside_touching_the_root_box),
        cmocka_unit_test(test_mesh_leaves_agree_with_brute_force),
        cmocka_unit_test(test_tree_lies_in_the_refs_block),
        cmocka_unit_test(test_closed_mesh_has_no_leaks),
        cmocka_unit_test(test_packets_agree_with_single_rays),
        cmocka_unit_test(test_narrow_packets_through_edges),
        cmocka_unit_test(test_occluded_packets_agree_with_single_rays),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
