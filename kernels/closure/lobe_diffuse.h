/* The diffuse lobe of the glTF material: Lambert's base under the dielectric's
 * specular layer, weighted (1 - m)(1 - t)(1 - F) base (glTF fresnel_mix;
 * docs/gltf.md), sampled with the cosine density. Its weight, f |cos|, pdf and
 * sampling side by side (the interface every lobe of kernels/closure/ has;
 * kernels/closure/bsdf.h composes them). */
#ifndef SPT_LOBE_DIFFUSE_H
#define SPT_LOBE_DIFFUSE_H

#include "util/portable.h"
#include "util/vecmath.h"
#include "closure/bsdf_params.h"
#include "sample/sampling.h"

/* The diffuse lobe's factor per wavelength, without 1/pi: (1-m)(1-t)(1 - F_dielectric)
 * base (glTF fresnel_mix), times 1 - the diffuse transmission factor (which
 * closure/lobe_diffuse_transmission.h takes; 1 - 0 is exact, so the floats of a
 * material without it are unchanged). */
SPT_FN vec4 bsdf_diffuse_factor(const BsdfParams *p, float c)
{
    float m = bsdf_metallic(p);
    float t = bsdf_transmission(p);
    vec4 one_minus = v4_sub(v4_splat(1.0f), bsdf_dielectric_fresnel(p, c));
    return v4_scale(v4_mul(one_minus, p->base), (1.0f - m) * (1.0f - t) * (1.0f - bsdf_dt(p)));
}

/* The lobe's unnormalised selection weight at wo: (1-m)(1-t)(1 - F)(1 - dt) times the
 * base's mean, F estimated at wo (bsdf_dielectric_fresnel_mean); 0 from inside. */
SPT_FN float bsdf_diffuse_weight(const BsdfParams *p, vec3 wo)
{
    if (wo.z <= 0.0f)
        return 0.0f;
    float m = bsdf_metallic(p);
    float t = bsdf_transmission(p);
    float fd = bsdf_dielectric_fresnel_mean(p, wo);
    float mean_base = 0.25f * (p->base.x + p->base.y + p->base.z + p->base.w);
    return (1.0f - m) * (1.0f - t) * (1.0f - fd) * fmaxf(mean_base, 0.0f) * (1.0f - bsdf_dt(p));
}

/* Adds f |cos theta_i| to *f: the factor at the half vector's cosine to wo,
 * times cos / pi; both directions outside. Under an iridescence film the
 * factor is taken at wo's own cosine (as the Khronos sample viewer evaluates
 * the film, at N.V): the film's reflectance oscillates with the angle, and
 * 1 - F at other cosines than the mirror's would return more light than
 * arrives where F peaks at wo (docs/gltf.md). */
SPT_FN void bsdf_diffuse_eval(const BsdfParams *p, vec3 wo, vec3 wi, vec4 *f)
{
    if (!(wo.z > 0.0f && wi.z > 0.0f))
        return;
    vec3 h = v3_normalize(v3_add(wo, wi));
    float c = p->iridescence > 0.0f ? wo.z : fabsf(v3_dot(wo, h));
    *f = v4_add(*f, v4_scale(bsdf_diffuse_factor(p, c), SPT_INV_PI * wi.z));
}

/* The lobe's share prob x cos / pi of the material's pdf. */
SPT_FN float bsdf_diffuse_pdf(vec3 wo, vec3 wi, float prob)
{
    if (!(wo.z > 0.0f && wi.z > 0.0f))
        return 0.0f;
    return prob * wi.z * SPT_INV_PI;
}

/* A cosine-distributed wi (BSDF_SAMPLED_WI), none from inside. */
SPT_FN int bsdf_diffuse_sample(vec3 wo, float u1, float u2, BsdfSample *s)
{
    if (wo.z <= 0.0f)
        return BSDF_SAMPLED_NONE;
    s->wi = spt_sample_cosine_hemisphere(u1, u2);
    return BSDF_SAMPLED_WI;
}

#endif
