/* Tests for plan.c: the settings the plan resolves from the scene and the
 * options, the coordinates it puts the scene in, and the decisions it
 * derives (camera interiors, transparency, reflection, shadow modes). */
#include <math.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <stdio.h>
#include <string.h>
#include <cmocka.h>

#include "testutil.h"

#include "lancer/accel.h"
#include "lancer/image.h"
#include "lancer/plan.h"
#include "lancer/render.h"

static const char *base =
    "image { width 200 height 100 spp 2 max_depth 4 }\n"
    "camera { eye 1 2 -8 target 1 2 0 fov 40 }\n"
    "light { position 3 4 -5 }\n"
    "light { position 0 9 0 shadowless }\n"
    "light { position 0 9 9 area_u 1 0 0 area_v 0 0 1 area_samples 3 2 }\n"
    "material m { }\n"
    "sphere { center 1 2 -8 radius 0.5 material m }\n"
    "box { min -1 -1 -1 max 1 1 1 material m }\n"
    "plane { normal 0 1 0 offset -2 material m }\n";

/* The base scene plus `extra`, parsed. */
static void load(Scene *s, const char *extra)
{
    char text[2048], err[512];
    snprintf(text, sizeof text, "%s%s", base, extra);
    int rc = scene_parse("t.scn", text, strlen(text), s, err, sizeof err);
    if (rc)
        print_error("%s\n", err);
    assert_int_equal(rc, 0);
}

static void build_ok(RenderPlan *p, Scene *s, const PlanOptions *o)
{
    char err[256];
    int rc = plan_build(p, s, o, err, sizeof err);
    if (rc)
        print_error("%s\n", err);
    assert_int_equal(rc, 0);
}

/* The base scene plus `extra`, and its plan for options o. */
static void load_plan(Scene *s, RenderPlan *p, const char *extra, const PlanOptions *o)
{
    load(s, extra);
    build_ok(p, s, o);
}

static void done(Scene *s, RenderPlan *p)
{
    plan_free(p);
    scene_free(s);
}

static void test_settings(void **state)
{
    (void)state;
    Scene s;
    RenderPlan p;
    PlanOptions o = plan_options();
    /* the scene's own settings */
    load_plan(&s, &p, "", &o);
    assert_int_equal(p.width, 200);
    assert_int_equal(p.height, 100);
    assert_int_equal(p.spp, 2);
    assert_int_equal(p.max_depth, 4);
    assert_int_equal(p.threads, 1);
    assert_int_equal(p.variant, PRIM_ROBUST);
    assert_ptr_equal(p.scene, &s);
    done(&s, &p);
    /* each option that is set wins */
    load(&s, "");
    o.width = 33;
    o.height = 44;
    o.spp = 5;
    o.threads = 3;
    o.classic = 1;
    build_ok(&p, &s, &o);
    assert_int_equal(p.width, 33);
    assert_int_equal(p.height, 44);
    assert_int_equal(p.spp, 5);
    assert_int_equal(p.threads, 3);
    assert_int_equal(p.variant, PRIM_CLASSIC);
    done(&s, &p);
    /* the scene's intersect setting */
    load(&s, "");
    s.image.classic = 1;
    o = plan_options();
    build_ok(&p, &s, &o);
    assert_int_equal(p.variant, PRIM_CLASSIC);
    done(&s, &p);
}

/* Each area light's samples, in the plan's coordinates: POV-Ray's grid
 * with its corners at the position plus or minus half of each axis, and
 * the weights of the plain average (area_samples 3 2: 1/4, 1/2, 1/4
 * times 1/2, 1/2). Point lights have none; --area-samples resizes them. */
static void test_area_samples(void **state)
{
    (void)state;
    Scene s;
    RenderPlan p;
    PlanOptions o = plan_options();
    o.world = 1;
    load_plan(&s, &p, "", &o);
    assert_null(p.area[0].point);
    assert_null(p.area[1].point);
    const PlanArea *a = &p.area[2];
    const float x[3] = {-0.5f, 0.0f, 0.5f}, z[2] = {9.0f - 0.5f, 9.0f + 0.5f}, wx[3] = {0.25f, 0.5f, 0.25f};
    for (int j = 0; j < 2; j++)
        for (int i = 0; i < 3; i++) {
            Vec3 q = a->point[j * 3 + i];
            assert_float_equal(q.x, x[i], 0);
            assert_float_equal(q.y, 9.0f, 0);
            assert_float_equal(q.z, z[j], 0);
            assert_float_equal(a->weight[j * 3 + i], wx[i] * 0.5f, 0);
        }
    done(&s, &p);
    o.area_samples = 5;
    load_plan(&s, &p, "", &o);
    assert_float_equal(p.area[2].point[24].x, 0.5f, 0);
    assert_float_equal(p.area[2].weight[24], 0.125f * 0.125f, 0);
    done(&s, &p);
}

/* The samples an adaptive light traces at every point: the corners of the
 * cells it splits for its level alone, worked out by hand from POV-Ray's
 * split at the floor and the ceiling of the middle; every sample when the
 * light is not adaptive. */
static void test_area_first(void **state)
{
    (void)state;
    static const struct {
        int n1, n2, adaptive, n;
        int first[24];
    } cases[] = {
        {3, 2, 0, 6, {0, 1, 2, 3, 4, 5}},
        {9, 9, 1, 4, {0, 8, 72, 80}},                       /* POV-Ray's adaptive 0: the corners */
        {5, 5, 2, 9, {0, 2, 4, 10, 12, 14, 20, 22, 24}},    /* adaptive 1: split at 2 */
        {6, 4, 2, 16, {0, 2, 3, 5, 6, 8, 9, 11, 12, 14, 15, 17, 18, 20, 21, 23}}, /* at 2 | 3 and 1 | 2 */
        {6, 4, 3, 24, {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16, 17, 18, 19, 20, 21, 22, 23}},
        {2, 2, 17, 4, {0, 1, 2, 3}},                        /* one cell, one sample wide */
        {1, 5, 2, 3, {0, 2, 4}},                            /* a line of samples */
    };
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        int first[LIMIT_AREA_SAMPLES * LIMIT_AREA_SAMPLES];
        assert_int_equal(plan_area_first(cases[c].n1, cases[c].n2, cases[c].adaptive, first), cases[c].n);
        for (int k = 0; k < cases[c].n; k++)
            assert_int_equal(first[k], cases[c].first[k]);
    }
    /* the largest grid at the deepest level: every sample, once */
    int first[LIMIT_AREA_SAMPLES * LIMIT_AREA_SAMPLES];
    assert_int_equal(plan_area_first(LIMIT_AREA_SAMPLES, LIMIT_AREA_SAMPLES, LIMIT_AREA_ADAPTIVE + 1, first),
                     LIMIT_AREA_SAMPLES * LIMIT_AREA_SAMPLES);
    for (int k = 0; k < LIMIT_AREA_SAMPLES * LIMIT_AREA_SAMPLES; k++)
        assert_int_equal(first[k], k);
}

static void test_errors(void **state)
{
    (void)state;
    Scene s;
    RenderPlan p;
    char err[256];
    PlanOptions o = plan_options();
    load(&s, "");
    o.width = LIMIT_IMAGE_SIDE;
    o.height = LIMIT_IMAGE_SIDE;
    assert_int_equal(plan_build(&p, &s, &o, err, sizeof err), -1);
    assert_string_equal(err, "a 32768x32768 image has more than the 268435456 pixels lancer renders");
    o = plan_options();
    o.spp = LIMIT_SPP + 1;
    assert_int_equal(plan_build(&p, &s, &o, err, sizeof err), -1);
    assert_string_equal(err, "spp must be a whole number from 1 to 16");
    o = plan_options();
    o.move = 1;
    o.translate[1] = INFINITY;
    assert_int_equal(plan_build(&p, &s, &o, err, sizeof err), -1);
    assert_string_equal(err, "the scene degenerates at that scale or offset");
    o.translate[1] = 0;
    o.scale = 0;
    assert_int_equal(plan_build(&p, &s, &o, err, sizeof err), -1);
    scene_free(&s);
    /* an oriented box too thin for float once scaled down */
    load(&s, "obox { center 0 0 0 u 1e-10 0 0 v 0 1e-10 0 w 0 0 1e-10 material m }\n");
    o = plan_options();
    o.move = 1;
    o.scale = 1e-30;
    assert_int_equal(plan_build(&p, &s, &o, err, sizeof err), -1);
    assert_string_equal(err, "the scene degenerates at that scale or offset");
    scene_free(&s);
    /* --area-samples over lights the scene kept within LIMIT_LIGHT_SAMPLES:
     * 300 area lights of 2 x 2 samples, at 64 a side 1,228,800, and 1,100
     * of them 4,505,600, past it, before the plan's tables take 88 MB */
    for (int n = 300; n <= 1100; n += 800) {
        static char text[1200 * 80];
        int len = snprintf(text, sizeof text, "%s", base);
        for (int i = 0; i < n; i++)
            len += snprintf(text + len, sizeof text - (size_t)len,
                            "light { position %d 9 0 area_u 1 0 0 area_v 0 0 1 area_samples 2 2 }\n", i);
        assert_int_equal(scene_parse("t.scn", text, (size_t)len, &s, err, sizeof err), 0);
        o = plan_options();
        o.area_samples = LIMIT_AREA_SAMPLES;
        if (n == 300) {
            build_ok(&p, &s, &o);
            plan_free(&p);
        } else {
            assert_int_equal(plan_build(&p, &s, &o, err, sizeof err), -1);
            assert_string_equal(err, "64 area samples a side would give the lights 4509698 samples, more than 4194304 in all");
        }
        scene_free(&s);
    }
}

/* A unit sphere flattened to a disk by `scale 1 1 F`, seen from k times
 * (0.3, 0.2, -3): a hair flatter than PLAN_FLATTEST, seen from there, is
 * refused at its statement; a hair less flat, the robust routine hits it
 * on a grid of rays across the disk and on rings next to its rim, at the
 * disk. */
static void test_flattest(void **state)
{
    (void)state;
    static const double ks[] = {1, 10, 100, 1000};
    for (size_t i = 0; i < sizeof ks / sizeof ks[0]; i++) {
        double k = ks[i], eye[3] = {0.3 * k, 0.2 * k, -3 * k};
        double dist = sqrt(eye[0] * eye[0] + eye[1] * eye[1] + eye[2] * eye[2]);
        for (int ok = 0; ok < 2; ok++) {
            /* the thinnest half-axis is F, the largest 1 */
            double f = (ok ? 1.001 : 0.999) * PLAN_FLATTEST * (dist + 1.0);
            char text[512], err[256];
            snprintf(text, sizeof text,
                     "camera { eye %.17g %.17g %.17g target 0 0 0 fov 40 }\nmaterial m { }\n"
                     "sphere { center 0 0 0 radius 1 scale 1 1 %.17g material m }\n",
                     eye[0], eye[1], eye[2], f);
            Scene s;
            RenderPlan p;
            PlanOptions o = plan_options();
            assert_int_equal(scene_parse("t.scn", text, strlen(text), &s, err, sizeof err), 0);
            int rc = plan_build(&p, &s, &o, err, sizeof err);
            if (!ok) {
                assert_int_equal(rc, -2);
                assert_true(strncmp(err, "3:1: sphere: too flat to trace from this camera", 47) == 0);
                scene_free(&s);
                continue;
            }
            assert_int_equal(rc, 0);
            int missed = 0; /* a grid over the disk, and rings close to its rim, where it is thinnest */
            for (int a = -10; a <= 10; a++)
                for (int b = -10; b <= 10 + 3 * 64; b++) {
                    double x = a * 0.095, y = b * 0.095;
                    if (b > 10) {
                        double rho = 1.0 - 0.001 / (double)(1 + (b - 11) / 64), phi = (b - 11) % 64 * (3.14159265358979323846 / 32);
                        x = rho * cos(phi);
                        y = rho * sin(phi);
                        if (a != 0)
                            continue;
                    } else if (x * x + y * y > 0.95 * 0.95) {
                        continue;
                    }
                    Vec3 rel = vec3((float)(x - eye[0]), (float)(y - eye[1]), (float)-eye[2]);
                    Ray r = {vec3(0, 0, 0), vec_normalize(rel), INFINITY};
                    PrimHit h;
                    missed += !prim_intersect(&s.prims[0], &r, PRIM_ROBUST, &h) ||
                              !(fabsf(h.t - vec_length(rel)) <= 1e-5f * vec_length(rel));
                }
            assert_int_equal(missed, 0);
            done(&s, &p);
        }
    }
    /* turned and stretched to half-axes 3, 2 and F: the bound reads the
     * true thinnest and largest half-axes, whatever the turn */
    for (int ok = 0; ok < 2; ok++) {
        double f = (ok ? 1.001 : 0.999) * PLAN_FLATTEST * (sqrt(9.13) + 3.0);
        char text[512], err[256];
        snprintf(text, sizeof text,
                 "camera { eye 0.3 0.2 -3 target 0 0 0 fov 40 }\nmaterial m { }\n"
                 "sphere { center 0 0 0 radius 1 scale 3 2 %.17g rotate 30 40 50 material m }\n",
                 f);
        Scene s;
        RenderPlan p;
        PlanOptions o = plan_options();
        assert_int_equal(scene_parse("t.scn", text, strlen(text), &s, err, sizeof err), 0);
        int rc = plan_build(&p, &s, &o, err, sizeof err);
        assert_int_equal(rc, ok ? 0 : -2);
        if (ok)
            plan_free(&p);
        scene_free(&s);
    }
}

static void assert_offset(const RenderPlan *p, double x, double y, double z)
{
    assert_true(p->offset[0] == x && p->offset[1] == y && p->offset[2] == z);
}

/* Robust plans put the eye at the origin and keep the offset; classic
 * plans and world plans keep the scene's coordinates. */
static void test_coordinates(void **state)
{
    (void)state;
    Scene s;
    RenderPlan p;
    PlanOptions o = plan_options();
    load_plan(&s, &p, "", &o);
    assert_offset(&p, 1, 2, -8);
    assert_vec(s.camera.eye, 0, 0, 0, 0);
    assert_vec(s.camera.target, 0, 0, 8, 0);
    assert_vec(s.lights[0].pos, 2, 2, 3, 0);
    assert_vec(s.prims[0].g.sphere.c, 0, 0, 0, 0);
    assert_vec(s.prims[1].g.box.lo, -2, -3, 7, 0);
    assert_float_equal(s.prims[2].g.plane.d, -4, 0); /* y = -2 moves to y = -4 */
    done(&s, &p);

    for (int k = 0; k < 2; k++) { /* classic, then robust in world coordinates */
        o = plan_options();
        o.classic = k == 0;
        o.world = k == 1;
        load_plan(&s, &p, "", &o);
        assert_offset(&p, 0, 0, 0);
        assert_vec(s.camera.eye, 1, 2, -8, 0);
        done(&s, &p);
    }

    /* the options' move first, then camera-relative: p -> 2p + (10, 0, 0), less the moved eye (12, 4, -16) */
    o = plan_options();
    o.move = 1;
    o.scale = 2;
    o.translate[0] = 10;
    load_plan(&s, &p, "", &o);
    assert_offset(&p, 12, 4, -16);
    assert_vec(s.camera.eye, 0, 0, 0, 0);
    assert_vec(s.lights[0].pos, 4, 4, 6, 0);
    assert_float_equal(s.prims[0].g.sphere.r, 1, 0);
    done(&s, &p);
}

/* --pn-mode overrides every patch's mode; the robust variant traces every
 * patch exact, one that asks for fast mode too, and the classic variant
 * traces them all fast; the plan counts them. */
static void test_pn_modes(void **state)
{
    (void)state;
    static const char *pn = "pn_triangle { a 0 0 0 b 1 0 0 c 0 1 0 na 0 0 1 nb 0 0 1 nc 0 0 1 material m }\n"
                            "pn_triangle { a 0 0 0 b 1 0 0 c 0 1 0 na 0 0 1 nb 0 0 1 nc 0 0 1 material m "
                            "pn_mode fast }\n";
    Scene s;
    RenderPlan p;
    PlanOptions o = plan_options();
    load_plan(&s, &p, pn, &o);
    assert_int_equal(s.prims[4].g.pn.mode, PN_FAST); /* asked for */
    assert_int_equal(p.patches[PN_EXACT], 2);        /* traced */
    assert_int_equal(p.patches[PN_FAST], 0);
    done(&s, &p);
    o.pn_mode = 1 + PN_FAST;
    load_plan(&s, &p, pn, &o);
    assert_int_equal(s.prims[3].g.pn.mode, PN_FAST);
    assert_int_equal(p.patches[PN_EXACT], 2);
    done(&s, &p);
    o.pn_mode = 1 + PN_EXACT;
    load_plan(&s, &p, pn, &o);
    assert_int_equal(p.patches[PN_EXACT], 2);
    assert_int_equal(s.prims[4].g.pn.mode, PN_EXACT);
    done(&s, &p);
    o = plan_options();
    o.classic = 1;
    load_plan(&s, &p, pn, &o);
    assert_int_equal(p.patches[PN_FAST], 2);
    done(&s, &p);
    o = plan_options();
    o.pn_mode = 3;
    load(&s, pn);
    char err[256];
    assert_int_equal(plan_build(&p, &s, &o, err, sizeof err), -1);
    assert_string_equal(err, "pn_mode out of range");
    scene_free(&s);
}

static void test_decisions(void **state)
{
    (void)state;
    Scene s;
    RenderPlan p;
    PlanOptions o = plan_options();
    /* opaque, no mirror: any-hit shadows for the lights that cast them */
    load_plan(&s, &p, "", &o);
    assert_false(p.transparent);
    assert_false(p.reflective);
    assert_int_equal(p.shadow[0], PLAN_SHADOW_OPAQUE);
    assert_int_equal(p.shadow[1], PLAN_SHADOW_NONE);
    assert_int_equal(p.shadow[2], PLAN_SHADOW_OPAQUE);
    /* the camera sits inside the sphere, but only refraction reads that */
    assert_int_equal(p.camera_in.n, 0);
    plan_free(&p);
    assert_null(p.shadow);
    scene_free(&s);

    /* a glass material anywhere: shadows are filtered, through every surface */
    load_plan(&s, &p, "material g { filter 0.5 }\nmaterial r { reflection 0.1 }\n", &o);
    assert_true(p.transparent);
    assert_true(p.reflective);
    assert_int_equal(p.shadow[0], PLAN_SHADOW_FILTERED);
    assert_int_equal(p.shadow[1], PLAN_SHADOW_NONE);
    assert_int_equal(p.shadow[2], PLAN_SHADOW_FILTERED);
    /* the camera sits at the sphere's centre, inside it, and outside the box */
    assert_int_equal(p.camera_in.n, 1);
    assert_int_equal(p.camera_in.prim[0], 0);
    done(&s, &p);

    /* nested solids, outermost first, and none: a scene without lights */
    const char *nested = "camera { eye 0 0 0 target 0 0 1 fov 40 }\nmaterial m { transmit 0.5 }\n"
                         "sphere { center 0 0 0 radius 2 material m }\n"
                         "sphere { center 5 0 0 radius 1 material m }\n"
                         "obox { center 0 0 0.5 u 1 0 0 v 0 1 0 w 0 0 1 material m }\n";
    char err[256];
    assert_int_equal(scene_parse("n.scn", nested, strlen(nested), &s, err, sizeof err), 0);
    build_ok(&p, &s, &o);
    assert_int_equal(p.camera_in.n, 2);
    assert_int_equal(p.camera_in.prim[0], 0);
    assert_int_equal(p.camera_in.prim[1], 2);
    assert_null(p.shadow);
    done(&s, &p);
    /* the inner solid written first: still the last, the medium at the eye */
    const char *inner_first = "camera { eye 0 0 0 target 0 0 1 fov 40 }\nmaterial m { transmit 0.5 }\n"
                              "sphere { center 0 0 0.2 radius 0.5 scale 1 1 2 material m }\n"
                              "box { min -3 -3 -3 max 3 3 3 material m }\n"
                              "sphere { center 0 0 0 radius 2 material m }\n";
    assert_int_equal(scene_parse("n.scn", inner_first, strlen(inner_first), &s, err, sizeof err), 0);
    build_ok(&p, &s, &o);
    assert_int_equal(p.camera_in.n, 3);
    assert_int_equal(p.camera_in.prim[0], 1);
    assert_int_equal(p.camera_in.prim[1], 2);
    assert_int_equal(p.camera_in.prim[2], 0);
    assert_int_equal(p.camera_in_lost, 0);
    done(&s, &p);

    /* inside 18 nested balls, written inner first: the 16 innermost are
     * kept, outermost first, and the two outermost left out and counted */
    char text[2048];
    int len = snprintf(text, sizeof text, "camera { eye 0 0 0 target 0 0 1 fov 40 }\nmaterial m { transmit 0.5 }\n");
    for (int i = 0; i < LIMIT_INTERIORS + 2; i++)
        len += snprintf(text + len, sizeof text - (size_t)len, "sphere { center 0 0 0 radius %d material m }\n", i + 1);
    assert_int_equal(scene_parse("n.scn", text, (size_t)len, &s, err, sizeof err), 0);
    build_ok(&p, &s, &o);
    assert_int_equal(p.camera_in.n, LIMIT_INTERIORS);
    assert_int_equal(p.camera_in_lost, 2);
    for (int i = 0; i < LIMIT_INTERIORS; i++)
        assert_int_equal(p.camera_in.prim[i], LIMIT_INTERIORS - 1 - i);
    done(&s, &p);
}

/* Renders scene text at 40 x 30, with --no-plan when full, into *img (NULL:
 * freed), and returns the rays traced and the light's plan in *shadow. */
static RayStats rays_of(const char *text, int full, Image *img, PlanShadow *shadow)
{
    Scene s;
    RenderPlan p;
    char err[512];
    assert_int_equal(scene_parse("t.scn", text, strlen(text), &s, err, sizeof err), 0);
    PlanOptions o = plan_options();
    o.width = 40;
    o.height = 30;
    o.full = full;
    build_ok(&p, &s, &o);
    if (shadow)
        *shadow = p.shadow[0];
    Accel *a = accel_build(&s, p.variant, 1);
    assert_non_null(a);
    Image own;
    Image *im = img ? img : &own;
    assert_int_equal(image_init(im, p.width, p.height), 0);
    RayStats st = {0};
    assert_int_equal(render_image(&p, a, NULL, im, &st), 0);
    if (!img)
        image_free(im);
    accel_free(a);
    done(&s, &p);
    return st;
}

#define SKY "camera { eye 0 2 -6 target 0 0.5 0 fov 50 }\n"

/* The plan's skips, counted in rays: each scene below traces none of the
 * kind it does not need, and with --no-plan traces them, to the same
 * picture bit for bit. */
static void test_skips(void **state)
{
    (void)state;
    static const struct {
        const char *text;
        int shadow, reflection, refraction; /* rays expected: 0 none, 1 some */
        PlanShadow mode;
    } cases[] = {
        /* diffuse only: no reflection or refraction rays */
        {SKY "light { position 2 6 -3 }\nmaterial m { }\nplane { normal 0 1 0 material m }\n"
             "sphere { center 0 1 0 radius 1 material m }\n",
         1, 0, 0, PLAN_SHADOW_OPAQUE},
        /* every light shadowless: no shadow rays */
        {SKY "light { position 2 6 -3 shadowless }\nlight { position -2 6 -3 shadowless }\nmaterial m { }\n"
             "plane { normal 0 1 0 material m }\nsphere { center 0 1 0 radius 1 material m }\n",
         0, 0, 0, PLAN_SHADOW_NONE},
        /* a plane lit from above, and nothing else */
        {SKY "light { position 1 5 -2 }\nmaterial m { }\nplane { normal 0 1 0 material m }\n", 0, 0, 0,
         PLAN_SHADOW_CLEAR},
        /* a lone convex solid cannot shadow itself from a point light */
        {SKY "light { position 1 5 -2 }\nmaterial m { reflection 0.3 }\n"
             "sphere { center 0 1 0 radius 1 scale 1 0.5 1 material m }\n",
         0, 1, 0, PLAN_SHADOW_CLEAR},
        /* a floor, and a box above the light: out of the way of every ray from the floor */
        {SKY "light { position 1 5 -2 }\nmaterial m { }\nplane { normal 0 1 0 material m }\n"
             "box { min -1 6 -1 max 1 7 1 material m }\n",
         0, 0, 0, PLAN_SHADOW_CLEAR},
        /* a box under the floor: the floor shadows it */
        {SKY "light { position 1 5 -2 }\nmaterial m { }\nplane { normal 0 1 0 material m }\n"
             "box { min -1 -3 -1 max 1 -1 1 material m }\n",
         1, 0, 0, PLAN_SHADOW_OPAQUE},
        /* the same box on the floor can shadow it */
        {SKY "light { position 1 5 -2 }\nmaterial m { }\nplane { normal 0 1 0 material m }\n"
             "box { min -1 0 -1 max 1 1 1 material m }\n",
         1, 0, 0, PLAN_SHADOW_OPAQUE},
        /* an area light: a solid shadows itself from part of it */
        {SKY "light { position 1 5 -2 area_u 4 0 0 area_v 0 0 4 area_samples 3 3 }\nmaterial m { }\n"
             "sphere { center 0 1 0 radius 1 material m }\n",
         1, 0, 0, PLAN_SHADOW_OPAQUE},
        /* a solid seen from inside shadows its own far wall, whose normal
         * turns to the ray and faces the light: the camera inside an opaque
         * sphere or box, and a lone glass ball (the plan once called these
         * lights clear, and every pixel inside the sphere differed) */
        {"camera { eye 0 0 0 target 0 0 1 fov 90 }\nlight { position 0 0 -5 }\nmaterial m { }\n"
         "sphere { center 0 0 0 radius 2 material m }\n",
         1, 0, 0, PLAN_SHADOW_OPAQUE},
        {"camera { eye 0 0 0 target 0 0 1 fov 90 }\nlight { position 0.5 0.3 -5 }\nmaterial m { }\n"
         "box { min -2 -2 -2 max 2 2 2 material m }\n",
         1, 0, 0, PLAN_SHADOW_OPAQUE},
        {SKY "light { position 3 4 -2 }\nmaterial g { diffuse 0.2 transmit 0.7 ior 1.5 }\n"
             "sphere { center 0 1 0 radius 1 material g }\n",
         1, 0, 1, PLAN_SHADOW_FILTERED},
        /* and a lone ball that filters (filter, no transmit) */
        {SKY "light { position 3 4 -2 }\nmaterial g { color 1 0.2 0.2 ambient 0 diffuse 1 filter 0.8 ior 1 }\n"
             "sphere { center 0 1 0 radius 1 material g }\n",
         1, 0, 1, PLAN_SHADOW_FILTERED},
        /* two mirrors face each other at depth 256 and adc_bailout 0: the
         * weight, 0.1 a bounce, underflows long before the last level, and
         * every ray is traced all the same (the plan once took a weight of
         * 0 for a coefficient of 0, skipped them, and lost the bright sky's
         * last 1e-38s where --no-plan kept them) */
        {"image { background 3e38 3e38 3e38 max_depth 256 adc_bailout 0 }\n"
         "camera { eye 0 0 0 target 0.45 0 1 fov 20 }\nlight { position 0 5 0 shadowless }\n"
         "material mir { ambient 0 diffuse 0 reflection 0.1 }\n"
         "triangle { a 1 -50 -1 b 1 50 -1 c 1 0 400 material mir }\n"
         "triangle { a -1 -50 -1 b -1 50 -1 c -1 0 400 material mir }\n",
         0, 1, 0, PLAN_SHADOW_NONE},
        /* a light so bright that its highlights are infinite: --no-plan's
         * mirror rays of coefficient 0 add nothing, not 0 times infinity */
        {SKY "light { position 2 5 -3 color 3e38 3e38 3e38 }\n"
             "material m { ambient 0 diffuse 1 phong 1 phong_size 1 }\n"
             "sphere { center 0 0 0 radius 1 material m }\nsphere { center 2.5 0 0 radius 1 material m }\n",
         1, 0, 0, PLAN_SHADOW_OPAQUE},
        /* glass: refraction rays, and shadows filtered */
        {SKY "light { position 1 5 -2 }\nmaterial g { transmit 0.8 ior 1.5 }\nmaterial m { }\n"
             "plane { normal 0 1 0 material m }\nsphere { center 0 1 0 radius 1 material g }\n",
         1, 0, 1, PLAN_SHADOW_FILTERED},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        Image a, b;
        PlanShadow mode;
        RayStats st = rays_of(cases[i].text, 0, &a, &mode);
        RayStats full = rays_of(cases[i].text, 1, &b, NULL);
        if ((st.shadow > 0) != cases[i].shadow || (st.reflection > 0) != cases[i].reflection ||
            (st.refraction > 0) != cases[i].refraction || mode != cases[i].mode)
            fail_msg("case %zu: %llu shadow, %llu reflection, %llu refraction rays, plan %d", i, st.shadow,
                     st.reflection, st.refraction, (int)mode);
        /* --no-plan does the work, and draws the same picture */
        assert_true(full.reflection > 0 && full.refraction > 0);
        assert_true(full.shadow >= st.shadow);
        if (mode == PLAN_SHADOW_CLEAR)
            assert_true(full.shadow > 0);
        if (strstr(cases[i].text, "adc_bailout 0 ")) /* the mirrors: an underflowed weight is no coefficient of 0 */
            assert_true(st.reflection == full.reflection);
        assert_memory_equal(a.rgb, b.rgb, sizeof(float) * 3 * 40 * 30);
        image_free(&a);
        image_free(&b);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_skips),
        cmocka_unit_test(test_settings),
        cmocka_unit_test(test_area_samples),
        cmocka_unit_test(test_area_first),
        cmocka_unit_test(test_errors),
        cmocka_unit_test(test_flattest),
        cmocka_unit_test(test_coordinates),
        cmocka_unit_test(test_decisions),
        cmocka_unit_test(test_pn_modes),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
