/* BVH refit (src/accel/bvh_build.h, bvh_refit): the tree of an earlier build
 * kept, its leaf blocks' vertices and its nodes' boxes recomputed from moved
 * triangles (docs/gltf.md, "Frame sequences"). */
#include "accel/bvh_build.h"

#include <float.h>
#include <stdlib.h>
#include <string.h>

#include "accel/bvh_builder.h"

/* Whether triangle p is one bvh_build keeps: every coordinate finite and
 * below 1e18 in magnitude (NaN compares false), and a non-zero area. */
static int tri_kept(const float *p)
{
    for (int k = 0; k < 9; k++)
        if (!(p[k] < 1e18f && p[k] > -1e18f))
            return 0;
    return !bvh_tri_zero_area(p);
}

/* Rewrites the vertices of the leaf block at p from tri_pos; its box into lo,
 * hi. 0 when two corners that shared a vertex of the block have moved apart
 * (the block would need another vertex: only a build can give it one). */
static int refit_leaf(const Bvh *bvh, float *p, const float *tri_pos, float lo[3], float hi[3])
{
    uint32_t first = bvh_word(p, 0), nv = bvh_word(p, 1) & 255u, n = bvh_word(p, 1) >> 8;
    const uint8_t *idx = (const uint8_t *)(p + 2 + 3 * nv);
    uint32_t written = 0; /* bit j: vertex j of the block rewritten */
    for (int a = 0; a < 3; a++) {
        lo[a] = FLT_MAX;
        hi[a] = -FLT_MAX;
    }
    for (uint32_t l = 0; l < n; l++) {
        const float *t = tri_pos + (size_t)bvh->prim_index[first + l] * 9;
        for (uint32_t c = 0; c < 3; c++) {
            uint32_t j = idx[c * n + l];
            const float *v = t + 3 * c;
            if (written >> j & 1u) {
                if (memcmp(&p[2 + j], &v[0], 4) || memcmp(&p[2 + nv + j], &v[1], 4) ||
                    memcmp(&p[2 + 2 * nv + j], &v[2], 4))
                    return 0;
                continue;
            }
            written |= 1u << j;
            for (int a = 0; a < 3; a++) {
                p[2 + a * nv + j] = v[a];
                lo[a] = minf(lo[a], v[a]);
                hi[a] = maxf(hi[a], v[a]);
            }
        }
    }
    return 1;
}

int bvh_refit(Bvh *bvh, const float *tri_pos, uint32_t tri_count, uint32_t built_count)
{
    double t0 = spt_now();
    if (tri_count != built_count)
        return 0;
    /* The same triangles must be kept: a kept one gone degenerate, or a
     * dropped one become valid, changes what the tree holds. */
    unsigned char *kept = spt_calloc(tri_count ? tri_count : 1, 1);
    for (uint32_t i = 0; i < bvh->prim_count; i++)
        kept[bvh->prim_index[i]] = 1;
    int ok = 1;
    for (uint32_t i = 0; i < tri_count && ok; i++)
        ok = tri_kept(tri_pos + (size_t)i * 9) == kept[i];
    free(kept);
    if (!ok || bvh->prim_count == 0) {
        bvh->refitted = ok;
        return ok;
    }
    /* A child's node index is above its parent's (bvh_build.c), so from the
     * last node to the root every child's box is final before its parent
     * reads it. */
    for (uint32_t k = bvh->node_count; k-- > 0;) {
        BvhNode *nd = &bvh->nodes[k];
        for (int c = 0; c < BVH_WIDTH; c++) {
            float lo[3], hi[3];
            if (nd->count[c]) {
                if (!refit_leaf(bvh, bvh->tri_data + nd->child[c], tri_pos, lo, hi))
                    return 0;
            } else if (nd->child[c]) {
                const BvhNode *ch = &bvh->nodes[nd->child[c]];
                for (int a = 0; a < 3; a++) {
                    lo[a] = FLT_MAX;
                    hi[a] = -FLT_MAX;
                    for (int i = 0; i < BVH_WIDTH; i++) {
                        lo[a] = minf(lo[a], ch->bounds[2 * a][i]);
                        hi[a] = maxf(hi[a], ch->bounds[2 * a + 1][i]);
                    }
                }
            } else {
                continue; /* an unused slot keeps its empty box */
            }
            for (int a = 0; a < 3; a++) {
                nd->bounds[2 * a][c] = lo[a];
                nd->bounds[2 * a + 1][c] = hi[a];
            }
        }
    }
    bvh->stats.build_seconds = spt_now() - t0;
    bvh->refitted = 1;
    return 1;
}
