/*
 * plan.c - the render plan (see plan.h): settings resolved, the scene put
 * in render coordinates, and the decisions derived from it.
 */
#include "lancer/plan.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "lancer/image.h"

PlanOptions plan_options(void)
{
    PlanOptions o;
    memset(&o, 0, sizeof o);
    o.threads = 1;
    o.scale = 1.0f;
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
    if (o->move && (!(o->scale > 0.0f) || !vec_is_finite(o->translate) ||
                    scene_transform(s, o->scale, o->translate) != 0))
        return fail(err, errlen, "the scene degenerates at that scale or offset");
    /* Robust mode renders in camera-relative coordinates: subtracting the
     * eye is exact for every coordinate within a factor of two of it
     * (Sterbenz), so a scene far from the origin keeps the precision it
     * would have near it; float spawn origins far out would otherwise sit
     * on a coarse grid. */
    if (p->variant == PRIM_ROBUST && !o->world) {
        p->offset = s->camera.eye;
        if (scene_transform(s, 1.0f, vec_neg(p->offset)) != 0)
            return fail(err, errlen, "the scene degenerates in camera-relative coordinates");
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
