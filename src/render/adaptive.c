/* Adaptive sampling: which pixels render the next doubling of the samples
 * (src/render/adaptive.h). */
#include "render/adaptive.h"

#include <math.h>
#include <stdlib.h>

#include "color/spd.h"
#include "core/util.h"

double adaptive_pixel_error(const double rgb_sum[3], const double sq[3], double n)
{
    if (n < 2.0)
        return 0.0;
    double err = 0.0;
    for (int k = 0; k < 3; k++) {
        double m = rgb_sum[k] / n;
        double var = (sq[k] / n - m * m) * n / (n - 1.0);
        if (var > 0.0)
            err += var / (m * m + 0.01);
    }
    return err / 3.0;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* Adding c samples to a pixel of n samples and error e per sample lowers its
 * expected squared error from e / n to e / (n + c): by e c / (n (n + c)). The
 * pixels whose drop is at least SPT_ADAPTIVE_SHARE of the median of the
 * non-zero drops take the segment: with every pixel alike all of them do
 * (their estimates' noise apart), and a pixel left out gains four times on
 * the others by the next choice, as their n doubled. A pixel whose samples
 * (and its neighbours') all agreed gains nothing and is left out; one with
 * fewer than 2 samples kept (no estimate) always takes the segment, and when
 * no pixel would gain, every pixel does. */
uint32_t adaptive_mask(uint32_t width, uint32_t height, const double *xyz, const double *count,
                       const double *sq, uint32_t c, uint32_t *mask)
{
    size_t npix = (size_t)width * height;
    double *err = spt_malloc(npix * sizeof(double));
    double *gain = spt_malloc(npix * sizeof(double));
    double *sorted = spt_malloc(npix * sizeof(double));
    /* The error is weighed relative to the image's level, its mean linear
     * sRGB over the pixels with samples, so that a scene lit 1e20 or 1e-20
     * times as brightly spends its samples alike (docs/limits.md). */
    double level = 0.0, lit = 0.0;
    for (size_t i = 0; i < npix; i++) {
        double rgb[3];
        if (count[i] <= 0.0)
            continue;
        xyz_to_linear_srgb(xyz + 3u * i, rgb);
        level += (fabs(rgb[0]) + fabs(rgb[1]) + fabs(rgb[2])) / (3.0 * count[i]);
        lit += 1.0;
    }
    level = lit > 0.0 ? level / lit : 0.0;
    if (!(level > 0.0) || !isfinite(level))
        level = 1.0;
    for (size_t i = 0; i < npix; i++) {
        double rgb[3], q[3];
        xyz_to_linear_srgb(xyz + 3u * i, rgb);
        for (int k = 0; k < 3; k++) {
            rgb[k] /= level;
            q[k] = sq[3u * i + k] / level / level;
        }
        err[i] = adaptive_pixel_error(rgb, q, count[i]);
    }
    /* Each pixel's error per sample, estimated from a few samples, is noisy;
     * its mean over the pixels within SPT_ADAPTIVE_RADIUS is not (the error
     * varies smoothly but at edges). */
    const int R = SPT_ADAPTIVE_RADIUS;
    uint32_t m = 0;
    for (uint32_t y = 0; y < height; y++)
        for (uint32_t x = 0; x < width; x++) {
            size_t i = (size_t)y * width + x;
            double n = count[i], e = 0.0, k = 0.0;
            for (int dy = -R; dy <= R; dy++)
                for (int dx = -R; dx <= R; dx++) {
                    long yy = (long)y + dy, xx = (long)x + dx;
                    if (yy < 0 || xx < 0 || yy >= (long)height || xx >= (long)width)
                        continue;
                    e += err[(size_t)yy * width + (size_t)xx];
                    k += 1.0;
                }
            e /= k;
            gain[i] = n >= 2.0 ? e * c / (n * (n + c)) : -1.0;
            if (gain[i] > 0.0)
                sorted[m++] = gain[i];
        }
    double median = 0.0;
    if (m) {
        qsort(sorted, m, sizeof(double), cmp_double);
        median = m % 2 ? sorted[m / 2] : 0.5 * (sorted[m / 2 - 1] + sorted[m / 2]);
    }
    uint32_t kept = 0;
    for (size_t i = 0; i < npix; i++) {
        mask[i] = !m || gain[i] < 0.0 || (gain[i] > 0.0 && gain[i] >= SPT_ADAPTIVE_SHARE * median);
        kept += mask[i];
    }
    free(err);
    free(gain);
    free(sorted);
    return kept;
}
