/*
 * cli.c - helpers shared by the commands (see cli.h).
 */
#include "cli.h"

#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "lancer/afile.h"

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

int cli_parse_int(const char *s, int lo, int hi, int *out)
{
    char *end;
    errno = 0;
    long v = strtol(s, &end, 10);
    if (errno || end == s || *end || v < lo || v > hi)
        return -1;
    *out = (int)v;
    return 0;
}

int cli_default_output(const char *path, const char *ext, char *buf, size_t len)
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

int cli_check_output(const char *path)
{
    char err[512];
    if (path && afile_check_writable(path, err, sizeof err) != 0) {
        fprintf(stderr, "lancer: %s\n", err);
        return -1;
    }
    return 0;
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
        if (cli_check_output(out[i].path) != 0)
            return -1;
    }
    return 0;
}
