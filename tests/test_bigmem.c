/* Unit tests for bigmem.c: big_zalloc's memory is zeroed and writable to
 * its last byte at every size, small and large; a large allocation is
 * aligned and, on Linux with transparent huge pages, advised as huge
 * pages; big_realloc keeps the bytes in use; the large arrays of a scene
 * (an image's pixels, a file read whole, a mesh file's vertices and
 * triangles, a mesh's primitives, the BVH) are in huge pages; AddressSanitizer still sees a write past a large
 * allocation's end; and the sizes it refuses. */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include <cmocka.h>

#include "testutil.h"

#include "lancer/afile.h"
#include "lancer/bvh.h"
#include "lancer/image.h"
#include "lancer/mesh.h"
#include "lancer/scene.h"
#include "../src/bigmem.h"

#if defined(__SANITIZE_ADDRESS__)
#include <sanitizer/asan_interface.h>
#endif

#define HUGE ((uintptr_t)2 << 20)

/* p[0 .. n-1] reads 0, then takes a write at both ends. */
static void assert_zeroed_writable(unsigned char *p, size_t n)
{
    for (size_t i = 0; i < n; i++)
        if (p[i] != 0)
            fail_msg("byte %zu of %zu is %d", i, n, p[i]);
    p[0] = 1;
    p[n - 1] = 1;
    assert_int_equal(p[0] + p[n - 1], 2);
}

static void test_zeroed_at_every_size(void **state)
{
    (void)state;
    const size_t sizes[] = {1, 3, 64, 4096, BIG_MIN - 1, BIG_MIN, BIG_MIN + 1, (size_t)2 << 20,
                            ((size_t)2 << 20) - 64, ((size_t)2 << 20) - 63, (size_t)5 << 20};
    for (size_t i = 0; i < sizeof sizes / sizeof sizes[0]; i++) {
        unsigned char *p = big_zalloc(sizes[i]);
        assert_non_null(p);
        assert_int_equal((uintptr_t)p % 16, 0);
        assert_zeroed_writable(p, sizes[i]);
        big_free(p);
    }
    /* freed memory dirtied, then the same size again: zeroed all the same */
    for (int round = 0; round < 3; round++) {
        unsigned char *p = big_zalloc((size_t)3 << 20);
        assert_non_null(p);
        assert_zeroed_writable(p, (size_t)3 << 20);
        memset(p, 0xab, (size_t)3 << 20);
        big_free(p);
    }
}

static void test_refuses_zero_and_overflow(void **state)
{
    (void)state;
    assert_null(big_zalloc(0));
    assert_null(big_zalloc(SIZE_MAX));
    assert_null(big_zalloc(SIZE_MAX - 100));
    big_free(NULL);
}

#if defined(__linux__)
/* The VmFlags of the mapping that holds p in /proc/self/smaps into flags;
 * 0, or -1 when not found. */
static int vm_flags(const void *p, char *flags, size_t len)
{
    FILE *f = fopen("/proc/self/smaps", "r");
    if (!f)
        return -1;
    char line[512];
    int in = 0, rc = -1;
    while (fgets(line, sizeof line, f)) {
        unsigned long lo, hi;
        char dash;
        if (sscanf(line, "%lx%c%lx ", &lo, &dash, &hi) == 3 && dash == '-') {
            in = (uintptr_t)p >= lo && (uintptr_t)p < hi;
            continue;
        }
        if (in && strncmp(line, "VmFlags:", 8) == 0) {
            snprintf(flags, len, "%s", line + 8);
            rc = 0;
            break;
        }
    }
    fclose(f);
    return rc;
}
#endif

/* Whether this kernel has transparent huge pages: the checks of the
 * advice are skipped where it has none. */
static int have_thp(void)
{
#if defined(__linux__)
    FILE *thp = fopen("/sys/kernel/mm/transparent_hugepage/enabled", "r");
    if (!thp)
        return 0;
    fclose(thp);
    return 1;
#else
    return 0;
#endif
}

/* Whether p lies in a mapping that madvise marked for huge pages
 * (VmFlags "hg"). */
static int in_huge_pages(const void *p)
{
#if defined(__linux__)
    char flags[512];
    assert_int_equal(vm_flags(p, flags, sizeof flags), 0);
    return strstr(flags, " hg") != NULL;
#else
    (void)p;
    return 0;
#endif
}

/* A block of big_realloc's: aligned to 2 MiB, in huge pages to its last
 * byte (where the kernel has them). */
static void assert_big(const void *p, size_t n)
{
    if (!have_thp())
        return;
    assert_int_equal((uintptr_t)p % HUGE, 0);
    assert_true(in_huge_pages(p));
    assert_true(in_huge_pages((const char *)p + n - 1));
}

/* A large allocation starts 64 bytes into a mapping advised as huge
 * pages, and ends in it; a small one is calloc's. */
static void test_large_in_huge_pages(void **state)
{
    (void)state;
    if (!have_thp()) {
        printf("  (no transparent huge pages here: skipped)\n");
        return;
    }
    const size_t n = (size_t)3 << 20;
    unsigned char *p = big_zalloc(n);
    assert_non_null(p);
    assert_int_equal((uintptr_t)p % HUGE, 64);
    assert_true(in_huge_pages(p));
    assert_true(in_huge_pages(p + n - 1));
    big_free(p);
    p = big_zalloc(4096);
    assert_non_null(p);
    assert_false(in_huge_pages(p));
    big_free(p);
}

/* big_realloc keeps the bytes in use, at every size and across the
 * threshold both ways; large blocks are aligned to 2 MiB and in huge
 * pages; all of them go to free(). */
static void test_realloc_keeps_bytes(void **state)
{
    (void)state;
    const size_t sizes[] = {16, 4096, BIG_MIN - 1, BIG_MIN, (size_t)3 << 20, (size_t)7 << 20, 100, (size_t)5 << 20};
    unsigned char *p = NULL;
    size_t used = 0;
    for (size_t i = 0; i < sizeof sizes / sizeof sizes[0]; i++) {
        size_t n = sizes[i];
        unsigned char *q = big_realloc(p, used, n);
        assert_non_null(q);
        size_t kept = used < n ? used : n;
        for (size_t j = 0; j < kept; j++)
            if (q[j] != (unsigned char)(j * 7 + 1))
                fail_msg("size %zu: byte %zu of %zu kept is %d", n, j, kept, q[j]);
        for (size_t j = kept; j < n; j++)
            q[j] = (unsigned char)(j * 7 + 1);
        if (n >= BIG_MIN)
            assert_big(q, n);
        p = q;
        used = n;
    }
    free(p);
    assert_null(big_realloc(NULL, 0, 0));
    assert_null(big_realloc(NULL, 0, SIZE_MAX));
}

/* big_release gives back the pages past `keep`, to the end of the block's
 * whole huge pages (a review found the BVH holding them: its plan at the
 * block's end made the last huge page resident, and the memory target
 * counted only the tree): the process holds less, the pages read 0 after,
 * and the bytes before keep are untouched. */
static long resident_kb(void)
{
    FILE *f = fopen("/proc/self/statm", "r");
    long pages = 0, rss = 0;
    if (!f)
        return -1;
    if (fscanf(f, "%ld %ld", &pages, &rss) != 2)
        rss = -1;
    fclose(f);
    return rss < 0 ? -1 : rss * (sysconf(_SC_PAGESIZE) / 1024);
}

static void test_release_gives_pages_back(void **state)
{
    (void)state;
    const size_t n = (size_t)5 << 20, keep = (size_t)1 << 20;
    unsigned char *p = big_realloc(NULL, 0, n);
    assert_non_null(p);
    memset(p, 0x5a, n);
    const long before = resident_kb();
    big_release(p, keep, n);
    const long after = resident_kb();
    for (size_t j = 0; j < keep; j++)
        if (p[j] != 0x5a)
            fail_msg("byte %zu before keep changed", j);
    for (size_t j = keep; j < n; j += 4096)
        if (p[j] != 0)
            fail_msg("byte %zu past keep reads %d", j, p[j]);
    if (before > 0 && after > 0) /* at least the 4 MiB past keep, less a page */
        assert_true(before - after >= 4 * 1024 - 4);
    free(p);
}

/* The arrays that a large scene fills as it is read, built and rendered
 * are in huge pages: each first write to a 4 KiB page of them was a page
 * fault. An image's pixels, a file read whole, a mesh file's vertices
 * and triangles, a mesh's primitives and the BVH's nodes. */
static void test_arrays_in_huge_pages(void **state)
{
    (void)state;
    if (!have_thp()) {
        printf("  (no transparent huge pages here: skipped)\n");
        return;
    }
    Image img;
    assert_int_equal(image_init(&img, 640, 480), 0);
    assert_true(in_huge_pages(img.rgb));
    image_free(&img);

    char path[] = "/tmp/lancer_bigmem_XXXXXX";
    int fd = mkstemp(path);
    assert_true(fd >= 0);
    FILE *f = fdopen(fd, "w");
    assert_non_null(f);
    for (int i = 0; i < 300000; i++)
        fputs("0123456789\n", f);
    assert_int_equal(fclose(f), 0);
    char *data, err[256];
    size_t len;
    assert_int_equal(afile_read(path, 1ull << 30, "files", &data, &len, err, sizeof err), 0);
    remove(path);
    assert_int_equal(len, 3300000);
    assert_big(data, len); /* aligned too: heap memory near it may be advised as well */
    free(data);

    /* a mesh file's vertices and triangles, as it is read */
    enum { G = 400 };
    char dir[] = "/tmp/lancer_bigmem_XXXXXX", off[64];
    assert_non_null(mkdtemp(dir));
    snprintf(off, sizeof off, "%s/grid.off", dir);
    f = fopen(off, "w");
    assert_non_null(f);
    fprintf(f, "OFF\n%d %d 0\n", G * G, 2 * (G - 1) * (G - 1));
    for (int y = 0; y < G; y++)
        for (int x = 0; x < G; x++)
            fprintf(f, "%d %d %d\n", x, y, (x * y) % 5);
    for (int y = 0; y + 1 < G; y++)
        for (int x = 0; x + 1 < G; x++)
            fprintf(f, "3 %d %d %d\n3 %d %d %d\n", y * G + x, y * G + x + 1, y * G + x + G, y * G + x + 1,
                    y * G + x + G + 1, y * G + x + G);
    assert_int_equal(fclose(f), 0);
    Mesh big;
    int rc = mesh_load(off, &big, err, sizeof err);
    remove(off);
    remove(dir);
    assert_int_equal(rc, 0);
    assert_int_equal(big.nt, 2 * (G - 1) * (G - 1));
    assert_true(sizeof *big.v * (size_t)big.nv >= BIG_MIN);
    assert_big(big.v, sizeof *big.v * (size_t)big.nv);
    assert_big(big.tri, sizeof *big.tri * (size_t)big.nt);
    mesh_free(&big);

    /* a grid of 2 x 100 x 100 triangles */
    enum { N = 100 };
    Mesh m;
    memset(&m, 0, sizeof m);
    m.nv = (N + 1) * (N + 1);
    m.nt = 2 * N * N;
    m.v = malloc(sizeof *m.v * (size_t)m.nv);
    m.tri = malloc(sizeof *m.tri * (size_t)m.nt);
    assert_non_null(m.v);
    assert_non_null(m.tri);
    for (int y = 0; y <= N; y++)
        for (int x = 0; x <= N; x++)
            m.v[y * (N + 1) + x] = vec3((float)x, (float)y, (float)((x * y) % 7));
    for (int y = 0, k = 0; y < N; y++)
        for (int x = 0; x < N; x++) {
            int a = y * (N + 1) + x;
            m.tri[k][0] = a, m.tri[k][1] = a + 1, m.tri[k][2] = a + N + 1, k++;
            m.tri[k][0] = a + 1, m.tri[k][1] = a + N + 2, m.tri[k][2] = a + N + 1, k++;
        }
    Scene sc;
    assert_int_equal(scene_from_mesh(&sc, &m), 0);
    assert_int_equal(sc.nprims, m.nt);
    assert_true(sizeof(Prim) * (size_t)sc.nprims >= BIG_MIN);
    assert_big(sc.prims, sizeof(Prim) * (size_t)sc.nprims);
    Bvh b;
    assert_int_equal(bvh_build(&b, sc.prims, sc.nprims, PRIM_ROBUST, 1), 0);
    assert_big(b.mem, 1);
    bvh_free(&b);
    scene_free(&sc);
    free(m.v);
    free(m.tri);
}

/* Under AddressSanitizer, the bytes on either side of a large allocation
 * are poisoned, as calloc's red zones are, and the bytes given are not. */
static void test_asan_sees_past_the_end(void **state)
{
    (void)state;
#if defined(__SANITIZE_ADDRESS__)
    const size_t n = ((size_t)3 << 20) + 5;
    unsigned char *p = big_zalloc(n);
    assert_non_null(p);
    assert_false(__asan_address_is_poisoned(p));
    assert_false(__asan_address_is_poisoned(p + n - 1));
    assert_true(__asan_address_is_poisoned(p + n));
    assert_true(__asan_address_is_poisoned(p - 1));
    big_free(p);
#else
    printf("  (not the AddressSanitizer build: skipped)\n");
#endif
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_zeroed_at_every_size),
        cmocka_unit_test(test_refuses_zero_and_overflow),
        cmocka_unit_test(test_large_in_huge_pages),
        cmocka_unit_test(test_realloc_keeps_bytes),
        cmocka_unit_test(test_release_gives_pages_back),
        cmocka_unit_test(test_arrays_in_huge_pages),
        cmocka_unit_test(test_asan_sees_past_the_end),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
