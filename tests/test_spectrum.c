/* src/color/spd.c and kernels/spectrum/spectrum.h against published values and against the
 * colour-science reference data in tests/data/colour (tools/gen_colour_refs.py). */
#include "test_util.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "color/spd.h"
#include "spectrum/spectrum.h"
#include "sample/wavelength.h"

/* XYZ of a named illuminant normalised to Y = 1. */
static void named_white(const char *name, double xyz[3])
{
    Spd s;
    SptError e = {0};
    assert_int_equal(spd_named(&s, name, &e), 0);
    spd_to_xyz(&s, xyz);
    double y = xyz[1];
    for (int k = 0; k < 3; k++)
        xyz[k] /= y;
    spd_free(&s);
}

/* White points of CIE A (from its formula) and D65 (table) vs CIE 15:2004. */
TEST(test_white_points)
{
    double xyz[3];
    named_white("D65", xyz);
    assert_close(xyz[0], 0.95047, 1e-3);
    assert_close(xyz[2], 1.08883, 1e-3);
    named_white("A", xyz);
    assert_close(xyz[0], 1.09850, 1e-3);
    assert_close(xyz[2], 0.35585, 1e-3);
}

/* Planck's law sampled at 1, 5, 10, 20 nm and irregularly: chromaticity of 6500 K
 * on the CIE 1931 Planckian locus, x = 0.3135, y = 0.3236 (CIE 15:2004 tables). */
TEST(test_spacing_and_planckian_locus)
{
    const int steps[] = {1, 5, 10, 20, 0};
    for (int k = 0; k < 5; k++) {
        double nm[600], v[600];
        int n = 0;
        for (double l = 340; l <= 850; l += steps[k] ? steps[k] : 3 + (n % 7)) {
            nm[n] = l;
            v[n] = blackbody_radiance(l, 6500.0);
            n++;
        }
        Spd s;
        SptError e = {0};
        assert_int_equal(spd_from_samples(&s, nm, v, n, &e), 0);
        double xyz[3];
        spd_to_xyz(&s, xyz);
        double sum = xyz[0] + xyz[1] + xyz[2];
        assert_close(xyz[0] / sum, 0.3135, 2e-4);
        assert_close(xyz[1] / sum, 0.3236, 2e-4);
        spd_free(&s);
    }
}

/* Reads the colour-science XYZ and sRGB8 of the 24 ColorChecker patches under D65
 * and compares with spd_read_csv + spd_reflectance_to_xyz. */
TEST(test_colorchecker)
{
    FILE *f = fopen(SPT_TEST_DATA("colour/colorchecker_expected.csv"), "r");
    assert_non_null(f);
    char line[512];
    int patches = 0;
    double worst_xyz = 0, worst_8 = 0;
    while (fgets(line, sizeof line, f)) {
        if (line[0] == '#')
            continue;
        int idx, r8[3];
        double want[3];
        char name[128];
        assert_int_equal(sscanf(line, "%d,%127[^,],%lf,%lf,%lf,%d,%d,%d", &idx, name, &want[0],
                                &want[1], &want[2], &r8[0], &r8[1], &r8[2]),
                         8);
        char path[256];
        snprintf(path, sizeof path, SPT_TEST_DATA("colour/colorchecker/%02d.csv"), idx);
        Spd s;
        SptError e = {0};
        if (spd_read_csv(&s, path, &e))
            fail_msg("%s", e.msg);
        double xyz[3], rgb[3];
        spd_reflectance_to_xyz(&s, xyz);
        xyz_to_linear_srgb(xyz, rgb);
        for (int k = 0; k < 3; k++) {
            double rel = fabs(xyz[k] - want[k]) / want[k];
            if (rel > worst_xyz)
                worst_xyz = rel;
            int got8 = srgb_to_8bit(rgb[k]);
            if (abs(got8 - r8[k]) > worst_8)
                worst_8 = abs(got8 - r8[k]);
            if (rel > 2e-3 || abs(got8 - r8[k]) > 1)
                fail_msg("patch %d '%s' channel %d: XYZ %.6f (want %.6f), sRGB8 %d (want %d)", idx,
                         name, k, xyz[k], want[k], got8, r8[k]);
        }
        spd_free(&s);
        patches++;
    }
    fclose(f);
    assert_int_equal(patches, 24);
    print_message("ColorChecker: largest XYZ relative error %.2g, sRGB8 %g\n", worst_xyz, worst_8);
}

/* The sRGB of a reflectance spectrum given by coefficients, under D65. */
static void coeffs_to_rgb_reflectance(const float c[3], double rgb[3])
{
    double nm[SPT_CIE_SAMPLES], v[SPT_CIE_SAMPLES];
    for (int i = 0; i < SPT_CIE_SAMPLES; i++) {
        nm[i] = SPT_CIE_LAMBDA_MIN + i;
        v[i] = spt_sigmoid_poly(c[0], c[1], c[2], (float)nm[i]);
    }
    Spd s;
    assert_int_equal(spd_from_samples(&s, nm, v, SPT_CIE_SAMPLES, NULL), 0);
    double xyz[3];
    spd_reflectance_to_xyz(&s, xyz);
    xyz_to_linear_srgb(xyz, rgb);
    spd_free(&s);
}

/* sRGB -> coefficients -> spectrum -> sRGB over a 9^3 grid of the gamut and 500
 * random colours. rgb_to_coeffs is exact: within 5e-5 per channel inside the
 * gamut (float coefficients, and this check sums its own D65 product); greys
 * (constant spectra) within 2e-4, the 4-digit matrix's white being (1.0000,
 * 1.0001, 0.9998); colours on the gamut's faces (a channel at 0 or 1, which a
 * sigmoid reaches only in the limit) within 1e-3. rgb_to_coeffs_fast, the table
 * alone, within 0.004 (a trilinear interpolation of coefficients, not colours:
 * 0.0017 with 64 cells per axis, 0.0065 with 32). */
static void round_trip_check(const float rgb[3], double *worst, double *worst_fast)
{
    float c[3];
    double got[3];
    int grey = rgb[0] == rgb[1] && rgb[1] == rgb[2], edge = 0;
    for (int k = 0; k < 3; k++)
        edge |= rgb[k] <= 0.0f || rgb[k] >= 1.0f;
    rgb_to_coeffs(rgb, c);
    coeffs_to_rgb_reflectance(c, got);
    for (int k = 0; k < 3; k++) {
        double d = fabs(got[k] - rgb[k]);
        if (!grey && !edge && d > *worst)
            *worst = d;
        if (!(d <= (grey ? 2e-4 : edge ? 1e-3 : 5e-5)))
            fail_msg("rgb (%.9g %.9g %.9g) came back as (%.9g %.9g %.9g)", rgb[0], rgb[1], rgb[2], got[0],
                     got[1], got[2]);
    }
    rgb_to_coeffs_fast(rgb, c);
    coeffs_to_rgb_reflectance(c, got);
    for (int k = 0; k < 3; k++) {
        double d = fabs(got[k] - rgb[k]);
        if (d > *worst_fast)
            *worst_fast = d;
        if (!(d <= 0.004))
            fail_msg("fast: rgb (%g %g %g) came back as (%g %g %g)", rgb[0], rgb[1], rgb[2], got[0], got[1],
                     got[2]);
    }
}

/* The table alone on what textures and vertex colours give it: 8-bit sRGB
 * colours (every 15th level of each channel, 18^3 colours), decoded. The
 * colour of the interpolated spectrum (1 nm sums, D65, computed here) must be
 * within 0.004 of the colour in every channel and 3e-4 on average (64 cells per
 * axis: 0.0026 and 0.00015; 32: 0.0078 and 0.0006). */
TEST(test_table_on_8bit_colours)
{
    double worst = 0.0, sum = 0.0;
    int n = 0;
    for (int r = 0; r < 256; r += 15)
        for (int g = 0; g < 256; g += 15)
            for (int b = 0; b < 256; b += 15) {
                float rgb[3] = {(float)srgb_decode(r / 255.0), (float)srgb_decode(g / 255.0),
                                (float)srgb_decode(b / 255.0)}, c[3];
                rgb_to_coeffs_fast(rgb, c);
                double xyz[3] = {0, 0, 0}, got[3];
                for (int i = 0; i < SPT_CIE_SAMPLES; i++) {
                    double v = spt_sigmoid_poly(c[0], c[1], c[2], (float)(SPT_CIE_LAMBDA_MIN + i)) *
                               SPT_D65_NORM[i] / SPT_CIE_Y_INTEGRAL;
                    xyz[0] += SPT_CIE_X[i] * v;
                    xyz[1] += SPT_CIE_Y[i] * v;
                    xyz[2] += SPT_CIE_Z[i] * v;
                }
                xyz_to_linear_srgb(xyz, got);
                for (int k = 0; k < 3; k++) {
                    double d = fabs(got[k] - rgb[k]);
                    worst = fmax(worst, d);
                    sum += d;
                    n++;
                    if (!(d <= 0.004))
                        fail_msg("sRGB8 (%d %d %d) channel %d: the table's spectrum has %.5f for %.5f", r, g, b, k,
                                 got[k], rgb[k]);
                }
            }
    print_message("table on 8-bit sRGB colours: largest error %.4f, mean %.2g\n", worst, sum / n);
    assert_true(sum / n <= 3e-4);
}

TEST(test_reflectance_round_trip)
{
    const int n = 9;
    double worst = 0, worst_fast = 0;
    for (int r = 0; r < n; r++)
        for (int g = 0; g < n; g++)
            for (int b = 0; b < n; b++) {
                float rgb[3] = {(float)r / (n - 1), (float)g / (n - 1), (float)b / (n - 1)};
                round_trip_check(rgb, &worst, &worst_fast);
            }
    uint32_t x = 12345u;
    for (int i = 0; i < 500; i++) {
        float rgb[3];
        for (int k = 0; k < 3; k++) {
            x = x * 1664525u + 1013904223u;
            rgb[k] = (float)(x >> 8) / 16777216.0f;
        }
        round_trip_check(rgb, &worst, &worst_fast);
    }
    print_message("reflectance round trip: largest error %.3g (non-grey), table alone %.3g\n", worst,
                  worst_fast);
}

/* Illuminant RGB -> scale * sigmoid * D65(Y=1) -> sRGB, including values above 1;
 * rgb (1,1,1) gives D65 itself. Within 2e-4 per channel times the largest. */
TEST(test_illuminant_round_trip)
{
    const float vals[] = {0.0f, 0.05f, 0.3f, 0.5f, 0.8f, 1.0f, 3.0f};
    const int nv = sizeof vals / sizeof vals[0];
    double worst = 0;
    for (int r = 0; r < nv; r++)
        for (int g = 0; g < nv; g++)
            for (int b = 0; b < nv; b++) {
                float rgb[3] = {vals[r], vals[g], vals[b]}, c[3], scale;
                float m = fmaxf(fmaxf(rgb[0], rgb[1]), rgb[2]);
                rgb_illuminant_coeffs(rgb, c, &scale);
                double xyz[3] = {0, 0, 0}, got[3];
                for (int i = 0; i < SPT_CIE_SAMPLES; i++) {
                    float l = (float)(SPT_CIE_LAMBDA_MIN + i);
                    double v = scale * spt_sigmoid_poly(c[0], c[1], c[2], l) * spt_d65_norm(l);
                    xyz[0] += v * spt_cie_x(l);
                    xyz[1] += v * spt_cie_y(l);
                    xyz[2] += v * spt_cie_z(l);
                }
                for (int k = 0; k < 3; k++)
                    xyz[k] /= SPT_CIE_Y_INTEGRAL;
                xyz_to_linear_srgb(xyz, got);
                for (int k = 0; k < 3; k++) {
                    double d = fabs(got[k] - rgb[k]) / (m > 1 ? m : 1);
                    if (d > worst)
                        worst = d;
                    /* Exact (float coefficients) but for greys, whose constant
                     * spectrum is 2e-4 off as in the reflectance test. */
                    if (!(d <= 2e-4))
                        fail_msg("illuminant rgb (%g %g %g) came back as (%g %g %g)", rgb[0],
                                 rgb[1], rgb[2], got[0], got[1], got[2]);
                }
            }
    print_message("illuminant round trip: largest error %.3g\n", worst);
}

/* White and black coefficients give exactly 1 and 0 everywhere, never NaN. */
TEST(test_sigmoid_extremes)
{
    float white[3] = {1, 1, 1}, black[3] = {0, 0, 0}, cw[3], cb[3];
    rgb_to_coeffs(white, cw);
    rgb_to_coeffs(black, cb);
    for (float l = 300.0f; l <= 900.0f; l += 0.5f) {
        assert_true(spt_sigmoid_poly(cw[0], cw[1], cw[2], l) == 1.0f);
        assert_true(spt_sigmoid_poly(cb[0], cb[1], cb[2], l) == 0.0f);
    }
    float nan_rgb[3] = {NAN, 0.5f, 0.5f}, c[3];
    rgb_to_coeffs(nan_rgb, c);
    for (int k = 0; k < 3; k++)
        assert_true(isfinite(c[k]));
    /* sigmoid(0) = 1/2 and sigmoid(1) = 1/2 + 1/(2 sqrt 2), from the definition. */
    assert_close(spt_sigmoid_poly(0, 0, 0, 500), 0.5, 1e-7);
    assert_close(spt_sigmoid_poly(0, 0, 1, 500), 0.5 + 0.5 / sqrt(2.0), 1e-6);
}

/* The matrices of docs/architecture.md: sRGB white (1,1,1) is D65 (0.9505, 1, 1.0890, IEC
 * 61966-2-1) and the two matrices invert each other to their 4-digit rounding. */
TEST(test_matrices)
{
    double one[3] = {1, 1, 1}, xyz[3], back[3];
    linear_srgb_to_xyz(one, xyz);
    assert_close(xyz[0], 0.9505, 1e-4);
    assert_close(xyz[1], 1.0000, 1e-4);
    assert_close(xyz[2], 1.0890, 1e-4);
    double tests[4][3] = {{0.2, 0.5, 0.9}, {1, 0, 0}, {0, 1, 0}, {0.3, 0.3, 0.05}};
    for (int t = 0; t < 4; t++) {
        linear_srgb_to_xyz(tests[t], xyz);
        xyz_to_linear_srgb(xyz, back);
        for (int k = 0; k < 3; k++)
            assert_close(back[k], tests[t][k], 2e-4);
        xyz_to_linear_srgb(tests[t], back);
        linear_srgb_to_xyz(back, xyz);
        for (int k = 0; k < 3; k++)
            assert_close(xyz[k], tests[t][k], 2e-4);
    }
}

/* The transfer curve: continuous at its threshold, the inverse inverts it, and
 * published 8-bit codes: linear 0.5 -> 188, 0.2158605 -> 128 (IEC 61966-2-1). */
TEST(test_transfer_curve)
{
    double t = 0.0031308;
    assert_close(srgb_encode(t * (1 - 1e-9)), srgb_encode(t * (1 + 1e-9)), 1e-6);
    assert_close(srgb_decode(0.04045 * (1 - 1e-9)), srgb_decode(0.04045 * (1 + 1e-9)), 1e-6);
    assert_close(srgb_encode(0.5), 0.735356983, 1e-6);
    for (double v = 0.0; v <= 1.0; v += 0.01)
        assert_close(srgb_decode(srgb_encode(v)), v, 1e-9);
    assert_int_equal(srgb_to_8bit(0.5), 188);
    assert_int_equal(srgb_to_8bit(0.2158605), 128);
    assert_int_equal(srgb_to_8bit(NAN), 0);
    assert_int_equal(srgb_to_8bit(-1.0), 0);
    assert_int_equal(srgb_to_8bit(7.0), 255);
}

/* Wien's displacement law: the peak is at b / T, b = 2.897771955e-3 m K (CODATA). */
TEST(test_blackbody_wien)
{
    const double temps[] = {2856, 4000, 6500};
    for (int k = 0; k < 3; k++) {
        double best = 0, best_nm = 0;
        for (double l = 200; l < 1500; l += 0.01) {
            double v = blackbody_radiance(l, temps[k]);
            if (v > best) {
                best = v;
                best_nm = l;
            }
        }
        assert_close(best_nm, 2.897771955e6 / temps[k], 0.02);
    }
}

/* Luminous efficacy of blackbodies vs colour-science (tests/data/colour/
 * efficacy.csv), and a 555 nm line is 683 lm/W by definition. */
TEST(test_luminous_efficacy)
{
    FILE *f = fopen(SPT_TEST_DATA("colour/efficacy.csv"), "r");
    assert_non_null(f);
    char line[512];
    int n = 0;
    while (fgets(line, sizeof line, f)) {
        double kelvin, want;
        if (line[0] == '#' || sscanf(line, "%lf,%lf", &kelvin, &want) != 2)
            continue;
        char name[64];
        snprintf(name, sizeof name, "blackbody:%g", kelvin);
        Spd s;
        assert_int_equal(spd_named(&s, name, NULL), 0);
        assert_close_rel(spd_luminous_efficacy(&s), want, 1e-4);
        spd_free(&s);
        n++;
    }
    fclose(f);
    assert_int_equal(n, 2);
    double nm = 555.0, p = 2.0;
    Spd line555 = {0};
    line555.line_count = 1;
    line555.line_nm = &nm;
    line555.line_power = &p;
    assert_close(spd_luminous_efficacy(&line555), 683.0, 0.01);
}

/* Published CIE 1931 values: ybar(555) = 1, xbar(600) = 1.0622, zbar(450) = 1.77211,
 * linear interpolation between samples, zero outside 360-830 nm; D65 ratio
 * S(460)/S(560) = 117.812/100 (CIE 15:2004). */
TEST(test_cmf_lookup)
{
    assert_close(spt_cie_y(555.0f), 1.0, 1e-6);
    assert_close(spt_cie_x(600.0f), 1.0622, 1e-4);
    assert_close(spt_cie_z(450.0f), 1.77211, 1e-4);
    assert_close(spt_cie_y(555.5f), 0.5 * (spt_cie_y(555.0f) + spt_cie_y(556.0f)), 1e-7);
    assert_true(spt_cie_x(359.0f) == 0.0f && spt_cie_y(831.0f) == 0.0f && spt_cie_z(NAN) == 0.0f);
    assert_close(spt_d65_norm(460.0f) / spt_d65_norm(560.0f), 1.17812, 1e-4);
    double y = 0;
    for (int i = 0; i < SPT_CIE_SAMPLES; i++)
        y += SPT_CIE_Y[i] * SPT_D65_NORM[i];
    assert_close(y / SPT_CIE_Y_INTEGRAL, 1.0, 1e-5);
}

/* Sampled-wavelength integration of ybar: the mean of (1/4) sum ybar(l)/pdf(l)
 * over many paths is the tabulated integral within 1e-3; the pdf integrates to 1
 * and sampling inverts its CDF. */
TEST(test_wavelength_sampling)
{
    uint32_t x = 12345;
    const int paths = 1 << 19;
    double sum = 0;
    for (int p = 0; p < paths; p++) {
        x = x * 1664525u + 1013904223u;
        float u = (float)(x >> 8) * (1.0f / 16777216.0f);
        vec4 l4, p4;
        spt_sample_wavelengths(u, &l4, &p4);
        float lam[4] = {l4.x, l4.y, l4.z, l4.w}, pdf[4] = {p4.x, p4.y, p4.z, p4.w};
        double s = 0;
        for (int i = 0; i < 4; i++) {
            assert_true(lam[i] >= 360.0f && lam[i] <= 830.0f && pdf[i] > 0.0f);
            s += spt_cie_y(lam[i]) / pdf[i];
        }
        sum += s / 4;
    }
    assert_close_rel(sum / paths, SPT_CIE_Y_INTEGRAL, 1e-3);
    double cdf = 0, h = 0.01;
    for (double l = 360.0; l < 830.0 - 1e-9; l += h) {
        double mid = l + h / 2;
        cdf += spt_wavelength_pdf((float)mid) * h;
        if (fmod(l - 360.0, 10.0) < h / 2) {
            /* the sample of u = cdf(l + h) should be l + h */
            double u = cdf;
            vec4 l4, p4;
            spt_sample_wavelengths((float)u, &l4, &p4);
            if (u < 1.0)
                assert_close(l4.x, l + h, 0.05);
        }
    }
    assert_close(cdf, 1.0, 1e-4);
    assert_true(spt_wavelength_pdf(359.0f) == 0.0f && spt_wavelength_pdf(831.0f) == 0.0f);
}

/* The spectral estimate's own noise: a grey surface of reflectance 0.5 under D65
 * (radiance 1), whose every path has the same radiance spectrum 0.5 D65(l), so
 * the spread of a path's linear sRGB comes from its four wavelengths alone. Over
 * u uniform (a fine grid, exact up to quadrature), the mean is 0.5 per channel
 * and the relative standard deviation of one path stays at most 0.25 in every
 * channel (it measured 0.22, 0.15, 0.20 in R, G, B; a density fitted to ybar,
 * pbrt-v4's visible-wavelength density, gives 0.15, 0.03 and 0.58: blue noise
 * dominates a grey image). */
TEST(test_wavelength_noise_flat_d65)
{
    enum { J = 1 << 16 };
    double sum[3] = {0, 0, 0}, sq[3] = {0, 0, 0};
    for (int j = 0; j < J; j++) {
        vec4 l4, p4;
        spt_sample_wavelengths((float)((j + 0.5) / J), &l4, &p4);
        float lam[SPT_NUM_LAMBDA] = {l4.x, l4.y, l4.z, l4.w}, pdf[SPT_NUM_LAMBDA] = {p4.x, p4.y, p4.z, p4.w};
        double xyz[3] = {0, 0, 0}, rgb[3];
        for (int i = 0; i < SPT_NUM_LAMBDA; i++) {
            double w = 0.5 * spt_d65_norm(lam[i]) / pdf[i] / (SPT_NUM_LAMBDA * SPT_CIE_Y_INTEGRAL);
            xyz[0] += w * spt_cie_x(lam[i]);
            xyz[1] += w * spt_cie_y(lam[i]);
            xyz[2] += w * spt_cie_z(lam[i]);
        }
        xyz_to_linear_srgb(xyz, rgb);
        for (int c = 0; c < 3; c++) {
            sum[c] += rgb[c];
            sq[c] += rgb[c] * rgb[c];
        }
    }
    for (int c = 0; c < 3; c++) {
        double mean = sum[c] / J, sd = sqrt(fmax(sq[c] / J - mean * mean, 0.0));
        print_message("grey 0.5 under D65, channel %d: mean %.5f, per-path std %.4f (relative %.3f)\n", c,
                      mean, sd, sd / mean);
        assert_close(mean, 0.5, 2e-3);
        assert_true(sd / mean <= 0.25);
    }
}

/* Writes text to a fresh temporary file and returns its path (static buffer). */
static const char *temp_file(const char *text)
{
    static char path[64];
    strcpy(path, "/tmp/spt_spectrum_XXXXXX");
    int fd = mkstemp(path);
    assert_true(fd >= 0);
    FILE *f = fdopen(fd, "w");
    fputs(text, f);
    fclose(f);
    return path;
}

/* A CSV of this text must be rejected with a message naming the file and this line. */
static void csv_rejected_at_line(const char *text, int line)
{
    const char *p = temp_file(text);
    Spd s;
    SptError e = {0};
    char want[128];
    assert_int_equal(spd_read_csv(&s, p, &e), SPT_EXIT_INPUT);
    snprintf(want, sizeof want, "%s: line %d:", p, line);
    if (!strstr(e.msg, want))
        fail_msg("message '%s' does not name '%s'", e.msg, want);
    unlink(p);
}

/* CSV: header, comments, blank lines, irregular spacing; the bad line's number. */
TEST(test_csv)
{
    const char *p = temp_file("# a comment\nwavelength_nm,value\n400,1\n\n410, 3 # note\n"
                              "  # indented comment\n450,0.5\n451.5,2\n");
    Spd s;
    SptError e = {0};
    assert_int_equal(spd_read_csv(&s, p, &e), 0);
    assert_int_equal(s.count, 4);
    assert_close(spd_eval(&s, 405), 2.0, 1e-12);
    assert_close(spd_eval(&s, 430), 1.75, 1e-12);
    assert_close(spd_eval(&s, 451), 1.5, 1e-12);
    assert_close(spd_eval(&s, 399.9), 0.0, 0);
    assert_close(spd_eval(&s, 452), 0.0, 0);
    spd_free(&s);
    unlink(p);

    csv_rejected_at_line("wavelength_nm,value\n400,1\n410,2\n420;3\n430,4\n", 4);
    csv_rejected_at_line("400,1\n410,abc\n", 2);

    p = temp_file("400,1\n400,2\n");
    assert_int_equal(spd_read_csv(&s, p, &e), SPT_EXIT_INPUT);
    unlink(p);
    assert_int_equal(spd_read_csv(&s, "/nonexistent/x.csv", &e), SPT_EXIT_INPUT);
    assert_non_null(strstr(e.msg, "/nonexistent/x.csv"));
    assert_int_equal(spd_parse(&s, "D66", &e), SPT_EXIT_INPUT);
    assert_int_equal(spd_parse(&s, "blackbody:-5", &e), SPT_EXIT_INPUT);
}

/* Mercury: six lines at the published wavelengths (the issue rounds them to 0.1 nm); spd_to_grid keeps their power. */
TEST(test_mercury)
{
    Spd s;
    assert_int_equal(spd_named(&s, "mercury", NULL), 0);
    const double want[6] = {404.7, 407.8, 435.8, 546.1, 577.0, 579.0};
    assert_int_equal(s.line_count, 6);
    double total = 0;
    for (int i = 0; i < 6; i++) {
        assert_close(s.line_nm[i], want[i], 0.07); /* rounded to 0.1 nm */
        total += s.line_power[i];
    }
    float grid[SPT_CIE_SAMPLES];
    spd_to_grid(&s, grid);
    double g = 0;
    for (int i = 0; i < SPT_CIE_SAMPLES; i++)
        g += grid[i];
    assert_close_rel(g, total, 1e-6);
    spd_free(&s);
}

TEST_MAIN("spectrum", NULL, NULL)
