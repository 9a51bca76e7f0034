/* The photon map's hash grid on the host (see render/photon_grid.h). A
 * counting sort by bucket that walks the photons in slot order, so the grid,
 * and the order in which a gather sums a bucket, are functions of the
 * photons alone (docs/architecture.md, "Caustics seen through specular
 * surfaces"). */
#include "render/photon_grid.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/util.h"
#include "integrator/photon_grid.h"

void photon_radius_table(float r0, uint32_t sample_begin, uint32_t n, float *out)
{
    /* r_i^2 = r_1^2 prod_{k=1}^{i-1} (k + alpha) / (k + 1)
     *       = r_1^2 Gamma(i + alpha) / (Gamma(1 + alpha) Gamma(i + 1)), pass i = sample + 1. */
    const double a = SPT_PM_ALPHA;
    for (uint32_t k = 0; k < n; k++) {
        double i = (double)sample_begin + (double)k + 1.0;
        double r2 = (double)r0 * (double)r0 * exp(lgamma(i + a) - lgamma(1.0 + a) - lgamma(i + 1.0));
        float r = (float)sqrt(r2);
        out[2 * k] = r;
        out[2 * k + 1] = 1.0f / (2.0f * r);
    }
}

/* The bucket of photon ph (its slot's radius table entry in radius). */
static uint32_t photon_bucket(const float *ph, const float *radius, uint32_t mask)
{
    uint32_t tag;
    memcpy(&tag, ph + 3, sizeof tag);
    uint32_t slot = tag & SPT_PM_TAG_SLOT;
    float inv = radius[2 * slot + 1];
    return spt_pm_hash(spt_pm_cell(ph[0], inv), spt_pm_cell(ph[1], inv), spt_pm_cell(ph[2], inv), slot) & mask;
}

static int photon_kept(const float *ph)
{
    return ph[8] > 0.0f || ph[9] > 0.0f || ph[10] > 0.0f || ph[11] > 0.0f;
}

uint32_t photon_grid_build(const float *raw, size_t slots, const float *radius, size_t max_buckets, float *out,
                           uint32_t *cells, uint32_t *mask)
{
    const size_t fl = 4 * SPT_PM_PHOTON_FLOAT4;
    size_t kept = 0;
    for (size_t s = 0; s < slots; s++)
        kept += photon_kept(raw + s * fl);
    size_t buckets = 1;
    while (buckets < kept && buckets < max_buckets)
        buckets *= 2;
    *mask = (uint32_t)(buckets - 1);
    memset(cells, 0, (buckets + 1) * sizeof *cells);
    uint32_t *bucket = spt_malloc((kept ? kept : 1) * sizeof *bucket);
    size_t n = 0;
    for (size_t s = 0; s < slots; s++)
        if (photon_kept(raw + s * fl)) {
            bucket[n] = photon_bucket(raw + s * fl, radius, *mask);
            cells[bucket[n] + 1]++;
            n++;
        }
    for (size_t b = 0; b < buckets; b++)
        cells[b + 1] += cells[b];
    /* Each bucket's photons in slot order: a cursor per bucket from its start. */
    uint32_t *at = spt_malloc(buckets * sizeof *at);
    memcpy(at, cells, buckets * sizeof *at);
    n = 0;
    for (size_t s = 0; s < slots; s++)
        if (photon_kept(raw + s * fl)) {
            memcpy(out + (size_t)at[bucket[n]]++ * fl, raw + s * fl, fl * sizeof *out);
            n++;
        }
    free(at);
    free(bucket);
    return (uint32_t)kept;
}
