/* A finished render on its way to its images, as the command line
 * (src/cli/cmd_render.c) and the library (src/api/spectrace.c) both take it:
 * the host memory it will need, the checks of its film before anything is
 * written, and its images' metadata and extra channels (docs/outputs.md). */
#ifndef SPT_RENDER_RESULT_H
#define SPT_RENDER_RESULT_H

#include <stddef.h>

#include "cl/cl_device.h"
#include "core/util.h"
#include "io/denoise.h"
#include "io/image_out.h"
#include "render/checkpoint.h"
#include "render/film.h"
#include "render/film_layers.h"
#include "render/gpu_scene.h"
#include "render/render.h"
#include "scene/scene.h"
#include "scene/sky.h"

/* The host memory a render of g with rs on count devices takes on top of
 * what is loaded (docs/limits.md, "The memory estimate"): the film, then the
 * larger of the render's own (render_memory) and that of writing its images,
 * which are made after the render's is freed: the linear sRGB image, the AOV
 * layers and the bands (film_layers_make), with --denoise the noisy image and
 * the two guides, and for each of the outputs not written as EXR (which is
 * encoded a few rows at a time) its encoding in memory, counted as 16 bytes
 * per pixel (src/io/image_out.c). */
typedef struct RenderHostMemory {
    double film, render, outputs;
    double need;   /* film + the larger of render and outputs */
    double loaded; /* not in need: the scene's device arrays and the
                      environment map (rs->sky) as read */
} RenderHostMemory;

/* Fills m and checks it against spt_memory_limit (the memory available, or
 * the address space a limit leaves): too much is refused with the amounts
 * (SPT_EXIT_DEVICE, as a device's own limits are), before an allocation
 * could fail or the OpenCL implementation abort. */
int render_host_memory(const ClDeviceInfo *const *infos, int count, const GpuScene *g,
                       const SceneCamera *cam, const RenderSettings *rs,
                       const char *const *outputs, int output_count, RenderHostMemory *m,
                       SptError *e);

/* The checks of a rendered film before any output is written (after the
 * test hook film_nan made its first pixels NaN, as a render gone wrong would):
 * a NaN or
 * infinite pixel is an internal error (the kernels drop such samples;
 * SPT_EXIT_FAILURE); with the variance layer (--aov variance) a pixel too
 * bright for it is SPT_EXIT_INPUT (docs/limits.md), and pixels too dim for it
 * a warning. scene names the scene in the messages. */
int render_film_check(Film *f, const RenderSettings *rs, const char *scene, SptError *e);

/* A warning naming scene when nothing lights it: no emitters in g, no lights
 * in s and a black sky (--background black, none or 0,0,0; an --env map of
 * zeros or at intensity 0). */
void render_warn_unlit(const GpuScene *g, const Scene *s, const Sky *sky, double env_intensity,
                       const char *scene);

/* --denoise: noisy (the linear sRGB of film f, rendered with rs and its AOV
 * sums) denoised by Open Image Denoise's RT filter into out, guided by f's
 * albedo and normal layers. The guides count as free of noise (cleanAux) for
 * a pinhole camera; with a lens, whose blur makes them noisy, they are
 * denoised first. A result with NaN or infinite values, or whose mean is not
 * within half and twice the noisy image's, is SPT_EXIT_FAILURE. */
int render_denoise(Denoiser *den, const Film *f, const RenderSettings *rs, const float *noisy,
                   float *out, SptError *e);

/* The devices of a render as its images' metadata names them: the device
 * ("name (platform)"), or every device with the samples per pixel it
 * rendered and its speed, "; " between them. */
void render_device_description(const ClDeviceInfo *const *infos, int count,
                               const RenderDeviceStats *per_device, char *out, size_t cap);

/* The metadata of an image of film f (rendered with rs, stats st, on the
 * devices device describes, of the scene named scene) and its extra EXR
 * channels, with room for spare more that the caller adds to layers (then
 * updating meta.layer_count): samples, seconds, device, seed, scene, the
 * maximum depth, the samples dropped as NaN and the pose when not the rest
 * state. meta borrows from the struct, which must stay where it is while it
 * is used. */
typedef struct RenderImageMeta {
    ImageMeta meta;
    FilmLayers layers;
    char depth[32], nan_dropped[32];
} RenderImageMeta;

void render_image_meta(RenderImageMeta *m, const Film *f, const RenderSettings *rs,
                       const RenderStats *st, const char *device, const char *scene, int spare);
/* --denoise: the image before denoising, noisy (3 floats per pixel, borrowed),
 * as the EXR's layer noisy.R, G, B (docs/outputs.md, "Denoising"); m was made
 * with room for it. */
void render_image_meta_noisy(RenderImageMeta *m, const float *noisy);
void render_image_meta_free(RenderImageMeta *m);

/* The image rgb (width x height, linear sRGB) written to count outputs with
 * meta and disp, then ckpt's final checkpoint of film f (ckpt may be NULL):
 * each to a temporary file, renamed over its name only when every one was
 * written (src/io/atomic_file.h), so a failure leaves every existing file as
 * it was. */
int render_write_outputs(const char *const *outputs, int count, const float *rgb, int width,
                         int height, const ImageMeta *meta, const DisplayOptions *disp,
                         CheckpointWriter *ckpt, const Film *f, SptError *e);

#endif
