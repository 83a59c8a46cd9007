/* Shaded values checked against POV-Ray's classic finish (the formula in
 * docs/povray-rules.md) evaluated by hand: a lit point, fade, a point in
 * shadow, shadowless lights, the phong and specular peaks, one reflection
 * bounce, and the depth limit; and that shading a known first hit
 * (shade_traced) is shade_trace. */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <math.h>
#include <stdio.h>
#include <string.h>
#include <stdlib.h>
#include <unistd.h>
#include <cmocka.h>

#include "testutil.h"

#include "lancer/shade.h"
#include "lancer/stop.h"

static const char *floor_scene =
    "image { background 0.2 0.4 0.6 }\n"
    "camera { eye 0 1 -5 target 0 0 0 fov 40 }\n"
    "material m { color 0.5 0.4 0.3 ambient 0.1 diffuse 0.6 }\n"
    "plane { normal 0 1 0 material m }\n";

/* Parses the floor scene plus `extra` lines. */
static void load(Scene *s, const char *extra)
{
    char text[4096], err[512];
    int len = snprintf(text, sizeof text, "%s%s", floor_scene, extra);
    assert_true(len > 0 && (size_t)len < sizeof text);
    int rc = scene_parse("t.scn", text, strlen(text), s, err, sizeof err);
    if (rc != 0)
        print_error("%s\n", err);
    assert_int_equal(rc, 0);
}

/* The plan for s in its own coordinates, since the tests' rays are in
 * them, and its Accel. */
static Accel *plan_world(RenderPlan *p, Scene *s)
{
    PlanOptions o = plan_options();
    o.world = 1;
    char err[256];
    assert_int_equal(plan_build(p, s, &o, err, sizeof err), 0);
    Accel *a = accel_build(s, p->variant, 1);
    assert_non_null(a);
    return a;
}

/* The colour seen along the ray from o towards d, the camera's ray. */
static Vec3 trace(Scene *s, Vec3 o, Vec3 d)
{
    RenderPlan p;
    Accel *a = plan_world(&p, s);
    RayStats st;
    memset(&st, 0, sizeof st);
    Ray r = ray_make(o, vec_normalize(d), INFINITY);
    Vec3 c = shade_trace(&p, a, &r, &st);
    accel_free(a);
    plan_free(&p);
    return c;
}

/* Every test looks at the origin from (-3, 4, 0): the floor point (0,0,0). */
#define EYE vec3(-3, 4, 0)
#define DIR vec3(3, -4, 0)

static void test_lit_point(void **state)
{
    (void)state;
    Scene s;
    /* light at distance 5, N.L = 0.8: C = P * (0.1 + 0.6 * 0.8) = P * 0.58 */
    load(&s, "light { position 3 4 0 }\n");
    assert_vec(trace(&s, EYE, DIR), 0.5f * 0.58f, 0.4f * 0.58f, 0.3f * 0.58f, 1e-6);
    scene_free(&s);
}

static void test_light_colour_and_fade(void **state)
{
    (void)state;
    Scene s;
    /* att = 2 / (1 + (5/2.5)^2) = 0.4: C = P*0.1 + 0.4 * Lc * P * 0.6 * 0.8 */
    load(&s, "light { position 3 4 0 color 1 0.5 2 fade_distance 2.5 fade_power 2 }\n");
    float k = 0.4f * 0.6f * 0.8f;
    assert_vec(trace(&s, EYE, DIR), 0.5f * (0.1f + k), 0.4f * (0.1f + 0.5f * k), 0.3f * (0.1f + 2 * k), 1e-6);
    scene_free(&s);
}

static void test_point_in_shadow(void **state)
{
    (void)state;
    Scene s;
    /* a sphere on the segment to the light leaves only the ambient term */
    load(&s, "light { position 3 4 0 }\nsphere { center 1.5 2 0 radius 0.5 material m }\n");
    assert_vec(trace(&s, EYE, DIR), 0.05f, 0.04f, 0.03f, 1e-6);
    scene_free(&s);
    /* an occluder beyond the light does not count */
    load(&s, "light { position 3 4 0 }\nsphere { center 6 8 0 radius 1 material m }\n");
    assert_vec(trace(&s, EYE, DIR), 0.5f * 0.58f, 0.4f * 0.58f, 0.3f * 0.58f, 1e-6);
    scene_free(&s);
}

/* How many floor points of a grid, seen from (-3, 2, 0), are not lit in
 * full by the light at (3, 4, 0): P (0.1 + 0.6 N.L), N.L = 4 / |L - p|. */
static int floor_points_in_shadow(Scene *s)
{
    RenderPlan p;
    Accel *a = plan_world(&p, s);
    RayStats st;
    memset(&st, 0, sizeof st);
    int dark = 0;
    for (int i = 0; i <= 60; i++)
        for (int j = 0; j <= 60; j++) {
            Vec3 q = vec3(-1.0f + 0.05f * (float)i, 0.0f, -1.5f + 0.05f * (float)j), eye = vec3(-3, 2, 0);
            Ray r = ray_make(eye, vec_normalize(vec_sub(q, eye)), INFINITY);
            float nl = 4.0f / vec_length(vec_sub(vec3(3, 4, 0), q));
            dark += fabsf(shade_trace(&p, a, &r, &st).x - 0.5f * (0.1f + 0.6f * nl)) > 1e-5f;
        }
    accel_free(a);
    plan_free(&p);
    return dark;
}

static void test_light_on_a_surface(void **state)
{
    (void)state;
    /* A lamp set in the ceiling: the ceiling passes through the light, and
     * a shadow ray's roundings must not decide whether it blocks it (as
     * POV-Ray, which ignores a blocker within 10^-3 of the light). A point
     * light and an area light (every sample on the ceiling), the ceiling
     * opaque and of glass (filtered shadows); the ceiling 0.01 lower hides
     * the light from every point. */
    const char *lights[] = {"light { position 3 4 0 }", "light { position 3 4 0 area_u 0.5 0 0 area_v 0 0 0.5 area_samples 3 3 }"};
    const char *offsets[] = {"4", "3.99"};
    for (int glass = 0; glass < 2; glass++)
        for (int l = 0; l < 2; l++)
            for (int o = 0; o < 2; o++) {
                char extra[512];
                snprintf(extra, sizeof extra,
                         "material g { color 1 1 1 ambient 0 diffuse 0 transmit 0.5 }\n%s\n"
                         "plane { normal 0 1 0 offset %s material %s }\n",
                         lights[l], offsets[o], glass ? "g" : "m");
                Scene s;
                load(&s, extra);
                assert_int_equal(floor_points_in_shadow(&s), o ? 61 * 61 : 0);
                scene_free(&s);
            }
}

static void test_shadowless_light(void **state)
{
    (void)state;
    Scene s;
    /* The eye and the light are mirror images in the floor, so a phong
     * highlight would peak (R.L = 1, +1 in every channel), and the sphere
     * lies on the way to the light: a shadowless light casts no shadow and
     * adds no highlight, but lights diffusely in full. */
    load(&s,
         "material shiny { color 0.5 0.4 0.3 ambient 0.1 diffuse 0.6 phong 1 }\n"
         "light { position 3 4 0 shadowless }\n"
         "sphere { center 1.5 2 0 radius 0.5 material m }\n");
    s.prims[0].material = 1; /* the floor is shiny */
    assert_vec(trace(&s, EYE, DIR), 0.5f * 0.58f, 0.4f * 0.58f, 0.3f * 0.58f, 1e-6);
    /* the same light, casting shadows: the sphere leaves the ambient term */
    s.lights[0].shadowless = 0;
    assert_vec(trace(&s, EYE, DIR), 0.05f, 0.04f, 0.03f, 1e-6);
    /* and without the sphere, the highlight is there */
    s.nprims = 1;
    assert_vec(trace(&s, EYE, DIR), 0.5f * 0.58f + 1, 0.4f * 0.58f + 1, 0.3f * 0.58f + 1, 1e-5);
    scene_free(&s);
}

static void test_phong_and_specular_peaks(void **state)
{
    (void)state;
    Scene s;
    /* The eye at (-3,4,0) and the light at (3,4,0) are mirror images in the
     * floor, so R = L (R.L = 1) and H = N (N.H = 1): both highlights peak,
     * in the light's colour: C = P*0.1 + Lc*(P*0.6*0.8 + phong + specular). */
    load(&s, "material h { color 0.5 0.4 0.3 ambient 0.1 diffuse 0.6 phong 0.25 specular 0.5 }\n"
             "plane { normal 0 1 0 offset 0 material h }\n"
             "light { position 3 4 0 color 1 1 0.5 }\n");
    s.prims[0] = s.prims[1]; /* the floor takes material h */
    s.nprims = 1;
    assert_vec(trace(&s, EYE, DIR), 0.29f + 0.75f, 0.232f + 0.75f, 0.03f + 0.5f * (0.144f + 0.75f), 1e-5);
    /* Off the peak, with the light at (0,5,0): L = (0,1,0), N.L = 1,
     * R = (0.6,0.8,0): R.L = 0.8, phong = 0.25 * 0.8^40;
     * H = normalize(L + V) = normalize(-0.6, 1.8, 0): N.H = 1.8/sqrt(3.6),
     * specular = 0.5 * (N.H)^(1/0.05). */
    s.lights[0].pos = vec3(0, 5, 0);
    s.lights[0].color = vec3(1, 1, 1);
    float hl = 0.25f * powf(0.8f, 40) + 0.5f * powf(1.8f / sqrtf(3.6f), 20);
    assert_vec(trace(&s, EYE, DIR), 0.5f * 0.7f + hl, 0.4f * 0.7f + hl, 0.3f * 0.7f + hl, 1e-5);
    /* and at phong_size 3, where the exponent shows: 0.8^3 (0.8^4 would be
     * 0.026 less) */
    s.materials[s.prims[0].material].phong_size = 3.0f;
    hl = 0.25f * 0.8f * 0.8f * 0.8f + 0.5f * powf(1.8f / sqrtf(3.6f), 20);
    assert_vec(trace(&s, EYE, DIR), 0.5f * 0.7f + hl, 0.4f * 0.7f + hl, 0.3f * 0.7f + hl, 1e-5);
    scene_free(&s);
}

static void test_reflection_bounce(void **state)
{
    (void)state;
    Scene s;
    /* A black mirror floor reflects the ray to (0.6, 0.8, 0), which meets a
     * sphere shaded by its ambient term alone: C = 0.5 * 0.9 * Pq. */
    load(&s, "material mirror { color 0 0 0 ambient 0 diffuse 0 reflection 0.5 }\n"
             "material q { color 1 0.5 0.25 ambient 0.9 diffuse 0 }\n"
             "plane { normal 0 1 0 material mirror }\n"
             "sphere { center 6 8 0 radius 1 material q }\n");
    s.prims[0] = s.prims[1];
    s.prims[1] = s.prims[2];
    s.nprims = 2;
    assert_vec(trace(&s, EYE, DIR), 0.45f, 0.225f, 0.1125f, 1e-6);
    /* aimed elsewhere, the reflected ray meets the background */
    assert_vec(trace(&s, EYE, vec3(3, -4, 3)), 0.1f, 0.2f, 0.3f, 1e-6);
    /* max_depth 1 allows no bounce: the cut ray is black, not background */
    s.image.max_depth = 1;
    assert_vec(trace(&s, EYE, DIR), 0, 0, 0, 0);
    scene_free(&s);
}

static void test_miss_and_depth_limit(void **state)
{
    (void)state;
    Scene s;
    /* A camera ray that meets nothing sees the background, at any depth
     * limit: the camera ray is level 1, within even max_depth 1. */
    load(&s, "");
    assert_vec(trace(&s, EYE, vec3(0, 1, 0)), 0.2f, 0.4f, 0.6f, 0);
    s.image.max_depth = 1;
    assert_vec(trace(&s, EYE, vec3(0, 1, 0)), 0.2f, 0.4f, 0.6f, 0);
    scene_free(&s);
    /* A black mirror floor: its reflected ray meets nothing either. At
     * level 2 it is within max_depth 2 and brings the background; with
     * max_depth 1 it is cut, and a cut ray is black, not background. */
    load(&s, "material mirror { color 0 0 0 ambient 0 diffuse 0 reflection 1 }\n");
    s.prims[0].material = 1;
    s.image.max_depth = 2;
    assert_vec(trace(&s, EYE, DIR), 0.2f, 0.4f, 0.6f, 1e-7);
    s.image.max_depth = 1;
    assert_vec(trace(&s, EYE, DIR), 0, 0, 0, 0);
    scene_free(&s);
}

static void test_light_behind_surface_adds_nothing(void **state)
{
    (void)state;
    Scene s;
    /* The light is just below the floor's horizon: N.L < 0, yet R.L > 0.
     * POV-Ray skips such a light entirely, highlight included. */
    load(&s, "material h { color 0.5 0.4 0.3 ambient 0.1 diffuse 0.6 phong 1 phong_size 1 }\n"
             "plane { normal 0 1 0 material h }\n"
             "light { position 100 -1 0 }\n");
    s.prims[0] = s.prims[1];
    s.nprims = 1;
    assert_vec(trace(&s, EYE, DIR), 0.05f, 0.04f, 0.03f, 1e-7);
    scene_free(&s);
}

static void test_area_weights(void **state)
{
    (void)state;
    /* POV-Ray's recursive halving: a plain mean only for powers of two */
    const float w3[] = {0.25f, 0.5f, 0.25f};
    const float w4[] = {0.25f, 0.25f, 0.25f, 0.25f};
    const float w5[] = {0.125f, 0.25f, 0.25f, 0.25f, 0.125f};
    const float w6[] = {0.125f, 0.25f, 0.125f, 0.125f, 0.25f, 0.125f};
    const float *want[] = {w3, w4, w5, w6};
    float w[LIMIT_AREA_SAMPLES];
    plan_area_weights(1, w);
    assert_float_equal(w[0], 1, 0);
    for (int n = 3; n <= 6; n++) {
        plan_area_weights(n, w);
        for (int i = 0; i < n; i++)
            assert_float_equal(w[i], want[n - 3][i], 0);
    }
    plan_area_weights(LIMIT_AREA_SAMPLES, w);
    float sum = 0;
    for (int i = 0; i < LIMIT_AREA_SAMPLES; i++)
        sum += w[i];
    assert_float_equal(sum, 1, 1e-6);
}

static void test_area_light_penumbra(void **state)
{
    (void)state;
    Scene s;
    /* Samples at x = -1, 0, 1 above the origin (weights 1/4, 1/2, 1/4); a
     * small sphere hides only the x = 1 sample. Lighting is computed from
     * the centre (N.L = 1): C = P*0.1 + 0.75*P*0.6. */
    load(&s, "light { position 0 10 0 area_u 2 0 0 area_v 0 0 0 area_samples 3 1 }\n"
             "sphere { center 0.5 5 0 radius 0.1 material m }\n");
    float k = 0.1f + 0.75f * 0.6f;
    assert_vec(trace(&s, EYE, DIR), 0.5f * k, 0.4f * k, 0.3f * k, 1e-6);
    scene_free(&s);
}

static void test_area_light_in_packets(void **state)
{
    (void)state;
    Scene s;
    /* Nine samples at x = -4 .. 4 above the origin, traced eight at a time
     * (then one): weights 1/16 at the ends, 1/8 between. A small sphere
     * hides only the last sample, the ninth ray, alone in its packet. */
    load(&s, "light { position 0 10 0 area_u 8 0 0 area_v 0 0 0 area_samples 9 1 }\n"
             "sphere { center 2 5 0 radius 0.1 material m }\n");
    float k = 0.1f + (15.0f / 16.0f) * 0.6f;
    assert_vec(trace(&s, EYE, DIR), 0.5f * k, 0.4f * k, 0.3f * k, 1e-6);
    /* moved to hide the first sample, the first ray of the first packet */
    s.prims[1].g.sphere.c = vec3(-2, 5, 0);
    assert_vec(trace(&s, EYE, DIR), 0.5f * k, 0.4f * k, 0.3f * k, 1e-6);
    scene_free(&s);
}

static void test_area_light_through_glass_in_packets(void **state)
{
    (void)state;
    Scene s;
    /* test_area_light_in_packets' light and sphere, the sphere of glass:
     * the ninth sample, alone in its packet, comes through it filtered
     * twice, F^2 = 0.5^2 in red; then the first, in the first packet. */
    load(&s, "material g { color 0.5 0.4 0.3 ambient 0 diffuse 0 filter 0.5 transmit 0.25 }\n"
             "light { position 0 10 0 area_u 8 0 0 area_v 0 0 0 area_samples 9 1 }\n"
             "sphere { center 2 5 0 radius 0.1 material g }\n");
    float k = 0.1f + (15.0f / 16.0f + 0.25f / 16.0f) * 0.6f;
    assert_float_equal(trace(&s, EYE, DIR).x, 0.5f * k, 1e-6);
    s.prims[1].g.sphere.c = vec3(-2, 5, 0);
    assert_float_equal(trace(&s, EYE, DIR).x, 0.5f * k, 1e-6);
    scene_free(&s);
}

static void test_transparent_surface(void **state)
{
    (void)state;
    Scene s;
    /* A floor with filter 0.5 and transmit 0.25 over nothing: opacity 0.25
     * scales ambient and diffuse, and the transmitted ray brings the
     * background times F = P*0.5 + 0.25. Light at distance 5, N.L = 0.8. */
    load(&s, "material g { color 0.5 0.4 0.3 ambient 0.1 diffuse 0.6 filter 0.5 transmit 0.25 }\n"
             "plane { normal 0 1 0 material g }\n"
             "light { position 3 4 0 }\n");
    s.prims[0] = s.prims[1];
    s.nprims = 1;
    float k = 0.25f * (0.1f + 0.6f * 0.8f);
    Vec3 f = vec3(0.5f * 0.5f + 0.25f, 0.4f * 0.5f + 0.25f, 0.3f * 0.5f + 0.25f);
    assert_vec(trace(&s, EYE, DIR), 0.5f * k + f.x * 0.2f, 0.4f * k + f.y * 0.4f, 0.3f * k + f.z * 0.6f, 1e-6);
    /* max_depth 1: the transmitted ray is cut, only the surface remains */
    s.image.max_depth = 1;
    assert_vec(trace(&s, EYE, DIR), 0.5f * k, 0.4f * k, 0.3f * k, 1e-6);
    scene_free(&s);
}

static void test_shadow_through_glass(void **state)
{
    (void)state;
    Scene s;
    /* A transparent sphere on the way to the light filters it twice, on the
     * way in and on the way out: the diffuse term carries F^2. */
    load(&s, "material g { color 0.8 0.5 0.25 ambient 0 diffuse 0 filter 0.5 transmit 0.25 ior 1.5 }\n"
             "light { position 3 4 0 }\n"
             "sphere { center 1.5 2 0 radius 0.5 material g }\n");
    Vec3 f = vec3(0.8f * 0.5f + 0.25f, 0.5f * 0.5f + 0.25f, 0.25f * 0.5f + 0.25f);
    Vec3 d = vec3(0.5f * 0.48f, 0.4f * 0.48f, 0.3f * 0.48f); /* P * 0.6 * 0.8 */
    assert_vec(trace(&s, EYE, DIR), 0.05f + d.x * f.x * f.x, 0.04f + d.y * f.y * f.y, 0.03f + d.z * f.z * f.z,
               1e-6);
    scene_free(&s);
}

static void test_refraction_through_slab(void **state)
{
    (void)state;
    Scene s;
    /* A clear slab (ior 1.5) fills -1 < y < 0. A ray entering at the origin
     * at 45 degrees bends to sin(t) = sin(45)/1.5 and leaves at
     * x = tan(t) = 0.5345, then goes on at 45 degrees to y = -2 at
     * x = 1.5345. A tile there (x 1.4 to 1.7) is only seen through the bend:
     * unbent, the ray would reach x = 2 and the background. */
    load(&s, "material clear { color 1 1 1 ambient 0 diffuse 0 transmit 1 ior 1.5 }\n"
             "material tile { color 0.9 0.6 0.3 ambient 1 diffuse 0 }\n"
             "box { min -10 -1 -10 max 10 0 10 material clear }\n"
             "box { min 1.4 -2.1 -1 max 1.7 -2 1 material tile }\n");
    s.prims[0] = s.prims[1];
    s.prims[1] = s.prims[2];
    s.nprims = 2;
    assert_vec(trace(&s, vec3(-1, 1, 0), vec3(1, -1, 0)), 0.9f, 0.6f, 0.3f, 1e-6);
    /* with ior 1 the ray goes straight on to the background */
    s.materials[1].ior = 1.0f;
    assert_vec(trace(&s, vec3(-1, 1, 0), vec3(1, -1, 0)), 0.2f, 0.4f, 0.6f, 1e-6);
    scene_free(&s);
}

/* A clear solid (transmit 1, ior 1: no bend, no colour of its own)
 * standing on the floor, listed before it: a ray through its bottom face
 * meets the floor there, at the same distance, and sees the floor's
 * ambient colour. The solid's face won the tie by its lower number, the
 * ray left it first, started past the floor, and saw the background; an
 * oriented box or a turned mesh on the floor, by the roundings. */
static void test_clear_solid_on_floor(void **state)
{
    (void)state;
    char dir[] = "/tmp/lancer-shade-XXXXXX", path[256], text[2048], err[512];
    test_box_off((const float[3]){-1, 0, -1}, (const float[3]){1, 2, 1}, text, sizeof text);
    test_temp_file(dir, "cube.off", text, path, sizeof path);
    static const char *const solids[] = {
        "box { min -1 0 -1 max 1 2 1 material g }",
        "obox { center 0 0.8 0 u 1 0 0 v 0 0.8 0 w 0 0 1 material g }",
        "box { min -1 0 -1 max 1 2 1 rotate 0 20 0 material g }",
        NULL, /* the mesh */
    };
    for (size_t i = 0; i < sizeof solids / sizeof solids[0]; i++) {
        char solid[512];
        if (solids[i])
            snprintf(solid, sizeof solid, "%s", solids[i]);
        else
            snprintf(solid, sizeof solid, "mesh { file \"%s\" material g rotate 0 30 0 }", path);
        snprintf(text, sizeof text,
                 "image { background 0.2 0.4 0.6 }\n"
                 "camera { eye 0 1 -5 target 0 0 0 fov 40 }\n"
                 "material m { color 0.5 0.4 0.3 ambient 0.1 diffuse 0.6 }\n"
                 "material g { color 1 1 1 ambient 0 diffuse 0 transmit 1 }\n"
                 "%s\nplane { normal 0 1 0 material m }\n",
                 solid);
        Scene s;
        if (scene_parse("t.scn", text, strlen(text), &s, err, sizeof err) != 0)
            fail_msg("%s", err);
        for (int k = 0; k < 25; k++) { /* down through the top, at angles, out through the bottom */
            const Vec3 at = vec3(-0.5f + 0.04f * (float)k, 0, 0.3f - 0.02f * (float)k);
            const Vec3 o = vec3(0.3f, 5, -1.5f);
            assert_vec(trace(&s, o, vec_sub(at, o)), 0.05f, 0.04f, 0.03f, 1e-6);
        }
        scene_free(&s);
    }
    remove(path);
    rmdir(dir);
}

/* Loads the floor scene plus `extra`, then drops the floor. */
static void load_floorless(Scene *s, const char *extra)
{
    load(s, extra);
    memmove(&s->prims[0], &s->prims[1], sizeof s->prims[0] * (size_t)(s->nprims - 1));
    s->nprims--;
}

/* The same slab as a mesh: a ray that enters by one triangle and leaves
 * by another leaves the one solid the mesh bounds, and bends back (it once
 * read as entering a second solid of the same ior, and went on unbent past
 * the tile). */
static void test_refraction_through_mesh_slab(void **state)
{
    (void)state;
    char dir[] = "/tmp/lancer-shade-XXXXXX", path[256], text[1024];
    test_box_off((const float[3]){-10, -1, -10}, (const float[3]){10, 0, 10}, text, sizeof text);
    test_temp_file(dir, "slab.off", text, path, sizeof path);
    /* (a pn slab is not flat: its corners' normals round it) */
    static const char *const kinds[2] = {"flat", "smooth"};
    for (int k = 0; k < 2; k++) {
        Scene s;
        snprintf(text, sizeof text,
                 "material clear { color 1 1 1 ambient 0 diffuse 0 transmit 1 ior 1.5 }\n"
                 "material tile { color 0.9 0.6 0.3 ambient 1 diffuse 0 }\n"
                 "mesh { file \"%s\" material clear %s }\n"
                 "box { min 1.4 -2.1 -1 max 1.7 -2 1 material tile }\n",
                 path, kinds[k]);
        load_floorless(&s, text);
        /* across the top face's diagonal, and beside it */
        assert_vec(trace(&s, vec3(-1, 1, 0), vec3(1, -1, 0)), 0.9f, 0.6f, 0.3f, 1e-5);
        assert_vec(trace(&s, vec3(-1, 1, 0.3f), vec3(1, -1, 0)), 0.9f, 0.6f, 0.3f, 1e-5);
        scene_free(&s);
    }
    remove(path);
    rmdir(dir);
}

/* A pyramid of height 3 over the square |x|, |z| <= 1, as six triangles;
 * and a material whose every surface lets through half the light
 * (transmit 0.5, ior 1: no bend). */
#define PYRAMID                                                                                                       \
    "triangle { a 0 3 0 b 1 0 -1 c -1 0 -1 material g }\n"                                                           \
    "triangle { a 0 3 0 b 1 0 1 c 1 0 -1 material g }\n"                                                             \
    "triangle { a 0 3 0 b -1 0 1 c 1 0 1 material g }\n"                                                             \
    "triangle { a 0 3 0 b -1 0 -1 c -1 0 1 material g }\n"                                                           \
    "triangle { a -1 0 -1 b 1 0 -1 c 1 0 1 material g }\n"                                                           \
    "triangle { a -1 0 -1 b 1 0 1 c -1 0 1 material g }\n"
#define HALF_CLEAR "material g { color 1 1 1 ambient 0 diffuse 0 transmit 0.5 }\n"

static void test_mesh_apex_crossed_once(void **state)
{
    (void)state;
    /* A ray into a sharp apex of a mesh, or past it by less than a spawn
     * offset's reach, crosses two surfaces: the background times 0.5^2.
     * The spawn offset off the face hit, along that face's normal, leaves
     * the origin outside the opposite face: without edge_clear the ray
     * crossed it as a third surface (0.125). */
    Scene s;
    load_floorless(&s, HALF_CLEAR PYRAMID);
    /* eyes above, within the apex's angle: each ray goes on into the pyramid */
    const Vec3 eyes[4] = {{0, 10, 0}, {0.5f, 12, 0.3f}, {-0.7f, 9, 0.9f}, {0.01f, 5, 0.02f}};
    int rays = 0;
    for (int e = 0; e < 4; e++)
        for (int i = -2; i <= 2; i++)
            for (int k = -2; k <= 2; k++) {
                /* through points 1e-4 below the apex, up to 2e-6 off its
                 * axis: inside the pyramid, whose half-width there is 3.3e-5 */
                Vec3 q = vec3(1e-6f * (float)i, 3.0f - 1e-4f, 1e-6f * (float)k);
                Vec3 c = trace(&s, eyes[e], vec_sub(q, eyes[e]));
                assert_vec(c, 0.25f * 0.2f, 0.25f * 0.4f, 0.25f * 0.6f, 1e-6);
                rays++;
            }
    /* straight down, exactly through the apex vertex */
    assert_vec(trace(&s, eyes[0], vec3(0, -1, 0)), 0.25f * 0.2f, 0.25f * 0.4f, 0.25f * 0.6f, 1e-6);
    assert_int_equal(rays, 100);
    /* Eyes to the side: rays through points within 2.4e-5 of the axis,
     * 1e-4 below the apex, cross two faces or miss. The exit lies closer
     * to the entry than the spawn offset's error bound reaches: a test of
     * the point's side of the exit face by that bound skipped the exit,
     * one surface (0.1). */
    const Vec3 side[2] = {{-2, 4, 1}, {3, 5, 0.3f}};
    int crossed = 0;
    for (int e = 0; e < 2; e++)
        for (int i = -4; i <= 4; i++)
            for (int k = -4; k <= 4; k++) {
                Vec3 q = vec3(6e-6f * (float)i, 3.0f - 1e-4f, 6e-6f * (float)k);
                Vec3 c = trace(&s, side[e], vec_sub(q, side[e]));
                if (fabsf(c.x - 0.2f) < 1e-6f) /* missed: the background */
                    continue;
                assert_vec(c, 0.25f * 0.2f, 0.25f * 0.4f, 0.25f * 0.6f, 1e-6);
                crossed++;
            }
    assert_true(crossed >= 100);
    scene_free(&s);
}

/* The 16 sides of a cone of height 3 over the unit circle of y = 0, as
 * triangles of material g (no base), into buf. */
static void cone_sides(char *buf, size_t len)
{
    size_t at = 0;
    for (int i = 0; i < 16; i++) {
        const double turn = 6.283185307179586, a0 = turn * i / 16, a1 = turn * (i + 1) / 16;
        at += (size_t)snprintf(buf + at, len - at, "triangle { a 0 3 0 b %.9f 0 %.9f c %.9f 0 %.9f material g }\n",
                               cos(a1), sin(a1), cos(a0), sin(a0));
        assert_true(at < len);
    }
}

static void test_mesh_apex_exit_within_offset(void **state)
{
    (void)state;
    /* Rays from the side into a cone 1e-4 below its apex, where it is
     * 6.6e-5 wide: the spawn offset off a face as long as these reaches
     * further, past the exit face, and the ray crossed one surface (0.5).
     * edge_clear finds the exit as the ray's first hit: two (0.25). */
    char sides[1536], extra[2048];
    cone_sides(sides, sizeof sides);
    snprintf(extra, sizeof extra, "%s%s", HALF_CLEAR, sides);
    Scene s;
    load_floorless(&s, extra);
    const Vec3 eyes[4] = {{3, 5, 0.3f}, {1, 4, -2}, {-2, 4, 1}, {0.2f, 8, 3}};
    for (int e = 0; e < 4; e++)
        for (int i = -2; i <= 2; i++)
            for (int k = -2; k <= 2; k++) {
                Vec3 q = vec3(1e-6f * (float)i, 3.0f - 1e-4f, 1e-6f * (float)k);
                assert_vec(trace(&s, eyes[e], vec_sub(q, eyes[e])), 0.25f * 0.2f, 0.25f * 0.4f, 0.25f * 0.6f, 1e-6);
            }
    scene_free(&s);
}

static void test_shadow_through_thin_apex(void **state)
{
    (void)state;
    /* A ceiling at y = 10, lit from below and to the side by a light whose
     * shadow rays to the ceiling points around P pass within 1e-6 of the
     * cone's axis, 1e-4 below its apex: in and out, two surfaces, and the
     * diffuse term carries 0.5^2, where the exit was skipped (0.5). */
    char sides[1536], extra[2048];
    cone_sides(sides, sizeof sides);
    snprintf(extra, sizeof extra, "%s%s%s", HALF_CLEAR,
             "material m2 { color 0.5 0.4 0.3 ambient 0.1 diffuse 0.6 }\n"
             "plane { normal 0 -1 0 offset -10 material m2 }\n"
             "light { position -3 -1 0 }\n",
             sides);
    Scene s;
    load_floorless(&s, extra);
    /* P = Q + t (Q - L), Q = (0, 3 - 1e-4, 0), L the light: on y = 10 */
    const double qy = 3.0 - 1e-4, t = (10.0 - qy) / (qy + 1.0);
    const Vec3 p = vec3((float)(3.0 * t), 10.0f, 0.0f), eye = vec3(p.x, 9.0f, 0.5f);
    /* N.L = 0.8: the light lies along (-0.6, -0.8, 0) from P */
    const float k = 0.1f + 0.6f * 0.8f * 0.25f;
    for (int i = -2; i <= 2; i++) {
        const Vec3 at = vec3(p.x, p.y, 1e-7f * (float)i);
        assert_vec(trace(&s, eye, vec_sub(at, eye)), 0.5f * k, 0.4f * k, 0.3f * k, 1e-5);
    }
    scene_free(&s);
}

static void test_mesh_box_edge_crossed_once(void **state)
{
    (void)state;
    /* Rays into a mesh cube exactly through its edges and a corner cross
     * two surfaces; the cube's faces meet at right angles, so the offset
     * off one face leaves the origin on the plane of the next. */
    Scene s;
    load_floorless(&s, HALF_CLEAR "triangle { a -1 -1 -1 b 1 1 -1 c 1 -1 -1 material g }\n"
                                  "triangle { a -1 -1 -1 b -1 1 -1 c 1 1 -1 material g }\n"
                                  "triangle { a -1 -1 1 b 1 -1 1 c 1 1 1 material g }\n"
                                  "triangle { a -1 -1 1 b 1 1 1 c -1 1 1 material g }\n"
                                  "triangle { a -1 -1 -1 b 1 -1 -1 c 1 -1 1 material g }\n"
                                  "triangle { a -1 -1 -1 b 1 -1 1 c -1 -1 1 material g }\n"
                                  "triangle { a 1 1 -1 b -1 1 -1 c -1 1 1 material g }\n"
                                  "triangle { a 1 1 -1 b -1 1 1 c 1 1 1 material g }\n"
                                  "triangle { a 1 -1 -1 b 1 1 -1 c 1 1 1 material g }\n"
                                  "triangle { a 1 -1 -1 b 1 1 1 c 1 -1 1 material g }\n"
                                  "triangle { a -1 -1 -1 b -1 -1 1 c -1 1 1 material g }\n"
                                  "triangle { a -1 -1 -1 b -1 1 1 c -1 1 -1 material g }\n");
    const Vec3 eyes[4][2] = {{{5, 5, 0.3f}, {1, 1, 0}},
                             {{5, 5, 0.3f}, {1, 1, 0.5f}},
                             {{-5, 5, 0.1f}, {-1, 1, 0}},
                             {{5, 5, 5}, {1, 1, 1}}};
    for (int i = 0; i < 4; i++)
        assert_vec(trace(&s, eyes[i][0], vec_sub(eyes[i][1], eyes[i][0])), 0.25f * 0.2f, 0.25f * 0.4f,
                   0.25f * 0.6f, 1e-6);
    /* rays within 4e-6 of the corner (1, 1, 1), from two eyes */
    const Vec3 far[2] = {{5, 5, 5}, {6, 4, 3}};
    for (int e = 0; e < 2; e++)
        for (int i = -2; i <= 2; i++)
            for (int k = -2; k <= 2; k++) {
                Vec3 q = vec3(1.0f - 2e-6f + 1e-6f * (float)i, 1.0f - 2e-6f + 1e-6f * (float)k, 1.0f - 2e-6f);
                assert_vec(trace(&s, far[e], vec_sub(q, far[e])), 0.25f * 0.2f, 0.25f * 0.4f, 0.25f * 0.6f, 1e-6);
            }
    scene_free(&s);
}

static void test_shadow_through_mesh_apex(void **state)
{
    (void)state;
    /* A ceiling at y = 10 lit from under the pyramid: the shadow ray from
     * the ceiling point over the apex goes in through the apex vertex and
     * out through the base, two surfaces, so the diffuse term carries 0.5^2
     * (ambient 0.1 and diffuse 0.6 of colour 0.5 0.4 0.3, N.L = 1). The
     * shadow rays are filtered ones, in filtered(), surface after surface. */
    Scene s;
    load_floorless(&s, HALF_CLEAR "material m2 { color 0.5 0.4 0.3 ambient 0.1 diffuse 0.6 }\n"
                                  "plane { normal 0 -1 0 offset -10 material m2 }\n"
                                  "light { position 0 -5 0 }\n" PYRAMID);
    const float k = 0.1f + 0.6f * 0.25f;
    assert_vec(trace(&s, vec3(0.5f, 9.5f, 0), vec3(-0.5f, 0.5f, 0)), 0.5f * k, 0.4f * k, 0.3f * k, 1e-6);
    scene_free(&s);
}

static void test_no_self_shadow_in_mesh_groove(void **state)
{
    (void)state;
    /* An opaque groove: two triangles sharing the z axis, opening upwards
     * at 22.6 degrees, seen and lit from straight above its bottom edge.
     * The light reaches the edge (N.L = 0.2 / sqrt(1.04) on either face);
     * the spawn offset off one face, into the groove, leaves the origin
     * behind the other face, which blocked the shadow ray without
     * blocked_past_edge: a point light's rays and an area light's. */
    const char *light[2] = {"light { position 0 10 0 }\n",
                            "light { position 0 10 0 area_u 0 0 0.4 area_v 0.02 0 0 area_samples 3 2 }\n"};
    for (int l = 0; l < 2; l++) {
        char extra[512];
        snprintf(extra, sizeof extra, "%s%s", light[l],
                 "triangle { a 0 0 -1 b 0 0 1 c 0.2 1 0 material m }\n"
                 "triangle { a 0 0 -1 b 0 0 1 c -0.2 1 0 material m }\n");
        Scene s;
        load_floorless(&s, extra);
        const float k = 0.1f + 0.6f * (0.2f / sqrtf(1.04f));
        assert_vec(trace(&s, vec3(0, 5, 0), vec3(0, -1, 0)), 0.5f * k, 0.4f * k, 0.3f * k, 1e-5);
        scene_free(&s);
    }
}

/* A floor of one triangle 80,000 across: a ray leaving it starts past the
 * triangle test's error band, which grows with the triangle (0.2 here),
 * over a box 0.02 high standing on it. The line from the point itself
 * decides (edge_clear, Surface.edge 2): the floor point at the box's foot,
 * lit at a low angle across the box, is in its shadow, for a point light
 * and an area light, opaque and filtered; and a mirror floor there shows
 * the box's face, not the sky above it. */
#define HUGE_FLOOR(mat) "triangle { a -40000 0 -40000 b 40000 0 -40000 c 0 0 40000 material " mat " }\n"
#define LOW_BOX(mat) "box { min 0.01 0 -1 max 1 0.02 1 material " mat " }\n"

static void test_shadow_of_low_box_on_huge_floor(void **state)
{
    (void)state;
    const char *light[2] = {"light { position 10 1 0 }\n",
                            "light { position 10 1 0 area_u 0 0 0.01 area_v 0 0.01 0 area_samples 2 2 }\n"};
    const char *glass[2] = {"",
                            "material g { color 1 1 1 transmit 0.5 }\nsphere { center 0 9 9 radius 1 material g }\n"};
    for (int l = 0; l < 2; l++)
        for (int f = 0; f < 2; f++) { /* f 1: a glass ball elsewhere, so shadows are filtered */
            char extra[1024];
            snprintf(extra, sizeof extra, "%s%s" HUGE_FLOOR("m") LOW_BOX("m"), light[l], glass[f]);
            Scene s;
            load_floorless(&s, extra);
            assert_vec(trace(&s, vec3(0, 5, 0), vec3(0, -1, 0)), 0.05f, 0.04f, 0.03f, 1e-6); /* ambient alone */
            scene_free(&s);
        }
}

static void test_filtered_shadow_on_huge_floor(void **state)
{
    (void)state;
    /* a glass ball between the floor point and the light: each of its two
     * surfaces lets half the light through, on the filtered shadow ray off
     * a huge triangle */
    Scene s;
    load_floorless(&s, "light { position 0 10 0 }\n"
                       "material g { color 1 1 1 ambient 0 diffuse 0 transmit 0.5 }\n"
                       "sphere { center 0 5 0 radius 1 material g }\n" HUGE_FLOOR("m"));
    assert_vec(trace(&s, EYE, DIR), 0.125f, 0.1f, 0.075f, 1e-6); /* ambient 0.1, diffuse 0.6 times 0.25 */
    scene_free(&s);
}

static void test_shadow_on_huge_floor_over_slabs(void **state)
{
    (void)state;
    /* the same shadow with twelve slabs under the floor: the line's search
     * passes at most EDGE_STEPS surfaces behind the point, and it starts
     * only a few of the point's own errors behind it, not past the slabs */
    char extra[4096];
    int at = snprintf(extra, sizeof extra, "light { position 10 1 0 }\n" HUGE_FLOOR("m") LOW_BOX("m"));
    for (int i = 1; i <= 12; i++)
        at += snprintf(extra + at, sizeof extra - (size_t)at, "box { min -50 %g -50 max 50 %g 50 material m }\n",
                       -0.3 * i, 0.1 - 0.3 * i);
    Scene s;
    load_floorless(&s, extra);
    assert_vec(trace(&s, vec3(0, 5, 0), vec3(0, -1, 0)), 0.05f, 0.04f, 0.03f, 1e-6);
    scene_free(&s);
}

static void test_ball_in_glass_box_on_huge_pane(void **state)
{
    (void)state;
    /* Seen from below through a clear pane, a clear box sunk 10^-6 into
     * it holds a red ball: the line from the pane's point starts inside
     * the box and meets it again at its top, but the ball first. */
    Scene s;
    load_floorless(&s, "material g { color 1 1 1 ambient 0 diffuse 0 transmit 1 }\n"
                       "material red { color 0.9 0.1 0.1 ambient 1 diffuse 0 }\n"
                       "box { min -1 -1e-6 -1 max 1 1 1 material g }\n"
                       "sphere { center 0.3 0.5 0.2 radius 0.3 material red }\n" HUGE_FLOOR("g"));
    assert_vec(trace(&s, vec3(0.3f, -5, 0.2f), vec3(0, 1, 0)), 0.9f, 0.1f, 0.1f, 1e-6);
    scene_free(&s);
}

static void test_mirror_of_low_box_on_huge_floor(void **state)
{
    (void)state;
    Scene s;
    load_floorless(&s, "material mir { color 0 0 0 ambient 0 diffuse 0 reflection 1 }\n"
                       "material red { color 0.9 0.1 0.1 ambient 1 diffuse 0 }\n" HUGE_FLOOR("mir") LOW_BOX("red"));
    assert_vec(trace(&s, vec3(-10, 1, 0), vec3(10, -1, 0)), 0.9f, 0.1f, 0.1f, 1e-6);
    scene_free(&s);
}

static void test_shadow_of_box_standing_on_huge_pane(void **state)
{
    (void)state;
    /* The box stands on a clear pane of the same size, over a floor 1
     * below, lit from straight above: the shadow ray from the floor under
     * the box crosses the pane at the box's foot, where the line from the
     * pane's point lies on the box. */
    Scene s;
    load_floorless(&s, "light { position 0 10 0 }\n"
                       "material g { color 1 1 1 ambient 0 diffuse 0 transmit 0.5 }\n"
                       "plane { normal 0 1 0 offset -1 material m }\n" HUGE_FLOOR("g") LOW_BOX("m"));
    const Vec3 c = trace(&s, vec3(-5, 0.5f, 0.2f), vec3(5.5f, -1.5f, 0)); /* in at x = -3.2, on to (0.5, -1, 0.2) */
    assert_vec(c, 0.025f, 0.02f, 0.015f, 1e-6);                           /* the floor's ambient, through the pane */
    scene_free(&s);
}

static void test_continued_rays_cut(void **state)
{
    (void)state;
    /* A ray through clear planes goes straight through each, at its level
     * (a continued ray): through 200 it reaches the background, and past
     * LIMIT_CONTINUED in a row it is cut, black, as past max_depth. */
    const int count[2] = {200, LIMIT_CONTINUED + 44};
    for (int t = 0; t < 2; t++) {
        static char text[64 * 400];
        char err[512];
        int at = snprintf(text, sizeof text, "%smaterial g { color 1 1 1 ambient 0 diffuse 0 transmit 1 }\n",
                          floor_scene);
        for (int k = 1; k <= count[t]; k++)
            at += snprintf(text + at, sizeof text - (size_t)at, "plane { normal 0 0 1 offset %d material g }\n", k);
        Scene s;
        assert_int_equal(scene_parse("t.scn", text, strlen(text), &s, err, sizeof err), 0);
        const Vec3 c = trace(&s, vec3(0, 1, 0), vec3(0, 0, 1));
        if (t == 0)
            assert_vec(c, 0.2f, 0.4f, 0.6f, 1e-6);
        else
            assert_vec(c, 0.0f, 0.0f, 0.0f, 0.0);
        scene_free(&s);
    }
}

/* A shadow ray through LIMIT_SHADOW_CROSSINGS clear planes reaches the
 * light (it once took one search too few, and found 256 dark); through
 * one more it is taken as blocked, and counted. */
static void test_shadow_crossings_limit(void **state)
{
    (void)state;
    const int count[2] = {LIMIT_SHADOW_CROSSINGS, LIMIT_SHADOW_CROSSINGS + 1};
    for (int t = 0; t < 2; t++) {
        static char text[64 * 400];
        char err[512];
        int at = snprintf(text, sizeof text,
                          "%slight { position 0 20 0 }\nmaterial g { color 1 1 1 ambient 0 diffuse 0 transmit 1 }\n",
                          floor_scene);
        for (int k = 0; k < count[t]; k++)
            at += snprintf(text + at, sizeof text - (size_t)at, "plane { normal 0 1 0 offset %g material g }\n",
                           10.0 + 0.01 * k);
        Scene s;
        assert_int_equal(scene_parse("t.scn", text, strlen(text), &s, err, sizeof err), 0);
        RenderPlan p;
        Accel *a = plan_world(&p, &s);
        RayStats st;
        memset(&st, 0, sizeof st);
        Ray r = ray_make(EYE, vec_normalize(DIR), INFINITY);
        const Vec3 c = shade_trace(&p, a, &r, &st);
        if (t == 0) { /* ambient and the whole diffuse term, the light straight above */
            assert_vec(c, 0.35f, 0.28f, 0.21f, 1e-6);
            assert_int_equal(st.shadow_cut, 0);
        } else {
            assert_vec(c, 0.05f, 0.04f, 0.03f, 1e-6);
            assert_int_equal(st.shadow_cut, 1);
        }
        accel_free(a);
        plan_free(&p);
        scene_free(&s);
    }
}

static void test_total_internal_reflection(void **state)
{
    (void)state;
    Scene s;
    /* Inside a glass ball (the camera starts inside it), a ray meeting the
     * surface at 60 degrees from the normal cannot leave (sin 60 * 1.5 > 1):
     * it is reflected, unfiltered, and keeps bouncing at 60 degrees; each
     * bounce is a level, and with max_depth 3 the third ray is black. So
     * the colour is only the surface's own (here nothing) plus black. */
    load(&s, "material glass { color 1 1 1 ambient 0 diffuse 0 transmit 1 ior 1.5 }\n"
             "sphere { center 0 0 0 radius 1 material glass }\n");
    s.prims[0] = s.prims[1];
    s.nprims = 1;
    s.image.max_depth = 3;
    s.camera.eye = vec3(0, 0, 0); /* camera rays start inside the ball */
    RenderPlan p;
    Accel *a = plan_world(&p, &s);
    RayStats st;
    memset(&st, 0, sizeof st);
    assert_int_equal(p.camera_in.n, 1);
    /* from (0, -0.866, 0) along +x: hits at (0.5, -0.866, 0), 60 degrees off the normal */
    Ray r = ray_make(vec3(0, -0.8660254f, 0), vec3(1, 0, 0), INFINITY);
    assert_vec(shade_trace(&p, a, &r, &st), 0, 0, 0, 0);
    assert_int_equal(st.refraction, 0);
    assert_int_equal(st.reflection, 2);
    /* the same ray from outside the list's point of view would refract out */
    memset(&st, 0, sizeof st);
    r = ray_make(vec3(0, 0, 0), vec3(1, 0, 0), INFINITY); /* head-on: leaves, to the background */
    assert_vec(shade_trace(&p, a, &r, &st), 0.2f, 0.4f, 0.6f, 1e-6);
    assert_int_equal(st.refraction, 1);
    accel_free(a);
    plan_free(&p);
    scene_free(&s);
}

/* One camera ray at a sphere of `material`, with adc_bailout b: its
 * counts of rays. */
static RayStats bailout_rays(const char *material, float b)
{
    Scene s;
    char extra[512];
    snprintf(extra, sizeof extra, "material x { %s }\nsphere { center 0 0 0 radius 1 material x }\n", material);
    load_floorless(&s, extra);
    s.image.adc_bailout = b;
    RenderPlan p;
    Accel *a = plan_world(&p, &s);
    RayStats st;
    memset(&st, 0, sizeof st);
    Ray r = ray_make(vec3(0, 0, -5), vec3(0, 0, 1), INFINITY);
    shade_trace(&p, a, &r, &st);
    accel_free(a);
    plan_free(&p);
    scene_free(&s);
    return st;
}

/* POV-Ray's adc_bailout (trace.cpp): a transmitted ray is traced when the
 * luminance of what the surface lets through, 0.297 r + 0.589 g + 0.114 b,
 * is above the bailout; a ray whose weight, the product of the
 * coefficients on its path, is below it is not. */
static void test_bailout_rules(void **state)
{
    (void)state;
    const char *red = "color 1 0 0 filter 1 ior 1", *green = "color 0 1 0 filter 1 ior 1";
    assert_int_equal(bailout_rays(red, 0.4f).refraction, 0); /* 0.297: not above */
    assert_int_equal(bailout_rays(red, 0.297f).refraction, 0); /* equal: not above */
    assert_true(bailout_rays(red, 0.29f).refraction > 0);
    assert_true(bailout_rays(green, 0.58f).refraction > 0); /* 0.589 */
    assert_int_equal(bailout_rays(green, 0.59f).refraction, 0);
    /* a mirror ray of weight 0.5 at a bailout of 0.5 is not below it */
    RayStats st = bailout_rays("reflection 0.5", 0.5f);
    assert_true(st.reflection == 1 && st.cut == 0);
    st = bailout_rays("reflection 0.5", nextafterf(0.5f, 1.0f));
    assert_true(st.reflection == 0 && st.cut == 1);
    /* through a ball of transmit 0.3: the ray inside weighs 0.3, the one
     * out of it 0.09, below a bailout of 0.2 */
    st = bailout_rays("transmit 0.3 ior 1", 0.2f);
    assert_true(st.refraction == 1 && st.cut == 1);
}

/* Total internal reflection's ray takes the transmitted ray's weight and
 * is not filtered by the reflection coefficient: from inside a glass box,
 * a ray meets the +x face at 60 degrees (sin 60 * 1.5 > 1), is reflected
 * whole, and leaves by the +y face at 30 degrees, filtered by 0.9. */
static void test_total_internal_reflection_unfiltered(void **state)
{
    (void)state;
    Scene s;
    load_floorless(&s, "material glass { color 1 1 1 ambient 0 diffuse 0 reflection 0.1 transmit 0.9 ior 1.5 }\n"
                       "box { min -3 -3 -3 max 3 3 3 material glass }\n");
    s.camera.eye = vec3(0, -2.5f, 0);
    Vec3 c = trace(&s, vec3(0, -2.5f, 0), vec3(0.5f, 0.8660254f, 0));
    /* at least the background through the +y face, 0.9 of it, and at
     * most that and a tenth more (the mirror ray back into the box) */
    assert_true(c.x >= 0.9f * 0.2f - 1e-6f && c.x <= 0.9f * 0.2f + 0.1f);
    assert_true(c.z >= 0.9f * 0.6f - 1e-6f && c.z <= 0.9f * 0.6f + 0.1f);
    scene_free(&s);
}

static void test_no_self_shadowing_on_spheres(void **state)
{
    (void)state;
    /* Camera rays from 10 units away hit a small sphere at every angle;
     * from each lit hit point, the shadow ray towards the light must not
     * find the sphere itself. The textbook quadratic puts grazing hit
     * points up to ~1e-5 inside the sphere, more than a spawn offset of a
     * few ulps; both variants project the point back onto the sphere. */
    Prim sphere = {PRIM_SPHERE, 0, {.sphere = {{1.2f, 0.4f, -0.8f}, 0.4f}}};
    for (int v = 0; v < 2; v++) {
        PrimVariant var = v ? PRIM_ROBUST : PRIM_CLASSIC;
        Vec3 eye = vec3(0, 4, -9), light = vec3(3, 2.5f, 1);
        int lit = 0, acne = 0;
        unsigned seed = 12345;
        for (int k = 0; k < 20000; k++) {
            seed = seed * 1103515245u + 12345u;
            float u = (float)(seed >> 8) / 16777216.0f;
            seed = seed * 1103515245u + 12345u;
            float w = (float)(seed >> 8) / 16777216.0f;
            /* aim at a random point of the disc the sphere shows the eye */
            Vec3 target = vec3(1.2f + 0.8f * (u - 0.5f), 0.4f + 0.8f * (w - 0.5f), -0.8f);
            Ray r = ray_make(eye, vec_normalize(vec_sub(target, eye)), INFINITY);
            Surface sf;
            if (!test_surface(&sphere, &r, var, &sf))
                continue;
            /* At the silhouette even the side the normal faces is uncertain;
             * either way that point is dark, so it is not counted. */
            if (vec_dot(r.d, sf.ng) > -0.01f)
                continue;
            Vec3 d = vec_sub(light, sf.p);
            float dist = vec_length(d);
            d = vec_scale(d, 1 / dist);
            if (vec_dot(d, sf.ng) <= 0)
                continue;
            lit++;
            Ray sh = ray_make(prim_spawn_origin(&sf, d), d, dist);
            PrimHit again;
            acne += prim_intersect(&sphere, &sh, var, &again);
        }
        assert_true(lit > 1000);
        assert_int_equal(acne, 0);
    }
}

/* shade_traced and shade_traced_packet, given accel_closest_packet's hits,
 * are shade_trace, bit for bit: on a mirror floor (a plane, outside the BVH) reflecting spheres and
 * the background, at every depth limit, 0 included. */
static void test_traced_is_trace(void **state)
{
    (void)state;
    Scene s;
    load(&s, "material mirror { color 0.2 0.2 0.2 ambient 0.1 diffuse 0.3 reflection 0.5 }\n"
             "material q { color 1 0.5 0.25 ambient 0.9 diffuse 0.4 }\n"
             "light { position 2 9 -3 }\n"
             "plane { normal 0 1 0 material mirror }\n"
             "sphere { center 6 8 0 radius 1 material q }\n"
             "sphere { center 0.5 0.5 0.5 radius 0.4 material q }\n");
    /* the mirror in place of the scene's own floor */
    memmove(&s.prims[0], &s.prims[1], sizeof(Prim) * (size_t)(s.nprims - 1));
    s.nprims--;
    /* one sign per axis, so that they go through the BVH as one packet */
    const Vec3 dirs[] = {vec3(3, -4, 0.05f), vec3(3, -4, 3), vec3(3.4f, -3.6f, 0.4f), vec3(3, -3.9f, 0.1f),
                         vec3(2, -0.5f, 0.2f)};
    /* five rays, and twelve (more than a packet: shade_traced_packet takes
     * them ACCEL_PACKET at a time) */
    for (int depth = 0; depth <= 3; depth++)
        for (int n = 5; n <= 12; n += 7) {
            s.image.max_depth = depth;
            RenderPlan p;
            Accel *a = plan_world(&p, &s);
            Ray r[2 * ACCEL_PACKET];
            PrimHit h[2 * ACCEL_PACKET];
            int best[2 * ACCEL_PACKET];
            RayStats st = {0}, st1 = st;
            for (int k = 0; k < n; k++)
                r[k] = ray_make(EYE, vec_normalize(vec_add(dirs[k % 5], vec3(0, 0, 0.01f * (float)(k / 5)))), INFINITY);
            accel_closest_packet(a, r, n, h, best, &st);
            Vec3 all[2 * ACCEL_PACKET];
            RayStats st2 = st;
            shade_traced_packet(&p, a, r, n, best, h, &st2, NULL, all);
            for (int k = 0; k < n; k++) {
                PrimHit w;
                assert_int_equal(best[k], accel_closest(a, &r[k], &w, &st1));
                Vec3 got = shade_traced(&p, a, &r[k], best[k], &h[k], &st);
                Vec3 want = shade_trace(&p, a, &r[k], &st1);
                assert_memory_equal(&got, &want, sizeof got);
                assert_memory_equal(&all[k], &want, sizeof want);
            }
            assert_true(st.shadow == st1.shadow && st.reflection == st1.reflection);
            assert_true(st2.shadow == st1.shadow && st2.reflection == st1.reflection);
            accel_free(a);
            plan_free(&p);
        }
    scene_free(&s);
}

/* Filtered shadows in a packet: the shadow rays go through the BVH
 * together, surface after surface, and give what one ray at a time gives,
 * bit for bit, and the analytic colours, for rays whose shadow rays cross
 * a glass sphere twice, meet an opaque one, or reach the light; in packets
 * of 1, 2 and 7. */
static void test_filtered_shadows_in_packets(void **state)
{
    (void)state;
    Scene s;
    load(&s, "material g { color 0.8 0.5 0.25 ambient 0 diffuse 0 filter 0.5 transmit 0.25 ior 1.5 }\n"
             "light { position -20 10 -20 }\n"
             "sphere { center -10 5 -10 radius 1 material g }\n"
             "sphere { center -7.5 5 -7.5 radius 0.5 material m }\n"
             "sphere { center -16.2 8 -15.92 radius 0.12 material g }\n");
    RenderPlan p;
    Accel *a = plan_world(&p, &s);
    assert_int_equal(p.shadow[0], PLAN_SHADOW_FILTERED);
    /* floor points (x, 0, z), every z > 0, so that the camera rays, and
     * their shadow rays, have one sign per axis: one packet each. In the
     * glass sphere's shadow (F^2 in red), the opaque one's (0) or the
     * light (1), in turns, so that the rays still on their way after the
     * first surface are not the first ones; the last, past a second glass
     * sphere too (F^4), goes on alone after its fourth. */
    const float at[][2] = {{5, 5}, {0, 0.1f}, {5, 1}, {0.5f, 0.2f}, {1, 0.3f}, {4.9f, 5.1f}, {-1, 0.4f}};
    const float f2 = 0.65f * 0.65f, filt[] = {0, f2, 1, f2, f2, 0, f2 * f2};
    const int n = (int)(sizeof at / sizeof at[0]);
    Ray r[ACCEL_PACKET];
    for (int k = 0; k < n; k++)
        r[k] = ray_make(EYE, vec_normalize(vec_sub(vec3(at[k][0], 0, at[k][1]), EYE)), INFINITY);
    const int sizes[] = {1, 2, n};
    for (int z = 0; z < 3; z++) {
        const int m = sizes[z];
        PrimHit h[ACCEL_PACKET];
        int best[ACCEL_PACKET];
        RayStats st = {0}, st1 = st;
        accel_closest_packet(a, r, m, h, best, &st);
        Vec3 all[ACCEL_PACKET];
        shade_traced_packet(&p, a, r, m, best, h, &st, NULL, all);
        for (int k = 0; k < m; k++) {
            Vec3 want = shade_trace(&p, a, &r[k], &st1);
            assert_memory_equal(&all[k], &want, sizeof want);
        }
        assert_true(st.shadow == st1.shadow);
        if (m == n) {
            /* each glass shadow ray crossed in and out: 7 + 4 x 2 + 2 rays */
            assert_int_equal(st.shadow, 17);
            /* red: ambient 0.05, and diffuse 0.3 N.L times the filter */
            for (int k = 0; k < n; k++) {
                float nl = 10.0f / vec_length(vec_sub(vec3(-20, 10, -20), vec3(at[k][0], 0, at[k][1])));
                assert_float_equal(all[k].x, 0.05f + 0.3f * nl * filt[k], 1e-5);
            }
        }
    }
    accel_free(a);
    plan_free(&p);
    scene_free(&s);
}

/* Refracted rays in packets: rays into two overlapping glass spheres of
 * one index (a ray from one into the other goes straight on, at its
 * level) with a third of another index inside one of them (nested
 * interiors, total internal reflection), shaded sixteen at a time
 * (shade_traced_packet), give what each gives alone (shade_trace), bit
 * for bit, with the same rays counted; at depths 2 and 6, and with
 * --no-plan's rays of weight 0. */
static void test_refraction_in_packets(void **state)
{
    (void)state;
    Scene s;
    load(&s, "material g { color 0.9 0.95 1 ambient 0 diffuse 0.05 phong 0.6 reflection 0.2 transmit 0.7 ior 1.5 }\n"
             "material w { color 0.8 0.9 1 ambient 0 diffuse 0.1 reflection 0.1 filter 0.6 ior 1.33 }\n"
             "light { position -2 6 -1 }\n"
             "sphere { center 0 1 0.6 radius 1 material g }\n"
             "sphere { center 0.6 1 1.2 radius 0.8 material g }\n"
             "sphere { center -0.2 1 0.5 radius 0.3 material w }\n");
    enum { N = 16 };
    Ray r[N];
    for (int k = 0; k < N; k++) /* x > 0, y < 0, z > 0 for all: one packet each */
        r[k] = ray_make(EYE, vec_normalize(vec_sub(vec3(-0.6f + 0.3f * (float)(k % 8), 0.6f + 0.5f * (float)(k / 8), 0.2f + 0.1f * (float)(k % 8)), EYE)), INFINITY);
    for (int full = 0; full <= 1; full++)
        for (int depth = 2; depth <= 6; depth += 4) {
            s.image.max_depth = depth;
            PlanOptions o = plan_options();
            o.world = 1;
            o.full = full;
            RenderPlan p;
            char err[256];
            assert_int_equal(plan_build(&p, &s, &o, err, sizeof err), 0);
            Accel *a = accel_build(&s, p.variant, 1);
            assert_non_null(a);
            PrimHit h[N];
            int best[N];
            RayStats st = {0}, st1 = st;
            accel_closest_packet(a, r, 8, h, best, &st);
            accel_closest_packet(a, r + 8, 8, h + 8, best + 8, &st);
            Vec3 all[N];
            shade_traced_packet(&p, a, r, N, best, h, &st, NULL, all);
            for (int k = 0; k < N; k++) {
                Vec3 want = shade_trace(&p, a, &r[k], &st1);
                assert_memory_equal(&all[k], &want, sizeof want);
            }
            assert_true(st.shadow == st1.shadow && st.reflection == st1.reflection);
            assert_true(st.refraction == st1.refraction && st.cut == st1.cut);
            assert_true(st.refraction >= N); /* every ray went in */
            accel_free(a);
            plan_free(&p);
        }
    scene_free(&s);
}

/* A sphere of the glass's own index that neither shows nor filters,
 * inside a glass sphere, changes nothing: a ray into it goes straight on
 * (the index ratio is 1 by the interiors' list), at its level, so the
 * floor seen through the glass stays lit at max_depth 3. Packets of eight
 * rays with it against single rays without it (to float rounding: the
 * ray's origin moves along its path). */
static void test_invisible_sphere_in_glass(void **state)
{
    (void)state;
    const char *glass = "material g { color 0.9 0.95 1 ambient 0 diffuse 0.05 reflection 0.1 transmit 0.8 ior 1.5 }\n"
                        "material inv { color 1 1 1 ambient 0 diffuse 0 transmit 1 ior 1.5 }\n"
                        "light { position -2 6 -1 }\n"
                        "sphere { center 0.5 1.2 0.8 radius 1 material g }\n";
    char with[1024];
    snprintf(with, sizeof with, "%ssphere { center 0.4 1 0.8 radius 0.5 material inv }\n", glass);
    Scene s0, s1;
    load(&s0, glass);
    load(&s1, with);
    Ray r[ACCEL_PACKET];
    for (int k = 0; k < ACCEL_PACKET; k++) /* through the middle of both spheres, one sign per axis */
        r[k] = ray_make(EYE, vec_normalize(vec_sub(vec3(0.3f + 0.05f * (float)k, 0.9f + 0.02f * (float)k, 0.7f + 0.03f * (float)k), EYE)), INFINITY);
    for (int depth = 3; depth <= 6; depth += 3) {
        s0.image.max_depth = s1.image.max_depth = depth;
        RenderPlan p0, p1;
        Accel *a0 = plan_world(&p0, &s0), *a1 = plan_world(&p1, &s1);
        PrimHit h[ACCEL_PACKET];
        int best[ACCEL_PACKET];
        RayStats st = {0};
        Vec3 got[ACCEL_PACKET];
        accel_closest_packet(a1, r, ACCEL_PACKET, h, best, &st);
        shade_traced_packet(&p1, a1, r, ACCEL_PACKET, best, h, &st, NULL, got);
        for (int k = 0; k < ACCEL_PACKET; k++) {
            Vec3 want = shade_trace(&p0, a0, &r[k], &st);
            assert_vec(got[k], want.x, want.y, want.z, 1e-5);
            assert_true(want.x > 0.1f); /* the lit floor, through the glass */
        }
        accel_free(a0);
        accel_free(a1);
        plan_free(&p0);
        plan_free(&p1);
    }
    scene_free(&s0);
    scene_free(&s1);
}

/* A stop flag, once set, stops the shading where it is: the packet's
 * colours are black and no secondary ray is traced, where without it the
 * glass sends mirror and refracted rays. */
static void test_stop_flag_stops_shading(void **state)
{
    (void)state;
    Scene sc;
    load(&sc, "material g { color 0.9 0.95 1 reflection 0.5 transmit 0.5 ior 1.5 }\n"
              "light { position -2 6 -1 }\n"
              "sphere { center 0.5 1.2 0.8 radius 1 material g }\n");
    RenderPlan p;
    Accel *a = plan_world(&p, &sc);
    Ray r[ACCEL_PACKET];
    for (int k = 0; k < ACCEL_PACKET; k++)
        r[k] = ray_make(EYE, vec_normalize(vec_sub(vec3(0.3f + 0.05f * (float)k, 0.9f, 0.7f), EYE)), INFINITY);
    PrimHit h[ACCEL_PACKET];
    int best[ACCEL_PACKET];
    RayStats st = {0};
    accel_closest_packet(a, r, ACCEL_PACKET, h, best, &st);
    Vec3 got[ACCEL_PACKET];
    volatile sig_atomic_t flag = 0;
    shade_traced_packet(&p, a, r, ACCEL_PACKET, best, h, &st, &flag, got);
    assert_true(st.reflection > 0 && st.refraction > 0);
    for (int k = 0; k < ACCEL_PACKET; k++)
        assert_true(got[k].x > 0.0f);
    RayStats st2 = {0};
    stop_set(&flag, SIGTERM);
    shade_traced_packet(&p, a, r, ACCEL_PACKET, best, h, &st2, &flag, got);
    assert_true(st2.reflection == 0 && st2.refraction == 0 && st2.shadow == 0);
    for (int k = 0; k < ACCEL_PACKET; k++)
        assert_vec(got[k], 0, 0, 0, 0);
    accel_free(a);
    plan_free(&p);
    scene_free(&sc);
}

/* POV-Ray's adaptive area light, against povray 3.7.0.10's own renders
 * (docs/povray-rules.md, section 10): a 5 x 5 light straight above a white
 * floor point, its two columns of samples at x = 1 and 2 behind a slab.
 * The full grid lets 0.625 through; a light dim enough that no edge of a
 * cell differs by more than 0.1 stops splitting: adaptive 0 keeps the four
 * corners (0.5), adaptive 1 splits once and stops (0.75); a bright one
 * splits down to the full grid whatever the level. */
static void test_adaptive_area_light(void **state)
{
    (void)state;
    static const struct {
        float color;
        int adaptive; /* -1: none */
        float want;
    } cases[] = {{0.03f, 0, 0.5f},  {0.03f, 1, 0.75f}, {0.03f, -1, 0.625f}, {1.0f, 0, 0.625f},
                 {1.0f, 1, 0.625f}, {0.04f, 0, 0.625f}};
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        char text[1024], err[512], ad[32] = "";
        if (cases[i].adaptive >= 0)
            snprintf(ad, sizeof ad, "area_adaptive %d", cases[i].adaptive);
        snprintf(text, sizeof text,
                 "camera { eye 0 1 -1 target 0 0 0 fov 40 }\n"
                 "light { position 0 10 0 color %g %g %g area_u 4 0 0 area_v 0 0 4 area_samples 5 5 %s }\n"
                 "material w { color 1 1 1 ambient 0 diffuse 1 }\n"
                 "plane { normal 0 1 0 material w }\n"
                 "box { min 0.5 9 -3 max 3 9.5 3 material w }\n",
                 (double)cases[i].color, (double)cases[i].color, (double)cases[i].color, ad);
        Scene s;
        assert_int_equal(scene_parse("t.scn", text, strlen(text), &s, err, sizeof err), 0);
        Vec3 c = trace(&s, vec3(0, 1, -1), vec3(0, -1, 1));
        scene_free(&s);
        /* the ray meets the floor a hair from (0, 0, 0): N.L is 1 to within 1e-6 */
        if (fabsf(c.x / cases[i].color - cases[i].want) > 1e-5f)
            fail_msg("case %zu: visibility %g, POV-Ray's %g", i, (double)(c.x / cases[i].color), (double)cases[i].want);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_lit_point),           cmocka_unit_test(test_light_colour_and_fade),
        cmocka_unit_test(test_point_in_shadow),     cmocka_unit_test(test_shadowless_light),
        cmocka_unit_test(test_phong_and_specular_peaks), cmocka_unit_test(test_reflection_bounce),
        cmocka_unit_test(test_miss_and_depth_limit), 
        cmocka_unit_test(test_light_behind_surface_adds_nothing), cmocka_unit_test(test_area_weights),
        cmocka_unit_test(test_area_light_penumbra), cmocka_unit_test(test_area_light_in_packets),
        cmocka_unit_test(test_area_light_through_glass_in_packets),
        cmocka_unit_test(test_transparent_surface),
        cmocka_unit_test(test_shadow_through_glass), cmocka_unit_test(test_refraction_through_slab),
        cmocka_unit_test(test_refraction_through_mesh_slab),
        cmocka_unit_test(test_clear_solid_on_floor),
        cmocka_unit_test(test_shadow_crossings_limit),
        cmocka_unit_test(test_total_internal_reflection), cmocka_unit_test(test_no_self_shadowing_on_spheres),
        cmocka_unit_test(test_traced_is_trace), cmocka_unit_test(test_filtered_shadows_in_packets),
        cmocka_unit_test(test_refraction_in_packets), cmocka_unit_test(test_invisible_sphere_in_glass),
        cmocka_unit_test(test_adaptive_area_light), cmocka_unit_test(test_light_on_a_surface),
        cmocka_unit_test(test_mesh_apex_crossed_once), cmocka_unit_test(test_mesh_apex_exit_within_offset),
        cmocka_unit_test(test_shadow_through_thin_apex),
        cmocka_unit_test(test_mesh_box_edge_crossed_once),
        cmocka_unit_test(test_shadow_through_mesh_apex), cmocka_unit_test(test_no_self_shadow_in_mesh_groove),
        cmocka_unit_test(test_shadow_of_low_box_on_huge_floor), cmocka_unit_test(test_mirror_of_low_box_on_huge_floor),
        cmocka_unit_test(test_shadow_of_box_standing_on_huge_pane), cmocka_unit_test(test_filtered_shadow_on_huge_floor),
        cmocka_unit_test(test_shadow_on_huge_floor_over_slabs), cmocka_unit_test(test_ball_in_glass_box_on_huge_pane),
        cmocka_unit_test(test_continued_rays_cut), cmocka_unit_test(test_stop_flag_stops_shading),
        cmocka_unit_test(test_bailout_rules), cmocka_unit_test(test_total_internal_reflection_unfiltered),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
