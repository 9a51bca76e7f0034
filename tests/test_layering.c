/* tools/check_includes.sh: the host's folders include only from their own
 * folder or from folders after them in the pipeline order of
 * docs/architecture.md ("Source layout"). The tree must pass; a copy of it
 * with one include planted against that order must fail, naming the file and
 * the include, so the check can fail. Run from the source root (as
 * tests/run_tests.sh does). */
#include "test_util.h"

#include <unistd.h>

/* Runs the shell command cmd through system(), its stdout and stderr into out
 * (by way of a temporary file); returns its exit status (-1 when it did not
 * exit). */
static int sh(const char *cmd, char *out, size_t cap)
{
    char log[] = "/tmp/spt-layering-log-XXXXXX";
    int fd = mkstemp(log);
    assert_true(fd >= 0);
    close(fd);
    char full[4096];
    snprintf(full, sizeof full, "( %s ) > '%s' 2>&1", cmd, log);
    int st = system(full);
    FILE *f = fopen(log, "r");
    assert_non_null(f);
    out[fread(out, 1, cap - 1, f)] = 0;
    fclose(f);
    unlink(log);
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

TEST(test_tree_passes)
{
    char out[8192];
    int rc = sh("tools/check_includes.sh", out, sizeof out);
    if (rc != 0)
        fail_msg("tools/check_includes.sh exited %d:\n%s", rc, out);
    assert_string_equal(out, "");
}

/* Includes against the order, each planted alone in a fresh copy: core/ is
 * the last step, so render/ is before it; io/ and cl/ share a step, so neither
 * comes after the other. The check must fail, naming the file and the include. */
TEST(test_include_against_order_fails)
{
    static const struct {
        const char *file, *include;
    } cases[] = {
        {"src/core/util.h", "render/render.h"},
        {"src/cl/cl_device.c", "io/image_out.h"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        char dir[64], out[8192], line[256], where[256];
        copy_tree(dir, sizeof dir);
        snprintf(line, sizeof line, "#include \"%s\"", cases[i].include);
        int rc = check_planted(dir, cases[i].file, line, out, sizeof out);
        remove_tree(dir);
        if (rc != 1)
            fail_msg("%s including %s: exit %d, expected 1:\n%s", cases[i].file, cases[i].include,
                     rc, out);
        snprintf(where, sizeof where, "%s:", cases[i].file);
        assert_non_null(strstr(out, where));
        assert_non_null(strstr(out, cases[i].include));
    }
}

/* An include from later in the order (render/ -> core/) is allowed, and an
 * include through ".." is refused whatever its folder. */
TEST(test_include_order_and_dotdot)
{
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
TEST(test_missing_order_line)
{
    char dir[64], out[8192], cmd[1024];
    copy_tree(dir, sizeof dir);
    snprintf(cmd, sizeof cmd, "sed -i '/^pipeline: /d' '%s/docs/architecture.md' && tools/check_includes.sh '%s'",
             dir, dir);
    int rc = sh(cmd, out, sizeof out);
    remove_tree(dir);
    assert_int_equal(rc, 2);
    assert_non_null(strstr(out, "pipeline"));
}

TEST_MAIN("tests", NULL, NULL)
