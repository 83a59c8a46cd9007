/* Unit tests for lex.c's numbers: lex_parse_float gives strtof's float bit
 * for bit (its fast path for short decimals included), and its codes for
 * malformed, non-finite and overlong tokens. */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>

#include "testutil.h"

#include "../src/lex.h"

static LexTok tok(const char *s) { return (LexTok){s, strlen(s)}; }

/* lex_parse_float(s) is LEX_NUM_OK with strtof's bits. */
static void assert_as_strtof(const char *s)
{
    float got = NAN, want = strtof(s, NULL);
    if (lex_parse_float(tok(s), &got) != LEX_NUM_OK || memcmp(&got, &want, sizeof got) != 0)
        fail_msg("\"%s\": lex_parse_float %a, strtof %a", s, (double)got, (double)want);
}

/* The fast path's edges: 2^24 and past it, ten powers of ten either way
 * and past them, leading and trailing zeros, signs and exponents. */
static void test_float_edges(void **state)
{
    (void)state;
    static const char *const s[] = {
        "0", "-0", "+0", "0.0", "-0.0", ".5", "5.", "-.5", "16777216", "16777217", "16777218", "-16777217",
        "1677721.7", "1677721.9", "0.16777217", "1e10", "1e11", "1e-10", "1e-11", "9999999e10", "16777216e10",
        "16777216e-10", "1.6777216e-3", "0.0000000001", "0.00000000001", "123456789", "0.1", "0.2", "0.3",
        "3.4028235e38", "1.17549435e-38", "1e-45", "-0.0732205", "0.00476389", "-0.411917", "0000000000000001.5",
        "1.5000000000000000", "1E5", "1e+5", "1e-05", "7e0", "00.000e-0", "2.5e-7", "8388609.5", "4.2949673e9"};
    for (size_t i = 0; i < sizeof s / sizeof s[0]; i++)
        assert_as_strtof(s[i]);
}

/* Random decimals: up to 12 significant digits, the point anywhere, an
 * exponent or none; most within the fast path, the rest beside it. */
static void test_float_random_decimals(void **state)
{
    (void)state;
    unsigned long long seed = 5;
    char buf[64];
    for (int n = 0; n < 400000; n++) {
        int digits = 1 + (int)test_uniform(&seed, 0.0f, 12.0f), point = (int)test_uniform(&seed, 0.0f, (float)digits + 1);
        size_t k = 0;
        if (test_uniform(&seed, 0.0f, 1.0f) < 0.5f)
            buf[k++] = '-';
        for (int d = 0; d < digits; d++) {
            if (d == point)
                buf[k++] = '.';
            buf[k++] = (char)('0' + (int)test_uniform(&seed, 0.0f, 10.0f));
        }
        if (test_uniform(&seed, 0.0f, 1.0f) < 0.3f)
            k += (size_t)sprintf(buf + k, "e%d", (int)test_uniform(&seed, -16.0f, 16.0f));
        buf[k] = '\0';
        assert_as_strtof(buf);
    }
}

/* Random floats printed with 1 to 9 significant digits, as mesh files
 * hold them. */
static void test_float_printed(void **state)
{
    (void)state;
    unsigned long long seed = 9;
    char buf[64];
    for (int n = 0; n < 300000; n++) {
        float x = test_uniform(&seed, -1.0f, 1.0f) * powf(10.0f, (float)(int)test_uniform(&seed, -12.0f, 12.0f));
        snprintf(buf, sizeof buf, "%.*g", 1 + n % 9, (double)x);
        assert_as_strtof(buf);
    }
}

static void test_float_codes(void **state)
{
    (void)state;
    float f = 1.0f;
    assert_int_equal(lex_parse_float(tok("1x"), &f), LEX_NUM_MALFORMED);
    assert_int_equal(lex_parse_float(tok("1e"), &f), LEX_NUM_MALFORMED);
    assert_int_equal(lex_parse_float(tok(""), &f), LEX_NUM_MALFORMED);
    assert_int_equal(lex_parse_float(tok("."), &f), LEX_NUM_MALFORMED);
    assert_int_equal(lex_parse_float(tok("nan"), &f), LEX_NUM_NONFINITE);
    assert_int_equal(lex_parse_float(tok("-Infinity"), &f), LEX_NUM_NONFINITE);
    assert_int_equal(lex_parse_float(tok("1e39"), &f), LEX_NUM_NONFINITE);
    assert_int_equal(lex_parse_float(tok("1e99999999"), &f), LEX_NUM_NONFINITE);
    assert_true(f == 1.0f); /* untouched by a failure */
    char lng[LIMIT_NUMBER_CHARS + 2];
    memset(lng, '1', sizeof lng - 1);
    lng[sizeof lng - 1] = '\0';
    assert_int_equal(lex_parse_float(tok(lng), &f), LEX_NUM_LONG);
    assert_int_equal(lex_parse_float(tok("1e-99999999"), &f), LEX_NUM_OK);
    assert_true(f == 0.0f);
}

/* lex_hash_str: equal strings hash equal under a seed, and names made to
 * share a slot of 2^12 under one seed (as material names made against a
 * fixed hash did: 32,768 of them took 12 s to read) spread under another. */
static void test_hash_str_seeded(void **state)
{
    (void)state;
    const uint64_t s1 = lex_mix64(11), s2 = lex_mix64(12);
    assert_true(lex_hash_str("granite", s1) == lex_hash_str("granite", s1));
    assert_true(lex_hash_str("granite", s1) != lex_hash_str("granite", s2));
    assert_true(lex_hash_str("", s1) != lex_hash_str("a", s1));
    assert_true(lex_hash_str("abcdefgh", s1) != lex_hash_str("abcdefgh\x01", s1));
    enum { N = 400, SLOTS = 1 << 12 };
    uint64_t h1[N], h2[N], k = 3;
    for (int n = 0; n < N;) {
        char name[24];
        k = lex_mix64(k);
        snprintf(name, sizeof name, "m%llx", (unsigned long long)(k >> 20));
        h1[n] = lex_hash_str(name, s1);
        h2[n] = lex_hash_str(name, s2);
        n += (h1[n] & (SLOTS - 1)) == 0;
    }
    assert_true(test_probes(h1, N, SLOTS) > 100L * N);
    assert_true(test_probes(h2, N, SLOTS) < 2L * N);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_float_edges),
        cmocka_unit_test(test_float_random_decimals),
        cmocka_unit_test(test_float_printed),
        cmocka_unit_test(test_float_codes),
        cmocka_unit_test(test_hash_str_seeded),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
