/* The sky of the command line (src/scene/sky.h). */
#include "scene/sky.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>

#include "color/spd.h"
#include "io/image_io.h"
#include "io/image_in.h"
#include "core/input_file.h"
#include "spectrum/cie_data.h"

/* The map of an image file, values as stored: an 8- or 16-bit integer file (PNG,
 * JPEG, ...) holds sRGB-encoded display values, decoded to linear (an LDR map
 * cannot hold the sun's range; HDR or EXR maps are meant). Float files are
 * linear as stored. */
size_t sky_map_data_floats(int width, int height)
{
    if (width < 1 || height < 1)
        return 0;
    return 4 * (size_t)width * (size_t)height + (size_t)height + 1 +
           (size_t)height * ((size_t)width + 1);
}

/* Whether the map of info fits the memory before it is read
 * (docs/limits.md, "The memory estimate"): its texels as read (every channel
 * as float) and as kept (RGB), then the renderer's data of it
 * (sky_map_data_floats) and a CPU device's copy of that; too much is an input
 * too big (SPT_EXIT_INPUT). */
static int sky_map_fits(const char *path, const ImageIoInfo *info, SptError *e)
{
    double texels = (double)info->width * (double)info->height;
    double kept = 3.0 * sizeof(float) * texels;
    double read = (double)info->channels * sizeof(float) * texels;
    double data = 2.0 * sizeof(float) * (double)sky_map_data_floats(info->width, info->height);
    double need = kept + (read > data ? read : data), limit = spt_memory_limit();
    char a[32], b[32];
    if (limit > 0 && need > limit)
        return spt_fail(e, SPT_EXIT_INPUT, "%s: a %dx%d environment map needs about %s of host "
                        "memory (its texels, sampling tables and a device's copy), more than the "
                        "%s %s", path, info->width,
                        info->height, spt_format_bytes(a, sizeof a, need),
                        spt_format_bytes(b, sizeof b, limit), spt_memory_limit_why());
    return SPT_EXIT_OK;
}

static int sky_load_map(Sky *sky, const char *path, SptError *e)
{
    float *rgb = NULL;
    int w = 0, h = 0;
    int rc = input_check(path, "environment map", e);
    /* A header that cannot be read is left to image_read_rgb to report. */
    ImageIoInfo head;
    SptError e_head = {0};
    if (rc == SPT_EXIT_OK && image_io_info(path, &head, &e_head) == SPT_EXIT_OK)
        rc = sky_map_fits(path, &head, e);
    if (rc == SPT_EXIT_OK)
        rc = image_read_rgb(path, &rgb, &w, &h, e);
    if (rc != SPT_EXIT_OK)
        return rc;
    ImageIoInfo info;
    SptError e2 = {0};
    if (image_io_info(path, &info, &e2) == SPT_EXIT_OK && strncmp(info.format, "uint", 4) == 0 &&
        strcmp(info.format_name, "hdr") != 0)
        for (size_t i = 0; i < (size_t)w * (size_t)h * 3; i++)
            rgb[i] = (float)srgb_decode(rgb[i]);
    for (size_t i = 0; i < (size_t)w * (size_t)h * 3; i++)
        if (!(rgb[i] >= 0.0f && rgb[i] <= SPT_MAX_INPUT_VALUE)) {
            float v = rgb[i];
            free(rgb);
            return spt_fail(e, SPT_EXIT_INPUT, "%s: texel (%zu, %zu) has the value %g: an "
                            "environment map's values must be finite, >= 0 and at most 1e30",
                            path, (i / 3) % (size_t)w, (i / 3) / (size_t)w, (double)v);
        }
    sky->kind = SPT_SKY_MAP;
    sky->map = rgb;
    sky->map_width = w;
    sky->map_height = h;
    return SPT_EXIT_OK;
}

/* --background SKY: black, R,G,B or an SPD. */
static int sky_parse_background(Sky *sky, const char *bg, SptError *e)
{
    float rgb[3];
    char extra;
    if (!strcasecmp(bg, "black") || !strcasecmp(bg, "none")) {
        sky->kind = SPT_SKY_BLACK;
        return SPT_EXIT_OK;
    }
    if (sscanf(bg, "%f,%f,%f%c", &rgb[0], &rgb[1], &rgb[2], &extra) == 3) {
        if (!(rgb[0] >= 0 && rgb[1] >= 0 && rgb[2] >= 0) || !isfinite(rgb[0] + rgb[1] + rgb[2]))
            return spt_fail(e, SPT_EXIT_USAGE, "--background '%s': colour components must be finite and >= 0", bg);
        if (rgb[0] > SPT_MAX_INPUT_VALUE || rgb[1] > SPT_MAX_INPUT_VALUE || rgb[2] > SPT_MAX_INPUT_VALUE)
            return spt_fail(e, SPT_EXIT_USAGE, "--background '%s': colour components must be at "
                            "most 1e30 (the renderer computes in float)", bg);
        sky->kind = SPT_SKY_RGB;
        memcpy(sky->rgb, rgb, sizeof rgb);
        return SPT_EXIT_OK;
    }
    /* An SPD, normalised to luminance Y = 1 when rendered. */
    Spd spd;
    SptError e2 = {0};
    /* A file that is there is bad input (its messages name it); anything else
     * is a bad option value. */
    struct stat st;
    int is_file = stat(bg, &st) == 0;
    if (spd_parse(&spd, bg, &e2)) {
        if (is_file)
            return spt_fail(e, e2.code, "--background: %s", e2.msg);
        return spt_fail(e, SPT_EXIT_USAGE, "--background '%s': %s", bg, e2.msg);
    }
    double xyz[3];
    spd_to_xyz(&spd, xyz);
    /* Normalised here, in double: a dim SPD's own values (a blackbody of 100 K
     * peaks at 1e-35 in the visible) underflow float, where the renderer's
     * table is. First by the 1 nm sums, then by what the renderer integrates:
     * the product of the table and ybar, both linear between the 1 nm samples
     * (the two differ for a steep SPD: a blackbody of 30 K has all its
     * luminance in the last nm, which the sums count twice). The luminance of
     * the float table must then be 1 to float's precision, or the SPD cannot be
     * carried. */
    double k = SPT_CIE_Y_INTEGRAL / xyz[1], y_grid = 0.0;
    if (xyz[1] > 0 && isfinite(k)) {
        for (int i = 0; i < spd.count; i++)
            spd.value[i] *= k;
        for (int i = 0; i < spd.line_count; i++)
            spd.line_power[i] *= k;
        sky->spd = spt_calloc(SPT_CIE_SAMPLES, sizeof(float));
        spd_to_grid(&spd, sky->spd);
        for (int pass = 0; pass < 2; pass++) {
            y_grid = 0.0;
            for (int i = 0; i + 1 < SPT_CIE_SAMPLES; i++) {
                double ya = SPT_CIE_Y[i], yb = SPT_CIE_Y[i + 1], ga = sky->spd[i], gb = sky->spd[i + 1];
                y_grid += (2.0 * ya * ga + ya * gb + yb * ga + 2.0 * yb * gb) / 6.0;
            }
            if (pass == 0 && y_grid > 0)
                for (int i = 0; i < SPT_CIE_SAMPLES; i++)
                    sky->spd[i] = (float)(sky->spd[i] * (SPT_CIE_Y_INTEGRAL / y_grid));
        }
    }
    spd_free(&spd);
    if (!(fabs(y_grid / SPT_CIE_Y_INTEGRAL - 1.0) < 1e-3)) {
        free(sky->spd);
        sky->spd = NULL;
        const char *why = xyz[1] > 0 ? "its luminance is lost in the renderer's float arithmetic"
                                     : "the SPD has no luminance (Y = 0 in 360-830 nm, or too dim to compute)";
        if (is_file)
            return spt_fail(e, SPT_EXIT_INPUT, "--background: %s: %s, so it cannot be normalised to Y = 1", bg, why);
        return spt_fail(e, SPT_EXIT_USAGE, "--background '%s': %s, so it cannot be normalised to Y = 1", bg, why);
    }
    sky->kind = SPT_SKY_SPD;
    /* The table's luminance is 1 already: render_lights.c scales by
     * SPT_CIE_Y_INTEGRAL / spd_y. */
    sky->spd_y = SPT_CIE_Y_INTEGRAL;
    return SPT_EXIT_OK;
}

int sky_from_args(Sky *sky, const char *env_path, const char *background, SptError *e)
{
    memset(sky, 0, sizeof *sky);
    if (env_path && background)
        return spt_fail(e, SPT_EXIT_USAGE, "--env and --background both set the sky; give one of them");
    int rc = SPT_EXIT_OK;
    if (env_path)
        rc = sky_load_map(sky, env_path, e);
    else if (background)
        rc = sky_parse_background(sky, background, e);
    if (rc) {
        sky_free(sky);
        return rc;
    }
    sky->env = env_path ? spt_strdup(env_path) : NULL;
    sky->background = background ? spt_strdup(background) : NULL;
    return SPT_EXIT_OK;
}

void sky_free(Sky *sky)
{
    free(sky->spd);
    free(sky->map);
    free(sky->env);
    free(sky->background);
    memset(sky, 0, sizeof *sky);
}
