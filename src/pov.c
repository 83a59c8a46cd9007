/*
 * pov.c - POV-Ray 3.7 export (see pov.h).
 */
#include "lancer/pov.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define POV_PI 3.14159265358979323846

/* Writes the shortest decimal that reads back as exactly v: 0.55, not
 * 0.550000012. */
static void num(FILE *f, float v)
{
    char buf[32];
    for (int digits = 1; digits <= 9; digits++) {
        snprintf(buf, sizeof buf, "%.*g", digits, (double)v);
        /* exponents only where plain digits would be long */
        int plain = !strchr(buf, 'e') || fabsf(v) >= 1e6f || fabsf(v) < 1e-4f;
        if (strtof(buf, NULL) == v && plain)
            break;
    }
    fputs(buf, f);
}

static void vec(FILE *f, Vec3 v)
{
    fputc('<', f);
    num(f, v.x);
    fputs(", ", f);
    num(f, v.y);
    fputs(", ", f);
    num(f, v.z);
    fputc('>', f);
}

/* k (with its leading blank or line break), a space, the value */
static void key(FILE *f, const char *k, float v)
{
    fprintf(f, "%s ", k);
    num(f, v);
}

static void camera(FILE *f, const Scene *s)
{
    const CameraSpec *c = &s->camera;
    double a = (double)s->width / (double)s->height;
    double t = tan((double)c->fovy * POV_PI / 360.0);
    double angle = 2.0 * atan(a * t) * 180.0 / POV_PI;
    /* look_at last: POV-Ray builds the camera basis from sky at that point. */
    fprintf(f, "camera {\n  perspective\n  location ");
    vec(f, c->eye);
    fprintf(f, "\n  sky ");
    vec(f, c->up);
    fprintf(f, "\n  up y\n  right -x*%.17g\n  angle %.17g\n  look_at ", a, angle);
    vec(f, c->target);
    fprintf(f, "\n}\n\n");
}

static void light(FILE *f, const Light *l)
{
    fprintf(f, "light_source {\n  ");
    vec(f, l->pos);
    fprintf(f, "\n  color rgb ");
    vec(f, l->color);
    if (l->fade_power > 0.0f) {
        key(f, "\n  fade_distance", l->fade_distance);
        key(f, "\n  fade_power", l->fade_power);
    }
    if (l->shadowless)
        fprintf(f, "\n  shadowless");
    fprintf(f, "\n}\n");
}

/* Materials become declared textures; the M_ prefix keeps names such as
 * "red" or "floor" clear of POV-Ray's keywords. */
static void material(FILE *f, const Material *m)
{
    fprintf(f, "#declare M_%s = texture {\n  pigment { color rgb ", m->name);
    vec(f, m->color);
    fprintf(f, " }\n  finish {\n   ");
    key(f, " ambient", m->ambient);
    key(f, " diffuse", m->diffuse);
    fprintf(f, "\n   ");
    key(f, " phong", m->phong);
    key(f, " phong_size", m->phong_size);
    fprintf(f, "\n   ");
    key(f, " specular", m->specular);
    key(f, " roughness", m->roughness);
    fprintf(f, "\n    reflection { ");
    num(f, m->reflection);
    fprintf(f, " }\n  }\n}\n");
}

static void prim(FILE *f, const Scene *s, const Prim *p)
{
    const Triangle *t = &p->g.tri;
    switch (p->kind) {
    case PRIM_SPHERE:
        fprintf(f, "sphere { ");
        vec(f, p->g.sphere.c);
        fprintf(f, ", ");
        num(f, p->g.sphere.r);
        break;
    case PRIM_PLANE:
        fprintf(f, "plane { ");
        vec(f, p->g.plane.n);
        fprintf(f, ", ");
        num(f, p->g.plane.d);
        break;
    case PRIM_TRIANGLE:
        fprintf(f, "triangle { ");
        vec(f, t->a);
        fprintf(f, ", ");
        vec(f, t->b);
        fprintf(f, ", ");
        vec(f, t->c);
        break;
    case PRIM_SMOOTH_TRIANGLE:
        fprintf(f, "smooth_triangle {\n  ");
        vec(f, t->a);
        fprintf(f, ", ");
        vec(f, t->na);
        fprintf(f, ",\n  ");
        vec(f, t->b);
        fprintf(f, ", ");
        vec(f, t->nb);
        fprintf(f, ",\n  ");
        vec(f, t->c);
        fprintf(f, ", ");
        vec(f, t->nc);
        fprintf(f, "\n ");
        break;
    case PRIM_BOX:
        fprintf(f, "box { ");
        vec(f, p->g.box.lo);
        fprintf(f, ", ");
        vec(f, p->g.box.hi);
        break;
    case PRIM_OBOX: {
        /* The unit cube mapped by x*u + y*v + z*w + c (POV-Ray's matrix takes
         * the images of the axes as rows, then the translation). */
        const OBox *b = &p->g.obox;
        const Vec3 rows[4] = {b->u, b->v, b->w, b->c};
        fprintf(f, "box { <-1, -1, -1>, <1, 1, 1>\n  matrix <");
        for (int i = 0; i < 4; i++) {
            num(f, rows[i].x);
            fputs(", ", f);
            num(f, rows[i].y);
            fputs(", ", f);
            num(f, rows[i].z);
            fputs(i < 3 ? ",  " : ">\n ", f);
        }
        break;
    }
    }
    fprintf(f, " texture { M_%s } }\n", s->materials[p->material].name);
}

int pov_export(const Scene *s, FILE *f)
{
    /* For k x k anti-aliasing the reference is a plain render at k times the
     * size, averaged in k x k blocks (lancer diff --downsample k): POV-Ray's
     * own +A filter is not a box filter. */
    int k = s->spp;
    fprintf(f, "// Exported by lancer: the POV-Ray 3.7 twin of a lancer scene.\n"
               "// lancer-reference: width %d height %d spp %d\n"
               "// Render: povray -D -V -GA +GF +GW -A +W%d +H%d +FE +Oout.exr +Ithis.pov\n",
            s->width, s->height, k, k * s->width, k * s->height);
    if (k > 1)
        fprintf(f, "// then average out.exr in %d x %d blocks: lancer diff lancer.exr out.exr --downsample %d\n", k, k,
                k);
    fprintf(f, "\n");
    fprintf(f, "#version 3.7;\n\nglobal_settings {\n  assumed_gamma 1.0\n  max_trace_level %d\n  adc_bailout 0\n"
               "  ambient_light rgb <1, 1, 1>\n}\n\n",
            s->max_depth);
    fprintf(f, "background { color rgb ");
    vec(f, s->background);
    fprintf(f, " }\n\n");
    camera(f, s);
    for (int i = 0; i < s->nlights; i++)
        light(f, &s->lights[i]);
    fprintf(f, "\n");
    for (int i = 0; i < s->nmaterials; i++)
        material(f, &s->materials[i]);
    fprintf(f, "\n");
    for (int i = 0; i < s->nprims; i++)
        prim(f, s, &s->prims[i]);
    return ferror(f) ? -1 : 0;
}
