/* The lights of one render: the scene's emitters and punctual lights, the sky of
 * the render settings, and the distribution that picks among them. */
#include "render/render_lights.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "shared/cie_data.h"

void render_lights_free(RenderLights *L)
{
    env_free(&L->env);
    distrib_free(&L->select);
    free(L->tri_light_pdf);
    memset(L, 0, sizeof *L);
}

/* The environment of a render (RenderSettings env_path, background): a map from
 * --env, a uniform sky from --background (linear sRGB upsampled as an illuminant,
 * or an SPD normalised to luminance Y = 1), nothing for "black", and for a scene
 * with no light at all the default sky, D65 of radiance 1 (linear sRGB 1, 1, 1),
 * with a note. */
static int env_setup(const RenderSettings *rs, const GpuScene *g, EnvLight *env, SptError *e)
{
    memset(env, 0, sizeof *env);
    env->env.rot_cos = 1.0f;
    const char *bg = rs->background;
    float rgb[3];
    char extra;
    if (rs->env_path && bg)
        return spt_fail(e, SPT_EXIT_USAGE, "--env and --background both set the sky; give one of them");
    if (!(rs->env_intensity >= 0.0f) || !isfinite(rs->env_intensity))
        return spt_fail(e, SPT_EXIT_USAGE, "--env-intensity must be finite and >= 0");
    if (rs->env_path)
        return env_load_map(env, rs->env_path, rs->env_rotation_deg * (float)(M_PI / 180.0),
                            rs->env_intensity, e);
    if (!bg) {
        if (g->emitter_count > 0 || g->light_count > 0)
            return 0;
        spt_note("the scene has no lights: it is lit by a uniform white sky (D65, radiance 1); "
                 "use --env FILE or --background R,G,B|SPD|black to change it");
        bg = "1,1,1";
    }
    if (!strcasecmp(bg, "black") || !strcasecmp(bg, "none"))
        return 0;
    if (sscanf(bg, "%f,%f,%f%c", &rgb[0], &rgb[1], &rgb[2], &extra) == 3) {
        if (!(rgb[0] >= 0 && rgb[1] >= 0 && rgb[2] >= 0) || !isfinite(rgb[0] + rgb[1] + rgb[2]))
            return spt_fail(e, SPT_EXIT_USAGE, "--background '%s': colour components must be finite and >= 0", bg);
        if (rgb[0] > 0 || rgb[1] > 0 || rgb[2] > 0)
            env_build_uniform(env, rgb, 1.0f);
        return 0;
    }
    /* An SPD, normalised to luminance Y = 1: a table in the environment's data. */
    Spd spd;
    SptError e2 = {0};
    if (spd_parse(&spd, bg, &e2))
        return spt_fail(e, SPT_EXIT_USAGE, "--background '%s': %s", bg, e2.msg);
    double xyz[3];
    spd_to_xyz(&spd, xyz);
    env->data = spt_calloc(SPT_CIE_SAMPLES, sizeof(float));
    env->data_count = SPT_CIE_SAMPLES;
    spd_to_grid(&spd, env->data);
    spd_free(&spd);
    if (!(xyz[1] > 0)) {
        env_free(env);
        return spt_fail(e, SPT_EXIT_USAGE, "--background '%s': the SPD has no luminance", bg);
    }
    env->env.kind = SPT_ENV_UNIFORM;
    env->env.uniform.kind = SPT_SPEC_TABLE;
    env->env.uniform.scale = (float)(SPT_CIE_Y_INTEGRAL / xyz[1]);
    env->env.uniform.offset = 0;
    env->y_mean = 1.0;
    return 0;
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
    uint32_t n = g->bvh.prim_count;
    L->tri_light_pdf = spt_calloc(n ? n : 1, sizeof(float));
    for (uint32_t k = 0; k < g->emitter_count; k++)
        L->tri_light_pdf[g->emitters[k]] = distrib_prob(&L->select, k) / g->emitter_area[k];
    if (L->env.env.kind != SPT_ENV_NONE && L->select.n > 0)
        L->env_prob = distrib_prob(&L->select, L->select.n - 1);
    return 0;
}
