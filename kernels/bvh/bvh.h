/* The ray queries of the BVH (kernels/bvh/bvh_node.h has its layout and the
 * steps of a traversal): closest hit, two closest hits at once, any hit. Valid
 * C99 and OpenCL C 1.2. With SPT_BVH_SHORT_STACK (the kernels' GPU path) a
 * query runs the short-stack traversal of kernels/bvh/bvh_short_stack.h, else
 * the full stack's bvh_trav_step. */
#ifndef SPT_KERNELS_BVH_H
#define SPT_KERNELS_BVH_H

#include "util/portable.h"
#include "util/vecmath.h"
#include "bvh/bvh_node.h"
#include "bvh/bvh_short_stack.h"

/* The traversal of one ray: returns 1 and fills hit when it found a hit. With
 * SPT_BVH_SHORT_STACK (the kernels' GPU path) the short stack, else the full
 * one. */
SPT_FN int bvh_traverse(const SPT_GLOBAL BvhNode *nodes, const SPT_GLOBAL float *tris,
                        vec3 org, vec3 dir, float tmax, int any_hit, BvhHit *hit)
{
#if defined(SPT_BVH_SHORT_STACK)
    return bvh_traverse_short(nodes, tris, org, dir, tmax, any_hit, BVH_SHORT_STACK_SIZE, hit);
#else
    BvhTrav s;
    bvh_trav_init(&s, org, dir, tmax);
    while (bvh_trav_step(nodes, tris, &s, any_hit))
        ;
    if (s.found)
        *hit = s.hit;
    return s.found;
#endif
}

/* Closest hit of the ray org + t dir with t in (0, tmax): returns 1 and fills hit,
 * or returns 0 (hit untouched) on a miss. An empty scene always misses. */
SPT_FN int bvh_intersect(const SPT_GLOBAL BvhNode *nodes, const SPT_GLOBAL float *tris,
                         vec3 org, vec3 dir, float tmax, BvhHit *hit)
{
    return bvh_traverse(nodes, tris, org, dir, tmax, 0, hit);
}

/* Closest hits of two rays at once (on CPUs): their traversals advance a step
 * each in turn, so the memory waits of one overlap the work of the other (a CPU
 * runs a work-item's code in order, and a ray's node loads depend on each
 * other; GPUs hide that latency with other work-items instead). Each result is
 * bvh_intersect's for that ray, bit for bit: found[k] is 1 when ray k hit, and
 * then hit[k] holds its hit. */
SPT_FN void bvh_intersect2(const SPT_GLOBAL BvhNode *nodes, const SPT_GLOBAL float *tris,
                           vec3 org0, vec3 dir0, vec3 org1, vec3 dir1, float tmax,
                           int found[2], BvhHit hit[2])
{
    BvhTrav a, b;
    bvh_trav_init(&a, org0, dir0, tmax);
    bvh_trav_init(&b, org1, dir1, tmax);
    int more_a = 1, more_b = 1;
    while (more_a | more_b) {
        if (more_a)
            more_a = bvh_trav_step(nodes, tris, &a, 0);
        if (more_b)
            more_b = bvh_trav_step(nodes, tris, &b, 0);
    }
    found[0] = a.found;
    found[1] = b.found;
    if (a.found)
        hit[0] = a.hit;
    if (b.found)
        hit[1] = b.hit;
}

/* 1 when any triangle is hit with t in (0, tmax) (shadow rays), else 0. */
SPT_FN int bvh_occluded(const SPT_GLOBAL BvhNode *nodes, const SPT_GLOBAL float *tris,
                        vec3 org, vec3 dir, float tmax)
{
    BvhHit h;
    return bvh_traverse(nodes, tris, org, dir, tmax, 1, &h);
}

#endif
