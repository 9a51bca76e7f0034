/* Textures and vertex attributes where the user sees them: scenes of
 * tools/make_texture_scenes.py (tests/data/textures/) rendered by the OpenCL
 * renderer (PoCL), with assertions on the pixels each input must change.
 *
 * Most scenes are a 2 x 2 m plane seen head-on by an orthographic camera that
 * frames it exactly: pixel (x, y) of a W x H image sees texture coordinate
 * ((x + 0.5) / W, (y + 0.5) / H), so a texture shows the right way up when
 * uv (0, 0) is the image's upper-left corner (glTF 2.0, "Images"). A Lambertian
 * plane (metallic 0, KHR_materials_specular factor 0) under the default sky
 * (uniform radiance 1, film Y = 1) shows its albedo: the expected values below
 * are the texels' sRGB values decoded with the sRGB transfer function, written
 * here independently of the loader. */
#include "test_util.h"

#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

#include "cl_device.h"
#include "film.h"
#include "render.h"
#include "scene.h"

static ClDeviceList devices;
static const ClDeviceInfo *device;

static int setup(void **state)
{
    (void)state;
    SptError e = {0};
    int sel[64], n = 0;
    if (cl_device_list(&devices, &e) || cl_device_select(&devices, "cpu", sel, &n, &e)) {
        fprintf(stderr, "no OpenCL CPU device: %s\n", e.msg);
        return -1;
    }
    device = &devices.devices[sel[0]];
    return 0;
}

static int teardown(void **state)
{
    (void)state;
    cl_device_list_free(&devices);
    return 0;
}

/* An image rendered from a scene: linear sRGB, 3 floats per pixel, rows top to
 * bottom. */
typedef struct Image {
    int w, h;
    float *rgb;
} Image;

/* Renders tests/data/textures/NAME at w x h with spp samples and max depth
 * depth; background as --background (NULL: the default). */
static Image render_texture_scene(const char *name, int w, int h, int spp, int depth,
                                  const char *background)
{
    char path[256];
    snprintf(path, sizeof path, "tests/data/textures/%s", name);
    Scene s;
    SptError e = {0};
    if (scene_load_gltf(&s, path, &e))
        fail_msg("load %s: %s", path, e.msg);
    GpuScene g;
    if (gpu_scene_build(&g, &s, &e))
        fail_msg("build %s: %s", path, e.msg);
    RenderSettings rs;
    memset(&rs, 0, sizeof rs);
    rs.width = w;
    rs.height = h;
    rs.spp = spp;
    rs.max_depth = depth;
    rs.seed = 7;
    rs.background = background;
    Film f;
    RenderStats st;
    film_init(&f, w, h);
    if (render_device(device, &g, &s.camera, &rs, &f, &st, &e))
        fail_msg("render %s: %s", path, e.msg);
    assert_int_equal(st.nan_dropped, 0);
    Image im = {w, h, malloc(sizeof(float) * 3 * (size_t)w * h)};
    film_to_linear_srgb(&f, im.rgb);
    film_free(&f);
    gpu_scene_free(&g);
    scene_free(&s);
    return im;
}

/* Mean colour of the middle half (in each direction) of cell (col, row) of a
 * cols x rows grid over the image. */
static void cell_mean(const Image *im, int cols, int rows, int col, int row, double out[3])
{
    int x0 = im->w * col / cols, x1 = im->w * (col + 1) / cols;
    int y0 = im->h * row / rows, y1 = im->h * (row + 1) / rows;
    int mx = (x1 - x0) / 4, my = (y1 - y0) / 4;
    double s[3] = {0, 0, 0};
    int n = 0;
    for (int y = y0 + my; y < y1 - my; y++)
        for (int x = x0 + mx; x < x1 - mx; x++, n++)
            for (int c = 0; c < 3; c++)
                s[c] += im->rgb[3 * ((size_t)y * im->w + x) + c];
    for (int c = 0; c < 3; c++)
        out[c] = s[c] / n;
}

/* The sRGB transfer function's decoding of an 8-bit value (IEC 61966-2-1). */
static double srgb8_to_linear(int v)
{
    double c = v / 255.0;
    return c <= 0.04045 ? c / 12.92 : pow((c + 0.055) / 1.055, 2.4);
}

/* Asserts that cell (col, row) of the grid has colour want (linear), within
 * rel relative plus abs absolute per channel. */
static void assert_cell(const Image *im, int cols, int rows, int col, int row, const double want[3],
                        double rel, double abs_tol)
{
    double got[3];
    cell_mean(im, cols, rows, col, row, got);
    for (int c = 0; c < 3; c++)
        if (!(fabs(got[c] - want[c]) <= rel * want[c] + abs_tol))
            fail_msg("cell (col %d, row %d) channel %d: %.4f, expected %.4f (cell colour %.4f %.4f "
                     "%.4f, expected %.4f %.4f %.4f)",
                     col, row, c, got[c], want[c], got[0], got[1], got[2], want[0], want[1], want[2]);
}

/* ------------------------------------------------------------------------- */
/* Base colour texture: 4 x 4 cells of 16 different colours (no two related by a
 * flip or transpose of the grid), cell (col, row) = palette entry
 * (5 (4 row + col) + 3) mod 27, palette entry i = sRGB levels (L[i / 9 mod 3],
 * L[i / 3 mod 3], L[i mod 3]), L = 40, 120, 200. Each cell must land where the
 * texture has it and with its colour: a texture read at one place, flipped or
 * transposed, or not sRGB-decoded fails. */

static void base_cell_colour(int col, int row, double out[3])
{
    static const int levels[3] = {40, 120, 200};
    int i = (5 * (row * 4 + col) + 3) % 27;
    out[0] = srgb8_to_linear(levels[(i / 9) % 3]);
    out[1] = srgb8_to_linear(levels[(i / 3) % 3]);
    out[2] = srgb8_to_linear(levels[i % 3]);
}

static void check_base_pattern(const char *scene)
{
    Image im = render_texture_scene(scene, 64, 64, 16, 2, NULL);
    for (int row = 0; row < 4; row++)
        for (int col = 0; col < 4; col++) {
            double want[3];
            base_cell_colour(col, row, want);
            assert_cell(&im, 4, 4, col, row, want, 0.06, 0.01);
        }
    free(im.rgb);
}

/* The texture without a sampler, and with an empty sampler object. */
static void test_base_color_no_sampler(void **state)
{
    (void)state;
    check_base_pattern("base_nosampler.gltf");
}

static void test_base_color_empty_sampler(void **state)
{
    (void)state;
    check_base_pattern("base_emptysampler.gltf");
}

/* ------------------------------------------------------------------------- */
/* What `spectrace render` says about lighting: a scene without emitters or
 * lights is lit by the default sky (a note, no warning that the image will be
 * black); only a black sky earns the warning. */

/* Runs `$SPECTRACE_EXE render ARGS` into a temporary folder with stderr captured
 * into out; returns the exit status. */
static int run_render(const char *args, char *out, size_t out_size)
{
    const char *exe = getenv("SPECTRACE_EXE");
    if (!exe || access(exe, X_OK))
        fail_msg("SPECTRACE_EXE is not set (run through tests/run_tests.sh)");
    char dir[] = "/tmp/spt_textures_XXXXXX";
    assert_non_null(mkdtemp(dir));
    char cmd[1024];
    snprintf(cmd, sizeof cmd, "'%s' render %s -q -o %s/out.exr 2>&1 >/dev/null; rm -rf %s", exe, args,
             dir, dir);
    FILE *p = popen(cmd, "r");
    assert_non_null(p);
    size_t n = fread(out, 1, out_size - 1, p);
    out[n] = 0;
    int st = pclose(p);
    return WIFEXITED(st) ? WEXITSTATUS(st) : 128;
}

static void test_sky_lit_scene_not_called_black(void **state)
{
    (void)state;
    static char out[8192];
    const char *scene = "tests/data/textures/base_nosampler.gltf --width 8 --spp 1";
    assert_int_equal(run_render(scene, out, sizeof out), 0);
    if (strstr(out, "will be black") || !strstr(out, "uniform white sky"))
        fail_msg("default sky: expected the sky note and no black-image warning, got:\n%s", out);
    char args[512];
    const char *black[] = {"black", "0,0,0"};
    for (int k = 0; k < 2; k++) {
        snprintf(args, sizeof args, "%s --background %s", scene, black[k]);
        assert_int_equal(run_render(args, out, sizeof out), 0);
        if (!strstr(out, "warning: ") || !strstr(out, "will be black"))
            fail_msg("--background %s: expected the black-image warning, got:\n%s", black[k], out);
    }
    snprintf(args, sizeof args, "%s --background 0.5,0.5,0.5", scene);
    assert_int_equal(run_render(args, out, sizeof out), 0);
    if (strstr(out, "will be black"))
        fail_msg("--background 0.5,0.5,0.5: no black-image warning expected, got:\n%s", out);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_base_color_no_sampler),
        cmocka_unit_test(test_base_color_empty_sampler),
        cmocka_unit_test(test_sky_lit_scene_not_called_black),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
