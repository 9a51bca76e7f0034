/* Hostile runs for memory and time, run as a user would ($SPECTRACE_EXE, set by
 * tests/run_tests.sh): renders too big for the memory they may have (the
 * host-memory estimate against the memory a render really takes, and a limit
 * on the address space), `--time` against a cold kernel build, and a second
 * signal during that build. A cold build is made by an empty program cache
 * (SPECTRACE_CACHE_DIR) and, on PoCL, its own cache off (POCL_KERNEL_CACHE=0)
 * in a folder of the test's (POCL_CACHE_DIR: processes sharing PoCL's default
 * folder remove each other's temporary files). */
#include "test_util.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "core/util.h"
#include "io/exr.h"

#define SCENE "tests/data/scenes/furnace.gltf"



/* The environment of a cold kernel build: an empty cache folder of our own
 * and PoCL's (a new one per call). */
static void cold_cache(void)
{
    static int n;
    char c[512];
    snprintf(c, sizeof c, "%s/cache%d", test_dir(), n);
    setenv("SPECTRACE_CACHE_DIR", c, 1);
    snprintf(c, sizeof c, "%s/pocl%d", test_dir(), n++);
    setenv("POCL_CACHE_DIR", c, 1);
    setenv("POCL_KERNEL_CACHE", "0", 1);
}

static void warm_cache(const char *saved)
{
    setenv("SPECTRACE_CACHE_DIR", saved, 1);
    unsetenv("POCL_CACHE_DIR");
    unsetenv("POCL_KERNEL_CACHE");
}

/* The peak resident memory (ru_maxrss, KiB) of the last run_child. */
static long child_maxrss_kb;

/* Runs spectrace with args (test_run_child) in a child whose address space is
 * limited to as_bytes (0: no limit). Once its stderr has a line starting with
 * wait_for (NULL: never), it gets SIGINT, and a second SIGINT once the first
 * one's note shows; *t_second (may be NULL) gets the seconds from the second
 * signal to the exit. Returns the exit status (-1: killed by a signal). */
static int run_child(const char *args, unsigned long long as_bytes, const char *wait_for,
                     char *err, size_t cap, double *t_second)
{
    static const int sigs[2] = {SIGINT, SIGINT};
    TestChild c = {.as_bytes = as_bytes, .wait_for = wait_for, .then_on = "note: stopping",
                   .sigs = sigs, .nsig = 2};
    int rc = test_run_child(args, &c, err, cap);
    child_maxrss_kb = c.maxrss_kb;
    if (t_second)
        *t_second = c.t_second;
    return rc;
}

/* The lines of err that start with "error:"; fails unless there is exactly one
 * and it contains want. */
static void one_error_line(const char *err, const char *want)
{
    int count = 0;
    const char *line = NULL;
    for (const char *p = err; p && *p; p = strchr(p, '\n') ? strchr(p, '\n') + 1 : NULL)
        if (!strncmp(p, "error:", 6)) {
            count++;
            line = p;
        }
    if (count != 1)
        fail_msg("expected one error line, got %d:\n%s", count, err);
    const char *end = strchr(line, '\n');
    if (want && !(strstr(line, want) && (!end || strstr(line, want) < end)))
        fail_msg("expected '%s' in the error line:\n%s", want, err);
}

/* --time counts the render from its first sample, not from the start of the
 * kernel build: with a cold build (seconds on PoCL) and --time 1, the run ends
 * with exit 0 and an image of at least one sample in every pixel (its spp
 * layer), never with exit 130, which only a signal may cause. */
/* The sanitizer build cannot run what measures or limits the process's memory,
 * nor a cold kernel build to its exit: AddressSanitizer reserves terabytes of
 * address space for its shadow (so `ulimit -v` ends it at start) and counts
 * the shadow in the resident memory, and LeakSanitizer ends a process with a
 * fatal error after PoCL's cold build (tests/test_checkpoint.c says the same).
 * The plain build runs these tests. */
static void not_under_sanitizers(void)
{
#if defined(__SANITIZE_ADDRESS__)
    print_message("  skipped in the sanitizer build (shadow memory, LeakSanitizer after a cold build); "
                  "the plain build runs it\n");
    skip();
#endif
}

/* Runs args with SPECTRACE_MAX_MEMORY_MB=mb (stderr into err) and requires the
 * exit status want. */
static void run_memory_limited(const char *args, const char *mb, int want, char *err, size_t cap)
{
    setenv("SPECTRACE_MAX_MEMORY_MB", mb, 1);
    int rc = run_child(args, 0, NULL, err, cap, NULL);
    unsetenv("SPECTRACE_MAX_MEMORY_MB");
    if (rc != want)
        fail_msg("exit %d, expected %d:\n%s", rc, want, err);
}

TEST(test_time_excludes_cold_build)
{
    not_under_sanitizers();
    char saved[512], args[1024], err[16384];
    snprintf(saved, sizeof saved, "%s", getenv("SPECTRACE_CACHE_DIR") ? getenv("SPECTRACE_CACHE_DIR") : "");
    const char *out = test_path("time.exr");
    snprintf(args, sizeof args, "render " SCENE " --width 8 --spp 1000000 --time 1 --aov spp "
             "--device 0 -o %s", out);
    cold_cache();
    int rc = run_child(args, 0, NULL, err, sizeof err, NULL);
    warm_cache(saved);
    if (rc != 0)
        fail_msg("exit %d, expected 0:\n%s", rc, err);
    if (!strstr(err, "building the kernels"))
        fail_msg("the build was not cold:\n%s", err);
    ExrLayers L;
    SptError e = {0};
    static const char *want[] = {"R", "G", "B", "spp"};
    if (exr_read_layers(out, want, 4, &L, &e))
        fail_msg("%s", e.msg);
    const float *spp = exr_layers_channel(&L, "spp")->data;
    size_t npix = (size_t)L.width * L.height, low = 0;
    for (size_t i = 0; i < npix; i++)
        low += !(spp[i] >= 1.0f);
    exr_layers_free(&L);
    if (low)
        fail_msg("%zu of %zu pixels without a sample:\n%s", low, npix, err);
}

/* A second SIGINT during a cold kernel build stops the run at once: exit 130
 * with one error line, nothing written, no temporary output and nothing in the
 * program cache (the build given up is not stored). The build takes seconds on PoCL (more on the other
 * implementations); the run must end within 2 s of the second signal, which
 * it is sent once the first one's note shows. */
TEST(test_second_sigint_during_build)
{
    char saved[512], args[1024], err[16384];
    snprintf(saved, sizeof saved, "%s", getenv("SPECTRACE_CACHE_DIR") ? getenv("SPECTRACE_CACHE_DIR") : "");
    const char *out = test_path("int.exr");
    snprintf(args, sizeof args, "render " SCENE " --width 8 --spp 4 --device 0 -o %s", out);
    cold_cache();
    const char *cache = getenv("SPECTRACE_CACHE_DIR");
    char cache_dir[512];
    snprintf(cache_dir, sizeof cache_dir, "%s", cache);
    double t = 0.0;
    double t0 = test_now();
    int rc = run_child(args, 0, "device 0: building the kernels", err, sizeof err, &t);
    double total = test_now() - t0;
    warm_cache(saved);
    if (rc != 130)
        fail_msg("exit %d, expected 130 (%.2f s after the second signal):\n%s", rc, t, err);
    if (!(t >= 0.0))
        fail_msg("the run ended before the second signal:\n%s", err);
    one_error_line(err, "stopped by a second signal during the kernel build");
    if (t > 2.0)
        fail_msg("the run ended %.2f s after the second signal (%.2f s in all):\n%s", t, total, err);
    assert_false(test_exists(out));
    char cmd[1200];
    snprintf(cmd, sizeof cmd, "find '%s' -maxdepth 1 -name '*.spt-tmp-*' | grep -q . || "
             "find '%s' -type f 2>/dev/null | grep -q .", test_dir(), cache_dir);
    if (system(cmd) == 0)
        fail_msg("a temporary output in %s, or a file in the program cache %s", test_dir(), cache_dir);
}

/* The estimate of --profile's memory line ("memory: about N MiB|GiB ..."),
 * in MiB; fails when there is none. */
static double estimate_mib(const char *err)
{
    const char *m = strstr(err, "memory: about ");
    if (!m)
        fail_msg("no memory line:\n%s", err);
    double v = 0.0;
    char unit[8] = "";
    if (sscanf(m + 14, "%lf %7s", &v, unit) != 2)
        fail_msg("cannot read the memory line:\n%s", err);
    return !strcmp(unit, "GiB") ? v * 1024.0 : v;
}

/* A 2048x1024 (or w x h) map of constant grey 0.5 as EXR. */
static void write_map(const char *path, int w, int h)
{
    size_t n = (size_t)w * h * 3;
    float *rgb = malloc(n * sizeof(float));
    for (size_t i = 0; i < n; i++)
        rgb[i] = 0.5f;
    SptError e = {0};
    if (exr_write_rgb(path, rgb, w, h, NULL, 0, &e))
        fail_msg("%s", e.msg);
    free(rgb);
}

/* The host-memory estimate (printed by --profile) against the peak resident
 * memory the render really takes (ru_maxrss of the child): the difference
 * between a large and a tiny render of the same kind, which leaves out what
 * does not grow with the image (the program, PoCL, the compiler), must agree
 * within 25%, for a plain render, 47 spectral bands, every AOV, and an
 * environment map. The sizes keep each difference near 100-250 MiB, well
 * above the noise of the allocator: 1024x1024 plain, 512x512 with bands or
 * AOVs, and a 2048x1024 map against a 16x8 one (an 8x8 image), which is the
 * 16384x8192 map's texels, tables and device copy per texel at 1/64 of the
 * memory. Each render runs once before it is measured, so the compiler's
 * memory is in neither peak: the first builds the program when the cache
 * lacks it, and PoCL compiles a kernel again at its first launch on a large
 * grid (kept in PoCL's own cache; on the GPU code path this added 61 MiB to
 * the --aov all render). */
TEST(test_estimate_matches_rss)
{
    not_under_sanitizers();
    write_map(test_path("map_big.exr"), 2048, 1024);
    write_map(test_path("map_small.exr"), 16, 8);
    char env_small[600], env_big[600];
    snprintf(env_small, sizeof env_small, "--width 8 --height 8 --env %s", test_path("map_small.exr"));
    snprintf(env_big, sizeof env_big, "--width 8 --height 8 --env %s", test_path("map_big.exr"));
    const struct {
        const char *what, *tiny, *large;
    } kind[] = {
        {"plain", "--width 8 --height 8", "--width 1024 --height 1024"},
        {"--spectral 47", "--width 8 --height 8 --spectral 47", "--width 512 --height 512 --spectral 47"},
        {"--aov all", "--width 8 --height 8 --aov all", "--width 512 --height 512 --aov all"},
        {"--env 2048x1024", env_small, env_big},
    };
    int bad = 0;
    for (size_t k = 0; k < sizeof kind / sizeof kind[0]; k++) {
        double est[2], rss[2];
        /* Tiny and large to warm up, then tiny and large measured. */
        for (int r = 0; r < 4; r++) {
            char args[2048], err[16384];
            snprintf(args, sizeof args, "render " SCENE " %s --max-depth 1 --spp 1 --profile "
                     "--device 0 -o %s", r % 2 ? kind[k].large : kind[k].tiny, test_path("rss.exr"));
            int rc = run_child(args, 0, NULL, err, sizeof err, NULL);
            if (rc != 0)
                fail_msg("%s: exit %d:\n%s", kind[k].what, rc, err);
            if (r < 2)
                continue;
            est[r - 2] = estimate_mib(err);
            rss[r - 2] = child_maxrss_kb / 1024.0;
        }
        double de = est[1] - est[0], dr = rss[1] - rss[0];
        print_message("  %-16s estimate %7.1f MiB, peak RSS %7.1f MiB more than the tiny render "
                      "(%+.1f%%)\n", kind[k].what, de, dr, 100.0 * (de - dr) / dr);
        if (!(fabs(de - dr) <= 0.25 * dr))
            bad++;
    }
    if (bad)
        fail_msg("%d estimates off by more than 25%% of the memory measured", bad);
}

/* Under a limit on the address space (ulimit -v), a render that would pass it
 * is refused before any device work, with exit 4 and one error line giving the
 * amount and the limit, instead of an abort inside the OpenCL implementation
 * (SIGABRT, exit 134) or a failed allocation: --spectral 470 at 512x512 needs
 * about 1.9 GiB (a film of 470 bands in double, their device and host sums),
 * under a 2 GiB limit. */
TEST(test_address_space_limit)
{
    not_under_sanitizers();
    char args[1024], err[16384];
    snprintf(args, sizeof args, "render " SCENE " --width 512 --height 512 --spectral 470 --spp 1 -q "
             "--device 0 -o %s", test_path("as.exr"));
    int rc = run_child(args, 2ull << 30, NULL, err, sizeof err, NULL);
    if (rc != 4)
        fail_msg("exit %d, expected 4:\n%s", rc, err);
    one_error_line(err, "render: a 512x512 render needs about ");
    if (!strstr(err, "that the address-space limit (ulimit -v) leaves") || err[strlen(err) - 1] != '\n' ||
        strchr(err, '\n') != err + strlen(err) - 1)
        fail_msg("expected one line naming the address-space limit:\n%s", err);
    assert_false(test_exists(test_path("as.exr")));
}

/* Small amounts read in MiB, never "0.0 GiB": a 256x256 render (about 19 MiB)
 * under a limit of 1 MiB. */
TEST(test_small_amounts_in_mib)
{
    char args[1024], err[16384];
    snprintf(args, sizeof args, "render " SCENE " --width 256 --height 256 --spp 1 -q --device 0 -o %s",
             test_path("small.exr"));
    run_memory_limited(args, "1", 4, err, sizeof err);
    one_error_line(err, "MiB of host memory");
    if (!strstr(err, "more than the 1.0 MiB available") || strstr(err, "0.0 GiB"))
        fail_msg("expected the amounts in MiB:\n%s", err);
}

/* An environment map too big for the memory is an input too big: exit 3 with
 * one error line naming the file and its size, before its texels are read. A
 * 2048x1024 map takes about 104 MiB (texels, tables, a device's copy); the
 * limit is 20 MiB. */
TEST(test_env_map_too_big)
{
    const char *map = test_path("map_limit.exr");
    write_map(map, 2048, 1024);
    char args[1024], err[16384];
    snprintf(args, sizeof args, "render " SCENE " --env %s --width 8 --spp 1 -q --device 0 -o %s", map,
             test_path("env.exr"));
    run_memory_limited(args, "20", 3, err, sizeof err);
    char want[700];
    snprintf(want, sizeof want, "%s: a 2048x1024 environment map needs about ", map);
    one_error_line(err, want);
    assert_false(test_exists(test_path("env.exr")));
}

TEST_MAIN("tests", test_dir_setup, test_dir_teardown)
