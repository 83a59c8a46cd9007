/*
 * shade.h - recursive Whitted shading with POV-Ray's classic finish.
 *
 *     Vec3 c = shade_trace(&scene, &accel, &camera_ray, 1, &stats);
 *
 * The model, term for term, is REFERENCE.md section 1 (POV-Ray 3.7): ambient,
 * Lambert diffuse, phong and specular highlights in the light's colour, light
 * fade, shadowless lights, and additive mirror reflection. `level` counts like
 * POV-Ray's max_trace_level: the camera ray is level 1, and a ray whose level
 * exceeds scene->max_depth returns black (not the background).
 */
#ifndef LANCER_SHADE_H
#define LANCER_SHADE_H

#include "lancer/accel.h"

Vec3 shade_trace(const Scene *s, const Accel *a, const Ray *r, int level, RayStats *st);

/* The origin for a ray leaving surface point p (unit geometric normal ng) in
 * direction dir: p pushed off the surface, to dir's side, by a bound on the
 * rounding error of p that grows with the magnitude of p and of the incoming
 * ray's origin o. No fixed epsilon: the offset scales with the scene. */
Vec3 shade_spawn_origin(Vec3 p, Vec3 ng, Vec3 dir, Vec3 o);

#endif
