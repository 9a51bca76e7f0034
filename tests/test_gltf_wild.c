/* src/scene/gltf_load.cpp, src/scene/mesh_decode.cpp, src/io/texture_io.cpp: glTF files "from
 * the wild" (tests/data/gltf/wild_*, written by tools/gen_wild_tests.py):
 * texture transforms against hand-computed matrices, the specular-glossiness
 * conversion against hand-solved values, warnings and refusals of extensions,
 * quantised, meshopt and Draco copies of one mesh against the plain copy, a
 * WebP texture against its known texels; the glTF-Validator's valid test files
 * (tests/data/gltf/validator/) and GLB buffers with and without a BIN chunk. */
#include "test_util.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "scene/scene.h"

#define DATA(f) SPT_TEST_DATA("gltf/" f)

/* Loads path (or, when json is not NULL, the text json under the name path)
 * with stderr captured; returns what it wrote (NUL-terminated, kept until the
 * next call); fails the test when the loader refuses it. */
static const char *load_capture(Scene *s, const char *path, const char *json)
{
    static char err[16384];
    SptError e = {0};
    fflush(stderr);
    FILE *tmp = tmpfile();
    assert_non_null(tmp);
    int saved = dup(2);
    dup2(fileno(tmp), 2);
    int rc = json ? scene_load_gltf_memory(s, json, strlen(json), path, &e)
                  : scene_load_gltf(s, path, &e);
    fflush(stderr);
    dup2(saved, 2);
    close(saved);
    rewind(tmp);
    err[fread(err, 1, sizeof err - 1, tmp)] = 0;
    fclose(tmp);
    if (rc)
        fail_msg("%s refused (%d): %s", path, rc, e.msg);
    return err;
}

/* Number of lines of text that start with "warning:" and contain every needle. */
static int count_warnings(const char *text, const char *n1, const char *n2)
{
    int count = 0;
    for (const char *line = text; *line;) {
        const char *end = strchr(line, '\n');
        size_t len = end ? (size_t)(end - line) : strlen(line);
        char buf[1024];
        snprintf(buf, sizeof buf, "%.*s", (int)len, line);
        if (!strncmp(buf, "warning:", 8) && strstr(buf, n1) && (!n2 || strstr(buf, n2))) count++;
        line += len + (end ? 1 : 0);
    }
    return count;
}

static void assert_matrix(const float *m, const double want[6])
{
    for (int k = 0; k < 6; k++)
        if (fabs(m[k] - want[k]) > 1e-6)
            fail_msg("uv_transform[%d] is %g, expected %g", k, m[k], want[k]);
}

TEST(test_texture_transform)
{
    Scene s;
    const char *err = load_capture(&s, DATA("wild_texture_transform.gltf"), NULL);
    assert_int_equal(s.material_count, 2);
    const SceneMaterial *m = &s.materials[0];
    /* KHR_texture_transform: M = T R S, R = [[cos, sin], [-sin, cos]]. Base:
     * offset (0.25, 0.5), rotation pi/6 (cos 0.8660254, sin 0.5), scale (2, 3). */
    const double c = 0.86602540378, sn = 0.5;
    const double base[6] = {2 * c, 3 * sn, 0.25, -2 * sn, 3 * c, 0.5};
    assert_matrix(m->tex[SPT_SLOT_BASE].transform, base);
    /* The corner uv (1, 0) goes to (2 cos + 0.25, -2 sin + 0.5) = (1.982, -0.5). */
    const float *b = m->tex[SPT_SLOT_BASE].transform;
    assert_close(b[0] * 1 + b[1] * 0 + b[2], 1.98205080757, 1e-6);
    assert_close(b[3] * 1 + b[4] * 0 + b[5], -0.5, 1e-6);
    const double mr[6] = {4, 0, 0, 0, 0.5, 0};
    assert_matrix(m->tex[SPT_SLOT_METALLIC_ROUGHNESS].transform, mr);
    const double em[6] = {1, 0, -1, 0, 1, 2};
    assert_matrix(m->tex[SPT_SLOT_EMISSIVE].transform, em);
    /* Rotation pi/2 alone: (u, v) -> (v, -u). */
    const double nr[6] = {0, 1, 0, -1, 0, 0};
    assert_matrix(m->tex[SPT_SLOT_NORMAL].transform, nr);
    const double id[6] = {1, 0, 0, 0, 1, 0};
    for (int k = 0; k < 4; k++) assert_matrix(s.materials[1].tex[k].transform, id);
    assert_true(m->tex[SPT_SLOT_BASE].tex >= 0 && m->tex[SPT_SLOT_NORMAL].tex >= 0 && m->tex[SPT_SLOT_EMISSIVE].tex >= 0);
    /* The normal texture reads TEXCOORD_1 (the transform's texCoord), which the
     * primitive lacks: its TEXCOORD_0 is used, with a warning. */
    assert_int_equal(m->tex[SPT_SLOT_NORMAL].texcoord, 1);
    assert_int_equal(m->tex[SPT_SLOT_BASE].texcoord, 0);
    assert_int_equal(count_warnings(err, "without TEXCOORD_1", "TEXCOORD_0 is used"), 1);
    scene_free(&s);
}

TEST(test_spec_gloss_and_ignored)
{
    Scene s;
    const char *err = load_capture(&s, DATA("wild_specgloss.gltf"), NULL);
    assert_int_equal(s.material_count, 7);
    /* Specular (0,0,0) < 0.04: metallic 0, base = diffuse (1 - 0) / (1 - 0.04). */
    const SceneMaterial *d = &s.materials[0];
    assert_close(d->metallic, 0, 1e-6);
    for (int k = 0; k < 3; k++) assert_close(d->base_color[k], 0.5 / 0.96, 1e-6);
    assert_close(d->base_color[3], 0.8, 1e-6);
    assert_close(d->roughness, 0.7, 1e-6);
    /* Specular (1,1,1), diffuse 0: b = 1 - 0.08, c = 0.04 - 1, D = 1, metallic
     * = (-0.92 + 1) / 0.08 = 1; base = (1 - 0) / 1 = 1; roughness 1 - 0.8. */
    const SceneMaterial *mt = &s.materials[1];
    assert_close(mt->metallic, 1, 1e-6);
    for (int k = 0; k < 3; k++) assert_close(mt->base_color[k], 1, 1e-6);
    assert_close(mt->roughness, 0.2, 1e-6);
    /* KHR_materials_sheen and KHR_materials_clearcoat are rendered: their
     * factors are read, no warning. */
    assert_close(s.materials[2].sheen_color[0], 1, 1e-6);
    assert_close(s.materials[2].sheen_color[1], 0, 1e-6);
    assert_close(s.materials[2].sheen_roughness, 0.4, 1e-6);
    assert_close(s.materials[3].clearcoat, 1, 1e-6);
    assert_close(s.materials[3].clearcoat_roughness, 0.1, 1e-6);
    assert_int_equal(count_warnings(err, "KHR_materials_sheen", NULL), 0);
    assert_int_equal(count_warnings(err, "KHR_materials_clearcoat", NULL), 0);
    /* One warning per ignored extension, naming its materials; one for the
     * unknown extensions, naming both. */
    /* KHR_materials_iridescence is rendered: its values are read (the
     * extension's defaults where absent), no warning. */
    assert_close(s.materials[5].iridescence, 1, 1e-6);
    assert_close(s.materials[5].iridescence_ior, 1.3, 1e-6);
    assert_close(s.materials[5].iridescence_min_nm, 100, 1e-6);
    assert_close(s.materials[5].iridescence_max_nm, 400, 1e-6);
    assert_close(s.materials[6].iridescence, 0, 0);
    assert_int_equal(count_warnings(err, "KHR_materials_iridescence", NULL), 0);
    /* KHR_materials_anisotropy is rendered: its strength is read, no warning. */
    assert_close(s.materials[6].anisotropy, 0.5, 1e-6);
    assert_int_equal(count_warnings(err, "KHR_materials_anisotropy", NULL), 0);
    /* KHR_materials_specular is rendered: its factor is read, no warning. */
    assert_close(s.materials[4].specular, 0.5, 1e-6);
    for (int k = 0; k < 3; k++) assert_close(s.materials[4].specular_color[k], 1, 1e-6);
    assert_int_equal(count_warnings(err, "KHR_materials_specular", NULL), 0);
    assert_int_equal(count_warnings(err, "EXT_spectrace_unknown", "EXT_other_unknown"), 1);
    assert_int_equal(count_warnings(err, "KHR_materials_pbrSpecularGlossiness", NULL), 0);
    scene_free(&s);
}

/* KHR_texture_basisu in extensionsUsed: one warning naming it and what
 * rendering it would need, and it is not among the unknown extensions. */
TEST(test_basisu_named)
{
    const char *json = "{\"asset\":{\"version\":\"2.0\"},\"extensionsUsed\":[\"KHR_texture_basisu\","
                       "\"EXT_foo\"]}";
    Scene s;
    const char *err = load_capture(&s, "tests/data/gltf/basisu.gltf", json);
    assert_int_equal(count_warnings(err, "KHR_texture_basisu is not rendered", "transcoder"), 1);
    assert_int_equal(count_warnings(err, "not supported", "EXT_foo"), 1);
    assert_int_equal(count_warnings(err, "not supported", "KHR_texture_basisu"), 0);
    scene_free(&s);
}

/* A file that requires an ignored or unknown extension: one error line naming
 * all of them and none of the supported ones. */
TEST(test_required_refused)
{
    const char *json =
        "{\"asset\":{\"version\":\"2.0\"},\"extensionsUsed\":[\"KHR_materials_volume_scatter\","
        "\"KHR_texture_transform\",\"EXT_foo\",\"EXT_meshopt_compression\"],"
        "\"extensionsRequired\":[\"KHR_materials_volume_scatter\",\"KHR_texture_transform\","
        "\"EXT_foo\",\"EXT_meshopt_compression\"]}";
    Scene s;
    SptError e = {0};
    int rc = scene_load_gltf_memory(&s, json, strlen(json), "tests/data/gltf/req.gltf", &e);
    assert_int_equal(rc, SPT_EXIT_INPUT);
    assert_non_null(strstr(e.msg, "extensionsRequired"));
    assert_non_null(strstr(e.msg, "KHR_materials_volume_scatter"));
    assert_non_null(strstr(e.msg, "EXT_foo"));
    assert_null(strstr(e.msg, "KHR_texture_transform"));
    assert_null(strstr(e.msg, "EXT_meshopt"));
    assert_null(strchr(e.msg, '\n'));
    /* Every extension docs/gltf.md lists as handled may be required. */
    const char *all =
        "{\"asset\":{\"version\":\"2.0\"},\"extensionsRequired\":[\"KHR_materials_emissive_strength\","
        "\"KHR_materials_ior\",\"KHR_materials_transmission\",\"KHR_materials_dispersion\","
        "\"KHR_materials_volume\",\"KHR_materials_unlit\",\"KHR_lights_punctual\","
        "\"KHR_texture_transform\",\"KHR_materials_pbrSpecularGlossiness\",\"KHR_mesh_quantization\","
        "\"EXT_meshopt_compression\",\"KHR_draco_mesh_compression\",\"EXT_texture_webp\","
        "\"KHR_materials_specular\",\"KHR_materials_clearcoat\",\"KHR_materials_sheen\","
        "\"KHR_materials_anisotropy\",\"KHR_materials_diffuse_transmission\"]}";
    /* A file requiring only handled extensions loads, none called not supported. */
    assert_null(strstr(load_capture(&s, "tests/data/gltf/all.gltf", all), "not supported"));
    scene_free(&s);
}

/* Loads a compressed copy and compares it with the plain one, triangle by
 * triangle: positions within pos_tol, vertex normals within nrm_tol, uvs within
 * uv_tol. */
static void compare_with_plain(const char *file, double pos_tol, double nrm_tol, double uv_tol)
{
    Scene p, c;
    test_load_scene(&p, DATA("wild_plain.gltf"));
    test_load_scene(&c, file);
    assert_int_equal(p.tri_count, 32);
    assert_int_equal(c.tri_count, p.tri_count);
    double dp = 0, dn = 0, du = 0;
    for (uint32_t t = 0; t < p.tri_count; t++) {
        /* The meshopt index codec may rotate a triangle's vertices (keeping its
         * winding): match the rotation that fits best. */
        int rot = 0;
        double best = INFINITY;
        for (int q = 0; q < 3; q++) {
            double d = 0;
            for (int k = 0; k < 3; k++)
                for (int r = 0; r < 3; r++)
                    d = fmax(d, fabs(p.tri_pos[t * 9 + k * 3 + r] -
                                     c.tri_pos[t * 9 + (k + q) % 3 * 3 + r]));
            if (d < best) best = d, rot = q;
        }
        for (int k = 0; k < 3; k++) {
            int kc = (k + rot) % 3;
            for (int r = 0; r < 3; r++)
                dp = fmax(dp, fabs(p.tri_pos[t * 9 + k * 3 + r] - c.tri_pos[t * 9 + kc * 3 + r]));
            uint32_t vp = p.tri_vidx[t * 3 + k], vc = c.tri_vidx[t * 3 + kc];
            for (int r = 0; r < 3; r++)
                dn = fmax(dn, fabs(p.vtx_normal[vp * 3 + r] - c.vtx_normal[vc * 3 + r]));
            for (int r = 0; r < 2; r++)
                du = fmax(du, fabs(p.vtx_uv[vp * 2 + r] - c.vtx_uv[vc * 2 + r]));
        }
    }
    if (dp > pos_tol || dn > nrm_tol || du > uv_tol)
        fail_msg("%s: largest differences: position %g (tolerance %g), normal %g (%g), uv %g (%g)",
                 file, dp, pos_tol, dn, nrm_tol, du, uv_tol);
    /* Bounds span [-1, 1] x [-1, 1] x [0, 0.3] in every copy. */
    assert_close(c.bounds_min[0], -1, pos_tol + 1e-6);
    assert_close(c.bounds_max[2], 0.3, pos_tol + 1e-6);
    scene_free(&p);
    scene_free(&c);
}

TEST(test_quantized_matches_plain)
{
    /* int16 steps of 2/32767 (half a step of rounding error), int8 normals
     * (1/127, then renormalised), uint16 uvs (1/65535). */
    compare_with_plain(DATA("wild_quantized.gltf"), 0.5 * 2 / 32767 + 1e-6, 1.5 / 127, 1e-5);
}

/* The same file without KHR_mesh_quantization declared: refused, with a hint. */
TEST(test_quantized_needs_extension)
{
    FILE *f = fopen(DATA("wild_quantized.gltf"), "rb");
    assert_non_null(f);
    static char text[16384];
    size_t n = fread(text, 1, sizeof text - 1, f);
    fclose(f);
    text[n] = 0;
    char *at;
    while ((at = strstr(text, "KHR_mesh_quantization"))) memcpy(at, "KHR_texture_transform", 21);
    Scene s;
    SptError e = {0};
    int rc = scene_load_gltf_memory(&s, text, n, "tests/data/gltf/q.gltf", &e);
    assert_int_equal(rc, SPT_EXIT_INPUT);
    if (!strstr(e.msg, "meshes[0].primitives[0].attributes.POSITION") ||
        !strstr(e.msg, "SHORT") || !strstr(e.msg, "need KHR_mesh_quantization"))
        fail_msg("got '%s'", e.msg);
}

TEST(test_meshopt_matches_plain)
{
    /* The meshopt codecs are lossless on floats; the normals went through the
     * 8-bit octahedral filter (steps of 1/127 in u, v, then 1/127 per output). */
    compare_with_plain(DATA("wild_meshopt.gltf"), 0, 2.0 / 127, 0);
    /* The same in a .glb, whose container the loader rebuilds around the JSON. */
    compare_with_plain(DATA("wild_meshopt.glb"), 0, 2.0 / 127, 0);
}

TEST(test_draco_matches_plain)
{
    /* 14-bit positions over a range of 2, 10-bit (octahedral) normals, 12-bit uvs. */
    compare_with_plain(DATA("wild_draco.gltf"), 2.0 / 16383, 4.0 / 1023, 1.0 / 4095);
}

/* Damaged meshopt data: one error naming the buffer view. */
TEST(test_meshopt_damaged)
{
    FILE *f = fopen(DATA("wild_meshopt.gltf"), "rb");
    assert_non_null(f);
    static char text[16384], copy[16384];
    size_t n = fread(text, 1, sizeof text - 1, f);
    fclose(f);
    text[n] = 0;
    static const struct {
        const char *from, *to, *want;
    } cases[] = {
        {"\"mode\":\"ATTRIBUTES\"", "\"mode\":\"BOGUSXXXXX\"",
         "bufferViews[0].extensions.EXT_meshopt_compression.mode"},
        {"\"byteStride\":12,\"count\":25", "\"byteStride\":12,\"count\":99",
         "bufferViews[0].extensions.EXT_meshopt_compression: corrupt"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        const char *at = strstr(text, cases[i].from);
        assert_non_null(at);
        assert_int_equal(strlen(cases[i].from), strlen(cases[i].to));
        memcpy(copy, text, n + 1);
        memcpy(copy + (at - text), cases[i].to, strlen(cases[i].to));
        Scene s;
        SptError e = {0};
        int rc = scene_load_gltf_memory(&s, copy, n, "tests/data/gltf/damaged.gltf", &e);
        assert_int_equal(rc, SPT_EXIT_INPUT);
        if (!strstr(e.msg, cases[i].want)) fail_msg("case %zu: got '%s'", i, e.msg);
    }
}

/* Primitives sharing vertex accessors share one copy of the vertices per
 * instance; the flattened instances (--instancing off) are counted. */
TEST(test_shared_vertices_and_instances)
{
    Scene s;
    SptError e = {0};
    if (scene_load_gltf_posed(&s, DATA("wild_instanced.gltf"),
                              &(ScenePose){NAN, NULL, NULL, SCENE_INSTANCING_OFF}, &e))
        fail_msg("%s", e.msg);
    assert_int_equal(s.tri_count, 6);
    assert_int_equal(s.vertex_count, 12); /* 4 per instance, not 6 */
    assert_int_equal(s.stats.instances, 3);
    assert_int_equal(s.stats.instanced_meshes, 1);
    assert_int_equal(s.stats.flattened_triangles, 4);
    assert_int_equal(s.stats.flattened_vertices, 8);
    /* Both triangles of the third instance use its own 4 vertices, at x + 4. */
    for (int k = 0; k < 6; k++) {
        uint32_t v = s.tri_vidx[4 * 3 + k];
        assert_true(v >= 8 && v < 12);
    }
    assert_int_equal(s.tri_mat[4], 0);
    assert_int_equal(s.tri_mat[5], 1);
    assert_close(s.tri_pos[5 * 9 + 3], 5, 0); /* (1, 1, 0) + (4, 0, 0) */
    assert_close(s.vtx_uv[s.tri_vidx[5 * 3 + 2] * 2 + 1], 1, 0); /* vertex 3: uv (0, 1) */
    scene_free(&s);
    /* `spectrace info` states the cost of the flattening. */
    static char out[16384];
    char args[512];
    snprintf(args, sizeof args, "info --no-bvh --instancing off %s", DATA("wild_instanced.gltf"));
    assert_int_equal(test_spectrace("", 0, args, TEST_BOTH, out, sizeof out), 0);
    if (!strstr(out, "flattened    1 mesh(es) placed several times, flattened: 4 triangles and 8 "
                     "vertices are copies"))
        fail_msg("no flattening line in:\n%s", out);
    if (!strstr(out, "2 unique triangle(s), 6 placed by the instances"))
        fail_msg("no unique and placed triangles in:\n%s", out);
    /* By reference (the default): the mesh once, its three instances, and
     * the two levels' device memory. */
    snprintf(args, sizeof args, "info %s", DATA("wild_instanced.gltf"));
    assert_int_equal(test_spectrace("", 0, args, TEST_BOTH, out, sizeof out), 0);
    if (!strstr(out, "instancing   1 mesh(es) placed by reference, 3 instance(s): 2 unique "
                     "triangle(s) (2 in the meshes), 6 placed (6 by the instances)") ||
        !strstr(out, "bvh          two levels built in") || !strstr(out, "; top 3 instance(s)"))
        fail_msg("no instancing lines in:\n%s", out);
}

static double srgb_to_linear(double x)
{
    return x <= 0.04045 ? x / 12.92 : pow((x + 0.055) / 1.055, 2.4);
}

TEST(test_webp_texture)
{
    Scene s;
    test_load_scene(&s, DATA("wild_webp.glb"));
    assert_int_equal(s.texture_count, 1);
    const SceneTexture *t = &s.textures[0];
    /* The WebP source wins over the 1x1 PNG fallback. */
    assert_int_equal(t->width, 2);
    assert_int_equal(t->height, 2);
    assert_int_equal(t->channels, 3);
    static const int want[12] = {0, 64, 128, 255, 255, 255, 128, 0, 255, 10, 20, 30};
    for (int i = 0; i < 12; i++) assert_close(t->texels[i], srgb_to_linear(want[i] / 255.0), 1e-5);
    scene_free(&s);
}

/* Reads a test data file whole (NUL-terminated); *n its size. */
static char *read_data(const char *path, size_t *n)
{
    FILE *f = fopen(path, "rb");
    if (!f) fail_msg("cannot open %s", path);
    fseek(f, 0, SEEK_END);
    long size = ftell(f);
    rewind(f);
    char *text = malloc((size_t)size + 1);
    assert_non_null(text);
    assert_int_equal(fread(text, 1, (size_t)size, f), (size_t)size);
    fclose(f);
    text[size] = 0;
    *n = (size_t)size;
    return text;
}

/* path's JSON with more top-level members (added after its first '{'), loaded
 * from memory under path's name; returns the loader's code. */
static int load_with(Scene *s, const char *path, const char *members, SptError *e)
{
    size_t n;
    char *text = read_data(path, &n);
    char *brace = strchr(text, '{');
    assert_non_null(brace);
    size_t cap = n + strlen(members) + 2, head = (size_t)(brace + 1 - text);
    char *json = malloc(cap);
    assert_non_null(json);
    int len = snprintf(json, cap, "%.*s%s,%s", (int)head, text, members, brace + 1);
    int rc = scene_load_gltf_memory(s, json, (size_t)len, path, e);
    free(json);
    free(text);
    return rc;
}

/* Files of the Khronos glTF-Validator's own tests that it reports valid
 * (tests/data/gltf/validator/, README there) load without an error: accessors
 * without a bufferView (zeros), sparse accessors over zeros and over a buffer
 * view, a .gltf buffer without uri, a mesh on a node of a file with no scene.
 * Where the files place a mesh, its zero positions make degenerate triangles,
 * which are dropped and counted. */
TEST(test_validator_valid_files)
{
    static const char *const files[] = {
        DATA("validator/accessor/valid.gltf"),
        DATA("validator/accessor_data/get_elements_sparse.gltf"),
        DATA("validator/mesh/primitive_generated_tangent_space.gltf"),
        DATA("validator/node/valid.gltf"),
    };
    Scene s;
    for (size_t i = 0; i < sizeof files / sizeof files[0]; i++) {
        const char *err = load_capture(&s, files[i], NULL);
        if (strstr(err, "error:")) fail_msg("%s: an error line:\n%s", files[i], err);
        /* node/valid.gltf has no scene: its root node's mesh is drawn, a triangle
         * of three zero positions (POSITION has no bufferView). */
        if (strstr(files[i], "node/")) {
            assert_int_equal(s.stats.primitives, 1);
            assert_int_equal(s.stats.dropped_degenerate, 1);
        } else {
            assert_int_equal(s.stats.primitives, 0); /* no node places their meshes */
        }
        assert_int_equal(s.tri_count, 0);
        scene_free(&s);
    }
    /* The tangent-space file's mesh placed on a node: four primitives sharing one
     * POSITION accessor without bufferView, so four zero-area triangles. */
    const char *place = "\"scene\":0,\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"mesh\":0}]";
    SptError e = {0};
    if (load_with(&s, files[2], place, &e)) fail_msg("%s", e.msg);
    assert_int_equal(s.stats.primitives, 4);
    assert_int_equal(s.stats.dropped_degenerate, 4);
    assert_int_equal(s.tri_count, 0);
    scene_free(&s);
    /* accessor/valid.gltf's sparse accessor reads buffers[0], which has no uri: a
     * primitive that uses it is refused, naming the accessor and the buffer. */
    char more[512];
    snprintf(more, sizeof more, "%s,\"meshes\":[{\"primitives\":[{\"attributes\":"
             "{\"POSITION\":0}}]}]", place);
    assert_int_equal(load_with(&s, files[0], more, &e), SPT_EXIT_INPUT);
    if (!strstr(e.msg, "valid.gltf: meshes[0].primitives[0].attributes.POSITION (accessors[0])") ||
        !strstr(e.msg, "buffers[0], which has no uri"))
        fail_msg("unexpected message: %s", e.msg);
}

/* A GLB of the JSON text json (padded) and, when bin_len > 0, a BIN chunk of
 * bin_len bytes of bin, into out; returns its size. */
static size_t make_glb(unsigned char *out, size_t cap, const char *json, const void *bin,
                       uint32_t bin_len)
{
    uint32_t jlen = (uint32_t)strlen(json), jpad = (jlen + 3) & ~3u;
    uint32_t bpad = (bin_len + 3) & ~3u;
    size_t total = 20 + jpad + (bin_len ? 8 + bpad : 0);
    assert_true(total <= cap);
    uint32_t hdr[5] = {0x46546C67u, 2, (uint32_t)total, jpad, 0x4E4F534Au};
    memcpy(out, hdr, 20);
    memcpy(out + 20, json, jlen);
    memset(out + 20 + jlen, ' ', jpad - jlen);
    if (bin_len) {
        uint32_t ch[2] = {bpad, 0x004E4942u};
        memcpy(out + 20 + jpad, ch, 8);
        memcpy(out + 28 + jpad, bin, bin_len);
        memset(out + 28 + jpad + bin_len, 0, bpad - bin_len);
    }
    return total;
}

/* GLB buffers (glTF 2.0, GLB file format): buffers[0] without uri is the BIN
 * chunk, so without one, or with one shorter than its byteLength, the file is
 * refused by name (the validator's BUFFER_MISSING_GLB_DATA; byteLength 0 is
 * below the schema's minimum of 1 as well). Another buffer without uri holds no
 * data: valid while nothing reads it (the validator's valid_placeholder.glb). */
TEST(test_glb_buffers)
{
    static const float pos[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    const char *tri = "\"scene\":0,\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"mesh\":0}],"
                      "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0}}]}],"
                      "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":3,"
                      "\"type\":\"VEC3\"}]";
    static const struct {
        const char *buffers, *views; /* JSON arrays' contents */
        int bin, with_tri;           /* a BIN chunk (the positions); the triangle */
        const char *want;            /* NULL: loads */
    } cases[] = {
        {"{\"byteLength\":4}", NULL, 0, 0,
         "buffers[0]: has no uri, so its data is the GLB's BIN chunk, and the file has no BIN chunk"},
        {"{\"byteLength\":0}", NULL, 0, 0, "buffers[0]: has no uri"},
        {"{\"byteLength\":36}", "{\"buffer\":0,\"byteLength\":36}", 0, 1, "has no BIN chunk"},
        {"{\"byteLength\":40}", "{\"buffer\":0,\"byteLength\":36}", 1, 1,
         "buffers[0]: byteLength 40 is more than the 36 bytes of the GLB's BIN chunk"},
        {"{\"byteLength\":36},{\"byteLength\":8}", "{\"buffer\":0,\"byteLength\":36}", 1, 1, NULL},
        {"{\"byteLength\":1,\"uri\":\"data:application/octet-stream;base64,AA==\"},"
         "{\"byteLength\":8}", NULL, 0, 0, NULL},
        {"{\"byteLength\":36},{\"byteLength\":36}", "{\"buffer\":1,\"byteLength\":36}", 1, 1,
         "(accessors[0]): bufferViews[0] is in buffers[1], which has no uri"},
    };
    static char json[2048];
    static unsigned char glb[4096];
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        int len = snprintf(json, sizeof json, "{\"asset\":{\"version\":\"2.0\"},\"buffers\":[%s]",
                           cases[i].buffers);
        if (cases[i].views)
            len += snprintf(json + len, sizeof json - (size_t)len, ",\"bufferViews\":[%s]",
                            cases[i].views);
        if (cases[i].with_tri) len += snprintf(json + len, sizeof json - (size_t)len, ",%s", tri);
        snprintf(json + len, sizeof json - (size_t)len, "}");
        size_t n = make_glb(glb, sizeof glb, json, pos, cases[i].bin ? sizeof pos : 0);
        Scene s;
        SptError e = {0};
        int rc = scene_load_gltf_memory(&s, glb, n, "buffers.glb", &e);
        if (!cases[i].want) {
            if (rc) fail_msg("case %zu refused: %s", i, e.msg);
            if (cases[i].with_tri) {
                assert_int_equal(s.tri_count, 1);
                assert_close(s.tri_pos[3], 1, 0);
                assert_close(s.tri_pos[7], 1, 0);
            }
            scene_free(&s);
            continue;
        }
        assert_int_equal(rc, SPT_EXIT_INPUT);
        if (strncmp(e.msg, "buffers.glb: ", 13) || !strstr(e.msg, cases[i].want))
            fail_msg("case %zu: expected 'buffers.glb: ...%s' in: %s", i, cases[i].want, e.msg);
    }
}

TEST_MAIN("tests", NULL, NULL)
