/*
 * main.c - the lancer command line: dispatch to a command, its usage, and
 * the parsing of its options (see cli.h for the command table).
 */
#include <errno.h>
#ifdef __GLIBC__
#include <malloc.h>
#endif
#include <math.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"

static const char *usage_main =
    "usage: lancer <command> [options]\n"
    "\n"
    "lancer is a Whitted ray tracer that renders scene files to OpenEXR.\n"
    "\n"
    "commands:\n"
    "  render SCENE      render a scene file to an EXR image (and a PNG preview)\n"
    "  tiles SCENE       split a render into regions, one per line, for a scheduler\n"
    "  merge TILE...     assemble rendered tiles into the full image\n"
    "  export-pov SCENE  write the POV-Ray 3.7 scene that renders the same picture\n"
    "  diff A.exr B.exr  compare two images pixel by pixel\n"
    "  bench ...         generate benchmark rays for a mesh, or time ray casting\n"
    "  help [COMMAND]    show this help, or a command's\n"
    "\n"
    "options:\n"
    "  --help            show this help\n"
    "  --version         print the version\n"
    "\n"
    "'lancer COMMAND --help' describes a command's options; 'man lancer' has\n"
    "them all.\n";

static const Command *const commands[] = {&cmd_render, &cmd_tiles, &cmd_merge, &cmd_export_pov, &cmd_diff, &cmd_bench};
#define NCOMMANDS ((int)(sizeof commands / sizeof commands[0]))

#define HELP_SHOWN 3 /* parse_opts showed --help: exit 0 */

/* Sets option o from its value val in args. Returns 0, or 2 after a
 * usage message. */
static int set_value(const Command *c, const Opt *o, const char *val, char *args)
{
    void *dst = args + o->offset;
    if (o->kind == OPT_STRING) { /* no option takes an empty string: a path or a list */
        if (!*val)
            return cli_usage_error(c->name, "%s needs a value, not an empty string", o->name);
        *(const char **)dst = val;
        return 0;
    }
    if (o->kind == OPT_INT) {
        if (cli_parse_int(val, o->lo, o->hi, (int *)dst) != 0)
            return cli_usage_error(c->name, "%s needs a whole number from %d to %d, not '%s'", o->name, o->lo, o->hi,
                                   val);
        return 0;
    }
    char *end;
    errno = 0;
    double v = strtod(val, &end);
    if (o->hi > 0) { /* a range */
        if (errno || end == val || *end || !(v >= o->lo && v <= o->hi))
            return cli_usage_error(c->name, "%s needs a number from %d to %d, not '%s'", o->name, o->lo, o->hi, val);
    } else if (errno || end == val || *end || !(v > 0) || !isfinite(v))
        return cli_usage_error(c->name, "%s needs a positive number, not '%s'", o->name, val);
    *(double *)dst = v;
    return 0;
}

/* Parses argv against the command's options into args; other arguments
 * are positional, at most c->maxpos of them, and so is every argument
 * after "--" (a scene named -x.scn). Returns 0, HELP_SHOWN, or 2 after a
 * usage message. Options that take a value accept "--opt value" and
 * "--opt=value". */
static int parse_opts(const Command *c, int argc, char **argv, char *args, const char **pos, int *npos)
{
    *npos = 0;
    int options = 1; /* until "--": after it, every argument is positional */
    for (int i = 0; i < argc; i++) {
        const char *arg = argv[i];
        if (options && !strcmp(arg, "--")) {
            options = 0;
            continue;
        }
        if (options && (!strcmp(arg, "-h") || !strcmp(arg, "--help"))) {
            fputs(c->usage, stdout);
            return HELP_SHOWN;
        }
        if (!options || arg[0] != '-' || arg[1] == '\0') {
            if (*npos == c->maxpos)
                return cli_usage_error(c->name, "unexpected argument '%s'", arg);
            pos[(*npos)++] = arg;
            continue;
        }
        const char *eq = arg[1] == '-' ? strchr(arg, '=') : NULL;
        size_t len = eq ? (size_t)(eq - arg) : strlen(arg);
        const Opt *o = NULL;
        for (int k = 0; k < c->nopts && !o; k++)
            if ((strlen(c->opts[k].name) == len && !strncmp(arg, c->opts[k].name, len)) ||
                (c->opts[k].alias && !eq && !strcmp(arg, c->opts[k].alias)))
                o = &c->opts[k];
        if (!o)
            return cli_usage_error(c->name, "unknown option '%s'", arg);
        if (o->kind == OPT_FLAG) {
            if (eq)
                return cli_usage_error(c->name, "option '%s' takes no value", o->name);
            *(int *)(args + o->offset) = 1;
            continue;
        }
        const char *val = eq ? eq + 1 : NULL;
        if (!val) {
            if (i + 1 >= argc)
                return cli_usage_error(c->name, "option '%s' needs a value", arg);
            val = argv[++i];
        }
        int rc = set_value(c, o, val, args);
        if (rc)
            return rc;
    }
    return 0;
}

/* Runs command c on its arguments. */
static int run(const Command *c, int argc, char **argv)
{
    int npos;
    const char **pos = malloc(sizeof *pos * (size_t)(argc + 1));
    char *args = calloc(1, c->args_size);
    if (!args || !pos) {
        fprintf(stderr, "lancer: out of memory\n");
        free(args);
        free(pos);
        return 1;
    }
    if (c->defaults)
        c->defaults(args);
    int rc = parse_opts(c, argc, argv, args, pos, &npos);
    if (rc == 0)
        rc = c->run(args, pos, npos);
    else if (rc == HELP_SHOWN)
        rc = 0;
    free(args);
    free(pos);
    return rc;
}

/* The command line's command, run. Returns the exit status. */
static int dispatch(int argc, char **argv)
{
#ifdef __GLIBC__
    /* Keep the heap's free top for the next allocation: glibc gives it
     * back to the system past 128 KiB, so zlib's state, allocated and
     * freed for each chunk of an EXR, was faulted in afresh every time.
     * (This also fixes glibc's threshold for mapping a block on its own
     * at 128 KiB: raising that too kept more memory at the peak.) */
    mallopt(M_TRIM_THRESHOLD, 256 << 20);
#endif
    if (argc < 2) {
        fputs(usage_main, stderr);
        return 2;
    }
    const char *cmd = argv[1];
    const int version = !strcmp(cmd, "--version"), usage = !strcmp(cmd, "--help") || !strcmp(cmd, "-h");
    /* 'help' is a command too, and takes -h and --help as every command does */
    const int help = !strcmp(cmd, "help"),
              help_help = help && argc == 3 && (!strcmp(argv[2], "--help") || !strcmp(argv[2], "-h"));
    if ((version || usage) && argc > 2) {
        fprintf(stderr, "lancer: '%s' takes no arguments (see 'lancer --help')\n", cmd);
        return 2;
    }
    if (usage || (help && argc == 2) || help_help) {
        fputs(usage_main, stdout);
        return 0;
    }
    if (version) {
        printf("lancer %s\n", LANCER_VERSION);
        return 0;
    }
    if (help && argc > 3) {
        fprintf(stderr, "lancer: 'help' takes one command (see 'lancer --help')\n");
        return 2;
    }
    const char *name = help ? argv[2] : cmd;
    for (int i = 0; i < NCOMMANDS; i++) {
        if (strcmp(name, commands[i]->name) != 0)
            continue;
        if (help) {
            fputs(commands[i]->usage, stdout);
            return 0;
        }
        return run(commands[i], argc - 2, argv + 2);
    }
    fprintf(stderr, "lancer: unknown command '%s' (see 'lancer --help')\n", name);
    return 2;
}

int main(int argc, char **argv)
{
    /* A closed pipe fails the write, reported below, rather than killing
     * lancer without a word. */
    signal(SIGPIPE, SIG_IGN);
    int rc = dispatch(argc, argv);
    /* What a command printed on stdout is its answer (diff's figures,
     * --explain's plan): lost to a full disk or a closed pipe, the run
     * failed, though the command found nothing wrong. */
    errno = 0;
    if ((fflush(stdout) != 0 || ferror(stdout)) && rc == 0) {
        fprintf(stderr, "lancer: cannot write the standard output%s%s\n", errno ? ": " : "",
                errno ? strerror(errno) : "");
        rc = 1;
    }
    return rc;
}
