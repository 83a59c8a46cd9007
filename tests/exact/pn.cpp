// pn.cpp - case 9: the boxes of PN patches (src/pntri.c). A random patch
// at a random scale and place, split along a random path of up to 14
// levels by pn_net_split; at every level, every control point of the exact
// sub-patch must lie in pn_net_box's box. The exact sub-patch is the one of
// the float root net (which is the patch, pntri.h), split by exact
// averages: every value is a dyadic rational of a few hundred bits, which
// MPFR at PREC bits holds exactly. A Bezier triangle lies in the convex
// hull of its control points, so a box that holds them holds the exact
// sub-patch. Each "ray" of the case is one path; its boxes are counted.
#include "judge.h"

#include <cstdio>
#include <cstring>

#include <mpfr.h>

extern "C" {
#include "lancer/pntri.h"
}

namespace judge {

namespace {

// Float exponents span 2^-149 to 2^128 and each level halves once more:
// well under 600 bits, so additions and halvings are exact.
const mpfr_prec_t PREC = 640;
const int MAX_DEPTH = 14;

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
};

// Barycentric weights (of the parent's P1, P2, P3) of the blossom's
// arguments: corners and edge midpoints, as in pntri.c.
const double ARG[6][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0, 0.5, 0.5}, {0.5, 0, 0.5}, {0.5, 0.5, 0}};
enum { E1, E2, E3, M23, M31, M12 };
// Each child's corners (its P1, P2, P3), as pn_net_split orders its children.
const int CHILD[4][3] = {{E1, M12, M31}, {M12, E2, M23}, {M31, M23, E3}, {M23, M31, M12}};

inline int at(int i, int k) { return (3 - i) * (4 - i) / 2 + k; } // PN_AT

// The exact net of child c of `in`, into `out`: b_ijk = the blossom at
// (C0^i, C1^j, C2^k), three de Casteljau steps with exact weights.
void exact_child(const XNet &in, int c, XNet &out)
{
    mpfr_t q[10][3], r[10][3], term;
    for (int i = 0; i < 10; i++)
        for (int a = 0; a < 3; a++) {
            mpfr_init2(q[i][a], PREC);
            mpfr_init2(r[i][a], PREC);
        }
    mpfr_init2(term, PREC);
    for (int i = 0; i <= 3; i++)
        for (int k = 0; k <= 3 - i; k++) {
            int args[3], n = 0;
            for (int t = 0; t < i; t++)
                args[n++] = CHILD[c][0];
            for (int t = 0; t < 3 - i - k; t++)
                args[n++] = CHILD[c][1];
            for (int t = 0; t < k; t++)
                args[n++] = CHILD[c][2];
            for (int p = 0; p < 10; p++)
                for (int a = 0; a < 3; a++)
                    mpfr_set(q[p][a], in.b[p][a], MPFR_RNDN);
            for (int d = 3, s = 0; d > 0; d--, s++) {
                const double *w = ARG[args[s]];
                for (int ii = 0; ii <= d - 1; ii++)
                    for (int kk = 0; kk <= d - 1 - ii; kk++) {
                        int row = d - 1 - ii, o = row * (row + 1) / 2 + kk, rin = d - ii;
                        const int src[3] = {(rin - 1) * rin / 2 + kk, rin * (rin + 1) / 2 + kk,
                                            rin * (rin + 1) / 2 + kk + 1};
                        for (int a = 0; a < 3; a++) {
                            mpfr_set_zero(r[o][a], 1);
                            for (int v = 0; v < 3; v++)
                                if (w[v] != 0.0) {
                                    mpfr_mul_d(term, q[src[v]][a], w[v], MPFR_RNDN); // by 1 or 1/2: exact
                                    mpfr_add(r[o][a], r[o][a], term, MPFR_RNDN);     // exact at PREC
                                }
                        }
                    }
                for (int p = 0; p < d * (d + 1) / 2; p++)
                    for (int a = 0; a < 3; a++)
                        mpfr_set(q[p][a], r[p][a], MPFR_RNDN);
            }
            for (int a = 0; a < 3; a++)
                mpfr_set(out.b[at(i, k)][a], q[0][a], MPFR_RNDN);
        }
    for (int i = 0; i < 10; i++)
        for (int a = 0; a < 3; a++) {
            mpfr_clear(q[i][a]);
            mpfr_clear(r[i][a]);
        }
    mpfr_clear(term);
}

Vec3 unit(double x, double y, double z)
{
    double l = std::sqrt(x * x + y * y + z * z);
    return vec3((float)(x / l), (float)(y / l), (float)(z / l));
}

} // namespace

void pn_box_ray(int rid, Rng &g, Stats &st, uint64_t ray, bool verbose)
{
    (void)rid;
    // A triangle at scale s, centred up to 10^5 s away; normals the face's
    // turned by up to about 60 degrees.
    double s = g.logu(1e-6, 1e6), off = g.coin(0.3) ? 0.0 : g.logu(1e-3, 1e5);
    double c[3] = {g.sgn() * off * s, g.sgn() * off * s, g.sgn() * off * s};
    Vec3 p[3];
    for (int k = 0; k < 3; k++)
        p[k] = vec3((float)(c[0] + s * g.uni(-1, 1)), (float)(c[1] + s * g.uni(-1, 1)), (float)(c[2] + s * g.uni(-1, 1)));
    Vec3 e1 = vec_sub(p[1], p[0]), e2 = vec_sub(p[2], p[0]), fn = vec_cross(e1, e2);
    if (!(vec_max_abs(fn) > 0.0f) || !vec_is_finite(fn)) {
        st.c[C_SKIP]++;
        return;
    }
    Vec3 n[3];
    double fl = std::sqrt((double)vec_dot(fn, fn));
    for (int k = 0; k < 3; k++)
        n[k] = unit(fn.x / fl + g.uni(-1, 1), fn.y / fl + g.uni(-1, 1), fn.z / fl + g.uni(-1, 1));
    PnPatch pn;
    pn_patch_init(&pn, p, n);
    for (int i = 0; i < 10; i++)
        if (!vec_is_finite(pn.b[i])) {
            st.c[C_SKIP]++;
            return;
        }
    PnNet net;
    pn_net_root(&pn, &net);
    XNet x[2];
    for (int i = 0; i < 10; i++) {
        mpfr_set_flt(x[0].b[i][0], pn.b[i].x, MPFR_RNDN);
        mpfr_set_flt(x[0].b[i][1], pn.b[i].y, MPFR_RNDN);
        mpfr_set_flt(x[0].b[i][2], pn.b[i].z, MPFR_RNDN);
    }
    int depth = g.below(MAX_DEPTH + 1), cur = 0;
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
        exact_child(x[cur], ch, x[1 - cur]);
        cur = 1 - cur;
    }
    if (verbose)
        std::printf("  pn patch scale=%g offset=%g depth=%d: %s\n", s, off, depth, ok ? "every box holds its sub-patch" : "a box fails");
}

} // namespace judge
