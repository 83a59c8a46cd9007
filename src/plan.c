/*
 * plan.c - the render plan (see plan.h): settings resolved, the scene put
 * in render coordinates, and the decisions derived from it.
 */
#include "lancer/plan.h"

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "lancer/bvh.h"
#include "lancer/image.h"
#include "dvec.h"

PlanOptions plan_options(void)
{
    PlanOptions o;
    memset(&o, 0, sizeof o);
    o.threads = 1;
    o.scale = 1.0;
    o.adc_bailout = -1.0;
    o.aa_threshold = -1.0;
    return o;
}

/* The volume of a solid primitive (one prim_inside can hold a point in). */
static double solid_volume(const Prim *p)
{
    static const double ball = 4.0 / 3.0 * 3.14159265358979323846;
    switch (p->kind) {
    case PRIM_SPHERE:
        return ball * (double)p->g.sphere.r * p->g.sphere.r * p->g.sphere.r;
    case PRIM_BOX: {
        const Box *b = &p->g.box;
        return ((double)b->hi.x - b->lo.x) * ((double)b->hi.y - b->lo.y) * ((double)b->hi.z - b->lo.z);
    }
    case PRIM_OBOX: { /* in double: the product of three float axes may pass float's range */
        const OBox *b = &p->g.obox;
        const double u[3] = {b->u.x, b->u.y, b->u.z}, v[3] = {b->v.x, b->v.y, b->v.z}, w[3] = {b->w.x, b->w.y, b->w.z};
        double vw[3];
        d3_cross(vw, v, w);
        return 8.0 * fabs(d3_dot(u, vw));
    }
    case PRIM_ELLIPSOID: {
        const double *m = p->g.ell.e->m; /* its rows' triple product */
        double c[3];
        d3_cross(c, m + 3, m + 6);
        return ball * fabs(d3_dot(m, c));
    }
    default:
        return INFINITY;
    }
}

/* For a transparent bounded primitive whose box meets one of the plan's
 * floors: the distance from the floor within which a point of it counts as
 * touching it (shade.c, floors_first). Rounding a number x to float moves
 * it by up to 2^-24 |x|, so the plan's move can put a face up to 2^-24 of
 * the terms that place it along the floor's normal n from where the scene
 * has it (a centre and half-axes for an oriented box: at most twice the
 * box's own coordinates, the sum of |n_i| max(|lo_i|, |hi_i|)), and the floor up to
 * 2^-24 |d| and that much again by its tilt. Else 0: spheres and ellipsoids
 * too, which touch a plane at a point, where no ray leaves them for the
 * floor but on a line of measure zero. */
static float floor_band(const Scene *s, const RenderPlan *p, int i)
{
    const Prim *q = &s->prims[i];
    const Material *m = &s->materials[q->material];
    float lo[3], hi[3];
    if (m->filter + m->transmit <= 0.0f || q->kind == PRIM_SPHERE || q->kind == PRIM_ELLIPSOID ||
        !bvh_prim_bounds(q, lo, hi))
        return 0.0f;
    float band = 0.0f;
    for (int j = 0; j < p->nfloors; j++) {
        const Plane *f = &s->prims[p->floors[j]].g.plane;
        float c = 0.0f, r = 0.0f, along = 0.0f; /* the box along n: centre, half-extent, magnitude */
        for (int a = 0; a < 3; a++) {
            const float n = fabsf(vec_comp(f->n, a));
            c += vec_comp(f->n, a) * 0.5f * (lo[a] + hi[a]);
            r += n * 0.5f * (hi[a] - lo[a]);
            along += n * fmaxf(fabsf(lo[a]), fabsf(hi[a]));
        }
        const float b = 0x1p-23f * (along + fabsf(f->d)) + FLT_MIN; /* (not 0, which says no floor) */
        if (fabsf(c - f->d) <= r + 2.0f * b) /* the box reaches the floor's band */
            band = fmaxf(band, b);
    }
    return band;
}

int plan_interiors_at(const Scene *s, Vec3 q, Interiors *in)
{
    int prim[LIMIT_INTERIORS + 1], n = 0, lost = 0;
    double vol[LIMIT_INTERIORS + 1];
    for (int i = 0; i < s->nprims; i++) {
        if (!prim_inside(&s->prims[i], q))
            continue;
        /* Outermost first, so that the last, the medium a ray starts in, is
         * the innermost: a solid inside another has the smaller volume. */
        double v = solid_volume(&s->prims[i]);
        int k = n++;
        for (; k > 0 && vol[k - 1] < v; k--) {
            vol[k] = vol[k - 1];
            prim[k] = prim[k - 1];
        }
        vol[k] = v;
        prim[k] = i;
        if (n > LIMIT_INTERIORS) { /* full: the outermost goes */
            n--;
            lost++;
            memmove(prim, prim + 1, sizeof(int) * (size_t)n);
            memmove(vol, vol + 1, sizeof(double) * (size_t)n);
        }
    }
    in->n = n;
    memcpy(in->prim, prim, sizeof(int) * (size_t)n);
    return lost;
}

/* Where the box lo..hi lies against plane pl and point l: 1 when every
 * corner is farther than pad on l's side of the plane, -1 when every corner
 * is farther than pad on the other side, 2 when it is clear of the slab
 * between the plane and the parallel plane through l (where every segment
 * from the plane to l lies), 0 else. */
static int box_side(const Plane *pl, const float lo[3], const float hi[3], Vec3 l, double pad)
{
    double sl = (double)vec_dot(pl->n, l) - pl->d;
    if (fabs(sl) <= pad)
        return 0;
    double mn = INFINITY, mx = -INFINITY; /* the corners' distances, positive on l's side */
    for (int c = 0; c < 8; c++) {
        double v = -(double)pl->d;
        for (int k = 0; k < 3; k++)
            v += (double)vec_comp(pl->n, k) * (c >> k & 1 ? hi[k] : lo[k]);
        v = sl > 0.0 ? v : -v;
        mn = fmin(mn, v);
        mx = fmax(mx, v);
    }
    if (mx < -pad)
        return -1;
    if (mn > fabs(sl) + pad)
        return 2;
    return mn > pad ? 1 : 0;
}

/* Whether primitive q may stand between point light l and some point of
 * primitive p (p != q), conservatively: boxes grown by pad, and any
 * doubt a yes. A segment from a point of p to l lies in the box of p's box
 * and l; a plane is crossed only by segments from its other side. */
static int may_shadow(const Prim *q, const Prim *p, Vec3 l, double pad)
{
    float qlo[3], qhi[3], plo[3], phi[3];
    int qb = bvh_prim_bounds(q, qlo, qhi), pb = bvh_prim_bounds(p, plo, phi);
    if (!qb && !pb)
        return 1; /* two planes */
    if (!pb) { /* p a plane: q must reach into the slab between it and l */
        int side = box_side(&p->g.plane, qlo, qhi, l, pad);
        return side != -1 && side != 2;
    }
    if (!qb) { /* q a plane: p must reach its far side from l */
        int side = box_side(&q->g.plane, plo, phi, l, pad);
        return side != 1 && side != 2;
    }
    for (int k = 0; k < 3; k++) {
        double lo = fmin(plo[k], vec_comp(l, k)) - pad, hi = fmax(phi[k], vec_comp(l, k)) + pad;
        if (qhi[k] < lo || qlo[k] > hi)
            return 0;
    }
    return 1;
}

/* 1 when the inside of primitive p may be seen: a closed solid that lets
 * light through (a refracted ray travels inside it), or around the eye
 * (within pad of its box). There, its far wall faces a light outside, and
 * the shadow ray leaves through its near wall: a solid shadows its own
 * inside from every light. */
static int inside_seen(const Scene *s, const Prim *p, double pad)
{
    if (p->kind != PRIM_SPHERE && p->kind != PRIM_BOX && p->kind != PRIM_OBOX && p->kind != PRIM_ELLIPSOID)
        return 0;
    const Material *m = &s->materials[p->material];
    if (m->transmit > 0.0f || m->filter > 0.0f)
        return 1;
    float lo[3], hi[3];
    bvh_prim_bounds(p, lo, hi);
    for (int k = 0; k < 3; k++)
        if (vec_comp(s->camera.eye, k) < lo[k] - pad || vec_comp(s->camera.eye, k) > hi[k] + pad)
            return 0;
    return 1;
}

/* 1 when no primitive of s can shadow any point of any primitive from
 * light l, so that its shadow rays would all find nothing: a point light
 * (a solid shadows itself from part of an area light), no PN patch (a
 * curved patch may shadow itself), no solid whose inside may be seen
 * (inside_seen()), and no pair of primitives that may_shadow() cannot
 * rule out. The pad covers spawned origins and the shadow ray's rounding:
 * a relative 2^-10 of the scene's extent. */
static int light_is_clear(const Scene *s, const Light *l)
{
    if (l->area_n1 * l->area_n2 != 1 || s->nprims > PLAN_CLEAR_PRIMS)
        return 0;
    double ext = vec_max_abs(l->pos);
    for (int i = 0; i < s->nprims; i++) {
        float lo[3], hi[3];
        if (s->prims[i].kind == PRIM_PN)
            return 0;
        if (bvh_prim_bounds(&s->prims[i], lo, hi))
            for (int k = 0; k < 3; k++)
                ext = fmax(ext, fmax(fabs(lo[k]), fabs(hi[k])));
        else
            ext = fmax(ext, fabs(s->prims[i].g.plane.d));
    }
    if (!isfinite(ext))
        return 0;
    double pad = ext * 0x1p-10 + 1e-30;
    for (int i = 0; i < s->nprims; i++)
        if (inside_seen(s, &s->prims[i], pad))
            return 0;
    for (int i = 0; i < s->nprims; i++)
        for (int j = 0; j < s->nprims; j++)
            if (i != j && may_shadow(&s->prims[j], &s->prims[i], l->pos, pad))
                return 0;
    return 1;
}

/* The largest singular value of the 3x3 matrix m (rows): the square root
 * of the largest eigenvalue of m^T m, by the closed form of Smith, "Eigenvalues
 * of a symmetric 3 x 3 matrix" (CACM 1961), exact to rounding relative to
 * itself however small the others are. */
static double largest_singular(const double m[9])
{
    double s[9];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            s[3 * i + j] = m[i] * m[j] + m[3 + i] * m[3 + j] + m[6 + i] * m[6 + j];
    double q = (s[0] + s[4] + s[8]) / 3.0, p1 = s[1] * s[1] + s[2] * s[2] + s[5] * s[5];
    double p2 = (s[0] - q) * (s[0] - q) + (s[4] - q) * (s[4] - q) + (s[8] - q) * (s[8] - q) + 2.0 * p1;
    if (!(p2 > 0.0))
        return sqrt(q);
    double p = sqrt(p2 / 6.0), b[9];
    for (int k = 0; k < 9; k++)
        b[k] = (s[k] - (k % 4 == 0 ? q : 0.0)) / p;
    double r = (b[0] * (b[4] * b[8] - b[5] * b[7]) - b[1] * (b[3] * b[8] - b[5] * b[6]) +
                b[2] * (b[3] * b[7] - b[4] * b[6])) / 2.0;
    return sqrt(q + 2.0 * p * cos(acos(fmin(1.0, fmax(-1.0, r))) / 3.0));
}

/* 0, or -2 with "line:col: ..." in err for the first ellipsoid of s too
 * flat, seen from the eye, for the robust routine to certify its hits: its
 * thinnest half-axis, 1 over A's largest singular value, over its distance
 * from the eye plus its largest, M's. */
static int too_flat(const Scene *s, char *err, size_t errlen)
{
    for (int i = 0; i < s->nprims; i++) {
        if (s->prims[i].kind != PRIM_ELLIPSOID)
            continue;
        const Ellipsoid *e = s->prims[i].g.ell.e;
        double d2 = 0.0;
        for (int k = 0; k < 3; k++) {
            double eye = s->placed ? s->camera.eye_at[k] : (double)vec_comp(s->camera.eye, k);
            d2 += (e->m[9 + k] - eye) * (e->m[9 + k] - eye);
        }
        double flat = 1.0 / largest_singular(e->a) / (sqrt(d2) + largest_singular(e->m));
        if (!(flat >= PLAN_FLATTEST)) {
            int idx = s->prims[i].g.ell.index;
            snprintf(err, errlen,
                     "%d:%d: sphere: too flat to trace from this camera: its thinnest half-axis over its distance "
                     "from the eye plus its largest is %.3g, below 2^-36 (%.3g), down to which lancer certifies hits",
                     s->ellipsoid_at ? s->ellipsoid_at[idx][0] : 0, s->ellipsoid_at ? s->ellipsoid_at[idx][1] : 0,
                     flat, PLAN_FLATTEST);
            return -2;
        }
    }
    return 0;
}

static int fail(char *err, size_t errlen, const char *msg)
{
    snprintf(err, errlen, "%s", msg);
    return -1;
}

/* POV-Ray's trace.cpp splits the index range [a, b] at its middle until
 * neighbours remain, averaging the four corner samples of each cell; along
 * one axis, each leaf pair shares the weight of its branch. */
static void area_rec(int a, int b, float wt, float *w)
{
    if (b - a <= 1) {
        w[a] += wt / 2;
        w[b] += wt / 2;
        return;
    }
    area_rec(a, (a + b) / 2, wt / 2, w);
    area_rec((a + b + 1) / 2, b, wt / 2, w);
}

void plan_area_weights(int n, float *w)
{
    memset(w, 0, sizeof(float) * (size_t)n);
    if (n == 1)
        w[0] = 1.0f;
    else
        area_rec(0, n - 1, 1.0f, w);
}

/* Marks the corners of the cell u1..u2 x v1..v2 at level lv, and of the
 * cells it is split into whatever its corners let through: as shade.c's
 * area_cell, up to the test of its samples. */
static void area_mark(int n1, int u1, int v1, int u2, int v2, int lv, int adaptive, unsigned char *mark)
{
    mark[v1 * n1 + u1] = mark[v1 * n1 + u2] = mark[v2 * n1 + u1] = mark[v2 * n1 + u2] = 1;
    if ((u2 - u1 > 1 || v2 - v1 > 1) && lv < adaptive - 1) {
        int ul = (u1 + u2) / 2, uh = (u1 + u2 + 1) / 2, vl = (v1 + v2) / 2, vh = (v1 + v2 + 1) / 2;
        area_mark(n1, u1, v1, ul, vl, lv + 1, adaptive, mark);
        area_mark(n1, uh, v1, u2, vl, lv + 1, adaptive, mark);
        area_mark(n1, u1, vh, ul, v2, lv + 1, adaptive, mark);
        area_mark(n1, uh, vh, u2, v2, lv + 1, adaptive, mark);
    }
}

int plan_area_first(int n1, int n2, int adaptive, int *first)
{
    unsigned char mark[LIMIT_AREA_SAMPLES * LIMIT_AREA_SAMPLES];
    int n = 0;
    memset(mark, adaptive == 0, (size_t)(n1 * n2));
    if (adaptive > 0)
        area_mark(n1, 0, 0, n1 - 1, n2 - 1, 0, adaptive, mark);
    for (int k = 0; k < n1 * n2; k++)
        if (mark[k])
            first[n++] = k;
    return n;
}

/* The samples of area light l, once for every shadow ray that needs them. */
static int area_table(const Light *l, PlanArea *a)
{
    int n1 = l->area_n1, n2 = l->area_n2;
    a->point = malloc((sizeof(Vec3) + sizeof(float) + sizeof(int)) * (size_t)(n1 * n2));
    if (!a->point)
        return -1;
    a->weight = (float *)(void *)(a->point + n1 * n2);
    a->first = (int *)(void *)(a->weight + n1 * n2);
    a->nfirst = plan_area_first(n1, n2, l->adaptive, a->first);
    float w1[LIMIT_AREA_SAMPLES], w2[LIMIT_AREA_SAMPLES];
    plan_area_weights(n1, w1);
    plan_area_weights(n2, w2);
    for (int j = 0; j < n2; j++)
        for (int i = 0; i < n1; i++) {
            float su = n1 > 1 ? (float)i / (float)(n1 - 1) - 0.5f : 0.0f;
            float sv = n2 > 1 ? (float)j / (float)(n2 - 1) - 0.5f : 0.0f;
            a->point[j * n1 + i] = vec_madd(vec_madd(l->pos, l->area_u, su), l->area_v, sv);
            a->weight[j * n1 + i] = w1[i] * w2[j];
        }
    return 0;
}

int plan_build(RenderPlan *p, Scene *s, const PlanOptions *o, char *err, size_t errlen)
{
    memset(p, 0, sizeof *p);
    p->scene = s;
    p->width = o->width ? o->width : s->image.width;
    p->height = o->height ? o->height : s->image.height;
    p->spp = o->spp ? o->spp : s->image.spp;
    p->max_depth = o->max_depth ? o->max_depth : s->image.max_depth;
    p->threads = o->threads > 0 ? o->threads : 1;
    p->variant = o->classic || s->image.classic ? PRIM_CLASSIC : PRIM_ROBUST;
    if (p->width < 1 || p->width > LIMIT_IMAGE_SIDE || p->height < 1 || p->height > LIMIT_IMAGE_SIDE ||
        (long)p->width * p->height > LIMIT_IMAGE_PIXELS) {
        snprintf(err, errlen, "a %dx%d image has more than the %ld pixels lancer renders", p->width, p->height,
                 LIMIT_IMAGE_PIXELS);
        return -1;
    }
    p->x0 = p->y0 = 0;
    p->x1 = p->width;
    p->y1 = p->height;
    if (o->region) {
        if (!(0 <= o->rx0 && o->rx0 < o->rx1 && o->rx1 <= p->width && 0 <= o->ry0 && o->ry0 < o->ry1 &&
              o->ry1 <= p->height)) {
            snprintf(err, errlen, "the region %d:%d,%d:%d is empty or not inside the %dx%d image", o->rx0, o->rx1,
                     o->ry0, o->ry1, p->width, p->height);
            return -1;
        }
        p->x0 = o->rx0;
        p->x1 = o->rx1;
        p->y0 = o->ry0;
        p->y1 = o->ry1;
    }
    if (o->max_depth && (o->max_depth < 1 || o->max_depth > LIMIT_DEPTH)) {
        snprintf(err, errlen, "max_depth must be a whole number from 1 to %d", LIMIT_DEPTH);
        return -1;
    }
    if (p->spp < 1 || p->spp > LIMIT_SPP) {
        snprintf(err, errlen, "spp must be a whole number from 1 to %d", LIMIT_SPP);
        return -1;
    }
    p->adc_bailout = o->adc_bailout >= 0.0 ? (float)o->adc_bailout : s->image.adc_bailout;
    p->aa_threshold = o->aa_threshold >= 0.0 ? (float)o->aa_threshold : s->image.aa_threshold;
    if (!(p->aa_threshold >= 0.0f) || !isfinite(p->aa_threshold))
        return fail(err, errlen, "aa_threshold must be a number from 0 up");
    if (!(p->adc_bailout >= 0.0f && p->adc_bailout < 1.0f)) /* at 1 POV-Ray shades no surface (docs/povray-rules.md) */
        return fail(err, errlen, "adc_bailout must be a number from 0 up to 1, 1 excluded");
    if (o->area_samples < 0 || o->area_samples > LIMIT_AREA_SAMPLES || o->area_adaptive < 0 ||
        o->area_adaptive > LIMIT_AREA_ADAPTIVE + 1)
        return fail(err, errlen, "area light setting out of range");
    for (int i = 0; i < s->nlights; i++) {
        Light *l = &s->lights[i];
        if (l->area_n1 * l->area_n2 == 1 && vec_max_abs(l->area_u) + vec_max_abs(l->area_v) == 0.0f)
            continue; /* a point light */
        if (o->area_samples)
            l->area_n1 = l->area_n2 = o->area_samples;
        if (o->area_adaptive)
            l->adaptive = o->area_adaptive;
    }
    const long long samples = scene_light_samples(s);
    if (samples > LIMIT_LIGHT_SAMPLES) { /* (a scene the parser made is within it) */
        if (o->area_samples)
            snprintf(err, errlen, "%d area samples a side would give the lights %lld samples, more than %d in all",
                     o->area_samples, samples, LIMIT_LIGHT_SAMPLES);
        else
            snprintf(err, errlen, "the lights take %lld samples, more than %d in all", samples, LIMIT_LIGHT_SAMPLES);
        return -1;
    }
    if (o->pn_mode < 0 || o->pn_mode > PN_FAST + 1)
        return fail(err, errlen, "pn_mode out of range");
    for (int i = 0; i < s->nprims; i++)
        if (s->prims[i].kind == PRIM_PN && o->pn_mode)
            s->prims[i].g.pn.mode = o->pn_mode - 1;
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
    if (too_flat(s, err, errlen) != 0)
        return -2;
    for (int i = 0; i < s->nprims; i++) /* those the move left */
        if (s->prims[i].kind == PRIM_PN)
            p->patches[p->variant == PRIM_CLASSIC ? PN_FAST : PN_EXACT]++; /* as prim.c traces them */
    for (int i = 0; i < s->nmaterials; i++) {
        const Material *m = &s->materials[i];
        p->transparent |= m->filter + m->transmit > 0.0f;
        p->reflective |= m->reflection > 0.0f;
    }
    if (p->transparent || o->full) /* only refraction reads the solids a ray is in */
        p->camera_in_lost = plan_interiors_at(s, s->camera.eye, &p->camera_in);
    if (p->transparent) {
        for (int i = 0; i < s->nprims; i++) {
            const Material *m = &s->materials[s->prims[i].material];
            if (s->prims[i].kind != PRIM_PLANE || m->filter + m->transmit > 0.0f)
                continue;
            int *f = realloc(p->floors, sizeof(int) * (size_t)(p->nfloors + 1));
            if (!f) {
                plan_free(p);
                return fail(err, errlen, "out of memory");
            }
            p->floors = f;
            p->floors[p->nfloors++] = i;
        }
    }
    if (p->nfloors && !(p->floor_band = calloc((size_t)s->nprims, sizeof(float)))) {
        plan_free(p);
        return fail(err, errlen, "out of memory");
    }
    int touch = 0; /* primitives that may stand on a floor: without any, no floors */
    for (int i = 0; p->nfloors && i < s->nprims; i++)
        touch += (p->floor_band[i] = floor_band(s, p, i)) > 0.0f;
    if (!touch) {
        free(p->floors);
        free(p->floor_band);
        p->floors = NULL;
        p->floor_band = NULL;
        p->nfloors = 0;
    }
    if (s->nlights > 0) {
        p->shadow = malloc(sizeof(PlanShadow) * (size_t)s->nlights);
        p->area = calloc((size_t)s->nlights, sizeof(PlanArea));
        for (int i = 0; p->area && i < s->nlights; i++)
            if (s->lights[i].area_n1 * s->lights[i].area_n2 > 1 && area_table(&s->lights[i], &p->area[i]) != 0) {
                plan_free(p);
                return fail(err, errlen, "out of memory");
            }
        if (!p->shadow || !p->area) {
            plan_free(p);
            return fail(err, errlen, "out of memory");
        }
    }
    p->full = o->full;
    /* The classic routines are not exact: a far grazing ray can hit a
     * sphere that the tree's boxes would have kept it from testing, so with
     * them the loop's picture is not the tree's, and the tree stays. */
    p->loop = o->accel == 2 || (o->accel == 0 && !o->full && p->variant == PRIM_ROBUST && s->nprims <= PLAN_LOOP_PRIMS);
    for (int i = 0; i < s->nlights; i++)
        p->shadow[i] = s->lights[i].shadowless                  ? PLAN_SHADOW_NONE
                       : !o->full && light_is_clear(s, &s->lights[i]) ? PLAN_SHADOW_CLEAR
                       : p->transparent                         ? PLAN_SHADOW_FILTERED
                                                                : PLAN_SHADOW_OPAQUE;
    return 0;
}

/* Appends a note, if there is room. */
static void note(PlanNote *notes, int max, int *n, int skipped, const char *what, const char *why)
{
    if (*n < max) {
        PlanNote *t = &notes[*n];
        snprintf(t->what, sizeof t->what, "%s", what);
        snprintf(t->why, sizeof t->why, "%s", why);
        t->skipped = skipped;
    }
    (*n)++;
}

int plan_notes(const RenderPlan *p, PlanNote *notes, int max)
{
    const Scene *s = p->scene;
    int n = 0, smooth = 0;
    char what[64], why[192];
    for (int i = 0; i < s->nlights; i++) {
        static const char *const how[] = {
            "a shadowless light",
            "a point light that nothing can stand in front of: no primitive lies between it and another's points",
            "any hit blocks it: any-hit queries, in packets for a point light",
            "transparent surfaces filter it: every surface on the way is found"};
        snprintf(what, sizeof what, "shadow rays toward light %d", i);
        PlanShadow m = p->shadow[i];
        int clear_possible = !s->lights[i].shadowless && s->lights[i].area_n1 * s->lights[i].area_n2 == 1;
        snprintf(why, sizeof why, "%s%s", how[m],
                 p->full && clear_possible ? " (--no-plan: not looked for)" : "");
        note(notes, max, &n, m <= PLAN_SHADOW_CLEAR, what, why);
    }
    snprintf(why, sizeof why,
             p->loop ? "%d primitives: a plain loop over them is faster than a tree"
             : p->variant == PRIM_CLASSIC && s->nprims <= PLAN_LOOP_PRIMS
                 ? "%d primitives, traced by the classic routines, whose answers a loop could change"
                 : "%d primitives",
             s->nprims);
    note(notes, max, &n, p->loop, "the BVH", why);
    note(notes, max, &n, !p->reflective && !p->full, "reflection rays",
         p->reflective    ? "some material reflects"
         : p->full        ? "no material reflects; traced all the same, weighed 0 (--no-plan)"
         : p->transparent ? "no material reflects (total internal reflection in a transparent one is traced, "
                            "and counted as reflection rays)"
                          : "no material reflects");
    note(notes, max, &n, !p->transparent && !p->full, "refraction rays and interior lists",
         p->transparent ? "some material lets light through"
         : p->full      ? "no material lets light through; traced all the same, weighed 0 (--no-plan)"
                        : "no material lets light through");
    if (s->vanished) {
        snprintf(why, sizeof why,
                 "%d box%s or triangle%s too thin, seen from this far, for a double to tell their sides apart: no "
                 "ray can hit them",
                 s->vanished, s->vanished > 1 ? "es" : "", s->vanished > 1 ? "s" : "");
        note(notes, max, &n, 1, "objects too thin to see", why);
    }
    for (int i = 0; i < s->nprims; i++)
        smooth += s->prims[i].kind == PRIM_SMOOTH_TRIANGLE || s->prims[i].kind == PRIM_PN;
    snprintf(why, sizeof why, smooth ? "%d smooth triangles or PN patches" : "no smooth triangle or PN patch: the shading normal is the geometric one", smooth);
    note(notes, max, &n, !smooth, "normal interpolation", why);
    int asked = 0; /* fast patches that the robust variant traces as exact ones */
    for (int i = 0; i < s->nprims; i++)
        asked += p->variant == PRIM_ROBUST && s->prims[i].kind == PRIM_PN && s->prims[i].g.pn.mode == PN_FAST;
    snprintf(why, sizeof why,
             asked ? "%d patches in exact mode, %d in fast mode (fast mode, asked for by %d, is traced exact by the "
                     "robust variant: as fast or faster)"
             : p->patches[0] + p->patches[1] ? "%d patches in exact mode, %d in fast mode"
                                             : "no PN patch",
             p->patches[PN_EXACT], p->patches[PN_FAST], asked);
    note(notes, max, &n, p->patches[0] + p->patches[1] == 0, "PN patch tracing", why);
    return n;
}

void plan_free(RenderPlan *p)
{
    for (int i = 0; p->area && i < p->scene->nlights; i++)
        free(p->area[i].point);
    free(p->area);
    free(p->shadow);
    free(p->floors);
    free(p->floor_band);
    memset(p, 0, sizeof *p);
}
