/* Tests for rayfile.c: round trip, the byte layout, tmin, and bad files. */
#include <stdarg.h>
#include <stddef.h>
#include <float.h>
#include <stdint.h>
#include <setjmp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include <cmocka.h>

#include "lancer/rayfile.h"

static char dir[64], path[128];

static int setup(void **state)
{
    (void)state;
    snprintf(dir, sizeof dir, "/tmp/lancer-rays-XXXXXX");
    if (!mkdtemp(dir))
        return -1;
    snprintf(path, sizeof path, "%s/r.rays", dir);
    return 0;
}

static int teardown(void **state)
{
    (void)state;
    remove(path);
    rmdir(dir);
    return 0;
}

static void write_bytes(const void *p, size_t n)
{
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(p, 1, n, f), n);
    fclose(f);
}

static void test_round_trip_and_layout(void **state)
{
    (void)state;
    Ray in[2] = {ray_make(vec3(1, 2, 3), vec3(0, 0, 1), INFINITY), ray_make(vec3(-1, 0.5f, 0), vec3(1, 0, 0), 7)};
    char err[256];
    assert_int_equal(rayfile_write(path, in, 2, err, sizeof err), 0);
    FILE *f = fopen(path, "rb");
    unsigned char b[16 + 64];
    assert_int_equal(fread(b, 1, sizeof b, f), sizeof b);
    assert_int_equal(fgetc(f), EOF); /* exactly 16 + 2 * 32 bytes */
    fclose(f);
    assert_memory_equal(b, "LNCRAYS1\x02\0\0\0\0\0\0\0", 16); /* magic, little-endian count */
    float ox;
    memcpy(&ox, b + 16, 4); /* this machine is little-endian, like the format */
    assert_float_equal(ox, 1, 0);
    Ray *out;
    size_t n;
    assert_int_equal(rayfile_read(path, &out, &n, err, sizeof err), 0);
    assert_int_equal(n, 2);
    assert_memory_equal(&out[1], &in[1], sizeof(Ray));
    assert_true(isinf(out[0].tmax));
    free(out);
}

/* rayfile_write_stream writes the same bytes into a stream that
 * rayfile_write puts in place, and says when a write failed. */
static void test_write_stream(void **state)
{
    (void)state;
    Ray in[3] = {ray_make(vec3(1, 2, 3), vec3(0, 0, 1), INFINITY), ray_make(vec3(-1, 0.5f, 0), vec3(1, 0, 0), 7),
                 ray_make(vec3(0, 0, 0), vec3(0.6f, 0.8f, 0), 2)};
    char err[256];
    assert_int_equal(rayfile_write(path, in, 3, err, sizeof err), 0);
    unsigned char want[16 + 3 * 32], got[sizeof want + 1];
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    assert_int_equal(fread(want, 1, sizeof want, f), sizeof want);
    fclose(f);
    f = tmpfile();
    assert_non_null(f);
    assert_int_equal(rayfile_write_stream(f, in, 3), 0);
    rewind(f);
    assert_int_equal(fread(got, 1, sizeof got, f), sizeof want);
    fclose(f);
    assert_memory_equal(got, want, sizeof want);
    f = fopen(path, "rb"); /* a stream open for reading: every write fails */
    assert_non_null(f);
    assert_int_equal(rayfile_write_stream(f, in, 3), -1);
    fclose(f);
}

static void test_tmin_moves_the_origin(void **state)
{
    (void)state;
    unsigned char b[16 + 32];
    memcpy(b, "LNCRAYS1\x01\0\0\0\0\0\0\0", 16);
    const float v[8] = {0, 0, 0, 0, 0, 2, 0.5f, 10}; /* tmin 0.5 along d = (0, 0, 2) */
    memcpy(b + 16, v, sizeof v);
    write_bytes(b, sizeof b);
    Ray *r;
    size_t n;
    char err[256];
    assert_int_equal(rayfile_read(path, &r, &n, err, sizeof err), 0);
    assert_float_equal(r[0].o.z, 1, 0);
    assert_float_equal(r[0].tmax, 9.5f, 0);
    free(r);
}

static void test_bad_files(void **state)
{
    (void)state;
    Ray *r = (Ray *)1;
    size_t n = 7;
    char err[256], want[256];
    write_bytes("LNCRAYS2\0\0\0\0\0\0\0\0", 16);
    assert_int_equal(rayfile_read(path, &r, &n, err, sizeof err), -1);
    assert_null(r);
    assert_int_equal(n, 0);
    snprintf(want, sizeof want, "%s: not a ray file (it must start with LNCRAYS1 and a count)", path);
    assert_string_equal(err, want);
    unsigned char b[16 + 32];
    memcpy(b, "LNCRAYS1\x02\0\0\0\0\0\0\0", 16); /* two announced, one there */
    memset(b + 16, 0, 32);
    write_bytes(b, sizeof b);
    assert_int_equal(rayfile_read(path, &r, &n, err, sizeof err), -1);
    snprintf(want, sizeof want, "%s: the count (2 rays) disagrees with the file size (48 bytes)", path);
    assert_string_equal(err, want);
    b[8] = 1;
    const float nanv = NAN;
    memcpy(b + 16 + 12, &nanv, 4);
    write_bytes(b, sizeof b);
    assert_int_equal(rayfile_read(path, &r, &n, err, sizeof err), -1);
    snprintf(want, sizeof want, "%s: ray 0 has a non-finite value", path);
    assert_string_equal(err, want);
    remove(path);
    assert_int_equal(rayfile_read(path, &r, &n, err, sizeof err), -1);
    snprintf(want, sizeof want, "%s: cannot open: No such file or directory", path);
    assert_string_equal(err, want);
}

/* From memory: a zero direction, one too short to trace, and a tmin that
 * throws the origin out of float range, are refused by ray; rayfile_ray_ok
 * agrees. */
static void test_parse_refuses_untraceable_rays(void **state)
{
    (void)state;
    unsigned char b[16 + 32];
    memcpy(b, "LNCRAYS1\x01\0\0\0\0\0\0\0", 16);
    Ray *r;
    size_t n;
    char err[256];
    const float zero[8] = {1, 2, 3, 0, 0, 0, 0, 10};
    memcpy(b + 16, zero, sizeof zero);
    assert_int_equal(rayfile_parse("mem", b, sizeof b, &r, &n, err, sizeof err), -1);
    assert_string_equal(err, "mem: ray 0 has a zero direction");
    /* every component subnormal: 1 / d overflowed, and the BVH let the ray
     * pass a mesh it hits at t = 10^39 * distance (it read as a miss) */
    const float tiny[8] = {0, 0, -5, 1e-45f, -1e-40f, 1e-39f, 0, INFINITY};
    memcpy(b + 16, tiny, sizeof tiny);
    assert_int_equal(rayfile_parse("mem", b, sizeof b, &r, &n, err, sizeof err), -1);
    assert_string_equal(err,
                        "mem: ray 0 has a direction too short to trace (no component of at least FLT_MIN, 2^-126)");
    const float least[8] = {0, 0, -5, 1e-45f, 0, FLT_MIN, 0, INFINITY};
    memcpy(b + 16, least, sizeof least);
    assert_int_equal(rayfile_parse("mem", b, sizeof b, &r, &n, err, sizeof err), 0);
    assert_true(rayfile_ray_ok(&r[0]));
    free(r);
    const float far[8] = {0, 0, 0, 0, 0, 3e38f, 3e38f, INFINITY};
    memcpy(b + 16, far, sizeof far);
    assert_int_equal(rayfile_parse("mem", b, sizeof b, &r, &n, err, sizeof err), -1);
    assert_string_equal(err, "mem: ray 0 has a tmin that moves its origin out of float range");
    const float fine[8] = {0, 0, 0, 0, 0, 3e38f, 0, INFINITY};
    memcpy(b + 16, fine, sizeof fine);
    assert_int_equal(rayfile_parse("mem", b, sizeof b, &r, &n, err, sizeof err), 0);
    assert_int_equal(n, 1);
    assert_true(rayfile_ray_ok(&r[0]));
    r[0].tmax = NAN;
    assert_false(rayfile_ray_ok(&r[0]));
    free(r);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_round_trip_and_layout),
        cmocka_unit_test(test_write_stream),
        cmocka_unit_test(test_tmin_moves_the_origin),
        cmocka_unit_test(test_bad_files),
        cmocka_unit_test(test_parse_refuses_untraceable_rays),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
