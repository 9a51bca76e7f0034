/* The parameters every chunk of a render shares (src/render/render_params.h):
 * the camera, the sampler, the scene's counts and bounds, the light-tracing
 * plan's results and the lens. */
#include "render/render_params.h"

#include <math.h>
#include <string.h>
#include <strings.h>

#include "bvh/bvh.h"
#include "bvh/bvh_tlas.h"
#include "render/light_plan.h"
#include "sample/rng.h"

/* The camera of the kernels: right and up scaled so that screen coordinates in
 * [-1, 1] span the field of view at the image's aspect ratio. */
static void camera_params(RenderParams *p, const SceneCamera *c, int width, int height)
{
    float t = tanf(0.5f * c->yfov);
    float aspect = (float)width / (float)height;
    /* Orthographic (glTF xmag/ymag: half the view's width and height): right and up
     * span the image plane itself; the image's aspect follows ymag. */
    float sx = c->orthographic ? c->ymag * aspect : t * aspect;
    float sy = c->orthographic ? c->ymag : t;
    p->orthographic = c->orthographic ? 1u : 0u;
    for (int i = 0; i < 3; i++) {
        p->cam_pos[i] = c->position[i];
        p->cam_fwd[i] = c->forward[i];
        p->cam_right[i] = c->right[i] * sx;
        p->cam_up[i] = c->up[i] * sy;
    }
    p->cam_right[3] = p->cam_up[3] = 0.0f;
    /* The ray cone that texture filtering follows (kernels/integrator/path.h): a pixel's
     * size at the camera (orthographic), or a pixel's angle (perspective, at the
     * image's centre). */
    p->cam_pos[3] = c->orthographic ? 2.0f * sy / (float)height : 0.0f;
    p->cam_fwd[3] = c->orthographic ? 0.0f : 2.0f * t / (float)height;
}

int render_sampler_parse(const char *name, uint32_t *sampler)
{
    static const char *const names[] = SPT_SAMPLER_NAMES; /* by value */
    for (uint32_t v = 0; v < sizeof names / sizeof names[0]; v++)
        if (name && !strcasecmp(name, names[v])) {
            *sampler = v;
            return 0;
        }
    return -1;
}

void render_params(RenderParams *p, const RenderLights *L, const GpuScene *g,
                   const SceneCamera *cam, const RenderSettings *rs)
{
    memset(p, 0, sizeof *p);
    camera_params(p, cam, rs->width, rs->height);
    p->width = rs->width;
    p->height = rs->height;
    p->seed = rs->seed;
    p->sampler = rs->sampler;
    if (rs->sampler == SPT_SAMPLER_ZSOBOL) {
        /* The samples per pixel (the cap under --time) rounded up to a power
         * of two fix the sequence (kernels/sample/rng.h, ZSobol). */
        p->zsobol_log2spp = spt_ceil_log2((uint32_t)(rs->spp > 0 ? rs->spp : 1));
        p->zsobol_digits = spt_zsobol_digits((uint32_t)rs->width, (uint32_t)rs->height, p->zsobol_log2spp);
    }
    p->max_depth = rs->max_depth;
    p->emitter_count = g->emitter_count;
    p->tri_emitters = g->tri_emitter_count;
    p->light_count = g->light_count;
    p->select_count = L->select.n;
    p->emitter_total = (float)L->select.total;
    p->env = L->env.env;
    p->env_prob = L->env_prob;
    p->tree_nodes = L->tree.count;
    p->aside_offset = L->aside_offset;
    p->aside_count = L->aside.n;
    p->node_count = g->tlas.inst_count ? (uint32_t)g->tlas.node_count : g->bvh.node_count;
    p->inst_count = g->tlas.inst_count;
    /* Russian roulette from the fifth segment on (Mitsuba 3's default): on
     * the 1M-triangle mesh scene of tools/bench_mitsuba.py (256x256, 64 spp)
     * it lowers relMSE x spp from 0.21 to 0.149 for 18% more time, 1.18
     * times the clean image per second of starting at the third segment
     * (docs/performance.md, "Russian roulette"). */
    p->rr_depth = 5;
    for (uint32_t i = 0; i < g->material_count; i++)
        if (g->materials[i].flags & (SPT_MAT_ALPHA_MASK | SPT_MAT_ALPHA_BLEND))
            p->has_alpha = 1;
    p->scene_radius = g->scene_radius;
    for (int k = 0; k < 3; k++)
        p->scene_center[k] = g->scene_center[k];
    /* The light-tracing pass: its caustic spheres and light paths. */
    light_plan(p, L, g, cam, rs);
    p->lens_radius = rs->aperture;
    p->focus_distance = rs->focus_distance;
    if (rs->aperture > 0 && !(rs->focus_distance > 0)) {
        /* Focus at the distance seen at the image centre (1 km when nothing is there). */
        BvhHit hit;
        vec3 o = v3(cam->position[0], cam->position[1], cam->position[2]);
        vec3 d = v3(cam->forward[0], cam->forward[1], cam->forward[2]);
        BvhInstHit ih;
        memset(&ih, 0, sizeof ih);
        p->focus_distance = 1000.0f;
        if (g->tlas.inst_count) {
            if (bvh_tlas_intersect(g->tlas.top, g->tlas.inst, g->tlas.nodes, g->tlas.tris, o, d, 1e30f, &ih))
                p->focus_distance = ih.h.t;
        } else if (g->bvh.prim_count && bvh_intersect(g->bvh.nodes, g->bvh.tri_data, o, d, 1e30f, &hit)) {
            p->focus_distance = hit.t;
        }
    }
}

void render_image_size(RenderSettings *rs, const SceneCamera *cam)
{
    if (!rs->width && !rs->height)
        rs->width = 512;
    float aspect = cam->aspect > 0 ? cam->aspect : 1.0f;
    if (!rs->height)
        rs->height = (long)(rs->width / aspect + 0.5f) > 0 ? (int)(long)(rs->width / aspect + 0.5f) : 1;
    if (!rs->width)
        rs->width = (long)(rs->height * aspect + 0.5f) > 0 ? (int)(long)(rs->height * aspect + 0.5f) : 1;
}

void render_adaptive_resolve(RenderSettings *rs, int may_adapt)
{
    if (rs->adaptive == SPT_SWITCH_AUTO)
        rs->adaptive = rs->time_limit > 0 && may_adapt ? SPT_SWITCH_ON : SPT_SWITCH_OFF;
    if (rs->adaptive == SPT_SWITCH_OFF)
        rs->adaptive = SPT_SWITCH_AUTO;
}
