/* A finished render on its way to its images (src/render/render_result.h). */
#include "render/render_result.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "io/atomic_file.h"

/* The bytes of writing the images (RenderHostMemory.outputs). */
static double output_bytes(const RenderSettings *rs, const char *const *outputs, int count)
{
    size_t np = (size_t)rs->width * (size_t)rs->height, floats = 3;
    if (rs->aov)
        floats += (size_t)SPT_FILM_AOV_LAYERS * 3;
    if (rs->spectral > 0)
        floats += (size_t)rs->spectral;
    if (rs->denoise)
        floats += 3 * 3;
    size_t bytes = np * floats * sizeof(float);
    for (int i = 0; i < count; i++) {
        const char *dot = strrchr(outputs[i], '.');
        if (!dot || strcasecmp(dot, ".exr"))
            bytes += np * 16;
    }
    return (double)bytes;
}

int render_host_memory(const ClDeviceInfo *const *infos, int count, const GpuScene *g,
                       const SceneCamera *cam, const RenderSettings *rs,
                       const char *const *outputs, int output_count, RenderHostMemory *m,
                       SptError *e)
{
    RenderMemory rm;
    render_memory(infos, count, g, cam, rs, &rm);
    m->film = (double)film_bytes(rs->width, rs->height, render_keeps_aov(rs), rs->spectral);
    m->render = (double)rm.total;
    m->outputs = output_bytes(rs, outputs, output_count);
    m->need = m->film + fmax(m->render, m->outputs);
    m->loaded = 0.0;
#define LOADED(type, name) m->loaded += (double)gpu_scene_buffer_bytes(g, NULL, #name);
    SPT_SCENE_BUFFERS(LOADED)
#undef LOADED
    if (rs->sky && rs->sky->kind == SPT_SKY_MAP)
        m->loaded += 3.0 * sizeof(float) * (double)rs->sky->map_width * (double)rs->sky->map_height;
    double limit = spt_memory_limit();
    char a[32], b[32], c[32], d[32], f[32];
    if (limit > 0 && m->need > limit)
        return spt_fail(e, SPT_EXIT_DEVICE, "render: a %dx%d render needs about %s of host memory "
                        "(film %s, then the larger of the render's %s and the outputs' %s), more "
                        "than the %s %s",
                        rs->width, rs->height, spt_format_bytes(a, sizeof a, m->need),
                        spt_format_bytes(b, sizeof b, m->film), spt_format_bytes(c, sizeof c, m->render),
                        spt_format_bytes(d, sizeof d, m->outputs), spt_format_bytes(f, sizeof f, limit),
                        spt_memory_limit_why());
    return SPT_EXIT_OK;
}

int render_film_check(Film *f, const RenderSettings *rs, const char *scene, SptError *e)
{
    long npix = (long)f->width * f->height;
    for (long i = 0; i < rs->test.film_nan && i < npix; i++)
        f->xyz[3 * i] = NAN;
    /* The sums of squares count only for the variance layer (a checkpoint
     * checks its own film, src/render/checkpoint.c). */
    size_t bad = film_nonfinite_except_squares(f);
    if (bad)
        return spt_fail(e, SPT_EXIT_FAILURE, "render: %zu of %ld pixels came out NaN or infinite (an "
                        "internal error); no output written", bad, npix);
    if ((rs->aov & SPT_AOV_VARIANCE) && (bad = film_nonfinite_pixels(f)))
        return spt_fail(e, SPT_EXIT_INPUT, "%s: --aov variance: %zu of %ld pixels are too bright for "
                        "the variance layer (the sums of their radiance squared pass float's range, "
                        "3.4e38: docs/limits.md); no output written", scene, bad, npix);
    if ((rs->aov & SPT_AOV_VARIANCE) && (bad = film_subnormal_square_pixels(f)))
        spt_warn("%s: --aov variance: %zu of %ld pixels are too dim for the variance layer (their "
                 "radiance squared is below float's normal range, 1.2e-38: docs/limits.md); their "
                 "variance is inexact, or 0 on a device that flushes such values",
                 scene, bad, npix);
    return SPT_EXIT_OK;
}

/* Whether the sky is black: --background black, none or R,G,B all 0, or --env
 * with intensity 0 or a map whose every texel is 0 (the renderer leaves these
 * unlit). */
static int sky_is_black(const Sky *sky, double env_intensity)
{
    if (sky->kind == SPT_SKY_MAP && env_intensity > 0) {
        size_t n = (size_t)sky->map_width * (size_t)sky->map_height * 3;
        for (size_t i = 0; i < n; i++)
            if (sky->map[i] != 0.0f)
                return 0;
        return 1;
    }
    return sky->kind == SPT_SKY_BLACK ||
           (sky->kind == SPT_SKY_RGB && sky->rgb[0] == 0.0f && sky->rgb[1] == 0.0f &&
            sky->rgb[2] == 0.0f) ||
           (sky->kind == SPT_SKY_MAP && !(env_intensity > 0));
}

void render_warn_unlit(const GpuScene *g, const Scene *s, const Sky *sky, double env_intensity,
                       const char *scene)
{
    /* Without emitters or lights the default sky lights the scene
     * (src/render/render_lights.c); only a black sky leaves it dark. */
    if (g->emitter_count == 0 && s->light_count == 0 && sky_is_black(sky, env_intensity))
        spt_warn("%s: nothing lights the scene (no emissive surfaces, no lights, a black sky): the "
                 "image will be black", scene);
}

int render_denoise(Denoiser *den, const Film *f, const RenderSettings *rs, const float *noisy,
                   float *out, SptError *e)
{
    size_t np = (size_t)rs->width * rs->height;
    float *albedo = spt_malloc(3 * np * sizeof(float)), *normal = spt_malloc(3 * np * sizeof(float));
    film_aov_layer(f, SPT_AOV_ALBEDO, albedo);
    film_aov_layer(f, SPT_AOV_NORMAL, normal);
    int rc = denoiser_run(den, noisy, albedo, normal, rs->width, rs->height, !(rs->aperture > 0), out, e);
    free(albedo);
    free(normal);
    if (rc)
        return rc;
    size_t bad = 0;
    double sum_noisy = 0, sum_den = 0;
    for (size_t i = 0; i < 3 * np; i++) {
        bad += !isfinite(out[i]);
        sum_noisy += noisy[i];
        sum_den += out[i];
    }
    if (bad)
        return spt_fail(e, SPT_EXIT_FAILURE, "render: --denoise: Open Image Denoise (%s) returned %zu NaN "
                        "or infinite values; no output written", den->path, bad);
    /* A denoiser moves light between neighbouring pixels, and removing
     * fireflies lowers the mean by a few percent (docs/outputs.md,
     * "Denoising"); half or twice the light is a denoiser gone wrong. */
    if (sum_noisy > 0 && !(sum_den >= 0.5 * sum_noisy && sum_den <= 2 * sum_noisy))
        return spt_fail(e, SPT_EXIT_FAILURE, "render: --denoise: Open Image Denoise (%s) returned an image "
                        "whose mean is %.3g times the rendered image's (%.3g); no output written",
                        den->path, sum_den / sum_noisy, sum_noisy / (3.0 * (double)np));
    return SPT_EXIT_OK;
}

void render_device_description(const ClDeviceInfo *const *infos, int count,
                               const RenderDeviceStats *per_device, char *out, size_t cap)
{
    if (count == 1) {
        snprintf(out, cap, "%s (%s)", infos[0]->name, infos[0]->platform_name);
        return;
    }
    size_t len = 0;
    out[0] = 0;
    for (int i = 0; i < count && len < cap; i++)
        len += (size_t)snprintf(out + len, cap - len, "%s%s (%s): %u spp, %.3f Mpaths/s%s",
                                i ? "; " : "", infos[i]->name, infos[i]->platform_name,
                                per_device[i].samples, per_device[i].paths_per_second * 1e-6,
                                per_device[i].failed ? ", failed" : "");
}

void render_image_meta(RenderImageMeta *m, const Film *f, const RenderSettings *rs,
                       const RenderStats *st, const char *device, const char *scene, int spare)
{
    memset(m, 0, sizeof *m);
    ImageMeta *meta = &m->meta;
    meta->spp = (int)st->spp_done;
    meta->render_seconds = st->seconds;
    meta->device = device;
    meta->seed = rs->seed;
    meta->scene = scene;
    snprintf(m->depth, sizeof m->depth, "%d", rs->max_depth);
    snprintf(m->nan_dropped, sizeof m->nan_dropped, "%llu", (unsigned long long)st->nan_dropped);
    image_meta_add(meta, "max_depth", m->depth);
    image_meta_add(meta, "nan_dropped", m->nan_dropped);
    /* The pose, when not the rest state (docs/gltf.md, "Animation, skins and
     * morph targets"): which frame of the file the image is. */
    if (rs->at)
        image_meta_add(meta, "at", rs->at);
    if (rs->animation)
        image_meta_add(meta, "animation", rs->animation);
    if (rs->camera)
        image_meta_add(meta, "camera", rs->camera);
    film_layers_make(&m->layers, f, rs->aov, spare);
    meta->exr_attrs = m->layers.attrs;
    meta->exr_attr_count = m->layers.attr_count;
    meta->layers = m->layers.channels;
    meta->layer_count = m->layers.count;
}

void render_image_meta_noisy(RenderImageMeta *m, const float *noisy)
{
    static const char *names[3] = {"noisy.R", "noisy.G", "noisy.B"};
    FilmLayers *L = &m->layers;
    for (int c = 0; c < 3; c++)
        L->channels[L->count++] = (ExrChannel){names[c], SPT_EXR_FLOAT, noisy + c, 3};
    m->meta.layer_count = L->count;
}

int render_write_outputs(const char *const *outputs, int count, const float *rgb, int width,
                         int height, const ImageMeta *meta, const DisplayOptions *disp,
                         CheckpointWriter *ckpt, const Film *f, SptError *e)
{
    /* The test hook that fails the commit of output N (tests/test_render.c). */
    const char *fail_at = getenv("SPECTRACE_TEST_FAIL_OUTPUT");
    atomic_test_fail_commit_at = fail_at ? atoi(fail_at) : 0;
    atomic_stage_begin();
    int rc = SPT_EXIT_OK;
    for (int i = 0; i < count && !rc; i++)
        rc = image_write(outputs[i], rgb, width, height, meta, disp, e);
    if (!rc && ckpt)
        rc = checkpoint_writer_finish(ckpt, f, e);
    int rc2 = atomic_stage_finish(!rc, e);
    atomic_test_fail_commit_at = 0;
    return rc ? rc : rc2;
}

void render_image_meta_free(RenderImageMeta *m)
{
    film_layers_free(&m->layers);
    memset(m, 0, sizeof *m);
}
