/*
 * image.c - the framebuffer and its writers (see image.h for the contract).
 *
 * EXR goes through OpenEXRCore, the C API of OpenEXR 3.x; PNG through libpng.
 * Every file is written to an afile.h temporary beside the target and renamed
 * over it only once complete.
 */
#include "lancer/image.h"

#include "lancer/afile.h"
#include "lancer/thread.h"
#include "bigmem.h"

#include <errno.h>
#include <math.h>
#include <pthread.h>
#include <setjmp.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <openexr.h>

#include <png.h>

int image_init(Image *img, int width, int height)
{
    img->width = img->height = img->x = img->y = img->full_width = img->full_height = 0;
    img->rgb = NULL;
    if (width < 1 || height < 1 || width > LIMIT_IMAGE_SIDE || height > LIMIT_IMAGE_SIDE ||
        (long)width * height > LIMIT_IMAGE_PIXELS)
        return -1;
    const size_t n = (size_t)width * (size_t)height * 3 * sizeof(float);
    img->rgb = big_zalloc(n);
    if (img->rgb == NULL)
        return -1;
    /* Every page faulted in now, not at the render's first write to it:
     * the image's memory is the image's cost, not the render's, as
     * POV-Ray's front end fills its image before it parses
     * (docs/povray-rules.md). */
    memset(img->rgb, 0, n);
    img->width = img->full_width = width;
    img->height = img->full_height = height;
    return 0;
}

void image_free(Image *img)
{
    if (img == NULL)
        return;
    big_free(img->rgb);
    img->rgb = NULL;
    img->width = img->height = img->x = img->y = img->full_width = img->full_height = 0;
}

/* Writers accept only what image_init produces, so a stray struct cannot
 * send a bogus size to the encoders. */
static int image_valid(const Image *img)
{
    return img != NULL && img->rgb != NULL && img->width >= 1 && img->height >= 1 &&
           img->width <= LIMIT_IMAGE_SIDE && img->height <= LIMIT_IMAGE_SIDE && img->x >= 0 && img->y >= 0 &&
           img->full_width <= LIMIT_IMAGE_SIDE && img->full_height <= LIMIT_IMAGE_SIDE &&
           img->x + img->width <= img->full_width && img->y + img->height <= img->full_height;
}

/* zlib's level for the EXR's ZIP chunks and the PNG, instead of its default
 * 6 (OpenEXR 3.1 compresses with zlib; later versions with libdeflate): at
 * 6, writing took about as long as rendering on two threads, and 4 takes
 * half of that for files a few percent larger (docs/performance.md). */
#define IMAGE_ZIP_LEVEL 4

/* The most pixels a byte of an EXR file can hold. zlib (ZIP, ZIPS and
 * PXR24's last stage) packs at most 1032 to 1; the DCT codecs (DWAA, DWAB)
 * keep one coefficient of a flat 8x8 block before zlib. 2^16 covers both,
 * and still refuses a 127-byte header that asks for 16384^2 pixels. */
#define IMAGE_EXR_PACKING 65536ULL

/* ---- OpenEXR ------------------------------------------------------------ */

/* Where the error callback leaves its message. The first one is kept: later
 * ones (e.g. from exr_finish cleaning up) are consequences, not causes. */
typedef struct {
    char msg[256];
    int set;
    pthread_mutex_t *lock; /* while several threads encode: NULL, or the lock that guards msg */
} ImageExrErr;

static void image_exr_note(ImageExrErr *e, const char *msg)
{
    if (e->lock)
        pthread_mutex_lock(e->lock);
    if (!e->set) {
        snprintf(e->msg, sizeof e->msg, "%s", msg);
        /* The err buffer holds one line. */
        for (char *p = e->msg; *p != '\0'; p++)
            if ((unsigned char)*p < 0x20)
                *p = ' ';
        e->set = 1;
    }
    if (e->lock)
        pthread_mutex_unlock(e->lock);
}

/* The ImageExrErr of each context being written. OpenEXRCore reports a
 * write context's errors with its lock held (exr_add_part out of memory,
 * say), and exr_get_user_data takes that lock again: the handler waited on
 * itself, and the render hung. So a written context's handler finds its
 * ImageExrErr here, under a lock of our own. */
#define IMAGE_EXR_WRITERS 16
static struct {
    exr_const_context_t ctx;
    ImageExrErr *e;
} image_exr_writers[IMAGE_EXR_WRITERS];
static pthread_mutex_t image_exr_writers_lock = PTHREAD_MUTEX_INITIALIZER;

/* Enters ctx's e (from NULL), or removes it (e NULL, from ctx's). When the
 * table is full, that context's messages fall back on the error codes'. */
static void image_exr_writer(exr_const_context_t ctx, exr_const_context_t from, ImageExrErr *e)
{
    pthread_mutex_lock(&image_exr_writers_lock);
    for (int i = 0; i < IMAGE_EXR_WRITERS; i++)
        if (image_exr_writers[i].ctx == from) {
            image_exr_writers[i].ctx = e ? ctx : NULL;
            image_exr_writers[i].e = e;
            break;
        }
    pthread_mutex_unlock(&image_exr_writers_lock);
}

/* Replaces OpenEXRCore's default handler, which prints to stderr. A
 * context being read (which takes no lock) or started gives its user data,
 * our ImageExrErr or a struct that begins with one (exr_get_user_data
 * returns the initializer's pointer even when the library does the file
 * I/O itself). */
static void image_exr_on_error(exr_const_context_t ctxt, exr_result_t code, const char *msg)
{
    void *ud = NULL;
    pthread_mutex_lock(&image_exr_writers_lock);
    for (int i = 0; i < IMAGE_EXR_WRITERS && !ud; i++)
        if (image_exr_writers[i].ctx == ctxt)
            ud = image_exr_writers[i].e;
    pthread_mutex_unlock(&image_exr_writers_lock);
    if (!ud && (exr_get_user_data(ctxt, &ud) != EXR_ERR_SUCCESS || ud == NULL))
        return;
    image_exr_note(ud, msg != NULL ? msg : exr_get_default_error_message(code));
}

static exr_context_initializer_t image_exr_init(ImageExrErr *e)
{
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = image_exr_on_error;
    init.user_data = e;
    /* Lets the header parser reject huge images before anything is read. */
    init.max_image_width = LIMIT_IMAGE_SIDE;
    init.max_image_height = LIMIT_IMAGE_SIDE;
    return init;
}

static void image_exr_report(char *err, size_t errlen, const char *path, const char *what,
                             const ImageExrErr *e, exr_result_t rv)
{
    snprintf(err, errlen, "%s: %s: %s", path, what,
             e->set ? e->msg : exr_get_default_error_message(rv));
}

/* Offset of a channel inside an interleaved RGB pixel, -1 if not R, G or B. */
static int image_rgb_offset(const char *name)
{
    if (name == NULL || name[0] == '\0' || name[1] != '\0')
        return -1;
    switch (name[0]) {
    case 'R': return 0;
    case 'G': return 1;
    case 'B': return 2;
    default: return -1;
    }
}

/* Encodes every scanline chunk, on up to `threads` threads. The encoder
 * converts our interleaved floats to the channel type itself (half: round
 * to nearest even, overflow to inf, subnormals kept), so no conversion code
 * lives here. OpenEXRCore lets each thread run an encode pipeline of its
 * own on one context, and calls the pipeline's yield_until_ready_fn before
 * writing a chunk: here it waits for the chunks before, which the format
 * wants in order. So the chunks are compressed side by side, and the file
 * is the same, byte for byte, for any number of threads. */
typedef struct {
    exr_context_t ctx;
    int part, lpc, nchunks;
    const Image *img;
    pthread_mutex_t lock;
    pthread_cond_t turn; /* written moved, or rv failed */
    int claimed;         /* chunks handed out */
    int written;         /* chunks written */
    exr_result_t rv;     /* the first failure */
} ExrJob;

/* One thread's encoder: its job, and the library's own compression. */
typedef struct {
    ExrJob *job;
    exr_result_t (*compress)(exr_encode_pipeline_t *enc);
} ExrCoder;

/* Waits until the chunks before this one are written. */
static exr_result_t exr_wait_turn(exr_encode_pipeline_t *enc)
{
    ExrJob *j = ((const ExrCoder *)enc->encoding_user_data)->job;
    int c = (enc->chunk.start_y - j->img->y) / j->lpc;
    pthread_mutex_lock(&j->lock);
    while (j->written < c && j->rv == EXR_ERR_SUCCESS)
        pthread_cond_wait(&j->turn, &j->lock);
    exr_result_t rv = j->rv == EXR_ERR_SUCCESS ? EXR_ERR_SUCCESS : EXR_ERR_INCORRECT_CHUNK;
    pthread_mutex_unlock(&j->lock);
    return rv;
}

/* The library's compression, then a chunk that deflated to exactly its
 * packed length stored raw. OpenEXRCore 3.1 (internal_zip.c) keeps the
 * deflated bytes unless they are longer, but a reader takes a chunk as
 * long as its packed data for raw: such a chunk read back as garbage
 * (OpenEXR issue #2306, fixed after 3.4.7). Where the library stored it raw
 * already, the copy is the same bytes. */
static exr_result_t exr_compress_chunk(exr_encode_pipeline_t *enc)
{
    const ExrCoder *me = enc->encoding_user_data;
    exr_result_t rv = me->compress(enc);
    if (rv == EXR_ERR_SUCCESS && enc->compressed_bytes == enc->packed_bytes &&
        enc->compressed_buffer != enc->packed_buffer)
        memcpy(enc->compressed_buffer, enc->packed_buffer, enc->packed_bytes);
    return rv;
}

/* Takes chunks until none is left or one fails. */
static void *exr_encode_chunks(void *arg)
{
    ExrJob *j = arg;
    const Image *img = j->img;
    exr_encode_pipeline_t enc = EXR_ENCODE_PIPELINE_INITIALIZER;
    ExrCoder me = {j, NULL};
    int started = 0;
    for (;;) {
        exr_chunk_info_t ci;
        exr_result_t rv = EXR_ERR_SUCCESS;
        /* the context's bookkeeping one thread at a time */
        pthread_mutex_lock(&j->lock);
        int c = j->rv == EXR_ERR_SUCCESS && j->claimed < j->nchunks ? j->claimed++ : -1;
        if (c >= 0)
            rv = exr_write_scanline_chunk_info(j->ctx, j->part, img->y + c * j->lpc, &ci);
        if (c >= 0 && rv == EXR_ERR_SUCCESS)
            rv = started ? exr_encoding_update(j->ctx, j->part, &ci, &enc)
                         : exr_encoding_initialize(j->ctx, j->part, &ci, &enc);
        pthread_mutex_unlock(&j->lock);
        if (c < 0)
            break;
        int first = !started;
        started = 1;
        int y = c * j->lpc;
        for (int k = 0; k < enc.channel_count && rv == EXR_ERR_SUCCESS; k++) {
            exr_coding_channel_info_t *ch = &enc.channels[k];
            int off = image_rgb_offset(ch->channel_name);
            if (off < 0) {
                rv = EXR_ERR_INVALID_ARGUMENT; /* cannot happen: we add only R, G, B */
                break;
            }
            ch->encode_from_ptr =
                (const uint8_t *)(img->rgb + ((size_t)y * (size_t)img->width) * 3 + (size_t)off);
            ch->user_data_type = EXR_PIXEL_FLOAT;
            ch->user_bytes_per_element = (int16_t)sizeof(float);
            ch->user_pixel_stride = (int32_t)(3 * sizeof(float));
            ch->user_line_stride = (int32_t)(3 * sizeof(float)) * img->width;
        }
        if (rv == EXR_ERR_SUCCESS && first) {
            rv = exr_encoding_choose_default_routines(j->ctx, j->part, &enc);
            me.compress = enc.compress_fn;
            if (me.compress)
                enc.compress_fn = exr_compress_chunk;
        }
        enc.yield_until_ready_fn = exr_wait_turn;
        enc.encoding_user_data = &me;
        if (rv == EXR_ERR_SUCCESS)
            rv = exr_encoding_run(j->ctx, j->part, &enc);
        pthread_mutex_lock(&j->lock);
        if (rv == EXR_ERR_SUCCESS)
            j->written++;
        else if (j->rv == EXR_ERR_SUCCESS)
            j->rv = rv;
        pthread_cond_broadcast(&j->turn);
        pthread_mutex_unlock(&j->lock);
        if (rv != EXR_ERR_SUCCESS)
            break;
    }
    if (started)
        exr_encoding_destroy(j->ctx, &enc);
    return NULL;
}

static exr_result_t image_exr_encode(exr_context_t ctx, int part, const Image *img, int threads, ImageExrErr *e)
{
    int32_t lpc = 0;
    exr_result_t rv = exr_get_scanlines_per_chunk(ctx, part, &lpc);
    if (rv != EXR_ERR_SUCCESS)
        return rv;
    if (lpc < 1)
        return EXR_ERR_INVALID_ARGUMENT;
    ExrJob j;
    memset(&j, 0, sizeof j);
    j.ctx = ctx;
    j.part = part;
    j.lpc = lpc;
    j.nchunks = (img->height + lpc - 1) / lpc;
    j.img = img;
    j.rv = EXR_ERR_SUCCESS;
    /* no more threads than chunks for each to take a few */
    int extra = threads - 1 < j.nchunks / 4 ? threads - 1 : j.nchunks / 4, started = 0;
    pthread_t *tids = extra > 0 ? malloc(sizeof(pthread_t) * (size_t)extra) : NULL;
    pthread_mutex_t msg_lock; /* the error handler's, never held while OpenEXRCore is called */
    if (pthread_mutex_init(&j.lock, NULL) != 0) {
        free(tids);
        return EXR_ERR_OUT_OF_MEMORY;
    }
    if (pthread_cond_init(&j.turn, NULL) != 0) {
        pthread_mutex_destroy(&j.lock);
        free(tids);
        return EXR_ERR_OUT_OF_MEMORY;
    }
    if (tids && pthread_mutex_init(&msg_lock, NULL) == 0) {
        e->lock = &msg_lock;
        while (started < extra && thread_start(&tids[started], exr_encode_chunks, &j) == 0)
            started++;
    }
    exr_encode_chunks(&j); /* the calling thread takes chunks too */
    for (int i = 0; i < started; i++)
        pthread_join(tids[i], NULL);
    if (e->lock)
        pthread_mutex_destroy(e->lock);
    e->lock = NULL;
    free(tids);
    pthread_cond_destroy(&j.turn);
    pthread_mutex_destroy(&j.lock);
    if (j.rv == EXR_ERR_SUCCESS && j.written != j.nchunks)
        return EXR_ERR_INCORRECT_CHUNK; /* cannot happen: every chunk is taken */
    return j.rv;
}

static exr_result_t image_exr_write_file(const Image *img, const char *file, ImagePrecision prec,
                                         const ImageAttr *attrs, int nattrs, int threads, ImageExrErr *e)
{
    exr_context_initializer_t init = image_exr_init(e);
    exr_context_t ctx = NULL;
    /* Directly: `file` is already our private temporary; afile renames it. */
    exr_result_t rv = exr_start_write(&ctx, file, EXR_WRITE_FILE_DIRECTLY, &init);
    if (rv != EXR_ERR_SUCCESS) {
        if (ctx != NULL)
            exr_finish(&ctx);
        return rv;
    }
    const exr_const_context_t writer = ctx;
    image_exr_writer(writer, NULL, e);

    int part = 0;
    exr_pixel_type_t type = prec == IMAGE_HALF ? EXR_PIXEL_HALF : EXR_PIXEL_FLOAT;
    static const char *const names[3] = {"B", "G", "R"}; /* the file sorts them anyway */
    rv = exr_add_part(ctx, NULL, EXR_STORAGE_SCANLINE, &part);
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_initialize_required_attr_simple(ctx, part, img->full_width, img->full_height,
                                                 EXR_COMPRESSION_ZIP);
    if (rv == EXR_ERR_SUCCESS) {
        exr_attr_box2i_t dw;
        dw.min.x = img->x;
        dw.min.y = img->y;
        dw.max.x = img->x + img->width - 1;
        dw.max.y = img->y + img->height - 1;
        rv = exr_set_data_window(ctx, part, &dw);
    }
    /* pLinear 0 ("logarithmic"), as OpenEXR's own RGBA writer marks colour. */
    for (int c = 0; c < 3 && rv == EXR_ERR_SUCCESS; c++)
        rv = exr_add_channel(ctx, part, names[c], type, EXR_PERCEPTUALLY_LOGARITHMIC, 1, 1);
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_set_zip_compression_level(ctx, part, IMAGE_ZIP_LEVEL);
    for (int i = 0; i < nattrs && rv == EXR_ERR_SUCCESS; i++)
        rv = exr_attr_set_string(ctx, part, attrs[i].name, attrs[i].value);
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_write_header(ctx);
    if (rv == EXR_ERR_SUCCESS)
        rv = image_exr_encode(ctx, part, img, threads, e);
    /* exr_finish writes the chunk offset table and closes the file, so its
     * result decides success too. */
    exr_result_t frv = exr_finish(&ctx);
    image_exr_writer(NULL, writer, NULL);
    return rv != EXR_ERR_SUCCESS ? rv : frv;
}

/* Checks what image_write_exr* are given. */
static int exr_args_ok(const Image *img, const char *path, ImagePrecision prec, char *err, size_t errlen)
{
    if (!image_valid(img)) {
        snprintf(err, errlen, "%s: cannot write: invalid image", path);
        return 0;
    }
    if (prec != IMAGE_HALF && prec != IMAGE_FLOAT) {
        snprintf(err, errlen, "%s: cannot write: invalid precision %d", path, (int)prec);
        return 0;
    }
    return 1;
}

int image_write_exr_file(const Image *img, const char *file, const char *name, ImagePrecision prec,
                         const ImageAttr *attrs, int nattrs, int threads, char *err, size_t errlen)
{
    if (!exr_args_ok(img, name, prec, err, errlen))
        return -1;
    ImageExrErr e = {{0}, 0, NULL};
    exr_result_t rv = image_exr_write_file(img, file, prec, attrs, nattrs, threads, &e);
    if (rv != EXR_ERR_SUCCESS) {
        image_exr_report(err, errlen, name, "cannot write", &e, rv);
        return -1;
    }
    return 0;
}

int image_write_exr(const Image *img, const char *path, ImagePrecision prec, char *err, size_t errlen)
{
    if (!exr_args_ok(img, path, prec, err, errlen))
        return -1;
    char tmp[AFILE_PATH_MAX];
    if (afile_temp(path, tmp, sizeof tmp, err, errlen) != 0)
        return -1;
    ImageExrErr e = {{0}, 0, NULL};
    exr_result_t rv = image_exr_write_file(img, tmp, prec, NULL, 0, 1, &e);
    if (rv != EXR_ERR_SUCCESS) {
        afile_abort(tmp);
        image_exr_report(err, errlen, path, "cannot write", &e, rv);
        return -1;
    }
    return afile_commit(tmp, path, err, errlen);
}

/* What reading needs beside the context: the message, the file's bytes,
 * and room for the channels lancer does not keep. The message comes first,
 * so that the error handler finds it at the user data's address. */
typedef struct {
    ImageExrErr e;
    const unsigned char *data;
    size_t len;
    float *scratch; /* one chunk of one channel, as floats */
    size_t scratch_len;
} ImageExrRead;

/* OpenEXRCore's read callback, over the bytes read beforehand: the file is
 * never opened by the library (so a FIFO cannot block it) and every read
 * stays inside what the file holds. */
static int64_t image_exr_mem_read(exr_const_context_t ctxt, void *ud, void *buffer, uint64_t sz, uint64_t offset,
                                  exr_stream_error_func_ptr_t error_cb)
{
    (void)ctxt;
    (void)error_cb;
    const ImageExrRead *m = ud;
    if (offset >= m->len)
        return 0;
    size_t n = (size_t)(sz < m->len - offset ? sz : m->len - offset);
    memcpy(buffer, m->data + offset, n);
    return (int64_t)n;
}

static int64_t image_exr_mem_size(exr_const_context_t ctxt, void *ud)
{
    (void)ctxt;
    return (int64_t)((const ImageExrRead *)ud)->len;
}

/* Decodes one chunk whose top-left pixel is (x0, y0) in image coordinates,
 * converting R, G and B to float straight into img. The other channels are
 * decoded into scratch, since OpenEXR 3.1's unpackers for some channel
 * layouts (three halves, say) write through every channel's pointer, a
 * NULL one too. */
static exr_result_t image_exr_decode_chunk(exr_const_context_t ctx, const exr_chunk_info_t *ci,
                                           int64_t x0, int64_t y0, Image *img,
                                           exr_decode_pipeline_t *dec, int *started, ImageExrRead *rd)
{
    ImageExrErr *e = &rd->e;
    /* A corrupt header or chunk table must not make us write outside img. */
    if (x0 < 0 || y0 < 0 || ci->width < 0 || ci->height < 0 ||
        x0 + ci->width > img->width || y0 + ci->height > img->height) {
        image_exr_note(e, "corrupt file: chunk lies outside the data window");
        return EXR_ERR_CORRUPT_CHUNK;
    }
    exr_result_t rv;
    if (*started) {
        rv = exr_decoding_update(ctx, 0, ci, dec);
    } else {
        rv = exr_decoding_initialize(ctx, 0, ci, dec);
        *started = 1;
    }
    if (rv != EXR_ERR_SUCCESS)
        return rv;

    float *origin = img->rgb + ((size_t)y0 * (size_t)img->width + (size_t)x0) * 3;
    for (int c = 0; c < dec->channel_count; c++) {
        exr_coding_channel_info_t *ch = &dec->channels[c];
        int off = image_rgb_offset(ch->channel_name);
        if (off < 0) {
            size_t need = (size_t)ch->width * (size_t)ch->height;
            if (need > rd->scratch_len) {
                float *sc = realloc(rd->scratch, sizeof(float) * need);
                if (!sc) {
                    image_exr_note(e, "out of memory");
                    return EXR_ERR_OUT_OF_MEMORY;
                }
                rd->scratch = sc;
                rd->scratch_len = need;
            }
            ch->decode_to_ptr = (uint8_t *)rd->scratch;
            ch->user_data_type = EXR_PIXEL_FLOAT;
            ch->user_bytes_per_element = (int16_t)sizeof(float);
            ch->user_pixel_stride = (int32_t)sizeof(float);
            ch->user_line_stride = (int32_t)sizeof(float) * ch->width;
            continue;
        }
        ch->decode_to_ptr = (uint8_t *)(origin + off);
        ch->user_data_type = EXR_PIXEL_FLOAT;
        ch->user_bytes_per_element = (int16_t)sizeof(float);
        ch->user_pixel_stride = (int32_t)(3 * sizeof(float));
        ch->user_line_stride = (int32_t)(3 * sizeof(float)) * img->width;
    }
    /* Chosen per chunk: the choice depends on the output pointers. */
    rv = exr_decoding_choose_default_routines(ctx, 0, dec);
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_decoding_run(ctx, 0, dec);
    return rv;
}

static exr_result_t image_exr_read_scanlines(exr_const_context_t ctx, const exr_attr_box2i_t *dw,
                                             Image *img, exr_decode_pipeline_t *dec, int *started,
                                             ImageExrRead *rd)
{
    ImageExrErr *e = &rd->e;
    int32_t lpc = 0;
    exr_result_t rv = exr_get_scanlines_per_chunk(ctx, 0, &lpc);
    if (rv != EXR_ERR_SUCCESS)
        return rv;
    if (lpc < 1) {
        image_exr_note(e, "corrupt file: bad scanlines per chunk");
        return EXR_ERR_FILE_BAD_HEADER;
    }
    /* Chunks start at the data window's top row, every lpc rows. */
    for (int64_t row = 0; row < img->height; row += lpc) {
        exr_chunk_info_t ci;
        rv = exr_read_scanline_chunk_info(ctx, 0, (int)(dw->min.y + row), &ci);
        if (rv != EXR_ERR_SUCCESS)
            return rv;
        if (ci.width != img->width) {
            image_exr_note(e, "corrupt file: chunk width differs from the data window");
            return EXR_ERR_CORRUPT_CHUNK;
        }
        rv = image_exr_decode_chunk(ctx, &ci, 0, (int64_t)ci.start_y - dw->min.y, img, dec,
                                    started, rd);
        if (rv != EXR_ERR_SUCCESS)
            return rv;
    }
    return EXR_ERR_SUCCESS;
}

/* Reads level 0 (full resolution) of a tiled part. */
static exr_result_t image_exr_read_tiles(exr_const_context_t ctx, Image *img,
                                         exr_decode_pipeline_t *dec, int *started, ImageExrRead *rd)
{
    ImageExrErr *e = &rd->e;
    uint32_t tw = 0, th = 0;
    exr_tile_level_mode_t level;
    exr_tile_round_mode_t round;
    exr_result_t rv = exr_get_tile_descriptor(ctx, 0, &tw, &th, &level, &round);
    if (rv != EXR_ERR_SUCCESS)
        return rv;
    if (tw == 0 || th == 0) {
        image_exr_note(e, "corrupt file: zero tile size");
        return EXR_ERR_FILE_BAD_HEADER;
    }
    int64_t nx = ((int64_t)img->width + tw - 1) / tw;
    int64_t ny = ((int64_t)img->height + th - 1) / th;
    for (int64_t ty = 0; ty < ny; ty++) {
        for (int64_t tx = 0; tx < nx; tx++) {
            exr_chunk_info_t ci;
            /* For tiles, ci.start_x/start_y are tile indices, not pixels. */
            rv = exr_read_tile_chunk_info(ctx, 0, (int)tx, (int)ty, 0, 0, &ci);
            if (rv == EXR_ERR_SUCCESS)
                rv = image_exr_decode_chunk(ctx, &ci, tx * tw, ty * th, img, dec, started, rd);
            if (rv != EXR_ERR_SUCCESS)
                return rv;
        }
    }
    return EXR_ERR_SUCCESS;
}

static exr_result_t image_exr_read_part(exr_const_context_t ctx, Image *img, ImageExrRead *rd)
{
    ImageExrErr *e = &rd->e;
    exr_storage_t storage;
    exr_result_t rv = exr_get_storage(ctx, 0, &storage);
    if (rv != EXR_ERR_SUCCESS)
        return rv;
    if (storage != EXR_STORAGE_SCANLINE && storage != EXR_STORAGE_TILED) {
        image_exr_note(e, "deep images are not supported");
        return EXR_ERR_FEATURE_NOT_IMPLEMENTED;
    }

    exr_attr_box2i_t dw;
    rv = exr_get_data_window(ctx, 0, &dw);
    if (rv != EXR_ERR_SUCCESS)
        return rv;
    int64_t w = (int64_t)dw.max.x - dw.min.x + 1;
    int64_t h = (int64_t)dw.max.y - dw.min.y + 1;
    if (w < 1 || h < 1 || w > LIMIT_IMAGE_SIDE || h > LIMIT_IMAGE_SIDE) {
        char msg[128];
        snprintf(msg, sizeof msg, "data window of %lldx%lld pixels is outside 1..%d", (long long)w,
                 (long long)h, LIMIT_IMAGE_SIDE);
        image_exr_note(e, msg);
        return EXR_ERR_ARGUMENT_OUT_OF_RANGE;
    }

    const exr_attr_chlist_t *chans = NULL;
    rv = exr_get_channels(ctx, 0, &chans);
    if (rv != EXR_ERR_SUCCESS)
        return rv;
    int wanted = 0;
    for (int c = 0; c < chans->num_channels; c++) {
        const exr_attr_chlist_entry_t *ch = &chans->entries[c];
        if (image_rgb_offset(ch->name.str) < 0)
            continue;
        if (ch->x_sampling != 1 || ch->y_sampling != 1) {
            image_exr_note(e, "subsampled R, G or B channels are not supported");
            return EXR_ERR_FEATURE_NOT_IMPLEMENTED;
        }
        wanted = 1;
    }

    if (!wanted) { /* nothing to read, and nothing to compare: other names, or layers */
        image_exr_note(e, "no channel named R, G or B");
        return EXR_ERR_FEATURE_NOT_IMPLEMENTED;
    }
    if (w * h > LIMIT_IMAGE_PIXELS) {
        char msg[160];
        snprintf(msg, sizeof msg, "data window of %lldx%lld pixels is more than the %ld an image may have",
                 (long long)w, (long long)h, (long)LIMIT_IMAGE_PIXELS);
        image_exr_note(e, msg);
        return EXR_ERR_ARGUMENT_OUT_OF_RANGE;
    }
    /* The header's size against the file's, before allocating it: no
     * compression of OpenEXR 3.1 packs more pixels into a byte than
     * IMAGE_EXR_PACKING, and the chunks' offsets take 8 bytes each. */
    int32_t nchunks = 0;
    if (exr_get_chunk_count(ctx, 0, &nchunks) == EXR_ERR_SUCCESS && (unsigned long long)nchunks * 8 > rd->len) {
        char msg[160];
        snprintf(
            msg, sizeof msg,
            "corrupt file: %lldx%lld pixels in %d chunks announced, whose offsets alone are more than its %zu bytes",
            (long long)w, (long long)h, (int)nchunks, rd->len);
        image_exr_note(e, msg);
        return EXR_ERR_CORRUPT_CHUNK;
    }
    if ((unsigned long long)(w * h) > (unsigned long long)rd->len * IMAGE_EXR_PACKING) {
        char msg[160];
        snprintf(msg, sizeof msg, "corrupt file: %lldx%lld pixels announced, more than its %zu bytes can hold",
                 (long long)w, (long long)h, rd->len);
        image_exr_note(e, msg);
        return EXR_ERR_CORRUPT_CHUNK;
    }
    if (image_init(img, (int)w, (int)h) != 0) {
        image_exr_note(e, "out of memory");
        return EXR_ERR_OUT_OF_MEMORY;
    }
    exr_attr_box2i_t disp;
    if (exr_get_display_window(ctx, 0, &disp) == EXR_ERR_SUCCESS) {
        int64_t fw = (int64_t)disp.max.x - disp.min.x + 1, fh = (int64_t)disp.max.y - disp.min.y + 1;
        int64_t x = (int64_t)dw.min.x - disp.min.x, y = (int64_t)dw.min.y - disp.min.y;
        if (x >= 0 && y >= 0 && x + w <= fw && y + h <= fh && fw <= LIMIT_IMAGE_SIDE && fh <= LIMIT_IMAGE_SIDE) {
            img->x = (int)x;
            img->y = (int)y;
            img->full_width = (int)fw;
            img->full_height = (int)fh;
        }
    }

    exr_decode_pipeline_t dec = EXR_DECODE_PIPELINE_INITIALIZER;
    int started = 0;
    if (storage == EXR_STORAGE_SCANLINE)
        rv = image_exr_read_scanlines(ctx, &dw, img, &dec, &started, rd);
    else
        rv = image_exr_read_tiles(ctx, img, &dec, &started, rd);
    if (started)
        exr_decoding_destroy(ctx, &dec);
    return rv;
}

/* The header's "lancer:" string attributes, and whether R, G and B are
 * all half. */
static exr_result_t image_exr_meta(exr_const_context_t ctx, ImageMeta *meta, ImageExrErr *e)
{
    int32_t count = 0;
    exr_result_t rv = exr_get_attribute_count(ctx, 0, &count);
    for (int32_t i = 0; i < count && rv == EXR_ERR_SUCCESS; i++) {
        const exr_attribute_t *a = NULL;
        rv = exr_get_attribute_by_index(ctx, 0, EXR_ATTR_LIST_FILE_ORDER, i, &a);
        if (rv != EXR_ERR_SUCCESS || a->type != EXR_ATTR_STRING || strncmp(a->name, "lancer:", 7) != 0)
            continue;
        if (meta->n == IMAGE_META_MAX) {
            image_exr_note(e, "more lancer: attributes than lancer writes");
            return EXR_ERR_FILE_BAD_HEADER;
        }
        size_t nl = strlen(a->name), vl = a->string->length > 0 ? (size_t)a->string->length : 0;
        char *n = malloc(nl + 1), *v = malloc(vl + 1);
        if (!n || !v) {
            free(n);
            free(v);
            image_exr_note(e, "out of memory");
            return EXR_ERR_OUT_OF_MEMORY;
        }
        memcpy(n, a->name, nl + 1);
        if (vl)
            memcpy(v, a->string->str, vl);
        v[vl] = '\0';
        meta->name[meta->n] = n;
        meta->value[meta->n++] = v;
    }
    const exr_attr_chlist_t *chans = NULL;
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_get_channels(ctx, 0, &chans);
    if (rv == EXR_ERR_SUCCESS) {
        int halves = 0;
        for (int c = 0; c < chans->num_channels; c++)
            halves += image_rgb_offset(chans->entries[c].name.str) >= 0 && chans->entries[c].pixel_type == EXR_PIXEL_HALF;
        meta->half = halves == 3;
    }
    return rv;
}

void image_meta_free(ImageMeta *meta)
{
    for (int i = 0; i < meta->n; i++) {
        free(meta->name[i]);
        free(meta->value[i]);
    }
    memset(meta, 0, sizeof *meta);
}

const char *image_meta_get(const ImageMeta *meta, const char *name)
{
    for (int i = 0; i < meta->n; i++)
        if (strcmp(meta->name[i], name) == 0)
            return meta->value[i];
    return NULL;
}

int image_parse_exr(const char *name, const void *data, size_t len, Image *img, char *err, size_t errlen)
{
    return image_parse_exr_meta(name, data, len, img, NULL, err, errlen);
}

int image_parse_exr_meta(const char *name, const void *data, size_t len, Image *img, ImageMeta *meta, char *err,
                         size_t errlen)
{
    img->width = 0;
    img->height = 0;
    img->rgb = NULL;
    ImageExrRead rd = {{{0}, 0, NULL}, (const unsigned char *)data, len, NULL, 0};
    exr_context_initializer_t init = image_exr_init(&rd.e);
    init.user_data = &rd;
    init.read_fn = image_exr_mem_read;
    init.size_fn = image_exr_mem_size;
    exr_context_t ctx = NULL;
    exr_result_t rv = exr_start_read(&ctx, name, &init);
    if (rv == EXR_ERR_SUCCESS && meta)
        rv = image_exr_meta(ctx, meta, &rd.e);
    if (rv == EXR_ERR_SUCCESS)
        rv = image_exr_read_part(ctx, img, &rd);
    if (ctx != NULL)
        exr_finish(&ctx);
    free(rd.scratch);
    if (rv != EXR_ERR_SUCCESS) {
        image_free(img);
        image_exr_report(err, errlen, name, "cannot read", &rd.e, rv);
        return -1;
    }
    return 0;
}

int image_read_exr_meta(const char *path, Image *img, ImageMeta *meta, char *err, size_t errlen)
{
    img->width = img->height = img->x = img->y = img->full_width = img->full_height = 0;
    img->rgb = NULL;
    if (meta)
        memset(meta, 0, sizeof *meta);
    char *data;
    size_t len;
    if (afile_read(path, (unsigned long long)LIMIT_EXR_BYTES, "images", &data, &len, err, errlen) != 0)
        return -1;
    int rc = image_parse_exr_meta(path, data, len, img, meta, err, errlen);
    free(data);
    return rc;
}

int image_read_exr(const char *path, Image *img, char *err, size_t errlen)
{
    return image_read_exr_meta(path, img, NULL, err, errlen);
}

/* ---- PNG ---------------------------------------------------------------- */

unsigned char image_srgb8(float linear)
{
    /* Written so that NaN also lands in the first branch. */
    if (!(linear > 0.0f))
        return 0;
    if (linear >= 1.0f)
        return 255;
    double x = linear;
    double v = x <= 0.0031308 ? 12.92 * x : 1.055 * pow(x, 1.0 / 2.4) - 0.055;
    return (unsigned char)(v * 255.0 + 0.5);
}

/* image_srgb8 by its thresholds: at[k] is the least float in (0, 1] that
 * image_srgb8 takes to k or more (k = 1 .. 255), found by bisection over
 * the floats' bit patterns, which order the positive floats. image_srgb8
 * never decreases as its argument grows, so the byte of x is the largest k
 * with at[k] <= x: the same bytes, without a pow() for each channel of
 * each pixel. */
typedef struct {
    float at[256];
} Srgb8Table;

static float float_of_bits(uint32_t b)
{
    float f;
    memcpy(&f, &b, sizeof f);
    return f;
}

float image_half_round(float x)
{
    uint32_t b;
    memcpy(&b, &x, sizeof b);
    const uint32_t sign = b & 0x80000000u, a = b ^ sign;
    float f;
    if (a >= 0x477ff000u) { /* 65520 (65504 and half its step: the tie goes to the even 2^16), or NaN */
        if (a > 0x7f800000u)
            return x;
        b = sign | 0x7f800000u;
    } else if (a < 0x38800000u) { /* below 2^-14: a multiple of 2^-24, the sum's step, ties to even */
        memcpy(&f, &a, sizeof f);
        f = (f + 0.5f) - 0.5f;
        memcpy(&b, &f, sizeof b);
        b |= sign;
    } else /* 10 of the 23 fraction bits, ties to even: a carry moves the exponent */
        b = sign | ((a + 0x0fffu + (a >> 13 & 1u)) & ~0x1fffu);
    memcpy(&f, &b, sizeof f);
    return f;
}

/* With half, the thresholds of image_srgb8 of x rounded to half
 * (image_half_round is monotone too): the lookup itself is the same. */
static void srgb8_table(Srgb8Table *t, int half)
{
    const uint32_t one = 0x3f800000u; /* 1.0f's bits */
    t->at[0] = 0.0f;
    for (int k = 1; k < 256; k++) {
        uint32_t lo = 1, hi = one; /* image_srgb8 of hi is 255 >= k */
        while (lo < hi) {
            uint32_t mid = lo + (hi - lo) / 2;
            float x = float_of_bits(mid);
            if (image_srgb8(half ? image_half_round(x) : x) >= k)
                hi = mid;
            else
                lo = mid + 1;
        }
        t->at[k] = float_of_bits(lo);
    }
}

static unsigned char srgb8_lookup(const Srgb8Table *t, float x)
{
    if (!(x > 0.0f)) /* NaN too */
        return 0;
    unsigned k = 0;
    for (unsigned step = 128; step > 0; step >>= 1)
        if (x >= t->at[k + step])
            k += step;
    return (unsigned char)k;
}

/* Everything the setjmp-protected code touches lives here, outside the
 * frame that calls setjmp, so longjmp cannot leave stale locals behind. */
typedef struct {
    const Image *img;
    int half; /* a half EXR's preview: its values as half rounds them (srgb8_table) */
    FILE *fp;
    Srgb8Table srgb;
    unsigned char *row; /* 3 * width bytes */
    png_structp png;
    png_infop info;
    char msg[256];
    int saved_errno; /* from the failing write, 0 if none */
} ImagePngJob;

static void image_png_on_error(png_structp png, png_const_charp msg)
{
    ImagePngJob *job = png_get_error_ptr(png);
    if (job->msg[0] == '\0')
        snprintf(job->msg, sizeof job->msg, "%s",
                 job->saved_errno != 0 ? strerror(job->saved_errno) : msg);
    /* Must not return: libpng would then print and abort on its own. */
    png_longjmp(png, 1);
}

static void image_png_on_warning(png_structp png, png_const_charp msg)
{
    (void)png; /* library code stays silent */
    (void)msg;
}

/* Our own write callback keeps errno, so "No space left on device" reaches
 * the user instead of libpng's bare "Write Error". */
static void image_png_write(png_structp png, png_bytep data, size_t len)
{
    ImagePngJob *job = png_get_io_ptr(png);
    errno = 0;
    if (fwrite(data, 1, len, job->fp) != len) {
        job->saved_errno = errno != 0 ? errno : EIO;
        png_error(png, "write failed");
    }
}

static void image_png_flush(png_structp png)
{
    ImagePngJob *job = png_get_io_ptr(png);
    errno = 0;
    if (fflush(job->fp) != 0) {
        job->saved_errno = errno != 0 ? errno : EIO;
        png_error(png, "flush failed");
    }
}

static int image_png_run(ImagePngJob *job)
{
    job->png = png_create_write_struct(PNG_LIBPNG_VER_STRING, job, image_png_on_error,
                                       image_png_on_warning);
    if (job->png == NULL) {
        snprintf(job->msg, sizeof job->msg, "out of memory");
        return -1;
    }
    job->info = png_create_info_struct(job->png);
    if (job->info == NULL) {
        snprintf(job->msg, sizeof job->msg, "out of memory");
        return -1;
    }
    if (setjmp(png_jmpbuf(job->png)))
        return -1;

    const Image *img = job->img;
    png_set_write_fn(job->png, job, image_png_write, image_png_flush);
    png_set_IHDR(job->png, job->info, (png_uint_32)img->width, (png_uint_32)img->height, 8,
                 PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
                 PNG_FILTER_TYPE_DEFAULT);
    /* Tells viewers the bytes are sRGB-encoded (sRGB, gAMA and cHRM chunks). */
    png_set_sRGB_gAMA_and_cHRM(job->png, job->info, PNG_sRGB_INTENT_PERCEPTUAL);
    png_set_compression_level(job->png, IMAGE_ZIP_LEVEL);
    png_write_info(job->png, job->info);
    srgb8_table(&job->srgb, job->half);
    for (int y = 0; y < img->height; y++) {
        const float *src = img->rgb + (size_t)y * (size_t)img->width * 3;
        for (size_t i = 0; i < (size_t)img->width * 3; i++)
            job->row[i] = srgb8_lookup(&job->srgb, src[i]);
        png_write_row(job->png, job->row);
    }
    png_write_end(job->png, job->info);
    return 0;
}

/* Writes the PNG into the file `file` (created or truncated), naming `path`
 * in messages. */
static int png_to_file(const Image *img, int half, const char *file, const char *path, char *err, size_t errlen)
{
    if (!image_valid(img)) {
        snprintf(err, errlen, "%s: cannot write: invalid image", path);
        return -1;
    }
    ImagePngJob job;
    memset(&job, 0, sizeof job);
    job.img = img;
    job.half = half;
    job.row = malloc((size_t)img->width * 3);
    if (job.row == NULL) {
        snprintf(err, errlen, "%s: cannot write: out of memory", path);
        return -1;
    }
    job.fp = fopen(file, "wb");
    if (job.fp == NULL) {
        snprintf(err, errlen, "%s: cannot write: %s", path, strerror(errno));
        free(job.row);
        return -1;
    }
    int rc = image_png_run(&job);
    if (job.png != NULL)
        png_destroy_write_struct(&job.png, &job.info);
    free(job.row);
    int bad = ferror(job.fp), saved = errno;
    /* fclose flushes the last buffered bytes: a late ENOSPC shows there */
    if (fclose(job.fp) != 0 && rc == 0) {
        snprintf(err, errlen, "%s: cannot write: %s", path, strerror(errno));
        return -1;
    }
    if (rc != 0 || bad) {
        snprintf(err, errlen, "%s: cannot write: %s", path,
                 job.msg[0] ? job.msg : bad ? strerror(saved) : "PNG encoding failed");
        return -1;
    }
    return 0;
}

int image_write_png_file(const Image *img, const char *file, const char *name, ImagePrecision prec, char *err,
                         size_t errlen)
{
    return png_to_file(img, prec == IMAGE_HALF, file, name, err, errlen);
}

int image_write_png(const Image *img, const char *path, char *err, size_t errlen)
{
    char tmp[AFILE_PATH_MAX];
    if (!image_valid(img)) {
        snprintf(err, errlen, "%s: cannot write: invalid image", path);
        return -1;
    }
    if (afile_temp(path, tmp, sizeof tmp, err, errlen) != 0)
        return -1;
    if (png_to_file(img, 0, tmp, path, err, errlen) != 0) {
        afile_abort(tmp);
        return -1;
    }
    return afile_commit(tmp, path, err, errlen);
}
