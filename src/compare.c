/*
 * compare.c - image differences (see compare.h).
 */
#include "lancer/compare.h"

#include <math.h>
#include <stdio.h>

/* 0 when a and b are the same pixels of a picture: one size, one place. */
static int same_part(const Image *a, const Image *b, char *err, size_t errlen)
{
    if (a->width != b->width || a->height != b->height) {
        snprintf(err, errlen, "the images differ in size: %dx%d and %dx%d", a->width, a->height, b->width, b->height);
        return -1;
    }
    /* two parts of a picture: as many pixels, but not the same ones */
    if (a->x != b->x || a->y != b->y || a->full_width != b->full_width || a->full_height != b->full_height) {
        snprintf(err, errlen,
                 "the images are different parts of their pictures: %dx%d at %d,%d of %dx%d and at %d,%d of %dx%d",
                 a->width, a->height, a->x, a->y, a->full_width, a->full_height, b->x, b->y, b->full_width,
                 b->full_height);
        return -1;
    }
    return 0;
}

static double absdiff(float x, float y)
{
    if (x == y || (x != x && y != y)) /* two NaNs: the same, as a file against itself */
        return 0.0;
    double d = fabs((double)x - (double)y);
    return isnan(d) ? INFINITY : d;
}

/* The largest channel difference of pixel i; *over: whether a channel
 * differs by more than threshold and relative times its larger value. */
static double pixel_diff(const Image *a, const Image *b, size_t i, double threshold, double relative, int *over,
                         double *sum, double *sum2)
{
    double m = 0.0;
    *over = 0;
    for (int c = 0; c < 3; c++) {
        const float x = a->rgb[3 * i + c], y = b->rgb[3 * i + c];
        double d = absdiff(x, y);
        *sum += d;
        *sum2 += d * d;
        if (d > m)
            m = d;
        if (d > threshold && !(d <= relative * fmax(fabs((double)x), fabs((double)y))))
            *over = 1;
    }
    return m;
}

int compare_images(const Image *a, const Image *b, double threshold, double relative, CompareStats *st, char *err,
                   size_t errlen)
{
    if (same_part(a, b, err, errlen))
        return -1;
    size_t n = (size_t)a->width * (size_t)a->height;
    double sum = 0.0, sum2 = 0.0;
    st->max = 0.0;
    st->over = 0;
    st->max_x = st->max_y = 0;
    for (size_t i = 0; i < n; i++) {
        int over;
        double m = pixel_diff(a, b, i, threshold, relative, &over, &sum, &sum2);
        st->over += over;
        if (m > st->max) {
            st->max = m;
            st->max_x = (int)(i % (size_t)a->width);
            st->max_y = (int)(i / (size_t)a->width);
        }
    }
    st->pixels = (long)n;
    st->mean = sum / (3.0 * (double)n);
    double mse = sum2 / (3.0 * (double)n);
    st->rms = sqrt(mse);
    st->psnr = mse > 0.0 ? 10.0 * log10(1.0 / mse) : INFINITY;
    return 0;
}

int compare_downsample(const Image *src, int k, Image *dst, char *err, size_t errlen)
{
    if (k < 1 || src->width % k != 0 || src->height % k != 0) {
        snprintf(err, errlen, "a %dx%d image cannot be averaged in %dx%d blocks", src->width, src->height, k, k);
        return -1;
    }
    if (src->x % k || src->y % k || src->full_width % k || src->full_height % k) {
        snprintf(err, errlen, "a %dx%d part at %d,%d of a %dx%d picture cannot be averaged in %dx%d blocks", src->width,
                 src->height, src->x, src->y, src->full_width, src->full_height, k, k);
        return -1;
    }
    if (image_init(dst, src->width / k, src->height / k) != 0) {
        snprintf(err, errlen, "out of memory");
        return -1;
    }
    dst->x = src->x / k; /* the same part of the picture, k times smaller */
    dst->y = src->y / k;
    dst->full_width = src->full_width / k;
    dst->full_height = src->full_height / k;
    for (int y = 0; y < dst->height; y++)
        for (int x = 0; x < dst->width; x++)
            for (int c = 0; c < 3; c++) {
                double s = 0.0; /* double: k*k float terms summed without drift */
                for (int j = 0; j < k; j++)
                    for (int i = 0; i < k; i++)
                        s += src->rgb[3 * ((size_t)(y * k + j) * (size_t)src->width + (size_t)(x * k + i)) + c];
                dst->rgb[3 * ((size_t)y * (size_t)dst->width + (size_t)x) + c] = (float)(s / (k * k));
            }
    return 0;
}

/* Colour ramp over log10 of the difference, its stops in step with the
 * threshold (at the default 2e-3: 1e-5, 1e-4, 1e-3), so that they stay in
 * order whatever the threshold is. */
static void ramp(double d, double threshold, float *rgb)
{
    static const float stops[5][3] = {{0, 0, 0}, {0, 0, 1}, {0, 1, 1}, {1, 1, 0}, {1, 0, 0}};
    const double at[5] = {threshold / 200.0, threshold / 20.0, threshold / 2.0, threshold, 100.0 * threshold};
    double x = d;
    int s = 0;
    while (s < 4 && x > at[s + 1])
        s++;
    if (s == 4 || x <= at[0]) {
        for (int c = 0; c < 3; c++)
            rgb[c] = stops[x <= at[0] ? 0 : 4][c];
        return;
    }
    double f = (log10(x) - log10(at[s])) / (log10(at[s + 1]) - log10(at[s]));
    for (int c = 0; c < 3; c++)
        rgb[c] = (float)((1.0 - f) * stops[s][c] + f * stops[s + 1][c]);
}

int compare_heatmap(const Image *a, const Image *b, double threshold, Image *dst, char *err, size_t errlen)
{
    if (same_part(a, b, err, errlen))
        return -1;
    if (image_init(dst, a->width, a->height) != 0) {
        snprintf(err, errlen, "out of memory");
        return -1;
    }
    size_t n = (size_t)a->width * (size_t)a->height;
    double sum = 0.0, sum2 = 0.0;
    int over;
    for (size_t i = 0; i < n; i++)
        ramp(pixel_diff(a, b, i, threshold, 0.0, &over, &sum, &sum2), threshold, &dst->rgb[3 * i]);
    return 0;
}
