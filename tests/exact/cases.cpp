// cases.cpp - the exact judge's driver and its ray generators (cases 1,
// 3-8 and 11; case 2 is in mesh.cpp, 9 and 10 in pn.cpp). No CGAL here:
// every exact decision is made in exact.cpp.
//
//     build/exact/judge [RAYS_PER_CASE] [--jobs N] [--case LIST] [--routine NAME]
//                       [--ray I] [--seed S] [--data DIR] [--details] [-v]
//
// One line per case and routine:
//     exact: <case> <routine> rays= agree= false_miss= false_hit= t_ulp_p50= t_ulp_p99= t_ulp_max= band= outside_band= ...
// then "judge: PASS" or "judge: FAIL ..." (exit 1). The cases, fields, bands
// and pass criteria are described in the README (the exact judge section).
#include "judge.h"

#include <algorithm>
#include <cerrno>
#include <cfloat>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <set>
#include <sys/wait.h>
#include <unistd.h>

using namespace judge;

namespace {

typedef __int128 i128;

// ---------------------------------------------------------------------
// Float helpers
// ---------------------------------------------------------------------

struct D3 {
    double x, y, z;
};
D3 d3(Vec3 v) { return D3{v.x, v.y, v.z}; }
D3 operator+(D3 a, D3 b) { return D3{a.x + b.x, a.y + b.y, a.z + b.z}; }
D3 operator-(D3 a, D3 b) { return D3{a.x - b.x, a.y - b.y, a.z - b.z}; }
D3 operator*(D3 a, double s) { return D3{a.x * s, a.y * s, a.z * s}; }
double dotd(D3 a, D3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
D3 crossd(D3 a, D3 b) { return D3{a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
double lend(D3 a) { return std::sqrt(dotd(a, a)); }
D3 normd(D3 a) { return a * (1.0 / lend(a)); }
Vec3 fv(D3 a) { return vec3((float)a.x, (float)a.y, (float)a.z); }
float compf(Vec3 v, int i) { return i == 0 ? v.x : i == 1 ? v.y : v.z; }
void setf(Vec3 &v, int i, float x) { (i == 0 ? v.x : i == 1 ? v.y : v.z) = x; }

D3 unit(Rng &g)
{
    for (;;) {
        D3 v{g.uni(-1, 1), g.uni(-1, 1), g.uni(-1, 1)};
        double l = dotd(v, v);
        if (l > 1e-4 && l <= 1.0)
            return v * (1.0 / std::sqrt(l));
    }
}
D3 in_ball(Rng &g)
{
    for (;;) {
        D3 v{g.uni(-1, 1), g.uni(-1, 1), g.uni(-1, 1)};
        if (dotd(v, v) <= 1.0)
            return v;
    }
}
// Two unit vectors completing n (unit) to an orthonormal frame.
void frame(D3 n, D3 &e1, D3 &e2)
{
    D3 a = std::fabs(n.x) < 0.6 ? D3{1, 0, 0} : D3{0, 1, 0};
    e1 = normd(crossd(n, a));
    e2 = crossd(n, e1);
}

Prim make_prim(PrimKind k)
{
    Prim p;
    std::memset(&p, 0, sizeof p);
    p.kind = k;
    return p;
}

// ---------------------------------------------------------------------
// Scenes at random scale and place (cases 1, 7, 8)
// ---------------------------------------------------------------------

struct Scene {
    double s;
    D3 T;
};

// Scale log-uniform in [1e-6, 1e6]; offset: none, or each coordinate of
// magnitude log-uniform up to 1e6.
Scene scene(Rng &g, double p_no_offset = 0.25, double lo = 1e-6, double hi = 1e6)
{
    Scene S;
    S.s = g.logu(lo, hi);
    if (g.coin(p_no_offset))
        S.T = D3{0, 0, 0};
    else
        S.T = D3{g.sgn() * g.logu(1e-6, 1e6), g.sgn() * g.logu(1e-6, 1e6), g.sgn() * g.logu(1e-6, 1e6)};
    return S;
}

bool tri_ok(const Triangle &t)
{
    Vec3 n = vec_cross(vec_sub(t.b, t.a), vec_sub(t.c, t.a));
    return vec_max_abs(n) > 0.0f && vec_is_finite(n);
}

bool gen_prim(Kind k, Rng &g, const Scene &S, Prim &p)
{
    double s = S.s;
    auto pt = [&]() { return fv(S.T + D3{g.uni(-1, 1), g.uni(-1, 1), g.uni(-1, 1)} * s); };
    switch (k) {
    case K_PN: /* PN patches are cases 9 and 10's alone (pn.cpp) */
    case K_ELL: /* ellipsoids are case 11's alone (case_ellipsoid) */
        break;
    case K_SPHERE:
        p = make_prim(PRIM_SPHERE);
        p.g.sphere.c = pt();
        p.g.sphere.r = (float)(s * g.uni(0.05, 1.0));
        return p.g.sphere.r > 0.0f;
    case K_PLANE: {
        p = make_prim(PRIM_PLANE);
        Vec3 n = fv(unit(g));
        p.g.plane.n = n;
        p.g.plane.d = (float)dotd(d3(n), d3(pt()));
        return true;
    }
    case K_TRI:
        p = make_prim(PRIM_TRIANGLE);
        p.g.tri.a = pt();
        p.g.tri.b = pt();
        p.g.tri.c = pt();
        return tri_ok(p.g.tri);
    case K_BOX: {
        p = make_prim(PRIM_BOX);
        Vec3 lo = pt(), hi;
        for (int i = 0; i < 3; i++) {
            float h = (float)(compf(lo, i) + s * g.uni(0.02, 2.0));
            if (!(h > compf(lo, i)))
                h = nextafterf(compf(lo, i), INFINITY);
            setf(hi, i, h);
        }
        p.g.box.lo = lo;
        p.g.box.hi = hi;
        return true;
    }
    case K_OBOX: {
        p = make_prim(PRIM_OBOX);
        D3 a = unit(g), b, c;
        frame(a, b, c);
        double ang = g.uni(0, 6.283185307179586);
        D3 b2 = b * std::cos(ang) + c * std::sin(ang), c2 = crossd(a, b2);
        p.g.obox.c = pt();
        p.g.obox.u = fv(a * (s * g.uni(0.05, 1.0)));
        p.g.obox.v = fv(b2 * (s * g.uni(0.05, 1.0)));
        p.g.obox.w = fv(c2 * (s * g.uni(0.05, 1.0)));
        return prim_obox_init(&p.g.obox) == 0;
    }
    }
    return false;
}

// A point inside the primitive (on the plane, in the triangle), in double,
// rounded to float.
Vec3 interior_point(const Prim &p, Rng &g)
{
    switch (p.kind) {
    case PRIM_PN: /* PN patches are cases 9 and 10's alone (pn.cpp) */
    case PRIM_ELLIPSOID: /* case 11's alone */
        break;
    case PRIM_SPHERE: return fv(d3(p.g.sphere.c) + in_ball(g) * (0.999 * p.g.sphere.r));
    case PRIM_PLANE: {
        D3 n = d3(p.g.plane.n), e1, e2;
        double nn = dotd(n, n);
        D3 base = n * (p.g.plane.d / nn);
        frame(normd(n), e1, e2);
        double s = std::max(1e-6, (double)std::fabs(p.g.plane.d)) * g.logu(1e-3, 1e3);
        return fv(base + e1 * (s * g.uni(-1, 1)) + e2 * (s * g.uni(-1, 1)));
    }
    case PRIM_TRIANGLE:
    case PRIM_SMOOTH_TRIANGLE: {
        double u = g.uni(0.001, 0.998), v = g.uni(0.001, 0.998);
        if (u + v > 0.999) {
            u = 0.999 - u;
            v = 0.999 - v;
            if (u < 0.001) u = 0.001;
            if (v < 0.001) v = 0.001;
        }
        D3 a = d3(p.g.tri.a);
        return fv(a + (d3(p.g.tri.b) - a) * u + (d3(p.g.tri.c) - a) * v);
    }
    case PRIM_BOX: {
        D3 lo = d3(p.g.box.lo), hi = d3(p.g.box.hi);
        return fv(D3{lo.x + (hi.x - lo.x) * g.uni(0.001, 0.999), lo.y + (hi.y - lo.y) * g.uni(0.001, 0.999),
                     lo.z + (hi.z - lo.z) * g.uni(0.001, 0.999)});
    }
    case PRIM_OBOX: {
        const OBox &b = p.g.obox;
        return fv(d3(b.c) + d3(b.u) * g.uni(-0.999, 0.999) + d3(b.v) * g.uni(-0.999, 0.999) +
                  d3(b.w) * g.uni(-0.999, 0.999));
    }
    }
    return vec3(0, 0, 0);
}

// A point on the surface (rounded to float: near it).
Vec3 surface_point(const Prim &p, Rng &g)
{
    switch (p.kind) {
    case PRIM_SPHERE: return fv(d3(p.g.sphere.c) + unit(g) * (double)p.g.sphere.r);
    case PRIM_BOX: {
        Vec3 q = interior_point(p, g);
        int k = g.below(3);
        setf(q, k, g.coin(0.5) ? compf(p.g.box.lo, k) : compf(p.g.box.hi, k));
        return q;
    }
    case PRIM_OBOX: {
        const OBox &b = p.g.obox;
        double x[3] = {g.uni(-1, 1), g.uni(-1, 1), g.uni(-1, 1)};
        x[g.below(3)] = g.sgn();
        return fv(d3(b.c) + d3(b.u) * x[0] + d3(b.v) * x[1] + d3(b.w) * x[2]);
    }
    default: return interior_point(p, g);
    }
}

double prim_size(const Prim &p)
{
    switch (p.kind) {
    case PRIM_PN: /* PN patches are cases 9 and 10's alone (pn.cpp) */
    case PRIM_ELLIPSOID: /* case 11's alone */
        break;
    case PRIM_SPHERE: return p.g.sphere.r;
    case PRIM_PLANE: return std::max(1e-30, (double)std::fabs(p.g.plane.d));
    case PRIM_TRIANGLE:
    case PRIM_SMOOTH_TRIANGLE:
        return std::max(lend(d3(p.g.tri.b) - d3(p.g.tri.a)), lend(d3(p.g.tri.c) - d3(p.g.tri.a)));
    case PRIM_BOX: return lend(d3(p.g.box.hi) - d3(p.g.box.lo));
    case PRIM_OBOX: return lend(d3(p.g.obox.u)) + lend(d3(p.g.obox.v)) + lend(d3(p.g.obox.w));
    }
    return 1.0;
}

bool is_solid(Kind k) { return k == K_SPHERE || k == K_BOX || k == K_OBOX; }

// A ray from o towards target: d = target - o in float; normalised (as the
// renderer does) with probability p_norm; a finite tmax around the target's
// distance with probability p_tmax.
bool aim(Vec3 o, Vec3 target, Rng &g, double p_norm, double p_tmax, Ray &r)
{
    if (!vec_is_finite(o) || !vec_is_finite(target))
        return false;
    Vec3 d = vec_sub(target, o);
    if (!(vec_max_abs(d) > 0.0f) || !vec_is_finite(d))
        return false;
    if (g.coin(p_norm)) {
        Vec3 n = vec_normalize(d);
        if (vec_max_abs(n) > 0.0f && vec_is_finite(n))
            d = n;
    }
    float tmax = INFINITY;
    if (g.coin(p_tmax)) {
        double tt = lend(d3(target) - d3(o)) / lend(d3(d));
        tmax = (float)(tt * g.uni(0.5, 1.5));
        if (!(tmax > 0.0f) || !std::isfinite(tmax))
            tmax = INFINITY;
    }
    r = ray_make(o, d, tmax);
    return true;
}

// ---------------------------------------------------------------------
// Lattices: integer coordinates times 2^e, exact in float while |n| < 2^24
// ---------------------------------------------------------------------

struct L3 {
    int64_t v[3];
};
L3 operator+(L3 a, L3 b) { return L3{{a.v[0] + b.v[0], a.v[1] + b.v[1], a.v[2] + b.v[2]}}; }
L3 operator-(L3 a, L3 b) { return L3{{a.v[0] - b.v[0], a.v[1] - b.v[1], a.v[2] - b.v[2]}}; }
L3 operator*(L3 a, int64_t s) { return L3{{a.v[0] * s, a.v[1] * s, a.v[2] * s}}; }
struct W3 {
    i128 v[3];
};
W3 crossl(L3 a, L3 b)
{
    return W3{{(i128)a.v[1] * b.v[2] - (i128)a.v[2] * b.v[1], (i128)a.v[2] * b.v[0] - (i128)a.v[0] * b.v[2],
               (i128)a.v[0] * b.v[1] - (i128)a.v[1] * b.v[0]}};
}
i128 dotw(W3 n, L3 d) { return n.v[0] * d.v[0] + n.v[1] * d.v[1] + n.v[2] * d.v[2]; }
bool zerow(W3 n) { return n.v[0] == 0 && n.v[1] == 0 && n.v[2] == 0; }
int sgn128(i128 x) { return (x > 0) - (x < 0); }
bool zerol(L3 a) { return a.v[0] == 0 && a.v[1] == 0 && a.v[2] == 0; }
int64_t maxabs(L3 a) { return std::max({std::llabs(a.v[0]), std::llabs(a.v[1]), std::llabs(a.v[2])}); }
L3 lrand(Rng &g, int64_t m) { return L3{{g.ibetween(-m, m), g.ibetween(-m, m), g.ibetween(-m, m)}}; }

const int64_t LAT_MAX = (1 << 24) - 1;

struct Lattice {
    int e = 0; // unit 2^e
    L3 T{{0, 0, 0}};
    bool ok = true;
    float f1(int64_t n, int64_t t)
    {
        int64_t m = n + t;
        if (std::llabs(m) > LAT_MAX)
            ok = false;
        return (float)std::ldexp((double)m, e);
    }
    Vec3 pt(L3 a) { return vec3(f1(a.v[0], T.v[0]), f1(a.v[1], T.v[1]), f1(a.v[2], T.v[2])); }
    Vec3 vec(L3 a, int extra = 0)
    {
        Vec3 r;
        for (int i = 0; i < 3; i++) {
            if (std::llabs(a.v[i]) > LAT_MAX)
                ok = false;
            setf(r, i, (float)std::ldexp((double)a.v[i], e + extra));
        }
        return r;
    }
};

// The extra exponent for a lattice direction: mostly so that its largest
// component lies in [1/2, 1) (near unit length, as the renderer's directions;
// a power of two keeps it exact), otherwise a random power of two.
int dir_exp(Rng &g, const Lattice &L, L3 d)
{
    if (g.coin(0.3))
        return (int)g.ibetween(-8, 8);
    int b;
    std::frexp((double)maxabs(d), &b); // maxabs in [2^(b-1), 2^b)
    return -b - L.e;
}

// A lattice for integer coordinates up to maxint: (half the time) a
// translation whose lattice coordinates reach tmag, and a unit 2^e that puts
// the largest coordinate between 2^-20 and 2^40 (the scenes' range: scales
// 1e-6 to 1e6, offsets up to 1e6).
Lattice lattice(Rng &g, int64_t maxint, int64_t tmag)
{
    Lattice L;
    if (g.coin(0.5) && tmag > 0)
        L.T = lrand(g, tmag);
    int b;
    std::frexp((double)(maxint + maxabs(L.T) + 1), &b);
    L.e = (int)g.ibetween(-20, 40) - b;
    return L;
}

// P lies on the closed triangle ABC (integers, exact).
bool on_tri(L3 A, L3 B, L3 C, L3 P)
{
    W3 n = crossl(B - A, C - A);
    if (zerow(n) || dotw(n, P - A) != 0)
        return false;
    // Barycentric signs: n.((V-U)x(P-U)) >= 0 for the three edges UV.
    // Coordinates stay below 2^20 here, so every product fits in 128 bits.
    auto side = [&](L3 U, L3 V) {
        W3 c = crossl(V - U, P - U);
        return n.v[0] * c.v[0] + n.v[1] * c.v[1] + n.v[2] * c.v[2];
    };
    return side(A, B) >= 0 && side(B, C) >= 0 && side(C, A) >= 0;
}

// ---------------------------------------------------------------------
// Case 1: interior fuzz
// ---------------------------------------------------------------------

void case_interior(int rid, Rng &g, Stats &st, uint64_t i, bool v, bool extreme = false)
{
    Kind k = ROUTINES[rid].kind;
    for (int tries = 0; tries < 100; tries++) {
        /* case 12: scenes 2^40 to 2^66 across, or 2^-66 to 2^-40, where
         * float products of coordinates over- or underflow */
        Scene S = !extreme ? scene(g) : g.coin(0.5) ? scene(g, 0.25, 0x1p40, 0x1p66) : scene(g, 0.25, 0x1p-66, 0x1p-40);
        Prim p;
        if (!gen_prim(k, g, S, p))
            continue;
        Vec3 target = interior_point(p, g), o;
        if (is_solid(k) && g.coin(0.2)) {
            o = interior_point(p, g);
        } else {
            double dist = g.coin(0.5) ? S.s * g.logu(1, 1e3) : S.s * g.logu(1, std::max(10.0, 1e6 / S.s));
            o = fv(d3(target) + unit(g) * dist);
        }
        Ray r;
        if (!aim(o, target, g, 0.7, 0.2, r))
            continue;
        judge_single(rid, p, r, st, i, v);
        return;
    }
    st.c[C_SKIP]++;
}

// ---------------------------------------------------------------------
// Case 3: integer triangles sharing edges and vertices; rays exactly
// through a shared edge point or vertex, crossing transversally.
// ---------------------------------------------------------------------

struct Config3 {
    std::vector<L3> tri; // 3 per triangle
    L3 P, O, d;
    std::vector<int> through;
};

// d crosses the surface made of the listed triangles at P transversally:
// all their normals have the same nonzero sign along d.
bool transversal(const Config3 &c, const std::vector<int> &tris, L3 d)
{
    int s0 = 0;
    for (int t : tris) {
        W3 n = crossl(c.tri[3 * t + 1] - c.tri[3 * t], c.tri[3 * t + 2] - c.tri[3 * t]);
        int s = sgn128(dotw(n, d));
        if (s == 0 || (s0 != 0 && s != s0))
            return false;
        s0 = s;
    }
    return true;
}

// Takes d as the ray's direction when it is transversal to tris, with the
// origin 1 to 3 steps of d before P.
bool aim_through(Rng &g, Config3 &c, const std::vector<int> &tris, L3 d)
{
    if (zerol(d) || !transversal(c, tris, d))
        return false;
    c.d = d;
    c.O = c.P - d * g.ibetween(1, 3);
    return true;
}

bool gen_quad(Rng &g, Config3 &c)
{
    int64_t M = (int64_t)1 << g.ibetween(1, 18);
    static const int ms[] = {2, 3, 4, 5, 7, 8};
    int64_t m = ms[g.below(6)];
    L3 A = lrand(g, M), e = lrand(g, M / m + 1);
    if (zerol(e))
        return false;
    L3 C = A + e * m, B = lrand(g, M), D = lrand(g, M);
    c.tri = {A, B, C, A, C, D};
    if (zerow(crossl(B - A, C - A)) || zerow(crossl(C - A, D - A)))
        return false;
    c.P = A + e * g.ibetween(1, m - 1);
    c.through = {0, 1};
    int64_t Md = (int64_t)1 << g.ibetween(0, 18);
    for (int k = 0; k < 30; k++)
        if (aim_through(g, c, c.through, lrand(g, Md)))
            return true;
    return false;
}

bool gen_fan(Rng &g, Config3 &c)
{
    int64_t M = (int64_t)1 << g.ibetween(2, 18);
    int k = (int)g.ibetween(3, 8);
    L3 V = lrand(g, M / 2);
    D3 nrm = unit(g), e1, e2;
    frame(nrm, e1, e2);
    bool planar = g.coin(0.3);
    std::vector<L3> R(k), E(k);
    std::vector<int64_t> mj(k);
    for (int j = 0; j < k; j++) {
        double th = 6.283185307179586 * (j + g.uni(-0.3, 0.3)) / k, rho = M * g.uni(0.3, 1.0);
        double h = planar ? 0.0 : M * g.uni(-0.6, 0.6);
        mj[j] = g.ibetween(1, 4);
        D3 q = (e1 * (rho * std::cos(th)) + e2 * (rho * std::sin(th)) + nrm * h) * (1.0 / mj[j]);
        E[j] = L3{{std::llround(q.x), std::llround(q.y), std::llround(q.z)}};
        if (zerol(E[j]))
            return false;
        R[j] = V + E[j] * mj[j];
    }
    c.tri.clear();
    std::vector<int> all;
    for (int j = 0; j < k; j++) {
        c.tri.insert(c.tri.end(), {V, R[j], R[(j + 1) % k]});
        if (zerow(crossl(R[j] - V, R[(j + 1) % k] - V)))
            return false;
        all.push_back(j);
    }
    // Through the centre (all triangles) or a spoke point (its two triangles).
    int spoke = -1;
    if (g.coin(0.5)) {
        std::vector<int> cands;
        for (int j = 0; j < k; j++)
            if (mj[j] >= 2)
                cands.push_back(j);
        if (!cands.empty())
            spoke = cands[g.below((int)cands.size())];
    }
    if (spoke < 0) {
        c.P = V;
        c.through = all;
    } else {
        c.P = V + E[spoke] * g.ibetween(1, mj[spoke] - 1);
        c.through = {(spoke + k - 1) % k, spoke}; // triangles j-1 and j share spoke j
    }
    int64_t Md = (int64_t)1 << g.ibetween(2, 18);
    for (int t = 0; t < 30; t++) {
        D3 dd = nrm * (double)Md + D3{g.uni(-1, 1), g.uni(-1, 1), g.uni(-1, 1)} * (Md * 0.7);
        L3 d{{std::llround(dd.x), std::llround(dd.y), std::llround(dd.z)}};
        if (g.coin(0.5))
            d = d * -1;
        if (aim_through(g, c, all, d))
            return true;
    }
    return false;
}

// Convex polyhedra (tetrahedron, octahedron, box split into 12 triangles)
// with an interior origin and a ray through a vertex or an edge point.
bool gen_poly(Rng &g, Config3 &c)
{
    int64_t M = (int64_t)1 << g.ibetween(1, 14);
    std::vector<L3> V;
    std::vector<int> F;
    L3 O;
    int kind = g.below(3);
    if (kind == 0) {
        for (int j = 0; j < 4; j++)
            V.push_back(lrand(g, M) * 8);
        W3 n = crossl(V[1] - V[0], V[2] - V[0]);
        i128 vol = dotw(n, V[3] - V[0]);
        if (vol == 0)
            return false;
        if (vol < 0)
            std::swap(V[1], V[2]);
        F = {0, 2, 1, 0, 1, 3, 1, 2, 3, 0, 3, 2};
        O = L3{{(V[0].v[0] + V[1].v[0] + V[2].v[0] + V[3].v[0]) / 4, (V[0].v[1] + V[1].v[1] + V[2].v[1] + V[3].v[1]) / 4,
                (V[0].v[2] + V[1].v[2] + V[2].v[2] + V[3].v[2]) / 4}};
    } else if (kind == 1) {
        L3 Z = lrand(g, M);
        int64_t a = g.ibetween(1, M) * 8, b = g.ibetween(1, M) * 8, cc = g.ibetween(1, M) * 8;
        V = {Z + L3{{a, 0, 0}}, Z - L3{{a, 0, 0}}, Z + L3{{0, b, 0}}, Z - L3{{0, b, 0}}, Z + L3{{0, 0, cc}}, Z - L3{{0, 0, cc}}};
        for (int sx = 0; sx < 2; sx++)
            for (int sy = 0; sy < 2; sy++)
                for (int sz = 0; sz < 2; sz++)
                    F.insert(F.end(), {sx, 2 + sy, 4 + sz});
        O = Z + L3{{g.sgn() > 0 ? a / 8 * g.ibetween(0, 2) : -a / 8 * g.ibetween(0, 2),
                    g.sgn() > 0 ? b / 8 * g.ibetween(0, 2) : -b / 8 * g.ibetween(0, 2),
                    g.sgn() > 0 ? cc / 8 * g.ibetween(0, 2) : -cc / 8 * g.ibetween(0, 2)}};
    } else {
        L3 lo = lrand(g, M) * 8, ext{{g.ibetween(1, M) * 8, g.ibetween(1, M) * 8, g.ibetween(1, M) * 8}};
        for (int j = 0; j < 8; j++)
            V.push_back(lo + L3{{j & 1 ? ext.v[0] : 0, j & 2 ? ext.v[1] : 0, j & 4 ? ext.v[2] : 0}});
        static const int quads[6][4] = {{0, 1, 3, 2}, {4, 6, 7, 5}, {0, 4, 5, 1}, {2, 3, 7, 6}, {0, 2, 6, 4}, {1, 5, 7, 3}};
        for (auto &q : quads) {
            if (g.coin(0.5))
                F.insert(F.end(), {q[0], q[1], q[2], q[0], q[2], q[3]});
            else
                F.insert(F.end(), {q[0], q[1], q[3], q[1], q[2], q[3]});
        }
        O = lo + L3{{ext.v[0] / 8 * g.ibetween(1, 7), ext.v[1] / 8 * g.ibetween(1, 7), ext.v[2] / 8 * g.ibetween(1, 7)}};
    }
    c.tri.clear();
    for (int f : F)
        c.tri.push_back(V[f]);
    // The target: a vertex, or an edge point at j/8 of an edge.
    int nf = (int)F.size() / 3, f = g.below(nf), k = g.below(3);
    L3 a = c.tri[3 * f + k], b = c.tri[3 * f + (k + 1) % 3];
    if (g.coin(0.5))
        c.P = a;
    else
        c.P = a + L3{{(b.v[0] - a.v[0]) / 8, (b.v[1] - a.v[1]) / 8, (b.v[2] - a.v[2]) / 8}} * g.ibetween(1, 7);
    c.through.clear();
    for (int t = 0; t < nf; t++)
        if (on_tri(c.tri[3 * t], c.tri[3 * t + 1], c.tri[3 * t + 2], c.P))
            c.through.push_back(t);
    c.O = O;
    c.d = c.P - O;
    return !zerol(c.d) && !c.through.empty();
}

void case_shared_edge(int rid, Rng &g, Stats &st, uint64_t i, bool v)
{
    for (int tries = 0; tries < 200; tries++) {
        Config3 c;
        int kind = g.below(3);
        bool ok = kind == 0 ? gen_quad(g, c) : kind == 1 ? gen_fan(g, c) : gen_poly(g, c);
        if (!ok)
            continue;
        int64_t m = maxabs(c.O);
        for (const L3 &t : c.tri)
            m = std::max(m, maxabs(t));
        Lattice L = lattice(g, m, std::max<int64_t>(0, ((int64_t)1 << 23) - 2 * m - 1));
        std::vector<Triangle> tris(c.tri.size() / 3);
        for (size_t t = 0; t < tris.size(); t++) {
            std::memset(&tris[t], 0, sizeof tris[t]);
            tris[t].a = L.pt(c.tri[3 * t]);
            tris[t].b = L.pt(c.tri[3 * t + 1]);
            tris[t].c = L.pt(c.tri[3 * t + 2]);
        }
        Vec3 o = L.pt(c.O), d = L.vec(c.d, dir_exp(g, L, c.d));
        if (!L.ok)
            continue;
        st.c[C_EXACTAIM]++;
        std::vector<int> first = c.through;
        union_ray(rid, tris.data(), tris.size(), first, c.through, ray_make(o, d, INFINITY), st, i, v);
        return;
    }
    st.c[C_SKIP]++;
}

// ---------------------------------------------------------------------
// Case 4: rays at box and oriented-box edges and corners
// ---------------------------------------------------------------------

void case_box_edge(int rid, Rng &g, Stats &st, uint64_t i, bool v)
{
    Kind k = ROUTINES[rid].kind;
    for (int tries = 0; tries < 100; tries++) {
        Prim p;
        Ray r;
        if (g.coin(0.5)) {
            // Exact: lattice boxes, lattice targets on edges and corners,
            // lattice origins, so the ray passes exactly through the target.
            int64_t M = (int64_t)1 << g.ibetween(1, 16);
            int64_t m = (int64_t)1 << g.ibetween(0, 3);
            L3 tgt, lo{}, hi{};
            L3 c{}, ax[3]{};
            if (k == K_BOX) {
                lo = lrand(g, M);
                hi = lo + L3{{g.ibetween(1, M), g.ibetween(1, M), g.ibetween(1, M)}};
                for (int j = 0; j < 3; j++)
                    tgt.v[j] = g.coin(0.5) ? lo.v[j] : hi.v[j];
                if (g.coin(0.6)) {
                    int j = g.below(3);
                    tgt.v[j] = g.ibetween(lo.v[j], hi.v[j]);
                }
            } else {
                c = lrand(g, M);
                int64_t am = std::max<int64_t>(1, M / 4);
                if (g.coin(0.3)) {
                    ax[0] = L3{{g.ibetween(1, am), 0, 0}};
                    ax[1] = L3{{0, g.ibetween(1, am), 0}};
                    ax[2] = L3{{0, 0, g.ibetween(1, am)}};
                } else {
                    for (auto &a : ax)
                        a = lrand(g, am);
                }
                for (auto &a : ax)
                    a = a * m;
                if (zerow(crossl(ax[0], ax[1])) || dotw(crossl(ax[0], ax[1]), ax[2]) == 0)
                    continue;
                double x[3];
                for (int j = 0; j < 3; j++)
                    x[j] = g.sgn();
                int free_axis = g.coin(0.6) ? g.below(3) : -1;
                tgt = c;
                for (int j = 0; j < 3; j++) {
                    int64_t num = j == free_axis ? g.ibetween(-m, m) : (int64_t)x[j] * m; // x_j = num / m
                    tgt = tgt + L3{{ax[j].v[0] / m * num, ax[j].v[1] / m * num, ax[j].v[2] / m * num}};
                }
            }
            // Grazing (oriented boxes, a quarter of the time): a direction in
            // the plane of a face, d.N = 0 exactly with a zero component,
            // which then takes a tiny float: the ray turns off the plane by
            // a few rounding units of the slab's d.N.
            int graze = k == K_OBOX && g.coin(0.25) ? 1 + (int)g.below(3) : 0; // the grazed slab, plus 1
            L3 gd{};
            int gzero = 0;
            if (graze) {
                W3 N = crossl(ax[graze % 3], ax[(graze + 1) % 3]); // the normal of slab graze - 1
                gzero = (int)g.below(3);                           // d's zero component
                int a1 = (gzero + 1) % 3, a2 = (gzero + 2) % 3;   // d = (N_a2, -N_a1) there: d.N = 0
                if (N.v[a1] == 0 && N.v[a2] == 0)
                    continue;
                gd.v[gzero] = 0;
                gd.v[a1] = (int64_t)N.v[a2];
                gd.v[a2] = -(int64_t)N.v[a1];
                if (maxabs(gd) > ((int64_t)1 << 20))
                    continue;
            }
            L3 O = graze ? tgt - gd * g.ibetween(1, 64) + lrand(g, g.coin(0.5) ? 0 : 1)
                 : g.coin(0.15) ? (k == K_BOX ? L3{{(lo.v[0] + hi.v[0]) / 2, (lo.v[1] + hi.v[1]) / 2, (lo.v[2] + hi.v[2]) / 2}} : c)
                                : tgt + lrand(g, (int64_t)1 << g.ibetween(1, 18));
            L3 d = graze ? gd : tgt - O;
            if (zerol(d))
                continue;
            int64_t mag = std::max({maxabs(O), maxabs(tgt), maxabs(lo), maxabs(hi), maxabs(c) + maxabs(ax[0]) + maxabs(ax[1]) + maxabs(ax[2])});
            Lattice L = lattice(g, mag, (int64_t)1 << 21);
            if (k == K_BOX) {
                p = make_prim(PRIM_BOX);
                p.g.box.lo = L.pt(lo);
                p.g.box.hi = L.pt(hi);
            } else {
                p = make_prim(PRIM_OBOX);
                p.g.obox.c = L.pt(c);
                p.g.obox.u = L.vec(ax[0]);
                p.g.obox.v = L.vec(ax[1]);
                p.g.obox.w = L.vec(ax[2]);
                if (prim_obox_init(&p.g.obox) != 0)
                    continue;
            }
            r = ray_make(L.pt(O), L.vec(d, dir_exp(g, L, d)), INFINITY);
            if (!L.ok)
                continue;
            if (graze) { // the tilt: 2^-60 to 2^-40 of the direction's length, either way
                float m = std::max({std::fabs(r.d.x), std::fabs(r.d.y), std::fabs(r.d.z)});
                setf(r.d, gzero, (float)(g.sgn() * std::ldexp((double)m, -(int)g.ibetween(40, 60))));
            } else {
                st.c[C_EXACTAIM]++;
            }
        } else {
            // Float: random boxes, targets on edges and corners in float.
            Scene S = scene(g);
            if (!gen_prim(k, g, S, p))
                continue;
            Vec3 tgt;
            if (k == K_BOX) {
                for (int j = 0; j < 3; j++)
                    setf(tgt, j, g.coin(0.5) ? compf(p.g.box.lo, j) : compf(p.g.box.hi, j));
                if (g.coin(0.6)) {
                    int j = g.below(3);
                    setf(tgt, j, (float)g.uni(compf(p.g.box.lo, j), compf(p.g.box.hi, j)));
                }
            } else {
                const OBox &b = p.g.obox;
                double x[3] = {g.sgn(), g.sgn(), g.sgn()};
                if (g.coin(0.6))
                    x[g.below(3)] = g.uni(-1, 1);
                tgt = fv(d3(b.c) + d3(b.u) * x[0] + d3(b.v) * x[1] + d3(b.w) * x[2]);
            }
            Vec3 o = g.coin(0.15) ? interior_point(p, g) : fv(d3(tgt) + unit(g) * (S.s * g.logu(1, 1e3)));
            if (!aim(o, tgt, g, 0.7, 0.0, r))
                continue;
        }
        judge_single(rid, p, r, st, i, v);
        return;
    }
    st.c[C_SKIP]++;
}

// ---------------------------------------------------------------------
// Case 5: degenerate directions and origins exactly on planes
// ---------------------------------------------------------------------

float subnormal(Rng &g)
{
    uint32_t bits = 1 + (uint32_t)(g.next() % 0x7fffff);
    if (g.coin(0.5))
        bits |= 0x80000000u;
    float x;
    std::memcpy(&x, &bits, 4);
    return x;
}

// A degenerate component: +-0, a subnormal, a tiny normal, or x itself.
float degen(Rng &g, float x)
{
    double u = g.uni();
    if (u < 0.35)
        return g.coin(0.5) ? 0.0f : -0.0f;
    if (u < 0.55)
        return subnormal(g);
    if (u < 0.65)
        return (float)(g.sgn() * FLT_MIN * g.uni(1, 2));
    return x;
}

// The direction towards a target with some components made degenerate;
// `forced` components (bit mask) are set to +-0.
Vec3 degen_dir(Rng &g, Vec3 a, unsigned forced)
{
    Vec3 d;
    for (int j = 0; j < 3; j++) {
        float x = compf(a, j);
        if (forced & (1u << j))
            x = g.coin(0.5) ? 0.0f : -0.0f;
        else if (g.coin(0.5))
            x = degen(g, x);
        setf(d, j, x);
    }
    if (!(vec_max_abs(d) > 0.0f)) { // keep one real component
        int j = 0;
        for (int t = 0; t < 3; t++)
            if (!(forced & (1u << t)) && std::fabs(compf(a, t)) > std::fabs(compf(a, j)))
                j = t;
        setf(d, j, compf(a, j) != 0.0f ? compf(a, j) : 1.0f);
        if (forced & (1u << j))
            return vec3(0, 0, 0);
    }
    return d;
}

void case_degenerate(int rid, Rng &g, Stats &st, uint64_t i, bool v)
{
    Kind k = ROUTINES[rid].kind;
    for (int tries = 0; tries < 200; tries++) {
        int64_t M = (int64_t)1 << g.ibetween(1, 12);
        Lattice L = lattice(g, 16 * M, (int64_t)1 << 20);
        Prim p;
        Vec3 o = vec3(0, 0, 0), tgt = vec3(0, 0, 0);
        unsigned forced = 0;
        switch (k) {
        case K_PN: /* PN patches are cases 9 and 10's alone (pn.cpp) */
        case K_ELL:
            break;
        case K_PLANE: {
            p = make_prim(PRIM_PLANE);
            L3 n, O = lrand(g, M), P;
            bool axis = g.coin(0.5);
            if (axis) {
                n = L3{{0, 0, 0}};
                n.v[g.below(3)] = g.coin(0.5) ? 1 : -1;
            } else {
                n = lrand(g, 4);
                if (zerol(n))
                    continue;
            }
            P = g.coin(0.5) ? O : lrand(g, M); // O on the plane half the time
            i128 pd = dotw(W3{{n.v[0], n.v[1], n.v[2]}}, P);
            // The plane n.x = pd in lattice units: with x = (X + T) 2^e,
            // n.x = (n.X + n.T) 2^e.
            i128 ntot = pd + dotw(W3{{n.v[0], n.v[1], n.v[2]}}, L.T);
            if (ntot > LAT_MAX || ntot < -LAT_MAX)
                continue;
            p.g.plane.n = vec3((float)n.v[0], (float)n.v[1], (float)n.v[2]);
            p.g.plane.d = (float)std::ldexp((double)ntot, L.e);
            o = L.pt(O);
            tgt = L.pt(P + lrand(g, M));
            if (axis && g.coin(0.5)) // also exactly parallel rays
                for (int j = 0; j < 3; j++)
                    if (n.v[j] != 0)
                        forced |= 1u << j;
            break;
        }
        case K_SPHERE: {
            p = make_prim(PRIM_SPHERE);
            L3 C = lrand(g, M);
            int64_t q = g.ibetween(1, M), R = 3 * q;
            L3 off;
            double u = g.uni();
            if (u < 0.4) { // exactly on the sphere
                if (g.coin(0.5)) {
                    int64_t a[3] = {q, 2 * q, 2 * q};
                    std::swap(a[0], a[g.below(3)]);
                    off = L3{{a[0] * (g.coin(0.5) ? 1 : -1), a[1] * (g.coin(0.5) ? 1 : -1), a[2] * (g.coin(0.5) ? 1 : -1)}};
                } else {
                    off = L3{{0, 0, 0}};
                    off.v[g.below(3)] = g.coin(0.5) ? R : -R;
                }
            } else if (u < 0.7) {
                off = lrand(g, q); // inside
            } else {
                off = lrand(g, 4 * R);
                for (int j = 0; j < 3; j++)
                    if (g.coin(0.4))
                        off.v[j] = 0;
            }
            p.g.sphere.c = L.pt(C);
            p.g.sphere.r = (float)std::ldexp((double)R, L.e);
            o = L.pt(C + off);
            L3 t = lrand(g, R / 2 + 1);
            for (int j = 0; j < 3; j++)
                if (g.coin(0.4))
                    t.v[j] = 0;
            tgt = L.pt(C + t);
            break;
        }
        case K_TRI: {
            p = make_prim(PRIM_TRIANGLE);
            L3 A = lrand(g, M), B = lrand(g, M), Cc = lrand(g, M);
            bool axis = g.coin(0.5);
            int ka = g.below(3);
            if (axis)
                B.v[ka] = Cc.v[ka] = A.v[ka];
            if (zerow(crossl(B - A, Cc - A)))
                continue;
            L3 O;
            if (g.coin(0.4)) { // the origin in the triangle's plane
                O = A + (B - A) * g.ibetween(-2, 2) + (Cc - A) * g.ibetween(-2, 2);
            } else {
                O = lrand(g, 2 * M);
            }
            p.g.tri.a = L.pt(A);
            p.g.tri.b = L.pt(B);
            p.g.tri.c = L.pt(Cc);
            o = L.pt(O);
            L3 S = A + B + Cc;
            tgt = vec3((float)std::ldexp((double)(S.v[0] + 3 * L.T.v[0]) / 3.0, L.e),
                       (float)std::ldexp((double)(S.v[1] + 3 * L.T.v[1]) / 3.0, L.e),
                       (float)std::ldexp((double)(S.v[2] + 3 * L.T.v[2]) / 3.0, L.e));
            if (axis && g.coin(0.5))
                forced |= 1u << ka; // a ray parallel to the triangle's plane
            break;
        }
        case K_BOX: {
            p = make_prim(PRIM_BOX);
            L3 lo = lrand(g, M), hi = lo + L3{{g.ibetween(1, M), g.ibetween(1, M), g.ibetween(1, M)}};
            L3 O = lrand(g, 2 * M), T;
            for (int j = 0; j < 3; j++)
                T.v[j] = g.ibetween(lo.v[j], hi.v[j]);
            double u = g.uni();
            if (u < 0.7) { // on one, two or three slab planes, moving in them
                int n_on = u < 0.4 ? 1 : u < 0.6 ? 2 : 3;
                int first = g.below(3);
                for (int t = 0; t < n_on; t++) {
                    int j = (first + t) % 3;
                    O.v[j] = g.coin(0.5) ? lo.v[j] : hi.v[j];
                    if (t < 2 || g.coin(0.5))
                        forced |= 1u << j;
                }
            }
            p.g.box.lo = L.pt(lo);
            p.g.box.hi = L.pt(hi);
            o = L.pt(O);
            tgt = L.pt(T);
            break;
        }
        case K_OBOX: {
            p = make_prim(PRIM_OBOX);
            L3 C = lrand(g, M), ax[3];
            int64_t am = std::max<int64_t>(1, M / 4);
            bool axis = g.coin(0.3);
            if (axis) {
                ax[0] = L3{{g.ibetween(1, am), 0, 0}};
                ax[1] = L3{{0, g.ibetween(1, am), 0}};
                ax[2] = L3{{0, 0, g.ibetween(1, am)}};
            } else {
                for (auto &a : ax)
                    a = lrand(g, am);
            }
            for (auto &a : ax)
                a = a * 4;
            if (dotw(crossl(ax[0], ax[1]), ax[2]) == 0)
                continue;
            p.g.obox.c = L.pt(C);
            p.g.obox.u = L.vec(ax[0]);
            p.g.obox.v = L.vec(ax[1]);
            p.g.obox.w = L.vec(ax[2]);
            if (prim_obox_init(&p.g.obox) != 0)
                continue;
            int f = g.below(3), f1 = (f + 1) % 3, f2 = (f + 2) % 3;
            if (g.coin(0.6)) {
                // On face f's plane (x_f = +-1), in or beside the face, moving
                // parallel to it (zero box-space component) half the time.
                L3 O = C + ax[f] * (g.coin(0.5) ? 1 : -1) + L3{{ax[f1].v[0] / 4, ax[f1].v[1] / 4, ax[f1].v[2] / 4}} * g.ibetween(-6, 6) +
                       L3{{ax[f2].v[0] / 4, ax[f2].v[1] / 4, ax[f2].v[2] / 4}} * g.ibetween(-6, 6);
                o = L.pt(O);
                if (g.coin(0.5)) {
                    L3 d = ax[f1] * g.ibetween(-3, 3) + ax[f2] * g.ibetween(-3, 3);
                    if (zerol(d))
                        continue;
                    Vec3 dv = L.vec(d);
                    if (!L.ok)
                        continue;
                    judge_single(rid, p, ray_make(o, dv, INFINITY), st, i, v);
                    return;
                }
                tgt = L.pt(C + lrand(g, am));
            } else {
                o = L.pt(lrand(g, 2 * M));
                tgt = L.pt(C + lrand(g, am));
            }
            break;
        }
        }
        if (!L.ok)
            continue;
        Vec3 a = vec_sub(tgt, o);
        if (!(vec_max_abs(a) > 0.0f))
            a = vec3(1, 0, 0);
        Vec3 d = degen_dir(g, a, forced);
        if (!(vec_max_abs(d) > 0.0f))
            continue;
        if (g.coin(0.3)) {
            Vec3 n = vec_normalize(d);
            if (vec_max_abs(n) > 0.0f && vec_is_finite(n))
                d = n;
        }
        judge_single(rid, p, ray_make(o, d, INFINITY), st, i, v);
        return;
    }
    st.c[C_SKIP]++;
}

// ---------------------------------------------------------------------
// Case 6: spheres from 1 to 1e6 radii away; near-tangent rays
// ---------------------------------------------------------------------

// Exactly tangent rays: d and n orthogonal integer vectors with |n| = L an
// integer; the sphere of radius q L about C touches the line through
// C + q n along d. All lattice points, so exact in float.
bool exact_tangent(Rng &g, Prim &p, Ray &r)
{
    static const int PAIRS[][7] = {{1, 2, 2, 2, 1, -2, 3}, {1, 2, 2, 2, -2, 1, 3}, {3, 4, 0, 4, -3, 0, 5},
                                   {2, 3, 6, 3, -6, 2, 7}, {2, 3, 6, 6, 2, -3, 7}, {0, 0, 1, 1, 0, 0, 1},
                                   {1, 1, 0, 0, 0, 1, 1},  {4, 4, 7, 1, -8, 4, 9}};
    const int *pr = PAIRS[g.below(8)];
    int perm[3] = {0, 1, 2};
    for (int k = 2; k > 0; k--)
        std::swap(perm[k], perm[g.below(k + 1)]);
    L3 d, n;
    for (int k = 0; k < 3; k++) {
        int64_t s = g.coin(0.5) ? 1 : -1;
        d.v[perm[k]] = s * pr[k];
        n.v[perm[k]] = s * pr[3 + k];
    }
    int64_t q = g.ibetween(1, 64), L = pr[6];
    // Distance from 1 to 1e6 radii, in steps of |d|.
    double D = (double)(q * L) * g.logu(1.0, 1e6), dl = std::sqrt((double)(d.v[0] * d.v[0] + d.v[1] * d.v[1] + d.v[2] * d.v[2]));
    int64_t lam = std::max<int64_t>(1, std::llround(D / dl));
    L3 C = lrand(g, 1 << 10), T = C + n * q, O = T - d * lam;
    int64_t mag = std::max(maxabs(O), maxabs(C) + q * L);
    if (mag > ((int64_t)1 << 23))
        return false;
    Lattice Lt = lattice(g, mag, ((int64_t)1 << 23) - mag - 1);
    p = make_prim(PRIM_SPHERE);
    p.g.sphere.c = Lt.pt(C);
    p.g.sphere.r = (float)std::ldexp((double)(q * L), Lt.e);
    Vec3 o = Lt.pt(O), dv = Lt.vec(d, dir_exp(g, Lt, d));
    if (!Lt.ok)
        return false;
    // Exactly tangent, or nudged by a few ulps (the origin, or the radius).
    if (g.coin(0.6)) {
        int k = (int)g.ibetween(1, 4) * (g.coin(0.5) ? 1 : -1);
        float *x = g.coin(0.3) ? &p.g.sphere.r : (g.coin(0.5) ? &o.x : g.coin(0.5) ? &o.y : &o.z);
        for (int s = 0; s < std::abs(k); s++)
            *x = nextafterf(*x, k > 0 ? INFINITY : -INFINITY);
    }
    r = ray_make(o, dv, INFINITY);
    return true;
}

void case_sphere(int rid, Rng &g, Stats &st, uint64_t i, bool v)
{
    if (g.coin(1.0 / 3.0)) {
        for (int tries = 0; tries < 100; tries++) {
            Prim p;
            Ray r;
            if (exact_tangent(g, p, r)) {
                st.c[C_EXACTAIM]++;
                judge_single(rid, p, r, st, i, v);
                return;
            }
        }
        st.c[C_SKIP]++;
        return;
    }
    for (int tries = 0; tries < 100; tries++) {
        Scene S = scene(g);
        Prim p = make_prim(PRIM_SPHERE);
        p.g.sphere.c = fv(S.T + D3{g.uni(-1, 1), g.uni(-1, 1), g.uni(-1, 1)} * S.s);
        p.g.sphere.r = (float)(S.s * g.uni(0.1, 1.0));
        double r = p.g.sphere.r, D = r * g.logu(1.0001, 1e6);
        D3 c = d3(p.g.sphere.c);
        Vec3 o = fv(c + unit(g) * D);
        D3 w = c - d3(o);
        double Dd = lend(w);
        if (!(Dd > r))
            continue;
        D3 wh = w * (1.0 / Dd), e1, e2;
        frame(wh, e1, e2);
        double ang = g.uni(0, 6.283185307179586);
        D3 uh = e1 * std::cos(ang) + e2 * std::sin(ang);
        D3 dir;
        if (g.coin(0.5)) {
            // Near-tangent in double: the tangent direction turned by a tiny angle
            // towards (+) or away from (-) the centre.
            double sa = r / Dd, ca = std::sqrt(1 - sa * sa);
            D3 t = wh * ca + uh * sa, towards = wh - t * dotd(wh, t);
            double delta = g.coin(0.1) ? 0.0 : g.sgn() * g.logu(1e-13, 1e-5) * sa;
            dir = t + normd(towards) * delta;
        } else {
            dir = (c + uh * (r * g.uni(0, 0.999))) - d3(o);
        }
        Vec3 d = fv(dir * (1.0 / lend(dir)));
        if (g.coin(0.3))
            d = fv(dir);
        if (!(vec_max_abs(d) > 0.0f) || !vec_is_finite(d))
            continue;
        judge_single(rid, p, ray_make(o, d, INFINITY), st, i, v);
        return;
    }
    st.c[C_SKIP]++;
}

// ---------------------------------------------------------------------
// Cases 7 and 8: random hits; t accuracy, then spawned origins
// ---------------------------------------------------------------------

void case_hits(int cs, int rid, Rng &g, Stats &st, uint64_t i, bool v)
{
    Kind k = ROUTINES[rid].kind;
    for (int tries = 0; tries < 100; tries++) {
        Scene S = scene(g, 0.5);
        Prim p;
        if (!gen_prim(k, g, S, p))
            continue;
        Vec3 tgt = g.coin(0.5) ? surface_point(p, g) : interior_point(p, g), o;
        // Case 8 spawns inwards only into solids resolvable in float.
        bool inside = is_solid(k) && g.coin(cs == 8 ? 0.25 : 0.15) && (cs != 8 || solid_resolved(p));
        if (inside)
            o = interior_point(p, g);
        else
            o = fv(d3(tgt) + unit(g) * (prim_size(p) * g.logu(0.01, 1e3)));
        Ray r;
        if (!aim(o, tgt, g, 0.7, cs == 8 ? 0.0 : 0.1, r))
            continue;
        Verdict vd = judge_single(rid, p, r, st, i, v);
        if (cs == 8 && vd.code == 1)
            spawn_check(rid, p, r, vd.h, g.coin(0.3), fv(unit(g)), 4.0 * prim_size(p), st, i, v);
        return;
    }
    st.c[C_SKIP]++;
}

// ---------------------------------------------------------------------
// Case 11: ellipsoids, |A x + b| = 1 with A and b the stored a[] taken as
// exact (the routine's own primitive); built from m, as a scene would be,
// through prim_ellipsoid_init
// ---------------------------------------------------------------------

struct Mat3 {
    double v[3][3];
};
Mat3 mat_diag(double a, double b, double c)
{
    Mat3 m{};
    m.v[0][0] = a;
    m.v[1][1] = b;
    m.v[2][2] = c;
    return m;
}
Mat3 mat_mul(const Mat3 &a, const Mat3 &b)
{
    Mat3 m{};
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            for (int k = 0; k < 3; k++)
                m.v[i][j] += a.v[i][k] * b.v[k][j];
    return m;
}
// A rotation: uniform (a unit quaternion), about one coordinate axis, or a
// signed permutation (which leaves exact zeros in A).
Mat3 mat_rot(Rng &g)
{
    double u = g.uni();
    if (u < 0.2) {
        Mat3 m{};
        int perm[3] = {0, 1, 2};
        for (int k = 2; k > 0; k--)
            std::swap(perm[k], perm[g.below(k + 1)]);
        for (int i = 0; i < 3; i++)
            m.v[i][perm[i]] = g.sgn();
        return m;
    }
    if (u < 0.4) {
        int a = g.below(3), b = (a + 1) % 3, c = (a + 2) % 3;
        double th = g.uni(0, 6.283185307179586);
        Mat3 m{};
        m.v[a][a] = 1;
        m.v[b][b] = m.v[c][c] = std::cos(th);
        m.v[b][c] = -std::sin(th);
        m.v[c][b] = std::sin(th);
        return m;
    }
    double q[4], n;
    do {
        n = 0;
        for (double &x : q) {
            x = g.uni(-1, 1);
            n += x * x;
        }
    } while (n > 1.0 || n < 1e-4);
    n = std::sqrt(n);
    double w = q[0] / n, x = q[1] / n, y = q[2] / n, z = q[3] / n;
    Mat3 m;
    m.v[0][0] = 1 - 2 * (y * y + z * z);
    m.v[0][1] = 2 * (x * y - w * z);
    m.v[0][2] = 2 * (x * z + w * y);
    m.v[1][0] = 2 * (x * y + w * z);
    m.v[1][1] = 1 - 2 * (x * x + z * z);
    m.v[1][2] = 2 * (y * z - w * x);
    m.v[2][0] = 2 * (x * z - w * y);
    m.v[2][1] = 2 * (y * z + w * x);
    m.v[2][2] = 1 - 2 * (x * x + y * y);
    return m;
}

void ell_fill(Ellipsoid &E, const Mat3 &M, D3 T)
{
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            E.m[3 * i + j] = M.v[i][j];
    E.m[9] = T.x;
    E.m[10] = T.y;
    E.m[11] = T.z;
}
// |M|_F: at least the largest semi-axis.
double ell_size(const Ellipsoid &E)
{
    double s = 0;
    for (int k = 0; k < 9; k++)
        s += E.m[k] * E.m[k];
    return std::sqrt(s);
}
// M u + t: a point of the ellipsoid's surface for a unit u (to double
// precision; its float rounding is what the rays see).
D3 ell_point(const Ellipsoid &E, D3 u)
{
    const double *m = E.m;
    return D3{m[0] * u.x + m[1] * u.y + m[2] * u.z + m[9], m[3] * u.x + m[4] * u.y + m[5] * u.z + m[10],
              m[6] * u.x + m[7] * u.y + m[8] * u.z + m[11]};
}
// The outward normal at x: A^T (A x + b), from the exact primitive's a[].
D3 ell_normal(const Ellipsoid &E, D3 x)
{
    const double *a = E.a;
    double q[3];
    for (int i = 0; i < 3; i++)
        q[i] = a[3 * i] * x.x + a[3 * i + 1] * x.y + a[3 * i + 2] * x.z + a[9 + i];
    return D3{a[0] * q[0] + a[3] * q[1] + a[6] * q[2], a[1] * q[0] + a[4] * q[1] + a[7] * q[2],
              a[2] * q[0] + a[5] * q[1] + a[8] * q[2]};
}

// Float ellipsoids: M = R1 diag(s) R2 (times a shear, a third of the time),
// s up to 10^-6 .. 10^6 and axis ratios up to 10^6; centres up to 10^5 from
// the origin (none; a multiple of the size; or each coordinate log-uniform).
bool ell_float(Rng &g, Ellipsoid &E)
{
    for (int tries = 0; tries < 20; tries++) {
        double s = g.logu(1e-6, 1e6), u = g.uni();
        double lo = u < 0.25 ? 0.3 : u < 0.6 ? 1e-3 : u < 0.9 ? 1e-4 : 1e-6;
        double s1 = s * (lo >= 0.3 ? g.uni(lo, 1.0) : g.logu(lo, 1.0));
        double s2 = s * (lo >= 0.3 ? g.uni(lo, 1.0) : g.logu(lo, 1.0));
        Mat3 M = mat_mul(mat_mul(mat_rot(g), mat_diag(s, s1, s2)), mat_rot(g));
        if (g.coin(1.0 / 3.0)) {
            Mat3 S = mat_diag(1, 1, 1);
            int i = g.below(3), j = (i + 1 + g.below(2)) % 3;
            S.v[i][j] = g.sgn() * g.logu(0.01, 10.0);
            M = g.coin(0.5) ? mat_mul(M, S) : mat_mul(S, M);
        }
        D3 T{0, 0, 0};
        double v = g.uni();
        if (v < 0.4)
            T = unit(g) * std::min(1e5, s * g.logu(1e-2, 1e4));
        else if (v < 0.8)
            T = D3{g.sgn() * g.logu(1e-6, 1e5), g.sgn() * g.logu(1e-6, 1e5), g.sgn() * g.logu(1e-6, 1e5)};
        ell_fill(E, M, T);
        if (prim_ellipsoid_init(&E) == 0)
            return true;
    }
    return false;
}

// A ray from the double o along the double dir, both rounded to float;
// the direction normalised (in float, as the renderer does) with
// probability 0.7; a finite tmax around tt (the distance of interest, in
// units of dir) with probability p_tmax.
bool ell_ray(D3 o, D3 dir, double tt, Rng &g, double p_tmax, Ray &r)
{
    Vec3 of = fv(o), d = fv(dir);
    if (!vec_is_finite(of) || !vec_is_finite(d) || !(vec_max_abs(d) > 0.0f))
        return false;
    if (g.coin(0.7)) {
        Vec3 n = vec_normalize(d);
        if (vec_max_abs(n) > 0.0f && vec_is_finite(n)) {
            tt *= lend(dir) / lend(d3(n));
            d = n;
        }
    }
    float tmax = INFINITY;
    if (g.coin(p_tmax)) {
        tmax = (float)(tt * g.uni(0.5, 1.5));
        if (!(tmax > 0.0f) || !std::isfinite(tmax))
            tmax = INFINITY;
    }
    r = ray_make(of, d, tmax);
    return true;
}

// Rays at a float ellipsoid: through a surface point from outside, near or
// far; along a tangent at a surface point, turned by up to 0.3 rad either
// way (or not at all); beside a tangent, moved off it along the normal by
// 10^-12 .. 10^-1 of the size either way (near misses and near hits); from
// inside; at an interior point; from a surface point rounded to float.
bool ell_float_ray(Rng &g, const Ellipsoid &E, double size, Ray &r)
{
    D3 x = ell_point(E, unit(g)), n = ell_normal(E, x);
    if (!(lend(n) > 0) || !std::isfinite(lend(n)))
        return false;
    D3 nh = normd(n);
    double dist = size * g.logu(1e-3, 1e6), u = g.uni();
    if (u < 0.2) {
        D3 w = unit(g);
        if (dotd(w, nh) < 0)
            w = w * -1.0;
        return aim(fv(x + w * dist), fv(x), g, 0.7, 0.1, r);
    }
    D3 v = unit(g), tdir = v - nh * dotd(v, nh);
    if (!(lend(tdir) > 1e-3))
        return false;
    tdir = normd(tdir);
    if (u < 0.45) { // tangent at x, turned towards the inside (+) or out (-)
        double delta = g.coin(0.1) ? 0.0 : g.sgn() * g.logu(1e-13, 0.3);
        D3 dir = tdir - nh * delta;
        return ell_ray(x - dir * dist, dir, dist, g, 0.1, r);
    }
    if (u < 0.6) { // beside the tangent line, off it along the normal
        double eps = g.sgn() * g.logu(1e-12, 1e-1);
        D3 o = x + nh * (eps * size) - tdir * dist;
        return ell_ray(o, tdir, dist, g, 0.1, r);
    }
    if (u < 0.75) { // from inside, at a surface point or anywhere
        D3 o = ell_point(E, in_ball(g) * 0.999);
        if (g.coin(0.5))
            return aim(fv(o), fv(x), g, 0.7, 0.1, r);
        return ell_ray(o, unit(g), size, g, 0.0, r);
    }
    if (u < 0.9) { // at an interior point, from outside
        D3 tgt = ell_point(E, in_ball(g) * 0.999);
        return aim(fv(tgt + unit(g) * (size * g.logu(1e-2, 1e4))), fv(tgt), g, 0.7, 0.1, r);
    }
    // from the surface point rounded to float (the exact origin may lie
    // on either side), in any direction
    return ell_ray(x, unit(g), size, g, 0.0, r);
}

// Lattice ellipsoids, exact by construction: A = diag(2^p) U with U a
// unimodular integer matrix (1 to 4 shears by up to 64, then a signed
// permutation), so that M = A^-1 = U^-1 diag(2^-p) is a dyadic matrix and
// prim_ellipsoid_init computes A and b = -A c exactly (checked). The
// poles c +- M e_i (A x + b = +-e_i) are lattice points exactly on the
// surface, and d is exactly tangent there when (U d)_i = 0.
struct EllLattice {
    int mode = 0;       // 0 tangent, 1 through a pole transversally, 2 origin on a pole or at the centre
    bool exact = false; // a[] is the intended A, b bit for bit
    bool tangent = false, through = false; // as built, before any nudge
};

bool ell_lattice(Rng &g, Ellipsoid &E, Ray &r, EllLattice &L)
{
    typedef int64_t I3[3][3];
    I3 U = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}, V = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}; // V = U^-1
    int nsh = (int)g.ibetween(1, 4);
    int64_t K = (int64_t)1 << g.ibetween(0, 6);
    for (int s = 0; s < nsh; s++) {
        int i = g.below(3), j = (i + 1 + g.below(2)) % 3;
        int64_t k = g.ibetween(-K, K);
        for (int c = 0; c < 3; c++) // row_i(U) += k row_j(U)
            U[i][c] += k * U[j][c];
        for (int rr = 0; rr < 3; rr++) // col_j(V) -= k col_i(V)
            V[rr][j] -= k * V[rr][i];
    }
    {   // a signed permutation P: U <- P U, V <- V P^T
        int perm[3] = {0, 1, 2};
        int64_t sg[3];
        for (int k = 2; k > 0; k--)
            std::swap(perm[k], perm[g.below(k + 1)]);
        for (auto &x : sg)
            x = g.coin(0.5) ? 1 : -1;
        I3 U2, V2;
        for (int i = 0; i < 3; i++)
            for (int c = 0; c < 3; c++) {
                U2[i][c] = sg[i] * U[perm[i]][c];
                V2[c][i] = sg[i] * V[c][perm[i]];
            }
        std::memcpy(U, U2, sizeof U);
        std::memcpy(V, V2, sizeof V);
    }
    for (int i = 0; i < 3; i++)
        for (int c = 0; c < 3; c++)
            if (std::llabs(U[i][c]) > (1 << 16) || std::llabs(V[i][c]) > (1 << 16))
                return false;
    // A = diag(2^p) U; lattice unit 2^beta; M in lattice units: Mi = V diag(2^sh).
    int p[3], pmax = -100;
    for (int &x : p) {
        x = (int)g.ibetween(-3, 3);
        pmax = std::max(pmax, x);
    }
    int64_t Mi[3][3];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            Mi[i][j] = V[i][j] << (pmax - p[j]); // M = Mi 2^-pmax
    int64_t mmax = 0;
    for (auto &row : Mi)
        for (int64_t x : row)
            mmax = std::max<int64_t>(mmax, std::llabs(x));
    // Centre, pole, direction, origin in lattice units.
    L3 C{{0, 0, 0}};
    if (g.coin(0.5))
        C = lrand(g, (int64_t)1 << g.ibetween(0, 22));
    int ax = g.below(3);
    int64_t sgn = g.coin(0.5) ? 1 : -1;
    L3 X = C + L3{{Mi[0][ax] * sgn, Mi[1][ax] * sgn, Mi[2][ax] * sgn}};
    L3 urow{{U[ax][0], U[ax][1], U[ax][2]}};
    L3 dI{{0, 0, 0}}, O;
    int zero = -1; // a component of dI that is 0 by construction
    double u = g.uni();
    L.mode = u < 0.55 ? 0 : u < 0.85 ? 1 : 2;
    if (L.mode == 0) {
        L3 w;
        if (g.coin(0.5)) {
            zero = g.below(3);
            w = L3{{0, 0, 0}};
            w.v[zero] = 1;
        } else {
            w = lrand(g, (int64_t)1 << g.ibetween(0, 6));
        }
        W3 c = crossl(urow, w);
        for (int k = 0; k < 3; k++) {
            if (c.v[k] > ((i128)1 << 23) || c.v[k] < -((i128)1 << 23))
                return false;
            dI.v[k] = (int64_t)c.v[k];
        }
        if (zerol(dI))
            return false;
        O = X - dI * g.ibetween(1, (int64_t)1 << g.ibetween(0, 10));
    } else if (L.mode == 1) {
        dI = lrand(g, (int64_t)1 << g.ibetween(0, 12));
        if (dotw(W3{{urow.v[0], urow.v[1], urow.v[2]}}, dI) == 0)
            return false;
        O = X - dI * g.ibetween(1, (int64_t)1 << g.ibetween(0, 10));
    } else {
        dI = lrand(g, (int64_t)1 << g.ibetween(0, 12));
        if (zerol(dI))
            return false;
        O = g.coin(0.6) ? X : C;
    }
    const int64_t LIM = ((int64_t)1 << 24) - 1;
    if (maxabs(C) > LIM || maxabs(X) > LIM || maxabs(O) > LIM || maxabs(dI) > LIM || mmax > LIM)
        return false;
    // Scale: lattice unit 2^beta, coordinates from about 2^-20 to 2^40.
    int b;
    std::frexp((double)std::max({maxabs(C), maxabs(O), mmax, (int64_t)1}), &b);
    int beta = (int)g.ibetween(-20, 40) - b;
    // World: x = X 2^beta, and M = Mi 2^beta (M e_i is column i of Mi in
    // lattice units), so A = M^-1 has A_ij = U_ij 2^(p_i - pmax - beta).
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            E.m[3 * i + j] = std::ldexp((double)Mi[i][j], beta);
    for (int k = 0; k < 3; k++)
        E.m[9 + k] = std::ldexp((double)C.v[k], beta);
    if (prim_ellipsoid_init(&E) != 0)
        return false;
    // Mi = V diag(2^(pmax - p)), so Mi^-1 = diag(2^(p - pmax)) U, and
    // A = Mi^-1 2^-beta; b = -A c = -(U C)_i 2^(p_i - pmax).
    L.exact = true;
    for (int i = 0; i < 3; i++) {
        int64_t uc = 0;
        for (int j = 0; j < 3; j++) {
            if (E.a[3 * i + j] != std::ldexp((double)U[i][j], p[i] - pmax - beta))
                L.exact = false;
            uc += U[i][j] * C.v[j];
        }
        if (E.a[9 + i] != -std::ldexp((double)uc, p[i] - pmax))
            L.exact = false;
    }
    // The direction's scale: mostly its largest component in [1/2, 1).
    int db;
    std::frexp((double)maxabs(dI), &db);
    int de = g.coin(0.3) ? (int)g.ibetween(-8, 8) - db : -db;
    Vec3 o = vec3((float)std::ldexp((double)O.v[0], beta), (float)std::ldexp((double)O.v[1], beta),
                  (float)std::ldexp((double)O.v[2], beta));
    Vec3 d = vec3((float)std::ldexp((double)dI.v[0], de), (float)std::ldexp((double)dI.v[1], de),
                  (float)std::ldexp((double)dI.v[2], de));
    L.tangent = L.mode == 0;
    L.through = L.mode == 1;
    if (L.mode == 0) {
        double w = g.uni();
        if (w < 0.35 && zero >= 0) {
            // grazing: d's zero component tilted to +-2^-k of its largest,
            // k in [8, 60] (relative discriminants across the band's edge)
            float m = vec_max_abs(d);
            setf(d, zero, (float)(g.sgn() * std::ldexp((double)m, -(int)g.ibetween(8, 60))));
            L.tangent = false;
        } else if (w < 0.6) {
            // a few ulps off: one coordinate of o or d
            int k = (int)g.ibetween(1, 4) * (g.coin(0.5) ? 1 : -1), c = g.below(3);
            Vec3 &v = g.coin(0.7) ? o : d;
            float x = compf(v, c);
            for (int s = 0; s < std::abs(k); s++)
                x = nextafterf(x, k > 0 ? INFINITY : -INFINITY);
            setf(v, c, x);
            L.tangent = false;
        }
    }
    r = ray_make(o, d, INFINITY);
    return vec_is_finite(o) && vec_is_finite(d);
}

void case_ellipsoid(int rid, Rng &g, Stats &st, uint64_t i, bool v)
{
    for (int tries = 0; tries < 100; tries++) {
        Ellipsoid E;
        std::memset(&E, 0, sizeof E);
        Ray r;
        EllLattice L;
        bool lattice = g.coin(0.3);
        if (lattice) {
            if (!ell_lattice(g, E, r, L))
                continue;
        } else {
            if (!ell_float(g, E) || !ell_float_ray(g, E, ell_size(E), r))
                continue;
        }
        Prim p = make_prim(PRIM_ELLIPSOID);
        p.g.ell.e = &E;
        p.g.ell.index = 0;
        if (lattice && L.exact && L.tangent) {
            st.c[C_EXACTAIM]++;
            int s = ell_disc_sign(p, r);
            if (s != 0) {
                st.c[C_INTERNAL]++;
                st.fail(i, "internal", "lattice ray built tangent has discriminant sign " + std::to_string(s) + ": " +
                                           fmt_prim(p) + " " + fmt_ray(r));
            }
        }
        if (lattice && L.exact && L.through) {
            st.c[C_EXACTTHRU]++;
            if (!exact_hit(p, r)) {
                st.c[C_INTERNAL]++;
                st.fail(i, "internal", "lattice ray built through a surface point does not hit: " + fmt_prim(p) + " " +
                                           fmt_ray(r));
            }
        }
        Verdict vd = judge_single(rid, p, r, st, i, v);
        if (vd.code == 1)
            spawn_check(rid, p, r, vd.h, g.coin(0.3), fv(unit(g)), 4.0 * ell_size(E), st, i, v);
        return;
    }
    st.c[C_SKIP]++;
}

// ---------------------------------------------------------------------
// The driver
// ---------------------------------------------------------------------

const char *CASE_NAMES[13] = {"",           "1-interior", "2-mesh",       "3-shared-edge", "4-box-edge", "5-degenerate",
                              "6-sphere",   "7-t-accuracy", "8-self-hit", "9-pn-boxes",   "10-pn-rays",
                              "11-ellipsoid", "12-far-and-tiny"};
const int N_CASES = 12;

std::vector<int> case_routines(int cs)
{
    switch (cs) {
    case 2:
    case 3: return {R_TRI, R_TRI_WT};
    case 4: return {R_BOX, R_BOX_ROB, R_OBOX, R_OBOX_ROB};
    case 6: return {R_SPHERE, R_SPHERE_ROB};
    case 9: return {R_PN_BOX};
    case 10: return {R_PN_EXACT, R_PN_FAST, R_PN_PIECES};
    case 11: return {R_ELL, R_ELL_ROB};
    default: {
        std::vector<int> all;
        for (int r = 0; r < N_ROUTINES; r++)
            if (ROUTINES[r].kind != K_PN && ROUTINES[r].kind != K_ELL)
                all.push_back(r);
        return all;
    }
    }
}

uint64_t g_seed = 0x1a2b3c4d5e6f7788ULL;
const uint64_t PN_RAY_DIVISOR = 2000;
// Case 11 runs 1/ELL_RAY_DIVISOR as many rays as cases 1 and 5-8: all of
// them (about 10 s at 10^6 on 2 idle cores; raise it if that grows past 15).
const uint64_t ELL_RAY_DIVISOR = 1;

void run_ray(int cs, int rid, uint64_t i, Stats &st, bool v)
{
    Rng g(ray_seed(g_seed, cs, rid, i));
    try {
        switch (cs) {
        case 1: case_interior(rid, g, st, i, v); break;
        case 2: mesh_ray(rid, g_seed, i, st, v); break;
        case 3: case_shared_edge(rid, g, st, i, v); break;
        case 4: case_box_edge(rid, g, st, i, v); break;
        case 5: case_degenerate(rid, g, st, i, v); break;
        case 6: case_sphere(rid, g, st, i, v); break;
        case 7:
        case 8: case_hits(cs, rid, g, st, i, v); break;
        case 9: pn_box_ray(rid, g, st, i, v); break;
        case 10: pn_ray(rid, g, st, i, v); break;
        case 11: case_ellipsoid(rid, g, st, i, v); break;
        case 12: case_interior(rid, g, st, i, v, true); break;
        }
    } catch (const std::exception &e) {
        st.c[C_INTERNAL]++;
        st.fail(i, "internal", std::string("exception: ") + e.what());
    }
}

struct Job {
    int cs, rid;
    uint64_t n;
};

bool write_all(int fd, const void *buf, size_t n)
{
    const char *p = (const char *)buf;
    while (n > 0) {
        ssize_t k = write(fd, p, n);
        if (k < 0 && errno == EINTR)
            continue;
        if (k <= 0)
            return false;
        p += k;
        n -= (size_t)k;
    }
    return true;
}

bool read_all(int fd, void *buf, size_t n)
{
    char *p = (char *)buf;
    while (n > 0) {
        ssize_t k = read(fd, p, n);
        if (k < 0 && errno == EINTR)
            continue;
        if (k <= 0)
            return false;
        p += k;
        n -= (size_t)k;
    }
    return true;
}

std::string fmt_ulp(const std::vector<double> &u, double q)
{
    if (u.empty())
        return "nan";
    size_t k = (size_t)std::floor(q * (double)(u.size() - 1));
    char b[32];
    std::snprintf(b, sizeof b, "%.3g", u[k]);
    return b;
}

// Prints the line and the failure details; returns the failed criteria.
std::vector<std::string> report(const Job &j, Stats &st, bool details)
{
    const Routine &R = ROUTINES[j.rid];
    std::sort(st.ulp.begin(), st.ulp.end());
    typedef unsigned long long ull;
    std::printf("exact: %s %s rays=%llu agree=%llu false_miss=%llu false_hit=%llu t_ulp_p50=%s t_ulp_p99=%s "
                "t_ulp_max=%s band=%llu outside_band=%llu t_bound_fail=%llu",
                CASE_NAMES[j.cs], R.name, (ull)st.c[C_RAYS], (ull)st.c[C_AGREE], (ull)st.c[C_FMISS],
                (ull)st.c[C_FHIT], fmt_ulp(st.ulp, 0.5).c_str(), fmt_ulp(st.ulp, 0.99).c_str(),
                fmt_ulp(st.ulp, 1.0).c_str(), (ull)st.c[C_BAND], (ull)st.c[C_OUTBAND], (ull)st.c[C_TBFAIL]);
    if (j.cs == 8 || j.cs == 11)
        std::printf(" self_hit=%llu spawned=%llu", (ull)st.c[C_SELFHIT], (ull)st.c[C_SPAWN]);
    if (j.cs != 2 && j.cs != 3) {
        if (R.kind == K_SPHERE || R.kind == K_ELL)
            std::printf(" near_tangent=%llu", (ull)st.c[C_NEARBAND]);
        else if (R.kind == K_PLANE)
            std::printf(" near_parallel=%llu", (ull)st.c[C_NEARBAND]);
        else if (R.kind == K_TRI)
            std::printf(" near_edge=%llu", (ull)st.c[C_NEARBAND]);
    }
    if (j.cs >= 2 && j.cs <= 4)
        std::printf(" exact_aim=%llu", (ull)st.c[C_EXACTAIM]);
    if (j.cs == 6 || j.cs == 11)
        std::printf(" exact_tangent=%llu", (ull)st.c[C_EXACTAIM]);
    if (j.cs == 11)
        std::printf(" exact_through=%llu false_miss_band=%llu false_hit_band=%llu spawn_skipped=%llu",
                    (ull)st.c[C_EXACTTHRU], (ull)st.c[C_FMISS_BAND], (ull)st.c[C_FHIT_BAND], (ull)st.c[C_SPAWNSKIP]);
    if (j.cs == 2 || j.cs == 3)
        std::printf(" tri_miss=%llu", (ull)st.c[C_TRIMISS]);
    if (j.cs == 9)
        std::printf(" box_fail=%llu", (ull)st.c[C_BOXFAIL]);
    if (j.cs == 10)
        std::printf(" near_surface=%llu uv_fail=%llu undecided=%llu", (ull)st.c[C_NEARBAND], (ull)st.c[C_UVFAIL],
                    (ull)st.c[C_UNDECIDED]);
    if (st.c[C_SKIP])
        std::printf(" skipped=%llu", (ull)st.c[C_SKIP]);
    if (st.c[C_INTERNAL])
        std::printf(" internal=%llu", (ull)st.c[C_INTERNAL]);
    std::printf(" outside_band_nonunit=%llu\n", (ull)st.c[C_OB_NONUNIT]);

    std::vector<std::string> bad;
    auto crit = [&](bool failed, const char *what) {
        if (failed)
            bad.push_back(std::string(CASE_NAMES[j.cs]) + " " + R.name + " " + what);
    };
    crit(st.c[C_INTERNAL] > 0, "internal>0 (a judge self-check failed)");
    if (R.robust) {
        crit((j.cs >= 2 && j.cs <= 4) && st.c[C_FMISS] > 0, "false_miss>0");
        crit(st.c[C_SELFHIT] > 0, "self_hit>0");
        crit(st.c[C_TBFAIL] > 0, "t_bound_fail>0");
        crit(st.c[C_OUTBAND] > 0, "outside_band>0");
        crit(st.c[C_BOXFAIL] > 0, "box_fail>0");
        crit(st.c[C_UVFAIL] > 0, "uv_fail>0");
    }
    // Details: every failure kind for robust routines; classic ones are only
    // measured (their details with --details).
    std::sort(st.fails.begin(), st.fails.end(), [](const Fail &a, const Fail &b) { return a.ray < b.ray; });
    std::map<std::string, int> shown;
    for (const Fail &f : st.fails) {
        bool is_failure = f.kind.rfind("false_miss_in_band", 0) != 0;
        if (!(details || (R.robust && is_failure) || f.kind == "internal"))
            continue;
        if (shown[f.kind]++ >= 3)
            continue;
        std::printf("  %s ray=%llu: %s\n", f.kind.c_str(), (unsigned long long)f.ray, f.text.c_str());
        std::printf("    replay: build/exact/judge --case %d --routine %s --ray %llu -v\n", j.cs, R.name,
                    (unsigned long long)f.ray);
    }
    std::fflush(stdout);
    return bad;
}

// Parses what fmt_prim and fmt_ray print: "KIND key=(x,y,z) key=x ...",
// numbers in any strtof syntax (hex floats are exact); kvd, when given, gets
// the same numbers by strtod (an ellipsoid's doubles).
bool parse_kv(const std::string &s, std::string &kind, std::map<std::string, std::vector<float>> &kv,
              std::map<std::string, std::vector<double>> *kvd = nullptr)
{
    size_t at = s.find_first_not_of(' ');
    if (at == std::string::npos)
        return false;
    size_t sp = s.find(' ', at);
    kind = s.substr(at, sp - at);
    while (sp != std::string::npos) {
        at = s.find_first_not_of(' ', sp);
        if (at == std::string::npos)
            break;
        size_t eq = s.find('=', at);
        if (eq == std::string::npos)
            return false;
        std::string key = s.substr(at, eq - at), val;
        size_t end = s.find(' ', eq);
        val = s.substr(eq + 1, end == std::string::npos ? std::string::npos : end - eq - 1);
        sp = end;
        std::vector<float> xs;
        std::vector<double> xd;
        std::string inner = val;
        if (!inner.empty() && inner[0] == '(')
            inner = inner.substr(1, inner.size() - 2);
        for (size_t p = 0; p <= inner.size();) {
            size_t q = inner.find(',', p);
            std::string num = inner.substr(p, q == std::string::npos ? std::string::npos : q - p);
            char *e = nullptr;
            xs.push_back(std::strtof(num.c_str(), &e));
            if (e == num.c_str())
                return false;
            xd.push_back(std::strtod(num.c_str(), nullptr));
            if (q == std::string::npos)
                break;
            p = q + 1;
        }
        kv[key] = xs;
        if (kvd)
            (*kvd)[key] = xd;
    }
    return true;
}

Vec3 v3of(const std::vector<float> &x) { return x.size() == 3 ? vec3(x[0], x[1], x[2]) : vec3(NAN, NAN, NAN); }

// --check "PRIM" "RAY": judges both variants of the primitive's routines on
// one input, verbosely.
int check_one(const std::string &ps, const std::string &rs)
{
    std::string kind, rk;
    std::map<std::string, std::vector<float>> a, b;
    std::map<std::string, std::vector<double>> ad;
    Ellipsoid E;
    std::memset(&E, 0, sizeof E);
    if (!parse_kv(ps, kind, a, &ad) || !parse_kv(rs, rk, b) || rk != "ray" || !b.count("o") || !b.count("d")) {
        std::fprintf(stderr, "judge: --check: cannot parse; give e.g. \"sphere c=(0,0,0) r=1\" \"ray o=(0,0,-5) d=(0,0,1) tmax=inf\"\n");
        return 2;
    }
    Prim p;
    int rid;
    auto sc = [&](const char *k) { return a.count(k) && !a[k].empty() ? a[k][0] : NAN; };
    if (kind == "plane") {
        p = make_prim(PRIM_PLANE);
        p.g.plane.n = v3of(a["n"]);
        p.g.plane.d = sc("d");
        rid = R_PLANE;
    } else if (kind == "sphere") {
        p = make_prim(PRIM_SPHERE);
        p.g.sphere.c = v3of(a["c"]);
        p.g.sphere.r = sc("r");
        rid = R_SPHERE;
    } else if (kind == "triangle") {
        p = make_prim(PRIM_TRIANGLE);
        p.g.tri.a = v3of(a["a"]);
        p.g.tri.b = v3of(a["b"]);
        p.g.tri.c = v3of(a["c"]);
        rid = R_TRI;
    } else if (kind == "box") {
        p = make_prim(PRIM_BOX);
        p.g.box.lo = v3of(a["lo"]);
        p.g.box.hi = v3of(a["hi"]);
        rid = R_BOX;
    } else if (kind == "obox") {
        p = make_prim(PRIM_OBOX);
        p.g.obox.c = v3of(a["c"]);
        p.g.obox.u = v3of(a["u"]);
        p.g.obox.v = v3of(a["v"]);
        p.g.obox.w = v3of(a["w"]);
        if (prim_obox_init(&p.g.obox) != 0) {
            std::fprintf(stderr, "judge: --check: prim_obox_init failed\n");
            return 2;
        }
        rid = R_OBOX;
    } else if (kind == "ellipsoid") {
        // m (12 doubles: rows of M, then t) through prim_ellipsoid_init; or
        // a as printed (the exact primitive), kept as given
        if (!ad.count("m") || ad["m"].size() != 12 || (ad.count("a") && ad["a"].size() != 12)) {
            std::fprintf(stderr, "judge: --check: an ellipsoid needs m=(12 numbers) and optionally a=(12 numbers)\n");
            return 2;
        }
        for (int k = 0; k < 12; k++)
            E.m[k] = ad["m"][k];
        if (ad.count("a")) {
            for (int k = 0; k < 12; k++)
                E.a[k] = ad["a"][k];
        } else if (prim_ellipsoid_init(&E) != 0) {
            std::fprintf(stderr, "judge: --check: prim_ellipsoid_init failed\n");
            return 2;
        }
        p = make_prim(PRIM_ELLIPSOID);
        p.g.ell.e = &E;
        rid = R_ELL;
    } else {
        std::fprintf(stderr, "judge: --check: unknown primitive %s\n", kind.c_str());
        return 2;
    }
    Ray r = ray_make(v3of(b["o"]), v3of(b["d"]), b.count("tmax") && !b["tmax"].empty() ? b["tmax"][0] : INFINITY);
    for (int k = rid; k <= rid + 1; k++) {
        Stats st;
        std::printf("%s:\n", ROUTINES[k].name);
        Verdict v = judge_single(k, p, r, st, 0, true);
        if (v.code == 1) // case 8's check, with the spawned ray going back along -d
            spawn_check(k, p, r, v.h, true, vec3(0, 0, 0),
                        4.0 * (p.kind == PRIM_ELLIPSOID ? ell_size(*p.g.ell.e) : prim_size(p)), st, 0, true);
    }
    return 0;
}

int usage()
{
    std::fprintf(stderr, "usage: judge [RAYS_PER_CASE] [--jobs N] [--case 1,2,...] [--routine NAME] [--ray I]\n"
                         "             [--seed S] [--data DIR] [--details] [-v]\n"
                         "       judge --check PRIM RAY     (as printed, e.g. \"box lo=(0,0,0) hi=(1,1,1)\" \"ray o=(..) d=(..) tmax=inf\";\n"
                         "                                   an ellipsoid: \"ellipsoid m=(12 numbers) [a=(12 numbers)]\", a kept as given)\n");
    return 2;
}

} // namespace

int main(int argc, char **argv)
{
    uint64_t rays = 100000;
    int jobs = (int)sysconf(_SC_NPROCESSORS_ONLN);
    std::set<int> cases;
    std::string routine, data = "build/cgal-data/meshes";
    long long one_ray = -1;
    bool verbose = false, details = false;
    for (int a = 1; a < argc; a++) {
        std::string s = argv[a];
        auto next = [&]() -> std::string {
            if (a + 1 >= argc) {
                std::exit(usage());
            }
            return argv[++a];
        };
        if (s == "--jobs" || s == "-j")
            jobs = std::atoi(next().c_str());
        else if (s == "--case") {
            std::string l = next();
            for (size_t p = 0; p < l.size();) {
                size_t q = l.find(',', p);
                cases.insert(std::atoi(l.substr(p, q - p).c_str()));
                p = q == std::string::npos ? l.size() : q + 1;
            }
        } else if (s == "--routine")
            routine = next();
        else if (s == "--ray")
            one_ray = std::atoll(next().c_str());
        else if (s == "--seed")
            g_seed = std::strtoull(next().c_str(), nullptr, 0);
        else if (s == "--data")
            data = next();
        else if (s == "--details")
            details = true;
        else if (s == "-v")
            verbose = true;
        else if (s == "--check") {
            std::string ps = next(), rs = next();
            return check_one(ps, rs);
        }
        else if (!s.empty() && s[0] != '-')
            rays = std::strtoull(s.c_str(), nullptr, 10);
        else
            return usage();
    }
    if (cases.empty())
        for (int c = 1; c <= N_CASES; c++)
            cases.insert(c);
    jobs = std::max(1, std::min(jobs, 64));

    std::vector<Job> js;
    for (int cs : cases) {
        if (cs < 1 || cs > N_CASES)
            return usage();
        std::vector<int> rs = case_routines(cs);
        std::vector<int> sel;
        for (int r : rs)
            if (routine.empty() || routine == ROUTINES[r].name)
                sel.push_back(r);
        // case 9's "rays" are patches split along a path of up to 14
        // levels, each a box, and case 10's are each an exact subdivision
        // to below float precision: fewer of them keep their time in line
        uint64_t per = cs == 9 ? 16 : cs == 10 ? PN_RAY_DIVISOR : cs == 11 ? ELL_RAY_DIVISOR : 1;
        for (int r : sel)
            js.push_back(Job{cs, r, std::max<uint64_t>(1, rays / rs.size() / per)});
    }
    if (js.empty()) {
        std::fprintf(stderr, "judge: nothing selected\n");
        return 2;
    }
    auto t0 = std::chrono::steady_clock::now();
    if (cases.count(2)) {
        std::string err;
        if (!mesh_setup(data, g_seed, verbose, err)) {
            std::printf("judge: FAIL case 2 setup: %s\n", err.c_str());
            return 1;
        }
    }
    if (one_ray >= 0) {
        for (const Job &j : js) {
            Stats st;
            std::printf("case %s routine %s ray %lld\n", CASE_NAMES[j.cs], ROUTINES[j.rid].name, one_ray);
            run_ray(j.cs, j.rid, (uint64_t)one_ray, st, true);
            report(j, st, true);
        }
        return 0;
    }
    std::printf("judge: rays_per_case=%llu jobs=%d seed=0x%llx\n", (unsigned long long)rays, jobs,
                (unsigned long long)g_seed);
    std::fflush(stdout);

    std::vector<int> fds(jobs);
    std::vector<pid_t> pids(jobs);
    for (int w = 0; w < jobs; w++) {
        int pfd[2];
        if (pipe(pfd) != 0) {
            std::perror("pipe");
            return 2;
        }
        pid_t pid = fork();
        if (pid < 0) {
            std::perror("fork");
            return 2;
        }
        if (pid == 0) {
            close(pfd[0]);
            for (const Job &j : js) {
                Stats st;
                for (uint64_t i = (uint64_t)w; i < j.n; i += (uint64_t)jobs)
                    run_ray(j.cs, j.rid, i, st, verbose);
                std::string msg = st.serialize();
                uint64_t len = msg.size();
                if (!write_all(pfd[1], &len, sizeof len) || !write_all(pfd[1], msg.data(), msg.size()))
                    _exit(3);
            }
            close(pfd[1]);
            _exit(0);
        }
        close(pfd[1]);
        fds[w] = pfd[0];
        pids[w] = pid;
    }
    std::vector<std::string> bad;
    auto tc = std::chrono::steady_clock::now();
    for (size_t k = 0; k < js.size(); k++) {
        Stats total;
        for (int w = 0; w < jobs; w++) {
            uint64_t len;
            std::string msg;
            if (!read_all(fds[w], &len, sizeof len)) {
                std::printf("judge: FAIL worker %d died during case %s %s\n", w, CASE_NAMES[js[k].cs],
                            ROUTINES[js[k].rid].name);
                return 2;
            }
            msg.resize(len);
            if (!read_all(fds[w], &msg[0], len)) {
                std::printf("judge: FAIL worker %d died\n", w);
                return 2;
            }
            total.merge(Stats::deserialize(msg));
        }
        std::vector<std::string> b = report(js[k], total, details);
        bad.insert(bad.end(), b.begin(), b.end());
        if (k + 1 == js.size() || js[k + 1].cs != js[k].cs) {
            auto now = std::chrono::steady_clock::now();
            std::printf("judge: case %s took %.1f s\n", CASE_NAMES[js[k].cs],
                        std::chrono::duration<double>(now - tc).count());
            tc = now;
        }
    }
    int status_all = 0;
    for (int w = 0; w < jobs; w++) {
        int status;
        waitpid(pids[w], &status, 0);
        if (!WIFEXITED(status) || WEXITSTATUS(status) != 0)
            status_all = 1;
    }
    double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (status_all) {
        std::printf("judge: FAIL a worker exited abnormally\n");
        return 2;
    }
    if (bad.empty()) {
        std::printf("judge: PASS (%.1f s)\n", secs);
        return 0;
    }
    std::printf("judge: FAIL (%.1f s), %zu criteria:\n", secs, bad.size());
    for (const std::string &b : bad)
        std::printf("judge:   %s\n", b.c_str());
    return 1;
}
