/*
 * fuzz.h - what the libFuzzer harnesses of tests/fuzz share.
 *
 * Each harness feeds one input to one reader and checks the library's
 * promises, not only that nothing crashes: an input that parses gives data
 * that passes the reader's validate function, and one that fails gives a
 * single line of message that names the input, and leaves nothing
 * allocated (LeakSanitizer, which libFuzzer runs after each input, and the
 * emptied result). A broken promise aborts, which libFuzzer reports as a
 * crash and saves the input.
 */
#ifndef LANCER_FUZZ_H
#define LANCER_FUZZ_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

/* The name the harnesses give their input, which messages must start with. */
#define FUZZ_NAME "fuzz.in"

static inline void fuzz_fail(const char *what, const char *detail)
{
    fprintf(stderr, "fuzz: broken promise: %s: %s\n", what, detail);
    abort();
}

static inline void fuzz_require(int ok, const char *what, const char *detail)
{
    if (!ok)
        fuzz_fail(what, detail);
}

/* A failure's message: one line, not empty, naming the input first, then
 * from lo to hi numbers from 1 ("fuzz.in:12:5: ...": a line and a column). */
static inline void fuzz_check_message(const char *err, int lo, int hi)
{
    const size_t n = strlen(FUZZ_NAME);
    fuzz_require(strchr(err, '\n') == NULL, "the message is more than one line", err);
    fuzz_require(strncmp(err, FUZZ_NAME ":", n + 1) == 0, "the message does not name the input first", err);
    const char *p = err + n + 1;
    int k = 0;
    for (; k < hi && *p >= '1' && *p <= '9'; k++) {
        while (*p >= '0' && *p <= '9')
            p++;
        fuzz_require(*p == ':', "a number in the message's place is not followed by ':'", err);
        p++;
    }
    fuzz_require(k >= lo, "the message lacks its line or column", err);
    fuzz_require(*p == ' ' && p[1] != '\0', "the message says nothing", err);
}

#endif
