/* The sky: what rays that leave the scene see, as the command line describes it
 * (--env, --background), decided before any device work and carried with the
 * scene (also to MPI ranks, which may not see the files). The renderer turns it
 * into the kernels' environment (src/render/render_lights.c), applying
 * RenderSettings' env_rotation and env_intensity to a map. */
#ifndef SPT_SKY_H
#define SPT_SKY_H

#include "core/util.h"

enum {
    SPT_SKY_DEFAULT = 0, /* nothing given: a scene without lights gets a white sky */
    SPT_SKY_BLACK,       /* "black", "none": no light from outside */
    SPT_SKY_RGB,         /* a uniform linear sRGB colour, upsampled as an illuminant */
    SPT_SKY_SPD,         /* a uniform SPD, normalised to luminance Y = 1 */
    SPT_SKY_MAP          /* an equirectangular map of linear RGB */
};

typedef struct Sky {
    int kind;                 /* SPT_SKY_* */
    float rgb[3];             /* SPT_SKY_RGB */
    float *spd;               /* SPT_SKY_SPD: SPT_CIE_SAMPLES floats, the SPD on the 1 nm grid */
    double spd_y;             /* SPT_SKY_SPD: the table's luminance Y (> 0; the sums
                                 of ybar times it, SPT_CIE_Y_INTEGRAL for luminance 1) */
    float *map;               /* SPT_SKY_MAP: 3 floats per texel, rows top to bottom */
    int map_width, map_height;
    /* Where it came from, as given on the command line (NULL: not given): for
     * messages, and for the checkpoint key, which counts files by content. */
    char *env;
    char *background;
} Sky;

/* The sky of --env FILE and --background SKY (either may be NULL, not both):
 * reads the map file (8- and 16-bit files are sRGB-decoded; HDR and EXR are
 * linear), or parses R,G,B, black/none or an SPD (name, blackbody:K, CSV file).
 * Returns SPT_EXIT_OK; SPT_EXIT_USAGE for both given, a bad colour or an SPD
 * without luminance; SPT_EXIT_INPUT for a map that cannot be read. */
int sky_from_args(Sky *sky, const char *env_path, const char *background, SptError *e);

void sky_free(Sky *sky);

/* The floats of the environment data the renderer makes of a width x height
 * map (src/render/host_lights.c, env_build_map): the texels' spectra (4 per
 * texel) and the sampling tables (a marginal CDF of height + 1, a conditional
 * CDF of width + 1 per row); 0 for an empty size. */
size_t sky_map_data_floats(int width, int height);

#endif
