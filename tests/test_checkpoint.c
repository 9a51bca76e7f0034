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

/* Runs `$SPECTRACE_EXE args` with stderr captured into out; returns the exit status. */
static int run(const char *args, char *out, size_t cap)
{
    const char *exe = getenv("SPECTRACE_EXE");
    if (!exe)
        fail_msg("SPECTRACE_EXE is not set (run through tests/run_tests.sh)");
    char cmd[2048];
    snprintf(cmd, sizeof cmd, "'%s' %s 2>&1 >/dev/null", exe, args);
    FILE *p = popen(cmd, "r");
    assert_non_null(p);
    char tmp[4096];
    size_t n = fread(out ? out : tmp, 1, (out ? cap : sizeof tmp) - 1, p);
    (out ? out : tmp)[n] = 0;
    int st = pclose(p);
    return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
}

/* run() that must succeed; prints the program's messages when it does not. */
static void run_ok(const char *args, char *out, size_t cap)
{
    int rc = run(args, out, cap);
    if (rc)
        fail_msg("exit code %d from spectrace %s:\n%s", rc, args, out);
}

/* The whole file, malloc'd. */
static char *slurp(const char *path, size_t *n)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        fail_msg("%s: %s", path, strerror(errno));
    fseek(f, 0, SEEK_END);
    long len = ftell(f);
    fseek(f, 0, SEEK_SET);
    char *b = malloc((size_t)len + 1);
    assert_int_equal(fread(b, 1, (size_t)len, f), (size_t)len);
    fclose(f);
    b[len] = 0;
    *n = (size_t)len;
    return b;
}

static int setup(void **state)
{
    (void)state;
    snprintf(dir, sizeof dir, "/tmp/spt-ckpt-XXXXXX");
    if (!mkdtemp(dir))
        return -1;
    /* Fill the program cache first, its exit code ignored: in the sanitizer
     * build, a process that compiled the kernels with PoCL's LLVM sometimes ends
     * with "LeakSanitizer has encountered a fatal error" (exit code 1), which
     * says nothing about the code under test. */
    char cmd[512], out[4096];
    snprintf(cmd, sizeof cmd, "render " SCENE " --width 8 --height 8 --spp 1 -q --device all -o %s/warm.exr",
             dir);
    run(cmd, out, sizeof out);
    return 0;
}

static int teardown(void **state)
{
    (void)state;
    char cmd[128];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
    return system(cmd) == 0 ? 0 : -1;
}

/* The file keeps the double sums (hi + lo floats) and non-contiguous done sets. */
static void test_file_round_trip(void **state)
{
    (void)state;
    RenderSettings rs;
    memset(&rs, 0, sizeof rs);
    rs.width = 3;
    rs.height = 2;
    rs.seed = 7;
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
    const char *p = path_in("rt.exr");
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

/* 64 spp in one go, on one device, equals 32 spp on one device, stopped, then
 * resumed to 64 on two devices. */
static void test_resume_split_invariance(void **state)
{
    (void)state;
    char cmd[1024], out[4096];
    snprintf(cmd, sizeof cmd, "render " SCENE " " COMMON " --device 0 --spp 64 -o %s --checkpoint %s",
             path_in("full.exr"), path_in("full_ck.exr"));
    run_ok(cmd, out, sizeof out);
    snprintf(cmd, sizeof cmd, "render " SCENE " " COMMON " --device 0 --spp 32 -o %s --checkpoint %s",
             path_in("half.exr"), path_in("half_ck.exr"));
    run_ok(cmd, out, sizeof out);
    Film a, b;
    assert_int_equal(load_checkpoint(path_in("half_ck.exr"), 3, 64, &b), 32);
    film_free(&b);
    snprintf(cmd, sizeof cmd, "render " SCENE " " COMMON " --device all --spp 64 -o %s --resume %s",
             path_in("resumed.exr"), path_in("half_ck.exr"));
    if (run(cmd, out, sizeof out))
        fail_msg("resume failed: %s", out);
    assert_int_equal(load_checkpoint(path_in("full_ck.exr"), 3, 64, &a), 64);
    assert_int_equal(load_checkpoint(path_in("half_ck.exr"), 3, 64, &b), 64);
    assert_same_film(&a, &b);
    assert_same_exr(path_in("full.exr"), path_in("resumed.exr"));
    film_free(&a);
    film_free(&b);
}

/* The same with every AOV layer (--aov all) and 47 spectral bands: the
 * checkpoint keeps their sums, and the resumed render's layers and bands are
 * those of the render in one go. */
static void test_resume_split_invariance_aov(void **state)
{
    (void)state;
    char cmd[1024], out[4096];
    snprintf(cmd, sizeof cmd, "render " SCENE " " COMMON " --aov all --spectral 47 --device 0 --spp 64 -o %s --checkpoint %s",
             path_in("afull.exr"), path_in("afull_ck.exr"));
    run_ok(cmd, out, sizeof out);
    snprintf(cmd, sizeof cmd, "render " SCENE " " COMMON " --aov all --spectral 47 --device 0 --spp 32 -o %s --checkpoint %s",
             path_in("ahalf.exr"), path_in("ahalf_ck.exr"));
    run_ok(cmd, out, sizeof out);
    snprintf(cmd, sizeof cmd, "render " SCENE " " COMMON " --aov all --spectral 47 --device all --spp 64 -o %s --resume %s",
             path_in("aresumed.exr"), path_in("ahalf_ck.exr"));
    run_ok(cmd, out, sizeof out);
    Film a, b;
    ckpt_aov = SPT_AOV_ALL;
    ckpt_spectral = 47;
    assert_int_equal(load_checkpoint(path_in("afull_ck.exr"), 3, 64, &a), 64);
    assert_int_equal(load_checkpoint(path_in("ahalf_ck.exr"), 3, 64, &b), 64);
    ckpt_aov = 0;
    ckpt_spectral = 0;
    assert_same_film(&a, &b);
    assert_same_aov_tol(&a, &b, 1e-4);
    assert_same_bands_tol(&a, &b, 1e-4);
    assert_same_exr(path_in("afull.exr"), path_in("aresumed.exr"));
    film_free(&a);
    film_free(&b);
    /* Resuming without the AOVs the checkpoint has: refused, naming the setting. */
    snprintf(cmd, sizeof cmd, "render " SCENE " " COMMON " --device 0 --spp 64 -o %s --resume %s",
             path_in("arefused.exr"), path_in("afull_ck.exr"));
    assert_int_equal(run(cmd, out, sizeof out), SPT_EXIT_INPUT);
    assert_non_null(strstr(out, "aov"));
    assert_false(exists(path_in("arefused.exr")));
}

/* Runs a refused resume: exit code 3 (or want), one error line containing
 * `says`, no output written and the checkpoint's bytes untouched. */
static void refused(const char *args, const char *ckpt, int want, const char *says)
{
    char cmd[1024], out[4096];
    size_t n0, n1;
    char *before = slurp(ckpt, &n0);
    unlink(path_in("refused.exr"));
    snprintf(cmd, sizeof cmd, "render %s --device 0 --spp 64 -o %s --resume %s", args,
             path_in("refused.exr"), ckpt);
    int rc = run(cmd, out, sizeof out);
    printf("%s", out);
    assert_int_equal(rc, want);
    if (strncmp(out, "error: ", 7) || strchr(out, '\n') != out + strlen(out) - 1 || !strstr(out, says))
        fail_msg("expected one error line saying '%s', got:\n%s", says, out);
    assert_false(exists(path_in("refused.exr")));
    char *after = slurp(ckpt, &n1);
    assert_int_equal(n0, n1);
    assert_memory_equal(before, after, n0);
    free(before);
    free(after);
}

static void test_resume_refusals(void **state)
{
    (void)state;
    char cmd[1024], out[4096];
    char ck[256], tr[256], img[256], txt[256];
    snprintf(ck, sizeof ck, "%s", path_in("ref_ck.exr"));
    snprintf(tr, sizeof tr, "%s", path_in("truncated_ck.exr"));
    snprintf(img, sizeof img, "%s", path_in("ref.exr"));
    snprintf(txt, sizeof txt, "%s", path_in("notes.exr"));
    snprintf(cmd, sizeof cmd, "render " SCENE " " COMMON " --device 0 --spp 8 -o %s --checkpoint %s",
             img, ck);
    run_ok(cmd, out, sizeof out);
    refused(OTHER_SCENE " " COMMON, ck, SPT_EXIT_INPUT, "another scene");
    refused(SCENE " --width 32 --height 32 --seed 4 -q", ck, SPT_EXIT_INPUT, "--seed 4 here, 3 in the checkpoint");
    refused(SCENE " --width 40 --height 32 --seed 3 -q", ck, SPT_EXIT_INPUT, "--width 40 here, 32 in the checkpoint");
    refused(SCENE " " COMMON " --max-depth 3", ck, SPT_EXIT_INPUT, "--max-depth 3 here, -1 in the checkpoint");
    /* Truncated: the first half of the file. */
    size_t n;
    char *bytes = slurp(ck, &n);
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
    snprintf(cmd, sizeof cmd, "render %s --device 0 -o %s --resume %s", args, path_in("refused.exr"), ck);
    assert_int_equal(run(cmd, out, sizeof out), SPT_EXIT_USAGE);
    assert_non_null(strstr(out, "must be at least 8"));
}

/* SIGINT during a two-device render with checkpoints: the checkpoint and the
 * image of the samples done are written, and resuming finishes the image, equal
 * to the one rendered without a stop. */
static void test_sigint_then_resume(void **state)
{
    (void)state;
    const char *exe = getenv("SPECTRACE_EXE");
    char ck[256], img[256], log[256];
    snprintf(ck, sizeof ck, "%s", path_in("int_ck.exr"));
    snprintf(img, sizeof img, "%s", path_in("int.exr"));
    snprintf(log, sizeof log, "%s", path_in("int.log"));
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
    /* Wait for the first periodic checkpoint: the render has made progress. */
    for (int i = 0; i < 3000 && !exists(ck); i++)
        usleep(10000);
    assert_true(exists(ck));
    kill(pid, SIGINT);
    int st;
    assert_int_equal(waitpid(pid, &st, 0), pid);
    size_t n;
    char *text = slurp(log, &n);
    printf("%s", text);
    assert_true(WIFEXITED(st));
    assert_int_equal(WEXITSTATUS(st), 0);
    assert_non_null(strstr(text, "stopped by a signal"));
    free(text);
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
             path_in("int_done.exr"), ck);
    if (run(cmd, out, sizeof out))
        fail_msg("resume failed: %s", out);
    snprintf(cmd, sizeof cmd, "render " SCENE " " COMMON " --device 0 --spp 128 -o %s --checkpoint %s",
             path_in("straight.exr"), path_in("straight_ck.exr"));
    run_ok(cmd, out, sizeof out);
    Film a, b;
    assert_int_equal(load_checkpoint(ck, 3, 128, &a), 128);
    assert_int_equal(load_checkpoint(path_in("straight_ck.exr"), 3, 128, &b), 128);
    assert_same_film(&a, &b);
    assert_same_exr(path_in("int_done.exr"), path_in("straight.exr"));
    film_free(&a);
    film_free(&b);
}

int main(void)
{
    setenv("POCL_DEVICES", "pthread pthread", 1);
    setenv("POCL_MAX_PTHREAD_COUNT", "1", 1);
    setenv("SPECTRACE_POOL", "512", 1);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_file_round_trip),
        cmocka_unit_test(test_resume_split_invariance),
        cmocka_unit_test(test_resume_split_invariance_aov),
        cmocka_unit_test(test_resume_refusals),
        cmocka_unit_test(test_sigint_then_resume),
    };
    return cmocka_run_group_tests_name("checkpoint", tests, setup, teardown);
}
