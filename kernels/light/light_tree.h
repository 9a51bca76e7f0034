/* The light tree (C99 and OpenCL C 1.2): next-event estimation picks a light
 * in proportion to an importance that depends on the shading point, after
 * Conty Estevez and Kulla 2018, "Importance Sampling of Many Lights with
 * Adaptive Tree Splitting" (the tree of light bounds and its importance,
 * sections 4.1-4.3, without the adaptive splitting). src/render/light_tree.c
 * builds it over the emissive triangles (an instanced mesh's as one leaf per
 * instance: kernels/light/inst_lights.h) and the point and spot lights;
 * directional lights and the environment stay outside it, chosen by power
 * beside it (docs/architecture.md, "Light selection").
 *
 * A node bounds its lights' positions (a box), the directions their surfaces
 * face (a cone: axis, spread theta_o), how far from such a direction they
 * emit (theta_e: pi/2 for a Lambertian emitter, 0 for a spot, whose cone is
 * theta_o) and their power. At a shading point p with geometric normal n its
 * importance is
 *   power * cos(theta') * cos(theta'_i) / d^2,
 * theta' the smallest angle between a direction of the cone of normals and a
 * direction from the box toward p (importance 0 when theta' exceeds
 * theta_e, where none of the node's lights emits toward p; a spot's
 * theta_e 0 passes only directions inside its cone, theta' 0),
 * theta'_i the smallest angle between n and a direction from p into the box
 * (importance 0 when every direction to the box lies below p's horizon,
 * both horizons for a transmissive BSDF), and d the distance to the box's
 * centre, at least the box's half diagonal (so a point inside a box does
 * not make it infinite). The angular terms bound the cosines of every light
 * of the node from above; the distance term is the paper's stand-in for the
 * distance, not a bound.
 *
 * Picking descends from the root, at each node choosing a child in proportion
 * to its importance (light_tree_split); the probability of a given light at p is the product of
 * those choices on its way down, which light_tree_pmf recomputes from its leaf
 * up (the MIS weight of a BSDF-sampled hit on an emitter needs it). */
#ifndef SPT_LIGHT_TREE_H
#define SPT_LIGHT_TREE_H

#include "util/portable.h"
#include "util/vecmath.h"
#include "sample/sampling.h"
#include "util/render_types.h"

/* LightTreeNode is in util/render_types.h (a kernel argument). */

/* The normal's quantization in a path's light context (light_ctx_pack): 12
 * bits per octahedral coordinate, so the decoded normal is within 2e-3 rad
 * of the true one (tests/test_light_tree.c: 1.1e-3); the horizon test widens the box's cone by
 * SPT_TREE_NORMAL_SLACK rad, so no light above the true horizon is lost. */
#define SPT_TREE_NORMAL_BITS 12
#define SPT_TREE_NORMAL_SLACK 4e-3f
#define SPT_TREE_SLACK_COS 0.999992f     /* cos(SPT_TREE_NORMAL_SLACK) */
#define SPT_TREE_SLACK_SIN 0.0039999893f /* sin(SPT_TREE_NORMAL_SLACK) */
/* The smallest squared distance the importance divides by, relative to a
 * root power of 1: keeps the sums of two children finite. */
#define SPT_TREE_MIN_D2 1e-12f

/* cos(a - b) for angles a, b in [0, pi] given by sine and cosine, 1 when
 * a <= b (the clamped difference max(a - b, 0)); sin likewise. */
SPT_FN float tree_cos_sub(float sa, float ca, float sb, float cb)
{
    return ca >= cb ? 1.0f : ca * cb + sa * sb;
}

SPT_FN float tree_sin_sub(float sa, float ca, float sb, float cb)
{
    return ca >= cb ? 0.0f : sa * cb - ca * sb;
}

/* The normal n (unit) and whether the BSDF takes light from both of its
 * sides, as one float: an integer below 2^24 (exact in a float) holding
 * n's octahedral coordinates, negative for two sides. */
SPT_FN float light_ctx_pack(vec3 n, spt_i32 two_sided)
{
    float s = fabsf(n.x) + fabsf(n.y) + fabsf(n.z);
    float ox = n.x / s, oy = n.y / s;
    if (n.z < 0.0f) {
        float tx = (1.0f - fabsf(oy)) * (ox >= 0.0f ? 1.0f : -1.0f);
        float ty = (1.0f - fabsf(ox)) * (oy >= 0.0f ? 1.0f : -1.0f);
        ox = tx;
        oy = ty;
    }
    float m = (float)((1 << SPT_TREE_NORMAL_BITS) - 1);
    float ix = floorf((ox * 0.5f + 0.5f) * m + 0.5f), iy = floorf((oy * 0.5f + 0.5f) * m + 0.5f);
    float v = ix + iy * (float)(1 << SPT_TREE_NORMAL_BITS) + 1.0f;
    return two_sided ? -v : v;
}

/* The normal light_ctx_pack packed into w (unit), and its sides in *two_sided. */
SPT_FN vec3 light_ctx_normal(float w, spt_i32 *two_sided)
{
    *two_sided = w < 0.0f;
    float v = fabsf(w) - 1.0f;
    float scale = (float)(1 << SPT_TREE_NORMAL_BITS), m = scale - 1.0f;
    float iy = floorf(v / scale);
    float ix = v - iy * scale;
    float ox = ix / m * 2.0f - 1.0f, oy = iy / m * 2.0f - 1.0f;
    float z = 1.0f - fabsf(ox) - fabsf(oy);
    if (z < 0.0f) {
        float tx = (1.0f - fabsf(oy)) * (ox >= 0.0f ? 1.0f : -1.0f);
        float ty = (1.0f - fabsf(ox)) * (oy >= 0.0f ? 1.0f : -1.0f);
        ox = tx;
        oy = ty;
    }
    return v3_normalize(v3(ox, oy, z));
}

/* The importance of node t at point p whose (decoded) normal is n, taking
 * light from one side of it or from both (two_sided); see the top of the
 * file. */
SPT_FN float light_tree_importance(const SPT_GLOBAL LightTreeNode *t, vec3 p, vec3 n, spt_i32 two_sided)
{
    vec3 lo = v3(t->lo[0], t->lo[1], t->lo[2]), hi = v3(t->hi[0], t->hi[1], t->hi[2]);
    vec3 c = v3_scale(v3_add(lo, hi), 0.5f);
    vec3 h = v3_scale(v3_sub(hi, lo), 0.5f);
    float r2 = v3_dot(h, h);
    vec3 d = v3_sub(p, c);
    float d2 = v3_dot(d, d);
    /* The cone of directions from p into the box's bounding sphere. */
    float sin_b = 0.0f, cos_b = -1.0f;
    vec3 w = v3(0.0f, 0.0f, 1.0f);
    if (d2 > r2) {
        float s2 = r2 / d2;
        sin_b = sqrtf(s2);
        cos_b = sqrtf(1.0f - s2);
    }
    if (d2 > 0.0f)
        w = v3_scale(d, 1.0f / sqrtf(d2));
    /* theta': from the cone of normals to the directions toward p. */
    float cos_w = v3_dot(v3(t->axis[0], t->axis[1], t->axis[2]), w);
    if (t->two_sided)
        cos_w = fabsf(cos_w);
    float sin_w = sqrtf(fmaxf(0.0f, 1.0f - cos_w * cos_w));
    float cos_o = t->cos_o, sin_o = sqrtf(fmaxf(0.0f, 1.0f - cos_o * cos_o));
    float cos_x = tree_cos_sub(sin_w, cos_w, sin_o, cos_o);
    float sin_x = tree_sin_sub(sin_w, cos_w, sin_o, cos_o);
    float cos_p = tree_cos_sub(sin_x, cos_x, sin_b, cos_b);
    if (cos_p < t->cos_e || !(cos_p > 0.0f))
        return 0.0f;
    /* theta'_i: from p's normal to the directions into the box, the box's
     * cone widened by the normal's quantization. */
    const float cs = SPT_TREE_SLACK_COS, ss = SPT_TREE_SLACK_SIN;
    float cos_bn = -1.0f, sin_bn = 0.0f;
    if (cos_b > -cs) {
        cos_bn = cos_b * cs - sin_b * ss;
        sin_bn = sin_b * cs + cos_b * ss;
    }
    float cos_i = -v3_dot(n, w);
    if (two_sided)
        cos_i = fabsf(cos_i);
    float sin_i = sqrtf(fmaxf(0.0f, 1.0f - cos_i * cos_i));
    float cos_ip = tree_cos_sub(sin_i, cos_i, sin_bn, cos_bn);
    if (!(cos_ip > 0.0f))
        return 0.0f;
    return t->power * cos_p * cos_ip / fmaxf(fmaxf(d2, r2), SPT_TREE_MIN_D2);
}

/* The probabilities of choosing children c[0] and c[1] of a node whose
 * importances are i0 and i1: in proportion to them, or when both are 0 (no
 * light below can reach the point, though the node's wider bounds said one
 * might) to the children's powers, so that every descent ends at a leaf and
 * the probabilities of all lights sum to 1. */
SPT_FN void light_tree_split(const SPT_GLOBAL LightTreeNode *c, float i0, float i1, float *p0, float *p1)
{
    float s = i0 + i1;
    if (!(s > 0.0f)) {
        i0 = c[0].power;
        i1 = c[1].power;
        s = i0 + i1;
    }
    if (!(s > 0.0f)) {
        *p0 = *p1 = 0.5f;
        return;
    }
    *p0 = i0 / s;
    *p1 = i1 / s;
}

/* Picks a light of tree t at (p, n, two_sided) with u in [0, 1): its index in
 * the light selection, and the probability of that pick in *prob. */
SPT_FN spt_i32 light_tree_sample(const SPT_GLOBAL LightTreeNode *t, vec3 p, vec3 n, spt_i32 two_sided,
                                 float u, float *prob)
{
    spt_u32 k = 0u;
    float pr = 1.0f;
    while (!t[k].leaf) {
        spt_u32 c = t[k].child;
        float i0 = light_tree_importance(t + c, p, n, two_sided);
        float i1 = light_tree_importance(t + c + 1u, p, n, two_sided);
        float p0, p1;
        light_tree_split(t + c, i0, i1, &p0, &p1);
        if (u < p0) {
            u = fminf(u / p0, SPT_ONE_MINUS_EPSILON);
            pr *= p0;
            k = c;
        } else {
            u = fminf((u - p0) / p1, SPT_ONE_MINUS_EPSILON);
            pr *= p1;
            k = c + 1u;
        }
    }
    *prob = pr;
    return (spt_i32)t[k].child;
}

/* The probability that light_tree_sample picks the light of leaf node `leaf`
 * at (p, n, two_sided): the product of the choices from the root down to it,
 * computed from the leaf up. */
SPT_FN float light_tree_pmf(const SPT_GLOBAL LightTreeNode *t, spt_u32 leaf, vec3 p, vec3 n,
                            spt_i32 two_sided)
{
    float pr = 1.0f;
    spt_u32 k = leaf;
    while (t[k].parent != SPT_TREE_NONE) {
        spt_u32 up = t[k].parent, c = t[up].child;
        float i0 = light_tree_importance(t + c, p, n, two_sided);
        float i1 = light_tree_importance(t + c + 1u, p, n, two_sided);
        float p0, p1;
        light_tree_split(t + c, i0, i1, &p0, &p1);
        pr *= k == c ? p0 : p1;
        k = up;
    }
    return pr;
}

/* Next-event estimation's pick with a tree: the aside distribution (cdf, n
 * entries: the tree, then each punctual light, whose weight is 0 unless it
 * is directional, then the environment when there is one) chooses by power
 * between the tree and the lights outside it; the tree then descends. The
 * index in the light selection ([emitters | punctual | environment], with
 * emitter_count emitters), its probability in *prob, and in *tree_prob the
 * tree's share of it (1 for a light outside the tree); -1 for none. */
SPT_FN spt_i32 light_tree_pick(const SPT_GLOBAL float *cdf, spt_u32 n, const SPT_GLOBAL LightTreeNode *t,
                               spt_u32 emitter_count, vec3 p, vec3 nrm, spt_i32 two_sided, float u,
                               float *prob, float *tree_prob)
{
    float pa, ur;
    *tree_prob = 1.0f;
    spt_i32 e = spt_discrete_sample(cdf, n, u, &pa, &ur);
    if (e < 0) {
        *prob = 0.0f;
        return -1;
    }
    if (e > 0) {
        *prob = pa;
        return (spt_i32)emitter_count + e - 1;
    }
    float pt;
    spt_i32 k = light_tree_sample(t, p, nrm, two_sided, ur, &pt);
    *tree_prob = pt;
    *prob = pa * pt;
    return k;
}

#endif
