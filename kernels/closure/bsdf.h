/* Material models shared by the kernels and host tests (C99 and OpenCL C 1.2).
 *
 * Conventions: directions in the local shading frame (z = shading normal, unit
 * vectors); wo points toward the viewer (previous vertex), wi toward the light /
 * next vertex. Spectral values are vec4, one per path wavelength (index 0 = hero).
 * Sampling returns the weight f * |cos(theta_i)| / pdf.
 *
 * Models:
 *  - glTF 2.0 metallic-roughness, Appendix B of the glTF 2.0 specification: GGX
 *    (Trowbridge-Reitz) D, Smith height-correlated masking-shadowing (Heitz 2014,
 *    "Understanding the Masking-Shadowing Function"), Schlick Fresnel, Lambertian
 *    base; fresnel_mix for the dielectric part (F0 from the ior, 0.04 at 1.5),
 *    conductor_fresnel for the metal part, mixed by metallic. With a measured
 *    conductor (p.conductor != 0) the metal uses the exact complex Fresnel.
 *  - KHR_materials_transmission + KHR_materials_ior: the dielectric part is
 *    (1 - t) (GGX Schlick layer over Lambert) + t (dielectric interface), the
 *    interface's refraction tinted by the base colour as the extension says. This
 *    departs from the extension's layering (which keeps the Schlick GGX layer over
 *    a mix(diffuse, btdf, t) base): the interface's own exact Fresnel reflection
 *    replaces the layer for the transmissive share, so a smooth clear glass has
 *    R + T = 1 exactly. The interface uses the exact
 *    dielectric Fresnel equations; smooth: specular reflection / refraction; rough:
 *    GGX microfacet transmission (Walter et al. 2007, "Microfacet Models for
 *    Refraction through Rough Surfaces"). Refracted radiance is scaled by 1/eta^2
 *    (radiance transport, as pbrt-v4 does).
 *  - KHR_materials_dispersion: ior(lambda) from the Abbe number (bsdf_dispersion_ior).
 *  - KHR_materials_sheen over that base, as its specification defines it: the
 *    "Charlie" lobe (Estevez and Kulla 2017, "Production Friendly Microfacet Sheen
 *    BRDF": distribution sin(theta_h)^(1/alpha), the specification's fitted
 *    visibility, F = 1) in the sheen colour, and the base scaled by the albedo
 *    scaling 1 - max3(sheen colour) max(E(mu_o), E(mu_i)), E the lobe's
 *    directional albedo (kernels/closure/sheen_table.h). Where E exceeds 1 (sheen
 *    roughness below about 0.26, grazing angles) the lobe would create energy;
 *    it is divided by max(1, E(mu_o), E(mu_i)) there and E is capped at 1 in the
 *    scaling, so albedo sheen + base never exceeds 1.
 *  - KHR_materials_clearcoat on top, as its specification defines it: a second
 *    GGX lobe (glTF's specular term without Fresnel, alpha = clearcoatRoughness^2)
 *    about the coat's own normal, weighted clearcoat Fc and the layers under it
 *    1 - clearcoat Fc, with Fc Schlick's Fresnel at ior 1.5 (f0 0.04) of the
 *    view's cosine to the coat normal (fresnel_coat). Light crossing the layers
 *    into a transmissive base is scaled the same way at its outside direction.
 *
 * Sampling the visible normals: Heitz 2018, "Sampling the GGX Distribution of
 * Visible Normals", JCGT 7(4). */
#ifndef SPT_BSDF_H
#define SPT_BSDF_H

#include "util/portable.h"
#include "util/vecmath.h"
#include "closure/conductors.h"
#include "closure/delta.h"
#include "closure/sheen_table.h"

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

/* The building blocks, in this order: Fresnel, refraction, dispersion and the
 * GGX distribution; then the clearcoat and sheen layers. They use BsdfParams
 * and are included here only. */
#include "closure/bsdf_microfacet.h"
#include "closure/bsdf_layers.h"

/* ---- The combined material: lobes and their selection ---------------------------- */

/* Fresnel weight of the dielectric's specular layer per wavelength at cosine c, as
 * KHR_materials_specular extends glTF's fresnel_mix: f0 = min(((ior - 1)/(ior + 1))^2
 * tint, 1) s, f90 = s, F = f0 + (f90 - f0)(1 - c)^5 (s = specular factor); the
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
    f0 = v4_scale(f0, p->specular);
    float m = fminf(fmaxf(1.0f - c, 0.0f), 1.0f);
    float m5 = m * m * m * m * m;
    return v4_add(f0, v4_scale(v4_sub(v4_splat(p->specular), f0), m5));
}

/* Lobe selection probabilities for wo (in the frame where wo.z > 0 for the
 * reflection lobes): specular reflection (GGX or delta), diffuse, dielectric
 * interface (transmission), coat, sheen. From the lobe weights: metal m,
 * dielectric (1-m) with specular share estimated by Schlick at wo.z, diffuse by
 * the base's mean, and the transmission share (1-m) t, all times what the layers
 * let through at wo; the coat's weight; the sheen's max3(colour) min(1, E(mu_o))
 * under the coat. Sum to 1. */
SPT_FN void bsdf_lobe_probs(const BsdfParams *p, vec3 wo, float *p_spec, float *p_diff, float *p_tr,
                            float *p_coat, float *p_sheen)
{
    float m = fminf(fmaxf(p->metallic, 0.0f), 1.0f);
    float t = fminf(fmaxf(p->transmission, 0.0f), 1.0f);
    float c = fabsf(wo.z);
    vec4 fv = bsdf_dielectric_fresnel(p, c);
    float fd = 0.25f * (fv.x + fv.y + fv.z + fv.w);
    float mean_base = 0.25f * (p->base.x + p->base.y + p->base.z + p->base.w);
    float ws = m + (1.0f - m) * (1.0f - t) * fd;
    float wd = (1.0f - m) * (1.0f - t) * (1.0f - fd) * fmaxf(mean_base, 0.0f);
    float wt = (1.0f - m) * t;
    if (wo.z <= 0.0f) {
        /* From inside only the interface responds. */
        ws = 0.0f;
        wd = 0.0f;
    }
    float wc = 0.0f, wsh = 0.0f;
    if (wo.z > 0.0f && (bsdf_has_coat(p) || bsdf_has_sheen(p))) {
        wc = bsdf_coat_weight(p, wo);
        float e = bsdf_has_sheen(p) ? fminf(1.0f, bsdf_sheen_albedo(wo.z, bsdf_sheen_r(p))) : 0.0f;
        wsh = (1.0f - wc) * p->sheen_max * e;
        float under = (1.0f - wc) * (1.0f - p->sheen_max * e);
        ws *= under;
        wd *= under;
        wt *= under;
    }
    float sum = ws + wd + wt + wc + wsh;
    *p_coat = 0.0f;
    *p_sheen = 0.0f;
    if (sum <= 0.0f) {
        *p_spec = 0.0f;
        *p_diff = 1.0f;
        *p_tr = 0.0f;
        return;
    }
    *p_spec = ws / sum;
    *p_diff = wd / sum;
    *p_tr = wt / sum;
    *p_coat = wc / sum;
    *p_sheen = wsh / sum;
}

/* Whether every lobe of the material is a delta (smooth, no diffuse, no sheen,
 * no rough coat): light sampling is then useless and MIS must not be applied. */
SPT_FN int bsdf_is_delta(const BsdfParams *p)
{
    float m = fminf(fmaxf(p->metallic, 0.0f), 1.0f);
    float t = fminf(fmaxf(p->transmission, 0.0f), 1.0f);
    int no_diffuse = m >= 1.0f || t >= 1.0f;
    return bsdf_roughness_is_delta(p->roughness) && no_diffuse && !bsdf_has_sheen(p) &&
           (!bsdf_has_coat(p) || bsdf_coat_smooth(p));
}

/* Whether the material has any delta lobe (smooth base or coat), while possibly
 * also rough ones. */
SPT_FN int bsdf_has_delta(const BsdfParams *p)
{
    return bsdf_roughness_is_delta(p->roughness) || (bsdf_has_coat(p) && bsdf_coat_smooth(p));
}

/* Whether the material is Lambert's alone: no metal, no transmission and no
 * specular layer, so every other lobe has weight 0 and bsdf_eval, bsdf_pdf and
 * bsdf_sample reduce to base cos / pi, cos / pi and a cosine sample. They take
 * that shortcut, which gives the same floats as the general arithmetic: the
 * diffuse factor is base * 1 * 1 and the diffuse lobe's probability wd / wd = 1. */
SPT_FN int bsdf_is_lambert(const BsdfParams *p)
{
    return p->specular == 0.0f && !(p->metallic > 0.0f) && !(p->transmission > 0.0f) &&
           !bsdf_has_coat(p) && !bsdf_has_sheen(p);
}

/* Fresnel of the metal part at cosine c between wo and h, per wavelength: Schlick
 * with F0 = base (glTF conductor_fresnel), or exact with eta + i k. */
SPT_FN vec4 bsdf_metal_fresnel(const BsdfParams *p, float c)
{
    if (p->conductor)
        return v4(bsdf_fresnel_conductor(c, p->eta.x, p->k.x), bsdf_fresnel_conductor(c, p->eta.y, p->k.y),
                  bsdf_fresnel_conductor(c, p->eta.z, p->k.z), bsdf_fresnel_conductor(c, p->eta.w, p->k.w));
    return bsdf_schlick(p->base, c);
}

/* The reflection Fresnel weight of the specular layer per wavelength at cosine c
 * (wo.h): m F_metal + (1-m)(1-t) F_dielectric (bsdf_dielectric_fresnel). */
SPT_FN vec4 bsdf_spec_fresnel(const BsdfParams *p, float c)
{
    float m = fminf(fmaxf(p->metallic, 0.0f), 1.0f);
    float t = fminf(fmaxf(p->transmission, 0.0f), 1.0f);
    vec4 fd = bsdf_dielectric_fresnel(p, c);
    return v4_add(v4_scale(bsdf_metal_fresnel(p, c), m), v4_scale(fd, (1.0f - m) * (1.0f - t)));
}

/* The diffuse lobe's factor per wavelength, without 1/pi: (1-m)(1-t)(1 - F_dielectric)
 * base (glTF fresnel_mix). */
SPT_FN vec4 bsdf_diffuse_factor(const BsdfParams *p, float c)
{
    float m = fminf(fmaxf(p->metallic, 0.0f), 1.0f);
    float t = fminf(fmaxf(p->transmission, 0.0f), 1.0f);
    vec4 one_minus = v4_sub(v4_splat(1.0f), bsdf_dielectric_fresnel(p, c));
    return v4_scale(v4_mul(one_minus, p->base), (1.0f - m) * (1.0f - t));
}

/* Generalised half vector of a refraction (Walter et al. 2007, eq. 16), oriented to
 * +z, for wo, wi on opposite sides and eta = n_inside / n_outside. */
SPT_FN vec3 bsdf_half_refract(vec3 wo, vec3 wi, float eta)
{
    float etap = wo.z > 0.0f ? eta : 1.0f / eta;
    vec3 h = v3_normalize(v3_add(wo, v3_scale(wi, etap)));
    return h.z < 0.0f ? v3_scale(h, -1.0f) : h;
}

/* The chance that the interface reflects at cosine cos_h (signed as
 * bsdf_fresnel_dielectric takes it): the mean of the path's wavelengths'
 * Fresnel reflectances, the hero's alone without dispersion. With a dispersive
 * index the hero's may be near 0 (n near 1) where another's is not, and
 * reflection's weight F_i / F_hero would be huge or, at F_hero = 0, that light
 * lost (docs/gltf.md, KHR_materials_dispersion). */
SPT_FN float bsdf_interface_q(const BsdfParams *p, float cos_h)
{
    float f = bsdf_fresnel_dielectric(cos_h, p->ior.x);
    if (p->ior.x == p->ior.y && p->ior.x == p->ior.z && p->ior.x == p->ior.w)
        return f;
    return 0.25f * (f + bsdf_fresnel_dielectric(cos_h, p->ior.y) + bsdf_fresnel_dielectric(cos_h, p->ior.z) +
                    bsdf_fresnel_dielectric(cos_h, p->ior.w));
}

/* The rough dielectric interface's f |cos i| contribution and its pdf for the
 * given wo, wi (Walter et al. 2007 eqs. 20-21 with VNDF sampling; pdf per
 * steradian of wi), for index eta (hero wavelength's value) and alpha. Fresnel is
 * the exact dielectric one; transmission is divided by eta'^2 (radiance). */
SPT_FN float bsdf_interface_eval_q(vec3 wo, vec3 wi, float eta, float alpha, const BsdfParams *pq, float *pdf)
{
    *pdf = 0.0f;
    if (wo.z == 0.0f || wi.z == 0.0f)
        return 0.0f;
    int reflect = wo.z * wi.z > 0.0f;
    float etap = 1.0f;
    vec3 h;
    if (reflect) {
        h = v3_normalize(v3_add(wo, wi));
        if (h.z < 0.0f)
            h = v3_scale(h, -1.0f);
    } else {
        etap = wo.z > 0.0f ? eta : 1.0f / eta;
        h = bsdf_half_refract(wo, wi, eta);
    }
    float dwo = v3_dot(wo, h), dwi = v3_dot(wi, h);
    /* Backfacing microfacets are discarded, and so is an undefined h (a
     * refraction at eta 1 straight through: wo + wi = 0). */
    if (!(dwo * wo.z > 0.0f) || !(dwi * wi.z > 0.0f))
        return 0.0f;
    float F = bsdf_fresnel_dielectric(dwo, eta);
    float D = bsdf_ggx_d(h, alpha);
    /* VNDF in the frame where wo is above: flip both when wo is inside. */
    vec3 wo_up = wo.z > 0.0f ? wo : v3_scale(wo, -1.0f);
    vec3 wi_up = wo.z > 0.0f ? wi : v3_scale(wi, -1.0f);
    float G = 1.0f / (1.0f + bsdf_ggx_lambda(wo_up, alpha) + bsdf_ggx_lambda(v3(wi_up.x, wi_up.y, fabsf(wi_up.z)), alpha));
    float vis = bsdf_ggx_vndf_pdf(wo_up, h, alpha);
    float q = pq ? bsdf_interface_q(pq, dwo) : F;
    if (reflect) {
        *pdf = vis / (4.0f * fabsf(dwo)) * q;
        return D * G * F / (4.0f * fabsf(wo.z));
    }
    float denom = dwi + dwo / etap;
    float jac = fabsf(dwi) / (denom * denom);
    *pdf = vis * jac * (1.0f - q);
    float ft = D * G * (1.0f - F) * fabsf(dwi * dwo) / (fabsf(wo.z) * denom * denom);
    return ft / (etap * etap);
}

/* bsdf_interface_eval_q with the pdf of reflecting with eta's own Fresnel. */
SPT_FN float bsdf_interface_eval(vec3 wo, vec3 wi, float eta, float alpha, float *pdf)
{
    return bsdf_interface_eval_q(wo, wi, eta, alpha, 0, pdf);
}

/* The base's (metallic-roughness, transmission) non-delta f |cos theta_i|, without
 * the layers; bsdf_eval below. */
SPT_FN vec4 bsdf_base_eval(const BsdfParams *p, vec3 wo, vec3 wi)
{
    vec4 r = v4_splat(0.0f);
    if (bsdf_is_lambert(p))
        return wo.z > 0.0f && wi.z > 0.0f ? v4_scale(p->base, SPT_INV_PI * wi.z) : r;
    float alpha = bsdf_alpha(p->roughness);
    int smooth = bsdf_roughness_is_delta(p->roughness);
    float m = fminf(fmaxf(p->metallic, 0.0f), 1.0f);
    float t = fminf(fmaxf(p->transmission, 0.0f), 1.0f);
    if (wo.z > 0.0f && wi.z > 0.0f) {
        vec3 h = v3_normalize(v3_add(wo, wi));
        float c = fabsf(v3_dot(wo, h));
        r = v4_scale(bsdf_diffuse_factor(p, c), SPT_INV_PI * wi.z);
        /* The specular layer: skipped when it has no weight (a pure Lambertian). */
        if (!smooth && (m > 0.0f || (p->specular > 0.0f && t < 1.0f))) {
            float spec = bsdf_ggx_d(h, alpha) * bsdf_ggx_g2(wo, wi, alpha) / (4.0f * wo.z);
            r = v4_add(r, v4_scale(bsdf_spec_fresnel(p, c), spec));
        }
    }
    float wt = (1.0f - m) * t;
    if (wt > 0.0f && !smooth) {
        float pd;
        vec4 fi = v4(bsdf_interface_eval(wo, wi, p->ior.x, alpha, &pd), bsdf_interface_eval(wo, wi, p->ior.y, alpha, &pd),
                     bsdf_interface_eval(wo, wi, p->ior.z, alpha, &pd), bsdf_interface_eval(wo, wi, p->ior.w, alpha, &pd));
        /* KHR_materials_transmission tints the transmitted light by the base colour. */
        if (wo.z * wi.z < 0.0f)
            fi = v4_mul(fi, p->base);
        r = v4_add(r, v4_scale(fi, wt));
    }
    return r;
}

/* Non-delta part of f(wo, wi) |cos theta_i| per wavelength, for wo.z > 0 (the
 * viewer outside) or, for the transmission lobe, either side. Delta lobes give 0.
 * The interface uses each wavelength's ior. */
SPT_FN vec4 bsdf_eval(const BsdfParams *p, vec3 wo, vec3 wi)
{
    vec4 r = bsdf_base_eval(p, wo, wi);
    if (bsdf_has_coat(p) || bsdf_has_sheen(p))
        r = bsdf_layers_eval(p, wo, wi, r);
    return r;
}

/* Solid-angle pdf with which bsdf_sample produces wi given wo (non-delta lobes
 * only; one-sample MIS over the lobes with bsdf_lobe_probs). The interface's pdf
 * uses the hero wavelength's ior. */
SPT_FN float bsdf_pdf(const BsdfParams *p, vec3 wo, vec3 wi)
{
    if (bsdf_is_lambert(p))
        return (wo.z > 0.0f && wi.z > 0.0f) ? wi.z * SPT_INV_PI : 0.0f;
    int smooth = bsdf_roughness_is_delta(p->roughness);
    float alpha = bsdf_alpha(p->roughness);
    float ps, pd, pt, pc, psh;
    bsdf_lobe_probs(p, wo, &ps, &pd, &pt, &pc, &psh);
    float pdf = 0.0f;
    if (wo.z > 0.0f && wi.z > 0.0f) {
        pdf += pd * wi.z * SPT_INV_PI;
        if (ps > 0.0f && !smooth) {
            vec3 h = v3_normalize(v3_add(wo, wi));
            pdf += ps * bsdf_ggx_vndf_pdf(wo, h, alpha) / (4.0f * v3_dot(wo, h));
        }
        if (psh > 0.0f)
            pdf += psh * SPT_INV_2PI;
    }
    if (pt > 0.0f && !smooth) {
        float pi_;
        bsdf_interface_eval_q(wo, wi, p->ior.x, alpha, p, &pi_);
        pdf += pt * pi_;
    }
    if (pc > 0.0f && !bsdf_coat_smooth(p)) {
        float pcd;
        bsdf_coat_eval(p, wo, wi, &pcd);
        pdf += pc * pcd;
    }
    return pdf;
}

/* Samples wi for wo from uniforms u0 (lobe choice), u1, u2 in [0, 1). Rough
 * lobes: weight = bsdf_eval / bsdf_pdf (so MIS with light sampling is consistent).
 * Delta lobes (alpha below BSDF_DELTA_ALPHA): mirror reflection with the Fresnel
 * weight, or the smooth interface choosing reflection with probability F of the
 * hero wavelength; is_delta is set. When the ior differs between wavelengths and
 * the sample refracted (smooth or rough), dispersive is set and only weight.x is
 * meaningful (the others are set to it; the renderer terminates them). */
/* sin and cos of x for |x| <= pi/4, where no argument reduction is needed: the
 * minimax polynomials of Cephes' sinf and cosf (S. Moshier), relative error
 * below 2^-23 there. Cheaper than the general sin/cos, whose argument
 * reduction (PoCL's __pocl_argReductionS) is an out-of-line call per use. */
SPT_FN void bsdf_sincos_pi4(float x, float *s, float *c)
{
    float z = x * x;
    *s = ((-1.9515295891e-4f * z + 8.3321608736e-3f) * z - 1.6666654611e-1f) * z * x + x;
    *c = ((2.443315711809948e-5f * z - 1.388731625493765e-3f) * z + 4.166664568298827e-2f) * z * z -
         0.5f * z + 1.0f;
}

/* Cosine-weighted hemisphere direction (Malley's method on a concentric disk).
 * The disk angle is phi = pi/4 (b/a), or pi/2 - pi/4 (a/b) on the other
 * wedges; the latter's cos and sin are the sin and cos of pi/4 (a/b), so both
 * take bsdf_sincos_pi4 of an angle in [-pi/4, pi/4]. Written with selects, not
 * branches: which wedge a random point falls in is a coin toss, which a CPU's
 * branch predictor gets wrong half the time. */
SPT_FN vec3 bsdf_sample_cosine(float u1, float u2)
{
    float a = 2.0f * u1 - 1.0f, b = 2.0f * u2 - 1.0f;
    int wide = fabsf(a) > fabsf(b);
    float r = wide ? a : b;
    float s, c;
    bsdf_sincos_pi4(0.25f * SPT_PI * ((wide ? b : a) / r), &s, &c);
    float x = r * (wide ? c : s), y = r * (wide ? s : c);
    /* The centre (a = b = 0) maps to itself (the ratio above is 0/0 there). */
    int centre = a == 0.0f && b == 0.0f;
    x = centre ? 0.0f : x;
    y = centre ? 0.0f : y;
    return v3(x, y, sqrtf(fmaxf(0.0f, 1.0f - x * x - y * y)));
}

SPT_FN BsdfSample bsdf_sample(const BsdfParams *p, vec3 wo, float u0, float u1, float u2)
{
    BsdfSample s;
    s.wi = v3(0.0f, 0.0f, 1.0f);
    s.weight = v4_splat(0.0f);
    s.pdf = 0.0f;
    s.is_delta = 0;
    s.dispersive = 0;
    s.valid = 0;
    if (wo.z == 0.0f)
        return s;
    if (bsdf_is_lambert(p)) {
        if (wo.z <= 0.0f)
            return s;
        s.wi = bsdf_sample_cosine(u1, u2);
        s.pdf = s.wi.z > 0.0f ? s.wi.z * SPT_INV_PI : 0.0f;
        if (!(s.pdf > 0.0f))
            return s;
        s.weight = v4_scale(v4_scale(p->base, SPT_INV_PI * s.wi.z), 1.0f / s.pdf);
        s.valid = 1;
        return s;
    }
    float ps, pd, pt, pc, psh;
    bsdf_lobe_probs(p, wo, &ps, &pd, &pt, &pc, &psh);
    int smooth = bsdf_roughness_is_delta(p->roughness);
    int layered = bsdf_has_coat(p) || bsdf_has_sheen(p);
    float eo, ei;
    float alpha = bsdf_alpha(p->roughness);
    int dispersive_ior = p->ior.x != p->ior.y || p->ior.x != p->ior.z || p->ior.x != p->ior.w;
    float m = fminf(fmaxf(p->metallic, 0.0f), 1.0f);
    float tr = fminf(fmaxf(p->transmission, 0.0f), 1.0f);

    if (u0 < pt) {
        /* The dielectric interface. */
        float eta = p->ior.x;
        float wt = (1.0f - m) * tr;
        vec3 wo_up = wo.z > 0.0f ? wo : v3_scale(wo, -1.0f);
        vec3 h = smooth ? v3(0.0f, 0.0f, 1.0f) : bsdf_ggx_sample_vndf(wo_up, alpha, u1, u2);
        float cos_h = wo.z > 0.0f ? v3_dot(wo, h) : -v3_dot(wo_up, h);
        float F = bsdf_fresnel_dielectric(cos_h, eta);
        /* Reflection with the chance q of bsdf_interface_q (bsdf_pdf's too). */
        float q = bsdf_interface_q(p, cos_h);
        /* Reuse u0 for reflect/refract: u0/pt is uniform in [0, 1). */
        float ur = u0 / pt;
        int reflect = ur < q;
        /* A hero of index 1 (docs/gltf.md: the clamp of a dispersive index)
         * meets no interface: it passes straight through, smooth or rough (the
         * rough refraction's half vector wo + wi would be 0). */
        int matched = eta == 1.0f && !reflect;
        if (matched) {
            s.wi = v3_scale(wo, -1.0f);
            s.dispersive = dispersive_ior;
            s.is_delta = 1;
            s.valid = 1;
            s.pdf = pt * (1.0f - q);
            s.weight = v4_scale(p->base, wt / s.pdf);
            if (layered)
                s.weight = v4_mul(s.weight, bsdf_layer_scale(p, wo, s.wi, &eo, &ei));
            if (s.dispersive)
                s.weight = v4_splat(s.weight.x);
            return s;
        }
        if (reflect) {
            s.wi = bsdf_reflect(wo, wo.z > 0.0f ? h : v3_scale(h, -1.0f));
        } else {
            float etap = wo.z > 0.0f ? eta : 1.0f / eta;
            vec3 n = wo.z > 0.0f ? h : v3_scale(h, -1.0f);
            if (!bsdf_refract(wo, n, etap, &s.wi))
                return s;
            s.dispersive = dispersive_ior;
        }
        /* A microfacet reflection that leaves through the surface (or a refraction
         * that stays on wo's side) is not an event of this lobe. */
        if ((s.wi.z * wo.z > 0.0f) != (reflect != 0))
            return s;
        if (smooth) {
            s.is_delta = 1;
            s.valid = 1;
            s.pdf = pt * (reflect ? q : 1.0f - q);
            if (reflect) {
                /* Each wavelength's F over the chance q of reflecting. */
                vec4 fr = v4_splat(F);
                if (dispersive_ior)
                    fr = v4(F, bsdf_fresnel_dielectric(cos_h, p->ior.y), bsdf_fresnel_dielectric(cos_h, p->ior.z),
                            bsdf_fresnel_dielectric(cos_h, p->ior.w));
                s.weight = v4_scale(fr, wt / s.pdf);
            } else {
                float etap = wo.z > 0.0f ? eta : 1.0f / eta;
                float w = wt * (1.0f - F) / (s.pdf * etap * etap);
                s.weight = v4_scale(p->base, w);
            }
            if (layered)
                s.weight = v4_mul(s.weight, bsdf_layer_scale(p, wo, s.wi, &eo, &ei));
            if (s.dispersive)
                s.weight = v4_splat(s.weight.x);
            return s;
        }
    } else if (u0 < pt + ps) {
        if (wo.z <= 0.0f)
            return s;
        if (smooth) {
            s.wi = v3(-wo.x, -wo.y, wo.z);
            s.is_delta = 1;
            s.valid = 1;
            s.pdf = ps;
            s.weight = v4_scale(bsdf_spec_fresnel(p, wo.z), 1.0f / ps);
            if (layered)
                s.weight = v4_mul(s.weight, bsdf_layer_scale(p, wo, s.wi, &eo, &ei));
            return s;
        }
        vec3 h = bsdf_ggx_sample_vndf(wo, alpha, u1, u2);
        s.wi = bsdf_reflect(wo, h);
        /* A reflection into the surface is no event of this lobe (its pdf
         * counts only wi above). */
        if (!(s.wi.z > 0.0f))
            return s;
    } else if (u0 < pt + ps + pc) {
        /* The coat, about its own normal. */
        if (wo.z <= 0.0f)
            return s;
        if (bsdf_coat_smooth(p)) {
            s.wi = bsdf_reflect(wo, p->cc_n);
            if (!(s.wi.z > 0.0f))
                return s;
            s.is_delta = 1;
            s.valid = 1;
            s.pdf = pc;
            s.weight = v4_splat(bsdf_coat_weight(p, wo) / pc);
            return s;
        }
        vec3 o = bsdf_to_coat(p, wo);
        if (!(o.z > 0.0f))
            return s;
        vec3 h = bsdf_ggx_sample_vndf(o, bsdf_alpha(p->cc_roughness), u1, u2);
        vec3 i = bsdf_reflect(o, h);
        if (!(i.z > 0.0f))
            return s;
        s.wi = bsdf_from_coat(p, i);
    } else if (u0 < pt + ps + pc + psh) {
        /* The sheen: uniform over the hemisphere (the lobe is broad and peaks
         * toward grazing directions, where a cosine density is thin). */
        if (wo.z <= 0.0f)
            return s;
        float z = u1, r = sqrtf(fmaxf(0.0f, 1.0f - z * z)), phi = 2.0f * SPT_PI * u2;
        s.wi = v3(r * cosf(phi), r * sinf(phi), z);
    } else {
        if (wo.z <= 0.0f)
            return s;
        s.wi = bsdf_sample_cosine(u1, u2);
    }
    s.pdf = bsdf_pdf(p, wo, s.wi);
    if (!(s.pdf > 0.0f))
        return s;
    vec4 f = bsdf_eval(p, wo, s.wi);
    s.weight = v4_scale(f, 1.0f / s.pdf);
    if (s.dispersive)
        s.weight = v4_splat(s.weight.x);
    s.valid = 1;
    return s;
}

#endif
