// exact.cpp - the exact answers, the error bands and the verdict of one
// routine on one ray. Everything here works on exactly the float bits the
// routine saw, as CGAL Epeck numbers (Lazy_exact_nt over GMP rationals:
// interval-filtered, exact when the filter cannot decide).
#include "judge.h"

#include <algorithm>
#include <cfloat>
#include <climits>
#include <cstdarg>
#include <cstdio>
#include <cstring>

#include <mpfr.h>

#include <CGAL/Exact_predicates_exact_constructions_kernel.h>
#include <CGAL/intersections.h>

namespace judge {

typedef CGAL::Epeck K;
typedef K::FT FT;
typedef K::Point_3 P3;
typedef K::Vector_3 V3;

// A ray in exact numbers (the float ray's bits; or a segment, for case 8).
struct XRay {
    FT o[3], d[3];
    bool fin = false; // tmax finite
    FT tmax;
};

// The exact answer for one primitive and one ray with window (0, tmax).
struct Ex {
    Kind kind = K_PLANE;
    bool skip = false; // degenerate input the judge does not rule on
    bool hit = false;
    // Non-sphere: every t in [lo, hi] is an acceptable nearest hit (lo == hi
    // unless the ray lies in a face or plane); hi_inf when unbounded above.
    FT lo, hi;
    bool hi_inf = false;
    // Where the whole line meets the surface (for the near-0/tmax band).
    std::vector<FT> cand;
    // Sphere: q(t) = A t^2 + 2 Bh t + C; the hit is root 1 (smaller) or 2.
    FT A, Bh, C, disc, f2, r2;
    int root = 0;
    // Ellipsoid: q(t) = |f + t D|^2 - 1, so also A = D.D, Bh = D.f, C = f.f - 1
    // (cmp_root evaluates q from f and D: no cancellation of large terms).
    FT ef[3], eD[3];
    // Plane/triangle: n.d, |n|^2, |d|^2; triangle edge functions and scales.
    FT nd, nn, dd;
    FT E[3], M[3];
    int face = -1;         // box/obox: the axis of the nearest hit when unique
    double t_approx = 0.0; // a double near the hit (or the line's candidate)
};

static int cmp_root(const Ex &e, int k, const FT &s);
// The kinds whose exact answer is a quadratic's root (Ex::A, Bh, C, root).
static inline bool is_quad(Kind k) { return k == K_SPHERE || k == K_ELL; }

const Routine ROUTINES[N_ROUTINES] = {
    {"prim_plane_hit", K_PLANE, false},         {"prim_plane_hit_robust", K_PLANE, true},
    {"prim_sphere_hit", K_SPHERE, false},       {"prim_sphere_hit_robust", K_SPHERE, true},
    {"prim_triangle_hit", K_TRI, false},        {"prim_triangle_hit_watertight", K_TRI, true},
    {"prim_box_hit", K_BOX, false},             {"prim_box_hit_robust", K_BOX, true},
    {"prim_obox_hit", K_OBOX, false},           {"prim_obox_hit_robust", K_OBOX, true},
    {"pn_net_box", K_PN, true},                 {"pn_hit_exact", K_PN, true},
    {"pn_hit_fast", K_PN, false},
    {"prim_ellipsoid_hit", K_ELL, false},       {"prim_ellipsoid_hit_robust", K_ELL, true},
    {"pn_hit_piece", K_PN, true},
};

int call_routine(int rid, const Prim &p, const Ray &r, PrimHit &h)
{
    switch (rid) {
    case R_PLANE: return prim_plane_hit(&p.g.plane, &r, &h);
    case R_PLANE_ROB: return prim_plane_hit_robust(&p.g.plane, &r, &h);
    case R_SPHERE: return prim_sphere_hit(&p.g.sphere, &r, &h);
    case R_SPHERE_ROB: return prim_sphere_hit_robust(&p.g.sphere, &r, &h);
    case R_TRI: return prim_triangle_hit(&p.g.tri, &r, &h);
    case R_TRI_WT: return prim_triangle_hit_watertight(&p.g.tri, &r, &h);
    case R_BOX: return prim_box_hit(&p.g.box, &r, &h);
    case R_BOX_ROB: return prim_box_hit_robust(&p.g.box, &r, &h);
    case R_OBOX: return prim_obox_hit(&p.g.obox, &r, &h);
    case R_OBOX_ROB: return prim_obox_hit_robust(&p.g.obox, &r, &h);
    case R_ELL: return prim_ellipsoid_hit(p.g.ell.e, &r, &h);
    case R_ELL_ROB: return prim_ellipsoid_hit_robust(p.g.ell.e, &r, &h);
    }
    return 0;
}

uint64_t ray_seed(uint64_t base, int case_id, int routine, uint64_t ray)
{
    uint64_t x = base ^ ((uint64_t)case_id << 56) ^ ((uint64_t)routine << 48);
    uint64_t a = splitmix64(x);
    x = a ^ ray;
    splitmix64(x);
    return splitmix64(x);
}

std::string hexf(float x)
{
    char b[48];
    std::snprintf(b, sizeof b, "%a", (double)x);
    return b;
}
std::string hexd(double x)
{
    char b[48];
    std::snprintf(b, sizeof b, "%a", x);
    return b;
}
static std::string hv(Vec3 v) { return "(" + hexf(v.x) + "," + hexf(v.y) + "," + hexf(v.z) + ")"; }
static std::string strf(const char *fmt, ...) __attribute__((format(printf, 1, 2)));
static std::string strf(const char *fmt, ...)
{
    char b[512];
    va_list ap;
    va_start(ap, fmt);
    std::vsnprintf(b, sizeof b, fmt, ap);
    va_end(ap);
    return b;
}

// =====================================================================
// Error bands. Each robust routine's documented band (prim.h), made
// concrete and computed exactly. Tune the constants here, nowhere else.
// =====================================================================

// Misses near 0 or tmax: when the routine reports a miss there is no terr,
// so the judge estimates one: this fraction of the problem's t scale
// (|t| + max|coordinate| / max|d_i|). A few float ulps: float inputs cannot
// place t more finely than that.
const double BAND_T_EDGE_REL = 0x1p-20;
// Plane: parallel to working precision, (n.d)^2 <= rel^2 |n|^2 |d|^2.
const double BAND_PLANE_REL = 0x1p-40;
// Sphere: near-tangent, |dist^2 - r^2| <= rel (|o-c| r + r^2), dist the
// distance from the centre to the line. (|o-c| r is the scale of the
// rounding error of dist^2 in the Ray Tracing Gems formulation; relative to
// |o-c|^2 + r^2 the band would swallow whole spheres seen from 1e6 radii.)
const double BAND_SPHERE_REL = 0x1p-40;
// Triangle: the ray passes within a relative margin of an edge line:
// |E_i| <= rel |d|inf |P_j|inf |P_k|inf, E_i = d.(P_k x P_j) the exact edge
// function, P = vertex - origin. The watertight routine evaluates its edge
// functions in float (2D cross products of sheared float coordinates,
// worst case ~72 float ulps of that product), so the band is 2^-16.
const double BAND_TRI_REL = 0x1p-16;
// Boxes: false hits within a relative 1e-6 of the slab intervals (each
// [t0, t1] widened by rel * max(|t0|, |t1|)); false misses never.
const double BAND_BOX_REL = 1e-6;
const double BAND_OBOX_REL = 1e-6;
// Ellipsoid (case 11): near-tangent in the unit sphere's space, where the
// ray is f + t D (f = A o + b, D = A d, A and b the stored doubles):
// |dist^2 - 1| <= rel (S + 1), dist the distance from 0 to that line, and
// S = max_i sum_j |a_ij| (|o_j| + |t_v d_j|) + |b_i| the magnitude of the
// terms of A (o + t d) + b at the line's closest point t_v = -(D.f)/(D.D),
// the scale of the rounding error of g = |A (o + t d) + b|^2 - 1 in double
// near the tangent point (its cancellation: A o and b are large for an
// ellipsoid far from the origin or much smaller than |o|). The sphere's
// band made affine: for A = I / r, b = -c / r it is the sphere's up to |c|
// and |o| in place of |o - c| (o - c is exact in double, A o + b is not).
// The routine's own bound on g's error near the surface (ell_g in
// src/prim.c) is about 21 u S + 10 u (u = 2^-53), below 2^-48 (S + 1): the
// band is 2^8 times that. (At 10^6 rays no robust false miss lies beyond
// 2^-48 (S + 1); 21 lie beyond 2^-50 (S + 1).)
const double BAND_ELL_REL = 0x1p-40;

// =====================================================================
// Small exact vector algebra on FT.
// =====================================================================

static inline FT F(float x) { return FT((double)x); }
static inline FT Fd(double x) { return FT(x); }

struct X3 {
    FT v[3];
};
static inline X3 x3(Vec3 a) { return X3{{F(a.x), F(a.y), F(a.z)}}; }
static inline X3 sub(const X3 &a, const X3 &b) { return X3{{a.v[0] - b.v[0], a.v[1] - b.v[1], a.v[2] - b.v[2]}}; }
static inline FT dot(const X3 &a, const X3 &b) { return a.v[0] * b.v[0] + a.v[1] * b.v[1] + a.v[2] * b.v[2]; }
static inline X3 cross(const X3 &a, const X3 &b)
{
    return X3{{a.v[1] * b.v[2] - a.v[2] * b.v[1], a.v[2] * b.v[0] - a.v[0] * b.v[2], a.v[0] * b.v[1] - a.v[1] * b.v[0]}};
}
static inline FT fabsx(const FT &a) { return a < 0 ? -a : a; }
static inline FT maxx(const FT &a, const FT &b) { return a < b ? b : a; }
static inline FT minx(const FT &a, const FT &b) { return a < b ? a : b; }
static inline FT inf_norm(const X3 &a) { return maxx(fabsx(a.v[0]), maxx(fabsx(a.v[1]), fabsx(a.v[2]))); }
static inline bool is_zero(const X3 &a) { return a.v[0] == 0 && a.v[1] == 0 && a.v[2] == 0; }
static inline X3 xr_o(const XRay &r) { return X3{{r.o[0], r.o[1], r.o[2]}}; }
static inline X3 xr_d(const XRay &r) { return X3{{r.d[0], r.d[1], r.d[2]}}; }
static inline float comp(Vec3 v, int i) { return i == 0 ? v.x : i == 1 ? v.y : v.z; }

static XRay xray_of(const Ray &r)
{
    XRay x;
    for (int i = 0; i < 3; i++) {
        x.o[i] = F(comp(r.o, i));
        x.d[i] = F(comp(r.d, i));
    }
    x.fin = std::isfinite(r.tmax);
    if (x.fin)
        x.tmax = F(r.tmax);
    return x;
}

static inline bool below_tmax(const XRay &r, const FT &t) { return !r.fin || t < r.tmax; }

// =====================================================================
// Exact answers, one per primitive kind.
// =====================================================================

static Ex ex_plane(const Plane &pl, const XRay &r)
{
    Ex e;
    e.kind = K_PLANE;
    X3 n = x3(pl.n), d = xr_d(r);
    if (is_zero(n) || is_zero(d)) {
        e.skip = true;
        return e;
    }
    FT pd = F(pl.d);
    e.nd = dot(n, d);
    e.nn = dot(n, n);
    e.dd = dot(d, d);
    FT no = dot(n, xr_o(r));
    if (e.nd != 0) {
        FT tc = (pd - no) / e.nd;
        e.cand.push_back(tc);
        e.t_approx = CGAL::to_double(tc);
        if (tc > 0 && below_tmax(r, tc)) {
            e.hit = true;
            e.lo = e.hi = tc;
        }
    } else if (no == pd) {
        // The ray lies in the plane: every t is a hit point; the infimum 0.
        e.cand.push_back(FT(0));
        e.hit = true;
        e.lo = 0;
        if (r.fin)
            e.hi = r.tmax;
        else
            e.hi_inf = true;
    }
    return e;
}

static int cmp_root(const Ex &e, int k, const FT &s)
{
    int sq, sv;
    if (e.kind == K_ELL) {
        // the same polynomials as below, as |y|^2 - 1 and D.y with y = f + s D,
        // which the interval filter decides far more often: y is near the
        // unit sphere where q is small, while A s^2, Bh s and C cancel
        FT y[3] = {e.ef[0] + s * e.eD[0], e.ef[1] + s * e.eD[1], e.ef[2] + s * e.eD[2]};
        sq = CGAL::sign(y[0] * y[0] + y[1] * y[1] + y[2] * y[2] - 1);
        sv = CGAL::sign(e.eD[0] * y[0] + e.eD[1] * y[1] + e.eD[2] * y[2]);
    } else {
        FT qs = (e.A * s + 2 * e.Bh) * s + e.C;
        sq = CGAL::sign(qs);
        sv = CGAL::sign(e.A * s + e.Bh); // sign(s - vertex), A > 0
    }
    if (sq == 0) {
        if (e.disc == 0)
            return 0;
        if (k == 1)
            return sv < 0 ? 0 : -1;
        return sv > 0 ? 0 : 1;
    }
    if (sq < 0)
        return k == 1 ? -1 : 1; // t1 < s < t2
    return sv < 0 ? 1 : -1;     // s outside [t1, t2], on the side sv says
}

static Ex ex_sphere(const Sphere &s, const XRay &r)
{
    Ex e;
    e.kind = K_SPHERE;
    X3 d = xr_d(r), f = sub(xr_o(r), x3(s.c));
    e.A = dot(d, d);
    if (e.A == 0 || !(s.r > 0.0f)) {
        e.skip = true;
        return e;
    }
    e.Bh = dot(d, f);
    e.f2 = dot(f, f);
    e.r2 = F(s.r) * F(s.r);
    e.C = e.f2 - e.r2;
    e.disc = e.Bh * e.Bh - e.A * e.C;
    if (e.disc < 0)
        return e;
    {
        double A = CGAL::to_double(e.A), B = CGAL::to_double(e.Bh), C = CGAL::to_double(e.C);
        double D = std::max(0.0, CGAL::to_double(e.disc));
        double q = -(B + std::copysign(std::sqrt(D), B));
        double t1 = q / A, t2 = q != 0.0 ? C / q : t1;
        if (t1 > t2)
            std::swap(t1, t2);
        e.t_approx = t1 > 0 ? t1 : t2;
    }
    if (cmp_root(e, 1, FT(0)) > 0) {
        if (!r.fin || cmp_root(e, 1, r.tmax) < 0) {
            e.hit = true;
            e.root = 1;
        }
    } else if (cmp_root(e, 2, FT(0)) > 0 && (!r.fin || cmp_root(e, 2, r.tmax) < 0)) {
        e.hit = true;
        e.root = 2;
    }
    return e;
}

// The nearest root of q(t) = A t^2 + 2 Bh t + C in (0, tmax), from e.A,
// e.Bh, e.C (A > 0) and e.disc = Bh^2 - A C, as ex_sphere does.
static void quad_resolve(Ex &e, const XRay &r)
{
    if (e.disc < 0)
        return;
    {
        // interval midpoints: to_double would compute the exact value
        auto mid = [](const FT &x) {
            std::pair<double, double> i = CGAL::to_interval(x);
            return 0.5 * i.first + 0.5 * i.second;
        };
        double A = mid(e.A), B = mid(e.Bh), C = mid(e.C);
        double D = std::max(0.0, mid(e.disc));
        double q = -(B + std::copysign(std::sqrt(D), B));
        double t1 = q / A, t2 = q != 0.0 ? C / q : t1;
        if (t1 > t2)
            std::swap(t1, t2);
        e.t_approx = t1 > 0 ? t1 : t2;
    }
    if (cmp_root(e, 1, FT(0)) > 0) {
        if (!r.fin || cmp_root(e, 1, r.tmax) < 0) {
            e.hit = true;
            e.root = 1;
        }
    } else if (cmp_root(e, 2, FT(0)) > 0 && (!r.fin || cmp_root(e, 2, r.tmax) < 0)) {
        e.hit = true;
        e.root = 2;
    }
}

// The ellipsoid |A x + b| = 1 of the stored a[] (rows of A, then b), every
// double taken as an exact rational: along the ray, g(t) = |f + t D|^2 - 1
// with f = A o + b and D = A d, exactly.
static void ell_fD(const Ellipsoid &E, const XRay &r, FT f[3], FT D[3])
{
    for (int i = 0; i < 3; i++) {
        f[i] = Fd(E.a[9 + i]);
        D[i] = FT(0);
        for (int j = 0; j < 3; j++) {
            FT a = Fd(E.a[3 * i + j]);
            f[i] += a * r.o[j];
            D[i] += a * r.d[j];
        }
    }
}

static Ex ex_ell(const Ellipsoid &E, const XRay &r)
{
    Ex e;
    e.kind = K_ELL;
    for (int k = 0; k < 12; k++)
        if (!std::isfinite(E.a[k])) {
            e.skip = true;
            return e;
        }
    FT *f = e.ef, *D = e.eD;
    ell_fD(E, r, f, D);
    e.A = D[0] * D[0] + D[1] * D[1] + D[2] * D[2];
    if (e.A == 0) { // d = 0 (or A singular as stored)
        e.skip = true;
        return e;
    }
    e.Bh = D[0] * f[0] + D[1] * f[1] + D[2] * f[2];
    e.f2 = f[0] * f[0] + f[1] * f[1] + f[2] * f[2];
    e.r2 = FT(1);
    e.C = e.f2 - 1;
    // Bh^2 - A C = |D|^2 - |D x f|^2 (Lagrange's identity), which the
    // interval filter decides where the large (D.f)^2 and |D|^2 |f|^2 cancel
    FT cx = D[1] * f[2] - D[2] * f[1], cy = D[2] * f[0] - D[0] * f[2], cz = D[0] * f[1] - D[1] * f[0];
    e.disc = e.A - (cx * cx + cy * cy + cz * cz);
    quad_resolve(e, r);
    return e;
}

static Ex ex_tri(const Triangle &t, const XRay &r)
{
    Ex e;
    e.kind = K_TRI;
    X3 A = x3(t.a), B = x3(t.b), C = x3(t.c), O = xr_o(r), d = xr_d(r);
    X3 n = cross(sub(B, A), sub(C, A));
    if (is_zero(n) || is_zero(d)) {
        e.skip = true; // a degenerate triangle or a zero direction
        return e;
    }
    X3 pa = sub(A, O), pb = sub(B, O), pc = sub(C, O);
    e.E[0] = dot(d, cross(pc, pb));
    e.E[1] = dot(d, cross(pa, pc));
    e.E[2] = dot(d, cross(pb, pa));
    FT di = inf_norm(d), na = inf_norm(pa), nb = inf_norm(pb), nc = inf_norm(pc);
    e.M[0] = di * nc * nb;
    e.M[1] = di * na * nc;
    e.M[2] = di * nb * na;
    e.nd = dot(n, d);
    e.nn = dot(n, n);
    e.dd = dot(d, d);
    if (e.nd != 0) {
        int s0 = CGAL::sign(e.E[0]), s1 = CGAL::sign(e.E[1]), s2 = CGAL::sign(e.E[2]);
        bool inside = (s0 >= 0 && s1 >= 0 && s2 >= 0) || (s0 <= 0 && s1 <= 0 && s2 <= 0);
        if (!inside)
            return e;
        FT tc = dot(n, pa) / e.nd;
        e.cand.push_back(tc);
        e.t_approx = CGAL::to_double(tc);
        if (tc > 0 && below_tmax(r, tc)) {
            e.hit = true;
            e.lo = e.hi = tc;
        }
        return e;
    }
    if (dot(n, pa) != 0)
        return e; // parallel to the plane, off it
    // The ray lies in the triangle's plane: intersect the line exactly.
    P3 Op(O.v[0], O.v[1], O.v[2]);
    V3 Dv(d.v[0], d.v[1], d.v[2]);
    K::Triangle_3 T(P3(A.v[0], A.v[1], A.v[2]), P3(B.v[0], B.v[1], B.v[2]), P3(C.v[0], C.v[1], C.v[2]));
    auto res = CGAL::intersection(K::Line_3(Op, Dv), T);
    if (!res)
        return e;
    FT s0, s1;
    if (const P3 *pt = boost::get<P3>(&*res)) {
        s0 = s1 = ((*pt - Op) * Dv) / e.dd;
    } else if (const K::Segment_3 *sg = boost::get<K::Segment_3>(&*res)) {
        s0 = ((sg->source() - Op) * Dv) / e.dd;
        s1 = ((sg->target() - Op) * Dv) / e.dd;
        if (s1 < s0)
            std::swap(s0, s1);
    } else {
        e.skip = true;
        return e;
    }
    e.cand.push_back(s0);
    e.cand.push_back(s1);
    e.t_approx = CGAL::to_double(s0);
    if (s1 > 0 && below_tmax(r, s0)) {
        e.hit = true;
        e.lo = maxx(s0, FT(0));
        e.hi = r.fin ? minx(s1, r.tmax) : s1;
    }
    return e;
}

// Slabs, for the box and the oriented box: in slab i the line's points are
// those with lo_i <= so_i + t sd_i <= hi_i.
struct SlabSet {
    FT t0[3], t1[3];
    int kind[3]; // 0 bounded [t0, t1]; 1 the whole line (sd = 0, inside); 2 empty
    bool face_lying = false;
};

static void slab(SlabSet &S, int i, const FT &lo, const FT &hi, const FT &so, const FT &sd)
{
    if (sd != 0) {
        FT a = (lo - so) / sd, b = (hi - so) / sd;
        if (sd < 0)
            std::swap(a, b);
        S.t0[i] = a;
        S.t1[i] = b;
        S.kind[i] = 0;
    } else if (so < lo || so > hi) {
        S.kind[i] = 2;
    } else {
        S.kind[i] = 1;
        if (so == lo || so == hi)
            S.face_lying = true;
    }
}

// The nearest hit of the closed solid's surface from the slabs.
static void slabs_resolve(Ex &e, const SlabSet &S, const XRay &r)
{
    bool has = false;
    FT tn, tf;
    int an = -1, af = -1;
    for (int i = 0; i < 3; i++) {
        if (S.kind[i] == 2)
            return;
        if (S.kind[i] == 1)
            continue;
        if (!has) {
            tn = S.t0[i];
            tf = S.t1[i];
            an = af = i;
            has = true;
            continue;
        }
        if (S.t0[i] > tn) {
            tn = S.t0[i];
            an = i;
        } else if (S.t0[i] == tn) {
            an = -1;
        }
        if (S.t1[i] < tf) {
            tf = S.t1[i];
            af = i;
        } else if (S.t1[i] == tf) {
            af = -1;
        }
    }
    if (!has || tn > tf)
        return; // a zero direction, or the line misses
    e.cand.push_back(tn);
    e.cand.push_back(tf);
    if (S.face_lying) {
        // The ray runs in a face: every t in [tn, tf] is a surface point.
        e.t_approx = CGAL::to_double(tn);
        if (tf > 0 && below_tmax(r, tn)) {
            e.hit = true;
            e.lo = maxx(tn, FT(0));
            e.hi = r.fin ? minx(tf, r.tmax) : tf;
        }
        return;
    }
    if (tn > 0) {
        e.t_approx = CGAL::to_double(tn);
        if (below_tmax(r, tn)) {
            e.hit = true;
            e.lo = e.hi = tn;
            e.face = an;
        }
    } else if (tf > 0) {
        e.t_approx = CGAL::to_double(tf);
        if (below_tmax(r, tf)) {
            e.hit = true;
            e.lo = e.hi = tf;
            e.face = af;
        }
    } else {
        e.t_approx = CGAL::to_double(tf);
    }
}

static SlabSet box_slabs(const Box &b, const XRay &r)
{
    SlabSet S;
    for (int i = 0; i < 3; i++)
        slab(S, i, F(comp(b.lo, i)), F(comp(b.hi, i)), r.o[i], r.d[i]);
    return S;
}

static Ex ex_box(const Box &b, const XRay &r)
{
    Ex e;
    e.kind = K_BOX;
    if (is_zero(xr_d(r))) {
        e.skip = true;
        return e;
    }
    for (int i = 0; i < 3; i++)
        if (!(comp(b.lo, i) <= comp(b.hi, i))) {
            e.skip = true;
            return e;
        }
    slabs_resolve(e, box_slabs(b, r), r);
    return e;
}

// The exact parallelepiped c + x u + y v + z w, |x|,|y|,|z| <= 1, from the
// float c, u, v, w (never from the rounded inverse): slab i holds the points
// with |N_i.(p - c)| <= |det|, N_i the cross product of the other two axes.
struct OBoxX {
    X3 c, N[3];
    FT h;
    bool ok;
};
static OBoxX obox_x(const OBox &b)
{
    OBoxX o;
    X3 ax[3] = {x3(b.u), x3(b.v), x3(b.w)};
    o.c = x3(b.c);
    for (int i = 0; i < 3; i++)
        o.N[i] = cross(ax[(i + 1) % 3], ax[(i + 2) % 3]);
    FT det = dot(ax[0], o.N[0]);
    o.ok = det != 0;
    o.h = fabsx(det);
    return o;
}

static SlabSet obox_slabs(const OBoxX &o, const XRay &r)
{
    SlabSet S;
    X3 oc = sub(xr_o(r), o.c), d = xr_d(r);
    for (int i = 0; i < 3; i++)
        slab(S, i, -o.h, o.h, dot(o.N[i], oc), dot(o.N[i], d));
    return S;
}

static Ex ex_obox(const OBox &b, const XRay &r)
{
    Ex e;
    e.kind = K_OBOX;
    OBoxX o = obox_x(b);
    if (!o.ok || is_zero(xr_d(r))) {
        e.skip = true;
        return e;
    }
    slabs_resolve(e, obox_slabs(o, r), r);
    return e;
}

static Ex exact_eval(const Prim &p, const XRay &r)
{
    switch (p.kind) {
    case PRIM_PN: /* PN patches are cases 9 and 10's alone (pn.cpp) */
        break;
    case PRIM_PLANE: return ex_plane(p.g.plane, r);
    case PRIM_SPHERE: return ex_sphere(p.g.sphere, r);
    case PRIM_TRIANGLE:
    case PRIM_SMOOTH_TRIANGLE: return ex_tri(p.g.tri, r);
    case PRIM_BOX: return ex_box(p.g.box, r);
    case PRIM_OBOX: return ex_obox(p.g.obox, r);
    case PRIM_ELLIPSOID: return ex_ell(*p.g.ell.e, r);
    }
    Ex e;
    e.skip = true;
    return e;
}

// =====================================================================
// The band tests (constants above).
// =====================================================================

static bool in_band_plane(const Ex &e)
{
    const FT k = Fd(BAND_PLANE_REL * BAND_PLANE_REL);
    return e.nd * e.nd <= k * e.nn * e.dd;
}

// |d|^2 (dist^2 - r^2) = -disc, so the test is |disc| <= rel A (|f| r + r^2),
// squared where |f| r needs a root.
static bool in_band_sphere(const Ex &e)
{
    if (e.kind != K_SPHERE)
        return false;
    FT y = fabsx(e.disc) / (Fd(BAND_SPHERE_REL) * e.A) - e.r2;
    return y <= 0 || y * y <= e.f2 * e.r2;
}

static bool in_band_ell(const Prim &p, const Ex &e, const XRay &r)
{
    if (e.kind != K_ELL || p.kind != PRIM_ELLIPSOID)
        return false;
    const double *a = p.g.ell.e->a;
    {
        // A filter in double, which builds no exact numbers: from the
        // intervals of disc, A and Bh, an upper bound on S (|t_v| <= |Bh| /
        // A) and a lower one on |disc|; most rays are far outside the band.
        std::pair<double, double> di = CGAL::to_interval(e.disc), ai = CGAL::to_interval(e.A),
                                  bi = CGAL::to_interval(e.Bh);
        double dlo = di.first > 0 ? di.first : di.second < 0 ? -di.second : 0.0;
        double tvm = std::max(std::fabs(bi.first), std::fabs(bi.second)) / ai.first, su = 0.0;
        for (int i = 0; i < 3; i++) {
            double si = std::fabs(a[9 + i]);
            for (int j = 0; j < 3; j++)
                si += std::fabs(a[3 * i + j]) * (std::fabs(CGAL::to_double(r.o[j])) + tvm * std::fabs(CGAL::to_double(r.d[j])));
            su = std::max(su, si);
        }
        double lim = BAND_ELL_REL * ai.second * (su + 1.0) * (1.0 + 0x1p-40);
        if (ai.first > 0 && std::isfinite(lim) && dlo > lim)
            return false;
    }
    FT tv = -e.Bh / e.A, S = 0;
    for (int i = 0; i < 3; i++) {
        FT s = fabsx(Fd(a[9 + i]));
        for (int j = 0; j < 3; j++)
            s += fabsx(Fd(a[3 * i + j])) * (fabsx(r.o[j]) + fabsx(tv * r.d[j]));
        S = maxx(S, s);
    }
    return fabsx(e.disc) <= Fd(BAND_ELL_REL) * e.A * (S + 1);
}

static bool in_band_triangle(const Ex &e)
{
    const FT k = Fd(BAND_TRI_REL);
    for (int i = 0; i < 3; i++)
        if (fabsx(e.E[i]) <= k * e.M[i])
            return true;
    return false;
}

// A hit of the slabs widened by rel * max(|t0|, |t1|) each; false hits there
// are allowed.
static bool in_band_slabs(const SlabSet &S, const XRay &r, double rel)
{
    bool has = false;
    FT tn, tf, k = Fd(rel);
    for (int i = 0; i < 3; i++) {
        if (S.kind[i] == 2)
            return false;
        if (S.kind[i] == 1)
            continue;
        FT m = k * maxx(fabsx(S.t0[i]), fabsx(S.t1[i]));
        FT a = S.t0[i] - m, b = S.t1[i] + m;
        if (!has) {
            tn = a;
            tf = b;
            has = true;
        } else {
            tn = maxx(tn, a);
            tf = minx(tf, b);
        }
    }
    return has && tn <= tf && tf > 0 && below_tmax(r, tn);
}

static bool in_band_box(const Prim &p, const XRay &r)
{
    if (p.kind == PRIM_BOX)
        return in_band_slabs(box_slabs(p.g.box, r), r, BAND_BOX_REL);
    OBoxX o = obox_x(p.g.obox);
    return in_band_slabs(obox_slabs(o, r), r, BAND_OBOX_REL);
}

// The routine's own band for its kind (sphere tangent, plane parallel,
// triangle edges; boxes: widened slabs, for false hits only).
static bool in_band_kind(const Prim &p, const Ex &e, const XRay &r, bool false_hit)
{
    switch (e.kind) {
    case K_PN: /* PN patches are cases 9 and 10's alone (pn.cpp) */
        break;
    case K_PLANE: return in_band_plane(e);
    case K_SPHERE: return in_band_sphere(e);
    case K_ELL: return in_band_ell(p, e, r);
    case K_TRI: return in_band_triangle(e);
    case K_BOX:
    case K_OBOX: return false_hit && in_band_box(p, r);
    }
    return false;
}

// The problem's t scale: |t| + max|coordinate| / max|d_i|.
static double t_scale(const Prim &p, const Ray &r, const Ex &e)
{
    double dm = vec_max_abs(r.d), m = vec_max_abs(r.o);
    switch (p.kind) {
    case PRIM_PN: /* PN patches are cases 9 and 10's alone (pn.cpp) */
        break;
    case PRIM_PLANE: {
        double nm = vec_max_abs(p.g.plane.n);
        if (nm > 0)
            m = std::max(m, std::fabs((double)p.g.plane.d) / nm);
        break;
    }
    case PRIM_SPHERE: m = std::max(m, (double)vec_max_abs(p.g.sphere.c) + std::fabs(p.g.sphere.r)); break;
    case PRIM_TRIANGLE:
    case PRIM_SMOOTH_TRIANGLE:
        m = std::max({m, (double)vec_max_abs(p.g.tri.a), (double)vec_max_abs(p.g.tri.b), (double)vec_max_abs(p.g.tri.c)});
        break;
    case PRIM_BOX: m = std::max({m, (double)vec_max_abs(p.g.box.lo), (double)vec_max_abs(p.g.box.hi)}); break;
    case PRIM_ELLIPSOID: {
        const double *M = p.g.ell.e->m;
        double c = 0.0, ax = 0.0;
        for (int i = 0; i < 3; i++) {
            c = std::max(c, std::fabs(M[9 + i]));
            ax = std::max(ax, std::fabs(M[3 * i]) + std::fabs(M[3 * i + 1]) + std::fabs(M[3 * i + 2]));
        }
        m = std::max(m, c + ax);
        break;
    }
    case PRIM_OBOX:
        m = std::max(m, (double)vec_max_abs(p.g.obox.c) + vec_max_abs(p.g.obox.u) + vec_max_abs(p.g.obox.v) +
                            vec_max_abs(p.g.obox.w));
        break;
    }
    return std::fabs(e.t_approx) + (dm > 0 ? m / dm : 0.0);
}

// Every band includes "t_exact within terr of 0 or of tmax". A false hit
// carries the routine's terr: the band holds when the reported t lies within
// terr of a place where the line meets the surface that is itself within terr
// of 0 or tmax.
static bool band_edges_hit(const Ex &e, const XRay &r, float t, float terr)
{
    if (!(terr >= 0.0f) || !std::isfinite(t))
        return false;
    FT T = F(t), R = F(terr);
    if (is_quad(e.kind)) {
        if (e.disc < 0)
            return false;
        for (int k = 1; k <= 2; k++) {
            if (!(cmp_root(e, k, T - R) >= 0 && cmp_root(e, k, T + R) <= 0))
                continue;
            if (cmp_root(e, k, R) <= 0 && cmp_root(e, k, -R) >= 0)
                return true;
            if (r.fin && cmp_root(e, k, r.tmax - R) >= 0 && cmp_root(e, k, r.tmax + R) <= 0)
                return true;
        }
        return false;
    }
    for (const FT &c : e.cand) {
        if (fabsx(T - c) > R)
            continue;
        if (fabsx(c) <= R || (r.fin && fabsx(c - r.tmax) <= R))
            return true;
    }
    return false;
}

// A false miss: the exact nearest hit within the judge's terr estimate of 0
// or tmax, or beyond FLT_MAX (no float t can report it).
static bool band_edges_miss(const Ex &e, const XRay &r, double terr_est)
{
    FT R = Fd(terr_est), big = Fd(FLT_MAX);
    if (is_quad(e.kind)) {
        int k = e.root;
        return cmp_root(e, k, R) <= 0 || (r.fin && cmp_root(e, k, r.tmax - R) >= 0) || cmp_root(e, k, big) >= 0;
    }
    return e.lo <= R || (r.fin && e.hi >= r.tmax - R) || e.lo >= big;
}

// =====================================================================
// t: the bound check (exact) and the ulp statistics.
// =====================================================================

static bool t_bound_ok(const Ex &e, float t, float terr)
{
    if (!std::isfinite(t) || !(terr >= 0.0f) || std::isnan(terr))
        return false;
    FT T = F(t);
    if (std::isinf(terr))
        return true;
    FT R = F(terr);
    if (is_quad(e.kind))
        return cmp_root(e, e.root, T - R) >= 0 && cmp_root(e, e.root, T + R) <= 0;
    return T >= e.lo - R && (e.hi_inf || T <= e.hi + R);
}

// x 2^-e as a double (mpfr_get_d after an exact exponent shift).
static double mpfr_get_d_2exp_scaled(mpfr_srcptr x, long e)
{
    mpfr_t y;
    mpfr_init2(y, mpfr_get_prec(x));
    mpfr_mul_2si(y, x, -e, MPFR_RNDN);
    double r = mpfr_get_d(y, MPFR_RNDN);
    mpfr_clear(y);
    return r;
}

static double ulpf_of(double x)
{
    float f = (float)std::fabs(x);
    if (!(f < INFINITY))
        return std::ldexp(1.0, 104);
    if (f < FLT_MIN)
        return std::ldexp(1.0, -149);
    int ex;
    std::frexp((double)f, &ex);
    return std::ldexp(1.0, ex - 24);
}


// The roots x1 <= x2 of A x^2 + 2 B x + C = 0 from its discriminant disc =
// B^2 - AC (negative taken as 0; clobbered, and may be q itself), the
// stable way: q = -(B + sign(B) sqrt(disc)), then q / A and C / q.
static void mp_stable_roots(mpfr_t A, mpfr_t B, mpfr_t C, mpfr_t disc, mpfr_t q, mpfr_t x1, mpfr_t x2)
{
    if (mpfr_sgn(disc) < 0)
        mpfr_set_zero(disc, 1);
    mpfr_sqrt(disc, disc, MPFR_RNDN);
    if (mpfr_sgn(B) >= 0)
        mpfr_add(q, B, disc, MPFR_RNDN);
    else
        mpfr_sub(q, B, disc, MPFR_RNDN);
    mpfr_neg(q, q, MPFR_RNDN);
    mpfr_div(x1, q, A, MPFR_RNDN);
    if (mpfr_sgn(q) != 0)
        mpfr_div(x2, C, q, MPFR_RNDN);
    else
        mpfr_set(x2, x1, MPFR_RNDN);
    if (mpfr_cmp(x1, x2) > 0)
        mpfr_swap(x1, x2);
}

// The sphere's root in MPFR from the exact dyadic coefficients: 2400 bits
// hold every product of the float inputs exactly; only the square root and
// one division round, at 2^-2400.
static double sphere_ulp(const Sphere &s, const Ray &r, int k, float t)
{
    const mpfr_prec_t P = 2400;
    mpfr_t A, B, C, f, tmp, D, q, x1, x2, tt;
    mpfr_inits2(P, A, B, C, f, tmp, D, q, x1, x2, tt, (mpfr_ptr)0);
    mpfr_set_zero(A, 1);
    mpfr_set_zero(B, 1);
    mpfr_set_zero(C, 1);
    for (int i = 0; i < 3; i++) {
        mpfr_set_d(f, comp(r.o, i), MPFR_RNDN);
        mpfr_sub_d(f, f, comp(s.c, i), MPFR_RNDN);
        double di = comp(r.d, i);
        mpfr_set_d(tmp, di, MPFR_RNDN);
        mpfr_mul_d(tmp, tmp, di, MPFR_RNDN);
        mpfr_add(A, A, tmp, MPFR_RNDN);
        mpfr_mul_d(tmp, f, di, MPFR_RNDN);
        mpfr_add(B, B, tmp, MPFR_RNDN);
        mpfr_mul(tmp, f, f, MPFR_RNDN);
        mpfr_add(C, C, tmp, MPFR_RNDN);
    }
    mpfr_set_d(tmp, s.r, MPFR_RNDN);
    mpfr_mul_d(tmp, tmp, s.r, MPFR_RNDN);
    mpfr_sub(C, C, tmp, MPFR_RNDN);
    mpfr_mul(D, B, B, MPFR_RNDN);
    mpfr_mul(tmp, A, C, MPFR_RNDN);
    mpfr_sub(D, D, tmp, MPFR_RNDN);
    mp_stable_roots(A, B, C, D, q, x1, x2);
    mpfr_ptr root = k == 1 ? x1 : x2;
    double base = mpfr_get_d(root, MPFR_RNDN);
    mpfr_set_d(tt, t, MPFR_RNDN);
    mpfr_sub(tt, tt, root, MPFR_RNDN);
    double diff = std::fabs(mpfr_get_d(tt, MPFR_RNDN));
    mpfr_clears(A, B, C, f, tmp, D, q, x1, x2, tt, (mpfr_ptr)0);
    return diff / ulpf_of(base);
}

// The ellipsoid's root k likewise: f = A o + b and D = A d from the doubles
// a[] and the float ray, then the quadratic's coefficients, every step
// checked exact (MPFR's inexact flag; the precision doubles until it is),
// so that only the square root and the last division round. use(root, P)
// is called once, with the root at precision P.
template <class Use> static void ell_root_mp(const Ellipsoid &E, const Ray &r, int k, Use use)
{
    for (mpfr_prec_t P = 640;; P *= 2) {
        mpfr_t f[3], D[3], A, B, C, tmp, q, x1, x2;
        for (int i = 0; i < 3; i++)
            mpfr_inits2(P, f[i], D[i], (mpfr_ptr)0);
        mpfr_inits2(P, A, B, C, tmp, q, x1, x2, (mpfr_ptr)0);
        mpfr_clear_inexflag();
        for (int i = 0; i < 3; i++) {
            mpfr_set_d(f[i], E.a[9 + i], MPFR_RNDN);
            mpfr_set_zero(D[i], 1);
            for (int j = 0; j < 3; j++) {
                mpfr_set_d(tmp, E.a[3 * i + j], MPFR_RNDN);
                mpfr_mul_d(tmp, tmp, comp(r.o, j), MPFR_RNDN);
                mpfr_add(f[i], f[i], tmp, MPFR_RNDN);
                mpfr_set_d(tmp, E.a[3 * i + j], MPFR_RNDN);
                mpfr_mul_d(tmp, tmp, comp(r.d, j), MPFR_RNDN);
                mpfr_add(D[i], D[i], tmp, MPFR_RNDN);
            }
        }
        mpfr_set_zero(A, 1);
        mpfr_set_zero(B, 1);
        mpfr_set_si(C, -1, MPFR_RNDN);
        for (int i = 0; i < 3; i++) {
            mpfr_mul(tmp, D[i], D[i], MPFR_RNDN);
            mpfr_add(A, A, tmp, MPFR_RNDN);
            mpfr_mul(tmp, D[i], f[i], MPFR_RNDN);
            mpfr_add(B, B, tmp, MPFR_RNDN);
            mpfr_mul(tmp, f[i], f[i], MPFR_RNDN);
            mpfr_add(C, C, tmp, MPFR_RNDN);
        }
        mpfr_mul(q, B, B, MPFR_RNDN);
        mpfr_mul(tmp, A, C, MPFR_RNDN);
        mpfr_sub(q, q, tmp, MPFR_RNDN); // the discriminant
        bool done = !mpfr_inexflag_p() || P >= 40000;
        if (done) {
            mp_stable_roots(A, B, C, q, q, x1, x2);
            use(k == 1 ? x1 : x2, P);
        }
        for (int i = 0; i < 3; i++)
            mpfr_clears(f[i], D[i], (mpfr_ptr)0);
        mpfr_clears(A, B, C, tmp, q, x1, x2, (mpfr_ptr)0);
        if (done)
            return;
    }
}

static double ell_ulp(const Ellipsoid &E, const Ray &r, int k, float t)
{
    double out = NAN;
    ell_root_mp(E, r, k, [&](mpfr_ptr root, mpfr_prec_t P) {
        mpfr_t tt;
        mpfr_init2(tt, P);
        double base = mpfr_get_d(root, MPFR_RNDN);
        mpfr_set_d(tt, t, MPFR_RNDN);
        mpfr_sub(tt, tt, root, MPFR_RNDN);
        out = std::fabs(mpfr_get_d(tt, MPFR_RNDN)) / ulpf_of(base);
        mpfr_clear(tt);
    });
    return out;
}

// The outward normal A^T (A x + b) at the exact hit point x = o + t d (t
// the exact root k), unit length, in double: from the root in MPFR at 640
// bits or more, so it is the exact normal's direction to far below double
// precision for every ellipsoid case 11 builds, however thin.
static void ell_hit_normal(const Ellipsoid &E, const Ray &r, int k, double n[3])
{
    ell_root_mp(E, r, k, [&](mpfr_ptr root, mpfr_prec_t P) {
        mpfr_t x[3], u[3], nn[3], tmp;
        for (int i = 0; i < 3; i++)
            mpfr_inits2(P, x[i], u[i], nn[i], (mpfr_ptr)0);
        mpfr_init2(tmp, P);
        for (int j = 0; j < 3; j++) {
            mpfr_mul_d(x[j], root, comp(r.d, j), MPFR_RNDN);
            mpfr_add_d(x[j], x[j], comp(r.o, j), MPFR_RNDN);
        }
        for (int i = 0; i < 3; i++) {
            mpfr_set_d(u[i], E.a[9 + i], MPFR_RNDN);
            for (int j = 0; j < 3; j++) {
                mpfr_mul_d(tmp, x[j], E.a[3 * i + j], MPFR_RNDN);
                mpfr_add(u[i], u[i], tmp, MPFR_RNDN);
            }
        }
        for (int j = 0; j < 3; j++) {
            mpfr_set_zero(nn[j], 1);
            for (int i = 0; i < 3; i++) {
                mpfr_mul_d(tmp, u[i], E.a[3 * i + j], MPFR_RNDN);
                mpfr_add(nn[j], nn[j], tmp, MPFR_RNDN);
            }
        }
        // scale before converting: the normal's length may be outside double's range
        long emax = LONG_MIN;
        for (int j = 0; j < 3; j++)
            if (mpfr_sgn(nn[j]) != 0)
                emax = std::max(emax, (long)mpfr_get_exp(nn[j]));
        double l = 0.0;
        for (int j = 0; j < 3; j++) {
            n[j] = emax == LONG_MIN ? 0.0 : mpfr_get_d_2exp_scaled(nn[j], emax);
            l += n[j] * n[j];
        }
        l = std::sqrt(l);
        for (int j = 0; j < 3; j++)
            n[j] = l > 0 ? n[j] / l : 0.0;
        for (int i = 0; i < 3; i++)
            mpfr_clears(x[i], u[i], nn[i], (mpfr_ptr)0);
        mpfr_clear(tmp);
    });
}

static double t_ulp(const Ex &e, const Prim &p, const Ray &r, float t)
{
    if (!std::isfinite(t))
        return INFINITY;
    if (e.kind == K_SPHERE)
        return sphere_ulp(p.g.sphere, r, e.root, t);
    if (e.kind == K_ELL)
        return ell_ulp(*p.g.ell.e, r, e.root, t);
    FT T = F(t);
    double diff = 0.0, base = t;
    if (T < e.lo) {
        diff = CGAL::to_double(e.lo - T);
        base = CGAL::to_double(e.lo);
    } else if (!e.hi_inf && T > e.hi) {
        diff = CGAL::to_double(T - e.hi);
        base = CGAL::to_double(e.hi);
    }
    return diff / ulpf_of(base);
}

// =====================================================================
// Formatting (hex floats are the exact bits).
// =====================================================================

std::string fmt_prim(const Prim &p)
{
    switch (p.kind) {
    case PRIM_PN: /* PN patches are cases 9 and 10's alone (pn.cpp) */
        break;
    case PRIM_PLANE: return "plane n=" + hv(p.g.plane.n) + " d=" + hexf(p.g.plane.d);
    case PRIM_SPHERE: return "sphere c=" + hv(p.g.sphere.c) + " r=" + hexf(p.g.sphere.r);
    case PRIM_TRIANGLE:
    case PRIM_SMOOTH_TRIANGLE: return "triangle a=" + hv(p.g.tri.a) + " b=" + hv(p.g.tri.b) + " c=" + hv(p.g.tri.c);
    case PRIM_BOX: return "box lo=" + hv(p.g.box.lo) + " hi=" + hv(p.g.box.hi);
    case PRIM_OBOX:
        return "obox c=" + hv(p.g.obox.c) + " u=" + hv(p.g.obox.u) + " v=" + hv(p.g.obox.v) + " w=" + hv(p.g.obox.w);
    case PRIM_ELLIPSOID: {
        // m as given to prim_ellipsoid_init, then a as it stored it (the
        // exact primitive); --check takes both back.
        std::string s = "ellipsoid m=(";
        for (int k = 0; k < 12; k++)
            s += (k ? "," : "") + hexd(p.g.ell.e->m[k]);
        s += ") a=(";
        for (int k = 0; k < 12; k++)
            s += (k ? "," : "") + hexd(p.g.ell.e->a[k]);
        return s + ")";
    }
    }
    return "?";
}

std::string fmt_ray(const Ray &r) { return "ray o=" + hv(r.o) + " d=" + hv(r.d) + " tmax=" + hexf(r.tmax); }

static std::string fmt_hit(int got, const PrimHit &h)
{
    if (!got)
        return "computed miss";
    return strf("computed hit t=%s (%.9g) terr=%s (%.3g) face=%d", hexf(h.t).c_str(), (double)h.t, hexf(h.terr).c_str(),
                (double)h.terr, h.face);
}

static std::string fmt_exact(const Ex &e)
{
    if (e.skip)
        return "exact: skipped (degenerate)";
    if (!e.hit) {
        std::string s = "exact miss";
        if (is_quad(e.kind) && e.disc >= 0)
            s += strf(" (line roots near %.9g, disc %s 0)", e.t_approx, e.disc == 0 ? "==" : ">");
        else if (!e.cand.empty())
            s += strf(" (line meets surface at t~%.9g)", CGAL::to_double(e.cand[0]));
        else
            s += " (line misses)";
        return s;
    }
    if (is_quad(e.kind))
        return strf("exact hit root %d t~%.17g (disc %s 0)", e.root, e.t_approx, e.disc == 0 ? "==" : ">");
    if (e.hi_inf || e.lo != e.hi)
        return strf("exact hit, any t in [%.17g, %s] (ray in a face/plane)", CGAL::to_double(e.lo),
                    e.hi_inf ? "inf" : strf("%.17g", CGAL::to_double(e.hi)).c_str());
    return strf("exact hit t~%.17g", CGAL::to_double(e.lo));
}

// =====================================================================
// Stats.
// =====================================================================

void Stats::fail(uint64_t ray, const std::string &kind, const std::string &text)
{
    int same = 0;
    for (const Fail &f : fails)
        same += f.kind == kind;
    if (same < 6)
        fails.push_back(Fail{ray, kind, text});

}

bool Stats::wants(const std::string &kind) const
{
    int same = 0;
    for (const Fail &f : fails)
        same += f.kind == kind;
    return same < 6;
}

void Stats::merge(const Stats &o)
{
    for (int i = 0; i < N_CNT; i++)
        c[i] += o.c[i];
    ulp.insert(ulp.end(), o.ulp.begin(), o.ulp.end());
    fails.insert(fails.end(), o.fails.begin(), o.fails.end());
}

template <class T> static void put(std::string &s, const T &v) { s.append((const char *)&v, sizeof v); }
template <class T> static T get(const std::string &s, size_t &at)
{
    T v;
    std::memcpy(&v, s.data() + at, sizeof v);
    at += sizeof v;
    return v;
}

std::string Stats::serialize() const
{
    std::string s;
    for (int i = 0; i < N_CNT; i++)
        put(s, c[i]);
    put(s, (uint64_t)ulp.size());
    s.append((const char *)ulp.data(), ulp.size() * sizeof(double));
    put(s, (uint64_t)fails.size());
    for (const Fail &f : fails) {
        put(s, f.ray);
        put(s, (uint64_t)f.kind.size());
        s += f.kind;
        put(s, (uint64_t)f.text.size());
        s += f.text;
    }
    return s;
}

Stats Stats::deserialize(const std::string &s)
{
    Stats st;
    size_t at = 0;
    for (int i = 0; i < N_CNT; i++)
        st.c[i] = get<uint64_t>(s, at);
    uint64_t n = get<uint64_t>(s, at);
    st.ulp.resize(n);
    std::memcpy(st.ulp.data(), s.data() + at, n * sizeof(double));
    at += n * sizeof(double);
    n = get<uint64_t>(s, at);
    for (uint64_t i = 0; i < n; i++) {
        Fail f;
        f.ray = get<uint64_t>(s, at);
        uint64_t m = get<uint64_t>(s, at);
        f.kind = s.substr(at, m);
        at += m;
        m = get<uint64_t>(s, at);
        f.text = s.substr(at, m);
        at += m;
        st.fails.push_back(f);
    }
    return st;
}

// =====================================================================
// One routine, one ray.
// =====================================================================

// Counts one verdict disagreement: inside or outside the band.
static bool disagreement_in_band(int rid, const Prim &p, const Ray &r, const XRay &xr, const Ex &ex, int got,
                                 const PrimHit &h, bool nb)
{
    const Routine &R = ROUTINES[rid];
    bool kind_band_any = R.kind == K_SPHERE || R.kind == K_PLANE || R.kind == K_TRI || R.kind == K_ELL;
    if (nb || (!kind_band_any && in_band_kind(p, ex, xr, got != 0)))
        return true;
    if (got) {
        float terr = h.terr;
        if (!R.robust || !(terr >= 0.0f))
            terr = std::max(0.0f, (float)(BAND_T_EDGE_REL * t_scale(p, r, ex)));
        return band_edges_hit(ex, xr, h.t, terr);
    }
    return band_edges_miss(ex, xr, BAND_T_EDGE_REL * t_scale(p, r, ex));
}

static std::string describe(int rid, const Prim &p, const Ray &r, const Ex &ex, int got, const PrimHit &h)
{
    return std::string(ROUTINES[rid].name) + " " + fmt_prim(p) + " " + fmt_ray(r) + " | " + fmt_exact(ex) + " | " +
           fmt_hit(got, h);
}

// |d|^2 outside [1/4, 4]: the renderer only makes unit directions.
static bool nonunit(const Ray &r)
{
    double l2 = (double)r.d.x * r.d.x + (double)r.d.y * r.d.y + (double)r.d.z * r.d.z;
    return !(l2 >= 0.25 && l2 <= 4.0);
}

// Failure kinds carry "/nonunit-d" when the ray's direction is far from unit.
static std::string fk(const char *kind, const Ray &r) { return std::string(kind) + (nonunit(r) ? "/nonunit-d" : ""); }

static void fresh_hit(PrimHit &h)
{
    std::memset(&h, 0, sizeof h);
    h.t = NAN;
    h.terr = NAN;
    h.face = -1;
}

// A second opinion from CGAL's own filtered predicates, where their
// semantics coincide with the contract's: an infinite ray (t >= 0 against
// 0 < t) whose origin is not on the surface. The oriented box has no CGAL
// type. Returns false on a disagreement.
static bool cgal_agrees(const Prim &p, const Ray &r, const Ex &e)
{
    if (std::isfinite(r.tmax) || e.skip)
        return true;
    for (const FT &c : e.cand)
        if (c == 0)
            return true;
    K::Ray_3 R(P3(F(r.o.x), F(r.o.y), F(r.o.z)), V3(F(r.d.x), F(r.d.y), F(r.d.z)));
    switch (p.kind) {
    case PRIM_PLANE: {
        if (e.nd == 0)
            return true;
        K::Plane_3 pl(F(p.g.plane.n.x), F(p.g.plane.n.y), F(p.g.plane.n.z), -F(p.g.plane.d));
        return CGAL::do_intersect(R, pl) == e.hit;
    }
    case PRIM_TRIANGLE:
    case PRIM_SMOOTH_TRIANGLE: {
        if (e.nd == 0)
            return true;
        const Triangle &t = p.g.tri;
        K::Triangle_3 T(P3(F(t.a.x), F(t.a.y), F(t.a.z)), P3(F(t.b.x), F(t.b.y), F(t.b.z)),
                        P3(F(t.c.x), F(t.c.y), F(t.c.z)));
        return CGAL::do_intersect(R, T) == e.hit;
    }
    case PRIM_SPHERE: {
        if (e.C == 0)
            return true;
        K::Sphere_3 S(P3(F(p.g.sphere.c.x), F(p.g.sphere.c.y), F(p.g.sphere.c.z)), e.r2);
        return CGAL::do_intersect(R, S) == e.hit;
    }
    case PRIM_BOX: {
        K::Iso_cuboid_3 B(P3(F(p.g.box.lo.x), F(p.g.box.lo.y), F(p.g.box.lo.z)),
                          P3(F(p.g.box.hi.x), F(p.g.box.hi.y), F(p.g.box.hi.z)));
        return CGAL::do_intersect(R, B) == e.hit;
    }
    default: return true;
    }
}

Verdict judge_single(int rid, const Prim &p, const Ray &r, Stats &st, uint64_t ray, bool verbose)
{
    Verdict v;
    const Routine &R = ROUTINES[rid];
    fresh_hit(v.h);
    v.got = call_routine(rid, p, r, v.h) != 0;
    XRay xr = xray_of(r);
    Ex ex = exact_eval(p, xr);
    if (verbose)
        std::printf("  %s\n  %s\n  %s: %s\n  %s\n", fmt_prim(p).c_str(), fmt_ray(r).c_str(), R.name,
                    fmt_hit(v.got, v.h).c_str(), fmt_exact(ex).c_str());
    if (ex.skip) {
        st.c[C_SKIP]++;
        return v;
    }
    v.ex_hit = ex.hit;
    v.t_exact = ex.t_approx;
    st.c[C_RAYS]++;
    if ((ray % 8 == 0 || verbose) && !cgal_agrees(p, r, ex)) {
        st.c[C_INTERNAL]++;
        st.fail(ray, "internal", "CGAL do_intersect disagrees with the judge's exact verdict: " + fmt_prim(p) + " " +
                                     fmt_ray(r) + " | " + fmt_exact(ex));
    }
    bool nb = (R.kind == K_SPHERE || R.kind == K_PLANE || R.kind == K_TRI || R.kind == K_ELL) &&
              in_band_kind(p, ex, xr, false);
    if (nb)
        st.c[C_NEARBAND]++;
    if (v.got && ex.hit) {
        v.code = 1;
        st.c[C_AGREE]++;
        st.ulp.push_back(t_ulp(ex, p, r, v.h.t));
        if (R.robust && !t_bound_ok(ex, v.h.t, v.h.terr)) {
            st.c[C_TBFAIL]++;
            st.fail(ray, fk("t_bound", r), describe(rid, p, r, ex, v.got, v.h) + strf(" | t_ulp=%.3g", st.ulp.back()));
            if (verbose)
                std::printf("  T-BOUND VIOLATION (t_ulp %.3g)\n", st.ulp.back());
        }
    } else if (!v.got && !ex.hit) {
        v.code = 0;
        st.c[C_AGREE]++;
    } else {
        bool fh = v.got;
        v.code = fh ? 2 : 3;
        st.c[fh ? C_FHIT : C_FMISS]++;
        bool band = disagreement_in_band(rid, p, r, xr, ex, v.got, v.h, nb);
        st.c[band ? C_BAND : C_OUTBAND]++;
        if (band)
            st.c[fh ? C_FHIT_BAND : C_FMISS_BAND]++;
        if (!band && nonunit(r))
            st.c[C_OB_NONUNIT]++;
        // (the text only while fail() keeps it: formatting is not free)
        if (!band && st.wants(fk(fh ? "false_hit" : "false_miss", r)))
            st.fail(ray, fk(fh ? "false_hit" : "false_miss", r), describe(rid, p, r, ex, v.got, v.h));
        else if (band && !fh && st.wants("false_miss_in_band"))
            st.fail(ray, "false_miss_in_band", describe(rid, p, r, ex, v.got, v.h));
        if (verbose)
            std::printf("  %s %s band\n", fh ? "FALSE HIT" : "FALSE MISS", band ? "inside" : "OUTSIDE");
    }
    return v;
}

bool exact_hit(const Prim &p, const Ray &r)
{
    Ex e = exact_eval(p, xray_of(r));
    return !e.skip && e.hit;
}

int ell_disc_sign(const Prim &p, const Ray &r)
{
    if (p.kind != PRIM_ELLIPSOID)
        return 2;
    Ex e = ex_ell(*p.g.ell.e, xray_of(r));
    return e.skip ? 2 : CGAL::sign(e.disc);
}

// =====================================================================
// Case 8: spawned origins.
// =====================================================================

static std::string sv3(Vec3 v) { return strf("(%.9g,%.9g,%.9g)", v.x, v.y, v.z); }

// Which side of the solid's surface q lies on, exactly: +1 outside the
// closed solid, -1 inside the open solid, 0 on the surface.
static int solid_side(const Prim &p, const X3 &Q)
{
    switch (p.kind) {
    case PRIM_SPHERE: {
        X3 f = sub(Q, x3(p.g.sphere.c));
        return CGAL::sign(dot(f, f) - F(p.g.sphere.r) * F(p.g.sphere.r));
    }
    case PRIM_BOX: {
        bool out = false, in = true;
        for (int i = 0; i < 3; i++) {
            FT lo = F(comp(p.g.box.lo, i)), hi = F(comp(p.g.box.hi, i));
            out = out || Q.v[i] < lo || Q.v[i] > hi;
            in = in && Q.v[i] > lo && Q.v[i] < hi;
        }
        return out ? 1 : in ? -1 : 0;
    }
    case PRIM_OBOX: {
        OBoxX o = obox_x(p.g.obox);
        X3 qc = sub(Q, o.c);
        bool out = false, in = true;
        for (int i = 0; i < 3; i++) {
            FT a = fabsx(dot(o.N[i], qc));
            out = out || a > o.h;
            in = in && a < o.h;
        }
        return out ? 1 : in ? -1 : 0;
    }
    case PRIM_ELLIPSOID: {
        const double *a = p.g.ell.e->a;
        FT g = -1;
        for (int i = 0; i < 3; i++) {
            FT x = Fd(a[9 + i]);
            for (int j = 0; j < 3; j++)
                x += Fd(a[3 * i + j]) * Q.v[j];
            g += x * x;
        }
        return CGAL::sign(g);
    }
    default: return 0;
    }
}

static double ulp_of(double x)
{
    int e;
    std::frexp(std::fabs((float)x), &e);
    return std::ldexp(1.0, std::max(e - 24, -149));
}

// A solid whose interior holds floats a good way from its surface: its
// thinnest extent is at least 2^12 ulps of its coordinates. (A box one ulp
// thick has no float strictly inside: a spawn into it cannot succeed.)
bool solid_resolved(const Prim &p)
{
    const double k = 4096.0;
    switch (p.kind) {
    case PRIM_SPHERE: return p.g.sphere.r >= k * ulp_of(vec_max_abs(p.g.sphere.c) + p.g.sphere.r);
    case PRIM_BOX: {
        double m = std::max(vec_max_abs(p.g.box.lo), vec_max_abs(p.g.box.hi)), th = INFINITY;
        for (int i = 0; i < 3; i++)
            th = std::min(th, (double)comp(p.g.box.hi, i) - comp(p.g.box.lo, i));
        return th >= k * ulp_of(m);
    }
    case PRIM_OBOX: {
        const OBox &b = p.g.obox;
        const Vec3 ax[3] = {b.u, b.v, b.w};
        auto crossd = [](Vec3 x, Vec3 y, double out[3]) {
            out[0] = (double)x.y * y.z - (double)x.z * y.y;
            out[1] = (double)x.z * y.x - (double)x.x * y.z;
            out[2] = (double)x.x * y.y - (double)x.y * y.x;
        };
        double n0[3];
        crossd(ax[1], ax[2], n0);
        double det = std::fabs(ax[0].x * n0[0] + ax[0].y * n0[1] + ax[0].z * n0[2]), th = INFINITY;
        for (int i = 0; i < 3; i++) {
            double n[3];
            crossd(ax[(i + 1) % 3], ax[(i + 2) % 3], n);
            th = std::min(th, det / std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]));
        }
        double m = vec_max_abs(b.c) + vec_max_abs(b.u) + vec_max_abs(b.v) + vec_max_abs(b.w);
        return th >= k * ulp_of(m);
    }
    case PRIM_ELLIPSOID: {
        // Semi-axes: the smallest is at least 1 / |A|_F, the largest at most
        // |M|_F; the smallest radius of curvature b^2 / a at least their
        // quotient (m is A^-1 to double precision: the margin is ample).
        const Ellipsoid &E = *p.g.ell.e;
        double fa = 0.0, fm = 0.0, c = 0.0, ax = 0.0;
        for (int i = 0; i < 9; i++) {
            fa += E.a[i] * E.a[i];
            fm += E.m[i] * E.m[i];
        }
        for (int i = 0; i < 3; i++) {
            c = std::max(c, std::fabs(E.m[9 + i]));
            ax = std::max(ax, std::fabs(E.m[3 * i]) + std::fabs(E.m[3 * i + 1]) + std::fabs(E.m[3 * i + 2]));
        }
        double rc = 1.0 / (fa * std::sqrt(fm) * (1.0 + 1e-6));
        return std::isfinite(rc) && rc >= k * ulp_of(c + ax);
    }
    default: return false;
    }
}

void spawn_check(int rid, const Prim &p, const Ray &r, const PrimHit &h, bool back, Vec3 w, double L, Stats &st,
                 uint64_t ray, bool verbose)
{
    PrimVariant var = ROUTINES[rid].robust ? PRIM_ROBUST : PRIM_CLASSIC;
    bool solid = p.kind == PRIM_SPHERE || p.kind == PRIM_BOX || p.kind == PRIM_OBOX || p.kind == PRIM_ELLIPSOID;
    int oside = solid ? solid_side(p, xr_o(xray_of(r))) : 0;
    if (solid && oside == 0)
        return; // the incoming ray starts on the surface: no side to keep
    if (oside < 0 && !solid_resolved(p))
        return; // too thin to hold a float strictly inside, away from the surface
    Surface s;
    std::memset(&s, 0, sizeof s);
    prim_surface(&p, &r, &h, var, &s);
    st.c[C_SPAWN]++;
    // (formatted only for a failure: every hit comes here)
    auto head = [&]() { return std::string(ROUTINES[rid].name) + " " + fmt_prim(p) + " " + fmt_ray(r) + " | " + fmt_hit(1, h); };
    Vec3 ng = s.ng;
    if (!vec_is_finite(ng) || vec_max_abs(ng) == 0.0f || !vec_is_finite(s.p)) {
        st.c[C_SELFHIT]++;
        st.fail(ray, fk("self_hit", r), head() + " | prim_surface gave a non-finite point or normal: p=" + sv3(s.p) + " ng=" + sv3(ng));
        return;
    }
    // The direction: -d is exactly on the side facing the incoming ray; the
    // normal (oriented towards -d) turned towards w stays on it with margin.
    Vec3 bk = vec_neg(r.d), dir = bk;
    if (!back) {
        double db = (double)ng.x * bk.x + (double)ng.y * bk.y + (double)ng.z * bk.z;
        double lb = std::sqrt((double)bk.x * bk.x + (double)bk.y * bk.y + (double)bk.z * bk.z);
        Vec3 n = db < 0 ? vec_neg(ng) : ng;
        if (std::fabs(db) >= 0.2 * lb) {
            dir = vec_normalize(vec_add(n, vec_scale(w, 0.9f)));
            if (!(vec_dot(dir, n) >= 0.2f) || !(vec_dot(dir, bk) > 0.0f))
                dir = n;
        }
    }
    if (p.kind == PRIM_ELLIPSOID) {
        // The direction is on the incoming side of the computed ng (-d on
        // that of the exact surface); the judge wants it there by a margin
        // that a float normal can resolve: dir . n_exact (the outward
        // normal at the exact hit, see ell_hit_normal) at least 2^-16 |dir|
        // towards the origin's side. Closer to the tangent plane (a grazing
        // hit, or -d of a near-tangent ray) the float normal cannot tell
        // the sides apart: not judged, counted in spawn_skipped.
        Ex e = exact_eval(p, xray_of(r));
        double n[3], ld = std::sqrt((double)dir.x * dir.x + (double)dir.y * dir.y + (double)dir.z * dir.z);
        ell_hit_normal(*p.g.ell.e, r, e.root, n);
        double nl = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        double dn = (n[0] * dir.x + n[1] * dir.y + n[2] * dir.z) * oside;
        if (e.skip || !e.hit || !(dn >= 0x1p-16 * ld * nl)) {
            st.c[C_SPAWN]--;
            st.c[C_SPAWNSKIP]++;
            return;
        }
    }
    Vec3 q = prim_spawn_origin(&s, dir);
    X3 Q = x3(q), D = x3(dir);
    bool ok = true, check_segment = true;
    const char *why = "";
    if (!vec_is_finite(q)) {
        ok = false;
        why = "non-finite spawned origin";
    } else if (p.kind == PRIM_PLANE || p.kind == PRIM_TRIANGLE || p.kind == PRIM_SMOOTH_TRIANGLE) {
        X3 A, n;
        FT off;
        if (p.kind == PRIM_PLANE) {
            n = x3(p.g.plane.n);
            off = dot(n, Q) - F(p.g.plane.d);
        } else {
            A = x3(p.g.tri.a);
            n = cross(sub(x3(p.g.tri.b), A), sub(x3(p.g.tri.c), A));
            off = dot(n, sub(Q, A));
        }
        int sq = CGAL::sign(off), sd = CGAL::sign(dot(n, D));
        if (sd == 0) {
            st.c[C_SPAWN]--;
            return; // dir lies in the plane: no side to judge
        }
        ok = sq == sd;
        why = "spawned origin not strictly on dir's side of the plane";
    } else {
        int qs = solid_side(p, Q);
        ok = qs == oside;
        check_segment = oside > 0;
        why = oside > 0 ? "spawned origin not strictly outside the (closed) solid"
                        : "spawned origin not strictly inside the solid";
    }
    if (ok && check_segment) {
        XRay seg;
        double ld = std::sqrt((double)dir.x * dir.x + (double)dir.y * dir.y + (double)dir.z * dir.z);
        for (int i = 0; i < 3; i++) {
            seg.o[i] = Q.v[i];
            seg.d[i] = D.v[i];
        }
        seg.fin = true;
        seg.tmax = Fd(L / ld);
        Ex e = exact_eval(p, seg);
        if (!e.skip && e.hit) {
            ok = false;
            why = "the segment from the spawned origin along dir hits the source primitive";
        } else if (!e.skip && var == PRIM_ROBUST) {
            // Exactly, the segment misses; the routine itself must too: a t
            // within its band of 0 would shadow the surface it left.
            PrimHit again;
            Ray out = ray_make(q, dir, (float)(L / ld));
            if (prim_intersect(&p, &out, var, &again)) {
                ok = false;
                why = "the routine hits the source primitive again from the spawned origin";
            }
        }
    }
    if (verbose)
        std::printf("  spawn: p=%s perr=%s ng=%s dir=%s q=%s: %s\n", sv3(s.p).c_str(), sv3(s.perr).c_str(),
                    sv3(ng).c_str(), sv3(dir).c_str(), sv3(q).c_str(), ok ? "ok" : why);
    if (!ok) {
        st.c[C_SELFHIT]++;
        st.fail(ray, fk("self_hit", r),
                head() + " | surface p=(" + hexf(s.p.x) + "," + hexf(s.p.y) + "," + hexf(s.p.z) + ") perr=" + sv3(s.perr) +
                    " ng=" + sv3(ng) + " dir=(" + hexf(dir.x) + "," + hexf(dir.y) + "," + hexf(dir.z) + ") spawned=(" +
                    hexf(q.x) + "," + hexf(q.y) + "," + hexf(q.z) + "): " + why);
    }
}

// =====================================================================
// Cases 2 and 3: unions of triangles.
// =====================================================================

void union_ray(int rid, const Triangle *tris, size_t n, const std::vector<int> &first, const std::vector<int> &through,
               const Ray &r, Stats &st, uint64_t ray, bool verbose)
{
    const Routine &R = ROUTINES[rid];
    XRay xr = xray_of(r);
    st.c[C_RAYS]++;
    auto tri_prim = [&](size_t i) {
        Prim p;
        std::memset(&p, 0, sizeof p);
        p.kind = PRIM_TRIANGLE;
        p.g.tri = tris[i];
        return p;
    };
    // Self-check: the triangles the ray was built to pass through are hit exactly.
    for (int i : through) {
        Ex e = exact_eval(tri_prim(i), xr);
        if (e.skip || !e.hit) {
            st.c[C_INTERNAL]++;
            st.fail(ray, "internal", "union ray does not exactly hit triangle it was built through: " +
                                         fmt_prim(tri_prim(i)) + " " + fmt_ray(r));
        }
    }
    PrimHit h;
    int found = -1;
    bool small = n <= 16;
    if (small) {
        // Judge every triangle on its own too.
        for (size_t i = 0; i < n; i++) {
            Prim p = tri_prim(i);
            fresh_hit(h);
            int got = call_routine(rid, p, r, h) != 0;
            Ex e = exact_eval(p, xr);
            if (e.skip)
                continue;
            if (got && found < 0)
                found = (int)i;
            if (verbose)
                std::printf("  tri %zu: %s | %s | %s\n", i, fmt_prim(p).c_str(), fmt_hit(got, h).c_str(),
                            fmt_exact(e).c_str());
            if (got && e.hit) {
                if ((int)i == found)
                    st.ulp.push_back(t_ulp(e, p, r, h.t));
                if (R.robust && !t_bound_ok(e, h.t, h.terr)) {
                    st.c[C_TBFAIL]++;
                    st.fail(ray, fk("t_bound", r), describe(rid, p, r, e, got, h));
                }
            } else if (got != (int)e.hit) {
                if (!got)
                    st.c[C_TRIMISS]++;
                bool band = disagreement_in_band(rid, p, r, xr, e, got, h, in_band_kind(p, e, xr, got != 0));
                st.c[band ? C_BAND : C_OUTBAND]++;
                if (!band && nonunit(r))
                    st.c[C_OB_NONUNIT]++;
                if (!band)
                    st.fail(ray, fk(got ? "false_hit_triangle" : "false_miss_triangle", r), describe(rid, p, r, e, got, h));
            }
        }
    } else {
        for (int i : first) {
            fresh_hit(h);
            if (call_routine(rid, tri_prim(i), r, h)) {
                found = i;
                break;
            }
        }
        if (found < 0)
            for (size_t i = 0; i < n && found < 0; i++) {
                fresh_hit(h);
                if (call_routine(rid, tri_prim(i), r, h))
                    found = (int)i;
            }
        if (found >= 0) {
            Prim p = tri_prim(found);
            Ex e = exact_eval(p, xr);
            if (!e.skip && e.hit) {
                st.ulp.push_back(t_ulp(e, p, r, h.t));
                if (R.robust && !t_bound_ok(e, h.t, h.terr)) {
                    st.c[C_TBFAIL]++;
                    st.fail(ray, fk("t_bound", r), describe(rid, p, r, e, 1, h));
                }
            } else if (!e.skip) {
                bool band = disagreement_in_band(rid, p, r, xr, e, 1, h, in_band_kind(p, e, xr, true));
                st.c[band ? C_BAND : C_OUTBAND]++;
                if (!band && nonunit(r))
                    st.c[C_OB_NONUNIT]++;
                if (!band)
                    st.fail(ray, fk("false_hit_triangle", r), describe(rid, p, r, e, 1, h));
            }
        }
        for (int i : first) { // single-triangle misses among the target's triangles
            Prim p = tri_prim(i);
            fresh_hit(h);
            if (!call_routine(rid, p, r, h) && exact_hit(p, r))
                st.c[C_TRIMISS]++;
        }
    }
    if (found >= 0) {
        st.c[C_AGREE]++;
    } else {
        st.c[C_FMISS]++;
        st.c[C_OUTBAND]++;
        if (nonunit(r))
            st.c[C_OB_NONUNIT]++;
        // Details for the first few (the rest are counted): which triangles
        // the ray exactly hits, by brute force, which also checks the premise
        // that it hits the union at all.
        if (st.wants(fk("false_miss", r))) {
            std::string t = std::string(R.name) + " no triangle of the union reports a hit; exact: the ray hits it. " +
                            fmt_ray(r) + " | triangles exactly hit (nearest first):";
            std::vector<std::pair<double, size_t>> hits;
            for (size_t i = 0; i < n; i++) {
                Ex e = exact_eval(tri_prim(i), xr);
                if (!e.skip && e.hit)
                    hits.push_back({CGAL::to_double(e.lo), i});
            }
            std::sort(hits.begin(), hits.end());
            if (hits.empty()) {
                st.c[C_INTERNAL]++;
                st.fail(ray, "internal", "union false miss but no triangle is exactly hit: " + fmt_ray(r));
            }
            for (size_t k = 0; k < hits.size() && k < 3; k++)
                t += " [" + fmt_prim(tri_prim(hits[k].second)) + " | " + fmt_exact(exact_eval(tri_prim(hits[k].second), xr)) + "]";
            t += strf(" (%zu exactly hit)", hits.size());
            st.fail(ray, fk("false_miss", r), t);
        }
    }
    if (verbose)
        std::printf("  union: %s\n", found >= 0 ? "hit" : "FALSE MISS");
}

} // namespace judge
