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
#include "render/render_options.h"

enum { SPT_KERNEL_PATH_DEVICE = 0, SPT_KERNEL_PATH_CPU, SPT_KERNEL_PATH_GPU };
/* How k_paths traces its two paths' closest-hit rays (the rays test hook). */
enum { SPT_RAYS_DEVICE = 0, SPT_RAYS_PAIRED, SPT_RAYS_ONE_BY_ONE };

/* Hooks for tests, off when zero; only tests set them (the command line takes
 * them from SPECTRACE_TEST_* variables: src/api/render_args.h). */
typedef struct RenderTestHooks {
    int fail_device;  /* 1 + the index (in the selection) of a device that fails as it
                         starts its chunk number fail_after (counting from 0) */
    int fail_after;
    int slow_device;  /* 1 + the index of a device that waits slow_ms before each chunk */
    int slow_ms;
    int inject_nan;   /* pixel 0's radiance is NaN, which the NaN guard must drop */
    int take_turns;   /* the devices take chunks in turn (0, 1, ..., 0, 1, ...), so
                         each renders a known share whatever its speed */
    int ranks_first;  /* spectrace-mpi: rank 0's devices take no chunk before every
                         other rank has had its first one (or has ended), so each
                         rank renders at least one chunk whatever the timing */
    int poison;       /* every path, shadow, queue, counter and film buffer is first
                         filled with the 32-bit word poison_word, so that a value
                         read before anything wrote it shows (NaN, all ones) */
    uint32_t poison_word;
    long film_nan;    /* spectrace render: the first film_nan pixels of the film are
                         made NaN after the render, as a render gone wrong would */
    int kernel_path;  /* SPT_KERNEL_PATH_CPU or _GPU: that code path on any device
                         (0: the device's own) */
    int stages;       /* 1: the stage kernels on the CPU path too, instead of
                         k_paths (comparisons; the extend stage's own time) */
    int rays;         /* SPT_RAYS_PAIRED or _ONE_BY_ONE: k_paths's rays traced so
                         on any CPU path (0: the device's choice) */
    int bvh_rebuild;  /* spectrace render --frames: every frame's BVH built anew,
                         never refitted (comparisons and timing) */
} RenderTestHooks;

struct Wavefront;

/* The scene buffers (SPT_SCENE_BUFFERS) by index. */
enum {
#define SPT_SB_INDEX(type, name) SPT_SB_##name,
    SPT_SCENE_BUFFERS(SPT_SB_INDEX)
#undef SPT_SB_INDEX
    SPT_SCENE_BUFFER_COUNT
};

/* Programs kept from one render to the next (a frame sequence: docs/gltf.md,
 * "Frame sequences"; a scene of the library: docs/api.md): per device of the
 * selection (the same selection in every render), its wavefront's context,
 * program and kernels (NULL until a render opens it; a device that fails is
 * closed and opened again by the next render), and the count of programs
 * built (or loaded from the binary cache). A render whose kernel options
 * differ from a kept program's (the thin film, AOVs, bands ...) builds that
 * device's program anew. With keep_scene the scene buffers stay on the
 * devices too, and a render uploads only those whose contents changed (the
 * materials after a material's change, say); uploads counts, per scene
 * buffer, the uploads on all devices, and upload_bytes their bytes. */
typedef struct RenderPrograms {
    struct Wavefront **w;
    int count;
    int builds;
    int keep_scene;
    int uploads[SPT_SCENE_BUFFER_COUNT];
    uint64_t upload_bytes;
} RenderPrograms;

/* count empty slots; render_programs_free closes every device opened. */
void render_programs_init(RenderPrograms *p, int count);
void render_programs_free(RenderPrograms *p);

/* What a render does. Its first fields are every option of the command line
 * marked RS in src/render/render_options.h, where each one's type, default,
 * range and meaning are declared once (not repeated here, so the two cannot
 * disagree); spp counts from sample_begin, and a time_limit ends the render
 * at a chunk boundary (chunks sized by render_deadline_chunk). The fields
 * below are what the programs set beside them. */
typedef struct RenderSettings {
    SPT_RENDER_OPTIONS(SPT_OPT_RS_FIELD)
    const Sky *sky;          /* --env, --background (src/scene/sky.h); NULL = default */
    uint32_t sample_begin;   /* first sample index (a resumed render starts later) */
    int progress;            /* print progress to stderr */
    int announce;            /* name a kernel build not found in the cache on stderr,
                                as progress does (for a caller printing its own
                                progress through on_progress) */
    volatile sig_atomic_t *stop; /* 1: finish the current chunks (drop a long one,
                                    SPT_LONG_CHUNK_POOLS), then stop; 2 (a second
                                    Ctrl-C): drop the chunks in progress at the next
                                    wave of paths and stop at once */
    uint32_t pool_size;      /* paths in flight per device; 0 = the device's default */
    RenderTestHooks test;
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
    /* - on_progress: called where the progress display is (after every completed
     *   chunk, with the lock held) with the samples per pixel done and asked
     *   for, the seconds since the render's start and the paths traced. */
    void (*on_progress)(void *ctx, uint32_t done, uint32_t total, double elapsed, uint64_t paths);
    void *on_progress_ctx;
    RenderPrograms *programs; /* NULL: the render builds its programs and frees them */
} RenderSettings;

/* Whether the film and the kernels keep AOV sums: for --aov, and for --denoise
 * (its guides are the albedo and normal layers). */
static inline int render_keeps_aov(const RenderSettings *rs)
{
    return rs->aov != 0 || rs->denoise;
}

/* The image size of rs (--width and --height) where the options leave it
 * open: a width of 512 when neither is given, the other side from the
 * camera's aspect ratio (1 when it has none). */
void render_image_size(RenderSettings *rs, const SceneCamera *cam);

/* --adaptive auto resolved (README.md, "--adaptive"): on for a render given
 * seconds (--time), where the image is what counts, when may_adapt (not
 * across MPI ranks nor with checkpoints, which keep no sums of squares); off
 * otherwise, kept as SPT_SWITCH_AUTO (a RenderSettings' default, so a render
 * without adaptive sampling has one checkpoint key however it was asked for). */
void render_adaptive_resolve(RenderSettings *rs, int may_adapt);

/* Kernel stages timed by --profile (src/render/wavefront.h, K_*). */
#define SPT_STAGES 6

/* Times and counts of a render. */
typedef struct RenderStats {
    double seconds;          /* wall time of the sample loop */
    double build_seconds;    /* program build (or cache load) */
    uint64_t paths;          /* camera paths traced */
    uint64_t rays_extend;    /* closest-hit rays (k_extend) */
    uint64_t rays_shadow;    /* shadow rays (k_connect) */
    uint64_t nan_dropped;    /* samples whose radiance was NaN/Inf */
    uint32_t spp_done;       /* samples per pixel completed */
    double stage_seconds[SPT_STAGES]; /* generate, extend, shade, connect, accumulate,
                                         whole paths (k_paths) (profile) */
} RenderStats;

/* What one device of a multi-device render did. */
typedef struct RenderDeviceStats {
    uint32_t samples;        /* samples per pixel it rendered */
    double paths_per_second; /* while rendering */
    int failed;              /* dropped after an error */
} RenderDeviceStats;

/* The sampler named name ("sobol", "zsobol" or "independent", any case) as its
 * SPT_SAMPLER_* value (kernels/util/render_types.h) in *sampler; -1 for other
 * names. */
int render_sampler_parse(const char *name, uint32_t *sampler);

/* Renders on count devices at once: each has its own context, program and path
 * pool, and takes chunks of samples from a shared counter, so a faster device
 * takes more; a device that fails is dropped with one warning and its chunk goes
 * back to the others. Chunk sums are added to film in double precision.
 * per_device (may be NULL) receives count entries. Fails only when every
 * device failed. */
int render_devices(const ClDeviceInfo *const *infos, int count, const GpuScene *g,
                   const SceneCamera *cam, const RenderSettings *rs, Film *film,
                   RenderStats *stats, RenderDeviceStats *per_device, SptError *e);

/* Samples per pixel of a device's next chunk under --time (a pure function of
 * its inputs): at most want; left: the seconds left until the time limit;
 * per_sample: the seconds per sample of the device's last chunk (0 before its
 * first). The first chunk is one sample, which measures the rate; each later
 * one takes half the time left (at least one sample), so chunks shrink toward
 * the deadline and the render ends within a sample's time before it instead
 * of a whole chunk after; 0 (take no more) when not even one sample fits.
 * Chunks are whole samples of every pixel, so every pixel keeps the same
 * number of samples. */
uint32_t render_deadline_chunk(uint32_t want, double left, double per_sample);

/* The host memory render_devices takes on top of the film and the loaded
 * scene (docs/limits.md, "The memory estimate"), each part from the function
 * that sizes its allocation: adaptive sampling's per-pixel arrays, the
 * environment map's data and sampling tables (sky_map_data_floats of the
 * map of rs->sky), and per device its host arrays (wavefront_plan) and, on a CPU
 * device, whose buffers are host memory, every buffer. */
typedef struct RenderMemory {
    size_t scheduler;   /* adaptive sampling */
    size_t lights;      /* the environment map's data */
    size_t devices;     /* every device's host arrays and CPU buffers */
    size_t total;       /* the sum */
} RenderMemory;

void render_memory(const ClDeviceInfo *const *infos, int count, const GpuScene *g,
                   const SceneCamera *cam, const RenderSettings *rs, RenderMemory *m);

/* Renders samples [rs->sample_begin, rs->sample_begin + rs->spp) of every pixel
 * of g with camera cam on device info, adding them to film (which must be
 * rs->width x rs->height). Stops early, at a chunk boundary, when rs->stop is set
 * or the time limit passes; stats->spp_done says how far it got (the film then
 * holds exactly that many samples per pixel). Returns 0 or an exit code. */
int render_device(const ClDeviceInfo *info, const GpuScene *g, const SceneCamera *cam,
                  const RenderSettings *rs, Film *film, RenderStats *stats, SptError *e);

#endif
