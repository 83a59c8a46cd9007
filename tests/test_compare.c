/* Tests for compare.c against differences worked out by hand. */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <math.h>
#include <cmocka.h>

#include "lancer/compare.h"

static void fill(Image *img, int w, int h, float v)
{
    assert_int_equal(image_init(img, w, h), 0);
    for (int i = 0; i < 3 * w * h; i++)
        img->rgb[i] = v;
}

static void test_identical(void **state)
{
    (void)state;
    Image a, b;
    fill(&a, 4, 3, 0.5f);
    fill(&b, 4, 3, 0.5f);
    b.rgb[0] = a.rgb[0] = INFINITY; /* equal infinities differ by nothing */
    CompareStats st;
    char err[128];
    assert_int_equal(compare_images(&a, &b, COMPARE_THRESHOLD, 0.0, &st, err, sizeof err), 0);
    assert_true(st.max == 0 && st.mean == 0 && st.rms == 0 && st.over == 0);
    assert_true(isinf(st.psnr));
    assert_int_equal(st.pixels, 12);
    image_free(&a);
    image_free(&b);
}

static void test_known_differences(void **state)
{
    (void)state;
    Image a, b;
    fill(&a, 2, 2, 0.0f);
    fill(&b, 2, 2, 0.0f);
    /* pixel (1,0): green off by 0.01; pixel (0,1): all three off by 0.001 */
    b.rgb[3 * 1 + 1] = 0.01f;
    for (int c = 0; c < 3; c++)
        b.rgb[3 * 2 + c] = 0.001f;
    CompareStats st;
    char err[128];
    assert_int_equal(compare_images(&a, &b, COMPARE_THRESHOLD, 0.0, &st, err, sizeof err), 0);
    assert_float_equal(st.max, 0.01, 1e-9);
    assert_int_equal(st.max_x, 1);
    assert_int_equal(st.max_y, 0);
    assert_int_equal(st.over, 1); /* 0.001 is under the threshold */
    assert_float_equal(st.mean, (0.01 + 3 * 0.001) / 12, 1e-9);
    double mse = (1e-4 + 3e-6) / 12;
    assert_float_equal(st.rms, sqrt(mse), 1e-9);
    assert_float_equal(st.psnr, 10 * log10(1 / mse), 1e-4);
    image_free(&a);
    image_free(&b);
}

/* Bright values against their half-float rounding (a review: POV-Ray's
 * 8.0781 against lancer's 8.0810, 2^-11 of 8 apart, counted as over): with
 * relative 2^-11 they are within, while 0.003 between small values is
 * still over, and so is a NaN. */
static void test_relative_tolerance(void **state)
{
    (void)state;
    Image a, b;
    fill(&a, 3, 1, 0.0f);
    fill(&b, 3, 1, 0.0f);
    a.rgb[0] = 8.0810f;
    b.rgb[0] = 8.0781f;
    a.rgb[3] = 0.5f;
    b.rgb[3] = 0.503f;
    a.rgb[6] = NAN;
    CompareStats st;
    char err[128];
    assert_int_equal(compare_images(&a, &b, COMPARE_THRESHOLD, 0.0, &st, err, sizeof err), 0);
    assert_int_equal(st.over, 3);
    assert_int_equal(compare_images(&a, &b, COMPARE_THRESHOLD, COMPARE_HALF, &st, err, sizeof err), 0);
    assert_int_equal(st.over, 2);
    /* a difference of exactly relative times the larger value is within
     * (0.25 between 1 and 0.75 at relative 0.25; 0.003 is then within too) */
    a.rgb[0] = 1.0f;
    b.rgb[0] = 0.75f;
    assert_int_equal(compare_images(&a, &b, COMPARE_THRESHOLD, 0.25, &st, err, sizeof err), 0);
    assert_int_equal(st.over, 1); /* the NaN */
    assert_int_equal(compare_images(&a, &b, COMPARE_THRESHOLD, 0.2499, &st, err, sizeof err), 0);
    assert_int_equal(st.over, 2);
    image_free(&a);
    image_free(&b);
}

/* The largest difference's place in an image wider than tall, and taller
 * than wide: x along the row, y down the rows. */
static void test_max_place(void **state)
{
    (void)state;
    const int sizes[2][2] = {{7, 3}, {3, 7}};
    for (int k = 0; k < 2; k++) {
        const int w = sizes[k][0], h = sizes[k][1];
        Image a, b;
        fill(&a, w, h, 0.0f);
        fill(&b, w, h, 0.0f);
        b.rgb[3 * (2 * w + 1) + 2] = 0.5f; /* (1, 2) */
        CompareStats st;
        char err[128];
        assert_int_equal(compare_images(&a, &b, COMPARE_THRESHOLD, 0.0, &st, err, sizeof err), 0);
        assert_int_equal(st.max_x, 1);
        assert_int_equal(st.max_y, 2);
        image_free(&a);
        image_free(&b);
    }
}

static void test_nan_and_size_mismatch(void **state)
{
    (void)state;
    Image a, b, c;
    fill(&a, 2, 1, 0.0f);
    fill(&b, 2, 1, 0.0f);
    fill(&c, 1, 2, 0.0f);
    b.rgb[4] = NAN;
    CompareStats st;
    char err[128];
    assert_int_equal(compare_images(&a, &b, COMPARE_THRESHOLD, 0.0, &st, err, sizeof err), 0);
    assert_true(isinf(st.max));
    assert_int_equal(st.over, 1);
    /* a NaN against a NaN differs by 0: an image with NaNs is its own
     * equal (it once differed from itself by infinity) */
    assert_int_equal(compare_images(&b, &b, COMPARE_THRESHOLD, 0.0, &st, err, sizeof err), 0);
    assert_true(st.max == 0.0);
    assert_int_equal(st.over, 0);
    assert_int_equal(compare_images(&a, &c, COMPARE_THRESHOLD, 0.0, &st, err, sizeof err), -1);
    assert_string_equal(err, "the images differ in size: 2x1 and 1x2");
    image_free(&a);
    image_free(&b);
    image_free(&c);
}

static void test_downsample(void **state)
{
    (void)state;
    Image big, small;
    char err[128];
    assert_int_equal(image_init(&big, 4, 2), 0);
    for (int i = 0; i < 4 * 2; i++)
        for (int c = 0; c < 3; c++)
            big.rgb[3 * i + c] = (float)(i * (c + 1)); /* value: pixel index times channel */
    assert_int_equal(compare_downsample(&big, 2, &small, err, sizeof err), 0);
    assert_int_equal(small.width, 2);
    assert_int_equal(small.height, 1);
    /* block 0 holds pixels 0, 1, 4, 5: mean index 2.5; block 1: 2, 3, 6, 7: 4.5 */
    assert_float_equal(small.rgb[0], 2.5f, 0);
    assert_float_equal(small.rgb[2], 7.5f, 0);
    assert_float_equal(small.rgb[3], 4.5f, 0);
    image_free(&small);
    assert_int_equal(compare_downsample(&big, 3, &small, err, sizeof err), -1);
    assert_string_equal(err, "a 4x2 image cannot be averaged in 3x3 blocks");
    image_free(&big);
}

static void test_heatmap_colours(void **state)
{
    (void)state;
    Image a, b, h;
    char err[128];
    fill(&a, 4, 1, 0.0f);
    fill(&b, 4, 1, 0.0f);
    b.rgb[3] = 1e-4f;                      /* blue */
    b.rgb[6] = (float)COMPARE_THRESHOLD;   /* yellow */
    b.rgb[9] = 1.0f;                       /* red */
    assert_int_equal(compare_heatmap(&a, &b, COMPARE_THRESHOLD, &h, err, sizeof err), 0);
    const float want[4][3] = {{0, 0, 0}, {0, 0, 1}, {1, 1, 0}, {1, 0, 0}};
    for (int i = 0; i < 4; i++)
        for (int c = 0; c < 3; c++)
            assert_float_equal(h.rgb[3 * i + c], want[i][c], 1e-4);
    image_free(&h);
    /* a threshold below the default's stops: the same colours at the same
     * fractions of it (at 1e-6, the pixels over it were black) */
    const double t = 1e-6;
    b.rgb[3] = (float)(t / 20);
    b.rgb[6] = (float)t;
    b.rgb[9] = (float)(100 * t);
    assert_int_equal(compare_heatmap(&a, &b, t, &h, err, sizeof err), 0);
    for (int i = 0; i < 4; i++)
        for (int c = 0; c < 3; c++)
            assert_float_equal(h.rgb[3 * i + c], want[i][c], 1e-4);
    image_free(&a);
    image_free(&b);
    image_free(&h);
}

/* Two parts of one picture, as many pixels each, are not compared as if
 * they were the same pixels (lancer diff found two crops of a render the
 * same); a render at 2x averaged down keeps its place in its picture. */
static void test_parts_of_pictures(void **state)
{
    (void)state;
    Image a, b, big, small;
    CompareStats st;
    char err[256];
    fill(&a, 4, 3, 0.5f);
    fill(&b, 4, 3, 0.5f);
    a.full_width = b.full_width = 10;
    a.full_height = b.full_height = 6;
    b.x = 6;
    assert_int_equal(compare_images(&a, &b, COMPARE_THRESHOLD, 0.0, &st, err, sizeof err), -1);
    assert_string_equal(err, "the images are different parts of their pictures: 4x3 at 0,0 of 10x6 and at 6,0 of 10x6");
    b.x = 0; /* the same place in pictures of two heights */
    b.full_height = 7;
    assert_int_equal(compare_images(&a, &b, COMPARE_THRESHOLD, 0.0, &st, err, sizeof err), -1);
    assert_string_equal(err, "the images are different parts of their pictures: 4x3 at 0,0 of 10x6 and at 0,0 of 10x7");
    b.x = 6;
    b.full_height = 6;
    assert_int_equal(compare_heatmap(&a, &b, COMPARE_THRESHOLD, &small, err, sizeof err), -1);
    fill(&big, 8, 6, 0.5f);
    big.x = 12;
    big.y = 0;
    big.full_width = 20;
    big.full_height = 12;
    assert_int_equal(compare_downsample(&big, 2, &small, err, sizeof err), 0);
    a.x = 6; /* where the averaged part lies */
    assert_int_equal(small.x, 6);
    assert_int_equal(small.full_width, 10);
    assert_int_equal(compare_images(&a, &small, COMPARE_THRESHOLD, 0.0, &st, err, sizeof err), 0);
    image_free(&small);
    big.x = 3; /* not on the blocks' grid */
    assert_int_equal(compare_downsample(&big, 2, &small, err, sizeof err), -1);
    assert_string_equal(err, "a 8x6 part at 3,0 of a 20x12 picture cannot be averaged in 2x2 blocks");
    image_free(&a);
    image_free(&b);
    image_free(&big);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_identical),      cmocka_unit_test(test_known_differences),
        cmocka_unit_test(test_nan_and_size_mismatch), cmocka_unit_test(test_downsample),
        cmocka_unit_test(test_heatmap_colours),
        cmocka_unit_test(test_parts_of_pictures),
        cmocka_unit_test(test_relative_tolerance),
        cmocka_unit_test(test_max_place),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
