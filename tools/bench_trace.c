/* Traversal benchmark: the device's ray queries alone, on given triangles and
 * rays, so that they can be timed against another ray tracer on the very same
 * input (tools/bench_trace.py writes both files from a glTF scene and times
 * Mitsuba 3's Embree on them; docs/performance.md, "Where a ray's time goes").
 *
 * Builds the BVH with the renderer's defaults (bvh_default_options_for) and a
 * kernel on the renderer's traversal with its options for the device: on a CPU
 * device the vector leaf test (SPT_BVH_SIMD) and the step prefetch where the
 * renderer's rule asks for it (wavefront_step_prefetch), elsewhere the short
 * stack. Times each query over all rays, one launch per run, and prints the
 * medians: closest hits one ray per work-item, closest hits two rays per
 * work-item traced together (bvh_intersect2, the pairs of the renderer's CPU
 * path on other vendors' CPUs), any hits of the same rays (unbounded, so most
 * end at their first hit) and any hits of the segments (shadow rays: those
 * that nothing blocks visit every box along them). Before that, the
 * host's traversal of the same tree counts the nodes, leaves and triangles a
 * ray visits (the first 200,000 rays).
 *
 * Usage: bench_trace TRIS RAYS SEGMENTS [RUNS]
 *   TRIS: float32 triangles, 9 per triangle (v0, v1, v2); RAYS: float32 rays,
 *   6 per ray (origin, direction), each tested for t in (0, 1e30);
 *   SEGMENTS: the same form, each from its origin to origin + direction (t in
 *   (0, 0.9999), as a shadow ray stops short of the light it aims at).
 * SPECTRACE_DEVICE selects the device. Exit 0, or 1 with an error line. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "accel/bvh_build.h"
#include "bvh/bvh.h"
#include "cl/cl_device.h"
#include "core/input_file.h"
#include "core/util.h"
#include "render/wavefront.h"
#include "bench_util.h"

/* The t up to which a segment is tested (1 is its end), on the host and in
 * k_src. */
#define SEGMENT_TMAX 0.9999f
#define BENCH_STR_(x) #x
#define BENCH_STR(x) BENCH_STR_(x)

static const char *k_src =
    "#include \"bvh/bvh.h\"\n"
    "#define SEGMENT_TMAX " BENCH_STR(SEGMENT_TMAX) "\n"
    "__kernel void k_trace(__global const BvhNode *nodes, __global const float *tris,\n"
    "                      __global const float *rays, __global float *out, int n, int mode)\n"
    "{\n"
    "    int i = get_global_id(0);\n"
    "    if (i >= n)\n"
    "        return;\n"
    "    vec3 o = v3(rays[i * 6], rays[i * 6 + 1], rays[i * 6 + 2]);\n"
    "    vec3 d = v3(rays[i * 6 + 3], rays[i * 6 + 4], rays[i * 6 + 5]);\n"
    "    BvhHit h;\n"
    "    if (mode == 1) {\n"
    "        out[i] = (float)bvh_occluded(nodes, tris, o, d, 1e30f);\n"
    "    } else if (mode == 3) {\n"
    "        /* a segment: d reaches its end at t = 1 */\n"
    "        out[i] = (float)bvh_occluded(nodes, tris, o, d, SEGMENT_TMAX);\n"
    "    } else if (mode == 2) {\n"
    "        /* rays 2k and 2k + 1 together, by the even work-item */\n"
    "        int j = i + 1 < n ? i + 1 : i;\n"
    "        if (i & 1)\n"
    "            return;\n"
    "        vec3 o2 = v3(rays[j * 6], rays[j * 6 + 1], rays[j * 6 + 2]);\n"
    "        vec3 d2 = v3(rays[j * 6 + 3], rays[j * 6 + 4], rays[j * 6 + 5]);\n"
    "        int f[2];\n"
    "        BvhHit hh[2];\n"
    "        bvh_intersect2(nodes, tris, o, d, o2, d2, 1e30f, f, hh);\n"
    "        out[i] = f[0] ? hh[0].t : -1.0f;\n"
    "        out[j] = f[1] ? hh[1].t : -1.0f;\n"
    "    } else {\n"
    "        out[i] = bvh_intersect(nodes, tris, o, d, 1e30f, &h) ? h.t : -1.0f;\n"
    "    }\n"
    "}\n";

/* The whole file at path (input_read) as floats, a whole number of records of
 * per; NULL with an error line otherwise. */
static float *read_floats(const char *path, const char *what, size_t per, size_t *count)
{
    unsigned char *data = NULL;
    size_t size = 0;
    SptError e = {0};
    if (input_read(path, what, &data, &size, &e)) {
        spt_report(&e);
        return NULL;
    }
    if (size == 0 || size % (per * sizeof(float))) {
        spt_error("%s: %s: not a whole number of %zu-float records (%zu bytes)", path, what, per, size);
        free(data);
        return NULL;
    }
    *count = size / (per * sizeof(float));
    return (float *)data;
}

/* Host traversal counts per ray over the first n rays, each tested for t in
 * (0, tmax) (any_hit: stop at the first hit). */
static void host_counts(const Bvh *bvh, const float *rays, size_t n, int any_hit, float tmax,
                        const char *what)
{
    double nodes = 0, leaves = 0, tris = 0;
    for (size_t i = 0; i < n; i++) {
        const float *r = rays + i * 6;
        BvhTrav s;
        bvh_trav_init(&s, v3(r[0], r[1], r[2]), v3(r[3], r[4], r[5]), tmax);
        do {
            if (s.count) {
                leaves++;
                tris += s.count & 255u;
            } else {
                nodes++;
            }
        } while (bvh_trav_step(bvh->nodes, bvh->tri_data, &s, any_hit));
    }
    printf("  host traversal, %s: %.2f nodes, %.2f leaves, %.1f triangles per ray\n", what,
           nodes / (double)n, leaves / (double)n, tris / (double)n);
}

int main(int argc, char **argv)
{
    if (argc < 4 || argc > 5) {
        fprintf(stderr, "usage: bench_trace TRIS RAYS SEGMENTS [RUNS]\n");
        return 1;
    }
    int runs = argc > 4 ? atoi(argv[4]) : 5;
    if (runs < 1) {
        spt_error("RUNS must be at least 1, not '%s'", argv[4]);
        return 1;
    }
    size_t nt = 0, nr = 0, ns = 0;
    float *tris = read_floats(argv[1], "triangles", 9, &nt);
    float *rays = tris ? read_floats(argv[2], "rays", 6, &nr) : NULL;
    float *segs = rays ? read_floats(argv[3], "segments", 6, &ns) : NULL;
    if (!segs || nt > UINT32_MAX || nr > (size_t)1 << 30 || ns > (size_t)1 << 30)
        return 1;
    SptError e = {0};
    Bvh bvh;
    BvhOptions opt = bvh_default_options_for((uint32_t)nt);
    if (bvh_build_ex(&bvh, tris, (uint32_t)nt, &opt, &e)) {
        spt_error("%s", e.msg);
        return 1;
    }
    double bvh_bytes = (double)bvh.node_count * sizeof(BvhNode) + (double)bvh.tri_data_bytes;
    printf("  %zu triangles, %zu rays; BVH %u nodes, leaves of %.2f triangles, %.1f MB\n", nt, nr,
           bvh.node_count, bvh.stats.avg_leaf_size, bvh_bytes * 1e-6);
    size_t nh = nr < 200000 ? nr : 200000;
    host_counts(&bvh, rays, nh, 0, 1e30f, "closest hit");
    host_counts(&bvh, rays, nh, 1, 1e30f, "any hit, unbounded");
    host_counts(&bvh, segs, ns < nh ? ns : nh, 1, SEGMENT_TMAX, "any hit, segments");

    ClDevice *dev = NULL;
    int ndev = 0;
    if (cl_devices_open(NULL, 0, &dev, &ndev, &e)) {
        cl_device_report(NULL, &e);
        return 1;
    }
    ClDevice *d = &dev[0];
    int cpu = (d->info.type & CL_DEVICE_TYPE_CPU) != 0;
    cl_ulong cache = 0;
    clGetDeviceInfo(d->info.id, CL_DEVICE_GLOBAL_MEM_CACHE_SIZE, sizeof cache, &cache, NULL);
    char options[128];
    snprintf(options, sizeof options, "%s%s", cpu ? "-DSPT_BVH_SIMD=1" : "-DSPT_BVH_SHORT_STACK=1",
             cpu && wavefront_step_prefetch(bvh_bytes, (double)cache) ? " -DSPT_BVH_STEP_PREFETCH=1" : "");
    cl_program prog;
    if (cl_program_build_text(d, "tools/bench_trace.cl", k_src, options, &prog, &e)) {
        cl_device_report(d, &e);
        return 1;
    }
    printf("  device: %s (%s), options %s\n", d->info.name, d->info.impl, options);
    cl_int err;
    cl_kernel k = clCreateKernel(prog, "k_trace", &err);
    size_t nmax = nr > ns ? nr : ns;
    cl_mem buf[5] = {
        clCreateBuffer(d->context, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, bvh.node_count * sizeof(BvhNode),
                       bvh.nodes, &err),
        clCreateBuffer(d->context, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, bvh.tri_data_bytes, bvh.tri_data, &err),
        clCreateBuffer(d->context, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, nr * 6 * sizeof(float), rays, &err),
        clCreateBuffer(d->context, CL_MEM_WRITE_ONLY, nmax * sizeof(float), NULL, &err),
        clCreateBuffer(d->context, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, ns * 6 * sizeof(float), segs, &err)};
    for (int a = 0; a < 5; a++)
        if (!buf[a]) {
            spt_error("bench_trace: cannot allocate the device's buffers (%zu rays)", nmax);
            return 1;
        }
    clSetKernelArg(k, 0, sizeof(cl_mem), &buf[0]);
    clSetKernelArg(k, 1, sizeof(cl_mem), &buf[1]);
    clSetKernelArg(k, 3, sizeof(cl_mem), &buf[3]);
    float *out = malloc(nmax * sizeof *out);
    double *sec = malloc((size_t)runs * sizeof *sec);
    /* Query q: its kernel mode, its rays (segments for the last) and name. */
    static const int mode_of[4] = {0, 2, 1, 3};
    static const char *names[4] = {"closest hit", "closest hit, two rays per work-item",
                                   "any hit, unbounded", "any hit, segments"};
    int status = 0;
    for (int q = 0; q < 4 && !status; q++) {
        int mode = mode_of[q], n = (int)(q == 3 ? ns : nr);
        clSetKernelArg(k, 2, sizeof(cl_mem), &buf[q == 3 ? 4 : 2]);
        clSetKernelArg(k, 4, sizeof n, &n);
        clSetKernelArg(k, 5, sizeof mode, &mode);
        /* Work-groups of 64, as the renderer's (kernels keep private stacks). */
        size_t local = 64, global = ((size_t)n + local - 1) / local * local;
        double hits = 0;
        /* One launch first, untimed: the device's first run of a kernel
         * pays for its set-up. */
        for (int r = -1; r < runs && !status; r++) {
            double t0 = spt_now();
            err = clEnqueueNDRangeKernel(d->queue, k, 1, NULL, &global, &local, 0, NULL, NULL);
            if (err == CL_SUCCESS)
                err = clFinish(d->queue);
            if (r >= 0)
                sec[r] = spt_now() - t0;
            if (err == CL_SUCCESS)
                err = clEnqueueReadBuffer(d->queue, buf[3], CL_TRUE, 0, (size_t)n * sizeof *out, out, 0, NULL,
                                          NULL);
            if (err != CL_SUCCESS) {
                spt_error("bench_trace: the %s kernel failed: %s", names[q], cl_error_name(err));
                status = 1;
            }
        }
        if (status)
            break;
        for (int i = 0; i < n; i++)
            hits += out[i] > 0.0f;
        double m = bench_median(sec, runs);
        printf("  %-36s %7.1f ns/ray  %7.2f Mrays/s  (median of %d; hit %.4f of the rays)\n", names[q],
               m / (double)n * 1e9, (double)n / m * 1e-6, runs, hits / (double)n);
    }
    for (int a = 0; a < 5; a++)
        clReleaseMemObject(buf[a]);
    clReleaseKernel(k);
    clReleaseProgram(prog);
    cl_devices_close(dev, ndev);
    bvh_free(&bvh);
    free(out);
    free(sec);
    free(segs);
    free(rays);
    free(tris);
    return status;
}
