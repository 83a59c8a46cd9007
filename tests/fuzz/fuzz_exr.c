/*
 * fuzz_exr.c - the EXR reader that `lancer diff` uses (image_parse_exr).
 * An image that reads must be valid (a size within the limits, its pixels
 * there); one that does not must leave the Image empty and a message
 * "fuzz.in: ...". Its place in the picture lies inside the picture, and
 * the header's lancer: strings are whole. The allocation a header may ask for is bounded by the
 * input's size (src/image.c); libFuzzer's -malloc_limit_mb catches more.
 */
#include "fuzz.h"

#include <string.h>

#include "lancer/image.h"
#include "lancer/limits.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    Image img;
    ImageMeta meta;
    char err[1024] = "";
    memset(&meta, 0, sizeof meta);
    if (image_parse_exr_meta(FUZZ_NAME, data, size, &img, &meta, err, sizeof err) != 0) {
        fuzz_check_message(err, 0, 0);
        fuzz_require(!img.rgb && !img.width && !img.height, "a failed read left an image", err);
        image_meta_free(&meta);
        return 0;
    }
    fuzz_require(img.x >= 0 && img.y >= 0 && img.x + img.width <= img.full_width &&
                     img.y + img.height <= img.full_height && img.full_width <= LIMIT_IMAGE_SIDE &&
                     img.full_height <= LIMIT_IMAGE_SIDE,
                 "the image's place is outside its picture", "x, y, full size");
    for (int i = 0; i < meta.n; i++)
        fuzz_require(strncmp(meta.name[i], "lancer:", 7) == 0 && strlen(meta.value[i]) < size,
                     "a header string is not what the file holds", meta.name[i]);
    image_meta_free(&meta);
    fuzz_require(img.rgb && img.width >= 1 && img.height >= 1 && img.width <= LIMIT_IMAGE_SIDE &&
                     img.height <= LIMIT_IMAGE_SIDE && (long)img.width * img.height <= LIMIT_IMAGE_PIXELS,
                 "the image read is not valid", "size or pixels");
    /* every pixel is there to be read (ASan checks the bounds) */
    volatile float sum = 0.0f;
    for (size_t i = 0; i < 3 * (size_t)img.width * (size_t)img.height; i += 97)
        sum += img.rgb[i];
    (void)sum;
    image_free(&img);
    return 0;
}
