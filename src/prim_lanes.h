/*
 * prim_lanes.h - the robust plane's, sphere's and ellipsoid's SIMD lanes,
 * written once for every width: prim.c includes it with Q_NAME (the
 * functions' suffix), Q_ATTR (their target), Q_W lanes, the vector V, the
 * lane mask M and their operations defined, once for AVX (four lanes, the
 * mask a vector) and once for AVX-512 (eight lanes, the mask a mask
 * register). It undefines them at its end, ready for the next width.
 *
 * prim.c's prim_plane_hit_robust and quadric_hit lane by lane, in the same
 * operations and order, so each lane gets the scalar routine's bits.
 */

/* prim_plane_hit_robust for the rays r[k0 .. k0 + Q_W - 1] up to tmax[k0
 * ..], one a lane: the same operations in the same order, each verdict a
 * mask. Returns the lanes hit. */
Q_ATTR static unsigned Q_NAME(plane_hit)(const Plane *pl, const Ray *r, int k0, const float *tmax, float *t_out,
                                         float *terr_out)
{
    const V zero = V_SET1(0.0);
    const V nx = V_SET1(pl->n.x), ny = V_SET1(pl->n.y), nz = V_SET1(pl->n.z);
    int k[Q_W];
    for (int j = 0; j < Q_W; j++)
        k[j] = k0 + j;
    V dx = V_MUL(nx, Q_RAY(r, k, RAY_D)), dy = V_MUL(ny, Q_RAY(r, k, RAY_D + 1));
    V dz = V_MUL(nz, Q_RAY(r, k, RAY_D + 2));
    V den = V_ADD(V_ADD(dx, dy), dz);
    V ox = V_MUL(nx, Q_RAY(r, k, RAY_O)), oy = V_MUL(ny, Q_RAY(r, k, RAY_O + 1));
    V oz = V_MUL(nz, Q_RAY(r, k, RAY_O + 2));
    V num = V_SUB(V_SET1(pl->d), V_ADD(V_ADD(ox, oy), oz));
    /* num == 0 || (num < 0) != (den < 0) */
    M miss = M_OR(V_CMP(num, zero, _CMP_EQ_OQ), M_XOR(V_CMP(num, zero, _CMP_LT_OQ), V_CMP(den, zero, _CMP_LT_OQ)));
    V e_den = V_MUL(V_SET1(gamma_d(2)), V_ADD(V_ADD(V_ABS(dx), V_ABS(dy)), V_ABS(dz)));
    miss = M_OR(miss, V_CMP(V_ABS(den), e_den, _CMP_NGT_UQ));
    const Q_F tm = Q_LOAD_F(tmax + k0);
    V reach = V_MUL(Q_CVT_PD(tm), V_ABS(den));
    miss = M_OR(miss, M_AND(V_CMP(reach, V_SET1(0x1p-1000), _CMP_GT_OQ),
                            V_CMP(V_ABS(num), V_MUL(reach, V_SET1(1.0 + 0x1p-50)), _CMP_GE_OQ)));
    if (M_BITS(miss) == Q_ALL) /* every lane decided: the divisions below are the cost */
        return 0;
    V e_num = V_ADD(V_MUL(V_SET1(gamma_d(2)), V_ADD(V_ADD(V_ABS(ox), V_ABS(oy)), V_ABS(oz))),
                    V_MUL(V_SET1(gamma_d(1)), V_ABS(num)));
    V t = V_DIV(num, den);
    /* quotient_err, then round_t */
    V err = V_ADD(V_DIV(V_ADD(e_num, V_MUL(V_ABS(t), e_den)), V_SUB(V_ABS(den), e_den)),
                  V_MUL(V_SET1(gamma_d(1)), V_ABS(t)));
    return ~M_BITS(miss) & Q_ROUND_T(t, err, tm, t_out, terr_out);
}

/* One coordinate's term of sphere_g and ell_g for the lanes: p (the
 * coordinate in the sphere's space) and ep (its error bound) added to g,
 * to their error e and to the magnitude mag, in their order. */
Q_ATTR static inline void Q_NAME(g_term)(V p, V ep, V *g, V *e, V *mag)
{
    const V pp = V_MUL(p, p), two_abs = V_MUL(V_SET1(2.0), V_ABS(p));
    *g = V_ADD(*g, pp);
    *e = V_ADD(*e, V_ADD(V_MUL(two_abs, ep), V_MUL(ep, ep)));
    *mag = V_ADD(*mag, pp);
}

/* sphere_g for the lanes, the same operations lane by lane. */
Q_ATTR static inline V Q_NAME(sphere_g)(const V f[3], const V d[3], V r2, V t, V *err)
{
    const V g3 = V_SET1(gamma_d(3));
    V g = V_NEG(r2), e = V_SET1(0.0), mag = r2;
    for (int i = 0; i < 3; i++) {
        V td = V_MUL(t, d[i]);
        V p = V_ADD(f[i], td);
        Q_NAME(g_term)(p, V_MUL(g3, V_ADD(V_ABS(f[i]), V_ABS(td))), &g, &e, &mag);
    }
    *err = V_ADD(e, V_MUL(V_SET1(gamma_d(5)), mag));
    return g;
}

/* ell_g for the lanes at o + t d (o and d the floats of the rays, in
 * double), the same operations lane by lane. */
Q_ATTR static inline V Q_NAME(ell_g)(const double *a, const V o[3], const V d[3], V t, V *err)
{
    const V g4 = V_SET1(gamma_d(4));
    V y[3], ey[3];
    for (int j = 0; j < 3; j++) {
        V td = V_MUL(t, d[j]);
        y[j] = V_ADD(o[j], td);
        ey[j] = V_MUL(V_SET1(gamma_d(2)), V_ADD(V_ABS(o[j]), V_ABS(td)));
    }
    V g = V_SET1(-1.0), e = V_SET1(0.0), mag = V_SET1(1.0);
    for (int i = 0; i < 3; i++) {
        V x = V_SET1(a[9 + i]), m = V_SET1(fabs(a[9 + i])), ex = V_SET1(0.0);
        for (int j = 0; j < 3; j++) {
            V ay = V_MUL(V_SET1(a[3 * i + j]), y[j]);
            x = V_ADD(x, ay);
            m = V_ADD(m, V_ABS(ay));
            ex = V_ADD(ex, V_MUL(V_SET1(fabs(a[3 * i + j])), ey[j]));
        }
        Q_NAME(g_term)(x, V_ADD(V_MUL(ex, V_SET1(1.0 + gamma_d(4))), V_MUL(g4, m)), &g, &e, &mag);
    }
    *err = V_MUL(V_ADD(e, V_MUL(V_SET1(gamma_d(5)), mag)), V_SET1(1.0 + gamma_d(8)));
    return g;
}

/* quadric_hit for the lanes' rays (their tmax), lane by lane: the same
 * operations in the same order (stable_roots from f and d, certify_root's
 * brackets on sphere_g, or on ell_g with ell the inverse map and gf, gd the
 * rays' own o and d, then round_t), each verdict a mask. Returns the lanes
 * hit. */
Q_ATTR __attribute__((always_inline)) static inline unsigned Q_NAME(quadric_hit)(const V f[3], const V d[3], V r2,
                                                                                const double *ell, const V gf[3],
                                                                                const V gd[3], Q_F tmax, float *t_out,
                                                                                float *terr_out)
{
    const V zero = V_SET1(0.0);
    /* stable_roots */
    V a = zero, b = zero, ff = zero, l2 = zero;
    for (int i = 0; i < 3; i++) {
        a = V_ADD(a, V_MUL(d[i], d[i]));
        b = V_ADD(b, V_MUL(f[i], d[i]));
        ff = V_ADD(ff, V_MUL(f[i], f[i]));
    }
    /* every lane from outside and moving away: none has a root (stable_roots) */
    if (M_BITS(M_AND(V_CMP(b, zero, _CMP_GT_OQ), V_CMP(V_SUB(ff, r2), zero, _CMP_GT_OQ))) == Q_ALL)
        return 0;
    V kk = V_DIV(b, a);
    for (int i = 0; i < 3; i++) {
        V li = V_SUB(f[i], V_MUL(kk, d[i]));
        l2 = V_ADD(l2, V_MUL(li, li));
    }
    V disc = V_MUL(a, V_SUB(r2, l2));
    M ok = V_CMP(disc, zero, _CMP_GE_OQ);
    V root = V_COPYSIGN(V_SQRT(disc), b);
    V q = V_NEG(V_ADD(b, root));
    V t0 = V_DIV(V_SUB(ff, r2), q), t1 = V_DIV(q, a);
    M swap = V_CMP(t0, t1, _CMP_GT_OQ);
    V lo = V_BLEND(t0, t1, swap), hi = V_BLEND(t1, t0, swap);
    ok = M_AND(ok, V_CMP(q, zero, _CMP_NEQ_UQ));
    /* stable_root */
    V t = V_BLEND(hi, lo, V_CMP(lo, zero, _CMP_GT_OQ));
    ok = M_AND(ok, V_CMP(t, zero, _CMP_GT_OQ));
    /* certify_root: each lane's bracket widens until it is certain, as
     * long as some lane's is not (none, when every lane missed) */
    V w = V_ADD(V_MUL(V_SET1(CERTIFY_START * UNIT_D), V_ABS(t)), V_SET1(1e-300));
    M sure = M_NONE;
    V half = zero; /* the certain lanes' half-widths */
    for (int it = 0; it < 24; it++, w = V_MUL(w, V_SET1(8.0))) {
        M need = M_ANDNOT(sure, ok);
        if (!M_BITS(need))
            break;
        V e_lo, e_hi, g_lo, g_hi;
        if (ell) {
            g_lo = Q_NAME(ell_g)(ell, gf, gd, V_SUB(t, w), &e_lo);
            g_hi = Q_NAME(ell_g)(ell, gf, gd, V_ADD(t, w), &e_hi);
        } else {
            g_lo = Q_NAME(sphere_g)(gf, gd, r2, V_SUB(t, w), &e_lo);
            g_hi = Q_NAME(sphere_g)(gf, gd, r2, V_ADD(t, w), &e_hi);
        }
        M now = M_AND(V_CMP(V_ABS(g_lo), e_lo, _CMP_GT_OQ), V_CMP(V_ABS(g_hi), e_hi, _CMP_GT_OQ));
        now = M_AND(need, M_AND(now, M_XOR(V_CMP(g_lo, zero, _CMP_GT_OQ), V_CMP(g_hi, zero, _CMP_GT_OQ))));
        half = V_BLEND(half, V_ADD(w, V_MUL(V_SET1(2.0 * UNIT_D), V_ADD(V_ABS(t), w))), now);
        sure = M_OR(sure, now);
    }
    ok = M_AND(ok, sure); /* a bracket never certain: tangent to working precision, a miss */
    return M_BITS(ok) & Q_ROUND_T(t, half, tmax, t_out, terr_out);
}

/* prim_sphere_hit_robust or prim_ellipsoid_hit_robust for the rays r[k[j]],
 * one a lane (p a sphere or an ellipsoid). Returns the lanes hit. */
Q_ATTR static unsigned Q_NAME(quadric_rays)(const Prim *p, const Ray *r, const int *k, float *t_out, float *terr_out)
{
    const Q_F tmax = Q_RAY_F(r, k, RAY_TMAX);
    const V o[3] = {Q_RAY(r, k, RAY_O), Q_RAY(r, k, RAY_O + 1), Q_RAY(r, k, RAY_O + 2)};
    const V d[3] = {Q_RAY(r, k, RAY_D), Q_RAY(r, k, RAY_D + 1), Q_RAY(r, k, RAY_D + 2)};
    V f[3];
    if (p->kind == PRIM_SPHERE) {
        const Sphere *s = &p->g.sphere;
        const V r2 = V_SET1((double)s->r * s->r); /* r^2 is exact */
        for (int i = 0; i < 3; i++)
            f[i] = V_SUB(o[i], V_SET1(vec_comp(s->c, i)));
        return Q_NAME(quadric_hit)(f, d, r2, NULL, f, d, tmax, t_out, terr_out);
    }
    /* ell_ray: f = A o + b, and A d */
    const double *a = p->g.ell.e->a;
    V dd[3];
    for (int i = 0; i < 3; i++) {
        const V a0 = V_SET1(a[3 * i]), a1 = V_SET1(a[3 * i + 1]), a2 = V_SET1(a[3 * i + 2]);
        f[i] = V_ADD(V_ADD(V_ADD(V_MUL(a0, o[0]), V_MUL(a1, o[1])), V_MUL(a2, o[2])), V_SET1(a[9 + i]));
        dd[i] = V_ADD(V_ADD(V_MUL(a0, d[0]), V_MUL(a1, d[1])), V_MUL(a2, d[2]));
    }
    return Q_NAME(quadric_hit)(f, dd, V_SET1(1.0), a, o, d, tmax, t_out, terr_out);
}

#undef Q_NAME
#undef Q_ATTR
#undef Q_W
#undef Q_ALL
#undef Q_LOAD_F
#undef Q_CVT_PD
#undef Q_F
#undef Q_RAY
#undef Q_RAY_F
#undef Q_ROUND_T
#undef V
#undef M
#undef V_SET1
#undef V_ADD
#undef V_SUB
#undef V_MUL
#undef V_DIV
#undef V_SQRT
#undef V_ABS
#undef V_NEG
#undef V_COPYSIGN
#undef V_BLEND
#undef V_CMP
#undef M_AND
#undef M_OR
#undef M_ANDNOT
#undef M_XOR
#undef M_BITS
#undef M_NONE
