/*
 * stamp.h - what an image lancer writes says of its own making, in its
 * EXR header: the scene's content hash, the settings that change pixels,
 * lancer's version and the frame. Tiles are merged, and partial renders
 * resumed, only when their stamps agree.
 *
 *     Stamp st;
 *     stamp_make(&st, &scene, &plan, &opts, use_float, frame);
 *     ImageAttr attrs[STAMP_ATTRS + 1];
 *     int n = stamp_attrs(&st, attrs);
 *     ... image_write_exr_file(img, tmp, path, prec, attrs, n, ...)
 *     if (stamp_differs(&st, &meta, why, sizeof why)) ... why ...
 */
#ifndef LANCER_CLI_STAMP_H
#define LANCER_CLI_STAMP_H

#include <stddef.h>

#include "lancer/image.h"
#include "lancer/plan.h"
#include "lancer/sha256.h"

#define STAMP_ATTRS 5 /* scene, scene_hash, settings, version, frame */

typedef struct {
    char scene[1024];        /* the scene file's path, for people */
    char hash[SHA256_HEX];   /* scene_content_hash */
    char settings[768];      /* "key=value" words, one for each setting that changes pixels */
    char frame[16];          /* the frame number, or "still" */
} Stamp;

/* The stamp of a render of scene s under plan p (built from options o),
 * written with 32-bit float channels or half, at `frame` (-1: a still). */
void stamp_make(Stamp *st, const char *scene, const Scene *s, const RenderPlan *p, const PlanOptions *o,
                int use_float, int frame);

/* The stamp as EXR attributes ("lancer:scene", ...). Returns how many. */
int stamp_attrs(const Stamp *st, ImageAttr *attrs);

/* 0 when the header's stamp (meta) is st's; else 1, with what differs, for
 * people, in why ("the scene's content differs", "spp=2, not spp=3", ...). */
int stamp_differs(const Stamp *st, const ImageMeta *meta, char *why, size_t len);

/* The same between two headers (merge): a is the reference. */
int stamp_meta_differs(const ImageMeta *a, const ImageMeta *b, char *why, size_t len);

#endif
