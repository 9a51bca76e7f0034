/* Prisms of dispersive glass (KHR_materials_dispersion) under a narrow spot
 * light, with the light-tracing pass (kernels/integrator/light_trace.h): where each
 * wavelength lands on the floor against Snell's law with the extension's Abbe
 * law, in white light (the band's centroids) and in a mercury lamp's light
 * (the line spectrum). */
#include "test_util.h"
#include "test_render_util.h"

#define FLOOR_ALBEDO 0.5

/* A prism of dispersive glass (KHR_materials_dispersion 2, n_d
 * 1.5; 2 is an Abbe number of 10) in a narrow white spot beam pointing down: the beam enters the prism's
 * horizontal top at normal incidence and leaves through its bottom face, tilted
 * by PRISM_ALPHA, bent by Snell's law with n(lambda) of the extension's Abbe
 * law, so each wavelength lands elsewhere on the floor: blue (higher index)
 * further from the axis than red. The flux-weighted centroid of each of the
 * floor's X, Y and Z (seen by a camera looking straight down, where every
 * pixel covers the same floor area) is predicted by the central ray of each
 * wavelength, weighted by the light's D65, the two interfaces' Fresnel
 * transmittance and the colour matching function. */
#define PRISM_ALPHA 0.5
#define PRISM_TOP 1.2
#define PRISM_DISPERSION 2.0

/* The prism: its cross-section in x-y is the triangle (-0.5, top), (0.5, top),
 * (0.5, top - tan(alpha)), extruded over z in [-0.5, 0.5]. */
static void append_prism(Scene *s)
{
    const float lo[3] = {-0.5f, (float)PRISM_TOP - 0.5f, -0.5f}, hi[3] = {0.5f, (float)PRISM_TOP, 0.5f};
    SceneMaterial *m = append_box(s, lo, hi);
    /* Bend the box into the prism: its bottom vertices onto the tilted plane
     * y = top - (x + 0.5) tan(alpha). */
    uint32_t t0 = s->tri_count - 12;
    for (uint32_t k = 0; k < 36; k++) {
        float *v = s->tri_pos + 9 * t0 + 3 * k;
        if (v[1] < (float)PRISM_TOP - 0.25f)
            v[1] = (float)(PRISM_TOP - (v[0] + 0.5) * tan(PRISM_ALPHA));
    }
    set_clear_glass(m, 1.5f);
    m->dispersion = (float)PRISM_DISPERSION;
}

/* The floor (albedo FLOOR_ALBEDO, 4 x 4 m), the prism, and one white spot light
 * at (0, y, 0) pointing down with the intensity and cone angles given: returns
 * the light. */
static SceneLight *prism_beam_scene(Scene *s, float y, float intensity, float inner, float outer)
{
    memset(s, 0, sizeof *s);
    const float floor_c[4][3] = {{-2, 0, -2}, {-2, 0, 2}, {2, 0, 2}, {2, 0, -2}};
    SceneMaterial *fl = append_rect(s, floor_c);
    for (int k = 0; k < 3; k++)
        fl->base_color[k] = FLOOR_ALBEDO;
    append_prism(s);
    s->light_count = 1;
    s->lights = calloc(1, sizeof(SceneLight));
    SceneLight *l = &s->lights[0];
    l->type = SPT_LIGHT_SPOT;
    l->position[1] = y;
    l->direction[1] = -1.0f;
    l->intensity = intensity;
    l->inner_cone = inner;
    l->outer_cone = outer;
    for (int k = 0; k < 3; k++)
        l->color[k] = 1.0f;
    return l;
}

/* Where the central ray of wavelength l lands on the floor (x), and the
 * fraction of its flux the two interfaces let through. */
static double prism_landing(double l, double *transmit)
{
    double n = 1.5 + 0.5 * (PRISM_DISPERSION / 20.0) * (523655.0 / (l * l) - 1.5168);
    double a = PRISM_ALPHA, yh = PRISM_TOP - 0.5 * tan(a);
    /* Inside, d = (0, -1), straight down; the bottom face's normal on the
     * inside N = (sin a, cos a): incidence a, and Snell's law from index n
     * into air, t = n d + (n cos_i - cos_t) N. */
    double ci = cos(a), eta = n, st2 = eta * eta * (1.0 - ci * ci);
    double ct = sqrt(1.0 - st2);
    double tx = (eta * ci - ct) * sin(a), ty = -eta + (eta * ci - ct) * cos(a);
    /* Fresnel out of the glass at incidence a equals that into it at the
     * refraction angle (reciprocity). */
    *transmit = (1.0 - fresnel(1.0, n)) * (1.0 - fresnel(ct, n));
    return yh * tx / -ty;
}

TEST(test_prism_dispersion)
{
    skip_if_quick();
    /* The predicted centroids. */
    double want[3], wsum[3] = {0}, wx[3] = {0};
    for (int i = 0; i < SPT_CIE_SAMPLES; i++) {
        double l = SPT_CIE_LAMBDA_MIN + i, T, x = prism_landing(l, &T);
        double cmf[3] = {SPT_CIE_X[i], SPT_CIE_Y[i], SPT_CIE_Z[i]};
        for (int c = 0; c < 3; c++) {
            double w = SPT_D65_NORM[i] * T * cmf[c];
            wsum[c] += w;
            wx[c] += w * x;
        }
    }
    for (int c = 0; c < 3; c++)
        want[c] = wx[c] / wsum[c];
    Scene s;
    prism_beam_scene(&s, 3.0f, 1000.0f, 0.006f, 0.01f);
    /* Looking straight down from 0.5 m at the beam's landing (the prism's
     * lowest point is 0.65 m high), +x to the right. */
    double x0 = want[1];
    camera_down(&s, (float)x0, 0.5f, 0.4f, 1.0f);
    scene_update_bounds(&s);
    RenderSettings rs = square_settings(64, 64, 4, 7);
    rs.caustics = SPT_SWITCH_ON;
    Film f;
    render_film_ok(&s, &rs, &f);
    double half = 0.5 * tan(0.5 * s.camera.yfov); /* the view's half-width on the floor */
    double got[3], sum[3] = {0}, sx[3] = {0}, edge = 0, total = 0;
    for (int py = 0; py < 64; py++)
        for (int px = 0; px < 64; px++) {
            size_t i = (size_t)py * 64 + px;
            double x = x0 + (2.0 * (px + 0.5) / 64 - 1.0) * half;
            for (int c = 0; c < 3; c++) {
                double v = f.xyz[3 * i + c] / f.count[i];
                sum[c] += v;
                sx[c] += v * x;
                total += v;
                if (px < 2 || px > 61 || py < 2 || py > 61)
                    edge += v;
            }
        }
    for (int c = 0; c < 3; c++)
        got[c] = sx[c] / sum[c];
    printf("prism: centroids X %.5f Y %.5f Z %.5f m, predicted %.5f %.5f %.5f; Z - X %.2f mm "
           "(predicted %.2f); flux at the view's edge %.2g of the total\n",
           got[0], got[1], got[2], want[0], want[1], want[2], 1e3 * (got[2] - got[0]),
           1e3 * (want[2] - want[0]), edge / total);
    /* The beam lies inside the view; blue is bent further (to +x) than red. */
    assert_true(edge < 1e-3 * total);
    assert_true(want[2] > want[0] + 5e-3);
    for (int c = 0; c < 3; c++)
        assert_true(fabs(got[c] - want[c]) < 0.02 * fabs(want[2] - want[0]));
    film_free(&f);
    scene_free(&s);
}

/* The same prism in a mercury lamp's beam (extras.spectrace.emission
 * "mercury": the lines of the NIST Handbook of Basic Atomic Spectroscopic
 * Data, "Strong lines of mercury (Hg I)", at 404.656, 407.783, 435.833,
 * 546.074, 576.960 and 579.066 nm, relative intensities 1800, 150, 4000, 1100,
 * 240, 280). The floor shows a line spectrum: one spot per line, where Snell's
 * law with the extension's Abbe law puts that wavelength (prism_landing). To
 * resolve the lines the beam must be narrower than their spacing on the floor
 * (about 0.55 mm per nm at 405 nm, 0.21 at 560 nm): the spot sits 5 cm over
 * the prism with an outer cone of 5e-4 rad, so the whole beam is at most
 * about 2 x 5e-4 x 1.7 m (air, glass and air, with the exit face's angular
 * magnification) = 1.7 mm wide on the floor, and each line (carried about
 * 1 nm wide, docs/gltf.md) that plus its own spread. A camera 0.5 m over
 * the floor sees 100 mm across in HG_W pixels (0.78 mm each) and 12.5 mm along
 * z. The image's X + Y + Z summed over the rows gives a profile along x whose
 * local maxima must be the predicted lines:
 * - each line, or group of lines closer than the beam (404.7 with the weak
 *   407.8, 2.4 pixels apart, which shows as a shoulder; the 577/579 doublet,
 *   0.5 pixels apart), has a maximum within one pixel of its predicted span,
 *   and every maximum above 2% of the largest lies within 1.5 pixels of a line;
 * - each single line's spot has the line's chromaticity (the CIE 1931
 *   spectral locus at its wavelength, interpolated in the 1 nm table);
 * - the groups' fluxes relative to 435.8 nm's are those of the NIST
 *   intensities times the two interfaces' Fresnel transmittance times
 *   xbar + ybar + zbar at each line, within 15% (Monte Carlo noise: a line is
 *   2 nm of the spectrum; the 404.7 nm group's ratio came out 2-10% high over
 *   six seeds at these 512 samples, within 1.5% over two at 4096). */
#define HG_W 128
#define HG_H 16
#define HG_SPP 512

/* The CIE 1931 colour matching functions at nm, interpolated. */
static void cmf_at(double nm, double cmf[3])
{
    double x = nm - SPT_CIE_LAMBDA_MIN;
    int i = (int)x;
    double fr = x - i;
    cmf[0] = (1 - fr) * SPT_CIE_X[i] + fr * SPT_CIE_X[i + 1];
    cmf[1] = (1 - fr) * SPT_CIE_Y[i] + fr * SPT_CIE_Y[i + 1];
    cmf[2] = (1 - fr) * SPT_CIE_Z[i] + fr * SPT_CIE_Z[i + 1];
}

TEST(test_prism_mercury_lines)
{
    skip_if_quick();
    static const double hg_nm[6] = {404.656, 407.783, 435.833, 546.074, 576.960, 579.066};
    static const double hg_rel[6] = {1800, 150, 4000, 1100, 240, 280};
    /* Groups of lines (first, last): 404.7 + 407.8, 435.8, 546.1, 577.0 + 579.1;
     * a group's maximum is the span of its lines but 407.8's (a shoulder). */
    static const int group[4][2] = {{0, 1}, {2, 2}, {3, 3}, {4, 5}};
    static const int at_max[4][2] = {{0, 0}, {2, 2}, {3, 3}, {4, 5}};
    double hg_x[6], hg_t[6];
    for (int j = 0; j < 6; j++)
        hg_x[j] = prism_landing(hg_nm[j], &hg_t[j]);
    Scene s;
    SceneLight *l = prism_beam_scene(&s, (float)PRISM_TOP + 0.05f, 200.0f, 0.0f, 5e-4f);
    SptError e = {0};
    assert_int_equal(spd_named(&l->spd, "mercury", &e), 0);
    double xc = 0.5 * (hg_x[0] + hg_x[5]), h = 0.5, half_w = 0.05;
    const float aspect = (float)HG_W / HG_H;
    camera_down(&s, (float)xc, (float)h, (float)(2.0 * atan(half_w / h / aspect)), aspect);
    scene_update_bounds(&s);
    RenderSettings rs = square_settings(HG_W, HG_SPP, 4, 11);
    rs.height = HG_H;
    rs.caustics = SPT_SWITCH_ON;
    Film f;
    render_caustic_scene(&s, &rs, &f);
    /* Columns: per-column XYZ summed over the rows, and the profile X + Y + Z. */
    double col[HG_W][3] = {{0}}, prof[HG_W] = {0}, top = 0;
    for (int px = 0; px < HG_W; px++) {
        for (int py = 0; py < HG_H; py++) {
            size_t i = (size_t)py * HG_W + px;
            for (int c = 0; c < 3; c++)
                col[px][c] += f.xyz[3 * i + c] / f.count[i];
        }
        prof[px] = col[px][0] + col[px][1] + col[px][2];
        top = fmax(top, prof[px]);
    }
    film_free(&f);
    scene_free(&s);
    /* Predicted pixel columns (continuous: 0 at the image's left edge). */
    double pred[6], px_per_m = HG_W / (2.0 * half_w);
    for (int j = 0; j < 6; j++)
        pred[j] = (hg_x[j] - (xc - half_w)) * px_per_m;
    /* Local maxima above 2% of the largest, each refined to the centroid of
     * its three pixels. */
    double peak[HG_W];
    int np = 0;
    for (int px = 1; px < HG_W - 1; px++)
        if (prof[px] > 0.02 * top && prof[px] >= prof[px - 1] && prof[px] > prof[px + 1]) {
            double a = prof[px - 1], b = prof[px], c = prof[px + 1];
            peak[np++] = px + 0.5 + (c - a) / (a + b + c);
        }
    printf("mercury lines through the prism: maxima at");
    for (int k = 0; k < np; k++)
        printf(" %.2f", peak[k]);
    printf(" px; predicted");
    for (int j = 0; j < 6; j++)
        printf(" %.3f nm %.2f px (x %.4f m)%s", hg_nm[j], pred[j], hg_x[j], j < 5 ? "," : "\n");
    for (int k = 0; k < np; k++) {
        double near = 1e9;
        for (int j = 0; j < 6; j++)
            near = fmin(near, fabs(peak[k] - pred[j]));
        if (near > 1.5)
            fail_msg("a maximum at %.2f px is %.2f px from every line", peak[k], near);
    }
    double want_flux[4] = {0}, got_flux[4] = {0}, got_xyz[4][3] = {{0}};
    for (int gi = 0; gi < 4; gi++) {
        double lo = fmin(pred[at_max[gi][0]], pred[at_max[gi][1]]);
        double hi = fmax(pred[at_max[gi][0]], pred[at_max[gi][1]]), off = 1e9;
        for (int k = 0; k < np; k++)
            off = fmin(off, peak[k] < lo ? lo - peak[k] : peak[k] > hi ? peak[k] - hi : 0.0);
        for (int j = group[gi][0]; j <= group[gi][1]; j++) {
            double cmf[3];
            cmf_at(hg_nm[j], cmf);
            want_flux[gi] += hg_rel[j] * hg_t[j] * (cmf[0] + cmf[1] + cmf[2]);
        }
        printf("  %.3f-%.3f nm: nearest maximum %.2f px outside the predicted %.2f-%.2f px\n",
               hg_nm[at_max[gi][0]], hg_nm[at_max[gi][1]], off, lo, hi);
        assert_true(off <= 1.0);
        /* The flux window: the whole group's span and 4 pixels either side. */
        lo = fmin(pred[group[gi][0]], pred[group[gi][1]]);
        hi = fmax(pred[group[gi][0]], pred[group[gi][1]]);
        for (int px = (int)floor(lo) - 4; px <= (int)floor(hi) + 4; px++)
            for (int c = 0; c < 3; c++)
                got_xyz[gi][c] += col[px][c];
        got_flux[gi] = got_xyz[gi][0] + got_xyz[gi][1] + got_xyz[gi][2];
    }
    for (int gi = 0; gi < 4; gi++) {
        double r = got_flux[gi] / got_flux[1], want = want_flux[gi] / want_flux[1];
        double sum = got_flux[gi], cx = got_xyz[gi][0] / sum, cy = got_xyz[gi][1] / sum;
        printf("  %.3f-%.3f nm: flux %.4f of 435.833 nm's (NIST %.4f), chromaticity %.4f %.4f",
               hg_nm[group[gi][0]], hg_nm[group[gi][1]], r, want, cx, cy);
        if (group[gi][0] == group[gi][1]) {
            double cmf[3];
            cmf_at(hg_nm[group[gi][0]], cmf);
            double cs = cmf[0] + cmf[1] + cmf[2];
            printf(" (spectral locus %.4f %.4f)", cmf[0] / cs, cmf[1] / cs);
            assert_close(cx, cmf[0] / cs, 0.003);
            assert_close(cy, cmf[1] / cs, 0.003);
        }
        printf("\n");
        assert_close_rel(r, want, 0.15);
    }
}

TEST_MAIN("tests", setup_cpu_device, teardown_cpu_device)
