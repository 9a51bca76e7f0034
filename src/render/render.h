/* The renderer: the settings of a render, and the rendering of a GpuScene
 * (render/gpu_scene.h) on one or several OpenCL devices into a Film. */
#ifndef SPT_RENDER_H
#define SPT_RENDER_H

#include <signal.h>
#include <stdint.h>

#include "cl/cl_device.h"
#include "core/util.h"
#include "render/film.h"
#include "render/gpu_scene.h"
#include "scene/scene.h"
#include "scene/sky.h"

typedef struct RenderSettings {
    int width, height;
    int spp;                 /* samples per pixel to reach (counting from sample_begin) */
    double time_limit;       /* seconds, 0 = none; stops at a chunk boundary */
    int max_depth;           /* path segments from the camera; <= 0 unlimited */
    uint32_t seed;
    uint32_t sample_begin;   /* first sample index (a resumed render starts later) */
    int progress;            /* print progress to stderr */
    int profile;             /* time the stages with OpenCL profiling events */
    volatile sig_atomic_t *stop; /* when set non-zero: finish the current chunk, stop */
    int take_turns;          /* tests: the devices take chunks in turn (0, 1, ..., 0, 1,
                                ...), so each renders a known share whatever its speed */
    /* Lighting and camera options of the command line. */
    const Sky *sky;          /* --env, --background (src/scene/sky.h); NULL = default */
    float env_rotation;      /* --env-rotation: degrees about +Y */
    float env_intensity;     /* --env-intensity: scale (default 1) */
    float aperture;          /* --aperture: lens radius in metres, 0 = pinhole */
    float focus_distance;    /* --focus-distance: metres, 0 = distance at the image centre */
    /* Optional hooks for other schedulers and for checkpoints (all NULL = off):
     * - done_in: rs->spp flags, one per relative sample index; samples already in
     *   the film (a resumed render) are not rendered again.
     * - take_chunk: hands out the next chunk [*begin, *begin + *n) of relative
     *   sample indices (at most want), 0 when there is none left; replaces the
     *   built-in counter (MPI ranks ask rank 0). Called with the scheduler's lock
     *   held, so calls are serialised. give_back returns a failed device's chunk.
     * - on_chunk: called with the lock held after every completed chunk, with the
     *   film (all samples done so far) and the per-sample done flags. */
    const unsigned char *done_in;
    int (*take_chunk)(void *ctx, uint32_t want, uint32_t *begin, uint32_t *n);
    void (*give_back)(void *ctx, uint32_t begin, uint32_t n);
    void *chunk_ctx;
    void (*on_chunk)(void *ctx, const Film *film, const unsigned char *done, uint32_t total);
    void *on_chunk_ctx;
} RenderSettings;

/* Times and counts of a render. */
typedef struct RenderStats {
    double seconds;          /* wall time of the sample loop */
    double build_seconds;    /* program build (or cache load) */
    uint64_t paths;          /* camera paths traced */
    uint64_t rays_extend;    /* closest-hit rays (k_extend) */
    uint64_t rays_shadow;    /* shadow rays (k_connect) */
    uint64_t nan_dropped;    /* samples whose radiance was NaN/Inf */
    uint32_t spp_done;       /* samples per pixel completed */
    double stage_seconds[5]; /* generate, extend, shade, connect, accumulate (profile) */
} RenderStats;

/* What one device of a multi-device render did. */
typedef struct RenderDeviceStats {
    uint32_t samples;        /* samples per pixel it rendered */
    double paths_per_second; /* while rendering */
    int failed;              /* dropped after an error */
} RenderDeviceStats;

/* Renders on count devices at once: each has its own context, program and path
 * pool, and takes chunks of samples from a shared counter, so a faster device
 * takes more; a device that fails is dropped with one warning and its chunk goes
 * back to the others. Chunk sums are added to film in double precision.
 * per_device (may be NULL) receives count entries. Fails only when every
 * device failed. */
int render_devices(const ClDeviceInfo *const *infos, int count, const GpuScene *g,
                   const SceneCamera *cam, const RenderSettings *rs, Film *film,
                   RenderStats *stats, RenderDeviceStats *per_device, SptError *e);

/* Renders samples [rs->sample_begin, rs->sample_begin + rs->spp) of every pixel
 * of g with camera cam on device info, adding them to film (which must be
 * rs->width x rs->height). Stops early, at a chunk boundary, when rs->stop is set
 * or the time limit passes; stats->spp_done says how far it got (the film then
 * holds exactly that many samples per pixel). Returns 0 or an exit code. */
int render_device(const ClDeviceInfo *info, const GpuScene *g, const SceneCamera *cam,
                  const RenderSettings *rs, Film *film, RenderStats *stats, SptError *e);

#endif
