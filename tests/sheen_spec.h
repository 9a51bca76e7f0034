/* The Charlie sheen's Lambda as KHR_materials_sheen's specification writes it,
 * shared by the tests that check the kernels' sheen against it (test_bsdf,
 * test_textures). Written here from the specification, not from
 * kernels/closure/, so that the tests compare against an independent value. */
#ifndef SPT_SHEEN_SPEC_H
#define SPT_SHEEN_SPEC_H

#include <math.h>

/* The specification's fitted L(x) at alpha = roughness^2: its coefficients
 * interpolate between the fits at alpha 0 and 1 by (1 - alpha)^2. */
static inline double spec_sheen_l(double x, double alpha)
{
    const double r0[5] = {21.5473, 3.82987, 0.19823, -1.97760, -4.32054};
    const double r1[5] = {25.3245, 3.32435, 0.16801, -1.27393, -4.85967};
    double t = (1 - alpha) * (1 - alpha), c[5];
    for (int k = 0; k < 5; k++)
        c[k] = r0[k] + (r1[k] - r0[k]) * t;
    return c[0] / (1 + c[1] * pow(x, c[2])) + c[3] * x + c[4];
}

/* Lambda(mu): exp(L(mu)) below mu = 1/2, mirrored about 1/2 above it. */
static inline double spec_sheen_lambda(double mu, double alpha)
{
    return mu < 0.5 ? exp(spec_sheen_l(mu, alpha))
                    : exp(2 * spec_sheen_l(0.5, alpha) - spec_sheen_l(1 - mu, alpha));
}

#endif
