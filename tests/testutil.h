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

#endif
