/*
 * compare.h - pixel differences between two images, for parity tests.
 *
 *     CompareStats st;
 *     if (compare_images(&a, &b, COMPARE_THRESHOLD, 0.0, &st, err, sizeof err) != 0) ...
 *     printf("max=%g over=%ld\n", st.max, st.over);
 *
 * Differences are absolute, per channel, in linear units. A pixel is "over"
 * when any of its channels differs by more than the threshold, or than
 * `relative` times the larger of the two values if that is more. Equal values
 * (infinities included) differ by 0; a NaN on one side, or infinities that
 * do not match, differ by infinity.
 */
#ifndef LANCER_COMPARE_H
#define LANCER_COMPARE_H

#include <stddef.h>

#include "lancer/image.h"

/* Half-float rounding of values up to about 4 is 2^-11 * 4 = 2e-3: the
 * tolerance of the parity tests; above, it is 2^-11 of the value
 * (COMPARE_HALF). */
#define COMPARE_THRESHOLD 2e-3
#define COMPARE_HALF 0x1p-11

typedef struct {
    double max, mean, rms;
    double psnr; /* 10 log10(1 / mse), peak 1.0; +inf when identical */
    long over, pixels;
    int max_x, max_y; /* where max was found */
} CompareStats;

/* Returns 0, or -1 with a message when the sizes differ. */
int compare_images(const Image *a, const Image *b, double threshold, double relative, CompareStats *st, char *err,
                   size_t errlen);

/* Averages src in k x k blocks into dst (a new image of size w/k x h/k): the
 * box filter that turns a k-times supersampled render into a pixel each.
 * Returns 0, or -1 when the size is not a multiple of k or memory runs out. */
int compare_downsample(const Image *src, int k, Image *dst, char *err, size_t errlen);

/* A false-colour map of the largest channel difference of each pixel, on a
 * log scale, T the threshold: black up to T/200, blue at T/20, cyan at T/2,
 * yellow at T and red from 100 T up. dst is a new image. */
int compare_heatmap(const Image *a, const Image *b, double threshold, Image *dst, char *err, size_t errlen);

#endif
