/* The reflectance of a thin dielectric film over a base, per wavelength: the
 * physics of KHR_materials_iridescence (docs/gltf.md, "How materials and lights
 * render"), evaluated exactly where the extension's sample code approximates
 * it (Schlick Fresnel, the spectral integral in RGB).
 *
 * Three media: the outside (real index n0: air, or the clear coat), the film
 * (real index n1, thickness d) and the base (complex index n2 + i k2: a
 * dielectric with k2 = 0, or a conductor). The amplitude reflectance of the two
 * interfaces with the film's multiple reflections summed is Airy's formula
 * (Born and Wolf, Principles of Optics, 7th ed., 1.6.4, eq. 57):
 *
 *   r = (r01 + r12 e^{2 i beta}) / (1 + r01 r12 e^{2 i beta}),
 *   beta = 2 pi n1 d cos(theta1) / lambda,
 *
 * so the phase difference of successive reflections is
 * 2 beta = 4 pi n1 d cos(theta1) / lambda. With q_j = n_j cos(theta_j) =
 * sqrt(n_j^2 - n0^2 sin^2(theta0)) (the root whose imaginary part is >= 0, a
 * wave that decays into an absorbing base or beyond total reflection), the
 * interfaces' Fresnel coefficients are r_jk = (q_j - q_k) / (q_j + q_k) for s
 * and (n_k^2 q_j - n_j^2 q_k) / (n_k^2 q_j + n_j^2 q_k) for p polarisation;
 * the reflectance is the mean of |r_s|^2 and |r_p|^2 (unpolarised light).
 * The convention is the time factor e^{-i omega t}, in which an absorbing
 * index is n + i k with k >= 0 (kernels/closure/conductors.h). A thickness of
 * 0 gives the bare base's Fresnel reflectance, a film of the outside's index
 * too. C99 and OpenCL C 1.2. */
#ifndef SPT_THIN_FILM_H
#define SPT_THIN_FILM_H

#include "util/portable.h"
#include "util/vecmath.h"

/* A complex number (the film's amplitudes). */
typedef struct SptCplx {
    float re, im;
} SptCplx;

SPT_FN SptCplx spt_cx(float re, float im)
{
    SptCplx z;
    z.re = re;
    z.im = im;
    return z;
}
SPT_FN SptCplx spt_cx_add(SptCplx a, SptCplx b) { return spt_cx(a.re + b.re, a.im + b.im); }
SPT_FN SptCplx spt_cx_sub(SptCplx a, SptCplx b) { return spt_cx(a.re - b.re, a.im - b.im); }
SPT_FN SptCplx spt_cx_mul(SptCplx a, SptCplx b)
{
    return spt_cx(a.re * b.re - a.im * b.im, a.re * b.im + a.im * b.re);
}
SPT_FN SptCplx spt_cx_div(SptCplx a, SptCplx b)
{
    float d = b.re * b.re + b.im * b.im;
    return spt_cx((a.re * b.re + a.im * b.im) / d, (a.im * b.re - a.re * b.im) / d);
}
SPT_FN float spt_cx_abs2(SptCplx a) { return a.re * a.re + a.im * a.im; }

/* The square root with imaginary part >= 0 (and real part >= 0 where the
 * imaginary part is 0). */
SPT_FN SptCplx spt_cx_sqrt(SptCplx z)
{
    float m = sqrtf(z.re * z.re + z.im * z.im);
    float re = sqrtf(fmaxf(0.5f * (m + z.re), 0.0f));
    float im = sqrtf(fmaxf(0.5f * (m - z.re), 0.0f));
    return spt_cx(z.im < 0.0f ? -re : re, im);
}

/* One polarisation's Fresnel coefficient from medium j (q_j, index squared
 * e_j) to k: s when p is 0, else p. */
SPT_FN SptCplx spt_film_fresnel(SptCplx qj, SptCplx ej, SptCplx qk, SptCplx ek, int p)
{
    if (!p)
        return spt_cx_div(spt_cx_sub(qj, qk), spt_cx_add(qj, qk));
    SptCplx a = spt_cx_mul(ek, qj), b = spt_cx_mul(ej, qk);
    return spt_cx_div(spt_cx_sub(a, b), spt_cx_add(a, b));
}

/* The film's reflectance at one wavelength lambda_nm (nm), for light from the
 * outside of index n0 at incidence cosine cos0, film index n1 and thickness
 * d_nm (nm), base index n2 + i k2. Unpolarised; in [0, 1] where the base does
 * not amplify. */
SPT_FN float spt_thin_film_reflectance(float cos0, float lambda_nm, float n0, float n1, float d_nm, float n2,
                                       float k2)
{
    cos0 = fminf(fmaxf(cos0, 0.0f), 1.0f);
    float s2 = n0 * n0 * (1.0f - cos0 * cos0); /* n0^2 sin^2(theta0), the same in every layer */
    SptCplx e0 = spt_cx(n0 * n0, 0.0f), e1 = spt_cx(n1 * n1, 0.0f);
    SptCplx e2 = spt_cx(n2 * n2 - k2 * k2, 2.0f * n2 * k2);
    SptCplx q0 = spt_cx(n0 * cos0, 0.0f);
    SptCplx q1 = spt_cx_sqrt(spt_cx(n1 * n1 - s2, 0.0f));
    SptCplx q2 = spt_cx_sqrt(spt_cx_sub(e2, spt_cx(s2, 0.0f)));
    /* e^{2 i beta}, beta = 2 pi d q1 / lambda. */
    float g = 4.0f * SPT_PI * d_nm / lambda_nm;
    float amp = expf(-g * q1.im);
    SptCplx ph = spt_cx(amp * cosf(g * q1.re), amp * sinf(g * q1.re));
    float r = 0.0f;
    for (int p = 0; p < 2; p++) {
        SptCplx r01 = spt_film_fresnel(q0, e0, q1, e1, p);
        SptCplx r12p = spt_cx_mul(spt_film_fresnel(q1, e1, q2, e2, p), ph);
        SptCplx num = spt_cx_add(r01, r12p);
        SptCplx den = spt_cx_add(spt_cx(1.0f, 0.0f), spt_cx_mul(r01, r12p));
        /* A zero denominator (|r01| = |r12| = 1: grazing light) reflects all. */
        float d2 = spt_cx_abs2(den);
        r += d2 > 0.0f ? spt_cx_abs2(num) / d2 : 1.0f;
    }
    return fminf(0.5f * r, 1.0f);
}

/* spt_thin_film_reflectance at the path's four wavelengths lambda, the base's
 * index n2 + i k2 per wavelength. */
SPT_FN vec4 spt_thin_film_reflectance4(float cos0, vec4 lambda, float n0, float n1, float d_nm, vec4 n2, vec4 k2)
{
    return v4(spt_thin_film_reflectance(cos0, lambda.x, n0, n1, d_nm, n2.x, k2.x),
              spt_thin_film_reflectance(cos0, lambda.y, n0, n1, d_nm, n2.y, k2.y),
              spt_thin_film_reflectance(cos0, lambda.z, n0, n1, d_nm, n2.z, k2.z),
              spt_thin_film_reflectance(cos0, lambda.w, n0, n1, d_nm, n2.w, k2.w));
}

/* The real index of a base whose normal-incidence reflectance against the
 * outside n0 is f0 (the inverse of ((n - n0)/(n + n0))^2, n >= n0): the
 * extension's rule for a base known only by its F0, which for a metal drops
 * the extinction k. f0 is capped at 0.9999 (an index of 4e4 n0). */
SPT_FN float spt_film_ior_from_f0(float f0, float n0)
{
    float s = sqrtf(fminf(fmaxf(f0, 0.0f), 0.9999f));
    return n0 * (1.0f + s) / (1.0f - s);
}

#endif
