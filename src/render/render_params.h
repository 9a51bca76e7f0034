/* The parameters every chunk of a render shares (RenderParams,
 * kernels/util/render_types.h), made once per render from the scene, its
 * lights, the camera and the settings: the camera's frame scaled to the field
 * of view, the sampler, the scene's counts and bounds, Russian roulette's
 * start, the light-tracing plan (src/render/light_plan.h) and the lens. */
#ifndef SPT_RENDER_PARAMS_H
#define SPT_RENDER_PARAMS_H

#include "render/gpu_scene.h"
#include "render/render.h"
#include "render/render_lights.h"
#include "scene/scene.h"
#include "util/render_types.h"

void render_params(RenderParams *p, const RenderLights *L, const GpuScene *g,
                   const SceneCamera *cam, const RenderSettings *rs);

#endif
