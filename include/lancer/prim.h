/*
 * prim.h - the geometric primitives and their ray intersection routines, in
 * two variants side by side: the classic formulations as their papers give
 * them, and robust ones.
 *
 *     PrimHit h;
 *     if (prim_sphere_hit_robust(&sphere, &ray, &h)) ... hit at h.t, within h.terr ...
 *
 *     Prim p;  ... filled by the scene parser ...
 *     if (prim_intersect(&p, &ray, PRIM_ROBUST, &h)) {
 *         prim_surface(&p, &ray, &h, PRIM_ROBUST, &surf);
 *         Ray next = ray_make(prim_spawn_origin(&surf, dir), dir, INFINITY);
 *     }
 *
 * The contract of every *_hit routine: return 1 and the nearest hit with
 * 0 < t < ray->tmax, or 0 when there is none. Surfaces are two-sided: a ray
 * starting inside a sphere or box hits its far side. Geometric normals are
 * computed only for the closest hit, by prim_surface.
 *
 * The robust routines also promise, about the exact answer for exactly the
 * float inputs they were given (the ray's and primitive's float values taken
 * as exact rationals):
 *
 * - t error: |t - t_exact| <= h->terr for every hit reported.
 * - Verdicts: hit or miss agrees with the exact answer except inside each
 *   routine's error band, stated beside it below. Every band includes
 *   "t_exact within terr of 0 or of tmax".
 * - Spawning: prim_surface bounds the hit point's error (Surface.perr), and
 *   prim_spawn_origin moves off the surface by more than that bound, so a
 *   spawned ray starts strictly on the side it leaves towards; off a
 *   triangle, perr also covers the triangle test's band around t = 0, so
 *   that the ray does not hit its own triangle again.
 *
 * The classic routines report terr = 0: they claim no bound. The exact judge
 * in tests/exact measures both variants against CGAL.
 */
#ifndef LANCER_PRIM_H
#define LANCER_PRIM_H

#include "lancer/ray.h"

typedef struct {
    Vec3 c;
    float r;
} Sphere;

/* Points p with n.p = d; n has unit length. */
typedef struct {
    Vec3 n;
    float d;
} Plane;

/* Vertices a, b, c; vertex normals na, nb, nc are used only when smooth.
 * solid: see prim_solid. */
typedef struct {
    Vec3 a, b, c;
    Vec3 na, nb, nc;
    int solid;
} Triangle;

typedef struct {
    Vec3 lo, hi;
} Box;

/* The parallelepiped c + x*u + y*v + z*w, |x|,|y|,|z| <= 1. inv holds the rows
 * of [u v w]^-1, which map a world offset from c to box coordinates; its rows
 * are also the face normals. Fill it with prim_obox_init. */
typedef struct {
    Vec3 c, u, v, w;
    Vec3 inv[3];
} OBox;

/* A sphere under a general affine map (an ellipsoid): the points x with
 * |A x + b| = 1. m maps the unit sphere to the world (rows of M, then t);
 * a is its inverse (rows of A = M^-1, then b = -A t), both in double. The
 * robust routine takes a, as stored, as the exact primitive; m serves the
 * bounds. Fill a with prim_ellipsoid_init. */
typedef struct Ellipsoid {
    double m[12];
    double a[12];
} Ellipsoid;

typedef enum {
    PRIM_SPHERE,
    PRIM_PLANE,
    PRIM_TRIANGLE,
    PRIM_SMOOTH_TRIANGLE,
    PRIM_BOX,
    PRIM_OBOX,
    PRIM_PN,
    PRIM_ELLIPSOID
} PrimKind;

/* A PN triangle (pntri.h), kept out of line so that it does not grow every
 * other primitive: patch points into the scene's array of patches (at
 * index), and mode is its PnMode. */
struct PnPatch;
struct PnPiece;
typedef struct {
    const struct PnPatch *patch;
    int index;
    int mode;
    const struct PnPiece *piece; /* NULL: the whole patch; else one piece of it (accel.c) */
    int solid;                   /* see prim_solid */
} PnRef;

/* An ellipsoid, kept out of line like a PN patch: e points into the
 * scene's array of ellipsoids, at index. */
typedef struct {
    const Ellipsoid *e;
    int index;
} EllRef;

typedef struct {
    PrimKind kind;
    int material;
    union {
        Sphere sphere;
        Plane plane;
        Triangle tri;
        Box box;
        OBox obox;
        PnRef pn;
        EllRef ell;
    } g;
} Prim;

/* 0 when p bounds a solid of its own; else the number of the mesh it is
 * part of (from 1), whose triangles or patches bound one solid, as
 * POV-Ray's mesh has one interior: a ray that enters by one leaves by
 * another. (Kept in the triangle and the patch, where the union has room:
 * a Prim stays 96 bytes.) */
static inline int prim_solid(const Prim *p)
{
    return p->kind == PRIM_TRIANGLE || p->kind == PRIM_SMOOTH_TRIANGLE ? p->g.tri.solid
           : p->kind == PRIM_PN                                       ? p->g.pn.solid
                                                                       : 0;
}

/* What a hit routine learns: the distance and its error bound, and where on
 * the primitive. */
typedef struct {
    float t;
    float terr; /* robust: |t - t_exact| <= terr; classic: 0 */
    float u, v; /* triangle barycentrics of b and c */
    int face;   /* box: the axis (0-2) of the slab whose plane was hit; the
                 * robust box adds 3 when it is the slab's max plane */
} PrimHit;

/* Shading information at the closest hit. ng is the unit geometric normal
 * and ns the unit shading normal, each flipped on its own to face the
 * incoming ray (as POV-Ray does: an interpolated normal that faces away is
 * turned round even where the geometric normal faces the ray). perr bounds,
 * per coordinate, how far p may lie from the surface. */
typedef struct {
    Vec3 p, ng, ns;
    Vec3 perr;
    Vec3 noff; /* the direction spawned origins move along, on ng's side: ng,
                * except on a box's edge or corner, where it is the sum of
                * the normals of every face p lies on */
    /* An oriented box's hit near another face (within its error of it):
     * pin is a point strictly inside the box, where rays into it start;
     * pin_side is +1 when ng points into the box, -1 when out of it, and 0
     * everywhere else (no pin). */
    Vec3 pin;
    int pin_side;
    /* Whether the hit is near a triangle's edge (prim_near_edge): 0 or 1
     * once known, and -1, for a robust triangle's hit, until the caller
     * asks; 2 for a hit on a triangle whose spawn margin is wide against
     * the point's distance (PRIM_WIDE_MARGIN; a huge triangle), which needs
     * the same care; 0 for every other hit. */
    int edge;
    /* Where edge is 1 or 2: the triangle, and the hit's barycentrics of
     * its b and c (prim_near_edge keeps them for prim_past_plane). */
    const Prim *tri;
    float tu, tv;
} Surface;

/* How near an edge prim_near_edge finds a triangle's hit, in spawn
 * offsets: enough for faces that meet the triangle at an angle down to a
 * few degrees. */
#define PRIM_EDGE_REACH 16.0

/* A triangle's spawn margin past this fraction of the hit point's largest
 * coordinate, or of the ray's length to it, sets Surface.edge to 2. The
 * margin grows with the triangle, not with the coordinates: a floor of two
 * triangles thousands of units across has one of a tenth of a unit, past
 * a surface standing on it. The render's coordinates are the camera's
 * (plan.h), so this is a fraction of the point's distance from the eye, a
 * few hundredths of a pixel's width at common fields of view. */
#define PRIM_WIDE_MARGIN 0x1p-12f

typedef enum { PRIM_ROBUST, PRIM_CLASSIC } PrimVariant;

/* ---- classic ---- */

/* Plane: t = ((a - o).n) / (d.n), a any point of the plane. */
int prim_plane_hit(const Plane *pl, const Ray *r, PrimHit *h);
/* Sphere: the textbook quadratic (d.d)t^2 + 2d.(o-c)t + (o-c).(o-c) - R^2 = 0. */
int prim_sphere_hit(const Sphere *s, const Ray *r, PrimHit *h);
/* Triangle: Moller and Trumbore, "Fast, Minimum Storage Ray-Triangle
 * Intersection", JGT 1997, without back-face culling. */
int prim_triangle_hit(const Triangle *tr, const Ray *r, PrimHit *h);
/* Axis-aligned box: Williams, Barrus, Morley, Shirley, "An Efficient and
 * Robust Ray-Box Intersection Algorithm", JGT 2005. */
int prim_box_hit(const Box *b, const Ray *r, PrimHit *h);
/* Oriented box: three pairs of slab planes; a hit when max(t_near) < min(t_far). */
int prim_obox_hit(const OBox *b, const Ray *r, PrimHit *h);
/* Ellipsoid: the ray mapped by A, b into the unit sphere's space in float,
 * where the textbook quadratic is solved (POV-Ray's way with a transformed
 * sphere); t is the same in both spaces, as the direction is not normalised. */
int prim_ellipsoid_hit(const Ellipsoid *e, const Ray *r, PrimHit *h);

/* ---- robust ---- */

/* Plane, evaluated in double with a forward error bound. Band: rays whose
 * n.d is within its rounding bound of 0 (parallel to working precision) are
 * misses. */
int prim_plane_hit_robust(const Plane *pl, const Ray *r, PrimHit *h);
/* prim_plane_hit_robust for the rays r[k] up to tmax[k] (not their own),
 * k < n <= 32: bit k of the result when ray k hits, at h[k] (u, v and
 * face 0). The same answers, bit for bit; with AVX, four rays at once. */
unsigned prim_plane_hit_robust_rays(const Plane *pl, const Ray *r, const float *tmax, int n, PrimHit *h);
/* Sphere: the numerically stable quadratic of Haines, Guenther and
 * Akenine-Moller, "Precision Improvements for Ray/Sphere Intersection", Ray
 * Tracing Gems ch. 7 (2019), in double; each root is then certified by the
 * sign of the exact quadratic on both sides of it. Band: near-tangent rays
 * whose discriminant is within its rounding bound of 0. */
int prim_sphere_hit_robust(const Sphere *s, const Ray *r, PrimHit *h);
/* Triangle: Woop, Benthin and Wald, "Watertight Ray/Triangle Intersection",
 * JCGT 2(1), 2013, in float as pbrt writes it: edges shared by two triangles
 * give exactly opposite edge functions, so no ray slips between them; an
 * edge function within its rounding bound of 0 is decided in double by the
 * same symmetric test in both triangles. terr is pbrt's bound, with the
 * shear errors taken in length units; a t outside (0, tmax) by less than
 * terr is taken again in double, since the triangle that gets a shared
 * edge may be seen almost edge-on, with a float t worse than its edge
 * signs. Band: rays within a relative 2^-16 of
 * an edge may be reported by only one of the triangles sharing it (never by
 * none: the exact judge checks closed meshes and shared edges). */
int prim_triangle_hit_watertight(const Triangle *tr, const Ray *r, PrimHit *h);
/* The same on three vertices (the four-lane test's lanes that need the
 * double path). */
int prim_triangle_hit_watertight3(const Vec3 v[3], const Ray *r, PrimHit *h);
/* Eight triangles side by side for the SIMD test (a BVH leaf's):
 * v[vertex][axis][lane], each row one AVX2 register (or two of SSE). */
typedef struct {
    float v[3][3][8];
} PrimTri8;

/* What the SIMD test needs of a ray, computed once per ray by
 * prim_triray_init: the axes and shear of the watertight test. */
typedef struct {
    float o[3], sx, sy, sz;
    int kx, ky, kz;
    int simd; /* 0: the direction is rescaled first, so every lane is
               * handed to prim_triangle_hit_watertight3 */
} PrimTriRay;

void prim_triray_init(PrimTriRay *p, const Ray *r);
/* The watertight test's terr from its bound on t's error and t: the bound
 * plus t's own rounding, rounded up. */
float prim_terr_up(float terr, float t);
/* Lane `lane` of t through the scalar routine: the same verdict and t as
 * prim_triangle_hit_watertight3, and the rest of the hit, without setting
 * up the ray again. */
int prim_tri8_lane_hit(const PrimTri8 *t, int lane, const PrimTriRay *p, const Ray *r, PrimHit *h);
/* Axis-aligned box: the slab test of Williams et al. in double, made
 * conservative after Ize, "Robust BVH Ray Traversal", JCGT 2(2), 2013: the
 * far distance grows by PRIM_BOX_PAD, so no hit is lost; an origin on a
 * slab plane with a zero direction component cannot make NaN decide the
 * verdict. Band: rays missing the box by a relative 2 gamma(8) in t (the
 * pad's 8u and the roundings' 7u) may be reported as hits. */
int prim_box_hit_robust(const Box *b, const Ray *r, PrimHit *h);
/* With u = 2^-53, as BVH_SLAB_PAD (bvh.h) in float: a near distance
 * (bound - o) * (1 / d) carries three roundings, a far one times the pad
 * four, so the pad must be at least (1 + u)^3 / (1 - u)^4, about 1 + 7u;
 * 1 + 8u is 1 + 2 gamma(4) rounded to double. (Ize's 1 + 2 gamma(3) is one
 * rounding short where the subtraction rounds.) */
#define PRIM_BOX_PAD (1.0 + 0x1p-50)
/* Oriented box: the six face planes in world space, in double. The verdict
 * takes each slab |(p - c).N| <= |det| widened in slab units by the
 * rounding bounds of its terms, so a slab nearly parallel to the ray widens
 * by what its rounding allows and no more; t comes from the slabs' ends as
 * quotients with their error bounds, or, for a slab the ray grazes, from
 * the brackets of its widened and narrowed interval. Band: false hits
 * only, for rays that pass within 2^-48 (|o - c| + |u| + |v| + |w|) of the
 * box along a face's normal. The margin grows with the box's size and the
 * origin's distance from c, not with |c| or t; relative to t it has no
 * bound, for a ray that grazes a face (docs/robustness.md). */
int prim_obox_hit_robust(const OBox *b, const Ray *r, PrimHit *h);

/* Ellipsoid: the ray mapped into the unit sphere's space in double and
 * the stable quadratic solved there, as for the sphere; each root is then
 * certified by the sign of the exact g(t) = |A (o + t d) + b|^2 - 1 on
 * both sides of it, evaluated from the float ray and the double A, b with
 * a forward error bound. Band: near-tangent rays, where no sign change is
 * certain in double. */
int prim_ellipsoid_hit_robust(const Ellipsoid *e, const Ray *r, PrimHit *h);

/* Computes e->a from e->m. Returns 0, or -1 when m is singular or not
 * finite, or its inverse is not finite. */
int prim_ellipsoid_init(Ellipsoid *e);

/* Computes b->inv from u, v, w. Returns 0, or -1 when the axes are linearly
 * dependent (the box would be flat). */
int prim_obox_init(OBox *b);

/* The tmax with which to search on after a hit at t, for a ray of tmax
 * tmax, so that no hit at t or nearer is lost and ties can be seen: one
 * float past t is not enough, since the watertight test rejects early by
 * comparing t * det, rounded, with tmax * det, which can differ from t by
 * a few ulps; 2^-18 relative covers that, and every other routine only
 * compares its t with tmax. Never past the ray's own tmax, so the hits
 * found are always among those a test with the ray itself finds. */
static inline float prim_tmax_past(float t, float tmax)
{
    float past = t * (1.0f + 0x1p-18f) + 0x1p-149f; /* (the tiniest float: past a subnormal t too) */
    return past < tmax ? past : tmax;
}

/* Starts loading *p into the caches, for a reader soon after: both ends,
 * as a Prim may straddle two cache lines. */
static inline void prim_prefetch(const Prim *p)
{
#ifdef __GNUC__
    __builtin_prefetch(p);
    __builtin_prefetch((const char *)p + sizeof *p - 1);
#else
    (void)p;
#endif
}

/* Whether a hit of primitive id at t replaces the best so far (best, -1
 * for none, at best_t): nearer, or as near with a lower index, so that the
 * closest hit does not depend on the order primitives are tested in. */
static inline int prim_hit_wins(float t, int id, float best_t, int best)
{
    return best < 0 || t < best_t || (t == best_t && id < best);
}

/* Dispatches to the routine for p->kind in the given variant. */
int prim_intersect(const Prim *p, const Ray *r, PrimVariant v, PrimHit *h);
/* prim_intersect for the rays r[k], k in the mask rays (k < 32), each up
 * to its own tmax: bit k of the result when ray k hits, at h[k] (the other
 * entries are not to be read). The same answers, bit for bit; with AVX, a
 * robust sphere or ellipsoid takes four rays at once, and a PN patch's
 * first tests take four (pn_hit_piece_rays). */
unsigned prim_intersect_rays(const Prim *p, const Ray *r, unsigned rays, PrimVariant v, PrimHit *h);

/* 1 when q lies inside a solid primitive: strictly inside a sphere or an
 * ellipsoid, and inside or on a face of a box or an oriented box, whose
 * hit routines take a ray from a face for one from inside (its first hit
 * the far face), as POV-Ray's Inside() does. Planes and triangles are
 * surfaces: nothing is inside them. */
int prim_inside(const Prim *p, Vec3 q);

/* Fills the hit point, normals and error bound for a hit found by
 * prim_intersect with the same variant. The classic variant's bound is a
 * heuristic (16 ulps of the larger of |p| and |ray origin|); the robust
 * one's is proven. */
void prim_surface(const Prim *p, const Ray *r, const PrimHit *h, PrimVariant v, Surface *s);
/* Does robust hit h of primitive p, of surface s, lie within
 * PRIM_EDGE_REACH spawn offsets of an edge of the triangle p? There
 * moving off the triangle's plane may cross that of a face beyond the
 * edge, and a ray spawned there hit that face at once (shade.c,
 * edge_clear). 0 for every other kind. When 1, s keeps p and h's
 * barycentrics (tri, tu, tv); the caller sets s->edge. */
int prim_near_edge(const Prim *p, const PrimHit *h, Surface *s);
/* Would a ray from s's point along d not cross flat primitive x (a
 * triangle or a plane), whatever its hit from an offset origin says? So
 * when the point lies on x's plane or past it as seen along d: the line
 * then meets the plane at a t <= 0 (shade.c, edge_clear). For a hit near
 * a triangle's edge (s->edge 1, prim_near_edge) the side is the exact
 * point's, from the triangle's vertices, when none of them lies on the far
 * side of x's plane from another; otherwise, and for other hits, s's
 * point within its error bound (off a huge triangle, s->edge 2, its own:
 * prim_wide_err) counts as on the plane. 0 for the other kinds of x. */
int prim_past_plane(const Prim *x, const Surface *s, Vec3 d);
/* For a hit on a huge triangle (s->edge 2), a bound on how far s->p lies
 * from the ray's exact meeting with the triangle's plane, summed over the
 * coordinates: its own error, short of the spawn margin that perr holds. */
float prim_wide_err(const Surface *s);
/* Does the line from the point of a hit near a triangle's edge (s->edge 1,
 * prim_near_edge: b0 a + b1 b + b2 c of s's triangle, in double; off a
 * huge triangle, s->edge 2, s->p within prim_wide_err) along d cross
 * triangle x at a t > 0? Where x's plane is met inside x, to within the
 * roundings of double. The point lies on s's triangle, so a face
 * beyond a convex edge, which the line leaves behind, is not crossed,
 * where the offset triangle test, within its error band of the edge, may
 * report it (shade.c, edge_behind). 0 for the other kinds of x. */
int prim_line_crosses(const Prim *x, const Surface *s, Vec3 d);
/* prim_surface for the hits j < n of rays r[j] at prims[best[j]], into
 * s[j], skipping those with best[j] < 0: the same surfaces, bit for bit;
 * with AVX, robust spheres four at a time. */
void prim_surface_hits(const Prim *prims, const int *best, const Ray *r, const PrimHit *h, int n, PrimVariant v,
                       Surface *s);

/* The origin for a ray leaving surface point s->p in direction dir: p moved
 * along the geometric normal, to dir's side, by more than s->perr projected
 * on it, then one float further (pbrt-v4's OffsetRayOrigin). No fixed
 * epsilon: the offset is the error bound of this very hit. It depends on
 * dir's side alone: prim_spawn_side takes nd = dot(s->ng, dir). */
Vec3 prim_spawn_side(const Surface *s, float nd);
/* Inline, so that dir crosses no call: a Vec3 passed by value was packed
 * through memory, and its reload stalled on the stores. */
static inline Vec3 prim_spawn_origin(const Surface *s, Vec3 dir) { return prim_spawn_side(s, vec_dot(s->ng, dir)); }

/* prim_spawn_origin's two answers, for the many rays that leave one point
 * (an area light's samples): o[0] for every dir with dot(s->ng, dir) < 0,
 * o[1] for every dir with dot(s->ng, dir) > 0. A dir with neither (in the
 * tangent plane, or not a number) takes prim_spawn_origin. */
void prim_spawn_origins(const Surface *s, Vec3 o[2]);

#endif
