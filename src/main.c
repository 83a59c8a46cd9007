/*
 * main.c - the lancer command line. The only place that prints or exits.
 *
 * Exit status: 0 success, 1 an error in the input or while writing, 2 a
 * usage error.
 */
#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "lancer/afile.h"
#include "lancer/render.h"

#define LANCER_VERSION "0.1.0"

static const char *usage_main =
    "usage: lancer <command> [options]\n"
    "\n"
    "lancer is a Whitted ray tracer that renders scene files to OpenEXR.\n"
    "\n"
    "commands:\n"
    "  render SCENE   render a scene file to an EXR image (and a PNG preview)\n"
    "  help [COMMAND] show this help, or a command's\n"
    "\n"
    "options:\n"
    "  --help         show this help\n"
    "  --version      print the version\n"
    "\n"
    "'lancer COMMAND --help' describes a command's options.\n";

static const char *usage_render =
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
    "      --threads N       render threads (default: every core)\n"
    "      --float           write 32-bit float channels (default: half)\n"
    "      --stats FILE.json write timings and ray counts as JSON\n"
    "  -q, --quiet           no progress bar or summary on stderr\n"
    "  -h, --help            show this help\n";

typedef struct {
    const char *scene, *exr, *png, *stats;
    int width, height, threads, quiet;
    ImagePrecision precision;
} RenderArgs;

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static int usage_error(const char *cmd, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    fprintf(stderr, "lancer %s: ", cmd);
    vfprintf(stderr, fmt, ap);
    va_end(ap);
    fprintf(stderr, "\n(see 'lancer %s --help')\n", cmd);
    return 2;
}

/* Parses a whole number in [lo, hi]; returns 0 or -1. */
static int parse_int(const char *s, int lo, int hi, int *out)
{
    char *end;
    errno = 0;
    long v = strtol(s, &end, 10);
    if (errno || end == s || *end != '\0' || v < lo || v > hi)
        return -1;
    *out = (int)v;
    return 0;
}

/* "out/<basename of scene without extension>.exr" */
static int default_output(const char *scene, char *buf, size_t len)
{
    const char *base = strrchr(scene, '/');
    base = base ? base + 1 : scene;
    const char *dot = strrchr(base, '.');
    int n = dot && dot != base ? (int)(dot - base) : (int)strlen(base);
    int w = snprintf(buf, len, "out/%.*s.exr", n, base);
    if (w < 0 || (size_t)w >= len)
        return -1;
    if (mkdir("out", 0777) != 0 && errno != EEXIST) {
        fprintf(stderr, "lancer: cannot create directory 'out': %s\n", strerror(errno));
        return -1;
    }
    return 0;
}

static int parse_render_args(int argc, char **argv, RenderArgs *a)
{
    memset(a, 0, sizeof *a);
    a->precision = IMAGE_HALF;
    long cores = sysconf(_SC_NPROCESSORS_ONLN);
    a->threads = cores > 0 ? (int)(cores < 1024 ? cores : 1024) : 1;
    for (int i = 0; i < argc; i++) {
        const char *arg = argv[i];
        if (strcmp(arg, "-h") == 0 || strcmp(arg, "--help") == 0) {
            fputs(usage_render, stdout);
            exit(0);
        }
        if (strcmp(arg, "-q") == 0 || strcmp(arg, "--quiet") == 0) {
            a->quiet = 1;
            continue;
        }
        if (strcmp(arg, "--float") == 0) {
            a->precision = IMAGE_FLOAT;
            continue;
        }
        if (arg[0] != '-' || arg[1] == '\0') {
            if (a->scene)
                return usage_error("render", "unexpected argument '%s' (only one SCENE)", arg);
            a->scene = arg;
            continue;
        }
        /* Every other option takes a value: "--opt value" or "--opt=value". */
        const char *val = NULL;
        char name[32];
        const char *eq = strchr(arg, '=');
        if (eq && arg[1] == '-') {
            size_t n = (size_t)(eq - arg);
            if (n >= sizeof name)
                return usage_error("render", "unknown option '%s'", arg);
            memcpy(name, arg, n);
            name[n] = '\0';
            val = eq + 1;
        } else {
            snprintf(name, sizeof name, "%s", arg);
        }
        int known = !strcmp(name, "-o") || !strcmp(name, "--output") || !strcmp(name, "--png") ||
                    !strcmp(name, "--width") || !strcmp(name, "--height") || !strcmp(name, "--threads") ||
                    !strcmp(name, "--stats");
        if (!known)
            return usage_error("render", "unknown option '%s'", arg);
        if (!val) {
            if (i + 1 >= argc)
                return usage_error("render", "option '%s' needs a value", arg);
            val = argv[++i];
        }
        if (!strcmp(name, "-o") || !strcmp(name, "--output"))
            a->exr = val;
        else if (!strcmp(name, "--png"))
            a->png = val;
        else if (!strcmp(name, "--stats"))
            a->stats = val;
        else if (!strcmp(name, "--threads")) {
            if (parse_int(val, 1, 1024, &a->threads))
                return usage_error("render", "--threads needs a whole number from 1 to 1024, not '%s'", val);
        } else {
            int *dst = !strcmp(name, "--width") ? &a->width : &a->height;
            if (parse_int(val, 1, IMAGE_MAX_SIDE, dst))
                return usage_error("render", "size must be a whole number from 1 to 32768, not '%s'", val);
        }
    }
    if (!a->scene)
        return usage_error("render", "%s", "missing SCENE");
    return 0;
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
    if (!p->shown && now() - p->start < PROGRESS_DELAY)
        return;
    p->shown = 1;
    p->last_percent = percent;
    char bar[41];
    int filled = percent * 40 / 100;
    for (int i = 0; i < 40; i++)
        bar[i] = i < filled ? '#' : '.';
    bar[40] = '\0';
    double el = now() - p->start;
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

static int write_stats(const char *path, const RenderArgs *a, const Scene *s, const double phase[4],
                       const RayStats *st)
{
    char tmp[AFILE_PATH_MAX], err[512];
    if (afile_temp(path, tmp, sizeof tmp, err, sizeof err) != 0) {
        fprintf(stderr, "lancer: %s\n", err);
        return -1;
    }
    FILE *f = fopen(tmp, "w");
    if (!f) {
        fprintf(stderr, "lancer: %s: %s\n", path, strerror(errno));
        afile_abort(tmp);
        return -1;
    }
    fprintf(f, "{\n  \"scene\": ");
    json_string(f, a->scene);
    fprintf(f, ",\n  \"width\": %d,\n  \"height\": %d,\n  \"threads\": %d,\n  \"primitives\": %d,\n",
            s->width, s->height, a->threads, s->nprims);
    fprintf(f, "  \"phases_s\": {\"parse\": %.6f, \"build\": %.6f, \"render\": %.6f, \"write\": %.6f},\n",
            phase[0], phase[1], phase[2], phase[3]);
    fprintf(f,
            "  \"rays\": {\"camera\": %llu, \"shadow\": %llu, \"reflection\": %llu, \"refraction\": %llu, "
            "\"total\": %llu},\n",
            st->camera, st->shadow, st->reflection, st->refraction,
            st->camera + st->shadow + st->reflection + st->refraction);
    fprintf(f, "  \"intersection_tests\": %llu\n}\n", st->isect_tests);
    int bad = ferror(f);
    if (fclose(f) != 0 || bad) {
        fprintf(stderr, "lancer: %s: write failed\n", path);
        afile_abort(tmp);
        return -1;
    }
    if (afile_commit(tmp, path, err, sizeof err) != 0) {
        fprintf(stderr, "lancer: %s\n", err);
        return -1;
    }
    return 0;
}

static int check_output(const char *path)
{
    char err[512];
    if (path && afile_check_writable(path, err, sizeof err) != 0) {
        fprintf(stderr, "lancer: %s\n", err);
        return -1;
    }
    return 0;
}

static int cmd_render(int argc, char **argv)
{
    RenderArgs a;
    int rc = parse_render_args(argc, argv, &a);
    if (rc)
        return rc;
    char exr_default[AFILE_PATH_MAX], err[1024];
    double phase[4] = {0, 0, 0, 0}, t0 = now();

    Scene s;
    if (scene_load(a.scene, &s, err, sizeof err) != 0) {
        fprintf(stderr, "%s\n", err);
        return 1;
    }
    phase[0] = now() - t0;
    if (a.width)
        s.width = a.width;
    if (a.height)
        s.height = a.height;
    if (!a.exr) {
        if (default_output(a.scene, exr_default, sizeof exr_default) != 0) {
            scene_free(&s);
            return 1;
        }
        a.exr = exr_default;
    }
    /* Fail on an unwritable output before spending time on the render. */
    if (check_output(a.exr) || check_output(a.png) || check_output(a.stats)) {
        scene_free(&s);
        return 1;
    }

    Image img;
    Accel acc;
    RayStats st = {0, 0, 0, 0, 0};
    if ((long)s.width * s.height > IMAGE_MAX_PIXELS) {
        fprintf(stderr, "lancer: a %dx%d image has more than the %ld pixels lancer renders\n", s.width, s.height,
                IMAGE_MAX_PIXELS);
        scene_free(&s);
        return 1;
    }
    if (image_init(&img, s.width, s.height) != 0) {
        fprintf(stderr, "lancer: out of memory for a %dx%d image\n", s.width, s.height);
        scene_free(&s);
        return 1;
    }
    t0 = now();
    if (accel_build(&acc, &s) != 0) {
        fprintf(stderr, "lancer: out of memory building the acceleration structure\n");
        image_free(&img);
        scene_free(&s);
        return 1;
    }
    phase[1] = now() - t0;

    Progress prog = {-1, 0, now()};
    RenderOptions opt = {a.threads, NULL, &prog};
    if (!a.quiet && isatty(STDERR_FILENO))
        opt.progress = on_progress;
    t0 = now();
    rc = render_image(&s, &acc, &opt, &img, &st);
    phase[2] = now() - t0;
    if (rc != 0)
        fprintf(stderr, "lancer: could not start the render threads\n");

    t0 = now();
    if (rc == 0 && image_write_exr(&img, a.exr, a.precision, err, sizeof err) != 0) {
        fprintf(stderr, "lancer: %s\n", err);
        rc = 1;
    }
    if (rc == 0 && a.png && image_write_png(&img, a.png, err, sizeof err) != 0) {
        fprintf(stderr, "lancer: %s\n", err);
        rc = 1;
    }
    phase[3] = now() - t0;
    if (rc == 0 && a.stats && write_stats(a.stats, &a, &s, phase, &st) != 0)
        rc = 1;
    if (rc == 0 && !a.quiet)
        fprintf(stderr, "lancer: wrote %s%s%s (%dx%d, %d thread%s, render %.3f s)\n", a.exr,
                a.png ? " and " : "", a.png ? a.png : "", s.width, s.height, a.threads, a.threads > 1 ? "s" : "",
                phase[2]);
    accel_free(&acc);
    image_free(&img);
    scene_free(&s);
    return rc ? 1 : 0;
}

int main(int argc, char **argv)
{
    if (argc < 2) {
        fputs(usage_main, stderr);
        return 2;
    }
    const char *cmd = argv[1];
    if (!strcmp(cmd, "--help") || !strcmp(cmd, "-h") || (!strcmp(cmd, "help") && argc == 2)) {
        fputs(usage_main, stdout);
        return 0;
    }
    if (!strcmp(cmd, "--version")) {
        printf("lancer %s\n", LANCER_VERSION);
        return 0;
    }
    if (!strcmp(cmd, "help")) {
        if (!strcmp(argv[2], "render")) {
            fputs(usage_render, stdout);
            return 0;
        }
        fprintf(stderr, "lancer: no help for unknown command '%s'\n", argv[2]);
        return 2;
    }
    if (!strcmp(cmd, "render"))
        return cmd_render(argc - 2, argv + 2);
    fprintf(stderr, "lancer: unknown command '%s' (see 'lancer --help')\n", cmd);
    return 2;
}
