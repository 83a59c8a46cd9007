/*
 * prim.h - the geometric primitives and their ray intersection routines.
 *
 *     float t;
 *     if (prim_sphere_hit(&sphere, &ray, &t)) ... hit at ray_at(&ray, t) ...
 *
 *     Prim p;  ... filled by the scene parser ...
 *     PrimHit h;
 *     if (prim_intersect(&p, &ray, &h)) prim_surface(&p, &ray, &h, &surf);
 *
 * Each *_hit routine returns 1 and the nearest t with 0 < t < ray->tmax, or 0
 * when there is none. Surfaces are two-sided: a ray starting inside a sphere
 * or box hits its far side. These are the classic formulations, written as
 * the cited papers give them; robust variants will sit beside them with the
 * same interface. Geometric normals are computed only for the closest hit,
 * by prim_surface, so the hit routines return the little they need (t, and
 * the barycentrics or face of the hit).
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

/* Vertices a, b, c; vertex normals na, nb, nc are used only when smooth. */
typedef struct {
    Vec3 a, b, c;
    Vec3 na, nb, nc;
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

typedef enum {
    PRIM_SPHERE,
    PRIM_PLANE,
    PRIM_TRIANGLE,
    PRIM_SMOOTH_TRIANGLE,
    PRIM_BOX,
    PRIM_OBOX
} PrimKind;

typedef struct {
    PrimKind kind;
    int material;
    union {
        Sphere sphere;
        Plane plane;
        Triangle tri;
        Box box;
        OBox obox;
    } g;
} Prim;

/* What a hit routine learns: the distance, and where on the primitive. */
typedef struct {
    float t;
    float u, v; /* triangle barycentrics of b and c */
    int face;   /* box: the axis (0-2) of the slab whose plane was hit */
} PrimHit;

/* Shading information at the closest hit. ng is the unit geometric normal
 * and ns the unit shading normal, each flipped on its own to face the
 * incoming ray (as POV-Ray does: an interpolated normal that faces away is
 * turned round even where the geometric normal faces the ray). */
typedef struct {
    Vec3 p, ng, ns;
} Surface;

/* Plane: t = ((a - o).n) / (d.n), a any point of the plane. */
int prim_plane_hit(const Plane *pl, const Ray *r, float *t);
/* Sphere: the textbook quadratic (d.d)t^2 + 2d.(o-c)t + (o-c).(o-c) - R^2 = 0. */
int prim_sphere_hit(const Sphere *s, const Ray *r, float *t);
/* Triangle: Moller and Trumbore, "Fast, Minimum Storage Ray-Triangle
 * Intersection", JGT 1997, without back-face culling. */
int prim_triangle_hit(const Triangle *tr, const Ray *r, float *t, float *u, float *v);
/* Axis-aligned box: Williams, Barrus, Morley, Shirley, "An Efficient and
 * Robust Ray-Box Intersection Algorithm", JGT 2005. */
int prim_box_hit(const Box *b, const Ray *r, float *t, int *face);
/* Oriented box: three pairs of slab planes; a hit when max(t_near) < min(t_far). */
int prim_obox_hit(const OBox *b, const Ray *r, float *t, int *face);

/* Computes b->inv from u, v, w. Returns 0, or -1 when the axes are linearly
 * dependent (the box would be flat). */
int prim_obox_init(OBox *b);

/* Dispatches to the routine for p->kind. */
int prim_intersect(const Prim *p, const Ray *r, PrimHit *h);

/* 1 when q lies strictly inside a solid primitive (sphere, box, oriented
 * box). Planes and triangles are surfaces: nothing is inside them. */
int prim_inside(const Prim *p, Vec3 q);

/* Fills the hit point and normals for a hit found by prim_intersect. */
void prim_surface(const Prim *p, const Ray *r, const PrimHit *h, Surface *s);

#endif
