/*
 * stream.c - closest hits for a batch of incoherent rays, traced in the
 * order of their origins' Morton codes within their directions' octants
 * (stream.h).
 */
#include "lancer/stream.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "bigmem.h"

/* Bits per axis of the origin's cell: 2^21 cells over the scene's box, a
 * 24-bit key with the octant on top, sorted in two passes of 12 bits. */
#define CELL_BITS 7
#define KEY_BITS (3 * CELL_BITS + 3)
#define PASS_BITS 12

/* Below this many rays, every ray goes in the caller's order. Above it, a
 * sample of this many goes first, and the rest are sorted unless the
 * sample's rays test fewer than SORT_MIN_TESTS primitives each (sorting
 * would cost more than it saves) or more than one in SORT_COHERENT of its
 * neighbours start in the same octant and the same of 8^3 coarse cells (the
 * key's top 12 bits): the rays are in a good order already. */
#define SORT_MIN_RAYS 16384
#define SORT_SAMPLE 4096
#define SORT_MIN_TESTS 4
#define SORT_COHERENT 8
#define COARSE_BITS 12

/* A ray's answers in the stream's order. */
typedef struct {
    PrimHit h;
    int best;
} Answer;

struct AccelStream {
    size_t max;
    uint64_t *a, *b; /* key << 32 | ray index, and the radix sort's other half */
    Answer *ans;
    uint32_t count[2][1 << PASS_BITS];
};

typedef char key_fits_two_passes[KEY_BITS <= 2 * PASS_BITS ? 1 : -1];

AccelStream *accel_stream_new(size_t max)
{
    if (max > ACCEL_STREAM_MAX || max > SIZE_MAX / sizeof(Answer))
        return NULL;
    AccelStream *s = calloc(1, sizeof *s);
    if (!s)
        return NULL;
    const size_t m = max ? max : 1;
    s->max = max;
    /* in huge pages, and touched now: a page's first write is a fault,
     * which a trace would otherwise take thousands of */
    s->a = big_zalloc(m * sizeof *s->a);
    s->b = big_zalloc(m * sizeof *s->b);
    s->ans = big_zalloc(m * sizeof *s->ans);
    if (!s->a || !s->b || !s->ans) {
        accel_stream_free(s);
        return NULL;
    }
    memset(s->a, 0, m * sizeof *s->a);
    memset(s->b, 0, m * sizeof *s->b);
    memset(s->ans, 0, m * sizeof *s->ans);
    return s;
}

void accel_stream_free(AccelStream *s)
{
    if (!s)
        return;
    big_free(s->a);
    big_free(s->b);
    big_free(s->ans);
    free(s);
}

/* The origin's cell along one axis, f = (o - lo) * scale: NaN and below
 * lo to 0, beyond the box to the last. */
static inline uint32_t cell(float f)
{
    const float last = (float)((1 << CELL_BITS) - 1);
    return f > 0.0f ? f < last ? (uint32_t)f : (uint32_t)last : 0u;
}

/* A ray's sort key: its direction's octant, then its origin's cell of the
 * scene's box in Morton's order (G. M. Morton, IBM, 1966): cells near in
 * space are near in the order. */
typedef struct {
    Vec3 lo, scale;
    uint32_t spread[1 << CELL_BITS]; /* bit j of x at bit 3j */
} Keys;

static void keys_init(Keys *k, Vec3 lo, Vec3 hi)
{
    const float cells = (float)(1 << CELL_BITS);
    k->lo = lo;
    k->scale = vec3(cells / (hi.x - lo.x), cells / (hi.y - lo.y), cells / (hi.z - lo.z));
    for (uint32_t x = 0; x < 1u << CELL_BITS; x++) {
        k->spread[x] = 0;
        for (int j = 0; j < CELL_BITS; j++)
            k->spread[x] |= (x >> j & 1u) << 3 * j;
    }
}

static inline uint32_t key_of(const Keys *k, const Ray *q)
{
    uint32_t oct = (uint32_t)(q->d.x < 0.0f) | (uint32_t)(q->d.y < 0.0f) << 1 | (uint32_t)(q->d.z < 0.0f) << 2;
    return oct << 3 * CELL_BITS | k->spread[cell((q->o.x - k->lo.x) * k->scale.x)] << 2 |
           k->spread[cell((q->o.y - k->lo.y) * k->scale.y)] << 1 | k->spread[cell((q->o.z - k->lo.z) * k->scale.z)];
}

/* s->a[0 .. n-1]: the indices 0 .. n-1 of r in the order of their keys,
 * equal keys in the caller's order (a least-significant-digit radix sort
 * is stable). */
static void sort_rays(AccelStream *s, const Keys *k, const Ray *r, size_t n)
{
    const uint32_t mask = (1u << PASS_BITS) - 1;
    uint32_t *c0 = s->count[0], *c1 = s->count[1];
    memset(s->count, 0, sizeof s->count);
    for (size_t i = 0; i < n; i++) {
        const uint32_t key = key_of(k, &r[i]);
        s->a[i] = (uint64_t)key << 32 | (uint32_t)i;
        c0[key & mask]++;
        c1[key >> PASS_BITS]++;
    }
    uint32_t sum0 = 0, sum1 = 0;
    for (int j = 0; j < 1 << PASS_BITS; j++) {
        uint32_t k0 = c0[j], k1 = c1[j];
        c0[j] = sum0;
        c1[j] = sum1;
        sum0 += k0;
        sum1 += k1;
    }
    for (size_t i = 0; i < n; i++) /* by the low digit into b, then the high into a */
        s->b[c0[(s->a[i] >> 32) & mask]++] = s->a[i];
    for (size_t i = 0; i < n; i++)
        s->a[c1[s->b[i] >> (32 + PASS_BITS)]++] = s->b[i];
}

int accel_closest_stream(const Accel *a, AccelStream *s, const Ray *r, size_t n, PrimHit *h, int *best,
                         RayStats *st)
{
    const size_t head = n < SORT_MIN_RAYS ? n : SORT_SAMPLE;
    const unsigned long long tests0 = st->isect_tests;
    for (size_t i = 0; i < head; i++)
        best[i] = accel_closest(a, &r[i], &h[i], st);
    Vec3 lo, hi;
    int sort = head < n && n <= s->max && st->isect_tests - tests0 >= (unsigned long long)SORT_MIN_TESTS * head &&
               accel_bounds(a, &lo, &hi) == 0;
    Keys k;
    if (sort) {
        keys_init(&k, lo, hi);
        size_t same = 0; /* neighbours in the same coarse cell and octant */
        for (size_t i = 1; i < head; i++)
            same += (key_of(&k, &r[i]) ^ key_of(&k, &r[i - 1])) >> (KEY_BITS - COARSE_BITS) == 0;
        sort = same * SORT_COHERENT <= head;
    }
    if (!sort) {
        for (size_t i = head; i < n; i++)
            best[i] = accel_closest(a, &r[i], &h[i], st);
        return 0;
    }
    const Ray *rest = r + head;
    const size_t m = n - head;
    sort_rays(s, &k, rest, m);
    const uint64_t *order = s->a;
    Answer *ans = s->ans;
    for (size_t i = 0; i < m; i++) {
#ifdef __GNUC__
        if (i + 16 < m) /* the ray's line, ahead of its turn */
            __builtin_prefetch(&rest[(uint32_t)order[i + 16]]);
#endif
        ans[i].best = accel_closest(a, &rest[(uint32_t)order[i]], &ans[i].h, st);
    }
    /* Back in the caller's order after the trace, whose cache lines the
     * answers' scattered lines would otherwise take. */
    for (size_t i = 0; i < m; i++) {
#ifdef __GNUC__
        if (i + 16 < m) {
            const size_t f = head + (uint32_t)order[i + 16];
            __builtin_prefetch(&h[f], 1);
            __builtin_prefetch(&best[f], 1);
        }
#endif
        const size_t j = head + (uint32_t)order[i];
        h[j] = ans[i].h;
        best[j] = ans[i].best;
    }
    return 1;
}
