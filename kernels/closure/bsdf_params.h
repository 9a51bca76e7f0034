/* The parameters of the glTF material at one hit (BsdfParams), the outcome of
 * sampling it (BsdfSample), and what every lobe of kernels/closure/ reads of
 * them: the clamped metallic and transmission factors, whether the coat and
 * sheen layers are present, and the Fresnel weight of the dielectric's
 * specular layer (which the specular and the diffuse lobes share). C99 and
 * OpenCL C 1.2. Conventions: kernels/closure/bsdf.h. */
#ifndef SPT_BSDF_PARAMS_H
#define SPT_BSDF_PARAMS_H

#include "util/portable.h"
#include "util/vecmath.h"
#include "closure/delta.h"
#include "closure/thin_film.h"

/* Smallest alpha used by a rough lobe. */
#define BSDF_MIN_ALPHA 1e-3f

/* Per-hit material parameters, built by the renderer (not a buffer struct). */
typedef struct BsdfParams {
    vec4 base;          /* base reflectance per wavelength (glTF baseColor upsampled) */
    vec4 ior;           /* dielectric index per wavelength (KHR_materials_ior/dispersion) */
    vec4 eta;           /* conductor index, real part, per wavelength */
    vec4 k;             /* conductor index, imaginary part, per wavelength */
    float metallic;     /* glTF metallicFactor, 0..1 */
    float roughness;    /* glTF perceptual roughness; alpha = roughness^2 */
    float transmission; /* KHR_materials_transmission factor, 0..1 */
    spt_i32 conductor;  /* nonzero: the metal uses eta, k (exact Fresnel), not base */
    vec4 spec_tint;     /* KHR_materials_specular colour per wavelength (1: none) */
    float specular;     /* KHR_materials_specular factor (1: the plain glTF model;
                           0 removes the dielectric's specular layer: pure Lambert) */
    /* KHR_materials_clearcoat (clearcoat 0: no coat). */
    float clearcoat;    /* layer weight: clearcoatFactor x texture */
    float cc_roughness; /* perceptual; alpha = cc_roughness^2 */
    vec3 cc_n;          /* the coat's unit normal in this local frame (z >= 0 side) */
    /* KHR_materials_sheen (sheen_max 0: no sheen). */
    vec4 sheen;         /* sheen colour per wavelength */
    float sheen_max;    /* max3 of the sheen colour's linear RGB (the albedo scaling) */
    float sheen_roughness; /* perceptual; alpha = r^2, r raised to SPT_SHEEN_R_MIN */
    /* KHR_materials_iridescence (iridescence 0: no film). */
    vec4 lambda;        /* the path's wavelengths in nm (the film's phase) */
    float iridescence;  /* iridescenceFactor x texture R, 0..1: the film's share of the Fresnel */
    float film_ior;     /* iridescenceIor */
    float film_nm;      /* the film's thickness in nm */
    /* KHR_materials_anisotropy (aniso 0: the isotropic GGX). */
    float aniso;        /* anisotropy strength x texture B, 0..1 */
    vec3 aniso_t;       /* the anisotropy direction: unit, in this local frame (z 0);
                           material_bsdf leaves it in texture tangent space */
    /* KHR_materials_diffuse_transmission (diffuse_transmission 0: none). */
    float diffuse_transmission; /* factor x texture A, 0..1 */
    vec4 dt_color;      /* diffuseTransmissionColor per wavelength */
} BsdfParams;

/* Outcome of bsdf_sample. */
typedef struct BsdfSample {
    vec3 wi;            /* sampled direction (unit) */
    vec4 weight;        /* f |cos theta_i| / pdf per wavelength (0 if invalid) */
    float pdf;          /* solid-angle pdf (the lobe selection probability for delta) */
    spt_i32 is_delta;   /* the sampled lobe is a delta: no MIS with light sampling */
    spt_i32 dispersive; /* the refraction depended on wavelength: keep only index 0 */
    spt_i32 valid;      /* 0: the sample failed (weight 0) */
} BsdfSample;

/* What a lobe's sample function (bsdf_<lobe>_sample) did with the BsdfSample:
 * nothing usable (the material returns it as it is), chose wi only (the
 * material then sets pdf and weight from bsdf_pdf and bsdf_eval, so that MIS
 * with light sampling is consistent), or filled a delta sample whole. */
#define BSDF_SAMPLED_NONE 0
#define BSDF_SAMPLED_WI 1
#define BSDF_SAMPLED_DELTA 2

/* glTF metallicFactor and the transmission factor, clamped to [0, 1]. */
SPT_FN float bsdf_metallic(const BsdfParams *p) { return fminf(fmaxf(p->metallic, 0.0f), 1.0f); }
SPT_FN float bsdf_transmission(const BsdfParams *p) { return fminf(fmaxf(p->transmission, 0.0f), 1.0f); }

/* Whether the base (metal, specular layer, transmission) is a mirror: its
 * reflection and interface lobes are then delta lobes. */
SPT_FN int bsdf_base_smooth(const BsdfParams *p) { return bsdf_roughness_is_delta(p->roughness); }

/* Whether the layers' code is compiled in: the CPU path's kernels are built
 * with SPT_LAYERS 0 when no material of the scene has a clear coat, a sheen,
 * anisotropy or diffuse transmission (src/render/wavefront.c,
 * wavefront_options), so that every hit's BSDF skips their tests
 * (docs/performance.md, "Generality a scene does not use"); host code and
 * the tests' kernels have it. */
#ifndef SPT_LAYERS
#define SPT_LAYERS 1
#endif

SPT_FN int bsdf_has_coat(const BsdfParams *p) { return SPT_LAYERS && p->clearcoat > 0.0f; }
SPT_FN int bsdf_has_aniso(const BsdfParams *p) { return SPT_LAYERS && p->aniso > 0.0f; }
SPT_FN int bsdf_has_dt(const BsdfParams *p) { return SPT_LAYERS && p->diffuse_transmission > 0.0f; }

/* Whether the specular reflection lobe is a mirror: a smooth base without
 * anisotropy (which widens the lobe along its direction, docs/gltf.md). */
SPT_FN int bsdf_specular_smooth(const BsdfParams *p) { return bsdf_base_smooth(p) && !bsdf_has_aniso(p); }

/* The diffuse transmission factor, clamped to [0, 1]. */
SPT_FN float bsdf_dt(const BsdfParams *p) { return fminf(fmaxf(p->diffuse_transmission, 0.0f), 1.0f); }
SPT_FN int bsdf_has_sheen(const BsdfParams *p) { return SPT_LAYERS && p->sheen_max > 0.0f; }

/* Whether the film code is compiled in: the path kernels are built with
 * SPT_IRIDESCENCE 0 when no material of the scene has a film
 * (src/render/wavefront.c), since its complex arithmetic, inlined at every
 * Fresnel evaluation, multiplies the program's size (docs/architecture.md,
 * "Portability rules"); host code and the tests' kernels have it. */
#ifndef SPT_IRIDESCENCE
#define SPT_IRIDESCENCE 1
#endif

/* Whether p has a film (KHR_materials_iridescence) that the program renders. */
SPT_FN int bsdf_has_film(const BsdfParams *p) { return SPT_IRIDESCENCE && p->iridescence > 0.0f; }

/* KHR_materials_iridescence: the base's Fresnel f at cosine c mixed with the
 * reflectance of the film over a base of index n_base + i k_base per
 * wavelength (kernels/closure/thin_film.h), by the iridescence factor, as the
 * extension mixes F_schlick and F_iridescence; scale multiplies the film's
 * reflectance (the specular factor). The film's outside is the clear coat
 * (index 1.5, bsdf_coat_fresnel's) where there is one, as the extension
 * layers them, else air. */
SPT_FN vec4 bsdf_film_mix(const BsdfParams *p, vec4 f, float c, vec4 n_base, vec4 k_base, float scale)
{
#if SPT_IRIDESCENCE
    if (!bsdf_has_film(p))
        return f;
    float n0 = p->clearcoat > 0.0f ? 1.5f : 1.0f;
    vec4 film = spt_thin_film_reflectance4(c, p->lambda, n0, p->film_ior, p->film_nm, n_base, k_base);
    return v4_add(f, v4_scale(v4_sub(v4_scale(film, scale), f), p->iridescence));
#else
    (void)p, (void)c, (void)n_base, (void)k_base, (void)scale;
    return f;
#endif
}

/* Fresnel weight of the dielectric's specular layer per wavelength at cosine c, as
 * KHR_materials_specular extends glTF's fresnel_mix: f0 = min(((ior - 1)/(ior + 1))^2
 * tint, 1) s, f90 = s, F = f0 + (f90 - f0)(1 - c)^5 (s = specular factor), mixed
 * with the iridescence film's reflectance times s (bsdf_film_mix); the
 * diffuse base gets 1 - F. With s = 1 and tint 1 this is the core glTF model. */
SPT_FN vec4 bsdf_dielectric_fresnel(const BsdfParams *p, float c)
{
    /* No specular layer (pure Lambert): what the arithmetic below gives too, for
     * any finite ior, without its four divisions (called several times a hit). */
    if (p->specular == 0.0f)
        return v4_splat(0.0f);
    vec4 r = v4_sub(p->ior, v4_splat(1.0f));
    vec4 q = v4_add(p->ior, v4_splat(1.0f));
    vec4 f0 = v4(r.x / q.x, r.y / q.y, r.z / q.z, r.w / q.w);
    f0 = v4_mul(v4_mul(f0, f0), p->spec_tint);
    f0 = v4(fminf(f0.x, 1.0f), fminf(f0.y, 1.0f), fminf(f0.z, 1.0f), fminf(f0.w, 1.0f));
    vec4 f0s = v4_scale(f0, p->specular);
    float m = fminf(fmaxf(1.0f - c, 0.0f), 1.0f);
    float m5 = m * m * m * m * m;
    vec4 f = v4_add(f0s, v4_scale(v4_sub(v4_splat(p->specular), f0s), m5));
    if (!(p->iridescence > 0.0f))
        return f;
    /* The film over the base of the (tinted) F0, its index from F0 as the
     * extension derives it: the ior itself when the tint is 1. */
    vec4 n = v4(spt_film_ior_from_f0(f0.x, 1.0f), spt_film_ior_from_f0(f0.y, 1.0f), spt_film_ior_from_f0(f0.z, 1.0f),
                spt_film_ior_from_f0(f0.w, 1.0f));
    return bsdf_film_mix(p, f, c, n, v4_splat(0.0f), p->specular);
}

/* The mean over the path's wavelengths of bsdf_dielectric_fresnel at wo's
 * cosine: the share of the dielectric's light the specular layer takes, as the
 * lobe selection estimates it. */
SPT_FN float bsdf_dielectric_fresnel_mean(const BsdfParams *p, vec3 wo)
{
    vec4 fv = bsdf_dielectric_fresnel(p, fabsf(wo.z));
    return 0.25f * (fv.x + fv.y + fv.z + fv.w);
}

#endif
