/* Shared set-up of the tests that render through the library (src/render/:
 * test_render, test_render_sky, test_shading, test_materials, test_textures):
 * the CPU device they render on, renders of a file or a Scene, and the small
 * scenes several of them build. Include after test_util.h. */
#ifndef SPT_TEST_RENDER_UTIL_H
#define SPT_TEST_RENDER_UTIL_H

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cl/cl_device.h"
#include "render/film.h"
#include "render/render.h"
#include "scene/scene.h"
#include "spectrum/cie_data.h"
#include "render_fixture.h"

#define SPT_CIE_Y_INTEGRAL_HOST ((double)SPT_CIE_Y_INTEGRAL)

static ClDeviceList devices;
static const ClDeviceInfo *device; /* the first CPU device */

/* cmocka group set-up: lists the devices and picks the CPU. */
static int setup_cpu_device(void **state)
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

static int teardown_cpu_device(void **state)
{
    (void)state;
    cl_device_list_free(&devices);
    return 0;
}

/* Renders scene s with rs on the test device into film (initialised here,
 * whatever the outcome, with AOV sums when rs->aov and rs->spectral bands):
 * the one path every library render of these tests takes. Returns the exit
 * code, e its message. */
static inline int render_film(const Scene *s, const RenderSettings *rs, Film *film, RenderStats *st,
                              SptError *e)
{
    film_init_full(film, rs->width, rs->height, rs->aov != 0, rs->spectral);
    GpuScene g;
    int rc = gpu_scene_build(&g, s, e);
    if (rc)
        return rc;
    rc = render_device(device, &g, &s->camera, rs, film, st, e);
    gpu_scene_free(&g);
    return rc;
}

/* render_film that must succeed: fails the test with the render's message
 * otherwise; returns the render's statistics. */
static inline RenderStats render_film_ok(const Scene *s, const RenderSettings *rs, Film *film)
{
    SptError e = {0};
    RenderStats st;
    if (render_film(s, rs, film, &st, &e))
        fail_msg("render: %s", e.msg);
    return st;
}

/* Renders scene s at w x h into film (initialised here); background as
 * --background (NULL: the default sky); hooks: the test hooks (may be NULL).
 * Returns the exit code, its message printed. */
static inline int render_scene_hooks(const Scene *s, int w, int h, int spp, int depth, uint32_t seed,
                                     const char *background, const RenderTestHooks *hooks,
                                     Film *film, RenderStats *st)
{
    RenderSettings rs = test_settings(w, h, spp, depth, seed);
    if (hooks)
        rs.test = *hooks;
    Sky sky;
    SptError e = {0};
    int rc = sky_from_args(&sky, NULL, background, &e);
    if (rc) {
        fprintf(stderr, "sky %s: %s\n", background ? background : "(default)", e.msg);
        return rc;
    }
    rs.sky = background ? &sky : NULL;
    rc = render_film(s, &rs, film, st, &e);
    if (rc)
        fprintf(stderr, "render: %s\n", e.msg);
    sky_free(&sky);
    return rc;
}

static inline int render_scene(const Scene *s, int w, int h, int spp, int depth, uint32_t seed,
                               const char *background, Film *film, RenderStats *st)
{
    return render_scene_hooks(s, w, h, spp, depth, seed, background, NULL, film, st);
}

/* The same for the scene file at path. */
static inline int render_file_hooks(const char *path, int w, int h, int spp, int depth, uint32_t seed,
                                    const char *background, const RenderTestHooks *hooks,
                                    Film *film, RenderStats *st)
{
    Scene s;
    SptError e = {0};
    int rc = scene_load_gltf(&s, path, &e);
    if (rc) {
        fprintf(stderr, "load %s: %s\n", path, e.msg);
        return rc;
    }
    rc = render_scene_hooks(&s, w, h, spp, depth, seed, background, hooks, film, st);
    scene_free(&s);
    return rc;
}

static inline int render_file(const char *path, int w, int h, int spp, int depth, uint32_t seed,
                              const char *background, Film *film, RenderStats *st)
{
    return render_file_hooks(path, w, h, spp, depth, seed, background, NULL, film, st);
}

/* The test hooks of render_gltf's renders. */
static RenderTestHooks g_hooks;

/* Renders scene file `path` at w x h, spp, depth, seed into film (initialised
 * here) with g_hooks; returns the render's exit code. */
static inline int render_gltf(const char *path, int w, int h, int spp, int depth, uint32_t seed,
                              Film *film, RenderStats *st)
{
    return render_file_hooks(path, w, h, spp, depth, seed, NULL, &g_hooks, film, st);
}

/* A square camera at (0, y, z) looking down the y-z plane along (0, -a, -b),
 * +x to the right; its other fields zero. */
static inline void aim_camera(Scene *s, double y, double z, double a, double b, float yfov)
{
    double len = sqrt(a * a + b * b);
    memset(&s->camera, 0, sizeof s->camera);
    s->camera.position[1] = (float)y;
    s->camera.position[2] = (float)z;
    s->camera.forward[1] = (float)(-a / len);
    s->camera.forward[2] = (float)(-b / len);
    s->camera.up[1] = (float)(b / len);
    s->camera.up[2] = (float)(-a / len);
    s->camera.right[0] = 1.0f;
    s->camera.yfov = yfov;
    s->camera.aspect = 1.0f;
    scene_update_bounds(s);
}

/* Points the camera of s straight down (-Y) from (x, height, 0), +X to the
 * right and -Z up in the image, of vertical field yfov and aspect; its other
 * fields as they were. */
static inline void camera_down(Scene *s, float x, float height, float yfov, float aspect)
{
    s->camera.position[0] = x;
    s->camera.position[1] = height;
    s->camera.forward[1] = -1.0f;
    s->camera.up[2] = -1.0f;
    s->camera.right[0] = 1.0f;
    s->camera.yfov = yfov;
    s->camera.aspect = aspect;
}

/* The means of each channel over the 4 x 4 blocks of a w x w interleaved RGB
 * image (w a multiple of 4): out[3 * (4 * by + bx) + c]. */
static inline void block_means_4x4(const float *rgb, int w, double out[48])
{
    const int bs = w / 4;
    for (int by = 0; by < 4; by++)
        for (int bx = 0; bx < 4; bx++)
            for (int c = 0; c < 3; c++) {
                double b = 0;
                for (int y = by * bs; y < (by + 1) * bs; y++)
                    for (int x = bx * bs; x < (bx + 1) * bs; x++)
                        b += rgb[3 * (y * w + x) + c];
                out[3 * (4 * by + bx) + c] = b / (bs * bs);
            }
}

/* The block test of two w x w renders (interleaved RGB, w a multiple of 4)
 * that differ only by float rounding, such as a scene traced by reference
 * and flattened: mean |difference| below 0.5% of b's mean and every 4x4
 * block's mean within 2% (rounding moves a few silhouette pixels' paths,
 * nothing else). what names the pair in the printed figures. */
static inline void assert_images_agree(const float *a, const float *b, int w, const char *what)
{
    double sum = 0, diff = 0;
    for (int i = 0; i < 3 * w * w; i++) {
        sum += b[i];
        diff += fabs((double)a[i] - b[i]);
    }
    double ba[48], bb[48], worst = 0;
    block_means_4x4(a, w, ba);
    block_means_4x4(b, w, bb);
    for (int i = 0; i < 48; i++)
        worst = fmax(worst, fabs(ba[i] - bb[i]) / fmax(bb[i], 1e-3));
    printf("%s: mean %.6f, mean |diff| %.3g (%.3g%%), worst block %.3g%%\n", what,
           sum / (3 * w * w), diff / (3 * w * w), 100 * diff / sum, 100 * worst);
    assert_true(sum > 0);
    assert_true(diff < 0.005 * sum);
    assert_true(worst < 0.02);
}

/* Mean linear sRGB of a film. */
static inline void film_mean(const Film *f, double mean[3])
{
    size_t n = (size_t)f->width * f->height;
    float *rgb = malloc(n * 3 * sizeof(float));
    film_to_linear_srgb(f, rgb);
    mean[0] = mean[1] = mean[2] = 0;
    for (size_t i = 0; i < n; i++)
        for (int c = 0; c < 3; c++)
            mean[c] += rgb[3 * i + c];
    for (int c = 0; c < 3; c++)
        mean[c] /= (double)n;
    free(rgb);
}

/* Reads the n numbers following `key` after `section` in the JSON file at path. */
static inline int json_numbers(const char *path, const char *section, const char *key, double *v, int n)
{
    FILE *f = fopen(path, "r");
    if (!f)
        return -1;
    static char buf[1 << 16];
    size_t len = fread(buf, 1, sizeof buf - 1, f);
    fclose(f);
    buf[len] = 0;
    const char *p = strstr(buf, section);
    p = p ? strstr(p, key) : NULL;
    if (!p)
        return -1;
    p += strlen(key);
    for (int i = 0; i < n; i++) {
        while (*p && !(*p == '-' || (*p >= '0' && *p <= '9')))
            p++;
        char *end;
        v[i] = strtod(p, &end);
        if (end == p)
            return -1;
        p = end;
    }
    return 0;
}

/* The 3 numbers of `"key": [a, b, c]` following `section` in a JSON file. */
static inline int json_triple(const char *path, const char *section, const char *key, double v[3])
{
    return json_numbers(path, section, key, v, 3);
}

/* A scene built in code: a sphere of radius 1 at the origin (a convex
 * polyhedron with flat faces, so no point sees another), material m, no light;
 * camera at +Z 4 looking toward -Z, yfov 0.6 rad. */
static inline void sphere_scene_material(Scene *s, const SceneMaterial *m)
{
    sphere_scene_mesh(s, 48, 96, 0.0f);
    s->materials[0] = *m;
    s->camera.position[2] = 4.0f;
    s->camera.forward[2] = -1.0f;
    s->camera.up[1] = 1.0f;
    s->camera.right[0] = 1.0f;
    s->camera.yfov = 0.6f;
    s->camera.aspect = 1.0f;
    scene_update_bounds(s);
}

/* The same sphere, Lambertian of albedo `albedo` (metallic 0 and no specular
 * layer: KHR_materials_specular 0). */
static inline void sphere_scene(Scene *s, float albedo)
{
    SceneMaterial m;
    scene_material_default(&m);
    m.metallic = 0.0f;
    m.specular = 0.0f;
    for (int k = 0; k < 3; k++)
        m.base_color[k] = albedo;
    sphere_scene_material(s, &m);
}

/* Settings of a w x w render of spp samples at max_depth with seed; the rest
 * zero (no environment unless set; env_intensity 1 as the command line's). */
static inline RenderSettings square_settings(int w, int spp, int depth, uint32_t seed)
{
    RenderSettings rs = test_settings(w, w, spp, depth, seed);
    rs.env_intensity = 1.0f;
    return rs;
}

/* Renders scene s with rs on the test device into rgb (linear sRGB, 3 floats
 * per pixel; may be NULL); returns the render's exit code, e its message. */
static inline int render_scene_rgb(const Scene *s, const RenderSettings *rs, float *rgb, SptError *e)
{
    Film f;
    RenderStats st;
    int rc = render_film(s, rs, &f, &st, e);
    if (!rc && rgb)
        film_to_linear_srgb(&f, rgb);
    film_free(&f);
    return rc;
}

/* Whether a test runs the kernels' code path `path` (SPT_KERNEL_PATH_CPU or
 * _GPU) here: everywhere but on rusticl, which takes the GPU path
 * (src/render/wavefront.c, kernel_path_pairs) and whose build of the CPU
 * path's program (-DSPT_BVH_PAIRS, the megakernel) runs past 10 minutes and
 * 3 GB in Mesa's own passes; PoCL and Intel's runtime test that path. */
static inline int test_kernel_path_here(int path)
{
    return path != SPT_KERNEL_PATH_CPU || !test_on_rusticl();
}

/* Scenes a and b (the same scene traced two ways: by reference and
 * flattened) render alike (assert_images_agree) at w x w, 8 samples, depth 5,
 * on the CPU path (megakernel and stages) and the GPU-shaped path (the
 * paths that run here: test_kernel_path_here). */
static inline void assert_renders_agree(const Scene *a, const Scene *b, int w)
{
    static const int paths[3][2] = {{SPT_KERNEL_PATH_CPU, 0}, {SPT_KERNEL_PATH_CPU, 1},
                                    {SPT_KERNEL_PATH_GPU, 0}};
    float *ia = malloc(sizeof(float) * 3 * w * w), *ib = malloc(sizeof(float) * 3 * w * w);
    for (int k = 0; k < 3; k++) {
        if (!test_kernel_path_here(paths[k][0]))
            continue;
        RenderSettings rs = square_settings(w, 8, 5, 7u);
        rs.test.kernel_path = paths[k][0];
        rs.test.stages = paths[k][1];
        SptError e = {0};
        if (render_scene_rgb(a, &rs, ia, &e) || render_scene_rgb(b, &rs, ib, &e))
            fail_msg("render: %s", e.msg);
        char what[64];
        snprintf(what, sizeof what, "path %d stages %d", paths[k][0], paths[k][1]);
        assert_images_agree(ia, ib, w, what);
    }
    free(ia);
    free(ib);
}

/* Scenes a and b (the same scene traced two ways) render alike where their
 * random streams differ, as when a's emitters are instances and b's
 * world-space triangles (the light selection's entries differ): at w x w,
 * spp samples, depth 5, on the CPU path (megakernel and stages) and the
 * GPU-shaped path (those that run here), a's and b's mean |difference| and worst 4x4 block within
 * 1.5 times (the block 1% more than) those of b rendered with two seeds:
 * a and b share every random number but the light picks', so their
 * difference is below two seeds' unless the scenes differ. */
static inline void assert_renders_agree_noisy(const Scene *a, const Scene *b, int w, int spp)
{
    static const int paths[3][2] = {{SPT_KERNEL_PATH_CPU, 0}, {SPT_KERNEL_PATH_CPU, 1},
                                    {SPT_KERNEL_PATH_GPU, 0}};
    size_t n = (size_t)3 * w * w;
    float *ia = malloc(sizeof(float) * n), *ib = malloc(sizeof(float) * n), *ic = malloc(sizeof(float) * n);
    for (int k = 0; k < 3; k++) {
        if (!test_kernel_path_here(paths[k][0]))
            continue;
        RenderSettings rs = square_settings(w, spp, 5, 7u), rs2 = square_settings(w, spp, 5, 8u);
        rs.test.kernel_path = rs2.test.kernel_path = paths[k][0];
        rs.test.stages = rs2.test.stages = paths[k][1];
        SptError e = {0};
        if (render_scene_rgb(a, &rs, ia, &e) || render_scene_rgb(b, &rs, ib, &e) ||
            render_scene_rgb(b, &rs2, ic, &e))
            fail_msg("render: %s", e.msg);
        double sum = 0, dab = 0, dbc = 0;
        for (size_t i = 0; i < n; i++) {
            sum += ib[i];
            dab += fabs((double)ia[i] - ib[i]);
            dbc += fabs((double)ic[i] - ib[i]);
        }
        double ba[48], bb[48], bc[48], wab = 0, wbc = 0;
        block_means_4x4(ia, w, ba);
        block_means_4x4(ib, w, bb);
        block_means_4x4(ic, w, bc);
        for (int i = 0; i < 48; i++) {
            wab = fmax(wab, fabs(ba[i] - bb[i]) / fmax(bb[i], 1e-3));
            wbc = fmax(wbc, fabs(bc[i] - bb[i]) / fmax(bb[i], 1e-3));
        }
        printf("path %d stages %d: mean |diff| %.3g%% (seeds %.3g%%), worst block %.3g%% (seeds %.3g%%)\n",
               paths[k][0], paths[k][1], 100 * dab / sum, 100 * dbc / sum, 100 * wab, 100 * wbc);
        assert_true(sum > 0);
        assert_true(dab < 1.5 * dbc);
        assert_true(wab < 1.5 * wbc + 0.01);
    }
    free(ia);
    free(ib);
    free(ic);
}

/* Grows s by n triangles of their own 3 vertices each (tri_vidx numbers them
 * in order; their normals and uvs zero, their positions and material to be
 * set); returns the first new triangle. */
static inline uint32_t grow_triangles(Scene *s, uint32_t n)
{
    uint32_t t0 = s->tri_count, v0 = s->vertex_count;
    s->tri_count += n;
    s->vertex_count += 3 * n;
    s->tri_pos = realloc(s->tri_pos, sizeof(float) * 9 * s->tri_count);
    s->tri_vidx = realloc(s->tri_vidx, sizeof(uint32_t) * 3 * s->tri_count);
    s->tri_mat = realloc(s->tri_mat, sizeof(uint32_t) * s->tri_count);
    s->vtx_normal = realloc(s->vtx_normal, sizeof(float) * 3 * s->vertex_count);
    s->vtx_uv = realloc(s->vtx_uv, sizeof(float) * 2 * s->vertex_count);
    for (uint32_t k = 0; k < 3 * n; k++) {
        s->tri_vidx[3 * t0 + k] = v0 + k;
        s->vtx_normal[3 * (v0 + k)] = s->vtx_normal[3 * (v0 + k) + 1] = s->vtx_normal[3 * (v0 + k) + 2] = 0;
        s->vtx_uv[2 * (v0 + k)] = s->vtx_uv[2 * (v0 + k) + 1] = 0;
    }
    return t0;
}

/* Appends a material of the glTF defaults (scene_material_default) to s for
 * the triangles from t0 on; returns it. */
static inline SceneMaterial *append_material(Scene *s, uint32_t t0)
{
    s->materials = realloc(s->materials, sizeof(SceneMaterial) * (s->material_count + 1));
    SceneMaterial *m = &s->materials[s->material_count];
    scene_material_default(m);
    for (uint32_t t = t0; t < s->tri_count; t++)
        s->tri_mat[t] = s->material_count;
    s->material_count++;
    return m;
}

/* Appends the quad with corners c[0..3] (counter-clockwise about its front
 * normal) as two triangles with a new Lambertian material (metallic 0, no
 * specular layer) to s; returns the material. */
static inline SceneMaterial *append_rect(Scene *s, const float c[4][3])
{
    uint32_t t0 = grow_triangles(s, 2);
    static const int order[6] = {0, 1, 2, 0, 2, 3};
    for (uint32_t k = 0; k < 6; k++)
        memcpy(s->tri_pos + 9 * t0 + 3 * k, c[order[k]], 3 * sizeof(float));
    SceneMaterial *m = append_material(s, t0);
    m->metallic = 0.0f;
    m->specular = 0.0f;
    return m;
}

/* Appends the quad y = height over [-6, 6]^2 (two triangles, facing +Y) with a
 * new material to s; returns the material. */
static inline SceneMaterial *append_quad(Scene *s, float height)
{
    const float c[4][3] = {{-6, height, -6}, {-6, height, 6}, {6, height, 6}, {6, height, -6}};
    return append_rect(s, c);
}

/* A new scene s of the grey (0.5) quad y = 0 (append_quad) alone; returns its
 * material. */
static inline SceneMaterial *grey_quad_scene(Scene *s)
{
    memset(s, 0, sizeof *s);
    SceneMaterial *m = append_quad(s, 0.0f);
    for (int k = 0; k < 3; k++)
        m->base_color[k] = 0.5f;
    return m;
}

/* Appends the box [lo, hi] (12 triangles, counter-clockwise seen from outside)
 * with a new material to s; returns the material. */
static inline SceneMaterial *append_box(Scene *s, const float lo[3], const float hi[3])
{
    uint32_t t0 = grow_triangles(s, 12);
    static const int quad[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
    uint32_t t = t0;
    for (int axis = 0; axis < 3; axis++)
        for (int sg = -1; sg <= 1; sg += 2) {
            int b = (axis + 1) % 3, c = (axis + 2) % 3;
            float q[4][3];
            for (int k = 0; k < 4; k++) {
                /* (b, c, axis) is right-handed: this order is counter-clockwise
                 * about +axis; the -axis face is reversed to face outward. */
                int kk = sg > 0 ? k : 3 - k;
                q[k][axis] = sg > 0 ? hi[axis] : lo[axis];
                q[k][b] = quad[kk][0] > 0 ? hi[b] : lo[b];
                q[k][c] = quad[kk][1] > 0 ? hi[c] : lo[c];
            }
            const int tri[2][3] = {{0, 1, 2}, {0, 2, 3}};
            for (int h = 0; h < 2; h++, t++)
                for (int k = 0; k < 3; k++)
                    memcpy(s->tri_pos + 9 * t + 3 * k, q[tri[h][k]], sizeof q[0]);
        }
    return append_material(s, t0);
}

/* Makes m clear smooth glass of index ior: white, transmission 1, roughness 0. */
static inline void set_clear_glass(SceneMaterial *m, float ior)
{
    m->metallic = 0.0f;
    m->roughness = 0.0f;
    m->transmission = 1.0f;
    m->ior = ior;
    for (int k = 0; k < 3; k++)
        m->base_color[k] = 1.0f;
}

/* Renders s with rs on the test device into film (initialised here), which
 * must come out finite. */
static inline void render_caustic_scene(const Scene *s, const RenderSettings *rs, Film *film)
{
    SptError e = {0};
    RenderStats st;
    int rc = render_film(s, rs, film, &st, &e);
    if (rc)
        fprintf(stderr, "render: %s\n", e.msg);
    assert_int_equal(rc, 0);
    assert_int_equal(film_nonfinite_pixels(film), 0);
}

/* Unpolarised Fresnel reflectance of an air-glass interface at incidence
 * cos_i from the air. */
static inline double fresnel(double cos_i, double n)
{
    double sin_t = sqrt(fmax(0.0, 1.0 - cos_i * cos_i)) / n, cos_t = sqrt(fmax(0.0, 1.0 - sin_t * sin_t));
    double rs = (cos_i - n * cos_t) / (cos_i + n * cos_t), rp = (n * cos_i - cos_t) / (n * cos_i + cos_t);
    return 0.5 * (rs * rs + rp * rp);
}

#endif
