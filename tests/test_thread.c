/* Tests for thread.c: a started thread runs its function, and runs on the
 * caller's whole set of processors, however it was started; a caller
 * pinned to one processor keeps its threads there. */
#if defined(__linux__)
#define _GNU_SOURCE /* pthread_getaffinity_np, sched_getcpu */
#endif
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <string.h>
#include <cmocka.h>
#include <pthread.h>
#include <sched.h>

#include "lancer/thread.h"

typedef struct {
    int ran;
#if defined(__linux__) && defined(__GLIBC__) && defined(CPU_COUNT)
    cpu_set_t cpus; /* the thread's own, as it runs */
#endif
} Seen;

static void *look(void *arg)
{
    Seen *s = arg;
    s->ran = 1;
#if defined(__linux__) && defined(__GLIBC__) && defined(CPU_COUNT)
    if (pthread_getaffinity_np(pthread_self(), sizeof s->cpus, &s->cpus) != 0)
        s->ran = -1;
#endif
    return s;
}

static void test_thread_runs_its_function(void **state)
{
    (void)state;
    for (int i = 0; i < 8; i++) {
        Seen s;
        memset(&s, 0, sizeof s);
        pthread_t t;
        void *out = NULL;
        assert_int_equal(thread_start(&t, look, &s), 0);
        assert_int_equal(pthread_join(t, &out), 0);
        assert_ptr_equal(out, &s);
        assert_int_equal(s.ran, 1);
    }
}

#if defined(__linux__) && defined(__GLIBC__) && defined(CPU_COUNT)
/* The thread, started away from the caller's processor, takes back the
 * caller's set (it fails when the thread keeps the set it started on);
 * pinned to one processor, the caller's thread starts there. */
static void test_thread_keeps_the_callers_processors(void **state)
{
    (void)state;
    cpu_set_t all, one;
    assert_int_equal(pthread_getaffinity_np(pthread_self(), sizeof all, &all), 0);
    if (CPU_COUNT(&all) < 2)
        skip();
    for (int i = 0; i < 8; i++) {
        Seen s;
        memset(&s, 0, sizeof s);
        pthread_t t;
        assert_int_equal(thread_start(&t, look, &s), 0);
        assert_int_equal(pthread_join(t, NULL), 0);
        assert_int_equal(s.ran, 1);
        assert_true(CPU_EQUAL(&s.cpus, &all));
    }
    int self = sched_getcpu();
    assert_true(self >= 0);
    CPU_ZERO(&one);
    CPU_SET(self, &one);
    assert_int_equal(pthread_setaffinity_np(pthread_self(), sizeof one, &one), 0);
    Seen s;
    memset(&s, 0, sizeof s);
    pthread_t t;
    int rc = thread_start(&t, look, &s);
    if (rc == 0)
        pthread_join(t, NULL);
    assert_int_equal(pthread_setaffinity_np(pthread_self(), sizeof all, &all), 0);
    assert_int_equal(rc, 0);
    assert_int_equal(s.ran, 1);
    assert_true(CPU_EQUAL(&s.cpus, &one));
}
#else
static void test_thread_keeps_the_callers_processors(void **state)
{
    (void)state;
    skip();
}
#endif

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_thread_runs_its_function),
        cmocka_unit_test(test_thread_keeps_the_callers_processors),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
