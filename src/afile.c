/*
 * afile.c - atomic file replacement (see afile.h for the contract).
 */
#include "lancer/afile.h"

#include <errno.h>
#include <stdint.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

int afile_temp(const char *path, char *tmp, size_t tmplen, char *err, size_t errlen)
{
    int n = snprintf(tmp, tmplen, "%s.tmp.XXXXXX", path);
    if (n < 0 || (size_t)n >= tmplen) {
        snprintf(err, errlen, "%s: path is too long", path);
        return -1;
    }
    int fd = mkstemp(tmp);
    if (fd < 0) {
        snprintf(err, errlen, "%s: cannot create a file there: %s", path, strerror(errno));
        return -1;
    }
    /* mkstemp creates the file 0600; give it the mode a plain fopen would
     * (0666 less the umask), since it will become the user's file. */
    mode_t mask = umask(0);
    umask(mask);
    if (fchmod(fd, 0666 & ~mask) != 0) {
        snprintf(err, errlen, "%s: cannot set permissions: %s", path, strerror(errno));
        close(fd);
        remove(tmp);
        return -1;
    }
    close(fd);
    return 0;
}

int afile_commit(const char *tmp, const char *path, char *err, size_t errlen)
{
    /* Flush the data before the rename makes it the user's file, so that a
     * crash cannot leave a complete-looking name over incomplete contents. */
    int fd = open(tmp, O_RDONLY);
    if (fd < 0 || fsync(fd) != 0) {
        snprintf(err, errlen, "%s: cannot flush to disk: %s", path, strerror(errno));
        if (fd >= 0)
            close(fd);
        remove(tmp);
        return -1;
    }
    close(fd);
    if (rename(tmp, path) != 0) {
        snprintf(err, errlen, "%s: cannot replace file: %s", path, strerror(errno));
        remove(tmp);
        return -1;
    }
    return 0;
}

void afile_abort(const char *tmp) { remove(tmp); }

FILE *afile_fopen(const char *path, char *tmp, size_t tmplen, char *err, size_t errlen)
{
    if (afile_temp(path, tmp, tmplen, err, errlen) != 0)
        return NULL;
    FILE *f = fopen(tmp, "w");
    if (!f) {
        snprintf(err, errlen, "%s: cannot write: %s", path, strerror(errno));
        afile_abort(tmp);
    }
    return f;
}

int afile_fclose(FILE *f, const char *tmp, const char *path, char *err, size_t errlen)
{
    int bad = ferror(f);
    int saved = errno;
    if (fclose(f) != 0 || bad) {
        snprintf(err, errlen, "%s: cannot write: %s", path, strerror(bad ? saved : errno));
        afile_abort(tmp);
        return -1;
    }
    return afile_commit(tmp, path, err, errlen);
}

int afile_check_writable(const char *path, char *err, size_t errlen)
{
    struct stat st;
    if (stat(path, &st) == 0 && S_ISDIR(st.st_mode)) {
        snprintf(err, errlen, "%s: is a directory", path);
        return -1;
    }
    char tmp[AFILE_PATH_MAX];
    if (afile_temp(path, tmp, sizeof tmp, err, errlen) != 0)
        return -1;
    afile_abort(tmp);
    return 0;
}

int afile_open_read(const char *path, unsigned long long max_bytes, const char *what, unsigned long long *size,
                    char *err, size_t errlen)
{
    /* O_NONBLOCK: opening a FIFO for reading would otherwise wait for a
     * writer, forever; the check below then refuses it. */
    int fd = open(path, O_RDONLY | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0) {
        snprintf(err, errlen, "%s: cannot open: %s", path, strerror(errno));
        return -1;
    }
    struct stat st;
    if (fstat(fd, &st) != 0) {
        snprintf(err, errlen, "%s: cannot open: %s", path, strerror(errno));
        close(fd);
        return -1;
    }
    if (!S_ISREG(st.st_mode)) {
        snprintf(err, errlen, "%s: not a regular file (%s)", path,
                 S_ISDIR(st.st_mode) ? "a directory" : S_ISFIFO(st.st_mode) ? "a FIFO" : "a device or socket");
        close(fd);
        return -1;
    }
    if ((unsigned long long)st.st_size > max_bytes) {
        snprintf(err, errlen, "%s: file of %lld bytes is larger than the %llu MiB limit for %s", path,
                 (long long)st.st_size, max_bytes >> 20, what);
        close(fd);
        return -1;
    }
    int flags = fcntl(fd, F_GETFL);
    if (flags >= 0)
        fcntl(fd, F_SETFL, flags & ~O_NONBLOCK);
    *size = (unsigned long long)st.st_size;
    return fd;
}

int afile_read(const char *path, unsigned long long max_bytes, const char *what, char **out, size_t *outlen, char *err,
               size_t errlen)
{
    const unsigned long long limit = max_bytes < SIZE_MAX / 2 ? max_bytes : SIZE_MAX / 2;
    unsigned long long size;
    int fd = afile_open_read(path, limit, what, &size, err, errlen);
    if (fd < 0)
        return -1;
    /* One byte more than the size: a file that grew since fstat shows it. */
    size_t cap = (size_t)size + 1, len = 0;
    char *buf = malloc(cap);
    if (!buf) {
        snprintf(err, errlen, "%s: out of memory reading %zu bytes", path, cap);
        close(fd);
        return -1;
    }
    int rc = 0;
    for (;;) {
        ssize_t n = read(fd, buf + len, cap - len);
        if (n < 0 && errno == EINTR)
            continue;
        if (n < 0) {
            snprintf(err, errlen, "%s: read error: %s", path, strerror(errno));
            rc = -1;
            break;
        }
        if (n == 0)
            break;
        len += (size_t)n;
        if (len == cap) { /* it grew while being read */
            snprintf(err, errlen, "%s: the file changed while it was read", path);
            rc = -1;
            break;
        }
    }
    close(fd);
    if (rc != 0) {
        free(buf);
        return -1;
    }
    *out = buf;
    *outlen = len;
    return 0;
}
