// The glTF loader's instancing: the traversal's placements of meshes (nodes
// and EXT_mesh_gpu_instancing instances) flattened into world-space triangles
// or kept as one mesh in its own space plus its instances (docs/gltf.md,
// "Instancing"; the renderer's side: docs/architecture.md, "Instances (two
// levels)").
#include "scene/gltf_loader.h"

namespace spt_gltf {

// A placement of mesh mi at world by node, resolved by place_meshes once the
// traversal has counted every mesh's placements.
int Loader::place(int mi, const Mat4 &world, int node)
{
    placements.push_back({mi, node, world});
    // Each counted as an instance: a file placing millions stops here.
    return charge_memory("nodes[" + std::to_string(node) + "]");
}

// Whether mesh mi (its primitives read), placed by nodes, can be traced by
// reference: not skinned or morphed (posed per node: src/scene/gltf_pose.cpp).
// Emitting meshes are lights once per instance, and TANGENT stays in the
// mesh's space, which the renderer moves through the instance's transform
// (docs/architecture.md, "Instances (two levels)").
bool Loader::by_reference_ok(int mi, const std::vector<int> &nodes)
{
    for (int n : nodes)
        if (m.nodes[n].skin >= 0) return false;
    for (const PrimData &pd : prim[mi]) {
        if (pd.skip) continue;
        const PrimData &vd = pd.vsrc ? *pd.vsrc : pd;
        if (pd.deformable || vd.deformable)
            return false;
    }
    return true;
}

int Loader::place_meshes()
{
    const int mode = pose_opts.instancing;
    size_t nm = m.meshes.size();
    std::vector<std::vector<int>> nodes(nm);
    for (const Placement &p : placements) nodes[p.mesh].push_back(p.node);
    std::vector<int> ref(nm, -1); // the mesh's index into ref_meshes
    int rc;
    for (size_t mi = 0; mi < nm && mode != SCENE_INSTANCING_OFF; mi++) {
        size_t uses = nodes[mi].size();
        if (uses == 0 || (uses < 2 && mode != SCENE_INSTANCING_ON)) continue;
        for (size_t pi = 0; pi < prim[mi].size(); pi++)
            if (!prim[mi][pi].read && (rc = read_primitive((int)mi, (int)pi))) return rc;
        if (!by_reference_ok((int)mi, nodes[mi])) continue;
        ref[mi] = (int)ref_meshes.size();
        ref_meshes.push_back((int)mi);
    }
    // The flattened placements in scene order (as without instancing), the
    // others as instances (no longer charged as placements).
    std::vector<Placement> todo;
    todo.swap(placements);
    for (const Placement &p : todo) {
        if (ref[p.mesh] < 0) {
            if ((rc = emit_instance(p.mesh, p.world, p.node))) return rc;
            continue;
        }
        stats.instances++;
        inst_mesh.push_back((uint32_t)ref[p.mesh]);
        for (int r = 0; r < 3; r++) {
            for (int c = 0; c < 3; c++) inst_xf.push_back((float)p.world.m[c * 4 + r]);
            inst_xf.push_back((float)p.world.m[12 + r]);
        }
    }
    // Each mesh once in its own space, after the world-space triangles.
    std::vector<uint32_t> kept(ref_meshes.size()), kept_emissive(ref_meshes.size());
    for (size_t k = 0; k < ref_meshes.size(); k++) {
        int mi = ref_meshes[k];
        size_t tris_before = tri_mat.size();
        uint32_t prims_before = stats.primitives, emissive_before = stats.emissive_triangles;
        if ((rc = emit_triangles(mi, mat_identity(), nodes[mi][0]))) return rc;
        ref_tri_count.push_back((uint32_t)(tri_mat.size() - tris_before));
        // The primitives and emitting triangles count per placement, as
        // flattened ones do.
        kept[k] = stats.primitives - prims_before;
        kept_emissive[k] = stats.emissive_triangles - emissive_before;
        stats.primitives = prims_before;
        stats.emissive_triangles = emissive_before;
        mesh_emitted[mi] = (uint32_t)nodes[mi].size();
    }
    for (uint32_t r : inst_mesh) {
        stats.primitives += kept[r];
        stats.emissive_triangles += kept_emissive[r];
    }
    // A mesh whose triangles were all dropped places nothing.
    std::vector<uint32_t> renum(ref_meshes.size());
    std::vector<char> empty(ref_meshes.size());
    size_t nk = 0;
    for (size_t k = 0; k < ref_meshes.size(); k++) {
        renum[k] = (uint32_t)nk;
        empty[k] = ref_tri_count[k] == 0;
        if (!empty[k]) {
            ref_meshes[nk] = ref_meshes[k];
            ref_tri_count[nk++] = ref_tri_count[k];
        }
    }
    size_t ni = 0;
    for (size_t i = 0; i < inst_mesh.size(); i++) {
        if (empty[inst_mesh[i]]) continue;
        inst_mesh[ni] = renum[inst_mesh[i]];
        std::copy(inst_xf.begin() + 12 * i, inst_xf.begin() + 12 * i + 12, inst_xf.begin() + 12 * ni);
        ni++;
    }
    ref_meshes.resize(nk);
    ref_tri_count.resize(nk);
    inst_mesh.resize(ni);
    inst_xf.resize(12 * ni);
    todo = std::vector<Placement>();
    return charge_memory("the meshes placed by reference");
}

} // namespace spt_gltf
