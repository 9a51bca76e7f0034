/* Host colour science: SPDs, CIE XYZ, sRGB, named illuminants, RGB upsampling. */
#include "color/spd.h"

#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include <sys/stat.h>

#include "color/spd_data.h"
#include "core/input_file.h"
#include "spectrum/cie_data.h"
#include "spectrum/spectrum.h"

void spd_free(Spd *s)
{
    if (!s)
        return;
    free(s->nm);
    free(s->value);
    free(s->line_nm);
    free(s->line_power);
    memset(s, 0, sizeof *s);
}

/* A malloc'd copy of n doubles, NULL for none. */
static double *dup_doubles(const double *p, int n)
{
    if (n <= 0 || !p)
        return NULL;
    double *q = spt_malloc((size_t)n * sizeof(double));
    memcpy(q, p, (size_t)n * sizeof(double));
    return q;
}

int spd_copy(Spd *dst, const Spd *src)
{
    Spd r;
    memset(&r, 0, sizeof r);
    r.count = src->count;
    r.nm = dup_doubles(src->nm, src->count);
    r.value = dup_doubles(src->value, src->count);
    r.line_count = src->line_count;
    r.line_nm = dup_doubles(src->line_nm, src->line_count);
    r.line_power = dup_doubles(src->line_power, src->line_count);
    *dst = r;
    return 0;
}

/* qsort order of samples by wavelength. */
static int cmp_sample(const void *a, const void *b)
{
    double x = ((const SpdSample *)a)->nm, y = ((const SpdSample *)b)->nm;
    return x < y ? -1 : x > y;
}

void spd_sort_samples(SpdSample *s, size_t n) { qsort(s, n, sizeof *s, cmp_sample); }

int spd_from_samples(Spd *out, const double *nm, const double *value, int n, SptError *e)
{
    memset(out, 0, sizeof *out);
    if (n < 1)
        return spt_fail(e, SPT_EXIT_INPUT, "an SPD needs at least one sample");
    SpdSample *p = spt_malloc((size_t)n * sizeof(SpdSample));
    for (int i = 0; i < n; i++) {
        if (!isfinite(nm[i]) || !isfinite(value[i]) || nm[i] <= 0) {
            free(p);
            return spt_fail(e, SPT_EXIT_INPUT,
                            "sample %d (%g nm, %g) is not a positive finite wavelength with a finite value",
                            i, nm[i], value[i]);
        }
        if (value[i] < 0 || value[i] > SPT_MAX_INPUT_VALUE) {
            free(p);
            return spt_fail(e, SPT_EXIT_INPUT, "sample %d (%g nm): value %g is %s", i, nm[i],
                            value[i], value[i] < 0 ? "negative (a spectrum is never negative)"
                                                   : "above 1e30 (the renderer computes in float)");
        }
        p[i].nm = nm[i];
        p[i].value = value[i];
    }
    spd_sort_samples(p, (size_t)n);
    for (int i = 1; i < n; i++)
        if (p[i].nm == p[i - 1].nm) {
            double w = p[i].nm;
            free(p);
            return spt_fail(e, SPT_EXIT_INPUT, "wavelength %g nm is given twice", w);
        }
    out->count = n;
    out->nm = spt_malloc((size_t)n * sizeof(double));
    out->value = spt_malloc((size_t)n * sizeof(double));
    for (int i = 0; i < n; i++) {
        out->nm[i] = p[i].nm;
        out->value[i] = p[i].value;
    }
    free(p);
    return 0;
}

double spd_eval(const Spd *s, double nm)
{
    int n = s->count;
    if (n == 0 || !(nm >= s->nm[0]) || nm > s->nm[n - 1])
        return 0.0;
    if (n == 1)
        return s->value[0];
    int lo = 0, hi = n - 1;
    while (hi - lo > 1) {
        int mid = (lo + hi) / 2;
        if (s->nm[mid] <= nm)
            lo = mid;
        else
            hi = mid;
    }
    double f = (nm - s->nm[lo]) / (s->nm[hi] - s->nm[lo]);
    return s->value[lo] * (1.0 - f) + s->value[hi] * f;
}

/* CMFs at a wavelength, in double from the float tables (linear interpolation). */
static void cmf_at(double nm, double out[3])
{
    out[0] = spt_cie_x((float)nm);
    out[1] = spt_cie_y((float)nm);
    out[2] = spt_cie_z((float)nm);
}

void spd_to_xyz(const Spd *s, double xyz[3])
{
    xyz[0] = xyz[1] = xyz[2] = 0.0;
    for (int i = 0; i < SPT_CIE_SAMPLES; i++) {
        double v = spd_eval(s, SPT_CIE_LAMBDA_MIN + i);
        xyz[0] += SPT_CIE_X[i] * v;
        xyz[1] += SPT_CIE_Y[i] * v;
        xyz[2] += SPT_CIE_Z[i] * v;
    }
    for (int k = 0; k < s->line_count; k++) {
        double c[3];
        cmf_at(s->line_nm[k], c);
        for (int j = 0; j < 3; j++)
            xyz[j] += c[j] * s->line_power[k];
    }
}

void spd_reflectance_to_xyz(const Spd *s, double xyz[3])
{
    Spd d65;
    spd_named(&d65, "D65", NULL);
    double norm = 0.0;
    xyz[0] = xyz[1] = xyz[2] = 0.0;
    for (int i = 0; i < SPT_CIE_SAMPLES; i++) {
        double l = SPT_CIE_LAMBDA_MIN + i, e = spd_eval(&d65, l), v = spd_eval(s, l) * e;
        xyz[0] += SPT_CIE_X[i] * v;
        xyz[1] += SPT_CIE_Y[i] * v;
        xyz[2] += SPT_CIE_Z[i] * v;
        norm += SPT_CIE_Y[i] * e;
    }
    for (int k = 0; k < 3; k++)
        xyz[k] /= norm;
    spd_free(&d65);
}

double spd_luminous_efficacy(const Spd *s)
{
    /* Trapezoidal integrals over the 1 nm grid (the CIE definition of an
     * integral over tabulated data), plus the lines inside 360-830 nm. */
    double y = 0.0, p = 0.0;
    for (int i = 0; i < SPT_CIE_SAMPLES; i++) {
        double w = (i == 0 || i == SPT_CIE_SAMPLES - 1) ? 0.5 : 1.0;
        double v = spd_eval(s, SPT_CIE_LAMBDA_MIN + i);
        y += w * SPT_CIE_Y[i] * v;
        p += w * v;
    }
    for (int k = 0; k < s->line_count; k++)
        if (s->line_nm[k] >= SPT_CIE_LAMBDA_MIN && s->line_nm[k] <= SPT_CIE_LAMBDA_MAX) {
            y += spt_cie_y((float)s->line_nm[k]) * s->line_power[k];
            p += s->line_power[k];
        }
    return p > 0 ? 683.0 * y / p : 0.0;
}

void spd_to_grid(const Spd *s, float *grid)
{
    for (int i = 0; i < SPT_CIE_SAMPLES; i++)
        grid[i] = (float)spd_eval(s, SPT_CIE_LAMBDA_MIN + i);
    /* A line of power p becomes p per nm in the 1 nm bin around it, split
     * between the two nearest grid points so its centroid is kept. */
    for (int k = 0; k < s->line_count; k++) {
        double x = s->line_nm[k] - SPT_CIE_LAMBDA_MIN;
        if (x < 0 || x > SPT_CIE_SAMPLES - 1)
            continue;
        int i = (int)x;
        if (i > SPT_CIE_SAMPLES - 2)
            i = SPT_CIE_SAMPLES - 2;
        double f = x - i;
        grid[i] += (float)(s->line_power[k] * (1.0 - f));
        grid[i + 1] += (float)(s->line_power[k] * f);
    }
}

double blackbody_radiance(double nm, double kelvin)
{
    const double h = 6.62607015e-34, c = 299792458.0, kb = 1.380649e-23;
    if (!(kelvin > 0) || !(nm > 0))
        return 0.0;
    double l = nm * 1e-9;
    return 2.0 * h * c * c / (pow(l, 5) * (exp(h * c / (l * kb * kelvin)) - 1.0));
}

void xyz_to_linear_srgb(const double xyz[3], double rgb[3])
{
    double x = xyz[0], y = xyz[1], z = xyz[2];
    rgb[0] = 3.2406 * x - 1.5372 * y - 0.4986 * z;
    rgb[1] = -0.9689 * x + 1.8758 * y + 0.0415 * z;
    rgb[2] = 0.0557 * x - 0.2040 * y + 1.0570 * z;
}

void linear_srgb_to_xyz(const double rgb[3], double xyz[3])
{
    double r = rgb[0], g = rgb[1], b = rgb[2];
    xyz[0] = 0.4124 * r + 0.3576 * g + 0.1805 * b;
    xyz[1] = 0.2126 * r + 0.7152 * g + 0.0722 * b;
    xyz[2] = 0.0193 * r + 0.1192 * g + 0.9505 * b;
}

/* ---- Named SPDs ----------------------------------------------------------------- */

/* An SPD from a regularly spaced published table. */
static void spd_from_table(Spd *out, double start, double step, int count, const double *v)
{
    double *nm = spt_malloc((size_t)count * sizeof(double));
    for (int i = 0; i < count; i++)
        nm[i] = start + step * i;
    spd_from_samples(out, nm, v, count, NULL);
    free(nm);
}

/* CIE illuminant A from its defining formula (CIE 15:2004, eq. 1.1), normalised to
 * 100 at 560 nm, at 1 nm from 300 to 830 nm. */
static void spd_illuminant_a(Spd *out)
{
    int n = 531;
    double *nm = spt_malloc((size_t)n * sizeof(double)), *v = spt_malloc((size_t)n * sizeof(double));
    const double c2 = 1.435e7; /* nm K, as in the CIE definition */
    for (int i = 0; i < n; i++) {
        double l = 300.0 + i;
        nm[i] = l;
        v[i] = 100.0 * pow(560.0 / l, 5) * (exp(c2 / (2848.0 * 560.0)) - 1.0) /
               (exp(c2 / (2848.0 * l)) - 1.0);
    }
    spd_from_samples(out, nm, v, n, NULL);
    free(nm);
    free(v);
}

/* Mercury lines and relative powers: NIST Atomic Spectra Database, "Strong lines
 * of mercury (Hg I)" (NIST Handbook of Basic Atomic Spectroscopic Data),
 * relative intensities 1800, 150, 4000, 1100, 240, 280, scaled so the strongest
 * (435.8 nm) has power 1. Wavelengths in air, nm. */
static const double mercury_nm[6] = {404.656, 407.783, 435.833, 546.074, 576.960, 579.066};
static const double mercury_rel[6] = {1800, 150, 4000, 1100, 240, 280};

int spd_named(Spd *out, const char *name, SptError *e)
{
    memset(out, 0, sizeof *out);
    if (!strncasecmp(name, "blackbody:", 10)) {
        char *end;
        double k = strtod(name + 10, &end);
        if (!name[10] || *end || !(k > 0) || k > 1e6)
            return spt_fail(e, SPT_EXIT_INPUT,
                            "'%s': a blackbody needs a temperature in kelvin, e.g. blackbody:2856", name);
        int n = SPT_CIE_SAMPLES;
        double *nm = spt_malloc((size_t)n * sizeof(double)), *v = spt_malloc((size_t)n * sizeof(double));
        for (int i = 0; i < n; i++) {
            nm[i] = SPT_CIE_LAMBDA_MIN + i;
            v[i] = blackbody_radiance(nm[i], k);
        }
        spd_from_samples(out, nm, v, n, NULL);
        free(nm);
        free(v);
        return 0;
    }
    if (!strcasecmp(name, "A")) {
        spd_illuminant_a(out);
    } else if (!strcasecmp(name, "D65")) {
        spd_from_table(out, spt_d65_start, spt_d65_step, spt_d65_count, spt_d65_values);
    } else if (!strcasecmp(name, "F2")) {
        spd_from_table(out, spt_f2_start, spt_f2_step, spt_f2_count, spt_f2_values);
    } else if (!strcasecmp(name, "F7")) {
        spd_from_table(out, spt_f7_start, spt_f7_step, spt_f7_count, spt_f7_values);
    } else if (!strcasecmp(name, "F11")) {
        spd_from_table(out, spt_f11_start, spt_f11_step, spt_f11_count, spt_f11_values);
    } else if (!strcasecmp(name, "mercury") || !strcasecmp(name, "Hg")) {
        out->line_count = 6;
        out->line_nm = dup_doubles(mercury_nm, 6);
        out->line_power = spt_malloc(6 * sizeof(double));
        for (int i = 0; i < 6; i++)
            out->line_power[i] = mercury_rel[i] / 4000.0;
    } else {
        return spt_fail(e, SPT_EXIT_INPUT,
                        "unknown SPD '%s' (known: A, D65, F2, F7, F11, mercury, blackbody:KELVIN, or a CSV file)",
                        name);
    }
    return 0;
}

int spd_read_csv(Spd *out, const char *path, SptError *e)
{
    memset(out, 0, sizeof *out);
    unsigned char *text = NULL;
    size_t text_size = 0;
    int rc = input_read(path, "SPD file", &text, &text_size, e);
    if (rc)
        return rc;
    rc = spd_parse_csv(out, path, (const char *)text, text_size, e);
    free(text);
    return rc;
}

int spd_parse_csv(Spd *out, const char *path, const char *text_in, size_t text_size, SptError *e)
{
    memset(out, 0, sizeof *out);
    if (memchr(text_in, 0, text_size))
        return spt_fail(e, SPT_EXIT_INPUT, "%s: not a text file (it holds a zero byte)", path);
    /* fmemopen reads from a copy (it may not be given const memory). */
    char *text = text_size ? spt_malloc(text_size) : NULL;
    if (text_size)
        memcpy(text, text_in, text_size);
    FILE *f = text_size ? fmemopen(text, text_size, "r") : NULL;
    if (!f) {
        free(text);
        return spt_fail(e, SPT_EXIT_INPUT, "%s: no samples (expected lines of 'wavelength_nm,value')",
                        path);
    }
    char line[4096];
    int lineno = 0, n = 0, cap = 0, rc = 0, header_ok = 1;
    double *nm = NULL, *v = NULL;
    while (fgets(line, sizeof line, f)) {
        lineno++;
        char *p = line;
        while (isspace((unsigned char)*p))
            p++;
        if (!*p || *p == '#')
            continue;
        char *end;
        errno = 0;
        double a = strtod(p, &end);
        char *q = end;
        while (*q == ' ' || *q == '\t')
            q++;
        int ok = end != p && *q == ',';
        double b = 0;
        if (ok) {
            q++;
            b = strtod(q, &end);
            ok = end != q;
            while (isspace((unsigned char)*end))
                end++;
            ok = ok && (*end == 0 || *end == '#');
        }
        /* Two numbers that are no sample: the reason, not the format. */
        char why[160] = "";
        if (ok && (!isfinite(a) || !(a > 0)))
            snprintf(why, sizeof why, "wavelength %g nm is %s", a, isfinite(a) ? "not positive" : "not finite");
        else if (ok && !isfinite(b))
            snprintf(why, sizeof why, "%g nm: value %g is not finite", a, b);
        else if (ok && b < 0)
            snprintf(why, sizeof why, "%g nm: value %g is negative (a spectrum is never negative)", a, b);
        else if (ok && b > SPT_MAX_INPUT_VALUE)
            snprintf(why, sizeof why, "%g nm: value %g is above 1e30 (the renderer computes in float)", a, b);
        if (why[0]) {
            rc = spt_fail(e, SPT_EXIT_INPUT, "%s: line %d: %s", path, lineno, why);
            goto done;
        }
        if (!ok) {
            /* One header line is allowed before the first sample. */
            if (n == 0 && header_ok && !isdigit((unsigned char)*p) && *p != '-' && *p != '+' && *p != '.') {
                header_ok = 0;
                continue;
            }
            char *nl = strchr(line, '\n');
            if (nl)
                *nl = 0;
            rc = spt_fail(e, SPT_EXIT_INPUT,
                          "%s: line %d: expected 'wavelength_nm,value' with numbers, got '%.60s'", path,
                          lineno, p);
            goto done;
        }
        header_ok = 0;
        if (n == cap) {
            cap = cap ? 2 * cap : 64;
            nm = spt_realloc(nm, (size_t)cap * sizeof(double));
            v = spt_realloc(v, (size_t)cap * sizeof(double));
        }
        nm[n] = a;
        v[n] = b;
        n++;
    }
    if (ferror(f)) {
        rc = spt_fail(e, SPT_EXIT_INPUT, "%s: cannot read: %s", path, strerror(errno));
        goto done;
    }
    if (n == 0) {
        rc = spt_fail(e, SPT_EXIT_INPUT, "%s: no samples (expected lines of 'wavelength_nm,value')", path);
        goto done;
    }
    /* One sample is no spectrum (zero outside the samples, linear between). */
    if (n == 1) {
        rc = spt_fail(e, SPT_EXIT_INPUT, "%s: one sample (%g nm); an SPD needs at least 2 rows, "
                      "linear between them and zero outside", path, nm[0]);
        goto done;
    }
    {
        SptError e2 = {0};
        if (spd_from_samples(out, nm, v, n, &e2))
            rc = spt_fail(e, SPT_EXIT_INPUT, "%s: %s", path, e2.msg);
    }
done:
    free(nm);
    free(v);
    fclose(f);
    free(text);
    return rc;
}

int spd_parse(Spd *out, const char *text, SptError *e)
{
    SptError e1 = {0};
    if (!spd_named(out, text, &e1))
        return 0;
    /* Text that looks like a path, or names a file that exists, is read as a CSV
     * (so an unreadable file says why); anything else is an unknown name. */
    size_t n = strlen(text);
    int path_like = strchr(text, '/') || (n > 4 && !strcasecmp(text + n - 4, ".csv"));
    struct stat st;
    if (stat(text, &st) != 0 && !path_like && errno == ENOENT)
        return spt_fail(e, SPT_EXIT_INPUT, "%s", e1.msg);
    return spd_read_csv(out, text, e);
}

/* ---- RGB upsampling (Jakob and Hanika 2019) ----------------------------------- */

/* The table fitted at build time by tools/rgb2spec/rgb2spec_opt.c (BUILD/gen/
 * rgb2spec_data.c): res^3 cells per largest channel, z spacing in scale[], nm
 * coefficients at [m][z][y][x][3]. */
extern const int spt_rgb2spec_res;
extern const float spt_rgb2spec_scale[];
extern const float spt_rgb2spec_data[];

/* rgb_in clamped to [0, 1] (NaN -> 0) into rgb; for a grey, its coefficients (a
 * constant spectrum, exactly 0 or 1 for black and white) into coeffs and 1. */
static int clamp_rgb_grey(const float rgb_in[3], float rgb[3], float coeffs[3])
{
    for (int c = 0; c < 3; c++) {
        float v = rgb_in[c];
        rgb[c] = v > 0.0f ? (v < 1.0f ? v : 1.0f) : 0.0f; /* NaN -> 0 */
    }
    if (rgb[0] == rgb[1] && rgb[1] == rgb[2]) {
        double v = rgb[0];
        coeffs[0] = coeffs[1] = 0.0f;
        coeffs[2] = v <= 0 ? -1e20f : v >= 1 ? 1e20f : (float)((v - 0.5) / sqrt(v * (1.0 - v)));
        return 1;
    }
    return 0;
}

/* Coefficients of a non-grey rgb in [0, 1] by trilinear interpolation of the
 * fitted table in the cell of the largest channel (z) and the other two divided
 * by it (x, y), as Jakob and Hanika's lookup. Exact at the table's nodes only:
 * the coefficients are not linear in the colour, and between nodes the colour
 * of the interpolated spectrum is off by up to 0.003 (64 cells per axis). */
static void table_coeffs(const float rgb[3], float coeffs[3])
{
    const int res = spt_rgb2spec_res;
    int m = rgb[0] >= rgb[1] ? (rgb[0] >= rgb[2] ? 0 : 2) : (rgb[1] >= rgb[2] ? 1 : 2);
    float z = rgb[m];
    float x = rgb[(m + 1) % 3] / z * (float)(res - 1), y = rgb[(m + 2) % 3] / z * (float)(res - 1);
    int xi = (int)x, yi = (int)y, zi = 0;
    if (xi > res - 2)
        xi = res - 2;
    if (yi > res - 2)
        yi = res - 2;
    /* The last scale[] interval that starts at or below z (scale is increasing). */
    int lo = 0, hi = res - 1;
    while (hi - lo > 1) {
        int mid = (lo + hi) / 2;
        if (spt_rgb2spec_scale[mid] <= z)
            lo = mid;
        else
            hi = mid;
    }
    zi = lo;
    float fx = x - (float)xi, fy = y - (float)yi;
    float fz = (z - spt_rgb2spec_scale[zi]) / (spt_rgb2spec_scale[zi + 1] - spt_rgb2spec_scale[zi]);
    for (int c = 0; c < 3; c++) {
        double v = 0.0;
        for (int dz = 0; dz < 2; dz++)
            for (int dy = 0; dy < 2; dy++)
                for (int dx = 0; dx < 2; dx++) {
                    size_t idx = ((((size_t)m * res + zi + dz) * res + yi + dy) * res + xi + dx) * 3 + c;
                    double w = (dx ? fx : 1.0f - fx) * (dy ? fy : 1.0f - fy) * (dz ? fz : 1.0f - fz);
                    v += w * spt_rgb2spec_data[idx];
                }
        coeffs[c] = (float)v;
    }
}

/* The refinement works in t = (l - 360) / 470 (coefficients of order 1). */
#define RGB2SPEC_SPAN ((double)(SPT_CIE_LAMBDA_MAX - SPT_CIE_LAMBDA_MIN))

/* Linear sRGB of the reflectance sigmoid(a0 t^2 + a1 t + a2) under D65, by the
 * 1 nm sums the renderer's colour pipeline uses, and its Jacobian in a. w holds
 * each sample's weight (the sRGB of its CIE 1931 values times D65 / integral of
 * ybar). */
static void sigmoid_colour(const double w[3][SPT_CIE_SAMPLES], const double a[3], double rgb[3],
                           double jac[3][3])
{
    memset(rgb, 0, 3 * sizeof(double));
    memset(jac, 0, 9 * sizeof(double));
    for (int i = 0; i < SPT_CIE_SAMPLES; i++) {
        double t = i / (double)(SPT_CIE_SAMPLES - 1);
        double x = (a[0] * t + a[1]) * t + a[2];
        double q = 1.0 / sqrt(1.0 + x * x);
        double s = 0.5 + 0.5 * x * q, ds = 0.5 * q * q * q;
        for (int c = 0; c < 3; c++) {
            rgb[c] += w[c][i] * s;
            jac[c][0] += w[c][i] * ds * t * t;
            jac[c][1] += w[c][i] * ds * t;
            jac[c][2] += w[c][i] * ds;
        }
    }
}

/* Solves the 3x3 system m d = b by Cramer's rule; 0 when (nearly) singular. */
static int solve3x3(const double m[3][3], const double b[3], double d[3])
{
    double det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) -
                 m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
                 m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    if (!(fabs(det) > 1e-300) || !isfinite(det))
        return 0;
    for (int k = 0; k < 3; k++) {
        double mk[3][3];
        memcpy(mk, m, sizeof mk);
        for (int r = 0; r < 3; r++)
            mk[r][k] = b[r];
        d[k] = (mk[0][0] * (mk[1][1] * mk[2][2] - mk[1][2] * mk[2][1]) -
                mk[0][1] * (mk[1][0] * mk[2][2] - mk[1][2] * mk[2][0]) +
                mk[0][2] * (mk[1][0] * mk[2][1] - mk[1][1] * mk[2][0])) / det;
    }
    return 1;
}

/* Moves the table's coefficients c (nm) to the ones whose colour is exactly rgb
 * (to 1e-9; least squares for a colour no sigmoid spectrum reaches) by
 * Levenberg-Marquardt steps on the same objective as tools/rgb2spec/
 * rgb2spec_opt.c. Keeps c when no step improves it. */
static void refine_coeffs(const float rgb[3], float c[3])
{
    double w[3][SPT_CIE_SAMPLES];
    for (int i = 0; i < SPT_CIE_SAMPLES; i++) {
        double xyz[3] = {SPT_CIE_X[i], SPT_CIE_Y[i], SPT_CIE_Z[i]}, lin[3];
        xyz_to_linear_srgb(xyz, lin);
        for (int k = 0; k < 3; k++)
            w[k][i] = lin[k] * SPT_D65_NORM[i] / SPT_CIE_Y_INTEGRAL;
    }
    /* nm -> t: c0 l^2 + c1 l + c2 with l = 360 + 470 t. */
    const double l0 = SPT_CIE_LAMBDA_MIN, sp = RGB2SPEC_SPAN;
    double a[3] = {c[0] * sp * sp, sp * (2.0 * l0 * c[0] + c[1]), (c[0] * l0 + c[1]) * l0 + c[2]};
    double col[3], jac[3][3], err = 0.0, mu = 1e-4;
    sigmoid_colour(w, a, col, jac);
    for (int k = 0; k < 3; k++)
        err += (col[k] - rgb[k]) * (col[k] - rgb[k]);
    const double err0 = err;
    for (int it = 0; it < 40 && err > 1e-18; it++) {
        double jtj[3][3], jtr[3];
        for (int k = 0; k < 3; k++) {
            jtr[k] = 0.0;
            for (int r = 0; r < 3; r++)
                jtr[k] += jac[r][k] * (col[r] - rgb[r]);
            for (int l = 0; l < 3; l++) {
                jtj[k][l] = 0.0;
                for (int r = 0; r < 3; r++)
                    jtj[k][l] += jac[r][k] * jac[r][l];
            }
        }
        int improved = 0;
        for (int tries = 0; tries < 20 && !improved; tries++) {
            double m[3][3], d[3];
            memcpy(m, jtj, sizeof m);
            for (int k = 0; k < 3; k++)
                m[k][k] += mu * jtj[k][k] + 1e-30;
            if (solve3x3(m, jtr, d)) {
                double na[3] = {a[0] - d[0], a[1] - d[1], a[2] - d[2]}, ncol[3], njac[3][3], nerr = 0.0;
                sigmoid_colour(w, na, ncol, njac);
                for (int k = 0; k < 3; k++)
                    nerr += (ncol[k] - rgb[k]) * (ncol[k] - rgb[k]);
                if (nerr < err) {
                    memcpy(a, na, sizeof a);
                    memcpy(col, ncol, sizeof col);
                    memcpy(jac, njac, sizeof jac);
                    err = nerr;
                    mu = fmax(mu * 0.1, 1e-12);
                    improved = 1;
                    continue;
                }
            }
            mu *= 10.0;
        }
        if (!improved)
            break;
    }
    if (!(err < err0))
        return;
    /* t -> nm. */
    double c0 = a[0] / (sp * sp), c1 = a[1] / sp - 2.0 * l0 * c0;
    double c2 = a[2] - (c0 * l0 + c1) * l0;
    if (isfinite(c0) && isfinite(c1) && isfinite(c2)) {
        c[0] = (float)c0;
        c[1] = (float)c1;
        c[2] = (float)c2;
    }
}

void rgb_to_coeffs_fast(const float rgb_in[3], float coeffs[3])
{
    float rgb[3];
    if (!clamp_rgb_grey(rgb_in, rgb, coeffs))
        table_coeffs(rgb, coeffs);
}

void rgb_to_coeffs(const float rgb_in[3], float coeffs[3])
{
    float rgb[3];
    if (clamp_rgb_grey(rgb_in, rgb, coeffs))
        return;
    table_coeffs(rgb, coeffs);
    refine_coeffs(rgb, coeffs);
}

/* rgb_illuminant_coeffs with the reflectance conversion conv. */
static void illuminant_coeffs(const float rgb[3], float coeffs[3], float *scale,
                              void (*conv)(const float *, float *))
{
    float m = fmaxf(fmaxf(rgb[0], rgb[1]), rgb[2]);
    if (!(m > 0.0f)) {
        coeffs[0] = coeffs[1] = 0.0f;
        coeffs[2] = -1e20f;
        *scale = 0.0f;
        return;
    }
    *scale = 2.0f * m;
    float r[3] = {rgb[0] / *scale, rgb[1] / *scale, rgb[2] / *scale};
    conv(r, coeffs);
}

void rgb_illuminant_coeffs(const float rgb[3], float coeffs[3], float *scale)
{
    illuminant_coeffs(rgb, coeffs, scale, rgb_to_coeffs);
}

void rgb_illuminant_coeffs_fast(const float rgb[3], float coeffs[3], float *scale)
{
    illuminant_coeffs(rgb, coeffs, scale, rgb_to_coeffs_fast);
}
