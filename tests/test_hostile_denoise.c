/* Hostile input to --denoise, run as a user would ($SPECTRACE_EXE, set by
 * tests/run_tests.sh; every command under `timeout`, so a hang fails the test):
 * SPECTRACE_OIDN naming something that is not a regular file is refused at
 * once with one error line. */
#include "test_util.h"

#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "core/util.h"

#define BOX "tests/data/scenes/cornell_box_rgb.gltf"

static char dir[64];

static int setup(void **state)
{
    (void)state;
    snprintf(dir, sizeof dir, "/tmp/spt_hostile_denoise_XXXXXX");
    if (!mkdtemp(dir))
        return -1;
    return 0;
}

static int teardown(void **state)
{
    (void)state;
    char cmd[128];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
    return system(cmd) == 0 ? 0 : -1;
}

/* Runs `env timeout -s KILL secs $SPECTRACE_EXE args`, stderr into err (stdout
 * discarded); returns the exit status (-1: killed, as by the timeout). */
static int run_env(const char *env, int secs, const char *args, char *err, size_t cap)
{
    const char *exe = getenv("SPECTRACE_EXE");
    if (!exe)
        fail_msg("SPECTRACE_EXE is not set (run through tests/run_tests.sh)");
    char cmd[4096];
    snprintf(cmd, sizeof cmd, "%s timeout -s KILL %d '%s' %s 2>&1 >/dev/null", env, secs, exe, args);
    FILE *p = popen(cmd, "r");
    assert_non_null(p);
    size_t n = fread(err, 1, cap - 1, p);
    err[n] = 0;
    int st = pclose(p);
    return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
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

/* SPECTRACE_OIDN naming a FIFO (which dlopen would wait on for a writer), a
 * folder or a device file: one error line naming it, exit 2 (as for a file
 * that is not the library), at once and before rendering. */
static void test_oidn_not_regular_file(void **state)
{
    (void)state;
    char fifo[256], out[256], env[512], args[512], err[4096];
    snprintf(fifo, sizeof fifo, "%s/oidn.fifo", dir);
    assert_int_equal(mkfifo(fifo, 0600), 0);
    snprintf(out, sizeof out, "%s/x.exr", dir);
    const char *paths[] = {fifo, dir, "/dev/null"};
    for (int i = 0; i < 3; i++) {
        snprintf(env, sizeof env, "SPECTRACE_OIDN='%s'", paths[i]);
        snprintf(args, sizeof args, "render " BOX " --width 8 --spp 1 -q --device 0 --denoise -o %s", out);
        double t0 = spt_now();
        int rc = run_env(env, 10, args, err, sizeof err);
        double secs = spt_now() - t0;
        printf("SPECTRACE_OIDN=%s: exit %d after %.2f s: %s", paths[i], rc, secs, err);
        if (rc != SPT_EXIT_USAGE)
            fail_msg("SPECTRACE_OIDN=%s: exit %d, expected %d", paths[i], rc, SPT_EXIT_USAGE);
        one_error(err, paths[i]);
        if (!strstr(err, "regular file"))
            fail_msg("expected 'regular file' in: %s", err);
        struct stat st;
        assert_int_not_equal(stat(out, &st), 0);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_oidn_not_regular_file),
    };
    return cmocka_run_group_tests_name("hostile_denoise", tests, setup, teardown);
}
