/* The renderer on one OpenCL device: the scene turned into device arrays
 * (GpuScene), and the wavefront loop that renders chunks of samples into a Film. */
#ifndef SPT_RENDER_H
#define SPT_RENDER_H

#include <signal.h>
#include <stdint.h>

#include "accel/bvh_build.h"
#include "cl/cl_device.h"
#include "core/distribution.h"
#include "render/film.h"
#include "scene/scene.h"
#include "core/util.h"
#include "render/host_lights.h"
#include "shared/render_types.h"

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
    /* Lighting and camera options of the command line. */
    const char *env_path;    /* --env: equirectangular HDR/EXR map, NULL = none */
    float env_rotation_deg;  /* --env-rotation: about +Y */
    float env_intensity;     /* --env-intensity: scale (default 1) */
    const char *background;  /* --background: "R,G,B", an SPD, "black", NULL = default */
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

/* The scene as the kernels read it: packed triangles in BVH order and their
 * shading data, materials with spectra, coefficient textures, emitters. */
typedef struct GpuScene {
    Bvh bvh;
    TriShade *tri_shade;     /* per packed triangle */
    float *vtx_pos;          /* 3 per vertex: positions, from the Scene's triangles */
    float *vtx_normal;       /* borrowed from the Scene */
    float *vtx_uv;           /* borrowed from the Scene */
    float *vtx_uv1;          /* borrowed from the Scene; NULL without TEXCOORD_1 */
    float *vtx_color;        /* 4 per vertex: COLOR_0's sigmoid coefficients and alpha;
                                NULL without COLOR_0 */
    uint32_t vertex_count;
    GpuMaterial *materials;
    uint32_t material_count;
    float *spectra;          /* SPT_CIE_SAMPLES floats per tabulated spectrum */
    uint32_t spectra_count;  /* floats */
    GpuTexture *textures;
    uint32_t texture_count;
    float *texels;           /* 4 floats per texel (GpuTexture's kinds), mip pyramids */
    size_t texel_count;
    uint32_t *emitters;      /* packed triangle index per emitter */
    uint32_t emitter_count;
    float *emitter_power;    /* per emitter: pi * area * Y(Le), its selection weight */
    float *emitter_area;
    GpuLight *lights;        /* punctual lights (spectra tables in spectra) */
    uint32_t light_count;
    float scene_radius;      /* of the bounding sphere, for light power estimates */
} GpuScene;

/* Builds the BVH and the device arrays of s. Returns 0 or an exit code. */
int gpu_scene_build(GpuScene *g, const Scene *s, SptError *e);
void gpu_scene_free(GpuScene *g);

/* Bytes of device memory the scene arrays need (for `info` and limit checks). */
size_t gpu_scene_bytes(const GpuScene *g);

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
