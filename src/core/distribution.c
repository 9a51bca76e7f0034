/* Discrete distributions: CDF tables for spt_discrete_sample. */
#include "core/distribution.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/util.h"

/* A weight as the distribution uses it: the weight when finite and > 0, else 0. */
static double distrib_usable(float w)
{
    return (isfinite(w) && w > 0.0f) ? (double)w : 0.0;
}

int distrib_build(Distrib *d, const float *weights, uint32_t n)
{
    memset(d, 0, sizeof *d);
    d->n = n;
    d->cdf = spt_calloc((size_t)n + 1, sizeof(float));
    double total = 0.0;
    uint32_t positive = 0, last = 0;
    for (uint32_t i = 0; i < n; i++) {
        double w = distrib_usable(weights[i]);
        if (w > 0.0) {
            positive++;
            last = i;
        }
        total += w;
    }
    d->total = total;
    d->positive = positive;
    if (positive == 0)
        return 0;
    /* Rounding a non-decreasing double sequence to float keeps it non-decreasing;
     * entries from the last usable weight on are set to 1 exactly, so trailing
     * unusable entries get probability 0 and cdf[n] = 1. */
    double sum = 0.0;
    for (uint32_t i = 0; i < last; i++) {
        sum += distrib_usable(weights[i]);
        d->cdf[i + 1] = (float)(sum / total);
    }
    for (uint32_t i = last + 1; i <= n; i++)
        d->cdf[i] = 1.0f;
    return 1;
}

float distrib_prob(const Distrib *d, uint32_t i)
{
    return d->cdf[i + 1] - d->cdf[i];
}

void distrib_free(Distrib *d)
{
    free(d->cdf);
    memset(d, 0, sizeof *d);
}
