/*
 * camera.c - pinhole camera; see camera.h for the mapping.
 */
#include "lancer/camera.h"

void camera_init(Camera *cam, const CameraSpec *spec, int width, int height)
{
    /* tan in double: fovy is in degrees and the conversion loses nothing. */
    float t = (float)tan((double)spec->fovy * 3.14159265358979323846 / 360.0);
    float a = (float)width / (float)height;
    cam->eye = spec->eye;
    cam->f = vec_normalize(vec_sub(spec->target, spec->eye));
    Vec3 r = vec_normalize(vec_cross(cam->f, spec->up));
    Vec3 u = vec_cross(r, cam->f);
    cam->r = vec_scale(r, t * a);
    cam->u = vec_scale(u, t);
    cam->inv_w = 1.0f / (float)width;
    cam->inv_h = 1.0f / (float)height;
}
