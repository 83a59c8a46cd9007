/* Tests for afile.c: atomic replacement, clean failure, whole-file reads. */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <dirent.h>
#include <unistd.h>
#include <cmocka.h>

#include "lancer/afile.h"

static char dir[64];

static int setup(void **state)
{
    (void)state;
    snprintf(dir, sizeof dir, "/tmp/lancer-afile-XXXXXX");
    return mkdtemp(dir) ? 0 : -1;
}

static int teardown(void **state)
{
    (void)state;
    char cmd[128];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
    return system(cmd) == 0 ? 0 : -1;
}

/* Files in dir, not counting . and .. */
static int entries(void)
{
    DIR *d = opendir(dir);
    int n = 0;
    struct dirent *e;
    while ((e = readdir(d)) != NULL)
        n += e->d_name[0] != '.';
    closedir(d);
    return n;
}

static void test_replace_and_abort(void **state)
{
    (void)state;
    char path[128], tmp[AFILE_PATH_MAX], err[256];
    snprintf(path, sizeof path, "%s/out.txt", dir);
    FILE *f = afile_fopen(path, tmp, sizeof tmp, err, sizeof err);
    assert_non_null(f);
    fputs("first", f);
    assert_int_equal(entries(), 1); /* only the temporary so far */
    assert_int_equal(access(path, F_OK), -1);
    assert_int_equal(afile_fclose(f, tmp, path, err, sizeof err), 0);
    /* a second write that is abandoned leaves the first file alone */
    f = afile_fopen(path, tmp, sizeof tmp, err, sizeof err);
    assert_non_null(f);
    fputs("second", f);
    fclose(f);
    afile_abort(tmp);
    assert_int_equal(entries(), 1);
    char *buf;
    size_t len;
    assert_int_equal(afile_read(path, 1000, "texts", &buf, &len, err, sizeof err), 0);
    assert_int_equal(len, 5);
    assert_memory_equal(buf, "first", 5);
    free(buf);
}

static void test_writability_and_errors(void **state)
{
    (void)state;
    char path[128], err[256], want[256];
    assert_int_equal(afile_check_writable(dir, err, sizeof err), -1);
    snprintf(want, sizeof want, "%s: is a directory", dir);
    assert_string_equal(err, want);
    snprintf(path, sizeof path, "%s/no/such/dir/x", dir);
    assert_int_equal(afile_check_writable(path, err, sizeof err), -1);
    assert_non_null(strstr(err, "cannot create a file there"));
    snprintf(path, sizeof path, "%s/ok", dir);
    assert_int_equal(afile_check_writable(path, err, sizeof err), 0);
    assert_int_equal(entries(), 0); /* the check leaves nothing behind */
}

static void test_read_limits(void **state)
{
    (void)state;
    char path[128], err[256], want[256], *buf = NULL;
    size_t len;
    snprintf(path, sizeof path, "%s/big", dir);
    FILE *f = fopen(path, "w");
    for (int i = 0; i < 3 << 19; i++) /* 1.5 MiB */
        fputc('x', f);
    fclose(f);
    assert_int_equal(afile_read(path, 1 << 20, "things", &buf, &len, err, sizeof err), -1);
    snprintf(want, sizeof want, "%s: file of 1572864 bytes is larger than the 1 MiB limit for things", path);
    assert_string_equal(err, want);
    assert_int_equal(afile_read(dir, 1 << 20, "things", &buf, &len, err, sizeof err), -1);
    assert_non_null(strstr(err, "not a regular file (a directory)"));
    /* A FIFO would block its reader forever, and /dev/zero never ends:
     * both are refused before a byte is read. */
    snprintf(path, sizeof path, "%s/fifo", dir);
    assert_int_equal(mkfifo(path, 0600), 0);
    assert_int_equal(afile_read(path, 1 << 20, "things", &buf, &len, err, sizeof err), -1);
    assert_non_null(strstr(err, "not a regular file (a FIFO)"));
    remove(path);
    assert_int_equal(afile_read("/dev/zero", 1 << 20, "things", &buf, &len, err, sizeof err), -1);
    assert_string_equal(err, "/dev/zero: not a regular file (a device or socket)");
    snprintf(path, sizeof path, "%s/none", dir);
    assert_int_equal(afile_read(path, 1 << 20, "things", &buf, &len, err, sizeof err), -1);
    snprintf(want, sizeof want, "%s: cannot open: No such file or directory", path);
    assert_string_equal(err, want);
}

/* Writes text to path through afile, committing it. */
static void put(const char *path, const char *text)
{
    char tmp[AFILE_PATH_MAX], err[256];
    FILE *f = afile_fopen(path, tmp, sizeof tmp, err, sizeof err);
    assert_non_null(f);
    fputs(text, f);
    assert_int_equal(afile_fclose(f, tmp, path, err, sizeof err), 0);
}

/* Asserts that the file at path holds exactly text. */
static void assert_holds(const char *path, const char *text)
{
    char *buf, err[256];
    size_t len;
    assert_int_equal(afile_read(path, 1000, "texts", &buf, &len, err, sizeof err), 0);
    assert_int_equal(len, strlen(text));
    assert_memory_equal(buf, text, len);
    free(buf);
}

/* Devices and FIFOs are refused, never replaced by a regular file. */
static void test_devices_are_not_replaced(void **state)
{
    (void)state;
    char path[128], err[256];
    assert_int_equal(afile_check_writable("/dev/null", err, sizeof err), -1);
    assert_non_null(strstr(err, "not a regular file"));
    snprintf(path, sizeof path, "%s/fifo", dir);
    assert_int_equal(mkfifo(path, 0600), 0);
    assert_int_equal(afile_check_writable(path, err, sizeof err), -1);
    struct stat st;
    assert_int_equal(stat(path, &st), 0);
    assert_true(S_ISFIFO(st.st_mode));
    assert_int_equal(stat("/dev/null", &st), 0);
    assert_true(S_ISCHR(st.st_mode));
}

/* A symbolic link keeps being a link: its target is replaced, even through
 * a chain of relative links in another folder, and a dangling link gets
 * its target created. */
static void test_symlink_target_is_replaced(void **state)
{
    (void)state;
    char real[128], sub[128], link1[128], link2[128], dangling[128], made[128];
    snprintf(real, sizeof real, "%s/real.txt", dir);
    snprintf(sub, sizeof sub, "%s/sub", dir);
    snprintf(link1, sizeof link1, "%s/sub/one", dir);
    snprintf(link2, sizeof link2, "%s/two", dir);
    put(real, "old");
    assert_int_equal(mkdir(sub, 0700), 0);
    assert_int_equal(symlink("../real.txt", link1), 0);
    assert_int_equal(symlink("sub/one", link2), 0);
    put(link2, "new");
    struct stat st;
    assert_int_equal(lstat(link2, &st), 0);
    assert_true(S_ISLNK(st.st_mode));
    assert_int_equal(lstat(link1, &st), 0);
    assert_true(S_ISLNK(st.st_mode));
    assert_holds(real, "new");
    snprintf(dangling, sizeof dangling, "%s/dangling", dir);
    snprintf(made, sizeof made, "%s/made.txt", dir);
    assert_int_equal(symlink("made.txt", dangling), 0);
    put(dangling, "made");
    assert_holds(made, "made");
    assert_int_equal(entries(), 5); /* real, sub, two, dangling, made: no temporary left */
}

/* The pid of a process that has ended: a child, waited for. */
static pid_t dead_pid(void)
{
    pid_t child = fork();
    if (child == 0)
        _exit(0);
    assert_true(child > 0);
    assert_int_equal(waitpid(child, NULL, 0), child);
    return child;
}

/* The temporary files of a process that no longer runs are removed by the
 * next write to the same target; those of a running process, and files
 * that only look alike, are kept. */
static void test_stale_temporaries_removed(void **state)
{
    (void)state;
    const pid_t child = dead_pid();
    char dead[160], alive[160], other[160], odd[160], path[128];
    snprintf(path, sizeof path, "%s/out.exr", dir);
    snprintf(dead, sizeof dead, "%s/out.exr.lancer-tmp.%ld.AbC123", dir, (long)child);
    snprintf(alive, sizeof alive, "%s/out.exr.lancer-tmp.%ld.AbC123", dir, (long)getppid());
    snprintf(other, sizeof other, "%s/other.exr.lancer-tmp.%ld.AbC123", dir, (long)child);
    snprintf(odd, sizeof odd, "%s/out.exr.lancer-tmp.x%ld.AbC123", dir, (long)child);
    const char *files[] = {dead, alive, other, odd};
    for (int i = 0; i < 4; i++)
        put(files[i], "left");
    put(path, "new");
    assert_int_equal(access(dead, F_OK), -1);
    assert_int_equal(access(alive, F_OK), 0);
    assert_int_equal(access(other, F_OK), 0);
    assert_int_equal(access(odd, F_OK), 0);
    assert_int_equal(entries(), 4);
}

/* A file name of the longest length the system takes, 255 bytes, is
 * written: its temporary's name cuts it, where the tag and pid once made it
 * too long to create; and a dead run's temporary of that cut name is
 * removed as any other. */
static void test_longest_name(void **state)
{
    (void)state;
    const pid_t child = dead_pid();
    char name[256], path[AFILE_PATH_MAX], tmp[AFILE_PATH_MAX], err[AFILE_PATH_MAX + 128], dead[AFILE_PATH_MAX];
    memset(name, 'n', 255);
    name[255] = '\0';
    snprintf(path, sizeof path, "%s/%s", dir, name);
    FILE *f = afile_fopen(path, tmp, sizeof tmp, err, sizeof err);
    if (!f)
        fail_msg("%s", err);
    assert_true(strlen(strrchr(tmp, '/') + 1) <= 255);
    fputs("long", f);
    assert_int_equal(afile_fclose(f, tmp, path, err, sizeof err), 0);
    assert_int_equal(access(path, F_OK), 0);
    /* one byte more cannot be written: refused before any work */
    assert_int_equal(afile_check_writable(path, err, sizeof err), 0);
    char longer[AFILE_PATH_MAX];
    assert_true(snprintf(longer, sizeof longer, "%sn", path) < (int)sizeof longer);
    assert_int_equal(afile_check_writable(longer, err, sizeof err), -1);
    assert_non_null(strstr(err, "the file name is 256 bytes long"));
    /* the temporary's name as the dead run made it, the pid in its place */
    const char *tag = strstr(strrchr(tmp, '/'), ".lancer-tmp.");
    assert_non_null(tag);
    snprintf(dead, sizeof dead, "%.*s.lancer-tmp.%ld.AbC123", (int)(tag - tmp), tmp, (long)child);
    put(dead, "left");
    assert_int_equal(entries(), 2);
    put(path, "again");
    assert_int_equal(access(dead, F_OK), -1);
    assert_int_equal(entries(), 1);
    /* a set keeps the old file aside while it commits: that name fits too */
    AfileSet set;
    afile_set_init(&set);
    const char *t = afile_set_add(&set, path, err, sizeof err);
    if (!t)
        fail_msg("%s", err);
    FILE *g = fopen(t, "w");
    assert_non_null(g);
    fputs("set", g);
    fclose(g);
    if (afile_set_commit(&set, err, sizeof err) != 0)
        fail_msg("%s", err);
    assert_holds(path, "set");
    assert_int_equal(entries(), 1);
}

/* A set of outputs is committed whole: all new files, no leftovers; when
 * one cannot be put in place, the others are put back as they were. */
static void test_set_all_or_none(void **state)
{
    (void)state;
    char a[128], b[128], c[128], err[256];
    snprintf(a, sizeof a, "%s/a", dir);
    snprintf(b, sizeof b, "%s/b", dir);
    snprintf(c, sizeof c, "%s/c", dir);
    put(a, "old a");
    AfileSet set;
    afile_set_init(&set);
    const char *ta = afile_set_add(&set, a, err, sizeof err), *tb = afile_set_add(&set, b, err, sizeof err);
    assert_non_null(ta);
    assert_non_null(tb);
    FILE *f = fopen(ta, "w");
    fputs("new a", f);
    fclose(f);
    f = fopen(tb, "w");
    fputs("new b", f);
    fclose(f);
    assert_int_equal(afile_set_commit(&set, err, sizeof err), 0);
    assert_holds(a, "new a");
    assert_holds(b, "new b");
    assert_int_equal(entries(), 2);

    /* c is a folder that holds a file: its output cannot be put in place */
    assert_int_equal(mkdir(c, 0700), 0);
    char inside[160];
    snprintf(inside, sizeof inside, "%s/keep", c);
    put(inside, "x");
    afile_set_init(&set);
    const char *names[] = {a, b, c};
    for (int i = 0; i < 3; i++) {
        const char *t = afile_set_add(&set, names[i], err, sizeof err);
        assert_non_null(t);
        f = fopen(t, "w");
        fputs("newer", f);
        fclose(f);
    }
    assert_int_equal(afile_set_commit(&set, err, sizeof err), -1);
    assert_non_null(strstr(err, c));
    assert_holds(a, "new a");
    assert_holds(b, "new b");
    assert_int_equal(entries(), 3);

    /* an abandoned set leaves nothing */
    afile_set_init(&set);
    assert_non_null(afile_set_add(&set, a, err, sizeof err));
    assert_int_equal(entries(), 4);
    afile_set_abort(&set);
    assert_int_equal(entries(), 3);
    assert_holds(a, "new a");
}

/* afile_same compares files, not names: the same file under another
 * spelling, through a symbolic link or a hard link is the same; a file yet
 * to be made is the same as another spelling of its folder and name. */
static void test_same_file(void **state)
{
    (void)state;
    char a[128], a2[160], b[128], sym[128], hard[128], new1[128], new2[160];
    snprintf(a, sizeof a, "%s/a", dir);
    snprintf(a2, sizeof a2, "%s/./a", dir);
    snprintf(b, sizeof b, "%s/b", dir);
    snprintf(sym, sizeof sym, "%s/s", dir);
    snprintf(hard, sizeof hard, "%s/h", dir);
    snprintf(new1, sizeof new1, "%s/n", dir);
    snprintf(new2, sizeof new2, "%s/../%s/n", dir, strrchr(dir, '/') + 1);
    put(a, "a");
    put(b, "b");
    assert_int_equal(symlink("a", sym), 0);
    assert_int_equal(link(a, hard), 0);
    assert_true(afile_same(a, a2));
    assert_true(afile_same(a, sym));
    assert_true(afile_same(hard, sym));
    assert_false(afile_same(a, b));
    assert_true(afile_same(new1, new2));
    assert_false(afile_same(new1, a));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup_teardown(test_replace_and_abort, setup, teardown),
        cmocka_unit_test_setup_teardown(test_writability_and_errors, setup, teardown),
        cmocka_unit_test_setup_teardown(test_read_limits, setup, teardown),
        cmocka_unit_test_setup_teardown(test_devices_are_not_replaced, setup, teardown),
        cmocka_unit_test_setup_teardown(test_symlink_target_is_replaced, setup, teardown),
        cmocka_unit_test_setup_teardown(test_stale_temporaries_removed, setup, teardown),
        cmocka_unit_test_setup_teardown(test_longest_name, setup, teardown),
        cmocka_unit_test_setup_teardown(test_set_all_or_none, setup, teardown),
        cmocka_unit_test_setup_teardown(test_same_file, setup, teardown),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
