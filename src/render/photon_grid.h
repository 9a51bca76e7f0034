/* The host's side of photon merging (kernels/integrator/photon_grid.h): each
 * chunk's radii, and the hash grid sorted from the photons its light paths
 * left. */
#ifndef SPT_RENDER_PHOTON_GRID_H
#define SPT_RENDER_PHOTON_GRID_H

#include <stddef.h>
#include <stdint.h>

/* Per sample slot k of a chunk whose first sample index is sample_begin: the
 * radius r of sample index sample_begin + k (Knaus and Zwicker's schedule
 * from r0) and its cells' inverse edge 1 / (2 r), into out[2 k], out[2 k + 1]. */
void photon_radius_table(float r0, uint32_t sample_begin, uint32_t n, float *out);

/* Sorts the photons of raw (slots photon slots of SPT_PM_PHOTON_FLOAT4
 * float4 each, a slot whose flux is all zero empty) into out (the same
 * layout, kept photons only, by bucket, and within a bucket in slot order)
 * with cells (first photon of each bucket, then the end: *mask + 2 words,
 * *mask + 1 a power of two at most max_buckets, about the photons' number),
 * radius the chunk's table (photon_radius_table). Returns the photons kept. */
uint32_t photon_grid_build(const float *raw, size_t slots, const float *radius, size_t max_buckets, float *out,
                           uint32_t *cells, uint32_t *mask);

#endif
