/* The lights of one render: the scene's emitters and punctual lights, the sky of
 * the render settings, and the distribution that picks among them. */
#include "render/render_lights.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "spectrum/cie_data.h"

void render_lights_free(RenderLights *L)
{
    env_free(&L->env);
    distrib_free(&L->select);
    free(L->tri_light_pdf);
    memset(L, 0, sizeof *L);
}

/* The environment of a render: the sky of the settings (src/scene/sky.h) as the
 * kernels' environment, a map rotated and scaled by env_rotation and
 * env_intensity; and for a scene with no light at all and no sky given, the
 * default sky, D65 of radiance 1 (linear sRGB 1, 1, 1), with a note. */
static int env_setup(const RenderSettings *rs, const GpuScene *g, EnvLight *env, SptError *e)
{
    memset(env, 0, sizeof *env);
    env->env.rot_cos = 1.0f;
    const Sky *sky = rs->sky;
    if (!(rs->env_intensity >= 0.0f) || !isfinite(rs->env_intensity))
        return spt_fail(e, SPT_EXIT_USAGE, "--env-intensity must be finite and >= 0");
    int kind = sky ? sky->kind : SPT_SKY_DEFAULT;
    if (kind == SPT_SKY_MAP)
        return env_build_map(env, sky->map, sky->map_width, sky->map_height,
                             rs->env_rotation * (float)(M_PI / 180.0), rs->env_intensity,
                             sky->env ? sky->env : "the environment map", e);
    if (kind == SPT_SKY_DEFAULT) {
        if (g->emitter_count > 0 || g->light_count > 0)
            return 0;
        spt_note("the scene has no lights: it is lit by a uniform white sky (D65, radiance 1); "
                 "use --env FILE or --background R,G,B|SPD|black to change it");
        const float white[3] = {1.0f, 1.0f, 1.0f};
        env_build_uniform(env, white, 1.0f);
        return 0;
    }
    if (kind == SPT_SKY_RGB) {
        if (sky->rgb[0] > 0 || sky->rgb[1] > 0 || sky->rgb[2] > 0)
            env_build_uniform(env, sky->rgb, 1.0f);
        return 0;
    }
    if (kind == SPT_SKY_SPD) {
        /* The SPD normalised to luminance Y = 1: a table in the environment's data. */
        env->data = spt_calloc(SPT_CIE_SAMPLES, sizeof(float));
        env->data_count = SPT_CIE_SAMPLES;
        memcpy(env->data, sky->spd, SPT_CIE_SAMPLES * sizeof(float));
        env->env.kind = SPT_ENV_UNIFORM;
        env->env.uniform.kind = SPT_SPEC_TABLE;
        env->env.uniform.scale = (float)(SPT_CIE_Y_INTEGRAL / sky->spd_y);
        env->env.uniform.offset = 0;
        env->y_mean = 1.0;
    }
    return 0; /* SPT_SKY_BLACK */
}

/* The lights of a render and the selection among them. */
int render_lights_setup(RenderLights *L, const GpuScene *g, const RenderSettings *rs,
                               SptError *e)
{
    memset(L, 0, sizeof *L);
    int rc = env_setup(rs, g, &L->env, e);
    if (rc)
        return rc;
    lights_build_selection(&L->select, g->emitter_power, g->emitter_count, g->lights, g->light_count,
                           g->spectra, &L->env, g->scene_radius);
    uint32_t n = g->prim_total;
    L->tri_light_pdf = spt_calloc(n ? n : 1, sizeof(float));
    for (uint32_t k = 0; k < g->emitter_count; k++)
        L->tri_light_pdf[g->emitters[k]] = distrib_prob(&L->select, k) / g->emitter_area[k];
    if (L->env.env.kind != SPT_ENV_NONE && L->select.n > 0)
        L->env_prob = distrib_prob(&L->select, L->select.n - 1);
    return 0;
}
