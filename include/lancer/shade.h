/*
 * shade.h - recursive Whitted shading with POV-Ray 3.7's classic finish.
 *
 *     RenderPlan p;  Accel *a;                  ... plan_build, accel_build ...
 *     Vec3 c = shade_trace(&p, a, &camera_ray, &stats);
 *
 * The model is POV-Ray 3.7's, term for term (docs/povray-rules.md gives
 * each rule with its source in POV-Ray's code):
 *
 * - ambient, Lambert diffuse, and phong and specular highlights in the
 *   light's colour; a light with N.L below 1e-10 adds nothing at all;
 * - light fade, shadowless lights, and area lights whose visibility is
 *   POV-Ray's recursively weighted average of the sample grid;
 * - filter and transmit: ambient and diffuse scale by 1 - filter - transmit,
 *   the transmitted ray by color*filter + transmit; shadow rays pass
 *   transparent surfaces, multiplied by that factor at every crossing;
 * - refraction by the ratio of indices from each ray's list of interiors,
 *   with total internal reflection;
 * - additive mirror reflection.
 *
 * Depth counts like POV-Ray's max_trace_level: the camera ray is level 1,
 * every reflected or refracted ray one more; a ray past the plan's
 * max_depth is black, not the background. A transmitted ray that does not
 * bend continues at its parent's level. Camera rays start inside the
 * plan's camera_in; every other setting and decision comes from the plan
 * too (plan.h), and the visibility queries from the Accel.
 */
#ifndef LANCER_SHADE_H
#define LANCER_SHADE_H

#include <signal.h>

#include "lancer/accel.h"
#include "lancer/plan.h"

/* The colour seen along camera ray r. */
Vec3 shade_trace(const RenderPlan *p, const Accel *a, const Ray *r, RayStats *st);

/* shade_trace when the camera ray's closest hit is already known: i and h
 * from accel_closest (or accel_closest_packet). The same colour. */
Vec3 shade_traced(const RenderPlan *p, const Accel *a, const Ray *r, int i, const PrimHit *h, RayStats *st);

/* shade_traced for each of r[0 .. n-1] into out[k], BVH_PACKET at a time:
 * the same colours. The shadow rays of the rays' hits towards each point light
 * are traced together (accel_occluded_packet), and so are their mirror
 * rays (accel_closest_packet), whose hits are shaded the same way. stop:
 * NULL, or a flag (RenderOptions.stop) read before each packet of hits is
 * shaded; once it is nonzero the rest is left untraced, black, and the
 * colours are not the picture's (a ray's tree can grow as 2^max_depth). */
void shade_traced_packet(const RenderPlan *p, const Accel *a, const Ray *r, int n, const int *best, const PrimHit *h,
                         RayStats *st, const volatile sig_atomic_t *stop, Vec3 *out);

#endif
