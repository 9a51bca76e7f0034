/* Adaptive sampling (src/render/adaptive.h): the per-pixel error estimate
 * against hand-computed values, the choice of pixels on synthetic films whose
 * answer is known, and renders: the first 16 samples are the plain render's,
 * every pixel's samples are the first of its own sequence (its value is the
 * plain render's at its own count), the counts are what the segments allow,
 * and the same render twice is the same image. */
#include "test_util.h"
#include "test_render_util.h"

#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

#include "color/spd.h"
#include "render/adaptive.h"
#include "render/film.h"
#include "render/render.h"
#include "scene/scene.h"

#define SCENE "tests/data/scenes/cornell_box_rgb.gltf"
#define W 32

/* Samples {1, 3} in every channel: mean 2, unbiased variance 2, so each
 * channel's error per sample is 2 / (4 + 0.01). Fewer than two samples, or
 * samples that agree, give 0. */
TEST(test_pixel_error)
{
    const double sum[3] = {4, 4, 4}, sq[3] = {10, 10, 10};
    assert_close(adaptive_pixel_error(sum, sq, 2.0), 2.0 / 4.01, 1e-12);
    const double sum2[3] = {4, 2, 0}, sq2[3] = {10, 2, 0}; /* {1,3}, {1,1}, {0,0} */
    assert_close(adaptive_pixel_error(sum2, sq2, 2.0), (2.0 / 4.01) / 3.0, 1e-12);
    assert_close(adaptive_pixel_error(sum, sq, 1.0), 0.0, 0.0);
}

/* A film of w x h pixels of n samples each with linear sRGB mean 0.5 and, per
 * channel, unbiased variance var(x) for the pixels of column x. */
static void synthetic_film(int w, int h, double n, double (*var)(int), double *xyz, double *count,
                           double *sq)
{
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            size_t i = (size_t)y * w + x;
            double rgb[3] = {0.5 * n, 0.5 * n, 0.5 * n};
            linear_srgb_to_xyz(rgb, xyz + 3 * i);
            count[i] = n;
            for (int k = 0; k < 3; k++)
                sq[3 * i + k] = var(x) * (n - 1.0) + 0.25 * n;
        }
}

static double var_halves(int x) { return x < 10 ? 0.1 : 0.001; }
static double var_even(int x) { (void)x; return 0.05; }
static double var_none(int x) { (void)x; return 0.0; }

/* Left half 100 times noisier than the right: beyond the estimate's
 * averaging radius (2 pixels) the left takes the segment and the right does
 * not. Every pixel alike: all take it. No noise anywhere: all take it (there
 * is nothing to choose by). A pixel without two samples takes it. */
TEST(test_mask)
{
    enum { w = 20, h = 10, n = w * h };
    double xyz[3 * n], count[n], sq[3 * n];
    uint32_t mask[n];
    synthetic_film(w, h, 16, var_halves, xyz, count, sq);
    count[5 * w + 15] = 1.0; /* right half, one sample */
    adaptive_mask(w, h, xyz, count, sq, 16, mask);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            if (x <= 7 || (y == 5 && x == 15))
                assert_int_equal(mask[y * w + x], 1);
            if (x >= 12 && !(y == 5 && x == 15))
                assert_int_equal(mask[y * w + x], 0);
        }
    synthetic_film(w, h, 16, var_even, xyz, count, sq);
    assert_int_equal(adaptive_mask(w, h, xyz, count, sq, 16, mask), n);
    synthetic_film(w, h, 16, var_none, xyz, count, sq);
    assert_int_equal(adaptive_mask(w, h, xyz, count, sq, 16, mask), n);
}

/* The Cornell box at W x W, spp samples, seed 5, adaptive or not, into film
 * (initialised here). */
static void render_box(int spp, int adaptive, Film *film)
{
    Scene s;
    test_load_scene(&s, SCENE);
    RenderSettings rs = square_settings(W, spp, 8, 5);
    rs.adaptive = adaptive ? SPT_SWITCH_ON : SPT_SWITCH_OFF;
    render_film_ok(&s, &rs, film);
    scene_free(&s);
}

static void assert_pixel_close(const float *a, const float *b, size_t i)
{
    for (int k = 0; k < 3; k++) {
        float x = a[3 * i + k], y = b[3 * i + k];
        if (!(fabsf(x - y) <= 1e-5f * fabsf(y) + 1e-7f))
            fail_msg("pixel %zu channel %d: %.9g against %.9g", i, k, x, y);
    }
}

TEST(test_render_prefixes)
{
    enum { n = W * W };
    Film plain[4], ad, ad2, first;
    float *rgb_plain[4], *rgb_ad = malloc(sizeof(float) * 3 * n), *rgb = malloc(sizeof(float) * 3 * n);
    for (int k = 0; k < 4; k++) {
        render_box(16 * (k + 1), 0, &plain[k]);
        rgb_plain[k] = malloc(sizeof(float) * 3 * n);
        film_to_linear_srgb(&plain[k], rgb_plain[k]);
    }
    /* The first segment is every pixel's first 16 samples. */
    render_box(16, 1, &first);
    film_to_linear_srgb(&first, rgb);
    for (size_t i = 0; i < n; i++) {
        assert_close(first.count[i], 16.0, 0.0);
        assert_pixel_close(rgb, rgb_plain[0], i);
    }
    /* 64 sample indices: [0, 16) for all, then [16, 32) and [32, 64) for the
     * pixels chosen, each pixel's as its next samples: a count of 16, 32, 48
     * or 64, and the plain render's value at that count. */
    render_box(64, 1, &ad);
    film_to_linear_srgb(&ad, rgb_ad);
    int seen[5] = {0};
    for (size_t i = 0; i < n; i++) {
        double c = ad.count[i];
        int k = (int)(c / 16.0);
        if (!(c == 16.0 * k && k >= 1 && k <= 4))
            fail_msg("pixel %zu: %g samples", i, c);
        seen[k]++;
        assert_pixel_close(rgb_ad, rgb_plain[k - 1], i);
    }
    printf("adaptive 64 on the Cornell box %dx%d: pixels of 16, 32, 48, 64 samples: %d %d %d %d\n", W,
           W, seen[1], seen[2], seen[3], seen[4]);
    assert_true(seen[4] > 0 && seen[4] < n);
    assert_true(seen[1] + seen[2] + seen[3] > 0);
    /* The same render again: the same image. */
    render_box(64, 1, &ad2);
    film_to_linear_srgb(&ad2, rgb);
    assert_memory_equal(rgb, rgb_ad, sizeof(float) * 3 * n);
    for (int k = 0; k < 4; k++) {
        film_free(&plain[k]);
        free(rgb_plain[k]);
    }
    film_free(&ad);
    film_free(&ad2);
    film_free(&first);
    free(rgb_ad);
    free(rgb);
}

/* `spectrace render ARGS -o OUT` with stderr captured: its exit code and the
 * first 511 bytes it printed. */
static int run_render(const char *args, const char *out, char *line, size_t size)
{
    char a[1024];
    snprintf(a, sizeof a, "render " SCENE " --width 8 -q %s -o %s", args, out);
    return test_spectrace("", 0, a, TEST_BOTH, line, size);
}

/* The command line: a bad value, and --adaptive on with a checkpoint (whose
 * film keeps no sums of squares) are refused with one error line and no
 * output; auto with --checkpoint renders without it. */
TEST(test_command_line)
{
    char out[64], ck[64], line[512];
    snprintf(out, sizeof out, "/tmp/spt-adaptive-%d.exr", (int)getpid());
    snprintf(ck, sizeof ck, "/tmp/spt-adaptive-ck-%d.exr", (int)getpid());
    const char *bad[] = {"--adaptive maybe", "--adaptive on --checkpoint /tmp/spt-adaptive-ck.exr"};
    for (int i = 0; i < 2; i++) {
        assert_int_equal(run_render(bad[i], out, line, sizeof line), SPT_EXIT_USAGE);
        printf("%s: %s", bad[i], line);
        assert_true(!strncmp(line, "error: ", 7) && strchr(line, '\n') == line + strlen(line) - 1);
        assert_non_null(strstr(line, "--adaptive"));
        assert_int_equal(access(out, F_OK), -1);
    }
    char args[256];
    snprintf(args, sizeof args, "--time 0.5 --checkpoint %s", ck);
    assert_int_equal(run_render(args, out, line, sizeof line), 0);
    assert_int_equal(access(out, F_OK), 0);
    unlink(out);
    unlink(ck);
}

TEST_MAIN("adaptive", setup_cpu_device, teardown_cpu_device)
