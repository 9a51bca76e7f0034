/* Spectral images (--spectral N, src/render/film.h): the bands integrated with
 * the CIE 1931 functions give the XYZ film, a diffuse plane under a mercury
 * lamp shows the lamp's lines in their bands and nothing elsewhere, and the EXR
 * names its channels and attributes as Fichet, Pacanowski and Wilkie 2021 lay
 * them out. Split invariance of the bands: tests/test_multidevice.c (devices),
 * tests/test_checkpoint.c (resume), tests/test_mpi.c (ranks). */
#include "test_util.h"
#include "test_render_util.h"

#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

#include "io/exr.h"
#include "render/film.h"
#include "render/render.h"
#include "scene/scene.h"
#include "scene/sky.h"

/* Renders s with rs into film (with rs->spectral bands). */
static void render_bands(const Scene *s, const RenderSettings *rs, Film *film)
{
    assert_int_equal(render_film_ok(s, rs, film).nan_dropped, 0);
}

/* The Cornell box with 47 bands of 10 nm: per band, the integral of the CIE
 * functions over the band times the band's mean radiance, summed over the
 * bands and normalised as the film is (by the sum of ybar), give the film's
 * XYZ: the image means within 1%. (Per pixel they differ by the noise of the
 * functions' slope within a band against the pixel's few samples.) */
TEST(test_bands_reproduce_xyz)
{
    Scene s;
    test_load_scene(&s, "scenes/cornell_box.gltf");
    enum { W = 32, B = 47 };
    RenderSettings rs = square_settings(W, 64, -1, 21);
    rs.spectral = B;
    Film f;
    render_bands(&s, &rs, &f);
    /* The integrals of the functions (linear between the table's 1 nm
     * samples, as the kernels read them) over each band. */
    double cmf[3][B];
    memset(cmf, 0, sizeof cmf);
    for (int l = 0; l + 1 < SPT_CIE_SAMPLES; l++) {
        int b = l / 10;
        cmf[0][b] += 0.5 * (SPT_CIE_X[l] + SPT_CIE_X[l + 1]);
        cmf[1][b] += 0.5 * (SPT_CIE_Y[l] + SPT_CIE_Y[l + 1]);
        cmf[2][b] += 0.5 * (SPT_CIE_Z[l] + SPT_CIE_Z[l + 1]);
    }
    size_t np = (size_t)W * W;
    float *bands = malloc(sizeof(float) * B * np);
    film_spectral_layer(&f, bands);
    double mean_film[3] = {0, 0, 0}, mean_bands[3] = {0, 0, 0}, worst = 0;
    int tested = 0;
    for (size_t i = 0; i < np; i++) {
        double film_xyz[3], band_xyz[3] = {0, 0, 0};
        for (int c = 0; c < 3; c++) {
            film_xyz[c] = f.xyz[3 * i + c] / f.count[i];
            for (int b = 0; b < B; b++)
                band_xyz[c] += bands[i * B + b] * 10.0 * (cmf[c][b] / 10.0) / SPT_CIE_Y_INTEGRAL_HOST;
            mean_film[c] += film_xyz[c] / np;
            mean_bands[c] += band_xyz[c] / np;
        }
        if (film_xyz[1] > 0.05) {
            tested++;
            for (int c = 0; c < 3; c++)
                worst = fmax(worst, fabs(band_xyz[c] - film_xyz[c]) / fmax(film_xyz[c], 0.05));
        }
    }
    printf("image mean XYZ: film %.5f %.5f %.5f, bands %.5f %.5f %.5f; %d pixels within %.2f%%\n",
           mean_film[0], mean_film[1], mean_film[2], mean_bands[0], mean_bands[1], mean_bands[2], tested,
           100 * worst);
    for (int c = 0; c < 3; c++)
        assert_close_rel(mean_bands[c], mean_film[c], 0.01);
    assert_true(tested > 400);
    free(bands);
    film_free(&f);
    scene_free(&s);
}

/* A grey plane (albedo 0.5) under a uniform mercury sky (--background mercury:
 * the lines of NIST's table, 404.7 and 407.8, 435.8, 546.1, 577.0 and 579.1
 * nm) seen from above: over 99% of the power lands in the four bands holding
 * the lines, every band holds its share of the lamp's spectrum (as the
 * renderer has it: the lines on the 1 nm grid; each within 4%: a line is 2 nm
 * of the 470 that wavelengths are drawn from, so 1024 samples of 256 pixels
 * hit each some thousands of times), and the bands the spectrum does not
 * reach hold exactly nothing. */
TEST(test_mercury_lines)
{
    /* 262,144 paths: minutes at rusticl's launch cost; PoCL and Intel's
     * runtime run it, and the binning it checks is the same code there. */
    skip_if_quick();
    Scene s;
    grey_quad_scene(&s);
    camera_down(&s, 0.0f, 2.0f, 0.6f, 1.0f);
    scene_update_bounds(&s);
    Sky sky;
    SptError e = {0};
    if (sky_from_args(&sky, NULL, "mercury", &e))
        fail_msg("%s", e.msg);
    enum { W = 16, B = 47 };
    RenderSettings rs = square_settings(W, 1024, -1, 2);
    rs.spectral = B;
    rs.sky = &sky;
    Film f;
    render_bands(&s, &rs, &f);
    size_t np = (size_t)W * W;
    float *bands = malloc(sizeof(float) * B * np);
    film_spectral_layer(&f, bands);
    double mean[B];
    memset(mean, 0, sizeof mean);
    for (size_t i = 0; i < np; i++)
        for (int b = 0; b < B; b++)
            mean[b] += bands[i * B + b] / np;
    /* What the bands must hold: the sky's spectrum as the renderer has it (the
     * lines on the 1 nm grid, read linearly between its samples), integrated
     * over each band. */
    double want[B], want_total = 0, total = 0, lines = 0;
    memset(want, 0, sizeof want);
    for (int l = 0; l + 1 < SPT_CIE_SAMPLES; l++)
        want[l / 10] += 0.5 * ((double)sky.spd[l] + sky.spd[l + 1]);
    for (int b = 0; b < B; b++) {
        want_total += want[b];
        total += mean[b];
    }
    /* Bands 4 (400-410 nm), 7 (430-440), 18 (540-550), 21 (570-580). */
    static const int line_band[4] = {4, 7, 18, 21};
    for (int k = 0; k < 4; k++)
        lines += mean[line_band[k]] / total;
    printf("%.2f%% of the power in the four bands of the lines\n", 100 * lines);
    assert_true(lines > 0.99);
    for (int b = 0; b < B; b++) {
        if (want[b] == 0.0) {
            if (mean[b] != 0.0)
                fail_msg("band %d (%d-%d nm) holds %g, no mercury line there", b, 360 + 10 * b, 370 + 10 * b,
                         mean[b]);
            continue;
        }
        double got = mean[b] / total, w = want[b] / want_total;
        printf("band %d-%d nm: %.4f of the power (the lamp's spectrum %.4f)\n", 360 + 10 * b, 370 + 10 * b, got, w);
        if (w > 0.01)
            assert_close_rel(got, w, 0.04);
        else
            assert_close(got, w, 0.001);
    }
    free(bands);
    film_free(&f);
    sky_free(&sky);
    scene_free(&s);
}

/* The command line: the EXR holds R, G, B and the bands as channels
 * "S0.<centre>nm" (comma decimal separator), with spectralLayoutVersion and
 * emissiveUnits; 4 bands of 117.5 nm are named by their centres. */
TEST(test_exr_layout)
{
    char path[64], cmd[1024], err[4096];
    snprintf(path, sizeof path, "/tmp/spt-spectral-%d.exr", (int)getpid());
    snprintf(cmd, sizeof cmd,
             "render scenes/cornell_box.gltf --width 8 --height 8 --spp 2 -q --spectral 4 -o %s", path);
    if (test_run_exe("", 0, cmd, err, sizeof err))
        fail_msg("spectrace %s:\n%s", cmd, err);
    static const char *want[] = {"R",          "G", "B", "S0.418,750000nm", "S0.536,250000nm", "S0.653,750000nm",
                                 "S0.771,250000nm"};
    ExrLayers L;
    SptError e = {0};
    if (exr_read_layers(path, want, 7, &L, &e))
        fail_msg("%s", e.msg);
    assert_int_equal(L.channel_count, 7);
    const ExrAttr *v = exr_layers_attr(&L, "spectralLayoutVersion", SPT_EXR_ATTR_STRING);
    const ExrAttr *u = exr_layers_attr(&L, "emissiveUnits", SPT_EXR_ATTR_STRING);
    assert_non_null(v);
    assert_non_null(u);
    assert_string_equal(v->s, "1.0");
    assert_string_equal(u->s, "W.m^-2.sr^-1");
    exr_layers_free(&L);
    unlink(path);
}

/* `spectrace color --pixel X,Y` of a spectral EXR gives the pixel's colour as
 * the renderer's film has it: on the textured plane of tests/data/textures/
 * (16 x 16, 1024 samples a pixel), the linear sRGB it prints for the centre of
 * a cell is the EXR's R, G, B there within 1.5% (0.002 absolute); a pixel
 * outside the image is a usage error. */
TEST(test_color_pixel)
{
    skip_if_quick(); /* the colour tool is host code; PoCL runs it */
    char path[64], cmd[1024], out[1024];
    snprintf(path, sizeof path, "/tmp/spt-spectral-px-%d.exr", (int)getpid());
    snprintf(cmd, sizeof cmd, "render tests/data/textures/base_nosampler.gltf --width 16 --spp 1024 -q "
             "--spectral 47 -o %s", path);
    if (test_run_exe("", 0, cmd, out, sizeof out))
        fail_msg("spectrace %s:\n%s", cmd, out);
    static const char *rgb_names[3] = {"R", "G", "B"};
    ExrLayers L;
    SptError e = {0};
    if (exr_read_layers(path, rgb_names, 3, &L, &e))
        fail_msg("%s", e.msg);
    const int px[3][2] = {{2, 2}, {6, 10}, {13, 5}};
    for (int k = 0; k < 3; k++) {
        snprintf(cmd, sizeof cmd, "color --pixel %d,%d %s", px[k][0], px[k][1], path);
        assert_int_equal(test_spectrace("", 0, cmd, TEST_STDOUT, out, sizeof out), 0);
        double xyz[3], lin[3];
        const char *l = strstr(out, "linear-sRGB");
        assert_non_null(l);
        assert_int_equal(sscanf(out, "XYZ %lf %lf %lf", &xyz[0], &xyz[1], &xyz[2]), 3);
        assert_int_equal(sscanf(l, "linear-sRGB %lf %lf %lf", &lin[0], &lin[1], &lin[2]), 3);
        size_t i = (size_t)px[k][1] * L.width + (size_t)px[k][0];
        for (int c = 0; c < 3; c++) {
            double film = ((const float *)exr_layers_channel(&L, rgb_names[c])->data)[i];
            printf("pixel %d,%d %s: color --pixel %.5f, the EXR %.5f\n", px[k][0], px[k][1], rgb_names[c],
                   lin[c], film);
            assert_close(lin[c], film, 0.015 * film + 0.002);
        }
    }
    exr_layers_free(&L);
    snprintf(cmd, sizeof cmd, "color --pixel 16,0 %s", path);
    assert_int_equal(test_spectrace("", 0, cmd, TEST_STDOUT, out, sizeof out), SPT_EXIT_USAGE);
    unlink(path);
}

TEST_MAIN("spectral", setup_cpu_device, teardown_cpu_device)
