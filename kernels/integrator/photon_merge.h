/* Photon merging for caustics seen through specular surfaces
 * (docs/architecture.md, "Caustics seen through specular surfaces"): the
 * light paths of the light-tracing pass (kernels/integrator/light_trace.h)
 * leave photons where they reach a surface with a non-delta lobe (after their
 * first vertex, a delta one), and camera paths that reach such a surface
 * after delta vertices only gather them within a radius that shrinks with the
 * sample index (progressive photon mapping: Hachisuka, Ogaki and Jensen
 * 2008; the radius schedule of Knaus and Zwicker 2011,
 * kernels/integrator/photon_grid.h). Kernels built with SPT_MERGE only.
 *
 * The partition of path space: name a path's vertices from the camera by the
 * lobe each took, D (non-delta) or S (delta). The merge owns the paths
 * camera - S+ - D - (any) - S - light (the light one the light-tracing pass
 * starts from: an emissive triangle of the light selection, a punctual
 * light, an environment map that the selection holds) whose light path left
 * its photon at that first D, that is fewer than SPT_PM_PER_PATH vertices
 * with a non-delta lobe lie between it and the last S; a camera path drops
 * the emission it reaches that way (pm_camera_drops), and keeps everything
 * else. Those paths were the camera paths' alone (their first vertex is S,
 * so the light-tracing pass's connections never made them), and the dropped
 * emission has MIS weight 1 (reached through a delta vertex), so no weight
 * is split. A camera path and a light path of one sample index carry the
 * same wavelengths (pm_lambda_u), so a merge multiplies the two lane by
 * lane. */
#ifndef SPT_PHOTON_MERGE_H
#define SPT_PHOTON_MERGE_H

#include "util/portable.h"
#include "util/vecmath.h"
#include "util/render_types.h"
#include "sample/rng.h"
#include "closure/bsdf.h"
#include "integrator/path.h"
#include "integrator/kernel_globals.h"
#include "integrator/photon_grid.h"

SPT_DEVICE_ONLY

/* The hero wavelength's CDF value of sample index s, for every camera path
 * and light path of it: the golden-ratio sequence (Kronecker) in 32-bit
 * fixed point from a seed-dependent start, so the sample indices' values are
 * spread evenly over [0, 1) and the value is a function of (seed, s) alone. */
SPT_FN_INLINE float pm_lambda_u(uint seed, uint s)
{
    return spt_u32_to_unit(spt_hash_u32(seed ^ 0x3c6ef372u) + s * 0x9e3779b9u);
}

/* The hero wavelength's CDF value of a path of sample index `sample` whose
 * own would be u: pm_lambda_u with merging (in kernels built with
 * SPT_MERGE), else u. */
SPT_FN_INLINE float pm_wavelength_u(float u, uint sample, const KernelGlobals *kg)
{
#ifdef SPT_MERGE
    if (kg->p->merge)
        return pm_lambda_u(kg->p->seed, sample);
#endif
    (void)sample;
    (void)kg;
    return u;
}

/* A camera path's throughput beta after a BSDF sample (dispersive: it
 * refracted at a wavelength-dependent index), with merging: a dispersive
 * refraction leaves it its hero wavelength alone, as TerminateSecondary does,
 * but its wavelengths' pdfs stay, and the hero's throughput takes the 4 the
 * pdf would lose (SPT_PM_HERO marks it). So the radiance the path gathered
 * before (a merge of a hero-only photon, whose hero lane carries that 4
 * already, pm_gather) keeps its weight when the path loses its other lanes
 * later: dividing it by a hero-only pdf at the end would count it four times
 * over (docs/architecture.md, "Caustics seen through specular surfaces").
 * Returns 0, leaving beta, for light paths and without merging. */
SPT_FN_INLINE int pm_camera_hero(uint i, int dispersive, float4 *beta, const KernelGlobals *kg)
{
    uint lt = kg->ps_lt[i];
    if (!kg->p->merge || (lt & SPT_LT_LIGHT))
        return 0;
    if (dispersive && !(lt & SPT_PM_HERO)) {
        kg->ps_lt[i] = lt | SPT_PM_HERO;
        *beta = (float4)(4.0f * beta->x, 0.0f, 0.0f, 0.0f);
    } else if (lt & SPT_PM_HERO) {
        *beta = (float4)(beta->x, 0.0f, 0.0f, 0.0f);
    }
    return 1;
}

/* The camera path's state after its vertex sampled a lobe, delta or not, its
 * BSDF having a non-delta lobe or not (has_d; SPT_PM_* of render_types.h):
 * after its first non-delta vertex (the merge's), the vertices with a
 * non-delta lobe but the last one are counted (up to SPT_PM_COUNT_MAX): the
 * light path through them left a photon at each (pm_deposit) before the one
 * at the merge's vertex. */
SPT_FN_INLINE uint pm_camera_next(uint lt, int is_delta, int has_d)
{
    if (!(lt & SPT_PM_SEEN_D))
        return is_delta ? lt : lt | SPT_PM_SEEN_D;
    uint n = (lt >> SPT_PM_COUNT_SHIFT) & SPT_PM_COUNT_MAX;
    n = min(n + ((lt & SPT_PM_LAST_D) ? 1u : 0u), SPT_PM_COUNT_MAX);
    return (lt & ~(SPT_PM_LAST_D | (SPT_PM_COUNT_MAX << SPT_PM_COUNT_SHIFT))) | (n << SPT_PM_COUNT_SHIFT) |
           (has_d ? SPT_PM_LAST_D : 0u);
}

/* Whether the emission that a camera path in state lt reaches is the merge's
 * (camera - S+ - D - ... - S+ - light, with fewer than SPT_PM_PER_PATH
 * vertices with a non-delta lobe between the D and the last S: those whose
 * photon the light path left at the D): env for a ray that left the scene,
 * else a triangle of tri_light_pdf's (the light selection's). lt's
 * SPT_LT_CHAIN (x1 took a non-delta lobe: the light-tracing pass's) and
 * SPT_LT_SPEC (the last vertex took a delta one) are lt_camera_next's. */
SPT_FN_INLINE int pm_camera_drops(uint lt, int env, uint prim, const KernelGlobals *kg)
{
    if (!kg->p->merge || (lt & (SPT_PM_SEEN_D | SPT_LT_CHAIN | SPT_LT_SPEC)) != (SPT_PM_SEEN_D | SPT_LT_SPEC) ||
        ((lt >> SPT_PM_COUNT_SHIFT) & SPT_PM_COUNT_MAX) >= SPT_PM_PER_PATH)
        return 0;
    if (env)
        return kg->p->env_prob > 0.0f && kg->p->env.kind == SPT_ENV_MAP;
    return kg->tri_light_pdf[prim] > 0.0f;
}

/* Light path i's photon at p (the light's direction there wo, toward the
 * path's previous vertex; throughput beta; depth segments from the light), a
 * vertex with a non-delta lobe after the path's first (delta) one: into its
 * next slot of pm_photon, while it has one (the camera paths keep the paths
 * whose photon would come later: pm_camera_drops). */
SPT_FN_INLINE void pm_deposit(uint i, float3 p, float3 wo, float4 beta, uint depth, const KernelGlobals *kg)
{
    uint lt = kg->ps_lt[i];
    uint n = (lt >> SPT_PM_COUNT_SHIFT) & SPT_PM_COUNT_MAX;
    if (!kg->p->merge || n >= SPT_PM_PER_PATH)
        return;
    float4 phi = kg->ps_radiance[i] * beta;
    if (!(max4(phi) > 0.0f) || !isfinite(max4(phi)))
        return;
    uint lw = kg->ps_work[i] - kg->p->light_begin;
    uint slot = lw / kg->p->light_paths;
    uint tag = slot | (min(depth, SPT_PM_TAG_DEPTH) << SPT_PM_TAG_DEPTH_SHIFT) |
               (kg->ps_lambda_pdf[i].y > 0.0f ? 0u : SPT_PM_TAG_HERO);
    __global float4 *ph = kg->pm_photon + SPT_PM_PHOTON_FLOAT4 * (lw * SPT_PM_PER_PATH + n);
    ph[0] = (float4)(p, as_float(tag));
    ph[1] = (float4)(wo, 0.0f);
    ph[2] = phi;
    kg->ps_lt[i] = lt + (1u << SPT_PM_COUNT_SHIFT);
}

/* The merge at camera path i's vertex p (depth segments from the camera;
 * its frame ngf, tg, bt, ns; wo_l toward the camera, local; both_sides: the
 * BSDF bp sends light to both sides): the radiance toward the camera of the
 * photons of its sample slot within the slot's radius, a kernel density
 * estimate with the disc's constant kernel, per unit of the path's
 * throughput. A photon's flux arrived with its geometric cosine, which the
 * shading cosine in bsdf_eval replaces (Veach's adjoint, as the light-tracing
 * pass's connections do). */
SPT_FN_INLINE float4 pm_gather(uint i, uint depth, float3 p, float3 ngf, float3 tg, float3 bt, float3 ns,
                               float3 wo_l, int both_sides, const BsdfParams *bp, const KernelGlobals *kg)
{
    uint npix = (uint)(kg->p->width * kg->p->height);
    uint slot = kg->ps_work[i] / npix;
    float r = kg->pm_radius[2u * slot], inv = kg->pm_radius[2u * slot + 1u];
    int hero_only = (kg->ps_lt[i] & SPT_PM_HERO) != 0u;
    float4 sum = (float4)(0.0f);
    int x0 = spt_pm_cell(p.x - r, inv), x1 = spt_pm_cell(p.x + r, inv);
    int y0 = spt_pm_cell(p.y - r, inv), y1 = spt_pm_cell(p.y + r, inv);
    int z0 = spt_pm_cell(p.z - r, inv), z1 = spt_pm_cell(p.z + r, inv);
    for (int x = x0; x <= x1; x++)
        for (int y = y0; y <= y1; y++)
            for (int z = z0; z <= z1; z++) {
                uint b = spt_pm_hash(x, y, z, slot) & kg->p->pm_mask;
                uint end = kg->pm_cell[b + 1u];
                for (uint k = kg->pm_cell[b]; k < end; k++) {
                    const __global float4 *ph = kg->pm_photon + SPT_PM_PHOTON_FLOAT4 * k;
                    float4 a = ph[0];
                    uint tag = as_uint(a.w);
                    uint dl = (tag >> SPT_PM_TAG_DEPTH_SHIFT) & SPT_PM_TAG_DEPTH;
                    float3 d = a.xyz - p;
                    /* Its own cell only: two cells may share a bucket. */
                    if ((tag & SPT_PM_TAG_SLOT) != slot || spt_pm_cell(a.x, inv) != x ||
                        spt_pm_cell(a.y, inv) != y || spt_pm_cell(a.z, inv) != z || !(dot(d, d) < r * r) ||
                        (kg->p->max_depth > 0 && depth + dl > (uint)kg->p->max_depth))
                        continue;
                    float3 wi = ph[1].xyz;
                    float wi_side = dot(wi, ngf);
                    float3 wi_l = (float3)(dot(wi, tg), dot(wi, bt), dot(wi, ns));
                    if (!(wi_side * wi_l.z > 0.0f) || (!both_sides && !(wi_side > 0.0f)))
                        continue;
                    float4 phi = ph[2];
                    /* A light path that kept only its hero wavelength: that
                     * lane's estimate carries the 4 its lost lanes leave it
                     * (the camera path's pdfs count all four); a camera path
                     * that kept only its hero carries that 4 in its
                     * throughput already (pm_camera_hero). */
                    if ((tag & SPT_PM_TAG_HERO) && !hero_only)
                        phi = (float4)(4.0f * phi.x, 0.0f, 0.0f, 0.0f);
                    sum += bsdf_eval(bp, wo_l, wi_l) * phi * (1.0f / fabs(wi_side));
                }
            }
    return sum * (1.0f / (SPT_PI * r * r * (float)kg->p->light_paths));
}

#endif
