/* OpenEXR reading and writing through OpenEXRCore (contracts in src/io/exr.h). */
#include "io/exr.h"

#include <errno.h>
#include <limits.h>
#include <openexr.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "io/atomic_file.h"

/* Most channels a file may have here (checkpoints need a handful). */
#define EXR_MAX_CHANNELS 2048

/* OpenEXRCore reports details through a callback; keep the last message of this
 * thread so the SptError can carry it instead of a bare error code. */
static _Thread_local char g_exr_msg[512];

static void exr_on_error(exr_const_context_t ctxt, exr_result_t code, const char *msg)
{
    (void)ctxt;
    snprintf(g_exr_msg, sizeof g_exr_msg, "%s", msg ? msg : exr_get_default_error_message(code));
}

/* The best description of rv: the callback's message when it matches, else the
 * library's default text for the code. */
static const char *exr_reason(exr_result_t rv)
{
    return g_exr_msg[0] ? g_exr_msg : exr_get_default_error_message(rv);
}

static exr_context_initializer_t exr_init(int flags)
{
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = exr_on_error;
    init.flags = flags;
    return init;
}

/* Checks the arguments of a write; programming errors, but reported as an output
 * failure rather than a crash. */
static int check_write_args(const char *path, int width, int height,
                            const ExrChannel *channels, int channel_count,
                            const ExrAttr *attrs, int attr_count, SptError *e)
{
    if (width <= 0 || height <= 0)
        return spt_fail(e, SPT_EXIT_OUTPUT, "%s: invalid image size %dx%d", path, width, height);
    if (channel_count <= 0 || channel_count > EXR_MAX_CHANNELS || !channels)
        return spt_fail(e, SPT_EXIT_OUTPUT, "%s: invalid channel count %d", path, channel_count);
    for (int c = 0; c < channel_count; ++c) {
        const ExrChannel *ch = &channels[c];
        if (!ch->name || !ch->name[0] || strlen(ch->name) > 255 || !ch->data ||
            (ch->type != SPT_EXR_FLOAT && ch->type != SPT_EXR_UINT) || ch->stride < 0)
            return spt_fail(e, SPT_EXIT_OUTPUT, "%s: channel %d: invalid definition", path, c);
        for (int d = 0; d < c; ++d)
            if (!strcmp(channels[d].name, ch->name))
                return spt_fail(e, SPT_EXIT_OUTPUT, "%s: channel '%s' given twice", path,
                                ch->name);
    }
    for (int a = 0; a < attr_count; ++a) {
        const ExrAttr *at = &attrs[a];
        if (!at->name || !at->name[0] || strlen(at->name) > 255 ||
            (at->type == SPT_EXR_ATTR_STRING && !at->s) ||
            (at->type != SPT_EXR_ATTR_STRING && at->type != SPT_EXR_ATTR_INT &&
             at->type != SPT_EXR_ATTR_DOUBLE))
            return spt_fail(e, SPT_EXIT_OUTPUT, "%s: attribute %d: invalid definition", path, a);
    }
    return SPT_EXIT_OK;
}

/* Where write_chunk writes (the pipeline's encoding_user_data). */
typedef struct ChunkTarget {
    exr_context_t ctxt;
    int part;
} ChunkTarget;

/* The encode pipeline's write stage. A chunk whose stored size equals its
 * uncompressed size holds the uncompressed pixels: that is how every reader
 * tells a stored chunk from a compressed one. So a compressed chunk must be
 * strictly smaller, else the packed pixels are written instead. OpenEXRCore up
 * to 3.4.7 (Debian 12 has 3.1.5) writes a zlib stream that came out exactly as
 * long as the pixels as it is, and readers then take the zlib bytes for floats
 * (a 16-row band of NaN and 3e38 values in a noisy image; OpenEXR issue 2306). */
static exr_result_t write_chunk(exr_encode_pipeline_t *enc)
{
    const ChunkTarget *t = enc->encoding_user_data;
    const void *data = enc->compressed_buffer;
    uint64_t bytes = enc->compressed_bytes;
    if (bytes >= enc->packed_bytes) {
        data = enc->packed_buffer;
        bytes = enc->packed_bytes;
    }
    return exr_write_scanline_chunk(t->ctxt, t->part, enc->chunk.start_y, data, bytes);
}

/* Writes the whole file to tmp (which exists and is empty). */
static int write_file(const char *path, const char *tmp, int width, int height,
                      const ExrChannel *channels, int channel_count, const ExrAttr *attrs,
                      int attr_count, int srgb_chroma, SptError *e)
{
    exr_context_initializer_t init = exr_init(0);
    exr_context_t ctxt = NULL;
    exr_encode_pipeline_t enc = EXR_ENCODE_PIPELINE_INITIALIZER;
    int enc_live = 0;
    const char *stage = "create";
    int part = 0;
    g_exr_msg[0] = 0;

    exr_result_t rv = exr_start_write(&ctxt, tmp, EXR_WRITE_FILE_DIRECTLY, &init);
    int longnames = 0;
    for (int c = 0; c < channel_count; ++c)
        longnames |= strlen(channels[c].name) > 31;
    for (int a = 0; a < attr_count; ++a)
        longnames |= strlen(attrs[a].name) > 31;
    if (rv == EXR_ERR_SUCCESS && longnames) {
        stage = "header";
        rv = exr_set_longname_support(ctxt, 1);
    }
    if (rv == EXR_ERR_SUCCESS) {
        stage = "header";
        rv = exr_add_part(ctxt, NULL, EXR_STORAGE_SCANLINE, &part);
    }
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_initialize_required_attr_simple(ctxt, part, width, height, EXR_COMPRESSION_ZIP);
    for (int c = 0; c < channel_count && rv == EXR_ERR_SUCCESS; ++c)
        rv = exr_add_channel(ctxt, part, channels[c].name,
                             channels[c].type == SPT_EXR_UINT ? EXR_PIXEL_UINT : EXR_PIXEL_FLOAT,
                             EXR_PERCEPTUALLY_LOGARITHMIC, 1, 1);
    if (rv == EXR_ERR_SUCCESS && srgb_chroma) {
        /* ITU-R BT.709 primaries and D65 white: what linear sRGB means. */
        exr_attr_chromaticities_t ch = {0.64f, 0.33f, 0.30f, 0.60f, 0.15f, 0.06f, 0.3127f, 0.3290f};
        rv = exr_attr_set_chromaticities(ctxt, part, "chromaticities", &ch);
    }
    for (int a = 0; a < attr_count && rv == EXR_ERR_SUCCESS; ++a) {
        const ExrAttr *at = &attrs[a];
        if (at->type == SPT_EXR_ATTR_STRING)
            rv = exr_attr_set_string(ctxt, part, at->name, at->s);
        else if (at->type == SPT_EXR_ATTR_INT)
            rv = exr_attr_set_int(ctxt, part, at->name, at->i);
        else
            rv = exr_attr_set_double(ctxt, part, at->name, at->d);
    }
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_write_header(ctxt);

    int32_t lines = 1;
    ChunkTarget target = {ctxt, part};
    if (rv == EXR_ERR_SUCCESS) {
        stage = "pixels";
        rv = exr_get_scanlines_per_chunk(ctxt, part, &lines);
    }
    for (int y = 0; y < height && rv == EXR_ERR_SUCCESS; y += lines) {
        exr_chunk_info_t ci;
        memset(&ci, 0, sizeof ci);
        rv = exr_write_scanline_chunk_info(ctxt, part, y, &ci);
        if (rv != EXR_ERR_SUCCESS)
            break;
        if (!enc_live) {
            rv = exr_encoding_initialize(ctxt, part, &ci, &enc);
            enc_live = rv == EXR_ERR_SUCCESS;
        } else {
            rv = exr_encoding_update(ctxt, part, &ci, &enc);
        }
        if (rv != EXR_ERR_SUCCESS)
            break;
        for (int k = 0; k < enc.channel_count; ++k) {
            exr_coding_channel_info_t *cc = &enc.channels[k];
            const ExrChannel *src = NULL;
            for (int c = 0; c < channel_count && !src; ++c)
                if (!strcmp(channels[c].name, cc->channel_name))
                    src = &channels[c];
            if (!src) { /* cannot happen: the file has exactly our channels */
                rv = EXR_ERR_INVALID_ARGUMENT;
                break;
            }
            size_t stride = (size_t)(src->stride > 0 ? src->stride : 1) * 4;
            cc->encode_from_ptr =
                (const uint8_t *)src->data + (size_t)ci.start_y * (size_t)width * stride;
            cc->user_pixel_stride = (int32_t)stride;
            cc->user_line_stride = (int32_t)(stride * (size_t)width);
            cc->user_bytes_per_element = 4;
            cc->user_data_type = src->type == SPT_EXR_UINT ? EXR_PIXEL_UINT : EXR_PIXEL_FLOAT;
        }
        if (rv == EXR_ERR_SUCCESS)
            rv = exr_encoding_choose_default_routines(ctxt, part, &enc);
        if (rv == EXR_ERR_SUCCESS) {
            enc.encoding_user_data = &target;
            enc.write_fn = write_chunk;
            rv = exr_encoding_run(ctxt, part, &enc);
        }
    }
    if (enc_live)
        exr_encoding_destroy(ctxt, &enc);
    if (rv == EXR_ERR_SUCCESS) {
        stage = "finish";
        rv = exr_finish(&ctxt); /* writes the chunk offset table, closes the file */
    } else if (ctxt) {
        exr_finish(&ctxt);
    }
    if (rv != EXR_ERR_SUCCESS)
        return spt_fail(e, SPT_EXIT_OUTPUT, "%s: cannot write OpenEXR file (%s): %s", path,
                        stage, exr_reason(rv));
    return SPT_EXIT_OK;
}

static int write_atomic(const char *path, int width, int height, const ExrChannel *channels,
                        int channel_count, const ExrAttr *attrs, int attr_count,
                        int srgb_chroma, SptError *e)
{
    int rc = check_write_args(path, width, height, channels, channel_count, attrs,
                              attr_count, e);
    if (rc)
        return rc;
    char tmp[PATH_MAX + 64];
    rc = atomic_temp_create(path, tmp, sizeof tmp, e);
    if (rc)
        return rc;
    rc = write_file(path, tmp, width, height, channels, channel_count, attrs, attr_count,
                    srgb_chroma, e);
    if (rc) {
        unlink(tmp);
        return rc;
    }
    return atomic_temp_commit(tmp, path, e);
}

int exr_write_layers(const char *path, int width, int height, const ExrChannel *channels,
                     int channel_count, const ExrAttr *attrs, int attr_count, SptError *e)
{
    return write_atomic(path, width, height, channels, channel_count, attrs, attr_count, 0, e);
}

int exr_write_rgb(const char *path, const float *rgb, int width, int height,
                  const ExrAttr *attrs, int attr_count, SptError *e)
{
    return exr_write_rgb_layers(path, rgb, width, height, NULL, 0, attrs, attr_count, e);
}

int exr_write_rgb_layers(const char *path, const float *rgb, int width, int height,
                         const ExrChannel *layers, int layer_count, const ExrAttr *attrs,
                         int attr_count, SptError *e)
{
    if (!rgb)
        return spt_fail(e, SPT_EXIT_OUTPUT, "%s: no pixels to write", path);
    if (layer_count < 0 || layer_count > EXR_MAX_CHANNELS - 3 || (layer_count && !layers))
        return spt_fail(e, SPT_EXIT_OUTPUT, "%s: invalid layer count %d", path, layer_count);
    ExrChannel *ch = spt_malloc((size_t)(3 + layer_count) * sizeof *ch);
    ch[0] = (ExrChannel){"R", SPT_EXR_FLOAT, rgb + 0, 3};
    ch[1] = (ExrChannel){"G", SPT_EXR_FLOAT, rgb + 1, 3};
    ch[2] = (ExrChannel){"B", SPT_EXR_FLOAT, rgb + 2, 3};
    for (int i = 0; i < layer_count; i++)
        ch[3 + i] = layers[i];
    int rc = write_atomic(path, width, height, ch, 3 + layer_count, attrs, attr_count, 1, e);
    free(ch);
    return rc;
}

void exr_layers_free(ExrLayers *l)
{
    if (!l)
        return;
    for (int c = 0; c < l->channel_count; ++c) {
        free((void *)l->channels[c].name);
        free((void *)l->channels[c].data);
    }
    for (int a = 0; a < l->attr_count; ++a) {
        free((void *)l->attrs[a].name);
        free((void *)l->attrs[a].s);
    }
    free(l->channels);
    free(l->attrs);
    memset(l, 0, sizeof *l);
}

/* Copies the string, int and double attributes of part 0 into out. */
static int read_attrs(const char *path, exr_context_t ctxt, ExrLayers *out, SptError *e)
{
    int32_t n = 0;
    exr_result_t rv = exr_get_attribute_count(ctxt, 0, &n);
    if (rv != EXR_ERR_SUCCESS)
        return spt_fail(e, SPT_EXIT_INPUT, "%s: damaged OpenEXR header: %s", path, exr_reason(rv));
    out->attrs = spt_calloc((size_t)(n > 0 ? n : 1), sizeof *out->attrs);
    for (int32_t i = 0; i < n; ++i) {
        const exr_attribute_t *at = NULL;
        rv = exr_get_attribute_by_index(ctxt, 0, EXR_ATTR_LIST_FILE_ORDER, i, &at);
        if (rv != EXR_ERR_SUCCESS || !at)
            return spt_fail(e, SPT_EXIT_INPUT, "%s: damaged OpenEXR header: %s", path,
                            exr_reason(rv));
        ExrAttr a = {0};
        if (at->type == EXR_ATTR_STRING) {
            a.type = SPT_EXR_ATTR_STRING;
            int len = at->string && at->string->str ? at->string->length : 0;
            char *s = spt_malloc((size_t)len + 1);
            if (len)
                memcpy(s, at->string->str, (size_t)len);
            s[len] = 0;
            a.s = s;
        } else if (at->type == EXR_ATTR_INT) {
            a.type = SPT_EXR_ATTR_INT;
            a.i = at->i;
        } else if (at->type == EXR_ATTR_DOUBLE) {
            a.type = SPT_EXR_ATTR_DOUBLE;
            a.d = at->d;
        } else {
            continue;
        }
        a.name = spt_strdup(at->name);
        out->attrs[out->attr_count++] = a;
    }
    return SPT_EXIT_OK;
}

/* Reads every scanline chunk of part 0 into out's channel buffers. */
static int read_pixels(const char *path, exr_context_t ctxt, int min_y, ExrLayers *out,
                       SptError *e)
{
    int32_t lines = 1;
    exr_result_t rv = exr_get_scanlines_per_chunk(ctxt, 0, &lines);
    exr_decode_pipeline_t dec = EXR_DECODE_PIPELINE_INITIALIZER;
    int dec_live = 0;
    int row = min_y;
    for (int y = 0; y < out->height && rv == EXR_ERR_SUCCESS; y += lines) {
        exr_chunk_info_t ci;
        memset(&ci, 0, sizeof ci);
        row = min_y + y;
        rv = exr_read_scanline_chunk_info(ctxt, 0, row, &ci);
        if (rv != EXR_ERR_SUCCESS)
            break;
        if (!dec_live) {
            rv = exr_decoding_initialize(ctxt, 0, &ci, &dec);
            dec_live = rv == EXR_ERR_SUCCESS;
        } else {
            rv = exr_decoding_update(ctxt, 0, &ci, &dec);
        }
        if (rv != EXR_ERR_SUCCESS)
            break;
        for (int k = 0; k < dec.channel_count; ++k) {
            exr_coding_channel_info_t *cc = &dec.channels[k];
            ExrChannel *dst = NULL;
            for (int c = 0; c < out->channel_count && !dst; ++c)
                if (!strcmp(out->channels[c].name, cc->channel_name))
                    dst = &out->channels[c];
            if (!dst) {
                cc->decode_to_ptr = NULL; /* skipped */
                continue;
            }
            cc->decode_to_ptr = (uint8_t *)dst->data +
                                (size_t)(ci.start_y - min_y) * (size_t)out->width * 4;
            cc->user_pixel_stride = 4;
            cc->user_line_stride = out->width * 4;
            cc->user_bytes_per_element = 4;
            cc->user_data_type = dst->type == SPT_EXR_UINT ? EXR_PIXEL_UINT : EXR_PIXEL_FLOAT;
        }
        rv = exr_decoding_choose_default_routines(ctxt, 0, &dec);
        if (rv == EXR_ERR_SUCCESS)
            rv = exr_decoding_run(ctxt, 0, &dec);
    }
    if (dec_live)
        exr_decoding_destroy(ctxt, &dec);
    if (rv != EXR_ERR_SUCCESS)
        return spt_fail(e, SPT_EXIT_INPUT,
                        "%s: damaged or truncated OpenEXR file: pixels at row %d: %s", path, row,
                        exr_reason(rv));
    return SPT_EXIT_OK;
}

int exr_read_layers(const char *path, const char *const *required, int required_count,
                    ExrLayers *out, SptError *e)
{
    memset(out, 0, sizeof *out);
    struct stat st;
    if (stat(path, &st) != 0)
        return spt_fail(e, SPT_EXIT_INPUT, "%s: cannot open: %s", path, strerror(errno));
    if (!S_ISREG(st.st_mode))
        return spt_fail(e, SPT_EXIT_INPUT, "%s: not a regular file", path);

    /* No chunk reconstruction: a damaged file is refused, not half-repaired. */
    exr_context_initializer_t init = exr_init(EXR_CONTEXT_FLAG_DISABLE_CHUNK_RECONSTRUCTION);
    exr_context_t ctxt = NULL;
    g_exr_msg[0] = 0;
    exr_result_t rv = exr_start_read(&ctxt, path, &init);
    if (rv != EXR_ERR_SUCCESS) {
        int rc = spt_fail(e, SPT_EXIT_INPUT, "%s: not a readable OpenEXR file: %s", path,
                          exr_reason(rv));
        if (ctxt)
            exr_finish(&ctxt);
        return rc;
    }

    int rc = SPT_EXIT_OK;
    int parts = 0;
    exr_storage_t storage = EXR_STORAGE_SCANLINE;
    exr_attr_box2i_t dw;
    const exr_attr_chlist_t *chl = NULL;
    memset(&dw, 0, sizeof dw);
    if (exr_get_count(ctxt, &parts) != EXR_ERR_SUCCESS || parts != 1)
        rc = spt_fail(e, SPT_EXIT_INPUT, "%s: expected a single-part OpenEXR file, found %d parts",
                      path, parts);
    else if (exr_get_storage(ctxt, 0, &storage) != EXR_ERR_SUCCESS ||
             storage != EXR_STORAGE_SCANLINE)
        rc = spt_fail(e, SPT_EXIT_INPUT, "%s: expected a scanline OpenEXR file (not tiled or deep)",
                      path);
    else if ((rv = exr_get_data_window(ctxt, 0, &dw)) != EXR_ERR_SUCCESS ||
             (rv = exr_get_channels(ctxt, 0, &chl)) != EXR_ERR_SUCCESS || !chl)
        rc = spt_fail(e, SPT_EXIT_INPUT, "%s: damaged OpenEXR header: %s", path, exr_reason(rv));
    if (rc) {
        exr_finish(&ctxt);
        return rc;
    }

    long long w = (long long)dw.max.x - dw.min.x + 1, h = (long long)dw.max.y - dw.min.y + 1;
    if (w <= 0 || h <= 0 || w > INT_MAX / 4 || h > INT_MAX || w * h > (long long)(SIZE_MAX / 8))
        rc = spt_fail(e, SPT_EXIT_INPUT, "%s: invalid data window %lldx%lld", path, w, h);
    else if (w > SPT_EXR_READ_MAX_SIDE || h > SPT_EXR_READ_MAX_SIDE)
        rc = spt_fail(e, SPT_EXIT_INPUT, "%s: data window %lldx%lld is larger than any image "
                      "spectrace writes (%d per side)", path, w, h, SPT_EXR_READ_MAX_SIDE);
    else if (chl->num_channels <= 0 || chl->num_channels > EXR_MAX_CHANNELS)
        rc = spt_fail(e, SPT_EXIT_INPUT, "%s: unsupported channel count %d", path,
                      chl->num_channels);
    for (int c = 0; c < chl->num_channels && !rc; ++c)
        if (chl->entries[c].x_sampling != 1 || chl->entries[c].y_sampling != 1)
            rc = spt_fail(e, SPT_EXIT_INPUT, "%s: channel '%s' is subsampled (unsupported)",
                          path, chl->entries[c].name.str);
    for (int r = 0; r < required_count && !rc; ++r) {
        int found = 0;
        for (int c = 0; c < chl->num_channels && !found; ++c)
            found = !strcmp(chl->entries[c].name.str, required[r]);
        if (!found)
            rc = spt_fail(e, SPT_EXIT_INPUT, "%s: channel '%s' is missing", path, required[r]);
    }
    if (rc) {
        exr_finish(&ctxt);
        return rc;
    }

    out->width = (int)w;
    out->height = (int)h;
    out->channels = spt_calloc((size_t)chl->num_channels, sizeof *out->channels);
    for (int c = 0; c < chl->num_channels && !rc; ++c) {
        ExrChannel *ch = &out->channels[out->channel_count++];
        ch->name = spt_strdup(chl->entries[c].name.str);
        ch->type = chl->entries[c].pixel_type == EXR_PIXEL_UINT ? SPT_EXR_UINT : SPT_EXR_FLOAT;
        ch->stride = 1;
        /* Plain calloc: a damaged header may claim a huge image; that is an input
         * error, not a reason to abort. */
        ch->data = calloc((size_t)w * (size_t)h, 4);
        if (!ch->data)
            rc = spt_fail(e, SPT_EXIT_INPUT, "%s: out of memory for a %lldx%lld image", path,
                          w, h);
    }
    if (!rc)
        rc = read_attrs(path, ctxt, out, e);
    if (!rc)
        rc = read_pixels(path, ctxt, dw.min.y, out, e);
    exr_finish(&ctxt);
    if (rc)
        exr_layers_free(out);
    return rc;
}

const ExrChannel *exr_layers_channel(const ExrLayers *l, const char *name)
{
    for (int c = 0; c < l->channel_count; ++c)
        if (!strcmp(l->channels[c].name, name))
            return &l->channels[c];
    return NULL;
}

const ExrAttr *exr_layers_attr(const ExrLayers *l, const char *name, int type)
{
    for (int a = 0; a < l->attr_count; ++a)
        if (l->attrs[a].type == type && !strcmp(l->attrs[a].name, name))
            return &l->attrs[a];
    return NULL;
}
