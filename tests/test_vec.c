/* Unit tests for vec.h and src/dvec.h. */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include "testutil.h"

#include "lancer/vec.h"
#include "../src/dvec.h"

static void test_arithmetic(void **state)
{
    (void)state;
    Vec3 a = vec3(1, 2, 3), b = vec3(-4, 5, 0.5f);
    assert_vec(vec_add(a, b), -3, 7, 3.5f, 0);
    assert_vec(vec_sub(a, b), 5, -3, 2.5f, 0);
    assert_vec(vec_mul(a, b), -4, 10, 1.5f, 0);
    assert_vec(vec_scale(a, 2), 2, 4, 6, 0);
    assert_vec(vec_neg(a), -1, -2, -3, 0);
    assert_vec(vec_madd(a, b, 2), -7, 12, 4, 0);
    assert_float_equal(vec_dot(a, b), -4 + 10 + 1.5f, 0);
}

static void test_cross_is_right_handed(void **state)
{
    (void)state;
    assert_vec(vec_cross(vec3(1, 0, 0), vec3(0, 1, 0)), 0, 0, 1, 0);
    assert_vec(vec_cross(vec3(0, 1, 0), vec3(0, 0, 1)), 1, 0, 0, 0);
    assert_vec(vec_cross(vec3(0, 0, 1), vec3(1, 0, 0)), 0, 1, 0, 0);
    /* a x b is orthogonal to both */
    Vec3 a = vec3(1, 2, 3), b = vec3(-2, 0.5f, 4);
    Vec3 c = vec_cross(a, b);
    assert_float_equal(vec_dot(c, a), 0, 1e-5);
    assert_float_equal(vec_dot(c, b), 0, 1e-5);
}

static void test_length_and_normalize(void **state)
{
    (void)state;
    assert_float_equal(vec_length(vec3(3, 4, 12)), 13, 0);
    assert_vec(vec_normalize(vec3(0, 0, -7)), 0, 0, -1, 0);
    assert_float_equal(vec_length(vec_normalize(vec3(1, 2, 3))), 1, 1e-6);
    /* a zero vector stays zero instead of becoming NaN */
    assert_vec(vec_normalize(vec3(0, 0, 0)), 0, 0, 0, 0);
}

static void test_reflect_and_misc(void **state)
{
    (void)state;
    /* 45 degrees onto a floor comes back up at 45 degrees */
    assert_vec(vec_reflect(vec3(1, -1, 0), vec3(0, 1, 0)), 1, 1, 0, 0);
    assert_float_equal(vec_max_abs(vec3(-5, 2, 4)), 5, 0);
    assert_true(vec_is_finite(vec3(1, 2, 3)));
    assert_false(vec_is_finite(vec3(1, INFINITY, 3)));
    assert_false(vec_is_finite(vec3(NAN, 0, 0)));
}

/* The difference of two floats is exact in double: here 2^24 + 2 and 1
 * differ by 2^24 + 1, which no float holds. */
static void test_d3_sub_is_exact(void **state)
{
    (void)state;
    double r[3];
    d3_sub(r, vec3(16777218.0f, 1.0f, -0.1f), vec3(1.0f, 16777218.0f, 0.1f));
    assert_true(r[0] == 16777217.0);
    assert_true(r[1] == -16777217.0);
    assert_true(r[2] == -2.0 * (double)0.1f);
}

static void test_d3_cross_and_dot(void **state)
{
    (void)state;
    const double x[3] = {1, 0, 0}, y[3] = {0, 1, 0}, z[3] = {0, 0, 1};
    const double u[3] = {1, 2, 3}, w[3] = {-4, 5, 0.5};
    double r[3];
    d3_cross(r, x, y); /* right-handed */
    assert_true(r[0] == 0.0 && r[1] == 0.0 && r[2] == 1.0);
    d3_cross(r, y, z);
    assert_true(r[0] == 1.0 && r[1] == 0.0 && r[2] == 0.0);
    d3_cross(r, u, w);
    assert_true(r[0] == 2 * 0.5 - 3 * 5 && r[1] == 3 * -4 - 1 * 0.5 && r[2] == 1 * 5 - 2 * -4);
    assert_true(d3_dot(r, u) == 0.0 && d3_dot(r, w) == 0.0);
    assert_true(d3_dot(u, w) == -4 + 10 + 1.5);
    /* a product float would round: (2^24 + 1)^2 is exact in double */
    const double big[3] = {16777217.0, 0, 0};
    assert_true(d3_dot(big, big) == 281475010265089.0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_arithmetic),
        cmocka_unit_test(test_cross_is_right_handed),
        cmocka_unit_test(test_length_and_normalize),
        cmocka_unit_test(test_reflect_and_misc),
        cmocka_unit_test(test_d3_sub_is_exact),
        cmocka_unit_test(test_d3_cross_and_dot),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
