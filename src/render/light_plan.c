/* The light-tracing plan of a render (src/render/light_plan.h): whether the
 * pass runs, the caustic spheres its first rays aim at, and how many light
 * paths it traces (docs/architecture.md, "Caustics"). */
#include "render/light_plan.h"

#include <math.h>
#include <stdlib.h>

#include "closure/delta.h"
#include "integrator/photon_grid.h"
#include "light/inst_lights.h"
#include "light/lights.h"
#include "sample/sampling.h"

/* Whether material m may take a delta lobe somewhere: a smooth base (its
 * roughness factor, or a roughness texture that may lower it) or a clear coat
 * that may be smooth, by the kernels' test of a hit's lobes
 * (bsdf_roughness_is_delta, kernels/closure/delta.h) on the factors. A light
 * path goes on only through such a surface. */
static int material_may_be_delta(const GpuMaterial *m)
{
    if (bsdf_roughness_is_delta(m->roughness) || m->slot[SPT_TS_METALLIC_ROUGHNESS].tex >= 0)
        return 1;
    return m->clearcoat > 0.0f && (bsdf_roughness_is_delta(m->cc_roughness) ||
                                   m->slot[SPT_TS_CLEARCOAT_ROUGHNESS].tex >= 0);
}

/* What caustic_bounds gathers per group: the box of its vertices (pass 0),
 * then their farthest squared distance from the box's centre (pass 1). */
typedef struct CausticFit {
    RenderParams *p;
    int pass;
    float lo[SPT_CAUSTIC_MAX][3], hi[SPT_CAUSTIC_MAX][3];
    double m_abs[SPT_CAUSTIC_MAX], r2[SPT_CAUSTIC_MAX];
} CausticFit;

static void fit_vertex(CausticFit *f, int k, const float x[3])
{
    if (f->pass == 0) {
        for (int c = 0; c < 3; c++) {
            f->lo[k][c] = fminf(f->lo[k][c], x[c]);
            f->hi[k][c] = fmaxf(f->hi[k][c], x[c]);
        }
        return;
    }
    double d2 = 0;
    for (int c = 0; c < 3; c++) {
        double d = (double)x[c] - f->p->caustic[4 * k + c];
        d2 += d * d;
    }
    f->r2[k] = fmax(f->r2[k], d2);
}

/* fit_vertex on each world-space vertex of each placed triangle whose
 * material is in a group (group[m] >= 0): the world-space triangles as they
 * are, then each instance's mesh through its transform in double, rounded
 * as a flattened copy's (docs/architecture.md, "Instances (two levels)"). */
static void group_vertices(const GpuScene *g, const int32_t *group, CausticFit *f)
{
    const Tlas *tl = &g->tlas;
    for (uint32_t k = 0; k <= tl->inst_count; k++) {
        const BvhInstance *in = k ? &tl->inst[k - 1] : NULL;
        uint32_t mesh = k ? tl->inst_mesh[k - 1] : 0;
        if (in && mesh == 0)
            continue; /* the world's triangles under the identity: done at k 0 */
        uint32_t begin = in ? g->mesh_prims[mesh] : 0;
        uint32_t end = in ? g->mesh_prims[mesh + 1] : g->bvh.prim_count;
        for (uint32_t i = begin; i < end; i++) {
            const TriShade *ts = &g->tri_shade[i];
            if (ts->material >= g->material_count || group[ts->material] < 0)
                continue;
            for (int v = 0; v < 3; v++) {
                const float *x = g->vtx_pos + 3 * (size_t)ts->v[v];
                float w[3];
                for (int r = 0; r < 3 && in; r++)
                    w[r] = (float)((double)in->xf[4 * r] * x[0] + (double)in->xf[4 * r + 1] * x[1] +
                                   (double)in->xf[4 * r + 2] * x[2] + in->xf[4 * r + 3]);
                fit_vertex(f, group[ts->material], in ? w : x);
            }
        }
    }
}

/* The caustic spheres (p->caustic, p->caustic_count; none when no triangle's
 * material may take a delta lobe): one per such material, or one for all of
 * them when there are more than SPT_CAUSTIC_MAX; each about the centre of the
 * box around its triangles' vertices, through the farthest of them, widened
 * by float rounding. A light path goes on only from such a surface, so its
 * first ray is aimed at these spheres (kernels/light/lights.h): one sphere
 * per material wastes fewer rays than one around all (on the Cornell box it
 * held the glass and the gold spheres and the space between them). */
static void caustic_bounds(RenderParams *p, const GpuScene *g)
{
    int32_t *group = spt_calloc(g->material_count ? g->material_count : 1, sizeof(int32_t));
    uint32_t n = 0;
    for (uint32_t m = 0; m < g->material_count; m++)
        group[m] = -1;
    for (uint32_t i = 0; i < g->prim_total; i++) {
        uint32_t m = g->tri_shade[i].material;
        if (m < g->material_count && group[m] < 0 && material_may_be_delta(&g->materials[m]))
            group[m] = (int32_t)n++;
    }
    if (n > SPT_CAUSTIC_MAX) {
        for (uint32_t m = 0; m < g->material_count; m++)
            if (group[m] >= 0)
                group[m] = 0;
        n = 1;
    }
    CausticFit fit;
    fit.p = p;
    fit.pass = 0;
    for (uint32_t k = 0; k < n; k++) {
        fit.m_abs[k] = fit.r2[k] = 0.0;
        for (int c = 0; c < 3; c++) {
            fit.lo[k][c] = INFINITY;
            fit.hi[k][c] = -INFINITY;
        }
    }
    group_vertices(g, group, &fit);
    for (uint32_t k = 0; k < n; k++)
        for (int c = 0; c < 3; c++) {
            p->caustic[4 * k + c] = 0.5f * (fit.lo[k][c] + fit.hi[k][c]);
            fit.m_abs[k] = fmax(fit.m_abs[k], fmax(fabs((double)fit.lo[k][c]), fabs((double)fit.hi[k][c])));
        }
    /* The farthest vertex from the box's centre (a sphere's mesh gets its own
     * radius, not the box's half diagonal, sqrt(3) times as long). */
    fit.pass = 1;
    group_vertices(g, group, &fit);
    double *m_abs = fit.m_abs, *r2 = fit.r2;
    for (uint32_t k = 0; k < n; k++)
        p->caustic[4 * k + 3] = (float)(sqrt(r2[k]) * (1.0 + 1e-5) + 1e-5 * m_abs[k] + 1e-6);
    p->caustic_count = n;
    free(group);
}

/* Whether the ray from o along unit d meets a caustic sphere of p. */
static int ray_meets_caustic(const RenderParams *p, vec3 o, vec3 d)
{
    for (uint32_t k = 0; k < p->caustic_count; k++)
        if (lt_meets_caustic(p, k, o, d))
            return 1;
    return 0;
}

static float share_u(uint64_t *state)
{
    uint64_t z = (*state += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return (float)((z ^ (z >> 31)) >> 40) * 0x1p-24f;
}

/* The light-tracing pass sizing: the light paths' first rays are aimed at the
 * caustic spheres (lt_aim_cones), where sampling the lights' emission as such
 * would send most of them elsewhere, to end at their first vertex.
 * --light-paths R asks for as many paths that head for a sphere as R light
 * paths per camera path sampled without aiming would give: the pass traces
 * R s per camera path, s = (the share of unaimed paths whose first ray meets
 * a sphere) / (the share of the pass's paths that do: all that are aimed, the
 * rest as unaimed). Estimated from SHARE_N light samples drawn as lt_start
 * draws them (stratified over the light selection, fixed numbers: the same on
 * every rank and device); 1 without caustic spheres or a light that reaches
 * them. The aiming tests are the kernels' own (lt_aim_cones, lt_aims_punctual,
 * lt_meets_caustic: kernels/light/lights.h); the unaimed point and direction
 * are drawn here again rather than by a function shared with lt_start
 * (kernels/integrator/light_trace.h), whose draws are OpenCL vector
 * expressions (a triangle's point from its barycentrics, kept for the
 * emission's textures; d = l.x t + l.y b + l.z n) that the device compiler
 * may contract into fused multiply-adds as written: recast as calls that the
 * host compiles, they could round differently and change the images, while
 * this estimate of a share of hits does not depend on such rounding. */
#define SHARE_N 16384
static double caustic_share(const RenderParams *p, const RenderLights *L, const GpuScene *g)
{
    if (p->caustic_count == 0 || L->select.n == 0)
        return 1.0;
    vec3 cs = v3(p->scene_center[0], p->scene_center[1], p->scene_center[2]);
    uint64_t st = 0x5eed5eedull;
    double old_hits = 0, new_hits = 0;
    for (int k = 0; k < SHARE_N; k++) {
        float prob;
        int e = spt_discrete_sample(L->select.cdf, L->select.n, ((float)k + share_u(&st)) / SHARE_N, &prob, NULL);
        float u1 = share_u(&st), u2 = share_u(&st), u3 = share_u(&st), u4 = share_u(&st), u5 = share_u(&st);
        float omega;
        if (e < 0 || !(prob > 0.0f))
            continue;
        if ((uint32_t)e < g->emitter_count) {
            uint32_t prim = g->emitters[e];
            const BvhInstance *in = NULL;
            if ((uint32_t)e >= g->tri_emitter_count) {
                /* An instance's triangle, as lt_start picks it. */
                float pt;
                in = &g->tlas.inst[prim];
                prim = inst_light_pick(L->inst_light, L->cdf_all, g->tlas.inst_count,
                                       (uint32_t)e - g->tri_emitter_count, share_u(&st), &pt);
                if (prim == SPT_INST_LIGHT_NONE)
                    continue;
            }
            const TriShade *ts = &g->tri_shade[prim];
            vec3 a, b, c;
            gpu_scene_tri(g, prim, &a, &b, &c);
            if (in) {
                a = bvh_xf_apply(in->xf, a, 1.0f);
                b = bvh_xf_apply(in->xf, b, 1.0f);
                c = bvh_xf_apply(in->xf, c, 1.0f);
            }
            vec3 cr = v3_cross(v3_sub(b, a), v3_sub(c, a));
            if (in && (in->flags & BVH_INSTANCE_MIRRORED))
                cr = v3_scale(cr, -1.0f);
            float area2 = v3_length(cr);
            if (!(area2 > 0.0f))
                continue;
            vec3 q = spt_sample_triangle(a, b, c, u1, u2);
            vec3 n = v3_scale(cr, 1.0f / area2);
            if ((g->materials[ts->material].flags & SPT_MAT_DOUBLE_SIDED_EMISSION) && u5 < 0.5f)
                n = v3_scale(n, -1.0f);
            vec3 t_, b_;
            v3_basis(n, &t_, &b_);
            vec3 l = spt_sample_cosine_hemisphere(u3, u4);
            vec3 d = v3_add(v3_add(v3_scale(t_, l.x), v3_scale(b_, l.y)), v3_scale(n, l.z));
            int hit = ray_meets_caustic(p, q, v3_normalize(d));
            old_hits += hit;
            new_hits += lt_aim_cones(p, q, &omega) ? 1 : hit;
        } else if ((uint32_t)e < g->emitter_count + g->light_count) {
            const GpuLight *l = &g->lights[(uint32_t)e - g->emitter_count];
            vec3 ax = v3(l->dir[0], l->dir[1], l->dir[2]), t_, b_;
            v3_basis(ax, &t_, &b_);
            if (l->type == SPT_PUNCTUAL_DIRECTIONAL) {
                vec3 disk = spt_sample_concentric_disk(u3, u4);
                float R = p->scene_radius;
                vec3 o = v3_add(v3_add(cs, v3_scale(v3_add(v3_scale(t_, disk.x), v3_scale(b_, disk.y)), R)),
                                v3_scale(ax, -R));
                old_hits += ray_meets_caustic(p, o, ax);
                new_hits += 1;
                continue;
            }
            vec3 pos = v3(l->pos[0], l->pos[1], l->pos[2]);
            float x = u3 * l->spot_span, ct = 1.0f - x, sn = sqrtf(fmaxf(0.0f, x * (2.0f - x)));
            float phi = 2.0f * SPT_PI * u4;
            vec3 d = v3_add(v3_add(v3_scale(t_, sn * cosf(phi)), v3_scale(b_, sn * sinf(phi))), v3_scale(ax, ct));
            int hit = ray_meets_caustic(p, pos, v3_normalize(d));
            old_hits += hit;
            new_hits += lt_aims_punctual(p, l, &omega) ? 1 : hit;
        } else if (L->env.env.kind == SPT_ENV_MAP) {
            /* Already aimed (its disc covers the sphere). */
            old_hits += 1;
            new_hits += 1;
        }
    }
    return new_hits > 0 ? old_hits / new_hits : 1.0;
}

/* Whether material m has a delta lobe that passes or turns light: smooth
 * transmission, smooth metal, a smooth clear coat. */
static int material_turns_light(const GpuMaterial *m)
{
    int smooth = bsdf_roughness_is_delta(m->roughness);
    int cc_smooth = bsdf_roughness_is_delta(m->cc_roughness);
    return (smooth && (m->transmission > 0.0f || m->metallic > 0.0f)) || (m->clearcoat > 0.0f && cc_smooth);
}

/* Whether a triangle of the scene has a material that material_turns_light
 * (the return value), and whether such a material is dispersive
 * (KHR_materials_dispersion) into *disperses when not NULL. A material that
 * only the file defines, on no rendered triangle, makes no caustics. */
static int scene_turns_light_ex(const GpuScene *g, int *disperses)
{
    unsigned char *used = spt_calloc(g->material_count ? g->material_count : 1, 1);
    int any = 0, disp = 0;
    for (uint32_t i = 0; i < g->prim_total; i++)
        if (g->tri_shade[i].material < g->material_count)
            used[g->tri_shade[i].material] = 1;
    for (uint32_t i = 0; i < g->material_count; i++)
        if (used[i] && material_turns_light(&g->materials[i])) {
            any = 1;
            disp |= g->materials[i].dispersion > 0.0f;
        }
    free(used);
    if (disperses)
        *disperses = disp;
    return any;
}

static int scene_turns_light(const GpuScene *g)
{
    return scene_turns_light_ex(g, NULL);
}

/* Whether dispersive glass and a line spectrum meet: with merging, a
 * dispersive refraction leaves every path of a sample index the same hero
 * wavelength, too few wavelengths over the render to find a line narrower
 * than their spacing (docs/architecture.md, "Caustics seen through specular
 * surfaces"). */
static int scene_disperses_lines(const GpuScene *g)
{
    int disp;
    scene_turns_light_ex(g, &disp);
    return disp && g->line_spectrum;
}

/* Whether the light-tracing pass runs (--caustics): on, or auto and the scene
 * has a light (an emitter, a punctual light, or an --env map that the light
 * selection holds; not a uniform sky, whose light through glass the camera
 * paths keep) and a
 * triangle whose surface has a delta lobe that passes or turns light
 * (material_turns_light). It needs a perspective camera (pinhole or thin
 * lens). */
int light_plan_runs(const RenderSettings *rs, const RenderLights *L, const GpuScene *g,
                    const SceneCamera *cam, int warn)
{
    if (rs->caustics == SPT_SWITCH_OFF)
        return 0;
    /* Light paths splat XYZ into the image only: the spectral bands and the
     * variance layer are made of camera samples, which then carry every
     * path (caustics included) themselves. */
    if (rs->spectral > 0 || (rs->aov & SPT_AOV_VARIANCE)) {
        if (rs->caustics == SPT_SWITCH_ON && warn)
            spt_warn("--caustics on: the light-tracing pass adds to the image only, not to %s; "
                     "rendering without it", rs->spectral > 0 ? "--spectral's bands" : "the variance layer");
        return 0;
    }
    if (cam->orthographic) {
        if (rs->caustics == SPT_SWITCH_ON && warn)
            spt_warn("--caustics on: the light-tracing pass needs a perspective camera (this one is "
                     "orthographic); rendering without it");
        return 0;
    }
    if (rs->caustics == SPT_SWITCH_ON)
        return 1;
    if (g->emitter_count == 0 && g->light_count == 0 && L &&
        !(L->env.env.kind == SPT_ENV_MAP && L->env_prob > 0.0f))
        return 0;
    return scene_turns_light(g);
}

int light_plan_merges(const RenderSettings *rs, const GpuScene *g)
{
    if (rs->merge == SPT_SWITCH_OFF || rs->caustics == SPT_SWITCH_OFF || rs->spectral > 0 ||
        (rs->aov & SPT_AOV_VARIANCE))
        return 0;
    if (rs->merge == SPT_SWITCH_ON)
        return 1;
    int disperses; /* one scan of the triangles' materials for both */
    return scene_turns_light_ex(g, &disperses) && !(disperses && g->line_spectrum);
}

uint32_t light_plan_max_paths(const RenderSettings *rs)
{
    double r = rs->light_paths > 0.0f ? (double)rs->light_paths : SPT_LIGHT_PATHS_DEFAULT;
    double n = floor(fmin(r, SPT_LIGHT_PATHS_MAX) * (double)rs->width * (double)rs->height + 0.5);
    return n < 1.0 ? 1u : (uint32_t)n;
}

/* Photon merging's initial radius (kernels/integrator/photon_grid.h):
 * SPT_PM_R0_PIXELS pixel footprints (p->cam_fwd[3], a pixel's angle) at the
 * distance of the nearest caustic sphere, where the surfaces seen through
 * glass or in a mirror are. */
static float merge_radius(const RenderParams *p)
{
    const float *c = p->cam_pos;
    double dist = 0.0;
    for (uint32_t k = 0; k < p->caustic_count; k++) {
        const float *s = p->caustic + 4 * k;
        double dx = s[0] - c[0], dy = s[1] - c[1], dz = s[2] - c[2];
        double d = fmax(sqrt(dx * dx + dy * dy + dz * dz), (double)s[3]);
        dist = k == 0 || d < dist ? d : dist;
    }
    if (!(dist > 0.0))
        dist = p->scene_radius;
    return (float)(SPT_PM_R0_PIXELS * (double)p->cam_fwd[3] * dist);
}

void light_plan(RenderParams *p, const RenderLights *L, const GpuScene *g, const SceneCamera *cam,
                const RenderSettings *rs)
{
    caustic_bounds(p, g);
    if (rs->merge == SPT_SWITCH_ON && !light_plan_runs(rs, L, g, cam, 0))
        spt_warn("--merge on: photon merging needs the light-tracing pass (--caustics), which does not run "
                 "here; rendering without it");
    else if (rs->merge == SPT_SWITCH_ON && scene_disperses_lines(g))
        spt_warn("--merge on: the scene has dispersive glass and a light with a line spectrum, whose lines "
                 "the one hero wavelength per sample index that merging leaves through that glass may "
                 "miss (docs/architecture.md, \"Caustics seen through specular surfaces\"); --merge auto "
                 "leaves it to the camera paths");
    /* rs->light_paths (0: the default) light paths per camera path, times
     * caustic_share: that many times the pixels per sample index, rounded, at
     * least one. */
    if (light_plan_runs(rs, L, g, cam, 1)) {
        double r = rs->light_paths > 0.0f ? (double)rs->light_paths : SPT_LIGHT_PATHS_DEFAULT;
        double n = floor(fmin(r, SPT_LIGHT_PATHS_MAX) * caustic_share(p, L, g) * (double)rs->width *
                             (double)rs->height +
                         0.5);
        p->light_paths = n < 1.0 ? 1u : (uint32_t)n;
        /* Photon merging: its buffers hold light_plan_max_paths. */
        if (light_plan_merges(rs, g)) {
            if (p->light_paths > light_plan_max_paths(rs))
                p->light_paths = light_plan_max_paths(rs);
            p->merge = 1;
            p->pm_r0 = merge_radius(p);
        }
    }
}
