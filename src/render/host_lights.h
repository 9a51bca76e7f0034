/* Host construction of the light models of kernels/light/lights.h: punctual lights from
 * glTF KHR_lights_punctual (photometric units converted to spectral radiometric
 * ones), environment maps with their sampling distribution, and the one CDF that
 * picks among all lights in proportion to power.
 *
 * Photometric conversion: a glTF light of linear RGB colour c and intensity Iv
 * (cd for point/spot, lux for directional) gets the spectrum
 * S(l) = rgb_illuminant_coeffs(c) (D65 times the sigmoid spectrum) scaled so that
 * 683 lm/W * integral(ybar S) dl = Iv, i.e. radiometric total = Iv / K with
 * K = 683 integral(ybar S) / integral(S) the luminous efficacy of S (sums over
 * the 1 nm grid 360..830). The table is I(l) in W/(sr nm) (point, spot) or E(l)
 * in W/(m^2 nm) (directional). A light with a spectrum of its own (SceneLight
 * spd, from extras.spectrace.emission) gets that shape instead of the colour's,
 * scaled the same way: the colour is then not used. */
#ifndef SPT_HOST_LIGHTS_H
#define SPT_HOST_LIGHTS_H

#include <stdint.h>

#include "core/distribution.h"
#include "light/lights.h"
#include "scene/scene.h"
#include "core/util.h"

SPT_STATIC_ASSERT(sizeof(GpuLight) == 80, "GpuLight layout");
SPT_STATIC_ASSERT(sizeof(GpuEnvMap) == 64, "GpuEnvMap layout");

/* The spectral table (SPT_CIE_SAMPLES floats, 1 nm from 360 nm) of linear RGB
 * colour rgb as an illuminant, scaled so that 683 * sum(ybar table) equals
 * photometric (cd -> W/(sr nm), lux -> W/(m^2 nm), cd/m^2 -> W/(m^2 sr nm)).
 * A black colour or a photometric value of 0 gives all zeros. Returns the
 * luminous efficacy K (lm/W) of the colour's spectrum, 0 for black. */
double light_photometric_table(const float rgb[3], double photometric, float *table);

/* The same for the shape spd (spd_to_grid: a spectral line becomes its power
 * per nm in its 1 nm bin): table = k spd with 683 * sum(ybar table) =
 * photometric. Returns the luminous efficacy of spd, 0 when it has no luminance
 * (the table is then all zeros). */
double light_spd_table(const Spd *spd, double photometric, float *table);

/* The device light of scene light sl: geometry copied, spot cone turned into the
 * specification's scale/offset, spectrum (light_photometric_table's, times
 * SPT_LIGHT_FILM_PER_WATT: the film's units, where 1 cd/m^2 reads Y = 1) written
 * as a table into table
 * (SPT_CIE_SAMPLES floats) which the caller places at table_offset of the
 * renderer's spectra buffer. Returns SPT_EXIT_OK, or SPT_EXIT_INPUT naming the
 * light when its type is unknown, its intensity, colour, position or
 * direction is negative or not finite, or its spectrum has no luminance. */
int light_from_scene(const SceneLight *sl, float *table, uint32_t table_offset, GpuLight *out,
                     SptError *e);

/* The Y-weighted power of a light (W, weighted like the film's Y):
 * Py = integral(P(l) ybar(l)) dl / integral(ybar), with
 *   point: 4 pi I; spot: its flux, 2 pi I (x_inner + (x_outer - x_inner) / 3)
 *   with x = 1 - cos of each cone (the falloff's integral, GpuLight);
 *   directional: E pi r^2 (r = scene_radius, the
 *   bounding sphere the light crosses). spectra: the spectra buffer. */
double light_power(const GpuLight *l, const float *spectra, float scene_radius);

/* An environment ready to upload: the struct and its float buffer (texels,
 * marginal and conditional CDFs, or the uniform background's table). */
typedef struct EnvLight {
    GpuEnvMap env;
    float *data;
    uint32_t data_count;
    double y_mean;   /* film Y of the radiance averaged over the sphere */
} EnvLight;

/* Builds a map environment from rgb (width x height linear RGB triples, rows top
 * to bottom; see GpuEnvMap for the direction convention), rotated by
 * rotation_rad about +Y and scaled by intensity. Texels become illuminant
 * coefficients; row y, column x gets sampling weight Y(texel) sin(theta_y) at
 * the texel's centre. Returns SPT_EXIT_OK, or SPT_EXIT_INPUT (name in the
 * message) for a bad size, a non-finite or negative texel, or an intensity that
 * is negative or not finite; env is then zeroed. */
int env_build_map(EnvLight *env, const float *rgb, int width, int height, float rotation_rad,
                  float intensity, const char *name, SptError *e);

/* env_build_map from an image file, read as sky_from_args reads --env
 * (src/scene/sky.h). */
int env_load_map(EnvLight *env, const char *path, float rotation_rad, float intensity,
                 SptError *e);

/* A uniform background of linear RGB rgb times intensity (D65 times the sigmoid
 * spectrum, like a map texel), stored as sigmoid coefficients. */
void env_build_uniform(EnvLight *env, const float rgb[3], float intensity);

/* The environment's Y-weighted power estimate: pi * mean radiance Y over the
 * sphere * pi r^2 (r = scene_radius): the irradiance pi L a surface receives from
 * a hemisphere of that radiance, times the bounding disc's area, which is how
 * a directional light is counted too, so the two compare per receiving point.
 * (pbrt-v4's UniformInfiniteLight::Phi counts 4 pi^2 r^2 L, the flux through the
 * whole bounding sphere: 4 times this; either is only a selection weight.) */
double env_power(const EnvLight *env, float scene_radius);

void env_free(EnvLight *env);

/* One distribution over every light, in this order: tri_count emissive triangles
 * (weights tri_power[i], already Y-weighted powers: pi * area * Y(Le)), then
 * light_count punctual lights (light_power), then the environment when env is
 * not NULL and not SPT_ENV_NONE (env_power). Returns distrib_build's result. */
int lights_build_selection(Distrib *d, const float *tri_power, uint32_t tri_count,
                           const GpuLight *lights, uint32_t light_count, const float *spectra,
                           const EnvLight *env, float scene_radius);

#endif
