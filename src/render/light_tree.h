/* The host's construction of the light tree of kernels/light/light_tree.h
 * (Conty Estevez and Kulla 2018): a binary tree over the lights that
 * next-event estimation picks by importance at the shading point, built top
 * down by binned splits that minimise the paper's surface area orientation
 * heuristic (SAOH, its section 4.4). */
#ifndef SPT_HOST_LIGHT_TREE_H
#define SPT_HOST_LIGHT_TREE_H

#include <stdint.h>

#include "light/light_tree.h"

/* The bounds of one light: its box, the cone of its normals (axis, spread
 * theta_o in radians), how far beyond them it emits (theta_e), its power
 * (any unit, the same for all) and whether it emits on both sides. */
typedef struct LightBound {
    double lo[3], hi[3];
    double axis[3];
    double theta_o, theta_e;
    double power;
    int two_sided;
} LightBound;

/* A built tree: nodes (node 0 the root, 2 n - 1 of them for n lights) and,
 * per light k of the input, the index of its leaf. */
typedef struct LightTree {
    LightTreeNode *nodes;
    uint32_t count;
    uint32_t *leaf_of;
} LightTree;

/* Builds t over lights[0..n-1] (n >= 1, every power > 0); leaf k's `child`
 * is ids[k] (the light's index in the renderer's light selection). */
void light_tree_build(LightTree *t, const LightBound *lights, const uint32_t *ids, uint32_t n);

void light_tree_free(LightTree *t);

#endif
