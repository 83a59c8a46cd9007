/* Unit tests for camera.c: rays through pixel centres, right-handed. */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include "testutil.h"

#include "lancer/camera.h"

static CameraSpec spec(float fovy)
{
    CameraSpec c = {.eye = {0, 0, 0}, .target = {0, 0, 1}, .up = {0, 1, 0}, .fovy = fovy};
    return c;
}

static void test_centre_pixel_looks_at_target(void **state)
{
    (void)state;
    CameraSpec c = {.eye = {1, 2, 3}, .target = {1, 2, 10}, .up = {0, 1, 0}, .fovy = 40};
    Camera cam;
    camera_init(&cam, &c, 5, 3); /* odd sizes: pixel (2, 1) is centred */
    Ray r = camera_ray(&cam, 2.5f, 1.5f);
    assert_vec(r.o, 1, 2, 3, 0);
    assert_vec(r.d, 0, 0, 1, 1e-7);
}

static void test_corner_pixel_centre(void **state)
{
    (void)state;
    /* fovy 90: t = 1; W/H = 2. Pixel (0, 0) centre (0.5, 0.5) maps to
     * sx = 2*0.5/4 - 1 = -0.75 and sy = 1 - 2*0.5/2 = 0.5, so
     * d = f - 0.75*t*a*r + 0.5*t*u with r = f x up = (-1, 0, 0), u = (0, 1, 0):
     * (1.5, 0.5, 1) normalised. Screen left is +x: the camera is right-handed. */
    CameraSpec c = spec(90);
    Camera cam;
    camera_init(&cam, &c, 4, 2);
    Ray r = camera_ray(&cam, 0.5f, 0.5f);
    float n = sqrtf(1.5f * 1.5f + 0.25f + 1);
    assert_vec(r.d, 1.5f / n, 0.5f / n, 1 / n, 1e-6);
    /* the bottom-right pixel is its mirror image */
    r = camera_ray(&cam, 3.5f, 1.5f);
    assert_vec(r.d, -1.5f / n, -0.5f / n, 1 / n, 1e-6);
}

static void test_vertical_field_of_view(void **state)
{
    (void)state;
    /* the top edge of the image (y = 0) is fovy/2 above the view direction */
    CameraSpec c = spec(60);
    Camera cam;
    camera_init(&cam, &c, 100, 100);
    Ray r = camera_ray(&cam, 50, 0);
    assert_float_equal(atan2f(r.d.y, r.d.z), 30 * 3.14159265f / 180, 1e-6);
}

static void test_rays_are_camera_ray(void **state)
{
    (void)state;
    /* camera_rays (four at a time) gives camera_ray's rays bit for bit,
     * for every count, on cameras looking every way. */
    unsigned long long rng = 7;
    for (int c = 0; c < 200; c++) {
        CameraSpec cs = {.eye = test_rvec(&rng, -5, 5), .target = test_rvec(&rng, -5, 5), .up = {0, 1, 0}, .fovy = test_uniform(&rng, 5, 150)};
        Camera cam;
        camera_init(&cam, &cs, 640, 480);
        float x[11], y[11];
        for (int k = 0; k < 11; k++) {
            x[k] = test_uniform(&rng, -10, 650);
            y[k] = test_uniform(&rng, -10, 490);
        }
        for (int n = 0; n <= 11; n++) {
            Ray got[11];
            camera_rays(&cam, x, y, n, got);
            for (int k = 0; k < n; k++) {
                Ray want = camera_ray(&cam, x[k], y[k]);
                assert_memory_equal(&got[k], &want, sizeof want);
            }
        }
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_centre_pixel_looks_at_target),
        cmocka_unit_test(test_corner_pixel_centre),
        cmocka_unit_test(test_vertical_field_of_view),
        cmocka_unit_test(test_rays_are_camera_ray),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
