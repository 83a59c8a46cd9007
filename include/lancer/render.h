/*
 * render.h - the render loop: camera rays through every pixel, shaded, in
 * parallel.
 *
 *     RenderOptions opt = {on_progress, ctx, &stop_flag, rows_done};  or NULL
 *     int rc = render_image(&plan, accel, &opt, &img, &stats);
 *
 * The image size, the region rendered, samples per pixel and threads are
 * the plan's (plan.h); img holds the region. Rows are handed out to
 * threads one at a time; every pixel is computed on its own from the same
 * inputs, so it is bit-identical for any thread count, in any region, and
 * in a render resumed from any set of finished rows (adaptive
 * supersampling looks at the centre samples of the rows and columns
 * around the region, and around the rows still to do, as a whole render
 * does). A row's camera rays are traced eight at a time
 * (accel_closest_packet) and shaded together (shade_traced_packet, which
 * traces their shadow rays together), which changes no pixel: each is
 * shade_trace's.
 * The progress callback, when set, is called after each finished row with
 * the number of rows done, from whichever thread finished it, one call at a
 * time (it must not call back into the renderer).
 *
 * A render can be stopped (by a signal handler that sets *stop): threads
 * leave the row they are in, rows not yet started are not, and
 * render_image returns 1. rows_done[y] is then 1 for each finished row y of
 * the region. Rows whose flag is 1 on entry are kept as img holds them (a
 * resumed render's): only the others are rendered.
 */
#ifndef LANCER_RENDER_H
#define LANCER_RENDER_H

#include "lancer/accel.h"
#include "lancer/image.h"
#include "lancer/plan.h"

typedef void (*RenderProgress)(void *ctx, int rows_done, int rows_total);

#include <signal.h>

typedef struct {
    RenderProgress progress; /* NULL: none */
    void *progress_ctx;
    const volatile sig_atomic_t *stop; /* NULL, or nonzero to stop */
    unsigned char *rows_done;          /* NULL, or one flag (0 or 1) per row of the region */
} RenderOptions;

/* Renders into img, which must already have the size of the plan's
 * region. Adds the ray counts to *stats. Returns 0 when every row is done,
 * 1 when stopped, or -1 when img has another size or memory or the lock
 * cannot be had (the calling thread renders even when no other thread can
 * be started). */
int render_image(const RenderPlan *p, const Accel *a, const RenderOptions *opt, Image *img, RayStats *stats);

#endif
