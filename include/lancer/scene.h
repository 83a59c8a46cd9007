/*
 * scene.h - the scene: the world as plain arrays of materials, lights and
 * primitives, with the camera; and the parser of lancer's scene format (the
 * format is documented in README.md).
 *
 *     Scene s;
 *     char err[512];
 *     if (scene_load("scenes/default.scn", &s, err, sizeof err) != 0) {
 *         fprintf(stderr, "%s\n", err);   "file:line:col: what is wrong"
 *         return 1;
 *     }
 *     ... s.prims[i], s.materials[s.prims[i].material] ...
 *     scene_free(&s);
 *
 * A loaded scene has been validated: every number is finite, every normal and
 * axis has length, every material exists. On error nothing is returned (the
 * Scene is left empty and scene_free is still safe).
 *
 * How to render the scene is not the Scene's: the file's image block is
 * kept as it was read (SceneImage), and the render plan (plan.h) resolves
 * it against the command line and derives every render decision.
 */
#ifndef LANCER_SCENE_H
#define LANCER_SCENE_H

#include <stddef.h>

#include "lancer/limits.h"
#include "lancer/mesh.h"
#include "lancer/pntri.h"
#include "lancer/prim.h"

/* Buffers for a name and a path, with their ends (limits.h). */
#define SCENE_NAME_MAX (LIMIT_NAME_CHARS + 1)
#define SCENE_PATH_MAX (LIMIT_PATH_CHARS + 1)

/* POV-Ray's classic finish with a plain pigment (docs/povray-rules.md),
 * plus POV-Ray's filter and transmit and an index of refraction. */
typedef struct {
    char name[SCENE_NAME_MAX];
    Vec3 color;
    float ambient, diffuse;
    float phong, phong_size;
    float specular, roughness;
    float reflection;
    float filter, transmit; /* light let through: tinted by color, and plain */
    float ior;              /* of the object's interior; 1 bends nothing */
} Material;

/* A point light, or an area light: a grid of area_n1 x area_n2 points
 * spanning area_u and area_v (full edge vectors) centred on pos. */
typedef struct {
    Vec3 pos, color;
    double at[3]; /* pos in double, as placed (Scene.place says why) */
    float fade_distance, fade_power; /* fade_power 0: no attenuation */
    int shadowless;
    Vec3 area_u, area_v;
    int area_n1, area_n2; /* 1 x 1: a point light */
    int adaptive;         /* 1 + POV-Ray's adaptive level; 0 (a zeroed light's, POV-Ray's
                           * default): the full grid */
} Light;

typedef struct {
    Vec3 eye, target, up;
    float fovy;                       /* vertical field of view, degrees */
    double eye_at[3], target_at[3];   /* eye and target in double, as placed */
} CameraSpec;

/* A key of the camera path: the camera at a frame. Between keys, eye,
 * target and fov follow Catmull-Rom splines over the frame numbers. */
typedef struct {
    int frame;
    double eye[3], target[3];
    double fov; /* degrees */
} CameraKey;

/* Where a primitive stands, in double, as the scene file placed it and the
 * moves since (scene_transform) took it: its float coordinates are these,
 * rounded. Per kind:
 *   sphere: p[0] the centre, p[1][0] the radius;
 *   plane: p[0] the unit normal, p[1][0] the offset;
 *   triangle, smooth triangle, PN triangle: p[0..2] the vertices;
 *   box: p[0] min, p[1] max;
 *   oriented box: p[0] the centre (its axes are directions: float is enough);
 *   ellipsoid: unused (its Ellipsoid is in double). */
typedef struct {
    double p[3][3];
} Place;

/* The file's image block, or its defaults: what the plan starts from. */
typedef struct {
    int width, height;
    int max_depth; /* POV-Ray's max_trace_level: the camera ray is level 1 */
    int spp;       /* spp x spp regular samples per pixel, box-filtered */
    int classic;   /* use the classic intersection routines, not the robust ones */
    int pn_mode;   /* PnMode of the PN patches that set none */
    float adc_bailout; /* POV-Ray's: a secondary ray of weight below it is not traced */
    float aa_threshold; /* adaptive anti-aliasing (render.h); 0: the regular grid everywhere */
} SceneImage;

/* lancer's default adc_bailout (README.md says why). */
#define SCENE_ADC_BAILOUT 0x1p-12f

typedef struct {
    SceneImage image;
    Vec3 background; /* what a ray that hits nothing sees */
    CameraSpec camera;
    CameraKey *keys; /* the camera path, by increasing frame (keyframe blocks) */
    int nkeys;
    Material *materials;
    int nmaterials;
    Light *lights;
    int nlights;
    Prim *prims;
    int nprims;
    PnPatch *patches; /* the PN patches, which PRIM_PN primitives point into */
    int npatches;
    Ellipsoid *ellipsoids; /* the ellipsoids, which PRIM_ELLIPSOID primitives point into */
    int nellipsoids;
    int (*ellipsoid_at)[2]; /* per ellipsoid, its sphere statement's line and column (NULL: built in code) */
    /* The coordinates in double: a scene far from the origin is kept as
     * written until the render plan has moved it next to the camera, and
     * only then rounded to float. place is NULL or parallel to prims;
     * placed says that the camera's and lights' doubles are set. A scene
     * built in code, with floats only, gets both from its floats when it
     * is first moved. */
    Place *place;
    int placed;
    int degenerate; /* mesh triangles dropped for having no area */
    int nmeshes;    /* meshes added: the last one's primitives have solid nmeshes (Prim.solid) */
    int vanished;   /* boxes and triangles that scene_transform dropped */
    int *origin;    /* NULL, or since a drop, each primitive's number in the scene as written */
    char **inputs;  /* the files read: each mesh, then the scene file (scene_load) */
    unsigned char (*input_sha256)[SHA256_BYTES]; /* each input's bytes' digest */
    int ninputs;
} Scene;

/* Reads and parses a scene file. Returns 0, or -1 with "path:line:col:
 * message" in err. Paths in messages are given as passed. */
int scene_load(const char *path, Scene *s, char *err, size_t errlen);

/* Parses scene text held in memory; `name` stands for the file in messages. */
int scene_parse(const char *name, const char *text, size_t len, Scene *s, char *err, size_t errlen);

/* Appends the mesh's triangles to the scene with material `material`, each
 * point p mapped to M p + t in double, where xf holds the rows of M then t
 * (12 doubles; NULL for none); normals are mapped by the inverse transpose.
 * smooth: smooth_triangles with the mesh's vertex normals (m->n must be
 * set), else flat triangles. Triangles that the transform flattens are
 * dropped and counted in *dropped. Returns 0, or -1 when memory runs out. */
int scene_add_mesh(Scene *s, const Mesh *m, int material, int smooth, const double *xf, int *dropped);

/* Appends the mesh's triangles as PN patches (pntri.h) with material
 * `material` and PnMode `mode`, each from the mesh's vertex normals (m->n
 * must be set), mapped by xf as scene_add_mesh maps them. Returns 0, or -1
 * when memory runs out. */
int scene_add_pn_mesh(Scene *s, const Mesh *m, int material, int mode, const double *xf, int *dropped);

/* A new scene of the mesh's flat triangles and one default material (the
 * benchmarks' scene). Returns 0, or -1 when memory runs out (the scene is
 * then empty). */
int scene_from_mesh(Scene *s, const Mesh *m);

/* The same with the mesh's triangles as PN patches in PnMode `mode`, from
 * its vertex normals (m->n must be set). */
int scene_from_pn_mesh(Scene *s, const Mesh *m, int mode);

/* Splits every triangle in two across its longest edge: the corner
 * opposite it is joined to the edge's midpoint, and both halves keep the
 * primitive's kind, material and normals. The surface stays the same, and
 * the triangle count doubles (the BVH's build series grows meshes so).
 * Returns 0, or -1 when memory runs out or the count would pass INT32_MAX
 * (the scene is then unchanged). */
int scene_split_triangles(Scene *s);

/* Moves the whole scene, camera and lights included, by p -> p*scale +
 * offset (scale > 0), in double, then rounds it to float again. Shading
 * does not change: fade distances scale too, and every angle stays. The
 * render plan moves scenes so (plan.h). A box or triangle that the move
 * leaves with no extent in double (a small one far from the new origin)
 * can be hit by no ray: it is dropped, counted in `vanished` (`origin` then
 * numbers the primitives left as the scene wrote them), and a box
 * flat along one axis only is kept one double thick there. Returns 0, or
 * -1 when the moved scene no longer passes scene_validate: a coordinate
 * overflowed, or a shape or the camera degenerated in float. */
int scene_transform(Scene *s, double scale, const double offset[3]);

/* Primitive i's Place: its doubles, or for a scene built in code its
 * floats widened (an ellipsoid has none: its Ellipsoid is in double). */
Place scene_place(const Scene *s, int i);

/* Checks what a loaded scene promises (the top of this file): settings in
 * range, every number finite, the camera, every material, light and
 * primitive well formed, every material index valid. Returns 0, or -1 with
 * what is wrong in err. */
int scene_validate(const Scene *s, char *err, size_t errlen);

/* The samples of the scene's lights, all together: area_n1 x area_n2 each
 * (a point light's 1), at most LIMIT_LIGHT_SAMPLES in a valid scene. */
long long scene_light_samples(const Scene *s);

/* Puts the camera where the camera path has it at `frame` (scene_camera
 * takes the camera block's up): on a key, the key's camera exactly;
 * between keys, the Catmull-Rom splines through them, with the frame
 * numbers as knots and one-sided tangents at the ends; before the first
 * key and after the last, that key's. Call it before plan_build moves the
 * scene. Returns 0, or -1 with a message in err: no camera path, or a
 * camera that the path degenerates at this frame (eye on target, up along
 * the view, fov out of range). */
int scene_camera_frame(Scene *s, int frame, char *err, size_t errlen);

/* The scene's content hash, in hex: the SHA-256 of its inputs' digests in
 * order, so of the scene file and every mesh it loads, as they were read.
 * Two scenes with the same hash render the same picture under the same
 * settings; a tile of a stale scene has another hash. */
void scene_content_hash(const Scene *s, char hex[SHA256_HEX]);

void scene_free(Scene *s);

#endif
