// The glTF loader's materials and textures: metallic-roughness with its
// extensions, the spectral extras, texture references and image decoding.
#include "scene/gltf_loader.h"

namespace spt_gltf {

// Conductors the spectral extras may name (complex IOR tables in the renderer).
const char *const k_conductors[] = {"Au", "Ag", "Al", "Cu"};


// A number property of an extension object: absent leaves *out unchanged.
static int ext_number(Loader *L, const Value &o, const char *key, double *out, const std::string &obj)
{
    if (!o.IsObject() || !o.Has(key)) return 0;
    const Value &v = o.Get(key);
    if (!v.IsNumber() || !std::isfinite(v.GetNumberAsDouble()))
        return L->bad("%s.%s: not a number", obj.c_str(), key);
    *out = v.GetNumberAsDouble();
    return 0;
}

// A value the glTF specification (or the extension's schema) bounds to [lo, hi]:
// one outside is refused, naming it, rather than clamped (a clearcoatFactor of
// -1 clamped to 0 gave a black image without a word). key may carry an index.
static int in_range(Loader *L, const std::string &obj, const std::string &key, double v, double lo,
                    double hi)
{
    if (v >= lo && v <= hi) return 0;
    return L->bad("%s.%s: %g is outside [%g, %g], the range the glTF specification allows",
                  obj.c_str(), key.c_str(), v, lo, hi);
}

// An array of n numbers, each in [lo, hi], into out (absent: out unchanged).
static int ranged_array(Loader *L, const Value &x, const char *key, int n, double lo, double hi,
                        const std::string &obj, double *out)
{
    if (!x.IsObject() || !x.Has(key)) return 0;
    const Value &c = x.Get(key);
    if (!c.IsArray() || (int)c.ArrayLen() != n)
        return L->bad("%s.%s: expected %d numbers", obj.c_str(), key, n);
    for (int k = 0; k < n; k++) {
        if (!c.Get(k).IsNumber() || !std::isfinite(c.Get(k).GetNumberAsDouble()))
            return L->bad("%s.%s: not a number", obj.c_str(), key);
        double v = c.Get(k).GetNumberAsDouble();
        if (int rc = in_range(L, obj, std::string(key) + "[" + std::to_string(k) + "]", v, lo, hi))
            return rc;
        out[k] = v;
    }
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
    mem_used_textures += (double)ti.width * ti.height * ti.channels * sizeof(float);
    if ((over_budget_rc = charge_memory("images[" + std::to_string(image) + "]"))) return 0;
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
    if (!decode_image(source)) return over_budget_rc;
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

// A light's spectral extras: extras.spectrace.emission, the shape of its
// spectrum (named or inline alike; the intensity sets the level when the light
// is built, render/host_lights.h).
int Loader::light_extras(const Value &extras, SceneLight *sl, const std::string &obj)
{
    if (!extras.IsObject() || !extras.Has("spectrace")) return 0;
    const Value &sp = extras.Get("spectrace");
    std::string o = obj + ".extras.spectrace";
    if (!sp.IsObject()) return bad("%s: expected an object", o.c_str());
    for (const auto &k : sp.Keys())
        if (k != "emission")
            return bad("%s: unknown key '%s' (expected emission)", o.c_str(), k.c_str());
    if (!sp.Has("emission")) return 0;
    int rc;
    if ((rc = parse_spd(sp.Get("emission"), &sl->spd, o + ".emission"))) return rc;
    double xyz[3];
    spd_to_xyz(&sl->spd, xyz);
    if (!(xyz[1] > 0)) {
        spd_free(&sl->spd);
        return bad("%s.emission: the SPD has no luminance (nothing visible in 360-830 nm), so "
                   "no level gives the light its intensity", o.c_str());
    }
    return 0;
}

// Perceived brightness of a linear RGB colour, as in the conversion below.
static double perceived_brightness(const double c[3])
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
    int rc;
    for (const auto &a : arrays)
        if ((rc = ranged_array(this, x, a.key, a.n, 0, 1, obj, a.v))) return rc;
    if ((rc = ext_number(this, x, "glossinessFactor", &gloss, obj)) ||
        (rc = in_range(this, obj, "glossinessFactor", gloss, 0, 1)))
        return rc;
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
// The core of a material: pbrMetallicRoughness's factors and textures, the
// normal, occlusion and emissive textures, the emissive factor and the alpha mode.
int Loader::material_core(const tinygltf::Material &mat, SceneMaterial *sm, const std::string &obj)
{
    const char *o = obj.c_str();
    const auto &pbr = mat.pbrMetallicRoughness;
    if (pbr.baseColorFactor.size() != 4)
        return bad("%s.pbrMetallicRoughness.baseColorFactor: expected 4 numbers", o);
    int rc;
    const std::string po = obj + ".pbrMetallicRoughness";
    for (int k = 0; k < 4; k++) {
        if ((rc = in_range(this, po, "baseColorFactor[" + std::to_string(k) + "]",
                           pbr.baseColorFactor[k], 0, 1)))
            return rc;
        sm->base_color[k] = (float)pbr.baseColorFactor[k];
    }
    if ((rc = in_range(this, po, "metallicFactor", pbr.metallicFactor, 0, 1)) ||
        (rc = in_range(this, po, "roughnessFactor", pbr.roughnessFactor, 0, 1)) ||
        (rc = in_range(this, obj, "occlusionTexture.strength", mat.occlusionTexture.strength, 0, 1)))
        return rc;
    sm->metallic = (float)pbr.metallicFactor;
    sm->roughness = (float)pbr.roughnessFactor;
    if ((rc = texture_ref(pbr.baseColorTexture.index, pbr.baseColorTexture.texCoord, true,
                          obj + ".pbrMetallicRoughness.baseColorTexture", &sm->tex[SPT_SLOT_BASE],
                          &pbr.baseColorTexture.extensions)) ||
        (rc = texture_ref(pbr.metallicRoughnessTexture.index,
                          pbr.metallicRoughnessTexture.texCoord, false,
                          obj + ".pbrMetallicRoughness.metallicRoughnessTexture",
                          &sm->tex[SPT_SLOT_METALLIC_ROUGHNESS], &pbr.metallicRoughnessTexture.extensions)) ||
        (rc = texture_ref(mat.emissiveTexture.index, mat.emissiveTexture.texCoord, true,
                          obj + ".emissiveTexture", &sm->tex[SPT_SLOT_EMISSIVE],
                          &mat.emissiveTexture.extensions)) ||
        (rc = texture_ref(mat.normalTexture.index, mat.normalTexture.texCoord, false,
                          obj + ".normalTexture", &sm->tex[SPT_SLOT_NORMAL], &mat.normalTexture.extensions)) ||
        (rc = texture_ref(mat.occlusionTexture.index, mat.occlusionTexture.texCoord, false,
                          obj + ".occlusionTexture", &sm->tex[SPT_SLOT_OCCLUSION],
                          &mat.occlusionTexture.extensions, false)))
        return rc;
    sm->normal_scale = (float)mat.normalTexture.scale;
    if (!mat.emissiveFactor.empty()) {
        if (mat.emissiveFactor.size() != 3) return bad("%s.emissiveFactor: expected 3 numbers", o);
        for (int k = 0; k < 3; k++) {
            if ((rc = in_range(this, obj, "emissiveFactor[" + std::to_string(k) + "]",
                               mat.emissiveFactor[k], 0, 1)))
                return rc;
            sm->emissive[k] = (float)mat.emissiveFactor[k];
        }
    }
    if (mat.alphaMode == "OPAQUE")
        sm->alpha_mode = SPT_ALPHA_OPAQUE;
    else if (mat.alphaMode == "MASK")
        sm->alpha_mode = SPT_ALPHA_MASK;
    else if (mat.alphaMode == "BLEND")
        sm->alpha_mode = SPT_ALPHA_BLEND;
    else
        return bad("%s.alphaMode: '%s' is not OPAQUE, MASK or BLEND", o, mat.alphaMode.c_str());
    if (!(mat.alphaCutoff >= 0)) return bad("%s.alphaCutoff: %g is negative", o, mat.alphaCutoff);
    sm->alpha_cutoff = (float)mat.alphaCutoff;
    sm->double_sided = mat.doubleSided ? 1 : 0;
    return 0;
}

// KHR_materials_emissive_strength, _ior, _transmission and _dispersion: a
// number each (and the transmission texture). eo: "materials[i].extensions.".
int Loader::material_ext_scalars(const tinygltf::Material &mat, SceneMaterial *sm, const std::string &eo)
{
    auto ext = [&](const char *name) -> const Value * {
        auto it = mat.extensions.find(name);
        return it == mat.extensions.end() ? nullptr : &it->second;
    };
    double d;
    int rc;
    if (const Value *x = ext("KHR_materials_emissive_strength")) {
        d = 1;
        if ((rc = ext_number(this, *x, "emissiveStrength", &d, eo + "KHR_materials_emissive_strength")))
            return rc;
        if (d < 0) return bad("%sKHR_materials_emissive_strength: negative strength", eo.c_str());
        if (d > SPT_MAX_INPUT_VALUE)
            return bad("%sKHR_materials_emissive_strength: %g is above 1e30, more than the "
                       "renderer's float arithmetic can carry", eo.c_str(), d);
        sm->emissive_strength = (float)d;
    }
    if (const Value *x = ext("KHR_materials_ior")) {
        d = 1.5;
        if ((rc = ext_number(this, *x, "ior", &d, eo + "KHR_materials_ior"))) return rc;
        if (d < 1 && d != 0) return bad("%sKHR_materials_ior.ior: %g is below 1", eo.c_str(), d);
        sm->ior = (float)d;
    }
    if (const Value *x = ext("KHR_materials_transmission")) {
        d = 0;
        if ((rc = ext_number(this, *x, "transmissionFactor", &d, eo + "KHR_materials_transmission")))
            return rc;
        if ((rc = in_range(this, eo + "KHR_materials_transmission", "transmissionFactor", d, 0, 1)))
            return rc;
        sm->transmission = (float)d;
        if ((rc = ext_texture(*x, "transmissionTexture", false, eo + "KHR_materials_transmission",
                              &sm->tex[SPT_SLOT_TRANSMISSION])))
            return rc;
    }
    if (const Value *x = ext("KHR_materials_dispersion")) {
        d = 0;
        if ((rc = ext_number(this, *x, "dispersion", &d, eo + "KHR_materials_dispersion")))
            return rc;
        if (d < 0) return bad("%sKHR_materials_dispersion.dispersion: negative", eo.c_str());
        sm->dispersion = (float)d;
    }
    return 0;
}

// KHR_materials_volume: thickness, attenuation distance and colour.
int Loader::material_ext_volume(const Value *x, SceneMaterial *sm, const std::string &vo)
{
    double d = 0;
    int rc;
    if ((rc = ext_number(this, *x, "thicknessFactor", &d, vo))) return rc;
    if (d < 0) return bad("%s.thicknessFactor: negative", vo.c_str());
    sm->thickness = (float)d;
    d = 0;
    if ((rc = ext_number(this, *x, "attenuationDistance", &d, vo))) return rc;
    if (x->Has("attenuationDistance") && !(d > 0))
        return bad("%s.attenuationDistance: must be > 0", vo.c_str());
    sm->attenuation_distance = (float)d;
    double ac[3] = {1, 1, 1};
    if ((rc = ranged_array(this, *x, "attenuationColor", 3, 0, 1, vo, ac))) return rc;
    if (x->Has("attenuationColor"))
        for (int k = 0; k < 3; k++) sm->attenuation_color[k] = (float)ac[k];
    return 0;
}

// KHR_materials_specular: the factor, the colour factor and their textures.
int Loader::material_ext_specular(const Value *x, SceneMaterial *sm, const std::string &so)
{
    double d = 1;
    int rc;
    if ((rc = ext_number(this, *x, "specularFactor", &d, so))) return rc;
    if ((rc = in_range(this, so, "specularFactor", d, 0, 1))) return rc;
    sm->specular = (float)d;
    if (x->Has("specularColorFactor")) {
        const Value &c = x->Get("specularColorFactor");
        if (!c.IsArray() || c.ArrayLen() != 3)
            return bad("%s.specularColorFactor: expected 3 numbers", so.c_str());
        for (int k = 0; k < 3; k++) {
            if (!c.Get(k).IsNumber()) return bad("%s.specularColorFactor: not a number", so.c_str());
            double v = c.Get(k).GetNumberAsDouble();
            if (!(v >= 0) || !std::isfinite(v))
                return bad("%s.specularColorFactor: must be finite and >= 0", so.c_str());
            sm->specular_color[k] = (float)v;
        }
    }
    if ((rc = ext_texture(*x, "specularTexture", false, so, &sm->tex[SPT_SLOT_SPECULAR])) ||
        (rc = ext_texture(*x, "specularColorTexture", true, so, &sm->tex[SPT_SLOT_SPECULAR_COLOR])))
        return rc;
    return 0;
}

// KHR_materials_clearcoat: the coat's factor and roughness, their textures and
// its own normal texture.
int Loader::material_ext_clearcoat(const Value *x, SceneMaterial *sm, const std::string &co)
{
    double cc = 0, cr = 0;
    int rc;
    if ((rc = ext_number(this, *x, "clearcoatFactor", &cc, co)) ||
        (rc = ext_number(this, *x, "clearcoatRoughnessFactor", &cr, co)))
        return rc;
    if ((rc = in_range(this, co, "clearcoatFactor", cc, 0, 1)) ||
        (rc = in_range(this, co, "clearcoatRoughnessFactor", cr, 0, 1)))
        return rc;
    sm->clearcoat = (float)cc;
    sm->clearcoat_roughness = (float)cr;
    if ((rc = ext_texture(*x, "clearcoatTexture", false, co, &sm->tex[SPT_SLOT_CLEARCOAT])) ||
        (rc = ext_texture(*x, "clearcoatRoughnessTexture", false, co,
                          &sm->tex[SPT_SLOT_CLEARCOAT_ROUGHNESS])) ||
        (rc = ext_texture(*x, "clearcoatNormalTexture", false, co, &sm->tex[SPT_SLOT_CLEARCOAT_NORMAL],
                          &sm->clearcoat_normal_scale)))
        return rc;
    return 0;
}

// KHR_materials_sheen: the sheen colour and roughness and their textures.
int Loader::material_ext_sheen(const Value *x, SceneMaterial *sm, const std::string &sho)
{
    int rc;
    double sc[3];
    if ((rc = ranged_array(this, *x, "sheenColorFactor", 3, 0, 1, sho, sc))) return rc;
    if (x->Has("sheenColorFactor"))
        for (int k = 0; k < 3; k++) sm->sheen_color[k] = (float)sc[k];
    double sr = 0;
    if ((rc = ext_number(this, *x, "sheenRoughnessFactor", &sr, sho)) ||
        (rc = in_range(this, sho, "sheenRoughnessFactor", sr, 0, 1)))
        return rc;
    sm->sheen_roughness = (float)sr;
    if ((rc = ext_texture(*x, "sheenColorTexture", true, sho, &sm->tex[SPT_SLOT_SHEEN_COLOR])) ||
        (rc = ext_texture(*x, "sheenRoughnessTexture", false, sho, &sm->tex[SPT_SLOT_SHEEN_ROUGHNESS])))
        return rc;
    return 0;
}

// KHR_materials_iridescence: the factor, the film's index, its thickness range
// (nm) and the two textures, bounded as the extension's schema bounds them.
int Loader::material_ext_iridescence(const Value *x, SceneMaterial *sm, const std::string &io)
{
    double f = 0, n = 1.3, lo = 100, hi = 400;
    int rc;
    if ((rc = ext_number(this, *x, "iridescenceFactor", &f, io)) ||
        (rc = ext_number(this, *x, "iridescenceIor", &n, io)) ||
        (rc = ext_number(this, *x, "iridescenceThicknessMinimum", &lo, io)) ||
        (rc = ext_number(this, *x, "iridescenceThicknessMaximum", &hi, io)))
        return rc;
    if ((rc = in_range(this, io, "iridescenceFactor", f, 0, 1))) return rc;
    if (!(n >= 1)) return bad("%s.iridescenceIor: %g is below 1", io.c_str(), n);
    if (!(lo >= 0)) return bad("%s.iridescenceThicknessMinimum: %g is negative", io.c_str(), lo);
    if (!(hi >= 0)) return bad("%s.iridescenceThicknessMaximum: %g is negative", io.c_str(), hi);
    if (n > SPT_MAX_INPUT_VALUE || lo > SPT_MAX_INPUT_VALUE || hi > SPT_MAX_INPUT_VALUE)
        return bad("%s: a value above 1e30, more than the renderer's float arithmetic can carry", io.c_str());
    sm->iridescence = (float)f;
    sm->iridescence_ior = (float)n;
    sm->iridescence_min_nm = (float)lo;
    sm->iridescence_max_nm = (float)hi;
    if ((rc = ext_texture(*x, "iridescenceTexture", false, io, &sm->tex[SPT_SLOT_IRIDESCENCE])) ||
        (rc = ext_texture(*x, "iridescenceThicknessTexture", false, io,
                          &sm->tex[SPT_SLOT_IRIDESCENCE_THICKNESS])))
        return rc;
    return 0;
}

// KHR_materials_anisotropy: the strength, the rotation (radians, any number) and the texture (RG direction, B strength; linear).
int Loader::material_ext_anisotropy(const Value *x, SceneMaterial *sm, const std::string &ao)
{
    double st = 0, rot = 0;
    int rc;
    if ((rc = ext_number(this, *x, "anisotropyStrength", &st, ao)) ||
        (rc = in_range(this, ao, "anisotropyStrength", st, 0, 1)) ||
        (rc = ext_number(this, *x, "anisotropyRotation", &rot, ao)))
        return rc;
    sm->anisotropy = (float)st;
    sm->anisotropy_rotation = (float)rot;
    return ext_texture(*x, "anisotropyTexture", false, ao, &sm->tex[SPT_SLOT_ANISOTROPY]);
}

// KHR_materials_diffuse_transmission: the factor, the colour and their textures.
int Loader::material_ext_diffuse_transmission(const Value *x, SceneMaterial *sm, const std::string &dto)
{
    double f = 0, c[3];
    int rc;
    if ((rc = ext_number(this, *x, "diffuseTransmissionFactor", &f, dto)) ||
        (rc = in_range(this, dto, "diffuseTransmissionFactor", f, 0, 1)) ||
        (rc = ranged_array(this, *x, "diffuseTransmissionColorFactor", 3, 0, 1, dto, c)))
        return rc;
    sm->diffuse_transmission = (float)f;
    if (x->Has("diffuseTransmissionColorFactor"))
        for (int k = 0; k < 3; k++) sm->diffuse_transmission_color[k] = (float)c[k];
    if ((rc = ext_texture(*x, "diffuseTransmissionTexture", false, dto,
                          &sm->tex[SPT_SLOT_DIFFUSE_TRANSMISSION])) ||
        (rc = ext_texture(*x, "diffuseTransmissionColorTexture", true, dto,
                          &sm->tex[SPT_SLOT_DIFFUSE_TRANSMISSION_COLOR])))
        return rc;
    return 0;
}

// Every extension of a material, in this order: the scalar ones, volume,
// specular, clearcoat, sheen, iridescence, anisotropy, diffuse transmission,
// unlit, spec-gloss; the ones we ignore are noted.
int Loader::material_extensions(const tinygltf::Material &mat, SceneMaterial *sm, const std::string &obj)
{
    auto ext = [&](const char *name) -> const Value * {
        auto it = mat.extensions.find(name);
        return it == mat.extensions.end() ? nullptr : &it->second;
    };
    std::string eo = obj + ".extensions.";
    int rc;
    if ((rc = material_ext_scalars(mat, sm, eo))) return rc;
    if (const Value *x = ext("KHR_materials_volume"))
        if ((rc = material_ext_volume(x, sm, eo + "KHR_materials_volume"))) return rc;
    if (const Value *x = ext("KHR_materials_specular"))
        if ((rc = material_ext_specular(x, sm, eo + "KHR_materials_specular"))) return rc;
    if (const Value *x = ext("KHR_materials_clearcoat"))
        if ((rc = material_ext_clearcoat(x, sm, eo + "KHR_materials_clearcoat"))) return rc;
    if (const Value *x = ext("KHR_materials_sheen"))
        if ((rc = material_ext_sheen(x, sm, eo + "KHR_materials_sheen"))) return rc;
    if (const Value *x = ext("KHR_materials_iridescence"))
        if ((rc = material_ext_iridescence(x, sm, eo + "KHR_materials_iridescence"))) return rc;
    if (const Value *x = ext("KHR_materials_anisotropy"))
        if ((rc = material_ext_anisotropy(x, sm, eo + "KHR_materials_anisotropy"))) return rc;
    if (const Value *x = ext("KHR_materials_diffuse_transmission"))
        if ((rc = material_ext_diffuse_transmission(x, sm, eo + "KHR_materials_diffuse_transmission")))
            return rc;
    if (ext("KHR_materials_unlit")) sm->unlit = 1;
    if (const Value *x = ext("KHR_materials_pbrSpecularGlossiness"))
        if ((rc = spec_gloss(*x, sm, eo + "KHR_materials_pbrSpecularGlossiness"))) return rc;
    for (const char *ig : k_ignored_material_ext)
        if (ext(ig)) ignored_ext[ig].push_back(sm->name);
    return 0;
}

// Material index: its core, its extensions and its spectral extras, in that
// order; appended to mats. Returns its index, or minus an exit code.
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
    int rc;
    if ((rc = material_core(mat, &sm, obj)) || (rc = material_extensions(mat, &sm, obj)))
        return -rc;
    if ((rc = spectral_extras(mat.extras, &sm, obj))) {
        spd_free(&sm.emission_spd);
        spd_free(&sm.reflectance_spd);
        return -rc;
    }
    mats.push_back(sm);
    return (int)mats.size() - 1;
}

} // namespace spt_gltf
