/*
 * cmd_diff.c - lancer diff: two EXR images compared pixel by pixel.
 */
#include <stddef.h>
#include <stdio.h>

#include "cli.h"
#include "lancer/compare.h"
#include "lancer/limits.h"

static const char usage[] =
    "usage: lancer diff A.exr B.exr [options]\n"
    "\n"
    "Compares two EXR images channel by channel and prints one line:\n"
    "  max=<max abs diff> mean=<mean abs diff> rms=<rms> psnr=<dB>\n"
    "  over=<pixels with a channel differing by more than the threshold> pixels=<total>\n"
    "PSNR takes 1.0 as the peak. The exit status is 0 whatever the difference,\n"
    "1 when an image cannot be read, the sizes or the parts of the pictures differ,\n"
    "or stdout cannot be written.\n"
    "\n"
    "options:\n"
    "      --heatmap OUT.png  write a false-colour map of the differences, T the\n"
    "                         threshold: black up to T/200, blue at T/20, cyan at\n"
    "                         T/2, yellow at T, red from 100 T (T = 2e-3: 1e-5,\n"
    "                         1e-4, 1e-3, 2e-3, 0.2)\n"
    "      --downsample K     average B in K x K blocks first (B is a render at\n"
    "                         K times the size of A)\n"
    "      --threshold T      the difference that counts as over (default 2e-3)\n"
    "      --relative R       ...or R times the larger of the two values, if\n"
    "                         that is more (default 0; 4.8828125e-4, 2^-11, is\n"
    "                         the rounding of half floats)\n"
    "  -h, --help             show this help\n";

typedef struct {
    const char *heatmap;
    int down;
    double threshold, relative;
} Args;

static void defaults(void *args)
{
    Args *a = args;
    a->down = 1;
    a->threshold = COMPARE_THRESHOLD;
}

static int read_exr(const char *path, Image *img)
{
    char err[CLI_ERR_LEN];
    if (image_read_exr(path, img, err, sizeof err) != 0) {
        fprintf(stderr, "lancer: %s\n", err);
        return -1;
    }
    return 0;
}

static int run(void *args, const char **pos, int npos)
{
    Args *a = args;
    if (npos < 2)
        return cli_usage_error("diff", "needs two images, A and B");
    const CliOutput heat_out = {"--heatmap", a->heatmap, ".png"};
    if (cli_check_outputs(&heat_out, 1, pos, 2) != 0)
        return 1;
    Image ia, ib, small, heat;
    char err[CLI_ERR_LEN];
    if (read_exr(pos[0], &ia) != 0)
        return 1;
    if (read_exr(pos[1], &ib) != 0) {
        image_free(&ia);
        return 1;
    }
    if (a->down > 1) {
        if (compare_downsample(&ib, a->down, &small, err, sizeof err) != 0) {
            fprintf(stderr, "lancer: %s: %s\n", pos[1], err);
            image_free(&ia);
            image_free(&ib);
            return 1;
        }
        image_free(&ib);
        ib = small;
    }
    CompareStats st;
    int rc = compare_images(&ia, &ib, a->threshold, a->relative, &st, err, sizeof err);
    if (rc == 0) {
        printf("max=%.6g mean=%.6g rms=%.6g psnr=%.2f over=%ld pixels=%ld\n", st.max, st.mean, st.rms, st.psnr,
               st.over, st.pixels);
        if (a->heatmap) {
            rc = compare_heatmap(&ia, &ib, a->threshold, &heat, err, sizeof err);
            if (rc == 0) {
                rc = image_write_png(&heat, a->heatmap, err, sizeof err);
                image_free(&heat);
            }
        }
    }
    if (rc != 0)
        fprintf(stderr, "lancer: %s\n", err);
    image_free(&ia);
    image_free(&ib);
    return rc ? 1 : 0;
}

static const Opt opts[] = {
    {"--heatmap", NULL, OPT_STRING, offsetof(Args, heatmap), 0, 0},
    {"--downsample", NULL, OPT_INT, offsetof(Args, down), 1, LIMIT_DOWNSAMPLE},
    {"--threshold", NULL, OPT_DOUBLE, offsetof(Args, threshold), 0, 0},
    {"--relative", NULL, OPT_DOUBLE, offsetof(Args, relative), 0, 1},
};

const Command cmd_diff = {"diff", usage, opts, (int)(sizeof opts / sizeof opts[0]), 2, sizeof(Args), defaults, run};
