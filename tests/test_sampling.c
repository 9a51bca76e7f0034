/* kernels/sample/sampling.h warps and src/core/distribution.c distributions against their pdfs,
 * plus the chi-square helper (tests/chi2.h) itself. Uniform numbers come from a
 * generator local to this file, so these tests do not rest on kernels/sample/rng.h. */
#include "test_util.h"

#include <stdlib.h>
#include <string.h>

#include "chi2.h"
#include "core/distribution.h"
#include "sample/sampling.h"

/* Chi-square tests expected to pass in this binary, for the Sidak correction. */
#define SAMPLING_CHI2_TESTS 7

/* The two uniforms of sample i of a test with this stream number. */
static void test_uniform2(uint32_t stream, uint32_t i, float *u1, float *u2)
{
    uint64_t base = ((uint64_t)stream << 40) + 2u * (uint64_t)i;
    *u1 = test_uniform(base);
    *u2 = test_uniform(base + 1u);
}

/* Sample i of a direction sampler of two uniforms, drawn from this stream. */
static int direction_sample(uint32_t stream, uint32_t i, vec3 (*sampler)(float, float),
                            double p[3])
{
    float u1, u2;
    test_uniform2(stream, i, &u1, &u2);
    vec3 d = sampler(u1, u2);
    p[0] = d.x;
    p[1] = d.y;
    p[2] = d.z;
    return 1;
}

/* ---- The chi-square helper ---------------------------------------------------- */

/* The survival function against closed forms and published table values. */
TEST(test_chi2_survival_function)
{
    /* dof 2: Q = exp(-x/2). dof 1: Q = erfc(sqrt(x/2)). */
    for (double x = 0.01; x < 60.0; x *= 1.7) {
        assert_close_rel(chi2_survival(x, 2.0), exp(-0.5 * x), 1e-12);
        assert_close_rel(chi2_survival(x, 1.0), erfc(sqrt(0.5 * x)), 1e-10);
    }
    /* Upper quantiles from statistical tables (Abramowitz and Stegun 26.8). */
    assert_close(chi2_survival(3.841458820694124, 1.0), 0.05, 1e-9);
    assert_close(chi2_survival(23.209251158954356, 10.0), 0.01, 1e-9);
    assert_close(chi2_survival(9.341817765591966, 10.0), 0.5, 1e-9);
    /* Even dof 2k: Q = exp(-x/2) sum_{j<k} (x/2)^j / j!, summed in logs; covers the
     * large-dof regime the grid tests use, both sides of the series/fraction
     * switch. */
    const double dof = 1000.0, xs[3] = {900.0, 1000.0, 1100.0};
    for (int t = 0; t < 3; t++) {
        double h = 0.5 * xs[t], sum = 0.0;
        for (int j = 0; j < (int)(dof / 2); j++)
            sum += exp(-h + j * log(h) - lgamma(j + 1.0));
        assert_close_rel(chi2_survival(xs[t], dof), sum, 1e-9);
    }
    assert_close(chi2_sidak(0.01, 1), 0.01, 1e-15);
    assert_close(1.0 - pow(1.0 - chi2_sidak(0.01, 10), 10), 0.01, 1e-12);
}

/* Samples of the cosine-weighted hemisphere, for the negative control and the
 * real test. */
static int cosine_sample(void *ctx, uint32_t i, double p[3])
{
    (void)ctx;
    return direction_sample(1, i, spt_sample_cosine_hemisphere, p);
}

/* Density of the uniform hemisphere, per steradian. */
static double uniform_hemisphere_pdf(void *ctx, const double p[3])
{
    (void)ctx;
    return p[2] >= 0.0 ? 1.0 / (2.0 * M_PI) : 0.0;
}

/* A wrong pdf must be rejected: cosine-distributed samples against the uniform
 * hemisphere density, and a sampler that covers half the domain. */
TEST(test_chi2_rejects_wrong_pdf)
{
    Chi2Grid g = chi2_sphere("cosine samples against the uniform pdf", 32, 32, 0, cosine_sample,
                             uniform_hemisphere_pdf, NULL);
    g.samples = 100000;
    Chi2Result r;
    assert_false(chi2_grid_run(&g, &r));
    assert_true(r.pvalue < 1e-6);
    print_message("  (expected failure) %s\n", r.message);

    double obs[4] = {0, 50, 50, 0}, expct[4] = {25, 25, 25, 25};
    assert_false(chi2_test_counts("half the cells", obs, expct, 4, 0.01, &r));
    /* Samples in a cell of expected count 0 fail outright. */
    double obs2[3] = {50, 49, 1}, exp2[3] = {50, 50, 0};
    assert_false(chi2_test_counts("zero cell", obs2, exp2, 3, 0.01, &r));
}

/* ---- Directions ------------------------------------------------------------------ */

/* Density of the cosine-weighted hemisphere, per steradian. */
static double cosine_pdf(void *ctx, const double p[3])
{
    (void)ctx;
    return p[2] > 0.0 ? p[2] / M_PI : 0.0;
}

/* Sample i of spt_sample_uniform_hemisphere. */
static int uniform_hemisphere_sample(void *ctx, uint32_t i, double p[3])
{
    (void)ctx;
    return direction_sample(2, i, spt_sample_uniform_hemisphere, p);
}

/* Sample i of spt_sample_uniform_sphere. */
static int uniform_sphere_sample(void *ctx, uint32_t i, double p[3])
{
    (void)ctx;
    return direction_sample(3, i, spt_sample_uniform_sphere, p);
}

/* Density of the uniform sphere, per steradian. */
static double uniform_sphere_pdf(void *ctx, const double p[3])
{
    (void)ctx;
    (void)p;
    return 1.0 / (4.0 * M_PI);
}

/* Runs a direction test on a 32 x 32 grid in (phi, cos theta) and checks the
 * analytic pdf integrates to 1 over the sphere. */
static void run_direction_test(const char *name, int (*sample)(void *, uint32_t, double[3]),
                               double (*pdf)(void *, const double[3]))
{
    Chi2Grid g = chi2_sphere(name, 32, 32, SAMPLING_CHI2_TESTS, sample, pdf, NULL);
    Chi2Result r = chi2_require(&g);
    assert_close(r.integral, 1.0, 1e-6);
}

/* Chi-square of the cosine-weighted hemisphere; its pdf function. */
TEST(test_cosine_hemisphere)
{
    run_direction_test("cosine hemisphere", cosine_sample, cosine_pdf);
    /* The kernel's pdf function agrees with the analytic density. */
    for (float c = -0.5f; c <= 1.0f; c += 0.125f)
        assert_close(spt_pdf_cosine_hemisphere(c), c > 0.0f ? c / M_PI : 0.0, 1e-7);
}

/* Chi-square of the uniform hemisphere; its pdf function. */
TEST(test_uniform_hemisphere)
{
    run_direction_test("uniform hemisphere", uniform_hemisphere_sample, uniform_hemisphere_pdf);
    assert_close(spt_pdf_uniform_hemisphere(0.3f), 1.0 / (2.0 * M_PI), 1e-8);
    assert_close(spt_pdf_uniform_hemisphere(-0.3f), 0.0, 0.0);
}

/* Chi-square of the uniform sphere; its pdf function. */
TEST(test_uniform_sphere)
{
    run_direction_test("uniform sphere", uniform_sphere_sample, uniform_sphere_pdf);
    assert_close(spt_pdf_uniform_sphere(), 1.0 / (4.0 * M_PI), 1e-8);
}

/* The directions are unit length, within the hemisphere for the hemisphere maps,
 * also at the corners of the unit square. */
TEST(test_directions_are_unit)
{
    const float us[5] = {0.0f, 0.25f, 0.5f, 0.75f, SPT_ONE_MINUS_EPSILON};
    for (int i = 0; i < 5; i++)
        for (int j = 0; j < 5; j++) {
            vec3 d[3] = {spt_sample_cosine_hemisphere(us[i], us[j]),
                         spt_sample_uniform_hemisphere(us[i], us[j]),
                         spt_sample_uniform_sphere(us[i], us[j])};
            for (int k = 0; k < 3; k++) {
                assert_close(v3_length(d[k]), 1.0, 1e-6);
                if (k < 2)
                    assert_true(d[k].z >= 0.0f);
            }
        }
}

/* ---- Disk and triangle ----------------------------------------------------------- */

/* A uniform disk point maps to a uniform point (r^2, phi) of [0,1) x [0, 2 pi). */
static int disk_polar_sample(void *ctx, uint32_t i, double p[3])
{
    (void)ctx;
    float u1, u2;
    test_uniform2(4, i, &u1, &u2);
    vec3 d = spt_sample_concentric_disk(u1, u2);
    p[0] = (double)d.x * d.x + (double)d.y * d.y;
    p[1] = atan2(d.y, d.x);
    if (p[1] < 0.0)
        p[1] += 2.0 * M_PI;
    return d.z == 0.0f;
}

/* Density of a uniform disk point in (r^2, phi). */
static double disk_polar_pdf(void *ctx, const double p[3])
{
    (void)ctx;
    (void)p;
    return 1.0 / (2.0 * M_PI);
}

/* Chi-square of the concentric disk in (r^2, phi). */
TEST(test_concentric_disk)
{
    Chi2Grid g = chi2_plane("concentric disk, in (r^2, phi)", 0.0, 1.0, 0.0, 2.0 * M_PI, 32, 32,
                            SAMPLING_CHI2_TESTS, disk_polar_sample, disk_polar_pdf, NULL);
    Chi2Result r = chi2_require(&g);
    assert_close(r.integral, 1.0, 1e-9);
}

/* A triangle inside the unit square, not aligned with the grid. */
static const double tri[3][2] = {{0.1, 0.2}, {0.9, 0.35}, {0.3, 0.95}};

/* Sample i of spt_sample_triangle on tri, as (x, y). */
static int triangle_sample(void *ctx, uint32_t i, double p[3])
{
    (void)ctx;
    float u1, u2;
    test_uniform2(5, i, &u1, &u2);
    vec3 q = spt_sample_triangle(v3((float)tri[0][0], (float)tri[0][1], 0.0f),
                                 v3((float)tri[1][0], (float)tri[1][1], 0.0f),
                                 v3((float)tri[2][0], (float)tri[2][1], 0.0f), u1, u2);
    p[0] = q.x;
    p[1] = q.y;
    return 1;
}

/* Area of tri, in double precision. */
static double triangle_area_d(void)
{
    return 0.5 * fabs((tri[1][0] - tri[0][0]) * (tri[2][1] - tri[0][1]) -
                      (tri[2][0] - tri[0][0]) * (tri[1][1] - tri[0][1]));
}

/* Keeps the part of polygon (in, n vertices) with s * (p[axis] - c) >= 0
 * (Sutherland-Hodgman); returns the new vertex count. */
static int clip_polygon(double (*in)[2], int n, double (*out)[2], int axis, double c, double s)
{
    int m = 0;
    for (int i = 0; i < n; i++) {
        const double *a = in[i], *b = in[(i + 1) % n];
        double da = s * (a[axis] - c), db = s * (b[axis] - c);
        if (da >= 0.0) {
            out[m][0] = a[0];
            out[m][1] = a[1];
            m++;
        }
        if ((da >= 0.0) != (db >= 0.0)) {
            double t = da / (da - db);
            out[m][0] = a[0] + t * (b[0] - a[0]);
            out[m][1] = a[1] + t * (b[1] - a[1]);
            m++;
        }
    }
    return m;
}

/* Exact probability of a cell: the area of its intersection with the triangle
 * (polygon clipping and the shoelace formula) over the triangle's area. */
static double triangle_cell_prob(void *ctx, double x0, double x1, double y0, double y1)
{
    (void)ctx;
    double a[16][2], b[16][2];
    int n = 3;
    memcpy(a, tri, sizeof tri);
    n = clip_polygon(a, n, b, 0, x0, 1.0);
    n = clip_polygon(b, n, a, 0, x1, -1.0);
    n = clip_polygon(a, n, b, 1, y0, 1.0);
    n = clip_polygon(b, n, a, 1, y1, -1.0);
    double area2 = 0.0;
    for (int i = 0; i < n; i++)
        area2 += a[i][0] * a[(i + 1) % n][1] - a[(i + 1) % n][0] * a[i][1];
    return 0.5 * fabs(area2) / triangle_area_d();
}

/* Area density of tri. */
static double triangle_pdf(void *ctx, const double p[3])
{
    (void)ctx;
    (void)p;
    return 1.0 / triangle_area_d(); /* unused: cell_prob is exact */
}

/* Chi-square of triangle sampling with exact cell probabilities; the
 * barycentrics and the area function. */
TEST(test_triangle_area_sampling)
{
    Chi2Grid g = chi2_plane("triangle by area", 0.0, 1.0, 0.0, 1.0, 32, 32, SAMPLING_CHI2_TESTS,
                            triangle_sample, triangle_pdf, NULL);
    g.cell_prob = triangle_cell_prob;
    Chi2Result r = chi2_require(&g);
    assert_close(r.integral, 1.0, 1e-9);
    /* Barycentrics are non-negative and sum to 1. */
    for (uint32_t i = 0; i < 10000; i++) {
        float u1, u2;
        test_uniform2(6, i, &u1, &u2);
        vec3 b = spt_sample_triangle_bary(u1, u2);
        assert_true(b.x >= 0.0f && b.y >= 0.0f && b.z >= -1e-7f);
        assert_close(b.x + b.y + b.z, 1.0, 1e-6);
    }
}

/* ---- MIS ------------------------------------------------------------------------- */

/* Power heuristic values against a^2 / (a^2 + b^2), and its edge cases. */
TEST(test_power_heuristic)
{
    assert_close(spt_power_heuristic(1.0f, 1.0f), 0.5, 1e-7);
    assert_close(spt_power_heuristic(2.0f, 1.0f), 0.8, 1e-7);
    assert_close(spt_power_heuristic(1.0f, 3.0f), 0.1, 1e-7);
    assert_close(spt_power_heuristic(1.0f, 0.0f), 1.0, 0.0);
    assert_close(spt_power_heuristic(0.0f, 1.0f), 0.0, 0.0);
    assert_close(spt_power_heuristic(0.0f, 0.0f), 0.0, 0.0);
    /* No overflow for huge pdfs, and an infinite (delta) pdf wins. */
    assert_close(spt_power_heuristic(1e30f, 1e30f), 0.5, 1e-7);
    assert_close(spt_power_heuristic(3e30f, 1e30f), 0.9, 1e-6);
    assert_close(spt_power_heuristic(INFINITY, 1.0f), 1.0, 0.0);
    assert_close(spt_power_heuristic(1.0f, INFINITY), 0.0, 0.0);
    /* The two weights of a pair sum to 1. */
    for (int i = 1; i < 100; i++) {
        float a = 0.37f * (float)i, b = 1.0f / (float)i;
        double wa = (double)a * a / ((double)a * a + (double)b * b);
        assert_close(spt_power_heuristic(a, b), wa, 1e-6);
        assert_close(spt_power_heuristic(a, b) + spt_power_heuristic(b, a), 1.0, 1e-6);
    }
}

/* ---- Discrete distributions ------------------------------------------------------ */

/* Light powers with every kind of unusable weight mixed in. */
#define LIGHTS 64
/* Fills w[0..LIGHTS-1]. */
static void light_weights(float *w)
{
    for (int i = 0; i < LIGHTS; i++)
        w[i] = (float)((i * 37) % 101) * 0.5f + 0.01f * (float)i;
    w[0] = 0.0f;
    w[5] = -3.0f;
    w[9] = NAN;
    w[10] = INFINITY;
    w[11] = -INFINITY;
    w[20] = 0.0f;
    w[21] = 1e-3f;
    w[LIGHTS - 1] = 0.0f;
}

/* Whether distrib_build counts weight w. */
static int light_usable(float w)
{
    return isfinite(w) && w > 0.0f;
}

/* The CDF table: bounds, monotonicity, probabilities equal weight / total. */
TEST(test_distrib_table)
{
    float w[LIGHTS];
    light_weights(w);
    Distrib d;
    assert_int_equal(distrib_build(&d, w, LIGHTS), 1);
    double total = 0.0;
    uint32_t positive = 0;
    for (int i = 0; i < LIGHTS; i++)
        if (light_usable(w[i])) {
            total += w[i];
            positive++;
        }
    assert_int_equal(d.n, LIGHTS);
    assert_int_equal(d.positive, positive);
    assert_close_rel(d.total, total, 1e-15);
    assert_true(d.cdf[0] == 0.0f);
    assert_true(d.cdf[LIGHTS] == 1.0f);
    for (int i = 0; i < LIGHTS; i++) {
        assert_true(d.cdf[i + 1] >= d.cdf[i]);
        double want = light_usable(w[i]) ? w[i] / total : 0.0;
        float p = distrib_prob(&d, i);
        if (want == 0.0)
            assert_true(p == 0.0f);
        else
            assert_close(p, want, 1.5e-7);
        /* The kernel's lookup agrees. */
        assert_true(spt_discrete_pdf(d.cdf, (spt_u32)i) == p);
    }
    distrib_free(&d);
    assert_null(d.cdf);
}

/* Sampling by power: counts against weight/total, zero weights never chosen, the
 * probability returned is the entry's, and the remapped uniform is uniform. */
TEST(test_distrib_sampling)
{
    float w[LIGHTS];
    light_weights(w);
    Distrib d;
    distrib_build(&d, w, LIGHTS);
    enum { REMAP_BINS = 100 };
    static double obs[LIGHTS], expct[LIGHTS], robs[REMAP_BINS], rexp[REMAP_BINS];
    memset(obs, 0, sizeof obs);
    memset(robs, 0, sizeof robs);
    const uint32_t n = CHI2_DEFAULT_SAMPLES;
    for (uint32_t s = 0; s < n; s++) {
        float prob, ur;
        spt_i32 i = spt_discrete_sample(d.cdf, LIGHTS, test_uniform(((uint64_t)7 << 40) + s),
                                        &prob, &ur);
        assert_true(i >= 0 && i < LIGHTS);
        if (!light_usable(w[i]))
            fail_msg("picked entry %d of weight %g", i, w[i]);
        if (prob != distrib_prob(&d, (uint32_t)i))
            fail_msg("entry %d: probability %.9g, table says %.9g", i, prob,
                     distrib_prob(&d, (uint32_t)i));
        assert_true(ur >= 0.0f && ur < 1.0f);
        obs[i] += 1.0;
        robs[(int)(ur * REMAP_BINS)] += 1.0;
    }
    for (int i = 0; i < LIGHTS; i++)
        expct[i] = light_usable(w[i]) ? n * (w[i] / d.total) : 0.0;
    for (int b = 0; b < REMAP_BINS; b++)
        rexp[b] = (double)n / REMAP_BINS;
    double alpha = chi2_sidak(0.01, SAMPLING_CHI2_TESTS);
    Chi2Result r;
    chi2_test_counts("light selection by power", obs, expct, LIGHTS, alpha, &r);
    require_pass(&r);
    chi2_test_counts("remapped uniform", robs, rexp, REMAP_BINS, alpha, &r);
    require_pass(&r);
    distrib_free(&d);
}

/* Edge cases: boundaries of u, a single entry, empty distributions. */
TEST(test_distrib_edges)
{
    float prob, ur;
    /* u = 0 and u just below 1 (and out-of-range u) pick the first and last
     * usable entries, never the zero ones around them. */
    float w[6] = {0.0f, 2.0f, 0.0f, 1.0f, 1.0f, 0.0f};
    Distrib d;
    assert_int_equal(distrib_build(&d, w, 6), 1);
    assert_int_equal(spt_discrete_sample(d.cdf, 6, 0.0f, &prob, &ur), 1);
    assert_close(prob, 0.5, 1e-7);
    assert_close(ur, 0.0, 0.0);
    assert_int_equal(spt_discrete_sample(d.cdf, 6, SPT_ONE_MINUS_EPSILON, &prob, 0), 4);
    assert_close(prob, 0.25, 1e-7);
    assert_int_equal(spt_discrete_sample(d.cdf, 6, 1.0f, &prob, 0), 4);
    assert_int_equal(spt_discrete_sample(d.cdf, 6, -1.0f, &prob, 0), 1);
    assert_int_equal(spt_discrete_sample(d.cdf, 6, NAN, &prob, 0), 1);
    assert_int_equal(spt_discrete_sample(d.cdf, 6, 0.5f, &prob, &ur), 3);
    assert_close(ur, 0.0, 1e-6);
    assert_int_equal(spt_discrete_sample(d.cdf, 6, 0.625f, &prob, &ur), 3);
    assert_close(ur, 0.5, 1e-6);
    distrib_free(&d);

    float one = 5.0f;
    assert_int_equal(distrib_build(&d, &one, 1), 1);
    assert_int_equal(spt_discrete_sample(d.cdf, 1, 0.7f, &prob, &ur), 0);
    assert_true(prob == 1.0f);
    assert_close(ur, 0.7, 1e-7);
    assert_close(d.total, 5.0, 0.0);
    distrib_free(&d);

    /* All weights unusable, or none: empty, sampling returns -1. */
    float bad[4] = {0.0f, -1.0f, NAN, INFINITY};
    assert_int_equal(distrib_build(&d, bad, 4), 0);
    assert_int_equal(d.positive, 0);
    assert_close(d.total, 0.0, 0.0);
    for (int i = 0; i <= 4; i++)
        assert_true(d.cdf[i] == 0.0f);
    prob = 1.0f;
    ur = 1.0f;
    assert_int_equal(spt_discrete_sample(d.cdf, 4, 0.3f, &prob, &ur), -1);
    assert_true(prob == 0.0f && ur == 0.0f);
    distrib_free(&d);
    assert_int_equal(distrib_build(&d, NULL, 0), 0);
    assert_int_equal(spt_discrete_sample(d.cdf, 0, 0.3f, &prob, 0), -1);
    distrib_free(&d);
}

/* The binary search agrees with a linear scan (the i with cdf[i] <= u <
 * cdf[i+1]) for many sizes, with runs of zero weights, and for u exactly on
 * table values. */
TEST(test_discrete_matches_linear_scan)
{
    float w[70];
    uint64_t r = 99;
    for (uint32_t n = 1; n <= 70; n++) {
        for (uint32_t i = 0; i < n; i++)
            w[i] = test_uniform(r++) < 0.35f ? 0.0f : test_uniform(r++) * 10.0f;
        w[(n * 7) % n] = 1.0f; /* at least one usable weight */
        Distrib d;
        assert_int_equal(distrib_build(&d, w, n), 1);
        for (uint32_t t = 0; t < 500 + n; t++) {
            float u = t < n ? d.cdf[t] : test_uniform(r++);
            if (u >= 1.0f)
                continue;
            uint32_t want = 0;
            while (!(u < d.cdf[want + 1]))
                want++;
            float prob;
            spt_i32 got = spt_discrete_sample(d.cdf, n, u, &prob, 0);
            if (got != (spt_i32)want)
                fail_msg("n = %u, u = %.9g: index %d, linear scan says %u", n, u, got, want);
            assert_true(w[want] > 0.0f && prob > 0.0f);
        }
        distrib_free(&d);
    }
}

/* Millions of entries: the double-precision sum keeps the table exact to float
 * rounding (a float running sum would stall once the total dwarfs an entry). */
TEST(test_distrib_large)
{
    const uint32_t n = 3000000;
    float *w = malloc(sizeof(float) * n);
    for (uint32_t i = 0; i < n; i++)
        w[i] = 1.0f + (float)(i % 3);
    Distrib d;
    assert_int_equal(distrib_build(&d, w, n), 1);
    assert_close(d.total, 6000000.0, 0.0);
    assert_true(d.cdf[n] == 1.0f);
    for (uint32_t i = 0; i < n; i += 1000) {
        /* cdf[i] = (i + i/3*3 + ...) / total: the exact prefix sum, then rounded. */
        double prefix = 0.0;
        uint32_t full = i / 3;
        prefix = 6.0 * full;
        for (uint32_t j = full * 3; j < i; j++)
            prefix += 1.0 + (double)(j % 3);
        assert_true(d.cdf[i] == (float)(prefix / d.total));
    }
    /* Entry 0 (weight 1 of 6e6) is picked by u just above 0 and has its weight. */
    float prob;
    assert_int_equal(spt_discrete_sample(d.cdf, n, 1e-8f, &prob, 0), 0);
    assert_close_rel(prob, 1.0 / 6e6, 1e-3);
    assert_int_equal(spt_discrete_sample(d.cdf, n, SPT_ONE_MINUS_EPSILON, &prob, 0),
                     (int)(n - 1));
    distrib_free(&d);
    free(w);
}

TEST_MAIN("sampling", NULL, NULL)
