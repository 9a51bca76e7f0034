/* kernels/closure/bsdf.h against independent values: textbook Fresnel forms, the
 * normal-incidence conductor formula, the KHR_materials_dispersion definition at
 * the Fraunhofer lines, Snell's law through a prism, chi-square tests of the
 * samplers against their pdfs (tests/chi2.h), reciprocity and white-furnace
 * albedos. */
#include "test_cl_util.h"

#include <stdlib.h>
#include <string.h>

#include "chi2.h"
#include "sheen_spec.h"
#include "bsdf_test.h"

/* Chi-square tests expected to pass in this binary, for the Sidak correction. */
#define BSDF_CHI2_TESTS 15
#define BSDF_CHI2_SAMPLES 200000u

/* A direction at polar angle theta (degrees) in the xz plane, z up. */
static vec3 dir_deg(double theta)
{
    double t = theta * M_PI / 180.0;
    return v3((float)sin(t), 0.0f, (float)cos(t));
}

/* ---- Fresnel ------------------------------------------------------------------ */

/* The dielectric Fresnel against the sine/tangent forms (Hecht, Optics, 4.42-4.43),
 * a different algebraic route, and against published air-glass numbers. */
TEST(test_fresnel_dielectric)
{
    const double n = 1.5;
    assert_close(bsdf_fresnel_dielectric(1.0f, 1.5f), 0.04, 1e-6);
    /* Brewster's angle: Rp = 0, so R = Rs / 2 = 0.0739 (Hecht). */
    double tb = atan(n);
    assert_close(bsdf_fresnel_dielectric((float)cos(tb), 1.5f), 0.5 * pow(sin(tb - asin(sin(tb) / n)) / sin(tb + asin(sin(tb) / n)), 2), 1e-5);
    for (double deg = 5.0; deg < 89.0; deg += 7.0) {
        double i = deg * M_PI / 180.0, t = asin(sin(i) / n);
        double rs = pow(sin(i - t) / sin(i + t), 2), rp = pow(tan(i - t) / tan(i + t), 2);
        assert_close(bsdf_fresnel_dielectric((float)cos(i), 1.5f), 0.5 * (rs + rp), 2e-6);
        /* From inside at the refracted angle: the same reflectance (Stokes). */
        assert_close(bsdf_fresnel_dielectric(-(float)cos(t), 1.5f), 0.5 * (rs + rp), 2e-5);
    }
    /* Beyond the critical angle asin(1/1.5) = 41.81 degrees: total reflection. */
    assert_close(bsdf_fresnel_dielectric(-(float)cos(42.0 * M_PI / 180.0), 1.5f), 1.0, 0.0);
    assert_true(bsdf_fresnel_dielectric(-(float)cos(41.5 * M_PI / 180.0), 1.5f) < 1.0f);
}

/* The conductor Fresnel: at normal incidence ((n-1)^2 + k^2) / ((n+1)^2 + k^2);
 * with k = 0 it equals the dielectric one at every angle; at grazing it tends to 1. */
TEST(test_fresnel_conductor)
{
    /* (n, k) pairs spanning metals at visible wavelengths (gold-like, silver-like,
     * aluminium-like, copper-like); the formula is the check, not the values. */
    const float nk[5][2] = {{0.18f, 3.4f}, {0.05f, 4.3f}, {1.2f, 7.3f}, {0.27f, 3.4f}, {1.5f, 0.0f}};
    for (int j = 0; j < 5; j++) {
        double n = nk[j][0], k = nk[j][1];
        double want = ((n - 1) * (n - 1) + k * k) / ((n + 1) * (n + 1) + k * k);
        assert_close(bsdf_fresnel_conductor(1.0f, nk[j][0], nk[j][1]), want, 1e-5);
        assert_true(bsdf_fresnel_conductor(1e-4f, nk[j][0], nk[j][1]) > 0.99f);
    }
    for (double c = 0.05; c <= 1.0; c += 0.1)
        assert_close(bsdf_fresnel_conductor((float)c, 1.5f, 0.0f), bsdf_fresnel_dielectric((float)c, 1.5f), 1e-5);
}

/* The measured tables: at normal incidence bsdf_fresnel_conductor equals
 * ((n-1)^2 + k^2) / ((n+1)^2 + k^2) from the table's n, k at 3 wavelengths; table
 * entries equal the source values (pbrt-v4, tools/gen_conductors.py) interpolated
 * by hand; reflectances have the published character (gold and copper dark in the
 * blue, bright in the red; silver bright; aluminium about 0.91 at 550 nm). */
TEST(test_conductor_tables)
{
    const char *names[4] = {"Au", "Ag", "Cu", "Al"};
    const float lams[3] = {450.0f, 550.0f, 700.0f};
    double R[4][3];
    for (int m = 0; m < 4; m++)
        for (int j = 0; j < 3; j++) {
            double n = spt_conductor_lookup(m, 0, lams[j]), k = spt_conductor_lookup(m, 1, lams[j]);
            double want = ((n - 1) * (n - 1) + k * k) / ((n + 1) * (n + 1) + k * k);
            BsdfParams p = make_params(1.0f, 1.0f, 0.0f, 0.0f);
            bsdf_set_conductor(&p, m, lams[j], lams[j], lams[j], lams[j]);
            R[m][j] = bsdf_fresnel_conductor(1.0f, p.eta.x, p.k.x);
            assert_close(R[m][j], want, 1e-5);
            /* The smooth metal's mirror sample weight is the same reflectance. */
            BsdfSample s = bsdf_sample(&p, v3(0, 0, 1), 0.5f, 0.5f, 0.5f);
            assert_true(s.valid && s.is_delta);
            assert_close(s.weight.x, want, 1e-5);
            print_message("  %s %.0f nm: n %.4f k %.4f R(0) %.4f\n", names[m], lams[j], n, k, want);
        }
    /* Source points: Au 551.040771 nm n 0.345500 between 550 and 555 nm entries;
     * Cu 590.400818 nm k 2.809000; lookups there agree to the 5 nm resampling. */
    assert_close(spt_conductor_lookup(SPT_CONDUCTOR_AU, 0, 551.040771f), 0.3455, 0.003);
    assert_close(spt_conductor_lookup(SPT_CONDUCTOR_CU, 1, 590.400818f), 2.809, 0.01);
    assert_close(spt_conductor_lookup(SPT_CONDUCTOR_AL, 1, 619.920898f), 7.48, 0.01);
    assert_close(spt_conductor_lookup(SPT_CONDUCTOR_AG, 0, 495.936707f), 0.13, 0.002);
    assert_true(R[0][0] < 0.45 && R[0][2] > 0.95);
    assert_true(R[2][0] < 0.65 && R[2][2] > 0.95);
    assert_true(R[1][1] > 0.95);
    assert_close(R[3][1], 0.915, 0.02);
}

/* ---- Dispersion and the prism -------------------------------------------------- */

/* KHR_materials_dispersion: n(lambda_d) = ior and (n_d - 1)/(n_F - n_C) = V with
 * dispersion = 20/V; Fraunhofer d 587.5618, F 486.1327, C 656.2725 nm. */
TEST(test_dispersion_ior)
{
    const double ld = 587.5618, lf = 486.1327, lc = 656.2725;
    const double ior = 1.5168, V = 64.17;
    float disp = (float)(20.0 / V);
    double nd = bsdf_dispersion_ior((float)ior, disp, (float)ld);
    double nf = bsdf_dispersion_ior((float)ior, disp, (float)lf);
    double nc = bsdf_dispersion_ior((float)ior, disp, (float)lc);
    assert_close(nd, ior, 2e-5);
    assert_close_rel((nd - 1.0) / (nf - nc), V, 1e-3);
    assert_true(nf > nd && nd > nc);
    assert_close(bsdf_dispersion_ior(1.5f, 0.0f, 400.0f), 1.5, 0.0);
    print_message("  BK7-like: n_F %.5f n_d %.5f n_C %.5f, Abbe %.3f\n", nf, nd, nc, (nd - 1) / (nf - nc));
}

/* A ray through a 60-degree prism (apex along y) refracted by bsdf_refract at both
 * faces with each wavelength's ior; deviation against Snell's law in angles:
 * delta = theta1 + theta4 - A, theta2 = asin(sin theta1 / n), theta3 = A - theta2,
 * theta4 = asin(n sin theta3). Red is bent least. */
TEST(test_prism)
{
    const double A = 60.0 * M_PI / 180.0, theta1 = 50.0 * M_PI / 180.0;
    const float lambdas[3] = {450.0f, 550.0f, 700.0f};
    double dev[3];
    /* Face normals (outward) in the xz plane: face 1 at -A/2, face 2 at +A/2 about z. */
    vec3 n1 = v3((float)-cos(A / 2), 0.0f, (float)sin(A / 2));
    vec3 n2 = v3((float)cos(A / 2), 0.0f, (float)sin(A / 2));
    for (int j = 0; j < 3; j++) {
        double n = bsdf_dispersion_ior(1.5168f, 20.0f / 64.17f, lambdas[j]);
        /* Incoming direction d at angle theta1 to -n1, in the plane, tilted up. */
        vec3 t1 = v3((float)sin(A / 2), 0.0f, (float)cos(A / 2)); /* tangent of face 1 */
        vec3 d = v3_add(v3_scale(n1, (float)-cos(theta1)), v3_scale(t1, (float)sin(theta1)));
        vec3 w = v3_scale(d, -1.0f), inside = v3(0, 0, 0), out = v3(0, 0, 0);
        assert_true(bsdf_refract(w, n1, (float)n, &inside));
        /* At face 2 the ray leaves: w points back inside, the normal is -n2. */
        assert_true(bsdf_refract(v3_scale(inside, -1.0f), v3_scale(n2, -1.0f), (float)(1.0 / n), &out));
        double c = v3_dot(d, out);
        double got = acos(fmin(1.0, c));
        double th2 = asin(sin(theta1) / n), th3 = A - th2, th4 = asin(n * sin(th3));
        double want = theta1 + th4 - A;
        assert_close(got, want, 2e-4);
        dev[j] = got;
        print_message("  %.0f nm: n %.5f, deviation %.4f deg (Snell %.4f)\n", lambdas[j], n, got * 180 / M_PI,
                      want * 180 / M_PI);
    }
    assert_true(dev[2] < dev[1] && dev[1] < dev[0]);
}

/* ---- Chi-square tests ----------------------------------------------------------- */

typedef struct VndfCtx {
    vec3 wo;
    float alpha;
    uint32_t stream;
    int sphere; /* 1: bin h itself on the sphere (wide lobes) */
} VndfCtx;

/* Sample i as the microfacet normal's scaled slope-free coordinates (h.x, h.y) /
 * alpha, so the plane grid resolves the lobe at every alpha. */
static int vndf_sample(void *ctx, uint32_t i, double p[3])
{
    VndfCtx *c = ctx;
    uint64_t b = ((uint64_t)c->stream << 40) + 2u * (uint64_t)i;
    vec3 h = bsdf_ggx_sample_vndf(c->wo, c->alpha, test_uniform(b), test_uniform(b + 1));
    if (c->sphere) {
        p[0] = h.x;
        p[1] = h.y;
        p[2] = h.z;
        return 1;
    }
    p[0] = h.x / c->alpha;
    p[1] = h.y / c->alpha;
    return 1;
}

/* Density of (h.x, h.y) / alpha: D_wo(h) per steradian times d omega / dA =
 * alpha^2 / h.z (projection of the hemisphere onto the disk). */
static double vndf_pdf(void *ctx, const double p[3])
{
    VndfCtx *c = ctx;
    if (c->sphere)
        return bsdf_ggx_vndf_pdf(c->wo, v3((float)p[0], (float)p[1], (float)p[2]), c->alpha);
    double x = p[0] * c->alpha, y = p[1] * c->alpha, r2 = x * x + y * y;
    if (r2 >= 1.0)
        return 0.0;
    double z = sqrt(1.0 - r2);
    return bsdf_ggx_vndf_pdf(c->wo, v3((float)x, (float)y, (float)z), c->alpha) * c->alpha * c->alpha / z;
}

/* Visible-normal sampling against D_wo(h), several alphas and angles; the domain
 * [-3, 3]^2 in units of alpha for narrow lobes (the tail outside is the pdf's
 * missing mass), the sphere for wide ones (whose projected density is singular at
 * the disk's rim). */
TEST(test_vndf_chi2)
{
    const float alphas[2] = {0.1f, 0.6f};
    const double thetas[2] = {10.0, 70.0};
    uint32_t stream = 1;
    for (int a = 0; a < 2; a++)
        for (int t = 0; t < 2; t++) {
            VndfCtx c = {dir_deg(thetas[t]), alphas[a], stream++, alphas[a] > 0.3f};
            char name[96];
            snprintf(name, sizeof name, "GGX VNDF alpha %.2f theta_o %.0f", alphas[a], thetas[t]);
            Chi2Grid g = c.sphere ? chi2_sphere(name, 40, 40, BSDF_CHI2_TESTS, vndf_sample, vndf_pdf, &c)
                                  : chi2_plane(name, -3.0, 3.0, -3.0, 3.0, 40, 40, BSDF_CHI2_TESTS,
                                               vndf_sample, vndf_pdf, &c);
            g.samples = BSDF_CHI2_SAMPLES;
            chi2_require(&g);
        }
}

static void run_mat_chi2(const char *what, BsdfParams p, vec3 wo, uint32_t stream)
{
    MatCtx c = {p, wo, stream};
    char name[128];
    snprintf(name, sizeof name, "%s rough %.2f theta_o %.0f", what, p.roughness,
             acos(fabs(wo.z)) * 180 / M_PI);
    Chi2Grid g = chi2_sphere(name, 64, 64, BSDF_CHI2_TESTS, mat_sample, mat_pdf, &c);
    g.samples = BSDF_CHI2_SAMPLES;
    chi2_require(&g);
}

/* The full metallic-roughness sampler (diffuse + GGX), a measured conductor and
 * the rough dielectric (reflection + transmission, from outside and inside). */
TEST(test_material_chi2)
{
    run_mat_chi2("metallic-roughness m 0.3", make_params(0.8f, 0.3f, 0.5f, 0.0f), dir_deg(30), 101);
    run_mat_chi2("metallic-roughness m 0.0", make_params(0.5f, 0.0f, 0.45f, 0.0f), dir_deg(75), 102);
    BsdfParams cu = make_params(1.0f, 1.0f, 0.3f, 0.0f);
    cu.conductor = 1;
    cu.eta = v4(0.27f, 0.5f, 1.0f, 1.1f);
    cu.k = v4(3.4f, 2.6f, 2.5f, 2.4f);
    run_mat_chi2("conductor", cu, dir_deg(45), 103);
    run_mat_chi2("rough dielectric (outside)", make_params(1.0f, 0.0f, 0.5f, 1.0f), dir_deg(40), 104);
    run_mat_chi2("rough dielectric (outside)", make_params(1.0f, 0.0f, 0.45f, 1.0f), dir_deg(70), 105);
    vec3 in = dir_deg(20);
    in.z = -in.z;
    run_mat_chi2("rough dielectric (inside)", make_params(1.0f, 0.0f, 0.4f, 1.0f), in, 106);
    run_mat_chi2("half transmissive", make_params(0.7f, 0.0f, 0.4f, 0.5f), dir_deg(50), 107);
}

/* ---- KHR_materials_clearcoat and KHR_materials_sheen ---------------------------- */

/* A coat of weight cc and roughness r with its normal tilted by tilt degrees about
 * the y axis, and a sheen of grey colour c and roughness sr, on p. */
static BsdfParams with_layers(BsdfParams p, float cc, float r, double tilt, float c, float sr)
{
    p.clearcoat = cc;
    p.cc_roughness = r;
    p.cc_n = dir_deg(tilt);
    p.sheen = v4_splat(c);
    p.sheen_max = c;
    p.sheen_roughness = sr;
    return p;
}

/* The layered sampler against its pdf: coat over a rough metallic-roughness base,
 * a coat with its own (tilted) normal over a diffuse base, sheen over diffuse, and
 * coat + sheen over a rough metal. */
TEST(test_layers_chi2)
{
    run_mat_chi2("coat 0.3 over m 0.3", with_layers(make_params(0.8f, 0.3f, 0.5f, 0.0f), 1.0f, 0.3f, 0, 0, 0),
                 dir_deg(40), 201);
    run_mat_chi2("tilted coat 0.2 over diffuse",
                 with_layers(make_params(0.6f, 0.0f, 0.6f, 0.0f), 0.8f, 0.2f, 25, 0, 0), dir_deg(60), 202);
    run_mat_chi2("sheen 0.5 over diffuse", with_layers(make_params(0.5f, 0.0f, 0.7f, 0.0f), 0, 0, 0, 0.8f, 0.5f),
                 dir_deg(70), 203);
    run_mat_chi2("coat 0.4 + sheen 0.2 over metal",
                 with_layers(make_params(0.9f, 1.0f, 0.3f, 0.0f), 0.7f, 0.4f, 0, 1.0f, 0.2f), dir_deg(20), 204);
}

/* The sample weight is eval / pdf for layered materials, and a sheen over a
 * diffuse base is reciprocal (the albedo scaling uses max(E(mu_o), E(mu_i)), and
 * the lobe's own normalisation max(1, E(mu_o), E(mu_i)), both symmetric). */
TEST(test_layers_consistency)
{
    BsdfParams mats[3] = {with_layers(make_params(0.6f, 0.4f, 0.45f, 0.0f), 1.0f, 0.25f, 10, 0.7f, 0.3f),
                          with_layers(make_params(0.8f, 0.0f, 0.5f, 0.5f), 0.5f, 0.35f, 0, 0.0f, 0.0f),
                          with_layers(make_params(0.6f, 0.0f, 0.8f, 0.0f), 0.0f, 0.0f, 0, 0.9f, 0.15f)};
    int checked = 0;
    for (int k = 0; k < 3; k++)
        for (uint32_t i = 0; i < 2000; i++) {
            vec3 wo = v3_normalize(v3(test_uniform(17000 + i) - 0.5f, test_uniform(19000 + i) - 0.5f,
                                      test_uniform(21000 + i) + 0.02f));
            uint64_t b = 3u * (60000u * (uint64_t)k + i);
            BsdfSample s = bsdf_sample(&mats[k], wo, test_uniform(b), test_uniform(b + 1), test_uniform(b + 2));
            if (!s.valid || s.is_delta)
                continue;
            vec4 f = bsdf_eval(&mats[k], wo, s.wi);
            assert_close_rel(s.weight.x, f.x / bsdf_pdf(&mats[k], wo, s.wi), 1e-4);
            if (k == 2 && s.wi.z > 0.01f) {
                vec4 back = bsdf_eval(&mats[k], s.wi, wo);
                assert_close_rel(f.x / s.wi.z, back.x / wo.z, 2e-3);
            }
            checked++;
        }
    assert_true(checked > 4000);
}

/* E(mu, r) of kernels/closure/sheen_table.h between its nodes against the directional
 * albedo of the specification's Charlie lobe integrated here over wi (midpoint
 * rule, 1000 x 400 nodes, double precision). */
static double spec_sheen_albedo(double mu, double r)
{
    double alpha = r * r, sum = 0;
    const int nt = 1000, np = 400;
    double wo[3] = {sqrt(1 - mu * mu), 0, mu};
    for (int a = 0; a < nt; a++) {
        double ci = (a + 0.5) / nt, si = sqrt(1 - ci * ci);
        for (int b = 0; b < np; b++) {
            double ph = (b + 0.5) / np * M_PI;
            double h[3] = {wo[0] + si * cos(ph), si * sin(ph), wo[2] + ci};
            double hl = sqrt(h[0] * h[0] + h[1] * h[1] + h[2] * h[2]);
            double s2 = 1 - (h[2] / hl) * (h[2] / hl);
            double D = (2 + 1 / alpha) * pow(s2 > 0 ? s2 : 0, 0.5 / alpha) / (2 * M_PI);
            double V = 1 / ((1 + spec_sheen_lambda(mu, alpha) + spec_sheen_lambda(ci, alpha)) * 4 * mu * ci);
            sum += D * V * ci;
        }
    }
    return 2 * sum / nt * M_PI / np;
}

TEST(test_sheen_table)
{
    const double mus[4] = {0.07, 0.33, 0.61, 0.93}, rs[4] = {0.12, 0.35, 0.66, 0.97};
    for (int i = 0; i < 4; i++)
        for (int j = 0; j < 4; j++) {
            double want = spec_sheen_albedo(mus[i], rs[j]);
            double got = bsdf_sheen_albedo((float)mus[i], (float)rs[j]);
            print_message("  E(mu %.2f, r %.2f): table %.4f, integrated %.4f\n", mus[i], rs[j], got, want);
            assert_close(got, want, 0.02 * want + 0.003);
        }
}

/* White furnaces of each layer: what a layer and what is under it reflect never
 * exceeds what arrives (albedo <= 1 within 3 standard errors), over roughness and
 * view angle. The coat alone over a black base reflects exactly its weight Fc when
 * smooth, and Fc times single-scattering GGX's albedo when rough (which loses
 * energy at high roughness, as the base's GGX does); a sheen over a white Lambert
 * base keeps most of the energy. The printed table states the losses. */
TEST(test_layer_furnace)
{
    const float roughs[4] = {0.07f, 0.3f, 0.6f, 1.0f};
    const double thetas[4] = {0.0, 45.0, 75.0, 88.0};
    uint32_t stream = 900;
    BsdfParams black = make_params(0.0f, 0.0f, 0.5f, 0.0f);
    black.specular = 0.0f;
    BsdfParams white = make_params(1.0f, 0.0f, 0.5f, 0.0f);
    white.specular = 0.0f;
    BsdfParams metal = make_params(1.0f, 1.0f, 0.5f, 0.0f);
    double worst = 0.0;
    for (int r = 0; r < 4; r++) {
        print_message("  roughness %.2f, theta_o  0 / 45 / 75 / 88:\n", roughs[r]);
        const struct {
            const char *what;
            BsdfParams p;
        } cases[5] = {
            {"sheen over black", with_layers(black, 0, 0, 0, 1.0f, roughs[r])},
            {"sheen over white Lambert", with_layers(white, 0, 0, 0, 1.0f, roughs[r])},
            {"coat over black", with_layers(black, 1.0f, roughs[r], 0, 0, 0)},
            {"coat over white Lambert", with_layers(white, 1.0f, roughs[r], 0, 0, 0)},
            {"coat + sheen over white metal", with_layers(metal, 1.0f, roughs[r], 0, 1.0f, roughs[r])},
        };
        for (int k = 0; k < 5; k++) {
            char line[256];
            int at = snprintf(line, sizeof line, "    %-30s", cases[k].what);
            for (int t = 0; t < 4; t++) {
                double err, a = albedo_err(&cases[k].p, dir_deg(thetas[t]), 40000, stream++, &err);
                at += snprintf(line + at, sizeof line - at, " %.4f", a);
                if (a > 1.0 + 3.0 * err + 1e-4)
                    fail_msg("%s, roughness %.2f, theta %.0f: albedo %.5f +- %.5f exceeds 1", cases[k].what,
                             roughs[r], thetas[t], a, err);
                worst = fmax(worst, a);
                if (k == 2) {
                    /* A coat over black reflects at most its weight Fc(mu_o). */
                    double fc = bsdf_coat_fresnel((float)cos(thetas[t] * M_PI / 180.0));
                    assert_true(a <= fc + 3.0 * err + 1e-6);
                }
            }
            print_message("%s\n", line);
        }
    }
    /* The smooth coat over black reflects exactly Fc. */
    BsdfParams mirror = with_layers(black, 1.0f, 0.0f, 0, 0, 0);
    for (int t = 0; t < 4; t++) {
        double err, a = albedo_err(&mirror, dir_deg(thetas[t]), 20000, stream++, &err);
        assert_close(a, bsdf_coat_fresnel((float)cos(thetas[t] * M_PI / 180.0)), 1e-5);
    }
    print_message("  largest albedo %.4f\n", worst);
}

/* ---- Consistency, reciprocity, energy ------------------------------------------ */

/* For rough materials the sample weight equals eval / pdf at the sampled wi, and
 * reflection is reciprocal: f(wo, wi) = f(wi, wo), i.e. eval(wo,wi)/wi.z =
 * eval(wi,wo)/wo.z. */
TEST(test_consistency_reciprocity)
{
    BsdfParams p = make_params(0.6f, 0.4f, 0.45f, 0.0f);
    for (uint32_t i = 0; i < 2000; i++) {
        vec3 wo = v3_normalize(v3(test_uniform(7000 + i) - 0.5f, test_uniform(9000 + i) - 0.5f, test_uniform(11000 + i) + 0.05f));
        BsdfSample s = bsdf_sample(&p, wo, test_uniform(3 * i), test_uniform(3 * i + 1), test_uniform(3 * i + 2));
        if (!s.valid)
            continue;
        vec4 f = bsdf_eval(&p, wo, s.wi);
        assert_close_rel(s.weight.x, f.x / bsdf_pdf(&p, wo, s.wi), 1e-4);
        assert_false(s.is_delta);
        if (s.wi.z > 0.01f) {
            vec4 b = bsdf_eval(&p, s.wi, wo);
            assert_close_rel(f.x / s.wi.z, b.x / wo.z, 1e-3);
        }
    }
    assert_false(bsdf_is_delta(&p));
    BsdfParams glass = make_params(1.0f, 0.0f, 0.0f, 1.0f);
    assert_true(bsdf_is_delta(&glass));
    BsdfParams mirror = make_params(1.0f, 1.0f, 0.0f, 0.0f);
    assert_true(bsdf_is_delta(&mirror));
    BsdfParams plastic = make_params(1.0f, 0.0f, 0.0f, 0.0f);
    assert_false(bsdf_is_delta(&plastic));
}

/* Rough transmission obeys generalised reciprocity (Veach 1997, thesis eq. 5.14):
 * the physical BTDF has f(wo,wi) / n_i^2 = f(wi,wo) / n_o^2 (n_i, n_o: the
 * indices on wi's and wo's sides). bsdf_eval divides refraction by eta'^2 for
 * radiance transport, so with wo outside and wi inside glass of index eta,
 * eval(wo,wi)/|wi.z| = eval(wi,wo)/|wo.z| / eta^2. */
TEST(test_transmission_reciprocity)
{
    const float roughs[2] = {0.3f, 0.7f};
    int checked = 0;
    for (int r = 0; r < 2; r++) {
        BsdfParams p = make_params(1.0f, 0.0f, roughs[r], 1.0f);
        for (uint32_t i = 0; i < 500; i++) {
            vec3 wo = v3_normalize(v3(test_uniform(40000 + i) - 0.5f, test_uniform(41000 + i) - 0.5f, test_uniform(42000 + i) + 0.1f));
            vec3 wi = v3_normalize(v3(test_uniform(43000 + i) - 0.5f, test_uniform(44000 + i) - 0.5f, -test_uniform(45000 + i) - 0.1f));
            double a = bsdf_eval(&p, wo, wi).x / fabs(wi.z), b = bsdf_eval(&p, wi, wo).x / fabs(wo.z);
            if (a < 1e-6 && b < 1e-6)
                continue;
            assert_close_rel(a, b / (1.5 * 1.5), 2e-3);
            checked++;
        }
    }
    assert_true(checked > 200);
    print_message("  %d pairs with f(wo,wi) = f(wi,wo) / eta^2\n", checked);
}

/* Monte Carlo directional albedo: the mean sample weight (hero wavelength). When
 * undo_eta is set, refracted samples are multiplied back by eta'^2 (the radiance
 * scaling), giving the energy balance R + T. */
static double albedo(const BsdfParams *p, vec3 wo, uint32_t n, uint32_t stream, int undo_eta)
{
    double sum = 0.0;
    for (uint32_t i = 0; i < n; i++) {
        uint64_t b = ((uint64_t)stream << 40) + 3u * (uint64_t)i;
        BsdfSample s = bsdf_sample(p, wo, test_uniform(b), test_uniform(b + 1), test_uniform(b + 2));
        if (!s.valid)
            continue;
        double w = s.weight.x;
        if (undo_eta && s.wi.z * wo.z < 0.0f) {
            double etap = wo.z > 0.0f ? p->ior.x : 1.0 / p->ior.x;
            w *= etap * etap;
        }
        sum += w;
    }
    return sum / n;
}

/* A white rough metal and a rough dielectric never exceed albedo 1 (single
 * scattering loses energy at high roughness); the smooth dielectric's R + T is 1. */
TEST(test_energy)
{
    const float roughs[4] = {0.05f, 0.3f, 0.6f, 1.0f};
    const double thetas[3] = {0.0, 45.0, 80.0};
    uint32_t stream = 500;
    for (int r = 0; r < 4; r++)
        for (int t = 0; t < 3; t++) {
            BsdfParams metal = make_params(1.0f, 1.0f, roughs[r], 0.0f);
            double am = albedo(&metal, dir_deg(thetas[t]), 40000, stream++, 0);
            BsdfParams diel = make_params(1.0f, 0.0f, roughs[r], 1.0f);
            double ad = albedo(&diel, dir_deg(thetas[t]), 40000, stream++, 1);
            print_message("  rough %.2f theta %2.0f: white metal %.4f, dielectric R+T %.4f\n", roughs[r], thetas[t],
                          am, ad);
            assert_true(am <= 1.01);
            assert_true(ad <= 1.01);
            if (roughs[r] <= 0.05f) {
                assert_true(am > 0.97);
                assert_true(ad > 0.97);
            }
        }
    const double smooth_thetas[4] = {0.0, 30.0, 60.0, 85.0};
    for (int t = 0; t < 4; t++) {
        BsdfParams glass = make_params(1.0f, 0.0f, 0.0f, 1.0f);
        double a_out = albedo(&glass, dir_deg(smooth_thetas[t]), 20000, stream++, 1);
        vec3 in = dir_deg(smooth_thetas[t] * 0.5);
        in.z = -in.z;
        double a_in = albedo(&glass, in, 20000, stream++, 1);
        print_message("  smooth glass theta %2.0f: R+T from outside %.6f, from inside (theta %.0f) %.6f\n",
                      smooth_thetas[t], a_out, smooth_thetas[t] * 0.5, a_in);
        assert_close(a_out, 1.0, 1e-5);
        assert_close(a_in, 1.0, 1e-5);
    }
}

/* Smooth dielectric sampling: the reflect fraction equals the Fresnel reflectance,
 * and the directions obey the mirror law and Snell's law. A dispersive ior sets
 * the dispersive flag on refraction only. */
TEST(test_smooth_dielectric)
{
    BsdfParams glass = make_params(1.0f, 0.0f, 0.0f, 1.0f);
    const double thetas[3] = {0.0, 45.0, 80.0};
    for (int t = 0; t < 3; t++) {
        vec3 wo = dir_deg(thetas[t]);
        double F = bsdf_fresnel_dielectric(wo.z, 1.5f);
        uint32_t n = 100000, nr = 0;
        for (uint32_t i = 0; i < n; i++) {
            BsdfSample s = bsdf_sample(&glass, wo, test_uniform(900000 + i), 0.5f, 0.5f);
            assert_true(s.valid && s.is_delta);
            if (s.wi.z > 0.0f) {
                nr++;
                assert_close(s.wi.x, -wo.x, 1e-6);
                assert_close(s.wi.z, wo.z, 1e-6);
            } else {
                double sin_t = sqrt(s.wi.x * s.wi.x + s.wi.y * s.wi.y);
                assert_close(sin_t * 1.5, sin(thetas[t] * M_PI / 180.0), 1e-5);
            }
        }
        double frac = (double)nr / n, sigma = sqrt(F * (1 - F) / n);
        print_message("  theta %.0f: reflected %.4f, Fresnel %.4f\n", thetas[t], frac, F);
        assert_close(frac, F, 5 * sigma + 1e-4);
    }
    /* A tinted glass (KHR_materials_transmission: the btdf times the base colour):
     * the refraction weight is base / eta^2, the reflection weight stays 1. */
    BsdfParams tint = glass;
    tint.base = v4(0.5f, 0.25f, 1.0f, 0.75f);
    BsdfSample st = bsdf_sample(&tint, dir_deg(30), 0.99f, 0.5f, 0.5f);
    assert_true(st.valid && st.wi.z < 0.0f);
    assert_close(st.weight.x, 0.5 / 2.25, 1e-5);
    assert_close(st.weight.y, 0.25 / 2.25, 1e-5);
    st = bsdf_sample(&tint, dir_deg(30), 0.001f, 0.5f, 0.5f);
    assert_true(st.valid && st.wi.z > 0.0f);
    assert_close(st.weight.y, 1.0, 1e-5);
    BsdfParams disp = glass;
    disp.ior = v4(1.52f, 1.51f, 1.50f, 1.53f);
    BsdfSample s = bsdf_sample(&disp, dir_deg(30), 0.99f, 0.5f, 0.5f);
    assert_true(s.valid && s.dispersive && s.wi.z < 0.0f);
    s = bsdf_sample(&disp, dir_deg(30), 0.001f, 0.5f, 0.5f);
    assert_true(s.valid && !s.dispersive && s.wi.z > 0.0f);
}

/* ---- The device build ---------------------------------------------------------- */

/* Each work-item samples and evaluates one material for one (wo, u) input. */
static const char *k_device_src =
    "#include \"closure/bsdf.h\"\n"
    "__kernel void k_bsdf_test(__global const float *in, __global float *out, int n)\n"
    "{\n"
    "    int i = get_global_id(0);\n"
    "    if (i >= n) return;\n"
    "    const __global float *q = in + 10 * i;\n"
    "    BsdfParams p;\n"
    "    p.base = (float4)(q[6], q[6], 0.5f, 0.9f);\n"
    "    p.ior = (float4)(1.5f, 1.51f, 1.52f, 1.49f);\n"
    "    p.eta = (float4)(0.2f, 0.5f, 1.0f, 1.2f);\n"
    "    p.k = (float4)(3.0f, 2.6f, 2.5f, 7.0f);\n"
    "    p.metallic = q[7]; p.roughness = q[8]; p.transmission = q[9]; p.conductor = i % 2;\n"
    "    p.spec_tint = (float4)(1.0f, 0.9f, 1.0f, 1.1f); p.specular = 0.75f;\n"
    "    p.clearcoat = (i % 6 == 2) ? q[9] : 0.0f; p.cc_roughness = 0.1f + 0.5f * q[4];\n"
    "    p.cc_n = normalize((float3)(0.2f * q[5], -0.1f, 1.0f));\n"
    "    p.sheen_max = (i % 7 == 3) ? q[6] : 0.0f; p.sheen = (float4)(p.sheen_max, 0.5f * p.sheen_max, 0.1f, 0.0f);\n"
    "    p.sheen_roughness = q[5];\n"
    "    p.aniso = (i % 5 == 2) ? q[7] : 0.0f; p.aniso_t = normalize((float3)(q[4] - 0.5f, q[5] - 0.5f, 0.0f));\n"
    "    p.diffuse_transmission = (i % 3 == 1) ? q[4] : 0.0f; p.dt_color = (float4)(0.9f, q[6], 0.3f, 1.0f);\n"
    "    p.iridescence = 0.0f; p.film_ior = 1.3f; p.film_nm = 100.0f + 400.0f * q[6];\n"
    "    p.lambda = (float4)(400.0f + q[3] * 400.0f, 500.0f, 600.0f, 700.0f);\n"
    "    if (i % 4 == 1) bsdf_set_conductor(&p, i % 3, 400.0f + q[3] * 400.0f, 500.0f, 600.0f, 700.0f);\n"
    "    float3 wo = normalize((float3)(q[0], q[1], q[2]));\n"
    "    BsdfSample s = bsdf_sample(&p, wo, q[3], q[4], q[5]);\n"
    "    float4 f = bsdf_eval(&p, wo, s.wi);\n"
    "    __global float *o = out + 10 * i;\n"
    "    o[0] = s.wi.x; o[1] = s.wi.y; o[2] = s.wi.z; o[3] = s.weight.x; o[4] = s.weight.w;\n"
    "    o[5] = s.pdf; o[6] = (float)(s.valid + 2 * s.is_delta + 4 * s.dispersive);\n"
    "    o[7] = f.y; o[8] = bsdf_pdf(&p, wo, s.wi); o[9] = (float)bsdf_is_delta(&p);\n"
    "}\n";

/* The header builds as OpenCL C 1.2 and the device's samples equal the host's. */
TEST(test_device_matches_host)
{
    TestCl cl = test_cl_open();
    enum { N = 512 };
    static float in[10 * N], out[10 * N];
    for (int i = 0; i < N; i++) {
        float *q = in + 10 * i;
        for (int j = 0; j < 10; j++)
            q[j] = test_uniform(77000 + 10 * (uint64_t)i + j);
        q[0] -= 0.5f;
        q[1] -= 0.5f;
        q[2] = (i % 3 == 0) ? -(q[2] + 0.05f) : q[2] + 0.05f;
        q[8] = (i % 5 == 0) ? 0.0f : 0.1f + 0.9f * q[8];
    }
    TestClArg arg = {in, sizeof in};
    /* Without the thin film, as the path kernels of a scene without one are
     * built (docs/architecture.md, "Portability rules"): rusticl's build of
     * the film inlined here runs past 10 GB. test_iridescence checks the film
     * on the device through renders. */
    test_cl_run(&cl, k_device_src, "-DSPT_IRIDESCENCE=0", "kernels/closure/bsdf.h", "k_bsdf_test", &arg, 1,
                out, sizeof out, N, 0);
    int compared = 0;
    for (int i = 0; i < N; i++) {
        const float *q = in + 10 * i;
        BsdfParams p;
        p.base = v4(q[6], q[6], 0.5f, 0.9f);
        p.ior = v4(1.5f, 1.51f, 1.52f, 1.49f);
        p.eta = v4(0.2f, 0.5f, 1.0f, 1.2f);
        p.k = v4(3.0f, 2.6f, 2.5f, 7.0f);
        p.metallic = q[7];
        p.roughness = q[8];
        p.transmission = q[9];
        p.conductor = i % 2;
        p.spec_tint = v4(1.0f, 0.9f, 1.0f, 1.1f);
        p.specular = 0.75f;
        p.clearcoat = (i % 6 == 2) ? q[9] : 0.0f;
        p.cc_roughness = 0.1f + 0.5f * q[4];
        p.cc_n = v3_normalize(v3(0.2f * q[5], -0.1f, 1.0f));
        p.sheen_max = (i % 7 == 3) ? q[6] : 0.0f;
        p.sheen = v4(p.sheen_max, 0.5f * p.sheen_max, 0.1f, 0.0f);
        p.sheen_roughness = q[5];
        p.aniso = (i % 5 == 2) ? q[7] : 0.0f;
        p.aniso_t = v3_normalize(v3(q[4] - 0.5f, q[5] - 0.5f, 0.0f));
        p.diffuse_transmission = (i % 3 == 1) ? q[4] : 0.0f;
        p.dt_color = v4(0.9f, q[6], 0.3f, 1.0f);
        p.iridescence = 0.0f;
        p.film_ior = 1.3f;
        p.film_nm = 100.0f + 400.0f * q[6];
        p.lambda = v4(400.0f + q[3] * 400.0f, 500.0f, 600.0f, 700.0f);
        if (i % 4 == 1)
            bsdf_set_conductor(&p, i % 3, 400.0f + q[3] * 400.0f, 500.0f, 600.0f, 700.0f);
        vec3 wo = v3_normalize(v3(q[0], q[1], q[2]));
        BsdfSample s = bsdf_sample(&p, wo, q[3], q[4], q[5]);
        vec4 f = bsdf_eval(&p, wo, s.wi);
        const float want[10] = {s.wi.x, s.wi.y, s.wi.z, s.weight.x, s.weight.w, s.pdf,
                                (float)(s.valid + 2 * s.is_delta + 4 * s.dispersive), f.y,
                                bsdf_pdf(&p, wo, s.wi), (float)bsdf_is_delta(&p)};
        const float *g = out + 10 * i;
        /* Flags must agree; values to float rounding (the device may contract). */
        if (g[6] != want[6])
            fail_msg("input %d: flags device %g, host %g", i, g[6], want[6]);
        test_cl_assert_agree(i, g, want, 10, 2e-3f);
        compared += s.valid;
    }
    print_message("  %d valid samples agree between device and host\n", compared);
    test_cl_close(&cl);
}

TEST_MAIN("bsdf", NULL, NULL)
