/* Tests for src/cli/bench.c: the generated rays and the timed passes. */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>

#include "../src/cli/bench.h"

/* A scene of one sphere (and one default material). */
static void one_sphere(Scene *s, Vec3 c, float r)
{
    memset(s, 0, sizeof *s);
    s->prims = calloc(1, sizeof(Prim));
    s->materials = calloc(1, sizeof(Material));
    assert_non_null(s->prims);
    assert_non_null(s->materials);
    s->nprims = s->nmaterials = 1;
    s->prims[0].kind = PRIM_SPHERE;
    s->prims[0].g.sphere.c = c;
    s->prims[0].g.sphere.r = r;
}

static void test_rays_and_passes(void **state)
{
    (void)state;
    /* one unit sphere: framed by the camera, every hit has a normal */
    Scene s;
    one_sphere(&s, vec3(0, 0, 0), 1.0f);
    Accel *a = accel_build(&s, PRIM_ROBUST, 1);
    assert_non_null(a);
    RaySet p, sh, d;
    assert_int_equal(bench_gen_rays(&s, a, 32, 24, 0, 7, &p, &sh, &d), 0);
    assert_int_equal(p.n, 32 * 24);
    /* one shadow and one diffuse ray per primary hit */
    BenchResult r;
    bench_trace(a, p.rays, p.n, BENCH_CLOSEST, 1, &r);
    assert_true(r.hits > p.n / 10 && r.hits < p.n);
    assert_int_equal(sh.n, r.hits);
    assert_int_equal(d.n, r.hits);
    assert_true(r.sumt > 0 && r.mrays > 0);
    BenchResult r0 = r;
    /* one pass counts the hits and sums their t as bench_trace does */
    size_t hits;
    double sumt;
    assert_true(bench_pass(a, p.rays, p.n, 0, &hits, &sumt) >= 0.0);
    assert_int_equal(hits, r.hits);
    assert_true(sumt == r.sumt);
    for (size_t i = 0; i < d.n; i++) {
        /* secondary rays start strictly outside the sphere, and diffuse ones
         * leave it (the hemisphere of the outward normal) */
        Vec3 o = d.rays[i].o;
        assert_true(vec_dot(o, o) > 1.0f);
        assert_true(vec_dot(d.rays[i].d, o) > 0.0f);
        /* a shadow ray starts on the side it leaves to: outside towards a
         * light in front, inside towards one behind (it then hits the sphere) */
        Vec3 so = sh.rays[i].o;
        assert_true((vec_dot(so, so) > 1.0f) == (vec_dot(sh.rays[i].d, so) > 0.0f));
    }
    /* so none of them hits the sphere again */
    bench_trace(a, d.rays, d.n, BENCH_CLOSEST, 1, &r);
    assert_int_equal(r.hits, 0);
    bench_trace(a, sh.rays, sh.n, BENCH_ANY, 1, &r);
    assert_true(r.hits < sh.n); /* the light is outside: most shadow rays are clear */
    /* in packets: the same hits, the same sum of t */
    assert_true(bench_pass_packet(a, p.rays, p.n, &hits, &sumt) >= 0.0);
    assert_int_equal(hits, r0.hits);
    assert_true(sumt == r0.sumt);
    bench_free(&p);
    bench_free(&sh);
    bench_free(&d);
    assert_null(p.rays);
    accel_free(a);
    scene_free(&s);
}

/* A tight framing of a sphere seen from afar: the loose one misses most
 * rays, the tight one hits at least BENCH_TIGHT_HITS of them. */
static void test_tight_framing(void **state)
{
    (void)state;
    Scene s;
    one_sphere(&s, vec3(5, -2, 7), 0.5f);
    Accel *a = accel_build(&s, PRIM_ROBUST, 1);
    assert_non_null(a);
    for (int tight = 0; tight < 2; tight++) {
        RaySet p, sh, d;
        assert_int_equal(bench_gen_rays(&s, a, 64, 48, tight, 3, &p, &sh, &d), 0);
        assert_int_equal(p.n, 64 * 48);
        if (tight)
            assert_true(sh.n >= BENCH_TIGHT_HITS * p.n);
        else
            assert_true(sh.n > 0 && sh.n < 0.5 * p.n);
        bench_free(&p);
        bench_free(&sh);
        bench_free(&d);
    }
    accel_free(a);
    scene_free(&s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_rays_and_passes),
        cmocka_unit_test(test_tight_framing),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
