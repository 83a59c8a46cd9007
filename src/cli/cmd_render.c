/*
 * cmd_render.c - lancer render: a scene file to an EXR image, with an
 * optional PNG preview and statistics.
 */
#include <errno.h>
#include <math.h>
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
#include "outputs.h"
#include "stamp.h"

static const char usage[] =
    "usage: lancer render SCENE [options]\n"
    "\n"
    "Renders SCENE (lancer's scene format, see README.md) to a linear OpenEXR\n"
    "image. The outputs of a run are written to temporary files and renamed\n"
    "into place together, so existing files are only replaced by complete new\n"
    "ones. An output may not be an input (the scene, a mesh) or a device.\n"
    "SIGINT or SIGTERM stops the render: the rows done are saved in\n"
    "OUT.partial.exr, the outputs are untouched, and lancer exits 130 or 143;\n"
    "--resume continues from there.\n"
    "\n"
    "options:\n"
    "  -o, --output OUT.exr  the EXR to write (default: out/<scene name>.exr)\n"
    "      --png OUT.png     also write an 8-bit sRGB PNG preview\n"
    "      --width W         image width in pixels (overrides the scene)\n"
    "      --height H        image height in pixels (overrides the scene)\n"
    "      --quality Q       draft, preview or final: a preset of the settings that\n"
    "                        trade time for error (spp, aa-threshold, adc-bailout,\n"
    "                        area-samples, area-adaptive, pn-mode); each option below\n"
    "                        overrides it\n"
    "      --spp K           K x K samples per pixel, box-filtered (overrides the scene)\n"
    "      --max-depth N     trace depth, POV-Ray's max_trace_level (overrides the scene)\n"
    "      --aa-threshold T  adaptive anti-aliasing: only pixels that differ from a\n"
    "                        neighbour by more than T get the K x K grid of --spp\n"
    "                        (overrides the scene; 0: every pixel)\n"
    "      --threads N       threads for the build, the render and the writing\n"
    "                        (default: every core)\n"
    "      --float           write 32-bit float channels (default: half)\n"
    "      --classic         use the classic intersection routines instead of the\n"
    "                        robust ones (to compare their cost and error)\n"
    "      --pn-mode MODE    trace every PN patch in MODE, exact or fast\n"
    "                        (overrides the scene)\n"
    "      --scale S         scale the whole scene, camera and lights included\n"
    "      --translate X,Y,Z then move it: the picture should not change\n"
    "      --area-samples N  every area light's grid of shadow samples, N x N\n"
    "      --area-adaptive N every area light's adaptive level (POV-Ray's adaptive N)\n"
    "      --adc-bailout W   do not trace a secondary ray whose weight, the product\n"
    "                        of the coefficients on its path, is below W (POV-Ray's\n"
    "                        adc_bailout; overrides the scene; 0 traces every one)\n"
    "      --stats FILE.json write the render plan, timings and ray counts as JSON\n"
    "      --explain         print the plan (what the render skips, and why), the\n"
    "                        rays traced by kind and the time of each phase\n"
    "      --accel KIND      bvh or loop: trace through a BVH, or a plain loop over\n"
    "                        the primitives (default: the plan's choice)\n"
    "      --no-plan         skip nothing the plan would skip: the same picture,\n"
    "                        by all the work (to measure what the plan saves)\n"
    "      --region X0:X1,Y0:Y1  render only columns X0..X1-1 of rows Y0..Y1-1 (the\n"
    "                        pixels of the whole render, bit for bit; see merge)\n"
    "      --frame N         render frame N of the scene's camera path (keyframes)\n"
    "      --frames A:B      render frames A to B-1; the output names then need a\n"
    "                        frame pattern, %d or %0Nd (default out/<scene>.%04d.exr)\n"
    "      --resume          continue from OUT.partial.exr when it is of this scene,\n"
    "                        settings and region; do nothing when OUT is complete\n"
    "  -q, --quiet           no progress bar or summary on stderr\n"
    "  -h, --help            show this help\n";

typedef struct {
    const char *exr, *png, *stats;
    int width, height, spp, max_depth, threads, quiet, use_float, classic, explain, no_plan;
    int area_samples, area_adaptive, resume, frame;
    double scale, aa;
    const char *translate, *pn_mode, *accel, *quality, *region, *frames, *adc;
} Args;

/* The quality presets, points on or near every benchmark scene's frontier
 * of time against error (docs/performance.md, make frontier). */
typedef struct {
    const char *name;
    int spp, area_samples, area_adaptive; /* area_adaptive: the level */
    double aa_threshold, adc_bailout;     /* adc_bailout -1: the scene's */
} Quality;

static const Quality QUALITIES[] = {
    {"draft", 1, 4, 0, 0.0, 0.016},
    {"preview", 3, 8, 0, 0.1, 0.004},
    {"final", 4, 8, 1, 0.03, -1.0},
};

static void defaults(void *args)
{
    Args *a = args;
    a->threads = cli_default_threads();
    a->aa = -1.0;
    a->area_adaptive = -1;
    a->frame = -1;
}

typedef struct {
    int last_percent, shown;
    int tty; /* a bar redrawn in place; else a line every tenth, for logs */
    double start;
} Progress;

/* Seconds a render must run before its progress shows: short renders stay
 * quiet, on a terminal and, longer, in a log. */
#define PROGRESS_DELAY 0.3
#define PROGRESS_LOG_DELAY 10.0
/* Reading the scene or building the BVH takes longer than this (a mesh of
 * millions of triangles): say so when it is done, before the next phase. */
#define PROGRESS_PHASE 1.0

static void on_progress(void *ctx, int done, int total)
{
    Progress *p = ctx;
    int percent = (int)(100LL * done / total);
    if (percent == p->last_percent || (!p->tty && percent / 10 == p->last_percent / 10))
        return;
    double el = clock_now() - p->start;
    if (!p->shown && el < (p->tty ? PROGRESS_DELAY : PROGRESS_LOG_DELAY))
        return;
    p->shown = 1;
    p->last_percent = percent;
    double eta = done > 0 ? el * (total - done) / done : 0.0;
    if (!p->tty) {
        fprintf(stderr, "lancer: rendering %3d%%, %.0f s elapsed, %.0f s left\n", percent, el, eta);
        return;
    }
    char bar[41];
    int filled = percent * 40 / 100;
    for (int i = 0; i < 40; i++)
        bar[i] = i < filled ? '#' : '.';
    bar[40] = '\0';
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

/* The plan's notes shown: every light's, for scenes of up to 60 lights. */
#define PLAN_NOTES_SHOWN 64

/* The plan as a JSON object, what the renderer decided to do. */
static void write_plan(FILE *f, const RenderPlan *p)
{
    static const char *const shadows[] = {"none", "clear", "opaque", "filtered"};
    const Scene *s = p->scene;
    fprintf(f,
            "{\"width\": %d, \"height\": %d, \"spp\": %d, \"max_depth\": %d, \"threads\": %d, "
            "\"intersect\": \"%s\", \"adc_bailout\": %.9g, \"aa_threshold\": %.9g,\n",
            p->width, p->height, p->spp, p->max_depth, p->threads, p->variant == PRIM_CLASSIC ? "classic" : "robust",
            (double)p->adc_bailout, (double)p->aa_threshold);
    fprintf(f, "           \"region\": [%d, %d, %d, %d],\n", p->x0, p->x1, p->y0, p->y1);
    fprintf(f, "           \"camera_offset\": [%.9g, %.9g, %.9g], \"camera_inside\": [", p->offset[0], p->offset[1],
            p->offset[2]);
    for (int i = 0; i < p->camera_in.n; i++) { /* numbered as the scene wrote them */
        int k = p->camera_in.prim[i];
        fprintf(f, "%s%d", i ? ", " : "", s->origin ? s->origin[k] : k);
    }
    fprintf(f, "],\n           \"pn_patches\": {\"exact\": %d, \"fast\": %d},", p->patches[PN_EXACT],
            p->patches[PN_FAST]);
    fprintf(f, "\n           \"transparent\": %s, \"reflective\": %s,\n           \"lights\": [",
            json_bool(p->transparent), json_bool(p->reflective));
    for (int i = 0; i < s->nlights; i++)
        fprintf(f, "%s{\"shadows\": \"%s\", \"samples\": %d}", i ? ", " : "", shadows[p->shadow[i]],
                s->lights[i].area_n1 * s->lights[i].area_n2);
    fprintf(f, "],\n           \"notes\": [");
    PlanNote notes[PLAN_NOTES_SHOWN];
    int n = plan_notes(p, notes, PLAN_NOTES_SHOWN);
    for (int i = 0; i < n && i < PLAN_NOTES_SHOWN; i++) {
        fprintf(f, "%s{\"what\": ", i ? ",\n             " : "");
        json_string(f, notes[i].what);
        fprintf(f, ", \"skipped\": %s, \"why\": ", json_bool(notes[i].skipped));
        json_string(f, notes[i].why);
        fputc('}', f);
    }
    fprintf(f, "]}");
}

static const char *const PHASES[4] = {"parse", "build", "render", "write"};

/* What the acceleration structure holds, for --stats and --explain. */
typedef struct {
    size_t bytes;
    int pn_split, pn_pieces; /* accel_pn_split */
} AccelInfo;

static AccelInfo accel_info(const Accel *acc)
{
    AccelInfo ai;
    ai.bytes = accel_bytes(acc);
    ai.pn_split = accel_pn_split(acc, &ai.pn_pieces);
    return ai;
}

/* The plan, the rays and the phases, for a person (--explain). */
static void explain(FILE *f, const char *scene, const RenderPlan *p, const AccelInfo *ai, const double phase[4],
                    const RayStats *st)
{
    PlanNote notes[PLAN_NOTES_SHOWN];
    int n = plan_notes(p, notes, PLAN_NOTES_SHOWN);
    fprintf(f, "plan for %s%s:\n", scene, p->full ? " (--no-plan: nothing skipped that could be traced)" : "");
    for (int i = 0; i < n && i < PLAN_NOTES_SHOWN; i++)
        fprintf(f, "  %-8s %s: %s\n", notes[i].skipped ? "skipped" : "done", notes[i].what, notes[i].why);
    if (n > PLAN_NOTES_SHOWN)
        fprintf(f, "  ... and %d more\n", n - PLAN_NOTES_SHOWN);
    if (ai->bytes < 1000000)
        fprintf(f, "acceleration: %.1f kB", (double)ai->bytes / 1e3);
    else
        fprintf(f, "acceleration: %.1f MB", (double)ai->bytes / 1e6);
    if (ai->pn_split)
        fprintf(f, ", with %d PN patch%s split ahead of rays into %d pieces", ai->pn_split,
                ai->pn_split > 1 ? "es" : "", ai->pn_pieces);
    fprintf(f, "\n");
    fprintf(f, "rays: %llu camera, %llu shadow, %llu reflection, %llu refraction (%llu in all)\n", st->camera,
            st->shadow, st->reflection, st->refraction, st->camera + st->shadow + st->reflection + st->refraction);
    fprintf(f, "cut: %llu secondary rays below adc_bailout %g\n", st->cut, (double)p->adc_bailout);
    if (p->aa_threshold > 0.0f && p->spp > 1)
        fprintf(f, "anti-aliasing: %llu of %d pixels supersampled %dx%d (aa_threshold %g)\n", st->supersampled,
                p->width * p->height, p->spp, p->spp, (double)p->aa_threshold);
    double total = phase[0] + phase[1] + phase[2] + phase[3];
    fprintf(f, "time:");
    for (int i = 0; i < 4; i++)
        fprintf(f, "%s %s %.3f s (%.0f%%)", i ? "," : "", PHASES[i], phase[i], total > 0 ? 100 * phase[i] / total : 0);
    fprintf(f, "\n");
}

/* Writes the statistics as JSON into the file `file` (a temporary file of
 * the run's set; path names it in messages). */
static int write_stats(const char *file, const char *path, const char *scene, const RenderPlan *p,
                       const AccelInfo *ai, const double phase[4], const RayStats *st)
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
    fprintf(f, ",\n  \"primitives\": %d,\n  \"degenerate_triangles\": %d,\n  \"vanished_primitives\": %d,\n",
            p->scene->nprims, p->scene->degenerate, p->scene->vanished);
    fprintf(f, "  \"acceleration\": {\"bytes\": %zu, \"pn_patches_split\": %d, \"pn_pieces\": %d},\n", ai->bytes,
            ai->pn_split, ai->pn_pieces);
    fprintf(f, "  \"phases_s\": {\"parse\": %.6f, \"build\": %.6f, \"render\": %.6f, \"write\": %.6f},\n",
            phase[0], phase[1], phase[2], phase[3]);
    double total = phase[0] + phase[1] + phase[2] + phase[3];
    fprintf(f, "  \"phases_share\": {");
    for (int i = 0; i < 4; i++)
        fprintf(f, "%s\"%s\": %.4f", i ? ", " : "", PHASES[i], total > 0 ? phase[i] / total : 0.0);
    fprintf(f, "},\n");
    fprintf(f,
            "  \"rays\": {\"camera\": %llu, \"shadow\": %llu, \"reflection\": %llu, \"refraction\": %llu, "
            "\"total\": %llu, \"cut_by_adc_bailout\": %llu},\n",
            st->camera, st->shadow, st->reflection, st->refraction,
            st->camera + st->shadow + st->reflection + st->refraction, st->cut);
    fprintf(f, "  \"supersampled_pixels\": %llu,\n", st->supersampled);
    fprintf(f, "  \"too_deep_rays\": %llu,\n", st->too_deep);
    fprintf(f, "  \"shadow_rays_past_crossings\": %llu,\n", st->shadow_cut);
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
    if (a->quality) {
        const Quality *q = NULL;
        for (size_t i = 0; i < sizeof QUALITIES / sizeof QUALITIES[0]; i++)
            if (strcmp(a->quality, QUALITIES[i].name) == 0)
                q = &QUALITIES[i];
        if (!q)
            return cli_usage_error("render", "--quality must be draft, preview or final, not '%s'", a->quality);
        o->spp = q->spp;
        o->area_samples = q->area_samples;
        o->area_adaptive = q->area_adaptive + 1;
        o->aa_threshold = q->aa_threshold;
        o->adc_bailout = q->adc_bailout;
    }
    o->width = a->width;
    o->height = a->height;
    if (a->spp)
        o->spp = a->spp;
    if (a->max_depth)
        o->max_depth = a->max_depth;
    if (a->area_samples)
        o->area_samples = a->area_samples;
    if (a->area_adaptive >= 0) /* -1 unless given */
        o->area_adaptive = a->area_adaptive + 1;
    o->classic = a->classic;
    o->threads = a->threads;
    o->full = a->no_plan;
    if (a->accel) {
        o->accel = strcmp(a->accel, "bvh") == 0 ? 1 : strcmp(a->accel, "loop") == 0 ? 2 : -1;
        if (o->accel < 0)
            return cli_usage_error("render", "--accel must be bvh or loop, not '%s'", a->accel);
    }
    if (a->adc) { /* below 1 as a float: at 1 POV-Ray shades no surface */
        char *end;
        errno = 0;
        double v = strtod(a->adc, &end);
        if (errno || end == a->adc || *end || !(v >= 0.0 && (float)v < 1.0f))
            return cli_usage_error("render", "--adc-bailout needs a number from 0 up to 1, 1 excluded, not '%s'",
                                   a->adc);
        o->adc_bailout = v;
    }
    if (a->aa >= 0.0) /* likewise, from 0 to 3 */
        o->aa_threshold = a->aa;
    if (a->pn_mode) {
        o->pn_mode = 1 + pn_mode_named(a->pn_mode);
        if (!o->pn_mode)
            return cli_usage_error("render", "--pn-mode must be exact or fast, not '%s'", a->pn_mode);
    }
    if (a->scale > 0.0 || a->translate) {
        char tail;
        o->move = 1;
        o->scale = a->scale > 0.0 ? a->scale : 1.0;
        if (a->translate &&
            (sscanf(a->translate, "%lf,%lf,%lf%c", &o->translate[0], &o->translate[1], &o->translate[2], &tail) != 3 ||
             !isfinite(o->translate[0]) || !isfinite(o->translate[1]) || !isfinite(o->translate[2])))
            return cli_usage_error("render", "--translate needs X,Y,Z, three finite numbers, not '%s'", a->translate);
    }
    return 0;
}

/* One render's files: its frame's names. */
typedef struct {
    char exr[AFILE_PATH_MAX], png[AFILE_PATH_MAX], stats[AFILE_PATH_MAX], partial[AFILE_PATH_MAX];
} Paths;

/* Writes the run's outputs into temporary files and puts them all in place
 * together, or none. Returns 0, -1 after a message, or 1 when a signal came
 * while they were written (they are then discarded). */
static int write_outputs(const Args *a, const Paths *pp, const char *scene, const RenderPlan *plan,
                         const AccelInfo *ai, const Image *img, const ImageAttr *attrs, int nattrs, double phase[4],
                         const RayStats *st)
{
    double t0 = clock_now();
    const char *exr = outputs_add(pp->exr);
    const char *png = exr && a->png ? outputs_add(pp->png) : NULL;
    const char *stats = exr && (!a->png || png) && a->stats ? outputs_add(pp->stats) : NULL;
    int rc = 0;
    if (!exr || (a->png && !png) || (a->stats && !stats))
        rc = -1;
    /* each in its own temporary file, committed together below */
    if (rc == 0 && outputs_write_images(img, exr, pp->exr, a->use_float ? IMAGE_FLOAT : IMAGE_HALF, attrs, nattrs,
                                        png, pp->png, plan->threads) != 0)
        rc = -1;
    phase[3] = clock_now() - t0;
    if (rc == 0 && stats && write_stats(stats, pp->stats, scene, plan, ai, phase, st) != 0)
        rc = -1;
    if (rc == 0 && outputs_stopped())
        rc = 1;
    if (rc != 0) {
        outputs_abort();
        return rc;
    }
    return outputs_commit();
}

/* 1 when img's place in the picture is the same as o's. */
static int same_place(const Image *img, const Image *o)
{
    return o->x == img->x && o->y == img->y && o->width == img->width && o->height == img->height &&
           o->full_width == img->full_width && o->full_height == img->full_height;
}

/* --resume: returns 2 when the output is already complete, with this
 * stamp and region (nothing to do); 0 after taking the partial image's
 * rows into img and done, or when there is no partial image; -1 after a
 * message (a partial image of another render is never discarded). */
static int resume(const Paths *pp, const Stamp *st, Image *img, unsigned char *done, int quiet)
{
    char err[AFILE_PATH_MAX + 256], why[512];
    Image o;
    ImageMeta m;
    struct stat sb;
    if (stat(pp->exr, &sb) == 0 && S_ISREG(sb.st_mode)) {
        int complete = image_read_exr_meta(pp->exr, &o, &m, err, sizeof err) == 0 &&
                       !image_meta_get(&m, "lancer:rows") && !stamp_differs(st, &m, why, sizeof why) &&
                       same_place(img, &o);
        image_free(&o);
        image_meta_free(&m);
        if (complete)
            return 2;
    }
    if (lstat(pp->partial, &sb) != 0) {
        if (errno == ENOENT)
            return 0;
        fprintf(stderr, "lancer: cannot resume from %s: %s\n", pp->partial, strerror(errno));
        return -1;
    }
    int rc = -1;
    const char *rows = NULL;
    if (image_read_exr_meta(pp->partial, &o, &m, err, sizeof err) != 0)
        fprintf(stderr, "lancer: cannot resume: %s\n", err);
    else if (!(rows = image_meta_get(&m, "lancer:rows")))
        fprintf(stderr, "lancer: cannot resume from %s: it lists no finished rows (not a partial render)\n",
                pp->partial);
    else if (stamp_differs(st, &m, why, sizeof why))
        fprintf(stderr, "lancer: cannot resume from %s: it was %s; remove it to render from the start\n", pp->partial,
                why);
    else if (!same_place(img, &o))
        fprintf(stderr,
                "lancer: cannot resume from %s: it holds the region %d:%d,%d:%d of a %dx%d picture, not %d:%d,%d:%d "
                "of %dx%d; remove it to render from the start\n",
                pp->partial, o.x, o.x + o.width, o.y, o.y + o.height, o.full_width, o.full_height, img->x,
                img->x + img->width, img->y, img->y + img->height, img->full_width, img->full_height);
    else if (outputs_parse_rows(rows, done, img->height) != 0)
        fprintf(stderr, "lancer: cannot resume from %s: its list of finished rows is corrupt\n", pp->partial);
    else {
        int n = 0;
        for (int y = 0; y < img->height; y++)
            if (done[y]) {
                size_t row = (size_t)y * (size_t)img->width * 3;
                memcpy(img->rgb + row, o.rgb + row, sizeof(float) * 3 * (size_t)img->width);
                n++;
            }
        if (!quiet)
            fprintf(stderr, "lancer: resuming from %s: %d of %d rows done\n", pp->partial, n, img->height);
        rc = 0;
    }
    image_free(&o);
    image_meta_free(&m);
    return rc;
}

/* Renders one picture (frame -1: a still) into the files pp names.
 * Returns the exit status. */
static int render_one(Args *a, const char *scene, const PlanOptions *po, int frame, const Paths *pp)
{
    char err[CLI_ERR_LEN];
    double phase[4] = {0, 0, 0, 0}, t0 = clock_now();
    Scene s;
    if (scene_load(scene, &s, err, sizeof err) != 0) {
        fprintf(stderr, "%s\n", err);
        return 1;
    }
    if (frame >= 0 && scene_camera_frame(&s, frame, err, sizeof err) != 0) {
        fprintf(stderr, "lancer: %s: %s\n", scene, err);
        scene_free(&s);
        return 1;
    }
    phase[0] = clock_now() - t0;
    if (!a->quiet && phase[0] > PROGRESS_PHASE)
        fprintf(stderr, "lancer: read %s (%d primitives) in %.1f s; building the BVH\n", scene, s.nprims, phase[0]);
    RenderPlan plan;
    int rc = plan_build(&plan, &s, po, err, sizeof err);
    if (rc != 0) {
        if (rc == -2 && frame >= 0) /* a place in the scene file, as seen from this frame's camera */
            fprintf(stderr, "%s:%s (at frame %d)\n", scene, err, frame);
        else if (rc == -2)
            fprintf(stderr, "%s:%s\n", scene, err);
        else
            fprintf(stderr, "lancer: %s: %s\n", scene, err);
        scene_free(&s);
        return 1;
    }
    /* Fail on an output that cannot or must not be written before spending
     * time on the render. */
    const CliOutput outs[] = {{"-o", pp->exr, ".exr"},
                              {"--png", a->png ? pp->png : NULL, ".png"},
                              {"--stats", a->stats ? pp->stats : NULL, NULL},
                              {"(partial)", pp->partial, NULL}};
    if (cli_check_outputs(outs, 4, (const char *const *)s.inputs, s.ninputs) != 0) {
        plan_free(&plan);
        scene_free(&s);
        return 1;
    }

    Image img;
    RayStats st = {0};
    int w = plan.x1 - plan.x0, h = plan.y1 - plan.y0;
    unsigned char *done = calloc((size_t)h, 1);
    if (!done || image_init(&img, w, h) != 0) {
        fprintf(stderr, "lancer: out of memory for a %dx%d image\n", w, h);
        free(done);
        plan_free(&plan);
        scene_free(&s);
        return 1;
    }
    img.x = plan.x0;
    img.y = plan.y0;
    img.full_width = plan.width;
    img.full_height = plan.height;
    Stamp stamp;
    stamp_make(&stamp, scene, &s, &plan, po, a->use_float, frame);
    ImageAttr attrs[STAMP_ATTRS];
    int nattrs = stamp_attrs(&stamp, attrs);
    Accel *acc = NULL;
    if (a->resume && (rc = resume(pp, &stamp, &img, done, a->quiet)) != 0) {
        if (rc == 2 && !a->quiet)
            fprintf(stderr, "lancer: %s is complete, from this scene and these settings; nothing to do\n", pp->exr);
        if (rc == 2 && (a->png || a->stats)) /* said even with -q: the run leaves out what it was asked for */
            fprintf(stderr, "lancer: %s%s%s not written: %s with a render, and there was none\n",
                    a->png ? "--png" : "", a->png && a->stats ? " and " : "", a->stats ? "--stats" : "",
                    a->png && a->stats ? "they come" : "it comes");
        rc = rc == 2 ? 0 : 1;
        goto out;
    }
    t0 = clock_now();
    acc = accel_build_as(&s, plan.variant, plan.threads, plan.loop);
    if (!acc) {
        fprintf(stderr, "lancer: out of memory building the acceleration structure\n");
        rc = 1;
        goto out;
    }
    phase[1] = clock_now() - t0;
    AccelInfo ai = accel_info(acc);
    if (!a->quiet && phase[1] > PROGRESS_PHASE)
        fprintf(stderr, "lancer: built the BVH in %.1f s; rendering\n", phase[1]);

    Progress prog = {-1, 0, isatty(STDERR_FILENO), clock_now()};
    RenderOptions opt = {a->quiet ? NULL : on_progress, &prog, &outputs_stop, done};
    t0 = clock_now();
    rc = render_image(&plan, acc, &opt, &img, &st);
    phase[2] = clock_now() - t0;
    if (rc < 0)
        fprintf(stderr, "lancer: could not set up the render threads\n");
    else if (rc == 0)
        rc = write_outputs(a, pp, scene, &plan, &ai, &img, attrs, nattrs, phase, &st);
    if (rc == 1) /* stopped, while rendering or writing */
        rc = outputs_save_partial(attrs, nattrs, pp->exr, pp->partial, &img, done,
                                  prog.tty && prog.shown && prog.last_percent < 100 ? "\n" : "");
    else if (rc == 0) {
        struct stat old;
        if (lstat(pp->partial, &old) == 0 && S_ISREG(old.st_mode))
            unlink(pp->partial); /* the rest of a stopped run, now done */
        if (!a->quiet)
            fprintf(stderr, "lancer: wrote %s%s%s (%dx%d, %d thread%s, render %.3f s)\n", pp->exr,
                    a->png ? " and " : "", a->png ? pp->png : "", w, h, plan.threads, plan.threads > 1 ? "s" : "",
                    phase[2]);
        /* Said even with -q: the picture is not the scene's there. */
        if (st.too_deep)
            fprintf(stderr,
                    "lancer: warning: %llu refracted rays entered solids nested more than %d deep, which lancer "
                    "does not follow: their refraction is not the scene's\n",
                    st.too_deep, LIMIT_INTERIORS);
        if (st.shadow_cut)
            fprintf(stderr,
                    "lancer: warning: %llu shadow rays crossed more than %d transparent surfaces, which lancer "
                    "does not follow: they were taken as blocked\n",
                    st.shadow_cut, LIMIT_SHADOW_CROSSINGS);
        if (plan.camera_in_lost)
            fprintf(stderr,
                    "lancer: warning: the camera is inside %d solids past the %d innermost that lancer follows: "
                    "rays leaving those refract as if they were not there\n",
                    plan.camera_in_lost, LIMIT_INTERIORS);
        if (a->explain)
            explain(stdout, scene, &plan, &ai, phase, &st);
    } else
        rc = 1;
out:
    accel_free(acc);
    image_free(&img);
    free(done);
    plan_free(&plan);
    scene_free(&s);
    return rc;
}

/* Copies path (NULL: "") into buf; 0 when it does not fit. */
static int fits(char *buf, size_t len, const char *path)
{
    int n = snprintf(buf, len, "%s", path ? path : "");
    return n >= 0 && (size_t)n < len;
}

/* The files of frame `frame` (-1: a still, names as given). Returns 0, or
 * 1 after a message. */
static int paths_of(const Args *a, int frame, Paths *pp)
{
    if (frame < 0) {
        if (!fits(pp->exr, sizeof pp->exr, a->exr) || !fits(pp->png, sizeof pp->png, a->png) ||
            !fits(pp->stats, sizeof pp->stats, a->stats)) {
            fprintf(stderr, "lancer: an output path is too long\n");
            return 1;
        }
    } else if (cli_frame_path("-o", a->exr, frame, pp->exr, sizeof pp->exr, NULL) != 0 ||
               (a->png && cli_frame_path("--png", a->png, frame, pp->png, sizeof pp->png, NULL) != 0) ||
               (a->stats && cli_frame_path("--stats", a->stats, frame, pp->stats, sizeof pp->stats, NULL) != 0))
        return 1;
    return outputs_partial_name(pp->exr, pp->partial, sizeof pp->partial) != 0;
}

/* The literal part of frame pattern pat (well formed) after its last
 * number, "%%" as one percent sign, into lit; its length. */
static size_t pattern_tail(const char *pat, char *lit, size_t cap)
{
    const char *tail = pat;
    for (const char *q = pat; *q; q++)
        if (q[0] == '%' && q[1] == '%')
            q++;
        else if (q[0] == '%') {
            q += strspn(q + 1, "0123456789") + 1; /* at the conversion's 'd' */
            tail = q + (*q != '\0');
        }
    size_t n = 0;
    for (const char *q = tail; *q && n + 1 < cap; q++)
        lit[n++] = *q == '%' ? *++q : *q;
    lit[n] = '\0';
    return n;
}

/* Whether a name ending in tail a can end in tail b too: one ends the
 * other. */
static int tails_meet(const char *a, size_t na, const char *b, size_t nb)
{
    return na >= nb ? !memcmp(a + na - nb, b, nb) : !memcmp(b + nb - na, a, na);
}

/* The frame f in [lo, hi) whose file under frame pattern pat (well
 * formed, its pattern_tail tail) is name, or -1 for none. */
static int frame_of(const char *pat, const char *tail, size_t ntail, const char *name, int lo, int hi)
{
    const size_t len = strlen(name);
    if (ntail > len || memcmp(name + len - ntail, tail, ntail) != 0)
        return -1;
    size_t at = 0;
    const char *p = pat;
    for (; *p && !(p[0] == '%' && p[1] != '%'); p++, at++) { /* the literal part before the first number */
        if (p[0] == '%')
            p++; /* "%%", one percent sign */
        if (name[at] != *p)
            return -1;
    }
    if (!*p)
        return -1;
    char buf[AFILE_PATH_MAX];
    long f = 0;
    for (size_t k = at; name[k] >= '0' && name[k] <= '9' && f <= LIMIT_FRAME; k++) { /* each length of number */
        f = f * 10 + (name[k] - '0');
        if (f >= lo && f < hi && cli_frame_path(NULL, pat, (int)f, buf, sizeof buf, NULL) == 0 && !strcmp(buf, name))
            return (int)f;
    }
    return -1;
}

/* Frame pattern pat with its folder named by its device and inode, into
 * out, so that two spellings of one folder ("out", "./out", a link to it)
 * compare equal; pat itself where the folder holds a frame number or does
 * not exist. Returns 0, or -1 when out is too short. */
static int pattern_in_real_folder(const char *pat, char *out, size_t len)
{
    const char *slash = strrchr(pat, '/');
    char dir[AFILE_PATH_MAX];
    struct stat st;
    int n = slash ? snprintf(dir, sizeof dir, "%.*s", slash == pat ? 1 : (int)(slash - pat), pat)
                  : snprintf(dir, sizeof dir, ".");
    if (n < 0 || (size_t)n >= sizeof dir || strchr(dir, '%') || stat(dir, &st) != 0)
        return fits(out, len, pat) ? 0 : -1;
    n = snprintf(out, len, "%llu:%llu/%s", (unsigned long long)st.st_dev, (unsigned long long)st.st_ino,
                 slash ? slash + 1 : pat);
    return n >= 0 && (size_t)n < len ? 0 : -1;
}

/* 0 when no two files of frames first..last-1 are one file, of two frames
 * or of one (a%d.exr and a%02d.exr from frame 10), else 2 after a message
 * (each frame's inputs and writability are checked as it starts). The files:
 * the outputs of pat[0 .. 2], and the partial image of -o (pat[0]), which
 * a finished frame removes. */
static int frames_apart(const char *const pat[3], int first, int last)
{
    static const char *const opt[4] = {"-o", "--png", "--stats", "the partial image of -o"};
    char canon[4][AFILE_PATH_MAX], partial[AFILE_PATH_MAX], name[AFILE_PATH_MAX];
    const char *given[4] = {pat[0], pat[1], pat[2], NULL};
    if (outputs_partial_name(pat[0], partial, sizeof partial) != 0)
        return 2;
    given[3] = partial;
    for (int i = 0; i < 4; i++)
        if (given[i] && pattern_in_real_folder(given[i], canon[i], sizeof canon[i]) != 0)
            return cli_usage_error("render", "%s %s: the path is too long", opt[i], given[i]);
    /* Only kinds whose names can end alike are compared (".exr" and
     * ".partial.exr" can, ".exr" and ".png" cannot): a million frames are
     * checked in seconds. */
    char tail[4][AFILE_PATH_MAX];
    size_t ntail[4];
    int meets[4] = {0, 0, 0, 0};
    for (int i = 0; i < 4; i++)
        ntail[i] = given[i] ? pattern_tail(canon[i], tail[i], sizeof tail[i]) : 0;
    for (int i = 0; i < 4; i++)
        for (int j = 0; j < 4; j++)
            if (i != j && given[i] && given[j] && tails_meet(tail[i], ntail[i], tail[j], ntail[j]))
                meets[i] |= 1 << j;
    for (int f = first; f < last; f++)
        for (int i = 0; i < 4; i++) {
            if (!meets[i])
                continue;
            if (cli_frame_path(opt[i], canon[i], f, name, sizeof name, NULL) != 0)
                return 2;
            for (int j = 0; j < 4; j++) {
                if (!(meets[i] >> j & 1))
                    continue;
                int g = frame_of(canon[j], tail[j], ntail[j], name, first, last);
                if (g >= 0) { /* named as the user wrote them */
                    char a[AFILE_PATH_MAX], b[AFILE_PATH_MAX];
                    if (cli_frame_path(opt[i], given[i], f, a, sizeof a, NULL) != 0 ||
                        cli_frame_path(opt[j], given[j], g, b, sizeof b, NULL) != 0)
                        return 2;
                    return cli_usage_error(
                        "render",
                        "%s of frame %d (%s) and %s of frame %d (%s) are one file; each output needs a file of its own",
                        opt[i], f, a, opt[j], g, b);
                }
            }
        }
    return 0;
}

/* "A:B" into *a and *b, the numbers lo <= A < B <= hi. */
static int parse_range(const char *s, int lo, int hi, int *a, int *b)
{
    int v[2];
    if (cli_parse_ints(s, ":", 2, v) != 0 || !(lo <= v[0] && v[0] < v[1] && v[1] <= hi))
        return -1;
    *a = v[0];
    *b = v[1];
    return 0;
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
    if (a->region) {
        int r[4];
        po.region = 1;
        if (cli_parse_ints(a->region, ":,:", 4, r) != 0 || !(r[0] < r[1] && r[2] < r[3]))
            return cli_usage_error("render", "--region needs X0:X1,Y0:Y1 with 0 <= X0 < X1 and 0 <= Y0 < Y1, not '%s'",
                                   a->region);
        po.rx0 = r[0];
        po.rx1 = r[1];
        po.ry0 = r[2];
        po.ry1 = r[3];
    }
    int first = -1, last = 0; /* frames first..last-1; -1: a still */
    if (a->frame >= 0 && a->frames)
        return cli_usage_error("render", "--frame and --frames exclude each other");
    if (a->frame >= 0) {
        first = a->frame;
        last = a->frame + 1;
    }
    if (a->frames && parse_range(a->frames, 0, LIMIT_FRAME + 1, &first, &last) != 0)
        return cli_usage_error("render", "--frames needs A:B, frames A to B-1 with 0 <= A < B <= %d, not '%s'",
                               LIMIT_FRAME + 1, a->frames);

    static char exr_default[AFILE_PATH_MAX]; /* static: a->exr, in the caller's memory, keeps it */
    if (!a->exr) {
        if (cli_default_output(scene, first >= 0 ? ".%04d.exr" : ".exr", exr_default, sizeof exr_default) != 0)
            return 1;
        a->exr = exr_default;
    }
    if (first >= 0) { /* frame patterns well formed; with several frames, each frame's files its own */
        const char *const opt_names[3] = {"-o", "--png", "--stats"}, *const paths[3] = {a->exr, a->png, a->stats};
        char buf[AFILE_PATH_MAX];
        for (int i = 0; i < 3; i++) {
            int n = 0;
            if (paths[i] && cli_frame_path(opt_names[i], paths[i], 0, buf, sizeof buf, &n) != 0)
                return 2;
            if (paths[i] && n == 0 && last - first > 1)
                return cli_usage_error("render", "%s %s: several frames need a frame pattern in the name, such as %%04d",
                                       opt_names[i], paths[i]);
        }
        if (frames_apart(paths, first, last) != 0)
            return 2;
    }
    outputs_catch_signals();
    for (int f = first; f < last; f++) { /* once, at -1, for a still */
        Paths pp;
        if (paths_of(a, f, &pp) != 0)
            return 1;
        rc = render_one(a, scene, &po, f, &pp);
        if (rc != 0)
            return rc;
        if (outputs_stopped() && f + 1 < last) /* between two frames: the next one is not begun */
            return 128 + outputs_stopped();
    }
    return 0;
}

static const Opt opts[] = {
    {"--output", "-o", OPT_STRING, offsetof(Args, exr), 0, 0},
    {"--png", NULL, OPT_STRING, offsetof(Args, png), 0, 0},
    {"--stats", NULL, OPT_STRING, offsetof(Args, stats), 0, 0},
    {"--width", NULL, OPT_INT, offsetof(Args, width), 1, LIMIT_IMAGE_SIDE},
    {"--height", NULL, OPT_INT, offsetof(Args, height), 1, LIMIT_IMAGE_SIDE},
    {"--spp", NULL, OPT_INT, offsetof(Args, spp), 1, LIMIT_SPP},
    {"--quality", NULL, OPT_STRING, offsetof(Args, quality), 0, 0},
    {"--max-depth", NULL, OPT_INT, offsetof(Args, max_depth), 1, LIMIT_DEPTH},
    {"--threads", NULL, OPT_INT, offsetof(Args, threads), 1, LIMIT_THREADS},
    {"--float", NULL, OPT_FLAG, offsetof(Args, use_float), 0, 0},
    {"--classic", NULL, OPT_FLAG, offsetof(Args, classic), 0, 0},
    {"--pn-mode", NULL, OPT_STRING, offsetof(Args, pn_mode), 0, 0},
    {"--scale", NULL, OPT_DOUBLE, offsetof(Args, scale), 0, 0},
    {"--translate", NULL, OPT_STRING, offsetof(Args, translate), 0, 0},
    {"--quiet", "-q", OPT_FLAG, offsetof(Args, quiet), 0, 0},
    {"--explain", NULL, OPT_FLAG, offsetof(Args, explain), 0, 0},
    {"--no-plan", NULL, OPT_FLAG, offsetof(Args, no_plan), 0, 0},
    {"--accel", NULL, OPT_STRING, offsetof(Args, accel), 0, 0},
    {"--adc-bailout", NULL, OPT_STRING, offsetof(Args, adc), 0, 0},
    {"--aa-threshold", NULL, OPT_DOUBLE, offsetof(Args, aa), 0, 3},
    {"--area-samples", NULL, OPT_INT, offsetof(Args, area_samples), 1, LIMIT_AREA_SAMPLES},
    {"--area-adaptive", NULL, OPT_INT, offsetof(Args, area_adaptive), 0, LIMIT_AREA_ADAPTIVE},
    {"--region", NULL, OPT_STRING, offsetof(Args, region), 0, 0},
    {"--resume", NULL, OPT_FLAG, offsetof(Args, resume), 0, 0},
    {"--frame", NULL, OPT_INT, offsetof(Args, frame), 0, LIMIT_FRAME},
    {"--frames", NULL, OPT_STRING, offsetof(Args, frames), 0, 0},
};

const Command cmd_render = {"render", usage, opts, (int)(sizeof opts / sizeof opts[0]), 1, sizeof(Args), defaults, run};
