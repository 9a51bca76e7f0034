/* Surface shading of the wavefront kernels (kernels/device/wavefront.cl, which
 * includes this where k_shade's helpers belong, after defining ALL_BUFFERS,
 * ALL_ARGS and NO_HIT): the hit's geometry and texture footprint, the
 * materials' opacity, emission, normals and BSDF parameters, and shade_path cut
 * into the steps of a surface hit (miss, alpha, emission, direct light, BSDF
 * bounce, Russian roulette). */
#ifndef SPT_SHADE_SURFACE_H
#define SPT_SHADE_SURFACE_H

#include "shared/portable.h"

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
    if (m->slot[SPT_TS_BASE].tex >= 0)
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
    bp.base = material_base(m, c, prim, bu, bv, lam, tri_shade, vtx_color, spectra, textures, texels);
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

/* shade_path's steps, in the order it runs them (as Cycles' shade_surface):
 * the miss, the hit's geometry, alpha, emission, the shading frame, direct light,
 * the BSDF bounce and Russian roulette. What they share: */
typedef struct ShadeHit {
    uint i;           /* the path */
    uint prim;        /* the hit triangle (packed index) */
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
    float3 ngf;         /* the face normal on the side the BSDF's +z is on */
    float3 ns, tg, bt;  /* the shading normal and its tangent basis */
    float3 wo_l;        /* the direction to the previous vertex, local */
    float wo_side;      /* its side of the face */
    SptSampler smp;     /* the path's sample: its dims (kernels/device/rng.h) */
    uint key;           /* smp.rand_key: spt_rand_key(key, d) = spt_rand(seed, pixel, sample, d),
                           for dims the sampler does not serve */
    uint bounce;
} ShadeFrame;

/* The camera paths' share of the path space beside the light-tracing pass
 * (kernels/device/light_trace.h), which owns the paths camera - x1 - s+ -
 * light: x1 a non-delta vertex (its lobe sampled as such), s+ one or more
 * delta vertices, the light an emissive triangle of the light selection.
 * lt_camera_next is a camera path's state after the vertex at depth `depth`
 * sampled a lobe (delta or not); lt_camera_drops says whether emission of
 * triangle prim reached with state lt is the light-tracing pass's. With the
 * pass off (P.light_paths 0) every camera path keeps everything. */
SPT_FN_INLINE uint lt_camera_next(uint lt, uint depth, int is_delta)
{
    if (depth == 1u)
        return is_delta ? 0u : SPT_LT_CHAIN;
    return is_delta ? (lt | SPT_LT_SPEC) : 0u;
}

SPT_FN_INLINE int lt_camera_drops(uint lt, uint prim, ALL_BUFFERS)
{
    return P.light_paths > 0u && lt == (SPT_LT_CHAIN | SPT_LT_SPEC) && tri_light_pdf[prim] > 0.0f;
}

/* A path that left the scene sees the environment, weighted against light
 * sampling by MIS; it ends. */
SPT_FN_INLINE void shade_miss(uint i, float4 lam, float4 beta, ALL_BUFFERS)
{
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
}

/* The geometry and material of the hit, and its texture footprint tc. */
SPT_FN_INLINE void shade_hit_geometry(ShadeHit *h, TexCtx *tc, ALL_BUFFERS)
{
    uint i = h->i;
    h->L = ps_radiance[i];
    h->rd = ps_ray_d[i].xyz;
    tri_positions(tri_shade, vtx_pos, h->prim, &h->v0, &h->v1, &h->v2);
    h->bu = h->hit.y;
    h->bv = h->hit.z;
    h->p = (1.0f - h->bu - h->bv) * h->v0 + h->bu * h->v1 + h->bv * h->v2;
    h->ng = normalize(cross(h->v1 - h->v0, h->v2 - h->v0));
    h->front = dot(h->ng, h->rd) < 0.0f;
    h->ts = tri_shade[h->prim];
    h->m = materials + h->ts.material;
    /* The ray cone's width here: ray_d.w holds it at the last real vertex, and
     * ray_o.w the distance passed through alpha since. */
    h->cone_w = ps_ray_d[i].w + P.cam_fwd[3] * (h->hit.x + ps_ray_o[i].w);
    TexCtx none = {{(float2)(0.0f), (float2)(0.0f)}, {(float2)(0.0f), (float2)(0.0f)},
                   {(float2)(0.0f), (float2)(0.0f)}};
    *tc = none;
    if (material_uses_uv(h->m))
        *tc = tex_ctx(h->m, h->prim, h->bu, h->bv, h->v0, h->v1, h->v2, h->ng, h->rd, h->cone_w,
                      tri_shade, vtx_uv, vtx_uv1);
}

/* Cut-out (MASK) and blended (BLEND) surfaces: with probability 1 - opacity the
 * path passes through unchanged, without counting a segment, by the random
 * numbers of (seed, pixel, sample). Returns 1 when it does (its ray now starts
 * past the surface). */
SPT_FN_INLINE int shade_alpha(const ShadeHit *h, const TexCtx *tc, uint seed, uint pixel, uint sample,
                              ALL_BUFFERS)
{
    const __global GpuMaterial *m = h->m;
    uint i = h->i;
    if (!(m->flags & (SPT_MAT_ALPHA_MASK | SPT_MAT_ALPHA_BLEND)))
        return 0;
    float op = material_opacity(m, tc, h->prim, h->bu, h->bv, tri_shade, vtx_color, textures, texels);
    uint passes = ps_passes[i];
    if (op < 1.0f && passes < 64u) {
        float u = spt_rand(seed ^ 0x9e3779b9u, pixel, sample, h->depth * 64u + passes);
        if (u >= op) {
            ps_passes[i] = passes + 1u;
            /* w carries the distance from the last real vertex, for MIS. */
            float3 o2 = offset_origin(h->p, h->front ? -h->ng : h->ng);
            ps_ray_o[i] = (float4)(o2, ps_ray_o[i].w + dot(o2 - ps_ray_o[i].xyz, h->rd));
            ps_throughput[i] = h->beta;
            return 1; /* same direction, depth and MIS state */
        }
    }
    return 0;
}

/* Emission on the front face, weighted against light sampling by MIS. */
SPT_FN_INLINE void shade_emission(ShadeHit *h, const TexCtx *tc, ALL_BUFFERS)
{
    const __global GpuMaterial *m = h->m;
    uint i = h->i;
    if (!((m->flags & SPT_MAT_EMISSIVE) && (h->front || (m->flags & SPT_MAT_DOUBLE_SIDED_EMISSION))))
        return;
    /* Light reached through delta vertices from a first non-delta vertex: the
     * light-tracing pass counts those paths (kernels/device/light_trace.h). */
    if (lt_camera_drops(ps_lt[i], h->prim, ALL_ARGS))
        return;
    float4 le = material_emission(m, tc, h->lam, fabs(dot(h->ng, h->rd)), h->prim, h->bu, h->bv,
                                  tri_shade, vtx_color, spectra, textures, texels);
    float w = 1.0f;
    float prev_pdf = ps_bsdf_pdf[i];
    if (prev_pdf > 0.0f) {
        float cos_l = fabs(dot(h->ng, h->rd));
        float dist = h->hit.x + ps_ray_o[i].w; /* w: distance passed through alpha */
        float light_pdf = tri_light_pdf[h->prim] * dist * dist / fmax(cos_l, 1e-8f);
        w = spt_power_heuristic(prev_pdf, light_pdf);
    }
    h->L += h->beta * le * w;
}

/* The shading frame. A transmissive surface keeps its outside (the winding's
 * front) as +z, so the BSDF knows which side the path is on; an opaque one is
 * shaded from whichever side the path arrives. */
SPT_FN_INLINE void shade_frame(const ShadeHit *h, const TexCtx *tc, BsdfParams *bp, ShadeFrame *f,
                               SptSampler smp, ALL_BUFFERS)
{
    const __global GpuMaterial *m = h->m;
    uint prim = h->prim;
    *bp = material_bsdf(m, tc, prim, h->bu, h->bv, h->lam, tri_shade, vtx_color, spectra, textures,
                        texels);
    f->two_sided_bsdf = bp->transmission > 0.0f && bp->metallic < 1.0f;
    float3 ngf = h->ng, n_coat;
    float3 ns = shading_normal(prim, h->bu, h->bv, &ngf, f->two_sided_bsdf, h->v0, h->v1, h->v2, m, tc,
                               &n_coat, ALL_ARGS);
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
}

/* Next-event estimation: one light chosen in proportion to power among the
 * emissive triangles, the punctual lights and the environment. Returns 1 and
 * fills the shadow ray (origin, direction with tmax in w, contribution) when the
 * light's contribution is not zero. */
SPT_FN_INLINE int shade_direct_light(const ShadeHit *h, const TexCtx *tc, const BsdfParams *bp,
                                     const ShadeFrame *f, float4 *sh_o, float4 *sh_d, float4 *sh_c,
                                     ALL_BUFFERS)
{
    uint depth = h->depth, bounce = f->bounce;
    float4 lam = h->lam;
    float3 p = h->p, ngf = f->ngf, tg = f->tg, bt = f->bt, ns = f->ns, wo_l = f->wo_l;
    if (!(P.select_count > 0u && (P.max_depth <= 0 || depth + 1u <= (uint)P.max_depth) &&
          !bsdf_is_delta(bp)))
        return 0;
    float prob, usel, ul, vl;
    usel = spt_sampler_1d(f->smp, spt_dim_bounce(bounce, SPT_DIM_LIGHT_SELECT));
    spt_sampler_pair(f->smp, spt_dim_bounce(bounce, SPT_DIM_LIGHT_U), &ul, &vl);
    int e = spt_discrete_sample(light_cdf, P.select_count, usel, &prob, 0);
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
            TexCtx ltc = *tc;
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
        (f->two_sided_bsdf || wi_side > 0.0f)) {
        float4 fv = bsdf_eval(bp, wo_l, wi_l);
        float wgt = delta ? 1.0f : spt_power_heuristic(light_pdf, bsdf_pdf(bp, wo_l, wi_l));
        float4 cn = h->beta * fv * le * (wgt / light_pdf);
        if (max4(cn) > 0.0f) {
            float3 so = offset_origin(p, wi_side > 0.0f ? ngf : -ngf);
            *sh_o = (float4)(so, 0.0f);
            *sh_d = (float4)(wi, dist >= SPT_LIGHT_FAR ? SPT_LIGHT_FAR : dist * (1.0f - 1e-4f));
            *sh_c = cn;
            return 1;
        }
    }
    return 0;
}

/* BSDF sampling: the next direction wn (world), its side of the face, whether it
 * reflects; h->beta takes the sample's weight. Returns whether the path goes on. */
SPT_FN_INLINE int shade_bsdf_bounce(ShadeHit *h, const BsdfParams *bp, const ShadeFrame *f, BsdfSample *bs,
                                    float3 *wn, float *wn_side, int *reflect, ALL_BUFFERS)
{
    uint i = h->i, bounce = f->bounce;
    float ub, vb;
    spt_sampler_pair(f->smp, spt_dim_bounce(bounce, SPT_DIM_BSDF_U), &ub, &vb);
    *bs = bsdf_sample(bp, f->wo_l, spt_sampler_1d(f->smp, spt_dim_bounce(bounce, SPT_DIM_BSDF_LOBE)), ub, vb);
    *wn = bs->wi.x * f->tg + bs->wi.y * f->bt + bs->wi.z * f->ns;
    *wn_side = dot(*wn, f->ngf);
    /* Reflection stays on wo's side of the face, refraction crosses it. */
    *reflect = bs->wi.z * f->wo_l.z > 0.0f;
    int alive = bs->valid && (*reflect ? *wn_side * f->wo_side > 0.0f : *wn_side * f->wo_side < 0.0f);
    if (alive) {
        h->beta *= bs->weight;
        float4 lp = ps_lambda_pdf[i];
        if (bs->dispersive && lp.y > 0.0f) {
            /* The refraction split the wavelengths: only the hero carries on
             * (pbrt-v4's TerminateSecondary); its pdf becomes 1/4 of what it was. */
            lp = (float4)(0.25f * lp.x, 0.0f, 0.0f, 0.0f);
            ps_lambda_pdf[i] = lp;
        }
        if (!(lp.y > 0.0f))
            h->beta = (float4)(h->beta.x, 0.0f, 0.0f, 0.0f);
        alive = max4(h->beta) > 0.0f;
    }
    return alive;
}

/* Russian roulette on the largest wavelength throughput, surviving with at
 * most 0.95 (as Mitsuba 3 does): a path whose throughput never drops (total
 * internal reflection inside a smooth sphere keeps it at exactly 1) must
 * still end. SPT_MAX_SEGMENTS bounds "unlimited" depth as a last resort.
 * Returns whether the path goes on (h->beta divided by its survival chance). */
SPT_FN_INLINE int shade_roulette(ShadeHit *h, const ShadeFrame *f, int alive, ALL_BUFFERS)
{
    if (alive && h->depth >= SPT_MAX_SEGMENTS)
        alive = 0;
    if (alive && h->depth >= P.rr_depth) {
        float qs = fmin(max4(h->beta), 0.95f);
        float u = spt_sampler_1d(f->smp, spt_dim_bounce(f->bounce, SPT_DIM_ROULETTE));
        if (u >= qs)
            alive = 0;
        else
            h->beta /= qs;
    }
    return alive;
}

#ifdef SPT_AOV
/* The AOVs of the sample of path i (aov_sample, 3 float4 per sample: see
 * kernels/shared/render_types.h). The first hit gives the shading normal (on
 * the side the camera sees), the depth along the camera's view axis and the
 * position; the albedo is the first surface's that does not reflect or
 * transmit specularly only (through a mirror or clear glass, the albedo seen
 * behind it, as Open Image Denoise expects), or the last surface's when the
 * path ends there. */
SPT_FN_INLINE void shade_aov(const ShadeHit *h, const TexCtx *tc, const BsdfParams *bp, const ShadeFrame *f,
                             int ends, ALL_BUFFERS)
{
    uint w = ps_work[h->i];
    if (h->depth == 1u) {
        float3 fwd = normalize(vload4(0, P.cam_fwd).xyz);
        float z = dot(h->p - vload4(0, P.cam_pos).xyz, fwd);
        aov_sample[3u * w + 1u] = (float4)(f->ns, z);
        aov_sample[3u * w + 2u] = (float4)(h->p, 0.0f);
    }
    if (aov_sample[3u * w].w == 0.0f && (ends || !bsdf_is_delta(bp))) {
        float3 a = material_albedo(h->m, tc, h->prim, h->bu, h->bv, tri_shade, vtx_color, spectra, textures,
                                   texels);
        aov_sample[3u * w] = (float4)(a, 1.0f);
    }
}
#endif

/* What path i brings to its hit (or miss): the hit, its depth, wavelengths, and
 * its throughput, through the volume it crossed. */
SPT_FN_INLINE void shade_hit_begin(uint i, ShadeHit *h, ALL_BUFFERS)
{
    h->i = i;
    h->hit = ps_hit[i];
    h->prim = as_uint(h->hit.w);
    h->depth = ps_depth[i] + 1u;
    h->lam = ps_lambda[i];
    h->beta = ps_throughput[i];
    uint medium = ps_medium[i];
    if (medium != 0u && h->prim != NO_HIT)
        h->beta *= volume_transmittance(materials + (medium - 1u), h->hit.x, h->lam, spectra);
}

/* Shades path i at its hit; returns 1 and fills the shadow ray (origin, direction
 * with tmax in w, contribution) when next-event estimation wants one. */
static int shade_path(uint i, float4 *sh_o, float4 *sh_d, float4 *sh_c, ALL_BUFFERS)
{
    ShadeHit h;
    shade_hit_begin(i, &h, ALL_ARGS);
    if (h.prim == NO_HIT) {
        shade_miss(i, h.lam, h.beta, ALL_ARGS);
        return 0;
    }
    TexCtx tc;
    shade_hit_geometry(&h, &tc, ALL_ARGS);
    uint npix = (uint)(P.width * P.height);
    uint w_item = ps_work[i];
    uint pixel = w_item % npix;
    uint sample = P.sample_begin + w_item / npix;
    if (shade_alpha(&h, &tc, P.seed, pixel, sample, ALL_ARGS))
        return 0;
    shade_emission(&h, &tc, ALL_ARGS);
    if ((P.max_depth > 0 && h.depth >= (uint)P.max_depth) || (h.m->flags & SPT_MAT_UNLIT)) {
#ifdef SPT_AOV
        {
            ShadeFrame fe;
            BsdfParams bpe;
            shade_frame(&h, &tc, &bpe, &fe, spt_sampler(P.sampler, P.seed, pixel, sample), ALL_ARGS);
            shade_aov(&h, &tc, &bpe, &fe, 1, ALL_ARGS);
        }
#endif
        ps_radiance[i] = h.L;
        ps_flags[i] = SPT_PATH_FINISHED;
        return 0;
    }
    ShadeFrame f;
    BsdfParams bp;
    shade_frame(&h, &tc, &bp, &f, spt_sampler(P.sampler, P.seed, pixel, sample), ALL_ARGS);
#ifdef SPT_AOV
    shade_aov(&h, &tc, &bp, &f, 0, ALL_ARGS);
#endif
    int shadow = shade_direct_light(&h, &tc, &bp, &f, sh_o, sh_d, sh_c, ALL_ARGS);
    BsdfSample bs;
    float3 wn;
    float wn_side;
    int reflect;
    int alive = shade_bsdf_bounce(&h, &bp, &f, &bs, &wn, &wn_side, &reflect, ALL_ARGS);
    alive = shade_roulette(&h, &f, alive, ALL_ARGS);
    ps_radiance[i] = h.L;
    if (!alive) {
        ps_flags[i] = SPT_PATH_FINISHED;
        return shadow;
    }
    if (P.light_paths > 0u)
        ps_lt[i] = lt_camera_next(ps_lt[i], h.depth, bs.is_delta);
    /* Entering or leaving a volume (refraction through a transmissive surface). */
    if (!reflect && f.two_sided_bsdf)
        ps_medium[i] = wn_side < 0.0f && h.m->attenuation.kind != SPT_SPEC_NONE ? h.ts.material + 1u : 0u;
    ps_throughput[i] = h.beta;
    ps_ray_o[i] = (float4)(offset_origin(h.p, wn_side > 0.0f ? f.ngf : -f.ngf), 0.0f);
    ps_ray_d[i] = (float4)(wn, h.cone_w);
    ps_bsdf_pdf[i] = bs.is_delta ? 0.0f : bs.pdf;
    ps_depth[i] = h.depth;
    return shadow;
}

#endif
