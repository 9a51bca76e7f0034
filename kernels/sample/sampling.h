/* Sampling routines shared by the kernels and the host tests (C99 and OpenCL C
 * 1.2): warps from uniform numbers in [0, 1) to directions, disk points, triangle
 * points and discrete choices, each with its pdf, and the MIS power heuristic.
 *
 * Directions are in the local frame with the normal along +z (build one with
 * v3_basis). Solid-angle pdfs are per steradian. */
#ifndef SPT_SAMPLING_H
#define SPT_SAMPLING_H

#include "util/portable.h"
#include "util/vecmath.h"

/* The bits of a float. */
SPT_FN spt_u32 spt_f32_bits(float f)
{
#if SPT_DEVICE
    return as_uint(f);
#else
    union {
        float f;
        spt_u32 u;
    } v;
    v.f = f;
    return v.u;
#endif
}

/* The largest float below 1 (1 - 2^-24). */
#define SPT_ONE_MINUS_EPSILON 0.99999994f

/* A point of the unit disk (z = 0) from (u1, u2) in [0,1)^2 with uniform density
 * 1/pi: Shirley and Chiu's concentric map, which keeps strata compact. */
SPT_FN vec3 spt_sample_concentric_disk(float u1, float u2)
{
    float ox = 2.0f * u1 - 1.0f;
    float oy = 2.0f * u2 - 1.0f;
    if (ox == 0.0f && oy == 0.0f)
        return v3(0.0f, 0.0f, 0.0f);
    float r, theta;
    if (fabsf(ox) > fabsf(oy)) {
        r = ox;
        theta = (SPT_PI / 4.0f) * (oy / ox);
    } else {
        r = oy;
        theta = (SPT_PI / 2.0f) - (SPT_PI / 4.0f) * (ox / oy);
    }
    return v3(r * cosf(theta), r * sinf(theta), 0.0f);
}

/* sin and cos of x for |x| <= pi/4, where no argument reduction is needed: the
 * minimax polynomials of Cephes' sinf and cosf (S. Moshier), relative error
 * below 2^-23 there. Cheaper than the general sin/cos, whose argument
 * reduction (PoCL's __pocl_argReductionS) is an out-of-line call per use. */
SPT_FN void spt_sincos_pi4(float x, float *s, float *c)
{
    float z = x * x;
    *s = ((-1.9515295891e-4f * z + 8.3321608736e-3f) * z - 1.6666654611e-1f) * z * x + x;
    *c = ((2.443315711809948e-5f * z - 1.388731625493765e-3f) * z + 4.166664568298827e-2f) * z * z -
         0.5f * z + 1.0f;
}

/* A direction of the upper hemisphere (z >= 0) with density cos(theta)/pi
 * (Malley's method: a point of the concentric disk lifted onto the
 * hemisphere). The disk angle is phi = pi/4 (b/a), or pi/2 - pi/4 (a/b) on the
 * other wedges; the latter's cos and sin are the sin and cos of pi/4 (a/b), so
 * both take spt_sincos_pi4 of an angle in [-pi/4, pi/4]. Written with selects,
 * not branches: which wedge a random point falls in is a coin toss, which a
 * CPU's branch predictor gets wrong half the time. */
SPT_FN vec3 spt_sample_cosine_hemisphere(float u1, float u2)
{
    float a = 2.0f * u1 - 1.0f, b = 2.0f * u2 - 1.0f;
    int wide = fabsf(a) > fabsf(b);
    float r = wide ? a : b;
    float s, c;
    spt_sincos_pi4(0.25f * SPT_PI * ((wide ? b : a) / r), &s, &c);
    float x = r * (wide ? c : s), y = r * (wide ? s : c);
    /* The centre (a = b = 0) maps to itself (the ratio above is 0/0 there). */
    int centre = a == 0.0f && b == 0.0f;
    x = centre ? 0.0f : x;
    y = centre ? 0.0f : y;
    return v3(x, y, sqrtf(fmaxf(0.0f, 1.0f - x * x - y * y)));
}

/* Density of spt_sample_cosine_hemisphere at a direction with this cos(theta)
 * (0 below the horizon). */
SPT_FN float spt_pdf_cosine_hemisphere(float cos_theta)
{
    return cos_theta > 0.0f ? cos_theta * SPT_INV_PI : 0.0f;
}

/* A direction of the upper hemisphere (z >= 0) with constant density 1/(2 pi). */
SPT_FN vec3 spt_sample_uniform_hemisphere(float u1, float u2)
{
    float z = u1;
    float r = sqrtf(fmaxf(0.0f, 1.0f - z * z));
    float phi = 2.0f * SPT_PI * u2;
    return v3(r * cosf(phi), r * sinf(phi), z);
}

/* Density of spt_sample_uniform_hemisphere: 1/(2 pi) for cos(theta) >= 0, else 0. */
SPT_FN float spt_pdf_uniform_hemisphere(float cos_theta)
{
    return cos_theta >= 0.0f ? SPT_INV_2PI : 0.0f;
}

/* A direction of the unit sphere with constant density 1/(4 pi). */
SPT_FN vec3 spt_sample_uniform_sphere(float u1, float u2)
{
    float z = 1.0f - 2.0f * u1;
    float r = sqrtf(fmaxf(0.0f, 1.0f - z * z));
    float phi = 2.0f * SPT_PI * u2;
    return v3(r * cosf(phi), r * sinf(phi), z);
}

/* Density of spt_sample_uniform_sphere. */
SPT_FN float spt_pdf_uniform_sphere(void)
{
    return SPT_INV_4PI;
}

/* Barycentrics (b0, b1, b2), summing to 1, of a point uniformly distributed by
 * area over a triangle, so the area density is 1/area. Heitz 2019 ("A
 * Low-Distortion Map Between Triangle and Square"): no square root, and
 * neighbouring (u1, u2) stay neighbours. The point is b0 p0 + b1 p1 + b2 p2. */
SPT_FN vec3 spt_sample_triangle_bary(float u1, float u2)
{
    float b0, b1;
    if (u1 < u2) {
        b0 = 0.5f * u1;
        b1 = u2 - b0;
    } else {
        b1 = 0.5f * u2;
        b0 = u1 - b1;
    }
    return v3(b0, b1, 1.0f - b0 - b1);
}

/* A point uniformly distributed by area on triangle (p0, p1, p2); its area
 * density is 1 / its area. */
SPT_FN vec3 spt_sample_triangle(vec3 p0, vec3 p1, vec3 p2, float u1, float u2)
{
    vec3 b = spt_sample_triangle_bary(u1, u2);
    return v3_add(v3_add(v3_scale(p0, b.x), v3_scale(p1, b.y)), v3_scale(p2, b.z));
}

/* Veach's power heuristic (beta = 2) weight of a sample drawn from the strategy
 * with density pdf_a, combined with one with density pdf_b (multiply a pdf by
 * its sample count when strategies take several): pdf_a^2 / (pdf_a^2 + pdf_b^2).
 * Written with a ratio, so huge pdfs do not overflow; 0 when pdf_a is 0, 1 when
 * pdf_b is 0 (or pdf_a is infinite). Pdfs must not be negative or NaN. */
SPT_FN float spt_power_heuristic(float pdf_a, float pdf_b)
{
    if (!(pdf_a > 0.0f))
        return 0.0f;
    if (pdf_a >= pdf_b) {
        float r = pdf_b / pdf_a;
        return 1.0f / (1.0f + r * r);
    }
    float r = pdf_a / pdf_b;
    return r * r / (1.0f + r * r);
}

/* Picks an index of a discrete distribution from its CDF: cdf holds n + 1
 * non-decreasing floats with cdf[0] = 0 and cdf[n] = 1 (src/core/distribution.c builds
 * it), and index i has probability cdf[i+1] - cdf[i]. u in [0, 1) (clamped to
 * it). Returns the index i with cdf[i] <= u < cdf[i+1] (binary search, so an
 * entry of probability 0 is never returned) and sets *prob to its probability;
 * when u_remapped is not 0, sets it to (u - cdf[i]) / prob in [0, 1), a fresh
 * uniform number that can be reused. An empty distribution (n == 0 or
 * cdf[n] == 0) returns -1 with *prob = 0 and *u_remapped = 0. */
SPT_FN spt_i32 spt_discrete_sample(const SPT_GLOBAL float *cdf, spt_u32 n, float u,
                                   float *prob, float *u_remapped)
{
    if (n == 0u || !(cdf[n] > 0.0f)) {
        *prob = 0.0f;
        if (u_remapped)
            *u_remapped = 0.0f;
        return -1;
    }
    u = fminf(fmaxf(u, 0.0f), SPT_ONE_MINUS_EPSILON);
    /* The last i in [0, n) with cdf[i] <= u (cdf[0] = 0 <= u, so one exists).
     * Invariant: cdf[i] <= u and the answer lies in [i, i + len). A fixed
     * number of steps and a select instead of a branch: no misprediction on a
     * CPU, no divergence on a GPU. */
    spt_u32 i = 0u, len = n;
    while (len > 1u) {
        spt_u32 hlen = len >> 1;
        /* cdf[i + hlen] <= u exactly when u - cdf[i + hlen] is not negative
         * (an exact zero difference is +0), i.e. its sign bit is clear: a
         * mask from the sign bit, not a ?: or a comparison, which LLVM turns
         * back into a branch (a coin toss for the predictor). */
        float d = u - cdf[i + hlen];
        i += hlen & ((spt_f32_bits(d) >> 31) - 1u);
        len -= hlen;
    }
    float p = cdf[i + 1u] - cdf[i];
    *prob = p;
    if (u_remapped)
        *u_remapped = fminf((u - cdf[i]) / p, SPT_ONE_MINUS_EPSILON);
    return (spt_i32)i;
}

/* Probability of index i (< n) of the distribution whose CDF is cdf, as
 * spt_discrete_sample reports it when it picks i. */
SPT_FN float spt_discrete_pdf(const SPT_GLOBAL float *cdf, spt_u32 i)
{
    return cdf[i + 1u] - cdf[i];
}

#endif
