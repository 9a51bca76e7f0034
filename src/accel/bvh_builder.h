/* What the BVH builder's files (src/accel/bvh_build.c, bvh_split.c) share: the
 * triangle references, the binary tree's nodes as they are decided, and the
 * split searches; the refit (bvh_refit.c) shares the rule that drops a
 * triangle. Nothing else includes it. */
#ifndef SPT_BVH_BUILDER_H
#define SPT_BVH_BUILDER_H

#include <float.h>
#include <stdint.h>

#include "accel/bvh_build.h"
#include "accel/bvh_lanes.h"


/* Below this depth splits follow the SAH; from it on they are object medians,
 * which halve the triangle count, so 2^32 triangles still end in leaves at depth
 * BVH_MEDIAN_DEPTH + 32 <= BVH_MAX_DEPTH - 1. */
#define BVH_MEDIAN_DEPTH (BVH_MAX_DEPTH - 1 - 32)
/* Most triangles indexed: node indices and counts must fit in 31 bits. */
#define BVH_MAX_TRIS (1u << 30)

/* A triangle's bounds while building; its centroid (doubled) is lo + hi. */
typedef struct PrimRef {
    float lo[3];
    uint32_t id;
    float hi[3];
    float pad;
} PrimRef;
typedef struct Box {
    float lo[3], hi[3];
} Box;

/* A chosen split of refs[begin, end): [begin, mid) left, [mid, end) right. */
typedef struct Split {
    uint32_t mid;
} Split;

typedef struct SweepKey {
    float key;
    uint32_t id;
    uint32_t ref; /* position in refs */
} SweepKey;

/* A node of the binary SAH tree, decided but not stored: its refs [begin, end),
 * its bounds, and unless it is a leaf the split point mid (the refs are already
 * partitioned). The 8-wide nodes are made from these as the build goes. */
typedef struct Item {
    uint32_t begin, end, mid;
    uint32_t depth; /* in the binary tree, root = 0 */
    int leaf;
    Box bounds;
} Item;

typedef struct Builder {
    PrimRef *refs;
    BvhNode *wide;      /* the 8-wide nodes made so far */
    uint32_t wide_count, wide_cap;
    double sah;         /* the binary tree's SAH cost times its root's area */
    BvhStats *st;
    BvhOptions opt;
    /* full-sweep scratch, sized for all refs */
    SweepKey *keys;
    float *right_area;
    PrimRef *tmp;
    uint32_t *leaf_slot; /* per ref: at a leaf's first ref, node * BVH_WIDTH + slot + 1 of
                            the leaf, else 0 */
    const float *tri_pos; /* the input triangles */
} Builder;

/* A binned SAH split of refs[begin, end): the centroid bins along axis ... <= k
 * go left. */
typedef struct BinSplit {
    int axis, k, nb;
    float cmin, scale; /* bin of a ref = min((centroid - cmin) * scale, nb - 1) */
} BinSplit;

static inline void box_empty(Box *b)
{
    for (int a = 0; a < 3; a++) {
        b->lo[a] = FLT_MAX;
        b->hi[a] = -FLT_MAX;
    }
}

static inline void box_grow_ref(Box *b, const PrimRef *r)
{
    for (int a = 0; a < 3; a++) {
        b->lo[a] = minf(b->lo[a], r->lo[a]);
        b->hi[a] = maxf(b->hi[a], r->hi[a]);
    }
}

/* Half the surface area; 0 for an empty box. */
static inline float box_half_area(const Box *b)
{
    float dx = b->hi[0] - b->lo[0], dy = b->hi[1] - b->lo[1], dz = b->hi[2] - b->lo[2];
    if (dx < 0.0f || dy < 0.0f || dz < 0.0f)
        return 0.0f;
    return dx * dy + dy * dz + dz * dx;
}

/* 1 when the cross product of triangle p's edges (in float, as the renderer
 * computes a geometric normal) is the zero vector: bvh_build drops it. Its
 * coordinates must be finite and below 1e18, so it cannot overflow. */
int bvh_tri_zero_area(const float *p);

/* Bounds and centroid bounds of refs[begin, end). */
void bvh_refs_bounds(const PrimRef *refs, uint32_t begin, uint32_t end, Box *b, Box *cb);

/* Binned SAH split of refs[begin, end) (count >= 2) with bounds and centroid
 * bounds cb. Returns 1 with bs and *cost filled, or 0 when the centroids cannot
 * be told apart. */
int bvh_split_binned(Builder *bd, uint32_t begin, uint32_t end, const Box *bounds,
                 const Box *cb, BinSplit *bs, float *cost);

/* Partitions refs[begin, end) by bs and sets s->mid. Branch-free (Lomuto):
 * which side a ref goes to is hard to predict once the order no longer follows
 * the split axis. Returns 1 when both sides are non-empty (always, when bs came
 * from bvh_split_binned on this range). */
int bvh_partition_binned(Builder *bd, uint32_t begin, uint32_t end, const BinSplit *bs,
                     Split *s);

/* Object median split of refs[begin, end) (count >= 2) along the widest centroid
 * axis, or by position when all centroids coincide. Always splits. */
void bvh_split_median(Builder *bd, uint32_t begin, uint32_t end, const Box *cb, Split *s);

/* Exact SAH split of refs[begin, end): every position of a sort by centroid along
 * each axis. Returns 1 with s and *cost filled (count >= 2 always splits). */
int bvh_split_sweep(Builder *bd, uint32_t begin, uint32_t end, const Box *bounds, Split *s,
                float *cost);

#endif
