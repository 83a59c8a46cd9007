/*
 * embree_bench.c - lancer against Embree 3 on the same rays, one thread.
 *
 *     build/embree_bench MESH DIR [PASSES]
 *
 * DIR holds primary.rays, shadow.rays and diffuse.rays (lancer bench
 * --gen-rays). For each file the three tracers take turns pass by pass, in
 * the same run: lancer (robust, watertight), Embree default, and Embree with
 * RTC_SCENE_FLAG_ROBUST, in an order that turns each pass so that none
 * always runs first. The median Mrays/s of each and the hit counts are
 * printed, and the ratios as the median over passes of each pass's own
 * ratio: the two sides of a ratio ran a moment apart, so the shared
 * machine's slower spells cancel. Hit counts that differ are reported, not
 * hidden.
 * Build times are medians too, both on one thread, Embree at its default
 * (medium) quality, with each build's page faults: on a virtual machine a
 * fault can cost more than a build's own work on that page. A benchmark,
 * not a test: it asserts nothing.
 */
#include <stdio.h>
#include <stdlib.h>
#include <sys/resource.h>

#include <embree3/rtcore.h>

#include "lancer/accel.h"
#include "lancer/bvh.h"
#include "bench.h"
#include "clock.h"
#include "lancer/rayfile.h"

#define ROUNDS_MAX 64

static int cmp(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* The process's minor page faults so far (ru_minflt: not in POSIX's
 * rusage, but in glibc's and the BSDs'). */
static double faults(void)
{
    struct rusage u;
    return getrusage(RUSAGE_SELF, &u) == 0 ? (double)u.ru_minflt : 0.0;
}

static double median(double *v, int n)
{
    qsort(v, (size_t)n, sizeof(double), cmp);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

static RTCScene embree_scene(RTCDevice dev, const Mesh *m, int robust, double *ms)
{
    double t0 = clock_now();
    RTCScene sc = rtcNewScene(dev);
    if (robust)
        rtcSetSceneFlags(sc, RTC_SCENE_FLAG_ROBUST);
    RTCGeometry g = rtcNewGeometry(dev, RTC_GEOMETRY_TYPE_TRIANGLE);
    float *v = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float),
                                       (size_t)m->nv);
    unsigned *ix = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned),
                                           (size_t)m->nt);
    for (int i = 0; i < m->nv; i++) {
        v[3 * i] = m->v[i].x;
        v[3 * i + 1] = m->v[i].y;
        v[3 * i + 2] = m->v[i].z;
    }
    for (int i = 0; i < m->nt; i++)
        for (int k = 0; k < 3; k++)
            ix[3 * i + k] = (unsigned)m->tri[i][k];
    rtcCommitGeometry(g);
    rtcAttachGeometry(sc, g);
    rtcReleaseGeometry(g);
    rtcCommitScene(sc);
    *ms = 1e3 * (clock_now() - t0);
    return sc;
}

/* One pass of Embree over the rays; returns seconds. */
static double embree_pass(RTCScene sc, const Ray *rays, size_t n, int any, size_t *hits)
{
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    size_t k = 0;
    double t0 = clock_now();
    for (size_t i = 0; i < n; i++) {
        struct RTCRayHit rh;
        rh.ray.org_x = rays[i].o.x;
        rh.ray.org_y = rays[i].o.y;
        rh.ray.org_z = rays[i].o.z;
        rh.ray.dir_x = rays[i].d.x;
        rh.ray.dir_y = rays[i].d.y;
        rh.ray.dir_z = rays[i].d.z;
        rh.ray.tnear = 0.0f;
        rh.ray.tfar = rays[i].tmax;
        rh.ray.time = 0.0f;
        rh.ray.mask = ~0u;
        rh.ray.id = 0;
        rh.ray.flags = 0;
        if (any) {
            rtcOccluded1(sc, &ctx, &rh.ray);
            k += rh.ray.tfar < 0.0f; /* Embree marks an occluded ray with tfar = -inf */
        } else {
            rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
            rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
            rtcIntersect1(sc, &ctx, &rh);
            k += rh.hit.geomID != RTC_INVALID_GEOMETRY_ID;
        }
    }
    *hits = k;
    return clock_now() - t0;
}

int main(int argc, char **argv)
{
    if (argc < 3) {
        fprintf(stderr, "usage: embree_bench MESH DIR [PASSES]\n");
        return 2;
    }
    int passes = argc > 3 ? atoi(argv[3]) : 11;
    if (passes < 1 || passes > ROUNDS_MAX)
        passes = 11;
    char err[1024];
    Mesh m;
    if (mesh_load(argv[1], &m, err, sizeof err) != 0) {
        fprintf(stderr, "%s\n", err);
        return 1;
    }
    Scene s;
    if (scene_from_mesh(&s, &m) != 0) {
        fprintf(stderr, "out of memory\n");
        return 1;
    }
    RTCDevice dev = rtcNewDevice("threads=1");
    double lb[ROUNDS_MAX], ed[ROUNDS_MAX], er[ROUNDS_MAX], lf[ROUNDS_MAX], ef[ROUNDS_MAX];
    Accel *acc = NULL;
    RTCScene sd = NULL, sr = NULL;
    for (int k = 0; k < passes; k++) { /* builds, alternating too */
        double f0 = faults(), t0 = clock_now();
        accel_free(acc);
        if (!(acc = accel_build(&s, PRIM_ROBUST, 1)))
            return 1;
        lb[k] = 1e3 * (clock_now() - t0);
        lf[k] = faults() - f0;
        if (sd) {
            rtcReleaseScene(sd);
            rtcReleaseScene(sr);
        }
        f0 = faults();
        sd = embree_scene(dev, &m, 0, &ed[k]);
        sr = embree_scene(dev, &m, 1, &er[k]);
        ef[k] = 0.5 * (faults() - f0);
    }
    size_t bytes = accel_bytes(acc);
    printf("mesh %s: %d triangles, %d degenerate dropped\n", argv[1], m.nt, m.degenerate);
    printf("build (ms, median of %d, one thread): lancer %.1f, Embree %.1f, Embree robust %.1f; "
           "lancer / Embree = %.2f\n",
           passes, median(lb, passes), median(ed, passes), median(er, passes), median(lb, passes) / median(ed, passes));
    printf("page faults per build (median): lancer %.0f, Embree %.0f (the mean of its default and robust builds)\n", median(lf, passes),
           median(ef, passes));
    printf("lancer BVH memory: %.1f bytes per triangle (%d-wide nodes, leaves with their triangles' vertices, "
           "leaf order)\n",
           (double)bytes / m.nt, BVH_WIDTH);
    printf("| rays | kind | lancer Mrays/s | Embree | Embree robust | lancer / Embree | lancer / robust | hits "
           "(lancer, Embree, robust) |\n| --- | --- | --- | --- | --- | --- | --- | --- |\n");
    const char *files[3] = {"primary", "shadow", "diffuse"};
    for (int f = 0; f < 3; f++) {
        char path[1024];
        snprintf(path, sizeof path, "%s/%s.rays", argv[2], files[f]);
        Ray *rays;
        size_t n, hl = 0, hd = 0, hr = 0;
        if (rayfile_read(path, &rays, &n, err, sizeof err) != 0) {
            fprintf(stderr, "%s\n", err);
            return 1;
        }
        int any = f == 1;
        double sumt;
        bench_pass(acc, rays, n, any, &hl, &sumt); /* warm-up */
        embree_pass(sd, rays, n, any, &hd);
        embree_pass(sr, rays, n, any, &hr);
        double tl[ROUNDS_MAX], td[ROUNDS_MAX], trr[ROUNDS_MAX], qd[ROUNDS_MAX], qr[ROUNDS_MAX];
        for (int k = 0; k < passes; k++) {
            for (int j = 0; j < 3; j++)
                switch ((j + k) % 3) {
                case 0:
                    tl[k] = n / bench_pass(acc, rays, n, any, &hl, &sumt) / 1e6;
                    break;
                case 1:
                    td[k] = n / embree_pass(sd, rays, n, any, &hd) / 1e6;
                    break;
                default:
                    trr[k] = n / embree_pass(sr, rays, n, any, &hr) / 1e6;
                }
            qd[k] = tl[k] / td[k];
            qr[k] = tl[k] / trr[k];
        }
        printf("| %s | %s | %.2f | %.2f | %.2f | %.2f | %.2f | %zu, %zu, %zu |\n", files[f], any ? "any" : "closest",
               median(tl, passes), median(td, passes), median(trr, passes), median(qd, passes), median(qr, passes),
               hl, hd, hr);
        free(rays);
    }
    rtcReleaseScene(sd);
    rtcReleaseScene(sr);
    rtcReleaseDevice(dev);
    accel_free(acc);
    scene_free(&s);
    mesh_free(&m);
    return 0;
}
