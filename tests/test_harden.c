/* Hostile input to the program, run as a user would ($SPECTRACE_EXE, set by
 * tests/run_tests.sh; every command under `timeout`, so a hang fails the test):
 * each case ends with its documented exit code (README.md, "Exit codes"), one
 * `error:` line on stderr, and no file lost: an existing output is untouched by a
 * failed run, an output never replaces an input, no temporary file is left. */
#include "test_util.h"

#include <dirent.h>
#include <fcntl.h>
#include <math.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "io/exr.h"
#include "io/image_out.h"
#include "render/checkpoint.h"

#define SCENE "tests/data/scenes/furnace.gltf"
#define TINY "--width 8 --spp 1 -q --device 0"


/* `timeout 120 spectrace args` (env: "VAR=value " prefixes, or ""), stderr
 * into err; the exit status (-1: killed). */
static int run_env(const char *env, const char *args, char *err, size_t cap)
{
    return test_run_exe(env, 120, args, err, cap);
}

static int run(const char *args, char *err, size_t cap)
{
    return run_env("", args, err, cap);
}

/* The run fails with code and one error line naming want. */
static void refused(const char *args, int code, const char *want)
{
    char err[8192];
    int rc = run(args, err, sizeof err);
    if (rc != code)
        fail_msg("`%s`: exit %d, expected %d; stderr:\n%s", args, rc, code, err);
    test_one_error(err, want);
}

/* No temporary output file is left in the folder. */
static void assert_no_temporaries(void)
{
    DIR *d = opendir(test_dir());
    assert_non_null(d);
    struct dirent *de;
    while ((de = readdir(d)))
        if (strstr(de->d_name, ".spt-tmp-"))
            fail_msg("temporary file left: %s", de->d_name);
    closedir(d);
}

/* A rendered image, the "existing output" the failing runs must not touch. */
static unsigned char *good_output(const char *name, size_t *n)
{
    char args[1024], err[4096];
    snprintf(args, sizeof args, "render " SCENE " " TINY " -o %s", test_path(name));
    int rc = run(args, err, sizeof err);
    if (rc)
        fail_msg("the reference render failed (%d): %s", rc, err);
    return (unsigned char *)test_slurp(test_path(name), n);
}

/* A second output whose name is too long for the file system, or whose write fails
 * (a full disk, by the test hook), fails the run with exit 5 and leaves the first
 * output as it was: every output is written to a temporary file first and renamed
 * only when all were written. */
TEST(test_failed_output_keeps_others)
{
    size_t n;
    unsigned char *good = good_output("good.exr", &n);
    char name[300], args[2048];
    memset(name, 'a', 252);
    snprintf(name + 252, sizeof name - 252, ".exr");
    snprintf(args, sizeof args, "render " SCENE " " TINY " --spp 2 -o %s -o %s",
             test_path("good.exr"), test_path(name));
    refused(args, 5, "longer than");
    test_assert_file_is(test_path("good.exr"), good, n);

    /* The second, then the third output (the checkpoint) fails at its commit. */
    for (int k = 2; k <= 3; k++) {
        char env[64], err[4096];
        snprintf(env, sizeof env, "SPECTRACE_TEST_FAIL_OUTPUT=%d", k);
        snprintf(args, sizeof args, "render " SCENE " " TINY " --spp 2 -o %s -o %s --checkpoint %s",
                 test_path("good.exr"), test_path("new.png"), test_path("new_ck.exr"));
        int rc = run_env(env, args, err, sizeof err);
        if (rc != 5)
            fail_msg("exit %d, expected 5: %s", rc, err);
        test_one_error(err, "injected failure");
        test_assert_file_is(test_path("good.exr"), good, n);
        assert_false(test_exists(test_path("new.png")));
        assert_false(test_exists(test_path("new_ck.exr")));
    }
    assert_no_temporaries();
    free(good);
}

/* Outputs that name inputs are refused before rendering (exit 2), compared by
 * device and inode: the environment map (by name, through "x/..", through a
 * symbolic link), the scene under another name (a hard link), an SPD file, the
 * checkpoint being resumed; and two outputs naming one file. */
TEST(test_output_naming_input)
{
    size_t n;
    unsigned char *env = good_output("env.exr", &n);
    char args[2048];
    mkdir(test_path("sub"), 0755);
    const char *same[] = {"env.exr", "sub/../env.exr", "env_link.exr"};
    assert_int_equal(symlink("env.exr", test_path("env_link.exr")), 0);
    for (int i = 0; i < 3; i++) {
        snprintf(args, sizeof args, "render " SCENE " " TINY " --env %s -o %s", test_path("env.exr"),
                 test_path(same[i]));
        refused(args, 2, "is the input file");
    }
    test_assert_file_is(test_path("env.exr"), env, n);

    /* The scene, hard-linked under an image name. */
    size_t sn;
    unsigned char *scene = (unsigned char *)test_slurp(SCENE, &sn);
    FILE *f = fopen(test_path("scene.gltf"), "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(scene, 1, sn, f), sn);
    fclose(f);
    assert_int_equal(link(test_path("scene.gltf"), test_path("scene_alias.exr")), 0);
    snprintf(args, sizeof args, "render %s " TINY " -o %s", test_path("scene.gltf"),
             test_path("scene_alias.exr"));
    refused(args, 2, "is the input file");
    test_assert_file_is(test_path("scene.gltf"), scene, sn);
    free(scene);

    /* An SPD file of --background, hard-linked under an image name. */
    test_write_text(test_path("sky.csv"), "400,1\n700,1\n");
    assert_int_equal(link(test_path("sky.csv"), test_path("sky.hdr")), 0);
    snprintf(args, sizeof args, "render " SCENE " " TINY " --background %s -o %s",
             test_path("sky.csv"), test_path("sky.hdr"));
    refused(args, 2, "is the input file");

    /* The checkpoint being resumed, as an image output; the checkpoint as an image
     * output; two outputs naming one file. */
    char err[4096];
    snprintf(args, sizeof args, "render " SCENE " " TINY " -o %s --checkpoint %s",
             test_path("o.exr"), test_path("ck.exr"));
    assert_int_equal(run(args, err, sizeof err), 0);
    size_t cn;
    unsigned char *ck = (unsigned char *)test_slurp(test_path("ck.exr"), &cn);
    snprintf(args, sizeof args, "render " SCENE " " TINY " --spp 2 -o %s --resume %s",
             test_path("ck.exr"), test_path("ck.exr"));
    refused(args, 2, "being resumed");
    snprintf(args, sizeof args, "render " SCENE " " TINY " -o %s --checkpoint %s",
             test_path("ck.exr"), test_path("./ck.exr"));
    refused(args, 2, "name the same file");
    test_assert_file_is(test_path("ck.exr"), ck, cn);
    snprintf(args, sizeof args, "render " SCENE " " TINY " -o %s -o %s", test_path("two.exr"),
             test_path("sub/../two.exr"));
    refused(args, 2, "name the same file");
    assert_false(test_exists(test_path("two.exr")));
    assert_no_temporaries();
    free(ck);
    free(env);
}

/* An output that is a symbolic link stays one: the file it points to is
 * replaced. */
TEST(test_output_symlink_kept)
{
    size_t n;
    unsigned char *old = good_output("target.exr", &n);
    assert_int_equal(symlink("target.exr", test_path("via_link.exr")), 0);
    char args[1024], err[4096];
    snprintf(args, sizeof args, "render " SCENE " " TINY " --spp 3 -o %s", test_path("via_link.exr"));
    assert_int_equal(run(args, err, sizeof err), 0);
    struct stat st;
    assert_int_equal(lstat(test_path("via_link.exr"), &st), 0);
    assert_true(S_ISLNK(st.st_mode));
    size_t m;
    unsigned char *now = (unsigned char *)test_slurp(test_path("target.exr"), &m);
    assert_true(m != n || memcmp(now, old, n) != 0); /* 3 spp instead of 1 */
    free(now);
    free(old);
}

/* Inputs that are not regular files, or too large, are refused before they are
 * read (exit 3), without reading /dev/zero forever or a multi-gigabyte file. */
TEST(test_input_files)
{
    char args[1024];
    refused("info /dev/zero", 3, "character device");
    refused("render /dev/zero " TINY, 3, "character device");
    refused("color /dev/zero", 3, "character device");
    refused("color /dev/urandom", 3, "character device");
    snprintf(args, sizeof args, "render " SCENE " " TINY " --env /dev/zero -o %s", test_path("z.exr"));
    refused(args, 3, "environment map");
    assert_int_equal(symlink("/dev/zero", test_path("zero.exr")), 0);
    snprintf(args, sizeof args, "render " SCENE " " TINY " --resume %s -o %s", test_path("zero.exr"),
             test_path("z.exr"));
    refused(args, 3, "checkpoint");
    snprintf(args, sizeof args, "info %s", test_dir());
    refused(args, 3, "a folder");

    /* A sparse 3 GiB file: refused by its size, not read. */
    int fd = open(test_path("huge.glb"), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    assert_true(fd >= 0);
    assert_int_equal(ftruncate(fd, 3ll << 30), 0);
    close(fd);
    snprintf(args, sizeof args, "info %s", test_path("huge.glb"));
    refused(args, 3, "larger than the input limit of 2048 MiB");
    /* The limit moves with SPECTRACE_MAX_INPUT_MB. */
    char err[4096];
    assert_int_equal(run_env("SPECTRACE_MAX_INPUT_MB=1", "info " SCENE, err, sizeof err), 0);
    fd = open(test_path("two_mb.gltf"), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    assert_true(fd >= 0);
    assert_int_equal(ftruncate(fd, 2 << 20), 0);
    close(fd);
    snprintf(args, sizeof args, "info %s", test_path("two_mb.gltf"));
    assert_int_equal(run_env("SPECTRACE_MAX_INPUT_MB=1", args, err, sizeof err), 3);
    test_one_error(err, "input limit of 1 MiB");

    /* A FIFO is read, up to the same cap. */
    assert_int_equal(mkfifo(test_path("fifo.gltf"), 0644), 0);
    pid_t pid = fork();
    assert_true(pid >= 0);
    if (pid == 0) {
        size_t n;
        unsigned char *b = (unsigned char *)test_slurp(SCENE, &n);
        int w = open(test_path("fifo.gltf"), O_WRONLY);
        _exit(w >= 0 && write(w, b, n) == (ssize_t)n ? 0 : 1);
    }
    snprintf(args, sizeof args, "info %s", test_path("fifo.gltf"));
    assert_int_equal(run(args, err, sizeof err), 0);
    int st;
    waitpid(pid, &st, 0);
}

/* JSON nested 20,000 arrays deep (a stack overflow in the glTF library's
 * recursive conversion) is refused before parsing, in a .gltf and in a GLB. */
TEST(test_deep_json)
{
    const int depth = 20000;
    size_t cap = 64 + 2 * (size_t)depth + 8;
    char *json = malloc(cap);
    int len = snprintf(json, cap, "{\"asset\":{\"version\":\"2.0\"},\"extras\":");
    for (int i = 0; i < depth; i++)
        json[len++] = '[';
    for (int i = 0; i < depth; i++)
        json[len++] = ']';
    json[len++] = '}';
    while (len % 4)
        json[len++] = ' ';
    json[len] = 0;
    test_write_text(test_path("deep.gltf"), json);
    char args[1024];
    snprintf(args, sizeof args, "info %s", test_path("deep.gltf"));
    refused(args, 3, "nested more than");
    snprintf(args, sizeof args, "render %s " TINY " -o %s", test_path("deep.gltf"), test_path("d.exr"));
    refused(args, 3, "nested more than");

    FILE *f = fopen(test_path("deep.glb"), "wb");
    assert_non_null(f);
    unsigned hdr[5] = {0x46546C67u, 2, 20 + (unsigned)len, (unsigned)len, 0x4E4F534Au};
    fwrite(hdr, 4, 5, f);
    fwrite(json, 1, (size_t)len, f);
    fclose(f);
    snprintf(args, sizeof args, "info %s", test_path("deep.glb"));
    refused(args, 3, "nested more than");
    free(json);
}

/* Runs spectrace with args (split at spaces), waits until its stderr has a
 * line starting with wait_for, sends it the signals sigs[0..nsig) (the second
 * once then_on shows on stderr, the note that the first was caught; the rest at
 * once), then reads stderr to the end into err. Returns the exit status (-1:
 * killed by a signal). */
static int run_signalled_then(const char *args, const char *wait_for, const char *then_on,
                              const int *sigs, int nsig, char *err, size_t cap)
{
    TestChild c = {.wait_for = wait_for, .then_on = then_on, .sigs = sigs, .nsig = nsig};
    return test_run_child(args, &c, err, cap);
}

static int run_signalled(const char *args, const char *wait_for, const int *sigs, int nsig,
                         char *err, size_t cap)
{
    return run_signalled_then(args, wait_for, "note: stopping", sigs, nsig, err, cap);
}

/* SIGHUP is SIGTERM: after one chunk is done (its progress line), a render that
 * would take hours stops after its current chunk and writes what is complete. */
TEST(test_sighup_writes)
{
    char args[1024], err[16384];
    snprintf(args, sizeof args, "render " SCENE " --width 16 --spp 16777216 --device 0 -o %s",
             test_path("hup.exr"));
    int sig = SIGHUP;
    int rc = run_signalled(args, "render:", &sig, 1, err, sizeof err);
    if (rc != 0)
        fail_msg("exit %d, expected 0:\n%s", rc, err);
    assert_non_null(strstr(err, "stopped by a signal after"));
    assert_true(test_exists(test_path("hup.exr")));
}

/* The signal tests fix the path pool, so that which chunks are long (more
 * camera paths than SPT_LONG_CHUNK_POOLS pools) does not depend on the device. */
#define POOL "SPECTRACE_POOL"

/* A w x h render at 1 spp on device 0 into test_path(name), in pools of
 * 65536 paths (one long chunk), sent sigs (run_signalled_then: the first with
 * the device line, the second once then_on shows) stops with exit 130,
 * leaving no image and no temporary file; says_stopped: its stderr says
 * "error: render: stopped". */
static void stopped_unwritten(int w, int h, const char *name, const int *sigs, int nsig, const char *then_on,
                              int says_stopped)
{
    char args[1024], err[16384];
    snprintf(args, sizeof args, "render " SCENE " --width %d --height %d --spp 1 --device 0 -o %s", w, h,
             test_path(name));
    setenv(POOL, "65536", 1);
    int rc = run_signalled_then(args, "device 0:", then_on, sigs, nsig, err, sizeof err);
    unsetenv(POOL);
    if (rc != 130)
        fail_msg("exit %d, expected 130:\n%s", rc, err);
    if (says_stopped)
        assert_non_null(strstr(err, "error: render: stopped"));
    assert_false(test_exists(test_path(name)));
    assert_no_temporaries();
}

/* A first Ctrl-C drops a long chunk at once: a 2048x2048 render of one sample
 * per pixel is one chunk of 64 pools of 65536 (a minute on a loaded CPU); the
 * run stops within a wave of paths, with exit 130 and nothing written, as no
 * sample of every pixel is complete. (Had it waited for the chunk, it would
 * write the image with exit 0.) */
TEST(test_first_sigint_drops_long_chunk)
{
    const int sig = SIGINT;
    stopped_unwritten(2048, 2048, "long.exr", &sig, 1, "note: stopping", 1);
}

/* ... and writes the samples complete before it: 1024x640 at 2 spp is two
 * chunks of one sample (40 pools of 16384 each); SIGINT once the first is done
 * (its progress line). The run ends with exit 0 and an image whose every pixel
 * holds the same whole number of samples (the spp layer), the one its
 * spectrace:spp attribute and the note give: 1, or 2 had the second chunk
 * finished before the signal. */
TEST(test_first_sigint_writes_whole_samples)
{
    char args[1024], err[16384];
    const char *out = test_path("whole.exr");
    snprintf(args, sizeof args, "render " SCENE " --width 1024 --height 640 --spp 2 --aov spp "
             "--device 0 -o %s", out);
    setenv(POOL, "16384", 1);
    int sig = SIGINT;
    int rc = run_signalled(args, "render:", &sig, 1, err, sizeof err);
    unsetenv(POOL);
    if (rc != 0)
        fail_msg("exit %d, expected 0:\n%s", rc, err);
    const char *note = strstr(err, "stopped by a signal after ");
    assert_non_null(note);
    int done = atoi(note + strlen("stopped by a signal after "));
    assert_true(done == 1 || done == 2);
    ExrLayers L;
    SptError e = {0};
    static const char *want[] = {"R", "G", "B", "spp"};
    if (exr_read_layers(out, want, 4, &L, &e))
        fail_msg("%s", e.msg);
    assert_int_equal(L.width, 1024);
    assert_int_equal(L.height, 640);
    const ExrAttr *a = exr_layers_attr(&L, "spectrace:spp", SPT_EXR_ATTR_INT);
    assert_non_null(a);
    assert_int_equal(a->i, done);
    const float *spp = exr_layers_channel(&L, "spp")->data;
    const float *r = exr_layers_channel(&L, "R")->data;
    size_t npix = (size_t)1024 * 640, off = 0, bad = 0;
    for (size_t i = 0; i < npix; i++) {
        if (spp[i] != (float)done)
            off++;
        if (!(isfinite(r[i]) && r[i] >= 0.0f))
            bad++;
    }
    exr_layers_free(&L);
    if (off || bad)
        fail_msg("%zu pixels without %d samples, %zu not finite and >= 0", off, done, bad);
    assert_no_temporaries();
}

/* A second Ctrl-C stops at once: 1600x1280 at one sample per pixel is one
 * regular chunk (31 pools of 65536: seconds on a CPU); the first SIGINT waits
 * for it, the second drops it, so the run ends with exit 130 and nothing
 * written. (Without the second stop it would finish the chunk and write the
 * image with exit 0.) The device line comes while the devices open, so the
 * first signal may also land before rendering, which ends with exit 130 too;
 * the second then comes during the clean-up and must not kill the process. */
TEST(test_second_sigint_stops_at_once)
{
    const int sigs[2] = {SIGINT, SIGINT};
    stopped_unwritten(1600, 1280, "int.exr", sigs, 2, "note: stopping", 1);
}

/* A signal during the clean-up of a stopped run does not kill it: a long
 * chunk (as in test_first_sigint_drops_long_chunk) so that the first SIGINT,
 * with the device line, stops the run, and the second once the run has said
 * it stopped; the exit stays 130 and nothing is written. */
TEST(test_sigint_during_cleanup)
{
    const int sigs[2] = {SIGINT, SIGINT};
    stopped_unwritten(2048, 2048, "late.exr", sigs, 2, "error: render: stopped", 0);
}

/* OpenImageIO's library (libspectrace-oiio.so, src/io/oiio_lib.h) is loaded only
 * when an image other than EXR is read or written: without it (a folder that
 * does not hold it in SPECTRACE_OIIO_DIR) a PNG output fails before rendering
 * with one error line naming the output and exit 5, leaving the existing file
 * as it was, while an EXR-only render of an untextured scene succeeds. */
TEST(test_image_library_when_needed)
{
    char args[1024], err[16384];
    const char *png = test_path("lib.png"), *exr = test_path("lib.exr");
    FILE *f = fopen(png, "w");
    assert_non_null(f);
    fputs("keep", f);
    fclose(f);
    snprintf(args, sizeof args, "render " SCENE " " TINY " -o %s", png);
    int rc = run_env("SPECTRACE_OIIO_DIR=/nonexistent", args, err, sizeof err);
    if (rc != SPT_EXIT_OUTPUT)
        fail_msg("exit %d, expected %d:\n%s", rc, SPT_EXIT_OUTPUT, err);
    char want[512];
    snprintf(want, sizeof want, "error: %s: cannot load the image writer: "
             "libspectrace-oiio.so was not found", png);
    if (!strstr(err, want) || strstr(err, "device 0:"))
        fail_msg("expected one error before rendering, got:\n%s", err);
    size_t n;
    unsigned char *kept = (unsigned char *)test_slurp(png, &n);
    assert_true(n == 4 && !memcmp(kept, "keep", 4));
    free(kept);
    snprintf(args, sizeof args, "render " SCENE " " TINY " -o %s", exr);
    rc = run_env("SPECTRACE_OIIO_DIR=/nonexistent", args, err, sizeof err);
    if (rc != 0)
        fail_msg("EXR-only render: exit %d:\n%s", rc, err);
    assert_true(test_exists(exr));
    assert_no_temporaries();
}

/* Values the renderer's float arithmetic cannot carry are refused with the file,
 * the object and the value (they used to give a black image or NaN with exit 0):
 * a point light of 1e38 cd, an environment texel of 3e38, an SPD sample of
 * 1e308; a negative SPD sample is refused too. `color --` ends the options.
 * Each error names the file first (the light's check runs after loading). */
TEST(test_values_beyond_float)
{
    size_t n;
    unsigned char *text = (unsigned char *)test_slurp("tests/data/scenes/mat_point_light.gltf", &n);
    char *at = strstr((char *)text, "\"intensity\": 100000.0");
    assert_non_null(at);
    FILE *f = fopen(test_path("light.gltf"), "wb");
    assert_non_null(f);
    fwrite(text, 1, (size_t)(at - (char *)text), f);
    fputs("\"intensity\": 1e38", f);
    fputs(at + strlen("\"intensity\": 100000.0"), f);
    fclose(f);
    free(text);
    char args[1024];
    snprintf(args, sizeof args, "render %s " TINY " -o %s", test_path("light.gltf"), test_path("l.exr"));
    refused(args, 3, "light.gltf: extensions.KHR_lights_punctual.lights[0] ('lamp'): "
                     "intensity 1e+38 is too large");
    assert_false(test_exists(test_path("l.exr")));
    /* spectrace info describes the scene, then refuses the light as render does. */
    snprintf(args, sizeof args, "info %s", test_path("light.gltf"));
    refused(args, 3, "light.gltf: extensions.KHR_lights_punctual.lights[0] ('lamp'): "
                     "intensity 1e+38 is too large");

    float px[4 * 2 * 3];
    for (int i = 0; i < 24; i++)
        px[i] = 0.5f;
    px[7] = 3e38f;
    SptError e = {0};
    assert_int_equal(image_write(test_path("sun.exr"), px, 4, 2, NULL, NULL, &e), 0);
    snprintf(args, sizeof args, "render " SCENE " " TINY " --env %s -o %s", test_path("sun.exr"),
             test_path("s.exr"));
    refused(args, 3, "texel (2, 0) has the value 3e+38");

    test_write_text(test_path("huge.csv"), "400,1e308\n700,1e308\n");
    snprintf(args, sizeof args, "color %s", test_path("huge.csv"));
    refused(args, 3, "value 1e+308 is above 1e30");
    test_write_text(test_path("neg.csv"), "400,1\n550,-0.5\n700,1\n");
    snprintf(args, sizeof args, "render " SCENE " " TINY " --background %s -o %s", test_path("neg.csv"),
             test_path("n.exr"));
    refused(args, 3, "value -0.5 is negative");
    /* "--" ends the options: a file whose name starts with '-'. */
    test_write_text(test_path("-flat.csv"), "400,1\n700,1\n");
    char err[4096], cmd[2048];
    snprintf(cmd, sizeof cmd, "cd '%s' && '%s' color -- -flat.csv", test_dir(), test_exe());
    assert_int_equal(test_sh(cmd, TEST_STDERR, err, sizeof err), 0);
    assert_int_equal(strlen(err), 0);
}

/* A render whose film and outputs do not fit the host memory is refused before
 * any work with the amount and the limit (exit 4; SPECTRACE_MAX_MEMORY_MB stands
 * for a small machine), and nothing is written. */
TEST(test_host_memory_refused)
{
    char args[1024], err[4096];
    snprintf(args, sizeof args, "render " SCENE " --width 2048 --height 2048 --spp 1 -q --device 0 -o %s",
             test_path("mem.exr"));
    int rc = run_env("SPECTRACE_MAX_MEMORY_MB=64", args, err, sizeof err);
    if (rc != 4)
        fail_msg("exit %d, expected 4: %s", rc, err);
    test_one_error(err, "render: a 2048x2048 render needs about ");
    assert_non_null(strstr(err, "more than the 64.0 MiB available"));
    assert_false(test_exists(test_path("mem.exr")));
}

/* Inputs that libFuzzer found to crash, hang or exhaust memory in a reader
 * (tests/data/fuzz/TARGET/, README there): each is refused as bad input. */
TEST(test_fuzz_regressions)
{
    const char *folder = "tests/data/fuzz/checkpoint";
    DIR *d = opendir(folder);
    assert_non_null(d);
    int count = 0;
    struct dirent *de;
    while ((de = readdir(d))) {
        if (de->d_name[0] == '.' || !strstr(de->d_name, ".exr"))
            continue;
        char path[512];
        snprintf(path, sizeof path, "%s/%s", folder, de->d_name);
        CheckpointKey k;
        memset(&k, 0, sizeof k);
        Film film;
        unsigned char *done = NULL;
        SptError e = {0};
        int rc = checkpoint_read(path, &k, 16, &film, &done, &e);
        if (rc != SPT_EXIT_INPUT)
            fail_msg("%s: checkpoint_read returned %d (%s), expected %d", path, rc, e.msg,
                     SPT_EXIT_INPUT);
        count++;
    }
    closedir(d);
    assert_true(count >= 2);
}

TEST_MAIN("tests", test_dir_setup, test_dir_teardown)
