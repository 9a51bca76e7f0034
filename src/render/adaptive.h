/* Adaptive sampling (`spectrace render --adaptive`, on by default with
 * --time): every pixel takes the first SPT_ADAPTIVE_FIRST samples, then each
 * doubling of the sample indices, [c, 2c), goes only to the pixels where c
 * more samples would lower the image's relative error the most
 * (docs/architecture.md, "Adaptive sampling"). A pixel's samples are always
 * the first of its own sequence (kernels/util/render_types.h, pixel_lag),
 * and the choice is a function of the film's sums at c, so the image is a
 * function of the samples done. */
#ifndef SPT_ADAPTIVE_H
#define SPT_ADAPTIVE_H

#include <stdint.h>

/* Samples every pixel takes before the first choice. */
#define SPT_ADAPTIVE_FIRST 16u
/* A pixel takes a segment when its expected gain is at least this share of
 * the median pixel's (adaptive.c). */
#define SPT_ADAPTIVE_SHARE 0.5
/* The error estimate is averaged over the (2 R + 1)^2 pixels around. */
#define SPT_ADAPTIVE_RADIUS 2

/* The mask of segment [c, 2c) of the sample indices into mask (npix words,
 * 1: the pixel renders those samples, 0: it does not), from each pixel's sums
 * so far: xyz (3 per pixel, XYZ), count (its samples kept) and sq (3 per
 * pixel, the sums of the squares of its samples' linear sRGB), the error
 * of each weighed with rgb and sq over the image's mean level. Returns how
 * many pixels it keeps. */
uint32_t adaptive_mask(uint32_t width, uint32_t height, const double *xyz, const double *count,
                       const double *sq, uint32_t c, uint32_t *mask);

/* A pixel's expected relative error per sample (what adaptive_mask weighs):
 * the mean over linear sRGB channels of the samples' variance over
 * (mean^2 + 0.01). rgb_sum and sq are sums over n samples. */
double adaptive_pixel_error(const double rgb_sum[3], const double sq[3], double n);

#endif
