/* The light-tracing plan of a render (docs/architecture.md, "Caustics"): whether
 * the light-tracing pass runs, the caustic spheres that its light paths' first
 * rays aim at (one per material that may take a delta lobe, by the kernels' own
 * test, kernels/closure/delta.h), and how many light paths it traces per sample
 * index. The kernels' side is kernels/integrator/light_trace.h. */
#ifndef SPT_LIGHT_PLAN_H
#define SPT_LIGHT_PLAN_H

#include "render/gpu_scene.h"
#include "render/render.h"
#include "render/render_lights.h"
#include "scene/scene.h"
#include "util/render_types.h"

/* Whether the light-tracing pass runs (--caustics): on, or auto and the scene
 * has a light (an emitter, a punctual light, or an --env map that L's light
 * selection holds; with L NULL, as if the scene had one: the memory
 * estimate's upper bound, before the lights are built) and a triangle whose
 * material has a delta lobe that passes or turns light; never with
 * --spectral, the variance layer or an orthographic camera (with a warning
 * under `on` when warn is set). */
int light_plan_runs(const RenderSettings *rs, const RenderLights *L, const GpuScene *g,
                    const SceneCamera *cam, int warn);

/* Whether photon merging is on for scene g (docs/architecture.md, "Caustics
 * seen through specular surfaces"): --merge on, or auto where a triangle's
 * material has a delta lobe that passes or turns light (as the light-tracing
 * pass's auto rule), so that camera paths may see, through it, a caustic that
 * light paths carry through it, unless such a material is dispersive and a
 * light's spectrum has lines; never where the light-tracing pass cannot run
 * for the settings (--caustics off, --spectral, the variance layer). It runs
 * where the pass runs too (light_plan). */
int light_plan_merges(const RenderSettings *rs, const GpuScene *g);

/* Light paths per sample index of the light-tracing pass for rs at most,
 * with photon merging (its buffers are sized from this). */
uint32_t light_plan_max_paths(const RenderSettings *rs);

/* Fills p's caustic spheres (p->caustic, p->caustic_count) and, when the pass
 * runs, p->light_paths, and photon merging's p->merge and p->pm_r0 (the
 * initial radius); needs p's scene centre and radius and camera set. */
void light_plan(RenderParams *p, const RenderLights *L, const GpuScene *g, const SceneCamera *cam,
                const RenderSettings *rs);

#endif
