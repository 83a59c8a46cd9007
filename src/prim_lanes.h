/*
 * prim_lanes.h - the robust plane's, sphere's and ellipsoid's SIMD lanes,
 * written once for every width: prim.c includes it with Q_NAME (the
 * functions' suffix), Q_ATTR (their target), Q_W lanes, the vector Q_V,
 * the lane mask Q_M and their operations (QV_*, QM_*) defined, once for
 * AVX (four lanes, the mask a vector) and once for AVX-512 (eight lanes,
 * the mask a mask register). It undefines them at its end, ready for the
 * next width. (Their prefixes are not tri_lanes.h's V_*: each template's
 * names are its own.)
 *
 * prim.c's prim_plane_hit_robust, quadric_hit and prim_box_hit_robust lane
 * by lane, in the same operations and order, so each lane gets the scalar
 * routine's bits.
 */

/* prim_plane_hit_robust for the rays r[k0 .. k0 + Q_W - 1] up to tmax[k0
 * ..], one a lane: the same operations in the same order, each verdict a
 * mask. Returns the lanes hit. */
Q_ATTR static unsigned Q_NAME(plane_hit)(const Plane *pl, const Ray *r, int k0, const float *tmax, float *t_out,
                                         float *terr_out)
{
    const Q_V zero = QV_SET1(0.0);
    const Q_V nx = QV_SET1(pl->n.x), ny = QV_SET1(pl->n.y), nz = QV_SET1(pl->n.z);
    int k[Q_W];
    for (int j = 0; j < Q_W; j++)
        k[j] = k0 + j;
    Q_F f[RAY_FIELDS];
    Q_FIELDS(r, k, f);
    Q_V dx = QV_MUL(nx, Q_CVT_PD(f[RAY_D])), dy = QV_MUL(ny, Q_CVT_PD(f[RAY_D + 1]));
    Q_V dz = QV_MUL(nz, Q_CVT_PD(f[RAY_D + 2]));
    Q_V den = QV_ADD(QV_ADD(dx, dy), dz);
    Q_V ox = QV_MUL(nx, Q_CVT_PD(f[RAY_O])), oy = QV_MUL(ny, Q_CVT_PD(f[RAY_O + 1]));
    Q_V oz = QV_MUL(nz, Q_CVT_PD(f[RAY_O + 2]));
    Q_V num = QV_SUB(QV_SET1(pl->d), QV_ADD(QV_ADD(ox, oy), oz));
    /* num == 0 || (num < 0) != (den < 0) */
    Q_M miss = QM_OR(QV_CMP(num, zero, _CMP_EQ_OQ),
                     QM_XOR(QV_CMP(num, zero, _CMP_LT_OQ), QV_CMP(den, zero, _CMP_LT_OQ)));
    Q_V e_den = QV_MUL(QV_SET1(gamma_d(2)), QV_ADD(QV_ADD(QV_ABS(dx), QV_ABS(dy)), QV_ABS(dz)));
    miss = QM_OR(miss, QV_CMP(QV_ABS(den), e_den, _CMP_NGT_UQ));
    const Q_F tm = Q_LOAD_F(tmax + k0);
    Q_V reach = QV_MUL(Q_CVT_PD(tm), QV_ABS(den));
    miss = QM_OR(miss, QM_AND(QV_CMP(reach, QV_SET1(0x1p-1000), _CMP_GT_OQ),
                              QV_CMP(QV_ABS(num), QV_MUL(reach, QV_SET1(1.0 + 0x1p-50)), _CMP_GE_OQ)));
    if (QM_BITS(miss) == Q_ALL) /* every lane decided: the divisions below are the cost */
        return 0;
    Q_V e_num = QV_ADD(QV_MUL(QV_SET1(gamma_d(2)), QV_ADD(QV_ADD(QV_ABS(ox), QV_ABS(oy)), QV_ABS(oz))),
                       QV_MUL(QV_SET1(gamma_d(1)), QV_ABS(num)));
    Q_V t = QV_DIV(num, den);
    /* quotient_err, then round_t */
    Q_V err = QV_ADD(QV_DIV(QV_ADD(e_num, QV_MUL(QV_ABS(t), e_den)), QV_SUB(QV_ABS(den), e_den)),
                     QV_MUL(QV_SET1(gamma_d(1)), QV_ABS(t)));
    return ~QM_BITS(miss) & Q_ROUND_T(t, err, tm, t_out, terr_out);
}

/* One coordinate's term of sphere_g and ell_g for the lanes: p (the
 * coordinate in the sphere's space) and ep (its error bound) added to g,
 * to their error e and to the magnitude mag, in their order. */
Q_ATTR static inline void Q_NAME(g_term)(Q_V p, Q_V ep, Q_V *g, Q_V *e, Q_V *mag)
{
    const Q_V pp = QV_MUL(p, p), two_abs = QV_MUL(QV_SET1(2.0), QV_ABS(p));
    *g = QV_ADD(*g, pp);
    *e = QV_ADD(*e, QV_ADD(QV_MUL(two_abs, ep), QV_MUL(ep, ep)));
    *mag = QV_ADD(*mag, pp);
}

/* sphere_g for the lanes, the same operations lane by lane. */
Q_ATTR static inline Q_V Q_NAME(sphere_g)(const Q_V f[3], const Q_V d[3], Q_V r2, Q_V t, Q_V *err)
{
    const Q_V g3 = QV_SET1(gamma_d(3));
    Q_V g = QV_NEG(r2), e = QV_SET1(0.0), mag = r2;
    for (int i = 0; i < 3; i++) {
        Q_V td = QV_MUL(t, d[i]);
        Q_V p = QV_ADD(f[i], td);
        Q_NAME(g_term)(p, QV_MUL(g3, QV_ADD(QV_ABS(f[i]), QV_ABS(td))), &g, &e, &mag);
    }
    *err = QV_ADD(e, QV_MUL(QV_SET1(gamma_d(5)), mag));
    return g;
}

/* ell_g for the lanes at o + t d (o and d the floats of the rays, in
 * double), the same operations lane by lane. */
Q_ATTR static inline Q_V Q_NAME(ell_g)(const double *a, const Q_V o[3], const Q_V d[3], Q_V t, Q_V *err)
{
    const Q_V g4 = QV_SET1(gamma_d(4));
    Q_V y[3], ey[3];
    for (int j = 0; j < 3; j++) {
        Q_V td = QV_MUL(t, d[j]);
        y[j] = QV_ADD(o[j], td);
        ey[j] = QV_MUL(QV_SET1(gamma_d(2)), QV_ADD(QV_ABS(o[j]), QV_ABS(td)));
    }
    Q_V g = QV_SET1(-1.0), e = QV_SET1(0.0), mag = QV_SET1(1.0);
    for (int i = 0; i < 3; i++) {
        Q_V x = QV_SET1(a[9 + i]), m = QV_SET1(fabs(a[9 + i])), ex = QV_SET1(0.0);
        for (int j = 0; j < 3; j++) {
            Q_V ay = QV_MUL(QV_SET1(a[3 * i + j]), y[j]);
            x = QV_ADD(x, ay);
            m = QV_ADD(m, QV_ABS(ay));
            ex = QV_ADD(ex, QV_MUL(QV_SET1(fabs(a[3 * i + j])), ey[j]));
        }
        Q_NAME(g_term)(x, QV_ADD(QV_MUL(ex, QV_SET1(1.0 + gamma_d(4))), QV_MUL(g4, m)), &g, &e, &mag);
    }
    *err = QV_MUL(QV_ADD(e, QV_MUL(QV_SET1(gamma_d(5)), mag)), QV_SET1(1.0 + gamma_d(8)));
    return g;
}

/* quadric_hit for the lanes' rays (their tmax), lane by lane: the same
 * operations in the same order (stable_roots from f and d, certify_root's
 * brackets on sphere_g, or on ell_g with ell the inverse map and gf, gd the
 * rays' own o and d, then round_t), each verdict a mask. Returns the lanes
 * hit. */
Q_ATTR __attribute__((always_inline)) static inline unsigned Q_NAME(quadric_hit)(const Q_V f[3], const Q_V d[3], Q_V r2,
                                                                                const double *ell, const Q_V gf[3],
                                                                                const Q_V gd[3], Q_F tmax, float *t_out,
                                                                                float *terr_out)
{
    const Q_V zero = QV_SET1(0.0);
    /* stable_roots */
    Q_V a = zero, b = zero, ff = zero, l2 = zero;
    for (int i = 0; i < 3; i++) {
        a = QV_ADD(a, QV_MUL(d[i], d[i]));
        b = QV_ADD(b, QV_MUL(f[i], d[i]));
        ff = QV_ADD(ff, QV_MUL(f[i], f[i]));
    }
    /* every lane from outside and moving away: none has a root (stable_roots) */
    if (QM_BITS(QM_AND(QV_CMP(b, zero, _CMP_GT_OQ), QV_CMP(QV_SUB(ff, r2), zero, _CMP_GT_OQ))) == Q_ALL)
        return 0;
    Q_V kk = QV_DIV(b, a);
    for (int i = 0; i < 3; i++) {
        Q_V li = QV_SUB(f[i], QV_MUL(kk, d[i]));
        l2 = QV_ADD(l2, QV_MUL(li, li));
    }
    Q_V disc = QV_MUL(a, QV_SUB(r2, l2));
    Q_M ok = QV_CMP(disc, zero, _CMP_GE_OQ);
    Q_V root = QV_COPYSIGN(QV_SQRT(disc), b);
    Q_V q = QV_NEG(QV_ADD(b, root));
    Q_V t0 = QV_DIV(QV_SUB(ff, r2), q), t1 = QV_DIV(q, a);
    Q_M swap = QV_CMP(t0, t1, _CMP_GT_OQ);
    Q_V lo = QV_BLEND(t0, t1, swap), hi = QV_BLEND(t1, t0, swap);
    ok = QM_AND(ok, QV_CMP(q, zero, _CMP_NEQ_UQ));
    /* stable_root */
    Q_V t = QV_BLEND(hi, lo, QV_CMP(lo, zero, _CMP_GT_OQ));
    ok = QM_AND(ok, QV_CMP(t, zero, _CMP_GT_OQ));
    /* certify_root: each lane's bracket widens until it is certain, as
     * long as some lane's is not (none, when every lane missed) */
    Q_V w = QV_ADD(QV_MUL(QV_SET1(CERTIFY_START * UNIT_D), QV_ABS(t)), QV_SET1(1e-300));
    Q_M sure = QM_NONE;
    Q_V half = zero; /* the certain lanes' half-widths */
    for (int it = 0; it < 24; it++, w = QV_MUL(w, QV_SET1(8.0))) {
        Q_M need = QM_ANDNOT(sure, ok);
        if (!QM_BITS(need))
            break;
        Q_V e_lo, e_hi, g_lo, g_hi;
        if (ell) {
            g_lo = Q_NAME(ell_g)(ell, gf, gd, QV_SUB(t, w), &e_lo);
            g_hi = Q_NAME(ell_g)(ell, gf, gd, QV_ADD(t, w), &e_hi);
        } else {
            g_lo = Q_NAME(sphere_g)(gf, gd, r2, QV_SUB(t, w), &e_lo);
            g_hi = Q_NAME(sphere_g)(gf, gd, r2, QV_ADD(t, w), &e_hi);
        }
        Q_M now = QM_AND(QV_CMP(QV_ABS(g_lo), e_lo, _CMP_GT_OQ), QV_CMP(QV_ABS(g_hi), e_hi, _CMP_GT_OQ));
        now = QM_AND(need, QM_AND(now, QM_XOR(QV_CMP(g_lo, zero, _CMP_GT_OQ), QV_CMP(g_hi, zero, _CMP_GT_OQ))));
        half = QV_BLEND(half, QV_ADD(w, QV_MUL(QV_SET1(2.0 * UNIT_D), QV_ADD(QV_ABS(t), w))), now);
        sure = QM_OR(sure, now);
    }
    ok = QM_AND(ok, sure); /* a bracket never certain: tangent to working precision, a miss */
    return QM_BITS(ok) & Q_ROUND_T(t, half, tmax, t_out, terr_out);
}

/* prim_sphere_hit_robust or prim_ellipsoid_hit_robust for the rays r[k[j]],
 * one a lane (p a sphere or an ellipsoid). Returns the lanes hit. */
Q_ATTR static unsigned Q_NAME(quadric_rays)(const Prim *p, const Ray *r, const int *k, float *t_out, float *terr_out)
{
    Q_F rf[RAY_FIELDS];
    Q_FIELDS(r, k, rf);
    const Q_F tmax = rf[RAY_TMAX];
    const Q_V o[3] = {Q_CVT_PD(rf[RAY_O]), Q_CVT_PD(rf[RAY_O + 1]), Q_CVT_PD(rf[RAY_O + 2])};
    const Q_V d[3] = {Q_CVT_PD(rf[RAY_D]), Q_CVT_PD(rf[RAY_D + 1]), Q_CVT_PD(rf[RAY_D + 2])};
    Q_V f[3];
    if (p->kind == PRIM_SPHERE) {
        const Sphere *s = &p->g.sphere;
        const Q_V r2 = QV_SET1((double)s->r * s->r); /* r^2 is exact */
        for (int i = 0; i < 3; i++)
            f[i] = QV_SUB(o[i], QV_SET1(vec_comp(s->c, i)));
        return Q_NAME(quadric_hit)(f, d, r2, NULL, f, d, tmax, t_out, terr_out);
    }
    /* ell_ray: f = A o + b, and A d */
    const double *a = p->g.ell.e->a;
    Q_V dd[3];
    for (int i = 0; i < 3; i++) {
        const Q_V a0 = QV_SET1(a[3 * i]), a1 = QV_SET1(a[3 * i + 1]), a2 = QV_SET1(a[3 * i + 2]);
        f[i] = QV_ADD(QV_ADD(QV_ADD(QV_MUL(a0, o[0]), QV_MUL(a1, o[1])), QV_MUL(a2, o[2])), QV_SET1(a[9 + i]));
        dd[i] = QV_ADD(QV_ADD(QV_MUL(a0, d[0]), QV_MUL(a1, d[1])), QV_MUL(a2, d[2]));
    }
    return Q_NAME(quadric_hit)(f, dd, QV_SET1(1.0), a, o, d, tmax, t_out, terr_out);
}

/* prim_box_hit_robust for the rays r[k[j]], one a lane: the slabs in the
 * same operations and order, each comparison a mask that picks the lanes'
 * new bounds and faces. Returns the lanes hit; their faces into face_out. */
Q_ATTR static unsigned Q_NAME(box_rays)(const Box *b, const Ray *r, const int *k, float *t_out, float *terr_out,
                                        int *face_out)
{
    Q_F rf[RAY_FIELDS];
    Q_FIELDS(r, k, rf);
    const Q_V zero = QV_SET1(0.0), pad = QV_SET1(PRIM_BOX_PAD);
    Q_V tnear = QV_SET1(-INFINITY), tfar = QV_SET1(INFINITY), texit = QV_SET1(INFINITY);
    Q_V near_face = zero, far_face = zero; /* small whole numbers, exact in double */
    for (int i = 0; i < 3; i++) {
        const Q_V inv = QV_DIV(QV_SET1(1.0), Q_CVT_PD(rf[RAY_D + i])), o = Q_CVT_PD(rf[RAY_O + i]);
        const Q_V lo = QV_SET1((double)vec_comp(b->lo, i)), hi = QV_SET1((double)vec_comp(b->hi, i));
        const Q_M neg = QV_CMP(inv, zero, _CMP_LT_OQ);
        const Q_V t0 = QV_MUL(QV_SUB(QV_BLEND(lo, hi, neg), o), inv);
        const Q_V t1 = QV_MUL(QV_SUB(QV_BLEND(hi, lo, neg), o), inv);
        const Q_M in = QV_CMP(t0, tnear, _CMP_GT_OQ), out = QV_CMP(t1, texit, _CMP_LT_OQ);
        tnear = QV_BLEND(tnear, t0, in);
        near_face = QV_BLEND(near_face, QV_BLEND(QV_SET1(i), QV_SET1(i + 3), neg), in);
        texit = QV_BLEND(texit, t1, out);
        far_face = QV_BLEND(far_face, QV_BLEND(QV_SET1(i + 3), QV_SET1(i), neg), out);
        const Q_V tp = QV_MUL(t1, pad);
        tfar = QV_BLEND(tfar, tp, QV_CMP(tp, tfar, _CMP_LT_OQ));
    }
    const Q_M ok = QV_CMP(tnear, tfar, _CMP_LE_OQ), outside = QV_CMP(tnear, zero, _CMP_GT_OQ);
    if (!QM_BITS(ok))
        return 0;
    const Q_V t = QV_BLEND(texit, tnear, outside);
    Q_STORE_I32(face_out, QV_BLEND(far_face, near_face, outside));
    return QM_BITS(ok) & Q_ROUND_T(t, QV_MUL(QV_SET1(gamma_d(3)), QV_ABS(t)), rf[RAY_TMAX], t_out, terr_out);
}

#undef Q_NAME
#undef Q_ATTR
#undef Q_W
#undef Q_ALL
#undef Q_LOAD_F
#undef Q_CVT_PD
#undef Q_F
#undef Q_FIELDS
#undef Q_ROUND_T
#undef Q_STORE_I32
#undef Q_V
#undef Q_M
#undef QV_SET1
#undef QV_ADD
#undef QV_SUB
#undef QV_MUL
#undef QV_DIV
#undef QV_SQRT
#undef QV_ABS
#undef QV_NEG
#undef QV_COPYSIGN
#undef QV_BLEND
#undef QV_CMP
#undef QM_AND
#undef QM_OR
#undef QM_ANDNOT
#undef QM_XOR
#undef QM_BITS
#undef QM_NONE
