/* The light-tracing pass with an environment map as a light
 * (kernels/integrator/light_trace.h, --caustics; docs/architecture.md,
 * "Caustics"): light paths that start on a disc outside the scene that covers
 * its glass, parallel to a direction of the map, and the camera paths that
 * drop the map they see through a delta vertex after a non-delta first
 * vertex. A uniform sky stays the camera paths'.
 *
 * The furnace: under a uniform sky of radiance L, a scene made only of white
 * Lambertian surfaces (albedo 1, both sides) and clear lossless glass (closed,
 * flat faces) has radiance L everywhere outside the glass: a uniform field is
 * a solution of the rendering equation there (a white Lambertian surface sends
 * back the L it receives from every direction; a smooth dielectric interface
 * sends R L + T L = L, the n^2 inside the glass cancelling on the way out), and
 * the only one, since light escapes. A white floor under a raised glass slab
 * (and a white roof over half of them) therefore shows the sky's radiance
 * everywhere, also right under the slab,
 * where much of it is the sky seen through the glass by the floor: paths
 * camera - floor - glass ... glass - sky, which the light paths own with the
 * pass on under a map (here a flat one, of the same radiance everywhere).
 * Counting those twice, or by neither technique, moves that part of the floor
 * far from L.
 *
 * Also: a glass sphere over a grey floor under a map with a bright patch (a
 * sun), with the pass on and off at the same samples, block by block (Welch's
 * test over seeds); --caustics auto runs the pass for a map but not for a
 * uniform sky; the light paths' splats do not depend on the path pool. */
#include "test_util.h"
#include "test_render_util.h"

#include "scene/sky.h"

/* The slab: clear smooth glass of index 1.5 over [-1.5, 1.5] x [SLAB_BOTTOM,
 * SLAB_TOP] x [-1.5, 1.5] above a 4 x 4 m floor at y = 0. */
#define SLAB_BOTTOM 0.6f
#define SLAB_TOP 0.8f
#define ROOF_Y 3.0f

enum { VIEW_UNDER, VIEW_THROUGH };

/* The furnace scene: the white floor, the glass slab, a white roof over half
 * of them and a camera. VIEW_UNDER:
 * under the slab's level, from the side, at the floor's centre (its rays meet
 * the floor first, so every path has a non-delta first vertex); VIEW_THROUGH:
 * from above, through the slab's top (paths whose first vertex is glass, the
 * camera paths' with the pass on too) and past its edge. */
static void furnace_scene(Scene *s, int view)
{
    memset(s, 0, sizeof *s);
    const float floor_c[4][3] = {{-2, 0, -2}, {-2, 0, 2}, {2, 0, 2}, {2, 0, -2}};
    SceneMaterial *fl = append_rect(s, floor_c);
    for (int k = 0; k < 3; k++)
        fl->base_color[k] = 1.0f;
    const float lo[3] = {-1.5f, SLAB_BOTTOM, -1.5f}, hi[3] = {1.5f, SLAB_TOP, 1.5f};
    set_clear_glass(append_box(s, lo, hi), 1.5f);
    /* A white roof over half of it, facing down, outside the glass's
     * bounding sphere (radius 2.13 m about (0, 0.7, 0)) but inside the
     * scene's: the sky's light paths start outside the scene, so they meet it
     * as the camera paths do (from a disc tangent to the glass's sphere they
     * would pass it by). */
    const float roof_c[4][3] = {{-3, ROOF_Y, -3}, {0.5f, ROOF_Y, -3}, {0.5f, ROOF_Y, 3}, {-3, ROOF_Y, 3}};
    SceneMaterial *rf = append_rect(s, roof_c);
    for (int k = 0; k < 3; k++)
        rf->base_color[k] = 1.0f;
    if (view == VIEW_UNDER)
        aim_camera(s, 0.5, 2.5, 0.5, 2.5, 0.35f);
    else
        aim_camera(s, 2.0, 2.6, 2.0, 2.0, 0.9f);
}

/* Renders s with rs into rgb (linear sRGB, w x w x 3). */
static void render_rgb(const Scene *s, const RenderSettings *rs, float *rgb)
{
    SptError e = {0};
    int rc = render_scene_rgb(s, rs, rgb, &e);
    if (rc)
        fail_msg("render: %s", e.msg);
}

/* The uniform sky of linear sRGB (1, 1, 1): D65 of radiance 1, Y = 1. */
static Sky white_sky(void)
{
    Sky sky;
    memset(&sky, 0, sizeof sky);
    sky.kind = SPT_SKY_RGB;
    sky.rgb[0] = sky.rgb[1] = sky.rgb[2] = 1.0f;
    return sky;
}

/* A map of FW x FH texels of linear sRGB (1, 1, 1): the same sky, sampled by
 * the map's distribution. */
enum { FW = 16, FH = 8 };
static float flat_map[FW * FH * 3];

/* The sky of the w x h map of linear sRGB texels (borrowed, not freed). */
static Sky map_sky(float *map, int w, int h)
{
    Sky sky = {.kind = SPT_SKY_MAP, .map = map, .map_width = w, .map_height = h};
    return sky;
}

static Sky flat_map_sky(void)
{
    for (int i = 0; i < FW * FH * 3; i++)
        flat_map[i] = 1.0f;
    return map_sky(flat_map, FW, FH);
}

/* The furnace of view under sky with --caustics mode: the mean of each
 * linear sRGB channel over the image against 1 (within 1%), and the mean of
 * the green channel over each of the 4 x 4 blocks, within 5 standard errors
 * of 1 (or 1%), the standard error from the spread of the block's pixels,
 * whose expected values are all 1. The light paths spread the sky's light
 * thinly over the floor (1-4% noise in a block at 512 samples). Under the
 * slab they own 40-55% of the floor's radiance (the slab fills much of its
 * sky, weighted by the cosine): counting that share twice puts the floor's
 * blocks at 1.39-1.55, losing it at 0.47-0.61, and light paths from a disc
 * tangent to the glass's bounding sphere (which passes the roof by) at
 * 1.28-1.42. */
static void check_furnace(int view, const Sky *sky, int caustics, int spp, const char *what)
{
    enum { W = 32, B = 4, NP = W * W / (B * B) };
    Scene s;
    furnace_scene(&s, view);
    RenderSettings rs = square_settings(W, spp, -1, 3);
    rs.caustics = caustics;
    rs.sky = sky;
    float *rgb = malloc(sizeof(float) * 3 * W * W);
    render_rgb(&s, &rs, rgb);
    scene_free(&s);
    double all[3] = {0}, m[B * B] = {0}, m2[B * B] = {0};
    for (int py = 0; py < W; py++)
        for (int px = 0; px < W; px++) {
            const float *c = rgb + 3 * (py * W + px);
            for (int k = 0; k < 3; k++)
                all[k] += c[k] / (W * W);
            int b = (py * B / W) * B + px * B / W;
            m[b] += c[1] / NP;
            m2[b] += (double)c[1] * c[1] / NP;
        }
    free(rgb);
    double worst = 0, worst_z = 0;
    int bad = 0;
    for (int b = 0; b < B * B; b++) {
        double se = sqrt(fmax(m2[b] - m[b] * m[b], 0.0) / (NP - 1));
        double z = fabs(m[b] - 1.0) / fmax(se, 0.002);
        if (z > worst_z) {
            worst_z = z;
            worst = m[b] - 1.0;
        }
        printf("%s%.4f (%.4f)%s", b % B ? " " : "  ", m[b], se, b % B == B - 1 ? "\n" : "");
        bad += !(fabs(m[b] - 1.0) < fmax(5.0 * se, 0.01));
    }
    printf("%s: mean %.4f %.4f %.4f (expected 1), blocks (standard errors) above, furthest off %+.2f%% "
           "(%.1f standard errors)\n", what, all[0], all[1], all[2], 100.0 * worst, worst_z);
    assert_int_equal(bad, 0);
    for (int k = 0; k < 3; k++)
        assert_close_rel(all[k], 1.0, 0.01);
}

/* The furnace with the pass on, seen under the slab: a flat map (the light
 * paths' directions by the map's sampling), then the uniform sky of the same
 * radiance (the camera paths keep it whole), and through the slab's top. The
 * camera paths alone agree (off). */
TEST(test_sky_furnace)
{
    Sky map = flat_map_sky();
    check_furnace(VIEW_UNDER, &map, SPT_SWITCH_ON, 512, "furnace under the slab, flat map, on");
    skip_if_quick();
    Sky sky = white_sky();
    check_furnace(VIEW_UNDER, &sky, SPT_SWITCH_ON, 128, "furnace under the slab, uniform sky, on");
    check_furnace(VIEW_THROUGH, &map, SPT_SWITCH_ON, 512, "furnace through the slab, flat map, on");
    check_furnace(VIEW_UNDER, &map, SPT_SWITCH_OFF, 128, "furnace under the slab, flat map, off");
}

/* --caustics auto runs the pass when the only light is a map: the image is
 * bit for bit the one of --caustics on, and not that of off; a smaller path
 * pool (other paths in flight, other orders of the light film's atomics)
 * gives the same image bit for bit; and under the default white sky auto
 * renders as off. */
TEST(test_sky_auto_and_pool)
{
    skip_if_quick();
    enum { W = 16, N = 6 };
    Scene s;
    furnace_scene(&s, VIEW_UNDER);
    Sky map = flat_map_sky();
    float *img[N];
    const int mode[N] = {SPT_SWITCH_AUTO, SPT_SWITCH_ON, SPT_SWITCH_OFF, SPT_SWITCH_ON,
                         SPT_SWITCH_AUTO, SPT_SWITCH_OFF};
    for (int k = 0; k < N; k++) {
        RenderSettings rs = square_settings(W, 8, -1, 5);
        rs.caustics = mode[k];
        rs.sky = k < 4 ? &map : NULL;
        if (k == 3)
            rs.pool_size = 1000;
        img[k] = malloc(sizeof(float) * 3 * W * W);
        render_rgb(&s, &rs, img[k]);
    }
    scene_free(&s);
    size_t n = sizeof(float) * 3 * W * W;
    assert_memory_equal(img[0], img[1], n);
    assert_memory_not_equal(img[1], img[2], n);
    assert_memory_equal(img[1], img[3], n);
    assert_memory_equal(img[4], img[5], n);
    for (int k = 0; k < N; k++)
        free(img[k]);
}

/* A glass sphere (tests/data/scenes/caustic_sphere.gltf without its spot
 * light: radius 0.5 m, 1 m up, a floor of albedo 0.8, the camera under the
 * sphere looking down) under a map of a dim blue sky with a bright warm patch
 * 15 degrees from the zenith, whose caustic falls in view. With the pass on
 * and off, SS_RUNS renders each (seeds 1.. and 101..) of SS_SPP samples; each
 * side's block means over the runs and their standard errors from the runs'
 * spread; Welch's statistic per block and channel (48 of them, about 10
 * degrees of freedom: P(|t_10| > 6) is 1.3e-4, so a correct renderer exceeds
 * the bound with under 1% probability; the seeds are fixed). */
#define SS_W 48
#define SS_SPP 32
#define SS_RUNS 6
#define SS_WELCH_BOUND 6.0
enum { SMW = 64, SMH = 32 };
static float sun_map[SMW * SMH * 3];

static Sky sun_sky(void)
{
    const double sun[3] = {sin(0.26), cos(0.26), 0.0};
    for (int y = 0; y < SMH; y++)
        for (int x = 0; x < SMW; x++) {
            /* The direction of the texel's centre (lights.h's convention). */
            double th = M_PI * (y + 0.5) / SMH, ph = 2.0 * M_PI * (x + 0.5) / SMW;
            double d[3] = {-sin(ph) * sin(th), cos(th), cos(ph) * sin(th)};
            int hot = d[0] * sun[0] + d[1] * sun[1] + d[2] * sun[2] > 0.985;
            float *t = sun_map + 3 * (y * SMW + x);
            t[0] = hot ? 40.0f : 0.2f;
            t[1] = hot ? 32.0f : 0.3f;
            t[2] = hot ? 24.0f : 0.5f;
        }
    return map_sky(sun_map, SMW, SMH);
}

TEST(test_sun_sphere_on_off)
{
    skip_if_quick();
    Scene s;
    SptError e = {0};
    if (scene_load_gltf(&s, "tests/data/scenes/caustic_sphere.gltf", &e))
        fail_msg("load: %s", e.msg);
    s.light_count = 0;
    Sky sky = sun_sky();
    enum { NB = 48 };
    double sum[2][NB] = {{0}}, sum2[2][NB] = {{0}}, img[2] = {0};
    float *rgb = malloc(sizeof(float) * 3 * SS_W * SS_W);
    for (int side = 0; side < 2; side++)
        for (int run = 0; run < SS_RUNS; run++) {
            RenderSettings rs = square_settings(SS_W, SS_SPP, -1, (uint32_t)(1 + 100 * side + run));
            rs.caustics = side == 0 ? SPT_SWITCH_ON : SPT_SWITCH_OFF;
            rs.sky = &sky;
            render_rgb(&s, &rs, rgb);
            double b[48];
            block_means_4x4(rgb, SS_W, b);
            for (int k = 0; k < 48; k++) {
                sum[side][k] += b[k];
                sum2[side][k] += b[k] * b[k];
                img[side] += b[k] / NB / SS_RUNS;
            }
        }
    free(rgb);
    scene_free(&s);
    double worst = 0, var_img[2] = {0};
    int worst_k = 0;
    for (int k = 0; k < NB; k++) {
        double m[2], se2[2];
        for (int side = 0; side < 2; side++) {
            m[side] = sum[side][k] / SS_RUNS;
            double var = fmax(0.0, (sum2[side][k] - SS_RUNS * m[side] * m[side]) / (SS_RUNS - 1));
            se2[side] = var / SS_RUNS;
            var_img[side] += se2[side] / (NB * NB);
        }
        assert_true(se2[0] > 0.0 && se2[1] > 0.0);
        double t = fabs(m[0] - m[1]) / sqrt(se2[0] + se2[1]);
        if (k % 3 == 1)
            printf("%s%8.4f/%-8.4f(t %.2f)%s", k % 12 == 1 ? "  " : " ", m[0], m[1], t, k % 12 == 10 ? "\n" : "");
        if (t > worst) {
            worst = t;
            worst_k = k;
        }
    }
    /* The image mean's standard error, as if the blocks were independent (they
     * are not: a loose bound). */
    double z = fabs(img[0] - img[1]) / sqrt(var_img[0] + var_img[1]);
    printf("sun over a glass sphere, block means on/off (green) above: image mean on %.4f, off %.4f (%+.2f%%, "
           "%.2f standard errors); largest Welch statistic %.2f (block %d, %d, channel %d), bound %.1f\n",
           img[0], img[1], 100.0 * (img[0] / img[1] - 1.0), z, worst, worst_k / 12, worst_k / 3 % 4, worst_k % 3,
           SS_WELCH_BOUND);
    assert_true(worst < SS_WELCH_BOUND);
    assert_true(z < 4.0);
}

TEST_MAIN("caustics_sky", setup_cpu_device, teardown_cpu_device)
