/*
 * tri_lanes.h - the SIMD body of the watertight triangle test, written once
 * for every width: tri4.h includes it with TRI_LANES (the function's name)
 * and the V_* operations defined, once for SSE (four lanes, half a
 * PrimTri8), once for AVX2 (eight lanes, a whole PrimTri8) and once for
 * AVX-512 (sixteen lanes: the eight for two rays, with TRI_LANES_RAY2 and
 * V_RAY). It undefines them at its end, ready for the next width.
 *
 * prim.c's watertight() lane by lane, in the same operations and order, so
 * each lane decided here gets the same bits as the scalar routine. Lanes
 * with an edge function too close to 0, or a t too close to 0 or tmax,
 * are left to the caller in *slow.
 */
#ifndef TRI_LANES_DECL
#define TRI_LANES_DECL TRI_INLINE
#endif
/* A second ray's parameters (TRI_LANES_RAY2), and a value of each ray in
 * its lanes (V_RAY(first's, second's)): with one ray, the first's in all. */
#ifndef TRI_LANES_RAY2
#define TRI_LANES_RAY2
#define V_RAY(a, b) V_SET1(a)
#endif
TRI_LANES_DECL int TRI_LANES(const float *blk, int lanes, const PrimTriRay *p, const Ray *r, TRI_LANES_RAY2 float *ht,
                             float *hterr, float *hu, float *hv, int *slow)
{
    const V g5 = V_SET1(GAMMA_F(5)), zero = V_SET1(0.0f);
    const V ox = V_RAY(p->o[p->kx], p2->o[p2->kx]), oy = V_RAY(p->o[p->ky], p2->o[p2->ky]);
    const V oz = V_RAY(p->o[p->kz], p2->o[p2->kz]);
    const V sx = V_RAY(p->sx, p2->sx), sy = V_RAY(p->sy, p2->sy);
    /* One bound for the three edges, from the largest magnitudes:
     * edge_err is monotone in each argument and rounding is monotone, so
     * it is at least each edge's own bound, at a third of the cost. A lane
     * it cannot decide takes the scalar routine, which applies the
     * per-edge bounds: the verdict's bits are the same. */
    V mx0 = V_SET1(TRI_SHEAR_FLOOR), my0 = mx0, mz_len = zero; /* (watertight()'s floor) */
    /* (written out: a loop over arrays of vectors is not unrolled at -O2) */
#define VERTEX(k, X, Y, Z)                                                                      \
    V X = V_SUB(V_LOAD(blk, k, p->kx), ox), Y = V_SUB(V_LOAD(blk, k, p->ky), oy);               \
    V Z = V_SUB(V_LOAD(blk, k, p->kz), oz);                                                     \
    mx0 = V_MAX(mx0, V_ABS(X));                                                                 \
    my0 = V_MAX(my0, V_ABS(Y));                                                                 \
    mz_len = V_MAX(mz_len, V_ABS(Z));                                                           \
    X = V_ADD(X, V_MUL(sx, Z));                                                                 \
    Y = V_ADD(Y, V_MUL(sy, Z))
    VERTEX(0, ax, ay, az);
    VERTEX(1, bx, by, bz);
    VERTEX(2, cx, cy, cz);
#undef VERTEX
#define MAX3(a, b, c) V_MAX(V_ABS(a), V_MAX(V_ABS(b), V_ABS(c)))
    V mx = MAX3(ax, bx, cx), my = MAX3(ay, by, cy);
    V ex = V_MUL(g5, V_ADD(mx0, mz_len)), ey = V_MUL(g5, V_ADD(my0, mz_len));
    V e0 = V_SUB(V_MUL(bx, cy), V_MUL(by, cx));
    V e1 = V_SUB(V_MUL(cx, ay), V_MUL(cy, ax));
    V e2 = V_SUB(V_MUL(ax, by), V_MUL(ay, bx));
    /* edge_err(mx, my, ex, ey, mx, my, ex, ey) in edge_err's order (mx and
     * my are magnitudes already) */
    V m = V_ADD(V_MUL(mx, my), V_MUL(my, mx));
    V d = V_ADD(V_MUL(ex, my), V_MUL(ey, mx));
    d = V_ADD(d, V_MUL(ey, mx));
    d = V_ADD(d, V_MUL(ex, my));
    d = V_ADD(d, V_MUL(ex, ey));
    d = V_ADD(d, V_MUL(ey, ex));
    V bound = V_ADD(V_MUL(V_SET1(GAMMA_F(3)), m), V_MUL(d, V_SET1(1.0f + GAMMA_F(3))));
    V emin = V_MIN(V_ABS(e0), V_MIN(V_ABS(e1), V_ABS(e2)));
    int unsure = M_BITS(V_LE(emin, bound));
    /* edges of both signs: the ray passes outside (a lane with a NaN edge,
     * past 2^63, has a NaN ts, and the scalar routine decides it) */
    V emn = V_MIN(e0, V_MIN(e1, e2)), emx = V_MAX(e0, V_MAX(e1, e2));
    V det = V_ADD(V_ADD(e0, e1), e2);
    V sz = V_RAY(p->sz, p2->sz);
    V azs = V_MUL(az, sz), bzs = V_MUL(bz, sz), czs = V_MUL(cz, sz);
    V ts = V_ADD(V_ADD(V_MUL(e0, azs), V_MUL(e1, bzs)), V_MUL(e2, czs));
    V tmax = V_RAY(r->tmax, r2->tmax), tmd = V_MUL(tmax, det);
    M neg = V_LT(det, zero);
    M out_neg = M_OR(V_GE(ts, zero), V_LT(ts, tmd));
    M out_pos = M_OR(V_LE(ts, zero), V_GT(ts, tmd));
    M edges_out = M_OR(M_AND(V_LT(emn, zero), V_GT(emx, zero)), V_EQ(det, zero));
    M t_out = M_OR(M_AND(neg, out_neg), M_ANDNOT(neg, out_pos));
    *slow = lanes & unsure;
    int inside = lanes & ~unsure & ~M_BITS(edges_out);
    if (!inside) /* most leaves a ray reaches are missed by here */
        return 0;
    /* the rest of watertight() for the lanes inside, in its order (a lane
     * with a finite ts has no NaN, so MAXPS is max3 there; a NaN ts goes
     * to the scalar routine, below). max |z sz| is max|z| |sz|
     * rounded, and max |e| the larger of |min e| and |max e|: rounding
     * and abs are monotone. */
    V mz = V_MUL(mz_len, V_ABS(sz)), me = V_MAX(V_ABS(emn), V_ABS(emx));
    V dxe = V_MUL(g5, V_ADD(mx, mz_len)), dye = V_MUL(g5, V_ADD(my, mz_len));
    V g3 = V_SET1(GAMMA_F(3)), dze = V_MUL(g3, mz);
    V de = V_ADD(V_MUL(V_MUL(V_SET1(GAMMA_F(2)), mx), my), V_MUL(dye, mx));
    de = V_MUL(V_SET1(2.0f), V_ADD(de, V_MUL(dxe, my)));
    V tserr = V_ADD(V_MUL(V_MUL(g3, me), mz), V_MUL(de, mz));
    tserr = V_MUL(V_SET1(3.0f), V_ADD(tserr, V_MUL(dze, me)));
    /* a t outside (0, tmax) by less than its error bound (times |det|):
     * watertight() takes it again in double */
    V tsd = V_SEL(neg, V_SUB(zero, ts), ts);
    int near = M_BITS(M_AND(V_GT(tsd, V_SUB(zero, tserr)), V_LT(tsd, V_ADD(V_ABS(tmd), tserr))));
    int hit = inside & ~M_BITS(t_out);
    if (hit) { /* only then the division */
        V inv = V_DIV(V_SET1(1.0f), det), tv = V_MUL(ts, inv);
        hit &= M_BITS(M_AND(V_GT(tv, zero), V_LT(tv, tmax)));
        V_STORE(ht, tv);
        V_STORE(hterr, V_TERR_UP(V_MUL(tserr, V_ABS(inv)), tv)); /* prim_terr_up, every lane */
        V_STORE(hu, V_MUL(e1, inv));
        V_STORE(hv, V_MUL(e2, inv));
    }
    /* a t past float's range or a NaN (tri_t_out_of_range), to the scalar
     * routine, which takes it in double (me, sure here, is at least
     * TRI_T_TINY: TRI_SHEAR_FLOOR); apart from the branch above, which
     * would otherwise wait for tserr */
    M fits = M_AND(V_GE(tserr, V_SET1(TRI_T_TINY)), V_LE(tserr, V_SET1(TRI_T_HUGE)));
    int far = inside & ~M_BITS(fits);
    *slow |= (inside & ~hit & near) | far;
    return hit & ~far;
#undef MAX3
}

#undef TRI_LANES
#undef TRI_LANES_DECL
#undef TRI_LANES_RAY2
#undef V_RAY
#undef V
#undef V_LOAD
#undef V_STORE
#undef V_SET1
#undef V_ADD
#undef V_SUB
#undef V_MUL
#undef V_DIV
#undef V_MIN
#undef V_MAX
#undef M
#undef M_AND
#undef M_OR
#undef M_ANDNOT
#undef M_BITS
#undef V_SEL
#undef V_ABS
#undef V_LT
#undef V_LE
#undef V_GT
#undef V_GE
#undef V_EQ
#undef V_TERR_UP
