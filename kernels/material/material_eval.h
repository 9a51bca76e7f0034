/* A surface hit's material, for kernels/integrator/shade_surface.h: the
 * triangle's geometry and texture footprint, and the material's opacity,
 * emission, albedo, normals and BSDF parameters at the hit. Each function takes
 * the buffers it reads. */
#ifndef SPT_MATERIAL_EVAL_H
#define SPT_MATERIAL_EVAL_H

#include "util/portable.h"
#include "util/vecmath.h"
#include "util/render_types.h"
#include "spectrum/spectrum.h"
#include "closure/bsdf.h"
#include "integrator/path.h"
#include "bvh/bvh_tlas.h"

SPT_DEVICE_ONLY

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

/* A hit's instance (docs/architecture.md, "Instances (two levels)"):
 * SPT_NO_INST for a scene without instances, whose vertices are in world space. */
#define SPT_NO_INST 0xffffffffu

/* Vertices a, b, c of instance in's mesh moved to world space. */
static void tri_to_world(const __global BvhInstance *in, float3 *a, float3 *b, float3 *c)
{
    *a = bvh_xf_apply(in->xf, *a, 1.0f);
    *b = bvh_xf_apply(in->xf, *b, 1.0f);
    *c = bvh_xf_apply(in->xf, *c, 1.0f);
}

/* The vertices of packed triangle prim in world space: through instance k of
 * inst (its mesh's space to the world) unless k is SPT_NO_INST. The winding
 * stays the mesh's: a mirrored instance's face normal is to be negated
 * (BVH_INSTANCE_MIRRORED). Inlined, so that a one-level scene's hits load
 * their vertices as tri_positions alone does, in the caller's code
 * (docs/performance.md, "Instances: two levels"). */
SPT_FN_INLINE void tri_world(const __global TriShade *ts, const __global float *vtx_pos,
                             const __global BvhInstance *inst, uint k, uint prim, float3 *a, float3 *b,
                             float3 *c)
{
    tri_positions(ts, vtx_pos, prim, a, b, c);
    if (k != SPT_NO_INST)
        tri_to_world(inst + k, a, b, c);
}

/* A vertex normal of instance k (SPT_NO_INST: in world space already) in world
 * space, unit as the loader makes a flattened copy's (0 stays 0: none given). */
static float3 vertex_normal_world(const __global BvhInstance *inst, uint k, float3 n)
{
    if (k == SPT_NO_INST)
        return n;
    float3 w = bvh_xf_normal(&inst[k], n);
    float l = length(w);
    return l > 0.0f ? w / l : (float3)(0.0f);
}

/* A vertex tangent t (unit xyz, w the bitangent's sign, 0 0 0 0: none) of
 * instance k (SPT_NO_INST: in world space already) in world space, as the
 * glTF loader moves a flattened copy's (src/scene/gltf_loader.h, mat_tangent):
 * xyz through the transform's linear part, normalised, and w negated where
 * the instance mirrors, since the bitangent cross(n, t) w must follow the
 * transform as t and the normal do (glTF 2.0 3.7.2.1). */
static float4 vertex_tangent_world(const __global BvhInstance *inst, uint k, float4 t)
{
    if (k == SPT_NO_INST || t.w == 0.0f)
        return t;
    float3 w = bvh_xf_apply(inst[k].xf, t.xyz, 0.0f);
    float l = length(w);
    if (!(l > 0.0f))
        return (float4)(0.0f);
    return (float4)(w / l, (inst[k].flags & BVH_INSTANCE_MIRRORED) ? -t.w : t.w);
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
    if (slot_textured(m, SPT_TS_BASE)) {
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
    if (slot_textured(m, SPT_TS_EMISSIVE))
        le *= slot_spectrum(m, SPT_TS_EMISSIVE, c, lam, textures, texels, &w);
    if ((m->flags & (SPT_MAT_UNLIT | SPT_MAT_VERTEX_COLOR)) == (SPT_MAT_UNLIT | SPT_MAT_VERTEX_COLOR))
        le *= tri_color(tri_shade, vtx_color, prim, bu, bv, lam, &w);
    if (m->clearcoat > 0.0f) {
        float cc = m->clearcoat;
        if (slot_textured(m, SPT_TS_CLEARCOAT))
            cc *= slot_value(m, SPT_TS_CLEARCOAT, c, textures, texels).x;
        le *= 1.0f - clamp(cc, 0.0f, 1.0f) * bsdf_coat_fresnel(cos_v);
    }
    return le;
}

/* The four wavelengths of a float4 as an array (for kernels/light/lights.h). */
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

/* The tangent frame at unit normal n of a triangle (v0, v1, v2) with texture
 * coordinates t0, t1, t2, as MikkTSpace would derive it for a mesh without
 * tangents (docs/gltf.md, "Tangents"): tangent along increasing u, bitangent
 * toward decreasing v (the image's +Y, glTF 2.0 "normalTexture"), its sign
 * following the texture's handedness on the triangle (mirrored coordinates).
 * Returns 0 when the texture coordinates are degenerate. */
static int uv_tangent_frame(float2 t0, float2 t1, float2 t2, float3 n, float3 v0, float3 v1, float3 v2,
                            float3 *tg, float3 *bt)
{
    float2 d1 = t1 - t0, d2 = t2 - t0;
    float det = d1.x * d2.y - d2.x * d1.y;
    if (!(fabs(det) > 1e-12f))
        return 0;
    float3 dpdu = ((v1 - v0) * d2.y - (v2 - v0) * d1.y) / det;
    float3 dpdv = ((v2 - v0) * d1.x - (v1 - v0) * d2.x) / det;
    float3 t = dpdu - n * dot(n, dpdu);
    float tl = length(t);
    if (!(tl > 1e-12f))
        return 0;
    t /= tl;
    float3 b = cross(n, t);
    if (dot(b, dpdv) > 0.0f)
        b = -b;
    *tg = t;
    *bt = b;
    return 1;
}

/* The mesh's tangent frame at (bu, bv) of packed triangle prim of instance k
 * of inst (SPT_NO_INST: a world-space triangle), for material m with
 * SPT_MAT_TANGENTS: TANGENT in world space (vertex_tangent_world)
 * interpolated and orthogonalised at the unit world normal n, the bitangent
 * cross(nv, t) w (glTF 2.0 3.7.2.1, nv the world vertex normal; its sign is
 * what the frame takes from it) made orthogonal to both. Returns 0 where a
 * vertex of the triangle has no tangent (w 0) or the tangent is parallel to n. */
static int mesh_tangent_frame(const __global GpuMaterial *m, uint prim, float bu, float bv, float3 n, float3 nv,
                              const __global TriShade *tri_shade, const __global float4 *vtx_tangent,
                              const __global BvhInstance *inst, uint k, float3 *tg, float3 *bt)
{
    if (!(m->flags & SPT_MAT_TANGENTS))
        return 0;
    TriShade ts = tri_shade[prim];
    float4 a = vertex_tangent_world(inst, k, vtx_tangent[ts.v[0]]),
           b = vertex_tangent_world(inst, k, vtx_tangent[ts.v[1]]),
           c = vertex_tangent_world(inst, k, vtx_tangent[ts.v[2]]);
    if (a.w == 0.0f || b.w == 0.0f || c.w == 0.0f)
        return 0;
    float3 t = (1.0f - bu - bv) * a.xyz + bu * b.xyz + bv * c.xyz;
    t -= n * dot(n, t);
    float tl = length(t);
    if (!(tl > 1e-6f))
        return 0;
    t /= tl;
    float3 b0 = cross(n, t);
    *tg = t;
    *bt = dot(b0, cross(nv, t) * a.w) < 0.0f ? -b0 : b0;
    return 1;
}

/* Normal n (the interpolated world vertex normal) bent by the tangent-space
 * normal map of slot k (scale: the normalTextureInfo's), in the mesh's tangent
 * frame (mesh_tangent_frame, the triangle instance ik's of inst) or, without
 * TANGENT, the frame uv_tangent_frame derives from the slot's (transformed)
 * texture coordinates on the world vertices v0, v1, v2. n itself when they
 * are degenerate. */
static float3 normal_map(const __global GpuMaterial *m, int k, float scale, float3 n, uint prim, float bu,
                         float bv, float3 v0, float3 v1, float3 v2, const TexCtx *c,
                         const __global TriShade *tri_shade, const __global float *vtx_uv,
                         const __global float *vtx_uv1, const __global float4 *vtx_tangent,
                         const __global GpuTexture *textures, const __global float4 *texels,
                         const __global BvhInstance *inst, uint ik)
{
    const __global GpuTexSlot *s = m->slot + k;
    TriShade ts = tri_shade[prim];
    const __global float *uvs = s->uv_set ? vtx_uv1 : vtx_uv;
    float3 tg, bt;
    if (!mesh_tangent_frame(m, prim, bu, bv, n, n, tri_shade, vtx_tangent, inst, ik, &tg, &bt) &&
        !uv_tangent_frame(uv_apply(s->m, vload2(ts.v[0], uvs)), uv_apply(s->m, vload2(ts.v[1], uvs)),
                          uv_apply(s->m, vload2(ts.v[2], uvs)), n, v0, v1, v2, &tg, &bt))
        return n;
    float4 tx = slot_value(m, k, c, textures, texels);
    float3 nt = (float3)((2.0f * tx.x - 1.0f) * scale, (2.0f * tx.y - 1.0f) * scale, 2.0f * tx.z - 1.0f);
    float3 nb = nt.x * tg + nt.y * bt + nt.z * n;
    float nl = length(nb);
    return nl > 1e-6f ? nb / nl : n;
}

/* KHR_materials_anisotropy's direction at a hit (packed triangle prim of
 * instance k of inst at (bu, bv), world vertices v0, v1, v2, shading normal n,
 * face normal ng on the winding's front), in the local
 * frame (tg, bt, n) of the BSDF: the material's direction in tangent space
 * (dir, from material_bsdf) mapped through the mesh's tangent frame
 * (mesh_tangent_frame) or, without TANGENT, the one of the anisotropy slot's
 * untransformed texture coordinates (uv_tangent_frame: the frame MikkTSpace
 * would generate, docs/gltf.md "Tangents"), projected on the shading plane.
 * The local x axis when neither exists. */
static float3 aniso_direction(const __global GpuMaterial *m, float3 dir, float3 n, float3 ng, float3 tg,
                              float3 bt, uint prim, float bu, float bv, float3 v0, float3 v1, float3 v2,
                              const __global TriShade *tri_shade, const __global float *vtx_normal,
                              const __global float *vtx_uv, const __global float *vtx_uv1,
                              const __global float4 *vtx_tangent, const __global BvhInstance *inst, uint k)
{
    TriShade ts = tri_shade[prim];
    const __global float *uvs = m->slot[SPT_TS_ANISOTROPY].uv_set ? vtx_uv1 : vtx_uv;
    float3 nv = (1.0f - bu - bv) * vertex_normal_world(inst, k, vload3(ts.v[0], vtx_normal)) +
                bu * vertex_normal_world(inst, k, vload3(ts.v[1], vtx_normal)) +
                bv * vertex_normal_world(inst, k, vload3(ts.v[2], vtx_normal));
    if (!(length(nv) > 1e-6f))
        nv = ng;
    float3 ut, ub;
    if (!mesh_tangent_frame(m, prim, bu, bv, n, nv, tri_shade, vtx_tangent, inst, k, &ut, &ub) &&
        !uv_tangent_frame(vload2(ts.v[0], uvs), vload2(ts.v[1], uvs), vload2(ts.v[2], uvs), n, v0, v1, v2,
                          &ut, &ub))
        return (float3)(1.0f, 0.0f, 0.0f);
    float3 a = dir.x * ut + dir.y * ub;
    float2 l = (float2)(dot(a, tg), dot(a, bt));
    float ll = length(l);
    return ll > 1e-6f ? (float3)(l / ll, 0.0f) : (float3)(1.0f, 0.0f, 0.0f);
}

/* The shading normal of packed triangle prim at (bu, bv), on the side of the
 * face normal *ng (the winding's front): the interpolated vertex normal, bent by
 * the material's normal texture; *n_coat: the clear coat's normal, the vertex
 * normal bent by the clearcoat normal texture only (KHR_materials_clearcoat: the
 * base's normal map does not reach the coat). With follow_normals (a transmissive
 * surface, whose outside matters), a vertex normal that disagrees with the winding
 * wins: *ng is flipped instead. The vertex normals are instance k's of inst
 * (tri_world). */
static float3 shading_normal(uint prim, float bu, float bv, float3 *ng, int follow_normals, float3 v0,
                             float3 v1, float3 v2, const __global GpuMaterial *m, const TexCtx *c,
                             float3 *n_coat, const __global TriShade *tri_shade,
                             const __global float *vtx_normal, const __global float *vtx_uv,
                             const __global float *vtx_uv1, const __global float4 *vtx_tangent,
                             const __global GpuTexture *textures, const __global float4 *texels,
                             const __global BvhInstance *inst, uint k)
{
    TriShade ts = tri_shade[prim];
    float3 ns = *ng;
    float3 a = vertex_normal_world(inst, k, vload3(ts.v[0], vtx_normal)),
           b = vertex_normal_world(inst, k, vload3(ts.v[1], vtx_normal)),
           cc = vertex_normal_world(inst, k, vload3(ts.v[2], vtx_normal));
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
    if (m->clearcoat > 0.0f && slot_textured(m, SPT_TS_CLEARCOAT_NORMAL))
        *n_coat = normal_map(m, SPT_TS_CLEARCOAT_NORMAL, m->cc_normal_scale, ns, prim, bu, bv, v0, v1, v2, c,
                             tri_shade, vtx_uv, vtx_uv1, vtx_tangent, textures, texels, inst, k);
    if (slot_textured(m, SPT_TS_NORMAL))
        ns = normal_map(m, SPT_TS_NORMAL, m->normal_scale, ns, prim, bu, bv, v0, v1, v2, c, tri_shade, vtx_uv,
                        vtx_uv1, vtx_tangent, textures, texels, inst, k);
    return ns;
}

/* The base colour of material m at a hit (texture context c, packed triangle
 * prim at (bu, bv)) at the wavelengths lam: the factor times the base colour
 * texture times COLOR_0, clamped to [0, 1]. */
static float4 material_base(const __global GpuMaterial *m, const TexCtx *c, uint prim, float bu, float bv,
                            float4 lam, const __global TriShade *tri_shade,
                            const __global float4 *vtx_color, const __global float *spectra,
                            const __global GpuTexture *textures, const __global float4 *texels)
{
    float w;
    float4 base = spec_eval(&m->reflectance, lam, spectra);
    if (slot_textured(m, SPT_TS_BASE))
        base *= slot_spectrum(m, SPT_TS_BASE, c, lam, textures, texels, &w);
    if (m->flags & SPT_MAT_VERTEX_COLOR)
        base *= tri_color(tri_shade, vtx_color, prim, bu, bv, lam, &w);
    return clamp(base, 0.0f, 1.0f);
}

#ifdef SPT_AOV
/* The albedo AOV of material m at a hit: the linear sRGB of its base colour
 * (material_base) as a reflectance under D65, from the CIE 1931 functions and
 * D65 every 10 nm over 360-830 nm (the 1 nm tables sampled: sigmoid spectra
 * are smooth on that scale), normalised so that a reflectance of 1 is
 * (1, 1, 1). The same for every sample: no wavelength noise. */
static float3 material_albedo(const __global GpuMaterial *m, const TexCtx *c, uint prim, float bu, float bv,
                              const __global TriShade *tri_shade, const __global float4 *vtx_color,
                              const __global float *spectra, const __global GpuTexture *textures,
                              const __global float4 *texels)
{
    float3 xyz = (float3)(0.0f);
    float norm = 0.0f;
    for (int k = 0; k < 12; k++) {
        float4 lam = (float)SPT_CIE_LAMBDA_MIN + 10.0f * ((float)(4 * k) + (float4)(0.0f, 1.0f, 2.0f, 3.0f));
        float4 s = material_base(m, c, prim, bu, bv, lam, tri_shade, vtx_color, spectra, textures, texels);
        float4 d = (float4)(spt_d65_norm(lam.x), spt_d65_norm(lam.y), spt_d65_norm(lam.z),
                            spt_d65_norm(lam.w));
        float4 cx = cie_lookup4(SPT_CIE_X, lam), cy = cie_lookup4(SPT_CIE_Y, lam),
               cz = cie_lookup4(SPT_CIE_Z, lam);
        float4 sd = s * d;
        xyz += (float3)(dot(sd, cx), dot(sd, cy), dot(sd, cz));
        norm += dot(d, cy);
    }
    return path_xyz_to_linear_srgb(xyz / norm);
}
#endif

/* KHR_materials_anisotropy and KHR_materials_diffuse_transmission of material m
 * at a hit into bp: the strength times the anisotropy texture's B, the
 * direction (R, G) * 2 - 1 (else (1, 0)) rotated by anisotropyRotation, in
 * tangent space (shade_frame maps it to the local frame); the diffuse
 * transmission factor times its texture's A, the colour times its texture's
 * RGB (sRGB). */
static void material_bsdf_ext(const __global GpuMaterial *m, const TexCtx *c, float4 lam,
                              const __global float *spectra, const __global GpuTexture *textures,
                              const __global float4 *texels, BsdfParams *bp)
{
    float w;
    if (!SPT_LAYERS) {
        /* No material of the scene has these (bsdf_params.h, SPT_LAYERS). */
        bp->aniso = 0.0f;
        bp->aniso_t = (float3)(1.0f, 0.0f, 0.0f);
        bp->diffuse_transmission = 0.0f;
        bp->dt_color = (float4)(0.0f);
        return;
    }
    bp->aniso = m->aniso;
    float2 d = (float2)(1.0f, 0.0f);
    if (m->aniso > 0.0f && slot_textured(m, SPT_TS_ANISOTROPY)) {
        float4 t = slot_value(m, SPT_TS_ANISOTROPY, c, textures, texels);
        d = (float2)(2.0f * t.x - 1.0f, 2.0f * t.y - 1.0f);
        bp->aniso *= t.z;
    }
    bp->aniso = clamp(bp->aniso, 0.0f, 1.0f);
    bp->aniso_t = (float3)(m->aniso_cos * d.x - m->aniso_sin * d.y, m->aniso_sin * d.x + m->aniso_cos * d.y, 0.0f);
    bp->diffuse_transmission = m->diffuse_transmission;
    bp->dt_color = (float4)(0.0f);
    if (m->diffuse_transmission > 0.0f) {
        if (slot_textured(m, SPT_TS_DIFFUSE_TRANSMISSION))
            bp->diffuse_transmission *= slot_value(m, SPT_TS_DIFFUSE_TRANSMISSION, c, textures, texels).w;
        bp->dt_color = spec_eval(&m->dt_color, lam, spectra);
        if (slot_textured(m, SPT_TS_DIFFUSE_TRANSMISSION_COLOR))
            bp->dt_color *= slot_spectrum(m, SPT_TS_DIFFUSE_TRANSMISSION_COLOR, c, lam, textures, texels, &w);
        bp->dt_color = clamp(bp->dt_color, 0.0f, 1.0f);
    }
    bp->diffuse_transmission = clamp(bp->diffuse_transmission, 0.0f, 1.0f);
}

/* The BSDF parameters of material m at a hit (texture context c, packed triangle
 * prim at (bu, bv)) for the wavelengths lam. Texture channels, as glTF 2.0 and its
 * extensions define them: base colour RGB (sRGB) and A; metallic B, roughness G;
 * transmission R; specular A, specular colour RGB (sRGB); clearcoat R, clearcoat
 * roughness G; sheen colour RGB (sRGB), sheen roughness A; iridescence R,
 * iridescence thickness G (between the minimum and maximum; the maximum
 * without a texture, as KHR_materials_iridescence says); anisotropy RG
 * direction, B strength; diffuse transmission A, its colour RGB (sRGB)
 * (material_bsdf_ext). COLOR_0 multiplies the
 * base colour. The coat normal is left to the caller (it needs the frame). */
static BsdfParams material_bsdf(const __global GpuMaterial *m, const TexCtx *c, uint prim, float bu, float bv,
                                float4 lam, const __global TriShade *tri_shade,
                                const __global float4 *vtx_color, const __global float *spectra,
                                const __global GpuTexture *textures, const __global float4 *texels)
{
    BsdfParams bp;
    float w;
    bp.base = material_base(m, c, prim, bu, bv, lam, tri_shade, vtx_color, spectra, textures, texels);
    bp.metallic = m->metallic;
    bp.roughness = m->roughness;
    if (slot_textured(m, SPT_TS_METALLIC_ROUGHNESS)) {
        float4 t = slot_value(m, SPT_TS_METALLIC_ROUGHNESS, c, textures, texels);
        bp.roughness *= t.y;
        bp.metallic *= t.z;
    }
    bp.metallic = clamp(bp.metallic, 0.0f, 1.0f);
    bp.roughness = clamp(bp.roughness, 0.0f, 1.0f);
    bp.transmission = m->transmission;
    if (slot_textured(m, SPT_TS_TRANSMISSION))
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
    if (slot_textured(m, SPT_TS_SPECULAR_COLOR))
        bp.spec_tint *= slot_spectrum(m, SPT_TS_SPECULAR_COLOR, c, lam, textures, texels, &w);
    bp.specular = m->specular;
    if (slot_textured(m, SPT_TS_SPECULAR))
        bp.specular = clamp(bp.specular * slot_value(m, SPT_TS_SPECULAR, c, textures, texels).w, 0.0f, 1.0f);
    bp.clearcoat = m->clearcoat;
    bp.cc_roughness = m->cc_roughness;
    if (bp.clearcoat > 0.0f) {
        if (slot_textured(m, SPT_TS_CLEARCOAT))
            bp.clearcoat *= slot_value(m, SPT_TS_CLEARCOAT, c, textures, texels).x;
        if (slot_textured(m, SPT_TS_CLEARCOAT_ROUGHNESS))
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
        if (slot_textured(m, SPT_TS_SHEEN_COLOR)) {
            bp.sheen *= slot_spectrum(m, SPT_TS_SHEEN_COLOR, c, lam, textures, texels, &w);
            bp.sheen_max *= w;
        }
        if (slot_textured(m, SPT_TS_SHEEN_ROUGHNESS))
            bp.sheen_roughness *= slot_value(m, SPT_TS_SHEEN_ROUGHNESS, c, textures, texels).w;
    }
    bp.lambda = lam;
    bp.iridescence = m->iridescence;
    bp.film_ior = m->irid_ior;
    bp.film_nm = m->irid_max_nm;
    if (bp.iridescence > 0.0f) {
        if (slot_textured(m, SPT_TS_IRIDESCENCE))
            bp.iridescence *= slot_value(m, SPT_TS_IRIDESCENCE, c, textures, texels).x;
        if (slot_textured(m, SPT_TS_IRIDESCENCE_THICKNESS))
            bp.film_nm = mix(m->irid_min_nm, m->irid_max_nm,
                             slot_value(m, SPT_TS_IRIDESCENCE_THICKNESS, c, textures, texels).y);
    }
    bp.iridescence = clamp(bp.iridescence, 0.0f, 1.0f);
    material_bsdf_ext(m, c, lam, spectra, textures, texels, &bp);
    return bp;
}

#endif
