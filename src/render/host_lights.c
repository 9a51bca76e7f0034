/* Host construction of punctual lights, environments and the light selection
 * distribution (see render/host_lights.h). */
#include "render/host_lights.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "color/spd.h"
#include "scene/sky.h"

/* Trapezoid weight of grid sample i (the CIE integral over tabulated data). */
static double grid_weight(int i)
{
    return (i == 0 || i == SPT_CIE_SAMPLES - 1) ? 0.5 : 1.0;
}

/* The Y-weighted integral of a grid table: integral(t ybar) / integral(ybar). */
static double table_y(const float *t)
{
    double y = 0.0, n = 0.0;
    for (int i = 0; i < SPT_CIE_SAMPLES; i++) {
        y += grid_weight(i) * SPT_CIE_Y[i] * t[i];
        n += grid_weight(i) * SPT_CIE_Y[i];
    }
    return y / n;
}

/* Film Y of a spectrum s, evaluated on the 1 nm grid (spectra for tables). */
static double spec_y(SpecRef s, const float *spectra)
{
    float t[SPT_CIE_SAMPLES];
    for (int i = 0; i < SPT_CIE_SAMPLES; i++)
        t[i] = light_spec_value(s, spectra, (float)(SPT_CIE_LAMBDA_MIN + i));
    return table_y(t);
}

double light_photometric_table(const float rgb[3], double photometric, float *table)
{
    float c[3], scale;
    rgb_illuminant_coeffs(rgb, c, &scale);
    double y = 0.0, p = 0.0;
    double *s = malloc(sizeof(double) * SPT_CIE_SAMPLES);
    for (int i = 0; i < SPT_CIE_SAMPLES; i++) {
        float l = (float)(SPT_CIE_LAMBDA_MIN + i);
        s[i] = (double)scale * spt_sigmoid_poly(c[0], c[1], c[2], l) * SPT_D65_NORM[i];
        y += grid_weight(i) * SPT_CIE_Y[i] * s[i];
        p += grid_weight(i) * s[i];
    }
    /* 683 * integral(ybar k S) = photometric. */
    double k = (y > 0.0 && photometric > 0.0) ? photometric / (683.0 * y) : 0.0;
    for (int i = 0; i < SPT_CIE_SAMPLES; i++)
        table[i] = (float)(k * s[i]);
    free(s);
    return p > 0.0 ? 683.0 * y / p : 0.0;
}

double light_spd_table(const Spd *spd, double photometric, float *table)
{
    spd_to_grid(spd, table);
    double y = 0.0, p = 0.0;
    for (int i = 0; i < SPT_CIE_SAMPLES; i++) {
        y += grid_weight(i) * SPT_CIE_Y[i] * table[i];
        p += grid_weight(i) * table[i];
    }
    /* 683 * integral(ybar k S) = photometric, as for a colour. */
    double k = (y > 0.0 && photometric > 0.0) ? photometric / (683.0 * y) : 0.0;
    for (int i = 0; i < SPT_CIE_SAMPLES; i++)
        table[i] = (float)(k * table[i]);
    return p > 0.0 && y > 0.0 ? 683.0 * y / p : 0.0;
}

/* 1 when all n values are finite, else 0. */
static int all_finite(const float *v, int n)
{
    for (int i = 0; i < n; i++)
        if (!isfinite(v[i]))
            return 0;
    return 1;
}

int light_from_scene(const SceneLight *sl, float *table, uint32_t table_offset, GpuLight *out,
                     SptError *e)
{
    memset(out, 0, sizeof *out);
    /* The light in messages: its object in the file (and its name, unless the
     * loader's "light" for an unnamed one), else its name. */
    char who[256];
    if (sl->object[0] && strcmp(sl->name, "light") != 0)
        snprintf(who, sizeof who, "%s ('%s')", sl->object, sl->name);
    else if (sl->object[0])
        snprintf(who, sizeof who, "%s", sl->object);
    else
        snprintf(who, sizeof who, "light '%s'", sl->name);
    if (sl->type != SPT_LIGHT_POINT && sl->type != SPT_LIGHT_SPOT &&
        sl->type != SPT_LIGHT_DIRECTIONAL)
        return spt_fail(e, SPT_EXIT_INPUT, "%s: unknown type %d", who, sl->type);
    if (!(isfinite(sl->intensity) && sl->intensity >= 0.0f))
        return spt_fail(e, SPT_EXIT_INPUT, "%s: intensity %g is not a finite value >= 0",
                        who, sl->intensity);
    if (!all_finite(sl->color, 3) || sl->color[0] < 0.0f || sl->color[1] < 0.0f ||
        sl->color[2] < 0.0f)
        return spt_fail(e, SPT_EXIT_INPUT, "%s: colour (%g, %g, %g) must be finite and >= 0",
                        who, sl->color[0], sl->color[1], sl->color[2]);
    if (!all_finite(sl->position, 3) || !all_finite(sl->direction, 3))
        return spt_fail(e, SPT_EXIT_INPUT, "%s: position or direction is not finite", who);
    double dl = sqrt((double)sl->direction[0] * sl->direction[0] +
                     (double)sl->direction[1] * sl->direction[1] +
                     (double)sl->direction[2] * sl->direction[2]);
    if (sl->type != SPT_LIGHT_POINT && !(dl > 0.0))
        return spt_fail(e, SPT_EXIT_INPUT, "%s: zero direction", who);
    out->type = (spt_u32)sl->type;
    for (int a = 0; a < 3; a++) {
        out->pos[a] = sl->position[a];
        out->dir[a] = dl > 0.0 ? (float)(sl->direction[a] / dl) : (a == 2 ? -1.0f : 0.0f);
    }
    if (sl->type == SPT_LIGHT_SPOT) {
        /* KHR_lights_punctual: 0 <= inner < outer <= pi/2. The falloff in
         * x = 1 - cos (GpuLight): 1 - cos(a) = 2 sin^2(a/2) and
         * cos(inner) - cos(outer) = 2 sin((outer + inner)/2) sin((outer - inner)/2)
         * keep their digits for cones of a fraction of a degree, where cos
         * rounds to 1 in float. inner = outer is a hard edge. */
        double outer = fmin(fmax((double)sl->outer_cone, 0.0), 0.5 * M_PI);
        double inner = fmin(fmax((double)sl->inner_cone, 0.0), outer);
        double width = 2.0 * sin(0.5 * (outer + inner)) * sin(0.5 * (outer - inner));
        out->cos_outer = (float)cos(outer);
        out->cos_inner = (float)cos(inner);
        out->spot_span = (float)(2.0 * sin(0.5 * outer) * sin(0.5 * outer));
        out->spot_scale = width > 1e-30 ? (float)(1.0 / width) : 1e30f;
    } else {
        out->cos_outer = -1.0f;
        out->cos_inner = -1.0f;
        out->spot_scale = 0.0f;
        out->spot_span = 2.0f;
    }
    /* W/(sr nm) or W/(m^2 nm), into the film's units (kernels/light/lights.h). */
    if (sl->spd.count > 0 || sl->spd.line_count > 0) {
        if (!(light_spd_table(&sl->spd, sl->intensity, table) > 0.0))
            return spt_fail(e, SPT_EXIT_INPUT, "%s: its spectrum has no luminance (nothing "
                            "visible in 360-830 nm), so no level gives it its intensity", who);
    } else {
        light_photometric_table(sl->color, sl->intensity, table);
    }
    for (int i = 0; i < SPT_CIE_SAMPLES; i++) {
        table[i] *= SPT_LIGHT_FILM_PER_WATT;
        if (!(table[i] <= SPT_MAX_INPUT_VALUE))
            return spt_fail(e, SPT_EXIT_INPUT, "%s: intensity %g is too large: its "
                            "spectrum reaches %g, above the 1e30 the renderer's float "
                            "arithmetic can carry", who, sl->intensity, (double)table[i]);
    }
    out->spectrum.kind = SPT_SPEC_TABLE;
    out->spectrum.scale = 1.0f;
    out->spectrum.offset = table_offset;
    return SPT_EXIT_OK;
}

double light_power(const GpuLight *l, const float *spectra, float scene_radius)
{
    double y = spec_y(l->spectrum, spectra);
    if (l->type == SPT_PUNCTUAL_POINT)
        return 4.0 * M_PI * y;
    if (l->type == SPT_PUNCTUAL_SPOT) {
        /* The flux: 2 pi times the falloff's integral over x = 1 - cos, full
         * up to the inner cone's x, then t^2 falling linearly in x to 0 at
         * the outer cone's (a third of the transition). */
        double span = l->spot_span, width = fmin(1.0 / (double)l->spot_scale, span);
        return 2.0 * M_PI * (span - width + width / 3.0) * y;
    }
    return y * M_PI * (double)scene_radius * scene_radius;
}

int env_build_map(EnvLight *env, const float *rgb, int width, int height, float rotation_rad,
                  float intensity, const char *name, SptError *e)
{
    memset(env, 0, sizeof *env);
    if (width < 1 || height < 1 || (int64_t)width * height > (1 << 28))
        return spt_fail(e, SPT_EXIT_INPUT, "%s: environment map size %dx%d is not usable", name,
                        width, height);
    if (!(isfinite(intensity) && intensity >= 0.0f) || !isfinite(rotation_rad))
        return spt_fail(e, SPT_EXIT_INPUT,
                        "%s: environment intensity %g or rotation %g is not usable", name,
                        intensity, rotation_rad);
    size_t n = (size_t)width * (size_t)height;
    for (size_t i = 0; i < 3 * n; i++) {
        if (!(isfinite(rgb[i]) && rgb[i] >= 0.0f))
            return spt_fail(e, SPT_EXIT_INPUT,
                            "%s: environment texel (%zu, %zu) has a negative or non-finite value",
                            name, (i / 3) % (size_t)width, (i / 3) / (size_t)width);
        if ((double)rgb[i] * intensity > SPT_MAX_INPUT_VALUE)
            return spt_fail(e, SPT_EXIT_INPUT,
                            "%s: environment texel (%zu, %zu) is %g (times intensity %g), above "
                            "the 1e30 the renderer's float arithmetic can carry", name,
                            (i / 3) % (size_t)width, (i / 3) / (size_t)width, (double)rgb[i],
                            (double)intensity);
    }
    GpuEnvMap *g = &env->env;
    g->kind = SPT_ENV_MAP;
    g->width = width;
    g->height = height;
    g->rot_cos = cosf(rotation_rad);
    g->rot_sin = sinf(rotation_rad);
    g->texel_offset = 0;
    g->marginal_offset = (uint32_t)(4 * n);
    g->conditional_offset = g->marginal_offset + (uint32_t)height + 1u;
    env->data_count = (uint32_t)sky_map_data_floats(width, height);
    env->data = spt_calloc(env->data_count, sizeof(float));
    float *row_w = spt_malloc(sizeof(float) * (size_t)(width > height ? width : height));
    float *row_sum = spt_malloc(sizeof(float) * (size_t)height);
    double y_sum = 0.0;
    for (int y = 0; y < height; y++) {
        double st = sin(M_PI * (y + 0.5) / height);
        for (int x = 0; x < width; x++) {
            const float *c = rgb + 3 * ((size_t)y * width + x);
            float col[3] = {c[0] * intensity, c[1] * intensity, c[2] * intensity};
            float *t = env->data + 4 * ((size_t)y * width + x);
            rgb_illuminant_coeffs_fast(col, t, &t[3]);
            /* The luminance of linear sRGB (the Y row of docs/architecture.md's matrix). */
            double lum = 0.2126 * col[0] + 0.7152 * col[1] + 0.0722 * col[2];
            row_w[x] = (float)(lum * st);
            /* Solid angle of the texel, for the mean over the sphere. */
            y_sum += lum * (2.0 * M_PI / width) *
                     (cos(M_PI * y / height) - cos(M_PI * (y + 1.0) / height));
        }
        Distrib dc;
        distrib_build(&dc, row_w, (uint32_t)width);
        memcpy(env->data + g->conditional_offset + (size_t)y * (width + 1), dc.cdf,
               sizeof(float) * (size_t)(width + 1));
        row_sum[y] = (float)dc.total;
        distrib_free(&dc);
    }
    Distrib dm;
    distrib_build(&dm, row_sum, (uint32_t)height);
    memcpy(env->data + g->marginal_offset, dm.cdf, sizeof(float) * (size_t)(height + 1));
    distrib_free(&dm);
    env->y_mean = y_sum / (4.0 * M_PI);
    free(row_w);
    free(row_sum);
    return SPT_EXIT_OK;
}

int env_load_map(EnvLight *env, const char *path, float rotation_rad, float intensity,
                 SptError *e)
{
    Sky sky;
    memset(env, 0, sizeof *env);
    int rc = sky_from_args(&sky, path, NULL, e);
    if (rc != SPT_EXIT_OK)
        return rc;
    rc = env_build_map(env, sky.map, sky.map_width, sky.map_height, rotation_rad, intensity, path, e);
    sky_free(&sky);
    return rc;
}

void env_build_uniform(EnvLight *env, const float rgb[3], float intensity)
{
    memset(env, 0, sizeof *env);
    float col[3] = {rgb[0] * intensity, rgb[1] * intensity, rgb[2] * intensity};
    env->env.kind = SPT_ENV_UNIFORM;
    env->env.rot_cos = 1.0f;
    rgb_illuminant_coeffs(col, env->env.uniform.c, &env->env.uniform.scale);
    env->env.uniform.kind = SPT_SPEC_SIGMOID;
    env->env.uniform.flags = SPT_SPEC_ILLUMINANT;
    env->y_mean = spec_y(env->env.uniform, NULL);
}

double env_power(const EnvLight *env, float scene_radius)
{
    if (env->env.kind == SPT_ENV_NONE)
        return 0.0;
    return M_PI * env->y_mean * M_PI * (double)scene_radius * scene_radius;
}

void env_free(EnvLight *env)
{
    free(env->data);
    memset(env, 0, sizeof *env);
}

int lights_build_selection(Distrib *d, const float *tri_power, uint32_t tri_count,
                           const GpuLight *lights, uint32_t light_count, const float *spectra,
                           const EnvLight *env, float scene_radius)
{
    int has_env = env && env->env.kind != SPT_ENV_NONE;
    uint32_t n = tri_count + light_count + (has_env ? 1u : 0u);
    float *w = spt_malloc(sizeof(float) * (n ? n : 1));
    for (uint32_t i = 0; i < tri_count; i++)
        w[i] = tri_power[i];
    for (uint32_t i = 0; i < light_count; i++)
        w[tri_count + i] = (float)light_power(&lights[i], spectra, scene_radius);
    if (has_env)
        w[n - 1] = (float)env_power(env, scene_radius);
    int ok = distrib_build(d, w, n);
    free(w);
    return ok;
}
