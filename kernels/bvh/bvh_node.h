/* Bounding volume hierarchy on the device: the node and triangle layouts the host
 * builder (src/accel/bvh_build.c) writes, the ray's node and leaf tests, and
 * the steps of the full-stack traversal (the queries built on them:
 * kernels/bvh/bvh.h). Valid C99 and OpenCL C 1.2, so the
 * host tests and benchmarks run exactly the code the kernels run.
 *
 * Layout: a flat array of 256-byte 8-wide nodes (the binary SAH tree of
 * src/accel/bvh_build.c gathered, each node taking up to eight of its largest descendants),
 * depth first, node 0 the root. A node stores its children's boxes as structure
 * of arrays, bounds[2 a + 0] = the eight low and bounds[2 a + 1] = the eight high
 * coordinates along axis a, so one test of all children is a handful of float8
 * operations. Eight-wide nodes make a ray's chain of dependent node loads about
 * a third shorter than four-wide ones did, and cost the same float8 test on
 * a CPU. Child i is a leaf when count[i] > 0: the block at word child[i] of
 * count[i] & 255 triangles with count[i] >> 8 distinct vertices (below), so
 * its loads need not wait for its header; when count[i] == 0 it is the node
 * child[i] (> 0); an unused
 * slot has count 0 and an empty box (low +FLT_MAX, high -FLT_MAX) that no ray
 * enters.
 *
 * Quantised nodes (SPT_BVH_QNODES, set by the host when it uploads them:
 * src/accel/bvh_build.h, bvh_qnodes_wanted): the same tree in 128-byte nodes
 * (BvhQNode), its children's boxes quantised (Ylitie, Karras and Laine 2017,
 * "Efficient Incoherent Ray Traversal on GPUs Through Compressed Wide
 * BVHs"): per axis a an origin org[a] and a power-of-two step 2^e (exp[a], the
 * biased exponent of the float 2^e), and per child a byte per plane, q[2 a]
 * the eight low and q[2 a + 1] the eight high planes along axis a. A plane is
 * org[a] + q 2^e computed in float (bvh_qplane; q 2^e is exact, so a fused
 * multiply-add rounds it the same), and the builder rounds each low plane
 * down and each high plane up in that very arithmetic, so every decoded box
 * contains its child's float box and the slab test is as conservative as on
 * float boxes: the closest hit is the same (only which of two hits at exactly
 * the same distance wins may change, as the visiting order may). Bit i of
 * used marks the slots that hold a child. Half the node bytes for two more
 * float8 operations per plane (docs/performance.md, "What sets the speed":
 * slower on CPU devices, so not their default).
 *
 * Triangles are packed in leaf order (packed triangle i, the prim of a hit, is
 * input triangle prim_index[i]), and each leaf is a block of 32-bit words in
 * the tris buffer: the leaf of n triangles at word b holds
 *   [b]      the packed index of its first triangle,
 *   [b + 1]  nv | n << 8, nv (<= BVH_LEAF_VERTS) its distinct vertices,
 *   [b + 2, b + 2 + 3 nv)  those vertices as structure of arrays: nv x, nv y,
 *            nv z coordinates,
 *   then 3 n bytes: byte c n + l is the vertex (0 .. nv - 1) of corner c of its
 *   triangle l,
 * bvh_leaf_words(n, nv) words in all. Sharing the vertices of a mesh's
 * neighbouring triangles makes a leaf about 2.4 times smaller than 9 floats per
 * triangle, and the random reads of incoherent rays miss the cache less. The
 * builder bounds the distinct vertices, so an x86 CPU (SPT_BVH_SIMD; AVX-512 or AVX2)
 * tests a leaf's triangles 16 (AVX-512) or 8 (AVX2) at a time, their corners
 * gathered from the 16-lane vertex rows by a permute, while a GPU, or the host, loops
 * over them with the same arithmetic lane by lane. A leaf's block may be
 * followed by BVH_TRI_PAD words of padding at the buffer's end, as the vector
 * loads of the last leaf read past it.
 *
 * Depth: the binary tree is never deeper than BVH_MAX_DEPTH - 1 and gathering
 * never deepens it, and a node pushes at most 7 children, so the traversal
 * stack of BVH_STACK_SIZE entries cannot overflow. That stack takes 5.4 KB
 * per ray: fine on a CPU (which traces two rays at once, with two stacks; PoCL
 * keeps those of a whole work-group on a thread's stack, so the kernels run in
 * groups of about 64), but on a GPU it would live in slow memory, so the GPU
 * path (SPT_BVH_SHORT_STACK) keeps a short stack and restarts from the root
 * when it overflowed (bvh_traverse_short).
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
#ifndef SPT_KERNELS_BVH_NODE_H
#define SPT_KERNELS_BVH_NODE_H

#include "util/portable.h"
#include "util/vecmath.h"
#if !SPT_DEVICE && defined(__SSE2__)
#include <emmintrin.h>
#endif

/* Deepest binary node depth + 1 (the builder's bound) and the traversal stack
 * size (see the header comment). */
#define BVH_MAX_DEPTH 64
#define BVH_WIDTH 8
#define BVH_STACK_SIZE ((BVH_WIDTH - 1) * BVH_MAX_DEPTH + 1)
/* FLT_MAX, a sort key beyond every entry distance (those are <= tmax). */
#define BVH_FAR 3.402823466e+38f

typedef struct BvhFNode {
    float bounds[6][BVH_WIDTH]; /* [2 a] low, [2 a + 1] high along axis a, per child */
    spt_u32 child[BVH_WIDTH];   /* a node index, or a leaf's first triangle */
    spt_u32 count[BVH_WIDTH];   /* leaf: triangles | distinct vertices << 8; 0: a node (or unused) */
} BvhFNode;

/* Most triangles and distinct vertices in one leaf (a 16-lane row), and the
 * words of padding after the last leaf block. */
#define BVH_LEAF_MAX 16
#define BVH_LEAF_VERTS 16
#define BVH_TRI_PAD 16

/* Words of the block of a leaf of n triangles with nv distinct vertices. */
#define bvh_leaf_words(n, nv) (2u + 3u * (nv) + (3u * (n) + 3u) / 4u)

/* The quantised node (see the header comment). */
typedef struct BvhQNode {
    float org[3];               /* per axis, the planes' origin */
    spt_u8 exp[3];              /* per axis, the biased float exponent of the planes' step */
    spt_u8 used;                /* bit i: slot i holds a child */
    spt_u8 q[6][BVH_WIDTH];     /* [2 a] low, [2 a + 1] high planes along axis a, per child */
    spt_u32 child[BVH_WIDTH];   /* as BvhFNode's */
    spt_u32 count[BVH_WIDTH];   /* as BvhFNode's */
} BvhQNode;

/* The smallest and largest biased exponents of a step: 255 steps of the
 * largest stay finite, and a step times a byte is never subnormal, so
 * q 2^e is exact. */
#define BVH_QEXP_MIN 1
#define BVH_QEXP_MAX 246

SPT_STATIC_ASSERT(sizeof(BvhFNode) == 256, "BvhFNode must stay 256 bytes (device layout)");
SPT_STATIC_ASSERT(sizeof(BvhQNode) == 128, "BvhQNode must stay 128 bytes (device layout)");

/* The node the traversal reads: the device's quantised nodes when the host
 * uploads them, else (and always on the host) the float ones. */
#if SPT_DEVICE && defined(SPT_BVH_QNODES)
typedef BvhQNode BvhNode;
#else
typedef BvhFNode BvhNode;
#endif
SPT_STATIC_ASSERT(bvh_leaf_words(BVH_LEAF_MAX, BVH_LEAF_VERTS) <= 64,
                  "bvh_prefetch's five requests cover leaf blocks of at most 64 words");

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

/* Word i of a leaf block, as an unsigned integer. */
SPT_FN spt_u32 bvh_word(const SPT_GLOBAL float *p, spt_u32 i)
{
#if SPT_DEVICE
    return as_uint(p[i]);
#else
    union { float f; spt_u32 u; } w;
    w.f = p[i];
    return w.u;
#endif
}

/* The step 2^e of a quantised node's planes along an axis, from its biased
 * exponent. */
SPT_FN float bvh_qstep(spt_u32 biased)
{
#if SPT_DEVICE
    return as_float(biased << 23);
#else
    union { float f; spt_u32 u; } w;
    w.u = biased << 23;
    return w.f;
#endif
}

/* The plane of byte q along an axis of origin org and step: the device's
 * decoding, lane for lane, and the one the builder rounds in. */
SPT_FN float bvh_qplane(float org, float step, spt_u32 q)
{
    return (float)q * step + org;
}

/* Child i's box of quantised node n as the traversal decodes it. */
SPT_FN void bvh_qnode_box(const SPT_GLOBAL BvhQNode *n, int i, float lo[3], float hi[3])
{
    for (int a = 0; a < 3; a++) {
        float step = bvh_qstep(n->exp[a]);
        lo[a] = bvh_qplane(n->org[a], step, n->q[2 * a][i]);
        hi[a] = bvh_qplane(n->org[a], step, n->q[2 * a + 1][i]);
    }
}

/* The three vertices of triangle l of the leaf block at p. */
SPT_FN void bvh_leaf_vertices(const SPT_GLOBAL float *p, spt_u32 l, vec3 *v0, vec3 *v1, vec3 *v2)
{
    spt_u32 nv = bvh_word(p, 1) & 255u, n = bvh_word(p, 1) >> 8;
    const SPT_GLOBAL float *v = p + 2;
    const SPT_GLOBAL spt_u8 *idx = (const SPT_GLOBAL spt_u8 *)(v + 3u * nv);
    spt_u32 a = idx[l], b = idx[n + l], c = idx[2u * n + l];
    *v0 = v3(v[a], v[nv + a], v[2u * nv + a]);
    *v1 = v3(v[b], v[nv + b], v[2u * nv + b]);
    *v2 = v3(v[c], v[nv + c], v[2u * nv + c]);
}

#if !SPT_DEVICE
/* min/max of the host's box test without SSE: compares, as the device's
 * selects (fminf/fmaxf are library calls unless -ffast-math). */
SPT_FN float bvh_min_(float a, float b) { return a < b ? a : b; }
SPT_FN float bvh_max_(float a, float b) { return a > b ? a : b; }
#endif

/* 1/d with |d| clamped away from 0, so the slab test never forms 0 * inf. */
SPT_FN float bvh_safe_rcp(float d)
{
    return 1.0f / (fabsf(d) > 1e-30f ? d : copysignf(1e-30f, d));
}

/* Precomputes r for a ray (org, dir); dir must be non-zero. Inlined: called
 * from several traversals, it would otherwise become a call whose BvhRay goes
 * through memory (docs/performance.md, "Instances: two levels"). */
SPT_FN_INLINE void bvh_ray_init(BvhRay *r, vec3 org, vec3 dir)
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

/* Index of the lowest set bit of m (m != 0). */
SPT_FN spt_u32 bvh_lowest_bit(spt_u32 m)
{
#if SPT_DEVICE
    return 31u - clz(m & (0u - m));
#else
    return (spt_u32)__builtin_ctz(m);
#endif
}

/* Entry distances of the ray into a node's BVH_WIDTH child boxes (BvhEnter),
 * and in *mask the children it enters: bit i is set when child i's box
 * overlaps [0, tbest], and then lane i is its entry distance (the other lanes
 * hold their empty interval's near distance and are not read).
 * Far distances are widened by 1 + 2 gamma(3) (Ize 2013, "Robust BVH Ray
 * Traversal") so rounding never culls a box the triangle test would hit. The
 * min and max are compare-and-select (a < b ? a : b) on the device and the host
 * alike, without fmin's NaN handling: no operand can be NaN (finite boxes and
 * origins, finite non-zero reciprocals). */
#if SPT_DEVICE
typedef float8 BvhEnter;
#define BVH_ENTER_LANE(d, i) bvh_lane8(d, i)

/* x86 CPUs (SPT_BVH_SIMD with AVX2; PoCL defines the target's feature macros)
 * take a vector's lane by a variable index, and a compare's lanes as a bit
 * mask, with one instruction each through clang's built-ins: vpermps and
 * vmovmskps. OpenCL C has neither, and its portable forms below (halving
 * selects, an OR of lane bits) are chains of dependent shuffles on the
 * traversal's critical path. */
#if defined(SPT_BVH_SIMD) && defined(__AVX2__)
#define BVH_X86_AVX2 1
#endif

/* Lane l (0..7) of x: vpermps, or halving selects (no indexed private array). */
SPT_FN float bvh_lane8(float8 x, uint l)
{
#if defined(BVH_X86_AVX2)
    return as_float8(__builtin_ia32_permvarsf256(x, (int8)((int)l))).s0;
#else
    float4 x4 = (l & 4u) ? x.hi : x.lo;
    float2 x2 = (l & 2u) ? x4.hi : x4.lo;
    return (l & 1u) ? x2.y : x2.x;
#endif
}

/* Bit i set when lane i of the compare result c is true (all ones). */
SPT_FN uint bvh_mask8(int8 c)
{
#if defined(BVH_X86_AVX2)
    return (uint)__builtin_ia32_movmskps256(as_float8(c));
#else
    uint8 b = as_uint8(c) & (uint8)(1u, 2u, 4u, 8u, 16u, 32u, 64u, 128u);
    uint4 b4 = b.lo | b.hi;
    uint2 b2 = b4.lo | b4.hi;
    return b2.x | b2.y;
#endif
}

SPT_FN float8 bvh_v8_min(float8 a, float8 b) { return select(b, a, a < b); }
SPT_FN float8 bvh_v8_max(float8 a, float8 b) { return select(b, a, a > b); }

#if defined(SPT_BVH_QNODES)
/* The eight planes of row row (bvh_qplane, lane by lane). */
SPT_FN float8 bvh_qplanes8(const __global BvhQNode *n, int row, float org, float step)
{
    return convert_float8(vload8(0, n->q[row])) * (float8)(step) + (float8)(org);
}

SPT_FN float8 bvh_node_enter(const __global BvhQNode *n, const BvhRay *r, float tbest, uint *mask)
{
    float8 ox = (float8)(r->ox), oy = (float8)(r->oy), oz = (float8)(r->oz);
    float gx = n->org[0], gy = n->org[1], gz = n->org[2];
    float sx = bvh_qstep(n->exp[0]), sy = bvh_qstep(n->exp[1]), sz = bvh_qstep(n->exp[2]);
    float8 tnx = (bvh_qplanes8(n, r->nx, gx, sx) - ox) * r->ix;
    float8 tfx = (bvh_qplanes8(n, r->nx ^ 1, gx, sx) - ox) * r->ix;
    float8 tny = (bvh_qplanes8(n, r->ny, gy, sy) - oy) * r->iy;
    float8 tfy = (bvh_qplanes8(n, r->ny ^ 1, gy, sy) - oy) * r->iy;
    float8 tnz = (bvh_qplanes8(n, r->nz, gz, sz) - oz) * r->iz;
    float8 tfz = (bvh_qplanes8(n, r->nz ^ 1, gz, sz) - oz) * r->iz;
    float8 tn = bvh_v8_max(bvh_v8_max(tnx, tny), bvh_v8_max(tnz, (float8)(0.0f)));
    float8 tf = bvh_v8_min(bvh_v8_min(tfx, tfy), tfz) * 1.00000036f;
    tf = bvh_v8_min(tf, (float8)(tbest));
    *mask = bvh_mask8(tn <= tf) & (uint)n->used;
    return tn;
}
#else
SPT_FN float8 bvh_node_enter(const __global BvhNode *n, const BvhRay *r, float tbest, uint *mask)
{
    float8 ox = (float8)(r->ox), oy = (float8)(r->oy), oz = (float8)(r->oz);
    float8 tnx = (vload8(0, n->bounds[r->nx]) - ox) * r->ix;
    float8 tfx = (vload8(0, n->bounds[r->nx ^ 1]) - ox) * r->ix;
    float8 tny = (vload8(0, n->bounds[r->ny]) - oy) * r->iy;
    float8 tfy = (vload8(0, n->bounds[r->ny ^ 1]) - oy) * r->iy;
    float8 tnz = (vload8(0, n->bounds[r->nz]) - oz) * r->iz;
    float8 tfz = (vload8(0, n->bounds[r->nz ^ 1]) - oz) * r->iz;
    float8 tn = bvh_v8_max(bvh_v8_max(tnx, tny), bvh_v8_max(tnz, (float8)(0.0f)));
    float8 tf = bvh_v8_min(bvh_v8_min(tfx, tfy), tfz) * 1.00000036f;
    tf = bvh_v8_min(tf, (float8)(tbest));
    *mask = bvh_mask8(tn <= tf);
    return tn;
}
#endif

#else
typedef struct BvhEnter {
    float v[BVH_WIDTH];
} BvhEnter;
#define BVH_ENTER_LANE(d, i) ((d).v[i])

SPT_FN BvhEnter bvh_node_enter(const BvhNode *n, const BvhRay *r, float tbest, spt_u32 *mask)
{
    BvhEnter d;
    spt_u32 m = 0;
#if defined(__SSE2__)
    /* The device's float8 arithmetic, four lanes at a time (minps/maxps are
     * a < b ? a : b and a > b ? a : b, like the device's selects). */
    __m128 ox = _mm_set1_ps(r->ox), oy = _mm_set1_ps(r->oy), oz = _mm_set1_ps(r->oz);
    __m128 ix = _mm_set1_ps(r->ix), iy = _mm_set1_ps(r->iy), iz = _mm_set1_ps(r->iz);
    for (int h = 0; h < BVH_WIDTH; h += 4) {
        __m128 tnx = _mm_mul_ps(_mm_sub_ps(_mm_loadu_ps(n->bounds[r->nx] + h), ox), ix);
        __m128 tfx = _mm_mul_ps(_mm_sub_ps(_mm_loadu_ps(n->bounds[r->nx ^ 1] + h), ox), ix);
        __m128 tny = _mm_mul_ps(_mm_sub_ps(_mm_loadu_ps(n->bounds[r->ny] + h), oy), iy);
        __m128 tfy = _mm_mul_ps(_mm_sub_ps(_mm_loadu_ps(n->bounds[r->ny ^ 1] + h), oy), iy);
        __m128 tnz = _mm_mul_ps(_mm_sub_ps(_mm_loadu_ps(n->bounds[r->nz] + h), oz), iz);
        __m128 tfz = _mm_mul_ps(_mm_sub_ps(_mm_loadu_ps(n->bounds[r->nz ^ 1] + h), oz), iz);
        __m128 tn = _mm_max_ps(_mm_max_ps(tnx, tny), _mm_max_ps(tnz, _mm_setzero_ps()));
        __m128 tf = _mm_mul_ps(_mm_min_ps(_mm_min_ps(tfx, tfy), tfz), _mm_set1_ps(1.00000036f));
        tf = _mm_min_ps(tf, _mm_set1_ps(tbest));
        __m128 in = _mm_cmple_ps(tn, tf);
        _mm_storeu_ps(d.v + h, tn);
        m |= (spt_u32)_mm_movemask_ps(in) << h;
    }
#else
    for (int i = 0; i < BVH_WIDTH; i++) {
        float tnx = (n->bounds[r->nx][i] - r->ox) * r->ix, tfx = (n->bounds[r->nx ^ 1][i] - r->ox) * r->ix;
        float tny = (n->bounds[r->ny][i] - r->oy) * r->iy, tfy = (n->bounds[r->ny ^ 1][i] - r->oy) * r->iy;
        float tnz = (n->bounds[r->nz][i] - r->oz) * r->iz, tfz = (n->bounds[r->nz ^ 1][i] - r->oz) * r->iz;
        float tn = bvh_max_(bvh_max_(tnx, tny), bvh_max_(tnz, 0.0f));
        float tf = bvh_min_(bvh_min_(tfx, tfy), tfz) * 1.00000036f;
        tf = bvh_min_(tf, tbest);
        d.v[i] = tn;
        m |= (spt_u32)(tn <= tf) << i;
    }
#endif
    *mask = m;
    return d;
}

#endif

/* Watertight test of triangle l of a leaf: its corners are vertices idx[l],
 * idx[n + l] and idx[2 n + l] of the rows rx, ry, rz (the vertices' kx, ky and
 * kz coordinates). On a hit with t in (0, tbest) writes hit (prim = prim) and
 * returns 1, else returns 0 and leaves hit alone. */
SPT_FN int bvh_tri_intersect(const SPT_GLOBAL float *rx, const SPT_GLOBAL float *ry,
                             const SPT_GLOBAL float *rz, const SPT_GLOBAL spt_u8 *idx, spt_u32 n,
                             spt_u32 l, spt_u32 prim, const BvhRay *r, float tbest, BvhHit *hit)
{
#if SPT_DEVICE
#pragma OPENCL FP_CONTRACT OFF
#endif
    spt_u32 a = idx[l], b = idx[n + l], c = idx[2u * n + l];
    float okx = r->okx, oky = r->oky, okz = r->okz;
    float az = rz[a] - okz, bz = rz[b] - okz, cz = rz[c] - okz;
    float ax = (rx[a] - okx) - r->sx * az;
    float ay = (ry[a] - oky) - r->sy * az;
    float bx = (rx[b] - okx) - r->sx * bz;
    float by = (ry[b] - oky) - r->sy * bz;
    float cx = (rx[c] - okx) - r->sx * cz;
    float cy = (ry[c] - oky) - r->sy * cz;
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
    hit->prim = prim;
    return 1;
}

/* The vector leaf test needs a variable permute, which OpenCL C lacks
 * (shuffle() compiles to scalar code in PoCL): x86 CPUs get it from clang's
 * vpermps built-ins, 512-bit with AVX-512 (all 16 triangles in one row), and
 * with AVX2 two 256-bit ones and a blend per row of 8 triangles (a leaf of
 * more than 8 takes two rows; SPT_BVH_NO_AVX512 forces this form, for the
 * tests). */
#if SPT_DEVICE && defined(SPT_BVH_SIMD) && defined(__AVX512F__) && !defined(SPT_BVH_NO_AVX512)
#define BVH_LEAF_VECTOR 1
#define BVH_X86_AVX512 1
/* Lane i of the result is lane idx[i] (0..15) of v: one vpermps. */
SPT_FN float16 bvh_gather16(float16 v, int16 idx)
{
    return __builtin_ia32_permvarsf512(v, idx);
}
#elif SPT_DEVICE && defined(SPT_BVH_SIMD) && defined(__AVX2__)
#define BVH_LEAF_VECTOR 1
/* Lanes idx[i] (0..15) of v for 8 lanes: a vpermps from each half of v (it
 * uses the low 3 bits), then the half idx[i] names. */
SPT_FN float8 bvh_gather8_of16(float16 v, int8 idx)
{
    return select(__builtin_ia32_permvarsf256(v.lo, idx), __builtin_ia32_permvarsf256(v.hi, idx),
                  idx > (int8)(7));
}
#endif

#if defined(BVH_LEAF_VECTOR)
/* The watertight test of bvh_tri_intersect lane by lane, on W-lane vectors of
 * the sheared corners (a, b, c): each lane's hit distance when it hits with t
 * in (0, tbest) and live is set, BVH_FAR otherwise, and its barycentrics in
 * *u, *v. Defined for 16 lanes (AVX-512's one row) and 8 (AVX2's, so a leaf
 * of at most 8 triangles costs one 256-bit row instead of two). */
#define BVH_DEFINE_TRI_LANES(W)                                                             \
    SPT_FN float##W bvh_tri##W##_lanes(float##W ax, float##W ay, float##W az, float##W bx,   \
                                       float##W by, float##W bz, float##W cx, float##W cy,   \
                                       float##W cz, float sz, float tbest, int##W live,      \
                                       float##W *u, float##W *v)                             \
    {                                                                                       \
        _Pragma("OPENCL FP_CONTRACT OFF")                                                   \
        float##W eu = cx * by - cy * bx;                                                    \
        float##W ev = ax * cy - ay * cx;                                                    \
        float##W ew = bx * ay - by * ax;                                                    \
        float##W zero = (float##W)(0.0f);                                                   \
        int##W outside = ((eu < zero) | (ev < zero) | (ew < zero)) &                        \
                         ((eu > zero) | (ev > zero) | (ew > zero));                         \
        float##W det = eu + ev + ew;                                                        \
        float##W rcp = (float##W)(1.0f) / det;                                              \
        float##W w0 = eu * rcp, w1 = ev * rcp, w2 = ew * rcp;                               \
        float##W t = (w0 * az + w1 * bz + w2 * cz) * (float##W)(sz);                        \
        int##W ok = ~outside & (det != zero) & (t > zero) & (t < (float##W)(tbest)) & live; \
        *u = w1;                                                                            \
        *v = w2;                                                                            \
        return select((float##W)(BVH_FAR), t, ok);                                          \
    }

/* The smallest lane of x: compare and select, as the node test's min (fmin's
 * NaN handling costs an unordered compare and a blend per step, and no lane
 * is NaN). */
SPT_FN float bvh_min8(float8 x)
{
    float4 m4 = select(x.hi, x.lo, x.lo < x.hi);
    float2 m2 = select(m4.hi, m4.lo, m4.lo < m4.hi);
    return m2.x < m2.y ? m2.x : m2.y;
}

/* A leaf's vertex rows (nv <= 16 vertices; the kx, ky, kz coordinates at rx,
 * ry, rz) sheared into the ray's space, as bvh_tri_intersect does vertex by
 * vertex: once per vertex, before the corners are gathered. */
SPT_FN void bvh_shear16(const __global float *rx, const __global float *ry, const __global float *rz,
                        const BvhRay *r, float16 *xs, float16 *ys, float16 *zs)
{
#pragma OPENCL FP_CONTRACT OFF
    *zs = vload16(0, rz) - (float16)(r->okz);
    *xs = (vload16(0, rx) - (float16)(r->okx)) - (float16)(r->sx) * *zs;
    *ys = (vload16(0, ry) - (float16)(r->oky)) - (float16)(r->sy) * *zs;
}

#if defined(BVH_X86_AVX512)
BVH_DEFINE_TRI_LANES(16)
#define BVH_LANE_IDS16 ((int16)(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15))

SPT_FN float bvh_min16(float16 x) { return bvh_min8(select(x.hi, x.lo, x.lo < x.hi)); }

/* All of a leaf's (n <= 16) triangles in one 16-lane test: the hit distance of
 * each lane that hits with t in (0, tbest), BVH_FAR for the others and for
 * lanes >= n, and each lane's barycentrics in *u, *v. */
SPT_FN float16 bvh_tri16_distances(const __global float *rx, const __global float *ry,
                                   const __global float *rz, const __global uchar *idx, uint n,
                                   const BvhRay *r, float tbest, float16 *u, float16 *v)
{
    float16 xs, ys, zs;
    bvh_shear16(rx, ry, rz, r, &xs, &ys, &zs);
    int16 ia = convert_int16(vload16(0, idx));
    int16 ib = convert_int16(vload16(0, idx + n));
    int16 ic = convert_int16(vload16(0, idx + 2 * n));
    return bvh_tri16_lanes(bvh_gather16(xs, ia), bvh_gather16(ys, ia), bvh_gather16(zs, ia),
                           bvh_gather16(xs, ib), bvh_gather16(ys, ib), bvh_gather16(zs, ib),
                           bvh_gather16(xs, ic), bvh_gather16(ys, ic), bvh_gather16(zs, ic), r->sz, tbest,
                           BVH_LANE_IDS16 < (int16)((int)n), u, v);
}
#else
BVH_DEFINE_TRI_LANES(8)
#define BVH_LANE_IDS8 ((int8)(0, 1, 2, 3, 4, 5, 6, 7))

/* Triangles [l0, l0 + 8) of a leaf of n (l0 < n <= 16) in one 8-lane test, as
 * bvh_tri16_distances for 16; xs, ys, zs: the leaf's sheared vertex rows. */
SPT_FN float8 bvh_tri8_distances(float16 xs, float16 ys, float16 zs, const __global uchar *idx, uint n,
                                 uint l0, const BvhRay *r, float tbest, float8 *u, float8 *v)
{
    int8 ia = convert_int8(vload8(0, idx + l0));
    int8 ib = convert_int8(vload8(0, idx + n + l0));
    int8 ic = convert_int8(vload8(0, idx + 2 * n + l0));
    return bvh_tri8_lanes(bvh_gather8_of16(xs, ia), bvh_gather8_of16(ys, ia), bvh_gather8_of16(zs, ia),
                          bvh_gather8_of16(xs, ib), bvh_gather8_of16(ys, ib), bvh_gather8_of16(zs, ib),
                          bvh_gather8_of16(xs, ic), bvh_gather8_of16(ys, ic), bvh_gather8_of16(zs, ic), r->sz,
                          tbest, BVH_LANE_IDS8 + (int8)((int)l0) < (int8)((int)n), u, v);
}
#endif

#endif

/* Tests the leaf block at word off (leaf, its node's count: triangles | vertices
 * << 8) against the ray: closest hit (any_hit 0: the nearest below *best,
 * updating *best and hit) or any hit (stops at the first). Returns 1 when it
 * found a hit. */
SPT_FN int bvh_leaf_intersect(const SPT_GLOBAL float *tris, spt_u32 off, spt_u32 leaf,
                              const BvhRay *r, float *best, int any_hit, BvhHit *hit)
{
    const SPT_GLOBAL float *p = tris + off;
    spt_u32 count = leaf & 255u, nv = leaf >> 8;
    const SPT_GLOBAL float *rx = p + 2 + (spt_u32)r->kx * nv;
    const SPT_GLOBAL float *ry = p + 2 + (spt_u32)r->ky * nv;
    const SPT_GLOBAL float *rz = p + 2 + (spt_u32)r->kz * nv;
    const SPT_GLOBAL spt_u8 *idx = (const SPT_GLOBAL spt_u8 *)(p + 2 + 3u * nv);
#if defined(BVH_X86_AVX512)
    float16 u, v;
    float16 t = bvh_tri16_distances(rx, ry, rz, idx, count, r, *best, &u, &v);
    /* The lanes that hit (t < *best <= tmax, finite; the others BVH_FAR). */
    int16 hits = t < (float16)(BVH_FAR);
    uint hm = bvh_mask8(hits.lo) | bvh_mask8(hits.hi) << 8;
    if (!hm)
        return 0;
    if (any_hit)
        return 1;
    /* The first lane at the minimum, as the lane loop would keep it: where
     * one lane hits (a ray mostly meets one triangle of a leaf) that lane,
     * without the reduction across the lanes. */
    uint l;
    float m;
    if (!(hm & (hm - 1u))) {
        l = bvh_lowest_bit(hm);
        m = as_float16(bvh_gather16(t, (int16)((int)l))).s0;
    } else {
        m = bvh_min16(t);
        int16 at_min = t == (float16)(m);
        l = bvh_lowest_bit(bvh_mask8(at_min.lo) | bvh_mask8(at_min.hi) << 8);
    }
    hit->t = m;
    hit->u = as_float16(bvh_gather16(u, (int16)((int)l))).s0;
    hit->v = as_float16(bvh_gather16(v, (int16)((int)l))).s0;
    hit->prim = bvh_word(p, 0) + l;
    *best = m;
    return 1;
#elif defined(BVH_LEAF_VECTOR)
    /* AVX2: eight triangles per row, the second row only for a leaf of more
     * than eight; the nearer row wins, the first on a tie (as the lane loop). */
    float16 xs, ys, zs;
    bvh_shear16(rx, ry, rz, r, &xs, &ys, &zs);
    float8 u, v;
    float8 t = bvh_tri8_distances(xs, ys, zs, idx, count, 0u, r, *best, &u, &v);
    float m = bvh_min8(t);
    uint l0 = 0u;
    if (count > 8u) {
        float8 u1, v1;
        float8 t1 = bvh_tri8_distances(xs, ys, zs, idx, count, 8u, r, *best, &u1, &v1);
        float m1 = bvh_min8(t1);
        if (m1 < m) {
            m = m1;
            t = t1;
            u = u1;
            v = v1;
            l0 = 8u;
        }
    }
    if (!(m < *best))
        return 0;
    if (any_hit)
        return 1;
    uint l = bvh_lowest_bit(bvh_mask8(t == (float8)(m)));
    hit->t = m;
    hit->u = bvh_lane8(u, l);
    hit->v = bvh_lane8(v, l);
    hit->prim = bvh_word(p, 0) + l0 + l;
    *best = m;
    return 1;
#else
    spt_u32 first = bvh_word(p, 0);
    int found = 0;
    for (spt_u32 l = 0; l < count; l++) {
        if (bvh_tri_intersect(rx, ry, rz, idx, count, l, first + l, r, *best, hit)) {
            *best = hit->t;
            found = 1;
            if (any_hit)
                return 1;
        }
    }
    return found;
#endif
}

/* Asks the memory system early for a child (a node, or when count > 0 the leaf
 * block at word child), so its latency overlaps other work. */
SPT_FN void bvh_prefetch(const SPT_GLOBAL BvhNode *nodes, const SPT_GLOBAL float *tris,
                         spt_u32 child, spt_u32 count)
{
    if (count) {
        const SPT_GLOBAL float *p = tris + child;
        /* every cache line of the leaf's block: at most 2 + 3 * 16 + 12 = 62
         * words, so five requests 16 words apart (the last ones clamped to
         * its last word) cover all, without a loop whose trip count the
         * branch predictor would have to guess per leaf */
        spt_u32 last = bvh_leaf_words(count & 255u, count >> 8) - 1u;
        SPT_PREFETCH(p);
        SPT_PREFETCH(p + (last < 16u ? last : 16u));
        SPT_PREFETCH(p + (last < 32u ? last : 32u));
        SPT_PREFETCH(p + (last < 48u ? last : 48u));
        SPT_PREFETCH(p + last);
    } else {
        /* the node's cache lines: four, or two of a quantised node */
        const SPT_GLOBAL char *q = (const SPT_GLOBAL char *)&nodes[child];
        SPT_PREFETCH(q);
        SPT_PREFETCH(q + 64);
#if !defined(SPT_BVH_QNODES)
        SPT_PREFETCH(q + 128);
        SPT_PREFETCH(q + 192);
#endif
    }
}

/* One ray's traversal in progress: the ray, its best hit so far, the current
 * item (node cur when count is 0, else the leaf block at word cur, count its
 * node's count word) and the deferred items with their entry distances. */
typedef struct BvhTrav {
    BvhRay r;
    float best;
    int found, sp;
    spt_u32 cur, count;
    BvhHit hit;
    spt_u32 stack_child[BVH_STACK_SIZE], stack_count[BVH_STACK_SIZE];
    float stack_t[BVH_STACK_SIZE];
} BvhTrav;

/* Starts s at the root for the ray org + t dir, t in (0, tmax). */
SPT_FN_INLINE void bvh_trav_init(BvhTrav *s, vec3 org, vec3 dir, float tmax)
{
    bvh_ray_init(&s->r, org, dir);
    s->best = tmax;
    s->found = 0;
    s->sp = 0;
    s->cur = 0;
    s->count = 0;
}

/* Makes (child, count) s's current item and, with SPT_BVH_STEP_PREFETCH (set
 * by the host for BVHs larger than the cache), asks for its memory now: in
 * bvh_intersect2 the other ray's step runs before this one's next, and the
 * loads overlap it (a step ends at a data-dependent branch, so the CPU does
 * not run ahead into the next load by itself). */
SPT_FN_INLINE void bvh_trav_next(const SPT_GLOBAL BvhNode *nodes, const SPT_GLOBAL float *tris,
                                 BvhTrav *s, spt_u32 child, spt_u32 count)
{
    s->cur = child;
    s->count = count;
#if defined(SPT_BVH_STEP_PREFETCH)
    bvh_prefetch(nodes, tris, child, count);
#else
    (void)nodes;
    (void)tris;
#endif
}

/* The children of a node that a ray enters (mask, entry distances d), sorted
 * by entry distance, farthest first, into kd (distances) and ks (slots); of
 * equal distances the higher slot counts as nearer. Returns their number. */
SPT_FN_INLINE int bvh_sort_entered(BvhEnter d, spt_u32 mask, float kd[BVH_WIDTH],
                                   spt_u32 ks[BVH_WIDTH])
{
    int k = 0;
    for (spt_u32 m = mask; m; m &= m - 1u) {
        spt_u32 i = bvh_lowest_bit(m);
        float di = BVH_ENTER_LANE(d, i);
        int j = k++;
        while (j > 0 && kd[j - 1] < di) {
            kd[j] = kd[j - 1];
            ks[j] = ks[j - 1];
            j--;
        }
        kd[j] = di;
        ks[j] = i;
    }
    return k;
}

/* The order an any-hit query visits a node's children in: its leaves first,
 * nearest first, then its nodes (their keys pushed past every entry distance,
 * so among themselves they go by slot: d + 1e30 rounds to 1e30). A leaf may
 * end the query at once where a node costs a descent, and the large
 * triangles that block most rays (a room's walls) sit in leaves near the
 * root: bench_trace's shadow segments 5-7% and its unbounded any-hit rays
 * 8-35% faster (docs/performance.md, "Where a ray's time goes"). Only the
 * order changes: the deferred children keep a cull key of 0 (an any-hit
 * query ends at its first hit, so none is culled), and the answer is the
 * same. */
SPT_FN_INLINE BvhEnter bvh_leaves_first(BvhEnter d, const SPT_GLOBAL BvhNode *n)
{
#if SPT_DEVICE
    return select(d + (float8)(1e30f), d, vload8(0, n->count) != (uint8)(0u));
#else
    for (int i = 0; i < BVH_WIDTH; i++)
        if (!n->count[i])
            d.v[i] += 1e30f;
    return d;
#endif
}

/* One step of the traversal behind bvh_intersect (any_hit 0: closest hit) and
 * bvh_occluded (any_hit 1: stops at the first hit): tests the current item and
 * moves to the next. Returns 1 while there is more to do, 0 when s is finished
 * (s->found and s->hit hold the result). The children a ray enters are visited
 * nearest first (an any-hit query's leaves before its nodes: bvh_leaves_first),
 * the others deferred on the stack and skipped when their entry distance is
 * beyond the best hit. */
SPT_FN_INLINE int bvh_trav_step(const SPT_GLOBAL BvhNode *nodes, const SPT_GLOBAL float *tris,
                         BvhTrav *s, int any_hit)
{
    if (s->count) {
        if (bvh_leaf_intersect(tris, s->cur, s->count, &s->r, &s->best, any_hit, &s->hit)) {
            s->found = 1;
            if (any_hit)
                return 0;
        }
    } else {
        const SPT_GLOBAL BvhNode *n = &nodes[s->cur];
        spt_u32 mask;
        BvhEnter d = bvh_node_enter(n, &s->r, s->best, &mask);
        if (any_hit)
            d = bvh_leaves_first(d, n);
        if (mask) {
            spt_u32 a = bvh_lowest_bit(mask), rest = mask & (mask - 1u);
            if (!rest) {
                /* One child entered, the usual case deep in the tree. */
                bvh_trav_next(nodes, tris, s, n->child[a], n->count[a]);
                return 1;
            }
            int sp = s->sp;
            if (!(rest & (rest - 1u))) {
                /* Two: visit the nearer, defer the other. */
                spt_u32 b = bvh_lowest_bit(rest);
                float ka = BVH_ENTER_LANE(d, a), kb = BVH_ENTER_LANE(d, b);
                /* Of equal distances the higher slot (b) counts as nearer, as
                 * in the sort below (bvh_short_step relies on one order). */
                spt_u32 near = kb <= ka ? b : a, far = kb <= ka ? a : b;
                s->stack_child[sp] = n->child[far];
                s->stack_count[sp] = n->count[far];
                bvh_prefetch(nodes, tris, n->child[far], n->count[far]);
                s->stack_t[sp] = any_hit ? 0.0f : (kb <= ka ? ka : kb);
                s->sp = sp + 1;
                bvh_trav_next(nodes, tris, s, n->child[near], n->count[near]);
                return 1;
            }
            /* Three or more: sort, defer all but the nearest. */
            float kd[BVH_WIDTH];
            spt_u32 ks[BVH_WIDTH];
            int k = bvh_sort_entered(d, mask, kd, ks);
            for (int j = 0; j < k - 1; j++) {
                s->stack_child[sp] = n->child[ks[j]];
                s->stack_count[sp] = n->count[ks[j]];
                s->stack_t[sp++] = any_hit ? 0.0f : kd[j];
            }
            bvh_prefetch(nodes, tris, n->child[ks[k - 2]], n->count[ks[k - 2]]);
            bvh_prefetch(nodes, tris, n->child[ks[k - 3]], n->count[ks[k - 3]]);
            s->sp = sp;
            bvh_trav_next(nodes, tris, s, n->child[ks[k - 1]], n->count[ks[k - 1]]);
            return 1;
        }
    }
    /* Next: the nearest deferred item the best hit does not rule out. */
    for (int sp = s->sp; sp > 0;) {
        sp--;
        if (s->stack_t[sp] <= s->best) {
            s->sp = sp;
            bvh_trav_next(nodes, tris, s, s->stack_child[sp], s->stack_count[sp]);
            return 1;
        }
    }
    return 0;
}

#endif
