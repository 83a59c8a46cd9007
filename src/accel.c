/*
 * accel.c - brute-force visibility: every ray tests every primitive.
 */
#include "lancer/accel.h"

int accel_build(Accel *a, const Scene *s)
{
    a->prims = s->prims;
    a->nprims = s->nprims;
    a->variant = s->classic ? PRIM_CLASSIC : PRIM_ROBUST;
    return 0;
}

void accel_free(Accel *a)
{
    a->prims = NULL;
    a->nprims = 0;
}

int accel_closest(const Accel *a, const Ray *r, PrimHit *h, RayStats *st)
{
    Ray q = *r; /* tmax shrinks to the nearest hit so far */
    int best = -1;
    PrimHit cur;
    for (int i = 0; i < a->nprims; i++) {
        if (prim_intersect(&a->prims[i], &q, a->variant, &cur)) {
            best = i;
            *h = cur;
            q.tmax = cur.t;
        }
    }
    st->isect_tests += (unsigned long long)a->nprims;
    return best;
}

int accel_occluded(const Accel *a, const Ray *r, RayStats *st)
{
    PrimHit cur;
    for (int i = 0; i < a->nprims; i++) {
        if (prim_intersect(&a->prims[i], r, a->variant, &cur)) {
            st->isect_tests += (unsigned long long)i + 1;
            return 1;
        }
    }
    st->isect_tests += (unsigned long long)a->nprims;
    return 0;
}
