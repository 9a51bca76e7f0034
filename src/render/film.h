/* The film: per-pixel sums of XYZ and sample counts in double precision, and
 * with AOVs (--aov) the per-pixel sums the AOV layers are made of. Films of
 * disjoint sample ranges add up to the image of their union (film_add). */
#ifndef SPT_FILM_H
#define SPT_FILM_H

#include <stddef.h>
#include <stdint.h>

/* The AOV layers of --aov (a bit mask). */
#define SPT_AOV_ALBEDO 1u   /* albedo.R/G/B */
#define SPT_AOV_NORMAL 2u   /* N.X/Y/Z */
#define SPT_AOV_DEPTH 4u    /* Z */
#define SPT_AOV_POSITION 8u /* P.X/Y/Z */
#define SPT_AOV_VARIANCE 16u /* variance.R/G/B */
#define SPT_AOV_SPP 32u     /* spp */
#define SPT_AOV_ALL 63u

/* The AOV sums of a pixel, SPT_AOV_SUMS doubles in this order: the sums over
 * its kept samples of the albedo (linear sRGB), the shading normal (world), the
 * depth (along the camera's view axis), the position (world) of the first hit,
 * and the squares of the sample's linear sRGB radiance (the variance layer). The
 * kernels' per-pixel sums (kernels/integrator/wavefront.cl, k_accumulate) come as
 * SPT_AOV_CHUNK_FLOATS floats per pixel: (albedo RGB, Z), (N, 0), (P, 0),
 * (squares RGB, 0). */
#define SPT_AOV_SUMS 13
#define SPT_AOV_CHUNK_FLOATS 16
enum { SPT_AOV_S_ALBEDO = 0, SPT_AOV_S_N = 3, SPT_AOV_S_Z = 6, SPT_AOV_S_P = 7, SPT_AOV_S_SQ = 10 };

/* Spectral bands (--spectral N): N equal bands over 360-830 nm; each sample's
 * wavelength j adds L(lambda_j) / (4 pdf(lambda_j)) to the band containing
 * lambda_j (the weight the XYZ film gives it, without the colour matching
 * function), so a band's sum over the samples, over their number and the
 * band's width, is the mean spectral radiance in the band. */
#define SPT_SPECTRAL_MIN_NM 360.0
#define SPT_SPECTRAL_MAX_NM 830.0

typedef struct Film {
    int width, height;
    double *xyz;   /* 3 per pixel: sums */
    double *count; /* per pixel: samples kept */
    double *aov;   /* SPT_AOV_SUMS per pixel, or NULL: no AOVs */
    int bands;     /* spectral bands (0: none) */
    double *spec;  /* bands per pixel: sums */
} Film;

/* Allocates a zeroed film; film_init_aov with aov != 0 also keeps the AOV sums. */
void film_init(Film *f, int width, int height);
void film_init_aov(Film *f, int width, int height, int aov);
/* Also keeps bands spectral band sums per pixel (0: none). */
void film_init_full(Film *f, int width, int height, int aov, int bands);
/* The bytes film_init_full allocates for those arguments. */
size_t film_bytes(int width, int height, int aov, int bands);
void film_free(Film *f);

/* Zeroes every sum and count. */
void film_clear(Film *f);

/* Adds per-pixel sums given as float4 (X, Y, Z, count) for every pixel, and
 * (when the film keeps AOVs) SPT_AOV_CHUNK_FLOATS floats of AOV sums per pixel,
 * and (with bands) f->bands floats of band sums per pixel. */
void film_add_chunk(Film *f, const float *xyzn, const float *aov, const float *spec);

/* The mean spectral radiance of every band of every pixel (bands floats per
 * pixel): its sum over the pixel's samples and the band's width in nm. */
void film_spectral_layer(const Film *f, float *out);

/* dst += src (same size; the AOV sums when both keep them). */
void film_add(Film *dst, const Film *src);

/* The film as one array of doubles (for messages between processes):
 * film_doubles values, packed and unpacked in the same order. */
size_t film_doubles(const Film *f);
void film_pack(const Film *f, double *out);
void film_unpack(Film *f, const double *in);

/* Linear sRGB (3 floats per pixel, rows top to bottom) of the mean XYZ of each
 * pixel; pixels without samples are black. rgb is malloc'd by the caller. */
void film_to_linear_srgb(const Film *f, float *rgb);

/* The AOV layer `which` (one SPT_AOV_* bit) of every pixel, as `channels` floats
 * per pixel (3 for albedo, N, P and variance, 1 for Z and spp): the mean over
 * the pixel's samples (N not renormalised; misses count as 0), the variance of
 * the pixel's estimate (the sample variance of its samples' linear sRGB over
 * their number; 0 below 2 samples), or the sample count. Returns channels; out
 * is malloc'd by the caller with room for 3 floats per pixel. The film must keep
 * AOVs (except for spp). */
int film_aov_layer(const Film *f, unsigned which, float *out);

/* Parses a --aov list ("albedo,N,Z,P,variance,spp" in any order, or "all";
 * the names also as normal, depth, position; case-insensitive) into a mask.
 * Returns 0, or -1 for an empty list or an unknown name. */
int film_aov_parse(const char *list, unsigned *mask);

/* Number of pixels whose sums, sample count or linear sRGB (film_to_linear_srgb)
 * are NaN or infinite as floats, the precision of every output and checkpoint;
 * with AOVs, an AOV sum too. No output may hold such a pixel: the kernels drop
 * non-finite samples, so one is an internal error. */
size_t film_nonfinite_pixels(const Film *f);

/* The same, leaving out the sums of squares of the variance layer: they
 * overflow float where a pixel's radiance passes about 1e19 (docs/limits.md)
 * while the image and the other AOV sums are still finite, and only the
 * variance layer and a checkpoint use them. */
size_t film_nonfinite_except_squares(const Film *f);

/* How many pixels with samples have a mean linear sRGB whose square is not 0
 * yet below float's normal range (1.2e-38: a radiance under about 1.1e-19):
 * the kernels sum such squares in float, as subnormals that keep few bits or
 * that a device may flush to 0, so their variance layer is inexact
 * (docs/limits.md). */
size_t film_subnormal_square_pixels(const Film *f);

/* Smallest per-pixel sample count. */
double film_min_count(const Film *f);

#endif
