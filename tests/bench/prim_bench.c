/*
 * prim_bench.c - speed of each intersection routine, classic against
 * robust, in millions of ray tests per second on one thread.
 *
 *     build/prim_bench [RAYS] [ROUNDS]
 *
 * Each routine is timed on the same RAYS rays (default 2^20) against one
 * primitive, about half of them hits; the classic and robust variants
 * alternate for ROUNDS rounds (default 9) and the medians are printed with
 * their ratio. A benchmark, not a test: it asserts nothing.
 */
#include <stdio.h>
#include <stdlib.h>

#include "clock.h"
#include "lancer/prim.h"

typedef int (*HitFn)(const void *prim, const Ray *r, PrimHit *h);

static int plane_c(const void *p, const Ray *r, PrimHit *h) { return prim_plane_hit(p, r, h); }
static int plane_r(const void *p, const Ray *r, PrimHit *h) { return prim_plane_hit_robust(p, r, h); }
static int sphere_c(const void *p, const Ray *r, PrimHit *h) { return prim_sphere_hit(p, r, h); }
static int sphere_r(const void *p, const Ray *r, PrimHit *h) { return prim_sphere_hit_robust(p, r, h); }
static int tri_c(const void *p, const Ray *r, PrimHit *h) { return prim_triangle_hit(p, r, h); }
static int tri_r(const void *p, const Ray *r, PrimHit *h) { return prim_triangle_hit_watertight(p, r, h); }
static int box_c(const void *p, const Ray *r, PrimHit *h) { return prim_box_hit(p, r, h); }
static int box_r(const void *p, const Ray *r, PrimHit *h) { return prim_box_hit_robust(p, r, h); }
static int obox_c(const void *p, const Ray *r, PrimHit *h) { return prim_obox_hit(p, r, h); }
static int obox_r(const void *p, const Ray *r, PrimHit *h) { return prim_obox_hit_robust(p, r, h); }

static unsigned long long rng = 88172645463325252ULL;

static float uniform(void) /* xorshift64, in [-1, 1) */
{
    rng ^= rng << 13;
    rng ^= rng >> 7;
    rng ^= rng << 17;
    return (float)((double)(rng >> 11) / 4503599627370496.0 - 1.0);
}

/* Seconds for one pass of fn over the rays; *hits counts hits. */
static double pass(HitFn fn, const void *prim, const Ray *rays, int n, int *hits)
{
    PrimHit h;
    int k = 0;
    double t0 = clock_now();
    for (int i = 0; i < n; i++)
        k += fn(prim, &rays[i], &h);
    double t = clock_now() - t0;
    *hits = k;
    return t;
}

static int cmp(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

int main(int argc, char **argv)
{
    int n = argc > 1 ? atoi(argv[1]) : 1 << 20;
    int rounds = argc > 2 ? atoi(argv[2]) : 9;
    if (n < 1 || rounds < 1 || rounds > 99) {
        fprintf(stderr, "usage: prim_bench [RAYS] [ROUNDS (1-99)]\n");
        return 2;
    }
    Ray *rays = malloc(sizeof(Ray) * (size_t)n);
    if (!rays)
        return 1;
    /* Origins around (0, 0, -4), aimed at the unit region about the origin,
     * where every primitive sits: roughly half hit. */
    for (int i = 0; i < n; i++) {
        Vec3 o = vec3(uniform(), uniform(), -4.0f + uniform());
        Vec3 target = vec3(1.6f * uniform(), 1.6f * uniform(), 0.5f * uniform());
        rays[i] = ray_make(o, vec_normalize(vec_sub(target, o)), INFINITY);
    }
    Plane plane = {vec_normalize(vec3(0.1f, 0.2f, -1.0f)), 0.0f};
    Sphere sphere = {{0, 0, 0}, 0.9f};
    Triangle tri = {{-1, -1, 0}, {1, -0.8f, 0.1f}, {0, 1, -0.1f}, {0, 0, 1}, {0, 0, 1}, {0, 0, 1}, 0};
    Box box = {{-0.7f, -0.7f, -0.7f}, {0.7f, 0.7f, 0.7f}};
    OBox obox = {{0, 0, 0}, {0.6f, 0.2f, 0}, {-0.2f, 0.6f, 0.1f}, {0, -0.1f, 0.6f}, {{0, 0, 0}}};
    prim_obox_init(&obox);
    struct {
        const char *name;
        const void *prim;
        HitFn classic, robust;
    } cases[] = {
        {"plane", &plane, plane_c, plane_r},     {"sphere", &sphere, sphere_c, sphere_r},
        {"triangle", &tri, tri_c, tri_r},         {"box", &box, box_c, box_r},
        {"obox", &obox, obox_c, obox_r},
    };
    printf("| routine | classic Mrays/s | robust Mrays/s | robust / classic | hits (classic, robust) |\n");
    printf("| --- | --- | --- | --- | --- |\n");
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        double tc[99], tr[99];
        int hc = 0, hr = 0;
        pass(cases[c].classic, cases[c].prim, rays, n, &hc); /* warm-up */
        pass(cases[c].robust, cases[c].prim, rays, n, &hr);
        for (int k = 0; k < rounds; k++) {
            tc[k] = pass(cases[c].classic, cases[c].prim, rays, n, &hc);
            tr[k] = pass(cases[c].robust, cases[c].prim, rays, n, &hr);
        }
        qsort(tc, (size_t)rounds, sizeof(double), cmp);
        qsort(tr, (size_t)rounds, sizeof(double), cmp);
        double mc = n / tc[rounds / 2] / 1e6, mr = n / tr[rounds / 2] / 1e6;
        printf("| %s | %.1f | %.1f | %.2f | %d, %d |\n", cases[c].name, mc, mr, mr / mc, hc, hr);
    }
    free(rays);
    return 0;
}
