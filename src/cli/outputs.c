/*
 * outputs.c - a render's outputs and the signals that stop it (see
 * outputs.h).
 *
 * The first SIGINT or SIGTERM only sets outputs_stop, which the render
 * threads read. A second one removes the run's temporary files (unlink(2)
 * only: safe in a handler) and exits at once. The set of outputs is
 * changed, and put in place, with the signals held, so that the handler
 * never sees it half updated and a run never stops half way through
 * replacing its outputs.
 */
#include "outputs.h"

#include <pthread.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "lancer/afile.h"
#include "lancer/stop.h"
#include "lancer/thread.h"

volatile sig_atomic_t outputs_stop;
static AfileSet run_files;

static void on_signal(int sig)
{
    if (stop_read(&outputs_stop)) {
        afile_set_abort(&run_files);
        _exit(128 + sig);
    }
    stop_set(&outputs_stop, sig);
}

int outputs_stopped(void) { return stop_read(&outputs_stop); }

/* A signal ignored when lancer started (nohup, a background job of a
 * shell) stays ignored, as the caller meant. */
void outputs_catch_signals(void)
{
    static const int sigs[2] = {SIGINT, SIGTERM};
    for (int i = 0; i < 2; i++) {
        struct sigaction sa, old;
        if (sigaction(sigs[i], NULL, &old) != 0 || old.sa_handler == SIG_IGN)
            continue;
        memset(&sa, 0, sizeof sa);
        sa.sa_handler = on_signal;
        sigemptyset(&sa.sa_mask);
        sigaction(sigs[i], &sa, NULL);
    }
}

static void hold_signals(int hold)
{
    sigset_t set;
    sigemptyset(&set);
    sigaddset(&set, SIGINT);
    sigaddset(&set, SIGTERM);
    pthread_sigmask(hold ? SIG_BLOCK : SIG_UNBLOCK, &set, NULL);
}

/* Adds path to the run's files with the signals held (a handler must not
 * see the set half updated). Returns the temporary file's name, or NULL
 * after a message. */
const char *outputs_add(const char *path)
{
    char err[AFILE_PATH_MAX + 128];
    hold_signals(1);
    const char *tmp = afile_set_add(&run_files, path, err, sizeof err);
    hold_signals(0);
    if (!tmp)
        fprintf(stderr, "lancer: %s\n", err);
    return tmp;
}

int outputs_commit(void)
{
    char err[AFILE_PATH_MAX + 128];
    hold_signals(1);
    int rc = afile_set_commit(&run_files, err, sizeof err);
    hold_signals(0);
    if (rc != 0)
        fprintf(stderr, "lancer: %s\n", err);
    return rc;
}

void outputs_abort(void)
{
    hold_signals(1);
    afile_set_abort(&run_files);
    hold_signals(0);
}

/* "<exr without .exr>.partial.exr" into buf. Returns 0, or -1 after a
 * message. */
int outputs_partial_name(const char *exr, char *buf, size_t len)
{
    size_t n = strlen(exr);
    if (n >= 4 && !strcmp(exr + n - 4, ".exr"))
        n -= 4;
    int w = snprintf(buf, len, "%.*s.partial.exr", (int)n, exr);
    if (w < 0 || (size_t)w >= len) {
        fprintf(stderr, "lancer: %s: path too long\n", exr);
        return -1;
    }
    return 0;
}

/* The finished rows as inclusive ranges, "0-11,14,20-31", into buf. */
static void rows_list(const unsigned char *done, int h, char *buf, size_t len)
{
    size_t at = 0;
    buf[0] = '\0';
    for (int y = 0; y < h; y++) {
        if (!done[y] || (y > 0 && done[y - 1]))
            continue;
        int end = y;
        while (end + 1 < h && done[end + 1])
            end++;
        int w = end > y ? snprintf(buf + at, len - at, "%s%d-%d", at ? "," : "", y, end)
                        : snprintf(buf + at, len - at, "%s%d", at ? "," : "", y);
        if (w < 0 || (size_t)w >= len - at)
            return; /* cannot happen: len allows every other row */
        at += (size_t)w;
    }
}

/* Saves the finished rows of a stopped render to the partial image, the
 * rows not finished black, the finished ones listed in its header
 * ("lancer:rows"). Returns the exit status: 128 + the signal, or 1 when
 * the partial image cannot be written. */
int outputs_save_partial(const ImageAttr *attrs, int nattrs, const char *exr, const char *partial, Image *img,
                         const unsigned char *done, const char *lead)
{
    int sig = outputs_stopped(), n = 0, w = img->width, h = img->height;
    for (int y = 0; y < h; y++)
        if (done[y])
            n++;
        else
            memset(img->rgb + (size_t)y * (size_t)w * 3, 0, sizeof(float) * 3 * (size_t)w);
    const char *name = sig == SIGINT ? "SIGINT" : "SIGTERM";
    if (n == 0) {
        fprintf(stderr, "%slancer: stopped by %s before a row was done; %s is unchanged\n", lead, name, exr);
        return 128 + sig;
    }
    size_t len = 12 * (size_t)h + 1;
    char *rows = malloc(len), err[AFILE_PATH_MAX + 128];
    if (!rows) {
        fprintf(stderr, "%slancer: stopped by %s; out of memory saving %s\n", lead, name, partial);
        return 1;
    }
    rows_list(done, h, rows, len);
    ImageAttr all[IMAGE_META_MAX];
    int n_all = 0;
    for (int i = 0; i < nattrs && n_all < IMAGE_META_MAX - 1; i++)
        all[n_all++] = attrs[i];
    all[n_all++] = (ImageAttr){"lancer:rows", rows};
    const char *tmp = outputs_add(partial);
    int rc = !tmp || image_write_exr_file(img, tmp, partial, IMAGE_FLOAT, all, n_all, 1, err, sizeof err) != 0;
    if (tmp && rc)
        fprintf(stderr, "lancer: %s\n", err);
    if (rc)
        outputs_abort();
    else
        rc = outputs_commit() != 0;
    free(rows);
    if (rc)
        return 1;
    fprintf(stderr, "%slancer: stopped by %s: %d of %d rows saved in %s; %s is unchanged\n", lead, name, n, h,
            partial, exr);
    return 128 + sig;
}

int outputs_parse_rows(const char *rows, unsigned char *done, int h)
{
    memset(done, 0, (size_t)h);
    const char *p = rows;
    while (*p) {
        char *end;
        long a = strtol(p, &end, 10), b = a;
        if (end == p || a < 0 || a >= h)
            return -1;
        p = end;
        if (*p == '-') {
            b = strtol(p + 1, &end, 10);
            if (end == p + 1 || b < a || b >= h)
                return -1;
            p = end;
        }
        for (long y = a; y <= b; y++)
            done[y] = 1;
        if (*p == ',')
            p++;
        else if (*p)
            return -1;
    }
    return 0;
}

/* The PNG preview into its temporary file tmp: on a thread of its own
 * beside the EXR, or after it. */
typedef struct {
    const Image *img;
    ImagePrecision prec;
    const char *tmp, *name;
    int rc;
    char err[AFILE_PATH_MAX + 128];
} PngJob;

static void *write_png(void *arg)
{
    PngJob *j = arg;
    j->rc = image_write_png_file(j->img, j->tmp, j->name, j->prec, j->err, sizeof j->err);
    return NULL;
}

int outputs_write_images(const Image *img, const char *exr, const char *exr_name, ImagePrecision prec,
                         const ImageAttr *attrs, int nattrs, const char *png, const char *png_name, int threads)
{
    char err[AFILE_PATH_MAX + 128];
    int rc = 0;
    PngJob pj = {img, prec, png, png_name, 0, ""};
    pthread_t tid;
    int beside = png && threads > 1 && thread_start(&tid, write_png, &pj) == 0;
    if (image_write_exr_file(img, exr, exr_name, prec, attrs, nattrs, threads - beside, err, sizeof err) != 0) {
        fprintf(stderr, "lancer: %s\n", err);
        rc = -1;
    }
    if (beside)
        pthread_join(tid, NULL);
    else if (rc == 0 && png)
        write_png(&pj);
    if (pj.rc != 0) {
        fprintf(stderr, "lancer: %s\n", pj.err);
        rc = -1;
    }
    return rc;
}
