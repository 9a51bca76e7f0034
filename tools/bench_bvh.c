/* BVH benchmark (`make bench`): build speed and SAH quality on a 1M-triangle
 * displaced sphere (binned against the exact full-sweep builder), memory per
 * triangle, and single-thread host traversal speed for incoherent rays on that
 * mesh and on the Stanford bunny (when /work/shared/data or $SPECTRACE_BUNNY
 * has it). Prints medians of several runs; the build also as CPU time of the
 * building thread, which on a shared machine is what one core spent.
 * Usage: bench_bvh [RUNS] [SWEEP_STACKS SWEEP_SLICES] */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "accel/bvh_build.h"
#include "bench_util.h"

static uint64_t rng_state = 7;
static double rnd(void) { return bvh_gen_uniform(&rng_state); }

/* Triangles of an OBJ file ("v x y z", "f a b c ..." fanned, 1-based or negative
 * indices, "a/b/c" forms). Returns NULL when the file cannot be read. */
static float *read_obj(const char *path, uint32_t *tri_count)
{
    FILE *f = fopen(path, "r");
    if (!f)
        return NULL;
    size_t nv = 0, cv = 1024, nt = 0, ct = 1024;
    float *v = malloc(cv * 3 * sizeof *v), *t = malloc(ct * 9 * sizeof *t);
    char line[4096];
    while (fgets(line, sizeof line, f)) {
        if (line[0] == 'v' && line[1] == ' ') {
            if (nv == cv)
                v = realloc(v, (cv *= 2) * 3 * sizeof *v);
            if (sscanf(line + 2, "%f %f %f", &v[nv * 3], &v[nv * 3 + 1], &v[nv * 3 + 2]) == 3)
                nv++;
        } else if (line[0] == 'f' && line[1] == ' ') {
            long idx[64];
            int n = 0;
            char *p = line + 2, *end;
            while (n < 64) {
                long k = strtol(p, &end, 10);
                if (end == p)
                    break;
                idx[n++] = k < 0 ? (long)nv + k : k - 1;
                p = end;
                while (*p && *p != ' ' && *p != '\t')
                    p++;
            }
            for (int i = 1; i + 1 < n; i++) {
                long a = idx[0], b = idx[i], c = idx[i + 1];
                if (a < 0 || b < 0 || c < 0 || (size_t)a >= nv || (size_t)b >= nv ||
                    (size_t)c >= nv)
                    continue;
                if (nt == ct)
                    t = realloc(t, (ct *= 2) * 9 * sizeof *t);
                memcpy(t + nt * 9, v + a * 3, 3 * sizeof *t);
                memcpy(t + nt * 9 + 3, v + b * 3, 3 * sizeof *t);
                memcpy(t + nt * 9 + 6, v + c * 3, 3 * sizeof *t);
                nt++;
            }
        }
    }
    fclose(f);
    free(v);
    *tri_count = (uint32_t)nt;
    return t;
}

/* CPU seconds used by this thread: what one core spent, whatever else the
 * (shared) machine was running meanwhile. */
static double thread_cpu(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

/* Median build seconds (wall clock) over runs builds, and in *cpu the median
 * CPU seconds of this thread; leaves the last build in bvh. */
static double time_build(Bvh *bvh, const float *t, uint32_t n, const BvhOptions *o, int runs,
                         double *cpu)
{
    double s[32], c[32];
    SptError e;
    for (int r = 0; r < runs; r++) {
        if (r)
            bvh_free(bvh);
        double c0 = thread_cpu();
        if (bvh_build_ex(bvh, t, n, o, &e)) {
            fprintf(stderr, "bench_bvh: %s\n", e.msg);
            exit(1);
        }
        c[r] = thread_cpu() - c0;
        s[r] = bvh->stats.build_seconds;
    }
    if (cpu)
        *cpu = bench_median(c, runs);
    return bench_median(s, runs);
}

/* Incoherent rays: origins uniform in the mesh bounds, uniform directions.
 * Prints median Mrays/s of closest-hit and of any-hit traversal. */
static void bench_rays(const char *name, const Bvh *bvh, int runs, int nrays)
{
    float lo[3], hi[3];
    bvh_bounds(bvh, lo, hi);
    vec3 *org = malloc(nrays * sizeof *org), *dir = malloc(nrays * sizeof *dir);
    for (int i = 0; i < nrays; i++) {
        org[i] = v3(lo[0] + (hi[0] - lo[0]) * (float)rnd(), lo[1] + (hi[1] - lo[1]) * (float)rnd(),
                    lo[2] + (hi[2] - lo[2]) * (float)rnd());
        double z = 2 * rnd() - 1, phi = 2 * M_PI * rnd(), s = sqrt(1 - z * z);
        dir[i] = v3((float)(s * cos(phi)), (float)(s * sin(phi)), (float)z);
    }
    double closest[32], any[32];
    long hits = 0;
    for (int r = 0; r < runs; r++) {
        hits = 0;
        double t0 = spt_now();
        for (int i = 0; i < nrays; i++) {
            BvhHit h;
            hits += bvh_intersect(bvh->nodes, bvh->tri_data, org[i], dir[i], 1e30f, &h);
        }
        double t1 = spt_now();
        for (int i = 0; i < nrays; i++)
            hits += bvh_occluded(bvh->nodes, bvh->tri_data, org[i], dir[i], 1e30f);
        double t2 = spt_now();
        closest[r] = nrays / (t1 - t0) * 1e-6;
        any[r] = nrays / (t2 - t1) * 1e-6;
    }
    printf("  %s: host traversal, 1 thread, %d incoherent rays (%.0f%% hit): closest %.2f "
           "Mrays/s, any-hit %.2f Mrays/s\n",
           name, nrays, 50.0 * hits / nrays, bench_median(closest, runs), bench_median(any, runs));
    free(org);
    free(dir);
}

static void print_tree(const char *label, const Bvh *b)
{
    const BvhStats *s = &b->stats;
    printf("  %s: %u %d-wide nodes, %u leaves, depth %u, leaf size avg %.2f max %u, SAH cost "
           "%.2f (binary tree), %.1f bytes/triangle (nodes + leaf blocks; +8 for "
           "prim_index and tri_leaf)\n",
           label, s->node_count, BVH_WIDTH, s->leaf_count, s->max_depth, s->avg_leaf_size, s->max_leaf_size,
           s->sah_cost, s->bytes_per_tri);
}

int main(int argc, char **argv)
{
    int runs = argc > 1 ? atoi(argv[1]) : 5;
    uint32_t sw_stacks = argc > 3 ? (uint32_t)atoi(argv[2]) : 250;
    uint32_t sw_slices = argc > 3 ? (uint32_t)atoi(argv[3]) : 500;
    if (runs < 1 || runs > 32)
        runs = 5;
    const float c[3] = {0, 0, 0};
    uint32_t n;
    float *mesh = bvh_gen_sphere(500, 1000, 1.0f, c, 0.3f, &n);
    BvhOptions o = bvh_default_options();
    /* tuning knobs: BVH_BINS, BVH_MAX_LEAF, BVH_COST_NODE (cost_tri stays 1) */
    if (getenv("BVH_BINS"))
        o.bins = atoi(getenv("BVH_BINS"));
    if (getenv("BVH_MAX_LEAF"))
        o.max_leaf = atoi(getenv("BVH_MAX_LEAF"));
    if (getenv("BVH_COST_NODE"))
        o.cost_node = (float)atof(getenv("BVH_COST_NODE"));
    Bvh bvh;
    double cpu;
    o.threads = 1;
    double sec = time_build(&bvh, mesh, n, &o, runs, &cpu);
    printf("  displaced sphere, %u triangles: binned build (%d bins, leaf <= %d, node cost %.2f) median %.3f s "
           "= %.2f Mtriangles/s (1 thread, %d runs); CPU time of the thread: median %.3f s = %.2f "
           "Mtriangles/s\n",
           n, o.bins, o.max_leaf, o.cost_node, sec, n / sec * 1e-6, runs, cpu, n / cpu * 1e-6);
    /* The default: the root's subtrees on the CPUs online (the same tree). */
    bvh_free(&bvh);
    o.threads = 0;
    double psec = time_build(&bvh, mesh, n, &o, runs, NULL);
    printf("  the same on %u threads (the default: the CPUs online, at most %d): median %.3f s = %.2f "
           "Mtriangles/s (%.2fx)\n",
           bvh.stats.build_threads, BVH_WIDTH, psec, n / psec * 1e-6, sec / psec);
    print_tree("binned tree", &bvh);

    /* Quality reference: the exact SAH sweep (slow: one run). */
    uint32_t sn;
    float *smesh = bvh_gen_sphere(sw_stacks, sw_slices, 1.0f, c, 0.3f, &sn);
    Bvh bin_s, sweep;
    time_build(&bin_s, smesh, sn, &o, 1, NULL);
    BvhOptions so = o;
    so.full_sweep = 1;
    double ssec = time_build(&sweep, smesh, sn, &so, 1, NULL);
    printf("  SAH cost on %u triangles: binned %.3f, full sweep %.3f (%.2f s): binned is "
           "%+.1f%%\n",
           sn, bin_s.stats.sah_cost, sweep.stats.sah_cost, ssec,
           100.0 * (bin_s.stats.sah_cost / sweep.stats.sah_cost - 1.0));
    bvh_free(&bin_s);
    bvh_free(&sweep);
    free(smesh);

    bench_rays("displaced sphere 1M", &bvh, runs > 3 ? 3 : runs, 500000);
    bvh_free(&bvh);
    free(mesh);

    const char *bunny = getenv("SPECTRACE_BUNNY");
    if (!bunny)
        bunny = "/work/shared/data/stanford-bunny.obj";
    float *bt = read_obj(bunny, &n);
    if (!bt || n == 0) {
        printf("  bunny: %s not found, skipped\n", bunny);
    } else {
        sec = time_build(&bvh, bt, n, &o, runs, NULL);
        printf("  bunny, %u triangles: build median %.3f s\n", n, sec);
        print_tree("bunny tree", &bvh);
        bench_rays("bunny", &bvh, runs > 3 ? 3 : runs, 500000);
        bvh_free(&bvh);
    }
    free(bt);
    return 0;
}
