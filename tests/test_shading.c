/* The renderer on PoCL: surface shading inputs where the image shows them:
 * unlit materials, normal maps, volume absorption, dispersion, alpha blend and
 * mask; point lights of RGB and spectral emission against the inverse-square
 * law. */
#include "test_util.h"
#include "test_render_util.h"

#include <stdlib.h>
#include <string.h>

#include <math.h>
#include <unistd.h>

#include "cl/cl_device.h"
#include "io/exr.h"
#include "render/film.h"
#include "render/render.h"
#include "scene/scene.h"
#include "color/spd.h"
#include "spectrum/cie_data.h"

/* KHR_materials_unlit: the surface shows its base colour (upsampled as an
 * illuminant, so it comes back as the same linear sRGB), lit or not. */
TEST(test_unlit)
{
    Scene s;
    sphere_scene(&s, 0.0f);
    const float want[3] = {0.2f, 0.5f, 0.8f};
    for (int k = 0; k < 3; k++)
        s.materials[0].base_color[k] = want[k];
    s.materials[0].unlit = 1;
    RenderSettings rs = test_settings(16, 16, 64, -1, 0);
    Film f;
    render_film_ok(&s, &rs, &f);
    float rgb[16 * 16 * 3];
    film_to_linear_srgb(&f, rgb);
    double c[3] = {0, 0, 0};
    for (int y = 6; y < 10; y++)
        for (int x = 6; x < 10; x++)
            for (int k = 0; k < 3; k++)
                c[k] += rgb[3 * (y * 16 + x) + k] / 16.0;
    printf("unlit: (%.4f, %.4f, %.4f)\n", c[0], c[1], c[2]);
    for (int k = 0; k < 3; k++)
        assert_close(c[k], want[k], 0.01);
    assert_true(rgb[0] == 0.0f); /* a corner sees the black background */
    film_free(&f);
    scene_free(&s);
}

/* Normal maps: a Lambertian plane (facing +Y, u along +X, v along +Z) whose
 * normal texture tilts the normal by 30 degrees, once toward the tangent (+u: +X)
 * and once toward the bitangent (+Y of the texture = -v: -Z, the glTF
 * convention), lit by a directional light of 1000 lux from 30 degrees off the
 * zenith on that side, so the bent normal faces the light: L = rho/pi E. With the
 * light on the other side, L = rho/pi E cos(60 degrees). */
static double render_normal_mapped(int toward_bitangent, double light_sign)
{
    enum { W = 8 };
    const double a = M_PI / 6.0;
    Scene s;
    SceneMaterial *m = grey_quad_scene(&s);
    for (uint32_t v = 0; v < s.vertex_count; v++) {
        uint32_t t = v / 3, c = v % 3;
        const float *p = s.tri_pos + 9 * t + 3 * c;
        s.vtx_uv[2 * v] = (p[0] + 6.0f) / 12.0f;
        s.vtx_uv[2 * v + 1] = (p[2] + 6.0f) / 12.0f;
    }
    s.texture_count = 1;
    s.textures = calloc(1, sizeof(SceneTexture));
    SceneTexture *tx = &s.textures[0];
    tx->width = tx->height = 2;
    tx->channels = 3;
    tx->wrap_s = tx->wrap_t = SPT_WRAP_REPEAT;
    tx->texels = malloc(sizeof(float) * 12);
    float n[3] = {toward_bitangent ? 0.0f : (float)sin(a), toward_bitangent ? (float)sin(a) : 0.0f,
                  (float)cos(a)};
    for (int i = 0; i < 4; i++)
        for (int k = 0; k < 3; k++)
            tx->texels[3 * i + k] = 0.5f * (n[k] + 1.0f);
    m->tex[SPT_SLOT_NORMAL].tex = 0;
    camera_down(&s, 0.0f, 3.0f, 0.2f, 1.0f);
    s.light_count = 1;
    s.lights = calloc(1, sizeof(SceneLight));
    SceneLight *dl = &s.lights[0];
    dl->type = SPT_LIGHT_DIRECTIONAL;
    /* The light travels toward -(side) and down; side = +X or -Z. */
    double side = light_sign * sin(a);
    dl->direction[0] = toward_bitangent ? 0.0f : (float)-side;
    dl->direction[2] = toward_bitangent ? (float)side : 0.0f;
    dl->direction[1] = (float)-cos(a);
    dl->intensity = 1000.0f;
    for (int k = 0; k < 3; k++)
        dl->color[k] = 1.0f;
    scene_update_bounds(&s);
    SptError e = {0};
    RenderSettings rs = square_settings(W, 16, 2, 9);
    float rgb[W * W * 3];
    assert_int_equal(render_scene_rgb(&s, &rs, rgb, &e), 0);
    double mean = 0;
    for (int i = 0; i < W * W * 3; i++)
        mean += rgb[i] / (W * W * 3);
    scene_free(&s);
    return mean;
}

TEST(test_normal_map)
{
    const double full = 0.5 / M_PI * 1000.0; /* film Y in cd/m^2 */
    for (int b = 0; b < 2; b++) {
        double toward = render_normal_mapped(b, 1.0), away = render_normal_mapped(b, -1.0);
        printf("normal map (tilt toward the %s): facing the light %.6g (expected %.6g), "
               "away %.6g (expected %.6g)\n", b ? "bitangent" : "tangent", toward, full, away, 0.5 * full);
        assert_close_rel(toward, full, 0.01);
        assert_close_rel(away, 0.5 * full, 0.01);
    }
}

/* KHR_materials_volume: a clear slab 2 m thick (transmission 1, ior 1: no
 * Fresnel loss, no bending) with attenuation colour 0.5 at 1 m, in the default
 * white sky: each pixel sees the sky through 2 / cos(theta) metres of it, so
 * L = 0.5^(2 / cos theta) (Beer-Lambert). */
TEST(test_volume_absorption)
{
    enum { W = 16 };
    Scene s;
    memset(&s, 0, sizeof s);
    const float lo[3] = {-4, -4, -1}, hi[3] = {4, 4, 1};
    SceneMaterial *m = append_box(&s, lo, hi);
    set_clear_glass(m, 1.0f); /* ior 1: no refraction, only the medium */
    for (int k = 0; k < 3; k++)
        m->attenuation_color[k] = 0.5f;
    m->attenuation_distance = 1.0f;
    s.camera.position[2] = 6.0f;
    s.camera.forward[2] = -1.0f;
    s.camera.up[1] = 1.0f;
    s.camera.right[0] = 1.0f;
    s.camera.yfov = 0.4f;
    s.camera.aspect = 1.0f;
    scene_update_bounds(&s);
    SptError e = {0};
    RenderSettings rs = square_settings(W, 16, -1, 4);
    float rgb[W * W * 3];
    assert_int_equal(render_scene_rgb(&s, &rs, rgb, &e), 0);
    double got = 0, want = 0, t = tan(0.2);
    for (int py = 0; py < W; py++)
        for (int px = 0; px < W; px++) {
            double sx = (2.0 * (px + 0.5) / W - 1.0) * t, sy = (1.0 - 2.0 * (py + 0.5) / W) * t;
            double cos_t = 1.0 / sqrt(1.0 + sx * sx + sy * sy);
            want += 3.0 * pow(0.5, 2.0 / cos_t);
            for (int k = 0; k < 3; k++)
                got += rgb[3 * (py * W + px) + k];
        }
    printf("volume: mean %.5f, Beer-Lambert %.5f\n", got / (3 * W * W), want / (3 * W * W));
    assert_close_rel(got, want, 0.01);
    scene_free(&s);
}

/* KHR_materials_dispersion in a white furnace: a smooth glass sphere (ior 1.5,
 * dispersion 3, i.e. Abbe number 6.7) in the default sky of radiance 1 must look
 * exactly like the sky, whatever the wavelengths do: paths that refract keep
 * only their hero wavelength (pbrt-v4's TerminateSecondary), which must stay
 * unbiased, so the sphere's pixels average 1 in every channel. */
TEST(test_dispersion_furnace)
{
    enum { W = 24 };
    Scene s;
    SptError e = {0};
    sphere_scene(&s, 1.0f);
    /* Smooth vertex normals: inside a smooth sphere a ray keeps its angle of
     * incidence, so a path beyond the critical angle is totally reflected with
     * throughput 1 forever unless Russian roulette still ends it (this render
     * once never finished). */
    for (uint32_t v = 0; v < s.vertex_count; v++) {
        const float *q = s.tri_pos + 3 * v; /* vertex v is corner v % 3 of triangle v / 3 */
        float l = sqrtf(q[0] * q[0] + q[1] * q[1] + q[2] * q[2]);
        for (int k = 0; k < 3; k++)
            s.vtx_normal[3 * v + k] = q[k] / l;
    }
    SceneMaterial *m = &s.materials[0];
    m->transmission = 1.0f;
    m->roughness = 0.0f;
    m->specular = 1.0f;
    m->dispersion = 3.0f;
    RenderSettings rs = square_settings(W, 256, -1, 12);
    float rgb[W * W * 3];
    assert_int_equal(render_scene_rgb(&s, &rs, rgb, &e), 0);
    double c[3] = {0, 0, 0};
    for (int y = 8; y < 16; y++)
        for (int x = 8; x < 16; x++)
            for (int k = 0; k < 3; k++)
                c[k] += rgb[3 * (y * W + x) + k] / 64.0;
    printf("dispersive glass furnace: (%.4f, %.4f, %.4f), expected 1\n", c[0], c[1], c[2]);
    for (int k = 0; k < 3; k++)
        assert_close(c[k], 1.0, 0.02);
    scene_free(&s);
}

/* alphaMode BLEND: a black plane of alpha 0.5 between the emitter and the lit
 * plane of plane_irradiance.gltf transmits half the light (camera and shadow
 * rays both); alphaMode MASK below its cutoff transmits all of it. */
TEST(test_alpha_blend_and_mask)
{
    const double open = 0.96833700; /* tests/data/scenes/README.md: rho L0 mean(F) */
    for (int mode = 0; mode < 2; mode++) {
        Scene s;
        SptError e = {0};
        assert_int_equal(scene_load_gltf(&s, "tests/data/scenes/plane_irradiance.gltf", &e), 0);
        SceneMaterial *m = append_quad(&s, 0.75f);
        m->base_color[0] = m->base_color[1] = m->base_color[2] = 0.0f;
        m->base_color[3] = mode == 0 ? 0.5f : 0.3f;
        m->alpha_mode = mode == 0 ? SPT_ALPHA_BLEND : SPT_ALPHA_MASK;
        m->alpha_cutoff = 0.5f;
        RenderSettings rs = test_settings(16, 16, 128, -1, 0);
        Film f;
        render_film_ok(&s, &rs, &f);
        double mean[3];
        film_mean(&f, mean);
        double want = mode == 0 ? 0.5 * open : open;
        printf("%s plane: mean %.4f, expected %.4f\n", mode == 0 ? "blend 0.5" : "mask (cut out)", mean[1], want);
        for (int c = 0; c < 3; c++)
            assert_close_rel(mean[c], want, 0.02);
        film_free(&f);
        scene_free(&s);
    }
}

/* A point light of 10 cd 2 m over a Lambertian floor of albedo 0.5, seen
 * from 3 m straight above (direct light only): the floor's luminance is
 * rho E / pi with E = I cos(theta) / r^2, whatever the light's spectrum, since
 * a punctual light's intensity is photometric (docs/gltf.md). Four lights: a
 * white RGB colour (D65 as an illuminant), the named D65 and A SPDs and the
 * mercury lines (extras.spectrace.emission). Each image's mean Y over the
 * pixels' expected values must be 1; its chromaticity that of the spectrum
 * (D65 and A: CIE 15's 0.31272 0.32903 and 0.44757 0.40745; mercury: summed
 * here from the NIST lines and the CIE 1931 tables), and the white and D65
 * lights' images agree pixel by pixel (same samples, the same spectrum up to
 * the upsampling's fit). */
#define SPL_W 32

static void render_point_light(const char *spd, double rgb_xyz[3], double *ratio, float *img)
{
    Scene s;
    memset(&s, 0, sizeof s);
    const float floor_c[4][3] = {{-4, 0, -4}, {-4, 0, 4}, {4, 0, 4}, {4, 0, -4}};
    SceneMaterial *fl = append_rect(&s, floor_c);
    for (int k = 0; k < 3; k++)
        fl->base_color[k] = 0.5f;
    s.light_count = 1;
    s.lights = calloc(1, sizeof(SceneLight));
    SceneLight *l = &s.lights[0];
    strcpy(l->name, "bulb");
    l->type = SPT_LIGHT_POINT;
    l->position[1] = 2.0f;
    l->direction[1] = -1.0f;
    l->intensity = 10.0f;
    for (int k = 0; k < 3; k++)
        l->color[k] = 1.0f;
    SptError e = {0};
    if (spd)
        assert_int_equal(spd_named(&l->spd, spd, &e), 0);
    const float tf = 0.1f; /* tan of the half field of view */
    camera_down(&s, 0.0f, 3.0f, 2.0f * atanf(tf), 1.0f);
    scene_update_bounds(&s);
    RenderSettings rs = square_settings(SPL_W, 256, 2, 5);
    Film f;
    render_film_ok(&s, &rs, &f);
    double sum_y = 0, sum_want = 0;
    for (int k = 0; k < 3; k++)
        rgb_xyz[k] = 0;
    for (int py = 0; py < SPL_W; py++)
        for (int px = 0; px < SPL_W; px++) {
            size_t i = (size_t)py * SPL_W + px;
            double x = 3.0 * tf * (2.0 * (px + 0.5) / SPL_W - 1.0), z = 3.0 * tf * (2.0 * (py + 0.5) / SPL_W - 1.0);
            double r = sqrt(x * x + z * z + 4.0);
            sum_want += 0.5 / M_PI * 10.0 * (2.0 / r) / (r * r);
            for (int k = 0; k < 3; k++)
                rgb_xyz[k] += f.xyz[3 * i + k] / f.count[i];
            sum_y += f.xyz[3 * i + 1] / f.count[i];
            img[i] = (float)(f.xyz[3 * i + 1] / f.count[i]);
        }
    *ratio = sum_y / sum_want;
    film_free(&f);
    scene_free(&s);
}

TEST(test_spectral_point_light)
{
    static const char *spds[4] = {NULL, "D65", "A", "mercury"};
    /* Mercury's chromaticity from the NIST lines (tests/test_lights.c). */
    static const double hg_nm[6] = {404.656, 407.783, 435.833, 546.074, 576.960, 579.066};
    static const double hg_rel[6] = {1800, 150, 4000, 1100, 240, 280};
    double hg[3] = {0};
    for (int j = 0; j < 6; j++) {
        double x = hg_nm[j] - SPT_CIE_LAMBDA_MIN;
        int i = (int)x;
        double fr = x - i;
        hg[0] += hg_rel[j] * ((1 - fr) * SPT_CIE_X[i] + fr * SPT_CIE_X[i + 1]);
        hg[1] += hg_rel[j] * ((1 - fr) * SPT_CIE_Y[i] + fr * SPT_CIE_Y[i + 1]);
        hg[2] += hg_rel[j] * ((1 - fr) * SPT_CIE_Z[i] + fr * SPT_CIE_Z[i + 1]);
    }
    const double want_xy[4][2] = {{0.31272, 0.32903}, {0.31272, 0.32903}, {0.44757, 0.40745},
                                  {hg[0] / (hg[0] + hg[1] + hg[2]), hg[1] / (hg[0] + hg[1] + hg[2])}};
    const double tol_y[4] = {0.01, 0.01, 0.01, 0.05}; /* mercury: lines are 2 nm of the samples */
    static float img[4][SPL_W * SPL_W];
    for (int k = 0; k < 4; k++) {
        double xyz[3], ratio;
        render_point_light(spds[k], xyz, &ratio, img[k]);
        double sum = xyz[0] + xyz[1] + xyz[2], cx = xyz[0] / sum, cy = xyz[1] / sum;
        printf("point light, %s: mean Y %.4f of rho I cos / (pi r^2), chromaticity %.4f %.4f (expected %.4f %.4f)\n",
               spds[k] ? spds[k] : "white RGB", ratio, cx, cy, want_xy[k][0], want_xy[k][1]);
        assert_close(ratio, 1.0, tol_y[k]);
        assert_close(cx, want_xy[k][0], 0.003);
        assert_close(cy, want_xy[k][1], 0.003);
    }
    double worst = 0;
    for (int i = 0; i < SPL_W * SPL_W; i++)
        worst = fmax(worst, fabs(img[1][i] / img[0][i] - 1.0));
    printf("white RGB and D65 lights: largest per-pixel difference in Y %.2g\n", worst);
    assert_true(worst < 0.01);
}

TEST_MAIN("shading", setup_cpu_device, teardown_cpu_device)
