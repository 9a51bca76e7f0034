/* Spectral functions shared by the kernels and the host (C99 and OpenCL C 1.2):
 * CIE 1931 colour matching functions at any wavelength, the Jakob-Hanika
 * sigmoid-polynomial spectra and the normalised D65 illuminant. (The sampling
 * of a path's wavelengths: kernels/sample/wavelength.h.) */
#ifndef SPT_KERNEL_SPECTRUM_H
#define SPT_KERNEL_SPECTRUM_H

#include "util/portable.h"
#include "spectrum/cie_data.h"

/* Linear interpolation of a 1 nm table over 360..830 at lambda; 0 outside. */
#define SPT_TABLE_LERP(table, lambda)                                               \
    do {                                                                            \
        float x_ = (lambda) - (float)SPT_CIE_LAMBDA_MIN;                            \
        if (!(x_ >= 0.0f) || x_ > (float)(SPT_CIE_SAMPLES - 1))                     \
            return 0.0f;                                                            \
        int i_ = (int)x_;                                                           \
        if (i_ > SPT_CIE_SAMPLES - 2)                                               \
            i_ = SPT_CIE_SAMPLES - 2;                                               \
        float f_ = x_ - (float)i_;                                                  \
        return table[i_] * (1.0f - f_) + table[i_ + 1] * f_;                        \
    } while (0)

/* CIE 1931 2-degree colour matching functions at lambda (nm). */
SPT_FN float spt_cie_x(float lambda) { SPT_TABLE_LERP(SPT_CIE_X, lambda); }
SPT_FN float spt_cie_y(float lambda) { SPT_TABLE_LERP(SPT_CIE_Y, lambda); }
SPT_FN float spt_cie_z(float lambda) { SPT_TABLE_LERP(SPT_CIE_Z, lambda); }

/* The Jakob-Hanika spectrum of coefficients (c0, c1, c2) at lambda in nm:
 * sigmoid(c0 l^2 + c1 l + c2), sigmoid(x) = 1/2 + x / (2 sqrt(1 + x^2)). Huge |x|
 * (the coefficients of pure white or black) give exactly 1 or 0. */
SPT_FN float spt_sigmoid_poly(float c0, float c1, float c2, float lambda)
{
    float x = (c0 * lambda + c1) * lambda + c2;
    if (!(fabsf(x) < 1e18f))
        return x > 0.0f ? 1.0f : 0.0f;
    return 0.5f + x / (2.0f * sqrtf(1.0f + x * x));
}

#ifdef SPT_D65_NORM
/* The CIE D65 illuminant normalised to Y = 1, at lambda. */
SPT_FN float spt_d65_norm(float lambda) { SPT_TABLE_LERP(SPT_D65_NORM, lambda); }
#endif

#endif
