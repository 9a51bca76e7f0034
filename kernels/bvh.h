/* Bounding volume hierarchy on the device: the node and triangle layouts the host
 * builder (src/bvh.c) writes, and the traversal. Valid C99 and OpenCL C 1.2, so the
 * host tests and benchmarks run exactly the code the kernels run.
 *
 * Layout: a flat array of 128-byte 4-wide nodes (the binary SAH tree of
 * src/bvh.c gathered, each node taking up to four of its largest descendants),
 * depth first, node 0 the root. A node stores its children's boxes as structure
 * of arrays, bounds[2 a + 0] = the four low and bounds[2 a + 1] = the four high
 * coordinates along axis a, so one child test is a handful of float4
 * operations. Child i is a leaf of count[i] > 0 triangles starting at packed
 * triangle child[i], or when count[i] == 0 the node child[i] (> 0); an unused
 * slot has count 0 and an empty box (low +FLT_MAX, high -FLT_MAX) that no ray
 * enters. Triangles are packed in leaf order as 9 floats (v0, v1, v2).
 *
 * Depth: the binary tree is never deeper than BVH_MAX_DEPTH - 1 and gathering
 * never deepens it, and a node pushes at most 3 children, so the traversal
 * stack of BVH_STACK_SIZE entries cannot overflow. (On GPUs this 2.3 KB
 * private stack lives in slow memory; a shorter stack with a restart would
 * suit them better.)
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
#if !SPT_DEVICE && defined(__SSE2__)
#include <emmintrin.h>
#endif

/* Deepest binary node depth + 1 (the builder's bound) and the traversal stack
 * size (see the header comment). */
#define BVH_MAX_DEPTH 64
#define BVH_WIDTH 4
#define BVH_STACK_SIZE (3 * BVH_MAX_DEPTH + 1)
/* FLT_MAX, a sort key beyond every entry distance (those are <= tmax). */
#define BVH_FAR 3.402823466e+38f

typedef struct BvhNode {
    float bounds[6][BVH_WIDTH]; /* [2 a] low, [2 a + 1] high along axis a, per child */
    spt_u32 child[BVH_WIDTH];   /* a node index, or a leaf's first triangle */
    spt_u32 count[BVH_WIDTH];   /* leaf: its triangle count; 0: a node (or unused) */
} BvhNode;

/* One triangle, packed: v0, v1, v2 (world space). */
typedef struct BvhTri {
    float v[9];
} BvhTri;

SPT_STATIC_ASSERT(sizeof(BvhNode) == 128, "BvhNode must stay 128 bytes (device layout)");
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
    int nx, ny, nz; /* per axis, the row of BvhNode.bounds with the near planes */
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
    /* Along an axis the ray runs down, a box's high plane is the near one. */
    r->nx = r->ix < 0.0f ? 1 : 0;
    r->ny = r->iy < 0.0f ? 3 : 2;
    r->nz = r->iz < 0.0f ? 5 : 4;
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

#if SPT_DEVICE
SPT_FN vec4 bvh_v4_load(const SPT_GLOBAL float *p) { return vload4(0, p); }
/* Compare-based like the host's, without fmin's NaN handling: no operand of the
 * box test can be NaN (finite boxes and origins, finite non-zero reciprocals). */
SPT_FN vec4 bvh_v4_min(vec4 a, vec4 b) { return select(b, a, a < b); }
SPT_FN vec4 bvh_v4_max(vec4 a, vec4 b) { return select(b, a, a > b); }
#else
SPT_FN vec4 bvh_v4_load(const float *p) { return v4(p[0], p[1], p[2], p[3]); }
SPT_FN vec4 bvh_v4_min(vec4 a, vec4 b)
{
    return v4(BVH_MIN(a.x, b.x), BVH_MIN(a.y, b.y), BVH_MIN(a.z, b.z), BVH_MIN(a.w, b.w));
}
SPT_FN vec4 bvh_v4_max(vec4 a, vec4 b)
{
    return v4(BVH_MAX(a.x, b.x), BVH_MAX(a.y, b.y), BVH_MAX(a.z, b.z), BVH_MAX(a.w, b.w));
}
#endif

/* Entry distances of the ray into node n's four child boxes: lane i is child i's
 * entry distance if its box overlaps [0, tbest], else -1. Far distances are
 * widened by 1 + 2 gamma(3) (Ize 2013, "Robust BVH Ray Traversal") so rounding
 * never culls a box the triangle test would hit. */
SPT_FN vec4 bvh_node_enter(const SPT_GLOBAL BvhNode *n, const BvhRay *r, float tbest)
{
#if !SPT_DEVICE && defined(__SSE2__)
    /* The same operations lane for lane in SSE (minps/maxps are a < b ? a : b
     * and a > b ? a : b, like bvh_v4_min/max), for host traversal speed. */
    __m128 ox = _mm_set1_ps(r->ox), oy = _mm_set1_ps(r->oy), oz = _mm_set1_ps(r->oz);
    __m128 ix = _mm_set1_ps(r->ix), iy = _mm_set1_ps(r->iy), iz = _mm_set1_ps(r->iz);
    __m128 tnx = _mm_mul_ps(_mm_sub_ps(_mm_loadu_ps(n->bounds[r->nx]), ox), ix);
    __m128 tfx = _mm_mul_ps(_mm_sub_ps(_mm_loadu_ps(n->bounds[r->nx ^ 1]), ox), ix);
    __m128 tny = _mm_mul_ps(_mm_sub_ps(_mm_loadu_ps(n->bounds[r->ny]), oy), iy);
    __m128 tfy = _mm_mul_ps(_mm_sub_ps(_mm_loadu_ps(n->bounds[r->ny ^ 1]), oy), iy);
    __m128 tnz = _mm_mul_ps(_mm_sub_ps(_mm_loadu_ps(n->bounds[r->nz]), oz), iz);
    __m128 tfz = _mm_mul_ps(_mm_sub_ps(_mm_loadu_ps(n->bounds[r->nz ^ 1]), oz), iz);
    __m128 tn = _mm_max_ps(_mm_max_ps(tnx, tny), _mm_max_ps(tnz, _mm_setzero_ps()));
    __m128 tf = _mm_mul_ps(_mm_min_ps(_mm_min_ps(tfx, tfy), tfz), _mm_set1_ps(1.00000036f));
    tf = _mm_min_ps(tf, _mm_set1_ps(tbest));
    __m128 in = _mm_cmple_ps(tn, tf);
    __m128 d = _mm_or_ps(_mm_and_ps(in, tn), _mm_andnot_ps(in, _mm_set1_ps(-1.0f)));
    float out[4];
    _mm_storeu_ps(out, d);
    return v4(out[0], out[1], out[2], out[3]);
#else
    vec4 tnx = v4_scale(v4_sub(bvh_v4_load(n->bounds[r->nx]), v4_splat(r->ox)), r->ix);
    vec4 tfx = v4_scale(v4_sub(bvh_v4_load(n->bounds[r->nx ^ 1]), v4_splat(r->ox)), r->ix);
    vec4 tny = v4_scale(v4_sub(bvh_v4_load(n->bounds[r->ny]), v4_splat(r->oy)), r->iy);
    vec4 tfy = v4_scale(v4_sub(bvh_v4_load(n->bounds[r->ny ^ 1]), v4_splat(r->oy)), r->iy);
    vec4 tnz = v4_scale(v4_sub(bvh_v4_load(n->bounds[r->nz]), v4_splat(r->oz)), r->iz);
    vec4 tfz = v4_scale(v4_sub(bvh_v4_load(n->bounds[r->nz ^ 1]), v4_splat(r->oz)), r->iz);
    vec4 tn = bvh_v4_max(bvh_v4_max(tnx, tny), bvh_v4_max(tnz, v4_splat(0.0f)));
    vec4 tf = v4_scale(bvh_v4_min(bvh_v4_min(tfx, tfy), tfz), 1.00000036f);
    tf = bvh_v4_min(tf, v4_splat(tbest));
#if SPT_DEVICE
    return select((float4)(-1.0f), tn, tn <= tf);
#else
    return v4(tn.x <= tf.x ? tn.x : -1.0f, tn.y <= tf.y ? tn.y : -1.0f,
              tn.z <= tf.z ? tn.z : -1.0f, tn.w <= tf.w ? tn.w : -1.0f);
#endif
#endif
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

/* Orders the (distance, slot) pairs (ka, sa) and (kb, sb) by distance, without
 * branches. */
#define BVH_SWAP_IF(ka, sa, kb, sb)                                              \
    do {                                                                         \
        int sw_ = (kb) < (ka);                                                   \
        float kt_ = sw_ ? (kb) : (ka);                                           \
        int st_ = sw_ ? (sb) : (sa);                                             \
        (kb) = sw_ ? (ka) : (kb);                                                \
        (sb) = sw_ ? (sa) : (sb);                                                \
        (ka) = kt_;                                                              \
        (sa) = st_;                                                              \
    } while (0)

/* The traversal behind bvh_intersect (any_hit 0: closest hit) and bvh_occluded
 * (any_hit 1: stops at the first hit). The children a ray enters are visited
 * nearest first, the others deferred on the stack and skipped when their entry
 * distance is beyond the best hit. */
SPT_FN int bvh_traverse(const SPT_GLOBAL BvhNode *nodes, const SPT_GLOBAL BvhTri *tris,
                        vec3 org, vec3 dir, float tmax, int any_hit, BvhHit *hit)
{
    BvhRay r;
    bvh_ray_init(&r, org, dir);
    float best = tmax;
    int found = 0;
    spt_u32 stack_child[BVH_STACK_SIZE], stack_count[BVH_STACK_SIZE];
    float stack_t[BVH_STACK_SIZE];
    int sp = 0;
    /* The current item: node cur (count 0) or the leaf of count triangles
     * from cur. */
    spt_u32 cur = 0, count = 0;
    for (;;) {
        if (count) {
            for (spt_u32 i = cur; i < cur + count; i++) {
                if (bvh_tri_intersect(tris, i, &r, best, hit)) {
                    best = hit->t;
                    found = 1;
                    if (any_hit)
                        return 1;
                }
            }
        } else {
            const SPT_GLOBAL BvhNode *n = &nodes[cur];
            vec4 d4 = bvh_node_enter(n, &r, best);
            /* Sort the slots by entry distance, misses (-1) last as +big, with
             * a 4-input sorting network of conditional swaps. */
            float k0 = d4.x >= 0.0f ? d4.x : BVH_FAR, k1 = d4.y >= 0.0f ? d4.y : BVH_FAR;
            float k2 = d4.z >= 0.0f ? d4.z : BVH_FAR, k3 = d4.w >= 0.0f ? d4.w : BVH_FAR;
            int nh = (d4.x >= 0.0f) + (d4.y >= 0.0f) + (d4.z >= 0.0f) + (d4.w >= 0.0f);
            int s0 = 0, s1 = 1, s2 = 2, s3 = 3;
            BVH_SWAP_IF(k0, s0, k1, s1);
            BVH_SWAP_IF(k2, s2, k3, s3);
            BVH_SWAP_IF(k0, s0, k2, s2);
            BVH_SWAP_IF(k1, s1, k3, s3);
            BVH_SWAP_IF(k1, s1, k2, s2);
            if (nh > 0) {
                /* Defer all but the nearest, farthest first. */
                if (nh > 3) {
                    stack_child[sp] = n->child[s3]; stack_count[sp] = n->count[s3];
                    stack_t[sp++] = k3;
                }
                if (nh > 2) {
                    stack_child[sp] = n->child[s2]; stack_count[sp] = n->count[s2];
                    stack_t[sp++] = k2;
                }
                if (nh > 1) {
                    stack_child[sp] = n->child[s1]; stack_count[sp] = n->count[s1];
                    stack_t[sp++] = k1;
                }
                cur = n->child[s0];
                count = n->count[s0];
                continue;
            }
        }
        /* Next: the nearest deferred item the best hit does not rule out. */
        for (;;) {
            if (sp == 0)
                return found;
            sp--;
            if (stack_t[sp] <= best) {
                cur = stack_child[sp];
                count = stack_count[sp];
                break;
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
