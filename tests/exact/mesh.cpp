// mesh.cpp - case 2: closed CGAL meshes (from Debian's libcgal-demo data,
// unpacked by scripts/cgal-data.sh), scaled and moved, converted to float
// triangles; origins strictly inside (CGAL::Side_of_triangle_mesh, exact);
// rays aimed at vertices and edge points. The exact answer is always "the
// ray hits the mesh": a ray from a point strictly inside a closed triangle
// mesh must cross it.
#include "judge.h"

#include <algorithm>
#include <array>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <map>
#include <sstream>

#include <CGAL/Exact_predicates_exact_constructions_kernel.h>
#include <CGAL/Side_of_triangle_mesh.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/boost/graph/helpers.h>

namespace judge {

namespace {

typedef CGAL::Epeck K;
typedef K::Point_3 P3;
typedef CGAL::Surface_mesh<P3> Mesh;

// Closed, 2-manifold, free of self-intersections (checked once with
// CGAL::Polygon_mesh_processing::does_self_intersect; is_closed is checked
// at every run), each under 5k triangles.
const char *const MESHES[] = {"eight.off", "anchor.off", "hand.off", "couplingdown.off"};
const int N_TRANSFORMS = 6;
const int POOL = 48;

struct Config {
    std::string name;
    double s;
    double T[3];
    std::vector<Vec3> vf;
    std::vector<std::array<int, 3>> F;
    std::vector<Triangle> tris;
    std::vector<std::vector<int>> vfaces;
    std::vector<std::array<std::vector<int>, 3>> efaces; // faces sharing face f's edge k
    std::vector<Vec3> pool;
};
std::vector<Config> g_cfg;

bool read_off(const std::string &path, std::vector<std::array<double, 3>> &V, std::vector<std::array<int, 3>> &F,
              std::string &err)
{
    std::ifstream in(path);
    if (!in) {
        err = "cannot open " + path + " (run scripts/cgal-data.sh)";
        return false;
    }
    std::vector<std::string> lines;
    std::string line;
    while (std::getline(in, line)) {
        size_t h = line.find('#');
        if (h != std::string::npos)
            line.resize(h);
        if (line.find_first_not_of(" \t\r") != std::string::npos)
            lines.push_back(line);
    }
    if (lines.empty() || lines[0].find("OFF") == std::string::npos) {
        err = path + ": not an OFF file";
        return false;
    }
    size_t at = 1;
    std::istringstream hs(lines[0].substr(lines[0].find("OFF") + 3));
    long nv = -1, nf = -1, ne = 0;
    if (!(hs >> nv >> nf)) {
        std::istringstream h2(lines[at++]);
        h2 >> nv >> nf >> ne;
    }
    if (nv <= 0 || nf <= 0 || lines.size() < at + (size_t)nv + (size_t)nf) {
        err = path + ": bad OFF header";
        return false;
    }
    for (long i = 0; i < nv; i++) {
        std::istringstream ls(lines[at++]);
        std::array<double, 3> p;
        if (!(ls >> p[0] >> p[1] >> p[2])) {
            err = path + ": bad vertex";
            return false;
        }
        V.push_back(p);
    }
    for (long i = 0; i < nf; i++) {
        std::istringstream ls(lines[at++]);
        int n;
        std::array<int, 3> f;
        if (!(ls >> n >> f[0] >> f[1] >> f[2]) || n != 3) {
            err = path + ": not a triangle mesh";
            return false;
        }
        F.push_back(f);
    }
    return true;
}

bool build(Config &c, const std::vector<std::array<double, 3>> &V, Rng &g, bool verbose, std::string &err)
{
    size_t nv = V.size();
    c.vf.resize(nv);
    for (size_t i = 0; i < nv; i++)
        c.vf[i] = vec3((float)(c.s * V[i][0] + c.T[0]), (float)(c.s * V[i][1] + c.T[1]), (float)(c.s * V[i][2] + c.T[2]));
    std::vector<P3> P(nv);
    for (size_t i = 0; i < nv; i++)
        P[i] = P3(c.vf[i].x, c.vf[i].y, c.vf[i].z);
    for (const auto &f : c.F)
        if (CGAL::collinear(P[f[0]], P[f[1]], P[f[2]]))
            return false; // rounding flattened a face: try another transform
    Mesh m;
    std::vector<Mesh::Vertex_index> vi(nv);
    for (size_t i = 0; i < nv; i++)
        vi[i] = m.add_vertex(P[i]);
    for (const auto &f : c.F)
        if (m.add_face(vi[f[0]], vi[f[1]], vi[f[2]]) == Mesh::null_face()) {
            err = c.name + ": add_face failed";
            return false;
        }
    if (!CGAL::is_triangle_mesh(m) || !CGAL::is_closed(m)) {
        err = c.name + ": not a closed triangle mesh";
        return false;
    }
    c.tris.resize(c.F.size());
    c.vfaces.assign(nv, {});
    std::map<std::pair<int, int>, std::vector<int>> edges;
    for (size_t f = 0; f < c.F.size(); f++) {
        std::memset(&c.tris[f], 0, sizeof(Triangle));
        c.tris[f].a = c.vf[c.F[f][0]];
        c.tris[f].b = c.vf[c.F[f][1]];
        c.tris[f].c = c.vf[c.F[f][2]];
        for (int k = 0; k < 3; k++) {
            c.vfaces[c.F[f][k]].push_back((int)f);
            int a = c.F[f][k], b = c.F[f][(k + 1) % 3];
            edges[{std::min(a, b), std::max(a, b)}].push_back((int)f);
        }
    }
    c.efaces.resize(c.F.size());
    for (size_t f = 0; f < c.F.size(); f++)
        for (int k = 0; k < 3; k++) {
            int a = c.F[f][k], b = c.F[f][(k + 1) % 3];
            c.efaces[f][k] = edges[{std::min(a, b), std::max(a, b)}];
        }
    // Origins: uniform in the bounding box, on a grid 2^-14 of its size (so
    // that target - origin is more often exact in float), kept when exactly
    // inside.
    CGAL::Side_of_triangle_mesh<Mesh, K> inside(m);
    float lo[3], hi[3];
    for (int k = 0; k < 3; k++) {
        lo[k] = INFINITY;
        hi[k] = -INFINITY;
    }
    for (const Vec3 &v : c.vf)
        for (int k = 0; k < 3; k++) {
            float x = k == 0 ? v.x : k == 1 ? v.y : v.z;
            lo[k] = std::min(lo[k], x);
            hi[k] = std::max(hi[k], x);
        }
    double ext = std::max({hi[0] - (double)lo[0], hi[1] - (double)lo[1], hi[2] - (double)lo[2]});
    int e;
    std::frexp(ext, &e);
    double step = std::ldexp(1.0, e - 14);
    int tries = 0;
    while ((int)c.pool.size() < POOL && tries < 40000) {
        tries++;
        float q[3];
        for (int k = 0; k < 3; k++)
            q[k] = (float)(std::nearbyint(g.uni(lo[k], hi[k]) / step) * step);
        if (inside(P3(q[0], q[1], q[2])) == CGAL::ON_BOUNDED_SIDE)
            c.pool.push_back(vec3(q[0], q[1], q[2]));
    }
    if (c.pool.empty()) {
        err = c.name + ": no interior origin found";
        return false;
    }
    if (verbose)
        std::printf("judge: mesh %s faces=%zu scale=%g T=(%g,%g,%g) origins=%zu/%d tries\n", c.name.c_str(), c.F.size(),
                    c.s, c.T[0], c.T[1], c.T[2], c.pool.size(), tries);
    return true;
}

} // namespace

bool mesh_setup(const std::string &dir, uint64_t seed, bool verbose, std::string &err)
{
    g_cfg.clear();
    int mi = 0;
    for (const char *name : MESHES) {
        std::vector<std::array<double, 3>> V;
        std::vector<std::array<int, 3>> F;
        if (!read_off(dir + "/" + name, V, F, err))
            return false;
        // Centre on the bounding box, largest extent 1.
        double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
        for (const auto &p : V)
            for (int k = 0; k < 3; k++) {
                lo[k] = std::min(lo[k], p[k]);
                hi[k] = std::max(hi[k], p[k]);
            }
        double ext = std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]});
        for (auto &p : V)
            for (int k = 0; k < 3; k++)
                p[k] = (p[k] - 0.5 * (lo[k] + hi[k])) / ext;
        for (int t = 0; t < N_TRANSFORMS; t++) {
            bool ok = false;
            for (int attempt = 0; attempt < 20 && !ok; attempt++) {
                Rng g(ray_seed(seed, 2, 100 + mi, (uint64_t)(t * 1000 + attempt)));
                Config c;
                c.name = name;
                c.F = F;
                if (t == 0) {
                    c.s = 1.0;
                    c.T[0] = c.T[1] = c.T[2] = 0.0;
                } else {
                    c.s = g.logu(1e-6, 1e6);
                    bool zero = g.coin(0.25);
                    for (int k = 0; k < 3; k++)
                        c.T[k] = zero ? 0.0 : g.sgn() * c.s * g.logu(1e-3, 1024.0);
                }
                std::string e2;
                if (build(c, V, g, verbose, e2)) {
                    g_cfg.push_back(std::move(c));
                    ok = true;
                } else if (!e2.empty()) {
                    err = e2;
                    return false;
                }
            }
            if (!ok) {
                err = std::string(name) + ": every transform flattened a face";
                return false;
            }
        }
        mi++;
    }
    return true;
}

// Exact aim: o + d == target exactly (checked with an error-free sum).
static bool exact_sum(float o, float d, float target)
{
    double a = target, b = -(double)o, s = a + b, bb = s - a, err = (a - (s - bb)) + (b - bb);
    return err == 0.0 && s == (double)d;
}

void mesh_ray(int rid, uint64_t base_seed, uint64_t ray, Stats &st, bool verbose)
{
    Rng g(ray_seed(base_seed, 2, rid, ray));
    const Config &c = g_cfg[g.below((int)g_cfg.size())];
    Vec3 o = c.pool[g.below((int)c.pool.size())], target;
    std::vector<int> first, through;
    bool vertex = g.coin(0.5);
    if (vertex) {
        int v = g.below((int)c.vf.size());
        target = c.vf[v];
        first = c.vfaces[v];
    } else {
        int f = g.below((int)c.F.size()), k = g.below(3);
        Vec3 a = c.vf[c.F[f][k]], b = c.vf[c.F[f][(k + 1) % 3]];
        double l = g.coin(0.3) ? 0.5 : g.uni(0.02, 0.98);
        target = vec3((float)(a.x + l * ((double)b.x - a.x)), (float)(a.y + l * ((double)b.y - a.y)),
                      (float)(a.z + l * ((double)b.z - a.z)));
        first = c.efaces[f][k];
    }
    Vec3 d = vec_sub(target, o);
    if (!(vec_max_abs(d) > 0.0f)) {
        st.c[C_SKIP]++;
        return;
    }
    bool exact = exact_sum(o.x, d.x, target.x) && exact_sum(o.y, d.y, target.y) && exact_sum(o.z, d.z, target.z);
    if (g.coin(0.5)) {
        Vec3 n = vec_normalize(d);
        if (vec_max_abs(n) > 0.0f && vec_is_finite(n)) {
            d = n;
            exact = false;
        }
    }
    if (exact) {
        st.c[C_EXACTAIM]++;
        if (vertex)
            through = first; // every face around the vertex contains the target
    }
    if (verbose)
        std::printf("  mesh %s scale=%g: origin inside, aimed at %s%s\n", c.name.c_str(), c.s,
                    vertex ? "a vertex" : "an edge point", exact ? " (exactly)" : "");
    union_ray(rid, c.tris.data(), c.tris.size(), first, through, ray_make(o, d, INFINITY), st, ray, verbose);
}

} // namespace judge
