/*
 * mesh_read.h - what the mesh readers share (private to src/): the mesh
 * being built, its one allocation point, and the checks and messages every
 * format gives alike (mesh_build.c). Each reader fills a MeshBuild from a
 * LexReader over the file's bytes and ends with mesh_finish; mesh.c picks
 * the reader.
 */
#ifndef LANCER_MESH_READ_H
#define LANCER_MESH_READ_H

#include <stddef.h>
#include <stdint.h>

#include "lancer/mesh.h"
#include "bigmem.h"
#include "lex.h"

/* The one allocation point, which a build may override. */
#ifndef MESH_REALLOC
#define MESH_REALLOC(p, used, size) big_realloc(p, used, size)
#define MESH_FREE(p) free(p)
#endif

typedef struct {
    Mesh m;
    size_t cap_t; /* room in m.tri, and in m.ntri when track_n */
    int track_n;  /* every triangle also gets a row in m.ntri */
} MeshBuild;

/* Resizes p, whose first `used` elements are in use, to n elements of
 * `size` bytes; a large array in huge pages (bigmem.h). Returns NULL when
 * out of memory or when n * size overflows; p is then untouched. n must
 * be > 0. */
void *mesh_array(void *p, size_t used, size_t n, size_t size);
/* Room for item n of the array p, of *cap items so far: p, doubled from
 * `first` items when full, or NULL when out of memory (p untouched). */
void *mesh_grow(void *p, int *cap, int n, int first, size_t size);

/* Reads a coordinate (what = "coordinate") or a normal component: a
 * finite float, or an error on R's current line. */
int mesh_read_coord(const LexReader *R, LexTok t, const char *what, float *out);
/* Checks that t is a number (an ignored value: a colour, w, a property). */
int mesh_check_number(const LexReader *R, LexTok t);

/* Of `count` items announced in a text file, each at least `min` bytes
 * (min > 0) with `rem` bytes left, as many as a reader can start: those
 * bytes hold no more whole lines, the last '\n' optional, and one begun.
 * A count past it is not refused when announced: the reading stops at the
 * first short line or at the file's end, which says where the file is
 * wrong, and arrays of this many items bound what it allocates. */
long long mesh_text_cap(long long count, size_t rem, unsigned long long min);
/* Allocates m->v (and m->n with normals) for nv vertices, nv <= INT_MAX. */
int mesh_alloc_vertices(const LexReader *R, long line, MeshBuild *B, long long nv, int normals);
/* Makes room for n triangles in all. Returns 0 or -1 (out of memory). */
int mesh_reserve_tris(const LexReader *R, long line, MeshBuild *B, size_t n);
/* Appends triangle c (and its normal indices nc when track_n). */
int mesh_push_tri(const LexReader *R, MeshBuild *B, const int c[3], const int nc[3]);
/* Corner j of a polygon fanned into triangles from its first corner:
 * vertex v (and normal n, when nc is given) into c (nc); from the third
 * corner on, each closes a triangle. */
int mesh_fan_corner(const LexReader *R, MeshBuild *B, long long j, int v, int n, int c[3], int nc[3]);
/* 1 when triangle c of vertices v has zero area: two corners repeated, or
 * all three collinear, decided exactly on the float coordinates. */
int mesh_tri_degenerate(const Vec3 *v, const int c[3]);
/* 1 when it is degenerate with three distinct corners not all at one
 * point: the collinear triangles a mesh keeps apart (mesh.h). */
int mesh_tri_line(const Vec3 *v, const int c[3]);
/* Frees the normals: the mesh has none. */
void mesh_drop_normals(Mesh *m);
/* Drops degenerate triangles, trims the arrays, and with vertex_normals
 * (one normal per vertex, as NOFF and PLY give them) makes ntri a copy of
 * tri. A mesh without triangles keeps no normals. */
int mesh_finish(const LexReader *R, MeshBuild *B, int vertex_normals);

/* The hash of a vertex's coordinates under seed by which STL's vertices
 * are welded (-0 as +0), each table with a seed of its own
 * (lex_hash_seed); any run of its low bits serves as a table's slot. */
uint64_t mesh_weld_hash(Vec3 p, uint64_t seed);

/* The readers: each returns 0, or -1 with the message in R's buffer. */
int mesh_read_off(LexReader *R, MeshBuild *B);
int mesh_read_obj(LexReader *R, MeshBuild *B);
int mesh_read_ply(LexReader *R, MeshBuild *B);
int mesh_read_stl(LexReader *R, MeshBuild *B);

#endif
