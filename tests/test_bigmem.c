/* Unit tests for bigmem.c: big_zalloc's memory is zeroed and writable to
 * its last byte at every size, small and large; a large allocation is
 * aligned and, on Linux with transparent huge pages, advised as huge
 * pages, an image's pixels among them; AddressSanitizer still sees a
 * write past its end; and the sizes it refuses. */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>

#include "testutil.h"

#include "lancer/image.h"
#include "../src/bigmem.h"

#if defined(__SANITIZE_ADDRESS__)
#include <sanitizer/asan_interface.h>
#endif

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

/* A large allocation starts 64 bytes into a mapping of its own that
 * madvise marked for huge pages (VmFlags "hg"), where the kernel has
 * transparent huge pages. */
static void test_large_in_huge_pages(void **state)
{
    (void)state;
#if defined(__linux__)
    FILE *thp = fopen("/sys/kernel/mm/transparent_hugepage/enabled", "r");
    if (!thp) {
        printf("  (no transparent huge pages in this kernel: skipped)\n");
        return;
    }
    fclose(thp);
    unsigned char *p = big_zalloc((size_t)3 << 20);
    assert_non_null(p);
    assert_int_equal((uintptr_t)p % ((uintptr_t)2 << 20), 64);
    char flags[512];
    assert_int_equal(vm_flags(p, flags, sizeof flags), 0);
    if (!strstr(flags, " hg"))
        fail_msg("VmFlags:%s", flags);
    /* the whole allocation lies in that one mapping */
    char last[512];
    assert_int_equal(vm_flags(p + ((size_t)3 << 20) - 1, last, sizeof last), 0);
    assert_string_equal(flags, last);
    big_free(p);
    /* a small one is calloc's */
    p = big_zalloc(4096);
    assert_int_equal(vm_flags(p, flags, sizeof flags), 0);
    assert_null(strstr(flags, " hg"));
    big_free(p);
#else
    printf("  (not Linux: skipped)\n");
#endif
}

/* An image's pixels are such an allocation: the render's first write to
 * each page of them was a page fault. */
static void test_image_in_huge_pages(void **state)
{
    (void)state;
#if defined(__linux__)
    FILE *thp = fopen("/sys/kernel/mm/transparent_hugepage/enabled", "r");
    if (!thp) {
        printf("  (no transparent huge pages in this kernel: skipped)\n");
        return;
    }
    fclose(thp);
    Image img;
    assert_int_equal(image_init(&img, 640, 480), 0);
    char flags[512];
    assert_int_equal(vm_flags(img.rgb, flags, sizeof flags), 0);
    if (!strstr(flags, " hg"))
        fail_msg("VmFlags:%s", flags);
    image_free(&img);
#else
    printf("  (not Linux: skipped)\n");
#endif
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
        cmocka_unit_test(test_image_in_huge_pages),
        cmocka_unit_test(test_asan_sees_past_the_end),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
