/* Unit tests for prim.c: analytic hits, misses, tangents, rays starting
 * inside, objects behind the ray, and rays parallel to planes and faces.
 * Every test runs twice: on the classic routines and on the robust ones. */
#include <stdarg.h>
#include <stdio.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <float.h>
#include <math.h>
#include <string.h>
#include <cmocka.h>

#include "testutil.h"

#include "lancer/prim.h"
#include "../src/tri4.h" /* tri_ray_init and the lanes: in test_prim_avx2, their AVX2 forms */

/* The four lanes' hits, as tri4_hit_watertight leaves them. */
typedef struct {
    float t[4], terr[4], u[4], v[4];
} Hit4;

static int tri4_hit(const PrimTri8 *t, int at, int lanes, const PrimTriRay *p, const Ray *r, Hit4 *h)
{
    return tri4_hit_watertight(t, at, lanes, p, r, h->t, h->terr, h->u, h->v);
}

/* Lane l of h4 holds hit h, bit for bit. */
static void assert_lane_is(const Hit4 *h4, int l, const PrimHit *h)
{
    assert_memory_equal(&h4->t[l], &h->t, sizeof(float));
    assert_memory_equal(&h4->terr[l], &h->terr, sizeof(float));
    assert_memory_equal(&h4->u[l], &h->u, sizeof(float));
    assert_memory_equal(&h4->v[l], &h->v, sizeof(float));
}

/* Triangle v into lane `lane` of t, as a BVH leaf holds it. */
static void put_lane(PrimTri8 *t, int lane, const Vec3 v[3])
{
    for (int k = 0; k < 3; k++) {
        t->v[k][0][lane] = v[k].x;
        t->v[k][1][lane] = v[k].y;
        t->v[k][2][lane] = v[k].z;
    }
}

static Ray ray(float ox, float oy, float oz, float dx, float dy, float dz)
{
    return ray_make(vec3(ox, oy, oz), vec_normalize(vec3(dx, dy, dz)), INFINITY);
}

/* The variant under test, set by each group's setup. */
static PrimVariant V;

static int setup_classic(void **state)
{
    (void)state;
    V = PRIM_CLASSIC;
    return 0;
}

static int setup_robust(void **state)
{
    (void)state;
    V = PRIM_ROBUST;
    return 0;
}

/* Each routine of the variant under test, returning t (and u, v, face). */
static int sphere_hit(const Sphere *s, const Ray *r, float *t)
{
    PrimHit h;
    int k = V == PRIM_ROBUST ? prim_sphere_hit_robust(s, r, &h) : prim_sphere_hit(s, r, &h);
    if (k)
        *t = h.t;
    return k;
}

static int plane_hit(const Plane *pl, const Ray *r, float *t)
{
    PrimHit h;
    int k = V == PRIM_ROBUST ? prim_plane_hit_robust(pl, r, &h) : prim_plane_hit(pl, r, &h);
    if (k)
        *t = h.t;
    return k;
}

static int triangle_hit(const Triangle *tr, const Ray *r, float *t, float *u, float *v)
{
    PrimHit h;
    int k = V == PRIM_ROBUST ? prim_triangle_hit_watertight(tr, r, &h) : prim_triangle_hit(tr, r, &h);
    if (k) {
        *t = h.t;
        *u = h.u;
        *v = h.v;
    }
    return k;
}

static int box_hit(const Box *b, const Ray *r, float *t, int *face)
{
    PrimHit h;
    int k = V == PRIM_ROBUST ? prim_box_hit_robust(b, r, &h) : prim_box_hit(b, r, &h);
    if (k) {
        *t = h.t;
        *face = h.face % 3; /* the axis; the robust box adds 3 for a max plane */
    }
    return k;
}

static int obox_hit(const OBox *b, const Ray *r, float *t, int *face)
{
    PrimHit h;
    int k = V == PRIM_ROBUST ? prim_obox_hit_robust(b, r, &h) : prim_obox_hit(b, r, &h);
    if (k) {
        *t = h.t;
        *face = h.face;
    }
    return k;
}

/* ---- sphere ---- */

static void test_sphere(void **state)
{
    (void)state;
    Sphere s = {{0, 0, 5}, 1};
    float t = -1;
    Ray r = ray(0, 0, 0, 0, 0, 1);
    assert_true(sphere_hit(&s, &r, &t));
    assert_float_equal(t, 4, 1e-6);
    r.tmax = 3.5f; /* the hit lies beyond tmax */
    assert_false(sphere_hit(&s, &r, &t));
    r = ray(0, 1.01f, 0, 0, 0, 1); /* passes just above */
    assert_false(sphere_hit(&s, &r, &t));
    r = ray(0, 0, 10, 0, 0, 1); /* sphere behind the ray */
    assert_false(sphere_hit(&s, &r, &t));
}

static void test_sphere_tangent_and_inside(void **state)
{
    (void)state;
    Sphere unit = {{0, 0, 0}, 1};
    float t = -1;
    /* Discriminant exactly 0: the grazing ray touches at (0, 1, 0). The
     * classic quadratic calls that a hit; for the robust routine a double
     * root is inside its documented band (tangent to working precision),
     * where it answers miss. */
    Ray r = ray(-5, 1, 0, 1, 0, 0);
    if (V == PRIM_CLASSIC) {
        assert_true(sphere_hit(&unit, &r, &t));
        assert_float_equal(t, 5, 1e-6);
    } else {
        assert_false(sphere_hit(&unit, &r, &t));
    }
    Sphere big = {{0, 0, 0}, 2};
    r = ray(0, 0, 0, 0, 0, -1); /* from the centre: the far side at t = r */
    assert_true(sphere_hit(&big, &r, &t));
    assert_float_equal(t, 2, 1e-6);
    Prim p = {PRIM_SPHERE, 0, {.sphere = {{0, 0, 0}, 2}}};
    PrimHit h;
    Surface sf;
    assert_true(prim_intersect(&p, &r, V, &h));
    prim_surface(&p, &r, &h, V, &sf);
    assert_vec(sf.p, 0, 0, -2, 1e-6);
    assert_vec(sf.ng, 0, 0, 1, 1e-6); /* flipped to face the ray: inward */
}

/* ---- ellipsoid ---- */

/* An ellipsoid of semi-axes 2, 1, 0.5 along x, y, z, centred at c: m maps
 * the unit sphere onto it. */
static Ellipsoid ellipsoid(double cx, double cy, double cz)
{
    Ellipsoid e = {{2, 0, 0, 0, 1, 0, 0, 0, 0.5, cx, cy, cz}, {0}};
    assert_int_equal(prim_ellipsoid_init(&e), 0);
    return e;
}

static void test_ellipsoid(void **state)
{
    (void)state;
    Ellipsoid e = ellipsoid(1, 2, 3);
    /* the inverse: x / 2, y, 2 z, less the centre's image */
    assert_true(e.a[0] == 0.5 && e.a[4] == 1 && e.a[8] == 2 && e.a[9] == -0.5 && e.a[10] == -2 && e.a[11] == -6);
    Prim p = {PRIM_ELLIPSOID, 0, {.ell = {&e, 0}}};
    PrimHit h;
    Surface sf;
    /* along each axis, from outside: the semi-axis decides where */
    const float o[3][3] = {{-9, 2, 3}, {1, -8, 3}, {1, 2, -7}}, d[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    const float want[3] = {8, 9, 9.5f};
    for (int k = 0; k < 3; k++) {
        Ray r = ray(o[k][0], o[k][1], o[k][2], d[k][0], d[k][1], d[k][2]);
        assert_true(prim_intersect(&p, &r, V, &h));
        assert_float_equal(h.t, want[k], 1e-5);
        if (V == PRIM_ROBUST)
            assert_true(fabsf(h.t - want[k]) <= h.terr);
        prim_surface(&p, &r, &h, V, &sf);
        assert_vec(sf.ng, -d[k][0], -d[k][1], -d[k][2], 1e-6); /* facing the ray */
    }
    /* an oblique hit: the normal is the gradient A^T (A p + b), not p - c */
    Ray r = ray(1 + 2 * 0.3f, 2 + 0.4f, -5, 0, 0, 1); /* the unit sphere's (0.3, 0.4, -sqrt(0.75)) */
    assert_true(prim_intersect(&p, &r, V, &h));
    assert_float_equal(h.t, 8 - sqrtf(0.75f) / 2, 1e-5);
    prim_surface(&p, &r, &h, V, &sf);
    float g[3] = {0.15f, 0.4f, -2 * sqrtf(0.75f)}, len = sqrtf(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]);
    assert_vec(sf.ng, g[0] / len, g[1] / len, g[2] / len, 1e-5);
    /* a miss beside the long axis, where a sphere of radius 2 would be hit */
    r = ray(1, 3.5f, -5, 0, 0, 1);
    assert_false(prim_intersect(&p, &r, V, &h));
    /* from inside: the far side */
    r = ray(1, 2, 3, 1, 0, 0);
    assert_true(prim_intersect(&p, &r, V, &h));
    assert_float_equal(h.t, 2, 1e-6);
    assert_true(prim_inside(&p, vec3(2.9f, 2, 3)));
    assert_false(prim_inside(&p, vec3(1, 2, 3.6f)));
    /* a singular map has no ellipsoid */
    Ellipsoid flat = {{1, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0}, {0}};
    assert_int_equal(prim_ellipsoid_init(&flat), -1);
    flat.m[8] = NAN;
    assert_int_equal(prim_ellipsoid_init(&flat), -1);
}

/* The robust ellipsoid's spawned rays leave on the side they go to, for
 * hits all over a thin, turned ellipsoid far from the origin. */
static void test_ellipsoid_spawn(void **state)
{
    (void)state;
    double c = cos(0.5), sn = sin(0.5);
    Ellipsoid e = {{300 * c, -0.02 * sn, 0, 300 * sn, 0.02 * c, 0, 0, 0, 5, 1000, -2000, 500}, {0}};
    assert_int_equal(prim_ellipsoid_init(&e), 0);
    Prim p = {PRIM_ELLIPSOID, 0, {.ell = {&e, 0}}};
    unsigned long long rng = 7;
    int hits = 0;
    for (int i = 0; i < 2000; i++) {
        Vec3 q = test_rvec(&rng, -1, 1), from = vec_add(vec3(1000, -2000, 500), vec_scale(test_rvec(&rng, -1, 1), 600));
        Vec3 to = vec3((float)(1000 + 300 * c * q.x), (float)(-2000 + 300 * sn * q.x), (float)(500 + 5 * q.z));
        Ray r = ray_make(from, vec_normalize(vec_sub(to, from)), INFINITY);
        Surface sf;
        if (!test_surface(&p, &r, PRIM_ROBUST, &sf))
            continue;
        hits++;
        /* out again (reflection) and in (refraction): outside, then inside */
        Vec3 out = vec_neg(r.d);
        assert_false(prim_inside(&p, prim_spawn_origin(&sf, out)));
        assert_true(prim_inside(&p, prim_spawn_origin(&sf, r.d)) || prim_inside(&p, vec3(from.x, from.y, from.z)));
    }
    assert_true(hits > 500);
}

/* Two rays of the exact judge's case 11 whose spawned origins, back along
 * the ray, were inside the ellipsoid: at a distance of 10^6 the float t is
 * 0.04 off, and o + t d with it; at 1.2 10^7 and a grazing 1.5 degrees the
 * normal at that point was also turned into the solid. */
static void test_ellipsoid_spawn_far_and_grazing(void **state)
{
    (void)state;
    static const double m[2][12] = {
        {0, -0x1.e311edfc98e0bp+0, 0, -0x1.964a019b4aff9p+0, 0, 0, 0, 0, -0x1.82504f49f8fd2p+0, 0, 0, 0},
        {-0x1.6488c2d0ed5b2p+2, -0x1.80f5268531e61p+2, 0x1.2ca70f381d8e8p+1, -0x1.d47f8f753fddbp+2,
         0x1.35b6bd086bbcap+2, -0x1.121eaad5b2fdbp+0, -0x1.92afd09be6a92p-1, -0x1.37e5ebbf5823ep+1,
         -0x1.aaf0371024219p+2, 0, 0, 0}};
    const Ray rays[2] = {
        {{0x1.7b75cep+19f, -0x1.ae1986p+17f, -0x1.492afp+19f}, {-0x1.7a319cp-1f, 0x1.aca9bcp-3f, 0x1.48118cp-1f},
         INFINITY},
        {{0x1.6a2feap+21f, -0x1.15d48p+23f, 0x1.bba3d2p+22f}, {-0x1.f977ap-3f, 0x1.83bd04p-1f, -0x1.359242p-1f},
         INFINITY}};
    for (int k = 0; k < 2; k++) {
        Ellipsoid e;
        memcpy(e.m, m[k], sizeof e.m);
        assert_int_equal(prim_ellipsoid_init(&e), 0);
        Prim p = {PRIM_ELLIPSOID, 0, {.ell = {&e, 0}}};
        PrimHit h;
        Surface sf;
        assert_true(prim_intersect(&p, &rays[k], PRIM_ROBUST, &h));
        prim_surface(&p, &rays[k], &h, PRIM_ROBUST, &sf);
        assert_true(vec_dot(sf.ng, rays[k].d) < 0.0f); /* outward: the ray enters */
        Vec3 q = prim_spawn_origin(&sf, vec_neg(rays[k].d));
        assert_false(prim_inside(&p, q));
        Ray back = ray_make(q, vec_neg(rays[k].d), INFINITY);
        assert_false(prim_intersect(&p, &back, PRIM_ROBUST, &h));
    }
}

/* ---- plane ---- */

static void test_plane(void **state)
{
    (void)state;
    Plane pl = {{0, 1, 0}, 2}; /* y = 2 */
    float t = -1;
    Ray r = ray(0, 0, 0, 0, 1, 0);
    assert_true(plane_hit(&pl, &r, &t));
    assert_float_equal(t, 2, 0);
    r = ray(0, 0, 0, 0, -1, 0); /* plane behind */
    assert_false(plane_hit(&pl, &r, &t));
    r = ray(0, 0, 0, 1, 0, 0); /* parallel, below */
    assert_false(plane_hit(&pl, &r, &t));
    r = ray(0, 2, 0, 1, 0, 0); /* parallel, in the plane */
    assert_false(plane_hit(&pl, &r, &t));
    r = ray(0, 0, 0, 0, 1, 0); /* tmax: a hit at t = tmax is none, one float further it is */
    r.tmax = 2.0f;
    assert_false(plane_hit(&pl, &r, &t));
    r.tmax = nextafterf(2.0f, 0.0f);
    assert_false(plane_hit(&pl, &r, &t));
    r.tmax = nextafterf(2.0f, INFINITY);
    assert_true(plane_hit(&pl, &r, &t));
    r = ray(0, 3, 0, 0, 1, 0); /* above, moving away */
    assert_false(plane_hit(&pl, &r, &t));
    r = ray(0, 2, 0, 0, 1, 0); /* from the plane itself: t = 0 */
    assert_false(plane_hit(&pl, &r, &t));
    r = ray(3, 6, 0, -3, -4, 0); /* oblique from above: distance 5 */
    assert_true(plane_hit(&pl, &r, &t));
    assert_float_equal(t, 5, 1e-6);
    Prim p = {PRIM_PLANE, 0, {.plane = pl}};
    PrimHit h;
    Surface sf;
    assert_true(prim_intersect(&p, &r, V, &h));
    prim_surface(&p, &r, &h, V, &sf);
    assert_vec(sf.p, 0, 2, 0, 1e-6);
    assert_vec(sf.ng, 0, 1, 0, 0);
    r = ray(0, 0, 0, 0, 1, 0); /* from below: the normal faces down */
    assert_true(prim_intersect(&p, &r, V, &h));
    prim_surface(&p, &r, &h, V, &sf);
    assert_vec(sf.ng, 0, -1, 0, 0);
    /* grazing: n . d is 0 in float and 8.7e-9 in fact, so the ray meets the
     * plane 10^8 away, going along n: the normal turns to face it (it did
     * not while the float product decided) */
    Prim g = {PRIM_PLANE, 0, {.plane = {vec3(0x1.d84184p-1f, -0x1.8b913p-2f, 0), 1}}};
    r = ray_make(vec3(0, 0, 0), vec3(0x1.07ed78p-2f, 0x1.3b186ap-1f, 0.5f), INFINITY);
    assert_true(vec_dot(g.g.plane.n, r.d) == 0.0f);
    if (prim_intersect(&g, &r, V, &h)) {
        prim_surface(&g, &r, &h, V, &sf);
        assert_true((double)sf.ng.x * r.d.x + (double)sf.ng.y * r.d.y + (double)sf.ng.z * r.d.z < 0.0);
        assert_true((double)sf.ns.x * r.d.x + (double)sf.ns.y * r.d.y + (double)sf.ns.z * r.d.z < 0.0);
    } else
        assert_true(V == PRIM_CLASSIC); /* the classic test takes the ray as parallel */
}

/* ---- triangle ---- */

static const Triangle tri = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0, 0, 1}, {0, 0, 1}, 0};

static void test_triangle(void **state)
{
    (void)state;
    float t = -1, u = -1, v = -1;
    Ray r = ray(0.25f, 0.5f, -2, 0, 0, 1);
    assert_true(triangle_hit(&tri, &r, &t, &u, &v));
    assert_float_equal(t, 2, 0);
    assert_float_equal(u, 0.25f, 0);
    assert_float_equal(v, 0.5f, 0);
    r = ray(0.25f, 0.5f, 2, 0, 0, -1); /* back side: two-sided */
    assert_true(triangle_hit(&tri, &r, &t, &u, &v));
    assert_float_equal(t, 2, 0);
    r = ray(0.75f, 0.75f, -2, 0, 0, 1); /* beyond the hypotenuse */
    assert_false(triangle_hit(&tri, &r, &t, &u, &v));
    r = ray(-0.1f, 0.5f, -2, 0, 0, 1); /* left of edge a-c */
    assert_false(triangle_hit(&tri, &r, &t, &u, &v));
    r = ray(0.25f, 0.25f, 2, 0, 0, 1); /* triangle behind */
    assert_false(triangle_hit(&tri, &r, &t, &u, &v));
    r = ray(-1, 0.25f, 0, 1, 0, 0); /* parallel, in its plane */
    assert_false(triangle_hit(&tri, &r, &t, &u, &v));
    r = ray(0.5f, 0.5f, -1, 0, 0, 1); /* exactly on the hypotenuse: u + v = 1 */
    assert_true(triangle_hit(&tri, &r, &t, &u, &v));
    assert_float_equal(u + v, 1, 0);
}

static void test_smooth_triangle_normal(void **state)
{
    (void)state;
    Prim p = {PRIM_SMOOTH_TRIANGLE, 0, {.tri = tri}};
    p.g.tri.na = vec3(0, 0, 1);
    p.g.tri.nb = vec_normalize(vec3(1, 0, 1));
    p.g.tri.nc = vec_normalize(vec3(0, 1, 1));
    Ray r = ray(0, 0, -1, 0, 0, 1); /* hits vertex a */
    PrimHit h;
    Surface sf;
    assert_true(prim_intersect(&p, &r, V, &h));
    prim_surface(&p, &r, &h, V, &sf);
    /* at a the shading normal is na, flipped with ng to face the ray */
    assert_vec(sf.ns, 0, 0, -1, 1e-6);
    assert_vec(sf.ng, 0, 0, -1, 1e-6);
    r = ray(1, 0, 1, 0, 0, -1); /* vertex b, from the other side */
    assert_true(prim_intersect(&p, &r, V, &h));
    prim_surface(&p, &r, &h, V, &sf);
    assert_vec(sf.ns, 0.70710678f, 0, 0.70710678f, 1e-6);
    assert_vec(sf.ng, 0, 0, 1, 1e-6);
}

static void test_smooth_normal_flips_on_its_own(void **state)
{
    (void)state;
    /* Vertex normals leaning far over: at a grazing view the interpolated
     * normal faces away from the ray while the face itself faces it. Each
     * is turned to face the ray on its own, as POV-Ray does. */
    Prim p = {PRIM_SMOOTH_TRIANGLE, 0, {.tri = tri}};
    p.g.tri.na = p.g.tri.nb = p.g.tri.nc = vec_normalize(vec3(1, 0, 0.2f));
    Ray r = ray(-1.75f, 0.25f, 0.5f, 4, 0, -1); /* meets (0.25, 0.25, 0); d.ng < 0 but d.ns > 0 */
    PrimHit h;
    Surface sf;
    assert_true(prim_intersect(&p, &r, V, &h));
    prim_surface(&p, &r, &h, V, &sf);
    assert_vec(sf.ng, 0, 0, 1, 1e-6);
    Vec3 n = vec_normalize(vec3(-1, 0, -0.2f));
    assert_vec(sf.ns, n.x, n.y, n.z, 1e-6);
}

static void test_inside(void **state)
{
    (void)state;
    Prim s = {PRIM_SPHERE, 0, {.sphere = {{0, 0, 0}, 1}}};
    assert_true(prim_inside(&s, vec3(0.5f, 0.5f, 0.5f)));
    assert_false(prim_inside(&s, vec3(1, 0, 0))); /* the surface is not inside */
    Prim b = {PRIM_BOX, 0, {.box = {{-1, -1, -1}, {1, 1, 1}}}};
    assert_true(prim_inside(&b, vec3(0.9f, -0.9f, 0)));
    assert_false(prim_inside(&b, vec3(1.1f, 0, 0)));
    /* a box's face and an oriented box's are inside, as for their hit
     * routines: a ray from there hits the far face (they were outside) */
    assert_true(prim_inside(&b, vec3(1, 0.5f, 0)));
    assert_true(prim_inside(&b, vec3(-1, -1, -1)));
    assert_false(prim_inside(&b, vec3(nextafterf(1, 2), 0.5f, 0)));
    Ray from_face = ray(1, 0.5f, 0, -1, 0, 0);
    PrimHit fh;
    assert_true(prim_intersect(&b, &from_face, V, &fh));
    assert_float_equal(fh.t, 2, 0);
    Prim o = {PRIM_OBOX, 0, {.obox = {{0, 0, 0}, {1, 0, 1}, {0, 1, 0}, {-1, 0, 1}, {{0, 0, 0}}}}};
    assert_int_equal(prim_obox_init(&o.g.obox), 0);
    assert_true(prim_inside(&o, vec3(0, 0, 1.9f)));
    assert_false(prim_inside(&o, vec3(1.9f, 0, 1.9f)));
    assert_true(prim_inside(&o, vec3(0, 1, 0))); /* on the face of v */
    assert_false(prim_inside(&o, vec3(0, 1.0001f, 0)));
    Prim pl = {PRIM_PLANE, 0, {.plane = {{0, 1, 0}, 0}}};
    assert_false(prim_inside(&pl, vec3(0, -5, 0))); /* planes are surfaces only */
}

static void test_spawn_origin(void **state)
{
    (void)state;
    /* A plane hit far from the origin: the spawned origin lies strictly on
     * the side the new ray leaves to, by at least a float's spacing. */
    Prim p = {PRIM_PLANE, 0, {.plane = {{0, 1, 0}, 0}}};
    Ray r = ray(1e5f, 3, 0, 1, -1, 0);
    PrimHit h;
    Surface sf;
    assert_true(prim_intersect(&p, &r, V, &h));
    prim_surface(&p, &r, &h, V, &sf);
    Vec3 up = prim_spawn_origin(&sf, vec3(0, 1, 0));
    Vec3 down = prim_spawn_origin(&sf, vec3(0, -1, 0));
    assert_true(up.y > 0 && up.y < 1.0f);
    assert_true(down.y < 0 && down.y > -1.0f);
    /* A box face: p is exactly on the face, and one float out is enough. */
    Prim b = {PRIM_BOX, 0, {.box = {{-1, -1, -1}, {1, 1, 1}}}};
    r = ray(0.25f, 0.5f, -5, 0, 0, 1);
    assert_true(prim_intersect(&b, &r, V, &h));
    prim_surface(&b, &r, &h, V, &sf);
    Vec3 out = prim_spawn_origin(&sf, vec3(0, 0, -1));
    Vec3 in = prim_spawn_origin(&sf, vec3(0, 0, 1));
    assert_true(out.z < -1.0f);
    assert_true(in.z > -1.0f);
    /* A face at 0: one float out is the smallest subnormal, on either side;
     * a negative coordinate steps towards and away from 0 by one float. */
    Prim b0 = {PRIM_BOX, 0, {.box = {{-1, -1, -2}, {1, 1, 0}}}};
    r = ray(-0.75f, 0.5f, 5, 0, 0, -1);
    assert_true(prim_intersect(&b0, &r, V, &h));
    prim_surface(&b0, &r, &h, V, &sf);
    if (V == PRIM_ROBUST) {
        assert_true(prim_spawn_origin(&sf, vec3(0, 0, 1)).z == 0x1p-149f);
        assert_true(prim_spawn_origin(&sf, vec3(0, 0, -1)).z == -0x1p-149f);
    }
    r = ray(-0.75f, 0.5f, -5, 0, 0, 1);
    assert_true(prim_intersect(&b0, &r, V, &h));
    prim_surface(&b0, &r, &h, V, &sf);
    if (V == PRIM_ROBUST) {
        assert_true(prim_spawn_origin(&sf, vec3(0, 0, -1)).z == nextafterf(-2.0f, -INFINITY));
        assert_true(prim_spawn_origin(&sf, vec3(0, 0, 1)).z == nextafterf(-2.0f, 0.0f));
    }
    /* Small scenes get small offsets: at 1e-4 the offset stays below 1e-8. */
    Prim s = {PRIM_SPHERE, 0, {.sphere = {{0, 0, 0}, 1e-4f}}};
    r = ray(0, 0, -1e-3f, 0, 0, 1);
    assert_true(prim_intersect(&s, &r, V, &h));
    prim_surface(&s, &r, &h, V, &sf);
    Vec3 o = prim_spawn_origin(&sf, vec3(0, 0, -1));
    assert_true(o.z < -1e-4f && o.z > -1e-4f - 1e-8f);
}

static void test_robust_error_bounds(void **state)
{
    (void)state;
    if (V != PRIM_ROBUST)
        return; /* the classic routines claim no bound */
    /* Exact answers: each robust t lies within its own terr, and terr is
     * small: a few ulps for most routines. */
    PrimHit h;
    Sphere s = {{0, 0, 5}, 1};
    Ray r = ray(0, 0, 0, 0, 0, 1);
    assert_true(prim_sphere_hit_robust(&s, &r, &h));
    assert_true(fabsf(h.t - 4) <= h.terr && h.terr < 4e-6f);
    Plane pl = {{0, 1, 0}, 2};
    r = ray(0, 0, 0, 0, 1, 0);
    assert_true(prim_plane_hit_robust(&pl, &r, &h));
    assert_true(fabsf(h.t - 2) <= h.terr && h.terr < 1e-6f);
    r = ray(0.25f, 0.5f, -2, 0, 0, 1);
    assert_true(prim_triangle_hit_watertight(&tri, &r, &h));
    /* pbrt's bound for the watertight test is loose: some 200 ulps here */
    assert_true(fabsf(h.t - 2) <= h.terr && h.terr < 1e-4f);
    Box b = {{-1, -1, -1}, {1, 1, 1}};
    r = ray(0, 0, -5, 0, 0, 1);
    assert_true(prim_box_hit_robust(&b, &r, &h));
    assert_true(fabsf(h.t - 4) <= h.terr && h.terr < 4e-6f);
    OBox o = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {{0, 0, 0}}};
    assert_int_equal(prim_obox_init(&o), 0);
    assert_true(prim_obox_hit_robust(&o, &r, &h));
    assert_true(fabsf(h.t - 4) <= h.terr && h.terr < 4e-6f);
}

/* Box coordinate i of q, in double: N_i . (q - c) / det, N_i the cross
 * product of the other two axes (products of floats are exact in double). */
/* prim_spawn_origins' pair against prim_spawn_origin for directions on
 * both sides of surface s: bit for bit. Returns the directions compared. */
static int spawn_pair_agrees(const Surface *s, unsigned long long *seed)
{
    Vec3 o[2];
    prim_spawn_origins(s, o);
    int n = 0;
    for (int k = 0; k < 64; k++) {
        Vec3 d = test_rvec(seed, -1, 1);
        float nd = vec_dot(s->ng, d);
        if (nd == 0.0f)
            continue;
        Vec3 want = prim_spawn_origin(s, d), got = o[nd > 0.0f];
        assert_memory_equal(&want, &got, sizeof want);
        n++;
    }
    return n;
}

/* prim_spawn_origin against its definition, with libm's nextafterf: p
 * moved by the error bound along the side's normal, then one float further
 * along each component the normal moves; for points at 0, at and around
 * the least and the largest floats, of either sign, huge enough to round
 * to infinity, normals with components of 0, and bounds of 0. */
static void test_spawn_origin_is_its_definition(void **state)
{
    (void)state;
    unsigned long long g = 99;
    static const float pick[] = {0.0f, -0.0f, 0x1p-149f, -0x1p-149f, 0x1p-126f, 3.5f, -7.25f, FLT_MAX, -FLT_MAX, 1e30f};
    int moved = 0;
    for (int k = 0; k < 20000; k++) {
        Surface sf;
        memset(&sf, 0, sizeof sf);
        float c[3], e[3], m[3];
        for (int i = 0; i < 3; i++) {
            int w = (int)test_uniform(&g, 0, 14);
            c[i] = w < 10 ? pick[w] : test_uniform(&g, -100, 100);
            e[i] = (k + i) % 3 == 0 ? 0.0f : test_uniform(&g, 0, 1e-3f);
            m[i] = (k >> i) % 4 == 0 ? 0.0f : test_uniform(&g, -1, 1);
        }
        sf.p = vec3(c[0], c[1], c[2]);
        sf.perr = vec3(e[0], e[1], e[2]);
        sf.noff = sf.ng = vec3(m[0], m[1], m[2]);
        Vec3 d = test_rvec(&g, -1, 1);
        float nd = vec_dot(sf.ng, d);
        Vec3 n = nd < 0.0f ? vec_neg(sf.noff) : sf.noff;
        float dist = fabsf(n.x) * sf.perr.x + fabsf(n.y) * sf.perr.y + fabsf(n.z) * sf.perr.z;
        float want[3] = {sf.p.x + dist * n.x, sf.p.y + dist * n.y, sf.p.z + dist * n.z}, nn[3] = {n.x, n.y, n.z};
        for (int i = 0; i < 3; i++)
            if (nn[i] != 0.0f) {
                want[i] = nextafterf(want[i], nn[i] > 0.0f ? INFINITY : -INFINITY);
                moved++;
            }
        Vec3 got = prim_spawn_origin(&sf, d);
        assert_memory_equal(&got.x, &want[0], sizeof(float));
        assert_memory_equal(&got.y, &want[1], sizeof(float));
        assert_memory_equal(&got.z, &want[2], sizeof(float));
    }
    assert_true(moved > 30000);
}

/* prim_near_edge: 1 for a triangle's hit on an edge, at a vertex or
 * within PRIM_EDGE_REACH spawn offsets of an edge (keeping the triangle and
 * the barycentrics), 0 for its other hits and for other primitives; Surface.edge -1 (not yet known) for the robust
 * triangle, 0 for the classic one and for other primitives. */
static void test_triangle_near_edge(void **state)
{
    (void)state;
    const Prim p = {PRIM_TRIANGLE, 0, {.tri = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0, 0, 1}, {0, 0, 1}}}};
    static const float at[][3] = {
        /* x, y, whether near an edge */
        {0.5f, 0.5f, 1},  {0.5f, 0.0f, 1},  {0.0f, 0.25f, 1}, {0.0f, 0.0f, 1}, {1.0f, 0.0f, 1},
        {0.5f, 1e-6f, 1}, {0.25f, 0.25f, 0}, {0.3f, 0.2f, 0},  {0.1f, 0.1f, 0},
        {0.4f, 0.5f, 0}, /* 0.1 / sqrt(2) from the long edge */
    };
    for (size_t i = 0; i < sizeof at / sizeof at[0]; i++)
        for (int v = 0; v < 2; v++) {
            const PrimVariant var = v ? PRIM_CLASSIC : PRIM_ROBUST;
            Ray r = ray(at[i][0], at[i][1], 5, 0, 0, -1);
            PrimHit h;
            Surface sf;
            assert_true(prim_intersect(&p, &r, var, &h));
            prim_surface(&p, &r, &h, var, &sf);
            assert_int_equal(sf.edge, v ? 0 : -1);
            if (v == 0 && prim_near_edge(&p, &h, &sf) != (int)at[i][2])
                print_error("hit at %g %g: near_edge %d\n", at[i][0], at[i][1], prim_near_edge(&p, &h, &sf));
            if (v == 0)
                assert_int_equal(prim_near_edge(&p, &h, &sf), (int)at[i][2]);
            if (v == 0 && at[i][2]) /* kept for prim_past_plane */
                assert_true(sf.tri == &p && sf.tu == h.u && sf.tv == h.v);
        }
    /* a sphere's hit, even where a triangle's would be on an edge */
    const Prim sp = {PRIM_SPHERE, 0, {.sphere = {{0, 0, 0}, 1}}};
    Ray r = ray(0, 0, 5, 0, 0, -1);
    PrimHit h;
    Surface sf;
    assert_true(prim_intersect(&sp, &r, PRIM_ROBUST, &h));
    prim_surface(&sp, &r, &h, PRIM_ROBUST, &sf);
    assert_int_equal(sf.edge, 0);
    assert_int_equal(prim_near_edge(&sp, &h, &sf), 0);
}

/* A hit on a triangle 80,000 across, tilted, seen from 10 away: its spawn
 * margin is wide against the point's distance, so the hit is marked (edge
 * 2) and its point is the ray's meeting with the plane, within
 * prim_wide_err of it; from the barycentrics it was up to 0.02 off the
 * ray. The same triangle a million times smaller, from as far, is not
 * marked. */
static void test_huge_triangle_hit(void **state)
{
    (void)state;
    for (int small = 0; small < 2; small++) {
        const float k = small ? 1e-6f : 1.0f;
        const Vec3 a = vec3(-40000 * k, -40000 * k, 3 * k), b = vec3(40000 * k, -40000 * k, 7 * k);
        const Vec3 c = vec3(0, 40000 * k, 5 * k);
        const Prim p = {PRIM_TRIANGLE, 0, {.tri = {a, b, c, {0, 0, 1}, {0, 0, 1}, {0, 0, 1}}}};
        for (int i = 0; i < 50; i++) {
            const Vec3 d = vec3(k * (0.013f * (float)i - 0.3f), k * (0.3f - 0.011f * (float)i), -1.0f);
            Ray r = ray_make(vec3(0.1f * k, 0.2f * k, 10), d, INFINITY);
            PrimHit h;
            Surface sf;
            assert_true(prim_intersect(&p, &r, PRIM_ROBUST, &h));
            prim_surface(&p, &r, &h, PRIM_ROBUST, &sf);
            if (small) {
                assert_int_equal(sf.edge, -1);
                continue;
            }
            assert_int_equal(sf.edge, 2);
            assert_true(sf.tri == &p);
            /* the meeting, in long double from the float data */
            long double n[3], e1[3], e2[3], ao[3], dd[3] = {d.x, d.y, d.z}, nd = 0, nao = 0;
            for (int j = 0; j < 3; j++) {
                e1[j] = (long double)vec_comp(b, j) - vec_comp(a, j);
                e2[j] = (long double)vec_comp(c, j) - vec_comp(a, j);
                ao[j] = (long double)vec_comp(a, j) - vec_comp(r.o, j);
            }
            for (int j = 0; j < 3; j++) {
                n[j] = e1[(j + 1) % 3] * e2[(j + 2) % 3] - e1[(j + 2) % 3] * e2[(j + 1) % 3];
                nd += n[j] * dd[j];
                nao += n[j] * ao[j];
            }
            const long double t = nao / nd;
            const float err = prim_wide_err(&sf);
            assert_true(err < 1e-5f);
            float off = 0.0f;
            for (int j = 0; j < 3; j++)
                off += (float)fabsl(vec_comp(sf.p, j) - (vec_comp(r.o, j) + t * dd[j]));
            if (!(off <= err))
                print_error("ray %d: point %g off the ray, bound %g\n", i, (double)off, (double)err);
            assert_true(off <= err);
        }
    }
}

/* Rays leaving a point within 0.01 above a triangle 80,000 across: the
 * test keeps a t within its error band of 0, so some of them hit it just
 * behind their origins. Such a hit is not marked huge: its point, the
 * ray's meeting with the plane, would lie behind the ray, and a ray off it
 * would go back (a loop without end through a glass ball standing there). */
static void test_huge_triangle_hit_behind(void **state)
{
    (void)state;
    const Prim p = {PRIM_TRIANGLE,
                    0,
                    {.tri = {{-40000, 0, -40000}, {40000, 0, -40000}, {0, 0, 40000}, {0, 0, 1}, {0, 0, 1}, {0, 0, 1}}}};
    int hits = 0;
    for (int i = 0; i < 2000; i++) {
        const Vec3 d = vec_normalize(vec3(0.1f * (float)(i / 100) - 1.0f, 0.3f, 0.7f));
        Ray r = ray_make(vec3(0.3f, 1e-4f * (float)(i % 100 + 1), 0.2f), d, INFINITY);
        PrimHit h;
        Surface sf;
        if (!prim_intersect(&p, &r, PRIM_ROBUST, &h))
            continue;
        hits++;
        prim_surface(&p, &r, &h, PRIM_ROBUST, &sf);
        assert_int_not_equal(sf.edge, 2);
    }
    assert_true(hits > 0); /* the band's hits are there to be looked at */
}

/* prim_past_plane: 1 when the point lies on a flat primitive's plane
 * (within its error bound) or past it along d, 0 when d heads for the
 * plane from in front of it, and 0 for primitives that are not flat. */
static void test_past_plane(void **state)
{
    (void)state;
    const Prim flat = {PRIM_TRIANGLE, 0, {.tri = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0, 0, 1}, {0, 0, 1}}}};
    const Prim plane = {PRIM_PLANE, 0, {.plane = {{0, 1, 0}, 2}}};
    const Prim sphere = {PRIM_SPHERE, 0, {.sphere = {{0, 0, 0}, 1}}};
    Surface s;
    memset(&s, 0, sizeof s);
    s.perr = vec3(1e-6f, 1e-6f, 1e-6f);
    const Vec3 up = vec3(0, 0, 1), down = vec3(0, 0, -1);
    s.p = vec3(0.2f, 0.2f, 1.0f); /* in front of the triangle's plane */
    assert_int_equal(prim_past_plane(&flat, &s, down), 0);
    assert_int_equal(prim_past_plane(&flat, &s, up), 1);
    s.p = vec3(0.2f, 0.2f, -1.0f); /* behind it: down leads away */
    assert_int_equal(prim_past_plane(&flat, &s, down), 1);
    assert_int_equal(prim_past_plane(&flat, &s, up), 0);
    s.p = vec3(0.2f, 0.2f, 1e-3f); /* 1e-3 in front: on it within an error of 1e-2, not of 1e-6 */
    assert_int_equal(prim_past_plane(&flat, &s, down), 0);
    s.perr = vec3(1e-2f, 1e-2f, 1e-2f);
    assert_int_equal(prim_past_plane(&flat, &s, down), 1);
    s.perr = vec3(1e-6f, 1e-6f, 1e-6f);
    s.p = vec3(5, 0.2f, 0); /* on the plane, outside the triangle: the plane is what counts */
    assert_int_equal(prim_past_plane(&flat, &s, down), 1);
    assert_int_equal(prim_past_plane(&flat, &s, vec3(1, 0, 0)), 1); /* along the plane */
    s.p = vec3(0, 3, 0); /* above the plane y = 2 */
    assert_int_equal(prim_past_plane(&plane, &s, vec3(0, -1, 0)), 0);
    assert_int_equal(prim_past_plane(&plane, &s, vec3(0, 1, 0)), 1);
    s.p = vec3(0, 0, 1); /* on the sphere: not a flat primitive */
    assert_int_equal(prim_past_plane(&sphere, &s, up), 0);
}

/* prim_past_plane for a hit near a triangle's edge (Surface.edge 1, with
 * tri, tu and tv): the side of the exact point, from the triangle's
 * vertices, however near the plane and however large the point's error
 * bound. */
static void test_past_plane_of_triangle_hit(void **state)
{
    (void)state;
    /* A in z = 0; B shares A's edge from (0,0,0) to (1,0,0) and stands in
     * y = 0, A's third vertex on its negative side (B's normal is -y). */
    const Prim a = {PRIM_TRIANGLE, 0, {.tri = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0, 0, 1}, {0, 0, 1}}}};
    const Prim b = {PRIM_TRIANGLE, 0, {.tri = {{0, 0, 0}, {1, 0, 0}, {0, 0, 1}, {0, 1, 0}, {0, 1, 0}, {0, 1, 0}}}};
    const Prim coplanar = {PRIM_TRIANGLE, 0, {.tri = {{0, 0, 0}, {0, 1, 0}, {-1, 0, 0}, {0, 0, 1}, {0, 0, 1}, {0, 0, 1}}}};
    const Prim across = {PRIM_TRIANGLE, 0, {.tri = {{0.3f, 0, 0}, {0.3f, 1, 0}, {0.3f, 0, 1}, {1, 0, 0}, {1, 0, 0}, {1, 0, 0}}}};
    Surface s;
    memset(&s, 0, sizeof s);
    s.edge = 1;
    s.tri = &a;
    s.tu = 0.5f; /* 1e-7 from the shared edge, inside A */
    s.tv = 1e-7f;
    s.p = vec3(0.5f, 1e-7f, 0);
    s.perr = vec3(1e-4f, 1e-4f, 1e-4f); /* a spawn margin, far wider than 1e-7 */
    /* towards B from its inner side: B lies ahead, 1e-7 away */
    assert_int_equal(prim_past_plane(&b, &s, vec3(0, -1, 0)), 0);
    assert_int_equal(prim_past_plane(&b, &s, vec3(0.6f, -0.8f, 0)), 0);
    /* away from it: behind */
    assert_int_equal(prim_past_plane(&b, &s, vec3(0, 1, 0)), 1);
    /* for a hit away from an edge, the point within its error bound of
     * B's plane counts as on it */
    s.edge = 0;
    assert_int_equal(prim_past_plane(&b, &s, vec3(0, -1, 0)), 1);
    s.edge = 1;
    /* exactly on the shared edge: on B's plane, t = 0 */
    s.tv = 0.0f;
    assert_int_equal(prim_past_plane(&b, &s, vec3(0, -1, 0)), 1);
    s.tv = 1e-7f;
    /* a face in A's own plane: the point is on it, either way */
    assert_int_equal(prim_past_plane(&coplanar, &s, vec3(0, 0, 1)), 1);
    assert_int_equal(prim_past_plane(&coplanar, &s, vec3(0, 0, -1)), 1);
    /* a plane across A (x = 0.3): A's vertices on both sides, so the
     * point's own side, 0.2 past it */
    assert_int_equal(prim_past_plane(&across, &s, vec3(-1, 0, 0)), 0);
    assert_int_equal(prim_past_plane(&across, &s, vec3(1, 0, 0)), 1);
}

static void test_line_crosses_triangle(void **state)
{
    (void)state;
    /* A in z = 0; B in y = 0 shares A's edge from (0,0,0) to (1,0,0); the
     * hit on A is 1e-7 from that edge, (0.5, 1e-7, 0). */
    const Prim a = {PRIM_TRIANGLE, 0, {.tri = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0, 0, 1}, {0, 0, 1}}}};
    const Prim b = {PRIM_TRIANGLE, 0, {.tri = {{0, 0, 0}, {1, 0, 0}, {0, 0, 1}, {0, 1, 0}, {0, 1, 0}, {0, 1, 0}}}};
    Surface s;
    memset(&s, 0, sizeof s);
    s.edge = 1;
    s.tri = &a;
    s.tu = 0.5f;
    s.tv = 1e-7f;
    /* B's plane 1e-7 ahead, met at (0.5, 0, 1e-7): inside B */
    assert_int_equal(prim_line_crosses(&b, &s, vec3(0, -1, 1)), 1);
    /* met at (0.5, 0, -1e-7): beside B, past its edge */
    assert_int_equal(prim_line_crosses(&b, &s, vec3(0, -1, -1)), 0);
    /* away from B's plane, and along it */
    assert_int_equal(prim_line_crosses(&b, &s, vec3(0, 1, 1)), 0);
    assert_int_equal(prim_line_crosses(&b, &s, vec3(1, 0, 0)), 0);
    /* the hit's own triangle, and a plane, are never crossed */
    assert_int_equal(prim_line_crosses(&a, &s, vec3(0, 0, -1)), 0);
    const Prim plane = {PRIM_PLANE, 0, {.plane = {{0, 1, 0}, 0}}};
    assert_int_equal(prim_line_crosses(&plane, &s, vec3(0, -1, 1)), 0);
    /* C stands on A's edge from (1,0,0) to (0,1,0), in x + y + z = 1,
     * below A. The hit's b1 + b2 pass 1 by a rounding: taken as they are,
     * the point lies 1e-7 past that edge, off C's plane, and a ray down
     * meets C at once; brought back onto the edge, it lies on C's plane. */
    const Prim c = {PRIM_TRIANGLE, 0, {.tri = {{1, 0, 0}, {0, 1, 0}, {1, 1, -1}, {0, 0, 1}, {0, 0, 1}, {0, 0, 1}}}};
    s.tu = 0.6f;
    s.tv = 0.4000001f;
    assert_int_equal(prim_line_crosses(&c, &s, vec3(0, 0, -1)), 0);
    /* from well inside A, the same ray does not reach C, and one across it does */
    s.tu = 0.3f;
    s.tv = 0.3f;
    assert_int_equal(prim_line_crosses(&c, &s, vec3(0, 0, -1)), 0);
    assert_int_equal(prim_line_crosses(&c, &s, vec3(1, 1, -0.5f)), 1);
}

/* A hit exactly on a triangle's edge b c has weight 1 - u - v = 0 there,
 * but u and v are each rounded: a camera ray in the plane of a smooth
 * icosahedron's edge (POV-Ray parity, an odd image width) hit it with u
 * and v below, whose 1 - u - v is 7.45e-9. Taken as it was, that weight
 * put the point inside A, behind B, and the shadow ray across the ridge
 * was blocked where it leaves the solid; within its roundings of 0, the
 * point is on the edge, and on B's plane. */
static void test_hit_on_edge_bc(void **state)
{
    (void)state;
    /* A in z = 0 with its edge b c along the x axis, a on the +y side; B
     * in y = 0 shares that edge, A's vertex a on B's negative side. */
    const Prim a = {PRIM_TRIANGLE, 0, {.tri = {{0, 1, 0}, {0, 0, 0}, {1, 0, 0}, {0, 0, 1}, {0, 0, 1}, {0, 0, 1}}}};
    const Prim b = {PRIM_TRIANGLE, 0, {.tri = {{0, 0, 0}, {1, 0, 0}, {0, 0, 1}, {0, -1, 0}, {0, -1, 0}, {0, -1, 0}}}};
    Surface s;
    memset(&s, 0, sizeof s);
    s.edge = 1;
    s.tri = &a;
    s.tu = 0.904616654f;
    s.tv = 0.0953833386f;
    assert_true(1.0f - s.tu - s.tv > 0.0f); /* the rounding this is about */
    s.p = vec3(s.tv, 0, 0);
    s.perr = vec3(1e-7f, 1e-7f, 1e-7f);
    /* on B's plane: past it, either way */
    assert_int_equal(prim_past_plane(&b, &s, vec3(0, -1, 0)), 1);
    assert_int_equal(prim_past_plane(&b, &s, vec3(0, 1, 0)), 1);
    /* so the line from the point towards B's side does not cross B */
    assert_int_equal(prim_line_crosses(&b, &s, vec3(0, -1, 1)), 0);
    /* a point truly inside A, 1e-5 from the edge, is behind B still */
    s.tu = 0.9f;
    s.tv = 0.09999f;
    assert_int_equal(prim_past_plane(&b, &s, vec3(0, -1, 0)), 0);
    assert_int_equal(prim_line_crosses(&b, &s, vec3(0, -1, 1)), 1);
}

static double obox_coord(const OBox *b, Vec3 q, int i)
{
    const Vec3 ax[3] = {b->u, b->v, b->w};
    Vec3 a = ax[(i + 1) % 3], c = ax[(i + 2) % 3];
    double n[3] = {(double)a.y * c.z - (double)a.z * c.y, (double)a.z * c.x - (double)a.x * c.z,
                   (double)a.x * c.y - (double)a.y * c.x};
    Vec3 u = ax[i];
    double det = u.x * n[0] + u.y * n[1] + u.z * n[2];
    return (n[0] * ((double)q.x - b->c.x) + n[1] * ((double)q.y - b->c.y) + n[2] * ((double)q.z - b->c.z)) / det;
}

static void test_obox_spawn_inside_near_edge(void **state)
{
    (void)state;
    /* Two rays from inside oriented boxes that leave them beside an edge
     * (found by the exact judge's case 8 at 10^8 rays): moved off the face
     * along its normal, the origin spawned back inside stayed outside the
     * neighbouring face, where the hit point's error had put it. */
    static const float in[2][18] = {
        {0x1.ea5d62p-10f, 0x1.0685dep+5f, -0x1.d3c1b4p-6f, 0x1.08a7b6p-5f, 0x1.2751e4p-4f, 0x1.26398cp-7f,
         -0x1.4558a8p-6f, -0x1.d146a8p-8f, 0x1.07138ep-3f, 0x1.164316p-4f, -0x1.024dfep-5f, 0x1.1f0594p-7f,
         -0x1.5f4baep-6f, 0x1.06a262p+5f, 0x1.c11c04p-5f, -0x1.9cac96p-1f, 0x1.2fde1ap-2f, 0x1.0638bcp-1f},
        {0x1.0724acp+18f, 0x1.15b2dcp+10f, -0x1.a0d414p+10f, -0x1.534884p+8f, 0x1.120898p+4f, 0x1.e43bccp+7f,
         0x1.1d1e66p+8f, 0x1.a267aap+9f, 0x1.545902p+8f, -0x1.955656p+7f, 0x1.7c0fdap+7f, -0x1.297242p+8f,
         0x1.075276p+18f, 0x1.baae3ap+10f, -0x1.03e988p+10f, -0x1.a115f8p-3f, -0x1.d88676p-1f, -0x1.4e9cbep-2f},
    };
    for (int k = 0; k < 2; k++) {
        const float *x = in[k];
        Prim p = {PRIM_OBOX, 0, {.obox = {{x[0], x[1], x[2]}, {x[3], x[4], x[5]}, {x[6], x[7], x[8]},
                                          {x[9], x[10], x[11]}, {{0, 0, 0}}}}};
        assert_int_equal(prim_obox_init(&p.g.obox), 0);
        Ray r = ray_make(vec3(x[12], x[13], x[14]), vec3(x[15], x[16], x[17]), INFINITY);
        for (int i = 0; i < 3; i++)
            assert_true(fabs(obox_coord(&p.g.obox, r.o, i)) < 1.0); /* the origin is inside */
        PrimHit h;
        assert_true(prim_obox_hit_robust(&p.g.obox, &r, &h));
        Surface s;
        prim_surface(&p, &r, &h, PRIM_ROBUST, &s);
        Vec3 q = prim_spawn_origin(&s, vec_neg(r.d));
        for (int i = 0; i < 3; i++)
            assert_true(fabs(obox_coord(&p.g.obox, q, i)) < 1.0);
        /* pinned: the origin of one side is the pin, as a pair too */
        assert_true(s.pin_side != 0);
        unsigned long long seed = 5;
        assert_true(spawn_pair_agrees(&s, &seed) > 0);
    }
}

static void test_spawn_origins_pair(void **state)
{
    (void)state;
    /* Rays from inside and outside every bounded kind, the oriented boxes'
     * near their edges too (where the origin is pinned on one side). */
    unsigned long long seed = 77;
    int compared = 0;
    for (int i = 0; i < 3000; i++) {
        Prim p;
        memset(&p, 0, sizeof p);
        switch (i % 4) {
        case 0:
            p.kind = PRIM_SPHERE;
            p.g.sphere.c = test_rvec(&seed, -5, 5);
            p.g.sphere.r = test_uniform(&seed, 0.1f, 3.0f);
            break;
        case 1:
            p.kind = PRIM_TRIANGLE;
            p.g.tri.a = test_rvec(&seed, -5, 5);
            p.g.tri.b = test_rvec(&seed, -5, 5);
            p.g.tri.c = test_rvec(&seed, -5, 5);
            break;
        case 2:
            p.kind = PRIM_BOX;
            p.g.box.lo = test_rvec(&seed, -5, 0);
            p.g.box.hi = vec_add(p.g.box.lo, test_rvec(&seed, 0.1f, 5));
            break;
        default:
            p.kind = PRIM_OBOX;
            p.g.obox.c = test_rvec(&seed, -2, 2);
            p.g.obox.u = test_rvec(&seed, -2, 2);
            p.g.obox.v = test_rvec(&seed, -2, 2);
            p.g.obox.w = test_rvec(&seed, -2, 2);
            if (prim_obox_init(&p.g.obox) != 0)
                continue;
        }
        Vec3 mid = p.kind == PRIM_SPHERE     ? p.g.sphere.c
                   : p.kind == PRIM_TRIANGLE ? vec_scale(vec_add(vec_add(p.g.tri.a, p.g.tri.b), p.g.tri.c), 1.0f / 3)
                   : p.kind == PRIM_BOX      ? vec_scale(vec_add(p.g.box.lo, p.g.box.hi), 0.5f)
                                             : p.g.obox.c;
        /* from near the middle (inside the solids) and from far outside */
        Vec3 o = i & 4 ? vec_add(mid, test_rvec(&seed, -0.05f, 0.05f)) : vec_add(mid, test_rvec(&seed, -20, 20));
        Ray r = ray_make(o, vec_sub(vec_add(mid, test_rvec(&seed, -1, 1)), o), INFINITY);
        Surface sf;
        if (!test_surface(&p, &r, PRIM_ROBUST, &sf))
            continue;
        compared += spawn_pair_agrees(&sf, &seed);
    }
    assert_true(compared > 50000); /* (the pinned ones: test_obox_spawn_inside_near_edge) */
}

static void test_box_origin_on_slab_plane(void **state)
{
    (void)state;
    /* An origin on the plane x = -1 moving parallel to it, with +0 and -0
     * x direction: (lo - o) * (1/0) is 0 * inf = NaN. The ray runs along
     * the closed box's face, which it touches: a hit at z = -1. */
    Box b = {{-1, -1, -1}, {1, 1, 1}};
    const float zeros[2] = {0.0f, -0.0f};
    for (int i = 0; i < 2; i++) {
        Ray r = ray_make(vec3(-1, 0, -5), vec3(zeros[i], 0, 1), INFINITY);
        PrimHit h;
        int hit = V == PRIM_ROBUST ? prim_box_hit_robust(&b, &r, &h) : prim_box_hit(&b, &r, &h);
        if (V == PRIM_ROBUST) {
            assert_true(hit);
            assert_float_equal(h.t, 4, 0);
        }
        r.o.x = 1; /* on x = hi */
        hit = V == PRIM_ROBUST ? prim_box_hit_robust(&b, &r, &h) : prim_box_hit(&b, &r, &h);
        if (V == PRIM_ROBUST)
            assert_true(hit);
    }
}

static void test_watertight_shared_edge(void **state)
{
    (void)state;
    /* A quad split along its diagonal; rays aimed at points of the
     * diagonal from off-axis origins, whose directions round in float.
     * The watertight test lets none of them through; Moller-Trumbore is
     * only measured (the exact judge reports how often it leaks). */
    Triangle t1 = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 0, 1}, {0, 0, 1}, {0, 0, 1}, 0};
    Triangle t2 = {{0, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0, 0, 1}, {0, 0, 1}, {0, 0, 1}, 0};
    int leaks = 0;
    for (int k = 1; k < 1000; k++) {
        float s = (float)k / 1000.0f;
        Vec3 o = vec3(0.3f + 0.001f * (float)k, -0.7f, -1.3f);
        Vec3 d = vec_sub(vec3(s, s, 0), o);
        Ray r = ray_make(o, d, INFINITY);
        PrimHit h;
        int hit = V == PRIM_ROBUST ? prim_triangle_hit_watertight(&t1, &r, &h) || prim_triangle_hit_watertight(&t2, &r, &h)
                                   : prim_triangle_hit(&t1, &r, &h) || prim_triangle_hit(&t2, &r, &h);
        leaks += !hit;
    }
    if (V == PRIM_ROBUST)
        assert_int_equal(leaks, 0);
}

/* ---- axis-aligned box ---- */

static const Box cube = {{-1, -1, -1}, {1, 1, 1}};

static void test_box(void **state)
{
    (void)state;
    float t = -1;
    int face = -1;
    Ray r = ray(0, 0, -5, 0, 0, 1);
    assert_true(box_hit(&cube, &r, &t, &face));
    assert_float_equal(t, 4, 0);
    assert_int_equal(face, 2);
    r = ray(0.5f, 0.5f, 5, 0, 0, -1); /* negative direction */
    assert_true(box_hit(&cube, &r, &t, &face));
    assert_float_equal(t, 4, 0);
    r = ray(0, 0, 0, 1, 0, 0); /* from inside: the far face */
    assert_true(box_hit(&cube, &r, &t, &face));
    assert_float_equal(t, 1, 0);
    assert_int_equal(face, 0);
    r = ray(0, 0, 5, 0, 0, 1); /* box behind */
    assert_false(box_hit(&cube, &r, &t, &face));
    r = ray(-5, 0.5f, 0, 1, 0, 0); /* parallel to four faces, inside their slabs */
    assert_true(box_hit(&cube, &r, &t, &face));
    assert_float_equal(t, 4, 0);
    assert_int_equal(face, 0);
    r = ray(-5, 2, 0, 1, 0, 0); /* parallel and outside the y slab */
    assert_false(box_hit(&cube, &r, &t, &face));
    r = ray(-5, 0, -5, 1, 0, 0.2f); /* passes beside */
    assert_false(box_hit(&cube, &r, &t, &face));
    r = ray(-3, 4, 0, 3, -4, 0); /* oblique onto the top face at (0, 1, 0) */
    assert_true(box_hit(&cube, &r, &t, &face));
    assert_float_equal(t, 3.75f, 1e-6);
    assert_int_equal(face, 1);
    r.tmax = 3.0f;
    assert_false(box_hit(&cube, &r, &t, &face));
}

static void test_box_pad_covers_the_roundings(void **state)
{
    (void)state;
    /* prim.h's bound, with u = 2^-53: the pad is at least (1 + u)^3 /
     * (1 - u)^4 = 1 + 7u + 25u^2 + ..., which is below 1 + 7u (1 + 2^-40).
     * PRIM_BOX_PAD - 1 is exact in double. (1 + 2 gamma(3), about 1 + 6u,
     * failed it.) */
    const double u = 0x1p-53;
    assert_true(PRIM_BOX_PAD - 1.0 >= 7.0 * u * (1.0 + 0x1p-40));
}

/* ---- oriented box ---- */

static void test_obox_init(void **state)
{
    (void)state;
    OBox b = {{1, 2, 3}, {2, 0, 0}, {1, 1, 0}, {0, 0.5f, 3}, {{0, 0, 0}}};
    assert_int_equal(prim_obox_init(&b), 0);
    Vec3 ax[3] = {b.u, b.v, b.w};
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            assert_float_equal(vec_dot(b.inv[i], ax[j]), i == j ? 1 : 0, 1e-6);
    OBox flat = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}, {{0, 0, 0}}};
    assert_int_equal(prim_obox_init(&flat), -1);
    /* axes of 1e13 overflow the determinant: the inverse would be all zero */
    OBox huge = {{0, 0, 0}, {1e13f, 0, 0}, {0, 1e13f, 0}, {0, 0, 1e13f}, {{0, 0, 0}}};
    assert_int_equal(prim_obox_init(&huge), -1);
}

static void test_obox(void **state)
{
    (void)state;
    /* the unit cube turned 45 degrees about y: half-diagonals of length sqrt 2 */
    OBox b = {{0, 0, 0}, {1, 0, 1}, {0, 1, 0}, {-1, 0, 1}, {{0, 0, 0}}};
    assert_int_equal(prim_obox_init(&b), 0);
    float t = -1;
    int face = -1;
    Ray r = ray(0.5f, 0, -5, 0, 0, 1); /* enters through the w face at z = -1.5 */
    assert_true(obox_hit(&b, &r, &t, &face));
    assert_float_equal(t, 3.5f, 1e-6);
    assert_int_equal(face, 2);
    Prim p = {PRIM_OBOX, 0, {.obox = b}};
    PrimHit h;
    Surface sf;
    assert_true(prim_intersect(&p, &r, V, &h));
    prim_surface(&p, &r, &h, V, &sf);
    assert_vec(sf.ng, 0.70710678f, 0, -0.70710678f, 1e-6);
    r = ray(0, 0, 0, 0, 0, 1); /* from the centre: the far corner at z = 2 */
    assert_true(obox_hit(&b, &r, &t, &face));
    assert_float_equal(t, 2, 1e-6);
    r = ray(0, 0, 5, 0, 0, 1); /* behind */
    assert_false(obox_hit(&b, &r, &t, &face));
    r = ray(-5, 0.5f, -5, 1, 0, 1); /* parallel to the u axis, inside the other slabs */
    assert_true(obox_hit(&b, &r, &t, &face));
    assert_float_equal(t, 5 * 1.41421356f - 1.41421356f, 1e-5);
    r = ray(-5, 2, -5, 1, 0, 1); /* parallel and above the v slab */
    assert_false(obox_hit(&b, &r, &t, &face));
    r = ray(3, 0, -5, 0, 0, 1); /* passes beside */
    assert_false(obox_hit(&b, &r, &t, &face));
}

/* A ray 2^-49 off parallel to a skewed box's face plane, passing 6.9 from
 * the box (the exact judge's --check: a miss). The robust routine once
 * widened each slab by its quotients' error bounds, which grow without
 * limit as the ray turns parallel: the slab was as good as ignored, and
 * the ray reported a hit at t = 9. Widened in slab units, it misses; and
 * the same ray shifted to pass through the box still hits, with a t whose
 * bound holds. */
static void test_obox_grazing_slab(void **state)
{
    (void)state;
    OBox b = {{0, 0, 0}, {1, 1, 1}, {1, -1, 0}, {0, 1, -1}, {{0, 0, 0}}};
    assert_int_equal(prim_obox_init(&b), 0);
    Ray r = ray_make(vec3(-5, 5, 15), vec3(1, 0x1p-49f, -1), INFINITY);
    PrimHit h;
    assert_false(prim_obox_hit_robust(&b, &r, &h));
    /* Along the middle plane of the grazed slab, (1,1,1).p = 0: the w slab
     * ((1,1,-2).p within 3) holds t in [4.5, 6.5] less a few 2^-49, the v
     * slab ((2,-1,-1).p within 3) t in [4, 6]: in through the w face. */
    r = ray_make(vec3(-5, -0.5f, 5.5f), vec3(1, 0x1p-49f, -1), INFINITY);
    assert_true(prim_obox_hit_robust(&b, &r, &h));
    assert_true(fabsf(h.t - 4.5f) <= h.terr + 1e-6f);
    assert_int_equal(h.face, 2);
}

/* A ray spawned from a triangle hit never hits that triangle again, in
 * any direction. The triangle of CGAL's fandisk_large.off that make bench
 * found: it lies 3e-14 from the plane z = 0 while its other coordinates
 * are near 17, so the hit point's own error along the normal is ~1e-20,
 * far below the error band of the triangle test (~1e-7 of the triangle's
 * size, from its x and y); 403 of 741 spawned rays hit it again at t ~1e-9
 * and shadowed it. Then random triangles, placed near the origin, near a
 * coordinate plane, or far away, some of them long and thin. */
static void test_spawn_leaves_triangle(void **state)
{
    (void)state;
    unsigned long long s = 0x9E3779B97F4A7C15ULL;
    int tests = 0;
    for (int n = 0; n < 4000; n++) {
        Prim p;
        memset(&p, 0, sizeof p);
        p.kind = PRIM_TRIANGLE;
        if (n == 0) {
            p.g.tri.a = vec3(4.734222412109375f, 17.814701080322266f, -3.226528405889627e-14f);
            p.g.tri.b = vec3(4.683684349060059f, 17.78635597229004f, -3.393399995135944e-14f);
            p.g.tri.c = vec3(4.715593338012695f, 17.746492385864258f, -3.393399995135944e-14f);
        } else {
            float scale = n % 4 == 0 ? 1e-3f : n % 4 == 1 ? 1.0f : 50.0f;
            Vec3 c = test_rvec(&s, -20, 20);
            if (n % 3 == 0)
                c = vec_scale(c, 1e4f);
            p.g.tri.a = vec_add(c, vec_scale(test_rvec(&s, -1, 1), scale));
            p.g.tri.b = vec_add(c, vec_scale(test_rvec(&s, -1, 1), scale));
            p.g.tri.c = n % 5 == 0 ? vec_add(vec_scale(p.g.tri.a, 0.5f), vec_scale(p.g.tri.b, 0.5f))
                                   : vec_add(c, vec_scale(test_rvec(&s, -1, 1), scale));
            if (n % 5 == 0) /* long and thin: c just off the middle of ab */
                p.g.tri.c = vec_add(p.g.tri.c, vec_scale(test_rvec(&s, -1, 1), scale * 1e-3f));
            if (n % 2 == 0) { /* flat in a coordinate plane, near it but not on it */
                int k = n / 2 % 3;
                float off = test_uniform(&s, -1, 1) * 1e-12f;
                Vec3 *v[3] = {&p.g.tri.a, &p.g.tri.b, &p.g.tri.c};
                for (int i = 0; i < 3; i++) {
                    float z = off * (1.0f + 0.1f * (float)i);
                    *v[i] = vec3(k == 0 ? z : v[i]->x, k == 1 ? z : v[i]->y, k == 2 ? z : v[i]->z);
                }
            }
        }
        Vec3 ctr = vec_scale(vec_add(vec_add(p.g.tri.a, p.g.tri.b), p.g.tri.c), 1.0f / 3.0f);
        for (int k = 0; k < 8; k++) {
            float u = test_uniform(&s, 0.02f, 0.96f), v = test_uniform(&s, 0.02f, 0.98f - u);
            Vec3 q = vec_add(vec_add(vec_scale(p.g.tri.a, 1 - u - v), vec_scale(p.g.tri.b, u)), vec_scale(p.g.tri.c, v));
            Vec3 eye = vec_add(ctr, vec_scale(vec_normalize(test_rvec(&s, -1, 1)), 100.0f));
            Ray r = ray_make(eye, vec_normalize(vec_sub(q, eye)), INFINITY);
            Surface sf;
            if (!test_surface(&p, &r, PRIM_ROBUST, &sf))
                continue;
            for (int j = 0; j < 4; j++) {
                Vec3 d = vec_normalize(test_rvec(&s, -1, 1));
                Ray out = ray_make(prim_spawn_origin(&sf, d), d, INFINITY);
                PrimHit h2;
                if (prim_intersect(&p, &out, PRIM_ROBUST, &h2))
                    fail_msg("triangle %d: a ray spawned at (%g %g %g) towards (%g %g %g) hits it again at t %g",
                             n, (double)out.o.x, (double)out.o.y, (double)out.o.z, (double)d.x, (double)d.y,
                             (double)d.z, (double)h2.t);
                tests++;
            }
        }
    }
    assert_true(tests > 50000);
}

/* ---- planes, rays at once ---- */

/* A routine for several rays against the scalar one for one of them: the
 * same verdict, and for a hit the same t and bound, bit for bit; counts
 * the hits and misses. */
static void same_hit(unsigned got_bit, const PrimHit *got, int hit, const PrimHit *want, int *hits, int *misses)
{
    assert_int_equal((int)got_bit, hit);
    if (!hit) {
        (*misses)++;
        return;
    }
    assert_memory_equal(&got->t, &want->t, sizeof want->t);
    assert_memory_equal(&got->terr, &want->terr, sizeof want->terr);
    (*hits)++;
}

/* prim_plane_hit_robust_rays against prim_plane_hit_robust, ray by ray:
 * the same verdicts and, for hits, the same t and terr, bit for bit, on
 * random and axis-aligned planes, for rays from all around, from on the
 * plane, parallel to it, with tiny and huge components and non-finite
 * ones, to tmax past, at and short of the hit, in groups of 1 to 16 (the
 * lanes, eight at a time where prim.c runs eight (AMD with AVX-512), then
 * four with AVX, and the rest one by one). */
static void test_plane_rays_match_scalar(void **state)
{
    (void)state;
    unsigned long long s = 0x9E3779B97F4A7C15ULL;
    int hits = 0, misses = 0;
    for (int round = 0; round < 4000; round++) {
        Plane pl;
        int axis = round % 4 == 0; /* y = d, so that origins can lie on it exactly */
        if (axis)
            pl = (Plane){{0, round % 8 == 0 ? 1.0f : -1.0f, 0}, test_uniform(&s, -5, 5)};
        else {
            Vec3 n = vec3(test_uniform(&s, -1, 1), test_uniform(&s, -1, 1), test_uniform(&s, -1, 1));
            pl = (Plane){vec_normalize(n), test_uniform(&s, -10, 10) * (round % 16 == 1 ? 1e6f : 1.0f)};
        }
        Ray r[16];
        float tmax[16];
        int n = 1 + round % 16;
        for (int k = 0; k < n; k++) {
            Vec3 o = vec3(test_uniform(&s, -20, 20), test_uniform(&s, -20, 20), test_uniform(&s, -20, 20));
            Vec3 d = vec_normalize(vec3(test_uniform(&s, -1, 1), test_uniform(&s, -1, 1), test_uniform(&s, -1, 1)));
            int kind = (int)test_uniform(&s, 0, 10);
            if (kind == 0 && axis)
                o.y = pl.n.y * pl.d; /* on the plane */
            else if (kind == 1 && axis)
                d.y = 0.0f; /* parallel */
            else if (kind == 2)
                d = vec3(d.x * 1e-30f, d.y * 1e-41f, d.z); /* tiny and subnormal */
            else if (kind == 3)
                o = vec_scale(o, 1e30f); /* huge */
            else if (kind == 4)
                o.x = (round & 1) ? INFINITY : NAN;
            else if (kind == 5)
                d.z = NAN;
            r[k] = ray_make(o, d, INFINITY);
            PrimHit h;
            int m = (int)test_uniform(&s, 0, 4);
            tmax[k] = m == 0 ? INFINITY : m == 1 ? test_uniform(&s, 0.01f, 50) : 1e-30f;
            if (m == 3 && prim_plane_hit_robust(&pl, &r[k], &h)) /* at the hit, or one float past it */
                tmax[k] = (round & 2) ? h.t : nextafterf(h.t, INFINITY);
        }
        PrimHit got[16];
        unsigned bits = prim_plane_hit_robust_rays(&pl, r, tmax, n, got);
        for (int k = 0; k < n; k++) {
            Ray q = r[k];
            q.tmax = tmax[k];
            PrimHit want;
            same_hit(bits >> k & 1, &got[k], prim_plane_hit_robust(&pl, &q, &want), &want, &hits, &misses);
        }
    }
    assert_true(hits > 2500 && misses > 10000);
}

/* prim_intersect_rays(p, r, rays) against prim_intersect ray by ray, both
 * robust: no bit outside the mask, and the same verdicts and, for hits, t,
 * terr and (a box's) face, bit for bit. */
static void rays_match_scalar(const Prim *p, const Ray *r, unsigned rays, int *hits, int *misses)
{
    PrimHit got[8];
    unsigned bits = prim_intersect_rays(p, r, rays, PRIM_ROBUST, got);
    assert_int_equal(bits & ~rays, 0);
    for (int k = 0; k < 8; k++) {
        if (!(rays >> k & 1))
            continue;
        PrimHit want;
        int hit = prim_intersect(p, &r[k], PRIM_ROBUST, &want);
        same_hit(bits >> k & 1, &got[k], hit, &want, hits, misses);
        if (hit && (p->kind == PRIM_BOX || p->kind == PRIM_OBOX))
            assert_int_equal(got[k].face, want.face);
    }
}

/* prim_intersect_rays on robust spheres and ellipsoids: the same verdicts
 * and the same bits as prim_intersect one ray at a time, for rays through,
 * past, grazing (whose root the first bracket cannot certify), from inside
 * and from the surface, tiny, huge and not numbers, in masks with gaps (of
 * five rays or more: eight lanes where prim.c runs eight). */
static void test_quadric_rays_match_scalar(void **state)
{
    (void)state;
    unsigned long long s = 0x2545F4914F6CDD1DULL;
    int hits = 0, misses = 0, grazing = 0, ellipsoids = 0;
    for (int round = 0; round < 9000; round++) {
        Prim p = {0};
        p.kind = PRIM_SPHERE;
        float scale = round % 7 == 0 ? 1e-4f : round % 7 == 1 ? 1e4f : 1.0f;
        p.g.sphere.c = vec_scale(vec3(test_uniform(&s, -5, 5), test_uniform(&s, -5, 5), test_uniform(&s, -5, 5)), scale);
        p.g.sphere.r = test_uniform(&s, 0.01f, 3.0f) * scale;
        const Sphere *sp = &p.g.sphere;
        Ellipsoid e;
        if (round % 3 == 2) { /* a map of the unit sphere about the same size, sheared */
            for (int i = 0; i < 9; i++)
                e.m[i] = (i % 4 == 0 ? 1.0 : 0.0) * sp->r + test_uniform(&s, -0.5f, 0.5f) * sp->r;
            e.m[9] = sp->c.x, e.m[10] = sp->c.y, e.m[11] = sp->c.z;
            if (prim_ellipsoid_init(&e) != 0)
                continue;
            p.kind = PRIM_ELLIPSOID;
            p.g.ell.e = &e;
            ellipsoids++;
        }
        Ray r[8];
        for (int k = 0; k < 8; k++) {
            Vec3 o = vec_add(sp->c, vec_scale(vec3(test_uniform(&s, -20, 20), test_uniform(&s, -20, 20), test_uniform(&s, -20, 20)), scale));
            Vec3 aim = vec_add(sp->c, vec_scale(vec3(test_uniform(&s, -1, 1), test_uniform(&s, -1, 1), test_uniform(&s, -1, 1)), sp->r));
            int kind = (int)test_uniform(&s, 0, 12);
            if (kind == 0 && p.kind == PRIM_ELLIPSOID) { /* grazing, made in the unit sphere's space and mapped */
                Vec3 y = vec3(test_uniform(&s, -4, 4), test_uniform(&s, -4, 4), 3.0f);
                Vec3 to = vec_normalize(vec_neg(y)), side = vec_normalize(vec_cross(to, vec3(0.3f, 1, 0.2f)));
                float dist = vec_length(y);
                Vec3 at = vec_add(vec_add(y, vec_scale(to, (dist * dist - 1) / dist)), vec_scale(side, sqrtf(1 - 1 / (dist * dist))));
                const double *m = e.m;
                o = vec3((float)(m[0] * y.x + m[1] * y.y + m[2] * y.z + m[9]), (float)(m[3] * y.x + m[4] * y.y + m[5] * y.z + m[10]),
                         (float)(m[6] * y.x + m[7] * y.y + m[8] * y.z + m[11]));
                aim = vec3((float)(m[0] * at.x + m[1] * at.y + m[2] * at.z + m[9]), (float)(m[3] * at.x + m[4] * at.y + m[5] * at.z + m[10]),
                           (float)(m[6] * at.x + m[7] * at.y + m[8] * at.z + m[11]));
                grazing++;
            } else if (kind == 0) { /* grazing: toward a point of the silhouette seen from o */
                Vec3 to = vec_normalize(vec_sub(sp->c, o)), side = vec_normalize(vec_cross(to, vec3(0.3f, 1, 0.2f)));
                float dist = vec_length(vec_sub(sp->c, o)), rr = sp->r * sp->r;
                aim = vec_add(vec_add(o, vec_scale(to, (dist * dist - rr) / dist)), vec_scale(side, sp->r * sqrtf(1 - rr / (dist * dist))));
                grazing++;
            } else if (kind == 1) /* from inside */
                o = vec_add(sp->c, vec_scale(vec3(test_uniform(&s, -1, 1), test_uniform(&s, -1, 1), test_uniform(&s, -1, 1)), sp->r * 0.5f));
            else if (kind == 2) /* on the surface, as a spawn leaves it */
                o = vec_add(sp->c, vec_scale(vec_normalize(vec3(test_uniform(&s, -1, 1), test_uniform(&s, -1, 1), 0.5f)), sp->r));
            Vec3 d = vec_normalize(vec_sub(aim, o));
            if (kind == 3)
                d = vec3(d.x * 1e-30f, d.y * 1e-41f, d.z * 1e-20f); /* tiny and subnormal */
            else if (kind == 4)
                o = vec_scale(o, 1e30f); /* huge */
            else if (kind == 5)
                o.y = (round & 1) ? INFINITY : NAN;
            else if (kind == 6)
                d.x = NAN;
            else if (kind == 7)
                d = vec_scale(d, -1.0f); /* away */
            r[k] = ray_make(o, d, INFINITY);
            int m = (int)test_uniform(&s, 0, 4);
            PrimHit h;
            if (m == 1)
                r[k].tmax = test_uniform(&s, 0.01f, 40) * scale;
            else if (m == 2 && prim_intersect(&p, &r[k], PRIM_ROBUST, &h)) /* at the hit, or one float past it */
                r[k].tmax = (round & 2) ? h.t : nextafterf(h.t, INFINITY);
        }
        unsigned rays = (unsigned)(round % 5 == 0 ? 0xff : test_uniform(&s, 0, 256)) & 0xff;
        rays_match_scalar(&p, r, rays, &hits, &misses);
    }
    assert_true(hits > 7000 && misses > 7000 && grazing > 4000 && ellipsoids > 2500);
}

/* prim_intersect_rays on robust oriented boxes, which work out the box's
 * slabs once for all the rays: the same verdicts, t, terr and face as
 * prim_intersect one ray at a time, for rays from outside and inside, along
 * an edge's direction (parallel to two faces), short of the hit and not
 * numbers, in masks with gaps. */
static void test_obox_rays_match_scalar(void **state)
{
    (void)state;
    unsigned long long s = 0x9E3779B97F4A7C15ULL;
    int hits = 0, misses = 0, boxes = 0;
    for (int round = 0; round < 4000; round++) {
        Prim p;
        memset(&p, 0, sizeof p);
        p.kind = PRIM_OBOX;
        float scale = round % 5 == 0 ? 1e-3f : round % 5 == 1 ? 1e3f : 1.0f;
        p.g.obox.c = vec_scale(test_rvec(&s, -3, 3), scale);
        p.g.obox.u = vec_scale(test_rvec(&s, -2, 2), scale);
        p.g.obox.v = vec_scale(test_rvec(&s, -2, 2), scale);
        p.g.obox.w = vec_scale(test_rvec(&s, -2, 2), scale);
        if (prim_obox_init(&p.g.obox) != 0)
            continue;
        boxes++;
        const OBox *b = &p.g.obox;
        Ray r[8];
        for (int k = 0; k < 8; k++) {
            int kind = (int)test_uniform(&s, 0, 8);
            Vec3 o = vec_add(b->c, vec_scale(test_rvec(&s, -15, 15), scale));
            if (kind == 1) /* from inside */
                o = vec_add(b->c, vec_scale(vec_add(vec_add(b->u, b->v), b->w), test_uniform(&s, -0.3f, 0.3f)));
            Vec3 aim = vec_add(b->c, vec_add(vec_scale(b->u, test_uniform(&s, -1.2f, 1.2f)),
                                             vec_add(vec_scale(b->v, test_uniform(&s, -1.2f, 1.2f)),
                                                     vec_scale(b->w, test_uniform(&s, -1.2f, 1.2f)))));
            Vec3 d = kind == 2 ? b->u : vec_sub(aim, o); /* kind 2: parallel to the faces of v and w */
            if (kind == 3)
                d.y = NAN;
            r[k] = ray_make(o, d, INFINITY);
            PrimHit h;
            if (kind == 4 && prim_intersect(&p, &r[k], PRIM_ROBUST, &h)) /* short of the hit */
                r[k].tmax = h.t;
        }
        unsigned rays = (unsigned)(round % 4 == 0 ? 0xff : test_uniform(&s, 0, 256)) & 0xff;
        rays_match_scalar(&p, r, rays, &hits, &misses);
    }
    assert_true(boxes > 3000 && hits > 4000 && misses > 4000);
}

/* prim_intersect_rays on robust axis-aligned boxes, in lanes: the same
 * verdicts, t, terr and face as prim_intersect one ray at a time, for rays
 * from outside and inside, at faces, edges and corners, parallel to a face
 * (a zero component of either sign) and from its plane (0 * inf, not a
 * number), tiny and huge, short of the hit or at it, and not numbers, in
 * masks with gaps (of five rays or more: eight lanes where prim.c runs
 * eight). */
static void test_box_rays_match_scalar(void **state)
{
    (void)state;
    unsigned long long s = 0xD1B54A32D192ED03ULL;
    int hits = 0, misses = 0, inside = 0, planes = 0;
    for (int round = 0; round < 6000; round++) {
        Prim p;
        memset(&p, 0, sizeof p);
        p.kind = PRIM_BOX;
        float scale = round % 5 == 0 ? 1e-3f : round % 5 == 1 ? 1e3f : 1.0f;
        Vec3 a = vec_scale(test_rvec(&s, -3, 3), scale), c = vec_scale(test_rvec(&s, -3, 3), scale);
        p.g.box.lo = vec3(fminf(a.x, c.x), fminf(a.y, c.y), fminf(a.z, c.z));
        p.g.box.hi = vec3(fmaxf(a.x, c.x), fmaxf(a.y, c.y), fmaxf(a.z, c.z));
        const Box *b = &p.g.box;
        Ray r[8];
        for (int k = 0; k < 8; k++) {
            int kind = (int)test_uniform(&s, 0, 10);
            /* a point of the box, its coordinates on a bound now and then: faces, edges, corners */
            float q[3];
            for (int i = 0; i < 3; i++) {
                float lo = vec_comp(b->lo, i), hi = vec_comp(b->hi, i), u = test_uniform(&s, -0.2f, 1.2f);
                q[i] = test_uniform(&s, 0, 3) < 1 ? (u < 0.5f ? lo : hi) : lo + u * (hi - lo);
            }
            Vec3 aim = vec3(q[0], q[1], q[2]);
            Vec3 o = vec_add(aim, vec_scale(test_rvec(&s, -15, 15), scale));
            if (kind == 1) { /* from inside */
                o = vec_scale(vec_add(b->lo, b->hi), 0.5f);
                inside++;
            }
            Vec3 d = vec_sub(aim, o);
            if (kind == 2) /* parallel to the faces of x, either zero */
                d.x = (round & 1) ? 0.0f : -0.0f;
            else if (kind == 3) { /* from a face's plane, parallel to it: 0 * inf */
                o.y = (round & 2) ? b->lo.y : b->hi.y;
                d.y = 0.0f;
                planes++;
            } else if (kind == 4)
                d.z = NAN;
            else if (kind == 5)
                d = vec3(d.x * 1e-30f, d.y * 1e-41f, d.z * 1e-20f); /* tiny and subnormal */
            else if (kind == 6)
                d = vec_scale(d, 1e30f); /* huge */
            else if (kind == 7)
                o.x = (round & 4) ? INFINITY : NAN;
            r[k] = ray_make(o, d, INFINITY);
            PrimHit h;
            int m = (int)test_uniform(&s, 0, 4);
            if (m == 1)
                r[k].tmax = test_uniform(&s, 0.01f, 2);
            else if (m == 2 && prim_intersect(&p, &r[k], PRIM_ROBUST, &h)) /* at the hit, or one float past it */
                r[k].tmax = (round & 8) ? h.t : nextafterf(h.t, INFINITY);
        }
        unsigned rays = (unsigned)(round % 4 == 0 ? 0xff : test_uniform(&s, 0, 256)) & 0xff;
        rays_match_scalar(&p, r, rays, &hits, &misses);
    }
    assert_true(hits > 10000 && misses > 5000 && inside > 3000 && planes > 3000);
}

/* The fields of a Surface that prim_surface sets, bit for bit. */
static void assert_same_surface(const Surface *a, const Surface *b)
{
    assert_memory_equal(&a->p, &b->p, sizeof a->p);
    assert_memory_equal(&a->perr, &b->perr, sizeof a->perr);
    assert_memory_equal(&a->ng, &b->ng, sizeof a->ng);
    assert_memory_equal(&a->ns, &b->ns, sizeof a->ns);
    assert_memory_equal(&a->noff, &b->noff, sizeof a->noff);
    assert_int_equal(a->pin_side, b->pin_side);
}

/* prim_surface_hits against prim_surface hit by hit: packets of 1 to 8
 * hits on spheres of every scale (from outside and from inside) among
 * boxes, with misses between them, robust and classic. */
static void test_surface_hits_match_scalar(void **state)
{
    (void)state;
    unsigned long long s = 0x9E3779B97F4A7C15ULL;
    Prim prims[6];
    int spheres = 0;
    for (int round = 0; round < 3000; round++) {
        for (int i = 0; i < 6; i++) {
            Prim *p = &prims[i];
            float scale = i == 4 ? 1e-3f : i == 5 ? 1e3f : 1.0f;
            Vec3 c = vec_scale(vec3(test_uniform(&s, -5, 5), test_uniform(&s, -5, 5), test_uniform(&s, -5, 5)), scale);
            float r = test_uniform(&s, 0.1f, 2.0f) * scale;
            memset(p, 0, sizeof *p);
            if (i == 3) {
                p->kind = PRIM_BOX;
                p->g.box = (Box){vec_sub(c, vec3(r, r, r)), vec_add(c, vec3(r, r, r))};
            } else {
                p->kind = PRIM_SPHERE;
                p->g.sphere.c = c;
                p->g.sphere.r = r;
            }
        }
        PrimVariant v = round % 4 == 3 ? PRIM_CLASSIC : PRIM_ROBUST;
        int n = 1 + round % 8, best[8];
        Ray r[8];
        PrimHit h[8];
        for (int k = 0; k < n; k++) {
            int i = (int)test_uniform(&s, 0, 6);
            const Prim *p = &prims[i];
            Vec3 c = p->kind == PRIM_BOX ? vec_scale(vec_add(p->g.box.lo, p->g.box.hi), 0.5f) : p->g.sphere.c;
            float size = p->kind == PRIM_BOX ? p->g.box.hi.x - p->g.box.lo.x : p->g.sphere.r;
            Vec3 o = vec_add(c, vec_scale(vec3(test_uniform(&s, -9, 9), test_uniform(&s, -9, 9), test_uniform(&s, -9, 9)), size));
            if (k % 5 == 4) /* from inside */
                o = vec_add(c, vec_scale(vec3(test_uniform(&s, -1, 1), test_uniform(&s, -1, 1), test_uniform(&s, -1, 1)), size * 0.4f));
            Vec3 aim = vec_add(c, vec_scale(vec3(test_uniform(&s, -1, 1), test_uniform(&s, -1, 1), test_uniform(&s, -1, 1)), size * 0.6f));
            r[k] = ray_make(o, vec_normalize(vec_sub(aim, o)), INFINITY);
            best[k] = k % 7 != 6 && prim_intersect(p, &r[k], v, &h[k]) ? i : -1;
            if (k % 6 == 5 && p->kind == PRIM_SPHERE) { /* a tangent ray, its hit at the tangent point */
                Vec3 d = vec_normalize(vec_sub(aim, o)), w = vec_normalize(vec_cross(d, vec3(0.3f, 1, -0.2f)));
                Vec3 q = vec_add(c, vec_scale(w, p->g.sphere.r));
                r[k] = ray_make(vec_sub(q, vec_scale(d, 5 * p->g.sphere.r)), d, INFINITY);
                h[k] = (PrimHit){5 * p->g.sphere.r, 0, 0, 0, 0};
                best[k] = i;
            }
            spheres += best[k] >= 0 && p->kind == PRIM_SPHERE;
        }
        Surface got[8];
        prim_surface_hits(prims, best, r, h, n, v, got);
        for (int k = 0; k < n; k++)
            if (best[k] >= 0) {
                Surface want;
                prim_surface(&prims[best[k]], &r[k], &h[k], v, &want);
                assert_same_surface(&got[k], &want);
            }
    }
    assert_true(spheres > 8000);
}

/* ---- four triangles at once ---- */

static unsigned long long rng = 0x2545F4914F6CDD1DULL;

static void test_tri4_matches_scalar(void **state)
{
    (void)state;
    /* A fan of four triangles around a shared vertex, so that lanes share
     * edges, and rays aimed at its vertices, at points of its edges and
     * inside it, with directions from tiny to huge (those take the rescaled
     * scalar path) and finite or infinite tmax; a fifth of them start
     * next to a triangle's inside, where t can be within its error bound
     * of 0. Every lane must get the scalar routine's verdict and the same
     * t, terr, u and v, bit for bit, and so must prim_tri8_lane_hit. The
     * fan lies in the first half of the eight lanes, or in the second. */
    int hits = 0, shared = 0, near = 0;
    for (int n = 0; n < 200000; n++) {
        Vec3 c = test_rvec(&rng, -2, 2), rim[4], v[4][3];
        for (int i = 0; i < 4; i++)
            rim[i] = vec_add(c, test_rvec(&rng, -1, 1));
        PrimTri8 t = {0};
        const int at = n / 7 % 2 * 4;
        for (int i = 0; i < 4; i++) {
            v[i][0] = c;
            v[i][1] = rim[i];
            v[i][2] = rim[(i + 1) % 4];
            put_lane(&t, at + i, v[i]);
        }
        int i = n % 4, kind = n / 4 % 4;
        float s = test_uniform(&rng, 0, 1);
        Vec3 target = kind == 0 ? rim[i] : kind == 1 ? vec_add(c, vec_scale(vec_sub(rim[i], c), s))
                    : kind == 2 ? vec_add(rim[i], vec_scale(vec_sub(rim[(i + 1) % 4], rim[i]), s))
                                : vec_add(c, test_rvec(&rng, -1, 1));
        Vec3 o = test_rvec(&rng, -6, 6), aim = vec_sub(target, o);
        if (n % 5 == 4) { /* from next to a triangle's inside, any way: t near 0, its sign in doubt */
            Vec3 e1 = vec_sub(rim[i], c), e2 = vec_sub(rim[(i + 1) % 4], c);
            Vec3 in = vec_add(c, vec_add(vec_scale(e1, test_uniform(&rng, 0.1f, 0.45f)),
                                         vec_scale(e2, test_uniform(&rng, 0.1f, 0.45f))));
            o = vec_add(in, vec_scale(test_rvec(&rng, -1, 1), ldexpf(1.0f, -(n / 5 % 30))));
            aim = test_rvec(&rng, -1, 1);
        }
        const float scales[] = {1, 0x1p-70f, 0x1p-20f, 0x1p20f, 0x1p70f, 3};
        Vec3 d = vec_scale(aim, scales[n / 16 % 6]);
        float tmax = n % 3 ? INFINITY : test_uniform(&rng, 0.5f, 1.5f) / scales[n / 16 % 6];
        Ray r = ray_make(o, d, tmax);
        PrimTriRay p;
        prim_triray_init(&p, &r);
        int lanes = 1 + n / 96 % 15;
        Hit4 h4;
        int got = tri4_hit(&t, at, lanes, &p, &r, &h4), nhit = 0;
        for (int l = 0; l < 4; l++) {
            PrimHit h;
            int want = (lanes >> l & 1) && prim_triangle_hit_watertight3(v[l], &r, &h);
            assert_int_equal(got >> l & 1, want);
            if (want) {
                assert_lane_is(&h4, l, &h);
                /* and the lane through the scalar routine */
                PrimHit g;
                assert_true(prim_tri8_lane_hit(&t, at + l, &p, &r, &g));
                assert_memory_equal(&g.t, &h.t, sizeof(float));
                assert_memory_equal(&g.terr, &h.terr, sizeof(float));
                assert_memory_equal(&g.u, &h.u, sizeof(float));
                assert_memory_equal(&g.v, &h.v, sizeof(float));
            }
            nhit += want;
        }
        hits += nhit > 0;
        shared += nhit > 1;
        near += nhit > 0 && n % 5 == 4;
    }
    assert_true(hits > 40000);
    assert_true(shared > 1000); /* rays through shared edges and the centre */
    assert_true(near > 3000);
}

#ifdef TRI4_AVX512
/* Eight triangles (two blocks) against two rays of the same axes at once,
 * sixteen lanes of AVX-512: each ray's lanes get tri8_lanes' verdicts, its
 * lanes left to the scalar routine, and its hits' t, terr, u and v, bit
 * for bit. The rays: one aimed into the fan, the other close by or far
 * off, from tiny to huge directions, some from next to the fan, with
 * finite or infinite tmax. */
static void test_tri16_matches_tri8(void **state)
{
    (void)state;
    if (!__builtin_cpu_supports("avx512f") || !__builtin_cpu_supports("avx512dq"))
        skip();
    int pairs = 0, hits = 0, slow = 0;
    for (int n = 0; n < 100000; n++) {
        /* a tenth of the fans far from the rays or tiny next to them,
         * where the lanes leave t to the scalar routine */
        const float geo = n % 10 != 9 ? 1.0f : n % 20 == 9 ? 0x1p44f : 0x1p-55f;
        Vec3 c = vec_scale(test_rvec(&rng, -2, 2), geo), rim[8];
        for (int i = 0; i < 8; i++)
            rim[i] = vec_add(c, vec_scale(test_rvec(&rng, -1, 1), geo));
        PrimTri8 t;
        for (int i = 0; i < 8; i++) {
            Vec3 v[3] = {c, rim[i], rim[(i + 1) % 8]};
            put_lane(&t, i, v);
        }
        Ray r[2];
        PrimTriRay p[2];
        const float scales[] = {1, 0x1p-70f, 0x1p-20f, 0x1p20f, 0x1p70f, 3};
        const float sc = scales[n / 16 % 6];
        for (int j = 0; j < 2; j++) {
            Vec3 target = vec_add(c, vec_scale(vec_sub(rim[(n + j) % 8], c), test_uniform(&rng, 0, 1.2f)));
            Vec3 o = j && n % 2 ? vec_add(r[0].o, vec_scale(test_rvec(&rng, -1e-3f, 1e-3f), geo))
                                : vec_scale(test_rvec(&rng, -6, 6), geo);
            if (n % 5 == 4) /* from next to the fan: t near 0 */
                o = vec_add(target, vec_scale(test_rvec(&rng, -1, 1), geo * ldexpf(1.0f, -(n / 5 % 30))));
            Vec3 d = vec_scale(n % 5 == 4 ? test_rvec(&rng, -1, 1) : vec_sub(target, o), sc);
            float tmax = (n + j) % 3 ? INFINITY : test_uniform(&rng, 0.5f, 1.5f) / sc;
            r[j] = ray_make(o, d, tmax);
            prim_triray_init(&p[j], &r[j]);
        }
        if (!p[0].simd || !p[1].simd || p[0].kz != p[1].kz)
            continue;
        pairs++;
        int lanes = 1 + n % 255;
        float t16[4][16], t8[2][4][8];
        int s16, s8[2], h8[2];
        int h16 = tri16_lanes(t.v[0][0], lanes | lanes << 8, &p[0], &r[0], &p[1], &r[1], t16[0], t16[1], t16[2], t16[3],
                              &s16);
        for (int j = 0; j < 2; j++)
            h8[j] = tri8_lanes(t.v[0][0], lanes, &p[j], &r[j], t8[j][0], t8[j][1], t8[j][2], t8[j][3], &s8[j]);
        for (int j = 0; j < 2; j++) {
            assert_int_equal(h16 >> 8 * j & 0xff, h8[j]);
            assert_int_equal(s16 >> 8 * j & 0xff, s8[j]);
            for (int l = 0; l < 8; l++)
                if (h8[j] >> l & 1)
                    for (int f = 0; f < 4; f++)
                        assert_memory_equal(&t16[f][8 * j + l], &t8[j][f][l], sizeof(float));
            hits += h8[j] != 0;
            slow += s8[j] != 0;
        }
    }
    assert_true(pairs > 30000);
    assert_true(hits > 10000);
    assert_true(slow > 100); /* lanes left to the scalar routine, in both forms */
}
#endif

/* A triangle's unit normal whatever its size (a review found huge ones
 * black): a float |n|^2 overflowed for edges of about 4 * 10^9, which
 * made the normal 0, and underflowed for 10^-13, which left it
 * unnormalised. */
static void test_triangle_normal_at_any_scale(void **state)
{
    (void)state;
    const float s[] = {4e9f, 1e10f, 1e-13f, 1.0f, 1e18f, 1e-18f};
    for (int i = 0; i < 6; i++)
        for (int variant = i < 4 ? 0 : 1; variant < 2; variant++) { /* (the classic test's t overflows by 10^18) */
            Prim p = {0};
            p.kind = PRIM_TRIANGLE;
            p.g.tri.a = vec3(-s[i], 0, -s[i]);
            p.g.tri.b = vec3(s[i], 0, -s[i]);
            p.g.tri.c = vec3(0, 0, s[i]);
            const PrimVariant v = variant ? PRIM_ROBUST : PRIM_CLASSIC;
            Ray r = ray_make(vec3(0, 2 * s[i], 0), vec3(0, -1, 0), INFINITY);
            PrimHit h;
            Surface sf;
            assert_true(prim_intersect(&p, &r, v, &h));
            prim_surface(&p, &r, &h, v, &sf);
            assert_true(fabsf(sf.ng.y - 1.0f) < 1e-6f && fabsf(sf.ng.x) < 1e-6f && fabsf(sf.ng.z) < 1e-6f);
            assert_true(fabsf(sf.ns.y - 1.0f) < 1e-6f && fabsf(sf.noff.y - 1.0f) < 1e-6f);
        }
}

/* Triangles far from the ray's origin or tiny next to it, where the
 * watertight test's float products over- or underflow (a review found
 * them): t = 2^42 came out infinite, and the far sides of a product's
 * inf - inf a NaN, both dropped; t = 2^-51 underflowed to 0, and 2^-50 to
 * a subnormal t off by half with a tiny bound; and an edge function below
 * the least float lost its sign, a miss by a hundredth of the triangle
 * taken for a hit. The exact answers come from rational arithmetic. */
static void test_watertight_far_and_tiny(void **state)
{
    (void)state;
    const float s[] = {0x1p42f, 0x1p-51f, 0x1p-50f, 0x1p60f, 0x1p-60f};
    for (int i = 0; i < 5; i++) { /* hit at u = 1/4, v = 1/2, t = s exactly */
        Triangle t = {0};
        t.a = vec3(-s[i], -s[i], s[i]);
        t.b = vec3(s[i], -s[i], s[i]);
        t.c = vec3(0, s[i], s[i]);
        Ray r = ray_make(vec3(0, 0, 0), vec3(0, 0, 1), INFINITY);
        PrimHit h;
        assert_true(prim_triangle_hit_watertight(&t, &r, &h));
        assert_true(isfinite(h.terr) && fabsf(h.t - s[i]) <= h.terr && h.terr < 0x1p-20f * s[i]);
        assert_true(fabsf(h.u - 0.25f) < 1e-6f && fabsf(h.v - 0.5f) < 1e-6f);
    }
    { /* a floor 2 * 10^13 across, seen from 5 * 10^12 away: every ray aimed inside it hits */
        const float k = 1e12f;
        Triangle t = {0};
        t.a = vec3(-10 * k, 0, -10 * k);
        t.b = vec3(10 * k, 0, -10 * k);
        t.c = vec3(10 * k, 0, 10 * k);
        Ray r = ray_make(vec3(0, 2 * k, -5 * k), vec3(0x1.368a46p-2f, -0x1.0d74ccp-1f, 0x1.96baa6p-1f), INFINITY);
        PrimHit h;
        assert_true(prim_triangle_hit_watertight(&t, &r, &h));
        assert_true(h.t > 2 * k && isfinite(h.terr) && h.terr < 0x1p-20f * h.t);
    }
    { /* exact: u = -0.0100001, v = 0.632, t = 1/8: a miss, by 1% */
        Triangle t = {0};
        t.a = vec3(0x1p+0f, -0x1.4c798ap-72f, 0x1.28d0fap-74f);
        t.b = vec3(0x1p+0f, -0x1.ad6efp-72f, -0x1.03de82p-72f);
        t.c = vec3(0x1p+0f, -0x1.456fecp-72f, 0x1.de02fp-72f);
        Ray r = ray_make(vec3(0, 0, 0), vec3(0x1p+3f, -0x1.470deep-69f, 0x1.4cec82p-69f), INFINITY);
        PrimHit h;
        assert_false(prim_triangle_hit_watertight(&t, &r, &h));
    }
}

/* The lanes (tri4.h) at those scales: the fan of test_tri4_matches_scalar
 * scaled as a whole, 2^40 to 2^64 from the ray's origin or 2^-45 to
 * 2^-60 next to it, must get the scalar routine's verdicts and bits, and
 * the rays aimed inside the fan must hit it. */
static void test_tri4_far_and_tiny_match_scalar(void **state)
{
    (void)state;
    const float scales[] = {0x1p40f, 0x1p44f, 0x1p52f, 0x1p64f, 0x1p-45f, 0x1p-52f, 0x1p-60f};
    int aimed = 0, found = 0;
    for (int n = 0; n < 14000; n++) {
        const float k = scales[n % 7];
        Vec3 c = test_rvec(&rng, -2, 2), rim[4], v[4][3];
        for (int i = 0; i < 4; i++)
            rim[i] = vec_add(c, test_rvec(&rng, -1, 1));
        PrimTri8 t = {0};
        for (int i = 0; i < 4; i++) {
            v[i][0] = vec_scale(c, k);
            v[i][1] = vec_scale(rim[i], k);
            v[i][2] = vec_scale(rim[(i + 1) % 4], k);
            put_lane(&t, i, v[i]);
        }
        const int i = n / 7 % 4;
        const float a = test_uniform(&rng, 0.1f, 0.45f), b = test_uniform(&rng, 0.1f, 0.45f);
        Vec3 in = vec_add(c, vec_add(vec_scale(vec_sub(rim[i], c), a), vec_scale(vec_sub(rim[(i + 1) % 4], c), b)));
        Vec3 o = test_rvec(&rng, -6, 6);
        Ray r = ray_make(vec_scale(o, k), vec_normalize(vec_sub(in, o)), INFINITY);
        PrimTriRay p;
        prim_triray_init(&p, &r);
        Hit4 h4;
        int got = tri4_hit(&t, 0, 15, &p, &r, &h4);
        for (int l = 0; l < 4; l++) {
            PrimHit h;
            int want = prim_triangle_hit_watertight3(v[l], &r, &h);
            assert_int_equal(got >> l & 1, want);
            if (want) {
                assert_lane_is(&h4, l, &h);
            }
        }
        if (vec_length(vec_cross(vec_sub(rim[i], c), vec_sub(rim[(i + 1) % 4], c))) > 0.05f) {
            aimed++;
            found += got >> i & 1;
        }
    }
    assert_true(aimed > 10000);
    assert_int_equal(found, aimed);
}

/* Inputs where a plausible slip in the triangle routines changes the
 * answer, which a review's mutations of them found no other test to see. */
static void test_triangle_at_t0_at_tmax_and_tiny(void **state)
{
    (void)state;
    PrimHit h;
    { /* classic: an origin on the triangle is t = 0, not a hit (t > 0) */
        Triangle t = {0};
        t.a = vec3(0, 0, 0);
        t.b = vec3(1, 0, 0);
        t.c = vec3(0, 1, 0);
        Ray r = ray_make(vec3(0.25f, 0.25f, 0), vec3(0, 0, 1), INFINITY);
        assert_false(prim_triangle_hit(&t, &r, &h));
    }
    { /* a t taken in double (past float's range) that lands on tmax: no hit */
        const float k = 0x1p50f;
        Triangle t = {0};
        t.a = vec3(k, -k, k);
        t.b = vec3(-k, -k, k);
        t.c = vec3(0, k, k);
        Ray r = ray_make(vec3(0, 0, 0), vec3(0, 0, 1), k);
        assert_false(prim_triangle_hit_watertight(&t, &r, &h));
        r.tmax = nextafterf(k, INFINITY);
        assert_true(prim_triangle_hit_watertight(&t, &r, &h) && h.t == k);
    }
    { /* a hit at exactly tmax, in the lanes as in the scalar routine: no hit */
        const Vec3 v[3] = {vec3(-1, -1, 1), vec3(1, -1, 1), vec3(0, 1, 1)};
        PrimTri8 t = {0};
        for (int l = 0; l < 8; l++)
            put_lane(&t, l, v);
        Ray r = ray_make(vec3(0, 0, 0), vec3(0, 0, 1), 1.0f);
        PrimTriRay p;
        prim_triray_init(&p, &r);
        Hit4 h4;
        assert_false(prim_triangle_hit_watertight3(v, &r, &h));
        assert_int_equal(tri4_hit(&t, 0, 15, &p, &r, &h4), 0);
        r.tmax = nextafterf(1.0f, INFINITY);
        prim_triray_init(&p, &r);
        assert_int_equal(tri4_hit(&t, 0, 15, &p, &r, &h4), 15);
    }
    { /* coordinates near 2^-40 and a direction of 2^-50: the lanes' shear
       * error takes the same floor (TRI_SHEAR_FLOOR) as the scalar
       * routine's, and gets its bits */
        const Vec3 v[3] = {vec3(-0x1.b7568ap-41f, -0x1.430eb4p-41f, 0x1.ddfb34p-40f),
                           vec3(-0x1.e79d2p-45f, -0x1.90e11p-43f, 0x1.93c384p-40f),
                           vec3(0x1.be3748p-41f, 0x1.49ff4cp-41f, 0x1.a6077ap-40f)};
        PrimTri8 t = {0};
        for (int l = 0; l < 8; l++)
            put_lane(&t, l, v);
        Ray r = ray_make(vec3(0, 0, 0), vec3(-0x1.10d032p-64f, 0x1.90a69p-61f, 0x1p-50f), INFINITY);
        PrimTriRay p;
        prim_triray_init(&p, &r);
        Hit4 h4;
        assert_true(prim_triangle_hit_watertight3(v, &r, &h));
        assert_int_equal(tri4_hit(&t, 0, 15, &p, &r, &h4), 15);
        for (int l = 0; l < 4; l++)
            assert_lane_is(&h4, l, &h);
    }
}

static void test_shared_edge_with_an_edge_on_triangle(void **state)
{
    (void)state;
    /* Two rays that make stress found leaking through the edge shared by
     * two triangles, one of them seen almost edge-on. The ray passes
     * exactly through the edge (t = 1/16 and 256 exactly, from CGAL); the
     * edge went to the edge-on triangle, whose float t came out negative
     * and was dropped. Either triangle may report the hit, with its t
     * within terr, in the scalar routine and in the lanes alike. */
    static const struct {
        float o[3], d[3], a[3], b[3], c[3], c1[3], t;
    } cases[] = {
        {{0x1.8d723cp+5f, 0x1.2106ap+5f, 0x1.ea05d8p+4f},
         {0x1p-12f, 0x1.ap-9f, -0x1p-12f},
         {0x1.8a3344p+5f, 0x1.1bcb28p+5f, 0x1.dd8588p+4f},
         {0x1.865728p+5f, 0x1.0f8c04p+5f, 0x1.d1c0dp+4f},
         {0x1.9250c4p+5f, 0x1.28e0d8p+5f, 0x1.fcc628p+4f},
         {0x1.8f64f8p+5f, 0x1.0f1734p+5f, 0x1.eef51p+4f},
         0x1p-4f},
        {{-0x1.915e2p+29f, 0x1.414a2p+29f, 0x1.92506p+29f},
         {8, -12, -10},
         {-0x1.939eep+29f, 0x1.2be34p+29f, 0x1.7cb55p+29f},
         {-0x1.7634bp+29f, 0x1.3e83bp+29f, 0x1.c9207p+29f},
         {-0x1.8fad2p+29f, 0x1.5156ap+29f, 0x1.a2842p+29f},
         {-0x1.67042p+29f, 0x1.674f1p+29f, 0x1.c170bp+29f},
         0x1p+8f},
    };
    for (size_t k = 0; k < sizeof cases / sizeof cases[0]; k++) {
#define V3(x) vec3((x)[0], (x)[1], (x)[2])
        Vec3 v[2][3] = {{V3(cases[k].a), V3(cases[k].b), V3(cases[k].c)},
                        {V3(cases[k].a), V3(cases[k].c), V3(cases[k].c1)}};
        Ray r = ray_make(V3(cases[k].o), V3(cases[k].d), INFINITY);
#undef V3
        PrimTri8 t8 = {0};
        for (int l = 0; l < 2; l++)
            put_lane(&t8, l, v[l]);
        PrimTriRay p;
        prim_triray_init(&p, &r);
        Hit4 h4;
        int lanes = tri4_hit(&t8, 0, 3, &p, &r, &h4), hits = 0;
        for (int l = 0; l < 2; l++) {
            PrimHit h;
            int hit = prim_triangle_hit_watertight3(v[l], &r, &h);
            assert_int_equal(lanes >> l & 1, hit);
            if (hit) {
                assert_true(fabsf(h.t - cases[k].t) <= h.terr);
                assert_float_equal(h4.t[l], h.t, 0);
            }
            hits += hit;
        }
        assert_true(hits >= 1);
    }
}

static void test_edge_on_triangle_hit_near_origin(void **state)
{
    (void)state;
    /* A triangle seen almost edge-on (its plane 1e-7 of a radian from the
     * ray), hit well inside its edges at t = 0.00934449300503299 (exact,
     * from rationals). The float t is no more accurate than its bound
     * terr, which is larger than t, and came out negative: the hit was
     * dropped, by the scalar routine and by the lanes alike. */
    Vec3 v[3] = {vec3(0x1.182252p+1f, 0x1.744ca4p+1f, -0x1.5f9834p+1f),
                 vec3(0x1.51a14p+0f, 0x1.f73048p+0f, -0x1.c1304ap+1f),
                 vec3(0x1.3a21c2p-1f, 0x1.395b98p+1f, -0x1.85757cp+1f)};
    Ray r = ray_make(vec3(0x1.6e8248p+0f, 0x1.407ep+1f, -0x1.863794p+1f),
                     vec3(-0x1.33eb4p-4f, -0x1.6f4e4p-2f, -0x1.3a631p-2f), INFINITY);
    const double t = 0x1.323349ed5a464p-7;
    PrimHit h;
    assert_true(prim_triangle_hit_watertight3(v, &r, &h));
    assert_true(fabs(h.t - t) <= h.terr);
    PrimTri8 t8 = {0};
    for (int l = 0; l < 4; l++)
        put_lane(&t8, l, v);
    PrimTriRay p;
    prim_triray_init(&p, &r);
    Hit4 h4;
    assert_int_equal(tri4_hit(&t8, 0, 15, &p, &r, &h4), 15);
    for (int l = 0; l < 4; l++)
        assert_float_equal(h4.t[l], h.t, 0);
}

/* prim_triray_init as first written, branch by branch: the reference. */
static void triray_reference(PrimTriRay *p, const Ray *r)
{
    const float d[3] = {r->d.x, r->d.y, r->d.z};
    int kz = fabsf(d[0]) > fabsf(d[1]) ? (fabsf(d[0]) > fabsf(d[2]) ? 0 : 2) : (fabsf(d[1]) > fabsf(d[2]) ? 1 : 2);
    int kx = kz == 2 ? 0 : kz + 1, ky = kx == 2 ? 0 : kx + 1;
    float m = fabsf(d[kz]);
    p->kx = kx;
    p->ky = ky;
    p->kz = kz;
    p->o[0] = r->o.x;
    p->o[1] = r->o.y;
    p->o[2] = r->o.z;
    p->simd = !(m < 0x1p-60f || m > 0x1p60f) && isfinite(d[0]) && isfinite(d[1]) && isfinite(d[2]);
    p->sx = -d[kx] / d[kz];
    p->sy = -d[ky] / d[kz];
    p->sz = 1.0f / d[kz];
}

/* tri_ray_init (tri4.h: in test_prim_avx2, built with -mavx2, its AVX2
 * form; here the scalar one, which prim_triray_init is) sets up what the
 * reference does, bit for bit: on ties of magnitude, zeros of both signs,
 * the rescaling bounds and just past them, infinities, NaN and random
 * directions. */
static void test_triray_init(void **state)
{
    (void)state;
    const float c[] = {0.0f, -0.0f, 1.0f, -1.0f, 0.5f, -3.0f, 0x1p-60f, -0x1p-60f, 0x1p-61f, 0x1p60f,
                       -0x1p60f, 0x1.000002p60f, INFINITY, -INFINITY, NAN, 1e-30f};
    const int nc = (int)(sizeof c / sizeof c[0]);
    unsigned long long seed = 11;
    for (int n = 0; n < nc * nc * nc + 100000; n++) {
        Vec3 d = n < nc * nc * nc ? vec3(c[n % nc], c[n / nc % nc], c[n / (nc * nc)]) : test_rvec(&seed, -1, 1);
        if (n >= nc * nc * nc && n % 3 == 0)
            d.y = n % 2 ? d.x : -d.x;
        Ray r = ray_make(test_rvec(&seed, -5, 5), d, INFINITY);
        PrimTriRay want, got, lib;
        memset(&want, 0xa5, sizeof want);
        memset(&got, 0x5a, sizeof got);
        memset(&lib, 0x3c, sizeof lib);
        triray_reference(&want, &r);
        tri_ray_init(&got, &r);
        prim_triray_init(&lib, &r);
        assert_memory_equal(&got, &want, sizeof want);
        assert_memory_equal(&lib, &want, sizeof want);
    }
#if defined(__AVX2__) && !defined(LANCER_NO_SIMD)
    /* eight at once, lane by lane the same, in packets of 1 to 8 rays */
    for (int n = 0; n < nc * nc * nc + 100000; n += 8) {
        Ray r[8];
        PrimTriRay want[8], got[8], *gp[8];
        const int m = 1 + n / 8 % 8;
        for (int k = 0; k < 8; k++) {
            const int i = n + k;
            Vec3 d = i < nc * nc * nc ? vec3(c[i % nc], c[i / nc % nc], c[i / (nc * nc)]) : test_rvec(&seed, -1, 1);
            if (i >= nc * nc * nc && i % 3 == 0)
                d.y = i % 2 ? d.x : -d.x;
            r[k] = ray_make(test_rvec(&seed, -5, 5), d, INFINITY);
            memset(&want[k], 0xa5, sizeof want[k]);
            memset(&got[k], 0xa5, sizeof got[k]);
            gp[k] = &got[k];
            if (k < m)
                tri_ray_init(&want[k], &r[k]);
        }
        tri_ray_init8(r, m, gp);
        assert_memory_equal(got, want, sizeof want); /* past m: untouched */
    }
#endif
}

/* Every hit routine writes the whole PrimHit, whatever it held before:
 * u and v are a triangle's barycentrics and face a box's side, and 0 where
 * the primitive has none, so that a hit copied or compared is defined. */
static void test_hit_fills_every_field(void **state)
{
    (void)state;
    Ellipsoid e = ellipsoid(0, 0, 0);
    OBox ob = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {{0, 0, 0}}};
    assert_int_equal(prim_obox_init(&ob), 0);
    const Prim p[] = {
        {PRIM_SPHERE, 0, {.sphere = {{0, 0, 0}, 1}}},
        {PRIM_PLANE, 0, {.plane = {{0, 0, 1}, 0}}},
        {PRIM_TRIANGLE, 0, {.tri = tri}},
        {PRIM_SMOOTH_TRIANGLE, 0, {.tri = tri}},
        {PRIM_BOX, 0, {.box = cube}},
        {PRIM_OBOX, 0, {.obox = ob}},
        {PRIM_ELLIPSOID, 0, {.ell = {&e, 0}}},
    };
    const Ray r = ray(0.25f, 0.5f, -5, 0, 0, 1);
    for (size_t i = 0; i < sizeof p / sizeof p[0]; i++) {
        PrimHit h;
        memset(&h, 0xff, sizeof h); /* u and v NaN, face -1 */
        assert_true(prim_intersect(&p[i], &r, V, &h));
        const int tri_kind = p[i].kind == PRIM_TRIANGLE || p[i].kind == PRIM_SMOOTH_TRIANGLE;
        assert_float_equal(h.u, tri_kind ? 0.25f : 0.0f, 0);
        assert_float_equal(h.v, tri_kind ? 0.5f : 0.0f, 0);
        assert_true(h.face >= 0 && h.face < 6);
        if (p[i].kind != PRIM_BOX && p[i].kind != PRIM_OBOX)
            assert_int_equal(h.face, 0);
    }
}

/* double_min and double_max (rounding.h), which the robust oriented box
 * calls instead of fmin and fmax, give libm's answers bit for bit: NaN
 * losing, infinities, and zeros of either sign (of two equal zeros, glibc
 * returns the first). */
static void test_double_min_max_are_libm(void **state)
{
    (void)state;
    const double c[] = {NAN, -INFINITY, -1.5, -0x1p-1074, -0.0, 0.0, 0x1p-1074, DBL_MIN, 1.5, DBL_MAX, INFINITY};
    const int nc = (int)(sizeof c / sizeof c[0]);
    for (int i = 0; i < nc; i++)
        for (int j = 0; j < nc; j++) {
            volatile double a = c[i], b = c[j]; /* no folding at compile time */
            double want[2] = {fmin(a, b), fmax(a, b)}, got[2] = {double_min(a, b), double_max(a, b)};
            for (int k = 0; k < 2; k++)
                if (isnan(want[k]))
                    assert_true(isnan(got[k]));
                else
                    assert_memory_equal(&got[k], &want[k], sizeof want[k]);
        }
}

int main(void)
{
#if defined(__AVX2__) && defined(__GNUC__)
    if (!__builtin_cpu_supports("avx2")) { /* test_prim_avx2 on a processor without AVX2 */
        puts("test_prim_avx2: skipped, no AVX2");
        return 0;
    }
#endif
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_sphere),
        cmocka_unit_test(test_sphere_tangent_and_inside),
        cmocka_unit_test(test_ellipsoid),
        cmocka_unit_test(test_plane),
        cmocka_unit_test(test_plane_rays_match_scalar),
        cmocka_unit_test(test_quadric_rays_match_scalar),
        cmocka_unit_test(test_obox_rays_match_scalar),
        cmocka_unit_test(test_box_rays_match_scalar),
        cmocka_unit_test(test_surface_hits_match_scalar),
        cmocka_unit_test(test_triangle),
        cmocka_unit_test(test_smooth_triangle_normal),
        cmocka_unit_test(test_box),
        cmocka_unit_test(test_box_pad_covers_the_roundings),
        cmocka_unit_test(test_obox_init),
        cmocka_unit_test(test_obox),
        cmocka_unit_test(test_smooth_normal_flips_on_its_own),
        cmocka_unit_test(test_inside),
        cmocka_unit_test(test_spawn_origin),
        cmocka_unit_test(test_spawn_origin_is_its_definition),
        cmocka_unit_test(test_spawn_origins_pair),
        cmocka_unit_test(test_spawn_leaves_triangle),
        cmocka_unit_test(test_robust_error_bounds),
        cmocka_unit_test(test_box_origin_on_slab_plane),
        cmocka_unit_test(test_watertight_shared_edge),
        cmocka_unit_test(test_hit_fills_every_field),
    };
    const struct CMUnitTest robust_only[] = {
        cmocka_unit_test(test_tri4_matches_scalar),
#ifdef TRI4_AVX512
        cmocka_unit_test(test_tri16_matches_tri8),
#endif
        cmocka_unit_test(test_triangle_normal_at_any_scale),
        cmocka_unit_test(test_watertight_far_and_tiny),
        cmocka_unit_test(test_tri4_far_and_tiny_match_scalar),
        cmocka_unit_test(test_triangle_at_t0_at_tmax_and_tiny),
        cmocka_unit_test(test_shared_edge_with_an_edge_on_triangle),
        cmocka_unit_test(test_edge_on_triangle_hit_near_origin),
        cmocka_unit_test(test_triray_init),
        cmocka_unit_test(test_double_min_max_are_libm),
        cmocka_unit_test(test_obox_grazing_slab),
        cmocka_unit_test(test_obox_spawn_inside_near_edge),
        cmocka_unit_test(test_triangle_near_edge),
        cmocka_unit_test(test_huge_triangle_hit),
        cmocka_unit_test(test_huge_triangle_hit_behind),
        cmocka_unit_test(test_past_plane),
        cmocka_unit_test(test_past_plane_of_triangle_hit),
        cmocka_unit_test(test_line_crosses_triangle),
        cmocka_unit_test(test_hit_on_edge_bc),
        cmocka_unit_test(test_ellipsoid_spawn),
        cmocka_unit_test(test_ellipsoid_spawn_far_and_grazing),
    };
    int failed = cmocka_run_group_tests_name("classic", tests, setup_classic, NULL);
    failed += cmocka_run_group_tests_name("robust", tests, setup_robust, NULL);
    return failed + cmocka_run_group_tests_name("robust, four lanes", robust_only, NULL, NULL);
}
