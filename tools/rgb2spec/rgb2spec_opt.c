/* rgb2spec_opt: fits the coefficient table of the RGB-to-spectrum model of Jakob and
 * Hanika 2019, "A Low-Dimensional Function Space for Efficient Spectral Upsampling"
 * (Computer Graphics Forum 38(2)), for linear sRGB reflectances under D65.
 *
 * Our own implementation of the method of the paper (no code taken from it). For
 * every cell (m, k, j, i) of a RES^3 grid per largest channel m, the target colour
 * has rgb[m] = z_k (a smoothstep-squared spacing that is denser near 0 and 1) and
 * the other two channels (m+1)%3, (m+2)%3 equal to x_i * z_k and y_j * z_k with
 * x_i = i / (RES-1). The spectrum s(l) = sigmoid(a0 t^2 + a1 t + a2),
 * t = (l - 360) / 470, is fitted by Levenberg-Marquardt so that the linear sRGB of
 * D65(Y=1) * s, by 1 nm sums with the CIE 1931 tables of kernels/spectrum/cie_data.h and the
 * matrix of docs/architecture.md, equals the target. Each column (m, i, j) is solved from the
 * middle of z outwards, each solution starting from its neighbour's, as the paper
 * does. The table stores the coefficients converted to nm (s = sigmoid(c0 l^2 +
 * c1 l + c2)), which is what src/color/spd.c interpolates trilinearly.
 *
 * Usage: rgb2spec_opt OUT.c  (writes the C table; depends only on libc/libm). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "spectrum/cie_data.h"

/* 64 cells per axis (3 * 64^3 fits in about 20 s of CPU, 9 MiB of floats): the
 * trilinear interpolation of the coefficients, which textures and vertex colours
 * use alone, puts the colour of its spectrum within 0.003 of an 8-bit sRGB
 * colour (mean 0.00015; 32 cells: 0.008, mean 0.0006; tests/test_spectrum.c). */
#define RES 64
#define N SPT_CIE_SAMPLES

static double g_weight[3][N]; /* linear sRGB weight of each 1 nm sample under D65 */
static double g_t[N];

/* Precomputes w_c(l) = (M cmf(l))_c * D65(l) / integral(ybar), so rgb = sum s w. */
static void init_weights(void)
{
    static const double m[3][3] = {{3.2406, -1.5372, -0.4986},
                                   {-0.9689, 1.8758, 0.0415},
                                   {0.0557, -0.2040, 1.0570}};
    for (int i = 0; i < N; i++) {
        double cmf[3] = {SPT_CIE_X[i], SPT_CIE_Y[i], SPT_CIE_Z[i]};
        for (int c = 0; c < 3; c++)
            g_weight[c][i] = (m[c][0] * cmf[0] + m[c][1] * cmf[1] + m[c][2] * cmf[2]) *
                             SPT_D65_NORM[i] / SPT_CIE_Y_INTEGRAL;
        g_t[i] = (double)i / (N - 1);
    }
}

/* The colour of coefficients a (normalised t) and, when jac is not NULL, its
 * Jacobian jac[c][k] = d rgb_c / d a_k. */
static void eval_rgb(const double a[3], double rgb[3], double jac[3][3])
{
    double r[3] = {0, 0, 0}, j[3][3] = {{0}};
    for (int i = 0; i < N; i++) {
        double t = g_t[i];
        double x = (a[0] * t + a[1]) * t + a[2];
        double q = 1.0 / sqrt(1.0 + x * x);
        double s = 0.5 + 0.5 * x * q;
        double ds = 0.5 * q * q * q;
        double d[3] = {ds * t * t, ds * t, ds};
        for (int c = 0; c < 3; c++) {
            double w = g_weight[c][i];
            r[c] += w * s;
            if (jac)
                for (int k = 0; k < 3; k++)
                    j[c][k] += w * d[k];
        }
    }
    memcpy(rgb, r, sizeof r);
    if (jac)
        memcpy(jac, j, sizeof j);
}

/* Solves m x = b by Gaussian elimination with partial pivoting; 0 when singular. */
static int solve3(double m[3][3], double b[3], double x[3])
{
    for (int c = 0; c < 3; c++) {
        int p = c;
        for (int r = c + 1; r < 3; r++)
            if (fabs(m[r][c]) > fabs(m[p][c]))
                p = r;
        if (!(fabs(m[p][c]) > 1e-300))
            return 0;
        for (int k = 0; k < 3; k++) {
            double t = m[c][k];
            m[c][k] = m[p][k];
            m[p][k] = t;
        }
        double t = b[c];
        b[c] = b[p];
        b[p] = t;
        for (int r = c + 1; r < 3; r++) {
            double f = m[r][c] / m[c][c];
            for (int k = c; k < 3; k++)
                m[r][k] -= f * m[c][k];
            b[r] -= f * b[c];
        }
    }
    for (int c = 2; c >= 0; c--) {
        double s = b[c];
        for (int k = c + 1; k < 3; k++)
            s -= m[c][k] * x[k];
        x[c] = s / m[c][c];
    }
    return 1;
}

/* Levenberg-Marquardt from a towards the coefficients whose colour is target
 * (least squares where the target is out of reach). Returns the final residual. */
static double fit(const double target[3], double a[3])
{
    double mu = 1e-3, rgb[3], jac[3][3], err = 0;
    eval_rgb(a, rgb, jac);
    for (int c = 0; c < 3; c++)
        err += (rgb[c] - target[c]) * (rgb[c] - target[c]);
    for (int it = 0; it < 200 && err > 1e-16; it++) {
        double jtj[3][3], jtr[3], d[3];
        for (int k = 0; k < 3; k++) {
            jtr[k] = 0;
            for (int c = 0; c < 3; c++)
                jtr[k] += jac[c][k] * (rgb[c] - target[c]);
            for (int l = 0; l < 3; l++) {
                jtj[k][l] = 0;
                for (int c = 0; c < 3; c++)
                    jtj[k][l] += jac[c][k] * jac[c][l];
            }
        }
        int improved = 0;
        for (int tries = 0; tries < 30 && !improved; tries++) {
            double m[3][3], b[3];
            memcpy(m, jtj, sizeof m);
            memcpy(b, jtr, sizeof b);
            for (int k = 0; k < 3; k++)
                m[k][k] += mu * (jtj[k][k] + 1e-12);
            if (solve3(m, b, d)) {
                double na[3] = {a[0] - d[0], a[1] - d[1], a[2] - d[2]}, nrgb[3], njac[3][3];
                eval_rgb(na, nrgb, njac);
                double nerr = 0;
                for (int c = 0; c < 3; c++)
                    nerr += (nrgb[c] - target[c]) * (nrgb[c] - target[c]);
                if (nerr < err) {
                    memcpy(a, na, sizeof na);
                    memcpy(rgb, nrgb, sizeof nrgb);
                    memcpy(jac, njac, sizeof njac);
                    improved = err - nerr > 1e-20;
                    err = nerr;
                    mu = fmax(mu * 0.2, 1e-12);
                    if (!improved)
                        return sqrt(err);
                    break;
                }
            }
            mu *= 10.0;
        }
        if (!improved)
            break;
    }
    return sqrt(err);
}

static double smoothstep(double x) { return x * x * (3.0 - 2.0 * x); }

static float g_table[3][RES][RES][RES][3]; /* [m][k=z][j=y][i=x][coeff] */
static float g_scale[RES];

/* Coefficients in nm of a0 t^2 + a1 t + a2 with t = (l - 360) / 470. */
static void to_nm(const double a[3], float c[3])
{
    const double l0 = SPT_CIE_LAMBDA_MIN, w = SPT_CIE_LAMBDA_MAX - SPT_CIE_LAMBDA_MIN;
    c[0] = (float)(a[0] / (w * w));
    c[1] = (float)(a[1] / w - 2.0 * a[0] * l0 / (w * w));
    c[2] = (float)(a[0] * l0 * l0 / (w * w) - a[1] * l0 / w + a[2]);
}

int main(int argc, char **argv)
{
    if (argc != 2) {
        fprintf(stderr, "usage: rgb2spec_opt OUT.c\n");
        return 2;
    }
    clock_t t0 = clock();
    init_weights();
    for (int k = 0; k < RES; k++)
        g_scale[k] = (float)smoothstep(smoothstep((double)k / (RES - 1)));
    double worst = 0;
    int start = RES / 5;
    for (int m = 0; m < 3; m++) {
        for (int j = 0; j < RES; j++) {
            for (int i = 0; i < RES; i++) {
                double x = (double)i / (RES - 1), y = (double)j / (RES - 1);
                double first[3] = {0, 0, 0};
                for (int dir = 0; dir < 2; dir++) {
                    /* Upwards from the middle, then downwards from its first solution. */
                    double a[3] = {first[0], first[1], first[2]};
                    int k0 = dir ? start - 1 : start, kend = dir ? -1 : RES, step = dir ? -1 : 1;
                    for (int k = k0; k != kend; k += step) {
                        double z = g_scale[k], target[3];
                        target[m] = z;
                        target[(m + 1) % 3] = x * z;
                        target[(m + 2) % 3] = y * z;
                        double r = fit(target, a);
                        /* Residuals of reachable colours measure the fit; the
                         * unreachable ones (outside the spectral locus) are least
                         * squares by design. */
                        if (z > 0.05 && z < 0.9 && r > worst && x > 0.1 && y > 0.1 && x < 0.9 && y < 0.9)
                            worst = r;
                        to_nm(a, g_table[m][k][j][i]);
                        if (k == start)
                            memcpy(first, a, sizeof first);
                    }
                }
            }
        }
    }
    FILE *f = fopen(argv[1], "w");
    if (!f) {
        perror(argv[1]);
        return 1;
    }
    fprintf(f, "/* Generated by tools/rgb2spec/rgb2spec_opt.c: Jakob-Hanika 2019 sigmoid\n"
               " * coefficients (in nm) for linear sRGB reflectances under D65. Do not edit. */\n"
               "const int spt_rgb2spec_res = %d;\n"
               "const float spt_rgb2spec_scale[%d] = {\n",
            RES, RES);
    for (int k = 0; k < RES; k++)
        fprintf(f, "%.9e,%s", g_scale[k], k % 6 == 5 ? "\n" : " ");
    fprintf(f, "};\n/* [largest channel][z][y][x][coefficient] */\n"
               "const float spt_rgb2spec_data[%d] = {\n",
            3 * RES * RES * RES * 3);
    const float *p = &g_table[0][0][0][0][0];
    for (int n = 0; n < 3 * RES * RES * RES * 3; n++)
        fprintf(f, "%.9e,%s", p[n], n % 6 == 5 ? "\n" : " ");
    fprintf(f, "};\n");
    if (fclose(f)) {
        perror(argv[1]);
        return 1;
    }
    fprintf(stderr, "rgb2spec_opt: %d^3 x 3 cells in %.1f s, largest in-gamut residual %.2g\n", RES,
            (double)(clock() - t0) / CLOCKS_PER_SEC, worst);
    return 0;
}
