// pn.cpp - the PN patches of src/pntri.c, judged exactly.
//
// The exact patch is the cubic Bezier triangle of the float control net
// (pntri.h: the net *is* the patch), its sub-patches got by exact midpoint
// subdivision: every value is a dyadic rational of a few hundred bits,
// which MPFR at PREC bits holds exactly (each operation's ternary value is
// checked). The predicates (ray against box, the hit certificate) are
// computed in GMP rationals.
//
// Case 9, the boxes: a random patch split along a random path of up to 14
// levels by pn_net_split; at every level, every control point of the exact
// sub-patch must lie in pn_net_box's box. A Bezier triangle lies in the
// convex hull of its control points, so a box that holds them holds the
// exact sub-patch.
//
// Case 10, the rays: pn_hit in each mode, and exact mode through pieces
// split ahead of rays (pn_hit_piece, and for every other ray
// pn_hit_piece_rays), against the exact patch. The exact
// side subdivides down to boxes half the band wide (the band, beta, is one
// float spacing of the patch's largest coordinate), keeping the sub-patches
// whose box, grown by 8 beta, the ray meets. It certifies a hit
// in a sub-patch by a degree argument (below) that holds even if the
// sub-patch moved by beta. Then:
//   - a float miss where a hit is certified is a false miss, outside the
//     band (unless the hit is within 16 beta of the origin: a ray leaving
//     the surface does not hit its own spot, pntri.c);
//   - a float hit agrees when [t - terr, t + terr] overlaps the ray's
//     interval in a leaf box; it is a false hit in the band when it only
//     overlaps a grown one; otherwise a false hit outside the band, or a
//     t_bound_fail when the ray does meet the patch's boxes elsewhere;
//   - t - terr may not lie beyond a certified hit (t_bound_fail);
//   - the patch's point at the float (u, v) must lie within 8 beta plus
//     2 terr |d| of the ray's point at t (uv_fail).
#include "judge.h"

#include <cfloat>
#include <cstdio>
#include <cstring>
#include <algorithm>

#include <gmpxx.h>
#include <mpfr.h>

extern "C" {
#include "lancer/pntri.h"
}

namespace judge {

namespace {

// Float exponents span 2^-149 to 2^128 and each level adds three bits
// (three halvings): PREC holds every value exactly for the depths used here,
// and an inexact step is caught (Inexact) rather than trusted.
const mpfr_prec_t PREC = 640;
const int BOX_DEPTH = 14;  // case 9's longest path
const int RAY_DEPTH = 60;  // case 10's deepest split
const long RAY_NODES = 30000; // case 10's work cap per ray (beyond it: undecided)

struct Inexact {};

inline void exact_op(int ternary)
{
    if (ternary != 0)
        throw Inexact();
}

struct XNet {
    mpfr_t b[10][3];
    XNet()
    {
        for (auto &p : b)
            for (auto &x : p)
                mpfr_init2(x, PREC);
    }
    ~XNet()
    {
        for (auto &p : b)
            for (auto &x : p)
                mpfr_clear(x);
    }
    XNet(const XNet &) = delete;
    XNet &operator=(const XNet &) = delete;
    void set(const XNet &o)
    {
        for (int i = 0; i < 10; i++)
            for (int a = 0; a < 3; a++)
                mpfr_set(b[i][a], o.b[i][a], MPFR_RNDN);
    }
};

// The blossom's arguments, as barycentric weights of the parent's P1, P2,
// P3: the corners and the edge midpoints.
enum { E1, E2, E3, M23, M31, M12, NARG };
const int WEIGHT2[NARG][3] = {{2, 0, 0}, {0, 2, 0}, {0, 0, 2}, {0, 1, 1}, {1, 0, 1}, {1, 1, 0}}; // twice the weights
// Each child's corners (its P1, P2, P3), as pn_net_split orders its children.
const int CHILD[4][3] = {{E1, M12, M31}, {M12, E2, M23}, {M31, M23, E3}, {M23, M31, M12}};

// Point (i, k) of a degree-n net (j = n - i - k), as PN_AT for n = 3.
inline int at(int n, int i, int k) { return (n - i) * (n - i + 1) / 2 + k; }

// Midpoint subdivision by the blossom B(x, y, z) of the cubic: child c's
// b_ijk = B(C0^i, C1^j, C2^k) for its corners C0, C1, C2, every blossom
// value computed once by three de Casteljau steps from the parent's net.
struct Splitter {
    mpfr_t l1[NARG][6][3], l2[NARG][NARG][3][3], l3[NARG][NARG][NARG][3];
    Splitter()
    {
        for (auto &a : l1)
            for (auto &p : a)
                for (auto &x : p)
                    mpfr_init2(x, PREC);
        for (auto &a : l2)
            for (auto &b : a)
                for (auto &p : b)
                    for (auto &x : p)
                        mpfr_init2(x, PREC);
        for (auto &a : l3)
            for (auto &b : a)
                for (auto &c : b)
                    for (auto &x : c)
                        mpfr_init2(x, PREC);
    }
    ~Splitter()
    {
        for (auto &a : l1)
            for (auto &p : a)
                for (auto &x : p)
                    mpfr_clear(x);
        for (auto &a : l2)
            for (auto &b : a)
                for (auto &p : b)
                    for (auto &x : p)
                        mpfr_clear(x);
        for (auto &a : l3)
            for (auto &b : a)
                for (auto &c : b)
                    for (auto &x : c)
                        mpfr_clear(x);
    }
    Splitter(const Splitter &) = delete;
    Splitter &operator=(const Splitter &) = delete;

    // One de Casteljau step of the degree-n net `in` at argument g, into
    // `out` (degree n - 1): out_ijk = w1 in_(i+1)jk + w2 in_i(j+1)k + w3 in_ij(k+1).
    static void step(mpfr_t (*in)[3], int n, int g, mpfr_t (*out)[3])
    {
        const int *w = WEIGHT2[g];
        for (int i = 0; i <= n - 1; i++)
            for (int k = 0; k <= n - 1 - i; k++) {
                const int src[3] = {at(n, i + 1, k), at(n, i, k), at(n, i, k + 1)};
                mpfr_t *o = out[at(n - 1, i, k)];
                int s0 = -1, s1 = -1;
                for (int v = 0; v < 3; v++)
                    if (w[v] == 2)
                        s0 = src[v];
                    else if (w[v] == 1)
                        (s0 < 0 ? s0 : s1) = src[v];
                for (int a = 0; a < 3; a++)
                    if (s1 < 0)
                        mpfr_set(o[a], in[s0][a], MPFR_RNDN);
                    else {
                        exact_op(mpfr_add(o[a], in[s0][a], in[s1][a], MPFR_RNDN));
                        exact_op(mpfr_div_2ui(o[a], o[a], 1, MPFR_RNDN));
                    }
            }
    }

    void split(const XNet &in, XNet *kid[4])
    {
        mpfr_t(*net)[3] = const_cast<mpfr_t(*)[3]>(in.b);
        for (int a = 0; a < NARG; a++)
            step(net, 3, a, l1[a]);
        for (int a = 0; a < NARG; a++)
            for (int b = a; b < NARG; b++)
                step(l1[a], 2, b, l2[a][b]);
        for (int a = 0; a < NARG; a++)
            for (int b = a; b < NARG; b++)
                for (int c = b; c < NARG; c++)
                    step(l2[a][b], 1, c, &l3[a][b][c]);
        for (int c = 0; c < 4; c++) {
            if (!kid[c])
                continue;
            for (int i = 0; i <= 3; i++)
                for (int k = 0; k <= 3 - i; k++) {
                    int g[3], n = 0;
                    for (int t = 0; t < i; t++)
                        g[n++] = CHILD[c][0];
                    for (int t = 0; t < 3 - i - k; t++)
                        g[n++] = CHILD[c][1];
                    for (int t = 0; t < k; t++)
                        g[n++] = CHILD[c][2];
                    std::sort(g, g + 3);
                    for (int a = 0; a < 3; a++)
                        mpfr_set(kid[c]->b[at(3, i, k)][a], l3[g[0]][g[1]][g[2]][a], MPFR_RNDN);
                }
        }
    }
};

Splitter &splitter()
{
    static Splitter s; // the judge's workers are processes, each one-threaded
    return s;
}

Vec3 unit(double x, double y, double z)
{
    double l = std::sqrt(x * x + y * y + z * z);
    return vec3((float)(x / l), (float)(y / l), (float)(z / l));
}

// A random patch: a triangle at scale s, centred up to 10^5 s away; normals
// the face's turned by up to about 60 degrees. False (counted skipped) when
// the triangle or its net is degenerate.
bool random_patch(Rng &g, Stats &st, PnPatch &pn, double &s, double &off)
{
    s = g.logu(1e-6, 1e6);
    off = g.coin(0.3) ? 0.0 : g.logu(1e-3, 1e5);
    double c[3] = {g.sgn() * off * s, g.sgn() * off * s, g.sgn() * off * s};
    Vec3 p[3];
    for (int k = 0; k < 3; k++)
        p[k] = vec3((float)(c[0] + s * g.uni(-1, 1)), (float)(c[1] + s * g.uni(-1, 1)), (float)(c[2] + s * g.uni(-1, 1)));
    Vec3 e1 = vec_sub(p[1], p[0]), e2 = vec_sub(p[2], p[0]), fn = vec_cross(e1, e2);
    if (!(vec_max_abs(fn) > 0.0f) || !vec_is_finite(fn)) {
        st.c[C_SKIP]++;
        return false;
    }
    Vec3 n[3];
    double fl = std::sqrt((double)vec_dot(fn, fn));
    for (int k = 0; k < 3; k++)
        n[k] = unit(fn.x / fl + g.uni(-1, 1), fn.y / fl + g.uni(-1, 1), fn.z / fl + g.uni(-1, 1));
    pn_patch_init(&pn, p, n);
    for (int i = 0; i < 10; i++)
        if (!vec_is_finite(pn.b[i])) {
            st.c[C_SKIP]++;
            return false;
        }
    return true;
}

void root_net(const PnPatch &pn, XNet &x)
{
    for (int i = 0; i < 10; i++) {
        mpfr_set_flt(x.b[i][0], pn.b[i].x, MPFR_RNDN);
        mpfr_set_flt(x.b[i][1], pn.b[i].y, MPFR_RNDN);
        mpfr_set_flt(x.b[i][2], pn.b[i].z, MPFR_RNDN);
    }
}

// The patch's point at (u, v), by de Casteljau in double from the float
// net (the judge's own, for targets and the uv check; its rounding is far
// below a float spacing).
void eval(const PnPatch &pn, double u, double v, double out[3])
{
    double w = 1.0 - u - v, q[10][3], r[10][3];
    for (int i = 0; i < 10; i++) {
        q[i][0] = pn.b[i].x;
        q[i][1] = pn.b[i].y;
        q[i][2] = pn.b[i].z;
    }
    for (int n = 3; n > 0; n--) {
        for (int i = 0; i <= n - 1; i++)
            for (int k = 0; k <= n - 1 - i; k++)
                for (int a = 0; a < 3; a++)
                    r[at(n - 1, i, k)][a] =
                        w * q[at(n, i + 1, k)][a] + u * q[at(n, i, k)][a] + v * q[at(n, i, k + 1)][a];
        std::memcpy(q, r, sizeof q);
    }
    for (int a = 0; a < 3; a++)
        out[a] = q[0][a];
}

mpq_class q_of(const mpfr_t x)
{
    mpq_class r;
    mpfr_get_q(r.get_mpq_t(), x);
    return r;
}

mpq_class q_of(double x) { return mpq_class(x); }

// The ray as rationals, and its interval in a box.
struct QRay {
    mpq_class o[3], d[3];
    bool tmax_inf;
    mpq_class tmax;
    explicit QRay(const Ray &r)
    {
        const float of[3] = {r.o.x, r.o.y, r.o.z}, df[3] = {r.d.x, r.d.y, r.d.z};
        for (int a = 0; a < 3; a++) {
            o[a] = q_of((double)of[a]);
            d[a] = q_of((double)df[a]);
        }
        tmax_inf = std::isinf(r.tmax);
        if (!tmax_inf)
            tmax = q_of((double)r.tmax);
    }
    // The part of (0, tmax) in which the ray is inside [lo - g, hi + g]:
    // false when empty, else its closure [tn, tf] (tf may be "inf").
    bool interval(const mpq_class lo[3], const mpq_class hi[3], const mpq_class &g, mpq_class &tn, mpq_class &tf,
                  bool &tf_inf) const
    {
        tn = 0;
        tf_inf = tmax_inf;
        if (!tmax_inf)
            tf = tmax;
        for (int a = 0; a < 3; a++) {
            mpq_class l = lo[a] - g, h = hi[a] + g;
            if (sgn(d[a]) == 0) {
                if (o[a] < l || o[a] > h)
                    return false;
                continue;
            }
            mpq_class t0 = (l - o[a]) / d[a], t1 = (h - o[a]) / d[a];
            if (t0 > t1)
                std::swap(t0, t1);
            if (t0 > tn)
                tn = t0;
            if (tf_inf || t1 < tf) {
                tf = t1;
                tf_inf = false;
            }
        }
        return tf_inf || tn <= tf;
    }
};

void box_of(const XNet &x, mpq_class lo[3], mpq_class hi[3])
{
    for (int a = 0; a < 3; a++) {
        int il = 0, ih = 0;
        for (int i = 1; i < 10; i++) {
            if (mpfr_cmp(x.b[i][a], x.b[il][a]) < 0)
                il = i;
            if (mpfr_cmp(x.b[i][a], x.b[ih][a]) > 0)
                ih = i;
        }
        lo[a] = q_of(x.b[il][a]);
        hi[a] = q_of(x.b[ih][a]);
    }
}

// The hit certificate. Project along the ray: P(p) = ((p - o)_i d_k -
// (p - o)_k d_i, (p - o)_j d_k - (p - o)_k d_j), k the direction's largest
// axis, a linear map whose kernel is d, taking the ray's line to 0. Let f
// be the projected sub-patch over its domain T, g the affine map through
// its projected corners (corners of a Bezier triangle lie on it). f - g is
// the Bezier triangle of the nets' differences, so |f - g| <= delta on each
// axis, delta the largest difference of the net and g raised to degree 3.
// If 0 lies inside g(T) farther than sqrt(2) delta from each edge's line,
// the homotopy g + s (f - g) never takes T's boundary to 0, so f has
// degree +-1 at 0 (as the affine g has): some domain point maps to 0, and
// the ray's line meets the sub-patch. The margin: moving the net by up to
// beta on each axis moves P by up to beta (|d_k| + |d_i|) and beta (|d_k|
// + |d_j|); adding that to delta certifies a hit that survives the move.
bool certified(const XNet &x, const QRay &r, const mpq_class &beta)
{
    int k = 0;
    for (int a = 1; a < 3; a++)
        if (abs(r.d[a]) > abs(r.d[k]))
            k = a;
    int i = (k + 1) % 3, j = (k + 2) % 3;
    mpq_class P[10][2];
    for (int n = 0; n < 10; n++) {
        mpq_class pi = q_of(x.b[n][i]) - r.o[i], pj = q_of(x.b[n][j]) - r.o[j], pk = q_of(x.b[n][k]) - r.o[k];
        P[n][0] = pi * r.d[k] - pk * r.d[i];
        P[n][1] = pj * r.d[k] - pk * r.d[j];
    }
    const mpq_class *A = P[at(3, 3, 0)], *B = P[at(3, 0, 0)], *C = P[at(3, 0, 3)];
    // 3 delta: the net times 3 against i A + j B + k C
    mpq_class d3 = 0;
    for (int ii = 0; ii <= 3; ii++)
        for (int kk = 0; kk <= 3 - ii; kk++) {
            int jj = 3 - ii - kk;
            for (int c = 0; c < 2; c++) {
                mpq_class e = abs(3 * P[at(3, ii, kk)][c] - (ii * A[c] + jj * B[c] + kk * C[c]));
                if (e > d3)
                    d3 = e;
            }
        }
    mpq_class di = abs(r.d[i]), dj = abs(r.d[j]), dk = abs(r.d[k]);
    mpq_class delta = d3 / 3 + beta * (dk + (di > dj ? di : dj));
    auto orient = [](const mpq_class *p, const mpq_class *q) -> mpq_class { // orient(p, q, 0)
        return p[0] * q[1] - p[1] * q[0];
    };
    mpq_class area = (B[0] - A[0]) * (C[1] - A[1]) - (B[1] - A[1]) * (C[0] - A[0]);
    int sg = sgn(area);
    if (sg == 0)
        return false;
    const mpq_class *E[3][2] = {{A, B}, {B, C}, {C, A}};
    for (auto &e : E) {
        mpq_class o = orient(e[0], e[1]) * sg;
        if (sgn(o) <= 0)
            return false;
        mpq_class lx = e[1][0] - e[0][0], ly = e[1][1] - e[0][1];
        if (o * o <= 2 * delta * delta * (lx * lx + ly * ly))
            return false;
    }
    return true;
}

struct Interval {
    mpq_class tn, tf;
    bool tf_inf;
};

// What the exact subdivision found for one ray.
struct Exact {
    bool cert = false;              // a hit is certified
    mpq_class cert_tf;              // the nearest certified hit is before this
    std::vector<Interval> grown;    // the ray's intervals in the grown leaf boxes
    std::vector<Interval> core;     // and in the leaf boxes it meets ungrown
    bool undecided = false;         // RAY_NODES reached
    long nodes = 0;
    bool met() const { return !core.empty(); } // the ray meets an exact leaf box
};

// Depth-first, nearest grown box first, over the sub-patches whose grown
// box the ray meets: those whose own box it meets are split down to leaves
// of beta, the others only down to the grown margin's size (they only say
// where a hit in the band can be). A node beyond the nearest certified hit
// and beyond `keep` (the float hit's reach) is pruned.
Exact exact_ray(const PnPatch &pn, const Ray &ray, const mpq_class &beta, const mpq_class &grow,
                const mpq_class *keep)
{
    Exact ex;
    QRay r(ray);
    // a sub-patch, its box, and the ray's intervals in it grown and not
    struct Node {
        XNet net;
        mpq_class lo[3], hi[3];
        Interval grown, own;
        bool core = false; // the ray meets the box itself
        int depth = 0;
    };
    static std::vector<Node *> pool;
    size_t need = 3 * RAY_DEPTH + 8;
    while (pool.size() < need)
        pool.push_back(new Node);
    const mpq_class zero(0), leaf = beta, front = 16 * beta;
    // measures n's box; false when the ray misses it grown
    auto measure = [&](Node &n) {
        box_of(n.net, n.lo, n.hi);
        if (!r.interval(n.lo, n.hi, grow, n.grown.tn, n.grown.tf, n.grown.tf_inf))
            return false;
        n.core = r.interval(n.lo, n.hi, zero, n.own.tn, n.own.tf, n.own.tf_inf);
        return true;
    };
    root_net(pn, pool[0]->net);
    if (!measure(*pool[0]))
        return ex;
    pool[0]->depth = 0;
    size_t top = 1;
    static XNet parent;
    while (top > 0) {
        Node *nd = pool[--top];
        if (ex.cert && nd->grown.tn > ex.cert_tf && !(keep && nd->grown.tn <= *keep))
            continue;
        if (++ex.nodes > RAY_NODES) {
            ex.undecided = true;
            break;
        }
        if (nd->core && certified(nd->net, r, beta)) {
            mpq_class tn, tf;
            bool inf;
            // the hit is on the ray, and not the origin's own spot; it lies
            // in the sub-patch's own box
            if (r.interval(nd->lo, nd->hi, front, tn, tf, inf) && sgn(tn) > 0 && !inf &&
                (r.tmax_inf || tf < r.tmax) && !nd->own.tf_inf && (!ex.cert || nd->own.tf < ex.cert_tf)) {
                ex.cert = true;
                ex.cert_tf = nd->own.tf;
            }
        }
        mpq_class ext = 0;
        for (int a = 0; a < 3; a++)
            if (nd->hi[a] - nd->lo[a] > ext)
                ext = nd->hi[a] - nd->lo[a];
        if (ext <= (nd->core ? leaf : grow) || nd->depth == RAY_DEPTH) {
            ex.grown.push_back(nd->grown);
            if (nd->core)
                ex.core.push_back(nd->own);
            continue;
        }
        // the children take the parent's slot and the three above it
        parent.set(nd->net);
        int depth = nd->depth + 1;
        Node *kn[4];
        XNet *kid[4];
        for (int c = 0; c < 4; c++) {
            kn[c] = pool[top + c];
            kid[c] = &kn[c]->net;
        }
        splitter().split(parent, kid);
        // the children whose grown box the ray meets go on the stack,
        // the farthest first
        Node *kept[4], *dropped[4];
        int nk = 0, nd_ = 0;
        for (int c = 0; c < 4; c++) {
            if (measure(*kn[c])) {
                kn[c]->depth = depth;
                kept[nk++] = kn[c];
            } else
                dropped[nd_++] = kn[c];
        }
        for (int i = 1; i < nk; i++)
            for (int j = i; j > 0 && kept[j]->grown.tn > kept[j - 1]->grown.tn; j--)
                std::swap(kept[j], kept[j - 1]);
        for (int i = 0; i < nk; i++)
            pool[top + i] = kept[i];
        for (int i = 0; i < nd_; i++)
            pool[top + nk + i] = dropped[i];
        top += nk;
    }
    return ex;
}

} // namespace

void pn_box_ray(int rid, Rng &g, Stats &st, uint64_t ray, bool verbose)
{
    (void)rid;
    PnPatch pn;
    double s, off;
    if (!random_patch(g, st, pn, s, off))
        return;
    PnNet net;
    pn_net_root(&pn, &net);
    XNet x[2];
    root_net(pn, x[0]);
    int depth = g.below(BOX_DEPTH + 1), cur = 0;
    bool ok = true;
    for (int d = 0; d <= depth && ok; d++) {
        double lo[3], hi[3];
        pn_net_box(&net, lo, hi);
        st.c[C_RAYS]++;
        for (int i = 0; i < 10 && ok; i++)
            for (int a = 0; a < 3 && ok; a++)
                if (mpfr_cmp_d(x[cur].b[i][a], lo[a]) < 0 || mpfr_cmp_d(x[cur].b[i][a], hi[a]) > 0) {
                    ok = false;
                    char buf[512];
                    std::snprintf(buf, sizeof buf,
                                  "depth %d: exact control point %d axis %d = %.17g outside [%.17g, %.17g] (err %.3g)",
                                  d, i, a, mpfr_get_d(x[cur].b[i][a], MPFR_RNDN), lo[a], hi[a], net.err);
                    st.c[C_BOXFAIL]++;
                    st.fail(ray, "box_fail", buf);
                }
        if (ok)
            st.c[C_AGREE]++;
        if (d == depth)
            break;
        int ch = g.below(4);
        PnNet kids[4];
        pn_net_split(&net, kids);
        net = kids[ch];
        XNet *out[4] = {nullptr, nullptr, nullptr, nullptr};
        out[ch] = &x[1 - cur];
        splitter().split(x[cur], out);
        cur = 1 - cur;
    }
    if (verbose)
        std::printf("  pn patch scale=%g offset=%g depth=%d: %s\n", s, off, depth, ok ? "every box holds its sub-patch" : "a box fails");
}

// pn_hit_piece as the BVH uses it: the patch split twice ahead of rays, as
// accel.c splits a steep one, and the nearest of the sixteen pieces' hits.
// Every other ray goes through pn_hit_piece_rays instead, in lane 1 of a
// group of four beside three other rays (its reverse from twice as far,
// and itself from half and twice as far back), as a packet's rays meet a
// piece together.
static int hit_by_pieces(const PnPatch &pn, const Ray &r, PnHit &fh, bool lanes)
{
    PnNet root, one[4], two[16];
    pn_net_root(&pn, &root);
    pn_net_split(&root, one);
    for (int k = 0; k < 4; k++)
        pn_net_split(&one[k], &two[4 * k]);
    int got = 0;
    for (int i = 0; i < 16; i++) {
        PnPiece pc;
        pc.net = two[i];
        pc.depth = 2;
        pn_piece_init(&pc, &pn);
        PnHit h;
        int hit;
        if (lanes) {
            Ray four[4] = {r, r, r, r};
            four[0].o = vec_madd(r.o, r.d, 2.0f);
            four[0].d = vec_neg(r.d);
            four[2].o = vec_madd(r.o, r.d, -0.5f);
            four[3].o = vec_madd(r.o, r.d, -2.0f);
            PnHit hs[4];
            hit = (int)(pn_hit_piece_rays(&pn, &pc, four, 15u, PN_EXACT, hs) >> 1 & 1u);
            h = hs[1];
        } else
            hit = pn_hit_piece(&pn, &pc, &r, PN_EXACT, &h);
        if (hit && (!got || h.t < fh.t)) {
            fh = h;
            got = 1;
        }
    }
    return got;
}

void pn_ray(int rid, Rng &g, Stats &st, uint64_t ray, bool verbose)
{
    PnPatch pn;
    double s, off;
    if (!random_patch(g, st, pn, s, off))
        return;
    double m = 0.0;
    for (int i = 0; i < 10; i++)
        m = std::max(m, (double)vec_max_abs(pn.b[i]));
    double beta_d = m * (double)FLT_EPSILON, grow_d = 8.0 * beta_d;
    double spacing = (double)std::nextafter((float)m, INFINITY) - (double)(float)m;

    // The target: a point of the patch (inside, on its boundary, or a corner)
    double u, v;
    int kind = g.below(5);
    if (kind == 1) {
        double t = g.coin(0.2) ? (double)g.below(2) : g.uni();
        switch (g.below(3)) {
        case 0: u = t, v = 0; break;
        case 1: u = 0, v = t; break;
        default: u = t, v = 1 - t; break;
        }
    } else {
        u = g.uni(), v = g.uni();
        if (u + v > 1)
            u = 1 - u, v = 1 - v;
    }
    double p[3], pu[3], pv[3], h = 1e-4;
    eval(pn, u, v, p);
    {
        double a[3], b[3];
        eval(pn, u + h, v, a);
        eval(pn, u - h, v, b);
        for (int c = 0; c < 3; c++)
            pu[c] = (a[c] - b[c]) / (2 * h);
        eval(pn, u, v + h, a);
        eval(pn, u, v - h, b);
        for (int c = 0; c < 3; c++)
            pv[c] = (a[c] - b[c]) / (2 * h);
    }
    double nrm[3] = {pu[1] * pv[2] - pu[2] * pv[1], pu[2] * pv[0] - pu[0] * pv[2], pu[0] * pv[1] - pu[1] * pv[0]};
    auto normalize = [](double *x) {
        double l = std::sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2]);
        if (l > 0)
            for (int c = 0; c < 3; c++)
                x[c] /= l;
        return l > 0;
    };
    double dir[3];
    for (int c = 0; c < 3; c++)
        dir[c] = g.uni(-1, 1);
    if (!normalize(dir) || !normalize(nrm) || !normalize(pu)) {
        st.c[C_SKIP]++;
        return;
    }
    if (kind == 2) { // grazing: along the tangent plane, tilted slightly
        double th = g.sgn() * g.logu(1e-7, 0.3);
        for (int c = 0; c < 3; c++)
            dir[c] = pu[c] * std::cos(th) + nrm[c] * std::sin(th);
    } else if (kind == 3) { // near the surface, towards it
        double off_n = g.sgn() * s * g.logu(1e-9, 1e-2);
        for (int c = 0; c < 3; c++)
            p[c] += nrm[c] * off_n;
    } else if (kind == 4) { // anywhere near the patch
        for (int c = 0; c < 3; c++)
            p[c] += s * g.uni(-1, 1);
    }
    double L = s * g.logu(1e-2, 1e2), scale = std::ldexp(1.0, (int)g.ibetween(-4, 4));
    Ray r;
    r.o = vec3((float)(p[0] - dir[0] * L), (float)(p[1] - dir[1] * L), (float)(p[2] - dir[2] * L));
    r.d = vec3((float)(dir[0] * scale), (float)(dir[1] * scale), (float)(dir[2] * scale));
    r.tmax = INFINITY;
    if (!vec_is_finite(r.o) || !(vec_max_abs(r.d) > 0.0f)) {
        st.c[C_SKIP]++;
        return;
    }

    PnHit fh;
    int got = rid == R_PN_PIECES ? hit_by_pieces(pn, r, fh, ray & 1)
                                 : pn_hit(&pn, &r, rid == R_PN_FAST ? PN_FAST : PN_EXACT, &fh);
    mpq_class beta = q_of(beta_d), grow = q_of(grow_d), keep;
    if (got)
        keep = q_of((double)fh.t) + q_of((double)fh.terr);
    Exact ex = exact_ray(pn, r, beta, grow, got ? &keep : nullptr);
    st.c[C_RAYS]++;
    char buf[768];
    std::snprintf(buf, sizeof buf,
                  "patch scale=%g offset=%g kind=%d o=(%a %a %a) d=(%a %a %a) | float %s t=%.9g terr=%.3g u=%.6g v=%.6g "
                  "| exact met=%d cert=%d nodes=%ld",
                  s, off, kind, r.o.x, r.o.y, r.o.z, r.d.x, r.d.y, r.d.z, got ? "hit" : "miss", got ? fh.t : 0.0,
                  got ? fh.terr : 0.0, got ? fh.u : 0.0, got ? fh.v : 0.0, ex.met(), ex.cert, ex.nodes);
    if (verbose)
        std::printf("  %s%s\n", buf, ex.undecided ? " undecided" : "");
    if (ex.undecided) {
        st.c[C_UNDECIDED]++;
        return;
    }
    if (ex.met() && !ex.cert)
        st.c[C_NEARBAND]++;
    if (!got) {
        if (ex.cert) {
            st.c[C_FMISS]++;
            st.c[C_OUTBAND]++;
            st.fail(ray, "false_miss", buf);
        } else
            st.c[C_AGREE]++;
        return;
    }
    mpq_class t = q_of((double)fh.t), e = q_of((double)fh.terr), a = t - e, b = t + e;
    auto overlaps = [&](const std::vector<Interval> &v) {
        for (const Interval &iv : v)
            if (b >= iv.tn && (iv.tf_inf || a <= iv.tf))
                return true;
        return false;
    };
    if (overlaps(ex.core)) { // where the exact patch is, to a spacing
        st.c[C_AGREE]++;
        // t's error: how far along the ray t lies from the nearest leaf box
        // that the ray meets, in float spacings of the patch's largest
        // coordinate (the precision of a point on it; t's own spacing can
        // be far finer)
        double dt = INFINITY;
        for (const Interval &iv : ex.core) {
            double lo = iv.tn.get_d(), hi = iv.tf.get_d(), x = fh.t < lo ? lo - fh.t : fh.t > hi ? fh.t - hi : 0.0;
            dt = std::min(dt, x);
        }
        st.ulp.push_back(dt * (double)vec_max_abs(r.d) / spacing);
    } else if (overlaps(ex.grown)) { // within the band of it
        st.c[C_FHIT]++;
        st.c[C_BAND]++;
    } else if (ex.met()) {
        st.c[C_TBFAIL]++;
        st.fail(ray, "t_bound_fail", std::string(buf) + " (t +- terr meets no exact box)");
    } else {
        st.c[C_FHIT]++;
        st.c[C_OUTBAND]++;
        st.fail(ray, "false_hit", buf);
    }
    if (ex.cert && a > ex.cert_tf) {
        st.c[C_TBFAIL]++;
        st.fail(ray, "t_bound_fail", std::string(buf) + " (a certified hit lies nearer)");
    }
    // the patch's point at (u, v) against the ray's at t
    double q[3], dd = std::sqrt((double)vec_dot(r.d, r.d));
    eval(pn, fh.u, fh.v, q);
    const float of[3] = {r.o.x, r.o.y, r.o.z}, df[3] = {r.d.x, r.d.y, r.d.z};
    double tol = grow_d + 2.0 * (double)fh.terr * dd + 0x1p-40 * m, worst = 0;
    for (int c = 0; c < 3; c++)
        worst = std::max(worst, std::fabs(q[c] - (of[c] + (double)fh.t * df[c])));
    if (worst > tol) {
        st.c[C_UVFAIL]++;
        std::snprintf(buf + std::strlen(buf), sizeof buf - std::strlen(buf), " (patch at (u, v) %.3g from the ray's point, tolerance %.3g)", worst, tol);
        st.fail(ray, "uv_fail", buf);
    }
}

} // namespace judge
