/* The wavefront path tracer's kernel entry points (DESIGN.md, "Data flow").
 *
 * One iteration of the host loop (src/render/render.c) runs: k_generate (finish ended
 * paths, start new ones from the chunk's work counter, queue every live path),
 * k_extend (closest hit), k_shade (emission with MIS, next-event estimation into
 * the shadow queue, BSDF sampling, Russian roulette), k_connect (shadow rays).
 * When a chunk's work is all done, k_accumulate sums its per-sample contributions
 * into per-pixel sums in sample order, so the image does not depend on how paths
 * were scheduled in the pool.
 *
 * Work item w of a chunk is pixel = w mod (W*H), sample = sample_begin + w / (W*H);
 * every random number is a function of (seed, pixel, sample, dimension) only.
 * Depth counts path segments from the camera (Mitsuba's max_depth convention). */
#include "shared/portable.h"
#include "shared/vecmath.h"
#include "device/rng.h"
#include "shared/sampling.h"
#include "shared/spectrum.h"
#include "shared/bvh.h"
#include "shared/render_types.h"
#include "device/path.h"
#include "device/bsdf.h"
#include "shared/lights.h"

#define PARAM(type, name) __global type *name,
#define PS_PARAM(type, name) __global type *ps_##name,
#define SH_PARAM(type, name) __global type *sh_##name,
/* Every kernel takes every buffer, in the order of these lists, so the host sets
 * arguments from the same lists (src/render/render.c). */
#define ALL_BUFFERS            \
    SPT_SCENE_BUFFERS(PARAM)   \
    SPT_WORK_BUFFERS(PARAM)    \
    SPT_PATH_STATE(PS_PARAM)   \
    SPT_SHADOW_STATE(SH_PARAM) \
    const RenderParams P
#define ARG(type, name) name,
#define PS_ARG(type, name) ps_##name,
#define SH_ARG(type, name) sh_##name,
#define ALL_ARGS                 \
    SPT_SCENE_BUFFERS(ARG)       \
    SPT_WORK_BUFFERS(ARG)        \
    SPT_PATH_STATE(PS_ARG)       \
    SPT_SHADOW_STATE(SH_ARG)     \
    P

#define NO_HIT 0xffffffffu
/* Segments after which a path ends whatever its throughput (a guard; Russian
 * roulette ends paths long before). */
#define SPT_MAX_SEGMENTS 1024u

/* The largest work-group the kernels run with (src/render/render.c: at most 64). */
#define SPT_GROUP_MAX 64

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

__kernel void k_generate(ALL_BUFFERS)
{
    __local uint l_slot[SPT_GROUP_MAX], l_base;
    uint i = get_global_id(0);
    uint flags = i < P.pool_size ? ps_flags[i] : SPT_PATH_ALIVE + 100u;
    int finished = flags == SPT_PATH_FINISHED;
    if (finished) {
        /* Write the finished path's XYZ into its own contribution slot. */
        float4 rad = ps_radiance[i];
#ifdef SPT_TEST_INJECT_NAN
        /* Test hook (SPECTRACE_TEST_INJECT_NAN): pixel 0's radiance becomes NaN. */
        if (ps_work[i] % (uint)(P.width * P.height) == 0u)
            rad.x = NAN;
#endif
        float4 xyz = path_radiance_to_xyz(rad, ps_lambda[i], ps_lambda_pdf[i]);
        if (isfinite(xyz.x) && isfinite(xyz.y) && isfinite(xyz.z)) {
            xyz.w = 1.0f;
        } else {
            atomic_inc(&counters[SPT_CNT_NAN]);
            xyz = (float4)(0.0f); /* w = 0: the sample is dropped, not counted */
        }
        contrib[ps_work[i]] = xyz;
        flags = SPT_PATH_DEAD;
        ps_flags[i] = flags;
    }
    /* Free slots take the next work items of the chunk; the group's finished
     * paths are counted in the same round of barriers. */
    uint total = P.work_end - P.work_begin;
    int wants = flags == SPT_PATH_DEAD;
    uint w = group_queue_slot(wants, &counters[SPT_CNT_WORK], total, finished,
                              &counters[SPT_CNT_DONE], l_slot, &l_base);
    if (wants && w < total) {
        uint npix = (uint)(P.width * P.height);
        uint pixel = w % npix;
        uint sample = P.sample_begin + w / npix;
        uint pkey = spt_sobol_pixel_key(P.seed, pixel);
        float jx, jy;
        spt_sample_pair(pkey, sample, 0u, &jx, &jy); /* SPT_DIM_PIXEL_X, _Y */
        float px = (float)(pixel % (uint)P.width) + jx;
        float py = (float)(pixel / (uint)P.width) + jy;
        float sx = 2.0f * px / (float)P.width - 1.0f;
        float sy = 1.0f - 2.0f * py / (float)P.height;
        float3 fwd = vload4(0, P.cam_fwd).xyz, right = vload4(0, P.cam_right).xyz,
               up = vload4(0, P.cam_up).xyz, org = vload4(0, P.cam_pos).xyz;
        float3 d = fwd + sx * right + sy * up;
        if (P.orthographic) {
            org += sx * right + sy * up;
            d = fwd;
        } else if (P.lens_radius > 0.0f) {
            /* Thin lens: a point on the lens aperture, aimed at the point of the
             * pinhole ray on the plane of focus (perpendicular to fwd). */
            float lu, lv;
            spt_sample_pair(pkey, sample, 1u, &lu, &lv); /* SPT_DIM_LENS_U, _V */
            vec3 disk = spt_sample_concentric_disk(lu, lv);
            float3 focus = org + d * P.focus_distance; /* dot(d, fwd) = 1 */
            org += P.lens_radius * (disk.x * normalize(right) + disk.y * normalize(up));
            d = focus - org;
        }
        ps_ray_o[i] = (float4)(org, 0.0f);
        ps_ray_d[i] = (float4)(normalize(d), P.cam_pos[3]); /* w: the ray cone's width */
        float4 lam, pdf;
        path_sample_wavelengths(spt_sample_wavelength_u(pkey, sample), &lam, &pdf);
        ps_lambda[i] = lam;
        ps_lambda_pdf[i] = pdf;
        ps_throughput[i] = (float4)(1.0f);
        ps_radiance[i] = (float4)(0.0f);
        ps_work[i] = w;
        ps_depth[i] = 0;
        ps_passes[i] = 0;
        ps_medium[i] = 0;
        ps_bsdf_pdf[i] = 0.0f; /* camera ray: emission seen directly has MIS weight 1 */
        flags = SPT_PATH_ALIVE;
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

/* Closest hits of the queued rays: on CPUs (SPT_BVH_PAIRS) work-item g traces
 * queue entries 2 g and 2 g + 1 together (bvh_intersect2), elsewhere entry g. */
__kernel void k_extend(ALL_BUFFERS)
{
    uint n = counters[SPT_CNT_EXTEND];
#if defined(SPT_BVH_PAIRS)
    uint g = 2u * get_global_id(0);
    if (g >= n)
        return;
    uint i = queue_extend[g];
    if (g + 1u < n && P.node_count > 0u) {
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
    int found = P.node_count > 0u && bvh_intersect(nodes, tris, ps_ray_o[i].xyz, ps_ray_d[i].xyz, 1e30f, &h);
    ps_hit[i] = extend_result(found, &h);
}

/* The vertices of packed triangle prim, from the vertex positions (the same
 * floats as the BVH's copy, whose leaf blocks spread a triangle over up to 9
 * cache lines). */
static void tri_positions(const __global TriShade *ts, const __global float *vtx_pos, uint prim,
                          float3 *a, float3 *b, float3 *c)
{
    TriShade s = ts[prim];
    *a = vload3(s.v[0], vtx_pos);
    *b = vload3(s.v[1], vtx_pos);
    *c = vload3(s.v[2], vtx_pos);
}

/* The texture context of packed triangle prim (vertices v0, v1, v2, unit face
 * normal ng) at barycentrics (bu, bv), reached along unit direction rd by a ray
 * cone of width cone_w there (0: no footprint). The cone's circular cross-section
 * projects onto the triangle's plane as an ellipse with axes cone_w across the
 * ray and cone_w / |cos| along it; each axis maps to uv through the triangle's
 * texture-coordinate gradient. TEXCOORD_1 only when the material reads it. */
static TexCtx tex_ctx(const __global GpuMaterial *m, uint prim, float bu, float bv, float3 v0, float3 v1,
                      float3 v2, float3 ng, float3 rd, float cone_w, const __global TriShade *tri_shade,
                      const __global float *vtx_uv, const __global float *vtx_uv1)
{
    TexCtx c;
    TriShade ts = tri_shade[prim];
    int sets = (m->flags & SPT_MAT_UV1) ? 2 : 1;
    float3 e1 = v1 - v0, e2 = v2 - v0;
    float3 fa = (float3)(0.0f), fb = (float3)(0.0f);
    float a1 = 0.0f, a2 = 0.0f, b1 = 0.0f, b2 = 0.0f;
    if (cone_w > 0.0f) {
        float cosv = fmax(fabs(dot(rd, ng)), 1e-3f);
        float3 across = cross(rd, ng);
        float la = length(across);
        vec3 t_, b_;
        v3_basis(ng, &t_, &b_);
        across = la > 1e-6f ? across / la : t_;
        fa = across * cone_w;
        fb = cross(ng, across) * (cone_w / cosv);
        /* Coordinates of fa and fb in the basis (e1, e2): the Gram system. */
        float d11 = dot(e1, e1), d12 = dot(e1, e2), d22 = dot(e2, e2);
        float det = d11 * d22 - d12 * d12;
        if (det > 1e-30f * d11 * d22) {
            float inv = 1.0f / det;
            float x1 = dot(fa, e1), x2 = dot(fa, e2);
            a1 = (d22 * x1 - d12 * x2) * inv;
            a2 = (d11 * x2 - d12 * x1) * inv;
            x1 = dot(fb, e1);
            x2 = dot(fb, e2);
            b1 = (d22 * x1 - d12 * x2) * inv;
            b2 = (d11 * x2 - d12 * x1) * inv;
        }
    }
    c.uv[1] = c.fa[1] = c.fb[1] = (float2)(0.0f);
    for (int k = 0; k < sets; k++) {
        const __global float *uvs = k ? vtx_uv1 : vtx_uv;
        float2 t0 = vload2(ts.v[0], uvs), t1 = vload2(ts.v[1], uvs), t2 = vload2(ts.v[2], uvs);
        c.uv[k] = (1.0f - bu - bv) * t0 + bu * t1 + bv * t2;
        c.fa[k] = a1 * (t1 - t0) + a2 * (t2 - t0);
        c.fb[k] = b1 * (t1 - t0) + b2 * (t2 - t0);
    }
    return c;
}

/* Whether material m reads texture coordinates or vertex colours at a hit (some
 * slot has a texture, or COLOR_0). */
static int material_uses_uv(const __global GpuMaterial *m)
{
    return (m->flags & (SPT_MAT_TEXTURED | SPT_MAT_VERTEX_COLOR)) != 0u;
}

/* COLOR_0 of packed triangle prim at (bu, bv), interpolated as spectra: the sigmoid
 * spectrum of each vertex's colour at lam (vtx_color: coefficients and alpha),
 * weighted by the barycentrics; the interpolated alpha in *alpha. */
static float4 tri_color(const __global TriShade *ts, const __global float4 *vtx_color, uint prim, float bu,
                        float bv, float4 lam, float *alpha)
{
    TriShade s = ts[prim];
    float4 a = vtx_color[s.v[0]], b = vtx_color[s.v[1]], c = vtx_color[s.v[2]];
    float wa = 1.0f - bu - bv;
    *alpha = wa * a.w + bu * b.w + bv * c.w;
    return wa * spec_sigmoid4(a.x, a.y, a.z, lam) + bu * spec_sigmoid4(b.x, b.y, b.z, lam) +
           bv * spec_sigmoid4(c.x, c.y, c.z, lam);
}

/* Opacity of material m at a hit: 1 for opaque materials; 0 or 1 for alphaMode MASK
 * (alpha against the cutoff); alpha itself for BLEND. alpha = the base colour's
 * alpha factor times the base colour texture's alpha times COLOR_0's alpha. A
 * cut-out reads its finest level: the cutoff of a blurred alpha is not the
 * blurred cut-out (distant foliage would thin out), while the pixel's samples
 * average the true one. */
static float material_opacity(const __global GpuMaterial *m, const TexCtx *c, uint prim, float bu, float bv,
                              const __global TriShade *tri_shade, const __global float4 *vtx_color,
                              const __global GpuTexture *textures, const __global float4 *texels)
{
    uint f = m->flags;
    if (!(f & (SPT_MAT_ALPHA_MASK | SPT_MAT_ALPHA_BLEND)))
        return 1.0f;
    float a = m->alpha;
    if (m->slot[SPT_TS_BASE].tex >= 0) {
        TexCtx fine = *c;
        if (f & SPT_MAT_ALPHA_MASK)
            fine.fa[0] = fine.fa[1] = fine.fb[0] = fine.fb[1] = (float2)(0.0f);
        a *= slot_value(m, SPT_TS_BASE, &fine, textures, texels).w;
    }
    if (f & SPT_MAT_VERTEX_COLOR) {
        TriShade s = tri_shade[prim];
        a *= (1.0f - bu - bv) * vtx_color[s.v[0]].w + bu * vtx_color[s.v[1]].w + bv * vtx_color[s.v[2]].w;
    }
    if (f & SPT_MAT_ALPHA_MASK)
        return a >= m->alpha_cutoff ? 1.0f : 0.0f;
    return clamp(a, 0.0f, 1.0f);
}

/* Emitted radiance of material m at a hit, at the four wavelengths: the emissive
 * factor (with KHR_materials_emissive_strength) times the emissive texture, seen
 * through the clear coat (1 - clearcoat Fc, KHR_materials_clearcoat's "Emission")
 * at cosine cos_v between the view and the surface. An unlit material's emission
 * is its base colour: times its base colour texture and COLOR_0. */
static float4 material_emission(const __global GpuMaterial *m, const TexCtx *c, float4 lam, float cos_v,
                                uint prim, float bu, float bv, const __global TriShade *tri_shade,
                                const __global float4 *vtx_color, const __global float *spectra,
                                const __global GpuTexture *textures, const __global float4 *texels)
{
    float4 le = spec_eval(&m->emission, lam, spectra);
    float w;
    if (m->slot[SPT_TS_EMISSIVE].tex >= 0)
        le *= slot_spectrum(m, SPT_TS_EMISSIVE, c, lam, textures, texels, &w);
    if ((m->flags & (SPT_MAT_UNLIT | SPT_MAT_VERTEX_COLOR)) == (SPT_MAT_UNLIT | SPT_MAT_VERTEX_COLOR))
        le *= tri_color(tri_shade, vtx_color, prim, bu, bv, lam, &w);
    if (m->clearcoat > 0.0f) {
        float cc = m->clearcoat;
        if (m->slot[SPT_TS_CLEARCOAT].tex >= 0)
            cc *= slot_value(m, SPT_TS_CLEARCOAT, c, textures, texels).x;
        le *= 1.0f - clamp(cc, 0.0f, 1.0f) * bsdf_coat_fresnel(cos_v);
    }
    return le;
}

/* The four wavelengths of a float4 as an array (for kernels/shared/lights.h). */
static void lambda_array(float4 lam, float *out)
{
    out[0] = lam.x;
    out[1] = lam.y;
    out[2] = lam.z;
    out[3] = lam.w;
}

/* Beer-Lambert transmittance over distance t inside the volume of material m
 * (KHR_materials_volume: attenuation colour c reached at attenuation distance d,
 * sigma = -ln(c) / d per wavelength). */
static float4 volume_transmittance(const __global GpuMaterial *m, float t, float4 lam,
                                   const __global float *spectra)
{
    float4 c = clamp(spec_eval(&m->attenuation, lam, spectra), 1e-6f, 1.0f);
    return exp(log(c) * (t / m->attenuation_distance));
}

/* Normal n bent by the tangent-space normal map of slot k (scale: the
 * normalTextureInfo's), with the tangent frame derived from the slot's
 * (transformed) texture coordinates over the triangle as MikkTSpace would for a
 * mesh without tangents: tangent along increasing u, bitangent toward decreasing v
 * (the image's +Y, glTF 2.0 "normalTexture"), its sign following the texture's
 * handedness on the triangle (mirrored coordinates). n itself when the texture
 * coordinates are degenerate. */
static float3 normal_map(const __global GpuMaterial *m, int k, float scale, float3 n, uint prim, float3 v0,
                         float3 v1, float3 v2, const TexCtx *c, const __global TriShade *tri_shade,
                         const __global float *vtx_uv, const __global float *vtx_uv1,
                         const __global GpuTexture *textures, const __global float4 *texels)
{
    const __global GpuTexSlot *s = m->slot + k;
    TriShade ts = tri_shade[prim];
    const __global float *uvs = s->uv_set ? vtx_uv1 : vtx_uv;
    float2 t0 = uv_apply(s->m, vload2(ts.v[0], uvs));
    float2 t1 = uv_apply(s->m, vload2(ts.v[1], uvs));
    float2 t2 = uv_apply(s->m, vload2(ts.v[2], uvs));
    float2 d1 = t1 - t0, d2 = t2 - t0;
    float det = d1.x * d2.y - d2.x * d1.y;
    if (!(fabs(det) > 1e-12f))
        return n;
    float3 dpdu = ((v1 - v0) * d2.y - (v2 - v0) * d1.y) / det;
    float3 dpdv = ((v2 - v0) * d1.x - (v1 - v0) * d2.x) / det;
    float3 tg = dpdu - n * dot(n, dpdu);
    float tl = length(tg);
    if (!(tl > 1e-12f))
        return n;
    tg /= tl;
    float3 bt = cross(n, tg);
    if (dot(bt, dpdv) > 0.0f)
        bt = -bt;
    float4 tx = slot_value(m, k, c, textures, texels);
    float3 nt = (float3)((2.0f * tx.x - 1.0f) * scale, (2.0f * tx.y - 1.0f) * scale, 2.0f * tx.z - 1.0f);
    float3 nb = nt.x * tg + nt.y * bt + nt.z * n;
    float nl = length(nb);
    return nl > 1e-6f ? nb / nl : n;
}

/* The shading normal of packed triangle prim at (bu, bv), on the side of the
 * face normal *ng (the winding's front): the interpolated vertex normal, bent by
 * the material's normal texture; *n_coat: the clear coat's normal, the vertex
 * normal bent by the clearcoat normal texture only (KHR_materials_clearcoat: the
 * base's normal map does not reach the coat). With follow_normals (a transmissive
 * surface, whose outside matters), a vertex normal that disagrees with the winding
 * wins: *ng is flipped instead. */
static float3 shading_normal(uint prim, float bu, float bv, float3 *ng, int follow_normals, float3 v0,
                             float3 v1, float3 v2, const __global GpuMaterial *m, const TexCtx *c,
                             float3 *n_coat, ALL_BUFFERS)
{
    TriShade ts = tri_shade[prim];
    float3 ns = *ng;
    float3 a = vload3(ts.v[0], vtx_normal), b = vload3(ts.v[1], vtx_normal),
           cc = vload3(ts.v[2], vtx_normal);
    float3 si = (1.0f - bu - bv) * a + bu * b + bv * cc;
    float len = length(si);
    if (len > 1e-6f) {
        si /= len;
        if (dot(si, *ng) < 0.0f) {
            if (follow_normals)
                *ng = -*ng;
            else
                si = -si;
        }
        ns = si;
    }
    *n_coat = ns;
    if (m->clearcoat > 0.0f && m->slot[SPT_TS_CLEARCOAT_NORMAL].tex >= 0)
        *n_coat = normal_map(m, SPT_TS_CLEARCOAT_NORMAL, m->cc_normal_scale, ns, prim, v0, v1, v2, c,
                             tri_shade, vtx_uv, vtx_uv1, textures, texels);
    if (m->slot[SPT_TS_NORMAL].tex >= 0)
        ns = normal_map(m, SPT_TS_NORMAL, m->normal_scale, ns, prim, v0, v1, v2, c, tri_shade, vtx_uv,
                        vtx_uv1, textures, texels);
    return ns;
}

/* The BSDF parameters of material m at a hit (texture context c, packed triangle
 * prim at (bu, bv)) for the wavelengths lam. Texture channels, as glTF 2.0 and its
 * extensions define them: base colour RGB (sRGB) and A; metallic B, roughness G;
 * transmission R; specular A, specular colour RGB (sRGB); clearcoat R, clearcoat
 * roughness G; sheen colour RGB (sRGB), sheen roughness A. COLOR_0 multiplies the
 * base colour. The coat normal is left to the caller (it needs the frame). */
static BsdfParams material_bsdf(const __global GpuMaterial *m, const TexCtx *c, uint prim, float bu, float bv,
                                float4 lam, const __global TriShade *tri_shade,
                                const __global float4 *vtx_color, const __global float *spectra,
                                const __global GpuTexture *textures, const __global float4 *texels)
{
    BsdfParams bp;
    float w;
    float4 base = spec_eval(&m->reflectance, lam, spectra);
    if (m->slot[SPT_TS_BASE].tex >= 0)
        base *= slot_spectrum(m, SPT_TS_BASE, c, lam, textures, texels, &w);
    if (m->flags & SPT_MAT_VERTEX_COLOR)
        base *= tri_color(tri_shade, vtx_color, prim, bu, bv, lam, &w);
    bp.base = clamp(base, 0.0f, 1.0f);
    bp.metallic = m->metallic;
    bp.roughness = m->roughness;
    if (m->slot[SPT_TS_METALLIC_ROUGHNESS].tex >= 0) {
        float4 t = slot_value(m, SPT_TS_METALLIC_ROUGHNESS, c, textures, texels);
        bp.roughness *= t.y;
        bp.metallic *= t.z;
    }
    bp.metallic = clamp(bp.metallic, 0.0f, 1.0f);
    bp.roughness = clamp(bp.roughness, 0.0f, 1.0f);
    bp.transmission = m->transmission;
    if (m->slot[SPT_TS_TRANSMISSION].tex >= 0)
        bp.transmission *= slot_value(m, SPT_TS_TRANSMISSION, c, textures, texels).x;
    bp.transmission = clamp(bp.transmission, 0.0f, 1.0f);
    float ior = fmax(m->ior, 1.0f);
    bp.ior = (float4)(bsdf_dispersion_ior(ior, m->dispersion, lam.x), bsdf_dispersion_ior(ior, m->dispersion, lam.y),
                      bsdf_dispersion_ior(ior, m->dispersion, lam.z), bsdf_dispersion_ior(ior, m->dispersion, lam.w));
    bp.eta = (float4)(1.0f);
    bp.k = (float4)(0.0f);
    bp.conductor = 0;
    if (m->conductor > 0)
        bsdf_set_conductor(&bp, m->conductor - 1, lam.x, lam.y, lam.z, lam.w);
    bp.spec_tint = m->spec_tint.kind == SPT_SPEC_NONE ? (float4)(1.0f) : spec_eval(&m->spec_tint, lam, spectra);
    if (m->slot[SPT_TS_SPECULAR_COLOR].tex >= 0)
        bp.spec_tint *= slot_spectrum(m, SPT_TS_SPECULAR_COLOR, c, lam, textures, texels, &w);
    bp.specular = m->specular;
    if (m->slot[SPT_TS_SPECULAR].tex >= 0)
        bp.specular = clamp(bp.specular * slot_value(m, SPT_TS_SPECULAR, c, textures, texels).w, 0.0f, 1.0f);
    bp.clearcoat = m->clearcoat;
    bp.cc_roughness = m->cc_roughness;
    if (bp.clearcoat > 0.0f) {
        if (m->slot[SPT_TS_CLEARCOAT].tex >= 0)
            bp.clearcoat *= slot_value(m, SPT_TS_CLEARCOAT, c, textures, texels).x;
        if (m->slot[SPT_TS_CLEARCOAT_ROUGHNESS].tex >= 0)
            bp.cc_roughness *= slot_value(m, SPT_TS_CLEARCOAT_ROUGHNESS, c, textures, texels).y;
    }
    bp.clearcoat = clamp(bp.clearcoat, 0.0f, 1.0f);
    bp.cc_roughness = clamp(bp.cc_roughness, 0.0f, 1.0f);
    bp.cc_n = (float3)(0.0f, 0.0f, 1.0f);
    bp.sheen = (float4)(0.0f);
    bp.sheen_max = 0.0f;
    bp.sheen_roughness = m->sheen_roughness;
    if (m->sheen.kind != SPT_SPEC_NONE) {
        bp.sheen = spec_eval(&m->sheen, lam, spectra);
        bp.sheen_max = m->sheen.scale;
        if (m->slot[SPT_TS_SHEEN_COLOR].tex >= 0) {
            bp.sheen *= slot_spectrum(m, SPT_TS_SHEEN_COLOR, c, lam, textures, texels, &w);
            bp.sheen_max *= w;
        }
        if (m->slot[SPT_TS_SHEEN_ROUGHNESS].tex >= 0)
            bp.sheen_roughness *= slot_value(m, SPT_TS_SHEEN_ROUGHNESS, c, textures, texels).w;
    }
    return bp;
}

/* Shades path i at its hit; returns 1 and fills the shadow ray (origin, direction
 * with tmax in w, contribution) when next-event estimation wants one. */
static int shade_path(uint i, float4 *sh_o, float4 *sh_d, float4 *sh_c, ALL_BUFFERS)
{
    int shadow = 0;
    float4 hit = ps_hit[i];
    uint prim = as_uint(hit.w);
    uint depth = ps_depth[i] + 1u; /* segments including the one just traced */
    float4 lam = ps_lambda[i];
    float4 beta = ps_throughput[i];
    uint medium = ps_medium[i];
    if (medium != 0u && prim != NO_HIT)
        beta *= volume_transmittance(materials + (medium - 1u), hit.x, lam, spectra);
    if (prim == NO_HIT) {
        /* The environment, weighted against light sampling by MIS. */
        if (P.env.kind != SPT_ENV_NONE) {
            float3 d = ps_ray_d[i].xyz;
            float la[4], le[4];
            lambda_array(lam, la);
            env_eval(&P.env, env_data, d, la, le);
            float w = 1.0f;
            float prev_pdf = ps_bsdf_pdf[i];
            if (prev_pdf > 0.0f && P.env_prob > 0.0f)
                w = spt_power_heuristic(prev_pdf, P.env_prob * env_pdf(&P.env, env_data, d));
            ps_radiance[i] += beta * (float4)(le[0], le[1], le[2], le[3]) * w;
        }
        ps_flags[i] = SPT_PATH_FINISHED;
        return 0;
    }
    float4 L = ps_radiance[i];
    float3 rd = ps_ray_d[i].xyz;
    vec3 v0, v1, v2;
    tri_positions(tri_shade, vtx_pos, prim, &v0, &v1, &v2);
    float bu = hit.y, bv = hit.z;
    float3 p = (1.0f - bu - bv) * v0 + bu * v1 + bv * v2;
    float3 ng = normalize(cross(v1 - v0, v2 - v0));
    int front = dot(ng, rd) < 0.0f;
    TriShade ts = tri_shade[prim];
    const __global GpuMaterial *m = materials + ts.material;
    /* The ray cone's width here: ray_d.w holds it at the last real vertex, and
     * ray_o.w the distance passed through alpha since. */
    float cone_w = ps_ray_d[i].w + P.cam_fwd[3] * (hit.x + ps_ray_o[i].w);
    TexCtx tc = {{(float2)(0.0f), (float2)(0.0f)}, {(float2)(0.0f), (float2)(0.0f)},
                 {(float2)(0.0f), (float2)(0.0f)}};
    if (material_uses_uv(m))
        tc = tex_ctx(m, prim, bu, bv, v0, v1, v2, ng, rd, cone_w, tri_shade, vtx_uv, vtx_uv1);

    /* Cut-out (MASK) and blended (BLEND) surfaces: with probability 1 - opacity the
     * path passes through unchanged, without counting a segment. */
    if (m->flags & (SPT_MAT_ALPHA_MASK | SPT_MAT_ALPHA_BLEND)) {
        float op = material_opacity(m, &tc, prim, bu, bv, tri_shade, vtx_color, textures, texels);
        uint passes = ps_passes[i];
        if (op < 1.0f && passes < 64u) {
            uint npx = (uint)(P.width * P.height);
            uint wk = ps_work[i];
            float u = spt_rand(P.seed ^ 0x9e3779b9u, wk % npx, P.sample_begin + wk / npx,
                               depth * 64u + passes);
            if (u >= op) {
                ps_passes[i] = passes + 1u;
                /* w carries the distance from the last real vertex, for MIS. */
                float3 o2 = offset_origin(p, front ? -ng : ng);
                ps_ray_o[i] = (float4)(o2, ps_ray_o[i].w + dot(o2 - ps_ray_o[i].xyz, rd));
                ps_throughput[i] = beta;
                return 0; /* same direction, depth and MIS state */
            }
        }
    }

    /* Emission on the front face, weighted against light sampling by MIS. */
    if ((m->flags & SPT_MAT_EMISSIVE) && (front || (m->flags & SPT_MAT_DOUBLE_SIDED_EMISSION))) {
        float4 le = material_emission(m, &tc, lam, fabs(dot(ng, rd)), prim, bu, bv, tri_shade, vtx_color,
                                      spectra, textures, texels);
        float w = 1.0f;
        float prev_pdf = ps_bsdf_pdf[i];
        if (prev_pdf > 0.0f) {
            float cos_l = fabs(dot(ng, rd));
            float dist = hit.x + ps_ray_o[i].w; /* w: distance passed through alpha */
            float light_pdf = tri_light_pdf[prim] * dist * dist / fmax(cos_l, 1e-8f);
            w = spt_power_heuristic(prev_pdf, light_pdf);
        }
        L += beta * le * w;
    }
    if ((P.max_depth > 0 && depth >= (uint)P.max_depth) || (m->flags & SPT_MAT_UNLIT)) {
        ps_radiance[i] = L;
        ps_flags[i] = SPT_PATH_FINISHED;
        return 0;
    }

    /* The shading frame. A transmissive surface keeps its outside (the winding's
     * front) as +z, so the BSDF knows which side the path is on; an opaque one is
     * shaded from whichever side the path arrives. */
    BsdfParams bp = material_bsdf(m, &tc, prim, bu, bv, lam, tri_shade, vtx_color, spectra, textures, texels);
    int two_sided_bsdf = bp.transmission > 0.0f && bp.metallic < 1.0f;
    float3 ngf = ng, n_coat;
    float3 ns = shading_normal(prim, bu, bv, &ngf, two_sided_bsdf, v0, v1, v2, m, &tc, &n_coat, ALL_ARGS);
    if (!two_sided_bsdf && !front) {
        ns = -ns;
        n_coat = -n_coat;
        ngf = -ng;
    }
    float3 wo = -rd;
    /* A shading normal that puts wo on the other side than the face does is not
     * used (it would leak light through the surface). */
    if (dot(wo, ns) * dot(wo, ngf) <= 0.0f)
        ns = ngf;
    vec3 tg, bt;
    v3_basis(ns, &tg, &bt);
    float3 wo_l = (float3)(dot(wo, tg), dot(wo, bt), dot(wo, ns));
    if (bp.clearcoat > 0.0f) {
        if (dot(wo, n_coat) * dot(wo, ngf) <= 0.0f)
            n_coat = ngf;
        bp.cc_n = normalize((float3)(dot(n_coat, tg), dot(n_coat, bt), dot(n_coat, ns)));
    }
    float wo_side = dot(wo, ngf);

    uint npix = (uint)(P.width * P.height);
    uint w_item = ps_work[i];
    uint pixel = w_item % npix;
    uint sample = P.sample_begin + w_item / npix;
    uint bounce = depth - 1u;
    uint key = spt_rng_key(P.seed, pixel, sample); /* spt_rand_key(key, d) = spt_rand(P.seed, pixel, sample, d) */

    /* Next-event estimation: one light chosen in proportion to power among the
     * emissive triangles, the punctual lights and the environment. */
    if (P.select_count > 0u && (P.max_depth <= 0 || depth + 1u <= (uint)P.max_depth) &&
        !bsdf_is_delta(&bp)) {
        float prob;
        int e = spt_discrete_sample(light_cdf, P.select_count,
                                    spt_rand_key(key, spt_dim_bounce(bounce, SPT_DIM_LIGHT_SELECT)),
                                    &prob, 0);
        float ul = spt_rand_key(key, spt_dim_bounce(bounce, SPT_DIM_LIGHT_U));
        float vl = spt_rand_key(key, spt_dim_bounce(bounce, SPT_DIM_LIGHT_V));
        float3 wi = (float3)(0.0f, 0.0f, 1.0f);
        float dist = 0.0f, light_pdf = 0.0f;
        float4 le = (float4)(0.0f);
        int delta = 0;
        if (e >= 0 && (uint)e < P.emitter_count) {
            uint lt = emitters[e];
            vec3 a, b, c;
            tri_positions(tri_shade, vtx_pos, lt, &a, &b, &c);
            vec3 bary = spt_sample_triangle_bary(ul, vl);
            float3 q = bary.x * a + bary.y * b + bary.z * c;
            float3 nl = normalize(cross(b - a, c - a));
            float3 dq = q - p;
            float dist2 = dot(dq, dq);
            dist = sqrt(dist2);
            wi = dq / dist;
            float cos_l = -dot(nl, wi);
            const __global GpuMaterial *lm = materials + tri_shade[lt].material;
            if (lm->flags & SPT_MAT_DOUBLE_SIDED_EMISSION)
                cos_l = fabs(cos_l);
            if (cos_l > 0.0f && dist > 0.0f) {
                light_pdf = tri_light_pdf[lt] * dist2 / cos_l;
                /* The emitter's textures at their finest level (no footprint). */
                TexCtx ltc = tc;
                if (material_uses_uv(lm))
                    ltc = tex_ctx(lm, lt, bary.y, bary.z, a, b, c, nl, wi, 0.0f, tri_shade, vtx_uv, vtx_uv1);
                le = material_emission(lm, &ltc, lam, cos_l, lt, bary.y, bary.z, tri_shade, vtx_color, spectra,
                                       textures, texels);
            }
        } else if (e >= 0 && (uint)e < P.emitter_count + P.light_count) {
            float la[4];
            lambda_array(lam, la);
            LightSample ls;
            light_punctual_sample(lights + ((uint)e - P.emitter_count), spectra, p, la, &ls);
            wi = ls.wi;
            dist = ls.dist;
            le = (float4)(ls.value[0], ls.value[1], ls.value[2], ls.value[3]);
            light_pdf = prob;
            delta = 1;
        } else if (e >= 0) {
            float epdf;
            wi = env_sample(&P.env, env_data, ul, vl, &epdf);
            dist = SPT_LIGHT_FAR;
            light_pdf = prob * epdf;
            if (light_pdf > 0.0f) {
                float la[4], lv[4];
                lambda_array(lam, la);
                env_eval(&P.env, env_data, wi, la, lv);
                le = (float4)(lv[0], lv[1], lv[2], lv[3]);
            }
        }
        float wi_side = dot(wi, ngf);
        float3 wi_l = (float3)(dot(wi, tg), dot(wi, bt), dot(wi, ns));
        /* The geometric and shading sides of wi must agree. */
        if (light_pdf > 0.0f && dist > 0.0f && wi_side * wi_l.z > 0.0f && max4(le) > 0.0f &&
            (two_sided_bsdf || wi_side > 0.0f)) {
            float4 f = bsdf_eval(&bp, wo_l, wi_l);
            float wgt = delta ? 1.0f : spt_power_heuristic(light_pdf, bsdf_pdf(&bp, wo_l, wi_l));
            float4 cn = beta * f * le * (wgt / light_pdf);
            if (max4(cn) > 0.0f) {
                float3 so = offset_origin(p, wi_side > 0.0f ? ngf : -ngf);
                *sh_o = (float4)(so, 0.0f);
                *sh_d = (float4)(wi, dist >= SPT_LIGHT_FAR ? SPT_LIGHT_FAR : dist * (1.0f - 1e-4f));
                *sh_c = cn;
                shadow = 1;
            }
        }
    }

    /* BSDF sampling. */
    BsdfSample bs = bsdf_sample(&bp, wo_l,
                                spt_rand_key(key, spt_dim_bounce(bounce, SPT_DIM_BSDF_LOBE)),
                                spt_rand_key(key, spt_dim_bounce(bounce, SPT_DIM_BSDF_U)),
                                spt_rand_key(key, spt_dim_bounce(bounce, SPT_DIM_BSDF_V)));
    float3 wn = bs.wi.x * tg + bs.wi.y * bt + bs.wi.z * ns;
    float wn_side = dot(wn, ngf);
    /* Reflection stays on wo's side of the face, refraction crosses it. */
    int reflect = bs.wi.z * wo_l.z > 0.0f;
    int alive = bs.valid && (reflect ? wn_side * wo_side > 0.0f : wn_side * wo_side < 0.0f);
    if (alive) {
        beta *= bs.weight;
        float4 lp = ps_lambda_pdf[i];
        if (bs.dispersive && lp.y > 0.0f) {
            /* The refraction split the wavelengths: only the hero carries on
             * (pbrt-v4's TerminateSecondary); its pdf becomes 1/4 of what it was. */
            lp = (float4)(0.25f * lp.x, 0.0f, 0.0f, 0.0f);
            ps_lambda_pdf[i] = lp;
        }
        if (!(lp.y > 0.0f))
            beta = (float4)(beta.x, 0.0f, 0.0f, 0.0f);
        alive = max4(beta) > 0.0f;
    }

    /* Russian roulette on the largest wavelength throughput, surviving with at
     * most 0.95 (as Mitsuba 3 does): a path whose throughput never drops (total
     * internal reflection inside a smooth sphere keeps it at exactly 1) must
     * still end. SPT_MAX_SEGMENTS bounds "unlimited" depth as a last resort. */
    if (alive && depth >= SPT_MAX_SEGMENTS)
        alive = 0;
    if (alive && depth >= P.rr_depth) {
        float qs = fmin(max4(beta), 0.95f);
        float u = spt_rand_key(key, spt_dim_bounce(bounce, SPT_DIM_ROULETTE));
        if (u >= qs)
            alive = 0;
        else
            beta /= qs;
    }
    ps_radiance[i] = L;
    if (!alive) {
        ps_flags[i] = SPT_PATH_FINISHED;
        return shadow;
    }
    /* Entering or leaving a volume (refraction through a transmissive surface). */
    if (!reflect && two_sided_bsdf)
        ps_medium[i] = wn_side < 0.0f && m->attenuation.kind != SPT_SPEC_NONE ? ts.material + 1u : 0u;
    ps_throughput[i] = beta;
    ps_ray_o[i] = (float4)(offset_origin(p, wn_side > 0.0f ? ngf : -ngf), 0.0f);
    ps_ray_d[i] = (float4)(wn, cone_w);
    ps_bsdf_pdf[i] = bs.is_delta ? 0.0f : bs.pdf;
    ps_depth[i] = depth;
    return shadow;
}

/* Prefetch distance of k_shade, in queue entries. */
#define SPT_SHADE_AHEAD 8u

__kernel void k_shade(ALL_BUFFERS)
{
    __local uint l_slot[SPT_GROUP_MAX], l_base;
    uint g = get_global_id(0);
    float4 so, sd, sc;
    int shadow = 0;
    uint i = 0;
    uint n = counters[SPT_CNT_EXTEND];
    if (g < n) {
        /* Cache misses hidden behind this path's work: the hit triangle's
         * shading record of the path 2 SPT_SHADE_AHEAD queue entries on is
         * fetched, and the vertex positions and normals of the one
         * SPT_SHADE_AHEAD on (whose record came in by now). */
        if (g + 2u * SPT_SHADE_AHEAD < n) {
            uint pa = as_uint(ps_hit[queue_extend[g + 2u * SPT_SHADE_AHEAD]].w);
            if (pa != NO_HIT)
                SPT_PREFETCH(tri_shade + pa);
        }
        if (g + SPT_SHADE_AHEAD < n) {
            uint pb = as_uint(ps_hit[queue_extend[g + SPT_SHADE_AHEAD]].w);
            if (pb != NO_HIT) {
                TriShade tb = tri_shade[pb];
                SPT_PREFETCH(vtx_pos + 3u * tb.v[0]);
                SPT_PREFETCH(vtx_pos + 3u * tb.v[1]);
                SPT_PREFETCH(vtx_pos + 3u * tb.v[2]);
                SPT_PREFETCH(vtx_normal + 3u * tb.v[0]);
                SPT_PREFETCH(vtx_normal + 3u * tb.v[1]);
                SPT_PREFETCH(vtx_normal + 3u * tb.v[2]);
            }
        }
        i = queue_extend[g];
        shadow = shade_path(i, &so, &sd, &sc, ALL_ARGS);
    }
    uint s = group_queue_slot(shadow, &counters[SPT_CNT_SHADOW], 0xffffffffu, 0, counters, l_slot,
                              &l_base);
    if (shadow) {
        sh_ray_o[s] = so;
        sh_ray_d[s] = sd;
        sh_contrib[s] = sc;
        sh_path[s] = i;
    }
}

__kernel void k_connect(ALL_BUFFERS)
{
    uint g = get_global_id(0);
    if (g >= counters[SPT_CNT_SHADOW])
        return;
    float4 d = sh_ray_d[g];
    float transmit = 1.0f;
    if (P.node_count > 0u && !P.has_alpha) {
        if (bvh_occluded(nodes, tris, sh_ray_o[g].xyz, d.xyz, d.w))
            return;
    } else if (P.node_count > 0u) {
        /* Surfaces with alpha let light through: walk the hits along the shadow
         * ray, multiplying by 1 - opacity (the expected transmission of the
         * stochastic opacity camera rays see). */
        float3 o = sh_ray_o[g].xyz;
        float tmax = d.w;
        for (int k = 0; k < 16; k++) {
            BvhHit h;
            if (!bvh_intersect(nodes, tris, o, d.xyz, tmax, &h))
                break;
            const __global GpuMaterial *m = materials + tri_shade[h.prim].material;
            vec3 a, b, c;
            tri_positions(tri_shade, vtx_pos, h.prim, &a, &b, &c);
            float3 ng = normalize(cross(b - a, c - a));
            float op = 1.0f;
            if (m->flags & (SPT_MAT_ALPHA_MASK | SPT_MAT_ALPHA_BLEND)) {
                /* At the finest level: a shadow ray carries no footprint. */
                TexCtx tc = tex_ctx(m, h.prim, h.u, h.v, a, b, c, ng, d.xyz, 0.0f, tri_shade, vtx_uv, vtx_uv1);
                op = material_opacity(m, &tc, h.prim, h.u, h.v, tri_shade, vtx_color, textures, texels);
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
    /* A path queues at most one shadow ray per iteration: no race on its radiance. */
    uint i = sh_path[g];
    ps_radiance[i] += transmit * sh_contrib[g];
}

/* Sums the chunk's per-sample contributions of each pixel, in sample order, into
 * chunk_sum (XYZ, and the number of samples kept in w). */
__kernel void k_accumulate(ALL_BUFFERS)
{
    uint pixel = get_global_id(0);
    uint npix = (uint)(P.width * P.height);
    if (pixel >= npix)
        return;
    uint n = (P.work_end - P.work_begin) / npix;
    float4 s = (float4)(0.0f);
    for (uint k = 0; k < n; k++)
        s += contrib[pixel + k * npix];
    chunk_sum[pixel] = s;
}
