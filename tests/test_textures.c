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
 * here independently of the loader.
 *
 * On an implementation with slow kernel launches (tests/run_tests.sh's quick
 * form: rusticl, about a second per sample of a small image) three run: a colour
 * texture, the sampler filters and the sheen. */
#include "test_util.h"
#include "test_render_util.h"

#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

#include "cl/cl_device.h"
#include "render/film.h"
#include "render/render.h"
#include "scene/scene.h"
#include "sheen_spec.h"

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
    Film f;
    RenderStats st;
    int rc = render_file(path, w, h, spp, depth, 7, background, &f, &st);
    if (rc)
        fail_msg("render %s: exit %d (its message above)", path, rc);
    assert_int_equal(st.nan_dropped, 0);
    Image im = {w, h, malloc(sizeof(float) * 3 * (size_t)w * h)};
    film_to_linear_srgb(&f, im.rgb);
    film_free(&f);
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

/* Asserts that every cell of an n x n grid has colour want, as assert_cell. */
static void assert_cells_all(const Image *im, int n, const double want[3], double rel, double abs_tol)
{
    for (int row = 0; row < n; row++)
        for (int col = 0; col < n; col++)
            assert_cell(im, n, n, col, row, want, rel, abs_tol);
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

/* The 4x4 cells of base_cell_colour times factor in im (64x64); frees im. */
static void assert_base_pattern(Image im, const double factor[3])
{
    for (int row = 0; row < 4; row++)
        for (int col = 0; col < 4; col++) {
            double want[3];
            base_cell_colour(col, row, want);
            for (int c = 0; c < 3; c++)
                want[c] *= factor[c];
            assert_cell(&im, 4, 4, col, row, want, 0.06, 0.01);
        }
    free(im.rgb);
}

static void check_base_pattern(const char *scene, const double factor[3])
{
    assert_base_pattern(render_texture_scene(scene, 64, 64, 16, 2, NULL), factor);
}

static const double one[3] = {1.0, 1.0, 1.0};

/* The texture without a sampler, and with an empty sampler object. */
TEST(test_base_color_no_sampler)
{
    check_base_pattern("base_nosampler.gltf", one);
}

TEST(test_base_color_empty_sampler)
{
    skip_if_quick();
    check_base_pattern("base_emptysampler.gltf", one);
}

/* The texture times baseColorFactor (0.5, 0.8, 1): each channel of each cell
 * scaled by its factor. */
TEST(test_base_color_factor)
{
    skip_if_quick();
    const double factor[3] = {0.5, 0.8, 1.0};
    check_base_pattern("base_factor.gltf", factor);
}

/* The base colour pattern at texture coordinate (u, v) as glTF's bilinear
 * filtering gives it: texel (i, j) of the 16 x 16 image (cells of 4 x 4 texels)
 * covers [i / 16, (i + 1) / 16] x [j / 16, (j + 1) / 16] and has its value at its
 * centre, wrap REPEAT, and the interpolation blends the texels' linear values
 * (glTF 2.0: the sRGB transfer function is decoded before linear interpolation). */
static void base_bilinear(double u, double v, double out[3])
{
    double tu = u * 16.0 - 0.5, tv = v * 16.0 - 0.5;
    int i0 = (int)floor(tu), j0 = (int)floor(tv);
    double fu = tu - i0, fv = tv - j0;
    out[0] = out[1] = out[2] = 0.0;
    for (int dj = 0; dj < 2; dj++)
        for (int di = 0; di < 2; di++) {
            int i = ((i0 + di) % 16 + 16) % 16, j = ((j0 + dj) % 16 + 16) % 16;
            double w = (di ? fu : 1.0 - fu) * (dj ? fv : 1.0 - fv), c[3];
            base_cell_colour(i / 4, j / 4, c);
            for (int k = 0; k < 3; k++)
                out[k] += w * c[k];
        }
}

/* The whole image, texel by texel, against the filtered texture: at 64 x 64 a
 * texel is 4 x 4 pixels and the bilinear function's kinks (the texel centres)
 * fall on pixel boundaries, so a pixel's mean is the value at its centre. Each
 * texel's 4 x 4-pixel mean must be within 10% of (value + 0.02): filtering the
 * encoded values and decoding afterwards (Blender Cycles' way with 8-bit sRGB
 * images) is up to 57% off at the cells' edges, texel centres at i / 16 instead
 * of (i + 0.5) / 16 up to 200%, CLAMP_TO_EDGE at the border 68%; the renderer's
 * own error (noise at 64 samples, the spectral upsampling of texels) stays
 * under 4%. */
TEST(test_base_color_texel_boundaries)
{
    skip_if_quick();
    Image im = render_texture_scene("base_nosampler.gltf", 64, 64, 64, 2, NULL);
    double worst = 0.0;
    for (int ty = 0; ty < 16; ty++)
        for (int tx = 0; tx < 16; tx++) {
            double got[3] = {0, 0, 0}, want[3] = {0, 0, 0};
            for (int y = 4 * ty; y < 4 * ty + 4; y++)
                for (int x = 4 * tx; x < 4 * tx + 4; x++) {
                    double c[3];
                    base_bilinear((x + 0.5) / 64.0, (y + 0.5) / 64.0, c);
                    for (int k = 0; k < 3; k++) {
                        got[k] += im.rgb[3 * ((size_t)y * 64 + x) + k] / 16.0;
                        want[k] += c[k] / 16.0;
                    }
                }
            for (int k = 0; k < 3; k++) {
                double r = fabs(got[k] - want[k]) / (want[k] + 0.02);
                worst = fmax(worst, r);
                if (!(r <= 0.1))
                    fail_msg("texel (%d, %d) channel %d: %.4f, expected %.4f (bilinear on linear values)", tx, ty,
                             k, got[k], want[k]);
            }
        }
    print_message("  largest |got - expected| / (expected + 0.02) over the texels: %.3f\n", worst);
    free(im.rgb);
}

/* ------------------------------------------------------------------------- */
/* Data textures and layers share one 4 x 4 layout of four kinds of cell (no
 * symmetry under flips or transposes): tools/make_texture_scenes.py KIND_GRID. */

static const int kind_grid[4][4] = {{0, 1, 2, 3}, {1, 1, 0, 2}, {3, 0, 2, 2}, {0, 3, 3, 1}};

/* Asserts that every cell of the 4 x 4 grid shows want[kind] (grey, all
 * channels) within rel relative plus abs_tol absolute. */
static void assert_kind_cells(const Image *im, const double want[4], double rel, double abs_tol)
{
    for (int row = 0; row < 4; row++)
        for (int col = 0; col < 4; col++) {
            double w = want[kind_grid[row][col]], g[3] = {w, w, w};
            assert_cell(im, 4, 4, col, row, g, rel, abs_tol);
        }
}

/* Renders tests/data/textures/NAME (render_texture_scene, 32 samples) and
 * checks its kinds of cells against want (assert_kind_cells). */
static void render_kind_cells(const char *name, int w, int h, int depth, const char *background,
                              const double want[4], double rel, double abs_tol)
{
    Image im = render_texture_scene(name, w, h, 32, depth, background);
    assert_kind_cells(&im, want, rel, abs_tol);
    free(im.rgb);
}

/* Alpha (linear, not sRGB-decoded) of the base colour texture: cells of alpha
 * 51, 128, 204, 255 over a black plane under the white sky. BLEND shows 1 - alpha;
 * MASK (cutoff 0.6) the sky where alpha < 0.6, else black. The same texture on a
 * white OPAQUE plane shows each cell's colour as stored: glTF's texels are not
 * premultiplied by their alpha. */
TEST(test_alpha_blend_and_mask)
{
    skip_if_quick();
    const int a8[4] = {51, 128, 204, 255};
    double blend[4], mask[4];
    for (int k = 0; k < 4; k++) {
        blend[k] = 1.0 - a8[k] / 255.0;
        mask[k] = a8[k] / 255.0 < 0.6 ? 1.0 : 0.0;
    }
    render_kind_cells("alpha_blend.gltf", 64, 64, 2, NULL, blend, 0.05, 0.02);
    Image im = render_texture_scene("alpha_mask.gltf", 64, 64, 16, 2, NULL);
    assert_kind_cells(&im, mask, 0.0, 0.03);
    free(im.rgb);
    const int rgb8[4][3] = {{200, 100, 50}, {40, 200, 120}, {120, 40, 200}, {200, 200, 40}};
    im = render_texture_scene("alpha_opaque.gltf", 64, 64, 16, 2, NULL);
    for (int row = 0; row < 4; row++)
        for (int col = 0; col < 4; col++) {
            const int *c = rgb8[kind_grid[row][col]];
            double want[3] = {srgb8_to_linear(c[0]), srgb8_to_linear(c[1]), srgb8_to_linear(c[2])};
            assert_cell(&im, 4, 4, col, row, want, 0.06, 0.01);
        }
    free(im.rgb);
}

/* A cut-out minified: a black plane (MASK, cutoff 0.5) whose alpha is a
 * checkerboard of 0 and 1 texels, eight to a pixel. Half of each pixel is
 * covered (the bilinear alpha is >= 0.5 on exactly half of a checkerboard), so
 * it reads 0.5 over the white sky; the cutoff applied to the blurred alpha (0.5
 * everywhere from the first mip level on) would keep it all. */
TEST(test_alpha_mask_minified)
{
    skip_if_quick();
    Image im = render_texture_scene("alpha_mask_far.gltf", 64, 64, 16, 2, NULL);
    double half[3] = {0.5, 0.5, 0.5};
    assert_cells_all(&im, 4, half, 0.0, 0.05);
    free(im.rgb);
}

/* The metallic-roughness texture (B metallic, G roughness, linear) of a white
 * plane lit head-on by pi lux (a white Lambertian would read 1), seen head-on
 * (wo = wi = n = h): glTF Appendix B gives f cos = D(n) G2 F / 4 for the GGX lobe,
 * D(n) = 1 / (pi alpha^2), G2 = 1, and for the dielectric the diffuse
 * (1 - F0) / pi besides, F0 = 0.04. Cells: metal rough 1 (1/4); metal rough
 * 128/255 (1 / (4 alpha^2)); mirror metal (0: a delta lobe never meets a delta
 * light); dielectric rough 1 (0.96 + 0.04/4). */
TEST(test_metallic_roughness)
{
    skip_if_quick();
    double a = (128.0 / 255.0) * (128.0 / 255.0);
    const double want[4] = {0.25, 1.0 / (4.0 * a * a), 0.0, 0.96 + 0.01};
    render_kind_cells("metallic_roughness.gltf", 64, 64, 2, "black", want, 0.03, 0.005);
}

/* The normal texture (scale 0.7) of a white Lambertian lit by pi lux from
 * l = (2, 1, 3) / sqrt(14): each cell shows max(0, n.l), n the decoded texel
 * (2 c / 255 - 1, x and y times the scale) in the tangent frame of the plane:
 * the tangent along increasing u (+X, or -X where the texture coordinates are
 * mirrored), the bitangent toward the image's top (+Y either way: glTF's
 * normal textures are +Y up, and a mirrored mapping flips the handedness, as
 * MikkTSpace's bitangent sign does). Cells: flat, tilted toward the texture's
 * +X, -X, +Y: four different values, so a swapped or mirrored axis, or a
 * missing scale, fails. */
static void check_normal_map(const char *scene, double tangent_x)
{
    const int codes[4][3] = {{128, 128, 255}, {218, 128, 218}, {38, 128, 218}, {128, 218, 218}};
    const double scale = 0.7, l[3] = {2 / sqrt(14.0), 1 / sqrt(14.0), 3 / sqrt(14.0)};
    double want[4];
    for (int k = 0; k < 4; k++) {
        double n[3];
        for (int c = 0; c < 3; c++)
            n[c] = (2.0 * codes[k][c] / 255.0 - 1.0) * (c < 2 ? scale : 1.0);
        n[0] *= tangent_x;
        double len = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        want[k] = fmax(0.0, (n[0] * l[0] + n[1] * l[1] + n[2] * l[2]) / len);
    }
    Image im = render_texture_scene(scene, 64, 64, 32, 2, "black");
    if (tangent_x < 0) {
        /* The mirrored mapping shows the texture mirrored: cell (col, row) of
         * the image is texture cell (3 - col, row). */
        for (int row = 0; row < 4; row++)
            for (int col = 0; col < 4; col++) {
                double w = want[kind_grid[row][3 - col]], g[3] = {w, w, w};
                assert_cell(&im, 4, 4, col, row, g, 0.03, 0.005);
            }
    } else {
        assert_kind_cells(&im, want, 0.03, 0.005);
    }
    free(im.rgb);
}

TEST(test_normal_map)
{
    skip_if_quick();
    check_normal_map("normal.gltf", 1.0);
    check_normal_map("normal_mirrored.gltf", -1.0);
}

/* The emissive texture (the base pattern, sRGB) times emissiveFactor (1, 0.8,
 * 0.6) times KHR_materials_emissive_strength 2, seen directly. */
TEST(test_emissive_texture)
{
    skip_if_quick();
    const double factor[3] = {2.0, 1.6, 1.2};
    assert_base_pattern(render_texture_scene("emissive.gltf", 64, 64, 32, 1, "black"), factor);
}

/* KHR_materials_transmission's texture (R, linear) on a smooth plane of ior 1 in
 * front of an emitter of radiance 1: each cell passes its transmission (0, 64,
 * 128, 255 / 255) of the light; the rest is diffuse reflection of the black sky. */
TEST(test_transmission_texture)
{
    skip_if_quick();
    const double want[4] = {0.0, 64.0 / 255.0, 128.0 / 255.0, 1.0};
    render_kind_cells("transmission.gltf", 64, 64, 4, "black", want, 0.03, 0.03);
}

/* The base colour pattern read through TEXCOORD_1 (texCoord 1; TEXCOORD_0 is one
 * constant point, so reading set 0 shows one colour). */
TEST(test_texcoord1)
{
    skip_if_quick();
    check_base_pattern("texcoord1.gltf", one);
}

/* COLOR_0 of a 3 x 3-vertex plane (tools/make_texture_scenes.py VERTEX_COLORS),
 * interpolated across each triangle and multiplying the white base colour; with
 * alphaMode BLEND its alpha blends the plane over the white sky. Checked in a
 * 3 x 3-pixel window at the centroid of each of the 8 triangles against the
 * barycentric interpolation of the vertex colours at each pixel's centre. */
static const double vertex_colors[9][4] = {
    {0.9, 0.1, 0.1, 1.0}, {0.1, 0.9, 0.1, 0.5}, {0.1, 0.1, 0.9, 1.0}, {0.9, 0.9, 0.1, 0.8}, {0.5, 0.5, 0.5, 0.2},
    {0.1, 0.9, 0.9, 1.0}, {0.9, 0.1, 0.9, 0.6}, {0.3, 0.6, 0.9, 1.0}, {0.9, 0.6, 0.3, 0.4}};

/* The interpolated COLOR_0 (RGBA) at plane point (x, y) in [-1, 1]^2: quads of
 * side 1 split along the diagonal from (i, j) to (i + 1, j + 1). quantise: the
 * colours as 8-bit normalised values. */
static void color_at(double x, double y, int quantise, double out[4])
{
    double fx = x + 1.0, fy = y + 1.0;
    int i = fx >= 1.0 ? 1 : 0, j = fy >= 1.0 ? 1 : 0;
    double u = fx - i, v = fy - j;
    int a = 3 * j + i, b, c;
    double wa, wb, wc;
    if (u >= v) { /* triangle (a, a + 1, a + 4) */
        b = a + 1;
        c = a + 4;
        wa = 1.0 - u;
        wb = u - v;
        wc = v;
    } else { /* triangle (a, a + 4, a + 3) */
        b = a + 4;
        c = a + 3;
        wa = 1.0 - v;
        wb = u;
        wc = v - u;
    }
    for (int k = 0; k < 4; k++) {
        double ca = vertex_colors[a][k], cb = vertex_colors[b][k], cc = vertex_colors[c][k];
        if (quantise) {
            ca = round(ca * 255.0) / 255.0;
            cb = round(cb * 255.0) / 255.0;
            cc = round(cc * 255.0) / 255.0;
        }
        out[k] = wa * ca + wb * cb + wc * cc;
    }
}

/* 128 spp: a 3 x 3-pixel mean of a half-transparent colour over the sky carries
 * the noise of alpha's coin flip per sample; at 32 spp it was about as large as
 * the tolerance (a change of sampler moved one channel from inside it to 0.034
 * off, 0.033 allowed). */
static void check_vertex_colors(const char *scene, int blend)
{
    const int W = 64;
    Image im = render_texture_scene(scene, W, W, 128, 2, NULL);
    /* Centroids of the triangles in quad-local coordinates. */
    const double cen[2][2] = {{2.0 / 3.0, 1.0 / 3.0}, {1.0 / 3.0, 2.0 / 3.0}};
    for (int q = 0; q < 4; q++)
        for (int t = 0; t < 2; t++) {
            double x = -1.0 + (q % 2) + cen[t][0], y = -1.0 + (q / 2) + cen[t][1];
            int px = (int)((x + 1.0) * 0.5 * W), py = (int)((1.0 - y) * 0.5 * W);
            double got[3] = {0, 0, 0}, want[3] = {0, 0, 0};
            for (int dy = -1; dy <= 1; dy++)
                for (int dx = -1; dx <= 1; dx++) {
                    int X = px + dx, Y = py + dy;
                    double c[4];
                    color_at(-1.0 + 2.0 * (X + 0.5) / W, 1.0 - 2.0 * (Y + 0.5) / W, blend, c);
                    for (int k = 0; k < 3; k++) {
                        got[k] += im.rgb[3 * ((size_t)Y * W + X) + k] / 9.0;
                        want[k] += (blend ? c[3] * c[k] + (1.0 - c[3]) : c[k]) / 9.0;
                    }
                }
            for (int k = 0; k < 3; k++)
                if (!(fabs(got[k] - want[k]) <= 0.04 * want[k] + 0.01))
                    fail_msg("%s: triangle %d of quad %d, channel %d: %.4f, expected %.4f", scene, t, q, k, got[k],
                             want[k]);
        }
    free(im.rgb);
}

TEST(test_color0_vec3_float)
{
    skip_if_quick();
    check_vertex_colors("color0_vec3_float.gltf", 0);
}

TEST(test_color0_vec3_ushort)
{
    skip_if_quick();
    check_vertex_colors("color0_vec3_ushort.gltf", 0);
}

TEST(test_color0_vec4_ubyte)
{
    skip_if_quick();
    check_vertex_colors("color0_vec4_ubyte.gltf", 1);
}

/* A 2 x 1 texture (white, black), clamped, magnified over the plane: column u
 * shows the texel under it with magFilter NEAREST (a step at u = 1/2), and with
 * LINEAR the interpolation between the texel centres (u = 1/4 and 3/4):
 * 1 - (u - 1/4) / (1/2) there, 1 and 0 outside. The ramp's kinks fall on pixel
 * boundaries of a 64-pixel row, so each pixel's mean is its centre's value. */
TEST(test_nearest_and_linear)
{
    Image nearest = render_texture_scene("filter_nearest.gltf", 64, 64, 16, 2, NULL);
    Image linear = render_texture_scene("filter_linear.gltf", 64, 64, 16, 2, NULL);
    for (int x = 0; x < 64; x++) {
        double u = (x + 0.5) / 64.0;
        double want_n = u < 0.5 ? 1.0 : 0.0, want_l = fmin(1.0, fmax(0.0, 1.0 - (u - 0.25) / 0.5));
        double gn = 0.0, gl = 0.0;
        for (int y = 16; y < 48; y++) {
            gn += nearest.rgb[3 * ((size_t)y * 64 + x) + 1] / 32.0;
            gl += linear.rgb[3 * ((size_t)y * 64 + x) + 1] / 32.0;
        }
        if (!(fabs(gn - want_n) <= 0.03) || !(fabs(gl - want_l) <= 0.03))
            fail_msg("column %d (u %.3f): nearest %.4f (expected %.4f), linear %.4f (expected %.4f)", x, u, gn,
                     want_n, gl, want_l);
    }
    free(nearest.rgb);
    free(linear.rgb);
}

/* A checkerboard floor to the horizon at 4 samples per pixel: where a pixel's
 * footprint covers many squares (rows 33-36, just below the horizon: beyond 18 m,
 * footprints over 4 m long) it must read their mean, 0.5, in every pixel: a
 * standard deviation across the band below 0.1 (the lighting's own noise at 4
 * samples is about 0.06; 256 samples give 0.008), where squares picked at random
 * by 4 samples give about 0.25. Near the camera the squares must still show (a
 * standard deviation above 0.3). */
TEST(test_horizon_converges_to_grey)
{
    skip_if_quick();
    Image im = render_texture_scene("horizon.gltf", 64, 64, 4, 2, NULL);
    double s[2] = {0, 0}, s2[2] = {0, 0};
    int n[2] = {0, 0};
    for (int y = 33; y < 64; y++) {
        int band = y < 37 ? 0 : y >= 56 ? 1 : -1;
        if (band < 0)
            continue;
        for (int x = 0; x < 64; x++) {
            double v = im.rgb[3 * ((size_t)y * 64 + x) + 1];
            s[band] += v;
            s2[band] += v * v;
            n[band]++;
        }
    }
    double mean_far = s[0] / n[0], sd_far = sqrt(fmax(0.0, s2[0] / n[0] - mean_far * mean_far));
    double mean_near = s[1] / n[1], sd_near = sqrt(fmax(0.0, s2[1] / n[1] - mean_near * mean_near));
    print_message("  far band (rows 33-36): mean %.4f, sd %.4f; near band (rows 56-63): mean %.4f, sd %.4f\n",
                  mean_far, sd_far, mean_near, sd_near);
    assert_close(mean_far, 0.5, 0.05);
    assert_true(sd_far < 0.1);
    assert_true(sd_near > 0.3);
    free(im.rgb);
}

/* The GGX coat's lobe over a black base, head-on under pi lux: the coat weight
 * clearcoat Fc(1) = 0.04 clearcoat times D(n) G2 / 4 = 1 / (4 pi alpha^2): pixel =
 * 0.01 clearcoat / alpha^2 (alpha = roughness^2). Cells (clearcoat R, roughness G
 * of one texture): (1, 128/255), (1, 1), (128/255, 128/255), (0, -). */
TEST(test_clearcoat)
{
    skip_if_quick();
    double a = (128.0 / 255.0) * (128.0 / 255.0), h = 128.0 / 255.0;
    const double want[4] = {0.01 / (a * a), 0.01, h * 0.01 / (a * a), 0.0};
    render_kind_cells("clearcoat.gltf", 64, 64, 2, "black", want, 0.03, 0.002);
}

/* The clearcoat normal texture (NEAREST: left half flat, right half the texel
 * (191, 128, 238), about 30 degrees toward +X): head-on view and light, so with
 * c = n_c.z the coat reflects Fc(c) D(c) G2 / (4 c) with glTF's D and G2 (alpha
 * 0.25) and Fc = 0.04 + 0.96 (1 - c)^5; the left half 0.01 / alpha^2 = 0.16. */
TEST(test_clearcoat_normal)
{
    skip_if_quick();
    double n[3] = {2 * 191 / 255.0 - 1, 2 * 128 / 255.0 - 1, 2 * 238 / 255.0 - 1};
    double c = n[2] / sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]), a = 0.25, a2 = a * a;
    double D = a2 / (M_PI * pow(c * c * (a2 - 1) + 1, 2));
    double lambda = 0.5 * (-1 + sqrt(1 + a2 * (1 - c * c) / (c * c)));
    double fc = 0.04 + 0.96 * pow(1 - c, 5);
    double tilted = M_PI * fc * D / (1 + 2 * lambda) / (4 * c);
    Image im = render_texture_scene("clearcoat_normal.gltf", 64, 64, 32, 2, "black");
    double flat[3] = {0.16, 0.16, 0.16}, right[3] = {tilted, tilted, tilted};
    print_message("  tilted coat: expected %.5f (flat 0.16)\n", tilted);
    for (int row = 0; row < 2; row++) {
        assert_cell(&im, 2, 2, 0, row, flat, 0.03, 0.002);
        assert_cell(&im, 2, 2, 1, row, right, 0.03, 0.001);
    }
    free(im.rgb);
}

/* The coat is on top of emission (KHR_materials_clearcoat, "Emission"): an
 * emitter of radiance 1 under a smooth coat, seen head-on under a black sky,
 * shows 1 - clearcoat Fc(1) = 0.96. */
TEST(test_clearcoat_over_emission)
{
    skip_if_quick();
    Image im = render_texture_scene("clearcoat_emissive.gltf", 32, 32, 64, 2, "black");
    double want[3] = {0.96, 0.96, 0.96};
    assert_cells_all(&im, 2, want, 0.01, 0.0);
    free(im.rgb);
}

/* KHR_materials_sheen over a black base, seen and lit 60 degrees off the normal
 * (pi lux, wo = wi = h, mu = 1/2): f cos = colour D V mu with the specification's
 * Charlie D = (2 + 1/alpha) sin(theta_h)^(1/alpha) / (2 pi) and V = 1 / ((1 + 2
 * Lambda(1/2)) 4 mu^2), alpha = r^2, written here from the specification. Cells
 * (colour RGB sRGB, roughness A linear): (1, 77), (188, 153), (1, 255), (0, -). */
TEST(test_sheen)
{
    const double colour[4] = {1.0, srgb8_to_linear(188), 1.0, 0.0}, rough[4] = {77, 153, 255, 255};
    double want[4];
    for (int k = 0; k < 4; k++) {
        double r = rough[k] / 255.0, alpha = r * r, mu = 0.5;
        double D = (2 + 1 / alpha) * pow(0.75, 0.5 / alpha) / (2 * M_PI);
        double lambda = exp(spec_sheen_l(mu, alpha));
        double V = 1 / ((1 + 2 * lambda) * 4 * mu * mu);
        want[k] = M_PI * colour[k] * D * V * mu;
    }
    print_message("  expected %.5f %.5f %.5f %.5f\n", want[0], want[1], want[2], want[3]);
    render_kind_cells("sheen.gltf", 64, 32, 2, "black", want, 0.03, 0.002);
}

/* KHR_materials_specular's textures on a black dielectric (roughness 0.5, alpha
 * 0.25), head-on under pi lux: the GGX lobe with F = F0 = 0.04 colour specular,
 * D(n) / 4 = 1 / (4 pi alpha^2): pixel = 0.16 colour specular. Cells (colour RGB
 * sRGB, specular A linear): white 1; (255, 128, 64) 1; white 128/255; white 0. */
TEST(test_specular_textures)
{
    skip_if_quick();
    Image im = render_texture_scene("specular.gltf", 64, 64, 32, 2, "black");
    const double tint[4][3] = {{1, 1, 1}, {1, srgb8_to_linear(128), srgb8_to_linear(64)}, {1, 1, 1}, {1, 1, 1}};
    const double spec[4] = {1.0, 1.0, 128.0 / 255.0, 0.0};
    for (int row = 0; row < 4; row++)
        for (int col = 0; col < 4; col++) {
            int k = kind_grid[row][col];
            double want[3];
            for (int c = 0; c < 3; c++)
                want[c] = 0.16 * tint[k][c] * spec[k];
            assert_cell(&im, 4, 4, col, row, want, 0.03, 0.002);
        }
    free(im.rgb);
}

/* ------------------------------------------------------------------------- */
/* What `spectrace render` says about lighting: a scene without emitters or
 * lights is lit by the default sky (a note, no warning that the image will be
 * black); only a black sky earns the warning. */

/* Runs `spectrace render ARGS` into a temporary EXR with stderr captured
 * into out; returns the exit status. */
static int run_render(const char *args, char *out, size_t out_size)
{
    char exr[64], a[1024];
    snprintf(exr, sizeof exr, "/tmp/spt_textures_%d.exr", (int)getpid());
    snprintf(a, sizeof a, "render %s -q -o %s", args, exr);
    int rc = test_run_exe("", 0, a, out, out_size);
    unlink(exr);
    return rc;
}

TEST(test_sky_lit_scene_not_called_black)
{
    skip_if_quick();
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

/* `spectrace info` names each texture slot with the file's texture index and its
 * uv set; a TEXCOORD_2 is warned about once. */
TEST(test_info_slots_and_texcoord_warning)
{
    skip_if_quick();
    static char out[16384];
    assert_int_equal(test_spectrace("", 0, "info --no-bvh tests/data/textures/texcoord1.gltf", TEST_BOTH,
                                    out, sizeof out),
                     0);
    if (!strstr(out, "baseColor textures[0] uv 1"))
        fail_msg("info does not show the base colour slot with its texture and uv set:\n%s", out);
    int warned = 0;
    for (const char *q = out; (q = strstr(q, "warning: ")); q++)
        warned += strstr(q, "TEXCOORD_2") && strstr(q, "TEXCOORD_2") < strchr(q, '\n');
    if (warned != 1)
        fail_msg("expected one warning about TEXCOORD_2, got %d:\n%s", warned, out);
    assert_int_equal(test_spectrace("", 0, "info --no-bvh tests/data/textures/clearcoat_normal.gltf",
                                    TEST_BOTH, out, sizeof out),
                     0);
    if (!strstr(out, "clearcoat 1 roughness 0.5") || !strstr(out, "clearcoatNormal textures[0] uv 0"))
        fail_msg("info does not show the clearcoat and its normal slot:\n%s", out);
    /* The camera's far plane on its line. */
    if (!strstr(out, "znear 0.01 zfar 100\n"))
        fail_msg("info does not show the camera's zfar on its line:\n%s", out);
}

TEST_MAIN("tests", setup_cpu_device, teardown_cpu_device)
