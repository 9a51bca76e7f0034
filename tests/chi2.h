/* Chi-square goodness-of-fit tests of sampling routines against their pdfs, in the
 * spirit of Mitsuba 3's chi2.py and pbrt-v4's sampling tests (docs/testing.md).
 *
 * A sampler is run CHI2_DEFAULT_SAMPLES (10^6) times unless told otherwise; the
 * samples are binned on a 2D grid over a domain; expected counts come from the
 * pdf integrated numerically over each cell (Gauss-Legendre, CHI2_GL_NODES^2
 * interior nodes per cell, so a pdf that jumps on a cell edge, such as a
 * hemisphere's horizon, is integrated exactly) or from an exact cell
 * probability callback; cells with an expected count below 5 are pooled (sorted
 * by expected count, Mitsuba's rule); the statistic is compared with the
 * chi-square distribution at significance alpha (0.01) with a Sidak correction
 * for the number of tests in the binary. Samples where the pdf is zero, and
 * samples outside the domain or rejected by the sampler beyond what the pdf's
 * missing mass allows, fail the test.
 *
 * Domains:
 *  CHI2_PLANE:  points (p[0], p[1]) in [x0,x1] x [y0,y1]; pdf is per unit area.
 *  CHI2_SPHERE: unit directions p[0..2], binned in (phi in [0, 2 pi), cos theta in
 *               [-1, 1]), res_x cells in phi and res_y in cos theta; pdf is per
 *               steradian, which is also the density in (phi, cos theta) since
 *               d omega = d phi d cos(theta).
 *
 * Header only (static functions), for tests: include it after test_util.h. */
#ifndef SPT_CHI2_H
#define SPT_CHI2_H

#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define CHI2_DEFAULT_SAMPLES 1000000u
#define CHI2_MIN_EXPECTED 5.0
#define CHI2_GL_NODES 5

enum { CHI2_PLANE = 0, CHI2_SPHERE = 1 };

/* The outcome of one test; message says what was compared on failure. */
typedef struct Chi2Result {
    double stat;      /* the chi-square statistic */
    int dof;          /* degrees of freedom (cells after pooling, minus 1) */
    double pvalue;    /* P[chi2(dof) >= stat] */
    double alpha;     /* the per-test significance after the Sidak correction */
    double integral;  /* the pdf's integral over the domain (grid tests) */
    int passed;
    char message[512];
} Chi2Result;

/* Regularised upper incomplete gamma function Q(a, x) = Gamma(a, x) / Gamma(a),
 * a > 0, x >= 0: the series for P when x < a + 1, else Lentz's continued
 * fraction for Q (Numerical Recipes, 6.2), to about 1e-14 relative. */
static double chi2_gamma_q(double a, double x)
{
    if (!(x > 0.0))
        return 1.0;
    double lead = exp(-x + a * log(x) - lgamma(a));
    if (x < a + 1.0) {
        double ap = a, del = 1.0 / a, sum = del;
        for (int n = 0; n < 100000; n++) {
            ap += 1.0;
            del *= x / ap;
            sum += del;
            if (fabs(del) < fabs(sum) * 1e-16)
                break;
        }
        double q = 1.0 - sum * lead;
        return q < 0.0 ? 0.0 : q;
    }
    const double tiny = 1e-300;
    double b = x + 1.0 - a, c = 1.0 / tiny, d = 1.0 / b, h = d;
    for (int i = 1; i < 100000; i++) {
        double an = -i * (i - a);
        b += 2.0;
        d = an * d + b;
        if (fabs(d) < tiny)
            d = tiny;
        c = b + an / c;
        if (fabs(c) < tiny)
            c = tiny;
        d = 1.0 / d;
        double del = d * c;
        h *= del;
        if (fabs(del - 1.0) < 1e-16)
            break;
    }
    return lead * h;
}

/* P[X >= stat] for X chi-square distributed with dof degrees of freedom. */
static double chi2_survival(double stat, double dof)
{
    return chi2_gamma_q(0.5 * dof, 0.5 * stat);
}

/* The per-test significance that keeps the family-wise level at alpha over
 * num_tests independent tests (Sidak). */
static double chi2_sidak(double alpha, int num_tests)
{
    return 1.0 - pow(1.0 - alpha, 1.0 / (num_tests > 0 ? num_tests : 1));
}

/* One cell of a test: observed and expected counts. */
typedef struct Chi2Cell {
    double obs, exp;
} Chi2Cell;

/* qsort order of cells: ascending expected count. */
static int chi2_cell_cmp(const void *a, const void *b)
{
    double x = ((const Chi2Cell *)a)->exp, y = ((const Chi2Cell *)b)->exp;
    return (x > y) - (x < y);
}

/* Tests observed counts observed[0..n-1] against expected counts expected[0..n-1] (which
 * should sum to the number of samples) at per-test significance alpha_single:
 * pools cells with expected < 5, fails outright when a cell with expected count
 * below 1e-9 holds samples. Fills r (name labels the message); returns
 * r->passed. */
static int chi2_test_counts(const char *name, const double *observed, const double *expected, int n,
                            double alpha_single, Chi2Result *r)
{
    memset(r, 0, sizeof *r);
    r->alpha = alpha_single;
    Chi2Cell *cells = malloc(sizeof *cells * (size_t)(n > 0 ? n : 1));
    int m = 0;
    double zero_hits = 0.0;
    for (int i = 0; i < n; i++) {
        if (expected[i] < 1e-9) {
            zero_hits += observed[i];
            continue;
        }
        cells[m].obs = observed[i];
        cells[m].exp = expected[i];
        m++;
    }
    if (zero_hits > 0.0) {
        snprintf(r->message, sizeof r->message,
                 "%s: %.0f samples fell where the pdf integrates to 0", name, zero_hits);
        free(cells);
        return r->passed = 0;
    }
    qsort(cells, (size_t)m, sizeof *cells, chi2_cell_cmp);
    double stat = 0.0, pool_obs = 0.0, pool_exp = 0.0;
    int used = 0;
    for (int i = 0; i < m; i++) {
        if (cells[i].exp < CHI2_MIN_EXPECTED || (pool_exp > 0.0 && pool_exp < CHI2_MIN_EXPECTED)) {
            pool_obs += cells[i].obs;
            pool_exp += cells[i].exp;
            if (pool_exp >= CHI2_MIN_EXPECTED) {
                double dd = pool_obs - pool_exp;
                stat += dd * dd / pool_exp;
                used++;
                pool_obs = pool_exp = 0.0;
            }
            continue;
        }
        double dd = cells[i].obs - cells[i].exp;
        stat += dd * dd / cells[i].exp;
        used++;
    }
    if (pool_exp > 0.0) {
        double dd = pool_obs - pool_exp;
        stat += dd * dd / pool_exp;
        used++;
    }
    free(cells);
    r->stat = stat;
    r->dof = used - 1;
    if (r->dof < 1) {
        snprintf(r->message, sizeof r->message, "%s: too few cells (%d) for a test", name, used);
        return r->passed = 0;
    }
    r->pvalue = chi2_survival(stat, r->dof);
    r->passed = r->pvalue >= alpha_single;
    snprintf(r->message, sizeof r->message,
             "%s: chi-square statistic %.2f, %d degrees of freedom, p-value %.3g "
             "(rejected below %.3g)",
             name, stat, r->dof, r->pvalue, alpha_single);
    return r->passed;
}

/* A sampler and its pdf on a 2D grid. Zero-initialise, then fill. */
typedef struct Chi2Grid {
    const char *name;
    int domain;              /* CHI2_PLANE or CHI2_SPHERE */
    double x0, x1, y0, y1;   /* plane bounds (the sphere's are fixed) */
    int res_x, res_y;        /* cells per axis */
    uint32_t samples;        /* 0: CHI2_DEFAULT_SAMPLES */
    int num_tests;           /* for the Sidak correction; 0: 1 */
    double alpha;            /* family-wise significance; 0: 0.01 */
    /* Sample i (0-based) into p (2 coordinates for the plane, a direction for the
     * sphere); returns 0 when the sampler produced no sample. */
    int (*sample)(void *ctx, uint32_t i, double p[3]);
    /* Density at p (plane: (x, y); sphere: a unit direction). Its integral over
     * the domain may be below 1 when the sampler rejects some samples; the
     * missing mass is then the expected count of rejections. */
    double (*pdf)(void *ctx, const double p[3]);
    /* Optional, plane only: the exact probability of the cell [x0,x1] x [y0,y1],
     * used instead of integrating pdf. */
    double (*cell_prob)(void *ctx, double x0, double x1, double y0, double y1);
    void *ctx;
} Chi2Grid;

/* Domain bounds of g as (x0, x1, y0, y1). */
static void chi2_bounds(const Chi2Grid *g, double b[4])
{
    if (g->domain == CHI2_SPHERE) {
        b[0] = 0.0;
        b[1] = 2.0 * M_PI;
        b[2] = -1.0;
        b[3] = 1.0;
    } else {
        b[0] = g->x0;
        b[1] = g->x1;
        b[2] = g->y0;
        b[3] = g->y1;
    }
}

/* The pdf of g at grid coordinates (x, y). */
static double chi2_pdf_at(const Chi2Grid *g, double x, double y)
{
    double p[3];
    if (g->domain == CHI2_SPHERE) {
        double s = sqrt(fmax(0.0, 1.0 - y * y));
        p[0] = s * cos(x);
        p[1] = s * sin(x);
        p[2] = y;
    } else {
        p[0] = x;
        p[1] = y;
        p[2] = 0.0;
    }
    return g->pdf(g->ctx, p);
}

/* The probability mass of g's pdf over one cell. */
static double chi2_cell_mass(const Chi2Grid *g, double x0, double x1, double y0, double y1)
{
    if (g->cell_prob && g->domain == CHI2_PLANE)
        return g->cell_prob(g->ctx, x0, x1, y0, y1);
    /* 5-point Gauss-Legendre nodes and weights on [-1, 1]. */
    static const double node[CHI2_GL_NODES] = {-0.9061798459386640, -0.5384693101056831, 0.0,
                                               0.5384693101056831, 0.9061798459386640};
    static const double weight[CHI2_GL_NODES] = {0.2369268850561891, 0.4786286704993665,
                                                 0.5688888888888889, 0.4786286704993665,
                                                 0.2369268850561891};
    double hx = 0.5 * (x1 - x0), hy = 0.5 * (y1 - y0);
    double cx = 0.5 * (x0 + x1), cy = 0.5 * (y0 + y1), sum = 0.0;
    for (int i = 0; i < CHI2_GL_NODES; i++)
        for (int j = 0; j < CHI2_GL_NODES; j++)
            sum += weight[i] * weight[j] * chi2_pdf_at(g, cx + hx * node[i], cy + hy * node[j]);
    return sum * hx * hy;
}

/* Runs the test g describes; fills r and returns r->passed. The last cell of the
 * test is "no sample or outside the domain", expected N (1 - integral). */
static int chi2_grid_run(const Chi2Grid *g, Chi2Result *r)
{
    uint32_t n = g->samples ? g->samples : CHI2_DEFAULT_SAMPLES;
    double alpha = g->alpha > 0.0 ? g->alpha : 0.01;
    int nx = g->res_x, ny = g->res_y, cells = nx * ny;
    double b[4];
    chi2_bounds(g, b);
    double *observed = calloc((size_t)cells + 1, sizeof(double));
    double *expected = calloc((size_t)cells + 1, sizeof(double));
    double dx = (b[1] - b[0]) / nx, dy = (b[3] - b[2]) / ny;
    for (uint32_t i = 0; i < n; i++) {
        double p[3] = {0.0, 0.0, 0.0}, x, y;
        int ok = g->sample(g->ctx, i, p);
        if (g->domain == CHI2_SPHERE) {
            double len = sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
            /* A direction must be unit length to within float precision. */
            ok = ok && fabs(len - 1.0) < 1e-4;
            x = atan2(p[1], p[0]);
            if (x < 0.0)
                x += 2.0 * M_PI;
            y = len > 0.0 ? p[2] / len : 0.0;
        } else {
            x = p[0];
            y = p[1];
        }
        int cx = (int)floor((x - b[0]) / dx), cy = (int)floor((y - b[2]) / dy);
        /* Points on the far edge of the domain (phi = 2 pi, cos theta = 1). */
        if (ok && x == b[1])
            cx = nx - 1;
        if (ok && y == b[3])
            cy = ny - 1;
        if (!ok || !(x >= b[0] && x <= b[1] && y >= b[2] && y <= b[3]) || cx < 0 || cy < 0 ||
            cx >= nx || cy >= ny)
            observed[cells] += 1.0;
        else
            observed[cy * nx + cx] += 1.0;
    }
    double integral = 0.0;
    for (int j = 0; j < ny; j++)
        for (int i = 0; i < nx; i++) {
            double m = chi2_cell_mass(g, b[0] + i * dx, b[0] + (i + 1) * dx, b[2] + j * dy,
                                      b[2] + (j + 1) * dy);
            expected[j * nx + i] = m * n;
            integral += m;
        }
    expected[cells] = integral < 1.0 ? (1.0 - integral) * n : 0.0;
    chi2_test_counts(g->name, observed, expected, cells + 1, chi2_sidak(alpha, g->num_tests), r);
    r->integral = integral;
    if (!r->passed && observed[cells] > 0.0) {
        size_t len = strlen(r->message);
        snprintf(r->message + len, sizeof r->message - len,
                 "; %.0f samples rejected or outside the domain, %.1f expected", observed[cells],
                 expected[cells]);
    }
    free(observed);
    free(expected);
    return r->passed;
}

/* Fails with the chi-square report unless r passed; prints it either way. */
static inline void require_pass(const Chi2Result *r)
{
    if (!r->passed)
        fail_msg("%s", r->message);
    print_message("  %s\n", r->message);
}

/* A test of sample against pdf (both given ctx) over res_x x res_y cells of
 * the plane [x0, x1] x [y0, y1], one of num_tests in the binary (the Sidak
 * correction); CHI2_DEFAULT_SAMPLES samples unless set after. */
static inline Chi2Grid chi2_plane(const char *name, double x0, double x1, double y0, double y1, int res_x,
                                  int res_y, int num_tests, int (*sample)(void *, uint32_t, double[3]),
                                  double (*pdf)(void *, const double[3]), void *ctx)
{
    Chi2Grid g = {.name = name, .domain = CHI2_PLANE, .x0 = x0, .x1 = x1, .y0 = y0, .y1 = y1,
                  .res_x = res_x, .res_y = res_y, .num_tests = num_tests, .sample = sample, .pdf = pdf,
                  .ctx = ctx};
    return g;
}

/* The same over the sphere's (phi, cos theta). */
static inline Chi2Grid chi2_sphere(const char *name, int res_x, int res_y, int num_tests,
                                   int (*sample)(void *, uint32_t, double[3]),
                                   double (*pdf)(void *, const double[3]), void *ctx)
{
    Chi2Grid g = chi2_plane(name, 0, 0, 0, 0, res_x, res_y, num_tests, sample, pdf, ctx);
    g.domain = CHI2_SPHERE;
    return g;
}

/* Runs g and fails with its report unless it passes (require_pass); returns
 * the result. */
static inline Chi2Result chi2_require(const Chi2Grid *g)
{
    Chi2Result r;
    chi2_grid_run(g, &r);
    require_pass(&r);
    return r;
}

#endif
