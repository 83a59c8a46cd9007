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
 * file lives in the target's own directory.
 */
#ifndef LANCER_AFILE_H
#define LANCER_AFILE_H

#include <stddef.h>
#include <stdio.h>

#define AFILE_PATH_MAX 4096

/* Creates an empty, uniquely named file beside `path` and writes its name to
 * tmp. Returns 0, or -1 with a message in err (tmp is then not created). */
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
 * not a directory and its directory accepts new files. Returns 0 or -1. */
int afile_check_writable(const char *path, char *err, size_t errlen);

#endif
