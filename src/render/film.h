/* The film: per-pixel sums of XYZ and sample counts in double precision. Films
 * of disjoint sample ranges add up to the image of their union (film_add). */
#ifndef SPT_FILM_H
#define SPT_FILM_H

#include <stddef.h>
#include <stdint.h>

typedef struct Film {
    int width, height;
    double *xyz;   /* 3 per pixel: sums */
    double *count; /* per pixel: samples kept */
} Film;

/* Allocates a zeroed film. */
void film_init(Film *f, int width, int height);
void film_free(Film *f);

/* Adds per-pixel sums given as float4 (X, Y, Z, count) for every pixel. */
void film_add_chunk(Film *f, const float *xyzn);

/* dst += src (same size). */
void film_add(Film *dst, const Film *src);

/* Linear sRGB (3 floats per pixel, rows top to bottom) of the mean XYZ of each
 * pixel; pixels without samples are black. rgb is malloc'd by the caller. */
void film_to_linear_srgb(const Film *f, float *rgb);

/* Number of pixels whose sums, sample count or linear sRGB (film_to_linear_srgb)
 * are NaN or infinite as floats, the precision of every output and checkpoint.
 * No output may hold such a pixel: the kernels drop non-finite samples, so one is
 * an internal error. */
size_t film_nonfinite_pixels(const Film *f);

/* Smallest per-pixel sample count. */
double film_min_count(const Film *f);

#endif
