/* Instancing benchmark (`make bench`): a 20,000-triangle mesh placed N times
 * in a field (N = 1,000 and 50,000: 20 million and 1 billion triangles) as
 * two levels (src/accel/tlas_build.c, kernels/bvh/bvh_tlas.h), against the
 * same mesh flattened F times (one level, F = 250 by default: 5 million
 * triangles, what this machine's memory comfortably flattens). Reports the
 * build seconds, the bytes of each level, the process's peak memory, and
 * single-thread host traversal speed: camera rays of a 512 x 512 pinhole over
 * the field, and from each camera hit a diffuse-like bounce ray (incoherent).
 * Then the renderer's figures: each field as a Scene (the mesh once, its
 * instances, a world-space emitter above) uploaded (gpu_scene_build: both
 * levels) and rendered at 512 x 512 on the default OpenCL device: build
 * seconds, the scene's device bytes, peak host memory and paths per second.
 * Usage: bench_instances [N ...]  (default 1000 50000; F from
 * SPECTRACE_BENCH_FLAT, 0 to skip; SPECTRACE_BENCH_RENDER_SPP samples per
 * pixel of the renders, default 2, 0 to skip them) */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>

#include "accel/tlas_build.h"
#include "cl/cl_device.h"
#include "render/gpu_scene.h"
#include "render/render.h"
/* Not on the tools' include path: named from this folder. */
#include "../tests/render_fixture.h"

#define WIDTH 512
#define SPACING 4.0 /* metres between neighbouring instances on the field's grid */

static uint64_t rng_state = 11;
static double rnd(void) { return bvh_gen_uniform(&rng_state); }

/* Instance i of n on a square grid with SPACING between neighbours, jittered,
 * turned about +y and scaled by 0.6 .. 1.4: rows of a 3x4 matrix. */
static void field_xf(uint32_t i, uint32_t n, float *m)
{
    uint32_t side = (uint32_t)ceil(sqrt((double)n));
    double a = 2.0 * M_PI * rnd(), s = 0.6 + 0.8 * rnd();
    double x = ((double)(i % side) - 0.5 * side + rnd() - 0.5) * SPACING;
    double z = ((double)(i / side) - 0.5 * side + rnd() - 0.5) * SPACING;
    const float r[12] = {(float)(s * cos(a)), 0, (float)(s * sin(a)), (float)x,
                         0, (float)s, 0, (float)s,
                         (float)(-s * sin(a)), 0, (float)(s * cos(a)), (float)z};
    memcpy(m, r, sizeof r);
}

/* The camera: above one corner of the field, looking across it and down. */
static void camera_ray(uint32_t n, int px, int py, vec3 *o, vec3 *d)
{
    double half = 0.5 * ceil(sqrt((double)n)) * SPACING;
    *o = v3((float)-half, (float)(0.15 * half + 3.0), (float)-half);
    vec3 f = v3(0.70710678f, -0.2f, 0.70710678f), r = v3(0.70710678f, 0.0f, -0.70710678f);
    vec3 u = v3(0.1f, 0.98f, 0.1f);
    float sx = (2.0f * (px + 0.5f) / WIDTH - 1.0f) * 0.6f, sy = (1.0f - 2.0f * (py + 0.5f) / WIDTH) * 0.6f;
    *d = v3(f.x + sx * r.x + sy * u.x, f.y + sx * r.y + sy * u.y, f.z + sx * r.z + sy * u.z);
}

/* A unit direction in the hemisphere of +-d's reverse (a bounce back toward
 * where the ray came from, uniformly). */
static vec3 bounce_dir(vec3 d)
{
    for (;;) {
        double x = 2 * rnd() - 1, y = 2 * rnd() - 1, z = 2 * rnd() - 1, l = x * x + y * y + z * z;
        if (l > 1.0 || l < 1e-6)
            continue;
        if (x * d.x + y * d.y + z * d.z > 0)
            x = -x, y = -y, z = -z;
        return v3((float)x, (float)y, (float)z);
    }
}

static double peak_rss_gib(void)
{
    struct rusage ru;
    getrusage(RUSAGE_SELF, &ru);
    return ru.ru_maxrss / (1024.0 * 1024.0);
}

/* Camera rays and their bounces through query (two levels when tl is set,
 * else the flat BVH): Mrays/s of each kind and the share of camera rays that
 * hit. */
static void trace(const Tlas *tl, const Bvh *flat, uint32_t n, double *cam_mrays, double *bounce_mrays,
                  double *hit_share)
{
    int nr = WIDTH * WIDTH, hits = 0;
    vec3 *bo = malloc((size_t)nr * sizeof *bo), *bd = malloc((size_t)nr * sizeof *bd);
    double t0 = spt_now();
    for (int i = 0; i < nr; i++) {
        vec3 o, d;
        camera_ray(n, i % WIDTH, i / WIDTH, &o, &d);
        float t = -1.0f;
        if (tl) {
            BvhInstHit h;
            if (bvh_tlas_intersect(tl->top, tl->inst, tl->nodes, tl->tris, o, d, 1e30f, &h))
                t = h.h.t;
        } else {
            BvhHit h;
            if (bvh_intersect(flat->nodes, flat->tri_data, o, d, 1e30f, &h))
                t = h.t;
        }
        if (t > 0.0f) {
            bo[hits] = v3(o.x + t * d.x, o.y + t * d.y, o.z + t * d.z);
            bd[hits++] = d;
        }
    }
    double t1 = spt_now();
    for (int i = 0; i < hits; i++)
        bd[i] = bounce_dir(bd[i]);
    double t2 = spt_now();
    volatile int sink = 0;
    for (int i = 0; i < hits; i++) {
        /* offset off the surface along the bounce */
        vec3 o = v3(bo[i].x + 1e-3f * bd[i].x, bo[i].y + 1e-3f * bd[i].y, bo[i].z + 1e-3f * bd[i].z);
        if (tl) {
            BvhInstHit h;
            sink += bvh_tlas_intersect(tl->top, tl->inst, tl->nodes, tl->tris, o, bd[i], 1e30f, &h);
        } else {
            BvhHit h;
            sink += bvh_intersect(flat->nodes, flat->tri_data, o, bd[i], 1e30f, &h);
        }
    }
    double t3 = spt_now();
    (void)sink;
    *cam_mrays = nr / (t1 - t0) * 1e-6;
    *bounce_mrays = hits ? hits / (t3 - t2) * 1e-6 : 0.0;
    *hit_share = (double)hits / nr;
    free(bo);
    free(bd);
}

/* The field of n instances (transforms xf) of the nt-triangle mesh tris as
 * a Scene: the mesh (diffuse grey) placed by reference, under a world-space
 * emitting square over the whole field, seen by camera_ray's camera. */
static void field_scene(Scene *s, const float *tris, uint32_t nt, const float *xf, uint32_t n)
{
    memset(s, 0, sizeof *s);
    double half = 0.5 * ceil(sqrt((double)n)) * SPACING + SPACING;
    uint32_t tc = nt + 2;
    s->tri_count = tc;
    s->vertex_count = 3 * tc;
    s->tri_pos = malloc((size_t)tc * 9 * sizeof(float));
    s->tri_vidx = malloc((size_t)tc * 3 * sizeof(uint32_t));
    s->tri_mat = calloc(tc, sizeof(uint32_t));
    s->vtx_normal = calloc((size_t)tc * 9, sizeof(float));
    s->vtx_uv = calloc((size_t)tc * 6, sizeof(float));
    for (uint32_t i = 0; i < 3 * tc; i++)
        s->tri_vidx[i] = i;
    /* The emitter at y = 40, facing down (its two triangles first: the
     * world's, before the mesh's). */
    const float h = (float)half, y = 40.0f;
    const float quad[18] = {-h, y, -h, h, y, h, h, y, -h, -h, y, -h, -h, y, h, h, y, h};
    memcpy(s->tri_pos, quad, sizeof quad);
    s->tri_mat[0] = s->tri_mat[1] = 1;
    memcpy(s->tri_pos + 18, tris, (size_t)nt * 9 * sizeof(float));
    s->material_count = 2;
    s->materials = malloc(2 * sizeof(SceneMaterial));
    scene_material_default(&s->materials[0]);
    scene_material_default(&s->materials[1]);
    for (int k = 0; k < 3; k++) {
        s->materials[0].base_color[k] = 0.6f;
        s->materials[0].metallic = 0.0f;
        s->materials[1].base_color[k] = 0.0f;
        s->materials[1].emissive[k] = 1.0f;
    }
    s->mesh_count = 1;
    s->mesh_tri_count = malloc(sizeof(uint32_t));
    s->mesh_tri_count[0] = nt;
    s->inst_count = n;
    s->inst_mesh = calloc(n, sizeof(uint32_t));
    s->inst_xf = malloc((size_t)n * 12 * sizeof(float));
    memcpy(s->inst_xf, xf, (size_t)n * 12 * sizeof(float));
    /* The bounds from the field (placing every vertex would cost n x nt). */
    const float lo[3] = {-h, 0.0f, -h}, hi[3] = {h, y, h};
    memcpy(s->bounds_min, lo, sizeof lo);
    memcpy(s->bounds_max, hi, sizeof hi);
    /* camera_ray's camera: its centre ray as forward, its image's x axis as
     * right, up square to both (camera_ray's up is nearly so). */
    vec3 o, d;
    camera_ray(n, WIDTH / 2, WIDTH / 2, &o, &d);
    const double f[3] = {0.70710678, -0.2, 0.70710678}, r[3] = {0.70710678, 0.0, -0.70710678};
    double lf = sqrt(f[0] * f[0] + f[1] * f[1] + f[2] * f[2]);
    const double u[3] = {r[1] * f[2] - r[2] * f[1], r[2] * f[0] - r[0] * f[2], r[0] * f[1] - r[1] * f[0]};
    double lu = sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
    SceneCamera *c = &s->camera;
    c->position[0] = o.x;
    c->position[1] = o.y;
    c->position[2] = o.z;
    for (int k = 0; k < 3; k++) {
        c->forward[k] = (float)(f[k] / lf);
        c->right[k] = (float)r[k];
        c->up[k] = (float)(u[k] / lu);
    }
    c->yfov = (float)(2.0 * atan(0.6 / lf));
    c->aspect = 1.0f;
}

/* Renders the field of n instances at WIDTH x WIDTH, spp samples per pixel,
 * on dev; prints the upload's build seconds and device bytes, the peak
 * host memory and paths per second. Returns 0 or 1. */
static int render_field(const ClDeviceInfo *dev, const float *tris, uint32_t nt, const float *xf,
                        uint32_t n, int spp)
{
    Scene s;
    field_scene(&s, tris, nt, xf, n);
    GpuScene g;
    SptError e = {0};
    double t0 = spt_now();
    int rc = gpu_scene_build(&g, &s, &e);
    double build = spt_now() - t0;
    RenderStats st;
    if (!rc) {
        RenderSettings rs = test_settings(WIDTH, WIDTH, spp, 8, 0);
        Film f;
        film_init(&f, WIDTH, WIDTH);
        /* The second of two runs: the first compiles the kernels. */
        for (int run = 0; run < 2 && !rc; run++) {
            film_clear(&f);
            rc = render_device(dev, &g, &s.camera, &rs, &f, &st, &e);
        }
        film_free(&f);
        if (!rc)
            printf("render, %u instances (%.3g triangles): upload built in %.3f s, %.2f MiB of "
                   "scene on the device; %dx%d %d spp max depth 8: %.3f Mpaths/s (%.2f s, %.2f "
                   "extend rays per path, %.3f Mrays/s); peak memory %.2f GiB\n",
                   n, (double)g.tlas.stats.instanced_tris, build, gpu_scene_bytes(&g) / 1048576.0,
                   WIDTH, WIDTH, spp, st.paths / st.seconds * 1e-6, st.seconds,
                   (double)st.rays_extend / st.paths, st.rays_extend / st.seconds * 1e-6,
                   peak_rss_gib());
        gpu_scene_free(&g);
    }
    scene_free(&s);
    if (rc)
        fprintf(stderr, "bench_instances: %s\n", e.msg);
    return rc ? 1 : 0;
}

int main(int argc, char **argv)
{
    uint32_t counts[8] = {1000, 50000};
    int nc = 2;
    if (argc > 1) {
        nc = 0;
        for (int i = 1; i < argc && nc < 8; i++)
            counts[nc++] = (uint32_t)strtod(argv[i], NULL);
    }
    const char *fe = getenv("SPECTRACE_BENCH_FLAT");
    uint32_t flat_n = fe ? (uint32_t)strtod(fe, NULL) : 250;

    const char *se = getenv("SPECTRACE_BENCH_RENDER_SPP");
    int spp = se ? atoi(se) : 2;
    ClDeviceList devices;
    const ClDeviceInfo *dev = NULL;
    if (spp > 0) {
        SptError de = {0};
        int sel[64], nsel;
        if (cl_device_list(&devices, &de) || cl_device_select(&devices, NULL, sel, &nsel, &de)) {
            fprintf(stderr, "bench_instances: %s\n", de.msg);
            return 1;
        }
        dev = &devices.devices[sel[0]];
        printf("device: %s (%s)\n", dev->name, dev->platform_name);
    }

    uint32_t nt;
    const float c[3] = {0, 1, 0};
    double t0 = spt_now();
    float *mesh_tris = bvh_gen_sphere(100, 100, 1.0f, c, 0.3f, &nt);
    Bvh mesh;
    SptError e = {0};
    if (bvh_build(&mesh, mesh_tris, nt, &e)) {
        fprintf(stderr, "bench_instances: %s\n", e.msg);
        return 1;
    }
    printf("mesh: %u triangles, BVH %u nodes, %.1f bytes/triangle, built in %.3f s (generated and "
           "built %.3f s)\n",
           mesh.prim_count, mesh.node_count, mesh.stats.bytes_per_tri, mesh.stats.build_seconds,
           spt_now() - t0);

    for (int k = 0; k < nc; k++) {
        uint32_t n = counts[k];
        rng_state = 11;
        float *xf = malloc((size_t)n * 12 * sizeof *xf);
        uint32_t *which = calloc(n, sizeof *which);
        for (uint32_t i = 0; i < n; i++)
            field_xf(i, n, xf + 12 * (size_t)i);
        Tlas tl;
        if (tlas_build(&tl, &mesh, NULL, 1, xf, which, n, &e)) {
            fprintf(stderr, "bench_instances: %s\n", e.msg);
            return 1;
        }
        double cam, bounce, share;
        trace(&tl, NULL, n, &cam, &bounce, &share);
        printf("two levels, %u instances (%.3g triangles): top level built in %.3f s, %.2f MiB "
               "(%u nodes, %u instances), bottom %.2f MiB; camera rays %.3f Mrays/s (%.0f%% hit), "
               "bounces %.3f Mrays/s, one thread; peak memory %.2f GiB\n",
               n, (double)tl.stats.instanced_tris, tl.stats.build_seconds,
               tl.stats.top_bytes / 1048576.0, tl.top_count, tl.inst_count,
               tl.stats.bottom_bytes / 1048576.0, cam, 100.0 * share, bounce, peak_rss_gib());
        tlas_free(&tl);
        if (dev && render_field(dev, mesh_tris, nt, xf, n, spp))
            return 1;
        free(xf);
        free(which);
    }
    if (dev)
        cl_device_list_free(&devices);

    if (flat_n) {
        rng_state = 11;
        size_t total = (size_t)flat_n * nt;
        float *flat = malloc(total * 9 * sizeof *flat), xf[12];
        float *xfs = malloc((size_t)flat_n * 12 * sizeof *xfs);
        uint32_t *which = calloc(flat_n, sizeof *which);
        for (uint32_t i = 0; i < flat_n; i++) {
            field_xf(i, flat_n, xf);
            memcpy(xfs + 12 * (size_t)i, xf, sizeof xf);
            for (uint32_t t = 0; t < nt * 3; t++) {
                const float *p = mesh_tris + 3 * (size_t)t;
                for (int r = 0; r < 3; r++)
                    flat[((size_t)i * nt * 3 + t) * 3 + r] =
                        (float)((double)xf[4 * r] * p[0] + (double)xf[4 * r + 1] * p[1] +
                                (double)xf[4 * r + 2] * p[2] + (double)xf[4 * r + 3]);
            }
        }
        Bvh fb;
        if (bvh_build(&fb, flat, (uint32_t)total, &e)) {
            fprintf(stderr, "bench_instances: %s\n", e.msg);
            return 1;
        }
        free(flat);
        double cam, bounce, share;
        trace(NULL, &fb, flat_n, &cam, &bounce, &share);
        printf("flattened, %u instances (%.3g triangles): built in %.3f s, %.2f MiB; camera rays "
               "%.3f Mrays/s (%.0f%% hit), bounces %.3f Mrays/s, one thread\n",
               flat_n, (double)fb.prim_count, fb.stats.build_seconds,
               (fb.node_count * sizeof(BvhNode) + fb.tri_data_bytes) / 1048576.0, cam, 100.0 * share,
               bounce);
        Tlas tl;
        if (tlas_build(&tl, &mesh, NULL, 1, xfs, which, flat_n, &e)) {
            fprintf(stderr, "bench_instances: %s\n", e.msg);
            return 1;
        }
        trace(&tl, NULL, flat_n, &cam, &bounce, &share);
        printf("two levels, the same %u instances: %.2f MiB; camera rays %.3f Mrays/s (%.0f%% hit), "
               "bounces %.3f Mrays/s, one thread\n",
               flat_n, (tl.stats.top_bytes + tl.stats.bottom_bytes) / 1048576.0, cam, 100.0 * share,
               bounce);
        tlas_free(&tl);
        bvh_free(&fb);
        free(xfs);
        free(which);
    }
    bvh_free(&mesh);
    free(mesh_tris);
    return 0;
}
