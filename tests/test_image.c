/*
 * test_image.c - image.c: EXR and PNG round trips, the sRGB transfer, and
 * what a failed write or read leaves behind. Each test gets a fresh
 * directory under /tmp, removed afterwards.
 */
#if defined(__linux__)
#define _DEFAULT_SOURCE /* mincore */
#endif
#include <stdarg.h>
#include <stddef.h>
#include <float.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include "lancer/image.h"
#include "testutil.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

/* OpenEXRCore's headers use C11 anonymous structs (see image.c). */
#if defined(__GNUC__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wpedantic"
#endif
#include <openexr.h>
#if defined(__GNUC__)
#pragma GCC diagnostic pop
#endif

#include <png.h>

/* ---- helpers ------------------------------------------------------------ */

typedef struct {
    char dir[256];
    char path[512];       /* scratch for join() */
    int quiet_fd;         /* saved stderr while capturing, else -1 */
    char quiet_path[600]; /* where stderr goes meanwhile */
} Fixture;

static const char *join(Fixture *f, const char *name)
{
    int n = snprintf(f->path, sizeof f->path, "%s/%s", f->dir, name);
    assert_true(n > 0 && (size_t)n < sizeof f->path);
    return f->path;
}

static void remove_tree(const char *path)
{
    struct stat st;
    if (lstat(path, &st) != 0)
        return;
    if (S_ISDIR(st.st_mode)) {
        DIR *d = opendir(path);
        if (d != NULL) {
            struct dirent *de;
            while ((de = readdir(d)) != NULL) {
                if (strcmp(de->d_name, ".") == 0 || strcmp(de->d_name, "..") == 0)
                    continue;
                char sub[1024];
                snprintf(sub, sizeof sub, "%s/%s", path, de->d_name);
                remove_tree(sub);
            }
            closedir(d);
        }
        rmdir(path);
    } else {
        unlink(path);
    }
}

/* Library code never prints: failing calls run with stderr sent to a file,
 * which must stay empty. If an assertion fires meanwhile, teardown restores
 * stderr and replays what was captured, cmocka's message included. */
static void quiet_begin(Fixture *f)
{
    snprintf(f->quiet_path, sizeof f->quiet_path, "%s/stderr.txt", f->dir);
    fflush(stderr);
    f->quiet_fd = dup(2);
    assert_true(f->quiet_fd >= 0);
    int fd = open(f->quiet_path, O_WRONLY | O_CREAT | O_TRUNC, 0600);
    assert_true(fd >= 0);
    assert_int_equal(dup2(fd, 2), 2);
    close(fd);
}

/* Restores stderr; returns the number of bytes captured. */
static long quiet_restore(Fixture *f)
{
    if (f->quiet_fd < 0)
        return 0;
    fflush(stderr);
    dup2(f->quiet_fd, 2);
    close(f->quiet_fd);
    f->quiet_fd = -1;
    long n = 0;
    FILE *fp = fopen(f->quiet_path, "rb");
    if (fp != NULL) {
        int c;
        while ((c = getc(fp)) != EOF) {
            fputc(c, stderr);
            n++;
        }
        fclose(fp);
    }
    unlink(f->quiet_path);
    return n;
}

static void quiet_end(Fixture *f)
{
    assert_int_equal(quiet_restore(f), 0);
}

static int setup(void **state)
{
    Fixture *f = calloc(1, sizeof *f);
    if (f == NULL)
        return -1;
    snprintf(f->dir, sizeof f->dir, "/tmp/lancer-test-image-XXXXXX");
    if (mkdtemp(f->dir) == NULL) {
        free(f);
        return -1;
    }
    f->quiet_fd = -1;
    *state = f;
    return 0;
}

static int teardown(void **state)
{
    Fixture *f = *state;
    quiet_restore(f);
    remove_tree(f->dir);
    free(f);
    return 0;
}

/* Leftover afile temporaries ("<target>.tmp.XXXXXX") in the fixture dir. */
static int count_tmp_files(const Fixture *f)
{
    DIR *d = opendir(f->dir);
    assert_non_null(d);
    int n = 0;
    struct dirent *de;
    while ((de = readdir(d)) != NULL)
        if (strstr(de->d_name, ".tmp.") != NULL)
            n++;
    closedir(d);
    return n;
}

static unsigned char *slurp(const char *path, size_t *len)
{
    FILE *fp = fopen(path, "rb");
    assert_non_null(fp);
    assert_int_equal(fseek(fp, 0, SEEK_END), 0);
    long n = ftell(fp);
    assert_true(n >= 0);
    rewind(fp);
    unsigned char *buf = malloc((size_t)n + 1);
    assert_non_null(buf);
    assert_int_equal(fread(buf, 1, (size_t)n, fp), (size_t)n);
    fclose(fp);
    *len = (size_t)n;
    return buf;
}

static void spill(const char *path, const void *data, size_t len)
{
    FILE *fp = fopen(path, "wb");
    assert_non_null(fp);
    assert_int_equal(fwrite(data, 1, len, fp), len);
    assert_int_equal(fclose(fp), 0);
}

/* Deterministic pseudo-random numbers (xorshift32), same on every run. */
static uint32_t rng_next(uint32_t *s)
{
    uint32_t x = *s;
    x ^= x << 13;
    x ^= x >> 17;
    x ^= x << 5;
    return *s = x;
}

static float bits_to_float(uint32_t u)
{
    float f;
    memcpy(&f, &u, sizeof f);
    return f;
}

static uint32_t float_to_bits(float f)
{
    uint32_t u;
    memcpy(&u, &f, sizeof u);
    return u;
}

/* Value of a positive finite half bit pattern (0 .. 0x7BFF), computed
 * independently of OpenEXR. */
static double half_value(unsigned h)
{
    unsigned e = h >> 10, m = h & 0x3FF;
    return e == 0 ? ldexp((double)m, -24) : ldexp((double)(1024 + m), (int)e - 25);
}

/* Reference float -> half -> float: round to nearest, ties to even. Positive
 * finite halves are ordered like their bit patterns, so a binary search
 * finds the two neighbours of |v|. */
static float ref_half(float v)
{
    if (isnan(v))
        return v;
    double a = fabs((double)v);
    double s = signbit(v) ? -1.0 : 1.0;
    if (a >= 65520.0) /* halfway between 65504 and 2^16: ties to even -> inf */
        return (float)(s * INFINITY);
    unsigned lo = 0, hi = 0x7BFF;
    while (lo < hi) { /* largest h with half_value(h) <= a */
        unsigned mid = (lo + hi + 1) / 2;
        if (half_value(mid) <= a)
            lo = mid;
        else
            hi = mid - 1;
    }
    unsigned h = lo;
    if (h < 0x7BFF) {
        double d0 = a - half_value(h), d1 = half_value(h + 1) - a;
        if (d1 < d0 || (d1 == d0 && (h & 1u)))
            h++;
    }
    return (float)(s * half_value(h));
}

static void fill_random_floats(Image *img, uint32_t seed)
{
    size_t n = (size_t)img->width * (size_t)img->height * 3;
    for (size_t i = 0; i < n; i++) {
        uint32_t u;
        do
            u = rng_next(&seed);
        while (((u >> 23) & 0xFF) == 0xFF); /* finite only */
        img->rgb[i] = bits_to_float(u);
    }
}

/* ---- image_init --------------------------------------------------------- */

static void test_init_sizes(void **state)
{
    (void)state;
    Image img;
    assert_int_equal(image_init(&img, 0, 5), -1);
    assert_null(img.rgb);
    assert_int_equal(img.width, 0);
    image_free(&img);
    assert_int_equal(image_init(&img, 5, -1), -1);
    assert_int_equal(image_init(&img, LIMIT_IMAGE_SIDE + 1, 1), -1);
    assert_int_equal(image_init(&img, 1, LIMIT_IMAGE_SIDE + 1), -1);
    /* each side fits, but the pixel count is over LIMIT_IMAGE_PIXELS */
    assert_int_equal(image_init(&img, LIMIT_IMAGE_SIDE, LIMIT_IMAGE_SIDE), -1);
    assert_null(img.rgb);

    assert_int_equal(image_init(&img, 7, 3), 0);
    assert_int_equal(img.width, 7);
    assert_int_equal(img.height, 3);
    for (int i = 0; i < 7 * 3 * 3; i++)
        assert_true(img.rgb[i] == 0.0f);
    image_free(&img);
    assert_null(img.rgb);
    image_free(&img); /* twice is fine */
    image_free(NULL);
}

/* Every page of a large image is in memory once image_init returns: the
 * render writes pixels, not page faults. */
static void test_init_touches_every_page(void **state)
{
    (void)state;
#if defined(__linux__)
    Image img;
    assert_int_equal(image_init(&img, 1024, 1024), 0); /* 12 MiB: a mapping of its own */
    const size_t page = (size_t)sysconf(_SC_PAGESIZE);
    const uintptr_t lo = (uintptr_t)img.rgb / page * page;
    const uintptr_t hi = (uintptr_t)(img.rgb + 1024 * 1024 * 3);
    const size_t pages = (hi - lo + page - 1) / page;
    unsigned char *in = malloc(pages);
    assert_non_null(in);
    assert_int_equal(mincore((void *)lo, hi - lo, in), 0);
    size_t resident = 0;
    for (size_t i = 0; i < pages; i++)
        resident += in[i] & 1;
    assert_int_equal(resident, pages);
    free(in);
    image_free(&img);
#else
    skip();
#endif
}

/* ---- EXR ---------------------------------------------------------------- */

static void test_exr_float_roundtrip(void **state)
{
    Fixture *f = *state;
    char err[512] = "";
    Image img, back;
    /* 37 rows: two full 16-line ZIP chunks and a partial one. */
    assert_int_equal(image_init(&img, 29, 37), 0);
    for (int y = 0; y < img.height; y++)
        for (int x = 0; x < img.width; x++) {
            float *p = img.rgb + 3 * (y * img.width + x);
            p[0] = (float)x / 28.0f + 0.001f * (float)y;
            p[1] = -2.5f * (float)y + 0.1f * (float)x;
            p[2] = 1000.0f + (float)(x * y) * 1.0e-3f;
        }
    /* Rows 20..27 are noise: ZIP cannot shrink them, so those chunks are
     * stored raw, another decoder path. Then the awkward values. */
    Image noise;
    assert_int_equal(image_init(&noise, img.width, 8), 0);
    fill_random_floats(&noise, 12345u);
    memcpy(img.rgb + 3 * 20 * img.width, noise.rgb, sizeof(float) * 3 * 8 * (size_t)img.width);
    image_free(&noise);
    const float odd[] = {-0.0f, 1.0e-40f, -3.0e38f, INFINITY, -INFINITY, NAN, 65504.0f, 1.0e-7f};
    for (size_t i = 0; i < sizeof odd / sizeof odd[0]; i++)
        img.rgb[3 * (30 * img.width) + i] = odd[i];

    const char *path = join(f, "float.exr");
    assert_int_equal(image_write_exr(&img, path, IMAGE_FLOAT, err, sizeof err), 0);
    assert_int_equal(image_read_exr(path, &back, err, sizeof err), 0);
    assert_int_equal(back.width, img.width);
    assert_int_equal(back.height, img.height);
    size_t n = (size_t)img.width * (size_t)img.height * 3;
    for (size_t i = 0; i < n; i++)
        assert_int_equal(float_to_bits(back.rgb[i]), float_to_bits(img.rgb[i]));
    assert_int_equal(count_tmp_files(f), 0);
    image_free(&back);
    image_free(&img);
}

/* Chunks that deflate to exactly their packed length: OpenEXRCore 3.1
 * kept the deflated bytes, which every reader takes for raw ones. Rows of
 * 8 pixels whose low k mantissa bits are random land there now and then,
 * at both precisions (k found by trying, with Debian 12's zlib); each must
 * read back bit for bit. */
static void test_exr_chunk_deflated_to_its_length(void **state)
{
    Fixture *f = *state;
    char err[512] = "";
    const char *path = join(f, "edge.exr");
    uint32_t seed = 1u;
    for (int half = 0; half < 2; half++)
        for (int t = 0; t < 256; t++) {
            Image img, back;
            assert_int_equal(image_init(&img, 8, 1), 0);
            /* half: 0.5 + m 2^-11, m < 2^k, exact in half's ten bits */
            const int k = half ? 9 + t % 2 : 10 + t % 2, shift = half ? 13 : 0;
            for (int i = 0; i < 24; i++)
                img.rgb[i] = bits_to_float(0x3f000000u | (rng_next(&seed) & ((1u << k) - 1u)) << shift);
            assert_int_equal(image_write_exr(&img, path, half ? IMAGE_HALF : IMAGE_FLOAT, err, sizeof err), 0);
            assert_int_equal(image_read_exr(path, &back, err, sizeof err), 0);
            for (int i = 0; i < 24; i++)
                assert_int_equal(float_to_bits(back.rgb[i]), float_to_bits(img.rgb[i]));
            image_free(&back);
            image_free(&img);
        }
}

/* A tile: the data window is the image, placed at (x, y) in a display
 * window of the full picture's size, and reads back so, with the header's
 * "lancer:" strings and its channel type; an image placed past its
 * picture is not written. */
static void test_exr_tile_windows(void **state)
{
    Fixture *f = *state;
    char err[512] = "";
    Image img, back;
    ImageMeta meta;
    assert_int_equal(image_init(&img, 29, 37), 0);
    fill_random_floats(&img, 777u);
    img.x = 13;
    img.y = 7; /* not a multiple of the 16-row chunks */
    img.full_width = 100;
    img.full_height = 80;
    const char *path = join(f, "tile.exr");
    const ImageAttr attrs[] = {{"lancer:a", "one"}, {"other", "not kept"}, {"lancer:b", ""}};
    char tmp[1024];
    snprintf(tmp, sizeof tmp, "%s", path);
    assert_int_equal(image_write_exr_file(&img, tmp, path, IMAGE_FLOAT, attrs, 3, 1, err, sizeof err), 0);
    assert_int_equal(image_read_exr_meta(path, &back, &meta, err, sizeof err), 0);
    assert_true(back.x == 13 && back.y == 7 && back.width == 29 && back.height == 37);
    assert_true(back.full_width == 100 && back.full_height == 80);
    assert_memory_equal(back.rgb, img.rgb, sizeof(float) * 3 * 29 * 37);
    assert_int_equal(meta.n, 2);
    assert_string_equal(image_meta_get(&meta, "lancer:a"), "one");
    assert_string_equal(image_meta_get(&meta, "lancer:b"), "");
    assert_null(image_meta_get(&meta, "other"));
    assert_int_equal(meta.half, 0);
    image_meta_free(&meta);
    image_free(&back);
    assert_int_equal(image_write_exr(&img, path, IMAGE_HALF, err, sizeof err), 0);
    assert_int_equal(image_read_exr_meta(path, &back, &meta, err, sizeof err), 0);
    assert_true(meta.half && meta.n == 0 && back.x == 13 && back.full_height == 80);
    image_meta_free(&meta);
    image_free(&back);
    img.x = 72; /* 72 + 29 > 100 */
    assert_int_equal(image_write_exr(&img, path, IMAGE_HALF, err, sizeof err), -1);
    assert_non_null(strstr(err, "invalid image"));
    image_free(&img);
}

static void test_exr_half_roundtrip(void **state)
{
    Fixture *f = *state;
    char err[512] = "";
    Image img, back;
    assert_int_equal(image_init(&img, 64, 50), 0);
    size_t n = (size_t)img.width * (size_t)img.height * 3;

    /* Hand-picked values first (index: meaning). */
    const float special[] = {
        0.0f, -0.0f, 1.0f, -2.0f, 0.5f, 65504.0f, -65504.0f,
        0x1p-14f,             /* smallest normal half */
        0x1p-24f,             /* smallest subnormal half */
        0x3FFp-24f,           /* largest subnormal half */
        1.0e-6f,              /* subnormal: 16.78 * 2^-24 -> 17 * 2^-24 */
        0x1p-25f,             /* tie between 0 and 2^-24: even is 0 */
        0x3p-25f,             /* tie between 1 and 2 * 2^-24: even is 2 */
        1.0f + 0x1p-11f,      /* tie: rounds down to 1 (even) */
        1.0f + 0x3p-11f,      /* tie: rounds up to 1 + 2^-9 (even) */
        0.1f, 3.14159265f, -1234.567f,
        65519.0f,             /* below the tie: 65504 */
        65520.0f,             /* the tie: +inf */
        1.0e5f, -1.0e5f, 3.0e38f, INFINITY, -INFINITY, NAN,
        1.0e-9f,              /* underflows to 0 */
    };
    size_t nspecial = sizeof special / sizeof special[0];
    memcpy(img.rgb, special, sizeof special);
    /* Then a log-uniform sweep over the whole half range and beyond, both
     * signs, so every exponent (and the subnormals) is exercised. */
    uint32_t seed = 987654321u;
    for (size_t i = nspecial; i < n; i++) {
        double mag = ldexp(1.0 + (double)(rng_next(&seed) % 1000000u) / 1.0e6,
                           (int)(rng_next(&seed) % 48u) - 30);
        img.rgb[i] = (float)((rng_next(&seed) & 1u) ? -mag : mag);
    }

    const char *path = join(f, "half.exr");
    assert_int_equal(image_write_exr(&img, path, IMAGE_HALF, err, sizeof err), 0);
    assert_int_equal(image_read_exr(path, &back, err, sizeof err), 0);
    assert_int_equal(back.width, img.width);
    assert_int_equal(back.height, img.height);

    /* Spot checks stated the plain way. */
    for (size_t i = 0; i < 10; i++) /* exactly representable: exact */
        assert_int_equal(float_to_bits(back.rgb[i]), float_to_bits(special[i]));
    assert_true(fabsf(back.rgb[10] - 1.0e-6f) <= 0x1p-25f);
    assert_true(back.rgb[10] == 17.0f * 0x1p-24f);
    assert_true(back.rgb[11] == 0.0f);
    assert_true(back.rgb[12] == 0x1p-23f);
    assert_true(back.rgb[13] == 1.0f);
    assert_true(back.rgb[14] == 1.0f + 0x1p-9f);
    assert_true(back.rgb[18] == 65504.0f);
    assert_true(isinf(back.rgb[19]) && back.rgb[19] > 0.0f);
    assert_true(isinf(back.rgb[20]) && back.rgb[20] > 0.0f);
    assert_true(isinf(back.rgb[21]) && back.rgb[21] < 0.0f);
    assert_true(isnan(back.rgb[25]));
    assert_true(back.rgb[26] == 0.0f);

    /* Everything against the independent reference rounding, and within
     * half a half-ulp (relative 2^-11) for normal finite values. */
    for (size_t i = 0; i < n; i++) {
        float v = img.rgb[i], got = back.rgb[i], want = ref_half(v);
        if (isnan(want)) {
            assert_true(isnan(got));
            continue;
        }
        if (float_to_bits(got) != float_to_bits(want))
            fail_msg("value %zu: %a became %a, expected %a", i, (double)v, (double)got,
                     (double)want);
        if (float_to_bits(image_half_round(v)) != float_to_bits(got)) /* the PNG preview's rounding */
            fail_msg("value %zu: image_half_round(%a) is %a, OpenEXR's half %a", i, (double)v,
                     (double)image_half_round(v), (double)got);
        if (fabsf(v) >= 0x1p-14f && fabsf(v) <= 65504.0f)
            assert_true(fabs((double)got - (double)v) <= fabs((double)v) * 0x1p-11);
    }
    image_free(&back);
    image_free(&img);
}

/* Writes an EXR through OpenEXRCore directly, to give the reader layouts
 * image_write_exr never produces: tiles, a data window off the origin,
 * uint/half/float channels, missing and extra channels. */
typedef struct {
    const char *name;
    exr_pixel_type_t type;
} TestChan;

/* The value stored at (x, y) of a channel of the given type, as raw bits,
 * and what a reader must make of it. */
static uint32_t sample_bits(exr_pixel_type_t type, int x, int y)
{
    switch (type) {
    case EXR_PIXEL_UINT: return (uint32_t)(x * 1000 + y * 7 + 3);
    case EXR_PIXEL_HALF: return 0x3C00u + ((unsigned)(x * 31 + y * 5) & 0x3FFu); /* [1, 2) */
    default: return float_to_bits(0.5f * (float)x - 3.25f * (float)y + 0.125f);
    }
}

static float sample_value(exr_pixel_type_t type, int x, int y)
{
    uint32_t b = sample_bits(type, x, y);
    switch (type) {
    case EXR_PIXEL_UINT: return (float)b;
    case EXR_PIXEL_HALF: return (float)half_value(b);
    default: return bits_to_float(b);
    }
}

static void write_core_exr(const char *path, int tiled, int x0, int y0, int w, int h,
                           exr_compression_t comp, const TestChan *chans, int nchans)
{
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    exr_context_t ctx = NULL;
    int part = 0;
    assert_int_equal(exr_start_write(&ctx, path, EXR_WRITE_FILE_DIRECTLY, &init), 0);
    assert_int_equal(
        exr_add_part(ctx, NULL, tiled ? EXR_STORAGE_TILED : EXR_STORAGE_SCANLINE, &part), 0);
    exr_attr_box2i_t dw;
    dw.min.x = x0;
    dw.min.y = y0;
    dw.max.x = x0 + w - 1;
    dw.max.y = y0 + h - 1;
    exr_attr_v2f_t center;
    center.x = 0.0f;
    center.y = 0.0f;
    assert_int_equal(exr_initialize_required_attr(ctx, part, &dw, &dw, 1.0f, &center, 1.0f,
                                                  EXR_LINEORDER_INCREASING_Y, comp),
                     0);
    const int tw = 16, th = 8;
    if (tiled)
        assert_int_equal(exr_set_tile_descriptor(ctx, part, tw, th, EXR_TILE_ONE_LEVEL,
                                                 EXR_TILE_ROUND_DOWN),
                         0);
    uint8_t *bufs[8];
    assert_true(nchans <= 8);
    for (int c = 0; c < nchans; c++) {
        assert_int_equal(exr_add_channel(ctx, part, chans[c].name, chans[c].type,
                                         EXR_PERCEPTUALLY_LOGARITHMIC, 1, 1),
                         0);
        size_t bpe = chans[c].type == EXR_PIXEL_HALF ? 2 : 4;
        bufs[c] = malloc((size_t)w * (size_t)h * bpe);
        assert_non_null(bufs[c]);
        for (int y = 0; y < h; y++)
            for (int x = 0; x < w; x++) {
                uint32_t b = sample_bits(chans[c].type, x, y);
                uint8_t *dst = bufs[c] + ((size_t)y * (size_t)w + (size_t)x) * bpe;
                if (bpe == 2) {
                    uint16_t b16 = (uint16_t)b;
                    memcpy(dst, &b16, 2);
                } else {
                    memcpy(dst, &b, 4);
                }
            }
    }
    assert_int_equal(exr_write_header(ctx), 0);

    int32_t lpc = 1;
    if (!tiled)
        assert_int_equal(exr_get_scanlines_per_chunk(ctx, part, &lpc), 0);
    int nx = tiled ? (w + tw - 1) / tw : 1;
    int ny = tiled ? (h + th - 1) / th : (h + lpc - 1) / lpc;
    exr_encode_pipeline_t enc = EXR_ENCODE_PIPELINE_INITIALIZER;
    int started = 0;
    for (int ty = 0; ty < ny; ty++)
        for (int tx = 0; tx < nx; tx++) {
            exr_chunk_info_t ci;
            int ox = tiled ? tx * tw : 0, oy = tiled ? ty * th : ty * lpc;
            if (tiled)
                assert_int_equal(exr_write_tile_chunk_info(ctx, part, tx, ty, 0, 0, &ci), 0);
            else
                assert_int_equal(exr_write_scanline_chunk_info(ctx, part, y0 + oy, &ci), 0);
            if (started)
                assert_int_equal(exr_encoding_update(ctx, part, &ci, &enc), 0);
            else
                assert_int_equal(exr_encoding_initialize(ctx, part, &ci, &enc), 0);
            for (int k = 0; k < enc.channel_count; k++) {
                exr_coding_channel_info_t *ch = &enc.channels[k];
                int c = 0;
                while (c < nchans && strcmp(chans[c].name, ch->channel_name) != 0)
                    c++;
                assert_true(c < nchans);
                int32_t bpe = chans[c].type == EXR_PIXEL_HALF ? 2 : 4;
                ch->encode_from_ptr = bufs[c] + ((size_t)oy * (size_t)w + (size_t)ox) * (size_t)bpe;
                ch->user_data_type = (uint16_t)chans[c].type;
                ch->user_bytes_per_element = (int16_t)bpe;
                ch->user_pixel_stride = bpe;
                ch->user_line_stride = bpe * w;
            }
            if (!started)
                assert_int_equal(exr_encoding_choose_default_routines(ctx, part, &enc), 0);
            started = 1;
            assert_int_equal(exr_encoding_run(ctx, part, &enc), 0);
        }
    exr_encoding_destroy(ctx, &enc);
    assert_int_equal(exr_finish(&ctx), 0);
    for (int c = 0; c < nchans; c++)
        free(bufs[c]);
}

/* Reads what write_core_exr wrote and checks every pixel. */
static void check_core_exr(const char *path, int w, int h, const TestChan *chans, int nchans)
{
    char err[512] = "";
    Image img;
    if (image_read_exr(path, &img, err, sizeof err) != 0)
        fail_msg("%s", err);
    assert_int_equal(img.width, w);
    assert_int_equal(img.height, h);
    static const char *const rgb[3] = {"R", "G", "B"};
    for (int k = 0; k < 3; k++) {
        int c = 0;
        while (c < nchans && strcmp(chans[c].name, rgb[k]) != 0)
            c++;
        for (int y = 0; y < h; y++)
            for (int x = 0; x < w; x++) {
                float want = c < nchans ? sample_value(chans[c].type, x, y) : 0.0f;
                float got = img.rgb[3 * ((size_t)y * (size_t)w + (size_t)x) + (size_t)k];
                if (float_to_bits(got) != float_to_bits(want))
                    fail_msg("%s (%d,%d) channel %s: got %g want %g", path, x, y, rgb[k],
                             (double)got, (double)want);
            }
    }
    image_free(&img);
}

static void test_exr_read_layouts(void **state)
{
    Fixture *f = *state;
    /* Tiled, 41x30 at (-5, 7): partial tiles on the right and bottom; no
     * R (reads as 0), an extra A to skip, G as uint, B as float. */
    const TestChan tiled[] = {{"A", EXR_PIXEL_HALF}, {"B", EXR_PIXEL_FLOAT}, {"G", EXR_PIXEL_UINT}};
    const char *p = join(f, "tiled.exr");
    write_core_exr(p, 1, -5, 7, 41, 30, EXR_COMPRESSION_ZIP, tiled, 3);
    check_core_exr(p, 41, 30, tiled, 3);

    /* Uncompressed scanlines at (3, -11), every type once. */
    const TestChan scan[] = {{"R", EXR_PIXEL_HALF}, {"G", EXR_PIXEL_UINT}, {"B", EXR_PIXEL_FLOAT}};
    p = join(f, "scan_none.exr");
    write_core_exr(p, 0, 3, -11, 19, 13, EXR_COMPRESSION_NONE, scan, 3);
    check_core_exr(p, 19, 13, scan, 3);

    /* PIZ (32-line chunks), all half, single row wide. */
    const TestChan halfs[] = {{"R", EXR_PIXEL_HALF}, {"G", EXR_PIXEL_HALF}, {"B", EXR_PIXEL_HALF}};
    p = join(f, "scan_piz.exr");
    write_core_exr(p, 0, 0, 0, 1, 70, EXR_COMPRESSION_PIZ, halfs, 3);
    check_core_exr(p, 1, 70, halfs, 3);

    /* No R, G or B at all: refused, where it once read as black, and
     * `lancer diff` found any two such files the same. */
    const TestChan lum[] = {{"Y", EXR_PIXEL_HALF}};
    p = join(f, "luma.exr");
    write_core_exr(p, 0, 0, 0, 5, 4, EXR_COMPRESSION_ZIP, lum, 1);
    Image img;
    char err[512] = "";
    quiet_begin(f);
    assert_int_equal(image_read_exr(p, &img, err, sizeof err), -1);
    quiet_end(f);
    assert_non_null(strstr(err, "luma.exr: cannot read: no channel named R, G or B"));
    assert_null(img.rgb);
}

static void test_exr_read_errors(void **state)
{
    Fixture *f = *state;
    char err[512] = "";
    Image img;

    quiet_begin(f);
    const char *missing = join(f, "missing.exr");
    assert_int_equal(image_read_exr(missing, &img, err, sizeof err), -1);
    assert_non_null(strstr(err, missing));
    assert_null(strchr(err, '\n'));
    assert_null(img.rgb);
    assert_int_equal(img.width, 0);

    /* Random bytes. */
    unsigned char junk[4096];
    uint32_t seed = 42u;
    for (size_t i = 0; i < sizeof junk; i++)
        junk[i] = (unsigned char)rng_next(&seed);
    const char *x = join(f, "x.exr");
    spill(x, junk, sizeof junk);
    err[0] = '\0';
    assert_int_equal(image_read_exr(x, &img, err, sizeof err), -1);
    assert_non_null(strstr(err, x));
    assert_null(img.rgb);

    /* Right magic number, garbage after it. */
    const unsigned char magic[4] = {0x76, 0x2f, 0x31, 0x01};
    memcpy(junk, magic, sizeof magic);
    const char *y = join(f, "magic.exr");
    spill(y, junk, sizeof junk);
    err[0] = '\0';
    assert_int_equal(image_read_exr(y, &img, err, sizeof err), -1);
    assert_non_null(strstr(err, y));
    assert_null(img.rgb);

    /* An empty file, a directory and a FIFO (which once blocked forever). */
    const char *e = join(f, "empty.exr");
    spill(e, "", 0);
    assert_int_equal(image_read_exr(e, &img, err, sizeof err), -1);
    assert_non_null(strstr(err, e));
    assert_int_equal(image_read_exr(f->dir, &img, err, sizeof err), -1);
    const char *fifo = join(f, "fifo.exr");
    assert_int_equal(mkfifo(fifo, 0600), 0);
    assert_int_equal(image_read_exr(fifo, &img, err, sizeof err), -1);
    assert_non_null(strstr(err, "not a regular file (a FIFO)"));
    remove(fifo);

    /* A real file cut short: its header is fine, its pixels are not. */
    Image src;
    assert_int_equal(image_init(&src, 64, 64), 0);
    fill_random_floats(&src, 7u);
    const char *t = join(f, "truncated.exr");
    assert_int_equal(image_write_exr(&src, t, IMAGE_FLOAT, err, sizeof err), 0);
    image_free(&src);
    size_t len;
    unsigned char *whole = slurp(t, &len);
    spill(t, whole, len / 2);
    free(whole);
    err[0] = '\0';
    assert_int_equal(image_read_exr(t, &img, err, sizeof err), -1);
    assert_non_null(strstr(err, t));
    assert_null(strchr(err, '\n'));
    assert_null(img.rgb);
    quiet_end(f);
}

/* Channels lancer does not keep, in layouts whose unpackers once wrote
 * through the NULL pointer lancer gave them: three halves, one of them not
 * R, G or B (`lancer diff` crashed on a file of its own with R renamed P),
 * and four halves. The R, G and B that are there are read; a missing one is
 * 0. */
static void test_exr_read_foreign_channels(void **state)
{
    Fixture *f = *state;
    const TestChan pgb[] = {{"B", EXR_PIXEL_HALF}, {"G", EXR_PIXEL_HALF}, {"P", EXR_PIXEL_HALF}};
    const char *p = join(f, "pgb.exr");
    write_core_exr(p, 0, 0, 0, 23, 37, EXR_COMPRESSION_ZIP, pgb, 3);
    check_core_exr(p, 23, 37, pgb, 3);
    const TestChan argb[] = {{"A", EXR_PIXEL_HALF}, {"B", EXR_PIXEL_HALF}, {"G", EXR_PIXEL_HALF}, {"R", EXR_PIXEL_HALF}};
    p = join(f, "argb.exr");
    write_core_exr(p, 0, 0, 0, 17, 9, EXR_COMPRESSION_NONE, argb, 4);
    check_core_exr(p, 17, 9, argb, 4);
    const TestChan tiled[] = {{"B", EXR_PIXEL_HALF}, {"G", EXR_PIXEL_HALF}, {"Z", EXR_PIXEL_HALF}};
    p = join(f, "bgz_tiled.exr");
    write_core_exr(p, 1, 0, 0, 33, 20, EXR_COMPRESSION_ZIP, tiled, 3);
    check_core_exr(p, 33, 20, tiled, 3);
}

/* A 1x1 file of compression comp whose data window is patched to w x h;
 * its length into *len. */
static void patched_exr(const Fixture *f, const char *p, exr_compression_t comp, int32_t w, int32_t h, size_t *len)
{
    (void)f;
    const TestChan rgb[] = {{"B", EXR_PIXEL_HALF}, {"G", EXR_PIXEL_HALF}, {"R", EXR_PIXEL_HALF}};
    write_core_exr(p, 0, 0, 0, 1, 1, comp, rgb, 3);
    unsigned char *b = slurp(p, len);
    static const char key[] = "dataWindow\0box2i";
    unsigned char *at = NULL;
    for (size_t i = 0; i + sizeof key < *len && !at; i++)
        if (memcmp(b + i, key, sizeof key) == 0)
            at = b + i + sizeof key + 4; /* past the name, the type and the size */
    assert_non_null(at);
    if (!at)
        return; /* (assert_non_null has ended the test) */
    const int32_t xmax = w - 1, ymax = h - 1;
    memcpy(at + 8, &xmax, 4); /* little-endian, as this machine */
    memcpy(at + 12, &ymax, 4);
    spill(p, b, *len);
    free(b);
}

/* image_read_exr of p fails with a message that holds want. */
static void refused(Fixture *f, const char *p, const char *want)
{
    char err[512] = "";
    Image img;
    quiet_begin(f);
    assert_int_equal(image_read_exr(p, &img, err, sizeof err), -1);
    quiet_end(f);
    if (!strstr(err, want))
        fail_msg("got '%s', want '%s'", err, want);
    assert_null(img.rgb);
}

/* A header that announces more pixels than its file can hold is refused
 * before they are allocated (3 GiB of float RGB at 16384^2): by the
 * chunks' offsets, 8 bytes each, which the file must hold; by the pixels a
 * byte can pack, where the chunks are few (PIZ: 32 rows each); and past
 * LIMIT_IMAGE_PIXELS, by that limit's name. A 6 KB file of 16384^2 pixels
 * once passed the second check and was allocated. */
static void test_exr_read_claims_checked(void **state)
{
    Fixture *f = *state;
    size_t len;
    const char *p = join(f, "claims.exr");
    patched_exr(f, p, EXR_COMPRESSION_ZIP, 16384, 16384, &len);
    refused(f, p, "16384x16384 pixels in 1024 chunks announced, whose offsets alone are more than its");
    patched_exr(f, p, EXR_COMPRESSION_PIZ, 1, 1, &len);
    const int32_t rows = 32 * (int32_t)(len / 8); /* as many PIZ chunks as the file could index */
    patched_exr(f, p, EXR_COMPRESSION_PIZ, 32767, rows, &len);
    char want[128];
    snprintf(want, sizeof want, "32767x%d pixels announced, more than its", (int)rows);
    refused(f, p, want);
    patched_exr(f, p, EXR_COMPRESSION_ZIP, 32767, 16385, &len);
    refused(f, p, "data window of 32767x16385 pixels is more than the 268435456 an image may have");
}

/* ---- sRGB and PNG ------------------------------------------------------- */

static void test_srgb8(void **state)
{
    (void)state;
    assert_int_equal(image_srgb8(0.0f), 0);
    assert_int_equal(image_srgb8(-0.0f), 0);
    assert_int_equal(image_srgb8(1.0f), 255);
    assert_int_equal(image_srgb8(0.5f), 188); /* 1.055 * 0.5^(1/2.4) - 0.055 = 0.7354 */
    assert_int_equal(image_srgb8(0.18f), 118); /* middle grey: 0.4614 */
    /* Both branches meet at 0.0031308 (0.04045 -> 10.31); the linear
     * segment below it, 12.92 * x. */
    assert_int_equal(image_srgb8(0.0031308f), 10);
    assert_int_equal(image_srgb8(0.0031309f), 10);
    assert_int_equal(image_srgb8(0.001f), 3);     /* 12.92e-3 * 255 = 3.29 */
    assert_int_equal(image_srgb8(0.0001f), 0);    /* 0.33 */
    assert_int_equal(image_srgb8(0.00016f), 1);   /* 0.53 */
    assert_int_equal(image_srgb8(-0.5f), 0);
    assert_int_equal(image_srgb8(-INFINITY), 0);
    assert_int_equal(image_srgb8(1.5f), 255);
    assert_int_equal(image_srgb8(INFINITY), 255);
    assert_int_equal(image_srgb8(NAN), 0);
    /* Monotonic over [0, 1]. */
    unsigned prev = 0;
    for (int i = 0; i <= 4096; i++) {
        unsigned v = image_srgb8((float)i / 4096.0f);
        assert_true(v >= prev);
        prev = v;
    }
    assert_int_equal(prev, 255);
}

typedef struct {
    int width, height, bit_depth, color_type, has_srgb;
    unsigned char *pixels; /* width * height * 3 */
} PngData;

static void png_test_error(png_structp png, png_const_charp msg)
{
    (void)msg;
    png_longjmp(png, 1);
}

/* Reads an 8-bit RGB PNG with libpng; 0 on success. */
static int png_load(const char *path, PngData *out)
{
    memset(out, 0, sizeof *out);
    FILE *fp = fopen(path, "rb");
    if (fp == NULL)
        return -1;
    png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, NULL, png_test_error, NULL);
    png_infop info = png_create_info_struct(png);
    if (setjmp(png_jmpbuf(png))) {
        free(out->pixels);
        out->pixels = NULL;
        png_destroy_read_struct(&png, &info, NULL);
        fclose(fp);
        return -1;
    }
    png_init_io(png, fp);
    png_read_info(png, info);
    out->width = (int)png_get_image_width(png, info);
    out->height = (int)png_get_image_height(png, info);
    out->bit_depth = png_get_bit_depth(png, info);
    out->color_type = png_get_color_type(png, info);
    int intent;
    out->has_srgb = png_get_sRGB(png, info, &intent) != 0;
    if (out->bit_depth == 8 && out->color_type == PNG_COLOR_TYPE_RGB) {
        out->pixels = malloc((size_t)out->width * (size_t)out->height * 3);
        for (int y = 0; y < out->height; y++)
            png_read_row(png, out->pixels + (size_t)y * (size_t)out->width * 3, NULL);
        png_read_end(png, NULL);
    }
    png_destroy_read_struct(&png, &info, NULL);
    fclose(fp);
    return 0;
}

static void test_png_roundtrip(void **state)
{
    Fixture *f = *state;
    char err[512] = "";
    Image img;
    assert_int_equal(image_init(&img, 13, 7), 0);
    size_t n = (size_t)img.width * (size_t)img.height * 3;
    for (size_t i = 0; i < n; i++)
        img.rgb[i] = -0.25f + 1.5f * (float)i / (float)n; /* below 0 to above 1 */
    img.rgb[4] = NAN;
    img.rgb[5] = INFINITY;

    const char *path = join(f, "out.png");
    assert_int_equal(image_write_png(&img, path, err, sizeof err), 0);
    PngData png;
    assert_int_equal(png_load(path, &png), 0);
    assert_int_equal(png.width, img.width);
    assert_int_equal(png.height, img.height);
    assert_int_equal(png.bit_depth, 8);
    assert_int_equal(png.color_type, PNG_COLOR_TYPE_RGB);
    assert_true(png.has_srgb);
    assert_non_null(png.pixels);
    for (size_t i = 0; i < n; i++)
        assert_int_equal(png.pixels[i], image_srgb8(img.rgb[i]));
    assert_int_equal(png.pixels[4], 0);
    assert_int_equal(png.pixels[5], 255);
    free(png.pixels);
    assert_int_equal(count_tmp_files(f), 0);
    image_free(&img);
}

/* The PNG writer converts by thresholds, not by image_srgb8 itself: its
 * bytes must be image_srgb8's at and around every value where the byte
 * changes (found here by bisection), across [0, 1] by even steps of the
 * floats' bit patterns, and at the odd values. */
/* A 128x128 image of the values around each of image_srgb8's steps, odd
 * values, then a sweep of [0, 1]. */
static void srgb_edges(Image *img)
{
    assert_int_equal(image_init(img, 128, 128), 0);
    size_t n = (size_t)128 * 128 * 3, i = 0;
    const float one = 1.0f;
    uint32_t one_bits;
    memcpy(&one_bits, &one, sizeof one_bits);
    for (int k = 1; k < 256; k++) {
        uint32_t lo = 1, hi = one_bits;
        while (lo < hi) {
            uint32_t mid = lo + (hi - lo) / 2;
            float x;
            memcpy(&x, &mid, sizeof x);
            if (image_srgb8(x) >= k)
                hi = mid;
            else
                lo = mid + 1;
        }
        for (int d = -64; d <= 64; d++) {
            uint32_t b = lo + (uint32_t)d;
            memcpy(&img->rgb[i++], &b, sizeof(float));
        }
    }
    const float odd[] = {0.0f, -0.0f, NAN, INFINITY, -INFINITY, 1.0f, 1.5f, -1.0f, 1e-45f, FLT_MIN, 0.0031308f};
    for (size_t k = 0; k < sizeof odd / sizeof odd[0]; k++)
        img->rgb[i++] = odd[k];
    const uint32_t step = one_bits / (uint32_t)(n - i) + 1;
    for (uint32_t b = 0; i < n; b += step)
        memcpy(&img->rgb[i++], &b, sizeof(float));
}

static void test_png_bytes_are_srgb8(void **state)
{
    Fixture *f = *state;
    char err[512] = "";
    Image img;
    srgb_edges(&img);
    size_t n = (size_t)img.width * (size_t)img.height * 3;
    const char *path = join(f, "srgb.png");
    assert_int_equal(image_write_png(&img, path, err, sizeof err), 0);
    PngData png;
    assert_int_equal(png_load(path, &png), 0);
    for (size_t i = 0; i < n; i++)
        if (png.pixels[i] != image_srgb8(img.rgb[i]))
            fail_msg("value %zu (%.9g): PNG byte %d, image_srgb8 %d", i, (double)img.rgb[i], png.pixels[i],
                     image_srgb8(img.rgb[i]));
    free(png.pixels);
    image_free(&img);
}

/* The preview of a half EXR: the bytes that the EXR's own values give, as
 * `lancer merge` makes them from its tiles, not those of the floats before
 * the rounding (a render's PNG once differed from its merged tiles' in 1%
 * of its bytes). */
static void test_png_of_half_is_the_half_exrs(void **state)
{
    Fixture *f = *state;
    char err[512] = "";
    Image img, back;
    srgb_edges(&img);
    size_t n = (size_t)img.width * (size_t)img.height * 3;
    const char *exr = join(f, "edges.exr");
    assert_int_equal(image_write_exr(&img, exr, IMAGE_HALF, err, sizeof err), 0);
    assert_int_equal(image_read_exr(exr, &back, err, sizeof err), 0);
    const char *png_half = join(f, "half.png");
    assert_int_equal(image_write_png_file(&img, png_half, "half.png", IMAGE_HALF, err, sizeof err), 0);
    PngData png;
    assert_int_equal(png_load(png_half, &png), 0);
    size_t moved = 0;
    for (size_t i = 0; i < n; i++) {
        if (png.pixels[i] != image_srgb8(back.rgb[i]))
            fail_msg("value %zu (%.9g, %.9g as half): PNG byte %d, the half's %d", i, (double)img.rgb[i],
                     (double)back.rgb[i], png.pixels[i], image_srgb8(back.rgb[i]));
        moved += png.pixels[i] != image_srgb8(img.rgb[i]);
    }
    assert_true(moved > 0); /* the rounding matters here */
    free(png.pixels);
    image_free(&back);
    image_free(&img);
}

/* ---- failures ----------------------------------------------------------- */

static void test_write_into_missing_dir(void **state)
{
    Fixture *f = *state;
    char err[512] = "";
    Image img;
    assert_int_equal(image_init(&img, 4, 4), 0);

    const char *path = join(f, "nope/a.exr");
    assert_int_equal(image_write_exr(&img, path, IMAGE_HALF, err, sizeof err), -1);
    assert_non_null(strstr(err, path));
    assert_null(strchr(err, '\n'));

    path = join(f, "nope/a.png");
    err[0] = '\0';
    assert_int_equal(image_write_png(&img, path, err, sizeof err), -1);
    assert_non_null(strstr(err, path));
    assert_int_equal(count_tmp_files(f), 0);

    /* An Image that image_init did not make is refused, not written. */
    Image bad = {4, 4, NULL, 0, 0, 4, 4};
    path = join(f, "bad.exr");
    assert_int_equal(image_write_exr(&bad, path, IMAGE_FLOAT, err, sizeof err), -1);
    assert_int_equal(image_write_png(&bad, path, err, sizeof err), -1);
    assert_int_equal(access(path, F_OK), -1);
    assert_int_equal(count_tmp_files(f), 0);
    image_free(&img);
}

static void test_write_replaces_existing(void **state)
{
    Fixture *f = *state;
    char err[512] = "";
    Image img, back;
    assert_int_equal(image_init(&img, 9, 5), 0);
    for (int i = 0; i < 9 * 5 * 3; i++)
        img.rgb[i] = (float)i * 0.25f;

    const char *path = join(f, "a.exr");
    spill(path, "old contents", 12);
    assert_int_equal(image_write_exr(&img, path, IMAGE_FLOAT, err, sizeof err), 0);
    assert_int_equal(image_read_exr(path, &back, err, sizeof err), 0);
    assert_int_equal(back.width, 9);
    assert_memory_equal(back.rgb, img.rgb, sizeof(float) * 9 * 5 * 3);
    image_free(&back);

    path = join(f, "a.png");
    spill(path, "old contents", 12);
    assert_int_equal(image_write_png(&img, path, err, sizeof err), 0);
    size_t len;
    unsigned char *bytes = slurp(path, &len);
    assert_true(len > 8);
    assert_int_equal(png_sig_cmp(bytes, 0, 8), 0);
    free(bytes);
    assert_int_equal(count_tmp_files(f), 0);
    image_free(&img);
}

/* Target is a directory: the temporary is written, the rename fails. */
static void test_write_over_directory(void **state)
{
    Fixture *f = *state;
    char err[512] = "";
    Image img;
    assert_int_equal(image_init(&img, 4, 4), 0);
    char dir[512];
    snprintf(dir, sizeof dir, "%s", join(f, "adir"));
    assert_int_equal(mkdir(dir, 0755), 0);
    char keep[600];
    snprintf(keep, sizeof keep, "%s/keep", dir);
    spill(keep, "kept", 4);

    quiet_begin(f);
    assert_int_equal(image_write_exr(&img, dir, IMAGE_HALF, err, sizeof err), -1);
    assert_non_null(strstr(err, dir));
    err[0] = '\0';
    assert_int_equal(image_write_png(&img, dir, err, sizeof err), -1);
    assert_non_null(strstr(err, dir));
    quiet_end(f);

    struct stat st;
    assert_int_equal(stat(dir, &st), 0);
    assert_true(S_ISDIR(st.st_mode));
    size_t len;
    unsigned char *bytes = slurp(keep, &len);
    assert_int_equal(len, 4);
    assert_memory_equal(bytes, "kept", 4);
    free(bytes);
    assert_int_equal(count_tmp_files(f), 0);
    image_free(&img);
}

/* A limit of `bytes` on the size of files written (RLIMIT_FSIZE), with
 * SIGXFSZ ignored: a write past it fails with EFBIG, even as root. Nothing
 * may print while the limit is on (stdout may be a big file), so the
 * fixture's output is quiet until fsize_limit_off. */
typedef struct {
    struct rlimit saved;
    void (*handler)(int);
} FsizeLimit;

static void fsize_limit_on(Fixture *f, rlim_t bytes, FsizeLimit *l)
{
    assert_int_equal(getrlimit(RLIMIT_FSIZE, &l->saved), 0);
    struct rlimit lim = l->saved;
    lim.rlim_cur = bytes;
    l->handler = signal(SIGXFSZ, SIG_IGN);
    quiet_begin(f);
    assert_int_equal(setrlimit(RLIMIT_FSIZE, &lim), 0);
}

static void fsize_limit_off(Fixture *f, FsizeLimit *l)
{
    int restored = setrlimit(RLIMIT_FSIZE, &l->saved);
    signal(SIGXFSZ, l->handler);
    assert_int_equal(restored, 0);
    quiet_end(f);
}

/* A write that fails half way (file size limit: EFBIG, which works even as
 * root) must leave the old file byte for byte and no temporary behind. */
static void test_failed_write_keeps_old_file(void **state)
{
    Fixture *f = *state;
    char err[512] = "";
    Image small, big;
    assert_int_equal(image_init(&small, 3, 2), 0);
    small.rgb[0] = 0.75f;
    assert_int_equal(image_init(&big, 256, 256), 0);
    fill_random_floats(&big, 99u); /* incompressible: ~786 KB as float */

    char exr[512], png[512];
    snprintf(exr, sizeof exr, "%s", join(f, "keep.exr"));
    snprintf(png, sizeof png, "%s", join(f, "keep.png"));
    assert_int_equal(image_write_exr(&small, exr, IMAGE_FLOAT, err, sizeof err), 0);
    assert_int_equal(image_write_png(&small, png, err, sizeof err), 0);
    size_t exr_len, png_len;
    unsigned char *exr_old = slurp(exr, &exr_len);
    unsigned char *png_old = slurp(png, &png_len);

    FsizeLimit lim;
    fsize_limit_on(f, 4096, &lim);
    char exr_err[512] = "", png_err[512] = "";
    int exr_rc = image_write_exr(&big, exr, IMAGE_FLOAT, exr_err, sizeof exr_err);
    int png_rc = image_write_png(&big, png, png_err, sizeof png_err);
    fsize_limit_off(f, &lim);

    assert_int_equal(exr_rc, -1);
    assert_non_null(strstr(exr_err, exr));
    assert_null(strchr(exr_err, '\n'));
    assert_int_equal(png_rc, -1);
    assert_non_null(strstr(png_err, png));
    assert_non_null(strstr(png_err, strerror(EFBIG)));

    size_t len;
    unsigned char *now = slurp(exr, &len);
    assert_int_equal(len, exr_len);
    assert_memory_equal(now, exr_old, len);
    free(now);
    now = slurp(png, &len);
    assert_int_equal(len, png_len);
    assert_memory_equal(now, png_old, len);
    free(now);
    assert_int_equal(count_tmp_files(f), 0);

    /* And the old EXR still reads as the old image. */
    Image back;
    assert_int_equal(image_read_exr(exr, &back, err, sizeof err), 0);
    assert_int_equal(back.width, 3);
    assert_true(back.rgb[0] == 0.75f);
    image_free(&back);
    free(exr_old);
    free(png_old);
    image_free(&big);
    image_free(&small);
}

/* Chunks compressed on several threads are written in order: the file is
 * the same, byte for byte, as one thread's, for any thread count, half or
 * float, with a data window whose rows start off the 16-row chunks and end
 * in a short chunk. */
static void test_exr_threads_same_bytes(void **state)
{
    Fixture *f = *state;
    char err[512] = "";
    Image img;
    assert_int_equal(image_init(&img, 61, 203), 0);
    fill_random_floats(&img, 4242u);
    for (size_t i = 0; i < (size_t)61 * 203 * 3; i += 7)
        img.rgb[i] = 0.5f; /* some runs for zlib to find */
    img.y = 5;
    img.full_width = 61;
    img.full_height = 210;
    const ImageAttr attrs[] = {{"lancer:rows", "0-3"}};
    for (int half = 0; half < 2; half++) {
        unsigned char *first = NULL;
        size_t first_len = 0;
        static const int counts[] = {1, 2, 3, 8, 64};
        for (size_t k = 0; k < sizeof counts / sizeof counts[0]; k++) {
            char path[512];
            snprintf(path, sizeof path, "%s", join(f, "threads.exr"));
            assert_int_equal(image_write_exr_file(&img, path, path, half ? IMAGE_HALF : IMAGE_FLOAT, attrs, 1,
                                                  counts[k], err, sizeof err),
                             0);
            size_t len;
            unsigned char *bytes = slurp(path, &len);
            if (!first) {
                first = bytes;
                first_len = len;
                continue;
            }
            assert_int_equal(len, first_len);
            assert_memory_equal(bytes, first, len);
            free(bytes);
        }
        Image back;
        char path[512];
        snprintf(path, sizeof path, "%s", join(f, "threads.exr"));
        assert_int_equal(image_read_exr(path, &back, err, sizeof err), 0);
        assert_int_equal(back.y, 5);
        assert_int_equal(back.height, 203);
        if (!half)
            assert_memory_equal(back.rgb, img.rgb, sizeof(float) * 3 * 61 * 203);
        image_free(&back);
        free(first);
    }
    image_free(&img);
}

/* A write on several threads that fails half way (file size limit) stops
 * every thread and says which file failed: no thread waits for a chunk
 * that will never be written. */
static void test_exr_threads_failed_write(void **state)
{
    Fixture *f = *state;
    Image big;
    assert_int_equal(image_init(&big, 256, 512), 0);
    fill_random_floats(&big, 7u); /* incompressible */
    char path[512];
    snprintf(path, sizeof path, "%s", join(f, "big.exr"));
    FsizeLimit lim;
    fsize_limit_on(f, 65536, &lim);
    char err[512] = "";
    int rc = image_write_exr_file(&big, path, "big.exr", IMAGE_FLOAT, NULL, 0, 4, err, sizeof err);
    fsize_limit_off(f, &lim);
    assert_int_equal(rc, -1);
    assert_non_null(strstr(err, "big.exr: cannot write"));
    assert_null(strchr(err, '\n'));
    image_free(&big);
}

/* `test_image --seeds DIR`: small EXRs of every compression that OpenEXR
 * 3.1's C library writes (not DWAA and DWAB), tiled and scanline, with
 * foreign and missing channels of every type, as DIR/exr: the fuzzer's
 * seeds (tests/fuzz). */
static int write_seeds(const char *dir)
{
    static const exr_compression_t comps[] = {EXR_COMPRESSION_NONE, EXR_COMPRESSION_RLE,   EXR_COMPRESSION_ZIPS,
                                              EXR_COMPRESSION_ZIP,  EXR_COMPRESSION_PIZ,   EXR_COMPRESSION_PXR24,
                                              EXR_COMPRESSION_B44,  EXR_COMPRESSION_B44A};
    const TestChan rgb[] = {{"B", EXR_PIXEL_HALF}, {"G", EXR_PIXEL_HALF}, {"R", EXR_PIXEL_HALF}};
    const TestChan mixed[] = {{"A", EXR_PIXEL_HALF}, {"B", EXR_PIXEL_FLOAT}, {"G", EXR_PIXEL_UINT}};
    const TestChan pgb[] = {{"B", EXR_PIXEL_HALF}, {"G", EXR_PIXEL_HALF}, {"P", EXR_PIXEL_HALF}};
    char path[512], name[32];
    for (size_t i = 0; i < sizeof comps / sizeof comps[0]; i++) {
        snprintf(name, sizeof name, "scan-%zu.exr", i);
        if (test_seed_path(dir, "exr", name, path, sizeof path) != 0)
            return 1;
        write_core_exr(path, 0, 0, 0, 8, 6, comps[i], rgb, 3);
        snprintf(name, sizeof name, "tiled-%zu.exr", i);
        if (test_seed_path(dir, "exr", name, path, sizeof path) != 0)
            return 1;
        write_core_exr(path, 1, -3, 2, 19, 10, comps[i], mixed, 3);
    }
    if (test_seed_path(dir, "exr", "pgb.exr", path, sizeof path) != 0)
        return 1;
    write_core_exr(path, 0, 0, 0, 5, 3, EXR_COMPRESSION_ZIP, pgb, 3);
    return 0;
}

int main(int argc, char **argv)
{
    if (argc == 3 && !strcmp(argv[1], "--seeds"))
        return write_seeds(argv[2]);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_init_sizes),
        cmocka_unit_test(test_init_touches_every_page),
        cmocka_unit_test_setup_teardown(test_exr_float_roundtrip, setup, teardown),
        cmocka_unit_test_setup_teardown(test_exr_half_roundtrip, setup, teardown),
        cmocka_unit_test_setup_teardown(test_exr_chunk_deflated_to_its_length, setup, teardown),
        cmocka_unit_test_setup_teardown(test_exr_tile_windows, setup, teardown),
        cmocka_unit_test_setup_teardown(test_exr_read_layouts, setup, teardown),
        cmocka_unit_test_setup_teardown(test_exr_read_errors, setup, teardown),
        cmocka_unit_test_setup_teardown(test_exr_read_foreign_channels, setup, teardown),
        cmocka_unit_test_setup_teardown(test_exr_read_claims_checked, setup, teardown),
        cmocka_unit_test(test_srgb8),
        cmocka_unit_test_setup_teardown(test_png_roundtrip, setup, teardown),
        cmocka_unit_test_setup_teardown(test_png_bytes_are_srgb8, setup, teardown),
        cmocka_unit_test_setup_teardown(test_png_of_half_is_the_half_exrs, setup, teardown),
        cmocka_unit_test_setup_teardown(test_write_into_missing_dir, setup, teardown),
        cmocka_unit_test_setup_teardown(test_write_replaces_existing, setup, teardown),
        cmocka_unit_test_setup_teardown(test_write_over_directory, setup, teardown),
        cmocka_unit_test_setup_teardown(test_failed_write_keeps_old_file, setup, teardown),
        cmocka_unit_test_setup_teardown(test_exr_threads_same_bytes, setup, teardown),
        cmocka_unit_test_setup_teardown(test_exr_threads_failed_write, setup, teardown),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
