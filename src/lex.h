/*
 * lex.h - the text reading that the scene parser and the mesh readers share
 * (private to src/): error messages with their position, lines and blank-
 * separated tokens of a byte range, and numbers.
 *
 * Input is a byte range [data, end) that need not end in a NUL and may hold
 * NUL bytes: no routine looks past `end`, and numbers are copied into a
 * bounded buffer before strtof sees them. Lines end in "\n" or "\r\n".
 *
 * Every message is one line, "name:line:col: message"; for binary data,
 * which has no lines, "name:line:col: message at byte offset N", placed at
 * the header line that announced the data.
 */
#ifndef LANCER_LEX_H
#define LANCER_LEX_H

#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "lancer/limits.h"

#if defined(__GNUC__)
#define LEX_PRINTF(f, a) __attribute__((format(printf, f, a)))
#else
#define LEX_PRINTF(f, a)
#endif

/* Room for a token quoted in a message: 40 bytes plus "...". */
#define LEX_QUOTE_LEN 48
/* Integers saturate here, so that "99999999999999999999" fails a range
 * check instead of wrapping around. */
#define LEX_INT_SAT 1000000000000000000LL

/* A line reader over [data, end), and where its messages go. */
typedef struct {
    const char *name;       /* the file, in messages */
    const char *data, *end; /* the whole input */
    const char *p;          /* start of the next line */
    const char *ls;         /* start of the line last returned (NULL before the first) */
    long line;              /* number of the line last returned, 0 before the first */
    const char *lf_from, *lf; /* no '\n' in [lf_from, lf): the next one, cached (NULL: none yet) */
    const char *cr_from, *cr; /* the same for '\r' */
    char *err;
    size_t errlen;
} LexReader;

/* A token: bytes [s, s + len). */
typedef struct {
    const char *s;
    size_t len;
} LexTok;

/* "name:line:col: message" into err (col 0: "name:line: message"); -1. */
LEX_PRINTF(6, 0)
int lex_verror(char *err, size_t errlen, const char *name, long line, long col, const char *fmt, va_list ap);

/* "name:line:col: message" into R's error buffer; returns -1. The column
 * is that of byte `at` of R's data, which lies on line `line`: the
 * offending token. A NULL `at` stands for the first token of the line, for
 * a message about the line as a whole (column 1 when `line` is not R's
 * current line). */
LEX_PRINTF(4, 5) int lex_fail(const LexReader *R, long line, const char *at, const char *fmt, ...);
/* lex_fail for binary data: the message ends with " at byte offset N". */
LEX_PRINTF(5, 6) int lex_fail_at(const LexReader *R, long line, const char *at, size_t off, const char *fmt, ...);
/* lex_fail at the end of the file: just past the last line's last byte. */
LEX_PRINTF(2, 3) int lex_fail_eof(const LexReader *R, const char *fmt, ...);

/* Next line as [*ls, *le), without "\n", "\r\n" or the lone "\r" that ends
 * an old Mac OS line. Returns 0 at the end. */
int lex_next_line(LexReader *R, const char **ls, const char **le);
/* Next line that holds a token. With `comments`, '#' cuts the rest of a
 * line first. */
int lex_next_text_line(LexReader *R, const char **ls, const char **le, int comments);
/* Next blank-separated token of [*q, e); advances *q. Returns 0 when none
 * is left. */
int lex_next_tok(const char **q, const char *e, LexTok *t);
/* Number of tokens in [s, e); the first `max` are stored in tk. */
int lex_split(const char *s, const char *e, LexTok *tk, int max);

/* The length of the UTF-8 byte-order mark that [s, end) starts with: 3,
 * or 0 when it starts with none. It is not part of a scene or mesh. */
static inline size_t lex_bom_len(const char *s, const char *end)
{
    return end - s >= 3 && memcmp(s, "\xef\xbb\xbf", 3) == 0 ? 3 : 0;
}

static inline int lex_is_blank(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; }
static inline int lex_is_digit(int c) { return c >= '0' && c <= '9'; }
static inline int lex_tok_same(LexTok a, LexTok b) { return a.len == b.len && memcmp(a.s, b.s, a.len) == 0; }
static inline int lex_tok_is(LexTok t, const char *word)
{
    LexTok w = {word, strlen(word)};
    return lex_tok_same(t, w);
}

/* t for a message: at most 40 bytes, bytes other than printable ASCII as
 * '?'. */
const char *lex_quote(LexTok t, char buf[LEX_QUOTE_LEN]);

/* The length of the decimal number at s: [+-] digits [. digits] with a
 * digit somewhere, then [(e|E) [+-] digits] when digits follow; 0 when
 * none starts there. What C's printf writes, without hex or nan. */
size_t lex_number_len(const char *s, const char *end);
/* 1 when all of t is such a number. */
int lex_is_decimal(LexTok t);
/* 1 for nan, inf, infinity with an optional sign, in any case: how C
 * libraries print non-finite values, so worth a message of their own. */
int lex_is_nonfinite_word(LexTok t);
/* Parses [+-]digits. Returns 0, or -1 when t is not an integer. Saturates
 * at +-LEX_INT_SAT. */
int lex_parse_int(LexTok t, long long *out);
/* double -> float as IEEE rounding would do it, without the undefined
 * behaviour C gives an out-of-range conversion. Returns 0, or -1 when the
 * result is not finite. */
int lex_to_float(double d, float *f);

/* The readers' hash tables (material names, STL's welded vertices) take a
 * seed of their own each time: a file made so that its keys fill one slot
 * of one table cannot aim at the next, whose slots it cannot know, and its
 * reading stays in proportion to its size. From the clock's nanoseconds
 * and the stack's address: no secret, but not the file author's to see. */
uint64_t lex_hash_seed(void);
/* Stafford's "Mix13" finaliser (as in SplitMix64): a bijection of 64 bits
 * in which every input bit reaches every output bit. */
static inline uint64_t lex_mix64(uint64_t k)
{
    k = (k ^ k >> 30) * 0xbf58476d1ce4e5b9u;
    k = (k ^ k >> 27) * 0x94d049bb133111ebu;
    return k ^ k >> 31;
}
/* The hash of string s under seed: its bytes eight at a time, each group
 * mixed into the state by lex_mix64, then its length. */
uint64_t lex_hash_str(const char *s, uint64_t seed);

enum { LEX_NUM_OK = 0, LEX_NUM_MALFORMED = -1, LEX_NUM_NONFINITE = -2, LEX_NUM_LONG = -3 };
/* The float nearest to decimal token t. Returns a LEX_NUM_ code. */
int lex_parse_float(LexTok t, float *out);

#endif
