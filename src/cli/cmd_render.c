/*
 * cmd_render.c - lancer render: a scene file to an EXR image, with an
 * optional PNG preview and statistics.
 */
#include <errno.h>
#include <pthread.h>
#include <signal.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "cli.h"
#include "clock.h"
#include "lancer/afile.h"
#include "lancer/render.h"

static const char usage[] =
    "usage: lancer render SCENE [options]\n"
    "\n"
    "Renders SCENE (lancer's scene format, see README.md) to a linear OpenEXR\n"
    "image. Outputs are written to a temporary file and renamed into place, so\n"
    "an existing file is only replaced by a complete new one.\n"
    "\n"
    "options:\n"
    "  -o, --output OUT.exr  the EXR to write (default: out/<scene name>.exr)\n"
    "      --png OUT.png     also write an 8-bit sRGB PNG preview\n"
    "      --width W         image width in pixels (overrides the scene)\n"
    "      --height H        image height in pixels (overrides the scene)\n"
    "      --spp K           K x K samples per pixel, box-filtered (overrides the scene)\n"
    "      --threads N       render threads (default: every core)\n"
    "      --float           write 32-bit float channels (default: half)\n"
    "      --classic         use the classic intersection routines instead of the\n"
    "                        robust ones (to compare their cost and error)\n"
    "      --scale S         scale the whole scene, camera and lights included\n"
    "      --translate X,Y,Z then move it: the picture should not change\n"
    "      --stats FILE.json write the render plan, timings and ray counts as JSON\n"
    "  -q, --quiet           no progress bar or summary on stderr\n"
    "  -h, --help            show this help\n";

typedef struct {
    const char *exr, *png, *stats;
    int width, height, spp, threads, quiet, use_float, classic;
    double scale;
    const char *translate;
} Args;

static void defaults(void *args)
{
    Args *a = args;
    long cores = sysconf(_SC_NPROCESSORS_ONLN);
    a->threads = cores > 0 ? (int)(cores < LIMIT_THREADS ? cores : LIMIT_THREADS) : 1;
}

typedef struct {
    int last_percent, shown;
    double start;
} Progress;

/* Seconds a render must run before the bar appears: short renders stay quiet. */
#define PROGRESS_DELAY 0.3

static void on_progress(void *ctx, int done, int total)
{
    Progress *p = ctx;
    int percent = (int)(100LL * done / total);
    if (percent == p->last_percent)
        return;
    if (!p->shown && clock_now() - p->start < PROGRESS_DELAY)
        return;
    p->shown = 1;
    p->last_percent = percent;
    char bar[41];
    int filled = percent * 40 / 100;
    for (int i = 0; i < 40; i++)
        bar[i] = i < filled ? '#' : '.';
    bar[40] = '\0';
    double el = clock_now() - p->start;
    double eta = done > 0 ? el * (total - done) / done : 0.0;
    fprintf(stderr, "\rrendering [%s] %3d%%  %.1fs elapsed, %.1fs left ", bar, percent, el, eta);
    if (done == total)
        fputc('\n', stderr);
}

/* Appends s to f as a JSON string. */
static void json_string(FILE *f, const char *s)
{
    fputc('"', f);
    for (; *s; s++) {
        unsigned char c = (unsigned char)*s;
        if (c == '"' || c == '\\')
            fprintf(f, "\\%c", c);
        else if (c < 0x20)
            fprintf(f, "\\u%04x", c);
        else
            fputc(c, f);
    }
    fputc('"', f);
}

static const char *json_bool(int b) { return b ? "true" : "false"; }

/* The plan as a JSON object, what the renderer decided to do. */
static void write_plan(FILE *f, const RenderPlan *p)
{
    static const char *const shadows[] = {"none", "opaque", "filtered"};
    const Scene *s = p->scene;
    fprintf(f,
            "{\"width\": %d, \"height\": %d, \"spp\": %d, \"max_depth\": %d, \"threads\": %d, "
            "\"intersect\": \"%s\",\n",
            p->width, p->height, p->spp, p->max_depth, p->threads, p->variant == PRIM_CLASSIC ? "classic" : "robust");
    fprintf(f, "           \"camera_offset\": [%.9g, %.9g, %.9g], \"camera_inside\": [", (double)p->offset.x,
            (double)p->offset.y, (double)p->offset.z);
    for (int i = 0; i < p->camera_in.n; i++)
        fprintf(f, "%s%d", i ? ", " : "", p->camera_in.prim[i]);
    fprintf(f, "],\n           \"transparent\": %s, \"reflective\": %s,\n           \"lights\": [",
            json_bool(p->transparent), json_bool(p->reflective));
    for (int i = 0; i < s->nlights; i++)
        fprintf(f, "%s{\"shadows\": \"%s\", \"samples\": %d}", i ? ", " : "", shadows[p->shadow[i]],
                s->lights[i].area_n1 * s->lights[i].area_n2);
    fprintf(f, "]}");
}

/* Writes the statistics as JSON into the file `file` (a temporary file of
 * the run's set; path names it in messages). */
static int write_stats(const char *file, const char *path, const char *scene, const RenderPlan *p,
                       const double phase[4], const RayStats *st)
{
    FILE *f = fopen(file, "w");
    if (!f) {
        fprintf(stderr, "lancer: %s: cannot write: %s\n", path, strerror(errno));
        return -1;
    }
    fprintf(f, "{\n  \"scene\": ");
    json_string(f, scene);
    fprintf(f, ",\n  \"plan\": ");
    write_plan(f, p);
    fprintf(f, ",\n  \"primitives\": %d,\n  \"degenerate_triangles\": %d,\n", p->scene->nprims,
            p->scene->degenerate);
    fprintf(f, "  \"phases_s\": {\"parse\": %.6f, \"build\": %.6f, \"render\": %.6f, \"write\": %.6f},\n",
            phase[0], phase[1], phase[2], phase[3]);
    fprintf(f,
            "  \"rays\": {\"camera\": %llu, \"shadow\": %llu, \"reflection\": %llu, \"refraction\": %llu, "
            "\"total\": %llu},\n",
            st->camera, st->shadow, st->reflection, st->refraction,
            st->camera + st->shadow + st->reflection + st->refraction);
    fprintf(f, "  \"intersection_tests\": %llu\n}\n", st->isect_tests);
    int bad = ferror(f), saved = errno;
    if (fclose(f) != 0 || bad) {
        fprintf(stderr, "lancer: %s: cannot write: %s\n", path, strerror(bad ? saved : errno));
        return -1;
    }
    return 0;
}

/* The plan's options from the command line. Returns 0, or 2 after a usage
 * message. */
static int plan_options_of(const Args *a, PlanOptions *o)
{
    *o = plan_options();
    o->width = a->width;
    o->height = a->height;
    o->spp = a->spp;
    o->classic = a->classic;
    o->threads = a->threads;
    if (a->scale > 0.0 || a->translate) {
        char tail;
        o->move = 1;
        o->scale = a->scale > 0.0 ? (float)a->scale : 1.0f;
        if (a->translate && sscanf(a->translate, "%f,%f,%f%c", &o->translate.x, &o->translate.y,
                                   &o->translate.z, &tail) != 3)
            return cli_usage_error("render", "--translate needs X,Y,Z, not '%s'", a->translate);
    }
    return 0;
}

/* ---- stopping: SIGINT and SIGTERM ----
 *
 * The first signal asks the render to stop: the threads leave their rows,
 * and the rows finished so far are saved to the partial image, for a later
 * run to resume. A second signal exits at once, after removing the run's
 * temporary files (unlink(2) only: safe in a handler). The outputs are put
 * in place with the signals held, so that a run never stops half way
 * through replacing them. */

static volatile sig_atomic_t stop_signal;
static AfileSet run_files;

static void on_signal(int sig)
{
    if (stop_signal) {
        afile_set_abort(&run_files);
        _exit(128 + sig);
    }
    stop_signal = sig;
}

/* A signal ignored when lancer started (nohup, a background job of a
 * shell) stays ignored, as the caller meant. */
static void catch_signals(void)
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
static const char *add_output(const char *path)
{
    char err[AFILE_PATH_MAX + 128];
    hold_signals(1);
    const char *tmp = afile_set_add(&run_files, path, err, sizeof err);
    hold_signals(0);
    if (!tmp)
        fprintf(stderr, "lancer: %s\n", err);
    return tmp;
}

static int commit_outputs(void)
{
    char err[AFILE_PATH_MAX + 128];
    hold_signals(1);
    int rc = afile_set_commit(&run_files, err, sizeof err);
    hold_signals(0);
    if (rc != 0)
        fprintf(stderr, "lancer: %s\n", err);
    return rc;
}

static void abort_outputs(void)
{
    hold_signals(1);
    afile_set_abort(&run_files);
    hold_signals(0);
}

/* "<exr without .exr>.partial.exr" into buf. Returns 0, or -1 after a
 * message. */
static int partial_name(const char *exr, char *buf, size_t len)
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
static int save_partial(const char *scene, const char *exr, const char *partial, Image *img,
                        const unsigned char *done, const char *lead)
{
    int sig = stop_signal, n = 0, w = img->width, h = img->height;
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
    const ImageAttr attrs[] = {{"lancer:rows", rows}, {"lancer:scene", scene}};
    const char *tmp = add_output(partial);
    int rc = !tmp || image_write_exr_file(img, tmp, partial, IMAGE_FLOAT, attrs, 2, err, sizeof err) != 0;
    if (tmp && rc)
        fprintf(stderr, "lancer: %s\n", err);
    if (rc)
        abort_outputs();
    else
        rc = commit_outputs() != 0;
    free(rows);
    if (rc)
        return 1;
    fprintf(stderr, "%slancer: stopped by %s: %d of %d rows saved in %s; %s is unchanged\n", lead, name, n, h,
            partial, exr);
    return 128 + sig;
}

/* Writes the run's outputs into temporary files and puts them all in place
 * together, or none. Returns 0, -1 after a message, or 1 when a signal came
 * while they were written (they are then discarded). */
static int write_outputs(const Args *a, const char *scene, const RenderPlan *plan, const Image *img,
                         double phase[4], const RayStats *st)
{
    char err[AFILE_PATH_MAX + 128];
    double t0 = clock_now();
    const char *exr = add_output(a->exr);
    const char *png = exr && a->png ? add_output(a->png) : NULL;
    const char *stats = exr && (!a->png || png) && a->stats ? add_output(a->stats) : NULL;
    int rc = 0;
    if (!exr || (a->png && !png) || (a->stats && !stats))
        rc = -1;
    if (rc == 0 && image_write_exr_file(img, exr, a->exr, a->use_float ? IMAGE_FLOAT : IMAGE_HALF, NULL, 0, err,
                                        sizeof err) != 0) {
        fprintf(stderr, "lancer: %s\n", err);
        rc = -1;
    }
    if (rc == 0 && png && image_write_png_file(img, png, a->png, err, sizeof err) != 0) {
        fprintf(stderr, "lancer: %s\n", err);
        rc = -1;
    }
    phase[3] = clock_now() - t0;
    if (rc == 0 && stats && write_stats(stats, a->stats, scene, plan, phase, st) != 0)
        rc = -1;
    if (rc == 0 && stop_signal)
        rc = 1;
    if (rc != 0) {
        abort_outputs();
        return rc;
    }
    return commit_outputs();
}

static int run(void *args, const char **pos, int npos)
{
    Args *a = args;
    if (npos == 0)
        return cli_usage_error("render", "missing SCENE");
    const char *scene = pos[0];
    PlanOptions po;
    int rc = plan_options_of(a, &po);
    if (rc)
        return rc;

    char exr_default[AFILE_PATH_MAX], partial[AFILE_PATH_MAX], err[1024];
    double phase[4] = {0, 0, 0, 0}, t0 = clock_now();
    Scene s;
    if (scene_load(scene, &s, err, sizeof err) != 0) {
        fprintf(stderr, "%s\n", err);
        return 1;
    }
    phase[0] = clock_now() - t0;
    RenderPlan plan;
    if (plan_build(&plan, &s, &po, err, sizeof err) != 0) {
        fprintf(stderr, "lancer: %s: %s\n", scene, err);
        scene_free(&s);
        return 1;
    }
    if (!a->exr && cli_default_output(scene, ".exr", exr_default, sizeof exr_default) == 0)
        a->exr = exr_default;
    /* Fail on an output that cannot or must not be written before spending
     * time on the render. */
    const CliOutput outs[] = {{"-o", a->exr}, {"--png", a->png}, {"--stats", a->stats}, {"(partial)", partial}};
    if (!a->exr || partial_name(a->exr, partial, sizeof partial) != 0 ||
        cli_check_outputs(outs, 4, (const char *const *)s.inputs, s.ninputs) != 0) {
        plan_free(&plan);
        scene_free(&s);
        return 1;
    }

    Image img;
    RayStats st = {0, 0, 0, 0, 0};
    unsigned char *done = malloc((size_t)plan.height);
    if (!done || image_init(&img, plan.width, plan.height) != 0) {
        fprintf(stderr, "lancer: out of memory for a %dx%d image\n", plan.width, plan.height);
        free(done);
        plan_free(&plan);
        scene_free(&s);
        return 1;
    }
    catch_signals();
    t0 = clock_now();
    Accel *acc = accel_build(&s, plan.variant, plan.threads);
    if (!acc) {
        fprintf(stderr, "lancer: out of memory building the acceleration structure\n");
        image_free(&img);
        free(done);
        plan_free(&plan);
        scene_free(&s);
        return 1;
    }
    phase[1] = clock_now() - t0;

    Progress prog = {-1, 0, clock_now()};
    RenderOptions opt = {NULL, &prog, &stop_signal, done};
    if (!a->quiet && isatty(STDERR_FILENO))
        opt.progress = on_progress;
    t0 = clock_now();
    rc = render_image(&plan, acc, &opt, &img, &st);
    phase[2] = clock_now() - t0;
    if (rc < 0)
        fprintf(stderr, "lancer: could not set up the render threads\n");
    else if (rc == 0)
        rc = write_outputs(a, scene, &plan, &img, phase, &st);
    if (rc == 1) /* stopped, while rendering or writing */
        rc = save_partial(scene, a->exr, partial, &img, done, prog.shown && prog.last_percent < 100 ? "\n" : "");
    else if (rc == 0) {
        struct stat old;
        if (lstat(partial, &old) == 0 && S_ISREG(old.st_mode))
            unlink(partial); /* the rest of a stopped run, now done */
        if (!a->quiet)
            fprintf(stderr, "lancer: wrote %s%s%s (%dx%d, %d thread%s, render %.3f s)\n", a->exr,
                    a->png ? " and " : "", a->png ? a->png : "", plan.width, plan.height, plan.threads,
                    plan.threads > 1 ? "s" : "", phase[2]);
    } else
        rc = 1;
    accel_free(acc);
    image_free(&img);
    free(done);
    plan_free(&plan);
    scene_free(&s);
    return rc;
}

static const Opt opts[] = {
    {"--output", "-o", OPT_STRING, offsetof(Args, exr), 0, 0},
    {"--png", NULL, OPT_STRING, offsetof(Args, png), 0, 0},
    {"--stats", NULL, OPT_STRING, offsetof(Args, stats), 0, 0},
    {"--width", NULL, OPT_INT, offsetof(Args, width), 1, LIMIT_IMAGE_SIDE},
    {"--height", NULL, OPT_INT, offsetof(Args, height), 1, LIMIT_IMAGE_SIDE},
    {"--spp", NULL, OPT_INT, offsetof(Args, spp), 1, LIMIT_SPP},
    {"--threads", NULL, OPT_INT, offsetof(Args, threads), 1, LIMIT_THREADS},
    {"--float", NULL, OPT_FLAG, offsetof(Args, use_float), 0, 0},
    {"--classic", NULL, OPT_FLAG, offsetof(Args, classic), 0, 0},
    {"--scale", NULL, OPT_DOUBLE, offsetof(Args, scale), 0, 0},
    {"--translate", NULL, OPT_STRING, offsetof(Args, translate), 0, 0},
    {"--quiet", "-q", OPT_FLAG, offsetof(Args, quiet), 0, 0},
};

const Command cmd_render = {"render", usage, opts, (int)(sizeof opts / sizeof opts[0]), 1, sizeof(Args), defaults, run};
