/* The AOV layers of --aov (src/render/film.h) against known geometry: a plane
 * at a known distance gives its depth and positions, a sphere's normals point
 * away from its centre, the albedo of a textured plane is its texture, and the
 * variance layer agrees with the variance of independent renders. AOVs leave
 * the beauty image as it is. Split invariance of the layers: tests/test_multidevice.c
 * (devices), tests/test_checkpoint.c (resume), tests/test_mpi.c (ranks). */
#include "test_util.h"
#include "test_render_util.h"

#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

#include "cl/cl_device.h"
#include "color/spd.h"
#include "io/exr.h"
#include "render/film.h"
#include "render/render.h"
#include "scene/scene.h"
#include "scene/sky.h"

/* Renders scene s with rs (rs->aov set by the caller) into film (initialised
 * here, with AOV sums when rs->aov); fails the test on an error. */
static void render_aov(const Scene *s, const RenderSettings *rs, Film *film)
{
    assert_int_equal(render_film_ok(s, rs, film).nan_dropped, 0);
}

/* One layer of film, malloc'd (3 floats per pixel room). */
static float *layer(const Film *f, unsigned which)
{
    float *out = malloc(sizeof(float) * 3 * (size_t)f->width * f->height);
    film_aov_layer(f, which, out);
    return out;
}

/* The quad y = 0 over [-6, 6]^2 seen straight down from height d by a pinhole
 * camera (forward -Y, up -Z, right +X). */
static void plane_scene(Scene *s, float d, float yfov)
{
    memset(s, 0, sizeof *s);
    append_quad(s, 0.0f);
    camera_down(s, 0.0f, d, yfov, 1.0f);
    scene_update_bounds(s);
}

/* Z is the plane's distance and P lies on it, at the mean of the pixel's
 * footprint; N is the plane's normal; the albedo is the plane's grey. */
TEST(test_plane_depth_position_normal)
{
    const float d = 2.5f, yfov = 0.6f;
    const int W = 24, spp = 16;
    Scene s;
    plane_scene(&s, d, yfov);
    for (int k = 0; k < 3; k++)
        s.materials[0].base_color[k] = 0.3f;
    RenderSettings rs = square_settings(W, spp, -1, 3);
    rs.aov = SPT_AOV_ALL;
    Film f;
    render_aov(&s, &rs, &f);
    float *z = layer(&f, SPT_AOV_DEPTH), *p = layer(&f, SPT_AOV_POSITION), *n = layer(&f, SPT_AOV_NORMAL),
          *alb = layer(&f, SPT_AOV_ALBEDO), *cnt = layer(&f, SPT_AOV_SPP);
    /* The image plane at distance 1 spans 2 tan(yfov / 2) across W pixels. */
    double half = tan(0.5 * yfov), px_size = 2.0 * half * d / W;
    double worst_z = 0, worst_p = 0;
    for (int y = 0; y < W; y++)
        for (int x = 0; x < W; x++) {
            size_t i = (size_t)y * W + x;
            assert_true(cnt[i] == (float)spp);
            worst_z = fmax(worst_z, fabs(z[i] - d) / d);
            assert_close(p[3 * i + 1], 0.0, 1e-6);
            double want_x = (2.0 * (x + 0.5) / W - 1.0) * half * d;
            double want_z = -(1.0 - 2.0 * (y + 0.5) / W) * half * d;
            worst_p = fmax(worst_p, fmax(fabs(p[3 * i] - want_x), fabs(p[3 * i + 2] - want_z)) / px_size);
            assert_close(n[3 * i + 0], 0.0, 1e-6);
            assert_close(n[3 * i + 1], 1.0, 1e-6);
            assert_close(n[3 * i + 2], 0.0, 1e-6);
            for (int c = 0; c < 3; c++)
                assert_close(alb[3 * i + c], 0.3, 2e-3);
        }
    printf("plane at %.2f m: largest relative depth error %.2g; position off the pixel's centre "
           "by at most %.3f pixel\n", d, worst_z, worst_p);
    assert_true(worst_z < 1e-6);
    /* The mean of 16 jittered positions in a pixel (Owen-scrambled Sobol: one
     * per sixteenth of each axis) is within 1/32 pixel of its centre. */
    assert_true(worst_p < 1.0 / 32.0 + 1e-3);
    free(z), free(p), free(n), free(alb), free(cnt);
    film_free(&f);
    scene_free(&s);
}

/* On the unit sphere: where every sample of a pixel hit it, the normal points
 * away from the centre (along P), |P| = 1 (within the tessellation) and
 * Z = 4 - P.z (the camera at z = 4 looks down -Z); pixels that see only the
 * sky have zero layers. */
TEST(test_sphere_normals)
{
    Scene s;
    sphere_scene(&s, 0.5f);
    const int W = 32;
    RenderSettings rs = square_settings(W, 8, -1, 5);
    rs.aov = SPT_AOV_ALL;
    Film f;
    render_aov(&s, &rs, &f);
    float *z = layer(&f, SPT_AOV_DEPTH), *p = layer(&f, SPT_AOV_POSITION), *n = layer(&f, SPT_AOV_NORMAL);
    int inside = 0, sky = 0;
    double worst = 1.0;
    for (size_t i = 0; i < (size_t)W * W; i++) {
        double nl = sqrt(n[3 * i] * n[3 * i] + n[3 * i + 1] * n[3 * i + 1] + n[3 * i + 2] * n[3 * i + 2]);
        double pl = sqrt(p[3 * i] * p[3 * i] + p[3 * i + 1] * p[3 * i + 1] + p[3 * i + 2] * p[3 * i + 2]);
        if (z[i] == 0.0f) {
            sky++;
            assert_true(nl == 0.0 && pl == 0.0);
            continue;
        }
        if (nl < 0.999)
            continue; /* the silhouette: some samples missed */
        inside++;
        double dot = (n[3 * i] * p[3 * i] + n[3 * i + 1] * p[3 * i + 1] + n[3 * i + 2] * p[3 * i + 2]) / (nl * pl);
        worst = fmin(worst, dot);
        assert_close(pl, 1.0, 0.01);
        assert_close(z[i], 4.0 - p[3 * i + 2], 1e-4);
    }
    printf("%d pixels inside the sphere, %d sky: smallest cosine between N and P %.5f\n", inside, sky,
           worst);
    assert_true(inside > 200);
    assert_true(sky > 200);
    /* Facets of the 48 x 96 tessellation tilt at most about pi / 48 from P. */
    assert_true(worst > 0.995);
    free(z), free(p), free(n);
    film_free(&f);
    scene_free(&s);
}

/* The albedo layer of the textured plane of tests/data/textures/ (4 x 4 cells
 * of known sRGB colours, seen head-on by an orthographic camera framing it) is
 * the texture. Texels become spectra through the fitted table alone
 * (rgb_to_coeffs_fast, up to 0.016 off the colour), so each cell's mean albedo
 * must be the colour of that spectrum under D65 (by the 1 nm CIE sums here,
 * where the kernels sample every 10 nm) within 0.5%, and the texel's colour,
 * decoded with the sRGB transfer function, within the table's 0.016. */
static double srgb8_to_linear(int v)
{
    double c = v / 255.0;
    return c <= 0.04045 ? c / 12.92 : pow((c + 0.055) / 1.055, 2.4);
}

/* Linear sRGB of the sigmoid reflectance of rgb's fitted coefficients under D65,
 * by the 1 nm sums. */
static void fitted_colour(const double rgb[3], double out[3])
{
    float in[3] = {(float)rgb[0], (float)rgb[1], (float)rgb[2]}, c[3];
    rgb_to_coeffs_fast(in, c);
    double xyz[3] = {0, 0, 0}, norm = 0;
    for (int i = 0; i < SPT_CIE_SAMPLES; i++) {
        double l = SPT_CIE_LAMBDA_MIN + i;
        double x = c[0] * l * l + c[1] * l + c[2];
        double sv = 0.5 + x / (2.0 * sqrt(1.0 + x * x));
        xyz[0] += sv * SPT_D65_NORM[i] * SPT_CIE_X[i];
        xyz[1] += sv * SPT_D65_NORM[i] * SPT_CIE_Y[i];
        xyz[2] += sv * SPT_D65_NORM[i] * SPT_CIE_Z[i];
        norm += SPT_D65_NORM[i] * SPT_CIE_Y[i];
    }
    for (int k = 0; k < 3; k++)
        xyz[k] /= norm;
    xyz_to_linear_srgb(xyz, out);
}

TEST(test_albedo_of_textured_plane)
{
    Scene s;
    test_load_scene(&s, "tests/data/textures/base_nosampler.gltf");
    const int W = 64;
    RenderSettings rs = square_settings(W, 4, -1, 7);
    rs.aov = SPT_AOV_ALBEDO;
    Film f;
    render_aov(&s, &rs, &f);
    float *alb = layer(&f, SPT_AOV_ALBEDO);
    static const int levels[3] = {40, 120, 200};
    double worst_fit = 0, worst_tex = 0;
    for (int row = 0; row < 4; row++)
        for (int col = 0; col < 4; col++) {
            /* tests/test_textures.c: cell (col, row) is palette entry
             * (5 (4 row + col) + 3) mod 27, entry i = levels (i / 9, i / 3, i) mod 3. */
            int k = (5 * (row * 4 + col) + 3) % 27;
            double tex[3] = {srgb8_to_linear(levels[(k / 9) % 3]), srgb8_to_linear(levels[(k / 3) % 3]),
                             srgb8_to_linear(levels[k % 3])}, fit[3];
            fitted_colour(tex, fit);
            double got[3] = {0, 0, 0};
            int np = 0;
            /* The middle half of the cell: away from the texture's filtered edges. */
            for (int y = row * 16 + 4; y < row * 16 + 12; y++)
                for (int x = col * 16 + 4; x < col * 16 + 12; x++, np++)
                    for (int c = 0; c < 3; c++)
                        got[c] += alb[3 * (y * W + x) + c];
            for (int c = 0; c < 3; c++) {
                got[c] /= np;
                double dfit = fabs(got[c] - fit[c]) / fmax(fit[c], 0.05), dtex = fabs(got[c] - tex[c]);
                worst_fit = fmax(worst_fit, dfit);
                worst_tex = fmax(worst_tex, dtex);
                if (dfit > 0.005 || dtex > 0.016)
                    fail_msg("cell (%d, %d) channel %d: albedo %.5f, the texel's spectrum %.5f, the texel %.5f",
                             col, row, c, got[c], fit[c], tex[c]);
            }
        }
    printf("albedo within %.3f%% of the texels' spectra, within %.4f of the texels\n", 100 * worst_fit,
           worst_tex);
    free(alb);
    film_free(&f);
    scene_free(&s);
}

/* The beauty image with AOVs is the one without: on PoCL bit for bit, on other
 * implementations (another compilation of the kernels) within 1e-5. */
TEST(test_beauty_unchanged)
{
    Scene s;
    test_load_scene(&s, "scenes/cornell_box.gltf");
    RenderSettings rs = square_settings(24, 8, -1, 9);
    Film a, b;
    render_aov(&s, &rs, &a);
    /* Every layer but the variance, which turns the light-tracing pass of
     * --caustics off (src/render/scheduler.c). */
    rs.aov = SPT_AOV_ALL & ~SPT_AOV_VARIANCE;
    render_aov(&s, &rs, &b);
    const char *impl = getenv("SPECTRACE_TEST_IMPL");
    int exact = !impl || !strcmp(impl, "pocl");
    for (size_t i = 0; i < 24 * 24; i++) {
        assert_true(a.count[i] == b.count[i]);
        for (int c = 0; c < 3; c++) {
            double x = a.xyz[3 * i + c], y = b.xyz[3 * i + c];
            if (exact ? x != y : fabs(x - y) > 1e-5 * fmax(fabs(x), 1e-3))
                fail_msg("pixel %zu channel %d: %.9g without AOVs, %.9g with", i, c, x, y);
        }
    }
    film_free(&a);
    film_free(&b);
    scene_free(&s);
}

/* Per-pixel sample variance of the linear sRGB of K renders of s
 * (W x W, spp samples, seeds 1000 + k) into var (3 per pixel); with layer
 * non-NULL, the mean of their variance layers too. */
static void independent_variance(const Scene *s, int W, int K, int spp, double *var, double *layer_mean)
{
    size_t np = (size_t)W * W;
    double *sum = calloc(3 * np, sizeof(double)), *sum2 = calloc(3 * np, sizeof(double));
    float *rgb = malloc(sizeof(float) * 3 * np);
    if (layer_mean)
        memset(layer_mean, 0, 3 * np * sizeof(double));
    for (int k = 0; k < K; k++) {
        RenderSettings rs = square_settings(W, spp, -1, 1000u + (uint32_t)k);
        rs.aov = SPT_AOV_VARIANCE;
        Film f;
        render_aov(s, &rs, &f);
        film_to_linear_srgb(&f, rgb);
        float *v = layer(&f, SPT_AOV_VARIANCE);
        for (size_t i = 0; i < 3 * np; i++) {
            sum[i] += rgb[i];
            sum2[i] += (double)rgb[i] * rgb[i];
            if (layer_mean)
                layer_mean[i] += v[i] / K;
        }
        free(v);
        film_free(&f);
    }
    for (size_t i = 0; i < 3 * np; i++) {
        double m = sum[i] / K;
        var[i] = (sum2[i] - K * m * m) / (K - 1);
    }
    free(sum), free(sum2), free(rgb);
}

/* The variance layer is the sample variance of a pixel's samples over their
 * number. Renders of 1 sample with independent seeds are independent samples
 * of each pixel: over the grey sphere under the white sky (light and BSDF
 * sampling, no rare bright paths: the Cornell box's need some 400 renders for
 * the mean of their variance to settle within 10%), the image mean of their
 * variance agrees with that of the layer times the sample count, per channel.
 * A pixel's samples are not independent, though: its position and wavelengths
 * are stratified across them (Owen-scrambled Sobol), which makes the variance
 * of a pixel's value smaller than the layer's estimate (on this sphere a half
 * to a quarter of it, on the Cornell box about 0.8); the layer is measured
 * against renders of the same sample count too, and must not be below it. */
TEST(test_variance_against_independent_renders)
{
    skip_if_quick();
    Scene s;
    sphere_scene(&s, 0.5f);
    enum { W = 24, SPP = 16 };
    size_t np = (size_t)W * W;
    double *one = malloc(sizeof(double) * 3 * np), *many = malloc(sizeof(double) * 3 * np),
           *lay = malloc(sizeof(double) * 3 * np), *unused = malloc(sizeof(double) * 3 * np);
    independent_variance(&s, W, 96, 1, one, unused);
    independent_variance(&s, W, 24, SPP, many, lay);
    for (int c = 0; c < 3; c++) {
        double per_sample = 0, estimated = 0, measured = 0;
        for (size_t i = 0; i < np; i++) {
            per_sample += one[3 * i + c] / np;
            estimated += lay[3 * i + c] / np;
            measured += many[3 * i + c] / np;
        }
        printf("channel %d: variance of a sample %.4g, the layer's times %d %.4g (ratio %.3f); variance of "
               "%d-sample renders %.4g, the layer's %.4g (ratio %.3f)\n",
               c, per_sample, SPP, SPP * estimated, SPP * estimated / per_sample, SPP, measured, estimated,
               estimated / measured);
        /* Stratification raises the layer's mean by up to SPP / (SPP - 1). */
        assert_true(SPP * estimated / per_sample > 0.93 && SPP * estimated / per_sample < 1.12);
        assert_true(estimated / measured > 0.9);
    }
    free(one), free(many), free(lay), free(unused);
    scene_free(&s);
}

/* The command line: the EXR holds the layers asked for, named layer.channel,
 * and nothing else; --aov without an EXR output is one usage error before
 * anything renders. */
TEST(test_command_line)
{
    char out_exr[64], out_png[64], cmd[1024], line[512] = "";
    snprintf(out_exr, sizeof out_exr, "/tmp/spt-aov-%d.exr", (int)getpid());
    snprintf(out_png, sizeof out_png, "/tmp/spt-aov-%d.png", (int)getpid());
    snprintf(cmd, sizeof cmd, "render scenes/cornell_box.gltf --width 8 --height 8 --spp 2 -q "
             "--aov albedo,Z,spp -o %s", out_exr);
    int rc = test_spectrace("", 0, cmd, TEST_BOTH, line, sizeof line);
    if (rc)
        fail_msg("exit %d:\n%s", rc, line);
    ExrLayers L;
    SptError e = {0};
    static const char *want[] = {"R", "G", "B", "albedo.R", "albedo.G", "albedo.B", "Z", "spp"};
    if (exr_read_layers(out_exr, want, 8, &L, &e))
        fail_msg("%s", e.msg);
    assert_int_equal(L.channel_count, 8);
    const float *spp = exr_layers_channel(&L, "spp")->data;
    for (int i = 0; i < 64; i++)
        assert_true(spp[i] == 2.0f);
    exr_layers_free(&L);
    unlink(out_exr);
    snprintf(cmd, sizeof cmd, "render scenes/cornell_box.gltf --width 8 --spp 2 --aov Z -o %s",
             out_png);
    rc = test_spectrace("", 0, cmd, TEST_BOTH, line, sizeof line);
    printf("%s", line);
    assert_int_equal(rc, SPT_EXIT_USAGE);
    assert_true(!strncmp(line, "error: ", 7) && strchr(line, '\n') == line + strlen(line) - 1);
    assert_non_null(strstr(line, "--aov"));
    assert_int_equal(access(out_png, F_OK), -1);
}

/* --aov names: a list, "all", aliases; unknown names refused. */
TEST(test_parse)
{
    unsigned m;
    assert_int_equal(film_aov_parse("albedo,N,Z", &m), 0);
    assert_int_equal(m, SPT_AOV_ALBEDO | SPT_AOV_NORMAL | SPT_AOV_DEPTH);
    assert_int_equal(film_aov_parse("all", &m), 0);
    assert_int_equal(m, SPT_AOV_ALL);
    assert_int_equal(film_aov_parse("position,Variance,spp,depth", &m), 0);
    assert_int_equal(m, SPT_AOV_POSITION | SPT_AOV_VARIANCE | SPT_AOV_SPP | SPT_AOV_DEPTH);
    assert_int_equal(film_aov_parse("albedo,", &m), -1);
    assert_int_equal(film_aov_parse("", &m), -1);
    assert_int_equal(film_aov_parse("alb", &m), -1);
}

TEST_MAIN("aov", setup_cpu_device, teardown_cpu_device)
