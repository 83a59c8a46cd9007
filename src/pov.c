/*
 * pov.c - POV-Ray 3.7 export (see pov.h).
 */
#include "lancer/pov.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "dvec.h"

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

/* The same for a double: up to 17 digits, so that a scene kept in double
 * (Scene.place) is written as lancer holds it. */
static void numd(FILE *f, double v)
{
    char buf[40];
    for (int digits = 1; digits <= 17; digits++) {
        snprintf(buf, sizeof buf, "%.*g", digits, v);
        int plain = !strchr(buf, 'e') || fabs(v) >= 1e6 || fabs(v) < 1e-4;
        if (strtod(buf, NULL) == v && plain)
            break;
    }
    fputs(buf, f);
}

static void dvec(FILE *f, const double v[3])
{
    fputc('<', f);
    numd(f, v[0]);
    fputs(", ", f);
    numd(f, v[1]);
    fputs(", ", f);
    numd(f, v[2]);
    fputc('>', f);
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

/* "<a>, <b>, <c>" */
static void vec3s(FILE *f, Vec3 a, Vec3 b, Vec3 c)
{
    vec(f, a);
    fputs(", ", f);
    vec(f, b);
    fputs(", ", f);
    vec(f, c);
}

/* The same, from doubles. */
static void dvec3s(FILE *f, const Place *q)
{
    dvec(f, q->p[0]);
    fputs(", ", f);
    dvec(f, q->p[1]);
    fputs(", ", f);
    dvec(f, q->p[2]);
}

/* A point of the scene: in double where it has one, else its float. */
static void point(FILE *f, const Scene *s, const double at[3], Vec3 v)
{
    if (s->placed)
        dvec(f, at);
    else
        vec(f, v);
}

/* POV-Ray's matrix: the images of the axes as rows, then the
 * translation; m holds the rows of M, then t. */
static void matrix(FILE *f, const double m[12])
{
    fputs("matrix <", f);
    for (int i = 0; i < 4; i++)
        for (int j = 0; j < 3; j++) {
            numd(f, i < 3 ? m[3 * j + i] : m[9 + j]);
            fputs(i == 3 && j == 2 ? ">" : j == 2 ? ",  " : ", ", f);
        }
}

/* k (with its leading blank or line break), a space, the value */
static void key(FILE *f, const char *k, float v)
{
    fprintf(f, "%s ", k);
    num(f, v);
}

static void camera(FILE *f, const Scene *s, int width, int height)
{
    const CameraSpec *c = &s->camera;
    double a = (double)width / (double)height;
    double t = tan((double)c->fovy * POV_PI / 360.0);
    double angle = 2.0 * atan(a * t) * 180.0 / POV_PI;
    /* look_at last: POV-Ray builds the camera basis from sky at that point. */
    fprintf(f, "camera {\n  perspective\n  location ");
    point(f, s, c->eye_at, c->eye);
    fprintf(f, "\n  sky ");
    vec(f, c->up);
    fprintf(f, "\n  up y\n  right -x*%.17g\n  angle %.17g\n  look_at ", a, angle);
    point(f, s, c->target_at, c->target);
    fprintf(f, "\n}\n\n");
}

static void light(FILE *f, const Scene *s, const Light *l)
{
    fprintf(f, "light_source {\n  ");
    point(f, s, l->at, l->pos);
    fprintf(f, "\n  color rgb ");
    vec(f, l->color);
    if (l->fade_power > 0.0f) {
        key(f, "\n  fade_distance", l->fade_distance);
        key(f, "\n  fade_power", l->fade_power);
    }
    if (l->area_n1 * l->area_n2 > 1) {
        /* No jitter and no adaptive: POV-Ray's default (adaptive 100) always
         * subdivides fully, which is what lancer's weights reproduce. */
        fprintf(f, "\n  area_light ");
        vec(f, l->area_u);
        fprintf(f, ", ");
        vec(f, l->area_v);
        fprintf(f, ", %d, %d", l->area_n1, l->area_n2);
        if (l->adaptive > 0)
            fprintf(f, "\n  adaptive %d", l->adaptive - 1);
    }
    if (l->shadowless)
        fprintf(f, "\n  shadowless");
    fprintf(f, "\n}\n");
}

/* Materials become declared textures; the M_ prefix keeps names such as
 * "red" or "floor" clear of POV-Ray's keywords. */
static void material(FILE *f, const Material *m)
{
    fprintf(f, "#declare M_%s = texture {\n  pigment { color rgbft <", m->name);
    num(f, m->color.x);
    fputs(", ", f);
    num(f, m->color.y);
    fputs(", ", f);
    num(f, m->color.z);
    fputs(", ", f);
    num(f, m->filter);
    fputs(", ", f);
    num(f, m->transmit);
    fputc('>', f);
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

/* Room for one patch's tessellation into n x n triangles. */
typedef struct {
    int n;
    Vec3 *pts, *nrm;
    int (*faces)[3];
} PnGrid;

/* The face normal (p1 - p0) x (p2 - p0) of triangle q, in double. */
static void face_normal(const Place *q, double n[3])
{
    double u[3], w[3];
    for (int k = 0; k < 3; k++) {
        u[k] = q->p[1][k] - q->p[0][k];
        w[k] = q->p[2][k] - q->p[0][k];
    }
    d3_cross(n, u, w);
}

/* 1 when the vertex normals of triangle q all lie on one side of its
 * face, computed in double. */
static int normals_one_side(const Place *q, const Triangle *t)
{
    double n[3], s[3];
    face_normal(q, n);
    const Vec3 v[3] = {t->na, t->nb, t->nc};
    for (int k = 0; k < 3; k++)
        s[k] = n[0] * v[k].x + n[1] * v[k].y + n[2] * v[k].z;
    return (s[0] > 0.0 && s[1] > 0.0 && s[2] > 0.0) || (s[0] < 0.0 && s[1] < 0.0 && s[2] < 0.0);
}

/* The normals n[0 .. 2] of a smooth triangle that goes out as a mesh2 (its
 * normals not on one side of its face). POV-Ray's mesh shades a face flat,
 * with its geometric normal, when its three normals lie within 10^-5 of
 * each other (|N1 - N2|^2 <= 10^-10, "Check for equal normals" in
 * parse.cpp), and lancer shades by them: three such normals, which lie in
 * the face's plane, go out as one unit normal, and two of them moved apart
 * by 4·10^-5 along the face's normal, past POV-Ray's test and far below a
 * picture's tolerance. */
static void part_normals(const Place *q, Vec3 n[3])
{
    double a[3], d1 = 0.0, d2 = 0.0;
    for (int k = 0; k < 3; k++) {
        a[k] = vec_comp(n[0], k);
        d1 += (vec_comp(n[1], k) - a[k]) * (vec_comp(n[1], k) - a[k]);
        d2 += (vec_comp(n[2], k) - a[k]) * (vec_comp(n[2], k) - a[k]);
    }
    const double len = sqrt(d3_dot(a, a));
    if (d1 > 1e-10 || d2 > 1e-10 || !(len > 0.0))
        return;
    double g[3];
    face_normal(q, g);
    const double glen = sqrt(d3_dot(g, g));
    if (!(glen > 0.0))
        return;
    for (int i = 0; i < 3; i++) {
        const double side = i == 0 ? 0.0 : i == 1 ? 4e-5 : -4e-5;
        n[i] = vec3((float)(a[0] / len + side * g[0] / glen), (float)(a[1] / len + side * g[1] / glen),
                    (float)(a[2] / len + side * g[2] / glen));
    }
}

/* A PN patch as a mesh2 of n segments per edge: the patch's points on the
 * (u, v) grid of step 1/n, with its shading normals, in the triangles'
 * order of (P1, P2, P3). Its error falls as 1/n^2 (docs/parity.md). */
static void pn_mesh2(FILE *f, const PnPatch *pn, const PnGrid *g)
{
    int n = g->n, nv = pn_grid_points(n);
    Vec3 *pts = g->pts, *nrm = g->nrm;
    int(*faces)[3] = g->faces;
    pn_tessellate(pn, n, pts, nrm, faces);
    fprintf(f, "mesh2 {\n  vertex_vectors { %d", nv);
    for (int k = 0; k < nv; k++) {
        fputs(", ", f);
        vec(f, pts[k]);
    }
    fprintf(f, " }\n  normal_vectors { %d", nv);
    for (int k = 0; k < nv; k++) {
        fputs(", ", f);
        vec(f, nrm[k]);
    }
    fprintf(f, " }\n  face_indices { %d", n * n);
    for (int k = 0; k < n * n; k++)
        fprintf(f, ", <%d, %d, %d>", faces[k][0], faces[k][1], faces[k][2]);
    fprintf(f, " }\n ");
}

/* 1 when POV-Ray's twin of a primitive of material m needs an interior:
 * light passes, or its ior counts where a ray starts in it. */
static int has_interior(const Material *m) { return m->filter + m->transmit > 0.0f || m->ior != 1.0f; }

static void interior(FILE *f, const Material *m)
{
    key(f, " interior { ior", m->ior);
    fputs(" }", f);
}

/* Every object as lancer holds it: a transform that gave an object of the
 * same kind is already applied to it (an oriented box is POV-Ray's box
 * with a matrix), and an ellipsoid is the unit sphere with its matrix.
 * Coordinates come from the scene's doubles where it has them.
 * Its interior comes with it unless `shared` (a mesh's, which its union
 * holds). */
static void prim(FILE *f, const Scene *s, const Prim *p, const PnGrid *grid, int shared)
{
    const Triangle *t = &p->g.tri;
    Place q = scene_place(s, (int)(p - s->prims));
    switch (p->kind) {
    case PRIM_SPHERE:
        fprintf(f, "sphere { ");
        dvec(f, q.p[0]);
        fprintf(f, ", ");
        numd(f, q.p[1][0]);
        break;
    case PRIM_ELLIPSOID:
        fprintf(f, "sphere { <0, 0, 0>, 1\n  ");
        matrix(f, p->g.ell.e->m);
        fprintf(f, "\n ");
        break;
    case PRIM_PLANE: {
        /* POV-Ray's plane is the solid n.p < d, and a camera inside it
         * changes how refraction starts; lancer's plane is a surface only.
         * Facing n towards the camera keeps the camera outside, and draws
         * the same surface. */
        double *n = q.p[0], d = q.p[1][0], e[3];
        for (int k = 0; k < 3; k++)
            e[k] = s->placed ? s->camera.eye_at[k] : vec_comp(s->camera.eye, k);
        if (d3_dot(n, e) < d) {
            for (int k = 0; k < 3; k++)
                n[k] = -n[k];
            d = -d;
        }
        fprintf(f, "plane { ");
        dvec(f, n);
        fprintf(f, ", ");
        numd(f, d);
        break;
    }
    case PRIM_TRIANGLE:
        fprintf(f, "triangle { ");
        dvec3s(f, &q);
        break;
    case PRIM_SMOOTH_TRIANGLE: {
        if (normals_one_side(&q, t)) {
            /* A smooth_triangle holds its vertices in double, and takes
             * its normals as they are; POV-Ray's mesh shades a face whose
             * normals are all one flat, and holds its vertices in float. */
            fprintf(f, "smooth_triangle { ");
            dvec(f, q.p[0]);
            fputs(", ", f);
            vec(f, t->na);
            fputs(", ", f);
            dvec(f, q.p[1]);
            fputs(", ", f);
            vec(f, t->nb);
            fputs(", ", f);
            dvec(f, q.p[2]);
            fputs(", ", f);
            vec(f, t->nc);
            break;
        }
        /* Else as a one-face mesh2: POV-Ray silently drops a
         * smooth_triangle whose vertex normals are not all on one side of
         * its face. Its float vertices go out relative to the first, which
         * a translate in double puts back. */
        double o[3] = {q.p[0][0], q.p[0][1], q.p[0][2]};
        fprintf(f, "mesh2 {\n  vertex_vectors { 3");
        for (int k = 0; k < 3; k++) {
            double v[3] = {q.p[k][0] - o[0], q.p[k][1] - o[1], q.p[k][2] - o[2]};
            fputs(", ", f);
            dvec(f, v);
        }
        fprintf(f, " }\n  normal_vectors { 3, ");
        Vec3 nv[3] = {t->na, t->nb, t->nc};
        part_normals(&q, nv);
        vec3s(f, nv[0], nv[1], nv[2]);
        fprintf(f, " }\n  face_indices { 1, <0, 1, 2> }\n  normal_indices { 1, <0, 1, 2> }\n  translate ");
        dvec(f, o);
        fputs("\n ", f);
        break;
    }
    case PRIM_BOX:
        fprintf(f, "box { ");
        dvec(f, q.p[0]);
        fprintf(f, ", ");
        dvec(f, q.p[1]);
        break;
    case PRIM_OBOX: {
        /* The unit cube mapped by x*u + y*v + z*w + c. */
        const OBox *b = &p->g.obox;
        double m[12];
        for (int k = 0; k < 3; k++) {
            m[3 * k] = vec_comp(b->u, k);
            m[3 * k + 1] = vec_comp(b->v, k);
            m[3 * k + 2] = vec_comp(b->w, k);
            m[9 + k] = q.p[0][k];
        }
        fprintf(f, "box { <-1, -1, -1>, <1, 1, 1>\n  ");
        matrix(f, m);
        fprintf(f, "\n ");
        break;
    }
    case PRIM_PN: { /* its net from its vertices relative to the first, as above */
        const PnPatch *pa = p->g.pn.patch;
        Vec3 v[3], n[3] = {pa->n[0], pa->n[1], pa->n[2]};
        for (int k = 0; k < 3; k++)
            v[k] = vec3((float)(q.p[k][0] - q.p[0][0]), (float)(q.p[k][1] - q.p[0][1]), (float)(q.p[k][2] - q.p[0][2]));
        PnPatch local;
        pn_patch_init(&local, v, n);
        pn_mesh2(f, &local, grid);
        fputs(" translate ", f);
        dvec(f, q.p[0]);
        fputs("\n ", f);
        break;
    }
    }
    const Material *m = &s->materials[p->material];
    fprintf(f, " texture { M_%s }", m->name);
    if (has_interior(m) && !shared)
        interior(f, m);
    fputs(" }\n", f);
}

/* The primitives from i on: one, or a mesh whose material needs an
 * interior as one union of its pieces with that one interior, so that a
 * ray entering by one piece leaves by another, as in lancer (prim_solid)
 * and as in POV-Ray's own mesh. Returns the primitives written. */
static int object(FILE *f, const Scene *s, int i, const PnGrid *grid)
{
    const Prim *p = &s->prims[i];
    const int solid = prim_solid(p);
    const Material *m = &s->materials[p->material];
    if (!solid || !has_interior(m)) {
        prim(f, s, p, grid, 0);
        return 1;
    }
    int n = 0;
    fputs("union {\n", f);
    for (; i + n < s->nprims && prim_solid(&s->prims[i + n]) == solid; n++) {
        fputs("  ", f);
        prim(f, s, &s->prims[i + n], grid, 1);
    }
    interior(f, m);
    fputs("\n}\n", f);
    return n;
}

int pov_export(const Scene *s, int width, int height, int pn_segments, FILE *f)
{
    int w = width ? width : s->image.width, h = height ? height : s->image.height;
    /* For k x k anti-aliasing the reference is a plain render at k times the
     * size, averaged in k x k blocks (lancer diff --downsample k): POV-Ray's
     * own +A filter is not a box filter. */
    int k = s->image.spp;
    fprintf(f, "// Exported by lancer: the POV-Ray 3.7 twin of a lancer scene.\n"
               "// lancer-reference: width %d height %d spp %d\n"
               "// Render: povray -D -V -GA +GF +GW -A +W%d +H%d +FE +Oout.exr +Ithis.pov\n",
            w, h, k, k * w, k * h);
    if (k > 1)
        fprintf(f, "// then average out.exr in %d x %d blocks: lancer diff lancer.exr out.exr --downsample %d\n", k, k,
                k);
    fprintf(f, "\n");
    fprintf(f, "#version 3.7;\n\nglobal_settings {\n  assumed_gamma 1.0\n  max_trace_level %d\n", s->image.max_depth);
    key(f, "  adc_bailout", s->image.adc_bailout);
    fprintf(f, "\n  ambient_light rgb <1, 1, 1>\n}\n\n");
    fprintf(f, "background { color rgb ");
    vec(f, s->background);
    fprintf(f, " }\n\n");
    camera(f, s, w, h);
    for (int i = 0; i < s->nlights; i++)
        light(f, s, &s->lights[i]);
    fprintf(f, "\n");
    for (int i = 0; i < s->nmaterials; i++)
        material(f, &s->materials[i]);
    fprintf(f, "\n");
    PnGrid g = {pn_segments > 0 ? pn_segments : POV_PN_SEGMENTS, NULL, NULL, NULL};
    if (s->npatches > 0) {
        g.pts = malloc(sizeof(Vec3) * (size_t)pn_grid_points(g.n));
        g.nrm = malloc(sizeof(Vec3) * (size_t)pn_grid_points(g.n));
        g.faces = malloc(sizeof(int[3]) * (size_t)g.n * (size_t)g.n);
    }
    int rc = 0;
    if (s->npatches > 0 && (!g.pts || !g.nrm || !g.faces))
        rc = -1;
    for (int i = 0; rc == 0 && i < s->nprims;)
        i += object(f, s, i, &g);
    free(g.pts);
    free(g.nrm);
    free(g.faces);
    return rc != 0 || ferror(f) ? -1 : 0;
}
