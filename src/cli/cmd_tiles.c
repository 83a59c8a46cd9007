/*
 * cmd_tiles.c - lancer tiles: a render split into regions, one per line,
 * for a job array or GNU parallel.
 */
#include <math.h>
#include <stddef.h>
#include <stdio.h>

#include "cli.h"
#include "lancer/limits.h"
#include "lancer/scene.h"

static const char usage[] =
    "usage: lancer tiles SCENE (--count N | --size WxH) [options]\n"
    "\n"
    "Prints the regions that cover SCENE's image, one a line, as\n"
    "'lancer render --region' takes them: X0:X1,Y0:Y1, half-open pixel\n"
    "ranges, row 0 at the top, in rows from the top left. Each region renders\n"
    "on its own ('lancer render SCENE --region R -o tile.exr'), and\n"
    "'lancer merge' puts the tiles together.\n"
    "\n"
    "options:\n"
    "      --count N     exactly N regions: a grid of C columns and R rows, C x R = N,\n"
    "                    whose cells are closest to square\n"
    "      --size WxH    regions of W x H pixels (smaller at the right and bottom)\n"
    "      --width W     the image's width, if the render overrides the scene's\n"
    "      --height H    the image's height, likewise\n"
    "  -h, --help        show this help\n";

typedef struct {
    int count, width, height;
    const char *size;
} Args;

/* The most regions lancer tiles prints. */
#define TILES_MAX 1000000

static int run(void *args, const char **pos, int npos)
{
    Args *a = args;
    if (npos == 0)
        return cli_usage_error("tiles", "missing SCENE");
    if (!a->count == !a->size)
        return cli_usage_error("tiles", "needs one of --count N and --size WxH");
    int size[2] = {0, 0};
    if (a->size && (cli_parse_ints(a->size, "x", 2, size) != 0 || size[0] < 1 || size[1] < 1 ||
                    size[0] > LIMIT_IMAGE_SIDE || size[1] > LIMIT_IMAGE_SIDE))
        return cli_usage_error("tiles", "--size needs WxH, two whole numbers from 1 to %d, not '%s'",
                               LIMIT_IMAGE_SIDE, a->size);
    int tw = size[0], th = size[1];
    Scene s;
    char err[CLI_ERR_LEN];
    if (scene_load(pos[0], &s, err, sizeof err) != 0) {
        fprintf(stderr, "%s\n", err);
        return 1;
    }
    int w, h;
    const int big = cli_image_size(a->width, a->height, s.image.width, s.image.height, &w, &h);
    scene_free(&s);
    if (big)
        return 1;
    int cols, rows;
    if (a->size) {
        cols = (w + tw - 1) / tw;
        rows = (h + th - 1) / th;
        if ((long)cols * rows > TILES_MAX) {
            fprintf(stderr, "lancer: tiles of %dx%d would make more than %d regions of a %dx%d image\n", tw, th,
                    TILES_MAX, w, h);
            return 1;
        }
    } else {
        /* the factor pair whose cells, (w / c) x (h / r), are closest to square */
        cols = rows = 0;
        double best = INFINITY;
        for (int c = 1; c <= a->count; c++) {
            int r = a->count / c;
            if (r * c != a->count || c > w || r > h)
                continue;
            double d = fabs(log(((double)w / c) / ((double)h / r)));
            if (d < best) {
                best = d;
                cols = c;
                rows = r;
            }
        }
        if (!cols) {
            fprintf(stderr, "lancer: a %dx%d image cannot be split into %d regions of whole pixels in a grid\n", w, h,
                    a->count);
            return 1;
        }
    }
    for (int j = 0; j < rows; j++)
        for (int i = 0; i < cols; i++) {
            long x0 = a->size ? (long)i * tw : (long)i * w / cols, y0 = a->size ? (long)j * th : (long)j * h / rows;
            long x1 = a->size ? (long)(i + 1) * tw : (long)(i + 1) * w / cols;
            long y1 = a->size ? (long)(j + 1) * th : (long)(j + 1) * h / rows;
            printf("%ld:%ld,%ld:%ld\n", x0, x1 < w ? x1 : w, y0, y1 < h ? y1 : h);
        }
    return 0; /* main fails the run if stdout cannot take the lines */
}

static const Opt opts[] = {
    {"--count", NULL, OPT_INT, offsetof(Args, count), 1, TILES_MAX},
    {"--size", NULL, OPT_STRING, offsetof(Args, size), 0, 0},
    {"--width", NULL, OPT_INT, offsetof(Args, width), 1, LIMIT_IMAGE_SIDE},
    {"--height", NULL, OPT_INT, offsetof(Args, height), 1, LIMIT_IMAGE_SIDE},
};

const Command cmd_tiles = {"tiles", usage, opts, (int)(sizeof opts / sizeof opts[0]), 1, sizeof(Args), NULL, run};
