/*
 * bigmem.h - zeroed memory for large arrays, in huge pages where the
 * system gives them.
 *
 *     float *a = big_zalloc(n * sizeof *a);
 *     if (a == NULL) ... out of memory ...
 *     big_free(a);
 *
 * The first write to each 4 KiB page of a fresh allocation is a page fault,
 * and on a virtual machine a fault can cost more than the work on its
 * page: a 640x480 image of float RGB is 900 of them. On Linux, an
 * allocation of BIG_MIN bytes or more is mapped on its own, aligned to
 * 2 MiB and advised as huge pages (madvise MADV_HUGEPAGE, which takes
 * effect when transparent huge pages are "always" or "madvise"): one fault
 * per 2 MiB. Smaller ones, and all on other systems, take calloc. Under
 * AddressSanitizer a mapping's bytes past the caller's are poisoned, as the
 * allocator's red zones would be.
 */
#ifndef LANCER_BIGMEM_H
#define LANCER_BIGMEM_H

#include <stddef.h>

/* Allocations from this size up are mapped on their own. */
#define BIG_MIN ((size_t)1 << 20)

/* n bytes, zeroed, aligned as malloc's (a mapping's to 64 bytes); NULL
 * when n is 0 or there is no memory. */
void *big_zalloc(size_t n);

/* Frees what big_zalloc returned; NULL is ignored. */
void big_free(void *p);

/* realloc(p, n) for a growing array that callers free with free(): when
 * it grows (or starts, p NULL) to BIG_MIN bytes or more, the new block is
 * aligned to 2 MiB, a whole number of 2 MiB long and advised as huge
 * pages, and the first `used` bytes of p (those in use) are copied into
 * it. Otherwise realloc(p, n), which keeps them all the same. NULL, with p
 * untouched, when there is no memory (or n is 0). */
void *big_realloc(void *p, size_t used, size_t n);

/* Gives back to the system the whole pages of p[keep .. size), p a block
 * of size bytes from big_realloc: they read as 0 after, and are no longer
 * held (a huge page touched anywhere is held whole). The bytes around
 * them, the allocator's among them, are untouched. */
void big_release(void *p, size_t keep, size_t size);

#endif
