/*
 * cli.h - the command line's shared parts: the command table that main.c
 * dispatches on, and the helpers every command uses. Only the command
 * line prints or exits; the library returns messages instead.
 *
 * A command describes its options as a table of Opt, each naming a field
 * of the command's own argument struct by its offset. main.c parses argv
 * against the table into a zeroed struct (after the command's defaults),
 * then calls run() with the struct and the positional arguments, so that
 * no command parses options itself.
 *
 * Exit status: 0 success, 1 an error in the input or while writing, 2 a
 * usage error.
 */
#ifndef LANCER_CLI_H
#define LANCER_CLI_H

#include <stddef.h>

#include "lancer/afile.h"

/* Room for a message that names two paths of the longest length. */
#define CLI_ERR_LEN (2 * AFILE_PATH_MAX + 512)

#define LANCER_VERSION "0.1.0"

typedef enum { OPT_FLAG, OPT_STRING, OPT_INT, OPT_DOUBLE } OptKind;

typedef struct {
    const char *name, *alias; /* "--output", "-o" */
    OptKind kind;
    size_t offset; /* of an int (flags, ints), a const char * or a double in the args */
    int lo, hi;    /* the range of an int; of a double when hi > 0, else any positive one */
} Opt;

typedef struct {
    const char *name;  /* "render" */
    const char *usage; /* the --help text */
    const Opt *opts;
    int nopts;
    int maxpos;       /* positional arguments, at most */
    size_t args_size; /* the command's argument struct */
    void (*defaults)(void *args); /* NULL: all zero */
    int (*run)(void *args, const char **pos, int npos);
} Command;

extern const Command cmd_render, cmd_tiles, cmd_merge, cmd_export_pov, cmd_diff, cmd_bench;

/* Prints "lancer CMD: message" and a pointer to --help; returns 2. */
int cli_usage_error(const char *cmd, const char *fmt, ...)
#ifdef __GNUC__
    __attribute__((format(printf, 2, 3)))
#endif
    ;

/* The default of --threads: the processors online, at most LIMIT_THREADS. */
int cli_default_threads(void);

/* The whole number s, if it is one from lo to hi: 0, else -1 (*out kept). */
int cli_parse_int(const char *s, int lo, int hi, int *out);

/* n whole numbers from 0 to INT_MAX, in decimal digits only, the i-th
 * followed by the separator seps[i] ("0:4,0:4" with seps ":,:"), into
 * out. Returns 0, or -1 when s is anything else or a number overflows. */
int cli_parse_ints(const char *s, const char *seps, int n, int *out);

/* "out/<basename of path without extension><ext>" into buf, creating out/.
 * Returns 0, or -1 after a message. */
int cli_default_output(const char *path, const char *ext, char *buf, size_t len);

/* Fills the frame pattern in path with frame into buf: "%d" and "%0Nd"
 * (N from 1 to 9) give the frame number, "%%" a percent sign. Sets *count
 * to how many numbers it put in (NULL: not wanted). Returns 0, or -1
 * after a message naming option (none when option is NULL) when the
 * pattern is another printf conversion or the path is too long. */
int cli_frame_path(const char *option, const char *path, int frame, char *buf, size_t len, int *count);

/* 0 when path (NULL: none) can be written, else -1 after a message. */
int cli_check_output(const char *path);

/* The image's size into *w and *h: width and height where set (not 0),
 * else the scene's sw and sh. Returns 0, or 1 after a message when it has
 * more pixels than lancer renders (as plan_build would refuse it). */
int cli_image_size(int width, int height, int sw, int sh, int *w, int *h);

/* A file a command writes: the option that names it ("--png"), its path
 * (NULL: not written this run), and for an image the extension of its
 * format (".png"; NULL for other files). */
typedef struct {
    const char *option, *path, *ext;
} CliOutput;

/* 0 when every output can be written (cli_check_output), names neither
 * one of the run's inputs nor another output, the same file by device and
 * inode or, for files yet to be made, by folder and name, and an image's
 * name does not end in another image format's extension (an EXR named
 * out.png); else -1 after a message. */
int cli_check_outputs(const CliOutput *out, int nout, const char *const *in, int nin);

#endif
