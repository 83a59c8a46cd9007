/*
 * shade.c - Whitted shading, POV-Ray's classic finish (REFERENCE.md 1).
 *
 * Every secondary ray starts at shade_spawn_origin(), never at the raw hit
 * point, and accepts any t > 0: the offset, not a t_min epsilon, keeps it off
 * its own surface.
 */
#include "lancer/shade.h"

#include <float.h>

/* Along the normal, the hit point p = o + t*d of the classic routines is off
 * by a few ulps of max(|o|, |p|): t is computed from o, so its rounding
 * happens at that magnitude. 16 ulps leaves a margin over that; the robust
 * variants will replace this with a proven per-primitive bound. */
#define SPAWN_ULPS 16.0f

Vec3 shade_spawn_origin(Vec3 p, Vec3 ng, Vec3 dir, Vec3 o)
{
    float mag = fmaxf(vec_max_abs(p), vec_max_abs(o));
    float e = SPAWN_ULPS * FLT_EPSILON * (mag > FLT_MIN ? mag : FLT_MIN);
    return vec_madd(p, ng, vec_dot(dir, ng) >= 0.0f ? e : -e);
}

/* Light attenuation: 2 / (1 + (d/fade_distance)^fade_power), or 1. */
static float fade(const Light *l, float dist)
{
    if (l->fade_power <= 0.0f)
        return 1.0f;
    return 2.0f / (1.0f + powf(dist / l->fade_distance, l->fade_power));
}

static Vec3 direct(const Scene *s, const Accel *a, const Material *m, const Surface *sf, const Ray *r,
                   RayStats *st)
{
    Vec3 c = vec_scale(m->color, m->ambient);
    Vec3 n = sf->ns;
    Vec3 refl = vec_reflect(r->d, n);
    Vec3 view = vec_neg(r->d);
    for (int i = 0; i < s->nlights; i++) {
        const Light *l = &s->lights[i];
        Vec3 tol = vec_sub(l->pos, sf->p);
        float dist = vec_length(tol);
        if (!(dist > 0.0f))
            continue;
        Vec3 L = vec_scale(tol, 1.0f / dist);
        float nl = vec_dot(n, L);
        Vec3 diff = vec3(0, 0, 0);
        float high = 0.0f; /* highlights are the light's colour, not P's */
        if (m->diffuse > 0.0f && nl >= 1e-10f)
            diff = vec_scale(m->color, m->diffuse * nl);
        if (!l->shadowless) { /* shadowless lights add no highlights */
            float rl = vec_dot(refl, L);
            if (m->phong > 0.0f && rl > 0.0f)
                high += m->phong * powf(rl, m->phong_size);
            if (m->specular > 0.0f) {
                float nh = vec_dot(n, vec_normalize(vec_add(L, view)));
                if (nh > 0.0f)
                    high += m->specular * powf(nh, 1.0f / m->roughness);
            }
        }
        Vec3 term = vec_add(diff, vec3(high, high, high));
        if (term.x <= 0.0f && term.y <= 0.0f && term.z <= 0.0f)
            continue; /* nothing to add: skip the shadow ray */
        if (!l->shadowless) {
            Ray sh = ray_make(shade_spawn_origin(sf->p, sf->ng, L, r->o), L, dist);
            st->shadow++;
            if (accel_occluded(a, &sh, st))
                continue;
        }
        c = vec_add(c, vec_scale(vec_mul(l->color, term), fade(l, dist)));
    }
    return c;
}

Vec3 shade_trace(const Scene *s, const Accel *a, const Ray *r, int level, RayStats *st)
{
    if (level > s->max_depth)
        return vec3(0, 0, 0);
    PrimHit h;
    int i = accel_closest(a, r, &h, st);
    if (i < 0)
        return s->background;
    const Prim *p = &a->prims[i];
    const Material *m = &s->materials[p->material];
    Surface sf;
    prim_surface(p, r, &h, &sf);
    Vec3 c = direct(s, a, m, &sf, r, st);
    /* A reflected ray past the depth limit would return black: skip it. */
    if (m->reflection > 0.0f && level < s->max_depth) {
        Vec3 d = vec_reflect(r->d, sf.ns);
        Ray rr = ray_make(shade_spawn_origin(sf.p, sf.ng, d, r->o), d, INFINITY);
        st->reflection++;
        c = vec_madd(c, shade_trace(s, a, &rr, level + 1, st), m->reflection);
    }
    return c;
}
