/* KHR_materials_anisotropy and KHR_materials_diffuse_transmission
 * (kernels/closure/bsdf_microfacet.h, lobe_specular.h,
 * lobe_diffuse_transmission.h) against independent values: the anisotropic
 * GGX's normalisation and its Smith Lambda through the masking equation,
 * integrated numerically in slope space; its isotropic limit; chi-square tests
 * of each new lobe's sampling against its pdf (tests/chi2.h); white furnaces;
 * the highlight's axis following the anisotropy direction. On the device:
 * a plane lit from behind through diffuse transmission against E cos / pi, a
 * diffusely transmitting sphere in the furnace, the rendered highlight turning
 * with anisotropyRotation over a textured plane, and strength 0 leaving the
 * image bit-identical. */
#include "test_util.h"
#include "test_render_util.h"

#include <stdlib.h>
#include <string.h>

#include "chi2.h"
#include "bsdf_test.h"
#include "render/film.h"
#include "scene/scene.h"

/* Chi-square tests expected to pass in this binary, for the Sidak correction. */
#define ANISO_CHI2_TESTS 9
#define ANISO_CHI2_SAMPLES 200000u

/* A direction at polar angle theta and azimuth phi (degrees), z up. */
static vec3 dir_deg2(double theta, double phi)
{
    double t = theta * M_PI / 180.0, p = phi * M_PI / 180.0;
    return v3((float)(sin(t) * cos(p)), (float)(sin(t) * sin(p)), (float)cos(t));
}

static BsdfParams with_aniso(BsdfParams p, float strength, double rot_deg)
{
    p.aniso = strength;
    p.aniso_t = v3((float)cos(rot_deg * M_PI / 180.0), (float)sin(rot_deg * M_PI / 180.0), 0.0f);
    return p;
}

static BsdfParams with_dt(BsdfParams p, float dt, float colour)
{
    p.diffuse_transmission = dt;
    p.dt_color = v4_splat(colour);
    return p;
}

/* ---- The anisotropic GGX ----------------------------------------------------- */

/* The slope-space density of GGX with roughnesses ax, ay (Heitz 2014, eq. 84
 * written out): P22(x, y) = 1 / (pi ax ay (1 + x^2/ax^2 + y^2/ay^2)^2); it
 * integrates to 1 over the plane, and D(h) = P22 / cos^4 theta_h at the
 * normal h = (-x, -y, 1) / |.|. */
static double p22(double x, double y, double ax, double ay)
{
    double t = 1.0 + x * x / (ax * ax) + y * y / (ay * ay);
    return 1.0 / (M_PI * ax * ay * t * t);
}

/* Integrates g(x, y) P22 over the plane by the midpoint rule in the
 * substitution x = ax tan(a), y = ay tan(b) (a, b in (-pi/2, pi/2)), which
 * maps the heavy tails onto a finite square. */
static double slope_integral(double ax, double ay, double (*g)(double x, double y, const void *c),
                             const void *c, int n)
{
    double sum = 0.0, h = M_PI / n;
    for (int i = 0; i < n; i++) {
        double a = -0.5 * M_PI + (i + 0.5) * h, ca = cos(a);
        for (int j = 0; j < n; j++) {
            double b = -0.5 * M_PI + (j + 0.5) * h, cb = cos(b);
            double x = ax * tan(a), y = ay * tan(b);
            double jac = ax * ay / (ca * ca * cb * cb);
            sum += g(x, y, c) * p22(x, y, ax, ay) * jac;
        }
    }
    return sum * h * h;
}

typedef struct DCheck {
    float ax, ay;
    vec3 wo;
} DCheck;

/* D(h(x, y)) cos^4 theta_h / P22(x, y): 1 when our D is the GGX's. */
static double d_ratio(double x, double y, const void *c)
{
    const DCheck *d = c;
    double n = sqrt(1.0 + x * x + y * y), cos_h = 1.0 / n;
    vec3 h = v3((float)(-x / n), (float)(-y / n), (float)cos_h);
    double got = bsdf_ggx_d_aniso(h, d->ax, d->ay) * pow(cos_h, 4);
    return got / p22(x, y, d->ax, d->ay);
}

/* The projected area of the microfacets toward wo, per slope:
 * max(0, wo.h) / cos theta_h times dA_h / dA = max(0, wo.z - x wo.x - y wo.y). */
static double projected(double x, double y, const void *c)
{
    const DCheck *d = c;
    return fmax(0.0, d->wo.z - x * d->wo.x - y * d->wo.y);
}

/* Our D against P22 pointwise, and through the masking equation
 * (Heitz 2014, eq. 15: integral of max(0, wo.h) D(h) dh = wo.z (1 + Lambda(wo))
 * for the Smith model) our Lambda against the distribution itself, with the
 * integral computed numerically in slope space; roughnesses along x and y
 * differing by up to 10 times and directions across the azimuth. */
TEST(test_aniso_ggx_masking_equation)
{
    const float rough[3][2] = {{0.05f, 0.5f}, {0.6f, 0.2f}, {0.3f, 0.3f}};
    const double dirs[4][2] = {{0, 0}, {40, 10}, {70, 100}, {85, 225}};
    double worst = 0.0;
    for (int r = 0; r < 3; r++) {
        DCheck c = {rough[r][0], rough[r][1], v3(0, 0, 1)};
        double one = slope_integral(c.ax, c.ay, d_ratio, &c, 400);
        /* d_ratio times P22 integrates to 1 exactly when d_ratio is 1. */
        assert_close(one, 1.0, 2e-4);
        for (int k = 0; k < 4; k++) {
            c.wo = dir_deg2(dirs[k][0], dirs[k][1]);
            double lhs = slope_integral(c.ax, c.ay, projected, &c, 1200);
            double rhs = c.wo.z * (1.0 + bsdf_ggx_lambda_aniso(c.wo, c.ax, c.ay));
            worst = fmax(worst, fabs(lhs / rhs - 1.0));
            if (fabs(lhs / rhs - 1.0) > 2e-3)
                fail_msg("ax %.2f ay %.2f theta %.0f phi %.0f: masking integral %.6f, wo.z (1 + Lambda) %.6f",
                         c.ax, c.ay, dirs[k][0], dirs[k][1], lhs, rhs);
        }
    }
    print_message("  masking equation: largest relative difference %.2e\n", worst);
}

/* With equal roughnesses the anisotropic functions are the isotropic ones (to
 * float rounding; the sampler to the bit), and a material with strength 0 is
 * the isotropic material to the bit whatever its direction. */
TEST(test_aniso_isotropic_limit)
{
    const float alphas[3] = {0.01f, 0.2f, 0.7f};
    for (int a = 0; a < 3; a++)
        for (int k = 0; k < 64; k++) {
            float al = alphas[a];
            vec3 w = dir_deg2(88.0 * test_uniform(5000 + 2 * k), 360.0 * test_uniform(5001 + 2 * k));
            vec3 h = dir_deg2(60.0 * test_uniform(6000 + 2 * k), 360.0 * test_uniform(6001 + 2 * k));
            assert_close_rel(bsdf_ggx_d_aniso(h, al, al), bsdf_ggx_d(h, al), 1e-3); /* the isotropic form cancels */
            assert_close_rel(1.0 + bsdf_ggx_lambda_aniso(w, al, al), 1.0 + bsdf_ggx_lambda(w, al), 2e-5);
            float u1 = test_uniform(7000 + 2 * k), u2 = test_uniform(7001 + 2 * k);
            vec3 s1 = bsdf_ggx_sample_vndf(w, al, u1, u2), s2 = bsdf_ggx_sample_vndf_aniso(w, al, al, u1, u2);
            assert_true(s1.x == s2.x && s1.y == s2.y && s1.z == s2.z);
        }
    /* A smooth base with anisotropy is a rough lobe along the direction (a
     * mirror across it), not a delta. */
    BsdfParams smooth = with_aniso(make_params(0.9f, 1.0f, 0.0f, 0.0f), 0.6f, 120);
    assert_false(bsdf_is_delta(&smooth));
    BsdfSample ss = bsdf_sample(&smooth, dir_deg2(30, 70), 0.5f, 0.3f, 0.6f);
    assert_true(ss.valid && !ss.is_delta && ss.pdf > 0.0f);
    smooth.aniso = 0.0f;
    assert_true(bsdf_is_delta(&smooth));
    /* Strength 0 with a direction: the isotropic material's every float. */
    BsdfParams iso = make_params(0.7f, 0.6f, 0.35f, 0.0f);
    BsdfParams zero = with_aniso(iso, 0.0f, 37.0);
    for (int k = 0; k < 256; k++) {
        vec3 wo = dir_deg2(85.0 * test_uniform(8000 + 5 * k), 360.0 * test_uniform(8001 + 5 * k));
        float u0 = test_uniform(8002 + 5 * k), u1 = test_uniform(8003 + 5 * k), u2 = test_uniform(8004 + 5 * k);
        BsdfSample a = bsdf_sample(&iso, wo, u0, u1, u2), b = bsdf_sample(&zero, wo, u0, u1, u2);
        assert_true(memcmp(&a.wi, &b.wi, sizeof a.wi) == 0 && memcmp(&a.weight, &b.weight, sizeof a.weight) == 0 &&
                    a.pdf == b.pdf);
        vec4 fa = bsdf_eval(&iso, wo, a.wi), fb = bsdf_eval(&zero, wo, a.wi);
        assert_true(memcmp(&fa, &fb, sizeof fa) == 0);
    }
}

/* ---- Chi-square tests ------------------------------------------------------------ */

typedef struct VndfCtx {
    vec3 wo;
    float ax, ay;
    uint32_t stream;
} VndfCtx;

static int vndf_sample(void *ctx, uint32_t i, double p[3])
{
    VndfCtx *c = ctx;
    uint64_t b = ((uint64_t)c->stream << 40) + 2u * (uint64_t)i;
    vec3 h = bsdf_ggx_sample_vndf_aniso(c->wo, c->ax, c->ay, test_uniform(b), test_uniform(b + 1));
    p[0] = h.x;
    p[1] = h.y;
    p[2] = h.z;
    return 1;
}

static double vndf_pdf(void *ctx, const double p[3])
{
    VndfCtx *c = ctx;
    return bsdf_ggx_vndf_pdf_aniso(c->wo, v3((float)p[0], (float)p[1], (float)p[2]), c->ax, c->ay);
}

static void run_mat_chi2(const char *what, BsdfParams p, vec3 wo, uint32_t stream)
{
    MatCtx c = {p, wo, stream};
    Chi2Grid g = chi2_sphere(what, 64, 64, ANISO_CHI2_TESTS, mat_sample, mat_pdf, &c);
    g.samples = ANISO_CHI2_SAMPLES;
    chi2_require(&g);
}

/* The anisotropic visible-normal sampler against its density, and whole
 * materials with the new lobes: sampled directions against bsdf_pdf. */
TEST(test_aniso_dt_chi2)
{
    VndfCtx v[2] = {{dir_deg2(35, 40), 0.2f, 0.6f, 1}, {dir_deg2(75, 200), 0.6f, 0.15f, 2}};
    for (int k = 0; k < 2; k++) {
        char name[96];
        snprintf(name, sizeof name, "anisotropic VNDF ax %.2f ay %.2f", v[k].ax, v[k].ay);
        Chi2Grid g = chi2_sphere(name, 64, 64, ANISO_CHI2_TESTS, vndf_sample, vndf_pdf, &v[k]);
        g.samples = ANISO_CHI2_SAMPLES;
        chi2_require(&g);
    }
    run_mat_chi2("anisotropic metal", with_aniso(make_params(0.9f, 1.0f, 0.4f, 0.0f), 0.8f, 30), dir_deg2(45, 10),
                 11);
    run_mat_chi2("strongly anisotropic metal", with_aniso(make_params(0.9f, 1.0f, 0.15f, 0.0f), 0.95f, 120),
                 dir_deg2(30, 70), 12);
    run_mat_chi2("anisotropic plastic", with_aniso(make_params(0.5f, 0.0f, 0.3f, 0.0f), 0.9f, -20),
                 dir_deg2(60, 0), 13);
    run_mat_chi2("diffuse transmission", with_dt(make_params(0.6f, 0.0f, 0.5f, 0.0f), 0.5f, 0.8f),
                 dir_deg2(40, 0), 14);
    vec3 in = dir_deg2(30, 50);
    in.z = -in.z;
    run_mat_chi2("diffuse + rough transmission (inside)", with_dt(make_params(0.6f, 0.0f, 0.4f, 0.5f), 0.7f, 1.0f),
                 in, 15);
    BsdfParams layered = with_dt(with_aniso(make_params(0.4f, 0.2f, 0.5f, 0.0f), 0.5f, 60), 0.4f, 0.6f);
    layered.clearcoat = 0.7f;
    layered.cc_roughness = 0.3f;
    layered.cc_n = v3(0.0f, 0.0f, 1.0f);
    run_mat_chi2("coated anisotropic diffuse transmitter", layered, dir_deg2(50, 300), 16);
}

/* ---- White furnaces ------------------------------------------------------------- */

/* The albedo of p at wo by quadrature of bsdf_eval over the sphere (midpoint
 * rule in cos theta and phi): an integral that does not use the sampler. */
static double albedo_quadrature(const BsdfParams *p, vec3 wo, int n)
{
    double sum = 0.0;
    for (int i = 0; i < n; i++) {
        double mu = -1.0 + (i + 0.5) * 2.0 / n, s = sqrt(fmax(0.0, 1.0 - mu * mu));
        for (int j = 0; j < 2 * n; j++) {
            double ph = (j + 0.5) * M_PI / n;
            vec3 wi = v3((float)(s * cos(ph)), (float)(s * sin(ph)), (float)mu);
            sum += bsdf_eval(p, wo, wi).x; /* f |cos theta_i| */
        }
    }
    return sum * (2.0 / n) * (M_PI / n);
}

/* Diffuse transmission splits the Lambertian base's light between the two
 * sides and keeps all of it: a white base and colour without a specular layer
 * reflect and transmit exactly 1 whatever the factor, with the specular layer
 * the same total as the material without transmission; the sampler's
 * albedos agree with the quadrature of bsdf_eval. An anisotropic white metal
 * never exceeds 1, and loses what the isotropic GGX loses at its larger
 * roughness at most. */
TEST(test_aniso_dt_furnace)
{
    const double thetas[3] = {0.0, 50.0, 80.0};
    uint32_t stream = 300;
    for (int t = 0; t < 3; t++) {
        vec3 wo = dir_deg2(thetas[t], 20);
        double err;
        BsdfParams lam = with_dt(make_params(1.0f, 0.0f, 0.5f, 0.0f), 0.35f, 1.0f);
        lam.specular = 0.0f;
        double a = albedo_err(&lam, wo, 20000, stream++, &err);
        assert_close(a, 1.0, 1e-5);
        BsdfParams plain = make_params(1.0f, 0.0f, 0.5f, 0.0f), dt = with_dt(plain, 0.6f, 1.0f);
        double ap = albedo_quadrature(&plain, wo, 400), ad = albedo_quadrature(&dt, wo, 400);
        double ms = albedo_err(&dt, wo, 200000, stream++, &err);
        print_message("  theta %2.0f: white Lambert + dt %.6f; plastic %.5f, plastic + dt %.5f (sampled %.5f +- "
                      "%.5f)\n",
                      thetas[t], a, ap, ad, ms, err);
        assert_close(ad, ap, 2e-3);
        assert_true(fabs(ms - ad) < 4.0 * err + 2e-3);
        for (int r = 0; r < 3; r++) {
            const float rough[3] = {0.1f, 0.4f, 0.8f};
            BsdfParams m = with_aniso(make_params(1.0f, 1.0f, rough[r], 0.0f), 0.8f, 25);
            double am = albedo_err(&m, wo, 100000, stream++, &err);
            double q = albedo_quadrature(&m, wo, 800);
            print_message("    anisotropic white metal roughness %.1f: %.5f +- %.5f (quadrature %.5f)\n", rough[r],
                          am, err, q);
            assert_true(am <= 1.0 + 3.0 * err + 1e-4);
            if (r > 0) /* the narrowest lobe is too sharp for the quadrature grid */
                assert_true(fabs(am - q) < 4.0 * err + 3e-3);
        }
    }
}

/* The highlight's axis: at normal incidence the sampled microfacet normals of
 * an anisotropic lobe spread most along the anisotropy direction; the
 * principal axis of their (h.x, h.y) covariance is the direction, for several
 * rotations. */
TEST(test_aniso_direction_rotates)
{
    const double rots[4] = {0.0, 30.0, 100.0, -60.0};
    for (int k = 0; k < 4; k++) {
        BsdfParams p = with_aniso(make_params(1.0f, 1.0f, 0.3f, 0.0f), 0.9f, rots[k]);
        double sxx = 0, syy = 0, sxy = 0;
        const int n = 50000;
        for (int i = 0; i < n; i++) {
            BsdfSample s = bsdf_sample(&p, v3(0, 0, 1), 0.5f, test_uniform(9000 + 2 * (uint64_t)i),
                                       test_uniform(9001 + 2 * (uint64_t)i));
            if (!s.valid) /* reflected below the horizon */
                continue;
            vec3 h = v3_normalize(v3_add(s.wi, v3(0, 0, 1)));
            sxx += h.x * h.x;
            syy += h.y * h.y;
            sxy += h.x * h.y;
        }
        double ang = 0.5 * atan2(2.0 * sxy, sxx - syy) * 180.0 / M_PI;
        double d = fmod(ang - rots[k] + 540.0, 180.0) - 90.0; /* axes: modulo 180 */
        print_message("  rotation %6.1f: principal axis %6.1f degrees\n", rots[k], ang);
        assert_true(fabs(fabs(d) - 90.0) < 1.0);
    }
}

/* ---- Renders ------------------------------------------------------------------- */

#define DT_SIZE 16
#define DT_I 1.0e4  /* the point light's intensity, candela */
#define DT_FACTOR 0.6

/* The quad y = 0 (facing +Y, texture coordinates u = x, v = z) of material m
 * alone, camera straight down from height 1 (60 degree field). */
static SceneMaterial *dt_plane_scene(Scene *s)
{
    memset(s, 0, sizeof *s);
    SceneMaterial *m = append_quad(s, 0.0f);
    for (uint32_t v = 0; v < s->vertex_count; v++) {
        s->vtx_uv[2 * v] = s->tri_pos[3 * v];
        s->vtx_uv[2 * v + 1] = s->tri_pos[3 * v + 2];
    }
    camera_down(s, 0.0f, 1.0f, (float)(60.0 * M_PI / 180.0), 1.0f);
    scene_update_bounds(s);
    return m;
}

static void add_point_light(Scene *s, float y, float intensity)
{
    s->light_count = 1;
    s->lights = calloc(1, sizeof(SceneLight));
    s->lights[0].type = SPT_LIGHT_POINT;
    s->lights[0].position[1] = y;
    s->lights[0].intensity = intensity;
    for (int k = 0; k < 3; k++)
        s->lights[0].color[k] = 1.0f;
}

/* A black Lambertian plane (no specular layer) with diffuse transmission
 * DT_FACTOR of white, lit from 1 m below by a point light, seen from above: its
 * luminance is DT_FACTOR E / pi with E = I cos / d^2 (thin-walled: nothing
 * else reaches the camera), per pixel (8 x 8 points) within 2%. */
TEST(test_dt_backlit_plane)
{
    Scene s;
    SceneMaterial *m = dt_plane_scene(&s);
    m->base_color[0] = m->base_color[1] = m->base_color[2] = 0.0f;
    m->diffuse_transmission = (float)DT_FACTOR;
    add_point_light(&s, -1.0f, (float)DT_I);
    RenderSettings rs = square_settings(DT_SIZE, 64, -1, 5);
    rs.env_intensity = 0.0f;
    Film f;
    render_film_ok(&s, &rs, &f);
    double t = tan(30.0 * M_PI / 180.0), worst = 0;
    for (int y = 0; y < DT_SIZE; y += 5)
        for (int x = 0; x < DT_SIZE; x += 5) {
            double want = 0;
            for (int sy = 0; sy < 8; sy++)
                for (int sx = 0; sx < 8; sx++) {
                    double u = (x + (sx + 0.5) / 8) / DT_SIZE * 2 - 1, v = 1 - (y + (sy + 0.5) / 8) / DT_SIZE * 2;
                    double px = u * t, pz = -v * t, d2 = px * px + pz * pz + 1.0, d = sqrt(d2);
                    want += DT_FACTOR * DT_I / d / d2 / M_PI / 64.0;
                }
            size_t i = (size_t)y * DT_SIZE + x;
            double got = f.xyz[3 * i + 1] / f.count[i];
            worst = fmax(worst, fabs(got / want - 1));
            if (fabs(got / want - 1) > 0.02)
                fail_msg("pixel (%d, %d): Y %.3f, expected DT E / pi = %.3f", x, y, got, want);
        }
    print_message("  backlit plane: largest difference from DT E cos / pi %.2f%%\n", 100 * worst);
    film_free(&f);
    scene_free(&s);
}

/* The sphere of material m in the furnace (the uniform sky), 32 x 32 at 64
 * samples: the mean linear sRGB over the image's central disc (radius 0.6 of
 * the half-width, all on the sphere) into mean. */
static void dt_furnace(const SceneMaterial *m, double mean[3])
{
    Scene s;
    sphere_scene_material(&s, m);
    const int w = 32;
    RenderSettings rs = square_settings(w, 64, -1, 9);
    Film f;
    RenderStats st = render_film_ok(&s, &rs, &f);
    float *rgb = malloc(sizeof(float) * 3 * w * w);
    film_to_linear_srgb(&f, rgb);
    int n = 0;
    mean[0] = mean[1] = mean[2] = 0;
    for (int y = 0; y < w; y++)
        for (int x = 0; x < w; x++) {
            double u = (x + 0.5) / w * 2 - 1, v = (y + 0.5) / w * 2 - 1;
            if (u * u + v * v > 0.36)
                continue;
            for (int c = 0; c < 3; c++)
                mean[c] += rgb[3 * (y * w + x) + c];
            n++;
        }
    for (int c = 0; c < 3; c++)
        mean[c] /= n;
    assert_int_equal(st.nan_dropped, 0);
    free(rgb);
    film_free(&f);
    scene_free(&s);
}

/* A sphere of white base and white diffuse transmission (no specular layer)
 * under the uniform sky: thin-walled, it neither absorbs nor gains, so the
 * sphere shows 1 within 1.5%. With KHR_materials_volume's thickness and an
 * attenuation (colour 0.5 at distance 0.5, the sphere's radius 1) the light
 * transmitted into it is absorbed on the way through: darker, and the more so
 * without thickness ignoring the attenuation (thin-walled: the volume rule). */
TEST(test_dt_furnace_sphere)
{
    SceneMaterial m;
    scene_material_default(&m);
    m.metallic = 0.0f;
    m.specular = 0.0f;
    m.diffuse_transmission = 0.5f;
    double thin[3], vol[3], thin_att[3];
    dt_furnace(&m, thin);
    for (int c = 0; c < 3; c++)
        m.attenuation_color[c] = 0.5f;
    m.attenuation_distance = 0.5f;
    dt_furnace(&m, thin_att);
    m.thickness = 1.0f;
    dt_furnace(&m, vol);
    print_message("  diffuse transmitting sphere in the furnace: thin-walled (%.4f, %.4f, %.4f), with an "
                  "attenuation but no thickness (%.4f, %.4f, %.4f), a volume (%.4f, %.4f, %.4f)\n",
                  thin[0], thin[1], thin[2], thin_att[0], thin_att[1], thin_att[2], vol[0], vol[1], vol[2]);
    for (int c = 0; c < 3; c++) {
        assert_close(thin[c], 1.0, 0.015);
        assert_true(memcmp(thin, thin_att, sizeof thin) == 0);
        assert_true(vol[c] < 0.9 && vol[c] > 0.2);
    }
}

/* Film Y's second moments about the image centre: the highlight's extent
 * along the image's x and y (pixels, y down) and their covariance. */
static void highlight_moments(const Film *f, double *ixx, double *iyy, double *ixy)
{
    int w = f->width;
    double sx = 0, sy = 0, sxy = 0, s = 0;
    for (int y = 0; y < w; y++)
        for (int x = 0; x < w; x++) {
            size_t i = (size_t)y * w + x;
            double l = f->xyz[3 * i + 1] / f->count[i];
            double dx = x + 0.5 - 0.5 * w, dy = y + 0.5 - 0.5 * w;
            sx += l * dx * dx;
            sy += l * dy * dy;
            sxy += l * dx * dy;
            s += l;
        }
    *ixx = sx / s;
    *iyy = sy / s;
    *ixy = sxy / s;
}

/* The highlight of an anisotropic white metal plane (dt_plane_scene, roughness
 * 0.25, strength 0.9, anisotropyRotation rot) under a point light next to the
 * camera: its moments (highlight_moments). tangent_w 0: no TANGENT (the
 * texture coordinates' frame); else TANGENT along +z with that w. */
static void aniso_highlight(double rot, float tangent_w, double *ixx, double *iyy, double *ixy)
{
    Scene s;
    SceneMaterial *m = dt_plane_scene(&s);
    m->metallic = 1.0f;
    m->base_color[0] = m->base_color[1] = m->base_color[2] = 1.0f;
    m->roughness = 0.25f;
    m->anisotropy = 0.9f;
    m->anisotropy_rotation = (float)rot;
    if (tangent_w != 0.0f) {
        s.vtx_tangent = calloc((size_t)s.vertex_count * 4, sizeof(float));
        for (uint32_t v = 0; v < s.vertex_count; v++) {
            s.vtx_tangent[4 * v + 2] = 1.0f;
            s.vtx_tangent[4 * v + 3] = tangent_w;
        }
    }
    add_point_light(&s, 1.0f, 10.0f);
    RenderSettings rs = square_settings(32, 16, 2, 3);
    rs.env_intensity = 0.0f;
    Film f;
    render_film_ok(&s, &rs, &f);
    highlight_moments(&f, ixx, iyy, ixy);
    print_message("  rotation %.3f, TANGENT w %+.0f: highlight extent x %.2f, y %.2f, xy %.2f pixels^2\n", rot,
                  tangent_w, *ixx, *iyy, *ixy);
    film_free(&f);
    scene_free(&s);
}

/* An anisotropic white metal plane under a point light next to the camera: the
 * highlight stretches along the texture's u (the tangent, image x) at
 * rotation 0, along v (image y) at rotation pi/2, and at pi/4 counter-clockwise
 * from the tangent toward the bitangent (decreasing v: glTF's tangent space,
 * +Y up in the texture; here image right and up, so x and y, y down,
 * anticorrelated); with strength 0 the rotation changes no bit of the image. */
TEST(test_aniso_render_rotation)
{
    const double rot[3] = {0.0, 0.5 * M_PI, 0.25 * M_PI};
    double ixx[3], iyy[3], ixy[3];
    for (int k = 0; k < 3; k++)
        aniso_highlight(rot[k], 0.0f, &ixx[k], &iyy[k], &ixy[k]);
    assert_true(ixx[0] > 2.0 * iyy[0]);
    assert_true(iyy[1] > 2.0 * ixx[1]);
    assert_true(ixy[2] < -0.5 * sqrt(ixx[2] * iyy[2]));
    /* Strength 0: the rotation (and the extension) change nothing. */
    Film g[2];
    for (int k = 0; k < 2; k++) {
        Scene s;
        SceneMaterial *m = dt_plane_scene(&s);
        m->metallic = 1.0f;
        m->roughness = 0.25f;
        m->anisotropy_rotation = k ? 1.0f : 0.0f;
        add_point_light(&s, 1.0f, 10.0f);
        RenderSettings rs = square_settings(16, 8, 3, 3);
        render_film_ok(&s, &rs, &g[k]);
        scene_free(&s);
    }
    assert_true(memcmp(g[0].xyz, g[1].xyz, sizeof(float) * 3 * 16 * 16) == 0);
    film_free(&g[0]);
    film_free(&g[1]);
}

/* ---- TANGENT ------------------------------------------------------------------- */

/* A triangle with TANGENT (w -1 on its third vertex) and a morph target moving
 * the tangents by (0, 1, 0) at mesh weight 0.5, on a node mirrored in x and
 * turned 90 degrees about z: each tangent is (1, 0.5, 0) by the morph, (-1,
 * 0.5, 0) by the mirror, (-0.5, -1, 0) by the turn, normalised; w changes sign
 * (the mirror flips the bitangent cross(n, t) w must give). */
TEST(test_tangent_loaded)
{
    float data[30] = {0, 0, 0, 1, 0, 0, 0, 1, 0,           /* POSITION */
                      1, 0, 0, 1, 1, 0, 0, 1, 1, 0, 0, -1, /* TANGENT */
                      0, 1, 0, 0, 1, 0, 0, 1, 0};          /* target TANGENT */
    char uri[30 * 4 * 3 + 1];
    const unsigned char *b = (const unsigned char *)data;
    for (size_t i = 0; i < sizeof data; i++)
        snprintf(uri + 3 * i, 4, "%%%02X", b[i]);
    char json[4096];
    snprintf(json, sizeof json,
             "{\"asset\":{\"version\":\"2.0\"},\"scene\":0,\"scenes\":[{\"nodes\":[0]}],"
             "\"nodes\":[{\"mesh\":0,\"scale\":[-1,1,1],\"rotation\":[0,0,0.7071067811865476,0.7071067811865476]}],"
             "\"buffers\":[{\"byteLength\":120,\"uri\":\"data:application/octet-stream,%s\"}],"
             "\"bufferViews\":[{\"buffer\":0,\"byteLength\":36},{\"buffer\":0,\"byteOffset\":36,"
             "\"byteLength\":48},{\"buffer\":0,\"byteOffset\":84,\"byteLength\":36}],"
             "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\","
             "\"min\":[0,0,0],\"max\":[1,1,0]},{\"bufferView\":1,\"componentType\":5126,\"count\":3,"
             "\"type\":\"VEC4\"},{\"bufferView\":2,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\"}],"
             "\"meshes\":[{\"weights\":[0.5],\"primitives\":[{\"attributes\":{\"POSITION\":0,\"TANGENT\":1},"
             "\"targets\":[{\"TANGENT\":2}]}]}]}",
             uri);
    Scene sc;
    SptError e = {0};
    int rc = scene_load_gltf_memory(&sc, json, strlen(json), "tangent.gltf", &e);
    if (rc)
        fail_msg("load: %s", e.msg);
    assert_non_null(sc.vtx_tangent);
    assert_int_equal(sc.vertex_count, 3);
    const double x = -0.5 / sqrt(1.25), y = -1.0 / sqrt(1.25);
    for (uint32_t v = 0; v < 3; v++) {
        const float *t = sc.vtx_tangent + 4 * v;
        assert_close(t[0], x, 1e-6);
        assert_close(t[1], y, 1e-6);
        assert_close(t[2], 0.0, 1e-6);
    }
    /* Two vertices of w 1 become -1, the one of w -1 becomes 1. */
    int neg = 0, pos = 0;
    for (uint32_t v = 0; v < 3; v++) {
        neg += sc.vtx_tangent[4 * v + 3] == -1.0f;
        pos += sc.vtx_tangent[4 * v + 3] == 1.0f;
    }
    assert_int_equal(neg, 2);
    assert_int_equal(pos, 1);
    scene_free(&sc);
}

/* TANGENT decides the anisotropy direction over the texture coordinates: the
 * plane of test_aniso_render_rotation (u along x) with tangents along z
 * stretches the highlight along z (image y) at rotation 0; the same tangents
 * with w -1 (the bitangent reversed) turn a rotation of pi/4 to the other
 * diagonal. */
TEST(test_tangent_render)
{
    double ixx[3], iyy[3], ixy[3];
    for (int k = 0; k < 3; k++)
        aniso_highlight(k == 0 ? 0.0 : 0.25 * M_PI, k == 2 ? -1.0f : 1.0f, &ixx[k], &iyy[k], &ixy[k]);
    assert_true(iyy[0] > 2.0 * ixx[0]);
    assert_true(fabs(ixy[1]) > 0.5 * sqrt(ixx[1] * iyy[1]));
    assert_true(ixy[1] * ixy[2] < 0.0);
}

TEST_MAIN("anisotropy", setup_cpu_device, teardown_cpu_device)
