/* Instancing benchmark (`make bench`): a 20,000-triangle mesh placed N times
 * in a field (N = 1,000 and 50,000: 20 million and 1 billion triangles) as
 * two levels (src/accel/tlas_build.c, kernels/bvh/bvh_tlas.h), against the
 * same mesh flattened F times (one level, F = 250 by default: 5 million
 * triangles, what this machine's memory comfortably flattens). Reports the
 * build seconds, the bytes of each level, the process's peak memory, and
 * single-thread host traversal speed: camera rays of a 512 x 512 pinhole over
 * the field, and from each camera hit a diffuse-like bounce ray (incoherent).
 * The renderer does not trace two levels yet: these are the BVH's figures,
 * not paths per second.
 * Usage: bench_instances [N ...]  (default 1000 50000; F from
 * SPECTRACE_BENCH_FLAT, 0 to skip) */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>

#include "accel/tlas_build.h"

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
        free(xf);
        free(which);
    }

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
