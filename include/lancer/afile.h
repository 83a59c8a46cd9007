/*
 * afile.h - whole files: replaced atomically (written beside the target,
 * then renamed), and read in one piece with a size limit.
 *
 *     char tmp[AFILE_PATH_MAX];
 *     if (afile_temp(path, tmp, sizeof tmp, err, errlen) != 0) return -1;
 *     ... write everything to tmp, on failure afile_abort(tmp) ...
 *     return afile_commit(tmp, path, err, errlen);
 *
 * The user's file at `path` is never touched until the new one is complete,
 * and a failed write never leaves a truncated file behind. rename(2) within
 * one directory is atomic on POSIX file systems, which is why the temporary
 * file lives in the target's own directory. A path that is a symbolic link
 * has its target replaced, as editors do, and the link is kept. Temporary
 * files are named "<target>.lancer-tmp.<pid>.XXXXXX"; those of a process
 * that no longer runs (a killed render) are removed by the next write to
 * the same target.
 *
 * Several outputs of one run are committed together, or none of them:
 *
 *     AfileSet set;
 *     afile_set_init(&set);
 *     const char *a = afile_set_add(&set, "out.exr", err, errlen);
 *     const char *b = afile_set_add(&set, "out.png", err, errlen);
 *     ... write into a and b; on failure afile_set_abort(&set) ...
 *     afile_set_commit(&set, err, errlen);
 */
#ifndef LANCER_AFILE_H
#define LANCER_AFILE_H

#include <stddef.h>
#include <stdio.h>

#define AFILE_PATH_MAX 4096
/* Outputs in one set, at most. */
#define AFILE_SET_MAX 8

/* Creates an empty, uniquely named file beside `path` (beside its target,
 * when path is a symbolic link) and writes its name to tmp. Returns 0, or
 * -1 with a message in err (tmp is then not created). */
int afile_temp(const char *path, char *tmp, size_t tmplen, char *err, size_t errlen);

/* Renames tmp over path. Returns 0, or -1 with a message in err; on failure
 * tmp is removed so that nothing is left behind. */
int afile_commit(const char *tmp, const char *path, char *err, size_t errlen);

/* Removes tmp after a failed write. */
void afile_abort(const char *tmp);

/* Text files through stdio: afile_temp plus fopen. Returns the stream, or
 * NULL with a message in err. */
FILE *afile_fopen(const char *path, char *tmp, size_t tmplen, char *err, size_t errlen);

/* Closes f and commits tmp over path if every write to f succeeded;
 * otherwise removes tmp. Returns 0 or -1 with a message in err. */
int afile_fclose(FILE *f, const char *tmp, const char *path, char *err, size_t errlen);

/* Opens path for reading if it is a regular file of at most max_bytes, and
 * refuses anything else before reading a byte: a FIFO (which would block),
 * a device such as /dev/zero (which never ends), a directory; `what` names
 * the kind of file in the message ("meshes"). Returns the descriptor, with
 * the file's size in *size, or -1 with "path: message". */
int afile_open_read(const char *path, unsigned long long max_bytes, const char *what, unsigned long long *size,
                    char *err, size_t errlen);

/* Reads the whole file at path, opened as afile_open_read does, into a new
 * buffer the caller frees (*out, *outlen). Returns 0, or -1 with "path:
 * message". */
int afile_read(const char *path, unsigned long long max_bytes, const char *what, char **out, size_t *outlen, char *err,
               size_t errlen);

/* Checks, without touching path, that a file could be written there: path is
 * not a directory, a device, a FIFO or a socket, and its directory accepts
 * new files. Returns 0 or -1 with a message in err. */
int afile_check_writable(const char *path, char *err, size_t errlen);

/* The file path names, its symbolic links followed (a dangling one to the
 * file it would create). Returns 0, or -1 with a message in err. */
int afile_resolve(const char *path, char *out, size_t outlen, char *err, size_t errlen);

/* 1 when a and b name the same file: the same device and inode, or, when
 * neither exists yet, the same name in the same directory; links followed. */
int afile_same(const char *a, const char *b);

/* Removes the temporary files beside path that processes no longer running
 * left behind. */
void afile_clean_stale(const char *path);

typedef struct {
    char path[AFILE_PATH_MAX];   /* as given, for messages */
    char target[AFILE_PATH_MAX]; /* its links followed */
    char tmp[AFILE_PATH_MAX];
    char backup[AFILE_PATH_MAX];
} AfileEntry;

typedef struct {
    int n;
    AfileEntry e[AFILE_SET_MAX];
} AfileSet;

void afile_set_init(AfileSet *s);

/* Adds an output: creates its temporary file and returns its name, into
 * which the caller writes; or NULL with a message in err. */
const char *afile_set_add(AfileSet *s, const char *path, char *err, size_t errlen);

/* Puts every output in place, or, when one cannot be, none: the old files
 * are put back. The temporary files are gone either way. Returns 0, or -1
 * with a message in err. */
int afile_set_commit(AfileSet *s, char *err, size_t errlen);

/* Removes every temporary file of the set. Only unlink(2) and memory: safe
 * in a signal handler. */
void afile_set_abort(AfileSet *s);

#endif
