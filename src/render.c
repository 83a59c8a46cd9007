/*
 * render.c - parallel render loop (see render.h for the determinism contract).
 */
#include "lancer/render.h"

#include <math.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>

#include "lancer/camera.h"
#include "lancer/shade.h"

typedef struct {
    const RenderPlan *p;
    const Accel *a;
    Camera cam;
    Image *img;
    RenderProgress progress;
    void *progress_ctx;
    const volatile sig_atomic_t *stop;
    unsigned char *rows_done_flags;
    pthread_mutex_t lock; /* guards next_row, rows_done, stats and progress */
    int next_row, rows_done;
    RayStats stats;
    /* Adaptive supersampling: pass 1 traces each pixel's centre; pass 2
     * the spp x spp grid of the pixels whose mask is set. */
    int pass;
    unsigned char *mask;
} Job;

/* Starts loading the primitives hit, which shading reads first (their
 * material, then their shape): the loads then overlap instead of stalling
 * one shading after another. */
static void prefetch_prims(const Prim *prims, const int *best, int n)
{
#ifdef __GNUC__
    for (int m = 0; m < n; m++)
        if (best[m] >= 0) { /* both ends: a Prim may straddle two cache lines */
            __builtin_prefetch(&prims[best[m]]);
            __builtin_prefetch((const char *)&prims[best[m]] + sizeof(Prim) - 1);
        }
#else
    (void)prims;
    (void)best;
    (void)n;
#endif
}

/* Traces the camera rays through image-plane positions (sx[m], sy[m]),
 * m < n, through the BVH together and adds each one's colour to its pixel
 * px[m] of row. */
static void trace_packet(const Job *job, const float *sx, const float *sy, const int *px, int n, float *row,
                         RayStats *st)
{
    Ray r[ACCEL_PACKET];
    int best[ACCEL_PACKET];
    PrimHit h[ACCEL_PACKET];
    camera_rays(&job->cam, sx, sy, n, r);
    accel_closest_packet(job->a, r, n, h, best, st);
    prefetch_prims(job->p->scene->prims, best, n);
    Vec3 c[ACCEL_PACKET];
    shade_traced_packet(job->p, job->a, r, n, best, h, st, c);
    for (int m = 0; m < n; m++) {
        float *p = row + 3 * px[m];
        p[0] += c[m].x;
        p[1] += c[m].y;
        p[2] += c[m].z;
    }
}

static int stopped(const Job *job) { return job->stop && *job->stop; }

/* Row y into row (3 floats a pixel): each pixel the mean of spp x spp
 * camera rays through a regular grid of sub-pixel centres, the same
 * points as the pixel centres of a render at spp times the size (that
 * render, averaged in blocks, is the box-filtered reference). The camera
 * rays are traced ACCEL_PACKET at a time: neighbours share the eye and most
 * of their path through the BVH. Returns 0, or -1 when stopped before the
 * row was done. */
static int render_row(const Job *job, int y, float *row, RayStats *st)
{
    int k = job->pass == 1 ? 1 : job->p->spp, w = job->img->width, n = 0;
    const unsigned char *mask = job->pass == 2 ? job->mask + (size_t)y * (size_t)w : NULL;
    float sx[ACCEL_PACKET], sy[ACCEL_PACKET]; /* the samples' image-plane positions */
    int px[ACCEL_PACKET];
    for (int x = 0; x < w; x++) {
        if (stopped(job))
            return -1;
        if (mask && !mask[x])
            continue; /* its centre sample stands */
        row[3 * x] = row[3 * x + 1] = row[3 * x + 2] = 0.0f;
        for (int j = 0; j < k; j++)
            for (int i = 0; i < k; i++) {
                sx[n] = (float)x + ((float)i + 0.5f) / (float)k;
                sy[n] = (float)y + ((float)j + 0.5f) / (float)k;
                px[n++] = x;
                if (n == ACCEL_PACKET) {
                    trace_packet(job, sx, sy, px, n, row, st);
                    n = 0;
                }
            }
        st->camera += (unsigned long long)(k * k);
    }
    if (n > 0)
        trace_packet(job, sx, sy, px, n, row, st);
    if (k > 1)
        for (int x = 0; x < w; x++)
            if (!mask || mask[x])
                for (int c = 0; c < 3; c++)
                    row[3 * x + c] *= 1.0f / (float)(k * k);
    return 0;
}

/* lancer's adaptive rule: a pixel is supersampled when its centre sample
 * differs from one of its four neighbours' by more than the threshold, in
 * the sum of the channels' absolute differences. Decided from the whole
 * first pass, so that no pixel's fate depends on which thread got there
 * first. Returns how many are. */
static long aa_mask(const Image *img, float threshold, unsigned char *mask)
{
    int w = img->width, h = img->height;
    long n = 0;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            const float *c = img->rgb + 3 * ((size_t)y * (size_t)w + (size_t)x);
            static const int dx[4] = {-1, 1, 0, 0}, dy[4] = {0, 0, -1, 1};
            int on = 0;
            for (int k = 0; k < 4 && !on; k++) {
                int nx = x + dx[k], ny = y + dy[k];
                if (nx < 0 || ny < 0 || nx >= w || ny >= h)
                    continue;
                const float *d = img->rgb + 3 * ((size_t)ny * (size_t)w + (size_t)nx);
                on = fabsf(c[0] - d[0]) + fabsf(c[1] - d[1]) + fabsf(c[2] - d[2]) > threshold;
            }
            mask[(size_t)y * (size_t)w + (size_t)x] = (unsigned char)on;
            n += on;
        }
    return n;
}

static void *worker(void *arg)
{
    Job *job = arg;
    RayStats st = {0, 0, 0, 0, 0, 0, 0};
    int w = job->img->width, h = job->img->height;
    int passes = job->mask ? 2 : 1; /* progress counts the rows of every pass */
    for (;;) {
        pthread_mutex_lock(&job->lock);
        int y = job->next_row < h && !stopped(job) ? job->next_row++ : -1;
        pthread_mutex_unlock(&job->lock);
        if (y < 0 || render_row(job, y, job->img->rgb + (size_t)y * (size_t)w * 3, &st) != 0)
            break;
        pthread_mutex_lock(&job->lock);
        if (job->rows_done_flags && job->pass != 1) /* a row is done after its last pass */
            job->rows_done_flags[y] = 1;
        job->rows_done++;
        if (job->progress)
            job->progress(job->progress_ctx, job->rows_done, passes * h);
        pthread_mutex_unlock(&job->lock);
    }
    pthread_mutex_lock(&job->lock);
    raystats_add(&job->stats, &st);
    pthread_mutex_unlock(&job->lock);
    return NULL;
}

/* Runs the job's pass on `threads` threads, the calling one among them.
 * Returns 0 when every row of the pass is done, 1 when stopped. */
static int run_pass(Job *job, int threads)
{
    int extra = threads > 1 ? threads - 1 : 0, started = 0, before = job->rows_done;
    pthread_t *tids = extra ? malloc(sizeof(pthread_t) * (size_t)extra) : NULL;
    if (tids)
        while (started < extra && pthread_create(&tids[started], NULL, worker, job) == 0)
            started++;
    worker(job); /* the calling thread works too */
    for (int i = 0; i < started; i++)
        pthread_join(tids[i], NULL);
    free(tids);
    return job->rows_done - before < job->img->height ? 1 : 0;
}

int render_image(const RenderPlan *p, const Accel *a, const RenderOptions *opt, Image *img, RayStats *stats)
{
    Job job;
    job.p = p;
    job.a = a;
    job.img = img;
    job.progress = opt ? opt->progress : NULL;
    job.progress_ctx = opt ? opt->progress_ctx : NULL;
    job.stop = opt ? opt->stop : NULL;
    job.rows_done_flags = opt ? opt->rows_done : NULL;
    if (job.rows_done_flags)
        memset(job.rows_done_flags, 0, (size_t)img->height);
    job.next_row = 0;
    job.rows_done = 0;
    job.stats = (RayStats){0, 0, 0, 0, 0, 0, 0};
    job.pass = 0;
    job.mask = NULL;
    camera_init(&job.cam, &p->scene->camera, img->width, img->height);
    if (p->aa_threshold > 0.0f && p->spp > 1) {
        job.mask = malloc((size_t)img->width * (size_t)img->height);
        if (!job.mask)
            return -1;
        job.pass = 1;
    }
    if (pthread_mutex_init(&job.lock, NULL) != 0) {
        free(job.mask);
        return -1;
    }
    int rc = run_pass(&job, p->threads);
    if (rc == 0 && job.mask) {
        long n = aa_mask(img, p->aa_threshold, job.mask);
        job.stats.supersampled += (unsigned long long)n;
        job.pass = 2;
        job.next_row = 0;
        rc = run_pass(&job, p->threads);
    }
    pthread_mutex_destroy(&job.lock);
    free(job.mask);
    raystats_add(stats, &job.stats);
    return rc;
}
