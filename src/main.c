/*
 * main.c - the lancer command line. The only place that prints or exits.
 *
 * Exit status: 0 success, 1 an error in the input or while writing, 2 a
 * usage error.
 */
#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "lancer/afile.h"
#include "lancer/bench.h"
#include "lancer/compare.h"
#include "lancer/pov.h"
#include "lancer/rayfile.h"
#include "lancer/render.h"

#define LANCER_VERSION "0.1.0"

static const char *usage_main =
    "usage: lancer <command> [options]\n"
    "\n"
    "lancer is a Whitted ray tracer that renders scene files to OpenEXR.\n"
    "\n"
    "commands:\n"
    "  render SCENE      render a scene file to an EXR image (and a PNG preview)\n"
    "  export-pov SCENE  write the POV-Ray 3.7 scene that renders the same picture\n"
    "  diff A.exr B.exr  compare two images pixel by pixel\n"
    "  bench ...         generate benchmark rays for a mesh, or time ray casting\n"
    "  help [COMMAND]    show this help, or a command's\n"
    "\n"
    "options:\n"
    "  --help            show this help\n"
    "  --version         print the version\n"
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
    "      --spp K           K x K samples per pixel, box-filtered (overrides the scene)\n"
    "      --threads N       render threads (default: every core)\n"
    "      --float           write 32-bit float channels (default: half)\n"
    "      --classic         use the classic intersection routines instead of the\n"
    "                        robust ones (to compare their cost and error)\n"
    "      --scale S         scale the whole scene, camera and lights included\n"
    "      --translate X,Y,Z then move it: the picture should not change\n"
    "      --stats FILE.json write timings and ray counts as JSON\n"
    "  -q, --quiet           no progress bar or summary on stderr\n"
    "  -h, --help            show this help\n";

static const char *usage_export =
    "usage: lancer export-pov SCENE [options]\n"
    "\n"
    "Writes the POV-Ray 3.7 scene that renders the same picture as SCENE:\n"
    "camera, lights, materials and every primitive. Its first lines give the\n"
    "povray command line for the reference render.\n"
    "\n"
    "options:\n"
    "  -o, --output OUT.pov  the file to write, or - for standard output\n"
    "                        (default: out/<scene name>.pov)\n"
    "      --width W         image width in pixels (overrides the scene)\n"
    "      --height H        image height in pixels (overrides the scene)\n"
    "  -h, --help            show this help\n";

static const char *usage_diff =
    "usage: lancer diff A.exr B.exr [options]\n"
    "\n"
    "Compares two EXR images channel by channel and prints one line:\n"
    "  max=<max abs diff> mean=<mean abs diff> rms=<rms> psnr=<dB>\n"
    "  over=<pixels with a channel differing by more than the threshold> pixels=<total>\n"
    "PSNR takes 1.0 as the peak. The exit status is 0 whatever the difference.\n"
    "\n"
    "options:\n"
    "      --heatmap OUT.png  write a false-colour map of the differences: black\n"
    "                         up to 1e-5, blue 1e-4, cyan 1e-3, yellow at the\n"
    "                         threshold, red from 100 times the threshold\n"
    "      --downsample K     average B in K x K blocks first (B is a render at\n"
    "                         K times the size of A)\n"
    "      --threshold T      the difference that counts as over (default 2e-3)\n"
    "  -h, --help             show this help\n";

static const char *usage_bench =
    "usage: lancer bench --gen-rays MESH OUTDIR [W H]\n"
    "       lancer bench --mesh MESH --rays FILE --kind closest|any [--passes N] [--classic]\n"
    "       lancer bench --build-series MESH [--max-mtris M]\n"
    "\n"
    "The first form writes OUTDIR/primary.rays, shadow.rays and diffuse.rays\n"
    "for a W x H camera framing the mesh (default 1024 x 1024): one ray per\n"
    "pixel; from each hit, one to a point light and one in a random direction\n"
    "of the hemisphere, shuffled. Ray files: \"LNCRAYS1\", a uint64 count, and\n"
    "per ray 8 little-endian float32 ox oy oz dx dy dz tmin tmax.\n"
    "\n"
    "The second builds the BVH over the mesh, traces every ray of FILE on one\n"
    "thread (closest hit, or any hit) for one warm-up and N timed passes\n"
    "(default 3), and prints one line:\n"
    "  mrays=<best Mrays/s> hits=<hits> sumt=<sum of t over hits> build_ms=<build> rays=<count>\n"
    "\n"
    "The third builds the BVH over the mesh, then splits every triangle in two\n"
    "and builds again, up to M million triangles (default 10), printing build\n"
    "times on 1 and 2 threads and memory per triangle for each size.\n"
    "\n"
    "options:\n"
    "      --passes N   timed passes (default 3)\n"
    "      --classic    the classic intersection routines, not the robust ones\n"
    "      --threads N  threads for the BVH build (default 1)\n"
    "  -h, --help       show this help\n";

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

/* ---- options, shared by every command ---- */

typedef enum { OPT_FLAG, OPT_STRING, OPT_INT, OPT_DOUBLE } OptKind;

typedef struct {
    const char *name, *alias; /* "--output", "-o" */
    OptKind kind;
    void *dst; /* int* for flags and ints, const char** for strings, double* */
    int lo, hi; /* the range of an int */
} Opt;

#define HELP_SHOWN 3 /* parse_opts showed --help: exit 0 */

/* The whole number s, if it is one from lo to hi: 0, else -1 (*out kept). */
static int parse_int(const char *s, int lo, int hi, int *out)
{
    char *end;
    errno = 0;
    long v = strtol(s, &end, 10);
    if (errno || end == s || *end || v < lo || v > hi)
        return -1;
    *out = (int)v;
    return 0;
}

/* Parses argv against opts; other arguments are positional, at most maxpos
 * of them. Returns 0, HELP_SHOWN, or 2 after a usage message. */
static int parse_opts(const char *cmd, const char *usage, int argc, char **argv, const Opt *opts, int nopts,
                      const char **pos, int maxpos, int *npos)
{
    *npos = 0;
    for (int i = 0; i < argc; i++) {
        const char *arg = argv[i];
        if (!strcmp(arg, "-h") || !strcmp(arg, "--help")) {
            fputs(usage, stdout);
            return HELP_SHOWN;
        }
        if (arg[0] != '-' || arg[1] == '\0') {
            if (*npos == maxpos)
                return usage_error(cmd, "unexpected argument '%s'", arg);
            pos[(*npos)++] = arg;
            continue;
        }
        const char *eq = arg[1] == '-' ? strchr(arg, '=') : NULL;
        size_t len = eq ? (size_t)(eq - arg) : strlen(arg);
        const Opt *o = NULL;
        for (int k = 0; k < nopts && !o; k++)
            if ((strlen(opts[k].name) == len && !strncmp(arg, opts[k].name, len)) ||
                (opts[k].alias && !eq && !strcmp(arg, opts[k].alias)))
                o = &opts[k];
        if (!o)
            return usage_error(cmd, "unknown option '%s'", arg);
        if (o->kind == OPT_FLAG) {
            if (eq)
                return usage_error(cmd, "option '%s' takes no value", o->name);
            *(int *)o->dst = 1;
            continue;
        }
        const char *val = eq ? eq + 1 : NULL;
        if (!val) {
            if (i + 1 >= argc)
                return usage_error(cmd, "option '%s' needs a value", arg);
            val = argv[++i];
        }
        if (o->kind == OPT_STRING) {
            *(const char **)o->dst = val;
        } else if (o->kind == OPT_INT) {
            if (parse_int(val, o->lo, o->hi, (int *)o->dst) != 0)
                return usage_error(cmd, "%s needs a whole number from %d to %d, not '%s'", o->name, o->lo, o->hi,
                                   val);
        } else {
            char *end;
            errno = 0;
            double v = strtod(val, &end);
            if (errno || end == val || *end || !(v > 0) || !isfinite(v))
                return usage_error(cmd, "%s needs a positive number, not '%s'", o->name, val);
            *(double *)o->dst = v;
        }
    }
    return 0;
}

/* "out/<basename of path without extension><ext>", creating out/. */
static int default_output(const char *path, const char *ext, char *buf, size_t len)
{
    const char *base = strrchr(path, '/');
    base = base ? base + 1 : path;
    const char *dot = strrchr(base, '.');
    int n = dot && dot != base ? (int)(dot - base) : (int)strlen(base);
    int w = snprintf(buf, len, "out/%.*s%s", n, base, ext);
    if (w < 0 || (size_t)w >= len) {
        fprintf(stderr, "lancer: %s: path too long\n", path);
        return -1;
    }
    if (mkdir("out", 0777) != 0 && errno != EEXIST) {
        fprintf(stderr, "lancer: cannot create directory 'out': %s\n", strerror(errno));
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

/* Loads a scene and applies size overrides (0: keep the scene's). */
static int load_scene(const char *path, int width, int height, Scene *s)
{
    char err[1024];
    if (scene_load(path, s, err, sizeof err) != 0) {
        fprintf(stderr, "%s\n", err);
        return -1;
    }
    if (width)
        s->width = width;
    if (height)
        s->height = height;
    if ((long)s->width * s->height > IMAGE_MAX_PIXELS) {
        fprintf(stderr, "lancer: a %dx%d image has more than the %ld pixels lancer renders\n", s->width, s->height,
                IMAGE_MAX_PIXELS);
        scene_free(s);
        return -1;
    }
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
    if (!p->shown && bench_now() - p->start < PROGRESS_DELAY)
        return;
    p->shown = 1;
    p->last_percent = percent;
    char bar[41];
    int filled = percent * 40 / 100;
    for (int i = 0; i < 40; i++)
        bar[i] = i < filled ? '#' : '.';
    bar[40] = '\0';
    double el = bench_now() - p->start;
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

typedef struct {
    const char *scene, *exr, *png, *stats;
    int width, height, spp, threads, quiet, use_float, classic;
    double scale;
    const char *translate;
} RenderArgs;

static int write_stats(const char *path, const RenderArgs *a, const Scene *s, const double phase[4],
                       const RayStats *st)
{
    char tmp[AFILE_PATH_MAX], err[512];
    FILE *f = afile_fopen(path, tmp, sizeof tmp, err, sizeof err);
    if (!f) {
        fprintf(stderr, "lancer: %s\n", err);
        return -1;
    }
    fprintf(f, "{\n  \"scene\": ");
    json_string(f, a->scene);
    fprintf(f,
            ",\n  \"width\": %d,\n  \"height\": %d,\n  \"spp\": %d,\n  \"threads\": %d,\n  \"primitives\": %d,\n"
            "  \"intersect\": \"%s\",\n  \"degenerate_triangles\": %d,\n",
            s->width, s->height, s->spp, a->threads, s->nprims, s->classic ? "classic" : "robust", s->degenerate);
    fprintf(f, "  \"phases_s\": {\"parse\": %.6f, \"build\": %.6f, \"render\": %.6f, \"write\": %.6f},\n",
            phase[0], phase[1], phase[2], phase[3]);
    fprintf(f,
            "  \"rays\": {\"camera\": %llu, \"shadow\": %llu, \"reflection\": %llu, \"refraction\": %llu, "
            "\"total\": %llu},\n",
            st->camera, st->shadow, st->reflection, st->refraction,
            st->camera + st->shadow + st->reflection + st->refraction);
    fprintf(f, "  \"intersection_tests\": %llu\n}\n", st->isect_tests);
    if (afile_fclose(f, tmp, path, err, sizeof err) != 0) {
        fprintf(stderr, "lancer: %s\n", err);
        return -1;
    }
    return 0;
}

static int cmd_render(int argc, char **argv)
{
    RenderArgs a;
    memset(&a, 0, sizeof a);
    long cores = sysconf(_SC_NPROCESSORS_ONLN);
    a.threads = cores > 0 ? (int)(cores < 1024 ? cores : 1024) : 1;
    const Opt opts[] = {
        {"--output", "-o", OPT_STRING, &a.exr, 0, 0},
        {"--png", NULL, OPT_STRING, &a.png, 0, 0},
        {"--stats", NULL, OPT_STRING, &a.stats, 0, 0},
        {"--width", NULL, OPT_INT, &a.width, 1, IMAGE_MAX_SIDE},
        {"--height", NULL, OPT_INT, &a.height, 1, IMAGE_MAX_SIDE},
        {"--spp", NULL, OPT_INT, &a.spp, 1, SCENE_MAX_SPP},
        {"--threads", NULL, OPT_INT, &a.threads, 1, 1024},
        {"--float", NULL, OPT_FLAG, &a.use_float, 0, 0},
        {"--classic", NULL, OPT_FLAG, &a.classic, 0, 0},
        {"--scale", NULL, OPT_DOUBLE, &a.scale, 0, 0},
        {"--translate", NULL, OPT_STRING, &a.translate, 0, 0},
        {"--quiet", "-q", OPT_FLAG, &a.quiet, 0, 0},
    };
    int npos;
    int rc = parse_opts("render", usage_render, argc, argv, opts, (int)(sizeof opts / sizeof opts[0]), &a.scene, 1,
                        &npos);
    if (rc)
        return rc == HELP_SHOWN ? 0 : rc;
    if (npos == 0)
        return usage_error("render", "missing SCENE");

    char exr_default[AFILE_PATH_MAX], err[1024];
    double phase[4] = {0, 0, 0, 0}, t0 = bench_now();
    Scene s;
    if (load_scene(a.scene, a.width, a.height, &s) != 0)
        return 1;
    phase[0] = bench_now() - t0;
    if (a.spp)
        s.spp = a.spp;
    if (a.classic)
        s.classic = 1;
    if (a.scale > 0.0 || a.translate) {
        Vec3 off = vec3(0, 0, 0);
        char tail;
        if (a.translate && sscanf(a.translate, "%f,%f,%f%c", &off.x, &off.y, &off.z, &tail) != 3) {
            scene_free(&s);
            return usage_error("render", "--translate needs X,Y,Z, not '%s'", a.translate);
        }
        if (!vec_is_finite(off) || scene_transform(&s, a.scale > 0.0 ? (float)a.scale : 1.0f, off) != 0) {
            fprintf(stderr, "lancer: %s: the scene degenerates at that scale or offset\n", a.scene);
            scene_free(&s);
            return 1;
        }
    }
    if (!a.exr) {
        if (default_output(a.scene, ".exr", exr_default, sizeof exr_default) != 0) {
            scene_free(&s);
            return 1;
        }
        a.exr = exr_default;
    }
    /* Robust mode renders in camera-relative coordinates: subtracting the
     * eye is exact for every coordinate within a factor of two of it
     * (Sterbenz), so a scene far from the origin keeps the precision it
     * would have near it: float spawn origins at 1e5 would otherwise sit
     * on a grid 1/128 apart. */
    if (!s.classic && scene_transform(&s, 1.0f, vec_neg(s.camera.eye)) != 0) {
        fprintf(stderr, "lancer: %s: the scene degenerates in camera-relative coordinates\n", a.scene);
        scene_free(&s);
        return 1;
    }
    /* Fail on an unwritable output before spending time on the render. */
    if (check_output(a.exr) || check_output(a.png) || check_output(a.stats)) {
        scene_free(&s);
        return 1;
    }

    Image img;
    Accel acc;
    RayStats st = {0, 0, 0, 0, 0};
    if (image_init(&img, s.width, s.height) != 0) {
        fprintf(stderr, "lancer: out of memory for a %dx%d image\n", s.width, s.height);
        scene_free(&s);
        return 1;
    }
    t0 = bench_now();
    if (accel_build(&acc, &s, a.threads) != 0) {
        fprintf(stderr, "lancer: out of memory building the acceleration structure\n");
        image_free(&img);
        scene_free(&s);
        return 1;
    }
    phase[1] = bench_now() - t0;

    Progress prog = {-1, 0, bench_now()};
    RenderOptions opt = {a.threads, NULL, &prog};
    if (!a.quiet && isatty(STDERR_FILENO))
        opt.progress = on_progress;
    t0 = bench_now();
    rc = render_image(&s, &acc, &opt, &img, &st);
    phase[2] = bench_now() - t0;
    if (rc != 0)
        fprintf(stderr, "lancer: could not set up the render threads\n");

    t0 = bench_now();
    if (rc == 0 && image_write_exr(&img, a.exr, a.use_float ? IMAGE_FLOAT : IMAGE_HALF, err, sizeof err) != 0) {
        fprintf(stderr, "lancer: %s\n", err);
        rc = 1;
    }
    if (rc == 0 && a.png && image_write_png(&img, a.png, err, sizeof err) != 0) {
        fprintf(stderr, "lancer: %s\n", err);
        rc = 1;
    }
    phase[3] = bench_now() - t0;
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

static int cmd_export_pov(int argc, char **argv)
{
    const char *scene = NULL, *out = NULL;
    int width = 0, height = 0, npos;
    const Opt opts[] = {
        {"--output", "-o", OPT_STRING, &out, 0, 0},
        {"--width", NULL, OPT_INT, &width, 1, IMAGE_MAX_SIDE},
        {"--height", NULL, OPT_INT, &height, 1, IMAGE_MAX_SIDE},
    };
    int rc = parse_opts("export-pov", usage_export, argc, argv, opts, (int)(sizeof opts / sizeof opts[0]), &scene,
                        1, &npos);
    if (rc)
        return rc == HELP_SHOWN ? 0 : rc;
    if (npos == 0)
        return usage_error("export-pov", "missing SCENE");
    Scene s;
    if (load_scene(scene, width, height, &s) != 0)
        return 1;
    char path[AFILE_PATH_MAX], tmp[AFILE_PATH_MAX], err[512];
    rc = 0;
    if (out && !strcmp(out, "-")) {
        if (pov_export(&s, stdout) != 0 || fflush(stdout) != 0) {
            fprintf(stderr, "lancer: writing to standard output failed\n");
            rc = 1;
        }
    } else if (!out && default_output(scene, ".pov", path, sizeof path) != 0) {
        rc = 1;
    } else {
        out = out ? out : path;
        FILE *f = afile_fopen(out, tmp, sizeof tmp, err, sizeof err);
        if (!f || (pov_export(&s, f), afile_fclose(f, tmp, out, err, sizeof err)) != 0) {
            fprintf(stderr, "lancer: %s\n", err);
            rc = 1;
        }
    }
    scene_free(&s);
    return rc;
}

static int read_exr(const char *path, Image *img)
{
    char err[512];
    if (image_read_exr(path, img, err, sizeof err) != 0) {
        fprintf(stderr, "lancer: %s\n", err);
        return -1;
    }
    return 0;
}

static int cmd_diff(int argc, char **argv)
{
    const char *pos[2], *heatmap = NULL;
    int down = 1, npos;
    double threshold = COMPARE_THRESHOLD;
    const Opt opts[] = {
        {"--heatmap", NULL, OPT_STRING, &heatmap, 0, 0},
        {"--downsample", NULL, OPT_INT, &down, 1, 64},
        {"--threshold", NULL, OPT_DOUBLE, &threshold, 0, 0},
    };
    int rc = parse_opts("diff", usage_diff, argc, argv, opts, (int)(sizeof opts / sizeof opts[0]), pos, 2, &npos);
    if (rc)
        return rc == HELP_SHOWN ? 0 : rc;
    if (npos < 2)
        return usage_error("diff", "needs two images, A and B");
    if (check_output(heatmap))
        return 1;
    Image a, b, small, heat;
    char err[512];
    if (read_exr(pos[0], &a) != 0)
        return 1;
    if (read_exr(pos[1], &b) != 0) {
        image_free(&a);
        return 1;
    }
    if (down > 1) {
        if (compare_downsample(&b, down, &small, err, sizeof err) != 0) {
            fprintf(stderr, "lancer: %s: %s\n", pos[1], err);
            image_free(&a);
            image_free(&b);
            return 1;
        }
        image_free(&b);
        b = small;
    }
    CompareStats st;
    rc = compare_images(&a, &b, threshold, &st, err, sizeof err);
    if (rc == 0) {
        printf("max=%.6g mean=%.6g rms=%.6g psnr=%.2f over=%ld pixels=%ld\n", st.max, st.mean, st.rms, st.psnr,
               st.over, st.pixels);
        if (heatmap) {
            rc = compare_heatmap(&a, &b, threshold, &heat, err, sizeof err);
            if (rc == 0) {
                rc = image_write_png(&heat, heatmap, err, sizeof err);
                image_free(&heat);
            }
        }
    }
    if (rc != 0)
        fprintf(stderr, "lancer: %s\n", err);
    image_free(&a);
    image_free(&b);
    return rc ? 1 : 0;
}

/* A scene of the mesh's flat triangles, one plain material. */
static int mesh_scene(const char *path, int classic, Scene *s)
{
    Mesh m;
    char err[1024];
    memset(s, 0, sizeof *s);
    if (mesh_load(path, &m, err, sizeof err) != 0) {
        fprintf(stderr, "%s\n", err);
        return -1;
    }
    int rc = scene_from_mesh(s, &m, classic);
    mesh_free(&m);
    if (rc != 0)
        fprintf(stderr, "lancer: %s: out of memory\n", path);
    return rc;
}

static int write_rays(const char *dir, const char *name, const RaySet *set)
{
    char path[AFILE_PATH_MAX], err[512];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    if (rayfile_write(path, set->rays, set->n, err, sizeof err) != 0) {
        fprintf(stderr, "lancer: %s\n", err);
        return -1;
    }
    return 0;
}

/* Build time and memory of the BVH as the mesh is split again and again
 * (each triangle in two, across its longest edge) up to max_tris. */
static int build_series(Scene *s, long max_tris)
{
    printf("| triangles | build ms, 1 thread | build ms, 2 threads | ns per triangle (1 thread) | BVH bytes per "
           "triangle |\n| --- | --- | --- | --- | --- |\n");
    for (;;) {
        double ms[2];
        size_t bytes = 0;
        for (int t = 0; t < 2; t++) {
            Accel acc;
            double t0 = bench_now();
            if (accel_build(&acc, s, t + 1) != 0) {
                fprintf(stderr, "lancer: out of memory building the BVH\n");
                return 1;
            }
            ms[t] = 1e3 * (bench_now() - t0);
            bytes = bvh_bytes(&acc.bvh);
            accel_free(&acc);
        }
        printf("| %d | %.1f | %.1f | %.0f | %.1f |\n", s->nprims, ms[0], ms[1], 1e6 * ms[0] / s->nprims,
               (double)bytes / s->nprims);
        fflush(stdout);
        if (2L * s->nprims > max_tris)
            return 0;
        Prim *np = malloc(sizeof(Prim) * 2 * (size_t)s->nprims);
        if (!np) {
            fprintf(stderr, "lancer: out of memory splitting the mesh\n");
            return 1;
        }
        for (int i = 0; i < s->nprims; i++) {
            Triangle t = s->prims[i].g.tri;
            Vec3 v[3] = {t.a, t.b, t.c};
            int k = 0; /* the corner opposite the longest edge */
            float best = -1.0f;
            for (int j = 0; j < 3; j++) {
                Vec3 e = vec_sub(v[(j + 1) % 3], v[(j + 2) % 3]);
                if (vec_dot(e, e) > best) {
                    best = vec_dot(e, e);
                    k = j;
                }
            }
            Vec3 a = v[k], b = v[(k + 1) % 3], c = v[(k + 2) % 3], m = vec_scale(vec_add(b, c), 0.5f);
            Triangle *t0 = &np[2 * i].g.tri, *t1 = &np[2 * i + 1].g.tri;
            np[2 * i] = np[2 * i + 1] = s->prims[i];
            t0->a = a;
            t0->b = b;
            t0->c = m;
            t1->a = a;
            t1->b = m;
            t1->c = c;
        }
        free(s->prims);
        s->prims = np;
        s->nprims *= 2;
    }
}

static int cmd_bench(int argc, char **argv)
{
    const char *gen = NULL, *mesh = NULL, *rays = NULL, *kind = NULL, *series = NULL, *pos[3] = {NULL, NULL, NULL};
    int passes = 3, classic = 0, threads = 1, npos, max_mtris = 10;
    const Opt opts[] = {
        {"--gen-rays", NULL, OPT_STRING, &gen, 0, 0},       {"--mesh", NULL, OPT_STRING, &mesh, 0, 0},
        {"--rays", NULL, OPT_STRING, &rays, 0, 0},          {"--kind", NULL, OPT_STRING, &kind, 0, 0},
        {"--passes", NULL, OPT_INT, &passes, 1, 1000},      {"--classic", NULL, OPT_FLAG, &classic, 0, 0},
        {"--threads", NULL, OPT_INT, &threads, 1, 1024},    {"--build-series", NULL, OPT_STRING, &series, 0, 0},
        {"--max-mtris", NULL, OPT_INT, &max_mtris, 1, 100},
    };
    int rc = parse_opts("bench", usage_bench, argc, argv, opts, (int)(sizeof opts / sizeof opts[0]), pos, 3, &npos);
    if (rc)
        return rc == HELP_SHOWN ? 0 : rc;
    if (series) {
        Scene s;
        if (npos != 0)
            return usage_error("bench", "--build-series takes no other arguments");
        if (mesh_scene(series, classic, &s) != 0)
            return 1;
        rc = build_series(&s, 1000000L * max_mtris);
        scene_free(&s);
        return rc;
    }
    if (!gen == !mesh)
        return usage_error("bench", "give either --gen-rays MESH OUTDIR or --mesh MESH --rays FILE --kind K");
    int w = 1024, h = 1024;
    if (gen && (npos != 1 && npos != 3))
        return usage_error("bench", "--gen-rays needs MESH OUTDIR [W H]");
    if (gen && npos == 3 &&
        (parse_int(pos[1], 1, IMAGE_MAX_SIDE, &w) != 0 || parse_int(pos[2], 1, IMAGE_MAX_SIDE, &h) != 0))
        return usage_error("bench", "W and H must be whole numbers from 1 to %d", IMAGE_MAX_SIDE);
    if (mesh && (!rays || !kind || (strcmp(kind, "closest") != 0 && strcmp(kind, "any") != 0) || npos != 0))
        return usage_error("bench", "--mesh needs --rays FILE and --kind closest or any");
    Scene s;
    if (mesh_scene(gen ? gen : mesh, classic, &s) != 0)
        return 1;
    Accel acc;
    double t0 = bench_now();
    if (accel_build(&acc, &s, threads) != 0) {
        fprintf(stderr, "lancer: out of memory building the BVH\n");
        scene_free(&s);
        return 1;
    }
    double build_ms = 1e3 * (bench_now() - t0);
    rc = 0;
    if (gen) {
        RaySet p, sh, d;
        if (bench_gen_rays(&acc, w, h, 1, &p, &sh, &d) != 0) {
            fprintf(stderr, "lancer: %s: no triangles to frame, or out of memory\n", gen);
            rc = 1;
        } else {
            if (write_rays(pos[0], "primary.rays", &p) || write_rays(pos[0], "shadow.rays", &sh) ||
                write_rays(pos[0], "diffuse.rays", &d))
                rc = 1;
            else
                printf("primary=%zu shadow=%zu diffuse=%zu\n", p.n, sh.n, d.n);
            bench_free(&p);
            bench_free(&sh);
            bench_free(&d);
        }
    } else {
        Ray *r;
        size_t n;
        char err[512];
        if (rayfile_read(rays, &r, &n, err, sizeof err) != 0) {
            fprintf(stderr, "lancer: %s\n", err);
            rc = 1;
        } else {
            BenchResult res;
            bench_trace(&acc, r, n, !strcmp(kind, "any"), passes, &res);
            printf("mrays=%.3f hits=%zu sumt=%.6g build_ms=%.2f rays=%zu\n", res.mrays, res.hits, res.sumt, build_ms,
                   n);
            free(r);
        }
    }
    accel_free(&acc);
    scene_free(&s);
    return rc;
}

int main(int argc, char **argv)
{
    static const struct {
        const char *name;
        int (*run)(int, char **);
        const char **usage;
    } cmds[] = {
        {"render", cmd_render, &usage_render},
        {"export-pov", cmd_export_pov, &usage_export},
        {"diff", cmd_diff, &usage_diff},
        {"bench", cmd_bench, &usage_bench},
    };
    const int ncmds = (int)(sizeof cmds / sizeof cmds[0]);
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
    int help = !strcmp(cmd, "help");
    const char *name = help ? argv[2] : cmd;
    for (int i = 0; i < ncmds; i++) {
        if (strcmp(name, cmds[i].name) != 0)
            continue;
        if (help) {
            fputs(*cmds[i].usage, stdout);
            return 0;
        }
        return cmds[i].run(argc - 2, argv + 2);
    }
    fprintf(stderr, "lancer: unknown command '%s' (see 'lancer --help')\n", name);
    return 2;
}
