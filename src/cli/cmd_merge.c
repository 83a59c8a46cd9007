/*
 * cmd_merge.c - lancer merge: rendered tiles assembled into the full image.
 */
#include <limits.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "lancer/afile.h"
#include "lancer/image.h"
#include "lancer/limits.h"
#include "outputs.h"
#include "stamp.h"

static const char usage[] =
    "usage: lancer merge -o OUT.exr [--png OUT.png] [--threads N] [-q] TILE.exr...\n"
    "\n"
    "Assembles tiles that 'lancer render --region' wrote into the full image:\n"
    "each tile's EXR data window says where it lies, and its header which\n"
    "scene (by the content hash of the scene file and its meshes), settings,\n"
    "version of lancer and frame it was rendered from. The tiles must cover\n"
    "the picture exactly once and agree on all of these; a partial tile (of\n"
    "a stopped render), an unreadable or truncated one, an overlap or a gap\n"
    "is an error that names the tiles, and nothing is written. OUT.exr keeps\n"
    "the tiles' channels (half or float) and stamp, and is written to a\n"
    "temporary file and renamed into place.\n"
    "\n"
    "options:\n"
    "  -o, --output OUT.exr  the full image to write (required)\n"
    "      --png OUT.png     also write an 8-bit sRGB PNG preview\n"
    "      --threads N       threads for the writing: the EXR's chunks, and\n"
    "                        the PNG beside them (default: the processors)\n"
    "  -q, --quiet           no summary on stderr\n"
    "  -h, --help            show this help\n";

typedef struct {
    const char *exr, *png;
    int quiet, threads;
} Args;

static void defaults(void *args)
{
    Args *a = args;
    a->threads = cli_default_threads();
}

typedef struct {
    int x0, x1, y0, y1;
} Rect;

static int rect_cmp(const void *a, const void *b)
{
    int x = ((const Rect *)a)->x0, y = ((const Rect *)b)->x0;
    return (x > y) - (x < y);
}

/* The first pixel of a w x h picture that no rectangle covers, in rows
 * from the top left; *gx = -1 when all are covered. */
static void first_gap(const Rect *r, int n, int w, int h, int *gx, int *gy)
{
    Rect *row = malloc(sizeof *row * (size_t)(n ? n : 1));
    *gx = *gy = -1;
    for (int y = 0; y < h && row && *gx < 0; y++) {
        int k = 0;
        for (int i = 0; i < n; i++)
            if (r[i].y0 <= y && y < r[i].y1)
                row[k++] = r[i];
        qsort(row, (size_t)k, sizeof *row, rect_cmp);
        int x = 0;
        for (int i = 0; i < k && row[i].x0 <= x; i++)
            x = row[i].x1 > x ? row[i].x1 : x;
        if (x < w) {
            *gx = x;
            *gy = y;
        }
    }
    free(row);
}

static int run(void *args, const char **pos, int npos)
{
    Args *a = args;
    if (!a->exr)
        return cli_usage_error("merge", "needs -o OUT.exr");
    if (npos == 0)
        return cli_usage_error("merge", "needs the tiles to merge");
    const CliOutput outs[] = {{"-o", a->exr, ".exr"}, {"--png", a->png, ".png"}};
    if (cli_check_outputs(outs, 2, pos, npos) != 0)
        return 1;
    char err[AFILE_PATH_MAX + 512], why[512];
    Image full = {0, 0, NULL, 0, 0, 0, 0}, t;
    ImageMeta first, m;
    Rect *rects = malloc(sizeof *rects * (size_t)npos);
    long long covered = 0;
    int rc = 1, i = 0;
    memset(&first, 0, sizeof first);
    if (!rects) {
        fprintf(stderr, "lancer: out of memory\n");
        return 1;
    }
    for (i = 0; i < npos; i++) {
        if (image_read_exr_meta(pos[i], &t, &m, err, sizeof err) != 0) {
            fprintf(stderr, "lancer: %s\n", err);
            image_meta_free(&m);
            goto out;
        }
        Rect r = {t.x, t.x + t.width, t.y, t.y + t.height};
        const char *rows = image_meta_get(&m, "lancer:rows");
        int bad = 1;
        if (rows)
            fprintf(stderr, "lancer: %s: is a partial render (rows %s done); finish it with lancer render --resume\n",
                    pos[i], rows);
        else if (i == 0 && stamp_meta_differs(&m, &m, why, sizeof why))
            fprintf(stderr, "lancer: %s: %s\n", pos[i], why);
        else if (i > 0 && stamp_meta_differs(&first, &m, why, sizeof why))
            fprintf(stderr, "lancer: %s: %s, unlike %s\n", pos[i], why, pos[0]);
        else if (i > 0 && (t.full_width != full.width || t.full_height != full.height))
            fprintf(stderr, "lancer: %s: is a tile of a %dx%d picture, %s of %dx%d\n", pos[i], t.full_width,
                    t.full_height, pos[0], full.width, full.height);
        else
            bad = 0;
        for (int k = 0; k < i && !bad; k++)
            if (r.x0 < rects[k].x1 && rects[k].x0 < r.x1 && r.y0 < rects[k].y1 && rects[k].y0 < r.y1) {
                fprintf(stderr, "lancer: %s: its region %d:%d,%d:%d overlaps %s's %d:%d,%d:%d\n", pos[i], r.x0, r.x1,
                        r.y0, r.y1, pos[k], rects[k].x0, rects[k].x1, rects[k].y0, rects[k].y1);
                bad = 1;
            }
        if (!bad && i == 0 &&
            (t.full_width > LIMIT_IMAGE_SIDE || t.full_height > LIMIT_IMAGE_SIDE ||
             (long)t.full_width * t.full_height > LIMIT_IMAGE_PIXELS)) {
            fprintf(stderr,
                    "lancer: %s: is a tile of a %dx%d picture, past lancer's limits of %d pixels a side and %ld "
                    "in all\n",
                    pos[i], t.full_width, t.full_height, LIMIT_IMAGE_SIDE, LIMIT_IMAGE_PIXELS);
            bad = 1;
        }
        if (!bad && i == 0 && image_init(&full, t.full_width, t.full_height) != 0) {
            fprintf(stderr, "lancer: out of memory for a %dx%d image\n", t.full_width, t.full_height);
            bad = 1;
        }
        if (bad) {
            image_free(&t);
            image_meta_free(&m);
            goto out;
        }
        for (int y = 0; y < t.height; y++)
            memcpy(full.rgb + ((size_t)(t.y + y) * (size_t)full.width + (size_t)t.x) * 3,
                   t.rgb + (size_t)y * (size_t)t.width * 3, sizeof(float) * 3 * (size_t)t.width);
        rects[i] = r;
        covered += (long long)t.width * t.height;
        image_free(&t);
        if (i == 0)
            first = m;
        else
            image_meta_free(&m);
    }
    if (covered < (long long)full.width * full.height) {
        int gx, gy;
        first_gap(rects, npos, full.width, full.height, &gx, &gy);
        fprintf(stderr, "lancer: the tiles leave %lld of the %dx%d picture's pixels uncovered, the first at (%d, %d)\n",
                (long long)full.width * full.height - covered, full.width, full.height, gx, gy);
        goto out;
    }
    ImageAttr attrs[IMAGE_META_MAX];
    for (int k = 0; k < first.n; k++)
        attrs[k] = (ImageAttr){first.name[k], first.value[k]};
    const char *exr = outputs_add(a->exr), *png = exr && a->png ? outputs_add(a->png) : NULL;
    if (exr && (!a->png || png) &&
        outputs_write_images(&full, exr, a->exr, first.half ? IMAGE_HALF : IMAGE_FLOAT, attrs, first.n, png, a->png,
                             a->threads) == 0)
        rc = outputs_commit() == 0 ? 0 : 1;
    else
        outputs_abort();
    if (rc == 0 && !a->quiet)
        fprintf(stderr, "lancer: merged %d tile%s into %s (%dx%d)\n", npos, npos > 1 ? "s" : "", a->exr, full.width,
                full.height);
out:
    image_meta_free(&first);
    image_free(&full);
    free(rects);
    return rc;
}

static const Opt opts[] = {
    {"--output", "-o", OPT_STRING, offsetof(Args, exr), 0, 0},
    {"--png", NULL, OPT_STRING, offsetof(Args, png), 0, 0},
    {"--quiet", "-q", OPT_FLAG, offsetof(Args, quiet), 0, 0},
    {"--threads", NULL, OPT_INT, offsetof(Args, threads), 1, LIMIT_THREADS},
};

const Command cmd_merge = {"merge", usage, opts, (int)(sizeof opts / sizeof opts[0]), INT_MAX, sizeof(Args), defaults,
                           run};
