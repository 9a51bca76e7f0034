/* The diffuse transmission lobe of the glTF material (KHR_materials_diffuse_transmission):
 * the extension replaces the dielectric's Lambertian base by
 * mix(diffuse_brdf(base), diffuse_btdf(colour), factor), so this lobe is the
 * Lambertian transmission share, weighted (1 - m)(1 - t)(1 - F) factor colour,
 * and the diffuse lobe (closure/lobe_diffuse.h) keeps 1 - factor of its own.
 * F is the dielectric specular layer's Fresnel at the half vector of wo and wi
 * mirrored to wo's side (the reflection the transmitted light did not take),
 * so a white base and colour with factor f split exactly what the diffuse lobe
 * alone would reflect: 1 - f of it reflected, f transmitted. It sends light
 * to the side opposite wo, from either side (docs/gltf.md). Weight, f |cos|,
 * pdf and sampling side by side; kernels/closure/bsdf.h composes the lobes. */
#ifndef SPT_LOBE_DIFFUSE_TRANSMISSION_H
#define SPT_LOBE_DIFFUSE_TRANSMISSION_H

#include "util/portable.h"
#include "util/vecmath.h"
#include "closure/bsdf_params.h"
#include "sample/sampling.h"

/* The lobe's unnormalised selection weight at wo: (1-m)(1-t)(1 - F) factor
 * times the colour's mean, F estimated at wo (bsdf_dielectric_fresnel_mean). */
SPT_FN float bsdf_dt_weight(const BsdfParams *p, vec3 wo)
{
    float dt = bsdf_dt(p);
    if (!(dt > 0.0f) || wo.z == 0.0f)
        return 0.0f;
    float m = bsdf_metallic(p);
    float t = bsdf_transmission(p);
    float fd = bsdf_dielectric_fresnel_mean(p, wo);
    vec4 c = p->dt_color;
    float mean = 0.25f * (c.x + c.y + c.z + c.w);
    return (1.0f - m) * (1.0f - t) * (1.0f - fd) * dt * fmaxf(mean, 0.0f);
}

/* Adds f |cos theta_i| = (1-m)(1-t)(1 - F) factor colour |wi.z| / pi to *f
 * for wo and wi on opposite sides. */
SPT_FN void bsdf_dt_eval(const BsdfParams *p, vec3 wo, vec3 wi, vec4 *f)
{
    float dt = bsdf_dt(p);
    if (!(dt > 0.0f) || !(wo.z * wi.z < 0.0f))
        return;
    float m = bsdf_metallic(p);
    float t = bsdf_transmission(p);
    vec3 h = v3_normalize(v3_add(wo, v3(wi.x, wi.y, -wi.z)));
    float c = fabsf(v3_dot(wo, h));
    vec4 one_minus = v4_sub(v4_splat(1.0f), bsdf_dielectric_fresnel(p, c));
    vec4 k = v4_scale(v4_mul(one_minus, p->dt_color), (1.0f - m) * (1.0f - t) * dt);
    *f = v4_add(*f, v4_scale(k, SPT_INV_PI * fabsf(wi.z)));
}

/* The lobe's share prob x |cos| / pi of the material's pdf. */
SPT_FN float bsdf_dt_pdf(vec3 wo, vec3 wi, float prob)
{
    if (!(prob > 0.0f) || !(wo.z * wi.z < 0.0f))
        return 0.0f;
    return prob * fabsf(wi.z) * SPT_INV_PI;
}

/* A cosine-distributed wi on the side opposite wo (BSDF_SAMPLED_WI). */
SPT_FN int bsdf_dt_sample(vec3 wo, float u1, float u2, BsdfSample *s)
{
    if (wo.z == 0.0f)
        return BSDF_SAMPLED_NONE;
    vec3 w = spt_sample_cosine_hemisphere(u1, u2);
    s->wi = wo.z > 0.0f ? v3(w.x, w.y, -w.z) : w;
    return BSDF_SAMPLED_WI;
}

#endif
