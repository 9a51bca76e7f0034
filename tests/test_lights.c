/* kernels/light/lights.h and src/render/host_lights.c: punctual lights against the inverse-square
 * law and the KHR_lights_punctual spot formula, the photometric conversion
 * against the CIE tables, the environment map's sampling against its pdf
 * (chi-square), its normalisation and colour, the uniform background's
 * irradiance, the selection distribution, the device build of the header, and
 * lights with spectra of their own (extras.spectrace.emission). */
#include "test_cl_util.h"

#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "chi2.h"
#include "io/image_out.h"
#include "render/host_lights.h"

/* Chi-square tests in this binary, for the Sidak correction. */
#define LIGHTS_CHI2_TESTS 4

/* Four wavelengths spread over the visible range. */
static const float k_lambda[4] = {412.5f, 503.0f, 587.25f, 701.0f};

/* A scene light with defaults. */
static SceneLight make_light(int type, float x, float y, float z, float intensity)
{
    SceneLight l;
    memset(&l, 0, sizeof l);
    strcpy(l.name, "test");
    l.type = type;
    l.position[0] = x;
    l.position[1] = y;
    l.position[2] = z;
    l.direction[1] = -1.0f;
    l.color[0] = l.color[1] = l.color[2] = 1.0f;
    l.intensity = intensity;
    return l;
}

/* A tabulated spectrum's value at lambda (independent linear interpolation). */
static double table_at(const float *t, double lambda)
{
    double x = lambda - SPT_CIE_LAMBDA_MIN;
    int i = (int)floor(x);
    double f = x - i;
    return t[i] * (1.0 - f) + t[i + 1] * f;
}

/* ---- Punctual lights ------------------------------------------------------- */

/* E = I cos(theta) / r^2 on the plane y = 0 under a point light at (0.3, 2, -0.5). */
TEST(test_point_irradiance_on_plane)
{
    SceneLight sl = make_light(SPT_LIGHT_POINT, 0.3f, 2.0f, -0.5f, 25.0f);
    sl.color[0] = 0.8f;
    sl.color[2] = 0.4f;
    float table[SPT_CIE_SAMPLES];
    GpuLight gl;
    SptError e;
    assert_int_equal(light_from_scene(&sl, table, 0, &gl, &e), SPT_EXIT_OK);
    const double pts[5][2] = {{0, 0}, {0.3, -0.5}, {2, 1}, {-3, 0.5}, {5, -4}};
    for (int k = 0; k < 5; k++) {
        double dx = 0.3 - pts[k][0], dy = 2.0, dz = -0.5 - pts[k][1];
        double r2 = dx * dx + dy * dy + dz * dz, r = sqrt(r2), cos_t = dy / r;
        LightSample s;
        light_punctual_sample(&gl, table, v3((float)pts[k][0], 0.0f, (float)pts[k][1]), k_lambda, &s);
        assert_close(s.dist, r, 1e-5 * r);
        assert_close(s.wi.y, cos_t, 1e-6);
        assert_int_equal(s.is_delta, 1);
        for (int i = 0; i < 4; i++) {
            double want = table_at(table, k_lambda[i]) * cos_t / r2;
            assert_close_rel(s.value[i] * s.wi.y, want, 1e-5);
        }
    }
}

/* The spot falloff at the axis, the inner cone, between, the outer cone and
 * outside, against the specification's formula evaluated here in double:
 * t = clamp((cos a - cos outer) / (cos inner - cos outer), 0, 1), falloff t^2. */
TEST(test_spot_falloff)
{
    SceneLight sl = make_light(SPT_LIGHT_SPOT, 0.0f, 3.0f, 0.0f, 4.0f);
    sl.inner_cone = 0.3f;
    sl.outer_cone = 0.6f;
    float table[SPT_CIE_SAMPLES];
    GpuLight gl;
    SptError e;
    assert_int_equal(light_from_scene(&sl, table, 0, &gl, &e), SPT_EXIT_OK);
    const double angles[] = {0.0, 0.15, 0.3, 0.4, 0.45, 0.55, 0.6, 0.7, 1.2};
    for (size_t k = 0; k < sizeof angles / sizeof angles[0]; k++) {
        double a = angles[k];
        double t = (cos(a) - cos(0.6)) / (cos(0.3) - cos(0.6));
        t = t < 0 ? 0 : (t > 1 ? 1 : t);
        double want = t * t;
        assert_close(light_spot_falloff(&gl, (float)(1.0 - cos(a))), want, 2e-5);
        /* The same through the sampling function: a point at distance 2 at angle a
         * from the downward axis, rotated about it. */
        double px = 2.0 * sin(a) * cos(1.0), pz = 2.0 * sin(a) * sin(1.0), py = 3.0 - 2.0 * cos(a);
        LightSample s;
        light_punctual_sample(&gl, table, v3((float)px, (float)py, (float)pz), k_lambda, &s);
        assert_close(s.value[1], table_at(table, k_lambda[1]) * want / 4.0,
                     2e-5 * table_at(table, k_lambda[1]));
    }
    /* At the inner cone exactly 1, at the outer exactly 0 (to float rounding). */
    assert_close(light_spot_falloff(&gl, (float)(1.0 - cos(0.3))), 1.0, 1e-4);
    assert_close(light_spot_falloff(&gl, (float)(1.0 - cos(0.6))), 0.0, 1e-4);
}

/* A directional light gives its irradiance E(l) at any point, from the direction
 * opposite to where it shines, at the far distance. */
TEST(test_directional)
{
    SceneLight sl = make_light(SPT_LIGHT_DIRECTIONAL, 0, 0, 0, 3.0f);
    sl.direction[0] = 1.0f; /* not unit: normalised by the conversion */
    sl.direction[1] = -1.0f;
    float table[SPT_CIE_SAMPLES];
    GpuLight gl;
    SptError e;
    assert_int_equal(light_from_scene(&sl, table, 0, &gl, &e), SPT_EXIT_OK);
    LightSample s;
    light_punctual_sample(&gl, table, v3(5.0f, -2.0f, 1.0f), k_lambda, &s);
    assert_close(s.wi.x, -sqrt(0.5), 1e-6);
    assert_close(s.wi.y, sqrt(0.5), 1e-6);
    assert_true(s.dist >= 1e30f);
    for (int i = 0; i < 4; i++)
        assert_close_rel(s.value[i], table_at(table, k_lambda[i]), 1e-6);
    /* 3 lux: in film units (the nit) the Y-weighted mean of the table is 3, and
     * as radiometric W/(m^2 nm), 683 * sum(ybar E) = 3. */
    double y = 0.0, ny = 0.0;
    for (int i = 0; i < SPT_CIE_SAMPLES; i++) {
        y += SPT_CIE_Y[i] * table[i];
        ny += SPT_CIE_Y[i];
    }
    assert_close_rel(y / ny, 3.0, 1e-3);
    assert_close_rel(683.0 * y / SPT_LIGHT_FILM_PER_WATT, 3.0, 1e-4);
}

/* White (1,1,1) at 1 cd: radiant intensity 1/K W/sr, K = 683 sum(ybar D65) /
 * sum(D65) from the CIE tables; a coloured light keeps its candela. */
TEST(test_photometric_conversion)
{
    double sy = 0.0, sd = 0.0;
    for (int i = 0; i < SPT_CIE_SAMPLES; i++) {
        sy += SPT_CIE_Y[i] * SPT_D65_NORM[i];
        sd += SPT_D65_NORM[i];
    }
    double k = 683.0 * sy / sd;
    print_message("  luminous efficacy of D65 over 360-830 nm: %.3f lm/W\n", k);
    assert_true(k > 150.0 && k < 250.0); /* D65 is about 200 lm/W */
    SceneLight sl = make_light(SPT_LIGHT_POINT, 0, 0, 0, 1.0f);
    float table[SPT_CIE_SAMPLES];
    GpuLight gl;
    SptError e;
    assert_int_equal(light_from_scene(&sl, table, 17, &gl, &e), SPT_EXIT_OK);
    assert_int_equal(gl.spectrum.kind, SPT_SPEC_TABLE);
    assert_int_equal(gl.spectrum.offset, 17);
    /* The device table is in film units: back to W/(sr nm). */
    for (int i = 0; i < SPT_CIE_SAMPLES; i++)
        table[i] /= SPT_LIGHT_FILM_PER_WATT;
    double total = 0.0;
    for (int i = 0; i < SPT_CIE_SAMPLES; i++)
        total += table[i];
    /* The sigmoid of white is 1 up to the fit's residual; sums vs trapezoid: 1e-3. */
    assert_close_rel(total, 1.0 / k, 2e-3);
    /* Its shape is D65. */
    for (int i = 0; i < SPT_CIE_SAMPLES; i += 47)
        assert_close_rel(table[i] * k * sd, SPT_D65_NORM[i], 2e-3);
    float kf = (float)light_photometric_table(sl.color, 1.0, table);
    assert_close_rel(kf, k, 2e-3);
    const float colours[3][3] = {{1, 0, 0}, {0.1f, 0.9f, 0.3f}, {0.05f, 0.05f, 2.0f}};
    for (int c = 0; c < 3; c++) {
        light_photometric_table(colours[c], 50.0, table);
        double y = 0.0;
        for (int i = 0; i < SPT_CIE_SAMPLES; i++)
            y += SPT_CIE_Y[i] * table[i];
        assert_close_rel(683.0 * y, 50.0, 1e-4);
    }
    /* The film's scale: 1 cd/m^2 reads as Y = 1, so one W of radiometric
     * quantity is 683 integral(ybar) film units. */
    double iy = 0.0;
    for (int i = 0; i < SPT_CIE_SAMPLES; i++)
        iy += SPT_CIE_Y[i];
    assert_close_rel(SPT_LIGHT_FILM_PER_WATT, 683.0 * iy, 1e-4);
}

/* Bad input is refused with the light's name. */
TEST(test_bad_lights)
{
    float table[SPT_CIE_SAMPLES];
    GpuLight gl;
    SptError e;
    SceneLight sl = make_light(SPT_LIGHT_POINT, 0, 0, 0, -1.0f);
    assert_int_equal(light_from_scene(&sl, table, 0, &gl, &e), SPT_EXIT_INPUT);
    assert_non_null(strstr(e.msg, "test"));
    sl = make_light(SPT_LIGHT_POINT, 0, NAN, 0, 1.0f);
    assert_int_equal(light_from_scene(&sl, table, 0, &gl, &e), SPT_EXIT_INPUT);
    sl = make_light(7, 0, 0, 0, 1.0f);
    assert_int_equal(light_from_scene(&sl, table, 0, &gl, &e), SPT_EXIT_INPUT);
    sl = make_light(SPT_LIGHT_SPOT, 0, 0, 0, 1.0f);
    sl.direction[1] = 0.0f;
    assert_int_equal(light_from_scene(&sl, table, 0, &gl, &e), SPT_EXIT_INPUT);
}

/* ybar at nm by linear interpolation of the 1 nm CIE table. */
static double ybar_at(double nm)
{
    double x = nm - SPT_CIE_LAMBDA_MIN;
    int i = (int)floor(x);
    return SPT_CIE_Y[i] * (1.0 - (x - i)) + SPT_CIE_Y[i + 1] * (x - i);
}

/* Lights with spectra of their own (tests/data/gltf/spectral_lights.gltf,
 * extras.spectrace.emission): the shape is the SPD's, the level such that
 * 683 integral(ybar I) = the intensity, the colour unused.
 * - mercury at 100 cd: each line's power, from the NIST relative intensities
 *   (NIST Handbook of Basic Atomic Spectroscopic Data, strong lines of Hg I:
 *   404.656 nm 1800, 407.783 150, 435.833 4000, 546.074 1100, 576.960 240,
 *   579.066 280), is I_j = 100 rel_j / (683 sum_k rel_k ybar(l_k)) W/sr,
 *   found in the two grid bins around it with its wavelength as their centroid;
 *   nothing elsewhere (the colour, red, is not used);
 * - an inline table of 1 over 400-700 nm at 50 cd: 50 / (683 sum ybar) W/(sr nm)
 *   inside, 0 outside;
 * - D65 at 3 lx: the white RGB light's table (itself D65 to the upsampling fit). */
TEST(test_spectral_lights)
{
    Scene s;
    test_load_scene(&s, "tests/data/gltf/spectral_lights.gltf");
    SptError e = {0};
    assert_int_equal(s.light_count, 3);
    float t[3][SPT_CIE_SAMPLES];
    GpuLight gl;
    for (int k = 0; k < 3; k++) {
        assert_int_equal(light_from_scene(&s.lights[k], t[k], 0, &gl, &e), SPT_EXIT_OK);
        for (int i = 0; i < SPT_CIE_SAMPLES; i++)
            t[k][i] /= SPT_LIGHT_FILM_PER_WATT;
    }
    static const double hg_nm[6] = {404.656, 407.783, 435.833, 546.074, 576.960, 579.066};
    static const double hg_rel[6] = {1800, 150, 4000, 1100, 240, 280};
    double norm = 0.0, mass = 0.0, total = 0.0, lum = 0.0;
    for (int j = 0; j < 6; j++)
        norm += hg_rel[j] * ybar_at(hg_nm[j]);
    for (int j = 0; j < 6; j++) {
        int i = (int)floor(hg_nm[j]) - SPT_CIE_LAMBDA_MIN;
        double want = 100.0 * hg_rel[j] / (683.0 * norm), got = t[0][i] + t[0][i + 1];
        double centroid = SPT_CIE_LAMBDA_MIN + i + t[0][i + 1] / got;
        print_message("  Hg %.3f nm: %.6g W/sr (expected %.6g), centroid %.4f nm\n", hg_nm[j], got, want,
                      centroid);
        assert_close_rel(got, want, 1e-5);
        assert_close(centroid, hg_nm[j], 1e-4);
        mass += got;
    }
    for (int i = 0; i < SPT_CIE_SAMPLES; i++) {
        lum += 683.0 * SPT_CIE_Y[i] * t[0][i];
        total += t[0][i];
    }
    assert_close_rel(mass, total, 1e-6); /* nothing besides the lines */
    assert_close_rel(lum, 100.0, 1e-5);
    double ysum = 0.0;
    for (int l = 400; l <= 700; l++)
        ysum += SPT_CIE_Y[l - SPT_CIE_LAMBDA_MIN];
    for (int i = 0; i < SPT_CIE_SAMPLES; i++) {
        int l = SPT_CIE_LAMBDA_MIN + i;
        assert_close_rel(t[1][i], l >= 400 && l <= 700 ? 50.0 / (683.0 * ysum) : 0.0, 1e-5);
    }
    SceneLight white = make_light(SPT_LIGHT_DIRECTIONAL, 0, 0, 0, 3.0f);
    float tw[SPT_CIE_SAMPLES];
    assert_int_equal(light_from_scene(&white, tw, 0, &gl, &e), SPT_EXIT_OK);
    double worst = 0.0;
    /* At the named D65's own 5 nm samples (its table, CIE 15, ends at 780 nm). */
    for (int i = 0; i <= 780 - SPT_CIE_LAMBDA_MIN; i += 5)
        worst = fmax(worst, fabs(t[2][i] * SPT_LIGHT_FILM_PER_WATT / tw[i] - 1.0));
    print_message("  D65 light vs white RGB light: largest relative difference %.2g\n", worst);
    assert_true(worst < 3e-3);
    /* A light made in code whose spectrum has no luminance is refused by name. */
    SceneLight dark = make_light(SPT_LIGHT_POINT, 0, 1, 0, 1.0f);
    const double nm[2] = {250, 300}, v[2] = {1, 1};
    assert_int_equal(spd_from_samples(&dark.spd, nm, v, 2, &e), 0);
    assert_int_equal(light_from_scene(&dark, tw, 0, &gl, &e), SPT_EXIT_INPUT);
    assert_non_null(strstr(e.msg, "'test'"));
    assert_non_null(strstr(e.msg, "no luminance"));
    spd_free(&dark.spd);
    scene_free(&s);
}

/* ---- Environment ------------------------------------------------------------- */

#define MAP_W 32
#define MAP_H 16

/* A 32x16 map: a sky gradient, a bright spot of 3x2 texels near the horizon, a
 * black band at the bottom. */
static float *make_map(void)
{
    float *rgb = malloc(sizeof(float) * 3 * MAP_W * MAP_H);
    for (int y = 0; y < MAP_H; y++)
        for (int x = 0; x < MAP_W; x++) {
            float *c = rgb + 3 * (y * MAP_W + x);
            float g = 0.2f + 0.8f * (float)y / MAP_H;
            c[0] = 0.3f * g + 0.02f * x;
            c[1] = 0.5f * g;
            c[2] = 0.9f * g;
            if (y >= 6 && y <= 7 && x >= 20 && x <= 22) {
                c[0] = 60.0f;
                c[1] = 45.0f;
                c[2] = 20.0f;
            }
            if (y == MAP_H - 1)
                c[0] = c[1] = c[2] = 0.0f;
        }
    return rgb;
}

typedef struct EnvCtx {
    EnvLight *env;
    double rot; /* the map's rotation, undone to bin in map coordinates */
} EnvCtx;

/* Sphere domain: the sampled direction itself. */
static int env_sample_cb(void *ctx, uint32_t i, double p[3])
{
    EnvLight *env = ((EnvCtx *)ctx)->env;
    float pdf;
    vec3 d = env_sample(&env->env, env->data, test_uniform(2ull * i + 77), test_uniform(2ull * i + 78),
                        &pdf);
    p[0] = d.x;
    p[1] = d.y;
    p[2] = d.z;
    /* The pdf returned with the sample equals env_pdf of the direction. */
    float q = env_pdf(&env->env, env->data, d);
    if (!(pdf > 0.0f) || fabsf(pdf - q) > 1e-3f * q)
        return 0;
    return 1;
}

static double env_pdf_cb(void *ctx, const double p[3])
{
    EnvLight *env = ((EnvCtx *)ctx)->env;
    return env_pdf(&env->env, env->data, v3((float)p[0], (float)p[1], (float)p[2]));
}

/* Plane domain: the sample's map coordinates (u, v), from the documented
 * convention written out here (undo the rotation about +Y, theta from +Y, phi =
 * atan2(-x, z)), so cells align with texels and the piecewise-constant density
 * integrates exactly. */
static int env_sample_uv_cb(void *ctx, uint32_t i, double p[3])
{
    EnvCtx *c = ctx;
    double d[3];
    if (!env_sample_cb(ctx, i, d))
        return 0;
    double mx = cos(c->rot) * d[0] - sin(c->rot) * d[2], mz = sin(c->rot) * d[0] + cos(c->rot) * d[2];
    double phi = atan2(-mx, mz);
    if (phi < 0.0)
        phi += 2.0 * M_PI;
    p[0] = phi / (2.0 * M_PI);
    p[1] = acos(fmax(-1.0, fmin(1.0, d[1]))) / M_PI;
    return 1;
}

/* Density in (u, v): env_pdf of the direction times the Jacobian 2 pi^2 sin(theta). */
static double env_pdf_uv_cb(void *ctx, const double p[3])
{
    EnvCtx *c = ctx;
    double th = M_PI * p[1], ph = 2.0 * M_PI * p[0];
    double mx = -sin(ph) * sin(th), my = cos(th), mz = cos(ph) * sin(th);
    vec3 d = v3((float)(cos(c->rot) * mx + sin(c->rot) * mz), (float)my,
                (float)(-sin(c->rot) * mx + cos(c->rot) * mz));
    return env_pdf(&c->env->env, c->env->data, d) * 2.0 * M_PI * M_PI * sin(th);
}

/* env_sample against env_pdf: chi-square over the map's (u, v) square (cells of
 * half a texel), rotated map; the samples come back through the rotation and
 * the direction convention, the density through env_pdf and the Jacobian. */
TEST(test_env_sample_chi2)
{
    float *rgb = make_map();
    EnvLight env;
    SptError e;
    assert_int_equal(env_build_map(&env, rgb, MAP_W, MAP_H, 0.7f, 2.0f, "map", &e), SPT_EXIT_OK);
    EnvCtx ctx = {&env, 0.7};
    Chi2Grid g = chi2_plane("env_sample (32x16 map, bright spot), in map coordinates", 0.0, 1.0, 0.0, 1.0,
                            2 * MAP_W, 2 * MAP_H, LIGHTS_CHI2_TESTS, env_sample_uv_cb, env_pdf_uv_cb, &ctx);
    g.samples = 400000;
    chi2_require(&g);
    env_free(&env);
    free(rgb);
}

/* The uniform background's sampling against its pdf. */
TEST(test_uniform_sample_chi2)
{
    EnvLight env;
    const float white[3] = {1, 1, 1};
    env_build_uniform(&env, white, 1.0f);
    EnvCtx ctx = {&env, 0.0};
    Chi2Grid g =
        chi2_sphere("uniform background sample", 20, 10, LIGHTS_CHI2_TESTS, env_sample_cb, env_pdf_cb, &ctx);
    g.samples = 200000;
    chi2_require(&g);
    env_free(&env);
}

/* Next-event estimation of the uniform background at a shading point
 * (env_sample_at): a tilted normal, its own frame, one side or both. */
typedef struct EnvAtCtx {
    EnvLight *env;
    vec3 n, t, b;
    int two_sided;
} EnvAtCtx;

static int env_sample_at_cb(void *ctx, uint32_t i, double p[3])
{
    EnvAtCtx *c = ctx;
    float pdf;
    vec3 d = env_sample_at(&c->env->env, c->env->data, c->n, c->t, c->b, c->two_sided,
                           test_uniform(2ull * i + 901), test_uniform(2ull * i + 902), &pdf);
    p[0] = d.x;
    p[1] = d.y;
    p[2] = d.z;
    /* A unit direction, never where the BSDF is 0 (behind n when one-sided),
     * whose pdf equals env_pdf_at's. */
    float q = env_pdf_at(&c->env->env, c->env->data, c->n, c->two_sided, d);
    float len = sqrtf(v3_dot(d, d)), cn = v3_dot(d, c->n);
    if (fabsf(len - 1.0f) > 1e-5f || (!c->two_sided && cn < 0.0f) || !(pdf >= 0.0f) ||
        fabsf(pdf - q) > 1e-4f * (q + 1e-3f))
        return 0;
    return 1;
}

static double env_pdf_at_cb(void *ctx, const double p[3])
{
    EnvAtCtx *c = ctx;
    return env_pdf_at(&c->env->env, c->env->data, c->n, c->two_sided, v3((float)p[0], (float)p[1], (float)p[2]));
}

static EnvAtCtx env_at_ctx(EnvLight *env, int two_sided)
{
    EnvAtCtx c;
    c.env = env;
    c.n = v3_normalize(v3(0.3f, 0.8f, -0.52f));
    v3_basis(c.n, &c.t, &c.b);
    c.two_sided = two_sided;
    return c;
}

/* env_sample_at against env_pdf_at over the sphere (cos/pi on the normal's side,
 * |cos|/(2 pi) on both), and the chi-square grid's integral of the pdf is 1. */
TEST(test_uniform_sample_at_chi2)
{
    EnvLight env;
    const float white[3] = {1, 1, 1};
    env_build_uniform(&env, white, 1.0f);
    for (int two = 0; two < 2; two++) {
        EnvAtCtx ctx = env_at_ctx(&env, two);
        Chi2Grid g = chi2_sphere(two ? "uniform background at a point, two-sided"
                                     : "uniform background at a point, one side",
                                 20, 10, LIGHTS_CHI2_TESTS, env_sample_at_cb, env_pdf_at_cb, &ctx);
        g.samples = 200000;
        Chi2Result r = chi2_require(&g);
        assert_close(r.integral, 1.0, 2e-3);
    }
    env_free(&env);
}

/* The irradiance of a unit-radiance sky on a plane is pi on each side: the
 * estimator sum cos+ / pdf of env_sample_at's samples gives it exactly on one
 * side (cosine sampling), and within Monte Carlo error with two sides. Against
 * the sphere's uniform sampling (env_sample), whose estimate 4 pi cos+ has a
 * variance of 5/3 pi^2, half its samples wasted below the horizon. A map keeps
 * env_sample. */
TEST(test_uniform_sample_at_irradiance)
{
    EnvLight env;
    const float white[3] = {1, 1, 1};
    env_build_uniform(&env, white, 1.0f);
    const int n = 65536;
    for (int two = 0; two < 2; two++) {
        EnvAtCtx c = env_at_ctx(&env, two);
        double sum = 0.0, sum2 = 0.0, sum_sphere = 0.0, sum2_sphere = 0.0;
        for (int i = 0; i < n; i++) {
            float u1 = test_uniform(2ull * i + 5001), u2 = test_uniform(2ull * i + 5002), pdf;
            vec3 d = env_sample_at(&env.env, env.data, c.n, c.t, c.b, two, u1, u2, &pdf);
            double cn = fmax(0.0, (double)v3_dot(d, c.n));
            double x = pdf > 0.0f ? cn / pdf : 0.0;
            sum += x;
            sum2 += x * x;
            d = env_sample(&env.env, env.data, u1, u2, &pdf);
            cn = fmax(0.0, (double)v3_dot(d, c.n));
            x = cn / pdf;
            sum_sphere += x;
            sum2_sphere += x * x;
        }
        double mean = sum / n, var = sum2 / n - mean * mean;
        double mean_s = sum_sphere / n, var_s = sum2_sphere / n - mean_s * mean_s;
        /* Two-sided: x is 2 pi cos or 0, variance pi^2; sphere: 4 pi cos+, variance 5/3 pi^2. */
        assert_close(mean, M_PI, two ? 5.0 * M_PI / sqrt((double)n) : 1e-4);
        assert_close(mean_s, M_PI, 5.0 * M_PI * sqrt(5.0 / 3.0) / sqrt((double)n));
        if (!two)
            assert_true(var < 1e-6);
        else
            assert_close(var / (M_PI * M_PI), 1.0, 0.05);
        assert_close(var_s / (M_PI * M_PI), 5.0 / 3.0, 0.08);
    }
    env_free(&env);
    /* A map: env_sample_at and env_pdf_at are env_sample and env_pdf. */
    float *rgb = make_map();
    SptError e;
    assert_int_equal(env_build_map(&env, rgb, MAP_W, MAP_H, 0.2f, 1.0f, "map", &e), SPT_EXIT_OK);
    EnvAtCtx c = env_at_ctx(&env, 0);
    for (int i = 0; i < 64; i++) {
        float u1 = test_uniform(2ull * i + 7001), u2 = test_uniform(2ull * i + 7002), p1, p2;
        vec3 a = env_sample_at(&env.env, env.data, c.n, c.t, c.b, 0, u1, u2, &p1);
        vec3 b = env_sample(&env.env, env.data, u1, u2, &p2);
        assert_true(a.x == b.x && a.y == b.y && a.z == b.z && p1 == p2);
        assert_true(env_pdf_at(&env.env, env.data, c.n, 1, a) == env_pdf(&env.env, env.data, a));
    }
    env_free(&env);
    free(rgb);
}

/* env_pdf integrates to 1 over the sphere: midpoint rule in (phi, cos theta) on a
 * grid much finer than the map. */
TEST(test_env_pdf_normalised)
{
    float *rgb = make_map();
    EnvLight env;
    SptError e;
    assert_int_equal(env_build_map(&env, rgb, MAP_W, MAP_H, -1.3f, 1.0f, "map", &e), SPT_EXIT_OK);
    const int np = 1600, nz = 800;
    double sum = 0.0;
    for (int j = 0; j < nz; j++) {
        double z = -1.0 + (j + 0.5) * 2.0 / nz, s = sqrt(1.0 - z * z);
        for (int i = 0; i < np; i++) {
            double phi = (i + 0.5) * 2.0 * M_PI / np;
            sum += env_pdf(&env.env, env.data, v3((float)(s * cos(phi)), (float)z, (float)(s * sin(phi))));
        }
    }
    double integral = sum * (2.0 * M_PI / np) * (2.0 / nz);
    assert_close(integral, 1.0, 3e-3);
    env_free(&env);
    free(rgb);
}

/* Linear sRGB of a spectral radiance function at direction d through the CIE
 * tables: XYZ = sum cmf L / sum ybar, then docs/architecture.md's matrix. */
static void env_rgb_at(const EnvLight *env, vec3 d, double rgb[3])
{
    double xyz[3] = {0, 0, 0}, ny = 0.0;
    for (int i = 0; i < SPT_CIE_SAMPLES; i += 4) {
        float l[4], v[4];
        for (int k = 0; k < 4; k++)
            l[k] = (float)(SPT_CIE_LAMBDA_MIN + (i + k < SPT_CIE_SAMPLES ? i + k : SPT_CIE_SAMPLES - 1));
        env_eval(&env->env, env->data, d, l, v);
        for (int k = 0; k < 4 && i + k < SPT_CIE_SAMPLES; k++) {
            xyz[0] += SPT_CIE_X[i + k] * v[k];
            xyz[1] += SPT_CIE_Y[i + k] * v[k];
            xyz[2] += SPT_CIE_Z[i + k] * v[k];
            ny += SPT_CIE_Y[i + k];
        }
    }
    for (int a = 0; a < 3; a++)
        xyz[a] /= ny;
    rgb[0] = 3.2406 * xyz[0] - 1.5372 * xyz[1] - 0.4986 * xyz[2];
    rgb[1] = -0.9689 * xyz[0] + 1.8758 * xyz[1] + 0.0415 * xyz[2];
    rgb[2] = 0.0557 * xyz[0] - 0.2040 * xyz[1] + 1.0570 * xyz[2];
}

/* The world direction of texel centre (x, y) by the documented convention,
 * written out independently: theta from +Y, phi = 2 pi u, u = 1/2 faces -Z,
 * then rotated by rot about +Y. */
static vec3 texel_dir(int x, int y, double rot)
{
    double th = M_PI * (y + 0.5) / MAP_H, ph = 2.0 * M_PI * (x + 0.5) / MAP_W;
    double mx = -sin(ph) * sin(th), my = cos(th), mz = cos(ph) * sin(th);
    return v3((float)(cos(rot) * mx + sin(rot) * mz), (float)my, (float)(-sin(rot) * mx + cos(rot) * mz));
}

/* The sampling weight is luminance times sin(theta): a constant map is then
 * sampled almost uniformly over the sphere (1/(4 pi) at texel centres, within
 * the midpoint rule's error over 16 rows, ~0.2%), whatever its colour. */
TEST(test_env_constant_map_uniform)
{
    float *rgb = malloc(sizeof(float) * 3 * MAP_W * MAP_H);
    for (int i = 0; i < MAP_W * MAP_H; i++) {
        rgb[3 * i] = 0.2f;
        rgb[3 * i + 1] = 0.9f;
        rgb[3 * i + 2] = 0.5f;
    }
    EnvLight env;
    SptError e;
    assert_int_equal(env_build_map(&env, rgb, MAP_W, MAP_H, 0.3f, 1.0f, "const", &e), SPT_EXIT_OK);
    for (int y = 0; y < MAP_H; y++)
        for (int x = 0; x < MAP_W; x += 5)
            assert_close_rel(env_pdf(&env.env, env.data, texel_dir(x, y, 0.3)), 1.0 / (4.0 * M_PI), 1e-2);
    env_free(&env);
    free(rgb);
}

/* env_eval gives back every texel's colour (times the intensity) within the
 * upsampling's accuracy; the orientation follows the documented convention. */
TEST(test_env_eval_colour)
{
    float *rgb = make_map();
    EnvLight env;
    SptError e;
    const double rot = 0.9, scale = 1.5;
    assert_int_equal(env_build_map(&env, rgb, MAP_W, MAP_H, (float)rot, (float)scale, "map", &e),
                     SPT_EXIT_OK);
    double worst = 0.0;
    for (int y = 0; y < MAP_H; y++)
        for (int x = 0; x < MAP_W; x++) {
            double got[3];
            env_rgb_at(&env, texel_dir(x, y, rot), got);
            const float *c = rgb + 3 * (y * MAP_W + x);
            double m = fmax(fmax(c[0], c[1]), fmax(c[2], 1e-3)) * scale;
            for (int a = 0; a < 3; a++) {
                double err = fabs(got[a] - c[a] * scale) / m;
                if (err > worst)
                    worst = err;
                if (err > 1e-2)
                    fail_msg("texel (%d, %d) channel %d: %g, expected %g", x, y, a, got[a],
                             c[a] * scale);
            }
        }
    print_message("  worst colour error relative to the texel's largest channel: %.2g\n", worst);
    env_free(&env);
    /* Orientation: a map bright only in its centre column (u = 1/2) is bright
     * toward -Z without rotation, dark toward +Z, +X and -X. */
    float *one = calloc(3 * MAP_W * MAP_H, sizeof(float));
    for (int y = 0; y < MAP_H; y++)
        for (int a = 0; a < 3; a++) {
            one[3 * (y * MAP_W + MAP_W / 2) + a] = 1.0f;
            one[3 * (y * MAP_W + MAP_W / 2 - 1) + a] = 1.0f;
        }
    assert_int_equal(env_build_map(&env, one, MAP_W, MAP_H, 0.0f, 1.0f, "one", &e), SPT_EXIT_OK);
    float v[4];
    env_eval(&env.env, env.data, v3(0, 0, -1), k_lambda, v);
    assert_true(v[1] > 0.5f);
    const vec3 dark[3] = {v3(0, 0, 1), v3(1, 0, 0), v3(-1, 0, 0)};
    for (int k = 0; k < 3; k++) {
        env_eval(&env.env, env.data, dark[k], k_lambda, v);
        assert_close(v[1], 0.0, 0.0);
    }
    /* Rotated by +90 degrees about +Y, -Z turns to -X. */
    env_free(&env);
    assert_int_equal(env_build_map(&env, one, MAP_W, MAP_H, (float)(0.5 * M_PI), 1.0f, "one", &e),
                     SPT_EXIT_OK);
    env_eval(&env.env, env.data, v3(-1, 0, 0), k_lambda, v);
    assert_true(v[1] > 0.5f);
    env_free(&env);
    free(one);
    free(rgb);
}

/* A uniform background of radiance L gives the irradiance pi L on a plane
 * (quadrature of L cos over the hemisphere with env_eval); it reads as film
 * Y = 1 for white (1,1,1), and its sampler estimates the same irradiance. */
TEST(test_uniform_irradiance)
{
    EnvLight env;
    const float col[3] = {0.2f, 0.7f, 0.4f};
    env_build_uniform(&env, col, 3.0f);
    const float lam[4] = {450.0f, 520.0f, 610.0f, 680.0f};
    float L[4];
    env_eval(&env.env, env.data, v3(0.3f, 0.8f, 0.52f), lam, L);
    const int nphi = 64, nz = 400;
    double E[4] = {0, 0, 0, 0};
    for (int j = 0; j < nz; j++) {
        double z = (j + 0.5) / nz, s = sqrt(1.0 - z * z);
        for (int i = 0; i < nphi; i++) {
            double phi = (i + 0.5) * 2.0 * M_PI / nphi;
            float v[4];
            /* The plane's normal is +Y. */
            env_eval(&env.env, env.data, v3((float)(s * cos(phi)), (float)z, (float)(s * sin(phi))),
                     lam, v);
            for (int k = 0; k < 4; k++)
                E[k] += v[k] * z * (2.0 * M_PI / nphi) * (1.0 / nz);
        }
    }
    double Emc = 0.0;
    const int n = 200000;
    for (int i = 0; i < n; i++) {
        float pdf, v[4];
        vec3 d = env_sample(&env.env, env.data, test_uniform(2ull * i + 5), test_uniform(2ull * i + 6), &pdf);
        env_eval(&env.env, env.data, d, lam, v);
        if (d.y > 0.0f)
            Emc += v[1] * d.y / pdf;
    }
    Emc /= n;
    for (int k = 0; k < 4; k++)
        assert_close_rel(E[k], M_PI * L[k], 1e-4);
    assert_close_rel(Emc, M_PI * L[1], 1e-2);
    assert_close(env_pdf(&env.env, env.data, v3(0, -1, 0)), 1.0 / (4.0 * M_PI), 1e-7);
    env_free(&env);
    const float white[3] = {1, 1, 1};
    env_build_uniform(&env, white, 1.0f);
    assert_close(env.y_mean, 1.0, 2e-3);
    env_free(&env);
}

/* An environment read from an EXR file equals the one built from the same
 * texels; a missing file and bad texels are refused with the file's name. */
TEST(test_env_load_file)
{
    float *rgb = make_map();
    char path[64];
    snprintf(path, sizeof path, "/tmp/spt_test_env_%d.exr", (int)getpid());
    SptError e;
    assert_int_equal(image_write(path, rgb, MAP_W, MAP_H, NULL, NULL, &e), SPT_EXIT_OK);
    EnvLight a, b;
    assert_int_equal(env_load_map(&a, path, 0.2f, 1.0f, &e), SPT_EXIT_OK);
    assert_int_equal(env_build_map(&b, rgb, MAP_W, MAP_H, 0.2f, 1.0f, "map", &e), SPT_EXIT_OK);
    assert_int_equal(a.data_count, b.data_count);
    assert_int_equal(a.env.width, MAP_W);
    assert_int_equal(a.env.height, MAP_H);
    for (uint32_t i = 0; i < a.data_count; i++)
        assert_close(a.data[i], b.data[i], 1e-3 * fmax(1.0, fabs(b.data[i])));
    env_free(&a);
    env_free(&b);
    remove(path);
    assert_int_not_equal(env_load_map(&a, "/nonexistent/env.exr", 0.0f, 1.0f, &e), SPT_EXIT_OK);
    assert_non_null(strstr(e.msg, "/nonexistent/env.exr"));
    /* An 8-bit PNG holds sRGB-encoded values (image_write encodes them): the map
     * decodes them back to linear, within the 8-bit quantisation. */
    float grey[MAP_W * MAP_H * 3];
    for (int i = 0; i < MAP_W * MAP_H * 3; i++)
        grey[i] = 0.2f;
    snprintf(path, sizeof path, "/tmp/spt_test_env_%d.png", (int)getpid());
    assert_int_equal(image_write(path, grey, MAP_W, MAP_H, NULL, NULL, &e), SPT_EXIT_OK);
    assert_int_equal(env_load_map(&a, path, 0.0f, 1.0f, &e), SPT_EXIT_OK);
    remove(path);
    assert_close(a.y_mean, 0.2, 0.2 * 0.01);
    env_free(&a);
    rgb[5] = NAN;
    assert_int_equal(env_build_map(&a, rgb, MAP_W, MAP_H, 0.0f, 1.0f, "bad.exr", &e), SPT_EXIT_INPUT);
    assert_non_null(strstr(e.msg, "bad.exr"));
    assert_null(a.data);
    free(rgb);
}

/* ---- Selection ----------------------------------------------------------------- */

/* light_from_scene of the n lights ls into gl, light i's table at
 * spectra + i * SPT_CIE_SAMPLES. */
static void gpu_lights(const SceneLight *ls, int n, float *spectra, GpuLight *gl)
{
    SptError e;
    for (int i = 0; i < n; i++)
        assert_int_equal(light_from_scene(&ls[i], spectra + i * SPT_CIE_SAMPLES,
                                          (uint32_t)(i * SPT_CIE_SAMPLES), &gl[i], &e), 0);
}

/* Probabilities proportional to the documented power formulas, computed here. */
TEST(test_selection)
{
    float spectra[3 * SPT_CIE_SAMPLES];
    GpuLight gl[3];
    SceneLight sl[3] = {make_light(SPT_LIGHT_POINT, 0, 1, 0, 2.0f),
                        make_light(SPT_LIGHT_SPOT, 0, 1, 0, 8.0f),
                        make_light(SPT_LIGHT_DIRECTIONAL, 0, 0, 0, 5.0f)};
    sl[1].inner_cone = 0.2f;
    sl[1].outer_cone = 0.6f;
    gpu_lights(sl, 3, spectra, gl);
    EnvLight env;
    const float white[3] = {1, 1, 1};
    env_build_uniform(&env, white, 0.5f);
    const float radius = 3.0f;
    const float tri[2] = {0.01f, 0.02f};
    Distrib dist;
    assert_int_equal(lights_build_selection(&dist, tri, 2, gl, 3, spectra, &env, radius), 1);
    assert_int_equal(dist.n, 6);
    /* The film's unit is the nit: a light of 1 cd has Y-weighted intensity 1. */
    double y1 = 1.0;
    /* The spot's flux: full intensity to the inner cone, a third of it over
     * the falloff, in 1 - cos. */
    double xi = 1.0 - cos(0.2), xo = 1.0 - cos(0.6);
    double w[6] = {0.01, 0.02, 4.0 * M_PI * 2.0 * y1, 2.0 * M_PI * (xi + (xo - xi) / 3.0) * 8.0 * y1,
                   5.0 * y1 * M_PI * 9.0, M_PI * 0.5 * M_PI * 9.0};
    double total = 0.0;
    for (int i = 0; i < 6; i++)
        total += w[i];
    for (uint32_t i = 0; i < 6; i++)
        assert_close_rel(distrib_prob(&dist, i), w[i] / total, 3e-3);
    distrib_free(&dist);
    env_free(&env);
}

/* ---- Device ------------------------------------------------------------------- */

/* The header builds as OpenCL C 1.2 and the device's results equal the host's. */
static const char *k_device_src =
    "#include \"light/lights.h\"\n"
    "__kernel void k_lights_test(__global const GpuLight *lights, __global const float *spectra,\n"
    "                            __global const GpuEnvMap *envs, __global const float *env_data,\n"
    "                            __global const float *in, __global float *out, int n)\n"
    "{\n"
    "    int i = get_global_id(0);\n"
    "    if (i >= n) return;\n"
    "    const __global float *q = in + 8 * i;\n"
    "    float lam[4] = {q[3], q[4], q[5], q[6]};\n"
    "    LightSample s;\n"
    "    light_punctual_sample(lights + (i % 2), spectra, (float3)(q[0], q[1], q[2]), lam, &s);\n"
    "    GpuEnvMap env = envs[0];\n"
    "    float pdf;\n"
    "    float3 d = env_sample(&env, env_data, q[0] * 0.1f + 0.5f, q[7], &pdf);\n"
    "    float v[4];\n"
    "    env_eval(&env, env_data, d, lam, v);\n"
    "    __global float *o = out + 12 * i;\n"
    "    o[0] = s.value[0]; o[1] = s.value[3]; o[2] = s.dist; o[3] = s.wi.x;\n"
    "    o[4] = d.x; o[5] = d.y; o[6] = d.z; o[7] = pdf;\n"
    "    o[8] = v[0]; o[9] = v[2]; o[10] = env_pdf(&env, env_data, d);\n"
    "    o[11] = (float)(sizeof(GpuLight) * 1000 + sizeof(GpuEnvMap));\n"
    "}\n";

TEST(test_device_matches_host)
{
    TestCl cl = test_cl_open();
    float spectra[2 * SPT_CIE_SAMPLES];
    GpuLight gl[2];
    SptError e;
    SceneLight sl[2] = {make_light(SPT_LIGHT_SPOT, 0, 2, 0, 10.0f),
                        make_light(SPT_LIGHT_DIRECTIONAL, 0, 0, 0, 2.0f)};
    sl[0].inner_cone = 0.4f;
    sl[0].outer_cone = 0.9f;
    gpu_lights(sl, 2, spectra, gl);
    float *rgb = make_map();
    EnvLight env;
    assert_int_equal(env_build_map(&env, rgb, MAP_W, MAP_H, 0.4f, 1.0f, "map", &e), SPT_EXIT_OK);
    enum { N = 256 };
    float in[8 * N], out[12 * N];
    for (int i = 0; i < N; i++) {
        in[8 * i] = 2.0f * test_uniform(1000 + 8 * i) - 1.0f;
        in[8 * i + 1] = 2.0f * test_uniform(1001 + 8 * i) - 1.0f;
        in[8 * i + 2] = 2.0f * test_uniform(1002 + 8 * i) - 1.0f;
        for (int k = 0; k < 4; k++)
            in[8 * i + 3 + k] = 380.0f + 400.0f * test_uniform(1003 + 8 * i + k);
        in[8 * i + 7] = test_uniform(1007 + 8 * i);
    }
    const TestClArg args[5] = {{gl, sizeof gl},
                               {spectra, sizeof spectra},
                               {&env.env, sizeof env.env},
                               {env.data, env.data_count * sizeof(float)},
                               {in, sizeof in}};
    test_cl_run(&cl, k_device_src, NULL, "kernels/light/lights.h", "k_lights_test", args, 5,
                out, sizeof out, N, 0);
    assert_close(out[11], sizeof(GpuLight) * 1000 + sizeof(GpuEnvMap), 0);
    for (int i = 0; i < N; i++) {
        const float *q = in + 8 * i;
        LightSample s;
        light_punctual_sample(&gl[i % 2], spectra, v3(q[0], q[1], q[2]), q + 3, &s);
        float pdf, v[4];
        vec3 d = env_sample(&env.env, env.data, q[0] * 0.1f + 0.5f, q[7], &pdf);
        env_eval(&env.env, env.data, d, q + 3, v);
        const float want[11] = {s.value[0], s.value[3], s.dist, s.wi.x, d.x, d.y, d.z, pdf,
                                v[0], v[2], env_pdf(&env.env, env.data, d)};
        test_cl_assert_agree(i, out + 12 * i, want, 11, 1e-4f);
    }
    test_cl_close(&cl);
    env_free(&env);
    free(rgb);
}

TEST_MAIN("tests", NULL, NULL)
