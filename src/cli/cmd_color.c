/* `spectrace color [--reflectance] SPD`: the colour of an SPD, normalised to Y = 1;
 * `spectrace color --pixel X,Y FILE.exr`: the colour of a pixel of a spectral EXR;
 * `spectrace color --film IOR,NM[,DEG] BASE`: the colour of a thin film's
 * reflectance under D65. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "cli/commands.h"
#include "color/spd.h"
#include "closure/conductors.h"
#include "closure/thin_film.h"
#include "core/util.h"
#include "io/exr.h"
#include "spectrum/cie_data.h"

static const char color_usage[] =
    "usage: spectrace color [--reflectance] [--] SPD\n"
    "       spectrace color --pixel X,Y FILE.exr\n"
    "       spectrace color --film IOR,NM[,DEGREES] BASE\n"
    "\n"
    "Prints the colour of SPD as three lines: CIE 1931 XYZ normalised so Y = 1, the\n"
    "linear sRGB of that XYZ (unclamped), and 8-bit sRGB (linear values clamped to\n"
    "[0, 1], then the sRGB transfer curve), e.g. for D65:\n"
    "  XYZ 0.950470 1.000000 1.088830\n"
    "  linear-sRGB 1.000000 1.000000 1.000000\n"
    "  sRGB8 255 255 255\n"
    "\n"
    "SPD: A, D65, F2, F7, F11 (CIE illuminants), mercury (Hg lamp lines),\n"
    "blackbody:KELVIN (Planck's law), or a CSV file of `wavelength_nm,value` lines\n"
    "(a header line and # comments allowed; linear interpolation, zero outside).\n"
    "\n"
    "  --reflectance   treat SPD as a reflectance under D65: a perfect white\n"
    "                  reflector has Y = 1 (no renormalisation to Y = 1)\n"
    "  --pixel X,Y     the spectrum of pixel (X, Y) (0-based, from the top left) of a\n"
    "                  spectral EXR (spectrace render --spectral: channels S0.<nm>nm\n"
    "                  of Fichet et al. 2021), each channel a band's mean radiance,\n"
    "                  constant over the band (its borders half way between the\n"
    "                  channels' wavelengths; one channel covers 360-830 nm), in\n"
    "                  the film's units as the renderer integrates them: XYZ = sum\n"
    "                  of L(l) cmf(l) over the sum of ybar (1 nm), not renormalised\n"
    "  --film IOR,NM[,DEGREES]\n"
    "                  the reflectance under D65 (as --reflectance) of a thin film\n"
    "                  of index IOR (>= 1) and thickness NM nanometres in air over\n"
    "                  BASE, a dielectric's index (>= 1) or a measured conductor\n"
    "                  (Au, Ag, Cu, Al), seen at DEGREES (0 <= DEGREES < 90, default\n"
    "                  0) from the normal: KHR_materials_iridescence's film as the\n"
    "                  renderer evaluates it (docs/gltf.md), per 1 nm\n"
    "\n"
    "Exit codes: 0 ok, 2 usage (a bad --film or its BASE too), 3 unknown SPD name,\n"
    "unreadable or invalid CSV, an SPD without luminance, or an EXR without\n"
    "spectral channels or with a band value that is negative or not finite.\n";

/* Prints v with six decimals, never as -0.000000. */
static void print_value(double v)
{
    char buf[64];
    snprintf(buf, sizeof buf, "%.6f", v);
    if (!strcmp(buf, "-0.000000"))
        strcpy(buf, "0.000000");
    printf(" %s", buf);
}

/* The wavelength in nm of an emissive spectral channel name "S0.<number>nm"
 * (Fichet et al. 2021: a comma or a point as the decimal separator); 0 when
 * the name is not one. */
static double channel_nm(const char *name)
{
    if (strncmp(name, "S0.", 3))
        return 0;
    char buf[64];
    snprintf(buf, sizeof buf, "%s", name + 3);
    size_t n = strlen(buf);
    if (n < 3 || strcmp(buf + n - 2, "nm"))
        return 0;
    buf[n - 2] = 0;
    for (char *p = buf; *p; p++)
        if (*p == ',')
            *p = '.';
    char *end;
    double v = strtod(buf, &end);
    return *end || !(v > 0) ? 0 : v;
}

/* The XYZ of pixel (x, y) of the spectral EXR at path, as the film's units
 * (docs/outputs.md, "Spectral images"): each channel is its band's mean
 * spectral radiance, so the spectrum is constant over each band, and XYZ is the
 * 1 nm sums of cmf times it over the sum of ybar. Band borders lie half way
 * between neighbouring channels' wavelengths, the outer ones as far out as the
 * nearest inner one (so equal bands, as the renderer writes, come out exactly);
 * a single channel covers the renderer's 360-830 nm. A 1 nm sample on a border
 * takes the mean of both bands. */
static int pixel_xyz(const char *path, long x, long y, double xyz[3], SptError *e)
{
    ExrLayers L;
    int rc = exr_read_layers(path, NULL, 0, &L, e);
    if (rc)
        return rc;
    SpdSample *band = spt_malloc(sizeof(SpdSample) * (size_t)(L.channel_count + 1));
    int n = 0;
    if (x < 0 || y < 0 || x >= L.width || y >= L.height) {
        rc = spt_fail(e, SPT_EXIT_USAGE, "color: --pixel %ld,%ld is outside %s (%dx%d)", x, y, path,
                      L.width, L.height);
        goto done;
    }
    for (int c = 0; c < L.channel_count; c++) {
        double w = channel_nm(L.channels[c].name);
        if (!(w > 0) || L.channels[c].type != SPT_EXR_FLOAT)
            continue;
        double v = ((const float *)L.channels[c].data)[(size_t)y * L.width + (size_t)x];
        if (!(v >= 0.0) || !isfinite(v)) {
            rc = spt_fail(e, SPT_EXIT_INPUT, "%s: pixel %ld,%ld, channel %s: %g is %s (a band's radiance is "
                          "finite and >= 0)", path, x, y, L.channels[c].name, v,
                          isfinite(v) ? "negative" : "not finite");
            goto done;
        }
        band[n].nm = w;
        band[n++].value = v;
    }
    if (n == 0) {
        rc = spt_fail(e, SPT_EXIT_INPUT, "%s: no spectral channels (S0.<wavelength>nm): not a spectral "
                      "EXR (spectrace render --spectral N writes one)", path);
        goto done;
    }
    spd_sort_samples(band, (size_t)n);
    for (int b = 1; b < n; b++)
        if (band[b].nm == band[b - 1].nm) {
            rc = spt_fail(e, SPT_EXIT_INPUT, "%s: two spectral channels at %g nm", path, band[b].nm);
            goto done;
        }
    xyz[0] = xyz[1] = xyz[2] = 0.0;
    for (int i = 0; i < SPT_CIE_SAMPLES; i++) {
        double l = SPT_CIE_LAMBDA_MIN + i, v = 0.0;
        int hits = 0;
        for (int b = 0; b < n; b++) {
            double lo = n == 1 ? SPT_CIE_LAMBDA_MIN
                        : b > 0 ? 0.5 * (band[b - 1].nm + band[b].nm)
                                : band[0].nm - 0.5 * (band[1].nm - band[0].nm);
            double hi = n == 1 ? SPT_CIE_LAMBDA_MAX
                        : b < n - 1 ? 0.5 * (band[b].nm + band[b + 1].nm)
                                    : band[b].nm + 0.5 * (band[b].nm - band[b - 1].nm);
            /* Borders compared to 1e-9 nm: the channel names carry 6 decimals. */
            if (l >= lo - 1e-9 && l <= hi + 1e-9) {
                v += band[b].value;
                hits++;
            }
        }
        if (hits)
            v /= hits;
        xyz[0] += SPT_CIE_X[i] * v;
        xyz[1] += SPT_CIE_Y[i] * v;
        xyz[2] += SPT_CIE_Z[i] * v;
    }
    for (int k = 0; k < 3; k++)
        xyz[k] /= SPT_CIE_Y_INTEGRAL;
done:
    free(band);
    exr_layers_free(&L);
    return rc;
}

/* The film of `--film` (IOR, NM, DEGREES in f[0..2]) over base (an index or a
 * conductor's name) as a reflectance spectrum at the CIE tables' 1 nm
 * samples, the renderer's own evaluation (kernels/closure/thin_film.h).
 * Returns SPT_EXIT_USAGE, with the message, for a base that is neither. */
static int film_spd(const double f[3], const char *base, Spd *out, SptError *e)
{
    static const char *const metals[SPT_CONDUCTOR_COUNT] = {"Au", "Ag", "Cu", "Al"};
    int metal = -1;
    for (int m = 0; m < SPT_CONDUCTOR_COUNT; m++)
        if (!strcasecmp(base, metals[m]))
            metal = m;
    char *end;
    double n = metal >= 0 ? 0.0 : strtod(base, &end);
    if (metal < 0 && (end == base || *end || !(n >= 1.0) || !(n <= 1e4)))
        return spt_fail(e, SPT_EXIT_USAGE, "color: --film base '%s' is neither an index in [1, 1e4] nor "
                        "Au, Ag, Cu or Al", base);
    double nm[SPT_CIE_SAMPLES], r[SPT_CIE_SAMPLES];
    float c = (float)cos(f[2] * (double)SPT_PI / 180.0);
    for (int i = 0; i < SPT_CIE_SAMPLES; i++) {
        float l = (float)(SPT_CIE_LAMBDA_MIN + i);
        float eta = metal >= 0 ? spt_conductor_lookup(metal, 0, l) : (float)n;
        float k = metal >= 0 ? spt_conductor_lookup(metal, 1, l) : 0.0f;
        nm[i] = l;
        r[i] = spt_thin_film_reflectance(c, l, 1.0f, (float)f[0], (float)f[1], eta, k);
    }
    return spd_from_samples(out, nm, r, SPT_CIE_SAMPLES, e);
}

/* Parses the arguments, evaluates the SPD and prints the three lines; returns an
 * exit code (SPT_EXIT_USAGE for bad arguments, SPT_EXIT_INPUT for a bad SPD). */
int cmd_color(int argc, char **argv)
{
    int reflectance = 0, options = 1, pixel = 0, film = 0;
    long px = 0, py = 0;
    double fv[3] = {0, 0, 0};
    const char *spd_text = NULL;
    for (int i = 1; i < argc; i++) {
        if (options && !strcmp(argv[i], "--")) {
            options = 0; /* what follows is the SPD, even when it starts with '-' */
        } else if (options && (!strcmp(argv[i], "--help") || !strcmp(argv[i], "-h"))) {
            fputs(color_usage, stdout);
            return SPT_EXIT_OK;
        } else if (options && !strcmp(argv[i], "--reflectance")) {
            reflectance = 1;
        } else if (options && !strcmp(argv[i], "--pixel")) {
            char tail;
            if (i + 1 >= argc || sscanf(argv[i + 1], "%ld,%ld%c", &px, &py, &tail) != 2) {
                spt_error("color: --pixel expects X,Y (whole numbers, e.g. --pixel 10,20)");
                return SPT_EXIT_USAGE;
            }
            pixel = 1;
            i++;
        } else if (options && !strcmp(argv[i], "--film")) {
            char tail;
            int got = i + 1 < argc ? sscanf(argv[i + 1], "%lf,%lf,%lf%c", &fv[0], &fv[1], &fv[2], &tail) : 0;
            if (got != 2 && got != 3) {
                spt_error("color: --film expects IOR,NM[,DEGREES] (e.g. --film 1.8,320 or --film 1.3,400,45)");
                return SPT_EXIT_USAGE;
            }
            if (!(fv[0] >= 1.0 && fv[0] <= 1e4) || !(fv[1] >= 0.0 && fv[1] <= 1e6) || !(fv[2] >= 0.0 && fv[2] < 90.0)) {
                spt_error("color: --film %s: the index must be in [1, 1e4], the thickness in [0, 1e6] nm and "
                          "the angle in [0, 90) degrees", argv[i + 1]);
                return SPT_EXIT_USAGE;
            }
            film = 1;
            i++;
        } else if (options && argv[i][0] == '-' && argv[i][1] != 0) {
            spt_error("color: unknown option '%s' (see spectrace color --help)", argv[i]);
            return SPT_EXIT_USAGE;
        } else if (spd_text) {
            spt_error("color: one SPD expected, got '%s' and '%s' (see spectrace color --help)",
                      spd_text, argv[i]);
            return SPT_EXIT_USAGE;
        } else {
            spd_text = argv[i];
        }
    }
    if (!spd_text) {
        spt_error("color: no SPD given (see spectrace color --help)");
        return SPT_EXIT_USAGE;
    }
    if (pixel && reflectance) {
        spt_error("color: --pixel and --reflectance do not go together (a pixel holds radiance)");
        return SPT_EXIT_USAGE;
    }
    if (film && (pixel || reflectance)) {
        spt_error("color: --film goes with neither --pixel nor --reflectance (a film is a reflectance)");
        return SPT_EXIT_USAGE;
    }
    Spd spd = {0};
    SptError e = {0};
    double xyz[3];
    if (pixel ? pixel_xyz(spd_text, px, py, xyz, &e)
              : film ? film_spd(fv, spd_text, &spd, &e) : spd_parse(&spd, spd_text, &e))
        return spt_report(&e);
    reflectance |= film;
    /* With --pixel, xyz holds pixel_xyz's sums already. */
    if (!pixel && reflectance) {
        spd_reflectance_to_xyz(&spd, xyz);
    } else if (!pixel) {
        spd_to_xyz(&spd, xyz);
        if (!(xyz[1] > 0.0)) {
            spd_free(&spd);
            spt_error("%s: the SPD has no luminance (Y = %g), so it cannot be normalised to Y = 1",
                      spd_text, xyz[1]);
            return SPT_EXIT_INPUT;
        }
        double y = xyz[1];
        for (int k = 0; k < 3; k++)
            xyz[k] /= y;
    }
    spd_free(&spd);
    if (!isfinite(xyz[0]) || !isfinite(xyz[1]) || !isfinite(xyz[2])) {
        spt_error("%s: the SPD's colour is not finite (XYZ %g %g %g)", spd_text, xyz[0], xyz[1],
                  xyz[2]);
        return SPT_EXIT_INPUT;
    }
    double rgb[3];
    xyz_to_linear_srgb(xyz, rgb);
    printf("XYZ");
    for (int k = 0; k < 3; k++)
        print_value(xyz[k]);
    printf("\nlinear-sRGB");
    for (int k = 0; k < 3; k++)
        print_value(rgb[k]);
    printf("\nsRGB8 %d %d %d\n", srgb_to_8bit(rgb[0]), srgb_to_8bit(rgb[1]), srgb_to_8bit(rgb[2]));
    return SPT_EXIT_OK;
}
