/* Image output: dispatch, pre-flight checks, display transforms, atomic writes
 * (contracts in src/io/image_out.h). */
#include "io/image_out.h"

#include <errno.h>
#include <fcntl.h>
#include <inttypes.h>
#include <limits.h>
#include <math.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include <unistd.h>

#include "io/atomic_file.h"
#include "io/exr.h"
#include "io/image_io.h"
#include "io/srgb.h"

enum { FMT_NONE, FMT_EXR, FMT_HDR, FMT_TIFF, FMT_PNG, FMT_JPEG };

/* The format named by path's extension (case-insensitive), or FMT_NONE. */
static int format_of(const char *path)
{
    const char *slash = strrchr(path, '/');
    const char *base = slash ? slash + 1 : path;
    const char *dot = strrchr(base, '.');
    if (!dot || dot == base)
        return FMT_NONE;
    static const struct { const char *ext; int fmt; } known[] = {
        {"exr", FMT_EXR},   {"hdr", FMT_HDR},  {"tif", FMT_TIFF}, {"tiff", FMT_TIFF},
        {"png", FMT_PNG},   {"jpg", FMT_JPEG}, {"jpeg", FMT_JPEG},
    };
    for (size_t i = 0; i < sizeof known / sizeof known[0]; ++i)
        if (!strcasecmp(dot + 1, known[i].ext))
            return known[i].fmt;
    return FMT_NONE;
}

int image_format_known(const char *path, int *is_display)
{
    int f = path ? format_of(path) : FMT_NONE;
    if (is_display)
        *is_display = f == FMT_PNG || f == FMT_JPEG;
    return f != FMT_NONE;
}

static int unknown_format(const char *path, SptError *e)
{
    return spt_fail(e, SPT_EXIT_USAGE,
                    "%s: unknown image format (use .exr, .png, .jpg, .jpeg, .tif, .tiff or .hdr)",
                    path);
}

int image_meta_add(ImageMeta *meta, const char *key, const char *value)
{
    if (meta->extra_count >= SPT_IMAGE_META_MAX_EXTRA)
        return -1;
    meta->extra[meta->extra_count].key = key;
    meta->extra[meta->extra_count].value = value;
    meta->extra_count++;
    return 0;
}

/* ---------------------------------------------------------------------------
 * Display transforms */

void image_tonemap_neutral(const float in[3], float out[3])
{
    /* Khronos PBR Neutral tone mapper, from its specification (Khronos Group, 2024,
     * https://github.com/KhronosGroup/ToneMapping/blob/main/PBR_Neutral/README.md):
     *   F90 = 0.04, Ks = 0.8 - F90, Kd = 0.15, x = min(R, G, B)
     *   f = x - x^2 / (4 F90) if x <= 2 F90, else F90
     *   p = max(R - f, G - f, B - f)
     *   pn = 1 - (1 - Ks)^2 / (p + 1 - 2 Ks)
     *   g = 1 / (Kd (p - pn) + 1)
     *   out = c - f                                  if p <= Ks
     *         (c - f) (pn / p) g + [pn, pn, pn] (1 - g)  otherwise.
     * Computed in double so the float result is the correctly rounded value. */
    const double f90 = 0.04, ks = 0.8 - f90, kd = 0.15;
    double c[3];
    for (int i = 0; i < 3; ++i)
        c[i] = in[i] > 0.0f ? (double)in[i] : 0.0; /* also maps NaN to 0 */
    if (isinf(c[0]) || isinf(c[1]) || isinf(c[2])) {
        out[0] = out[1] = out[2] = 1.0f; /* p -> inf: pn -> 1, g -> 0 */
        return;
    }
    double x = fmin(c[0], fmin(c[1], c[2]));
    double f = x <= 2.0 * f90 ? x - x * x / (4.0 * f90) : f90;
    for (int i = 0; i < 3; ++i)
        c[i] -= f;
    double p = fmax(c[0], fmax(c[1], c[2]));
    if (p <= ks) {
        for (int i = 0; i < 3; ++i)
            out[i] = (float)c[i];
        return;
    }
    double pn = 1.0 - (1.0 - ks) * (1.0 - ks) / (p + 1.0 - 2.0 * ks);
    double g = 1.0 / (kd * (p - pn) + 1.0);
    for (int i = 0; i < 3; ++i)
        out[i] = (float)(c[i] * (pn / p) * g + pn * (1.0 - g));
}

/* 2^exposure_ev of disp (1 for NULL). */
static double exposure_scale(const DisplayOptions *disp)
{
    return disp ? exp2((double)disp->exposure_ev) : 1.0;
}

static void display_pixel_scaled(const float in[3], double scale, int tonemap, uint8_t out[3])
{
    float v[3];
    for (int i = 0; i < 3; ++i) {
        double x = isnan(in[i]) ? 0.0 : (double)in[i] * scale;
        v[i] = isnan(x) ? 0.0f : (float)x; /* inf * 0 when the scale underflows */
    }
    if (tonemap == SPT_TONEMAP_NEUTRAL)
        image_tonemap_neutral(v, v);
    for (int i = 0; i < 3; ++i)
        out[i] = (uint8_t)srgb_to_8bit((double)v[i]);
}

void image_display_pixel(const float in[3], const DisplayOptions *disp, uint8_t out[3])
{
    display_pixel_scaled(in, exposure_scale(disp), disp ? disp->tonemap : SPT_TONEMAP_NONE,
                         out);
}

int image_tonemap_parse(const char *name, int *tonemap)
{
    if (name && !strcasecmp(name, "none")) {
        *tonemap = SPT_TONEMAP_NONE;
        return 0;
    }
    if (name && !strcasecmp(name, "neutral")) {
        *tonemap = SPT_TONEMAP_NEUTRAL;
        return 0;
    }
    return -1;
}

int image_output_check(const char *path, SptError *e)
{
    if (!path || !path[0])
        return spt_fail(e, SPT_EXIT_USAGE, "no output file name given");
    if (!image_format_known(path, NULL))
        return unknown_format(path, e);
    int rc = atomic_path_check(path, e);
    if (rc)
        return rc;
    char dir[PATH_MAX];
    const char *base;
    atomic_split_path(path, dir, sizeof dir, &base);
    struct stat st;
    if (stat(dir, &st) != 0) {
        if (errno == ENOENT)
            return spt_fail(e, SPT_EXIT_OUTPUT, "%s: folder '%s' does not exist", path, dir);
        if (errno == ENOTDIR)
            return spt_fail(e, SPT_EXIT_OUTPUT, "%s: '%s' is not a folder (a part of it is a file)",
                            path, dir);
        return spt_fail(e, SPT_EXIT_OUTPUT, "%s: folder '%s': %s", path, dir, strerror(errno));
    }
    if (!S_ISDIR(st.st_mode))
        return spt_fail(e, SPT_EXIT_OUTPUT, "%s: '%s' is not a folder", path, dir);
    if (stat(path, &st) == 0 && S_ISDIR(st.st_mode))
        return spt_fail(e, SPT_EXIT_OUTPUT, "%s: is a folder", path);
    /* Every format but EXR is written through OpenImageIO's library, which is
     * loaded now, so that a missing one fails before any rendering. */
    if (format_of(path) != FMT_EXR && (rc = image_io_load(path, e)))
        return rc;
    char tmp[PATH_MAX + 64];
    rc = atomic_temp_create(path, tmp, sizeof tmp, e);
    if (rc)
        return rc;
    unlink(tmp);
    return SPT_EXIT_OK;
}

/* ---------------------------------------------------------------------------
 * Writing */

/* One line describing meta, for formats that only keep a description. */
static void meta_summary(const ImageMeta *meta, char *out, size_t n)
{
    int len = snprintf(out, n, "spectrace: %d spp, %.3f s, seed %" PRIu32, meta->spp,
                       meta->render_seconds, meta->seed);
    if (meta->device && len >= 0 && (size_t)len < n)
        len += snprintf(out + len, n - (size_t)len, ", device %s", meta->device);
    if (meta->scene && len >= 0 && (size_t)len < n)
        len += snprintf(out + len, n - (size_t)len, ", scene %s", meta->scene);
    for (int i = 0; i < meta->extra_count && len >= 0 && (size_t)len < n; ++i)
        if (meta->extra[i].key && meta->extra[i].value)
            len += snprintf(out + len, n - (size_t)len, ", %s %s", meta->extra[i].key,
                            meta->extra[i].value);
}

/* Storage for the text forms that meta_pairs makes. */
typedef struct MetaText {
    char names[SPT_IMAGE_META_MAX_EXTRA][128];
    char spp[32], seconds[32], seed[32];
} MetaText;

/* The metadata as "spectrace:<name>" text pairs; names and values point into store
 * or meta. Returns the count (at most 5 + SPT_IMAGE_META_MAX_EXTRA). */

static int meta_pairs(const ImageMeta *meta, MetaText *store, const char **names,
                      const char **values)
{
    int n = 0;
    snprintf(store->spp, sizeof store->spp, "%d", meta->spp);
    snprintf(store->seconds, sizeof store->seconds, "%.17g", meta->render_seconds);
    snprintf(store->seed, sizeof store->seed, "%" PRIu32, meta->seed);
    names[n] = "spectrace:spp", values[n++] = store->spp;
    names[n] = "spectrace:renderSeconds", values[n++] = store->seconds;
    names[n] = "spectrace:seed", values[n++] = store->seed;
    if (meta->device)
        names[n] = "spectrace:device", values[n++] = meta->device;
    if (meta->scene)
        names[n] = "spectrace:scene", values[n++] = meta->scene;
    for (int i = 0; i < meta->extra_count && i < SPT_IMAGE_META_MAX_EXTRA; ++i) {
        if (!meta->extra[i].key || !meta->extra[i].value)
            continue;
        snprintf(store->names[i], sizeof store->names[i], "spectrace:%s", meta->extra[i].key);
        names[n] = store->names[i], values[n++] = meta->extra[i].value;
    }
    return n;
}

enum { META_MAX = 5 + SPT_IMAGE_META_MAX_EXTRA };

static int write_exr(const char *path, const float *rgb, int width, int height,
                     const ImageMeta *meta, SptError *e)
{
    ExrAttr attrs[META_MAX + 8];
    int n = 0;
    MetaText store;
    for (int i = 0; meta && i < meta->exr_attr_count && i < 8; i++)
        attrs[n++] = meta->exr_attrs[i];
    if (meta) {
        const char *names[META_MAX], *values[META_MAX];
        int count = meta_pairs(meta, &store, names, values);
        for (int i = 0; i < count; ++i) {
            ExrAttr a = {names[i], SPT_EXR_ATTR_STRING, values[i], 0, 0.0};
            /* Numbers as numbers where EXR has the type. */
            if (!strcmp(names[i], "spectrace:spp"))
                a.type = SPT_EXR_ATTR_INT, a.i = meta->spp;
            else if (!strcmp(names[i], "spectrace:renderSeconds"))
                a.type = SPT_EXR_ATTR_DOUBLE, a.d = meta->render_seconds;
            attrs[n++] = a;
        }
    }
    return exr_write_rgb_layers(path, rgb, width, height, meta ? meta->layers : NULL,
                                meta ? meta->layer_count : 0, attrs, n, e);
}

/* Encodes through OpenImageIO in memory, then writes the bytes atomically. */
static int write_oiio(const char *path, int fmt, const float *rgb, int width, int height,
                      const ImageMeta *meta, const DisplayOptions *disp, SptError *e)
{
    size_t count = (size_t)width * (size_t)height;
    const void *pixels = rgb;
    uint8_t *bytes = NULL;
    int display = fmt == FMT_PNG || fmt == FMT_JPEG;
    if (display) {
        bytes = spt_malloc(count * 3);
        double scale = exposure_scale(disp);
        int tonemap = disp ? disp->tonemap : SPT_TONEMAP_NONE;
        for (size_t i = 0; i < count; ++i)
            display_pixel_scaled(rgb + 3 * i, scale, tonemap, bytes + 3 * i);
        pixels = bytes;
    }

    ImageIoAttr attrs[4 + META_MAX];
    int n = 0;
    char summary[1024];
    MetaText store;
    attrs[n++] = (ImageIoAttr){"Software", "spectrace"};
    attrs[n++] = (ImageIoAttr){"oiio:ColorSpace", display ? "sRGB" : "Linear"};
    if (fmt == FMT_JPEG)
        attrs[n++] = (ImageIoAttr){"Compression", "jpeg:95"};
    if (fmt == FMT_TIFF)
        attrs[n++] = (ImageIoAttr){"Compression", "zip"};
    if (meta) {
        meta_summary(meta, summary, sizeof summary);
        attrs[n++] = (ImageIoAttr){"ImageDescription", summary};
        if (fmt == FMT_PNG) { /* PNG keeps free text chunks */
            const char *names[META_MAX], *values[META_MAX];
            int count_m = meta_pairs(meta, &store, names, values);
            for (int i = 0; i < count_m && n < (int)(sizeof attrs / sizeof attrs[0]); ++i)
                attrs[n++] = (ImageIoAttr){names[i], values[i]};
        }
    }

    unsigned char *file = NULL;
    size_t file_size = 0;
    int rc = image_io_encode(path, pixels, display ? SPT_IMAGE_IO_U8 : SPT_IMAGE_IO_F32, width,
                             height, 3, attrs, n, &file, &file_size, e);
    if (!rc)
        rc = atomic_write_bytes(path, file, file_size, e);
    free(file);
    free(bytes);
    return rc;
}

int image_output_check_size(const char *path, int width, int height, SptError *e)
{
    int fmt = path ? format_of(path) : FMT_NONE;
    if (fmt == FMT_NONE)
        return unknown_format(path ? path : "(null)", e);
    if (width <= 0 || height <= 0 || (size_t)width > SIZE_MAX / 12 / (size_t)height)
        return spt_fail(e, SPT_EXIT_OUTPUT, "%s: invalid image size %dx%d", path, width,
                        height);
    /* libjpeg's limit; beyond it libjpeg ends the process instead of failing. */
    if (fmt == FMT_JPEG && (width > 65500 || height > 65500))
        return spt_fail(e, SPT_EXIT_OUTPUT,
                        "%s: %dx%d is too large for JPEG (at most 65500 pixels per side)",
                        path, width, height);
    return SPT_EXIT_OK;
}

int image_write(const char *path, const float *rgb, int width, int height,
                const ImageMeta *meta, const DisplayOptions *disp, SptError *e)
{
    if (!path || !path[0])
        return spt_fail(e, SPT_EXIT_USAGE, "no output file name given");
    int fmt = format_of(path);
    if (fmt == FMT_NONE)
        return unknown_format(path, e);
    int rc = image_output_check_size(path, width, height, e);
    if (rc)
        return rc;
    if (!rgb)
        return spt_fail(e, SPT_EXIT_OUTPUT, "%s: no pixels to write", path);
    if (fmt == FMT_EXR)
        return write_exr(path, rgb, width, height, meta, e);
    return write_oiio(path, fmt, rgb, width, height, meta, disp, e);
}
