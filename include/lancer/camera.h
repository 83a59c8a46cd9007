/*
 * camera.h - a right-handed pinhole camera shooting through pixel centres.
 *
 *     Camera cam;
 *     camera_init(&cam, &scene.camera, width, height);
 *     Ray r = camera_ray(&cam, i + 0.5f, j + 0.5f);   pixel (i, j), row 0 at the top
 *     camera_rays(&cam, xs, ys, n, rays);             n rays at once, the same ones
 *
 * For pixel coordinates (x, y) the direction is
 *     f + (2x/W - 1) * t * a * r + (1 - 2y/H) * t * u,   t = tan(fovy/2), a = W/H,
 * with f the unit view direction, r = f x up and u = r x f (both unit). This is
 * exactly POV-Ray's `right -x*a, angle 2*atan(a*t)` mapping (docs/povray-rules.md, section 0),
 * and the direction is normalised so that t along a camera ray is distance.
 */
#ifndef LANCER_CAMERA_H
#define LANCER_CAMERA_H

#include "lancer/ray.h"
#include "lancer/scene.h"

typedef struct {
    Vec3 eye, f, r, u; /* r and u already scaled by t*a and t */
    float inv_w, inv_h;
} Camera;

/* The spec must be valid (scene_parse guarantees it). */
void camera_init(Camera *cam, const CameraSpec *spec, int width, int height);

/* The ray through image-plane position (x, y) in pixels. Inline: single
 * rays (and camera_rays' last few) would otherwise come back through
 * memory. */
static inline Ray camera_ray(const Camera *cam, float x, float y)
{
    float sx = 2.0f * x * cam->inv_w - 1.0f;
    float sy = 1.0f - 2.0f * y * cam->inv_h;
    Vec3 d = vec_add(cam->f, vec_add(vec_scale(cam->r, sx), vec_scale(cam->u, sy)));
    return ray_make(cam->eye, vec_normalize(d), INFINITY);
}

/* camera_ray(cam, x[k], y[k]) into out[k] for k < n, bit for bit (NaN
 * lanes aside, whose sign may differ): four at a time with SSE, where a
 * camera ray's square root and division took a sixth of a render's row
 * loop one by one. */
void camera_rays(const Camera *cam, const float *x, const float *y, int n, Ray *out);

#endif
