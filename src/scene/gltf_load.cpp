// glTF 2.0 loading into the flat Scene (src/scene/scene.h): the entry points and
// the last step, the Scene's arrays. The steps before live in src/scene/gltf_*.cpp
// (files, parse, nodes, pose, materials, geometry), the only tinygltf code.
//
// tinygltf parses the JSON (and the GLB container, after we have checked it);
// everything it does not check is checked here before any data is read: buffer
// view and accessor ranges (overflow-safe), dangling indices, component types,
// attribute counts, index ranges, node loops and parents, cameras, lights,
// required extensions. Each refusal is one SptError "FILE: OBJECT: reason" with
// SPT_EXIT_INPUT; each skip is one warning with a count.
#include "scene/gltf_loader.h"

namespace spt_gltf {

template <class T> static T *copy_out(const std::vector<T> &v)
{
    T *p = (T *)spt_malloc(v.size() * sizeof(T));
    if (!v.empty()) memcpy(p, v.data(), v.size() * sizeof(T));
    return p;
}

int Loader::finish(Scene *s)
{
    if (modes_skipped)
        spt_warn("%s: skipped %u primitive(s) of points or lines (only triangles are rendered)",
                 file, modes_skipped);
    if (no_position)
        spt_warn("%s: skipped %u primitive(s) without POSITION", file, no_position);
    if (leftover_indices)
        spt_warn("%s: %u TRIANGLES primitive(s) have a vertex count that is not a multiple of 3; "
                 "the extra vertices were ignored",
                 file, leftover_indices);
    if (texcoord_warned || texcoord_unread)
        spt_warn("%s: only TEXCOORD_0 and TEXCOORD_1 are read: %u texture reference(s) with a "
                 "texCoord above 1 use TEXCOORD_0, %u primitive(s) have TEXCOORD_2 or higher",
                 file, texcoord_warned, texcoord_unread);
    if (uv1_missing)
        spt_warn("%s: %u primitive(s) without TEXCOORD_1 have a material that reads it; their "
                 "TEXCOORD_0 is used instead",
                 file, uv1_missing);
    if (colors_clamped)
        spt_warn("%s: %u COLOR_0 component(s) outside [0, 1] clamped to it (a vertex colour "
                 "multiplies the base colour)",
                 file, colors_clamped);
    if (specgloss_textures)
        spt_warn("%s: %u KHR_materials_pbrSpecularGlossiness specularGlossinessTexture(s) "
                 "ignored (only the factors are converted)",
                 file, specgloss_textures);
    for (const auto &ig : ignored_ext)
        spt_warn("%s: %s is not rendered; ignored on %zu material(s): %s", file,
                 ig.first.c_str(), ig.second.size(), join_names(ig.second).c_str());
    if (stats.dropped_nonfinite)
        spt_warn("%s: dropped %u triangle(s) with NaN, infinite or huge (>= 1e18) coordinates",
                 file, stats.dropped_nonfinite);
    if (stats.dropped_degenerate)
        spt_warn("%s: dropped %u degenerate triangle(s) (zero area or repeated index)", file,
                 stats.dropped_degenerate);
    stats.skipped_primitives = modes_skipped + no_position;
    std::vector<char> mesh_used(m.meshes.size(), 0);
    for (size_t mi = 0; mi < prim.size(); mi++)
        for (const auto &pd : prim[mi]) mesh_used[mi] |= pd.read;
    for (char u : mesh_used) stats.meshes += u ? 1 : 0;

    s->tri_count = (uint32_t)tri_mat.size();
    s->tri_pos = copy_out(tri_pos);
    s->tri_vidx = copy_out(tri_vidx);
    s->tri_mat = copy_out(tri_mat);
    s->vertex_count = (uint32_t)vertex_count;
    s->vtx_normal = copy_out(vtx_normal);
    s->vtx_uv = copy_out(vtx_uv);
    s->vtx_uv1 = any_uv1 ? copy_out(vtx_uv1) : nullptr;
    s->vtx_color = any_color ? copy_out(vtx_color) : nullptr;
    s->vtx_tangent = any_tangent ? copy_out(vtx_tangent) : nullptr;
    s->material_count = (uint32_t)mats.size();
    s->materials = copy_out(mats);
    mats.clear(); // the SPDs now belong to s
    s->texture_count = (uint32_t)texs.size();
    s->textures = copy_out(texs);
    texs.clear();
    s->light_count = (uint32_t)lights.size();
    s->lights = copy_out(lights);
    lights.clear(); // their SPDs too
    s->stats = stats;
    s->camera_info_count = (uint32_t)cam_info.size();
    s->camera_info = copy_out(cam_info);
    s->animation_info_count = (uint32_t)anim_info.size();
    s->animation_info = copy_out(anim_info);
    if (!inst_mesh.empty()) { // the meshes placed by reference (gltf_instances.cpp)
        s->mesh_count = (uint32_t)ref_tri_count.size();
        s->mesh_tri_count = copy_out(ref_tri_count);
        s->inst_count = (uint32_t)inst_mesh.size();
        s->inst_mesh = copy_out(inst_mesh);
        s->inst_xf = copy_out(inst_xf);
    }
    if (unplayed_channels)
        spt_warn("%s: %u animation channel(s) without target.node (an extension's, such as "
                 "KHR_animation_pointer) not played",
                 file, unplayed_channels);
    scene_update_bounds(s);
    if (have_camera) {
        s->camera = camera;
    } else {
        scene_default_camera(s);
        spt_warn("%s: no camera in the scene; using a default one that frames the bounds from +Z",
                 file);
    }
    return 0;
}

static int load(Scene *s, const unsigned char *data, size_t size, const char *name,
                const ScenePose *pose, SptError *e)
{
    memset(s, 0, sizeof *s);
    Loader L;
    L.file = name;
    L.e = e;
    if (pose) L.pose_opts = *pose;
    const char *slash = strrchr(name, '/');
    L.dir = slash ? std::string(name, (size_t)(slash - name)) : std::string(".");
    if (L.dir.empty()) L.dir = "/";
    char *real = realpath(L.dir.c_str(), nullptr);
    L.dir_real = real ? real : L.dir;
    free(real);
    int rc = 0;
    try {
        if ((rc = L.parse(data, size)) || (rc = L.check_version_and_extensions()) ||
            (rc = L.decode_meshopt_views()) || (rc = L.check_buffer_views()))
            goto out;
        L.prim.resize(L.m.meshes.size());
        for (size_t i = 0; i < L.m.meshes.size(); i++)
            L.prim[i].resize(L.m.meshes[i].primitives.size());
        L.mesh_emitted.assign(L.m.meshes.size(), 0);
        L.mem_limit = spt_memory_limit();
        L.decoded_state.assign(L.m.images.size(), 0);
        L.decoded.assign(L.m.images.size(), TextureImage());
        for (size_t i = 0; i < L.m.materials.size(); i++) {
            int mi = L.material((int)i);
            if (mi < 0) {
                rc = -mi;
                goto out;
            }
        }
        if ((rc = L.select_camera()) || (rc = L.traverse())) goto out;
        s->path = spt_strdup(name);
        rc = L.finish(s);
    } catch (const std::bad_alloc &) {
        rc = L.bad("out of memory while loading");
    } catch (const std::exception &ex) {
        rc = L.bad("%s", ex.what());
    }
out:
    for (auto &sm : L.mats) {
        spd_free(&sm.emission_spd);
        spd_free(&sm.reflectance_spd);
    }
    for (auto &l : L.lights) spd_free(&l.spd);
    for (auto &t : L.texs) free(t.texels);
    for (auto &d : L.decoded) texture_io_free(&d);
    if (rc) scene_free(s);
    return rc;
}

} // namespace spt_gltf

extern "C" int scene_load_gltf_memory(Scene *s, const void *data, size_t size, const char *name,
                                      SptError *e)
{
    return scene_load_gltf_memory_posed(s, data, size, name, nullptr, e);
}

extern "C" int scene_load_gltf_memory_posed(Scene *s, const void *data, size_t size,
                                            const char *name, const ScenePose *pose, SptError *e)
{
    return spt_gltf::load(s, (const unsigned char *)data, size, name, pose, e);
}

extern "C" int scene_load_gltf(Scene *s, const char *path, SptError *e)
{
    return scene_load_gltf_posed(s, path, nullptr, e);
}

extern "C" int scene_load_gltf_posed(Scene *s, const char *path, const ScenePose *pose,
                                     SptError *e)
{
    memset(s, 0, sizeof *s);
    unsigned char *bytes = nullptr;
    size_t size = 0;
    int rc = input_read(path, "scene file", &bytes, &size, e);
    if (rc) return rc;
    rc = spt_gltf::load(s, bytes, size, path, pose, e);
    free(bytes);
    return rc;
}
