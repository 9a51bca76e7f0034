/* Bounding volume hierarchy on the device: the node and triangle layouts the host
 * builder (src/bvh.c) writes, and the traversal. Valid C99 and OpenCL C 1.2, so the
 * host tests and benchmarks run exactly the code the kernels run.
 *
 * Layout: a flat array of 32-byte binary nodes. Node 0 is the root and node 1 is
 * unused; the two children of an interior node are the adjacent pair at
 * [offset, offset + 1] (offset even, so with a 64-byte aligned buffer both child
 * boxes arrive in one cache line), pairs laid out depth first. A leaf holds the
 * contiguous triangles [offset, offset + count). Triangles are packed in leaf
 * order as 9 floats (v0, v1, v2).
 *
 * Depth: the builder never makes a node deeper than BVH_MAX_DEPTH - 1 (root =
 * depth 0), so the traversal stack of BVH_MAX_DEPTH entries cannot overflow: a
 * node at depth d has at most d deferred siblings on the stack.
 *
 * Ray-triangle test: watertight (Woop, Benthin and Wald 2013, "Watertight
 * Ray/Triangle Intersection"): a ray cannot pass between two triangles that share
 * an edge, as long as a*b - c*d is not contracted into a fused multiply-add. The
 * test disables contraction with FP_CONTRACT; a program built with
 * -cl-mad-enable or -cl-fast-relaxed-math may still fuse, which re-opens
 * pinholes of about one ulp along shared edges.
 *
 * Rays: org and dir need not be normalised; t is in units of dir. tmax must be
 * finite (use e.g. 1e30f instead of INFINITY, which fast-math builds assume away). */
#ifndef SPT_KERNELS_BVH_H
#define SPT_KERNELS_BVH_H

#include "shared.h"
#include "vecmath.h"

/* Deepest node depth + 1 and the traversal stack size (see the header comment). */
#define BVH_MAX_DEPTH 64
#define BVH_STACK_SIZE BVH_MAX_DEPTH
/* Marks a leaf in BvhNode.count; the low bits are its triangle count. */
#define BVH_LEAF_BIT 0x80000000u

typedef struct BvhNode {
    float lo[3];
    spt_u32 offset; /* interior: index of the first child (the second follows it);
                       leaf: first triangle */
    float hi[3];
    spt_u32 count;  /* leaf: BVH_LEAF_BIT | triangle count; interior: 0 */
} BvhNode;

/* One triangle, packed: v0, v1, v2 (world space). */
typedef struct BvhTri {
    float v[9];
} BvhTri;

SPT_STATIC_ASSERT(sizeof(BvhNode) == 32, "BvhNode must stay 32 bytes (device layout)");
SPT_STATIC_ASSERT(sizeof(BvhTri) == 36, "BvhTri must stay 36 bytes (device layout)");

/* A closest hit: distance t along dir, barycentrics such that the point is
 * (1-u-v) v0 + u v1 + v v2, and prim = index of the packed triangle. */
typedef struct BvhHit {
    float t, u, v;
    spt_u32 prim;
} BvhHit;

/* Per-ray constants of the traversal: origin, safe reciprocal direction, and the
 * shear of the watertight test (kz = the dominant axis of dir). */
typedef struct BvhRay {
    float ox, oy, oz;
    float ix, iy, iz;
    int kx, ky, kz;
    float okx, oky, okz; /* the origin permuted to (kx, ky, kz) */
    float sx, sy, sz;
} BvhRay;

/* The three vertices of packed triangle i. */
SPT_FN void bvh_tri_vertices(const SPT_GLOBAL BvhTri *tris, spt_u32 i, vec3 *v0, vec3 *v1,
                             vec3 *v2)
{
    const SPT_GLOBAL float *p = tris[i].v;
    *v0 = v3(p[0], p[1], p[2]);
    *v1 = v3(p[3], p[4], p[5]);
    *v2 = v3(p[6], p[7], p[8]);
}

/* min/max for the box test: the device's fmin/fmax are instructions, while on the
 * host fminf/fmaxf are library calls unless -ffast-math, so use compares there.
 * A NaN operand may make a box count as hit, never a triangle. */
#if SPT_DEVICE
#define BVH_MIN(a, b) fmin(a, b)
#define BVH_MAX(a, b) fmax(a, b)
#else
SPT_FN float bvh_min_(float a, float b) { return a < b ? a : b; }
SPT_FN float bvh_max_(float a, float b) { return a > b ? a : b; }
#define BVH_MIN(a, b) bvh_min_(a, b)
#define BVH_MAX(a, b) bvh_max_(a, b)
#endif

/* 1/d with |d| clamped away from 0, so the slab test never forms 0 * inf. */
SPT_FN float bvh_safe_rcp(float d)
{
    return 1.0f / (fabsf(d) > 1e-30f ? d : copysignf(1e-30f, d));
}

/* Precomputes r for a ray (org, dir); dir must be non-zero. */
SPT_FN void bvh_ray_init(BvhRay *r, vec3 org, vec3 dir)
{
    float d[3];
    d[0] = dir.x; d[1] = dir.y; d[2] = dir.z;
    r->ox = org.x; r->oy = org.y; r->oz = org.z;
    r->ix = bvh_safe_rcp(dir.x);
    r->iy = bvh_safe_rcp(dir.y);
    r->iz = bvh_safe_rcp(dir.z);
    float ax = fabsf(dir.x), ay = fabsf(dir.y), az = fabsf(dir.z);
    int kz = (ax >= ay && ax >= az) ? 0 : (ay >= az ? 1 : 2);
    int kx = kz == 2 ? 0 : kz + 1;
    int ky = kx == 2 ? 0 : kx + 1;
    /* Swapping kx and ky keeps the winding of the sheared triangle. */
    if (d[kz] < 0.0f) { int tmp = kx; kx = ky; ky = tmp; }
    r->kx = kx; r->ky = ky; r->kz = kz;
    float o[3];
    o[0] = org.x; o[1] = org.y; o[2] = org.z;
    r->okx = o[kx]; r->oky = o[ky]; r->okz = o[kz];
    r->sz = 1.0f / d[kz];
    r->sx = d[kx] * r->sz;
    r->sy = d[ky] * r->sz;
}

/* Entry distance of the ray into node n's box if it overlaps [0, tbest], else -1.
 * Far distances are widened by 1 + 2 gamma(3) (Ize 2013, "Robust BVH Ray
 * Traversal") so rounding never culls a box the triangle test would hit. */
SPT_FN float bvh_box_enter(const SPT_GLOBAL BvhNode *n, const BvhRay *r, float tbest)
{
    float x0 = (n->lo[0] - r->ox) * r->ix, x1 = (n->hi[0] - r->ox) * r->ix;
    float y0 = (n->lo[1] - r->oy) * r->iy, y1 = (n->hi[1] - r->oy) * r->iy;
    float z0 = (n->lo[2] - r->oz) * r->iz, z1 = (n->hi[2] - r->oz) * r->iz;
    float tn = BVH_MAX(BVH_MAX(BVH_MIN(x0, x1), BVH_MIN(y0, y1)), BVH_MAX(BVH_MIN(z0, z1), 0.0f));
    float tf = BVH_MIN(BVH_MIN(BVH_MAX(x0, x1), BVH_MAX(y0, y1)), BVH_MAX(z0, z1)) * 1.00000036f;
    tf = BVH_MIN(tf, tbest);
    return tn <= tf ? tn : -1.0f;
}

/* Watertight test of packed triangle i: on a hit with t in (0, tbest) writes hit
 * and returns 1, else returns 0 and leaves hit alone. */
SPT_FN int bvh_tri_intersect(const SPT_GLOBAL BvhTri *tris, spt_u32 i, const BvhRay *r,
                             float tbest, BvhHit *hit)
{
#if SPT_DEVICE
#pragma OPENCL FP_CONTRACT OFF
#endif
    const SPT_GLOBAL float *p = tris[i].v;
    int kx = r->kx, ky = r->ky, kz = r->kz;
    float okx = r->okx, oky = r->oky, okz = r->okz;
    float az = p[kz] - okz, bz = p[3 + kz] - okz, cz = p[6 + kz] - okz;
    float ax = (p[kx] - okx) - r->sx * az;
    float ay = (p[ky] - oky) - r->sy * az;
    float bx = (p[3 + kx] - okx) - r->sx * bz;
    float by = (p[3 + ky] - oky) - r->sy * bz;
    float cx = (p[6 + kx] - okx) - r->sx * cz;
    float cy = (p[6 + ky] - oky) - r->sy * cz;
    float eu = cx * by - cy * bx;
    float ev = ax * cy - ay * cx;
    float ew = bx * ay - by * ax;
    if ((eu < 0.0f || ev < 0.0f || ew < 0.0f) && (eu > 0.0f || ev > 0.0f || ew > 0.0f))
        return 0;
    float det = eu + ev + ew;
    if (det == 0.0f)
        return 0;
    /* Normalising before the sum keeps t finite for coordinates up to 1e18, where
     * the paper's unnormalised T = U az + V bz + W cz would overflow. */
    float rcp = 1.0f / det;
    float w0 = eu * rcp, w1 = ev * rcp, w2 = ew * rcp;
    float t = (w0 * az + w1 * bz + w2 * cz) * r->sz;
    if (!(t > 0.0f && t < tbest))
        return 0;
    hit->t = t;
    hit->u = w1;
    hit->v = w2;
    hit->prim = i;
    return 1;
}

/* The traversal behind bvh_intersect (any_hit 0: closest hit) and bvh_occluded
 * (any_hit 1: stops at the first hit). Children are visited nearer first and a
 * deferred child is skipped when its entry distance is beyond the best hit. */
SPT_FN int bvh_traverse(const SPT_GLOBAL BvhNode *nodes, const SPT_GLOBAL BvhTri *tris,
                        vec3 org, vec3 dir, float tmax, int any_hit, BvhHit *hit)
{
    BvhRay r;
    bvh_ray_init(&r, org, dir);
    float best = tmax;
    int found = 0;
    spt_u32 stack_node[BVH_STACK_SIZE];
    float stack_t[BVH_STACK_SIZE];
    int sp = 0;
    spt_u32 idx = 0;
    if (bvh_box_enter(&nodes[0], &r, best) < 0.0f)
        return 0;
    for (;;) {
        const SPT_GLOBAL BvhNode *n = &nodes[idx];
        spt_u32 count = n->count;
        int descend = 0;
        if (count & BVH_LEAF_BIT) {
            spt_u32 first = n->offset, end = first + (count & ~BVH_LEAF_BIT);
            for (spt_u32 i = first; i < end; i++) {
                if (bvh_tri_intersect(tris, i, &r, best, hit)) {
                    best = hit->t;
                    found = 1;
                    if (any_hit)
                        return 1;
                }
            }
        } else {
            spt_u32 c0 = n->offset, c1 = c0 + 1;
            float d0 = bvh_box_enter(&nodes[c0], &r, best);
            float d1 = bvh_box_enter(&nodes[c1], &r, best);
            if (d0 >= 0.0f && d1 >= 0.0f) {
                /* Both: go to the nearer, defer the other. */
                if (d1 < d0) { spt_u32 tc = c0; c0 = c1; c1 = tc; float td = d0; d0 = d1; d1 = td; }
                stack_node[sp] = c1;
                stack_t[sp] = d1;
                sp++;
                idx = c0;
                descend = 1;
            } else if (d0 >= 0.0f) {
                idx = c0;
                descend = 1;
            } else if (d1 >= 0.0f) {
                idx = c1;
                descend = 1;
            }
        }
        while (!descend) {
            if (sp == 0)
                return found;
            sp--;
            if (stack_t[sp] <= best) {
                idx = stack_node[sp];
                descend = 1;
            }
        }
    }
}

/* Closest hit of the ray org + t dir with t in (0, tmax): returns 1 and fills hit,
 * or returns 0 (hit untouched) on a miss. An empty scene always misses. */
SPT_FN int bvh_intersect(const SPT_GLOBAL BvhNode *nodes, const SPT_GLOBAL BvhTri *tris,
                         vec3 org, vec3 dir, float tmax, BvhHit *hit)
{
    return bvh_traverse(nodes, tris, org, dir, tmax, 0, hit);
}

/* 1 when any triangle is hit with t in (0, tmax) (shadow rays), else 0. */
SPT_FN int bvh_occluded(const SPT_GLOBAL BvhNode *nodes, const SPT_GLOBAL BvhTri *tris,
                        vec3 org, vec3 dir, float tmax)
{
    BvhHit h;
    return bvh_traverse(nodes, tris, org, dir, tmax, 1, &h);
}

#endif
