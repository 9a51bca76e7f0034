/* The sampling of a path's four wavelengths (C99 and OpenCL C 1.2): the
 * density of kernels/sample/wavelength_pdf.h (proportional to the norm of the
 * linear sRGB colour matching functions; tools/gen_wavelength_pdf.py), sampled
 * by linear interpolation of its inverse CDF table. The density sampled is thus
 * piecewise constant: bin k, [l_k, l_k+1), has probability 1 / SPT_WL_BINS
 * spread evenly over it (docs/architecture.md, "The physics it implements"). */
#ifndef SPT_WAVELENGTH_H
#define SPT_WAVELENGTH_H

#include "util/portable.h"
#include "util/vecmath.h"
#include "sample/wavelength_pdf.h"

/* The wavelength (nm) at CDF value (u + offset) mod 1, for u and offset in
 * [0, 1), and its density in *pdf. */
SPT_FN float spt_wavelength_at(float u, float offset, float *pdf)
{
    float ui = u + offset;
    if (ui >= 1.0f)
        ui -= 1.0f;
    float x = ui * (float)SPT_WL_BINS;
    int k = (int)x;
    k = k > SPT_WL_BINS - 1 ? SPT_WL_BINS - 1 : k;
    k = k < 0 ? 0 : k;
    float a = SPT_WL_INV_CDF[k], b = SPT_WL_INV_CDF[k + 1];
    *pdf = 1.0f / ((float)SPT_WL_BINS * (b - a));
    return a + (x - (float)k) * (b - a);
}

/* A path's four wavelengths from one uniform u in [0, 1): lane i at CDF value
 * (u + i/4) mod 1, so the four are stratified over the density, with their
 * densities in *pdf. */
SPT_FN void spt_sample_wavelengths(float u, vec4 *lambda, vec4 *pdf)
{
    float p0, p1, p2, p3;
    float l0 = spt_wavelength_at(u, 0.0f, &p0), l1 = spt_wavelength_at(u, 0.25f, &p1),
          l2 = spt_wavelength_at(u, 0.5f, &p2), l3 = spt_wavelength_at(u, 0.75f, &p3);
    *lambda = v4(l0, l1, l2, l3);
    *pdf = v4(p0, p1, p2, p3);
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

#endif
