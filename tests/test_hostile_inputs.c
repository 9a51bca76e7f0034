/* Hostile and unusual inputs to the command line and the glTF loader (issue 35,
 * "Inputs and messages"): values a float cannot carry, option values in any case,
 * implementation names as device selections, glTF values outside the ranges the
 * specification gives, a sky that lights nothing, messages that name the object,
 * and files the Khronos glTF-Validator reports valid. Each refusal is one
 * `error:` line with the documented exit code (README.md, "Exit codes"). The
 * command-line cases run $SPECTRACE_EXE (set by tests/run_tests.sh) under
 * `timeout`; the loader cases call the library. */
#include "test_util.h"

#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "cl/cl_device.h"
#include "api/render_args.h"
#include "io/image_in.h"
#include "render/render_options.h"
#include "scene/scene.h"

#define TINY "--width 8 --spp 1 -q --device 0"


/* `timeout 120 $SPECTRACE_EXE args`, stdout discarded, stderr into err. */
static int run_exe(const char *args, char *err, size_t cap)
{
    return test_run_exe("", 120, args, err, cap);
}

/* text is exactly one line, "error: ..." containing want. */
static void one_error(const char *what, const char *text, const char *want)
{
    const char *nl = strchr(text, '\n');
    if (strncmp(text, "error: ", 7) != 0 || !nl || nl[1] != 0)
        fail_msg("%s: expected one error line, got:\n%s", what, text);
    if (want && !strstr(text, want))
        fail_msg("%s: expected '%s' in: %s", what, want, text);
}

/* A triangle (0,0,0), (1,0,0), (0,1,0) of material 0, MATERIAL being the JSON of
 * that material; EXTRA more top-level members (with a leading comma, or ""). */
#define TRIANGLE_GLTF(MATERIAL, EXTRA)                                                          \
    "{\"asset\":{\"version\":\"2.0\"},\"scene\":0,\"scenes\":[{\"nodes\":[0]}],"              \
    "\"nodes\":[{\"mesh\":0}],\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0}," \
    "\"indices\":1,\"material\":0}]}],\"materials\":[" MATERIAL "],"                          \
    "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\"," \
    "\"min\":[0,0,0],\"max\":[1,1,0]},"                                                       \
    "{\"bufferView\":1,\"componentType\":5123,\"count\":3,\"type\":\"SCALAR\"}],"             \
    "\"bufferViews\":[{\"buffer\":0,\"byteLength\":36},"                                      \
    "{\"buffer\":0,\"byteOffset\":36,\"byteLength\":6}],"                                     \
    "\"buffers\":[{\"byteLength\":44,\"uri\":\"data:application/octet-stream;base64,"       \
    "AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAAAAABAAIAAAA=\"}]" EXTRA "}"

/* Loads JSON text as NAME; returns the exit code, the message in e. */
static int load_text(Scene *s, const char *json, SptError *e)
{
    memset(e, 0, sizeof *e);
    return scene_load_gltf_memory(s, json, strlen(json), "hostile.gltf", e);
}

/* The loader refuses json as bad input with a message that contains want. */
static void assert_refused(const char *json, const char *want)
{
    Scene s;
    SptError e;
    assert_int_equal(load_text(&s, json, &e), SPT_EXIT_INPUT);
    if (!strstr(e.msg, want))
        fail_msg("expected '%s', got '%s'", want, e.msg);
}

/* The triangle loads: one triangle, its bounds (0,0,0)..(1,1,0). */
static void assert_triangle(const Scene *s, unsigned tris)
{
    assert_int_equal(s->tri_count, tris);
    assert_close(s->bounds_min[0], 0, 0);
    assert_close(s->bounds_min[1], 0, 0);
    assert_close(s->bounds_max[0], 1, 0);
    assert_close(s->bounds_max[1], 1, 0);
    assert_close(s->bounds_max[2], 0, 0);
}

/* Case 10: a float option's value that turns into 0 or infinity as a 32-bit float
 * (what the kernels get) is refused naming the option and the value: 1e-46 passed
 * "> 0" as a double and became 0, which for --light-paths means the default 2. */
TEST(test_float_options_hold_their_value)
{
    static const char *const bad[][2] = {
        {"--light-paths 1e-46", "--light-paths '1e-46'"},
        {"--light-paths 1e-300", "--light-paths '1e-300'"},
        {"--focus-distance 1e-300", "--focus-distance '1e-300'"},
        {"--aperture 1e-40", "--aperture '1e-40'"},
        {"--env-intensity 1e39", "--env-intensity '1e39'"},
        {"--env-rotation -1e300", "--env-rotation '-1e300'"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        char args[1024], err[8192];
        snprintf(args, sizeof args, "render tests/data/scenes/furnace.gltf " TINY " -o %s/x.png %s",
                 test_dir(), bad[i][0]);
        int rc = run_exe(args, err, sizeof err);
        if (rc != SPT_EXIT_USAGE)
            fail_msg("`%s`: exit %d, expected %d; stderr:\n%s", bad[i][0], rc, SPT_EXIT_USAGE, err);
        one_error(bad[i][0], err, bad[i][1]);
    }
    /* A small value the float holds is kept as given. */
    RenderArgs a;
    char *argv[] = {"render", "--light-paths", "1e-30", "--aperture", "0", "s.gltf"};
    assert_int_equal(render_args_parse(&a, 6, argv), SPT_EXIT_OK);
    assert_true(a.rs.light_paths == 1e-30f);
    assert_true(a.rs.aperture == 0.0f);
}

/* Case 14: option values are case-insensitive throughout (README.md, "Rendering"):
 * --sampler SOBOL was accepted while --caustics ON was refused. */
TEST(test_option_values_any_case)
{
    RenderArgs a;
    char *argv[] = {"render", "--caustics", "ON",  "--adaptive", "Off", "--sampler", "SOBOL",
                    "--tonemap", "NEUTRAL", "--aov", "ALBEDO,n", "s.gltf"};
    int rc = render_args_parse(&a, 12, argv);
    if (rc) fail_msg("refused (%d)", rc);
    assert_int_equal(a.rs.caustics, SPT_SWITCH_ON);
    assert_int_equal(a.rs.adaptive, SPT_SWITCH_OFF);
    RenderArgs b;
    char *lower[] = {"render", "--caustics", "on",  "--adaptive", "off", "--sampler", "sobol",
                     "--tonemap", "neutral", "--aov", "albedo,N", "s.gltf"};
    assert_int_equal(render_args_parse(&b, 12, lower), SPT_EXIT_OK);
    assert_int_equal(a.rs.sampler, b.rs.sampler);
    assert_int_equal(a.rs.aov, b.rs.aov);
    assert_int_equal(a.tonemap, b.tonemap);
}

/* Case 11: an implementation's name selects only its devices. PoCL's device on
 * an Intel CPU has "Intel" in its name and vendor, and `--device intel` rendered
 * on it when Intel's runtime was absent. */
TEST(test_device_implementation_name)
{
    ClDeviceInfo d = {0};
    snprintf(d.platform_name, sizeof d.platform_name, "Portable Computing Language");
    snprintf(d.impl, sizeof d.impl, "pocl");
    snprintf(d.name, sizeof d.name, "cpu-haswell-Intel(R) Xeon(R) CPU");
    snprintf(d.vendor, sizeof d.vendor, "GenuineIntel");
    d.type = CL_DEVICE_TYPE_CPU;
    ClDeviceList list = {&d, 1};
    int out[1], n = 0;
    SptError e = {0};
    int rc = cl_device_select(&list, "intel", out, &n, &e);
    if (rc != SPT_EXIT_DEVICE) fail_msg("'intel' selected %d device(s) (rc %d)", n, rc);
    if (!strstr(e.msg, "no device of the OpenCL implementation 'intel'")) fail_msg("%s", e.msg);
    assert_int_equal(cl_device_select(&list, "pocl", out, &n, &e), SPT_EXIT_OK);
    assert_int_equal(cl_device_select(&list, "xeon", out, &n, &e), SPT_EXIT_OK);

    /* The program, with only PoCL visible, then (where installed) with Intel's
     * runtime beside it: `devices --device intel` marks a device of impl intel. */
    const char *exe = test_exe();
    char cmd[2048], outp[16384];
    snprintf(cmd, sizeof cmd,
             "eval \"$(tools/opencl_env.sh pocl %s/icd-pocl)\" && timeout -s KILL 60 '%s' devices "
             "--device intel 2>&1 >/dev/null",
             test_dir(), exe);
    rc = test_sh(cmd, TEST_BOTH, outp, sizeof outp);
    if (rc != SPT_EXIT_DEVICE) fail_msg("PoCL alone: exit %d, expected 4:\n%s", rc, outp);
    one_error("PoCL alone", outp, "implementation 'intel'");
    char probe[1024];
    snprintf(cmd, sizeof cmd, "tools/opencl_env.sh pocl,intel %s/icd-both >/dev/null", test_dir());
    if (test_sh(cmd, TEST_BOTH, probe, sizeof probe) != 0) {
        print_message("  the case with Intel's runtime left out, not installed: %s", probe);
        skip();
    }
    snprintf(cmd, sizeof cmd,
             "eval \"$(tools/opencl_env.sh pocl,intel %s/icd-both)\" && timeout -s KILL 60 '%s' "
             "devices --device intel 2>/dev/null",
             test_dir(), exe);
    rc = test_sh(cmd, TEST_BOTH, outp, sizeof outp);
    if (rc) fail_msg("PoCL and Intel: exit %d:\n%s", rc, outp);
    /* The marked device's platform line is the last one before it. */
    const char *mark = strstr(outp, " *[");
    if (!mark) fail_msg("no device marked:\n%s", outp);
    const char *plat = NULL;
    for (const char *p = strstr(outp, "platform "); p && p < mark; p = strstr(p + 1, "platform "))
        plat = p;
    if (!plat || !strstr(plat, ", impl intel\n") || strstr(plat, ", impl intel\n") > mark)
        fail_msg("the marked device is not Intel's:\n%s", outp);
}

/* Case 14: values outside the range the glTF specification or the extension
 * gives are refused with the object and the value named (a clearcoatFactor of
 * -1 was clamped to 0: a black coat without a word); the range's ends load. */
TEST(test_gltf_out_of_range_values)
{
    static const struct {
        const char *material, *want;
    } bad[] = {
        {"{\"extensions\":{\"KHR_materials_clearcoat\":{\"clearcoatFactor\":-1}}}",
         "materials[0].extensions.KHR_materials_clearcoat.clearcoatFactor: -1 is outside [0, 1]"},
        {"{\"extensions\":{\"KHR_materials_clearcoat\":{\"clearcoatFactor\":1,"
         "\"clearcoatRoughnessFactor\":-1}}}",
         "KHR_materials_clearcoat.clearcoatRoughnessFactor: -1 is outside"},
        {"{\"extensions\":{\"KHR_materials_volume\":{\"attenuationColor\":[1,-0.5,1]}}}",
         "KHR_materials_volume.attenuationColor[1]: -0.5 is outside"},
        {"{\"pbrMetallicRoughness\":{\"baseColorFactor\":[1,1,2,1]}}",
         "pbrMetallicRoughness.baseColorFactor[2]: 2 is outside"},
        {"{\"pbrMetallicRoughness\":{\"metallicFactor\":1.5}}", "metallicFactor: 1.5 is outside"},
        {"{\"pbrMetallicRoughness\":{\"roughnessFactor\":-0.25}}",
         "roughnessFactor: -0.25 is outside"},
        {"{\"emissiveFactor\":[0,3,0]}", "materials[0].emissiveFactor[1]: 3 is outside"},
        {"{\"extensions\":{\"KHR_materials_transmission\":{\"transmissionFactor\":1.01}}}",
         "transmissionFactor: 1.01 is outside"},
        {"{\"extensions\":{\"KHR_materials_specular\":{\"specularFactor\":2}}}",
         "specularFactor: 2 is outside"},
        {"{\"extensions\":{\"KHR_materials_sheen\":{\"sheenColorFactor\":[0,0,-1]}}}",
         "sheenColorFactor[2]: -1 is outside"},
        {"{\"extensions\":{\"KHR_materials_sheen\":{\"sheenRoughnessFactor\":7}}}",
         "sheenRoughnessFactor: 7 is outside"},
        {"{\"extensions\":{\"KHR_materials_iridescence\":{\"iridescenceFactor\":1.5}}}",
         "KHR_materials_iridescence.iridescenceFactor: 1.5 is outside [0, 1]"},
        {"{\"extensions\":{\"KHR_materials_iridescence\":{\"iridescenceIor\":0.5}}}",
         "KHR_materials_iridescence.iridescenceIor: 0.5 is below 1"},
        {"{\"extensions\":{\"KHR_materials_iridescence\":{\"iridescenceThicknessMinimum\":-1}}}",
         "KHR_materials_iridescence.iridescenceThicknessMinimum: -1 is negative"},
        {"{\"extensions\":{\"KHR_materials_iridescence\":{\"iridescenceThicknessMaximum\":-2}}}",
         "KHR_materials_iridescence.iridescenceThicknessMaximum: -2 is negative"},
        {"{\"extensions\":{\"KHR_materials_pbrSpecularGlossiness\":{\"glossinessFactor\":-1}}}",
         "glossinessFactor: -1 is outside"},
        {"{\"extensions\":{\"KHR_materials_pbrSpecularGlossiness\":{\"diffuseFactor\":[1,1,1,"
         "1.5]}}}",
         "diffuseFactor[3]: 1.5 is outside"},
        /* A number written as a string was replaced by the default unnoticed. */
        {"{\"pbrMetallicRoughness\":{\"metallicFactor\":\"0\"}}",
         "materials[0].pbrMetallicRoughness.metallicFactor: \"0\" is not a number"},
    };
    static char json[8192];
    Scene s;
    SptError e;
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        snprintf(json, sizeof json, TRIANGLE_GLTF("%s", ""), bad[i].material);
        int rc = load_text(&s, json, &e);
        if (rc != SPT_EXIT_INPUT)
            fail_msg("%s: loaded (%d), expected a refusal naming '%s'", bad[i].material, rc,
                     bad[i].want);
        if (!strstr(e.msg, bad[i].want)) fail_msg("expected '%s' in: %s", bad[i].want, e.msg);
    }
    /* A light's colour, which KHR_lights_punctual bounds to [0, 1] too. */
    snprintf(json, sizeof json, "%s",
             TRIANGLE_GLTF("{}", ",\"extensions\":{\"KHR_lights_punctual\":{\"lights\":[{"
                                 "\"type\":\"point\",\"color\":[1,2,1]}]}}"));
    char *node = strstr(json, "{\"mesh\":0}");
    assert_non_null(node);
    const char *lit = "{\"mesh\":0,\"extensions\":{\"KHR_lights_punctual\":{\"light\":0}}}";
    memmove(node + strlen(lit), node + 10, strlen(node + 10) + 1);
    memcpy(node, lit, strlen(lit));
    assert_refused(json, "KHR_lights_punctual.lights[0].color[1]: 2 is outside [0, 1]");
    static const char *const ends[] = {
        "{\"pbrMetallicRoughness\":{\"baseColorFactor\":[0,1,0,1],\"metallicFactor\":1,"
        "\"roughnessFactor\":0},\"emissiveFactor\":[1,0,1],\"extensions\":{"
        "\"KHR_materials_clearcoat\":{\"clearcoatFactor\":1,\"clearcoatRoughnessFactor\":0},"
        "\"KHR_materials_volume\":{\"attenuationColor\":[0,1,0.5]},"
        "\"KHR_materials_specular\":{\"specularFactor\":0},"
        "\"KHR_materials_sheen\":{\"sheenColorFactor\":[1,1,0],\"sheenRoughnessFactor\":1},"
        "\"KHR_materials_transmission\":{\"transmissionFactor\":1},"
        "\"KHR_materials_iridescence\":{\"iridescenceFactor\":1,\"iridescenceIor\":1,"
        "\"iridescenceThicknessMinimum\":0,\"iridescenceThicknessMaximum\":0}}}",
    };
    snprintf(json, sizeof json, TRIANGLE_GLTF("%s", ""), ends[0]);
    if (load_text(&s, json, &e)) fail_msg("the range's ends refused: %s", e.msg);
    assert_int_equal(s.material_count, 1);
    assert_close(s.materials[0].clearcoat, 1, 0);
    assert_close(s.materials[0].attenuation_color[2], 0.5, 0);
    assert_close(s.materials[0].iridescence, 1, 0);
    assert_close(s.materials[0].iridescence_ior, 1, 0);
    assert_close(s.materials[0].iridescence_max_nm, 0, 0);
    scene_free(&s);
}

/* Case 14: a sampler's magFilter written as the string "NEAREST" (not 9728) was
 * ignored, the texture then filtered linearly. */
TEST(test_gltf_sampler_enum_as_string)
{
    static char json[8192];
    snprintf(json, sizeof json, "%s",
             TRIANGLE_GLTF("{}", ",\"samplers\":[{\"magFilter\":\"NEAREST\"}]"));
    assert_refused(json, "samplers[0].magFilter: \"NEAREST\" is not");
}

/* Case 14: a NaN in COLOR_0 was clamped into a colour; it is refused naming the
 * accessor and the vertex. */
TEST(test_gltf_color_nan)
{
    const char *json =
        "{\"asset\":{\"version\":\"2.0\"},\"scene\":0,\"scenes\":[{\"nodes\":[0]}],"
        "\"nodes\":[{\"mesh\":0}],\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0,"
        "\"COLOR_0\":1}}]}],\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":3,"
        "\"type\":\"VEC3\",\"min\":[0,0,0],\"max\":[1,1,0]},{\"bufferView\":1,"
        "\"componentType\":5126,\"count\":3,\"type\":\"VEC3\"}],\"bufferViews\":[{\"buffer\":0,"
        "\"byteLength\":36},{\"buffer\":0,\"byteOffset\":36,\"byteLength\":36}],\"buffers\":[{"
        "\"byteLength\":72,\"uri\":\"data:application/octet-stream;base64,"
        "AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAAAACAPwAAgD8AAIA/AADAfwAAgD8AAIA/AACAPwAA"
        "gD8AAIA/\"}]}";
    assert_refused(json, "meshes[0].primitives[0].attributes.COLOR_0 (accessors[1]): vertex 1 "
                         "component 0 is nan");
}

/* Case 14: an --env map whose every texel is 0 lights nothing; with no other
 * light the image is black, which the run now says, as it does for
 * --env-intensity 0. */
TEST(test_env_all_zero_warns)
{
    char path[256], scene[256];
    snprintf(path, sizeof path, "%s/zero.hdr", test_dir());
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    fputs("#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 2 +X 4\n", f);
    for (int i = 0; i < 8 * 4; i++) fputc(0, f);
    fclose(f);
    snprintf(scene, sizeof scene, "%s/tri.gltf", test_dir());
    test_write_text(scene, TRIANGLE_GLTF("{}", ""));
    char args[1024], err[8192];
    snprintf(args, sizeof args, "render %s --env %s " TINY " -o %s/x.exr", scene, path, test_dir());
    int rc = run_exe(args, err, sizeof err);
    if (rc) fail_msg("exit %d:\n%s", rc, err);
    if (!strstr(err, "warning: ") || !strstr(err, "nothing lights the scene"))
        fail_msg("no warning that the image will be black:\n%s", err);
}

/* Case 15: an indices accessor that does not exist is named with its mesh and
 * primitive (the glTF library said "primitive indices accessor out of bounds"). */
TEST(test_gltf_indices_named)
{
    static char json[8192];
    snprintf(json, sizeof json, "%s", TRIANGLE_GLTF("{}", ""));
    char *at = strstr(json, "\"indices\":1");
    assert_non_null(at);
    at[10] = '7';
    assert_refused(json, "hostile.gltf: meshes[0].primitives[0].indices: accessors[7] does not exist");
}

/* Case 16: files the glTF-Validator reports valid. */

/* The validator's json/integer_written_as_float.gltf (tests/data/gltf/validator):
 * indices and counts written as 1.0, 1e0, 10e-1. */
TEST(test_gltf_validator_integers_as_floats)
{
    Scene s;
    SptError e = {0};
    int rc = scene_load_gltf(&s, SPT_TEST_DATA("gltf/validator/json/integer_written_as_float.gltf"), &e);
    if (rc) fail_msg("refused (%d): %s", rc, e.msg);
    scene_free(&s);
    /* The same in a triangle that renders: every index and count a float. */
    static char json[8192];
    snprintf(json, sizeof json, "%s", TRIANGLE_GLTF("{}", ""));
    static const char *const from[][2] = {
        {"\"scene\":0", "\"scene\":0.0"},  {"\"mesh\":0", "\"mesh\":0e5"},
        {"\"count\":3,", "\"count\":3.0,"}, {"\"indices\":1", "\"indices\":10e-1"},
        {"\"byteLength\":36", "\"byteLength\":3.6e1"},
    };
    for (size_t i = 0; i < sizeof from / sizeof from[0]; i++) {
        char *at = strstr(json, from[i][0]);
        assert_non_null(at);
        size_t a = strlen(from[i][0]), b = strlen(from[i][1]);
        memmove(at + b, at + a, strlen(at + a) + 1);
        memcpy(at, from[i][1], b);
    }
    if ((rc = load_text(&s, json, &e))) fail_msg("refused (%d): %s", rc, e.msg);
    assert_triangle(&s, 1);
    scene_free(&s);
    /* A fraction is still no index. */
    snprintf(json, sizeof json, "%s", TRIANGLE_GLTF("{}", ""));
    char *at = strstr(json, "\"mesh\":0");
    memmove(at + 10, at + 8, strlen(at + 8) + 1);
    memcpy(at, "\"mesh\":0.5", 10);
    assert_refused(json, "nodes[0].mesh: 0.5 is not an index");
}

/* Like the validator's buffer/data_uri.glb: a GLB whose buffer is a data URI with
 * percent-encoded bytes (no ";base64"), here the triangle's positions. */
TEST(test_gltf_glb_data_uri_buffer)
{
    const char *json =
        "{\"asset\":{\"version\":\"2.0\"},\"scene\":0,\"scenes\":[{\"nodes\":[0]}],"
        "\"nodes\":[{\"mesh\":0}],\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0}}]}],"
        "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\","
        "\"min\":[0,0,0],\"max\":[1,1,0]}],\"bufferViews\":[{\"buffer\":0,\"byteLength\":36}],"
        "\"buffers\":[{\"byteLength\":36,\"uri\":\"data:application/gltf-buffer,"
        "%00%00%00%00%00%00%00%00%00%00%00%00%00%00%80%3F%00%00%00%00%00%00%00%00%00%00%00%00"
        "%00%00%80%3F%00%00%00%00\"}]}";
    uint32_t jlen = (uint32_t)strlen(json), pad = (jlen + 3) & ~3u;
    static unsigned char glb[4096];
    uint32_t hdr[5] = {0x46546C67, 2, 20 + pad, pad, 0x4E4F534A};
    memcpy(glb, hdr, 20);
    memset(glb + 20, ' ', pad);
    memcpy(glb + 20, json, jlen);
    Scene s;
    SptError e = {0};
    int rc = scene_load_gltf_memory(&s, glb, 20 + pad, "data_uri.glb", &e);
    if (rc) fail_msg("refused (%d): %s", rc, e.msg);
    assert_triangle(&s, 1);
    scene_free(&s);
}

/* Like the validator's mesh/valid.gltf: an indices accessor without bufferView
 * (all zeros, glTF 2.0 3.6.2.3) with sparse values: the quad's indices become
 * 0 1 2 0 2 3, two triangles; without the sparse part, one degenerate triangle. */
TEST(test_gltf_indices_without_buffer_view)
{
    static const char head[] =
        "{\"asset\":{\"version\":\"2.0\"},\"scene\":0,\"scenes\":[{\"nodes\":[0]}],"
        "\"nodes\":[{\"mesh\":0}],\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0},"
        "\"indices\":1}]}],\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":4,"
        "\"type\":\"VEC3\",\"min\":[0,0,0],\"max\":[1,1,0]},";
    static const char tail[] =
        "\"bufferViews\":[{\"buffer\":0,\"byteLength\":48},{\"buffer\":0,\"byteOffset\":48,"
        "\"byteLength\":8},{\"buffer\":0,\"byteOffset\":56,\"byteLength\":12}],\"buffers\":[{"
        "\"byteLength\":68,\"uri\":\"data:application/octet-stream;base64,"
        "AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAACAPwAAgD8AAAAAAAAAAAAAgD8AAAAAAQIDBAUAAAABAAIAAAACAAMA"
        "AAA=\"}]}";
    static char json[8192];
    snprintf(json, sizeof json,
             "%s{\"componentType\":5123,\"count\":6,\"type\":\"SCALAR\",\"sparse\":{\"count\":5,"
             "\"indices\":{\"bufferView\":1,\"componentType\":5121},\"values\":{\"bufferView\":2}}}],%s",
             head, tail);
    Scene s;
    SptError e = {0};
    int rc = load_text(&s, json, &e);
    if (rc) fail_msg("refused (%d): %s", rc, e.msg);
    assert_triangle(&s, 2);
    scene_free(&s);
    snprintf(json, sizeof json, "%s{\"componentType\":5123,\"count\":3,\"type\":\"SCALAR\"}],%s",
             head, tail);
    if ((rc = load_text(&s, json, &e))) fail_msg("refused (%d): %s", rc, e.msg);
    assert_int_equal(s.tri_count, 0);
    assert_int_equal(s.stats.dropped_degenerate, 1);
    scene_free(&s);
}

/* A scene with no triangles (a scene of no nodes) renders its sky: the
 * device's BVH buffer is its root node's size with no data behind it, once
 * read past a 16-byte placeholder (AddressSanitizer: heap-buffer-overflow). */
TEST(test_empty_scene_renders_sky)
{
    char scene[256], out[256];
    snprintf(scene, sizeof scene, "%s/empty.gltf", test_dir());
    snprintf(out, sizeof out, "%s/empty.exr", test_dir());
    test_write_text(scene, "{\"asset\":{\"version\":\"2.0\"},\"scenes\":[{\"nodes\":[]}],\"scene\":0}");
    char args[1024], err[8192];
    snprintf(args, sizeof args, "render %s --width 8 --spp 64 -q --device 0 -o %s", scene, out);
    int rc = run_exe(args, err, sizeof err);
    if (rc) fail_msg("exit %d:\n%s", rc, err);
    float *rgb = NULL;
    int w = 0, h = 0;
    SptError e = {0};
    if (image_read_rgb(out, &rgb, &w, &h, &e)) fail_msg("%s", e.msg);
    /* The default sky is D65 at luminance 1, which is linear sRGB's white
     * (1, 1, 1); each pixel's few wavelengths scatter its colour, their mean
     * over the image does not. */
    double mean[3] = {0, 0, 0};
    for (int i = 0; i < w * h * 3; i++) {
        if (!(rgb[i] > 0.0f && isfinite(rgb[i]))) fail_msg("pixel value %d is %g", i, rgb[i]);
        mean[i % 3] += rgb[i] / (double)(w * h);
    }
    for (int c = 0; c < 3; c++)
        if (!(fabs(mean[c] - 1.0) < 0.01)) fail_msg("channel %d's mean is %g, not the sky's 1", c, mean[c]);
    free(rgb);
}

TEST_MAIN("tests", test_dir_setup, test_dir_teardown)
