// The glTF loader's node hierarchy: local transforms, the traversal of the
// scene's nodes (loops and shared children refused), cameras and punctual lights.
#include "scene/gltf_loader.h"

namespace spt_gltf {

// M = T R S of a translation, a rotation quaternion (x, y, z, w; normalised
// here) and a scale; false when the quaternion has no direction.
static bool trs_matrix(const double t[3], const double q_in[4], const double s[3], Mat4 *out)
{
    double ql = sqrt(q_in[0] * q_in[0] + q_in[1] * q_in[1] + q_in[2] * q_in[2] + q_in[3] * q_in[3]);
    if (!(ql > 0) || !std::isfinite(ql)) return false;
    double x = q_in[0] / ql, y = q_in[1] / ql, z = q_in[2] / ql, w = q_in[3] / ql;
    // Rotation matrix of the unit quaternion (row r, column c), then M = T R S.
    double R[3][3] = {{1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)},
                      {2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)},
                      {2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)}};
    *out = mat_identity();
    for (int c = 0; c < 3; c++)
        for (int r = 0; r < 3; r++) out->m[c * 4 + r] = R[r][c] * s[c];
    for (int r = 0; r < 3; r++) out->m[12 + r] = t[r];
    return true;
}

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
    if ((size_t)n < pose.size()) { // the animations' values at --at replace the file's
        const NodePose &np = pose[n];
        if (np.t) std::copy(np.T, np.T + 3, t);
        if (np.r) std::copy(np.R, np.R + 4, q);
        if (np.s) std::copy(np.S, np.S + 3, s);
    }
    if (!trs_matrix(t, q, s, out)) return bad("nodes[%d].rotation: not a unit quaternion", n);
    return 0;
}

// EXT_mesh_gpu_instancing on node n (ext: its object), placed at world: one
// instance of the node's mesh per element of the TRANSLATION, ROTATION and
// SCALE accessors (each optional, all of one count), at world times the
// element's T R S, in the node's space as the extension defines; each is a
// placement of the mesh as a node's is (docs/gltf.md, "Instancing").
int Loader::gpu_instances(int n, const Value &ext, const Mat4 &world)
{
    std::string eo = "nodes[" + std::to_string(n) + "].extensions.EXT_mesh_gpu_instancing";
    const Value &attrs = ext.IsObject() ? ext.Get("attributes") : Value();
    if (!attrs.IsObject()) return bad("%s.attributes: missing or not an object", eo.c_str());
    const int f = TINYGLTF_COMPONENT_TYPE_FLOAT, i8 = TINYGLTF_COMPONENT_TYPE_BYTE,
              u8 = TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE, i16 = TINYGLTF_COMPONENT_TYPE_SHORT,
              u16 = TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT;
    // The extension's types: floats; rotations also normalised signed bytes
    // and shorts; translations and scales also (normalised or not) integers
    // with KHR_mesh_quantization.
    const char *names[3] = {"TRANSLATION", "ROTATION", "SCALE"};
    std::vector<float> vals[3];
    size_t count = 0;
    bool any = false;
    for (int k = 0; k < 3; k++) {
        const Value &a = attrs.Get(names[k]);
        if (!attrs.Has(names[k])) continue;
        std::string ao = eo + ".attributes." + names[k];
        if (!a.IsNumber()) return bad("%s: not an accessor index", ao.c_str());
        int index = a.GetNumberAsInt();
        std::vector<int> types = {f};
        int norm = 0;
        if (k == 1)
            types = {f, i8, i16}, norm = 1;
        else if (quantization)
            types = {f, i8, u8, i16, u16}, norm = 2;
        bool zeros;
        int rc;
        if ((rc = check_accessor(index, ao, k == 1 ? 4 : 3, types, norm, &zeros))) return rc;
        size_t c = m.accessors[index].count;
        if (any && c != count)
            return bad("%s (accessors[%d]): %zu elements, where the other attributes have %zu",
                       ao.c_str(), index, c, count);
        count = c;
        any = true;
        read_floats(index, k == 1 ? 4 : 3, vals[k]);
        for (size_t i = 0; i < vals[k].size(); i++)
            if (!std::isfinite(vals[k][i]))
                return bad("%s (accessors[%d]): value %zu is not finite", ao.c_str(), index, i);
    }
    if (!any) return bad("%s.attributes: none of TRANSLATION, ROTATION and SCALE", eo.c_str());
    for (size_t i = 0; i < count; i++) {
        double t[3] = {0, 0, 0}, q[4] = {0, 0, 0, 1}, s[3] = {1, 1, 1};
        for (int c = 0; c < 3 && !vals[0].empty(); c++) t[c] = vals[0][3 * i + c];
        for (int c = 0; c < 4 && !vals[1].empty(); c++) q[c] = vals[1][4 * i + c];
        for (int c = 0; c < 3 && !vals[2].empty(); c++) s[c] = vals[2][3 * i + c];
        Mat4 local;
        if (!trs_matrix(t, q, s, &local))
            return bad("%s.attributes.ROTATION: element %zu is not a unit quaternion", eo.c_str(), i);
        int rc;
        if ((rc = place(m.nodes[n].mesh, mat_mul(world, local), n))) return rc;
    }
    return 0;
}

int Loader::traverse()
{
    size_t nn = m.nodes.size();
    parent.assign(nn, -1);
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
        if (node.skin < -1 || (node.skin >= 0 && (size_t)node.skin >= m.skins.size()))
            return bad("nodes[%zu].skin: skins[%d] does not exist", i, node.skin);
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

    // The animations checked and, at --at, sampled into the nodes' poses.
    int rc;
    if ((rc = animations())) return rc;
    cam_info.assign(m.cameras.size(), SceneCameraInfo());
    for (size_t c = 0; c < m.cameras.size(); c++) {
        snprintf(cam_info[c].name, sizeof cam_info[c].name, "%s", m.cameras[c].name.c_str());
        cam_info[c].orthographic = m.cameras[c].type == "orthographic";
        cam_info[c].node = -1;
    }
    // World transforms are kept only for skins, whose joints may come later.
    if (!m.skins.empty()) {
        world_state.assign(nn, 0);
        world.assign(nn, mat_identity());
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
        if ((rc = node_local(n, &local))) return rc;
        Mat4 world = mat_mul(parent_world, local);
        if (!world_state.empty()) {
            this->world[n] = world;
            world_state[n] = 1;
        }
        const auto &node = m.nodes[n];
        auto git = node.extensions.find("EXT_mesh_gpu_instancing");
        if (node.mesh >= 0 && git != node.extensions.end()) {
            if ((rc = gpu_instances(n, git->second, world))) return rc;
        } else if (node.mesh >= 0 && (rc = place(node.mesh, world, n))) {
            return rc;
        }
        // The camera: --camera's on the first node placing it, else the first
        // placed (docs/gltf.md, "Animation, skins and morph targets").
        if (node.camera >= 0 && cam_info[node.camera].node < 0) cam_info[node.camera].node = n;
        if (node.camera >= 0 && !have_camera &&
            (chosen_camera < 0 || node.camera == chosen_camera) &&
            (rc = camera_from(node.camera, world, n)))
            return rc;
        auto lit = node.extensions.find("KHR_lights_punctual");
        if (lit != node.extensions.end() &&
            (rc = light_from(lit->second.Get("light").GetNumberAsInt(), world, n)))
            return rc;
        for (size_t k = node.children.size(); k-- > 0;) stack.push_back({node.children[k], world});
    }
    if ((rc = place_meshes())) return rc;
    if (chosen_camera >= 0 && !have_camera)
        return bad("--camera '%s': cameras[%d]%s is placed on no node of the scene",
                   pose_opts.camera, chosen_camera,
                   m.cameras[chosen_camera].name.empty()
                       ? ""
                       : (" '" + m.cameras[chosen_camera].name + "'").c_str());
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
    snprintf(sl.object, sizeof sl.object, "%s", obj.c_str());
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
            // KHR_lights_punctual's schema bounds color to [0, 1]: a brighter
            // light is its intensity's job, and an out-of-range value is named
            // as the material factors are (gltf_materials.cpp, in_range).
            if (!(l.color[k] >= 0 && l.color[k] <= 1))
                return bad("%s.color[%d]: %g is outside [0, 1], the range the glTF specification "
                           "allows",
                           obj.c_str(), k, l.color[k]);
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
    int rc;
    std::string named = obj + (l.name.empty() ? "" : " '" + l.name + "'");
    if ((rc = light_extras(l.extras, &sl, named))) return rc;
    try {
        lights.push_back(sl);
    } catch (...) {
        spd_free(&sl.spd);
        throw;
    }
    return 0;
}

} // namespace spt_gltf
