/*
 * prim.c - ray/primitive intersection for planes, spheres, boxes and
 * oriented boxes: the classic routines as the literature gives them, and
 * robust variants beside them (see prim.h for the contract each keeps);
 * triangles are in tri.c. Also the hit point, normals and spawn origins of
 * every primitive.
 *
 * The robust routines work in double on float inputs (a product of two
 * floats is exact in double), round the answer to float, and report a
 * bound that covers both, by Higham's gamma(n) (rounding.h).
 */
#include "lancer/prim.h"

#include <float.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "lancer/pntri.h"
#include "dvec.h"
#include "rounding.h"

/* Four rays' plane tests at once with AVX, when the processor has it
 * (picked at run time: the rest of the file is built for the baseline). */
#if defined(__GNUC__) && defined(__x86_64__) && !defined(LANCER_NO_SIMD)
#define PRIM_AVX 1
#include <immintrin.h>

#include "ray_lanes.h"
#endif

/* prim_surface takes a triangle's normal in double where its length is
 * outside these, whose squares neither over- nor underflow in float. */
#define TRI_NORMAL_MIN 0x1p-60f
#define TRI_NORMAL_MAX 0x1p60f

/* The spawn margin off a triangle, in units of gamma (tri_spawn_margin):
 * 16 times the least that test_prim's triangles need. */
#define TRI_SPAWN_GAMMA 64

/* t as a float, and a float bound covering both err (a bound on |t - exact|)
 * and the rounding of t itself. */
static float round_t(double t, double err, float *terr)
{
    float tf = (float)t;
    *terr = float_up(err + fabs((double)tf - t));
    return tf;
}

int prim_plane_hit(const Plane *pl, const Ray *r, PrimHit *h)
{
    float denom = vec_dot(r->d, pl->n);
    if (denom == 0.0f)
        return 0; /* parallel: no single intersection point */
    /* a = d*n is a point of the plane, so (a - o).n = d - o.n. */
    float th = (pl->d - vec_dot(r->o, pl->n)) / denom;
    if (!(th > 0.0f && th < r->tmax))
        return 0;
    *h = (PrimHit){th, 0.0f, 0.0f, 0.0f, 0};
    return 1;
}

int prim_sphere_hit(const Sphere *s, const Ray *r, PrimHit *h)
{
    Vec3 oc = vec_sub(r->o, s->c);
    float a = vec_dot(r->d, r->d);
    float b = 2.0f * vec_dot(r->d, oc);
    float c = vec_dot(oc, oc) - s->r * s->r;
    float disc = b * b - 4.0f * a * c;
    if (disc < 0.0f)
        return 0; /* a tangent ray (disc == 0) counts as a hit */
    float sq = sqrtf(disc);
    float th = (-b - sq) / (2.0f * a);
    if (!(th > 0.0f))
        th = (-b + sq) / (2.0f * a); /* origin inside, or near root behind */
    if (!(th > 0.0f && th < r->tmax))
        return 0;
    *h = (PrimHit){th, 0.0f, 0.0f, 0.0f, 0};
    return 1;
}

/* The slab test's verdict (Kay and Kajiya): the entry tnear when it lies
 * ahead, else the exit tfar when the origin is inside; the face is the
 * axis of the slab crossed. */
static int slab_hit(float tnear, float tfar, int near_axis, int far_axis, float tmax, PrimHit *h)
{
    if (tnear > 0.0f && tnear < tmax) {
        *h = (PrimHit){tnear, 0.0f, 0.0f, 0.0f, near_axis};
        return 1;
    }
    if (tnear <= 0.0f && tfar > 0.0f && tfar < tmax) { /* origin inside */
        *h = (PrimHit){tfar, 0.0f, 0.0f, 0.0f, far_axis};
        return 1;
    }
    return 0;
}

int prim_box_hit(const Box *b, const Ray *r, PrimHit *h)
{
    /* Williams et al.: the sign of the inverse direction picks which bound is
     * the near plane, so no swaps are needed and -0 directions work. */
    const Vec3 bounds[2] = {b->lo, b->hi};
    float tnear = -INFINITY, tfar = INFINITY;
    int near_axis = 0, far_axis = 0;
    for (int i = 0; i < 3; i++) {
        float inv = 1.0f / vec_comp(r->d, i);
        int sign = inv < 0.0f;
        float o = vec_comp(r->o, i);
        float t0 = (vec_comp(bounds[sign], i) - o) * inv;
        float t1 = (vec_comp(bounds[1 - sign], i) - o) * inv;
        if (tnear > t1 || t0 > tfar)
            return 0;
        if (t0 > tnear) {
            tnear = t0;
            near_axis = i;
        }
        if (t1 < tfar) {
            tfar = t1;
            far_axis = i;
        }
    }
    return slab_hit(tnear, tfar, near_axis, far_axis, r->tmax, h);
}

int prim_obox_init(OBox *b)
{
    /* Rows of the inverse of M = [u v w] are the cross products of the other
     * two columns over the determinant. */
    Vec3 vw = vec_cross(b->v, b->w), wu = vec_cross(b->w, b->u), uv = vec_cross(b->u, b->v);
    float det = vec_dot(b->u, vw);
    if (!(fabsf(det) > 0.0f) || !isfinite(det) || !isfinite(1.0f / det))
        return -1;
    b->inv[0] = vec_scale(vw, 1.0f / det);
    b->inv[1] = vec_scale(wu, 1.0f / det);
    b->inv[2] = vec_scale(uv, 1.0f / det);
    return 0;
}

int prim_obox_hit(const OBox *b, const Ray *r, PrimHit *h)
{
    Vec3 rel = vec_sub(r->o, b->c);
    float tnear = -INFINITY, tfar = INFINITY;
    int near_axis = 0, far_axis = 0;
    for (int i = 0; i < 3; i++) {
        /* The ray in box coordinates, where the slabs are -1 <= x_i <= 1. */
        float o = vec_dot(b->inv[i], rel);
        float d = vec_dot(b->inv[i], r->d);
        if (d == 0.0f) {
            if (o < -1.0f || o > 1.0f)
                return 0; /* parallel to this slab and outside it */
            continue;
        }
        float t0 = (-1.0f - o) / d, t1 = (1.0f - o) / d;
        if (t0 > t1) {
            float tmp = t0;
            t0 = t1;
            t1 = tmp;
        }
        if (t0 > tnear) {
            tnear = t0;
            near_axis = i;
        }
        if (t1 < tfar) {
            tfar = t1;
            far_axis = i;
        }
    }
    if (!(tnear < tfar))
        return 0;
    return slab_hit(tnear, tfar, near_axis, far_axis, r->tmax, h);
}

/* ---- robust ---- */

/* t = num / den, computed from double values known to within e_num and
 * e_den: the bound on |t - exact| (valid while e_den < |den|). */
static double quotient_err(double t, double den, double e_num, double e_den)
{
    return (e_num + fabs(t) * e_den) / (fabs(den) - e_den) + gamma_d(1) * fabs(t);
}

int prim_plane_hit_robust(const Plane *pl, const Ray *r, PrimHit *h)
{
    /* Products of two floats are exact in double; only the sums round. */
    double nx = pl->n.x, ny = pl->n.y, nz = pl->n.z;
    double dx = nx * r->d.x, dy = ny * r->d.y, dz = nz * r->d.z;
    double den = dx + dy + dz;
    double ox = nx * r->o.x, oy = ny * r->o.y, oz = nz * r->o.z;
    double num = (double)pl->d - (ox + oy + oz);
    /* Two verdicts without the divisions below, the same as theirs: t = num
     * / den is <= 0, or at least tmax (so is its rounding: tmax is a float;
     * the product's rounding is covered by 2^-50). Shadow rays off the
     * plane and rays stopped short of it by a nearer hit end here. The
     * first comes before the error bounds: either way it is a miss. */
    if (num == 0.0 || (num < 0.0) != (den < 0.0))
        return 0;
    double e_den = gamma_d(2) * (fabs(dx) + fabs(dy) + fabs(dz));
    if (!(fabs(den) > e_den))
        return 0; /* parallel to working precision: a miss, by definition */
    double reach = (double)r->tmax * fabs(den);
    if (reach > 0x1p-1000 && fabs(num) >= reach * (1.0 + 0x1p-50))
        return 0;
    double e_num = gamma_d(2) * (fabs(ox) + fabs(oy) + fabs(oz)) + gamma_d(1) * fabs(num);
    double t = num / den;
    float terr, tf = round_t(t, quotient_err(t, den, e_num, e_den), &terr);
    if (!(tf > 0.0f && tf < r->tmax))
        return 0;
    *h = (PrimHit){tf, terr, 0.0f, 0.0f, 0};
    return 1;
}

#ifdef PRIM_AVX
/* The 32-bit lanes of a 64-bit lane mask. */
__attribute__((target("avx"))) static inline __m128 mask_ps(__m256d m)
{
    __m256 f = _mm256_castpd_ps(m);
    return _mm_shuffle_ps(_mm256_castps256_ps128(f), _mm256_extractf128_ps(f, 1), _MM_SHUFFLE(2, 0, 2, 0));
}

/* float_up for four lanes x >= 0, the same operations lane by lane (for
 * such x, float_next(f, 1) is f's bits plus 1). */
__attribute__((target("avx"))) static inline __m128 float_up4(__m256d x)
{
    __m128 f = _mm256_cvtpd_ps(x);
    __m128 big = _mm_cmpge_ps(f, _mm_set1_ps(FLT_MIN));
    __m128 g = _mm_or_ps(_mm_and_ps(big, _mm_mul_ps(f, _mm_set1_ps(1.0f + FLT_EPSILON))),
                         _mm_andnot_ps(big, _mm_castsi128_ps(_mm_add_epi32(_mm_castps_si128(f), _mm_set1_epi32(1)))));
    __m128 keep = mask_ps(_mm256_cmp_pd(_mm256_cvtps_pd(f), x, _CMP_GE_OQ));
    return _mm_or_ps(_mm_and_ps(keep, f), _mm_andnot_ps(keep, g));
}
#endif

/* g(t) = |f + t d|^2 - r2, the exact sphere equation along the ray, in
 * double with a bound on its error: its sign is certain when |g| > *err.
 * f = o - c carries at most one rounding per coordinate. */
static double sphere_g(const double f[3], const float d[3], double r2, double t, double *err)
{
    double g = -r2, e = 0.0, mag = r2;
    for (int i = 0; i < 3; i++) {
        double td = t * (double)d[i];
        double p = f[i] + td;
        /* f[i] (1 rounding), t*d (1), the sum (1) */
        double ep = gamma_d(3) * (fabs(f[i]) + fabs(td));
        g += p * p;
        e += 2.0 * fabs(p) * ep + ep * ep;
        mag += p * p;
    }
    *err = e + gamma_d(5) * mag;
    return g;
}

/* An exact function of t along a ray, evaluated in double with a bound on
 * its error: the sphere's or the ellipsoid's g. */
typedef double (*GFn)(const void *ctx, double t, double *err);

typedef struct {
    const double *f;
    const float *d;
    double r2;
} SphereG;

static double sphere_gfn(const void *ctx, double t, double *err)
{
    const SphereG *c = ctx;
    return sphere_g(c->f, c->d, c->r2, t, err);
}

/* certify_root's first half-width, in units of double roundoff of t */
#define CERTIFY_START 128.0

/* Certifies a root of g near t: widens a bracket until g changes sign
 * across it with certainty (then exactly one root lies inside). Returns the
 * bracket's half-width, or -1 when no certain sign change was found (a
 * near-double root: the ray is tangent to working precision). */
static double certify_root(GFn g, const void *ctx, double t)
{
    /* Start from the double computation's own accuracy, some double ulps:
     * starting at float ulps would swallow both roots of a sphere less than
     * a few float ulps deep along the ray (a small sphere far away). g's
     * error bound along a ray from afar is about 10 u t r, the slope at
     * the root 2 r cos(angle of incidence): a half-width of 128 u t is
     * certain from cos 0.1 up, where 16 u t needed about 0.5, and hits
     * from afar took a second round. */
    double w = CERTIFY_START * UNIT_D * fabs(t) + 1e-300;
    for (int k = 0; k < 24; k++, w *= 8.0) {
        double e_lo, e_hi;
        double g_lo = g(ctx, t - w, &e_lo);
        double g_hi = g(ctx, t + w, &e_hi);
        if (fabs(g_lo) > e_lo && fabs(g_hi) > e_hi && (g_lo > 0) != (g_hi > 0))
            return w + 2.0 * UNIT_D * (fabs(t) + w); /* t -+ w rounded: the bracket g was evaluated on */
    }
    return -1.0;
}

/* Both roots t0 <= t1 of |f + t d|^2 = r2, d here in double, by Ray
 * Tracing Gems ch. 7: the discriminant from the vector l between the
 * centre and the ray's closest point, which does not cancel the way
 * b^2 - ac does for distant spheres. Returns 0 when there are none, or
 * when q is 0 (no usable root). */
static inline int stable_roots(const double f[3], const double d[3], double r2, double *t0, double *t1)
{
    double a = 0.0, b = 0.0, ff = 0.0;
    for (int i = 0; i < 3; i++) {
        a += d[i] * d[i];
        b += f[i] * d[i];
        ff += f[i] * f[i];
    }
    /* From outside and moving away (a ray leaving the surface outwards):
     * below, q < 0, so t1 < 0 and t0 < 0, and there is no usable root.
     * Said here, before the divisions and the square root. */
    if (b > 0.0 && ff - r2 > 0.0)
        return 0;
    double k = b / a, l2 = 0.0;
    for (int i = 0; i < 3; i++) {
        double li = f[i] - k * d[i];
        l2 += li * li;
    }
    double disc = a * (r2 - l2);
    if (!(disc >= 0.0))
        return 0;
    double q = -(b + copysign(sqrt(disc), b));
    *t0 = (ff - r2) / q;
    *t1 = q / a;
    if (*t0 > *t1) {
        double tmp = *t0;
        *t0 = *t1;
        *t1 = tmp;
    }
    return q != 0.0;
}

/* The nearer root with t > 0 (the far one when the origin is inside), or
 * 0 for none. */
static inline int stable_root(const double f[3], const double d[3], double r2, double *t)
{
    double t0, t1;
    if (!stable_roots(f, d, r2, &t0, &t1))
        return 0;
    *t = t0 > 0.0 ? t0 : t1;
    return *t > 0.0;
}

/* The robust hit of a quadric along ray r, |f + t d|^2 = r2 in the space
 * where it is a sphere (d there in double), whose exact g the certificate
 * evaluates: the nearer root with t > 0, certified, rounded, within
 * (0, tmax). Returns 0 for a miss. */
static int quadric_hit(const double f[3], const double d[3], double r2, GFn g, const void *ctx, const Ray *r,
                       PrimHit *h)
{
    double t;
    if (!stable_root(f, d, r2, &t))
        return 0;
    double w = certify_root(g, ctx, t);
    if (w < 0.0)
        return 0; /* tangent to working precision: a miss, by definition */
    float terr, tf = round_t(t, w, &terr);
    if (!(tf > 0.0f && tf < r->tmax))
        return 0;
    *h = (PrimHit){tf, terr, 0.0f, 0.0f, 0};
    return 1;
}

int prim_sphere_hit_robust(const Sphere *s, const Ray *r, PrimHit *h)
{
    const float d[3] = {r->d.x, r->d.y, r->d.z};
    const double dd[3] = {d[0], d[1], d[2]};
    const double f[3] = {(double)r->o.x - s->c.x, (double)r->o.y - s->c.y, (double)r->o.z - s->c.z};
    const SphereG g = {f, d, (double)s->r * s->r}; /* r^2 is exact */
    return quadric_hit(f, dd, g.r2, sphere_gfn, &g, r, h);
}

#ifdef PRIM_AVX
/* round_t for four lanes, t and its half-width: t_out and terr_out, and
 * the lanes whose t lies in (0, tmax). */
__attribute__((target("avx"))) static inline unsigned round_t4(__m256d t, __m256d half, __m128 tmax, float *t_out,
                                                              float *terr_out)
{
    __m128 tf = _mm256_cvtpd_ps(t);
    __m256d off = _mm256_andnot_pd(_mm256_set1_pd(-0.0), _mm256_sub_pd(_mm256_cvtps_pd(tf), t)); /* |tf - t| */
    __m128 terr = float_up4(_mm256_add_pd(half, off));
    __m128 in = _mm_and_ps(_mm_cmpgt_ps(tf, _mm_setzero_ps()), _mm_cmplt_ps(tf, tmax));
    _mm_storeu_ps(t_out, tf);
    _mm_storeu_ps(terr_out, terr);
    return (unsigned)_mm_movemask_ps(in);
}

/* Four lanes, AVX. */
#define Q_NAME(f) f##4
#define Q_ATTR __attribute__((target("avx")))
#define Q_W 4
#define Q_ALL 15u
#define Q_LOAD_F _mm_loadu_ps
#define Q_CVT_PD _mm256_cvtps_pd
#define Q_F __m128
#define Q_FIELDS ray_fields
#define Q_ROUND_T round_t4
#define Q_STORE_I32(p, v) _mm_storeu_si128((__m128i *)(p), _mm256_cvttpd_epi32(v))
#define Q_V __m256d
#define Q_M __m256d
#define QV_SET1 _mm256_set1_pd
#define QV_ADD _mm256_add_pd
#define QV_SUB _mm256_sub_pd
#define QV_MUL _mm256_mul_pd
#define QV_DIV _mm256_div_pd
#define QV_SQRT _mm256_sqrt_pd
#define QV_ABS(x) _mm256_andnot_pd(_mm256_set1_pd(-0.0), x)
#define QV_NEG(x) _mm256_xor_pd(x, _mm256_set1_pd(-0.0))
#define QV_COPYSIGN(x, s) _mm256_or_pd(QV_ABS(x), _mm256_and_pd(_mm256_set1_pd(-0.0), s))
#define QV_BLEND _mm256_blendv_pd /* (a, b, m): b where m is set */
#define QV_CMP _mm256_cmp_pd
#define QM_AND _mm256_and_pd
#define QM_OR _mm256_or_pd
#define QM_ANDNOT _mm256_andnot_pd /* (a, b): b and not a */
#define QM_XOR _mm256_xor_pd
#define QM_BITS(m) ((unsigned)_mm256_movemask_pd(m))
#define QM_NONE _mm256_setzero_pd()
#include "prim_lanes.h"

#define AVX512 __attribute__((target("avx512f,avx512dq")))

/* round_t for eight lanes, as two halves of four. */
AVX512 static inline unsigned round_t8(__m512d t, __m512d half, __m256 tmax, float *t_out, float *terr_out)
{
    unsigned lo = round_t4(_mm512_castpd512_pd256(t), _mm512_castpd512_pd256(half), _mm256_castps256_ps128(tmax), t_out,
                           terr_out);
    unsigned hi = round_t4(_mm512_extractf64x4_pd(t, 1), _mm512_extractf64x4_pd(half, 1),
                           _mm256_extractf128_ps(tmax, 1), t_out + 4, terr_out + 4);
    return lo | hi << 4;
}

/* Eight lanes, AVX-512. */
#define Q_NAME(f) f##8
#define Q_ATTR AVX512
#define Q_W 8
#define Q_ALL 255u
#define Q_LOAD_F _mm256_loadu_ps
#define Q_CVT_PD _mm512_cvtps_pd
#define Q_F __m256
#define Q_FIELDS ray_fields8
#define Q_ROUND_T round_t8
#define Q_STORE_I32(p, v) _mm256_storeu_si256((__m256i *)(p), _mm512_cvttpd_epi32(v))
#define Q_V __m512d
#define Q_M __mmask8
#define QV_SET1 _mm512_set1_pd
#define QV_ADD _mm512_add_pd
#define QV_SUB _mm512_sub_pd
#define QV_MUL _mm512_mul_pd
#define QV_DIV _mm512_div_pd
#define QV_SQRT _mm512_sqrt_pd
#define QV_ABS(x) _mm512_andnot_pd(_mm512_set1_pd(-0.0), x)
#define QV_NEG(x) _mm512_xor_pd(x, _mm512_set1_pd(-0.0))
#define QV_COPYSIGN(x, s) _mm512_or_pd(QV_ABS(x), _mm512_and_pd(_mm512_set1_pd(-0.0), s))
#define QV_BLEND(a, b, m) _mm512_mask_blend_pd(m, a, b)
#define QV_CMP _mm512_cmp_pd_mask
#define QM_AND(a, b) ((__mmask8)((a) & (b)))
#define QM_OR(a, b) ((__mmask8)((a) | (b)))
#define QM_ANDNOT(a, b) ((__mmask8)(~(a) & (b)))
#define QM_XOR(a, b) ((__mmask8)((a) ^ (b)))
#define QM_BITS(m) ((unsigned)(m))
#define QM_NONE ((__mmask8)0)
#include "prim_lanes.h"
#undef AVX512

/* The processor runs the four-lane routines: it has AVX. */
static int prim_avx(void) { return __builtin_cpu_supports("avx"); }
#endif

unsigned prim_plane_hit_robust_rays(const Plane *pl, const Ray *r, const float *tmax, int n, PrimHit *h)
{
    unsigned hit = 0;
    int k = 0;
#ifdef PRIM_AVX
    if (prim_avx()) {
        const int eight = avx512_lanes_pay();
        while (k + 4 <= n) { /* eight lanes where avx512_lanes_pay() allows, else four */
            const int w = eight && k + 8 <= n ? 8 : 4;
            float t[8], terr[8];
            unsigned m = w == 8 ? plane_hit8(pl, r, k, tmax, t, terr) : plane_hit4(pl, r, k, tmax, t, terr);
            for (unsigned b = m; b; b &= b - 1) { /* the lanes hit: no other is read */
                int j = __builtin_ctz(b);
                h[k + j] = (PrimHit){t[j], terr[j], 0.0f, 0.0f, 0};
            }
            hit |= m << k;
            k += w;
        }
    }
#endif
    for (; k < n; k++) { /* the rest one by one */
        Ray q = r[k];
        q.tmax = tmax[k];
        PrimHit c = {0.0f, 0.0f, 0.0f, 0.0f, 0};
        hit |= (unsigned)prim_plane_hit_robust(pl, &q, &c) << k;
        h[k] = c;
    }
    return hit;
}

/* ---- ellipsoid ---- */

int prim_ellipsoid_init(Ellipsoid *e)
{
    const double *m = e->m;
    double c[9]; /* cofactors: the inverse times det */
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            int r0 = (j + 1) % 3, r1 = (j + 2) % 3, c0 = (i + 1) % 3, c1 = (i + 2) % 3;
            c[3 * i + j] = m[3 * r0 + c0] * m[3 * r1 + c1] - m[3 * r0 + c1] * m[3 * r1 + c0];
        }
    double det = m[0] * c[0] + m[1] * c[3] + m[2] * c[6];
    if (!(fabs(det) > 0.0) || !isfinite(det))
        return -1;
    for (int k = 0; k < 9; k++)
        e->a[k] = c[k] / det;
    for (int i = 0; i < 3; i++)
        e->a[9 + i] = -(e->a[3 * i] * m[9] + e->a[3 * i + 1] * m[10] + e->a[3 * i + 2] * m[11]);
    for (int k = 0; k < 12; k++)
        if (!isfinite(e->a[k]) || !isfinite(m[k]))
            return -1;
    return 0;
}

/* g(t) = |A (o + t d) + b|^2 - 1 in double, with a bound on its error: its
 * sign is certain when |g| > *err. */
typedef struct {
    const double *a;
    const float *o, *d;
} EllG;

static double ell_g(const void *ctx, double t, double *err)
{
    const EllG *c = ctx;
    const double *a = c->a;
    double y[3], ey[3];
    for (int j = 0; j < 3; j++) {
        double td = t * (double)c->d[j];
        y[j] = (double)c->o[j] + td;
        ey[j] = gamma_d(2) * (fabs((double)c->o[j]) + fabs(td)); /* t*d (1), the sum (1) */
    }
    double g = -1.0, e = 0.0, mag = 1.0;
    for (int i = 0; i < 3; i++) {
        double x = a[9 + i], m = fabs(a[9 + i]), ex = 0.0;
        for (int j = 0; j < 3; j++) {
            x += a[3 * i + j] * y[j];
            m += fabs(a[3 * i + j] * y[j]);
            ex += fabs(a[3 * i + j]) * ey[j];
        }
        /* y's errors through A, and the four-term sum's own roundings */
        ex = ex * (1.0 + gamma_d(4)) + gamma_d(4) * m;
        g += x * x;
        e += 2.0 * fabs(x) * ex + ex * ex;
        mag += x * x;
    }
    /* the bound's own arithmetic rounds too: a few ulps more */
    *err = (e + gamma_d(5) * mag) * (1.0 + gamma_d(8));
    return g;
}

/* The ray in the unit sphere's space: f = A o + b, and A d. */
static void ell_ray(const double *a, const Ray *r, double f[3], double d[3])
{
    for (int i = 0; i < 3; i++) {
        const double *row = a + 3 * i;
        f[i] = row[0] * r->o.x + row[1] * r->o.y + row[2] * r->o.z + a[9 + i];
        d[i] = row[0] * r->d.x + row[1] * r->d.y + row[2] * r->d.z;
    }
}

int prim_ellipsoid_hit(const Ellipsoid *e, const Ray *r, PrimHit *h)
{
    double f[3], d[3];
    ell_ray(e->a, r, f, d);
    static const Sphere unit = {{0.0f, 0.0f, 0.0f}, 1.0f};
    Ray o = *r;
    o.o = vec3((float)f[0], (float)f[1], (float)f[2]);
    o.d = vec3((float)d[0], (float)d[1], (float)d[2]);
    return prim_sphere_hit(&unit, &o, h);
}

int prim_ellipsoid_hit_robust(const Ellipsoid *e, const Ray *r, PrimHit *h)
{
    const float o[3] = {r->o.x, r->o.y, r->o.z}, d[3] = {r->d.x, r->d.y, r->d.z};
    double f[3], dd[3];
    ell_ray(e->a, r, f, dd);
    const EllG g = {e->a, o, d};
    return quadric_hit(f, dd, 1.0, ell_g, &g, r, h);
}

int prim_box_hit_robust(const Box *b, const Ray *r, PrimHit *h)
{
    /* Williams' slab test in double on the float inputs, made conservative
     * after Ize: each slab distance (bound - o) * (1/d) is within gamma(3)
     * of exact, so growing every far distance by PRIM_BOX_PAD (prim.h)
     * keeps every true hit. In double, 1/d cannot overflow for any float d
     * (subnormal directions included). The near plane is picked by the sign
     * of 1/d, never by comparing distances, so the NaN of 0 * inf (an origin
     * on a slab plane, parallel to it) is ignored: such a ray lies in the
     * closed slab. */
    const double pad = PRIM_BOX_PAD;
    const Vec3 bounds[2] = {b->lo, b->hi};
    double tnear = -INFINITY, tfar = INFINITY, texit = INFINITY;
    int near_face = 0, far_face = 0;
    for (int i = 0; i < 3; i++) {
        double inv = 1.0 / (double)vec_comp(r->d, i);
        int neg = inv < 0.0;
        double o = vec_comp(r->o, i);
        double t0 = ((double)vec_comp(bounds[neg], i) - o) * inv;
        double t1 = ((double)vec_comp(bounds[1 - neg], i) - o) * inv;
        if (t0 > tnear) {
            tnear = t0;
            near_face = i + 3 * neg; /* entering through hi when d < 0 */
        }
        if (t1 < texit) {
            texit = t1;
            far_face = i + 3 * (1 - neg);
        }
        if (t1 * pad < tfar)
            tfar = t1 * pad;
    }
    if (!(tnear <= tfar))
        return 0;
    int inside = !(tnear > 0.0);
    double t = inside ? texit : tnear;
    float terr, tf = round_t(t, gamma_d(3) * fabs(t), &terr);
    if (!(tf > 0.0f && tf < r->tmax))
        return 0;
    *h = (PrimHit){tf, terr, 0.0f, 0.0f, inside ? far_face : near_face};
    return 1;
}

/* x moved away from zero (up) or towards it (!up) by a relative 2^-50:
 * more than the three roundings of a quotient of two differences. */
static double outward(double x, int up) { return x * (up == (x > 0.0) ? 1.0 + 0x1p-50 : 1.0 - 0x1p-50); }

/* Narrows [*lo, *hi] to the t with a t <= b: t <= b / a when a > 0, t >=
 * b / a when a < 0, every t or none when a == 0; each bound rounded
 * outwards (widen) or inwards (!widen). */
static void slab_side(double a, double b, int widen, double *lo, double *hi)
{
    if (a > 0.0)
        *hi = double_min(*hi, outward(b / a, widen));
    else if (a < 0.0)
        *lo = double_max(*lo, outward(b / a, !widen));
    else if (b < 0.0)
        *lo = INFINITY;
}

/* The t with |so + t sd| <= w + k t e_sd, where so and sd carry errors up to
 * e_so and e_sd: k = 1 and w = the slab's half-width plus its error bounds
 * gives an interval that holds the exact slab's, k = -1 and w less them
 * one that it holds. In slab units, so that a slab nearly parallel to the
 * ray widens by what its rounding allows and no more. */
static void slab_interval(double so, double sd, double w, double e_sd, int k, double *lo, double *hi)
{
    *lo = -INFINITY;
    *hi = INFINITY;
    slab_side(sd - k * e_sd, w - so, k > 0, lo, hi);  /* so + t sd <= w + k t e_sd */
    slab_side(-sd - k * e_sd, w + so, k > 0, lo, hi); /* -(so + t sd) <= w + k t e_sd */
}

/* An oriented box's slabs, the part of the robust test that does not
 * depend on the ray: slab i holds the points p with |(p - c).N_i| <=
 * |det_i|, N_i the cross product of the other two axes and det_i = axis_i .
 * N_i: the exact faces of c + x u + y v + z w, with no rounded inverse in
 * between. Worked out once for all the rays that test one box together. */
typedef struct {
    double n[3][3];  /* N_i: exact products, one rounding */
    double half[3];  /* |det_i| */
    double e_det[3]; /* det_i's error bound */
} OBoxSlabs;

static void obox_slabs(const OBox *b, OBoxSlabs *k)
{
    const Vec3 ax[3] = {b->u, b->v, b->w};
    for (int i = 0; i < 3; i++) {
        Vec3 P = ax[(i + 1) % 3], Q = ax[(i + 2) % 3];
        double *n = k->n[i];
        n[0] = (double)P.y * Q.z - (double)P.z * Q.y;
        n[1] = (double)P.z * Q.x - (double)P.x * Q.z;
        n[2] = (double)P.x * Q.y - (double)P.y * Q.x;
        double det = 0.0, m_det = 0.0;
        for (int j = 0; j < 3; j++) {
            det += vec_comp(ax[i], j) * n[j];
            m_det += fabs(vec_comp(ax[i], j) * n[j]);
        }
        k->half[i] = fabs(det);
        k->e_det[i] = gamma_d(6) * m_det; /* the bound of the ray's sums below, more than det's own 5 roundings */
    }
}

/* prim_obox_hit_robust with the box's slabs k worked out. */
static int obox_hit_slabs(const OBox *b, const OBoxSlabs *k, const Ray *r, PrimHit *h)
{
    double oc[3], dd[3] = {r->d.x, r->d.y, r->d.z};
    for (int i = 0; i < 3; i++)
        oc[i] = (double)vec_comp(r->o, i) - vec_comp(b->c, i);
    /* The verdict takes each slab widened in slab units by its error
     * bounds (slab_interval). The distance takes each slab's ends as
     * quotients with their error bounds; those bounds grow without limit
     * as the ray turns parallel to the slab, so a slab nearly parallel to
     * the ray (grazed) gives the brackets of its widened and narrowed
     * interval instead. */
    double tnear = -INFINITY, tfar = INFINITY;       /* unwidened, for t */
    double wnear = -INFINITY, wfar = INFINITY;       /* widened, for the verdict */
    double near_up = -INFINITY, far_down = INFINITY; /* how far the exact ends may reach */
    double tn_err = 0.0, tf_err = 0.0;
    double g_lw = -INFINITY, g_ln = -INFINITY, g_hn = INFINITY, g_hw = INFINITY; /* grazed slabs' brackets */
    int near_axis = 0, far_axis = 0, g_near_axis = 0, g_far_axis = 0, grazing = 0;
    for (int i = 0; i < 3; i++) {
        const double *n = k->n[i];
        double so = 0.0, sd = 0.0, m_so = 0.0, m_sd = 0.0;
        for (int j = 0; j < 3; j++) {
            so += oc[j] * n[j];
            sd += dd[j] * n[j];
            m_so += fabs(oc[j] * n[j]);
            m_sd += fabs(dd[j] * n[j]);
        }
        /* n: 1 rounding; oc: 1; products and sums: 4 more */
        double e_det = k->e_det[i], e_so = gamma_d(6) * m_so, e_sd = gamma_d(6) * m_sd;
        double half = k->half[i], lo, hi, nlo, nhi;
        /* (the bounds grown by 2^-48 for the roundings of these sums) */
        double e_w = (e_det + e_so) * (1.0 + 0x1p-48), e_s = e_sd * (1.0 + 0x1p-48);
        slab_interval(so, sd, (half + e_w) * (1.0 + 0x1p-50), e_s, 1, &lo, &hi);
        wnear = double_max(wnear, lo);
        wfar = double_min(wfar, hi);
        if (!(fabs(sd) > 4.0 * e_sd)) { /* grazed: the quotients below would not bound t */
            slab_interval(so, sd, (half - e_w) * (1.0 - 0x1p-50), e_s, -1, &nlo, &nhi);
            grazing = 1;
            if (lo > g_lw) {
                g_lw = lo;
                g_near_axis = i;
            }
            if (hi < g_hw) {
                g_hw = hi;
                g_far_axis = i;
            }
            g_ln = double_max(g_ln, nlo);
            g_hn = double_min(g_hn, nhi);
            continue;
        }
        double e_num = e_det + e_so + gamma_d(1) * (half + fabs(so));
        double t0 = (-half - so) / sd, t1 = (half - so) / sd;
        double e0 = quotient_err(t0, sd, e_num, e_sd), e1 = quotient_err(t1, sd, e_num, e_sd);
        if (t0 > t1) {
            double tmp = t0;
            t0 = t1;
            t1 = tmp;
            tmp = e0;
            e0 = e1;
            e1 = tmp;
        }
        if (t0 > tnear) {
            tnear = t0;
            tn_err = e0;
            near_axis = i;
        }
        if (t1 < tfar) {
            tfar = t1;
            tf_err = e1;
            far_axis = i;
        }
        near_up = double_max(near_up, t0 + e0);
        far_down = double_min(far_down, t1 - e1);
    }
    if (!(wnear <= wfar)) /* the widened slabs do not overlap */
        return 0;
    /* The exact entry is the largest exact near distance: it lies within
     * tn_err below tnear and at most near_up above it (likewise the exit),
     * or within a grazed slab's brackets. */
    int inside;
    double t, err;
    if (!grazing) {
        inside = !(tnear > 0.0);
        t = inside ? tfar : tnear;
        err = inside ? double_max(tf_err, tfar - far_down) : double_max(tn_err, near_up - tnear);
    } else {
        double in_lo = double_max(tnear - tn_err, g_lw), in_hi = double_max(near_up, g_ln);
        double out_lo = double_min(far_down, g_hn), out_hi = double_min(tfar + tf_err, g_hw);
        inside = !(in_lo > 0.0);
        /* a hit's t is past 0; the quotients' estimate where it lies in the
         * bracket, else the bracket's middle */
        double lo = inside ? double_max(out_lo, 0.0) : in_lo, hi = inside ? out_hi : in_hi, est = inside ? tfar : tnear;
        if (est >= lo && est <= hi) {
            t = est;
            err = double_max(est - lo, hi - est);
        } else if (isfinite(lo) && isfinite(hi)) {
            t = 0.5 * lo + 0.5 * hi;
            err = 0.5 * (hi - lo) * (1.0 + 0x1p-50);
        } else {
            t = isfinite(lo) ? lo : hi;
            err = INFINITY;
        }
        /* From inside the widened box the entry may still lie in (0,
         * in_hi]: the bound then reaches it, so that the exact t is within
         * it of 0, as at every routine's origin. */
        if (inside && in_hi > 0.0)
            err = double_max(err, in_hi);
        if (g_lw > tnear - tn_err)
            near_axis = g_near_axis;
        if (g_hw < tfar + tf_err)
            far_axis = g_far_axis;
    }
    float terr, tf = round_t(t, err, &terr);
    if (!(tf > 0.0f && tf < r->tmax))
        return 0;
    *h = (PrimHit){tf, terr, 0.0f, 0.0f, inside ? far_axis : near_axis};
    return 1;
}

int prim_obox_hit_robust(const OBox *b, const Ray *r, PrimHit *h)
{
    OBoxSlabs k;
    obox_slabs(b, &k);
    return obox_hit_slabs(b, &k, r, h);
}

/* How variant v traces a PN patch: the robust one to float precision,
 * whichever mode the patch asks for (exact mode is as fast as fast mode's
 * Newton steps or faster: docs/performance.md), the classic one by
 * Newton's steps. */
static PnMode pn_mode_of(PrimVariant v) { return v == PRIM_ROBUST ? PN_EXACT : PN_FAST; }

int prim_intersect(const Prim *p, const Ray *r, PrimVariant v, PrimHit *h)
{
    int robust = v == PRIM_ROBUST;
    switch (p->kind) {
    case PRIM_SPHERE:
        return robust ? prim_sphere_hit_robust(&p->g.sphere, r, h) : prim_sphere_hit(&p->g.sphere, r, h);
    case PRIM_PLANE:
        return robust ? prim_plane_hit_robust(&p->g.plane, r, h) : prim_plane_hit(&p->g.plane, r, h);
    case PRIM_TRIANGLE:
    case PRIM_SMOOTH_TRIANGLE:
        return robust ? prim_triangle_hit_watertight(&p->g.tri, r, h) : prim_triangle_hit(&p->g.tri, r, h);
    case PRIM_BOX:
        return robust ? prim_box_hit_robust(&p->g.box, r, h) : prim_box_hit(&p->g.box, r, h);
    case PRIM_OBOX:
        return robust ? prim_obox_hit_robust(&p->g.obox, r, h) : prim_obox_hit(&p->g.obox, r, h);
    case PRIM_ELLIPSOID:
        return robust ? prim_ellipsoid_hit_robust(p->g.ell.e, r, h) : prim_ellipsoid_hit(p->g.ell.e, r, h);
    case PRIM_PN: {
        PnHit ph;
        PnMode mode = pn_mode_of(v);
        if (!(p->g.pn.piece ? pn_hit_piece(p->g.pn.patch, p->g.pn.piece, r, mode, &ph)
                            : pn_hit(p->g.pn.patch, r, mode, &ph)))
            return 0;
        *h = (PrimHit){ph.t, ph.terr, ph.u, ph.v, 0};
        return 1;
    }
    }
    return 0;
}

unsigned prim_intersect_rays(const Prim *p, const Ray *r, unsigned rays, PrimVariant v, PrimHit *h)
{
    unsigned hit = 0;
#ifdef PRIM_AVX
    if ((p->kind == PRIM_SPHERE || p->kind == PRIM_ELLIPSOID || p->kind == PRIM_BOX) && v == PRIM_ROBUST &&
        prim_avx())
        while (rays & (rays - 1)) {
            /* two rays or more: four lanes, or eight for five rays or more
             * where avx512_lanes_pay() allows, the last ones repeating the first */
            const int w = __builtin_popcount(rays) > 4 && avx512_lanes_pay() ? 8 : 4;
            int k[8] = {0, 0, 0, 0, 0, 0, 0, 0}, m = 0;
            for (; m < w && rays; rays &= rays - 1)
                k[m++] = __builtin_ctz(rays);
            for (int j = m; j < w; j++)
                k[j] = k[0];
            float t[8], terr[8];
            int face[8] = {0, 0, 0, 0, 0, 0, 0, 0};
            unsigned got;
            if (p->kind == PRIM_BOX)
                got = w == 8 ? box_rays8(&p->g.box, r, k, t, terr, face) : box_rays4(&p->g.box, r, k, t, terr, face);
            else
                got = w == 8 ? quadric_rays8(p, r, k, t, terr) : quadric_rays4(p, r, k, t, terr);
            for (int j = 0; j < m; j++)
                if (got >> j & 1) {
                    h[k[j]] = (PrimHit){t[j], terr[j], 0.0f, 0.0f, face[j]};
                    hit |= 1u << k[j];
                }
        }
#endif
    if (p->kind == PRIM_PN && (rays & (rays - 1))) {
        PnHit ph[32];
        unsigned got = pn_hit_piece_rays(p->g.pn.patch, p->g.pn.piece, r, rays, pn_mode_of(v), ph);
        for (unsigned m = got; m; m &= m - 1) {
            int k = __builtin_ctz(m);
            h[k] = (PrimHit){ph[k].t, ph[k].terr, ph[k].u, ph[k].v, 0};
        }
        return got;
    }
    if (p->kind == PRIM_OBOX && v == PRIM_ROBUST && (rays & (rays - 1))) {
        OBoxSlabs k; /* once for all of them */
        obox_slabs(&p->g.obox, &k);
        for (; rays; rays &= rays - 1) {
            int j = __builtin_ctz(rays);
            hit |= (unsigned)obox_hit_slabs(&p->g.obox, &k, &r[j], &h[j]) << j;
        }
        return hit;
    }
    for (; rays; rays &= rays - 1) { /* the rest one by one */
        int k = __builtin_ctz(rays);
        hit |= (unsigned)prim_intersect(p, &r[k], v, &h[k]) << k;
    }
    return hit;
}

/* p = o + t d, evaluated in double and rounded once, and its error: terr
 * |d| for t, the double evaluation, and the final rounding to float. */
static Vec3 ray_point(const Ray *r, float t, float terr, Vec3 *err)
{
    float p[3], e[3];
    for (int i = 0; i < 3; i++) {
        double o = vec_comp(r->o, i), d = vec_comp(r->d, i);
        double x = o + (double)t * d;
        p[i] = (float)x;
        e[i] = float_up((double)terr * fabs(d) + gamma_d(2) * (fabs(o) + fabs(t * d)) + UNIT_F * fabs(x));
    }
    *err = vec3(e[0], e[1], e[2]);
    return vec3(p[0], p[1], p[2]);
}

/* The hit point p of an oriented box's face f, off by up to s->perr, may
 * lie outside another face by as much, near an edge: moving off face f
 * along its normal does not take a spawned origin back inside. So where p
 * is that near another face, pin is p moved towards the centre c by a
 * fraction k of p - c, in double: every box coordinate l_i = N_i . (q - c)
 * / det (N_i the cross product of the other two axes, in double from the
 * float axes) scales by 1 - k, and k = 2 max (e_i + r_i), e_i bounding
 * l_i's error at p and r_i the rounding of pin to float, takes each below
 * 1 - r_i: (1 - k)(1 + e_i) + r_i < 1. Sets s->pin and s->pin_side (as
 * Surface says, for ng = inv[f]; the caller turns it with ng), or leaves
 * pin_side 0 where no pin is needed or the box is too thin. */
static void obox_pin(const OBox *b, int f, Surface *s)
{
    const Vec3 ax[3] = {b->u, b->v, b->w};
    double N[3][3], P[3], C[3], E[3], det = 0.0, cond = 0.0, dist = 0.0;
    for (int i = 0; i < 3; i++) {
        const Vec3 a = ax[(i + 1) % 3], c = ax[(i + 2) % 3];
        /* products of floats are exact in double: one rounding each */
        N[i][0] = (double)a.y * c.z - (double)a.z * c.y;
        N[i][1] = (double)a.z * c.x - (double)a.x * c.z;
        N[i][2] = (double)a.x * c.y - (double)a.y * c.x;
        P[i] = vec_comp(s->p, i);
        C[i] = vec_comp(b->c, i);
        E[i] = vec_comp(s->perr, i);
        dist += E[i];
    }
    for (int j = 0; j < 3; j++) {
        det += (double)vec_comp(b->u, j) * N[0][j];
        cond += fabs((double)vec_comp(b->u, j) * N[0][j]);
    }
    if (!(fabs(det) > 0.0) || !isfinite(det))
        return;
    cond /= fabs(det);
    double l[3], e[3], r[3], kmax = 0.0;
    int near = 0;
    for (int i = 0; i < 3; i++) {
        double dot = 0.0, mag = 0.0, pe = 0.0, ro = 0.0, mv = 0.0;
        for (int j = 0; j < 3; j++) {
            double x = P[j] - C[j], an = fabs(N[i][j]);
            dot += N[i][j] * x;
            mag += an * fabs(x);
            pe += an * E[j];
            ro += an * (double)FLT_EPSILON * double_max(fabs(P[j]), fabs(C[j]));
            mv += an * (dist + 4.0 * (double)FLT_EPSILON * fabs(P[j])); /* a spawn's move off face f */
        }
        l[i] = dot / det;
        /* the double roundings, generously: far below a float spacing */
        e[i] = (pe + 0x1p-40 * mag * cond) / fabs(det);
        r[i] = ro / fabs(det);
        kmax = double_max(kmax, 2.0 * (e[i] + r[i]));
        if (i != f && fabs(l[i]) >= 1.0 - 4.0 * (e[i] + r[i] + mv / fabs(det)))
            near = 1;
    }
    if (!near || !(kmax < 0.5) || !isfinite(kmax))
        return;
    float q[3];
    for (int j = 0; j < 3; j++)
        q[j] = (float)(P[j] + kmax * (C[j] - P[j]));
    s->pin = vec3(q[0], q[1], q[2]);
    /* ng = inv[f] = N_f / det (up to rounding), and l_f = inv[f] . (p - c):
     * ng points out of the box where l_f > 0 */
    s->pin_side = l[f] > 0.0 ? -1 : 1;
}

/* The robust ellipsoid's hit point, error bound and normal. The hit is
 * taken again in double (the float t has lost the bits that place it on a
 * distant or grazing surface, and may not tell two close roots apart:
 * the root is the one prim_ellipsoid_hit_robust took, by the same rule),
 * its point y in the unit sphere's space put
 * on the sphere, and mapped back by M: p lies on the ellipsoid to within
 * its roundings and M's error as A's inverse, which the residual
 * | |A p + b| - 1 | measures. The normal A^T y is taken there, and faces
 * the ray by the root that was hit, the nearer (entering) or the farther
 * (leaving), not by the sign of d.n, which a grazing ray's rounding can
 * turn. */
static void ell_surface(const Ellipsoid *e, const Ray *r, const PrimHit *h, Surface *s, Vec3 *ng)
{
    const double *a = e->a, *m = e->m;
    double f[3], d[3], t0, t1, t = h->t;
    int leaving = 0;
    ell_ray(a, r, f, d);
    if (stable_roots(f, d, 1.0, &t0, &t1)) { /* the root the hit routine took, as it took it */
        leaving = !(t0 > 0.0);
        t = leaving ? t1 : t0;
    }
    double y[3], len = 0.0;
    for (int i = 0; i < 3; i++) {
        y[i] = f[i] + t * d[i];
        len += y[i] * y[i];
    }
    len = sqrt(len);
    float pp[3], e_out[3];
    double x[3], mags[3], mnorm = 0.0;
    for (int i = 0; i < 3; i++) {
        x[i] = m[9 + i];
        mags[i] = fabs(m[9 + i]);
        for (int j = 0; j < 3; j++) {
            x[i] += m[3 * i + j] * (y[j] / len);
            mags[i] += fabs(m[3 * i + j]);
            mnorm += m[3 * i + j] * m[3 * i + j];
        }
    }
    /* how far x is from the surface A defines: | |A x + b| - 1 | in the
     * unit sphere's space, at most |M| (its largest singular value, under
     * the Frobenius norm) in the world's */
    double z2 = 0.0, zmag = 0.0;
    for (int i = 0; i < 3; i++) {
        double zi = a[9 + i], zm = fabs(a[9 + i]);
        for (int j = 0; j < 3; j++) {
            zi += a[3 * i + j] * x[j];
            zm += fabs(a[3 * i + j] * x[j]);
        }
        z2 += zi * zi;
        zmag += zm;
    }
    double off = (fabs(sqrt(z2) - 1.0) + gamma_d(8) * (zmag + 1.0)) * sqrt(mnorm) * (1.0 + 0x1p-20);
    double n[3], nlen = 0.0;
    for (int j = 0; j < 3; j++) {
        n[j] = (a[j] * y[0] + a[3 + j] * y[1] + a[6 + j] * y[2]) * (leaving ? -1.0 : 1.0);
        nlen += n[j] * n[j];
    }
    nlen = sqrt(nlen);
    for (int i = 0; i < 3; i++) {
        pp[i] = (float)x[i];
        e_out[i] = float_up(off + gamma_d(8) * mags[i] + UNIT_F * fabs(x[i]));
    }
    s->p = vec3(pp[0], pp[1], pp[2]);
    s->perr = vec3(e_out[0], e_out[1], e_out[2]);
    /* outward on entering, inward on leaving: against the ray either way */
    *ng = vec3((float)(n[0] / nlen), (float)(n[1] / nlen), (float)(n[2] / nlen));
}

/* A ray spawned off a triangle must leave it by more than the error band
 * of the triangle test's t, which keeps a t within its bound of 0 and so
 * would report the triangle again. That band comes from the vertices taken
 * relative to the ray's origin (their spread E about p, not their size),
 * and, in length off the plane, from E times E^2 / (twice the area): the
 * edge functions' error over the determinant, which shrinks with the area.
 * p's own error is far smaller where the triangle lies close to a
 * coordinate plane through the origin (a CAD model standing on z = 0), so
 * perr grows to this margin (a2: twice the area). */
static float tri_spawn_margin(const Triangle *t, Surface *s, float a2)
{
    /* (comparisons, not float_max: no operand here can be a NaN) */
    float e = vec_max_abs(vec_sub(t->a, s->p)), eb = vec_max_abs(vec_sub(t->b, s->p));
    float ec = vec_max_abs(vec_sub(t->c, s->p));
    e = eb > e ? eb : e;
    e = ec > e ? ec : e;
    float margin = gamma_f(TRI_SPAWN_GAMMA) * e * (1.0f + e * e / a2);
    if (!(margin <= e)) /* a sliver (or a2 = 0): at most the triangle's spread */
        margin = e;
    s->perr = vec3(s->perr.x > margin ? s->perr.x : margin, s->perr.y > margin ? s->perr.y : margin,
                   s->perr.z > margin ? s->perr.z : margin);
    return margin;
}

/* Triangle t's unnormalised normal (b - a) x (c - a) in double, from the
 * float vertices, whose differences are exact there; mag (NULL: not
 * wanted) bounds each component's rounding: the sum of its two products'
 * magnitudes, times a unit. */
static void tri_normal_d(const Triangle *t, double n[3], double mag[3])
{
    double e1[3], e2[3];
    d3_sub(e1, t->b, t->a);
    d3_sub(e2, t->c, t->a);
    d3_cross(n, e1, e2);
    for (int i = 0; mag && i < 3; i++) {
        int j = (i + 1) % 3, k = (i + 2) % 3;
        mag[i] = fabs(e1[j] * e2[k]) + fabs(e1[k] * e2[j]);
    }
}

/* A hit on a huge triangle (Surface.edge 2): its margin may pass over a
 * surface standing on it, which shade.c's edge_clear finds along the line
 * from the point, as next to an edge. That line must start on the ray:
 * the point from the barycentrics, each within its rounding, lies off it
 * by those roundings times the triangle's size, so it is the ray's
 * meeting with the triangle's plane instead, in double, then rounded. */
static void tri_wide_hit(const Prim *p, const Ray *r, const PrimHit *h, Surface *s)
{
    double n[3], ao[3];
    const double d[3] = {r->d.x, r->d.y, r->d.z};
    tri_normal_d(&p->g.tri, n, NULL);
    d3_sub(ao, p->g.tri.a, r->o);
    const double t = d3_dot(n, ao) / d3_dot(n, d);
    if (!(t > 0.0) || !isfinite(t))
        return; /* a ray that leaves the plane, hit within the test's band of t = 0: it keeps its margin */
    s->p = vec3((float)(r->o.x + t * d[0]), (float)(r->o.y + t * d[1]), (float)(r->o.z + t * d[2]));
    s->edge = 2;
    s->tri = p;
    s->tu = h->u;
    s->tv = h->v;
}

int prim_near_edge(const Prim *p, const PrimHit *h, Surface *s)
{
    if (p->kind != PRIM_TRIANGLE && p->kind != PRIM_SMOOTH_TRIANGLE)
        return 0;
    /* The distance to edge i is b_i |n| / |edge i|, n the unnormalised
     * normal; the offset is at most the sum of perr. Compared squared, in
     * double, which neither overflows nor takes a root. */
    const Triangle *t = &p->g.tri;
    const Vec3 v[3] = {t->a, t->b, t->c};
    const double b[3] = {1.0f - h->u - h->v, h->u, h->v};
    const double reach = PRIM_EDGE_REACH * ((double)s->perr.x + s->perr.y + s->perr.z);
    double n[3];
    tri_normal_d(t, n, NULL);
    const double n2 = d3_dot(n, n);
    for (int i = 0; i < 3; i++) { /* edge i, opposite vertex i */
        double e[3];
        d3_sub(e, v[(i + 2) % 3], v[(i + 1) % 3]);
        if (b[i] * b[i] * n2 <= reach * reach * d3_dot(e, e)) {
            s->tri = p; /* for prim_past_plane */
            s->tu = h->u;
            s->tv = h->v;
            return 1;
        }
    }
    return 0;
}

/* A hit's u and v keep their signs, each within 3 ulps of e1 / det and
 * e2 / det (prim_triangle_hit_watertight), but 1 - u - v carries their
 * errors and its own: within this of 0, the point may lie on the edge
 * b c, where the weight is 0 (a ray in the plane of a mesh's edge). */
#define B0_ERR 0x1p-20f

/* The signed distance of q from the plane through x0 of normal n (times
 * |n|), in double, and into *err a bound on its roundings, generously; mag
 * bounds the roundings of n's components (tri_normal_d). */
static double plane_side(const double n[3], const double x0[3], const double mag[3], const double q[3], double *err)
{
    double f = 0.0;
    *err = 0.0;
    for (int i = 0; i < 3; i++) {
        double dq = q[i] - x0[i];
        f += n[i] * dq;
        *err += 0x1p-40 * mag[i] * (fabs(dq) + fabs(x0[i]));
    }
    return f;
}

int prim_past_plane(const Prim *x, const Surface *s, Vec3 d)
{
    double n[3], x0[3], mag[3];
    if (x->kind == PRIM_TRIANGLE || x->kind == PRIM_SMOOTH_TRIANGLE) {
        tri_normal_d(&x->g.tri, n, mag);
        for (int i = 0; i < 3; i++)
            x0[i] = vec_comp(x->g.tri.a, i);
    } else if (x->kind == PRIM_PLANE) {
        for (int i = 0; i < 3; i++) {
            n[i] = vec_comp(x->g.plane.n, i);
            x0[i] = n[i] * x->g.plane.d;
            mag[i] = fabs(n[i]);
        }
    } else
        return 0;
    const double dd[3] = {d.x, d.y, d.z};
    const double nd = d3_dot(n, dd);
    if (s->edge == 1) {
        /* The exact point is b0 a + b1 b + b2 c, so its signed distance
         * from x's plane is b0 f(a) + b1 f(b) + b2 f(c): where no two
         * vertices lie on opposite sides, its side is theirs, however
         * near the point lies to the plane (a face that shares the edge
         * or the vertex near the point). A vertex within the roundings
         * of the plane (a shared one) is on it, and one whose weight is
         * within its roundings of 0 does not count (B0_ERR). */
        const Triangle *t = &s->tri->g.tri;
        const Vec3 v[3] = {t->a, t->b, t->c};
        const float b[3] = {1.0f - s->tu - s->tv, s->tu, s->tv}, berr[3] = {B0_ERR, 0.0f, 0.0f};
        int pos = 0, neg = 0;
        for (int k = 0; k < 3; k++) {
            double err;
            const double q[3] = {v[k].x, v[k].y, v[k].z};
            const double f = plane_side(n, x0, mag, q, &err);
            if (b[k] > berr[k] && fabs(f) > err) {
                pos |= f > 0.0;
                neg |= f < 0.0;
            }
        }
        if (!(pos && neg)) {
            const int side = pos - neg;
            return nd > 0.0 ? side >= 0 : nd < 0.0 ? side <= 0 : 1;
        }
    }
    double err;
    const double p[3] = {s->p.x, s->p.y, s->p.z};
    const double sp = plane_side(n, x0, mag, p, &err);
    const float w = s->edge == 2 ? prim_wide_err(s) : 0.0f;
    const Vec3 pe = s->edge == 2 ? vec3(w, w, w) : s->perr; /* off a huge triangle, p's own, not the margin */
    for (int i = 0; i < 3; i++) /* and p's error bound */
        err += fabs(n[i]) * vec_comp(pe, i);
    return nd > 0.0 ? sp >= -err : nd < 0.0 ? sp <= err : 1;
}

float prim_wide_err(const Surface *s)
{
    /* each coordinate within a rounding to float of the double, itself
     * within a few parts in 2^53 of the exact meeting: 2^-22 covers both */
    return float_up(0x1p-22f * (fabsf(s->p.x) + fabsf(s->p.y) + fabsf(s->p.z)) + FLT_MIN);
}

int prim_line_crosses(const Prim *x, const Surface *s, Vec3 d)
{
    if ((x->kind != PRIM_TRIANGLE && x->kind != PRIM_SMOOTH_TRIANGLE) || x == s->tri)
        return 0; /* (a line that leaves a plane does not meet it again) */
    /* The point b0 a + b1 b + b2 c of s's triangle, with b0 = 1 - b1 - b2
     * in double: each product of floats is exact, so the point lies on
     * that triangle to within the sums' roundings. The hit's b1 + b2 may
     * pass 1 by a rounding, which would put the point past the edge b c,
     * or fall short of it by one, which would put a point of that edge
     * inside: within B0_ERR, it is brought onto the edge. */
    const Triangle *t = &s->tri->g.tri, *u = &x->g.tri;
    double b1 = s->tu > 0.0f ? s->tu : 0.0, b2 = s->tv > 0.0f ? s->tv : 0.0, b0 = 1.0 - b1 - b2;
    if (b0 < B0_ERR) {
        b1 /= b1 + b2;
        b2 = 1.0 - b1;
        b0 = 0.0;
    }
    const double dd[3] = {d.x, d.y, d.z};
    double p[3], n[3], mag[3], x0[3], err;
    for (int i = 0; i < 3; i++) {
        /* a huge triangle's point: s->p, on the ray (tri_wide_hit) */
        p[i] =
            s->edge == 2 ? vec_comp(s->p, i) : b0 * vec_comp(t->a, i) + b1 * vec_comp(t->b, i) + b2 * vec_comp(t->c, i);
        x0[i] = vec_comp(u->a, i);
    }
    tri_normal_d(u, n, mag);
    const double f = plane_side(n, x0, mag, p, &err);
    if (s->edge == 2) /* and that point's own error */
        err += (fabs(n[0]) + fabs(n[1]) + fabs(n[2])) * prim_wide_err(s);
    const double tt = -f / d3_dot(n, dd); /* where the line meets x's plane */
    if (!(fabs(f) > err) || !(tt > 0.0) || !isfinite(tt))
        return 0; /* on the plane (a face through the point), or behind */
    double y[3];
    for (int i = 0; i < 3; i++)
        y[i] = p[i] + tt * dd[i];
    /* inside x: y on the inner side of each edge, to within a part in 2^40
     * of the terms (the roundings above are a few parts in 2^53) */
    const Vec3 v[3] = {u->a, u->b, u->c};
    for (int i = 0; i < 3; i++) {
        double e[3], q[3], m[3];
        d3_sub(e, v[(i + 1) % 3], v[i]);
        for (int k = 0; k < 3; k++)
            q[k] = y[k] - vec_comp(v[i], k);
        d3_cross(m, e, q);
        double tol = 0.0;
        for (int k = 0; k < 3; k++) {
            const int j = (k + 1) % 3, l = (k + 2) % 3;
            tol += fabs(n[k]) * (fabs(e[j] * q[l]) + fabs(e[l] * q[j]));
        }
        if (d3_dot(m, n) < -0x1p-40 * tol)
            return 0;
    }
    return 1;
}

/* 1 when n faces along d (n . d > 0): the two-sided surfaces' normals turn
 * to face the ray. A grazing ray's float product can round to 0, or past
 * it, while the exact one is not: within its rounding bound (with room for
 * products below FLT_MIN), the sign is taken in double, where the products
 * of floats are exact. */
static int faces_along(Vec3 n, Vec3 d)
{
    const float x = n.x * d.x, y = n.y * d.y, z = n.z * d.z, f = (x + y) + z;
    if (fabsf(f) > gamma_f(4) * ((fabsf(x) + fabsf(y)) + fabsf(z)) + 0x1p-147f)
        return f > 0.0f;
    return (double)n.x * d.x + (double)n.y * d.y + (double)n.z * d.z > 0.0;
}

void prim_surface(const Prim *p, const Ray *r, const PrimHit *h, PrimVariant v, Surface *s)
{
    int robust = v == PRIM_ROBUST;
    int oriented = 0; /* ng already faces the ray (the robust ellipsoid's) */
    Vec3 ng = vec3(0.0f, 0.0f, 0.0f), ns, noff = ng;
    s->pin_side = 0;
    s->edge = 0;
    int edge = 0; /* on a box's edge or corner: noff is the sum of its faces' normals */
    if (!robust)
        s->p = ray_at(r, h->t); /* perr: a heuristic, below */
    else if (p->kind != PRIM_SPHERE && p->kind != PRIM_TRIANGLE && p->kind != PRIM_SMOOTH_TRIANGLE &&
             p->kind != PRIM_ELLIPSOID)
        s->p = ray_point(r, h->t, h->terr, &s->perr); /* spheres, triangles and ellipsoids have better, below */
    switch (p->kind) {
    case PRIM_SPHERE: {
        /* The point is projected back onto the sphere (as pbrt does): the
         * textbook quadratic leaves grazing hits ~1e-5 off the surface at a
         * distance of 10, and even a certified t leaves terr |d|. The robust
         * variant takes the normal from o - c + t d in double, which does
         * not depend on where the sphere sits, so a translated scene shades
         * exactly like the original. */
        const Sphere *sp = &p->g.sphere;
        if (robust) {
            double q[3], len = 0.0;
            for (int i = 0; i < 3; i++) {
                q[i] = ((double)vec_comp(r->o, i) - vec_comp(sp->c, i)) + (double)h->t * vec_comp(r->d, i);
                len += q[i] * q[i];
            }
            len = sqrt(len);
            float pp[3] = {0, 0, 0}, e[3] = {0, 0, 0};
            for (int i = 0; i < 3; i++) {
                double x = vec_comp(sp->c, i) + sp->r * (q[i] / len);
                pp[i] = (float)x;
                e[i] = float_up(gamma_d(8) * (fabs(vec_comp(sp->c, i)) + sp->r) + UNIT_F * fabs(x));
            }
            ng = vec3((float)(q[0] / len), (float)(q[1] / len), (float)(q[2] / len));
            s->p = vec3(pp[0], pp[1], pp[2]);
            s->perr = vec3(e[0], e[1], e[2]);
        } else {
            ng = vec_sub(s->p, sp->c);
            s->p = vec_madd(sp->c, ng, sp->r / vec_length(ng));
        }
        break;
    }
    case PRIM_PLANE:
        ng = p->g.plane.n;
        break;
    case PRIM_TRIANGLE:
    case PRIM_SMOOTH_TRIANGLE: {
        const Triangle *t = &p->g.tri;
        ng = vec_cross(vec_sub(t->b, t->a), vec_sub(t->c, t->a));
        float alen = vec_length(ng);
        if (!(alen >= TRI_NORMAL_MIN && alen <= TRI_NORMAL_MAX)) {
            /* |n|^2 over- or underflows in float (edges of about 2^30, or
             * 2^-30): the direction from double, |n| rounded */
            double n[3];
            tri_normal_d(t, n, NULL);
            const double len = sqrt(d3_dot(n, n));
            if (len > 0.0) {
                ng = vec3((float)(n[0] / len), (float)(n[1] / len), (float)(n[2] / len));
                alen = (float)len;
            }
        }
        if (robust) {
            /* pbrt: from the barycentrics, which lie on the triangle's
             * plane to within gamma(7) of the terms; o + t d would carry
             * terr |d|, and pbrt's bound on t is loose. */
            float b0 = 1.0f - h->u - h->v;
            Vec3 pa = vec_scale(t->a, b0), pb = vec_scale(t->b, h->u), pc = vec_scale(t->c, h->v);
            s->p = vec_add(vec_add(pa, pb), pc);
            Vec3 m = vec_add(vec_add(vec3(fabsf(pa.x), fabsf(pa.y), fabsf(pa.z)), vec3(fabsf(pb.x), fabsf(pb.y), fabsf(pb.z))),
                             vec3(fabsf(pc.x), fabsf(pc.y), fabsf(pc.z)));
            s->perr = vec_scale(m, gamma_f(7));
            s->edge = -1; /* prim_near_edge tells, if asked */
            const float margin = tri_spawn_margin(t, s, alen);
            if (margin > PRIM_WIDE_MARGIN * vec_max_abs(s->p) && margin > PRIM_WIDE_MARGIN * h->t * vec_max_abs(r->d))
                tri_wide_hit(p, r, h, s);
        }
        break;
    }
    case PRIM_BOX: {
        int f = h->face % 3;
        ng = f == 0 ? vec3(1, 0, 0) : f == 1 ? vec3(0, 1, 0) : vec3(0, 0, 1);
        if (h->face < 3)
            ng = vec_neg(ng); /* outward, for the edge normal below */
        if (robust) { /* on a face, one coordinate is exactly the bound */
            const Box *b = &p->g.box;
            float bound = h->face >= 3 ? vec_comp(b->hi, f) : vec_comp(b->lo, f);
            float c[3] = {s->p.x, s->p.y, s->p.z}, e[3] = {s->perr.x, s->perr.y, s->perr.z};
            float out[3] = {0, 0, 0}; /* the outward normals of every face p lies on */
            c[f] = bound;
            e[f] = 0.0f;
            out[f] = h->face >= 3 ? 1.0f : -1.0f;
            for (int j = 0; j < 3; j++) {
                if (j == f)
                    continue;
                if (c[j] == vec_comp(b->lo, j) || c[j] == vec_comp(b->hi, j)) {
                    out[j] = c[j] == vec_comp(b->lo, j) ? -1.0f : 1.0f;
                    edge = 1;
                }
            }
            s->p = vec3(c[0], c[1], c[2]);
            s->perr = vec3(e[0], e[1], e[2]);
            /* On an edge or corner, rays spawn along the sum of the faces'
             * normals, so that they leave every face plane p lies on (the
             * normals stay the face's). */
            noff = vec3(out[0], out[1], out[2]);
        }
        break;
    }
    case PRIM_OBOX:
        ng = p->g.obox.inv[h->face];
        if (robust)
            obox_pin(&p->g.obox, h->face, s);
        break;
    case PRIM_ELLIPSOID:
        if (robust) {
            ell_surface(p->g.ell.e, r, h, s, &ng);
            oriented = 1;
            break;
        }
        { /* the gradient of |A x + b|^2 at p: A^T (A p + b) */
            const double *a = p->g.ell.e->a;
            double x[3], n[3];
            for (int i = 0; i < 3; i++)
                x[i] = a[3 * i] * s->p.x + a[3 * i + 1] * s->p.y + a[3 * i + 2] * s->p.z + a[9 + i];
            for (int j = 0; j < 3; j++)
                n[j] = a[j] * x[0] + a[3 + j] * x[1] + a[6 + j] * x[2];
            ng = vec3((float)n[0], (float)n[1], (float)n[2]);
        }
        break;
    case PRIM_PN:
        ng = pn_geometric_normal(p->g.pn.patch, h->u, h->v);
        if (robust) {
            /* The exact surface lies in the box that gave t, a few ulps
             * wide (exact mode); Newton's point is as close (fast mode). */
            float e = 16.0f * FLT_EPSILON * vec_max_abs(s->p);
            s->perr = vec_add(s->perr, vec3(e, e, e));
        }
        break;
    }
    if (!robust) { /* a heuristic: 16 ulps of the larger of |p| and |o| */
        float e = 16.0f * FLT_EPSILON * fmaxf(vec_max_abs(s->p), vec_max_abs(r->o));
        s->perr = vec3(e, e, e);
    }
    ng = vec_normalize(ng);
    noff = edge ? vec_normalize(noff) : ng;
    ns = ng;
    const int smooth = p->kind == PRIM_SMOOTH_TRIANGLE || p->kind == PRIM_PN;
    if (p->kind == PRIM_SMOOTH_TRIANGLE) {
        const Triangle *tr = &p->g.tri;
        float w = 1.0f - h->u - h->v;
        ns = vec_add(vec_add(vec_scale(tr->na, w), vec_scale(tr->nb, h->u)), vec_scale(tr->nc, h->v));
        ns = vec_normalize(ns);
    } else if (p->kind == PRIM_PN) {
        ns = pn_shading_normal(p->g.pn.patch, h->u, h->v);
    }
    /* Two-sided surfaces: each normal faces the incoming ray. A box's edge
     * normal turns with its face's normal, not by its own sign against the
     * ray: it must keep pointing out of (or into) every face it touches. */
    int back = oriented ? 0 : faces_along(ng, r->d);
    if (s->pin_side) /* obox_pin's side is the outward normal's: turn it with ng */
        s->pin_side = back ? -s->pin_side : s->pin_side;
    s->ng = back ? vec_neg(ng) : ng;
    s->noff = back ? vec_neg(noff) : noff;
    s->ns = oriented || !smooth ? s->ng : faces_along(ns, r->d) ? vec_neg(ns) : ns; /* (ns is ng) */
}

#ifdef PRIM_AVX
/* prim_surface for robust spheres, the hits k[0 .. 3] of rays r[k] at
 * prims[best[k]]: the same operations lane by lane, the sphere's part in
 * doubles and the normal's in floats, into s[k[0 .. 3]], field by field (a
 * Surface built aside and copied whole stalled on the copy's loads). */
__attribute__((target("avx"))) static void sphere_surface4(const Prim *prims, const int *best, const Ray *r,
                                                          const PrimHit *h, const int k[4], Surface *s)
{
    const Sphere *sp[4] = {&prims[best[k[0]]].g.sphere, &prims[best[k[1]]].g.sphere, &prims[best[k[2]]].g.sphere,
                           &prims[best[k[3]]].g.sphere};
#define LANES(x) _mm256_cvtps_pd(_mm_setr_ps(x(0), x(1), x(2), x(3)))
#define C(j) vec_comp(sp[j]->c, i)
#define T(j) h[k[j]].t
#define R(j) sp[j]->r
    const __m256d sign = _mm256_set1_pd(-0.0), t = LANES(T), rr = LANES(R);
    __m256d q[3], c[3], len = _mm256_setzero_pd();
    __m128 rf[RAY_FIELDS];
    ray_fields(r, k, rf);
    for (int i = 0; i < 3; i++) {
        c[i] = LANES(C);
        const __m256d o = _mm256_cvtps_pd(rf[RAY_O + i]), d = _mm256_cvtps_pd(rf[RAY_D + i]);
        q[i] = _mm256_add_pd(_mm256_sub_pd(o, c[i]), _mm256_mul_pd(t, d));
        len = _mm256_add_pd(len, _mm256_mul_pd(q[i], q[i]));
    }
    len = _mm256_sqrt_pd(len);
    float pp[3][4], e[3][4], ng[3][4];
    __m128 n[3];
    for (int i = 0; i < 3; i++) {
        __m256d u = _mm256_div_pd(q[i], len);
        __m256d x = _mm256_add_pd(c[i], _mm256_mul_pd(rr, u));
        _mm_storeu_ps(pp[i], _mm256_cvtpd_ps(x));
        __m256d b = _mm256_mul_pd(_mm256_set1_pd(gamma_d(8)), _mm256_add_pd(_mm256_andnot_pd(sign, c[i]), rr));
        _mm_storeu_ps(e[i], float_up4(_mm256_add_pd(b, _mm256_mul_pd(_mm256_set1_pd(UNIT_F), _mm256_andnot_pd(sign, x)))));
        n[i] = _mm256_cvtpd_ps(u);
    }
#undef LANES
#undef C
#undef T
#undef R
    /* the tail of prim_surface: ng normalised, turned to face the ray */
    __m128 len2 = _mm_add_ps(_mm_add_ps(_mm_mul_ps(n[0], n[0]), _mm_mul_ps(n[1], n[1])), _mm_mul_ps(n[2], n[2]));
    __m128 nl = _mm_sqrt_ps(len2), pos = _mm_cmpgt_ps(nl, _mm_setzero_ps());
    __m128 inv = _mm_div_ps(_mm_set1_ps(1.0f), nl);
    __m128 dd[3];
    for (int i = 0; i < 3; i++) {
        n[i] = _mm_or_ps(_mm_and_ps(pos, _mm_mul_ps(n[i], inv)), _mm_andnot_ps(pos, n[i]));
        dd[i] = rf[RAY_D + i];
    }
    /* faces_along, lane by lane: the float product where it is sure */
    const __m128 x = _mm_mul_ps(n[0], dd[0]), y = _mm_mul_ps(n[1], dd[1]), z = _mm_mul_ps(n[2], dd[2]);
    const __m128 nd = _mm_add_ps(_mm_add_ps(x, y), z), abs = _mm_set1_ps(-0.0f);
    const __m128 bound = _mm_add_ps(
        _mm_mul_ps(_mm_set1_ps(gamma_f(4)),
                   _mm_add_ps(_mm_add_ps(_mm_andnot_ps(abs, x), _mm_andnot_ps(abs, y)), _mm_andnot_ps(abs, z))),
        _mm_set1_ps(0x1p-147f));
    __m128 flip = _mm_and_ps(_mm_cmpgt_ps(nd, _mm_setzero_ps()), abs);
    const int unsure = _mm_movemask_ps(_mm_cmple_ps(_mm_andnot_ps(abs, nd), bound));
    if (unsure) {
        float nf[3][4], fl[4];
        for (int i = 0; i < 3; i++)
            _mm_storeu_ps(nf[i], n[i]);
        _mm_storeu_ps(fl, flip);
        for (int j = 0; j < 4; j++)
            if (unsure >> j & 1)
                fl[j] = faces_along(vec3(nf[0][j], nf[1][j], nf[2][j]), r[k[j]].d) ? -0.0f : 0.0f;
        flip = _mm_loadu_ps(fl);
    }
    for (int i = 0; i < 3; i++)
        _mm_storeu_ps(ng[i], _mm_xor_ps(n[i], flip));
    for (int j = 0; j < 4; j++) {
        Surface *o = &s[k[j]];
        o->p = vec3(pp[0][j], pp[1][j], pp[2][j]);
        o->perr = vec3(e[0][j], e[1][j], e[2][j]);
        o->ng = o->noff = o->ns = vec3(ng[0][j], ng[1][j], ng[2][j]);
        o->pin_side = 0;
        o->edge = 0;
    }
}
#endif

void prim_surface_hits(const Prim *prims, const int *best, const Ray *r, const PrimHit *h, int n, PrimVariant v,
                       Surface *s)
{
    int k[4] = {0, 0, 0, 0}, m = 0; /* the robust spheres' hits gathered */
#ifdef PRIM_AVX
    const int lanes = v == PRIM_ROBUST && prim_avx() ? 4 : 0;
#else
    const int lanes = 0;
#endif
    for (int j = 0; j < n; j++) {
        if (best[j] < 0)
            continue;
        if (!lanes || prims[best[j]].kind != PRIM_SPHERE) {
            prim_surface(&prims[best[j]], &r[j], &h[j], v, &s[j]);
            continue;
        }
        k[m++] = j;
#ifdef PRIM_AVX
        if (m == 4) {
            sphere_surface4(prims, best, r, h, k, s);
            m = 0;
        }
#endif
    }
    for (int i = 0; i < m; i++) /* fewer than four left */
        prim_surface(&prims[best[k[i]]], &r[k[i]], &h[k[i]], v, &s[k[i]]);
}

Vec3 prim_spawn_side(const Surface *s, float nd)
{
    if (s->pin_side && (nd > 0.0f) == (s->pin_side > 0))
        return s->pin; /* into an oriented box, from beside one of its edges */
    Vec3 n = nd < 0.0f ? vec_neg(s->noff) : s->noff; /* the side dir leaves to */
    float dist = fabsf(n.x) * s->perr.x + fabsf(n.y) * s->perr.y + fabsf(n.z) * s->perr.z;
    Vec3 po = vec_madd(s->p, n, dist);
    /* One float further along each component the normal moves, so that the
     * rounding of po itself cannot undo the offset, even when dist is 0 (a
     * box face, where p is exact). */
#ifdef PRIM_AVX
    /* SSE2, the x86-64 baseline: the three steps at once, by masks instead
     * of a branch per lane; infinities and NaNs take float_next below */
    const __m128 zero = _mm_setzero_ps(), vn = _mm_setr_ps(n.x, n.y, n.z, 0.0f);
    const __m128 vp = _mm_setr_ps(po.x, po.y, po.z, 0.0f);
    if (_mm_movemask_ps(_mm_cmple_ps(_mm_andnot_ps(_mm_set1_ps(-0.0f), vp), _mm_set1_ps(FLT_MAX))) == 15) {
        const __m128 up = _mm_cmpgt_ps(vn, zero), down = _mm_cmplt_ps(vn, zero), pos = _mm_cmpgt_ps(vp, zero);
        /* away from 0 (bits + 1) where p's sign is the way it moves,
         * towards it (bits - 1) where not; from 0, to the least float */
        const __m128 away = _mm_or_ps(_mm_and_ps(up, pos), _mm_andnot_ps(pos, down));
        const __m128 at0 = _mm_cmpeq_ps(vp, zero);
        __m128i b = _mm_castps_si128(vp);
        b = _mm_sub_epi32(b, _mm_castps_si128(_mm_andnot_ps(at0, away)));
        b = _mm_add_epi32(b, _mm_castps_si128(_mm_andnot_ps(at0, _mm_andnot_ps(away, _mm_or_ps(up, down)))));
        const __m128i least = _mm_or_si128(_mm_set1_epi32(1), _mm_and_si128(_mm_castps_si128(down), _mm_set1_epi32(INT32_MIN)));
        const __m128i z = _mm_castps_si128(_mm_and_ps(at0, _mm_or_ps(up, down)));
        const __m128 q = _mm_castsi128_ps(_mm_or_si128(_mm_andnot_si128(z, b), _mm_and_si128(z, least)));
        float out[4];
        _mm_storeu_ps(out, q);
        return vec3(out[0], out[1], out[2]);
    }
#endif
    /* Three scalars, not an array: the array's stores, a lane at a time,
     * stalled its reload as a Vec3. */
    float x = n.x != 0.0f ? float_next(po.x, n.x > 0.0f) : po.x;
    float y = n.y != 0.0f ? float_next(po.y, n.y > 0.0f) : po.y;
    float z = n.z != 0.0f ? float_next(po.z, n.z > 0.0f) : po.z;
    return vec3(x, y, z);
}

void prim_spawn_origins(const Surface *s, Vec3 o[2])
{
    o[0] = prim_spawn_side(s, -1.0f);
    o[1] = prim_spawn_side(s, 1.0f);
}

int prim_inside(const Prim *p, Vec3 q)
{
    switch (p->kind) {
    case PRIM_SPHERE: {
        Vec3 d = vec_sub(q, p->g.sphere.c);
        return vec_dot(d, d) < p->g.sphere.r * p->g.sphere.r;
    }
    case PRIM_BOX: {
        const Box *b = &p->g.box;
        return q.x >= b->lo.x && q.x <= b->hi.x && q.y >= b->lo.y && q.y <= b->hi.y && q.z >= b->lo.z && q.z <= b->hi.z;
    }
    case PRIM_OBOX: {
        Vec3 rel = vec_sub(q, p->g.obox.c);
        for (int i = 0; i < 3; i++)
            if (!(fabsf(vec_dot(p->g.obox.inv[i], rel)) <= 1.0f))
                return 0;
        return 1;
    }
    case PRIM_ELLIPSOID: {
        const double *a = p->g.ell.e->a;
        double g = 0.0;
        for (int i = 0; i < 3; i++) {
            double x = a[3 * i] * q.x + a[3 * i + 1] * q.y + a[3 * i + 2] * q.z + a[9 + i];
            g += x * x;
        }
        return g < 1.0;
    }
    case PRIM_PLANE:
    case PRIM_TRIANGLE:
    case PRIM_SMOOTH_TRIANGLE:
    case PRIM_PN:
        break;
    }
    return 0;
}
