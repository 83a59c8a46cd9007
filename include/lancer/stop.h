/*
 * stop.h - a render's stop flag: set by a signal handler, which runs on
 * whichever thread the signal finds, and read by every render thread.
 * volatile sig_atomic_t is only safe between a handler and the thread it
 * interrupts; across threads the flag is read and written atomically, as
 * a lock-free int, which a handler may also do.
 */
#ifndef LANCER_STOP_H
#define LANCER_STOP_H

#include <signal.h>

/* The flag's value; 0 for NULL (no flag). */
static inline int stop_read(const volatile sig_atomic_t *flag)
{
    if (!flag)
        return 0;
#ifdef __GNUC__
    return __atomic_load_n(flag, __ATOMIC_RELAXED);
#else
    return *flag;
#endif
}

static inline void stop_set(volatile sig_atomic_t *flag, int value)
{
#ifdef __GNUC__
    __atomic_store_n(flag, value, __ATOMIC_RELAXED);
#else
    *flag = value;
#endif
}

#endif
