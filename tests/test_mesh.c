/*
 * Tests of the mesh readers (mesh.h): good OFF, OBJ, PLY and STL (ASCII and
 * binary) inputs with their exact counts, coordinates and fan triangulation;
 * every class of bad input, for each format, with its exact "file:line:
 * message"; exact dropping of zero-area triangles; angle-weighted vertex
 * normals; mesh_load on files the test writes into a temporary directory;
 * and every good input truncated at every byte and mutated byte by byte,
 * which must fail cleanly or load a valid mesh (under ASan, never read out
 * of bounds). Self-contained, but for CGAL's two STL files, which it reads
 * from build/cgal-data when `make cgal-data` has put them there.
 */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include "testutil.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <unistd.h>

#include "lancer/limits.h"
#include "lancer/mesh.h"
#include "../src/mesh_read.h"

/* ---- helpers ---- */

static const char *fmt_name(MeshFormat f)
{
    static const char *const names[] = {"t.off", "t.obj", "t.ply", "t.stl"};
    return names[f];
}

/* Parses len bytes copied to a heap block of exactly that size, so that ASan
 * sees any read past the end. */
static int parse_n(MeshFormat f, const char *text, size_t len, Mesh *m, char *err, size_t errlen)
{
    char *copy = malloc(len ? len : 1);
    assert_non_null(copy);
    memcpy(copy, text, len);
    int rc = mesh_parse(fmt_name(f), copy, len, f, m, err, errlen);
    free(copy);
    return rc;
}

/* Parses text that must be valid, and checks the mesh's promises. */
static void parse_ok_n(MeshFormat f, const char *text, size_t len, Mesh *m)
{
    char err[512] = "";
    if (parse_n(f, text, len, m, err, sizeof err) != 0)
        fail_msg("unexpected parse error: %s", err);
    if (mesh_validate(m, err, sizeof err) != 0)
        fail_msg("invalid mesh: %s", err);
}

static void parse_ok(MeshFormat f, const char *text, Mesh *m) { parse_ok_n(f, text, strlen(text), m); }

static int mesh_is_empty(const Mesh *m)
{
    Mesh zero;
    memset(&zero, 0, sizeof zero);
    return memcmp(m, &zero, sizeof zero) == 0;
}

/* Parses bytes that must be refused with exactly `want`, leaving m empty. */
static void expect_error_n(MeshFormat f, const char *text, size_t len, const char *want)
{
    Mesh m;
    char err[512] = "";
    memset(&m, 0x5a, sizeof m);
    int rc = parse_n(f, text, len, &m, err, sizeof err);
    if (rc == 0) {
        mesh_free(&m);
        fail_msg("accepted, expected: %s", want);
    }
    if (strcmp(err, want) != 0)
        fail_msg("wrong message\n  got:  %s\n  want: %s", err, want);
    assert_true(mesh_is_empty(&m));
}

static void assert_tri(const int t[3], int a, int b, int c)
{
    if (t[0] != a || t[1] != b || t[2] != c)
        fail_msg("triangle (%d %d %d), expected (%d %d %d)", t[0], t[1], t[2], a, b, c);
}

static void assert_vec_near(Vec3 v, float x, float y, float z)
{
    if (fabsf(v.x - x) > 1e-6f || fabsf(v.y - y) > 1e-6f || fabsf(v.z - z) > 1e-6f)
        fail_msg("(%g %g %g), expected (%g %g %g)", v.x, v.y, v.z, x, y, z);
}

/* ---- binary PLY building ---- */

typedef struct {
    unsigned char b[8192];
    size_t n;
} Buf;

static void put(Buf *B, const void *p, size_t n)
{
    assert_true(B->n + n <= sizeof B->b);
    memcpy(B->b + B->n, p, n);
    B->n += n;
}

static void put_str(Buf *B, const char *s) { put(B, s, strlen(s)); }

static void put_le(Buf *B, uint64_t v, int bytes)
{
    for (int i = 0; i < bytes; i++) {
        unsigned char c = (unsigned char)(v >> (8 * i));
        put(B, &c, 1);
    }
}

static void put_u8(Buf *B, unsigned v) { put_le(B, v, 1); }
static void put_i16(Buf *B, int v) { put_le(B, (uint16_t)(int16_t)v, 2); }
static void put_u16(Buf *B, unsigned v) { put_le(B, v, 2); }
static void put_i32(Buf *B, int32_t v) { put_le(B, (uint32_t)v, 4); }
static void put_u32(Buf *B, uint32_t v) { put_le(B, v, 4); }

static void put_f32(Buf *B, float f)
{
    uint32_t u;
    memcpy(&u, &f, 4);
    put_le(B, u, 4);
}

static void put_f64(Buf *B, double d)
{
    uint64_t u;
    memcpy(&u, &d, 8);
    put_le(B, u, 8);
}

/* A binary PLY whose face element comes first and which has properties and
 * an element to skip of many types:
 *   face:     uchar flags, list uchar int vertex_indices, list uchar float texcoord
 *   vertex:   double x, float y, short z, uchar red, list ushort uint extra
 *   material: uchar r, double shininess  (fixed size: skipped whole)
 * 4 vertices of a unit square in z = 2, a quad and a triangle.
 * *face2 is set to the offset of the second face's record. */
static void binary_sample(Buf *B, size_t *face2)
{
    B->n = 0;
    put_str(B, "ply\n"
               "format binary_little_endian 1.0\n"
               "comment written by test_mesh\n"
               "element face 2\n"                              /* line 4 */
               "property uchar flags\n"
               "property list uchar int vertex_indices\n"
               "property list uchar float texcoord\n"
               "element vertex 4\n"                            /* line 8 */
               "property double x\n"
               "property float y\n"
               "property short z\n"
               "property uchar red\n"
               "property list ushort uint extra\n"
               "element material 2\n"                          /* line 14 */
               "property uchar r\n"
               "property double shininess\n"
               "end_header\n");                                /* line 17 */
    /* faces */
    put_u8(B, 7);
    put_u8(B, 4);
    put_i32(B, 0), put_i32(B, 1), put_i32(B, 2), put_i32(B, 3);
    put_u8(B, 2);
    put_f32(B, 0.5f), put_f32(B, 0.25f);
    *face2 = B->n;
    put_u8(B, 0);
    put_u8(B, 3);
    put_i32(B, 3), put_i32(B, 1), put_i32(B, 0);
    put_u8(B, 0);
    /* vertices */
    static const double xy[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    for (int i = 0; i < 4; i++) {
        put_f64(B, xy[i][0]);
        put_f32(B, (float)xy[i][1]);
        put_i16(B, 2);
        put_u8(B, 200);
        put_u16(B, (unsigned)i);
        for (int k = 0; k < i; k++)
            put_u32(B, 0xdeadbeefu);
    }
    /* materials */
    put_u8(B, 1), put_f64(B, 10);
    put_u8(B, 2), put_f64(B, 20);
}

/* ---- good inputs ---- */

static const char off_tetra[] = "# a tetrahedron, winding outward\n"
                                "OFF\n"
                                "\n"
                                "4 4 6   # counts\n"
                                "0 0 0\n"
                                "1 0 0\r\n"
                                "0 1 0\n"
                                "0 0 1\n"
                                "# faces\n"
                                "3 0 2 1\n"
                                "3 0 1 3\n"
                                "3 0 3 2\n"
                                "3 1 2 3\n";

static void test_off_basic(void **state)
{
    (void)state;
    Mesh m;
    parse_ok(MESH_OFF, off_tetra, &m);
    assert_int_equal(m.nv, 4);
    assert_int_equal(m.nt, 4);
    assert_int_equal(m.degenerate, 0);
    assert_null(m.n);
    assert_null(m.ntri);
    assert_int_equal(m.nn, 0);
    assert_vec(m.v[1], 1, 0, 0, 0);
    assert_vec(m.v[3], 0, 0, 1, 0);
    assert_tri(m.tri[0], 0, 2, 1);
    assert_tri(m.tri[3], 1, 2, 3);
    mesh_free(&m);
    assert_true(mesh_is_empty(&m));
    mesh_free(&m); /* twice is safe */
}

static void test_off_fan(void **state)
{
    (void)state;
    Mesh m;
    /* a pentagon in z = 0 and a quad with a colour, no header, counts with
     * spare blanks, numbers in several spellings */
    parse_ok(MESH_OFF,
             "  6 2 0\n"
             "0 0 0\n"
             "2.0 0. 0\n"
             "+3 1e0 0\n"
             "1 2 -0\n"
             ".5 1.5E+0 0\n"
             "0 0 1\n"
             "5 0 1 2 3 4\n"
             "4 0 1 5 4  255 0 0 255\n",
             &m);
    assert_int_equal(m.nv, 6);
    assert_int_equal(m.nt, 5);
    assert_vec(m.v[2], 3, 1, 0, 0);
    assert_vec(m.v[4], 0.5f, 1.5f, 0, 0);
    assert_tri(m.tri[0], 0, 1, 2);
    assert_tri(m.tri[1], 0, 2, 3);
    assert_tri(m.tri[2], 0, 3, 4);
    assert_tri(m.tri[3], 0, 1, 5);
    assert_tri(m.tri[4], 0, 5, 4);
    mesh_free(&m);
}

static void test_off_variants(void **state)
{
    (void)state;
    Mesh m;
    /* COFF: a colour of 4 or 3 values after each vertex, as CGAL writes */
    parse_ok(MESH_OFF, "COFF\n3 1 0\n0 0 0 192 192 192 255\n1 0 0 0.5 0.5 0.5\n0 1 0 1 1 1 1\n3 0 1 2\n", &m);
    assert_vec(m.v[1], 1, 0, 0, 0);
    mesh_free(&m);

    /* NOFF: normals per vertex, so ntri repeats tri */
    parse_ok(MESH_OFF,
             "NOFF\n4 1 0\n0 0 0 0 0 1\n1 0 0 0 0 1\n1 1 0 0 0 2\n0 1 0 0 0.5 0.5\n4 0 1 2 3\n", &m);
    assert_ptr_not_equal(m.ntri, m.tri);
    assert_vec(m.n[2], 0, 0, 2, 0); /* as written, not renormalised */
    for (int i = 0; i < m.nt; i++)
        assert_memory_equal(m.ntri[i], m.tri[i], sizeof m.tri[i]);
    mesh_free(&m);

    /* CNOFF */
    parse_ok(MESH_OFF, "CNOFF\n3 1 0\n0 0 0 0 0 1 1 0 0\n1 0 0 0 0 1 0 1 0 1\n0 1 0 0 0 1 0 0 1\n3 0 1 2\n", &m);
    assert_vec(m.n[1], 0, 0, 1, 0);
    mesh_free(&m);
}

static const char obj_sample[] = "# a quad and a triangle, with everything the reader ignores\n"
                                 "mtllib box.mtl\n"
                                 "o thing\n"
                                 "v 0 0 0\n"
                                 "v 1 0 0 1.0\n"                   /* w */
                                 "v 1 1 0 0.5 0.5 0.5\n"           /* colour */
                                 "v 0 1 0\n"
                                 "vt 0 0\n"
                                 "vt 1 0\n"
                                 "vt 1 1\n"
                                 "g side\n"
                                 "usemtl red\n"
                                 "s 1\n"
                                 "f 1/1 2/2 3/3 4/1   # quad\n"
                                 "l 1 2\n"
                                 "p 3\n"
                                 "v 0 0 1\r\n"
                                 "f\t-5 -4 -1\n"                   /* relative: 1 2 5 */
                                 "curv 0 1 1 2\n";

static void test_obj_basic(void **state)
{
    (void)state;
    Mesh m;
    parse_ok(MESH_OBJ, obj_sample, &m);
    assert_int_equal(m.nv, 5);
    assert_int_equal(m.nt, 3);
    assert_null(m.n);
    assert_vec(m.v[1], 1, 0, 0, 0);
    assert_vec(m.v[2], 1, 1, 0, 0);
    assert_vec(m.v[4], 0, 0, 1, 0);
    assert_tri(m.tri[0], 0, 1, 2);
    assert_tri(m.tri[1], 0, 2, 3);
    assert_tri(m.tri[2], 0, 1, 4);
    mesh_free(&m);
}

static void test_obj_negative_and_forward(void **state)
{
    (void)state;
    Mesh m;
    /* negative indices count back from the latest element; positive ones
     * may refer forward */
    parse_ok(MESH_OBJ,
             "v 0 0 0\nv 1 0 0\nv 0 1 0\n"
             "f -3 -2 -1\n"
             "f 1 2 4\n"
             "v 0 0 1\n"
             "vt 0 0\n"
             "f -4/-1 -1/-1 -2/-1\n",
             &m);
    assert_int_equal(m.nt, 3);
    assert_tri(m.tri[0], 0, 1, 2);
    assert_tri(m.tri[1], 0, 1, 3);
    assert_tri(m.tri[2], 0, 3, 2);
    mesh_free(&m);
}

static const char obj_normals[] = "v 0 0 0\n"
                                  "v 1 0 0\n"
                                  "v 1 1 0\n"
                                  "v 0 1 0\n"
                                  "vn 0 0 1\n"
                                  "vn 0 0 -1\n"
                                  "vn 0 1 0\n"
                                  "vn 1 0 0\n"
                                  "vt 0 0\n"
                                  "f 1//1 2//3 3//4 4//2\n"
                                  "f 1/1/2 3/1/2 2/1/-1\n";

static void test_obj_normals(void **state)
{
    (void)state;
    Mesh m;
    parse_ok(MESH_OBJ, obj_normals, &m);
    assert_int_equal(m.nt, 3);
    assert_int_equal(m.nn, 4);
    assert_non_null(m.ntri);
    assert_vec(m.n[1], 0, 0, -1, 0);
    /* the quad's fan keeps each corner's own normal */
    assert_tri(m.tri[0], 0, 1, 2);
    assert_tri(m.ntri[0], 0, 2, 3);
    assert_tri(m.tri[1], 0, 2, 3);
    assert_tri(m.ntri[1], 0, 3, 1);
    assert_tri(m.ntri[2], 1, 1, 3);
    assert_tri(m.tri[2], 0, 2, 1);
    mesh_free(&m);

}

/* The first normal of zero length that a corner uses: in index order,
 * not the corners' order; an unused one and a mesh without normals give -1. */
static void test_zero_normal(void **state)
{
    (void)state;
    Mesh m;
    parse_ok(MESH_OBJ, "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nvn 0 0 0\nvn 0 0 0\nvn 0 0 0\nf 1//4 2//2 3//1\n", &m);
    assert_int_equal(mesh_zero_normal(&m), 1);
    mesh_free(&m);
    parse_ok(MESH_OBJ, "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nvn 0 0 0\nf 1//1 2//1 3//1\n", &m);
    assert_int_equal(mesh_zero_normal(&m), -1);
    mesh_free(&m);
    parse_ok(MESH_OFF, "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n", &m);
    assert_int_equal(mesh_zero_normal(&m), -1);
    mesh_free(&m);
}

static const char ply_ascii[] = "ply\n"
                                "format ascii 1.0\n"
                                "comment extra properties and elements to skip\n"
                                "obj_info made by hand\n"
                                "element vertex 5\n"
                                "property float32 x\n"
                                "property uchar red\n"
                                "property double y\n"
                                "property list uchar float weights\n"
                                "property int z\n"
                                "property float nx\n"
                                "property float ny\n"
                                "property float nz\n"
                                "element edge 2\n"
                                "property int vertex1\n"
                                "property int vertex2\n"
                                "element face 2\n"
                                "property list uint8 int32 vertex_index\n"
                                "property uchar red\n"
                                "property list uchar uint texture\n"
                                "end_header\n"
                                "0 255 0 0 0 0 0 1\n"
                                "1 255 0 2 0.5 0.25 0 0 0 1\n"
                                "1 255 1 1 0.5 0 0 0 1\n"
                                "\n"
                                "0 0 1 0 0 0 0 1\n"
                                "0.5 0 0.5 0 -2 0 0 -1\n"
                                "0 1\n"
                                "1 2\n"
                                "4 0 1 2 3 128 0\n"
                                "3 1 0 4 0 3 7 7 7\n";

static void test_ply_ascii(void **state)
{
    (void)state;
    Mesh m;
    parse_ok(MESH_PLY, ply_ascii, &m);
    assert_int_equal(m.nv, 5);
    assert_int_equal(m.nt, 3);
    assert_int_equal(m.nn, 5);
    assert_vec(m.v[1], 1, 0, 0, 0);
    assert_vec(m.v[4], 0.5f, 0.5f, -2, 0);
    assert_vec(m.n[4], 0, 0, -1, 0);
    assert_tri(m.tri[0], 0, 1, 2);
    assert_tri(m.tri[1], 0, 2, 3);
    assert_tri(m.tri[2], 1, 0, 4);
    assert_tri(m.ntri[2], 1, 0, 4);
    mesh_free(&m);

}

static void test_ply_binary(void **state)
{
    (void)state;
    Buf B;
    size_t face2;
    Mesh m;
    binary_sample(&B, &face2);
    parse_ok_n(MESH_PLY, (const char *)B.b, B.n, &m);
    assert_int_equal(m.nv, 4);
    assert_int_equal(m.nt, 3);
    assert_null(m.n);
    assert_vec(m.v[0], 0, 0, 2, 0);
    assert_vec(m.v[2], 1, 1, 2, 0);
    assert_vec(m.v[3], 0, 1, 2, 0);
    assert_tri(m.tri[0], 0, 1, 2);
    assert_tri(m.tri[1], 0, 2, 3);
    assert_tri(m.tri[2], 3, 1, 0);
    mesh_free(&m);
}

/* Every scalar type, by both its names, as the type of x, y and z. */
static void test_ply_types(void **state)
{
    (void)state;
    static const char *const names[][2] = {{"char", "int8"},   {"uchar", "uint8"},   {"short", "int16"},
                                           {"ushort", "uint16"}, {"int", "int32"},     {"uint", "uint32"},
                                           {"float", "float32"}, {"double", "float64"}};
    static const int sizes[] = {1, 1, 2, 2, 4, 4, 4, 8};
    for (int t = 0; t < 8; t++) {
        for (int alias = 0; alias < 2; alias++) {
            const char *ty = names[t][alias];
            char hdr[512];
            Buf B;
            Mesh m;
            snprintf(hdr, sizeof hdr,
                     "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty %s x\nproperty %s y\n"
                     "property %s z\nproperty %s pad\nelement face 1\nproperty list %s %s vertex_indices\nend_header\n",
                     ty, ty, ty, ty, t < 6 ? ty : "uchar", t < 6 ? ty : "int");
            B.n = 0;
            put_str(&B, hdr);
            static const int coords[3][3] = {{0, 0, 0}, {5, 0, 0}, {0, 7, 1}};
            for (int i = 0; i < 3; i++) {
                for (int k = 0; k < 4; k++) {
                    int v = k < 3 ? coords[i][k] : 99;
                    if (t == 6)
                        put_f32(&B, (float)v);
                    else if (t == 7)
                        put_f64(&B, v);
                    else
                        put_le(&B, (uint64_t)v, sizes[t]);
                }
            }
            int isz = t < 6 ? sizes[t] : 4;
            put_le(&B, 3, t < 6 ? sizes[t] : 1);
            for (int i = 0; i < 3; i++)
                put_le(&B, (uint64_t)i, isz);
            parse_ok_n(MESH_PLY, (const char *)B.b, B.n, &m);
            assert_int_equal(m.nt, 1);
            assert_vec(m.v[1], 5, 0, 0, 0);
            assert_vec(m.v[2], 0, 7, 1, 0);
            mesh_free(&m);
        }
    }
    /* signed types keep their sign */
    Buf B;
    Mesh m;
    B.n = 0;
    put_str(&B, "ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty char x\nproperty short y\n"
                "property int z\nend_header\n");
    put_u8(&B, 0xff), put_i16(&B, -300), put_i32(&B, -70000);
    parse_ok_n(MESH_PLY, (const char *)B.b, B.n, &m);
    assert_vec(m.v[0], -1, -300, -70000, 0);
    mesh_free(&m);
}

/* A header of LIMIT_PLY_DECLARATIONS elements and properties is read; one
 * more is refused at its line. Each name is checked against those before
 * it, so a header of 100,000 once took seconds. */
static void test_ply_declarations(void **state)
{
    (void)state;
    static const char head[] = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                               "property float z\nelement face 1\nproperty list uchar int vertex_indices\n";
    static const char tail[] = "end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
    const int given = 6; /* in head */
    const size_t cap = sizeof head + sizeof tail + 32 * (LIMIT_PLY_DECLARATIONS + 1);
    char *text = malloc(cap);
    assert_non_null(text);
    for (int extra = 0; extra < 2; extra++) {
        size_t n = (size_t)snprintf(text, cap, "%s", head);
        int more = LIMIT_PLY_DECLARATIONS - given + extra;
        for (int i = 0; i < more; i++) /* unused elements of 1 or 2 properties, no rows */
            n += (size_t)snprintf(text + n, cap - n, i % 3 == 0 ? "element e%d 0\n" : "property int p%d\n", i);
        n += (size_t)snprintf(text + n, cap - n, "%s", tail);
        if (!extra) {
            Mesh m;
            parse_ok_n(MESH_PLY, text, n, &m);
            assert_int_equal(m.nt, 1);
            mesh_free(&m);
        } else {
            char want[128];
            snprintf(want, sizeof want, "t.ply:%d:1: more than %d elements and properties in the header",
                     8 + more, LIMIT_PLY_DECLARATIONS);
            expect_error_n(MESH_PLY, text, n, want);
        }
    }
    free(text);
}

/* An ASCII STL tetrahedron, as writers vary it: keywords in any case,
 * tokens split across lines, -0 beside 0, CRLF, and a second solid. */
static const char stl_ascii[] = "solid tetra made by hand\n"
                                "  facet normal 0 0 -1\n"
                                "    outer loop\n"
                                "      vertex 0 0 0\n"
                                "      vertex 0 1 0\n"
                                "      vertex 1 0 0\n"
                                "    endloop\n"
                                "  endfacet\n"
                                "  FACET NORMAL 0 -1 0 OUTER LOOP VERTEX -0 0 0 VERTEX 1 0 0 VERTEX 0 0 1\r\n"
                                "  ENDLOOP ENDFACET\n"
                                "  facet normal nan 0 0\n" /* normals are not read */
                                "    outer loop vertex 0 0 0 vertex\n0 0 1\nvertex 0 1 0 endloop\n"
                                "  endfacet\n"
                                "endsolid tetra\n"
                                "solid second\n"
                                "  facet normal 1 1 1 outer loop vertex 1 0 0 vertex 0 1 0 vertex 0 0 1 endloop endfacet\n"
                                "endsolid\n";

/* A binary STL of n triangles t (9 floats each), its header beginning with
 * "solid" as many writers' do. */
static void binary_stl(Buf *B, const float (*t)[9], uint32_t n)
{
    B->n = 0;
    char header[80];
    memset(header, ' ', sizeof header);
    memcpy(header, "solid binary, all the same", 26);
    put(B, header, sizeof header);
    put_u32(B, n);
    for (uint32_t i = 0; i < n; i++) {
        for (int k = 0; k < 3; k++)
            put_f32(B, 0); /* the facet normal */
        for (int k = 0; k < 9; k++)
            put_f32(B, t[i][k]);
        put_u16(B, 0);
    }
}

/* A unit square in z = 0 as two triangles sharing the diagonal. */
static const float stl_square[2][9] = {{0, 0, 0, 1, 0, 0, 1, 1, 0}, {0, 0, 0, 1, 1, 0, 0, 1, 0}};

static void test_stl(void **state)
{
    (void)state;
    Mesh m;
    parse_ok(MESH_STL, stl_ascii, &m);
    assert_int_equal(m.nv, 4); /* twelve vertices welded into four */
    assert_int_equal(m.nt, 4);
    assert_null(m.n);
    assert_vec(m.v[0], 0, 0, 0, 0);
    assert_vec(m.v[1], 0, 1, 0, 0);
    assert_vec(m.v[2], 1, 0, 0, 0);
    assert_vec(m.v[3], 0, 0, 1, 0);
    assert_tri(m.tri[0], 0, 1, 2);
    assert_tri(m.tri[1], 0, 2, 3);
    assert_tri(m.tri[2], 0, 3, 1);
    assert_tri(m.tri[3], 2, 1, 3);
    mesh_free(&m);

    Buf B;
    binary_stl(&B, stl_square, 2);
    assert_int_equal(B.n, 84 + 2 * 50);
    parse_ok_n(MESH_STL, (const char *)B.b, B.n, &m);
    assert_int_equal(m.nv, 4);
    assert_int_equal(m.nt, 2);
    assert_vec(m.v[3], 0, 1, 0, 0);
    assert_tri(m.tri[0], 0, 1, 2);
    assert_tri(m.tri[1], 0, 2, 3);
    mesh_free(&m);

    /* no triangles: an empty mesh, binary or ASCII */
    binary_stl(&B, stl_square, 0);
    parse_ok_n(MESH_STL, (const char *)B.b, B.n, &m);
    assert_int_equal(m.nt, 0);
    assert_null(m.v);
    mesh_free(&m);
    parse_ok(MESH_STL, "solid nothing\nendsolid nothing\n", &m);
    assert_int_equal(m.nt, 0);
    mesh_free(&m);

    /* a polygon of four vertices is fanned, as in the other formats */
    parse_ok(MESH_STL, "solid q\nfacet normal 0 0 1 outer loop vertex 0 0 0 vertex 1 0 0 vertex 1 1 0 vertex 0 1 0 "
                       "endloop endfacet endsolid q\n",
             &m);
    assert_int_equal(m.nt, 2);
    assert_tri(m.tri[1], 0, 2, 3);
    mesh_free(&m);
}

/* Welding probes a table of twice the vertices' slots from each vertex's
 * hash. Coordinates on a grid of whole numbers or halves, as CAD and voxel
 * exports write, once all hashed to a few slots, and a voxel solid of
 * 135,000 triangles took seconds to load: the probes of such a grid's
 * vertices, inserted as weld() inserts them, must stay a few a vertex. */
static void test_stl_weld_grid(void **state)
{
    (void)state;
    enum { SIDE = 40, SLOTS = 1 << 17 };
    static uint64_t h[SIDE * SIDE * SIDE];
    const uint64_t seed = lex_hash_seed();
    for (int step = 0; step < 2; step++) { /* whole numbers, then halves */
        const float f = step ? 0.5f : 1.0f;
        int n = 0;
        for (int x = 0; x < SIDE; x++)
            for (int y = 0; y < SIDE; y++)
                for (int z = 0; z < SIDE; z++)
                    h[n++] = mesh_weld_hash(vec3(f * (float)x, f * (float)y, f * (float)z), seed);
        assert_true(test_probes(h, n, SLOTS) < 3L * n);
    }
    /* -0 and +0 are one vertex, and any slot they take is the same */
    assert_true(mesh_weld_hash(vec3(-0.0f, 1, 2), seed) == mesh_weld_hash(vec3(0.0f, 1, 2), seed));

    /* Points whose hashes under one seed all fall in one slot of 2^12, as a
     * file made against a fixed hash would have them (such a binary STL of
     * 30,000 triangles took 27 s to weld), spread under another seed: a
     * few probes a point where the first seed takes hundreds. */
    enum { NAIMED = 400, AIMED_SLOTS = 1 << 12 };
    uint64_t h1[NAIMED], h2[NAIMED], s1 = lex_mix64(1), s2 = lex_mix64(2), rng_k = 7;
    for (int n = 0; n < NAIMED;) {
        rng_k = lex_mix64(rng_k);
        Vec3 q = vec3((float)(rng_k & 0xfffff), (float)(rng_k >> 20 & 0xfffff), (float)(rng_k >> 40 & 0xfffff));
        h1[n] = mesh_weld_hash(q, s1);
        h2[n] = mesh_weld_hash(q, s2);
        n += (h1[n] & (AIMED_SLOTS - 1)) == 0;
    }
    assert_true(test_probes(h1, NAIMED, AIMED_SLOTS) > 100L * NAIMED);
    assert_true(test_probes(h2, NAIMED, AIMED_SLOTS) < 2L * NAIMED);
    /* and each table its own seed */
    assert_true(lex_hash_seed() != lex_hash_seed());

    /* a binary STL of a 9 x 9 grid of unit squares (as many as a Buf
     * holds) welds into its 10 x 10 vertices */
    enum { N = 9 };
    float t[2 * N * N][9];
    for (int i = 0; i < N; i++)
        for (int j = 0; j < N; j++)
            for (int k = 0; k < 2; k++) {
                const float *q = stl_square[k];
                for (int c = 0; c < 9; c++)
                    t[2 * (N * i + j) + k][c] = q[c] + (c % 3 == 0 ? (float)i : c % 3 == 1 ? (float)j : 0.0f);
            }
    Buf B;
    binary_stl(&B, (const float(*)[9])t, 2 * N * N);
    Mesh m;
    parse_ok_n(MESH_STL, (const char *)B.b, B.n, &m);
    assert_int_equal(m.nv, (N + 1) * (N + 1));
    assert_int_equal(m.nt, 2 * N * N);
    mesh_free(&m);
}

/* CGAL's STL files (Debian's libcgal-demo; `make cgal-data` unpacks them):
 * pig.stl is binary, with its triangle count in its header, and
 * sphere.stl a binary closed surface, which welding must close: every
 * edge then belongs to exactly two triangles. */
static void test_stl_cgal(void **state)
{
    (void)state;
    static const char *const files[] = {"build/cgal-data/meshes/pig.stl", "build/cgal-data/meshes/sphere.stl"};
    for (int f = 0; f < 2; f++) {
        Mesh m;
        char err[512];
        FILE *fp = fopen(files[f], "rb");
        if (!fp) {
            print_message("%s is missing: run make cgal-data\n", files[f]);
            skip();
        }
        unsigned char head[84];
        assert_int_equal(fread(head, 1, 84, fp), 84);
        fclose(fp);
        uint32_t n = head[80] | (uint32_t)head[81] << 8 | (uint32_t)head[82] << 16 | (uint32_t)head[83] << 24;
        if (mesh_load(files[f], &m, err, sizeof err) != 0)
            fail_msg("%s", err);
        assert_int_equal(mesh_validate(&m, err, sizeof err), 0);
        assert_int_equal(m.nt + m.nline + m.degenerate, (int)n);
        assert_true(m.nv < 3 * m.nt / 2); /* shared: about half as many vertices as triangles */
        if (f == 1) { /* each directed edge once, and its reverse once */
            int ne = 3 * m.nt, *key = malloc(sizeof(int) * 2 * (size_t)ne);
            assert_non_null(key);
            for (int i = 0; i < m.nt; i++)
                for (int k = 0; k < 3; k++) {
                    key[2 * (3 * i + k)] = m.tri[i][k];
                    key[2 * (3 * i + k) + 1] = m.tri[i][(k + 1) % 3];
                }
            for (int e = 0; e < ne; e++) {
                int a = key[2 * e], b = key[2 * e + 1], same = 0, rev = 0;
                for (int g = 0; g < ne; g++) {
                    same += key[2 * g] == a && key[2 * g + 1] == b;
                    rev += key[2 * g] == b && key[2 * g + 1] == a;
                }
                assert_int_equal(same, 1);
                assert_int_equal(rev, 1);
            }
            free(key);
        }
        mesh_free(&m);
    }
}

/* ---- counts of every good input, one table ---- */

typedef struct {
    const char *name;
    MeshFormat fmt;
    const char *text;
    size_t len;
    int nv, nt, nn, degenerate;
} CountCase;

#define COUNTS(name, fmt, text, nv, nt, nn, deg) {name, fmt, text, sizeof(text) - 1, nv, nt, nn, deg}

static const CountCase count_cases[] = {
    COUNTS("off tetrahedron", MESH_OFF, off_tetra, 4, 4, 0, 0),
    COUNTS("off counts on the header line, a byte-order mark, no final newline", MESH_OFF,
           "\xef\xbb\xbfOFF 3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2", 3, 1, 0, 0),
    COUNTS("COFF", MESH_OFF, "COFF\n3 1 0\n0 0 0 192 192 192 255\n1 0 0 0.5 0.5 0.5\n0 1 0 1 1 1 1\n3 0 1 2\n", 3,
           1, 0, 0),
    COUNTS("NOFF", MESH_OFF, "NOFF\n4 1 0\n0 0 0 0 0 1\n1 0 0 0 0 1\n1 1 0 0 0 2\n0 1 0 0 0.5 0.5\n4 0 1 2 3\n", 4,
           2, 4, 0),
    COUNTS("CNOFF", MESH_OFF, "CNOFF\n3 1 0\n0 0 0 0 0 1 1 0 0\n1 0 0 0 0 1 0 1 0 1\n0 1 0 0 0 1 0 0 1\n3 0 1 2\n", 3,
           1, 3, 0),
    COUNTS("off without faces, vertices nothing uses", MESH_OFF, "OFF\n2 0 0\n0 0 0\n1 1 1\n", 2, 0, 0, 0),
    COUNTS("off with nothing", MESH_OFF, "OFF\n0 0 0\n", 0, 0, 0, 0),
    COUNTS("off all degenerate: no triangles, no normals", MESH_OFF,
           "NOFF\n3 1 0\n0 0 0 0 0 1\n1 1 1 0 0 1\n2 2 2 0 0 1\n3 0 1 2\n", 3, 0, 0, 1),
    COUNTS("off huge and tiny coordinates (the collinear one kept apart: nline)", MESH_OFF,
           "OFF\n6 2 0\n-3e38 -3e38 0\n3e38 3e38 0\n1e38 1e38 0\n1e-45 0 0\n0 1e-45 0\n1e-45 1e-45 1e-45\n"
           "3 0 1 2\n3 3 4 5\n",
           6, 1, 0, 0),
    COUNTS("obj sample", MESH_OBJ, obj_sample, 5, 3, 0, 0),
    COUNTS("obj normals", MESH_OBJ, obj_normals, 4, 3, 4, 0),
    COUNTS("obj one face without normals: the file's normals are dropped for all", MESH_OBJ,
           "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1\nf 1 3 2\n", 3, 2, 0, 0),
    COUNTS("obj normals no face uses", MESH_OBJ, "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1 2 3\n", 3, 1, 0, 0),
    COUNTS("ply ascii", MESH_PLY, ply_ascii, 5, 3, 5, 0),
    COUNTS("ply CRLF, the face element first, no final newline", MESH_PLY,
           "ply\r\nformat ascii 1.0\r\nelement face 1\r\nproperty list uchar int vertex_indices\r\n"
           "element vertex 3\r\nproperty float x\r\nproperty float y\r\nproperty float z\r\nend_header\r\n"
           "3 0 1 2\r\n0 0 0\r\n1 0 0\r\n0 1 0",
           3, 1, 0, 0),
    COUNTS("obj with old Mac OS line endings, a lone CR each", MESH_OBJ,
           "v 0 0 0\rv 1 0 0\rv 0 1 0\r\rf 1 2 3\r", 3, 1, 0, 0),
    COUNTS("off with old Mac OS line endings", MESH_OFF, "OFF\r3 1 0\r0 0 0\r1 0 0\r0 1 0\r3 0 1 2", 3, 1, 0, 0),
    COUNTS("obj with lone CRs and a final LF, and a CR before a CRLF", MESH_OBJ,
           "v 0 0 0\rv 1 0 0\r\r\nv 0 1 0\rf 1 2 3\r\n", 3, 1, 0, 0),
    COUNTS("ply with blanks after the first line's 'ply'", MESH_PLY,
           "ply \t\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
           "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
           3, 1, 0, 0),
    COUNTS("ply point cloud", MESH_PLY,
           "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\n"
           "end_header\n1 2 3\n",
           1, 0, 0, 0),
    COUNTS("stl ascii", MESH_STL, stl_ascii, 4, 4, 0, 0),
    COUNTS("stl empty solid", MESH_STL, "solid nothing\nendsolid nothing\n", 0, 0, 0, 0),
};

/* Each good input loads with its counts, and its arrays are there exactly
 * when they hold something. */
static void test_counts(void **state)
{
    (void)state;
    for (size_t i = 0; i < sizeof count_cases / sizeof count_cases[0]; i++) {
        const CountCase *c = &count_cases[i];
        Mesh m;
        parse_ok_n(c->fmt, c->text, c->len, &m);
        if (m.nv != c->nv || m.nt != c->nt || m.nn != c->nn || m.degenerate != c->degenerate)
            fail_msg("case '%s': nv %d nt %d nn %d degenerate %d, expected %d %d %d %d", c->name, m.nv, m.nt, m.nn,
                     m.degenerate, c->nv, c->nt, c->nn, c->degenerate);
        if ((m.v != NULL) != (c->nv > 0) || (m.tri != NULL) != (c->nt > 0) || (m.n != NULL) != (c->nn > 0) ||
            (m.ntri != NULL) != (c->nn > 0))
            fail_msg("case '%s': arrays present or missing against the counts", c->name);
        mesh_free(&m);
        assert_true(mesh_is_empty(&m));
    }
}

/* ---- degenerate triangles ---- */

static void test_degenerate(void **state)
{
    (void)state;
    Mesh m;
    /* 0: fine; 1: repeated index; 2: collinear; 3: two vertices at the same
     * place; 4: collinear along a skew line (multiples of (1,2,3)/16, exact
     * in float); 5: a sliver one float ulp off the line through the origin
     * and (1,1,1), which has area and is kept; 6: three distinct vertices
     * at one place. 2, 3 and 4 have distinct corners not at one point:
     * kept after the others (nline), in order; 1 and 6 are dropped. */
    parse_ok(MESH_OFF,
             "OFF\n12 7 0\n"
             "0 0 0\n1 0 0\n0 1 0\n2 0 0\n0 1 0\n"
             "0.0625 0.125 0.1875\n0.125 0.25 0.375\n0.25 0.5 0.75\n"
             "1 1 1\n2 2 2.0000002\n1 0 0\n1 0 0\n"
             "3 0 1 2\n"
             "3 0 0 1\n"
             "3 0 1 3\n"
             "3 0 2 4\n"
             "3 5 6 7\n"
             "3 0 8 9\n"
             "3 1 10 11\n",
             &m);
    assert_int_equal(m.degenerate, 2);
    assert_int_equal(m.nt, 2);
    assert_int_equal(m.nline, 3);
    assert_tri(m.tri[0], 0, 1, 2);
    assert_tri(m.tri[1], 0, 8, 9);
    assert_tri(m.tri[2], 0, 1, 3);
    assert_tri(m.tri[3], 0, 2, 4);
    assert_tri(m.tri[4], 5, 6, 7);
    char err[256];
    assert_int_equal(mesh_validate(&m, err, sizeof err), 0);
    mesh_free(&m);

    /* a fan whose middle triangle is degenerate: the others stay, in order,
     * the collinear ones after them */
    parse_ok(MESH_OBJ, "v 0 0 0\nv 1 -1 0\nv 1 0 0\nv 2 0 0\nv 1 1 0\nf 1 2 3 4 5\nf 1 3 4\n", &m);
    assert_int_equal(m.degenerate, 0);
    assert_int_equal(m.nt, 2);
    assert_int_equal(m.nline, 2);
    assert_tri(m.tri[0], 0, 1, 2);
    assert_tri(m.tri[1], 0, 3, 4);
    assert_tri(m.tri[2], 0, 2, 3);
    assert_tri(m.tri[3], 0, 2, 3);
    mesh_free(&m);

    /* normals follow their triangles when some are set apart or dropped */
    parse_ok(MESH_OBJ,
             "v 0 0 0\nv 1 0 0\nv 2 0 0\nv 0 1 0\nvn 0 0 1\nvn 1 0 0\n"
             "f 1//1 2//1 3//1\nf 1//2 2//2 4//2\nf 1//1 1//2 2//1\n",
             &m);
    assert_int_equal(m.degenerate, 1);
    assert_int_equal(m.nt, 1);
    assert_int_equal(m.nline, 1);
    assert_tri(m.ntri[0], 1, 1, 1);
    assert_tri(m.tri[1], 0, 1, 2);
    assert_tri(m.ntri[1], 0, 0, 0);
    assert_int_equal(mesh_validate(&m, err, sizeof err), 0);
    /* the angle-weighted normals leave the collinear one's corners alone,
     * and give it its corners' normals */
    Mesh w;
    parse_ok(MESH_OFF, "OFF\n4 2 0\n0 0 0\n1 0 0\n2 0 0\n0 1 0\n3 0 1 3\n3 0 1 2\n", &w);
    assert_int_equal(w.nline, 1);
    assert_int_equal(mesh_vertex_normals(&w, err, sizeof err), 0);
    assert_tri(w.ntri[1], 0, 1, 2);
    assert_vec_near(w.n[0], 0, 0, 1);
    assert_vec_near(w.n[1], 0, 0, 1);
    assert_int_equal(mesh_validate(&w, err, sizeof err), 0);
    mesh_free(&w);
    mesh_free(&m);

    /* a mesh of collinear triangles alone has no triangles: all dropped */
    parse_ok(MESH_OFF, "OFF\n3 1 0\n0 0 0\n1 0 0\n2 0 0\n3 0 1 2\n", &m);
    assert_int_equal(m.nt, 0);
    assert_int_equal(m.nline, 0);
    assert_int_equal(m.degenerate, 1);
    mesh_free(&m);

    /* huge and tiny coordinates: exact, no overflow or underflow verdicts */
    parse_ok(MESH_OFF,
             "OFF\n6 2 0\n"
             "-3e38 -3e38 0\n3e38 3e38 0\n1e38 1e38 0\n"
             "1e-45 0 0\n0 1e-45 0\n1e-45 1e-45 1e-45\n"
             "3 0 1 2\n3 3 4 5\n",
             &m);
    assert_tri(m.tri[0], 3, 4, 5);
    mesh_free(&m);
}

/* ---- vertex normals ---- */

static void assert_unit(Vec3 n)
{
    assert_float_equal(vec_length(n), 1, 1e-6);
}

static void test_normals_tetra(void **state)
{
    (void)state;
    Mesh m;
    char err[256];
    parse_ok(MESH_OFF, off_tetra, &m);
    assert_int_equal(mesh_vertex_normals(&m, err, sizeof err), 0);
    assert_int_equal(mesh_validate(&m, err, sizeof err), 0);
    assert_int_equal(m.nn, 4);
    Vec3 centre = vec3(0.25f, 0.25f, 0.25f);
    for (int i = 0; i < 4; i++) {
        assert_unit(m.n[i]);
        assert_true(vec_dot(m.n[i], vec_sub(m.v[i], centre)) > 0.5f * vec_length(vec_sub(m.v[i], centre)));
    }
    /* the corner at the origin sees three right angles: the normal is the diagonal */
    float d = -1 / sqrtf(3);
    assert_vec(m.n[0], d, d, d, 1e-6f);
    for (int i = 0; i < m.nt; i++)
        assert_memory_equal(m.ntri[i], m.tri[i], sizeof m.tri[i]);
    mesh_free(&m);
}

/* A cube of 12 triangles: whichever diagonal splits a face, each face turns
 * 90 degrees around each of its corners, so angle weighting gives the exact
 * diagonal at every corner (area or uniform weights would not). */
static void test_normals_cube(void **state)
{
    (void)state;
    Mesh m;
    char err[256];
    parse_ok(MESH_OFF,
             "OFF\n8 6 0\n"
             "0 0 0\n1 0 0\n1 1 0\n0 1 0\n0 0 1\n1 0 1\n1 1 1\n0 1 1\n"
             "4 0 3 2 1\n4 4 5 6 7\n4 1 5 4 0\n4 2 3 7 6\n4 2 6 5 1\n4 0 4 7 3\n", /* diagonals mixed */
             &m);
    assert_int_equal(m.nt, 12);
    assert_int_equal(mesh_vertex_normals(&m, err, sizeof err), 0);
    assert_int_equal(mesh_validate(&m, err, sizeof err), 0);
    float d = 1 / sqrtf(3);
    for (int i = 0; i < 8; i++) {
        Vec3 p = m.v[i];
        assert_unit(m.n[i]);
        assert_vec(m.n[i], p.x > 0 ? d : -d, p.y > 0 ? d : -d, p.z > 0 ? d : -d, 1e-6f);
    }
    mesh_free(&m);
}

static void test_normals_flat_and_edge_cases(void **state)
{
    (void)state;
    Mesh m;
    char err[256];
    /* a flat, irregular pentagon tilted out of the axes: every normal is the face's */
    parse_ok(MESH_OBJ, "v 0 0 0\nv 2 0 2\nv 3 1 3\nv 1 3 1\nv -1 1 -1\nv 9 9 9\nf 1 2 3 4 5\n", &m);
    assert_int_equal(mesh_vertex_normals(&m, err, sizeof err), 0);
    assert_int_equal(mesh_validate(&m, err, sizeof err), 0);
    float h = 1 / sqrtf(2);
    for (int i = 0; i < 5; i++)
        assert_vec(m.n[i], -h, 0, h, 1e-6f);
    assert_vec(m.n[5], 0, 0, 0, 0); /* unused vertex */
    mesh_free(&m);

    /* the file's normals are replaced */
    parse_ok(MESH_OBJ, obj_normals, &m);
    assert_int_equal(mesh_vertex_normals(&m, err, sizeof err), 0);
    assert_int_equal(m.nn, 4);
    assert_int_equal(mesh_validate(&m, err, sizeof err), 0);
    mesh_free(&m);

    /* two faces back to back: the sums cancel, the first face's normal is used */
    parse_ok(MESH_OFF, "OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 2 1\n", &m);
    assert_int_equal(mesh_vertex_normals(&m, err, sizeof err), 0);
    for (int i = 0; i < 3; i++)
        assert_vec(m.n[i], 0, 0, 1, 0);
    mesh_free(&m);

    /* no triangles: no normals */
    parse_ok(MESH_OFF, "OFF\n1 0 0\n0 0 0\n", &m);
    assert_int_equal(mesh_vertex_normals(&m, err, sizeof err), 0);
    assert_null(m.n);
    assert_int_equal(mesh_validate(&m, err, sizeof err), 0);
    mesh_free(&m);
}

/* ---- bad inputs ---- */

typedef struct {
    const char *name;
    MeshFormat fmt;
    const char *text;
    size_t len; /* the text may hold a NUL byte */
    const char *want;
} BadCase;

#define BAD(name, fmt, text, want) {name, fmt, text, sizeof(text) - 1, want}

/* OFF: a triangle whose fault (or whose file's fault) is in the marked line */
#define OFF3 "OFF\n3 1 0\n"
/* a comment line after the data (the text's words are kept for the columns
 * of the messages at the file's end) */
#define PAD "# a comment to pad the file, so that the announced counts still fit in its size\n"

/* PLY ascii: a header of 9 lines, so vertex data start on line 10 */
#define PLYH(nv, nf)                                                                                                   \
    "ply\nformat ascii 1.0\nelement vertex " #nv "\nproperty float x\nproperty float y\nproperty float z\n"            \
    "element face " #nf "\nproperty list uchar int vertex_indices\nend_header\n"

static const BadCase bad_cases[] = {
    /* ---- OFF ---- */
    BAD("off empty", MESH_OFF, "", "t.off:1:1: empty file: no OFF header or counts line"),
    BAD("off only comments", MESH_OFF, "# nothing\n\n", "t.off:2:1: empty file: no OFF header or counts line"),
    BAD("off no counts", MESH_OFF, "OFF\n# counts?\n", "t.off:2:10: file ends before the counts line"),
    BAD("off 4D", MESH_OFF, "4OFF\n", "t.off:1:1: unsupported OFF variant '4OFF' (OFF, COFF, NOFF and CNOFF are read)"),
    BAD("off ST", MESH_OFF, "STOFF\n", "t.off:1:1: unsupported OFF variant 'STOFF' (OFF, COFF, NOFF and CNOFF are read)"),
    BAD("off CC", MESH_OFF, "CCOFF\n", "t.off:1:1: unsupported OFF variant 'CCOFF' (OFF, COFF, NOFF and CNOFF are read)"),
    BAD("off binary", MESH_OFF, "OFF BINARY\n", "t.off:1:5: binary OFF is not supported"),
    BAD("off not off", MESH_OFF, "ply\nformat ascii 1.0\n",
        "t.off:1:1: expected an OFF header or the counts line, got 'ply'"),
    BAD("off counts 2", MESH_OFF, "OFF\n3 1\n", "t.off:2:1: counts line has 2 values, expected 3 (vertices faces edges)"),
    BAD("off counts 4", MESH_OFF, "OFF\n3 1 0 0\n",
        "t.off:2:1: counts line has 4 values, expected 3 (vertices faces edges)"),
    BAD("off count malformed", MESH_OFF, "OFF\n3 1.0 0\n", "t.off:2:3: malformed count '1.0'"),
    BAD("off count negative", MESH_OFF, "OFF\n-3 1 0\n", "t.off:2:1: negative count '-3'"),
    BAD("off huge vertex count", MESH_OFF, "OFF\n1000000000000 1 0\n0 0 0\n",
        "t.off:2:1: 1000000000000 vertices announced, more than 2147483647"),
    BAD("off overflowing vertex count", MESH_OFF, "OFF\n99999999999999999999999 1 0\n0 0 0\n",
        "t.off:2:1: 99999999999999999999999 vertices announced, more than 2147483647"),
    /* counts that the bytes cannot hold: the reading says where they end, or
     * which line is short, with arrays no larger than the bytes can fill */
    BAD("off vertex count past the bytes", MESH_OFF, "OFF\n1000000 1 0\n0 0 0\n",
        "t.off:3:6: file ends after 1 of 1000000 vertices"),
    BAD("off huge face count", MESH_OFF, "OFF 3 1000000000000 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
        "t.off:5:8: file ends after 1 of 1000000000000 faces"),
    BAD("off overflowing face count", MESH_OFF, "OFF 3 99999999999999999999999 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2",
        "t.off:5:8: file ends after 1 of 99999999999999999999999 faces"),
    BAD("off short vertex line in a near-minimal file", MESH_OFF, OFF3 "0 0 0\n1 0\n0 1 0\n3 0 1 2\n",
        "t.off:4:1: vertex line has 2 values, expected 3"),
    BAD("off truncated vertices", MESH_OFF, "OFF\n4 1 0\n0 0 0\n1 0 0\n" PAD,
        "t.off:5:80: file ends after 2 of 4 vertices"),
    BAD("off truncated faces", MESH_OFF, "OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n" PAD,
        "t.off:7:80: file ends after 1 of 2 faces"),
    BAD("off truncated face line", MESH_OFF, OFF3 "0 0 0\n1 0 0\n0 1 0\n4 0 1 2\n",
        "t.off:6:1: face lists 3 of its 4 corners"),
    BAD("off truncated vertex line", MESH_OFF, OFF3 "0 0 0\n1 0\n0 1 0\n3 0 1 2\n" PAD,
        "t.off:4:1: vertex line has 2 values, expected 3"),
    BAD("off too many vertex values", MESH_OFF, OFF3 "0 0 0\n1 0 0 0.5\n0 1 0\n3 0 1 2\n",
        "t.off:4:1: vertex line has 4 values, expected 3"),
    BAD("off fewer vertices than announced", MESH_OFF, "OFF\n4 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n" PAD,
        "t.off:6:1: vertex line has 4 values, expected 3 (a face line: fewer vertices than announced?)"),
    BAD("off more vertices than announced", MESH_OFF, "OFF\n2 1 0\n0 0 0\n1 0 0\n0.5 1 0\n3 0 1 2\n",
        "t.off:5:1: malformed corner count '0.5' (a vertex line: more vertices than announced?)"),
    BAD("off extra face", MESH_OFF, OFF3 "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 2 1\n",
        "t.off:7:1: extra data after the 1 face announced"),
    BAD("off extra junk", MESH_OFF, "OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 2 1\n\nend\n",
        "t.off:9:1: extra data after the 2 faces announced"),
    BAD("off NOFF without normals", MESH_OFF, "NOFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n" PAD,
        "t.off:3:1: vertex line has 3 values, expected 6 (position, normal)"),
    BAD("off COFF without colour", MESH_OFF, "COFF\n3 1 0\n0 0 0 1 1 1\n1 0 0\n0 1 0 1 1 1\n3 0 1 2\n" PAD,
        "t.off:4:1: vertex line has 3 values, expected 6 or 7 (position, colour)"),
    BAD("off index out of range", MESH_OFF, OFF3 "0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n",
        "t.off:6:7: vertex index 3 out of range (3 vertices)"),
    BAD("off negative index", MESH_OFF, OFF3 "0 0 0\n1 0 0\n0 1 0\n3 0 -1 2\n",
        "t.off:6:5: vertex index -1 out of range (3 vertices)"),
    BAD("off huge index", MESH_OFF, OFF3 "0 0 0\n1 0 0\n0 1 0\n3 0 1 4294967298\n",
        "t.off:6:7: vertex index 4294967298 out of range (3 vertices)"),
    /* past 64 bits, as written (it was echoed saturated) */
    BAD("off index past 64 bits", MESH_OFF, OFF3 "0 0 0\n1 0 0\n0 1 0\n3 0 1 99999999999999999999\n",
        "t.off:6:7: vertex index 99999999999999999999 out of range (3 vertices)"),
    BAD("obj index past 64 bits", MESH_OBJ, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 99999999999999999999\n",
        "t.obj:4:7: vertex index 99999999999999999999 out of range (3 vertices)"),
    BAD("off nan", MESH_OFF, OFF3 "0 0 0\nnan 0 0\n0 1 0\n3 0 1 2\n", "t.off:4:1: non-finite coordinate 'nan'"),
    BAD("off -inf", MESH_OFF, OFF3 "0 0 0\n1 0 0\n0 -inf 0\n3 0 1 2\n", "t.off:5:3: non-finite coordinate '-inf'"),
    BAD("off Infinity", MESH_OFF, OFF3 "0 0 Infinity\n1 0 0\n0 1 0\n3 0 1 2\n",
        "t.off:3:5: non-finite coordinate 'Infinity'"),
    BAD("off 1e999", MESH_OFF, OFF3 "0 0 0\n1 0 1e999\n0 1 0\n3 0 1 2\n", "t.off:4:5: non-finite coordinate '1e999'"),
    BAD("off 1e39 float overflow", MESH_OFF, OFF3 "0 0 0\n1 0 0\n-1e39 1 0\n3 0 1 2\n",
        "t.off:5:1: non-finite coordinate '-1e39'"),
    BAD("off nan normal", MESH_OFF, "NOFF\n3 1 0\n0 0 0 0 0 1\n1 0 0 0 NaN 1\n0 1 0 0 0 1\n3 0 1 2\n",
        "t.off:4:9: non-finite normal component 'NaN'"),
    BAD("off malformed 1.2.3", MESH_OFF, OFF3 "0 0 0\n1.2.3 0 0\n0 1 0\n3 0 1 2\n",
        "t.off:4:1: malformed number '1.2.3'"),
    BAD("off malformed hex", MESH_OFF, OFF3 "0 0 0\n1 0 0\n0 0x1 0\n3 0 1 2\n", "t.off:5:3: malformed number '0x1'"),
    BAD("off malformed 1e", MESH_OFF, OFF3 "0 0 0\n1 0 0\n0 1 1e\n3 0 1 2\n", "t.off:5:5: malformed number '1e'"),
    BAD("off malformed comma", MESH_OFF, OFF3 "0 0 0\n1,5 0 0\n0 1 0\n3 0 1 2\n", "t.off:4:1: malformed number '1,5'"),
    BAD("off NUL byte", MESH_OFF, OFF3 "0 0 0\n1 0\0 0\n0 1 0\n3 0 1 2\n", "t.off:4:3: malformed number '0?'"),
    BAD("off long number", MESH_OFF,
        OFF3 "0 0 0\n1 0 0\n0 1 "
             "0.000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000"
             "0000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000"
             "0000000000000000000000000000000000000000000000000000000000000000000000000000000000000001\n3 0 1 2\n",
        "t.off:5:5: number longer than 255 characters '0.00000000000000000000000000000000000000...'"),
    BAD("off malformed index", MESH_OFF, OFF3 "0 0 0\n1 0 0\n0 1 0\n3 0 1.0 2\n",
        "t.off:6:5: malformed vertex index '1.0'"),
    BAD("off malformed corner count", MESH_OFF, OFF3 "0 0 0\n1 0 0\n0 1 0\nthree 0 1 2\n",
        "t.off:6:1: malformed corner count 'three'"),
    BAD("off two corners", MESH_OFF, OFF3 "0 0 0\n1 0 0\n0 1 0\n2 0 1\n" PAD,
        "t.off:6:1: face with 2 corners (at least 3 needed)"),
    BAD("off zero corners", MESH_OFF, OFF3 "0 0 0\n1 0 0\n0 1 0\n0\n" PAD,
        "t.off:6:1: face with 0 corners (at least 3 needed)"),
    /* without the padding too: the counts' bound takes a face to be at least
     * "0\n", so the face's own error speaks (it blamed the counts) */
    BAD("off two corners, short file", MESH_OFF, OFF3 "0 0 0\n1 0 0\n0 1 0\n2 0 1\n",
        "t.off:6:1: face with 2 corners (at least 3 needed)"),
    BAD("off zero corners, short file", MESH_OFF, OFF3 "0 0 0\n1 0 0\n0 1 0\n0",
        "t.off:6:1: face with 0 corners (at least 3 needed)"),
    BAD("off colour too long", MESH_OFF, OFF3 "0 0 0\n1 0 0\n0 1 0\n3 0 1 2 1 1 1 1 1\n",
        "t.off:6:1: face has 5 values after its 3 corners, at most 4 (a colour) allowed"),
    BAD("off colour malformed", MESH_OFF, OFF3 "0 0 0\n1 0 0\n0 1 0\n3 0 1 2 red\n",
        "t.off:6:9: malformed number 'red'"),

    /* ---- OBJ (no counts: truncation shows as a short line or face) ---- */
    /* columns count bytes from each line's start: after "\r\n", after a lone
     * CR, and after the byte-order mark on the first line; blanks count */
    BAD("obj column crlf", MESH_OBJ, "v 0 0 0\r\nv 1 0 0\r\nv 0 1 0\r\nf 1 2  9\r\n",
        "t.obj:4:8: vertex index 9 out of range (3 vertices)"),
    BAD("obj column lone cr", MESH_OBJ, "v 0 0 0\rv 1 0 0\rv 0 1 0\r\tf 1 2 9\r",
        "t.obj:4:8: vertex index 9 out of range (3 vertices)"),
    BAD("obj column bom", MESH_OBJ, "\xef\xbb\xbfv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 3 2 1 0x\n",
        "t.obj:5:9: malformed vertex index '0x'"),
    BAD("obj column bom first line", MESH_OBJ, "\xef\xbb\xbf  f 1 2 3\n", "t.obj:1:5: vertex index 1 out of range (0 vertices)"),
    BAD("obj line column", MESH_OBJ, "v 0 0 0\n  vn 1 0\n", "t.obj:2:3: 'vn' takes 3 numbers, got 2"),
    BAD("obj v short", MESH_OBJ, "v 0 0 0\nv 1 0\n", "t.obj:2:1: 'v' takes 3 or 4 numbers (or 6 with a colour), got 2"),
    BAD("obj v 5 values", MESH_OBJ, "v 0 0 0 1 1\n", "t.obj:1:1: 'v' takes 3 or 4 numbers (or 6 with a colour), got 5"),
    BAD("obj vn short", MESH_OBJ, "vn 0 1\n", "t.obj:1:1: 'vn' takes 3 numbers, got 2"),
    BAD("obj nan", MESH_OBJ, "v 0 0 0\nv 0 nan 0\n", "t.obj:2:5: non-finite coordinate 'nan'"),
    BAD("obj inf", MESH_OBJ, "v 0 0 0\nv 0 0 +INF\n", "t.obj:2:7: non-finite coordinate '+INF'"),
    BAD("obj 1e999", MESH_OBJ, "# c\nv 1e999 0 0\n", "t.obj:2:3: non-finite coordinate '1e999'"),
    BAD("obj -1e39", MESH_OBJ, "v 0 -1e39 0\n", "t.obj:1:5: non-finite coordinate '-1e39'"),
    BAD("obj normal inf", MESH_OBJ, "vn inf 0 0\n", "t.obj:1:4: non-finite normal component 'inf'"),
    BAD("obj malformed", MESH_OBJ, "v 0 0 0,5\n", "t.obj:1:7: malformed number '0,5'"),
    BAD("obj malformed w", MESH_OBJ, "v 0 0 0 w\n", "t.obj:1:9: malformed number 'w'"),
    BAD("obj index out of range", MESH_OBJ, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n",
        "t.obj:4:7: vertex index 4 out of range (3 vertices)"),
    BAD("obj relative out of range", MESH_OBJ, "v 0 0 0\nv 1 0 0\nf -1 -2 -3\nv 0 1 0\n",
        "t.obj:3:9: relative vertex index -3 out of range (2 vertices defined so far)"),
    BAD("obj index zero", MESH_OBJ, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n",
        "t.obj:4:3: vertex index 0 is invalid (OBJ indices start at 1)"),
    BAD("obj normal out of range", MESH_OBJ, "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nvn 0 0 1\nf 1//1 2//3 3//1\n",
        "t.obj:6:11: normal index 3 out of range (2 normals)"),
    BAD("obj texture out of range", MESH_OBJ, "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/1 2/-2 3/1\n",
        "t.obj:5:9: relative texture coordinate index -2 out of range (1 texture coordinates defined so far)"),
    BAD("obj malformed index", MESH_OBJ, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 b 3\n", "t.obj:4:5: malformed vertex index 'b'"),
    BAD("obj corner trailing slash", MESH_OBJ, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/ 2 3\n",
        "t.obj:4:3: malformed face corner '1/'"),
    BAD("obj corner empty normal", MESH_OBJ, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1// 2 3\n",
        "t.obj:4:3: malformed face corner '1//'"),
    BAD("obj corner four parts", MESH_OBJ, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1/1/1 2 3\n",
        "t.obj:4:3: malformed face corner '1/1/1/1'"),
    BAD("obj corner no vertex", MESH_OBJ, "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf /1 2 3\n",
        "t.obj:5:3: malformed face corner '/1'"),
    BAD("obj mixed normals", MESH_OBJ, "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3\n",
        "t.obj:5:13: face mixes corners with and without normals"),
    BAD("obj two corners", MESH_OBJ, "v 0 0 0\nv 1 0 0\nf 1 2\n", "t.obj:3:1: face with 2 corners (at least 3 needed)"),
    BAD("obj no corners", MESH_OBJ, "v 0 0 0\nf # nothing\n", "t.obj:2:1: face with 0 corners (at least 3 needed)"),
    BAD("obj unknown statement", MESH_OBJ, "v 0 0 0\n3 0 1 2\n", "t.obj:2:1: unknown statement '3'"),
    BAD("obj NUL byte", MESH_OBJ, "v 0 0 0\n\0 1 2\n", "t.obj:2:1: unknown statement '?'"),

    /* ---- STL, ASCII ---- */
    /* the end of the file: just past the last line's last byte, before its CR LF */
    BAD("stl end column crlf", MESH_STL, "solid a\r\nfacet normal 0 0 1\r\n",
        "t.stl:2:19: file ends where 'outer' should follow the facet normal"),
    BAD("stl empty", MESH_STL, "", "t.stl:1:1: not an STL file: 0 bytes, and no 'solid' for ASCII STL (binary STL "
                                   "takes at least 84 bytes)"),
    BAD("stl not stl", MESH_STL, "OFF\n3 1 0\n", "t.stl:1:1: not an STL file: 10 bytes, and no 'solid' for ASCII STL "
                                                 "(binary STL takes at least 84 bytes)"),
    BAD("stl no endsolid", MESH_STL, "solid a\nfacet normal 0 0 1 outer loop vertex 0 0 0 vertex 1 0 0 vertex 0 1 0\n"
                                     "endloop endfacet\n",
        "t.stl:3:17: file ends before 'endsolid'"),
    BAD("stl no facet", MESH_STL, "solid a\nfacets normal 0 0 1\n",
        "t.stl:2:1: expected 'facet' or 'endsolid', got 'facets'"),
    BAD("stl no normal", MESH_STL, "solid a\nfacet outer loop\n", "t.stl:2:7: expected 'normal' after 'facet', got 'outer'"),
    BAD("stl short normal", MESH_STL, "solid a\nfacet normal 0 0 outer loop\n", "t.stl:2:18: malformed number 'outer'"),
    BAD("stl no loop", MESH_STL, "solid a\nfacet normal 0 0 1 outer\nvertex 0 0 0\n",
        "t.stl:3:1: expected 'loop' after 'outer', got 'vertex'"),
    BAD("stl bad vertex", MESH_STL, "solid a\nfacet normal 0 0 1 outer loop\nvertex 0 0 0\nvertex 1 0\nvertex 0 1 0\n",
        "t.stl:5:1: malformed number 'vertex'"),
    BAD("stl nan vertex", MESH_STL, "solid a\nfacet normal 0 0 1 outer loop\nvertex 0 0 0\nvertex 1 0 nan\n",
        "t.stl:4:12: non-finite coordinate 'nan'"),
    BAD("stl 1e39 vertex", MESH_STL, "solid a\nfacet normal 0 0 1 outer loop\nvertex 0 0 0\nvertex 1e39 0 0\n",
        "t.stl:4:8: non-finite coordinate '1e39'"),
    BAD("stl two vertices", MESH_STL, "solid a\nfacet normal 0 0 1 outer loop\nvertex 0 0 0\nvertex 1 0 0\nendloop\n"
                                      "endfacet\nendsolid a\n",
        "t.stl:5:1: facet with 2 vertices (at least 3 needed)"),
    BAD("stl no endloop", MESH_STL, "solid a\nfacet normal 0 0 1 outer loop\nvertex 0 0 0\nvertex 1 0 0\n"
                                    "vertex 0 1 0\nendfacet\n",
        "t.stl:6:1: expected 'vertex' or 'endloop', got 'endfacet'"),
    BAD("stl no endfacet", MESH_STL, "solid a\nfacet normal 0 0 1 outer loop\nvertex 0 0 0\nvertex 1 0 0\n"
                                     "vertex 0 1 0\nendloop\nendsolid a\n",
        "t.stl:7:1: expected 'endfacet' after 'endloop', got 'endsolid'"),
    BAD("stl junk after", MESH_STL, "solid a\nendsolid a\n\njunk\n",
        "t.stl:4:1: expected 'solid' or the end of the file, got 'junk'"),
    BAD("stl truncated", MESH_STL, "solid a\nfacet normal 0 0 1 outer loop\nvertex 0 0",
        "t.stl:3:11: file ends inside 'vertex' (3 numbers)"),
    BAD("stl NUL byte", MESH_STL, "solid a\nfacet normal 0 0 1 outer loop\nvertex 0 \0 0\n",
        "t.stl:3:10: malformed number '?'"),

    /* ---- PLY, ASCII ---- */
    BAD("ply empty", MESH_PLY, "", "t.ply:1:1: not a PLY file (the first line must be 'ply')"),
    BAD("ply not ply", MESH_PLY, "OFF\n3 1 0\n", "t.ply:1:1: not a PLY file (the first line must be 'ply')"),
    BAD("ply no end_header", MESH_PLY, "ply\nformat ascii 1.0\nelement vertex 0\n",
        "t.ply:3:17: header has no 'end_header' line"),
    BAD("ply no format", MESH_PLY, "ply\nelement vertex 0\nend_header\n", "t.ply:3:1: the header has no 'format' line"),
    BAD("ply big endian", MESH_PLY, "ply\nformat binary_big_endian 1.0\nend_header\n",
        "t.ply:2:8: binary_big_endian PLY is not supported (ascii and binary_little_endian are)"),
    BAD("ply unknown format", MESH_PLY, "ply\nformat text 1.0\nend_header\n", "t.ply:2:8: unknown PLY format 'text'"),
    BAD("ply version", MESH_PLY, "ply\nformat ascii 2.0\nend_header\n",
        "t.ply:2:14: unsupported PLY version '2.0' (1.0 is read)"),
    BAD("ply two formats", MESH_PLY, "ply\nformat ascii 1.0\nformat ascii 1.0\nend_header\n",
        "t.ply:3:1: second 'format' line"),
    BAD("ply unknown keyword", MESH_PLY, "ply\nformat ascii 1.0\nelemnt vertex 3\nend_header\n",
        "t.ply:3:1: unknown header keyword 'elemnt'"),
    BAD("ply property first", MESH_PLY, "ply\nformat ascii 1.0\nproperty float x\nend_header\n",
        "t.ply:3:1: 'property' before any 'element'"),
    BAD("ply unknown type", MESH_PLY, "ply\nformat ascii 1.0\nelement vertex 1\nproperty float16 x\nend_header\n",
        "t.ply:4:10: unknown property type 'float16'"),
    BAD("ply float list count", MESH_PLY,
        "ply\nformat ascii 1.0\nelement vertex 1\nproperty list float int x\nend_header\n",
        "t.ply:4:15: list count type must be an integer type, not 'float'"),
    BAD("ply duplicate property", MESH_PLY,
        "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty double x\nend_header\n",
        "t.ply:5:17: second property 'x' in element 'vertex'"),
    BAD("ply duplicate element", MESH_PLY,
        "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nelement vertex 2\nend_header\n",
        "t.ply:5:9: second 'vertex' element"),
    BAD("ply malformed element count", MESH_PLY, "ply\nformat ascii 1.0\nelement vertex -1\nend_header\n",
        "t.ply:3:16: malformed element count '-1'"),
    BAD("ply no vertex", MESH_PLY, "ply\nformat ascii 1.0\nelement face 0\nend_header\n",
        "t.ply:4:1: no 'vertex' element"),
    BAD("ply no z", MESH_PLY,
        "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nend_header\n0 0\n",
        "t.ply:3:9: 'vertex' element has no property 'z'"),
    BAD("ply list x", MESH_PLY,
        "ply\nformat ascii 1.0\nelement vertex 1\nproperty list uchar float x\nproperty float y\nproperty float z\n"
        "end_header\n",
        "t.ply:3:9: vertex property 'x' is a list, not a number"),
    BAD("ply partial normals", MESH_PLY,
        "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\n"
        "property float nx\nproperty float nz\nend_header\n0 0 0 0 1\n",
        "t.ply:3:9: 'vertex' element has some of nx, ny, nz but not all three"),
    BAD("ply no vertex_indices", MESH_PLY,
        "ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nproperty float y\nproperty float z\n"
        "element face 0\nproperty list uchar int indices\nend_header\n",
        "t.ply:7:9: 'face' element has no 'vertex_indices' list"),
    BAD("ply float vertex_indices", MESH_PLY,
        "ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nproperty float y\nproperty float z\n"
        "element face 0\nproperty list uchar float vertex_indices\nend_header\n",
        "t.ply:7:9: face property 'vertex_indices' must have an integer item type"),
    BAD("ply huge vertex count", MESH_PLY, PLYH(1000000000000, 1) "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
        "t.ply:3:16: 1000000000000 vertices announced, more than 2147483647"),
    BAD("ply vertex count past the bytes", MESH_PLY, PLYH(1000000, 1) "0 0 0\n1 0 0\n0 1 0\n",
        "t.ply:12:6: file ends after 3 of 1000000 'vertex' elements"),
    /* the vertex begun in the last of the bytes, one more than whole lines
     * fill (the sanitized build checks that its values have room) */
    BAD("ply vertex begun in the last byte", MESH_PLY, PLYH(1000, 1) "0 0 0\n0",
        "t.ply:11:1: too few values for a 'vertex' element (no 'y')"),
    BAD("ply huge face count", MESH_PLY, PLYH(3, 1000000000000) "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
        "t.ply:13:8: file ends after 1 of 1000000000000 'face' elements"),
    BAD("ply short vertex line in a near-minimal file", MESH_PLY, PLYH(3, 1) "0 0 0\n1 0\n0 1 0\n3 0 1 2\n",
        "t.ply:11:1: too few values for a 'vertex' element (no 'z')"),
    BAD("ply truncated vertices", MESH_PLY, PLYH(3, 1) "0.0000 0.0000 0.0000\n1.0000 0.0000 0.0000\n",
        "t.ply:11:21: file ends after 2 of 3 'vertex' elements"),
    BAD("ply truncated faces", MESH_PLY, PLYH(3, 2) "0.0000 0.0000 0.0000\n1 0 0\n0 1 0\n3 0 1 2\n",
        "t.ply:13:8: file ends after 1 of 2 'face' elements"),
    BAD("ply too few values", MESH_PLY, PLYH(3, 1) "0 0 0\n1 0\n0 1 0\n3 0 1 2\n" PAD,
        "t.ply:11:1: too few values for a 'vertex' element (no 'z')"),
    BAD("ply too many values", MESH_PLY, PLYH(3, 1) "0 0 0\n1 0 0 0\n0 1 0\n3 0 1 2\n",
        "t.ply:11:7: too many values for a 'vertex' element"),
    BAD("ply extra line", MESH_PLY, PLYH(3, 1) "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 2 1\n",
        "t.ply:14:1: extra data after the announced elements"),
    BAD("ply face lists too few", MESH_PLY, PLYH(3, 1) "0 0 0\n1 0 0\n0 1 0\n4 0 1 2\n",
        "t.ply:13:1: face lists 3 of its 4 corners"),
    BAD("ply other list too short", MESH_PLY,
        "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\n"
        "property list uchar int extra\nend_header\n0 0 0 3 1 2\n" PAD,
        "t.ply:9:1: too few values for a 'vertex' element (list 'extra' announces 3)"),
    BAD("ply two corners", MESH_PLY, PLYH(3, 1) "0 0 0\n1 0 0\n0 1 0\n2 0 1\n" PAD,
        "t.ply:13:1: face with 2 corners (at least 3 needed)"),
    BAD("ply index out of range", MESH_PLY, PLYH(3, 1) "0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n",
        "t.ply:13:7: vertex index 3 out of range (3 vertices)"),
    BAD("ply negative index", MESH_PLY, PLYH(3, 1) "0 0 0\n1 0 0\n0 1 0\n3 0 -1 2\n",
        "t.ply:13:5: vertex index -1 out of range (3 vertices)"),
    BAD("ply negative list count", MESH_PLY, PLYH(3, 1) "0 0 0\n1 0 0\n0 1 0\n-3 0 1 2\n",
        "t.ply:13:1: negative list count -3"),
    BAD("ply nan", MESH_PLY, PLYH(3, 1) "0 0 0\n1 nan 0\n0 1 0\n3 0 1 2\n", "t.ply:11:3: non-finite coordinate 'nan'"),
    BAD("ply 1e999", MESH_PLY, PLYH(3, 1) "0 0 1e999\n1 0 0\n0 1 0\n3 0 1 2\n",
        "t.ply:10:5: non-finite coordinate '1e999'"),
    BAD("ply malformed", MESH_PLY, PLYH(3, 1) "0 0 0\n1 0 0\n0 1.0.0 0\n3 0 1 2\n",
        "t.ply:12:3: malformed number '1.0.0'"),
    BAD("ply malformed index", MESH_PLY, PLYH(3, 1) "0 0 0\n1 0 0\n0 1 0\n3 0 x 2\n",
        "t.ply:13:5: malformed vertex index 'x'"),
    BAD("ply malformed integer", MESH_PLY,
        "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\n"
        "property uchar red\nend_header\n0 0 0 1.5\n",
        "t.ply:9:7: malformed integer '1.5'"),
    BAD("ply integer coordinate", MESH_PLY,
        "ply\nformat ascii 1.0\nelement vertex 1\nproperty int x\nproperty float y\nproperty float z\n"
        "end_header\n0.5 0 0\n",
        "t.ply:8:1: malformed integer '0.5'"),
};

static void test_bad_inputs(void **state)
{
    (void)state;
    for (size_t i = 0; i < sizeof bad_cases / sizeof bad_cases[0]; i++) {
        const BadCase *c = &bad_cases[i];
        Mesh m;
        char err[512] = "";
        memset(&m, 0x5a, sizeof m);
        int rc = parse_n(c->fmt, c->text, c->len, &m, err, sizeof err);
        if (rc == 0) {
            mesh_free(&m);
            fail_msg("case '%s': accepted, expected: %s", c->name, c->want);
        }
        if (strcmp(err, c->want) != 0)
            fail_msg("case '%s': wrong message\n  got:  %s\n  want: %s", c->name, err, c->want);
        if (!mesh_is_empty(&m))
            fail_msg("case '%s': mesh not left empty", c->name);
    }
}

/* Binary PLY faults, each reported on the line of the element's header
 * statement with the byte offset of the fault. */
static void test_bad_binary(void **state)
{
    (void)state;
    Buf B, C;
    size_t face2;
    char want[256];
    binary_sample(&B, &face2);
    size_t data = strlen("ply\nformat binary_little_endian 1.0\ncomment written by test_mesh\n"
                         "element face 2\nproperty uchar flags\nproperty list uchar int vertex_indices\n"
                         "property list uchar float texcoord\nelement vertex 4\nproperty double x\nproperty float y\n"
                         "property short z\nproperty uchar red\nproperty list ushort uint extra\n"
                         "element material 2\nproperty uchar r\nproperty double shininess\nend_header\n");
    /* vertex records: 8 + 4 + 2 + 1 + 2 + 4i bytes */
    size_t vert0 = face2 + 1 + 1 + 12 + 1;
    size_t vert2 = vert0 + 17 + 21;
    size_t mat0 = vert2 + 25 + 29;
    assert_int_equal(face2, data + 27);
    assert_int_equal(B.n, mat0 + 18);

    /* cut inside the faces or the vertices: the bytes left cannot hold the
     * counts (2 faces of at least 15 bytes, 4 vertices of at least 17) */
    snprintf(want, sizeof want,
             "t.ply:8:16: 4 'vertex' elements announced, more than the %zu bytes after the header can hold",
             face2 + 3 - data);
    expect_error_n(MESH_PLY, (const char *)B.b, face2 + 3, want);
    snprintf(want, sizeof want,
             "t.ply:8:16: 4 'vertex' elements announced, more than the %zu bytes after the header can hold",
             vert2 + 8 - data);
    expect_error_n(MESH_PLY, (const char *)B.b, vert2 + 8, want);
    /* cut within the slack that lists longer than their minimum leave: the
     * instance that runs out is found while reading */
    snprintf(want, sizeof want, "t.ply:8:9: file ends after 3 of 4 'vertex' elements at byte offset %zu", mat0 - 1);
    expect_error_n(MESH_PLY, (const char *)B.b, mat0 - 1, want);
    snprintf(want, sizeof want, "t.ply:14:9: file ends after 1 of 2 'material' elements at byte offset %zu",
             B.n - 1);
    expect_error_n(MESH_PLY, (const char *)B.b, B.n - 1, want);

    /* a byte too many */
    C = B;
    put_u8(&C, 0);
    snprintf(want, sizeof want, "t.ply:17:1: 1 byte of extra data after the announced elements at byte offset %zu",
             B.n);
    expect_error_n(MESH_PLY, (const char *)C.b, C.n, want);

    /* index out of range, negative index, two corners, huge count */
    C = B;
    C.b[face2 + 2 + 4] = 4; /* second face's second index: 1 -> 4 */
    snprintf(want, sizeof want, "t.ply:4:9: vertex index 4 out of range (4 vertices) at byte offset %zu",
             face2 + 2 + 4);
    expect_error_n(MESH_PLY, (const char *)C.b, C.n, want);
    C = B;
    memset(C.b + face2 + 2, 0xff, 4); /* -1 */
    snprintf(want, sizeof want, "t.ply:4:9: vertex index -1 out of range (4 vertices) at byte offset %zu", face2 + 2);
    expect_error_n(MESH_PLY, (const char *)C.b, C.n, want);
    C = B;
    C.b[face2 + 1] = 2;
    snprintf(want, sizeof want, "t.ply:4:9: face with 2 corners (at least 3 needed) at byte offset %zu", face2 + 1);
    expect_error_n(MESH_PLY, (const char *)C.b, C.n, want);
    C = B;
    C.b[face2 + 1] = 250; /* the list runs past the end of the file */
    snprintf(want, sizeof want, "t.ply:4:9: file ends after 1 of 2 'face' elements at byte offset %zu", B.n);
    expect_error_n(MESH_PLY, (const char *)C.b, C.n, want);
    C = B;
    C.b[vert2 + 15] = 0xff, C.b[vert2 + 16] = 0xff; /* extra list of 65535 uint */
    snprintf(want, sizeof want, "t.ply:8:9: file ends after 2 of 4 'vertex' elements at byte offset %zu", B.n);
    expect_error_n(MESH_PLY, (const char *)C.b, C.n, want);

    /* non-finite coordinates: a double NaN, a double too large for float, a float inf */
    C = B;
    double nan_d = NAN, big = 1e300;
    float inf_f = INFINITY;
    memcpy(C.b + vert2, &nan_d, 8);
    snprintf(want, sizeof want, "t.ply:8:9: non-finite coordinate nan in vertex 2 at byte offset %zu", vert2);
    expect_error_n(MESH_PLY, (const char *)C.b, C.n, want);
    C = B;
    memcpy(C.b + vert0, &big, 8);
    snprintf(want, sizeof want, "t.ply:8:9: non-finite coordinate 1e+300 in vertex 0 at byte offset %zu", vert0);
    expect_error_n(MESH_PLY, (const char *)C.b, C.n, want);
    C = B;
    memcpy(C.b + vert0 + 8, &inf_f, 4);
    snprintf(want, sizeof want, "t.ply:8:9: non-finite coordinate inf in vertex 0 at byte offset %zu", vert0 + 8);
    expect_error_n(MESH_PLY, (const char *)C.b, C.n, want);

    /* counts the data cannot hold: fail before allocating */
    C.n = 0;
    put_str(&C, "ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\nproperty float x\n"
                "property float y\nproperty float z\nend_header\n");
    put_f32(&C, 0), put_f32(&C, 0), put_f32(&C, 0);
    expect_error_n(MESH_PLY, (const char *)C.b, C.n,
                   "t.ply:3:16: 4000000000 'vertex' elements announced, more than the 12 bytes after the header can hold");
    C.n = 0;
    put_str(&C, "ply\nformat binary_little_endian 1.0\nelement vertex 0\nproperty float x\nproperty float y\n"
                "property float z\nelement face 5\nproperty list int int vertex_indices\nend_header\n");
    for (int i = 0; i < 4; i++)
        put_i32(&C, 3), put_i32(&C, 0), put_i32(&C, 0), put_i32(&C, 0);
    expect_error_n(MESH_PLY, (const char *)C.b, C.n,
                   "t.ply:7:14: 5 'face' elements announced, more than the 64 bytes after the header can hold");
    /* a skipped element of 1e12 instances */
    C.n = 0;
    put_str(&C, "ply\nformat binary_little_endian 1.0\nelement vertex 0\nproperty float x\nproperty float y\n"
                "property float z\nelement junk 1000000000000\nproperty uchar a\nend_header\n");
    put_u8(&C, 1);
    expect_error_n(MESH_PLY, (const char *)C.b, C.n,
                   "t.ply:7:14: 1000000000000 'junk' elements announced, more than the 1 bytes after the header can hold");

    /* an element without properties takes no bytes, however many it has */
    Mesh m;
    C.n = 0;
    put_str(&C, "ply\nformat binary_little_endian 1.0\nelement nothing 1000000000000\nelement vertex 1\n"
                "property float x\nproperty float y\nproperty float z\nend_header\n");
    put_f32(&C, 1), put_f32(&C, 2), put_f32(&C, 3);
    parse_ok_n(MESH_PLY, (const char *)C.b, C.n, &m);
    assert_vec(m.v[0], 1, 2, 3, 0);
    mesh_free(&m);
}

/* Binary STL faults: the size that the count does not match, and
 * non-finite coordinates, with the byte offset of the value. */
static void test_bad_binary_stl(void **state)
{
    (void)state;
    Buf B;
    binary_stl(&B, stl_square, 2);
    memcpy(B.b, "mesh", 4); /* no 'solid': binary or nothing */
    expect_error_n(MESH_STL, (const char *)B.b, B.n - 1,
                   "t.stl:1:1: binary STL announces 2 triangles, which take 184 bytes, but the file has 183 (and it does "
                   "not begin with 'solid' for ASCII STL)");
    expect_error_n(MESH_STL, (const char *)B.b, 83,
                   "t.stl:1:1: not an STL file: 83 bytes, and no 'solid' for ASCII STL (binary STL takes at least 84 "
                   "bytes)");
    Buf C = B;
    put_u8(&C, 0);
    expect_error_n(MESH_STL, (const char *)C.b, C.n,
                   "t.stl:1:1: binary STL announces 2 triangles, which take 184 bytes, but the file has 185 (and it does "
                   "not begin with 'solid' for ASCII STL)");
    /* a count of 4e9 in 184 bytes: refused before anything is allocated */
    C = B;
    C.b[83] = 0xee;
    expect_error_n(MESH_STL, (const char *)C.b, C.n,
                   "t.stl:1:1: binary STL announces 3992977410 triangles, which take 199648870584 bytes, but the file "
                   "has 184 (and it does not begin with 'solid' for ASCII STL)");
    /* the second triangle's third vertex's y */
    C = B;
    float inf = INFINITY;
    size_t off = 84 + 50 + 12 + 2 * 12 + 4;
    memcpy(C.b + off, &inf, 4);
    expect_error_n(MESH_STL, (const char *)C.b, C.n, "t.stl:1:1: non-finite coordinate in triangle 1 at byte offset 174");
    assert_int_equal(off, 174);
}

/* Messages are cut to the buffer, never overrun it; a zero-size buffer is fine. */
static void test_error_buffer(void **state)
{
    (void)state;
    Mesh m;
    char err[16];
    memset(err, 'x', sizeof err);
    assert_int_equal(mesh_parse("t.off", "OFF\n3 1\n", 8, MESH_OFF, &m, err, 10), -1);
    assert_string_equal(err, "t.off:2:1");
    assert_int_equal(err[10], 'x');
    assert_int_equal(mesh_parse("t.off", "OFF\n3 1\n", 8, MESH_OFF, &m, NULL, 0), -1);
    /* a NULL buffer of length 0 is an empty file */
    assert_int_equal(mesh_parse("t.obj", NULL, 0, MESH_OBJ, &m, err, sizeof err), 0);
    assert_true(mesh_is_empty(&m));
}

/* ---- files ---- */

static char tmpdir[64];

static void write_file(const char *path, const void *data, size_t len)
{
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(data, 1, len, f), len);
    assert_int_equal(fclose(f), 0);
}

static void test_load(void **state)
{
    (void)state;
    char path[256], err[512];
    Mesh m;
    snprintf(tmpdir, sizeof tmpdir, "/tmp/test_mesh_XXXXXX");
    assert_non_null(mkdtemp(tmpdir));

    /* a binary PLY written here, with an upper-case extension */
    Buf B;
    size_t face2;
    binary_sample(&B, &face2);
    snprintf(path, sizeof path, "%s/quad.PLY", tmpdir);
    write_file(path, B.b, B.n);
    if (mesh_load(path, &m, err, sizeof err) != 0)
        fail_msg("%s", err);
    assert_int_equal(m.nv, 4);
    assert_int_equal(m.nt, 3);
    assert_vec(m.v[2], 1, 1, 2, 0);
    mesh_free(&m);
    remove(path);

    binary_stl(&B, stl_square, 2);
    snprintf(path, sizeof path, "%s/square.stl", tmpdir);
    write_file(path, B.b, B.n);
    assert_int_equal(mesh_load(path, &m, err, sizeof err), 0);
    assert_int_equal(m.nt, 2);
    mesh_free(&m);
    remove(path);

    snprintf(path, sizeof path, "%s/t.Obj", tmpdir);
    write_file(path, obj_sample, strlen(obj_sample));
    assert_int_equal(mesh_load(path, &m, err, sizeof err), 0);
    assert_int_equal(m.nt, 3);
    mesh_free(&m);
    remove(path);

    /* errors carry the path as given */
    snprintf(path, sizeof path, "%s/bad.off", tmpdir);
    static const char bad[] = "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 9\n";
    write_file(path, bad, strlen(bad));
    assert_int_equal(mesh_load(path, &m, err, sizeof err), -1);
    char want[512];
    snprintf(want, sizeof want, "%s:6:7: vertex index 9 out of range (3 vertices)", path);
    assert_string_equal(err, want);
    assert_true(mesh_is_empty(&m));
    remove(path);

    /* missing file, unknown extension, a directory */
    snprintf(path, sizeof path, "%s/missing.off", tmpdir);
    assert_int_equal(mesh_load(path, &m, err, sizeof err), -1);
    snprintf(want, sizeof want, "%s: cannot open: No such file or directory", path);
    assert_string_equal(err, want);
    assert_int_equal(mesh_load("mesh.3ds", &m, err, sizeof err), -1);
    assert_string_equal(err, "mesh.3ds: unknown mesh format (the name must end in .off, .obj, .ply or .stl)");
    assert_int_equal(mesh_load("off", &m, err, sizeof err), -1);
    assert_int_equal(mesh_load("dir.ply/x", &m, err, sizeof err), -1);
    snprintf(path, sizeof path, "%s/dir.off", tmpdir);
    assert_int_equal(mkdir(path, 0700), 0);
    assert_int_equal(mesh_load(path, &m, err, sizeof err), -1);
    assert_true(mesh_is_empty(&m));
    rmdir(path);

    /* a file over the size limit is refused before it is read (a sparse file:
     * skipped where the file system cannot make one) */
    snprintf(path, sizeof path, "%s/huge.off", tmpdir);
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    int sparse = ftruncate(fileno(f), (off_t)(LIMIT_MESH_BYTES + 1)) == 0;
    fclose(f);
    if (sparse) {
        assert_int_equal(mesh_load(path, &m, err, sizeof err), -1);
        snprintf(want, sizeof want, "%s: file of %llu bytes is larger than the 4096 MiB limit for meshes", path,
                 (unsigned long long)LIMIT_MESH_BYTES + 1);
        assert_string_equal(err, want);
    }
    remove(path);
    rmdir(tmpdir);

    MeshFormat fmt = MESH_OBJ;
    assert_int_equal(mesh_format_from_path("a/b.c/mesh.oFf", &fmt), 0);
    assert_int_equal(fmt, MESH_OFF);
    assert_int_equal(mesh_format_from_path("a.plyx", &fmt), -1);
    assert_int_equal(fmt, MESH_OFF);
}

/* ---- robustness: truncation and mutation of every good input ---- */

/* Parses len bytes; either a clean error that names the file, or a valid mesh. */
static void parse_anything(MeshFormat f, const char *text, size_t len)
{
    Mesh m;
    char err[512] = "";
    if (parse_n(f, text, len, &m, err, sizeof err) == 0) {
        if (mesh_validate(&m, err, sizeof err) != 0)
            fail_msg("invalid mesh accepted (%zu bytes): %s", len, err);
        char e2[256];
        if (mesh_vertex_normals(&m, e2, sizeof e2) != 0 || mesh_validate(&m, e2, sizeof e2) != 0)
            fail_msg("normals: %s", e2);
        mesh_free(&m);
    } else {
        const char *name = fmt_name(f);
        if (strncmp(err, name, strlen(name)) != 0 || err[strlen(name)] != ':')
            fail_msg("error without location: %s", err);
        assert_true(mesh_is_empty(&m));
    }
}

static void test_fuzz(void **state)
{
    (void)state;
    Buf B, S;
    size_t face2;
    binary_sample(&B, &face2);
    binary_stl(&S, stl_square, 2);
    const struct {
        MeshFormat fmt;
        const char *text;
        size_t len;
    } samples[] = {
        {MESH_OFF, off_tetra, sizeof off_tetra - 1},
        {MESH_OBJ, obj_sample, sizeof obj_sample - 1},
        {MESH_OBJ, obj_normals, sizeof obj_normals - 1},
        {MESH_PLY, ply_ascii, sizeof ply_ascii - 1},
        {MESH_PLY, (const char *)B.b, B.n},
        {MESH_STL, stl_ascii, sizeof stl_ascii - 1},
        {MESH_STL, (const char *)S.b, S.n},
    };
    static const unsigned char subst[] = {0, '\n', ' ', '0', '9', '-', '.', '/', '#', 'e', 0x7f, 0xff};
    for (size_t s = 0; s < sizeof samples / sizeof samples[0]; s++) {
        const char *t = samples[s].text;
        size_t len = samples[s].len;
        for (size_t cut = 0; cut <= len; cut++) /* every prefix */
            parse_anything(samples[s].fmt, t, cut);
        char *mut = malloc(len);
        assert_non_null(mut);
        for (size_t i = 0; i < len; i++) { /* every byte replaced by each of subst */
            for (size_t k = 0; k < sizeof subst; k++) {
                memcpy(mut, t, len);
                mut[i] = (char)subst[k];
                parse_anything(samples[s].fmt, mut, len);
            }
        }
        /* and a pseudo-random walk of multi-byte damage */
        uint32_t r = 12345u + (uint32_t)s;
        for (int iter = 0; iter < 2000; iter++) {
            memcpy(mut, t, len);
            for (int k = 0; k < 4; k++) {
                r = r * 1664525u + 1013904223u;
                size_t at = (r >> 8) % len;
                r = r * 1664525u + 1013904223u;
                mut[at] = (char)(r >> 24);
            }
            r = r * 1664525u + 1013904223u;
            parse_anything(samples[s].fmt, mut, (r >> 8) % (len + 1));
        }
        free(mut);
    }
}

/* `test_mesh --seeds DIR`: every mesh of the tables above, good and bad,
 * and the binary samples, as DIR/off, DIR/obj, DIR/ply and DIR/stl: the
 * fuzzers' seeds (tests/fuzz). */
static int write_seeds(const char *dir)
{
    static const char *const sub[] = {"off", "obj", "ply", "stl"};
    char name[32];
    int rc = 0;
    for (size_t i = 0; i < sizeof count_cases / sizeof count_cases[0]; i++) {
        snprintf(name, sizeof name, "good-%zu", i);
        rc |= test_write_seed(dir, sub[count_cases[i].fmt], name, count_cases[i].text, count_cases[i].len);
    }
    for (size_t i = 0; i < sizeof bad_cases / sizeof bad_cases[0]; i++) {
        snprintf(name, sizeof name, "bad-%zu", i);
        rc |= test_write_seed(dir, sub[bad_cases[i].fmt], name, bad_cases[i].text, bad_cases[i].len);
    }
    Buf B;
    size_t face2;
    binary_sample(&B, &face2);
    rc |= test_write_seed(dir, "ply", "binary", B.b, B.n);
    binary_stl(&B, stl_square, 2);
    rc |= test_write_seed(dir, "stl", "binary", B.b, B.n);
    rc |= test_write_seed(dir, "stl", "ascii", stl_ascii, sizeof stl_ascii - 1);
    rc |= test_write_seed(dir, "obj", "sample", obj_sample, sizeof obj_sample - 1);
    rc |= test_write_seed(dir, "obj", "normals", obj_normals, sizeof obj_normals - 1);
    rc |= test_write_seed(dir, "ply", "ascii", ply_ascii, sizeof ply_ascii - 1);
    rc |= test_write_seed(dir, "off", "tetra", off_tetra, sizeof off_tetra - 1);
    return rc ? 1 : 0;
}

int main(int argc, char **argv)
{
    if (argc == 3 && !strcmp(argv[1], "--seeds"))
        return write_seeds(argv[2]);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_off_basic),
        cmocka_unit_test(test_off_fan),
        cmocka_unit_test(test_off_variants),
        cmocka_unit_test(test_obj_basic),
        cmocka_unit_test(test_obj_negative_and_forward),
        cmocka_unit_test(test_obj_normals),
        cmocka_unit_test(test_zero_normal),
        cmocka_unit_test(test_ply_ascii),
        cmocka_unit_test(test_ply_binary),
        cmocka_unit_test(test_ply_types),
        cmocka_unit_test(test_ply_declarations),
        cmocka_unit_test(test_stl),
        cmocka_unit_test(test_stl_weld_grid),
        cmocka_unit_test(test_stl_cgal),
        cmocka_unit_test(test_counts),
        cmocka_unit_test(test_degenerate),
        cmocka_unit_test(test_normals_tetra),
        cmocka_unit_test(test_normals_cube),
        cmocka_unit_test(test_normals_flat_and_edge_cases),
        cmocka_unit_test(test_bad_inputs),
        cmocka_unit_test(test_bad_binary),
        cmocka_unit_test(test_bad_binary_stl),
        cmocka_unit_test(test_error_buffer),
        cmocka_unit_test(test_load),
        cmocka_unit_test(test_fuzz),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
