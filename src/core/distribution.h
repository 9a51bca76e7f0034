/* Host-side construction of discrete distributions for the kernels, e.g. light
 * selection in proportion to power: a CDF table to upload as is and sample with
 * spt_discrete_sample (kernels/sample/sampling.h). */
#ifndef SPT_DISTRIBUTION_H
#define SPT_DISTRIBUTION_H

#include <stdint.h>

/* A discrete distribution over n entries.
 * cdf: n + 1 floats, non-decreasing, cdf[0] = 0 and cdf[n] = 1 exactly for a
 *      non-empty distribution; all 0 for an empty one (spt_discrete_sample then
 *      returns -1). Entry i has probability cdf[i+1] - cdf[i], which is 0 exactly
 *      for every entry whose weight was not usable. The table is float: an entry
 *      whose weight is below about 2^-24 of the total may round to probability 0
 *      (then it is never picked, consistently with the probability reported).
 * total: the sum of the usable weights (double precision); probability times
 *      total gives back the weight, so the renderer turns a selection probability
 *      into a pdf with it. 0 for an empty distribution.
 * positive: the number of entries with a usable weight. */
typedef struct Distrib {
    float *cdf;
    uint32_t n;
    uint32_t positive;
    double total;
} Distrib;

/* Builds d from weights[0..n-1] (weights may be NULL when n is 0). Usable weights
 * are finite and > 0; zero, negative, NaN and infinite weights count as 0. Sums
 * in double precision, so n may be in the millions without drift. Returns 1 for
 * a distribution that can be sampled, 0 for an empty one (n == 0 or no usable
 * weight): d is valid either way and must be released with distrib_free. */
int distrib_build(Distrib *d, const float *weights, uint32_t n);

/* The probability of entry i (< d->n), exactly as the kernel computes it. */
float distrib_prob(const Distrib *d, uint32_t i);

/* Releases d's table and zeroes it; a zeroed Distrib is fine. */
void distrib_free(Distrib *d);

#endif
