// The glTF loader's checks of the JSON text before the glTF library parses it:
// nesting depth, and whole-number indices, counts and offsets in range.
#include "scene/gltf_loader.h"

namespace spt_gltf {

// The deepest nesting of arrays and objects in JSON text (strings skipped), up to
// just past limit, and the byte offset where it went past. The glTF library turns
// JSON into values recursively, so text nested thousands deep would overflow the
// stack: it is refused before the library sees it.
static int json_depth_over(const unsigned char *json, size_t size, int limit, size_t *where)
{
    int depth = 0;
    bool in_string = false;
    for (size_t i = 0; i < size; i++) {
        unsigned char c = json[i];
        if (in_string) {
            if (c == '\\') i++;
            else if (c == '"') in_string = false;
        } else if (c == '"') {
            in_string = true;
        } else if (c == '[' || c == '{') {
            if (++depth > limit) {
                *where = i;
                return depth;
            }
        } else if (c == ']' || c == '}') {
            depth--;
        }
    }
    return 0;
}

int Loader::check_json_depth(const unsigned char *json, size_t size)
{
    size_t where = 0;
    if (json_depth_over(json, size, k_max_json_depth, &where))
        return bad("JSON nested more than %d arrays and objects deep (at byte %zu); refused",
                   k_max_json_depth, where);
    return check_json_numbers(json, size);
}

namespace {

// The checks of check_json_numbers: each property that holds an index, an offset
// or a length must be a whole number in range. The glTF library reads such
// values as int or size_t, so "0", 0.5 or 2^64 became 0 or -1 (a mesh silently
// dropped), 2147483648 became -2147483648 and -12 a huge offset.
struct NumberCheck {
    std::string msg;

    // o[key] (when present) is a whole number in [lo, hi]; path names o.
    bool whole(const nlohmann::json &o, const char *key, const std::string &path, long long lo,
               long long hi, const char *what)
    {
        if (!msg.empty() || !o.is_object() || !o.contains(key)) return msg.empty();
        const nlohmann::json &v = o[key];
        // 1.0 or 1e0 is the number 1 (JSON does not tell them apart; the parse
        // rewrites such numbers as integers for the glTF library).
        double d = v.is_number() ? v.get<double>() : NAN;
        bool ok = v.is_number_integer()
                      ? (v.is_number_unsigned()
                             ? v.get<unsigned long long>() <= (unsigned long long)hi
                             : v.get<long long>() >= lo && v.get<long long>() <= hi)
                      : v.is_number_float() && d == floor(d) && d >= (double)lo && d <= (double)hi;
        if (!ok)
            msg = path + "." + key + ": " + v.dump().substr(0, 40) + " is not " + what;
        return ok;
    }
    bool index(const nlohmann::json &o, const char *key, const std::string &path)
    {
        return whole(o, key, path, 0, INT_MAX, "an index (a whole number from 0 to 2147483647)");
    }
    bool size(const nlohmann::json &o, const char *key, const std::string &path)
    {
        return whole(o, key, path, 0, (1ll << 53),
                     "a byte count (a whole number from 0 to 2^53)");
    }
    // Every element of o[key] (an array) is an index.
    void index_array(const nlohmann::json &o, const char *key, const std::string &path)
    {
        if (!msg.empty() || !o.is_object() || !o.contains(key) || !o[key].is_array()) return;
        const auto &a = o[key];
        for (size_t i = 0; i < a.size() && msg.empty(); i++) {
            nlohmann::json wrap = {{"v", a[i]}};
            if (!whole(wrap, "v", path, 0, INT_MAX, "an index (a whole number from 0 to 2147483647)"))
                msg = path + "." + key + "[" + std::to_string(i) + "]" + msg.substr(msg.find(':'));
        }
    }
    // Texture references anywhere inside a material: "index" and "texCoord".
    void texture_refs(const nlohmann::json &v, const std::string &path)
    {
        if (!msg.empty()) return;
        if (v.is_object()) {
            if (v.contains("index") && (v.contains("texCoord") || path.find("Texture") != std::string::npos))
                index(v, "index", path), whole(v, "texCoord", path, 0, INT_MAX, "a whole number >= 0");
            for (auto it = v.begin(); it != v.end() && msg.empty(); ++it)
                if (it.key() != "extras") texture_refs(it.value(), path + "." + it.key());
        } else if (v.is_array()) {
            for (size_t i = 0; i < v.size() && msg.empty(); i++)
                texture_refs(v[i], path + "[" + std::to_string(i) + "]");
        }
    }
    // Inside a material (not its extras), each factor and each of alphaCutoff,
    // scale, strength, ior, dispersion, attenuationDistance, emissiveStrength,
    // rotation is a number or an array of numbers: the glTF library put its
    // default in place of any other value.
    void numbers(const nlohmann::json &v, const std::string &path)
    {
        if (!msg.empty() || !v.is_object()) return;
        static const char *const k_keys[] = {"alphaCutoff", "scale", "strength", "ior",
                                             "dispersion", "attenuationDistance",
                                             "emissiveStrength", "rotation"};
        for (auto it = v.begin(); it != v.end() && msg.empty(); ++it) {
            const std::string &k = it.key();
            if (k == "extras") continue;
            bool numeric = k.size() > 6 && k.compare(k.size() - 6, 6, "Factor") == 0;
            for (const char *n : k_keys) numeric |= k == n;
            const auto &x = it.value();
            bool ok = x.is_number();
            if (x.is_array()) {
                ok = true;
                for (const auto &e : x) ok &= e.is_number();
            }
            if (numeric && !ok)
                msg = path + "." + k + ": " + x.dump().substr(0, 40) + " is not a number" +
                      (x.is_array() ? " array" : "");
            else if (x.is_object())
                numbers(x, path + "." + k);
        }
    }
    // Calls f(element, "name[i]") for every object in j[name].
    template <class F> void each(const nlohmann::json &j, const char *name, F f)
    {
        if (!j.contains(name) || !j[name].is_array()) return;
        for (size_t i = 0; i < j[name].size() && msg.empty(); i++)
            f(j[name][i], std::string(name) + "[" + std::to_string(i) + "]");
    }
};

} // namespace

int Loader::check_json_numbers(const unsigned char *json, size_t size)
{
    nlohmann::json j;
    try {
        j = nlohmann::json::parse(json, json + size);
    } catch (const std::exception &) {
        return 0; // reported by the normal parse
    }
    if (!j.is_object()) return 0;
    NumberCheck c;
    c.index(j, "scene", "the file");
    if (!c.msg.empty()) return bad("scene: %s", c.msg.substr(c.msg.find(':') + 2).c_str());
    c.each(j, "scenes", [&](const nlohmann::json &s, const std::string &p) { c.index_array(s, "nodes", p); });
    c.each(j, "nodes", [&](const nlohmann::json &n, const std::string &p) {
        c.index(n, "mesh", p), c.index(n, "camera", p), c.index(n, "skin", p);
        c.index_array(n, "children", p);
        if (n.is_object() && n.contains("extensions") && n["extensions"].is_object() &&
            n["extensions"].contains("KHR_lights_punctual"))
            c.index(n["extensions"]["KHR_lights_punctual"], "light",
                    p + ".extensions.KHR_lights_punctual");
    });
    c.each(j, "meshes", [&](const nlohmann::json &m, const std::string &p) {
        c.each(m, "primitives", [&](const nlohmann::json &q, const std::string &pp) {
            std::string o = p + "." + pp;
            c.index(q, "indices", o), c.index(q, "material", o);
            c.whole(q, "mode", o, 0, 6, "a primitive mode (0 to 6)");
            if (q.is_object() && q.contains("attributes") && q["attributes"].is_object())
                for (auto it = q["attributes"].begin(); it != q["attributes"].end(); ++it) {
                    nlohmann::json wrap = {{it.key(), it.value()}};
                    c.index(wrap, it.key().c_str(), o + ".attributes");
                }
        });
    });
    c.each(j, "accessors", [&](const nlohmann::json &a, const std::string &p) {
        c.index(a, "bufferView", p), c.size(a, "byteOffset", p), c.size(a, "count", p);
        if (a.is_object() && a.contains("sparse") && a["sparse"].is_object()) {
            const auto &s = a["sparse"];
            c.size(s, "count", p + ".sparse");
            for (const char *part : {"indices", "values"})
                if (s.contains(part))
                    c.index(s[part], "bufferView", p + ".sparse." + part),
                        c.size(s[part], "byteOffset", p + ".sparse." + part);
        }
    });
    c.each(j, "bufferViews", [&](const nlohmann::json &v, const std::string &p) {
        c.index(v, "buffer", p), c.size(v, "byteOffset", p), c.size(v, "byteLength", p);
        if (c.msg.empty() && v.is_object() && v.contains("byteStride") &&
            !(v["byteStride"].is_number_integer() && v["byteStride"].get<long long>() >= 4 &&
              v["byteStride"].get<long long>() <= 252 && v["byteStride"].get<long long>() % 4 == 0))
            c.msg = p + ".byteStride: " + v["byteStride"].dump().substr(0, 40) +
                    " is not a multiple of 4 in 4..252";
    });
    c.each(j, "buffers", [&](const nlohmann::json &b, const std::string &p) { c.size(b, "byteLength", p); });
    c.each(j, "textures", [&](const nlohmann::json &t, const std::string &p) {
        c.index(t, "source", p), c.index(t, "sampler", p);
    });
    c.each(j, "images", [&](const nlohmann::json &im, const std::string &p) { c.index(im, "bufferView", p); });
    // Sampler filters and wraps are integer enums; the glTF library ignored any
    // other value ("NEAREST" as a string meant the default, linear). Which
    // integers are allowed is checked where they are used (texture_ref).
    c.each(j, "samplers", [&](const nlohmann::json &sp, const std::string &p) {
        for (const char *k : {"magFilter", "minFilter", "wrapS", "wrapT"})
            c.whole(sp, k, p, 0, INT_MAX, "a glTF enum number (such as 9728 for NEAREST)");
    });
    c.each(j, "materials", [&](const nlohmann::json &m, const std::string &p) { c.numbers(m, p); });
    c.each(j, "materials", [&](const nlohmann::json &m, const std::string &p) { c.texture_refs(m, p); });
    if (!c.msg.empty()) return bad("%s", c.msg.c_str());
    return 0;
}

} // namespace spt_gltf
