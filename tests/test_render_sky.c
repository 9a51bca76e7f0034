/* The renderer on PoCL: the sky (the default white sky, --background, an
 * environment map against its analytic irradiance) and punctual lights against
 * the inverse-square law and their photometric units. */
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

/* With no light at all, the default sky (D65, radiance 1) lights the scene: a
 * Lambertian surface of albedo rho open to the whole sky shows rho, the sky
 * itself shows 1; --background black keeps it dark. */
TEST(test_default_sky)
{
    Scene s;
    SptError e = {0};
    sphere_scene(&s, 0.5f);
    RenderSettings rs = test_settings(32, 32, 64, -1, 0);
    Film f;
    render_film_ok(&s, &rs, &f);
    float *rgb = malloc(32 * 32 * 3 * sizeof(float));
    film_to_linear_srgb(&f, rgb);
    /* The central 8x8 pixels see the sphere's front, the corners the sky
     * (the 4x4 pixels of the top-left one: a single pixel's 64 samples hold
     * its blue within about 1%, the tolerance below). */
    double centre[3] = {0, 0, 0}, corner[3] = {0, 0, 0};
    for (int y = 12; y < 20; y++)
        for (int x = 12; x < 20; x++)
            for (int c = 0; c < 3; c++)
                centre[c] += rgb[3 * (y * 32 + x) + c] / 64.0;
    for (int y = 0; y < 4; y++)
        for (int x = 0; x < 4; x++)
            for (int c = 0; c < 3; c++)
                corner[c] += rgb[3 * (y * 32 + x) + c] / 16.0;
    printf("default sky: sphere (%.4f, %.4f, %.4f), sky (%.4f, %.4f, %.4f)\n", centre[0], centre[1],
           centre[2], corner[0], corner[1], corner[2]);
    for (int c = 0; c < 3; c++) {
        assert_close_rel(centre[c], 0.5, 0.02);
        assert_close_rel(corner[c], 1.0, 0.01);
    }
    film_free(&f);
    /* --background black: no light at all. */
    Sky black;
    assert_int_equal(sky_from_args(&black, NULL, "black", &e), 0);
    rs.sky = &black;
    render_film_ok(&s, &rs, &f);
    film_to_linear_srgb(&f, rgb);
    for (int i = 0; i < 32 * 32 * 3; i++)
        assert_true(rgb[i] == 0.0f);
    film_free(&f);
    sky_free(&black);
    free(rgb);
    scene_free(&s);
}

/* The grey box under the default sky (tests/data/scenes/grey_box_sky.gltf): every
 * face pixel has the expected value 0.5 (a convex Lambertian object of albedo 0.5
 * sees only the sky of radiance 1), so a face pixel's squared error is its
 * noise. Face pixels are those below 0.75 whose 8 neighbours are too (the
 * silhouette mixes in the sky). Returns the mean value and the mean squared
 * error per channel of one render with the given sampler. */
static int grey_box_noise_blocks(spt_u32 sampler, int w, int spp, double mean[3], double mse[3],
                                 double block_mse[3]);

static int grey_box_noise(spt_u32 sampler, int w, int spp, double mean[3], double mse[3])
{
    return grey_box_noise_blocks(sampler, w, spp, mean, mse, NULL);
}

/* As grey_box_noise, and in block_mse (unless NULL) the mean squared error of
 * the means of the aligned 2 x 2 pixel blocks whose pixels are all face
 * pixels: a quarter of mse when neighbouring pixels' errors are independent,
 * less when they cancel. */
static int grey_box_noise_blocks(spt_u32 sampler, int w, int spp, double mean[3], double mse[3],
                                 double block_mse[3])
{
    Scene s;
    SptError e = {0};
    if (scene_load_gltf(&s, "tests/data/scenes/grey_box_sky.gltf", &e)) {
        fprintf(stderr, "%s\n", e.msg);
        return -1;
    }
    RenderSettings rs = square_settings(w, spp, -1, 3u);
    rs.sampler = sampler;
    float *rgb = malloc(sizeof(float) * 3 * (size_t)w * (size_t)w);
    int rc = render_scene_rgb(&s, &rs, rgb, &e);
    scene_free(&s);
    int n = 0;
    for (int c = 0; c < 3; c++)
        mean[c] = mse[c] = 0;
    for (int y = 1; !rc && y < w - 1; y++)
        for (int x = 1; x < w - 1; x++) {
            int face = 1;
            for (int dy = -1; dy <= 1; dy++)
                for (int dx = -1; dx <= 1; dx++)
                    face &= rgb[3 * ((y + dy) * w + x + dx) + 1] < 0.75f;
            if (!face)
                continue;
            n++;
            for (int c = 0; c < 3; c++) {
                double v = rgb[3 * (y * w + x) + c];
                mean[c] += v;
                mse[c] += (v - 0.5) * (v - 0.5);
            }
        }
    int nb = 0;
    if (block_mse) {
        for (int c = 0; c < 3; c++)
            block_mse[c] = 0;
        for (int y = 0; !rc && y + 1 < w; y += 2)
            for (int x = 0; x + 1 < w; x += 2) {
                int face = 1;
                for (int dy = -1; dy <= 2; dy++)
                    for (int dx = -1; dx <= 2; dx++) {
                        int yy = y + dy, xx = x + dx;
                        face &= yy >= 0 && yy < w && xx >= 0 && xx < w && rgb[3 * (yy * w + xx) + 1] < 0.75f;
                    }
                if (!face)
                    continue;
                nb++;
                for (int c = 0; c < 3; c++) {
                    double v = 0.25 * (rgb[3 * (y * w + x) + c] + rgb[3 * (y * w + x + 1) + c] +
                                       rgb[3 * ((y + 1) * w + x) + c] + rgb[3 * ((y + 1) * w + x + 1) + c]);
                    block_mse[c] += (v - 0.5) * (v - 0.5);
                }
            }
        for (int c = 0; c < 3; c++)
            block_mse[c] /= nb > 0 ? nb : 1;
    }
    free(rgb);
    if (rc || n < w * w / 2 || (block_mse && nb < w * w / 16))
        return -1;
    for (int c = 0; c < 3; c++) {
        mean[c] /= n;
        mse[c] /= n;
    }
    return 0;
}

/* --sampler: the Sobol sampler (the default) leaves the grey box's faces with at
 * most half the squared error of the independent sampler at the same samples
 * (at 64 spp it measured 1/9 to 1/17 per channel), and both are unbiased. The
 * colour noise is held too: a per-pixel std of at most 0.0055 in every channel
 * (measured 0.0043, 0.0015, 0.0049; 0.0067, 0.0045, 0.0069 when the sky's
 * light samples were spread over the whole sphere, half of them below the
 * face's horizon; 0.011 in blue with a wavelength density fitted to ybar,
 * whose blue weights vary most). */
TEST(test_sampler_noise)
{
    double m_sob[3], e_sob[3], m_ind[3], e_ind[3];
    assert_int_equal(grey_box_noise(SPT_SAMPLER_SOBOL, 64, 64, m_sob, e_sob), 0);
    assert_int_equal(grey_box_noise(SPT_SAMPLER_INDEPENDENT, 64, 64, m_ind, e_ind), 0);
    for (int c = 0; c < 3; c++) {
        printf("grey box, channel %d: mean %.5f (sobol) %.5f (independent), per-pixel std %.5f "
               "(sobol) %.5f (independent)\n", c, m_sob[c], m_ind[c], sqrt(e_sob[c]), sqrt(e_ind[c]));
        assert_close(m_sob[c], 0.5, 0.002);
        assert_close(m_ind[c], 0.5, 0.004);
        assert_true(e_sob[c] <= 0.5 * e_ind[c]);
        assert_true(sqrt(e_sob[c]) <= 0.0055);
    }
}

/* --sampler zsobol: unbiased and about as good per pixel as the Sobol sampler
 * at 4 samples per pixel (squared error at most 1.3 times; measured 1.06,
 * 1.14, 0.98), and its errors cancel between neighbours: the means of 2 x 2
 * pixel blocks keep at most 0.6 times the squared error that the Sobol
 * sampler's keep (whose pixels' errors are independent: a quarter of a
 * pixel's; measured 0.30, 0.29 and 0.44 in red, green and blue). */
TEST(test_zsobol_blue_noise)
{
    double m_z[3], e_z[3], b_z[3], m_s[3], e_s[3], b_s[3], m_i[3], e_i[3];
    /* The independent sampler's figure is printed for comparison: at 4
     * samples neither Sobol form beats it per pixel on this scene. */
    assert_int_equal(grey_box_noise_blocks(SPT_SAMPLER_ZSOBOL, 64, 4, m_z, e_z, b_z), 0);
    assert_int_equal(grey_box_noise_blocks(SPT_SAMPLER_SOBOL, 64, 4, m_s, e_s, b_s), 0);
    assert_int_equal(grey_box_noise(SPT_SAMPLER_INDEPENDENT, 64, 4, m_i, e_i), 0);
    for (int c = 0; c < 3; c++) {
        printf("grey box 4 spp, channel %d: mean %.5f (zsobol) %.5f (sobol); per-pixel std %.5f (zsobol) "
               "%.5f (sobol) %.5f (independent); 2x2 block mean std %.5f (zsobol) %.5f (sobol)\n",
               c, m_z[c], m_s[c], sqrt(e_z[c]), sqrt(e_s[c]), sqrt(e_i[c]), sqrt(b_z[c]), sqrt(b_s[c]));
        assert_close(m_z[c], 0.5, 0.004);
        assert_true(e_z[c] <= 1.3 * e_s[c]);
        assert_true(b_z[c] <= 0.6 * b_s[c]);
    }
}

/* KHR_lights_punctual in the renderer, units included: a pure Lambertian plane
 * (albedo 0.5) under a spot light of 100 cd pointing down from 2 m (cones 0.3
 * and 0.5 rad), then under the spot and a directional light of 1000 lux at 45
 * degrees at once (one light picked per sample by power). Each pixel's radiance
 * is rho/pi times the illuminance, E = E_dir cos(45) + I cos(theta) falloff / r^2
 * (the extension's smooth cone falloff), in film units Y = Lv (the film's
 * unit is the nit, as for emissive colours); the lights are white (D65), so
 * every channel of linear sRGB equals Y. */
static void render_punctual(int with_directional, float *rgb, int w)
{
    Scene s;
    grey_quad_scene(&s);
    camera_down(&s, 0.0f, 3.0f, 1.0f, 1.0f);
    s.light_count = with_directional ? 2 : 1;
    s.lights = calloc(2, sizeof(SceneLight));
    SceneLight *sp = &s.lights[0], *dl = &s.lights[1];
    sp->type = SPT_LIGHT_SPOT;
    sp->position[1] = 2.0f;
    sp->direction[1] = -1.0f;
    sp->intensity = 100.0f;
    sp->inner_cone = 0.3f;
    sp->outer_cone = 0.5f;
    dl->type = SPT_LIGHT_DIRECTIONAL;
    dl->direction[1] = dl->direction[2] = -(float)sqrt(0.5);
    dl->intensity = 1000.0f;
    for (int k = 0; k < 3; k++)
        dl->color[k] = sp->color[k] = 1.0f;
    scene_update_bounds(&s);
    SptError e = {0};
    RenderSettings rs = square_settings(w, with_directional ? 256 : 32, -1, 5);
    assert_int_equal(render_scene_rgb(&s, &rs, rgb, &e), 0);
    scene_free(&s);
}

TEST(test_punctual_lights)
{
    enum { W = 48 };
    float *rgb = malloc(W * W * 3 * sizeof(float));
    const double to_film = 1.0; /* film Y = luminance in cd/m^2 (kernels/light/lights.h) */
    const double ci = cos(0.3), co = cos(0.5), t = tan(0.5);
    for (int both = 0; both < 2; both++) {
        render_punctual(both, rgb, W);
        double got = 0, want = 0, got_in = 0, want_in = 0, got_edge = 0, want_edge = 0;
        int n_in = 0;
        for (int py = 0; py < W; py++)
            for (int px = 0; px < W; px++) {
                double sx = 2.0 * (px + 0.5) / W - 1.0, sy = 1.0 - 2.0 * (py + 0.5) / W;
                double X = 3.0 * sx * t, Z = -3.0 * sy * t;
                double r2 = X * X + Z * Z + 4.0, r = sqrt(r2);
                double c = 2.0 / r; /* incidence and angle from the spot's axis */
                double tt = fmin(fmax((c - co) / (ci - co), 0.0), 1.0);
                double E = (both ? 1000.0 * sqrt(0.5) : 0.0) + 100.0 * c * tt * tt / r2;
                double L = 0.5 / M_PI * E * to_film;
                for (int k = 0; k < 3; k++) {
                    double v = rgb[3 * (py * W + px) + k];
                    got += v;
                    want += L;
                    if (tt >= 1.0) {
                        got_in += v;
                        want_in += L;
                    } else if (tt > 0.0) {
                        got_edge += v;
                        want_edge += L;
                    }
                }
                n_in += tt >= 1.0;
            }
        printf("punctual (%s): image mean %.6g, predicted %.6g; inner cone %.6g, predicted %.6g (%d "
               "pixels); falloff ring %.6g, predicted %.6g\n", both ? "spot + directional" : "spot",
               got / (3 * W * W), want / (3 * W * W), got_in / (3 * n_in), want_in / (3 * n_in), n_in,
               got_edge, want_edge);
        assert_true(n_in > 50);
        assert_close_rel(got, want, 0.01);
        if (!both) {
            assert_close_rel(got_in, want_in, 0.01);
            assert_close_rel(got_edge, want_edge, 0.02);
        }
    }
    free(rgb);
}

/* The plane of plane_irradiance.gltf lit by an emitter whose radiance is a named
 * SPD normalised to Y = 1 (illuminant A, the mercury lamp's lines): the plane's
 * XYZ is rho * mean(F) times the SPD's XYZ from the colour science (what
 * `spectrace color` prints), per channel. */
TEST(test_named_light_spectra)
{
    const double rho_f = 0.5 * 0.96833700;
    const char *names[2] = {"A", "mercury"};
    const int spp[2] = {64, 512};
    const double tol[2] = {0.015, 0.03};
    for (int k = 0; k < 2; k++) {
        Scene s;
        SptError e = {0};
        assert_int_equal(scene_load_gltf(&s, "tests/data/scenes/plane_irradiance.gltf", &e), 0);
        Spd spd;
        assert_int_equal(spd_named(&spd, names[k], &e), 0);
        double xyz[3];
        spd_to_xyz(&spd, xyz);
        /* Normalise to Y = 1 in the film's units (XYZ = sum cmf P / sum ybar). */
        double scale = SPT_CIE_Y_INTEGRAL_HOST / xyz[1];
        for (int i = 0; i < spd.count; i++)
            spd.value[i] *= scale;
        for (int i = 0; i < spd.line_count; i++)
            spd.line_power[i] *= scale;
        int emitters = 0;
        for (uint32_t m = 0; m < s.material_count; m++)
            if (s.materials[m].emissive[0] > 0) {
                spd_free(&s.materials[m].emission_spd);
                spd_copy(&s.materials[m].emission_spd, &spd);
                emitters++;
            }
        assert_int_equal(emitters, 1);
        RenderSettings rs = test_settings(8, 8, spp[k], -1, 0);
        Film f;
        render_film_ok(&s, &rs, &f);
        double got[3] = {0, 0, 0};
        for (int i = 0; i < 64; i++)
            for (int c = 0; c < 3; c++)
                got[c] += f.xyz[3 * i + c] / f.count[i] / 64.0;
        printf("%s: plane XYZ (%.4f, %.4f, %.4f), expected (%.4f, %.4f, %.4f)\n", names[k], got[0],
               got[1], got[2], rho_f * xyz[0] * scale / SPT_CIE_Y_INTEGRAL_HOST, rho_f,
               rho_f * xyz[2] * scale / SPT_CIE_Y_INTEGRAL_HOST);
        for (int c = 0; c < 3; c++)
            assert_close_rel(got[c], rho_f * xyz[c] * scale / SPT_CIE_Y_INTEGRAL_HOST, tol[k]);
        spd_free(&spd);
        film_free(&f);
        scene_free(&s);
    }
}

/* Direction of environment map coordinates (u, v) (kernels/util/render_types.h,
 * GpuEnvMap): theta = pi v from +Y, phi = 2 pi u. */
static void env_dir(double u, double v, double d[3])
{
    double th = M_PI * v, ph = 2.0 * M_PI * u;
    d[0] = -sin(ph) * sin(th);
    d[1] = cos(th);
    d[2] = cos(ph) * sin(th);
}

/* --env: a map with a bright warm patch over a dim blue sky lights a white
 * Lambertian sphere. Pixels that see the sky show the map's texel; the sphere's
 * front shows rho/pi times the integral of L max(0, w.n) over the map, summed by
 * brute force over sub-cells of every texel. This checks the map's importance
 * sampling, its pdf and its MIS with BSDF sampling in the renderer. */
TEST(test_env_map)
{
    enum { MW = 32, MH = 16, W = 32 };
    static float map[MW * MH * 3];
    const double sun[3] = {0.6 / 1.0, 0.5, 0.6};
    double sl = sqrt(sun[0] * sun[0] + sun[1] * sun[1] + sun[2] * sun[2]);
    for (int y = 0; y < MH; y++)
        for (int x = 0; x < MW; x++) {
            double d[3];
            env_dir((x + 0.5) / MW, (y + 0.5) / MH, d);
            int hot = (d[0] * sun[0] + d[1] * sun[1] + d[2] * sun[2]) / sl > 0.85;
            float *t = map + 3 * (y * MW + x);
            t[0] = hot ? 6.0f : 0.2f;
            t[1] = hot ? 4.0f : 0.3f;
            t[2] = hot ? 2.0f : 0.5f;
        }
    char path[64];
    snprintf(path, sizeof path, "/tmp/spectrace_env_%d.exr", (int)getpid());
    SptError e = {0};
    assert_int_equal(exr_write_rgb(path, map, MW, MH, NULL, 0, &e), 0);

    Scene s;
    sphere_scene(&s, 0.5f);
    RenderSettings rs = square_settings(W, 256, -1, 11);
    Sky sky;
    if (sky_from_args(&sky, path, NULL, &e))
        fail_msg("%s", e.msg);
    rs.sky = &sky;
    float *rgb = malloc(W * W * 3 * sizeof(float));
    int rc = render_scene_rgb(&s, &rs, rgb, &e);
    sky_free(&sky);
    unlink(path);
    if (rc)
        fail_msg("%s", e.msg);

    /* Camera rays through pixel centres (sphere_scene: at +Z 4 looking -Z). */
    double t = tan(0.5 * s.camera.yfov);
    double got_sphere[3] = {0, 0, 0}, want_sphere[3] = {0, 0, 0};
    double got_sky[3] = {0, 0, 0}, want_sky[3] = {0, 0, 0};
    int n_sphere = 0, n_sky = 0;
    for (int py = 0; py < W; py++)
        for (int px = 0; px < W; px++) {
            double dx = (2.0 * (px + 0.5) / W - 1.0) * t, dy = (1.0 - 2.0 * (py + 0.5) / W) * t;
            double dl = sqrt(dx * dx + dy * dy + 1.0);
            double d[3] = {dx / dl, dy / dl, -1.0 / dl};
            /* Ray (0,0,4) + s d against the unit sphere. */
            double b = 4.0 * d[2], c = 16.0 - 1.0;
            double disc = b * b - c;
            const float *pix = rgb + 3 * (py * W + px);
            if (disc > 0.0 && sqrt(disc) > 0.1 && px >= 12 && px < 20 && py >= 12 && py < 20) {
                double sh = -b - sqrt(disc);
                double n[3] = {sh * d[0], sh * d[1], 4.0 + sh * d[2]};
                double irr[3] = {0, 0, 0};
                const int sub = 8;
                for (int y = 0; y < MH; y++)
                    for (int x = 0; x < MW; x++)
                        for (int j = 0; j < sub; j++)
                            for (int i = 0; i < sub; i++) {
                                double u = (x + (i + 0.5) / sub) / MW, v = (y + (j + 0.5) / sub) / MH;
                                double w[3];
                                env_dir(u, v, w);
                                double c2 = w[0] * n[0] + w[1] * n[1] + w[2] * n[2];
                                if (c2 <= 0.0)
                                    continue;
                                double dw = (2.0 * M_PI / MW) * (M_PI / MH) * sin(M_PI * v) / (sub * sub);
                                for (int k = 0; k < 3; k++)
                                    irr[k] += map[3 * (y * MW + x) + k] * c2 * dw;
                            }
                for (int k = 0; k < 3; k++) {
                    want_sphere[k] += 0.5 / M_PI * irr[k];
                    got_sphere[k] += pix[k];
                }
                n_sphere++;
            } else if (disc <= 0.0) {
                /* The sky: the texel of the pixel's direction (with the camera's
                 * -Z at u = 1/2). Pixels whose footprint may straddle texels are
                 * skipped: all four corners must fall in one texel. */
                int tx = -1, ty = -1, same = 1;
                for (int q = 0; q < 4; q++) {
                    double cx = (2.0 * (px + (q & 1)) / W - 1.0) * t, cy = (1.0 - 2.0 * (py + (q >> 1)) / W) * t;
                    double cl = sqrt(cx * cx + cy * cy + 1.0);
                    double cd[3] = {cx / cl, cy / cl, -1.0 / cl};
                    double phi = atan2(-cd[0], cd[2]);
                    if (phi < 0)
                        phi += 2.0 * M_PI;
                    int qx = (int)(phi / (2.0 * M_PI) * MW), qy = (int)(acos(cd[1]) / M_PI * MH);
                    if (q == 0) {
                        tx = qx;
                        ty = qy;
                    } else if (qx != tx || qy != ty) {
                        same = 0;
                    }
                }
                if (!same)
                    continue;
                for (int k = 0; k < 3; k++) {
                    want_sky[k] += map[3 * (ty * MW + tx) + k];
                    got_sky[k] += pix[k];
                }
                n_sky++;
            }
        }
    assert_true(n_sphere >= 32 && n_sky >= 16);
    printf("env map: sphere (%.4f, %.4f, %.4f), brute force (%.4f, %.4f, %.4f) over %d pixels\n",
           got_sphere[0] / n_sphere, got_sphere[1] / n_sphere, got_sphere[2] / n_sphere,
           want_sphere[0] / n_sphere, want_sphere[1] / n_sphere, want_sphere[2] / n_sphere, n_sphere);
    printf("env map: sky (%.4f, %.4f, %.4f), texels (%.4f, %.4f, %.4f) over %d pixels\n",
           got_sky[0] / n_sky, got_sky[1] / n_sky, got_sky[2] / n_sky, want_sky[0] / n_sky,
           want_sky[1] / n_sky, want_sky[2] / n_sky, n_sky);
    /* The sky: within 1.5% of its largest channel (the RGB -> illuminant spectrum
     * -> RGB round trip of a saturated colour is off by up to 0.7% of it). */
    double sky_max = fmax(want_sky[0], fmax(want_sky[1], want_sky[2])) / n_sky;
    for (int k = 0; k < 3; k++) {
        assert_close_rel(got_sphere[k] / n_sphere, want_sphere[k] / n_sphere, 0.025);
        assert_true(fabs(got_sky[k] - want_sky[k]) / n_sky <= 0.015 * sky_max);
    }
    free(rgb);
    scene_free(&s);
}

/* --env names a missing file: one error naming it, an input error. */
TEST(test_env_missing)
{
    SptError e = {0};
    Sky sky;
    assert_int_equal(sky_from_args(&sky, "/nonexistent/sky.exr", NULL, &e), SPT_EXIT_INPUT);
    assert_non_null(strstr(e.msg, "/nonexistent/sky.exr"));
    /* --env and --background together are refused. */
    assert_int_equal(sky_from_args(&sky, "/nonexistent/sky.exr", "1,1,1", &e), SPT_EXIT_USAGE);
}

TEST_MAIN("render_sky", setup_cpu_device, teardown_cpu_device)
