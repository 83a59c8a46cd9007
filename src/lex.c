/*
 * lex.c - the text reading that the scene parser and the mesh readers
 * share (see lex.h).
 */
#include "lex.h"

#include <float.h>
#include <limits.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

/* ---- lines, tokens and errors ---- */

int lex_verror(char *err, size_t errlen, const char *name, long line, long col, const char *fmt, va_list ap)
{
    if (errlen == 0)
        return -1;
    int n = col > 0 ? snprintf(err, errlen, "%s:%ld:%ld: ", name, line, col) : snprintf(err, errlen, "%s:%ld: ", name, line);
    if (n >= 0 && (size_t)n < errlen)
        vsnprintf(err + n, errlen - (size_t)n, fmt, ap);
    return -1;
}

/* The column of byte at: bytes since the start of its line, plus one. A
 * line starts after a '\n' or after a '\r' (which ends a line unless a
 * '\n' follows it: lex_next_line); the first, after a UTF-8 byte-order
 * mark, as the scene's does. */
static long column(const LexReader *R, const char *at)
{
    const char *s = at;
    while (s > R->data && s[-1] != '\n' && s[-1] != '\r')
        s--;
    if (s == R->data)
        s += lex_bom_len(s, at);
    return (long)(at - s) + 1;
}

/* The first token of R's current line (its start if it has none). */
static const char *line_first(const LexReader *R)
{
    if (!R->ls)
        return R->data;
    const char *s = R->ls;
    while (s < R->end && lex_is_blank(*s) && *s != '\r')
        s++;
    return s;
}

LEX_PRINTF(4, 0) static int vfail(const LexReader *R, long line, const char *at, const char *fmt, va_list ap)
{
    long col = at ? column(R, at) : line == R->line ? column(R, line_first(R)) : 1;
    return lex_verror(R->err, R->errlen, R->name, line, col, fmt, ap);
}

int lex_fail(const LexReader *R, long line, const char *at, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vfail(R, line, at, fmt, ap);
    va_end(ap);
    return -1;
}

int lex_fail_at(const LexReader *R, long line, const char *at, size_t off, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vfail(R, line, at, fmt, ap);
    va_end(ap);
    if (R->errlen > 0) {
        size_t n = strlen(R->err);
        if (n + 1 < R->errlen)
            snprintf(R->err + n, R->errlen - n, " at byte offset %zu", off);
    }
    return -1;
}

int lex_fail_eof(const LexReader *R, const char *fmt, ...)
{
    /* the last line is the one last read: the file's end, less the line's
     * own end ("\n", "\r\n" or "\r") */
    const char *at = R->end;
    if (at > R->data && at[-1] == '\n')
        at--;
    if (at > R->data && at[-1] == '\r')
        at--;
    va_list ap;
    va_start(ap, fmt);
    vfail(R, R->line > 0 ? R->line : 1, at, fmt, ap);
    va_end(ap);
    return -1;
}

/* The first byte c at or after s, or R->end; *from and *at cache the last
 * search, so that each c is searched for once however long the lines
 * between them (and a reader sent back to its start searches again). */
static const char *next_byte(const LexReader *R, const char **from, const char **at, const char *s, int c)
{
    if (!*at || s < *from || s > *at) {
        const char *x = memchr(s, c, (size_t)(R->end - s));
        *from = s;
        *at = x ? x : R->end;
    }
    return *at;
}

int lex_next_line(LexReader *R, const char **ls, const char **le)
{
    if (R->p >= R->end)
        return 0;
    const char *s = R->p;
    const char *e = next_byte(R, &R->lf_from, &R->lf, s, '\n');
    const char *cr = next_byte(R, &R->cr_from, &R->cr, s, '\r'), *next = e < R->end ? e + 1 : R->end;
    if (cr < e && cr + 1 < e) /* a lone CR, as old Mac OS files end their lines */
        e = cr, next = cr + 1;
    R->p = next;
    R->ls = s;
    R->line++;
    if (e > s && e[-1] == '\r')
        e--;
    *ls = s;
    *le = e;
    return 1;
}

int lex_next_tok(const char **q, const char *e, LexTok *t)
{
    const char *p = *q;
    while (p < e && lex_is_blank(*p))
        p++;
    if (p >= e) {
        *q = p;
        return 0;
    }
    t->s = p;
    while (p < e && !lex_is_blank(*p))
        p++;
    t->len = (size_t)(p - t->s);
    *q = p;
    return 1;
}

int lex_split(const char *s, const char *e, LexTok *tk, int max)
{
    int n = 0;
    LexTok t;
    while (lex_next_tok(&s, e, &t)) {
        if (n < max)
            tk[n] = t;
        if (n < INT_MAX)
            n++;
    }
    return n;
}

int lex_next_text_line(LexReader *R, const char **ls, const char **le, int comments)
{
    const char *s, *e;
    while (lex_next_line(R, &s, &e)) {
        if (comments) {
            const char *h = memchr(s, '#', (size_t)(e - s));
            if (h)
                e = h;
        }
        const char *q = s;
        LexTok t;
        if (lex_next_tok(&q, e, &t)) {
            *ls = s;
            *le = e;
            return 1;
        }
    }
    return 0;
}

/* t for a message: at most 40 bytes, bytes other than printable ASCII as '?'. */
const char *lex_quote(LexTok t, char buf[LEX_QUOTE_LEN])
{
    size_t n = t.len > 40 ? 40 : t.len, i;
    for (i = 0; i < n; i++) {
        unsigned char c = (unsigned char)t.s[i];
        buf[i] = c >= 0x20 && c < 0x7f ? (char)c : '?';
    }
    if (n < t.len)
        memcpy(buf + i, "...", 3), i += 3;
    buf[i] = '\0';
    return buf;
}

/* ---- numbers ---- */

size_t lex_number_len(const char *s, const char *end)
{
    const char *q = s;
    size_t digits = 0;
    if (q < end && (*q == '+' || *q == '-'))
        q++;
    while (q < end && lex_is_digit(*q))
        q++, digits++;
    if (q < end && *q == '.') {
        q++;
        while (q < end && lex_is_digit(*q))
            q++, digits++;
    }
    if (digits == 0)
        return 0;
    if (q < end && (*q == 'e' || *q == 'E')) {
        const char *e = q + 1;
        if (e < end && (*e == '+' || *e == '-'))
            e++;
        if (e < end && lex_is_digit(*e)) {
            while (e < end && lex_is_digit(*e))
                e++;
            q = e;
        }
    }
    return (size_t)(q - s);
}

int lex_is_decimal(LexTok t) { return t.len > 0 && lex_number_len(t.s, t.s + t.len) == t.len; }

int lex_is_nonfinite_word(LexTok t)
{
    static const char *const words[] = {"nan", "inf", "infinity"};
    size_t i = t.len > 0 && (t.s[0] == '+' || t.s[0] == '-');
    for (size_t w = 0; w < 3; w++) {
        size_t n = strlen(words[w]), k;
        if (t.len - i != n)
            continue;
        for (k = 0; k < n; k++)
            if ((t.s[i + k] | 0x20) != words[w][k])
                break;
        if (k == n)
            return 1;
    }
    return 0;
}

int lex_parse_int(LexTok t, long long *out)
{
    size_t i = 0;
    int neg = 0;
    long long v = 0;
    if (i < t.len && (t.s[i] == '+' || t.s[i] == '-'))
        neg = t.s[i++] == '-';
    if (i == t.len)
        return -1;
    for (; i < t.len; i++) {
        if (!lex_is_digit(t.s[i]))
            return -1;
        v = v > LEX_INT_SAT / 10 ? LEX_INT_SAT : v * 10 + (t.s[i] - '0');
    }
    if (v > LEX_INT_SAT)
        v = LEX_INT_SAT;
    *out = neg ? -v : v;
    return 0;
}

int lex_to_float(double d, float *f)
{
    /* Values below FLT_MAX + half an ulp round to FLT_MAX; the halfway point
     * rounds to even, which is infinity (FLT_MAX's significand is odd). */
    const double lim = (double)FLT_MAX + 0x1p103;
    if (isnan(d) || fabs(d) >= lim)
        return -1;
    *f = fabs(d) > FLT_MAX ? (d > 0 ? FLT_MAX : -FLT_MAX) : (float)d;
    return 0;
}

/* Clinger's fast path ("How to Read Floating Point Numbers Accurately",
 * PLDI 1990), in float: a decimal m 10^e with m <= 2^24 and |e| <= 10
 * is (float)m times or over 10^|e|, both exact in float, so the one
 * rounding of that product or quotient gives the nearest float, as strtof
 * does. Most mesh coordinates ("-0.0732205") are such numbers; 0 for any
 * other, which strtof then reads. t is a decimal (lex_is_decimal). */
static int fast_float(LexTok t, float *out)
{
    static const float pow10[] = {1e0f, 1e1f, 1e2f, 1e3f, 1e4f, 1e5f, 1e6f, 1e7f, 1e8f, 1e9f, 1e10f};
    const char *q = t.s, *end = t.s + t.len;
    int neg = *q == '-';
    q += *q == '-' || *q == '+';
    uint32_t m = 0;
    long e = 0;
    int point = 0; /* 1 past the decimal point: each digit then divides by 10 */
    for (; q < end && (lex_is_digit(*q) || (*q == '.' && !point)); q++) {
        if (*q == '.') {
            point = 1;
            continue;
        }
        if (m > (1u << 24) / 10) /* (leading zeros keep m 0) */
            return 0;
        m = 10 * m + (uint32_t)(*q - '0');
        e -= point;
    }
    if (q < end) { /* [eE][+-]digits, as lex_number_len allows */
        q++;
        int eneg = *q == '-';
        q += *q == '-' || *q == '+';
        long x = 0;
        for (; q < end && x < 1000; q++)
            x = 10 * x + (*q - '0');
        if (q < end)
            return 0;
        e += eneg ? -x : x;
    }
    if (m > (1u << 24) || e < -10 || e > 10 || FLT_EVAL_METHOD != 0) /* (x87: rounded twice) */
        return 0;
    float f = e < 0 ? (float)m / pow10[-e] : (float)m * pow10[e];
    *out = neg ? -f : f;
    return 1;
}

int lex_parse_float(LexTok t, float *out)
{
    if (!lex_is_decimal(t))
        return lex_is_nonfinite_word(t) ? LEX_NUM_NONFINITE : LEX_NUM_MALFORMED;
    if (t.len > LIMIT_NUMBER_CHARS)
        return LEX_NUM_LONG;
    if (fast_float(t, out))
        return LEX_NUM_OK;
    char buf[LIMIT_NUMBER_CHARS + 1], *end;
    memcpy(buf, t.s, t.len);
    buf[t.len] = '\0';
    float f = strtof(buf, &end);
    if (end != buf + t.len) /* a locale whose decimal point is not '.' */
        return LEX_NUM_MALFORMED;
    if (!isfinite(f))
        return LEX_NUM_NONFINITE;
    *out = f;
    return LEX_NUM_OK;
}

uint64_t lex_hash_seed(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return lex_mix64((uint64_t)ts.tv_nsec ^ (uint64_t)ts.tv_sec << 30 ^ (uint64_t)(uintptr_t)&ts << 7);
}

uint64_t lex_hash_str(const char *s, uint64_t seed)
{
    uint64_t k = seed;
    size_t n = strlen(s);
    for (size_t i = 0; i < n; i += 8) {
        uint64_t g = 0;
        memcpy(&g, s + i, n - i < 8 ? n - i : 8);
        k = lex_mix64(k ^ g);
    }
    return lex_mix64(k ^ n);
}
