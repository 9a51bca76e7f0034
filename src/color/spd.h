/* Host colour science: SPDs, CIE XYZ, sRGB, named illuminants, RGB upsampling.
 * Device-side evaluation (CMF lookup, sigmoid polynomials, wavelength sampling)
 * lives in kernels/spectrum/spectrum.h and is shared with the host through kernels/. */
#ifndef SPT_SPECTRUM_H
#define SPT_SPECTRUM_H

#include <stddef.h>

#include "core/util.h"
#include "io/srgb.h"

/* One (wavelength, value) sample of a tabulated spectrum. */
typedef struct SpdSample {
    double nm, value;
} SpdSample;

/* Sorts n samples by wavelength. */
void spd_sort_samples(SpdSample *s, size_t n);

/* A spectral power distribution: a piecewise-linear function of wavelength (nm),
 * zero outside [nm[0], nm[count-1]], plus optional spectral lines (delta
 * functions of a given power, in the same units times nm). Samples are sorted by
 * strictly increasing wavelength. */
typedef struct Spd {
    int count;
    double *nm;
    double *value;
    int line_count;
    double *line_nm;
    double *line_power;
} Spd;

void spd_free(Spd *s);
int spd_copy(Spd *dst, const Spd *src);

/* A piecewise-linear SPD from n samples (any spacing, sorted or not; duplicates of
 * a wavelength or non-finite values are an error). */
int spd_from_samples(Spd *out, const double *nm, const double *value, int n, SptError *e);

/* A named SPD: "A", "D65", "F2", "F7", "F11", "mercury", "blackbody:KELVIN"
 * (case-insensitive names). Returns SPT_EXIT_INPUT for an unknown name. */
int spd_named(Spd *out, const char *name, SptError *e);

/* An SPD from a CSV file of `wavelength_nm,value` lines (a header line and
 * # comments allowed); a bad line is an error naming the file and line number. */
int spd_read_csv(Spd *out, const char *path, SptError *e);

/* The same from text_size bytes of text in memory (path names it in errors). */
int spd_parse_csv(Spd *out, const char *path, const char *text, size_t text_size, SptError *e);

/* A name as spd_named accepts, or else a CSV file path. */
int spd_parse(Spd *out, const char *text, SptError *e);

/* The SPD's value at nm (linear interpolation, zero outside; lines excluded). */
double spd_eval(const Spd *s, double nm);

/* Unnormalised tristimulus values: X = sum over the 1 nm CIE samples of
 * xbar(l) P(l) (likewise Y, Z), plus sum over lines of cmf(line) * power. */
void spd_to_xyz(const Spd *s, double xyz[3]);

/* XYZ of a reflectance s under CIE D65, by the same 1 nm sums, normalised so that
 * a perfect white reflector (s = 1) has Y = 1; lines are ignored. */
void spd_reflectance_to_xyz(const Spd *s, double xyz[3]);

/* Luminous efficacy in lm/W: 683 * integral(ybar P) / integral(P) over 360-830 nm. */
double spd_luminous_efficacy(const Spd *s);

/* Resamples onto the 1 nm grid 360..830 (SPT_CIE_SAMPLES values) as the renderer
 * uses it: box-averaged over each 1 nm bin so a line of power p becomes p per nm in
 * its bin. */
void spd_to_grid(const Spd *s, float *grid);

/* Planck's law: spectral radiance in W/(m^2 sr m) at wavelength nm, temperature K. */
double blackbody_radiance(double nm, double kelvin);

/* The matrices of docs/architecture.md (its transfer curve: src/io/srgb.h,
 * included above). */
void xyz_to_linear_srgb(const double xyz[3], double rgb[3]);
void linear_srgb_to_xyz(const double rgb[3], double xyz[3]);

/* RGB upsampling (Jakob and Hanika 2019). Coefficients c give the spectrum
 * s(l) = sigmoid(c0 l^2 + c1 l + c2), l in nm (see kernels/spectrum/spectrum.h). */
/* A reflectance, rgb clamped to [0,1]: the spectrum whose colour under D65 (1 nm
 * CIE 1931 sums, docs/architecture.md's matrix) is rgb to 1e-9, found from the fitted
 * table's coefficients by Levenberg-Marquardt (about 0.1 ms). For constant
 * colours: material factors, emission, lights, the sky. */
void rgb_to_coeffs(const float rgb[3], float coeffs[3]);
/* The fitted table's trilinear interpolation alone, for per-texel and per-vertex
 * conversions (0.1 us instead of about 25 us):
 * exact at its nodes; in between, its spectrum's colour is within 0.003 of an
 * 8-bit sRGB colour (tools/rgb2spec/rgb2spec_opt.c, tests/test_spectrum.c). */
void rgb_to_coeffs_fast(const float rgb[3], float coeffs[3]);
/* An illuminant from linear sRGB: scale * sigmoid(c)(l) * D65(l), with D65
 * normalised so that its Y is 1; so rgb (1,1,1) becomes D65 with Y = 1. The
 * coefficients are those of rgb / scale as a reflectance (rgb_to_coeffs; _fast:
 * rgb_to_coeffs_fast). */
void rgb_illuminant_coeffs(const float rgb[3], float coeffs[3], float *scale);
void rgb_illuminant_coeffs_fast(const float rgb[3], float coeffs[3], float *scale);

#endif
