/*
 * pntri.h - PN triangles: the curved patch of Vlachos, Peters, Boyd and
 * Mitchell, "Curved PN Triangles", I3D 2001, made from a triangle and its
 * three vertex normals, and traced directly.
 *
 *     PnPatch p;
 *     pn_patch_init(&p, pts, unit_normals);
 *     PnHit h;
 *     if (pn_hit(&p, &ray, PN_EXACT, &h)) ... hit at h.t within h.terr, at (h.u, h.v) ...
 *
 * The patch is the cubic Bezier triangle of its ten float control points:
 * they are computed in double from the float vertices and unit normals and
 * rounded once, and from then on they *are* the patch (the exact judge
 * takes them as exact rationals). An edge's two inner points depend only on
 * that edge's end points and their normals, and are computed by one
 * function, so two patches that share an edge and its normals share its
 * boundary curve bit for bit.
 *
 * The control net's order. Barycentrics (w, u, v), w = 1 - u - v, weigh
 * the vertices P1, P2, P3; b_ijk (i + j + k = 3) is the point whose
 * Bernstein polynomial is 3!/(i! j! k!) w^i u^j v^k. The net is stored row
 * by row from P1: row r = 3 - i holds the points with i = 3 - r, by k
 * from 0, so that b_ijk is at PN_AT(i, k) = r (r + 1) / 2 + k:
 *
 *     0: b300                     (P1)
 *     1: b210  2: b201
 *     3: b120  4: b111  5: b102
 *     6: b030  7: b021  8: b012  9: b003      (P2 ... P3)
 */
#ifndef LANCER_PNTRI_H
#define LANCER_PNTRI_H

#include "lancer/ray.h"

#define PN_AT(i, k) ((3 - (i)) * (4 - (i)) / 2 + (k))

typedef struct PnPatch {
    Vec3 b[10]; /* the control net, in the order above */
    /* The quadratic normal field: n200 = N1, n020 = N2, n002 = N3, then
     * n110, n011, n101, each of unit length. */
    Vec3 n[6];
} PnPatch;

typedef enum { PN_EXACT, PN_FAST } PnMode;

/* The PnMode named "exact" or "fast", or -1 for any other name. */
int pn_mode_named(const char *name);

/* A hit: t, a bound terr on its error (0 in PN_FAST: none), and the
 * domain point (u, v), the weights of P2 and P3. */
typedef struct {
    float t, terr, u, v;
} PnHit;

/* The patch of vertices p[0..2] and unit vertex normals n[0..2]. */
void pn_patch_init(PnPatch *pn, const Vec3 p[3], const Vec3 n[3]);

/* The patch's point at (u, v), in double, with its partial derivatives
 * (either may be NULL). */
void pn_eval(const PnPatch *pn, double u, double v, double pt[3], double du[3], double dv[3]);

/* The unit shading normal at (u, v): the quadratic normal field,
 * renormalised. */
Vec3 pn_shading_normal(const PnPatch *pn, float u, float v);

/* The unit geometric normal at (u, v), (dB/du x dB/dv) normalised, oriented
 * as (P2 - P1) x (P3 - P1) for a flat patch; where the derivatives are
 * parallel (a degenerate corner), the shading normal. */
Vec3 pn_geometric_normal(const PnPatch *pn, float u, float v);

/* The box [lo, hi] of the control net, which holds the patch (a Bezier
 * triangle lies in the convex hull of its net). */
void pn_bounds(const PnPatch *pn, Vec3 *lo, Vec3 *hi);

/* ---- tessellation ----
 *
 * The patch as n x n flat triangles on its (u, v) grid, for renderers that
 * have no PN primitive (export-pov) and for comparing with one: pts and
 * nrm get the (n + 1)(n + 2) / 2 points (a/n, b/n), a + b <= n, in rows of
 * equal a, with the shading normals there; faces gets the n * n
 * triangles, as indices into pts, in P1, P2, P3's turning order. */
static inline int pn_grid_points(int n) { return (n + 1) * (n + 2) / 2; }
void pn_tessellate(const PnPatch *pn, int n, Vec3 *pts, Vec3 *nrm, int (*faces)[3]);

/* ---- subdivision, in double ----
 *
 * A sub-patch over the domain triangle with corners (u0, v0), (u0 + s, v0)
 * and (u0, v0 + s) (or, flipped, with -s), its net computed by de
 * Casteljau steps from its parent's. err bounds, on every axis, how far
 * each computed control point may lie from the exact sub-patch's. */
typedef struct PnNet {
    double b[10][3];
    double err;
    double u0, v0, s;
    int flip;
} PnNet;

/* The whole patch as a net. */
void pn_net_root(const PnPatch *pn, PnNet *net);

/* The four children of the midpoint split: the corners' (at P1's, P2's
 * and P3's end of the parent) and the middle one, each with its domain and
 * error bound. Points along the parent's edges are computed by the curve's
 * own de Casteljau step at 1/2, whose averages give the same bits from
 * either end, so patches sharing an edge split it into the same points. */
void pn_net_split(const PnNet *parent, PnNet child[4]);

/* For tests: 0 makes the split and pn_eval run their plain loops where
 * they would run AVX (the same bits, lane by lane), 1 lets them pick
 * again. Returns 1 when the processor has AVX, which they then use. Not
 * for use while another thread traces patches. */
int pn_split_avx(int allow);

/* For tests: the split's program, as pntri.c describes it (test_pntri
 * derives it again from the blossom). */
typedef struct {
    int nops;
    unsigned char op[64][2];
    unsigned char child[4][10];
    int nown[4];
    unsigned char own[4][64];
} PnSplitProgram;
void pn_split_program(PnSplitProgram *g);

/* The net's box grown by its error bound, in double. */
void pn_net_box(const PnNet *net, double lo[3], double hi[3]);

/* ---- intersection ---- */

/* The nearest hit with 0 < t < ray->tmax: (h->u, h->v) is the domain point,
 * h->terr bounds t's error. PN_EXACT subdivides, nearest sub-patch first,
 * until a piece is flat, or its box small, to float precision, or is
 * proven to be crossed once at a point Newton's method pins down (or not
 * at all ahead of the origin); PN_FAST solves by Newton's method from the
 * patch's centre, falling back to subdivision where Newton fails. */
int pn_hit(const PnPatch *pn, const Ray *r, PnMode mode, PnHit *h);

/* The slope L of the piece as a graph over the plane of its corners, which
 * bounds its proofs (pntri.c, pn_certify): rays at an angle to that plane's
 * normal whose tangent is below 1 / L can be settled on it at once.
 * INFINITY when the piece is too curved to be shown a graph. */
double pn_net_slope(const PnPatch *pn, const PnNet *net);

/* A piece of a patch, a sub-patch depth splits down (pn_net_split), which
 * a BVH holds in the patch's place, with what every ray would compute of
 * it again: its net's box, the patch's largest coordinate, and the shape
 * the first tests of every ray that enters it measure (pntri.c, trace). */
typedef struct PnPiece {
    PnNet net;
    double lo[3], hi[3]; /* pn_net_box */
    double mag;
    int depth;
    int shaped;          /* 1 when the four below are set */
    double dev;          /* how far the net strays from its corners' triangle */
    double len[3];       /* that triangle's edges, |AB|, |AC| and |BC| */
    double kappa, slope; /* the piece as a graph over that triangle's plane */
} PnPiece;
/* Fills in the box, the magnitude and the shape of a piece of pn whose net
 * is set. */
void pn_piece_init(PnPiece *pc, const PnPatch *pn);

/* pn_hit on one piece of the patch: the piece's hits (in PN_FAST, Newton's
 * method starts from its centre and keeps any root on the patch). */
int pn_hit_piece(const PnPatch *pn, const PnPiece *piece, const Ray *ray, PnMode mode, PnHit *h);

/* pn_hit_piece for the rays ray[k], k in the mask rays (k < 32), or pn_hit
 * when piece is NULL: bit k of the result when ray k hits, at h[k] (the
 * other entries are not to be read). The same answers, bit for bit; with
 * AVX, the first tests of up to four rays at a time. */
unsigned pn_hit_piece_rays(const PnPatch *pn, const PnPiece *piece, const Ray *ray, unsigned rays, PnMode mode,
                           PnHit *h);

/* For tests: pn_hit with its proofs of a piece's only crossing (proofs 1)
 * or by subdivision alone (0), adding to *proven (when not NULL) how many
 * pieces a proof settled. */
int pn_hit_with(const PnPatch *pn, const Ray *r, PnMode mode, int proofs, PnHit *h, long *proven);

#endif
