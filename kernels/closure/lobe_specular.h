/* The specular reflection lobe of the glTF material: one GGX microfacet lobe
 * (glTF 2.0 Appendix B: Trowbridge-Reitz D, Smith height-correlated G2) whose
 * Fresnel mixes the metal's (Schlick with F0 = base, or a measured conductor's
 * exact complex Fresnel) and the dielectric's specular layer
 * (bsdf_dielectric_fresnel) by metallic; a mirror (delta lobe) below
 * BSDF_DELTA_ALPHA. With KHR_materials_anisotropy the lobe is the anisotropic
 * GGX (bsdf_aniso_alphas) about the anisotropy direction p->aniso_t, and never
 * a mirror. Weight, f |cos|, pdf and sampling side by side;
 * kernels/closure/bsdf.h composes the lobes. */
#ifndef SPT_LOBE_SPECULAR_H
#define SPT_LOBE_SPECULAR_H

#include "util/portable.h"
#include "util/vecmath.h"
#include "closure/bsdf_params.h"
#include "closure/bsdf_microfacet.h"

/* Fresnel of the metal part at cosine c between wo and h, per wavelength: Schlick
 * with F0 = base (glTF conductor_fresnel), or exact with eta + i k; mixed with
 * the iridescence film's reflectance over the metal (bsdf_film_mix), whose
 * index is eta + i k where measured, else the real index of F0 = base (the
 * extension's rule). */
SPT_FN vec4 bsdf_metal_fresnel(const BsdfParams *p, float c)
{
    vec4 f;
    if (p->conductor)
        f = v4(bsdf_fresnel_conductor(c, p->eta.x, p->k.x), bsdf_fresnel_conductor(c, p->eta.y, p->k.y),
               bsdf_fresnel_conductor(c, p->eta.z, p->k.z), bsdf_fresnel_conductor(c, p->eta.w, p->k.w));
    else
        f = bsdf_schlick(p->base, c);
    if (!(p->iridescence > 0.0f))
        return f;
    if (p->conductor)
        return bsdf_film_mix(p, f, c, p->eta, p->k, 1.0f);
    vec4 n = v4(spt_film_ior_from_f0(p->base.x, 1.0f), spt_film_ior_from_f0(p->base.y, 1.0f),
                spt_film_ior_from_f0(p->base.z, 1.0f), spt_film_ior_from_f0(p->base.w, 1.0f));
    return bsdf_film_mix(p, f, c, n, v4_splat(0.0f), 1.0f);
}

/* The reflection Fresnel weight of the specular layer per wavelength at cosine c
 * (wo.h): m F_metal + (1-m)(1-t) F_dielectric (bsdf_dielectric_fresnel). */
SPT_FN vec4 bsdf_spec_fresnel(const BsdfParams *p, float c)
{
    float m = bsdf_metallic(p);
    float t = bsdf_transmission(p);
    vec4 fd = bsdf_dielectric_fresnel(p, c);
    return v4_add(v4_scale(bsdf_metal_fresnel(p, c), m), v4_scale(fd, (1.0f - m) * (1.0f - t)));
}

/* The lobe's unnormalised selection weight at wo: m + (1-m)(1-t) F, F estimated
 * at wo (bsdf_dielectric_fresnel_mean); 0 from inside. */
SPT_FN float bsdf_specular_weight(const BsdfParams *p, vec3 wo)
{
    if (wo.z <= 0.0f)
        return 0.0f;
    float m = bsdf_metallic(p);
    float t = bsdf_transmission(p);
    float fd = bsdf_dielectric_fresnel_mean(p, wo);
    return m + (1.0f - m) * (1.0f - t) * fd;
}

/* w in the anisotropy's frame (x along p->aniso_t, z the normal), and back. */
SPT_FN vec3 bsdf_to_aniso(const BsdfParams *p, vec3 w)
{
    float c = p->aniso_t.x, s = p->aniso_t.y;
    return v3(c * w.x + s * w.y, c * w.y - s * w.x, w.z);
}

SPT_FN vec3 bsdf_from_aniso(const BsdfParams *p, vec3 w)
{
    float c = p->aniso_t.x, s = p->aniso_t.y;
    return v3(c * w.x - s * w.y, s * w.x + c * w.y, w.z);
}

/* The anisotropic lobe's D G2 / (4 wo.z) (f |cos| without Fresnel) and, in
 * *pdf, its visible-normal density of h over 4 wo.h, h the unit half vector. */
SPT_FN float bsdf_specular_aniso(const BsdfParams *p, vec3 wo, vec3 wi, vec3 h, float *pdf)
{
    float ax, ay;
    bsdf_aniso_alphas(p->roughness, p->aniso, &ax, &ay);
    vec3 wo_a = bsdf_to_aniso(p, wo), wi_a = bsdf_to_aniso(p, wi), h_a = bsdf_to_aniso(p, h);
    *pdf = bsdf_ggx_vndf_pdf_aniso(wo_a, h_a, ax, ay) / (4.0f * v3_dot(wo, h));
    return bsdf_ggx_d_aniso(h_a, ax, ay) * bsdf_ggx_g2_aniso(wo_a, wi_a, ax, ay) / (4.0f * wo.z);
}

/* Adds the rough lobe's f |cos theta_i| = F D G2 / (4 wo.z) to *f, both
 * directions outside; nothing when the lobe is a mirror or has no weight (a
 * pure Lambertian). */
SPT_FN void bsdf_specular_eval(const BsdfParams *p, vec3 wo, vec3 wi, vec4 *f)
{
    float m = bsdf_metallic(p);
    float t = bsdf_transmission(p);
    if (!(wo.z > 0.0f && wi.z > 0.0f) || bsdf_specular_smooth(p) ||
        !(m > 0.0f || (p->specular > 0.0f && t < 1.0f)))
        return;
    vec3 h = v3_normalize(v3_add(wo, wi));
    float c = fabsf(v3_dot(wo, h));
    float spec, pd;
    if (bsdf_has_aniso(p)) {
        spec = bsdf_specular_aniso(p, wo, wi, h, &pd);
    } else {
        float alpha = bsdf_alpha(p->roughness);
        spec = bsdf_ggx_d(h, alpha) * bsdf_ggx_g2(wo, wi, alpha) / (4.0f * wo.z);
    }
    *f = v4_add(*f, v4_scale(bsdf_spec_fresnel(p, c), spec));
}

/* The rough lobe's share of the material's pdf: prob times the visible-normal
 * density of h over 4 wo.h (the reflection's Jacobian). */
SPT_FN float bsdf_specular_pdf(const BsdfParams *p, vec3 wo, vec3 wi, float prob)
{
    if (!(wo.z > 0.0f && wi.z > 0.0f) || !(prob > 0.0f) || bsdf_specular_smooth(p))
        return 0.0f;
    vec3 h = v3_normalize(v3_add(wo, wi));
    if (bsdf_has_aniso(p)) {
        float pd;
        bsdf_specular_aniso(p, wo, wi, h, &pd);
        return prob * pd;
    }
    float alpha = bsdf_alpha(p->roughness);
    return prob * bsdf_ggx_vndf_pdf(wo, h, alpha) / (4.0f * v3_dot(wo, h));
}

/* The mirror: the whole delta sample, weight F(wo.z) / prob
 * (BSDF_SAMPLED_DELTA). Rough: wi reflected about a visible normal
 * (BSDF_SAMPLED_WI), none when it goes into the surface (the lobe's pdf counts
 * only wi above). */
SPT_FN int bsdf_specular_sample(const BsdfParams *p, vec3 wo, float u1, float u2, float prob, BsdfSample *s)
{
    if (wo.z <= 0.0f)
        return BSDF_SAMPLED_NONE;
    if (bsdf_specular_smooth(p)) {
        s->wi = v3(-wo.x, -wo.y, wo.z);
        s->is_delta = 1;
        s->valid = 1;
        s->pdf = prob;
        s->weight = v4_scale(bsdf_spec_fresnel(p, wo.z), 1.0f / prob);
        return BSDF_SAMPLED_DELTA;
    }
    vec3 h;
    if (bsdf_has_aniso(p)) {
        float ax, ay;
        bsdf_aniso_alphas(p->roughness, p->aniso, &ax, &ay);
        h = bsdf_from_aniso(p, bsdf_ggx_sample_vndf_aniso(bsdf_to_aniso(p, wo), ax, ay, u1, u2));
    } else {
        h = bsdf_ggx_sample_vndf(wo, bsdf_alpha(p->roughness), u1, u2);
    }
    s->wi = bsdf_reflect(wo, h);
    return s->wi.z > 0.0f ? BSDF_SAMPLED_WI : BSDF_SAMPLED_NONE;
}

#endif
