/*
 * image.h - the framebuffer and its writers: OpenEXR (linear) and PNG preview.
 *
 *     Image img;
 *     if (image_init(&img, w, h) != 0) ... out of memory ...
 *     img.rgb[3 * (y * w + x) + c] = value;      row 0 is the top row
 *     if (image_write_exr(&img, "out/a.exr", IMAGE_HALF, err, sizeof err) != 0) ...
 *     image_free(&img);
 *
 * Pixels are linear RGB floats. The EXR keeps them linear (half or 32-bit
 * float channels R, G, B); the PNG is an 8-bit sRGB-encoded, clamped preview.
 * Every writer goes through afile.h: a failed write leaves the previous file
 * untouched and no temporary file behind. Functions return 0 on success or
 * -1 with a one-line message (no trailing newline) in err; they never print.
 */
#ifndef LANCER_IMAGE_H
#define LANCER_IMAGE_H

#include <stddef.h>

#include "lancer/limits.h"

typedef struct {
    int width, height;
    float *rgb; /* width * height * 3 floats, owned by the Image */
    /* Where it lies in the full picture (a tile of a larger render): its
     * top-left pixel, and the full picture's size. image_init makes an
     * image its own full picture; in an EXR these are the data window and
     * the display window. */
    int x, y, full_width, full_height;
} Image;

typedef enum { IMAGE_HALF, IMAGE_FLOAT } ImagePrecision;

/* The largest image: LIMIT_IMAGE_SIDE and LIMIT_IMAGE_PIXELS (limits.h). */

/* Allocates a black image. Returns 0, or -1 on a bad size (a side outside
 * 1..LIMIT_IMAGE_SIDE or more than LIMIT_IMAGE_PIXELS pixels) or no memory
 * (img is then empty and image_free is still safe). */
int image_init(Image *img, int width, int height);
void image_free(Image *img);

/* OpenEXR through OpenEXRCore (openexr.h): one scanline part whose data
 * window is the image and display window its full picture, ZIP
 * compression, channels R, G, B (stored in the file's alphabetical order
 * B, G, R) as half or 32-bit float. Half rounds to nearest even: magnitudes
 * from 65520 up become infinity, tiny values become subnormals or zero, NaN
 * stays NaN. */
int image_write_exr(const Image *img, const char *path, ImagePrecision prec, char *err, size_t errlen);

/* A string attribute of an EXR header, such as "lancer:rows". */
typedef struct {
    const char *name, *value;
} ImageAttr;

/* image_write_exr into the file `file` itself (a temporary file the caller
 * commits, afile.h), with nattrs string attributes in its header, its
 * chunks compressed on up to `threads` threads (the same bytes for any
 * number); messages name `name`, the file the user knows. */
int image_write_exr_file(const Image *img, const char *file, const char *name, ImagePrecision prec,
                         const ImageAttr *attrs, int nattrs, int threads, char *err, size_t errlen);

/* Reads the R, G and B channels of a scanline or tiled EXR into a new image
 * (img must be uninitialised or freed); missing channels read as 0, but
 * a file with none of the three is an error (nothing to compare). The
 * image is the data window, placed in the display window (x, y,
 * full_width and full_height; a data window that is not inside the display
 * window makes a picture of its own); half, float and uint
 * channels all become float; tiled files give their full-resolution level
 * and multi-part files their first part. Deep data and subsampled R, G or B
 * are errors. On failure img is left empty. */
int image_read_exr(const char *path, Image *img, char *err, size_t errlen);

/* image_read_exr of an EXR held in memory (len bytes at data); messages
 * name `name`. */
int image_parse_exr(const char *name, const void *data, size_t len, Image *img, char *err, size_t errlen);

/* What an EXR's header says beside its pixels: its string attributes whose
 * names start with "lancer:", and whether R, G and B are all half. */
#define IMAGE_META_MAX 16
typedef struct {
    int n;
    char *name[IMAGE_META_MAX], *value[IMAGE_META_MAX];
    int half;
} ImageMeta;

/* image_read_exr, and the header's ImageMeta into *meta (freed with
 * image_meta_free, also after a failure). */
int image_read_exr_meta(const char *path, Image *img, ImageMeta *meta, char *err, size_t errlen);
/* The same of an EXR held in memory. */
int image_parse_exr_meta(const char *name, const void *data, size_t len, Image *img, ImageMeta *meta, char *err,
                         size_t errlen);
void image_meta_free(ImageMeta *meta);
/* The value of attribute `name`, or NULL. */
const char *image_meta_get(const ImageMeta *meta, const char *name);

/* 8-bit RGB PNG: each channel clamped to [0,1] and sRGB-encoded. */
int image_write_png(const Image *img, const char *path, char *err, size_t errlen);

/* image_write_png into the file `file` itself (a temporary file the caller
 * commits); messages name `name`. With prec IMAGE_HALF, the preview of the
 * image as a half EXR holds it: each value rounded to half first
 * (image_half_round), so that it is the one that `lancer merge` makes of
 * that EXR's tiles. */
int image_write_png_file(const Image *img, const char *file, const char *name, ImagePrecision prec, char *err,
                         size_t errlen);

/* x rounded to the nearest half-precision value, ties to even, as OpenEXR
 * stores a half channel: past 65504 by half a step or more an infinity,
 * below 2^-14 a subnormal; a NaN stays a NaN. */
float image_half_round(float x);

/* The sRGB transfer function applied to one linear value, clamped, as an
 * 8-bit code value (rounded to nearest): 0 and below, and NaN, give 0; 1 and
 * above give 255. */
unsigned char image_srgb8(float linear);

#endif
