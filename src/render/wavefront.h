/* The wavefront loop on one device: its context, program, kernels and buffers
 * (named once through the lists of kernels/util/render_types.h), and the
 * rendering of one chunk of samples. */
#ifndef SPT_WAVEFRONT_H
#define SPT_WAVEFRONT_H

#include <stdint.h>

#include "cl/cl_device.h"
#include "render/gpu_scene.h"
#include "render/render.h"
#include "render/render_lights.h"

/* The kernels; the first six are also the profile's stages (stage_seconds),
 * where k_shade_light's time counts as the shading's. */
enum { K_GENERATE, K_EXTEND, K_SHADE, K_CONNECT, K_ACCUMULATE, K_PATHS, K_SHADE_LIGHT, K_COUNT };

/* Every device buffer. */
typedef struct Buffers {
#define MEMBER(type, name) cl_mem name;
#define PS_MEMBER(type, name) cl_mem ps_##name;
#define SH_MEMBER(type, name) cl_mem sh_##name;
    SPT_SCENE_BUFFERS(MEMBER)
    SPT_WORK_BUFFERS(MEMBER)
    SPT_PATH_STATE(PS_MEMBER)
    SPT_SHADOW_STATE(SH_MEMBER)
#undef MEMBER
#undef PS_MEMBER
#undef SH_MEMBER
} Buffers;

/* Every allocation of a render on one device, sized once (wavefront_plan) for
 * both wavefront_create, which allocates from it, and the host-memory estimate
 * (render_memory), so the two cannot differ: the device's buffers, and the
 * host arrays the worker reads a chunk's sums into. */
typedef struct WavefrontPlan {
    uint32_t pool;         /* paths in flight */
    uint32_t chunk_spp;    /* samples per pixel of a chunk */
    int aov, bands;        /* as in Wavefront */
#define SPT_PLAN_MEMBER(type, name) size_t name;
    SPT_WORK_BUFFERS(SPT_PLAN_MEMBER)
#undef SPT_PLAN_MEMBER
    size_t path_state;     /* every path-state field, pool entries each */
    size_t shadow_state;   /* every shadow-ray field, pool entries each */
    size_t scene;          /* the scene buffers (env_data included) */
    size_t device;         /* all of the above: every buffer on the device */
    size_t host_sums, host_aov, host_spec, host_sq; /* the worker's host arrays */
    size_t host_pm;        /* photon merging's host arrays (Wavefront pm_*) */
    ClAlloc allocs[64];    /* every buffer, for cl_device_check_memory */
    int count;
} WavefrontPlan;

/* The plan of rendering g at rs's size on info's device. L may be NULL before
 * the lights are set up: env_floats then gives the environment map's data
 * (sky_map_data_floats; 0 without a map). light_film: the render's light paths
 * per sample index (--caustics; at most, where not yet known), which splat
 * into the light film (and leave photons, with --merge); 0: none, the light
 * film is a placeholder. */
void wavefront_plan(WavefrontPlan *p, const ClDeviceInfo *info, const GpuScene *g,
                    const RenderSettings *rs, const RenderLights *L, size_t env_floats,
                    uint32_t light_film);

typedef struct Wavefront {
    ClDevice dev;
    cl_program program;
    cl_kernel k[K_COUNT];
    Buffers b;
    size_t local[K_COUNT]; /* work-group size of each kernel */
    uint32_t pool;
    uint32_t chunk_spp;
    int ray_pairs;         /* 1: k_extend traces two rays per work-item (CPU devices) */
    int mega;              /* 1: k_paths runs whole paths (CPU devices), not the stages */
    int aov;               /* 1: the kernels keep AOVs (built with SPT_AOV) */
    int bands;             /* spectral bands (built with SPT_BANDS), 0: none */
    WavefrontPlan plan;    /* the sizes of every buffer */
    char options[256];     /* the program's build options (wavefront_options) */
    /* Per scene buffer (SPT_SB_*): the memory it uses in place (CPU devices;
     * NULL: the device's own copy), and with kept scene buffers
     * (RenderPrograms.keep_scene) the size and hash of what was uploaded. */
    void *host_mem[SPT_SCENE_BUFFER_COUNT];
    size_t scene_bytes[SPT_SCENE_BUFFER_COUNT];
    uint64_t scene_hash[SPT_SCENE_BUFFER_COUNT];
    uint32_t uploaded;     /* bit SPT_SB_*: uploaded by the last wavefront_buffers */
    /* Photon merging's host arrays (run_merge_chunk): the photons read back,
     * sorted into the grid, its buckets, the chunk's radii; NULL until used. */
    float *pm_raw, *pm_sorted, *pm_radius;
    uint32_t *pm_cells;
    volatile sig_atomic_t *stop; /* RenderSettings.stop: at 2 (1 for a long chunk),
                                    render_chunk stops */
} Wavefront;

/* Opens info's device, builds the program and allocates every buffer for
 * rendering g with the lights L at rs's size, after checking the device's
 * memory. Returns 0 or an exit code; wavefront_free cleans up either way. */
int wavefront_create(Wavefront *w, const ClDeviceInfo *info, const GpuScene *g,
                     const RenderSettings *rs, const RenderLights *L, uint32_t light_film, SptError *e);
void wavefront_free(Wavefront *w);

/* The two halves of wavefront_create, for a program kept from one render to
 * the next (RenderPrograms, src/render/render.h): wavefront_open opens the
 * device and builds the program and kernels for rs's kernel options (g only
 * chooses whether the traversal prefetches, which changes no result);
 * wavefront_buffers checks the device's memory and makes the buffers of a
 * render of g; wavefront_release_buffers releases them, keeping the program.
 * With rs->programs->keep_scene, wavefront_buffers keeps each scene buffer
 * the last render left (wavefront_release_work_buffers) whose size and
 * contents are unchanged, and uploads the others; w->uploaded says which. */
int wavefront_open(Wavefront *w, const ClDeviceInfo *info, const GpuScene *g,
                   const RenderSettings *rs, SptError *e);
int wavefront_buffers(Wavefront *w, const GpuScene *g, const RenderSettings *rs,
                      const RenderLights *L, uint32_t light_film, SptError *e);
void wavefront_release_buffers(Wavefront *w);
void wavefront_release_work_buffers(Wavefront *w);

/* The build options of the program for rendering g with rs on info's device
 * (the kernel specialisations: code path, AOVs, bands, the thin film ...)
 * into out. */
void wavefront_options(const ClDeviceInfo *info, const GpuScene *g, const RenderSettings *rs,
                       char *out, size_t cap);

/* Whether the CPU path's traversal asks for each next node's memory early
 * (SPT_BVH_STEP_PREFETCH): for a BVH of bvh_bytes on a device whose global
 * memory cache is cache bytes (as it reports it; 0: unknown). */
int wavefront_step_prefetch(double bvh_bytes, double cache);

/* Whether w, a wavefront kept from an earlier render, can render g with rs:
 * as it is (SPT_WAVEFRONT_FITS), after wavefront_program builds its program
 * with rs's options (SPT_WAVEFRONT_REBUILD: its context and buffers stay), or
 * only opened anew (SPT_WAVEFRONT_REOPEN: its queue's profiling differs). */
enum { SPT_WAVEFRONT_REOPEN, SPT_WAVEFRONT_REBUILD, SPT_WAVEFRONT_FITS };
int wavefront_fits(const Wavefront *w, const GpuScene *g, const RenderSettings *rs);

/* Builds w's program and kernels for rendering g with rs, replacing those it
 * had (wavefront_open's second half). Returns 0 or an exit code. */
int wavefront_program(Wavefront *w, const GpuScene *g, const RenderSettings *rs, SptError *e);

/* A chunk of more camera paths than this many pools is long: a first stop
 * request (*stop 1) drops it rather than waiting for it. */
#define SPT_LONG_CHUNK_POOLS 32u

/* Renders samples [sample_begin, sample_begin + n) of every pixel on w: sums
 * receives 4 floats per pixel (XYZ sums and the sample count), and with AOVs
 * aov_sums SPT_AOV_CHUNK_FLOATS per pixel (src/render/film.h), with spectral
 * bands spec_sums w->bands per pixel, and unless NULL sq_sums 4 floats per
 * pixel (the sums of the squares of its kept samples' linear sRGB, and 0); st
 * gains the chunk's paths, rays and (with profile) stage times. When *w->stop reaches 2 (or 1, for a long
 * chunk) between two waves of paths, returns SPT_EXIT_INTERRUPTED (the chunk is
 * dropped, nothing of it is in sums). */
int render_chunk(Wavefront *w, const RenderParams *base, uint32_t sample_begin, uint32_t n,
                 int profile, float *sums, float *aov_sums, float *spec_sums, float *sq_sums,
                 RenderStats *st, SptError *e);

/* Which of the next chunks' samples each pixel takes (adaptive sampling,
 * src/render/adaptive.h): lag[p] (kernels/util/render_types.h, pixel_lag;
 * wavefront_create starts every pixel at 0, every sample). */
int wavefront_set_lags(Wavefront *w, const uint32_t *lag, size_t npix, SptError *e);

#endif
