/* The scene as device arrays (GpuScene), built from a loaded Scene. */
#ifndef SPT_GPU_SCENE_H
#define SPT_GPU_SCENE_H

#include <stddef.h>
#include <stdint.h>

#include "accel/bvh_build.h"
#include "accel/tlas_build.h"
#include "core/util.h"
#include "render/host_lights.h"
#include "scene/scene.h"
#include "util/render_types.h"

/* The scene as the kernels read it: packed triangles in BVH order and their
 * shading data, materials with spectra, coefficient textures, emitters. */
typedef struct GpuScene {
    Bvh bvh;                 /* the triangles in world space (all of them without instances) */
    /* With instances (Scene.mesh_count > 0; docs/architecture.md, "Instances
     * (two levels)"): the two levels, whose mesh 0 is bvh placed by the
     * identity and whose meshes 1 .. are the Scene's. The packed triangles
     * are bvh's, then each mesh's in turn (BvhInstance.prim_base); the
     * kernels' nodes and tris are tlas's. inst_count 0: no instances. */
    Tlas tlas;
    /* The kernels' nodes and top level quantised (kernels/bvh/bvh_node.h,
     * BvhQNode) when bvh_qnodes_wanted, uploaded instead of the float ones;
     * else NULL. */
    BvhQNode *qnodes, *qtop;
    uint32_t *mesh_prims;    /* tlas's mesh m: packed triangles [mesh_prims[m], mesh_prims[m + 1]) */
    uint32_t prim_total;     /* packed triangles: bvh's and the meshes' */
    TriShade *tri_shade;     /* per packed triangle */
    float *vtx_pos;          /* 3 per vertex: positions, from the Scene's triangles */
    float *vtx_normal;       /* borrowed from the Scene */
    float *vtx_uv;           /* borrowed from the Scene */
    float *vtx_uv1;          /* borrowed from the Scene; NULL without TEXCOORD_1 */
    float *vtx_color;        /* 4 per vertex: COLOR_0's sigmoid coefficients and alpha;
                                NULL without COLOR_0 */
    float *vtx_tangent;      /* borrowed from the Scene; NULL without TANGENT */
    uint32_t vertex_count;
    GpuMaterial *materials;
    uint32_t material_count;
    float *spectra;          /* SPT_CIE_SAMPLES floats per tabulated spectrum */
    uint32_t spectra_count;  /* floats */
    GpuTexture *textures;
    uint32_t texture_count;
    float *texels;           /* 4 floats per texel (GpuTexture's kinds), mip pyramids */
    size_t texel_count;
    /* The light selection's emitters: tri_emitter_count triangles in world
     * space, then one entry per instance whose mesh emits
     * (docs/architecture.md, "Instances (two levels)"). */
    uint32_t *emitters;      /* per emitter: its packed triangle, or its instance in tlas */
    uint32_t emitter_count;
    uint32_t tri_emitter_count;
    float *emitter_power;    /* per emitter: pi * area * Y(Le) (an instance's: of its emitting
                                triangles placed), its selection weight */
    float *emitter_area;     /* per triangle emitter; 0 for an instance */
    /* Per tlas mesh m (the world's, 0, has none: its emitters are
     * triangles), its emitting triangles, stored once for all its
     * instances: packed triangles mesh_emitter_prims[mesh_emitter_first[m]
     * .. mesh_emitter_first[m + 1]), each weighted by pi * area * Y(Le) in
     * the mesh's space (mesh_emitter_power). NULL without instances. */
    uint32_t mesh_count;     /* tlas meshes, the world's included */
    uint32_t *mesh_emitter_first;
    uint32_t *mesh_emitter_prims;
    float *mesh_emitter_power;
    GpuLight *lights;        /* punctual lights (spectra tables in spectra) */
    uint32_t light_count;
    float scene_radius;      /* of the bounding sphere, for light power estimates */
    float scene_center[3];   /* its centre */
    int line_spectrum;       /* a light's or an emissive material's spectrum has lines
                                (an SPD's line_count, e.g. mercury): light_plan_merges */
} GpuScene;

/* Builds the BVH and the device arrays of s. Returns 0 or an exit code. */
int gpu_scene_build(GpuScene *g, const Scene *s, SptError *e);

/* The same with the BVH given (built, or refitted by bvh_refit, over s's
 * triangles): g takes it over, whatever the outcome (*bvh is zeroed). */
int gpu_scene_build_with(GpuScene *g, const Scene *s, Bvh *bvh, SptError *e);
void gpu_scene_free(GpuScene *g);

/* Rebuilds what depends on s's materials and lights (materials, spectra,
 * textures, emitters, punctual lights) of a g that gpu_scene_build made,
 * keeping its BVH and vertices: after a change of a material's or a light's
 * parameters (src/api/spectrace.h). Returns 0 or an exit code; g is then
 * freed. */
int gpu_scene_build_shading(GpuScene *g, const Scene *s, SptError *e);

/* The vertices of packed triangle prim as the kernels read them (vtx_pos):
 * in world space, or a mesh's triangle in its mesh's space. */
void gpu_scene_tri(const GpuScene *g, uint32_t prim, vec3 *a, vec3 *b, vec3 *c);

/* Bytes of device memory the scene arrays need (for `info` and limit checks). */
size_t gpu_scene_bytes(const GpuScene *g);

struct RenderLights;

/* Byte size and contents of the scene buffer called name (a name of
 * SPT_SCENE_BUFFERS, kernels/util/render_types.h): sizes are never 0 (OpenCL
 * refuses empty buffers); contents may be NULL (a zeroed buffer). L may be NULL
 * (an estimate for `info`: no environment). */
size_t gpu_scene_buffer_bytes(const GpuScene *g, const struct RenderLights *L, const char *name);
const void *gpu_scene_buffer_data(const GpuScene *g, const struct RenderLights *L,
                                  const char *name);

#endif
