/* Hostile input to --denoise, run as a user would ($SPECTRACE_EXE, set by
 * tests/run_tests.sh; every command under `timeout`, so a hang fails the test):
 * images far from Open Image Denoise's normal range (the Cornell box lit at
 * emissive strengths from 1e-20 to 1e20 times its own) keep their level
 * through the denoiser, the variance layer keeps its scale or is refused, a
 * failing denoiser is one error line, and SPECTRACE_OIDN naming something that
 * is not a regular file is refused at once with one error line. The tests that
 * need the library skip, saying so, where `make denoise` could not install it
 * (tests/test_denoise.c). */
#include "test_util.h"
#include "denoise_test.h"
#include "scaled_box.h"

#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "core/util.h"
#include "io/denoise.h"
#include "io/exr.h"

#define W 64

static int setup(void **state)
{
    if (test_dir_setup(state))
        return -1;
    Denoiser d;
    oidn_probe(&d);
    denoiser_close(&d);
    return 0;
}

static const char *const rgb[3] = {"R", "G", "B"};
static const char *const noisy[3] = {"noisy.R", "noisy.G", "noisy.B"};

/* The Cornell box with its light's emissive strength (20.7) times 1e-20 to
 * 1e20, so that the image's values span 1e-22 to 1e21 (the scene limit is
 * 1e30; these keep the image within float), 64 px wide at 4 spp,
 * denoised: each run exits 0 and the denoised image's mean stays within 3% of
 * the noisy image's, the physics being linear in the light; and the denoised
 * image over the strength is the same image at every strength (within 1% of
 * its sum), as are the albedo and normal guides, which do not depend on the
 * light at all. */
TEST(test_exposure_sweep)
{
    need_oidn();
    static const double k[] = {1, 1e-20, 1e-9, 1e-3, 1e3, 1e9, 1e19, 1e20};
    enum { NK = sizeof k / sizeof k[0] };
    static const char *const want[] = {"R",       "G",       "B",        "noisy.R",  "noisy.G",
                                       "noisy.B", "albedo.R", "albedo.G", "albedo.B", "N.X",
                                       "N.Y",     "N.Z"};
    ExrLayers ref;
    int failed = 0;
    for (int i = 0; i < NK; i++) {
        char args[1024], err[8192], out[256];
        snprintf(out, sizeof out, "%s/den.exr", test_dir());
        snprintf(args, sizeof args, "render %s --width %d --spp 4 -q --device 0 --denoise --aov albedo,N -o %s",
                 box_times(k[i]), W, out);
        int rc = test_run_exe("", 120, args, err, sizeof err);
        if (rc && i == 0)
            fail_msg("strength x 1: exit %d: %s", rc, err);
        if (rc) {
            print_error("strength x %g: exit %d: %s", k[i], rc, err);
            failed = 1;
            continue;
        }
        ExrLayers l;
        SptError e = {0};
        if (exr_read_layers(out, want, 12, &l, &e))
            fail_msg("%s", e.msg);
        double den = 0, noi = 0;
        for (int c = 0; c < 3; c++) {
            den += channel_sum(&l, rgb[c]);
            noi += channel_sum(&l, noisy[c]);
        }
        double dev = fabs(den / noi - 1);
        printf("strength x %-6g: noisy mean %.4g, denoised mean %.4g (%+.2f%%)", k[i], noi / (3.0 * W * W),
               den / (3.0 * W * W), 100 * (den / noi - 1));
        if (!(dev <= 0.03))
            failed = 1;
        if (i == 0) {
            ref = l;
            printf("\n");
            continue;
        }
        double moved = 0, ref_sum = 0, guide = 0;
        for (int c = 0; c < 3; c++) {
            moved += channel_diff(&l, k[i], &ref, 1, rgb[c]);
            ref_sum += fabs(channel_sum(&ref, rgb[c]));
            guide = fmax(guide, channel_diff(&l, 1, &ref, 1, want[6 + c]));
            guide = fmax(guide, channel_diff(&l, 1, &ref, 1, want[9 + c]));
        }
        printf("; over the strength off the strength-1 image by %.3f%%, guides by %.2g\n", 100 * moved / ref_sum,
               guide);
        if (!(moved <= 0.01 * ref_sum) || !(guide <= 1e-3))
            failed = 1;
        exr_layers_free(&l);
    }
    exr_layers_free(&ref);
    if (failed)
        fail_msg("see the lines above");
}

/* The variance layer (which needs no denoiser) over the strength squared is
 * the same at strengths 1e-9 to 1e9 (within 1% of its sum), where its values
 * are normal floats; where the sums of squares pass float's range (strength
 * x 1e20) the run is refused with one error line naming the scene, exit 3
 * (docs/limits.md), not written nor called an internal error. */
TEST(test_variance_layer)
{
    static const double k[] = {1, 1e-9, 1e-3, 1e3, 1e9};
    enum { NK = sizeof k / sizeof k[0] };
    static const char *const want[] = {"variance.R", "variance.G", "variance.B"};
    char args[1024], err[8192], out[256];
    snprintf(out, sizeof out, "%s/var.exr", test_dir());
    ExrLayers ref;
    for (int i = 0; i < NK; i++) {
        snprintf(args, sizeof args, "render %s --width %d --spp 4 -q --device 0 --aov variance -o %s",
                 box_times(k[i]), W, out);
        int rc = test_run_exe("", 120, args, err, sizeof err);
        if (rc)
            fail_msg("strength x %g: exit %d: %s", k[i], rc, err);
        ExrLayers l;
        SptError e = {0};
        if (exr_read_layers(out, want, 3, &l, &e))
            fail_msg("%s", e.msg);
        if (i == 0) {
            ref = l;
            continue;
        }
        double moved = 0, ref_sum = 0;
        for (int c = 0; c < 3; c++) {
            moved += channel_diff(&l, k[i] * k[i], &ref, 1, want[c]);
            ref_sum += channel_sum(&ref, want[c]);
        }
        printf("strength x %-6g: variance over the strength squared off the strength-1 one by %.4f%%\n", k[i],
               100 * moved / ref_sum);
        assert_true(ref_sum > 0);
        assert_true(moved <= 0.01 * ref_sum);
        exr_layers_free(&l);
    }
    exr_layers_free(&ref);
    const char *scene = box_times(1e20);
    snprintf(args, sizeof args, "render %s --width %d --spp 4 -q --device 0 --aov variance -o %s", scene, W,
             out);
    unlink(out);
    int rc = test_run_exe("", 120, args, err, sizeof err);
    printf("strength x 1e20 with the variance layer: exit %d: %s", rc, err);
    if (rc != SPT_EXIT_INPUT)
        fail_msg("exit %d, expected %d", rc, SPT_EXIT_INPUT);
    test_one_error(err, scene);
    if (!strstr(err, "variance") || strstr(err, "internal"))
        fail_msg("expected the variance layer named, and no internal error, in: %s", err);
    struct stat st;
    assert_int_not_equal(stat(out, &st), 0);
}

/* A stand-in for Open Image Denoise 2 (its functions as src/io/oidn_api.h
 * declares them) whose filter, by STUB_OIDN: reports an error; returns NaN;
 * returns a black image without an error. */
static const char stub_src[] =
    "#include <math.h>\n#include <stdbool.h>\n#include <stddef.h>\n#include <stdlib.h>\n#include <string.h>\n"
    "static float *o; static size_t n; static int failed; static int dev = 1;\n"
    "static const char *mode(void) { const char *m = getenv(\"STUB_OIDN\"); return m ? m : \"\"; }\n"
    "void *oidnNewDevice(int t) { (void)t; return &dev; }\n"
    "void oidnCommitDevice(void *d) { (void)d; }\n"
    "void oidnReleaseDevice(void *d) { (void)d; }\n"
    "int oidnGetDeviceError(void *d, const char **m) { (void)d; *m = \"stub: out of memory\"; return failed; }\n"
    "void *oidnNewFilter(void *d, const char *t) { (void)t; return d; }\n"
    "void oidnSetSharedFilterImage(void *f, const char *name, void *p, int fmt, size_t w, size_t h, size_t a,\n"
    "  size_t b, size_t c) { (void)f; (void)fmt; (void)a; (void)b; (void)c;\n"
    "  if (!strcmp(name, \"output\")) { o = p; n = 3 * w * h; } }\n"
    "void oidnSetFilterBool(void *f, const char *name, bool v) { (void)f; (void)name; (void)v; }\n"
    "void oidnCommitFilter(void *f) { (void)f; }\n"
    "void oidnExecuteFilter(void *f) { (void)f; if (!strcmp(mode(), \"error\")) failed = 1;\n"
    "  for (size_t i = 0; i < n; i++) o[i] = !strcmp(mode(), \"nan\") ? NAN : 0.0f; }\n"
    "void oidnReleaseFilter(void *f) { (void)f; }\n";

/* Open Image Denoise failing (the stand-in above, loaded through
 * SPECTRACE_OIDN): each way ends in one error line naming the denoiser and
 * not an internal error, exit 1 (README.md, "Exit codes"), nothing written;
 * a black image returned without an error counts as failing. */
TEST(test_denoiser_failure)
{
    char src[256], lib[256], cmd[1024], out[256], env[512], args[1024], err[4096];
    snprintf(src, sizeof src, "%s/stub.c", test_dir());
    snprintf(lib, sizeof lib, "%s/libstub.so", test_dir());
    snprintf(out, sizeof out, "%s/stub.exr", test_dir());
    FILE *f = fopen(src, "w");
    assert_non_null(f);
    fputs(stub_src, f);
    fclose(f);
    snprintf(cmd, sizeof cmd, "cc -shared -fPIC -o '%s' '%s' 2>&1", lib, src);
    if (system(cmd)) {
        print_message("  no C compiler to build the stand-in library: skipped\n");
        skip();
    }
    static const char *const modes[] = {"error", "nan", "black"};
    static const char *const says[] = {"stub: out of memory", "NaN", "mean"};
    for (int i = 0; i < 3; i++) {
        snprintf(env, sizeof env, "STUB_OIDN=%s SPECTRACE_OIDN='%s'", modes[i], lib);
        snprintf(args, sizeof args, "render " BOX " --width 16 --spp 1 -q --device 0 --denoise -o %s", out);
        int rc = test_run_exe(env, 120, args, err, sizeof err);
        printf("denoiser %s: exit %d: %s", modes[i], rc, err);
        if (rc != SPT_EXIT_FAILURE)
            fail_msg("denoiser %s: exit %d, expected %d", modes[i], rc, SPT_EXIT_FAILURE);
        test_one_error(err, says[i]);
        if (!strstr(err, "Open Image Denoise") || strstr(err, "internal"))
            fail_msg("expected the denoiser named, and no internal error, in: %s", err);
        struct stat st;
        assert_int_not_equal(stat(out, &st), 0);
    }
}

/* SPECTRACE_OIDN naming a FIFO (which dlopen would wait on for a writer), a
 * folder or a device file: one error line naming it, exit 2 (as for a file
 * that is not the library), at once and before rendering. */
TEST(test_oidn_not_regular_file)
{
    char fifo[256], out[256], env[512], args[512], err[4096];
    snprintf(fifo, sizeof fifo, "%s/oidn.fifo", test_dir());
    assert_int_equal(mkfifo(fifo, 0600), 0);
    snprintf(out, sizeof out, "%s/x.exr", test_dir());
    const char *paths[] = {fifo, test_dir(), "/dev/null"};
    for (int i = 0; i < 3; i++) {
        snprintf(env, sizeof env, "SPECTRACE_OIDN='%s'", paths[i]);
        snprintf(args, sizeof args, "render " BOX " --width 8 --spp 1 -q --device 0 --denoise -o %s", out);
        double t0 = spt_now();
        int rc = test_run_exe(env, 10, args, err, sizeof err);
        double secs = spt_now() - t0;
        printf("SPECTRACE_OIDN=%s: exit %d after %.2f s: %s", paths[i], rc, secs, err);
        if (rc != SPT_EXIT_USAGE)
            fail_msg("SPECTRACE_OIDN=%s: exit %d, expected %d", paths[i], rc, SPT_EXIT_USAGE);
        test_one_error(err, paths[i]);
        if (!strstr(err, "regular file"))
            fail_msg("expected 'regular file' in: %s", err);
        struct stat st;
        assert_int_not_equal(stat(out, &st), 0);
    }
}

TEST_MAIN("hostile_denoise", setup, test_dir_teardown)
