/* Device helpers of the wavefront kernels: spectra of materials, textures, ray
 * offsets and the conversion of a path's spectral radiance to XYZ. OpenCL C only
 * (float4 carries the path's four wavelengths). */
#ifndef SPT_PATH_H
#define SPT_PATH_H

#include "util/portable.h"
#include "util/vecmath.h"
#include "spectrum/spectrum.h"
#include "sample/wavelength.h"
#include "util/render_types.h"

SPT_DEVICE_ONLY

/* ps_hit's prim (w, as bits) of a ray that hit nothing. */
#define NO_HIT 0xffffffffu

/* sigmoid-polynomial spectrum at four wavelengths. */
static float4 spec_sigmoid4(float c0, float c1, float c2, float4 lam)
{
    return (float4)(spt_sigmoid_poly(c0, c1, c2, lam.x), spt_sigmoid_poly(c0, c1, c2, lam.y),
                    spt_sigmoid_poly(c0, c1, c2, lam.z), spt_sigmoid_poly(c0, c1, c2, lam.w));
}

/* Where a linear lookup in a table on the 1 nm grid 360..830 reads at four
 * wavelengths l: the entries i and i + 1, the fraction *f between them, and
 * *in (-1 for lanes inside the table; the others read entry 0 and must give
 * 0). Selects, not per-wavelength range branches. min's bound is written as a
 * vector: Oclgrind 21.10 computes min(int4, int) wrongly (reads out of the table
 * under make check-kernels). */
static int4 table_index4(float4 l, float4 *f, int4 *in)
{
    float4 x = l - (float)SPT_CIE_LAMBDA_MIN;
    *in = isgreaterequal(x, (float4)(0.0f)) & islessequal(x, (float4)(SPT_CIE_SAMPLES - 1));
    int4 i = select((int4)(0), min(convert_int4(select((float4)(0.0f), x, *in)), (int4)(SPT_CIE_SAMPLES - 2)),
                    *in);
    *f = x - convert_float4(i);
    return i;
}

/* Linear interpolation in such a table at four wavelengths, for a table in
 * address space AS (OpenCL 1.2 has no generic pointers, so one body serves
 * two functions). */
#define SPT_TABLE_LOOKUP4(name, AS)                                            \
    static float4 name(AS const float *t, float4 l)                            \
    {                                                                          \
        float4 f;                                                              \
        int4 in, i = table_index4(l, &f, &in);                                 \
        float4 a = (float4)(t[i.x], t[i.y], t[i.z], t[i.w]);                   \
        float4 b = (float4)(t[i.x + 1], t[i.y + 1], t[i.z + 1], t[i.w + 1]);   \
        return select((float4)(0.0f), a * (1.0f - f) + b * f, in);             \
    }
SPT_TABLE_LOOKUP4(table_lookup4, __global)
/* The same for the CIE tables (in constant memory), as spt_cie_x etc. compute
 * it per wavelength. */
SPT_TABLE_LOOKUP4(cie_lookup4, __constant)

/* The value of spectrum s at the four wavelengths lam. */
static float4 spec_eval(const __global SpecRef *s, float4 lam, const __global float *spectra)
{
    uint kind = s->kind;
    if (kind == SPT_SPEC_SIGMOID) {
        float4 v = s->scale * spec_sigmoid4(s->c[0], s->c[1], s->c[2], lam);
        if (s->flags & SPT_SPEC_ILLUMINANT)
            v *= (float4)(spt_d65_norm(lam.x), spt_d65_norm(lam.y), spt_d65_norm(lam.z),
                          spt_d65_norm(lam.w));
        return v;
    }
    if (kind == SPT_SPEC_TABLE) {
        return s->scale * table_lookup4(spectra + s->offset, lam);
    }
    return (float4)(0.0f);
}

/* ---- Textures ---------------------------------------------------------------------
 * Texels live in the texels buffer (no image objects: OpenCL 1.2 devices differ in
 * what they support), as mip pyramids (GpuTexture). A lookup blends up to 8 texels:
 * bilinear within a level (texel centres at (i + 1/2) / size, neighbours wrapped by
 * the sampler's modes), linear between the two levels around the footprint's level
 * of detail; a magnified texture with magFilter NEAREST reads its nearest texel.
 * Colour texels blend as spectra (the sigmoid spectrum of each texel, weighted), so
 * the result is the spectrum of the blended RGB as far as a linear projection (an
 * observer's RGB) can tell. */

/* The largest footprint elongation filtered away: the level of detail follows the
 * footprint's minor axis, or its major axis over this, whichever is larger; the
 * stretch beyond it is left to the pixel's samples (each lands elsewhere along the
 * major axis), so a grazing surface is not blurred across its whole footprint. */
#define SPT_TEX_MAX_ANISO 4.0f

/* uv reduced by a glTF wrap mode to a range where texel indices stay small:
 * [0, 1) for REPEAT, [0, 2) for MIRRORED_REPEAT, [-1, 2] for CLAMP_TO_EDGE. A
 * coordinate that is not finite reads as 0. */
static float tex_reduce(float u, int mode)
{
    if (!isfinite(u))
        return 0.0f;
    if (mode == 33071) /* CLAMP_TO_EDGE */
        return clamp(u, -1.0f, 2.0f);
    if (mode == 33648) /* MIRRORED_REPEAT */
        return u - 2.0f * floor(u * 0.5f);
    return u - floor(u); /* REPEAT */
}

/* Texel index i of a row or column of n texels, wrapped by a glTF wrap mode. */
static int tex_wrap(int i, int n, int mode)
{
    if (mode == 33071)
        return clamp(i, 0, n - 1);
    if (mode == 33648) {
        int p = 2 * n, k = i % p;
        k = k < 0 ? k + p : k;
        return k < n ? k : p - 1 - k;
    }
    int k = i % n;
    return k < 0 ? k + n : k;
}

/* The texels a lookup blends and their weights. */
typedef struct TexTaps {
    uint at[8];
    float w[8];
    int n;
} TexTaps;

/* Adds the bilinear taps of level `level` at (reduced) uv, weighted by scale. */
static void tex_bilinear(const __global GpuTexture *t, int level, float2 uv, float scale, TexTaps *tp)
{
    uint off = t->offset;
    for (int k = 0; k < level; k++)
        off += (uint)(max(t->width >> k, 1) * max(t->height >> k, 1));
    int w = max(t->width >> level, 1), h = max(t->height >> level, 1);
    float x = uv.x * (float)w - 0.5f, y = uv.y * (float)h - 0.5f;
    float fx = floor(x), fy = floor(y);
    float ax = x - fx, ay = y - fy;
    int x0 = (int)fx, y0 = (int)fy;
    int xa = tex_wrap(x0, w, t->wrap_s), xb = tex_wrap(x0 + 1, w, t->wrap_s);
    uint ra = off + (uint)(tex_wrap(y0, h, t->wrap_t) * w), rb = off + (uint)(tex_wrap(y0 + 1, h, t->wrap_t) * w);
    int n = tp->n;
    tp->at[n] = ra + (uint)xa;
    tp->w[n] = scale * (1.0f - ax) * (1.0f - ay);
    tp->at[n + 1] = ra + (uint)xb;
    tp->w[n + 1] = scale * ax * (1.0f - ay);
    tp->at[n + 2] = rb + (uint)xa;
    tp->w[n + 2] = scale * (1.0f - ax) * ay;
    tp->at[n + 3] = rb + (uint)xb;
    tp->w[n + 3] = scale * ax * ay;
    tp->n = n + 4;
}

/* The taps of texture t at uv with level of detail lod (log2 of the footprint in
 * level-0 texels; <= 0: magnified). */
static void tex_taps(const __global GpuTexture *t, float2 uv, float lod, TexTaps *tp)
{
    tp->n = 0;
    uv = (float2)(tex_reduce(uv.x, t->wrap_s), tex_reduce(uv.y, t->wrap_t));
    if (!(lod > 0.0f) && (t->flags & SPT_TEX_NEAREST)) {
        int x = tex_wrap((int)floor(uv.x * (float)t->width), t->width, t->wrap_s);
        int y = tex_wrap((int)floor(uv.y * (float)t->height), t->height, t->wrap_t);
        tp->at[0] = t->offset + (uint)(y * t->width + x);
        tp->w[0] = 1.0f;
        tp->n = 1;
        return;
    }
    float l = clamp(isfinite(lod) ? lod : 0.0f, 0.0f, (float)(t->levels - 1u));
    int l0 = (int)l;
    float f = l - (float)l0;
    tex_bilinear(t, l0, uv, 1.0f - f, tp);
    if (f > 0.0f && (uint)(l0 + 1) < t->levels)
        tex_bilinear(t, l0 + 1, uv, f, tp);
}

/* The blended texel of a DATA texture (or any texture's w channel). */
static float4 tex_value(const __global GpuTexture *textures, const __global float4 *texels, int tex,
                        float2 uv, float lod)
{
    TexTaps tp;
    tex_taps(textures + tex, uv, lod, &tp);
    float4 v = (float4)(0.0f);
    for (int k = 0; k < tp.n; k++)
        v += tp.w[k] * texels[tp.at[k]];
    return v;
}

/* The blended spectrum of a COLOR or SCALED texture at the wavelengths lam, and
 * its blended w channel in *w (alpha, or the scale). */
static float4 tex_spectrum(const __global GpuTexture *textures, const __global float4 *texels, int tex,
                           float2 uv, float lod, float4 lam, float *w)
{
    const __global GpuTexture *t = textures + tex;
    TexTaps tp;
    tex_taps(t, uv, lod, &tp);
    int scaled = t->kind == SPT_TEXKIND_SCALED;
    float4 v = (float4)(0.0f);
    float ws = 0.0f;
    for (int k = 0; k < tp.n; k++) {
        float4 c = texels[tp.at[k]];
        float wk = tp.w[k];
        ws += wk * c.w;
        if (wk > 0.0f)
            v += (scaled ? wk * c.w : wk) * spec_sigmoid4(c.x, c.y, c.z, lam);
    }
    *w = ws;
    return v;
}

/* uv transformed by a 2x3 row-major affine matrix (KHR_texture_transform). */
static float2 uv_apply(const __global float *m, float2 uv)
{
    return (float2)(m[0] * uv.x + m[1] * uv.y + m[2], m[3] * uv.x + m[4] * uv.y + m[5]);
}

/* Where a shading point reads its textures: both sets' texture coordinates and
 * the footprint of the path's ray cone on the surface, as two axis vectors in each
 * set's uv space (zero: no footprint, the finest level). */
typedef struct TexCtx {
    float2 uv[2];
    float2 fa[2], fb[2];
} TexCtx;

/* Level of detail of texture slot s (its texture t) at c: log2 of the footprint's
 * extent in texels (after the slot's transform), by SPT_TEX_MAX_ANISO's rule. */
static float tex_slot_lod(const __global GpuTexSlot *s, const __global GpuTexture *t, const TexCtx *c)
{
    uint set = s->uv_set;
    float2 a = c->fa[set], b = c->fb[set];
    float2 ta = (float2)((s->m[0] * a.x + s->m[1] * a.y) * (float)t->width,
                         (s->m[3] * a.x + s->m[4] * a.y) * (float)t->height);
    float2 tb = (float2)((s->m[0] * b.x + s->m[1] * b.y) * (float)t->width,
                         (s->m[3] * b.x + s->m[4] * b.y) * (float)t->height);
    float la = length(ta), lb = length(tb);
    float wdt = fmax(fmin(la, lb), fmax(la, lb) * (1.0f / SPT_TEX_MAX_ANISO));
    return wdt > 0.0f ? log2(wdt) : 0.0f;
}

/* Whether the texture code is compiled in: the CPU path's kernels are built
 * with SPT_TEXTURES 0 when no material of the scene has a texture in any
 * slot (src/render/wavefront.c, wavefront_options), which takes the slots'
 * tests and the texture reads out of every hit's shading (docs/performance.md,
 * "Generality a scene does not use"). */
#ifndef SPT_TEXTURES
#define SPT_TEXTURES 1
#endif

/* Whether slot k of material m has a texture. */
static int slot_textured(const __global GpuMaterial *m, int k) { return SPT_TEXTURES && m->slot[k].tex >= 0; }

/* Slot k of material m read at c: the blended texel (DATA), or the spectrum at lam
 * with the w channel in *w (COLOR, SCALED). The slot must have a texture. */
static float4 slot_value(const __global GpuMaterial *m, int k, const TexCtx *c,
                         const __global GpuTexture *textures, const __global float4 *texels)
{
    const __global GpuTexSlot *s = m->slot + k;
    return tex_value(textures, texels, s->tex, uv_apply(s->m, c->uv[s->uv_set]),
                     tex_slot_lod(s, textures + s->tex, c));
}

static float4 slot_spectrum(const __global GpuMaterial *m, int k, const TexCtx *c, float4 lam,
                            const __global GpuTexture *textures, const __global float4 *texels, float *w)
{
    const __global GpuTexSlot *s = m->slot + k;
    return tex_spectrum(textures, texels, s->tex, uv_apply(s->m, c->uv[s->uv_set]),
                        tex_slot_lod(s, textures + s->tex, c), lam, w);
}

/* A ray origin moved off the surface at p along n (pointing to the side the ray
 * leaves on), by an amount that grows with |p| to cover float rounding of p. */
static float3 offset_origin(float3 p, float3 n)
{
    float3 a = fabs(p);
    float m = fmax(a.x, fmax(a.y, a.z));
    return p + n * (1e-5f * m + 1e-6f);
}


/* XYZ of a path's spectral radiance L at wavelengths lam with pdfs pdf: the mean
 * over the wavelengths of L cmf / pdf, normalised by the integral of ybar so a
 * flat spectrum of 1 has Y = 1. Wavelengths with pdf 0 (terminated) count 0.
 * The sums run over the wavelengths in order, as a loop over them would, with
 * a weight of 0 in place of skipping a terminated one (the same sum). */
static float4 path_radiance_to_xyz(float4 L, float4 lam, float4 pdf)
{
    float4 w = select((float4)(0.0f), L / pdf, isgreater(pdf, (float4)(0.0f)));
    float4 cx = cie_lookup4(SPT_CIE_X, lam), cy = cie_lookup4(SPT_CIE_Y, lam),
           cz = cie_lookup4(SPT_CIE_Z, lam);
    float4 xyz = (float4)(0.0f);
    xyz += w.x * (float4)(cx.x, cy.x, cz.x, 0.0f);
    xyz += w.y * (float4)(cx.y, cy.y, cz.y, 0.0f);
    xyz += w.z * (float4)(cx.z, cy.z, cz.z, 0.0f);
    xyz += w.w * (float4)(cx.w, cy.w, cz.w, 0.0f);
    return xyz * (1.0f / ((float)SPT_NUM_LAMBDA * SPT_CIE_Y_INTEGRAL));
}

/* Linear sRGB of XYZ: the matrix of src/color/spd.c (xyz_to_linear_srgb;
 * docs/architecture.md, "The physics it implements"). */
static float3 path_xyz_to_linear_srgb(float3 c)
{
    return (float3)(3.2406f * c.x - 1.5372f * c.y - 0.4986f * c.z,
                    -0.9689f * c.x + 1.8758f * c.y + 0.0415f * c.z,
                    0.0557f * c.x - 0.2040f * c.y + 1.0570f * c.z);
}

/* Largest component of v. */
static float max4(float4 v)
{
    return fmax(fmax(v.x, v.y), fmax(v.z, v.w));
}

/* max4(v) > 0: fmax passes over NaN components, and so does a lane test
 * (NaN > 0 is false), without fmax's NaN handling and its chain of three. */
static int any_positive4(float4 v)
{
    return any(v > (float4)(0.0f));
}

#endif
