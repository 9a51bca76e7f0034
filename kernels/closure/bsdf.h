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
 *  - KHR_materials_sheen over that base (closure/lobe_sheen.h): the "Charlie"
 *    lobe in the sheen colour, the base scaled by 1 - max3(sheen colour)
 *    max(E(mu_o), E(mu_i)), E the lobe's directional albedo.
 *  - KHR_materials_anisotropy: the specular lobe is the anisotropic GGX
 *    (closure/lobe_specular.h) about the anisotropy direction.
 *  - KHR_materials_diffuse_transmission: 1 - factor of the Lambertian base
 *    stays diffuse reflection, factor of it is Lambertian transmission in the
 *    transmission colour (closure/lobe_diffuse_transmission.h).
 *  - KHR_materials_clearcoat on top (closure/lobe_coat.h): a second GGX lobe about
 *    the coat's own normal, weighted clearcoat Fc, the layers under it
 *    1 - clearcoat Fc. Light crossing the layers into a transmissive base is
 *    scaled the same way at its outside direction (bsdf_layer_scale).
 *
 * One file per lobe, each with its selection weight, f |cos|, pdf and sampling
 * side by side: closure/lobe_diffuse.h, lobe_specular.h (metal and the
 * dielectric's specular layer), lobe_transmission.h (the dielectric interface,
 * smooth and rough), lobe_coat.h, lobe_sheen.h,
 * lobe_diffuse_transmission.h; their building blocks (Fresnel,
 * refraction, GGX) in closure/bsdf_microfacet.h. This file composes them into
 * the glTF material: the lobes' selection probabilities, the layering (coat
 * over sheen over the base) and the one-sample MIS over the lobes
 * (docs/architecture.md, "Adding a BSDF lobe"). */
#ifndef SPT_BSDF_H
#define SPT_BSDF_H

#include "util/portable.h"
#include "util/vecmath.h"
#include "sample/sampling.h"
#include "closure/bsdf_params.h"
#include "closure/bsdf_microfacet.h"
#include "closure/lobe_diffuse.h"
#include "closure/lobe_specular.h"
#include "closure/lobe_transmission.h"
#include "closure/lobe_coat.h"
#include "closure/lobe_sheen.h"
#include "closure/lobe_diffuse_transmission.h"

/* The lobes, in the order bsdf_sample's u0 walks their probabilities (the
 * order is part of the images: a sample's lobe depends on it). */
enum {
    BSDF_LOBE_TRANSMISSION,
    BSDF_LOBE_SPECULAR,
    BSDF_LOBE_COAT,
    BSDF_LOBE_SHEEN,
    BSDF_LOBE_DIFFUSE_TRANSMISSION,
    BSDF_LOBE_DIFFUSE,
    BSDF_LOBES
};

/* Lobe selection probabilities for wo, indexed by BSDF_LOBE_* (in the frame
 * where wo.z > 0 for the reflection lobes): each lobe's weight at wo, those of
 * the base (specular, diffuse, transmission) times what the layers over it let
 * through at wo: the coat takes its weight, the sheen max3(colour) min(1, E(mu_o))
 * of the rest. Sum to 1 (the diffuse lobe alone when every weight is 0). */
SPT_FN void bsdf_lobe_probs(const BsdfParams *p, vec3 wo, float pr[BSDF_LOBES])
{
    pr[BSDF_LOBE_SPECULAR] = bsdf_specular_weight(p, wo);
    pr[BSDF_LOBE_DIFFUSE] = bsdf_diffuse_weight(p, wo);
    pr[BSDF_LOBE_TRANSMISSION] = bsdf_transmission_weight(p);
    pr[BSDF_LOBE_COAT] = 0.0f;
    pr[BSDF_LOBE_SHEEN] = 0.0f;
    pr[BSDF_LOBE_DIFFUSE_TRANSMISSION] = bsdf_dt_weight(p, wo);
    if (wo.z > 0.0f && (bsdf_has_coat(p) || bsdf_has_sheen(p))) {
        float wc = bsdf_coat_weight(p, wo);
        float e = bsdf_sheen_e(p, wo);
        float under = (1.0f - wc) * (1.0f - p->sheen_max * e);
        pr[BSDF_LOBE_COAT] = wc;
        pr[BSDF_LOBE_SHEEN] = (1.0f - wc) * p->sheen_max * e;
        pr[BSDF_LOBE_SPECULAR] *= under;
        pr[BSDF_LOBE_DIFFUSE] *= under;
        pr[BSDF_LOBE_TRANSMISSION] *= under;
        pr[BSDF_LOBE_DIFFUSE_TRANSMISSION] *= under;
    }
    /* Summed in this order (its rounding is part of the images). */
    float sum = pr[BSDF_LOBE_SPECULAR] + pr[BSDF_LOBE_DIFFUSE] + pr[BSDF_LOBE_TRANSMISSION] + pr[BSDF_LOBE_COAT] +
                pr[BSDF_LOBE_SHEEN] + pr[BSDF_LOBE_DIFFUSE_TRANSMISSION];
    for (int i = 0; i < BSDF_LOBES; i++)
        pr[i] = sum <= 0.0f ? (i == BSDF_LOBE_DIFFUSE ? 1.0f : 0.0f) : pr[i] / sum;
}

/* The lobe that u0 in [0, 1) picks from the probabilities pr: the first whose
 * running sum exceeds u0 (the last when rounding leaves u0 above them all); *ur:
 * u0 remapped to [0, 1) within the lobe's interval, a fresh uniform number for
 * a choice inside the lobe. */
SPT_FN int bsdf_pick_lobe(const float pr[BSDF_LOBES], float u0, float *ur)
{
    float lo = 0.0f;
    for (int i = 0; i < BSDF_LOBES - 1; i++) {
        float hi = lo + pr[i];
        if (u0 < hi) {
            *ur = (u0 - lo) / pr[i];
            return i;
        }
        lo = hi;
    }
    *ur = (u0 - lo) / pr[BSDF_LOBES - 1];
    return BSDF_LOBES - 1;
}

/* Whether lobe i of p is a delta: the base's reflection and interface when the
 * base is smooth, the coat when it is. */
SPT_FN int bsdf_lobe_is_delta(const BsdfParams *p, int i)
{
    if (i == BSDF_LOBE_TRANSMISSION)
        return bsdf_base_smooth(p);
    if (i == BSDF_LOBE_SPECULAR)
        return bsdf_specular_smooth(p);
    return i == BSDF_LOBE_COAT && bsdf_has_coat(p) && bsdf_coat_smooth(p);
}

/* Whether every lobe of the material is a delta (smooth, no anisotropy, no
 * diffuse, no sheen, no rough coat): light sampling is then useless and MIS must not be applied. */
SPT_FN int bsdf_is_delta(const BsdfParams *p)
{
    float m = bsdf_metallic(p);
    float t = bsdf_transmission(p);
    int no_diffuse = m >= 1.0f || t >= 1.0f;
    return bsdf_roughness_is_delta(p->roughness) && !bsdf_has_aniso(p) && no_diffuse && !bsdf_has_sheen(p) &&
           (!bsdf_has_coat(p) || bsdf_coat_smooth(p));
}

/* Whether the material is Lambert's alone: no metal, no transmission, no
 * diffuse transmission and no specular layer, so every other lobe has weight 0 and bsdf_eval, bsdf_pdf and
 * bsdf_sample reduce to base cos / pi, cos / pi and a cosine sample. They take
 * that shortcut, which gives the same floats as the general arithmetic: the
 * diffuse factor is base * 1 * 1 and the diffuse lobe's probability wd / wd = 1. */
SPT_FN int bsdf_is_lambert(const BsdfParams *p)
{
    return p->specular == 0.0f && !(p->metallic > 0.0f) && !(p->transmission > 0.0f) &&
           !bsdf_has_coat(p) && !bsdf_has_sheen(p) && !bsdf_has_dt(p);
}

SPT_FN int bsdf_is_layered(const BsdfParams *p) { return bsdf_has_coat(p) || bsdf_has_sheen(p); }

/* Whether u0 picks a delta lobe in bsdf_sample (light tracing follows only
 * the delta events from its first vertex on). */
SPT_FN int bsdf_picks_delta(const BsdfParams *p, vec3 wo, float u0)
{
    if (bsdf_is_lambert(p))
        return 0;
    float pr[BSDF_LOBES], ur;
    bsdf_lobe_probs(p, wo, pr);
    return bsdf_lobe_is_delta(p, bsdf_pick_lobe(pr, u0, &ur));
}

/* What the base's light is scaled by where it passes the layers, per wavelength:
 * (1 - coat weight) (1 - s max(E(mu_o), E(mu_i)) capped at 1), with the coat
 * weight and the E of the directions outside the surface only (a ray crossing a
 * transmissive base meets the layers once), s the larger of max3(sheen colour)
 * and the sheen's value at the wavelength (so that no wavelength gains energy
 * where the upsampled spectrum peaks above the colour's largest component). */
SPT_FN vec4 bsdf_layer_scale(const BsdfParams *p, vec3 wo, vec3 wi)
{
    int up_o = wo.z > 0.0f, up_i = wi.z > 0.0f;
    if (!up_o && !up_i)
        return v4_splat(1.0f);
    float wc = bsdf_coat_weight(p, up_o ? wo : wi);
    if (!bsdf_has_sheen(p))
        return v4_splat(1.0f - wc);
    float r = bsdf_sheen_r(p);
    float eo = up_o ? bsdf_sheen_albedo(wo.z, r) : 0.0f;
    float ei = up_i ? bsdf_sheen_albedo(wi.z, r) : 0.0f;
    float e = fminf(1.0f, fmaxf(eo, ei));
    vec4 s = v4(fmaxf(p->sheen.x, p->sheen_max), fmaxf(p->sheen.y, p->sheen_max),
                fmaxf(p->sheen.z, p->sheen_max), fmaxf(p->sheen.w, p->sheen_max));
    return v4_scale(v4_sub(v4_splat(1.0f), v4_scale(s, e)), 1.0f - wc);
}

/* Non-delta part of f(wo, wi) |cos theta_i| per wavelength, for wo.z > 0 (the
 * viewer outside) or, for the transmission lobe, either side. Delta lobes give 0.
 * The interface uses each wavelength's ior. The base's lobes, scaled by what
 * the layers let through, then the layers' own lobes (summed in this order:
 * its rounding is part of the images). */
SPT_FN vec4 bsdf_eval(const BsdfParams *p, vec3 wo, vec3 wi)
{
    vec4 f = v4_splat(0.0f);
    if (bsdf_is_lambert(p))
        return wo.z > 0.0f && wi.z > 0.0f ? v4_scale(p->base, SPT_INV_PI * wi.z) : f;
    bsdf_diffuse_eval(p, wo, wi, &f);
    bsdf_specular_eval(p, wo, wi, &f);
    bsdf_transmission_eval(p, wo, wi, &f);
    bsdf_dt_eval(p, wo, wi, &f);
    if (!bsdf_is_layered(p))
        return f;
    f = v4_mul(f, bsdf_layer_scale(p, wo, wi));
    bsdf_sheen_eval(p, wo, wi, 1.0f - bsdf_coat_weight(p, wo), &f);
    bsdf_coat_eval(p, wo, wi, &f);
    return f;
}

/* Solid-angle pdf with which bsdf_sample produces wi given wo (non-delta lobes
 * only; one-sample MIS over the lobes with bsdf_lobe_probs: the lobes' shares
 * summed in this order, its rounding part of the images). The interface's pdf
 * uses the hero wavelength's ior. */
SPT_FN float bsdf_pdf(const BsdfParams *p, vec3 wo, vec3 wi)
{
    if (bsdf_is_lambert(p))
        return wo.z > 0.0f && wi.z > 0.0f ? spt_pdf_cosine_hemisphere(wi.z) : 0.0f;
    float pr[BSDF_LOBES];
    bsdf_lobe_probs(p, wo, pr);
    float pdf = 0.0f;
    pdf += bsdf_diffuse_pdf(wo, wi, pr[BSDF_LOBE_DIFFUSE]);
    pdf += bsdf_specular_pdf(p, wo, wi, pr[BSDF_LOBE_SPECULAR]);
    pdf += bsdf_sheen_pdf(wo, wi, pr[BSDF_LOBE_SHEEN]);
    pdf += bsdf_transmission_pdf(p, wo, wi, pr[BSDF_LOBE_TRANSMISSION]);
    pdf += bsdf_coat_pdf(p, wo, wi, pr[BSDF_LOBE_COAT]);
    pdf += bsdf_dt_pdf(wo, wi, pr[BSDF_LOBE_DIFFUSE_TRANSMISSION]);
    return pdf;
}

/* Samples wi for wo from uniforms u0 (lobe choice), u1, u2 in [0, 1). Rough
 * lobes: weight = bsdf_eval / bsdf_pdf (so MIS with light sampling is consistent).
 * Delta lobes (alpha below BSDF_DELTA_ALPHA): mirror reflection with the Fresnel
 * weight, or the smooth interface choosing reflection with probability F of the
 * hero wavelength; is_delta is set. When the ior differs between wavelengths and
 * the sample refracted (smooth or rough), dispersive is set and only weight.x is
 * meaningful (the others are set to it; the renderer terminates them). */
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
        s.wi = spt_sample_cosine_hemisphere(u1, u2);
        s.pdf = spt_pdf_cosine_hemisphere(s.wi.z);
        if (!(s.pdf > 0.0f))
            return s;
        s.weight = v4_scale(v4_scale(p->base, SPT_INV_PI * s.wi.z), 1.0f / s.pdf);
        s.valid = 1;
        return s;
    }
    float pr[BSDF_LOBES], ur;
    bsdf_lobe_probs(p, wo, pr);
    int lobe = bsdf_pick_lobe(pr, u0, &ur);
    int got;
    switch (lobe) {
    case BSDF_LOBE_TRANSMISSION:
        got = bsdf_transmission_sample(p, wo, ur, u1, u2, pr[lobe], &s);
        break;
    case BSDF_LOBE_SPECULAR:
        got = bsdf_specular_sample(p, wo, u1, u2, pr[lobe], &s);
        break;
    case BSDF_LOBE_COAT:
        got = bsdf_coat_sample(p, wo, u1, u2, pr[lobe], &s);
        break;
    case BSDF_LOBE_SHEEN:
        got = bsdf_sheen_sample(wo, u1, u2, &s);
        break;
    case BSDF_LOBE_DIFFUSE_TRANSMISSION:
        got = bsdf_dt_sample(wo, u1, u2, &s);
        break;
    default:
        got = bsdf_diffuse_sample(wo, u1, u2, &s);
        break;
    }
    if (got == BSDF_SAMPLED_NONE)
        return s;
    if (got == BSDF_SAMPLED_DELTA) {
        /* A delta event of the base (all but the coat, the top layer) passes
         * the layers over it. */
        if (lobe != BSDF_LOBE_COAT && bsdf_is_layered(p))
            s.weight = v4_mul(s.weight, bsdf_layer_scale(p, wo, s.wi));
        if (s.dispersive)
            s.weight = v4_splat(s.weight.x);
        return s;
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
