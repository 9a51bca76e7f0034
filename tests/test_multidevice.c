/* Several devices in one process (issue "Scale"): PoCL exposes two CPU devices of
 * one compute unit each (POCL_DEVICES="pthread pthread", set before any OpenCL
 * call). The image must not depend on how the samples were split. */
#include "test_util.h"

#include <stdlib.h>
#include <string.h>

#include "cl/cl_device.h"
#include "render/film.h"
#include "film_test.h"
#include "render/render.h"
#include "scene/scene.h"

static ClDeviceList devices;
static const RenderTestHooks no_hooks, turns = {.take_turns = 1};
static Scene scene;
static GpuScene gpu;

static int setup(void **state)
{
    (void)state;
    SptError e = {0};
    if (cl_device_list(&devices, &e) || devices.count < 2) {
        fprintf(stderr, "need two PoCL devices: %s\n", e.msg);
        return -1;
    }
    if (scene_load_gltf(&scene, "scenes/cornell_box.gltf", &e) || gpu_scene_build(&gpu, &scene, &e)) {
        fprintf(stderr, "%s\n", e.msg);
        return -1;
    }
    return 0;
}

static int teardown(void **state)
{
    (void)state;
    gpu_scene_free(&gpu);
    scene_free(&scene);
    cl_device_list_free(&devices);
    return 0;
}

/* Photon merging (--merge) in render_on_aov's renders. */
static int multi_merge = SPT_SWITCH_OFF;

/* Renders the Cornell box at 24x24, 32 spp on the devices listed in `which`
 * with the test hooks hooks. */
static int render_on_aov(const int *which, int n, RenderTestHooks hooks, unsigned aov, Film *film,
                         RenderDeviceStats *per, SptError *e)
{
    const ClDeviceInfo *infos[4];
    for (int i = 0; i < n; i++)
        infos[i] = &devices.devices[which[i]];
    RenderSettings rs;
    memset(&rs, 0, sizeof rs);
    rs.width = rs.height = 24;
    rs.spp = 32;
    rs.max_depth = -1;
    rs.seed = 11;
    rs.pool_size = 512; /* small chunks: the work splits into many */
    rs.test = hooks;
    rs.merge = multi_merge;
    rs.aov = aov;
    rs.spectral = aov ? 47 : 0; /* the AOV test covers the spectral bands too */
    rs.sampler = aov ? SPT_SAMPLER_ZSOBOL : SPT_SAMPLER_SOBOL; /* and ZSobol */
    film_init_full(film, rs.width, rs.height, aov != 0, rs.spectral);
    RenderStats st;
    return render_devices(infos, n, &gpu, &scene.camera, &rs, film, &st, per, e);
}

static int render_on(const int *which, int n, RenderTestHooks hooks, Film *film,
                     RenderDeviceStats *per, SptError *e)
{
    return render_on_aov(which, n, hooks, 0, film, per, e);
}

/* The image of device 0 alone (one) and of devices 0 and 1 with the test hooks
 * (two; per: each device's share), with the layers aov; both renders must
 * succeed. */
static void render_one_and_two(RenderTestHooks hooks, unsigned aov, Film *one, Film *two,
                               RenderDeviceStats per[2])
{
    SptError e = {0};
    const int d0[1] = {0}, d01[2] = {0, 1};
    if (render_on_aov(d0, 1, no_hooks, aov, one, NULL, &e))
        fail_msg("device 0 alone: %s", e.msg);
    if (render_on_aov(d01, 2, hooks, aov, two, per, &e))
        fail_msg("devices 0 and 1: %s", e.msg);
}

TEST(test_split_invariance)
{
    Film one, two;
    RenderDeviceStats per[2];
    /* In turns, so that both devices render half of the samples however the
     * threads are scheduled. */
    render_one_and_two(turns, 0, &one, &two, per);
    printf("two devices: %u and %u spp\n", per[0].samples, per[1].samples);
    assert_int_equal(per[0].samples, 16);
    assert_int_equal(per[1].samples, 16);
    assert_same_film(&one, &two);
    film_free(&one);
    film_free(&two);
}

/* The same with photon merging: each device sorts the photons of its own
 * chunks, and a gather's sum does not depend on the chunk. */
TEST(test_split_invariance_merge)
{
    Film one, two;
    RenderDeviceStats per[2];
    multi_merge = SPT_SWITCH_ON;
    render_one_and_two(turns, 0, &one, &two, per);
    multi_merge = SPT_SWITCH_OFF;
    printf("two devices, --merge on: %u and %u spp\n", per[0].samples, per[1].samples);
    assert_int_equal(per[0].samples, 16);
    assert_int_equal(per[1].samples, 16);
    assert_same_film(&one, &two);
    film_free(&one);
    film_free(&two);
}

/* The AOV layers (--aov) and spectral bands (--spectral 47) of two devices
 * sharing the samples are those of one (with the ZSobol sampler). */
TEST(test_split_invariance_aov)
{
    Film one, two;
    RenderDeviceStats per[2];
    render_one_and_two(turns, SPT_AOV_ALL, &one, &two, per);
    assert_int_equal(per[0].samples, 16);
    assert_int_equal(per[1].samples, 16);
    assert_same_film(&one, &two);
    assert_same_aov_tol(&one, &two, 1e-4);
    assert_same_bands_tol(&one, &two, 1e-4);
    film_free(&one);
    film_free(&two);
}

/* A device slowed down by the test hook takes fewer chunks. */
TEST(test_balance)
{
    Film f;
    SptError e = {0};
    RenderDeviceStats per[2];
    const int d01[2] = {0, 1};
    const RenderTestHooks slow1 = {.slow_device = 1 + 1, .slow_ms = 300};
    int rc = render_on(d01, 2, slow1, &f, per, &e);
    assert_int_equal(rc, 0);
    printf("fast device %u spp, slowed device %u spp\n", per[0].samples, per[1].samples);
    assert_true(per[1].samples < per[0].samples);
    assert_int_equal(per[0].samples + per[1].samples, 32);
    film_free(&f);
}

/* A device failing after its first chunk is dropped; its chunk goes to the other
 * and the image equals the one-device image. */
TEST(test_device_failure)
{
    Film one, f;
    SptError e = {0};
    RenderDeviceStats per[2];
    /* Device 1 fails as it starts its second chunk; the devices take chunks in
     * turn, so it does come to its second. */
    const RenderTestHooks fail1 = {.fail_device = 1 + 1, .fail_after = 1, .take_turns = 1};
    render_one_and_two(fail1, 0, &one, &f, per);
    assert_true(per[1].failed);
    assert_false(per[0].failed);
    assert_same_film(&one, &f);
    film_free(&one);
    film_free(&f);
    /* Both failing: the render fails. */
    const RenderTestHooks fail0 = {.fail_device = 0 + 1, .fail_after = 0};
    const int d0only[1] = {0};
    assert_int_equal(render_on(d0only, 1, fail0, &f, per, &e), SPT_EXIT_DEVICE);
    film_free(&f);
}

/* One image from two OpenCL implementations (tests/run_tests.sh runs this file
 * with PoCL and another implementation visible: PoCL's two devices, then the
 * other's): PoCL alone and PoCL with the other implementation sharing the
 * samples give the same film, within 1e-3 of each pixel's largest channel.
 * Not bit for bit: OpenCL lets a compiler contract a*b + c into an FMA and
 * Intel's runtime does, so a sample's float roundings differ (one Cornell box
 * pixel of 24x24 differs by 1.2e-4, a grazing path's hit point moved by a
 * rounding). A sample that took another path, or a lost or doubled sample,
 * changes its pixel by about 1/32 (32 spp) and fails. Skipped when only PoCL is
 * visible. */
TEST(test_split_across_implementations)
{
    int other = -1;
    for (int i = 0; i < devices.count && other < 0; i++)
        if (strcmp(devices.devices[i].platform_name, devices.devices[0].platform_name) != 0)
            other = i;
    if (other < 0) {
        print_message("  one OpenCL implementation only (%s): skipped\n",
                      devices.devices[0].platform_name);
        skip();
    }
    Film one, two;
    SptError e = {0};
    RenderDeviceStats per[2];
    const int d0[1] = {0}, dboth[2] = {0, other};
    assert_int_equal(render_on(d0, 1, no_hooks, &one, NULL, &e), 0);
    /* In turns, so that the other implementation, slower to start, renders
     * half of the samples. */
    int rc = render_on(dboth, 2, turns, &two, per, &e);
    assert_int_equal(rc, 0);
    printf("%s: %u spp, %s: %u spp\n", devices.devices[0].platform_name, per[0].samples,
           devices.devices[other].platform_name, per[1].samples);
    assert_int_equal(per[0].samples + per[1].samples, 32);
    assert_true(per[0].samples > 0 && per[1].samples > 0);
    assert_same_film_tol(&one, &two, 1e-3);
    film_free(&one);
    film_free(&two);
}

/* Two PoCL CPU devices of one compute unit each; run for another implementation
 * (tests/run_tests.sh shows PoCL and it), only the test across the two: the
 * others ran on PoCL alone. */
static int two_devices(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    setenv("POCL_DEVICES", "pthread pthread", 1);
    setenv("POCL_MAX_PTHREAD_COUNT", "1", 1);
    const char *impl = getenv("SPECTRACE_TEST_IMPL");
    if (impl && strcmp(impl, "pocl") != 0)
        test_keep_only("test_split_across_implementations");
    return TEST_GO_ON;
}

TEST_MAIN_HOOK("multidevice", setup, teardown, two_devices)
