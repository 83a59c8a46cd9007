/*
 * testutil.h - helpers shared by the cmocka test programs. Include it after
 * <cmocka.h>.
 */
#ifndef LANCER_TESTUTIL_H
#define LANCER_TESTUTIL_H

#include <stdio.h>
#include <sys/stat.h>
#include <unistd.h>

#include "lancer/prim.h"
#include "lancer/vec.h"

/* Each component of v within tol of (x, y, z). */
static inline void assert_vec(Vec3 v, float x, float y, float z, float tol)
{
    assert_float_equal(v.x, x, tol);
    assert_float_equal(v.y, y, tol);
    assert_float_equal(v.z, z, tol);
}

/* 1 with *sf filled when ray r hits p (variant v), else 0. */
static inline int test_surface(const Prim *p, const Ray *r, PrimVariant v, Surface *sf)
{
    PrimHit h;
    if (!prim_intersect(p, r, v, &h))
        return 0;
    prim_surface(p, r, &h, v, sf);
    return 1;
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

/* Seeds for the fuzzers (tests/fuzz): a test program run as `test_x
 * --seeds DIR` writes the inputs of its tables, good and bad, under DIR.
 * test_seed_path makes DIR/sub and puts "DIR/sub/name" in buf (len bytes);
 * test_write_seed writes len bytes there. Both return 0, or -1 after a
 * message. */
static inline int test_seed_path(const char *dir, const char *sub, const char *name, char *buf, size_t len)
{
    int n = snprintf(buf, len, "%s/%s", dir, sub);
    if (n >= 0 && (size_t)n < len) {
        mkdir(dir, 0777); /* either may exist already */
        mkdir(buf, 0777);
    }
    if (n < 0 || (size_t)n >= len || access(buf, W_OK) != 0) {
        fprintf(stderr, "cannot make %s/%s\n", dir, sub);
        return -1;
    }
    n = snprintf(buf, len, "%s/%s/%s", dir, sub, name);
    return n < 0 || (size_t)n >= len ? -1 : 0;
}

static inline int test_write_seed(const char *dir, const char *sub, const char *name, const void *data, size_t len)
{
    char path[512];
    if (test_seed_path(dir, sub, name, path, sizeof path) != 0)
        return -1;
    FILE *f = fopen(path, "wb");
    int ok = f && fwrite(data, 1, len, f) == len;
    if (f && fclose(f) != 0)
        ok = 0;
    if (!ok)
        fprintf(stderr, "cannot write %s\n", path);
    return ok ? 0 : -1;
}

#endif
