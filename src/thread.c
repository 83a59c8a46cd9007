/*
 * thread.c - starting a thread that runs at once (thread.h).
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
