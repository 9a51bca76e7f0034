/* Surface shading of the wavefront kernels (kernels/integrator/wavefront.cl):
 * shade_path cut into the steps of a surface hit (miss, alpha, emission,
 * direct light, BSDF bounce, Russian roulette), over the material evaluation
 * of kernels/material/material_eval.h. The steps take the kernel's buffers as
 * kg (kernels/integrator/kernel_globals.h). */
#ifndef SPT_SHADE_SURFACE_H
#define SPT_SHADE_SURFACE_H

#include "util/portable.h"
#include "util/vecmath.h"
#include "util/render_types.h"
#include "sample/rng.h"
#include "sample/sampling.h"
#include "closure/bsdf.h"
#include "light/lights.h"
#include "light/light_tree.h"
#include "light/inst_lights.h"
#include "integrator/path.h"
#include "integrator/kernel_globals.h"
#include "material/material_eval.h"
#include "integrator/photon_merge.h"

SPT_DEVICE_ONLY

/* Segments after which a path ends whatever its throughput (a guard; Russian
 * roulette ends paths long before). */
#define SPT_MAX_SEGMENTS 1024u

/* shade_path's steps, in the order it runs them (as Cycles' shade_surface):
 * the miss, the hit's geometry, alpha, emission, the shading frame, direct light,
 * the BSDF bounce and Russian roulette. What they share: */
typedef struct ShadeHit {
    uint i;           /* the path */
    uint prim;        /* the hit triangle (packed index) */
    uint inst;        /* its instance (ps_inst), or SPT_NO_INST */
    uint depth;       /* segments including the one just traced */
    float4 hit;       /* ps_hit: t, barycentrics, prim */
    float4 lam;       /* the path's wavelengths */
    float4 beta;      /* its throughput */
    float4 L;         /* its radiance so far */
    float3 rd;        /* the ray's direction */
    vec3 v0, v1, v2;  /* the triangle */
    float bu, bv;     /* barycentrics of the hit */
    float3 p;         /* the hit point */
    float3 ng;        /* the face normal (winding) */
    int front;        /* the ray arrived on the front face */
    TriShade ts;
    const __global GpuMaterial *m;
    float cone_w;     /* the ray cone's width at the hit */
} ShadeHit;

/* The local frame at the hit that the material's BSDF is evaluated in. (The
 * texture footprint TexCtx and the BsdfParams travel beside these structs, as
 * their own variables: their addresses go to functions that may not be
 * inlined, and only they should then live in memory.) */
typedef struct ShadeFrame {
    int two_sided_bsdf; /* transmissive: +z is the outside whichever side the path is on */
    int both_sides;     /* the BSDF sends light to both sides (two_sided_bsdf, or
                           KHR_materials_diffuse_transmission) */
    float3 ngf;         /* the face normal on the side the BSDF's +z is on */
    float3 ns, tg, bt;  /* the shading normal and its tangent basis */
    float3 wo_l;        /* the direction to the previous vertex, local */
    float wo_side;      /* its side of the face */
    SptSampler smp;     /* the path's sample: its dims (kernels/sample/rng.h) */
    uint key;           /* smp.rand_key: spt_rand_key(key, d) = spt_rand(seed, pixel, sample, d),
                           for dims the sampler does not serve */
    uint bounce;
    int drawn;          /* u holds the bounce's dims (shade_draw_bounce) */
    float u[SPT_DIM_BOUNCE_BLOCK];
} ShadeFrame;

/* All dims of bounce `bounce` of smp's sample at once, into u, where the
 * sampler is the Sobol one (spt_sample_bounce: the same numbers as one at a
 * time, in a fraction of the instructions); returns whether it drew them.
 * shade_take_bounce gives them to the frame, whose shade_u and shade_u2 read
 * them. */
SPT_FN_INLINE int shade_draw_bounce(SptSampler smp, uint bounce, float u[SPT_DIM_BOUNCE_BLOCK])
{
    if (smp.kind != SPT_SAMPLER_SOBOL)
        return 0;
    spt_sample_bounce(smp.pixel_key, smp.sample, bounce, u);
    return 1;
}

SPT_FN_INLINE void shade_take_bounce(ShadeFrame *f, int drawn, const float u[SPT_DIM_BOUNCE_BLOCK])
{
    f->drawn = drawn;
    for (uint k = 0u; k < SPT_DIM_BOUNCE_BLOCK; k++)
        f->u[k] = u[k];
}

/* Dim k (SPT_DIM_LIGHT_SELECT ...) of f's bounce. */
SPT_FN_INLINE float shade_u(const ShadeFrame *f, uint k)
{
    return f->drawn ? f->u[k] : spt_sampler_1d(f->smp, spt_dim_bounce(f->bounce, k));
}

/* Dims k and k + 1 (k even) of f's bounce. */
SPT_FN_INLINE void shade_u2(const ShadeFrame *f, uint k, float *u0, float *u1)
{
    if (f->drawn) {
        *u0 = f->u[k];
        *u1 = f->u[k + 1u];
    } else {
        spt_sampler_pair(f->smp, spt_dim_bounce(f->bounce, k), u0, u1);
    }
}

/* The camera paths' share of the path space beside the light-tracing pass
 * (kernels/integrator/light_trace.h), which owns the paths camera - x1 - ... - xk -
 * light whose first vertex x1 took a non-delta lobe and whose last vertex xk
 * took a delta lobe, the light an emissive triangle of the light selection,
 * an environment map when the selection holds it, or a punctual light (which
 * camera paths never reach). ps_lt keeps SPT_LT_CHAIN once x1 took a
 * non-delta lobe and SPT_LT_SPEC while the last vertex took a delta one:
 * lt_camera_next is the state after the vertex at depth `depth` sampled its
 * lobe; lt_camera_drops says whether emission of triangle prim reached with
 * state lt is the light-tracing pass's, lt_camera_drops_env the same for the
 * environment seen by a ray that left the scene (a map only: a uniform sky,
 * which every BSDF sample through glass sees, stays the camera paths').
 * With the pass off (params.light_paths 0) every camera path keeps everything. */
SPT_FN_INLINE uint lt_camera_next(uint lt, uint depth, int is_delta)
{
    uint chain = depth == 1u ? (is_delta ? 0u : SPT_LT_CHAIN) : (lt & SPT_LT_CHAIN);
    return chain | (is_delta ? SPT_LT_SPEC : 0u);
}

/* The light selection's entry of instance inst (kernels/light/inst_lights.h):
 * SPT_INST_LIGHT_NONE unless its mesh emits (then its triangles' tri_light_pdf
 * is their probability in the mesh's distribution). */
SPT_FN_INLINE uint inst_emitter(uint inst, const KernelGlobals *kg)
{
    return SPT_HAS_INSTANCES(kg->p) && kg->p->emitter_count > kg->p->tri_emitters && inst != SPT_NO_INST
               ? kg->inst_light[inst]
               : SPT_INST_LIGHT_NONE;
}

SPT_FN_INLINE int lt_camera_drops(uint lt, uint prim, uint inst, const KernelGlobals *kg)
{
    if (!(kg->p->light_paths > 0u && (lt & (SPT_LT_CHAIN | SPT_LT_SPEC)) == (SPT_LT_CHAIN | SPT_LT_SPEC) && kg->tri_light_pdf[prim] > 0.0f))
        return 0;
    /* An instance's triangle is in the selection when the instance is. */
    uint e = inst_emitter(inst, kg);
    return e == SPT_INST_LIGHT_NONE || spt_discrete_pdf(kg->light_cdf, e) > 0.0f;
}

/* The probability that next-event estimation at the vertex a ray left picks
 * instance entry e (its point and normal in ctx, ps_light_ctx, with the
 * tree): by power, or the tree's share times the tree's pick of its leaf. */
SPT_FN_INLINE float inst_entry_prob(uint e, float4 ctx, const KernelGlobals *kg)
{
    if (kg->p->tree_nodes == 0u)
        return spt_discrete_pdf(kg->light_cdf, e);
    uint leaf = inst_light_leaf(kg->inst_light, kg->p->inst_count, e - kg->p->tri_emitters);
    if (leaf == SPT_TREE_NONE)
        return 0.0f;
    spt_i32 ts;
    vec3 n = light_ctx_normal(ctx.w, &ts);
    return spt_discrete_pdf(kg->light_cdf + kg->p->aside_offset, 0u) *
           light_tree_pmf(kg->light_tree, leaf, ctx.xyz, n, ts);
}

SPT_FN_INLINE int lt_camera_drops_env(uint lt, const KernelGlobals *kg)
{
    return kg->p->light_paths > 0u && (lt & (SPT_LT_CHAIN | SPT_LT_SPEC)) == (SPT_LT_CHAIN | SPT_LT_SPEC) &&
           kg->p->env_prob > 0.0f && kg->p->env.kind == SPT_ENV_MAP;
}

/* A path that left the scene sees the environment, weighted against light
 * sampling by MIS; it ends. Left through a delta vertex on a path whose first
 * vertex was non-delta, the light-tracing pass counts it instead (no light
 * sample covers a delta vertex's direction, so that escape has MIS weight 1:
 * all of it is the pass's). */
SPT_FN_INLINE void shade_miss(uint i, float4 lam, float4 beta, const KernelGlobals *kg)
{
    int drop = lt_camera_drops_env(kg->ps_lt[i], kg);
#ifdef SPT_MERGE
    /* camera - S+ - D - S+ - map: photon merging's (photon_merge.h). */
    drop = drop || pm_camera_drops(kg->ps_lt[i], 1, 0u, kg);
#endif
    if (kg->p->env.kind != SPT_ENV_NONE && !drop) {
        float3 d = kg->ps_ray_d[i].xyz;
        float la[4], le[4];
        lambda_array(lam, la);
        env_eval(&kg->p->env, kg->env_data, d, la, le);
        float w = 1.0f;
        float prev_pdf = kg->ps_bsdf_pdf[i];
        /* The uniform sky's light-sampling density depends on the normal of the
         * vertex the ray left, so shade_path kept it (ps_env_pdf); a map's
         * depends on the direction only. */
        if (prev_pdf > 0.0f && kg->p->env_prob > 0.0f)
            w = spt_power_heuristic(prev_pdf, kg->p->env.kind == SPT_ENV_UNIFORM
                                                  ? kg->ps_env_pdf[i]
                                                  : kg->p->env_prob *
                                                        env_pdf(&kg->p->env, kg->env_data, d));
        kg->ps_radiance[i] += beta * (float4)(le[0], le[1], le[2], le[3]) * w;
    }
    kg->ps_flags[i] = SPT_PATH_FINISHED;
}

/* The geometry and material of the hit, and its texture footprint tc. */
SPT_FN_INLINE void shade_hit_geometry(ShadeHit *h, TexCtx *tc, const KernelGlobals *kg)
{
    uint i = h->i;
    h->L = kg->ps_radiance[i];
    h->rd = kg->ps_ray_d[i].xyz;
    tri_world(kg->tri_shade, kg->vtx_pos, kg->tlas_inst, h->inst, h->prim, &h->v0, &h->v1, &h->v2);
    h->bu = h->hit.y;
    h->bv = h->hit.z;
    h->p = (1.0f - h->bu - h->bv) * h->v0 + h->bu * h->v1 + h->bv * h->v2;
    h->ng = v3_unit(cross(h->v1 - h->v0, h->v2 - h->v0));
    if (h->inst != SPT_NO_INST && (kg->tlas_inst[h->inst].flags & BVH_INSTANCE_MIRRORED))
        h->ng = -h->ng;
    h->front = dot(h->ng, h->rd) < 0.0f;
    h->ts = kg->tri_shade[h->prim];
    h->m = kg->materials + h->ts.material;
    /* The ray cone's width here: ray_d.w holds it at the last real vertex, and
     * ray_o.w the distance passed through alpha since. */
    h->cone_w = kg->ps_ray_d[i].w + kg->p->cam_fwd[3] * (h->hit.x + kg->ps_ray_o[i].w);
    TexCtx none = {{(float2)(0.0f), (float2)(0.0f)}, {(float2)(0.0f), (float2)(0.0f)},
                   {(float2)(0.0f), (float2)(0.0f)}};
    *tc = none;
    if (material_uses_uv(h->m))
        *tc = tex_ctx(h->m, h->prim, h->bu, h->bv, h->v0, h->v1, h->v2, h->ng, h->rd, h->cone_w,
                      kg->tri_shade, kg->vtx_uv, kg->vtx_uv1);
}

/* Cut-out (MASK) and blended (BLEND) surfaces: with probability 1 - opacity the
 * path passes through unchanged, without counting a segment. Returns 1 when it
 * does (its ray now starts past the surface). The coin: with use_smp, for the
 * first surface met since the path's last real vertex (ray_o.w, the distance
 * passed through such surfaces, is still 0: every pass adds a positive
 * distance), dim SPT_DIM_ALPHA of this bounce from the path's sampler, so a
 * pixel's samples cover a blended surface's opacity evenly; otherwise, and for
 * further surfaces, the hashed numbers of (seed, pixel, sample). */
SPT_FN_INLINE int shade_alpha_with(const ShadeHit *h, const TexCtx *tc, int use_smp, SptSampler smp, uint seed,
                                   uint pixel, uint sample, const KernelGlobals *kg)
{
    const __global GpuMaterial *m = h->m;
    uint i = h->i;
    if (!(m->flags & (SPT_MAT_ALPHA_MASK | SPT_MAT_ALPHA_BLEND)))
        return 0;
    float op = material_opacity(m, tc, h->prim, h->bu, h->bv, kg->tri_shade, kg->vtx_color, kg->textures,
                                kg->texels);
    uint passes = kg->ps_passes[i];
    if (op < 1.0f && passes < 64u) {
        float4 o = kg->ps_ray_o[i];
        float u = use_smp && o.w == 0.0f ? spt_sampler_1d(smp, spt_dim_bounce(h->depth - 1u, SPT_DIM_ALPHA))
                                         : spt_rand(seed ^ 0x9e3779b9u, pixel, sample, h->depth * 64u + passes);
        if (u >= op) {
            kg->ps_passes[i] = passes + 1u;
            /* w carries the distance from the last real vertex, for MIS. */
            float3 o2 = offset_origin(h->p, h->front ? -h->ng : h->ng);
            kg->ps_ray_o[i] = (float4)(o2, o.w + dot(o2 - o.xyz, h->rd));
            kg->ps_throughput[i] = h->beta;
            return 1; /* same direction, depth and MIS state */
        }
    }
    return 0;
}

/* shade_alpha_with on the hashed numbers alone (the light paths'). */
SPT_FN_INLINE int shade_alpha(const ShadeHit *h, const TexCtx *tc, uint seed, uint pixel, uint sample,
                              const KernelGlobals *kg)
{
    SptSampler none = {0u, 0u, 0u, 0u};
    return shade_alpha_with(h, tc, 0, none, seed, pixel, sample, kg);
}

/* Emission on the front face, weighted against light sampling by MIS. */
SPT_FN_INLINE void shade_emission(ShadeHit *h, const TexCtx *tc, const KernelGlobals *kg)
{
    const __global GpuMaterial *m = h->m;
    uint i = h->i;
    if (!((m->flags & SPT_MAT_EMISSIVE) && (h->front || (m->flags & SPT_MAT_DOUBLE_SIDED_EMISSION))))
        return;
    /* Light reached through a delta vertex on a path whose first vertex was
     * non-delta: the light-tracing pass counts those paths
     * (kernels/integrator/light_trace.h). */
    if (lt_camera_drops(kg->ps_lt[i], h->prim, h->inst, kg))
        return;
#ifdef SPT_MERGE
    /* camera - S+ - D - S+ - light: photon merging's (photon_merge.h). */
    if (pm_camera_drops(kg->ps_lt[i], 0, h->prim, kg))
        return;
#endif
    float4 le = material_emission(m, tc, h->lam, fabs(dot(h->ng, h->rd)), h->prim, h->bu, h->bv,
                                  kg->tri_shade, kg->vtx_color, kg->spectra, kg->textures, kg->texels);
    float w = 1.0f;
    float prev_pdf = kg->ps_bsdf_pdf[i];
    if (prev_pdf > 0.0f) {
        float cos_l = fabs(dot(h->ng, h->rd));
        float dist = h->hit.x + kg->ps_ray_o[i].w; /* w: distance passed through alpha */
        float light_pdf = kg->tri_light_pdf[h->prim] * dist * dist / fmax(cos_l, 1e-8f);
        uint e = inst_emitter(h->inst, kg);
        if (e != SPT_INST_LIGHT_NONE) {
            /* An instance's triangle: P(its entry) p(triangle) per placed area. */
            float area = 0.5f * length(cross(h->v1 - h->v0, h->v2 - h->v0));
            light_pdf = area > 0.0f ? inst_entry_prob(e, kg->ps_light_ctx[i], kg) * light_pdf / area : 0.0f;
        } else if (kg->p->tree_nodes > 0u) {
            /* With the light tree, the pick's probability at the vertex the ray
             * left (its point and normal kept in ps_light_ctx). */
            float4 c = kg->ps_light_ctx[i];
            spt_i32 ts;
            vec3 n = light_ctx_normal(c.w, &ts);
            light_pdf *= light_tree_pmf(kg->light_tree, kg->tri_light_leaf[h->prim], c.xyz, n, ts);
        }
        w = spt_power_heuristic(prev_pdf, light_pdf);
    }
    h->L += h->beta * le * w;
}

/* The shading frame. A transmissive surface keeps its outside (the winding's
 * front) as +z, so the BSDF knows which side the path is on; an opaque one is
 * shaded from whichever side the path arrives. */
SPT_FN_INLINE void shade_frame(const ShadeHit *h, const TexCtx *tc, BsdfParams *bp, ShadeFrame *f,
                               SptSampler smp, const KernelGlobals *kg)
{
    const __global GpuMaterial *m = h->m;
    uint prim = h->prim;
    *bp = material_bsdf(m, tc, prim, h->bu, h->bv, h->lam, kg->tri_shade, kg->vtx_color, kg->spectra,
                        kg->textures, kg->texels);
    f->two_sided_bsdf = bp->transmission > 0.0f && bp->metallic < 1.0f;
    float3 ngf = h->ng, n_coat;
    float3 ns = shading_normal(prim, h->bu, h->bv, &ngf, f->two_sided_bsdf, h->v0, h->v1, h->v2, m, tc,
                               &n_coat, kg->tri_shade, kg->vtx_normal, kg->vtx_uv, kg->vtx_uv1,
                               kg->vtx_tangent, kg->textures, kg->texels, kg->tlas_inst, h->inst);
    if (!f->two_sided_bsdf && !h->front) {
        ns = -ns;
        n_coat = -n_coat;
        ngf = -h->ng;
    }
    float3 wo = -h->rd;
    /* A shading normal that puts wo on the other side than the face does is not
     * used (it would leak light through the surface). */
    if (dot(wo, ns) * dot(wo, ngf) <= 0.0f)
        ns = ngf;
    vec3 tg, bt;
    v3_basis(ns, &tg, &bt);
    f->wo_l = (float3)(dot(wo, tg), dot(wo, bt), dot(wo, ns));
    f->both_sides = f->two_sided_bsdf || (bsdf_has_dt(bp) && bp->metallic < 1.0f);
    if (bsdf_has_aniso(bp))
        bp->aniso_t = aniso_direction(m, bp->aniso_t, ns, h->ng, tg, bt, prim, h->bu, h->bv, h->v0, h->v1, h->v2,
                                      kg->tri_shade, kg->vtx_normal, kg->vtx_uv, kg->vtx_uv1, kg->vtx_tangent,
                                      kg->tlas_inst, h->inst);
    if (bp->clearcoat > 0.0f) {
        if (dot(wo, n_coat) * dot(wo, ngf) <= 0.0f)
            n_coat = ngf;
        bp->cc_n = normalize((float3)(dot(n_coat, tg), dot(n_coat, bt), dot(n_coat, ns)));
    }
    f->wo_side = dot(wo, ngf);
    f->ngf = ngf;
    f->ns = ns;
    f->tg = tg;
    f->bt = bt;
    f->bounce = h->depth - 1u;
    f->smp = smp;
    f->key = smp.rand_key;
    f->drawn = 0;
}

/* Next-event estimation's emitter entry e when it is an instance's
 * (kernels/light/inst_lights.h; prob: the entry's probability, u the
 * triangle's random number): a triangle of its mesh placed by the instance,
 * a, b, c, its unit normal nl as the instance turns it, and *pl, P(entry)
 * p(triangle) per placed area. Returns the triangle (packed index), or 0
 * with zero vertices and *pl 0 where the mesh has none. Out of line,
 * so that the triangles' case keeps its registers (docs/performance.md,
 * "Instances: two levels"). */
static uint inst_emitter_triangle(uint e, float prob, float u, const KernelGlobals *kg, float3 *a, float3 *b,
                                  float3 *c, float3 *nl, float *pl)
{
    float pt;
    uint k = kg->emitters[e];
    uint lt = inst_light_pick(kg->inst_light, kg->light_cdf, kg->p->inst_count, e - kg->p->tri_emitters, u, &pt);
    *pl = 0.0f;
    if (lt == SPT_INST_LIGHT_NONE) {
        *a = *b = *c = *nl = (float3)(0.0f);
        return 0u;
    }
    tri_world(kg->tri_shade, kg->vtx_pos, kg->tlas_inst, k, lt, a, b, c);
    float3 cr = cross(*b - *a, *c - *a);
    *nl = v3_unit(cr);
    float area = 0.5f * length(cr);
    *pl = area > 0.0f ? prob * pt / area : 0.0f;
    if (kg->tlas_inst[k].flags & BVH_INSTANCE_MIRRORED)
        *nl = -*nl;
    return lt;
}

/* Next-event estimation: one light chosen (by usel, the bounce's
 * SPT_DIM_LIGHT_SELECT) in proportion to power among the
 * emissive triangles, the punctual lights and the environment, or with the
 * light tree (kernels/light/light_tree.h) by importance at p among the first
 * two, beside the others by power. Returns 1 and
 * fills the shadow ray (origin, direction with tmax in w, contribution) when the
 * light's contribution is not zero. */
SPT_FN_INLINE int shade_direct_light(const ShadeHit *h, const TexCtx *tc, const BsdfParams *bp,
                                     const ShadeFrame *f, float usel, float4 *sh_o, float4 *sh_d,
                                     float4 *sh_c, const KernelGlobals *kg)
{
    uint depth = h->depth, bounce = f->bounce;
    float4 lam = h->lam;
    float3 p = h->p, ngf = f->ngf, tg = f->tg, bt = f->bt, ns = f->ns, wo_l = f->wo_l;
    if (!(kg->p->select_count > 0u && (kg->p->max_depth <= 0 || depth + 1u <= (uint)kg->p->max_depth) &&
          !bsdf_is_delta(bp)))
        return 0;
    float prob, ul, vl;
    shade_u2(f, SPT_DIM_LIGHT_U, &ul, &vl);
    /* tree_prob: the light tree's share of prob for an emitter it picked
     * (tri_light_pdf holds the rest of its pdf), 1 otherwise. */
    float tree_prob = 1.0f;
    int e;
    if (kg->p->tree_nodes > 0u) {
        spt_i32 ts;
        float pk = light_ctx_pack(ngf, f->two_sided_bsdf);
        vec3 n = light_ctx_normal(pk, &ts);
        e = light_tree_pick(kg->light_cdf + kg->p->aside_offset, kg->p->aside_count, kg->light_tree,
                            kg->p->emitter_count, p, n, ts, usel, &prob, &tree_prob);
    } else {
        e = spt_discrete_sample(kg->light_cdf, kg->p->select_count, usel, &prob, 0);
    }
    float3 wi = (float3)(0.0f, 0.0f, 1.0f);
    float dist = 0.0f, light_pdf = 0.0f;
    float4 le = (float4)(0.0f);
    int delta = 0;
    if (e >= 0 && (uint)e < kg->p->emitter_count) {
        /* A triangle: its probability per area pl, tri_light_pdf times the
         * tree's share; an instance's (inst_emitter_triangle) from its mesh. */
        vec3 a, b, c, nl;
        uint lt;
        float pl;
        vec3 bary = spt_sample_triangle_bary(ul, vl);
        if (!SPT_HAS_INSTANCES(kg->p) || (uint)e < kg->p->tri_emitters) {
            lt = kg->emitters[e];
            tri_positions(kg->tri_shade, kg->vtx_pos, lt, &a, &b, &c);
            nl = v3_unit(cross(b - a, c - a));
            pl = kg->tri_light_pdf[lt] * tree_prob;
        } else {
            lt = inst_emitter_triangle(
                (uint)e, prob, spt_rand_key(f->key, spt_dim_bounce(bounce, SPT_DIM_LIGHT_SELECT) | SPT_DIM_INST_TRI),
                kg, &a, &b, &c, &nl, &pl);
        }
        float3 q = bary.x * a + bary.y * b + bary.z * c;
        float3 dq = q - p;
        float dist2 = dot(dq, dq);
        dist = sqrt(dist2);
        wi = dq / dist;
        float cos_l = -dot(nl, wi);
        const __global GpuMaterial *lm = kg->materials + kg->tri_shade[lt].material;
        if (lm->flags & SPT_MAT_DOUBLE_SIDED_EMISSION)
            cos_l = fabs(cos_l);
        if (cos_l > 0.0f && dist > 0.0f && pl > 0.0f) {
            light_pdf = pl * dist2 / cos_l;
            /* The emitter's textures at their finest level (no footprint). */
            TexCtx ltc = *tc;
            if (material_uses_uv(lm))
                ltc = tex_ctx(lm, lt, bary.y, bary.z, a, b, c, nl, wi, 0.0f, kg->tri_shade, kg->vtx_uv,
                              kg->vtx_uv1);
            le = material_emission(lm, &ltc, lam, cos_l, lt, bary.y, bary.z, kg->tri_shade, kg->vtx_color,
                                   kg->spectra, kg->textures, kg->texels);
        }
    } else if (e >= 0 && (uint)e < kg->p->emitter_count + kg->p->light_count) {
        float la[4];
        lambda_array(lam, la);
        LightSample ls;
        light_punctual_sample(kg->lights + ((uint)e - kg->p->emitter_count), kg->spectra, p, la, &ls);
        wi = ls.wi;
        dist = ls.dist;
        le = (float4)(ls.value[0], ls.value[1], ls.value[2], ls.value[3]);
        light_pdf = prob;
        delta = 1;
    } else if (e >= 0) {
        float epdf;
        wi = env_sample_at(&kg->p->env, kg->env_data, ns, tg, bt, f->both_sides, ul, vl, &epdf);
        dist = SPT_LIGHT_FAR;
        light_pdf = prob * epdf;
        if (light_pdf > 0.0f) {
            float la[4], lv[4];
            lambda_array(lam, la);
            env_eval(&kg->p->env, kg->env_data, wi, la, lv);
            le = (float4)(lv[0], lv[1], lv[2], lv[3]);
        }
    }
    float wi_side = dot(wi, ngf);
    float3 wi_l = (float3)(dot(wi, tg), dot(wi, bt), dot(wi, ns));
    /* The geometric and shading sides of wi must agree. */
    if (light_pdf > 0.0f && dist > 0.0f && wi_side * wi_l.z > 0.0f && any_positive4(le) &&
        (f->both_sides || wi_side > 0.0f)) {
        float4 fv = bsdf_eval(bp, wo_l, wi_l);
        float wgt = delta ? 1.0f : spt_power_heuristic(light_pdf, bsdf_pdf(bp, wo_l, wi_l));
        float4 cn = h->beta * fv * le * (wgt / light_pdf);
        if (any_positive4(cn)) {
            float3 so = offset_origin(p, wi_side > 0.0f ? ngf : -ngf);
            *sh_o = (float4)(so, 0.0f);
            *sh_d = (float4)(wi, dist >= SPT_LIGHT_FAR ? SPT_LIGHT_FAR : dist * (1.0f - 1e-4f));
            *sh_c = cn;
            return 1;
        }
    }
    return 0;
}

/* BSDF sampling, the lobe chosen by ulobe (the bounce's SPT_DIM_BSDF_LOBE): the
 * next direction wn (world), its side of the face, whether it reflects;
 * h->beta takes the sample's weight. Returns whether the path goes on. */
SPT_FN_INLINE int shade_bsdf_bounce(ShadeHit *h, const BsdfParams *bp, const ShadeFrame *f, float ulobe,
                                    BsdfSample *bs, float3 *wn, float *wn_side, int *reflect,
                                    const KernelGlobals *kg)
{
    uint i = h->i;
    float ub, vb;
    shade_u2(f, SPT_DIM_BSDF_U, &ub, &vb);
    *bs = bsdf_sample(bp, f->wo_l, ulobe, ub, vb);
    *wn = bs->wi.x * f->tg + bs->wi.y * f->bt + bs->wi.z * f->ns;
    *wn_side = dot(*wn, f->ngf);
    /* Reflection stays on wo's side of the face, refraction crosses it. */
    *reflect = bs->wi.z * f->wo_l.z > 0.0f;
    int alive = bs->valid && (*reflect ? *wn_side * f->wo_side > 0.0f : *wn_side * f->wo_side < 0.0f);
    if (alive) {
        h->beta *= bs->weight;
#ifdef SPT_MERGE
        if (!pm_camera_hero(i, bs->dispersive, &h->beta, kg))
#endif
        {
            float4 lp = kg->ps_lambda_pdf[i];
            if (bs->dispersive && lp.y > 0.0f) {
                /* The refraction split the wavelengths: only the hero carries on
                 * (pbrt-v4's TerminateSecondary); its pdf becomes 1/4 of what it was. */
                lp = (float4)(0.25f * lp.x, 0.0f, 0.0f, 0.0f);
                kg->ps_lambda_pdf[i] = lp;
            }
            if (!(lp.y > 0.0f))
                h->beta = (float4)(h->beta.x, 0.0f, 0.0f, 0.0f);
        }
        alive = any_positive4(h->beta);
    }
    return alive;
}

/* The medium a path is in after crossing the surface of hit h toward wn (wn_side:
 * its side of f->ngf): entering or leaving a volume. A transmissive surface's
 * outside is +z (f->ngf); a diffuse transmitter's the winding's front, and it
 * bounds a volume only with KHR_materials_volume's thickness (docs/gltf.md:
 * thin-walled otherwise). */
SPT_FN_INLINE uint shade_medium_after(const ShadeHit *h, const ShadeFrame *f, float3 wn, float wn_side)
{
    const __global GpuMaterial *m = h->m;
    int absorbs = m->attenuation.kind != SPT_SPEC_NONE;
    if (f->two_sided_bsdf)
        return wn_side < 0.0f && absorbs ? h->ts.material + 1u : 0u;
    return dot(wn, h->ng) < 0.0f && absorbs && (m->flags & SPT_MAT_VOLUME) ? h->ts.material + 1u : 0u;
}

/* Russian roulette on the largest wavelength throughput, surviving with at
 * most 0.95 (as Mitsuba 3 does): a path whose throughput never drops (total
 * internal reflection inside a smooth sphere keeps it at exactly 1) must
 * still end. SPT_MAX_SEGMENTS bounds "unlimited" depth as a last resort.
 * Returns whether the path goes on (h->beta divided by its survival chance). */
SPT_FN_INLINE int shade_roulette(ShadeHit *h, const ShadeFrame *f, int alive, const KernelGlobals *kg)
{
    if (alive && h->depth >= SPT_MAX_SEGMENTS)
        alive = 0;
    if (alive && h->depth >= kg->p->rr_depth) {
        float qs = fmin(max4(h->beta), 0.95f);
        float u = shade_u(f, SPT_DIM_ROULETTE);
        if (u >= qs)
            alive = 0;
        else
            h->beta /= qs;
    }
    return alive;
}

#ifdef SPT_AOV
/* The AOVs of the sample of path i (aov_sample, 3 float4 per sample: see
 * kernels/util/render_types.h). The first hit gives the shading normal (on
 * the side the camera sees), the depth along the camera's view axis and the
 * position; the albedo is the first surface's that does not reflect or
 * transmit specularly only (through a mirror or clear glass, the albedo seen
 * behind it, as Open Image Denoise expects), or the last surface's when the
 * path ends there. */
SPT_FN_INLINE void shade_aov(const ShadeHit *h, const TexCtx *tc, const BsdfParams *bp, const ShadeFrame *f,
                             int ends, const KernelGlobals *kg)
{
    uint w = kg->ps_work[h->i];
    if (h->depth == 1u) {
        float3 fwd = normalize(vload4(0, kg->p->cam_fwd).xyz);
        float z = dot(h->p - vload4(0, kg->p->cam_pos).xyz, fwd);
        kg->aov_sample[3u * w + 1u] = (float4)(f->ns, z);
        kg->aov_sample[3u * w + 2u] = (float4)(h->p, 0.0f);
    }
    if (kg->aov_sample[3u * w].w == 0.0f && (ends || !bsdf_is_delta(bp))) {
        float3 a = material_albedo(h->m, tc, h->prim, h->bu, h->bv, kg->tri_shade, kg->vtx_color, kg->spectra,
                                   kg->textures, kg->texels);
        kg->aov_sample[3u * w] = (float4)(a, 1.0f);
    }
}
#endif

/* What path i brings to its hit (or miss): the hit, its depth, wavelengths, and
 * its throughput, through the volume it crossed. */
SPT_FN_INLINE void shade_hit_begin(uint i, ShadeHit *h, const KernelGlobals *kg)
{
    h->i = i;
    h->hit = kg->ps_hit[i];
    h->prim = as_uint(h->hit.w);
    h->inst = SPT_HAS_INSTANCES(kg->p) && h->prim != NO_HIT ? kg->ps_inst[i] : SPT_NO_INST;
    h->depth = kg->ps_depth[i] + 1u;
    h->lam = kg->ps_lambda[i];
    h->beta = kg->ps_throughput[i];
    uint medium = kg->ps_medium[i];
    if (medium != 0u && h->prim != NO_HIT)
        h->beta *= volume_transmittance(kg->materials + (medium - 1u), h->hit.x, h->lam, kg->spectra);
}

/* The sample a camera path draws its numbers from: its pixel, its sample
 * index and their sampler, the same at each of its segments. */
typedef struct PathSample {
    uint pixel, sample;
    SptSampler smp;
    /* The dims of bounce u_bounce, drawn ahead (path_sample_draw) where
     * drawn is set. */
    uint u_bounce;
    int drawn;
    float u[SPT_DIM_BOUNCE_BLOCK];
} PathSample;

/* The sample (pixel, sample index) of a camera path, and the sample of work
 * item w (w < light_begin). Through a pointer, not returned: an inlined
 * struct return leaves llvm.experimental.noalias.scope.decl in the
 * unoptimised code, which Oclgrind cannot run. */
SPT_FN_INLINE void path_sample_set(uint pixel, uint sample, SptSampler smp, PathSample *ps)
{
    ps->pixel = pixel;
    ps->sample = sample;
    ps->smp = smp;
    ps->drawn = 0;
    ps->u_bounce = 0u;
}

SPT_FN_INLINE void path_sample_of(uint w, PathSample *ps, const KernelGlobals *kg)
{
    uint npix = (uint)(kg->p->width * kg->p->height);
    uint pixel = w % npix;
    uint sample = kg->p->sample_begin + w / npix - kg->pixel_lag[pixel];
    path_sample_set(pixel, sample, spt_sampler_for(kg->p, pixel, sample), ps);
}

/* Draws the dims of the bounce path i shades next into ps, ahead of its
 * traversal: a bounce's draw is a chain of dependent 8-lane multiplies
 * (spt_sample_bounce), whose latency the traversal's independent work then
 * covers (docs/performance.md, "Instructions per segment"). */
SPT_FN_INLINE void path_sample_draw(uint i, PathSample *ps, const KernelGlobals *kg)
{
    ps->u_bounce = kg->ps_depth[i];
    ps->drawn = shade_draw_bounce(ps->smp, ps->u_bounce, ps->u);
}

/* Shades path i, of sample *ps, at its hit; returns 1 and fills the shadow ray
 * (origin, direction with tmax in w, contribution) when next-event estimation
 * wants one. k_paths keeps each path's PathSample from its start (its hashes
 * and divisions were 4% of the instructions of a segment's shading:
 * docs/performance.md, "Instructions per segment"); shade_path derives it. */
SPT_FN_INLINE int shade_path_of(uint i, const PathSample *ps, float4 *sh_o, float4 *sh_d, float4 *sh_c,
                                const KernelGlobals *kg)
{
    ShadeHit h;
    shade_hit_begin(i, &h, kg);
    if (h.prim == NO_HIT) {
        shade_miss(i, h.lam, h.beta, kg);
        return 0;
    }
    uint pixel = ps->pixel, sample = ps->sample;
    SptSampler smp = ps->smp;
    /* The bounce's numbers depend on the sample alone: drawn ahead
     * (path_sample_draw), or here before the hit's geometry, so that the
     * chains of their hashes run beside its loads. */
    float ub[SPT_DIM_BOUNCE_BLOCK];
    int drawn;
    if (ps->drawn && ps->u_bounce == h.depth - 1u) {
        drawn = 1;
        for (uint k = 0u; k < SPT_DIM_BOUNCE_BLOCK; k++)
            ub[k] = ps->u[k];
    } else {
        drawn = shade_draw_bounce(smp, h.depth - 1u, ub);
    }
    TexCtx tc;
    shade_hit_geometry(&h, &tc, kg);
    if (shade_alpha_with(&h, &tc, 1, smp, kg->p->seed, pixel, sample, kg))
        return 0;
    shade_emission(&h, &tc, kg);
    if ((kg->p->max_depth > 0 && h.depth >= (uint)kg->p->max_depth) || (h.m->flags & SPT_MAT_UNLIT)) {
#ifdef SPT_AOV
        {
            ShadeFrame fe;
            BsdfParams bpe;
            shade_frame(&h, &tc, &bpe, &fe, smp, kg);
            shade_aov(&h, &tc, &bpe, &fe, 1, kg);
        }
#endif
        kg->ps_radiance[i] = h.L;
        kg->ps_flags[i] = SPT_PATH_FINISHED;
        return 0;
    }
    ShadeFrame f;
    BsdfParams bp;
    shade_frame(&h, &tc, &bp, &f, smp, kg);
#ifdef SPT_AOV
    shade_aov(&h, &tc, &bp, &f, 0, kg);
#endif
    shade_take_bounce(&f, drawn, ub);
    float usel, ulobe;
    shade_u2(&f, SPT_DIM_LIGHT_SELECT, &usel, &ulobe);
    int shadow = shade_direct_light(&h, &tc, &bp, &f, usel, sh_o, sh_d, sh_c, kg);
#ifdef SPT_MERGE
    /* A surface with a non-delta lobe reached through delta vertices only
     * (one or more): the photons there (kernels/integrator/photon_merge.h). */
    if (kg->p->merge && h.depth >= 2u && !(kg->ps_lt[i] & SPT_PM_SEEN_D) && !bsdf_is_delta(&bp))
        h.L += h.beta * pm_gather(i, h.depth, h.p, f.ngf, f.tg, f.bt, f.ns, f.wo_l, f.both_sides, &bp, kg);
#endif
    BsdfSample bs;
    float3 wn;
    float wn_side;
    int reflect;
    int alive = shade_bsdf_bounce(&h, &bp, &f, ulobe, &bs, &wn, &wn_side, &reflect, kg);
    alive = shade_roulette(&h, &f, alive, kg);
    kg->ps_radiance[i] = h.L;
    if (!alive) {
        kg->ps_flags[i] = SPT_PATH_FINISHED;
        return shadow;
    }
    if (kg->p->light_paths > 0u) {
        uint lt = kg->ps_lt[i], lt_next = lt_camera_next(lt, h.depth, bs.is_delta);
#ifdef SPT_MERGE
        lt_next |= pm_camera_next(lt, bs.is_delta, !bsdf_is_delta(&bp)) & SPT_PM_BITS;
#endif
        kg->ps_lt[i] = lt_next;
    }
    if (!reflect && f.both_sides)
        kg->ps_medium[i] = shade_medium_after(&h, &f, wn, wn_side);
    kg->ps_throughput[i] = h.beta;
    kg->ps_ray_o[i] = (float4)(offset_origin(h.p, wn_side > 0.0f ? f.ngf : -f.ngf), 0.0f);
    kg->ps_ray_d[i] = (float4)(wn, h.cone_w);
    kg->ps_bsdf_pdf[i] = bs.is_delta ? 0.0f : bs.pdf;
    if (kg->p->tree_nodes > 0u && !bs.is_delta)
        kg->ps_light_ctx[i] = (float4)(h.p, light_ctx_pack(f.ngf, f.two_sided_bsdf));
    if (kg->p->env.kind == SPT_ENV_UNIFORM && !bs.is_delta)
        kg->ps_env_pdf[i] =
            kg->p->env_prob * env_pdf_at(&kg->p->env, kg->env_data, f.ns, f.both_sides, wn);
    kg->ps_depth[i] = h.depth;
    return shadow;
}

/* shade_path_of for a path whose sample is derived from its work item (the
 * stage kernels' k_shade). */
static int shade_path(uint i, float4 *sh_o, float4 *sh_d, float4 *sh_c, const KernelGlobals *kg)
{
    PathSample ps;
    path_sample_of(kg->ps_work[i], &ps, kg);
    return shade_path_of(i, &ps, sh_o, sh_d, sh_c, kg);
}

/* shade_path_of as one function for k_paths's two slots (inlined into each,
 * the shading's code would be there twice). */
static int shade_path_kept(uint i, const PathSample *ps, float4 *sh_o, float4 *sh_d, float4 *sh_c,
                           const KernelGlobals *kg)
{
    return shade_path_of(i, ps, sh_o, sh_d, sh_c, kg);
}

#endif
