/*
 * cmd_export.c - lancer export-pov: the POV-Ray 3.7 twin of a scene.
 */
#include <stddef.h>
#include <stdio.h>
#include <string.h>

#include "cli.h"
#include "lancer/afile.h"
#include "lancer/image.h"
#include "lancer/pov.h"

static const char usage[] =
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
    "      --pn-segments N   write each PN patch as a smooth mesh of N segments\n"
    "                        per edge, N x N triangles (default 16); the error\n"
    "                        falls as 1/N^2\n"
    "      --frame N         the camera at frame N of the scene's camera path\n"
    "  -h, --help            show this help\n";

typedef struct {
    const char *out;
    int width, height, pn_segments, frame;
} Args;

static void defaults(void *args) { ((Args *)args)->frame = -1; }

static int run(void *args, const char **pos, int npos)
{
    Args *a = args;
    if (npos == 0)
        return cli_usage_error("export-pov", "missing SCENE");
    const char *scene = pos[0], *out = a->out;
    Scene s;
    char path[AFILE_PATH_MAX], tmp[AFILE_PATH_MAX], err[CLI_ERR_LEN];
    if (scene_load(scene, &s, err, sizeof err) != 0) {
        fprintf(stderr, "%s\n", err);
        return 1;
    }
    if (a->frame >= 0 && scene_camera_frame(&s, a->frame, err, sizeof err) != 0) {
        fprintf(stderr, "lancer: %s: %s\n", scene, err);
        scene_free(&s);
        return 1;
    }
    int w, h, rc = 0;
    if (cli_image_size(a->width, a->height, s.image.width, s.image.height, &w, &h) != 0) {
        rc = 1;
    } else if (out && !strcmp(out, "-")) {
        if (pov_export(&s, w, h, a->pn_segments, stdout) != 0 || fflush(stdout) != 0) {
            fprintf(stderr, "lancer: writing to standard output failed\n");
            rc = 1;
        }
    } else if (!out && cli_default_output(scene, ".pov", path, sizeof path) != 0) {
        rc = 1;
    } else {
        out = out ? out : path;
        const CliOutput o = {"-o", out, NULL};
        FILE *f;
        if (cli_check_outputs(&o, 1, (const char *const *)s.inputs, s.ninputs) != 0) {
            rc = 1;
        } else if (!(f = afile_fopen(out, tmp, sizeof tmp, err, sizeof err))) {
            fprintf(stderr, "lancer: %s\n", err);
            rc = 1;
        } else if (pov_export(&s, w, h, a->pn_segments, f) != 0) { /* out of memory, or a write failed */
            fclose(f);
            afile_abort(tmp);
            fprintf(stderr, "lancer: %s: out of memory, or writing failed; the file is unchanged\n", out);
            rc = 1;
        } else if (afile_fclose(f, tmp, out, err, sizeof err) != 0) {
            fprintf(stderr, "lancer: %s\n", err);
            rc = 1;
        }
    }
    scene_free(&s);
    return rc;
}

static const Opt opts[] = {
    {"--output", "-o", OPT_STRING, offsetof(Args, out), 0, 0},
    {"--width", NULL, OPT_INT, offsetof(Args, width), 1, LIMIT_IMAGE_SIDE},
    {"--height", NULL, OPT_INT, offsetof(Args, height), 1, LIMIT_IMAGE_SIDE},
    {"--pn-segments", NULL, OPT_INT, offsetof(Args, pn_segments), 1, LIMIT_PN_SEGMENTS},
    {"--frame", NULL, OPT_INT, offsetof(Args, frame), 0, LIMIT_FRAME},
};

const Command cmd_export_pov = {"export-pov", usage, opts, (int)(sizeof opts / sizeof opts[0]), 1, sizeof(Args), defaults,
                                run};
