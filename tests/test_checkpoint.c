/* Checkpoints and resume (issue "Scale", several sittings): the file keeps the
 * film to double precision, a render stopped and resumed equals the one rendered
 * in one go, refusals say which, and Ctrl-C writes the checkpoint and the image.
 * Runs $SPECTRACE_EXE (set by tests/run_tests.sh) on two PoCL devices of one
 * compute unit each. */
#include "test_util.h"

#include <errno.h>
#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>


#define SCENE "scenes/cornell_box.gltf"
#define OTHER_SCENE "tests/data/scenes/furnace.gltf"
/* Every render of these tests: small, quiet, seed 3. */
#define COMMON "--width 32 --height 32 --seed 3 -q"

#include "ckpt_test.h"
#include "render_fixture.h"

/* Runs spectrace with args, stderr into out (may be NULL); returns the exit status. */
static int run(const char *args, char *out, size_t cap)
{
    return test_run_exe("", 0, args, out, cap);
}

/* run() that must succeed; prints the program's messages when it does not. */
static void run_ok(const char *args, char *out, size_t cap)
{
    int rc = run(args, out, cap);
    if (rc)
        fail_msg("exit code %d from spectrace %s:\n%s", rc, args, out);
}

static int setup(void **state)
{
    (void)state;
    if (test_dir_make("spt-ckpt"))
        return -1;
    /* Fill the program cache first, its exit code ignored: in the sanitizer
     * build, a process that compiled the kernels with PoCL's LLVM sometimes ends
     * with "LeakSanitizer has encountered a fatal error" (exit code 1), which
     * says nothing about the code under test. */
    char cmd[512], out[4096];
    snprintf(cmd, sizeof cmd, "render " SCENE " --width 8 --height 8 --spp 1 -q --device all -o %s/warm.exr",
             test_dir());
    run(cmd, out, sizeof out);
    return 0;
}

/* The file keeps the double sums (hi + lo floats) and non-contiguous done sets. */
TEST(test_file_round_trip)
{
    RenderSettings rs = test_settings(3, 2, 0, 0, 7);
    CheckpointKey k;
    SptError e = {0};
    assert_int_equal(checkpoint_key(&k, SCENE, &rs, &e), 0);
    Film f;
    film_init(&f, 3, 2);
    for (int i = 0; i < 6; i++) {
        for (int c = 0; c < 3; c++)
            f.xyz[3 * i + c] = 1e7 + 0.123456789 * (i + 1) + c;
        f.count[i] = 6;
    }
    unsigned char done[12] = {1, 1, 1, 1, 0, 0, 0, 0, 1, 1, 0, 0};
    const char *p = test_path("rt.exr");
    assert_int_equal(checkpoint_write(p, &k, &f, done, 12, &e), 0);
    Film g;
    unsigned char *d2;
    assert_int_equal(checkpoint_read(p, &k, 12, &g, &d2, &e), 0);
    assert_memory_equal(done, d2, 12);
    for (int i = 0; i < 18; i++)
        assert_close_rel(g.xyz[i], f.xyz[i], 1e-12);
    for (int i = 0; i < 6; i++)
        assert_true(g.count[i] == 6);
    free(d2);
    film_free(&g);
    /* Resuming to fewer samples than it holds: a usage error. */
    assert_int_equal(checkpoint_read(p, &k, 9, &g, &d2, &e), SPT_EXIT_USAGE);
    printf("%s\n", e.msg);
    /* A negative sum (radiance and the colour matching functions are never
     * negative) is damage: refused, nothing read. */
    f.xyz[4] = -1.0;
    assert_int_equal(checkpoint_write(p, &k, &f, done, 12, &e), 0);
    assert_int_equal(checkpoint_read(p, &k, 12, &g, &d2, &e), SPT_EXIT_INPUT);
    assert_non_null(strstr(e.msg, "negative"));
    assert_null(g.xyz);
    film_free(&f);
}

/* Renders with the options extra (and COMMON) 64 spp in one go on device 0
 * (<tag>full.exr, its checkpoint <tag>full_ck.exr) and 32 spp on device 0
 * (<tag>half_ck.exr, which holds 32), then resumes the latter to 64 on every
 * device (<tag>resumed.exr). */
static void render_split(const char *extra, const char *tag)
{
    char cmd[1024], out[4096], f[4][64];
    static const char *names[4] = {"full.exr", "full_ck.exr", "half.exr", "half_ck.exr"};
    for (int i = 0; i < 4; i++)
        snprintf(f[i], sizeof f[i], "%s%s", tag, names[i]);
    for (int h = 0; h < 2; h++) {
        snprintf(cmd, sizeof cmd, "render " SCENE " " COMMON " %s --device 0 --spp %d -o %s --checkpoint %s",
                 extra, h ? 32 : 64, test_path(f[2 * h]), test_path(f[2 * h + 1]));
        run_ok(cmd, out, sizeof out);
    }
    Film b;
    assert_int_equal(load_checkpoint(test_path(f[3]), 3, 64, &b), 32);
    film_free(&b);
    snprintf(f[0], sizeof f[0], "%sresumed.exr", tag);
    snprintf(cmd, sizeof cmd, "render " SCENE " " COMMON " %s --device all --spp 64 -o %s --resume %s", extra,
             test_path(f[0]), test_path(f[3]));
    run_ok(cmd, out, sizeof out);
}

/* 64 spp in one go, on one device, equals 32 spp on one device, stopped, then
 * resumed to 64 on two devices. */
TEST(test_resume_split_invariance)
{
    render_split("", "");
    assert_same_render(test_path("full_ck.exr"), test_path("half_ck.exr"), 3, 64, test_path("full.exr"),
                       test_path("resumed.exr"));
}

/* The same with every AOV layer (--aov all) and 47 spectral bands: the
 * checkpoint keeps their sums, and the resumed render's layers and bands are
 * those of the render in one go. */
TEST(test_resume_split_invariance_aov)
{
    char cmd[1024], out[4096];
    Film a, b;
    ckpt_aov = SPT_AOV_ALL;
    ckpt_spectral = 47;
    render_split("--aov all --spectral 47", "a");
    assert_int_equal(load_checkpoint(test_path("afull_ck.exr"), 3, 64, &a), 64);
    assert_int_equal(load_checkpoint(test_path("ahalf_ck.exr"), 3, 64, &b), 64);
    ckpt_aov = 0;
    ckpt_spectral = 0;
    assert_same_film(&a, &b);
    assert_same_aov_tol(&a, &b, 1e-4);
    assert_same_bands_tol(&a, &b, 1e-4);
    assert_same_exr(test_path("afull.exr"), test_path("aresumed.exr"));
    film_free(&a);
    film_free(&b);
    /* Resuming without the AOVs the checkpoint has: refused, naming the setting. */
    snprintf(cmd, sizeof cmd, "render " SCENE " " COMMON " --device 0 --spp 64 -o %s --resume %s",
             test_path("arefused.exr"), test_path("afull_ck.exr"));
    assert_int_equal(run(cmd, out, sizeof out), SPT_EXIT_INPUT);
    assert_non_null(strstr(out, "aov"));
    assert_false(test_exists(test_path("arefused.exr")));
}

/* Runs a refused resume: exit code 3 (or want), one error line containing
 * `says`, no output written and the checkpoint's bytes untouched. */
static void refused(const char *args, const char *ckpt, int want, const char *says)
{
    char cmd[1024], out[4096];
    size_t n0, n1;
    char *before = test_slurp(ckpt, &n0);
    unlink(test_path("refused.exr"));
    snprintf(cmd, sizeof cmd, "render %s --device 0 --spp 64 -o %s --resume %s", args,
             test_path("refused.exr"), ckpt);
    int rc = run(cmd, out, sizeof out);
    printf("%s", out);
    assert_int_equal(rc, want);
    if (strncmp(out, "error: ", 7) || strchr(out, '\n') != out + strlen(out) - 1 || !strstr(out, says))
        fail_msg("expected one error line saying '%s', got:\n%s", says, out);
    assert_false(test_exists(test_path("refused.exr")));
    char *after = test_slurp(ckpt, &n1);
    assert_int_equal(n0, n1);
    assert_memory_equal(before, after, n0);
    free(before);
    free(after);
}

TEST(test_resume_refusals)
{
    char cmd[1024], out[4096];
    char ck[256], tr[256], img[256], txt[256];
    snprintf(ck, sizeof ck, "%s", test_path("ref_ck.exr"));
    snprintf(tr, sizeof tr, "%s", test_path("truncated_ck.exr"));
    snprintf(img, sizeof img, "%s", test_path("ref.exr"));
    snprintf(txt, sizeof txt, "%s", test_path("notes.exr"));
    snprintf(cmd, sizeof cmd, "render " SCENE " " COMMON " --device 0 --spp 8 -o %s --checkpoint %s",
             img, ck);
    run_ok(cmd, out, sizeof out);
    refused(OTHER_SCENE " " COMMON, ck, SPT_EXIT_INPUT, "another scene");
    refused(SCENE " --width 32 --height 32 --seed 4 -q", ck, SPT_EXIT_INPUT, "--seed 4 here, 3 in the checkpoint");
    refused(SCENE " --width 40 --height 32 --seed 3 -q", ck, SPT_EXIT_INPUT, "--width 40 here, 32 in the checkpoint");
    refused(SCENE " " COMMON " --max-depth 3", ck, SPT_EXIT_INPUT, "--max-depth 3 here, -1 in the checkpoint");
    /* Truncated: the first half of the file. */
    size_t n;
    char *bytes = test_slurp(ck, &n);
    FILE *f = fopen(tr, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(bytes, 1, n / 2, f), n / 2);
    fclose(f);
    free(bytes);
    refused(SCENE " " COMMON, tr, SPT_EXIT_INPUT, "truncated");
    /* Not a checkpoint: an image output, and a text file. */
    refused(SCENE " " COMMON, img, SPT_EXIT_INPUT, "not a spectrace checkpoint");
    f = fopen(txt, "w");
    assert_non_null(f);
    fputs("not an EXR file at all\n", f);
    fclose(f);
    refused(SCENE " " COMMON, txt, SPT_EXIT_INPUT, "damaged");
    /* Fewer samples than the checkpoint holds. */
    char args[256];
    snprintf(args, sizeof args, SCENE " " COMMON " --spp 4");
    snprintf(cmd, sizeof cmd, "render %s --device 0 -o %s --resume %s", args, test_path("refused.exr"), ck);
    assert_int_equal(run(cmd, out, sizeof out), SPT_EXIT_USAGE);
    assert_non_null(strstr(out, "must be at least 8"));
}

/* SIGINT during a two-device render with checkpoints: the checkpoint and the
 * image of the samples done are written, and resuming finishes the image, equal
 * to the one rendered without a stop. */
TEST(test_sigint_then_resume)
{
    const char *exe = test_exe();
    char ck[256], img[256], log[256];
    snprintf(ck, sizeof ck, "%s", test_path("int_ck.exr"));
    snprintf(img, sizeof img, "%s", test_path("int.exr"));
    snprintf(log, sizeof log, "%s", test_path("int.log"));
    pid_t pid = fork();
    assert_true(pid >= 0);
    if (pid == 0) {
        /* Slow chunks on device 0 so the render is still going when the signal comes. */
        setenv("SPECTRACE_TEST_SLOW_DEVICE", "0:40", 1);
        FILE *lf = freopen(log, "w", stderr);
        (void)lf;
        execl(exe, exe, "render", SCENE, "--width", "32", "--height", "32", "--seed", "3", "-q",
              "--device", "all", "--spp", "128", "--checkpoint", ck, "--checkpoint-every", "0.05",
              "-o", img, (char *)NULL);
        _exit(127);
    }
    stop_after_checkpoint(pid, ck, SIGINT, log);
    Film part;
    uint32_t done = load_checkpoint(ck, 3, 128, &part);
    printf("stopped after %u of 128 spp\n", done);
    assert_true(done > 0 && done < 128);
    /* The image is the checkpoint's samples. */
    size_t npix = 32 * 32;
    float *rgb = malloc(npix * 3 * sizeof(float));
    film_to_linear_srgb(&part, rgb);
    ExrLayers L;
    SptError e = {0};
    static const char *names[3] = {"R", "G", "B"};
    if (exr_read_layers(img, names, 3, &L, &e))
        fail_msg("%s", e.msg);
    for (size_t i = 0; i < npix; i++) {
        assert_true(part.count[i] == done);
        for (int c = 0; c < 3; c++)
            assert_close(((const float *)exr_layers_channel(&L, names[c])->data)[i], rgb[3 * i + c],
                         1e-5 * fmax(1.0, fabs(rgb[3 * i + c])));
    }
    exr_layers_free(&L);
    free(rgb);
    film_free(&part);
    /* Resume to 128 and compare with 128 in one go. */
    char cmd[1024], out[4096];
    snprintf(cmd, sizeof cmd, "render " SCENE " " COMMON " --device 0 --spp 128 -o %s --resume %s",
             test_path("int_done.exr"), ck);
    if (run(cmd, out, sizeof out))
        fail_msg("resume failed: %s", out);
    snprintf(cmd, sizeof cmd, "render " SCENE " " COMMON " --device 0 --spp 128 -o %s --checkpoint %s",
             test_path("straight.exr"), test_path("straight_ck.exr"));
    run_ok(cmd, out, sizeof out);
    assert_same_render(ck, test_path("straight_ck.exr"), 3, 128, test_path("int_done.exr"),
                       test_path("straight.exr"));
}

TEST_MAIN_ENV("checkpoint", setup, test_dir_teardown,
              "POCL_DEVICES=pthread pthread", "POCL_MAX_PTHREAD_COUNT=1",
              "SPECTRACE_POOL=512")
