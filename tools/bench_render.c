/* Renderer benchmark (`make bench`): paths per second on the default Cornell box
 * (512x512, 64 spp, max depth 8) and rays per second of the extend stage alone on a
 * generated scene of about one million triangles with incoherent (diffusely
 * bounced) rays, on the selected OpenCL device, with where the time goes measured by
 * OpenCL profiling events. Prints the median of several runs.
 *
 * Paths per second come from runs without profiling, as `spectrace render` runs
 * (profiling waits for each kernel before queueing the next); one more, profiled,
 * run gives the stage split (on CPU devices, where k_paths runs whole paths,
 * one line). The sphere runs take the stage kernels (RenderTestHooks stages), so
 * that the extend stage has its own time. The sphere's extend rays are all bounce rays but the
 * first of each path, a camera ray from the sphere's centre; camera rays are
 * coherent (one origin, neighbouring directions), so the figure that counts is the
 * bounce rays' alone: (rays of the depth-5 run - rays of a camera-only run) /
 * (extend time of the one - extend time of the other). Both are printed.
 * Usage: bench_render [RUNS] (SPECTRACE_DEVICE selects the device;
 * SPECTRACE_BENCH_ONLY=cornell or =sphere runs one of the two). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cl/cl_device.h"
#include "render/film.h"
#include "render/render.h"
#include "scene/scene.h"
#include "bench_util.h"
/* Not on the tools' include path: named from this folder. */
#include "../tests/render_fixture.h"

/* A closed displaced sphere of ~1M triangles seen from inside, diffuse 0.8 and
 * emissive, so every bounce sends rays in all directions. */
static void make_sphere_scene(Scene *s)
{
    sphere_scene_mesh(s, 500, 1000, 0.2f);
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
               int profile, int stages, RenderStats *st)
{
    GpuScene g;
    SptError e = {0};
    int rc = gpu_scene_build(&g, s, &e);
    if (!rc) {
        RenderSettings rs = test_settings(w, h, spp, depth, 0);
        rs.profile = profile;
        rs.test.stages = stages;
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
    double pps[16], stage[SPT_STAGES] = {0};
    static const char *names[SPT_STAGES] = {"generate", "extend",     "shade",
                                            "connect",  "accumulate", "paths"};
    for (int r = 0; do_cornell && r < runs && r < 16; r++) {
        RenderStats st;
        if (run(dev, &cb, 512, 512, 64, 8, 0, 0, &st))
            return 1;
        pps[r] = st.paths / st.seconds;
        printf("  cornell run %d: %.3f Mpaths/s (%.2f s; %.2f extend and %.2f shadow rays per "
               "path)\n",
               r + 1, pps[r] * 1e-6, st.seconds, (double)st.rays_extend / st.paths,
               (double)st.rays_shadow / st.paths);
    }
    if (do_cornell) {
        printf("cornell box 512x512 64 spp max depth 8: median %.3f Mpaths/s over %d runs\n",
               bench_median(pps, runs < 16 ? runs : 16) * 1e-6, runs);
        RenderStats st;
        if (run(dev, &cb, 512, 512, 64, 8, 1, 0, &st))
            return 1;
        double tot = 0;
        for (int k = 0; k < SPT_STAGES; k++)
            tot += (stage[k] = st.stage_seconds[k]);
        printf("  where the time goes (one more run, profiled: %.3f Mpaths/s with the waits):\n",
               st.paths / st.seconds * 1e-6);
        for (int k = 0; k < SPT_STAGES; k++)
            if (stage[k] > 0)
                printf("  %-10s %7.3f s  %5.1f%%\n", names[k], stage[k],
                       tot > 0 ? 100 * stage[k] / tot : 0);
        scene_free(&cb);
    }
    if (!do_sphere) {
        cl_device_list_free(&list);
        return 0;
    }
    Scene sp;
    make_sphere_scene(&sp);
    double all[16], bounce[16], camera[16];
    for (int r = 0; r < runs && r < 16; r++) {
        RenderStats st, cam;
        if (run(dev, &sp, 256, 256, 16, 5, 1, 1, &st) || run(dev, &sp, 256, 256, 16, 1, 1, 1, &cam))
            return 1;
        all[r] = st.rays_extend / st.stage_seconds[1];
        camera[r] = cam.rays_extend / cam.stage_seconds[1];
        bounce[r] = (double)(st.rays_extend - cam.rays_extend) /
                    (st.stage_seconds[1] - cam.stage_seconds[1]);
        printf("  sphere run %d: bounce rays %.3f Mrays/s (%llu in %.2f s of extend); all rays %.3f, "
               "camera rays alone %.3f\n",
               r + 1, bounce[r] * 1e-6, (unsigned long long)(st.rays_extend - cam.rays_extend),
               st.stage_seconds[1] - cam.stage_seconds[1], all[r] * 1e-6, camera[r] * 1e-6);
    }
    int nr = runs < 16 ? runs : 16;
    printf("displaced sphere %u triangles, incoherent (bounce) extend rays: median %.3f Mrays/s "
           "(all rays %.3f, camera rays %.3f)\n",
           sp.tri_count, bench_median(bounce, nr) * 1e-6, bench_median(all, nr) * 1e-6,
           bench_median(camera, nr) * 1e-6);
    scene_free(&sp);
    cl_device_list_free(&list);
    return 0;
}
