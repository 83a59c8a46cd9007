/*
 * Tests of the scene parser (scene.h): every kind of bad input, each with its
 * exact message and the line:col of the offending token; that nothing is
 * returned on error; and that a good scene yields the values (and defaults)
 * it spells out, whatever its comments, line endings and number spellings.
 * Run from the repository root (scene_load reads scenes/default.scn).
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
#include <unistd.h>

#include "lancer/scene.h"

/* ---- helpers ---- */

static int parse(const char *text, Scene *s, char *err, size_t errlen)
{
    return scene_parse("t.scn", text, strlen(text), s, err, errlen);
}

/* Parses text that must be valid; fails the test with the parser's message if not. */
static void parse_ok(const char *text, Scene *s)
{
    char err[512] = "";
    if (parse(text, s, err, sizeof err) != 0)
        fail_msg("unexpected parse error: %s", err);
}

/* 1 when the Scene holds nothing: no arrays, no counts, no settings. */
static int scene_is_empty(const Scene *s)
{
    Scene zero;
    memset(&zero, 0, sizeof zero);
    return s->materials == NULL && s->nmaterials == 0 && s->lights == NULL && s->nlights == 0 &&
           s->prims == NULL && s->nprims == 0 && s->image.width == 0 && s->image.height == 0 && s->image.max_depth == 0 &&
           memcmp(s, &zero, sizeof zero) == 0;
}

/* text[0..len) with control and non-ASCII bytes as \xNN, for failure reports. */
static const char *escaped(const char *text, size_t len, char *buf, size_t buflen)
{
    size_t o = 0;
    for (size_t i = 0; i < len && o + 5 < buflen; i++) {
        unsigned char c = (unsigned char)text[i];
        if (c == '\n')
            o += (size_t)snprintf(buf + o, buflen - o, "\\n");
        else if (c >= 0x20 && c < 0x7f)
            buf[o++] = (char)c;
        else
            o += (size_t)snprintf(buf + o, buflen - o, "\\x%02x", c);
    }
    buf[o] = '\0';
    return buf;
}

/* ---- bad inputs ---- */

/* A valid camera (line 1) and material 'm' (line 2), so that the fault that
 * follows stands on line 3. */
#define CAM "camera { eye 0 0 -5 target 0 0 0 fov 40 }\n"
#define PRE CAM "material m { }\n"

typedef struct {
    const char *name;
    const char *text;
    size_t len; /* the text may hold a NUL byte */
    const char *want;
} BadCase;

#define BAD(name, text, want) {name, text, sizeof(text) - 1, want}

/* 254 zeros: "1." and these are one character more than LIMIT_NUMBER_CHARS */
#define ZEROS_10 "0000000000"
#define ZEROS_50 ZEROS_10 ZEROS_10 ZEROS_10 ZEROS_10 ZEROS_10
#define ZEROS_254 ZEROS_50 ZEROS_50 ZEROS_50 ZEROS_50 ZEROS_50 "0000"

static const BadCase bad_cases[] = {
    BAD("unexpected character",
        PRE "sphere { center 0 0 0 radius @ material m }\n",
        "t.scn:3:30: unexpected character '@'"),
    BAD("unexpected character at top level",
        PRE "$\n",
        "t.scn:3:1: unexpected character '$'"),
    BAD("NUL byte",
        PRE "sphere { center 0 0 \x00" " radius 1 material m }\n",
        "t.scn:3:21: unexpected byte 0x00"),
    BAD("NUL byte in a quoted path, which would cut it short",
        PRE "mesh { file \"ok.off\x00/etc/passwd\" material m }\n",
        "t.scn:3:20: byte 0x00 in a string"),
    BAD("control byte in a quoted path",
        PRE "mesh { file \"a\x1b[2Jb.off\" material m }\n",
        "t.scn:3:15: byte 0x1b in a string"),
    BAD("tab in a quoted path",
        PRE "mesh { file \"a\tb.off\" material m }\n",
        "t.scn:3:15: byte 0x09 in a string"),
    BAD("DEL in a quoted path",
        PRE "mesh { file \"ab\x7f.off\" material m }\n",
        "t.scn:3:16: byte 0x7f in a string"),
    BAD("non-ASCII byte in a name",
        PRE "material caf\xc3" "\xa9" " { }\n",
        "t.scn:3:13: unexpected byte 0xc3"),
    BAD("control byte",
        PRE "sphere { center 0 0 0\x0b" " radius 1 material m }\n",
        "t.scn:3:22: unexpected byte 0x0b"),
    BAD("lone dot",
        PRE "sphere { center 0 0 0 radius . material m }\n",
        "t.scn:3:30: unexpected character '.'"),
    BAD("lone minus",
        PRE "sphere { center 0 0 - 1 radius 1 material m }\n",
        "t.scn:3:21: unexpected character '-'"),
    BAD("non-finite 1e999",
        PRE "sphere { center 0 0 0 radius 1e999 material m }\n",
        "t.scn:3:30: non-finite number '1e999' (out of single-precision range)"),
    BAD("float overflow 1e39",
        PRE "sphere { center 0 1e39 0 radius 1 material m }\n",
        "t.scn:3:19: non-finite number '1e39' (out of single-precision range)"),
    BAD("float overflow -1e39",
        PRE "sphere { center 0 0 -1e39 radius 1 material m }\n",
        "t.scn:3:21: non-finite number '-1e39' (out of single-precision range)"),
    BAD("malformed 1.2.3",
        PRE "sphere { center 0 1.2.3 0 radius 1 material m }\n",
        "t.scn:3:19: malformed number '1.2.3'"),
    BAD("malformed 3x",
        PRE "sphere { center 0 0 0 radius 3x material m }\n",
        "t.scn:3:30: malformed number '3x'"),
    BAD("malformed 1e",
        PRE "sphere { center 0 0 0 radius 1e material m }\n",
        "t.scn:3:30: malformed number '1e'"),
    BAD("malformed 1e+",
        PRE "sphere { center 0 0 0 radius 1e+ material m }\n",
        "t.scn:3:30: malformed number '1e+'"),
    BAD("malformed 1-2",
        PRE "sphere { center 0 1-2 0 radius 1 material m }\n",
        "t.scn:3:19: malformed number '1-2'"),
    BAD("malformed 0x10",
        PRE "sphere { center 0 0 0 radius 0x10 material m }\n",
        "t.scn:3:30: malformed number '0x10'"),
    BAD("number longer than LIMIT_NUMBER_CHARS",
        PRE "sphere { center 0 0 0 radius 1." ZEROS_254 " material m }\n",
        "t.scn:3:30: number longer than 255 characters"),
    BAD("unknown keyword",
        PRE "spheer { center 0 0 0 radius 1 material m }\n",
        "t.scn:3:1: unknown keyword 'spheer'"),
    BAD("keywords are case-sensitive",
        PRE "Sphere { center 0 0 0 radius 1 material m }\n",
        "t.scn:3:1: unknown keyword 'Sphere'"),
    BAD("unknown keyword before a bad token",
        PRE "foo 1.2.3\n",
        "t.scn:3:1: unknown keyword 'foo'"),
    BAD("brace at top level",
        PRE "{ }\n",
        "t.scn:3:1: expected a keyword, found '{'"),
    BAD("closing brace at top level",
        PRE "}\n",
        "t.scn:3:1: expected a keyword, found '}'"),
    BAD("number at top level",
        PRE "42\n",
        "t.scn:3:1: expected a keyword, found number '42'"),
    BAD("keyword without block",
        PRE "sphere center 0 0 0\n",
        "t.scn:3:8: sphere: expected '{', found 'center'"),
    BAD("keyword at end of file",
        PRE "sphere\n",
        "t.scn:4:1: sphere: expected '{', found end of file"),
    BAD("material without name",
        PRE "material { }\n",
        "t.scn:3:10: material: expected a name, found '{'"),
    BAD("material with a number for a name",
        PRE "material 3 { }\n",
        "t.scn:3:10: material: expected a name, found number '3'"),
    BAD("material name too long",
        PRE "material aaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaa { }\n",
        "t.scn:3:10: material: name longer than 63 characters"),
    BAD("material name without block",
        PRE "material n material o { }\n",
        "t.scn:3:12: material: expected '{', found 'material'"),
    BAD("unknown property",
        PRE "sphere { centre 0 0 0 radius 1 material m }\n",
        "t.scn:3:10: sphere: unknown property 'centre'"),
    BAD("normal on a flat triangle",
        PRE "triangle { a 0 0 0 b 1 0 0 c 0 1 0 na 0 0 1 material m }\n",
        "t.scn:3:36: triangle: unknown property 'na'"),
    BAD("number for a property name",
        PRE "sphere { 1 }\n",
        "t.scn:3:10: sphere: expected a property name, found number '1'"),
    BAD("brace for a property name",
        PRE "sphere { { }\n",
        "t.scn:3:10: sphere: expected a property name, found '{'"),
    BAD("missing value before }",
        PRE "sphere { center 0 0 0 material m radius }\n",
        "t.scn:3:41: sphere: missing value for 'radius' (expects a number)"),
    BAD("missing value before next property",
        PRE "sphere { center 0 0 0 radius material m }\n",
        "t.scn:3:30: sphere: missing value for 'radius' (expects a number)"),
    BAD("missing vector component before next property",
        PRE "sphere { center 0 0 radius 1 material m }\n",
        "t.scn:3:21: sphere: missing value for 'center' (expects three numbers, got 2)"),
    BAD("missing whole vector before }",
        PRE "sphere { radius 1 material m center }\n",
        "t.scn:3:37: sphere: missing value for 'center' (expects three numbers, got 0)"),
    BAD("missing name before }",
        PRE "sphere { center 0 0 0 radius 1 material }\n",
        "t.scn:3:41: sphere: missing value for 'material' (expects a name)"),
    BAD("missing value at end of file",
        PRE "sphere { center 0 0 0 radius ",
        "t.scn:3:30: sphere: missing value for 'radius' (expects a number)"),
    BAD("extra number",
        PRE "sphere { center 0 0 0 radius 1 2 material m }\n",
        "t.scn:3:32: sphere: extra value '2' after 'radius' (expects a number)"),
    BAD("extra vector component",
        PRE "sphere { center 0 0 0 0 radius 1 material m }\n",
        "t.scn:3:23: sphere: extra value '0' after 'center' (expects three numbers)"),
    BAD("extra value after a name",
        PRE "sphere { center 0 0 0 radius 1 material m 7 }\n",
        "t.scn:3:43: sphere: extra value '7' after 'material' (expects a name)"),
    BAD("value after a flag",
        PRE "light { position 0 0 0 shadowless 1 }\n",
        "t.scn:3:35: light: extra value '1' after 'shadowless' (expects no value)"),
    BAD("name for a number",
        PRE "sphere { center 0 0 0 radius big material m }\n",
        "t.scn:3:30: sphere: wrong type for 'radius': expected a number, found 'big'"),
    BAD("name in a vector",
        PRE "sphere { center 0 y 0 radius 1 material m }\n",
        "t.scn:3:19: sphere: wrong type for 'center': expected a number, found 'y'"),
    BAD("brace for a number",
        PRE "sphere { center 0 0 0 radius { } }\n",
        "t.scn:3:30: sphere: wrong type for 'radius': expected a number, found '{'"),
    BAD("number for a name",
        PRE "sphere { center 0 0 0 radius 1 material 1 }\n",
        "t.scn:3:41: sphere: wrong type for 'material': expected a name, found number '1'"),
    BAD("material name too long in a reference",
        PRE "sphere { center 0 0 0 radius 1 material aaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaa }\n",
        "t.scn:3:41: sphere: name longer than 63 characters"),
    BAD("duplicate property",
        PRE "sphere { center 0 0 0 radius 1 radius 2 material m }\n",
        "t.scn:3:32: sphere: duplicate property 'radius' (first given at 3:23)"),
    BAD("duplicate flag",
        PRE "light { position 0 0 0 shadowless shadowless }\n",
        "t.scn:3:35: light: duplicate property 'shadowless' (first given at 3:24)"),
    BAD("missing } at end of file",
        PRE "sphere { center 0 0 0 radius 1 material m",
        "t.scn:3:42: sphere: missing '}' before end of file (to close the '{' at 3:8)"),
    BAD("missing } at end of file after newline and comment",
        PRE "sphere { center 0 0 0 radius 1 material m\n# the end\n",
        "t.scn:5:1: sphere: missing '}' before end of file (to close the '{' at 3:8)"),
    BAD("missing } before the next statement",
        PRE "sphere { center 0 0 0 radius 1 material m\nplane { normal 0 1 0 material m }\n",
        "t.scn:4:1: sphere: missing '}' before 'plane' (to close the '{' at 3:8)"),
    BAD("missing } before a material",
        PRE "light { position 0 0 0\nmaterial n { }\n",
        "t.scn:4:1: light: missing '}' before 'material' (to close the '{' at 3:7)"),
    /* a statement's keyword as a property of a block without it: no '}'
     * is missing (it once said one was) */
    BAD("a material in a light",
        PRE "light { position 0 0 0 material m }\n",
        "t.scn:3:24: light: unknown property 'material'"),
    BAD("a material in the image, a comment after it",
        PRE "image { material # here\n m }\n",
        "t.scn:3:9: image: unknown property 'material'"),
    BAD("missing } in the camera",
        "camera { eye 0 0 -5 target 0 0 0 fov 40\nmaterial m { }\n",
        "t.scn:2:1: camera: missing '}' before 'material' (to close the '{' at 1:8)"),
    BAD("duplicate camera",
        CAM "camera { eye 0 0 0 target 0 0 1 fov 30 }\n",
        "t.scn:2:1: duplicate 'camera' block"),
    BAD("duplicate image",
        CAM "image { width 10 }\nimage { height 10 }\n",
        "t.scn:3:1: duplicate 'image' block"),
    BAD("missing camera",
        "material m { }\nsphere { center 0 0 0 radius 1 material m }\n",
        "t.scn:3:1: the scene has no 'camera' block"),
    BAD("missing camera in an empty file",
        "",
        "t.scn:1:1: the scene has no 'camera' block"),
    BAD("missing camera in a file of comments",
        "# nothing\n# here",
        "t.scn:2:7: the scene has no 'camera' block"),
    BAD("undefined material",
        PRE "sphere { center 0 0 0 radius 1 material n }\n",
        "t.scn:3:41: sphere: undefined material 'n'"),
    BAD("material used before its definition",
        CAM "sphere { center 0 0 0 radius 1 material m }\nmaterial m { }\n",
        "t.scn:2:41: sphere: undefined material 'm'"),
    BAD("undefined material in a plane",
        PRE "plane { material M normal 0 1 0 }\n",
        "t.scn:3:18: plane: undefined material 'M'"),
    BAD("duplicate material name",
        PRE "material m { color 1 0 0 }\n",
        "t.scn:3:10: duplicate material name 'm'"),
    BAD("sphere without radius",
        PRE "sphere { center 0 0 0 material m }\n",
        "t.scn:3:1: sphere: missing property 'radius'"),
    BAD("sphere without center",
        PRE "  sphere { radius 1 material m }\n",
        "t.scn:3:3: sphere: missing property 'center'"),
    BAD("sphere without material",
        PRE "sphere { center 0 0 0 radius 1 }\n",
        "t.scn:3:1: sphere: missing property 'material'"),
    BAD("plane without normal",
        PRE "plane { offset 1 material m }\n",
        "t.scn:3:1: plane: missing property 'normal'"),
    BAD("triangle without c",
        PRE "triangle { a 0 0 0 b 1 0 0 material m }\n",
        "t.scn:3:1: triangle: missing property 'c'"),
    BAD("smooth_triangle without nc",
        PRE "smooth_triangle { a 0 0 0 b 1 0 0 c 0 1 0 na 0 0 1 nb 0 0 1 material m }\n",
        "t.scn:3:1: smooth_triangle: missing property 'nc'"),
    BAD("box without max",
        PRE "box { min 0 0 0 material m }\n",
        "t.scn:3:1: box: missing property 'max'"),
    BAD("obox without w",
        PRE "obox { center 0 0 0 u 1 0 0 v 0 1 0 material m }\n",
        "t.scn:3:1: obox: missing property 'w'"),
    BAD("light without position",
        PRE "light { color 1 1 1 }\n",
        "t.scn:3:1: light: missing property 'position'"),
    BAD("camera without fov",
        "camera { eye 0 0 0 target 0 0 1 }\n",
        "t.scn:1:1: camera: missing property 'fov'"),
    BAD("camera without eye",
        "camera { target 0 0 1 fov 40 }\n",
        "t.scn:1:1: camera: missing property 'eye'"),
    BAD("camera without target",
        "camera { eye 0 0 1 fov 40 }\n",
        "t.scn:1:1: camera: missing property 'target'"),
    BAD("negative radius",
        PRE "sphere { center 0 0 0 radius -1 material m }\n",
        "t.scn:3:30: sphere: 'radius' must be positive"),
    BAD("zero radius",
        PRE "sphere { center 0 0 0 radius 0 material m }\n",
        "t.scn:3:30: sphere: 'radius' must be positive"),
    BAD("radius that underflows to zero",
        PRE "sphere { center 0 0 0 radius 1e-50 material m }\n",
        "t.scn:3:30: sphere: 'radius' must be positive"),
    BAD("zero plane normal",
        PRE "plane { normal 0 0 0 material m }\n",
        "t.scn:3:16: plane: 'normal' must have non-zero length"),
    BAD("plane normal too large",
        PRE "plane { normal 1e30 0 0 material m }\n",
        "t.scn:3:16: plane: 'normal' is too small or too large to normalize"),
    BAD("plane normal too small",
        PRE "plane { normal 0 1e-30 0 material m }\n",
        "t.scn:3:16: plane: 'normal' is too small or too large to normalize"),
    BAD("zero obox u",
        PRE "obox { center 0 0 0 u 0 0 0 v 0 1 0 w 0 0 1 material m }\n",
        "t.scn:3:23: obox: 'u' must have non-zero length"),
    BAD("zero obox v",
        PRE "obox { center 0 0 0 u 1 0 0 v 0 0 0 w 0 0 1 material m }\n",
        "t.scn:3:31: obox: 'v' must have non-zero length"),
    BAD("zero obox w",
        PRE "obox { center 0 0 0 u 1 0 0 v 0 1 0 w 0 0 0 material m }\n",
        "t.scn:3:39: obox: 'w' must have non-zero length"),
    BAD("coplanar obox axes",
        PRE "obox { center 0 0 0 u 1 0 0 v 0 1 0 w 1 1 0 material m }\n",
        "t.scn:3:1: obox: axes 'u', 'v' and 'w' are linearly dependent (the box is flat) or too large"),
    BAD("parallel obox axes",
        PRE "obox { center 0 0 0 u 1 0 0 v -2 0 0 w 0 0 1 material m }\n",
        "t.scn:3:1: obox: axes 'u', 'v' and 'w' are linearly dependent (the box is flat) or too large"),
    BAD("zero smooth_triangle normal",
        PRE "smooth_triangle { a 0 0 0 b 1 0 0 c 0 1 0 na 0 0 1 nb 0 0 0 nc 0 0 1 material m }\n",
        "t.scn:3:55: smooth_triangle: 'nb' must have non-zero length"),
    BAD("collinear triangle",
        PRE "triangle { a 0 0 0 b 1 1 1 c 2 2 2 material m }\n",
        "t.scn:3:1: triangle: the three vertices are collinear (zero area)"),
    BAD("triangle with two equal vertices",
        PRE "triangle { a 1 2 3 b 4 5 6 c 1 2 3 material m }\n",
        "t.scn:3:1: triangle: the three vertices are collinear (zero area)"),
    BAD("collinear smooth_triangle",
        PRE "smooth_triangle { a 0 0 0 b 0 1 0 c 0 3 0 na 1 0 0 nb 1 0 0 nc 1 0 0 material m }\n",
        "t.scn:3:1: smooth_triangle: the three vertices are collinear (zero area)"),
    BAD("box flat in y",
        PRE "box { min 0 0 0 max 1 0 1 material m }\n",
        "t.scn:3:21: box: 'max' must exceed 'min' on every axis"),
    BAD("box inverted in z",
        PRE "box { max 1 1 -1 min 0 0 0 material m }\n",
        "t.scn:3:11: box: 'max' must exceed 'min' on every axis"),
    BAD("fov 0",
        "camera { eye 0 0 -5 target 0 0 0 fov 0 }\n",
        "t.scn:1:38: camera: 'fov' must be between 0 and 180 degrees"),
    BAD("fov 180",
        "camera { eye 0 0 -5 target 0 0 0 fov 180 }\n",
        "t.scn:1:38: camera: 'fov' must be between 0 and 180 degrees"),
    BAD("fov that rounds to 180",
        "camera { eye 0 0 -5 target 0 0 0 fov 179.9999999 }\n",
        "t.scn:1:38: camera: 'fov' must be between 0 and 180 degrees (it is 180 in single precision)"),
    BAD("negative fov",
        "camera { fov -10 eye 0 0 -5 target 0 0 0 }\n",
        "t.scn:1:14: camera: 'fov' must be between 0 and 180 degrees"),
    BAD("target equal to eye",
        "camera { eye 1 2 3 target 1 2 3 fov 40 }\n",
        "t.scn:1:27: camera: 'target' must differ from 'eye'"),
    BAD("target too close to eye",
        "camera { eye 0 0 0 target 0 0 1e-30 fov 40 }\n",
        "t.scn:1:27: camera: 'target' is too close to or too far from 'eye'"),
    BAD("target too far from eye",
        "camera { eye 0 0 -3e38 target 0 0 3e38 fov 40 }\n",
        "t.scn:1:31: camera: 'target' is too close to or too far from 'eye'"),
    BAD("up parallel to the view",
        "camera { eye 0 0 0 target 0 0 1 up 0 0 2 fov 40 }\n",
        "t.scn:1:36: camera: 'up' must not be parallel to the view direction"),
    BAD("up opposite to the view",
        "camera { eye 0 0 0 target 0 0 1 up 0 0 -1 fov 40 }\n",
        "t.scn:1:36: camera: 'up' must not be parallel to the view direction"),
    BAD("default up parallel to the view",
        "camera { eye 0 0 0 target 0 5 0 fov 40 }\n",
        "t.scn:1:1: camera: 'up' (by default 0 1 0) must not be parallel to the view direction"),
    BAD("zero up",
        "camera { eye 0 0 0 target 0 0 1 up 0 0 0 fov 40 }\n",
        "t.scn:1:36: camera: 'up' must have non-zero length"),
    BAD("image width 0",
        "image { width 0 }\ncamera { eye 0 0 -5 target 0 0 0 fov 40 }\n",
        "t.scn:1:15: image: 'width' must be a whole number from 1 to 32768"),
    BAD("image width not an integer",
        "image { width 640.5 }\ncamera { eye 0 0 -5 target 0 0 0 fov 40 }\n",
        "t.scn:1:15: image: 'width' must be a whole number from 1 to 32768"),
    BAD("image height too large",
        "image { width 640 height 32769 }\ncamera { eye 0 0 -5 target 0 0 0 fov 40 }\n",
        "t.scn:1:26: image: 'height' must be a whole number from 1 to 32768"),
    BAD("image too many pixels",
        "image { width 32768 height 16385 }\ncamera { eye 0 0 -5 target 0 0 0 fov 40 }\n",
        "t.scn:1:1: image: 32768 x 16385 is more than the 268435456 pixels lancer renders"),
    BAD("image height negative",
        "image { height -480 }\ncamera { eye 0 0 -5 target 0 0 0 fov 40 }\n",
        "t.scn:1:16: image: 'height' must be a whole number from 1 to 32768"),
    BAD("max_depth 0",
        "image { max_depth 0 }\ncamera { eye 0 0 -5 target 0 0 0 fov 40 }\n",
        "t.scn:1:19: image: 'max_depth' must be a whole number from 1 to 256"),
    BAD("max_depth not an integer",
        "image { max_depth 2.5 }\ncamera { eye 0 0 -5 target 0 0 0 fov 40 }\n",
        "t.scn:1:19: image: 'max_depth' must be a whole number from 1 to 256"),
    BAD("max_depth too large",
        "image { max_depth 257 }\ncamera { eye 0 0 -5 target 0 0 0 fov 40 }\n",
        "t.scn:1:19: image: 'max_depth' must be a whole number from 1 to 256"),
    BAD("roughness 0",
        PRE "material r { roughness 0 }\n",
        "t.scn:3:24: material: 'roughness' must be positive"),
    BAD("negative roughness",
        PRE "material r { roughness -0.5 }\n",
        "t.scn:3:24: material: 'roughness' must not be negative"),
    BAD("negative ambient",
        PRE "material r { ambient -0.1 }\n",
        "t.scn:3:22: material: 'ambient' must not be negative"),
    BAD("negative diffuse",
        PRE "material r { diffuse -1 }\n",
        "t.scn:3:22: material: 'diffuse' must not be negative"),
    BAD("negative phong",
        PRE "material r { phong -1 }\n",
        "t.scn:3:20: material: 'phong' must not be negative"),
    BAD("negative phong_size",
        PRE "material r { phong_size -40 }\n",
        "t.scn:3:25: material: 'phong_size' must not be negative"),
    BAD("negative specular",
        PRE "material r { specular -0.2 }\n",
        "t.scn:3:23: material: 'specular' must not be negative"),
    BAD("negative reflection",
        PRE "material r { reflection -0.5 }\n",
        "t.scn:3:25: material: 'reflection' must not be negative"),
    BAD("negative colour",
        PRE "material r { color 0.5 -0.1 0 }\n",
        "t.scn:3:20: material: 'color' must not be negative"),
    BAD("fade_power without fade_distance",
        PRE "light { position 0 0 0 fade_power 2 }\n",
        "t.scn:3:24: light: 'fade_power' needs 'fade_distance'"),
    BAD("fade_distance 0",
        PRE "light { position 0 0 0 fade_distance 0 fade_power 2 }\n",
        "t.scn:3:38: light: 'fade_distance' must be positive"),
    BAD("negative fade_distance",
        PRE "light { position 0 0 0 fade_distance -1 }\n",
        "t.scn:3:38: light: 'fade_distance' must be positive"),
    BAD("negative fade_power",
        PRE "light { position 0 0 0 fade_distance 5 fade_power -1 }\n",
        "t.scn:3:51: light: 'fade_power' must not be negative"),
    BAD("pn_triangle without nc",
        PRE "pn_triangle { a 0 0 0 b 1 0 0 c 0 1 0 na 0 0 1 nb 0 0 1 material m }\n",
        "t.scn:3:1: pn_triangle: missing property 'nc'"),
    BAD("pn_triangle with a zero normal",
        PRE "pn_triangle { a 0 0 0 b 1 0 0 c 0 1 0 na 0 0 1 nb 0 0 0 nc 0 0 1 material m }\n",
        "t.scn:3:51: pn_triangle: 'nb' must have non-zero length"),
    BAD("pn_triangle of collinear points",
        PRE "pn_triangle { a 0 0 0 b 1 0 0 c 2 0 0 na 0 0 1 nb 0 0 1 nc 0 0 1 material m }\n",
        "t.scn:3:1: pn_triangle: the three vertices are collinear (zero area)"),
    BAD("unknown pn_mode",
        PRE "pn_triangle { a 0 0 0 b 1 0 0 c 0 1 0 na 0 0 1 nb 0 0 1 nc 0 0 1 material m pn_mode slow }\n",
        "t.scn:3:85: pn_triangle: 'pn_mode' must be 'exact' or 'fast', not 'slow'"),
    BAD("unknown pn_mode in image",
        "image { pn_mode 1 }\n",
        "t.scn:1:17: image: wrong type for 'pn_mode': expected a name, found number '1'"),
    BAD("pn_mode on a mesh that is not pn",
        PRE "mesh { file \"m.off\" material m pn_mode fast }\n",
        "t.scn:3:32: mesh: 'pn_mode' is for a 'pn' mesh"),
    BAD("pn and flat",
        PRE "mesh { file \"m.off\" material m flat pn }\n",
        "t.scn:3:37: mesh: 'flat', 'smooth' and 'pn' exclude each other"),
    BAD("CRLF line endings",
        "camera { eye 0 0 -5 target 0 0 0 fov 40 }\r\nmaterial m { }\r\nsphere { center 0 0 0 radius -1 material m }\r\n",
        "t.scn:3:30: sphere: 'radius' must be positive"),
    BAD("old Mac OS line endings, a lone CR each",
        "camera { eye 0 0 -5 target 0 0 0 fov 40 }\r# a comment\rmaterial m { }\rsphere { center 0 0 0 radius -1 material m }\r",
        "t.scn:4:30: sphere: 'radius' must be positive"),
    BAD("a comment that a lone CR ends, before the keyword of the next block (it once ran to the file's end)",
        "camera { eye 0 0 5 target 0 0 0 fov 40 }\rmaterial m { }\rsphere { center 0 0 0 radius 1 material m\r"
        "plane # c\r{ normal 0 1 0 material m }\r",
        "t.scn:4:1: sphere: missing '}' before 'plane' (to close the '{' at 3:8)"),
    BAD("tabs count one column",
        PRE "\tsphere {\tcenter 0 0 0\tradius\t-1 material m }\n",
        "t.scn:3:31: sphere: 'radius' must be positive"),
    BAD("comments before the fault",
        PRE "# a comment with } { @ 1.2.3 \xff\nsphere { # radius 1\n  center 0 0 0 # }\n  radius -1 material m }\n",
        "t.scn:6:10: sphere: 'radius' must be positive"),
    BAD("missing } after a trailing comment",
        PRE "sphere { center 0 0 0 radius 1 material m # no brace",
        "t.scn:3:53: sphere: missing '}' before end of file (to close the '{' at 3:8)"),
    BAD("singular matrix on a sphere",
        PRE "sphere { center 0 0 0 radius 1 matrix 1 0 0 0 1 0 0 0 0 0 0 0 material m }",
        "t.scn:3:39: sphere: 'matrix' is singular: its 3x3 part has no inverse"),
    BAD("singular matrix on a box",
        PRE "box { min 0 0 0 max 1 1 1 matrix 1 2 3 2 4 6 0 0 1 0 0 0 material m }",
        "t.scn:3:34: box: 'matrix' is singular: its 3x3 part has no inverse"),
    BAD("zero scale on a triangle",
        PRE "triangle { a 0 0 0 b 1 0 0 c 0 1 0 scale 1 0 1 material m }",
        "t.scn:3:42: triangle: 'scale' must not be zero"),
    BAD("zero scale on a plane",
        PRE "plane { normal 0 1 0 scale 0 material m }",
        "t.scn:3:28: plane: 'scale' must not be zero"),
    BAD("singular matrix on a mesh",
        PRE "mesh { file \"q.off\" matrix 0 0 0 0 0 0 0 0 0 1 2 3 material m }",
        "t.scn:3:28: mesh: 'matrix' is singular: its 3x3 part has no inverse"),
    BAD("rotate takes three numbers",
        PRE "obox { center 0 0 0 u 1 0 0 v 0 1 0 w 0 0 1 rotate 30 material m }",
        "t.scn:3:55: obox: missing value for 'rotate' (expects three numbers, got 1)"),
    BAD("a box flattened in double by its transform",
        PRE "box { min 0 0 0 max 1 1 1 scale 1 1 1e-45 translate 0 0 -1 material m }",
        "t.scn:3:1: box: its transform leaves it flat or out of float's range"),
    BAD("a sphere whose radius its scale takes below float",
        PRE "sphere { center 0 0 0 radius 1e-30 scale 1e-30 material m }",
        "t.scn:3:1: sphere: its transform leaves it flat or out of float's range"),
    BAD("a triangle its scale takes past float",
        PRE "triangle { a 0 0 0 b 1 0 0 c 0 1 0 scale 1e30 1e30 1e30 translate 1e30 0 0 matrix 1e10 0 0 0 1e10 0 0 0 1e10 0 0 0 material m }",
        "t.scn:3:1: triangle: its transform leaves it flat or out of float's range"),
    BAD("a keyframe without a frame",
        PRE "keyframe { eye 0 0 -5 target 0 0 0 }",
        "t.scn:3:1: keyframe: missing property 'frame'"),
    BAD("a keyframe at a fractional frame",
        PRE "keyframe { frame 1.5 eye 0 0 -5 target 0 0 0 }",
        "t.scn:3:18: keyframe: 'frame' must be a whole number from 0 to 999999"),
    BAD("keyframes out of order",
        PRE "keyframe { frame 4 eye 0 0 -5 target 0 0 0 }\nkeyframe { frame 4 eye 1 0 -5 target 0 0 0 }",
        "t.scn:4:18: keyframe: frame 4 must come after frame 4 (keys go in the order of their frames)"),
    BAD("a keyframe whose eye is its target",
        PRE "keyframe { frame 0 eye 1 2 3 target 1 2 3 }",
        "t.scn:3:37: keyframe: 'target' must differ from 'eye'"),
    BAD("a keyframe fov of 180",
        PRE "keyframe { frame 0 eye 0 0 -5 target 0 0 0 fov 180 }",
        "t.scn:3:48: keyframe: 'fov' must be between 0 and 180 degrees"),
    /* a keyframe's fov is checked as the camera's, in single precision, at
     * its place (it once passed, and failed later with no position) */
    BAD("a keyframe fov that rounds to 180",
        PRE "keyframe { frame 0 eye 0 0 -5 target 0 0 0 fov 179.99999999 }",
        "t.scn:3:48: keyframe: 'fov' must be between 0 and 180 degrees (not in single precision)"),
    BAD("a keyframe fov that rounds to 0",
        PRE "keyframe { frame 0 eye 0 0 -5 target 0 0 0 fov 1e-50 }",
        "t.scn:3:48: keyframe: 'fov' must be between 0 and 180 degrees (not in single precision)"),
    /* a negative bailout does not "round to 1" */
    BAD("a negative adc_bailout",
        PRE "image { adc_bailout -0.1 }",
        "t.scn:3:21: image: 'adc_bailout' must be a number from 0 up to 1, 1 excluded"),
    /* an aa_threshold that rounds to 0 would mean no adaptive anti-aliasing */
    BAD("an aa_threshold that rounds to 0",
        PRE "image { spp 4 aa_threshold 1e-50 }",
        "t.scn:3:28: image: 'aa_threshold' must be a number above 0, at most 3 (it rounds to 0 as a float)"),
    /* \" and \\ escape in a string, and any other backslash is itself (a\b
     * once named ab.off) */
    BAD("a backslash in a mesh's path",
        PRE "mesh { file \"no\\dir\\\\x\\\"y.off\" material m }",
        "t.scn:3:13: mesh: no\\dir\\x\"y.off: cannot open: No such file or directory"),
    /* a name's key followed by another key and its value: the name is
     * missing (it once read the key as the name, and the value as extra) */
    BAD("a material's name left out",
        PRE "sphere { material center 0 0 0 radius 1 }",
        "t.scn:3:19: sphere: missing value for 'material' (expects a name)"),
    BAD("a pn_mode left out",
        PRE "mesh { pn pn_mode file \"x.off\" }",
        "t.scn:3:19: mesh: missing value for 'pn_mode' (expects a name)"),
    /* a word with bytes past ASCII is quoted whole (it was cut at the
     * first: 'sph') */
    BAD("a keyword with an accent",
        PRE "sph\xc3\xa8re { center 0 0 0 radius 1 material m }",
        "t.scn:3:1: unknown keyword 'sph\xc3\xa8re' (keywords and names are ASCII letters, digits and '_')"),
    BAD("error after many objects",
        PRE "sphere { center 0 0 0 radius 1 material m }\nsphere { center 0 0 0 radius 1 material m }\nsphere { center 0 0 0 radius 1 material m }\nsphere { center 0 0 0 radius 1 material m }\nsphere { center 0 0 0 radius 1 material m }\nsphere { center 0 0 0 radius 1 material m }\nsphere { center 0 0 0 radius 1 material m }\nsphere { center 0 0 0 radius 1 material m }\nsphere { center 0 0 0 radius 1 material m }\nsphere { center 0 0 0 radius 1 material m }\nsphere { center 0 0 0 radius 1 material m }\nsphere { center 0 0 0 radius 1 material m }\nsphere { center 0 0 0 radius 1 material m }\nsphere { center 0 0 0 radius 1 material m }\nsphere { center 0 0 0 radius 1 material m }\nsphere { center 0 0 0 radius 1 material m }\nsphere { center 0 0 0 radius 1 material m }\nsphere { center 0 0 0 radius 1 material m }\nsphere { center 0 0 0 radius 1 material m }\nsphere { center 0 0 0 radius 1 material m }\nbogus\n",
        "t.scn:23:1: unknown keyword 'bogus'"),
};

static void test_bad_inputs(void **state)
{
    (void)state;
    size_t n = sizeof bad_cases / sizeof bad_cases[0];
    int failures = 0;
    for (size_t i = 0; i < n; i++) {
        const BadCase *c = &bad_cases[i];
        Scene s;
        memset(&s, 0xa5, sizeof s); /* garbage in: the parser must clear it */
        char err[512] = "";
        int rc = scene_parse("t.scn", c->text, c->len, &s, err, sizeof err);
        int empty = scene_is_empty(&s);
        if (rc != -1 || strcmp(err, c->want) != 0 || !empty) {
            char buf[4096];
            print_error("bad case %zu (%s): text \"%s\"\n  want: rc -1, \"%s\"\n  got:  rc %d, \"%s\"%s\n", i,
                        c->name, escaped(c->text, c->len, buf, sizeof buf), c->want, rc, err,
                        empty ? "" : ", and the scene is not empty");
            failures++;
        }
        scene_free(&s);
        scene_free(&s); /* harmless twice */
    }
    if (failures)
        fail_msg("%d of %zu bad-input cases failed", failures, n);
}

/* Every bad case, cut short at each byte, still fails cleanly or parses:
 * no crash, no leak, and an empty Scene whenever the answer is an error. */
static void test_bad_inputs_truncated(void **state)
{
    (void)state;
    size_t n = sizeof bad_cases / sizeof bad_cases[0];
    for (size_t i = 0; i < n; i++) {
        const BadCase *c = &bad_cases[i];
        for (size_t len = 0; len <= c->len; len++) {
            char *copy = malloc(len ? len : 1); /* exactly len bytes: ASan catches reads past the end */
            assert_non_null(copy);
            memcpy(copy, c->text, len);
            Scene s;
            char err[512] = "";
            int rc = scene_parse("t.scn", copy, len, &s, err, sizeof err);
            if (rc != 0) {
                assert_int_equal(rc, -1);
                assert_true(scene_is_empty(&s));
                assert_true(strncmp(err, "t.scn:", 6) == 0);
            }
            scene_free(&s);
            free(copy);
        }
    }
}

/* The message is cut to the buffer given and stays a C string. */
static void test_error_buffer_truncation(void **state)
{
    (void)state;
    Scene s;
    char small[8];
    memset(small, 'x', sizeof small);
    assert_int_equal(scene_parse("t.scn", "@", 1, &s, small, sizeof small), -1);
    assert_string_equal(small, "t.scn:1");
    char mid[24];
    assert_int_equal(scene_parse("t.scn", "@", 1, &s, mid, sizeof mid), -1);
    assert_string_equal(mid, "t.scn:1:1: unexpected c");
    char one[1] = {'x'};
    assert_int_equal(scene_parse("t.scn", "@", 1, &s, one, sizeof one), -1);
    assert_int_equal(one[0], '\0');
    assert_true(scene_is_empty(&s));
    /* the file name stands as given */
    char err[256];
    assert_int_equal(scene_parse("dir/My Scene.scn", "\n\n  @", 5, &s, err, sizeof err), -1);
    assert_string_equal(err, "dir/My Scene.scn:3:3: unexpected character '@'");
}

/* ---- good inputs ---- */

static const char full_scene[] =
    "# every statement and every property\n"
    "image { width 320 height 200 background 0.1 0.2 0.3 max_depth 7 }\n"
    "camera { fov 55.5 up 0 0 1 eye 1 2 -3 target 0 1 0 }\n"
    "light { position -6 9 -6 color 0.8 0.7 0.6 fade_distance 10 fade_power 2 shadowless }\n"
    "light { position 1 2 3 }\n"
    "light { position 4 5 6 fade_distance 3 }\n"
    "material full { color 0.9 0.5 0.1 ambient 0.2 diffuse 0.7 phong 0.5 phong_size 60\n"
    "                specular 0.3 roughness 0.02 reflection 0.25 }\n"
    "material plain { }\n"
    "material zero { ambient 0 diffuse 0 phong 0 phong_size 0 specular 0 reflection 0 color 0 0 0 }\n"
    "sphere { material full center 1 2 3 radius 0.5 }\n"
    "plane { normal 0 2 0 offset -1 material plain }\n"
    "plane { normal 3 0 -4 material zero }\n"
    "triangle { a 0 0 0 b 1 0 0 c 0 1 0 material plain }\n"
    "smooth_triangle { a 0 0 1 b 1 0 1 c 0 1 1 na 0 0 2 nb 0 3 4 nc -1 0 0 material full }\n"
    "box { min -1 -2 -3 max 1 2 3 material plain }\n"
    "obox { center 1 1 1 u 0.4 0 0.25 v 0 0.35 0 w -0.15 0 0.24 material full }\n";

/* Every field of m is want's, exactly. */
static void assert_material(const Material *m, const Material *w)
{
    const struct {
        const char *key;
        float got, want;
    } f[] = {{"color.x", m->color.x, w->color.x}, {"color.y", m->color.y, w->color.y},
             {"color.z", m->color.z, w->color.z}, {"ambient", m->ambient, w->ambient},
             {"diffuse", m->diffuse, w->diffuse}, {"phong", m->phong, w->phong},
             {"phong_size", m->phong_size, w->phong_size}, {"specular", m->specular, w->specular},
             {"roughness", m->roughness, w->roughness}, {"reflection", m->reflection, w->reflection},
             {"filter", m->filter, w->filter}, {"transmit", m->transmit, w->transmit}, {"ior", m->ior, w->ior}};
    assert_string_equal(m->name, w->name);
    for (size_t i = 0; i < sizeof f / sizeof f[0]; i++)
        if (f[i].got != f[i].want)
            fail_msg("material '%s': %s is %g, expected %g", w->name, f[i].key, (double)f[i].got, (double)f[i].want);
}

static void test_full_scene(void **state)
{
    (void)state;
    Scene s;
    parse_ok(full_scene, &s);

    assert_int_equal(s.image.width, 320);
    assert_int_equal(s.image.height, 200);
    assert_int_equal(s.image.max_depth, 7);
    assert_vec(s.background, 0.1f, 0.2f, 0.3f, 0);

    assert_vec(s.camera.eye, 1, 2, -3, 0);
    assert_vec(s.camera.target, 0, 1, 0, 0);
    assert_vec(s.camera.up, 0, 0, 1, 0);
    assert_float_equal(s.camera.fovy, 55.5f, 0);

    assert_int_equal(s.nlights, 3);
    assert_vec(s.lights[0].pos, -6, 9, -6, 0);
    assert_vec(s.lights[0].color, 0.8f, 0.7f, 0.6f, 0);
    assert_float_equal(s.lights[0].fade_distance, 10, 0);
    assert_float_equal(s.lights[0].fade_power, 2, 0);
    assert_true(s.lights[0].shadowless);
    assert_vec(s.lights[1].pos, 1, 2, 3, 0);
    assert_vec(s.lights[1].color, 1, 1, 1, 0); /* defaults */
    assert_float_equal(s.lights[1].fade_distance, 0, 0);
    assert_float_equal(s.lights[1].fade_power, 0, 0);
    assert_false(s.lights[1].shadowless);
    assert_float_equal(s.lights[2].fade_distance, 3, 0); /* a distance alone: still no fade */
    assert_float_equal(s.lights[2].fade_power, 0, 0);

    /* the second is all POV-Ray 3.7's defaults; zero is allowed wherever
     * negative is the limit */
    const Material want[3] = {
        {"full", {0.9f, 0.5f, 0.1f}, 0.2f, 0.7f, 0.5f, 60, 0.3f, 0.02f, 0.25f, 0, 0, 1},
        {"plain", {1, 1, 1}, 0.1f, 0.6f, 0, 40, 0, 0.05f, 0, 0, 0, 1},
        {"zero", {0, 0, 0}, 0, 0, 0, 0, 0, 0.05f, 0, 0, 0, 1},
    };
    assert_int_equal(s.nmaterials, 3);
    for (int i = 0; i < 3; i++)
        assert_material(&s.materials[i], &want[i]);

    assert_int_equal(s.nprims, 7);
    const Prim *p = s.prims;
    assert_int_equal(p[0].kind, PRIM_SPHERE);
    assert_int_equal(p[0].material, 0);
    assert_vec(p[0].g.sphere.c, 1, 2, 3, 0);
    assert_float_equal(p[0].g.sphere.r, 0.5f, 0);

    assert_int_equal(p[1].kind, PRIM_PLANE);
    assert_int_equal(p[1].material, 1);
    assert_vec(p[1].g.plane.n, 0, 1, 0, 0); /* normalised */
    assert_float_equal(p[1].g.plane.d, -1, 0);
    assert_int_equal(p[2].kind, PRIM_PLANE);
    assert_int_equal(p[2].material, 2);
    assert_vec(p[2].g.plane.n, 0.6f, 0, -0.8f, 1e-6f);
    assert_float_equal(p[2].g.plane.d, 0, 0); /* default offset */

    assert_int_equal(p[3].kind, PRIM_TRIANGLE);
    assert_int_equal(p[3].material, 1);
    assert_vec(p[3].g.tri.a, 0, 0, 0, 0);
    assert_vec(p[3].g.tri.b, 1, 0, 0, 0);
    assert_vec(p[3].g.tri.c, 0, 1, 0, 0);

    assert_int_equal(p[4].kind, PRIM_SMOOTH_TRIANGLE);
    assert_int_equal(p[4].material, 0);
    assert_vec(p[4].g.tri.a, 0, 0, 1, 0);
    assert_vec(p[4].g.tri.b, 1, 0, 1, 0);
    assert_vec(p[4].g.tri.c, 0, 1, 1, 0);
    assert_vec(p[4].g.tri.na, 0, 0, 1, 1e-6f); /* normalised */
    assert_vec(p[4].g.tri.nb, 0, 0.6f, 0.8f, 1e-6f);
    assert_vec(p[4].g.tri.nc, -1, 0, 0, 1e-6f);

    assert_int_equal(p[5].kind, PRIM_BOX);
    assert_int_equal(p[5].material, 1);
    assert_vec(p[5].g.box.lo, -1, -2, -3, 0);
    assert_vec(p[5].g.box.hi, 1, 2, 3, 0);

    assert_int_equal(p[6].kind, PRIM_OBOX);
    assert_int_equal(p[6].material, 0);
    const OBox *b = &p[6].g.obox;
    assert_vec(b->c, 1, 1, 1, 0);
    assert_vec(b->u, 0.4f, 0, 0.25f, 0);
    assert_vec(b->v, 0, 0.35f, 0, 0);
    assert_vec(b->w, -0.15f, 0, 0.24f, 0);
    const Vec3 axes[3] = {b->u, b->v, b->w};
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            assert_float_equal(vec_dot(b->inv[i], axes[j]), i == j ? 1.0f : 0.0f, 1e-6f);

    scene_free(&s);
    assert_true(scene_is_empty(&s));
}

/* A camera alone: the image defaults, the default up, and nothing else. */
static void test_defaults(void **state)
{
    (void)state;
    Scene s;
    parse_ok("camera { eye 0 0 -5 target 0 0 0 fov 40 }", &s);
    assert_int_equal(s.image.width, 640);
    assert_int_equal(s.image.height, 480);
    assert_int_equal(s.image.max_depth, 5);
    assert_vec(s.background, 0, 0, 0, 0);
    assert_vec(s.camera.up, 0, 1, 0, 0);
    assert_int_equal(s.nmaterials, 0);
    assert_int_equal(s.nlights, 0);
    assert_int_equal(s.nprims, 0);
    assert_null(s.materials);
    assert_null(s.lights);
    assert_null(s.prims);
    scene_free(&s);

    /* an image block sets only what it names, wherever it stands */
    parse_ok("camera { eye 0 0 -5 target 0 0 0 fov 40 }\nimage { height 100 }\n", &s);
    assert_int_equal(s.image.width, 640);
    assert_int_equal(s.image.height, 100);
    assert_int_equal(s.image.max_depth, 5);
    scene_free(&s);
    parse_ok("image { }\ncamera { eye 0 0 -5 target 0 0 0 fov 40 }\n", &s);
    assert_int_equal(s.image.width, 640);
    assert_int_equal(s.image.height, 480);
    scene_free(&s);

    /* the limits themselves are allowed */
    parse_ok("image { width 1 height 32768 max_depth 256 }\n"
             "camera { eye 0 0 0 target 0 0 1 fov 179.9 }\n",
             &s);
    assert_int_equal(s.image.width, 1);
    assert_int_equal(s.image.height, 32768);
    assert_int_equal(s.image.max_depth, 256);
    scene_free(&s);
}

static void test_comments(void **state)
{
    (void)state;
    Scene s;
    parse_ok("# leading comment\n"
             "camera # after a keyword\n"
             "{ # after a brace\n"
             "  eye 0 0 -5 # after a vector\n"
             "  target # between a key and its value\n"
             "  0 # between components\n"
             "  0 0\n"
             "  fov 40}# glued to a brace\n"
             "#\n"
             "material m{}#glued { sphere @ 1.2.3 \xff\n"
             "sphere{center 0 0 0 radius 2#glued to a number\n"
             "material m}\n"
             "light { position 1 2 3 shadowless# glued to a flag\n"
             "}\n"
             "# trailing comment without a newline",
             &s);
    assert_vec(s.camera.eye, 0, 0, -5, 0);
    assert_vec(s.camera.target, 0, 0, 0, 0);
    assert_float_equal(s.camera.fovy, 40, 0);
    assert_int_equal(s.nmaterials, 1);
    assert_int_equal(s.nprims, 1);
    assert_float_equal(s.prims[0].g.sphere.r, 2, 0);
    assert_int_equal(s.nlights, 1);
    assert_true(s.lights[0].shadowless);
    scene_free(&s);
}

static void test_crlf_and_tabs(void **state)
{
    (void)state;
    Scene s;
    parse_ok("camera {\teye 0 0 -5\r\n\ttarget\t0 0 0\r\n\tfov 40 }\r\n"
             "material\tm\t{\tcolor\t0.5\t0.25\t1\t}\r\n"
             "\r\n"
             "sphere { center 1 2 3 radius 1 material m } # comment\r\n"
             "  \t  \r\n",
             &s);
    assert_vec(s.camera.target, 0, 0, 0, 0);
    assert_float_equal(s.camera.fovy, 40, 0);
    assert_int_equal(s.nmaterials, 1);
    assert_vec(s.materials[0].color, 0.5f, 0.25f, 1, 0);
    assert_int_equal(s.nprims, 1);
    assert_vec(s.prims[0].g.sphere.c, 1, 2, 3, 0);
    scene_free(&s);
}

static void test_transform(void **state)
{
    (void)state;
    Scene s;
    parse_ok("camera { eye 0 1 -5 target 0 0 0 fov 40 }\n"
             "light { position 1 2 3 fade_distance 2 fade_power 1 area_u 1 0 0 area_v 0 0 2 area_samples 2 2 }\n"
             "material m { }\n"
             "sphere { center 1 2 3 radius 0.5 material m }\n"
             "plane { normal 0 1 0 offset 1 material m }\n"
             "box { min 0 0 0 max 1 1 1 material m }\n"
             "obox { center 0 0 0 u 1 0 0 v 0 1 0 w 0 0 1 material m }\n"
             "triangle { a 0 0 0 b 1 0 0 c 0 1 0 material m }\n",
             &s);
    /* p -> 2p + (10, 20, 30) */
    assert_int_equal(scene_transform(&s, 2, (double[3]){10, 20, 30}), 0);
    assert_vec(s.camera.eye, 10, 22, 20, 0);
    assert_vec(s.camera.target, 10, 20, 30, 0);
    assert_vec(s.lights[0].pos, 12, 24, 36, 0);
    assert_vec(s.lights[0].area_v, 0, 0, 4, 0);
    assert_float_equal(s.lights[0].fade_distance, 4, 0);
    assert_vec(s.prims[0].g.sphere.c, 12, 24, 36, 0);
    assert_float_equal(s.prims[0].g.sphere.r, 1, 0);
    assert_float_equal(s.prims[1].g.plane.d, 22, 0); /* y = 1 moves to y = 22 */
    assert_vec(s.prims[2].g.box.hi, 12, 22, 32, 0);
    assert_vec(s.prims[3].g.obox.u, 2, 0, 0, 0);
    assert_float_equal(s.prims[3].g.obox.inv[0].x, 0.5f, 0); /* the inverse follows */
    assert_vec(s.prims[4].g.tri.b, 12, 20, 30, 0);
    /* a move that overflows float, or collapses the camera, is refused:
     * the scene scaled by 1e38 once rendered from an eye at infinity */
    assert_int_equal(scene_transform(&s, 1e38, (double[3]){0, 0, 0}), -1);
    scene_free(&s);
    parse_ok("camera { eye 0 1 -5 target 0 0 0 fov 40 }\nmaterial m { }\nsphere { center 0 0 0 radius 1 material m }\n",
             &s);
    assert_int_equal(scene_transform(&s, 1e-45, (double[3]){0, 0, 0}), -1);
    scene_free(&s);
}

/* Every object takes matrix, scale, rotate and translate; where the result
 * is an object of a kind lancer has, it is built, else the sphere becomes
 * an ellipsoid. */
static void test_object_transforms(void **state)
{
    (void)state;
    Scene s;
    parse_ok(CAM "material m { }\n"
                 "sphere { center 1 0 0 radius 0.5 rotate 0 0 90 scale 2 translate 0 0 1 material m }\n"
                 "sphere { center 0 0 0 radius 1 scale 2 1 1 translate 0 1 0 material m }\n"
                 "plane { normal 0 1 0 offset 1 rotate 90 0 0 material m }\n"
                 "box { min 0 0 0 max 1 2 3 rotate 0 90 0 material m }\n"
                 "box { min -1 -1 -1 max 1 1 1 rotate 0 45 0 translate 5 0 0 material m }\n"
                 "triangle { a 0 0 0 b 1 0 0 c 0 1 0 matrix 1 0 0 0 1 0 0 0 1 1 2 3 material m }\n"
                 "smooth_triangle { a 0 0 0 b 1 0 0 c 0 1 0 na 1 0 1 nb 0 0 1 nc 0 0 1 scale 1 1 2 material m }\n"
                 "obox { center 0 0 0 u 1 0 0 v 0 1 0 w 0 0 1 scale 2 translate 1 1 1 material m }\n"
                 "pn_triangle { a 0 0 0 b 1 0 0 c 0 1 0 na 0 0 1 nb 0 0 1 nc 0 0 1 translate 0 0 4 material m }\n"
                 "box { min 0 0 0 max 1 1 1 scale -2 1 1 material m }\n",
             &s);
    assert_int_equal(s.nprims, 10);
    /* a quarter turn about z takes (1, 0, 0) to (0, 1, 0), exactly */
    assert_int_equal(s.prims[0].kind, PRIM_SPHERE);
    assert_vec(s.prims[0].g.sphere.c, 0, 2, 1, 0);
    assert_float_equal(s.prims[0].g.sphere.r, 1, 0);
    /* a non-uniform scale: an ellipsoid, whose inverse maps (2, 1, 0) to the unit sphere */
    assert_int_equal(s.prims[1].kind, PRIM_ELLIPSOID);
    assert_ptr_equal(s.prims[1].g.ell.e, &s.ellipsoids[0]);
    const double *a = s.prims[1].g.ell.e->a;
    assert_true(a[0] == 0.5 && a[4] == 1 && a[8] == 1 && a[10] == -1);
    /* y = 1 turned by 90 degrees about x: z = 1 */
    assert_int_equal(s.prims[2].kind, PRIM_PLANE);
    assert_vec(s.prims[2].g.plane.n, 0, 0, 1, 0);
    assert_float_equal(s.prims[2].g.plane.d, 1, 0);
    /* a quarter turn keeps a box a box; 45 degrees makes it an oriented one */
    assert_int_equal(s.prims[3].kind, PRIM_BOX);
    assert_vec(s.prims[3].g.box.lo, 0, 0, -1, 0);
    assert_vec(s.prims[3].g.box.hi, 3, 2, 0, 0);
    assert_int_equal(s.prims[4].kind, PRIM_OBOX);
    assert_vec(s.prims[4].g.obox.c, 5, 0, 0, 0);
    assert_vec(s.prims[4].g.obox.u, 0.70710678f, 0, -0.70710678f, 1e-7);
    assert_int_equal(s.prims[5].kind, PRIM_TRIANGLE);
    assert_vec(s.prims[5].g.tri.b, 2, 2, 3, 0);
    /* normals go through the inverse transpose: (1, 0, 1) under scale z by 2 leans to x */
    assert_int_equal(s.prims[6].kind, PRIM_SMOOTH_TRIANGLE);
    assert_vec(s.prims[6].g.tri.na, 0.89442719f, 0, 0.44721360f, 1e-7);
    assert_int_equal(s.prims[7].kind, PRIM_OBOX);
    assert_vec(s.prims[7].g.obox.c, 1, 1, 1, 0);
    assert_vec(s.prims[7].g.obox.w, 0, 0, 2, 0);
    assert_int_equal(s.prims[8].kind, PRIM_PN);
    assert_vec(s.patches[0].b[PN_AT(0, 3)], 0, 1, 4, 0);
    /* a negative scale swaps a box's ends */
    assert_vec(s.prims[9].g.box.lo, -2, 0, 0, 0);
    assert_vec(s.prims[9].g.box.hi, 0, 1, 1, 0);
    scene_free(&s);
}

/* Coordinates are kept in double until the last move: a scene far from
 * the origin, moved next to its camera, keeps what a float far out would
 * lose (100000.81 is 100000.8125 in float, 100000.8 is 100000.796875). */
static void test_double_coordinates(void **state)
{
    (void)state;
    Scene s;
    parse_ok("camera { eye 100000.8 0 -5 target 100000.8 0 0 fov 40 }\n"
             "light { position 100003.3 1 0 }\n"
             "material m { }\n"
             "sphere { center 100000.81 0 0 radius 0.5 material m }\n"
             "triangle { a 100000.83 0 0 b 100001.83 0 0 c 100000.83 1 0 material m }\n"
             "plane { normal 1 0 0 offset 100000.85 material m }\n",
             &s);
    assert_true(s.camera.eye_at[0] == 100000.8);
    assert_true(s.place[0].p[0][0] == 100000.81);
    assert_int_equal(scene_transform(&s, 1.0, (double[3]){-100000.8, 0, 5}), 0);
    assert_vec(s.camera.eye, 0, 0, 0, 0);
    assert_vec(s.lights[0].pos, 2.5f, 1, 5, 1e-9);
    assert_vec(s.prims[0].g.sphere.c, 0.01f, 0, 5, 1e-9);
    assert_vec(s.prims[1].g.tri.a, 0.03f, 0, 5, 1e-9);
    assert_float_equal(s.prims[2].g.plane.d, 0.05f, 1e-9);
    scene_free(&s);
    /* a triangle and a box smaller than a float's spacing where they
     * stand, far from the camera: valid as written, and still valid once
     * moved, though their floats collapse (no ray will hit them) */
    parse_ok("camera { eye 0 0 -5 target 0 0 0 fov 40 }\nmaterial m { }\n"
             "triangle { a 1e7 0 0 b 10000000.25 0 0 c 1e7 0.25 0 material m }\n"
             "box { min 1e7 1e7 1e7 max 10000000.25 10000000.25 10000000.25 material m }\n",
             &s);
    char err[256];
    assert_int_equal(scene_validate(&s, err, sizeof err), 0);
    assert_int_equal(scene_transform(&s, 1.0, (double[3]){0, 0, 5}), 0);
    scene_free(&s);
}

/* Next to a camera 3 away, shapes 1e-30 across have no extent in double:
 * the move drops a box and a sliver no ray can hit, and keeps a box flat
 * along one axis, which still shows its face, one double thick. */
static void test_too_thin_once_moved(void **state)
{
    (void)state;
    Scene s;
    parse_ok("camera { eye 0.3 0.2 -3 target 0 0 0 fov 40 }\nmaterial m { }\n"
             "box { min 0 0 0 max 1e-30 1e-30 1e-30 material m }\n"
             "triangle { a -1 0 0 b 1 0 0 c 0 1e-30 0 material m }\n"
             "box { min -1 -1 0 max 1 1 1e-30 material m }\n"
             "sphere { center 0 0 0 radius 1e-30 material m }\n",
             &s);
    assert_int_equal(scene_transform(&s, 1.0, (double[3]){-0.3, -0.2, 3}), 0);
    assert_int_equal(s.vanished, 2);
    assert_int_equal(s.nprims, 2);
    assert_int_equal(s.prims[0].kind, PRIM_BOX);
    assert_int_equal(s.prims[1].kind, PRIM_SPHERE);
    assert_true(s.place[0].p[0][2] == 3.0 && s.place[0].p[1][2] == nextafter(3.0, 4.0));
    /* the flat box's face stops a ray from the eye at z = 3 */
    Ray r = {vec3(0, 0, 0), vec_normalize(vec3(-0.3f, -0.2f, 3)), INFINITY};
    PrimHit h;
    assert_true(prim_intersect(&s.prims[0], &r, PRIM_ROBUST, &h));
    assert_float_equal(h.t * r.d.z, 3.0f, 1e-6);
    scene_free(&s);
}

/* Makes the folder dir (a mkdtemp template) and in it quad.off holding
 * `off`, whose path goes into path. */
static void temp_mesh(char *dir, char *path, size_t len, const char *off)
{
    assert_non_null(mkdtemp(dir));
    snprintf(path, len, "%s/quad.off", dir);
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs(off, f);
    fclose(f);
}

static void test_mesh_statement(void **state)
{
    (void)state;
    char dir[] = "/tmp/lancer-scene-XXXXXX", path[256], text[1024], err[512];
    /* a unit quad (two triangles) and a degenerate triangle */
    temp_mesh(dir, path, sizeof path, "OFF\n5 2 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n2 0 0\n4 0 1 2 3\n3 0 1 4\n");
    Scene s;
    snprintf(text, sizeof text,
             CAM "material m { }\n"
                 "mesh { file \"%s\" material m smooth scale 2 rotate 0 0 90 translate 1 2 3 }\n",
             path);
    parse_ok(text, &s);
    assert_int_equal(s.nprims, 2);
    assert_int_equal(s.degenerate, 1);
    assert_int_equal(s.prims[0].kind, PRIM_SMOOTH_TRIANGLE);
    /* (1, 0, 0): scaled to (2, 0, 0), turned 90 degrees about z to (0, 2, 0),
     * moved to (1, 4, 3) */
    assert_vec(s.prims[0].g.tri.b, 1, 4, 3, 1e-6);
    assert_vec(s.prims[0].g.tri.na, 0, 0, 1, 1e-6); /* the quad's normal, kept by the rotation */
    scene_free(&s);
    /* A normal turns with its surface, whatever the rotation and scale: it
     * stays normal to the moved triangle (it once turned the other way). */
    static const char *const moves[] = {"rotate 90 0 0", "rotate 30 40 50", "scale 1 3 0.5 rotate 0 60 10"};
    for (size_t k = 0; k < sizeof moves / sizeof moves[0]; k++) {
        snprintf(text, sizeof text, CAM "material m { }\nmesh { file \"%s\" material m smooth %s }\n", path, moves[k]);
        parse_ok(text, &s);
        const Triangle *t = &s.prims[0].g.tri;
        Vec3 face = vec_normalize(vec_cross(vec_sub(t->b, t->a), vec_sub(t->c, t->a)));
        assert_float_equal(fabsf(vec_dot(face, t->na)), 1.0f, 1e-5);
        scene_free(&s);
    }
    /* a relative path is relative to the scene file's folder */
    snprintf(text, sizeof text, CAM "material m { }\nmesh { file \"quad.off\" material m }\n");
    char name[256];
    snprintf(name, sizeof name, "%s/t.scn", dir);
    assert_int_equal(scene_parse(name, text, strlen(text), &s, err, sizeof err), 0);
    assert_int_equal(s.prims[1].kind, PRIM_TRIANGLE);
    scene_free(&s);
    /* errors carry the scene position and the loader's message */
    const char *missing = CAM "material m { }\nmesh { file \"nowhere.off\" material m }\n";
    assert_int_equal(scene_parse("t.scn", missing, strlen(missing), &s, err, sizeof err), -1);
    assert_string_equal(err, "t.scn:3:13: mesh: nowhere.off: cannot open: No such file or directory");
    const char *empty = CAM "material m { }\nmesh { file \"\" material m }\n";
    assert_int_equal(scene_parse("t.scn", empty, strlen(empty), &s, err, sizeof err), -1);
    assert_string_equal(err, "t.scn:3:13: mesh: 'file' is empty");
    snprintf(text, sizeof text, CAM "material m { }\nmesh { file \"%s\" material m flat smooth }\n", path);
    assert_int_equal(scene_parse("t.scn", text, strlen(text), &s, err, sizeof err), -1);
    assert_non_null(strstr(err, "t.scn:3:"));
    assert_non_null(strstr(err, "'flat', 'smooth' and 'pn' exclude each other"));
    const char *open = CAM "mesh { file \"quad.off material m }\n";
    assert_int_equal(scene_parse("t.scn", open, strlen(open), &s, err, sizeof err), -1);
    assert_string_equal(err, "t.scn:2:13: unterminated string");
    const char *open_crlf = CAM "mesh { file \"quad.off material m }\r\n";
    assert_int_equal(scene_parse("t.scn", open_crlf, strlen(open_crlf), &s, err, sizeof err), -1);
    assert_string_equal(err, "t.scn:2:13: unterminated string");
    const char *two = CAM "material m { }\nmesh { file \"q.off\" material m scale 1 2 }\n";
    assert_int_equal(scene_parse("t.scn", two, strlen(two), &s, err, sizeof err), -1);
    assert_string_equal(err, "t.scn:3:42: mesh: missing value for 'scale' (expects one or three numbers, got 2)");
    remove(path);
    rmdir(dir);
}

/* Many materials, looked up by name through the parser's table: each
 * object gets the one it names, in any order, and a name defined twice is
 * found among thousands (the table grows and rehashes on the way). */
static void test_many_materials(void **state)
{
    (void)state;
    enum { N = 5000 };
    size_t cap = 80 * (size_t)N * 2 + 256, len = 0;
    char *text = malloc(cap), err[256];
    assert_non_null(text);
    len += (size_t)snprintf(text + len, cap - len, CAM);
    for (int i = 0; i < N; i++)
        len += (size_t)snprintf(text + len, cap - len, "material m%d { ambient %g }\n", i, (double)i / N);
    for (int i = 0; i < N; i++)
        len += (size_t)snprintf(text + len, cap - len, "sphere { center 0 0 %d radius 0.4 material m%d }\n", i,
                                N - 1 - i);
    Scene s;
    parse_ok(text, &s);
    assert_int_equal(s.nmaterials, N);
    for (int i = 0; i < N; i++) {
        assert_int_equal(s.prims[i].material, N - 1 - i);
        assert_float_equal(s.materials[s.prims[i].material].ambient, (float)((double)(N - 1 - i) / N), 0);
    }
    scene_free(&s);
    /* m4321 again, on line N + 2 (after the camera's) */
    len = 0;
    len += (size_t)snprintf(text + len, cap - len, CAM);
    for (int i = 0; i < N; i++)
        len += (size_t)snprintf(text + len, cap - len, "material m%d { }\n", i);
    len += (size_t)snprintf(text + len, cap - len, "material m4321 { }\n");
    assert_int_equal(scene_parse("t.scn", text, len, &s, err, sizeof err), -1);
    char want[64];
    snprintf(want, sizeof want, "t.scn:%d:10: duplicate material name 'm4321'", N + 2);
    assert_string_equal(err, want);
    free(text);
}

/* A mesh that would add nothing it can shade is an error at its file,
 * where both once vanished from the scene without a word: a smooth or pn
 * mesh with a corner's normal of zero length (each such triangle was
 * dropped as degenerate), and a mesh whose every triangle leaves the
 * floats once moved. */
static void test_mesh_that_vanishes(void **state)
{
    (void)state;
    char dir[] = "/tmp/lancer-scene-XXXXXX", path[256], text[1024], err[512];
    temp_mesh(dir, path, sizeof path, "NOFF\n3 1 0\n0 0 0 0 0 1\n1 0 0 0 0 0\n0 1 0 0 0 1\n3 0 1 2\n");
    Scene s;
    const char *kinds[] = {"smooth", "pn"};
    for (int k = 0; k < 2; k++) {
        snprintf(text, sizeof text, CAM "material m { }\nmesh { file \"%s\" material m %s }\n", path, kinds[k]);
        assert_int_equal(scene_parse("t.scn", text, strlen(text), &s, err, sizeof err), -1);
        assert_non_null(strstr(err, "t.scn:3:13: mesh: "));
        assert_non_null(strstr(err, "its normal 2 (counting from 1) has zero length"));
    }
    /* flat, the normals play no part */
    snprintf(text, sizeof text, CAM "material m { }\nmesh { file \"%s\" material m }\n", path);
    parse_ok(text, &s);
    assert_int_equal(s.nprims, 1);
    scene_free(&s);
    remove(path);
    rmdir(dir);
    char dir2[] = "/tmp/lancer-scene-XXXXXX";
    temp_mesh(dir2, path, sizeof path, "OFF\n3 1 0\n0 0 0\n1e30 0 0\n0 1e30 0\n3 0 1 2\n");
    snprintf(text, sizeof text, CAM "material m { }\nmesh { file \"%s\" material m scale 1e10 }\n", path);
    assert_int_equal(scene_parse("t.scn", text, strlen(text), &s, err, sizeof err), -1);
    assert_non_null(strstr(err, "t.scn:3:1: mesh: "));
    assert_non_null(strstr(err, "every triangle has no area or leaves the range of floats"));
    remove(path);
    rmdir(dir2);
}

/* pn_triangle and pn meshes: patches out of line, normals made unit, the
 * mode from the block, else the image block (wherever it stands), else
 * exact. */
static void test_pn_statements(void **state)
{
    (void)state;
    char dir[] = "/tmp/lancer-scene-XXXXXX", path[256], text[1024];
    temp_mesh(dir, path, sizeof path, "OFF\n4 2 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2\n3 0 2 3\n");
    Scene s;
    snprintf(text, sizeof text,
             CAM "material m { }\n"
                 "pn_triangle { a 0 0 0 b 1 0 0 c 0 1 0 na 0 0 2 nb 0 1 1 nc 0 0 1 material m }\n"
                 "mesh { file \"%s\" material m pn pn_mode exact translate 0 0 5 }\n"
                 "pn_triangle { a 0 0 0 b 1 0 0 c 0 1 0 na 0 0 1 nb 0 0 1 nc 0 0 1 material m pn_mode exact }\n"
                 "image { pn_mode fast }\n",
             path);
    parse_ok(text, &s);
    assert_int_equal(s.nprims, 4);
    assert_int_equal(s.npatches, 4);
    for (int i = 0; i < 4; i++) {
        assert_int_equal(s.prims[i].kind, PRIM_PN);
        assert_ptr_equal(s.prims[i].g.pn.patch, &s.patches[s.prims[i].g.pn.index]);
    }
    assert_int_equal(s.prims[0].g.pn.mode, PN_FAST); /* the image block's, given after it */
    assert_int_equal(s.prims[1].g.pn.mode, PN_EXACT);
    assert_int_equal(s.prims[3].g.pn.mode, PN_EXACT);
    assert_vec(s.patches[0].n[0], 0, 0, 1, 0);          /* (0 0 2) made unit */
    assert_vec(s.patches[0].n[1], 0, 0.70710678f, 0.70710678f, 1e-7);
    assert_vec(s.patches[1].b[PN_AT(0, 3)], 1, 1, 5, 0); /* the mesh's third vertex, moved */
    /* the mesh's normals are the file's none, so angle-weighted: a flat quad's */
    assert_vec(s.patches[1].n[2], 0, 0, 1, 1e-6);
    scene_free(&s);
    parse_ok(CAM "material m { }\n"
                 "pn_triangle { a 0 0 0 b 1 0 0 c 0 1 0 na 0 0 1 nb 0 0 1 nc 0 0 1 material m }\n",
             &s);
    assert_int_equal(s.prims[0].g.pn.mode, PN_EXACT); /* the default */
    /* a scene transform moves the net */
    assert_int_equal(scene_transform(&s, 2.0, (double[3]){1, 0, 0}), 0);
    assert_vec(s.patches[0].b[PN_AT(0, 0)], 3, 0, 0, 0);
    scene_free(&s);
    remove(path);
    rmdir(dir);
}

static void test_utf8_bom(void **state)
{
    (void)state;
    Scene s;
    /* editors on some systems start files with a byte-order mark */
    parse_ok("\xef\xbb\xbf" "camera { eye 0 0 -5 target 0 0 0 fov 40 }\n", &s);
    assert_float_equal(s.camera.fovy, 40, 0);
    scene_free(&s);
    char err[256];
    const char *bad = "\xef\xbb\xbf" "@";
    assert_int_equal(scene_parse("t.scn", bad, strlen(bad), &s, err, sizeof err), -1);
    assert_string_equal(err, "t.scn:1:1: unexpected character '@'");
}

static void test_number_forms(void **state)
{
    (void)state;
    Scene s;
    parse_ok("camera { eye 0 0 -5 target 0 0 0 fov 40 }\n"
             "material m { }\n"
             "sphere { center -1 +2.5 .5 radius 3. material m }\n"
             "light { position 1e-3 2E+2 -.5 color 1.5e1 0.0 00012 }\n"
             "box { min -1E1 -0 -1e-0 max +.25e+1 7. 1e5 material m }\n",
             &s);
    assert_vec(s.prims[0].g.sphere.c, -1, 2.5f, 0.5f, 0);
    assert_float_equal(s.prims[0].g.sphere.r, 3, 0);
    assert_true(s.lights[0].pos.x == 1e-3f);
    assert_true(s.lights[0].pos.y == 200.0f);
    assert_true(s.lights[0].pos.z == -0.5f);
    assert_vec(s.lights[0].color, 15, 0, 12, 0);
    assert_vec(s.prims[1].g.box.lo, -10, 0, -1, 0);
    assert_vec(s.prims[1].g.box.hi, 2.5f, 7, 1e5f, 0);
    scene_free(&s);
    /* a number of exactly LIMIT_NUMBER_CHARS characters is read */
    parse_ok("camera { eye 0 0 -5 target 0 0 0 fov 40 }\nmaterial m { }\n"
             "sphere { center 0 0 0 radius 2." ZEROS_50 ZEROS_50 ZEROS_50 ZEROS_50 ZEROS_50 "000 material m }\n",
             &s);
    assert_float_equal(s.prims[0].g.sphere.r, 2, 0);
    scene_free(&s);
}

/* Names: letters, digits and underscores, up to 63 characters; a material
 * may share its name with a keyword or a property. */
static void test_names(void **state)
{
    (void)state;
    char text[512];
    char name63[64];
    memset(name63, 'n', 63);
    name63[63] = '\0';
    snprintf(text, sizeof text,
             "camera { eye 0 0 -5 target 0 0 0 fov 40 }\n"
             "material _Mat_2 { }\n"
             "material sphere { }\n"
             "material radius { }\n"
             "material %s { }\n"
             "sphere { center 0 0 0 radius 1 material radius }\n"
             "sphere { material radius center 0 0 0 radius 1 }\n"
             "sphere { center 0 0 0 radius 1 material %s }\n"
             "sphere { center 0 0 0 radius 1 material _Mat_2 }\n",
             name63, name63);
    Scene s;
    parse_ok(text, &s);
    assert_int_equal(s.nmaterials, 4);
    assert_string_equal(s.materials[3].name, name63);
    assert_int_equal(s.nprims, 4);
    assert_int_equal(s.prims[0].material, 2);
    assert_int_equal(s.prims[1].material, 2); /* "radius", a key's name, before another key */
    assert_int_equal(s.prims[2].material, 3);
    assert_int_equal(s.prims[3].material, 0);
    scene_free(&s);
}

/* Enough of everything that the arrays grow several times. */
static void test_many_objects(void **state)
{
    (void)state;
    size_t cap = 1 << 16, len = 0;
    char *text = malloc(cap);
    assert_non_null(text);
    len += (size_t)snprintf(text + len, cap - len, "camera { eye 0 0 -5 target 0 0 0 fov 40 }\n");
    for (int i = 0; i < 40; i++)
        len += (size_t)snprintf(text + len, cap - len, "material m%d { ambient %d }\n", i, i);
    for (int i = 0; i < 30; i++)
        len += (size_t)snprintf(text + len, cap - len, "light { position %d 0 0 }\n", i);
    for (int i = 0; i < 100; i++)
        len += (size_t)snprintf(text + len, cap - len, "sphere { center %d 0 0 radius 1 material m%d }\n", i, i % 40);
    assert_true(len < cap);
    Scene s;
    parse_ok(text, &s);
    assert_int_equal(s.nmaterials, 40);
    assert_int_equal(s.nlights, 30);
    assert_int_equal(s.nprims, 100);
    for (int i = 0; i < 40; i++)
        assert_float_equal(s.materials[i].ambient, (float)i, 0);
    for (int i = 0; i < 30; i++)
        assert_float_equal(s.lights[i].pos.x, (float)i, 0);
    for (int i = 0; i < 100; i++) {
        assert_float_equal(s.prims[i].g.sphere.c.x, (float)i, 0);
        assert_int_equal(s.prims[i].material, i % 40);
    }
    scene_free(&s);

    /* the same, with a fault at the end: everything is freed, nothing returned */
    len += (size_t)snprintf(text + len, cap - len, "sphere { center 0 0 0 radius 1 material nope }\n");
    char err[512];
    int rc = scene_parse("t.scn", text, len, &s, err, sizeof err);
    free(text);
    assert_int_equal(rc, -1);
    assert_string_equal(err, "t.scn:172:41: sphere: undefined material 'nope'");
    assert_true(scene_is_empty(&s));
}

/* ---- scene_load ---- */

static void test_load_missing_file(void **state)
{
    (void)state;
    Scene s;
    memset(&s, 0xa5, sizeof s);
    char err[512];
    assert_int_equal(scene_load("scenes/no-such-scene.scn", &s, err, sizeof err), -1);
    assert_string_equal(err, "scenes/no-such-scene.scn: cannot open: No such file or directory");
    assert_true(scene_is_empty(&s));
    scene_free(&s);
}

static void test_load_directory(void **state)
{
    (void)state;
    Scene s;
    char err[512];
    assert_int_equal(scene_load("scenes", &s, err, sizeof err), -1);
    assert_string_equal(err, "scenes: not a regular file (a directory)");
    assert_true(scene_is_empty(&s));
}

/* Messages from a file carry its path as given. */
static void test_load_bad_file(void **state)
{
    (void)state;
    char path[] = "/tmp/lancer-test-scene-XXXXXX";
    int fd = mkstemp(path);
    assert_true(fd >= 0);
    static const char text[] = "camera { eye 0 0 -5 target 0 0 0 fov 40 }\n\nsphere { radius -1 }\n";
    assert_int_equal(write(fd, text, sizeof text - 1), (ssize_t)(sizeof text - 1));
    close(fd);
    Scene s;
    char err[512], want[600];
    int rc = scene_load(path, &s, err, sizeof err);
    unlink(path);
    assert_int_equal(rc, -1);
    snprintf(want, sizeof want, "%s:3:1: sphere: missing property 'center'", path);
    assert_string_equal(err, want);
    assert_true(scene_is_empty(&s));
}

static void test_load_default_scene(void **state)
{
    (void)state;
    Scene s;
    char err[512] = "";
    if (scene_load("scenes/default.scn", &s, err, sizeof err) != 0)
        fail_msg("scenes/default.scn: %s", err);
    assert_int_equal(s.image.width, 640);
    assert_int_equal(s.image.height, 480);
    assert_int_equal(s.image.max_depth, 5);
    assert_vec(s.background, 0.55f, 0.7f, 0.9f, 0);
    assert_vec(s.camera.eye, 0, 2.2f, -7.5f, 0);
    assert_float_equal(s.camera.fovy, 40, 0);
    assert_int_equal(s.nlights, 2);
    assert_int_equal(s.nmaterials, 6);
    assert_string_equal(s.materials[0].name, "floor");
    assert_string_equal(s.materials[5].name, "green");
    assert_int_equal(s.nprims, 7);
    assert_int_equal(s.prims[0].kind, PRIM_PLANE);
    assert_int_equal(s.prims[1].kind, PRIM_SPHERE);
    assert_int_equal(s.prims[1].material, 2); /* mirror */
    assert_int_equal(s.prims[4].kind, PRIM_BOX);
    assert_int_equal(s.prims[5].kind, PRIM_OBOX);
    assert_int_equal(s.prims[6].kind, PRIM_TRIANGLE);
    scene_free(&s);
}

/* scene_split_triangles halves every triangle across its longest edge:
 * the halves share the corner opposite it and the edge's midpoint, keep
 * the winding, and cover the triangle exactly; other primitives stay. */
static void test_split_triangles(void **state)
{
    (void)state;
    Scene s;
    parse_ok("camera { eye 0 1 -5 target 0 0 0 fov 40 }\n"
             "material m { }\nmaterial n { }\n"
             "sphere { center 0 0 0 radius 1 material m }\n"
             "triangle { a 0 0 0 b 4 0 0 c 0 2 0 material n }\n" /* longest edge b-c */
             "smooth_triangle { a 0 0 1 b 2 0 1 c 0 2 1 na 0 0 1 nb 1 0 0 nc 0 1 0 material m }\n",
             &s);
    assert_int_equal(scene_split_triangles(&s), 0);
    assert_int_equal(s.nprims, 5);
    assert_int_equal(s.prims[0].kind, PRIM_SPHERE);
    const Triangle *t0 = &s.prims[1].g.tri, *t1 = &s.prims[2].g.tri;
    assert_int_equal(s.prims[1].kind, PRIM_TRIANGLE);
    assert_int_equal(s.prims[2].material, 1);
    assert_vec(t0->a, 0, 0, 0, 0);
    assert_vec(t0->b, 4, 0, 0, 0);
    assert_vec(t0->c, 2, 1, 0, 0); /* the midpoint of b-c */
    assert_vec(t1->a, 0, 0, 0, 0);
    assert_vec(t1->b, 2, 1, 0, 0);
    assert_vec(t1->c, 0, 2, 0, 0);
    /* the same winding: both normals along +z, their areas summing to 4 */
    Vec3 n0 = vec_cross(vec_sub(t0->b, t0->a), vec_sub(t0->c, t0->a));
    Vec3 n1 = vec_cross(vec_sub(t1->b, t1->a), vec_sub(t1->c, t1->a));
    assert_true(n0.z > 0 && n1.z > 0);
    assert_float_equal(0.5f * (n0.z + n1.z), 4, 0);
    /* a smooth triangle's midpoint takes the normalised mean of its edge's normals */
    const Triangle *s0 = &s.prims[3].g.tri, *s1 = &s.prims[4].g.tri;
    assert_int_equal(s.prims[3].kind, PRIM_SMOOTH_TRIANGLE);
    assert_vec(s0->c, 1, 1, 1, 0);
    float h = 1 / sqrtf(2);
    assert_vec(s0->nc, h, h, 0, 1e-6f);
    assert_vec(s0->na, 0, 0, 1, 0);
    assert_vec(s1->nb, h, h, 0, 1e-6f);
    assert_vec(s1->nc, 0, 1, 0, 0);
    /* again: twice as many triangles once more */
    assert_int_equal(scene_split_triangles(&s), 0);
    assert_int_equal(s.nprims, 9);
    scene_free(&s);
}

static void test_scene_from_mesh(void **state)
{
    (void)state;
    Vec3 v[4] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    int tri[2][3] = {{0, 1, 2}, {0, 1, 3}};
    Mesh m = {.v = v, .nv = 4, .tri = tri, .nt = 2};
    Scene s;
    assert_int_equal(scene_from_mesh(&s, &m), 0);
    assert_int_equal(s.nmaterials, 1);
    assert_int_equal(s.nprims, 2);
    for (int i = 0; i < 2; i++) {
        assert_int_equal(s.prims[i].kind, PRIM_TRIANGLE);
        assert_int_equal(s.prims[i].material, 0);
    }
    assert_vec(s.prims[1].g.tri.c, 0, 0, 1, 0);
    scene_free(&s);
}

/* `test_scene --seeds DIR`: every bad scene of the table above as
 * DIR/scene: the fuzzer's seeds (tests/fuzz), beside the scenes/ files. */
static int write_seeds(const char *dir)
{
    char name[32];
    int rc = 0;
    for (size_t i = 0; i < sizeof bad_cases / sizeof bad_cases[0]; i++) {
        snprintf(name, sizeof name, "bad-%zu", i);
        rc |= test_write_seed(dir, "scene", name, bad_cases[i].text, bad_cases[i].len);
    }
    return rc ? 1 : 0;
}

/* The camera path: on a key, the key's camera exactly (fov from the camera
 * block when the key has none); between two keys, the line between them;
 * among more, Catmull-Rom's cubic, which keeps a uniform motion uniform
 * and gives the hand-computed value elsewhere; before the first key and
 * after the last, those keys. */
static void test_camera_path(void **state)
{
    (void)state;
    Scene s;
    char err[256];
    parse_ok(CAM "keyframe { frame 10 eye 0 0 -10 target 0 0 0 }\n"
                 "keyframe { frame 20 eye 10 0 -10 target 0 0 0 fov 60 }\n"
                 "keyframe { frame 30 eye 20 0 -10 target 0 0 0 }\n"
                 "keyframe { frame 50 eye 20 20 -10 target 0 0 0 }\n",
             &s);
    assert_int_equal(s.nkeys, 4);
    assert_int_equal(scene_camera_frame(&s, 20, err, sizeof err), 0);
    assert_true(s.camera.eye_at[0] == 10 && s.camera.eye_at[1] == 0 && s.camera.eye_at[2] == -10);
    assert_float_equal(s.camera.fovy, 60, 0);
    assert_int_equal(scene_camera_frame(&s, 10, err, sizeof err), 0);
    assert_float_equal(s.camera.fovy, 40, 0); /* the camera block's */
    assert_int_equal(scene_camera_frame(&s, 0, err, sizeof err), 0);
    assert_true(s.camera.eye_at[0] == 0 && s.camera.eye_at[2] == -10);
    assert_int_equal(scene_camera_frame(&s, 99, err, sizeof err), 0);
    assert_true(s.camera.eye_at[0] == 20 && s.camera.eye_at[1] == 20);
    /* x moves uniformly over keys 10, 20, 30, then stops; on 10..20 both
     * tangents are 1 a frame: linear */
    assert_int_equal(scene_camera_frame(&s, 13, err, sizeof err), 0);
    assert_float_equal(s.camera.eye_at[0], 3.0, 1e-12);
    /* y: 0, 0, 0 at 10, 20, 30 and 20 at 50. On 20..30 (h 10, s 0.5) the
     * tangents are 0 and (20 - 0) / (50 - 20): y = h11 h m1 with
     * h11 = s^3 - s^2 = -1/8, so -10/8 * 2/3 = -5/6 */
    assert_int_equal(scene_camera_frame(&s, 25, err, sizeof err), 0);
    assert_float_equal(s.camera.eye_at[1], -5.0 / 6.0, 1e-12);
    /* fov: 40, 60, 40 at 10, 20, 30 (the keys without one take the
     * block's). At 15: tangents (60 - 40) / 10 = 2, one-sided, and
     * (40 - 40) / 20 = 0: 40 h00 + 2 h10 h + 60 h01 = 20 + 2.5 + 30 */
    assert_int_equal(scene_camera_frame(&s, 15, err, sizeof err), 0);
    assert_float_equal(s.camera.fovy, 52.5f, 1e-5);
    scene_free(&s);
    /* two keys: a straight line, the midpoint at the middle frame */
    parse_ok(CAM "keyframe { frame 0 eye 0 0 -4 target 0 0 0 }\nkeyframe { frame 8 eye 4 2 -8 target 0 1 0 }\n",
             &s);
    assert_int_equal(scene_camera_frame(&s, 4, err, sizeof err), 0);
    assert_true(s.camera.eye_at[0] == 2 && s.camera.eye_at[1] == 1 && s.camera.eye_at[2] == -6);
    assert_true(s.camera.target_at[1] == 0.5);
    scene_free(&s);
    /* a path through the target: the eye meets it between keys */
    parse_ok(CAM "keyframe { frame 0 eye -1 0 0 target 0 0 0 }\nkeyframe { frame 2 eye 1 0 0 target 0 0 0 }\n", &s);
    assert_int_equal(scene_camera_frame(&s, 1, err, sizeof err), -1);
    assert_string_equal(err, "frame 1: the camera path puts the eye on the target");
    scene_free(&s);
    parse_ok(CAM, &s);
    assert_int_equal(scene_camera_frame(&s, 1, err, sizeof err), -1);
    assert_string_equal(err, "the scene has no camera path (no 'keyframe' block)");
    scene_free(&s);
}

/* Writes text to path. */
static void put_file(const char *path, const char *mode, const char *text)
{
    FILE *f = fopen(path, mode);
    assert_non_null(f);
    if (f) {
        fputs(text, f);
        fclose(f);
    }
}

/* The content hash of the scene file at path. */
static void hash_of(const char *path, char hex[SHA256_HEX])
{
    Scene s;
    char err[512];
    assert_int_equal(scene_load(path, &s, err, sizeof err), 0);
    scene_content_hash(&s, hex);
    scene_free(&s);
}

/* The content hash covers the scene file and its meshes as read: it
 * changes with a byte of either, and not with the scene file's name. */
static void test_content_hash(void **state)
{
    (void)state;
    char dir[] = "/tmp/lancer-hash-XXXXXX", path[256], scn[300], scn2[300];
    char h1[SHA256_HEX], h2[SHA256_HEX], h3[SHA256_HEX], h4[SHA256_HEX];
    temp_mesh(dir, path, sizeof path, "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
    const char *text = CAM "material m { }\nmesh { file \"quad.off\" material m }\n";
    snprintf(scn, sizeof scn, "%s/a.scn", dir);
    snprintf(scn2, sizeof scn2, "%s/b.scn", dir);
    put_file(scn, "w", text);
    put_file(scn2, "w", text);
    hash_of(scn, h1);
    hash_of(scn2, h2);
    assert_string_equal(h1, h2);
    put_file(path, "w", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 2 0\n3 0 1 2\n"); /* one coordinate of the mesh */
    hash_of(scn, h3);
    assert_string_not_equal(h1, h3);
    put_file(scn, "a", "# a comment\n"); /* a comment more in the scene */
    hash_of(scn, h4);
    assert_string_not_equal(h3, h4);
    unlink(path);
    unlink(scn);
    unlink(scn2);
    rmdir(dir);
}

/* A scene's lights take at most LIMIT_LIGHT_SAMPLES samples in all: 1,024
 * area lights of 64 x 64 do, the next one is refused at its samples (each
 * such line, 80 bytes, made the plan keep 80 KB, and 100,000 of them ran
 * out of 4 GiB), and a point light past them at its statement. */
static void test_light_samples_limit(void **state)
{
    (void)state;
    static char text[1100 * 90];
    const char *area = "light { position 0 9 0 area_u 1 0 0 area_v 0 0 1 area_samples 64 64 }\n";
    int len = snprintf(text, sizeof text, CAM);
    for (int i = 0; i < 1024; i++)
        len += snprintf(text + len, sizeof text - (size_t)len, "%s", area);
    Scene s;
    char err[256];
    assert_int_equal(scene_parse("t.scn", text, (size_t)len, &s, err, sizeof err), 0);
    assert_true(scene_light_samples(&s) == 1024 * 4096);
    scene_free(&s);
    int with_area = len + snprintf(text + len, sizeof text - (size_t)len, "%s", area);
    assert_int_equal(scene_parse("t.scn", text, (size_t)with_area, &s, err, sizeof err), -1);
    assert_string_equal(err, "t.scn:1026:63: light: the scene's lights would take 4198400 samples, more than 4194304 in all");
    int with_point = len + snprintf(text + len, sizeof text - (size_t)len, "light { position 0 9 0 }\n");
    assert_int_equal(scene_parse("t.scn", text, (size_t)with_point, &s, err, sizeof err), -1);
    assert_string_equal(err, "t.scn:1026:1: light: the scene's lights would take 4194305 samples, more than 4194304 in all");
}

int main(int argc, char **argv)
{
    if (argc == 3 && !strcmp(argv[1], "--seeds"))
        return write_seeds(argv[2]);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_bad_inputs),
        cmocka_unit_test(test_bad_inputs_truncated),
        cmocka_unit_test(test_error_buffer_truncation),
        cmocka_unit_test(test_full_scene),
        cmocka_unit_test(test_defaults),
        cmocka_unit_test(test_comments),
        cmocka_unit_test(test_crlf_and_tabs),
        cmocka_unit_test(test_utf8_bom),
        cmocka_unit_test(test_transform),
        cmocka_unit_test(test_object_transforms),
        cmocka_unit_test(test_double_coordinates),
        cmocka_unit_test(test_too_thin_once_moved),
        cmocka_unit_test(test_mesh_statement), cmocka_unit_test(test_mesh_that_vanishes), cmocka_unit_test(test_many_materials),
        cmocka_unit_test(test_pn_statements),
        cmocka_unit_test(test_number_forms),
        cmocka_unit_test(test_names),
        cmocka_unit_test(test_many_objects),
        cmocka_unit_test(test_load_missing_file),
        cmocka_unit_test(test_load_directory),
        cmocka_unit_test(test_load_bad_file),
        cmocka_unit_test(test_load_default_scene),
        cmocka_unit_test(test_scene_from_mesh),
        cmocka_unit_test(test_split_triangles),
        cmocka_unit_test(test_camera_path),
        cmocka_unit_test(test_content_hash),
        cmocka_unit_test(test_light_samples_limit),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
