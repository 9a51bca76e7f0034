/* The clearcoat lobe (KHR_materials_clearcoat): a second GGX lobe (glTF's
 * specular term without Fresnel, alpha = clearcoatRoughness^2) about the
 * coat's own normal, weighted clearcoat Fc, Fc Schlick's Fresnel at ior 1.5 of
 * the view's cosine to the coat normal (fresnel_coat); a mirror (delta lobe)
 * below BSDF_DELTA_ALPHA. The coat is the top layer: kernels/closure/bsdf.h
 * scales the layers under it by 1 - clearcoat Fc. Weight, f |cos|, pdf and
 * sampling side by side. */
#ifndef SPT_LOBE_COAT_H
#define SPT_LOBE_COAT_H

#include "util/portable.h"
#include "util/vecmath.h"
#include "closure/bsdf_params.h"
#include "closure/delta.h"
#include "closure/bsdf_microfacet.h"

/* Whether the coat is a mirror (a delta lobe). */
SPT_FN int bsdf_coat_smooth(const BsdfParams *p)
{
    return bsdf_roughness_is_delta(p->cc_roughness);
}

/* The coat's Fresnel at cosine c between the view and the coat normal: Schlick at
 * ior 1.5, f0 = ((1.5 - 1) / (1.5 + 1))^2 = 0.04 (the extension's fresnel_coat). */
SPT_FN float bsdf_coat_fresnel(float c)
{
    float m = fminf(fmaxf(1.0f - c, 0.0f), 1.0f);
    return 0.04f + 0.96f * (m * m * m * m * m);
}

/* The share the coat takes of light seen from outside direction w:
 * clearcoat Fc(w . n_c) (0 when w is below the coat normal); the layers under it
 * get 1 minus that. Also the lobe's unnormalised selection weight at wo. */
SPT_FN float bsdf_coat_weight(const BsdfParams *p, vec3 w)
{
    if (!bsdf_has_coat(p))
        return 0.0f;
    float c = v3_dot(w, p->cc_n);
    return c > 0.0f ? p->clearcoat * bsdf_coat_fresnel(c) : 0.0f;
}

/* w in the coat's frame (z along cc_n; the identity when cc_n is +z), and back. */
SPT_FN vec3 bsdf_to_coat(const BsdfParams *p, vec3 w)
{
    vec3 t, b;
    v3_basis(p->cc_n, &t, &b);
    return v3(v3_dot(w, t), v3_dot(w, b), v3_dot(w, p->cc_n));
}

SPT_FN vec3 bsdf_from_coat(const BsdfParams *p, vec3 w)
{
    vec3 t, b;
    v3_basis(p->cc_n, &t, &b);
    return v3_add(v3_add(v3_scale(t, w.x), v3_scale(b, w.y)), v3_scale(p->cc_n, w.z));
}

/* The rough coat lobe without its weight, f |cos| with both the BRDF's and the
 * cosine taken to the coat normal: D G2 / (4 (wo.n_c)) (glTF's specular term, F
 * left to the weight); *pdf: the density of sampling it (visible normals about
 * n_c). 0 unless wo and wi are both above the coat. */
SPT_FN float bsdf_coat_lobe(const BsdfParams *p, vec3 wo, vec3 wi, float *pdf)
{
    *pdf = 0.0f;
    vec3 o = bsdf_to_coat(p, wo), i = bsdf_to_coat(p, wi);
    if (o.z <= 0.0f || i.z <= 0.0f)
        return 0.0f;
    float alpha = bsdf_alpha(p->cc_roughness);
    vec3 h = v3_normalize(v3_add(o, i));
    float oh = v3_dot(o, h);
    if (!(oh > 0.0f))
        return 0.0f;
    *pdf = bsdf_ggx_vndf_pdf(o, h, alpha) / (4.0f * oh);
    return bsdf_ggx_d(h, alpha) * bsdf_ggx_g2(o, i, alpha) / (4.0f * o.z);
}

/* Adds the rough coat's clearcoat Fc(wo) f |cos| to *f, both directions
 * outside; nothing for a mirror coat (delta) or none. */
SPT_FN void bsdf_coat_eval(const BsdfParams *p, vec3 wo, vec3 wi, vec4 *f)
{
    if (!(wo.z > 0.0f && wi.z > 0.0f))
        return;
    float wc = bsdf_coat_weight(p, wo);
    if (wc > 0.0f && !bsdf_coat_smooth(p)) {
        float pd;
        *f = v4_add(*f, v4_splat(wc * bsdf_coat_lobe(p, wo, wi, &pd)));
    }
}

/* The rough coat's share of the material's pdf. */
SPT_FN float bsdf_coat_pdf(const BsdfParams *p, vec3 wo, vec3 wi, float prob)
{
    if (!(prob > 0.0f) || bsdf_coat_smooth(p))
        return 0.0f;
    float pcd;
    bsdf_coat_lobe(p, wo, wi, &pcd);
    return prob * pcd;
}

/* The mirror coat: the whole delta sample, weight clearcoat Fc(wo) / prob
 * (BSDF_SAMPLED_DELTA). Rough: wi reflected about a visible normal of the
 * coat (BSDF_SAMPLED_WI). None when wo or wi is below the coat or the surface. */
SPT_FN int bsdf_coat_sample(const BsdfParams *p, vec3 wo, float u1, float u2, float prob, BsdfSample *s)
{
    if (wo.z <= 0.0f)
        return BSDF_SAMPLED_NONE;
    if (bsdf_coat_smooth(p)) {
        s->wi = bsdf_reflect(wo, p->cc_n);
        if (!(s->wi.z > 0.0f))
            return BSDF_SAMPLED_NONE;
        s->is_delta = 1;
        s->valid = 1;
        s->pdf = prob;
        s->weight = v4_splat(bsdf_coat_weight(p, wo) / prob);
        return BSDF_SAMPLED_DELTA;
    }
    vec3 o = bsdf_to_coat(p, wo);
    if (!(o.z > 0.0f))
        return BSDF_SAMPLED_NONE;
    vec3 h = bsdf_ggx_sample_vndf(o, bsdf_alpha(p->cc_roughness), u1, u2);
    vec3 i = bsdf_reflect(o, h);
    if (!(i.z > 0.0f))
        return BSDF_SAMPLED_NONE;
    s->wi = bsdf_from_coat(p, i);
    return BSDF_SAMPLED_WI;
}

#endif
