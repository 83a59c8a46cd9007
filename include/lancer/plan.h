/*
 * plan.h - the render plan: how a scene is to be rendered, decided once,
 * before the first ray.
 *
 *     Scene s;                                 ... scene_load ...
 *     PlanOptions o = plan_options();          the scene's own settings
 *     o.threads = 4;                           ... and the command line's
 *     RenderPlan p;
 *     char err[256];
 *     if (plan_build(&p, &s, &o, err, sizeof err) != 0) ... err ...
 *     Accel *a = accel_build(&s, p.variant, p.threads);
 *     render_image(&p, a, NULL, &img, &stats);
 *     plan_free(&p);
 *
 * The Scene is the world; the plan is everything else the renderer reads:
 *
 * - the settings: the scene file's image block (SceneImage), with each
 *   option that is set in PlanOptions taking its place;
 * - the coordinates: plan_build moves the scene by the options' scale and
 *   translation, then, for the robust variant, so that the eye sits at the
 *   origin (camera-relative rendering; the offset is kept in the plan)
 *   unless the options ask for world coordinates;
 * - the decisions derived from the scene: which solids the camera is
 *   inside, whether any material lets light through or reflects, and how
 *   each light's shadows are traced.
 *
 * The plan points into the scene, which must outlive it and must not
 * change while it is used. shade.c and render.c read only the plan (and
 * through it the scene) and the Accel.
 */
#ifndef LANCER_PLAN_H
#define LANCER_PLAN_H

#include <stddef.h>

#include "lancer/limits.h"
#include "lancer/scene.h"

/* What the caller asks for; a zero (or NULL) field keeps the scene's own. */
typedef struct {
    int width, height; /* pixels, 1 to LIMIT_IMAGE_SIDE */
    int spp;           /* 1 to LIMIT_SPP */
    int max_depth;     /* 1 to LIMIT_DEPTH */
    int classic;       /* 1: the classic routines, whatever the scene says */
    int pn_mode;       /* 1 + PnMode: every PN patch in that mode, whatever the scene says */
    int threads;       /* render and build threads; 0 means 1 */
    int world;         /* 1: keep the scene's coordinates, no camera-relative move
                        * (for callers that trace rays of their own in them) */
    int move;          /* 1: move the scene by p -> p*scale + translate first */
    int accel;         /* 0: the plan's choice; 1: the BVH; 2: a plain loop */
    int full;          /* 1: skip nothing the plan could skip (--no-plan): the same
                        * picture, bit for bit, by all the work */
    double adc_bailout; /* 0 to 1; negative: the scene's */
    int area_samples;  /* every area light's grid, N x N (1 to LIMIT_AREA_SAMPLES) */
    double aa_threshold; /* adaptive anti-aliasing's threshold; negative: the scene's */
    int area_adaptive; /* 1 + every area light's adaptive level (Light.adaptive) */
    double scale;      /* > 0 */
    double translate[3];
    int region;        /* 1: render only columns rx0..rx1-1 of rows ry0..ry1-1 */
    int rx0, rx1, ry0, ry1;
} PlanOptions;


/* The ordered list of primitives a ray is inside, innermost last. */
typedef struct {
    int n;
    int prim[LIMIT_INTERIORS];
} Interiors;

/* How the shadows of one light are found. */
typedef enum {
    PLAN_SHADOW_NONE,     /* a shadowless light: no shadow rays */
    PLAN_SHADOW_CLEAR,    /* nothing can stand between it and any surface: no shadow rays */
    PLAN_SHADOW_OPAQUE,   /* any hit blocks it: any-hit queries, in packets for a point light */
    PLAN_SHADOW_FILTERED  /* transparent surfaces filter it: each surface on the way is found */
} PlanShadow;

/* Scenes of at most this many primitives are searched for lights that
 * nothing can shadow (each pair of primitives is tested). */
#define PLAN_CLEAR_PRIMS 256

/* Scenes of at most this many primitives are traced by a plain loop over
 * them, without a BVH: faster below it (docs/performance.md measures the
 * crossover). */
#define PLAN_LOOP_PRIMS 3

/* The flattest ellipsoid traced: its thinnest half-axis over its distance
 * from the eye plus its largest half-axis. Flatter, the robust routine
 * cannot certify its hits in double and would lose them (docs/robustness.md
 * measures where). */
#define PLAN_FLATTEST 0x1p-36

/* An area light's samples, sample (i, j) at j * area_n1 + i. */
typedef struct {
    Vec3 *point;   /* POV-Ray's grid, corners included */
    float *weight; /* its weight in the plain (not adaptive) average, w1[i] * w2[j] of plan_area_weights */
    int *first;    /* the samples an adaptive light traces at every point, ascending (plan_area_first) */
    int nfirst;
} PlanArea;

typedef struct {
    const Scene *scene; /* the world, in the plan's coordinates */
    int width, height, spp, max_depth, threads;
    int x0, x1, y0, y1;    /* the region rendered, half-open: the whole image unless asked */
    PrimVariant variant;
    int patches[2];        /* the PN patches traced in each PnMode: all exact (robust) or all fast (classic) */
    double offset[3];      /* added to the plan's coordinates, gives the scene's as moved by the options */
    Interiors camera_in;   /* the solids the camera is inside, outermost first: where camera rays start */
    int camera_in_lost;    /* the outermost solids around the camera past LIMIT_INTERIORS, left out */
    int transparent;       /* some material lets light through (filter or transmit) */
    int reflective;        /* some material reflects */
    int full;              /* --no-plan: every skip below is off */
    int loop;              /* trace by a plain loop over the primitives, no BVH (accel_build_as) */
    float adc_bailout;     /* POV-Ray's cut-off of secondary rays by weight (shade.h) */
    float aa_threshold;    /* > 0: only pixels whose centre differs from a neighbour's by
                            * more get the spp x spp grid (render.h); 0: every pixel */
    PlanShadow *shadow;    /* per light, scene->lights[i] */
    PlanArea *area;        /* per light: its samples, for an area light (NULL for a point light) */
    int *floors;           /* with transparent materials, the opaque planes (shade.c: floors_first) */
    int nfloors;
    float *floor_band;     /* with floors, per primitive: 0, or for a transparent one whose box meets a
                            * floor, how far the float roundings can put it from a floor it touches */
} RenderPlan;

/* Options that keep every setting of the scene, on one thread. */
PlanOptions plan_options(void);

/* Builds the plan for scene s, moving s as described above, in double:
 * the scene's floats are rounded after the last move (Scene.place). Returns 0, or
 * -1 with a message in err: a setting out of range, a move that is not
 * finite or makes an oriented box degenerate (s may then be partly
 * moved: load it again), or no memory; or -2 when a statement of the scene
 * file is at fault (an ellipsoid flatter than PLAN_FLATTEST from the
 * camera): err then holds "line:col: what is wrong", for the caller to
 * put the file's name before. On error p needs no plan_free. */
int plan_build(RenderPlan *p, Scene *s, const PlanOptions *o, char *err, size_t errlen);

void plan_free(RenderPlan *p);

/* POV-Ray's area-light weights along one axis of n samples (n <= 64): the
 * leaves of its recursive halving of the grid, which is a plain mean only
 * when n is a power of two. Writes n weights summing to 1. */
void plan_area_weights(int n, float *w);

/* The samples of an n1 x n2 grid (n1, n2 <= 64) that POV-Ray's adaptive
 * subdivision traces at every point, whatever they let through: the
 * corners of every cell it splits for its level alone (Light.adaptive, 1 +
 * POV-Ray's level; 0 for a light that is not adaptive: every sample).
 * Writes their indices j * n1 + i into first, ascending, and returns how
 * many. */
int plan_area_first(int n1, int n2, int adaptive, int *first);

/* One decision of the plan, for a person (render --explain) and for
 * --stats: a part of the work, whether it is skipped, and why. */
typedef struct {
    char what[64];
    int skipped;
    char why[192];
} PlanNote;

/* The plan's decisions, at most max of them, into notes: each light's
 * shadow rays, reflection and refraction rays, the shading normals, the PN
 * patches. Returns how many there are (which may exceed max). */
int plan_notes(const RenderPlan *p, PlanNote *notes, int max);

/* The solids of s that contain point q, by decreasing volume: of nested
 * solids, the innermost last (the medium there), as refraction reads the
 * list; solids of one volume in scene order. Past LIMIT_INTERIORS, the
 * innermost are kept; returns how many were left out. */
int plan_interiors_at(const Scene *s, Vec3 q, Interiors *in);

#endif
