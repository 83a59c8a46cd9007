/*
 * sha256.h - SHA-256 (FIPS 180-4), for the content hash that ties a tile
 * or a partial render to the scene and meshes it was rendered from.
 *
 *     Sha256 h;
 *     sha256_init(&h);
 *     sha256_update(&h, bytes, len);      as often as needed
 *     unsigned char d[SHA256_BYTES];
 *     sha256_final(&h, d);
 *     char hex[SHA256_HEX]; sha256_hex(d, hex);
 */
#ifndef LANCER_SHA256_H
#define LANCER_SHA256_H

#include <stddef.h>
#include <stdint.h>

#define SHA256_BYTES 32
#define SHA256_HEX 65 /* 64 digits and the terminating NUL */

typedef struct {
    uint32_t h[8];
    uint64_t bytes;          /* the message's length so far */
    unsigned char block[64]; /* the block being filled */
} Sha256;

void sha256_init(Sha256 *s);
void sha256_update(Sha256 *s, const void *data, size_t len);
/* The digest; s must be initialised again before reuse. */
void sha256_final(Sha256 *s, unsigned char out[SHA256_BYTES]);
/* The digest in lower-case hexadecimal, as sha256sum prints it. */
void sha256_hex(const unsigned char d[SHA256_BYTES], char out[SHA256_HEX]);

#endif
