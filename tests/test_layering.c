/* tools/check_includes.sh: the host's folders include only from their own
 * folder or from folders after them in the pipeline order of
 * docs/architecture.md ("Source layout"). The tree must pass; a copy of it
 * with one include planted against that order must fail, naming the file and
 * the include, so the check can fail. Run from the source root (as
 * tests/run_tests.sh does). */
#include "test_util.h"

#include <unistd.h>

/* Runs the shell command cmd, its stdout and stderr into out; returns its exit
 * status (-1 when it did not exit). */
static int sh(const char *cmd, char *out, size_t cap)
{
    char full[4096];
    snprintf(full, sizeof full, "( %s ) 2>&1", cmd);
    FILE *p = popen(full, "r");
    assert_non_null(p);
    size_t n = fread(out, 1, cap - 1, p);
    out[n] = 0;
    int st = pclose(p);
    return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
}

/* A copy of src/ and docs/architecture.md in a new temporary folder (dir). */
static void copy_tree(char *dir, size_t cap)
{
    snprintf(dir, cap, "/tmp/spt-layering-XXXXXX");
    assert_non_null(mkdtemp(dir));
    char cmd[1024], out[4096];
    snprintf(cmd, sizeof cmd, "cp -r src '%s/src' && mkdir '%s/docs' && cp docs/architecture.md '%s/docs/'",
             dir, dir, dir);
    assert_int_equal(sh(cmd, out, sizeof out), 0);
}

static void remove_tree(const char *dir)
{
    char cmd[1024], out[256];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
    assert_int_equal(sh(cmd, out, sizeof out), 0);
}

/* Appends the line text to file (relative to dir) and runs the check on dir:
 * returns its status, its output in out. */
static int check_planted(const char *dir, const char *file, const char *text, char *out, size_t cap)
{
    char cmd[2048];
    snprintf(cmd, sizeof cmd, "printf '%%s\\n' '%s' >> '%s/%s' && tools/check_includes.sh '%s'", text,
             dir, file, dir);
    return sh(cmd, out, cap);
}

static void test_tree_passes(void **state)
{
    (void)state;
    char out[8192];
    int rc = sh("tools/check_includes.sh", out, sizeof out);
    if (rc != 0)
        fail_msg("tools/check_includes.sh exited %d:\n%s", rc, out);
    assert_string_equal(out, "");
}

/* core/ is the last step: an include of render/ from it is against the order. */
static void test_include_from_above_fails(void **state)
{
    (void)state;
    char dir[64], out[8192];
    copy_tree(dir, sizeof dir);
    int rc = check_planted(dir, "src/core/util.h", "#include \"render/render.h\"", out, sizeof out);
    remove_tree(dir);
    assert_int_equal(rc, 1);
    assert_non_null(strstr(out, "src/core/util.h:"));
    assert_non_null(strstr(out, "\"render/render.h\""));
}

/* io/ and cl/ share a step: neither comes after the other. */
static void test_include_across_one_step_fails(void **state)
{
    (void)state;
    char dir[64], out[8192];
    copy_tree(dir, sizeof dir);
    int rc = check_planted(dir, "src/cl/cl_device.c", "#include \"io/image_out.h\"", out, sizeof out);
    remove_tree(dir);
    assert_int_equal(rc, 1);
    assert_non_null(strstr(out, "src/cl/cl_device.c:"));
    assert_non_null(strstr(out, "\"io/image_out.h\""));
}

/* An include from later in the order (render/ -> core/) is allowed, and an
 * include through ".." is refused whatever its folder. */
static void test_include_order_and_dotdot(void **state)
{
    (void)state;
    char dir[64], out[8192];
    copy_tree(dir, sizeof dir);
    int ok = check_planted(dir, "src/render/film.c", "#include \"core/util.h\"", out, sizeof out);
    int dotdot = check_planted(dir, "src/scene/scene.c", "#include \"../core/util.h\"", out, sizeof out);
    remove_tree(dir);
    assert_int_equal(ok, 0);
    assert_int_equal(dotdot, 1);
    assert_non_null(strstr(out, "src/scene/scene.c:"));
    assert_non_null(strstr(out, "\"../core/util.h\""));
}

/* Without the pipeline line in the docs the check cannot run, and says so. */
static void test_missing_order_line(void **state)
{
    (void)state;
    char dir[64], out[8192], cmd[1024];
    copy_tree(dir, sizeof dir);
    snprintf(cmd, sizeof cmd, "sed -i '/^pipeline: /d' '%s/docs/architecture.md' && tools/check_includes.sh '%s'",
             dir, dir);
    int rc = sh(cmd, out, sizeof out);
    remove_tree(dir);
    assert_int_equal(rc, 2);
    assert_non_null(strstr(out, "pipeline"));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_tree_passes),
        cmocka_unit_test(test_include_from_above_fails),
        cmocka_unit_test(test_include_across_one_step_fails),
        cmocka_unit_test(test_include_order_and_dotdot),
        cmocka_unit_test(test_missing_order_line),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
