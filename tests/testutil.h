/*
 * testutil.h - helpers shared by the cmocka test programs. Include it after
 * <cmocka.h>.
 */
#ifndef LANCER_TESTUTIL_H
#define LANCER_TESTUTIL_H

#include "lancer/vec.h"

/* Each component of v within tol of (x, y, z). */
static inline void assert_vec(Vec3 v, float x, float y, float z, float tol)
{
    assert_float_equal(v.x, x, tol);
    assert_float_equal(v.y, y, tol);
    assert_float_equal(v.z, z, tol);
}

/* xorshift64, uniform in [lo, hi): the same sequence on every machine. */
static inline float test_uniform(unsigned long long *s, float lo, float hi)
{
    *s ^= *s << 13;
    *s ^= *s >> 7;
    *s ^= *s << 17;
    return lo + (hi - lo) * (float)((double)(*s >> 11) / 9007199254740992.0);
}

static inline Vec3 test_rvec(unsigned long long *s, float lo, float hi)
{
    float x = test_uniform(s, lo, hi), y = test_uniform(s, lo, hi);
    return vec3(x, y, test_uniform(s, lo, hi));
}

#endif
