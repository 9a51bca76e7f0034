/* Render settings and a scene built in code, shared by the render tests
 * (test_render_util.h) and the renderer benchmark (tools/bench_render.c, which
 * includes this file by its path): nothing here depends on the test harness. */
#ifndef SPT_RENDER_FIXTURE_H
#define SPT_RENDER_FIXTURE_H

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "accel/bvh_build.h"
#include "render/render.h"
#include "scene/scene.h"

/* Settings of a w x h render of spp samples at max_depth with seed; the rest
 * zero (the default sky; env_intensity 0: see square_settings in
 * test_render_util.h). */
static inline RenderSettings test_settings(int w, int h, int spp, int depth, uint32_t seed)
{
    RenderSettings rs;
    memset(&rs, 0, sizeof rs);
    rs.width = w;
    rs.height = h;
    rs.spp = spp;
    rs.max_depth = depth;
    rs.seed = seed;
    return rs;
}

/* s holds a sphere of radius 1 at the origin, stacks x slices, its vertices
 * moved along the radius by up to `displace`: flat triangles of their own
 * vertices (normals and uvs zero), all of material 0, one material slot
 * (zeroed: the caller fills it), camera zeroed, bounds not yet computed. */
static inline void sphere_scene_mesh(Scene *s, uint32_t stacks, uint32_t slices, float displace)
{
    memset(s, 0, sizeof *s);
    uint32_t n = 0;
    const float c[3] = {0, 0, 0};
    s->tri_pos = bvh_gen_sphere(stacks, slices, 1.0f, c, displace, &n);
    s->tri_count = n;
    s->vertex_count = 3 * n;
    s->tri_vidx = malloc(sizeof(uint32_t) * 3 * n);
    s->tri_mat = calloc(n, sizeof(uint32_t));
    s->vtx_normal = calloc((size_t)9 * n, sizeof(float));
    s->vtx_uv = calloc((size_t)6 * n, sizeof(float));
    for (uint32_t i = 0; i < 3 * n; i++)
        s->tri_vidx[i] = i;
    s->material_count = 1;
    s->materials = calloc(1, sizeof(SceneMaterial));
}

#endif
