// The glTF loader's pose (docs/gltf.md, "Animation, skins and morph targets"):
// animations checked and sampled at --at (glTF 2.0 3.11 and Appendix C), the
// skins' joint matrices, the morph targets' weights and the vertices they move,
// and the --camera choice.
#include "scene/gltf_loader.h"

#include <cctype>

namespace spt_gltf {

namespace {

enum { INTERP_LINEAR, INTERP_STEP, INTERP_CUBIC };

// A channel's value at time t (glTF 2.0 Appendix C): keys in tin (strictly
// increasing), nc components per value, CUBICSPLINE values as (in-tangent,
// value, out-tangent) triples. Before the first key and after the last, the
// first and last values. quat: LINEAR is the spherical interpolation.
void sample(const std::vector<float> &tin, const std::vector<float> &v, int nc, int interp,
            bool quat, double t, double *out)
{
    size_t n = tin.size();
    size_t stride = interp == INTERP_CUBIC ? 3 : 1, off = interp == INTERP_CUBIC ? 1 : 0;
    auto val = [&](size_t k, int c) { return (double)v[(k * stride + off) * (size_t)nc + (size_t)c]; };
    if (!(t > tin[0]) || n == 1) {
        for (int c = 0; c < nc; c++) out[c] = val(0, c);
        return;
    }
    if (t >= tin[n - 1]) {
        for (int c = 0; c < nc; c++) out[c] = val(n - 1, c);
        return;
    }
    size_t k = (size_t)(std::upper_bound(tin.begin(), tin.end(), t) - tin.begin()) - 1;
    double td = (double)tin[k + 1] - tin[k], s = (t - tin[k]) / td;
    if (interp == INTERP_STEP) {
        for (int c = 0; c < nc; c++) out[c] = val(k, c);
    } else if (interp == INTERP_CUBIC) {
        double s2 = s * s, s3 = s2 * s;
        for (int c = 0; c < nc; c++) {
            double vk = val(k, c), vk1 = val(k + 1, c);
            double bk = v[(k * 3 + 2) * (size_t)nc + (size_t)c];       // out-tangent of k
            double ak1 = v[((k + 1) * 3) * (size_t)nc + (size_t)c];    // in-tangent of k + 1
            out[c] = (2 * s3 - 3 * s2 + 1) * vk + td * (s3 - 2 * s2 + s) * bk +
                     (-2 * s3 + 3 * s2) * vk1 + td * (s3 - s2) * ak1;
        }
    } else if (quat) {
        double a[4], b[4], d = 0;
        for (int c = 0; c < 4; c++) a[c] = val(k, c), b[c] = val(k + 1, c), d += a[c] * b[c];
        double sgn = d < 0 ? -1.0 : 1.0, ad = fabs(d);
        if (ad > 1.0 - 1e-9) { // the same rotation: sin(a) ~ 0, linear is exact enough
            for (int c = 0; c < 4; c++) out[c] = (1 - s) * a[c] + s * sgn * b[c];
        } else {
            double ang = acos(ad), sa = sin(ang);
            double wa = sin(ang * (1 - s)) / sa, wb = sgn * sin(ang * s) / sa;
            for (int c = 0; c < 4; c++) out[c] = wa * a[c] + wb * b[c];
        }
    } else {
        for (int c = 0; c < nc; c++) out[c] = (1 - s) * val(k, c) + s * val(k + 1, c);
    }
}

// A selector of --animation or --camera: the first object of that name, else a
// whole number as an index; -1 when neither.
template <class T> int select(const std::vector<T> &objs, const char *sel)
{
    for (size_t i = 0; i < objs.size(); i++)
        if (objs[i].name == sel) return (int)i;
    char *end;
    errno = 0;
    long v = strtol(sel, &end, 10);
    if (*sel && !*end && !errno && v >= 0 && (size_t)v < objs.size() && isdigit((unsigned char)*sel))
        return (int)v;
    return -1;
}

// "0 'walk', 1 'run'": the objects for a message naming what exists.
template <class T> std::string listing(const std::vector<T> &objs)
{
    std::vector<std::string> v;
    for (size_t i = 0; i < objs.size() && i < 8; i++)
        v.push_back(std::to_string(i) + (objs[i].name.empty() ? "" : " '" + objs[i].name + "'"));
    if (objs.size() > 8) v.push_back("...");
    return v.empty() ? "none" : join_names(v);
}

} // namespace

int Loader::select_camera()
{
    if (!pose_opts.camera) return 0;
    chosen_camera = select(m.cameras, pose_opts.camera);
    if (chosen_camera < 0)
        return bad("--camera '%s': the file has no camera of that name or index (its cameras: %s)",
                   pose_opts.camera, listing(m.cameras).c_str());
    return 0;
}

int Loader::animations()
{
    const int f = TINYGLTF_COMPONENT_TYPE_FLOAT, i8 = TINYGLTF_COMPONENT_TYPE_BYTE,
              u8 = TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE, i16 = TINYGLTF_COMPONENT_TYPE_SHORT,
              u16 = TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT;
    int play = -1; // -1: all
    if (pose_opts.animation) {
        play = select(m.animations, pose_opts.animation);
        if (play < 0)
            return bad("--animation '%s': the file has no animation of that name or index (its "
                       "animations: %s)",
                       pose_opts.animation, listing(m.animations).c_str());
    }
    double at = pose_opts.at;
    if (pose_opts.animation && !std::isfinite(at)) at = 0; // --animation alone: its start
    if (!m.animations.empty()) pose.assign(m.nodes.size(), NodePose()); // else: no pose
    if (std::isfinite(at) && m.animations.empty())
        spt_warn("%s: --at %g: the file has no animations; its rest pose is rendered", file, at);
    bool zeros;
    int rc;
    for (size_t ai = 0; ai < m.animations.size(); ai++) {
        const auto &an = m.animations[ai];
        std::string ao = "animations[" + std::to_string(ai) + "]" +
                         (an.name.empty() ? "" : " '" + an.name + "'");
        SceneAnimationInfo info = {};
        snprintf(info.name, sizeof info.name, "%s", an.name.c_str());
        info.start = HUGE_VAL;
        info.end = -HUGE_VAL;
        // Each sampler's input: times in seconds, >= 0 and strictly increasing
        // (each accessor read and checked once, however many samplers share it).
        std::vector<const std::vector<float> *> times(an.samplers.size());
        std::vector<int> interp(an.samplers.size());
        for (size_t si = 0; si < an.samplers.size(); si++) {
            const auto &sp = an.samplers[si];
            std::string so = ao + ".samplers[" + std::to_string(si) + "]";
            auto key = std::make_pair(sp.input, 0); // 0: as times
            auto it = anim_floats.find(key);
            if (it == anim_floats.end()) {
                if ((rc = check_accessor(sp.input, so + ".input", 1, {f}, 0, &zeros))) return rc;
                std::vector<float> t;
                read_floats(sp.input, 1, t);
                for (size_t k = 0; k < t.size(); k++)
                    if (!std::isfinite(t[k]) || t[k] < 0 || (k && !(t[k] > t[k - 1])))
                        return bad("%s.input (accessors[%d]): time %zu is %g: times must be "
                                   "finite, >= 0 and strictly increasing",
                                   so.c_str(), sp.input, k, (double)t[k]);
                it = anim_floats.emplace(key, std::move(t)).first;
            }
            times[si] = &it->second;
            if (sp.interpolation == "LINEAR") interp[si] = INTERP_LINEAR;
            else if (sp.interpolation == "STEP") interp[si] = INTERP_STEP;
            else if (sp.interpolation == "CUBICSPLINE") interp[si] = INTERP_CUBIC;
            else
                return bad("%s.interpolation: '%s' is not LINEAR, STEP or CUBICSPLINE", so.c_str(),
                           sp.interpolation.c_str());
        }
        for (size_t ci = 0; ci < an.channels.size(); ci++) {
            const auto &ch = an.channels[ci];
            std::string co = ao + ".channels[" + std::to_string(ci) + "]";
            if (ch.sampler < 0 || (size_t)ch.sampler >= an.samplers.size())
                return bad("%s.sampler: samplers[%d] does not exist in the animation", co.c_str(),
                           ch.sampler);
            // glTF 2.0 5.6: a channel without target.node is for an extension
            // (KHR_animation_pointer): not played.
            if (ch.target_node == -1) {
                unplayed_channels++;
                continue;
            }
            if (ch.target_node < 0 || (size_t)ch.target_node >= m.nodes.size())
                return bad("%s.target.node: nodes[%d] does not exist", co.c_str(), ch.target_node);
            const auto &node = m.nodes[ch.target_node];
            const std::string &path = ch.target_path;
            int nc;
            std::vector<int> types = {f};
            int norm = 0;
            if (path == "translation" || path == "scale") {
                nc = 3;
            } else if (path == "rotation") {
                nc = 4, types = {f, i8, u8, i16, u16}, norm = 1;
            } else if (path == "weights") {
                if (node.mesh < 0 || (size_t)node.mesh >= m.meshes.size() ||
                    m.meshes[node.mesh].primitives.empty() ||
                    m.meshes[node.mesh].primitives[0].targets.empty())
                    return bad("%s.target: animates the weights of nodes[%d], which has no mesh "
                               "with morph targets",
                               co.c_str(), ch.target_node);
                nc = (int)m.meshes[node.mesh].primitives[0].targets.size();
                types = {f, i8, u8, i16, u16}, norm = 1;
            } else {
                return bad("%s.target.path: '%s' is not translation, rotation, scale or weights",
                           co.c_str(), path.c_str());
            }
            if (!node.matrix.empty() && path != "weights")
                return bad("%s.target: nodes[%d] has a matrix; only translation, rotation and "
                           "scale can be animated (glTF 2.0 3.5.3)",
                           co.c_str(), ch.target_node);
            const auto &sp = an.samplers[ch.sampler];
            std::string oo = ao + ".samplers[" + std::to_string(ch.sampler) + "].output";
            int per_value = path == "weights" ? 1 : nc;
            // The output, read and checked once per accessor and value size (which
            // decides the allowed types: 3 translation and scale, 4 rotation, 1
            // weights).
            auto key = std::make_pair(sp.output, per_value);
            auto it = anim_floats.find(key);
            if (it == anim_floats.end()) {
                if ((rc = check_accessor(sp.output, oo, per_value, types, norm, &zeros))) return rc;
                std::vector<float> o;
                read_floats(sp.output, per_value, o);
                for (size_t k = 0; k < o.size(); k++)
                    if (!std::isfinite(o[k]))
                        return bad("%s (accessors[%d]): value %zu is not finite", oo.c_str(),
                                   sp.output, k);
                it = anim_floats.emplace(key, std::move(o)).first;
            }
            const std::vector<float> &out = it->second;
            const auto &tin = *times[ch.sampler];
            size_t want = tin.size() * (interp[ch.sampler] == INTERP_CUBIC ? 3 : 1) *
                          (path == "weights" ? (size_t)nc : 1);
            if (m.accessors[sp.output].count != want)
                return bad("%s (accessors[%d]): count %zu, expected %zu for %zu key(s)%s%s",
                           oo.c_str(), sp.output, m.accessors[sp.output].count, want, tin.size(),
                           interp[ch.sampler] == INTERP_CUBIC ? " of CUBICSPLINE triples" : "",
                           path == "weights" ? (" of " + std::to_string(nc) + " weights").c_str() : "");
            info.channels++;
            info.start = std::min(info.start, (double)tin.front());
            info.end = std::max(info.end, (double)tin.back());
            if (!std::isfinite(at) || (play >= 0 && (size_t)play != ai)) continue;
            // Played: the node's property at `at` (a later channel on the same
            // property wins).
            NodePose &np = pose[ch.target_node];
            double val[4];
            if (path == "weights") {
                np.w = true;
                np.W.assign((size_t)nc, 0.0);
                sample(tin, out, nc, interp[ch.sampler], false, at, np.W.data());
            } else {
                sample(tin, out, nc, interp[ch.sampler], path == "rotation", at, val);
                double *dst = path == "translation" ? np.T : path == "rotation" ? np.R : np.S;
                (path == "translation" ? np.t : path == "rotation" ? np.r : np.s) = true;
                for (int c = 0; c < nc; c++) dst[c] = val[c];
            }
        }
        if (!info.channels) info.start = info.end = 0;
        anim_info.push_back(info);
    }
    return 0;
}

int Loader::node_world(int n, Mat4 *out)
{
    if (world_state.empty()) {
        world_state.assign(m.nodes.size(), 0);
        world.assign(m.nodes.size(), mat_identity());
    }
    if (world_state[n]) {
        *out = world[n];
        return 0;
    }
    // The chain up to a known ancestor (or the root), then down: the same
    // products as traverse's walk.
    std::vector<int> chain;
    for (int k = n; k >= 0 && !world_state[k]; k = parent[k]) chain.push_back(k);
    for (size_t i = chain.size(); i-- > 0;) {
        int k = chain[i];
        Mat4 local;
        if (int rc = node_local(k, &local)) return rc;
        world[k] = mat_mul(parent[k] >= 0 ? world[parent[k]] : mat_identity(), local);
        world_state[k] = 1;
    }
    *out = world[n];
    return 0;
}

int Loader::read_deform(int mi, int pi, size_t nv)
{
    PrimData &pd = prim[mi][pi];
    const auto &p = m.meshes[mi].primitives[pi];
    std::string obj = "meshes[" + std::to_string(mi) + "].primitives[" + std::to_string(pi) + "]";
    const int f = TINYGLTF_COMPONENT_TYPE_FLOAT, u8 = TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE,
              u16 = TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT;
    bool zeros;
    int rc;
    // Morph targets: POSITION, NORMAL and TANGENT deltas (VEC3: a TANGENT delta
    // moves xyz, w stays; float, or normalised integers with
    // KHR_mesh_quantization), sparse ones included.
    std::vector<int> dtypes = {f};
    if (quantization)
        dtypes = {f, TINYGLTF_COMPONENT_TYPE_BYTE, TINYGLTF_COMPONENT_TYPE_SHORT};
    pd.tpos.resize(p.targets.size());
    pd.tnrm.resize(p.targets.size());
    pd.ttan.resize(p.targets.size());
    for (size_t t = 0; t < p.targets.size(); t++)
        for (const auto &a : p.targets[t]) {
            std::vector<float> *dst = a.first == "POSITION"  ? &pd.tpos[t]
                                      : a.first == "NORMAL"  ? &pd.tnrm[t]
                                      : a.first == "TANGENT" ? &pd.ttan[t]
                                                             : nullptr;
            if (!dst) continue; // TEXCOORD_n and COLOR_n deltas: not read
            std::string to = obj + ".targets[" + std::to_string(t) + "]." + a.first;
            if ((rc = check_accessor(a.second, to, 3, dtypes, quantization ? 2 : 0, &zeros)))
                return rc;
            if (m.accessors[a.second].count != nv)
                return bad("%s (accessors[%d]): count %zu differs from POSITION's %zu", to.c_str(),
                           a.second, m.accessors[a.second].count, nv);
            read_floats(a.second, 3, *dst);
        }
    // JOINTS_0/1 (unsigned byte or short) and WEIGHTS_0/1 (float or normalised
    // unsigned byte or short): up to 8 influences per vertex.
    for (int set = 0; set < 2; set++) {
        std::string jn = "JOINTS_" + std::to_string(set), wn = "WEIGHTS_" + std::to_string(set);
        auto jit = p.attributes.find(jn), wit = p.attributes.find(wn);
        if (jit == p.attributes.end() && wit == p.attributes.end()) continue;
        if (jit == p.attributes.end() || wit == p.attributes.end())
            return bad("%s.attributes: %s without %s", obj.c_str(),
                       (jit == p.attributes.end() ? wn : jn).c_str(),
                       (jit == p.attributes.end() ? jn : wn).c_str());
        if (set == 1 && pd.joints.empty())
            return bad("%s.attributes: JOINTS_1 without JOINTS_0", obj.c_str());
        std::string jo = obj + ".attributes." + jn, wo = obj + ".attributes." + wn;
        if ((rc = check_accessor(jit->second, jo, 4, {u8, u16}, 0, &zeros)) ||
            (rc = check_accessor(wit->second, wo, 4, {f, u8, u16}, 1, &zeros)))
            return rc;
        for (auto it : {jit, wit})
            if (m.accessors[it->second].count != nv)
                return bad("%s.attributes.%s (accessors[%d]): count %zu differs from POSITION's %zu",
                           obj.c_str(), it->first.c_str(), it->second,
                           m.accessors[it->second].count, nv);
        std::vector<float> j, w;
        read_floats(jit->second, 4, j);
        read_floats(wit->second, 4, w);
        pd.joints.resize(nv * 8, 0.0f);
        pd.weights.resize(nv * 8, 0.0f);
        for (size_t v = 0; v < nv; v++)
            for (int k = 0; k < 4; k++) {
                pd.joints[v * 8 + set * 4 + k] = j[v * 4 + k];
                pd.weights[v * 8 + set * 4 + k] = w[v * 4 + k];
            }
    }
    return 0;
}

int Loader::deform_for(int node, int mi, Deform *d)
{
    const auto &nd = m.nodes[node];
    const auto &mesh = m.meshes[mi];
    d->weights.clear();
    d->joints = nullptr;
    // Morph weights: the animation's, else the node's, else the mesh's, else 0.
    size_t nt = 0;
    for (const auto &p : mesh.primitives) nt = std::max(nt, p.targets.size());
    for (size_t pi = 0; pi < mesh.primitives.size(); pi++)
        if (!mesh.primitives[pi].targets.empty() && mesh.primitives[pi].targets.size() != nt)
            return bad("meshes[%d].primitives[%zu].targets: %zu targets, but another primitive "
                       "of the mesh has %zu (glTF 2.0 3.7.2.2: all must have as many)",
                       mi, pi, mesh.primitives[pi].targets.size(), nt);
    if (nt) {
        const std::vector<double> &w = pose.size() > (size_t)node && pose[node].w ? pose[node].W
                                       : !nd.weights.empty()                     ? nd.weights
                                                                                 : mesh.weights;
        if (!w.empty() && w.size() != nt)
            return bad("%s: %zu morph weights for meshes[%d]'s %zu targets",
                       &w == &nd.weights ? ("nodes[" + std::to_string(node) + "].weights").c_str()
                                         : ("meshes[" + std::to_string(mi) + "].weights").c_str(),
                       w.size(), mi, nt);
        d->weights.assign(nt, 0.0);
        for (size_t k = 0; k < w.size(); k++) {
            if (!std::isfinite(w[k]))
                return bad("nodes[%d]: morph weight %zu is not finite", node, k);
            d->weights[k] = w[k];
        }
    }
    if (nd.skin < 0) return 0;
    if ((size_t)nd.skin >= m.skins.size())
        return bad("nodes[%d].skin: skins[%d] does not exist", node, nd.skin);
    d->skin = nd.skin;
    // The joint matrices depend on the skin alone (not on the node using it):
    // computed once per skin.
    auto done = skin_matrices.find(nd.skin);
    if (done != skin_matrices.end()) {
        d->joints = &done->second;
        return 0;
    }
    const auto &sk = m.skins[nd.skin];
    std::string so = "skins[" + std::to_string(nd.skin) + "]";
    if (sk.joints.empty()) return bad("%s.joints: empty", so.c_str());
    std::vector<float> ibm;
    if (sk.inverseBindMatrices >= 0) {
        bool zeros;
        if (int rc = check_accessor(sk.inverseBindMatrices, so + ".inverseBindMatrices", 16,
                                    {TINYGLTF_COMPONENT_TYPE_FLOAT}, 0, &zeros))
            return rc;
        if (m.accessors[sk.inverseBindMatrices].count < sk.joints.size())
            return bad("%s.inverseBindMatrices (accessors[%d]): %zu matrices for %zu joints",
                       so.c_str(), sk.inverseBindMatrices,
                       m.accessors[sk.inverseBindMatrices].count, sk.joints.size());
        read_floats(sk.inverseBindMatrices, 16, ibm);
    } else if (sk.inverseBindMatrices < -1) {
        return bad("%s.inverseBindMatrices: accessors[%d] does not exist", so.c_str(),
                   sk.inverseBindMatrices);
    }
    // Joint matrix = the joint's world transform x its inverse bind matrix; the
    // skinned node's own transform is not applied (glTF 2.0 3.7.3.1).
    std::vector<Mat4> joints;
    for (size_t k = 0; k < sk.joints.size(); k++) {
        int jn = sk.joints[k];
        if (jn < 0 || (size_t)jn >= m.nodes.size())
            return bad("%s.joints[%zu]: nodes[%d] does not exist", so.c_str(), k, jn);
        Mat4 jw, b = mat_identity();
        if (int rc = node_world(jn, &jw)) return rc;
        if (!ibm.empty())
            for (int c = 0; c < 16; c++) b.m[c] = ibm[k * 16 + c];
        joints.push_back(mat_mul(jw, b));
    }
    d->joints = &skin_matrices.emplace(nd.skin, std::move(joints)).first->second;
    return 0;
}

int Loader::deform_vertex(const PrimData &pd, int mi, int pi, size_t v, const Deform &d,
                          const Mat4 &world, double wp[3], double nw[3], float tw[4], bool *flip)
{
    double p[3], n[3] = {0, 0, 0}, tg[3] = {0, 0, 0};
    for (int r = 0; r < 3; r++) p[r] = pd.pos[v * 3 + r];
    bool has_n = !pd.nrm.empty(), has_t = !pd.tan.empty();
    if (has_n)
        for (int r = 0; r < 3; r++) n[r] = pd.nrm[v * 3 + r];
    if (has_t)
        for (int r = 0; r < 3; r++) tg[r] = pd.tan[v * 4 + r];
    for (size_t t = 0; t < d.weights.size() && t < pd.tpos.size(); t++) {
        double w = d.weights[t];
        if (w == 0) continue;
        for (int r = 0; r < 3; r++) {
            if (!pd.tpos[t].empty()) p[r] += w * pd.tpos[t][v * 3 + r];
            if (has_n && !pd.tnrm[t].empty()) n[r] += w * pd.tnrm[t][v * 3 + r];
            if (has_t && !pd.ttan[t].empty()) tg[r] += w * pd.ttan[t][v * 3 + r];
        }
    }
    Mat4 M = world;
    if (d.joints && !pd.joints.empty()) {
        M = Mat4{};
        for (int k = 0; k < 8; k++) {
            double w = pd.weights[v * 8 + k];
            if (w == 0) continue;
            size_t j = (size_t)pd.joints[v * 8 + k];
            if (j >= d.joints->size())
                return bad("meshes[%d].primitives[%d].attributes.JOINTS_%d: vertex %zu names joint "
                           "%zu, but skins[%d] has %zu joints",
                           mi, pi, k / 4, v, j, d.skin, d.joints->size());
            for (int c = 0; c < 16; c++) M.m[c] += w * (*d.joints)[j].m[c];
        }
    }
    mat_point(M, p, wp);
    double det = det3(M), cof[9];
    *flip = det < 0;
    nw[0] = nw[1] = nw[2] = 0;
    if (has_n) {
        cofactor3(M, cof);
        for (int r = 0; r < 3; r++)
            nw[r] = (cof[r * 3] * n[0] + cof[r * 3 + 1] * n[1] + cof[r * 3 + 2] * n[2]) *
                    (*flip ? -1.0 : 1.0);
        if (!normalize3(nw)) nw[0] = nw[1] = nw[2] = 0;
    }
    tw[0] = tw[1] = tw[2] = tw[3] = 0;
    if (has_t) mat_tangent(M, tg, pd.tan[v * 4 + 3], *flip, tw);
    return 0;
}

} // namespace spt_gltf
