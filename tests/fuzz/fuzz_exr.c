/*
 * fuzz_exr.c - the EXR reader that `lancer diff` uses (image_parse_exr).
 * An image that reads must be valid (a size within the limits, its pixels
 * there); one that does not must leave the Image empty and a message
 * "fuzz.in: ...". The allocation a header may ask for is bounded by the
 * input's size (src/image.c); libFuzzer's -malloc_limit_mb catches more.
 */
#include "fuzz.h"

#include "lancer/image.h"
#include "lancer/limits.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    Image img;
    char err[1024] = "";
    if (image_parse_exr(FUZZ_NAME, data, size, &img, err, sizeof err) != 0) {
        fuzz_check_message(err, 0, 0);
        fuzz_require(!img.rgb && !img.width && !img.height, "a failed read left an image", err);
        return 0;
    }
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
