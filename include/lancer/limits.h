/*
 * limits.h - every limit of lancer's inputs and settings, in one place; the
 * README's table of limits gives the same values. Going past one is an
 * error that names it, never a crash, a hang or an allocation without
 * bound.
 */
#ifndef LANCER_LIMITS_H
#define LANCER_LIMITS_H

#include <stdint.h>

/* Images: a side, and width x height (3 GiB of float RGB). */
#define LIMIT_IMAGE_SIDE 32768
#define LIMIT_IMAGE_PIXELS (1L << 28)
/* Anti-aliasing: spp x spp samples per pixel. */
#define LIMIT_SPP 16
/* Trace depth: POV-Ray's max_trace_level. */
#define LIMIT_DEPTH 256
/* Render and build threads. */
#define LIMIT_THREADS 1024
/* An area light's grid, per side, and its adaptive level. */
#define LIMIT_AREA_SAMPLES 64
#define LIMIT_AREA_ADAPTIVE 16
/* The samples of a scene's lights, all together (a point light is one):
 * the plan keeps each area light's samples, 20 bytes each, so that a light
 * of a line of text cannot take 80 KB of memory without bound. */
#define LIMIT_LIGHT_SAMPLES (1 << 22)

/* Files, refused by size before they are read. A scene is text written
 * by hand or by a script. A mesh in the most verbose format lancer reads,
 * ASCII STL, takes about 250 bytes a triangle: 4 GiB holds 10 million
 * triangles and more. EXR inputs of `lancer diff` and ray files likewise. */
#define LIMIT_SCENE_BYTES (64LL << 20)
#define LIMIT_MESH_BYTES (4LL << 30)
#define LIMIT_EXR_BYTES (4LL << 30)
#define LIMIT_RAYFILE_BYTES (4LL << 30)

/* Primitives in a scene, and triangles in a mesh (indices are int32). */
#define LIMIT_PRIMITIVES INT32_MAX

/* Characters of a material name, of a path in a scene file (a mesh's), and
 * of a number in a scene or mesh file. */
#define LIMIT_NAME_CHARS 63
#define LIMIT_PATH_CHARS 1023
#define LIMIT_NUMBER_CHARS 255

/* Transparent solids a ray is tracked inside at once (deeper nesting is
 * not tracked), transparent surfaces a shadow ray crosses, and surfaces a
 * path passes straight through in a row (POV-Ray's continued rays, which
 * keep their trace level; past it, black, as past max_depth: each one is a
 * level of the recursion). */
#define LIMIT_INTERIORS 16
#define LIMIT_SHADOW_CROSSINGS 256
#define LIMIT_CONTINUED 256

/* Elements and properties a PLY header declares, in all: real files have
 * a few dozen, and each name is checked against those before it. */
#define LIMIT_PLY_DECLARATIONS 4096

/* `lancer export-pov --pn-segments`: a PN patch's segments per edge in
 * POV-Ray's twin (N^2 triangles a patch). */
#define LIMIT_PN_SEGMENTS 256

/* `lancer diff --downsample`, per side. */
#define LIMIT_DOWNSAMPLE 64

/* The last frame number of a camera path: frame patterns such as %04d
 * stay short. */
#define LIMIT_FRAME 999999

#endif
