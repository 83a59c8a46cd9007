/* Tests for pntri.c: the control net against Vlachos et al.'s formulas, the
 * flat patch against the watertight triangle, subdivision against
 * evaluation, the error bound's boxes, shared edges bit for bit, a PN
 * sphere against the sphere, and closed PN surfaces that no ray escapes:
 * an icosahedron's, and CGAL's closed meshes' (LANCER_PN_CRACK_RAYS rays
 * per mesh and placement, default 2000; `make stress` runs 10^6). */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include "testutil.h"

#include <float.h>
#include <math.h>
#include <string.h>

#include <stdio.h>
#include <stdlib.h>
#include <unistd.h> /* rmdir */

#include "lancer/accel.h"
#include "lancer/pntri.h"
#include "lancer/prim.h"
#include "lancer/scene.h"

static Vec3 unit(Vec3 a) { return vec_normalize(a); }

/* b_ijk by the paper's formulas, in double, for one axis. */
static double paper_point(double P[3][3], double N[3][3], int i, int k, int a)
{
    int j = 3 - i - k;
    int c[3] = {i, j, k};
    for (int v = 0; v < 3; v++)
        if (c[v] == 3)
            return P[v][a];
    double e[6]; /* b210 b120 b021 b012 b102 b201 on axis a */
    static const int from[6] = {0, 1, 1, 2, 2, 0}, to[6] = {1, 0, 2, 1, 0, 2};
    for (int m = 0; m < 6; m++) {
        int s = from[m], t = to[m];
        double w = 0;
        for (int x = 0; x < 3; x++)
            w += (P[t][x] - P[s][x]) * N[s][x];
        e[m] = (2 * P[s][a] + P[t][a] - w * N[s][a]) / 3;
    }
    if (i == 2 && j == 1)
        return e[0];
    if (i == 1 && j == 2)
        return e[1];
    if (j == 2 && k == 1)
        return e[2];
    if (j == 1 && k == 2)
        return e[3];
    if (k == 2 && i == 1)
        return e[4];
    if (k == 1 && i == 2)
        return e[5];
    double E = (e[0] + e[1] + e[2] + e[3] + e[4] + e[5]) / 6, V = (P[0][a] + P[1][a] + P[2][a]) / 3;
    return E + (E - V) / 2;
}

static void make_patch(PnPatch *pn, Vec3 a, Vec3 b, Vec3 c, Vec3 na, Vec3 nb, Vec3 nc)
{
    const Vec3 p[3] = {a, b, c}, n[3] = {unit(na), unit(nb), unit(nc)};
    pn_patch_init(pn, p, n);
}

/* A random patch with a corner at c and the others within sc of it on
 * each axis, its vertex normals random too. */
static void random_patch(PnPatch *pn, unsigned long long *seed, Vec3 c, float sc)
{
    Vec3 b = vec_add(c, vec_scale(test_rvec(seed, -1, 1), sc)), d = vec_add(c, vec_scale(test_rvec(seed, -1, 1), sc));
    Vec3 na = test_rvec(seed, -1, 1), nb = test_rvec(seed, -1, 1), nc = test_rvec(seed, -1, 1);
    make_patch(pn, c, b, d, na, nb, nc);
}

/* Patch k of a test at three scales in turn (1, 10^-3, 10^4), placed up to
 * ten times its scale from the origin: returns the scale. */
static float scaled_patch(PnPatch *pn, unsigned long long *seed, int k)
{
    float sc = k % 3 == 0 ? 1.0f : k % 3 == 1 ? 1e-3f : 1e4f;
    Vec3 c = vec_scale(test_rvec(seed, -10, 10), sc);
    random_patch(pn, seed, c, sc);
    return sc;
}

/* The modes' names, and nothing else. */
static void test_mode_names(void **state)
{
    (void)state;
    assert_int_equal(pn_mode_named("exact"), PN_EXACT);
    assert_int_equal(pn_mode_named("fast"), PN_FAST);
    assert_int_equal(pn_mode_named("Fast"), -1);
    assert_int_equal(pn_mode_named(""), -1);
    assert_int_equal(pn_mode_named("exactly"), -1);
}

static void test_control_net(void **state)
{
    (void)state;
    PnPatch pn;
    Vec3 p[3] = {vec3(0, 0, 0), vec3(2, 0.5f, 0.1f), vec3(0.3f, 1.7f, -0.2f)};
    Vec3 n[3] = {unit(vec3(0.1f, 0.2f, 1)), unit(vec3(-0.3f, 0.1f, 1)), unit(vec3(0.2f, -0.4f, 1))};
    pn_patch_init(&pn, p, n);
    double P[3][3], N[3][3];
    for (int v = 0; v < 3; v++) {
        P[v][0] = p[v].x, P[v][1] = p[v].y, P[v][2] = p[v].z;
        N[v][0] = n[v].x, N[v][1] = n[v].y, N[v][2] = n[v].z;
    }
    for (int i = 0; i <= 3; i++)
        for (int k = 0; k <= 3 - i; k++) {
            const Vec3 *b = &pn.b[PN_AT(i, k)];
            assert_float_equal(b->x, (float)paper_point(P, N, i, k, 0), 0);
            assert_float_equal(b->y, (float)paper_point(P, N, i, k, 1), 0);
            assert_float_equal(b->z, (float)paper_point(P, N, i, k, 2), 0);
        }
    /* the corners interpolate the vertices, with their normals */
    double pt[3];
    pn_eval(&pn, 0, 0, pt, NULL, NULL);
    assert_true(pt[0] == p[0].x && pt[1] == p[0].y && pt[2] == p[0].z);
    pn_eval(&pn, 1, 0, pt, NULL, NULL);
    assert_true(pt[0] == p[1].x && pt[1] == p[1].y && pt[2] == p[1].z);
    pn_eval(&pn, 0, 1, pt, NULL, NULL);
    assert_true(pt[0] == p[2].x && pt[1] == p[2].y && pt[2] == p[2].z);
    for (int v = 0; v < 3; v++) {
        Vec3 s = pn_shading_normal(&pn, v == 1 ? 1.0f : 0.0f, v == 2 ? 1.0f : 0.0f);
        assert_vec(s, n[v].x, n[v].y, n[v].z, 1e-6f);
        /* the surface is tangent to the vertex's plane there */
        Vec3 g = pn_geometric_normal(&pn, v == 1 ? 1.0f : 0.0f, v == 2 ? 1.0f : 0.0f);
        assert_true(vec_dot(g, n[v]) > 0.9999f);
    }
}

/* The derivatives against central differences. */
static void test_derivatives(void **state)
{
    (void)state;
    PnPatch pn;
    make_patch(&pn, vec3(0, 0, 0), vec3(1, 0, 0.2f), vec3(0, 1, -0.1f), vec3(0.3f, 0, 1), vec3(0, 0.4f, 1),
               vec3(-0.2f, -0.1f, 1));
    const double h = 1e-6;
    for (double u = 0.1; u < 0.8; u += 0.23)
        for (double v = 0.05; u + v < 0.95; v += 0.19) {
            double du[3], dv[3], a[3], b[3];
            pn_eval(&pn, u, v, NULL, du, dv);
            pn_eval(&pn, u + h, v, a, NULL, NULL);
            pn_eval(&pn, u - h, v, b, NULL, NULL);
            for (int c = 0; c < 3; c++)
                assert_float_equal(du[c], (a[c] - b[c]) / (2 * h), 1e-6);
            pn_eval(&pn, u, v + h, a, NULL, NULL);
            pn_eval(&pn, u, v - h, b, NULL, NULL);
            for (int c = 0; c < 3; c++)
                assert_float_equal(dv[c], (a[c] - b[c]) / (2 * h), 1e-6);
        }
}

/* A child's net describes its parent's surface over its domain: the
 * child's point at (s, t) is the parent's at the domain point it maps to,
 * for every child, three levels down. */
static void check_net(const PnPatch *pn, const PnNet *net, int depth)
{
    for (int m = 0; m < 6; m++) {
        double s = (m % 3) * 0.3 + 0.05, t = (m / 3) * 0.4 + 0.1;
        if (s + t > 1)
            continue;
        /* the net's own point at (s, t), by de Casteljau in double */
        double mine[3], want[3], w = 1 - s - t;
        double q[10][3];
        memcpy(q, net->b, sizeof q);
        for (int d = 3; d > 0; d--) {
            double r[10][3];
            for (int i = 0; i <= d - 1; i++)
                for (int k = 0; k <= d - 1 - i; k++) {
                    int row = d - 1 - i, at = row * (row + 1) / 2 + k, rin = d - i;
                    for (int c = 0; c < 3; c++)
                        r[at][c] = w * q[(rin - 1) * rin / 2 + k][c] + s * q[rin * (rin + 1) / 2 + k][c] +
                                   t * q[rin * (rin + 1) / 2 + k + 1][c];
                }
            memcpy(q, r, sizeof r);
        }
        memcpy(mine, q[0], sizeof mine);
        double sg = net->flip ? -net->s : net->s;
        pn_eval(pn, net->u0 + sg * s, net->v0 + sg * t, want, NULL, NULL);
        for (int c = 0; c < 3; c++)
            assert_float_equal(mine[c], want[c], 1e-12);
    }
    if (depth == 0)
        return;
    PnNet kids[4];
    pn_net_split(net, kids);
    for (int c = 0; c < 4; c++) {
        assert_true(kids[c].err >= net->err);
        check_net(pn, &kids[c], depth - 1);
    }
}

static void test_subdivision(void **state)
{
    (void)state;
    PnPatch pn;
    make_patch(&pn, vec3(0, 0, 0), vec3(1, 0, 0.2f), vec3(0, 1, -0.1f), vec3(0.3f, 0, 1), vec3(0, 0.4f, 1),
               vec3(-0.2f, -0.1f, 1));
    PnNet root;
    pn_net_root(&pn, &root);
    check_net(&pn, &root, 3);
}

/* The split's program, derived from the blossom: a child's point
 * b(C0^i, C1^j, C2^k) is three de Casteljau steps on the parent's net, one
 * per argument, corners (which only select) before midpoints; each
 * distinct average of two pool entries is made once. pntri.c's tables
 * must be this program, op for op. */
enum { E1, E2, E3, M23, M31, M12 };

static int prog_avg(PnSplitProgram *g, int a, int b)
{
    if (a > b) {
        int t = a;
        a = b;
        b = t;
    }
    for (int n = 0; n < g->nops; n++)
        if (g->op[n][0] == a && g->op[n][1] == b)
            return 10 + n;
    g->op[g->nops][0] = (unsigned char)a;
    g->op[g->nops][1] = (unsigned char)b;
    return 10 + g->nops++;
}

/* One de Casteljau step with argument x on a net of pool entries of
 * degree d (points at (d - i)(d - i + 1)/2 + k), to degree d - 1. */
static void prog_step(PnSplitProgram *g, const int *in, int d, int x, int *out)
{
    for (int i = 0; i <= d - 1; i++)
        for (int k = 0; k <= d - 1 - i; k++) {
            int r = d - 1 - i, rin = d - i;
            int p1 = in[(rin - 1) * rin / 2 + k], p2 = in[rin * (rin + 1) / 2 + k], p3 = in[rin * (rin + 1) / 2 + k + 1];
            int *o = &out[r * (r + 1) / 2 + k];
            switch (x) {
            case E1: *o = p1; break;
            case E2: *o = p2; break;
            case E3: *o = p3; break;
            case M23: *o = prog_avg(g, p2, p3); break;
            case M31: *o = prog_avg(g, p3, p1); break;
            default: *o = prog_avg(g, p1, p2); break;
            }
        }
}

static void test_split_program_is_the_blossoms(void **state)
{
    (void)state;
    static const int corners[4][3] = {
        {E1, M12, M31},  /* at P1 */
        {M12, E2, M23},  /* at P2 */
        {M31, M23, E3},  /* at P3 */
        {M23, M31, M12}, /* the middle one, turned half round */
    };
    PnSplitProgram want, got;
    memset(&want, 0, sizeof want);
    memset(&got, 0, sizeof got);
    int root[10];
    for (int i = 0; i < 10; i++)
        root[i] = i;
    for (int c = 0; c < 4; c++)
        for (int i = 0; i <= 3; i++)
            for (int k = 0; k <= 3 - i; k++) {
                int args[3], n = 0;
                for (int t = 0; t < i; t++)
                    args[n++] = corners[c][0];
                for (int t = 0; t < 3 - i - k; t++)
                    args[n++] = corners[c][1];
                for (int t = 0; t < k; t++)
                    args[n++] = corners[c][2];
                for (int u = 1; u < 3; u++) /* the order of application */
                    for (int w = u; w > 0 && args[w] < args[w - 1]; w--) {
                        int t = args[w];
                        args[w] = args[w - 1];
                        args[w - 1] = t;
                    }
                int q2[6], q1[3], q0[1];
                prog_step(&want, root, 3, args[0], q2);
                prog_step(&want, q2, 2, args[1], q1);
                prog_step(&want, q1, 1, args[2], q0);
                want.child[c][PN_AT(i, k)] = (unsigned char)q0[0];
            }
    /* each child's own ops: those its points are made from (an op only
     * reads entries made before it) */
    for (int c = 0; c < 4; c++) {
        unsigned char need[10 + 64] = {0};
        for (int i = 0; i < 10; i++)
            need[want.child[c][i]] = 1;
        for (int n = want.nops - 1; n >= 0; n--)
            if (need[10 + n])
                need[want.op[n][0]] = need[want.op[n][1]] = 1;
        for (int n = 0; n < want.nops; n++)
            if (need[10 + n])
                want.own[c][want.nown[c]++] = (unsigned char)n;
    }
    pn_split_program(&got);
    assert_int_equal(got.nops, want.nops);
    assert_memory_equal(got.op, want.op, sizeof want.op);
    assert_memory_equal(got.child, want.child, sizeof want.child);
    assert_memory_equal(got.nown, want.nown, sizeof want.nown);
    assert_memory_equal(got.own, want.own, sizeof want.own);
}

/* Every point of a sub-patch lies in its net's box, grown by its error
 * bound: sampled densely, at depth 6, on a patch far from the origin. */
static void test_boxes_hold_their_patch(void **state)
{
    (void)state;
    PnPatch pn;
    Vec3 o = vec3(1e4f, -3e3f, 7e3f);
    make_patch(&pn, vec_add(o, vec3(0, 0, 0)), vec_add(o, vec3(1, 0, 0.2f)), vec_add(o, vec3(0, 1, -0.1f)),
               vec3(0.6f, 0, 1), vec3(0, 0.8f, 1), vec3(-0.5f, -0.3f, 1));
    PnNet net;
    pn_net_root(&pn, &net);
    unsigned long long seed = 7;
    for (int d = 0; d < 6; d++) {
        PnNet kids[4];
        pn_net_split(&net, kids);
        net = kids[(int)test_uniform(&seed, 0, 4) & 3];
    }
    double lo[3], hi[3];
    pn_net_box(&net, lo, hi);
    double sg = net.flip ? -net.s : net.s;
    for (int m = 0; m <= 20; m++)
        for (int n = 0; m + n <= 20; n++) {
            double p[3];
            pn_eval(&pn, net.u0 + sg * m / 20.0, net.v0 + sg * n / 20.0, p, NULL, NULL);
            for (int c = 0; c < 3; c++) {
                /* pn_eval's own rounding, at most a few ulps of 1e4 */
                assert_true(p[c] >= lo[c] - 1e-11 && p[c] <= hi[c] + 1e-11);
            }
        }
}

/* Two patches sharing an edge (its end points and their normals) have the
 * same four control points on it, and so do their sub-patches along it,
 * bit for bit, however each patch's corners are ordered. */
static void edge_points(const PnNet *net, int edge, double out[4][3])
{
    /* edge 0: P1 -> P2 (i from 3 down, k = 0); 1: P2 -> P3 (i = 0); 2: P3 -> P1 (j = 0) */
    for (int m = 0; m < 4; m++) {
        int i = edge == 0 ? 3 - m : edge == 1 ? 0 : m, k = edge == 0 ? 0 : edge == 1 ? m : 3 - m;
        memcpy(out[m], net->b[PN_AT(i, k)], sizeof out[m]);
    }
}

static void test_shared_edges_bit_for_bit(void **state)
{
    (void)state;
    Vec3 a = vec3(0.1f, 0.2f, 0.3f), b = vec3(1.3f, -0.2f, 0.45f), c = vec3(0.2f, 1.1f, -0.15f),
         d = vec3(1.2f, 1.0f, 0.6f);
    Vec3 na = vec3(0.2f, 0.1f, 1), nb = vec3(-0.3f, 0.2f, 1), nc = vec3(0.1f, -0.3f, 1), nd = vec3(0.4f, 0.4f, 1);
    /* A = (a, b, c): edge b -> c is its edge 1. B = (c, b, d): edge c -> b is its edge 0, the other way. */
    PnPatch A, B;
    make_patch(&A, a, b, c, na, nb, nc);
    make_patch(&B, c, b, d, nc, nb, nd);
    PnNet na0, nb0;
    pn_net_root(&A, &na0);
    pn_net_root(&B, &nb0);
    /* follow the shared edge down both trees: the piece of edge b -> c
     * between fractions [lo, lo + len) */
    PnNet x = na0, y = nb0;
    int ex = 1, ey = 0;       /* the edge's number in each net */
    int fx = 0, fy = 1;       /* whether each net walks it from c (1) or b (0) */
    unsigned long long seed = 3;
    for (int depth = 0; depth < 8; depth++) {
        double px[4][3], py[4][3];
        edge_points(&x, ex, px);
        edge_points(&y, ey, py);
        for (int m = 0; m < 4; m++)
            assert_memory_equal(px[fx ? 3 - m : m], py[fy ? 3 - m : m], sizeof px[m]);
        /* take the same half of the edge in both: the child at the edge's
         * first or second corner */
        int half = (int)test_uniform(&seed, 0, 2) & 1;
        PnNet kx[4], ky[4];
        pn_net_split(&x, kx);
        pn_net_split(&y, ky);
        /* edge e of a net runs from corner e to corner (e + 1) % 3; the
         * child at corner e keeps it as edge e, the one at corner e + 1 too */
        int cx = half ^ fx ? (ex + 1) % 3 : ex, cy = half ^ fy ? (ey + 1) % 3 : ey;
        x = kx[cx];
        y = ky[cy];
    }
}

/* A patch whose normals are its face's is the flat triangle: its hits are
 * the watertight triangle's, within both error bounds, and its misses too
 * away from the edges. */
/* A triangle, and its PN patch with the face's normal at every vertex. */
static void flat_pair(PnPatch *pn, Triangle *tr)
{
    Vec3 a = vec3(-1, -1, 0.5f), b = vec3(1.5f, -0.8f, 0.7f), c = vec3(-0.2f, 1.2f, 0.3f);
    Vec3 n = unit(vec_cross(vec_sub(b, a), vec_sub(c, a)));
    make_patch(pn, a, b, c, n, n, n);
    *tr = (Triangle){a, b, c, n, n, n, 0};
}

static void test_flat_patch_is_the_triangle(void **state)
{
    (void)state;
    PnPatch pn;
    Triangle tr;
    flat_pair(&pn, &tr);
    unsigned long long seed = 11;
    int agree = 0, hits = 0;
    for (int i = 0; i < 3000; i++) {
        Vec3 o = test_rvec(&seed, -3, 3);
        o.z = test_uniform(&seed, 3, 6);
        Vec3 to = test_rvec(&seed, -1.5f, 1.5f);
        to.z = 0.5f;
        Ray r = ray_make(o, vec_sub(to, o), INFINITY);
        PnHit hp;
        PrimHit ht;
        int p = pn_hit(&pn, &r, PN_EXACT, &hp), t = prim_triangle_hit_watertight(&tr, &r, &ht);
        if (p == t)
            agree++;
        if (p && t) {
            hits++;
            assert_true(fabsf(hp.t - ht.t) <= hp.terr + ht.terr + 1e-6f * ht.t);
            /* the domain point is the triangle's barycentrics */
            assert_float_equal(hp.u, ht.u, 1e-5f);
            assert_float_equal(hp.v, ht.v, 1e-5f);
        }
    }
    assert_true(hits > 500);
    assert_true(agree >= 2995); /* disagreements only grazing an edge */
}

/* The icosahedron's vertices on the unit sphere, with normals = positions. */
static const float ico_v[12][3] = {
    {0, 1, 1.618034f},  {0, -1, 1.618034f},  {0, 1, -1.618034f},  {0, -1, -1.618034f},
    {1, 1.618034f, 0},  {-1, 1.618034f, 0},  {1, -1.618034f, 0},  {-1, -1.618034f, 0},
    {1.618034f, 0, 1},  {-1.618034f, 0, 1},  {1.618034f, 0, -1},  {-1.618034f, 0, -1},
};
static const int ico_f[20][3] = {
    {0, 1, 8},  {0, 9, 1},  {0, 8, 4},  {0, 4, 5},  {0, 5, 9},  {1, 9, 7},  {1, 7, 6},
    {1, 6, 8},  {8, 6, 10}, {8, 10, 4}, {4, 10, 2}, {4, 2, 5},  {5, 2, 11}, {5, 11, 9},
    {9, 11, 7}, {7, 11, 3}, {7, 3, 6},  {6, 3, 10}, {10, 3, 2}, {2, 3, 11},
};

/* The PN icosahedron of the sphere of radius R at c. */
static void ico_patches(PnPatch pn[20], float R, Vec3 c)
{
    for (int f = 0; f < 20; f++) {
        Vec3 p[3], n[3];
        for (int k = 0; k < 3; k++) {
            const float *v = ico_v[ico_f[f][k]];
            n[k] = unit(vec3(v[0], v[1], v[2]));
            p[k] = vec_add(c, vec_scale(n[k], R));
        }
        pn_patch_init(&pn[f], p, n);
    }
}

static int closest(const PnPatch *pn, int n, const Ray *r, PnMode mode, PnHit *best)
{
    int found = 0;
    Ray q = *r;
    for (int f = 0; f < n; f++) {
        PnHit h;
        if (pn_hit(&pn[f], &q, mode, &h)) {
            *best = h;
            q.tmax = h.t;
            found = 1;
        }
    }
    return found;
}

/* PN patches of an icosahedron on the unit sphere lie inside it and within
 * theta^4 / 24 of it (theta = 63.4 degrees, the edge's angle): rays from
 * the centre meet the surface at a distance from 0.94 to 1. */
static void test_sphere_approximation(void **state)
{
    (void)state;
    PnPatch pn[20];
    ico_patches(pn, 1.0f, vec3(0, 0, 0));
    unsigned long long seed = 5;
    double lo = 1, hi = 0;
    for (int i = 0; i < 2000; i++) {
        Vec3 d = unit(test_rvec(&seed, -1, 1));
        Ray r = ray_make(vec3(0, 0, 0), d, INFINITY);
        PnHit h = {0}; /* (set by closest: -O3 cannot tell) */
        assert_true(closest(pn, 20, &r, PN_EXACT, &h));
        lo = fmin(lo, h.t);
        hi = fmax(hi, h.t);
    }
    assert_true(lo > 1 - 0.0630 && hi <= 1 + 1e-6);
    assert_true(lo < 1 - 0.05); /* the centroids reach the bound's neighbourhood */
}

/* A closed PN surface has no cracks: rays from inside, aimed at every
 * vertex and edge midpoint, at several scales and offsets, all hit. */
static void test_closed_surface_does_not_leak(void **state)
{
    (void)state;
    const float scales[3] = {1e-4f, 1.0f, 1e5f};
    const Vec3 offsets[2] = {vec3(0, 0, 0), vec3(1e5f, 1e5f, 1e5f)};
    for (int s = 0; s < 3; s++)
        for (int o = 0; o < 2; o++) {
            if (o == 1 && s == 0)
                continue; /* a 1e-4 sphere at 1e5 is below float resolution */
            PnPatch pn[20];
            Vec3 c = offsets[o];
            ico_patches(pn, scales[s], c);
            unsigned long long seed = 9;
            for (int f = 0; f < 20; f++)
                for (int e = 0; e < 6; e++) {
                    /* a vertex (e < 3) or an edge's midpoint */
                    Vec3 p = pn[f].b[e < 3 ? (e == 0 ? 0 : e == 1 ? 6 : 9) : 0];
                    if (e >= 3) {
                        double pt[3];
                        pn_eval(&pn[f], e == 3 ? 0.5 : 0.0, e == 4 ? 0.5 : e == 5 ? 0.5 : 0.0, pt, NULL, NULL);
                        p = vec3((float)pt[0], (float)pt[1], (float)pt[2]);
                    }
                    for (int k = 0; k < 4; k++) {
                        Vec3 from = vec_add(c, vec_scale(test_rvec(&seed, -0.3f, 0.3f), scales[s]));
                        Ray r = ray_make(from, vec_sub(p, from), INFINITY);
                        PnHit h;
                        if (!closest(pn, 20, &r, PN_EXACT, &h))
                            fail_msg("scale %g offset %d: a ray from inside escaped through face %d point %d", (double)scales[s],
                                     o, f, e);
                    }
                }
        }
}

/* A unit cube whose edge (0,0,0)-(1,0,0) is split at its midpoint on the
 * face y = 0, and closed on the face z = 0 by the collinear triangle of
 * the edge's three vertices, as exporters close a T-junction: that
 * triangle has no area, but its PN patch has curved edges and fills the
 * gap between its neighbours'. Rays from inside, at the split edge and
 * beside it, all hit; with the collinear triangle dropped, the background
 * showed through (a mesh once dropped it). */
static void test_t_junction_does_not_leak(void **state)
{
    (void)state;
    char dir[] = "/tmp/lancer-pntri-XXXXXX", path[256], text[512], err[512];
    test_temp_file(dir, "cube.off",
                   "OFF\n9 14 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n0 0 1\n1 0 1\n1 1 1\n0 1 1\n0.5 0 0\n"
                   "3 0 3 2\n3 0 2 1\n3 4 5 6\n3 4 6 7\n3 0 5 4\n3 2 3 7\n3 2 7 6\n3 1 2 6\n3 1 6 5\n3 0 4 7\n"
                   "3 0 7 3\n3 0 8 5\n3 8 1 5\n3 0 1 8\n",
                   path, sizeof path);
    static const char *const kinds[2] = {"flat", "pn"};
    for (int k = 0; k < 2; k++) {
        Scene s;
        snprintf(text, sizeof text,
                 "camera { eye 0 0 -5 target 0 0 0 fov 40 }\nmaterial m { }\n"
                 "mesh { file \"%s\" material m %s }\n",
                 path, kinds[k]);
        if (scene_parse("t.scn", text, strlen(text), &s, err, sizeof err) != 0)
            fail_msg("%s", err);
        /* flat: 13 triangles and the collinear one dropped; pn: 14 patches */
        assert_int_equal(s.nprims, k ? 14 : 13);
        assert_int_equal(s.degenerate, k ? 0 : 1);
        if (k) {
            Accel *acc = accel_build(&s, PRIM_ROBUST, 1);
            assert_non_null(acc);
            static const Vec3 from[3] = {{0.25f, 0.5f, 0.02f}, {0.5f, 0.3f, 0.3f}, {0.8f, 0.1f, 0.05f}};
            int escaped = 0;
            for (int o = 0; o < 3; o++)
                for (int i = 0; i <= 200; i++)
                    for (int j = -2; j <= 2; j++) {
                        /* along the edge, and up to 0.02 off it on both faces */
                        const float x = (float)i / 200.0f, off = 0.01f * (float)j;
                        const Vec3 at = vec3(x, off > 0 ? off : 0, off < 0 ? -off : 0);
                        Ray r = ray_make(from[o], vec_sub(at, from[o]), INFINITY);
                        PrimHit h;
                        RayStats st;
                        memset(&st, 0, sizeof st);
                        escaped += accel_closest(acc, &r, &h, &st) < 0;
                    }
            assert_int_equal(escaped, 0);
            accel_free(acc);
        }
        scene_free(&s);
    }
    remove(path);
    rmdir(dir);
}

/* The tessellation: its points are the patch's at the grid, its faces
 * cover the grid once, each turning as P1, P2, P3 do. */
static void test_tessellation(void **state)
{
    (void)state;
    PnPatch pn;
    make_patch(&pn, vec3(0, 0, 0), vec3(1, 0, 0.2f), vec3(0, 1, -0.1f), vec3(0.3f, 0, 1), vec3(0, 0.4f, 1),
               vec3(-0.2f, -0.1f, 1));
    enum { N = 4 };
    Vec3 pts[(N + 1) * (N + 2) / 2], nrm[(N + 1) * (N + 2) / 2];
    int faces[N * N][3];
    assert_int_equal(pn_grid_points(N), (N + 1) * (N + 2) / 2);
    pn_tessellate(&pn, N, pts, nrm, faces);
    int k = 0;
    for (int a = 0; a <= N; a++)
        for (int b = 0; a + b <= N; b++, k++) {
            double pt[3];
            pn_eval(&pn, (double)a / N, (double)b / N, pt, NULL, NULL);
            assert_vec(pts[k], (float)pt[0], (float)pt[1], (float)pt[2], 0);
            Vec3 s = pn_shading_normal(&pn, (float)a / N, (float)b / N);
            assert_vec(nrm[k], s.x, s.y, s.z, 0);
        }
    assert_vec(pts[0], pn.b[PN_AT(3, 0)].x, pn.b[PN_AT(3, 0)].y, pn.b[PN_AT(3, 0)].z, 0);
    /* in the domain, every face turns the same way as the patch, and the
     * faces' areas add up to the domain's, 1/2 */
    double area = 0;
    for (int f = 0; f < N * N; f++) {
        double uv[3][2];
        for (int c = 0; c < 3; c++) {
            int v = faces[f][c], a = 0;
            assert_true(v >= 0 && v < pn_grid_points(N));
            while (v > N - a) { /* row a holds N + 1 - a points */
                v -= N + 1 - a;
                a++;
            }
            uv[c][0] = (double)a / N;
            uv[c][1] = (double)v / N;
        }
        double cross = (uv[1][0] - uv[0][0]) * (uv[2][1] - uv[0][1]) - (uv[1][1] - uv[0][1]) * (uv[2][0] - uv[0][0]);
        assert_true(cross > 0);
        area += cross / 2;
    }
    assert_float_equal(area, 0.5, 1e-12);
}

/* Exact mode's t holds its bound: rays aimed at points of a curved patch
 * (at 1, 10^-4 and 10^5 in size, near and far from the origin), from all
 * sides at a cosine above 0.3, hit it where its point is, within terr and
 * the rounding of the aim. This covers both of its stops: boxes at float
 * precision, and pieces flat to float precision. */
static void test_exact_hits_within_their_bound(void **state)
{
    (void)state;
    const float scales[3] = {1.0f, 1e-4f, 1e5f};
    const float offsets[2] = {0.0f, 3e3f};
    unsigned long long seed = 31;
    int n = 0;
    for (int si = 0; si < 3; si++)
        for (int oi = 0; oi < 2; oi++) {
            float sc = scales[si];
            Vec3 c = vec3(offsets[oi] * sc, -0.5f * offsets[oi] * sc, 0.25f * offsets[oi] * sc);
            PnPatch pn;
            make_patch(&pn, vec_add(c, vec3(0, 0, 0)), vec_add(c, vec3(sc, 0, 0.3f * sc)),
                       vec_add(c, vec3(0, sc, -0.2f * sc)), vec3(0.7f, 0.1f, 1), vec3(-0.2f, 0.6f, 1),
                       vec3(0.3f, -0.7f, 1));
            for (int k = 0; k < 2000; k++) {
                double u = test_uniform(&seed, 0, 1), v = test_uniform(&seed, 0, 1);
                if (u + v > 1) {
                    u = 1 - u;
                    v = 1 - v;
                }
                double pt[3], du[3], dv[3];
                pn_eval(&pn, u, v, pt, du, dv);
                Vec3 target = vec3((float)pt[0], (float)pt[1], (float)pt[2]);
                Vec3 ng = unit(vec_cross(vec3((float)du[0], (float)du[1], (float)du[2]),
                                         vec3((float)dv[0], (float)dv[1], (float)dv[2])));
                Vec3 dir = unit(test_rvec(&seed, -1, 1));
                float cosine = fabsf(vec_dot(dir, ng));
                if (cosine < 0.3f)
                    continue;
                Vec3 o = vec_sub(target, vec_scale(dir, 2.0f * sc));
                Ray r = ray_make(o, vec_sub(target, o), INFINITY);
                PnHit h;
                double len = sqrt((double)vec_dot(r.d, r.d));
                double m = fmax(vec_max_abs(o), vec_max_abs(target));
                double aim = 4.0 * m * FLT_EPSILON / (len * cosine);
                n++;
                int hit = pn_hit(&pn, &r, PN_EXACT, &h);
                if (hit && h.t < 1.0 - h.terr - aim) {
                    /* an earlier crossing of the curved patch: a point of it */
                    double q[3];
                    pn_eval(&pn, h.u, h.v, q, NULL, NULL);
                    double gap = 0;
                    for (int a = 0; a < 3; a++) {
                        double x = (a == 0 ? o.x : a == 1 ? o.y : o.z) + h.t * (a == 0 ? r.d.x : a == 1 ? r.d.y : r.d.z);
                        gap = fmax(gap, fabs(x - q[a]));
                    }
                    if (gap <= 64.0 * m * FLT_EPSILON + h.terr * len)
                        continue;
                }
                if (!hit || fabs(h.t - 1.0) > h.terr + aim)
                    fail_msg("scale %g offset %g: ray at (%g, %g) %s t=%.9g terr=%g aim=%g", (double)sc,
                             (double)offsets[oi], u, v, "missed or", (double)h.t, (double)h.terr, aim);
            }
        }
    assert_true(n > 5000);
}

/* The AVX forms of the split and of pn_eval (where the processor has
 * AVX) and their plain loops give the same bits: the children's nets,
 * their boxes, the patch's points and derivatives, and every hit, for
 * patches at scales and offsets, hit, missed and grazed, and for rays
 * leaving the surface (which split deepest). */
static void test_avx_is_the_loop(void **state)
{
    (void)state;
    if (!pn_split_avx(1)) {
        print_message("no AVX here: the split runs its loop alone\n");
        return;
    }
    unsigned long long seed = 97;
    int hits = 0;
    for (int k = 0; k < 3000; k++) {
        float sc = k % 3 == 0 ? 1.0f : k % 3 == 1 ? 1e-4f : 1e5f;
        Vec3 c = vec_scale(test_rvec(&seed, -100, 100), sc);
        PnPatch pn;
        random_patch(&pn, &seed, c, sc);
        PnNet root, kids[2][4];
        pn_net_root(&pn, &root);
        double box[2][4][2][3];
        for (int avx = 0; avx <= 1; avx++) {
            pn_split_avx(avx);
            pn_net_split(&root, kids[avx]);
            for (int i = 0; i < 4; i++)
                pn_net_box(&kids[avx][i], box[avx][i][0], box[avx][i][1]);
        }
        for (int i = 0; i < 4; i++) { /* field by field: not the padding */
            assert_memory_equal(kids[0][i].b, kids[1][i].b, sizeof kids[0][i].b);
            const double f0[4] = {kids[0][i].err, kids[0][i].u0, kids[0][i].v0, kids[0][i].s};
            const double f1[4] = {kids[1][i].err, kids[1][i].u0, kids[1][i].v0, kids[1][i].s};
            assert_memory_equal(f0, f1, sizeof f0);
            assert_int_equal(kids[0][i].flip, kids[1][i].flip);
        }
        assert_memory_equal(box[0], box[1], sizeof box[0]);
        for (int j = 0; j < 4; j++) { /* inside the domain, on its edges and off it (Newton's steps stray) */
            double uv[2] = {test_uniform(&seed, -0.5, 1.5), j == 1 ? 0.0 : test_uniform(&seed, -0.5, 1.5)};
            double e[2][3][3];
            for (int avx = 0; avx <= 1; avx++) {
                pn_split_avx(avx);
                pn_eval(&pn, uv[0], uv[1], e[avx][0], e[avx][1], e[avx][2]);
            }
            assert_memory_equal(e[0], e[1], sizeof e[0]);
        }
        /* a ray through a point of the patch, or leaving it */
        double u = test_uniform(&seed, 0, 1), v = test_uniform(&seed, 0, 1), pt[3];
        if (u + v > 1)
            u = 1 - u, v = 1 - v;
        pn_eval(&pn, u, v, pt, NULL, NULL);
        Vec3 p = vec3((float)pt[0], (float)pt[1], (float)pt[2]), d = unit(test_rvec(&seed, -1, 1));
        Ray r = ray_make(k % 2 ? p : vec_sub(p, vec_scale(d, 2.0f * sc)), d, INFINITY);
        PnHit h[2];
        int got[2];
        for (int avx = 0; avx <= 1; avx++) {
            memset(&h[avx], 0, sizeof h[avx]);
            pn_split_avx(avx);
            got[avx] = pn_hit(&pn, &r, PN_EXACT, &h[avx]);
        }
        assert_int_equal(got[0], got[1]);
        assert_memory_equal(&h[0], &h[1], sizeof h[0]);
        hits += got[0];
    }
    pn_split_avx(1);
    assert_true(hits > 1000);
}

/* Rays that graze a flat patch, at cosines from 2^-3 down to 2^-20 with
 * its plane, aimed at points inside it, hit it as the watertight triangle
 * does, within the bounds: the thickened triangle culls without the cosine
 * cut that its hits have. */
static void test_grazing_rays(void **state)
{
    (void)state;
    PnPatch pn;
    Triangle tr;
    flat_pair(&pn, &tr);
    Vec3 a = tr.a, b = tr.b, c = tr.c, n = tr.na;
    unsigned long long seed = 41;
    int hits = 0;
    for (int i = 0; i < 600; i++) {
        float wb = test_uniform(&seed, 0.1f, 0.8f), wc = test_uniform(&seed, 0.1f, 0.9f - wb);
        Vec3 target = vec_add(a, vec_add(vec_scale(vec_sub(b, a), wb), vec_scale(vec_sub(c, a), wc)));
        Vec3 along = unit(vec_cross(n, test_rvec(&seed, -1, 1)));
        float cosine = ldexpf(1.0f, -(int)test_uniform(&seed, 3, 21));
        Vec3 dir = unit(vec_add(along, vec_scale(n, i & 1 ? cosine : -cosine)));
        Vec3 o = vec_sub(target, vec_scale(dir, 3.0f));
        Ray r = ray_make(o, vec_sub(target, o), INFINITY);
        PnHit hp;
        PrimHit ht;
        int p = pn_hit(&pn, &r, PN_EXACT, &hp), t = prim_triangle_hit_watertight(&tr, &r, &ht);
        if (!t)
            continue; /* the aim's rounding can take a grazing ray past the plane's far side */
        hits++;
        if (!p)
            fail_msg("cosine 2^%d: the patch missed a ray the triangle hits at t=%g", ilogbf(cosine), (double)ht.t);
        assert_true(fabsf(hp.t - ht.t) <= hp.terr + ht.terr + 1e-5f * ht.t);
    }
    assert_true(hits > 300);
}

/* The fast mode finds the exact mode's hits, within a small error. */
static void test_fast_mode(void **state)
{
    (void)state;
    PnPatch pn[20];
    ico_patches(pn, 1.0f, vec3(0, 0, 0));
    unsigned long long seed = 21;
    int both = 0;
    for (int i = 0; i < 2000; i++) {
        Vec3 o = vec_scale(unit(test_rvec(&seed, -1, 1)), 3.0f);
        Vec3 to = test_rvec(&seed, -0.9f, 0.9f);
        Ray r = ray_make(o, vec_sub(to, o), INFINITY);
        PnHit he = {0}, hf = {0}; /* (set by closest when it returns 1: -O3 cannot tell) */
        int e = closest(pn, 20, &r, PN_EXACT, &he), f = closest(pn, 20, &r, PN_FAST, &hf);
        assert_int_equal(e, f);
        if (e && f) {
            both++;
            assert_float_equal(hf.t, he.t, 1e-5f * he.t + he.terr);
        }
    }
    assert_true(both > 1000);
}

/* closest over pn[0 .. n-1] in exact mode, with proofs or by subdivision
 * alone, adding the pieces proofs settled to *proven. */
static int closest_with(const PnPatch *pn, int n, const Ray *r, int proofs, PnHit *best, long *proven)
{
    int found = 0;
    Ray q = *r;
    for (int f = 0; f < n; f++) {
        PnHit h;
        if (pn_hit_with(&pn[f], &q, PN_EXACT, proofs, &h, proven)) {
            *best = h;
            q.tmax = h.t;
            found = 1;
        }
    }
    return found;
}

/* Exact mode with the proofs of a piece's only crossing and by
 * subdivision alone agree, on the PN icosahedron at three scales and far
 * from the origin: rays from outside aimed inside it and past it, and rays
 * leaving the surface from points a few float spacings above it, outwards
 * (which the convex surface never stops: proofs settle their own spot)
 * and inwards (which cross it at once); then random bent patches. */
static void test_proofs_agree_with_subdivision(void **state)
{
    (void)state;
    const float scales[3] = {1.0f, 1e-3f, 1e4f};
    unsigned long long seed = 77;
    int hits = 0, left = 0;
    long proven = 0, proven_leaving = 0, unused = 0;
    for (int s = 0; s < 3; s++)
        for (int far = 0; far < 2; far++) {
            float R = scales[s];
            Vec3 c = far ? vec3(40 * R, -25 * R, 10 * R) : vec3(0, 0, 0);
            PnPatch pn[20];
            ico_patches(pn, R, c);
            for (int i = 0; i < 600; i++) {
                Ray r;
                if (i % 3 != 2) { /* from outside, at a point inside or past the sphere */
                    Vec3 o = vec_add(c, vec_scale(unit(test_rvec(&seed, -1, 1)), 3 * R));
                    Vec3 to = vec_add(c, vec_scale(test_rvec(&seed, -1, 1), i % 3 ? 1.3f * R : 0.9f * R));
                    r = ray_make(o, vec_sub(to, o), INFINITY);
                } else { /* from a point just above the surface */
                    int f = (int)test_uniform(&seed, 0, 19.99f);
                    double u = test_uniform(&seed, 0, 1), v = test_uniform(&seed, 0, 1), p[3], du[3], dv[3];
                    if (u + v > 1) {
                        u = 1 - u;
                        v = 1 - v;
                    }
                    pn_eval(&pn[f], u, v, p, du, dv);
                    Vec3 ng = unit(vec_cross(vec3((float)du[0], (float)du[1], (float)du[2]),
                                             vec3((float)dv[0], (float)dv[1], (float)dv[2])));
                    Vec3 at = vec3((float)p[0], (float)p[1], (float)p[2]);
                    Vec3 o = vec_add(at, vec_scale(ng, 48 * FLT_EPSILON * vec_max_abs(at)));
                    Vec3 d = unit(test_rvec(&seed, -1, 1));
                    float dn = vec_dot(d, ng);
                    if (fabsf(dn) < 0.1f)
                        continue;
                    r = ray_make(o, d, INFINITY);
                    if (dn > 0) { /* outwards: a convex surface stops none */
                        PnHit h;
                        int sub = closest_with(pn, 20, &r, 0, &h, &unused);
                        if (sub || closest_with(pn, 20, &r, 1, &h, &proven_leaving))
                            fail_msg("scale %g: a ray leaving patch %d at (%g, %g) hit the surface (%s)", (double)R,
                                     f, u, v, sub ? "subdivision" : "proof");
                        left++;
                        continue;
                    }
                }
                PnHit hs = {0}, hp = {0}; /* (set by closest_with when it returns 1: -O3 cannot tell) */
                int sub = closest_with(pn, 20, &r, 0, &hs, &unused), prf = closest_with(pn, 20, &r, 1, &hp, &proven);
                if (sub != prf)
                    fail_msg("scale %g ray %d: subdivision %s, proof %s", (double)R, i, sub ? "hits" : "misses",
                             prf ? "hits" : "misses");
                if (!sub)
                    continue;
                hits++;
                if (fabs((double)hs.t - hp.t) > (double)hs.terr + hp.terr + 4.0 * FLT_EPSILON * hs.t)
                    fail_msg("scale %g ray %d: t %.9g against %.9g (terr %g, %g)", (double)R, i, (double)hs.t,
                             (double)hp.t, (double)hs.terr, (double)hp.terr);
            }
        }
    /* random bent patches, aimed at their points and beside them */
    for (int k = 0; k < 300; k++) {
        Vec3 a = test_rvec(&seed, -1, 1), b = test_rvec(&seed, -1, 1), c = test_rvec(&seed, -1, 1);
        Vec3 n = unit(vec_cross(vec_sub(b, a), vec_sub(c, a)));
        PnPatch pn;
        make_patch(&pn, a, b, c, vec_add(n, test_rvec(&seed, -0.8f, 0.8f)), vec_add(n, test_rvec(&seed, -0.8f, 0.8f)),
                   vec_add(n, test_rvec(&seed, -0.8f, 0.8f)));
        for (int i = 0; i < 20; i++) {
            double p[3];
            pn_eval(&pn, test_uniform(&seed, -0.1f, 0.6f), test_uniform(&seed, -0.1f, 0.6f), p, NULL, NULL);
            Vec3 to = vec3((float)p[0], (float)p[1], (float)p[2]);
            Vec3 o = vec_add(to, vec_scale(unit(test_rvec(&seed, -1, 1)), 3.0f));
            Ray r = ray_make(o, vec_sub(to, o), INFINITY);
            PnHit hs = {0}, hp = {0};
            int sub = pn_hit_with(&pn, &r, PN_EXACT, 0, &hs, &unused);
            int prf = pn_hit_with(&pn, &r, PN_EXACT, 1, &hp, &proven);
            if (sub != prf)
                fail_msg("patch %d ray %d: subdivision %s, proof %s", k, i, sub ? "hits" : "misses",
                         prf ? "hits" : "misses");
            hits += sub;
            if (sub && fabs((double)hs.t - hp.t) > (double)hs.terr + hp.terr + 4.0 * FLT_EPSILON * hs.t)
                fail_msg("patch %d ray %d: t %.9g against %.9g (terr %g, %g)", k, i, (double)hs.t, (double)hp.t,
                         (double)hs.terr, (double)hp.terr);
        }
    }
    assert_int_equal(unused, 0); /* subdivision alone proves nothing */
    assert_true(hits > 4000 && left > 200);
    /* the proofs ran: most hits, and most leaving rays' own spots */
    assert_true(proven > hits / 2 && proven_leaving > left / 2);
}

/* ---- CGAL's closed meshes as PN surfaces ---- */

static const char *const closed_meshes[] = {"eight.off", "anchor.off", "hand.off", "couplingdown.off"};

/* The mesh `name` moved by p -> (p - c) * a + t, as PN patches (pn) or
 * flat triangles, into s. */
static void load_placed(const char *name, int pn, double a, Vec3 c, Vec3 t, Scene *s)
{
    char text[1024], err[512];
    Vec3 m = vec3((float)(t.x - c.x * a), (float)(t.y - c.y * a), (float)(t.z - c.z * a));
    snprintf(text, sizeof text,
             "camera { eye 0 0 -5 target 0 0 0 fov 40 }\nmaterial m { }\n"
             "mesh { file \"build/cgal-data/meshes/%s\" material m %s matrix %.9g 0 0 0 %.9g 0 0 0 %.9g %.9g %.9g %.9g }\n",
             name, pn ? "pn" : "flat", a, a, a, (double)m.x, (double)m.y, (double)m.z);
    if (scene_parse("t.scn", text, strlen(text), s, err, sizeof err) != 0)
        fail_msg("%s", err);
}

/* 1 when q is inside the flat mesh: an odd number of its triangles cross
 * a ray from q in a random direction. */
static int inside_flat(const Scene *flat, Vec3 q, unsigned long long *seed)
{
    Ray r = ray_make(q, unit(test_rvec(seed, -1, 1)), INFINITY);
    int n = 0;
    for (int i = 0; i < flat->nprims; i++) {
        PrimHit h;
        n += prim_intersect(&flat->prims[i], &r, PRIM_ROBUST, &h);
    }
    return n & 1;
}

/* 1 when q lies outside the box of every patch's control net. The PN
 * surface, the flat mesh, and every surface between them (the patch
 * (1 - s) flat + s PN, whose net stays in the same boxes) lie inside those
 * boxes, so such a point inside the flat mesh is inside the PN surface. */
static int outside_nets(const Scene *pn, Vec3 q)
{
    for (int i = 0; i < pn->npatches; i++) {
        Vec3 lo, hi;
        pn_bounds(&pn->patches[i], &lo, &hi);
        if (q.x >= lo.x && q.x <= hi.x && q.y >= lo.y && q.y <= hi.y && q.z >= lo.z && q.z <= hi.z)
            return 0;
    }
    return 1;
}

/* Rays from inside each closed mesh's PN surface, aimed at its vertices
 * and its edges' midpoints (points that two or more patches share), and at
 * points near them (at 2^-4 to 2^-24 of the patch's size), at three scales
 * and far from the origin: a ray from inside a closed surface must leave
 * it, so every one must hit. */
/* pn_net_slope: a flat patch is a graph of slope 0, to roundings; a bent
 * one is steeper, and its pieces flatten as they shrink, below 0.1 in four
 * splits (as accel.c expects of the patches it splits ahead of rays); a
 * ray starting from a piece finds the hit of the whole patch there. */
static void test_slope_and_pieces(void **state)
{
    (void)state;
    PnPatch flat, bent;
    Vec3 a = vec3(0, 0, 0), b = vec3(2, 0, 0), c = vec3(0, 2, 0), z = vec3(0, 0, 1);
    make_patch(&flat, a, b, c, z, z, z);
    make_patch(&bent, a, b, c, vec3(-0.5f, -0.5f, 1), vec3(0.7f, 0, 1), vec3(0, 0.7f, 1));
    PnNet net;
    pn_net_root(&flat, &net);
    assert_true(pn_net_slope(&flat, &net) < 1e-9);
    pn_net_root(&bent, &net);
    double top = pn_net_slope(&bent, &net);
    assert_true(top > 0.1);
    PnNet level[256], next[256];
    int n = 1;
    level[0] = net;
    for (int d = 1; d <= 4; d++) {
        double worst = 0.0;
        for (int k = 0; k < n; k++)
            pn_net_split(&level[k], &next[4 * k]);
        n *= 4;
        for (int k = 0; k < n; k++) {
            level[k] = next[k];
            double sl = pn_net_slope(&bent, &level[k]);
            worst = sl > worst ? sl : worst;
        }
        assert_true(worst < top);
        top = worst;
    }
    assert_true(top < 0.1);
    /* rays down onto the patch: the nearest of the pieces' hits is the patch's */
    unsigned long long g = 3;
    for (int k = 0; k < 2000; k++) {
        Vec3 o = vec3(test_uniform(&g, -0.2f, 1.6f), test_uniform(&g, -0.2f, 1.6f), 3);
        Ray r = ray_make(o, vec_normalize(vec3(test_uniform(&g, -0.3f, 0.3f), test_uniform(&g, -0.3f, 0.3f), -1)), INFINITY);
        PnHit whole, h, best = {INFINITY, 0, 0, 0};
        int got = pn_hit(&bent, &r, PN_EXACT, &whole), any = 0;
        for (int i = 0; i < n; i++) {
            PnPiece pc;
            pc.net = level[i];
            pc.depth = 4;
            pn_piece_init(&pc, &bent);
            if (pn_hit_piece(&bent, &pc, &r, PN_EXACT, &h) && h.t < best.t)
                best = h, any = 1;
        }
        assert_int_equal(got, any);
        if (got)
            assert_true(fabsf(best.t - whole.t) <= best.terr + whole.terr);
    }
}

/* A piece keeps the shape that a ray's first tests measure of it: its
 * corner triangle's edges, its net's distance from that triangle, and its
 * slope; and a ray meets a piece that keeps them exactly as one that does
 * not (the same bits), in both modes, for rays that hit it, miss it, graze
 * it, and leave it. */
static void test_pieces_keep_their_shape(void **state)
{
    (void)state;
    unsigned long long seed = 41;
    int hits = 0, compared = 0;
    for (int k = 0; k < 300; k++) {
        PnPatch pn;
        float sc = scaled_patch(&pn, &seed, k);
        PnNet root, kids[4];
        pn_net_root(&pn, &root);
        pn_net_split(&root, kids);
        for (int i = 0; i < 4; i++) {
            PnPiece pc, bare;
            pc.net = kids[i];
            pc.depth = 1;
            pn_piece_init(&pc, &pn);
            assert_int_equal(pc.shaped, 1);
            bare = pc;
            bare.shaped = 0;
            const double *A = pc.net.b[PN_AT(3, 0)], *B = pc.net.b[PN_AT(0, 0)], *C = pc.net.b[PN_AT(0, 3)];
            double e1[3], e2[3], e3[3], dev = 0.0;
            for (int a = 0; a < 3; a++) {
                e1[a] = B[a] - A[a];
                e2[a] = C[a] - A[a];
                e3[a] = e2[a] - e1[a];
            }
            assert_true(pc.len[0] == sqrt(e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2]));
            assert_true(pc.len[1] == sqrt(e2[0] * e2[0] + e2[1] * e2[1] + e2[2] * e2[2]));
            assert_true(pc.len[2] == sqrt(e3[0] * e3[0] + e3[1] * e3[1] + e3[2] * e3[2]));
            /* b_ijk against A + j e1 / 3 + k e2 / 3 */
            for (int ii = 0; ii <= 3; ii++)
                for (int kk = 0; kk <= 3 - ii; kk++) {
                    int jj = 3 - ii - kk;
                    for (int a = 0; a < 3; a++)
                        dev = fmax(dev, fabs(pc.net.b[PN_AT(ii, kk)][a] - (A[a] + jj * e1[a] / 3 + kk * e2[a] / 3)));
                }
            /* with the net's error and the flat test's rounding allowance,
             * 2^-40 of the piece's largest coordinate m (this loop's own
             * roundings are a few 2^-53 of m) */
            double m = 0.0;
            for (int a = 0; a < 3; a++)
                m = fmax(m, fmax(fabs(pc.lo[a]), fabs(pc.hi[a])));
            double want = dev + pc.net.err + 0x1p-40 * m;
            assert_true(pc.dev >= want - 0x1p-44 * m && pc.dev <= want + 0x1p-44 * m);
            if (pc.kappa > 0.0)
                assert_true(pc.slope == pn_net_slope(&pn, &pc.net));
            else
                assert_true(isinf(pn_net_slope(&pn, &pc.net)));
            /* rays through a point of the piece, leaving it, and aimed past it */
            double u = test_uniform(&seed, 0, 1), v = test_uniform(&seed, 0, 1), pt[3];
            if (u + v > 1)
                u = 1 - u, v = 1 - v;
            double sg = pc.net.flip ? -pc.net.s : pc.net.s;
            pn_eval(&pn, pc.net.u0 + sg * u, pc.net.v0 + sg * v, pt, NULL, NULL);
            Vec3 p = vec3((float)pt[0], (float)pt[1], (float)pt[2]);
            for (int j = 0; j < 4; j++) {
                Vec3 d = unit(test_rvec(&seed, -1, 1));
                Vec3 o = j == 0 ? p : vec_sub(vec_add(p, vec_scale(test_rvec(&seed, -0.3f, 0.3f), j == 3 ? sc : 0)),
                                                vec_scale(d, 2.0f * sc));
                Ray r = ray_make(o, d, INFINITY);
                for (int mode = 0; mode <= 1; mode++) {
                    PnHit h[2];
                    memset(h, 0, sizeof h);
                    int got0 = pn_hit_piece(&pn, &pc, &r, mode ? PN_FAST : PN_EXACT, &h[0]);
                    int got1 = pn_hit_piece(&pn, &bare, &r, mode ? PN_FAST : PN_EXACT, &h[1]);
                    assert_int_equal(got0, got1);
                    assert_memory_equal(&h[0], &h[1], sizeof h[0]);
                    hits += got0;
                    compared++;
                }
            }
        }
    }
    assert_true(compared == 300 * 4 * 4 * 2);
    assert_true(hits > 3000);
}

/* pn_hit_piece_rays against pn_hit_piece (pn_hit for the whole patch) ray
 * by ray, bit for bit, in both modes and for masks of two rays or more,
 * which the lanes take four at a time: rays aimed at points of the piece
 * from outside, rays leaving those points (spawned off the surface), rays
 * stopped short of them, rays along an axis, and rays aimed past the
 * piece; on whole patches and on pieces one, two and twelve splits down
 * (the last flat to float precision). */
static void test_piece_rays_are_one_by_one(void **state)
{
    (void)state;
    unsigned long long seed = 43;
    long compared = 0, hits = 0, leaving = 0;
    for (int k = 0; k < 300; k++) {
        PnPatch pn;
        float sc = scaled_patch(&pn, &seed, k);
        PnNet net, kids[4];
        pn_net_root(&pn, &net);
        int depth = k % 4 == 3 ? 12 : k % 4;
        for (int l = 0; l < depth; l++) {
            pn_net_split(&net, kids);
            net = kids[test_uniform(&seed, 0, 1) < 0.5 ? 3 : (int)test_uniform(&seed, 0, 2.99)];
        }
        PnPiece pc;
        pc.net = net;
        pc.depth = depth;
        pn_piece_init(&pc, &pn);
        Ray r[8];
        for (int j = 0; j < 8; j++) {
            double u = test_uniform(&seed, 0, 1), v = test_uniform(&seed, 0, 1), pt[3], du[3], dv[3];
            if (u + v > 1)
                u = 1 - u, v = 1 - v;
            double sg = net.flip ? -net.s : net.s;
            pn_eval(&pn, net.u0 + sg * u, net.v0 + sg * v, pt, du, dv);
            Vec3 p = vec3((float)pt[0], (float)pt[1], (float)pt[2]);
            Vec3 n = unit(vec3((float)(du[1] * dv[2] - du[2] * dv[1]), (float)(du[2] * dv[0] - du[0] * dv[2]),
                               (float)(du[0] * dv[1] - du[1] * dv[0])));
            Vec3 d = unit(test_rvec(&seed, -1, 1));
            int kind = (j + k) % 5;
            if (kind == 3) { /* along an axis */
                d = vec3(0, 0, 0);
                if (j % 3 == 0)
                    d.x = 1;
                else if (j % 3 == 1)
                    d.y = -1;
                else
                    d.z = 1;
            }
            if (kind == 1) { /* leaving its point, off the surface as a spawned ray is */
                if (vec_dot(d, n) < 0)
                    d = vec_neg(d);
                Surface sf;
                memset(&sf, 0, sizeof sf);
                sf.p = p;
                float e = 16.0f * FLT_EPSILON * vec_max_abs(p);
                sf.perr = vec3(e, e, e);
                sf.ng = sf.noff = sf.ns = n;
                r[j] = ray_make(prim_spawn_origin(&sf, d), d, j % 2 ? INFINITY : 3.0f * sc);
                leaving++;
                continue;
            }
            Vec3 aim = kind == 4 ? vec_add(p, vec_scale(test_rvec(&seed, -0.5f, 0.5f), sc)) : p;
            Vec3 o = vec_sub(aim, vec_scale(d, 2.0f * sc));
            r[j] = ray_make(o, d, kind == 2 ? 1.0f * sc : INFINITY); /* kind 2: stopped short */
        }
        for (int mode = 0; mode <= 1; mode++) {
            PnHit one[8], lanes[8];
            unsigned want = 0;
            for (int j = 0; j < 8; j++)
                want |= (unsigned)(depth ? pn_hit_piece(&pn, &pc, &r[j], mode ? PN_FAST : PN_EXACT, &one[j])
                                         : pn_hit(&pn, &r[j], mode ? PN_FAST : PN_EXACT, &one[j]))
                        << j;
            for (unsigned mask = 3; mask < 256; mask += 1 + (unsigned)(test_uniform(&seed, 0, 1) * 20)) {
                if (!(mask & (mask - 1)))
                    continue;
                memset(lanes, 0xa5, sizeof lanes);
                unsigned got = pn_hit_piece_rays(&pn, depth ? &pc : NULL, r, mask, mode ? PN_FAST : PN_EXACT, lanes);
                assert_int_equal(got, want & mask);
                for (int j = 0; j < 8; j++)
                    if (got >> j & 1)
                        assert_memory_equal(&lanes[j], &one[j], sizeof one[j]);
                compared += __builtin_popcount(mask);
            }
            hits += __builtin_popcount(want);
        }
    }
    assert_true(compared > 50000);
    assert_true(hits > 1500 && leaving > 400);
}

static void test_cgal_meshes_do_not_leak(void **state)
{
    (void)state;
    FILE *probe = fopen("build/cgal-data/meshes/eight.off", "r");
    if (!probe) {
        print_message("build/cgal-data/meshes is missing: run make cgal-data\n");
        skip();
    }
    fclose(probe);
    const char *env = getenv("LANCER_PN_CRACK_RAYS");
    long rays = env ? atol(env) : 2000;
    assert_true(rays > 0);
    /* (scale, offset): the largest side becomes `scale`, its centre `offset` on every axis */
    static const double place[5][2] = {{1e-4, 0}, {1, 0}, {1e5, 0}, {1e5, 1e5}, {1e3, 1e5}};
    long total = 0;
    for (size_t mi = 0; mi < sizeof closed_meshes / sizeof closed_meshes[0]; mi++) {
        Scene raw;
        load_placed(closed_meshes[mi], 0, 1.0, vec3(0, 0, 0), vec3(0, 0, 0), &raw);
        Vec3 lo = raw.prims[0].g.tri.a, hi = lo;
        for (int i = 0; i < raw.nprims; i++) {
            const Triangle *t = &raw.prims[i].g.tri;
            const Vec3 v[3] = {t->a, t->b, t->c};
            for (int k = 0; k < 3; k++) {
                lo = vec3(fminf(lo.x, v[k].x), fminf(lo.y, v[k].y), fminf(lo.z, v[k].z));
                hi = vec3(fmaxf(hi.x, v[k].x), fmaxf(hi.y, v[k].y), fmaxf(hi.z, v[k].z));
            }
        }
        scene_free(&raw);
        Vec3 c = vec_scale(vec_add(lo, hi), 0.5f), ext = vec_sub(hi, lo);
        double side = fmax(ext.x, fmax(ext.y, ext.z));
        for (int pl = 0; pl < 5; pl++) {
            double a = place[pl][0] / side;
            Vec3 t = vec3((float)place[pl][1], (float)place[pl][1], (float)place[pl][1]);
            Scene pn, flat;
            load_placed(closed_meshes[mi], 1, a, c, t, &pn);
            load_placed(closed_meshes[mi], 0, a, c, t, &flat);
            if (pn.degenerate != 0)
                fail_msg("%s at scale %g: %d triangles collapsed, the mesh is no longer closed", closed_meshes[mi],
                         place[pl][0], pn.degenerate);
            Accel *acc = accel_build(&pn, PRIM_ROBUST, 1);
            assert_non_null(acc);
            unsigned long long seed = 1000 * mi + (unsigned long long)pl + 1;
            Vec3 origins[32];
            int no = 0;
            for (int tries = 0; no < 32 && tries < 20000; tries++) {
                Vec3 q = vec_add(t, vec_scale(test_rvec(&seed, -0.5f, 0.5f), (float)place[pl][0]));
                if (inside_flat(&flat, q, &seed) && inside_flat(&flat, q, &seed) && outside_nets(&pn, q))
                    origins[no++] = q;
            }
            assert_true(no > 0);
            for (long k = 0; k < rays; k++, total++) {
                int pi = (int)(test_uniform(&seed, 0, 1) * (float)pn.npatches) % pn.npatches;
                const PnPatch *p = &pn.patches[pi];
                int at = (int)(test_uniform(&seed, 0, 6)) % 6;
                /* the three corners, then the three edges' midpoints */
                static const double uv[6][2] = {{0, 0}, {1, 0}, {0, 1}, {0.5, 0}, {0.5, 0.5}, {0, 0.5}};
                double pt[3];
                pn_eval(p, uv[at][0], uv[at][1], pt, NULL, NULL);
                Vec3 target = at < 3 ? p->b[at == 0 ? PN_AT(3, 0) : at == 1 ? PN_AT(0, 0) : PN_AT(0, 3)]
                                     : vec3((float)pt[0], (float)pt[1], (float)pt[2]);
                if (k & 1) { /* beside it, by a fraction of the patch's size */
                    Vec3 plo, phi;
                    pn_bounds(p, &plo, &phi);
                    float size = vec_max_abs(vec_sub(phi, plo)), f = ldexpf(1.0f, -(int)test_uniform(&seed, 4, 25));
                    target = vec_add(target, vec_scale(unit(test_rvec(&seed, -1, 1)), size * f));
                }
                Vec3 o = origins[k % no];
                Ray r = ray_make(o, vec_sub(target, o), INFINITY);
                PrimHit h;
                RayStats st;
                memset(&st, 0, sizeof st);
                if (accel_closest(acc, &r, &h, &st) < 0)
                    fail_msg("%s at scale %g, offset %g: the ray o=(%a,%a,%a) d=(%a,%a,%a) from inside escaped near %s "
                             "of patch %d",
                             closed_meshes[mi], place[pl][0], place[pl][1], (double)r.o.x, (double)r.o.y, (double)r.o.z,
                             (double)r.d.x, (double)r.d.y, (double)r.d.z, at < 3 ? "a corner" : "an edge's midpoint", pi);
            }
            accel_free(acc);
            scene_free(&pn);
            scene_free(&flat);
        }
    }
    print_message("%ld rays from inside, none escaped\n", total);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_mode_names),
        cmocka_unit_test(test_control_net),
        cmocka_unit_test(test_derivatives),
        cmocka_unit_test(test_subdivision),
        cmocka_unit_test(test_split_program_is_the_blossoms),
        cmocka_unit_test(test_boxes_hold_their_patch),
        cmocka_unit_test(test_shared_edges_bit_for_bit),
        cmocka_unit_test(test_flat_patch_is_the_triangle),
        cmocka_unit_test(test_sphere_approximation),
        cmocka_unit_test(test_closed_surface_does_not_leak),
        cmocka_unit_test(test_t_junction_does_not_leak),
        cmocka_unit_test(test_tessellation),
        cmocka_unit_test(test_exact_hits_within_their_bound),
        cmocka_unit_test(test_grazing_rays),
        cmocka_unit_test(test_avx_is_the_loop),
        cmocka_unit_test(test_fast_mode),
        cmocka_unit_test(test_proofs_agree_with_subdivision),
        cmocka_unit_test(test_slope_and_pieces),
        cmocka_unit_test(test_pieces_keep_their_shape),
        cmocka_unit_test(test_piece_rays_are_one_by_one),
        cmocka_unit_test(test_cgal_meshes_do_not_leak),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
