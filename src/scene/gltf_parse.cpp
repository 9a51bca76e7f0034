// The glTF loader's parsing and validation: the JSON and GLB container, the
// version and required extensions, buffer views and accessors, read into arrays.
#include "scene/gltf_loader.h"
#include <algorithm>

namespace spt_gltf {

// Extensions whose meaning we implement; only these may be in extensionsRequired.
// Keep in sync with the code that reads them and docs/gltf.md, "What the loader reads".
const char *const k_supported_ext[] = {
    "KHR_materials_emissive_strength", "KHR_materials_ior", "KHR_materials_transmission",
    "KHR_materials_dispersion", "KHR_materials_volume", "KHR_materials_unlit",
    "KHR_lights_punctual", "KHR_texture_transform", "KHR_materials_pbrSpecularGlossiness",
    "KHR_mesh_quantization", "EXT_meshopt_compression", "KHR_draco_mesh_compression",
    "EXT_texture_webp", "KHR_materials_specular", "KHR_materials_clearcoat", "KHR_materials_sheen",
    "KHR_materials_iridescence",
    "KHR_materials_anisotropy", "KHR_materials_diffuse_transmission",
    "EXT_mesh_gpu_instancing",
};


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

// EXT_meshopt_compression's fallback buffers may have no uri (their bytes are
// never needed when the extension is decoded), which tinygltf refuses in a
// .gltf and reads past the BIN chunk in a .glb. Such buffers get a 4-byte data
// URI instead; *out is the rewritten JSON. False when nothing was rewritten.
// Likewise KHR_draco_mesh_compression primitives' indices accessors have no
// bufferView (the faces are in the Draco data), which tinygltf refuses: their
// "indices" is dropped (the loader takes the faces from Draco).
// A buffer without uri that holds no data (valid while nothing reads it: any in
// a .gltf, any but buffers[0] in a .glb) gets the same 4-byte data URI, and its
// buffer views become 4-byte views of it, listed in *dead_views: an accessor
// that reads one is refused (check_accessor), an image in one is unusable.
// In a .glb, buffers[0] without uri is the BIN chunk (glTF 2.0 4.4.3.3): with
// no BIN chunk (bin_len 0), or one shorter than its byteLength, *why says so
// and the file is refused.
// Also rewritten, so that the glTF library reads what the glTF validator
// accepts as valid: numbers written with a fraction or exponent that are whole
// (1.0, 1e0: JSON does not tell them from 1, and the library reads only integers
// as indices and counts) become integers; a data URI buffer that is not base64
// (RFC 2397 allows percent-encoded bytes; the library reads only base64) becomes
// a base64 one; and a primitive's indices accessor without bufferView (zeros,
// perhaps with sparse values: glTF 2.0 3.6.2.3), which the library refuses, is
// taken out of the primitive and listed in *zero_view_indices as
// (mesh, primitive) -> accessor, read by the loader itself.
static void whole_floats_to_integers(nlohmann::json &v, bool *changed)
{
    if (v.is_object() || v.is_array()) {
        for (auto &x : v) whole_floats_to_integers(x, changed);
    } else if (v.is_number_float()) {
        double d = v.get<double>();
        if (std::isfinite(d) && d == floor(d) && fabs(d) <= 9007199254740992.0) {
            v = (long long)d;
            *changed = true;
        }
    }
}

static const char k_b64[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";

static std::string base64(const std::string &bytes)
{
    std::string out;
    size_t i = 0, n = bytes.size();
    for (; i + 2 < n; i += 3) {
        uint32_t w = (uint8_t)bytes[i] << 16 | (uint8_t)bytes[i + 1] << 8 | (uint8_t)bytes[i + 2];
        for (int k = 3; k >= 0; k--) out += k_b64[(w >> (6 * k)) & 63];
    }
    if (i < n) {
        uint32_t w = (uint8_t)bytes[i] << 16 | (i + 1 < n ? (uint8_t)bytes[i + 1] << 8 : 0);
        out += k_b64[(w >> 18) & 63];
        out += k_b64[(w >> 12) & 63];
        out += i + 1 < n ? k_b64[(w >> 6) & 63] : '=';
        out += '=';
    }
    return out;
}

static bool rewrite_fallback_buffers(const unsigned char *json, size_t size, bool glb,
                                     uint64_t bin_len, std::string *out,
                                     std::vector<int> *dead_views, std::string *why,
                                     std::map<std::pair<int, int>, int> *zero_view_indices)
{
    static const char key[] = "EXT_meshopt_compression", draco[] = "KHR_draco_mesh_compression";
    nlohmann::json j;
    try {
        j = nlohmann::json::parse(json, json + size);
    } catch (const std::exception &) {
        return false; // reported by the normal parse
    }
    if (!j.is_object()) return false;
    bool changed = false;
    whole_floats_to_integers(j, &changed);
    const bool have_accessors = j.contains("accessors") && j["accessors"].is_array();
    if (j.contains("meshes") && j["meshes"].is_array())
        for (size_t mi = 0; mi < j["meshes"].size(); mi++) {
            auto &mesh = j["meshes"][mi];
            if (!mesh.is_object() || !mesh.contains("primitives") || !mesh["primitives"].is_array())
                continue;
            for (size_t pi = 0; pi < mesh["primitives"].size(); pi++) {
                auto &p = mesh["primitives"][pi];
                if (!p.is_object() || !p.contains("indices")) continue;
                if (p.contains("extensions") && p["extensions"].is_object() &&
                    p["extensions"].contains(draco)) {
                    p.erase("indices");
                    changed = true;
                    continue;
                }
                if (!p["indices"].is_number_unsigned() || !have_accessors) continue;
                size_t ai = p["indices"].get<size_t>();
                if (ai >= j["accessors"].size() || !j["accessors"][ai].is_object() ||
                    j["accessors"][ai].contains("bufferView"))
                    continue;
                (*zero_view_indices)[{(int)mi, (int)pi}] = (int)ai;
                p.erase("indices");
                changed = true;
            }
        }
    if (!j.contains("buffers") || !j["buffers"].is_array()) {
        if (changed) *out = j.dump();
        return changed;
    }
    std::vector<size_t> no_data; // .gltf buffers without uri (and not meshopt fallbacks)
    for (size_t bi = 0; bi < j["buffers"].size(); bi++) {
        auto &b = j["buffers"][bi];
        if (b.is_object() && b.contains("uri") && b["uri"].is_string()) {
            // A data URI without ";base64": its bytes percent-encoded (RFC 2397).
            std::string uri = b["uri"];
            size_t comma = uri.find(',');
            if (uri.compare(0, 5, "data:") != 0 || comma == std::string::npos ||
                uri.rfind(";base64", comma) != std::string::npos)
                continue;
            b["uri"] = "data:application/octet-stream;base64," + base64(uri_decode(uri.substr(comma + 1)));
            changed = true;
            continue;
        }
        if (!b.is_object() || b.contains("uri")) continue;
        const nlohmann::json *x = b.contains("extensions") ? &b["extensions"] : nullptr;
        bool fallback = x && x->is_object() && x->contains(key) && (*x)[key].is_object() &&
                        (*x)[key].contains("fallback") && (*x)[key]["fallback"] == true;
        if (!fallback && glb && bi == 0) { // the BIN chunk
            uint64_t want = b.contains("byteLength") && b["byteLength"].is_number_unsigned()
                                ? b["byteLength"].get<uint64_t>()
                                : 0;
            char msg[200];
            if (bin_len == 0)
                snprintf(msg, sizeof msg, "buffers[0]: has no uri, so its data is the GLB's BIN "
                                          "chunk, and the file has no BIN chunk");
            else if (want > bin_len)
                snprintf(msg, sizeof msg, "buffers[0]: byteLength %llu is more than the %llu "
                                          "bytes of the GLB's BIN chunk",
                         (unsigned long long)want, (unsigned long long)bin_len);
            else
                continue;
            *why = msg;
            return false;
        }
        if (!fallback) no_data.push_back(bi);
        b["uri"] = "data:application/octet-stream;base64,AAAAAA==";
        b["byteLength"] = 4;
        changed = true;
    }
    if (!no_data.empty() && j.contains("bufferViews") && j["bufferViews"].is_array())
        for (size_t vi = 0; vi < j["bufferViews"].size(); vi++) {
            auto &v = j["bufferViews"][vi];
            if (!v.is_object() || !v.contains("buffer") || !v["buffer"].is_number_unsigned()) continue;
            size_t bi = v["buffer"].get<size_t>();
            if (std::find(no_data.begin(), no_data.end(), bi) == no_data.end()) continue;
            v["byteOffset"] = 0;
            v["byteLength"] = 4;
            v.erase("byteStride");
            dead_views->push_back((int)vi);
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
        if (int r = check_json_depth(json, json_size)) return r;
        std::string fixed, why;
        uint32_t bin_len = 0; // the BIN chunk's length, checked above; 0: no BIN chunk
        if (json_end < length) memcpy(&bin_len, data + json_end, 4);
        bool rewritten =
            rewrite_fallback_buffers(json, json_size, true, bin_len, &fixed, &dead_views, &why,
                                     &zero_view_indices);
        if (!why.empty()) return bad("%s", why.c_str());
        if (rewritten) {
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
        if (int r = check_json_depth(data, size)) return r;
        std::string fixed, why;
        if (rewrite_fallback_buffers(data, size, false, 0, &fixed, &dead_views, &why,
                                     &zero_view_indices))
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
    // The library's "primitive indices accessor out of bounds" names no object.
    size_t n_acc = j.contains("accessors") && j["accessors"].is_array() ? j["accessors"].size() : 0;
    if (j.contains("meshes") && j["meshes"].is_array())
        for (size_t mi = 0; mi < j["meshes"].size(); mi++) {
            const auto &mesh = j["meshes"][mi];
            if (!mesh.is_object() || !mesh.contains("primitives") || !mesh["primitives"].is_array())
                continue;
            for (size_t pi = 0; pi < mesh["primitives"].size(); pi++) {
                const auto &p = mesh["primitives"][pi];
                if (p.is_object() && p.contains("indices") && p["indices"].is_number_unsigned() &&
                    p["indices"].get<size_t>() >= n_acc)
                    return bad("meshes[%zu].primitives[%zu].indices: accessors[%zu] does not exist "
                               "(the file has %zu accessors)",
                               mi, pi, p["indices"].get<size_t>(), n_acc);
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
    std::vector<std::string> missing, unknown, unknown_reported;
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
    for (const auto &x : m.extensionsUsed)
        for (const UnrenderedExt &u : k_unrendered_ext)
            if (x == u.name) {
                spt_warn("%s: %s is not rendered: %s", file, u.name, u.needs);
                unknown_reported.push_back(x);
            }
    for (const auto &x : m.extensionsUsed) {
        if (!supported(x) && !ignored(x) &&
            std::find(unknown_reported.begin(), unknown_reported.end(), x) == unknown_reported.end())
            unknown.push_back(x);
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
    *zeros = a.bufferView < 0 && !a.sparse.isSparse;
    if (a.bufferView < 0) return a.sparse.isSparse ? check_sparse(index, o) : 0;
    if ((size_t)a.bufferView >= m.bufferViews.size())
        return bad("%s (accessors[%d]): bufferViews[%d] does not exist", o, index, a.bufferView);
    if (int r = check_view_has_data(a.bufferView, o, index)) return r;
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
    return a.sparse.isSparse ? check_sparse(index, o) : 0;
}

// A buffer view an accessor reads must lie in a buffer with data (not one
// without uri in a .gltf: rewrite_fallback_buffers).
int Loader::check_view_has_data(int view, const char *o, int index)
{
    if (std::find(dead_views.begin(), dead_views.end(), view) == dead_views.end()) return 0;
    return bad("%s (accessors[%d]): bufferViews[%d] is in buffers[%d], which has no uri (no data)",
               o, index, view, m.bufferViews[view].buffer);
}

// An unsigned integer index of component type ct (1, 2 or 4 bytes) at p.
static uint32_t read_uint(const unsigned char *p, int ct)
{
    if (ct == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE) return p[0];
    if (ct == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT) {
        uint16_t u;
        memcpy(&u, p, 2);
        return u;
    }
    uint32_t u;
    memcpy(&u, p, 4);
    return u;
}

// The sparse part of a checked accessor (glTF 2.0 3.6.2.3): its count, the index
// component type, both ranges inside their buffer views (tightly packed), and
// indices strictly increasing below the accessor's count.
int Loader::check_sparse(int index, const char *o)
{
    const auto &a = m.accessors[index];
    const auto &s = a.sparse;
    if (s.count < 1 || (size_t)s.count > a.count)
        return bad("%s (accessors[%d]): sparse.count %d is not in 1..%zu", o, index, s.count,
                   a.count);
    int ict = s.indices.componentType;
    if (ict != TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE &&
        ict != TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT && ict != TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT)
        return bad("%s (accessors[%d]): sparse.indices.componentType %d is not an unsigned "
                   "byte, short or int", o, index, ict);
    uint64_t elem = (uint64_t)type_components(a.type) * (uint64_t)component_size(a.componentType);
    struct Part {
        const char *name;
        int view, offset;
        uint64_t bytes;
    } parts[2] = {{"indices", s.indices.bufferView, s.indices.byteOffset,
                   (uint64_t)s.count * (uint64_t)component_size(ict)},
                  {"values", s.values.bufferView, s.values.byteOffset, (uint64_t)s.count * elem}};
    for (const Part &pt : parts) {
        if (pt.view < 0 || (size_t)pt.view >= m.bufferViews.size())
            return bad("%s (accessors[%d]): sparse.%s.bufferView %d does not exist", o, index,
                       pt.name, pt.view);
        if (int r = check_view_has_data(pt.view, o, index)) return r;
        if (pt.offset < 0)
            return bad("%s (accessors[%d]): sparse.%s.byteOffset %d is negative", o, index,
                       pt.name, pt.offset);
        size_t len = m.bufferViews[pt.view].byteLength;
        if ((uint64_t)pt.offset > len || pt.bytes > len - (uint64_t)pt.offset)
            return bad("%s (accessors[%d]): sparse.%s: %llu bytes from byteOffset %d run past the "
                       "end of bufferViews[%d] (%zu bytes)", o, index, pt.name,
                       (unsigned long long)pt.bytes, pt.offset, pt.view, len);
    }
    const unsigned char *ip = sparse_data(a.sparse.indices.bufferView, a.sparse.indices.byteOffset);
    size_t isz = (size_t)component_size(ict);
    int64_t prev = -1;
    for (int i = 0; i < s.count; i++) {
        uint32_t k = read_uint(ip + (size_t)i * isz, ict);
        if ((int64_t)k <= prev || k >= a.count)
            return bad("%s (accessors[%d]): sparse.indices[%d] is %u: indices must increase and "
                       "stay below count %zu", o, index, i, k, a.count);
        prev = k;
    }
    return 0;
}

const unsigned char *Loader::sparse_data(int view, int offset) const
{
    const auto &bv = m.bufferViews[view];
    return m.buffers[bv.buffer].data.data() + bv.byteOffset + (size_t)offset;
}

// One component of type ct at p as a float, as glTF 2.0 3.11 maps normalised
// integers (max(c / 127, -1) for signed ones); plain integers
// (KHR_mesh_quantization) as their values.
static float decode_component(const unsigned char *p, int ct, bool normalized)
{
    switch (ct) {
    case TINYGLTF_COMPONENT_TYPE_FLOAT: {
        float v;
        memcpy(&v, p, 4);
        return v;
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE:
        return normalized ? (float)p[0] / 255.0f : (float)p[0];
    case TINYGLTF_COMPONENT_TYPE_BYTE: {
        int8_t b;
        memcpy(&b, p, 1);
        return normalized ? fmaxf((float)b / 127.0f, -1.0f) : (float)b;
    }
    case TINYGLTF_COMPONENT_TYPE_SHORT: {
        int16_t h;
        memcpy(&h, p, 2);
        return normalized ? fmaxf((float)h / 32767.0f, -1.0f) : (float)h;
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
        uint16_t u;
        memcpy(&u, p, 2);
        return normalized ? (float)u / 65535.0f : (float)u;
    }
    default: { // UNSIGNED_INT (not allowed for attributes, kept total)
        uint32_t u;
        memcpy(&u, p, 4);
        return (float)u;
    }
    }
}

// Reads a checked accessor as floats (decode_component), then its sparse
// substitutions over them.
int Loader::read_floats(int index, int ncomp, std::vector<float> &out)
{
    const auto &a = m.accessors[index];
    out.assign(a.count * (size_t)ncomp, 0.0f);
    size_t cs = (size_t)component_size(a.componentType);
    if (a.bufferView >= 0) {
        const auto &bv = m.bufferViews[a.bufferView];
        const unsigned char *base = m.buffers[bv.buffer].data.data() + bv.byteOffset + a.byteOffset;
        size_t stride = bv.byteStride ? bv.byteStride : cs * (size_t)ncomp;
        for (size_t i = 0; i < a.count; i++)
            for (int c = 0; c < ncomp; c++)
                out[i * (size_t)ncomp + (size_t)c] =
                    decode_component(base + i * stride + (size_t)c * cs, a.componentType, a.normalized);
    }
    if (a.sparse.isSparse) {
        const auto &s = a.sparse;
        const unsigned char *ip = sparse_data(s.indices.bufferView, s.indices.byteOffset);
        const unsigned char *vp = sparse_data(s.values.bufferView, s.values.byteOffset);
        size_t isz = (size_t)component_size(s.indices.componentType);
        for (int i = 0; i < s.count; i++) {
            size_t k = read_uint(ip + (size_t)i * isz, s.indices.componentType);
            for (int c = 0; c < ncomp; c++)
                out[k * (size_t)ncomp + (size_t)c] = decode_component(
                    vp + ((size_t)i * (size_t)ncomp + (size_t)c) * cs, a.componentType, a.normalized);
        }
    }
    return 0;
}

int Loader::read_indices(int index, std::vector<uint32_t> &out)
{
    const auto &a = m.accessors[index];
    out.assign(a.count, 0);
    if (a.bufferView >= 0) {
        const auto &bv = m.bufferViews[a.bufferView];
        const unsigned char *base = m.buffers[bv.buffer].data.data() + bv.byteOffset + a.byteOffset;
        size_t cs = (size_t)component_size(a.componentType);
        size_t stride = bv.byteStride ? bv.byteStride : cs;
        for (size_t i = 0; i < a.count; i++) out[i] = read_uint(base + i * stride, a.componentType);
    }
    if (a.sparse.isSparse) {
        const auto &s = a.sparse;
        const unsigned char *ip = sparse_data(s.indices.bufferView, s.indices.byteOffset);
        const unsigned char *vp = sparse_data(s.values.bufferView, s.values.byteOffset);
        size_t isz = (size_t)component_size(s.indices.componentType);
        size_t vsz = (size_t)component_size(a.componentType);
        for (int i = 0; i < s.count; i++)
            out[read_uint(ip + (size_t)i * isz, s.indices.componentType)] =
                read_uint(vp + (size_t)i * vsz, a.componentType);
    }
    return 0;
}

} // namespace spt_gltf
