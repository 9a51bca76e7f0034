/* Sizes, sample counts, path pools and devices nobody picks on purpose, on two
 * scenes whose image is known exactly: every pixel must be finite, within what
 * one sample can possibly contribute, hold exactly the samples asked for, and the
 * image mean must match the analytic value within noise. The EXR output of each
 * render must read back bit for bit (noisy pixels compress to within a few bytes
 * of their size, where a ZIP chunk stored wrongly reads back as bands of NaN and
 * 3e38 values; src/io/exr.c).
 *
 * The scenes (written here as glTF): a 10 m x 10 m Lambertian floor (an 8x8 grid,
 * albedo from base colour (0.2, 0.5, 0.8), specularFactor 0: pure Lambert) seen
 * straight down from 2.5 m with yfov 60 degrees (the view reaches at most 4.4 m
 * from the centre, at 3x1, the widest image here; the floor 5 m: every pixel sees
 * the floor), lit
 *   - "sky": by nothing, so by the default white sky: D65 of luminance 1 (XYZ
 *     0.9505, 1, 1.089; linear sRGB 1, 1, 1), or
 *   - "box": by a closed box of emitters over the floor (ceiling at 5 m and four
 *     walls, facing inward, emissive (1, 1, 1), which is the same D65 of
 *     luminance 1, and black without a specular layer: they reflect nothing), and
 *     no sky.
 * Every point of the floor sees, over its whole upper hemisphere, radiance
 * S(lambda) and nothing else (the floor is flat, so it never sees itself), so it
 * reflects L(lambda) = rho(lambda) S(lambda) towards the camera exactly, whatever
 * the floor's size. The image mean is then XYZ_c = integral of rho S cmf_c over
 * 360..830 nm / integral of ybar: about linear sRGB (0.2, 0.5, 0.8).
 *
 * The bound per pixel: every pixel's expected value has a luminance Y in [0, 1]
 * (rho <= 1 and the sky's Y is 1), but a pixel of a few samples can exceed it:
 * a sample's XYZ is the mean over its four wavelengths of L(lambda) cmf_c(lambda)
 * / p(lambda) / integral of ybar (p the wavelength density), never negative
 * (radiance and the CIE functions are not), and L itself is an estimate. At the
 * floor, next-event estimation adds rho S p_b p_l / (p_l^2 + p_b^2) <= rho S / 2
 * (power heuristic; p_b = cos / pi the BSDF's density, p_l the light's) and the
 * BSDF-sampled ray at most rho S (weight rho, MIS weight <= 1), so L(lambda) <=
 * 1.5 rho(lambda) S(lambda) in every sample. A pixel, the mean of its samples,
 * thus has each channel c in [0, 1.5 max over lambda of rho S cmf_c / p /
 * integral of ybar] (plus 1% for float rounding): about 1.7, 1.9 and 8.6 for X, Y
 * and Z. Garbage (NaN, Inf, 3e38, negative) cannot pass that, and the EXR round
 * trip and the mean catch the rest.
 *
 * Runs on two PoCL CPU devices (POCL_DEVICES="pthread pthread"), alone or
 * together; RenderSettings.pool_size sets the path pool, and through it the chunk sizes;
 * the poison test hook fills every path, queue and film buffer with NaN or all
 * ones before use, so a value read but never written shows.
 *
 * And a film that holds a NaN or infinite pixel all the same is never written:
 * `spectrace render` fails with one error: line (exit code 1) and leaves every
 * output as it was; checkpoint_write refuses it too. */
#include "test_util.h"

#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

#include "render/checkpoint.h"
#include "cl/cl_device.h"
#include "io/exr.h"
#include "render/film.h"
#include "io/image_out.h"
#include "render/render.h"
#include "scene/scene.h"
#include "color/spd.h"
#include "spectrum/cie_data.h"
#include "spectrum/spectrum.h"
#include "sample/wavelength.h"

enum { SKY, BOX, SCENES };
static const char *const scene_names[SCENES] = {"sky", "box"};

static char g_dir[256];
static char g_path[SCENES][300];
static ClDeviceList devices;
/* The device under test and the second device of the two-device renders: on
 * PoCL its two devices; on another implementation (run with PoCL visible too,
 * tests/run_tests.sh) that implementation's first device and PoCL's. */
static int dev_a, dev_b;
static Scene scenes[SCENES];
static GpuScene gpus[SCENES];
static double expect_xyz[3];  /* the image mean, both scenes */
static double bound_xyz[3];   /* the most one sample can give, per channel */
static double sigma1[SCENES][3]; /* per-sample standard deviation, from a calibration render */

/* ---- The scenes ------------------------------------------------------------ */

typedef struct Mesh {
    float pos[2048 * 3], nrm[2048 * 3];
    uint32_t idx[4096 * 3];
    int nv, nt;
} Mesh;

/* An n x n grid of quads over the parallelogram o + s u + t v (s, t in [0, 1]),
 * wound so that its faces' normal is cross(u, v) (normalised into every vertex). */
static void add_grid(Mesh *m, const float o[3], const float u[3], const float v[3], int n)
{
    float nr[3] = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
    float len = sqrtf(nr[0] * nr[0] + nr[1] * nr[1] + nr[2] * nr[2]);
    int base = m->nv;
    for (int j = 0; j <= n; j++)
        for (int i = 0; i <= n; i++) {
            for (int k = 0; k < 3; k++) {
                m->pos[3 * m->nv + k] = o[k] + u[k] * (float)i / (float)n + v[k] * (float)j / (float)n;
                m->nrm[3 * m->nv + k] = nr[k] / len;
            }
            m->nv++;
        }
    for (int j = 0; j < n; j++)
        for (int i = 0; i < n; i++) {
            uint32_t a = (uint32_t)(base + j * (n + 1) + i), b = a + 1, c = a + (uint32_t)(n + 1),
                     d = c + 1;
            uint32_t t[6] = {a, b, c, b, d, c};
            memcpy(&m->idx[3 * m->nt], t, sizeof t);
            m->nt += 2;
        }
}

static void base64(FILE *f, const unsigned char *p, size_t n)
{
    static const char tab[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    for (size_t i = 0; i < n; i += 3) {
        uint32_t x = (uint32_t)p[i] << 16 | (i + 1 < n ? (uint32_t)p[i + 1] << 8 : 0) |
                     (i + 2 < n ? p[i + 2] : 0);
        fputc(tab[x >> 18 & 63], f);
        fputc(tab[x >> 12 & 63], f);
        fputc(i + 1 < n ? tab[x >> 6 & 63] : '=', f);
        fputc(i + 2 < n ? tab[x & 63] : '=', f);
    }
}

/* Writes the glTF of meshes[0..count) (mesh k uses material k) with the camera
 * 2.5 m over the origin looking down -Y. */
static void write_gltf(const char *path, Mesh *const *meshes, int count)
{
    size_t bytes = 0;
    for (int k = 0; k < count; k++)
        bytes += (size_t)meshes[k]->nv * 24 + (size_t)meshes[k]->nt * 12;
    unsigned char *buf = malloc(bytes), *p = buf;
    for (int k = 0; k < count; k++) {
        memcpy(p, meshes[k]->pos, (size_t)meshes[k]->nv * 12), p += (size_t)meshes[k]->nv * 12;
        memcpy(p, meshes[k]->nrm, (size_t)meshes[k]->nv * 12), p += (size_t)meshes[k]->nv * 12;
        memcpy(p, meshes[k]->idx, (size_t)meshes[k]->nt * 12), p += (size_t)meshes[k]->nt * 12;
    }
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fprintf(f, "{\"asset\":{\"version\":\"2.0\"},\"extensionsUsed\":[\"KHR_materials_specular\"],"
               "\"buffers\":[{\"byteLength\":%zu,\"uri\":\"data:application/octet-stream;base64,",
            bytes);
    base64(f, buf, bytes);
    fprintf(f, "\"}],\"bufferViews\":[");
    size_t off = 0;
    for (int k = 0; k < count; k++) {
        size_t sz[3] = {(size_t)meshes[k]->nv * 12, (size_t)meshes[k]->nv * 12,
                        (size_t)meshes[k]->nt * 12};
        for (int b = 0; b < 3; b++) {
            fprintf(f, "%s{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu}", k || b ? "," : "",
                    off, sz[b]);
            off += sz[b];
        }
    }
    fprintf(f, "],\"accessors\":[");
    for (int k = 0; k < count; k++) {
        const Mesh *m = meshes[k];
        float lo[3] = {1e30f, 1e30f, 1e30f}, hi[3] = {-1e30f, -1e30f, -1e30f};
        for (int i = 0; i < m->nv; i++)
            for (int c = 0; c < 3; c++) {
                lo[c] = fminf(lo[c], m->pos[3 * i + c]);
                hi[c] = fmaxf(hi[c], m->pos[3 * i + c]);
            }
        fprintf(f, "%s{\"bufferView\":%d,\"componentType\":5126,\"count\":%d,\"type\":\"VEC3\","
                   "\"min\":[%g,%g,%g],\"max\":[%g,%g,%g]},"
                   "{\"bufferView\":%d,\"componentType\":5126,\"count\":%d,\"type\":\"VEC3\"},"
                   "{\"bufferView\":%d,\"componentType\":5125,\"count\":%d,\"type\":\"SCALAR\"}",
                k ? "," : "", 3 * k, m->nv, lo[0], lo[1], lo[2], hi[0], hi[1], hi[2], 3 * k + 1,
                m->nv, 3 * k + 2, 3 * m->nt);
    }
    fprintf(f, "],\"materials\":["
               "{\"pbrMetallicRoughness\":{\"baseColorFactor\":[0.2,0.5,0.8,1],"
               "\"metallicFactor\":0,\"roughnessFactor\":1},"
               "\"extensions\":{\"KHR_materials_specular\":{\"specularFactor\":0}}},"
               "{\"pbrMetallicRoughness\":{\"baseColorFactor\":[0,0,0,1],"
               "\"metallicFactor\":0,\"roughnessFactor\":1},\"emissiveFactor\":[1,1,1],"
               "\"extensions\":{\"KHR_materials_specular\":{\"specularFactor\":0}}}],"
               "\"meshes\":[");
    for (int k = 0; k < count; k++)
        fprintf(f, "%s{\"primitives\":[{\"attributes\":{\"POSITION\":%d,\"NORMAL\":%d},"
                   "\"indices\":%d,\"material\":%d}]}",
                k ? "," : "", 3 * k, 3 * k + 1, 3 * k + 2, k);
    fprintf(f, "],\"cameras\":[{\"type\":\"perspective\",\"perspective\":"
               "{\"yfov\":1.0471975511965976,\"aspectRatio\":1,\"znear\":0.01}}],\"nodes\":[");
    for (int k = 0; k < count; k++)
        fprintf(f, "{\"mesh\":%d},", k);
    fprintf(f, "{\"camera\":0,\"translation\":[0,2.5,0],"
               "\"rotation\":[-0.7071067811865476,0,0,0.7071067811865476]}],"
               "\"scenes\":[{\"nodes\":[");
    for (int k = 0; k <= count; k++)
        fprintf(f, "%s%d", k ? "," : "", k);
    fprintf(f, "]}],\"scene\":0}\n");
    fclose(f);
    free(buf);
}

static void write_scenes(void)
{
    static Mesh floor_mesh, box;
    memset(&floor_mesh, 0, sizeof floor_mesh);
    memset(&box, 0, sizeof box);
    /* The floor, normal +Y: u = 10 Z, v = 10 X. */
    add_grid(&floor_mesh, (float[3]){-5, 0, -5}, (float[3]){0, 0, 10}, (float[3]){10, 0, 0}, 8);
    /* The emitters' faces, normals inward: ceiling -Y, walls +-X, +-Z. */
    add_grid(&box, (float[3]){-5, 5, -5}, (float[3]){10, 0, 0}, (float[3]){0, 0, 10}, 2);
    add_grid(&box, (float[3]){-5, 0, -5}, (float[3]){0, 5, 0}, (float[3]){0, 0, 10}, 2);
    add_grid(&box, (float[3]){5, 0, -5}, (float[3]){0, 0, 10}, (float[3]){0, 5, 0}, 2);
    add_grid(&box, (float[3]){-5, 0, -5}, (float[3]){10, 0, 0}, (float[3]){0, 5, 0}, 2);
    add_grid(&box, (float[3]){-5, 0, 5}, (float[3]){0, 5, 0}, (float[3]){10, 0, 0}, 2);
    Mesh *sky[1] = {&floor_mesh}, *lit[2] = {&floor_mesh, &box};
    write_gltf(g_path[SKY], sky, 1);
    write_gltf(g_path[BOX], lit, 2);
}

/* ---- The analytic values ------------------------------------------------- */

/* The floor's radiance rho(lambda) S(lambda). */
static double floor_radiance(double l, const float rho_c[3], const float sky_c[3], float sky_scale)
{
    float lf = (float)l;
    return spt_sigmoid_poly(rho_c[0], rho_c[1], rho_c[2], lf) * sky_scale *
           spt_sigmoid_poly(sky_c[0], sky_c[1], sky_c[2], lf) * spt_d65_norm(lf);
}

static void analytic_values(void)
{
    const float base[3] = {0.2f, 0.5f, 0.8f}, white[3] = {1, 1, 1};
    float rho_c[3], sky_c[3], sky_scale;
    rgb_to_coeffs(base, rho_c);
    rgb_illuminant_coeffs(white, sky_c, &sky_scale);
    /* Midpoint rule at 0.01 nm over 360..830 nm (the tables are linear between
     * their 1 nm entries, so this is the integral the renderer estimates). */
    double sum[3] = {0, 0, 0}, mx[3] = {0, 0, 0};
    const double h = 0.01;
    for (double l = SPT_CIE_LAMBDA_MIN + 0.5 * h; l < SPT_CIE_LAMBDA_MAX; l += h) {
        double L = floor_radiance(l, rho_c, sky_c, sky_scale);
        double cmf[3] = {spt_cie_x((float)l), spt_cie_y((float)l), spt_cie_z((float)l)};
        double p = spt_wavelength_pdf((float)l);
        for (int c = 0; c < 3; c++) {
            sum[c] += L * cmf[c] * h;
            mx[c] = fmax(mx[c], L * cmf[c] / p);
        }
    }
    for (int c = 0; c < 3; c++) {
        expect_xyz[c] = sum[c] / SPT_CIE_Y_INTEGRAL;
        bound_xyz[c] = 1.01 * 1.5 * mx[c] / SPT_CIE_Y_INTEGRAL;
    }
    double rgb[3];
    xyz_to_linear_srgb(expect_xyz, rgb);
    print_message("floor: XYZ %.5f %.5f %.5f (linear sRGB %.4f %.4f %.4f); per-sample bound "
                  "%.3f %.3f %.3f\n",
                  expect_xyz[0], expect_xyz[1], expect_xyz[2], rgb[0], rgb[1], rgb[2],
                  bound_xyz[0], bound_xyz[1], bound_xyz[2]);
}

/* ---- Rendering ------------------------------------------------------------ */

typedef struct Config {
    int w, h, spp;
    int pool;      /* pool_size, 0 = the device's default (65536 on a CPU) */
    int devices;   /* 1: device 0; 2: both */
    uint32_t seed; /* 0: one of the sweep's own */
} Config;

static int render_config(int scene, const Config *c, uint32_t seed, uint32_t poison, Film *film,
                         RenderStats *st, SptError *e)
{
    RenderSettings rs;
    memset(&rs, 0, sizeof rs);
    rs.width = c->w;
    rs.height = c->h;
    rs.spp = c->spp;
    rs.max_depth = -1;
    rs.seed = seed;
    rs.env_intensity = 1.0f;
    rs.pool_size = c->pool > 0 ? (uint32_t)c->pool : 0;
    rs.test.poison = 1;
    rs.test.poison_word = poison;
    film_init(film, c->w, c->h);
    const ClDeviceInfo *infos[2] = {&devices.devices[dev_a], &devices.devices[dev_b]};
    int rc = render_devices(infos, c->devices, &gpus[scene], &scenes[scene].camera, &rs, film, st,
                            NULL, e);
    return rc;
}

/* The standard deviation of one sample, per channel, from a 48x48 render at 1
 * spp (2304 independent samples of the same expected value). */
static void calibrate(int scene)
{
    const Config c = {48, 48, 1, 0, 1, 999};
    Film f;
    RenderStats st;
    SptError e = {0};
    if (render_config(scene, &c, c.seed, 0, &f, &st, &e))
        fail_msg("calibration render: %s", e.msg);
    size_t n = (size_t)c.w * c.h;
    for (int ch = 0; ch < 3; ch++) {
        double s = 0, s2 = 0;
        for (size_t i = 0; i < n; i++) {
            double v = f.xyz[3 * i + ch];
            s += v;
            s2 += v * v;
        }
        double m = s / (double)n;
        sigma1[scene][ch] = sqrt(fmax(s2 / (double)n - m * m, 0.0) * (double)n / (double)(n - 1));
    }
    film_free(&f);
}

/* Every check of one render; returns the largest deviation of the mean in units
 * of its standard error. */
static double check_config(int scene, const Config *c, int index)
{
    uint32_t seed = c->seed ? c->seed : 1000u * (uint32_t)scene + (uint32_t)index;
    uint32_t poison = index % 2 ? 0xffffffffu : 0x7fc00000u; /* all ones, NaN */
    Film f;
    RenderStats st;
    SptError e = {0};
    if (render_config(scene, c, seed, poison, &f, &st, &e))
        fail_msg("%s %dx%d %d spp pool %d, %d device(s): render failed: %s", scene_names[scene],
                 c->w, c->h, c->spp, c->pool, c->devices, e.msg);
    char what[128];
    snprintf(what, sizeof what, "%s %dx%d %d spp pool %d, %d device(s)", scene_names[scene], c->w,
             c->h, c->spp, c->pool, c->devices);
    if (st.spp_done != (uint32_t)c->spp || st.nan_dropped != 0)
        fail_msg("%s: %u spp done, %llu NaN samples dropped", what, st.spp_done,
                 (unsigned long long)st.nan_dropped);
    size_t n = (size_t)c->w * c->h;
    double mean[3] = {0, 0, 0};
    for (size_t i = 0; i < n; i++) {
        if (f.count[i] != (double)c->spp)
            fail_msg("%s: pixel (%zu, %zu) holds %g samples", what, i % (size_t)c->w,
                     i / (size_t)c->w, f.count[i]);
        for (int ch = 0; ch < 3; ch++) {
            double v = f.xyz[3 * i + ch] / f.count[i];
            if (!(v >= 0.0 && v <= bound_xyz[ch]))
                fail_msg("%s: pixel (%zu, %zu) channel %c = %g, outside [0, %.3f]", what,
                         i % (size_t)c->w, i / (size_t)c->w, "XYZ"[ch], v, bound_xyz[ch]);
            mean[ch] += v / (double)n;
        }
    }
    /* The mean against the analytic value: 5 standard errors (the samples of a
     * pixel are stratified, so sigma1 / sqrt(samples) overestimates it) and 0.1%
     * for the integration. */
    double worst = 0;
    for (int ch = 0; ch < 3; ch++) {
        double se = sigma1[scene][ch] / sqrt((double)n * c->spp);
        double dev = fabs(mean[ch] - expect_xyz[ch]);
        if (!(dev <= 5.0 * se + 1e-3 * expect_xyz[ch]))
            fail_msg("%s: mean %c = %.5f, expected %.5f within %.5f (5 standard errors)", what,
                     "XYZ"[ch], mean[ch], expect_xyz[ch], 5.0 * se + 1e-3 * expect_xyz[ch]);
        worst = fmax(worst, dev / se);
    }
    /* The EXR output holds exactly the film's linear sRGB. */
    float *rgb = malloc(n * 3 * sizeof(float));
    film_to_linear_srgb(&f, rgb);
    char path[400];
    snprintf(path, sizeof path, "%s/out.exr", g_dir);
    if (image_write(path, rgb, c->w, c->h, NULL, NULL, &e))
        fail_msg("%s: %s", what, e.msg);
    ExrLayers l;
    if (exr_read_layers(path, NULL, 0, &l, &e))
        fail_msg("%s: %s", what, e.msg);
    for (int ch = 0; ch < 3; ch++) {
        const float *v = exr_layers_channel(&l, (const char *[]){"R", "G", "B"}[ch])->data;
        for (size_t i = 0; i < n; i++)
            if (memcmp(&v[i], &rgb[3 * i + ch], sizeof(float)))
                fail_msg("%s: the EXR's pixel (%zu, %zu) channel %c reads %g, the film gives %g",
                         what, i % (size_t)c->w, i / (size_t)c->w, "RGB"[ch], v[i],
                         rgb[3 * i + ch]);
    }
    exr_layers_free(&l);
    free(rgb);
    film_free(&f);
    return worst;
}

/* The sweep: odd sizes and sizes below the path pool, sample counts that are not
 * powers of two, pools from 1 path up (smaller than a work-group of 64, one
 * either side of it, smaller and larger than the image), one device and two. A
 * chunk is ceil(16 pool / pixels) samples, at most ceil(spp / 16) (src/render/render.c),
 * so these give chunks of 1 to 9 samples, with a shorter last one where the
 * chunk does not divide spp (130 spp: 14 of 9 and one of 4; 17 spp: 8 of 2 and
 * one of 1); 130x70 at 130 spp with a pool of 1000 takes chunks of 2, 31x17 at 64
 * spp with a pool of 64 chunks of 2. The first three are the renders of the
 * report that found the EXR bands (64x64, seed 1, 16, 48 and 64 spp: one to two
 * 16-row bands each with Debian 12's OpenEXR and zlib before the fix). */
static const Config sweep[] = {
    {64, 64, 16, 0, 1, 1},  {64, 64, 48, 0, 2, 1},  {64, 64, 64, 0, 1, 1},
    {1, 1, 1, 0, 1, 0},     {1, 1, 130, 1, 1, 0},   {1, 1, 17, 7, 2, 0},    {1, 1, 64, 0, 2, 0},
    {2, 1, 3, 1, 2, 0},     {2, 1, 100, 0, 1, 0},   {1, 2, 9, 2, 1, 0},     {1, 3, 5, 63, 1, 0},
    {1, 3, 48, 1, 2, 0},    {3, 2, 127, 3, 2, 0},   {5, 3, 2, 7, 1, 0},     {5, 3, 31, 0, 2, 0},
    {5, 3, 130, 65, 1, 0},  {7, 7, 7, 1, 1, 0},     {7, 7, 16, 64, 2, 0},   {7, 7, 64, 0, 1, 0},
    {7, 7, 129, 1000, 2, 0}, {3, 1, 33, 5, 1, 0},  {13, 7, 1, 63, 2, 0},   {13, 7, 17, 0, 1, 0},
    {13, 7, 48, 7, 1, 0},   {13, 7, 100, 65, 2, 0}, {17, 19, 6, 100, 2, 0}, {31, 17, 3, 0, 1, 0},
    {31, 17, 16, 1000, 2, 0}, {31, 17, 33, 64, 1, 0}, {31, 17, 64, 64, 2, 0}, {33, 65, 2, 1000, 1, 0},
    {33, 65, 31, 0, 2, 0},  {33, 65, 48, 0, 1, 0},  {47, 53, 9, 4096, 2, 0}, {64, 64, 16, 0, 2, 0},
    {64, 64, 48, 0, 1, 0},  {64, 64, 64, 0, 2, 0},  {64, 64, 5, 1000, 2, 0}, {64, 64, 100, 0, 1, 0},
    {96, 96, 24, 0, 1, 0},  {127, 63, 11, 0, 2, 0}, {130, 70, 1, 0, 1, 0},  {130, 70, 7, 1000, 2, 0},
    {130, 70, 64, 0, 2, 0}, {130, 70, 130, 1000, 1, 0},
};

static void run_sweep(int scene)
{
    calibrate(scene);
    print_message("%s: one sample's standard deviation XYZ %.4f %.4f %.4f\n", scene_names[scene],
                  sigma1[scene][0], sigma1[scene][1], sigma1[scene][2]);
    double worst = 0;
    int count = (int)(sizeof sweep / sizeof sweep[0]), done = 0;
    for (int i = 0; i < count; i++) {
        /* The quick form (an implementation that takes about 10 ms a kernel
         * launch): the configurations of up to 4096 samples whose pool is the
         * default or a work-group or more, i.e. of few launches. */
        const Config *c = &sweep[i];
        if (test_quick() && ((long)c->w * c->h * c->spp > 4096 || (c->pool > 0 && c->pool < 64)))
            continue;
        worst = fmax(worst, check_config(scene, c, i));
        done++;
    }
    print_message("%s on %s (and %s): %d of %d renders, every pixel finite and in range, EXR "
                  "exact; largest mean deviation %.2f standard errors\n",
                  scene_names[scene], devices.devices[dev_a].impl, devices.devices[dev_b].impl,
                  done, count, worst);
}

TEST(test_sweep_sky)
{
    run_sweep(SKY);
}

TEST(test_sweep_box)
{
    run_sweep(BOX);
}

/* ---- A film that holds a non-finite pixel is never written --------------- */

/* The whole file, malloc'd (NULL when it cannot be read). */
static char *slurp(const char *path, size_t *n)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    fseek(f, 0, SEEK_END);
    long len = ftell(f);
    fseek(f, 0, SEEK_SET);
    char *b = malloc((size_t)len + 1);
    assert_int_equal(fread(b, 1, (size_t)len, f), (size_t)len);
    fclose(f);
    *n = (size_t)len;
    return b;
}

/* `spectrace render` with SPECTRACE_TEST_FILM_NAN=3 (the first 3 pixels of the
 * film NaN after the render): exit code 1, one error: line naming 3 pixels, the
 * existing output untouched, no new output and no checkpoint. */
TEST(test_nonfinite_film_refused)
{
    char old[400], png[400], ck[400], cmd[2400];
    snprintf(old, sizeof old, "%s/old.exr", g_dir);
    snprintf(png, sizeof png, "%s/new.png", g_dir);
    snprintf(ck, sizeof ck, "%s/ck.exr", g_dir);
    FILE *f = fopen(old, "wb");
    assert_non_null(f);
    fputs("an earlier render", f);
    fclose(f);
    snprintf(cmd, sizeof cmd,
             "render '%s' --width 8 --height 6 --spp 2 -q -o '%s' -o '%s' --checkpoint '%s'",
             g_path[SKY], old, png, ck);
    char out[4096];
    int rc = test_run_exe("SPECTRACE_TEST_FILM_NAN=3", 0, cmd, out, sizeof out);
    if (rc != 1)
        fail_msg("exit code %d, expected 1:\n%s", rc, out);
    int errors = 0;
    for (const char *l = out; l && *l; l = strchr(l, '\n') ? strchr(l, '\n') + 1 : NULL)
        errors += !strncmp(l, "error:", 6);
    if (errors != 1 || !strstr(out, "error: render: 3 of 48 pixels came out NaN or infinite"))
        fail_msg("expected one error: line naming 3 of 48 pixels:\n%s", out);
    size_t len;
    char *kept = slurp(old, &len);
    assert_non_null(kept);
    assert_int_equal(len, strlen("an earlier render"));
    assert_memory_equal(kept, "an earlier render", len);
    free(kept);
    assert_int_equal(access(png, F_OK), -1);
    assert_int_equal(access(ck, F_OK), -1);
    /* The same render without the hook writes all three. */
    assert_int_equal(test_run_exe("", 0, cmd, out, sizeof out), 0);
    assert_int_equal(access(png, F_OK), 0);
    assert_int_equal(access(ck, F_OK), 0);
}

/* checkpoint_write refuses such a film too (the periodic checkpoints of a render
 * whose film went wrong), and leaves the file there as it was. */
TEST(test_nonfinite_checkpoint_refused)
{
    char ck[400];
    snprintf(ck, sizeof ck, "%s/ck2.exr", g_dir);
    Film film;
    film_init(&film, 5, 4);
    for (int i = 0; i < 20; i++) {
        film.count[i] = 1;
        film.xyz[3 * i + 1] = 0.5;
    }
    CheckpointKey key;
    memset(&key, 0, sizeof key);
    key.width = 5;
    key.height = 4;
    unsigned char done[1] = {1};
    SptError e = {0};
    assert_int_equal(checkpoint_write(ck, &key, &film, done, 1, &e), 0);
    size_t n0, n1;
    char *before = slurp(ck, &n0);
    film.xyz[3 * 7 + 2] = INFINITY;
    film.count[11] = NAN;
    film.xyz[3 * 13] = 1e300; /* finite as a double, infinite as a float */
    assert_int_equal(film_nonfinite_pixels(&film), 3);
    assert_int_equal(checkpoint_write(ck, &key, &film, done, 1, &e), SPT_EXIT_FAILURE);
    assert_non_null(strstr(e.msg, "3 pixels"));
    assert_non_null(strstr(e.msg, ck));
    char *after = slurp(ck, &n1);
    assert_int_equal(n0, n1);
    assert_memory_equal(before, after, n0);
    free(before);
    free(after);
    film_free(&film);
}

/* ---- Setup ----------------------------------------------------------------- */

static int setup(void **state)
{
    (void)state;
    SptError e = {0};
    snprintf(g_dir, sizeof g_dir, "/tmp/spt-test-sweep-XXXXXX");
    if (!mkdtemp(g_dir))
        return -1;
    for (int s = 0; s < SCENES; s++)
        snprintf(g_path[s], sizeof g_path[s], "%s/%s.gltf", g_dir, scene_names[s]);
    write_scenes();
    if (cl_device_list(&devices, &e) || devices.count < 2) {
        fprintf(stderr, "need two OpenCL devices (PoCL's two, or PoCL and another): %s\n", e.msg);
        return -1;
    }
    const char *impl = getenv("SPECTRACE_TEST_IMPL");
    dev_a = 0;
    dev_b = 1;
    if (impl && *impl && strcmp(impl, "pocl") != 0) {
        dev_a = -1;
        for (int i = 0; i < devices.count && dev_a < 0; i++)
            if (strcmp(devices.devices[i].impl, impl) == 0)
                dev_a = i;
        if (dev_a < 0) {
            fprintf(stderr, "no device of %s is visible\n", impl);
            return -1;
        }
        dev_b = dev_a == 0 ? 1 : 0;
    }
    for (int s = 0; s < SCENES; s++)
        if (scene_load_gltf(&scenes[s], g_path[s], &e) || gpu_scene_build(&gpus[s], &scenes[s], &e)) {
            fprintf(stderr, "%s\n", e.msg);
            return -1;
        }
    analytic_values();
    return 0;
}

static int teardown(void **state)
{
    (void)state;
    for (int s = 0; s < SCENES; s++) {
        gpu_scene_free(&gpus[s]);
        scene_free(&scenes[s]);
    }
    cl_device_list_free(&devices);
    char cmd[512];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", g_dir);
    return system(cmd) == 0 ? 0 : -1;
}

/* Two PoCL CPU devices, set before any OpenCL call (with another
 * implementation visible too, its device is the one under test). */
TEST_MAIN_ENV("sweep", setup, teardown, "POCL_DEVICES=pthread pthread")
