/* `spectrace color`: output format, values against published white points and the
 * colour-science ColorChecker data, and its errors. Runs the program at
 * $SPECTRACE_EXE (set by tests/run_tests.sh). */
#include "test_util.h"

#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

/* Runs `$SPECTRACE_EXE args` with stdout (and, when merge, stderr) captured into out;
 * returns the exit status. */
static int run(const char *args, int merge, char *out, size_t cap)
{
    return test_spectrace("", 0, args, merge ? TEST_BOTH : TEST_STDOUT, out, cap);
}

/* Parses the three lines exactly; fails when the format differs. */
static void parse3(const char *out, double xyz[3], double rgb[3], int rgb8[3])
{
    char tail[8];
    int used = 0;
    if (sscanf(out, "XYZ %lf %lf %lf\nlinear-sRGB %lf %lf %lf\nsRGB8 %d %d %d\n%n", &xyz[0], &xyz[1],
               &xyz[2], &rgb[0], &rgb[1], &rgb[2], &rgb8[0], &rgb8[1], &rgb8[2], &used) != 9 ||
        out[used] != 0 || sscanf(out + used, "%7s", tail) == 1)
        fail_msg("unexpected output:\n%s", out);
    /* Six decimals on every value: "d.dddddd". */
    const char *p = out;
    int values = 0;
    while ((p = strchr(p, '.'))) {
        int d = 0;
        while (p[1 + d] >= '0' && p[1 + d] <= '9')
            d++;
        if (d != 6)
            fail_msg("a value without six decimals in:\n%s", out);
        values++;
        p++;
    }
    assert_int_equal(values, 6);
}

/* D65 and A normalised to Y = 1 print their published white points (CIE 15:2004). */
TEST(test_white_points)
{
    char out[4096];
    double xyz[3], rgb[3];
    int r8[3];
    assert_int_equal(run("color D65", 0, out, sizeof out), 0);
    parse3(out, xyz, rgb, r8);
    assert_close(xyz[0], 0.95047, 1e-3);
    assert_close(xyz[1], 1.0, 1e-9);
    assert_close(xyz[2], 1.08883, 1e-3);
    for (int k = 0; k < 3; k++) {
        assert_close(rgb[k], 1.0, 1e-3);
        assert_int_equal(r8[k], 255);
    }
    assert_int_equal(run("color a", 0, out, sizeof out), 0);
    parse3(out, xyz, rgb, r8);
    assert_close(xyz[0], 1.09850, 1e-3);
    assert_close(xyz[2], 0.35585, 1e-3);
    /* linear red > 1 clamps to 255 */
    assert_int_equal(r8[0], 255);
}

/* --reflectance with a ColorChecker CSV gives colour-science's XYZ and sRGB8. */
TEST(test_reflectance)
{
    char out[4096];
    double xyz[3], rgb[3];
    int r8[3];
    /* patch 7, orange, from tests/data/colour/colorchecker_expected.csv */
    assert_int_equal(run("color --reflectance tests/data/colour/colorchecker/07.csv", 0, out,
                         sizeof out),
                     0);
    parse3(out, xyz, rgb, r8);
    assert_close_rel(xyz[0], 0.3645759, 2e-3);
    assert_close_rel(xyz[1], 0.2933021, 2e-3);
    assert_close_rel(xyz[2], 0.0590810, 2e-3);
    assert_in_range(r8[0], 217, 219);
    assert_in_range(r8[1], 122, 124);
    assert_in_range(r8[2], 41, 43);
}

/* Other names run and print the format. */
TEST(test_names)
{
    const char *names[] = {"F2", "F7", "F11", "mercury", "blackbody:2856", "BLACKBODY:6500"};
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++) {
        char args[128], out[4096];
        double xyz[3], rgb[3];
        int r8[3];
        snprintf(args, sizeof args, "color %s", names[i]);
        assert_int_equal(run(args, 0, out, sizeof out), 0);
        parse3(out, xyz, rgb, r8);
        assert_close(xyz[1], 1.0, 1e-9);
    }
}

/* Checks one failing run: the exit code and exactly one `error:` line containing
 * want. */
static void expect_error(const char *args, int code, const char *want)
{
    char out[4096];
    assert_int_equal(run(args, 1, out, sizeof out), code);
    if (strncmp(out, "error: ", 7) || strchr(out, '\n') != out + strlen(out) - 1 || !strstr(out, want))
        fail_msg("'%s': expected one error line containing '%s', got:\n%s", args, want, out);
}

/* Errors: unknown name, unreadable file, bad CSV line, usage. */
TEST(test_errors)
{
    expect_error("color D66", 3, "D66");
    expect_error("color /nonexistent/spd.csv", 3, "/nonexistent/spd.csv: cannot read");
    expect_error("color tests", 3, "tests: the SPD file is a folder");
    expect_error("color blackbody:hot", 3, "blackbody:hot");
    char path[] = "/tmp/spt_color_XXXXXX";
    int fd = mkstemp(path);
    assert_true(fd >= 0);
    FILE *f = fdopen(fd, "w");
    fputs("wavelength_nm,value\n500,1\n510 2\n", f);
    fclose(f);
    char args[128], want[128];
    snprintf(args, sizeof args, "color %s", path);
    snprintf(want, sizeof want, "%s: line 3", path);
    expect_error(args, 3, want);
    unlink(path);
    expect_error("color", 2, "no SPD");
    expect_error("color --bogus D65", 2, "--bogus");
    expect_error("color D65 A", 2, "one SPD");
    char out[8192];
    assert_int_equal(run("color --help", 0, out, sizeof out), 0);
    assert_non_null(strstr(out, "usage: spectrace color"));
    assert_non_null(strstr(out, "--reflectance"));
}

TEST_MAIN("color_cmd", NULL, NULL)
