/* The renderer on PoCL against analytic scenes (tests/data/scenes/README.md):
 * the white furnace, a Lambertian plane under a square emitter, determinism, the
 * NaN guard, and the Cornell box against Mitsuba 3's image means. */
#include "test_util.h"
#include "test_render_util.h"

#include <stdlib.h>
#include <string.h>

#include <math.h>
#include <unistd.h>

#include "cl/cl_device.h"
#include "io/exr.h"
#include "render/film.h"
#include "film_test.h"
#include "render/render.h"
#include "render/wavefront.h"
#include "scene/scene.h"
#include "color/spd.h"
#include "spectrum/cie_data.h"

/* Closed diffuse enclosure, albedo a = 0.8, emitted radiance 1: the radiance
 * is sum_{k<D} a^k (Le / (1 - a) = 5 unlimited). */
TEST(test_white_furnace)
{
    const double a = 0.8;
    const int depths[] = {1, 2, 3, 8, -1};
    /* Quick runs: the bounded depths up to 3 (unlimited depth is the slow case). */
    size_t ndepths = test_quick() ? 3 : sizeof depths / sizeof depths[0];
    for (size_t k = 0; k < ndepths; k++) {
        int d = depths[k];
        double want = d > 0 ? (1.0 - pow(a, d)) / (1.0 - a) : 1.0 / (1.0 - a);
        Film f;
        RenderStats st;
        assert_int_equal(render_gltf("tests/data/scenes/furnace.gltf", 24, 24, 64, d, 1, &f, &st), 0);
        double m[3];
        film_mean(&f, m);
        printf("furnace depth %d: mean (%.5f, %.5f, %.5f), expected %.5f\n", d, m[0], m[1], m[2], want);
        for (int c = 0; c < 3; c++)
            assert_close_rel(m[c], want, 0.01);
        assert_int_equal(st.nan_dropped, 0);
        film_free(&f);
    }
}

/* Flat spectral tables (reflectance 0.8, emission 1 at every wavelength): linear
 * sRGB of equal-energy white E computed from the CIE tables, times 1 / (1 - a). */
TEST(test_white_furnace_spectral)
{
    skip_if_quick();
    /* XYZ of the flat spectrum (sum cmf / sum ybar) -> linear sRGB, independently
     * of the renderer: from the CIE 1 nm table sums (colour-science) and the sRGB
     * matrix of docs/architecture.md. */
    const double X = 1.00008, Y = 1.0, Z = 1.00033;
    double E[3] = {3.2406 * X - 1.5372 * Y - 0.4986 * Z, -0.9689 * X + 1.8758 * Y + 0.0415 * Z,
                   0.0557 * X - 0.2040 * Y + 1.0570 * Z};
    Film f;
    RenderStats st;
    assert_int_equal(render_gltf("tests/data/scenes/furnace_spectral.gltf", 24, 24, 128, -1, 2, &f, &st), 0);
    double m[3];
    film_mean(&f, m);
    printf("spectral furnace: mean (%.4f, %.4f, %.4f), expected (%.4f, %.4f, %.4f)\n", m[0], m[1],
           m[2], E[0] * 5, E[1] * 5, E[2] * 5);
    for (int c = 0; c < 3; c++)
        assert_close_rel(m[c], 5.0 * E[c], 0.01);
    film_free(&f);
}

/* View factor from a point to a parallel a x b rectangle having the point under
 * a corner, at distance h. */
static double view_factor_corner(double a, double b, double h)
{
    double A = a / h, B = b / h;
    return (A / sqrt(1 + A * A) * atan(B / sqrt(1 + A * A)) +
            B / sqrt(1 + B * B) * atan(A / sqrt(1 + B * B))) / (2 * M_PI);
}

/* A Lambertian plane (rho 0.5) 1 m under a 10 m square emitter of radiance 2:
 * L = rho E / pi = rho L0 F, F the view factor, averaged over the framed region. */
TEST(test_plane_irradiance)
{
    const double rho = 0.5, L0 = 2.0, s = 5.0, h = 1.0, w = 0.5 * tan(5.0 * M_PI / 180.0);
    double fsum = 0;
    const int n = 64;
    for (int i = 0; i < n; i++)
        for (int j = 0; j < n; j++) {
            double x = -w + (i + 0.5) * 2 * w / n, z = -w + (j + 0.5) * 2 * w / n;
            fsum += view_factor_corner(s - x, s - z, h) + view_factor_corner(s + x, s - z, h) +
                    view_factor_corner(s - x, s + z, h) + view_factor_corner(s + x, s + z, h);
        }
    double want = rho * L0 * fsum / (n * n);
    Film f;
    RenderStats st;
    assert_int_equal(render_gltf("tests/data/scenes/plane_irradiance.gltf", 16, 16, 64, -1, 3, &f, &st), 0);
    double m[3];
    film_mean(&f, m);
    printf("plane: mean (%.5f, %.5f, %.5f), expected %.5f\n", m[0], m[1], m[2], want);
    for (int c = 0; c < 3; c++)
        assert_close_rel(m[c], want, 0.01);
    film_free(&f);
    /* Depth 1: the camera sees only the plane, which does not emit. */
    assert_int_equal(render_gltf("tests/data/scenes/plane_irradiance.gltf", 8, 8, 4, 1, 3, &f, &st), 0);
    film_mean(&f, m);
    for (int c = 0; c < 3; c++)
        assert_close(m[c], 0.0, 1e-9);
    film_free(&f);
}

/* The GPU code path (one ray per work-item, one triangle at a time in a leaf),
 * forced on this CPU device with the kernel_path test hook, gives the film of
 * the CPU path (paired rays, the leaf's SIMD test): both find the same closest
 * hits with the same arithmetic, so the films agree within assert_same_film's
 * 1e-4 (on PoCL they are identical bit for bit). The CPU path runs whole paths
 * in k_paths; in the stage kernels (the stages hook) it gives the same film.
 * The GPU path also runs under Oclgrind, a GPU to spectrace (make
 * check-kernels). */
TEST(test_gpu_path_on_cpu_device)
{
    skip_if_quick();
    Film a, b, c;
    RenderStats st;
    g_hooks.kernel_path = SPT_KERNEL_PATH_GPU;
    int rc = render_gltf("scenes/cornell_box.gltf", 32, 32, 16, -1, 9, &a, &st);
    g_hooks.kernel_path = SPT_KERNEL_PATH_CPU;
    int rc2 = render_gltf("scenes/cornell_box.gltf", 32, 32, 16, -1, 9, &b, &st);
    g_hooks.stages = 1;
    int rc3 = render_gltf("scenes/cornell_box.gltf", 32, 32, 16, -1, 9, &c, &st);
    g_hooks.stages = 0;
    /* k_paths's rays paired and one by one (the device picks one of the two;
     * src/render/wavefront.c, kernel_path_for): the same hits and arithmetic,
     * so the same film bit for bit. */
    Film d, f;
    g_hooks.rays = SPT_RAYS_PAIRED;
    int rc4 = render_gltf("scenes/cornell_box.gltf", 32, 32, 16, -1, 9, &d, &st);
    g_hooks.rays = SPT_RAYS_ONE_BY_ONE;
    int rc5 = render_gltf("scenes/cornell_box.gltf", 32, 32, 16, -1, 9, &f, &st);
    g_hooks.rays = SPT_RAYS_DEVICE;
    g_hooks.kernel_path = SPT_KERNEL_PATH_DEVICE;
    assert_int_equal(rc, 0);
    assert_int_equal(rc2, 0);
    assert_int_equal(rc3, 0);
    assert_int_equal(rc4, 0);
    assert_int_equal(rc5, 0);
    assert_same_film(&a, &b);
    assert_same_film(&c, &b);
    assert_same_film(&d, &b);
    assert_memory_equal(d.xyz, f.xyz, 32 * 32 * 3 * sizeof(double));
    film_free(&a);
    film_free(&b);
    film_free(&c);
    film_free(&d);
    film_free(&f);
}

/* The traversal's step prefetch (src/render/wavefront.c,
 * wavefront_step_prefetch): on for a tree above a quarter of the device's
 * cache, a cache reported above 32 MiB (a server package's) counted as 32
 * MiB; on when the cache is unknown. The figures of docs/performance.md,
 * "What sets the speed": the 1M-triangle mesh's 24 MB tree and the 7 MB one
 * of 300,000 triangles on a Xeon reporting 480 MiB. */
TEST(test_step_prefetch_rule)
{
    const double mib = 1024.0 * 1024.0;
    assert_true(wavefront_step_prefetch(24e6, 480.0 * mib));
    assert_false(wavefront_step_prefetch(7e6, 480.0 * mib));
    assert_true(wavefront_step_prefetch(7e6, 16.0 * mib));
    assert_false(wavefront_step_prefetch(3e6, 16.0 * mib));
    assert_true(wavefront_step_prefetch(1e6, 0.0));
}

/* Whether wavefront_options builds the program without the texture code
 * (-DSPT_TEXTURES=0) and without the layers' (-DSPT_LAYERS=0). */
static void assert_leaves_out(const GpuScene *g, const RenderSettings *rs, int textures, int layers)
{
    char o[256];
    wavefront_options(device, g, rs, o, sizeof o);
    assert_int_equal(strstr(o, "-DSPT_TEXTURES=0 ") != NULL, textures);
    assert_int_equal(strstr(o, "-DSPT_LAYERS=0 ") != NULL, layers);
}

/* The CPU path's program leaves out the texture and the layers' code only
 * where no material of the scene needs it (src/render/wavefront.c,
 * wavefront_options): any texture slot in use keeps the first, any clear
 * coat, sheen, anisotropy or diffuse transmission (a NaN factor too) the
 * second; the GPU path keeps both. The renders of tools/image_hashes.sh and
 * the material tests check what the programs draw. */
TEST(test_program_leaves_out_unused_code)
{
    Scene s;
    grey_quad_scene(&s);
    GpuScene g;
    SptError e = {0};
    assert_int_equal(gpu_scene_build(&g, &s, &e), 0);
    RenderSettings rs = test_settings(8, 8, 1, 2, 1u);
    rs.test.kernel_path = SPT_KERNEL_PATH_CPU;
    assert_leaves_out(&g, &rs, 1, 1);
    GpuMaterial *m = &g.materials[0];
    float *factor[] = {&m->clearcoat, &m->aniso, &m->diffuse_transmission};
    for (int k = 0; k < 3; k++) {
        *factor[k] = 0.25f;
        assert_leaves_out(&g, &rs, 1, 0);
        *factor[k] = NAN;
        assert_leaves_out(&g, &rs, 1, 0);
        *factor[k] = -1.0f;
        assert_leaves_out(&g, &rs, 1, 1);
        *factor[k] = 0.0f;
    }
    m->sheen.kind = SPT_SPEC_SIGMOID;
    assert_leaves_out(&g, &rs, 1, 0);
    m->sheen.kind = SPT_SPEC_NONE;
    for (int k = 0; k < SPT_TS_COUNT; k++) {
        assert_int_equal(m->slot[k].tex, -1);
        m->slot[k].tex = 0;
        assert_leaves_out(&g, &rs, 0, 1);
        m->slot[k].tex = -1;
    }
    rs.test.kernel_path = SPT_KERNEL_PATH_GPU;
    assert_leaves_out(&g, &rs, 0, 0);
    gpu_scene_free(&g);
    scene_free(&s);
}

/* The same seed on the same device gives the same film bit for bit; another seed
 * does not. Rendering three times also exercises release of every object. */
TEST(test_determinism)
{
    Film a, b, c;
    RenderStats st;
    const char *p = "scenes/cornell_box.gltf";
    assert_int_equal(render_gltf(p, 32, 32, 8, -1, 7, &a, &st), 0);
    assert_int_equal(render_gltf(p, 32, 32, 8, -1, 7, &b, &st), 0);
    assert_int_equal(render_gltf(p, 32, 32, 8, -1, 8, &c, &st), 0);
    size_t n = 32 * 32 * 3;
    assert_memory_equal(a.xyz, b.xyz, n * sizeof(double));
    assert_memory_not_equal(a.xyz, c.xyz, n * sizeof(double));
    film_free(&a);
    film_free(&b);
    film_free(&c);
}

/* NaN radiance never reaches the film: with the test hook, pixel 0's samples are
 * dropped and counted, and every pixel stays finite. */
TEST(test_nan_guard)
{
    Film f;
    RenderStats st;
    g_hooks.inject_nan = 1;
    int rc = render_gltf("tests/data/scenes/furnace.gltf", 8, 8, 4, 2, 1, &f, &st);
    g_hooks.inject_nan = 0;
    assert_int_equal(rc, 0);
    assert_int_equal(st.nan_dropped, 4); /* pixel 0, 4 samples */
    assert_true(f.count[0] == 0.0);
    for (size_t i = 0; i < 3 * 64; i++)
        assert_true(isfinite(f.xyz[i]));
    assert_true(f.count[1] == 4.0);
    film_free(&f);
}

/* The default Cornell box (Cornell's measured spectra) against Mitsuba 3's
 * llvm_ad_spectral image means (tests/data/mitsuba/cornell_box_means.json), at max
 * depth 8: within 2% per channel, and the 4x4 block means (which catch a mirrored
 * or shifted image) within 10% where they are not tiny. */
TEST(test_cornell_box_vs_mitsuba)
{
    skip_if_quick();
    const char *ref = "tests/data/mitsuba/cornell_box_means.json";
    double want[3];
    assert_int_equal(json_triple(ref, "\"max_depth_8\"", "\"mean\"", want), 0);
    Film f;
    RenderStats st;
    const int w = 128;
    /* 256 spp: the block under the glass sphere holds a caustic, whose block mean
     * is still about 5% noisy at this count (9% at 64 spp). */
    assert_int_equal(render_gltf("scenes/cornell_box.gltf", w, w, 256, 8, 5, &f, &st), 0);
    double m[3];
    film_mean(&f, m);
    printf("cornell box depth 8: mean (%.5f, %.5f, %.5f), Mitsuba (%.5f, %.5f, %.5f)\n", m[0], m[1],
           m[2], want[0], want[1], want[2]);
    for (int c = 0; c < 3; c++)
        assert_close_rel(m[c], want[c], 0.02);
    /* Block means: top-left block is dark (red wall corner), the top middle holds
     * the light. Compare the green channel of the four top-row blocks. */
    float *rgb = malloc((size_t)w * w * 3 * sizeof(float));
    film_to_linear_srgb(&f, rgb);
    const char *p = NULL;
    {
        FILE *fp = fopen(ref, "r");
        static char buf[1 << 16];
        size_t n = fread(buf, 1, sizeof buf - 1, fp);
        fclose(fp);
        buf[n] = 0;
        p = strstr(strstr(buf, "\"max_depth_8\""), "block_means_4x4") + 15;
        for (int by = 0; by < 4; by++)
            for (int bx = 0; bx < 4; bx++) {
                double r[3];
                for (int c = 0; c < 3; c++) { /* the next three numbers */
                    char *end;
                    while (*p && !(*p == '-' || (*p >= '0' && *p <= '9')))
                        p++;
                    r[c] = strtod(p, &end);
                    assert_true(end != p);
                    p = end;
                }
                double b[3] = {0, 0, 0};
                int bs = w / 4;
                for (int y = by * bs; y < (by + 1) * bs; y++)
                    for (int x = bx * bs; x < (bx + 1) * bs; x++)
                        for (int c = 0; c < 3; c++)
                            b[c] += rgb[3 * (y * w + x) + c] / (bs * bs);
                for (int c = 0; c < 3; c++)
                    if (r[c] > 0.02)
                        assert_close_rel(b[c], r[c], 0.10);
            }
    }
    free(rgb);
    film_free(&f);
}

/* An orthographic camera (ymag 2: the view spans [-2, 2]^2) sees a unit sphere of
 * unlit white as a disc covering pi / 16 of the image. */
TEST(test_orthographic)
{
    Scene s;
    sphere_scene(&s, 1.0f);
    s.materials[0].unlit = 1;
    s.camera.orthographic = 1;
    s.camera.xmag = s.camera.ymag = 2.0f;
    RenderSettings rs = test_settings(64, 64, 16, -1, 0);
    Film f;
    render_film_ok(&s, &rs, &f);
    double m[3];
    film_mean(&f, m);
    /* The polyhedral sphere's silhouette is a 96-gon inscribed in the unit circle. */
    double want = 96 * 0.5 * sin(2 * M_PI / 96) / 16.0;
    printf("orthographic: mean %.4f, expected %.4f\n", m[1], want);
    assert_close_rel(m[1], want, 0.02);
    film_free(&f);
    scene_free(&s);
}

TEST_MAIN("render", setup_cpu_device, teardown_cpu_device)
