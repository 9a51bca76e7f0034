/* The lights of one render (RenderLights): built per render from the GpuScene
 * and the render settings' sky, uploaded with the scene buffers. */
#ifndef SPT_RENDER_LIGHTS_H
#define SPT_RENDER_LIGHTS_H

#include "core/distribution.h"
#include "render/gpu_scene.h"
#include "render/host_lights.h"
#include "render/light_tree.h"
#include "render/render.h"

/* The lights of one render: the scene's emitters and punctual lights plus the
 * environment of the render settings, and the one distribution that picks among
 * them in proportion to power. */
typedef struct RenderLights {
    EnvLight env;
    Distrib select;          /* [emitters | punctual lights | environment] */
    float *tri_light_pdf;    /* per packed triangle: P(select) / area, 0 if not emitting;
                                with the tree, P(the tree) / area; an instanced mesh's
                                emitting triangle: its probability in its mesh's
                                distribution (kernels/light/inst_lights.h) */
    float env_prob;
    /* The light tree (kernels/light/light_tree.h) when next-event estimation
     * uses it (tree.count > 0): the aside distribution (the tree, each
     * punctual light, weight 0 unless directional, the environment), the
     * CDFs of select and aside end to end as the kernels' light_cdf (aside
     * from aside_offset), and per packed triangle its leaf node. */
    LightTree tree;
    Distrib aside;
    float *cdf_all;
    uint32_t aside_offset;
    uint32_t *tri_leaf;
    /* Emitters on instanced meshes: the kernels' inst_light
     * (kernels/light/inst_lights.h; NULL without them), whose meshes' CDFs
     * follow select's and aside's in cdf_all; cdf_count: cdf_all's floats. */
    uint32_t *inst_light;
    uint32_t inst_light_count;
    uint32_t cdf_count;
} RenderLights;

/* Whether the render picks lights with the tree (--light-tree): never off
 * or with fewer than two lights the tree would hold (emitters, point and
 * spot lights); always on; under auto, when those lights spread over a
 * quarter of the scene's diameter or more. */
int render_lights_use_tree(const GpuScene *g, const RenderSettings *rs);

/* Builds L for g and the sky of rs. Returns 0 or an exit code (a bad --env or
 * --background). */
int render_lights_setup(RenderLights *L, const GpuScene *g, const RenderSettings *rs,
                        SptError *e);
void render_lights_free(RenderLights *L);

#endif
