#include "render/film.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "color/spd.h"
#include "core/util.h"

void film_init(Film *f, int width, int height)
{
    size_t n = (size_t)width * (size_t)height;
    f->width = width;
    f->height = height;
    f->xyz = spt_calloc(3 * n, sizeof(double));
    f->count = spt_calloc(n, sizeof(double));
}

void film_free(Film *f)
{
    free(f->xyz);
    free(f->count);
    memset(f, 0, sizeof *f);
}

void film_add_chunk(Film *f, const float *xyzn)
{
    size_t n = (size_t)f->width * (size_t)f->height;
    for (size_t i = 0; i < n; i++) {
        f->xyz[3 * i + 0] += xyzn[4 * i + 0];
        f->xyz[3 * i + 1] += xyzn[4 * i + 1];
        f->xyz[3 * i + 2] += xyzn[4 * i + 2];
        f->count[i] += xyzn[4 * i + 3];
    }
}

void film_add(Film *dst, const Film *src)
{
    size_t n = (size_t)dst->width * (size_t)dst->height;
    for (size_t i = 0; i < 3 * n; i++)
        dst->xyz[i] += src->xyz[i];
    for (size_t i = 0; i < n; i++)
        dst->count[i] += src->count[i];
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

size_t film_nonfinite_pixels(const Film *f)
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
        bad += !ok;
    }
    return bad;
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
