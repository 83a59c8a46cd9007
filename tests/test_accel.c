/* Tests for accel.c: the queries over a whole scene, bounded primitives in
 * the BVH and planes beside it, against brute force over every primitive;
 * the tie rule across the two; the packet queries ray by ray; and the
 * accessors. */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>

#include "testutil.h"

#include "lancer/accel.h"
#include "lancer/bvh.h"
#include "lancer/pntri.h"

/* A scene of n primitives: spheres, triangles, boxes scattered in
 * [-4, 4]^3, and every hundredth a plane at 4 to 6 from the origin. */
static void random_scene(Scene *s, int n, unsigned long long *g)
{
    memset(s, 0, sizeof *s);
    s->prims = calloc((size_t)n, sizeof(Prim));
    assert_non_null(s->prims);
    s->nprims = n;
    for (int i = 0; i < n; i++) {
        Prim *p = &s->prims[i];
        Vec3 c = test_rvec(g, -4, 4);
        switch (i % 100 == 50 ? 3 : i % 3) {
        case 0:
            p->kind = PRIM_SPHERE;
            p->g.sphere.c = c;
            p->g.sphere.r = test_uniform(g, 0.1f, 0.6f);
            break;
        case 1:
            p->kind = PRIM_TRIANGLE;
            p->g.tri.a = c;
            p->g.tri.b = vec_add(c, test_rvec(g, -1, 1));
            p->g.tri.c = vec_add(c, test_rvec(g, -1, 1));
            break;
        case 2:
            p->kind = PRIM_BOX;
            p->g.box.lo = c;
            p->g.box.hi = vec_add(c, test_rvec(g, 0.05f, 0.8f));
            break;
        default:
            p->kind = PRIM_PLANE;
            p->g.plane.n = vec_normalize(test_rvec(g, -1, 1));
            p->g.plane.d = test_uniform(g, 4, 6);
            break;
        }
    }
}

/* The fields of a hit that primitive p's routines set: t and terr, the
 * barycentrics of a triangle, the face of a box. */
static void assert_same_hit(const Prim *p, const PrimHit *a, const PrimHit *b)
{
    assert_memory_equal(&a->t, &b->t, sizeof a->t);
    assert_memory_equal(&a->terr, &b->terr, sizeof a->terr);
    if (p->kind == PRIM_TRIANGLE) {
        assert_memory_equal(&a->u, &b->u, sizeof a->u);
        assert_memory_equal(&a->v, &b->v, sizeof a->v);
    }
    if (p->kind == PRIM_BOX)
        assert_int_equal(a->face, b->face);
}

/* The closest hit by testing every primitive, with the tie rule. */
static int brute_closest(const Scene *s, const Ray *r, PrimVariant v, PrimHit *best_h)
{
    int best = -1;
    PrimHit h;
    for (int i = 0; i < s->nprims; i++)
        if (prim_intersect(&s->prims[i], r, v, &h) && prim_hit_wins(h.t, i, best_h->t, best)) {
            best = i;
            *best_h = h;
        }
    return best;
}

static Ray random_ray(unsigned long long *g)
{
    Vec3 o = test_rvec(g, -6, 6), d = vec_normalize(test_rvec(g, -1, 1));
    float tmax = test_uniform(g, 0, 1) < 0.3f ? test_uniform(g, 0.5f, 10) : INFINITY;
    return ray_make(o, d, tmax);
}

static void test_closest_and_occluded_match_brute_force(void **state)
{
    (void)state;
    unsigned long long g = 99;
    for (int v = 0; v < 2; v++) {
        PrimVariant var = v ? PRIM_CLASSIC : PRIM_ROBUST;
        Scene s;
        random_scene(&s, 300, &g);
        Accel *a = accel_build(&s, var, 2);
        assert_non_null(a);
        assert_int_equal(accel_variant(a), var);
        int hits = 0, plane_hits = 0;
        for (int k = 0; k < 20000; k++) {
            Ray r = random_ray(&g);
            RayStats st = {0};
            PrimHit h, w;
            int got = accel_closest(a, &r, &h, &st), want = brute_closest(&s, &r, var, &w);
            assert_int_equal(got, want);
            if (want >= 0) {
                assert_same_hit(&s.prims[want], &h, &w);
                hits++;
                plane_hits += s.prims[want].kind == PRIM_PLANE;
            }
            assert_int_equal(accel_occluded(a, &r, &st), want >= 0);
            assert_true(st.isect_tests > 0);
        }
        /* both the BVH and the planes gave answers */
        assert_true(hits > 5000 && plane_hits > 1000 && hits - plane_hits > 1000);
        accel_free(a);
        scene_free(&s);
    }
}

/* brute_closest, passing over skip[0 .. ns-1]. */
static int brute_except(const Scene *s, const Ray *r, const int *skip, int ns, PrimHit *best_h)
{
    int best = -1;
    PrimHit h;
    for (int i = 0; i < s->nprims; i++) {
        int skipped = 0;
        for (int j = 0; j < ns; j++)
            skipped |= skip[j] == i;
        if (!skipped && prim_intersect(&s->prims[i], r, PRIM_ROBUST, &h) && prim_hit_wins(h.t, i, best_h->t, best)) {
            best = i;
            *best_h = h;
        }
    }
    return best;
}

static void test_closest_except_matches_brute_force(void **state)
{
    (void)state;
    /* Each ray again without its nearest primitives, one by one, and
     * without a random one: through the BVH and the planes, and by the
     * plain loop, as by brute force. */
    unsigned long long g = 5;
    Scene s;
    random_scene(&s, 300, &g);
    Accel *a[2] = {accel_build_as(&s, PRIM_ROBUST, 2, 0), accel_build_as(&s, PRIM_ROBUST, 1, 1)};
    assert_non_null(a[0]);
    assert_non_null(a[1]);
    int passed = 0, planes = 0;
    for (int k = 0; k < 5000; k++) {
        const Ray r = random_ray(&g);
        RayStats st = {0};
        int skip[4] = {(int)(test_uniform(&g, 0, 1) * (float)s.nprims) % s.nprims, -1, -1, -1};
        for (int ns = 1; ns <= 4; ns++) {
            PrimHit w, h;
            const int want = brute_except(&s, &r, skip, ns, &w);
            for (int v = 0; v < 2; v++) {
                assert_int_equal(accel_closest_except(a[v], &r, skip, ns, &h, &st), want);
                if (want >= 0)
                    assert_same_hit(&s.prims[want], &h, &w);
            }
            if (want < 0)
                break;
            passed += ns > 1;
            planes += s.prims[want].kind == PRIM_PLANE;
            if (ns < 4)
                skip[ns] = want; /* the next round passes over it too */
        }
        PrimHit h, w;
        assert_int_equal(accel_closest_except(a[0], &r, skip, 0, &h, &st), accel_closest(a[0], &r, &w, &st));
    }
    assert_true(passed > 2000 && planes > 200);
    accel_free(a[0]);
    accel_free(a[1]);
    scene_free(&s);
}

/* A triangle lying in a plane: both are hit at exactly the same t, and the
 * lower scene index wins, whichever of the two it is. */
static void test_ties_between_planes_and_the_bvh(void **state)
{
    (void)state;
    for (int order = 0; order < 2; order++) {
        Scene s;
        memset(&s, 0, sizeof s);
        s.prims = calloc(2, sizeof(Prim));
        assert_non_null(s.prims);
        s.nprims = 2;
        Prim *pl = &s.prims[order], *tr = &s.prims[1 - order];
        pl->kind = PRIM_PLANE;
        pl->g.plane.n = vec3(0, 1, 0);
        pl->g.plane.d = 0;
        tr->kind = PRIM_TRIANGLE;
        tr->g.tri.a = vec3(-1, 0, -1);
        tr->g.tri.b = vec3(1, 0, -1);
        tr->g.tri.c = vec3(0, 0, 2);
        Accel *a = accel_build(&s, PRIM_ROBUST, 1);
        assert_non_null(a);
        Ray r[3];
        for (int k = 0; k < 3; k++)
            r[k] = ray_make(vec3(0.1f * (float)k, 2, 0), vec3(0, -1, 0), INFINITY);
        RayStats st = {0};
        PrimHit h[3];
        int best[3];
        assert_int_equal(accel_closest(a, &r[0], &h[0], &st), 0);
        assert_float_equal(h[0].t, 2, 0);
        accel_closest_packet(a, r, 3, h, best, &st);
        for (int k = 0; k < 3; k++)
            assert_int_equal(best[k], 0);
        accel_free(a);
        scene_free(&s);
    }
}

/* accel_closest_packet is accel_closest ray by ray, in packets of any size. */
static void test_closest_packet_is_closest(void **state)
{
    (void)state;
    unsigned long long g = 7;
    Scene s;
    random_scene(&s, 200, &g);
    Accel *a = accel_build(&s, PRIM_ROBUST, 1);
    assert_non_null(a);
    for (int k = 0; k < 3000; k++) {
        int n = 1 + k % (2 * ACCEL_PACKET + 3);
        Ray r[2 * ACCEL_PACKET + 3];
        Vec3 o = test_rvec(&g, -6, 6), d = test_rvec(&g, -1, 1);
        for (int j = 0; j < n; j++) /* neighbours from one origin, as camera rays */
            r[j] = ray_make(o, vec_normalize(vec_add(d, test_rvec(&g, -0.05f, 0.05f))), INFINITY);
        PrimHit h[2 * ACCEL_PACKET + 3], w;
        int best[2 * ACCEL_PACKET + 3];
        RayStats st = {0};
        accel_closest_packet(a, r, n, h, best, &st);
        for (int j = 0; j < n; j++) {
            assert_int_equal(best[j], accel_closest(a, &r[j], &w, &st));
            if (best[j] >= 0)
                assert_same_hit(&s.prims[best[j]], &h[j], &w);
        }
    }
    accel_free(a);
    scene_free(&s);
}

/* accel_occluded_packet is accel_occluded ray by ray: shadow rays towards
 * a point above a floor (a plane, outside the BVH) with spheres on it, from
 * points above the floor (blocked by spheres or not) and below it (blocked
 * by the plane), in packets of every size and in more than one. */
static void test_occluded_packet_is_occluded(void **state)
{
    (void)state;
    Scene s;
    memset(&s, 0, sizeof s);
    s.prims = calloc(4, sizeof(Prim));
    assert_non_null(s.prims);
    s.nprims = 4;
    s.prims[0].kind = PRIM_PLANE;
    s.prims[0].g.plane.n = vec3(0, 1, 0);
    const float sph[3][4] = {{0, 1, 0, 1}, {2.5f, 0.5f, 1, 0.5f}, {-2, 0.7f, -1, 0.7f}};
    for (int i = 0; i < 3; i++) {
        s.prims[1 + i].kind = PRIM_SPHERE;
        s.prims[1 + i].g.sphere.c = vec3(sph[i][0], sph[i][1], sph[i][2]);
        s.prims[1 + i].g.sphere.r = sph[i][3];
    }
    Accel *a = accel_build(&s, PRIM_ROBUST, 1);
    assert_non_null(a);
    unsigned long long g = 12345;
    const Vec3 light = vec3(0.5f, 6, -0.5f);
    int blocked = 0, by_plane = 0, free_rays = 0;
    for (int k = 0; k < 4000; k++) {
        int n = 1 + k % (2 * ACCEL_PACKET + 3); /* more than a packet too */
        Vec3 c = test_rvec(&g, -4, 4);
        Ray r[2 * ACCEL_PACKET + 3];
        for (int j = 0; j < n; j++) {
            Vec3 o = vec_add(c, test_rvec(&g, -0.5f, 0.5f));
            o.y = k % 5 == 0 && j == 0 ? -0.5f : fabsf(o.y) * 0.3f + 1e-3f;
            Vec3 d = vec_sub(light, o);
            float len = vec_length(d);
            r[j] = ray_make(o, vec_scale(d, 1.0f / len), len);
        }
        RayStats st = {0};
        unsigned got = accel_occluded_packet(a, r, n, &st);
        assert_true(got >> n == 0);
        for (int j = 0; j < n; j++) {
            int want = accel_occluded(a, &r[j], &st);
            assert_int_equal((int)(got >> j & 1), want);
            blocked += want;
            by_plane += want && r[j].o.y < 0.0f;
            free_rays += !want;
        }
    }
    /* every kind of verdict was met */
    assert_true(blocked > 1000 && by_plane > 100 && free_rays > 1000);
    accel_free(a);
    scene_free(&s);
}

static void test_accessors(void **state)
{
    (void)state;
    unsigned long long g = 3;
    Scene s;
    random_scene(&s, 50, &g);
    Accel *a = accel_build(&s, PRIM_ROBUST, 1);
    assert_non_null(a);
    Vec3 lo, hi;
    assert_int_equal(accel_bounds(a, &lo, &hi), 0);
    for (int i = 0; i < s.nprims; i++) { /* the box holds every bounded primitive */
        float plo[3], phi[3];
        if (!bvh_prim_bounds(&s.prims[i], plo, phi))
            continue;
        for (int k = 0; k < 3; k++) {
            assert_true(vec_comp(lo, k) <= plo[k]);
            assert_true(vec_comp(hi, k) >= phi[k]);
        }
    }
    assert_true(accel_bytes(a) >= sizeof(BvhWideNode));
    accel_free(a);
    accel_free(NULL); /* safe, as free */
    /* planes alone, and nothing at all: no bounds, every query a miss or the plane */
    s.nprims = 0;
    a = accel_build(&s, PRIM_ROBUST, 1);
    assert_non_null(a);
    assert_int_equal(accel_bounds(a, &lo, &hi), -1);
    Ray r = ray_make(vec3(0, 0, 0), vec3(0, 0, 1), INFINITY);
    PrimHit h;
    RayStats st = {0};
    assert_int_equal(accel_closest(a, &r, &h, &st), -1);
    assert_int_equal(accel_occluded(a, &r, &st), 0);
    accel_free(a);
    s.prims[0].kind = PRIM_PLANE;
    s.prims[0].g.plane.n = vec3(0, 0, 1);
    s.prims[0].g.plane.d = 3;
    s.nprims = 1;
    a = accel_build(&s, PRIM_ROBUST, 1);
    assert_non_null(a);
    assert_int_equal(accel_bounds(a, &lo, &hi), -1);
    assert_int_equal(accel_closest(a, &r, &h, &st), 0);
    assert_float_equal(h.t, 3, 0);
    accel_free(a);
    scene_free(&s);
}

/* A plain loop over the primitives (the plan's choice for a handful of
 * them) answers every query as the BVH does: the same primitive and hit,
 * bit for bit, the same any-hit verdict, single and in packets. */
static void test_loop_answers_as_the_bvh(void **state)
{
    (void)state;
    unsigned long long g = 11;
    for (int n = 1; n <= 120; n += 17) {
        Scene s;
        random_scene(&s, n, &g);
        Accel *tree = accel_build_as(&s, PRIM_ROBUST, 1, 0), *loop = accel_build_as(&s, PRIM_ROBUST, 1, 1);
        assert_non_null(tree);
        assert_non_null(loop);
        RayStats st = {0};
        Ray r[ACCEL_PACKET];
        for (int k = 0; k < 4000; k++) {
            Vec3 o = test_rvec(&g, -6, 6);
            r[k % ACCEL_PACKET] = ray_make(o, vec_normalize(vec_sub(test_rvec(&g, -4, 4), o)), k % 4 ? INFINITY : 3.0f);
            const Ray *q = &r[k % ACCEL_PACKET];
            PrimHit a, b;
            int ia = accel_closest(tree, q, &a, &st), ib = accel_closest(loop, q, &b, &st);
            assert_int_equal(ia, ib);
            if (ia >= 0)
                assert_same_hit(&s.prims[ia], &a, &b);
            assert_int_equal(accel_occluded(tree, q, &st), accel_occluded(loop, q, &st));
            if (k % ACCEL_PACKET == ACCEL_PACKET - 1) {
                PrimHit ha[ACCEL_PACKET], hb[ACCEL_PACKET];
                int ba[ACCEL_PACKET], bb[ACCEL_PACKET];
                accel_closest_packet(tree, r, ACCEL_PACKET, ha, ba, &st);
                accel_closest_packet(loop, r, ACCEL_PACKET, hb, bb, &st);
                assert_memory_equal(ba, bb, sizeof ba);
                assert_int_equal(accel_occluded_packet(tree, r, ACCEL_PACKET, &st),
                                 accel_occluded_packet(loop, r, ACCEL_PACKET, &st));
            }
        }
        accel_free(tree);
        accel_free(loop);
        free(s.prims);
    }
}


/* PN patches are split ahead of rays into pieces in the BVH (accel.c):
 * the tree answers as the whole patches one by one, for rays from
 * outside and rays leaving the surface both ways, t within both bounds
 * and within those of exact mode's pn_hit, whichever mode the patches ask
 * for: the robust variant traces them all exact (fast mode's Newton steps
 * claim no bound). An octahedron whose vertex normals point out from its
 * centre: eight steep patches, among spheres, which accel_pn_split counts
 * (none in the classic variant). */
static void check_split_patches(PnMode mode)
{
    static const float V[6][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
    static const int F[8][3] = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4}, {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
    PnPatch patches[8];
    Scene s;
    memset(&s, 0, sizeof s);
    s.nprims = 12;
    s.prims = calloc((size_t)s.nprims, sizeof(Prim));
    assert_non_null(s.prims);
    unsigned long long g = 5;
    for (int f = 0; f < 8; f++) {
        Vec3 p[3], n[3];
        for (int k = 0; k < 3; k++) {
            p[k] = vec3(V[F[f][k]][0] * 1.5f, V[F[f][k]][1] * 1.5f, V[F[f][k]][2] * 1.5f);
            n[k] = vec_normalize(p[k]);
        }
        pn_patch_init(&patches[f], p, n);
        s.prims[3 * f / 2].kind = PRIM_PN; /* among the spheres: indices matter for ties */
    }
    for (int i = 0, f = 0; i < s.nprims; i++) {
        Prim *q = &s.prims[i];
        if (q->kind == PRIM_PN) {
            q->g.pn.patch = &patches[f++];
            q->g.pn.mode = (int)mode;
        } else {
            q->kind = PRIM_SPHERE;
            q->g.sphere.c = test_rvec(&g, -3, 3);
            q->g.sphere.r = 0.4f;
        }
    }
    Accel *tree = accel_build_as(&s, PRIM_ROBUST, 1, 0), *loop = accel_build_as(&s, PRIM_ROBUST, 1, 1);
    assert_non_null(tree);
    assert_non_null(loop);
    /* the patches were split: four pieces each at least, beyond the classic
     * variant's tree, which traces them whole */
    Accel *whole = accel_build_as(&s, PRIM_CLASSIC, 1, 0);
    assert_non_null(whole);
    assert_true(accel_bytes(tree) > accel_bytes(whole) + 8 * 4 * sizeof(PnPiece));
    int pieces = -1, loop_pieces = -1;
    assert_int_equal(accel_pn_split(tree, &pieces), 8);
    assert_true(pieces >= 8 * 4);
    assert_int_equal(accel_pn_split(loop, &loop_pieces), 8);
    assert_int_equal(loop_pieces, pieces);
    assert_int_equal(accel_pn_split(whole, &pieces), 0);
    assert_int_equal(pieces, 0);
    accel_free(whole);
    RayStats st = {0};
    int hits = 0;
    for (int k = 0; k < 6000; k++) {
        Vec3 o = test_rvec(&g, -5, 5);
        Ray r = ray_make(o, vec_normalize(vec_sub(test_rvec(&g, -1, 1), o)), INFINITY);
        for (int leave = 0; leave < 3; leave++) {
            /* the tree against the whole patches one by one (b), and the
             * loop, which splits them too, against the tree (a patch's t
             * may differ within its bound with the tmax it is traced to) */
            PrimHit a, b = {0, 0, 0, 0, 0}, c;
            int ia = accel_closest(tree, &r, &a, &st), ib = brute_closest(&s, &r, PRIM_ROBUST, &b);
            assert_int_equal(ia, ib);
            assert_int_equal(accel_closest(loop, &r, &c, &st), ia);
            if (ia >= 0)
                assert_true(fabsf(a.t - c.t) <= a.terr + c.terr);
            assert_int_equal(accel_occluded(tree, &r, &st), ib >= 0);
            assert_int_equal(accel_occluded(loop, &r, &st), ib >= 0);
            if (ia < 0 || s.prims[ia].kind != PRIM_PN)
                break;
            PnHit e;
            assert_true(fabsf(a.t - b.t) <= a.terr + b.terr);
            assert_true(pn_hit(s.prims[ia].g.pn.patch, &r, PN_EXACT, &e));
            assert_true(fabsf(a.t - e.t) <= a.terr + e.terr);
            hits += leave == 0;
            if (leave == 2)
                break;
            /* leave from there, outwards then inwards, from an origin off the surface */
            Vec3 x = vec_add(r.o, vec_scale(r.d, a.t)), out = vec_normalize(x);
            Vec3 side = leave ? vec_neg(out) : out;
            r = ray_make(vec_add(x, vec_scale(side, 1e-4f)), vec_normalize(vec_add(side, test_rvec(&g, -0.5f, 0.5f))),
                         INFINITY);
        }
    }
    assert_true(hits > 500);
    accel_free(tree);
    accel_free(loop);
    free(s.prims);
}

/* Rays whose direction has a component below 2^-128, not 0 (a review):
 * its inverse overflowed, the tree took the ray as parallel to that axis
 * and culled the boxes it drifts into, and lost hits that the loop and the
 * triangle's own routine find. Triangles at 2^-120, rays along z starting
 * just below each one's box and drifting up into it by t = 1, where they
 * cross it just above its lower edge. */
static void test_subnormal_direction_components(void **state)
{
    (void)state;
    enum { N = 64 };
    const float u = 0x1p-120f;
    Prim p[N];
    memset(p, 0, sizeof p);
    for (int i = 0; i < N; i++) {
        const float x = (float)(4 * (i % 8)) * u, y = (float)(4 * (i / 8)) * u;
        p[i].kind = PRIM_TRIANGLE;
        p[i].g.tri.a = vec3(x - u, y, u);
        p[i].g.tri.b = vec3(x + u, y, u);
        p[i].g.tri.c = vec3(x, y + 2 * u, u);
    }
    Scene s;
    memset(&s, 0, sizeof s);
    s.prims = p;
    s.nprims = N;
    Accel *tree = accel_build_as(&s, PRIM_ROBUST, 1, 0), *loop = accel_build_as(&s, PRIM_ROBUST, 1, 1);
    assert_non_null(tree);
    assert_non_null(loop);
    RayStats st = {0};
    int found = 0;
    for (int i = 0; i < N; i++) {
        const Triangle *t = &p[i].g.tri;
        const Vec3 c = vec3(t->c.x, t->a.y + 3 * 0x1p-131f, u);
        const Vec3 d = vec3((float)(i % 5 - 2) * 0x1p-140f, 0x1p-129f, u);
        const Ray r = ray_make(vec_sub(c, d), d, INFINITY);
        PrimHit a, b;
        const int ia = accel_closest(tree, &r, &a, &st), ib = accel_closest(loop, &r, &b, &st);
        assert_int_equal(ia, ib);
        assert_int_equal(accel_occluded(tree, &r, &st), accel_occluded(loop, &r, &st));
        found += ia == i;
    }
    assert_int_equal(found, N);
    accel_free(tree);
    accel_free(loop);
}

static void test_split_patches_answer_as_whole_ones(void **state)
{
    (void)state;
    check_split_patches(PN_EXACT);
    check_split_patches(PN_FAST);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_closest_and_occluded_match_brute_force),
        cmocka_unit_test(test_closest_except_matches_brute_force),
        cmocka_unit_test(test_ties_between_planes_and_the_bvh),
        cmocka_unit_test(test_closest_packet_is_closest),
        cmocka_unit_test(test_occluded_packet_is_occluded),
        cmocka_unit_test(test_accessors),
        cmocka_unit_test(test_loop_answers_as_the_bvh),
        cmocka_unit_test(test_split_patches_answer_as_whole_ones),
        cmocka_unit_test(test_subnormal_direction_components),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
