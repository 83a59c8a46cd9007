/*
 * thread.c - starting a thread that runs at once, and a pool of them (thread.h).
 */
#if defined(__linux__)
#define _GNU_SOURCE /* pthread_attr_setaffinity_np, sched_getcpu */
#endif
#include "lancer/thread.h"

#include <sched.h>
#include <stdlib.h>

#if defined(__linux__) && defined(__GLIBC__) && defined(CPU_COUNT)
typedef struct {
    void *(*fn)(void *);
    void *arg;
    cpu_set_t cpus; /* the caller's */
} Start;

static void *start_placed(void *arg)
{
    Start s = *(Start *)arg;
    free(arg);
    pthread_setaffinity_np(pthread_self(), sizeof s.cpus, &s.cpus);
    return s.fn(s.arg);
}

/* A new thread on the caller's processors but its own, or -1 when there
 * are no others (or no memory): the caller starts it as usual. */
static int start_away(pthread_t *t, void *(*fn)(void *), void *arg)
{
    int self = sched_getcpu();
    if (self < 0 || self >= CPU_SETSIZE)
        return -1;
    Start *s = malloc(sizeof *s);
    if (!s)
        return -1;
    s->fn = fn;
    s->arg = arg;
    pthread_attr_t attr;
    int rc = -1;
    if (pthread_getaffinity_np(pthread_self(), sizeof s->cpus, &s->cpus) == 0) {
        cpu_set_t away = s->cpus;
        CPU_CLR(self, &away);
        if (CPU_COUNT(&away) > 0 && pthread_attr_init(&attr) == 0) {
            if (pthread_attr_setaffinity_np(&attr, sizeof away, &away) == 0 &&
                pthread_create(t, &attr, start_placed, s) == 0)
                rc = 0;
            pthread_attr_destroy(&attr);
        }
    }
    if (rc != 0)
        free(s);
    return rc;
}
#endif

int thread_start(pthread_t *t, void *(*fn)(void *), void *arg)
{
#if defined(__linux__) && defined(__GLIBC__) && defined(CPU_COUNT)
    if (start_away(t, fn, arg) == 0)
        return 0;
#endif
    return pthread_create(t, NULL, fn, arg);
}

struct ThreadPool {
    pthread_mutex_t lock;
    pthread_cond_t go, done;
    /* written under the lock, and read without it by the spins below */
    unsigned job;     /* counts the jobs begun (and the end); a worker waits for the next */
    unsigned pending; /* the workers not yet finished with the current job */
    int ended;        /* the current or a past job was the workers' last (pool_run_last) */
    void (*fn)(void *);
    void *arg;
    int nworkers;
    pthread_t *tids;
};

/* How many times a thread looks for its next job, or the workers' end, before
 * it sleeps: a render's passes follow each other within microseconds, sooner
 * than a sleeping thread wakes on a virtual machine. */
#define POOL_SPIN 4096

#ifdef __GNUC__
#define POOL_LOAD(x) __atomic_load_n(&(x), __ATOMIC_ACQUIRE)
#define POOL_STORE(x, v) __atomic_store_n(&(x), (v), __ATOMIC_RELEASE)
#else
#define POOL_LOAD(x) (x)
#define POOL_STORE(x, v) ((x) = (v))
#endif

/* Waits, awake and for a bounded while, as long as (*w == v) == same
 * (without the atomics, it does not wait: the caller sleeps on the lock at
 * once). */
static void spin_while(const unsigned *w, unsigned v, int same)
{
#ifdef __GNUC__
    for (int i = 0; i < POOL_SPIN && (POOL_LOAD(*w) == v) == same; i++) {
#if defined(__x86_64__) || defined(__i386__)
        __builtin_ia32_pause();
#endif
    }
#else
    (void)w;
    (void)v;
    (void)same;
#endif
}

static void *pool_worker(void *arg)
{
    ThreadPool *p = arg;
    unsigned seen = 0;
    pthread_mutex_lock(&p->lock);
    for (;;) {
        if (p->job == seen) {
            pthread_mutex_unlock(&p->lock);
            spin_while(&p->job, seen, 1);
            pthread_mutex_lock(&p->lock);
            while (p->job == seen)
                pthread_cond_wait(&p->go, &p->lock);
        }
        seen = p->job;
        void (*fn)(void *) = p->fn;
        void *fa = p->arg;
        const int last = p->ended;
        if (!fn) /* pool_free's end */
            break;
        pthread_mutex_unlock(&p->lock);
        fn(fa);
        pthread_mutex_lock(&p->lock);
        POOL_STORE(p->pending, p->pending - 1);
        if (p->pending == 0)
            pthread_cond_signal(&p->done);
        if (last) /* p is not touched after the unlock below */
            break;
    }
    pthread_mutex_unlock(&p->lock);
    return NULL;
}

ThreadPool *pool_new(int threads)
{
    int want = threads > 1 ? threads - 1 : 0;
    ThreadPool *p = calloc(1, sizeof *p);
    if (!p)
        return NULL;
    if (want && !(p->tids = malloc(sizeof *p->tids * (size_t)want)))
        goto fail;
    if (pthread_mutex_init(&p->lock, NULL) != 0)
        goto fail;
    if (pthread_cond_init(&p->go, NULL) != 0) {
        pthread_mutex_destroy(&p->lock);
        goto fail;
    }
    if (pthread_cond_init(&p->done, NULL) != 0) {
        pthread_cond_destroy(&p->go);
        pthread_mutex_destroy(&p->lock);
        goto fail;
    }
    while (p->nworkers < want && thread_start(&p->tids[p->nworkers], pool_worker, p) == 0)
        p->nworkers++;
    return p;
fail:
    free(p->tids);
    free(p);
    return NULL;
}

int pool_threads(const ThreadPool *p) { return p->nworkers + 1; }

/* fn(arg) on every thread; with last, the workers end after it. */
static void run(ThreadPool *p, void (*fn)(void *), void *arg, int last)
{
    const int workers = p->ended ? 0 : p->nworkers; /* (after the last job, the caller alone) */
    if (workers > 0) {
        pthread_mutex_lock(&p->lock);
        p->fn = fn;
        p->arg = arg;
        p->ended = last;
        POOL_STORE(p->pending, (unsigned)workers);
        POOL_STORE(p->job, p->job + 1);
        pthread_cond_broadcast(&p->go);
        pthread_mutex_unlock(&p->lock);
    }
    fn(arg);
    if (workers > 0) {
        spin_while(&p->pending, 0, 0);
        /* Past this lock every worker has let go of it after its count,
         * and one that had its last job touches p no more. */
        pthread_mutex_lock(&p->lock);
        while (p->pending > 0)
            pthread_cond_wait(&p->done, &p->lock);
        pthread_mutex_unlock(&p->lock);
    }
}

void pool_run(ThreadPool *p, void (*fn)(void *), void *arg) { run(p, fn, arg, 0); }

void pool_run_last(ThreadPool *p, void (*fn)(void *), void *arg) { run(p, fn, arg, 1); }

void pool_free(ThreadPool *p)
{
    if (!p)
        return;
    const int ended = p->ended;
    if (!ended) { /* the workers wait for a job: none comes */
        pthread_mutex_lock(&p->lock);
        p->fn = NULL;
        POOL_STORE(p->job, p->job + 1);
        pthread_cond_broadcast(&p->go);
        pthread_mutex_unlock(&p->lock);
    }
    /* Workers past their last job are let go, not waited for: they touch
     * the pool no more (run), and waiting for a thread's end means waiting
     * for its processor to wake, which on a virtual machine can take as
     * long as a frame's last rows. */
    for (int i = 0; i < p->nworkers; i++)
        if (ended)
            pthread_detach(p->tids[i]);
        else
            pthread_join(p->tids[i], NULL);
    pthread_cond_destroy(&p->done);
    pthread_cond_destroy(&p->go);
    pthread_mutex_destroy(&p->lock);
    free(p->tids);
    free(p);
}
