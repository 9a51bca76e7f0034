/* The library's C API (src/api/spectrace.h) against the command line: the same
 * scene and settings give the same image bit for bit, in one process or two
 * threads; changed materials equal the changed file; errors are the command
 * line's; the progress callback cancels. Each render is small (32 x 32, 4
 * samples) on the implementation's default device. */
#include <math.h>
#include <pthread.h>
#include <unistd.h>

#include "test_util.h"
#include "test_main.h"

#include "api/spectrace.h"
#include "denoise_test.h"
#include "io/exr.h"

#define BOX "scenes/cornell_box.gltf"
#define W 32

static spectrace_renderer *R;

static int setup(void **state)
{
    spectrace_error err;
    if (!(R = spectrace_renderer_open(NULL, &err))) {
        fprintf(stderr, "no device: %s\n", err.message);
        return -1;
    }
    return test_dir_setup(state);
}

static int teardown(void **state)
{
    spectrace_renderer_close(R);
    return test_dir_teardown(state);
}

/* Settings from "name=value" words. */
static spectrace_settings *settings(const char *const *kv)
{
    spectrace_settings *s = spectrace_settings_new();
    spectrace_error err;
    for (; *kv; kv++) {
        char name[64];
        const char *eq = strchr(*kv, '=');
        snprintf(name, sizeof name, "%.*s", (int)(eq - *kv), *kv);
        if (spectrace_settings_set(s, name, eq + 1, &err))
            fail_msg("%s: %s", *kv, err.message);
    }
    return s;
}

static const char *const base_kv[] = {"width=32", "spp=4", "seed=7", "caustics=off", NULL};

static spectrace_scene *load_or_fail(const char *path, const spectrace_settings *st)
{
    spectrace_error err;
    spectrace_scene *s = spectrace_scene_load(path, st, &err);
    if (!s)
        fail_msg("%s: %s", path, err.message);
    return s;
}

static spectrace_image *render_or_fail(spectrace_renderer *r, spectrace_scene *s, const spectrace_settings *st)
{
    spectrace_image *img;
    spectrace_error err;
    if (spectrace_render(r, s, st, NULL, NULL, &img, &err))
        fail_msg("render: %s", err.message);
    return img;
}

static float *rgb_of(const spectrace_image *img)
{
    size_t n = (size_t)spectrace_image_width(img) * spectrace_image_height(img) * 3;
    float *rgb = malloc(n * sizeof(float));
    assert_non_null(rgb);
    spectrace_image_rgb(img, rgb);
    return rgb;
}

/* The EXR channel called name of the file at path, compared with want (stride
 * floats per pixel) bit for bit. */
static void assert_channel_is(const ExrLayers *L, const char *name, const float *want, int stride)
{
    for (int c = 0; c < L->channel_count; c++) {
        if (strcmp(L->channels[c].name, name))
            continue;
        const float *got = L->channels[c].data;
        for (int i = 0; i < L->width * L->height; i++)
            if (memcmp(&got[i], &want[(size_t)i * stride], sizeof(float)))
                fail_msg("channel %s, pixel %d: the command line's %.9g, the library's %.9g", name, i,
                         (double)got[i], (double)want[(size_t)i * stride]);
        return;
    }
    fail_msg("no channel %s", name);
}

/* The command line's render of scene with args into path, read back. */
static void cli_render(const char *scene, const char *args, const char *path, ExrLayers *L)
{
    char cmd[2048], err[4096];
    snprintf(cmd, sizeof cmd, "render %s --width 32 --spp 4 --seed 7 --caustics off %s -q -o %s", scene,
             args, path);
    /* A kernel build on rusticl takes minutes on a loaded machine. */
    if (test_run_exe("", 1800, cmd, err, sizeof err))
        fail_msg("spectrace %s: %s", cmd, err);
    SptError e = {0};
    if (exr_read_layers(path, NULL, 0, L, &e))
        fail_msg("%s: %s", path, e.msg);
}

/* The image, its AOV layers and spectral bands equal the command line's bit
 * for bit, and the library's EXR holds the same channels. */
TEST(test_api_equals_command_line)
{
    /* The AOV and spectral kernels take rusticl over 15 minutes to build;
     * test_api_two_scenes_in_one_process compares the plain image there. */
    skip_if_quick();
    static const char *const kv[] = {"width=32", "spp=4", "seed=7", "caustics=off", "aov=albedo,Z",
                                     "spectral=4", NULL};
    spectrace_settings *st = settings(kv);
    spectrace_error err;
    spectrace_scene *s = load_or_fail(BOX, st);
    spectrace_image *img = render_or_fail(R, s, st);
    assert_int_equal(spectrace_image_width(img), W);
    assert_int_equal(spectrace_image_height(img), W); /* the box's camera is square */
    assert_int_equal(spectrace_image_spp(img), 4);
    float *rgb = rgb_of(img), *albedo = malloc(W * W * 3 * sizeof(float)), *z = malloc(W * W * 3 * sizeof(float));
    float *bands = malloc(W * W * 4 * sizeof(float)), *counts = malloc(W * W * sizeof(float));
    assert_int_equal(spectrace_image_aov(img, "albedo", albedo, &err), 3);
    assert_int_equal(spectrace_image_aov(img, "Z", z, &err), 1);
    assert_int_equal(spectrace_image_aov(img, "N", z, &err), -SPECTRACE_ERR_USAGE); /* not asked for */
    assert_int_equal(spectrace_image_band_count(img), 4);
    spectrace_image_bands(img, bands);
    spectrace_image_counts(img, counts);
    for (int i = 0; i < W * W; i++)
        assert_true(counts[i] == 4.0f);
    ExrLayers L;
    cli_render(BOX, "--aov albedo,Z --spectral 4", test_path("cli.exr"), &L);
    static const char *const rgbn[] = {"R", "G", "B"}, *const albn[] = {"albedo.R", "albedo.G", "albedo.B"};
    for (int c = 0; c < 3; c++) {
        assert_channel_is(&L, rgbn[c], rgb + c, 3);
        assert_channel_is(&L, albn[c], albedo + c, 3);
    }
    assert_channel_is(&L, "Z", z, 1);
    assert_channel_is(&L, "S0.418,750000nm", bands + 0, 4);
    assert_channel_is(&L, "S0.771,250000nm", bands + 3, 4);
    /* The library's own EXR: the same channels, the same values. */
    if (spectrace_image_write(img, test_path("api.exr"), &err))
        fail_msg("%s", err.message);
    ExrLayers M;
    SptError e = {0};
    if (exr_read_layers(test_path("api.exr"), NULL, 0, &M, &e))
        fail_msg("%s", e.msg);
    assert_int_equal(M.channel_count, L.channel_count);
    for (int c = 0; c < L.channel_count; c++)
        assert_channel_is(&M, L.channels[c].name, L.channels[c].data, 1);
    /* And the command line's metadata (src/render/render_result.h): each key
     * with the same value, the render's own seconds aside. */
    size_t na, nc;
    char *api = test_slurp(test_path("api.exr"), &na), *cli = test_slurp(test_path("cli.exr"), &nc);
    static const char *const keys[] = {"spectrace:max_depth", "spectrace:nan_dropped", "spectrace:seed",
                                       "spectrace:spp", "spectrace:device", "spectrace:scene"};
    for (size_t k = 0; k < sizeof keys / sizeof keys[0]; k++) {
        const char *a = memmem(api, na, keys[k], strlen(keys[k]) + 1);
        const char *c = memmem(cli, nc, keys[k], strlen(keys[k]) + 1);
        if (!a || !c)
            fail_msg("%s: in the library's EXR %d, the command line's %d", keys[k], !!a, !!c);
        /* name, type name, 4-byte size, value */
        a += strlen(keys[k]) + 1;
        c += strlen(keys[k]) + 1;
        a += strlen(a) + 1;
        c += strlen(c) + 1;
        int32_t sa, sc;
        memcpy(&sa, a, 4);
        memcpy(&sc, c, 4);
        assert_int_equal(sa, sc);
        assert_memory_equal(a + 4, c + 4, (size_t)sa);
    }
    free(api);
    free(cli);
    exr_layers_free(&L);
    exr_layers_free(&M);
    free(rgb);
    free(albedo);
    free(z);
    free(bands);
    free(counts);
    spectrace_image_free(img);
    spectrace_scene_free(s);
    spectrace_settings_free(st);
}

/* Two scenes one after the other in one process, the first again after the
 * second, and each equal to its command-line render (a separate process). */
TEST(test_api_two_scenes_in_one_process)
{
    const char *files[2] = {BOX, SPT_TEST_DATA("scenes/caustic_sphere_area.gltf")};
    spectrace_settings *st = settings(base_kv);
    spectrace_error err;
    float *first[2];
    for (int k = 0; k < 3; k++) {
        spectrace_scene *s = spectrace_scene_load(files[k % 2], st, &err);
        if (!s)
            fail_msg("%s", err.message);
        spectrace_image *img = render_or_fail(R, s, st);
        float *rgb = rgb_of(img);
        if (k < 2) {
            first[k] = rgb;
            ExrLayers L;
            cli_render(files[k], "", test_path("cli2.exr"), &L);
            static const char *const rgbn[] = {"R", "G", "B"};
            for (int c = 0; c < 3; c++)
                assert_channel_is(&L, rgbn[c], rgb + c, 3);
            exr_layers_free(&L);
        } else {
            assert_memory_equal(rgb, first[0], W * W * 3 * sizeof(float));
            free(rgb);
        }
        spectrace_image_free(img);
        spectrace_scene_free(s);
    }
    free(first[0]);
    free(first[1]);
    spectrace_settings_free(st);
}

typedef struct ThreadJob {
    const char *file;
    float *rgb;
    char error[1100];
} ThreadJob;

static void *thread_render(void *arg)
{
    ThreadJob *j = arg;
    spectrace_error err;
    spectrace_renderer *r = spectrace_renderer_open(NULL, &err);
    spectrace_settings *st = spectrace_settings_new();
    spectrace_settings_set(st, "width", "32", NULL);
    spectrace_settings_set(st, "spp", "4", NULL);
    spectrace_settings_set(st, "seed", "7", NULL);
    spectrace_settings_set(st, "caustics", "off", NULL);
    spectrace_scene *s = r ? spectrace_scene_load(j->file, st, &err) : NULL;
    spectrace_image *img = NULL;
    if (s && !spectrace_render(r, s, st, NULL, NULL, &img, &err)) {
        j->rgb = malloc(W * W * 3 * sizeof(float));
        spectrace_image_rgb(img, j->rgb);
    } else {
        snprintf(j->error, sizeof j->error, "%s: %s", j->file, err.message);
    }
    spectrace_image_free(img);
    spectrace_scene_free(s);
    spectrace_settings_free(st);
    spectrace_renderer_close(r);
    return NULL;
}

/* Two renderers in two threads at once give the images of one at a time. */
TEST(test_api_two_threads)
{
    ThreadJob jobs[2] = {{BOX, NULL, ""}, {SPT_TEST_DATA("scenes/caustic_sphere_area.gltf"), NULL, ""}};
    float *alone[2];
    for (int k = 0; k < 2; k++) {
        thread_render(&jobs[k]);
        if (!jobs[k].rgb)
            fail_msg("%s", jobs[k].error);
        alone[k] = jobs[k].rgb;
        jobs[k].rgb = NULL;
    }
    pthread_t t[2];
    for (int k = 0; k < 2; k++)
        assert_int_equal(pthread_create(&t[k], NULL, thread_render, &jobs[k]), 0);
    for (int k = 0; k < 2; k++)
        pthread_join(t[k], NULL);
    for (int k = 0; k < 2; k++) {
        if (!jobs[k].rgb)
            fail_msg("%s", jobs[k].error);
        assert_memory_equal(jobs[k].rgb, alone[k], W * W * 3 * sizeof(float));
        free(jobs[k].rgb);
        free(alone[k]);
    }
}

/* A material changed between renders: the glass's roughness set to 0.3 gives
 * the command line's image of the file with that roughness; back to the
 * file's value gives the first image again. */
TEST(test_api_material_changes)
{
    spectrace_settings *st = settings(base_kv);
    spectrace_error err;
    spectrace_scene *s = load_or_fail(BOX, st);
    int glass = spectrace_scene_material_find(s, "dispersive_glass"), light = spectrace_scene_material_find(s, "light");
    assert_true(glass >= 0 && light >= 0);
    assert_int_equal(spectrace_scene_material_find(s, "no such"), -1);
    spectrace_image *img = render_or_fail(R, s, st);
    float *before = rgb_of(img);
    spectrace_image_free(img);

    float v[4], rough = 0.3f;
    assert_int_equal(spectrace_scene_material_get(s, glass, "roughness", v, &err), 1);
    assert_true(v[0] == 0.0f);
    assert_int_equal(spectrace_scene_material_set(s, glass, "roughness", &rough, 1, &err), 0);
    img = render_or_fail(R, s, st);
    float *rough_rgb = rgb_of(img);
    spectrace_image_free(img);
    test_copy_replacing(BOX, "\"metallicFactor\": 0.0,\n    \"roughnessFactor\": 0.0\n",
                        "\"metallicFactor\": 0.0,\n    \"roughnessFactor\": 0.3\n", test_path("rough.gltf"));
    ExrLayers L;
    cli_render(test_path("rough.gltf"), "", test_path("rough.exr"), &L);
    static const char *const rgbn[] = {"R", "G", "B"};
    for (int c = 0; c < 3; c++)
        assert_channel_is(&L, rgbn[c], rough_rgb + c, 3);
    exr_layers_free(&L);
    assert_memory_not_equal(rough_rgb, before, W * W * 3 * sizeof(float));

    float zero = 0.0f;
    assert_int_equal(spectrace_scene_material_set(s, glass, "roughness", &zero, 1, &err), 0);
    img = render_or_fail(R, s, st);
    float *again = rgb_of(img);
    spectrace_image_free(img);
    assert_memory_equal(again, before, W * W * 3 * sizeof(float));

    /* Bad parameters: named errors, nothing changed. */
    float big = 2.0f;
    assert_int_equal(spectrace_scene_material_set(s, glass, "roughness", &big, 1, &err), SPECTRACE_ERR_USAGE);
    assert_non_null(strstr(err.message, "dispersive_glass: roughness 2 is outside [0, 1]"));
    assert_int_equal(spectrace_scene_material_set(s, glass, "roughness", v, 2, &err), SPECTRACE_ERR_USAGE);
    assert_int_equal(spectrace_scene_material_set(s, glass, "shininess", v, 1, &err), SPECTRACE_ERR_USAGE);
    assert_int_equal(spectrace_scene_material_set(s, 99, "roughness", v, 1, &err), SPECTRACE_ERR_USAGE);
    assert_int_equal(spectrace_scene_material_get(s, glass, "roughness", v, &err), 1);
    assert_true(v[0] == 0.0f);
    free(before);
    free(rough_rgb);
    free(again);
    spectrace_scene_free(s);
    spectrace_settings_free(st);
}

/* The sweep of the issue (docs/api.md, "Speed: a sweep in one process"): 20
 * roughness values of one material rendered from one scene load build the
 * program once and upload the geometry once per device, and the materials at
 * every change; each image equals that of a scene loaded fresh with its
 * roughness (so no stale buffer is kept). Another kernel specialisation (AOVs)
 * builds the program again but keeps the geometry on the device; another size
 * builds and uploads nothing. */
static void render_fresh_at(float rough, const spectrace_settings *st, const float *want)
{
    spectrace_error err;
    spectrace_scene *s = load_or_fail(BOX, st);
    int glass = spectrace_scene_material_find(s, "dispersive_glass");
    assert_int_equal(spectrace_scene_material_set(s, glass, "roughness", &rough, 1, &err), 0);
    spectrace_image *img = render_or_fail(R, s, st);
    float *rgb = rgb_of(img);
    size_t n = (size_t)spectrace_image_width(img) * spectrace_image_height(img) * 3;
    assert_memory_equal(rgb, want, n * sizeof(float));
    free(rgb);
    spectrace_image_free(img);
    spectrace_scene_free(s);
}

TEST(test_api_sweep_keeps_device_state)
{
    spectrace_settings *st = settings(base_kv);
    spectrace_error err;
    spectrace_scene *s = load_or_fail(BOX, st);
    int glass = spectrace_scene_material_find(s, "dispersive_glass");
    int ndev = spectrace_renderer_device_count(R);
    float *kept[20];
    for (int k = 0; k < 20; k++) {
        float rough = (float)k / 19.0f;
        assert_int_equal(spectrace_scene_material_set(s, glass, "roughness", &rough, 1, &err), 0);
        spectrace_image *img = render_or_fail(R, s, st);
        kept[k] = rgb_of(img);
        spectrace_image_free(img);
    }
    spectrace_scene_stats sst;
    spectrace_scene_stats_get(s, &sst);
    assert_int_equal(sst.renders, 20);
    assert_int_equal(sst.bvh_builds, 1);
    assert_int_equal(sst.program_builds, ndev);
    assert_int_equal(sst.geometry_uploads, ndev);
    assert_int_equal(sst.material_uploads, 20 * ndev);
    /* Neighbouring roughness values give other images, each that of a fresh
     * scene. */
    assert_memory_not_equal(kept[6], kept[7], W * W * 3 * sizeof(float));
    render_fresh_at(7.0f / 19.0f, st, kept[7]);
    render_fresh_at(1.0f, st, kept[19]);

    /* AOVs: another program, the same geometry on the device (not in the
     * quick form: rusticl takes over 15 minutes to build the AOV kernels). */
    spectrace_settings *next = spectrace_settings_copy(st);
    int builds = ndev, renders = 20;
    if (!test_quick()) {
        assert_int_equal(spectrace_settings_set(next, "aov", "albedo", &err), 0);
        spectrace_image *img = render_or_fail(R, s, next);
        float *with_aov = rgb_of(img);
        spectrace_image_free(img);
        spectrace_scene_stats_get(s, &sst);
        builds += ndev;
        renders++;
        assert_int_equal(sst.program_builds, builds);
        assert_int_equal(sst.geometry_uploads, ndev);
        assert_int_equal(sst.material_uploads, 20 * ndev);
        render_fresh_at(1.0f, next, with_aov);
        free(with_aov);
    }

    /* Another size: nothing built or uploaded. */
    assert_int_equal(spectrace_settings_set(next, "width", "24", &err), 0);
    spectrace_image *img = render_or_fail(R, s, next);
    assert_int_equal(spectrace_image_width(img), 24);
    spectrace_image_free(img);
    spectrace_scene_stats_get(s, &sst);
    assert_int_equal(sst.renders, renders + 1);
    assert_int_equal(sst.program_builds, builds);
    assert_int_equal(sst.geometry_uploads, ndev);
    assert_int_equal(sst.material_uploads, 20 * ndev);
    for (int k = 0; k < 20; k++)
        free(kept[k]);
    spectrace_settings_free(next);
    spectrace_scene_free(s);
    spectrace_settings_free(st);
}

/* A spectrum as (nm, value) pairs replaces the file's: the light's emission
 * set to the file's own samples renders the same image, and to twice them
 * twice the image (one emitter: the light choice and every path stay, each
 * contribution doubles exactly, up to float rounding). */
TEST(test_api_spectrum_changes)
{
    spectrace_settings *st = settings(base_kv);
    spectrace_error err;
    spectrace_scene *s = load_or_fail(BOX, st);
    int light = spectrace_scene_material_find(s, "light");
    spectrace_image *img = render_or_fail(R, s, st);
    float *before = rgb_of(img);
    spectrace_image_free(img);
    double nm[4] = {400, 500, 600, 700}, same[4] = {0, 8, 15.6, 18.4}, twice[4] = {0, 16, 31.2, 36.8};
    assert_int_equal(spectrace_scene_material_set_spectrum(s, light, "emission", nm, same, 4, &err), 0);
    img = render_or_fail(R, s, st);
    float *rgb = rgb_of(img);
    spectrace_image_free(img);
    assert_memory_equal(rgb, before, W * W * 3 * sizeof(float));
    free(rgb);
    assert_int_equal(spectrace_scene_material_set_spectrum(s, light, "emission", nm, twice, 4, &err), 0);
    img = render_or_fail(R, s, st);
    rgb = rgb_of(img);
    spectrace_image_free(img);
    for (int i = 0; i < W * W * 3; i++)
        assert_close_rel(rgb[i], 2.0 * before[i], 1e-5);
    double bad[4] = {0, -1, 1, 1};
    assert_int_equal(spectrace_scene_material_set_spectrum(s, light, "emission", nm, bad, 4, &err),
                     SPECTRACE_ERR_USAGE);
    assert_int_equal(spectrace_scene_material_set_spectrum(s, light, "glow", nm, same, 4, &err),
                     SPECTRACE_ERR_USAGE);
    free(rgb);
    free(before);
    spectrace_scene_free(s);
    spectrace_settings_free(st);
}

/* A punctual light's intensity doubled doubles the image (a spot light, the
 * only light: as above); its colour set to black leaves only the sky. */
TEST(test_api_light_changes)
{
    spectrace_settings *st = settings(base_kv);
    spectrace_error err;
    spectrace_scene *s = spectrace_scene_load(SPT_TEST_DATA("scenes/caustic_sphere.gltf"), st, &err);
    if (!s)
        fail_msg("%s", err.message);
    assert_int_equal(spectrace_scene_light_count(s), 1);
    spectrace_image *img = render_or_fail(R, s, st);
    float *before = rgb_of(img);
    spectrace_image_free(img);
    float intensity, twice;
    assert_int_equal(spectrace_scene_light_get(s, 0, "intensity", &intensity, &err), 1);
    assert_true(intensity > 0);
    twice = 2 * intensity;
    assert_int_equal(spectrace_scene_light_set(s, 0, "intensity", &twice, 1, &err), 0);
    img = render_or_fail(R, s, st);
    float *rgb = rgb_of(img);
    spectrace_image_free(img);
    double sum = 0;
    for (int i = 0; i < W * W * 3; i++) {
        assert_close_rel(rgb[i], 2.0 * before[i], 1e-5);
        sum += before[i];
    }
    assert_true(sum > 0);
    float neg = -1;
    assert_int_equal(spectrace_scene_light_set(s, 0, "intensity", &neg, 1, &err), SPECTRACE_ERR_USAGE);
    assert_int_equal(spectrace_scene_light_set(s, 3, "intensity", &twice, 1, &err), SPECTRACE_ERR_USAGE);
    free(rgb);
    free(before);
    spectrace_scene_free(s);
    spectrace_settings_free(st);
}

/* Settings by name as the command line's options, with its messages. */
TEST(test_api_settings)
{
    spectrace_settings *st = spectrace_settings_new();
    spectrace_error err;
    char v[256];
    assert_int_equal(spectrace_settings_get(st, "spp", v, sizeof v, &err), 0);
    assert_string_equal(v, "16");
    assert_int_equal(spectrace_settings_get(st, "sampler", v, sizeof v, &err), 0);
    assert_string_equal(v, "sobol");
    assert_int_equal(spectrace_settings_set_int(st, "max-depth", 8, &err), 0);
    assert_int_equal(spectrace_settings_get(st, "max-depth", v, sizeof v, &err), 0);
    assert_string_equal(v, "8");
    assert_int_equal(spectrace_settings_set_double(st, "light-paths", 0.5, &err), 0);
    assert_int_equal(spectrace_settings_get(st, "light-paths", v, sizeof v, &err), 0);
    assert_string_equal(v, "0.5");
    assert_int_equal(spectrace_settings_set(st, "aov", "z,ALBEDO", &err), 0);
    assert_int_equal(spectrace_settings_get(st, "aov", v, sizeof v, &err), 0);
    assert_string_equal(v, "albedo,Z");
    assert_int_equal(spectrace_settings_set(st, "profile", "on", &err), 0);
    assert_int_equal(spectrace_settings_get(st, "profile", v, sizeof v, &err), 0);
    assert_string_equal(v, "1");
    /* A bad value: the command line's message, and the setting as it was. */
    char out[4096];
    assert_int_equal(test_run_exe("", 60, "render " BOX " --spp 0", out, sizeof out), SPECTRACE_ERR_USAGE);
    assert_int_equal(spectrace_settings_set(st, "spp", "0", &err), SPECTRACE_ERR_USAGE);
    assert_int_equal(err.code, SPECTRACE_ERR_USAGE);
    char want[1100];
    snprintf(want, sizeof want, "error: %s\n", err.message);
    assert_string_equal(out, want);
    assert_int_equal(spectrace_settings_get(st, "spp", v, sizeof v, &err), 0);
    assert_string_equal(v, "16");
    assert_int_equal(spectrace_settings_set(st, "no-such", "1", &err), SPECTRACE_ERR_USAGE);
    assert_int_equal(spectrace_settings_set(st, "output", "x.png", &err), SPECTRACE_ERR_USAGE);
    assert_int_equal(spectrace_settings_set(st, "at", "soon", &err), SPECTRACE_ERR_USAGE);
    /* Every option of the list is named, with a kind. */
    int n = spectrace_settings_count(), seen_spp = 0;
    assert_true(n > 20);
    for (int i = 0; i < n; i++) {
        assert_non_null(spectrace_settings_kind(i));
        seen_spp += !strcmp(spectrace_settings_name(i), "spp") && !strcmp(spectrace_settings_kind(i), "int");
    }
    assert_int_equal(seen_spp, 1);
    spectrace_settings *copy = spectrace_settings_copy(st);
    assert_int_equal(spectrace_settings_get(copy, "aov", v, sizeof v, &err), 0);
    assert_string_equal(v, "albedo,Z");
    spectrace_settings_free(copy);
    spectrace_settings_free(st);
}

/* A missing file: the command line's error line and code. */
TEST(test_api_load_errors)
{
    spectrace_error err;
    assert_null(spectrace_scene_load("no/such.gltf", NULL, &err));
    char out[4096], want[1100];
    assert_int_equal(test_run_exe("", 60, "render no/such.gltf", out, sizeof out), err.code);
    assert_int_equal(err.code, SPECTRACE_ERR_INPUT);
    snprintf(want, sizeof want, "error: %s\n", err.message);
    assert_string_equal(out, want);
    /* The pose is the scene's: a render with another camera is refused. */
    spectrace_scene *s = spectrace_scene_load(BOX, NULL, &err);
    assert_non_null(s);
    spectrace_settings *st = spectrace_settings_new();
    spectrace_settings_set(st, "camera", "0", &err);
    spectrace_image *img;
    assert_int_equal(spectrace_render(R, s, st, NULL, NULL, &img, &err), SPECTRACE_ERR_USAGE);
    assert_null(img);
    spectrace_settings_free(st);
    spectrace_scene_free(s);
}

/* The scene from its bytes renders as from its file. */
TEST(test_api_scene_from_memory)
{
    size_t n;
    char *bytes = test_slurp(BOX, &n);
    spectrace_error err;
    spectrace_scene *a = spectrace_scene_load_memory(bytes, n, "scenes", &err);
    if (!a)
        fail_msg("%s", err.message);
    spectrace_scene *b = spectrace_scene_load(BOX, NULL, &err);
    spectrace_settings *st = settings(base_kv);
    spectrace_image *ia = render_or_fail(R, a, st), *ib = render_or_fail(R, b, st);
    float *ra = rgb_of(ia), *rb = rgb_of(ib);
    assert_memory_equal(ra, rb, W * W * 3 * sizeof(float));
    free(ra);
    free(rb);
    free(bytes);
    spectrace_image_free(ia);
    spectrace_image_free(ib);
    spectrace_scene_free(a);
    spectrace_scene_free(b);
    spectrace_settings_free(st);
    assert_null(spectrace_scene_load_memory("{", 1, NULL, &err));
    assert_int_equal(err.code, SPECTRACE_ERR_INPUT);
}

/* denoise: the library's image is the command line's --denoise image bit for
 * bit, denoised and noisy (noisy_rgb, the EXR's noisy layer), and its EXR
 * holds the same channels. */
TEST(test_api_denoise)
{
    /* The denoiser's guides are AOVs, whose kernels take rusticl over 15
     * minutes to build (as in test_api_equals_command_line). */
    skip_if_quick();
    Denoiser probe;
    oidn_probe(&probe);
    if (have_oidn)
        denoiser_close(&probe);
    need_oidn();
    static const char *const kv[] = {"width=32", "spp=4", "seed=7", "caustics=off", "denoise=true", NULL};
    spectrace_settings *st = settings(kv);
    spectrace_error err;
    spectrace_scene *s = load_or_fail(BOX, st);
    spectrace_image *img = render_or_fail(R, s, st);
    float *rgb = rgb_of(img), *noisy = malloc(W * W * 3 * sizeof(float));
    assert_non_null(noisy);
    spectrace_image_noisy_rgb(img, noisy);
    assert_memory_not_equal(rgb, noisy, W * W * 3 * sizeof(float));
    ExrLayers L, M;
    cli_render(BOX, "--denoise", test_path("den-cli.exr"), &L);
    static const char *const rgbn[] = {"R", "G", "B"}, *const noisyn[] = {"noisy.R", "noisy.G", "noisy.B"};
    for (int c = 0; c < 3; c++) {
        assert_channel_is(&L, rgbn[c], rgb + c, 3);
        assert_channel_is(&L, noisyn[c], noisy + c, 3);
    }
    if (spectrace_image_write(img, test_path("den-api.exr"), &err))
        fail_msg("%s", err.message);
    SptError e = {0};
    if (exr_read_layers(test_path("den-api.exr"), NULL, 0, &M, &e))
        fail_msg("%s", e.msg);
    assert_int_equal(M.channel_count, L.channel_count);
    for (int c = 0; c < L.channel_count; c++)
        assert_channel_is(&M, L.channels[c].name, L.channels[c].data, 1);
    exr_layers_free(&L);
    exr_layers_free(&M);
    free(rgb);
    free(noisy);
    spectrace_image_free(img);
    spectrace_scene_free(s);
    spectrace_settings_free(st);
}

/* A scene from bytes posed as asked: the turntable at 0.5 s from its bytes is
 * the file loaded at 0.5 s, bit for bit, and not its rest pose; a render of
 * it asking for another pose is refused. */
TEST(test_api_scene_from_memory_posed)
{
    /* kv + 1: the same without the pose. */
    static const char *const kv[] = {"at=0.5", "width=16", "spp=2", "seed=7", "caustics=off",
                                     "max-depth=3", NULL};
    const char *path = SPT_TEST_DATA("anim/turntable.gltf");
    size_t n;
    char *bytes = test_slurp(path, &n);
    spectrace_settings *st = settings(kv), *rest = settings(kv + 1);
    spectrace_error err;
    spectrace_scene *a = spectrace_scene_load_memory_posed(bytes, n, SPT_TEST_DATA("anim"), st, &err);
    if (!a)
        fail_msg("%s", err.message);
    spectrace_scene *b = load_or_fail(path, st);
    spectrace_scene *c = spectrace_scene_load_memory(bytes, n, SPT_TEST_DATA("anim"), &err);
    assert_non_null(c);
    spectrace_image *ia = render_or_fail(R, a, st), *ib = render_or_fail(R, b, st), *ic = render_or_fail(R, c, rest);
    float *ra = rgb_of(ia), *rb = rgb_of(ib), *rc = rgb_of(ic);
    size_t bytes_rgb = (size_t)spectrace_image_width(ia) * spectrace_image_height(ia) * 3 * sizeof(float);
    assert_memory_equal(ra, rb, bytes_rgb);
    assert_memory_not_equal(ra, rc, bytes_rgb);
    spectrace_image *none;
    assert_int_equal(spectrace_render(R, a, rest, NULL, NULL, &none, &err), SPECTRACE_ERR_USAGE);
    assert_non_null(strstr(err.message, "differ from the pose the scene was loaded in"));
    free(ra);
    free(rb);
    free(rc);
    free(bytes);
    spectrace_image_free(ia);
    spectrace_image_free(ib);
    spectrace_image_free(ic);
    spectrace_scene_free(a);
    spectrace_scene_free(b);
    spectrace_scene_free(c);
    spectrace_settings_free(st);
    spectrace_settings_free(rest);
}

typedef struct Calls {
    int n;
    uint32_t last, total;
    int bad;
} Calls;

static int stop_at_first(void *user, uint32_t done, uint32_t total)
{
    Calls *c = user;
    c->bad |= done <= c->last || done > total;
    c->n++;
    c->last = done;
    c->total = total;
    return 1;
}

static int count_calls(void *user, uint32_t done, uint32_t total)
{
    Calls *c = user;
    c->bad |= done <= c->last || done > total;
    c->n++;
    c->last = done;
    c->total = total;
    return 0;
}

/* The progress callback sees the samples grow to the total, and stops the
 * render when it returns non-zero. */
TEST(test_api_progress_and_cancel)
{
    static const char *const kv[] = {"width=32", "spp=64", "seed=7", "caustics=off", NULL};
    spectrace_settings *st = settings(kv);
    spectrace_error err;
    spectrace_scene *s = spectrace_scene_load(BOX, st, &err);
    assert_non_null(s);
    Calls c = {0, 0, 0, 0};
    spectrace_image *img;
    assert_int_equal(spectrace_render(R, s, st, count_calls, &c, &img, &err), 0);
    assert_false(c.bad);
    assert_true(c.n >= 1);
    assert_int_equal(c.last, 64);
    assert_int_equal(c.total, 64);
    spectrace_image_free(img);
    memset(&c, 0, sizeof c);
    assert_int_equal(spectrace_render(R, s, st, stop_at_first, &c, &img, &err), SPECTRACE_ERR_CANCELLED);
    assert_null(img);
    assert_int_equal(c.n, 1);
    assert_non_null(strstr(err.message, "stopped by the progress callback"));
    spectrace_scene_free(s);
    spectrace_settings_free(st);
}

/* A render larger than the memory allows is refused before any allocation
 * (SPECTRACE_MAX_MEMORY_MB sets the limit, as for the command line), and a
 * render given seconds without samples renders whole samples until then. */
TEST(test_api_memory_and_time)
{
    spectrace_error err;
    spectrace_scene *s = spectrace_scene_load(BOX, NULL, &err);
    assert_non_null(s);
    static const char *const big[] = {"width=4096", "spectral=470", NULL};
    spectrace_settings *st = settings(big);
    spectrace_image *img;
    setenv("SPECTRACE_MAX_MEMORY_MB", "256", 1);
    assert_int_equal(spectrace_render(R, s, st, NULL, NULL, &img, &err), SPECTRACE_ERR_DEVICE);
    unsetenv("SPECTRACE_MAX_MEMORY_MB");
    assert_null(img);
    assert_non_null(strstr(err.message, "render: a 4096x4096 render needs about"));
    spectrace_settings_free(st);
    static const char *const timed[] = {"width=16", "time=0.5", "caustics=off", NULL};
    st = settings(timed);
    assert_int_equal(spectrace_render(R, s, st, NULL, NULL, &img, &err), 0);
    assert_true(spectrace_image_spp(img) >= 1);
    assert_true(spectrace_image_spp(img) < (1 << 24));
    spectrace_image_free(img);
    spectrace_settings_free(st);
    spectrace_scene_free(s);
}

/* spectrace_color prints what `spectrace color` prints. */
TEST(test_api_color)
{
    static const char *const spds[] = {"D65", "A", "blackbody:3000", "mercury"};
    for (size_t k = 0; k < sizeof spds / sizeof spds[0]; k++) {
        spectrace_color_info c;
        spectrace_error err;
        assert_int_equal(spectrace_color(spds[k], NULL, NULL, 0, 0, &c, &err), 0);
        char args[128], out[1024], want[1024];
        snprintf(args, sizeof args, "color %s", spds[k]);
        assert_int_equal(test_spectrace("", 60, args, TEST_STDOUT, out, sizeof out), 0);
        snprintf(want, sizeof want, "XYZ %.6f %.6f %.6f\nlinear-sRGB %.6f %.6f %.6f\nsRGB8 %d %d %d\n", c.xyz[0],
                 c.xyz[1], c.xyz[2], c.linear_srgb[0], c.linear_srgb[1], c.linear_srgb[2], c.srgb8[0],
                 c.srgb8[1], c.srgb8[2]);
        assert_string_equal(out, want);
        assert_close(c.x + c.y, (c.xyz[0] + c.xyz[1]) / (c.xyz[0] + c.xyz[1] + c.xyz[2]), 1e-12);
    }
    /* Samples: a flat spectrum is illuminant E, x = y = 1/3. */
    double nm[2] = {360, 830}, v[2] = {1, 1};
    spectrace_color_info c;
    assert_int_equal(spectrace_color(NULL, nm, v, 2, 0, &c, NULL), 0);
    assert_close(c.x, 1.0 / 3.0, 2e-4);
    assert_close(c.y, 1.0 / 3.0, 2e-4);
    spectrace_error err;
    assert_int_equal(spectrace_color("no-such-spd", NULL, NULL, 0, 0, &c, &err), SPECTRACE_ERR_INPUT);
}

/* The library's steps as the command line takes them (since 1.2): outputs
 * checked against the scene's inputs, the devices named, the memory estimate,
 * a render stopped by its stop flag that keeps its samples, its outputs and
 * final checkpoint written together, and the resumed render equal to the
 * uninterrupted one bit for bit. */
#define SPP 8

/* The settings of the steps' tests (8 samples: one per chunk), with a
 * checkpoint and a resumed checkpoint in test_dir() where named. */
static spectrace_settings *step_settings(const char *checkpoint_name, const char *resume_name)
{
    spectrace_settings *s = spectrace_settings_new();
    spectrace_error err;
    static const char *const kv[][2] = {{"width", "32"}, {"spp", "8"}, {"seed", "7"}, {"caustics", "off"}};
    for (size_t i = 0; i < sizeof kv / sizeof kv[0]; i++)
        if (spectrace_settings_set(s, kv[i][0], kv[i][1], &err))
            fail_msg("%s: %s", kv[i][0], err.message);
    if (checkpoint_name && spectrace_settings_set(s, "checkpoint", test_path(checkpoint_name), &err))
        fail_msg("checkpoint: %s", err.message);
    if (resume_name && spectrace_settings_set(s, "resume", test_path(resume_name), &err))
        fail_msg("resume: %s", err.message);
    return s;
}

/* The progress seen: its calls, the last figures, whether the samples or the
 * paths ever went back; it asks to stop once stop_at samples are done. */
typedef struct Seen {
    int n, bad;
    spectrace_progress_info last;
    uint32_t stop_at;
} Seen;

static int watch(void *user, const spectrace_progress_info *p)
{
    Seen *s = user;
    s->bad |= p->done > p->total || p->elapsed < 0 ||
              (s->n && (p->done <= s->last.done || p->paths < s->last.paths));
    s->n++;
    s->last = *p;
    return s->stop_at && p->done >= s->stop_at;
}

/* Outputs that would replace the scene file, or each other, are refused with
 * the command line's messages; others pass. */
TEST(test_api_steps_check_outputs)
{
    spectrace_error err;
    spectrace_settings *st = step_settings("ck.exr", NULL);
    spectrace_scene *s = spectrace_scene_load(BOX, st, &err);
    assert_non_null(s);
    const char *scene_out[] = {test_path("a.exr"), "./" BOX};
    assert_int_equal(spectrace_scene_check_outputs(s, st, scene_out, 2, &err), SPECTRACE_ERR_USAGE);
    assert_non_null(strstr(err.message, "this output is the input file " BOX));
    char again[4096];
    snprintf(again, sizeof again, "%s/./a.exr", test_dir());
    const char *twice[] = {test_path("a.exr"), again};
    assert_int_equal(spectrace_scene_check_outputs(s, st, twice, 2, &err), SPECTRACE_ERR_USAGE);
    assert_non_null(strstr(err.message, "name the same file"));
    const char *ck_too[] = {test_path("ck.exr")};
    assert_int_equal(spectrace_scene_check_outputs(s, st, ck_too, 1, &err), SPECTRACE_ERR_USAGE);
    assert_non_null(strstr(err.message, "--checkpoint"));
    const char *fine[] = {test_path("a.exr"), test_path("b.png")};
    assert_int_equal(spectrace_scene_check_outputs(s, st, fine, 2, &err), 0);
    spectrace_scene_free(s);
    spectrace_settings_free(st);
}

/* A device's figures are those of its name; the memory estimate adds up as
 * docs/limits.md says (the film, then the larger of the render's and the
 * outputs'), and an output not written as EXR costs 16 bytes a pixel more. */
TEST(test_api_steps_devices_and_memory)
{
    spectrace_error err;
    spectrace_device_info d;
    assert_int_equal(spectrace_renderer_device_info(R, 0, &d, &err), 0);
    char name[1100];
    snprintf(name, sizeof name, "%s (%s)", d.name, d.platform);
    assert_string_equal(name, spectrace_renderer_device_name(R, 0));
    assert_true(d.index >= 0 && d.driver && d.driver[0]);
    assert_int_equal(spectrace_renderer_device_info(R, spectrace_renderer_device_count(R), &d, &err),
                     SPECTRACE_ERR_USAGE);
    spectrace_settings *st = step_settings(NULL, NULL);
    spectrace_scene *s = spectrace_scene_load(BOX, st, &err);
    assert_non_null(s);
    const char *exr[] = {test_path("a.exr")}, *png[] = {test_path("a.exr"), test_path("a.png")};
    spectrace_memory m1, m2;
    assert_int_equal(spectrace_render_prepare(R, s, st, exr, 1, &m1, &err), 0);
    assert_int_equal(spectrace_render_prepare(R, s, st, png, 2, &m2, &err), 0);
    assert_true(m1.film > 0 && m1.loaded > 0 && m1.render > 0);
    assert_true(m1.need == m1.film + (m1.render > m1.outputs ? m1.render : m1.outputs));
    assert_true(m2.outputs == m1.outputs + 32.0 * 32.0 * 16.0);
    assert_true(m2.film == m1.film && m2.loaded == m1.loaded);
    spectrace_scene_free(s);
    spectrace_settings_free(st);
}

/* A render stopped through its stop flag keeps its samples (keep_stopped),
 * its outputs and deferred final checkpoint are written together, and the
 * render resumed from that checkpoint equals the uninterrupted one bit for
 * bit; the progress figures grow and end at the render's. */
TEST(test_api_steps_stop_write_resume)
{
    spectrace_error err;
    spectrace_settings *plain = step_settings(NULL, NULL);
    spectrace_scene *s = spectrace_scene_load(BOX, plain, &err);
    assert_non_null(s);
    Seen seen = {0};
    spectrace_render_options o = {watch, &seen, NULL, 0, 0, 0};
    spectrace_image *full;
    assert_int_equal(spectrace_render_with(R, s, plain, &o, &full, &err), 0);
    spectrace_render_stats fs;
    spectrace_image_stats(full, &fs);
    assert_false(seen.bad);
    assert_int_equal(seen.last.done, SPP);
    assert_int_equal(seen.last.total, SPP);
    assert_true(seen.last.paths == (double)fs.paths && fs.paths > 0);
    assert_true(fs.spp_done == SPP && !fs.stopped && !fs.spp_resumed && !fs.checkpoint);
    float *want = rgb_of(full);

    spectrace_settings *ck = step_settings("ck.exr", NULL);
    volatile sig_atomic_t stop = 0;
    Seen part = {0, 0, {0}, 3};
    spectrace_render_options keep = {watch, &part, &stop, 1, 0, 1};
    spectrace_image *img;
    assert_int_equal(spectrace_render_with(R, s, ck, &keep, &img, &err), 0);
    spectrace_render_stats ps;
    spectrace_image_stats(img, &ps);
    assert_int_equal(stop, 1);
    assert_true(ps.stopped && ps.spp_done >= 3 && ps.spp_done < SPP);
    assert_string_equal(ps.checkpoint, test_path("ck.exr"));
    assert_int_equal(ps.checkpoint_spp, ps.spp_done);
    assert_int_equal(access(test_path("ck.exr"), F_OK), -1); /* deferred to the outputs */
    const char *outs[] = {test_path("part.exr"), test_path("part.png")};
    assert_int_equal(spectrace_image_write_outputs(img, outs, 2, &err), 0);
    assert_int_equal(access(test_path("ck.exr"), F_OK), 0);
    assert_int_equal(access(test_path("part.png"), F_OK), 0);
    spectrace_image_free(img);

    spectrace_settings *rs = step_settings(NULL, "ck.exr");
    spectrace_image *resumed;
    assert_int_equal(spectrace_render(R, s, rs, NULL, NULL, &resumed, &err), 0);
    spectrace_render_stats rst;
    spectrace_image_stats(resumed, &rst);
    assert_int_equal(rst.spp_resumed, ps.spp_done);
    assert_int_equal(spectrace_image_spp(resumed), SPP);
    float *got = rgb_of(resumed);
    assert_memory_equal(got, want, 32 * 32 * 3 * sizeof(float));
    free(got);
    free(want);
    spectrace_image_free(resumed);
    spectrace_image_free(full);
    spectrace_settings_free(rs);
    spectrace_settings_free(ck);
    spectrace_settings_free(plain);
    spectrace_scene_free(s);
}

#define TURNTABLE SPT_TEST_DATA("anim/turntable.gltf")

/* image's linear sRGB and XYZ equal want's bit for bit. */
static void assert_same_image(const spectrace_image *image, const spectrace_image *want)
{
    size_t n = (size_t)spectrace_image_width(want) * spectrace_image_height(want) * 3;
    assert_int_equal(spectrace_image_width(image), spectrace_image_width(want));
    assert_int_equal(spectrace_image_height(image), spectrace_image_height(want));
    float *a = malloc(n * sizeof(float)), *b = malloc(n * sizeof(float));
    assert_non_null(a);
    assert_non_null(b);
    spectrace_image_rgb(image, a);
    spectrace_image_rgb(want, b);
    assert_memory_equal(a, b, n * sizeof(float));
    spectrace_image_xyz(image, a);
    spectrace_image_xyz(want, b);
    assert_memory_equal(a, b, n * sizeof(float));
    free(a);
    free(b);
}

/* A frame sequence through the API (docs/api.md, "Frame sequences"): the
 * turntable (tests/data/anim/turntable.gltf, a 1 s turn) loaded at 0 s and
 * set to frame 3 at 24 frames per second (0.125 s) renders frame 3 of the
 * command line's --frames 0:3 bit for bit, with the BVH refitted and no
 * program built again; its first image differs; a render asking for the old
 * time is refused. With the BVH built anew (the test hook
 * SPECTRACE_TEST_BVH_REBUILD) it is a fresh load at 0.125 s, bit for bit (a
 * refitted tree keeps the first pose's triangle order, which changes the
 * noise: tests/test_frames.c). */
TEST(test_api_set_time)
{
    static const char *const kv0[] = {"at=0", "width=32", "spp=4", "seed=7", "caustics=off", NULL};
    static const char *const kv3[] = {"at=0.125", "width=32", "spp=4", "seed=7", "caustics=off", NULL};
    spectrace_settings *s0 = settings(kv0), *s3 = settings(kv3);
    spectrace_error err;
    spectrace_scene *s = load_or_fail(TURNTABLE, s0);
    assert_true(spectrace_scene_time(s) == 0.0);
    spectrace_image *i0 = render_or_fail(R, s, s0);
    spectrace_scene_stats st0, st3;
    spectrace_scene_timing tm;
    spectrace_scene_stats_get(s, &st0);
    spectrace_scene_timing_get(s, &tm);
    assert_int_equal(tm.bvh_refitted, 0);
    assert_int_equal(st0.bvh_builds, 1);
    if (spectrace_scene_set_time(s, 3.0 / 24.0, &err))
        fail_msg("%s", err.message);
    assert_true(spectrace_scene_time(s) == 0.125);
    spectrace_image *none;
    assert_int_equal(spectrace_render(R, s, s0, NULL, NULL, &none, &err), SPECTRACE_ERR_USAGE);
    spectrace_image *i3 = render_or_fail(R, s, s3);
    spectrace_scene_stats_get(s, &st3);
    spectrace_scene_timing_get(s, &tm);
    assert_int_equal(tm.bvh_refitted, 1);
    assert_int_equal(tm.bvh_refits, 1);
    assert_int_equal(st3.bvh_builds, 1);
    assert_int_equal(st3.program_builds, st0.program_builds);
    assert_int_equal(st3.renders, 2);
    spectrace_scene *fresh = load_or_fail(TURNTABLE, s3);
    spectrace_image *f3 = render_or_fail(R, fresh, s3);
    setenv("SPECTRACE_TEST_BVH_REBUILD", "1", 1);
    if (spectrace_scene_set_time(s, 0.125, &err))
        fail_msg("%s", err.message);
    spectrace_image *b3 = render_or_fail(R, s, s3);
    unsetenv("SPECTRACE_TEST_BVH_REBUILD");
    spectrace_scene_timing_get(s, &tm);
    assert_int_equal(tm.bvh_refitted, 0);
    assert_same_image(b3, f3);
    spectrace_image_free(b3);
    float *rgb0 = rgb_of(i0), *rgb3 = rgb_of(i3);
    assert_memory_not_equal(rgb0, rgb3, (size_t)W * W * 3 * sizeof(float));
    /* The command line's frame 3 of four. */
    char cmd[2048], out[8192];
    snprintf(cmd, sizeof cmd, "render %s --frames 0:3 --width 32 --spp 4 --seed 7 --caustics off -q "
             "-o %s", TURNTABLE, test_path("frame_#.exr"));
    if (test_run_exe("", 1800, cmd, out, sizeof out))
        fail_msg("spectrace %s: %s", cmd, out);
    ExrLayers L;
    SptError e = {0};
    if (exr_read_layers(test_path("frame_3.exr"), NULL, 0, &L, &e))
        fail_msg("%s", e.msg);
    static const char *const rgbn[] = {"R", "G", "B"};
    for (int c = 0; c < 3; c++)
        assert_channel_is(&L, rgbn[c], rgb3 + c, 3);
    exr_layers_free(&L);
    free(rgb0);
    free(rgb3);
    spectrace_image_free(i0);
    spectrace_image_free(i3);
    spectrace_image_free(f3);
    spectrace_scene_free(s);
    spectrace_scene_free(fresh);
    spectrace_settings_free(s0);
    spectrace_settings_free(s3);
}

/* spectrace_scene_set_time refuses a time that is not finite, and a scene
 * whose file is gone stays as it was (its image the same bit for bit); a
 * scene from bytes is posed again from them (equal to the file loaded at that
 * time); the file's animations are the turntable's two, each of one channel
 * keyed from 0 to 1 s (its accessors' min and max). */
TEST(test_api_set_time_errors_memory_animations)
{
    static const char *const kv[] = {"at=0.25", "width=16", "spp=2", "seed=7", "caustics=off",
                                     "max-depth=3", NULL};
    spectrace_settings *st = settings(kv);
    spectrace_error err;
    size_t n;
    char *bytes = test_slurp(TURNTABLE, &n);
    FILE *f = fopen(test_path("copy.gltf"), "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(bytes, 1, n, f), n);
    fclose(f);
    spectrace_scene *s = load_or_fail(test_path("copy.gltf"), st);
    spectrace_image *before = render_or_fail(R, s, st);
    assert_int_equal(spectrace_scene_set_time(s, NAN, &err), SPECTRACE_ERR_USAGE);
    assert_int_equal(unlink(test_path("copy.gltf")), 0);
    assert_int_equal(spectrace_scene_set_time(s, 0.5, &err), SPECTRACE_ERR_INPUT);
    assert_non_null(strstr(err.message, "copy.gltf"));
    assert_true(spectrace_scene_time(s) == 0.25);
    spectrace_image *after = render_or_fail(R, s, st);
    assert_same_image(after, before);
    /* From bytes, posed at 0.25 s, then at 0.5 s. */
    spectrace_scene *m = spectrace_scene_load_memory_posed(bytes, n, SPT_TEST_DATA("anim"), st, &err);
    if (!m)
        fail_msg("%s", err.message);
    if (spectrace_scene_set_time(m, 0.5, &err))
        fail_msg("%s", err.message);
    spectrace_settings_set(st, "at", "0.5", NULL);
    spectrace_scene *file = load_or_fail(TURNTABLE, st);
    spectrace_image *im = render_or_fail(R, m, st), *ifile = render_or_fail(R, file, st);
    assert_same_image(im, ifile);
    /* The animations. */
    assert_int_equal(spectrace_scene_animation_count(file), 2);
    static const char *const names[] = {"turn", "orbit"};
    for (int i = 0; i < 2; i++) {
        spectrace_animation_info a;
        assert_int_equal(spectrace_scene_animation_info(file, i, &a, &err), 0);
        assert_string_equal(a.name, names[i]);
        assert_true(a.start == 0.0 && a.end == 1.0);
        assert_int_equal(a.channels, 1);
    }
    spectrace_animation_info a;
    assert_int_equal(spectrace_scene_animation_info(file, 2, &a, &err), SPECTRACE_ERR_USAGE);
    free(bytes);
    spectrace_image_free(before);
    spectrace_image_free(after);
    spectrace_image_free(im);
    spectrace_image_free(ifile);
    spectrace_scene_free(s);
    spectrace_scene_free(m);
    spectrace_scene_free(file);
    spectrace_settings_free(st);
}

/* The instancing setting reaches the loader: off flattens the scene's
 * repeated meshes into world-space triangles, which take more memory than
 * the meshes placed by reference (docs/gltf.md, "Instancing"). */
TEST(test_api_instancing_setting)
{
    const char *path = SPT_TEST_DATA("scenes/instancing.gltf");
    static const char *const off[] = {"instancing=off", "width=16", NULL};
    static const char *const on[] = {"instancing=on", "width=16", NULL};
    spectrace_settings *so = settings(off), *sn = settings(on);
    spectrace_scene *a = load_or_fail(path, so), *b = load_or_fail(path, sn);
    spectrace_memory ma, mb;
    spectrace_error err;
    assert_int_equal(spectrace_render_prepare(R, a, so, NULL, 0, &ma, &err), 0);
    assert_int_equal(spectrace_render_prepare(R, b, sn, NULL, 0, &mb, &err), 0);
    if (!(ma.loaded > mb.loaded))
        fail_msg("loaded: %g bytes flattened, %g placed by reference", ma.loaded, mb.loaded);
    spectrace_scene_free(a);
    spectrace_scene_free(b);
    spectrace_settings_free(so);
    spectrace_settings_free(sn);
}

TEST_MAIN("api", setup, teardown)
