/*
 * pov.h - export a scene as the POV-Ray 3.7 scene that renders the same
 * picture, so that POV-Ray can serve as the reference renderer.
 *
 *     FILE *f = ...;
 *     if (pov_export(&scene, 0, 0, 0, f) != 0) ... a write failed ...
 *
 * The mapping follows docs/povray-rules.md, section 0: linear output (assumed_gamma
 * 1), no ambient light beyond each finish's own, the scene's adc_bailout
 * (the same rays cut as lancer's), max_trace_level = max_depth, and the right-handed
 * camera as `right -x*a` with the horizontal angle. Every finish value is
 * written out, so POV-Ray's defaults never matter. Numbers are printed with
 * 9 significant digits, which round-trips every float exactly. The output
 * has no timestamp: the same scene always gives the same bytes, which lets
 * references be cached by a hash of the .pov file.
 */
#ifndef LANCER_POV_H
#define LANCER_POV_H

#include <stdio.h>

#include "lancer/scene.h"

/* PN patches are written as smooth meshes of this many segments per edge
 * unless the caller asks for another number. */
#define POV_PN_SEGMENTS 16

/* Writes the scene to f, for an image of width x height pixels (0: the
 * scene's own size), each PN patch tessellated into pn_segments^2
 * triangles (0: POV_PN_SEGMENTS) with its shading normals. Returns 0, or
 * -1 if a write to f failed or memory ran out. */
int pov_export(const Scene *s, int width, int height, int pn_segments, FILE *f);

#endif
