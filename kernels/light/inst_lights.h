/* Emitters on instanced meshes (docs/architecture.md, "Instances (two
 * levels)"), C99 and OpenCL C 1.2: the light selection holds one entry per
 * instance whose mesh emits, weighted by the power of its emitting triangles
 * placed by the instance; the entry's triangle is then picked from its
 * mesh's distribution over its emitting triangles (by their power in the
 * mesh's space), stored once for all the mesh's instances, and a point
 * uniformly on the placed triangle. A sample's density per world area is
 * P(entry) p(triangle) / (the placed triangle's area).
 *
 * The inst_light buffer (built by src/render/render_lights.c), uints:
 *  - [0, inst_count): per instance k (the top level's order), its entry in
 *    the light selection, or SPT_INST_LIGHT_NONE (its mesh emits nothing;
 *    the instance placing the world's triangles, whose emitters are entries
 *    of their own);
 *  - then per instance entry j (selection entry tri_emitters + j), two
 *    words: where its mesh's list starts in inst_light, and its leaf in the
 *    light tree (SPT_TREE_NONE without the tree, or outside it);
 *  - a mesh's list: its count n of emitting triangles, the offset of their
 *    CDF (n + 1 floats) in light_cdf, then the n packed triangles. */
#ifndef SPT_INST_LIGHTS_H
#define SPT_INST_LIGHTS_H

#include "util/portable.h"
#include "sample/sampling.h"

#define SPT_INST_LIGHT_NONE 0xffffffffu

/* The triangle's pick takes a hashed number (spt_rand_key) of the pick's
 * own dim: the light selection's dim of the bounce with this bit set, out
 * of the samplers' range, independent of the selection's number (whose
 * remainder after a descent of the light tree keeps few bits). */
#define SPT_DIM_INST_TRI 0x40000000u

/* The light tree leaf of instance entry j (SPT_TREE_NONE: none). */
SPT_FN spt_u32 inst_light_leaf(const SPT_GLOBAL spt_u32 *il, spt_u32 inst_count, spt_u32 j)
{
    return il[inst_count + 2u * j + 1u];
}

/* Picks a triangle of instance entry j with u in [0, 1) from its mesh's
 * distribution (cdf: light_cdf): its packed index, and its probability
 * among the mesh's emitting triangles in *prob; SPT_INST_LIGHT_NONE (prob
 * 0) when there is none. */
SPT_FN spt_u32 inst_light_pick(const SPT_GLOBAL spt_u32 *il, const SPT_GLOBAL float *cdf, spt_u32 inst_count,
                               spt_u32 j, float u, float *prob)
{
    spt_u32 d = il[inst_count + 2u * j];
    spt_i32 t = spt_discrete_sample(cdf + il[d + 1u], il[d], u, prob, 0);
    return t < 0 ? SPT_INST_LIGHT_NONE : il[d + 2u + (spt_u32)t];
}

#endif
