/* `spectrace color [--reflectance] SPD`: the colour of an SPD, normalised to Y = 1. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "cli/commands.h"
#include "color/spd.h"
#include "core/util.h"

static const char color_usage[] =
    "usage: spectrace color [--reflectance] [--] SPD\n"
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
    "\n"
    "Exit codes: 0 ok, 2 usage, 3 unknown SPD name, unreadable or invalid CSV, or an\n"
    "SPD without luminance.\n";

/* Prints v with six decimals, never as -0.000000. */
static void print_value(double v)
{
    char buf[64];
    snprintf(buf, sizeof buf, "%.6f", v);
    if (!strcmp(buf, "-0.000000"))
        strcpy(buf, "0.000000");
    printf(" %s", buf);
}

/* Parses the arguments, evaluates the SPD and prints the three lines; returns an
 * exit code (SPT_EXIT_USAGE for bad arguments, SPT_EXIT_INPUT for a bad SPD). */
int cmd_color(int argc, char **argv)
{
    int reflectance = 0, options = 1;
    const char *spd_text = NULL;
    for (int i = 1; i < argc; i++) {
        if (options && !strcmp(argv[i], "--")) {
            options = 0; /* what follows is the SPD, even when it starts with '-' */
        } else if (options && (!strcmp(argv[i], "--help") || !strcmp(argv[i], "-h"))) {
            fputs(color_usage, stdout);
            return SPT_EXIT_OK;
        } else if (options && !strcmp(argv[i], "--reflectance")) {
            reflectance = 1;
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
    Spd spd;
    SptError e = {0};
    if (spd_parse(&spd, spd_text, &e))
        return spt_report(&e);
    double xyz[3];
    if (reflectance) {
        spd_reflectance_to_xyz(&spd, xyz);
    } else {
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
