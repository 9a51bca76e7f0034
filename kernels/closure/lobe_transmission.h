/* The dielectric interface of the glTF material (KHR_materials_transmission
 * with KHR_materials_ior and KHR_materials_dispersion), weighted (1 - m) t and
 * with its refraction tinted by the base colour: the exact dielectric Fresnel
 * equations; smooth (below BSDF_DELTA_ALPHA): specular reflection or
 * refraction, delta lobes; rough: GGX microfacet reflection and transmission
 * (Walter et al. 2007, "Microfacet Models for Refraction through Rough
 * Surfaces"). Refracted radiance is scaled by 1/eta^2 (radiance transport, as
 * pbrt-v4 does). Under a KHR_materials_iridescence film the Fresnel
 * reflectance is the film's mix (bsdf_interface_film). The only lobe that
 * responds from inside. Weight, f |cos|, pdf and sampling side by side;
 * kernels/closure/bsdf.h composes the lobes. */
#ifndef SPT_LOBE_TRANSMISSION_H
#define SPT_LOBE_TRANSMISSION_H

#include "util/portable.h"
#include "util/vecmath.h"
#include "closure/bsdf_params.h"
#include "closure/bsdf_microfacet.h"

/* Generalised half vector of a refraction (Walter et al. 2007, eq. 16), oriented to
 * +z, for wo, wi on opposite sides and eta = n_inside / n_outside. */
SPT_FN vec3 bsdf_half_refract(vec3 wo, vec3 wi, float eta)
{
    float etap = wo.z > 0.0f ? eta : 1.0f / eta;
    vec3 h = v3_normalize(v3_add(wo, v3_scale(wi, etap)));
    return h.z < 0.0f ? v3_scale(h, -1.0f) : h;
}

/* The interface's reflectance at cosine cos_h (signed as
 * bsdf_fresnel_dielectric takes it) per wavelength under a KHR_materials_iridescence
 * film (p->iridescence > 0): the exact Fresnel mixed with the film's
 * reflectance (kernels/closure/thin_film.h) by the iridescence factor, as
 * bsdf_film_mix mixes the layer's. The film lies on the outside face: from
 * inside, light meets the base first (the film between the base's index and
 * the outside's; past the critical angle the film's field is evanescent and
 * the reflection total). A lossless film transmits the rest, 1 - F. */
SPT_FN vec4 bsdf_interface_film(const BsdfParams *p, float cos_h)
{
    vec4 f = v4(bsdf_fresnel_dielectric(cos_h, p->ior.x), bsdf_fresnel_dielectric(cos_h, p->ior.y),
                bsdf_fresnel_dielectric(cos_h, p->ior.z), bsdf_fresnel_dielectric(cos_h, p->ior.w));
    if (cos_h >= 0.0f || !bsdf_has_film(p))
        return bsdf_film_mix(p, f, cos_h, p->ior, v4_splat(0.0f), 1.0f);
#if SPT_IRIDESCENCE
    float n0 = p->clearcoat > 0.0f ? 1.5f : 1.0f, c = -cos_h, n = p->film_ior, d = p->film_nm;
    vec4 film = v4(spt_thin_film_reflectance(c, p->lambda.x, p->ior.x, n, d, n0, 0.0f),
                   spt_thin_film_reflectance(c, p->lambda.y, p->ior.y, n, d, n0, 0.0f),
                   spt_thin_film_reflectance(c, p->lambda.z, p->ior.z, n, d, n0, 0.0f),
                   spt_thin_film_reflectance(c, p->lambda.w, p->ior.w, n, d, n0, 0.0f));
    return v4_add(f, v4_scale(v4_sub(film, f), p->iridescence));
#else
    return f;
#endif
}

/* The chance that the interface reflects at cosine cos_h (signed as
 * bsdf_fresnel_dielectric takes it): the mean of the path's wavelengths'
 * Fresnel reflectances, the hero's alone without dispersion or film. With a
 * dispersive index the hero's may be near 0 (n near 1) where another's is not,
 * and reflection's weight F_i / F_hero would be huge or, at F_hero = 0, that
 * light lost (docs/gltf.md, KHR_materials_dispersion); a film's reflectance
 * differs between wavelengths too. */
SPT_FN float bsdf_interface_q(const BsdfParams *p, float cos_h)
{
    if (bsdf_has_film(p)) {
        vec4 f = bsdf_interface_film(p, cos_h);
        return 0.25f * (f.x + f.y + f.z + f.w);
    }
    float f = bsdf_fresnel_dielectric(cos_h, p->ior.x);
    if (p->ior.x == p->ior.y && p->ior.x == p->ior.z && p->ior.x == p->ior.w)
        return f;
    return 0.25f * (f + bsdf_fresnel_dielectric(cos_h, p->ior.y) + bsdf_fresnel_dielectric(cos_h, p->ior.z) +
                    bsdf_fresnel_dielectric(cos_h, p->ior.w));
}

/* The rough dielectric interface's f |cos i| contribution and its pdf for the
 * given wo, wi (Walter et al. 2007 eqs. 20-21 with VNDF sampling; pdf per
 * steradian of wi), for index eta (hero wavelength's value) and alpha. Fresnel is
 * the exact dielectric one, or under pf's film (pf non-zero with iridescence)
 * its wavelength wl's bsdf_interface_film; transmission is divided by eta'^2
 * (radiance). The pdf reflects with the chance bsdf_interface_q(pq) or, pq 0,
 * with the F used. */
SPT_FN float bsdf_interface_eval_q(vec3 wo, vec3 wi, float eta, float alpha, const BsdfParams *pq, float *pdf,
                                   const BsdfParams *pf, int wl)
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
    if (pf && pf->iridescence > 0.0f) {
        vec4 ff = bsdf_interface_film(pf, dwo);
        F = wl == 0 ? ff.x : wl == 1 ? ff.y : wl == 2 ? ff.z : ff.w;
    }
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

/* The lobe's unnormalised selection weight: (1 - m) t, from either side. */
SPT_FN float bsdf_transmission_weight(const BsdfParams *p)
{
    return (1.0f - bsdf_metallic(p)) * bsdf_transmission(p);
}

/* Adds the rough interface's f |cos theta_i| at each wavelength's ior, times
 * (1 - m) t, the refraction tinted by the base colour, to *f; nothing when
 * smooth (delta) or without weight. */
SPT_FN void bsdf_transmission_eval(const BsdfParams *p, vec3 wo, vec3 wi, vec4 *f)
{
    float wt = bsdf_transmission_weight(p);
    if (!(wt > 0.0f) || bsdf_base_smooth(p))
        return;
    float alpha = bsdf_alpha(p->roughness);
    float pd;
    vec4 fi = v4(bsdf_interface_eval_q(wo, wi, p->ior.x, alpha, 0, &pd, p, 0),
                 bsdf_interface_eval_q(wo, wi, p->ior.y, alpha, 0, &pd, p, 1),
                 bsdf_interface_eval_q(wo, wi, p->ior.z, alpha, 0, &pd, p, 2),
                 bsdf_interface_eval_q(wo, wi, p->ior.w, alpha, 0, &pd, p, 3));
    /* KHR_materials_transmission tints the transmitted light by the base colour. */
    if (wo.z * wi.z < 0.0f)
        fi = v4_mul(fi, p->base);
    *f = v4_add(*f, v4_scale(fi, wt));
}

/* The rough interface's share of the material's pdf, at the hero wavelength's
 * ior, reflecting with the chance bsdf_interface_q. */
SPT_FN float bsdf_transmission_pdf(const BsdfParams *p, vec3 wo, vec3 wi, float prob)
{
    if (!(prob > 0.0f) || bsdf_base_smooth(p))
        return 0.0f;
    float pi_;
    bsdf_interface_eval_q(wo, wi, p->ior.x, bsdf_alpha(p->roughness), p, &pi_, 0, 0);
    return prob * pi_;
}

/* Reflects (with the chance q of bsdf_interface_q, from ur) or refracts about
 * the smooth normal or a visible microfacet normal (u1, u2), at the hero
 * wavelength's ior. Smooth: the whole delta sample (BSDF_SAMPLED_DELTA), its
 * weight before the layers over the base; rough: wi (BSDF_SAMPLED_WI). A
 * refraction at a wavelength-dependent ior sets dispersive. */
SPT_FN int bsdf_transmission_sample(const BsdfParams *p, vec3 wo, float ur, float u1, float u2, float prob,
                                    BsdfSample *s)
{
    int smooth = bsdf_base_smooth(p);
    float alpha = bsdf_alpha(p->roughness);
    int dispersive_ior = p->ior.x != p->ior.y || p->ior.x != p->ior.z || p->ior.x != p->ior.w;
    float eta = p->ior.x;
    float wt = bsdf_transmission_weight(p);
    vec3 wo_up = wo.z > 0.0f ? wo : v3_scale(wo, -1.0f);
    vec3 h = smooth ? v3(0.0f, 0.0f, 1.0f) : bsdf_ggx_sample_vndf(wo_up, alpha, u1, u2);
    float cos_h = wo.z > 0.0f ? v3_dot(wo, h) : -v3_dot(wo_up, h);
    float F = bsdf_fresnel_dielectric(cos_h, eta);
    /* Reflection with the chance q of bsdf_interface_q (bsdf_pdf's too). */
    float q = bsdf_interface_q(p, cos_h);
    int reflect = ur < q;
    /* A hero of index 1 (docs/gltf.md: the clamp of a dispersive index)
     * meets no interface: it passes straight through, smooth or rough (the
     * rough refraction's half vector wo + wi would be 0). */
    if (eta == 1.0f && !reflect) {
        s->wi = v3_scale(wo, -1.0f);
        s->dispersive = dispersive_ior;
        s->is_delta = 1;
        s->valid = 1;
        s->pdf = prob * (1.0f - q);
        /* A film there still reflects: the rest, 1 - F, passes. */
        vec4 t = bsdf_has_film(p) ? v4_sub(v4_splat(1.0f), bsdf_interface_film(p, cos_h)) : v4_splat(1.0f);
        s->weight = v4_scale(v4_mul(p->base, t), wt / s->pdf);
        return BSDF_SAMPLED_DELTA;
    }
    if (reflect) {
        s->wi = bsdf_reflect(wo, wo.z > 0.0f ? h : v3_scale(h, -1.0f));
    } else {
        float etap = wo.z > 0.0f ? eta : 1.0f / eta;
        vec3 n = wo.z > 0.0f ? h : v3_scale(h, -1.0f);
        if (!bsdf_refract(wo, n, etap, &s->wi))
            return BSDF_SAMPLED_NONE;
        s->dispersive = dispersive_ior;
    }
    /* A microfacet reflection that leaves through the surface (or a refraction
     * that stays on wo's side) is not an event of this lobe. */
    if ((s->wi.z * wo.z > 0.0f) != (reflect != 0))
        return BSDF_SAMPLED_NONE;
    if (!smooth)
        return BSDF_SAMPLED_WI;
    s->is_delta = 1;
    s->valid = 1;
    s->pdf = prob * (reflect ? q : 1.0f - q);
    if (bsdf_has_film(p)) {
        /* Each wavelength's film: F or 1 - F over the chance of the event. */
        vec4 fr = bsdf_interface_film(p, cos_h);
        float etap = reflect ? 1.0f : wo.z > 0.0f ? eta : 1.0f / eta;
        vec4 e = reflect ? fr : v4_mul(p->base, v4_sub(v4_splat(1.0f), fr));
        s->weight = v4_scale(e, wt / (s->pdf * etap * etap));
    } else if (reflect) {
        /* Each wavelength's F over the chance q of reflecting. */
        vec4 fr = v4_splat(F);
        if (dispersive_ior)
            fr = v4(F, bsdf_fresnel_dielectric(cos_h, p->ior.y), bsdf_fresnel_dielectric(cos_h, p->ior.z),
                    bsdf_fresnel_dielectric(cos_h, p->ior.w));
        s->weight = v4_scale(fr, wt / s->pdf);
    } else {
        float etap = wo.z > 0.0f ? eta : 1.0f / eta;
        s->weight = v4_scale(p->base, wt * (1.0f - F) / (s->pdf * etap * etap));
    }
    return BSDF_SAMPLED_DELTA;
}

#endif
