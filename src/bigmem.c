/*
 * bigmem.c - zeroed memory for large arrays, in huge pages where the
 * system gives them (bigmem.h).
 */
#if defined(__linux__)
#define _GNU_SOURCE /* MAP_ANONYMOUS, madvise */
#endif
#include "bigmem.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#if defined(__linux__)
#include <sys/mman.h>
#if defined(MAP_ANONYMOUS) && defined(MADV_HUGEPAGE)
#define BIG_MAP 1
#endif
#endif

/* Under AddressSanitizer the header and the mapping's slack past the
 * caller's bytes are poisoned, as its own allocator's red zones are. */
#if defined(__SANITIZE_ADDRESS__)
#define BIG_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define BIG_ASAN 1
#endif
#endif
#ifdef BIG_ASAN
#include <sanitizer/asan_interface.h>
#define POISON(p, n) __asan_poison_memory_region(p, n)
#define UNPOISON(p, n) __asan_unpoison_memory_region(p, n)
#else
#define POISON(p, n) ((void)(p), (void)(n))
#define UNPOISON(p, n) ((void)(p), (void)(n))
#endif

#define HUGE_PAGE ((size_t)2 << 20)

#ifdef BIG_MAP
/* n up to a whole number of huge pages (n at most SIZE_MAX - HUGE_PAGE). */
static size_t huge_round(size_t n) { return (n + HUGE_PAGE - 1) / HUGE_PAGE * HUGE_PAGE; }
#endif

/* Before the caller's bytes: where they came from. 64 bytes, so that a
 * mapping's bytes start on a cache line. */
typedef union {
    struct {
        void *map;  /* the mapping, or NULL: from calloc */
        size_t len; /* its length */
    } h;
    unsigned char pad[64];
} Head;

void *big_zalloc(size_t n)
{
    if (n == 0 || n > SIZE_MAX - sizeof(Head) - 2 * HUGE_PAGE)
        return NULL;
    const size_t need = sizeof(Head) + n;
#ifdef BIG_MAP
    if (n >= BIG_MIN) {
        /* A mapping aligned to a huge page and a whole number of them
         * long, so that every 2 MiB of it can be one: map one page more,
         * then unmap what lies outside. Fresh anonymous pages read 0. */
        const size_t len = huge_round(need);
        char *m = mmap(NULL, len + HUGE_PAGE, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
        if (m != MAP_FAILED) {
            char *base = (char *)(((uintptr_t)m + HUGE_PAGE - 1) & ~(uintptr_t)(HUGE_PAGE - 1));
            if (base > m)
                munmap(m, (size_t)(base - m));
            munmap(base + len, (size_t)(m + HUGE_PAGE - base));
            madvise(base, len, MADV_HUGEPAGE); /* advice: without huge pages, small ones as before */
            Head *hd = (Head *)base;
            hd->h.map = base;
            hd->h.len = len;
            POISON(base, sizeof(Head));
            POISON(base + need, len - need);
            return base + sizeof(Head);
        }
    }
#endif
    Head *hd = calloc(1, need);
    if (hd == NULL)
        return NULL;
    hd->h.map = NULL;
    POISON(hd, sizeof(Head));
    return hd + 1;
}

void big_free(void *p)
{
    if (p == NULL)
        return;
    Head *hd = (Head *)p - 1;
    UNPOISON(hd, sizeof(Head));
#ifdef BIG_MAP
    if (hd->h.map != NULL) {
        UNPOISON(hd->h.map, hd->h.len); /* for whatever is mapped there next */
        munmap(hd->h.map, hd->h.len);
        return;
    }
#endif
    free(hd);
}

void big_release(void *p, size_t keep, size_t size)
{
#ifdef BIG_MAP
    /* a block big_realloc mapped runs to its whole huge pages, which the
     * first touch of their last one made resident */
    const size_t len = size >= BIG_MIN && size <= SIZE_MAX - HUGE_PAGE ? huge_round(size) : size;
    const uintptr_t page = 4096; /* (a multiple of it, were pages larger, is whole pages too) */
    const uintptr_t lo = ((uintptr_t)p + keep + page - 1) & ~(page - 1), hi = ((uintptr_t)p + len) & ~(page - 1);
    if (keep < size && hi > lo)
        madvise((void *)lo, hi - lo, MADV_DONTNEED);
#else
    (void)p;
    (void)keep;
    (void)size;
#endif
}

void *big_realloc(void *p, size_t used, size_t n)
{
    if (n == 0 || n > SIZE_MAX - HUGE_PAGE)
        return NULL;
#ifdef BIG_MAP
    if (n >= BIG_MIN && (p == NULL || n > used)) { /* shrinking: realloc's, in place */
        const size_t len = huge_round(n);
        void *q;
        if (posix_memalign(&q, HUGE_PAGE, len) != 0)
            return NULL;
        madvise(q, len, MADV_HUGEPAGE);
        if (p != NULL && used > 0)
            memcpy(q, p, used);
        free(p);
        return q;
    }
#endif
    (void)used;
    return realloc(p, n);
}
