/*
 * failat.c - an LD_PRELOAD library for tests/oom.sh: the FAIL_AT-th
 * allocation of the process (malloc, calloc, realloc, posix_memalign,
 * aligned_alloc; counted from 1 over every thread) fails as when memory
 * runs out. With FAIL_COUNT set, the count is written to that file at
 * exit, so that the test knows how many allocations to try.
 */
#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <unistd.h>

extern void *__libc_malloc(size_t);
extern void *__libc_calloc(size_t, size_t);
extern void *__libc_realloc(void *, size_t);
extern void *__libc_memalign(size_t, size_t);

static long target = -1, count;

static int fail_now(void)
{
    if (target < 0) {
        const char *s = getenv("FAIL_AT");
        target = s ? atol(s) : 0;
    }
    return __atomic_add_fetch(&count, 1, __ATOMIC_RELAXED) == target && target > 0;
}

void *malloc(size_t n)
{
    if (fail_now()) {
        errno = ENOMEM;
        return NULL;
    }
    return __libc_malloc(n);
}

void *calloc(size_t a, size_t b)
{
    if (fail_now()) {
        errno = ENOMEM;
        return NULL;
    }
    return __libc_calloc(a, b);
}

void *realloc(void *p, size_t n)
{
    if (fail_now()) {
        errno = ENOMEM;
        return NULL;
    }
    return __libc_realloc(p, n);
}

int posix_memalign(void **p, size_t a, size_t n)
{
    if (fail_now())
        return ENOMEM;
    *p = __libc_memalign(a, n);
    return *p ? 0 : ENOMEM;
}

void *aligned_alloc(size_t a, size_t n)
{
    if (fail_now()) {
        errno = ENOMEM;
        return NULL;
    }
    return __libc_memalign(a, n);
}

/* (snprintf and write, no stdio stream: they may allocate) */
__attribute__((destructor)) static void report(void)
{
    const char *f = getenv("FAIL_COUNT");
    if (!f || !*f)
        return;
    char b[32];
    int n = snprintf(b, sizeof b, "%ld\n", count);
    int fd = open(f, O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (fd >= 0) {
        if (write(fd, b, (size_t)n) != n)
            n = 0;
        close(fd);
    }
}
