/* spectrace render --frames (docs/gltf.md, "Frame sequences"): a 24-frame
 * turntable of the Cornell box (tests/data/anim/turntable.gltf, written by
 * tools/make_anim_scenes.py) rendered with one program build; each frame
 * whose BVH was built anew the image of the same frame rendered alone with
 * --at (bit for bit), and a refitted one the same picture with other noise (a
 * refit keeps the first frame's triangle order: test_refit_agrees); the names
 * the frames' files get; a frame that fails leaving the others; bad ranges
 * refused with one error line. */
#include "test_util.h"

#include <sys/stat.h>
#include <unistd.h>

#include "io/image_in.h"

#define TURNTABLE "tests/data/anim/turntable.gltf"
/* The word SMALL in run()'s arguments: a small render (on rusticl, whose
 * kernel launches take milliseconds each, and in the quick form elsewhere,
 * one sample of 16 x 16 pixels and paths of at most 3 segments). */
#define SMALL "SMALL"
static const char *small(void)
{
    return test_quick() ? "--width 16 --height 16 --spp 1 --max-depth 3 --caustics off --seed 5"
                        : "--width 32 --height 32 --spp 4 --seed 5";
}
#define FPS 24.0

static char dir[64];

static int make_dir(void **state)
{
    (void)state;
    snprintf(dir, sizeof dir, "/tmp/spt_frames_XXXXXX");
    return mkdtemp(dir) ? 0 : -1;
}

static int remove_dir(void **state)
{
    (void)state;
    char cmd[128];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
    return system(cmd) == 0 ? 0 : -1;
}

/* The pixels of image DIR/name (w x h). */
static float *pixels(const char *name, int *w, int *h)
{
    char path[512];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    float *px = NULL;
    SptError e = {0};
    if (image_read_rgb(path, &px, w, h, &e))
        fail_msg("%s: %s", path, e.msg);
    return px;
}

/* Whether images a and b (in dir) hold the same pixels, bit for bit. */
static int same_pixels(const char *a, const char *b)
{
    int wa, ha, wb, hb;
    float *pa = pixels(a, &wa, &ha), *pb = pixels(b, &wb, &hb);
    assert_int_equal(wa, wb);
    assert_int_equal(ha, hb);
    int same = !memcmp(pa, pb, sizeof(float) * 3 * (size_t)wa * (size_t)ha);
    free(pa);
    free(pb);
    return same;
}

/* Runs spectrace with env and args (DIR in args is the test's folder, SMALL
 * small()); fails the test unless it exits with want. Its stderr into err. */
static void run(const char *env, const char *args, int want, char *err, size_t cap)
{
    char full[2048];
    const char *p = args;
    size_t n = 0;
    while (*p && n < sizeof full - 80) {
        if (!strncmp(p, "DIR", 3)) {
            n += (size_t)snprintf(full + n, sizeof full - n, "%s", dir);
            p += 3;
        } else if (!strncmp(p, SMALL, 5)) {
            n += (size_t)snprintf(full + n, sizeof full - n, "%s", small());
            p += 5;
        } else {
            full[n++] = *p++;
        }
    }
    full[n] = 0;
    int rc = test_run_exe(env, 600, full, err, cap);
    if (rc != want)
        fail_msg("spectrace %s: exit %d, expected %d:\n%s", full, rc, want, err);
}

static int exists(const char *name)
{
    char path[512];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    return access(path, F_OK) == 0;
}

/* The 24 frames of a turn (at 24 frames per second) with one program build,
 * one line per frame, every BVH after the first refitted; the same frames with
 * every BVH built anew (the test hook) equal frames rendered alone with --at
 * at their times, bit for bit. */
TEST_FIXTURE(test_turntable, make_dir, remove_dir)
{
    static char err[1 << 16];
    run("", "render --frames 0:23 " SMALL " -o DIR/turn_####.exr " TURNTABLE, 0, err, sizeof err);
    printf("%s", err);
    assert_non_null(strstr(err, "rendered 24 of 24 frames"));
    assert_non_null(strstr(err, "(1 program build)"));
    int lines = 0, refits = 0;
    for (const char *l = err; (l = strstr(l, "\nframe ")); l++) {
        lines++;
        const char *nl = strchr(l + 1, '\n');
        const char *r = strstr(l, "BVH refitted");
        refits += r && (!nl || r < nl);
    }
    lines += strncmp(err, "frame ", 6) == 0; /* the first line, with -q's device line gone */
    assert_int_equal(lines, 24);
    assert_int_equal(refits, 23);
    run("SPECTRACE_TEST_BVH_REBUILD=1", "render -q --frames 0:23 " SMALL " -o DIR/built_##.exr "
        TURNTABLE, 0, err, sizeof err);
    char a[64], b[64], args[512];
    int differ = 0;
    for (int f = 0; f < 24; f++) {
        snprintf(a, sizeof a, "turn_%04d.exr", f);
        snprintf(b, sizeof b, "built_%02d.exr", f);
        differ += !same_pixels(a, b);
    }
    /* A refitted BVH packs the triangles in the first frame's order, so the
     * emitters are listed (and chosen by the same random numbers) in another
     * order, and rays that meet two triangles at the same distance may take
     * the other: other noise, the same picture (test_refit_agrees). */
    printf("%d of 24 frames with a refitted BVH differ from those with a built one\n", differ);
    assert_false(exists("turn_0024.exr"));
    /* Alone, at the frame's time written as the sequence writes it: the
     * frames whose BVH was built. */
    static const int alone[] = {0, 1, 7, 13, 23};
    for (size_t i = 0; i < sizeof alone / sizeof alone[0]; i++) {
        int f = alone[i];
        snprintf(args, sizeof args, "render -q --at %.17g " SMALL " -o DIR/alone.exr " TURNTABLE,
                 f / FPS);
        run("", args, 0, err, sizeof err);
        snprintf(a, sizeof a, "built_%02d.exr", f);
        if (!same_pixels(a, "alone.exr"))
            fail_msg("frame %d differs from the frame rendered alone at --at %.17g", f, f / FPS);
    }
    /* The frames are not all one image: the contents turn. */
    assert_false(same_pixels("turn_0000.exr", "turn_0007.exr"));
}

/* Frames whose BVH was refitted and the same frames with it built anew agree:
 * the means of 8 x 8-pixel blocks (4096 samples each) of the two renders of
 * frames 3 and 6 within 10% of each other (or 0.005 where dark), and the
 * images' means within 2%. A refit that left a moved triangle's box where it
 * was loses the turning block and spheres in part of the image. */
TEST_FIXTURE(test_refit_agrees, make_dir, remove_dir)
{
    skip_if_quick(); /* the refit is host code: the full form's PoCL run tests it */
    static char err[1 << 16];
    const char *args = "render -q --frames 0:6:3 --width 32 --height 32 --spp 64 --seed 9 "
                       "-o DIR/%s_#.exr " TURNTABLE;
    char a[512];
    snprintf(a, sizeof a, args, "refit");
    run("", a, 0, err, sizeof err);
    snprintf(a, sizeof a, args, "built");
    run("SPECTRACE_TEST_BVH_REBUILD=1", a, 0, err, sizeof err);
    for (int f = 3; f <= 6; f += 3) {
        char na[64], nb[64];
        snprintf(na, sizeof na, "refit_%d.exr", f);
        snprintf(nb, sizeof nb, "built_%d.exr", f);
        int w, h;
        float *ra = pixels(na, &w, &h), *rb = pixels(nb, &w, &h);
        assert_int_equal(w, 32);
        /* Block (bx, by) channel c at 3 (4 by + bx) + c. */
        double ba[48] = {0}, bb[48] = {0}, ma = 0, mb = 0, worst = 0;
        for (int p = 0; p < 32 * 32; p++)
            for (int c = 0; c < 3; c++) {
                int i = 3 * (4 * (p / 32 / 8) + p % 32 / 8) + c;
                ba[i] += ra[3 * p + c] / 64.0;
                bb[i] += rb[3 * p + c] / 64.0;
            }
        for (int i = 0; i < 48; i++) {
            ma += ba[i] / 48;
            mb += bb[i] / 48;
            double d = fabs(ba[i] - bb[i]) / fmax(0.05, bb[i]);
            worst = fmax(worst, d);
            if (fabs(ba[i] - bb[i]) > fmax(0.005, 0.1 * bb[i]))
                fail_msg("frame %d block %d channel %d: %.4f refitted, %.4f built", f, i / 3,
                         i % 3, ba[i], bb[i]);
        }
        printf("frame %d: mean %.4f refitted, %.4f built; largest block difference %.3f\n", f,
               ma, mb, worst);
        assert_close_rel(ma, mb, 0.02);
        free(ra);
        free(rb);
    }
}

/* --animation and --camera per frame: the "orbit" camera swinging about the
 * box while the "turn" animation stays at rest; each frame the image of the
 * same frame alone. */
TEST_FIXTURE(test_camera_animation, make_dir, remove_dir)
{
    static char err[1 << 16];
    run("", "render --frames 0:22:11 --animation orbit --camera orbit " SMALL
        " -o DIR/orbit_###.exr " TURNTABLE, 0, err, sizeof err);
    printf("%s", err);
    assert_non_null(strstr(err, "rendered 3 of 3 frames"));
    assert_true(exists("orbit_000.exr") && exists("orbit_011.exr") && exists("orbit_022.exr"));
    assert_false(exists("orbit_001.exr"));
    char a[64], args[512];
    for (int f = 0; f <= 22; f += 11) {
        snprintf(args, sizeof args,
                 "render -q --at %.17g --animation orbit --camera orbit " SMALL
                 " -o DIR/alone.exr " TURNTABLE, f / FPS);
        run("", args, 0, err, sizeof err);
        snprintf(a, sizeof a, "orbit_%03d.exr", f);
        if (!same_pixels(a, "alone.exr"))
            fail_msg("orbit frame %d differs from the frame rendered alone", f);
    }
    assert_false(same_pixels("orbit_000.exr", "orbit_011.exr"));
}

/* File names: the last run of #s takes the frame number, padded to its
 * length (or longer); a name without # gets four digits before its extension;
 * --checkpoint names follow the same rule, one checkpoint per frame. */
TEST_FIXTURE(test_names, make_dir, remove_dir)
{
    static char err[1 << 16];
    run("", "render -q --frames 8:10:2 " SMALL " -o DIR/a_#.png -o DIR/b.exr -o DIR/c#_##.png "
        "--checkpoint DIR/ck_####.exr " TURNTABLE, 0, err, sizeof err);
    static const char *want[] = {"a_8.png", "a_10.png", "b0008.exr", "b0010.exr", "c#_08.png",
                                 "c#_10.png", "ck_0008.exr", "ck_0010.exr"};
    for (size_t i = 0; i < sizeof want / sizeof want[0]; i++)
        if (!exists(want[i]))
            fail_msg("%s/%s was not written", dir, want[i]);
    assert_false(exists("a_9.png"));
    assert_false(exists("b0009.exr"));
    /* Each frame resumes its own checkpoint: both are complete, so nothing is
     * rendered again and the images are those of the first run. */
    run("", "render --frames 8:10:2 " SMALL " -o DIR/r_#.exr --resume DIR/ck_####.exr "
        TURNTABLE, 0, err, sizeof err);
    printf("%s", err);
    assert_true(same_pixels("r_8.exr", "b0008.exr"));
    assert_true(same_pixels("r_10.exr", "b0010.exr"));
}

/* A frame that fails (its output is a link to the scene file, which it would
 * destroy) is reported and the others are written; the run ends with that
 * frame's exit code (2) and a line naming it. */
TEST_FIXTURE(test_failed_frame, make_dir, remove_dir)
{
    static char err[1 << 16];
    char link[256], real[4096];
    assert_non_null(realpath(TURNTABLE, real));
    snprintf(link, sizeof link, "%s/f_1.png", dir);
    assert_int_equal(symlink(real, link), 0);
    run("", "render -q --frames 0:2 " SMALL " -o DIR/f_#.png " TURNTABLE, 2, err, sizeof err);
    printf("%s", err);
    assert_true(exists("f_0.png") && exists("f_2.png"));
    struct stat st;
    assert_int_equal(lstat(link, &st), 0);
    assert_true(S_ISLNK(st.st_mode));
    assert_non_null(strstr(err, "error: render: 1 of 3 frames failed (frame 1); the others were "
                                "written"));
    assert_non_null(strstr(err, "is the input file"));
}

/* Bad ranges: one error line naming the option, exit 2, nothing written. */
TEST_FIXTURE(test_bad_ranges, make_dir, remove_dir)
{
    static const char *bad[] = {"5:2", "1:2:0", "a:b", "1", "1:2:3:4", "-1:2", "1:10000000",
                                "1:2:", ":2", "1:2x"};
    char args[512], err[4096];
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        snprintf(args, sizeof args, "render --frames '%s' -o DIR/x_#.png " TURNTABLE, bad[i]);
        run("", args, 2, err, sizeof err);
        char want[64];
        snprintf(want, sizeof want, "--frames '%s'", bad[i]);
        test_one_error(err, want);
    }
    run("", "render --frames 0:1 --at 0.5 -o DIR/x_#.png " TURNTABLE, 2, err, sizeof err);
    test_one_error(err, "cannot be combined with --at");
    run("", "render --frames 0:1 --fps 0 -o DIR/x_#.png " TURNTABLE, 2, err, sizeof err);
    test_one_error(err, "--fps '0'");
    assert_false(exists("x_0.png"));
}

TEST_MAIN("frames", NULL, NULL)
