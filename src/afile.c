/*
 * afile.c - whole files: replaced atomically, read in one piece (see afile.h
 * for the contract).
 *
 * A temporary file is named "<target>.lancer-tmp.<pid>.XXXXXX" (the
 * target's name cut where it would not fit), beside the target, so that
 * rename(2) can put it in place atomically, and so that a later run can
 * tell the leftovers of a killed one (their process is gone) from the
 * files of a run still going, and remove them.
 */
#include "lancer/afile.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "bigmem.h"

#define AFILE_TMP_TAG ".lancer-tmp."
/* The longest file name (NAME_MAX on Linux), and the room a temporary
 * name takes beyond its target's: the tag, a pid (at most 10 digits),
 * ".XXXXXX" and a set's ".bak". A longer target's name is cut in its
 * temporary's (tmp_stem). */
#define AFILE_NAME_MAX 255
#define AFILE_TMP_EXTRA ((int)sizeof AFILE_TMP_TAG - 1 + 10 + 7 + 4)

/* How much of a target's file name base its temporary names repeat. */
static int tmp_stem(const char *base)
{
    const size_t n = strlen(base);
    return n > AFILE_NAME_MAX - AFILE_TMP_EXTRA ? AFILE_NAME_MAX - AFILE_TMP_EXTRA : (int)n;
}

/* Symbolic links followed to their target, at most (as the kernel's
 * ELOOP limit). */
#define AFILE_LINKS_MAX 40

int afile_resolve(const char *path, char *out, size_t outlen, char *err, size_t errlen)
{
    char cur[AFILE_PATH_MAX], link[AFILE_PATH_MAX];
    if (snprintf(cur, sizeof cur, "%s", path) >= (int)sizeof cur || strlen(path) >= outlen) {
        snprintf(err, errlen, "%s: path is too long", path);
        return -1;
    }
    for (int hops = 0;; hops++) {
        struct stat st;
        if (lstat(cur, &st) != 0 || !S_ISLNK(st.st_mode))
            break; /* missing, or not a link: the target itself */
        if (hops == AFILE_LINKS_MAX) {
            snprintf(err, errlen, "%s: too many levels of symbolic links", path);
            return -1;
        }
        ssize_t n = readlink(cur, link, sizeof link - 1);
        if (n < 0) {
            snprintf(err, errlen, "%s: cannot follow the link: %s", path, strerror(errno));
            return -1;
        }
        link[n] = '\0';
        const char *slash = strrchr(cur, '/');
        int w;
        if (link[0] == '/' || !slash) /* absolute, or relative to a link in "." */
            w = snprintf(out, outlen, "%s", link);
        else
            w = snprintf(out, outlen, "%.*s/%s", (int)(slash - cur), cur, link);
        if (w < 0 || (size_t)w >= outlen || (size_t)w >= sizeof cur) {
            snprintf(err, errlen, "%s: path is too long", path);
            return -1;
        }
        memcpy(cur, out, (size_t)w + 1);
    }
    snprintf(out, outlen, "%s", cur);
    return 0;
}

/* The folder of path ("." for none) into dir, and its last part. */
static const char *split_path(const char *path, char *dir, size_t dirlen)
{
    const char *slash = strrchr(path, '/');
    if (!slash) {
        snprintf(dir, dirlen, ".");
        return path;
    }
    if (slash == path)
        snprintf(dir, dirlen, "/");
    else
        snprintf(dir, dirlen, "%.*s", (int)(slash - path), path);
    return slash + 1;
}

void afile_clean_stale(const char *path)
{
    char dir[AFILE_PATH_MAX], prefix[AFILE_PATH_MAX], full[AFILE_PATH_MAX];
    const char *base = split_path(path, dir, sizeof dir);
    int np = snprintf(prefix, sizeof prefix, "%.*s" AFILE_TMP_TAG, tmp_stem(base), base);
    if (np < 0 || (size_t)np >= sizeof prefix)
        return;
    DIR *d = opendir(dir);
    if (!d)
        return;
    struct dirent *e;
    while ((e = readdir(d)) != NULL) {
        if (strncmp(e->d_name, prefix, (size_t)np) != 0)
            continue;
        char *end;
        long pid = strtol(e->d_name + np, &end, 10);
        if (end == e->d_name + np || *end != '.' || pid <= 0)
            continue;
        /* Only a dead process's: a run still writing keeps its files. */
        if (pid == (long)getpid() || kill((pid_t)pid, 0) == 0 || errno != ESRCH)
            continue;
        if (snprintf(full, sizeof full, "%s/%s", dir, e->d_name) < (int)sizeof full)
            unlink(full);
    }
    closedir(d);
}

int afile_temp(const char *path, char *tmp, size_t tmplen, char *err, size_t errlen)
{
    char target[AFILE_PATH_MAX];
    if (afile_resolve(path, target, sizeof target, err, errlen) != 0)
        return -1;
    afile_clean_stale(target);
    char dir[AFILE_PATH_MAX];
    const char *base = split_path(target, dir, sizeof dir);
    int n = snprintf(tmp, tmplen, "%.*s" AFILE_TMP_TAG "%ld.XXXXXX", (int)(base - target) + tmp_stem(base), target,
                     (long)getpid());
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
        unlink(tmp);
        return -1;
    }
    close(fd);
    return 0;
}

/* Flushes tmp to disk: before a rename makes it the user's file, so that a
 * crash cannot leave a complete-looking name over incomplete contents. */
static int flush_file(const char *tmp, const char *path, char *err, size_t errlen)
{
    int fd = open(tmp, O_RDONLY | O_CLOEXEC);
    if (fd < 0 || fsync(fd) != 0) {
        snprintf(err, errlen, "%s: cannot flush to disk: %s", path, strerror(errno));
        if (fd >= 0)
            close(fd);
        return -1;
    }
    close(fd);
    return 0;
}

int afile_commit(const char *tmp, const char *path, char *err, size_t errlen)
{
    char target[AFILE_PATH_MAX];
    if (afile_resolve(path, target, sizeof target, err, errlen) != 0 || flush_file(tmp, path, err, errlen) != 0) {
        unlink(tmp);
        return -1;
    }
    if (rename(tmp, target) != 0) {
        snprintf(err, errlen, "%s: cannot replace file: %s", path, strerror(errno));
        unlink(tmp);
        return -1;
    }
    return 0;
}

void afile_abort(const char *tmp) { unlink(tmp); }

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
    char target[AFILE_PATH_MAX];
    if (afile_resolve(path, target, sizeof target, err, errlen) != 0)
        return -1;
    struct stat st;
    if (stat(target, &st) == 0 && !S_ISREG(st.st_mode)) {
        /* Replacing a device or a FIFO with a regular file would break it
         * (as root, -o /dev/null would replace /dev/null). */
        snprintf(err, errlen, "%s: %s", path,
                 S_ISDIR(st.st_mode) ? "is a directory"
                                     : "not a regular file (a device, FIFO or socket), which lancer does not replace");
        return -1;
    }
    /* The temporary file's name is cut to fit (tmp_stem), so the name
     * itself is measured: a render would run to its end and then fail. */
    char dir[AFILE_PATH_MAX];
    const char *base = split_path(target, dir, sizeof dir);
    long most = pathconf(dir, _PC_NAME_MAX);
    if (most <= 0)
        most = AFILE_NAME_MAX;
    if (strlen(base) > (size_t)most) {
        snprintf(err, errlen, "%s: the file name is %zu bytes long, more than the %ld its folder allows", path,
                 strlen(base), most);
        return -1;
    }
    char tmp[AFILE_PATH_MAX];
    if (afile_temp(path, tmp, sizeof tmp, err, errlen) != 0)
        return -1;
    afile_abort(tmp);
    return 0;
}

int afile_same(const char *a, const char *b)
{
    char ra[AFILE_PATH_MAX], rb[AFILE_PATH_MAX], err[8];
    if (afile_resolve(a, ra, sizeof ra, err, sizeof err) != 0 || afile_resolve(b, rb, sizeof rb, err, sizeof err) != 0)
        return strcmp(a, b) == 0;
    struct stat sa, sb;
    int ea = stat(ra, &sa) == 0, eb = stat(rb, &sb) == 0;
    if (ea && eb)
        return sa.st_dev == sb.st_dev && sa.st_ino == sb.st_ino;
    if (ea || eb)
        return 0;
    /* Neither exists yet: the same name in the same folder. */
    char da[AFILE_PATH_MAX], db[AFILE_PATH_MAX];
    const char *na = split_path(ra, da, sizeof da), *nb = split_path(rb, db, sizeof db);
    return strcmp(na, nb) == 0 && stat(da, &sa) == 0 && stat(db, &sb) == 0 && sa.st_dev == sb.st_dev &&
           sa.st_ino == sb.st_ino;
}

/* ---- sets of outputs, committed together ---- */

void afile_set_init(AfileSet *s) { memset(s, 0, sizeof *s); }

const char *afile_set_add(AfileSet *s, const char *path, char *err, size_t errlen)
{
    if (s->n == AFILE_SET_MAX) {
        snprintf(err, errlen, "%s: too many outputs", path);
        return NULL;
    }
    AfileEntry *e = &s->e[s->n];
    if (afile_resolve(path, e->target, sizeof e->target, err, errlen) != 0 ||
        afile_temp(e->target, e->tmp, sizeof e->tmp, err, errlen) != 0)
        return NULL;
    snprintf(e->path, sizeof e->path, "%s", path);
    e->backup[0] = '\0';
    s->n++;
    return e->tmp;
}

void afile_set_abort(AfileSet *s)
{
    for (int i = 0; i < s->n; i++)
        unlink(s->e[i].tmp);
    s->n = 0;
}

int afile_set_commit(AfileSet *s, char *err, size_t errlen)
{
    for (int i = 0; i < s->n; i++)
        if (flush_file(s->e[i].tmp, s->e[i].path, err, errlen) != 0) {
            afile_set_abort(s);
            return -1;
        }
    /* Each old file is kept under a second name until every new one is in
     * place, so that a rename failing half way can put the old ones back:
     * the outputs of one run are all new, or all as they were. */
    int done = 0, rc = 0;
    for (; done < s->n && rc == 0; done++) {
        AfileEntry *e = &s->e[done];
        size_t n = strlen(e->tmp);
        if (n + 5 > sizeof e->backup) {
            snprintf(err, errlen, "%s: path is too long", e->path);
            rc = -1;
            break;
        }
        memcpy(e->backup, e->tmp, n);
        memcpy(e->backup + n, ".bak", 5);
        if (link(e->target, e->backup) != 0) {
            if (errno != ENOENT) { /* ENOENT: no old file to keep */
                snprintf(err, errlen, "%s: cannot keep the old file: %s", e->path, strerror(errno));
                rc = -1;
                break;
            }
            e->backup[0] = '\0';
        }
        if (rename(e->tmp, e->target) != 0) {
            snprintf(err, errlen, "%s: cannot replace file: %s", e->path, strerror(errno));
            rc = -1;
            break;
        }
    }
    if (rc != 0) { /* entry `done` failed: undo the ones before it */
        for (int i = done - 1; i >= 0; i--) {
            AfileEntry *e = &s->e[i];
            if (e->backup[0] != '\0')
                rename(e->backup, e->target);
            else
                unlink(e->target);
        }
        if (s->e[done].backup[0] != '\0')
            unlink(s->e[done].backup);
    }
    for (int i = 0; i < s->n; i++) {
        if (rc == 0 && s->e[i].backup[0] != '\0')
            unlink(s->e[i].backup);
        if (rc != 0)
            unlink(s->e[i].tmp);
    }
    s->n = 0;
    return rc;
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
    char *buf = big_realloc(NULL, 0, cap); /* huge pages for a large file (bigmem.h) */
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
