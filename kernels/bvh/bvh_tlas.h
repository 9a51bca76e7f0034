/* Two-level ray queries: a top-level BVH over instances, each a mesh's own
 * bottom-level BVH (kernels/bvh/bvh.h) placed by a 3x4 transform, so a mesh
 * used many times is stored once (Cycles, Mitsuba 3 through Embree and
 * OptiX, and pbrt-v4 render instances this way). Valid C99 and OpenCL C 1.2;
 * the host builds the levels (src/accel/tlas_build.c).
 *
 * Layout: the top level is an array of BvhNode (kernels/bvh/bvh_node.h) over
 * the instances' world-space boxes, whose leaf slots have count 1 and child
 * the instance's index in the instance array (the tree's order). Every
 * mesh's bottom level is an ordinary BVH; their nodes lie one after another
 * in one node array and their leaf blocks in one word array, an instance
 * naming where its mesh's begin (node_base, tri_base: the mesh's node and
 * word indices stay relative to those), and prim_base, the mesh's first
 * triangle in the scene's per-triangle arrays.
 *
 * At a leaf of the top level the ray goes into the instance's space, o' =
 * inv (o, 1) and d' = inv (d, 0), and runs the mesh's query there; d' is not
 * normalised, so a hit's t is the same parameter along the world-space ray
 * (up to the rounding of the transform), and the best t carries across
 * instances unchanged. The hit's normals go back with the inverse transpose
 * (inv's rows are its columns); an instance whose transform mirrors
 * (negative determinant, BVH_INSTANCE_MIRRORED) reverses its triangles'
 * winding, as glTF says for nodes with a negative scale.
 *
 * Private memory: the top level runs the short stack of
 * kernels/bvh/bvh_short_stack.h on every path (its trail bounds its levels
 * as it does a mesh's), and the bottom level what bvh_traverse runs there
 * (the full stack on CPUs, the short one with SPT_BVH_SHORT_STACK), so a
 * GPU-shaped query holds two short stacks' state, 2 x 312 bytes (one full
 * stack's state is 5.5 KB). */
#ifndef SPT_KERNELS_BVH_TLAS_H
#define SPT_KERNELS_BVH_TLAS_H

#include "util/portable.h"
#include "util/vecmath.h"
#include "bvh/bvh.h"
#include "bvh/bvh_node.h"
#include "bvh/bvh_short_stack.h"

/* BvhInstance.flags: the transform's determinant is negative. */
#define BVH_INSTANCE_MIRRORED 1u

/* One instance of a mesh: xf maps its space to the world (rows of a 3x4
 * matrix, xf[4 r + c], column 3 the translation), inv the world to its space. */
typedef struct BvhInstance {
    float xf[12];
    float inv[12];
    spt_u32 node_base; /* its mesh's first node in the bottom levels' node array */
    spt_u32 tri_base;  /* its mesh's first word in their leaf blocks */
    spt_u32 prim_base; /* its mesh's first triangle in the scene's triangles */
    spt_u32 flags;     /* BVH_INSTANCE_MIRRORED */
} BvhInstance;

SPT_STATIC_ASSERT(sizeof(BvhInstance) == 112, "BvhInstance must stay 112 bytes (device layout)");

/* A two-level hit: the mesh's hit (prim counted from the instance's
 * prim_base, t along the world-space ray) and the instance. */
typedef struct BvhInstHit {
    BvhHit h;
    spt_u32 inst;
} BvhInstHit;

/* The point p (w 1) or direction (w 0) through the rows m of a 3x4 matrix. */
SPT_FN vec3 bvh_xf_apply(const SPT_GLOBAL float *m, vec3 p, float w)
{
#if SPT_DEVICE
#pragma OPENCL FP_CONTRACT OFF
#endif
    return v3(m[0] * p.x + m[1] * p.y + m[2] * p.z + m[3] * w,
              m[4] * p.x + m[5] * p.y + m[6] * p.z + m[7] * w,
              m[8] * p.x + m[9] * p.y + m[10] * p.z + m[11] * w);
}

/* A normal n of instance space in world space (unnormalised): the inverse
 * transpose, whose rows are inv's columns. */
SPT_FN vec3 bvh_xf_normal(const SPT_GLOBAL BvhInstance *in, vec3 n)
{
#if SPT_DEVICE
#pragma OPENCL FP_CONTRACT OFF
#endif
    const SPT_GLOBAL float *m = in->inv;
    return v3(m[0] * n.x + m[4] * n.y + m[8] * n.z, m[1] * n.x + m[5] * n.y + m[9] * n.z,
              m[2] * n.x + m[6] * n.y + m[10] * n.z);
}

/* The query of instance k's mesh for the world-space ray (org, dir) below
 * *best: on a hit, *best and hit are updated (prim counted from prim_base)
 * and 1 is returned. */
SPT_FN int bvh_instance_query(const SPT_GLOBAL BvhInstance *inst, spt_u32 k,
                              const SPT_GLOBAL BvhNode *nodes, const SPT_GLOBAL float *tris,
                              vec3 org, vec3 dir, float *best, int any_hit, BvhInstHit *hit)
{
    const SPT_GLOBAL BvhInstance *in = &inst[k];
    vec3 o = bvh_xf_apply(in->inv, org, 1.0f), d = bvh_xf_apply(in->inv, dir, 0.0f);
    BvhHit h;
    if (!bvh_traverse(nodes + in->node_base, tris + in->tri_base, o, d, *best, any_hit, &h))
        return 0;
    *best = h.t;
    hit->h = h;
    hit->h.prim = h.prim + in->prim_base;
    hit->inst = k;
    return 1;
}

/* The two-level traversal of the ray org + t dir, t in (0, tmax): closest hit
 * (any_hit 0) or any hit (1), with a top-level stack of cap entries
 * (1 .. BVH_SHORT_STACK_SIZE; tests force restarts with small ones).
 * Returns 1 and fills hit when it found one. A top level with no instances
 * (a root without children) always misses. */
SPT_FN int bvh_tlas_traverse_cap(const SPT_GLOBAL BvhNode *top, const SPT_GLOBAL BvhInstance *inst,
                                 const SPT_GLOBAL BvhNode *nodes, const SPT_GLOBAL float *tris,
                                 vec3 org, vec3 dir, float tmax, int any_hit, int cap,
                                 BvhInstHit *hit)
{
    BvhShort s;
    bvh_short_init(&s, org, dir, tmax);
    for (;;) {
        int more;
        if (s.count) {
            if (bvh_instance_query(inst, s.cur, nodes, tris, org, dir, &s.best, any_hit, hit)) {
                s.found = 1;
                if (any_hit)
                    break;
            }
            more = bvh_short_pop(&s);
        } else {
            more = bvh_short_node(top, &s, cap);
            if (more < 0)
                more = bvh_short_pop(&s);
        }
        if (!more)
            break;
    }
    return s.found;
}

/* Closest hit over the instances (bvh_intersect's contract, two levels). */
SPT_FN int bvh_tlas_intersect(const SPT_GLOBAL BvhNode *top, const SPT_GLOBAL BvhInstance *inst,
                              const SPT_GLOBAL BvhNode *nodes, const SPT_GLOBAL float *tris,
                              vec3 org, vec3 dir, float tmax, BvhInstHit *hit)
{
    return bvh_tlas_traverse_cap(top, inst, nodes, tris, org, dir, tmax, 0, BVH_SHORT_STACK_SIZE,
                                 hit);
}

/* 1 when any instance's triangle is hit with t in (0, tmax) (shadow rays). */
SPT_FN int bvh_tlas_occluded(const SPT_GLOBAL BvhNode *top, const SPT_GLOBAL BvhInstance *inst,
                             const SPT_GLOBAL BvhNode *nodes, const SPT_GLOBAL float *tris,
                             vec3 org, vec3 dir, float tmax)
{
    BvhInstHit h;
    return bvh_tlas_traverse_cap(top, inst, nodes, tris, org, dir, tmax, 1, BVH_SHORT_STACK_SIZE,
                                 &h);
}

#endif
