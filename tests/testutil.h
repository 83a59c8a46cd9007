/*
 * testutil.h - helpers shared by the cmocka test programs. Include it after
 * <cmocka.h>.
 */
#ifndef LANCER_TESTUTIL_H
#define LANCER_TESTUTIL_H

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <unistd.h>

#include "lancer/prim.h"
#include "lancer/vec.h"

/* The slots that keys of hashes h[0 .. n-1] look at, put one by one into a
 * table of linear probing of nslots (a power of two, more than n), as the
 * readers' hash tables are. */
static inline long test_probes(const uint64_t *h, int n, size_t nslots)
{
    unsigned char *taken = calloc(nslots, 1);
    if (!taken)
        abort();
    long probes = 0;
    for (int k = 0; k < n; k++) {
        size_t i = (size_t)h[k] & (nslots - 1);
        for (probes++; taken[i]; probes++)
            i = (i + 1) & (nslots - 1);
        taken[i] = 1;
    }
    free(taken);
    return probes;
}

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

/* Makes the folder dir (a mkdtemp template) and in it the file `name`
 * holding text, whose path goes into path (len bytes). */
static inline void test_temp_file(char *dir, const char *name, const char *text, char *path, size_t len)
{
    assert_non_null(mkdtemp(dir));
    snprintf(path, len, "%s/%s", dir, name);
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs(text, f);
    fclose(f);
}

/* The OFF file of the box lo..hi as 12 triangles, outward, into buf. */
static inline void test_box_off(const float lo[3], const float hi[3], char *buf, size_t len)
{
    int n = snprintf(buf, len, "OFF\n8 12 0\n");
    for (int k = 0; k < 8; k++) /* corner k: x from bit 0 ^ bit 1, y from bit 1, z from bit 2 */
        n += snprintf(buf + n, len - (size_t)n, "%.9g %.9g %.9g\n", (double)((k & 1) ^ (k >> 1 & 1) ? hi[0] : lo[0]),
                      (double)(k & 2 ? hi[1] : lo[1]), (double)(k & 4 ? hi[2] : lo[2]));
    snprintf(buf + n, len - (size_t)n, "3 0 2 1\n3 0 3 2\n3 4 5 6\n3 4 6 7\n3 0 1 5\n3 0 5 4\n3 3 7 6\n3 3 6 2\n"
                                       "3 0 4 7\n3 0 7 3\n3 1 2 6\n3 1 6 5\n");
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
