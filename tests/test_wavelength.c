/* The sampling of a path's wavelengths (kernels/sample/wavelength.h,
 * spt_sample_wavelengths, the function the kernels call), on the host and on
 * the OpenCL device: the table of kernels/sample/wavelength_pdf.h follows its
 * target density, the wavelengths follow the table's density (chi-square
 * through tests/chi2.h, docs/testing.md), the densities returned are the
 * table's, the four wavelengths of a path are stratified, and the device gives
 * what the host gives. */
#include "test_util.h"
#include <stdlib.h>
#include <string.h>
#include "chi2.h"
#include "test_cl_util.h"
#include "sample/wavelength.h"
#include "spectrum/spectrum.h"

/* The density the wavelength table is made to follow (tools/gen_wavelength_pdf.py),
 * unnormalised, written out from its definition: the Euclidean norm of the
 * linear sRGB colour matching functions (the CIE 1931 functions through the
 * XYZ -> sRGB matrix of IEC 61966-2-1) plus 1% of its largest value. */
static double wavelength_target(double l)
{
    static const double m[3][3] = {{3.2406, -1.5372, -0.4986}, {-0.9689, 1.8758, 0.0415},
                                   {0.0557, -0.2040, 1.0570}};
    static double top = 0.0;
    double xyz[3] = {spt_cie_x((float)l), spt_cie_y((float)l), spt_cie_z((float)l)}, n2 = 0.0;
    for (int c = 0; c < 3; c++) {
        double v = m[c][0] * xyz[0] + m[c][1] * xyz[1] + m[c][2] * xyz[2];
        n2 += v * v;
    }
    if (top == 0.0) {
        for (int i = SPT_CIE_LAMBDA_MIN; i <= SPT_CIE_LAMBDA_MAX; i++) {
            double x[3] = {spt_cie_x((float)i), spt_cie_y((float)i), spt_cie_z((float)i)}, q = 0.0;
            for (int c = 0; c < 3; c++) {
                double v = m[c][0] * x[0] + m[c][1] * x[1] + m[c][2] * x[2];
                q += v * v;
            }
            top = fmax(top, sqrt(q));
        }
    }
    return sqrt(n2) + 0.01 * top;
}

/* The density the table samples, in double: bin k of SPT_WL_INV_CDF holds
 * probability 1 / SPT_WL_BINS, spread evenly over it. */
static double wavelength_pdf_ref(double l)
{
    for (int k = 0; k < SPT_WL_BINS; k++)
        if (l >= SPT_WL_INV_CDF[k] && l < SPT_WL_INV_CDF[k + 1])
            return 1.0 / (SPT_WL_BINS * ((double)SPT_WL_INV_CDF[k + 1] - SPT_WL_INV_CDF[k]));
    return l == SPT_WL_INV_CDF[SPT_WL_BINS]
               ? 1.0 / (SPT_WL_BINS * ((double)SPT_WL_INV_CDF[SPT_WL_BINS] - SPT_WL_INV_CDF[SPT_WL_BINS - 1]))
               : 0.0;
}

/* The CDF of that density at l. */
static double wavelength_cdf_ref(double l)
{
    for (int k = 0; k < SPT_WL_BINS; k++)
        if (l < SPT_WL_INV_CDF[k + 1])
            return (k + (l - SPT_WL_INV_CDF[k]) / ((double)SPT_WL_INV_CDF[k + 1] - SPT_WL_INV_CDF[k])) /
                   SPT_WL_BINS;
    return 1.0;
}

/* The wavelengths under test, four per path: those of the host or of the device. */
enum { PATHS = 1 << 18 };
static float path_u[PATHS], path_lambda[4 * PATHS], path_pdf[4 * PATHS];

/* The host's spt_sample_wavelengths for path_u into path_lambda, path_pdf. */
static void run_host(void)
{
    for (uint32_t i = 0; i < PATHS; i++) {
        vec4 l, p;
        spt_sample_wavelengths(path_u[i], &l, &p);
        const float lv[4] = {l.x, l.y, l.z, l.w}, pv[4] = {p.x, p.y, p.z, p.w};
        memcpy(path_lambda + 4 * i, lv, sizeof lv);
        memcpy(path_pdf + 4 * i, pv, sizeof pv);
    }
}

/* Sample i: wavelength i % 4 of path i / 4, mapped through the density's CDF,
 * as (cdf(l), 0.5): uniform when the wavelengths follow the density. (A
 * chi-square in nm would need the cell masses of a density with steps inside
 * the cells, which a quadrature gets wrong.) */
static int wavelength_sample(void *ctx, uint32_t i, double p[3])
{
    (void)ctx;
    p[0] = wavelength_cdf_ref(path_lambda[i]);
    p[1] = 0.5;
    return 1;
}

static double unit_pdf(void *ctx, const double p[3])
{
    (void)ctx;
    (void)p;
    return 1.0;
}

/* The checks of the wavelengths in path_lambda, path_pdf for path_u (from
 * `who`): chi-square of all 2^20 against the table's density (res 250 so that
 * cells do not line up with the bins); each in 360..830 nm with the table's
 * density as its pdf (away from bin edges, where float rounding may pick the
 * neighbour bin); wavelength k of a path at CDF value (u + k/4) mod 1, so the
 * four are stratified. */
static void check_wavelengths(const char *who)
{
    Chi2Grid g = chi2_plane(who, 0.0, 1.0, 0.0, 1.0, 250, 1, 2, wavelength_sample, unit_pdf, NULL);
    g.samples = 4 * PATHS;
    chi2_require(&g);
    uint32_t checked = 0;
    for (uint32_t i = 0; i < 4u * PATHS; i++) {
        float l = path_lambda[i], u = path_u[i / 4];
        int k = (int)(i % 4);
        if (!(l >= 360.0f && l <= 830.0f))
            fail_msg("%s: path %u, wavelength %d = %.4f nm", who, i / 4, k, l);
        if (wavelength_pdf_ref(l + 1e-3) == wavelength_pdf_ref(l - 1e-3)) {
            assert_close_rel(path_pdf[i], wavelength_pdf_ref(l), 1e-5);
            checked++;
        }
        double dist = fabs(wavelength_cdf_ref(l) - fmod((double)u + k / 4.0, 1.0));
        dist = fmin(dist, 1.0 - dist);
        if (!(dist < 1e-5))
            fail_msg("%s: u = %.7f, wavelength %d = %.4f nm: CDF off by %.3g", who, u, k, l, dist);
    }
    /* Nearly every wavelength lies away from a bin edge. */
    assert_true(checked > 4u * PATHS / 10u * 9u);
}

/* The table spans 360..830 nm and each of its bins holds 1 / SPT_WL_BINS of the
 * target density (within 0.1%: the table's 4 decimals); spt_wavelength_pdf is
 * the table's density and integrates to 1; the host's wavelengths pass
 * check_wavelengths. */
TEST(test_wavelength_sampling)
{
    assert_true(SPT_WL_INV_CDF[0] == (float)SPT_CIE_LAMBDA_MIN);
    assert_true(SPT_WL_INV_CDF[SPT_WL_BINS] == (float)SPT_CIE_LAMBDA_MAX);
    /* Simpson's rule over each bin, 256 panels. */
    double total = 0.0, bin[SPT_WL_BINS] = {0};
    for (int k = 0; k < SPT_WL_BINS; k++) {
        double a = SPT_WL_INV_CDF[k], w = ((double)SPT_WL_INV_CDF[k + 1] - a) / 256.0;
        for (int j = 0; j <= 256; j++)
            bin[k] += (j == 0 || j == 256 ? 1.0 : (j % 2 ? 4.0 : 2.0)) * wavelength_target(a + j * w);
        bin[k] *= w / 3.0;
        total += bin[k];
    }
    for (int k = 0; k < SPT_WL_BINS; k++)
        if (fabs(bin[k] / total * SPT_WL_BINS - 1.0) > 1e-3)
            fail_msg("wavelength bin %d [%.4f, %.4f] nm holds %.6f of the target density, expected %.6f", k,
                     SPT_WL_INV_CDF[k], SPT_WL_INV_CDF[k + 1], bin[k] / total, 1.0 / SPT_WL_BINS);
    /* spt_wavelength_pdf: pointwise (between bin edges), and its integral (0.01 nm). */
    double sum = 0.0;
    for (int j = 0; j < 47000; j++) {
        double l = 360.0 + 0.01 * (j + 0.5);
        float pk = spt_wavelength_pdf((float)l);
        assert_close_rel(pk, wavelength_pdf_ref((float)l), 1e-5);
        sum += pk * 0.01;
    }
    assert_close(sum, 1.0, 1e-4);
    assert_close(spt_wavelength_pdf(359.0f), 0.0, 0.0);
    assert_close(spt_wavelength_pdf(831.0f), 0.0, 0.0);
    for (uint32_t i = 0; i < PATHS; i++)
        path_u[i] = test_uniform(((uint64_t)8 << 40) + i);
    run_host();
    check_wavelengths("host wavelengths, through the CDF");
}

static const char device_src[] =
    "#include \"sample/wavelength.h\"\n"
    "__kernel void k_wavelengths(__global const float *u, __global float *out, int n)\n"
    "{\n"
    "    int i = get_global_id(0);\n"
    "    float4 l, p;\n"
    "    spt_sample_wavelengths(u[i], &l, &p);\n"
    "    vstore4(l, 2 * i, out);\n"
    "    vstore4(p, 2 * i + 1, out);\n"
    "}\n";

/* The same on the default OpenCL device (a GPU when there is one): its
 * wavelengths pass check_wavelengths, and equal the host's to float precision
 * (OpenCL allows division within 2.5 ulp and contraction into an FMA). Skipped
 * without an OpenCL device. */
TEST(test_device_wavelengths)
{
    TestCl cl = test_cl_open();
    for (uint32_t i = 0; i < PATHS; i++)
        path_u[i] = test_uniform(((uint64_t)10 << 40) + i);
    static float out[8 * PATHS], dev_lambda[4 * PATHS], dev_pdf[4 * PATHS];
    const TestClArg in = {path_u, sizeof path_u};
    test_cl_run(&cl, device_src, NULL, "sample/wavelength.h", "k_wavelengths", &in, 1, out, sizeof out, PATHS,
                0);
    test_cl_close(&cl);
    for (uint32_t i = 0; i < PATHS; i++) {
        memcpy(dev_lambda + 4 * i, out + 8 * i, 4 * sizeof(float));
        memcpy(dev_pdf + 4 * i, out + 8 * i + 4, 4 * sizeof(float));
    }
    memcpy(path_lambda, dev_lambda, sizeof dev_lambda);
    memcpy(path_pdf, dev_pdf, sizeof dev_pdf);
    check_wavelengths("device wavelengths, through the CDF");
    run_host();
    for (uint32_t i = 0; i < 4u * PATHS; i++)
        if (!(fabsf(dev_lambda[i] - path_lambda[i]) <= 1e-6f * path_lambda[i] &&
              fabsf(dev_pdf[i] - path_pdf[i]) <= 1e-6f * path_pdf[i]))
            fail_msg("path %u, wavelength %u: device %.9g nm, pdf %.9g; host %.9g nm, pdf %.9g", i / 4, i % 4,
                     dev_lambda[i], dev_pdf[i], path_lambda[i], path_pdf[i]);
}

TEST_MAIN("wavelength", NULL, NULL)
