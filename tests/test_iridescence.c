/* KHR_materials_iridescence: the thin film of kernels/closure/thin_film.h
 * against an independent method, the characteristic (transfer) matrix of
 * thin-film optics (Macleod, Thin-Film Optical Filters, 4th ed., 2.2: the
 * layer's 2 x 2 matrix, tilted admittances, N = n - ik convention), in double
 * precision, over wavelengths, thicknesses, angles, dielectric and measured
 * conductor bases; analytic cases (a quarter-wave antireflection layer
 * reflects nothing, a half-wave layer is absent); the film in the material's
 * Fresnel terms as the extension mixes them; white furnaces of film
 * materials; and a flat film under the default sky (uniform D65) rendered on
 * the OpenCL device, its colour against the colour computed from the matrix
 * method's reflectance, D65 and the CIE 1931 functions. */
#include "test_util.h"
#include "test_render_util.h"

#include <complex.h>
#include <stdlib.h>
#include <string.h>

#include "closure/bsdf.h"
#include "closure/conductors.h"
#include "closure/thin_film.h"
#include "color/spd.h"
#include "render/film.h"
#include "scene/scene.h"
#include "spectrum/cie_data.h"

/* ---- The reference: the characteristic matrix -------------------------------- */

/* n_j cos(theta_j) for a medium of complex index N (N = n - ik) with
 * n0 sin(theta0) = s: the root with imaginary part <= 0 (a wave that decays
 * in this convention, time factor e^{i omega t}). */
static double complex tilted(double complex N, double s)
{
    double complex w = csqrt(N * N - s * s);
    return cimag(w) > 0 ? -w : w;
}

/* Reflectance (mean of s and p) of air-like outside n0 | film n1, d_nm | base
 * n2 - i k2 at angle theta0 and lambda_nm, by the layer's characteristic
 * matrix [[cos delta, i sin delta / eta1], [i eta1 sin delta, cos delta]],
 * delta = 2 pi N1 cos(theta1) d / lambda: [B, C] = M [1, eta2], Y = C / B,
 * r = (eta0 - Y) / (eta0 + Y). Tilted admittances: N cos (s), N / cos (p). */
static double tmm_reflectance(double theta0, double lambda_nm, double n0, double n1, double d_nm, double n2,
                              double k2)
{
    double s = n0 * sin(theta0);
    double complex N[3] = {n0, n1, n2 - I * k2};
    double complex q[3];
    for (int j = 0; j < 3; j++)
        q[j] = j == 0 ? n0 * cos(theta0) : tilted(N[j], s);
    double complex delta = 2.0 * M_PI * q[1] * d_nm / lambda_nm;
    double r = 0.0;
    for (int p = 0; p < 2; p++) {
        double complex eta[3];
        for (int j = 0; j < 3; j++)
            eta[j] = p ? N[j] * N[j] / q[j] : q[j];
        double complex B = ccos(delta) + I * csin(delta) / eta[1] * eta[2];
        double complex C = I * eta[1] * csin(delta) + ccos(delta) * eta[2];
        double complex rr = (eta[0] * B - C) / (eta[0] * B + C);
        r += 0.5 * creal(rr * conj(rr));
    }
    return r;
}

/* The kernel's film at theta (radians). */
static double kernel_film(double theta, double lambda, double n0, double n1, double d, double n2, double k2)
{
    return spt_thin_film_reflectance((float)cos(theta), (float)lambda, (float)n0, (float)n1, (float)d, (float)n2,
                                     (float)k2);
}

/* ---- The film against the matrix method -------------------------------------- */

/* Over wavelengths 380-780 nm, thicknesses 0-1200 nm, angles 0-85 degrees and
 * film indices below and above the base's: dielectric bases (1.0, 1.2, 1.5,
 * 2.4), the measured conductors (Au, Ag, Cu, Al at each wavelength), a film
 * under a coat of index 1.5 with a lower index (total reflection inside the
 * coat past 60 degrees, the film's field evanescent) and a dielectric base
 * below the film's index (total reflection at the second interface). Within
 * 2e-4 (float arithmetic; the phase reaches 70 rad). */
TEST(test_film_vs_matrix_method)
{
    const double lambdas[] = {380, 437, 512, 589, 656, 780};
    const double thick[] = {0, 35, 120, 275, 400, 730, 1200};
    const double thetas[] = {0, 15, 30, 45, 60, 70, 80, 85};
    const double films[] = {1.3, 1.8, 2.6};
    const double bases[] = {1.0, 1.2, 1.5, 2.4};
    double worst = 0;
    long n = 0;
    for (size_t li = 0; li < sizeof lambdas / sizeof *lambdas; li++)
        for (size_t di = 0; di < sizeof thick / sizeof *thick; di++)
            for (size_t ti = 0; ti < sizeof thetas / sizeof *thetas; ti++)
                for (size_t fi = 0; fi < sizeof films / sizeof *films; fi++) {
                    double lam = lambdas[li], d = thick[di], th = thetas[ti] * M_PI / 180, nf = films[fi];
                    /* Dielectric bases, from air. */
                    for (size_t bi = 0; bi < sizeof bases / sizeof *bases; bi++) {
                        double want = tmm_reflectance(th, lam, 1.0, nf, d, bases[bi], 0.0);
                        double got = kernel_film(th, lam, 1.0, nf, d, bases[bi], 0.0);
                        worst = fmax(worst, fabs(got - want));
                        if (fabs(got - want) > 2e-4)
                            fail_msg("dielectric %.2f, film %.2f %.0f nm, %.0f nm, %.0f deg: %.6f, matrix %.6f",
                                     bases[bi], nf, d, lam, thetas[ti], got, want);
                        n++;
                    }
                    /* Measured conductors. */
                    for (int mtl = 0; mtl < SPT_CONDUCTOR_COUNT; mtl++) {
                        double eta = spt_conductor_lookup(mtl, 0, (float)lam);
                        double k = spt_conductor_lookup(mtl, 1, (float)lam);
                        double want = tmm_reflectance(th, lam, 1.0, nf, d, eta, k);
                        double got = kernel_film(th, lam, 1.0, nf, d, eta, k);
                        worst = fmax(worst, fabs(got - want));
                        if (fabs(got - want) > 2e-4)
                            fail_msg("conductor %d, film %.2f %.0f nm, %.0f nm, %.0f deg: %.6f, matrix %.6f", mtl,
                                     nf, d, lam, thetas[ti], got, want);
                        n++;
                    }
                    /* Under a coat of index 1.5, over glass and over gold. */
                    double want = tmm_reflectance(th, lam, 1.5, nf, d, 1.5, 0.0);
                    double got = kernel_film(th, lam, 1.5, nf, d, 1.5, 0.0);
                    worst = fmax(worst, fabs(got - want));
                    if (fabs(got - want) > 2e-4)
                        fail_msg("coat | film %.2f %.0f nm | glass, %.0f nm, %.0f deg: %.6f, matrix %.6f", nf, d,
                                 lam, thetas[ti], got, want);
                    n++;
                }
    print_message("  %ld cases, largest difference %.2e\n", n, worst);
}

/* Cases with a closed form: a film of thickness 0 or of the outside's index
 * leaves the bare base's Fresnel reflectance (the dielectric and conductor
 * Fresnel of kernels/closure/bsdf_microfacet.h); a quarter-wave layer of
 * index sqrt(n_base) reflects nothing at normal incidence at its wavelength
 * (Hecht, Optics, 9.7.1), and a half-wave layer is absent there; at normal
 * incidence over a dielectric the reflectance is Airy's closed form
 * (r01^2 + r12^2 + 2 r01 r12 cos(2 delta)) / (1 + r01^2 r12^2 + 2 r01 r12 cos(2 delta)). */
TEST(test_film_closed_forms)
{
    for (double deg = 0; deg < 89; deg += 11) {
        double th = deg * M_PI / 180;
        float c = (float)cos(th);
        assert_close(kernel_film(th, 550, 1, 1.7, 0, 1.5, 0), bsdf_fresnel_dielectric(c, 1.5f), 2e-6);
        assert_close(kernel_film(th, 550, 1, 1.0, 300, 1.5, 0), bsdf_fresnel_dielectric(c, 1.5f), 2e-6);
        assert_close(kernel_film(th, 550, 1, 1.4, 0, 0.27, 2.78), bsdf_fresnel_conductor(c, 0.27f, 2.78f), 2e-5);
    }
    const double ns = 1.52, nf = sqrt(1.52), lam0 = 550;
    assert_close(kernel_film(0, lam0, 1, nf, lam0 / (4 * nf), ns, 0), 0.0, 1e-6);
    double bare = pow((ns - 1) / (ns + 1), 2);
    assert_close(kernel_film(0, lam0, 1, 2.0, lam0 / (2 * 2.0), ns, 0), bare, 1e-5);
    for (double lam = 380; lam <= 780; lam += 20)
        for (double d = 50; d <= 1000; d += 95) {
            double r01 = (1 - 1.33) / (1 + 1.33), r12 = (1.33 - 1.5) / (1.33 + 1.5);
            double cs = cos(4 * M_PI * 1.33 * d / lam);
            double want = (r01 * r01 + r12 * r12 + 2 * r01 * r12 * cs) / (1 + r01 * r01 * r12 * r12 + 2 * r01 * r12 * cs);
            assert_close(kernel_film(0, lam, 1, 1.33, d, 1.5, 0), want, 2e-6);
        }
}

/* ---- The film in the material ------------------------------------------------ */

/* A material with a film of iridescence, film_ior and film_nm over the base
 * (ior 1.5, at the wavelengths 420, 505, 590 and 675 nm); the rest zero. */
static BsdfParams film_params(float metallic, float roughness, float base, float iridescence, float film_ior,
                              float film_nm)
{
    BsdfParams p = {.base = v4_splat(base),
                    .ior = v4_splat(1.5f),
                    .metallic = metallic,
                    .roughness = roughness,
                    .spec_tint = v4_splat(1.0f),
                    .specular = 1.0f,
                    .lambda = v4(420.0f, 505.0f, 590.0f, 675.0f),
                    .iridescence = iridescence,
                    .film_ior = film_ior,
                    .film_nm = film_nm};
    return p;
}

static float v4_at(vec4 v, int i) { return i == 0 ? v.x : i == 1 ? v.y : i == 2 ? v.z : v.w; }

/* The extension's mix F = mix(F_base, F_film, iridescence) in both Fresnel
 * terms: the dielectric's (its F0 from the ior, the film's reflectance times
 * the specular factor) and the metal's (over the measured conductor's eta + ik
 * where it has one, else over the real index of F0 = base colour); the diffuse
 * lobe takes 1 - F; a coat makes the film's outside index 1.5. */
TEST(test_film_in_fresnel)
{
    const double thetas[3] = {0, 40, 75};
    for (int t = 0; t < 3; t++) {
        double th = thetas[t] * M_PI / 180;
        float c = (float)cos(th);
        BsdfParams p = film_params(0.0f, 0.5f, 1.0f, 1.0f, 1.8f, 310.0f);
        BsdfParams half = p, plain = p;
        half.iridescence = 0.5f;
        plain.iridescence = 0.0f;
        vec4 f = bsdf_dielectric_fresnel(&p, c), fh = bsdf_dielectric_fresnel(&half, c);
        vec4 f0 = bsdf_dielectric_fresnel(&plain, c);
        p.specular = 0.5f;
        vec4 fs = bsdf_dielectric_fresnel(&p, c);
        p.specular = 1.0f;
        p.clearcoat = 0.5f;
        vec4 fc = bsdf_dielectric_fresnel(&p, c);
        p.clearcoat = 0.0f;
        /* The metal over silver, and over the index of F0 = 0.6. */
        BsdfParams ag = film_params(1.0f, 0.5f, 1.0f, 1.0f, 1.45f, 260.0f);
        bsdf_set_conductor(&ag, SPT_CONDUCTOR_AG, ag.lambda.x, ag.lambda.y, ag.lambda.z, ag.lambda.w);
        BsdfParams f06 = film_params(1.0f, 0.5f, 0.6f, 0.7f, 1.45f, 260.0f);
        vec4 fa = bsdf_metal_fresnel(&ag, c), fm = bsdf_metal_fresnel(&f06, c);
        BsdfParams f06plain = f06;
        f06plain.iridescence = 0.0f;
        vec4 fm0 = bsdf_metal_fresnel(&f06plain, c);
        double n06 = (1 + sqrt(0.6)) / (1 - sqrt(0.6));
        for (int i = 0; i < 4; i++) {
            double lam = v4_at(p.lambda, i);
            double film = tmm_reflectance(th, lam, 1, 1.8, 310, 1.5, 0);
            assert_close(v4_at(f, i), film, 2e-5);
            assert_close(v4_at(fh, i), 0.5 * v4_at(f0, i) + 0.5 * film, 2e-5);
            assert_close(v4_at(fs, i), 0.5 * film, 2e-5);
            assert_close(v4_at(fc, i), tmm_reflectance(th, lam, 1.5, 1.8, 310, 1.5, 0), 2e-5);
            double eta = v4_at(ag.eta, i), k = v4_at(ag.k, i);
            assert_close(v4_at(fa, i), tmm_reflectance(th, lam, 1, 1.45, 260, eta, k), 2e-5);
            assert_close(v4_at(fm, i), 0.3 * v4_at(fm0, i) + 0.7 * tmm_reflectance(th, lam, 1, 1.45, 260, n06, 0),
                         3e-5);
            /* The diffuse lobe under the film takes 1 - F. */
            vec4 dfac = bsdf_diffuse_factor(&p, c);
            assert_close(v4_at(dfac, i), 1.0 - film, 2e-5);
        }
    }
}

/* Mean bsdf_sample weight per wavelength (the directional albedo) at wo, n
 * samples, and its standard error. */
static vec4 film_albedo(const BsdfParams *p, vec3 wo, uint32_t n, uint32_t stream, vec4 *err)
{
    double sum[4] = {0}, sum2[4] = {0};
    for (uint32_t i = 0; i < n; i++) {
        uint64_t b = ((uint64_t)stream << 40) + 3u * (uint64_t)i;
        BsdfSample s = bsdf_sample(p, wo, test_uniform(b), test_uniform(b + 1), test_uniform(b + 2));
        for (int k = 0; k < 4; k++) {
            double w = s.valid ? v4_at(s.weight, k) : 0.0;
            sum[k] += w;
            sum2[k] += w * w;
        }
    }
    double m[4], e[4];
    for (int k = 0; k < 4; k++) {
        m[k] = sum[k] / n;
        e[k] = sqrt(fmax(sum2[k] / n - m[k] * m[k], 0.0) / n);
    }
    *err = v4((float)e[0], (float)e[1], (float)e[2], (float)e[3]);
    return v4((float)m[0], (float)m[1], (float)m[2], (float)m[3]);
}

/* White furnaces of film materials, per wavelength, view angle and
 * roughness (within 3 standard errors). A smooth film over a smooth
 * dielectric layer over a white Lambertian base returns exactly 1: the film
 * loses nothing (R + T = 1) and the diffuse lobe takes 1 - F at the view's
 * cosine. A smooth metal under the film reflects exactly the film's
 * reflectance over its base (the matrix method's), <= 1. Metals never exceed
 * 1; rough dielectrics exceed it by at most 0.5% (measured 0.27%: the rough
 * lobe's F at the microfacet's cosine beside the diffuse's 1 - F at the
 * view's). What rough lobes lose is single-scattering GGX's; the table prints
 * each material without the film beside it (whose dielectric exceeds 1 at
 * grazing angles: the base model's 1 - F(wo.h) under a mirror). */
TEST(test_film_furnace)
{
    const float roughs[3] = {0.0f, 0.3f, 0.8f};
    const double thetas[4] = {0, 45, 75, 88};
    uint32_t stream = 4000;
    for (int r = 0; r < 3; r++) {
        print_message("  roughness %.1f, theta 0 / 45 / 75 / 88, mean over 4 wavelengths (without film):\n",
                      roughs[r]);
        BsdfParams cases[3] = {
            film_params(0.0f, roughs[r], 1.0f, 1.0f, 1.8f, 400.0f), /* over a white Lambert base */
            film_params(1.0f, roughs[r], 0.95f, 1.0f, 1.3f, 250.0f), /* over a lossless "metal" of F0 0.95 */
            film_params(1.0f, roughs[r], 1.0f, 1.0f, 1.5f, 300.0f),  /* over gold */
        };
        bsdf_set_conductor(&cases[2], SPT_CONDUCTOR_AU, 420.0f, 505.0f, 590.0f, 675.0f);
        const char *what[3] = {"film, dielectric, white base", "film over F0 0.95 metal", "film over gold"};
        for (int k = 0; k < 3; k++) {
            char line[256];
            int at = snprintf(line, sizeof line, "    %-30s", what[k]);
            for (int t = 0; t < 4; t++) {
                double th = thetas[t] * M_PI / 180;
                vec3 wo = v3((float)sin(th), 0.0f, (float)cos(th));
                vec4 err, a = film_albedo(&cases[k], wo, 20000, stream++, &err);
                BsdfParams bare = cases[k];
                bare.iridescence = 0.0f;
                vec4 err0, a0 = film_albedo(&bare, wo, 20000, stream++, &err0);
                double mean = 0, mean0 = 0;
                for (int i = 0; i < 4; i++) {
                    double ai = v4_at(a, i), ei = v4_at(err, i);
                    mean += ai / 4;
                    mean0 += v4_at(a0, i) / 4;
                    /* The rough lobe's F at the microfacet's cosine beside
                     * the diffuse's 1 - F at the view's: up to 0.3% over. */
                    double allow = k == 0 && roughs[r] > 0.0f ? 0.005 : 0.0;
                    if (ai > 1.0 + allow + 3.0 * ei + 1e-4)
                        fail_msg("%s, roughness %.1f, theta %.0f, wavelength %d: albedo %.5f +- %.5f exceeds 1",
                                 what[k], roughs[r], thetas[t], i, ai, ei);
                    if (roughs[r] == 0.0f && k == 0)
                        assert_close(ai, 1.0, 3.0 * ei + 3e-4);
                    if (roughs[r] == 0.0f && k == 1) {
                        double n = (1 + sqrt(0.95)) / (1 - sqrt(0.95));
                        double want = tmm_reflectance(th, v4_at(cases[k].lambda, i), 1, 1.3, 250, n, 0);
                        assert_close(ai, want, 3e-5);
                        assert_true(want <= 1.0);
                    }
                }
                at += snprintf(line + at, sizeof line - at, " %.4f (%.4f)", mean, mean0);
            }
            print_message("%s\n", line);
        }
    }
}

/* A film on a smooth transmissive dielectric (KHR_materials_transmission 1,
 * ior 1.5, white): from either side, per wavelength, what it reflects is the
 * film's reflectance (from outside: air | film | glass; from inside: glass |
 * film | air, total past the critical angle of 41.8 degrees) by the matrix
 * method, and what it reflects and transmits adds up to 1 (the lossless film,
 * R + T = 1; the refracted weight's 1 / eta'^2 radiance scaling undone). The
 * interface's two events, each weight times its chance (the sample's pdf). */
TEST(test_film_on_transmission)
{
    const double thetas[6] = {0, 30, 41, 42, 60, 85};
    for (int side = 0; side < 2; side++)
        for (int t = 0; t < 6; t++) {
            BsdfParams p = film_params(0.0f, 0.0f, 1.0f, 1.0f, 1.33f, 380.0f);
            p.transmission = 1.0f;
            double th = thetas[t] * M_PI / 180;
            vec3 wo = v3((float)sin(th), 0.0f, (float)(side ? -cos(th) : cos(th)));
            /* u0 below every chance reflects; just under 1 refracts. */
            BsdfSample r = bsdf_sample(&p, wo, 0.0f, 0.5f, 0.5f);
            BsdfSample tr = bsdf_sample(&p, wo, 0.99999f, 0.5f, 0.5f);
            assert_true(r.valid && r.wi.z * wo.z > 0.0f);
            int refracts = tr.valid && tr.wi.z * wo.z < 0.0f;
            double q = r.pdf, e2 = side ? 1.0 / (1.5 * 1.5) : 1.5 * 1.5;
            for (int k = 0; k < 4; k++) {
                double lam = v4_at(p.lambda, k);
                double want = side ? tmm_reflectance(th, lam, 1.5, 1.33, 380, 1.0, 0)
                                   : tmm_reflectance(th, lam, 1.0, 1.33, 380, 1.5, 0);
                double R = v4_at(r.weight, k) * q;
                double T = refracts ? v4_at(tr.weight, k) * tr.pdf * e2 : 0.0;
                assert_close(R, want, 2e-5);
                assert_close(R + T, 1.0, 2e-5);
            }
        }
}

/* ---- A rendered film -------------------------------------------------------- */

#define FILM_SIZE 12

/* A 2 x 2 m square in the z = 0 plane facing +z, material m, seen from 4 m
 * away along the direction theta degrees from its normal (in the xz plane),
 * with a field of view of 0.02 rad: every ray meets it within 0.6 degrees of
 * theta. Two triangles, normals from the winding. */
static void film_square_scene(Scene *s, const SceneMaterial *m, double theta_deg)
{
    memset(s, 0, sizeof *s);
    static const float quad[18] = {-1, -1, 0, 1, -1, 0, 1, 1, 0, -1, -1, 0, 1, 1, 0, -1, 1, 0};
    s->tri_count = 2;
    s->vertex_count = 6;
    s->tri_pos = malloc(sizeof quad);
    memcpy(s->tri_pos, quad, sizeof quad);
    s->tri_vidx = malloc(6 * sizeof(uint32_t));
    for (uint32_t i = 0; i < 6; i++)
        s->tri_vidx[i] = i;
    s->tri_mat = calloc(2, sizeof(uint32_t));
    s->vtx_normal = calloc(18, sizeof(float));
    s->vtx_uv = calloc(12, sizeof(float));
    s->material_count = 1;
    s->materials = calloc(1, sizeof(SceneMaterial));
    s->materials[0] = *m;
    double t = theta_deg * M_PI / 180;
    s->camera.position[0] = (float)(4 * sin(t));
    s->camera.position[2] = (float)(4 * cos(t));
    s->camera.forward[0] = (float)-sin(t);
    s->camera.forward[2] = (float)-cos(t);
    s->camera.up[1] = 1.0f;
    /* right = forward x up */
    s->camera.right[0] = (float)cos(t);
    s->camera.right[2] = (float)-sin(t);
    s->camera.yfov = 0.02f;
    s->camera.aspect = 1.0f;
    scene_update_bounds(s);
}

/* The linear sRGB of reflectance R(lambda) under D65 (the default sky's
 * radiance, Y = 1): XYZ = sum R D65 cmf / sum D65 ybar over the CIE tables'
 * 1 nm samples. */
static void film_expected_rgb(double theta_deg, double n0, double nf, double d, int conductor, double nb,
                              double rgb[3])
{
    double xyz[3] = {0, 0, 0}, norm = 0;
    for (int i = 0; i < SPT_CIE_SAMPLES; i++) {
        double lam = SPT_CIE_LAMBDA_MIN + i;
        double eta = nb, k = 0;
        if (conductor >= 0) {
            eta = spt_conductor_lookup(conductor, 0, (float)lam);
            k = spt_conductor_lookup(conductor, 1, (float)lam);
        }
        double R = tmm_reflectance(theta_deg * M_PI / 180, lam, n0, nf, d, eta, k);
        double e = SPT_D65_NORM[i];
        xyz[0] += R * e * SPT_CIE_X[i];
        xyz[1] += R * e * SPT_CIE_Y[i];
        xyz[2] += R * e * SPT_CIE_Z[i];
        norm += e * SPT_CIE_Y[i];
    }
    for (int c = 0; c < 3; c++)
        xyz[c] /= norm;
    xyz_to_linear_srgb(xyz, rgb);
}

/* The image's mean linear sRGB. */
static void film_render_mean(const SceneMaterial *m, double theta_deg, int spp, double rgb[3])
{
    Scene s;
    film_square_scene(&s, m, theta_deg);
    Film f;
    RenderStats st;
    assert_int_equal(render_scene(&s, FILM_SIZE, FILM_SIZE, spp, -1, 7, NULL, &f, &st), 0);
    assert_int_equal(st.nan_dropped, 0);
    float *px = malloc((size_t)FILM_SIZE * FILM_SIZE * 3 * sizeof(float));
    film_to_linear_srgb(&f, px);
    for (int c = 0; c < 3; c++) {
        rgb[c] = 0;
        for (int i = 0; i < FILM_SIZE * FILM_SIZE; i++)
            rgb[c] += px[3 * i + c] / (FILM_SIZE * FILM_SIZE);
    }
    free(px);
    film_free(&f);
    scene_free(&s);
}

/* Smooth films under the default sky (uniform D65 of Y = 1), seen at 0 and 60
 * degrees: a film of index 1.8 (and 2.3), 320 (and 540) nm, over a black
 * dielectric base of ior 1.5 (only the specular layer reflects), and a film of
 * index 1.45, 250 nm over measured silver. The mirror shows the sky times the
 * film's reflectance, so the image's colour is that of R(lambda) under D65:
 * within 0.004 + 2% per channel of the matrix method's, 1024 samples a pixel. */
TEST(test_film_colour_rendered)
{
    const struct {
        const char *what;
        double nf, d;
        int conductor; /* -1: the dielectric */
        double theta;
    } cases[] = {
        {"film 1.8, 320 nm over black glass, 0 deg", 1.8, 320, -1, 0},
        {"film 1.8, 320 nm over black glass, 60 deg", 1.8, 320, -1, 60},
        {"film 2.3, 540 nm over black glass, 0 deg", 2.3, 540, -1, 0},
        {"film 1.45, 250 nm over silver, 0 deg", 1.45, 250, SPT_CONDUCTOR_AG, 0},
        {"film 1.45, 250 nm over silver, 60 deg", 1.45, 250, SPT_CONDUCTOR_AG, 60},
    };
    int spp = test_quick() ? 256 : 1024;
    for (size_t k = 0; k < sizeof cases / sizeof *cases; k++) {
        SceneMaterial m;
        scene_material_default(&m);
        m.roughness = 0.0f;
        if (cases[k].conductor >= 0) {
            m.metallic = 1.0f;
            snprintf(m.conductor, sizeof m.conductor, "Ag");
        } else {
            m.metallic = 0.0f;
            for (int c = 0; c < 3; c++)
                m.base_color[c] = 0.0f;
        }
        m.iridescence = 1.0f;
        m.iridescence_ior = (float)cases[k].nf;
        m.iridescence_max_nm = (float)cases[k].d;
        double got[3], want[3], bare[3];
        film_render_mean(&m, cases[k].theta, spp, got);
        film_expected_rgb(cases[k].theta, 1.0, cases[k].nf, cases[k].d, cases[k].conductor, 1.5, want);
        /* Without the film, the bare base: the colour must differ. */
        film_expected_rgb(cases[k].theta, 1.0, 1.0, 0.0, cases[k].conductor, 1.5, bare);
        print_message("  %-44s rendered (%.4f %.4f %.4f), computed (%.4f %.4f %.4f), bare (%.4f %.4f %.4f)\n",
                      cases[k].what, got[0], got[1], got[2], want[0], want[1], want[2], bare[0], bare[1], bare[2]);
        for (int c = 0; c < 3; c++)
            if (fabs(got[c] - want[c]) > 0.004 + 0.02 * fabs(want[c]))
                fail_msg("%s: channel %d rendered %.5f, computed %.5f", cases[k].what, c, got[c], want[c]);
    }
}

/* The two textures: a 1 x 1 texture of R 0.6, G 0.25 as both iridescenceTexture
 * and iridescenceThicknessTexture of a film of index 1.8 between 200 and 600
 * nm over black glass, seen at normal incidence: the film is 0.6 of the
 * Fresnel term (the rest Schlick's, 0.04 there) and 200 + 0.25 x 400 = 300 nm
 * thick. */
TEST(test_film_textures_rendered)
{
    SceneMaterial m;
    scene_material_default(&m);
    m.roughness = 0.0f;
    m.metallic = 0.0f;
    for (int c = 0; c < 3; c++)
        m.base_color[c] = 0.0f;
    m.iridescence = 1.0f;
    m.iridescence_ior = 1.8f;
    m.iridescence_min_nm = 200.0f;
    m.iridescence_max_nm = 600.0f;
    m.tex[SPT_SLOT_IRIDESCENCE].tex = 0;
    m.tex[SPT_SLOT_IRIDESCENCE_THICKNESS].tex = 0;
    Scene s;
    film_square_scene(&s, &m, 0.0);
    s.texture_count = 1;
    s.textures = calloc(1, sizeof(SceneTexture));
    s.textures[0].width = s.textures[0].height = 1;
    s.textures[0].channels = 4;
    s.textures[0].wrap_s = s.textures[0].wrap_t = SPT_WRAP_REPEAT;
    s.textures[0].texels = malloc(4 * sizeof(float));
    const float texel[4] = {0.6f, 0.25f, 0.9f, 1.0f};
    memcpy(s.textures[0].texels, texel, sizeof texel);
    Film f;
    RenderStats st;
    assert_int_equal(render_scene(&s, FILM_SIZE, FILM_SIZE, test_quick() ? 256 : 1024, -1, 7, NULL, &f, &st), 0);
    float *px = malloc((size_t)FILM_SIZE * FILM_SIZE * 3 * sizeof(float));
    film_to_linear_srgb(&f, px);
    double got[3] = {0, 0, 0}, film[3], want[3];
    for (int c = 0; c < 3; c++)
        for (int i = 0; i < FILM_SIZE * FILM_SIZE; i++)
            got[c] += px[3 * i + c] / (FILM_SIZE * FILM_SIZE);
    film_expected_rgb(0.0, 1.0, 1.8, 300.0, -1, 1.5, film);
    /* Colour is linear in the reflectance: 0.4 x 0.04 (grey) + 0.6 x film. */
    for (int c = 0; c < 3; c++)
        want[c] = 0.4 * 0.04 + 0.6 * film[c];
    print_message("  textured film: rendered (%.4f %.4f %.4f), computed (%.4f %.4f %.4f)\n", got[0], got[1], got[2],
                  want[0], want[1], want[2]);
    for (int c = 0; c < 3; c++)
        if (fabs(got[c] - want[c]) > 0.004 + 0.02 * fabs(want[c]))
            fail_msg("textured film: channel %d rendered %.5f, computed %.5f", c, got[c], want[c]);
    free(px);
    film_free(&f);
    scene_free(&s);
}

/* `spectrace color --film IOR,NM[,DEGREES] BASE` prints the film's colour under
 * D65: its linear sRGB within 1e-4 of the matrix method's (the six decimals
 * printed, and D65 from the colour library's table rather than the kernels');
 * a bad film or base is a usage error (exit code 2). */
TEST(test_color_film_command)
{
    static const struct {
        const char *args;
        double nf, d, theta;
        int conductor;
    } cases[] = {
        {"color --film 1.8,320 1.5", 1.8, 320, 0, -1},
        {"color --film 2.3,540,60 1.5", 2.3, 540, 60, -1},
        {"color --film 1.45,250,30 ag", 1.45, 250, 30, SPT_CONDUCTOR_AG},
    };
    char out[1024];
    for (size_t k = 0; k < sizeof cases / sizeof *cases; k++) {
        assert_int_equal(test_spectrace("", 60, cases[k].args, TEST_STDOUT, out, sizeof out), 0);
        const char *line = strstr(out, "linear-sRGB ");
        double got[3], want[3];
        assert_non_null(line);
        assert_int_equal(sscanf(line, "linear-sRGB %lf %lf %lf", &got[0], &got[1], &got[2]), 3);
        film_expected_rgb(cases[k].theta, 1.0, cases[k].nf, cases[k].d, cases[k].conductor, 1.5, want);
        for (int c = 0; c < 3; c++)
            assert_close(got[c], want[c], 1e-4);
    }
    static const char *const bad[] = {"color --film 0.5,100 1.5", "color --film 1.5,-1 1.5",
                                      "color --film 1.5,100,90 1.5", "color --film 1.5 1.5",
                                      "color --film 1.5,100 Xx", "color --film 1.5,100 0.9",
                                      "color --film 1.5,100 --reflectance D65"};
    for (size_t k = 0; k < sizeof bad / sizeof *bad; k++)
        assert_int_equal(test_spectrace("", 60, bad[k], TEST_BOTH, out, sizeof out), 2);
}

TEST_MAIN("iridescence", setup_cpu_device, teardown_cpu_device)
