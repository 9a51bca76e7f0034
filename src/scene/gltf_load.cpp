// glTF 2.0 loading into the flat Scene (src/scene/scene.h). The only tinygltf code.
//
// tinygltf parses the JSON (and the GLB container, after we have checked it);
// everything it does not check is checked here before any data is read: buffer
// view and accessor ranges (overflow-safe), dangling indices, component types,
// attribute counts, index ranges, node loops and parents, cameras, lights,
// required extensions. Each refusal is one SptError "FILE: OBJECT: reason" with
// SPT_EXIT_INPUT; each skip is one warning with a count.
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
#include <vector>

#include <sys/stat.h>

extern "C" {
#include "scene/scene.h"
#include "shared/cie_data.h"
#include "scene/mesh_decode.h"
#include "scene/texture_io.h"
}

namespace {

using tinygltf::Value;

// Extensions whose meaning we implement; only these may be in extensionsRequired.
// Keep in sync with the code that reads them and the README's loader section.
const char *const k_supported_ext[] = {
    "KHR_materials_emissive_strength", "KHR_materials_ior", "KHR_materials_transmission",
    "KHR_materials_dispersion", "KHR_materials_volume", "KHR_materials_unlit",
    "KHR_lights_punctual", "KHR_texture_transform", "KHR_materials_pbrSpecularGlossiness",
    "KHR_mesh_quantization", "EXT_meshopt_compression", "KHR_draco_mesh_compression",
    "EXT_texture_webp", "KHR_materials_specular", "KHR_materials_clearcoat", "KHR_materials_sheen",
};

// Material extensions we know and deliberately ignore (one warning each, listing
// the materials): a file that requires one is refused like an unknown one.
const char *const k_ignored_material_ext[] = {
    "KHR_materials_iridescence", "KHR_materials_anisotropy",
};

// Conductors the spectral extras may name (complex IOR tables in the renderer).
const char *const k_conductors[] = {"Au", "Ag", "Al", "Cu"};

// Largest scene we flatten (triangles and vertices are indexed by uint32 and the
// renderer stores 36 bytes of positions per triangle).
const uint64_t k_max_triangles = (uint64_t)1 << 30;
const uint64_t k_max_vertices = (uint64_t)1 << 31;

// Column-major 4x4 matrix in double, as glTF stores them.
struct Mat4 {
    double m[16];
};

Mat4 mat_identity()
{
    Mat4 r = {};
    r.m[0] = r.m[5] = r.m[10] = r.m[15] = 1.0;
    return r;
}

Mat4 mat_mul(const Mat4 &a, const Mat4 &b)
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
void mat_point(const Mat4 &m, const double p[3], double out[3])
{
    for (int r = 0; r < 3; r++)
        out[r] = m.m[r] * p[0] + m.m[4 + r] * p[1] + m.m[8 + r] * p[2] + m.m[12 + r];
}

// Direction d transformed by the upper 3x3 of m.
void mat_dir(const Mat4 &m, const double d[3], double out[3])
{
    for (int r = 0; r < 3; r++) out[r] = m.m[r] * d[0] + m.m[4 + r] * d[1] + m.m[8 + r] * d[2];
}

double det3(const Mat4 &m)
{
    const double *a = m.m;
    return a[0] * (a[5] * a[10] - a[9] * a[6]) - a[4] * (a[1] * a[10] - a[9] * a[2]) +
           a[8] * (a[1] * a[6] - a[5] * a[2]);
}

// Cofactor matrix of the upper 3x3 (row-major 3x3): the inverse transpose times
// the determinant, so normals transform by it up to scale and sign.
void cofactor3(const Mat4 &m, double c[9])
{
    // a(r, col) = m.m[col * 4 + r]
    auto a = [&](int r, int col) { return m.m[col * 4 + r]; };
    for (int r = 0; r < 3; r++)
        for (int col = 0; col < 3; col++) {
            int r1 = (r + 1) % 3, r2 = (r + 2) % 3, c1 = (col + 1) % 3, c2 = (col + 2) % 3;
            c[r * 3 + col] = a(r1, c1) * a(r2, c2) - a(r1, c2) * a(r2, c1);
        }
}

bool normalize3(double v[3])
{
    double l = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    if (!(l > 0) || !std::isfinite(l)) return false;
    for (int i = 0; i < 3; i++) v[i] /= l;
    return true;
}

void cross3(const double a[3], const double b[3], double out[3])
{
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}

// Percent-decoding of a relative URI into a file name.
std::string uri_decode(const std::string &uri)
{
    std::string out;
    for (size_t i = 0; i < uri.size(); i++) {
        if (uri[i] == '%' && i + 2 < uri.size() && isxdigit((unsigned char)uri[i + 1]) &&
            isxdigit((unsigned char)uri[i + 2])) {
            out += (char)strtol(uri.substr(i + 1, 2).c_str(), nullptr, 16);
            i += 2;
        } else {
            out += uri[i];
        }
    }
    return out;
}

std::string join_names(const std::vector<std::string> &v)
{
    std::string s;
    for (size_t i = 0; i < v.size(); i++) s += (i ? ", " : "") + v[i];
    return s;
}

std::string first_line(std::string s)
{
    while (!s.empty() && (s[0] == '\n' || s[0] == ' ')) s.erase(0, 1);
    size_t nl = s.find('\n');
    if (nl != std::string::npos) s.resize(nl);
    return s;
}

int component_size(int type)
{
    switch (type) {
    case TINYGLTF_COMPONENT_TYPE_BYTE:
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return 1;
    case TINYGLTF_COMPONENT_TYPE_SHORT:
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: return 2;
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT:
    case TINYGLTF_COMPONENT_TYPE_FLOAT: return 4;
    default: return 0;
    }
}

const char *component_name(int type)
{
    switch (type) {
    case TINYGLTF_COMPONENT_TYPE_BYTE: return "BYTE";
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return "UNSIGNED_BYTE";
    case TINYGLTF_COMPONENT_TYPE_SHORT: return "SHORT";
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: return "UNSIGNED_SHORT";
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: return "UNSIGNED_INT";
    case TINYGLTF_COMPONENT_TYPE_FLOAT: return "FLOAT";
    default: return "an invalid component type";
    }
}

int type_components(int type)
{
    switch (type) {
    case TINYGLTF_TYPE_SCALAR: return 1;
    case TINYGLTF_TYPE_VEC2: return 2;
    case TINYGLTF_TYPE_VEC3: return 3;
    case TINYGLTF_TYPE_VEC4: return 4;
    case TINYGLTF_TYPE_MAT2: return 4;
    case TINYGLTF_TYPE_MAT3: return 9;
    case TINYGLTF_TYPE_MAT4: return 16;
    default: return 0;
    }
}

const char *type_name(int n)
{
    switch (n) {
    case 1: return "SCALAR";
    case 2: return "VEC2";
    case 3: return "VEC3";
    default: return "VEC4";
    }
}

// The mesh data of one primitive, read once and shared by its instances.
struct PrimData {
    bool read = false, skip = false;
    std::vector<float> pos, nrm, uv, uv1; // per vertex, in the mesh's space
    std::vector<float> col;               // COLOR_0: 4 per vertex (alpha 1 for VEC3)
    // Primitives with the same POSITION, NORMAL, TEXCOORD_0, TEXCOORD_1 and COLOR_0
    // accessors (as exporters write multi-material meshes) share one copy of the
    // vertices: vsrc is the primitive holding them (nullptr: this one).
    const PrimData *vsrc = nullptr;
    std::vector<uint32_t> tris;      // 3 local vertex indices per triangle, file winding
    uint32_t material = 0;
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
    std::vector<float> tri_pos, vtx_normal, vtx_uv, vtx_uv1, vtx_color;
    bool any_uv1 = false, any_color = false; // some primitive has TEXCOORD_1 / COLOR_0
    std::vector<uint32_t> tri_vidx, tri_mat;
    uint64_t vertex_count = 0;
    std::vector<SceneMaterial> mats;
    std::vector<SceneTexture> texs;
    std::vector<SceneLight> lights;
    SceneCamera camera = {};
    bool have_camera = false;
    SceneStats stats = {};
    int default_material = -1;
    uint32_t modes_skipped = 0, no_position = 0, texcoord_warned = 0, leftover_indices = 0;
    uint32_t specgloss_textures = 0, meshopt_views = 0, draco_primitives = 0;
    uint32_t texcoord_unread = 0;  // primitives with TEXCOORD_n, n > 1 (never read)
    uint32_t uv1_missing = 0;      // slots reading TEXCOORD_1 of a primitive without it
    bool quantization = false; // KHR_mesh_quantization in extensionsUsed
    std::map<std::string, std::vector<std::string>> ignored_ext; // extension -> materials

    std::vector<std::vector<PrimData>> prim; // [mesh][primitive]
    std::map<std::tuple<int, int, int, int, int>, const PrimData *> vertex_owner; // accessors -> data
    std::vector<uint32_t> mesh_emitted;      // instances emitted so far, per mesh
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
    int diagnose_parse_failure(const unsigned char *json, size_t size, const std::string &err);
    int check_version_and_extensions();
    int check_buffer_views();
    int check_accessor(int index, const std::string &obj, int want_components,
                       const std::vector<int> &types, int normalized_ok, bool *zeros);
    int read_floats(int index, int ncomp, std::vector<float> &out);
    int read_indices(int index, std::vector<uint32_t> &out);
    int node_local(int n, Mat4 *out);
    int traverse();
    int material(int index);
    int texture_ref(int tex, int texcoord, bool srgb, const std::string &obj, SceneTexRef *out,
                    const tinygltf::ExtensionMap *ext, bool load = true);
    int ext_texture(const Value &x, const char *key, bool srgb, const std::string &obj,
                    SceneTexRef *out, float *scale = nullptr);
    int texture_transform(const tinygltf::ExtensionMap *ext, int *texcoord,
                          const std::string &obj, float *uv_transform);
    int spec_gloss(const Value &x, SceneMaterial *sm, const std::string &obj);
    int decode_image(int image);
    int spectral_extras(const Value &extras, SceneMaterial *sm, const std::string &obj);
    int parse_spd(const Value &v, Spd *out, const std::string &obj);
    int read_primitive(int mesh, int p);
    int read_draco(int mesh, int p, const Value &ext, std::vector<uint32_t> &idx);
    int decode_meshopt_views();
    int emit_instance(int mesh, const Mat4 &world);
    int camera_from(int cam, const Mat4 &world, int node);
    int light_from(int light, const Mat4 &world, int node);
    int finish(Scene *s);
};

// ---------------------------------------------------------------------------
// File access: tinygltf reads external buffers and images through these, so no
// file outside the scene's folder is ever opened.

bool Loader::inside_folder(const std::string &path, std::string *real_out)
{
    char *real = realpath(path.c_str(), nullptr);
    if (!real) return false;
    std::string r(real);
    free(real);
    if (real_out) *real_out = r;
    return r.size() > dir_real.size() && r.compare(0, dir_real.size(), dir_real) == 0 &&
           (r[dir_real.size()] == '/' || dir_real == "/");
}

bool fs_exists(const std::string &path, void *user)
{
    Loader *L = (Loader *)user;
    struct stat st;
    if (stat(path.c_str(), &st) != 0 || !S_ISREG(st.st_mode)) return false;
    if (!L->inside_folder(path, nullptr)) {
        L->refused.push_back(path);
        return false;
    }
    return true;
}

std::string fs_expand(const std::string &path, void *) { return path; }

bool fs_read(std::vector<unsigned char> *out, std::string *err, const std::string &path,
             void *user)
{
    Loader *L = (Loader *)user;
    if (!L->inside_folder(path, nullptr)) {
        if (err) *err = "outside the scene folder";
        return false;
    }
    FILE *f = fopen(path.c_str(), "rb");
    if (!f) {
        if (err) *err = strerror(errno);
        return false;
    }
    out->clear();
    unsigned char chunk[65536];
    size_t n;
    while ((n = fread(chunk, 1, sizeof chunk, f)) > 0) out->insert(out->end(), chunk, chunk + n);
    fclose(f);
    // tinygltf refuses the whole file when an image file is empty; one zero byte
    // turns that into a corrupt image (a warning), and a buffer still fails its
    // size check.
    if (out->empty()) out->push_back(0);
    return true;
}

bool fs_write(std::string *err, const std::string &, const std::vector<unsigned char> &, void *)
{
    if (err) *err = "writing is not supported";
    return false;
}

// Keeps the encoded bytes of data-URI images; external files and buffer views
// are decoded later, after their ranges and paths have been checked.
bool keep_image_bytes(tinygltf::Image *image, const int index, std::string *, std::string *, int,
                      int, const unsigned char *bytes, int size, void *user)
{
    Loader *L = (Loader *)user;
    if (image->bufferView == -1 && image->uri.empty() && bytes && size > 0)
        L->data_uri_images[index].assign(bytes, bytes + size);
    return true;
}

// ---------------------------------------------------------------------------
// Parsing

// EXT_meshopt_compression's fallback buffers may have no uri (their bytes are
// never needed when the extension is decoded), which tinygltf refuses in a
// .gltf and reads past the BIN chunk in a .glb. Such buffers get a 4-byte data
// URI instead; *out is the rewritten JSON. False when nothing was rewritten.
// Likewise KHR_draco_mesh_compression primitives' indices accessors have no
// bufferView (the faces are in the Draco data), which tinygltf refuses: their
// "indices" is dropped (the loader takes the faces from Draco).
bool rewrite_fallback_buffers(const unsigned char *json, size_t size, std::string *out)
{
    static const char key[] = "EXT_meshopt_compression", draco[] = "KHR_draco_mesh_compression";
    if (std::search(json, json + size, key, key + sizeof key - 1) == json + size &&
        std::search(json, json + size, draco, draco + sizeof draco - 1) == json + size)
        return false;
    nlohmann::json j;
    try {
        j = nlohmann::json::parse(json, json + size);
    } catch (const std::exception &) {
        return false; // reported by the normal parse
    }
    if (!j.is_object()) return false;
    bool changed = false;
    if (j.contains("meshes") && j["meshes"].is_array())
        for (auto &mesh : j["meshes"]) {
            if (!mesh.is_object() || !mesh.contains("primitives") || !mesh["primitives"].is_array())
                continue;
            for (auto &p : mesh["primitives"]) {
                if (!p.is_object() || !p.contains("extensions") || !p["extensions"].is_object() ||
                    !p["extensions"].contains(draco) || !p.contains("indices"))
                    continue;
                p.erase("indices");
                changed = true;
            }
        }
    if (!j.contains("buffers") || !j["buffers"].is_array()) {
        if (changed) *out = j.dump();
        return changed;
    }
    for (auto &b : j["buffers"]) {
        if (!b.is_object() || b.contains("uri") || !b.contains("extensions")) continue;
        const auto &x = b["extensions"];
        if (!x.is_object() || !x.contains(key) || !x[key].is_object()) continue;
        const auto &fb = x[key];
        if (!fb.contains("fallback") || fb["fallback"] != true) continue;
        b["uri"] = "data:application/octet-stream;base64,AAAAAA==";
        b["byteLength"] = 4;
        changed = true;
    }
    if (changed) *out = j.dump();
    return changed;
}

int Loader::parse(const unsigned char *data, size_t size)
{
    if (size == 0) return bad("empty file (not glTF)");
    tinygltf::TinyGLTF gltf;
    gltf.SetImageLoader(keep_image_bytes, this);
    tinygltf::FsCallbacks fs = {fs_exists, fs_expand, fs_read, fs_write, this};
    gltf.SetFsCallbacks(fs);
    std::string err, warn;
    bool ok;
    const unsigned char *json = data;
    size_t json_size = size;
    if (size >= 4 && !memcmp(data, "glTF", 4)) {
        // The GLB container, checked fully here: tinygltf trusts some lengths.
        uint32_t h[5] = {0, 0, 0, 0, 0};
        if (size < 20) return bad("truncated GLB: %zu bytes, the header needs 20", size);
        memcpy(h, data, 20);
        if (h[1] != 2) return bad("GLB version %u is not supported (only 2)", h[1]);
        if (h[2] > size)
            return bad("truncated GLB: the header says %u bytes, the file has %zu", h[2], size);
        if (h[2] < 20) return bad("GLB length %u is shorter than its header", h[2]);
        uint64_t length = h[2], json_end = 20 + (uint64_t)h[3];
        if (h[4] != 0x4E4F534A) return bad("GLB: the first chunk is not JSON");
        if (h[3] == 0 || json_end > length)
            return bad("GLB: JSON chunk length %u does not fit in the file's %u bytes", h[3], h[2]);
        if (json_end < length) {
            uint32_t c[2];
            if (json_end + 8 > length) return bad("GLB: truncated BIN chunk header");
            memcpy(c, data + json_end, 8);
            if (c[1] != 0x004E4942) return bad("GLB: the second chunk is not BIN");
            if (json_end + 8 + (uint64_t)c[0] > length)
                return bad("GLB: BIN chunk length %u runs past the end of the file", c[0]);
            if (c[0] < 4 || c[0] % 4)
                return bad("GLB: BIN chunk length %u is not a positive multiple of 4", c[0]);
        }
        json = data + 20;
        json_size = h[3];
        std::string fixed;
        if (rewrite_fallback_buffers(json, json_size, &fixed)) {
            // The same container around the rewritten JSON chunk.
            while (fixed.size() % 4) fixed += ' ';
            std::vector<unsigned char> glb(20);
            uint32_t hdr[5] = {h[0], 2, 0, (uint32_t)fixed.size(), 0x4E4F534A};
            glb.insert(glb.end(), fixed.begin(), fixed.end());
            glb.insert(glb.end(), data + 20 + h[3], data + h[2]);
            hdr[2] = (uint32_t)glb.size();
            memcpy(glb.data(), hdr, 20);
            ok = gltf.LoadBinaryFromMemory(&m, &err, &warn, glb.data(), (unsigned)glb.size(), dir,
                                           tinygltf::REQUIRE_VERSION);
        } else {
            ok = gltf.LoadBinaryFromMemory(&m, &err, &warn, data, h[2], dir,
                                           tinygltf::REQUIRE_VERSION);
        }
    } else {
        if (size > UINT_MAX) return bad("a .gltf file of 4 GiB or more is not supported");
        std::string fixed;
        if (rewrite_fallback_buffers(data, size, &fixed))
            ok = gltf.LoadASCIIFromString(&m, &err, &warn, fixed.data(), (unsigned)fixed.size(),
                                          dir, tinygltf::REQUIRE_VERSION);
        else
            ok = gltf.LoadASCIIFromString(&m, &err, &warn, (const char *)data, (unsigned)size,
                                          dir, tinygltf::REQUIRE_VERSION);
    }
    if (!ok) return diagnose_parse_failure(json, json_size, err);
    return 0;
}

// tinygltf's own messages do not always name the object; for the common causes
// (bad JSON, a missing or mis-sized buffer file) say which one it is.
int Loader::diagnose_parse_failure(const unsigned char *json, size_t size, const std::string &err)
{
    nlohmann::json j;
    try {
        j = nlohmann::json::parse(json, json + size);
    } catch (const std::exception &ex) {
        std::string what = ex.what();
        size_t p = what.find("] ");
        if (p != std::string::npos) what = what.substr(p + 2);
        return bad("not valid JSON: %s", first_line(what).c_str());
    }
    if (!j.is_object()) return bad("not a glTF file: the JSON root is not an object");
    if (!j.contains("asset") || !j["asset"].is_object()) return bad("asset: missing");
    if (!j["asset"].contains("version") || !j["asset"]["version"].is_string())
        return bad("asset.version: missing");
    // Top-level arrays whose elements must be objects, and the properties tinygltf
    // requires of them ('n': a number, 's': a string, 'a': an array).
    static const struct {
        const char *array, *props;
    } k_required[] = {
        {"accessors", "componentType:n count:n type:s"}, {"buffers", "byteLength:n"},
        {"bufferViews", "buffer:n byteLength:n"},        {"meshes", "primitives:a"},
        {"cameras", "type:s"},                           {"nodes", ""},
        {"materials", ""},                               {"images", ""},
        {"textures", ""},                                {"samplers", ""},
        {"scenes", ""},                                  {"skins", ""},
        {"animations", ""},
    };
    for (const auto &r : k_required) {
        if (!j.contains(r.array)) continue;
        const auto &arr = j[r.array];
        if (!arr.is_array()) return bad("%s: not a JSON array", r.array);
        for (size_t i = 0; i < arr.size(); i++) {
            if (!arr[i].is_object()) return bad("%s[%zu]: not a JSON object", r.array, i);
            std::string props = r.props;
            size_t p = 0;
            while (p < props.size()) {
                size_t sp = props.find(' ', p), colon = props.find(':', p);
                if (sp == std::string::npos) sp = props.size();
                std::string key = props.substr(p, colon - p);
                char kind = props[colon + 1];
                p = sp + 1;
                const char *what = kind == 'n' ? "a number" : kind == 's' ? "a string" : "an array";
                if (!arr[i].contains(key))
                    return bad("%s[%zu].%s: missing (required)", r.array, i, key.c_str());
                const auto &v = arr[i][key];
                if ((kind == 'n' && !v.is_number()) || (kind == 's' && !v.is_string()) ||
                    (kind == 'a' && !v.is_array()))
                    return bad("%s[%zu].%s: not %s", r.array, i, key.c_str(), what);
            }
        }
    }
    if (j.contains("images") && j["images"].is_array())
        for (size_t i = 0; i < j["images"].size(); i++) {
            const auto &im = j["images"][i];
            if (im.contains("uri") && im.contains("bufferView"))
                return bad("images[%zu]: has both uri and bufferView", i);
            if (!im.contains("uri") && !im.contains("bufferView"))
                return bad("images[%zu]: has neither uri nor bufferView", i);
            if (im.contains("uri") && im["uri"].is_string() &&
                im["uri"].get<std::string>().compare(0, 5, "data:") == 0 &&
                err.find("image[" + std::to_string(i) + "]") != std::string::npos)
                return bad("images[%zu].uri: not a valid base64 data URI", i);
        }
    if (j.contains("buffers") && j["buffers"].is_array()) {
        for (size_t i = 0; i < j["buffers"].size(); i++) {
            const auto &b = j["buffers"][i];
            if (!b.is_object() || !b.contains("uri") || !b["uri"].is_string()) continue;
            std::string uri = b["uri"];
            if (uri.compare(0, 5, "data:") == 0) {
                if (err.find("Failed to decode 'uri' : " + uri) != std::string::npos)
                    return bad("buffers[%zu].uri: not a base64 data URI of byteLength bytes", i);
                continue;
            }
            std::string path = dir + "/" + uri_decode(uri);
            struct stat st;
            if (stat(path.c_str(), &st) != 0)
                return bad("buffers[%zu]: file '%s' not found", i, uri.c_str());
            if (!inside_folder(path, nullptr))
                return bad("buffers[%zu]: uri '%s' points outside the scene folder (not read)", i,
                           uri.c_str());
            if (b.contains("byteLength") && b["byteLength"].is_number_unsigned() &&
                (uint64_t)st.st_size != b["byteLength"].get<uint64_t>())
                return bad("buffers[%zu]: file '%s' has %lld bytes, byteLength says %llu", i,
                           uri.c_str(), (long long)st.st_size,
                           (unsigned long long)b["byteLength"].get<uint64_t>());
        }
    }
    return bad("%s", first_line(err).c_str());
}

int Loader::check_version_and_extensions()
{
    const std::string &v = m.asset.version;
    if (v.size() < 3 || v[0] != '2' || v[1] != '.')
        return bad("asset.version: '%s' is not supported (glTF 2.x only)", v.c_str());
    const std::string &mv = m.asset.minVersion;
    if (!mv.empty() && mv != "2.0")
        return bad("asset.minVersion: '%s' is newer than the supported 2.0", mv.c_str());
    std::vector<std::string> missing, unknown;
    auto supported = [](const std::string &name) {
        for (const char *s : k_supported_ext)
            if (name == s) return true;
        return false;
    };
    for (const auto &x : m.extensionsRequired)
        if (!supported(x)) missing.push_back(x);
    if (!missing.empty())
        return bad("extensionsRequired: not supported: %s", join_names(missing).c_str());
    auto ignored = [](const std::string &name) {
        for (const char *s : k_ignored_material_ext)
            if (name == s) return true;
        return false;
    };
    for (const auto &x : m.extensionsUsed) {
        if (!supported(x) && !ignored(x)) unknown.push_back(x);
        if (x == "KHR_mesh_quantization") quantization = true;
    }
    if (!unknown.empty())
        spt_warn("%s: extensionsUsed: %zu extension(s) not supported, ignored: %s", file,
                 unknown.size(), join_names(unknown).c_str());
    return 0;
}

int Loader::check_buffer_views()
{
    for (size_t i = 0; i < m.bufferViews.size(); i++) {
        const auto &bv = m.bufferViews[i];
        if (bv.buffer < 0 || (size_t)bv.buffer >= m.buffers.size())
            return bad("bufferViews[%zu]: buffers[%d] does not exist", i, bv.buffer);
        size_t blen = m.buffers[bv.buffer].data.size();
        if (bv.byteLength == 0) return bad("bufferViews[%zu]: byteLength is 0", i);
        if (bv.byteOffset > blen || bv.byteLength > blen - bv.byteOffset)
            return bad("bufferViews[%zu]: bytes %zu..%zu run past the end of buffers[%d] "
                       "(%zu bytes)",
                       i, bv.byteOffset, bv.byteOffset + bv.byteLength, bv.buffer, blen);
        if (bv.byteStride != 0 && (bv.byteStride < 4 || bv.byteStride > 252 || bv.byteStride % 4))
            return bad("bufferViews[%zu]: byteStride %zu is not a multiple of 4 in 4..252", i,
                       bv.byteStride);
    }
    return 0;
}

// Checks accessors[index] for use as obj: existence, type, component type, count,
// and that every element lies inside its buffer view. *zeros: no bufferView (all
// elements are zero, glTF 2.0 3.6.2.3). normalized_ok: 0 integers must not be
// normalized, 1 they must be, 2 either (KHR_mesh_quantization).
int Loader::check_accessor(int index, const std::string &obj, int want_components,
                           const std::vector<int> &types, int normalized_ok, bool *zeros)
{
    const char *o = obj.c_str();
    if (index < 0 || (size_t)index >= m.accessors.size())
        return bad("%s: accessors[%d] does not exist", o, index);
    const auto &a = m.accessors[index];
    if (a.sparse.isSparse)
        return bad("%s (accessors[%d]): sparse accessors are not supported", o, index);
    if (a.count == 0) return bad("%s (accessors[%d]): count is 0", o, index);
    int ncomp = type_components(a.type);
    if (ncomp != want_components)
        return bad("%s (accessors[%d]): type must be %s", o, index, type_name(want_components));
    bool type_ok = false;
    for (int t : types) type_ok |= a.componentType == t;
    if (!type_ok)
        return bad("%s (accessors[%d]): component type %s is not allowed here%s", o, index,
                   component_name(a.componentType),
                   !quantization && obj.find(".attributes.") != std::string::npos &&
                           a.componentType != TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT
                       ? " (integer attributes need KHR_mesh_quantization in extensionsUsed)"
                       : "");
    if (a.normalized && !normalized_ok)
        return bad("%s (accessors[%d]): normalized integers are not allowed here", o, index);
    if (!a.normalized && normalized_ok == 1 && a.componentType != TINYGLTF_COMPONENT_TYPE_FLOAT)
        return bad("%s (accessors[%d]): integer components must be normalized here", o, index);
    *zeros = a.bufferView < 0;
    if (*zeros) return 0;
    if ((size_t)a.bufferView >= m.bufferViews.size())
        return bad("%s (accessors[%d]): bufferViews[%d] does not exist", o, index, a.bufferView);
    const auto &bv = m.bufferViews[a.bufferView];
    uint64_t elem = (uint64_t)ncomp * (uint64_t)component_size(a.componentType);
    uint64_t stride = bv.byteStride ? bv.byteStride : elem;
    if (stride < elem)
        return bad("%s (accessors[%d]): byteStride %llu is smaller than an element (%llu bytes)",
                   o, index, (unsigned long long)stride, (unsigned long long)elem);
    uint64_t span, end;
    if (__builtin_mul_overflow((uint64_t)(a.count - 1), stride, &span) ||
        __builtin_add_overflow(span, elem, &end) ||
        __builtin_add_overflow(end, (uint64_t)a.byteOffset, &end) || end > bv.byteLength)
        return bad("%s (accessors[%d]): byteOffset %zu + %zu elements of stride %llu run past the "
                   "end of bufferViews[%d] (%zu bytes)",
                   o, index, a.byteOffset, a.count, (unsigned long long)stride, a.bufferView,
                   bv.byteLength);
    return 0;
}

// Reads a checked accessor as floats: float components as they are, normalised
// integers mapped to [0,1] or [-1,1] (glTF 2.0 3.11, max(c / 127, -1) for
// signed ones), plain integers (KHR_mesh_quantization) as their values.
int Loader::read_floats(int index, int ncomp, std::vector<float> &out)
{
    const auto &a = m.accessors[index];
    out.assign(a.count * (size_t)ncomp, 0.0f);
    if (a.bufferView < 0) return 0;
    const auto &bv = m.bufferViews[a.bufferView];
    const unsigned char *base = m.buffers[bv.buffer].data.data() + bv.byteOffset + a.byteOffset;
    size_t cs = (size_t)component_size(a.componentType);
    size_t stride = bv.byteStride ? bv.byteStride : cs * (size_t)ncomp;
    for (size_t i = 0; i < a.count; i++)
        for (int c = 0; c < ncomp; c++) {
            const unsigned char *p = base + i * stride + (size_t)c * cs;
            float v;
            switch (a.componentType) {
            case TINYGLTF_COMPONENT_TYPE_FLOAT: memcpy(&v, p, 4); break;
            case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE:
                v = a.normalized ? (float)p[0] / 255.0f : (float)p[0];
                break;
            case TINYGLTF_COMPONENT_TYPE_BYTE: {
                int8_t b;
                memcpy(&b, p, 1);
                v = a.normalized ? fmaxf((float)b / 127.0f, -1.0f) : (float)b;
                break;
            }
            case TINYGLTF_COMPONENT_TYPE_SHORT: {
                int16_t h;
                memcpy(&h, p, 2);
                v = a.normalized ? fmaxf((float)h / 32767.0f, -1.0f) : (float)h;
                break;
            }
            case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
                uint16_t u;
                memcpy(&u, p, 2);
                v = a.normalized ? (float)u / 65535.0f : (float)u;
                break;
            }
            default: { // UNSIGNED_INT (not allowed for attributes, kept total)
                uint32_t u;
                memcpy(&u, p, 4);
                v = (float)u;
            }
            }
            out[i * (size_t)ncomp + (size_t)c] = v;
        }
    return 0;
}

int Loader::read_indices(int index, std::vector<uint32_t> &out)
{
    const auto &a = m.accessors[index];
    out.assign(a.count, 0);
    if (a.bufferView < 0) return 0;
    const auto &bv = m.bufferViews[a.bufferView];
    const unsigned char *base = m.buffers[bv.buffer].data.data() + bv.byteOffset + a.byteOffset;
    size_t cs = (size_t)component_size(a.componentType);
    size_t stride = bv.byteStride ? bv.byteStride : cs;
    for (size_t i = 0; i < a.count; i++) {
        const unsigned char *p = base + i * stride;
        if (cs == 1) {
            out[i] = p[0];
        } else if (cs == 2) {
            uint16_t u;
            memcpy(&u, p, 2);
            out[i] = u;
        } else {
            memcpy(&out[i], p, 4);
        }
    }
    return 0;
}

// ---------------------------------------------------------------------------
// Nodes

int Loader::node_local(int n, Mat4 *out)
{
    const auto &node = m.nodes[n];
    if (!node.matrix.empty()) {
        if (node.matrix.size() != 16)
            return bad("nodes[%d].matrix: %zu numbers, expected 16", n, node.matrix.size());
        for (int i = 0; i < 16; i++) out->m[i] = node.matrix[i];
        return 0;
    }
    if (!node.translation.empty() && node.translation.size() != 3)
        return bad("nodes[%d].translation: %zu numbers, expected 3", n, node.translation.size());
    if (!node.rotation.empty() && node.rotation.size() != 4)
        return bad("nodes[%d].rotation: %zu numbers, expected 4", n, node.rotation.size());
    if (!node.scale.empty() && node.scale.size() != 3)
        return bad("nodes[%d].scale: %zu numbers, expected 3", n, node.scale.size());
    double t[3] = {0, 0, 0}, q[4] = {0, 0, 0, 1}, s[3] = {1, 1, 1};
    for (size_t i = 0; i < node.translation.size(); i++) t[i] = node.translation[i];
    for (size_t i = 0; i < node.rotation.size(); i++) q[i] = node.rotation[i];
    for (size_t i = 0; i < node.scale.size(); i++) s[i] = node.scale[i];
    double ql = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    if (!(ql > 0) || !std::isfinite(ql))
        return bad("nodes[%d].rotation: not a unit quaternion", n);
    for (double &c : q) c /= ql;
    double x = q[0], y = q[1], z = q[2], w = q[3];
    // Rotation matrix of the unit quaternion (row r, column c), then M = T R S.
    double R[3][3] = {{1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)},
                      {2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)},
                      {2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)}};
    *out = mat_identity();
    for (int c = 0; c < 3; c++)
        for (int r = 0; r < 3; r++) out->m[c * 4 + r] = R[r][c] * s[c];
    for (int r = 0; r < 3; r++) out->m[12 + r] = t[r];
    return 0;
}

int Loader::traverse()
{
    size_t nn = m.nodes.size();
    std::vector<int> parent(nn, -1);
    for (size_t i = 0; i < nn; i++) {
        const auto &node = m.nodes[i];
        for (size_t k = 0; k < node.children.size(); k++) {
            int c = node.children[k];
            if (c < 0 || (size_t)c >= nn)
                return bad("nodes[%zu].children[%zu]: nodes[%d] does not exist", i, k, c);
            if ((size_t)c == i) return bad("nodes[%zu]: the node is its own child", i);
            if (parent[c] >= 0)
                return bad("nodes[%d]: has two parents (nodes[%d] and nodes[%zu])", c, parent[c],
                           i);
            parent[c] = (int)i;
        }
        if (node.mesh >= 0 && (size_t)node.mesh >= m.meshes.size())
            return bad("nodes[%zu].mesh: meshes[%d] does not exist", i, node.mesh);
        if (node.mesh < -1) return bad("nodes[%zu].mesh: meshes[%d] does not exist", i, node.mesh);
        if (node.camera < -1 || (node.camera >= 0 && (size_t)node.camera >= m.cameras.size()))
            return bad("nodes[%zu].camera: cameras[%d] does not exist", i, node.camera);
        auto lit = node.extensions.find("KHR_lights_punctual");
        if (lit != node.extensions.end()) {
            const Value &l = lit->second.IsObject() ? lit->second.Get("light") : Value();
            if (!l.IsNumber() || l.GetNumberAsInt() < 0 ||
                (size_t)l.GetNumberAsInt() >= m.lights.size())
                return bad("nodes[%zu].extensions.KHR_lights_punctual.light: not an index into "
                           "the file's %zu lights",
                           i, m.lights.size());
        }
    }
    // With at most one parent each, a loop is a parent chain that returns to a
    // node on the current walk; each node is walked once (O(nodes)).
    std::vector<char> state(nn, 0); // 0 unseen, 1 on the current walk, 2 done
    std::vector<int> walk;
    for (size_t i = 0; i < nn; i++) {
        walk.clear();
        int n = (int)i;
        while (n >= 0 && state[n] == 0) {
            state[n] = 1;
            walk.push_back(n);
            n = parent[n];
        }
        if (n >= 0 && state[n] == 1) return bad("nodes[%d]: the node hierarchy has a loop", n);
        for (int w : walk) state[w] = 2;
    }

    std::vector<int> roots;
    if (m.defaultScene >= 0 || !m.scenes.empty()) {
        int sc = m.defaultScene >= 0 ? m.defaultScene : 0;
        if ((size_t)sc >= m.scenes.size()) return bad("scene: scenes[%d] does not exist", sc);
        roots = m.scenes[sc].nodes;
        std::vector<char> listed(nn, 0);
        for (size_t k = 0; k < roots.size(); k++) {
            int r = roots[k];
            if (r < 0 || (size_t)r >= nn)
                return bad("scenes[%d].nodes[%zu]: nodes[%d] does not exist", sc, k, r);
            if (parent[r] >= 0)
                return bad("scenes[%d].nodes[%zu]: nodes[%d] is a child of nodes[%d], not a root",
                           sc, k, r, parent[r]);
            if (listed[r]) return bad("scenes[%d].nodes[%zu]: nodes[%d] is listed twice", sc, k, r);
            listed[r] = 1;
        }
    } else if (nn) {
        for (size_t i = 0; i < nn; i++)
            if (parent[i] < 0) roots.push_back((int)i);
        spt_warn("%s: scenes: the file has no scene; using its %zu root node(s)", file,
                 roots.size());
    }

    // Depth-first, pre-order, children in file order, with an explicit stack (no
    // recursion, so any depth works).
    std::vector<std::pair<int, Mat4>> stack;
    for (size_t k = roots.size(); k-- > 0;) stack.push_back({roots[k], mat_identity()});
    while (!stack.empty()) {
        int n = stack.back().first;
        Mat4 parent_world = stack.back().second;
        stack.pop_back();
        Mat4 local;
        int rc = node_local(n, &local);
        if (rc) return rc;
        Mat4 world = mat_mul(parent_world, local);
        const auto &node = m.nodes[n];
        if (node.mesh >= 0 && (rc = emit_instance(node.mesh, world))) return rc;
        if (node.camera >= 0 && !have_camera && (rc = camera_from(node.camera, world, n)))
            return rc;
        auto lit = node.extensions.find("KHR_lights_punctual");
        if (lit != node.extensions.end() &&
            (rc = light_from(lit->second.Get("light").GetNumberAsInt(), world, n)))
            return rc;
        for (size_t k = node.children.size(); k-- > 0;) stack.push_back({node.children[k], world});
    }
    return 0;
}

int Loader::camera_from(int cam, const Mat4 &world, int node)
{
    const auto &c = m.cameras[cam];
    SceneCamera sc = {};
    if (c.type == "perspective") {
        const auto &p = c.perspective;
        if (!(p.yfov > 0 && p.yfov < M_PI))
            return bad("cameras[%d].perspective.yfov: %g is not in (0, pi)", cam, p.yfov);
        if (!(p.znear > 0)) return bad("cameras[%d].perspective.znear: %g is not > 0", cam, p.znear);
        if (p.zfar != 0 && !(p.zfar > p.znear))
            return bad("cameras[%d].perspective.zfar: %g is not greater than znear %g", cam,
                       p.zfar, p.znear);
        if (p.aspectRatio < 0 || !std::isfinite(p.aspectRatio))
            return bad("cameras[%d].perspective.aspectRatio: %g is not > 0", cam, p.aspectRatio);
        sc.yfov = (float)p.yfov;
        sc.aspect = (float)p.aspectRatio;
        sc.znear = (float)p.znear;
        sc.zfar = (float)p.zfar;
    } else if (c.type == "orthographic") {
        const auto &o = c.orthographic;
        if (o.xmag == 0 || o.ymag == 0 || !std::isfinite(o.xmag) || !std::isfinite(o.ymag))
            return bad("cameras[%d].orthographic: xmag and ymag must be non-zero", cam);
        if (!(o.znear >= 0) || !(o.zfar > o.znear))
            return bad("cameras[%d].orthographic: needs 0 <= znear < zfar (got %g, %g)", cam,
                       o.znear, o.zfar);
        sc.orthographic = 1;
        sc.xmag = (float)fabs(o.xmag);
        sc.ymag = (float)fabs(o.ymag);
        sc.znear = (float)o.znear;
        sc.zfar = (float)o.zfar;
        sc.aspect = (float)(fabs(o.xmag) / fabs(o.ymag));
    } else {
        return bad("cameras[%d].type: '%s' is neither perspective nor orthographic", cam,
                   c.type.c_str());
    }
    double origin[3] = {0, 0, 0}, pos[3], fwd[3], up[3], right[3];
    double zf[3] = {0, 0, -1}, yu[3] = {0, 1, 0};
    mat_point(world, origin, pos);
    mat_dir(world, zf, fwd);
    mat_dir(world, yu, up);
    if (!normalize3(fwd)) return bad("nodes[%d]: the camera's transform is singular", node);
    cross3(fwd, up, right);
    if (!normalize3(right)) return bad("nodes[%d]: the camera's transform is singular", node);
    cross3(right, fwd, up);
    for (int k = 0; k < 3; k++) {
        if (!std::isfinite(pos[k])) return bad("nodes[%d]: the camera's position is not finite", node);
        sc.position[k] = (float)pos[k];
        sc.forward[k] = (float)fwd[k];
        sc.up[k] = (float)up[k];
        sc.right[k] = (float)right[k];
    }
    camera = sc;
    have_camera = true;
    return 0;
}

int Loader::light_from(int li, const Mat4 &world, int node)
{
    const auto &l = m.lights[li];
    SceneLight sl = {};
    snprintf(sl.name, sizeof sl.name, "%s", l.name.empty() ? "light" : l.name.c_str());
    std::string obj = "extensions.KHR_lights_punctual.lights[" + std::to_string(li) + "]";
    if (l.type == "point")
        sl.type = SPT_LIGHT_POINT;
    else if (l.type == "spot")
        sl.type = SPT_LIGHT_SPOT;
    else if (l.type == "directional")
        sl.type = SPT_LIGHT_DIRECTIONAL;
    else
        return bad("%s.type: '%s' is not point, spot or directional", obj.c_str(), l.type.c_str());
    sl.color[0] = sl.color[1] = sl.color[2] = 1.0f;
    if (!l.color.empty()) {
        if (l.color.size() != 3) return bad("%s.color: expected 3 numbers", obj.c_str());
        for (int k = 0; k < 3; k++) {
            if (!(l.color[k] >= 0) || !std::isfinite(l.color[k]))
                return bad("%s.color: components must be finite and >= 0", obj.c_str());
            sl.color[k] = (float)l.color[k];
        }
    }
    if (!(l.intensity >= 0) || !std::isfinite(l.intensity))
        return bad("%s.intensity: %g is not a finite value >= 0", obj.c_str(), l.intensity);
    if (!(l.range >= 0) || !std::isfinite(l.range))
        return bad("%s.range: %g is not > 0", obj.c_str(), l.range);
    sl.intensity = (float)l.intensity;
    sl.range = (float)l.range;
    if (sl.type == SPT_LIGHT_SPOT) {
        double in = l.spot.innerConeAngle, out = l.spot.outerConeAngle;
        if (!(in >= 0 && in < out && out <= M_PI / 2 + 1e-9))
            return bad("%s.spot: needs 0 <= innerConeAngle < outerConeAngle <= pi/2 (got %g, %g)",
                       obj.c_str(), in, out);
        sl.inner_cone = (float)in;
        sl.outer_cone = (float)out;
    }
    double origin[3] = {0, 0, 0}, zf[3] = {0, 0, -1}, pos[3], dir[3];
    mat_point(world, origin, pos);
    mat_dir(world, zf, dir);
    if (sl.type != SPT_LIGHT_POINT && !normalize3(dir))
        return bad("nodes[%d]: the light's transform is singular", node);
    for (int k = 0; k < 3; k++) {
        if (!std::isfinite(pos[k])) return bad("nodes[%d]: the light's position is not finite", node);
        sl.position[k] = (float)pos[k];
        sl.direction[k] = (float)dir[k];
    }
    if (sl.type == SPT_LIGHT_POINT && !normalize3(dir)) sl.direction[2] = -1.0f;
    lights.push_back(sl);
    return 0;
}

// ---------------------------------------------------------------------------
// Materials and textures

// A number property of an extension object: absent leaves *out unchanged.
int ext_number(Loader *L, const Value &o, const char *key, double *out, const std::string &obj)
{
    if (!o.IsObject() || !o.Has(key)) return 0;
    const Value &v = o.Get(key);
    if (!v.IsNumber() || !std::isfinite(v.GetNumberAsDouble()))
        return L->bad("%s.%s: not a number", obj.c_str(), key);
    *out = v.GetNumberAsDouble();
    return 0;
}

int Loader::decode_image(int image)
{
    if (decoded_state[image]) return decoded_state[image] > 0;
    decoded_state[image] = -1;
    const auto &im = m.images[image];
    TextureImage ti = {};
    char why[256] = "";
    std::string what;
    int rc = -1;
    if (im.bufferView >= 0) {
        if ((size_t)im.bufferView >= m.bufferViews.size()) {
            snprintf(why, sizeof why, "bufferViews[%d] does not exist", im.bufferView);
        } else {
            const auto &bv = m.bufferViews[im.bufferView];
            rc = texture_io_load_memory(m.buffers[bv.buffer].data.data() + bv.byteOffset,
                                        bv.byteLength, im.mimeType.c_str(), &ti, why, sizeof why);
        }
    } else if (data_uri_images.count(image)) {
        const auto &bytes = data_uri_images[image];
        rc = texture_io_load_memory(bytes.data(), bytes.size(), im.mimeType.c_str(), &ti, why,
                                    sizeof why);
    } else if (!im.uri.empty()) {
        std::string path = dir + "/" + uri_decode(im.uri), real;
        struct stat st;
        if (stat(path.c_str(), &st) != 0)
            snprintf(why, sizeof why, "file '%s' not found", im.uri.c_str());
        else if (!inside_folder(path, &real))
            snprintf(why, sizeof why, "uri '%s' points outside the scene folder (not read)",
                     im.uri.c_str());
        else
            rc = texture_io_load_file(real.c_str(), &ti, why, sizeof why);
    } else {
        snprintf(why, sizeof why, "no image data");
    }
    if (rc) {
        spt_warn("%s: images[%d]: %s; using the material's factors instead", file, image, why);
        stats.unusable_images++;
        return 0;
    }
    decoded[image] = ti;
    decoded_state[image] = 1;
    return 1;
}

// KHR_texture_transform of a texture reference (ext: its extensions), as the
// extension defines it: uv' = T * R * S * (u, v, 1) with T the offset, R the
// rotation by `rotation` radians counter-clockwise in UV space (matrix rows
// (cos, sin), (-sin, cos), since v points down the image) and S the scale, into
// uv_transform (2x3 row-major; left as it is without the extension). Its
// texCoord overrides *texcoord.
int Loader::texture_transform(const tinygltf::ExtensionMap *ext, int *texcoord,
                              const std::string &obj, float *uv_transform)
{
    if (!ext) return 0;
    auto it = ext->find("KHR_texture_transform");
    if (it == ext->end()) return 0;
    const Value &x = it->second;
    std::string o = obj + ".extensions.KHR_texture_transform";
    if (!x.IsObject()) return bad("%s: not a JSON object", o.c_str());
    double off[2] = {0, 0}, scale[2] = {1, 1}, rot = 0;
    const char *pair_keys[2] = {"offset", "scale"};
    double *pairs[2] = {off, scale};
    for (int k = 0; k < 2; k++) {
        if (!x.Has(pair_keys[k])) continue;
        const Value &a = x.Get(pair_keys[k]);
        if (!a.IsArray() || a.ArrayLen() != 2 || !a.Get(0).IsNumber() || !a.Get(1).IsNumber() ||
            !std::isfinite(a.Get(0).GetNumberAsDouble()) ||
            !std::isfinite(a.Get(1).GetNumberAsDouble()))
            return bad("%s.%s: expected 2 finite numbers", o.c_str(), pair_keys[k]);
        pairs[k][0] = a.Get(0).GetNumberAsDouble();
        pairs[k][1] = a.Get(1).GetNumberAsDouble();
    }
    int rc;
    if ((rc = ext_number(this, x, "rotation", &rot, o))) return rc;
    if (x.Has("texCoord")) {
        const Value &t = x.Get("texCoord");
        if (!t.IsInt() || t.GetNumberAsInt() < 0)
            return bad("%s.texCoord: not an index >= 0", o.c_str());
        *texcoord = t.GetNumberAsInt();
    }
    double c = cos(rot), sn = sin(rot);
    float M[6] = {(float)(c * scale[0]), (float)(sn * scale[1]), (float)off[0],
                  (float)(-sn * scale[0]), (float)(c * scale[1]), (float)off[1]};
    memcpy(uv_transform, M, sizeof M);
    return 0;
}

// Resolves a material's reference to textures[tex] (texCoord texcoord, ext: the
// textureInfo's extensions) into *out: the file's index, the texture coordinate set
// (0 or 1; a higher one is counted in a warning and read as 0), the transform, and
// the SceneTexture (-1 when the image is unusable, with a warning), decoded for
// colour (srgb) or as data. With load false only the reference is recorded (a slot
// the renderer reports but does not read). Dangling references are errors.
int Loader::texture_ref(int tex, int texcoord, bool srgb, const std::string &obj, SceneTexRef *out,
                        const tinygltf::ExtensionMap *ext, bool load)
{
    out->tex = -1;
    if (tex < 0) return 0;
    int rc;
    if ((rc = texture_transform(ext, &texcoord, obj, out->transform))) return rc;
    if ((size_t)tex >= m.textures.size())
        return bad("%s.index: textures[%d] does not exist", obj.c_str(), tex);
    if (texcoord < 0) return bad("%s.texCoord: %d is negative", obj.c_str(), texcoord);
    if (texcoord > 1) {
        texcoord_warned++;
        texcoord = 0;
    }
    out->gltf_index = tex;
    out->texcoord = texcoord;
    const auto &t = m.textures[tex];
    int source = t.source;
    // EXT_texture_webp: its source (decoded by OpenImageIO) wins over the fallback.
    auto wit = t.extensions.find("EXT_texture_webp");
    if (wit != t.extensions.end()) {
        const Value &src = wit->second.IsObject() ? wit->second.Get("source") : Value();
        if (!src.IsInt() || src.GetNumberAsInt() < 0 ||
            (size_t)src.GetNumberAsInt() >= m.images.size())
            return bad("textures[%d].extensions.EXT_texture_webp.source: not an index into the "
                       "file's %zu images",
                       tex, m.images.size());
        source = src.GetNumberAsInt();
    }
    if (source < 0) {
        spt_warn("%s: textures[%d]: has no source image; using the factor", file, tex);
        return 0;
    }
    if ((size_t)source >= m.images.size())
        return bad("textures[%d].source: images[%d] does not exist", tex, source);
    // Sampler: wrap modes, and whether magnification keeps texels square
    // (magFilter NEAREST); no sampler or an empty one: repeat, linear.
    int ws = SPT_WRAP_REPEAT, wt = SPT_WRAP_REPEAT, nearest = 0;
    if (t.sampler >= 0) {
        if ((size_t)t.sampler >= m.samplers.size())
            return bad("textures[%d].sampler: samplers[%d] does not exist", tex, t.sampler);
        const auto &sp = m.samplers[t.sampler];
        ws = sp.wrapS;
        wt = sp.wrapT;
        for (int w : {ws, wt})
            if (w != SPT_WRAP_REPEAT && w != SPT_WRAP_CLAMP && w != SPT_WRAP_MIRROR)
                return bad("samplers[%d]: wrap mode %d is not a glTF wrap mode", t.sampler, w);
        if (sp.magFilter != -1 && sp.magFilter != TINYGLTF_TEXTURE_FILTER_NEAREST &&
            sp.magFilter != TINYGLTF_TEXTURE_FILTER_LINEAR)
            return bad("samplers[%d].magFilter: %d is not NEAREST (9728) or LINEAR (9729)", t.sampler,
                       sp.magFilter);
        nearest = sp.magFilter == TINYGLTF_TEXTURE_FILTER_NEAREST;
    } else if (t.sampler < -1) {
        return bad("textures[%d].sampler: samplers[%d] does not exist", tex, t.sampler);
    }
    if (!load) return 0;
    auto key = std::make_tuple(source, srgb ? 1 : 0, ws, wt, nearest);
    auto it = texture_of.find(key);
    if (it != texture_of.end()) {
        out->tex = it->second;
        return 0;
    }
    if (!decode_image(source)) return 0;
    const TextureImage &ti = decoded[source];
    SceneTexture st = {};
    const auto &im = m.images[source];
    std::string name = !im.name.empty() ? im.name
                       : (!im.uri.empty() && im.uri.compare(0, 5, "data:") != 0)
                           ? im.uri
                           : "images[" + std::to_string(source) + "]";
    snprintf(st.name, sizeof st.name, "%s", name.c_str());
    st.width = ti.width;
    st.height = ti.height;
    st.channels = ti.channels;
    st.srgb_decoded = srgb ? 1 : 0;
    st.wrap_s = ws;
    st.wrap_t = wt;
    st.nearest = nearest;
    size_t n = (size_t)ti.width * ti.height * ti.channels;
    st.texels = (float *)spt_malloc(n * sizeof(float));
    memcpy(st.texels, ti.texels, n * sizeof(float));
    if (srgb) texture_io_srgb_to_linear(st.texels, (size_t)ti.width * ti.height, ti.channels);
    texs.push_back(st);
    out->tex = (int)texs.size() - 1;
    texture_of[key] = out->tex;
    return 0;
}

// The textureInfo x[key] of a material extension (absent: nothing), resolved by
// texture_ref; scale: where a normalTextureInfo's scale goes (default 1).
int Loader::ext_texture(const Value &x, const char *key, bool srgb, const std::string &obj,
                        SceneTexRef *out, float *scale)
{
    if (!x.IsObject() || !x.Has(key)) return 0;
    const Value &ti = x.Get(key);
    std::string o = obj + "." + key;
    const Value &ix = ti.IsObject() ? ti.Get("index") : Value();
    if (!ix.IsInt()) return bad("%s.index: missing or not an integer", o.c_str());
    int tc = 0;
    if (ti.Has("texCoord")) {
        if (!ti.Get("texCoord").IsInt()) return bad("%s.texCoord: not an integer", o.c_str());
        tc = ti.Get("texCoord").GetNumberAsInt();
    }
    if (scale) {
        double sc = 1;
        int rc;
        if ((rc = ext_number(this, ti, "scale", &sc, o))) return rc;
        *scale = (float)sc;
    }
    tinygltf::ExtensionMap em;
    const Value &ev = ti.Get("extensions");
    if (ev.IsObject())
        for (const auto &k : ev.Keys()) em[k] = ev.Get(k);
    return texture_ref(ix.GetNumberAsInt(), tc, srgb, o, out, &em);
}

int Loader::parse_spd(const Value &v, Spd *out, const std::string &obj)
{
    SptError e2 = {};
    if (v.IsString()) {
        if (spd_named(out, v.Get<std::string>().c_str(), &e2))
            return bad("%s: %s", obj.c_str(), e2.msg);
        return 0;
    }
    if (!v.IsArray() || v.ArrayLen() < 2)
        return bad("%s: expected an SPD name or a table [[nm, value], ...] of 2 or more rows",
                   obj.c_str());
    size_t n = v.ArrayLen();
    std::vector<double> nm(n), val(n);
    for (size_t i = 0; i < n; i++) {
        const Value &row = v.Get((int)i);
        if (!row.IsArray() || row.ArrayLen() != 2 || !row.Get(0).IsNumber() ||
            !row.Get(1).IsNumber())
            return bad("%s[%zu]: expected [nm, value]", obj.c_str(), i);
        nm[i] = row.Get(0).GetNumberAsDouble();
        val[i] = row.Get(1).GetNumberAsDouble();
        if (!(nm[i] > 0) || !std::isfinite(nm[i]) || !std::isfinite(val[i]) || val[i] < 0)
            return bad("%s[%zu]: wavelength must be > 0 nm and value finite and >= 0",
                       obj.c_str(), i);
    }
    if (spd_from_samples(out, nm.data(), val.data(), (int)n, &e2))
        return bad("%s: %s", obj.c_str(), e2.msg);
    return 0;
}

int Loader::spectral_extras(const Value &extras, SceneMaterial *sm, const std::string &obj)
{
    if (!extras.IsObject() || !extras.Has("spectrace")) return 0;
    const Value &sp = extras.Get("spectrace");
    std::string o = obj + ".extras.spectrace";
    if (!sp.IsObject()) return bad("%s: expected an object", o.c_str());
    for (const auto &k : sp.Keys())
        if (k != "emission" && k != "reflectance" && k != "conductor")
            return bad("%s: unknown key '%s' (expected emission, reflectance, conductor)",
                       o.c_str(), k.c_str());
    int rc;
    if (sp.Has("emission") && (rc = parse_spd(sp.Get("emission"), &sm->emission_spd, o + ".emission")))
        return rc;
    if (sp.Has("emission") && sp.Get("emission").IsString()) {
        /* A named emission SPD is a shape, not a level: scale it to the luminance
         * of emissive (1, 1, 1), Y = 1 in the film's units (sum cmf P / sum ybar),
         * times KHR_materials_emissive_strength. Inline tables are absolute. */
        double xyz[3];
        spd_to_xyz(&sm->emission_spd, xyz);
        if (!(xyz[1] > 0))
            return bad("%s.emission: the SPD has no luminance (nothing visible in 360-830 nm)", o.c_str());
        double scale = sm->emissive_strength * (double)SPT_CIE_Y_INTEGRAL / xyz[1];
        for (int i = 0; i < sm->emission_spd.count; i++)
            sm->emission_spd.value[i] *= scale;
        for (int i = 0; i < sm->emission_spd.line_count; i++)
            sm->emission_spd.line_power[i] *= scale;
    }
    if (sp.Has("reflectance") &&
        (rc = parse_spd(sp.Get("reflectance"), &sm->reflectance_spd, o + ".reflectance")))
        return rc;
    if (sp.Has("conductor")) {
        const Value &c = sp.Get("conductor");
        std::vector<std::string> names(std::begin(k_conductors), std::end(k_conductors));
        bool known = false;
        if (c.IsString())
            for (const auto &n : names) known |= c.Get<std::string>() == n;
        if (!known)
            return bad("%s.conductor: expected one of %s", o.c_str(), join_names(names).c_str());
        snprintf(sm->conductor, sizeof sm->conductor, "%s", c.Get<std::string>().c_str());
    }
    return 0;
}

// Perceived brightness of a linear RGB colour, as in the conversion below.
double perceived_brightness(const double c[3])
{
    return sqrt(0.299 * c[0] * c[0] + 0.587 * c[1] * c[1] + 0.114 * c[2] * c[2]);
}

// KHR_materials_pbrSpecularGlossiness (legacy) to metallic-roughness, by the
// method of the extension's own example converter (KhronosGroup/glTF,
// extensions/2.0/Archived/KHR_materials_pbrSpecularGlossiness/examples/
// convert-between-workflows, js/three.pbrUtilities.js, by Babylon.js authors):
// metallic solves a quadratic in the perceived brightness of diffuse and
// specular with a dielectric F0 of 0.04; the base colour blends the colour
// implied by the diffuse and by the specular with metallic^2; roughness is
// 1 - glossiness; alpha is the diffuse alpha. The diffuse texture becomes the
// base colour texture (times the converted factor); the specularGlossiness
// texture cannot be converted per texel and is ignored (counted in a warning).
int Loader::spec_gloss(const Value &x, SceneMaterial *sm, const std::string &obj)
{
    if (!x.IsObject()) return bad("%s: not a JSON object", obj.c_str());
    double diffuse[4] = {1, 1, 1, 1}, specular[3] = {1, 1, 1}, gloss = 1;
    const struct {
        const char *key;
        double *v;
        int n;
    } arrays[2] = {{"diffuseFactor", diffuse, 4}, {"specularFactor", specular, 3}};
    for (const auto &a : arrays) {
        if (!x.Has(a.key)) continue;
        const Value &v = x.Get(a.key);
        if (!v.IsArray() || (int)v.ArrayLen() != a.n)
            return bad("%s.%s: expected %d numbers", obj.c_str(), a.key, a.n);
        for (int k = 0; k < a.n; k++) {
            if (!v.Get(k).IsNumber() || !std::isfinite(v.Get(k).GetNumberAsDouble()))
                return bad("%s.%s: not a number", obj.c_str(), a.key);
            a.v[k] = fmin(fmax(v.Get(k).GetNumberAsDouble(), 0), 1);
        }
    }
    int rc;
    if ((rc = ext_number(this, x, "glossinessFactor", &gloss, obj))) return rc;
    gloss = fmin(fmax(gloss, 0), 1);
    const double f0 = 0.04, eps = 1e-6;
    double spec_strength = fmax(specular[0], fmax(specular[1], specular[2]));
    double one_minus = 1 - spec_strength;
    double pd = perceived_brightness(diffuse), ps = perceived_brightness(specular);
    double metallic = 0;
    if (ps >= f0) {
        double a = f0, b = pd * one_minus / (1 - f0) + ps - 2 * f0, c = f0 - ps;
        double D = b * b - 4 * a * c;
        metallic = fmin(fmax((-b + sqrt(fmax(D, 0))) / (2 * a), 0), 1);
    }
    for (int k = 0; k < 3; k++) {
        double from_diffuse = diffuse[k] * one_minus / (1 - f0) / fmax(1 - metallic, eps);
        double from_specular = (specular[k] - f0 * (1 - metallic)) / fmax(metallic, eps);
        double w = metallic * metallic;
        sm->base_color[k] = (float)fmin(fmax(from_diffuse + (from_specular - from_diffuse) * w, 0), 1);
    }
    sm->base_color[3] = (float)diffuse[3];
    sm->metallic = (float)metallic;
    sm->roughness = (float)(1 - gloss);
    sm->tex[SPT_SLOT_METALLIC_ROUGHNESS].tex = -1;
    sm->tex[SPT_SLOT_METALLIC_ROUGHNESS].gltf_index = -1;
    if (x.Has("diffuseTexture")) {
        SceneTexRef &b = sm->tex[SPT_SLOT_BASE];
        for (int k = 0; k < 6; k++) b.transform[k] = k == 0 || k == 4;
        b.gltf_index = -1;
        if ((rc = ext_texture(x, "diffuseTexture", true, obj, &b))) return rc;
    }
    if (x.Has("specularGlossinessTexture")) specgloss_textures++;
    return 0;
}

// Converts materials[index] (index -1: the glTF default material) and returns its
// position in mats, or a negative exit code.
int Loader::material(int index)
{
    SceneMaterial sm;
    scene_material_default(&sm);
    const auto &mat = m.materials[index];
    std::string name = mat.name.empty() ? "" : " '" + mat.name + "'";
    std::string obj = "materials[" + std::to_string(index) + "]" + name;
    snprintf(sm.name, sizeof sm.name, "%s",
             mat.name.empty() ? ("materials[" + std::to_string(index) + "]").c_str()
                              : mat.name.c_str());
    const char *o = obj.c_str();
    const auto &pbr = mat.pbrMetallicRoughness;
    if (pbr.baseColorFactor.size() != 4)
        return -bad("%s.pbrMetallicRoughness.baseColorFactor: expected 4 numbers", o);
    for (int k = 0; k < 4; k++) sm.base_color[k] = (float)fmin(fmax(pbr.baseColorFactor[k], 0), 1);
    sm.metallic = (float)fmin(fmax(pbr.metallicFactor, 0), 1);
    sm.roughness = (float)fmin(fmax(pbr.roughnessFactor, 0), 1);
    int rc;
    if ((rc = texture_ref(pbr.baseColorTexture.index, pbr.baseColorTexture.texCoord, true,
                          obj + ".pbrMetallicRoughness.baseColorTexture", &sm.tex[SPT_SLOT_BASE],
                          &pbr.baseColorTexture.extensions)) ||
        (rc = texture_ref(pbr.metallicRoughnessTexture.index,
                          pbr.metallicRoughnessTexture.texCoord, false,
                          obj + ".pbrMetallicRoughness.metallicRoughnessTexture",
                          &sm.tex[SPT_SLOT_METALLIC_ROUGHNESS], &pbr.metallicRoughnessTexture.extensions)) ||
        (rc = texture_ref(mat.emissiveTexture.index, mat.emissiveTexture.texCoord, true,
                          obj + ".emissiveTexture", &sm.tex[SPT_SLOT_EMISSIVE],
                          &mat.emissiveTexture.extensions)) ||
        (rc = texture_ref(mat.normalTexture.index, mat.normalTexture.texCoord, false,
                          obj + ".normalTexture", &sm.tex[SPT_SLOT_NORMAL], &mat.normalTexture.extensions)) ||
        (rc = texture_ref(mat.occlusionTexture.index, mat.occlusionTexture.texCoord, false,
                          obj + ".occlusionTexture", &sm.tex[SPT_SLOT_OCCLUSION],
                          &mat.occlusionTexture.extensions, false)))
        return -rc;
    sm.normal_scale = (float)mat.normalTexture.scale;
    if (!mat.emissiveFactor.empty()) {
        if (mat.emissiveFactor.size() != 3) return -bad("%s.emissiveFactor: expected 3 numbers", o);
        for (int k = 0; k < 3; k++) sm.emissive[k] = (float)fmin(fmax(mat.emissiveFactor[k], 0), 1);
    }
    if (mat.alphaMode == "OPAQUE")
        sm.alpha_mode = SPT_ALPHA_OPAQUE;
    else if (mat.alphaMode == "MASK")
        sm.alpha_mode = SPT_ALPHA_MASK;
    else if (mat.alphaMode == "BLEND")
        sm.alpha_mode = SPT_ALPHA_BLEND;
    else
        return -bad("%s.alphaMode: '%s' is not OPAQUE, MASK or BLEND", o, mat.alphaMode.c_str());
    if (!(mat.alphaCutoff >= 0)) return -bad("%s.alphaCutoff: %g is negative", o, mat.alphaCutoff);
    sm.alpha_cutoff = (float)mat.alphaCutoff;
    sm.double_sided = mat.doubleSided ? 1 : 0;

    auto ext = [&](const char *name) -> const Value * {
        auto it = mat.extensions.find(name);
        return it == mat.extensions.end() ? nullptr : &it->second;
    };
    std::string eo = obj + ".extensions.";
    double d;
    if (const Value *x = ext("KHR_materials_emissive_strength")) {
        d = 1;
        if ((rc = ext_number(this, *x, "emissiveStrength", &d, eo + "KHR_materials_emissive_strength")))
            return -rc;
        if (d < 0) return -bad("%sKHR_materials_emissive_strength: negative strength", eo.c_str());
        sm.emissive_strength = (float)d;
    }
    if (const Value *x = ext("KHR_materials_ior")) {
        d = 1.5;
        if ((rc = ext_number(this, *x, "ior", &d, eo + "KHR_materials_ior"))) return -rc;
        if (d < 1 && d != 0) return -bad("%sKHR_materials_ior.ior: %g is below 1", eo.c_str(), d);
        sm.ior = (float)d;
    }
    if (const Value *x = ext("KHR_materials_transmission")) {
        d = 0;
        if ((rc = ext_number(this, *x, "transmissionFactor", &d, eo + "KHR_materials_transmission")))
            return -rc;
        sm.transmission = (float)fmin(fmax(d, 0), 1);
        if ((rc = ext_texture(*x, "transmissionTexture", false, eo + "KHR_materials_transmission",
                              &sm.tex[SPT_SLOT_TRANSMISSION])))
            return -rc;
    }
    if (const Value *x = ext("KHR_materials_dispersion")) {
        d = 0;
        if ((rc = ext_number(this, *x, "dispersion", &d, eo + "KHR_materials_dispersion")))
            return -rc;
        if (d < 0) return -bad("%sKHR_materials_dispersion.dispersion: negative", eo.c_str());
        sm.dispersion = (float)d;
    }
    if (const Value *x = ext("KHR_materials_volume")) {
        std::string vo = eo + "KHR_materials_volume";
        d = 0;
        if ((rc = ext_number(this, *x, "thicknessFactor", &d, vo))) return -rc;
        if (d < 0) return -bad("%s.thicknessFactor: negative", vo.c_str());
        sm.thickness = (float)d;
        d = 0;
        if ((rc = ext_number(this, *x, "attenuationDistance", &d, vo))) return -rc;
        if (x->Has("attenuationDistance") && !(d > 0))
            return -bad("%s.attenuationDistance: must be > 0", vo.c_str());
        sm.attenuation_distance = (float)d;
        if (x->Has("attenuationColor")) {
            const Value &c = x->Get("attenuationColor");
            if (!c.IsArray() || c.ArrayLen() != 3)
                return -bad("%s.attenuationColor: expected 3 numbers", vo.c_str());
            for (int k = 0; k < 3; k++) {
                if (!c.Get(k).IsNumber()) return -bad("%s.attenuationColor: not a number", vo.c_str());
                sm.attenuation_color[k] = (float)fmin(fmax(c.Get(k).GetNumberAsDouble(), 0), 1);
            }
        }
    }
    if (const Value *x = ext("KHR_materials_specular")) {
        std::string so = eo + "KHR_materials_specular";
        d = 1;
        if ((rc = ext_number(this, *x, "specularFactor", &d, so))) return -rc;
        if (!(d >= 0)) return -bad("%s.specularFactor: negative", so.c_str());
        sm.specular = (float)fmin(d, 1);
        if (x->Has("specularColorFactor")) {
            const Value &c = x->Get("specularColorFactor");
            if (!c.IsArray() || c.ArrayLen() != 3)
                return -bad("%s.specularColorFactor: expected 3 numbers", so.c_str());
            for (int k = 0; k < 3; k++) {
                if (!c.Get(k).IsNumber()) return -bad("%s.specularColorFactor: not a number", so.c_str());
                double v = c.Get(k).GetNumberAsDouble();
                if (!(v >= 0) || !std::isfinite(v))
                    return -bad("%s.specularColorFactor: must be finite and >= 0", so.c_str());
                sm.specular_color[k] = (float)v;
            }
        }
        if ((rc = ext_texture(*x, "specularTexture", false, so, &sm.tex[SPT_SLOT_SPECULAR])) ||
            (rc = ext_texture(*x, "specularColorTexture", true, so, &sm.tex[SPT_SLOT_SPECULAR_COLOR])))
            return -rc;
    }
    if (const Value *x = ext("KHR_materials_clearcoat")) {
        std::string co = eo + "KHR_materials_clearcoat";
        double cc = 0, cr = 0;
        if ((rc = ext_number(this, *x, "clearcoatFactor", &cc, co)) ||
            (rc = ext_number(this, *x, "clearcoatRoughnessFactor", &cr, co)))
            return -rc;
        sm.clearcoat = (float)fmin(fmax(cc, 0), 1);
        sm.clearcoat_roughness = (float)fmin(fmax(cr, 0), 1);
        if ((rc = ext_texture(*x, "clearcoatTexture", false, co, &sm.tex[SPT_SLOT_CLEARCOAT])) ||
            (rc = ext_texture(*x, "clearcoatRoughnessTexture", false, co,
                              &sm.tex[SPT_SLOT_CLEARCOAT_ROUGHNESS])) ||
            (rc = ext_texture(*x, "clearcoatNormalTexture", false, co, &sm.tex[SPT_SLOT_CLEARCOAT_NORMAL],
                              &sm.clearcoat_normal_scale)))
            return -rc;
    }
    if (const Value *x = ext("KHR_materials_sheen")) {
        std::string sho = eo + "KHR_materials_sheen";
        if (x->Has("sheenColorFactor")) {
            const Value &c = x->Get("sheenColorFactor");
            if (!c.IsArray() || c.ArrayLen() != 3)
                return -bad("%s.sheenColorFactor: expected 3 numbers", sho.c_str());
            for (int k = 0; k < 3; k++) {
                if (!c.Get(k).IsNumber() || !std::isfinite(c.Get(k).GetNumberAsDouble()))
                    return -bad("%s.sheenColorFactor: not a number", sho.c_str());
                sm.sheen_color[k] = (float)fmin(fmax(c.Get(k).GetNumberAsDouble(), 0), 1);
            }
        }
        double sr = 0;
        if ((rc = ext_number(this, *x, "sheenRoughnessFactor", &sr, sho))) return -rc;
        sm.sheen_roughness = (float)fmin(fmax(sr, 0), 1);
        if ((rc = ext_texture(*x, "sheenColorTexture", true, sho, &sm.tex[SPT_SLOT_SHEEN_COLOR])) ||
            (rc = ext_texture(*x, "sheenRoughnessTexture", false, sho, &sm.tex[SPT_SLOT_SHEEN_ROUGHNESS])))
            return -rc;
    }
    if (ext("KHR_materials_unlit")) sm.unlit = 1;
    if (const Value *x = ext("KHR_materials_pbrSpecularGlossiness"))
        if ((rc = spec_gloss(*x, &sm, eo + "KHR_materials_pbrSpecularGlossiness"))) return -rc;
    for (const char *ig : k_ignored_material_ext)
        if (ext(ig)) ignored_ext[ig].push_back(sm.name);
    if ((rc = spectral_extras(mat.extras, &sm, obj))) {
        spd_free(&sm.emission_spd);
        spd_free(&sm.reflectance_spd);
        return -rc;
    }
    mats.push_back(sm);
    return (int)mats.size() - 1;
}

// ---------------------------------------------------------------------------
// Geometry

int Loader::read_primitive(int mi, int pi)
{
    PrimData &pd = prim[mi][pi];
    pd.read = true;
    const auto &p = m.meshes[mi].primitives[pi];
    std::string obj = "meshes[" + std::to_string(mi) + "].primitives[" + std::to_string(pi) + "]";
    const char *o = obj.c_str();
    int mode = p.mode < 0 ? TINYGLTF_MODE_TRIANGLES : p.mode;
    if (mode > TINYGLTF_MODE_TRIANGLE_FAN) return bad("%s.mode: %d is not a glTF mode", o, mode);
    if (p.material < -1 || (p.material >= 0 && (size_t)p.material >= m.materials.size()))
        return bad("%s.material: materials[%d] does not exist", o, p.material);
    if (mode < TINYGLTF_MODE_TRIANGLES) {
        pd.skip = true;
        modes_skipped++;
        return 0;
    }
    auto pit = p.attributes.find("POSITION");
    if (pit == p.attributes.end()) {
        pd.skip = true;
        no_position++;
        return 0;
    }
    const int f = TINYGLTF_COMPONENT_TYPE_FLOAT, i8 = TINYGLTF_COMPONENT_TYPE_BYTE,
              u8 = TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE, i16 = TINYGLTF_COMPONENT_TYPE_SHORT,
              u16 = TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT;
    // KHR_mesh_quantization (when the file uses it) widens the attribute types:
    // POSITION and TEXCOORD_n any 8/16-bit integer, normalised or not; NORMAL
    // normalised signed 8/16-bit. Node transforms dequantise positions.
    std::vector<int> pos_types = {f}, nrm_types = {f}, uv_types = {f, u8, u16};
    if (quantization) {
        pos_types = {f, i8, u8, i16, u16};
        nrm_types = {f, i8, i16};
        uv_types = {f, i8, u8, i16, u16};
    }
    bool zeros;
    int rc;
    std::vector<uint32_t> idx;
    auto dit = p.extensions.find("KHR_draco_mesh_compression");
    if (dit != p.extensions.end()) {
        if ((rc = read_draco(mi, pi, dit->second, idx))) return rc;
    } else if ((rc = [&]() -> int { // the plain (accessor) attributes and indices
        if ((rc = check_accessor(pit->second, obj + ".attributes.POSITION", 3, pos_types,
                                 quantization ? 2 : 0, &zeros)))
            return rc;
        size_t nv = m.accessors[pit->second].count;
        if (nv > UINT32_MAX) return bad("%s: more than 2^32 vertices", o);
        auto nit = p.attributes.find("NORMAL");
        if (nit != p.attributes.end()) {
            if ((rc = check_accessor(nit->second, obj + ".attributes.NORMAL", 3, nrm_types,
                                     quantization ? 1 : 0, &zeros)))
                return rc;
            if (m.accessors[nit->second].count != nv)
                return bad("%s.attributes.NORMAL (accessors[%d]): count %zu differs from POSITION's %zu",
                           o, nit->second, m.accessors[nit->second].count, nv);
        }
        // TEXCOORD_0, TEXCOORD_1 and COLOR_0 (VEC3 or VEC4 of floats or normalised
        // unsigned bytes or shorts, glTF 2.0 3.7.2.1).
        int acc[3] = {-1, -1, -1}, ncol = 0;
        const char *names[3] = {"TEXCOORD_0", "TEXCOORD_1", "COLOR_0"};
        for (int k = 0; k < 3; k++) {
            auto it = p.attributes.find(names[k]);
            if (it == p.attributes.end()) continue;
            std::string ao = obj + ".attributes." + names[k];
            if (k == 2) {
                if (it->second >= 0 && (size_t)it->second < m.accessors.size())
                    ncol = type_components(m.accessors[it->second].type) == 3 ? 3 : 4;
                if ((rc = check_accessor(it->second, ao, ncol ? ncol : 4, {f, u8, u16}, 1, &zeros)))
                    return rc;
            } else if ((rc = check_accessor(it->second, ao, 2, uv_types, quantization ? 2 : 1, &zeros))) {
                return rc;
            }
            if (m.accessors[it->second].count != nv)
                return bad("%s (accessors[%d]): count %zu differs from POSITION's %zu", ao.c_str(),
                           it->second, m.accessors[it->second].count, nv);
            acc[k] = it->second;
        }
        for (const auto &a : p.attributes)
            if (a.first.compare(0, 9, "TEXCOORD_") == 0 && a.first != names[0] && a.first != names[1]) {
                texcoord_unread++;
                break;
            }
        auto vkey = std::make_tuple(pit->second, nit != p.attributes.end() ? nit->second : -1, acc[0],
                                    acc[1], acc[2]);
        auto own = vertex_owner.find(vkey);
        if (own != vertex_owner.end()) {
            pd.vsrc = own->second;
        } else {
            vertex_owner[vkey] = &pd;
            read_floats(pit->second, 3, pd.pos);
            if (nit != p.attributes.end()) read_floats(nit->second, 3, pd.nrm);
            if (acc[0] >= 0) read_floats(acc[0], 2, pd.uv);
            if (acc[1] >= 0) read_floats(acc[1], 2, pd.uv1);
            if (acc[2] >= 0) {
                std::vector<float> c;
                read_floats(acc[2], ncol, c);
                pd.col.resize(nv * 4, 1.0f);
                for (size_t v = 0; v < nv; v++)
                    for (int k = 0; k < ncol; k++) pd.col[v * 4 + k] = c[v * ncol + k];
            }
        }
        if (p.indices >= 0) {
            if ((rc = check_accessor(p.indices, obj + ".indices", 1,
                                     {TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE,
                                      TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT,
                                      TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT},
                                     false, &zeros)))
                return rc;
            read_indices(p.indices, idx);
            for (size_t i = 0; i < idx.size(); i++)
                if (idx[i] >= nv)
                    return bad("%s.indices (accessors[%d]): element %zu is %u, but POSITION has only "
                               "%zu vertices",
                               o, p.indices, i, idx[i], nv);
        } else if (p.indices < -1) {
            return bad("%s.indices: accessors[%d] does not exist", o, p.indices);
        } else {
            idx.resize(nv);
            for (size_t i = 0; i < nv; i++) idx[i] = (uint32_t)i;
        }
        return 0;
        }()))
        return rc;
    size_t n = idx.size();
    if (mode == TINYGLTF_MODE_TRIANGLES) {
        if (n % 3) leftover_indices++;
        for (size_t i = 0; i + 2 < n; i += 3)
            pd.tris.insert(pd.tris.end(), {idx[i], idx[i + 1], idx[i + 2]});
    } else if (mode == TINYGLTF_MODE_TRIANGLE_STRIP) {
        // glTF 2.0 3.7.2.1: triangle i is (i, i + 1 + i%2, i + 2 - i%2).
        for (size_t i = 0; i + 2 < n; i++)
            pd.tris.insert(pd.tris.end(), {idx[i], idx[i + 1 + i % 2], idx[i + 2 - i % 2]});
    } else {
        // Fans: triangle i is (i + 1, i + 2, 0).
        for (size_t i = 0; i + 2 < n; i++)
            pd.tris.insert(pd.tris.end(), {idx[i + 1], idx[i + 2], idx[0]});
    }
    if (p.material < 0) {
        if (default_material < 0) {
            SceneMaterial sm;
            scene_material_default(&sm);
            mats.push_back(sm);
            default_material = (int)mats.size() - 1;
        }
        pd.material = (uint32_t)default_material;
    } else {
        pd.material = (uint32_t)p.material; // materials are converted first, same order
    }
    return 0;
}

// EXT_meshopt_compression: every compressed buffer view is decoded into a new
// buffer and the view pointed at it, so the rest of the loader (and its range
// checks) sees plain data.
int Loader::decode_meshopt_views()
{
    size_t nviews = m.bufferViews.size();
    for (size_t i = 0; i < nviews; i++) {
        auto &bv = m.bufferViews[i];
        auto it = bv.extensions.find("EXT_meshopt_compression");
        if (it == bv.extensions.end()) continue;
        const Value &x = it->second;
        std::string o = "bufferViews[" + std::to_string(i) + "].extensions.EXT_meshopt_compression";
        if (!x.IsObject()) return bad("%s: not a JSON object", o.c_str());
        double num[5] = {-1, 0, -1, -1, -1}; // buffer, byteOffset, byteLength, byteStride, count
        const char *keys[5] = {"buffer", "byteOffset", "byteLength", "byteStride", "count"};
        for (int k = 0; k < 5; k++) {
            if (!x.Has(keys[k])) {
                if (k == 1) continue;
                return bad("%s.%s: missing (required)", o.c_str(), keys[k]);
            }
            const Value &v = x.Get(keys[k]);
            if (!v.IsNumber() || !(v.GetNumberAsDouble() >= 0) ||
                v.GetNumberAsDouble() > 9e15 || v.GetNumberAsDouble() != floor(v.GetNumberAsDouble()))
                return bad("%s.%s: not an integer >= 0", o.c_str(), keys[k]);
            num[k] = v.GetNumberAsDouble();
        }
        size_t buf = (size_t)num[0], off = (size_t)num[1], len = (size_t)num[2],
               stride = (size_t)num[3], count = (size_t)num[4];
        if (buf >= m.buffers.size())
            return bad("%s.buffer: buffers[%zu] does not exist", o.c_str(), buf);
        size_t blen = m.buffers[buf].data.size();
        if (off > blen || len > blen - off)
            return bad("%s: bytes %zu..%zu run past the end of buffers[%zu] (%zu bytes)", o.c_str(),
                       off, off + len, buf, blen);
        std::string mode = x.Get("mode").IsString() ? x.Get("mode").Get<std::string>() : "";
        std::string filter = x.Get("filter").IsString() ? x.Get("filter").Get<std::string>() : "NONE";
        int md = mode == "ATTRIBUTES" ? SPT_MESHOPT_ATTRIBUTES
                 : mode == "TRIANGLES" ? SPT_MESHOPT_TRIANGLES
                 : mode == "INDICES"   ? SPT_MESHOPT_INDICES
                                       : -1;
        int fl = filter == "NONE"          ? SPT_MESHOPT_NONE
                 : filter == "OCTAHEDRAL"  ? SPT_MESHOPT_OCTAHEDRAL
                 : filter == "QUATERNION"  ? SPT_MESHOPT_QUATERNION
                 : filter == "EXPONENTIAL" ? SPT_MESHOPT_EXPONENTIAL
                                           : -1;
        if (md < 0)
            return bad("%s.mode: '%s' is not ATTRIBUTES, TRIANGLES or INDICES", o.c_str(),
                       mode.c_str());
        if (fl < 0)
            return bad("%s.filter: '%s' is not NONE, OCTAHEDRAL, QUATERNION or EXPONENTIAL",
                       o.c_str(), filter.c_str());
        size_t total;
        if (count == 0 || __builtin_mul_overflow(count, stride, &total) ||
            total > ((size_t)1 << 32))
            return bad("%s: count %zu x byteStride %zu is 0 or above 4 GiB", o.c_str(), count,
                       stride);
        // The codecs spend at least 2 bits per 16 bytes of output (vertex) or a
        // byte per triangle (index): anything larger is corrupt, and refusing it
        // here avoids allocating for it.
        if (total / 64 > len + 1024)
            return bad("%s: corrupt compressed data (%zu bytes cannot hold %zu)", o.c_str(), len,
                       total);
        tinygltf::Buffer out;
        out.data.resize(total);
        char why[200] = "";
        if (mesh_meshopt_decode(out.data.data(), count, stride, m.buffers[buf].data.data() + off,
                                len, md, fl, why, sizeof why))
            return bad("%s: %s", o.c_str(), why);
        m.buffers.push_back(std::move(out));
        auto &v = m.bufferViews[i]; // push_back above may not move views, but be safe
        v.buffer = (int)m.buffers.size() - 1;
        v.byteOffset = 0;
        v.byteLength = total;
        if (md != SPT_MESHOPT_ATTRIBUTES) v.byteStride = 0;
        else if (v.byteStride == 0) v.byteStride = stride;
        meshopt_views++;
    }
    return 0;
}

// KHR_draco_mesh_compression: the primitive's attributes and triangles come from
// the Draco mesh in the extension's bufferView (the accessors only describe it).
int Loader::read_draco(int mi, int pi, const Value &x, std::vector<uint32_t> &idx)
{
    PrimData &pd = prim[mi][pi];
    const auto &p = m.meshes[mi].primitives[pi];
    std::string o = "meshes[" + std::to_string(mi) + "].primitives[" + std::to_string(pi) +
                    "].extensions.KHR_draco_mesh_compression";
    if (!x.IsObject()) return bad("%s: not a JSON object", o.c_str());
    int mode = p.mode < 0 ? TINYGLTF_MODE_TRIANGLES : p.mode;
    if (mode != TINYGLTF_MODE_TRIANGLES)
        return bad("%s: only TRIANGLES primitives are supported with Draco", o.c_str());
    const Value &bvv = x.Get("bufferView");
    if (!bvv.IsInt() || bvv.GetNumberAsInt() < 0 ||
        (size_t)bvv.GetNumberAsInt() >= m.bufferViews.size())
        return bad("%s.bufferView: not an index into the file's %zu buffer views", o.c_str(),
                   m.bufferViews.size());
    const Value &attrs = x.Get("attributes");
    if (!attrs.IsObject() || !attrs.Get("POSITION").IsInt())
        return bad("%s.attributes: no POSITION id", o.c_str());
    const auto &bv = m.bufferViews[bvv.GetNumberAsInt()];
    char why[300] = "";
    DracoDecoded *d = mesh_draco_decode(m.buffers[bv.buffer].data.data() + bv.byteOffset,
                                        bv.byteLength, why, sizeof why);
    if (!d) return bad("%s: %s", o.c_str(), why);
    std::unique_ptr<DracoDecoded, void (*)(DracoDecoded *)> guard(d, mesh_draco_free);
    size_t np = mesh_draco_points(d), nf = mesh_draco_faces(d);
    if (np == 0 || nf == 0) return bad("%s: the Draco mesh is empty", o.c_str());
    // COLOR_0 has as many components as the primitive's accessor for it says.
    auto cit = p.attributes.find("COLOR_0");
    int ncol = cit != p.attributes.end() && cit->second >= 0 && (size_t)cit->second < m.accessors.size() &&
                       type_components(m.accessors[cit->second].type) == 3
                   ? 3
                   : 4;
    std::vector<float> col;
    const struct {
        const char *name;
        int ncomp;
        std::vector<float> *out;
    } want[5] = {{"POSITION", 3, &pd.pos}, {"NORMAL", 3, &pd.nrm}, {"TEXCOORD_0", 2, &pd.uv},
                 {"TEXCOORD_1", 2, &pd.uv1}, {"COLOR_0", ncol, &col}};
    for (const auto &w : want) {
        const Value &id = attrs.Get(w.name);
        if (!id.IsInt()) continue;
        w.out->resize(np * (size_t)w.ncomp);
        if (mesh_draco_attribute(d, id.GetNumberAsInt(), w.ncomp, w.out->data()))
            return bad("%s.attributes.%s: no Draco attribute %d with %d components", o.c_str(),
                       w.name, id.GetNumberAsInt(), w.ncomp);
    }
    if (!col.empty()) {
        pd.col.assign(np * 4, 1.0f);
        for (size_t v = 0; v < np; v++)
            for (int k = 0; k < ncol; k++) pd.col[v * 4 + k] = col[v * ncol + k];
    }
    idx.resize(nf * 3);
    mesh_draco_indices(d, idx.data());
    for (size_t i = 0; i < idx.size(); i++)
        if (idx[i] >= np) return bad("%s: a face refers to point %u of %zu", o.c_str(), idx[i], np);
    draco_primitives++;
    return 0;
}

bool coordinate_ok(double x) { return std::isfinite(x) && fabs(x) < 1e18; }

int Loader::emit_instance(int mi, const Mat4 &world)
{
    const auto &mesh = m.meshes[mi];
    stats.instances++;
    bool repeat = mesh_emitted[mi]++ > 0; // a further instance: flattened copy
    if (mesh_emitted[mi] == 2) stats.instanced_meshes++;
    uint64_t tris_before = tri_mat.size(), verts_before = vertex_count;
    double det = det3(world), cof[9];
    cofactor3(world, cof);
    bool mirrored = det < 0;
    // Vertices already emitted for this instance: shared vertex data -> base, world
    // positions.
    std::map<const PrimData *, std::pair<uint64_t, std::vector<double>>> emitted;
    for (size_t pi = 0; pi < mesh.primitives.size(); pi++) {
        PrimData &pd = prim[mi][pi];
        int rc;
        if (!pd.read && (rc = read_primitive(mi, (int)pi))) return rc;
        if (pd.skip) continue;
        stats.primitives++;
        const PrimData &vd = pd.vsrc ? *pd.vsrc : pd;
        size_t nv = vd.pos.size() / 3;
        auto done = emitted.find(&vd);
        if (done == emitted.end()) {
            if (vertex_count + nv > k_max_vertices)
                return bad("more than 2^31 vertices in the scene");
            done = emitted.emplace(&vd, std::make_pair(vertex_count, std::vector<double>())).first;
            std::vector<double> &wp = done->second.second;
            wp.resize(nv * 3);
            for (size_t v = 0; v < nv; v++) {
                double p[3] = {vd.pos[v * 3], vd.pos[v * 3 + 1], vd.pos[v * 3 + 2]};
                mat_point(world, p, &wp[v * 3]);
                double nw[3] = {0, 0, 0};
                if (!vd.nrm.empty()) {
                    const float *n = &vd.nrm[v * 3];
                    for (int r = 0; r < 3; r++)
                        nw[r] = (cof[r * 3] * n[0] + cof[r * 3 + 1] * n[1] + cof[r * 3 + 2] * n[2]) *
                                (mirrored ? -1.0 : 1.0);
                    if (!normalize3(nw)) nw[0] = nw[1] = nw[2] = 0;
                }
                for (int r = 0; r < 3; r++) vtx_normal.push_back((float)nw[r]);
                vtx_uv.push_back(vd.uv.empty() ? 0.0f : vd.uv[v * 2]);
                vtx_uv.push_back(vd.uv.empty() ? 0.0f : vd.uv[v * 2 + 1]);
                // TEXCOORD_1 where the primitive has none: its TEXCOORD_0, so a
                // slot reading set 1 sees the mesh's only mapping.
                const std::vector<float> &u1 = vd.uv1.empty() ? vd.uv : vd.uv1;
                vtx_uv1.push_back(u1.empty() ? 0.0f : u1[v * 2]);
                vtx_uv1.push_back(u1.empty() ? 0.0f : u1[v * 2 + 1]);
                // COLOR_0 clamped to [0, 1] (a colour multiplying the base colour).
                for (int k = 0; k < 4; k++)
                    vtx_color.push_back(vd.col.empty() ? 1.0f : fminf(fmaxf(vd.col[v * 4 + k], 0.0f), 1.0f));
            }
            vertex_count += nv;
            any_uv1 |= !vd.uv1.empty();
            any_color |= !vd.col.empty();
        }
        uint64_t base = done->second.first;
        const std::vector<double> &wp = done->second.second;
        const SceneMaterial &sm = mats[pd.material];
        if (vd.uv1.empty())
            for (int k = 0; k < SPT_SLOT_COUNT; k++)
                if (sm.tex[k].tex >= 0 && sm.tex[k].texcoord == 1) {
                    uv1_missing++;
                    break;
                }
        bool emissive = sm.emission_spd.count > 0 ||
                        (sm.emissive_strength > 0 &&
                         (sm.emissive[0] > 0 || sm.emissive[1] > 0 || sm.emissive[2] > 0));
        for (size_t t = 0; t + 2 < pd.tris.size(); t += 3) {
            uint32_t a = pd.tris[t], b = pd.tris[t + 1], c = pd.tris[t + 2];
            if (a == b || b == c || a == c) {
                stats.dropped_degenerate++;
                continue;
            }
            if (mirrored) std::swap(b, c);
            float fp[9];
            bool finite = true;
            for (int k = 0; k < 3; k++) {
                uint32_t v = k == 0 ? a : k == 1 ? b : c;
                for (int r = 0; r < 3; r++) {
                    fp[k * 3 + r] = (float)wp[v * 3 + r];
                    finite &= coordinate_ok(wp[v * 3 + r]) && coordinate_ok(fp[k * 3 + r]);
                }
            }
            if (!finite) {
                stats.dropped_nonfinite++;
                continue;
            }
            double e1[3], e2[3], cr[3];
            for (int r = 0; r < 3; r++) {
                e1[r] = (double)fp[3 + r] - fp[r];
                e2[r] = (double)fp[6 + r] - fp[r];
            }
            cross3(e1, e2, cr);
            double area2 = sqrt(cr[0] * cr[0] + cr[1] * cr[1] + cr[2] * cr[2]);
            double l1 = sqrt(e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2]);
            double l2 = sqrt(e2[0] * e2[0] + e2[1] * e2[1] + e2[2] * e2[2]);
            if (!(area2 > 1e-10 * l1 * l2) || area2 == 0) {
                stats.dropped_degenerate++;
                continue;
            }
            if (tri_mat.size() >= k_max_triangles)
                return bad("more than 2^30 triangles in the scene");
            tri_pos.insert(tri_pos.end(), fp, fp + 9);
            tri_vidx.insert(tri_vidx.end(),
                            {(uint32_t)(base + a), (uint32_t)(base + b), (uint32_t)(base + c)});
            tri_mat.push_back(pd.material);
            if (emissive) stats.emissive_triangles++;
        }
    }
    if (repeat) {
        stats.flattened_triangles += (uint32_t)(tri_mat.size() - tris_before);
        stats.flattened_vertices += (uint32_t)(vertex_count - verts_before);
    }
    return 0;
}

template <class T> T *copy_out(const std::vector<T> &v)
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
    s->material_count = (uint32_t)mats.size();
    s->materials = copy_out(mats);
    mats.clear(); // the SPDs now belong to s
    s->texture_count = (uint32_t)texs.size();
    s->textures = copy_out(texs);
    texs.clear();
    s->light_count = (uint32_t)lights.size();
    s->lights = copy_out(lights);
    s->stats = stats;
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

int load(Scene *s, const unsigned char *data, size_t size, const char *name, SptError *e)
{
    memset(s, 0, sizeof *s);
    Loader L;
    L.file = name;
    L.e = e;
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
        L.decoded_state.assign(L.m.images.size(), 0);
        L.decoded.assign(L.m.images.size(), TextureImage());
        for (size_t i = 0; i < L.m.materials.size(); i++) {
            int mi = L.material((int)i);
            if (mi < 0) {
                rc = -mi;
                goto out;
            }
        }
        if ((rc = L.traverse())) goto out;
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
    for (auto &t : L.texs) free(t.texels);
    for (auto &d : L.decoded) texture_io_free(&d);
    if (rc) scene_free(s);
    return rc;
}

} // namespace

extern "C" int scene_load_gltf_memory(Scene *s, const void *data, size_t size, const char *name,
                                      SptError *e)
{
    return load(s, (const unsigned char *)data, size, name, e);
}

extern "C" int scene_load_gltf(Scene *s, const char *path, SptError *e)
{
    memset(s, 0, sizeof *s);
    FILE *f = fopen(path, "rb");
    if (!f) return spt_fail(e, SPT_EXIT_INPUT, "%s: cannot open: %s", path, strerror(errno));
    std::vector<unsigned char> bytes;
    unsigned char chunk[1 << 16];
    size_t n;
    while ((n = fread(chunk, 1, sizeof chunk, f)) > 0) bytes.insert(bytes.end(), chunk, chunk + n);
    bool failed = ferror(f);
    fclose(f);
    if (failed) return spt_fail(e, SPT_EXIT_INPUT, "%s: cannot read the file", path);
    return load(s, bytes.data(), bytes.size(), path, e);
}
