/* The wavefront path tracer's kernel entry points (docs/architecture.md, "Data flow").
 *
 * One iteration of the host loop (src/render/wavefront.c) runs: k_generate (finish ended
 * paths, start new ones from the chunk's work counter, queue every live path),
 * k_extend (closest hit), k_shade and k_shade_light (the camera paths' and the
 * light paths' shading: emission with MIS, next-event estimation into the
 * shadow queue, BSDF sampling, Russian roulette), k_connect (shadow rays).
 * With the light-tracing pass (kernels/integrator/light_trace.h), a chunk's work
 * items past its camera paths (params.light_begin on) are light paths in the same
 * pool and queues.
 * When a chunk's work is all done, k_accumulate sums its per-sample contributions
 * into per-pixel sums in sample order, so the image does not depend on how paths
 * were scheduled in the pool.
 *
 * Work item w of a chunk is pixel = w mod (W*H), sample = sample_begin + w / (W*H);
 * every random number is a function of (seed, pixel, sample, dimension) only.
 * Depth counts path segments from the camera (Mitsuba's max_depth convention). */
#include "util/portable.h"
#include "util/vecmath.h"
#include "sample/rng.h"
#include "sample/sampling.h"
#include "spectrum/spectrum.h"
#include "bvh/bvh.h"
#include "util/render_types.h"
#include "integrator/path.h"
#include "closure/bsdf.h"
#include "light/lights.h"
#include "integrator/kernel_globals.h"
/* Surface shading: the materials' textures and BSDFs at a hit, and shade_path
 * in its steps; the light-tracing pass. */
#include "integrator/shade_surface.h"
#include "integrator/light_trace.h"

/* Work-group aggregated queue slots: every work-item of the group calls this
 * with want = 0 or 1 (all must call it: it has barriers); it returns the index
 * in the queue whose counter is *counter for those that want one, from one
 * global atomic per group instead of one per item. The work-items with
 * count != 0 are added to *count_counter in the same go (count_counter is
 * only touched when some have). Work-item 0 numbers the wanting items in
 * local-id order with a scan of l_slot (one word per item, SPT_GROUP_MAX):
 * two barriers and no local atomics, where a counter bumped with atomic_inc
 * took three barriers and a locked instruction per item (PoCL runs the items
 * of a group one after another, and splits their loop at every barrier).
 * The slots end at `limit`: a group that finds the counter at or past it
 * takes back its claim (the counter then stays within limit plus a few groups'
 * sizes, and no index below limit is handed out twice, since only claims made
 * at or past limit are taken back); slots at or past limit are not for use.
 * Nothing reads the counter but these atomics: a plain read of it in a
 * work-item would race with other groups' claims.
 * Always inlined: a function with barriers that was left a call went wrong in
 * two compilers. PoCL 3.1, once k_generate was its only caller or a second
 * such function stood beside it, compiled k_generate's scans wrong (groups took
 * more slots than they had items: paths queued twice, then heap corruption);
 * Intel's CPU runtime lost queue entries (the shadow queue of a furnace scene
 * held half its rays). */
static SPT_ALWAYS_INLINE uint group_queue_slot(int want, __global uint *counter, uint limit,
                                               int count, __global uint *count_counter,
                                               __local uint *l_slot, __local uint *l_base)
{
    uint lid = get_local_id(0);
    l_slot[lid] = (want ? 1u : 0u) | (count ? 0x10000u : 0u);
    barrier(CLK_LOCAL_MEM_FENCE);
    if (lid == 0u) {
        uint n = get_local_size(0), sum = 0u;
        for (uint k = 0u; k < n; k++) {
            uint f = l_slot[k];
            l_slot[k] = sum;
            sum += f;
        }
        uint nwant = sum & 0xffffu, ncount = sum >> 16;
        uint base = nwant ? atomic_add(counter, nwant) : 0u;
        if (nwant && base >= limit)
            atomic_sub(counter, nwant);
        *l_base = base;
        if (ncount)
            atomic_add(count_counter, ncount);
    }
    barrier(CLK_LOCAL_MEM_FENCE);
    return *l_base + (l_slot[lid] & 0xffffu);
}


/* A finished camera path: its XYZ into its own contribution slot (and its
 * spectral bands); a NaN or infinite one is dropped and counted. */
static void path_finish(uint i, const KernelGlobals *kg)
{
    float4 rad = kg->ps_radiance[i];
#ifdef SPT_TEST_INJECT_NAN
    /* Test hook (SPECTRACE_TEST_INJECT_NAN): pixel 0's radiance becomes NaN. */
    if (kg->ps_work[i] % (uint)(kg->p->width * kg->p->height) == 0u)
        rad.x = NAN;
#endif
    float4 xyz = path_radiance_to_xyz(rad, kg->ps_lambda[i], kg->ps_lambda_pdf[i]);
    if (kg->ps_lt[i] & SPT_LT_SKIP) {
        xyz = (float4)(0.0f); /* left out by adaptive sampling: w = 0, not counted */
    } else if (isfinite(xyz.x) && isfinite(xyz.y) && isfinite(xyz.z)) {
        xyz.w = 1.0f;
    } else {
        atomic_inc(&kg->counters[SPT_CNT_NAN]);
        xyz = (float4)(0.0f); /* w = 0: the sample is dropped, not counted */
    }
    kg->contrib[kg->ps_work[i]] = xyz;
#ifdef SPT_BANDS
    {
        /* Each wavelength's weight L / (4 pdf), as the XYZ film weighs it
         * without the colour matching function, and its band. */
        float4 lam = kg->ps_lambda[i], lp = kg->ps_lambda_pdf[i];
        float4 wv = select((float4)(0.0f), rad / lp, isgreater(lp, (float4)(0.0f))) * 0.25f;
        if (xyz.w == 0.0f)
            wv = (float4)(0.0f);
        float4 band = clamp(floor((lam - 360.0f) * ((float)SPT_BANDS / 470.0f)), 0.0f,
                            (float)(SPT_BANDS - 1));
        kg->spec_sample[2u * kg->ps_work[i]] = wv;
        kg->spec_sample[2u * kg->ps_work[i] + 1u] = band;
    }
#endif
}

/* Starts work item w of the chunk in slot i (a camera path, or a light path
 * from params.light_begin on); returns its flags. A camera path's sample goes
 * to *ps where ps is not 0 (k_paths keeps it: shade_path_of). */
static uint path_start(uint i, uint w, PathSample *ps, const KernelGlobals *kg)
{
    if (w >= kg->p->light_begin)
        return lt_start(i, w, kg);
    uint npix = (uint)(kg->p->width * kg->p->height);
    uint pixel = w % npix;
    uint lag = kg->pixel_lag[pixel];
    uint sample = kg->p->sample_begin + w / npix - lag;
    kg->ps_work[i] = w;
#ifdef SPT_AOV
    /* A sample that sees nothing (or is skipped) has zero AOVs; k_shade fills
     * what it hits. */
    kg->aov_sample[3u * w + 0u] = (float4)(0.0f);
    kg->aov_sample[3u * w + 1u] = (float4)(0.0f);
    kg->aov_sample[3u * w + 2u] = (float4)(0.0f);
#endif
    if (lag == SPT_PIXEL_SKIP) {
        kg->ps_radiance[i] = (float4)(0.0f);
        kg->ps_lambda[i] = (float4)(550.0f);
        kg->ps_lambda_pdf[i] = (float4)(1.0f);
        kg->ps_lt[i] = SPT_LT_SKIP;
        return SPT_PATH_FINISHED;
    }
    SptSampler smp = spt_sampler_for(kg->p, pixel, sample);
    if (ps)
        path_sample_set(pixel, sample, smp, ps);
    float jx, jy;
    spt_sampler_pair(smp, SPT_DIM_PIXEL_X, &jx, &jy);
    float px = (float)(pixel % (uint)kg->p->width) + jx;
    float py = (float)(pixel / (uint)kg->p->width) + jy;
    float sx = 2.0f * px / (float)kg->p->width - 1.0f;
    float sy = 1.0f - 2.0f * py / (float)kg->p->height;
    float3 fwd = vload4(0, kg->p->cam_fwd).xyz, right = vload4(0, kg->p->cam_right).xyz,
           up = vload4(0, kg->p->cam_up).xyz, org = vload4(0, kg->p->cam_pos).xyz;
    float3 d = fwd + sx * right + sy * up;
    if (kg->p->orthographic) {
        org += sx * right + sy * up;
        d = fwd;
    } else if (kg->p->lens_radius > 0.0f) {
        /* Thin lens: a point on the lens aperture, aimed at the point of the
         * pinhole ray on the plane of focus (perpendicular to fwd). */
        float lu, lv;
        spt_sampler_pair(smp, SPT_DIM_LENS_U, &lu, &lv);
        vec3 disk = spt_sample_concentric_disk(lu, lv);
        float3 focus = org + d * kg->p->focus_distance; /* dot(d, fwd) = 1 */
        org += kg->p->lens_radius * (disk.x * normalize(right) + disk.y * normalize(up));
        d = focus - org;
    }
    kg->ps_ray_o[i] = (float4)(org, 0.0f);
    kg->ps_ray_d[i] = (float4)(v3_unit(d), kg->p->cam_pos[3]); /* w: the ray cone's width */
    float4 lam, pdf;
    /* With merging, the wavelengths of the chunk's light paths of this
     * sample slot (kernels/integrator/photon_merge.h): its sample index,
     * unless adaptive sampling put the pixel's own behind it (lag). */
    spt_sample_wavelengths(
        pm_wavelength_u(spt_sampler_1d(smp, SPT_DIM_WAVELENGTH), kg->p->sample_begin + w / npix, kg), &lam, &pdf);
    kg->ps_lambda[i] = lam;
    kg->ps_lambda_pdf[i] = pdf;
    kg->ps_throughput[i] = (float4)(1.0f);
    kg->ps_radiance[i] = (float4)(0.0f);
    kg->ps_depth[i] = 0;
    kg->ps_passes[i] = 0;
    kg->ps_medium[i] = 0;
    kg->ps_bsdf_pdf[i] = 0.0f; /* camera ray: emission seen directly has MIS weight 1 */
    kg->ps_lt[i] = 0u;
    return SPT_PATH_ALIVE;
}

__kernel void k_generate(KERNEL_ARGS)
{
    __local uint l_slot[SPT_GROUP_MAX], l_base;
    uint i = get_global_id(0);
    uint flags = i < params.pool_size ? ps_flags[i] : SPT_PATH_ALIVE + 100u;
    int finished = flags == SPT_PATH_FINISHED;
    if (finished && (ps_lt[i] & SPT_LT_LIGHT)) {
        /* A light path: its splats went to the light film in k_connect. */
        flags = SPT_PATH_DEAD;
        ps_flags[i] = flags;
    } else if (finished) {
        KERNEL_GLOBALS;
        path_finish(i, kg);
        flags = SPT_PATH_DEAD;
        ps_flags[i] = flags;
    }
    /* Free slots take the next work items of the chunk; the group's finished
     * paths are counted in the same round of barriers. */
    uint total = params.work_end - params.work_begin;
    int wants = flags == SPT_PATH_DEAD;
    uint w = group_queue_slot(wants, &counters[SPT_CNT_WORK], total, finished,
                              &counters[SPT_CNT_DONE], l_slot, &l_base);
    if (wants && w < total) {
        KERNEL_GLOBALS;
        flags = path_start(i, params.work_begin + w, (PathSample *)0, kg);
        ps_flags[i] = flags;
    }
    uint q = group_queue_slot(flags == SPT_PATH_ALIVE, &counters[SPT_CNT_EXTEND], 0xffffffffu, 0,
                              counters, l_slot, &l_base);
    if (flags == SPT_PATH_ALIVE)
        queue_extend[q] = i;
}

/* A path's ps_hit: the hit (t, u, v, prim) when found (else h is not read),
 * or NO_HIT. */
static float4 extend_result(int found, const BvhHit *h)
{
    return found ? (float4)(h->t, h->u, h->v, as_float(h->prim))
                 : (float4)(0.0f, 0.0f, 0.0f, as_float(NO_HIT));
}

/* The closest hit of the ray org + t dir, t in (0, tmax): through the two
 * levels when the scene has instances (docs/architecture.md, "Instances (two
 * levels)"; *inst gets the hit's), else the one BVH (*inst untouched). */
static int scene_intersect(float3 org, float3 dir, float tmax, BvhHit *h, uint *inst,
                           const KernelGlobals *kg)
{
    if (!SPT_HAS_INSTANCES(kg->p))
        return kg->p->node_count > 0u && bvh_intersect(kg->nodes, kg->tris, org, dir, tmax, h);
    BvhInstHit ih;
    if (!bvh_tlas_intersect(kg->tlas_top, kg->tlas_inst, kg->nodes, kg->tris, org, dir, tmax, &ih))
        return 0;
    *h = ih.h;
    *inst = ih.inst;
    return 1;
}

/* Path i's closest hit as ps_hit holds it, its instance into ps_inst. */
static float4 extend_path(uint i, const KernelGlobals *kg)
{
    BvhHit h;
    uint inst = 0u;
    int found = scene_intersect(kg->ps_ray_o[i].xyz, kg->ps_ray_d[i].xyz, 1e30f, &h, &inst, kg);
    if (SPT_HAS_INSTANCES(kg->p))
        kg->ps_inst[i] = inst;
    return extend_result(found, &h);
}

/* Closest hits of the queued rays: on CPUs (SPT_BVH_PAIRS) work-item g traces
 * queue entries 2 g and 2 g + 1 together (bvh_intersect2; one after the other
 * through the two levels of an instanced scene), elsewhere entry g. */
__kernel void k_extend(KERNEL_ARGS)
{
    uint n = counters[SPT_CNT_EXTEND];
    if (SPT_HAS_INSTANCES(&params)) {
        KERNEL_GLOBALS;
#if defined(SPT_BVH_PAIRS)
        for (uint g = 2u * get_global_id(0); g < n && g < 2u * get_global_id(0) + 2u; g++)
#else
        uint g = get_global_id(0);
        if (g < n)
#endif
            ps_hit[queue_extend[g]] = extend_path(queue_extend[g], kg);
        return;
    }
#if defined(SPT_BVH_PAIRS)
    uint g = 2u * get_global_id(0);
    if (g >= n)
        return;
    uint i = queue_extend[g];
    if (g + 1u < n && params.node_count > 0u) {
        uint j = queue_extend[g + 1u];
        int found[2];
        BvhHit hit[2];
        bvh_intersect2(nodes, tris, ps_ray_o[i].xyz, ps_ray_d[i].xyz, ps_ray_o[j].xyz,
                       ps_ray_d[j].xyz, 1e30f, found, hit);
        ps_hit[i] = extend_result(found[0], &hit[0]);
        ps_hit[j] = extend_result(found[1], &hit[1]);
        return;
    }
    BvhHit h;
    if (g + 1u < n)
        ps_hit[queue_extend[g + 1u]] = extend_result(0, &h);
#else
    uint g = get_global_id(0);
    if (g >= n)
        return;
    uint i = queue_extend[g];
    BvhHit h;
#endif
    int found =
        params.node_count > 0u && bvh_intersect(nodes, tris, ps_ray_o[i].xyz, ps_ray_d[i].xyz, 1e30f, &h);
    ps_hit[i] = extend_result(found, &h);
}

/* Asks for the positions and normals of the vertices of triangle record t. */
SPT_FN_INLINE void prefetch_vertices(TriShade t, const KernelGlobals *kg)
{
    for (int k = 0; k < 3; k++) {
        SPT_PREFETCH(kg->vtx_pos + 3u * t.v[k]);
        SPT_PREFETCH(kg->vtx_normal + 3u * t.v[k]);
    }
}

/* Prefetch distance of the shading kernels, in queue entries. */
#define SPT_SHADE_AHEAD 8u

/* Cache misses hidden behind the work of queue entry g's path (of n): the hit
 * triangle's shading record of the path 2 SPT_SHADE_AHEAD queue entries on is
 * fetched, and the vertex positions and normals of the one SPT_SHADE_AHEAD on
 * (whose record came in by now). */
SPT_FN_INLINE void shade_prefetch(uint g, uint n, const KernelGlobals *kg)
{
    if (g + 2u * SPT_SHADE_AHEAD < n) {
        uint pa = as_uint(kg->ps_hit[kg->queue_extend[g + 2u * SPT_SHADE_AHEAD]].w);
        if (pa != NO_HIT)
            SPT_PREFETCH(kg->tri_shade + pa);
    }
    if (g + SPT_SHADE_AHEAD < n) {
        uint pb = as_uint(kg->ps_hit[kg->queue_extend[g + SPT_SHADE_AHEAD]].w);
        if (pb != NO_HIT)
            prefetch_vertices(kg->tri_shade[pb], kg);
    }
}

/* The queued paths are shaded by two kernels over the same queue, k_shade
 * the camera paths (shade_path) and k_shade_light the light paths (lt_shade),
 * each passing over the other's entries: a compiler that inlines every call
 * (Mesa's NIR, for llvmpipe) then compiles each kind's shading in a kernel of
 * its own instead of both in one (docs/performance.md, "rusticl's build").
 * Neither reads what the other writes in the same wave: a path's state is its
 * own, the shadow queue's order is not the image's (a camera path's ray adds
 * to its own radiance, a light path's splats are integer sums), and photons
 * are deposited and gathered in different passes (run_merge_chunk). The two
 * differ only in the kind they take (kind: ps_lt's SPT_LT_LIGHT bit) and
 * the function that shades it (shade). */
#define SPT_SHADE_KERNEL(name, kind, shade)                                                              \
    __kernel void name(KERNEL_ARGS)                                                                      \
    {                                                                                                    \
        __local uint l_slot[SPT_GROUP_MAX], l_base;                                                      \
        uint g = get_global_id(0);                                                                       \
        float4 so, sd, sc;                                                                               \
        int shadow = 0;                                                                                  \
        uint i = 0;                                                                                      \
        uint n = counters[SPT_CNT_EXTEND];                                                               \
        if (g < n && (ps_lt[queue_extend[g]] & SPT_LT_LIGHT) == (kind)) {                                \
            KERNEL_GLOBALS;                                                                              \
            shade_prefetch(g, n, kg);                                                                    \
            i = queue_extend[g];                                                                         \
            shadow = shade(i, &so, &sd, &sc, kg);                                                        \
        }                                                                                                \
        uint s = group_queue_slot(shadow, &counters[SPT_CNT_SHADOW], 0xffffffffu, 0, counters, l_slot,   \
                                  &l_base);                                                              \
        if (shadow) {                                                                                    \
            sh_ray_o[s] = so;                                                                            \
            sh_ray_d[s] = sd;                                                                            \
            sh_contrib[s] = sc;                                                                          \
            sh_path[s] = i;                                                                              \
        }                                                                                                \
    }

SPT_SHADE_KERNEL(k_shade, 0u, shade_path)
SPT_SHADE_KERNEL(k_shade_light, SPT_LT_LIGHT, lt_shade)

/* Traces the shadow ray (origin so, direction and tmax sd, contribution sc)
 * of path i and, unless it is blocked, adds its contribution to the path's
 * radiance, or a light path's splat to the light film. */
static void connect_shadow(float4 so, float4 d, float4 sc, uint i, const KernelGlobals *kg)
{
    float transmit = 1.0f;
    if (SPT_HAS_INSTANCES(kg->p) && !kg->p->has_alpha) {
        if (bvh_tlas_occluded(kg->tlas_top, kg->tlas_inst, kg->nodes, kg->tris, so.xyz, d.xyz, d.w))
            return;
    } else if (kg->p->node_count > 0u && !kg->p->has_alpha) {
        if (bvh_occluded(kg->nodes, kg->tris, so.xyz, d.xyz, d.w))
            return;
    } else if (kg->p->node_count > 0u) {
        /* Surfaces with alpha let light through: walk the hits along the shadow
         * ray, multiplying by 1 - opacity (the expected transmission of the
         * stochastic opacity camera rays see). */
        float3 o = so.xyz;
        float tmax = d.w;
        for (int k = 0; k < 16; k++) {
            BvhHit h;
            uint inst = SPT_NO_INST;
            if (!scene_intersect(o, d.xyz, tmax, &h, &inst, kg))
                break;
            const __global GpuMaterial *m = kg->materials + kg->tri_shade[h.prim].material;
            vec3 a, b, c;
            tri_world(kg->tri_shade, kg->vtx_pos, kg->tlas_inst, inst, h.prim, &a, &b, &c);
            float3 ng = normalize(cross(b - a, c - a));
            float op = 1.0f;
            if (m->flags & (SPT_MAT_ALPHA_MASK | SPT_MAT_ALPHA_BLEND)) {
                /* At the finest level: a shadow ray carries no footprint. */
                TexCtx tc = tex_ctx(m, h.prim, h.u, h.v, a, b, c, ng, d.xyz, 0.0f, kg->tri_shade, kg->vtx_uv,
                                    kg->vtx_uv1);
                op = material_opacity(m, &tc, h.prim, h.u, h.v, kg->tri_shade, kg->vtx_color, kg->textures,
                                      kg->texels);
            }
            transmit *= 1.0f - op;
            if (!(transmit > 0.0f) || k == 15)
                return;
            float3 q = o + h.t * d.xyz;
            float3 o2 = offset_origin(q, dot(ng, d.xyz) > 0.0f ? ng : -ng);
            tmax -= dot(o2 - o, d.xyz);
            o = o2;
            if (!(tmax > 0.0f))
                break;
        }
    }
    if (kg->ps_lt[i] & SPT_LT_LIGHT) {
        /* A light path's connection to the camera: a splat (XYZ, its rounding's
         * number in w) at the pixel in the ray's origin's w. */
        lt_splat(as_uint(so.w), (float4)(transmit * sc.xyz, sc.w), kg);
        return;
    }
    /* A path queues at most one shadow ray per iteration: no race on its radiance. */
    kg->ps_radiance[i] += transmit * sc;
}

__kernel void k_connect(KERNEL_ARGS)
{
    KERNEL_GLOBALS;
    uint g = get_global_id(0);
    if (g >= counters[SPT_CNT_SHADOW])
        return;
    connect_shadow(sh_ray_o[g], sh_ray_d[g], sh_contrib[g], sh_path[g], kg);
}

#if defined(SPT_BVH_PAIRS)
/* The CPU devices' form of the loop (src/render/wavefront.c, "megakernel";
 * docs/performance.md): k_paths runs whole paths, with the same steps as the
 * stage kernels (path_start, extend, shade_path or lt_shade, connect_shadow,
 * path_finish), so a sample's numbers and result are the same; its path
 * state stays in the cache instead of passing through the pool's buffers and
 * queues four times per segment. Each work-item keeps two paths, in slots 2 g
 * and 2 g + 1, whose closest-hit rays are traced together (bvh_intersect2),
 * and gives a slot whose path ended the next work item of
 * [params.work_begin, params.work_end) from counter SPT_CNT_WORK (counting from
 * params.work_begin; the host zeroes it per launch), until none is left
 * (SPT_ONE_RAY: the two rays traced one after the other instead). A CPU
 * runs a work-group's items one after another, so each thread keeps one
 * work-item's two paths in flight. */

/* The end of path i: a camera path's contribution (a light path's splats went
 * to the light film at its connections). */
static void mega_end(uint i, const KernelGlobals *kg)
{
    if (!(kg->ps_lt[i] & SPT_LT_LIGHT))
        path_finish(i, kg);
}

/* Work items a work-item takes from SPT_CNT_WORK at a time. One atomic per
 * path start made the counter's cache line move between the threads at each
 * of them (docs/performance.md, "Vector width: AVX-512 against AVX2"); a
 * batch leaves at most SPT_WORK_BATCH - 1 items to one thread at a launch's
 * end. Which slot runs a work item does not change its numbers: path_start
 * draws everything from the item's index. */
#define SPT_WORK_BATCH 16u

/* A work-item's batch of work items: [next, end), relative to work_begin. */
typedef struct {
    uint next, end;
} WorkBatch;

/* Starts the next work item in slot i; 1 when one is alive there, 0 when the
 * launch's work is all taken. */
static int mega_next(uint i, WorkBatch *wb, PathSample *ps, const KernelGlobals *kg)
{
    for (;;) {
        if (wb->next == wb->end) {
            wb->next = atomic_add(&kg->counters[SPT_CNT_WORK], SPT_WORK_BATCH);
            wb->end = wb->next + SPT_WORK_BATCH;
        }
        uint rel = wb->next++;
        if (rel >= kg->p->work_end - kg->p->work_begin)
            return 0;
        uint w = kg->p->work_begin + rel;
        uint flags = path_start(i, w, ps, kg);
        kg->ps_flags[i] = flags;
        if (flags == SPT_PATH_ALIVE) {
            if (!(kg->ps_lt[i] & SPT_LT_LIGHT))
                path_sample_draw(i, ps, kg);
            return 1;
        }
        mega_end(i, kg);
    }
}

/* Shades path i at its hit (ps_hit) and traces its shadow ray; when the path
 * ended, starts the next. Returns mega_next's 1 or 0, or 1 while the path goes
 * on. */
SPT_FN_INLINE int mega_shade(uint i, uint *nshadow, WorkBatch *wb, PathSample *ps, const KernelGlobals *kg)
{
    float4 so, sd, sc;
    int shadow = (kg->ps_lt[i] & SPT_LT_LIGHT) ? lt_shade(i, &so, &sd, &sc, kg)
                                               : shade_path_kept(i, ps, &so, &sd, &sc, kg);
    if (shadow) {
        connect_shadow(so, sd, sc, i, kg);
        *nshadow += 1u;
    }
    if (kg->ps_flags[i] != SPT_PATH_FINISHED) {
        if (!(kg->ps_lt[i] & SPT_LT_LIGHT))
            path_sample_draw(i, ps, kg);
        return 1;
    }
    mega_end(i, kg);
    return mega_next(i, wb, ps, kg);
}

__kernel void k_paths(KERNEL_ARGS)
{
    KERNEL_GLOBALS;
    uint s0 = 2u * get_global_id(0), s1 = s0 + 1u;
    uint nray = 0u, nshadow = 0u;
    WorkBatch wb = {0u, 0u};
    PathSample ps0, ps1; /* the two paths' samples (shade_path_of) */
    int a0 = s0 < params.pool_size && mega_next(s0, &wb, &ps0, kg);
    int a1 = a0 && s1 < params.pool_size && mega_next(s1, &wb, &ps1, kg);
    while (a0 | a1) {
        if (SPT_HAS_INSTANCES(&params)) {
            /* Two levels (docs/architecture.md, "Instances (two levels)"): one ray at a time. */
            if (a0)
                ps_hit[s0] = extend_path(s0, kg);
            if (a1)
                ps_hit[s1] = extend_path(s1, kg);
        } else if (a0 && a1 && params.node_count > 0u) {
            int found[2];
            BvhHit hit[2];
#if defined(SPT_ONE_RAY)
            /* One ray after the other: faster than the pair on Intel's cores
             * (src/render/wavefront.c, kernel_path_for; docs/performance.md,
             * "Vector width: AVX-512 against AVX2"); the same hits. */
            found[0] = bvh_intersect(nodes, tris, ps_ray_o[s0].xyz, ps_ray_d[s0].xyz, 1e30f, &hit[0]);
#if defined(SPT_BVH_STEP_PREFETCH)
            /* The first hit's triangle record comes in while the second ray
             * is traced. */
            if (found[0])
                SPT_PREFETCH(tri_shade + hit[0].prim);
#endif
            found[1] = bvh_intersect(nodes, tris, ps_ray_o[s1].xyz, ps_ray_d[s1].xyz, 1e30f, &hit[1]);
#else
            bvh_intersect2(nodes, tris, ps_ray_o[s0].xyz, ps_ray_d[s0].xyz, ps_ray_o[s1].xyz,
                           ps_ray_d[s1].xyz, 1e30f, found, hit);
#endif
            ps_hit[s0] = extend_result(found[0], &hit[0]);
            ps_hit[s1] = extend_result(found[1], &hit[1]);
#if defined(SPT_BVH_STEP_PREFETCH)
            /* In a scene larger than the cache, the second hit's triangle and
             * its vertices' positions and normals are asked for now, so they
             * arrive while the first path is shaded (on the 1M-triangle mesh
             * of tools/bench_mitsuba.py these loads were a sixth of
             * shade_path's time); one ray at a time, also the first hit's
             * vertices, its record having come in during the second ray's
             * traversal. */
#if defined(SPT_ONE_RAY)
            if (found[0])
                prefetch_vertices(tri_shade[hit[0].prim], kg);
#endif
            if (found[1])
                prefetch_vertices(tri_shade[hit[1].prim], kg);
#endif
        } else {
            uint i = a0 ? s0 : s1;
            BvhHit h;
            int found = params.node_count > 0u &&
                        bvh_intersect(nodes, tris, ps_ray_o[i].xyz, ps_ray_d[i].xyz, 1e30f, &h);
            ps_hit[i] = extend_result(found, &h);
            if (a0 && a1)
                ps_hit[s1] = extend_result(0, &h);
        }
        nray += (uint)a0 + (uint)a1;
        if (a0)
            a0 = mega_shade(s0, &nshadow, &wb, &ps0, kg);
        if (a1)
            a1 = mega_shade(s1, &nshadow, &wb, &ps1, kg);
    }
    if (nray)
        atomic_add(&counters[SPT_CNT_EXTEND], nray);
    if (nshadow)
        atomic_add(&counters[SPT_CNT_SHADOW], nshadow);
}
#endif

/* Sums the chunk's per-sample contributions of each pixel, in sample order, into
 * chunk_sum (XYZ, and the number of samples kept in w), and adds the light
 * paths' splats (which count no sample). */
__kernel void k_accumulate(KERNEL_ARGS)
{
    uint pixel = get_global_id(0);
    uint npix = (uint)(params.width * params.height);
    if (pixel >= npix)
        return;
    uint n = (params.light_begin - params.work_begin) / npix;
    /* The squares are taken of the radiance over 2^e, e the exponent of the
     * largest kept component, and e is kept in w: float squares of radiance
     * itself pass float's range above 1.8e19 and fall below its normal range
     * (which some devices flush to 0) under 1e-19 (docs/limits.md). */
    float mx = 0.0f;
    for (uint k = 0; k < n; k++) {
        float4 c = contrib[pixel + k * npix];
        float3 a = fabs(path_xyz_to_linear_srgb(c.xyz));
        if (c.w > 0.0f)
            mx = fmax(mx, fmax(a.x, fmax(a.y, a.z)));
    }
    int ex = 0;
    if (mx > 0.0f && isfinite(mx))
        (void)frexp(mx, &ex);
    float4 s = (float4)(0.0f), ssq = (float4)(0.0f);
    for (uint k = 0; k < n; k++) {
        float4 c = contrib[pixel + k * npix];
        float3 rgb = ldexp(path_xyz_to_linear_srgb(c.xyz), -ex);
        s += c;
        ssq += c.w * (float4)(rgb * rgb, 0.0f);
    }
    ssq.w = (float)ex;
    chunk_sq[pixel] = ssq;
    /* A pixel left out of the chunk's camera samples leaves out its light
     * paths' splats too: its sum stays that of the samples it counts. */
    if (params.light_paths > 0u && pixel_lag[pixel] != SPT_PIXEL_SKIP) {
        const __global uint *a = light_film + SPT_SPLAT_WORDS * pixel;
        const float unit = 1.0f / (float)(1 << SPT_SPLAT_BITS);
        s.x += (float)(((ulong)a[1] << 32) | a[0]) * unit;
        s.y += (float)(((ulong)a[3] << 32) | a[2]) * unit;
        s.z += (float)(((ulong)a[5] << 32) | a[4]) * unit;
    }
    chunk_sum[pixel] = s;
#ifdef SPT_AOV
    /* The AOVs of the samples kept (w = 1; a dropped sample has w = 0) and the
     * squares of their linear sRGB, in the same sample order. */
    float4 alb = (float4)(0.0f), nz = (float4)(0.0f), pos = (float4)(0.0f), sq = (float4)(0.0f);
    for (uint k = 0; k < n; k++) {
        uint w = pixel + k * npix;
        float4 c = contrib[w];
        float keep = c.w;
        float3 rgb = path_xyz_to_linear_srgb(c.xyz);
        alb += keep * (float4)(aov_sample[3u * w].xyz, 0.0f);
        nz += keep * aov_sample[3u * w + 1u];
        pos += keep * (float4)(aov_sample[3u * w + 2u].xyz, 0.0f);
        sq += keep * (float4)(rgb * rgb, 0.0f);
    }
    /* (albedo, Z), (N, 0), (P, 0), (squares, 0): src/render/film.h */
    aov_sum[4u * pixel + 0u] = (float4)(alb.xyz, nz.w);
    aov_sum[4u * pixel + 1u] = (float4)(nz.xyz, 0.0f);
    aov_sum[4u * pixel + 2u] = pos;
    aov_sum[4u * pixel + 3u] = sq;
#endif
#ifdef SPT_BANDS
    /* Every wavelength of every sample into its band, in sample order. */
    __global float *bands = spec_sum + (size_t)pixel * SPT_BANDS;
    for (int b = 0; b < SPT_BANDS; b++)
        bands[b] = 0.0f;
    for (uint k = 0; k < n; k++) {
        uint w = pixel + k * npix;
        float4 wv = spec_sample[2u * w], bd = spec_sample[2u * w + 1u];
        bands[(int)bd.x] += wv.x;
        bands[(int)bd.y] += wv.y;
        bands[(int)bd.z] += wv.z;
        bands[(int)bd.w] += wv.w;
    }
#endif
}
