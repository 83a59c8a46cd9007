/*
 * bench.c - benchmark rays and timed passes (see bench.h).
 */
#include "bench.h"

#include <stdlib.h>

#include "clock.h"
#include "lancer/camera.h"

/* xorshift64*: fast, and the same sequence on every machine. */
static double next_unit(unsigned long long *s)
{
    *s ^= *s >> 12;
    *s ^= *s << 25;
    *s ^= *s >> 27;
    return (double)((*s * 2685821657736338717ULL) >> 11) / 9007199254740992.0;
}

void bench_free(RaySet *s)
{
    free(s->rays);
    s->rays = NULL;
    s->n = 0;
}

/* The fraction of the w x h picture's rays that hit, from 32 x 32 of them
 * spread evenly. */
static double hit_fraction(const Accel *a, const CameraSpec *spec, int w, int h)
{
    Camera cam;
    camera_init(&cam, spec, w, h);
    RayStats st = {0};
    int hits = 0;
    for (int y = 0; y < 32; y++)
        for (int x = 0; x < 32; x++) {
            Ray r = camera_ray(&cam, ((float)x + 0.5f) * (float)w / 32.0f, ((float)y + 0.5f) * (float)h / 32.0f);
            PrimHit hit;
            hits += accel_closest(a, &r, &hit, &st) >= 0;
        }
    return hits / 1024.0;
}

/* Narrows the loose framing until BENCH_TIGHT_HITS of the rays hit: aimed
 * at the surface seen at the picture's centre (the bounds' centre may be a
 * hole), the field of view shrinks by steps. The first view that reaches
 * the fraction is kept, else the one with the most hits. */
static void tighten(const Accel *a, CameraSpec *spec, int w, int h)
{
    Camera cam;
    camera_init(&cam, spec, 1, 1);
    Ray r = camera_ray(&cam, 0.5f, 0.5f);
    PrimHit hit;
    RayStats st = {0};
    if (accel_closest(a, &r, &hit, &st) >= 0)
        spec->target = vec_madd(r.o, r.d, hit.t);
    CameraSpec best = *spec;
    double most = -1.0;
    for (float fov = spec->fovy; fov >= 1.0f; fov *= 0.85f) {
        spec->fovy = fov;
        double f = hit_fraction(a, spec, w, h);
        if (f > most) {
            most = f;
            best = *spec;
        }
        if (f >= BENCH_TIGHT_HITS)
            break;
    }
    *spec = best;
}

int bench_gen_rays(const Scene *s, const Accel *a, int w, int h, int tight, unsigned long long seed, RaySet *primary,
                   RaySet *shadow, RaySet *diffuse)
{
    primary->n = shadow->n = diffuse->n = 0;
    size_t np = (size_t)w * (size_t)h;
    primary->rays = malloc(sizeof(Ray) * np);
    shadow->rays = malloc(sizeof(Ray) * np);
    diffuse->rays = malloc(sizeof(Ray) * np);
    Vec3 lo, hi;
    if (!primary->rays || !shadow->rays || !diffuse->rays || accel_bounds(a, &lo, &hi) != 0) {
        bench_free(primary);
        bench_free(shadow);
        bench_free(diffuse);
        return -1;
    }
    /* Frame the bounds from the front, a little above, 40 degrees high. */
    Vec3 c = vec_scale(vec_add(lo, hi), 0.5f);
    float radius = 0.5f * vec_length(vec_sub(hi, lo));
    CameraSpec spec = {.eye = vec_madd(c, vec_normalize(vec3(0.0f, 0.3f, 1.0f)), 3.0f * radius),
                       .target = c,
                       .up = vec3(0, 1, 0),
                       .fovy = 40.0f};
    if (tight)
        tighten(a, &spec, w, h);
    Vec3 light = vec_madd(c, vec3(1.5f, 3.0f, 2.0f), radius);
    Camera cam;
    camera_init(&cam, &spec, w, h);
    RayStats st = {0};
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            Ray r = camera_ray(&cam, (float)x + 0.5f, (float)y + 0.5f);
            primary->rays[primary->n++] = r;
            PrimHit hit;
            int i = accel_closest(a, &r, &hit, &st);
            if (i < 0)
                continue;
            Surface sf;
            prim_surface(&s->prims[i], &r, &hit, accel_variant(a), &sf);
            Vec3 tol = vec_sub(light, sf.p);
            float dist = vec_length(tol);
            Vec3 l = vec_scale(tol, 1.0f / dist);
            Vec3 o = prim_spawn_origin(&sf, l);
            shadow->rays[shadow->n++] = ray_make(o, l, vec_length(vec_sub(light, o)));
            /* uniform on the sphere (Marsaglia), folded onto the facing side */
            Vec3 d;
            double len2;
            do {
                d = vec3((float)(2 * next_unit(&seed) - 1), (float)(2 * next_unit(&seed) - 1),
                         (float)(2 * next_unit(&seed) - 1));
                len2 = vec_dot(d, d);
            } while (len2 > 1.0 || len2 < 1e-6);
            d = vec_normalize(d);
            if (vec_dot(d, sf.ng) < 0.0f)
                d = vec_neg(d);
            diffuse->rays[diffuse->n++] = ray_make(prim_spawn_origin(&sf, d), d, INFINITY);
        }
    for (size_t i = diffuse->n; i > 1; i--) { /* Fisher-Yates */
        size_t j = (size_t)(next_unit(&seed) * (double)i);
        Ray t = diffuse->rays[i - 1];
        diffuse->rays[i - 1] = diffuse->rays[j];
        diffuse->rays[j] = t;
    }
    return 0;
}

double bench_pass(const Accel *a, const Ray *rays, size_t n, int any, size_t *hits, double *sumt)
{
    RayStats st = {0};
    size_t k = 0;
    double sum = 0.0, t0 = clock_now();
    for (size_t i = 0; i < n; i++) {
        if (any) {
            k += (size_t)accel_occluded(a, &rays[i], &st);
        } else {
            PrimHit h;
            if (accel_closest(a, &rays[i], &h, &st) >= 0) {
                k++;
                sum += h.t;
            }
        }
    }
    double dt = clock_now() - t0;
    *hits = k;
    *sumt = sum;
    return dt;
}

/* The hits among answers best[0 .. n-1] added to *k, their t to *sum. */
static void tally(const int *best, const PrimHit *h, size_t n, size_t *k, double *sum)
{
    for (size_t i = 0; i < n; i++)
        if (best[i] >= 0) {
            ++*k;
            *sum += h[i].t;
        }
}

double bench_pass_packet(const Accel *a, const Ray *rays, size_t n, size_t *hits, double *sumt)
{
    RayStats st = {0};
    size_t k = 0;
    double sum = 0.0, t0 = clock_now();
    for (size_t i = 0; i < n; i += ACCEL_PACKET) {
        int m = n - i < ACCEL_PACKET ? (int)(n - i) : ACCEL_PACKET, best[ACCEL_PACKET];
        PrimHit h[ACCEL_PACKET];
        accel_closest_packet(a, rays + i, m, h, best, &st);
        tally(best, h, (size_t)m, &k, &sum);
    }
    double dt = clock_now() - t0;
    *hits = k;
    *sumt = sum;
    return dt;
}

double bench_pass_stream(const Accel *a, AccelStream *s, const Ray *rays, size_t n, PrimHit *h, int *best, size_t *hits,
                         double *sumt)
{
    RayStats st = {0};
    size_t k = 0;
    double sum = 0.0, t0 = clock_now();
    accel_closest_stream(a, s, rays, n, h, best, &st);
    tally(best, h, n, &k, &sum);
    double dt = clock_now() - t0;
    *hits = k;
    *sumt = sum;
    return dt;
}

int bench_trace(const Accel *a, const Ray *rays, size_t n, BenchKind kind, int passes, BenchResult *res)
{
    AccelStream *s = NULL;
    PrimHit *h = NULL;
    int *hit = NULL;
    if (kind == BENCH_STREAM) {
        s = accel_stream_new(n);
        h = malloc((n ? n : 1) * sizeof *h);
        hit = malloc((n ? n : 1) * sizeof *hit);
        if (!s || !h || !hit) {
            accel_stream_free(s);
            free(h);
            free(hit);
            return -1;
        }
    }
    double best = 0.0;
    for (int p = -1; p < passes; p++) { /* pass -1 warms the caches */
        double dt = kind == BENCH_PACKET   ? bench_pass_packet(a, rays, n, &res->hits, &res->sumt)
                    : kind == BENCH_STREAM ? bench_pass_stream(a, s, rays, n, h, hit, &res->hits, &res->sumt)
                                           : bench_pass(a, rays, n, kind == BENCH_ANY, &res->hits, &res->sumt);
        if (p < 0)
            continue;
        if (dt > 0.0 && (double)n / dt / 1e6 > best)
            best = (double)n / dt / 1e6;
    }
    res->mrays = best;
    accel_stream_free(s);
    free(h);
    free(hit);
    return 0;
}
