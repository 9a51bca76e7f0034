/* The two levels of an instanced scene (kernels/bvh/bvh_tlas.h): each mesh's
 * bottom-level BVH (bvh_build), stored once however many instances use it,
 * and a top-level BVH over the instances' world-space boxes with each
 * instance's 3x4 transform and its inverse. */
#ifndef SPT_TLAS_BUILD_H
#define SPT_TLAS_BUILD_H

#include <stddef.h>
#include <stdint.h>

#include "accel/bvh_build.h"
#include "bvh/bvh_tlas.h"
#include "core/util.h"

/* What a build made, for `info` and the benchmark: the device memory of each
 * level in bytes, and the triangles stored against those the instances place. */
typedef struct TlasStats {
    uint32_t instances;        /* kept (inst_count) */
    uint32_t dropped;          /* instances with a singular or non-finite transform */
    uint64_t unique_tris;      /* the meshes' kept triangles, each counted once */
    uint64_t instanced_tris;   /* the triangles of every kept instance */
    size_t top_bytes;          /* top-level nodes and instances */
    size_t bottom_bytes;       /* the meshes' nodes and leaf blocks */
    double build_seconds;      /* the top level (the meshes' are in their BvhStats) */
} TlasStats;

typedef struct Tlas {
    BvhNode *top;              /* top_count nodes, root first (device-ready) */
    uint32_t top_count;
    BvhInstance *inst;         /* inst_count, in the top level's order (device-ready) */
    uint32_t inst_count;
    uint32_t *inst_index;      /* inst_index[k] = input index of instance k */
    uint32_t *inst_mesh;       /* inst_mesh[k] = the mesh instance k places */
    BvhNode *nodes;            /* the meshes' nodes, one after another (device-ready) */
    size_t node_count;
    float *tris;               /* the meshes' leaf blocks, one after another (device-ready) */
    size_t tri_words;
    TlasStats stats;
} Tlas;

/* Builds tlas (overwritten) for inst_count instances: instance i places mesh
 * inst_mesh[i] (of mesh_count, already built, each kept as it is) by the rows
 * xf[12 i .. 12 i + 12) of a 3x4 matrix (column 3 the translation).
 * mesh_prim_base[m] is mesh m's first triangle in the scene's per-triangle
 * arrays (BvhInstance.prim_base). Instances with a singular or non-finite
 * transform are dropped and counted. Returns 0, or SPT_EXIT_INPUT (tlas left
 * empty, e filled) for a mesh index out of range or a scene too large. */
int tlas_build(Tlas *tlas, const Bvh *meshes, const uint32_t *mesh_prim_base, uint32_t mesh_count,
               const float *xf, const uint32_t *inst_mesh, uint32_t inst_count, SptError *e);

/* The light selection's per-instance term (docs/architecture.md,
 * "Instances"): for each instance k of tl, the sum over its mesh's triangles
 * of weight[m][t] (per input triangle of mesh m, 0 for one that does not
 * emit; NULL for a mesh with no emitter) times the triangle's world-space
 * area under the instance's transform, into power[k]. Triangles of weight 0
 * cost nothing, so a scene's work is its instances times their meshes'
 * emitting triangles, and its storage one number per instance. */
void tlas_emitter_power(const Tlas *tl, const Bvh *meshes, const float *const *weight, double *power);

/* Triangle (a, b, c) of a mesh placed by instance in, computed in double:
 * returns its world-space area; lo and hi (3 doubles each, NULL: not
 * wanted) grow to hold its vertices; n (NULL: not wanted) gets its unit
 * world-space face normal as the renderer faces it (the placed winding's,
 * negated for a mirrored instance), 0 for a degenerate triangle. */
double tlas_placed_tri(const BvhInstance *in, vec3 a, vec3 b, vec3 c, double *lo, double *hi, double *n);

/* Frees what tlas_build allocated and zeroes tlas; safe on a zeroed Tlas. */
void tlas_free(Tlas *tlas);

#endif
