/*
 * fuzz_scene.c - the scene parser (scene_parse). A scene that parses must
 * pass scene_validate, and get a render plan and an acceleration structure;
 * a scene that does not must leave the Scene empty and a message
 * "fuzz.in:line:col: what is wrong". A ray from the eye to the target is
 * traced through the scene, its PN patches included. Mesh files that a scene names are read
 * from the working directory, as the command line would.
 */
#include "fuzz.h"

#include <math.h>

#include "lancer/accel.h"
#include "lancer/plan.h"
#include "lancer/scene.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    Scene s;
    char err[1024] = "";
    if (scene_parse(FUZZ_NAME, (const char *)data, size, &s, err, sizeof err) != 0) {
        fuzz_check_message(err, 2, 2);
        fuzz_require(!s.prims && !s.materials && !s.lights && !s.inputs && !s.patches && !s.nprims &&
                         !s.nmaterials && !s.nlights && !s.ninputs && !s.npatches,
                     "a failed parse left data in the scene", err);
        return 0;
    }
    fuzz_require(scene_validate(&s, err, sizeof err) == 0, "a parsed scene fails scene_validate", err);
    PlanOptions o = plan_options();
    o.threads = 1;
    RenderPlan p;
    if (plan_build(&p, &s, &o, err, sizeof err) == 0) {
        Accel *a = accel_build(&s, p.variant, 1);
        fuzz_require(a != NULL, "accel_build failed", "out of memory");
        Vec3 d = vec_normalize(vec_sub(s.camera.target, s.camera.eye));
        if (vec_is_finite(d) && vec_max_abs(d) > 0.5f) { /* a unit direction, as the camera's */
            Ray r = ray_make(s.camera.eye, d, INFINITY);
            PrimHit h;
            RayStats st;
            memset(&st, 0, sizeof st);
            if (accel_closest(a, &r, &h, &st) >= 0)
                fuzz_require(h.t > 0.0f && h.t < INFINITY && h.terr >= 0.0f, "a hit outside (0, inf)", "");
        }
        accel_free(a);
        plan_free(&p);
    }
    scene_free(&s);
    return 0;
}
