/*
 * rayfile.c - LNCRAYS1 ray files (see rayfile.h for the format).
 */
#include "lancer/rayfile.h"

#include <float.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "lancer/afile.h"
#include "lancer/limits.h"

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

/* No component of d reaches FLT_MIN (zero included): the reciprocal of the
 * largest, which the BVH's slab test takes, would overflow, and the ray
 * would pass through every box unseen. */
static int dir_too_short(Vec3 d) { return !(fabsf(d.x) >= FLT_MIN || fabsf(d.y) >= FLT_MIN || fabsf(d.z) >= FLT_MIN); }

int rayfile_ray_ok(const Ray *r)
{
    return isfinite(r->o.x) && isfinite(r->o.y) && isfinite(r->o.z) && isfinite(r->d.x) && isfinite(r->d.y) &&
           isfinite(r->d.z) && !dir_too_short(r->d) && !isnan(r->tmax);
}

int rayfile_write_stream(FILE *f, const Ray *rays, size_t n)
{
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
    return ferror(f) ? -1 : 0;
}

int rayfile_write(const char *path, const Ray *rays, size_t n, char *err, size_t errlen)
{
    char tmp[AFILE_PATH_MAX];
    FILE *f = afile_fopen(path, tmp, sizeof tmp, err, errlen);
    if (!f)
        return -1;
    rayfile_write_stream(f, rays, n); /* afile_fclose sees a failed write */
    return afile_fclose(f, tmp, path, err, errlen);
}

int rayfile_parse(const char *name, const void *data, size_t size, Ray **rays, size_t *n, char *err, size_t errlen)
{
    *rays = NULL;
    *n = 0;
    const unsigned char *b = data;
    if (size < 16 || memcmp(b, RAYFILE_MAGIC, 8) != 0) {
        snprintf(err, errlen, "%s: not a ray file (it must start with %s and a count)", name, RAYFILE_MAGIC);
        return -1;
    }
    uint64_t count = (uint64_t)get_u32(b + 8) | (uint64_t)get_u32(b + 12) << 32;
    /* The count must account for the whole file: this also bounds the
     * allocation by what is really there. */
    if (count != (size - 16) / RAYFILE_RECORD || (size - 16) % RAYFILE_RECORD) {
        snprintf(err, errlen, "%s: the count (%llu rays) disagrees with the file size (%zu bytes)", name,
                 (unsigned long long)count, size);
        return -1;
    }
    Ray *r = malloc(sizeof(Ray) * (size_t)(count ? count : 1));
    if (!r) {
        snprintf(err, errlen, "%s: %llu rays do not fit in memory", name, (unsigned long long)count);
        return -1;
    }
    for (uint64_t i = 0; i < count; i++) {
        const unsigned char *rec = b + 16 + RAYFILE_RECORD * i;
        float v[8];
        for (int k = 0; k < 8; k++) {
            v[k] = get_f32(rec + 4 * k);
            if (!isfinite(v[k]) && !(k == 7 && v[k] == INFINITY)) {
                snprintf(err, errlen, "%s: ray %llu has a non-finite value", name, (unsigned long long)i);
                free(r);
                return -1;
            }
        }
        Vec3 o = vec3(v[0], v[1], v[2]), d = vec3(v[3], v[4], v[5]);
        r[i] = ray_make(vec_madd(o, d, v[6]), d, v[7] - v[6]);
        const char *bad = NULL;
        if (d.x == 0.0f && d.y == 0.0f && d.z == 0.0f)
            bad = "a zero direction";
        else if (dir_too_short(d))
            bad = "a direction too short to trace (no component of at least FLT_MIN, 2^-126)";
        else if (!rayfile_ray_ok(&r[i]))
            bad = "a tmin that moves its origin out of float range";
        if (bad) {
            snprintf(err, errlen, "%s: ray %llu has %s", name, (unsigned long long)i, bad);
            free(r);
            return -1;
        }
    }
    *rays = r;
    *n = (size_t)count;
    return 0;
}

int rayfile_read(const char *path, Ray **rays, size_t *n, char *err, size_t errlen)
{
    *rays = NULL;
    *n = 0;
    char *buf;
    size_t size;
    if (afile_read(path, (unsigned long long)LIMIT_RAYFILE_BYTES, "ray files", &buf, &size, err, errlen) != 0)
        return -1;
    int rc = rayfile_parse(path, buf, size, rays, n, err, errlen);
    free(buf);
    return rc;
}
