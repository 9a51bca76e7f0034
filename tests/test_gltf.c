/* src/scene/gltf_load.cpp, src/io/texture_io.cpp, src/scene/scene.c: loading small glTF files
 * (tests/data/gltf/, written by tools/gen_gltf_tests.py) against hand-computed
 * values, and refusing broken ones with one message naming the object. */
#include "test_util.h"

#include <dirent.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

#include "scene/scene.h"

#define DATA(f) SPT_TEST_DATA("gltf/" f)

/* Vertex k (0..2) of triangle t equals (x, y, z). */
static void assert_vertex(const Scene *s, uint32_t t, int k, double x, double y, double z)
{
    const float *p = &s->tri_pos[t * 9 + k * 3];
    if (fabs(p[0] - x) > 1e-5 || fabs(p[1] - y) > 1e-5 || fabs(p[2] - z) > 1e-5)
        fail_msg("triangle %u vertex %d is (%g, %g, %g), expected (%g, %g, %g)", t, k, p[0], p[1],
                 p[2], x, y, z);
}

static void assert_vec3(const float *v, double x, double y, double z, double tol)
{
    assert_close(v[0], x, tol);
    assert_close(v[1], y, tol);
    assert_close(v[2], z, tol);
}

/* Every kept triangle's vertices lie inside the default camera's 45 degree view
 * (checked for a square image, the loosest aspect it promises). */
static void assert_all_visible(const Scene *s)
{
    const SceneCamera *c = &s->camera;
    double t = tan(0.5 * c->yfov);
    for (uint32_t i = 0; i < s->tri_count * 3; i++) {
        const float *p = &s->tri_pos[i * 3];
        double d[3] = {p[0] - c->position[0], p[1] - c->position[1], p[2] - c->position[2]};
        double depth = d[0] * c->forward[0] + d[1] * c->forward[1] + d[2] * c->forward[2];
        double x = d[0] * c->right[0] + d[1] * c->right[1] + d[2] * c->right[2];
        double y = d[0] * c->up[0] + d[1] * c->up[1] + d[2] * c->up[2];
        if (!(depth > c->znear) || fabs(x) > t * depth * (1 + 1e-6) || fabs(y) > t * depth * (1 + 1e-6))
            fail_msg("vertex %u (%g %g %g) is outside the default camera's view", i, p[0], p[1], p[2]);
    }
}

TEST(test_external_bin_translation)
{
    Scene s;
    test_load_scene(&s, DATA("tri_external.gltf"));
    assert_int_equal(s.tri_count, 1);
    assert_int_equal(s.vertex_count, 3);
    assert_vertex(&s, 0, 0, 1, 2, 3);
    assert_vertex(&s, 0, 1, 2, 2, 3);
    assert_vertex(&s, 0, 2, 1, 3, 3);
    for (int v = 0; v < 3; v++) assert_vec3(&s.vtx_normal[v * 3], 0, 0, 1, 1e-6);
    assert_close(s.vtx_uv[2], 1, 0);
    assert_close(s.vtx_uv[5], 1, 0);
    /* No material: the glTF default material. */
    assert_int_equal(s.material_count, 1);
    assert_int_equal(s.tri_mat[0], 0);
    assert_close(s.materials[0].base_color[0], 1, 0);
    assert_close(s.materials[0].metallic, 1, 0);
    assert_close(s.materials[0].roughness, 1, 0);
    assert_close(s.materials[0].ior, 1.5, 0);
    assert_int_equal(s.materials[0].tex[SPT_SLOT_BASE].tex, -1);
    /* No camera: the default one, 45 degrees, from +Z, framing the bounds
     * (sphere radius sqrt(0.5) at distance r / sin(22.5 deg) = 1.847759). */
    assert_int_equal(s.camera.is_default, 1);
    assert_close(s.camera.yfov, M_PI / 4, 1e-6);
    assert_vec3(s.camera.forward, 0, 0, -1, 0);
    assert_vec3(s.camera.position, 1.5, 2.5, 3 + 1.8477590650, 1e-5);
    assert_all_visible(&s);
    assert_vec3(s.bounds_min, 1, 2, 3, 0);
    assert_vec3(s.bounds_max, 2, 3, 3, 0);
    scene_free(&s);
}

TEST(test_data_uri_matrix)
{
    Scene s;
    test_load_scene(&s, DATA("tri_datauri.gltf"));
    assert_int_equal(s.tri_count, 1);
    assert_vertex(&s, 0, 0, 0, 0, -5);
    assert_vertex(&s, 0, 1, 2, 0, -5);
    assert_vertex(&s, 0, 2, 0, 2, -5);
    assert_vec3(&s.vtx_normal[0], 0, 0, 1, 1e-6); /* renormalised after scale 2 */
    scene_free(&s);
}

TEST(test_glb_trs)
{
    Scene s;
    test_load_scene(&s, DATA("tri.glb"));
    /* Scale x by 3, then 90 degrees about +Z: (x, y, z) -> (-y, 3x, z). */
    assert_int_equal(s.tri_count, 1);
    assert_vertex(&s, 0, 0, 0, 0, 0);
    assert_vertex(&s, 0, 1, 0, 3, 0);
    assert_vertex(&s, 0, 2, -1, 0, 0);
    assert_vec3(&s.vtx_normal[3], 0, 0, 1, 1e-6);
    assert_close(s.vtx_uv[2], 1, 0); /* TEXCOORD_0 of vertex 1 is (1, 0) */
    assert_close(s.vtx_uv[3], 0, 0);
    scene_free(&s);
}

TEST(test_mirrored_swaps_winding)
{
    Scene s;
    test_load_scene(&s, DATA("mirrored.gltf"));
    /* Scale -1 on x maps (0,0,0) (1,0,0) (0,1,0) to (0,0,0) (-1,0,0) (0,1,0); the
     * winding is swapped so the front face stays counter-clockwise. */
    assert_int_equal(s.tri_count, 1);
    assert_vertex(&s, 0, 0, 0, 0, 0);
    assert_vertex(&s, 0, 1, 0, 1, 0);
    assert_vertex(&s, 0, 2, -1, 0, 0);
    assert_int_equal(s.tri_vidx[1], 2);
    assert_int_equal(s.tri_vidx[2], 1);
    /* Geometric normal of the stored order: cross((0,1,0), (-1,0,0)) = (0,0,1);
     * the mirrored shading normal (inverse transpose) is (0,0,1) too. */
    assert_vec3(&s.vtx_normal[0], 0, 0, 1, 1e-6);
    scene_free(&s);
}

TEST(test_strips_fans_index_types)
{
    Scene s;
    test_load_scene(&s, DATA("modes.gltf"));
    /* strip (3) + fan (3) + u8 quad (2) + u32 quad (2); points and lines skipped. */
    assert_int_equal(s.tri_count, 10);
    assert_int_equal(s.stats.skipped_primitives, 2);
    static const double want[10][3][2] = {
        /* strip v0..v4 = (0,0) (0,1) (1,0) (1,1) (2,0): (0,1,2) (1,3,2) (2,3,4) */
        {{0, 0}, {0, 1}, {1, 0}}, {{0, 1}, {1, 1}, {1, 0}}, {{1, 0}, {1, 1}, {2, 0}},
        /* fan v0..v4 = (0,0) (1,0) (1,1) (0,1) (-1,1): (1,2,0) (2,3,0) (3,4,0) */
        {{1, 0}, {1, 1}, {0, 0}}, {{1, 1}, {0, 1}, {0, 0}}, {{0, 1}, {-1, 1}, {0, 0}},
        /* quads (0,1,2) (0,2,3), u8 then u32 indices */
        {{0, 0}, {1, 0}, {1, 1}}, {{0, 0}, {1, 1}, {0, 1}},
        {{0, 0}, {1, 0}, {1, 1}}, {{0, 0}, {1, 1}, {0, 1}},
    };
    for (uint32_t t = 0; t < 10; t++)
        for (int k = 0; k < 3; k++) assert_vertex(&s, t, k, want[t][k][0], want[t][k][1], 1);
    /* Vertex indices point into each primitive's own vertices: the fan starts at 5. */
    assert_int_equal(s.tri_vidx[3 * 3 + 2], 5);
    assert_int_equal(s.vertex_count, 18);
    scene_free(&s);
}

TEST(test_garbage_triangles_dropped)
{
    Scene s;
    test_load_scene(&s, DATA("garbage.gltf"));
    assert_int_equal(s.tri_count, 1);
    assert_int_equal(s.stats.dropped_nonfinite, 3);  /* NaN, Inf, 1e19 */
    assert_int_equal(s.stats.dropped_degenerate, 2); /* collinear, repeated index */
    assert_vertex(&s, 0, 1, 1, 0, 0);
    assert_true(s.bounds_max[0] == 1.0f && s.bounds_min[0] == 0.0f);
    scene_free(&s);
}

TEST(test_materials_textures_extras)
{
    Scene s;
    test_load_scene(&s, DATA("materials.gltf"));
    assert_int_equal(s.material_count, 6);
    assert_int_equal(s.tri_count, 6);
    for (uint32_t t = 0; t < 6; t++) assert_int_equal(s.tri_mat[t], t);
    const SceneMaterial *m = &s.materials[0];
    assert_string_equal(m->name, "textured");
    assert_vec3(m->base_color, 0.5, 0.25, 1, 0);
    assert_close(m->metallic, 0.3, 1e-7);
    assert_close(m->roughness, 0.7, 1e-7);
    assert_vec3(m->emissive, 1, 0.5, 0.25, 0);
    assert_close(m->emissive_strength, 4, 0);
    assert_close(m->normal_scale, 0.5, 0);
    assert_int_equal(m->alpha_mode, SPT_ALPHA_MASK);
    assert_close(m->alpha_cutoff, 0.3, 1e-7);
    assert_int_equal(m->double_sided, 1);
    /* The same image as colour (sRGB-decoded) and as data: two textures. */
    assert_true(m->tex[SPT_SLOT_BASE].tex >= 0 && m->tex[SPT_SLOT_METALLIC_ROUGHNESS].tex >= 0);
    assert_int_not_equal(m->tex[SPT_SLOT_BASE].tex, m->tex[SPT_SLOT_METALLIC_ROUGHNESS].tex);
    const SceneTexture *c = &s.textures[m->tex[SPT_SLOT_BASE].tex];
    const SceneTexture *d = &s.textures[m->tex[SPT_SLOT_METALLIC_ROUGHNESS].tex];
    assert_int_equal(c->width, 2);
    assert_int_equal(c->height, 2);
    assert_int_equal(c->channels, 3);
    assert_int_equal(c->srgb_decoded, 1);
    assert_int_equal(d->srgb_decoded, 0);
    assert_int_equal(c->wrap_s, SPT_WRAP_CLAMP);
    assert_int_equal(c->wrap_t, SPT_WRAP_MIRROR);
    assert_int_equal(d->wrap_s, SPT_WRAP_CLAMP);
    /* Top-left texel (0, 64, 128)/255: exact sRGB inverse 0, 0.0512695, 0.2158605
     * (gamma 2.2 would give 0.0478 and 0.2195). */
    assert_close(c->texels[0], 0, 1e-7);
    assert_close(c->texels[1], 0.0512694584, 1e-6);
    assert_close(c->texels[2], 0.2158605001, 1e-6);
    assert_close(d->texels[1], 64.0 / 255.0, 1e-7);
    /* Bottom-right texel (first row = top of the image) (10, 20, 30)/255. */
    assert_close(c->texels[9], 0.0030352698, 1e-7);
    assert_close(c->texels[11], 0.0129830323, 1e-7);
    assert_close(d->texels[11], 30.0 / 255.0, 1e-7);
    /* Normal map from a file beside the scene, emissive from a data URI. */
    assert_int_equal(s.textures[m->tex[SPT_SLOT_NORMAL].tex].srgb_decoded, 0);
    assert_string_equal(s.textures[m->tex[SPT_SLOT_NORMAL].tex].name, "tex_2x2.png");
    assert_int_equal(s.textures[m->tex[SPT_SLOT_EMISSIVE].tex].srgb_decoded, 1);
    assert_close(s.textures[m->tex[SPT_SLOT_EMISSIVE].tex].texels[3], 1.0, 1e-7); /* 255 */

    m = &s.materials[1];
    assert_string_equal(m->name, "glass");
    assert_close(m->ior, 1.7, 1e-6);
    assert_close(m->transmission, 0.9, 1e-7);
    assert_int_equal(m->tex[SPT_SLOT_TRANSMISSION].tex, s.materials[0].tex[SPT_SLOT_NORMAL].tex); /* same image, linear */
    assert_close(m->dispersion, 20, 0);
    assert_close(m->thickness, 0.1, 1e-7);
    assert_close(m->attenuation_distance, 2, 0);
    assert_vec3(m->attenuation_color, 0.9, 0.8, 0.7, 1e-7);
    assert_int_equal(m->alpha_mode, SPT_ALPHA_BLEND);
    assert_close(m->base_color[0], 1, 0);

    m = &s.materials[2];
    assert_int_equal(m->unlit, 1);
    assert_true(m->emission_spd.count > 0);
    assert_int_equal(m->reflectance_spd.count, 3);
    assert_close(m->reflectance_spd.nm[1], 500, 0);
    assert_close(m->reflectance_spd.value[2], 0.9, 0);
    assert_string_equal(s.materials[3].conductor, "Au");
    assert_string_equal(s.materials[2].conductor, "");

    /* Escaping, missing and corrupt images: warnings, factors used. */
    m = &s.materials[4];
    assert_int_equal(m->tex[SPT_SLOT_BASE].tex, -1);
    assert_int_equal(m->tex[SPT_SLOT_METALLIC_ROUGHNESS].tex, -1);
    assert_int_equal(m->tex[SPT_SLOT_EMISSIVE].tex, -1);
    assert_int_equal(s.stats.unusable_images, 3);
    assert_int_equal(s.texture_count, 4);
    /* The primitive without a material gets the glTF default material. */
    assert_string_equal(s.materials[5].name, "default");
    assert_int_equal(s.stats.emissive_triangles, 2); /* "textured" and "lamp" */
    scene_free(&s);
}

TEST(test_lights_and_camera)
{
    Scene s;
    test_load_scene(&s, DATA("lights.gltf"));
    /* Camera node: rotation -90 degrees about X under a parent at (0, 10, 0), so
     * it looks down -Y with +Y mapped to -Z. The second camera is not used. */
    const SceneCamera *c = &s.camera;
    assert_int_equal(c->is_default, 0);
    assert_int_equal(c->orthographic, 0);
    assert_vec3(c->position, 0, 10, 0, 1e-6);
    assert_vec3(c->forward, 0, -1, 0, 1e-6);
    assert_vec3(c->up, 0, 0, -1, 1e-6);
    assert_vec3(c->right, 1, 0, 0, 1e-6);
    assert_close(c->yfov, 0.8, 1e-7);
    assert_close(c->aspect, 1.5, 0);
    assert_close(c->znear, 0.1, 1e-8);
    assert_close(c->zfar, 100, 0);

    assert_int_equal(s.light_count, 3);
    const SceneLight *l = &s.lights[0];
    assert_int_equal(l->type, SPT_LIGHT_POINT);
    assert_string_equal(l->name, "bulb");
    assert_vec3(l->position, 1, 2, 3, 0);
    assert_vec3(l->color, 1, 0.5, 0.25, 0);
    assert_close(l->intensity, 100, 0);
    assert_close(l->range, 20, 0);
    l = &s.lights[1];
    assert_int_equal(l->type, SPT_LIGHT_SPOT);
    assert_vec3(l->position, 0, 5, 0, 1e-6);
    assert_vec3(l->direction, 0, -1, 0, 1e-6);
    assert_close(l->inner_cone, 0.2, 1e-7);
    assert_close(l->outer_cone, 0.5, 1e-7);
    assert_vec3(l->color, 1, 1, 1, 0);
    l = &s.lights[2];
    assert_int_equal(l->type, SPT_LIGHT_DIRECTIONAL);
    assert_vec3(l->direction, -1, 0, 0, 1e-6); /* -Z turned +90 degrees about Y */
    assert_close(l->intensity, 3, 0);
    scene_free(&s);
}

TEST(test_orthographic_camera)
{
    Scene s;
    test_load_scene(&s, DATA("ortho.gltf"));
    assert_int_equal(s.camera.orthographic, 1);
    assert_close(s.camera.xmag, 2, 0);
    assert_close(s.camera.ymag, 1, 0);
    assert_close(s.camera.zfar, 50, 0);
    assert_vec3(s.camera.position, 0, 0, 5, 0);
    assert_vec3(s.camera.forward, 0, 0, -1, 1e-7);
    scene_free(&s);
}

/* A chain of 20000 nodes, each moving by (0, 0, 0.005): no recursion limit, and
 * the mesh at the bottom sits at z = 100. */
TEST(test_deep_hierarchy)
{
    const int depth = 20000;
    size_t cap = (size_t)depth * 64 + 4096, n = 0;
    char *j = malloc(cap);
    /* One triangle (0,0,0) (1,0,0) (0,1,0) as a data URI of 36 bytes of floats. */
    n += (size_t)sprintf(j + n,
        "{\"asset\":{\"version\":\"2.0\"},\"scene\":0,\"scenes\":[{\"nodes\":[0]}],"
        "\"buffers\":[{\"byteLength\":36,\"uri\":\"data:application/octet-stream;base64,"
        "AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA\"}],"
        "\"bufferViews\":[{\"buffer\":0,\"byteLength\":36}],"
        "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\"}],"
        "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0}}]}],\"nodes\":[");
    for (int i = 0; i < depth; i++) {
        if (i < depth - 1)
            n += (size_t)sprintf(j + n, "{\"translation\":[0,0,0.005],\"children\":[%d]},", i + 1);
        else
            n += (size_t)sprintf(j + n, "{\"translation\":[0,0,0.005],\"mesh\":0}]}");
    }
    Scene s;
    SptError e = {0};
    int rc = scene_load_gltf_memory(&s, j, n, "deep.gltf", &e);
    free(j);
    if (rc) fail_msg("deep hierarchy: %s", e.msg);
    assert_int_equal(s.tri_count, 1);
    assert_vertex(&s, 0, 1, 1, 0, 100);
    scene_free(&s);
}

/* Base64 (RFC 4648) of n bytes into out (NUL-terminated). */
static void base64(const void *data, size_t n, char *out)
{
    static const char t[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    const unsigned char *b = data;
    size_t o = 0;
    for (size_t i = 0; i < n; i += 3) {
        unsigned v = (unsigned)b[i] << 16 | (i + 1 < n ? (unsigned)b[i + 1] << 8 : 0) |
                     (i + 2 < n ? b[i + 2] : 0);
        out[o++] = t[v >> 18 & 63];
        out[o++] = t[v >> 12 & 63];
        out[o++] = i + 1 < n ? t[v >> 6 & 63] : '=';
        out[o++] = i + 2 < n ? t[v & 63] : '=';
    }
    out[o] = 0;
}

/* One triangle from a buffer (data URI of `bytes`) with the given bufferViews and
 * accessors (accessor 0 is POSITION; "extra" adds attributes), loaded from
 * memory; returns the loader's code, e.msg on failure. */
static int load_one(Scene *s, const void *bytes, size_t n, const char *views, const char *accessors,
                    const char *extra, const char *more_buffers, SptError *e)
{
    char b64[1024], json[8192];
    base64(bytes, n, b64);
    snprintf(json, sizeof json,
             "{\"asset\":{\"version\":\"2.0\"},\"scene\":0,\"scenes\":[{\"nodes\":[0]}],"
             "\"nodes\":[{\"mesh\":0}],\"buffers\":[{\"byteLength\":%zu,\"uri\":"
             "\"data:application/octet-stream;base64,%s\"}%s],\"bufferViews\":[%s],"
             "\"accessors\":[%s],\"meshes\":[{\"primitives\":[{\"attributes\":"
             "{\"POSITION\":0%s}}]}]}",
             n, b64, more_buffers, views, accessors, extra);
    return scene_load_gltf_memory(s, json, strlen(json), "valid.gltf", e);
}

/* Valid glTF the loader once refused (glTF 2.0 3.6.2.3): sparse accessors over a
 * buffer view and over zeros (no bufferView), an accessor without bufferView
 * (zeros), a buffer without uri in a .gltf that nothing reads, and a data URI
 * buffer in a GLB. Positions are checked against the values the specification
 * gives them. */
TEST(test_valid_sparse_and_zeros)
{
    struct {
        float pos[9];
        uint32_t idx[2];
        float val[6];
    } d = {{0, 0, 0, 1, 0, 0, 0, 1, 0}, {1, 2}, {2, 0, 0, 0, 3, 0}};
    const char *views = "{\"buffer\":0,\"byteLength\":36},{\"buffer\":0,\"byteOffset\":36,"
                        "\"byteLength\":8},{\"buffer\":0,\"byteOffset\":44,\"byteLength\":24}";
    const char *sparse = "\"sparse\":{\"count\":2,\"indices\":{\"bufferView\":1,"
                         "\"componentType\":5125},\"values\":{\"bufferView\":2}}";
    char acc[1024];
    Scene s;
    SptError e = {0};
    /* Over the buffer view: vertices 1 and 2 replaced. */
    snprintf(acc, sizeof acc, "{\"bufferView\":0,\"componentType\":5126,\"count\":3,\"type\":"
             "\"VEC3\",%s}", sparse);
    if (load_one(&s, &d, sizeof d, views, acc, "", "", &e)) fail_msg("%s", e.msg);
    assert_int_equal(s.tri_count, 1);
    assert_vertex(&s, 0, 0, 0, 0, 0);
    assert_vertex(&s, 0, 1, 2, 0, 0);
    assert_vertex(&s, 0, 2, 0, 3, 0);
    scene_free(&s);
    /* Over zeros, and a TEXCOORD_0 of zeros (no bufferView at all). */
    snprintf(acc, sizeof acc, "{\"componentType\":5126,\"count\":3,\"type\":\"VEC3\",%s},"
             "{\"componentType\":5126,\"count\":3,\"type\":\"VEC2\"}", sparse);
    if (load_one(&s, &d, sizeof d, views, acc, ",\"TEXCOORD_0\":1", "", &e)) fail_msg("%s", e.msg);
    assert_int_equal(s.tri_count, 1);
    assert_vertex(&s, 0, 1, 2, 0, 0);
    assert_vertex(&s, 0, 2, 0, 3, 0);
    scene_free(&s);
    /* A buffer without uri that nothing reads (one of its views is unused too). */
    char views2[512];
    snprintf(views2, sizeof views2, "%s,{\"buffer\":1,\"byteLength\":16}", views);
    snprintf(acc, sizeof acc, "{\"bufferView\":0,\"componentType\":5126,\"count\":3,\"type\":"
             "\"VEC3\"}");
    if (load_one(&s, &d, sizeof d, views2, acc, "", ",{\"byteLength\":64}", &e))
        fail_msg("%s", e.msg);
    assert_vertex(&s, 0, 2, 0, 1, 0);
    scene_free(&s);
    /* ... but reading it is refused, naming the accessor and the buffer. */
    snprintf(acc, sizeof acc, "{\"bufferView\":3,\"componentType\":5126,\"count\":1,\"type\":"
             "\"VEC3\"}");
    assert_int_equal(load_one(&s, &d, sizeof d, views2, acc, "", ",{\"byteLength\":64}", &e),
                     SPT_EXIT_INPUT);
    assert_non_null(strstr(e.msg, "accessors[0]"));
    assert_non_null(strstr(e.msg, "buffers[1], which has no uri"));
    /* Broken sparse parts are refused, naming what is wrong. */
    static const struct {
        uint32_t idx[2];
        const char *sparse, *want;
    } bad[] = {
        {{2, 1}, NULL, "sparse.indices[1] is 1"},
        {{1, 3}, NULL, "sparse.indices[1] is 3"},
        {{1, 2}, "\"sparse\":{\"count\":4,\"indices\":{\"bufferView\":1,\"componentType\":5125},"
                 "\"values\":{\"bufferView\":2}}", "sparse.count 4"},
        {{1, 2}, "\"sparse\":{\"count\":2,\"indices\":{\"bufferView\":1,\"componentType\":5125},"
                 "\"values\":{\"bufferView\":2,\"byteOffset\":4}}", "sparse.values"},
        {{1, 2}, "\"sparse\":{\"count\":2,\"indices\":{\"bufferView\":1,\"componentType\":5126},"
                 "\"values\":{\"bufferView\":2}}", "sparse.indices.componentType"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        memcpy(d.idx, bad[i].idx, sizeof d.idx);
        snprintf(acc, sizeof acc, "{\"bufferView\":0,\"componentType\":5126,\"count\":3,"
                 "\"type\":\"VEC3\",%s}", bad[i].sparse ? bad[i].sparse : sparse);
        assert_int_equal(load_one(&s, &d, sizeof d, views, acc, "", "", &e), SPT_EXIT_INPUT);
        if (!strstr(e.msg, bad[i].want) || !strstr(e.msg, "accessors[0]"))
            fail_msg("expected '%s' in: %s", bad[i].want, e.msg);
    }
    /* A GLB whose only buffer is a data URI (no BIN chunk). */
    char b64[256], json[2048];
    base64(d.pos, sizeof d.pos, b64);
    int len = snprintf(json, sizeof json,
        "{\"asset\":{\"version\":\"2.0\"},\"scene\":0,\"scenes\":[{\"nodes\":[0]}],"
        "\"nodes\":[{\"mesh\":0}],\"buffers\":[{\"byteLength\":36,\"uri\":"
        "\"data:application/octet-stream;base64,%s\"}],\"bufferViews\":[{\"buffer\":0,"
        "\"byteLength\":36}],\"accessors\":[{\"bufferView\":0,\"componentType\":5126,"
        "\"count\":3,\"type\":\"VEC3\"}],\"meshes\":[{\"primitives\":[{\"attributes\":"
        "{\"POSITION\":0}}]}]}", b64);
    while (len % 4) json[len++] = ' ';
    unsigned char glb[2100];
    uint32_t hdr[5] = {0x46546C67u, 2, 20 + (uint32_t)len, (uint32_t)len, 0x4E4F534Au};
    memcpy(glb, hdr, 20);
    memcpy(glb + 20, json, (size_t)len);
    if (scene_load_gltf_memory(&s, glb, 20 + (size_t)len, "datauri.glb", &e)) fail_msg("%s", e.msg);
    assert_vertex(&s, 0, 1, 1, 0, 0);
    scene_free(&s);
}

/* Indices, offsets and lengths that are not whole numbers in range are refused,
 * naming the property and the value (the glTF library read "0", 0.5 and 2^64 as
 * 0 or -1, which dropped a mesh silently, 2147483648 as -2147483648, and a
 * negative byteOffset as a huge one). */
TEST(test_index_numbers_refused)
{
    static const struct {
        const char *nodes, *accessor_extra, *view_extra, *want;
    } cases[] = {
        {"{\"mesh\":\"0\"}", "", "", "nodes[0].mesh: \"0\" is not an index"},
        {"{\"mesh\":0.5}", "", "", "nodes[0].mesh: 0.5 is not an index"},
        {"{\"mesh\":18446744073709551616}", "", "", "nodes[0].mesh: 1.8446744073709552e+19"},
        {"{\"mesh\":2147483648}", "", "", "nodes[0].mesh: 2147483648 is not an index"},
        {"{\"mesh\":0,\"children\":[-1]}", "", "", "nodes[0].children[0]: -1 is not an index"},
        {"{\"mesh\":0}", ",\"byteOffset\":-12", "", "accessors[0].byteOffset: -12"},
        {"{\"mesh\":0}", "", ",\"byteStride\":2147483644",
         "bufferViews[0].byteStride: 2147483644 is not a multiple of 4"},
    };
    float pos[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    char b64[64];
    base64(pos, sizeof pos, b64);
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        char json[4096];
        snprintf(json, sizeof json,
                 "{\"asset\":{\"version\":\"2.0\"},\"scene\":0,\"scenes\":[{\"nodes\":[0]}],"
                 "\"nodes\":[%s],\"buffers\":[{\"byteLength\":36,\"uri\":"
                 "\"data:application/octet-stream;base64,%s\"}],\"bufferViews\":[{\"buffer\":0,"
                 "\"byteLength\":36%s}],\"accessors\":[{\"bufferView\":0,\"componentType\":5126,"
                 "\"count\":3,\"type\":\"VEC3\"%s}],\"meshes\":[{\"primitives\":[{\"attributes\":"
                 "{\"POSITION\":0}}]}]}",
                 cases[i].nodes, b64, cases[i].view_extra, cases[i].accessor_extra);
        Scene s;
        SptError e = {0};
        int rc = scene_load_gltf_memory(&s, json, strlen(json), "numbers.gltf", &e);
        if (rc != SPT_EXIT_INPUT || !strstr(e.msg, cases[i].want))
            fail_msg("case %zu: returned %d, '%s'; expected '%s'", i, rc, e.msg, cases[i].want);
    }
    /* "scene": -1 as well. */
    const char *neg = "{\"asset\":{\"version\":\"2.0\"},\"scene\":-1}";
    Scene s;
    SptError e = {0};
    assert_int_equal(scene_load_gltf_memory(&s, neg, strlen(neg), "scene.gltf", &e), SPT_EXIT_INPUT);
    assert_non_null(strstr(e.msg, "scene: -1 is not an index"));
}

/* A scene that will not fit the memory stops at the object that passes the
 * limit, with one error (SPECTRACE_MAX_MEMORY_MB stands for a small machine):
 * 10000 instances of a triangle against 1 MiB, and a texture against 0.01 MiB. */
TEST(test_memory_budget)
{
    const int n = 10000;
    size_t cap = (size_t)n * 16 + 4096, len = 0;
    char *j = malloc(cap);
    len += (size_t)sprintf(j + len, "{\"asset\":{\"version\":\"2.0\"},\"scene\":0,\"scenes\":[{\"nodes\":[");
    for (int i = 0; i < n; i++)
        len += (size_t)sprintf(j + len, "%s%d", i ? "," : "", i);
    len += (size_t)sprintf(j + len, "]}],"
        "\"buffers\":[{\"byteLength\":36,\"uri\":\"data:application/octet-stream;base64,"
        "AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA\"}],"
        "\"bufferViews\":[{\"buffer\":0,\"byteLength\":36}],"
        "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\"}],"
        "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0}}]}],\"nodes\":[");
    for (int i = 0; i < n; i++)
        len += (size_t)sprintf(j + len, "%s{\"mesh\":0}", i ? "," : "");
    len += (size_t)sprintf(j + len, "]}");
    Scene s;
    SptError e = {0};
    setenv("SPECTRACE_MAX_MEMORY_MB", "1", 1);
    int rc = scene_load_gltf_memory(&s, j, len, "many.gltf", &e);
    unsetenv("SPECTRACE_MAX_MEMORY_MB");
    /* The mesh is placed by reference (docs/gltf.md, "Instancing"): each
     * placement costs 256 bytes, so 1 MiB is passed by the 4097th, nodes[4096]. */
    if (rc != SPT_EXIT_INPUT || !strstr(e.msg, "by nodes[4096]") ||
        !strstr(e.msg, "SPECTRACE_MAX_MEMORY_MB"))
        fail_msg("instances: returned %d: %s", rc, e.msg);
    /* Without the limit they load. */
    if ((rc = scene_load_gltf_memory(&s, j, len, "many.gltf", &e))) fail_msg("%s", e.msg);
    assert_int_equal(s.tri_count, 1);
    assert_int_equal(s.inst_count, (uint32_t)n);
    scene_free(&s);
    free(j);
    /* A 16x16 texture (3 or 4 KiB of floats) against 0.001 MiB (1048 bytes). */
    setenv("SPECTRACE_MAX_MEMORY_MB", "0.001", 1);
    rc = scene_load_gltf(&s, SPT_TEST_DATA("textures/texcoord1.gltf"), &e);
    unsetenv("SPECTRACE_MAX_MEMORY_MB");
    if (rc != SPT_EXIT_INPUT || !strstr(e.msg, "by images[0]"))
        fail_msg("texture: returned %d: %s", rc, e.msg);
}

TEST(test_default_camera_frames_box)
{
    /* Two triangles spanning the box (-3,-1,2)..(5,4,9), built by hand. */
    float pos[18] = {-3, -1, 2, 5, 4, 9, -3, 4, 2, 5, -1, 9, -3, -1, 9, 5, 4, 2};
    Scene s;
    memset(&s, 0, sizeof s);
    s.tri_count = 2;
    s.tri_pos = pos;
    scene_update_bounds(&s);
    assert_vec3(s.bounds_min, -3, -1, 2, 0);
    assert_vec3(s.bounds_max, 5, 4, 9, 0);
    scene_default_camera(&s);
    assert_int_equal(s.camera.is_default, 1);
    assert_all_visible(&s);
    /* Every corner of the box is visible too. */
    for (int k = 0; k < 8; k++) {
        float corner[9] = {k & 1 ? 5 : -3, k & 2 ? 4 : -1, k & 4 ? 9 : 2};
        Scene one = s;
        one.tri_count = 1;
        for (int i = 3; i < 9; i++) corner[i] = corner[i % 3];
        one.tri_pos = corner;
        assert_all_visible(&one);
    }
    /* Empty scene: bounds min > max and a finite camera. */
    s.tri_count = 0;
    scene_update_bounds(&s);
    assert_true(s.bounds_min[0] > s.bounds_max[0]);
    scene_default_camera(&s);
    assert_true(isfinite(s.camera.position[2]) && s.camera.znear > 0);
}

/* Bad inputs: each is refused with SPT_EXIT_INPUT and one line that starts with
 * the file name and names the object (docs/testing.md, "Bad input and faults", items 1-10). */
typedef struct BadCase {
    const char *file;
    const char *object;  /* must appear in the message */
    const char *object2; /* and this too, when not NULL */
} BadCase;

static const BadCase bad_cases[] = {
    {"bad_empty.gltf", "empty file", NULL},
    {"bad_notjson.gltf", "not valid JSON", NULL},
    {"bad_truncated.gltf", "not valid JSON", NULL},
    {"bad_glb_version.glb", "GLB version 1", NULL},
    {"bad_glb_truncated.glb", "truncated GLB", NULL},
    {"bad_glb_chunk.glb", "BIN chunk", NULL},
    {"bad_glb_magic.glb", "not valid JSON", NULL},
    {"bad_no_version.gltf", "asset.version", "missing"},
    {"bad_version.gltf", "asset.version", "'1.0'"},
    {"bad_dangling_accessor.gltf", "attributes.POSITION", "accessors[9]"},
    {"bad_dangling_bufferview.gltf", "accessors[1]", "bufferViews[9]"},
    {"bad_dangling_mesh.gltf", "nodes[0].mesh", "meshes[3]"},
    {"bad_dangling_material.gltf", "meshes[0].primitives[0].material", "materials[2]"},
    {"bad_dangling_node.gltf", "nodes[0].children[0]", "nodes[5]"},
    {"bad_dangling_scene_node.gltf", "scenes[0].nodes[1]", "nodes[4]"},
    {"bad_dangling_texture.gltf", "materials[0].pbrMetallicRoughness.baseColorTexture",
     "textures[4]"},
    {"bad_accessor_range.gltf", "accessors[0]", "bufferViews[0]"},
    {"bad_accessor_offset.gltf", "accessors[0]", "byteOffset 8"},
    {"bad_view_range.gltf", "bufferViews[3]", "buffers[0]"},
    {"bad_count0.gltf", "accessors[0]", "count is 0"},
    {"bad_count_overflow.gltf", "accessors[0]", "4611686018427387905"},
    {"bad_stride.gltf", "accessors[0]", "byteStride 8"},
    {"bad_index_range.gltf", "meshes[0].primitives[0].indices", "is 7"},
    {"bad_position_type.gltf", "POSITION (accessors[0])", "UNSIGNED_SHORT"},
    {"bad_position_vec2.gltf", "POSITION (accessors[0])", "VEC3"},
    {"bad_index_float.gltf", "indices (accessors[3])", "FLOAT"},
    {"bad_unequal_counts.gltf", "NORMAL (accessors[1])", "count 2"},
    {"bad_mode.gltf", "primitives[0].mode", NULL},
    {"bad_node_loop.gltf", "nodes[", "loop"},
    {"bad_node_self.gltf", "nodes[0]", "own child"},
    {"bad_two_parents.gltf", "nodes[1]", "two parents"},
    {"bad_ext_required.gltf", "KHR_texture_basisu", "EXT_spectrace_nope"},
    {"bad_camera_yfov.gltf", "cameras[0].perspective.yfov", NULL},
    {"bad_camera_zfar.gltf", "cameras[0].perspective.zfar", NULL},
    {"bad_buffer_missing.gltf", "buffers[0]", "not found"},
    {"bad_buffer_escape.gltf", "buffers[0]", "outside the scene folder"},
    {"bad_buffer_size.gltf", "buffers[0]", "byteLength"},
    {"bad_accessor_no_type.gltf", "accessors[2].componentType", "missing"},
    {"bad_node_not_object.gltf", "nodes[0]", "not a JSON object"},
    {"bad_buffer_datauri.gltf", "buffers[0].uri", "byteLength"},
    {"bad_extras_name.gltf", "materials[0] 'lamp'.extras.spectrace.emission", NULL},
    {"bad_extras_table.gltf", "materials[0] 'lamp'.extras.spectrace.reflectance[1]", NULL},
    {"bad_extras_key.gltf", "materials[0] 'lamp'", "emision"},
    {"bad_extras_conductor.gltf", "materials[0] 'lamp'.extras.spectrace.conductor", NULL},
    {"bad_light.gltf", "KHR_lights_punctual.lights[0].spot", NULL},
    {"bad_light_extras_name.gltf", "KHR_lights_punctual.lights[0] 'lamp'.extras.spectrace.emission", "D56"},
    {"bad_light_extras_table.gltf", "KHR_lights_punctual.lights[0] 'lamp'.extras.spectrace.emission[1]", NULL},
    {"bad_light_extras_key.gltf", "KHR_lights_punctual.lights[0] 'lamp'.extras.spectrace", "emision"},
    {"bad_light_extras_dark.gltf", "KHR_lights_punctual.lights[0] 'lamp'.extras.spectrace.emission",
     "no luminance"},
    {"bad_light_index.gltf", "nodes[0].extensions.KHR_lights_punctual.light", NULL},
};

static void test_bad_file(void **state)
{
    const BadCase *c = *state;
    char path[256];
    snprintf(path, sizeof path, "%s%s", DATA(""), c->file);
    Scene s;
    SptError e = {0};
    int rc = scene_load_gltf(&s, path, &e);
    if (rc != SPT_EXIT_INPUT) fail_msg("%s: returned %d (message '%s'), expected 3", path, rc, e.msg);
    if (strncmp(e.msg, path, strlen(path)) || strncmp(e.msg + strlen(path), ": ", 2))
        fail_msg("message does not start with '%s: ': %s", path, e.msg);
    if (!strstr(e.msg, c->object) || (c->object2 && !strstr(e.msg, c->object2)))
        fail_msg("message does not name '%s'%s%s: %s", c->object, c->object2 ? " and " : "",
                 c->object2 ? c->object2 : "", e.msg);
    if (strchr(e.msg, '\n')) fail_msg("message has more than one line: %s", e.msg);
    assert_int_equal(s.tri_count, 0);
    assert_null(s.tri_pos);
    /* The supported extensions listed as required are not reported. */
    if (!strcmp(c->file, "bad_ext_required.gltf")) {
        assert_null(strstr(e.msg, "KHR_materials_ior"));
        assert_null(strstr(e.msg, "KHR_draco_mesh_compression"));
    }
}

/* Inputs that once crashed or hung the loader (libFuzzer, tools/fuzz/): each
 * must load or be refused with SPT_EXIT_INPUT. */
TEST(test_fuzz_regressions)
{
    const char *dir = DATA("regress");
    DIR *d = opendir(dir);
    assert_non_null(d);
    int count = 0;
    struct dirent *ent;
    while ((ent = readdir(d))) {
        if (ent->d_name[0] == '.' || !strcmp(ent->d_name, "README.md")) continue;
        char path[512];
        snprintf(path, sizeof path, "%s/%s", dir, ent->d_name);
        Scene s;
        SptError e = {0};
        int rc = scene_load_gltf(&s, path, &e);
        if (rc != 0 && rc != SPT_EXIT_INPUT) fail_msg("%s: returned %d: %s", path, rc, e.msg);
        if (rc == 0) scene_free(&s);
        count++;
    }
    closedir(d);
    assert_true(count > 0);
}

/* Runs `spectrace ARGS` with stdout and stderr into out; returns the exit status. */
static int run_spectrace(const char *args, char *out, size_t out_size)
{
    return test_spectrace("", 0, args, TEST_BOTH, out, out_size);
}

TEST(test_info_command)
{
    static char out[65536];
    int rc = run_spectrace("info --no-bvh tests/data/gltf/modes.gltf", out, sizeof out);
    if (rc != 0) fail_msg("info modes.gltf exited %d:\n%s", rc, out);
    /* Counts derived by hand in test_strips_fans_index_types. */
    assert_non_null(strstr(out, "triangles    10 kept, 0 dropped"));
    assert_non_null(strstr(out, "2 skipped"));
    assert_non_null(strstr(out, "1 instance(s), 18 vertices"));
    assert_non_null(strstr(out, "(default: the file has none)"));
    rc = run_spectrace("info tests/data/gltf/garbage.gltf", out, sizeof out);
    assert_int_equal(rc, 0);
    assert_non_null(strstr(out, "1 kept, 5 dropped (3 NaN/Inf/huge coordinates, 2 degenerate)"));
    assert_non_null(strstr(out, "bvh "));
    /* Lights with spectra show them instead of the colour: the mercury lines,
     * and D65 at CIE 15's chromaticity (0.31272, 0.32903). */
    rc = run_spectrace("info --no-bvh tests/data/gltf/spectral_lights.gltf", out, sizeof out);
    assert_int_equal(rc, 0);
    assert_non_null(strstr(out, "hg                   spectrum (0 samples, 6 lines)"));
    assert_non_null(strstr(out, "xy 0.3127 0.3290"));
    assert_null(strstr(out, "colour"));
    rc = run_spectrace("info tests/data/gltf/bad_two_parents.gltf", out, sizeof out);
    assert_int_equal(rc, SPT_EXIT_INPUT);
    const char *want = "error: tests/data/gltf/bad_two_parents.gltf: nodes[1]";
    if (strncmp(out, want, strlen(want)) ||
        strchr(out, '\n') != out + strlen(out) - 1)
        fail_msg("expected one error line naming nodes[1], got:\n%s", out);
    assert_int_equal(run_spectrace("info", out, sizeof out), SPT_EXIT_USAGE);
    assert_int_equal(run_spectrace("info --help", out, sizeof out), 0);
    assert_non_null(strstr(out, "usage: spectrace info SCENE"));
}

/* One test per damaged file, named by the file, after the tests above. */
static int add_bad_cases(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    for (size_t i = 0; i < sizeof bad_cases / sizeof bad_cases[0]; i++)
        test_add(bad_cases[i].file, test_bad_file, (void *)&bad_cases[i]);
    return TEST_GO_ON;
}

TEST_MAIN_HOOK("gltf", NULL, NULL, add_bad_cases)
