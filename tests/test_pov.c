/* Tests for pov.c: the exported text carries the settings parity depends on.
 * (Whether POV-Ray renders it to the same picture is the parity suite's job.) */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>

#include "lancer/pov.h"

static const char *scene_text =
    "image { width 200 height 100 background 0.25 0.5 1 max_depth 3 }\n"
    "camera { eye 1 2 3 target 1 2 4 up 0 1 0 fov 90 }\n"
    "light { position 0 10 0 color 1 0.5 0.25 fade_distance 5 fade_power 2 }\n"
    "light { position 1 1 1 shadowless }\n"
    "light { position 0 5 0 area_u 2 0 0 area_v 0 0 1 area_samples 5 3 }\n"
    "material red { color 1 0 0 ambient 0.2 diffuse 0.7 phong 0.5 phong_size 30 specular 0.25 roughness 0.01 "
    "reflection 0.3 }\n"
    "sphere { center 0 1 0 radius 0.5 material red }\n"
    "plane { normal 0 2 0 offset -1 material red }\n"
    "obox { center 1 2 3 u 1 0 0 v 0 2 0 w 0 0 3 material red }\n"
    "smooth_triangle { a 0 0 0 b 1 0 0 c 0 1 0 na 0 0 1 nb 0 0 1 nc 0 0 1 material red }\n"
    "smooth_triangle { a 1000000 0 0 b 1000001 0 0 c 1000000 1 0 na 0 0 1 nb 0 0.6 -0.8 nc 0 0 1 material red }\n"
    "smooth_triangle { a 0 0 5 b 1 0 5 c 0 1 5 na 2 0 0 nb 2 0 0 nc 2 0 0 material red }\n"
    "material glass { color 0.9 1 0.8 filter 0.5 transmit 0.25 ior 1.5 }\n"
    "sphere { center 0 1 0 radius 0.5 material glass }\n"
    "material room { ior 1.33 }\n"
    "box { min -9 -9 -9 max 9 9 9 material room }\n";

/* The export of text (NULL: scene_text), as a string the caller frees. */
static char *export_of(const char *text)
{
    Scene s;
    char err[256];
    text = text ? text : scene_text;
    assert_int_equal(scene_parse("t.scn", text, strlen(text), &s, err, sizeof err), 0);
    char *buf = NULL;
    size_t len = 0;
    FILE *f = open_memstream(&buf, &len);
    assert_non_null(f);
    assert_int_equal(pov_export(&s, 0, 0, 0, f), 0);
    fclose(f);
    scene_free(&s);
    return buf;
}

static char *export(void) { return export_of(NULL); }

static void expect(const char *text, const char *piece)
{
    if (!strstr(text, piece)) {
        print_error("missing: %s\n--- in:\n%s\n", piece, text);
        fail();
    }
}

static void test_globals_and_camera(void **state)
{
    (void)state;
    char *t = export();
    expect(t, "#version 3.7;");
    expect(t, "assumed_gamma 1.0");
    expect(t, "max_trace_level 3");
    expect(t, "adc_bailout 0.00024414062\n"); /* lancer's default, 2^-12, as the shortest float */
    expect(t, "background { color rgb <0.25, 0.5, 1> }");
    expect(t, "location <1, 2, 3>");
    /* a = 2, fovy 90: the horizontal angle is 2 atan(2) = 126.869897645844 degrees */
    expect(t, "right -x*2\n");
    expect(t, "angle 126.8698976458440");
    expect(t, "look_at <1, 2, 4>");
    expect(t, "+W200 +H100");
    free(t);
}

static void test_lights_materials_objects(void **state)
{
    (void)state;
    char *t = export();
    expect(t, "color rgb <1, 0.5, 0.25>\n  fade_distance 5\n  fade_power 2\n}");
    expect(t, "<1, 1, 1>\n  color rgb <1, 1, 1>\n  shadowless\n}");
    expect(t, "#declare M_red = texture {\n  pigment { color rgbft <1, 0, 0, 0, 0> }");
    expect(t, "ambient 0.2 diffuse 0.7");
    expect(t, "phong 0.5 phong_size 30");
    expect(t, "specular 0.25 roughness 0.01");
    expect(t, "reflection { 0.3 }");
    expect(t, "sphere { <0, 1, 0>, 0.5 texture { M_red } }");
    /* the normal is exported normalised, with the offset along it, and
     * turned to face the camera at y = 2 (which is then outside POV-Ray's
     * solid n.p < d) */
    expect(t, "plane { <0, 1, 0>, -1 texture { M_red } }");
    expect(t, "area_light <2, 0, 0>, <0, 0, 1>, 5, 3\n}");
    expect(t, "pigment { color rgbft <0.9, 1, 0.8, 0.5, 0.25> }");
    expect(t, "sphere { <0, 1, 0>, 0.5 texture { M_glass } interior { ior 1.5 } }");
    /* an opaque solid's ior too: a ray that starts inside it (a camera in a
     * room) leaves through its neighbours' surfaces by it */
    expect(t, "texture { M_room } interior { ior 1.33 } }");
    expect(t, "matrix <1, 0, 0,  0, 2, 0,  0, 0, 3,  1, 2, 3>");
    /* a smooth triangle whose normals lie on one side of it goes out as a
     * smooth_triangle, in double (a mesh would shade a face of one normal
     * flat, and hold its vertices in float) */
    expect(t, "smooth_triangle { <0, 0, 0>, <0, 0, 1>, <1, 0, 0>, <0, 0, 1>, <0, 1, 0>, <0, 0, 1> texture { M_red } }");
    /* any other as a one-face mesh2 (POV-Ray drops such a
     * smooth_triangle), its float vertices relative to the first and moved
     * back in double */
    expect(t, "mesh2 {\n  vertex_vectors { 3, <0, 0, 0>, <1, 0, 0>, <0, 1, 0> }\n"
              "  normal_vectors { 3, <0, 0, 1>, <0, 0.6, -0.8>, <0, 0, 1> }\n"
              "  face_indices { 1, <0, 1, 2> }\n  normal_indices { 1, <0, 1, 2> }\n"
              "  translate <1e+06, 0, 0>\n  texture { M_red } }");
    /* three equal normals in the face's plane: a mesh2 would shade the face
     * flat with its geometric normal (POV-Ray takes normals within 10^-5
     * for one), so they go out as a unit normal, two of them moved apart
     * along the face's normal (the face rendered flat, 2,638 pixels over) */
    expect(t, "  normal_vectors { 3, <1, 0, 0>, <1, 0, 4e-05>, <1, 0, -4e-05> }\n");
    free(t);
}

/* Transformed objects go out as lancer holds them, and coordinates as
 * they were written, not as the nearest float. */
static void test_transforms_and_doubles(void **state)
{
    (void)state;
    char *t = export_of("camera { eye 100000.8 0 -5 target 100000.8 0 0 fov 40 }\n"
                        "light { position 100003.3 1 0 }\n"
                        "material m { }\n"
                        "sphere { center 100000.81 0 0 radius 0.5 material m }\n"
                        "sphere { center 0 0 0 radius 1 scale 2 1 1 matrix 1 0.5 0 0 1 0 0 0 1 0 0 0 "
                        "translate 1 2 3 material m }\n"
                        "box { min 0 0 0 max 2 2 2 rotate 0 0 90 material m }\n");
    expect(t, "location <100000.8, 0, -5>");
    expect(t, "look_at <100000.8, 0, 0>");
    expect(t, "light_source {\n  <100003.3, 1, 0>");
    expect(t, "sphere { <100000.81, 0, 0>, 0.5 texture");
    /* the unit sphere under M = scale(2, 1, 1) after the shear, whose axes' images are the rows */
    expect(t, "sphere { <0, 0, 0>, 1\n  matrix <2, 0, 0,  1, 1, 0,  0, 0, 1,  1, 2, 3>");
    /* a quarter turn keeps the box axis-aligned */
    expect(t, "box { <-2, 0, 0>, <0, 2, 2> texture");
    free(t);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_globals_and_camera),
        cmocka_unit_test(test_lights_materials_objects),
        cmocka_unit_test(test_transforms_and_doubles),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
