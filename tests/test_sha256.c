/* Unit tests for sha256.h: the test vectors of FIPS 180-4's examples
 * (NIST, "SHA-256 example"), and any split of the input into updates. */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <string.h>

#include "lancer/sha256.h"

static void digest_of(const void *p, size_t n, char hex[SHA256_HEX])
{
    Sha256 s;
    unsigned char d[SHA256_BYTES];
    sha256_init(&s);
    sha256_update(&s, p, n);
    sha256_final(&s, d);
    sha256_hex(d, hex);
}

static void test_nist_vectors(void **state)
{
    (void)state;
    char hex[SHA256_HEX];
    digest_of("abc", 3, hex);
    assert_string_equal(hex, "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
    digest_of("", 0, hex);
    assert_string_equal(hex, "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
    const char *two = "abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq"; /* 448 bits: padding spills */
    digest_of(two, strlen(two), hex);
    assert_string_equal(hex, "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1");
}

static void test_million_a_in_uneven_updates(void **state)
{
    (void)state;
    static char a[1000];
    memset(a, 'a', sizeof a);
    Sha256 s;
    unsigned char d[SHA256_BYTES];
    char hex[SHA256_HEX];
    sha256_init(&s);
    size_t done = 0, step = 1;
    while (done < 1000000) { /* updates of 1, 2, ... 997 bytes: every offset in a block */
        size_t n = step < 1000000 - done ? step : 1000000 - done;
        sha256_update(&s, a, n);
        done += n;
        step = step % 997 + 1;
    }
    sha256_final(&s, d);
    sha256_hex(d, hex);
    assert_string_equal(hex, "cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_nist_vectors),
        cmocka_unit_test(test_million_a_in_uneven_updates),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
