/* The photon map's hash grid and radius schedule, shared by the host, which
 * builds the grid (src/render/photon_grid.c), and the kernels, which gather
 * from it (kernels/integrator/photon_merge.h). docs/architecture.md,
 * "Caustics seen through specular surfaces" has the method.
 *
 * A photon is three float4 (SPT_PM_PHOTON_FLOAT4): its position with its tag
 * (as bits) in w, the direction toward the light path's previous vertex, and
 * its flux at the path's four wavelengths. The tag: the photon's sample slot
 * in the chunk (bits 0-15), the light path's depth at the photon (segments
 * from the light, bits 16-30), and bit 31 when the light path kept only its
 * hero wavelength (a dispersive refraction). The grid of sample slot k has
 * cells of edge 2 r_k (r_k the slot's radius), so a disc of radius r_k meets
 * at most two cells along each axis; cell (x, y, z) of slot k is bucket
 * spt_pm_hash(x, y, z, k) & mask of a table of mask + 1 buckets, each bucket
 * the photons of its cells in the order of their slots in the light paths'
 * photon buffer (a counting sort by bucket, stable), so a gather sums them in
 * an order that does not depend on the schedule. */
#ifndef SPT_PHOTON_GRID_H
#define SPT_PHOTON_GRID_H

#include "util/portable.h"

/* Photons a light path may leave (one per vertex with a non-delta lobe after
 * its first vertex, the first SPT_PM_PER_PATH of them: the merge owns the
 * paths through those, the camera paths the rest; pm_camera_drops). */
#define SPT_PM_PER_PATH 7u
#define SPT_PM_PHOTON_FLOAT4 3u
#define SPT_PM_TAG_SLOT 0xffffu
#define SPT_PM_TAG_DEPTH_SHIFT 16
#define SPT_PM_TAG_DEPTH 0x7fffu
#define SPT_PM_TAG_HERO 0x80000000u

/* The radius schedule of Knaus and Zwicker 2011 ("Progressive photon
 * mapping: a probabilistic approach", eq. 20): r_{i+1}^2 = r_i^2 (i + alpha)
 * / (i + 1), pass i = sample index + 1, alpha = 2/3 (their recommendation). */
#define SPT_PM_ALPHA (2.0 / 3.0)

/* The initial radius in pixel footprints at the distance of the caustic
 * spheres (src/render/light_plan.c). */
#define SPT_PM_R0_PIXELS 0.5

/* The bucket of cell (x, y, z) of sample slot k (Teschner et al. 2003's
 * primes), before the table's mask. */
SPT_FN spt_u32 spt_pm_hash(spt_i32 x, spt_i32 y, spt_i32 z, spt_u32 k)
{
    return ((spt_u32)x * 73856093u) ^ ((spt_u32)y * 19349663u) ^ ((spt_u32)z * 83492791u) ^
           (k * 2654435761u);
}

/* The cell index along one axis of coordinate x, inv the cells' inverse
 * edge: one correctly rounded product, so host and device agree. */
SPT_FN spt_i32 spt_pm_cell(float x, float inv)
{
    return (spt_i32)floorf(x * inv);
}

#endif
