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
#include "lancer/stop.h"
#include "lancer/thread.h"
#include "bigmem.h"

typedef struct {
    const RenderPlan *p;
    const Accel *a;
    Camera cam;
    Image *img; /* the plan's region */
    RenderProgress progress;
    void *progress_ctx;
    const volatile sig_atomic_t *stop;
    unsigned char *rows_done; /* per row of the region */
    ThreadPool *pool;
    pthread_mutex_t lock;     /* guards stats and progress (and next and progress_done without atomics) */
    int next, progress_done, progress_total;
    RayStats stats;
    /* The pass: 0 the spp x spp grid of every pixel; with adaptive
     * supersampling, 1 the centre sample of every pixel the mask needs,
     * into centre, then 2 the grid of the pixels whose mask is set. */
    int pass;
    const int *rows; /* the pass's image rows, nrows of them */
    int nrows;
    float *centre;       /* pass 1: columns cx0..cx1-1 of image rows cy0.. */
    int cx0, cx1, cy0;
} Job;

/* Starts loading the primitives hit, which shading reads first (their
 * material, then their shape): the loads then overlap instead of stalling
 * one shading after another. */
static void prefetch_prims(const Prim *prims, const int *best, int n)
{
    for (int m = 0; m < n; m++)
        if (best[m] >= 0)
            prim_prefetch(&prims[best[m]]);
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
    shade_traced_packet(job->p, job->a, r, n, best, h, st, job->stop, c);
    for (int m = 0; m < n; m++) {
        float *p = row + 3 * px[m];
        p[0] += c[m].x;
        p[1] += c[m].y;
        p[2] += c[m].z;
    }
}

/* Adaptive supersampling goes in bands of at least this many rows. */
#define RENDER_BAND 16

static int stopped(const Job *job) { return stop_read(job->stop); }

/* Columns xa..xb-1 of image row y into out (3 floats a pixel, from xa):
 * each pixel the mean of k x k camera rays through a regular grid of
 * sub-pixel centres, the same points as the pixel centres of a render at k
 * times the size (that render, averaged in blocks, is the box-filtered
 * reference). Pixels whose mask (from xa) is 0 are left alone. The camera
 * rays are traced ACCEL_PACKET at a time: neighbours share the eye and most
 * of their path through the BVH, and no ray's result depends on its
 * packet, so neither does a pixel on the region or the rows around it.
 * Returns 0, or -1 when stopped before the row was done. */
static int render_row(const Job *job, int y, int xa, int xb, int k, const unsigned char *mask, float *out,
                      RayStats *st)
{
    int n = 0;
    float sx[ACCEL_PACKET], sy[ACCEL_PACKET]; /* the samples' image-plane positions */
    int px[ACCEL_PACKET];
    float at[LIMIT_SPP]; /* the sub-pixel centres' offsets, once a row */
    for (int i = 0; i < k; i++)
        at[i] = ((float)i + 0.5f) / (float)k;
    for (int x = xa; x < xb; x++) {
        if (stopped(job))
            return -1;
        if (mask && !mask[x - xa])
            continue;
        float *o = out + 3 * (x - xa);
        o[0] = o[1] = o[2] = 0.0f;
        for (int j = 0; j < k; j++)
            for (int i = 0; i < k; i++) {
                sx[n] = (float)x + at[i];
                sy[n] = (float)y + at[j];
                px[n++] = x - xa;
                if (n == ACCEL_PACKET) {
                    trace_packet(job, sx, sy, px, n, out, st);
                    n = 0;
                }
            }
        st->camera += (unsigned long long)(k * k);
    }
    if (n > 0)
        trace_packet(job, sx, sy, px, n, out, st);
    if (stopped(job)) /* maybe within a pixel, which shade_traced_packet then left unfinished */
        return -1;
    if (k > 1)
        for (int x = xa; x < xb; x++)
            if (!mask || mask[x - xa])
                for (int c = 0; c < 3; c++)
                    out[3 * (x - xa) + c] *= 1.0f / (float)(k * k);
    return 0;
}

/* lancer's adaptive rule: a pixel is supersampled when its centre sample
 * differs from one of its four neighbours' in the image by more than the
 * threshold, in the sum of the channels' absolute differences. Decided
 * from the centres of pass 1, whole before pass 2 begins, so that no
 * pixel's fate depends on which thread got there first, nor on the region
 * or the rows a resumed render keeps. Sets mask, image row y's; returns
 * how many pixels it set. */
static long mask_row(const Job *job, int y, unsigned char *mask)
{
    const RenderPlan *p = job->p;
    size_t cw = (size_t)(job->cx1 - job->cx0);
    long n = 0;
    for (int x = p->x0; x < p->x1; x++) {
        const float *c = job->centre + ((size_t)(y - job->cy0) * cw + (size_t)(x - job->cx0)) * 3;
        static const int dx[4] = {-1, 1, 0, 0}, dy[4] = {0, 0, -1, 1};
        int on = 0;
        for (int k = 0; k < 4 && !on; k++) {
            int nx = x + dx[k], ny = y + dy[k];
            if (nx < 0 || ny < 0 || nx >= p->width || ny >= p->height)
                continue;
            const float *d = job->centre + ((size_t)(ny - job->cy0) * cw + (size_t)(nx - job->cx0)) * 3;
            on = fabsf(c[0] - d[0]) + fabsf(c[1] - d[1]) + fabsf(c[2] - d[2]) > p->aa_threshold;
        }
        mask[x - p->x0] = (unsigned char)on;
        n += on;
    }
    return n;
}

/* Row y of the pass: 1 when done, 0 when stopped. */
static int pass_row(const Job *job, int y, RayStats *st)
{
    const RenderPlan *p = job->p;
    int w = p->x1 - p->x0;
    if (job->pass == 1) {
        size_t cw = (size_t)(job->cx1 - job->cx0);
        return render_row(job, y, job->cx0, job->cx1, 1, NULL, job->centre + (size_t)(y - job->cy0) * cw * 3, st) == 0;
    }
    float *out = job->img->rgb + (size_t)(y - p->y0) * (size_t)w * 3;
    if (job->pass == 0)
        return render_row(job, y, p->x0, p->x1, p->spp, NULL, out, st) == 0;
    unsigned char mask[LIMIT_IMAGE_SIDE]; /* the row's: no other row reads it */
    st->supersampled += (unsigned long long)mask_row(job, y, mask);
    if (render_row(job, y, p->x0, p->x1, p->spp, mask, out, st) != 0)
        return 0;
    const float *c = job->centre + ((size_t)(y - job->cy0) * (size_t)(job->cx1 - job->cx0) + (size_t)(p->x0 - job->cx0)) * 3;
    for (int x = 0; x < w; x++)
        if (!mask[x]) /* its centre sample stands */
            memcpy(out + 3 * x, c + 3 * x, sizeof(float) * 3);
    return 1;
}

/* The pass's next row for a thread (an index into rows), or -1. The rows
 * are counted out atomically where the compiler can: a thread that finds
 * a lock taken sleeps, and a virtual machine's processor that sleeps may
 * take longer to wake than a short frame's row takes to render. */
static int claim_row(Job *job)
{
    if (stopped(job))
        return -1;
#ifdef __GNUC__
    int i = __atomic_fetch_add(&job->next, 1, __ATOMIC_RELAXED);
#else
    pthread_mutex_lock(&job->lock);
    int i = job->next++;
    pthread_mutex_unlock(&job->lock);
#endif
    return i < job->nrows ? i : -1;
}

/* Counts a finished row, and reports it to the progress callback (under
 * the lock, one call at a time, in order). */
static void finish_row(Job *job)
{
#ifdef __GNUC__
    if (!job->progress) {
        __atomic_fetch_add(&job->progress_done, 1, __ATOMIC_RELAXED);
        return;
    }
#endif
    pthread_mutex_lock(&job->lock);
    job->progress_done++;
    if (job->progress)
        job->progress(job->progress_ctx, job->progress_done, job->progress_total);
    pthread_mutex_unlock(&job->lock);
}

static void worker(void *arg)
{
    Job *job = arg;
    RayStats st = {0};
    for (;;) {
        int i = claim_row(job);
        if (i < 0 || !pass_row(job, job->rows[i], &st))
            break;
        if (job->pass != 1) /* a row is done after its last pass (read once the threads are joined) */
            job->rows_done[job->rows[i] - job->p->y0] = 1;
        finish_row(job);
    }
    pthread_mutex_lock(&job->lock);
    raystats_add(&job->stats, &st);
    pthread_mutex_unlock(&job->lock);
}

/* Runs the job's pass over rows[0..n-1] on the pool's threads, the
 * calling one among them; with last, the workers end after it (the
 * render's last pass). Returns 0 when every row of the pass is done, 1
 * when stopped. */
static int run_pass(Job *job, int pass, const int *rows, int n, int last)
{
    job->pass = pass;
    job->rows = rows;
    job->nrows = n;
    job->next = 0;
    int before = job->progress_done;
    (last ? pool_run_last : pool_run)(job->pool, worker, job);
    return job->progress_done - before < n ? 1 : 0;
}

int render_image(const RenderPlan *p, const Accel *a, const RenderOptions *opt, Image *img, RayStats *stats)
{
    int w = p->x1 - p->x0, h = p->y1 - p->y0;
    if (img->width != w || img->height != h || w > LIMIT_IMAGE_SIDE)
        return -1;
    Job job;
    memset(&job, 0, sizeof job);
    job.p = p;
    job.a = a;
    job.img = img;
    job.progress = opt ? opt->progress : NULL;
    job.progress_ctx = opt ? opt->progress_ctx : NULL;
    job.stop = opt ? opt->stop : NULL;
    job.pool = pool_new(p->threads); /* for every pass of the render */
    camera_init(&job.cam, &p->scene->camera, p->width, p->height);
    int adaptive = p->aa_threshold > 0.0f && p->spp > 1;
    /* the rows to do, and for pass 1 the rows around them too */
    job.cx0 = p->x0 > 0 ? p->x0 - 1 : 0;
    job.cx1 = p->x1 < p->width ? p->x1 + 1 : p->width;
    job.cy0 = p->y0 > 0 ? p->y0 - 1 : 0;
    int cy1 = p->y1 < p->height ? p->y1 + 1 : p->height;
    unsigned char *done = opt && opt->rows_done ? opt->rows_done : calloc((size_t)h, 1);
    int *todo = malloc(sizeof(int) * (size_t)h), *around = malloc(sizeof(int) * (size_t)(cy1 - job.cy0));
    if (adaptive)
        job.centre = big_zalloc(sizeof(float) * 3 * (size_t)(job.cx1 - job.cx0) * (size_t)(cy1 - job.cy0));
    int rc = -1, ntodo = 0, naround = 0;
    if (!done || !todo || !around || (adaptive && !job.centre) || !job.pool ||
        pthread_mutex_init(&job.lock, NULL) != 0)
        goto out;
    job.rows_done = done;
    for (int y = p->y0; y < p->y1; y++)
        if (!done[y - p->y0])
            todo[ntodo++] = y;
    if (!adaptive) {
        job.progress_total = ntodo;
        rc = run_pass(&job, 0, todo, ntodo, 1);
    } else {
        /* In bands of rows, so that a stopped render keeps the bands done:
         * the centres a band needs (its rows and the rows around them, each
         * traced once), its mask, then its grids. */
        for (int y = job.cy0; y < cy1; y++) {
            int need = 0;
            for (int d = -1; d <= 1; d++)
                need |= y + d >= p->y0 && y + d < p->y1 && !done[y + d - p->y0];
            naround += need;
        }
        job.progress_total = ntodo + naround;
        int band = 4 * p->threads > RENDER_BAND ? 4 * p->threads : RENDER_BAND, traced = job.cy0;
        rc = 0;
        for (int b = 0; b < ntodo && rc == 0; b += band) {
            int nb = ntodo - b < band ? ntodo - b : band, n = 0;
            int last = todo[b + nb - 1] + 1 < cy1 ? todo[b + nb - 1] + 1 : cy1 - 1;
            for (int y = todo[b] - 1 > traced ? todo[b] - 1 : traced; y <= last; y++) {
                int need = 0;
                for (int d = -1; d <= 1; d++)
                    need |= y + d >= p->y0 && y + d < p->y1 && !done[y + d - p->y0];
                if (need)
                    around[n++] = y;
            }
            traced = last + 1;
            rc = run_pass(&job, 1, around, n, 0);
            if (rc == 0)
                rc = run_pass(&job, 2, todo + b, nb, b + band >= ntodo);
        }
    }
    pthread_mutex_destroy(&job.lock);
    raystats_add(stats, &job.stats);
out:
    if (!(opt && opt->rows_done))
        free(done);
    free(todo);
    free(around);
    big_free(job.centre);
    pool_free(job.pool);
    return rc;
}
