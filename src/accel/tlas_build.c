/* The top level of an instanced scene (src/accel/tlas_build.h): the inverse of
 * each instance's transform, its world-space box, and the 8-wide SAH tree of
 * src/accel/bvh_build.c over those boxes. */
#include "accel/tlas_build.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* The inverse of the 3x4 affine m (rows, column 3 the translation) in double,
 * rounded to float into inv; returns the determinant of m's linear part (0 or
 * non-finite: no inverse, inv untouched). */
static double affine_inverse(const float *m, float *inv)
{
    double a = m[0], b = m[1], c = m[2], d = m[4], e = m[5], f = m[6], g = m[8], h = m[9],
           k = m[10];
    double det = a * (e * k - f * h) - b * (d * k - f * g) + c * (d * h - e * g);
    if (!(det != 0.0) || !isfinite(det))
        return 0.0;
    for (int i = 0; i < 12; i++)
        if (!isfinite(m[i]))
            return 0.0;
    double r[9] = {(e * k - f * h) / det, (c * h - b * k) / det, (b * f - c * e) / det,
                   (f * g - d * k) / det, (a * k - c * g) / det, (c * d - a * f) / det,
                   (d * h - e * g) / det, (b * g - a * h) / det, (a * e - b * d) / det};
    for (int row = 0; row < 3; row++) {
        double t = -(r[3 * row] * m[3] + r[3 * row + 1] * m[7] + r[3 * row + 2] * m[11]);
        for (int col = 0; col < 3; col++)
            inv[4 * row + col] = (float)r[3 * row + col];
        inv[4 * row + 3] = (float)t;
    }
    return det;
}

/* The world-space box (6 floats: low, high) of the box lo..hi placed by m:
 * its corners in double, widened by a relative 2^-20 so that the top
 * level's float box test never rejects a ray that meets the mesh in the
 * instance's space after the rounding of the ray's transform (the ray's
 * rounding there is a few ulps of float, far below 2^-20). */
static void world_box(const float *m, const float lo[3], const float hi[3], float *box)
{
    double wlo[3] = {DBL_MAX, DBL_MAX, DBL_MAX}, whi[3] = {-DBL_MAX, -DBL_MAX, -DBL_MAX};
    for (int corner = 0; corner < 8; corner++) {
        double p[3] = {corner & 1 ? hi[0] : lo[0], corner & 2 ? hi[1] : lo[1],
                       corner & 4 ? hi[2] : lo[2]};
        for (int r = 0; r < 3; r++) {
            double w = m[4 * r] * p[0] + m[4 * r + 1] * p[1] + m[4 * r + 2] * p[2] + m[4 * r + 3];
            wlo[r] = fmin(wlo[r], w);
            whi[r] = fmax(whi[r], w);
        }
    }
    double ext = 0.0;
    for (int r = 0; r < 3; r++)
        ext = fmax(ext, fmax(fabs(wlo[r]), fabs(whi[r])));
    double pad = ext * 0x1p-20;
    for (int r = 0; r < 3; r++) {
        box[r] = nextafterf((float)(wlo[r] - pad), -FLT_MAX);
        box[3 + r] = nextafterf((float)(whi[r] + pad), FLT_MAX);
    }
}

int tlas_build(Tlas *tlas, const Bvh *meshes, const uint32_t *mesh_prim_base, uint32_t mesh_count,
               const float *xf, const uint32_t *inst_mesh, uint32_t inst_count, SptError *e)
{
    double t0 = spt_now();
    memset(tlas, 0, sizeof *tlas);
    for (uint32_t i = 0; i < inst_count; i++)
        if (inst_mesh[i] >= mesh_count)
            return spt_fail(e, SPT_EXIT_INPUT, "instances[%u]: mesh %u of %u", i, inst_mesh[i],
                            mesh_count);
    /* The meshes' levels one after another; an instance names where its
     * mesh's begin. */
    size_t *node_base = spt_malloc((mesh_count + 1) * sizeof *node_base);
    size_t *word_base = spt_malloc((mesh_count + 1) * sizeof *word_base);
    size_t nodes = 0, words = 0;
    for (uint32_t m = 0; m < mesh_count; m++) {
        node_base[m] = nodes;
        word_base[m] = words;
        nodes += meshes[m].node_count;
        words += meshes[m].tri_data_bytes / sizeof(float);
        tlas->stats.unique_tris += meshes[m].prim_count;
    }
    if (nodes > UINT32_MAX || words > UINT32_MAX) {
        free(node_base);
        free(word_base);
        return spt_fail(e, SPT_EXIT_INPUT, "instances: the meshes' BVHs take %zu nodes and %zu "
                        "words, more than 32-bit indices reach", nodes, words);
    }
    tlas->nodes = spt_malloc((nodes ? nodes : 1) * sizeof *tlas->nodes);
    tlas->tris = spt_malloc((words ? words : 1) * sizeof *tlas->tris);
    for (uint32_t m = 0; m < mesh_count; m++) {
        memcpy(tlas->nodes + node_base[m], meshes[m].nodes, meshes[m].node_count * sizeof(BvhNode));
        memcpy(tlas->tris + word_base[m], meshes[m].tri_data, meshes[m].tri_data_bytes);
    }
    tlas->node_count = nodes;
    tlas->tri_words = words;

    /* The instances that can be inverted, with their boxes. */
    BvhInstance *kept = spt_malloc((inst_count ? inst_count : 1) * sizeof *kept);
    uint32_t *kept_index = spt_malloc((inst_count ? inst_count : 1) * sizeof *kept_index);
    float *boxes = spt_malloc((inst_count ? inst_count : 1) * 6 * sizeof *boxes);
    uint32_t n = 0;
    for (uint32_t i = 0; i < inst_count; i++) {
        const float *m = xf + 12 * (size_t)i;
        const Bvh *mesh = &meshes[inst_mesh[i]];
        BvhInstance *in = &kept[n];
        memset(in, 0, sizeof *in);
        double det = affine_inverse(m, in->inv);
        if (det == 0.0) {
            tlas->stats.dropped++;
            continue;
        }
        if (mesh->prim_count == 0)
            continue; /* nothing to hit */
        memcpy(in->xf, m, sizeof in->xf);
        in->node_base = (uint32_t)node_base[inst_mesh[i]];
        in->tri_base = (uint32_t)word_base[inst_mesh[i]];
        in->prim_base = mesh_prim_base ? mesh_prim_base[inst_mesh[i]] : 0;
        in->flags = det < 0.0 ? BVH_INSTANCE_MIRRORED : 0u;
        float lo[3], hi[3];
        bvh_bounds(mesh, lo, hi);
        world_box(m, lo, hi, boxes + 6 * (size_t)n);
        kept_index[n] = i;
        tlas->stats.instanced_tris += mesh->prim_count;
        n++;
    }
    free(node_base);
    free(word_base);

    uint32_t *order = spt_malloc((n ? n : 1) * sizeof *order);
    int rc = bvh_build_boxes(boxes, n, &tlas->top, &tlas->top_count, order, e);
    free(boxes);
    if (rc) {
        free(order);
        free(kept);
        free(kept_index);
        tlas_free(tlas);
        return rc;
    }
    /* The instances in the tree's order: a leaf's child is its position. */
    tlas->inst = spt_malloc((n ? n : 1) * sizeof *tlas->inst);
    tlas->inst_index = spt_malloc((n ? n : 1) * sizeof *tlas->inst_index);
    tlas->inst_mesh = spt_malloc((n ? n : 1) * sizeof *tlas->inst_mesh);
    for (uint32_t k = 0; k < n; k++) {
        tlas->inst[k] = kept[order[k]];
        tlas->inst_index[k] = kept_index[order[k]];
        tlas->inst_mesh[k] = inst_mesh[tlas->inst_index[k]];
    }
    if (n == 0)
        memset(tlas->inst, 0, sizeof *tlas->inst);
    tlas->inst_count = n;
    free(order);
    free(kept);
    free(kept_index);
    tlas->stats.instances = n;
    tlas->stats.top_bytes = tlas->top_count * sizeof(BvhNode) + (n ? n : 1) * sizeof(BvhInstance);
    tlas->stats.bottom_bytes = nodes * sizeof(BvhNode) + words * sizeof(float);
    tlas->stats.build_seconds = spt_now() - t0;
    return SPT_EXIT_OK;
}

double tlas_placed_tri(const BvhInstance *in, vec3 a, vec3 b, vec3 c, double *lo, double *hi, double *n)
{
    const vec3 v[3] = {a, b, c};
    double p[3][3];
    for (int q = 0; q < 3; q++)
        for (int r = 0; r < 3; r++) {
            p[q][r] = (double)in->xf[4 * r] * v[q].x + (double)in->xf[4 * r + 1] * v[q].y +
                      (double)in->xf[4 * r + 2] * v[q].z + in->xf[4 * r + 3];
            if (lo) {
                lo[r] = fmin(lo[r], p[q][r]);
                hi[r] = fmax(hi[r], p[q][r]);
            }
        }
    double e1[3], e2[3];
    for (int r = 0; r < 3; r++) {
        e1[r] = p[1][r] - p[0][r];
        e2[r] = p[2][r] - p[0][r];
    }
    double cr[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                    e1[0] * e2[1] - e1[1] * e2[0]};
    double len = sqrt(cr[0] * cr[0] + cr[1] * cr[1] + cr[2] * cr[2]);
    /* The winding a mirrored instance reverses (BVH_INSTANCE_MIRRORED). */
    double sign = in->flags & BVH_INSTANCE_MIRRORED ? -1.0 : 1.0;
    for (int r = 0; n && r < 3; r++)
        n[r] = len > 0.0 ? sign * cr[r] / len : 0.0;
    return 0.5 * len;
}

void tlas_emitter_power(const Tlas *tl, const Bvh *meshes, const float *const *weight, double *power)
{
    for (uint32_t k = 0; k < tl->inst_count; k++) {
        uint32_t m = tl->inst_mesh[k];
        double sum = 0.0;
        if (weight[m]) {
            const Bvh *b = &meshes[m];
            for (uint32_t i = 0; i < b->prim_count; i++) {
                float w = weight[m][b->prim_index[i]];
                if (!(w > 0.0f))
                    continue;
                vec3 v[3];
                bvh_vertices(b, i, &v[0], &v[1], &v[2]);
                sum += (double)w * tlas_placed_tri(&tl->inst[k], v[0], v[1], v[2], NULL, NULL, NULL);
            }
        }
        power[k] = sum;
    }
}

void tlas_free(Tlas *tlas)
{
    if (!tlas)
        return;
    free(tlas->top);
    free(tlas->inst);
    free(tlas->inst_index);
    free(tlas->inst_mesh);
    free(tlas->nodes);
    free(tlas->tris);
    memset(tlas, 0, sizeof *tlas);
}
