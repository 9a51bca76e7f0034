/* Materials and punctual lights in the renderer (PoCL), against independent
 * values: Mitsuba 3's conductor, roughconductor, dielectric and roughdielectric
 * plugins on the scenes of tools/make_material_scenes.py (image means in
 * tests/data/mitsuba/mat_*_means.json), white furnaces under the default sky
 * (radiance 1), and a point light over a Lambertian plane (E = I cos / r^2).
 * Scenes and numbers: tests/data/scenes/README.md, "Material scenes". */
#include "test_util.h"
#include "test_render_util.h"

#include <stdlib.h>
#include <string.h>

#include "accel/bvh_build.h"
#include "cl/cl_device.h"
#include "render/film.h"
#include "render/render.h"
#include "scene/scene.h"
#include "spectrum/cie_data.h"

/* Linear sRGB of a film, malloc'd (3 floats per pixel, rows top to bottom). */
static float *film_rgb(const Film *f)
{
    float *rgb = malloc((size_t)f->width * f->height * 3 * sizeof(float));
    film_to_linear_srgb(f, rgb);
    return rgb;
}

/* ------------------------------------------------------------------------- */
/* Mitsuba 3 comparisons: the image mean at max depth 8 within 3% per channel. */

static void compare_with_mitsuba(const char *name, int spp)
{
    char scene[256], ref[256];
    snprintf(scene, sizeof scene, "tests/data/scenes/%s.gltf", name);
    snprintf(ref, sizeof ref, "tests/data/mitsuba/%s_means.json", name);
    double want[3];
    assert_int_equal(json_triple(ref, "\"max_depth_8\"", "\"mean\"", want), 0);
    Film f;
    RenderStats st;
    assert_int_equal(render_file(scene, 64, 64, spp, 8, 11, NULL, &f, &st), 0);
    float *rgb = film_rgb(&f);
    double m[3] = {0, 0, 0};
    for (int i = 0; i < 64 * 64; i++)
        for (int c = 0; c < 3; c++)
            m[c] += rgb[3 * i + c] / (64.0 * 64.0);
    printf("%s: spectrace (%.5f, %.5f, %.5f), Mitsuba (%.5f, %.5f, %.5f), diff (%+.2f%%, %+.2f%%, "
           "%+.2f%%), %.1f s\n", name, m[0], m[1], m[2], want[0], want[1], want[2],
           100 * (m[0] / want[0] - 1), 100 * (m[1] / want[1] - 1), 100 * (m[2] / want[2] - 1),
           st.seconds);
    assert_int_equal(st.nan_dropped, 0);
    for (int c = 0; c < 3; c++)
        assert_close_rel(m[c], want[c], 0.03);
    free(rgb);
    film_free(&f);
}

TEST(test_conductor_vs_mitsuba)
{
    compare_with_mitsuba("mat_conductor", 64);
}

TEST(test_roughconductor_vs_mitsuba)
{
    compare_with_mitsuba("mat_roughconductor", 64);
}

TEST(test_dielectric_vs_mitsuba)
{
    skip_if_quick();
    compare_with_mitsuba("mat_dielectric", 128);
}

TEST(test_roughdielectric_vs_mitsuba)
{
    skip_if_quick();
    compare_with_mitsuba("mat_roughdielectric", 128);
}

/* ------------------------------------------------------------------------- */
/* White furnaces: a sphere alone under the default sky (uniform D65 radiance,
 * film Y = 1). Whatever the BSDF, what comes back is at most what the sky sends
 * (1); a smooth dielectric loses nothing, so it shows exactly 1. */

#define FURNACE_SIZE 48

/* The sphere of material m (sphere_scene_material) in the furnace (the default
 * sky), FURNACE_SIZE square at spp with seed: its linear sRGB, malloc'd. */
static float *furnace_rgb(const SceneMaterial *m, int spp, uint32_t seed, RenderStats *st)
{
    Scene s;
    sphere_scene_material(&s, m);
    Film f;
    assert_int_equal(render_scene(&s, FURNACE_SIZE, FURNACE_SIZE, spp, -1, seed, NULL, &f, st), 0);
    float *rgb = film_rgb(&f);
    film_free(&f);
    scene_free(&s);
    return rgb;
}

#define FURNACE_CAM_Z 4.0 /* sphere_scene_material's camera (tests/test_render_util.h) */

/* Cosine between the surface normal of the unit sphere and the direction back
 * to the camera, for the ray through image-plane point (u, v) in [-1, 1]^2
 * (scaled by tan(yfov/2)); 0 when the ray misses. */
static double furnace_mu(double u, double v)
{
    double t = tan(0.3);
    double d[3] = {u * t, v * t, -1.0};
    double len = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    for (int k = 0; k < 3; k++)
        d[k] /= len;
    /* |o + s d| = 1 with o = (0, 0, 4). */
    double b = FURNACE_CAM_Z * d[2], cc = FURNACE_CAM_Z * FURNACE_CAM_Z - 1.0;
    double disc = b * b - cc;
    if (disc <= 0)
        return 0.0;
    double s = -b - sqrt(disc);
    double p[3] = {s * d[0], s * d[1], FURNACE_CAM_Z + s * d[2]};
    return -(p[0] * d[0] + p[1] * d[1] + p[2] * d[2]);
}

/* Directional albedo of a white (F = 1) GGX microfacet reflector with
 * height-correlated Smith masking (the glTF 2.0 appendix B model), for viewing
 * cosine mu and alpha = roughness^2, by quadrature over the half vector:
 * E(v) = integral D(h) G2(v, l) (v.h) / (n.v) dw_h over l = reflect(v, h) above
 * the surface. An independent numerical integral of the published formulas. */
static double ggx_white_albedo(double mu, double alpha)
{
    const int nt = 1200, np = 96;
    double a2 = alpha * alpha, v[3] = {sqrt(1 - mu * mu), 0, mu}, sum = 0;
    for (int i = 0; i < nt; i++) {
        double th = (i + 0.5) * (M_PI / 2) / nt, ct = cos(th), st = sin(th);
        double dd = ct * ct * (a2 - 1) + 1, D = a2 / (M_PI * dd * dd);
        for (int j = 0; j < np; j++) {
            double ph = (j + 0.5) * 2 * M_PI / np;
            double h[3] = {st * cos(ph), st * sin(ph), ct};
            double vh = v[0] * h[0] + v[1] * h[1] + v[2] * h[2];
            if (vh <= 0)
                continue;
            double lz = 2 * vh * h[2] - v[2];
            if (lz <= 0)
                continue;
            double lv = (1 - lz * lz) / (lz * lz), vv = (1 - mu * mu) / (mu * mu);
            double lam_l = 0.5 * (-1 + sqrt(1 + a2 * lv)), lam_v = 0.5 * (-1 + sqrt(1 + a2 * vv));
            double G2 = 1.0 / (1.0 + lam_l + lam_v);
            sum += D * G2 * vh / mu * st * ((M_PI / 2) / nt) * (2 * M_PI / np);
        }
    }
    return sum;
}

/* Mean over the pixels whose whole footprint lies well inside the sphere's disc
 * (image-plane radius < 0.7 of the half-height; the disc's edge is at 0.84),
 * and optionally the mean of `expect(mu)` over the same pixels (8 x 8 sub-pixel
 * points each). */
static double disc_mean(const float *rgb, int c, double (*expect)(double mu, double alpha),
                        double alpha, double *want)
{
    const int w = FURNACE_SIZE;
    double sum = 0, esum = 0;
    int n = 0;
    for (int y = 0; y < w; y++)
        for (int x = 0; x < w; x++) {
            double u = (x + 0.5) / w * 2 - 1, v = 1 - (y + 0.5) / w * 2;
            if (u * u + v * v >= 0.7 * 0.7)
                continue;
            sum += rgb[3 * (y * w + x) + c];
            n++;
            if (expect) {
                double e = 0;
                for (int sy = 0; sy < 8; sy++)
                    for (int sx = 0; sx < 8; sx++) {
                        double uu = (x + (sx + 0.5) / 8) / w * 2 - 1, vv = 1 - (y + (sy + 0.5) / 8) / w * 2;
                        e += expect(furnace_mu(uu, vv), alpha) / 64;
                    }
                esum += e;
            }
        }
    if (want)
        *want = expect ? esum / n : 1.0;
    return sum / n;
}

/* GGX albedo tabulated over mu (quadrature is slow), linear in between. */
static double albedo_table[65];
static double albedo_table_alpha = -1;
static double ggx_albedo_lookup(double mu, double alpha)
{
    if (alpha != albedo_table_alpha) {
        for (int i = 0; i <= 64; i++)
            albedo_table[i] = ggx_white_albedo(i == 0 ? 1e-3 : i / 64.0, alpha);
        albedo_table_alpha = alpha;
    }
    double f = mu * 64;
    int i = (int)f;
    if (i >= 64)
        return albedo_table[64];
    return albedo_table[i] + (albedo_table[i + 1] - albedo_table[i]) * (f - i);
}

/* A white metal (metallic 1, base colour 1, no conductor data: Schlick with
 * F0 = 1 is exactly 1) in the furnace, roughness 0, 0.25, 0.5 and 1: the sphere
 * shows its single-scattering GGX albedo E(mu) <= 1 (exactly 1 when smooth);
 * the whole image never exceeds 1. */
TEST(test_furnace_white_metal)
{
    skip_if_quick();
    const float rough[4] = {0.0f, 0.25f, 0.5f, 1.0f};
    for (int k = 0; k < 4; k++) {
        SceneMaterial m;
        scene_material_default(&m);
        m.metallic = 1.0f;
        m.roughness = rough[k];
        RenderStats st;
        float *rgb = furnace_rgb(&m, 64, 21, &st);
        double alpha = (double)rough[k] * rough[k], want = 1.0, got[3], image[3] = {0, 0, 0};
        for (int c = 0; c < 3; c++) {
            got[c] = disc_mean(rgb, c, alpha > 0 ? ggx_albedo_lookup : NULL, alpha, &want);
            for (int i = 0; i < FURNACE_SIZE * FURNACE_SIZE; i++)
                image[c] += rgb[3 * i + c] / (FURNACE_SIZE * FURNACE_SIZE);
        }
        printf("furnace white metal roughness %.2f: sphere (%.4f, %.4f, %.4f), GGX albedo %.4f; "
               "image mean (%.4f, %.4f, %.4f)\n", rough[k], got[0], got[1], got[2], want, image[0],
               image[1], image[2]);
        for (int c = 0; c < 3; c++) {
            assert_true(got[c] <= 1.005);
            assert_true(image[c] <= 1.005);
            assert_close_rel(got[c], want, 0.02);
        }
        assert_int_equal(st.nan_dropped, 0);
        free(rgb);
    }
}

/* The KHR_materials_clearcoat and KHR_materials_sheen layers in the furnace: a
 * coat and a sheen over a white Lambertian base, and over a rough white metal
 * (sheen roughness 0.2, where the Charlie lobe alone would exceed albedo 1 at
 * grazing angles): the whole renderer, every bounce, never returns more than
 * the sky sends; what is lost is printed. */
TEST(test_furnace_layers)
{
    for (int k = 0; k < 2; k++) {
        SceneMaterial m;
        scene_material_default(&m);
        m.metallic = k == 0 ? 0.0f : 1.0f;
        m.roughness = k == 0 ? 0.5f : 1.0f;
        m.specular = k == 0 ? 0.0f : 1.0f;
        m.clearcoat = 1.0f;
        m.clearcoat_roughness = k == 0 ? 0.3f : 1.0f;
        for (int c = 0; c < 3; c++)
            m.sheen_color[c] = 1.0f;
        m.sheen_roughness = k == 0 ? 0.5f : 0.2f;
        RenderStats st;
        float *rgb = furnace_rgb(&m, 64, 23, &st);
        double got[3];
        for (int c = 0; c < 3; c++)
            got[c] = disc_mean(rgb, c, NULL, 0.0, NULL);
        printf("furnace coat + sheen over %s: sphere (%.4f, %.4f, %.4f)\n",
               k == 0 ? "white Lambert" : "rough white metal", got[0], got[1], got[2]);
        for (int c = 0; c < 3; c++)
            assert_true(got[c] <= 1.005);
        free(rgb);
    }
}

/* A glass sphere (transmission 1, ior 1.5) in the furnace: smooth, it neither
 * absorbs nor gains (every path leaves it again, and the 1/eta^2 radiance
 * scaling cancels in and out), so the sphere shows 1 within 1%; rough (0.5),
 * single-scattering microfacets lose energy (how much: the next test) but the
 * sphere never exceeds 1. */
TEST(test_furnace_glass)
{
    skip_if_quick();
    const float rough[2] = {0.0f, 0.5f};
    const double tol_below[2] = {0.01, 1.0};
    for (int k = 0; k < 2; k++) {
        SceneMaterial m;
        scene_material_default(&m);
        m.metallic = 0.0f;
        m.roughness = rough[k];
        m.transmission = 1.0f;
        m.ior = 1.5f;
        RenderStats st;
        float *rgb = furnace_rgb(&m, 128, 22, &st);
        double got[3], image[3] = {0, 0, 0};
        for (int c = 0; c < 3; c++) {
            got[c] = disc_mean(rgb, c, NULL, 0, NULL);
            for (int i = 0; i < FURNACE_SIZE * FURNACE_SIZE; i++)
                image[c] += rgb[3 * i + c] / (FURNACE_SIZE * FURNACE_SIZE);
        }
        printf("furnace glass roughness %.2f: sphere (%.4f, %.4f, %.4f), image mean (%.4f, %.4f, %.4f)\n",
               rough[k], got[0], got[1], got[2], image[0], image[1], image[2]);
        for (int c = 0; c < 3; c++) {
            assert_true(got[c] <= 1.01);
            assert_true(image[c] <= 1.005);
            assert_true(got[c] >= 1.0 - tol_below[k]);
        }
        assert_int_equal(st.nan_dropped, 0);
        free(rgb);
    }
}

/* ------------------------------------------------------------------------- */
/* A point light of I candela (white: D65-shaped) 1 m above a Lambertian plane
 * of albedo rho, no other light (--background black). At a plane point at
 * distance d from the light, E = I cos / d^2 = I h / d^3 lux, the plane's
 * luminance Lv = rho E / pi cd/m^2, and film Y = Lv (the film's unit is the
 * nit: kernels/light/lights.h). Numbers from tools/make_material_scenes.py. */
#define PL_ALBEDO 0.5
#define PL_INTENSITY 1.0e5
#define PL_HEIGHT 1.0
#define PL_CAM_Y 0.5
#define PL_YFOV_DEG 60.0
#define PL_SIZE 16

/* Expected film Y averaged over pixel (x, y) (8 x 8 points). The camera looks
 * straight down; image right is +x, image up is -z (by symmetry the sign does
 * not matter). */
static double point_light_expected_y(int x, int y)
{
    double t = tan(0.5 * PL_YFOV_DEG * M_PI / 180.0), e = 0;
    for (int sy = 0; sy < 8; sy++)
        for (int sx = 0; sx < 8; sx++) {
            double u = (x + (sx + 0.5) / 8) / PL_SIZE * 2 - 1, v = 1 - (y + (sy + 0.5) / 8) / PL_SIZE * 2;
            double px = u * t * PL_CAM_Y, pz = -v * t * PL_CAM_Y;
            double d2 = px * px + pz * pz + PL_HEIGHT * PL_HEIGHT, d = sqrt(d2);
            double E = PL_INTENSITY * (PL_HEIGHT / d) / d2;
            double Lv = PL_ALBEDO * E / M_PI;
            e += Lv / 64.0; /* film Y = luminance in cd/m^2 (kernels/light/lights.h) */
        }
    return e;
}

TEST(test_point_light_irradiance)
{
    Film f;
    RenderStats st;
    assert_int_equal(render_file("tests/data/scenes/mat_point_light.gltf", PL_SIZE, PL_SIZE, 256, -1, 31,
                                 "black", &f, &st),
                     0);
    /* Film Y (XYZ's Y) per pixel: the centre 2 x 2, the four corners, two edges. */
    const int px[][2] = {{7, 7}, {8, 7}, {7, 8}, {8, 8}, {0, 0}, {15, 0}, {0, 15}, {15, 15}, {0, 8}, {8, 0}};
    double mean = 0, want_mean = 0;
    for (int y = 0; y < PL_SIZE; y++)
        for (int x = 0; x < PL_SIZE; x++) {
            size_t i = (size_t)y * PL_SIZE + x;
            mean += f.xyz[3 * i + 1] / f.count[i] / (PL_SIZE * PL_SIZE);
            want_mean += point_light_expected_y(x, y) / (PL_SIZE * PL_SIZE);
        }
    printf("point light: image mean Y %.5f, expected %.5f\n", mean, want_mean);
    for (size_t k = 0; k < sizeof px / sizeof px[0]; k++) {
        size_t i = (size_t)px[k][1] * PL_SIZE + px[k][0];
        double got = f.xyz[3 * i + 1] / f.count[i], want = point_light_expected_y(px[k][0], px[k][1]);
        printf("  pixel (%2d, %2d): Y %.5f, expected %.5f (%+.2f%%)\n", px[k][0], px[k][1], got, want,
               100 * (got / want - 1));
        assert_close_rel(got, want, 0.02);
    }
    assert_close_rel(mean, want_mean, 0.01);
    /* A white light on a grey plane: X and Z in D65's proportions (x 0.3127,
     * y 0.3290), so the image is neutral. */
    double X = 0, Y = 0, Z = 0;
    for (int i = 0; i < PL_SIZE * PL_SIZE; i++) {
        X += f.xyz[3 * i] / f.count[i];
        Y += f.xyz[3 * i + 1] / f.count[i];
        Z += f.xyz[3 * i + 2] / f.count[i];
    }
    printf("  chromaticity x %.4f y %.4f (D65 0.3127 0.3290)\n", X / (X + Y + Z), Y / (X + Y + Z));
    assert_close(X / (X + Y + Z), 0.3127, 0.003);
    assert_close(Y / (X + Y + Z), 0.3290, 0.003);
    film_free(&f);
}

/* The rough glass sphere of the furnace (mat_furnace_roughglass.gltf, the same
 * sphere and camera as above, unlimited depth) against Mitsuba 3's
 * roughdielectric (GGX, alpha 0.25) under a constant sky of radiance 1: the
 * image mean within 2%. Mitsuba's Smith masking is separable, ours height-
 * correlated (which loses a little less), so ours may sit slightly above. */
TEST(test_furnace_roughglass_vs_mitsuba)
{
    skip_if_quick();
    double want[3];
    assert_int_equal(json_triple("tests/data/mitsuba/mat_furnace_roughglass_means.json", "\"max_depth_-1\"",
                                 "\"mean\"", want),
                     0);
    Film f;
    RenderStats st;
    assert_int_equal(render_file("tests/data/scenes/mat_furnace_roughglass.gltf", FURNACE_SIZE, FURNACE_SIZE, 64,
                                 -1, 23, NULL, &f, &st),
                     0);
    float *rgb = film_rgb(&f);
    double m[3] = {0, 0, 0};
    for (int i = 0; i < FURNACE_SIZE * FURNACE_SIZE; i++)
        for (int c = 0; c < 3; c++)
            m[c] += rgb[3 * i + c] / (FURNACE_SIZE * FURNACE_SIZE);
    printf("furnace rough glass (image mean): spectrace (%.4f, %.4f, %.4f), Mitsuba (%.4f, %.4f, %.4f)\n",
           m[0], m[1], m[2], want[0], want[1], want[2]);
    for (int c = 0; c < 3; c++) {
        assert_true(m[c] <= 1.005);
        assert_close_rel(m[c], want[c], 0.02);
    }
    free(rgb);
    film_free(&f);
}

TEST_MAIN("materials", setup_cpu_device, teardown_cpu_device)
