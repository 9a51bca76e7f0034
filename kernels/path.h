/* Device helpers of the wavefront kernels: spectra of materials, textures, ray
 * offsets and the conversion of a path's spectral radiance to XYZ. OpenCL C only
 * (float4 carries the path's four wavelengths). */
#ifndef SPT_PATH_H
#define SPT_PATH_H

#include "shared.h"
#include "vecmath.h"
#include "spectrum.h"
#include "render_types.h"

/* sigmoid-polynomial spectrum at four wavelengths. */
static float4 spec_sigmoid4(float c0, float c1, float c2, float4 lam)
{
    return (float4)(spt_sigmoid_poly(c0, c1, c2, lam.x), spt_sigmoid_poly(c0, c1, c2, lam.y),
                    spt_sigmoid_poly(c0, c1, c2, lam.z), spt_sigmoid_poly(c0, c1, c2, lam.w));
}

/* A tabulated spectrum on the 1 nm grid 360..830 at four wavelengths. */
static float table_lookup(const __global float *t, float l)
{
    float x = l - (float)SPT_CIE_LAMBDA_MIN;
    if (!(x >= 0.0f) || x > (float)(SPT_CIE_SAMPLES - 1))
        return 0.0f;
    int i = min((int)x, SPT_CIE_SAMPLES - 2);
    float f = x - (float)i;
    return t[i] * (1.0f - f) + t[i + 1] * f;
}

/* Where table_lookup reads at four wavelengths l: the entries i and i + 1, the
 * fraction *f between them, and *in (-1 for lanes inside the table; the others
 * read entry 0 and must give 0). The same arithmetic per lane, with selects
 * instead of the per-wavelength range branches. */
static int4 table_index4(float4 l, float4 *f, int4 *in)
{
    float4 x = l - (float)SPT_CIE_LAMBDA_MIN;
    *in = isgreaterequal(x, (float4)(0.0f)) & islessequal(x, (float4)(SPT_CIE_SAMPLES - 1));
    int4 i = select((int4)(0), min(convert_int4(select((float4)(0.0f), x, *in)), SPT_CIE_SAMPLES - 2), *in);
    *f = x - convert_float4(i);
    return i;
}

/* table_lookup at four wavelengths at once, for a table in address space AS
 * (OpenCL 1.2 has no generic pointers, so one body serves two functions). */
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

/* spec_eval for a spectrum held in private memory (the kernel parameters). */
static float4 spec_eval_private(const SpecRef *s, float4 lam, const __global float *spectra)
{
    if (s->kind == SPT_SPEC_SIGMOID) {
        float4 v = s->scale * spec_sigmoid4(s->c[0], s->c[1], s->c[2], lam);
        if (s->flags & SPT_SPEC_ILLUMINANT)
            v *= (float4)(spt_d65_norm(lam.x), spt_d65_norm(lam.y), spt_d65_norm(lam.z),
                          spt_d65_norm(lam.w));
        return v;
    }
    if (s->kind == SPT_SPEC_TABLE) {
        const __global float *t = spectra + s->offset;
        return s->scale * (float4)(table_lookup(t, lam.x), table_lookup(t, lam.y),
                                   table_lookup(t, lam.z), table_lookup(t, lam.w));
    }
    return (float4)(0.0f);
}

/* Wraps a texture coordinate by a glTF wrap mode into [0, 1]. */
static float wrap_coord(float u, int mode)
{
    if (mode == 33071) /* CLAMP_TO_EDGE */
        return clamp(u, 0.0f, 1.0f);
    if (mode == 33648) { /* MIRRORED_REPEAT */
        float f = u - 2.0f * floor(u * 0.5f);
        return f > 1.0f ? 2.0f - f : f;
    }
    return u - floor(u); /* REPEAT */
}

/* Texel (nearest) of texture tex at uv: sigmoid coefficients in xyz, scale in w. */
static float4 texture_texel(const __global GpuTexture *textures, const __global float4 *texels,
                            int tex, float2 uv)
{
    const __global GpuTexture *t = textures + tex;
    float u = wrap_coord(uv.x, t->wrap_s), v = wrap_coord(uv.y, t->wrap_t);
    int x = clamp((int)(u * (float)t->width), 0, t->width - 1);
    int y = clamp((int)(v * (float)t->height), 0, t->height - 1);
    return texels[t->offset + (uint)(y * t->width + x)];
}

/* uv transformed by a 2x3 row-major affine matrix (KHR_texture_transform). */
static float2 uv_apply(const __global float *m, float2 uv)
{
    return (float2)(m[0] * uv.x + m[1] * uv.y + m[2], m[3] * uv.x + m[4] * uv.y + m[5]);
}

/* Spectrum of a texel of a coefficient texture at lam. */
static float4 texel_spectrum(float4 texel, float4 lam)
{
    return spec_sigmoid4(texel.x, texel.y, texel.z, lam);
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

/* spt_sample_wavelengths (kernels/spectrum.h) with less transcendental work, for
 * the generate kernel: atanh(t) as 0.5 log((1 + t) / (1 - t)), and the pdf from
 * the same t instead of a cosh of the wavelength. The density is the tanh CDF's
 * derivative, k / ((T1 - T0) cosh^2(k (l - 538))), and cosh^2(atanh(t)) =
 * 1 / (1 - t^2), so pdf = k (1 - t^2) / (T1 - T0): the same density, evaluated
 * exactly where the inverse CDF put the sample. */
static void path_sample_wavelengths(float u, float4 *lambda, float4 *pdf)
{
    float4 ui = u + (float4)(0.0f, 0.25f, 0.5f, 0.75f);
    ui = select(ui, ui - 1.0f, isgreaterequal(ui, 1.0f));
    float4 t = SPT_WL_T0 + ui * (SPT_WL_T1 - SPT_WL_T0);
    float4 l = SPT_WL_CENTER + (0.5f / SPT_WL_K) * log((1.0f + t) / (1.0f - t));
    *lambda = clamp(l, (float)SPT_CIE_LAMBDA_MIN, (float)SPT_CIE_LAMBDA_MAX);
    *pdf = (SPT_WL_K / (SPT_WL_T1 - SPT_WL_T0)) * (1.0f - t * t);
}

/* Largest component of v. */
static float max4(float4 v)
{
    return fmax(fmax(v.x, v.y), fmax(v.z, v.w));
}

#endif
