// judge.h - the exact judge's shared declarations, free of CGAL so that the
// generators (cases.cpp) compile fast; exact.cpp and mesh.cpp hold the CGAL.
//
// Every intersection routine of include/lancer/prim.h is called on float
// inputs and its answer compared with the exact answer for exactly those
// float bits, computed with CGAL's Epeck (floats are exact rationals).
#ifndef LANCER_EXACT_JUDGE_H
#define LANCER_EXACT_JUDGE_H

#include <cmath>
#include <math.h>
#include <cstdint>
#include <string>
#include <vector>

extern "C" {
#include "lancer/prim.h"
}

namespace judge {

// ---- deterministic random numbers: one stream per (case, routine, ray) ----

static inline uint64_t splitmix64(uint64_t &x)
{
    uint64_t z = (x += 0x9e3779b97f4a7c15ULL);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
}

struct Rng {
    uint64_t s[4];
    explicit Rng(uint64_t seed)
    {
        for (auto &x : s)
            x = splitmix64(seed);
    }
    static uint64_t rotl(uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }
    uint64_t next()
    {
        uint64_t r = rotl(s[1] * 5, 7) * 9, t = s[1] << 17;
        s[2] ^= s[0];
        s[3] ^= s[1];
        s[1] ^= s[2];
        s[0] ^= s[3];
        s[2] ^= t;
        s[3] = rotl(s[3], 45);
        return r;
    }
    double uni() { return (double)(next() >> 11) * 0x1p-53; }
    double uni(double a, double b) { return a + (b - a) * uni(); }
    int below(int n) { return (int)(uni() * n); }
    long ibetween(long lo, long hi) { return lo + (long)(uni() * (double)(hi - lo + 1)); }
    bool coin(double p) { return uni() < p; }
    double sgn() { return coin(0.5) ? 1.0 : -1.0; }
    double logu(double lo, double hi) { return lo * std::pow(hi / lo, uni()); }
};

uint64_t ray_seed(uint64_t base, int case_id, int routine, uint64_t ray);

// ---- the routines under test ----

enum Kind { K_PLANE, K_SPHERE, K_TRI, K_BOX, K_OBOX, K_PN, K_ELL };

struct Routine {
    const char *name;
    Kind kind;
    bool robust;
};

// The PN routines are judged by cases 9 (R_PN_BOX, not an intersection
// routine) and 10 (pn_hit in each mode) alone (pn.cpp), the ellipsoid's by
// case 11 alone (last, so that the other routines' seeds stay as they were).
enum {
    R_PLANE,
    R_PLANE_ROB,
    R_SPHERE,
    R_SPHERE_ROB,
    R_TRI,
    R_TRI_WT,
    R_BOX,
    R_BOX_ROB,
    R_OBOX,
    R_OBOX_ROB,
    R_PN_BOX,
    R_PN_EXACT,
    R_PN_FAST,
    R_ELL,
    R_ELL_ROB,
    R_PN_PIECES, // last: the others' seeds stay as they were
    N_ROUTINES
};
extern const Routine ROUTINES[N_ROUTINES];

int call_routine(int rid, const Prim &p, const Ray &r, PrimHit &h);

// ---- counters: one set per (case, routine) ----

enum Cnt {
    C_RAYS,
    C_AGREE,
    C_FMISS,
    C_FHIT,
    C_BAND,
    C_OUTBAND,
    C_TBFAIL,
    C_SELFHIT,
    C_SPAWN,    // spawned origins checked (case 8)
    C_NEARBAND, // rays (any verdict) inside the routine's own band: near-tangent, near-parallel, near-edge
    C_EXACTAIM, // rays that pass exactly through their float target (cases 2-4)
    C_TRIMISS,  // case 2/3: (ray, triangle) single-triangle misses at exact hits (allowed, in band)
    C_SKIP,     // generated inputs rejected (degenerate), not counted in rays
    C_INTERNAL, // judge self-checks that failed (never expected)
    C_OB_NONUNIT, // outside-band disagreements whose ray direction is far from unit length (|d|^2 not in [1/4, 4])
    C_BOXFAIL,    // case 9: PN boxes that miss a control point of their exact sub-patch
    C_UVFAIL,     // case 10: hits whose (u, v) is not where the ray's point at t is
    C_UNDECIDED,  // case 10: rays the exact side gave up on (its work cap), not judged
    C_FMISS_BAND, // false misses inside the band (C_FMISS - C_FMISS_BAND are outside it)
    C_FHIT_BAND,  // false hits inside the band
    C_EXACTTHRU,  // case 11: lattice rays exactly through a surface point, transversally
    C_SPAWNSKIP,  // case 11: spawns not judged, the direction on no certain side of the exact surface
    N_CNT
};

struct Fail {
    uint64_t ray;
    std::string kind, text;
};

struct Stats {
    uint64_t c[N_CNT] = {};
    std::vector<double> ulp;
    std::vector<Fail> fails;
    void fail(uint64_t ray, const std::string &kind, const std::string &text);
    bool wants(const std::string &kind) const; // fail() would still record this kind
    void merge(const Stats &o);
    std::string serialize() const;
    static Stats deserialize(const std::string &s);
};

// ---- judging (exact.cpp) ----

// The verdict on one routine and one ray.
struct Verdict {
    int got = 0;
    PrimHit h{};
    int code = -1;      // -1 skipped (degenerate input), 0 agree miss, 1 agree hit, 2 false hit, 3 false miss
    bool ex_hit = false;
    double t_exact = 0; // approximately
};

// Calls routine rid on (p, r), judges it exactly and counts into st.
Verdict judge_single(int rid, const Prim &p, const Ray &r, Stats &st, uint64_t ray, bool verbose);

// The exact verdict alone (for the generators' self-checks).
bool exact_hit(const Prim &p, const Ray &r);

// Case 8: after an agreed hit (v from judge_single), prim_surface and
// prim_spawn_origin with a direction on the side of the geometric normal
// facing the incoming ray: -d itself when `back` (exactly on that side), else
// the surface normal turned by up to ~80 degrees towards w. Checks exactly
// that the spawned origin lies strictly on that side of the surface (solids:
// outside when the ray came from outside, inside when from inside) and that
// the segment of length ~L from it does not hit the primitive. Counts C_SPAWN
// and C_SELFHIT. Case 11 calls it too; for an ellipsoid a direction is
// judged only when it lies on the incoming side of the exact surface by
// 2^-16 |dir| against the exact normal at the exact hit, else it counts
// C_SPAWNSKIP: nearer the tangent plane a float normal cannot tell the
// sides apart.
void spawn_check(int rid, const Prim &p, const Ray &r, const PrimHit &h, bool back, Vec3 w, double L, Stats &st,
                 uint64_t ray, bool verbose);

// A solid whose interior holds floats well away from its surface: its
// thinnest extent is at least 2^12 ulps of its coordinates. (A box one ulp
// thick has no float strictly inside; case 8 does not spawn into such.) An
// ellipsoid's measure is a lower bound on its smallest radius of curvature
// (b^2 / a at the tip of its longest axis), which is its sphere's radius.
bool solid_resolved(const Prim &p);

// Case 11: the sign of the exact discriminant of g(t) = |A (o + t d) + b|^2
// - 1 for an ellipsoid (A, b its stored a[] as exact rationals), for the
// generator's self-checks; 2 for a degenerate ray (d = 0).
int ell_disc_sign(const Prim &p, const Ray &r);

// Cases 2 and 3: a ray whose exact answer is "hits the union of tris" (the
// caller guarantees it: origin inside a closed mesh, or a transversal pass
// through a shared edge or vertex). Tries the triangles in `first`, then
// all; counts a false miss when no triangle reports a hit. `through` lists
// triangles the ray must hit exactly (a self-check; may be empty).
void union_ray(int rid, const Triangle *tris, size_t n, const std::vector<int> &first, const std::vector<int> &through,
               const Ray &r, Stats &st, uint64_t ray, bool verbose);

std::string fmt_prim(const Prim &p);
std::string hexd(double x);
std::string fmt_ray(const Ray &r);
std::string hexf(float x);

// ---- case 2: closed meshes (mesh.cpp) ----

bool mesh_setup(const std::string &dir, uint64_t seed, bool verbose, std::string &err);
void mesh_ray(int rid, uint64_t base_seed, uint64_t ray, Stats &st, bool verbose);
// Case 9 (pn.cpp): one PN patch split along a random path, each box checked.
void pn_box_ray(int rid, Rng &g, Stats &st, uint64_t ray, bool verbose);
// Case 10 (pn.cpp): one ray against one PN patch, pn_hit judged exactly.
void pn_ray(int rid, Rng &g, Stats &st, uint64_t ray, bool verbose);

} // namespace judge

#endif
