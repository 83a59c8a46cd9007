/*
 * cli.c - helpers shared by the commands (see cli.h).
 */
#include "cli.h"

#include <errno.h>
#include <limits.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include <unistd.h>

#include "lancer/afile.h"
#include "lancer/limits.h"

int cli_usage_error(const char *cmd, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    fprintf(stderr, "lancer %s: ", cmd);
    vfprintf(stderr, fmt, ap);
    va_end(ap);
    fprintf(stderr, "\n(see 'lancer %s --help')\n", cmd);
    return 2;
}

int cli_default_threads(void)
{
    long cores = sysconf(_SC_NPROCESSORS_ONLN);
    return cores > 0 ? (int)(cores < LIMIT_THREADS ? cores : LIMIT_THREADS) : 1;
}

int cli_parse_int(const char *s, int lo, int hi, int *out)
{
    /* digits, as cli_parse_ints takes them: strtol would also take blanks
     * and a '+' before them */
    if (!(*s >= '0' && *s <= '9') && !(*s == '-' && lo < 0))
        return -1;
    char *end;
    errno = 0;
    long v = strtol(s, &end, 10);
    if (errno || end == s || *end || v < lo || v > hi)
        return -1;
    *out = (int)v;
    return 0;
}

int cli_parse_ints(const char *s, const char *seps, int n, int *out)
{
    for (int i = 0; i < n; i++) {
        if (*s < '0' || *s > '9') /* strtol would take a sign or spaces */
            return -1;
        char *end;
        errno = 0;
        long v = strtol(s, &end, 10);
        if (errno || v > INT_MAX)
            return -1;
        out[i] = (int)v;
        s = end;
        if (i < n - 1 && *s++ != seps[i])
            return -1;
    }
    return *s ? -1 : 0;
}

/* Appends the n bytes s to buf (room len) at *at, ending it. Returns 0,
 * or -1 when they do not fit. */
static int put(char *buf, size_t len, size_t *at, const char *s, size_t n)
{
    if (*at + n >= len)
        return -1;
    memcpy(buf + *at, s, n);
    *at += n;
    buf[*at] = '\0';
    return 0;
}

int cli_default_output(const char *path, const char *ext, char *buf, size_t len)
{
    const char *base = strrchr(path, '/');
    base = base ? base + 1 : path;
    const char *dot = strrchr(base, '.');
    int n = dot && dot != base ? (int)(dot - base) : (int)strlen(base);
    int pattern = strchr(ext, '%') != NULL; /* then a '%' of the name is written "%%" */
    size_t at = 0;
    int bad = put(buf, len, &at, "out/", 4);
    for (int i = 0; i < n && !bad; i++)
        bad = base[i] == '%' && pattern ? put(buf, len, &at, "%%", 2) : put(buf, len, &at, base + i, 1);
    if (bad || put(buf, len, &at, ext, strlen(ext)) != 0) {
        fprintf(stderr, "lancer: %s: path too long\n", path);
        return -1;
    }
    if (mkdir("out", 0777) != 0 && errno != EEXIST) {
        fprintf(stderr, "lancer: cannot create directory 'out': %s\n", strerror(errno));
        return -1;
    }
    return 0;
}

int cli_frame_path(const char *option, const char *path, int frame, char *buf, size_t len, int *count)
{
    size_t at = 0;
    int n = 0;
    for (const char *p = path; *p; p++) {
        char piece[16];
        int w;
        if (*p != '%')
            w = snprintf(piece, sizeof piece, "%c", *p);
        else if (p[1] == '%')
            w = snprintf(piece, sizeof piece, "%%"), p++;
        else if (p[1] == 'd')
            w = snprintf(piece, sizeof piece, "%d", frame), p++, n++;
        else if (p[1] == '0' && p[2] >= '1' && p[2] <= '9' && p[3] == 'd')
            w = snprintf(piece, sizeof piece, "%0*d", p[2] - '0', frame), p += 3, n++;
        else {
            if (option)
                fprintf(stderr,
                        "lancer: %s %s: a frame pattern is %%d or %%0Nd (N from 1 to 9), and %%%% a percent sign\n",
                        option, path);
            return -1;
        }
        if (w < 0 || at + (size_t)w >= len) {
            if (option)
                fprintf(stderr, "lancer: %s %s: path too long\n", option, path);
            return -1;
        }
        memcpy(buf + at, piece, (size_t)w);
        at += (size_t)w;
    }
    buf[at] = '\0';
    if (count)
        *count = n;
    return 0;
}

int cli_check_output(const char *path)
{
    char err[CLI_ERR_LEN];
    if (path && afile_check_writable(path, err, sizeof err) != 0) {
        fprintf(stderr, "lancer: %s\n", err);
        return -1;
    }
    return 0;
}

/* The extension of path (from its last '.') when it names an image format
 * other than ext's, else NULL. */
static const char *other_image_ext(const char *path, const char *ext)
{
    static const char *const image[] = {".exr",  ".png", ".jpg", ".jpeg", ".tif",
                                        ".tiff", ".ppm", ".bmp", ".hdr",  ".tga"};
    const char *dot = strrchr(path, '.');
    if (!dot || strchr(dot, '/'))
        return NULL;
    for (size_t i = 0; i < sizeof image / sizeof image[0]; i++)
        if (strcasecmp(dot, image[i]) == 0)
            return strcmp(image[i], ext) != 0 ? dot : NULL;
    return NULL;
}

int cli_check_outputs(const CliOutput *out, int nout, const char *const *in, int nin)
{
    for (int i = 0; i < nout; i++) {
        if (!out[i].path)
            continue;
        for (int j = 0; j < nin; j++)
            if (afile_same(out[i].path, in[j])) {
                fprintf(stderr, "lancer: %s %s: is the input '%s'; lancer never writes over its inputs\n",
                        out[i].option, out[i].path, in[j]);
                return -1;
            }
        for (int j = 0; j < i; j++)
            if (out[j].path && afile_same(out[i].path, out[j].path)) {
                fprintf(stderr, "lancer: %s %s: is also the %s output; each output needs a file of its own\n",
                        out[i].option, out[i].path, out[j].option);
                return -1;
            }
        const char *wrong = out[i].ext ? other_image_ext(out[i].path, out[i].ext) : NULL;
        if (wrong) {
            fprintf(stderr, "lancer: %s %s: this output is %s image; end its name in %s, not %s\n", out[i].option,
                    out[i].path, strcmp(out[i].ext, ".exr") == 0 ? "an OpenEXR" : "a PNG", out[i].ext, wrong);
            return -1;
        }
        if (cli_check_output(out[i].path) != 0)
            return -1;
    }
    return 0;
}

int cli_image_size(int width, int height, int sw, int sh, int *w, int *h)
{
    *w = width ? width : sw;
    *h = height ? height : sh;
    if ((long)*w * *h <= LIMIT_IMAGE_PIXELS)
        return 0;
    fprintf(stderr, "lancer: a %dx%d image has more than the %ld pixels lancer renders\n", *w, *h, LIMIT_IMAGE_PIXELS);
    return 1;
}
