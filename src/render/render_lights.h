/* The lights of one render (RenderLights): built per render from the GpuScene
 * and the render settings' sky, uploaded with the scene buffers. */
#ifndef SPT_RENDER_LIGHTS_H
#define SPT_RENDER_LIGHTS_H

#include "core/distribution.h"
#include "render/gpu_scene.h"
#include "render/host_lights.h"
#include "render/render.h"

/* The lights of one render: the scene's emitters and punctual lights plus the
 * environment of the render settings, and the one distribution that picks among
 * them in proportion to power. */
typedef struct RenderLights {
    EnvLight env;
    Distrib select;          /* [emitters | punctual lights | environment] */
    float *tri_light_pdf;    /* per packed triangle: P(select) / area, 0 if not emitting */
    float env_prob;
} RenderLights;

/* Builds L for g and the sky of rs. Returns 0 or an exit code (a bad --env or
 * --background). */
int render_lights_setup(RenderLights *L, const GpuScene *g, const RenderSettings *rs,
                        SptError *e);
void render_lights_free(RenderLights *L);

#endif
