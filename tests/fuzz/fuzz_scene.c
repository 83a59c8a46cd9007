/*
 * fuzz_scene.c - the scene parser (scene_parse). A scene that parses must
 * pass scene_validate, and get a render plan and an acceleration structure;
 * a scene that does not must leave the Scene empty and a message
 * "fuzz.in:line:col: what is wrong". Mesh files that a scene names are read
 * from the working directory, as the command line would.
 */
#include "fuzz.h"

#include "lancer/accel.h"
#include "lancer/plan.h"
#include "lancer/scene.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    Scene s;
    char err[1024] = "";
    if (scene_parse(FUZZ_NAME, (const char *)data, size, &s, err, sizeof err) != 0) {
        fuzz_check_message(err, 2, 2);
        fuzz_require(!s.prims && !s.materials && !s.lights && !s.inputs && !s.nprims && !s.nmaterials &&
                         !s.nlights && !s.ninputs,
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
        accel_free(a);
        plan_free(&p);
    }
    scene_free(&s);
    return 0;
}
