/* The KHR_materials_clearcoat and KHR_materials_sheen layers of
 * kernels/closure/bsdf.h (which includes this after BsdfParams and the GGX
 * distribution of kernels/closure/bsdf_microfacet.h): the coat's lobe about its
 * own normal and its Fresnel weight, the sheen's "Charlie" lobe with its
 * tabulated albedo, and how the layers scale what is under them. */
#ifndef SPT_BSDF_LAYERS_H
#define SPT_BSDF_LAYERS_H

#include "util/portable.h"
#include "closure/delta.h"

/* ---- KHR_materials_clearcoat and KHR_materials_sheen layers --------------------- */

SPT_FN int bsdf_has_coat(const BsdfParams *p) { return p->clearcoat > 0.0f; }
SPT_FN int bsdf_has_sheen(const BsdfParams *p) { return p->sheen_max > 0.0f; }

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
 * get 1 minus that. */
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
SPT_FN float bsdf_coat_eval(const BsdfParams *p, vec3 wo, vec3 wi, float *pdf)
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

/* The sheen lobe with colour 1, f |cos theta_i| = D V mu_i / max(1, eo, ei)
 * (eo, ei: E at wo and wi), for wo and wi above the surface. */
SPT_FN float bsdf_sheen_eval(const BsdfParams *p, vec3 wo, vec3 wi, float eo, float ei)
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

/* What the base's light is scaled by where it passes the layers, per wavelength:
 * (1 - coat weight) (1 - s max(E(mu_o), E(mu_i)) capped at 1), with the coat
 * weight and the E of the directions outside the surface only (a ray crossing a
 * transmissive base meets the layers once), s the larger of max3(sheen colour)
 * and the sheen's value at the wavelength (so that no wavelength gains energy
 * where the upsampled spectrum peaks above the colour's largest component).
 * *eo, *ei: E at wo and wi (0 below the surface or without sheen). */
SPT_FN vec4 bsdf_layer_scale(const BsdfParams *p, vec3 wo, vec3 wi, float *eo, float *ei)
{
    int up_o = wo.z > 0.0f, up_i = wi.z > 0.0f;
    *eo = 0.0f;
    *ei = 0.0f;
    if (!up_o && !up_i)
        return v4_splat(1.0f);
    float wc = bsdf_coat_weight(p, up_o ? wo : wi);
    if (!bsdf_has_sheen(p))
        return v4_splat(1.0f - wc);
    float r = bsdf_sheen_r(p);
    if (up_o)
        *eo = bsdf_sheen_albedo(wo.z, r);
    if (up_i)
        *ei = bsdf_sheen_albedo(wi.z, r);
    float e = fminf(1.0f, fmaxf(*eo, *ei));
    vec4 s = v4(fmaxf(p->sheen.x, p->sheen_max), fmaxf(p->sheen.y, p->sheen_max),
                fmaxf(p->sheen.z, p->sheen_max), fmaxf(p->sheen.w, p->sheen_max));
    return v4_scale(v4_sub(v4_splat(1.0f), v4_scale(s, e)), 1.0f - wc);
}

/* The layered material's f |cos| from the base's value r at (wo, wi): the base
 * scaled by bsdf_layer_scale, plus the sheen lobe (under the coat) and the rough
 * coat lobe when both directions are outside. */
SPT_FN vec4 bsdf_layers_eval(const BsdfParams *p, vec3 wo, vec3 wi, vec4 r)
{
    float eo, ei;
    r = v4_mul(r, bsdf_layer_scale(p, wo, wi, &eo, &ei));
    if (!(wo.z > 0.0f && wi.z > 0.0f))
        return r;
    float wc = bsdf_coat_weight(p, wo);
    if (bsdf_has_sheen(p))
        r = v4_add(r, v4_scale(p->sheen, (1.0f - wc) * bsdf_sheen_eval(p, wo, wi, eo, ei)));
    if (wc > 0.0f && !bsdf_coat_smooth(p)) {
        float pd;
        r = v4_add(r, v4_splat(wc * bsdf_coat_eval(p, wo, wi, &pd)));
    }
    return r;
}

#endif
