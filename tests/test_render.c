/* Tests for render.c: the image does not depend on the thread count, every
 * pixel gets one camera ray, progress reaches every row in order, and the
 * packets of camera rays change no pixel. */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <math.h>
#include <stdio.h>
#include <string.h>
#include <cmocka.h>

#include "lancer/camera.h"
#include "lancer/render.h"
#include "lancer/stop.h"
#include "lancer/shade.h"

typedef struct {
    int calls, last, total;
    int monotonic;
} ProgressLog;

static void log_progress(void *ctx, int done, int total)
{
    ProgressLog *p = ctx;
    p->calls++;
    if (done != p->last + 1)
        p->monotonic = 0;
    p->last = done;
    p->total = total;
}

/* Renders scene file `path` at w x h (and spp x spp samples when spp > 0)
 * on `threads` threads into img, as the command line does; the caller
 * frees *s, *p and *a. */
static void render_scene(const char *path, int threads, int w, int h, int spp, Scene *s, RenderPlan *p, Accel **a,
                         Image *img, RayStats *st, ProgressLog *log)
{
    char err[512];
    int rc = scene_load(path, s, err, sizeof err);
    if (rc)
        print_error("%s\n", err);
    assert_int_equal(rc, 0);
    PlanOptions o = plan_options();
    o.width = w;
    o.height = h;
    o.spp = spp;
    o.threads = threads;
    assert_int_equal(plan_build(p, s, &o, err, sizeof err), 0);
    *a = accel_build(s, p->variant, 2);
    assert_non_null(*a);
    assert_int_equal(image_init(img, w, h), 0);
    memset(st, 0, sizeof *st);
    RenderOptions opt = {log ? log_progress : NULL, log, NULL, NULL};
    assert_int_equal(render_image(p, *a, &opt, img, st), 0);
}

static void render_default(int threads, int w, int h, Image *img, RayStats *st, ProgressLog *log)
{
    Scene s;
    RenderPlan p;
    Accel *a;
    render_scene("scenes/default.scn", threads, w, h, 0, &s, &p, &a, img, st, log);
    accel_free(a);
    plan_free(&p);
    scene_free(&s);
}

static void test_thread_count_does_not_change_pixels(void **state)
{
    (void)state;
    Image one, many;
    RayStats s1, s4;
    render_default(1, 97, 61, &one, &s1, NULL);
    render_default(4, 97, 61, &many, &s4, NULL);
    assert_memory_equal(one.rgb, many.rgb, sizeof(float) * 3 * 97 * 61);
    /* the same rays were traced, just by other threads */
    assert_true(s1.camera == s4.camera && s1.shadow == s4.shadow && s1.reflection == s4.reflection);
    assert_true(s1.isect_tests == s4.isect_tests);
    image_free(&one);
    image_free(&many);
}

static void test_counts_and_progress(void **state)
{
    (void)state;
    Image img;
    RayStats st;
    ProgressLog log = {0, 0, 0, 1};
    render_default(3, 40, 30, &img, &st, &log);
    assert_int_equal(st.camera, 40 * 30);
    assert_true(st.shadow > 0 && st.reflection > 0);
    assert_int_equal(st.refraction, 0);
    /* the floor plane is outside the BVH: every camera and reflection ray
     * tests it, and the BVH spares most of the other six tests */
    assert_true(st.isect_tests >= st.camera + st.reflection);
    assert_true(st.isect_tests < 7 * (st.camera + st.reflection + st.shadow));
    assert_int_equal(log.calls, 30);
    assert_int_equal(log.last, 30);
    assert_int_equal(log.total, 30);
    assert_true(log.monotonic);
    /* the sky at the top row is the background colour exactly */
    assert_float_equal(img.rgb[0], 0.55f, 0);
    assert_float_equal(img.rgb[1], 0.7f, 0);
    assert_float_equal(img.rgb[2], 0.9f, 0);
    image_free(&img);
}

/* render_image traces camera rays in packets; each pixel must still be the
 * mean of shade_trace over its sub-pixel centres, one ray at a time, bit
 * for bit, with one sample or several, on a width that leaves a partial
 * packet at each row's end; on the default scene (two point lights, whose
 * shadow rays go in packets, and a mirror), on glass spheres (refraction,
 * transparent shadows), and with an area light and a shadowless one. */
static void test_pixels_are_single_rays(void **state)
{
    (void)state;
    const char *scenes[] = {"scenes/default.scn", "scenes/parity/glass.scn", "scenes/parity/area.scn",
                            "scenes/parity/shadowless.scn"};
    for (int sc = 0; sc < 4; sc++)
        for (int k = 1; k <= 2; k++) {
            Scene s;
            RenderPlan p;
            Accel *a;
            Image img;
            RayStats st, st1 = {0};
            render_scene(scenes[sc], 1, 29, 23, k, &s, &p, &a, &img, &st, NULL);
            Camera cam;
            camera_init(&cam, &s.camera, p.width, p.height);
            for (int y = 0; y < p.height; y++)
                for (int x = 0; x < p.width; x++) {
                    Vec3 sum = vec3(0, 0, 0);
                    for (int j = 0; j < k; j++)
                        for (int i = 0; i < k; i++) {
                            Ray r = camera_ray(&cam, (float)x + ((float)i + 0.5f) / (float)k,
                                               (float)y + ((float)j + 0.5f) / (float)k);
                            sum = vec_add(sum, shade_trace(&p, a, &r, &st1));
                            st1.camera++;
                        }
                    if (k > 1)
                        sum = vec_scale(sum, 1.0f / (float)(k * k));
                    float want[3] = {sum.x, sum.y, sum.z};
                    assert_memory_equal(&img.rgb[3 * (y * p.width + x)], want, sizeof want);
                }
            /* the same rays (the tests made may differ: a packet meets
             * leaves in its own order) */
            assert_true(st.camera == st1.camera && st.shadow == st1.shadow && st.reflection == st1.reflection &&
                        st.refraction == st1.refraction);
            assert_true(sc != 1 || st.refraction > 0);
            image_free(&img);
            accel_free(a);
            plan_free(&p);
            scene_free(&s);
        }
}

/* Sets the stop flag once `after` rows are done, as a signal handler would. */
typedef struct {
    volatile sig_atomic_t stop;
    int after;
} StopAfter;

static void stop_after(void *ctx, int done, int total)
{
    StopAfter *sa = ctx;
    (void)total;
    if (done >= sa->after)
        stop_set(&sa->stop, 1);
}

/* Concentric glass balls seen from outside: with 16 a refracted ray's list
 * holds every ball it enters; with 17 the rays toward the centre enter one
 * more, and the render counts them. */
/* Renders scene text at w x h with options o on one thread into img (made
 * here), its counts into *st. */
static void render_text(const char *text, size_t len, const PlanOptions *o, int w, int h, Image *img, RayStats *st)
{
    Scene s;
    RenderPlan p;
    char err[256];
    assert_int_equal(scene_parse("t.scn", text, len, &s, err, sizeof err), 0);
    assert_int_equal(plan_build(&p, &s, o, err, sizeof err), 0);
    Accel *a = accel_build(&s, p.variant, 1);
    assert_non_null(a);
    assert_int_equal(image_init(img, w, h), 0);
    memset(st, 0, sizeof *st);
    RenderOptions opt = {NULL, NULL, NULL, NULL};
    assert_int_equal(render_image(&p, a, &opt, img, st), 0);
    accel_free(a);
    plan_free(&p);
    scene_free(&s);
}

static void test_nesting_past_the_limit_is_counted(void **state)
{
    (void)state;
    for (int n = LIMIT_INTERIORS; n <= LIMIT_INTERIORS + 1; n++) {
        char text[4096];
        int len = snprintf(text, sizeof text,
                           "image { width 8 height 8 max_depth 64 }\ncamera { eye 0 0 -4 target 0 0 0 fov 10 }\n"
                           "material a { transmit 1 ior 1.2 }\nmaterial b { transmit 1 ior 1.4 }\n");
        for (int i = 0; i < n; i++)
            len += snprintf(text + len, sizeof text - (size_t)len, "sphere { center 0 0 0 radius %g material %s }\n",
                            1.9 - 0.1 * i, i % 2 ? "b" : "a");
        PlanOptions o = plan_options();
        Image img;
        RayStats st;
        render_text(text, (size_t)len, &o, 8, 8, &img, &st);
        if (n == LIMIT_INTERIORS)
            assert_true(st.too_deep == 0);
        else
            assert_true(st.too_deep > 0);
        image_free(&img);
    }
}

/* Adaptive anti-aliasing's rule: a pixel is supersampled when its centre
 * differs from one of its four neighbours' by more than the threshold (the
 * sum of the channels' differences). A box whose top edge lies on the
 * image's middle line, of colour 0.25 against a black background: the
 * rows either side of the edge differ by exactly 0.25, and only from their
 * neighbour above or below. */
static void test_adaptive_mask_rule(void **state)
{
    (void)state;
    const char *text = "image { width 16 height 8 spp 3 background 0 0 0 }\n"
                       "camera { eye 0 0 -5 target 0 0 0 fov 40 }\n"
                       "material w { color 0.25 0 0 ambient 1 diffuse 0 }\n"
                       "box { min -100 -100 0 max 100 0 1 material w }\n";
    const float thresholds[3] = {0.25f, 0.2f, 0.3f};
    const unsigned long long want[3] = {0, 2 * 16, 0};
    for (int i = 0; i < 3; i++) {
        PlanOptions o = plan_options();
        o.aa_threshold = thresholds[i];
        Image img;
        RayStats st;
        render_text(text, strlen(text), &o, 16, 8, &img, &st);
        assert_true(img.rgb[0] == 0.0f && img.rgb[(size_t)3 * 16 * 7] == 0.25f); /* the corners: sky, box */
        assert_true(st.supersampled == want[i]);
        image_free(&img);
    }
}

/* A stopped render returns 1, marks exactly the rows it finished, and each
 * of those rows is the full render's, bit for bit; stopped before it
 * starts, it does no row. */
static void test_stop_keeps_finished_rows(void **state)
{
    (void)state;
    const int w = 53, h = 41;
    Image full;
    RayStats st;
    render_default(1, w, h, &full, &st, NULL);
    Scene s;
    char err[512];
    assert_int_equal(scene_load("scenes/default.scn", &s, err, sizeof err), 0);
    PlanOptions o = plan_options();
    o.width = w;
    o.height = h;
    for (int threads = 1; threads <= 3; threads += 2)
        for (int after = 0; after <= 7; after += 7) {
            o.threads = threads;
            RenderPlan p;
            assert_int_equal(plan_build(&p, &s, &o, err, sizeof err), 0);
            Accel *a = accel_build(&s, p.variant, 1);
            assert_non_null(a);
            Image img;
            assert_int_equal(image_init(&img, w, h), 0);
            unsigned char done[41];
            memset(done, 0, sizeof done);
            StopAfter sa = {after == 0, after};
            RenderOptions opt = {stop_after, &sa, &sa.stop, done};
            assert_int_equal(render_image(&p, a, &opt, &img, &st), 1);
            int ndone = 0;
            for (int y = 0; y < h; y++) {
                assert_true(done[y] == 0 || done[y] == 1);
                ndone += done[y];
                if (done[y])
                    assert_memory_equal(&img.rgb[3 * w * y], &full.rgb[3 * w * y], sizeof(float) * 3 * (size_t)w);
            }
            /* every thread finishes or leaves the row it is in */
            assert_true(ndone >= after && ndone <= after + threads);
            assert_true(ndone < h);
            image_free(&img);
            accel_free(a);
            plan_free(&p);
        }
    scene_free(&s);
    image_free(&full);
}

/* Renders scenes/parity/antialias.scn at 64 x 48 with spp 3 and the given
 * adaptive threshold (0: the regular grid) on `threads` threads. */
static void render_aa(float threshold, int spp, int threads, Image *img, RayStats *st, ProgressLog *log)
{
    char err[512];
    Scene s;
    RenderPlan p;
    assert_int_equal(scene_load("scenes/parity/antialias.scn", &s, err, sizeof err), 0);
    PlanOptions o = plan_options();
    o.width = 64;
    o.height = 48;
    o.spp = spp;
    o.threads = threads;
    o.aa_threshold = threshold;
    assert_int_equal(plan_build(&p, &s, &o, err, sizeof err), 0);
    Accel *a = accel_build(&s, p.variant, 1);
    assert_non_null(a);
    assert_int_equal(image_init(img, 64, 48), 0);
    memset(st, 0, sizeof *st);
    RenderOptions opt = {log ? log_progress : NULL, log, NULL, NULL};
    assert_int_equal(render_image(&p, a, &opt, img, st), 0);
    accel_free(a);
    plan_free(&p);
    scene_free(&s);
}

/* Adaptive anti-aliasing: every pixel is either its centre sample or the
 * regular 3 x 3 grid's value, bit for bit; the same for any thread count;
 * only some pixels are supersampled, and the picture stays within a bound
 * of the regular grid's. */
static void test_adaptive_antialiasing(void **state)
{
    (void)state;
    Image full, one, ad, ad3;
    RayStats st;
    ProgressLog log = {0, 0, 0, 1};
    render_aa(0.0f, 3, 1, &full, &st, NULL);
    render_aa(0.0f, 1, 1, &one, &st, NULL);
    render_aa(0.05f, 3, 3, &ad3, &st, NULL);
    render_aa(0.05f, 3, 1, &ad, &st, &log);
    assert_memory_equal(ad.rgb, ad3.rgb, sizeof(float) * 3 * 64 * 48);
    assert_true(st.supersampled > 0 && st.supersampled < 64 * 48 / 2);
    assert_int_equal(st.camera, 64 * 48 + 9 * st.supersampled);
    assert_int_equal(log.total, 2 * 48); /* progress runs over both passes */
    assert_true(log.monotonic && log.last == 2 * 48);
    int grid = 0, over = 0;
    for (int i = 0; i < 64 * 48; i++) {
        const float *a = ad.rgb + 3 * i, *f = full.rgb + 3 * i, *c = one.rgb + 3 * i;
        int is_full = !memcmp(a, f, sizeof(float) * 3), is_centre = !memcmp(a, c, sizeof(float) * 3);
        assert_true(is_full || is_centre);
        grid += is_full && !is_centre;
        for (int k = 0; k < 3; k++)
            if (fabsf(a[k] - f[k]) > 2e-3f) {
                over++;
                break;
            }
    }
    assert_true(grid > 0);
    /* a small image of this scene is mostly edges: 34 pixels of 3072 are off
     * the regular grid's by more than 2e-3 at threshold 0.05 (where a
     * pixel's own samples differ, but not its centre from its neighbours') */
    assert_true(over * 50 < 64 * 48);
    image_free(&full);
    image_free(&one);
    image_free(&ad);
    image_free(&ad3);
}

/* Renders `path` at w x h, spp and aa threshold aa on `threads` threads:
 * the region r (x0, x1, y0, y1; NULL: all) into img, keeping the rows
 * whose done flag is set (done NULL: none); img must be set up by the
 * caller when done is given (a resumed render's rows). */
static void render_region(const char *path, int w, int h, int spp, float aa, int threads, const int *r,
                          unsigned char *done, Image *img, RayStats *st)
{
    char err[512];
    Scene s;
    RenderPlan p;
    assert_int_equal(scene_load(path, &s, err, sizeof err), 0);
    PlanOptions o = plan_options();
    o.width = w;
    o.height = h;
    o.spp = spp;
    o.aa_threshold = aa;
    o.threads = threads;
    if (r) {
        o.region = 1;
        o.rx0 = r[0];
        o.rx1 = r[1];
        o.ry0 = r[2];
        o.ry1 = r[3];
    }
    assert_int_equal(plan_build(&p, &s, &o, err, sizeof err), 0);
    Accel *a = accel_build(&s, p.variant, 1);
    assert_non_null(a);
    if (!done)
        assert_int_equal(image_init(img, p.x1 - p.x0, p.y1 - p.y0), 0);
    memset(st, 0, sizeof *st);
    RenderOptions opt = {NULL, NULL, NULL, done};
    assert_int_equal(render_image(&p, a, &opt, img, st), 0);
    accel_free(a);
    plan_free(&p);
    scene_free(&s);
}

/* Each pixel of region r of img is full's (w wide), bit for bit. */
static void assert_region_equal(const Image *img, const Image *full, const int *r)
{
    for (int y = r[2]; y < r[3]; y++)
        assert_memory_equal(img->rgb + (size_t)(y - r[2]) * (size_t)img->width * 3,
                            full->rgb + ((size_t)y * (size_t)full->width + (size_t)r[0]) * 3,
                            sizeof(float) * 3 * (size_t)(r[1] - r[0]));
}

/* A region renders the pixels of the whole render, bit for bit: with one
 * sample, the regular grid, and adaptive supersampling (whose decisions
 * look past the region's edges), on one thread and three, for regions at
 * the corners, in the middle, one pixel, one row and one column. */
static void test_regions_are_the_whole_renders_pixels(void **state)
{
    (void)state;
    const int w = 61, h = 45;
    static const int regions[][4] = {{0, 17, 0, 9}, {44, 61, 36, 45}, {13, 40, 11, 30}, {30, 31, 22, 23},
                                     {0, 61, 20, 21}, {7, 8, 0, 45}};
    static const struct {
        int spp;
        float aa;
    } modes[] = {{1, 0.0f}, {2, 0.0f}, {3, 0.05f}};
    for (int m = 0; m < 3; m++) {
        Image full;
        RayStats st, stf;
        render_region("scenes/parity/antialias.scn", w, h, modes[m].spp, modes[m].aa, 2, NULL, NULL, &full, &stf);
        assert_true(modes[m].aa == 0.0f || (stf.supersampled > 0 && stf.supersampled < (unsigned)(w * h)));
        for (size_t k = 0; k < sizeof regions / sizeof regions[0]; k++) {
            Image img;
            render_region("scenes/parity/antialias.scn", w, h, modes[m].spp, modes[m].aa, 1 + 2 * (int)(k % 2),
                          regions[k], NULL, &img, &st);
            assert_region_equal(&img, &full, regions[k]);
            long n = (long)(regions[k][1] - regions[k][0]) * (regions[k][3] - regions[k][2]);
            if (modes[m].aa == 0.0f) /* only its own pixels are traced */
                assert_int_equal(st.camera, (unsigned long long)(n * modes[m].spp * modes[m].spp));
            image_free(&img);
        }
        image_free(&full);
    }
}

/* A render resumed from any set of finished rows (kept as they are) ends
 * with the whole render's pixels, bit for bit, with adaptive
 * supersampling, in a region too; the rows kept are not traced again. */
static void test_resumed_render_is_the_whole_render(void **state)
{
    (void)state;
    const int w = 48, h = 37;
    const int whole[4] = {0, w, 0, h}, part[4] = {5, 40, 3, 30};
    Image full;
    RayStats st;
    render_region("scenes/parity/antialias.scn", w, h, 3, 0.05f, 1, NULL, NULL, &full, &st);
    for (int trial = 0; trial < 4; trial++) {
        const int *r = trial < 2 ? whole : part;
        int rh = r[3] - r[2], rw = r[1] - r[0];
        unsigned char done[64];
        Image img;
        assert_int_equal(image_init(&img, rw, rh), 0);
        unsigned long long seed = 0x9e3779b97f4a7c15ULL + (unsigned)trial;
        int kept = 0;
        for (int y = 0; y < rh; y++) {
            seed ^= seed << 13, seed ^= seed >> 7, seed ^= seed << 17;
            /* trial 0 and 2: a run of rows, as a stop leaves; 1 and 3: any */
            done[y] = (unsigned char)(trial % 2 ? (seed >> 20) % 2 : y >= 4 && y < rh - 9);
            if (done[y]) { /* the rows kept: the whole render's */
                memcpy(img.rgb + (size_t)y * (size_t)rw * 3,
                       full.rgb + ((size_t)(y + r[2]) * (size_t)w + (size_t)r[0]) * 3, sizeof(float) * 3 * (size_t)rw);
                kept++;
            }
        }
        assert_true(kept > 0 && kept < rh);
        render_region("scenes/parity/antialias.scn", w, h, 3, 0.05f, 2, r, done, &img, &st);
        assert_region_equal(&img, &full, r);
        for (int y = 0; y < rh; y++)
            assert_int_equal(done[y], 1);
        /* pass 1 traces the centres of the rows to do and their neighbours
         * only: fewer camera rays than the rows to do, twice, at spp 1 */
        assert_true(st.camera < (unsigned long long)(rw + 2) * (unsigned)(rh - kept) * 3 + 9ULL * st.supersampled);
        image_free(&img);
    }
    image_free(&full);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_thread_count_does_not_change_pixels),
        cmocka_unit_test(test_counts_and_progress),
        cmocka_unit_test(test_nesting_past_the_limit_is_counted),
        cmocka_unit_test(test_pixels_are_single_rays),
        cmocka_unit_test(test_stop_keeps_finished_rows),
        cmocka_unit_test(test_adaptive_mask_rule),
        cmocka_unit_test(test_adaptive_antialiasing),
        cmocka_unit_test(test_regions_are_the_whole_renders_pixels),
        cmocka_unit_test(test_resumed_render_is_the_whole_render),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
