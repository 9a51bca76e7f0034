/* The building blocks of the lobes of kernels/closure/: small helpers (alpha,
 * reflection, refraction, the dielectric and conductor Fresnel equations,
 * Schlick, the dispersion law, measured conductors) and the GGX microfacet
 * distribution, isotropic and anisotropic (Heitz 2014, "Understanding the
 * Masking-Shadowing Function", section 5.2), with visible-normal sampling
 * (Heitz 2018, "Sampling the GGX Distribution of Visible Normals", JCGT 7(4)). */
#ifndef SPT_BSDF_MICROFACET_H
#define SPT_BSDF_MICROFACET_H

#include "util/portable.h"
#include "util/vecmath.h"
#include "closure/bsdf_params.h"
#include "closure/conductors.h"

/* ---- Small helpers --------------------------------------------------------------- */

/* glTF alpha = roughness^2, clamped to BSDF_MIN_ALPHA from below. */
SPT_FN float bsdf_alpha(float roughness)
{
    return fmaxf(roughness * roughness, BSDF_MIN_ALPHA);
}

/* Mirror reflection of w about the unit normal n (both pointing away from the
 * surface): 2 (w.n) n - w. */
SPT_FN vec3 bsdf_reflect(vec3 w, vec3 n)
{
    return v3_sub(v3_scale(n, 2.0f * v3_dot(w, n)), w);
}

/* Refraction of w (pointing away from the surface, on the side n points to) through
 * an interface with relative index eta = n_transmitted / n_incident (Snell's law).
 * Returns 0 on total internal reflection, else 1 with *wt the unit refracted
 * direction on the other side. */
SPT_FN int bsdf_refract(vec3 w, vec3 n, float eta, vec3 *wt)
{
    float cos_i = v3_dot(w, n);
    float sin2_t = fmaxf(0.0f, 1.0f - cos_i * cos_i) / (eta * eta);
    if (sin2_t >= 1.0f)
        return 0;
    float cos_t = sqrtf(1.0f - sin2_t);
    *wt = v3_add(v3_scale(w, -1.0f / eta), v3_scale(n, cos_i / eta - cos_t));
    return 1;
}

/* Exact unpolarised Fresnel reflectance of a dielectric interface (Born and Wolf,
 * Principles of Optics, 1.5.2) for cos_i = cosine of the incident angle measured on
 * the incident side (negative: the ray comes from inside, the indices swap) and
 * eta = n_inside / n_outside. Returns 1 under total internal reflection. */
SPT_FN float bsdf_fresnel_dielectric(float cos_i, float eta)
{
    if (cos_i < 0.0f) {
        eta = 1.0f / eta;
        cos_i = -cos_i;
    }
    cos_i = fminf(cos_i, 1.0f);
    float sin2_t = (1.0f - cos_i * cos_i) / (eta * eta);
    if (sin2_t >= 1.0f)
        return 1.0f;
    float cos_t = sqrtf(1.0f - sin2_t);
    float rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    float rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    return 0.5f * (rs * rs + rp * rp);
}

/* Exact unpolarised Fresnel reflectance of a conductor of complex index eta + i k
 * (relative to the outside medium) at incidence cosine cos_i in [0, 1]; the closed
 * form of the complex Fresnel equations used by pbrt-v3 (FrConductor, after
 * Lazanyi and Szirmay-Kalos 2005). */
SPT_FN float bsdf_fresnel_conductor(float cos_i, float eta, float k)
{
    cos_i = fminf(fmaxf(cos_i, 0.0f), 1.0f);
    float c2 = cos_i * cos_i, s2 = 1.0f - c2;
    float e2 = eta * eta, k2 = k * k;
    float t0 = e2 - k2 - s2;
    float a2b2 = sqrtf(fmaxf(t0 * t0 + 4.0f * e2 * k2, 0.0f));
    float t1 = a2b2 + c2;
    float a = sqrtf(fmaxf(0.5f * (a2b2 + t0), 0.0f));
    float t2 = 2.0f * cos_i * a;
    float rs = (t1 - t2) / (t1 + t2);
    float t3 = c2 * a2b2 + s2 * s2;
    float t4 = t2 * s2;
    float rp = rs * (t3 - t4) / (t3 + t4);
    return 0.5f * (rp + rs);
}

/* Schlick's approximation f0 + (1 - f0)(1 - c)^5 per wavelength (glTF Appendix B). */
SPT_FN vec4 bsdf_schlick(vec4 f0, float c)
{
    float m = fminf(fmaxf(1.0f - c, 0.0f), 1.0f);
    float m5 = m * m * m * m * m;
    return v4_add(f0, v4_scale(v4_sub(v4_splat(1.0f), f0), m5));
}

/* The range every index of refraction is clamped to (docs/gltf.md,
 * KHR_materials_dispersion). Below 1 the dispersion law has left its domain (the
 * Cauchy fit is for glass; at dispersion 300, ior 1.5 it gives n = -4 at 830 nm,
 * where the Fresnel equations and the 1/eta^2 radiance scaling have no meaning);
 * 1 is the vacuum's index, an interface that does not bend or reflect. Above 1e4
 * an interface already reflects all but 4e-4 of normal light, and both eta^2 and
 * 1/eta^2 stay far inside float's range. */
#define BSDF_IOR_MIN 1.0f
#define BSDF_IOR_MAX 1e4f

/* Index of refraction at wavelength lambda_nm from KHR_materials_dispersion: the
 * extension stores dispersion = 20 / V_d (Abbe number V_d = (n_d - 1)/(n_F - n_C)
 * at the Fraunhofer d 587.56, F 486.13, C 656.27 nm lines) and defines
 *   n(lambda) = n_d + (n_d - 1) / V_d * (523655 / lambda^2 - 1.5168),
 * a two-term Cauchy law n = A + B / lambda^2 fitted through n_d with
 * B = (n_d - 1)/V_d / (1/lambda_F^2 - 1/lambda_C^2) (= 523655 nm^2 scaled). With
 * dispersion 0 the ior is constant. The result is clamped to [BSDF_IOR_MIN,
 * BSDF_IOR_MAX] (NaN, from an infinite dispersion times 0, gives 1). */
SPT_FN float bsdf_dispersion_ior(float ior, float dispersion, float lambda_nm)
{
    float n = ior;
    if (dispersion > 0.0f) {
        float inv_v = dispersion / 20.0f;
        n = ior + (ior - 1.0f) * inv_v * (523655.0f / (lambda_nm * lambda_nm) - 1.5168f);
    }
    return fminf(fmaxf(n, BSDF_IOR_MIN), BSDF_IOR_MAX);
}

/* Makes p's metal a measured conductor (SPT_CONDUCTOR_AU, _AG, _CU, _AL of
 * kernels/closure/conductors.h) at the path's wavelengths lambda_nm[0..3]: sets conductor,
 * eta and k. */
SPT_FN void bsdf_set_conductor(BsdfParams *p, int metal, float l0, float l1, float l2, float l3)
{
    p->conductor = 1;
    p->eta = v4(spt_conductor_lookup(metal, 0, l0), spt_conductor_lookup(metal, 0, l1),
                spt_conductor_lookup(metal, 0, l2), spt_conductor_lookup(metal, 0, l3));
    p->k = v4(spt_conductor_lookup(metal, 1, l0), spt_conductor_lookup(metal, 1, l1),
              spt_conductor_lookup(metal, 1, l2), spt_conductor_lookup(metal, 1, l3));
}

/* ---- GGX microfacet distribution (isotropic) ------------------------------------ */

/* GGX normal distribution D(h) (Walter et al. 2007, eq. 33) for unit h with h.z > 0. */
SPT_FN float bsdf_ggx_d(vec3 h, float alpha)
{
    if (h.z <= 0.0f)
        return 0.0f;
    float a2 = alpha * alpha;
    float t = h.z * h.z * (a2 - 1.0f) + 1.0f;
    return a2 / (SPT_PI * t * t);
}

/* Smith Lambda for GGX (Heitz 2014, eq. 72): (-1 + sqrt(1 + alpha^2 tan^2)) / 2. */
SPT_FN float bsdf_ggx_lambda(vec3 w, float alpha)
{
    float c2 = w.z * w.z;
    if (c2 <= 0.0f)
        return 1e30f;
    float t2 = fmaxf(1.0f - c2, 0.0f) / c2;
    return 0.5f * (-1.0f + sqrtf(1.0f + alpha * alpha * t2));
}

/* Smith masking G1(w) = 1 / (1 + Lambda(w)). */
SPT_FN float bsdf_ggx_g1(vec3 w, float alpha)
{
    return 1.0f / (1.0f + bsdf_ggx_lambda(w, alpha));
}

/* Height-correlated masking-shadowing G2 = 1 / (1 + Lambda(wo) + Lambda(wi)) (Heitz
 * 2014, eq. 99), the form glTF Appendix B uses. */
SPT_FN float bsdf_ggx_g2(vec3 wo, vec3 wi, float alpha)
{
    return 1.0f / (1.0f + bsdf_ggx_lambda(wo, alpha) + bsdf_ggx_lambda(wi, alpha));
}

/* Density of visible normals D_wo(h) = G1(wo) max(0, wo.h) D(h) / wo.z (Heitz 2018,
 * eq. 3), per steradian of h, for wo.z > 0. */
SPT_FN float bsdf_ggx_vndf_pdf(vec3 wo, vec3 h, float alpha)
{
    float c = v3_dot(wo, h);
    if (wo.z <= 0.0f || c <= 0.0f)
        return 0.0f;
    return bsdf_ggx_g1(wo, alpha) * c * bsdf_ggx_d(h, alpha) / wo.z;
}

/* ---- GGX microfacet distribution (anisotropic) ---------------------------------- */

/* KHR_materials_anisotropy's roughnesses for perceptual roughness r and
 * anisotropy strength s: alpha_t = mix(r^2, 1, s^2) along the anisotropy
 * direction (the local x axis of these functions), alpha_b = r^2 across it,
 * both clamped to BSDF_MIN_ALPHA from below. */
SPT_FN void bsdf_aniso_alphas(float roughness, float s, float *at, float *ab)
{
    float a = roughness * roughness;
    *at = fmaxf(a + (1.0f - a) * (s * s), BSDF_MIN_ALPHA);
    *ab = fmaxf(a, BSDF_MIN_ALPHA);
}

/* Anisotropic GGX D(h) = 1 / (pi ax ay ((h.x/ax)^2 + (h.y/ay)^2 + h.z^2)^2)
 * (Heitz 2014, eq. 85), for unit h with h.z > 0; ax along x, ay along y. */
SPT_FN float bsdf_ggx_d_aniso(vec3 h, float ax, float ay)
{
    if (h.z <= 0.0f)
        return 0.0f;
    float x = h.x / ax, y = h.y / ay;
    float t = x * x + y * y + h.z * h.z;
    return 1.0f / (SPT_PI * ax * ay * t * t);
}

/* Smith Lambda of the anisotropic GGX (Heitz 2014, eq. 86):
 * (-1 + sqrt(1 + (ax^2 w.x^2 + ay^2 w.y^2) / w.z^2)) / 2. */
SPT_FN float bsdf_ggx_lambda_aniso(vec3 w, float ax, float ay)
{
    float c2 = w.z * w.z;
    if (c2 <= 0.0f)
        return 1e30f;
    float t = (ax * ax * w.x * w.x + ay * ay * w.y * w.y) / c2;
    return 0.5f * (-1.0f + sqrtf(1.0f + t));
}

/* Height-correlated G2 of the anisotropic GGX (Heitz 2014, eq. 99). */
SPT_FN float bsdf_ggx_g2_aniso(vec3 wo, vec3 wi, float ax, float ay)
{
    return 1.0f / (1.0f + bsdf_ggx_lambda_aniso(wo, ax, ay) + bsdf_ggx_lambda_aniso(wi, ax, ay));
}

/* Density of visible normals of the anisotropic GGX (Heitz 2018, eq. 3), per
 * steradian of h, for wo.z > 0. */
SPT_FN float bsdf_ggx_vndf_pdf_aniso(vec3 wo, vec3 h, float ax, float ay)
{
    float c = v3_dot(wo, h);
    if (wo.z <= 0.0f || c <= 0.0f)
        return 0.0f;
    float g1 = 1.0f / (1.0f + bsdf_ggx_lambda_aniso(wo, ax, ay));
    return g1 * c * bsdf_ggx_d_aniso(h, ax, ay) / wo.z;
}

/* A microfacet normal distributed as the visible normals of wo (wo.z > 0) of
 * the GGX with roughnesses ax along x and ay along y, from two uniforms in
 * [0, 1) (Heitz 2018, Listing 1). */
SPT_FN vec3 bsdf_ggx_sample_vndf_aniso(vec3 wo, float ax, float ay, float u1, float u2)
{
    vec3 vh = v3_normalize(v3(ax * wo.x, ay * wo.y, wo.z));
    float lensq = vh.x * vh.x + vh.y * vh.y;
    vec3 t1 = lensq > 0.0f ? v3_scale(v3(-vh.y, vh.x, 0.0f), 1.0f / sqrtf(lensq)) : v3(1.0f, 0.0f, 0.0f);
    vec3 t2 = v3_cross(vh, t1);
    float r = sqrtf(u1), phi = 2.0f * SPT_PI * u2;
    float p1 = r * cosf(phi), p2 = r * sinf(phi);
    float s = 0.5f * (1.0f + vh.z);
    p2 = (1.0f - s) * sqrtf(fmaxf(0.0f, 1.0f - p1 * p1)) + s * p2;
    vec3 nh = v3_add(v3_add(v3_scale(t1, p1), v3_scale(t2, p2)),
                     v3_scale(vh, sqrtf(fmaxf(0.0f, 1.0f - p1 * p1 - p2 * p2))));
    return v3_normalize(v3(ax * nh.x, ay * nh.y, fmaxf(1e-7f, nh.z)));
}

/* The isotropic case of bsdf_ggx_sample_vndf_aniso (the same floats). */
SPT_FN vec3 bsdf_ggx_sample_vndf(vec3 wo, float alpha, float u1, float u2)
{
    return bsdf_ggx_sample_vndf_aniso(wo, alpha, alpha, u1, u2);
}

#endif
