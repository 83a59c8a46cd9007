/*
 * stamp.c - what an image says of its own making (see stamp.h).
 */
#include "stamp.h"

#include <stdio.h>
#include <string.h>

#include "cli.h"

void stamp_make(Stamp *st, const char *scene, const Scene *s, const RenderPlan *p, const PlanOptions *o,
                int use_float, int frame)
{
    snprintf(st->scene, sizeof st->scene, "%s", scene);
    scene_content_hash(s, st->hash);
    /* %.17g gives back the double exactly, %.9g the float. The move is the
     * options' (the plan's own camera-relative move follows from it); the
     * threads and --no-plan change no pixel. The acceleration structure
     * can: the classic routines can hit, without the tree's boxes, what the
     * tree would not have tested, and the robust ones break a tie between
     * coincident PN patches by the pieces the tree splits them into. It is
     * part of the routines' name. */
    char intersect[16];
    snprintf(intersect, sizeof intersect, "%s-%s", p->variant == PRIM_CLASSIC ? "classic" : "robust",
             p->loop ? "loop" : "bvh");
    char area[16] = "scene", adaptive[16] = "scene", pn[16] = "scene";
    if (o->area_samples)
        snprintf(area, sizeof area, "%d", o->area_samples);
    if (o->area_adaptive)
        snprintf(adaptive, sizeof adaptive, "%d", o->area_adaptive - 1);
    if (o->pn_mode)
        snprintf(pn, sizeof pn, "%s", o->pn_mode - 1 == PN_FAST ? "fast" : "exact");
    snprintf(st->settings, sizeof st->settings,
             "size=%dx%d spp=%d max_depth=%d intersect=%s adc_bailout=%.9g aa_threshold=%.9g area_samples=%s "
             "area_adaptive=%s pn_mode=%s scale=%.17g translate=%.17g,%.17g,%.17g channels=%s",
             p->width, p->height, p->spp, p->max_depth, intersect,
             (double)p->adc_bailout, (double)p->aa_threshold, area, adaptive, pn, o->move ? o->scale : 1.0,
             o->move ? o->translate[0] : 0.0, o->move ? o->translate[1] : 0.0, o->move ? o->translate[2] : 0.0,
             use_float ? "float" : "half");
    if (frame >= 0)
        snprintf(st->frame, sizeof st->frame, "%d", frame);
    else
        snprintf(st->frame, sizeof st->frame, "still");
}

int stamp_attrs(const Stamp *st, ImageAttr *attrs)
{
    attrs[0] = (ImageAttr){"lancer:scene", st->scene};
    attrs[1] = (ImageAttr){"lancer:scene_hash", st->hash};
    attrs[2] = (ImageAttr){"lancer:settings", st->settings};
    attrs[3] = (ImageAttr){"lancer:version", LANCER_VERSION};
    attrs[4] = (ImageAttr){"lancer:frame", st->frame};
    return STAMP_ATTRS;
}

/* The first word of settings a and b that differs, as "b's, not a's". */
static void settings_diff(const char *a, const char *b, char *why, size_t len)
{
    while (*a || *b) {
        size_t na = strcspn(a, " "), nb = strcspn(b, " ");
        if (na != nb || strncmp(a, b, na) != 0) {
            snprintf(why, len, "rendered with %.*s, not %.*s", (int)nb, b, (int)na, a);
            return;
        }
        a += na + (a[na] == ' ');
        b += nb + (b[nb] == ' ');
    }
    snprintf(why, len, "rendered with other settings");
}

/* Compares the stamp values a (the reference) and b. */
static int differs(const char *hash_a, const char *settings_a, const char *version_a, const char *frame_a,
                   const ImageMeta *b, char *why, size_t len)
{
    const char *hash = image_meta_get(b, "lancer:scene_hash"), *settings = image_meta_get(b, "lancer:settings");
    const char *version = image_meta_get(b, "lancer:version"), *frame = image_meta_get(b, "lancer:frame");
    if (!hash || !settings || !version || !frame)
        snprintf(why, len, "has no lancer stamp in its header (not an image that lancer rendered)");
    else if (strcmp(hash, hash_a) != 0)
        snprintf(why, len, "rendered from another scene, or from its files as they were before they changed "
                           "(scene hash %.12s..., not %.12s...)", hash, hash_a);
    else if (strcmp(settings, settings_a) != 0)
        settings_diff(settings_a, settings, why, len);
    else if (strcmp(version, version_a) != 0)
        snprintf(why, len, "rendered by lancer %s, not %s", version, version_a);
    else if (strcmp(frame, frame_a) != 0)
        snprintf(why, len, "is frame %s, not %s", frame, frame_a);
    else
        return 0;
    return 1;
}

int stamp_differs(const Stamp *st, const ImageMeta *meta, char *why, size_t len)
{
    return differs(st->hash, st->settings, LANCER_VERSION, st->frame, meta, why, len);
}

int stamp_meta_differs(const ImageMeta *a, const ImageMeta *b, char *why, size_t len)
{
    const char *hash = image_meta_get(a, "lancer:scene_hash"), *settings = image_meta_get(a, "lancer:settings");
    const char *version = image_meta_get(a, "lancer:version"), *frame = image_meta_get(a, "lancer:frame");
    if (!hash || !settings || !version || !frame) {
        snprintf(why, len, "has no lancer stamp in its header (not an image that lancer rendered)");
        return 1;
    }
    return differs(hash, settings, version, frame, b, why, len);
}
