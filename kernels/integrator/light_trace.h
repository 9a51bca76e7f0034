/* The light-tracing pass of the wavefront kernels (kernels/integrator/wavefront.cl),
 * on the shading steps of kernels/integrator/shade_surface.h: paths that start on the
 * lights and reach the camera through a shadow ray, for the caustics that
 * camera paths find badly (an area light or a map's sun seen through glass)
 * or never (a punctual light behind glass). docs/architecture.md, "Caustics",
 * has the method; in short:
 *
 * - Path space is split between the two techniques, so nothing counts twice.
 *   Name a path's vertices from the camera, camera - x1 - ... - xk - light,
 *   each by the lobe it took: D (non-delta) or S (delta). The light paths own
 *   the paths with x1 D and xk S (the light an emissive triangle of the light
 *   selection, an environment map when the selection holds it, or a punctual
 *   light; a uniform sky stays the camera paths'): from the light, one or
 *   more S vertices, then a D vertex, then anything, down to x1. A camera
 *   path drops exactly the emission it reaches that way, an emitter's or the
 *   map's seen by a ray that left the scene (lt_camera_drops and
 *   lt_camera_drops_env in
 *   kernels/integrator/shade_surface.h); punctual lights it never reaches. The
 *   camera paths keep the rest: x1 S (a light path cannot connect through a
 *   delta vertex), xk D (next-event estimation and MIS find those well), and
 *   emitters outside the light selection.
 * - A light path starts on a light picked by the renderer's light selection
 *   (by power), its first ray aimed at the caustic spheres, the bounding
 *   spheres of the surfaces that may be delta (one per material): an
 *   emissive triangle's or a point or spot light's within the cones the
 *   spheres subtend (lt_aim_dir; as the light emits when its point lies in
 *   or near a sphere), a directional light's or an environment map's from
 *   discs outside the scene that cover the spheres (lt_aim_parallel), its
 *   rays parallel to the light's direction or to a direction of the map's
 *   sampling density (a uniform sky's share ends it). It
 *   carries its own four wavelengths (a dispersive refraction keeps only the hero, as camera
 *   paths do), and samples the BSDFs with the camera paths' code (with the
 *   adjoint's factors: no 1/eta^2 of radiance transport, Veach's
 *   shading-normal correction) and Russian roulette. Its first vertex must
 *   take a delta lobe, else it ends (the camera paths own all that follows);
 *   after that it connects to the camera (pinhole or thin lens) at every
 *   vertex with a non-delta lobe, by a shadow ray whose splat goes to the
 *   pixel the vertex projects to, and goes on.
 * - The splat: the camera's importance for a pinhole whose image plane lies at
 *   distance 1 is W_e = 1 / (A_pixel cos^3 theta) within a pixel (a thin
 *   lens: the same at a uniform point of the lens), so a light
 *   vertex y with throughput beta adds beta f(to camera, to light) |cos_y| /
 *   r^2 W_e, and the N = light_paths light paths of each sample index are
 *   averaged: the film's sum over spp samples gains that over light_paths.
 * - With photon merging (kernels/integrator/photon_merge.h), a light path also
 *   leaves a photon at each vertex with a non-delta lobe (the first
 *   SPT_PM_PER_PATH of them), for camera paths that see that surface through
 *   glass or in a mirror.
 * - Determinism: light path k of sample index s (k < light_paths) takes its
 *   random numbers from (seed ^ SPT_LT_SALT, k, s), and its splats go to the
 *   light film as 64-bit fixed-point sums by integer atomics (rounded up or
 *   down at random, without bias): integer sums do not depend on the order of
 *   the atomics, so a chunk's image is the same whatever the schedule. */
#ifndef SPT_LIGHT_TRACE_H
#define SPT_LIGHT_TRACE_H

#include "util/portable.h"
#include "util/vecmath.h"
#include "util/render_types.h"
#include "sample/rng.h"
#include "sample/sampling.h"
#include "closure/bsdf.h"
#include "closure/delta.h"
#include "light/lights.h"
#include "light/inst_lights.h"
#include "integrator/path.h"
#include "integrator/kernel_globals.h"
#include "material/material_eval.h"
#include "integrator/shade_surface.h"
#include "integrator/photon_merge.h"

SPT_DEVICE_ONLY

#define SPT_LT_SALT 0x6c8e9cf5u

/* Light path work item w: its index among its sample's light paths and its
 * sample index. */
SPT_FN_INLINE void lt_item(uint w, uint *lp, uint *sample, const RenderParams *p)
{
    uint lw = w - p->light_begin;
    *lp = lw % p->light_paths;
    *sample = p->sample_begin + lw / p->light_paths;
}

/* 1 + the caustic spheres other than k that the line from o along d meets:
 * the cones (lt_aim_dir) or discs (lt_aim_parallel) that a ray aimed at
 * sphere k lies in. */
SPT_FN_INLINE float lt_spheres_met(const RenderParams *p, uint k, float3 o, float3 d)
{
    float c = 1.0f;
    for (uint j = 0u; j < p->caustic_count; j++)
        if (j != k && lt_meets_caustic(p, j, o, d))
            c += 1.0f;
    return c;
}

/* Caustic sphere k's share of the aim: its cone's solid angle from q over
 * total, the cones' sum (lt_aim_dir; the cone's span, 1 - cos of its
 * half-angle, in *span), or with disc set its disc's area over total, the
 * discs' sum of squared radii (lt_aim_parallel). */
SPT_FN_INLINE float lt_sphere_share(const RenderParams *p, uint k, float3 q, int disc, float total, float *span)
{
    if (disc)
        return p->caustic[4 * k + 3] * p->caustic[4 * k + 3] / total;
    *span = lt_caustic_span(p, k, q);
    return 2.0f * SPT_PI * *span / total;
}

/* The caustic sphere that u picks in proportion to the shares of
 * lt_sphere_share, and in *u_in where u lies within its share, in [0, 1). */
SPT_FN_INLINE uint lt_pick_sphere(const RenderParams *p, float3 q, int disc, float total, float u, float *u_in,
                                  float *span)
{
    uint n = p->caustic_count, k = 0u;
    float share = lt_sphere_share(p, 0u, q, disc, total, span), acc = 0.0f;
    while (k + 1u < n && u >= acc + share) {
        acc += share;
        k++;
        share = lt_sphere_share(p, k, q, disc, total, span);
    }
    *u_in = fmin(fmax((u - acc) / share, 0.0f), 0x1.fffffep-1f);
    return k;
}

/* A light path's first direction from q aimed at the caustic spheres, whose
 * cones from q have omega solid angle in all (lt_aim_cones): only a path whose
 * first vertex is a surface that may be delta goes on, and every ray that
 * meets one starts within one of those cones. A cone in proportion to its
 * solid angle (u1 picks it and is reused within it), then uniform within
 * it: the density of a direction is (the cones it lies in) / omega, and
 * *count is that number (at least the chosen cone). */
SPT_FN_INLINE float3 lt_aim_dir(const RenderParams *p, float3 q, float omega, float u1, float u2,
                                float *count)
{
    float span = 0.0f;
    uint k = lt_pick_sphere(p, q, 0, omega, u1, &u1, &span);
    float3 ax = normalize((float3)(p->caustic[4 * k + 0], p->caustic[4 * k + 1], p->caustic[4 * k + 2]) - q);
    float x = u1 * span; /* 1 - cos(theta) */
    float ct = 1.0f - x;
    float st = sqrt(fmax(0.0f, x * (2.0f - x)));
    float phi = 2.0f * SPT_PI * u2;
    vec3 t_, b_;
    v3_basis(ax, &t_, &b_);
    float3 d = st * cos(phi) * t_ + st * sin(phi) * b_ + ct * ax;
    *count = lt_spheres_met(p, k, q, normalize(d));
    return d;
}

/* Parallel light along ax toward the caustic spheres: a ray through a disc
 * perpendicular to ax covering one sphere (u0 picks it, in proportion to its
 * disc's area), at u1, u2 on that disc, starting outside the scene's bounding
 * sphere: its origin in *o; returns the discs' total area over the number of
 * discs the ray's line crosses (the weight of a ray of density 1 per area
 * over the discs, counted where they overlap). */
SPT_FN_INLINE float lt_aim_parallel(const RenderParams *p, float3 ax, float u0, float u1, float u2, float3 *o)
{
    float total = 0.0f, span = 0.0f, u_in;
    for (uint j = 0u; j < p->caustic_count; j++)
        total += p->caustic[4 * j + 3] * p->caustic[4 * j + 3];
    uint k = lt_pick_sphere(p, ax, 1, total, u0, &u_in, &span);
    vec3 t_, b_;
    v3_basis(ax, &t_, &b_);
    vec3 disk = spt_sample_concentric_disk(u1, u2);
    float3 c = (float3)(p->caustic[4 * k + 0], p->caustic[4 * k + 1], p->caustic[4 * k + 2]);
    float3 cs = (float3)(p->scene_center[0], p->scene_center[1], p->scene_center[2]);
    *o = c + p->caustic[4 * k + 3] * (disk.x * t_ + disk.y * b_) - ax * (p->scene_radius + length(c - cs));
    return SPT_PI * total / lt_spheres_met(p, k, *o, ax);
}

/* Starts light path i as work item w (w >= params.light_begin): its wavelengths,
 * its light, its first ray, and in ps_radiance the emitted power's weight (the
 * light's emission over the density of the start point and direction). Returns
 * the path's flags: SPT_PATH_ALIVE, or SPT_PATH_FINISHED when it carries
 * nothing (a zero sample, or a max_depth too small for any path it owns). */
SPT_FN_INLINE uint lt_start(uint i, uint w, const KernelGlobals *kg)
{
    uint lp, sample;
    lt_item(w, &lp, &sample, kg->p);
    uint key = spt_rng_key(kg->p->seed ^ SPT_LT_SALT, lp, sample);
    float4 lam, lpdf;
    /* With merging, the camera paths' wavelengths of this sample index. */
    spt_sample_wavelengths(pm_wavelength_u(spt_rand_key(key, SPT_DIM_WAVELENGTH), sample, kg), &lam, &lpdf);
    float prob = 0.0f;
    int e = -1;
    if (kg->p->select_count > 0u)
        e = spt_discrete_sample(kg->light_cdf, kg->p->select_count,
                                spt_rand_key(key, spt_dim_bounce(0u, SPT_DIM_LIGHT_SELECT)), &prob, 0);
    float u1 = spt_rand_key(key, spt_dim_bounce(0u, SPT_DIM_LIGHT_U));
    float u2 = spt_rand_key(key, spt_dim_bounce(0u, SPT_DIM_LIGHT_V));
    float u3 = spt_rand_key(key, spt_dim_bounce(0u, SPT_DIM_BSDF_U));
    float u4 = spt_rand_key(key, spt_dim_bounce(0u, SPT_DIM_BSDF_V));
    float u5 = spt_rand_key(key, spt_dim_bounce(0u, SPT_DIM_BSDF_LOBE));
    float3 o = (float3)(0.0f), d = (float3)(0.0f, 0.0f, 1.0f);
    float4 power = (float4)(0.0f);
    uint k = SPT_NO_INST, lt = 0u;
    if (SPT_HAS_INSTANCES(kg->p) && e >= 0 && (uint)e >= kg->p->tri_emitters && (uint)e < kg->p->emitter_count &&
        prob > 0.0f) {
        /* An instance: a triangle of its mesh (kernels/light/inst_lights.h),
         * picked with probability pt, placed by the instance. */
        float pt;
        k = kg->emitters[e];
        lt = inst_light_pick(kg->inst_light, kg->light_cdf, kg->p->inst_count, (uint)e - kg->p->tri_emitters,
                             spt_rand_key(key, spt_dim_bounce(0u, SPT_DIM_LIGHT_SELECT) | SPT_DIM_INST_TRI), &pt);
        if (lt == SPT_INST_LIGHT_NONE)
            e = -1;
        prob *= pt;
    }
    if (e >= 0 && (uint)e < kg->p->emitter_count && prob > 0.0f) {
        /* An emissive triangle: a uniform point, a cosine-weighted direction
         * (either side, with probability 1/2 each, when both emit). */
        vec3 a, b, c;
        if (k == SPT_NO_INST) {
            lt = kg->emitters[e];
            tri_positions(kg->tri_shade, kg->vtx_pos, lt, &a, &b, &c);
        } else {
            tri_world(kg->tri_shade, kg->vtx_pos, kg->tlas_inst, k, lt, &a, &b, &c);
        }
        vec3 bary = spt_sample_triangle_bary(u1, u2);
        float3 q = bary.x * a + bary.y * b + bary.z * c;
        float3 cr = cross(b - a, c - a);
        if (k != SPT_NO_INST && (kg->tlas_inst[k].flags & BVH_INSTANCE_MIRRORED))
            cr = -cr;
        float area2 = length(cr);
        const __global GpuMaterial *lm = kg->materials + kg->tri_shade[lt].material;
        float omega, cones;
        if (area2 > 0.0f && lt_aim_cones(kg->p, q, &omega)) {
            /* Aimed at the caustic spheres: the side the direction leaves by
             * (none when that side does not emit). */
            float3 dg = lt_aim_dir(kg->p, q, omega, u3, u4, &cones);
            float3 ng = cr / area2;
            float cn = dot(dg, ng);
            int two = (lm->flags & SPT_MAT_DOUBLE_SIDED_EMISSION) != 0;
            if (cn > 0.0f || (two && cn < 0.0f)) {
                float3 n = cn > 0.0f ? ng : -ng;
                d = dg;
                TexCtx ltc = {{(float2)(0.0f), (float2)(0.0f)}, {(float2)(0.0f), (float2)(0.0f)},
                              {(float2)(0.0f), (float2)(0.0f)}};
                if (material_uses_uv(lm))
                    ltc = tex_ctx(lm, lt, bary.y, bary.z, a, b, c, ng, d, 0.0f, kg->tri_shade, kg->vtx_uv,
                                  kg->vtx_uv1);
                float4 le = material_emission(lm, &ltc, lam, fabs(cn), lt, bary.y, bary.z, kg->tri_shade,
                                              kg->vtx_color, kg->spectra, kg->textures, kg->texels);
                /* Le cos / (prob / area  cones / omega) */
                power = le * (fabs(cn) * (omega / cones) * 0.5f * area2 / prob);
                o = offset_origin(q, n);
            }
        } else if (area2 > 0.0f) {
            float3 ng = cr / area2, n = ng;
            float side_p = 1.0f;
            if (lm->flags & SPT_MAT_DOUBLE_SIDED_EMISSION) {
                side_p = 0.5f;
                if (u5 < 0.5f)
                    n = -n;
            }
            vec3 t_, b_;
            v3_basis(n, &t_, &b_);
            vec3 l = spt_sample_cosine_hemisphere(u3, u4);
            if (l.z > 0.0f) {
                d = l.x * t_ + l.y * b_ + l.z * n;
                TexCtx ltc = {{(float2)(0.0f), (float2)(0.0f)}, {(float2)(0.0f), (float2)(0.0f)},
                              {(float2)(0.0f), (float2)(0.0f)}};
                if (material_uses_uv(lm))
                    ltc = tex_ctx(lm, lt, bary.y, bary.z, a, b, c, ng, d, 0.0f, kg->tri_shade, kg->vtx_uv,
                                  kg->vtx_uv1);
                float4 le = material_emission(lm, &ltc, lam, l.z, lt, bary.y, bary.z, kg->tri_shade,
                                              kg->vtx_color, kg->spectra, kg->textures, kg->texels);
                /* Le cos / (prob / area  side_p  cos / pi) */
                power = le * (0.5f * area2 * SPT_PI / (prob * side_p));
                o = offset_origin(q, n);
            }
        }
    } else if (e >= 0 && (uint)e < kg->p->emitter_count + kg->p->light_count && prob > 0.0f) {
        const __global GpuLight *l = kg->lights + ((uint)e - kg->p->emitter_count);
        float4 spd = (float4)(light_spec_value(l->spectrum, kg->spectra, lam.x),
                              light_spec_value(l->spectrum, kg->spectra, lam.y),
                              light_spec_value(l->spectrum, kg->spectra, lam.z),
                              light_spec_value(l->spectrum, kg->spectra, lam.w));
        float3 ax = (float3)(l->dir[0], l->dir[1], l->dir[2]);
        vec3 t_, b_;
        v3_basis(ax, &t_, &b_);
        float3 cs = (float3)(kg->p->scene_center[0], kg->p->scene_center[1], kg->p->scene_center[2]);
        float3 pos = (float3)(l->pos[0], l->pos[1], l->pos[2]);
        float omega, cones;
        if (l->type == SPT_PUNCTUAL_DIRECTIONAL) {
            /* Parallel rays through discs perpendicular to the light that
             * cover the caustic spheres (lt_aim_parallel), or without them
             * through a disc of the scene's radius, tangent to its bounding
             * sphere on the side the light comes from: E area / prob. */
            if (kg->p->caustic_count > 0u) {
                power = spd * (lt_aim_parallel(kg->p, ax, u1, u3, u4, &o) / prob);
            } else {
                float R = kg->p->scene_radius;
                vec3 disk = spt_sample_concentric_disk(u3, u4);
                o = cs + R * (disk.x * t_ + disk.y * b_) - ax * R;
                power = spd * (SPT_PI * R * R / prob);
            }
            d = ax;
        } else if (lt_aims_punctual(kg->p, l, &omega)) {
            /* Aimed at the caustic spheres: I falloff omega / (cones prob). */
            o = pos;
            d = normalize(lt_aim_dir(kg->p, pos, omega, u3, u4, &cones));
            power = spd * (light_spot_falloff(l, light_one_minus_cos(d, ax)) * (omega / cones) / prob);
        } else {
            o = pos;
            /* Point: uniform over the sphere; spot: uniform within the outer cone,
             * times its falloff. I / (prob pdf). In x = 1 - cos (GpuLight's
             * spot_span), whose sine sqrt(x (2 - x)) float keeps for the
             * narrowest cones. */
            float span = l->spot_span;
            if (span > 0.0f) {
                float x = u3 * span;
                float ct = 1.0f - x;
                float st = sqrt(fmax(0.0f, x * (2.0f - x)));
                float phi = 2.0f * SPT_PI * u4;
                d = st * cos(phi) * t_ + st * sin(phi) * b_ + ct * ax;
                power = spd * (light_spot_falloff(l, x) * 2.0f * SPT_PI * span / prob);
            }
        }
    } else if (e >= 0 && prob > 0.0f && kg->p->env.kind == SPT_ENV_MAP) {
        /* An environment map (a uniform sky's share ends the path: camera paths
         * find it through glass well, and keep it): a direction w toward the
         * sky by env_sample's density (the texels' luminance), then parallel
         * rays along -w through discs perpendicular to w that cover the
         * spheres of the surfaces that may be delta (lt_aim_parallel): a
         * light path goes on only from such a surface, and every ray that
         * meets one crosses one of those discs. The rays start outside the
         * scene's bounding sphere: L(w) area / (crossed prob pdf(w)). */
        float epdf;
        float3 w = normalize(env_sample(&kg->p->env, kg->env_data, u1, u2, &epdf));
        if (epdf > 0.0f && kg->p->caustic_count > 0u) {
            float la[4], lv[4];
            lambda_array(lam, la);
            env_eval(&kg->p->env, kg->env_data, w, la, lv);
            float area = lt_aim_parallel(kg->p, -w, u5, u3, u4, &o);
            d = -w;
            power = (float4)(lv[0], lv[1], lv[2], lv[3]) * (area / (prob * epdf));
        }
    }
    kg->ps_lambda[i] = lam;
    kg->ps_lambda_pdf[i] = lpdf;
    kg->ps_throughput[i] = (float4)(1.0f);
    kg->ps_radiance[i] = power;
    kg->ps_work[i] = w;
    kg->ps_depth[i] = 0;
    kg->ps_passes[i] = 0;
    kg->ps_medium[i] = 0;
    kg->ps_bsdf_pdf[i] = 0.0f;
    kg->ps_lt[i] = SPT_LT_LIGHT;
    kg->ps_ray_o[i] = (float4)(o, 0.0f);
    kg->ps_ray_d[i] = (float4)(normalize(d), 0.0f);
    /* The shortest path the pass owns has 3 segments (light, delta vertex,
     * x1, camera). */
    int too_short = kg->p->max_depth > 0 && kg->p->max_depth < 3;
    return any_positive4(power) && !too_short ? SPT_PATH_ALIVE : SPT_PATH_FINISHED;
}

/* Connects light vertex h (frame f, BSDF bp) to the camera, a pinhole or a
 * point of the thin lens (uniform over it, from lu, lv): fills the shadow ray
 * and its splat: the contribution's XYZ in sh_c's xyz and a uniform number u
 * for its rounding in w, the pixel in sh_o's w (as bits), for k_connect to add
 * to the light film when the ray is not blocked; returns 1, or 0 when the
 * camera does not see the vertex's side, the point projects outside the
 * image, or the contribution is zero (or not finite: counted as such). A camera ray leaves lens point l toward the
 * point cam + F d of the plane of focus (d = fwd + sx right + sy up, F the
 * focus distance; l = cam for the pinhole), so the vertex is seen in the
 * pixel of the d whose focus point lies on the line from l through it. The
 * importance is the pinhole's with theta at l: the lens point's density
 * cancels the lens's 1/A_lens. */
SPT_FN_INLINE int lt_connect(const ShadeHit *h, const BsdfParams *bp, const ShadeFrame *f, float lu, float lv,
                             float u, float4 *sh_o, float4 *sh_d, float4 *sh_c, const KernelGlobals *kg)
{
    float3 cam = (float3)(kg->p->cam_pos[0], kg->p->cam_pos[1], kg->p->cam_pos[2]);
    float3 fwd = (float3)(kg->p->cam_fwd[0], kg->p->cam_fwd[1], kg->p->cam_fwd[2]);
    float3 right = (float3)(kg->p->cam_right[0], kg->p->cam_right[1], kg->p->cam_right[2]);
    float3 up = (float3)(kg->p->cam_up[0], kg->p->cam_up[1], kg->p->cam_up[2]);
    float3 lens = cam;
    if (kg->p->lens_radius > 0.0f) {
        vec3 disk = spt_sample_concentric_disk(lu, lv);
        lens += kg->p->lens_radius * (disk.x * normalize(right) + disk.y * normalize(up));
    }
    float3 dv = lens - h->p;
    float r2 = dot(dv, dv);
    if (!(r2 > 0.0f))
        return 0;
    float r = sqrt(r2);
    float3 wc = dv / r;
    /* The camera ray's d (as k_generate's rays leave). */
    float cosc = -dot(wc, fwd);
    if (!(cosc > 0.0f))
        return 0;
    float3 q = -wc / cosc;
    if (kg->p->lens_radius > 0.0f)
        q = (lens - cam) / kg->p->focus_distance + q;
    float sx = dot(q, right) / dot(right, right), sy = dot(q, up) / dot(up, up);
    float fx = 0.5f * (sx + 1.0f) * (float)kg->p->width, fy = 0.5f * (1.0f - sy) * (float)kg->p->height;
    if (!(fx >= 0.0f && fx < (float)kg->p->width && fy >= 0.0f && fy < (float)kg->p->height))
        return 0;
    uint px = (uint)min((int)fx, kg->p->width - 1), py = (uint)min((int)fy, kg->p->height - 1);
    float wc_side = dot(wc, f->ngf);
    float3 wc_l = (float3)(dot(wc, f->tg), dot(wc, f->bt), dot(wc, f->ns));
    /* The geometric and shading sides must agree; an opaque surface is seen
     * only from the side the light arrived on. */
    if (!(wc_side * wc_l.z > 0.0f) || (!f->both_sides && !(wc_side > 0.0f)))
        return 0;
    /* f(to camera, to light) |cos at the light's side (shading)|, as a camera
     * path sees it. */
    float4 fv = bsdf_eval(bp, wc_l, f->wo_l);
    float a_film = 4.0f * length(right) * length(up);
    float npix = (float)(kg->p->width * kg->p->height);
    /* |cos_y| / r^2 toward the camera (geometric) over the light's arriving
     * geometric cosine, which the shading cosine in fv replaces (Veach's
     * adjoint with shading normals); W_e = npix / (A_film cos^3). */
    float g = fabs(wc_side) / (fmax(fabs(f->wo_side), 1e-8f) * r2);
    float we = npix / (a_film * cosc * cosc * cosc);
    float4 c = kg->ps_radiance[h->i] * h->beta * fv * (g * we / (float)kg->p->light_paths);
    if (!any_positive4(c))
        return 0;
    /* With the wavelengths' pdf of this vertex: a dispersive refraction after
     * it changes the path's. */
    float4 xyz = path_radiance_to_xyz(c, kg->ps_lambda[h->i], kg->ps_lambda_pdf[h->i]);
    if (!(isfinite(xyz.x) && isfinite(xyz.y) && isfinite(xyz.z))) {
        atomic_inc(&kg->counters[SPT_CNT_NAN]);
        return 0;
    }
    uint pixel = py * (uint)kg->p->width + px;
    *sh_o = (float4)(offset_origin(h->p, wc_side > 0.0f ? f->ngf : -f->ngf), as_float(pixel));
    *sh_d = (float4)(wc, r * (1.0f - 1e-4f));
    *sh_c = (float4)(fmax(xyz.x, 0.0f), fmax(xyz.y, 0.0f), fmax(xyz.z, 0.0f), u);
    return 1;
}

/* Shades light path i at its hit: at its first vertex only a delta lobe lets
 * it go on; at later ones it connects to the camera (when the BSDF has a
 * non-delta lobe) and samples the BSDF as a camera path does. Returns 1 and
 * fills the shadow ray when it connects. */
static int lt_shade(uint i, float4 *sh_o, float4 *sh_d, float4 *sh_c, const KernelGlobals *kg)
{
    ShadeHit h;
    shade_hit_begin(i, &h, kg);
    /* Ends here unless it goes on below. */
    kg->ps_flags[i] = SPT_PATH_FINISHED;
    if (h.prim == NO_HIT)
        return 0;
    TexCtx tc;
    shade_hit_geometry(&h, &tc, kg);
    /* Textures with the footprint a camera ray would have here. */
    float3 cam = (float3)(kg->p->cam_pos[0], kg->p->cam_pos[1], kg->p->cam_pos[2]);
    float dc = length(h.p - cam);
    h.cone_w = kg->p->cam_pos[3] + kg->p->cam_fwd[3] * dc;
    if (material_uses_uv(h.m) && dc > 0.0f)
        tc = tex_ctx(h.m, h.prim, h.bu, h.bv, h.v0, h.v1, h.v2, h.ng, (h.p - cam) / dc, h.cone_w, kg->tri_shade,
                     kg->vtx_uv, kg->vtx_uv1);
    uint lp, sample;
    lt_item(kg->ps_work[i], &lp, &sample, kg->p);
    kg->ps_flags[i] = SPT_PATH_ALIVE;
    if (shade_alpha(&h, &tc, kg->p->seed ^ SPT_LT_SALT, lp, sample, kg))
        return 0;
    kg->ps_flags[i] = SPT_PATH_FINISHED;
    /* A connection here makes a path of depth + 1 segments. */
    if ((kg->p->max_depth > 0 && h.depth + 1u > (uint)kg->p->max_depth) || (h.m->flags & SPT_MAT_UNLIT))
        return 0;
    ShadeFrame f;
    BsdfParams bp;
    /* Light paths take independent samples: a light path is not a pixel's. */
    shade_frame(&h, &tc, &bp, &f, spt_sampler(SPT_SAMPLER_INDEPENDENT, kg->p->seed ^ SPT_LT_SALT, lp, sample),
                kg);
    /* Vertex k of a light path takes the dimensions of bounce k (bounce 0 is
     * the start on the light). */
    f.bounce = h.depth;
    int past_delta = (kg->ps_lt[i] & SPT_LT_SPEC) != 0u, shadow = 0;
    float ulobe = spt_sampler_1d(f.smp, spt_dim_bounce(f.bounce, SPT_DIM_BSDF_LOBE));
    if (past_delta) {
        /* Every vertex after the first delta one connects: the path camera -
         * here - ... - light has x1 non-delta and its last vertex delta. */
        if (!bsdf_is_delta(&bp)) {
#ifdef SPT_MERGE
            pm_deposit(i, h.p, -h.rd, h.beta, h.depth, kg);
#endif
            shadow = lt_connect(&h, &bp, &f, spt_rand_key(f.key, spt_dim_bounce(f.bounce, SPT_DIM_LIGHT_U)),
                                spt_rand_key(f.key, spt_dim_bounce(f.bounce, SPT_DIM_LIGHT_V)),
                                spt_rand_key(f.key, spt_dim_bounce(f.bounce, SPT_DIM_SPARE)), sh_o, sh_d, sh_c,
                                kg);
        }
    } else {
        /* The first vertex: a non-delta lobe makes every path through here
         * the camera paths' (its last vertex is non-delta). */
        if (!bsdf_picks_delta(&bp, f.wo_l, ulobe))
            return 0;
    }
    BsdfSample bs;
    float3 wn;
    float wn_side;
    int reflect;
    int alive = shade_bsdf_bounce(&h, &bp, &f, ulobe, &bs, &wn, &wn_side, &reflect, kg) &&
                (past_delta || bs.is_delta);
    if (alive) {
        /* The adjoint: refraction (delta or not) scales importance by eta'^2
         * relative to radiance (bsdf_sample divided by it, eta' taken on wo's
         * side; a diffuse transmission does not refract); shading normals by
         * |wo.ns| |wi.ng| / (|wo.ng| |wi.ns|). */
        if (!reflect && f.two_sided_bsdf) {
            float etap = f.wo_l.z > 0.0f ? bp.ior.x : 1.0f / bp.ior.x;
            h.beta *= etap * etap;
        }
        float den = fabs(f.wo_side) * fabs(bs.wi.z);
        h.beta *= den > 0.0f ? fabs(f.wo_l.z) * fabs(wn_side) / den : 0.0f;
        alive = max4(h.beta) > 0.0f && isfinite(max4(h.beta));
    }
    alive = shade_roulette(&h, &f, alive, kg);
    if (!alive)
        return shadow;
    if (!reflect && f.both_sides)
        kg->ps_medium[i] = shade_medium_after(&h, &f, wn, wn_side);
    kg->ps_flags[i] = SPT_PATH_ALIVE;
    uint lt_next = SPT_LT_LIGHT | SPT_LT_SPEC;
#ifdef SPT_MERGE
    /* Its photons so far. */
    lt_next |= kg->ps_lt[i] & SPT_PM_BITS;
#endif
    kg->ps_lt[i] = lt_next;
    kg->ps_throughput[i] = h.beta;
    kg->ps_ray_o[i] = (float4)(offset_origin(h.p, wn_side > 0.0f ? f.ngf : -f.ngf), 0.0f);
    kg->ps_ray_d[i] = (float4)(wn, 0.0f);
    kg->ps_depth[i] = h.depth;
    return shadow;
}

/* Adds v >= 0 to the 64-bit fixed-point sum at acc (low word, high word),
 * rounded down or up with probability of the remainder (u uniform in [0, 1)). */
SPT_FN_INLINE void lt_film_add(__global uint *acc, float v, float u)
{
    float x = floor(fmin(v, 0x1p42f) * (float)(1 << SPT_SPLAT_BITS) + u);
    ulong n = convert_ulong_sat(x);
    uint lo = (uint)n, hi = (uint)(n >> 32);
    uint old = atomic_add(acc, lo);
    hi += old + lo < old ? 1u : 0u; /* the carry */
    if (hi)
        atomic_add(acc + 1, hi);
}

/* A light path's connection that reached the camera: its XYZ (xyz, with the
 * uniform number for the rounding in w) into the light film at pixel. */
SPT_FN_INLINE void lt_splat(uint pixel, float4 xyz, const KernelGlobals *kg)
{
    float u = xyz.w;
    __global uint *acc = kg->light_film + SPT_SPLAT_WORDS * pixel;
    lt_film_add(acc, xyz.x, u);
    lt_film_add(acc + 2, xyz.y, fmod(u + 0.3333333f, 1.0f));
    lt_film_add(acc + 4, xyz.z, fmod(u + 0.6666667f, 1.0f));
}

#endif
