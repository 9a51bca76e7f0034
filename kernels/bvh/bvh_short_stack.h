/* The traversal with a short stack and restarts, the kernels' GPU path, over
 * the node layout and node steps of kernels/bvh/bvh_node.h (kernels/bvh/bvh.h
 * picks it for SPT_BVH_SHORT_STACK). */
#ifndef SPT_KERNELS_BVH_SHORT_STACK_H
#define SPT_KERNELS_BVH_SHORT_STACK_H

#include "util/portable.h"
#include "util/vecmath.h"
#include "bvh/bvh_node.h"

/* The traversal with a short stack and restarts (the GPU path): private
 * memory per ray of BVH_SHORT_STACK_SIZE deferred items (16 bytes each) and a
 * trail of one byte per tree level, about 250 bytes, where the full stack
 * (bvh_trav_step, kernels/bvh/bvh_node.h) takes 5.4 KB. It visits the same items in the same order as
 * bvh_trav_step, so its hits are the same bit for bit (tests/test_bvh.c).
 *
 * A node at level l (the root is level 0) visits its entered children in
 * order of entry distance, rank 0 the nearest; trail[l] holds the rank of the
 * one being visited and BVH_TRAIL_LAST when it is the last. Deferred children
 * go on the short stack with their level and rank; when it is full, the
 * oldest entry (the bottom) is dropped. When the stack runs empty after a
 * drop, the deepest level on the current item's path that is not on its last
 * child still has children to visit: its rank is advanced and the traversal
 * restarts at the root, following the trail's ranks down to that level, and
 * from there goes on as usual (the restart trail of Laine 2010, "Restart
 * Trail for Stackless BVH Traversal", for 8-wide nodes). The best hit only
 * shrinks, so a node's entered children on a later visit are a prefix of
 * those on an earlier one in the same order, and the ranks stay valid; a
 * rank past them means the rest of that node is beyond the best hit. */
#ifndef BVH_SHORT_STACK_SIZE
#define BVH_SHORT_STACK_SIZE 8
#endif
#define BVH_TRAIL_LAST 8u
/* The short stack is a ring (below): its slots are numbered modulo its size. */
SPT_STATIC_ASSERT((BVH_SHORT_STACK_SIZE & (BVH_SHORT_STACK_SIZE - 1)) == 0,
                  "BVH_SHORT_STACK_SIZE must be a power of two");
#define BVH_SHORT_SLOT(s, j) (((spt_u32)(s)->bot + (spt_u32)(j)) & (BVH_SHORT_STACK_SIZE - 1u))

typedef struct BvhShort {
    BvhRay r;
    float best;
    int found, sp, bot, depth, restart, dropped;
    spt_u32 cur, count; /* the current item, at level depth */
    BvhHit hit;
    /* sp entries, the j-th from the bottom in slot BVH_SHORT_SLOT(s, j): a
     * drop advances bot instead of moving the entries down, a loop that Intel's
     * CPU runtime's vectoriser compiles wrong (docs/performance.md, "Vector
     * width: AVX-512 against AVX2") */
    spt_u32 st_child[BVH_SHORT_STACK_SIZE], st_count[BVH_SHORT_STACK_SIZE];
    spt_u32 st_tag[BVH_SHORT_STACK_SIZE]; /* parent level | rank << 8 | BVH_TRAIL_LAST << 8 */
    float st_t[BVH_SHORT_STACK_SIZE];
    spt_u8 trail[BVH_MAX_DEPTH];
} BvhShort;

/* After the item at level s->depth is done, with the stack empty: restarts
 * for the deepest ancestor with children left (returns 1), or finishes
 * (returns 0). */
SPT_FN_INLINE int bvh_short_resume(BvhShort *s)
{
    for (int l = s->depth - 1; l >= 0; l--) {
        spt_u32 t = s->trail[l];
        if (!(t & BVH_TRAIL_LAST)) {
            s->trail[l] = (spt_u8)(t + 1u);
            s->restart = l;
            s->depth = 0;
            s->cur = 0;
            s->count = 0;
            return 1;
        }
    }
    return 0;
}

/* The current item, node s->cur, visited: moves to its nearest entered
 * child (returns 1), or finishes the traversal or restarts it (returns what
 * bvh_short_resume does), or returns -1 when the ray enters none of its
 * children (the caller then pops: bvh_short_pop). cap as bvh_short_step. The
 * top level of kernels/bvh/bvh_tlas.h runs its nodes through this too. */
SPT_FN_INLINE int bvh_short_node(const SPT_GLOBAL BvhNode *nodes, BvhShort *s, int cap)
{
    const SPT_GLOBAL BvhNode *n = &nodes[s->cur];
    int level = s->depth;
    spt_u32 mask;
    BvhEnter d = bvh_node_enter(n, &s->r, s->best, &mask);
    float kd[BVH_WIDTH];
    spt_u32 ks[BVH_WIDTH];
    int k = 0, r = 0;
    if (mask && !(mask & (mask - 1u))) {
        ks[0] = bvh_lowest_bit(mask);
        k = 1;
    } else if (mask) {
        k = bvh_sort_entered(d, mask, kd, ks);
    }
    if (s->restart >= 0) {
        r = (int)(s->trail[level] & 7u);
        if (r >= k) {
            /* What is left of this node is beyond the best hit. */
            s->restart = -1;
            return bvh_short_resume(s);
        }
        if (level < s->restart) {
            spt_u32 c = ks[k - 1 - r];
            s->cur = n->child[c];
            s->count = n->count[c];
            s->depth = level + 1;
            return 1;
        }
        s->restart = -1;
    }
    if (k) {
        s->trail[level] = (spt_u8)((spt_u32)r | (r == k - 1 ? BVH_TRAIL_LAST : 0u));
        for (int j = 0; j < k - 1 - r; j++) {
            if (s->sp == cap) {
                s->bot = (int)BVH_SHORT_SLOT(s, 1);
                s->sp = cap - 1;
                s->dropped = 1;
            }
            spt_u32 sp = BVH_SHORT_SLOT(s, s->sp++);
            s->st_child[sp] = n->child[ks[j]];
            s->st_count[sp] = n->count[ks[j]];
            s->st_t[sp] = kd[j];
            s->st_tag[sp] = (spt_u32)level | (spt_u32)(k - 1 - j) << 8 |
                            (j == 0 ? BVH_TRAIL_LAST << 8 : 0u);
        }
        spt_u32 c = ks[k - 1 - r];
        s->cur = n->child[c];
        s->count = n->count[c];
        s->depth = level + 1;
        return 1;
    }
    return -1;
}

/* After the current item is done: moves to the nearest deferred item the best
 * hit does not rule out (a skipped one counts as visited) and returns 1, or
 * restarts (bvh_short_resume), or returns 0 when the traversal is finished. */
SPT_FN_INLINE int bvh_short_pop(BvhShort *s)
{
    while (s->sp > 0) {
        spt_u32 sp = BVH_SHORT_SLOT(s, --s->sp);
        spt_u32 tag = s->st_tag[sp], l = tag & 255u;
        s->trail[l] = (spt_u8)(tag >> 8);
        s->depth = (int)l + 1;
        if (s->st_t[sp] <= s->best) {
            s->cur = s->st_child[sp];
            s->count = s->st_count[sp];
            return 1;
        }
    }
    return s->dropped ? bvh_short_resume(s) : 0;
}

/* One step: tests the current item and moves to the next; 0 when finished.
 * cap (<= BVH_SHORT_STACK_SIZE) is the stack size used (tests force restarts
 * with small ones). */
SPT_FN_INLINE int bvh_short_step(const SPT_GLOBAL BvhNode *nodes, const SPT_GLOBAL float *tris,
                                 BvhShort *s, int any_hit, int cap)
{
    if (s->count) {
        if (bvh_leaf_intersect(tris, s->cur, s->count, &s->r, &s->best, any_hit, &s->hit)) {
            s->found = 1;
            if (any_hit)
                return 0;
        }
    } else {
        int next = bvh_short_node(nodes, s, cap);
        if (next >= 0)
            return next;
    }
    return bvh_short_pop(s);
}

/* Starts s at the root for the ray org + t dir, t in (0, tmax). */
SPT_FN_INLINE void bvh_short_init(BvhShort *s, vec3 org, vec3 dir, float tmax)
{
    bvh_ray_init(&s->r, org, dir);
    s->best = tmax;
    s->found = 0;
    s->sp = 0;
    s->bot = 0;
    s->depth = 0;
    s->restart = -1;
    s->dropped = 0;
    s->cur = 0;
    s->count = 0;
}

/* bvh_traverse with the short stack, of cap entries (1 .. BVH_SHORT_STACK_SIZE). */
SPT_FN int bvh_traverse_short(const SPT_GLOBAL BvhNode *nodes, const SPT_GLOBAL float *tris,
                              vec3 org, vec3 dir, float tmax, int any_hit, int cap, BvhHit *hit)
{
    BvhShort s;
    bvh_short_init(&s, org, dir, tmax);
    while (bvh_short_step(nodes, tris, &s, any_hit, cap))
        ;
    if (s.found)
        *hit = s.hit;
    return s.found;
}

#endif
