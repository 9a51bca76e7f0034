/* Hostile spectral input, run as a user would ($SPECTRACE_EXE, set by
 * tests/run_tests.sh; every command under `timeout`): extreme
 * KHR_materials_dispersion, dim blackbody skies, SPD files of one sample or no
 * luminance, and `color --pixel` on spectral outputs. Each input either renders
 * the image its physics predicts (a white furnace, a sky of luminance 1) or is
 * refused with one `error:` line and the exit code of README.md, "Exit codes".
 * The renders run kernels: tiny images, few samples. */
#include "test_util.h"

#include <sys/wait.h>
#include <unistd.h>

#include "color/spd.h"
#include "closure/bsdf.h"
#include "io/exr.h"
#include "spectrum/cie_data.h"

#define TINY "-q --device 0"


/* Runs `$SPECTRACE_EXE args` under a time limit; its stderr into err, its stdout
 * into out (either may be NULL); returns the exit status (-1: killed). */
static int run(const char *args, char *out, size_t out_cap, char *err, size_t err_cap)
{
    char cmd[8192];
    snprintf(cmd, sizeof cmd, "%s 2>'%s'", args, test_path("stderr"));
    int rc = test_spectrace("", 120, cmd, TEST_STDOUT, out, out_cap);
    if (err) {
        FILE *f = fopen(test_path("stderr"), "r");
        size_t n = f ? fread(err, 1, err_cap - 1, f) : 0;
        err[n] = 0;
        if (f)
            fclose(f);
    }
    return rc;
}

/* The run exits with code and prints one line, "error: ..." containing each of
 * the strings in want (NULL-terminated). */
static void refused(const char *args, int code, const char *const *want)
{
    char err[8192];
    int rc = run(args, NULL, 0, err, sizeof err);
    if (rc != code)
        fail_msg("`%s`: exit %d, expected %d; stderr:\n%s", args, rc, code, err);
    const char *nl = strchr(err, '\n');
    if (strncmp(err, "error: ", 7) != 0 || !nl || nl[1] != 0)
        fail_msg("`%s`: expected one error line, got:\n%s", args, err);
    for (; want && *want; want++)
        if (!strstr(err, *want))
            fail_msg("`%s`: expected '%s' in: %s", args, *want, err);
}

/* Whether the program printed a warning (a line "warning: ..."; an OpenCL
 * compiler's own output during a cold kernel build is not the program's). */
static int warned(const char *err)
{
    for (const char *p = err; p; p = strchr(p, '\n'), p = p ? p + 1 : NULL)
        if (!strncmp(p, "warning: ", 9))
            return 1;
    return 0;
}

/* Runs the spectrace command cmd (exit 0 required, stderr into err), then reads
 * the R, G and B layers of the EXR exr it wrote into l (c: their pixels). */
static void run_read_rgb(const char *cmd, const char *exr, ExrLayers *l, const float *c[3],
                         char *err, size_t err_cap)
{
    int rc = run(cmd, NULL, 0, err, err_cap);
    if (rc)
        fail_msg("`%s`: exit %d: %s", cmd, rc, err);
    SptError e = {0};
    static const char *const rgb[3] = {"R", "G", "B"};
    if (exr_read_layers(exr, rgb, 3, l, &e))
        fail_msg("%s", e.msg);
    for (int k = 0; k < 3; k++)
        c[k] = exr_layers_channel(l, rgb[k])->data;
}

/* Renders args to an EXR in the test folder (exit 0 required, stderr into err)
 * and returns the mean luminance of its linear sRGB pixels (Y of
 * docs/architecture.md's matrix) and, in *nonfinite, how many pixels are not
 * finite. */
static double render_mean_y(const char *args, int *nonfinite, char *err, size_t err_cap)
{
    char cmd[4096];
    snprintf(cmd, sizeof cmd, "render %s " TINY " -o %s", args, test_path("out.exr"));
    ExrLayers l;
    const float *c[3];
    run_read_rgb(cmd, test_path("out.exr"), &l, c, err, err_cap);
    double sum = 0.0;
    int bad = 0, n = l.width * l.height;
    for (int i = 0; i < n; i++) {
        double y = 0.2126 * c[0][i] + 0.7152 * c[1][i] + 0.0722 * c[2][i];
        if (isfinite(y))
            sum += y;
        else
            bad++;
    }
    exr_layers_free(&l);
    *nonfinite = bad;
    return sum / n;
}

/* ---- Case 2: KHR_materials_dispersion of any value ------------------------------ */

/* tests/data/scenes/mat_furnace_roughglass.gltf (a glass sphere filling most
 * of the view, no lights: the default white sky of radiance 1) with the given
 * roughness, dispersion and ior (the file's is 1.5), written to path. */
static void furnace_glass_ior(const char *path, const char *roughness, double dispersion, const char *ior)
{
    FILE *f = fopen("tests/data/scenes/mat_furnace_roughglass.gltf", "r");
    assert_non_null(f);
    static char text[1 << 18], out[1 << 18];
    size_t n = fread(text, 1, sizeof text - 1, f);
    text[n] = 0;
    fclose(f);
    char disp[128], rough[64];
    snprintf(disp, sizeof disp, "\"KHR_materials_dispersion\": {\"dispersion\": %.17g}, ", dispersion);
    snprintf(rough, sizeof rough, "\"roughnessFactor\": %s", roughness);
    char ior_text[64];
    snprintf(ior_text, sizeof ior_text, "\"ior\": %s", ior);
    /* Each edit: a marker in the file and what replaces or precedes it. */
    const char *mark[4] = {"\"roughnessFactor\": 0.5", "\"KHR_materials_ior\": {", "\"KHR_materials_ior\",\n",
                           "\"ior\": 1.5"};
    const char *ins[4] = {rough, disp, "\"KHR_materials_dispersion\", ", ior_text};
    const int replace[4] = {1, 0, 0, 1};
    char *src = text;
    for (int k = 0; k < 4; k++) {
        char *p = strstr(src, mark[k]);
        if (!p)
            fail_msg("mat_furnace_roughglass.gltf lacks %s", mark[k]);
        size_t off = (size_t)(p - src);
        snprintf(out, sizeof out, "%.*s%s%s", (int)off, src, ins[k], replace[k] ? p + strlen(mark[k]) : p);
        memcpy(text, out, strlen(out) + 1);
        src = text;
    }
    test_write_text(path, text);
}

static void furnace_glass(const char *path, const char *roughness, double dispersion)
{
    furnace_glass_ior(path, roughness, dispersion, "1.5");
}

/* A non-absorbing dielectric (base colour white, transmission 1) in a white
 * furnace creates no light: every pixel's expected value is at most the sky's,
 * Y = 1, whatever its index at each wavelength, and exactly 1 for smooth glass.
 * The dispersion law of KHR_materials_dispersion gives indices below 1 and
 * negative ones from about dispersion 200 on (ior 1.5, at 830 nm); docs/gltf.md,
 * KHR_materials_dispersion, says what the renderer does there. Smooth glass must
 * give 1 within 6% (the image mean's noise at 16 x 16 pixels, 128 samples, is
 * about 1%; the sphere's interpolated normals kill a few grazing paths, 1-3%
 * with strong dispersion); rough glass between 0.6 and 1 (single-scattering GGX
 * loses energy: 0.88 at ior 1.5 without dispersion, as
 * tests/data/mitsuba/mat_furnace_roughglass_means.json has it). */
TEST(test_dispersion_furnace)
{
    const double disp[] = {0, 1, 20, 150, 200, 300, 1000, 1e5, 1e6};
    const char *rough[] = {"0.0", "0.5"};
    char err[8192], args[1024];
    int failed = 0;
    for (int r = 0; r < 2; r++)
        for (size_t i = 0; i < sizeof disp / sizeof disp[0]; i++) {
            furnace_glass(test_path("glass.gltf"), rough[r], disp[i]);
            snprintf(args, sizeof args, "%s --width 16 --spp 128", test_path("glass.gltf"));
            int bad;
            double y = render_mean_y(args, &bad, err, sizeof err);
            print_message("  roughness %s dispersion %g: mean Y %.4f, %d non-finite\n", rough[r], disp[i], y, bad);
            int ok = r == 0 ? fabs(y - 1.0) < 0.06 : y > 0.6 && y < 1.02;
            if (bad || !ok || warned(err)) {
                print_error("roughness %s, dispersion %g: mean Y %g (furnace: 1, or below it for rough glass), %d non-finite pixels; stderr: %s\n",
                            rough[r], disp[i], y, bad, err);
                failed++;
            }
        }
    /* An index of 1 (KHR_materials_ior allows it; the clamp above makes it at
     * some wavelengths) is no interface at all: the sky, Y = 1, smooth or
     * rough. */
    for (int r = 0; r < 2; r++) {
        furnace_glass_ior(test_path("glass.gltf"), rough[r], 0, "1.0");
        snprintf(args, sizeof args, "%s --width 16 --spp 128", test_path("glass.gltf"));
        int bad;
        double y = render_mean_y(args, &bad, err, sizeof err);
        print_message("  roughness %s ior 1: mean Y %.4f, %d non-finite\n", rough[r], y, bad);
        if (bad || !(fabs(y - 1.0) < 0.03) || warned(err)) {
            print_error("roughness %s, ior 1: mean Y %g (want 1), %d non-finite pixels; stderr: %s\n", rough[r],
                        y, bad, err);
            failed++;
        }
    }
    assert_int_equal(failed, 0);
}

/* The interface's reflection of the wavelengths that are not the hero, when the
 * hero's index is 1 (no reflection of its own) and theirs are not: bsdf_sample's
 * mean weight over the samples that reflect must be each wavelength's
 * reflectance, for smooth glass its Fresnel reflectance, for rough glass the
 * integral of bsdf_eval over the upper hemisphere (a 400 x 800 midpoint
 * quadrature). Before, reflection was chosen with the hero's Fresnel, 0 here, and
 * that light was lost. */
TEST(test_dispersive_reflection)
{
    BsdfParams p;
    memset(&p, 0, sizeof p);
    p.base = v4_splat(1.0f);
    p.ior = v4(1.0f, 1.5f, 3.0f, 1.2f);
    p.transmission = 1.0f;
    p.spec_tint = v4_splat(1.0f);
    p.specular = 1.0f;
    const double th = 30.0 * M_PI / 180.0;
    vec3 wo = v3((float)sin(th), 0.0f, (float)cos(th));
    const float rough[2] = {0.0f, 0.5f};
    for (int r = 0; r < 2; r++) {
        p.roughness = rough[r];
        double want[4];
        want[0] = bsdf_fresnel_dielectric(wo.z, p.ior.x);
        want[1] = bsdf_fresnel_dielectric(wo.z, p.ior.y);
        want[2] = bsdf_fresnel_dielectric(wo.z, p.ior.z);
        want[3] = bsdf_fresnel_dielectric(wo.z, p.ior.w);
        if (r) {
            const int nt = 400, np = 800;
            memset(want, 0, sizeof want);
            for (int i = 0; i < nt; i++)
                for (int j = 0; j < np; j++) {
                    double t = (i + 0.5) * 0.5 * M_PI / nt, ph = (j + 0.5) * 2.0 * M_PI / np;
                    vec3 wi = v3((float)(sin(t) * cos(ph)), (float)(sin(t) * sin(ph)), (float)cos(t));
                    vec4 f = bsdf_eval(&p, wo, wi);
                    double dw = sin(t) * (0.5 * M_PI / nt) * (2.0 * M_PI / np);
                    want[0] += f.x * dw;
                    want[1] += f.y * dw;
                    want[2] += f.z * dw;
                    want[3] += f.w * dw;
                }
        }
        const uint64_t n = 400000;
        double got[4] = {0, 0, 0, 0};
        for (uint64_t k = 0; k < n; k++) {
            BsdfSample s = bsdf_sample(&p, wo, test_uniform(3 * k), test_uniform(3 * k + 1), test_uniform(3 * k + 2));
            if (!s.valid || !(s.wi.z > 0.0f))
                continue;
            got[0] += s.weight.x;
            got[1] += s.weight.y;
            got[2] += s.weight.z;
            got[3] += s.weight.w;
        }
        for (int c = 0; c < 4; c++) {
            got[c] /= (double)n;
            print_message("  roughness %.1f, ior %.1f: reflected %.5f, expected %.5f\n", rough[r],
                          (double)((const float *)&p.ior)[c], got[c], want[c]);
        }
        for (int c = 0; c < 4; c++)
            assert_close(got[c], want[c], 0.01 * want[c] + 2e-4);
    }
}

/* ---- Case 4: dim blackbody skies ------------------------------------------------ */

/* `--background blackbody:T` is the SPD normalised to luminance 1: smooth glass
 * of dispersion 0 in that sky (a furnace) has mean Y 1 at every temperature the
 * option accepts, from the dimmest (about 24 K, where Planck's law underflows
 * in double) to 1e5 K. Below that it is refused as having no luminance. */
TEST(test_dim_blackbody_sky)
{
    const char *temps[] = {"100", "160", "200", "1000", "6500", "1e5"};
    char err[8192], args[1024];
    int failed = 0;
    furnace_glass(test_path("sky.gltf"), "0.0", 0);
    for (size_t i = 0; i < sizeof temps / sizeof temps[0]; i++) {
        snprintf(args, sizeof args, "%s --width 8 --spp 1024 --background blackbody:%s",
                 test_path("sky.gltf"), temps[i]);
        int bad;
        double y = render_mean_y(args, &bad, err, sizeof err);
        print_message("  blackbody:%s K: mean Y %.4f, %d non-finite\n", temps[i], y, bad);
        if (bad || !(fabs(y - 1.0) < 0.05) || warned(err)) {
            print_error("blackbody:%s: mean Y %g (want 1), %d non-finite; stderr: %s\n", temps[i], y, bad, err);
            failed++;
        }
    }
    assert_int_equal(failed, 0);
    snprintf(args, sizeof args, "render %s --width 8 --spp 1 " TINY " -o %s --background blackbody:10",
             test_path("sky.gltf"), test_path("no.exr"));
    refused(args, 2, (const char *const[]){"blackbody:10", "no luminance", NULL});
}

/* ---- Case 13 and 15: SPD files of one sample, no luminance, bad lines ------------- */

/* The SPD file name holding text is refused (exit 3, one error line naming it
 * and saying why) by `color` and as the --background of a render of
 * test_dir()/csv.gltf. */
static void spd_file_refused(const char *name, const char *text, const char *why)
{
    char args[1024];
    const char *csv = test_path(name);
    test_write_text(csv, text);
    snprintf(args, sizeof args, "color %s", csv);
    refused(args, 3, (const char *const[]){csv, why, NULL});
    snprintf(args, sizeof args, "render %s --width 8 --spp 1 " TINY " -o %s --background %s",
             test_path("csv.gltf"), test_path("no.exr"), csv);
    refused(args, 3, (const char *const[]){csv, why, NULL});
}

TEST(test_spd_csv_refused)
{
    char args[1024];
    furnace_glass(test_path("csv.gltf"), "0.0", 0);
    /* One sample: the README's SPD has at least 2 rows (linear between them). */
    spd_file_refused("one.csv", "wavelength,value\n400,1\n", "at least 2");
    /* No luminance (infrared only): a bad input file, 3, in both commands. */
    spd_file_refused("ir.csv", "900,1\n950,1\n", "no luminance");
    /* A line of numbers that are not a sample: the reason, not the format. */
    const char *bad[][3] = {{"400,1\n0,1\n", "line 2", "not positive"},
                            {"400,1\n500,-2\n", "line 2", "negative"},
                            {"400,1\n500,inf\n", "line 2", "not finite"},
                            {"400,1\n500\n", "line 2", "wavelength_nm,value"}};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        test_write_text(test_path("bad.csv"), bad[i][0]);
        snprintf(args, sizeof args, "color %s", test_path("bad.csv"));
        refused(args, 3, (const char *const[]){test_path("bad.csv"), bad[i][1], bad[i][2], NULL});
    }
}

/* ---- Case 12 and 15: color --pixel integrates bands ------------------------------- */

/* A spectral EXR as `render --spectral n` lays it out (docs/outputs.md: n equal
 * bands over 360-830 nm, each its mean spectral radiance, named by its centre),
 * 2 x 1 pixels: pixel 0 flat (1 in every band), pixel 1 a step (band b holds
 * b + 1); value bad (if not 0) replaces pixel 0's last band. */
static void write_bands(const char *path, int n, float bad)
{
    static char names[64][32];
    static float data[64][2];
    ExrChannel ch[64];
    for (int b = 0; b < n; b++) {
        snprintf(names[b], sizeof names[b], "S0.%.6fnm", 360.0 + (b + 0.5) * 470.0 / n);
        *strchr(names[b] + 3, '.') = ',';
        data[b][0] = 1.0f;
        data[b][1] = (float)(b + 1);
        ch[b] = (ExrChannel){names[b], SPT_EXR_FLOAT, data[b], 0};
    }
    if (bad != 0.0f)
        data[n - 1][0] = bad;
    SptError e = {0};
    if (exr_write_layers(path, 2, 1, ch, n, NULL, 0, &e))
        fail_msg("%s", e.msg);
}

/* XYZ of a spectrum constant over each of n equal bands over 360-830 nm (band b
 * of value f(b)): the CIE 1931 1 nm sums of cmf times the band's value (a 1 nm
 * sample on the border of two bands takes their mean), over the sum of ybar,
 * as the renderer's film normalises. */
static void band_xyz(int n, int step, double xyz[3])
{
    double w = 470.0 / n;
    xyz[0] = xyz[1] = xyz[2] = 0.0;
    for (int i = 0; i < SPT_CIE_SAMPLES; i++) {
        double x = i / w; /* the band coordinate of 360 + i nm */
        int b = (int)floor(x);
        double v = step ? b + 1.0 : 1.0;
        if (fabs(x - floor(x + 0.5)) < 1e-9 && i > 0 && i < SPT_CIE_SAMPLES - 1)
            v = step ? floor(x + 0.5) + 0.5 : 1.0;
        if (b >= n)
            v = step ? n : 1.0;
        xyz[0] += SPT_CIE_X[i] * v;
        xyz[1] += SPT_CIE_Y[i] * v;
        xyz[2] += SPT_CIE_Z[i] * v;
    }
    for (int k = 0; k < 3; k++)
        xyz[k] /= SPT_CIE_Y_INTEGRAL;
}

TEST(test_color_pixel_bands)
{
    const int counts[] = {1, 2, 3, 47};
    char args[1024], out[4096], err[4096];
    for (size_t c = 0; c < sizeof counts / sizeof counts[0]; c++)
        for (int step = 0; step < 2; step++) {
            write_bands(test_path("bands.exr"), counts[c], 0.0f);
            snprintf(args, sizeof args, "color --pixel %d,0 %s", step, test_path("bands.exr"));
            int rc = run(args, out, sizeof out, err, sizeof err);
            if (rc)
                fail_msg("`%s`: exit %d: %s", args, rc, err);
            double got[3], want[3];
            if (sscanf(out, "XYZ %lf %lf %lf", &got[0], &got[1], &got[2]) != 3)
                fail_msg("`%s` printed: %s", args, out);
            band_xyz(counts[c], step, want);
            print_message("  %d bands, %s: XYZ %.6f %.6f %.6f, expected %.6f %.6f %.6f\n", counts[c],
                          step ? "step" : "flat", got[0], got[1], got[2], want[0], want[1], want[2]);
            for (int k = 0; k < 3; k++)
                assert_close(got[k], want[k], 2e-6 + 1e-5 * want[k]);
        }
    /* A rendered pixel: a sky of a flat spectrum seen directly (--max-depth 1:
     * the glass sphere's pixels are black), whose bands are exact for any N.
     * The bands' XYZ must be the XYZ of the same pixel's RGB (docs/architecture.md's
     * matrix), which the film integrates from the same samples sample by sample.
     * N = 1 and 47 only: each N is a kernel build of its own (8 s cold on PoCL),
     * 47 shared with tests/test_spectral.c; the files above cover 2 and 3. */
    const int rendered[] = {1, 47};
    char flat[512];
    snprintf(flat, sizeof flat, "%s", test_path("flat.csv"));
    test_write_text(flat, "360,1\n830,1\n");
    furnace_glass(test_path("flat.gltf"), "0.0", 0);
    for (size_t c = 0; c < sizeof rendered / sizeof rendered[0]; c++) {
        snprintf(args, sizeof args, "render %s --width 8 --spp 256 --max-depth 1 --background %s --spectral %d " TINY
                 " -o %s", test_path("flat.gltf"), flat, rendered[c], test_path("flat.exr"));
        ExrLayers l;
        const float *px[3];
        run_read_rgb(args, test_path("flat.exr"), &l, px, err, sizeof err);
        double rgb[3], want[3], got[3];
        for (int k = 0; k < 3; k++)
            rgb[k] = px[k][0];
        exr_layers_free(&l);
        linear_srgb_to_xyz(rgb, want);
        snprintf(args, sizeof args, "color --pixel 0,0 %s", test_path("flat.exr"));
        int rc = run(args, out, sizeof out, err, sizeof err);
        if (rc || sscanf(out, "XYZ %lf %lf %lf", &got[0], &got[1], &got[2]) != 3)
            fail_msg("`%s`: exit %d: %s%s", args, rc, out, err);
        print_message("  render --spectral %d, pixel 0,0: bands XYZ %.4f %.4f %.4f, its RGB's XYZ %.4f %.4f %.4f\n",
                      rendered[c], got[0], got[1], got[2], want[0], want[1], want[2]);
        assert_true(want[1] > 0.5);
        for (int k = 0; k < 3; k++)
            assert_close(got[k], want[k], 0.03 * want[k]);
    }
    /* A band value that is no radiance: the file, the pixel, the channel and why. */
    const float bad[] = {-1.0f, NAN};
    const char *why[] = {"negative", "not finite"};
    for (int i = 0; i < 2; i++) {
        write_bands(test_path("bad.exr"), 2, bad[i]);
        snprintf(args, sizeof args, "color --pixel 0,0 %s", test_path("bad.exr"));
        refused(args, 3,
                (const char *const[]){test_path("bad.exr"), "pixel 0,0", "S0.712,500000nm", why[i], NULL});
    }
}

TEST_MAIN("tests", test_dir_setup, test_dir_teardown)
