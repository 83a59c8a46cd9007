/*
 * embree_bench.c - lancer against Embree 3 robust on the same rays, one
 * thread.
 *
 *     build/embree_bench MESH PASSES RESULTS DIR [DIR ...]
 *
 * Each DIR holds primary.rays, shadow.rays and diffuse.rays (lancer bench
 * --gen-rays), for one framing of the mesh; its last path component names
 * the framing. Embree's scene has RTC_SCENE_FLAG_ROBUST. For each file the
 * tracers take turns pass by pass, in an order that turns each pass so
 * that none always runs first:
 * - camera rays: lancer one by one (bvh_closest) and in packets of eight
 *   neighbours (accel_closest_packet, as its renderer traces them), Embree
 *   rtcIntersect1, and rtcIntersect8 with a valid mask and the coherent
 *   context flag;
 * - shadow rays: lancer's any-hit query against rtcOccluded1;
 * - diffuse rays: closest hit, lancer one by one and as one stream (its
 *   rays sorted by origin and octant first, the sort timed with the trace:
 *   stream.h), against rtcIntersect1 in the file's order.
 * A ratio is the median over passes of each pass's own ratio: the two sides
 * ran a moment apart, so the shared machine's slower spells cancel. Hit
 * counts that differ are reported, not hidden.
 *
 * Builds alternate too, all on one thread: lancer's, Embree's default
 * (medium quality) and robust ones, with each build's page faults (on a
 * virtual machine a fault can cost more than a build's own work on its
 * page). Memory: lancer's BVH (accel_bytes) against what Embree's memory
 * monitor callback counts as allocated by rtcCommitScene and still held,
 * both without the mesh's own vertex and index arrays.
 *
 * Markdown goes to standard output; each measured ratio is appended to
 * RESULTS as a line "target<TAB>case<TAB>value" (scripts/bench-table.sh).
 * A benchmark, not a test: it asserts nothing.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
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

static double median(const double *v, int n)
{
    double s[ROUNDS_MAX];
    memcpy(s, v, sizeof(double) * (size_t)n);
    qsort(s, (size_t)n, sizeof(double), cmp);
    return n % 2 ? s[n / 2] : 0.5 * (s[n / 2 - 1] + s[n / 2]);
}

static double largest(const double *v, int n)
{
    double m = v[0];
    for (int i = 1; i < n; i++)
        m = v[i] > m ? v[i] : m;
    return m;
}

/* Bytes that Embree holds, by its memory monitor. */
static long long embree_held;

static bool monitor(void *user, ssize_t bytes, bool post)
{
    (void)user;
    (void)post;
    embree_held += bytes;
    return true;
}

/* A scene of the mesh; *ms its build time, *bytes what its commit kept,
 * *pf the page faults of the build. Timed and counted: the commit alone,
 * as lancer's accel_build is, from a scene made before it; the copy of the
 * mesh into Embree's buffers is Embree's scene_from_mesh. */
static RTCScene embree_scene(RTCDevice dev, const Mesh *m, int robust, double *ms, long long *bytes, double *pf)
{
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
    long long held = embree_held;
    const double f0 = faults(), t0 = clock_now();
    rtcCommitScene(sc);
    *ms = 1e3 * (clock_now() - t0);
    *pf = faults() - f0;
    *bytes = embree_held - held;
    return sc;
}

static void embree_ray(const Ray *r, struct RTCRay *e)
{
    e->org_x = r->o.x;
    e->org_y = r->o.y;
    e->org_z = r->o.z;
    e->dir_x = r->d.x;
    e->dir_y = r->d.y;
    e->dir_z = r->d.z;
    e->tnear = 0.0f;
    e->tfar = r->tmax;
    e->time = 0.0f;
    e->mask = ~0u;
    e->id = 0;
    e->flags = 0;
}

/* One pass of Embree over the rays, one by one; returns seconds. */
static double embree_pass(RTCScene sc, const Ray *rays, size_t n, int any, size_t *hits)
{
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    size_t k = 0;
    double t0 = clock_now();
    for (size_t i = 0; i < n; i++) {
        struct RTCRayHit rh;
        embree_ray(&rays[i], &rh.ray);
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

/* One pass of rtcIntersect8 over the rays, eight neighbours at a time;
 * returns seconds. */
static double embree_pass8(RTCScene sc, const Ray *rays, size_t n, size_t *hits)
{
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    RTC_ALIGN(32) int valid[8];
    RTC_ALIGN(32) struct RTCRayHit8 rh;
    size_t k = 0;
    double t0 = clock_now();
    for (size_t i = 0; i < n; i += 8) {
        for (int j = 0; j < 8; j++) {
            valid[j] = i + (size_t)j < n ? -1 : 0;
            const Ray *r = &rays[valid[j] ? i + (size_t)j : i];
            rh.ray.org_x[j] = r->o.x;
            rh.ray.org_y[j] = r->o.y;
            rh.ray.org_z[j] = r->o.z;
            rh.ray.dir_x[j] = r->d.x;
            rh.ray.dir_y[j] = r->d.y;
            rh.ray.dir_z[j] = r->d.z;
            rh.ray.tnear[j] = 0.0f;
            rh.ray.tfar[j] = r->tmax;
            rh.ray.time[j] = 0.0f;
            rh.ray.mask[j] = ~0u;
            rh.ray.id[j] = 0;
            rh.ray.flags[j] = 0;
            rh.hit.geomID[j] = RTC_INVALID_GEOMETRY_ID;
            rh.hit.instID[0][j] = RTC_INVALID_GEOMETRY_ID;
        }
        rtcIntersect8(valid, sc, &ctx, &rh);
        for (int j = 0; j < 8; j++)
            k += valid[j] && rh.hit.geomID[j] != RTC_INVALID_GEOMETRY_ID;
    }
    *hits = k;
    return clock_now() - t0;
}

/* The tracers of one ray file: each fills its Mrays/s of a pass and its hits. */
enum { LANCER, LANCER8, EMBREE, EMBREE8, LANCER_STREAM };

/* A ray file's tracers, in turns, and its rows: each the ratio of a lancer
 * tracer to an Embree one (their places in which[]), with its label (NULL:
 * the file's name and ray count) and its target in the results. Camera rays
 * one by one and in packets; shadow rays; diffuse rays one by one, and
 * lancer's stream against the same Embree pass. */
typedef struct {
    const char *file;
    int any, tracers, which[4], rows;
    struct {
        int lancer, embree;
        const char *label, *target;
    } row[2];
} FileRuns;

static const FileRuns file_runs[3] = {
    {"primary", 0, 4, {LANCER, EMBREE, LANCER8, EMBREE8}, 2,
     {{0, 1, NULL, "camera"}, {2, 3, "primary, packets of 8", "packet"}}},
    {"shadow", 1, 2, {LANCER, EMBREE, 0, 0}, 1, {{0, 1, NULL, "shadow"}, {0, 0, NULL, NULL}}},
    {"diffuse", 0, 3, {LANCER, EMBREE, LANCER_STREAM, 0}, 2,
     {{0, 1, NULL, "diffuse-single"}, {2, 1, "diffuse, one stream", "stream"}}},
};

typedef struct {
    const Accel *acc;
    RTCScene sc;
    const Ray *rays;
    size_t n;
    AccelStream *stream; /* for LANCER_STREAM: room for n rays and their answers */
    PrimHit *h;
    int *best;
} Work;

static double run(const Work *w, int tracer, int any, size_t *hits)
{
    double sumt, s;
    switch (tracer) {
    case LANCER:
        s = bench_pass(w->acc, w->rays, w->n, any, hits, &sumt);
        break;
    case LANCER8:
        s = bench_pass_packet(w->acc, w->rays, w->n, hits, &sumt);
        break;
    case LANCER_STREAM:
        s = bench_pass_stream(w->acc, w->stream, w->rays, w->n, w->h, w->best, hits, &sumt);
        break;
    case EMBREE:
        s = embree_pass(w->sc, w->rays, w->n, any, hits);
        break;
    default:
        s = embree_pass8(w->sc, w->rays, w->n, hits);
    }
    return (double)w->n / s / 1e6;
}

static const char *base_name(const char *path)
{
    const char *s = strrchr(path, '/');
    return s && s[1] ? s + 1 : path;
}

int main(int argc, char **argv)
{
    if (argc < 5) {
        fprintf(stderr, "usage: embree_bench MESH PASSES RESULTS DIR [DIR ...]\n");
        return 2;
    }
    int passes = atoi(argv[2]);
    if (passes < 1 || passes > ROUNDS_MAX)
        passes = 11;
    FILE *out = fopen(argv[3], "a");
    if (!out) {
        perror(argv[3]);
        return 1;
    }
    char err[1024], mesh[256];
    snprintf(mesh, sizeof mesh, "%s", base_name(argv[1]));
    char *dot = strrchr(mesh, '.');
    if (dot)
        *dot = '\0';
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
    rtcSetDeviceMemoryMonitorFunction(dev, monitor, NULL);
    double lb[ROUNDS_MAX], ed[ROUNDS_MAX], er[ROUNDS_MAX], lf[ROUNDS_MAX], ef[ROUNDS_MAX];
    long long bd = 0, br = 0;
    Accel *acc = NULL;
    RTCScene sd = NULL, sr = NULL;
    for (int k = 0; k < passes; k++) { /* builds, alternating too */
        accel_free(acc); /* (outside the window, as Embree's release) */
        double f0 = faults(), t0 = clock_now();
        if (!(acc = accel_build(&s, PRIM_ROBUST, 1)))
            return 1;
        lb[k] = 1e3 * (clock_now() - t0);
        lf[k] = faults() - f0;
        if (sd) {
            rtcReleaseScene(sd);
            rtcReleaseScene(sr);
        }
        double pd, pr;
        sd = embree_scene(dev, &m, 0, &ed[k], &bd, &pd);
        sr = embree_scene(dev, &m, 1, &er[k], &br, &pr);
        ef[k] = 0.5 * (pd + pr);
    }
    double lbytes = (double)accel_bytes(acc) / m.nt, ebytes = (double)(bd < br ? bd : br) / m.nt;
    double eb = median(ed, passes) < median(er, passes) ? median(ed, passes) : median(er, passes);
    printf("### %s: %d triangles (%d degenerate dropped)\n\n", mesh, m.nt, m.degenerate);
    printf("- build, one thread, median of %d: lancer %.1f ms, Embree %.1f ms, Embree robust %.1f ms; "
           "lancer / the faster Embree = %.2f\n",
           passes, median(lb, passes), median(ed, passes), median(er, passes), median(lb, passes) / eb);
    printf("- page faults per build, median and most: lancer %.0f and %.0f, Embree %.0f and %.0f "
           "(the mean of its two builds)\n",
           median(lf, passes), largest(lf, passes), median(ef, passes), largest(ef, passes));
    printf("- BVH bytes per triangle: lancer %.1f, Embree %.1f, Embree robust %.1f\n\n", lbytes,
           (double)bd / m.nt, (double)br / m.nt);
    fprintf(out, "build\t%s\t%.3f\n", mesh, median(lb, passes) / eb);
    fprintf(out, "faults\t%s\t%.3f\n", mesh, largest(lf, passes) / largest(ef, passes));
    fprintf(out, "memory\t%s\t%.3f\n", mesh, lbytes / ebytes);

    printf("| framing | rays | lancer Mrays/s | Embree robust | lancer / Embree | hits (lancer, Embree) |\n"
           "| --- | --- | --- | --- | --- | --- |\n");
    for (int d = 4; d < argc; d++) {
        const char *framing = base_name(argv[d]);
        for (int f = 0; f < 3; f++) {
            const FileRuns *fr = &file_runs[f];
            char path[1024];
            snprintf(path, sizeof path, "%s/%s.rays", argv[d], fr->file);
            Ray *rays;
            size_t n;
            if (rayfile_read(path, &rays, &n, err, sizeof err) != 0) {
                fprintf(stderr, "%s\n", err);
                return 1;
            }
            Work w = {acc, sr, rays, n, NULL, NULL, NULL};
            for (int t = 0; t < fr->tracers; t++)
                if (fr->which[t] == LANCER_STREAM && (!(w.stream = accel_stream_new(n)) ||
                                                      !(w.h = malloc(n * sizeof *w.h)) ||
                                                      !(w.best = malloc(n * sizeof *w.best)))) {
                    fprintf(stderr, "out of memory\n");
                    return 1;
                }
            double mr[4][ROUNDS_MAX], q[2][ROUNDS_MAX];
            size_t hits[4];
            for (int t = 0; t < fr->tracers; t++) /* warm-up */
                run(&w, fr->which[t], fr->any, &hits[t]);
            for (int k = 0; k < passes; k++) {
                for (int j = 0; j < fr->tracers; j++) {
                    int t = (j + k) % fr->tracers;
                    mr[t][k] = run(&w, fr->which[t], fr->any, &hits[t]);
                }
                for (int r = 0; r < fr->rows; r++)
                    q[r][k] = mr[fr->row[r].lancer][k] / mr[fr->row[r].embree][k];
            }
            char c[300], label[64];
            snprintf(c, sizeof c, "%s/%s", mesh, framing);
            for (int r = 0; r < fr->rows; r++) {
                const int l = fr->row[r].lancer, e = fr->row[r].embree;
                if (fr->row[r].label)
                    snprintf(label, sizeof label, "%s", fr->row[r].label);
                else
                    snprintf(label, sizeof label, "%s (%zu)", fr->file, n);
                printf("| %s | %s | %.2f | %.2f | %.2f | %zu, %zu |\n", framing, label, median(mr[l], passes),
                       median(mr[e], passes), median(q[r], passes), hits[l], hits[e]);
                fprintf(out, "%s\t%s\t%.3f\n", fr->row[r].target, c, median(q[r], passes));
            }
            accel_stream_free(w.stream);
            free(w.h);
            free(w.best);
            free(rays);
        }
    }
    printf("\n");
    fclose(out);
    rtcReleaseScene(sd);
    rtcReleaseScene(sr);
    rtcReleaseDevice(dev);
    accel_free(acc);
    scene_free(&s);
    mesh_free(&m);
    return 0;
}
