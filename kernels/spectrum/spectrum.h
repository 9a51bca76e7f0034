/* Spectral functions shared by the kernels and the host (C99 and OpenCL C 1.2):
 * CIE 1931 colour matching functions at any wavelength, the Jakob-Hanika
 * sigmoid-polynomial spectra, the normalised D65 illuminant, and the sampling of
 * a path's four wavelengths. */
#ifndef SPT_KERNEL_SPECTRUM_H
#define SPT_KERNEL_SPECTRUM_H

#include "util/portable.h"
#include "spectrum/cie_data.h"
#include "sample/wavelength_pdf.h"

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

/* Wavelength importance sampling: the density of kernels/sample/wavelength_pdf.h
 * (proportional to the norm of the linear sRGB colour matching functions; see
 * tools/gen_wavelength_pdf.py), sampled by linear interpolation of its inverse
 * CDF table. The density sampled is thus piecewise constant: bin k, [l_k,
 * l_k+1), has probability 1 / SPT_WL_BINS spread evenly over it. */

/* The wavelength (nm) of CDF value u in [0, 1), and its density in *pdf. */
SPT_FN float spt_sample_wavelength_pdf(float u, float *pdf)
{
    float x = u * (float)SPT_WL_BINS;
    int k = (int)x;
    if (k > SPT_WL_BINS - 1)
        k = SPT_WL_BINS - 1;
    if (k < 0)
        k = 0;
    float a = SPT_WL_INV_CDF[k], b = SPT_WL_INV_CDF[k + 1];
    *pdf = 1.0f / ((float)SPT_WL_BINS * (b - a));
    return a + (x - (float)k) * (b - a);
}

/* The wavelength (nm) of CDF value u in [0, 1). */
SPT_FN float spt_sample_wavelength(float u)
{
    float pdf;
    return spt_sample_wavelength_pdf(u, &pdf);
}

/* The density at lambda (0 outside 360..830 nm): that of the bin holding it,
 * found by bisection of the table. */
SPT_FN float spt_wavelength_pdf(float lambda)
{
    if (!(lambda >= SPT_WL_INV_CDF[0] && lambda <= SPT_WL_INV_CDF[SPT_WL_BINS]))
        return 0.0f;
    int lo = 0, hi = SPT_WL_BINS; /* SPT_WL_INV_CDF[lo] <= lambda < SPT_WL_INV_CDF[hi] */
    while (hi - lo > 1) {
        int mid = (lo + hi) / 2;
        if (SPT_WL_INV_CDF[mid] <= lambda)
            lo = mid;
        else
            hi = mid;
    }
    return 1.0f / ((float)SPT_WL_BINS * (SPT_WL_INV_CDF[lo + 1] - SPT_WL_INV_CDF[lo]));
}

/* A path's four wavelengths: lambda[i] = inverse CDF of (u + i/4) mod 1, so the
 * four are stratified over the density, with their pdfs. */
SPT_FN void spt_sample_wavelengths(float u, float *lambda, float *pdf)
{
    for (int i = 0; i < SPT_NUM_LAMBDA; i++) {
        float ui = u + (float)i / (float)SPT_NUM_LAMBDA;
        if (ui >= 1.0f)
            ui -= 1.0f;
        lambda[i] = spt_sample_wavelength_pdf(ui, &pdf[i]);
    }
}

#endif
