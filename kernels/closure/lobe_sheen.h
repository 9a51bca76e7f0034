/* The sheen lobe (KHR_materials_sheen) as its specification defines it: the
 * "Charlie" lobe (Estevez and Kulla 2017, "Production Friendly Microfacet Sheen
 * BRDF": distribution sin(theta_h)^(1/alpha), the specification's fitted
 * visibility, F = 1) in the sheen colour, sampled uniformly over the
 * hemisphere. E, the lobe's directional albedo (kernels/closure/sheen_table.h),
 * scales the base under it (kernels/closure/bsdf.h, bsdf_layer_scale). Where E
 * exceeds 1 (sheen roughness below about 0.26, grazing angles) the lobe would
 * create energy; it is divided by max(1, E(mu_o), E(mu_i)) there and E is
 * capped at 1 in the scaling, so albedo sheen + base never exceeds 1. Weight,
 * f |cos|, pdf and sampling side by side. */
#ifndef SPT_LOBE_SHEEN_H
#define SPT_LOBE_SHEEN_H

#include "util/portable.h"
#include "util/vecmath.h"
#include "closure/bsdf_params.h"
#include "closure/sheen_table.h"
#include "sample/sampling.h"

/* The sheen roughness the lobe uses: within [SPT_SHEEN_R_MIN, 1]. */
SPT_FN float bsdf_sheen_r(const BsdfParams *p)
{
    return fminf(fmaxf(p->sheen_roughness, SPT_SHEEN_R_MIN), 1.0f);
}

/* E(mu, r) of kernels/closure/sheen_table.h: bilinear in (sqrt(mu), r). */
SPT_FN float bsdf_sheen_albedo(float mu, float r)
{
    const float last = (float)(SPT_SHEEN_N - 1);
    float x = sqrtf(fminf(fmaxf(mu, 0.0f), 1.0f)) * last;
    float y = fminf(fmaxf((r - SPT_SHEEN_R_MIN) / (1.0f - SPT_SHEEN_R_MIN), 0.0f), 1.0f) * last;
    int i = (int)fminf(x, last - 1.0f), j = (int)fminf(y, last - 1.0f);
    float fx = x - (float)i, fy = y - (float)j;
    int k = j * SPT_SHEEN_N + i;
    float a = spt_sheen_albedo[k] + fx * (spt_sheen_albedo[k + 1] - spt_sheen_albedo[k]);
    float b = spt_sheen_albedo[k + SPT_SHEEN_N] +
              fx * (spt_sheen_albedo[k + SPT_SHEEN_N + 1] - spt_sheen_albedo[k + SPT_SHEEN_N]);
    return a + fy * (b - a);
}

/* The specification's fit l(x) of the Charlie visibility, its two rows
 * interpolated by t = (1 - alpha)^2, and Lambda(mu) from it. */
SPT_FN float bsdf_sheen_l(float x, float alpha)
{
    float t = (1.0f - alpha) * (1.0f - alpha);
    float a = 21.5473f + t * (25.3245f - 21.5473f);
    float b = 3.82987f + t * (3.32435f - 3.82987f);
    float c = 0.19823f + t * (0.16801f - 0.19823f);
    float d = -1.97760f + t * (-1.27393f + 1.97760f);
    float e = -4.32054f + t * (-4.85967f + 4.32054f);
    return a / (1.0f + b * powf(x, c)) + d * x + e;
}

SPT_FN float bsdf_sheen_lambda(float mu, float alpha)
{
    return mu < 0.5f ? expf(bsdf_sheen_l(mu, alpha))
                     : expf(2.0f * bsdf_sheen_l(0.5f, alpha) - bsdf_sheen_l(1.0f - mu, alpha));
}

/* E at wo capped at 1 (0 without sheen): with max3 of the colour, the share
 * of light the sheen takes from what reaches it, as the lobe selection
 * estimates it. */
SPT_FN float bsdf_sheen_e(const BsdfParams *p, vec3 wo)
{
    return bsdf_has_sheen(p) ? fminf(1.0f, bsdf_sheen_albedo(wo.z, bsdf_sheen_r(p))) : 0.0f;
}

/* The lobe with colour 1, f |cos theta_i| = D V mu_i / max(1, eo, ei)
 * (eo, ei: E at wo and wi), for wo and wi above the surface. */
SPT_FN float bsdf_sheen_lobe(const BsdfParams *p, vec3 wo, vec3 wi, float eo, float ei)
{
    if (wo.z <= 0.0f || wi.z <= 0.0f)
        return 0.0f;
    float r = bsdf_sheen_r(p), alpha = r * r;
    vec3 h = v3_normalize(v3_add(wo, wi));
    float s2 = fmaxf(1.0f - h.z * h.z, 0.0f);
    float D = (2.0f + 1.0f / alpha) * powf(s2, 0.5f / alpha) * SPT_INV_2PI;
    float g = 1.0f + bsdf_sheen_lambda(wo.z, alpha) + bsdf_sheen_lambda(wi.z, alpha);
    return D / (g * 4.0f * wo.z * fmaxf(1.0f, fmaxf(eo, ei)));
}

/* Adds the sheen colour times over (what the layers above let through) times
 * the lobe to *f, both directions outside. */
SPT_FN void bsdf_sheen_eval(const BsdfParams *p, vec3 wo, vec3 wi, float over, vec4 *f)
{
    if (!bsdf_has_sheen(p) || !(wo.z > 0.0f && wi.z > 0.0f))
        return;
    float r = bsdf_sheen_r(p);
    float eo = bsdf_sheen_albedo(wo.z, r), ei = bsdf_sheen_albedo(wi.z, r);
    *f = v4_add(*f, v4_scale(p->sheen, over * bsdf_sheen_lobe(p, wo, wi, eo, ei)));
}

/* The lobe's share prob / (2 pi) of the material's pdf, both directions outside. */
SPT_FN float bsdf_sheen_pdf(vec3 wo, vec3 wi, float prob)
{
    if (!(wo.z > 0.0f && wi.z > 0.0f) || !(prob > 0.0f))
        return 0.0f;
    return prob * spt_pdf_uniform_hemisphere(wi.z);
}

/* wi uniform over the hemisphere (BSDF_SAMPLED_WI): the lobe is broad and
 * peaks toward grazing directions, where a cosine density is thin. */
SPT_FN int bsdf_sheen_sample(vec3 wo, float u1, float u2, BsdfSample *s)
{
    if (wo.z <= 0.0f)
        return BSDF_SAMPLED_NONE;
    s->wi = spt_sample_uniform_hemisphere(u1, u2);
    return BSDF_SAMPLED_WI;
}

#endif
