/* The wavefront loop on one device (docs/architecture.md, "Data flow"): the
 * program and the buffers of one device, and the kernel launches that render a
 * chunk of samples. */
#include "render/wavefront.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>

#include "render/light_plan.h"
#include "render/photon_grid.h"
#include "render/render_lights.h"
#include "integrator/photon_grid.h"

/* Host spellings of the kernel types named in the buffer lists. */
typedef cl_float4 float4;
typedef cl_uint uint;

static const char *const kernel_names[K_COUNT] = {"k_generate",   "k_extend", "k_shade",      "k_connect",
                                                  "k_accumulate", "k_paths",  "k_shade_light"};

_Static_assert(SPT_SCENE_BUFFER_COUNT <= 32, "Wavefront.uploaded has a bit per scene buffer");

/* Scene buffer i (SPT_SB_*) released, with the memory it used in place. */
static void scene_buffer_release(Wavefront *w, int i, cl_mem *m)
{
    if (*m) {
        /* A buffer is released before the memory it used in place. */
        clReleaseMemObject(*m);
        if (w->host_mem[i] && w->dev.queue)
            clFinish(w->dev.queue);
    }
    *m = NULL;
    free(w->host_mem[i]);
    w->host_mem[i] = NULL;
    w->scene_bytes[i] = 0;
    w->scene_hash[i] = 0;
}

void wavefront_release_work_buffers(Wavefront *w)
{
#define REL(type, name) if (w->b.name) clReleaseMemObject(w->b.name); w->b.name = NULL;
#define PS_REL(type, name) if (w->b.ps_##name) clReleaseMemObject(w->b.ps_##name); w->b.ps_##name = NULL;
#define SH_REL(type, name) if (w->b.sh_##name) clReleaseMemObject(w->b.sh_##name); w->b.sh_##name = NULL;
    SPT_WORK_BUFFERS(REL)
    SPT_PATH_STATE(PS_REL)
    SPT_SHADOW_STATE(SH_REL)
#undef REL
#undef PS_REL
#undef SH_REL
    free(w->pm_raw);
    free(w->pm_sorted);
    free(w->pm_radius);
    free(w->pm_cells);
    w->pm_raw = w->pm_sorted = w->pm_radius = NULL;
    w->pm_cells = NULL;
}

void wavefront_release_buffers(Wavefront *w)
{
    wavefront_release_work_buffers(w);
#define REL(type, name) scene_buffer_release(w, SPT_SB_##name, &w->b.name);
    SPT_SCENE_BUFFERS(REL)
#undef REL
}

void wavefront_free(Wavefront *w)
{
    wavefront_release_buffers(w);
    for (int i = 0; i < K_COUNT; i++)
        if (w->k[i])
            clReleaseKernel(w->k[i]);
    if (w->program)
        clReleaseProgram(w->program);
    cl_device_close(&w->dev);
    memset(w, 0, sizeof *w);
}

/* Read-only scene buffer i (SPT_SB_*) called name, of bytes bytes from data
 * (NULL: zeros). On a CPU device the
 * large ones (over 4 MiB: BVH nodes and triangles, vertex arrays, which the
 * kernels read at random) live in memory of our own that the device uses in
 * place (CL_MEM_USE_HOST_PTR; PoCL does not copy it), aligned to 2 MiB and
 * marked for transparent huge pages before it is first written, so a random
 * read of a 44 MB BVH misses the TLB far less often (the displaced sphere's
 * bounce rays about 7% faster). Linux only gives huge pages to memory so marked when
 * transparent_hugepage is "madvise" (Debian's default) or "always"; elsewhere
 * this is plain memory. */
static int scene_buffer_create(Wavefront *w, int i, const char *name, size_t bytes,
                               const void *data, cl_mem *out, SptError *e)
{
    static const char zeros[16];
    const size_t huge = (size_t)2 << 20;
    if ((w->dev.info.type & CL_DEVICE_TYPE_CPU) && data && bytes > 2 * huge) {
        size_t size = (bytes + huge - 1) & ~(huge - 1);
        void *mem = aligned_alloc(huge, size);
        if (mem) {
#ifdef MADV_HUGEPAGE
            madvise(mem, size, MADV_HUGEPAGE); /* advice: failure only loses speed */
#endif
            memcpy(mem, data, bytes);
            w->host_mem[i] = mem;
            return cl_buffer_create(&w->dev, name, CL_MEM_READ_ONLY | CL_MEM_USE_HOST_PTR, bytes,
                                    mem, out, e);
        }
    }
    return cl_buffer_create(&w->dev, name, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, bytes,
                            (void *)(data ? data : zeros), out, e);
}

/* bytes_hash's step: word mixed into h. */
static uint64_t hash_word(uint64_t h, uint64_t word)
{
    h = (h ^ word) * 0xbf58476d1ce4e5b9ull;
    return h ^ (h >> 29);
}

/* A 64-bit hash of n bytes at p (NULL: n zero bytes), which tells a kept
 * scene buffer's contents from the next render's: 8 bytes at a time, each
 * word mixed in by a multiply and the finaliser of SplitMix64 (Steele, Lea
 * and Flood, "Fast splittable pseudorandom number generators", OOPSLA 2014). */
static uint64_t bytes_hash(const void *p, size_t n)
{
    uint64_t h = 0x9e3779b97f4a7c15ull ^ (uint64_t)n;
    const unsigned char *c = p;
    /* Whole words by a fixed-size copy (one load; a copy of variable size
     * is a call to memcpy per word), then the tail zero-padded. */
    size_t k = 0;
    for (; p && k + 8 <= n; k += 8) {
        uint64_t word;
        memcpy(&word, c + k, 8);
        h = hash_word(h, word);
    }
    if (p && k < n) {
        uint64_t word = 0;
        memcpy(&word, c + k, n - k);
        h = hash_word(h, word);
    }
    h ^= h >> 30;
    h *= 0xbf58476d1ce4e5b9ull;
    h ^= h >> 27;
    h *= 0x94d049bb133111ebull;
    return h ^ (h >> 31);
}

/* Scene buffer i called name for rendering g with L: kept when keep and the
 * buffer w has holds the same bytes, else made anew (bit i of w->uploaded). */
static int scene_buffer(Wavefront *w, int i, const char *name, const GpuScene *g,
                        const RenderLights *L, int keep, cl_mem *m, SptError *e)
{
    size_t bytes = gpu_scene_buffer_bytes(g, L, name);
    const void *data = gpu_scene_buffer_data(g, L, name);
    uint64_t hash = keep ? bytes_hash(data, bytes) : 0;
    if (*m && keep && w->scene_bytes[i] == bytes && w->scene_hash[i] == hash)
        return 0;
    scene_buffer_release(w, i, m);
    int rc = scene_buffer_create(w, i, name, bytes, data, m, e);
    if (!rc) {
        w->scene_bytes[i] = bytes;
        w->scene_hash[i] = hash;
        w->uploaded |= 1u << i;
    }
    return rc;
}

/* The number of buffer arguments of every kernel (the params come after). */
#define ONE(type, name) +1
#define SPT_KERNEL_BUFFER_ARGS                                                                  \
    (0 SPT_SCENE_BUFFERS(ONE) SPT_WORK_BUFFERS(ONE) SPT_PATH_STATE(ONE) SPT_SHADOW_STATE(ONE))

/* Sets every buffer argument of kernel k, in list order, then the params: the
 * kernels' KERNEL_ARGS (kernels/integrator/kernel_globals.h). */
static int set_args(cl_kernel k, const Buffers *b, const RenderParams *p, SptError *e)
{
    cl_uint i = 0;
#define SET(type, name) SPT_CL_CHECK(e, clSetKernelArg(k, i++, sizeof(cl_mem), &b->name));
#define PS_SET(type, name) SPT_CL_CHECK(e, clSetKernelArg(k, i++, sizeof(cl_mem), &b->ps_##name));
#define SH_SET(type, name) SPT_CL_CHECK(e, clSetKernelArg(k, i++, sizeof(cl_mem), &b->sh_##name));
    SPT_SCENE_BUFFERS(SET)
    SPT_WORK_BUFFERS(SET)
    SPT_PATH_STATE(PS_SET)
    SPT_SHADOW_STATE(SH_SET)
#undef SET
#undef PS_SET
#undef SH_SET
    SPT_CL_CHECK(e, clSetKernelArg(k, i++, sizeof(RenderParams), p));
    return 0;
}

/* Fills buffer m with the 32-bit word pat (every buffer here is a whole number
 * of words). */
static int fill_words(ClDevice *dev, cl_mem m, cl_uint pat, SptError *e)
{
    size_t bytes = 0;
    SPT_CL_CHECK(e, clGetMemObjectInfo(m, CL_MEM_SIZE, sizeof bytes, &bytes, NULL));
    SPT_CL_CHECK(e, clEnqueueFillBuffer(dev->queue, m, &pat, sizeof pat, 0, bytes, 0, NULL, NULL));
    return 0;
}

/* Path pool size for a device: enough paths to fill it, bounded by memory;
 * asked (RenderSettings pool_size) when not 0. */
static uint32_t pool_size_for(const ClDeviceInfo *info, uint32_t asked, uint64_t work)
{
    uint64_t pool = (info->type & CL_DEVICE_TYPE_GPU) ? (1u << 20) : (1u << 16);
    if (asked > 0)
        pool = asked;
    if (pool > work)
        pool = work;
    return (uint32_t)(pool ? pool : 1);
}

/* The kernels' two code paths (kernels/bvh/bvh.h): 1 for the CPU path, which
 * tests a BVH leaf's triangles in vector rows (16 with AVX-512, 8 with AVX2)
 * and traces two rays per extend work-item, interleaved, each with a full
 * traversal stack; 0 for the GPU path, one ray per work-item with a short
 * stack, looping over a leaf's triangles, for devices whose work-items are SIMD
 * lanes and which hide memory latency with other work-items. By device type,
 * then by implementation where its CPU device runs work-items as lanes:
 *   - GPUs and accelerators, and Oclgrind (a GPU to us): the GPU path;
 *   - rusticl: llvmpipe vectorises a kernel across work-items like a GPU (it is
 *     a CPU device to OpenCL): the GPU path;
 *   - PoCL's CPU device runs a work-group's items one after another: the CPU
 *     path;
 *   - Intel's CPU runtime, with its vectoriser off (cl_runtime_defaults), runs
 *     them one after another too; of the two paths measured there the CPU path
 *     is the faster (docs/performance.md, "Implementations"): the CPU path;
 *   - any other CPU device: the CPU path. */
static int kernel_path_pairs(const ClDeviceInfo *info)
{
    if (!(info->type & CL_DEVICE_TYPE_CPU))
        return 0;
    if (!strcmp(info->impl, "rusticl") || !strcmp(info->impl, "oclgrind"))
        return 0;
    return 1;
}

/* SPECTRACE_KERNEL_PATH, the kernel_path test hook from the environment: "cpu",
 * "gpu", "cpu-stages" (the CPU path without the megakernel, *stages = 1),
 * "cpu-pairs" or "cpu-one-ray" (the CPU path, k_paths's rays paired or one
 * by one: *rays); else (unset or another word) the device's own path. */
static void kernel_path_env(int *path, int *stages, int *rays)
{
    static const struct {
        const char *word;
        int path, stages, rays;
    } words[] = {
        {"cpu", SPT_KERNEL_PATH_CPU, 0, SPT_RAYS_DEVICE},
        {"gpu", SPT_KERNEL_PATH_GPU, 0, SPT_RAYS_DEVICE},
        {"cpu-stages", SPT_KERNEL_PATH_CPU, 1, SPT_RAYS_DEVICE},
        {"cpu-pairs", SPT_KERNEL_PATH_CPU, 0, SPT_RAYS_PAIRED},
        {"cpu-one-ray", SPT_KERNEL_PATH_CPU, 0, SPT_RAYS_ONE_BY_ONE},
    };
    const char *v = getenv("SPECTRACE_KERNEL_PATH");
    *path = SPT_KERNEL_PATH_DEVICE;
    for (size_t k = 0; v && k < sizeof words / sizeof words[0]; k++)
        if (!strcmp(v, words[k].word)) {
            *path = words[k].path;
            *stages = *stages || words[k].stages;
            if (words[k].rays != SPT_RAYS_DEVICE)
                *rays = words[k].rays;
        }
}

/* Work-group size of kernel k on dev: 64 work-items (the queues take one global
 * atomic per group; PoCL keeps a group's private traversal stacks on a
 * thread's stack) rounded up to a whole number of the kernel's preferred
 * multiple (a GPU's warp or wavefront; 128 on Intel's CPU runtime, where 128
 * renders faster than 64), within the kernel's own limit on the device and
 * SPT_GROUP_MAX (the kernels' local arrays). */
static int group_size_for(cl_kernel k, cl_device_id dev, size_t *out, SptError *e)
{
    size_t max_wg = 1, mult = 1;
    SPT_CL_CHECK(e, clGetKernelWorkGroupInfo(k, dev, CL_KERNEL_WORK_GROUP_SIZE, sizeof max_wg,
                                             &max_wg, NULL));
    SPT_CL_CHECK(e, clGetKernelWorkGroupInfo(k, dev, CL_KERNEL_PREFERRED_WORK_GROUP_SIZE_MULTIPLE,
                                             sizeof mult, &mult, NULL));
    if (max_wg > SPT_GROUP_MAX)
        max_wg = SPT_GROUP_MAX;
    if (max_wg < 1)
        max_wg = 1;
    if (mult < 1 || mult > max_wg)
        mult = 1;
    size_t local = (64 + mult - 1) / mult * mult;
    if (local > max_wg)
        local = max_wg / mult * mult;
    *out = local;
    return 0;
}

/* A camera path counts up to SPT_PM_COUNT_MAX photons of the light path it
 * would merge with (kernels/integrator/photon_merge.h, pm_camera_drops). */
SPT_STATIC_ASSERT(SPT_PM_PER_PATH <= SPT_PM_COUNT_MAX, "a camera path's count of photons saturates below the slots");

/* Photon slots per sample index with photon merging (light_paths per sample
 * index; 0: no merging). */
static uint64_t merge_slots(const RenderSettings *rs, const GpuScene *g, uint32_t light_paths)
{
    if (!light_paths || !light_plan_merges(rs, g))
        return 0;
    return (uint64_t)light_plan_max_paths(rs) * SPT_PM_PER_PATH;
}

/* The hash grid's most buckets for photon slots: the power of two at or
 * above them. */
static uint64_t merge_buckets(uint64_t slots)
{
    uint64_t b = 1;
    while (b < slots)
        b *= 2;
    return b;
}

void wavefront_plan(WavefrontPlan *p, const ClDeviceInfo *info, const GpuScene *g,
                    const RenderSettings *rs, const RenderLights *L, size_t env_floats,
                    uint32_t light_film)
{
    memset(p, 0, sizeof *p);
    uint64_t npix = (uint64_t)rs->width * (uint64_t)rs->height;
    /* Samples per chunk: the pool 16 times over, with the per-sample
     * contribution buffer under 64 MiB. A chunk ends with its last paths
     * running in a near-empty pool and a wait for the host, so fewer, larger
     * chunks keep the device busier (16 pools render the Cornell box about 6%
     * faster than 4 on PoCL), and a chunk still takes well under a second. But
     * a render keeps at least 16 chunks (when it has the samples), so that
     * several devices or MPI processes sharing it end close together (with 4
     * chunks, two processes reach 1.8 times one instead of 1.95). */
    p->pool = pool_size_for(info, rs->pool_size, npix * (uint64_t)(rs->spp > 0 ? rs->spp : 1));
    uint64_t spp = (16ull * p->pool + npix - 1) / npix;
    if (rs->spp > 0 && spp > ((uint64_t)rs->spp + 15) / 16)
        spp = ((uint64_t)rs->spp + 15) / 16;
    /* With AOVs a sample also keeps 3 float4 (aov_sample). */
    p->aov = render_keeps_aov(rs);
    p->bands = rs->spectral > 0 ? rs->spectral : 0;
    uint64_t sample_bytes = (p->aov ? 64ull : 16ull) + (p->bands ? 32ull : 0ull);
    uint64_t cap = (64ull << 20) / (npix * sample_bytes);
    if (spp > cap)
        spp = cap;
    /* Photon merging keeps each sample index's photons: at most 128 MiB of
     * them per chunk. */
    uint64_t pm_slots = merge_slots(rs, g, light_film);
    if (pm_slots && spp > (128ull << 20) / (pm_slots * 16ull * SPT_PM_PHOTON_FLOAT4))
        spp = (128ull << 20) / (pm_slots * 16ull * SPT_PM_PHOTON_FLOAT4);
    if (spp < 1)
        spp = 1;
    if (rs->spp > 0 && spp > (uint64_t)rs->spp)
        spp = (uint64_t)rs->spp;
    p->chunk_spp = (uint32_t)spp;
    /* No more slots than a chunk has work items (its camera paths and at most
     * SPT_LIGHT_PATHS_MAX light paths per pixel and sample): the stage kernels
     * run over the whole pool every wave, and a render of few pixels and many
     * samples, whose pool the render's samples sized but whose chunks take
     * one sample each, spent each wave on empty slots (32x32 at 16 spp on
     * rusticl took 90 times as long as at 1 spp). The chunks stay as
     * planned above, and the image does not depend on the pool. */
    double chunk_items = (double)npix * (double)spp * (1.0 + (light_film ? SPT_LIGHT_PATHS_MAX : 0.0));
    if ((double)p->pool > chunk_items)
        p->pool = (uint32_t)chunk_items;

    /* The buffers (a buffer unused in this build holds one element). */
    p->counters = SPT_CNT_COUNT * sizeof(cl_uint);
    p->queue_extend = (size_t)p->pool * sizeof(cl_uint);
    p->contrib = (size_t)(npix * spp * 16ull);
    p->chunk_sum = (size_t)npix * 16;
    p->pixel_lag = (size_t)npix * 4;
    p->chunk_sq = (size_t)npix * 16;
    p->light_film = light_film ? (size_t)(npix * SPT_SPLAT_WORDS * 4ull) : 16;
    p->aov_sample = p->aov ? (size_t)(npix * spp * 48ull) : 16;
    p->aov_sum = p->aov ? (size_t)npix * 64 : 16;
    p->spec_sample = p->bands ? (size_t)(npix * spp * 32ull) : 16;
    p->spec_sum = p->bands ? (size_t)npix * 4 * (size_t)p->bands : 16;
    p->pm_photon = pm_slots ? (size_t)(pm_slots * spp * 16ull * SPT_PM_PHOTON_FLOAT4) : 16;
    p->pm_cell = pm_slots ? (size_t)((merge_buckets(pm_slots * spp) + 1) * 4ull) : 16;
    p->pm_radius = pm_slots ? (size_t)(spp * 8ull) : 16;
#define PS_BYTES(type, name) p->path_state += (size_t)p->pool * sizeof(type);
#define SH_BYTES(type, name) p->shadow_state += (size_t)p->pool * sizeof(type);
    SPT_PATH_STATE(PS_BYTES)
    SPT_SHADOW_STATE(SH_BYTES)
#undef PS_BYTES
#undef SH_BYTES
    /* The worker's host arrays (src/render/scheduler.c). */
    p->host_sums = (size_t)npix * 4 * sizeof(float);
    p->host_aov = p->aov ? (size_t)npix * SPT_AOV_CHUNK_FLOATS * sizeof(float) : 0;
    p->host_spec = p->bands ? (size_t)npix * (size_t)p->bands * sizeof(float) : 0;
    p->host_sq = rs->adaptive == SPT_SWITCH_ON && !rs->take_chunk ? (size_t)npix * 4 * sizeof(float) : 0;
    /* Photon merging's: the photons read back, sorted, and the grid. */
    p->host_pm = pm_slots ? 2 * p->pm_photon + p->pm_cell + p->pm_radius : 0;

    ClAlloc *al = p->allocs;
    int na = 0;
#define PLAN(type, nm)                                                                   \
    al[na].name = #nm;                                                                   \
    al[na].bytes = !L && !strcmp(#nm, "env_data") && env_floats ? env_floats * sizeof(float) \
                                                                : gpu_scene_buffer_bytes(g, L, #nm); \
    p->scene += al[na++].bytes;
    SPT_SCENE_BUFFERS(PLAN)
#undef PLAN
#define WORK(type, nm) al[na].name = #nm; al[na++].bytes = p->nm;
    SPT_WORK_BUFFERS(WORK)
#undef WORK
    al[na].name = "path state";
    al[na++].bytes = p->path_state;
    al[na].name = "shadow rays";
    al[na++].bytes = p->shadow_state;
    p->count = na;
    for (int i = 0; i < na; i++)
        p->device += al[i].bytes;
}

/* The kernels' code path for rendering with rs on info's device: *ray_pairs
 * (the CPU path), *mega (k_paths rather than the stages) and, unless one_ray
 * is NULL, *one_ray (k_paths traces its two rays one after the other). */
static void kernel_path_for(const ClDeviceInfo *info, const RenderSettings *rs, int *ray_pairs,
                            int *mega, int *one_ray)
{
    *ray_pairs = kernel_path_pairs(info);
    /* The kernel_path test hook overrides that choice, so both paths run on any
     * device: tools/check_kernels.sh runs the CPU path under Oclgrind (a GPU to
     * us), tests/run_tests.sh the device tests on PoCL's CPU with the GPU path.
     * The hook comes from the caller's settings or, where they leave it to the
     * device, from SPECTRACE_KERNEL_PATH (docs/testing.md). */
    int path = rs->test.kernel_path, stages = rs->test.stages, rays = rs->test.rays;
    if (path == SPT_KERNEL_PATH_DEVICE)
        kernel_path_env(&path, &stages, &rays);
    if (path == SPT_KERNEL_PATH_CPU)
        *ray_pairs = 1;
    else if (path == SPT_KERNEL_PATH_GPU)
        *ray_pairs = 0;
    /* The megakernel: on the CPU path, k_paths runs each work-item's paths from
     * start to end (kernels/integrator/wavefront.cl). A CPU runs a work-group's
     * items one after another, so the stage kernels' queues, barriers and
     * passes over the path state only cost time there: the Cornell box takes
     * about 10% less CPU time, the 1M-triangle mesh the same
     * (docs/performance.md). A GPU keeps the stages, whose queues keep its
     * lanes on the same work. The stages test hook keeps them on a CPU too. */
    *mega = *ray_pairs && !stages;
    /* k_paths's two closest-hit rays: on Intel's cores one after the other
     * is 3-5% faster than the paired traversal (bvh_intersect2) on both the
     * Cornell box and the 1M-triangle mesh (docs/performance.md, "Vector
     * width: AVX-512 against AVX2"); elsewhere the pair stays. The same hits
     * either way; the rays hook picks one for the tests. */
    if (one_ray)
        *one_ray = *mega && (rays == SPT_RAYS_ONE_BY_ONE ||
                             (rays == SPT_RAYS_DEVICE && strstr(info->vendor, "Intel") != NULL));
}

/* A BVH larger than a quarter of the device's cache (shared by its cores
 * and other programs) is read mostly from memory: each traversal step then
 * asks early for the next one's data; in a small scene those requests only
 * cost time. The cache counted is at most WAVEFRONT_CACHE_CAP: a server CPU
 * reports its whole package's last-level cache (480 MiB on a Xeon whose
 * virtual machine has 2 of its cores), of which a core gets a small share,
 * and at a higher latency than a desktop's (docs/performance.md, "What sets
 * the speed": the prefetch makes the 1M-triangle mesh's 24 MB tree 5%
 * faster there, and changes nothing at 2 and 7 MB). */
#define WAVEFRONT_CACHE_CAP (32.0 * 1024.0 * 1024.0)

int wavefront_step_prefetch(double bvh_bytes, double cache)
{
    if (cache > WAVEFRONT_CACHE_CAP)
        cache = WAVEFRONT_CACHE_CAP;
    return bvh_bytes > 0.25 * cache;
}

void wavefront_options(const ClDeviceInfo *info, const GpuScene *g, const RenderSettings *rs,
                       char *out, size_t cap)
{
    int ray_pairs, mega, one_ray;
    kernel_path_for(info, rs, &ray_pairs, &mega, &one_ray);
    cl_ulong cache = 0;
    if (ray_pairs && clGetDeviceInfo(info->id, CL_DEVICE_GLOBAL_MEM_CACHE_SIZE, sizeof cache,
                                     &cache, NULL) != CL_SUCCESS)
        cache = 0;
    double bvh_bytes = (double)g->bvh.node_count * (g->qnodes ? sizeof(BvhQNode) : sizeof(BvhNode)) +
                       (double)g->bvh.tri_data_bytes;
    int step_prefetch = ray_pairs && wavefront_step_prefetch(bvh_bytes, (double)cache);
    /* The thin film's code only where a material has one (kernels/closure/
     * bsdf_params.h, SPT_IRIDESCENCE). */
    int film = 0;
    for (uint32_t i = 0; i < g->material_count; i++)
        film |= g->materials[i].iridescence > 0.0f;
    /* The CPU path's program without the texture or the layers' code where
     * no material needs it (kernels/integrator/path.h, SPT_TEXTURES;
     * kernels/closure/bsdf_params.h, SPT_LAYERS; docs/performance.md,
     * "Generality a scene does not use"): a material has layers unless its
     * factors are 0 or below (a NaN counts as a layer). The GPU path keeps
     * them, for rusticl's build time as below. */
    int textures = !ray_pairs, layers = !ray_pairs;
    for (uint32_t i = 0; i < g->material_count; i++) {
        const GpuMaterial *m = &g->materials[i];
        for (int k = 0; k < SPT_TS_COUNT; k++)
            textures |= m->slot[k].tex >= 0;
        layers |= !(m->clearcoat <= 0.0f) || m->sheen.kind != SPT_SPEC_NONE || !(m->aniso <= 0.0f) ||
                  !(m->diffuse_transmission <= 0.0f);
    }
    /* A scene without instances builds the CPU path's program without their
     * code (kernels/integrator/kernel_globals.h, SPT_HAS_INSTANCES;
     * docs/performance.md, "Instances: two levels"). The GPU path keeps one
     * program for both: rusticl's cold build of each program variant takes
     * about 7 minutes, which CI would pay again for the second. */
    int no_inst = ray_pairs && g->tlas.inst_count == 0;
    char bands_def[32] = "";
    if (rs->spectral > 0)
        snprintf(bands_def, sizeof bands_def, "-DSPT_BANDS=%d ", rs->spectral);
    /* Photon merging's code only where it is asked for
     * (kernels/integrator/photon_merge.h). */
    snprintf(out, cap, "%s%s%s%s%s%s%s%s%s%s%s%s",
             ray_pairs ? "-DSPT_BVH_SIMD=1 -DSPT_BVH_PAIRS=1 " : "-DSPT_BVH_SHORT_STACK=1 ",
             one_ray ? "-DSPT_ONE_RAY=1 " : "",
             no_inst ? "-DSPT_INSTANCES=0 " : "", textures ? "" : "-DSPT_TEXTURES=0 ",
             layers ? "" : "-DSPT_LAYERS=0 ",
             g->qnodes ? "-DSPT_BVH_QNODES=1 " : "", step_prefetch ? "-DSPT_BVH_STEP_PREFETCH=1 " : "",
             film ? "" : "-DSPT_IRIDESCENCE=0 ", render_keeps_aov(rs) ? "-DSPT_AOV=1 " : "", bands_def,
             light_plan_merges(rs, g) ? "-DSPT_MERGE=1 " : "",
             rs->test.inject_nan ? "-DSPT_TEST_INJECT_NAN=1" : "");
}

int wavefront_fits(const Wavefront *w, const GpuScene *g, const RenderSettings *rs)
{
    if (w->dev.profiling != (rs->profile != 0))
        return SPT_WAVEFRONT_REOPEN;
    char options[sizeof w->options];
    int ray_pairs, mega;
    kernel_path_for(&w->dev.info, rs, &ray_pairs, &mega, NULL);
    wavefront_options(&w->dev.info, g, rs, options, sizeof options);
    return !strcmp(options, w->options) && ray_pairs == w->ray_pairs && mega == w->mega
               ? SPT_WAVEFRONT_FITS
               : SPT_WAVEFRONT_REBUILD;
}

int wavefront_program(Wavefront *w, const GpuScene *g, const RenderSettings *rs, SptError *e)
{
    int rc;
    for (int i = 0; i < K_COUNT; i++)
        if (w->k[i])
            clReleaseKernel(w->k[i]);
    memset(w->k, 0, sizeof w->k);
    if (w->program)
        clReleaseProgram(w->program);
    w->program = NULL;
    const ClDeviceInfo *info = &w->dev.info;
    w->aov = render_keeps_aov(rs);
    w->bands = rs->spectral > 0 ? rs->spectral : 0;
    kernel_path_for(info, rs, &w->ray_pairs, &w->mega, NULL);
    wavefront_options(info, g, rs, w->options, sizeof w->options);
    w->dev.stop = rs->stop;
    w->dev.announce = rs->progress || rs->announce;
    if ((rc = cl_program_build(&w->dev, "kernels/integrator/wavefront.cl", w->options, &w->program, e)))
        return rc;
    for (int i = 0; i < K_COUNT; i++) {
        cl_int err;
        if (i == K_PATHS && !w->ray_pairs)
            continue; /* k_paths is built on the CPU path only */
        SPT_CL_CHECK(e, (w->k[i] = clCreateKernel(w->program, kernel_names[i], &err), err));
        if ((rc = group_size_for(w->k[i], w->dev.info.id, &w->local[i], e)))
            return rc;
    }
    return 0;
}

int wavefront_open(Wavefront *w, const ClDeviceInfo *info, const GpuScene *g,
                   const RenderSettings *rs, SptError *e)
{
    int rc;
    memset(w, 0, sizeof *w);
    if ((rc = cl_device_open(&w->dev, info, rs->profile, e)))
        return rc;
    return wavefront_program(w, g, rs, e);
}

int wavefront_buffers(Wavefront *w, const GpuScene *g, const RenderSettings *rs,
                      const RenderLights *L, uint32_t light_film, SptError *e)
{
    int rc;
    const ClDeviceInfo *info = &w->dev.info;
    WavefrontPlan *pl = &w->plan;
    wavefront_plan(pl, info, g, rs, L, 0, light_film);
    w->pool = pl->pool;
    w->chunk_spp = pl->chunk_spp;
    if ((rc = cl_device_check_memory(info, pl->allocs, pl->count, e)))
        return rc;
    int keep = rs->programs && rs->programs->keep_scene;
    w->uploaded = 0;
#define MAKE_RO(type, name)                                                              \
    if ((rc = scene_buffer(w, SPT_SB_##name, #name, g, L, keep, &w->b.name, e)))         \
        return rc;
    SPT_SCENE_BUFFERS(MAKE_RO)
#undef MAKE_RO
    size_t pool = w->pool;
#define MAKE_PS(type, name)                                                              \
    if ((rc = cl_buffer_create(&w->dev, "path " #name, CL_MEM_READ_WRITE, pool * sizeof(type), \
                               NULL, &w->b.ps_##name, e)))                                 \
        return rc;
#define MAKE_SH(type, name)                                                              \
    if ((rc = cl_buffer_create(&w->dev, "shadow " #name, CL_MEM_READ_WRITE, pool * sizeof(type), \
                               NULL, &w->b.sh_##name, e)))                                 \
        return rc;
    SPT_PATH_STATE(MAKE_PS)
    SPT_SHADOW_STATE(MAKE_SH)
#undef MAKE_PS
#undef MAKE_SH
#define MAKE_WORK(type, name)                                                            \
    if ((rc = cl_buffer_create(&w->dev, #name,                                           \
                               !strcmp(#name, "pixel_lag") || !strcmp(#name, "pm_cell") || !strcmp(#name, "pm_radius") ? CL_MEM_READ_ONLY : CL_MEM_READ_WRITE, \
                               pl->name, NULL, &w->b.name, e)))                          \
        return rc;
    SPT_WORK_BUFFERS(MAKE_WORK)
#undef MAKE_WORK
    /* Test hook (RenderTestHooks poison): every path, shadow, queue, counter and
     * film buffer first holds the test's word, so that a value read before
     * anything wrote it shows rather than whatever the fresh allocation held. */
    if (rs->test.poison) {
        cl_uint pat = rs->test.poison_word;
#define POISON(type, name) if (!rc) rc = fill_words(&w->dev, w->b.name, pat, e);
#define PS_POISON(type, name) POISON(type, ps_##name)
#define SH_POISON(type, name) POISON(type, sh_##name)
        SPT_WORK_BUFFERS(POISON)
        SPT_PATH_STATE(PS_POISON)
        SPT_SHADOW_STATE(SH_POISON)
#undef POISON
#undef PS_POISON
#undef SH_POISON
        if (rc)
            return rc;
    }
    /* Every pixel takes every sample until adaptive sampling says otherwise. */
    if ((rc = fill_words(&w->dev, w->b.pixel_lag, 0u, e)))
        return rc;
    /* Every slot starts free (SPT_PATH_DEAD = 0). */
    cl_uint zero = 0;
    SPT_CL_CHECK(e, clEnqueueFillBuffer(w->dev.queue, w->b.ps_flags, &zero, sizeof zero, 0,
                                        pool * sizeof(cl_uint), 0, NULL, NULL));
    return 0;
}

int wavefront_create(Wavefront *w, const ClDeviceInfo *info, const GpuScene *g,
                     const RenderSettings *rs, const RenderLights *L, uint32_t light_film, SptError *e)
{
    int rc;
    memset(w, 0, sizeof *w);
    /* Everything checked against the device before it is opened. */
    WavefrontPlan pl;
    wavefront_plan(&pl, info, g, rs, L, 0, light_film);
    if ((rc = cl_device_check_memory(info, pl.allocs, pl.count, e)) ||
        (rc = wavefront_open(w, info, g, rs, e)))
        return rc;
    return wavefront_buffers(w, g, rs, L, light_film, e);
}

int wavefront_set_lags(Wavefront *w, const uint32_t *lag, size_t npix, SptError *e)
{
    SPT_CL_CHECK(e, clEnqueueWriteBuffer(w->dev.queue, w->b.pixel_lag, CL_TRUE, 0, npix * 4, lag, 0,
                                         NULL, NULL));
    return 0;
}

static double event_seconds(cl_event ev)
{
    cl_ulong a = 0, b = 0;
    clGetEventProfilingInfo(ev, CL_PROFILING_COMMAND_START, sizeof a, &a, NULL);
    clGetEventProfilingInfo(ev, CL_PROFILING_COMMAND_END, sizeof b, &b, NULL);
    return b > a ? (double)(b - a) * 1e-9 : 0.0;
}

/* Enqueues kernel k over n work-items (rounded up); with profiling, adds its
 * device time to *acc. */
static int run_kernel(Wavefront *w, int k, size_t n, double *acc, SptError *e)
{
    cl_event ev = NULL;
    size_t local = w->local[k];
    size_t global = (n + local - 1) / local * local;
    SPT_CL_CHECK(e, clEnqueueNDRangeKernel(w->dev.queue, w->k[k], 1, NULL, &global, &local, 0,
                                           NULL, acc ? &ev : NULL));
    if (ev) {
        clWaitForEvents(1, &ev);
        *acc += event_seconds(ev);
        clReleaseEvent(ev);
    }
    return 0;
}

/* The end of a chunk whose paths are all done: k_accumulate's per-pixel sums
 * read into sums (and the AOV and band sums). */
static int chunk_sums(Wavefront *w, const RenderParams *p, double *acc, float *sums,
                      float *aov_sums, float *spec_sums, float *sq_sums, RenderStats *st,
                      SptError *e)
{
    int rc;
    uint32_t npix = (uint32_t)(p->width * p->height);
    if ((rc = run_kernel(w, K_ACCUMULATE, npix, acc ? acc + K_ACCUMULATE : NULL, e)))
        return rc;
    SPT_CL_CHECK(e, clEnqueueReadBuffer(w->dev.queue, w->b.chunk_sum, CL_TRUE, 0,
                                        (size_t)npix * 16, sums, 0, NULL, NULL));
    if (sq_sums)
        SPT_CL_CHECK(e, clEnqueueReadBuffer(w->dev.queue, w->b.chunk_sq, CL_TRUE, 0,
                                            (size_t)npix * 16, sq_sums, 0, NULL, NULL));
    if (w->aov && aov_sums)
        SPT_CL_CHECK(e, clEnqueueReadBuffer(w->dev.queue, w->b.aov_sum, CL_TRUE, 0,
                                            (size_t)npix * 64, aov_sums, 0, NULL, NULL));
    if (w->bands && spec_sums)
        SPT_CL_CHECK(e, clEnqueueReadBuffer(w->dev.queue, w->b.spec_sum, CL_TRUE, 0,
                                            (size_t)npix * 4 * (size_t)w->bands, spec_sums, 0, NULL,
                                            NULL));
    st->paths += p->light_begin;
    return 0;
}

/* Work items per k_paths launch: a pool's worth (tens of milliseconds), so a
 * stop request is seen between launches as between the stage kernels' waves. */
#define SPT_MEGA_LAUNCH_ITEMS(w) ((uint64_t)(w)->pool)

/* Whether a stop request ends the chunk: a second one, or a first one in a
 * long chunk (render_chunk). */
static int stop_asked(const Wavefront *w, int long_chunk)
{
    return w->stop && (*w->stop >= 2 || (*w->stop == 1 && long_chunk));
}

/* Runs work items [p->work_begin, p->work_end) to their end on the CPU path:
 * k_paths over them, a launch per SPT_MEGA_LAUNCH_ITEMS, each launch's work
 * counter from zero. Work-items: four work-groups per compute unit, two slots
 * of the pool each (each CPU thread keeps one work-item's paths in flight at
 * a time). */
static int run_paths_mega(Wavefront *w, const RenderParams *p, int long_chunk, double *acc, RenderStats *st,
                          SptError *e)
{
    size_t local = w->local[K_PATHS];
    size_t items = (size_t)4 * (w->dev.info.compute_units ? w->dev.info.compute_units : 1) * local;
    if (items > w->pool / 2)
        items = (w->pool / 2 + local - 1) / local * local;
    if (items < 1)
        items = 1;
    uint32_t end = p->work_end;
    cl_uint counters[SPT_CNT_COUNT];
    for (uint64_t begin = p->work_begin; begin < end; begin += SPT_MEGA_LAUNCH_ITEMS(w)) {
        static const cl_uint zero = 0;
        RenderParams lp = *p;
        lp.work_begin = (uint32_t)begin;
        lp.work_end = begin + SPT_MEGA_LAUNCH_ITEMS(w) < end
                          ? (uint32_t)(begin + SPT_MEGA_LAUNCH_ITEMS(w))
                          : end;
        int rc;
        SPT_CL_CHECK(e, clSetKernelArg(w->k[K_PATHS], SPT_KERNEL_BUFFER_ARGS, sizeof lp, &lp));
        SPT_CL_CHECK(e, clEnqueueWriteBuffer(w->dev.queue, w->b.counters, CL_FALSE,
                                             SPT_CNT_WORK * sizeof(cl_uint), sizeof zero, &zero,
                                             0, NULL, NULL));
        if ((rc = run_kernel(w, K_PATHS, items, acc ? acc + K_PATHS : NULL, e)))
            return rc;
        if (lp.work_end == end)
            break;
        SPT_CL_CHECK(e, clFinish(w->dev.queue));
        if (stop_asked(w, long_chunk))
            return spt_fail(e, SPT_EXIT_INTERRUPTED, "interrupted");
    }
    SPT_CL_CHECK(e, clEnqueueReadBuffer(w->dev.queue, w->b.counters, CL_TRUE, 0,
                                        sizeof counters, counters, 0, NULL, NULL));
    st->rays_extend += counters[SPT_CNT_EXTEND];
    st->rays_shadow += counters[SPT_CNT_SHADOW];
    st->nan_dropped += counters[SPT_CNT_NAN];
    return 0;
}

/* The same with the stage kernels: waves of generate, extend, shade and
 * connect until every work item is done. The shading is two kernels, k_shade
 * for the camera paths and k_shade_light for the light paths (kernels/
 * integrator/wavefront.cl); each is launched only when p's work items hold
 * paths of its kind (camera paths below p->light_begin, light paths from it). */
static int run_paths_stages(Wavefront *w, const RenderParams *p, int long_chunk, double *acc, RenderStats *st,
                            SptError *e)
{
    int rc;
    cl_uint counters[SPT_CNT_COUNT] = {0};
    int camera = p->work_begin < p->light_begin, light = p->work_end > p->light_begin;
    for (;;) {
        static const cl_uint two_zeros[2] = {0, 0};
        SPT_CL_CHECK(e, clEnqueueWriteBuffer(w->dev.queue, w->b.counters, CL_FALSE, 0,
                                             sizeof two_zeros, two_zeros, 0, NULL, NULL));
        if ((rc = run_kernel(w, K_GENERATE, w->pool, acc ? acc + 0 : NULL, e)) ||
            (rc = run_kernel(w, K_EXTEND, w->ray_pairs ? (w->pool + 1) / 2 : w->pool,
                             acc ? acc + 1 : NULL, e)) ||
            (camera && (rc = run_kernel(w, K_SHADE, w->pool, acc ? acc + K_SHADE : NULL, e))) ||
            (light && (rc = run_kernel(w, K_SHADE_LIGHT, w->pool, acc ? acc + K_SHADE : NULL, e))) ||
            (rc = run_kernel(w, K_CONNECT, w->pool, acc ? acc + 3 : NULL, e)))
            return rc;
        SPT_CL_CHECK(e, clEnqueueReadBuffer(w->dev.queue, w->b.counters, CL_TRUE, 0,
                                            sizeof counters, counters, 0, NULL, NULL));
        st->rays_extend += counters[SPT_CNT_EXTEND];
        st->rays_shadow += counters[SPT_CNT_SHADOW];
        if (counters[SPT_CNT_DONE] >= p->work_end - p->work_begin)
            break;
        if (stop_asked(w, long_chunk))
            return spt_fail(e, SPT_EXIT_INTERRUPTED, "interrupted");
    }
    st->nan_dropped += counters[SPT_CNT_NAN];
    return 0;
}

/* Runs p's work items with every kernel's arguments set to p, the counters
 * zeroed first. */
static int run_paths(Wavefront *w, const RenderParams *p, int long_chunk, double *acc, RenderStats *st,
                     SptError *e)
{
    int rc;
    cl_uint counters[SPT_CNT_COUNT] = {0};
    SPT_CL_CHECK(e, clEnqueueWriteBuffer(w->dev.queue, w->b.counters, CL_TRUE, 0, sizeof counters,
                                         counters, 0, NULL, NULL));
    for (int k = 0; k < K_COUNT; k++)
        if (w->k[k] && (rc = set_args(w->k[k], &w->b, p, e)))
            return rc;
    return w->mega ? run_paths_mega(w, p, long_chunk, acc, st, e) : run_paths_stages(w, p, long_chunk, acc, st, e);
}

/* Photon merging's chunk (docs/architecture.md, "Caustics seen through
 * specular surfaces"): the light paths first, which leave their photons in
 * pm_photon (and splat as always); the hash grid sorted from them on the host
 * and uploaded (p's pm_mask and pm_count); then the camera paths, which
 * gather from it. */
static int run_merge_chunk(Wavefront *w, RenderParams *p, uint32_t n, int long_chunk, double *acc,
                           RenderStats *st, SptError *e)
{
    int rc;
    const WavefrontPlan *pl = &w->plan;
    if (!w->pm_raw) {
        w->pm_raw = spt_malloc(pl->pm_photon);
        w->pm_sorted = spt_malloc(pl->pm_photon);
        w->pm_cells = spt_malloc(pl->pm_cell);
        w->pm_radius = spt_malloc(pl->pm_radius);
    }
    size_t slots = (size_t)n * p->light_paths * SPT_PM_PER_PATH;
    size_t bytes = slots * 16u * SPT_PM_PHOTON_FLOAT4;
    if (bytes > pl->pm_photon || (size_t)n * 8u > pl->pm_radius)
        return spt_fail(e, SPT_EXIT_FAILURE, "photon buffers smaller than the chunk's photons");
    static const cl_uint zero = 0;
    SPT_CL_CHECK(e, clEnqueueFillBuffer(w->dev.queue, w->b.pm_photon, &zero, sizeof zero, 0, bytes, 0, NULL, NULL));
    photon_radius_table(p->pm_r0, p->sample_begin, n, w->pm_radius);
    SPT_CL_CHECK(e, clEnqueueWriteBuffer(w->dev.queue, w->b.pm_radius, CL_FALSE, 0, (size_t)n * 8u, w->pm_radius,
                                         0, NULL, NULL));
    RenderParams lp = *p;
    lp.work_begin = p->light_begin;
    if ((rc = run_paths(w, &lp, long_chunk, acc, st, e)))
        return rc;
    SPT_CL_CHECK(e, clEnqueueReadBuffer(w->dev.queue, w->b.pm_photon, CL_TRUE, 0, bytes, w->pm_raw, 0, NULL,
                                        NULL));
    p->pm_count = photon_grid_build(w->pm_raw, slots, w->pm_radius, pl->pm_cell / 4u - 1u, w->pm_sorted,
                                    w->pm_cells, &p->pm_mask);
    if (p->pm_count)
        SPT_CL_CHECK(e, clEnqueueWriteBuffer(w->dev.queue, w->b.pm_photon, CL_FALSE, 0,
                                             (size_t)p->pm_count * 16u * SPT_PM_PHOTON_FLOAT4, w->pm_sorted, 0,
                                             NULL, NULL));
    SPT_CL_CHECK(e, clEnqueueWriteBuffer(w->dev.queue, w->b.pm_cell, CL_TRUE, 0,
                                         ((size_t)p->pm_mask + 2u) * 4u, w->pm_cells, 0, NULL, NULL));
    RenderParams cp = *p;
    cp.work_end = p->light_begin;
    return run_paths(w, &cp, long_chunk, acc, st, e);
}

/* Renders samples [sample_begin, sample_begin + n) of every pixel on w and adds
 * their per-pixel sums to film. */
int render_chunk(Wavefront *w, const RenderParams *base, uint32_t sample_begin, uint32_t n,
                        int profile, float *sums, float *aov_sums, float *spec_sums, float *sq_sums,
                        RenderStats *st, SptError *e)
{
    RenderParams p = *base;
    uint32_t npix = (uint32_t)(p.width * p.height);
    p.sample_begin = sample_begin;
    p.work_begin = 0;
    /* The camera paths of the chunk, then its light paths (light_paths per
     * sample index). */
    p.light_begin = n * npix;
    p.work_end = p.light_begin + n * p.light_paths;
    if (p.light_paths > 0) {
        cl_uint zero = 0;
        SPT_CL_CHECK(e, clEnqueueFillBuffer(w->dev.queue, w->b.light_film, &zero, sizeof zero, 0,
                                            (size_t)npix * SPT_SPLAT_WORDS * 4u, 0, NULL, NULL));
    }
    int rc;
    double *acc = profile ? st->stage_seconds : NULL;
    /* A first stop request waits for a regular chunk (at most about 32 pools of
     * camera paths, well under a second), but drops a longer one: one sample of
     * an image larger than 32 pools (a chunk is never less), which can take a
     * minute. The film only ever receives whole chunks. */
    int long_chunk = (uint64_t)n * npix > SPT_LONG_CHUNK_POOLS * (uint64_t)w->pool;
    if (p.merge && p.light_paths > 0)
        rc = run_merge_chunk(w, &p, n, long_chunk, acc, st, e);
    else
        rc = run_paths(w, &p, long_chunk, acc, st, e);
    if (rc)
        return rc;
    /* k_accumulate's arguments: the whole chunk's. */
    p.work_begin = 0;
    p.work_end = p.light_begin + n * p.light_paths;
    if (w->k[K_ACCUMULATE] && (rc = set_args(w->k[K_ACCUMULATE], &w->b, &p, e)))
        return rc;
    return chunk_sums(w, &p, acc, sums, aov_sums, spec_sums, sq_sums, st, e);
}
