/*
 * thread.h - starting a thread that runs at once.
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

#endif
