/* The film: per-pixel sums of XYZ and sample counts in double precision. Films
 * of disjoint sample ranges add up to the image of their union (film_add). */
#ifndef SPT_FILM_H
#define SPT_FILM_H

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

/* Smallest per-pixel sample count. */
double film_min_count(const Film *f);

#endif
