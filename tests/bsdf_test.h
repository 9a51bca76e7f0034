/* What the BSDF tests (test_bsdf, test_anisotropy) share: a material made of
 * the given parts, a whole material's sampler and pdf in the form tests/chi2.h
 * takes, and its Monte Carlo directional albedo. Header only (static
 * functions), for tests: include it after test_util.h. */
#ifndef SPT_BSDF_TEST_H
#define SPT_BSDF_TEST_H

#include <math.h>
#include <stdint.h>
#include <string.h>

#include "closure/bsdf.h"

/* A material with the given parts; ior 1.5 at every wavelength, no layers. */
static BsdfParams make_params(float base, float metallic, float roughness, float transmission)
{
    BsdfParams p;
    memset(&p, 0, sizeof p);
    p.base = v4_splat(base);
    p.ior = v4_splat(1.5f);
    p.metallic = metallic;
    p.roughness = roughness;
    p.transmission = transmission;
    p.spec_tint = v4_splat(1.0f);
    p.specular = 1.0f;
    p.aniso_t = v3(1.0f, 0.0f, 0.0f);
    return p;
}

/* A material p seen from wo, sampled from stream (tests/chi2.h's context). */
typedef struct MatCtx {
    BsdfParams p;
    vec3 wo;
    uint32_t stream;
} MatCtx;

/* bsdf_sample's wi for sample i (0: the sample failed). */
static int mat_sample(void *ctx, uint32_t i, double p[3])
{
    MatCtx *c = ctx;
    uint64_t b = ((uint64_t)c->stream << 40) + 3u * (uint64_t)i;
    BsdfSample s = bsdf_sample(&c->p, c->wo, test_uniform(b), test_uniform(b + 1), test_uniform(b + 2));
    if (!s.valid)
        return 0;
    p[0] = s.wi.x;
    p[1] = s.wi.y;
    p[2] = s.wi.z;
    return 1;
}

static double mat_pdf(void *ctx, const double p[3])
{
    MatCtx *c = ctx;
    return bsdf_pdf(&c->p, c->wo, v3((float)p[0], (float)p[1], (float)p[2]));
}

/* Monte Carlo directional albedo of p at wo and its standard error (hero
 * wavelength), from n samples of stream. */
static double albedo_err(const BsdfParams *p, vec3 wo, uint32_t n, uint32_t stream, double *err)
{
    double sum = 0.0, sum2 = 0.0;
    for (uint32_t i = 0; i < n; i++) {
        uint64_t b = ((uint64_t)stream << 40) + 3u * (uint64_t)i;
        BsdfSample s = bsdf_sample(p, wo, test_uniform(b), test_uniform(b + 1), test_uniform(b + 2));
        double w = s.valid ? s.weight.x : 0.0;
        sum += w;
        sum2 += w * w;
    }
    double m = sum / n;
    *err = sqrt(fmax(sum2 / n - m * m, 0.0) / n);
    return m;
}

#endif
