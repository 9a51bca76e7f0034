/* Host BVH builder: binned SAH over triangles into the flat node array and packed
 * triangles that kernels/bvh/bvh.h traverses (on the device and, in tests, on the host). */
#ifndef SPT_BVH_BUILD_H
#define SPT_BVH_BUILD_H

#include <stddef.h>
#include <stdint.h>

#include "core/util.h"
/* The device layout (BvhNode, the packed triangles, bvh_intersect, bvh_occluded). */
#include "bvh/bvh.h"

/* What a build made, for `info`, the benchmark and the tests. */
typedef struct BvhStats {
    uint32_t node_count;       /* 8-wide nodes */
    uint32_t leaf_count;
    uint32_t max_depth;        /* of the 8-wide nodes, root = 0 */
    uint32_t max_leaf_size;
    double avg_leaf_size;      /* triangles per leaf */
    double sah_cost;           /* of the binary SAH tree the 8-wide one gathers:
                                  sum over nodes of area / root area times the
                                  cost (options cost_node per interior node,
                                  cost_tri per triangle in a leaf) */
    double build_seconds;
    uint32_t build_threads;    /* threads that built it (BvhOptions.threads) */
    double bytes_per_tri;      /* (nodes + leaf blocks) / kept triangles */
    uint32_t dropped;          /* dropped_nonfinite + dropped_degenerate */
    uint32_t dropped_nonfinite;  /* NaN/Inf or |coordinate| >= 1e18 */
    uint32_t dropped_degenerate; /* zero area (in float) */
} BvhStats;

typedef struct Bvh {
    BvhNode *nodes;          /* node_count nodes, root first (device-ready) */
    uint32_t node_count;
    float *tri_data;         /* the leaf blocks (kernels/bvh/bvh.h; device-ready),
                                then BVH_TRI_PAD words; only zeroed words when
                                prim_count is 0, so the buffer is never empty */
    size_t tri_data_bytes;
    uint32_t *tri_leaf;      /* per packed triangle: the word of its leaf's block;
                                one 0 when prim_count is 0 */
    uint32_t *prim_index;    /* prim_index[i] = input index of packed triangle i */
    uint32_t prim_count;     /* triangles kept */
    BvhStats stats;
    uint32_t build;          /* which bvh_build of this process made the tree (1, 2, ...);
                                refits keep it */
    int refitted;            /* 1: bvh_refit last moved it; 0: as bvh_build made it */
} Bvh;

/* Build settings; bvh_build uses bvh_default_options_for(tri_count). */
typedef struct BvhOptions {
    int bins;           /* SAH bins per axis, 2..BVH_MAX_BINS */
    int max_leaf;       /* most triangles per leaf, 1..BVH_MAX_LEAF */
    int full_sweep;     /* 1: exact (unbinned) SAH by sorting, O(n log^2 n): a
                           quality reference for the benchmark, not for scenes */
    float cost_node;    /* SAH cost of visiting an interior node (> 0) */
    float cost_tri;     /* SAH cost of one triangle test (> 0) */
    int threads;        /* threads building the root's subtrees (1 ..; the tree
                           is the same for any number); 0: the CPUs online
                           for 65,536 triangles or more, else 1 */
} BvhOptions;

#define BVH_MAX_BINS 64
#define BVH_MAX_LEAF BVH_LEAF_MAX

/* The settings bvh_build uses for tri_count triangles: leaves of at most a
 * row of the CPU devices' leaf test (16 with AVX-512, 8 with AVX2), or of 16
 * where a tree of rows of 8 would not fit a quarter of the host's cache. */
BvhOptions bvh_default_options_for(uint32_t tri_count);

/* bvh_default_options_for a scene small enough for the cache. */
BvhOptions bvh_default_options(void);

/* Builds bvh (overwritten) over tri_count triangles, 9 floats each (v0, v1, v2).
 * Triangles with a non-finite coordinate, |coordinate| >= 1e18 or zero area are
 * dropped and counted in bvh->stats. Zero kept triangles give a one-leaf tree that
 * every ray misses. Returns 0, or SPT_EXIT_INPUT (bvh left empty, e filled) when
 * the scene is too large to index. */
int bvh_build(Bvh *bvh, const float *tri_pos, uint32_t tri_count, SptError *e);

/* bvh_build with explicit options (NULL = defaults); invalid options are
 * SPT_EXIT_USAGE. */
int bvh_build_ex(Bvh *bvh, const float *tri_pos, uint32_t tri_count, const BvhOptions *opt,
                 SptError *e);

/* Refits bvh, built over built_count triangles, to the same triangles moved
 * to tri_pos (tri_count, 9 floats each): the tree and the packed order are
 * kept, the leaf blocks' vertices and every box recomputed, so the boxes are
 * those a build of the same tree would give. Returns 1, or 0 when only a build
 * can index the new positions: another count, a triangle kept or dropped
 * (bvh_build's rules) that now is not, or two corners that shared a leaf
 * vertex moved apart; bvh is then partly rewritten and must be freed. The
 * time goes to bvh->stats.build_seconds. */
int bvh_refit(Bvh *bvh, const float *tri_pos, uint32_t tri_count, uint32_t built_count);

/* An 8-wide tree over count boxes (6 floats each: low x y z, high x y z),
 * for a top level over instances (src/accel/tlas_build.c): the layout of
 * BvhNode with one box per leaf, a leaf slot having count 1 and child its
 * position p in the tree's order, order[p] (count entries, filled) the input
 * index of that box. *nodes (malloc'd; *node_count of them, at least the
 * root, which has no children when count is 0) is the caller's to free.
 * Returns 0, or SPT_EXIT_INPUT (nothing allocated) for too many boxes. */
int bvh_build_boxes(const float *boxes, uint32_t count, BvhNode **nodes, uint32_t *node_count,
                    uint32_t *order, SptError *e);

/* Node n as a quantised node (kernels/bvh/bvh_node.h, BvhQNode): each low
 * plane rounded down and each high plane up in the traversal's own float
 * arithmetic, so every decoded box contains n's float box; slots with an
 * empty box are unused. */
void bvh_node_quantise(BvhQNode *q, const BvhNode *n);

/* The count nodes quantised (malloc'd, 64-byte aligned; one zeroed node when
 * count is 0), the caller's to free. */
BvhQNode *bvh_quantise_nodes(const BvhNode *nodes, size_t count);

/* 1 when the renderer uploads quantised nodes (and compiles the kernels with
 * SPT_BVH_QNODES): SPECTRACE_BVH_NODES=quantised. They halve the nodes' bytes
 * (the 1M-triangle mesh: 24.3 -> 20.4 bytes per triangle) but were slower
 * on CPU devices in cache and no faster beyond it (docs/performance.md,
 * "What sets the speed"), so float nodes are the default. */
int bvh_qnodes_wanted(void);

/* Frees what bvh_build allocated and zeroes bvh; safe on a zeroed or freed Bvh. */
void bvh_free(Bvh *bvh);

/* The bounds of everything indexed (lo > hi when nothing is). */
void bvh_bounds(const Bvh *bvh, float lo[3], float hi[3]);

/* The vertices of packed triangle i. */
static inline void bvh_vertices(const Bvh *bvh, uint32_t i, vec3 *v0, vec3 *v1, vec3 *v2)
{
    const float *p = bvh->tri_data + bvh->tri_leaf[i];
    bvh_leaf_vertices(p, i - bvh_word(p, 0), v0, v1, v2);
}

/* A closed, star-shaped test mesh: a sphere of the given radius around center
 * with stacks x slices vertices between the poles, radially displaced by
 * amplitude * a smooth pattern (|amplitude| < 1 keeps it star-shaped around the
 * center). Adjacent triangles share bit-identical vertices. Returns a malloc'd
 * array of 9 floats per triangle and sets *tri_count = 2 * slices * stacks. */
float *bvh_gen_sphere(uint32_t stacks, uint32_t slices, float radius, const float center[3],
                      float amplitude, uint32_t *tri_count);

/* The next number of the SplitMix64 stream (Steele, Lea and Flood 2014) at
 * *state, as a double in [0, 1) (its top 53 bits): reproducible random test
 * geometry and rays for the BVH's tests and benchmark. */
double bvh_gen_uniform(uint64_t *state);

#endif
