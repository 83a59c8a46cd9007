/* Tests for thread.c: a started thread runs its function, and runs on the
 * caller's whole set of processors, however it was started; a caller
 * pinned to one processor keeps its threads there. A pool runs each job
 * once on each of its threads, and the job is done when pool_run returns. */
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

/* What the pool's threads saw of one job. */
typedef struct {
    pthread_mutex_t lock;
    int calls;
    pthread_t ids[8];
    int nids; /* the distinct threads that ran it */
} Tally;

static void tally(void *arg)
{
    Tally *t = arg;
    pthread_mutex_lock(&t->lock);
    t->calls++;
    int seen = 0;
    for (int i = 0; i < t->nids; i++)
        seen |= pthread_equal(t->ids[i], pthread_self());
    if (!seen && t->nids < 8)
        t->ids[t->nids++] = pthread_self();
    pthread_mutex_unlock(&t->lock);
}

/* Runs one job on p: returns how many calls it saw, and checks that each
 * was on a thread of its own, the caller's among them. */
static int run_tally_as(ThreadPool *p, void (*run)(ThreadPool *, void (*)(void *), void *))
{
    Tally t;
    memset(&t, 0, sizeof t);
    assert_int_equal(pthread_mutex_init(&t.lock, NULL), 0);
    run(p, tally, &t);
    pthread_mutex_destroy(&t.lock);
    assert_int_equal(t.nids, t.calls);
    int caller = 0;
    for (int i = 0; i < t.nids; i++)
        caller |= pthread_equal(t.ids[i], pthread_self());
    assert_true(caller);
    return t.calls;
}

static int run_tally(ThreadPool *p) { return run_tally_as(p, pool_run); }

/* Job after job, each runs once on each of the pool's threads and has
 * ended when pool_run returns; a pool of one thread, or of none, runs the
 * job on the caller. */
static void test_pool_runs_each_job_on_its_threads(void **state)
{
    (void)state;
    for (int threads = -1; threads <= 4; threads++) {
        ThreadPool *p = pool_new(threads);
        assert_non_null(p);
        int n = pool_threads(p);
        assert_int_equal(n, threads > 1 ? threads : 1);
        for (int i = 0; i < 50; i++)
            assert_int_equal(run_tally(p), n);
        pool_free(p);
    }
    pool_free(NULL);
}

/* The last job runs on every thread, as the others did; after it the
 * workers are gone, a job runs on the caller alone, and pool_free lets
 * them go without waiting (a render's last pass). Pools that end so, one
 * after another, leave no thread behind that touches a freed pool (which
 * AddressSanitizer would report). */
static void test_pool_last_job(void **state)
{
    (void)state;
    for (int round = 0; round < 20; round++)
        for (int threads = 1; threads <= 4; threads++) {
            ThreadPool *p = pool_new(threads);
            assert_non_null(p);
            const int n = pool_threads(p);
            assert_int_equal(run_tally(p), n);
            assert_int_equal(run_tally_as(p, pool_run_last), n);
            if (round & 1)
                assert_int_equal(run_tally(p), 1);
            pool_free(p);
        }
}

/* A job's writes are all seen when pool_run returns: each thread adds to
 * its own counter, many times, in job after job. */
typedef struct {
    pthread_mutex_t lock;
    int next;
    long sum[4];
} Sums;

static void add_many(void *arg)
{
    Sums *s = arg;
    pthread_mutex_lock(&s->lock);
    int k = s->next++;
    pthread_mutex_unlock(&s->lock);
    for (int i = 0; i < 1000; i++)
        s->sum[k] += i;
}

static void test_pool_job_is_done_when_run_returns(void **state)
{
    (void)state;
    ThreadPool *p = pool_new(2);
    assert_non_null(p);
    int n = pool_threads(p);
    Sums s;
    memset(&s, 0, sizeof s);
    assert_int_equal(pthread_mutex_init(&s.lock, NULL), 0);
    for (int job = 1; job <= 500; job++) {
        s.next = 0;
        pool_run(p, add_many, &s);
        assert_int_equal(s.next, n);
        for (int k = 0; k < n; k++)
            assert_int_equal(s.sum[k], 499500L * job);
    }
    pthread_mutex_destroy(&s.lock);
    pool_free(p);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_thread_runs_its_function),
        cmocka_unit_test(test_thread_keeps_the_callers_processors),
        cmocka_unit_test(test_pool_runs_each_job_on_its_threads),
        cmocka_unit_test(test_pool_job_is_done_when_run_returns),
        cmocka_unit_test(test_pool_last_job),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
