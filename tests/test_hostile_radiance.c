/* Radiance far from 1 (the Cornell box lit at its emissive strength times 1e20,
 * within the glTF limit of 1e30, docs/limits.md), run as a user would
 * ($SPECTRACE_EXE, set by tests/run_tests.sh; every command under `timeout`):
 * the per-pixel sums of radiance squared, which only the variance layer needs,
 * pass float's range there. A checkpoint without the variance layer is written
 * and resumes to the film of an uninterrupted render; with the variance layer
 * the render is refused with one error line naming the scene (exit 3, README.md
 * "Exit codes"), as without a checkpoint. */
#include "test_util.h"

#include <sys/wait.h>

#include "scaled_box.h"
#define SCENE BOX
#include "ckpt_test.h"

#define ARGS "--width 16 -q --device 0"

static int run(const char *args, char *err, size_t cap)
{
    return test_run_exe("", 120, args, err, cap);
}

/* (a) At 1e20 times the light, with --denoise's guides (the albedo layer) but
 * not the variance layer: 2 spp checkpointed then resumed to 4 gives the image
 * of a straight 4 spp render, and the checkpoint run exits 0. */
TEST(test_bright_checkpoint_resumes)
{
    char args[2048], err[8192];
    const char *box = box_times(1e20);
    snprintf(args, sizeof args, "render %s " ARGS " --spp 4 --aov albedo,N -o %s", box,
             test_path("straight.exr"));
    int rc = run(args, err, sizeof err);
    if (rc)
        fail_msg("straight render: exit %d: %s", rc, err);
    snprintf(args, sizeof args, "render %s " ARGS " --spp 2 --aov albedo,N -o %s --checkpoint %s", box,
             test_path("half.exr"), test_path("ck.exr"));
    rc = run(args, err, sizeof err);
    if (rc)
        fail_msg("2 spp with --checkpoint: exit %d, expected 0: %s", rc, err);
    snprintf(args, sizeof args, "render %s " ARGS " --spp 4 --aov albedo,N -o %s --resume %s", box,
             test_path("resumed.exr"), test_path("ck.exr"));
    rc = run(args, err, sizeof err);
    if (rc)
        fail_msg("resume to 4 spp: exit %d, expected 0: %s", rc, err);
    assert_same_exr(test_path("straight.exr"), test_path("resumed.exr"));
}

/* (a) The same with the variance layer, which cannot hold these squares: one
 * error line naming the scene and the layer, exit 3, as without --checkpoint. */
TEST(test_bright_checkpoint_variance_refused)
{
    char args[2048], err[8192];
    const char *box = box_times(1e20);
    snprintf(args, sizeof args, "render %s " ARGS " --spp 2 --aov variance -o %s --checkpoint %s", box,
             test_path("v.exr"), test_path("vck.exr"));
    int rc = run(args, err, sizeof err);
    const char *nl = strchr(err, '\n');
    if (rc != 3 || strncmp(err, "error: ", 7) || !nl || nl[1] || !strstr(err, box) || !strstr(err, "variance"))
        fail_msg("exit %d, expected 3 with one error line naming %s and the variance layer:\n%s", rc, box,
                 err);
}

/* Renders the box at k times its light with --adaptive on, 64 spp, the image
 * and the spp layer into out; exits on failure. */
static void adaptive_at(double k, const char *out)
{
    char args[2048], err[8192];
    snprintf(args, sizeof args, "render %s " ARGS " --spp 64 --adaptive on --aov spp -o %s", box_times(k), out);
    int rc = run(args, err, sizeof err);
    if (rc)
        fail_msg("x %g, --adaptive on: exit %d: %s", k, rc, err);
}

/* The layers of adaptive_at's renders. */
static const char *const adaptive_layers[] = {"R", "G", "B", "spp"};

/* The render of adaptive_at(k) against x 1's, ref (flat and tot as in the test
 * below): prints how far its spp layer, and its image over k, are from ref's;
 * returns whether both are within the test's bounds. */
static int adaptive_like_x1(const ExrLayers *ref, double k, double flat, double tot)
{
    ExrLayers l;
    SptError e = {0};
    adaptive_at(k, test_path("ak.exr"));
    if (exr_read_layers(test_path("ak.exr"), adaptive_layers, 4, &l, &e))
        fail_msg("%s", e.msg);
    size_t n = (size_t)ref->width * ref->height;
    const float *s0 = exr_layers_channel(ref, "spp")->data, *s1 = exr_layers_channel(&l, "spp")->data;
    double dspp = 0, dimg = 0, img = 0, lo = 1e30, hi = 0;
    for (size_t i = 0; i < n; i++) {
        dspp += fabs((double)s1[i] - s0[i]);
        lo = fmin(lo, s1[i]);
        hi = fmax(hi, s1[i]);
    }
    for (int c = 0; c < 3; c++) {
        const float *a = exr_layers_channel(ref, adaptive_layers[c])->data;
        for (size_t i = 0; i < n; i++)
            img += fabs(a[i]);
        dimg += channel_diff(ref, 1, &l, k, adaptive_layers[c]);
    }
    printf("x %g: spp %g to %g, off x 1 by %.2f%% of the samples; image off by %.2f%%\n", k, lo, hi,
           100 * dspp / tot, 100 * dimg / img);
    int same = dspp <= 0.1 * flat && dimg <= 0.02 * img;
    exr_layers_free(&l);
    return same;
}

/* (b), (c) Adaptive sampling weighs each pixel's error relative to the image's
 * level, so the light's strength times 1e20 (squares past float's range) or
 * 1e-20 (squares below float's normal range) spends the samples as at 1:
 * the spp layers differ by at most a tenth of how far x 1's differs from
 * plain sampling, and the images over the strength by at most 2% of the
 * image's sum (float rounding at another scale can flip a pixel's close
 * choice, so not exactly). */
TEST(test_adaptive_scale_invariant)
{
    static const double ks[] = {1e20, 1e-20};
    ExrLayers ref;
    SptError e = {0};
    adaptive_at(1, test_path("a1.exr"));
    if (exr_read_layers(test_path("a1.exr"), adaptive_layers, 4, &ref, &e))
        fail_msg("%s", e.msg);
    size_t n = (size_t)ref.width * ref.height;
    const float *s0 = exr_layers_channel(&ref, "spp")->data;
    /* How far x 1's choice is from plain sampling (every pixel 64 spp). */
    double flat = 0, tot = 0;
    for (size_t i = 0; i < n; i++) {
        flat += fabs(64.0 - s0[i]);
        tot += s0[i];
    }
    printf("x 1: spp off 64 by %.1f%% of the samples\n", 100 * flat / tot);
    assert_true(flat >= 0.03 * tot); /* adaptive sampling did choose */
    int failed = 0;
    for (int t = 0; t < 2; t++)
        failed |= !adaptive_like_x1(&ref, ks[t], flat, tot);
    exr_layers_free(&ref);
    if (failed)
        fail_msg("adaptive sampling depends on the light's scale");
}

/* (c) At 1e-20 times the light the squares of radiance (1e-38 to 1e-44) are
 * below float's normal range, 1.2e-38, where the kernels sum them: subnormals
 * that keep few bits, or 0 on a device that flushes them. The run exits 0 and
 * says so in one warning naming the scene and the variance layer
 * (docs/limits.md). How far the layer over k^2 is from x 1's is printed
 * (0.001% of its sum on PoCL, which keeps subnormals). */
TEST(test_dim_variance_not_silent)
{
    static const char *const want[] = {"variance.R", "variance.G", "variance.B"};
    const double k = 1e-20;
    char args[2048], err[8192];
    ExrLayers a, b;
    SptError e = {0};
    snprintf(args, sizeof args, "render %s " ARGS " --spp 4 --aov variance -o %s", box_times(1),
             test_path("v1.exr"));
    int rc = run(args, err, sizeof err);
    if (rc)
        fail_msg("x 1: exit %d: %s", rc, err);
    snprintf(args, sizeof args, "render %s " ARGS " --spp 4 --aov variance -o %s", box_times(k),
             test_path("vk.exr"));
    rc = run(args, err, sizeof err);
    if (rc)
        fail_msg("x %g: exit %d: %s", k, rc, err);
    if (exr_read_layers(test_path("v1.exr"), want, 3, &a, &e) ||
        exr_read_layers(test_path("vk.exr"), want, 3, &b, &e))
        fail_msg("%s", e.msg);
    double d = 0, tot = 0;
    for (int c = 0; c < 3; c++) {
        const float *x = exr_layers_channel(&a, want[c])->data, *y = exr_layers_channel(&b, want[c])->data;
        for (int i = 0; i < a.width * a.height; i++) {
            d += fabs(x[i] - y[i] / (k * k));
            tot += x[i];
        }
    }
    exr_layers_free(&a);
    exr_layers_free(&b);
    int warned = !strncmp(err, "warning: ", 9) && strstr(err, "variance") && strchr(err, '\n')[1] == 0;
    printf("x %g: variance / k^2 off x 1 by %.3g%% of its sum; %s\n", k, 100 * d / tot,
           warned ? "warned" : "no warning");
    if (!warned || !strstr(err, test_path("")))
        fail_msg("x %g: expected one warning naming the scene and the variance layer, got '%s'", k, err);
    if (!(d <= 0.02 * tot))
        print_message("  this device loses the subnormal squares (warned)\n");
}

TEST_MAIN("tests", test_dir_setup, test_dir_teardown)
