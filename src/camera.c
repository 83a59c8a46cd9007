/*
 * camera.c - pinhole camera; see camera.h for the mapping.
 */
#include "lancer/camera.h"

#include <float.h>

/* (not where floats are evaluated wider, as on i386's x87: bit for bit
 * needs float arithmetic) */
#if defined(__SSE2__) && !defined(LANCER_NO_SIMD) && FLT_EVAL_METHOD == 0
#include <emmintrin.h>
#define CAMERA_SSE 1
#endif

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

void camera_rays(const Camera *cam, const float *x, const float *y, int n, Ray *out)
{
    int k = 0;
#ifdef CAMERA_SSE
    /* camera_ray's operations in its order, lane by lane */
    const __m128 one = _mm_set1_ps(1.0f), two = _mm_set1_ps(2.0f);
    for (; k + 4 <= n; k += 4) {
        __m128 sx = _mm_sub_ps(_mm_mul_ps(_mm_mul_ps(two, _mm_loadu_ps(x + k)), _mm_set1_ps(cam->inv_w)), one);
        __m128 sy = _mm_sub_ps(one, _mm_mul_ps(_mm_mul_ps(two, _mm_loadu_ps(y + k)), _mm_set1_ps(cam->inv_h)));
#define DIR(c) \
    _mm_add_ps(_mm_set1_ps(cam->f.c), _mm_add_ps(_mm_mul_ps(_mm_set1_ps(cam->r.c), sx), _mm_mul_ps(_mm_set1_ps(cam->u.c), sy)))
        __m128 dx = DIR(x), dy = DIR(y), dz = DIR(z);
#undef DIR
        __m128 len = _mm_sqrt_ps(_mm_add_ps(_mm_add_ps(_mm_mul_ps(dx, dx), _mm_mul_ps(dy, dy)), _mm_mul_ps(dz, dz)));
        __m128 inv = _mm_div_ps(one, len), pos = _mm_cmpgt_ps(len, _mm_setzero_ps());
        float d[3][4];
        _mm_storeu_ps(d[0], _mm_or_ps(_mm_and_ps(pos, _mm_mul_ps(dx, inv)), _mm_andnot_ps(pos, dx)));
        _mm_storeu_ps(d[1], _mm_or_ps(_mm_and_ps(pos, _mm_mul_ps(dy, inv)), _mm_andnot_ps(pos, dy)));
        _mm_storeu_ps(d[2], _mm_or_ps(_mm_and_ps(pos, _mm_mul_ps(dz, inv)), _mm_andnot_ps(pos, dz)));
        for (int i = 0; i < 4; i++)
            out[k + i] = ray_make(cam->eye, vec3(d[0][i], d[1][i], d[2][i]), INFINITY);
    }
#endif
    for (; k < n; k++)
        out[k] = camera_ray(cam, x[k], y[k]);
}
