// The glTF loader's geometry: primitives read (plain, quantized, meshopt or
// Draco compressed) and flattened into world-space triangles per instance.
#include "scene/gltf_loader.h"

namespace spt_gltf {

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
        // NORMAL (VEC3) and TANGENT (VEC4, glTF 2.0 3.7.2.1): floats, or with
        // KHR_mesh_quantization normalised signed bytes or shorts.
        auto nit = p.attributes.find("NORMAL"), tit = p.attributes.find("TANGENT");
        const struct {
            decltype(nit) it;
            const char *name;
            int ncomp;
        } dirs[2] = {{nit, "NORMAL", 3}, {tit, "TANGENT", 4}};
        for (const auto &d : dirs) {
            if (d.it == p.attributes.end()) continue;
            int a = d.it->second;
            if ((rc = check_accessor(a, obj + ".attributes." + d.name, d.ncomp, nrm_types, quantization ? 1 : 0,
                                     &zeros)))
                return rc;
            if (m.accessors[a].count != nv)
                return bad("%s.attributes.%s (accessors[%d]): count %zu differs from POSITION's %zu", o, d.name,
                           a, m.accessors[a].count, nv);
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
                                    acc[1], acc[2], tit != p.attributes.end() ? tit->second : -1);
        pd.deformable = !p.targets.empty() || p.attributes.count("JOINTS_0") ||
                        p.attributes.count("WEIGHTS_0") || p.attributes.count("JOINTS_1") ||
                        p.attributes.count("WEIGHTS_1");
        auto own = pd.deformable ? vertex_owner.end() : vertex_owner.find(vkey);
        if (own != vertex_owner.end()) {
            pd.vsrc = own->second;
        } else {
            if (!pd.deformable) vertex_owner[vkey] = &pd;
            else if ((rc = read_deform(mi, pi, nv))) return rc;
            read_floats(pit->second, 3, pd.pos);
            if (nit != p.attributes.end()) read_floats(nit->second, 3, pd.nrm);
            if (tit != p.attributes.end()) read_floats(tit->second, 4, pd.tan);
            if (acc[0] >= 0) read_floats(acc[0], 2, pd.uv);
            if (acc[1] >= 0) read_floats(acc[1], 2, pd.uv1);
            if (acc[2] >= 0) {
                std::vector<float> c;
                read_floats(acc[2], ncol, c);
                // A NaN or infinite colour would be clamped into 0 or 1 unnoticed.
                for (size_t i = 0; i < c.size(); i++)
                    if (!std::isfinite(c[i]))
                        return bad("%s.attributes.COLOR_0 (accessors[%d]): vertex %zu component %zu "
                                   "is %g: colours must be finite",
                                   o, acc[2], i / (size_t)ncol, i % (size_t)ncol, (double)c[i]);
                    else if (c[i] < 0.0f || c[i] > 1.0f)
                        colors_clamped++;
                pd.col.resize(nv * 4, 1.0f);
                for (size_t v = 0; v < nv; v++)
                    for (int k = 0; k < ncol; k++) pd.col[v * 4 + k] = c[v * ncol + k];
            }
        }
        int indices = p.indices;
        auto zit = zero_view_indices.find({mi, pi});
        if (zit != zero_view_indices.end()) indices = zit->second;
        if (indices >= 0) {
            if ((rc = check_accessor(indices, obj + ".indices", 1,
                                     {TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE,
                                      TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT,
                                      TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT},
                                     false, &zeros)))
                return rc;
            read_indices(indices, idx);
            for (size_t i = 0; i < idx.size(); i++)
                if (idx[i] >= nv)
                    return bad("%s.indices (accessors[%d]): element %zu is %u, but POSITION has only "
                               "%zu vertices",
                               o, indices, i, idx[i], nv);
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
    } want[6] = {{"POSITION", 3, &pd.pos}, {"NORMAL", 3, &pd.nrm}, {"TEXCOORD_0", 2, &pd.uv},
                 {"TEXCOORD_1", 2, &pd.uv1}, {"COLOR_0", ncol, &col}, {"TANGENT", 4, &pd.tan}};
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

// One placement of mesh mi flattened into world-space triangles, counted.
int Loader::emit_instance(int mi, const Mat4 &world, int node)
{
    stats.instances++;
    bool repeat = mesh_emitted[mi]++ > 0; // a further instance: flattened copy
    if (mesh_emitted[mi] == 2) stats.instanced_meshes++;
    uint64_t tris_before = tri_mat.size(), verts_before = vertex_count;
    int rc;
    if ((rc = emit_triangles(mi, world, node))) return rc;
    if (repeat) {
        stats.flattened_triangles += (uint32_t)(tri_mat.size() - tris_before);
        stats.flattened_vertices += (uint32_t)(vertex_count - verts_before);
    }
    return charge_memory("meshes[" + std::to_string(mi) + "] (instance " +
                         std::to_string(mesh_emitted[mi]) + ")");
}

// Mesh mi's triangles and vertices through world (posed as node's) appended
// to the scene's arrays; the primitives counted in stats.
int Loader::emit_triangles(int mi, const Mat4 &world, int node)
{
    Deform deform;
    int rc;
    if ((rc = deform_for(node, mi, &deform))) return rc;
    const auto &mesh = m.meshes[mi];
    double det = det3(world), cof[9];
    cofactor3(world, cof);
    bool mirrored = det < 0;
    // Vertices already emitted for this instance: shared vertex data -> base, world
    // positions.
    std::map<const PrimData *, std::pair<uint64_t, std::vector<double>>> emitted;
    std::map<const PrimData *, std::vector<char>> vflip; // deformed vertices: mirrored?
    for (size_t pi = 0; pi < mesh.primitives.size(); pi++) {
        PrimData &pd = prim[mi][pi];
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
            if (vd.deformable) vflip[&vd].assign(nv, 0);
            for (size_t v = 0; v < nv; v++) {
                double p[3] = {vd.pos[v * 3], vd.pos[v * 3 + 1], vd.pos[v * 3 + 2]};
                double nw[3] = {0, 0, 0};
                float tw[4] = {0, 0, 0, 0};
                bool flip = false;
                if (vd.deformable) {
                    if ((rc = deform_vertex(vd, mi, (int)pi, v, deform, world, &wp[v * 3], nw, tw, &flip)))
                        return rc;
                    vflip[&vd][v] = flip;
                } else {
                    mat_point(world, p, &wp[v * 3]);
                }
                if (!vd.nrm.empty() && !vd.deformable) {
                    const float *n = &vd.nrm[v * 3];
                    for (int r = 0; r < 3; r++)
                        nw[r] = (cof[r * 3] * n[0] + cof[r * 3 + 1] * n[1] + cof[r * 3 + 2] * n[2]) *
                                (mirrored ? -1.0 : 1.0);
                    if (!normalize3(nw)) nw[0] = nw[1] = nw[2] = 0;
                }
                if (!vd.tan.empty() && !vd.deformable) {
                    const double t[3] = {vd.tan[v * 4], vd.tan[v * 4 + 1], vd.tan[v * 4 + 2]};
                    mat_tangent(world, t, vd.tan[v * 4 + 3], mirrored, tw);
                }
                for (int r = 0; r < 3; r++) vtx_normal.push_back((float)nw[r]);
                for (int r = 0; r < 4; r++) vtx_tangent.push_back(tw[r]);
                vtx_uv.push_back(vd.uv.empty() ? 0.0f : vd.uv[v * 2]);
                vtx_uv.push_back(vd.uv.empty() ? 0.0f : vd.uv[v * 2 + 1]);
                // TEXCOORD_1 where the primitive has none: its TEXCOORD_0, so a
                // slot reading set 1 sees the mesh's only mapping.
                const std::vector<float> &u1 = vd.uv1.empty() ? vd.uv : vd.uv1;
                vtx_uv1.push_back(u1.empty() ? 0.0f : u1[v * 2]);
                vtx_uv1.push_back(u1.empty() ? 0.0f : u1[v * 2 + 1]);
                // COLOR_0 clamped to [0, 1] (a colour multiplying the base colour;
                // a warning counts the clamped components).
                for (int k = 0; k < 4; k++)
                    vtx_color.push_back(vd.col.empty() ? 1.0f : fminf(fmaxf(vd.col[v * 4 + k], 0.0f), 1.0f));
            }
            vertex_count += nv;
            any_uv1 |= !vd.uv1.empty();
            any_color |= !vd.col.empty();
            any_tangent |= !vd.tan.empty();
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
            // A skinned vertex has its own transform: the first vertex's says
            // whether the triangle is mirrored.
            if (vd.deformable ? vflip[&vd][a] != 0 : mirrored) std::swap(b, c);
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
    return 0;
}

int Loader::charge_memory(const std::string &what)
{
    double used = (double)tri_mat.size() * k_bytes_per_triangle +
                  (double)vertex_count * k_bytes_per_vertex + mem_used_textures +
                  (double)(inst_mesh.size() + placements.size()) * k_bytes_per_instance;
    if (mem_limit <= 0 || used <= mem_limit) return 0;
    return bad("the scene needs more than %.1f MiB of memory by %s (%zu triangles, %.1f MiB of "
               "textures so far): more than the %.1f MiB available (SPECTRACE_MAX_MEMORY_MB sets "
               "the limit)", used / 1048576.0, what.c_str(), tri_mat.size(),
               mem_used_textures / 1048576.0, mem_limit / 1048576.0);
}

} // namespace spt_gltf
