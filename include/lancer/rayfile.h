/*
 * rayfile.h - ray files that other tracers can read and write too.
 *
 *     Ray *rays; size_t n;
 *     if (rayfile_read("primary.rays", &rays, &n, err, sizeof err) != 0) ...
 *     ... free(rays);
 *
 * Format: the 8 bytes "LNCRAYS1", a little-endian uint64 count, then count
 * records of 8 little-endian float32: ox oy oz dx dy dz tmin tmax. lancer's
 * rays start at t > 0, so a record's tmin is applied on reading by moving
 * the origin to o + tmin d (and shortening tmax to match); written files
 * have tmin 0. Directions need not be unit length.
 */
#ifndef LANCER_RAYFILE_H
#define LANCER_RAYFILE_H

#include <stddef.h>
#include <stdio.h>

#include "lancer/ray.h"

/* 1 when r is a ray that lancer can trace: a finite origin, a finite
 * direction with a component of at least FLT_MIN in magnitude, and a tmax
 * that is not NaN. */
int rayfile_ray_ok(const Ray *r);

/* Writes n rays atomically (afile.h). Returns 0, or -1 with a message. */
int rayfile_write(const char *path, const Ray *rays, size_t n, char *err, size_t errlen);
/* Writes n rays to f, as a ray file. Returns 0, or -1 when a write failed. */
int rayfile_write_stream(FILE *f, const Ray *rays, size_t n);

/* Reads a whole ray file into a new array the caller frees; every ray
 * passes rayfile_ray_ok. Returns 0, or -1 with "path: message" (bad magic,
 * a count that disagrees with the file's size, a non-finite value, a zero
 * direction or an origin that tmin moves out of float range in ray N). */
int rayfile_read(const char *path, Ray **rays, size_t *n, char *err, size_t errlen);

/* rayfile_read of a file held in memory (size bytes at data); messages name
 * `name`. */
int rayfile_parse(const char *name, const void *data, size_t size, Ray **rays, size_t *n, char *err, size_t errlen);

#endif
