/*
 * mesh.h - triangle meshes read from OFF, OBJ, PLY and STL files.
 *
 *     Mesh m;
 *     char err[512];
 *     if (mesh_load("bunny.off", &m, err, sizeof err) != 0) {
 *         fprintf(stderr, "%s\n", err);          "file:line: what is wrong"
 *         return 1;
 *     }
 *     if (!m.n && mesh_vertex_normals(&m, err, sizeof err) != 0) ...  (out of memory)
 *     for (int i = 0; i < m.nt; i++) {
 *         Vec3 a = m.v[m.tri[i][0]], b = m.v[m.tri[i][1]], c = m.v[m.tri[i][2]];
 *         Vec3 na = m.n[m.ntri[i][0]], nb = m.n[m.ntri[i][1]], nc = m.n[m.ntri[i][2]];
 *         ...
 *     }
 *     mesh_free(&m);
 *
 * What a loaded mesh promises (mesh_validate checks all of it):
 *
 * - every coordinate and normal component is finite in single precision;
 * - every index in tri is in [0, nv), every index in ntri in [0, nn);
 * - n and ntri are both NULL (nn == 0) or both present, and a mesh without
 *   triangles has no normals;
 * - no triangle has zero area: triangles whose three corners are collinear
 *   or repeated, decided exactly on the float coordinates, are dropped and
 *   counted in `degenerate`, but for those of three distinct corners (by
 *   index) not all at one point, which are kept apart after the others
 *   (`nline`): a PN patch of such a triangle has curved edges and fills
 *   the gap between its neighbours' patches (a T-junction closed by a
 *   sliver);
 * - polygons are fanned from their first corner: (c0 c1 c2), (c0 c2 c3) ...
 *   so the winding (and with it the facing) of the file is kept.
 *
 * Normals from a file are returned as written (finite, but neither checked
 * for unit length nor renormalised; they may be zero). Vertices nothing
 * refers to are kept. A file with no faces, or whose faces are all
 * degenerate, loads as a mesh with nt == 0: whether that is an error is for
 * the caller to say.
 *
 * Formats (what is read; everything else is rejected with a message):
 *
 * - OFF: an optional header line "OFF", "COFF", "NOFF" or "CNOFF" (counts
 *   may follow on the same line), the counts line "nv nf ne", nv vertex
 *   lines "x y z [nx ny nz] [r g b [a]]" (normals with N, a colour of 3 or 4
 *   values with C) and nf face lines "k i0 ... ik-1 [colour]" whose colour is
 *   at most 4 numbers and is ignored; indices from 0. '#' starts a comment
 *   anywhere. Lines matter: one vertex or face per line, and a line after
 *   the last face is an error. Binary OFF and the ST, 4 and n variants are
 *   refused.
 * - OBJ: "v x y z [w]" (w ignored; "v x y z r g b", the common vertex
 *   colour extension, also reads, colour ignored), "vn x y z", and "f" with
 *   corners v, v/vt, v//vn or v/vt/vn, indices from 1 or negative (relative
 *   to the elements defined so far). Positive indices may refer forward to
 *   elements defined later in the file. Every other statement (vt, o, g, s,
 *   usemtl, mtllib, l, p, curves ...) is ignored; vt only counts, so that
 *   texture indices can be checked; a line that does not start with a
 *   letter is an error. Line continuation ('\' at the end of a line) is not
 *   supported.
 *   Normals rule: a face's corners all have a normal or none does (a mix is
 *   an error). The file's normals are returned only when every face has
 *   them; if any face lacks them, n and ntri are NULL for the whole mesh and
 *   the caller can use mesh_vertex_normals. (Per-face fallbacks would mix
 *   shading models silently.)
 * - PLY: "format ascii 1.0" and "format binary_little_endian 1.0" (big
 *   endian is refused). The element "vertex" needs scalar properties x, y, z
 *   and may have nx, ny, nz (all three or none); the element "face" needs a
 *   list "vertex_indices" (or "vertex_index") of an integer type. Every other
 *   element and property, lists included, is skipped. Scalar types: char
 *   uchar short ushort int uint float double and their sized names int8 ...
 *   float64. In ASCII each element instance is one line (blank lines are
 *   skipped); an element without properties takes no bytes and no lines.
 *   Elements may come in any order; data after the last one is an error.
 *   A header declares at most LIMIT_PLY_DECLARATIONS elements and
 *   properties in all.
 * - STL: binary (80-byte header, uint32 count, 50-byte records, and a size
 *   of exactly 84 + 50 count) or ASCII ("solid", then "facet normal n n n",
 *   "outer loop", three or more "vertex x y z" (more are fanned), "endloop",
 *   "endfacet", and "endsolid"; keywords in any case; one solid after
 *   another allowed). Facet normals are checked to be numbers and then
 *   ignored. Vertices with the same coordinates are welded into one, so a
 *   closed solid loads as a closed mesh.
 *
 * Errors read "file:line: message". For binary PLY data, which has no lines,
 * the line is that of the header's "element" line describing the offending
 * data, and the message ends with "at byte offset N" (offset of the bad value
 * from the start of the file, 0-based; for data that runs out, the file's
 * length); binary STL's messages give line 1 and the byte offset likewise. Errors that concern the whole file
 * (cannot open, too large) read "file: message". Every count in a header is
 * checked against what the bytes that follow can hold before anything is
 * allocated from it.
 *
 * Numbers are read with strtof, so a program that sets LC_NUMERIC to a
 * locale whose decimal point is not '.' will see "malformed number" errors.
 *
 * Library code never prints or exits. On error the Mesh is left empty (all
 * zero) and mesh_free is still safe on it.
 */
#ifndef LANCER_MESH_H
#define LANCER_MESH_H

#include <stddef.h>

#include "lancer/limits.h"
#include "lancer/sha256.h"
#include "lancer/vec.h"


typedef enum { MESH_OFF, MESH_OBJ, MESH_PLY, MESH_STL } MeshFormat;

typedef struct {
    Vec3 *v;           /* vertex positions */
    int nv;
    Vec3 *n;           /* vertex normals from the file, or none (n == NULL, nn == 0) */
    int nn;
    int (*tri)[3];     /* triangles: indices into v */
    int nt;
    int (*ntri)[3];    /* per-corner indices into n (NULL when there are no normals) */
    int nline;         /* tri[nt .. nt + nline - 1] (and ntri's): collinear, of three distinct corners */
    int degenerate;    /* triangles dropped because they have zero area */
    unsigned char sha256[SHA256_BYTES]; /* the file's bytes' digest (mesh_load; else zero) */
} Mesh;

/* Reads and parses a mesh file; the format comes from the extension .off,
 * .obj, .ply or .stl (any case). Returns 0, or -1 with "path:line: message" (or
 * "path: message") in err and m left empty. On success the caller owns the
 * arrays in m and releases them with mesh_free; m->sha256 is the SHA-256
 * of the bytes parsed. err may be NULL when errlen is 0. */
int mesh_load(const char *path, Mesh *m, char *err, size_t errlen);

/* Parses a mesh held in memory (data need not be NUL-terminated; it may hold
 * NUL bytes); `name` stands for the file in messages. Result, ownership and
 * errors as for mesh_load. */
int mesh_parse(const char *name, const char *data, size_t len, MeshFormat fmt, Mesh *m, char *err,
               size_t errlen);

/* The format that mesh_load would pick for path. Returns 0, or -1 when the
 * extension is none of .off .obj .ply .stl (*fmt is then unchanged). */
int mesh_format_from_path(const char *path, MeshFormat *fmt);

/* Releases every array of m and leaves it empty. Safe on an empty Mesh and
 * on one a failed load returned. */
void mesh_free(Mesh *m);

/* Vertex normals for smooth shading: at each vertex, the sum of the unit
 * normals of the triangles around it, each weighted by the triangle's angle
 * at that vertex (Thuermer & Wuethrich, "Computing vertex normals from
 * polygonal meshes", JGT 1998), normalised. Computed in double. Replaces any
 * normals m has: fills m->n (nn = nv, unit length) and m->ntri (its own
 * array, a copy of m->tri). A vertex whose weighted sum cancels takes the
 * normal of its first triangle; a vertex no triangle uses gets (0,0,0).
 * Returns 0, or -1 with a message in err when out of memory (m is then
 * unchanged). */
int mesh_vertex_normals(Mesh *m, char *err, size_t errlen);

/* The first of m's normals that a triangle's corner uses and that has zero
 * length (which a smooth or PN mesh cannot shade by), or -1 when there is
 * none or m has no normals. */
int mesh_zero_normal(const Mesh *m);

/* Checks the promises listed at the top of this file. Returns 0, or -1 with
 * a message naming the first broken one in err. */
int mesh_validate(const Mesh *m, char *err, size_t errlen);

#endif
