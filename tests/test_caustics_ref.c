/* The light-tracing pass (kernels/integrator/light_trace.h) against Mitsuba 3: a
 * faceted glass sphere (ior 1.5, radius 0.5 m, centre 1 m up) over a
 * Lambertian floor (albedo 0.8), seen from under the sphere by a camera looking
 * straight down (tests/data/scenes/caustic_sphere*.gltf,
 * tools/make_material_scenes.py), lit
 *
 * - by a spot light, against Mitsuba's particle tracer (ptracer): all in view
 *   lies in the sphere's shadow, lit through the glass only; also by a narrow
 *   spot whose beam the sphere focuses into the view's middle;
 * - by a square area light, against Mitsuba's path tracer (path) at a high
 *   sample count: the view's middle is lit through the glass only, its corners
 *   also directly (the penumbra), so the caustic comes from spectrace's light
 *   paths and the direct light from its camera paths, while Mitsuba's camera
 *   paths find both.
 *
 * Each reference (tests/data/mitsuba/caustic_sphere*_means.json, with the
 * command that wrote it) holds the means of the image's 4 x 4 blocks per linear
 * sRGB channel and their standard errors from the spread of its independent
 * passes. spectrace renders a few independent passes (seeds 1..runs) whose
 * spread gives its own standard errors, and each block and channel is compared
 * with Welch's test.
 *
 * Also: with another number of light paths per camera path than the default
 * (--light-paths), the image still does not depend on how the samples are
 * split. */
#include "film_test.h"
#include "test_util.h"
#include "test_render_util.h"

#define CS_W 64
#define CS_BLOCKS 48 /* 4 x 4 blocks x 3 channels */

/* Welch's statistic of two means with standard errors se_a and se_b. */
static double welch(double a, double se_a, double b, double se_b)
{
    return fabs(a - b) / sqrt(se_a * se_a + se_b * se_b);
}

/* Renders the scene file `scene` at CS_W x CS_W in `runs` independent passes
 * of spp samples (seeds 1..runs) with --caustics `caustics` and compares the
 * 4 x 4 block means with the Mitsuba reference `ref` ("max_depth_-1" entry)
 * by Welch's statistic |difference| / sqrt(se_ours^2 + se_ref^2). Returns the
 * largest statistic over the 48 blocks and channels; *img_rel is the largest
 * relative difference of the image means per channel and *img_t the largest
 * Welch statistic of the image means. */
static double welch_vs_mitsuba(const char *scene, const char *ref, int runs, int spp, int caustics,
                               double *img_rel, double *img_t, const char *what)
{
    double ref_mean[CS_BLOCKS], ref_se[CS_BLOCKS], ref_img[3], ref_img_se[3];
    assert_int_equal(json_numbers(ref, "\"max_depth_-1\"", "\"block_means_4x4\"", ref_mean, CS_BLOCKS), 0);
    assert_int_equal(json_numbers(ref, "\"max_depth_-1\"", "\"block_stderr_4x4\"", ref_se, CS_BLOCKS), 0);
    assert_int_equal(json_triple(ref, "\"max_depth_-1\"", "\"mean\"", ref_img), 0);
    assert_int_equal(json_triple(ref, "\"max_depth_-1\"", "\"stderr_of_mean\"", ref_img_se), 0);
    Scene s;
    GpuScene g;
    SptError e = {0};
    int rc = scene_load_gltf(&s, scene, &e);
    if (rc)
        fprintf(stderr, "load: %s\n", e.msg);
    assert_int_equal(rc, 0);
    assert_int_equal(gpu_scene_build(&g, &s, &e), 0);
    double sum[CS_BLOCKS] = {0}, sum2[CS_BLOCKS] = {0}, img[3] = {0}, img2[3] = {0};
    float *rgb = malloc((size_t)CS_W * CS_W * 3 * sizeof(float));
    for (int run = 0; run < runs; run++) {
        double run_img[3] = {0};
        RenderSettings rs = square_settings(CS_W, spp, -1, (uint32_t)(run + 1));
        rs.caustics = caustics;
        Film f;
        RenderStats st;
        film_init(&f, CS_W, CS_W);
        rc = render_device(device, &g, &s.camera, &rs, &f, &st, &e);
        if (rc)
            fprintf(stderr, "render: %s\n", e.msg);
        assert_int_equal(rc, 0);
        assert_int_equal(film_nonfinite_pixels(&f), 0);
        film_to_linear_srgb(&f, rgb);
        film_free(&f);
        double b[48];
        block_means_4x4(rgb, CS_W, b);
        for (int k = 0; k < 48; k++) {
            sum[k] += b[k];
            sum2[k] += b[k] * b[k];
            run_img[k % 3] += b[k] / 16.0;
        }
        for (int c = 0; c < 3; c++) {
            img[c] += run_img[c] / runs;
            img2[c] += run_img[c] * run_img[c];
        }
    }
    free(rgb);
    gpu_scene_free(&g);
    scene_free(&s);
    double worst = 0;
    int worst_k = 0;
    for (int k = 0; k < CS_BLOCKS; k++) {
        double m = sum[k] / runs;
        double var = fmax(0.0, (sum2[k] - runs * m * m) / (runs - 1));
        double se = sqrt(var / runs), t = welch(m, se, ref_mean[k], ref_se[k]);
        if (k % 3 == 1)
            printf("%s%8.4f (%+.2f%%, t %.2f)%s", k % 12 == 1 ? "  " : " ", m, 100.0 * (m / ref_mean[k] - 1.0),
                   t, k % 12 == 10 ? "\n" : "");
        assert_true(ref_se[k] > 0.0 && se > 0.0); /* every block sees light */
        if (t > worst) {
            worst = t;
            worst_k = k;
        }
    }
    *img_rel = *img_t = 0;
    for (int c = 0; c < 3; c++) {
        double se = sqrt(fmax(0.0, (img2[c] - runs * img[c] * img[c]) / (runs - 1)) / runs);
        *img_rel = fmax(*img_rel, fabs(img[c] / ref_img[c] - 1.0));
        *img_t = fmax(*img_t, welch(img[c], se, ref_img[c], ref_img_se[c]));
    }
    printf("%s (green block means above): image mean %.4f %.4f %.4f, Mitsuba %.4f %.4f %.4f (largest "
           "difference %.2f%%, Welch statistic %.2f); largest block Welch statistic %.2f (block %d, %d, "
           "channel %d)\n",
           what, img[0], img[1], img[2], ref_img[0], ref_img[1], ref_img[2], 100.0 * *img_rel, *img_t, worst,
           worst_k / 12, worst_k / 3 % 4, worst_k % 3);
    return worst;
}

/* The spot light against Mitsuba's particle tracer (16 passes of 512 spp):
 * 8 passes of 64 spp. Each block's statistic has about 7 to 15 degrees of
 * freedom (Student t: P(|t_7| > 6) is 5e-4, so 48 tests of a correct
 * renderer exceed 6 with about 2% probability; the seeds are fixed, so the
 * outcome is deterministic). */
#define CS_WELCH_BOUND 6.0

/* tests/data/scenes/NAME.gltf against tests/data/mitsuba/NAME_means.json: 8
 * passes of spp with the pass on; every block's Welch statistic below
 * CS_WELCH_BOUND, and the image mean within 1% (by_image_t 0) or its Welch
 * statistic below 4 (1). */
static void mitsuba_case(const char *name, int spp, int by_image_t, const char *what)
{
    char scene[256], ref[256];
    snprintf(scene, sizeof scene, "tests/data/scenes/%s.gltf", name);
    snprintf(ref, sizeof ref, "tests/data/mitsuba/%s_means.json", name);
    double rel, img_t;
    double t = welch_vs_mitsuba(scene, ref, 8, spp, SPT_SWITCH_ON, &rel, &img_t, what);
    assert_true(t < CS_WELCH_BOUND);
    if (by_image_t)
        assert_true(img_t < 4.0);
    else
        assert_true(rel < 0.01);
}

TEST(test_sphere_caustic_mitsuba)
{
    skip_if_quick();
    mitsuba_case("caustic_sphere", 64, 0, "spot light through the sphere vs Mitsuba ptracer");
}

/* The same sphere under a narrow spot (cones 1.5 and 2 degrees, a fifth of
 * its flux between the cones; tests/data/mitsuba/caustic_sphere_narrow_means.json,
 * whose converter sums nested Mitsuba spots to glTF's falloff), all of whose
 * beam goes through the sphere and lands focused in the view's middle: the
 * same passes, Welch bound and image mean bound as the wide spot. */
TEST(test_sphere_narrow_spot_mitsuba)
{
    skip_if_quick();
    mitsuba_case("caustic_sphere_narrow", 64, 0,
                 "narrow spot (1.5/2 degrees) through the sphere vs Mitsuba ptracer");
}

/* The area light against Mitsuba's path tracer (tests/data/mitsuba/
 * caustic_sphere_area_means.json: 16 passes of 2048 spp, block standard
 * errors 0.06-0.6%): 8 passes of 32 spp with the pass on (the light paths
 * carry the caustic, the camera paths the corners' direct light), block
 * standard errors about 0.5-3%, so the test's power is ours. Welch's
 * statistics as for the spot: the blocks below CS_WELCH_BOUND, the image
 * mean (one statistic per channel; P(|t_7| > 4) is 0.005) below 4. A glass of
 * ior 1.45 instead of 1.5 gives a block statistic of 16 (1.52: 5). */
TEST(test_sphere_area_light_mitsuba)
{
    skip_if_quick();
    mitsuba_case("caustic_sphere_area", 32, 1, "area light through the sphere vs Mitsuba path");
}

/* Light path k of sample index s is a function of (seed, k, s) whatever the
 * number of light paths per sample index, and a sample index's splats are
 * divided by that number: with 0.37 light paths per camera path (not a
 * divisor of the pixels), samples [0, 3) and [3, 8) add up to [0, 8), and a
 * small path pool (another schedule) gives the same film bit for bit. */
TEST(test_light_paths_split)
{
    Scene s;
    GpuScene g;
    SptError e = {0};
    assert_int_equal(scene_load_gltf(&s, "tests/data/scenes/caustic_sphere_area.gltf", &e), 0);
    assert_int_equal(gpu_scene_build(&g, &s, &e), 0);
    enum { W = 24 };
    const uint32_t begin[4] = {0, 0, 3, 0}, count[4] = {8, 3, 5, 8}, pool[4] = {0, 0, 0, 1000};
    Film f[4];
    for (int k = 0; k < 4; k++) {
        RenderSettings rs = square_settings(W, (int)count[k], -1, 5);
        rs.caustics = SPT_SWITCH_ON;
        rs.light_paths = 0.37f;
        rs.sample_begin = begin[k];
        rs.pool_size = pool[k];
        RenderStats st;
        film_init(&f[k], W, W);
        assert_int_equal(render_device(device, &g, &s.camera, &rs, &f[k], &st, &e), 0);
    }
    assert_split_films(f, "--light-paths 0.37, [0,8) vs [0,3) + [3,8)");
    for (int k = 0; k < 4; k++)
        film_free(&f[k]);
    gpu_scene_free(&g);
    scene_free(&s);
}

TEST_MAIN("tests", setup_cpu_device, teardown_cpu_device)
