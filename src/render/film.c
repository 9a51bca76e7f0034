#include "render/film.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "color/spd.h"
#include "core/util.h"
#include "render/render_options.h"

void film_init(Film *f, int width, int height)
{
    film_init_aov(f, width, height, 0);
}

void film_init_aov(Film *f, int width, int height, int aov)
{
    film_init_full(f, width, height, aov, 0);
}

/* The doubles per pixel of each of a film's arrays: XYZ, count, AOV sums,
 * bands (film_init_full allocates, film_bytes counts). */
static void film_per_pixel(int aov, int bands, size_t k[4])
{
    k[0] = 3;
    k[1] = 1;
    k[2] = aov ? SPT_AOV_SUMS : 0;
    k[3] = bands > 0 ? (size_t)bands : 0;
}

size_t film_bytes(int width, int height, int aov, int bands)
{
    size_t k[4];
    film_per_pixel(aov, bands, k);
    return (size_t)width * (size_t)height * (k[0] + k[1] + k[2] + k[3]) * sizeof(double);
}

void film_init_full(Film *f, int width, int height, int aov, int bands)
{
    size_t n = (size_t)width * (size_t)height, k[4];
    film_per_pixel(aov, bands, k);
    f->width = width;
    f->height = height;
    f->xyz = spt_calloc(k[0] * n, sizeof(double));
    f->count = spt_calloc(k[1] * n, sizeof(double));
    f->aov = k[2] ? spt_calloc(k[2] * n, sizeof(double)) : NULL;
    f->bands = (int)k[3];
    f->spec = k[3] ? spt_calloc(k[3] * n, sizeof(double)) : NULL;
}

void film_free(Film *f)
{
    free(f->xyz);
    free(f->count);
    free(f->aov);
    free(f->spec);
    memset(f, 0, sizeof *f);
}

void film_clear(Film *f)
{
    size_t n = (size_t)f->width * (size_t)f->height;
    memset(f->xyz, 0, 3 * n * sizeof(double));
    memset(f->count, 0, n * sizeof(double));
    if (f->aov)
        memset(f->aov, 0, SPT_AOV_SUMS * n * sizeof(double));
    if (f->spec)
        memset(f->spec, 0, (size_t)f->bands * n * sizeof(double));
}

void film_add_chunk(Film *f, const float *xyzn, const float *aov, const float *spec)
{
    size_t n = (size_t)f->width * (size_t)f->height;
    for (size_t i = 0; i < n; i++) {
        f->xyz[3 * i + 0] += xyzn[4 * i + 0];
        f->xyz[3 * i + 1] += xyzn[4 * i + 1];
        f->xyz[3 * i + 2] += xyzn[4 * i + 2];
        f->count[i] += xyzn[4 * i + 3];
    }
    if (f->spec && spec)
        for (size_t i = 0; i < (size_t)f->bands * n; i++)
            f->spec[i] += spec[i];
    if (!f->aov || !aov)
        return;
    for (size_t i = 0; i < n; i++) {
        const float *a = aov + SPT_AOV_CHUNK_FLOATS * i;
        double *s = f->aov + SPT_AOV_SUMS * i;
        for (int c = 0; c < 3; c++) {
            s[SPT_AOV_S_ALBEDO + c] += a[c];
            s[SPT_AOV_S_N + c] += a[4 + c];
            s[SPT_AOV_S_P + c] += a[8 + c];
            s[SPT_AOV_S_SQ + c] += a[12 + c];
        }
        s[SPT_AOV_S_Z] += a[3];
    }
}

void film_add(Film *dst, const Film *src)
{
    size_t n = (size_t)dst->width * (size_t)dst->height;
    for (size_t i = 0; i < 3 * n; i++)
        dst->xyz[i] += src->xyz[i];
    for (size_t i = 0; i < n; i++)
        dst->count[i] += src->count[i];
    if (dst->aov && src->aov)
        for (size_t i = 0; i < SPT_AOV_SUMS * n; i++)
            dst->aov[i] += src->aov[i];
    if (dst->spec && src->spec && dst->bands == src->bands)
        for (size_t i = 0; i < (size_t)dst->bands * n; i++)
            dst->spec[i] += src->spec[i];
}

void film_spectral_layer(const Film *f, float *out)
{
    size_t n = (size_t)f->width * (size_t)f->height;
    double width = (SPT_SPECTRAL_MAX_NM - SPT_SPECTRAL_MIN_NM) / f->bands;
    for (size_t i = 0; i < n; i++)
        for (int b = 0; b < f->bands; b++) {
            size_t k = i * (size_t)f->bands + (size_t)b;
            out[k] = f->count[i] > 0 ? (float)(f->spec[k] / (f->count[i] * width)) : 0.0f;
        }
}

size_t film_doubles(const Film *f)
{
    size_t n = (size_t)f->width * (size_t)f->height;
    return (4 + (f->aov ? SPT_AOV_SUMS : 0) + (size_t)f->bands) * n;
}

void film_pack(const Film *f, double *out)
{
    size_t n = (size_t)f->width * (size_t)f->height;
    memcpy(out, f->xyz, 3 * n * sizeof(double));
    memcpy(out + 3 * n, f->count, n * sizeof(double));
    if (f->aov)
        memcpy(out + 4 * n, f->aov, SPT_AOV_SUMS * n * sizeof(double));
    if (f->spec)
        memcpy(out + (4 + (f->aov ? SPT_AOV_SUMS : 0)) * n, f->spec, (size_t)f->bands * n * sizeof(double));
}

void film_unpack(Film *f, const double *in)
{
    size_t n = (size_t)f->width * (size_t)f->height;
    memcpy(f->xyz, in, 3 * n * sizeof(double));
    memcpy(f->count, in + 3 * n, n * sizeof(double));
    if (f->aov)
        memcpy(f->aov, in + 4 * n, SPT_AOV_SUMS * n * sizeof(double));
    if (f->spec)
        memcpy(f->spec, in + (4 + (f->aov ? SPT_AOV_SUMS : 0)) * n, (size_t)f->bands * n * sizeof(double));
}

int film_aov_layer(const Film *f, unsigned which, float *out)
{
    size_t n = (size_t)f->width * (size_t)f->height;
    int channels = which == SPT_AOV_DEPTH || which == SPT_AOV_SPP ? 1 : 3;
    int first = which == SPT_AOV_ALBEDO ? SPT_AOV_S_ALBEDO
                : which == SPT_AOV_NORMAL ? SPT_AOV_S_N
                : which == SPT_AOV_DEPTH ? SPT_AOV_S_Z
                : which == SPT_AOV_POSITION ? SPT_AOV_S_P : 0;
    for (size_t i = 0; i < n; i++) {
        double c = f->count[i];
        if (which == SPT_AOV_SPP) {
            out[i] = (float)c;
            continue;
        }
        const double *s = f->aov + SPT_AOV_SUMS * i;
        if (which == SPT_AOV_VARIANCE) {
            /* The sample variance of the pixel's samples, over their number. */
            double xyz[3] = {0, 0, 0}, mean[3] = {0, 0, 0};
            if (c > 0) {
                for (int k = 0; k < 3; k++)
                    xyz[k] = f->xyz[3 * i + k] / c;
                xyz_to_linear_srgb(xyz, mean);
            }
            for (int k = 0; k < 3; k++) {
                double v = c >= 2 ? (s[SPT_AOV_S_SQ + k] - c * mean[k] * mean[k]) / ((c - 1) * c) : 0.0;
                out[3 * i + k] = (float)(v > 0 ? v : 0.0);
            }
            continue;
        }
        for (int k = 0; k < channels; k++)
            out[channels * i + k] = c > 0 ? (float)(s[first + k] / c) : 0.0f;
    }
    return channels;
}

int film_aov_parse(const char *list, unsigned *mask)
{
    /* The layers' names (bit k of the mask) and the other words for them. */
    static const char *const layers[] = SPT_AOV_NAMES;
    static const struct {
        const char *name;
        unsigned bit;
    } names[] = {{"normal", SPT_AOV_NORMAL}, {"depth", SPT_AOV_DEPTH},
                 {"position", SPT_AOV_POSITION}, {"all", SPT_AOV_ALL}};
    unsigned m = 0;
    const char *p = list;
    for (;;) {
        const char *end = strchr(p, ',');
        size_t len = end ? (size_t)(end - p) : strlen(p);
        unsigned bit = 0;
        for (unsigned k = 0; k < sizeof layers / sizeof layers[0] && !bit; k++)
            if (strlen(layers[k]) == len && !strncasecmp(p, layers[k], len))
                bit = 1u << k;
        for (size_t k = 0; k < sizeof names / sizeof names[0] && !bit; k++)
            if (strlen(names[k].name) == len && !strncasecmp(p, names[k].name, len))
                bit = names[k].bit;
        if (!bit)
            return -1;
        m |= bit;
        if (!end)
            break;
        p = end + 1;
    }
    *mask = m;
    return 0;
}

void film_to_linear_srgb(const Film *f, float *rgb)
{
    size_t n = (size_t)f->width * (size_t)f->height;
    for (size_t i = 0; i < n; i++) {
        double c = f->count[i];
        double xyz[3] = {0, 0, 0}, out[3];
        if (c > 0) {
            xyz[0] = f->xyz[3 * i + 0] / c;
            xyz[1] = f->xyz[3 * i + 1] / c;
            xyz[2] = f->xyz[3 * i + 2] / c;
        }
        xyz_to_linear_srgb(xyz, out);
        rgb[3 * i + 0] = (float)out[0];
        rgb[3 * i + 1] = (float)out[1];
        rgb[3 * i + 2] = (float)out[2];
    }
}

/* film_nonfinite_pixels, with or without the sums of squares. */
static size_t nonfinite(const Film *f, int squares)
{
    size_t n = (size_t)f->width * (size_t)f->height, bad = 0;
    for (size_t i = 0; i < n; i++) {
        const double *s = f->xyz + 3 * i;
        double c = f->count[i];
        /* As floats: the precision of the outputs and checkpoints. */
        int ok = isfinite((float)s[0]) && isfinite((float)s[1]) && isfinite((float)s[2]) &&
                 isfinite((float)c);
        if (ok && c > 0) {
            double xyz[3] = {s[0] / c, s[1] / c, s[2] / c}, rgb[3];
            xyz_to_linear_srgb(xyz, rgb);
            for (int k = 0; k < 3; k++)
                ok &= isfinite((float)rgb[k]);
        }
        if (f->aov)
            for (int k = 0; k < SPT_AOV_SUMS; k++)
                ok &= isfinite((float)f->aov[SPT_AOV_SUMS * i + k]) ||
                      (!squares && k >= SPT_AOV_S_SQ && k < SPT_AOV_S_SQ + 3);
        for (int k = 0; k < f->bands; k++)
            ok &= isfinite((float)f->spec[(size_t)f->bands * i + (size_t)k]);
        bad += !ok;
    }
    return bad;
}

size_t film_nonfinite_pixels(const Film *f)
{
    return nonfinite(f, 1);
}

size_t film_nonfinite_except_squares(const Film *f)
{
    return nonfinite(f, 0);
}

double film_min_count(const Film *f)
{
    size_t n = (size_t)f->width * (size_t)f->height;
    double m = n ? f->count[0] : 0;
    for (size_t i = 1; i < n; i++)
        if (f->count[i] < m)
            m = f->count[i];
    return m;
}

size_t film_subnormal_square_pixels(const Film *f)
{
    size_t n = (size_t)f->width * (size_t)f->height, dim = 0;
    for (size_t i = 0; i < n; i++) {
        double c = f->count[i], xyz[3], rgb[3], m2 = 0;
        if (!(c > 0))
            continue;
        for (int k = 0; k < 3; k++)
            xyz[k] = f->xyz[3 * i + k] / c;
        xyz_to_linear_srgb(xyz, rgb);
        for (int k = 0; k < 3; k++)
            m2 = fmax(m2, rgb[k] * rgb[k]);
        dim += m2 > 0 && m2 < FLT_MIN;
    }
    return dim;
}
