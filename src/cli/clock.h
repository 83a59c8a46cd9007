/*
 * clock.h - seconds on a monotonic clock, for the command line's timings
 * and the benchmarks.
 */
#ifndef LANCER_CLI_CLOCK_H
#define LANCER_CLI_CLOCK_H

#include <time.h>

static inline double clock_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

#endif
