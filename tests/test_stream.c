/* Tests for stream.c: a batch of rays answered as accel_closest answers
 * each, bit for bit, whether the stream sorts them or keeps the caller's
 * order; and when it sorts. */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>

#include "testutil.h"

#include "lancer/stream.h"

#define MANY 40000 /* above the stream's least batch to sort */

/* n triangles of sides up to 1.5 scattered in [-4, 4]^3, and `planes`
 * planes 5 from the origin. */
static void soup(Scene *s, int n, int planes, unsigned long long *g)
{
    memset(s, 0, sizeof *s);
    s->nprims = n + planes;
    s->prims = calloc((size_t)s->nprims, sizeof(Prim));
    assert_non_null(s->prims);
    for (int i = 0; i < n; i++) {
        Prim *p = &s->prims[i];
        Vec3 c = test_rvec(g, -4, 4);
        p->kind = PRIM_TRIANGLE;
        p->g.tri.a = c;
        p->g.tri.b = vec_add(c, test_rvec(g, -1.5f, 1.5f));
        p->g.tri.c = vec_add(c, test_rvec(g, -1.5f, 1.5f));
    }
    for (int i = n; i < n + planes; i++) {
        Prim *p = &s->prims[i];
        p->kind = PRIM_PLANE;
        p->g.plane.n = vec_normalize(test_rvec(g, -1, 1));
        p->g.plane.d = 5.0f;
    }
}

/* soup's scene in *sc and the queries over it. */
static Accel *soup_accel(Scene *sc, int n, int planes, unsigned long long *g)
{
    soup(sc, n, planes, g);
    Accel *a = accel_build(sc, PRIM_ROBUST, 1);
    assert_non_null(a);
    return a;
}

/* Random rays: origins in [-reach, reach]^3 (some outside the scene's box),
 * directions anywhere. */
static Ray *scattered(size_t n, float reach, unsigned long long *g)
{
    Ray *r = malloc(n * sizeof *r);
    assert_non_null(r);
    for (size_t i = 0; i < n; i++)
        r[i] = ray_make(test_rvec(g, -reach, reach), vec_normalize(test_rvec(g, -1, 1)), INFINITY);
    return r;
}

/* The stream's answers for r[0 .. n-1] (room for max) are accel_closest's,
 * every field of every hit; returns what accel_closest_stream returned. */
static int check_stream(const Accel *a, const Ray *r, size_t n, size_t max)
{
    AccelStream *s = accel_stream_new(max);
    assert_non_null(s);
    PrimHit *h = malloc((n ? n : 1) * sizeof *h);
    int *best = malloc((n ? n : 1) * sizeof *best);
    assert_non_null(h);
    assert_non_null(best);
    memset(h, 0x7f, n * sizeof *h); /* answers left unwritten would show */
    memset(best, 0x7f, n * sizeof *best);
    RayStats st;
    memset(&st, 0, sizeof st);
    int sorted = accel_closest_stream(a, s, r, n, h, best, &st);
    size_t hits = 0;
    for (size_t i = 0; i < n; i++) {
        PrimHit one;
        RayStats st1;
        memset(&st1, 0, sizeof st1);
        int b = accel_closest(a, &r[i], &one, &st1);
        assert_int_equal(best[i], b);
        if (b >= 0) {
            assert_memory_equal(&h[i], &one, sizeof one);
            hits++;
        }
    }
    assert_true(n == 0 || hits > 0);
    accel_stream_free(s);
    free(h);
    free(best);
    return sorted;
}

static void test_scattered_rays_sorted_answer_as_one_by_one(void **state)
{
    (void)state;
    unsigned long long g = 0x5eedULL;
    Scene sc;
    Accel *a = soup_accel(&sc, 3000, 2, &g);
    Ray *r = scattered(MANY, 6.0f, &g);
    assert_int_equal(check_stream(a, r, MANY, MANY), 1);
    accel_free(a);
    free(r);
    free(sc.prims);
}

static void test_coherent_rays_keep_their_order(void **state)
{
    (void)state;
    unsigned long long g = 0xc0ffeeULL;
    Scene sc;
    Accel *a = soup_accel(&sc, 3000, 0, &g);
    /* a camera's rays: one origin, directions in scanline order */
    Ray *r = malloc(MANY * sizeof *r);
    assert_non_null(r);
    for (int i = 0; i < MANY; i++) {
        float x = (float)(i % 200) / 100.0f - 1.0f, y = (float)(i / 200) / 100.0f - 1.0f;
        r[i] = ray_make(vec3(0.5f, 0.25f, 9.0f), vec_normalize(vec3(x, y, -2.0f)), INFINITY);
    }
    assert_int_equal(check_stream(a, r, MANY, MANY), 0);
    accel_free(a);
    free(r);
    free(sc.prims);
}

static void test_cheap_small_and_unbounded_batches_keep_their_order(void **state)
{
    (void)state;
    unsigned long long g = 0xfeedULL;
    Scene sc;
    Accel *a = soup_accel(&sc, 3000, 0, &g);
    Ray *r = scattered(MANY, 6.0f, &g);
    /* rays from all around the scene, leaving it: too few tests a ray for
     * a sort to pay (and one ray in MANY / 2 turned back, to hit) */
    Ray *away = malloc(MANY * sizeof *away);
    assert_non_null(away);
    for (int i = 0; i < MANY; i++) {
        Vec3 u = vec_normalize(test_rvec(&g, -1, 1));
        away[i] = ray_make(vec_scale(u, 12.0f), i % (MANY / 2) ? u : vec_neg(u), INFINITY);
    }
    assert_int_equal(check_stream(a, away, MANY, MANY), 0);
    free(away);
    assert_int_equal(check_stream(a, r, 1000, MANY), 0);       /* too few rays */
    assert_int_equal(check_stream(a, r, MANY, MANY - 1), 0);   /* more than the room */
    assert_int_equal(check_stream(a, r, MANY, MANY), 1);       /* the same rays, sorted */
    assert_int_equal(check_stream(a, r, 0, 0), 0);
    accel_free(a);
    free(sc.prims);

    /* planes alone: tests enough, but no box to sort in */
    a = soup_accel(&sc, 0, 8, &g);
    assert_int_equal(check_stream(a, r, MANY, MANY), 0);
    accel_free(a);
    free(sc.prims);
    free(r);
}

static void test_stream_room_limits(void **state)
{
    (void)state;
    assert_null(accel_stream_new(ACCEL_STREAM_MAX + 1));
    AccelStream *s = accel_stream_new(0);
    assert_non_null(s);
    accel_stream_free(s);
    accel_stream_free(NULL);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_scattered_rays_sorted_answer_as_one_by_one),
        cmocka_unit_test(test_coherent_rays_keep_their_order),
        cmocka_unit_test(test_cheap_small_and_unbounded_batches_keep_their_order),
        cmocka_unit_test(test_stream_room_limits),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
