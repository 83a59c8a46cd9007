/* Tests for afile.c: atomic replacement, clean failure, whole-file reads. */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
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

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup_teardown(test_replace_and_abort, setup, teardown),
        cmocka_unit_test_setup_teardown(test_writability_and_errors, setup, teardown),
        cmocka_unit_test_setup_teardown(test_read_limits, setup, teardown),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
