/*
 * rayfile.c - LNCRAYS1 ray files (see rayfile.h for the format).
 */
#include "lancer/rayfile.h"

#include <errno.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "lancer/afile.h"

#define RAYFILE_MAGIC "LNCRAYS1"
#define RAYFILE_RECORD 32

/* Little-endian encoding by bytes, so the format does not depend on the
 * machine's byte order. */
static void put_u32(unsigned char *p, uint32_t v)
{
    for (int i = 0; i < 4; i++)
        p[i] = (unsigned char)(v >> (8 * i));
}

static uint32_t get_u32(const unsigned char *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

static void put_f32(unsigned char *p, float f)
{
    uint32_t v;
    memcpy(&v, &f, 4);
    put_u32(p, v);
}

static float get_f32(const unsigned char *p)
{
    uint32_t v = get_u32(p);
    float f;
    memcpy(&f, &v, 4);
    return f;
}

int rayfile_write(const char *path, const Ray *rays, size_t n, char *err, size_t errlen)
{
    char tmp[AFILE_PATH_MAX];
    FILE *f = afile_fopen(path, tmp, sizeof tmp, err, errlen);
    if (!f)
        return -1;
    unsigned char head[16];
    memcpy(head, RAYFILE_MAGIC, 8);
    put_u32(head + 8, (uint32_t)(n & 0xffffffffu));
    put_u32(head + 12, (uint32_t)((uint64_t)n >> 32));
    fwrite(head, 1, sizeof head, f);
    for (size_t i = 0; i < n; i++) {
        const Ray *r = &rays[i];
        const float v[8] = {r->o.x, r->o.y, r->o.z, r->d.x, r->d.y, r->d.z, 0.0f, r->tmax};
        unsigned char rec[RAYFILE_RECORD];
        for (int k = 0; k < 8; k++)
            put_f32(rec + 4 * k, v[k]);
        fwrite(rec, 1, sizeof rec, f);
    }
    return afile_fclose(f, tmp, path, err, errlen);
}

int rayfile_read(const char *path, Ray **rays, size_t *n, char *err, size_t errlen)
{
    *rays = NULL;
    *n = 0;
    FILE *f = fopen(path, "rb");
    if (!f) {
        snprintf(err, errlen, "%s: cannot open: %s", path, strerror(errno));
        return -1;
    }
    unsigned char head[16];
    long size = -1;
    if (fseek(f, 0, SEEK_END) == 0)
        size = ftell(f);
    rewind(f);
    if (fread(head, 1, sizeof head, f) != sizeof head || memcmp(head, RAYFILE_MAGIC, 8) != 0) {
        snprintf(err, errlen, "%s: not a ray file (it must start with %s and a count)", path, RAYFILE_MAGIC);
        fclose(f);
        return -1;
    }
    uint64_t count = (uint64_t)get_u32(head + 8) | (uint64_t)get_u32(head + 12) << 32;
    /* The count must account for the whole file: this also bounds the
     * allocation by what is really there. */
    if (size < 16 || count != (uint64_t)(size - 16) / RAYFILE_RECORD || (uint64_t)(size - 16) % RAYFILE_RECORD) {
        snprintf(err, errlen, "%s: the count (%llu rays) disagrees with the file size (%ld bytes)", path,
                 (unsigned long long)count, size);
        fclose(f);
        return -1;
    }
    Ray *r = malloc(sizeof(Ray) * (size_t)(count ? count : 1));
    if (!r) {
        snprintf(err, errlen, "%s: %llu rays do not fit in memory", path, (unsigned long long)count);
        fclose(f);
        return -1;
    }
    for (uint64_t i = 0; i < count; i++) {
        unsigned char rec[RAYFILE_RECORD];
        float v[8];
        if (fread(rec, 1, sizeof rec, f) != sizeof rec) {
            snprintf(err, errlen, "%s: truncated at ray %llu", path, (unsigned long long)i);
            free(r);
            fclose(f);
            return -1;
        }
        for (int k = 0; k < 8; k++) {
            v[k] = get_f32(rec + 4 * k);
            if (!isfinite(v[k]) && !(k == 7 && v[k] == INFINITY)) {
                snprintf(err, errlen, "%s: ray %llu has a non-finite value", path, (unsigned long long)i);
                free(r);
                fclose(f);
                return -1;
            }
        }
        Vec3 o = vec3(v[0], v[1], v[2]), d = vec3(v[3], v[4], v[5]);
        r[i] = ray_make(vec_madd(o, d, v[6]), d, v[7] - v[6]);
    }
    fclose(f);
    *rays = r;
    *n = (size_t)count;
    return 0;
}
