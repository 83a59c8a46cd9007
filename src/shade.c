/*
 * shade.c - Whitted shading with POV-Ray 3.7's classic finish (shade.h).
 *
 * Every secondary ray starts at prim_spawn_origin(), never at the raw hit
 * point, and accepts any t > 0: the offset, derived from the hit's own
 * error bound, not a t_min epsilon, keeps it off its own surface (and,
 * next to a mesh's edge, edge_clear() off the faces beyond it; off a huge
 * triangle, whose offset may pass a surface standing on it, edge_clear()
 * takes the first surface on the line from the point). POV-Ray
 * itself ignores hits closer than 1e-4 (and shadow occluders within 1e-3 of
 * either end); the two differ only on surfaces that touch, a line of pixels
 * at most. At the light's end a shadow ray stops short (light_reach).
 */
#include "lancer/shade.h"
#include "lancer/stop.h"

#include <string.h>

/* POV-Ray skips a light when N.L is below this (its EPSILON). */
#define LIGHT_EPSILON 1e-10f
/* The faces past which edge_clear() moves a ray, at most, and how far
 * from its origin it looks for them, in perr's (Surface). */
#define EDGE_STEPS 8
#define EDGE_PROBE (4.0f * (float)PRIM_EDGE_REACH)
/* The first hits edge_clear() finds that wait for their rays' traces, at
 * most. A packet's refracted rays wait together, then its mirror rays: a
 * packet's worth, and room for the bent rays still waiting where others
 * went straight through, each traced at once, a level deeper. Past it, a
 * ray is traced as it starts. */
#define EDGE_GIVEN 16
/* Out of line and away from the shading's loops: the work for rays next
 * to a mesh's edge, which few rays do. */
#ifdef __GNUC__
#define EDGE_COLD __attribute__((noinline, cold))
#else
#define EDGE_COLD
#endif

/* A ray's first hit, found before the ray is traced (edge_clear). */
typedef struct {
    int prim;
    PrimHit h;
    Ray r; /* the ray's line from behind its point, which h is a hit of */
} Given;

/* The first hits found for rays not yet traced, each with its ray's
 * address: the trace that follows takes them (given()). */
typedef struct {
    int n;
    const Ray *ray[EDGE_GIVEN];
    Given g[EDGE_GIVEN];
} Givens;

typedef struct {
    const RenderPlan *p;
    const Scene *s; /* the plan's */
    const Accel *a;
    RayStats *st;
    Givens *given;
    int *continued; /* continued rays in the recursion now (LIMIT_CONTINUED) */
    const volatile sig_atomic_t *stop; /* NULL, or nonzero: shade no more */
} Ctx;

/* Light attenuation: 2 / (1 + (d/fade_distance)^fade_power), or 1. */
static float fade(const Light *l, float dist)
{
    if (l->fade_power <= 0.0f)
        return 1.0f;
    return 2.0f / (1.0f + powf(dist / l->fade_distance, l->fade_power));
}

static const Material *material_of(const Ctx *c, int prim) { return &c->s->materials[c->s->prims[prim].material]; }

/* color*filter + transmit: what a surface lets through, per channel. */
static Vec3 pass_factor(const Material *m)
{
    return vec_add(vec_scale(m->color, m->filter), vec3(m->transmit, m->transmit, m->transmit));
}

/* A shadow ray's tmax towards a light (or a light's sample) dist away: a
 * part in 2^13 short of it, so that a surface through the light itself (a
 * lamp set in a ceiling) does not shadow it by the roundings of the ray, as
 * POV-Ray ignores an occluder within SHADOW_TOLERANCE, 10^-3, of the light
 * (trace.cpp). A part of the distance, not a length: the picture does not
 * change with the scene's scale. */
static inline float light_reach(float dist) { return dist * (1.0f - 0x1p-13f); }

/* The distance from p to q, and the unit direction towards q into *dir
 * (not a number when they coincide: callers check the distance). */
static float toward(Vec3 p, Vec3 q, Vec3 *dir)
{
    Vec3 d = vec_sub(q, p);
    float dist = vec_length(d);
    *dir = vec_scale(d, 1.0f / dist);
    return dist;
}

/* The surface that the ray from sf's point itself crosses first along r's
 * direction, when r, spawned off sf, does not meet it: the spawn offset,
 * which clears the triangle test's error band, has taken r's origin past
 * it or beside it, as where the solid is thinner than the offset (a long
 * triangle's offset, near a sharp apex). A ray along r's line from `near`
 * behind the point meets every surface around it; those that the line
 * from the point does not cross ahead are passed over (prim_line_crosses,
 * prim_past_plane; a curved one, or a box, by its t), and the next is the
 * answer, into g, unless r hits it: then 1, else 0, and -1 when more than
 * EDGE_STEPS lie behind.
 * Off a huge triangle (sf->edge 2) the offset may take r's origin into a
 * solid standing on it, where r meets its far side: the line, searched
 * to r's end, is the answer, 1 when it meets a surface, 0 when none; a
 * solid that the point lies on or in counts by its hit from the point. */
EDGE_COLD static int edge_behind(const Ctx *c, const Surface *sf, const Ray *r, float near, Given *g)
{
    const int wide = sf->edge == 2;
    const float end = vec_dot(vec_sub(r->o, sf->p), r->d) + r->tmax; /* r's end, from the point */
    g->r = ray_make(vec_madd(sf->p, r->d, -near), r->d, near + (wide || end < near ? end : near));
    const float err = wide ? prim_wide_err(sf) : 0.0f;
    int skip[EDGE_STEPS + 1], ns = 0;
    if (wide) /* the triangle itself, which the line crosses at the point */
        skip[ns++] = (int)(sf->tri - c->s->prims);
    int solid = -1; /* a solid met behind that the line from the point meets ahead, at ht */
    PrimHit ht;
    int past = 0; /* 1 once the line has nothing more to meet */
    for (int step = 0; step < EDGE_STEPS; step++) {
        const int i = accel_closest_except(c->a, &g->r, skip, ns, &g->h, c->st);
        if (i < 0) {
            past = 1;
            break;
        }
        const Prim *x = &c->s->prims[i];
        const int tri = x->kind == PRIM_TRIANGLE || x->kind == PRIM_SMOOTH_TRIANGLE;
        /* ahead of the point by more than the two errors: the hit's, and
         * the point's, along the line, off the triangle's plane */
        const int ahead = wide && x != sf->tri && g->h.t - g->h.terr > near + 2.0f * err / fabsf(vec_dot(sf->ng, r->d));
        const int behind = tri                     ? !ahead && !prim_line_crosses(x, sf, r->d)
                           : x->kind == PRIM_PLANE ? prim_past_plane(x, sf, r->d)
                                                   : g->h.t <= near;
        PrimHit h;
        if (behind && wide && !tri && x->kind != PRIM_PLANE) {
            /* a solid met at or behind the point: the point may lie on it
             * (a box standing on the triangle) or in it, and the line from
             * the point then meets it ahead, unless another surface comes
             * first */
            const Ray from = ray_make(sf->p, r->d, end);
            if (prim_intersect(x, &from, c->p->variant, &h) && (solid < 0 || h.t < ht.t)) {
                solid = i;
                ht = h;
            }
        }
        if (behind) {
            skip[ns++] = i;
            continue;
        }
        if (solid >= 0 && ht.t < g->h.t - near)
            break;
        g->prim = i;
        return wide || !prim_intersect(x, r, c->p->variant, &h);
    }
    if (solid >= 0) {
        g->r = ray_make(sf->p, r->d, end);
        g->h = ht;
        g->prim = solid;
        return 1;
    }
    return past ? 0 : -1;
}

/* Where edge_behind() starts, behind the point of a hit on a huge triangle
 * (sf->edge 2): that point lies within its own error bound of the ray's
 * meeting with the plane, far less than the margin, so the line need start
 * only a few of those behind it, past fewer surfaces. */
static float wide_near(const Surface *sf) { return EDGE_PROBE * prim_wide_err(sf); }

/* A ray *r spawned off a triangle near its edge (sf->edge). The faces
 * beyond the edge pass through or close to sf's point, and the spawn
 * offset, which clears the plane of the triangle hit alone, may take the
 * origin across one of them (a sharp apex, a mesh box's edge): the ray
 * would hit it at once, a surface the ray from the point itself does not
 * cross (one too many through a glass mesh). So while the ray's first hit
 * is such a face (prim_past_plane), the ray starts again past it, from that
 * face's own spawn origin, a few times at most. Returns how far it looks
 * for them, which is where edge_behind() starts. */
EDGE_COLD static float edge_skip(const Ctx *c, const Surface *sf, Ray *r)
{
    /* Such a hit lies within a few offsets of the origin, unless the ray
     * runs almost along that face: the search stops there, which keeps
     * it to the BVH nodes around the point. */
    const float near = EDGE_PROBE * (sf->perr.x + sf->perr.y + sf->perr.z);
    for (int step = 0; step < EDGE_STEPS; step++) {
        PrimHit h;
        Ray probe = *r;
        probe.tmax = near < r->tmax ? near : r->tmax;
        const int i = accel_closest(c->a, &probe, &h, c->st);
        if (i < 0 || !prim_past_plane(&c->s->prims[i], sf, r->d))
            break;
        Surface x;
        prim_surface(&c->s->prims[i], r, &h, c->p->variant, &x);
        const Vec3 o = prim_spawn_origin(&x, r->d);
        r->tmax -= vec_length(vec_sub(o, r->o)); /* a shadow ray's end stays where it was */
        r->o = o;
        if (!(r->tmax > 0.0f))
            break;
    }
    return near;
}

/* A ray *r spawned off a triangle near its edge (sf->edge), for a trace
 * later: edge_skip(), and where the offset has taken r's origin past a
 * surface that the ray from the point does cross (one too few through a
 * glass mesh, edge_behind()), that surface is r's first hit. It waits for
 * the trace under r's address (given()). The rays that wait at once are
 * few, so EDGE_GIVEN always holds them; past it, a ray is traced as it
 * starts. */
EDGE_COLD static void edge_clear(const Ctx *c, const Surface *sf, Ray *r)
{
    Givens *w = c->given;
    Given g;
    const float near = sf->edge == 2 ? wide_near(sf) : edge_skip(c, sf, r);
    const int got = r->tmax > 0.0f ? edge_behind(c, sf, r, near, &g) : -1;
    if (got == 1 && w->n < EDGE_GIVEN) {
        w->ray[w->n] = r;
        w->g[w->n++] = g;
    } else if (got == 0 && sf->edge == 2)
        r->tmax = 0.0f; /* the line from the point meets nothing */
}

/* The first hit edge_clear() found for the ray at r, into g, and no longer
 * waiting; 0 when there is none. */
EDGE_COLD static int take(const Ctx *c, const Ray *r, Given *g)
{
    Givens *w = c->given;
    for (int j = 0; j < w->n; j++)
        if (w->ray[j] == r) {
            *g = w->g[j];
            w->n--; /* the last takes its place */
            w->ray[j] = w->ray[w->n];
            w->g[j] = w->g[w->n];
            return 1;
        }
    return 0;
}

/* The closest hits best[k] (h[k]) of the rays r[0 .. n-1], just traced:
 * where edge_clear() found a ray's first hit, that one, with its ray. */
EDGE_COLD static void given(const Ctx *c, Ray *r, int n, PrimHit *h, int *best)
{
    Given g;
    for (int k = 0; k < n && c->given->n; k++)
        if (take(c, &r[k], &g)) {
            r[k] = g.r;
            best[k] = g.prim;
            h[k] = g.h;
        }
}

/* sf->edge for hit h of primitive prim (Surface), worked out on first
 * need: few hits spawn a ray that needs it. */
static int near_edge(const Ctx *c, int prim, const PrimHit *h, Surface *sf)
{
    if (sf->edge < 0)
        sf->edge = prim_near_edge(&c->s->prims[prim], h, sf);
    return sf->edge;
}

/* Is the opaque shadow ray r off sf (sf->edge), found blocked when dark,
 * blocked once it starts past the faces beyond sf's edge, or by a surface
 * that its origin has passed? Next to an edge, a ray found clear needs no
 * look: a face edge_clear() would move it past would have blocked it, and
 * the offset, a few times the point's error, passes over nothing else. A
 * huge triangle's (edge 2) may pass over a surface standing on it. */
static int blocked_past_edge(const Ctx *c, const Surface *sf, Ray r, int dark)
{
    Given g;
    if (sf->edge == 2) { /* the line from the point tells, as far as it can */
        const int got = edge_behind(c, sf, &r, wide_near(sf), &g);
        return got < 0 ? dark : got;
    }
    if (!dark)
        return 0;
    const float near = edge_skip(c, sf, &r);
    return r.tmax > 0.0f && (accel_occluded(c->a, &r, c->st) || edge_behind(c, sf, &r, near, &g) == 1);
}

/* The light that filtered shadows let through along the shadow rays r[k]
 * towards points q[k], k < n <= ACCEL_PACKET, into f[k]: the product of
 * pass_factor over every transparent surface crossed, 0 behind an opaque
 * one (refraction is ignored, as in POV-Ray). The rays still on their way
 * go through the BVH together, surface after surface. */
static void filtered(const Ctx *c, Ray *r, int n, const Vec3 *q, Vec3 *f)
{
    Ray on[ACCEL_PACKET]; /* the rays on their way past a surface */
    Ray *cur = r;         /* the rays on their way, cur[j] for r[who[j]] */
    int who[ACCEL_PACKET], non = n;
    for (int k = 0; k < n; k++) {
        f[k] = vec3(1, 1, 1);
        who[k] = k;
    }
    /* (crossing k surfaces takes k + 1 searches, the last one clear) */
    for (int cross = 0; cross <= LIMIT_SHADOW_CROSSINGS && non; cross++) {
        int best[ACCEL_PACKET], m = 0;
        PrimHit h[ACCEL_PACKET];
        int through[ACCEL_PACKET]; /* the transparent surfaces crossed, or -1 */
        Surface sf[ACCEL_PACKET];
        accel_closest_packet(c->a, cur, non, h, best, c->st);
        if (c->given->n)
            given(c, cur, non, h, best);
        for (int j = 0; j < non; j++) {
            const int i = best[j];
            through[j] = -1;
            if (i < 0) /* through to q */
                continue;
            const Material *mt = material_of(c, i);
            if (mt->filter + mt->transmit <= 0.0f)
                f[who[j]] = vec3(0, 0, 0);
            else
                through[j] = i;
        }
        prim_surface_hits(c->s->prims, through, cur, h, non, c->p->variant, sf);
        for (int j = 0; j < non; j++) {
            const int i = through[j], k = who[j];
            if (i < 0)
                continue;
            f[k] = vec_mul(f[k], pass_factor(material_of(c, i)));
            /* on past the surface, field by field: a Ray copied whole
             * from one built on the stack stalled on its reload */
            const Vec3 d = cur[j].d, o = prim_spawn_origin(&sf[j], d);
            on[m].o = o; /* m <= j: cur[m] is done with */
            on[m].d = d;
            on[m].tmax = light_reach(vec_length(vec_sub(q[k], o)));
            if (near_edge(c, i, &h[j], &sf[j]))
                edge_clear(c, &sf[j], &on[m]);
            who[m++] = k;
            c->st->shadow++;
        }
        cur = on;
        non = m;
    }
    Given g;
    for (int j = 0; j < non; j++) { /* more crossings than the limit: dark */
        f[who[j]] = vec3(0, 0, 0);
        take(c, &cur[j], &g); /* and no hit waits for them */
    }
    c->st->shadow_cut += (unsigned)non;
}

/* prim_spawn_origin(sf, d) from sf's two spawn origins o. */
static Vec3 spawn_toward(const Surface *sf, const Vec3 o[2], Vec3 d)
{
    float nd = vec_dot(sf->ng, d);
    return nd < 0.0f ? o[0] : nd > 0.0f ? o[1] : prim_spawn_side(sf, nd);
}

/* The light that n <= ACCEL_PACKET samples of an area light let through
 * to sf, into t[k]: 1 when nothing is in between, 0 behind an opaque
 * object, or filtered(). Sample k is point[idx[k]], or point[k] when idx
 * is NULL. Their rays leave one point for one small patch, and go through
 * the BVH together. o: sf's spawn origins (prim_spawn_origins). Inline, so
 * that a NULL idx costs nothing. */
static inline void area_packet(const Ctx *c, PlanShadow mode, const Surface *sf, const Vec3 o[2], const Vec3 *point,
                               const int *idx, int n, Vec3 *t)
{
    Ray sr[ACCEL_PACKET];
    for (int k = 0; k < n; k++) {
        Vec3 d;
        float qd = toward(sf->p, point[idx ? idx[k] : k], &d);
        sr[k] = ray_make(spawn_toward(sf, o, d), d, light_reach(qd));
        if (sf->edge > 0 && mode != PLAN_SHADOW_OPAQUE)
            edge_clear(c, sf, &sr[k]);
    }
    c->st->shadow += (unsigned long long)n;
    if (mode == PLAN_SHADOW_OPAQUE) {
        unsigned dark = accel_occluded_packet(c->a, sr, n, c->st);
        for (int k = 0; k < n && sf->edge > 0; k++)
            dark = (dark & ~(1u << k)) | (unsigned)blocked_past_edge(c, sf, sr[k], dark >> k & 1) << k;
        for (int k = 0; k < n; k++)
            t[k] = dark >> k & 1 ? vec3(0, 0, 0) : vec3(1, 1, 1);
    } else {
        Vec3 q[ACCEL_PACKET]; /* gathered here: copied in the loop above, it stalled the reads of it */
        for (int k = 0; idx && k < n; k++)
            q[k] = point[idx[k]];
        filtered(c, sr, n, idx ? q : point, t);
    }
}

/* An area light's sample grid, each sample traced at most once, for
 * POV-Ray's adaptive subdivision (area_cell). */
typedef struct {
    const Ctx *c;
    PlanShadow mode;
    const Surface *sf;
    Vec3 o[2]; /* sf's spawn origins (prim_spawn_origins) */
    const Light *l;
    const PlanArea *area; /* its samples */
    Vec3 lc; /* the light's colour at the point, faded by the centre's distance */
    Vec3 t[LIMIT_AREA_SAMPLES * LIMIT_AREA_SAMPLES];
    unsigned char traced[LIMIT_AREA_SAMPLES * LIMIT_AREA_SAMPLES];
} AreaGrid;

/* Traces the samples idx[0 .. n-1], ACCEL_PACKET at a time. */
static void area_trace(AreaGrid *g, const int *idx, int n)
{
    Vec3 t[ACCEL_PACKET];
    for (int k0 = 0; k0 < n; k0 += ACCEL_PACKET) {
        const int ns = n - k0 < ACCEL_PACKET ? n - k0 : ACCEL_PACKET;
        area_packet(g->c, g->mode, g->sf, g->o, g->area->point, idx + k0, ns, t);
        for (int k = 0; k < ns; k++) {
            g->t[idx[k0 + k]] = t[k];
            g->traced[idx[k0 + k]] = 1;
        }
    }
}

/* POV-Ray's colour distance, |dr| + |dg| + |db| in double, of the light
 * that two samples let through. */
static double area_distance(const AreaGrid *g, Vec3 a, Vec3 b)
{
    Vec3 x = vec_mul(g->lc, a), y = vec_mul(g->lc, b);
    return fabs((double)x.x - y.x) + fabs((double)x.y - y.y) + fabs((double)x.z - y.z);
}

/* POV-Ray's adaptive area light (trace.cpp, TraceAreaLightSubsetShadowRay;
 * docs/povray-rules.md, section 10): the cell u1..u2 x v1..v2 at level lv
 * is the mean of its four corner samples, unless it is more than one
 * sample wide and either lv is below the light's adaptive level or two
 * corners along an edge differ by more than 0.1 in the light they let
 * through; then it is the mean of its four halves, split at the floor and
 * the ceiling of the middle. Its corners have been traced: the grid's by
 * light_visibility, the halves' here, together, before they are looked
 * at. */
static Vec3 area_cell(AreaGrid *g, int u1, int v1, int u2, int v2, int lv)
{
    const int n1 = g->l->area_n1;
    Vec3 s[4] = {g->t[v1 * n1 + u1], g->t[v1 * n1 + u2], g->t[v2 * n1 + u1], g->t[v2 * n1 + u2]};
    if ((u2 - u1 > 1 || v2 - v1 > 1) &&
        (lv < g->l->adaptive - 1 || area_distance(g, s[0], s[1]) > 0.1 || area_distance(g, s[1], s[3]) > 0.1 ||
         area_distance(g, s[3], s[2]) > 0.1 || area_distance(g, s[2], s[0]) > 0.1)) {
        int ul = (u1 + u2) / 2, uh = (u1 + u2 + 1) / 2, vl = (v1 + v2) / 2, vh = (v1 + v2 + 1) / 2;
        const int us[4] = {u1, ul, uh, u2}, vs[4] = {v1, vl, vh, v2};
        int idx[16], n = 0;
        for (int b = 0; b < 4; b++) /* the halves' corners not yet traced (once each), in the grid's order */
            for (int a = 0; a < 4; a++) {
                int k = vs[b] * n1 + us[a];
                if (!g->traced[k]) {
                    idx[n++] = k;
                    g->traced[k] = 1;
                }
            }
        area_trace(g, idx, n);
        s[0] = area_cell(g, u1, v1, ul, vl, lv + 1);
        s[1] = area_cell(g, uh, v1, u2, vl, lv + 1);
        s[2] = area_cell(g, u1, vh, ul, v2, lv + 1);
        s[3] = area_cell(g, uh, vh, u2, v2, lv + 1);
    }
    return vec_scale(vec_add(vec_add(s[0], s[1]), vec_add(s[2], s[3])), 0.25f);
}

/* The visible fraction of area light li from sf's point, per channel; lc:
 * the light's colour there, which light_term() has. (A point light's
 * shadow rays go in shade_packet's packets.) */
static Vec3 light_visibility(const Ctx *c, int li, const Surface *sf, Vec3 lc)
{
    const Light *l = &c->s->lights[li];
    PlanShadow mode = c->p->shadow[li];
    const PlanArea *area = &c->p->area[li];
    if (l->adaptive > 0) {
        AreaGrid g;
        g.c = c, g.mode = mode, g.sf = sf, g.l = l, g.area = area, g.lc = lc;
        prim_spawn_origins(sf, g.o);
        memset(g.traced, 0, (size_t)(l->area_n1 * l->area_n2));
        area_trace(&g, area->first, area->nfirst); /* what every point traces, then what its cells ask for */
        return area_cell(&g, 0, 0, l->area_n1 - 1, l->area_n2 - 1, 0);
    }
    /* every sample, summed in the grid's order */
    Vec3 vis = vec3(0, 0, 0), o[2], t[ACCEL_PACKET];
    prim_spawn_origins(sf, o);
    const int n = l->area_n1 * l->area_n2;
    for (int k0 = 0; k0 < n; k0 += ACCEL_PACKET) {
        const int ns = n - k0 < ACCEL_PACKET ? n - k0 : ACCEL_PACKET;
        area_packet(c, mode, sf, o, &area->point[k0], NULL, ns, t);
        for (int k = 0; k < ns; k++)
            vis = vec_madd(vis, t[k], area->weight[k0 + k]);
    }
    return vis;
}

/* 1 - filter - transmit: what scales ambient and diffuse. */
static float opacity_of(const Material *m) { return 1.0f - m->filter - m->transmit; }

/* Light l's share at sf, hit by ray r, short of its visibility: 0 when it
 * adds nothing, and no shadow ray is needed; else 1, with the unit
 * direction *L and distance *dist to the light, the surface's *term and the
 * light's colour *lc, to be scaled by the visibility unless the light is
 * shadowless. Inline: it runs for every light at every hit. */
static inline int light_term(const Material *m, const Surface *sf, const Ray *r, const Light *l, Vec3 *L, float *dist,
                             Vec3 *term, Vec3 *lc)
{
    Vec3 n = sf->ns;
    *dist = toward(sf->p, l->pos, L);
    if (!(*dist > 0.0f))
        return 0;
    float nl = vec_dot(n, *L);
    if (nl < LIGHT_EPSILON)
        return 0; /* light behind the surface: no diffuse, highlight or shadow ray */
    Vec3 t = vec_scale(m->color, m->diffuse * opacity_of(m) * nl);
    if (!l->shadowless) { /* shadowless lights add no highlights */
        float high = 0.0f;
        float rl = vec_dot(vec_reflect(r->d, n), *L);
        if (m->phong > 0.0f && rl > 0.0f)
            high += m->phong * powf(rl, m->phong_size);
        if (m->specular > 0.0f) {
            float nh = vec_dot(n, vec_normalize(vec_add(*L, vec_neg(r->d))));
            if (nh > 0.0f)
                high += m->specular * powf(nh, 1.0f / m->roughness);
        }
        t = vec_add(t, vec3(high, high, high));
    }
    if (t.x <= 0.0f && t.y <= 0.0f && t.z <= 0.0f)
        return 0; /* nothing to add: skip the shadow rays */
    *term = t;
    *lc = vec_scale(l->color, fade(l, *dist));
    return 1;
}

static Vec3 trace(const Ctx *c, const Ray *r, int level, int continued, const Interiors *in, float wt);
static void shade_packet(const Ctx *c, const Ray *r, int n, const int *best, const PrimHit *h, int level,
                         const Interiors *const *in, const float *wt, Vec3 *out);

/* A secondary ray's weight: its parent's times the coefficient that sends
 * it. A weight is 0 only where a coefficient is (which the plan skips and
 * --no-plan traces): a product that underflows stays at the least float,
 * so that adc_bailout decides it, as POV-Ray's does. */
static float weigh(float wt, float coef)
{
    const float w = wt * coef;
    return w == 0.0f && wt > 0.0f && coef > 0.0f ? 0x1p-149f : w; /* the least float */
}

/* POV-Ray's adc_bailout (trace.cpp, Trace::TraceRay): a ray carries the
 * product of the coefficients on its path, its weight, and one whose
 * weight is below the bailout is not traced: it adds nothing. A weight of
 * 0 (a coefficient of 0) is the plan's to skip: --no-plan traces it. */
static int worth(const Ctx *c, float wt)
{
    if (wt == 0.0f)
        return c->p->full;
    if (wt < c->p->adc_bailout) {
        c->st->cut++;
        return 0;
    }
    return 1;
}

/* The largest of a colour's channels: POV-Ray's weight of a filter. */
static float max3(Vec3 v) { return float_max(v.x, float_max(v.y, v.z)); }

/* The place of primitive prim's solid in the list in (the same primitive,
 * or one of the same mesh), or -1. */
static int solid_in(const Ctx *c, const Interiors *in, int prim)
{
    const int solid = prim_solid(&c->s->prims[prim]);
    int k = -1;
    for (int i = 0; i < in->n; i++)
        if (in->prim[i] == prim || (solid && prim_solid(&c->s->prims[in->prim[i]]) == solid))
            k = i;
    return k;
}

/* What refraction() made of a hit. */
enum { REFRACT_NONE, REFRACT_TIR, REFRACT_ON, REFRACT_RAY };

/* The ray refracted into or out of primitive `prim` (POV-Ray's trace.cpp
 * ComputeRefraction: the ratio of indices comes from the ray's list of
 * interiors, so nested and overlapping solids refract as POV-Ray's do),
 * of weight wt: REFRACT_RAY for a ray one level deeper, *t, inside *out;
 * REFRACT_ON for one straight through (no bend), which stays at the level;
 * REFRACT_TIR on total internal reflection (the caller's mirror ray then
 * carries it all); REFRACT_NONE when its weight is below the bailout. */
static int refraction(const Ctx *c, int prim, const Material *m, const Surface *sf, const Ray *r,
                      const Interiors *in, float wt, Ray *t, Interiors *out)
{
    *out = *in;
    float eta; /* incident index over transmitted index */
    int k = solid_in(c, in, prim), lost = 0;
    if (in->n == 0) {
        eta = 1.0f / m->ior;
        out->prim[out->n++] = prim;
    } else if (k == in->n - 1) { /* leaving the innermost solid */
        out->n--;
        eta = m->ior / (out->n ? material_of(c, out->prim[out->n - 1])->ior : 1.0f);
    } else if (k >= 0) { /* leaving a solid it overlaps: no bend */
        memmove(&out->prim[k], &out->prim[k + 1], sizeof(int) * (size_t)(out->n - k - 1));
        out->n--;
        eta = 1.0f;
    } else { /* entering a solid nested in the current one */
        eta = material_of(c, in->prim[in->n - 1])->ior / m->ior;
        if (out->n < LIMIT_INTERIORS)
            out->prim[out->n++] = prim;
        else /* its exit will read as an entry: counted if a ray goes on, and the render warns */
            lost = 1;
    }
    if (fabsf(eta - 1.0f) < 1e-10f) { /* straight through, at the same level */
        if (!worth(c, wt))
            return REFRACT_NONE;
        *t = ray_make(prim_spawn_origin(sf, r->d), r->d, INFINITY);
        if (sf->edge > 0)
            edge_clear(c, sf, t);
        c->st->refraction++;
        c->st->too_deep += (unsigned)lost;
        return REFRACT_ON;
    }
    float cosi = -vec_dot(r->d, sf->ns);
    float disc = 1.0f + eta * eta * (cosi * cosi - 1.0f);
    if (disc < 0.0f)
        return REFRACT_TIR;
    if (!worth(c, wt))
        return REFRACT_NONE;
    /* Heckbert's refraction formula, with N facing the incoming ray. */
    Vec3 d = vec_normalize(vec_madd(vec_scale(r->d, eta), sf->ns, eta * cosi - sqrtf(disc)));
    *t = ray_make(prim_spawn_origin(sf, d), d, INFINITY);
    if (sf->edge > 0)
        edge_clear(c, sf, t);
    c->st->refraction++;
    c->st->too_deep += (unsigned)lost;
    return REFRACT_RAY;
}

/* The hits of the n rays r inside the solids in[k], best[k] (h[k]), that
 * leave a transparent solid where an opaque plane (the plan's floors)
 * meets the ray at the same distance, give way to the plane: a glass solid
 * standing on a floor touches it, and a ray leaving the glass there meets
 * the floor. Else the ray left the solid first, started past the floor and
 * missed it, or not, by the scene's order and the roundings; POV-Ray draws
 * the floor. The same distance: within both hits' error bounds, and the
 * distance that rounding each surface to float (the plan's move) can put
 * between two that the scene makes meet (the plan's floor_band, 0 for the
 * primitives whose box does not reach a floor). */
static void floors_first(const Ctx *c, const Ray *r, int n, const Interiors *const *in, int *best, PrimHit *h)
{
    for (int k = 0; k < n; k++) {
        const float band = best[k] >= 0 && in[k]->n ? c->p->floor_band[best[k]] : 0.0f;
        if (band == 0.0f)
            continue;
        const Vec3 o = r[k].o, d = r[k].d;
        for (int j = 0; j < c->p->nfloors; j++) {
            const Prim *f = &c->s->prims[c->p->floors[j]];
            /* first roughly, where the ray meets the plane: ahead of its
             * origin (inside the solid, on the solid's side of the floor),
             * and near the hit, with room for every rounding below */
            const float no = vec_dot(f->g.plane.n, o), od = no - f->g.plane.d, nd = vec_dot(f->g.plane.n, d);
            if (!(od * nd < 0.0f))
                continue;
            /* |plane's t - t| within the bound below, times |nd|: no division */
            const float an = fabsf(nd), slack = 0x1p-19f * h[k].t * an + 0x1p-20f * (fabsf(no) + fabsf(f->g.plane.d));
            if (!(fabsf(od + h[k].t * nd) <= h[k].terr * an + slack + 2.0f * band))
                continue;
            PrimHit g;
            if (solid_in(c, in[k], best[k]) < 0) /* not leaving the solid */
                break;
            if (!prim_intersect(f, &r[k], c->p->variant, &g))
                continue;
            if (fabsf(g.t - h[k].t) <= g.terr + h[k].terr + band / an) {
                best[k] = c->p->floors[j];
                h[k] = g;
                break;
            }
        }
    }
}

/* `level` is the parent's level (0 for a camera ray); a continued ray stays
 * at it, any other ray is one deeper. */
static Vec3 trace(const Ctx *c, const Ray *r, int level, int continued, const Interiors *in, float wt)
{
    Given g;
    const int got = c->given->n && take(c, r, &g); /* edge_clear() found its first hit */
    if (level >= c->p->max_depth || (continued && *c->continued >= LIMIT_CONTINUED))
        return vec3(0, 0, 0);
    if (!continued)
        level++;
    PrimHit h;
    int i;
    if (got) {
        i = g.prim;
        h = g.h;
        r = &g.r;
    } else {
        i = accel_closest(c->a, r, &h, c->st);
        if (c->p->nfloors)
            floors_first(c, r, 1, &in, &i, &h);
    }
    Vec3 col;
    *c->continued += continued;
    shade_packet(c, r, 1, &i, &h, level, &in, &wt, &col);
    *c->continued -= continued;
    return col;
}

/* POV-Ray's test for a transmitted ray (trace.cpp, ComputeLightedTexture):
 * the luminance of pass_factor, at most 1, above the bailout. */
static int refracts(const Ctx *c, Vec3 f)
{
    float y = 0.297f * f.x + 0.589f * f.y + 0.114f * f.z;
    return (y < 1.0f ? y : 1.0f) > c->p->adc_bailout; /* fminf(1, y), NaN included, without the libm call */
}

/* prim_spawn_origin(sf, d), given sf's origin for every d on ng's side,
 * front (prim_spawn_side(sf, 1)): the side is all the origin depends on. */
static Vec3 spawn_front(const Surface *sf, Vec3 front, Vec3 d)
{
    float nd = vec_dot(sf->ng, d);
    return nd > 0.0f ? front : prim_spawn_side(sf, nd);
}

/* The mirror ray of r at sf, whose front origin is front, into *out field
 * by field: a Ray returned whole went through the stack, and its reload
 * stalled on the stores. */
static void mirror_ray(const Ctx *c, const Ray *r, const Surface *sf, Vec3 front, Ray *out)
{
    Vec3 d = vec_reflect(r->d, sf->ns);
    c->st->reflection++;
    out->o = spawn_front(sf, front, d);
    out->d = d;
    out->tmax = INFINITY;
}

Vec3 shade_trace(const RenderPlan *p, const Accel *a, const Ray *r, RayStats *st)
{
    Givens given;
    given.n = 0;
    int continued = 0;
    Ctx c = {p, p->scene, a, st, &given, &continued, NULL};
    return trace(&c, r, 0, 0, &p->camera_in, 1.0f);
}

Vec3 shade_traced(const RenderPlan *p, const Accel *a, const Ray *r, int i, const PrimHit *h, RayStats *st)
{
    Vec3 col;
    shade_traced_packet(p, a, r, 1, &i, h, st, NULL, &col);
    return col;
}

/* The colours of the n rays r (n <= ACCEL_PACKET) at `level`, inside the
 * solids in[k] and of weights wt[k], whose closest hits are best[k] (h[k]),
 * or the background where best[k] < 0, into out[k]: ambient and the
 * lights, light by light over all of them, so that the shadow rays towards
 * a point light go through the BVH together; then the secondary rays, the
 * refracted rays together and the mirror rays together, their hits shaded
 * the same way one level deeper. Each colour is the same whatever the rays
 * it is shaded with. */
static void shade_packet(const Ctx *c, const Ray *r, int n, const int *best, const PrimHit *h, int level,
                         const Interiors *const *in, const float *wt, Vec3 *out)
{
    const Scene *s = c->s;
    if (stop_read(c->stop)) {
        for (int k = 0; k < n; k++)
            out[k] = vec3(0, 0, 0);
        return;
    }
    const Material *m[ACCEL_PACKET];
    Surface sf[ACCEL_PACKET];
    Vec3 front[ACCEL_PACKET]; /* each hit's origin for the rays that leave on ng's side: most do */
    prim_surface_hits(s->prims, best, r, h, n, c->p->variant, sf);
    for (int k = 0; k < n; k++) {
        if (best[k] < 0) {
            m[k] = NULL;
            out[k] = s->background;
            continue;
        }
        m[k] = material_of(c, best[k]);
        out[k] = vec_scale(m[k]->color, m[k]->ambient * opacity_of(m[k]));
        front[k] = prim_spawn_side(&sf[k], 1.0f);
    }
    for (int i = 0; i < s->nlights; i++) {
        const Light *l = &s->lights[i];
        const PlanShadow mode = c->p->shadow[i];
        /* A point light's shadow rays go through the BVH together: any-hit
         * queries, or, when shadows are filtered, surface after surface
         * (filtered()). */
        const int together = l->area_n1 * l->area_n2 == 1;
        Vec3 term[ACCEL_PACKET], lc[ACCEL_PACKET];
        Ray sr[ACCEL_PACKET];
        int lit[ACCEL_PACKET], who[ACCEL_PACKET], ns = 0;
        unsigned wide = 0; /* the shadow rays off huge triangles (Surface.edge 2) */
        for (int k = 0; k < n; k++) {
            Vec3 L;
            float dist;
            lit[k] = best[k] >= 0 && light_term(m[k], &sf[k], &r[k], l, &L, &dist, &term[k], &lc[k]);
            if (!lit[k] || mode == PLAN_SHADOW_NONE || mode == PLAN_SHADOW_CLEAR)
                continue; /* the light reaches the point whole */
            if (together) { /* a point light: one shadow ray, in a packet below */
                sr[ns] = ray_make(spawn_front(&sf[k], front[k], L), L, light_reach(dist));
                c->st->shadow++;
                wide |= (unsigned)(sf[k].edge == 2) << ns;
                who[ns++] = k;
            } else {
                near_edge(c, best[k], &h[k], &sf[k]); /* known, for every sample */
                lc[k] = vec_mul(lc[k], light_visibility(c, i, &sf[k], lc[k]));
            }
        }
        if (mode == PLAN_SHADOW_FILTERED && ns) {
            Vec3 vis[ACCEL_PACKET], at[ACCEL_PACKET];
            for (int j = 0; j < ns; j++) /* past a mesh's edge first (opaque: once found blocked, below) */
                if (near_edge(c, best[who[j]], &h[who[j]], &sf[who[j]]))
                    edge_clear(c, &sf[who[j]], &sr[j]);
            for (int j = 0; j < ns; j++)
                at[j] = l->pos;
            filtered(c, sr, ns, at, vis);
            for (int j = 0; j < ns; j++)
                lc[who[j]] = vec_mul(lc[who[j]], vis[j]);
            ns = 0;
            wide = 0;
        }
        unsigned dark = ns ? accel_occluded_packet(c->a, sr, ns, c->st) : 0;
        /* the rays found blocked, near an edge looked at again, and every
         * ray off a huge triangle (blocked_past_edge) */
        const unsigned look = dark | wide;
        for (int j = 0; look >> j; j++) {
            const int k = who[j];
            int blocked = dark >> j & 1;
            if (!(look >> j & 1))
                continue;
            if (wide >> j & 1 || (blocked && near_edge(c, best[k], &h[k], &sf[k])))
                blocked = blocked_past_edge(c, &sf[k], sr[j], blocked);
            if (blocked)
                lc[k] = vec_mul(lc[k], vec3(0, 0, 0)); /* times a visibility of 0, as light_visibility's */
        }
        for (int k = 0; k < n; k++)
            if (lit[k])
                out[k] = vec_add(out[k], vec_mul(lc[k], term[k]));
    }
    if (level >= c->p->max_depth) /* any child ray of a hit at the last level returns black */
        return;
    /* The secondary rays, traced as trace() would: the refracted rays
     * together, then the mirror rays together, their hits shaded the same
     * way one level deeper; each hit adds its refracted ray's colour, then
     * its mirror ray's. */
    Ray tr[ACCEL_PACKET], rr[ACCEL_PACKET];
    Interiors tin[ACCEL_PACKET];
    const Interiors *tinp[ACCEL_PACKET], *rin[ACCEL_PACKET];
    /* (zeroed: GCC 12 at -O3 saw a read before the write) */
    Vec3 tf[ACCEL_PACKET] = {{0, 0, 0}};
    float tw[ACCEL_PACKET], rw[ACCEL_PACKET], rmul[ACCEL_PACKET]; /* rmul: by hit, the others by ray */
    int twho[ACCEL_PACKET], rwho[ACCEL_PACKET], nt = 0, nr = 0;
    for (int k = 0; k < n; k++) {
        if (best[k] < 0)
            continue;
        int tir = 0;
        Vec3 f = pass_factor(m[k]);
        const int through = refracts(c, f);
        float wf = 0.0f; /* a transmitted ray's weight */
        if (through || c->p->full) {
            if (through)
                wf = weigh(wt[k], max3(f));
            else /* --no-plan: traced all the same, and weighed 0 */
                f = vec3(0, 0, 0);
            near_edge(c, best[k], &h[k], &sf[k]); /* refraction() reads it */
            int got = refraction(c, best[k], m[k], &sf[k], &r[k], in[k], wf, &tr[nt], &tin[nt]);
            if (got == REFRACT_ON) {
                const Vec3 t = trace(c, &tr[nt], level, 1, &tin[nt], wf);
                if (through) /* as below */
                    out[k] = vec_add(out[k], vec_mul(f, t));
            } else if (got == REFRACT_RAY) {
                tf[nt] = f;
                tw[nt] = wf;
                tinp[nt] = &tin[nt];
                twho[nt++] = k;
            }
            tir = through && got == REFRACT_TIR;
        }
        /* total internal reflection: the mirror ray, its colour unfiltered
         * but its weight the transmitted ray's, as in POV-Ray */
        float w = tir ? wf : weigh(wt[k], m[k]->reflection);
        rmul[k] = tir ? 1.0f : m[k]->reflection;
        if (worth(c, w)) {
            rw[nr] = w;
            mirror_ray(c, &r[k], &sf[k], front[k], &rr[nr]);
            rin[nr] = in[k];
            rwho[nr++] = k;
        }
    }
    int best2[ACCEL_PACKET];
    PrimHit h2[ACCEL_PACKET];
    Vec3 got[ACCEL_PACKET];
    if (nt) {
        accel_closest_packet(c->a, tr, nt, h2, best2, c->st);
        if (c->p->nfloors)
            floors_first(c, tr, nt, tinp, best2, h2);
        if (c->given->n)
            given(c, tr, nt, h2, best2);
        shade_packet(c, tr, nt, best2, h2, level + 1, tinp, tw, got);
        for (int j = 0; j < nt; j++)
            if (tw[j] != 0.0f) /* --no-plan's rays of weight 0 add nothing, not even 0 times an infinity */
                out[twho[j]] = vec_add(out[twho[j]], vec_mul(tf[j], got[j]));
    }
    if (nr) {
        /* past a mesh's edge only now, once the refracted rays' hits that
         * edge_clear() found are taken: at most a packet's wait at once */
        for (int j = 0; j < nr; j++)
            if (near_edge(c, best[rwho[j]], &h[rwho[j]], &sf[rwho[j]]))
                edge_clear(c, &sf[rwho[j]], &rr[j]);
        accel_closest_packet(c->a, rr, nr, h2, best2, c->st);
        if (c->p->nfloors)
            floors_first(c, rr, nr, rin, best2, h2);
        if (c->given->n)
            given(c, rr, nr, h2, best2);
        shade_packet(c, rr, nr, best2, h2, level + 1, rin, rw, got);
        for (int j = 0; j < nr; j++)
            if (rw[j] != 0.0f)
                out[rwho[j]] = vec_madd(out[rwho[j]], got[j], rmul[rwho[j]]);
    }
}

void shade_traced_packet(const RenderPlan *p, const Accel *a, const Ray *r, int n, const int *best, const PrimHit *h,
                         RayStats *st, const volatile sig_atomic_t *stop, Vec3 *out)
{
    static const float ONES[ACCEL_PACKET] = {1, 1, 1, 1, 1, 1, 1, 1}; /* camera rays weigh 1 */
    const Interiors *in[ACCEL_PACKET]; /* camera rays start in the same solids */
    for (int k = 0; k < ACCEL_PACKET; k++)
        in[k] = &p->camera_in;
    Givens given;
    given.n = 0;
    int continued = 0;
    Ctx c = {p, p->scene, a, st, &given, &continued, stop};
    for (int k = 0; k < n; k += ACCEL_PACKET) {
        int m = n - k < ACCEL_PACKET ? n - k : ACCEL_PACKET;
        if (p->max_depth < 1) /* as trace() at level 0 */
            for (int j = 0; j < m; j++)
                out[k + j] = vec3(0, 0, 0);
        else if (p->nfloors && p->camera_in.n) { /* as trace() */
            int b[ACCEL_PACKET];
            PrimHit g[ACCEL_PACKET];
            memcpy(b, best + k, sizeof(int) * (size_t)m);
            memcpy(g, h + k, sizeof(PrimHit) * (size_t)m);
            floors_first(&c, r + k, m, in, b, g);
            shade_packet(&c, r + k, m, b, g, 1, in, ONES, out + k);
        } else
            shade_packet(&c, r + k, m, best + k, h + k, 1, in, ONES, out + k);
    }
}
