/* When a lobe is a delta (a perfect mirror or a perfectly smooth interface),
 * the one test that the kernels' BSDF (kernels/closure/bsdf_params.h for the
 * base's lobes, lobe_coat.h for the clear coat; the light paths ask it through
 * bsdf_picks_delta) and the host's light-tracing plan (src/render/light_plan.c: which materials may
 * be delta, hence the caustic spheres; docs/architecture.md, "Caustics") all
 * make, so that they cannot disagree about which surfaces start caustics.
 * C99 and OpenCL C. */
#ifndef SPT_CLOSURE_DELTA_H
#define SPT_CLOSURE_DELTA_H

#include "util/portable.h"

/* GGX alpha (glTF's roughness squared) below which a lobe is treated as
 * perfectly smooth: sampled as a delta, never evaluated or light-sampled. */
#define BSDF_DELTA_ALPHA 1e-3f

/* Whether a GGX lobe of glTF roughness r (alpha = r^2; the base's roughness or
 * the clear coat's) is a delta lobe. */
SPT_FN int bsdf_roughness_is_delta(float r)
{
    return r * r < BSDF_DELTA_ALPHA;
}

#endif
