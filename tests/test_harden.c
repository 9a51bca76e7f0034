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

static char dir[64];

static const char *in_dir(const char *name)
{
    static char buf[8][512];
    static int k;
    k = (k + 1) % 8;
    snprintf(buf[k], sizeof buf[k], "%s/%s", dir, name);
    return buf[k];
}

/* Runs `timeout 120 $SPECTRACE_EXE args` (env: "VAR=value " prefixes, or "");
 * stderr into err (stdout discarded); returns the exit status (124: timed out,
 * -1: killed by a signal). */
static int run_env(const char *env, const char *args, char *err, size_t cap)
{
    const char *exe = getenv("SPECTRACE_EXE");
    if (!exe)
        fail_msg("SPECTRACE_EXE is not set (run through tests/run_tests.sh)");
    char cmd[4096];
    snprintf(cmd, sizeof cmd, "%s timeout -s KILL 120 '%s' %s 2>&1 >/dev/null", env, exe, args);
    FILE *p = popen(cmd, "r");
    assert_non_null(p);
    size_t n = fread(err, 1, cap - 1, p);
    err[n] = 0;
    int st = pclose(p);
    return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
}

static int run(const char *args, char *err, size_t cap)
{
    return run_env("", args, err, cap);
}

/* stderr is exactly one line, "error: ..." containing want. */
static void one_error(const char *err, const char *want)
{
    const char *nl = strchr(err, '\n');
    if (strncmp(err, "error: ", 7) != 0 || !nl || nl[1] != 0)
        fail_msg("expected one error line, got:\n%s", err);
    if (want && !strstr(err, want))
        fail_msg("expected '%s' in: %s", want, err);
}

/* The run fails with code and one error line naming want. */
static void refused(const char *args, int code, const char *want)
{
    char err[8192];
    int rc = run(args, err, sizeof err);
    if (rc != code)
        fail_msg("`%s`: exit %d, expected %d; stderr:\n%s", args, rc, code, err);
    one_error(err, want);
}

static unsigned char *slurp(const char *path, size_t *n)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        fail_msg("cannot read %s", path);
    fseek(f, 0, SEEK_END);
    long len = ftell(f);
    fseek(f, 0, SEEK_SET);
    unsigned char *b = malloc((size_t)len + 1);
    assert_int_equal(fread(b, 1, (size_t)len, f), (size_t)len);
    b[len] = 0;
    fclose(f);
    *n = (size_t)len;
    return b;
}

static void assert_same_file(const char *path, const unsigned char *want, size_t n)
{
    size_t m;
    unsigned char *got = slurp(path, &m);
    if (m != n || memcmp(got, want, n))
        fail_msg("%s changed", path);
    free(got);
}

static int exists(const char *path)
{
    struct stat st;
    return lstat(path, &st) == 0;
}

/* No temporary output file is left in the folder. */
static void assert_no_temporaries(void)
{
    DIR *d = opendir(dir);
    assert_non_null(d);
    struct dirent *de;
    while ((de = readdir(d)))
        if (strstr(de->d_name, ".spt-tmp-"))
            fail_msg("temporary file left: %s", de->d_name);
    closedir(d);
}

static void write_text(const char *path, const char *text)
{
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs(text, f);
    fclose(f);
}

/* A rendered image, the "existing output" the failing runs must not touch. */
static unsigned char *good_output(const char *name, size_t *n)
{
    char args[1024], err[4096];
    snprintf(args, sizeof args, "render " SCENE " " TINY " -o %s", in_dir(name));
    int rc = run(args, err, sizeof err);
    if (rc)
        fail_msg("the reference render failed (%d): %s", rc, err);
    return slurp(in_dir(name), n);
}

static int setup(void **state)
{
    (void)state;
    snprintf(dir, sizeof dir, "/tmp/spt_harden_XXXXXX");
    return mkdtemp(dir) ? 0 : -1;
}

static int teardown(void **state)
{
    (void)state;
    char cmd[128];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
    return system(cmd) == 0 ? 0 : -1;
}

/* A second output whose name is too long for the file system, or whose write fails
 * (a full disk, by the test hook), fails the run with exit 5 and leaves the first
 * output as it was: every output is written to a temporary file first and renamed
 * only when all were written. */
static void test_failed_output_keeps_others(void **state)
{
    (void)state;
    size_t n;
    unsigned char *good = good_output("good.exr", &n);
    char name[300], args[2048];
    memset(name, 'a', 252);
    snprintf(name + 252, sizeof name - 252, ".exr");
    snprintf(args, sizeof args, "render " SCENE " " TINY " --spp 2 -o %s -o %s",
             in_dir("good.exr"), in_dir(name));
    refused(args, 5, "longer than");
    assert_same_file(in_dir("good.exr"), good, n);

    /* The second, then the third output (the checkpoint) fails at its commit. */
    for (int k = 2; k <= 3; k++) {
        char env[64], err[4096];
        snprintf(env, sizeof env, "SPECTRACE_TEST_FAIL_OUTPUT=%d", k);
        snprintf(args, sizeof args, "render " SCENE " " TINY " --spp 2 -o %s -o %s --checkpoint %s",
                 in_dir("good.exr"), in_dir("new.png"), in_dir("new_ck.exr"));
        int rc = run_env(env, args, err, sizeof err);
        if (rc != 5)
            fail_msg("exit %d, expected 5: %s", rc, err);
        one_error(err, "injected failure");
        assert_same_file(in_dir("good.exr"), good, n);
        assert_false(exists(in_dir("new.png")));
        assert_false(exists(in_dir("new_ck.exr")));
    }
    assert_no_temporaries();
    free(good);
}

/* Outputs that name inputs are refused before rendering (exit 2), compared by
 * device and inode: the environment map (by name, through "x/..", through a
 * symbolic link), the scene under another name (a hard link), an SPD file, the
 * checkpoint being resumed; and two outputs naming one file. */
static void test_output_naming_input(void **state)
{
    (void)state;
    size_t n;
    unsigned char *env = good_output("env.exr", &n);
    char args[2048];
    mkdir(in_dir("sub"), 0755);
    const char *same[] = {"env.exr", "sub/../env.exr", "env_link.exr"};
    assert_int_equal(symlink("env.exr", in_dir("env_link.exr")), 0);
    for (int i = 0; i < 3; i++) {
        snprintf(args, sizeof args, "render " SCENE " " TINY " --env %s -o %s", in_dir("env.exr"),
                 in_dir(same[i]));
        refused(args, 2, "is the input file");
    }
    assert_same_file(in_dir("env.exr"), env, n);

    /* The scene, hard-linked under an image name. */
    size_t sn;
    unsigned char *scene = slurp(SCENE, &sn);
    FILE *f = fopen(in_dir("scene.gltf"), "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(scene, 1, sn, f), sn);
    fclose(f);
    assert_int_equal(link(in_dir("scene.gltf"), in_dir("scene_alias.exr")), 0);
    snprintf(args, sizeof args, "render %s " TINY " -o %s", in_dir("scene.gltf"),
             in_dir("scene_alias.exr"));
    refused(args, 2, "is the input file");
    assert_same_file(in_dir("scene.gltf"), scene, sn);
    free(scene);

    /* An SPD file of --background, hard-linked under an image name. */
    write_text(in_dir("sky.csv"), "400,1\n700,1\n");
    assert_int_equal(link(in_dir("sky.csv"), in_dir("sky.hdr")), 0);
    snprintf(args, sizeof args, "render " SCENE " " TINY " --background %s -o %s",
             in_dir("sky.csv"), in_dir("sky.hdr"));
    refused(args, 2, "is the input file");

    /* The checkpoint being resumed, as an image output; the checkpoint as an image
     * output; two outputs naming one file. */
    char err[4096];
    snprintf(args, sizeof args, "render " SCENE " " TINY " -o %s --checkpoint %s",
             in_dir("o.exr"), in_dir("ck.exr"));
    assert_int_equal(run(args, err, sizeof err), 0);
    size_t cn;
    unsigned char *ck = slurp(in_dir("ck.exr"), &cn);
    snprintf(args, sizeof args, "render " SCENE " " TINY " --spp 2 -o %s --resume %s",
             in_dir("ck.exr"), in_dir("ck.exr"));
    refused(args, 2, "being resumed");
    snprintf(args, sizeof args, "render " SCENE " " TINY " -o %s --checkpoint %s",
             in_dir("ck.exr"), in_dir("./ck.exr"));
    refused(args, 2, "name the same file");
    assert_same_file(in_dir("ck.exr"), ck, cn);
    snprintf(args, sizeof args, "render " SCENE " " TINY " -o %s -o %s", in_dir("two.exr"),
             in_dir("sub/../two.exr"));
    refused(args, 2, "name the same file");
    assert_false(exists(in_dir("two.exr")));
    assert_no_temporaries();
    free(ck);
    free(env);
}

/* An output that is a symbolic link stays one: the file it points to is
 * replaced. */
static void test_output_symlink_kept(void **state)
{
    (void)state;
    size_t n;
    unsigned char *old = good_output("target.exr", &n);
    assert_int_equal(symlink("target.exr", in_dir("via_link.exr")), 0);
    char args[1024], err[4096];
    snprintf(args, sizeof args, "render " SCENE " " TINY " --spp 3 -o %s", in_dir("via_link.exr"));
    assert_int_equal(run(args, err, sizeof err), 0);
    struct stat st;
    assert_int_equal(lstat(in_dir("via_link.exr"), &st), 0);
    assert_true(S_ISLNK(st.st_mode));
    size_t m;
    unsigned char *now = slurp(in_dir("target.exr"), &m);
    assert_true(m != n || memcmp(now, old, n) != 0); /* 3 spp instead of 1 */
    free(now);
    free(old);
}

/* Inputs that are not regular files, or too large, are refused before they are
 * read (exit 3), without reading /dev/zero forever or a multi-gigabyte file. */
static void test_input_files(void **state)
{
    (void)state;
    char args[1024];
    refused("info /dev/zero", 3, "character device");
    refused("render /dev/zero " TINY, 3, "character device");
    refused("color /dev/zero", 3, "character device");
    refused("color /dev/urandom", 3, "character device");
    snprintf(args, sizeof args, "render " SCENE " " TINY " --env /dev/zero -o %s", in_dir("z.exr"));
    refused(args, 3, "environment map");
    assert_int_equal(symlink("/dev/zero", in_dir("zero.exr")), 0);
    snprintf(args, sizeof args, "render " SCENE " " TINY " --resume %s -o %s", in_dir("zero.exr"),
             in_dir("z.exr"));
    refused(args, 3, "checkpoint");
    snprintf(args, sizeof args, "info %s", dir);
    refused(args, 3, "a folder");

    /* A sparse 3 GiB file: refused by its size, not read. */
    int fd = open(in_dir("huge.glb"), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    assert_true(fd >= 0);
    assert_int_equal(ftruncate(fd, 3ll << 30), 0);
    close(fd);
    snprintf(args, sizeof args, "info %s", in_dir("huge.glb"));
    refused(args, 3, "larger than the input limit of 2048 MiB");
    /* The limit moves with SPECTRACE_MAX_INPUT_MB. */
    char err[4096];
    assert_int_equal(run_env("SPECTRACE_MAX_INPUT_MB=1", "info " SCENE, err, sizeof err), 0);
    fd = open(in_dir("two_mb.gltf"), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    assert_true(fd >= 0);
    assert_int_equal(ftruncate(fd, 2 << 20), 0);
    close(fd);
    snprintf(args, sizeof args, "info %s", in_dir("two_mb.gltf"));
    assert_int_equal(run_env("SPECTRACE_MAX_INPUT_MB=1", args, err, sizeof err), 3);
    one_error(err, "input limit of 1 MiB");

    /* A FIFO is read, up to the same cap. */
    assert_int_equal(mkfifo(in_dir("fifo.gltf"), 0644), 0);
    pid_t pid = fork();
    assert_true(pid >= 0);
    if (pid == 0) {
        size_t n;
        unsigned char *b = slurp(SCENE, &n);
        int w = open(in_dir("fifo.gltf"), O_WRONLY);
        _exit(w >= 0 && write(w, b, n) == (ssize_t)n ? 0 : 1);
    }
    snprintf(args, sizeof args, "info %s", in_dir("fifo.gltf"));
    assert_int_equal(run(args, err, sizeof err), 0);
    int st;
    waitpid(pid, &st, 0);
}

/* JSON nested 20,000 arrays deep (a stack overflow in the glTF library's
 * recursive conversion) is refused before parsing, in a .gltf and in a GLB. */
static void test_deep_json(void **state)
{
    (void)state;
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
    write_text(in_dir("deep.gltf"), json);
    char args[1024];
    snprintf(args, sizeof args, "info %s", in_dir("deep.gltf"));
    refused(args, 3, "nested more than");
    snprintf(args, sizeof args, "render %s " TINY " -o %s", in_dir("deep.gltf"), in_dir("d.exr"));
    refused(args, 3, "nested more than");

    FILE *f = fopen(in_dir("deep.glb"), "wb");
    assert_non_null(f);
    unsigned hdr[5] = {0x46546C67u, 2, 20 + (unsigned)len, (unsigned)len, 0x4E4F534Au};
    fwrite(hdr, 4, 5, f);
    fwrite(json, 1, (size_t)len, f);
    fclose(f);
    snprintf(args, sizeof args, "info %s", in_dir("deep.glb"));
    refused(args, 3, "nested more than");
    free(json);
}

/* Runs $SPECTRACE_EXE with args (split at spaces), waits until its stderr has a
 * line starting with wait_for, sends it the signals sigs[0..nsig) (each once the
 * previous one's note is on stderr, or at once), then reads stderr to the end
 * into err. Returns the exit status (-1: killed by a signal). */
static int run_signalled_then(const char *args, const char *wait_for, const char *then_on,
                              const int *sigs, int nsig, char *err, size_t cap)
{
    char buf[2048];
    snprintf(buf, sizeof buf, "%s", args);
    char *argv[64];
    int argc = 0;
    argv[argc++] = getenv("SPECTRACE_EXE");
    for (char *save = NULL, *t = strtok_r(buf, " ", &save); t && argc < 63;
         t = strtok_r(NULL, " ", &save))
        argv[argc++] = t;
    argv[argc] = NULL;
    int fds[2];
    assert_int_equal(pipe(fds), 0);
    pid_t pid = fork();
    assert_true(pid >= 0);
    if (pid == 0) {
        dup2(fds[1], 2);
        close(fds[0]);
        close(fds[1]);
        int null = open("/dev/null", O_WRONLY);
        dup2(null, 1);
        alarm(300); /* a hang ends as SIGALRM, which fails the test */
        execv(argv[0], argv);
        _exit(127);
    }
    close(fds[1]);
    FILE *f = fdopen(fds[0], "r");
    size_t n = 0;
    int sent = 0, waiting = 1;
    char line[4096];
    err[0] = 0;
    while (fgets(line, sizeof line, f)) {
        size_t len = strlen(line);
        if (n + len < cap) {
            memcpy(err + n, line, len + 1);
            n += len;
        }
        if (waiting && !strncmp(line, wait_for, strlen(wait_for)))
            waiting = 0;
        /* The first signal once the awaited line is there, the next once the
         * line then_on shows (the handler's note: the first was caught). */
        if (!waiting && sent < nsig && (sent == 0 || !strncmp(line, then_on, strlen(then_on)))) {
            kill(pid, sigs[sent++]);
            while (sent < nsig && sent > 1)
                kill(pid, sigs[sent++]);
        }
    }
    fclose(f);
    int st;
    waitpid(pid, &st, 0);
    return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
}

static int run_signalled(const char *args, const char *wait_for, const int *sigs, int nsig,
                         char *err, size_t cap)
{
    return run_signalled_then(args, wait_for, "note: stopping", sigs, nsig, err, cap);
}

/* SIGHUP is SIGTERM: after one chunk is done (its progress line), a render that
 * would take hours stops after its current chunk and writes what is complete. */
static void test_sighup_writes(void **state)
{
    (void)state;
    char args[1024], err[16384];
    snprintf(args, sizeof args, "render " SCENE " --width 16 --spp 16777216 --device 0 -o %s",
             in_dir("hup.exr"));
    int sig = SIGHUP;
    int rc = run_signalled(args, "render:", &sig, 1, err, sizeof err);
    if (rc != 0)
        fail_msg("exit %d, expected 0:\n%s", rc, err);
    assert_non_null(strstr(err, "stopped by a signal after"));
    assert_true(exists(in_dir("hup.exr")));
}

/* The signal tests fix the path pool, so that which chunks are long (more
 * camera paths than SPT_LONG_CHUNK_POOLS pools) does not depend on the device. */
#define POOL "SPECTRACE_POOL"

/* A first Ctrl-C drops a long chunk at once: a 2048x2048 render of one sample
 * per pixel is one chunk of 64 pools of 65536 (a minute on a loaded CPU); the
 * run stops within a wave of paths, with exit 130 and nothing written, as no
 * sample of every pixel is complete. (Had it waited for the chunk, it would
 * write the image with exit 0.) */
static void test_first_sigint_drops_long_chunk(void **state)
{
    (void)state;
    char args[1024], err[16384];
    snprintf(args, sizeof args,
             "render " SCENE " --width 2048 --height 2048 --spp 1 --device 0 -o %s", in_dir("long.exr"));
    setenv(POOL, "65536", 1);
    int sig = SIGINT;
    int rc = run_signalled(args, "device 0:", &sig, 1, err, sizeof err);
    unsetenv(POOL);
    if (rc != 130)
        fail_msg("exit %d, expected 130:\n%s", rc, err);
    assert_non_null(strstr(err, "error: render: stopped"));
    assert_false(exists(in_dir("long.exr")));
    assert_no_temporaries();
}

/* ... and writes the samples complete before it: 1024x640 at 2 spp is two
 * chunks of one sample (40 pools of 16384 each); SIGINT once the first is done
 * (its progress line). The run ends with exit 0 and an image whose every pixel
 * holds the same whole number of samples (the spp layer), the one its
 * spectrace:spp attribute and the note give: 1, or 2 had the second chunk
 * finished before the signal. */
static void test_first_sigint_writes_whole_samples(void **state)
{
    (void)state;
    char args[1024], err[16384];
    const char *out = in_dir("whole.exr");
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
static void test_second_sigint_stops_at_once(void **state)
{
    (void)state;
    char args[1024], err[16384];
    snprintf(args, sizeof args,
             "render " SCENE " --width 1600 --height 1280 --spp 1 --device 0 -o %s", in_dir("int.exr"));
    setenv(POOL, "65536", 1);
    int sigs[2] = {SIGINT, SIGINT};
    int rc = run_signalled(args, "device 0:", sigs, 2, err, sizeof err);
    unsetenv(POOL);
    if (rc != 130)
        fail_msg("exit %d, expected 130:\n%s", rc, err);
    assert_non_null(strstr(err, "error: render: stopped"));
    assert_false(exists(in_dir("int.exr")));
    assert_no_temporaries();
}

/* A signal during the clean-up of a stopped run does not kill it: a long
 * chunk (as in test_first_sigint_drops_long_chunk) so that the first SIGINT,
 * with the device line, stops the run, and the second once the run has said
 * it stopped; the exit stays 130 and nothing is written. */
static void test_sigint_during_cleanup(void **state)
{
    (void)state;
    char args[1024], err[16384];
    snprintf(args, sizeof args,
             "render " SCENE " --width 2048 --height 2048 --spp 1 --device 0 -o %s", in_dir("late.exr"));
    setenv(POOL, "65536", 1);
    int sigs[2] = {SIGINT, SIGINT};
    int rc = run_signalled_then(args, "device 0:", "error: render: stopped", sigs, 2, err, sizeof err);
    unsetenv(POOL);
    if (rc != 130)
        fail_msg("exit %d, expected 130:\n%s", rc, err);
    assert_false(exists(in_dir("late.exr")));
    assert_no_temporaries();
}

/* OpenImageIO's library (libspectrace-oiio.so, src/io/oiio_lib.h) is loaded only
 * when an image other than EXR is read or written: without it (a folder that
 * does not hold it in SPECTRACE_OIIO_DIR) a PNG output fails before rendering
 * with one error line naming the output and exit 5, leaving the existing file
 * as it was, while an EXR-only render of an untextured scene succeeds. */
static void test_image_library_when_needed(void **state)
{
    (void)state;
    char args[1024], err[16384];
    const char *png = in_dir("lib.png"), *exr = in_dir("lib.exr");
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
    unsigned char *kept = slurp(png, &n);
    assert_true(n == 4 && !memcmp(kept, "keep", 4));
    free(kept);
    snprintf(args, sizeof args, "render " SCENE " " TINY " -o %s", exr);
    rc = run_env("SPECTRACE_OIIO_DIR=/nonexistent", args, err, sizeof err);
    if (rc != 0)
        fail_msg("EXR-only render: exit %d:\n%s", rc, err);
    assert_true(exists(exr));
    assert_no_temporaries();
}

/* Values the renderer's float arithmetic cannot carry are refused with the file,
 * the object and the value (they used to give a black image or NaN with exit 0):
 * a point light of 1e38 cd, an environment texel of 3e38, an SPD sample of
 * 1e308; a negative SPD sample is refused too. `color --` ends the options.
 * Each error names the file first (the light's check runs after loading). */
static void test_values_beyond_float(void **state)
{
    (void)state;
    size_t n;
    unsigned char *text = slurp("tests/data/scenes/mat_point_light.gltf", &n);
    char *at = strstr((char *)text, "\"intensity\": 100000.0");
    assert_non_null(at);
    FILE *f = fopen(in_dir("light.gltf"), "wb");
    assert_non_null(f);
    fwrite(text, 1, (size_t)(at - (char *)text), f);
    fputs("\"intensity\": 1e38", f);
    fputs(at + strlen("\"intensity\": 100000.0"), f);
    fclose(f);
    free(text);
    char args[1024];
    snprintf(args, sizeof args, "render %s " TINY " -o %s", in_dir("light.gltf"), in_dir("l.exr"));
    refused(args, 3, "light.gltf: extensions.KHR_lights_punctual.lights[0] ('lamp'): "
                     "intensity 1e+38 is too large");
    assert_false(exists(in_dir("l.exr")));
    /* spectrace info describes the scene, then refuses the light as render does. */
    snprintf(args, sizeof args, "info %s", in_dir("light.gltf"));
    refused(args, 3, "light.gltf: extensions.KHR_lights_punctual.lights[0] ('lamp'): "
                     "intensity 1e+38 is too large");

    float px[4 * 2 * 3];
    for (int i = 0; i < 24; i++)
        px[i] = 0.5f;
    px[7] = 3e38f;
    SptError e = {0};
    assert_int_equal(image_write(in_dir("sun.exr"), px, 4, 2, NULL, NULL, &e), 0);
    snprintf(args, sizeof args, "render " SCENE " " TINY " --env %s -o %s", in_dir("sun.exr"),
             in_dir("s.exr"));
    refused(args, 3, "texel (2, 0) has the value 3e+38");

    write_text(in_dir("huge.csv"), "400,1e308\n700,1e308\n");
    snprintf(args, sizeof args, "color %s", in_dir("huge.csv"));
    refused(args, 3, "value 1e+308 is above 1e30");
    write_text(in_dir("neg.csv"), "400,1\n550,-0.5\n700,1\n");
    snprintf(args, sizeof args, "render " SCENE " " TINY " --background %s -o %s", in_dir("neg.csv"),
             in_dir("n.exr"));
    refused(args, 3, "value -0.5 is negative");
    /* "--" ends the options: a file whose name starts with '-'. */
    write_text(in_dir("-flat.csv"), "400,1\n700,1\n");
    char err[4096], cmd[2048];
    snprintf(cmd, sizeof cmd, "cd '%s' && '%s' color -- -flat.csv 2>&1 >/dev/null", dir,
             getenv("SPECTRACE_EXE"));
    FILE *p = popen(cmd, "r");
    assert_non_null(p);
    size_t got = fread(err, 1, sizeof err - 1, p);
    err[got] = 0;
    assert_int_equal(pclose(p), 0);
    assert_int_equal(got, 0);
}

/* A render whose film and outputs do not fit the host memory is refused before
 * any work with the amount and the limit (exit 4; SPECTRACE_MAX_MEMORY_MB stands
 * for a small machine), and nothing is written. */
static void test_host_memory_refused(void **state)
{
    (void)state;
    char args[1024], err[4096];
    snprintf(args, sizeof args, "render " SCENE " --width 2048 --height 2048 --spp 1 -q --device 0 -o %s",
             in_dir("mem.exr"));
    int rc = run_env("SPECTRACE_MAX_MEMORY_MB=64", args, err, sizeof err);
    if (rc != 4)
        fail_msg("exit %d, expected 4: %s", rc, err);
    one_error(err, "render: a 2048x2048 render needs about ");
    assert_non_null(strstr(err, "more than the 64.0 MiB available"));
    assert_false(exists(in_dir("mem.exr")));
}

/* Inputs that libFuzzer found to crash, hang or exhaust memory in a reader
 * (tests/data/fuzz/TARGET/, README there): each is refused as bad input. */
static void test_fuzz_regressions(void **state)
{
    (void)state;
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

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_failed_output_keeps_others),
        cmocka_unit_test(test_output_naming_input),
        cmocka_unit_test(test_output_symlink_kept),
        cmocka_unit_test(test_input_files),
        cmocka_unit_test(test_deep_json),
        cmocka_unit_test(test_sighup_writes),
        cmocka_unit_test(test_first_sigint_drops_long_chunk),
        cmocka_unit_test(test_first_sigint_writes_whole_samples),
        cmocka_unit_test(test_second_sigint_stops_at_once),
        cmocka_unit_test(test_sigint_during_cleanup),
        cmocka_unit_test(test_image_library_when_needed),
        cmocka_unit_test(test_values_beyond_float),
        cmocka_unit_test(test_fuzz_regressions),
        cmocka_unit_test(test_host_memory_refused),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
