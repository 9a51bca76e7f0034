// The glTF loader's parts (src/scene/gltf_*.cpp) share the Loader and its helpers
// through this header; nothing else includes it.
#ifndef SPT_GLTF_LOADER_H
#define SPT_GLTF_LOADER_H

#include <nlohmann/json.hpp>
#include <tiny_gltf.h>

#include <cerrno>
#include <climits>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <algorithm>
#include <map>
#include <memory>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include <sys/stat.h>

extern "C" {
#include "scene/scene.h"
#include "spectrum/cie_data.h"
#include "scene/mesh_decode.h"
#include "io/texture_io.h"
#include "core/input_file.h"
}

namespace spt_gltf {

using tinygltf::Value;

// Material extensions we know and deliberately ignore (one warning each, listing
// the materials): a file that requires one is refused like an unknown one.
// KHR_materials_volume_scatter would need a participating medium (scattering
// inside the volume, with a phase function) where the renderer has only
// Beer-Lambert absorption (docs/gltf.md).
inline const char *const k_ignored_material_ext[] = {
    "KHR_materials_volume_scatter",
};

// Other extensions we know and do not render, each with what rendering it would
// need (one warning each when extensionsUsed lists it; refused when required).
struct UnrenderedExt {
    const char *name, *needs;
};
inline const UnrenderedExt k_unrendered_ext[] = {
    {"KHR_texture_basisu",
     "its KTX2 images need a Basis Universal transcoder (libktx or basis_universal) to RGBA; a "
     "texture's fallback source is used where it has one, else the texture's factor"},
};

// Largest scene we flatten (triangles and vertices are indexed by uint32 and the
// renderer stores 36 bytes of positions per triangle).
inline constexpr uint64_t k_max_triangles = (uint64_t)1 << 30;
inline constexpr uint64_t k_max_vertices = (uint64_t)1 << 31;

// Column-major 4x4 matrix in double, as glTF stores them.
struct Mat4 {
    double m[16];
};

inline Mat4 mat_identity()
{
    Mat4 r = {};
    r.m[0] = r.m[5] = r.m[10] = r.m[15] = 1.0;
    return r;
}

inline Mat4 mat_mul(const Mat4 &a, const Mat4 &b)
{
    Mat4 r;
    for (int c = 0; c < 4; c++)
        for (int row = 0; row < 4; row++) {
            double s = 0;
            for (int k = 0; k < 4; k++) s += a.m[k * 4 + row] * b.m[c * 4 + k];
            r.m[c * 4 + row] = s;
        }
    return r;
}

// Point p transformed by m (affine).
inline void mat_point(const Mat4 &m, const double p[3], double out[3])
{
    for (int r = 0; r < 3; r++)
        out[r] = m.m[r] * p[0] + m.m[4 + r] * p[1] + m.m[8 + r] * p[2] + m.m[12 + r];
}

// A TANGENT (xyz, w the bitangent's sign) transformed by the upper 3x3 of m
// into out, normalised; w negated where m mirrors (the bitangent cross(n, t) w
// must follow m as t and the normal do); 0, 0, 0, 0 when degenerate (no tangent).
inline void mat_tangent(const Mat4 &m, const double t[3], float w, bool mirrored, float out[4])
{
    double d[3];
    for (int r = 0; r < 3; r++) d[r] = m.m[r] * t[0] + m.m[4 + r] * t[1] + m.m[8 + r] * t[2];
    double l = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    bool ok = l > 0 && std::isfinite(l) && w != 0;
    for (int r = 0; r < 3; r++) out[r] = ok ? (float)(d[r] / l) : 0.0f;
    out[3] = ok ? ((w < 0) != mirrored ? -1.0f : 1.0f) : 0.0f;
}

// Direction d transformed by the upper 3x3 of m.
inline void mat_dir(const Mat4 &m, const double d[3], double out[3])
{
    for (int r = 0; r < 3; r++) out[r] = m.m[r] * d[0] + m.m[4 + r] * d[1] + m.m[8 + r] * d[2];
}

inline double det3(const Mat4 &m)
{
    const double *a = m.m;
    return a[0] * (a[5] * a[10] - a[9] * a[6]) - a[4] * (a[1] * a[10] - a[9] * a[2]) +
           a[8] * (a[1] * a[6] - a[5] * a[2]);
}

// Cofactor matrix of the upper 3x3 (row-major 3x3): the inverse transpose times
// the determinant, so normals transform by it up to scale and sign.
inline void cofactor3(const Mat4 &m, double c[9])
{
    // a(r, col) = m.m[col * 4 + r]
    auto a = [&](int r, int col) { return m.m[col * 4 + r]; };
    for (int r = 0; r < 3; r++)
        for (int col = 0; col < 3; col++) {
            int r1 = (r + 1) % 3, r2 = (r + 2) % 3, c1 = (col + 1) % 3, c2 = (col + 2) % 3;
            c[r * 3 + col] = a(r1, c1) * a(r2, c2) - a(r1, c2) * a(r2, c1);
        }
}

inline bool normalize3(double v[3])
{
    double l = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    if (!(l > 0) || !std::isfinite(l)) return false;
    for (int i = 0; i < 3; i++) v[i] /= l;
    return true;
}

inline void cross3(const double a[3], const double b[3], double out[3])
{
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}

// Percent-decoding of a relative URI into a file name.
std::string uri_decode(const std::string &uri);
// The names as one "a, b, c" list.
std::string join_names(const std::vector<std::string> &v);
// The first line of a message, without leading blanks.
std::string first_line(std::string s);
// Byte size and name of a glTF component type; component count and name of an
// accessor type.
int component_size(int type);
const char *component_name(int type);
int type_components(int type);
const char *type_name(int n);

struct PrimData {
    bool read = false, skip = false;
    std::vector<float> pos, nrm, uv, uv1; // per vertex, in the mesh's space
    std::vector<float> col;               // COLOR_0: 4 per vertex (alpha 1 for VEC3)
    std::vector<float> tan;               // TANGENT: 4 per vertex (w: the bitangent's sign)
    // Primitives with the same POSITION, NORMAL, TEXCOORD_0, TEXCOORD_1, COLOR_0 and TANGENT
    // accessors (as exporters write multi-material meshes) share one copy of the
    // vertices: vsrc is the primitive holding them (nullptr: this one).
    const PrimData *vsrc = nullptr;
    std::vector<uint32_t> tris;      // 3 local vertex indices per triangle, file winding
    uint32_t material = 0;
    // Morph targets and skin weights (src/scene/gltf_pose.cpp): a primitive with
    // either keeps its own vertices (vsrc stays null), as they move per instance.
    bool deformable = false;
    std::vector<std::vector<float>> tpos, tnrm, ttan; // per target: POSITION, NORMAL, TANGENT deltas (or empty)
    std::vector<float> joints, weights;         // 8 per vertex (JOINTS_0/1, WEIGHTS_0/1); empty: none
};

// A node's animated properties at the posed time (which ones the animations set).
struct NodePose {
    bool t = false, r = false, s = false, w = false;
    double T[3] = {0, 0, 0}, R[4] = {0, 0, 0, 1}, S[3] = {1, 1, 1};
    std::vector<double> W; // morph weights
};

// What moves one mesh instance's vertices: its morph weights and, when its node
// has a skin, the joint matrices.
struct Deform {
    std::vector<double> weights;
    const std::vector<Mat4> *joints = nullptr; // the skin's (Loader::skin_matrices); null: none
    int skin = -1;
};

struct Loader {
    const char *file = "";   // the name in messages
    std::string dir;         // folder of the scene, for external files
    std::string dir_real;    // its realpath, for the containment check
    SptError *e = nullptr;
    tinygltf::Model m;
    std::map<int, std::vector<unsigned char>> data_uri_images; // image -> encoded bytes
    std::vector<std::string> refused; // external files outside the folder

    // Output under construction.
    std::vector<float> tri_pos, vtx_normal, vtx_uv, vtx_uv1, vtx_color, vtx_tangent;
    bool any_uv1 = false, any_color = false; // some primitive has TEXCOORD_1 / COLOR_0
    bool any_tangent = false;                // some primitive has TANGENT
    std::vector<uint32_t> tri_vidx, tri_mat;
    uint64_t vertex_count = 0;
    std::vector<SceneMaterial> mats;
    std::vector<SceneTexture> texs;
    std::vector<SceneLight> lights;
    SceneCamera camera = {};
    bool have_camera = false;
    // The pose (src/scene/gltf_pose.cpp): what was asked, each node's animated
    // properties, parents and world transforms (computed on demand for joints).
    ScenePose pose_opts = {NAN, nullptr, nullptr, SCENE_INSTANCING_AUTO};
    std::vector<NodePose> pose;
    std::vector<int> parent;
    std::vector<Mat4> world;
    std::vector<char> world_state;
    int chosen_camera = -1; // --camera's index into cameras[]; -1: the first placed
    uint32_t unplayed_channels = 0; // channels without target.node (extensions')
    // Read once however many samplers or instances share them: animation
    // accessors by (accessor, values per key: 0 for times) and skins' joint
    // matrices by skin.
    std::map<std::pair<int, int>, std::vector<float>> anim_floats;
    std::map<int, std::vector<Mat4>> skin_matrices;
    std::vector<SceneAnimationInfo> anim_info;
    std::vector<SceneCameraInfo> cam_info;
    SceneStats stats = {};
    int default_material = -1;
    uint32_t modes_skipped = 0, no_position = 0, texcoord_warned = 0, leftover_indices = 0;
    uint32_t specgloss_textures = 0, meshopt_views = 0, draco_primitives = 0;
    uint32_t texcoord_unread = 0;  // primitives with TEXCOORD_n, n > 1 (never read)
    uint32_t uv1_missing = 0;      // slots reading TEXCOORD_1 of a primitive without it
    bool quantization = false; // KHR_mesh_quantization in extensionsUsed
    std::map<std::string, std::vector<std::string>> ignored_ext; // extension -> materials

    std::vector<std::vector<PrimData>> prim; // [mesh][primitive]
    std::map<std::tuple<int, int, int, int, int, int>, const PrimData *> vertex_owner; // accessors -> data
    std::vector<uint32_t> mesh_emitted;      // instances emitted so far, per mesh
    // The traversal's placements of meshes (node or EXT_mesh_gpu_instancing
    // instance), in scene order; place_meshes then flattens each or keeps it
    // as an instance (src/scene/gltf_instances.cpp).
    struct Placement {
        int mesh, node;
        Mat4 world;
    };
    std::vector<Placement> placements;
    // The meshes placed by reference: their instances (index into
    // ref_meshes, 3x4 rows) and the file's mesh of each.
    std::vector<int> ref_meshes;
    std::vector<uint32_t> ref_tri_count, inst_mesh;
    std::vector<float> inst_xf;
    std::vector<int> decoded_state;          // per image: 0 untried, 1 ok, -1 failed
    std::vector<TextureImage> decoded;
    std::map<std::tuple<int, int, int, int, int>, int> texture_of; // (image,srgb,ws,wt,nearest)

    // "FILE: " + formatted text, SPT_EXIT_INPUT.
    int bad(const char *fmt, ...) __attribute__((format(printf, 2, 3)))
    {
        char text[900];
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(text, sizeof text, fmt, ap);
        va_end(ap);
        return spt_fail(e, SPT_EXIT_INPUT, "%s: %s", file, text);
    }

    bool inside_folder(const std::string &path, std::string *real_out);
    int parse(const unsigned char *data, size_t size);
    // The deepest JSON nesting accepted (docs/gltf.md); deeper text is refused
    // before parsing, as the glTF library's recursion would overflow the stack.
    static constexpr int k_max_json_depth = 128;
    int check_json_depth(const unsigned char *json, size_t size);
    int check_json_numbers(const unsigned char *json, size_t size);
    int diagnose_parse_failure(const unsigned char *json, size_t size, const std::string &err);
    int check_version_and_extensions();
    int check_buffer_views();
    int check_accessor(int index, const std::string &obj, int want_components,
                       const std::vector<int> &types, int normalized_ok, bool *zeros);
    // The memory the scene takes as it is read (approximate: triangles, vertices
    // and decoded texels with what the BVH and the device copies add), against
    // spt_memory_limit(): a scene too large stops at the object that passes it.
    double mem_limit = 0, mem_used_textures = 0;
    int over_budget_rc = 0;
    static constexpr double k_bytes_per_triangle = 160, k_bytes_per_vertex = 64;
    // A placement of a mesh, and an instance: the transforms here and on the
    // device (BvhInstance, 112 bytes) and a share of the top level's nodes.
    static constexpr double k_bytes_per_instance = 256;
    int charge_memory(const std::string &what);
    int check_sparse(int index, const char *obj);
    int check_view_has_data(int view, const char *obj, int index);
    std::vector<int> dead_views; // views of .gltf buffers without uri (no data)
    // (mesh, primitive) -> its indices accessor, which has no bufferView
    // (taken out of the primitive for the glTF library: rewrite_fallback_buffers)
    std::map<std::pair<int, int>, int> zero_view_indices;
    uint32_t colors_clamped = 0; // COLOR_0 components outside [0, 1], clamped
    const unsigned char *sparse_data(int view, int offset) const;
    int read_floats(int index, int ncomp, std::vector<float> &out);
    int read_indices(int index, std::vector<uint32_t> &out);
    int node_local(int n, Mat4 *out);
    int gpu_instances(int n, const Value &ext, const Mat4 &world);
    int traverse();
    int material(int index);
    int material_core(const tinygltf::Material &mat, SceneMaterial *sm, const std::string &obj);
    int material_extensions(const tinygltf::Material &mat, SceneMaterial *sm, const std::string &obj);
    int material_ext_scalars(const tinygltf::Material &mat, SceneMaterial *sm, const std::string &eo);
    int material_ext_volume(const Value *x, SceneMaterial *sm, const std::string &vo);
    int material_ext_specular(const Value *x, SceneMaterial *sm, const std::string &so);
    int material_ext_clearcoat(const Value *x, SceneMaterial *sm, const std::string &co);
    int material_ext_sheen(const Value *x, SceneMaterial *sm, const std::string &sho);
    int material_ext_iridescence(const Value *x, SceneMaterial *sm, const std::string &io);
    int material_ext_anisotropy(const Value *x, SceneMaterial *sm, const std::string &ao);
    int material_ext_diffuse_transmission(const Value *x, SceneMaterial *sm, const std::string &dto);
    int texture_ref(int tex, int texcoord, bool srgb, const std::string &obj, SceneTexRef *out,
                    const tinygltf::ExtensionMap *ext, bool load = true);
    int ext_texture(const Value &x, const char *key, bool srgb, const std::string &obj,
                    SceneTexRef *out, float *scale = nullptr);
    int texture_transform(const tinygltf::ExtensionMap *ext, int *texcoord,
                          const std::string &obj, float *uv_transform);
    int spec_gloss(const Value &x, SceneMaterial *sm, const std::string &obj);
    int decode_image(int image);
    int spectral_extras(const Value &extras, SceneMaterial *sm, const std::string &obj);
    int light_extras(const Value &extras, SceneLight *sl, const std::string &obj);
    int parse_spd(const Value &v, Spd *out, const std::string &obj);
    int read_primitive(int mesh, int p);
    int read_draco(int mesh, int p, const Value &ext, std::vector<uint32_t> &idx);
    int decode_meshopt_views();
    int emit_instance(int mesh, const Mat4 &world, int node);
    int emit_triangles(int mesh, const Mat4 &world, int node);
    int place(int mesh, const Mat4 &world, int node);
    bool by_reference_ok(int mesh, const std::vector<int> &nodes);
    int place_meshes();
    int select_camera();
    int animations();
    int node_world(int n, Mat4 *out);
    int read_deform(int mesh, int p, size_t nv);
    int deform_for(int node, int mesh, Deform *d);
    int deform_vertex(const PrimData &pd, int mesh, int p, size_t v, const Deform &d,
                      const Mat4 &world, double wp[3], double nw[3], float tw[4], bool *flip);
    int camera_from(int cam, const Mat4 &world, int node);
    int light_from(int light, const Mat4 &world, int node);
    int finish(Scene *s);
};

// tinygltf's file callbacks (src/scene/gltf_files.cpp): every file is checked to
// lie inside the scene's folder before it is opened.
bool fs_exists(const std::string &path, void *user);
std::string fs_expand(const std::string &path, void *);
bool fs_read(std::vector<unsigned char> *out, std::string *err, const std::string &path,
             void *user);
bool fs_write(std::string *err, const std::string &, const std::vector<unsigned char> &, void *);
bool keep_image_bytes(tinygltf::Image *image, const int index, std::string *, std::string *, int,
                      int, const unsigned char *bytes, int size, void *user);

} // namespace spt_gltf

#endif
