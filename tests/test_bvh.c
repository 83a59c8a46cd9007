/* Tests for bvh.c: the invariants after every build (bvh_validate), that
 * bvh_validate catches broken trees, and that the BVH and brute force agree
 * on the closest primitive for 10^6 random rays. */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>

#include "lancer/bvh.h"

static unsigned long long rng = 0x9E3779B97F4A7C15ULL;

static float uniform(float lo, float hi) /* xorshift64 */
{
    rng ^= rng << 13;
    rng ^= rng >> 7;
    rng ^= rng << 17;
    return lo + (hi - lo) * (float)((double)(rng >> 11) / 9007199254740992.0);
}

static Vec3 rvec(float lo, float hi) { return vec3(uniform(lo, hi), uniform(lo, hi), uniform(lo, hi)); }

/* n primitives of every bounded kind, plus a plane, scattered in a cube. */
static Prim *random_prims(int n)
{
    Prim *p = calloc((size_t)n + 1, sizeof(Prim));
    assert_non_null(p);
    for (int i = 0; i < n; i++) {
        Vec3 c = rvec(-10, 10);
        switch (i % 4) {
        case 0:
            p[i].kind = PRIM_SPHERE;
            p[i].g.sphere.c = c;
            p[i].g.sphere.r = uniform(0.1f, 1.5f);
            break;
        case 1:
            p[i].kind = PRIM_TRIANGLE;
            p[i].g.tri.a = c;
            p[i].g.tri.b = vec_add(c, rvec(-2, 2));
            p[i].g.tri.c = vec_add(c, rvec(-2, 2));
            break;
        case 2:
            p[i].kind = PRIM_BOX;
            p[i].g.box.lo = c;
            p[i].g.box.hi = vec_add(c, rvec(0.1f, 2));
            break;
        default:
            p[i].kind = PRIM_OBOX;
            p[i].g.obox.c = c;
            p[i].g.obox.u = rvec(-1, 1);
            p[i].g.obox.v = rvec(-1, 1);
            p[i].g.obox.w = rvec(-1, 1);
            if (prim_obox_init(&p[i].g.obox) != 0) { /* flat by chance: make it a sphere */
                p[i].kind = PRIM_SPHERE;
                p[i].g.sphere.c = c;
                p[i].g.sphere.r = 1;
            }
        }
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

static void test_coincident_centroids(void **state)
{
    (void)state;
    /* 1000 copies of one sphere: no split separates them, so the builder
     * halves by index, and the tree stays shallow enough to traverse. */
    Prim *p = calloc(1000, sizeof(Prim));
    assert_non_null(p);
    for (int i = 0; i < 1000; i++) {
        p[i].kind = PRIM_SPHERE;
        p[i].g.sphere.c = vec3(1, 2, 3);
        p[i].g.sphere.r = 1;
    }
    Bvh b;
    build_ok(&b, p, 1000, 1);
    unsigned long long tests = 0;
    PrimHit h;
    Ray r = ray_make(vec3(1, 2, -10), vec3(0, 0, 1), INFINITY);
    assert_int_equal(bvh_closest(&b, &r, &h, &tests), 0); /* a tie: the lowest index */
    assert_float_equal(h.t, 12, 1e-5);
    bvh_free(&b);
    free(p);
}

static void test_validate_catches_damage(void **state)
{
    (void)state;
    Prim *p = random_prims(200);
    Bvh b;
    char err[256];
    build_ok(&b, p, 200, 1);
    /* a child box sticking out of its parent */
    int c = (int)b.nodes[0].first;
    float saved = b.nodes[c].hi[0];
    b.nodes[c].hi[0] = b.nodes[0].hi[0] + 1;
    assert_int_equal(bvh_validate(&b, err, sizeof err), -1);
    assert_non_null(strstr(err, "outside its parent"));
    b.nodes[c].hi[0] = saved;
    /* a primitive referenced twice (and so another not at all) */
    int leaf = 0; /* the leftmost leaf */
    while (b.nodes[leaf].count == 0)
        leaf = (int)b.nodes[leaf].first;
    b.nodes[leaf].first = b.nodes[leaf].first == 0 ? 1 : 0;
    assert_int_equal(bvh_validate(&b, err, sizeof err), -1);
    bvh_free(&b);
    free(p);
}

/* Traces `rays` random rays aimed into the primitives through the BVH and by
 * brute force (ties to the lowest index) and counts the rays on which they
 * disagree: on the closest primitive, its t, or whether anything is hit.
 * Sets *hits to the rays that hit something. */
static int disagreements(const Bvh *b, const Prim *p, int n, int rays, int *hits)
{
    unsigned long long tests = 0;
    int bad = 0;
    *hits = 0;
    for (int k = 0; k < rays; k++) {
        Vec3 o = rvec(-14, 14);
        Ray r = ray_make(o, vec_normalize(vec_sub(rvec(-10, 10), o)), k % 3 ? INFINITY : uniform(1, 20));
        PrimHit h, c;
        int got = bvh_closest(b, &r, &h, &tests), want = -1;
        Ray q = r;
        for (int i = 0; i < n; i++)
            if (prim_intersect(&p[i], &q, PRIM_ROBUST, &c) && (want < 0 || c.t < q.tmax)) {
                want = i;
                q.tmax = c.t;
            }
        *hits += want >= 0;
        bad += got != want || (want >= 0 && h.t != q.tmax) || bvh_occluded(b, &r, &tests) != (want >= 0);
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
    assert_non_null(b.is_tri); /* mixed leaves: triangles read compactly, the rest as Prims */
    assert_int_equal(disagreements(&b, p, n, rays, &hits), 0);
    assert_true(hits > rays / 10);
    bvh_free(&b);
    free(p);
}

static void test_mesh_leaves_agree_with_brute_force(void **state)
{
    (void)state;
    /* triangles only: every leaf reads the compact copy of the vertices */
    const int n = 400, rays = 200000;
    Prim *p = calloc(n, sizeof(Prim));
    assert_non_null(p);
    for (int i = 0; i < n; i++) {
        Vec3 c = rvec(-10, 10);
        p[i].kind = i % 2 ? PRIM_TRIANGLE : PRIM_SMOOTH_TRIANGLE;
        p[i].g.tri.a = c;
        p[i].g.tri.b = vec_add(c, rvec(-2, 2));
        p[i].g.tri.c = vec_add(c, rvec(-2, 2));
    }
    Bvh b;
    int hits;
    build_ok(&b, p, n, 1);
    assert_non_null(b.tri);
    assert_int_equal(disagreements(&b, p, n, rays, &hits), 0);
    assert_true(hits > rays / 10);
    bvh_free(&b);
    free(p);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_validate_after_builds),
        cmocka_unit_test(test_coincident_centroids),
        cmocka_unit_test(test_validate_catches_damage),
        cmocka_unit_test(test_agrees_with_brute_force),
        cmocka_unit_test(test_mesh_leaves_agree_with_brute_force),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
