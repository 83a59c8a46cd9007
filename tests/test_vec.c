/* Unit tests for vec.h. */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include "testutil.h"

#include "lancer/vec.h"

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

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_arithmetic),
        cmocka_unit_test(test_cross_is_right_handed),
        cmocka_unit_test(test_length_and_normalize),
        cmocka_unit_test(test_reflect_and_misc),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
