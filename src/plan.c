/*
 * plan.c - the render plan (see plan.h): settings resolved, the scene put
 * in render coordinates, and the decisions derived from it.
 */
#include "lancer/plan.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "lancer/image.h"

PlanOptions plan_options(void)
{
    PlanOptions o;
    memset(&o, 0, sizeof o);
    o.threads = 1;
    o.scale = 1.0;
    return o;
}

void plan_interiors_at(const Scene *s, Vec3 q, Interiors *in)
{
    in->n = 0;
    for (int i = 0; i < s->nprims && in->n < LIMIT_INTERIORS; i++)
        if (prim_inside(&s->prims[i], q))
            in->prim[in->n++] = i;
}

static int fail(char *err, size_t errlen, const char *msg)
{
    snprintf(err, errlen, "%s", msg);
    return -1;
}

int plan_build(RenderPlan *p, Scene *s, const PlanOptions *o, char *err, size_t errlen)
{
    memset(p, 0, sizeof *p);
    p->scene = s;
    p->width = o->width ? o->width : s->image.width;
    p->height = o->height ? o->height : s->image.height;
    p->spp = o->spp ? o->spp : s->image.spp;
    p->max_depth = s->image.max_depth;
    p->threads = o->threads > 0 ? o->threads : 1;
    p->variant = o->classic || s->image.classic ? PRIM_CLASSIC : PRIM_ROBUST;
    if (p->width < 1 || p->width > LIMIT_IMAGE_SIDE || p->height < 1 || p->height > LIMIT_IMAGE_SIDE ||
        (long)p->width * p->height > LIMIT_IMAGE_PIXELS) {
        snprintf(err, errlen, "a %dx%d image has more than the %ld pixels lancer renders", p->width, p->height,
                 LIMIT_IMAGE_PIXELS);
        return -1;
    }
    if (p->spp < 1 || p->spp > LIMIT_SPP) {
        snprintf(err, errlen, "spp must be a whole number from 1 to %d", LIMIT_SPP);
        return -1;
    }
    if (o->pn_mode < 0 || o->pn_mode > PN_FAST + 1)
        return fail(err, errlen, "pn_mode out of range");
    for (int i = 0; i < s->nprims; i++) {
        PnRef *r = &s->prims[i].g.pn;
        if (s->prims[i].kind != PRIM_PN)
            continue;
        if (o->pn_mode)
            r->mode = o->pn_mode - 1;
        p->patches[p->variant == PRIM_CLASSIC ? PN_FAST : r->mode]++;
    }
    double scale = o->move ? o->scale : 1.0, t[3] = {0.0, 0.0, 0.0};
    if (o->move) {
        memcpy(t, o->translate, sizeof t);
        if (!(scale > 0.0) || !isfinite(scale) || !isfinite(t[0]) || !isfinite(t[1]) || !isfinite(t[2]))
            return fail(err, errlen, "the scene degenerates at that scale or offset");
    }
    /* Robust mode renders in camera-relative coordinates: the scene, kept
     * in double, is moved so that the eye sits at the origin and only then
     * rounded to float, so that what is near the camera is as precise as
     * in a scene at the origin, wherever the camera is; float spawn origins
     * far out would otherwise sit on a coarse grid. The options' move and
     * this one are one move, so nothing is rounded in between. */
    if (p->variant == PRIM_ROBUST && !o->world) {
        for (int k = 0; k < 3; k++) {
            double eye = s->placed ? s->camera.eye_at[k] : (double)vec_comp(s->camera.eye, k);
            p->offset[k] = eye * scale + t[k]; /* the eye, moved by the options */
            t[k] -= p->offset[k];
        }
        if (scene_transform(s, scale, t) != 0)
            return fail(err, errlen,
                        o->move ? "the scene degenerates at that scale or offset"
                                : "the scene degenerates in camera-relative coordinates");
    } else if (o->move && scene_transform(s, scale, t) != 0) {
        return fail(err, errlen, "the scene degenerates at that scale or offset");
    }
    plan_interiors_at(s, s->camera.eye, &p->camera_in);
    for (int i = 0; i < s->nmaterials; i++) {
        const Material *m = &s->materials[i];
        p->transparent |= m->filter + m->transmit > 0.0f;
        p->reflective |= m->reflection > 0.0f;
    }
    if (s->nlights > 0) {
        p->shadow = malloc(sizeof(PlanShadow) * (size_t)s->nlights);
        if (!p->shadow)
            return fail(err, errlen, "out of memory");
    }
    for (int i = 0; i < s->nlights; i++)
        p->shadow[i] = s->lights[i].shadowless ? PLAN_SHADOW_NONE
                       : p->transparent        ? PLAN_SHADOW_FILTERED
                                               : PLAN_SHADOW_OPAQUE;
    return 0;
}

void plan_free(RenderPlan *p)
{
    free(p->shadow);
    memset(p, 0, sizeof *p);
}
