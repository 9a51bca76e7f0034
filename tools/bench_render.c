/* Renderer benchmark (`make bench`): paths per second on the default Cornell box
 * (512x512, 64 spp, max depth 8) and rays per second of the extend stage alone on a
 * generated scene of about one million triangles with incoherent (diffusely
 * bounced) rays, on the selected OpenCL device, with where the time goes measured by
 * OpenCL profiling events. Prints the median of several runs.
 * Usage: bench_render [RUNS] (SPECTRACE_DEVICE selects the device;
 * SPECTRACE_BENCH_ONLY=cornell or =sphere runs one of the two). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cl_device.h"
#include "film.h"
#include "render.h"
#include "scene.h"

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

static double median(double *v, int n)
{
    qsort(v, (size_t)n, sizeof *v, cmp_double);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

/* A closed displaced sphere of ~1M triangles seen from inside, diffuse 0.8 and
 * emissive, so every bounce sends rays in all directions. */
static void make_sphere_scene(Scene *s)
{
    memset(s, 0, sizeof *s);
    uint32_t n = 0;
    const float c[3] = {0, 0, 0};
    s->tri_pos = bvh_gen_sphere(500, 1000, 1.0f, c, 0.2f, &n);
    s->tri_count = n;
    s->vertex_count = 3 * n;
    s->tri_vidx = malloc(sizeof(uint32_t) * 3 * n);
    s->tri_mat = calloc(n, sizeof(uint32_t));
    s->vtx_normal = calloc((size_t)3 * 3 * n, sizeof(float));
    s->vtx_uv = calloc((size_t)2 * 3 * n, sizeof(float));
    for (uint32_t i = 0; i < 3 * n; i++)
        s->tri_vidx[i] = i;
    s->material_count = 1;
    s->materials = calloc(1, sizeof(SceneMaterial));
    scene_material_default(&s->materials[0]);
    for (int k = 0; k < 3; k++) {
        s->materials[0].base_color[k] = 0.8f;
        s->materials[0].emissive[k] = 1.0f;
    }
    SceneCamera *cam = &s->camera;
    memset(cam, 0, sizeof *cam);
    cam->forward[2] = -1;
    cam->up[1] = 1;
    cam->right[0] = 1;
    cam->yfov = 1.0f;
    cam->aspect = 1.0f;
    scene_update_bounds(s);
}

static int run(const ClDeviceInfo *dev, const Scene *s, int w, int h, int spp, int depth,
               RenderStats *st)
{
    GpuScene g;
    SptError e = {0};
    int rc = gpu_scene_build(&g, s, &e);
    if (!rc) {
        RenderSettings rs;
        memset(&rs, 0, sizeof rs);
        rs.width = w;
        rs.height = h;
        rs.spp = spp;
        rs.max_depth = depth;
        rs.profile = 1;
        Film f;
        film_init(&f, w, h);
        rc = render_device(dev, &g, &s->camera, &rs, &f, st, &e);
        film_free(&f);
        gpu_scene_free(&g);
    }
    if (rc)
        fprintf(stderr, "error: %s\n", e.msg);
    return rc;
}

int main(int argc, char **argv)
{
    int runs = argc > 1 ? atoi(argv[1]) : 3;
    if (runs < 1)
        runs = 1;
    SptError e = {0};
    ClDeviceList list;
    int sel[64], nsel;
    if (cl_device_list(&list, &e) || cl_device_select(&list, NULL, sel, &nsel, &e)) {
        fprintf(stderr, "error: %s\n", e.msg);
        return 1;
    }
    const ClDeviceInfo *dev = &list.devices[sel[0]];
    printf("device: %s (%s)\n", dev->name, dev->platform_name);

    const char *only = getenv("SPECTRACE_BENCH_ONLY");
    int do_cornell = !only || !strcmp(only, "cornell"), do_sphere = !only || !strcmp(only, "sphere");
    Scene cb;
    if (do_cornell && scene_load_gltf(&cb, "scenes/cornell_box.gltf", &e)) {
        fprintf(stderr, "error: %s\n", e.msg);
        return 1;
    }
    double pps[16], stage[5] = {0};
    static const char *names[5] = {"generate", "extend", "shade", "connect", "accumulate"};
    for (int r = 0; do_cornell && r < runs && r < 16; r++) {
        RenderStats st;
        if (run(dev, &cb, 512, 512, 64, 8, &st))
            return 1;
        pps[r] = st.paths / st.seconds;
        for (int k = 0; k < 5; k++)
            stage[k] += st.stage_seconds[k] / runs;
        printf("  cornell run %d: %.3f Mpaths/s (%.2f s; %.2f extend and %.2f shadow rays per "
               "path)\n",
               r + 1, pps[r] * 1e-6, st.seconds, (double)st.rays_extend / st.paths,
               (double)st.rays_shadow / st.paths);
    }
    if (do_cornell) {
        double tot = 0;
        for (int k = 0; k < 5; k++)
            tot += stage[k];
        printf("cornell box 512x512 64 spp max depth 8: median %.3f Mpaths/s over %d runs\n",
               median(pps, runs < 16 ? runs : 16) * 1e-6, runs);
        for (int k = 0; k < 5; k++)
            printf("  %-10s %7.3f s  %5.1f%%\n", names[k], stage[k], tot > 0 ? 100 * stage[k] / tot : 0);
        scene_free(&cb);
    }
    if (!do_sphere) {
        cl_device_list_free(&list);
        return 0;
    }
    Scene sp;
    make_sphere_scene(&sp);
    double rps[16];
    for (int r = 0; r < runs && r < 16; r++) {
        RenderStats st;
        if (run(dev, &sp, 256, 256, 4, 5, &st))
            return 1;
        rps[r] = st.rays_extend / st.stage_seconds[1];
        printf("  sphere run %d: %.3f Mrays/s extend (%llu rays in %.2f s of extend)\n", r + 1,
               rps[r] * 1e-6, (unsigned long long)st.rays_extend, st.stage_seconds[1]);
    }
    printf("displaced sphere %u triangles, incoherent extend rays: median %.3f Mrays/s\n",
           sp.tri_count, median(rps, runs < 16 ? runs : 16) * 1e-6);
    scene_free(&sp);
    cl_device_list_free(&list);
    return 0;
}
