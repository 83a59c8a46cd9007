/*
 * thread.h - starting a thread that runs at once, and a pool of them.
 *
 *     pthread_t t;
 *     if (thread_start(&t, fn, arg) == 0) ... pthread_join(t, NULL) ...
 *     else fn(arg);   the caller does the work itself
 *
 * Linux may start a new thread on its creator's processor, and the creator
 * then waits until the scheduler moves one of them to an idle processor,
 * at its next tick: milliseconds, as long as a short frame's render. So
 * the thread starts on the processors the caller may use less the
 * caller's own, when there are others, and takes back the caller's whole
 * set as soon as it runs: no thread stays pinned. Elsewhere, and when
 * that cannot be set up, it starts as pthread_create starts it.
 */
#ifndef LANCER_THREAD_H
#define LANCER_THREAD_H

#include <pthread.h>

/* pthread_create(t, NULL, fn, arg), placed as above: 0, or its error. */
int thread_start(pthread_t *t, void *(*fn)(void *), void *arg);

/* Threads kept between jobs, so that a job does not wait for threads to
 * start and end: a render runs one job per pass, and adaptive
 * supersampling two per band of rows.
 *
 *     ThreadPool *pool = pool_new(4);      the caller and 3 workers
 *     pool_run(pool, fn, arg);             fn(arg) on each of the 4
 *     pool_run_last(pool, fn, arg);        again, the workers ending after it
 *     pool_free(pool);
 *
 * The workers are started with thread_start. Between jobs they look for
 * the next one for a bounded while, then sleep until it comes. */
typedef struct ThreadPool ThreadPool;

/* A pool of `threads` threads in all, the caller's among them: threads - 1
 * workers, or fewer when no more can be started. NULL when out of memory
 * (or the lock cannot be had). */
ThreadPool *pool_new(int threads);
/* The threads the pool runs a job on, the caller's included (1 or more). */
int pool_threads(const ThreadPool *p);
/* Runs fn(arg) on each of the pool's threads at once, the caller's among
 * them, and returns when every one has returned. */
void pool_run(ThreadPool *p, void (*fn)(void *), void *arg);
/* pool_run for the pool's last job: the workers end with it, so that
 * pool_free need not wait for them. A job after it runs on the caller
 * alone. */
void pool_run_last(ThreadPool *p, void (*fn)(void *), void *arg);
/* Ends the workers (between jobs) and frees the pool; NULL is ignored. */
void pool_free(ThreadPool *p);

#endif
