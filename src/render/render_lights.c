/* The lights of one render: the scene's emitters and punctual lights, the sky of
 * the render settings, and the distribution that picks among them. */
#include "render/render_lights.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "light/inst_lights.h"
#include "spectrum/cie_data.h"

void render_lights_free(RenderLights *L)
{
    env_free(&L->env);
    distrib_free(&L->select);
    free(L->tri_light_pdf);
    light_tree_free(&L->tree);
    distrib_free(&L->aside);
    free(L->cdf_all);
    free(L->tri_leaf);
    free(L->inst_light);
    memset(L, 0, sizeof *L);
}

/* The environment of a render: the sky of the settings (src/scene/sky.h) as the
 * kernels' environment, a map rotated and scaled by env_rotation and
 * env_intensity; and for a scene with no light at all and no sky given, the
 * default sky, D65 of radiance 1 (linear sRGB 1, 1, 1), with a note. */
static int env_setup(const RenderSettings *rs, const GpuScene *g, EnvLight *env, SptError *e)
{
    memset(env, 0, sizeof *env);
    env->env.rot_cos = 1.0f;
    const Sky *sky = rs->sky;
    if (!(rs->env_intensity >= 0.0f) || !isfinite(rs->env_intensity))
        return spt_fail(e, SPT_EXIT_USAGE, "--env-intensity must be finite and >= 0");
    int kind = sky ? sky->kind : SPT_SKY_DEFAULT;
    if (kind == SPT_SKY_MAP)
        return env_build_map(env, sky->map, sky->map_width, sky->map_height,
                             rs->env_rotation * (float)(M_PI / 180.0), rs->env_intensity,
                             sky->env ? sky->env : "the environment map", e);
    if (kind == SPT_SKY_DEFAULT) {
        if (g->emitter_count > 0 || g->light_count > 0)
            return 0;
        spt_note("the scene has no lights: it is lit by a uniform white sky (D65, radiance 1); "
                 "use --env FILE or --background R,G,B|SPD|black to change it");
        const float white[3] = {1.0f, 1.0f, 1.0f};
        env_build_uniform(env, white, 1.0f);
        return 0;
    }
    if (kind == SPT_SKY_RGB) {
        if (sky->rgb[0] > 0 || sky->rgb[1] > 0 || sky->rgb[2] > 0)
            env_build_uniform(env, sky->rgb, 1.0f);
        return 0;
    }
    if (kind == SPT_SKY_SPD) {
        /* The SPD normalised to luminance Y = 1: a table in the environment's data. */
        env->data = spt_calloc(SPT_CIE_SAMPLES, sizeof(float));
        env->data_count = SPT_CIE_SAMPLES;
        memcpy(env->data, sky->spd, SPT_CIE_SAMPLES * sizeof(float));
        env->env.kind = SPT_ENV_UNIFORM;
        env->env.uniform.kind = SPT_SPEC_TABLE;
        env->env.uniform.scale = (float)(SPT_CIE_Y_INTEGRAL / sky->spd_y);
        env->env.uniform.offset = 0;
        env->y_mean = 1.0;
    }
    return 0; /* SPT_SKY_BLACK */
}

/* --light-tree auto: the tree when the box of its lights spans at least
 * this share of the scene's bounding sphere's diameter. Lights that crowd
 * one spot (the Cornell box's ceiling light, 0.17 of it) look alike from
 * every point, and there the tree's picks cost time (10% fewer samples in
 * the same seconds) for no lower error (docs/performance.md, "Light
 * tree"). */
#define TREE_AUTO_SPREAD 0.25

/* The tree's bounds of instance emitter k (an entry from
 * g->tri_emitter_count on): the box of its mesh's emitting triangles
 * placed, the cone of their world-space normals about their area-weighted
 * mean (every direction when that mean is 0), theta_e pi/2 (Lambertian),
 * two-sided when one of their materials emits on both sides; power 0.
 * Its work is the mesh's emitting triangles; it stores nothing. */
static void inst_emitter_bound(const GpuScene *g, uint32_t k, LightBound *l)
{
    const BvhInstance *in = &g->tlas.inst[g->emitters[k]];
    uint32_t m = g->tlas.inst_mesh[g->emitters[k]];
    memset(l, 0, sizeof *l);
    for (int a = 0; a < 3; a++) {
        l->lo[a] = INFINITY;
        l->hi[a] = -INFINITY;
    }
    double sum[3] = {0.0, 0.0, 0.0};
    for (int pass = 0; pass < 2; pass++)
        for (uint32_t j = g->mesh_emitter_first[m]; j < g->mesh_emitter_first[m + 1]; j++) {
            uint32_t prim = g->mesh_emitter_prims[j];
            vec3 a, b, c;
            double n[3];
            gpu_scene_tri(g, prim, &a, &b, &c);
            double area = tlas_placed_tri(in, a, b, c, pass ? NULL : l->lo, pass ? NULL : l->hi, n);
            if (pass == 0) {
                for (int q = 0; q < 3; q++)
                    sum[q] += area * n[q];
                const GpuMaterial *mt = &g->materials[g->tri_shade[prim].material];
                l->two_sided |= (mt->flags & SPT_MAT_DOUBLE_SIDED_EMISSION) != 0;
            } else if (l->theta_o < M_PI && n[0] * n[0] + n[1] * n[1] + n[2] * n[2] > 0.0) {
                double d = n[0] * l->axis[0] + n[1] * l->axis[1] + n[2] * l->axis[2];
                l->theta_o = fmax(l->theta_o, acos(fmax(-1.0, fmin(1.0, d))));
            }
            if (pass == 0 && j + 1 == g->mesh_emitter_first[m + 1]) {
                double len = sqrt(sum[0] * sum[0] + sum[1] * sum[1] + sum[2] * sum[2]);
                for (int q = 0; q < 3; q++)
                    l->axis[q] = len > 0.0 ? sum[q] / len : (q == 2);
                l->theta_o = len > 0.0 ? 0.0 : M_PI;
            }
        }
    l->theta_e = 0.5 * M_PI;
}

/* Per tlas mesh, the box of its emitting triangles in its space (6
 * doubles: low, high; empty for a mesh without). */
static double *mesh_emitter_boxes(const GpuScene *g)
{
    double *box = spt_malloc(sizeof(double) * 6 * g->mesh_count);
    for (uint32_t m = 0; m < g->mesh_count; m++) {
        for (int a = 0; a < 3; a++) {
            box[6 * m + a] = INFINITY;
            box[6 * m + 3 + a] = -INFINITY;
        }
        for (uint32_t j = g->mesh_emitter_first[m]; j < g->mesh_emitter_first[m + 1]; j++) {
            vec3 v[3];
            gpu_scene_tri(g, g->mesh_emitter_prims[j], &v[0], &v[1], &v[2]);
            for (int q = 0; q < 3; q++) {
                const float c[3] = {v[q].x, v[q].y, v[q].z};
                for (int a = 0; a < 3; a++) {
                    box[6 * m + a] = fmin(box[6 * m + a], c[a]);
                    box[6 * m + 3 + a] = fmax(box[6 * m + 3 + a], c[a]);
                }
            }
        }
    }
    return box;
}

int render_lights_use_tree(const GpuScene *g, const RenderSettings *rs)
{
    if (rs->light_tree == SPT_SWITCH_OFF)
        return 0;
    uint32_t n = g->emitter_count;
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (uint32_t k = 0; k < g->tri_emitter_count; k++) {
        vec3 v[3];
        bvh_vertices(&g->bvh, g->emitters[k], &v[0], &v[1], &v[2]);
        for (int q = 0; q < 3; q++) {
            const float c[3] = {v[q].x, v[q].y, v[q].z};
            for (int a = 0; a < 3; a++) {
                lo[a] = fmin(lo[a], c[a]);
                hi[a] = fmax(hi[a], c[a]);
            }
        }
    }
    /* An instance's emitters: its mesh's emitters' box in the mesh's space
     * (found once per mesh), its corners placed. */
    double *mesh_box = g->emitter_count > g->tri_emitter_count ? mesh_emitter_boxes(g) : NULL;
    for (uint32_t k = g->tri_emitter_count; k < g->emitter_count; k++) {
        const BvhInstance *in = &g->tlas.inst[g->emitters[k]];
        const double *mb = mesh_box + 6 * (size_t)g->tlas.inst_mesh[g->emitters[k]];
        for (int corner = 0; corner < 8; corner++)
            for (int r = 0; r < 3; r++) {
                double w = in->xf[4 * r + 3];
                for (int c = 0; c < 3; c++)
                    w += (double)in->xf[4 * r + c] * mb[corner >> c & 1 ? 3 + c : c];
                lo[r] = fmin(lo[r], w);
                hi[r] = fmax(hi[r], w);
            }
    }
    free(mesh_box);
    for (uint32_t j = 0; j < g->light_count; j++) {
        if (g->lights[j].type == SPT_PUNCTUAL_DIRECTIONAL)
            continue;
        n++;
        for (int a = 0; a < 3; a++) {
            lo[a] = fmin(lo[a], g->lights[j].pos[a]);
            hi[a] = fmax(hi[a], g->lights[j].pos[a]);
        }
    }
    if (n < 2)
        return 0;
    if (rs->light_tree == SPT_SWITCH_ON)
        return 1;
    double d2 = 0.0;
    for (int a = 0; a < 3; a++)
        d2 += (hi[a] - lo[a]) * (hi[a] - lo[a]);
    return sqrt(d2) >= TREE_AUTO_SPREAD * 2.0 * (double)g->scene_radius;
}

/* The tree's bounds of every light it holds: the emitters (a triangle's
 * box, its normal, theta_e pi/2: Lambertian; two-sided when its material
 * emits on both sides; an instance's, inst_emitter_bound) and the point and spot lights (a point; a point
 * light emits everywhere, a spot within its outer cone). ids: their indices
 * in the light selection. Returns how many. */
static uint32_t tree_lights(const GpuScene *g, const RenderLights *L, LightBound *out, uint32_t *ids)
{
    uint32_t n = 0;
    for (uint32_t k = 0; k < g->emitter_count; k++) {
        double w = distrib_prob(&L->select, k);
        if (!(w > 0.0))
            continue;
        if (k >= g->tri_emitter_count) {
            inst_emitter_bound(g, k, &out[n]);
            out[n].power = w;
            ids[n++] = k;
            continue;
        }
        vec3 a, b, c;
        bvh_vertices(&g->bvh, g->emitters[k], &a, &b, &c);
        LightBound *l = &out[n];
        memset(l, 0, sizeof *l);
        const float *v[3] = {&a.x, &b.x, &c.x};
        for (int q = 0; q < 3; q++) {
            l->lo[q] = fmin(fmin(v[0][q], v[1][q]), v[2][q]);
            l->hi[q] = fmax(fmax(v[0][q], v[1][q]), v[2][q]);
        }
        double e1[3] = {b.x - a.x, b.y - a.y, b.z - a.z}, e2[3] = {c.x - a.x, c.y - a.y, c.z - a.z};
        double nx = e1[1] * e2[2] - e1[2] * e2[1], ny = e1[2] * e2[0] - e1[0] * e2[2],
               nz = e1[0] * e2[1] - e1[1] * e2[0];
        double len = sqrt(nx * nx + ny * ny + nz * nz);
        if (len > 0.0) {
            l->axis[0] = nx / len;
            l->axis[1] = ny / len;
            l->axis[2] = nz / len;
            l->theta_o = 0.0;
        } else {
            l->axis[2] = 1.0;
            l->theta_o = M_PI;
        }
        l->theta_e = 0.5 * M_PI;
        l->power = w;
        const GpuMaterial *m = &g->materials[g->tri_shade[g->emitters[k]].material];
        l->two_sided = (m->flags & SPT_MAT_DOUBLE_SIDED_EMISSION) != 0;
        ids[n++] = k;
    }
    for (uint32_t j = 0; j < g->light_count; j++) {
        const GpuLight *gl = &g->lights[j];
        double w = distrib_prob(&L->select, g->emitter_count + j);
        if (gl->type == SPT_PUNCTUAL_DIRECTIONAL || !(w > 0.0))
            continue;
        LightBound *l = &out[n];
        memset(l, 0, sizeof *l);
        for (int q = 0; q < 3; q++)
            l->lo[q] = l->hi[q] = gl->pos[q];
        if (gl->type == SPT_PUNCTUAL_SPOT) {
            for (int q = 0; q < 3; q++)
                l->axis[q] = gl->dir[q];
            l->theta_o = acos(fmax(-1.0, 1.0 - (double)gl->spot_span));
            l->theta_e = 0.0;
        } else {
            l->axis[2] = 1.0;
            l->theta_o = M_PI;
            l->theta_e = 0.5 * M_PI;
        }
        l->power = w;
        ids[n++] = g->emitter_count + j;
    }
    return n;
}

/* The tree and the aside distribution of L (render_lights_use_tree), and
 * per instance emitter (entry tri_emitter_count + j) its leaf in inst_leaf[j]. */
static void tree_setup(RenderLights *L, const GpuScene *g, uint32_t *inst_leaf)
{
    uint32_t cap = g->emitter_count + g->light_count;
    LightBound *lb = spt_malloc(sizeof(LightBound) * (cap ? cap : 1));
    uint32_t *ids = spt_malloc(sizeof(uint32_t) * (cap ? cap : 1));
    uint32_t n = tree_lights(g, L, lb, ids);
    double tree_p = 0.0;
    for (uint32_t i = 0; i < n; i++)
        tree_p += lb[i].power;
    if (n == 0) {
        free(lb);
        free(ids);
        return;
    }
    light_tree_build(&L->tree, lb, ids, n);
    /* The aside distribution: the tree's share, then the punctual lights
     * outside it (directional), then the environment, by the same powers. */
    uint32_t m = 1 + g->light_count + (L->select.n > cap ? 1u : 0u);
    float *w = spt_calloc(m, sizeof(float));
    w[0] = (float)tree_p;
    for (uint32_t j = 0; j < g->light_count; j++)
        if (g->lights[j].type == SPT_PUNCTUAL_DIRECTIONAL)
            w[1 + j] = distrib_prob(&L->select, g->emitter_count + j);
    if (m > 1 + g->light_count)
        w[m - 1] = distrib_prob(&L->select, L->select.n - 1);
    distrib_build(&L->aside, w, m);
    free(w);
    L->aside_offset = L->select.n + 1;
    float pt = distrib_prob(&L->aside, 0);
    /* One word per packed triangle, the instanced meshes' too (the buffer's
     * size, gpu_scene_buffer_bytes); theirs stay 0, their leaves per instance. */
    uint32_t np = g->prim_total;
    L->tri_leaf = spt_calloc(np ? np : 1, sizeof(uint32_t));
    for (uint32_t k = 0; k < g->tri_emitter_count; k++)
        L->tri_light_pdf[g->emitters[k]] = 0.0f;
    for (uint32_t i = 0; i < n; i++)
        if (ids[i] < g->tri_emitter_count) {
            uint32_t prim = g->emitters[ids[i]];
            L->tri_light_pdf[prim] = pt / g->emitter_area[ids[i]];
            L->tri_leaf[prim] = L->tree.leaf_of[i];
        } else if (ids[i] < g->emitter_count) {
            inst_leaf[ids[i] - g->tri_emitter_count] = L->tree.leaf_of[i];
        }
    if (L->env.env.kind != SPT_ENV_NONE)
        L->env_prob = distrib_prob(&L->aside, m - 1);
    free(lb);
    free(ids);
}

/* The kernels' light_cdf (select's CDF, then aside's with the tree, then
 * the instanced meshes' CDFs) and, with instance emitters, inst_light
 * (kernels/light/inst_lights.h; inst_leaf: their tree leaves): each
 * emitting mesh's distribution over its emitting triangles by their power
 * in its space, once however many instances place it, whose probabilities
 * go to those triangles' tri_light_pdf. */
static void cdf_setup(RenderLights *L, const GpuScene *g, const uint32_t *inst_leaf)
{
    uint32_t ni = g->emitter_count - g->tri_emitter_count, nk = g->tlas.inst_count;
    size_t cdfs = (size_t)L->select.n + 1 + (L->tree.count ? L->aside.n + 1 : 0);
    size_t words = 0;
    uint32_t *list = NULL;
    if (ni) {
        /* A list per emitting mesh: n, CDF offset, n triangles. */
        list = spt_malloc(sizeof(uint32_t) * g->mesh_count);
        words = nk + 2 * (size_t)ni;
        for (uint32_t m = 0; m < g->mesh_count; m++) {
            uint32_t c = g->mesh_emitter_first[m + 1] - g->mesh_emitter_first[m];
            list[m] = c ? (uint32_t)words : SPT_INST_LIGHT_NONE;
            words += c ? 2 + (size_t)c : 0;
            cdfs += c ? c + 1 : 0;
        }
    }
    L->cdf_count = (uint32_t)cdfs;
    L->cdf_all = spt_malloc(sizeof(float) * cdfs);
    memcpy(L->cdf_all, L->select.cdf, sizeof(float) * (L->select.n + 1));
    size_t at = (size_t)L->select.n + 1;
    if (L->tree.count) {
        memcpy(L->cdf_all + at, L->aside.cdf, sizeof(float) * (L->aside.n + 1));
        at += L->aside.n + 1;
    }
    if (!ni)
        return;
    L->inst_light_count = (uint32_t)words;
    uint32_t *il = L->inst_light = spt_malloc(sizeof(uint32_t) * words);
    for (uint32_t k = 0; k < nk; k++)
        il[k] = SPT_INST_LIGHT_NONE;
    for (uint32_t j = 0; j < ni; j++) {
        uint32_t k = g->emitters[g->tri_emitter_count + j];
        il[k] = g->tri_emitter_count + j;
        il[nk + 2 * j] = list[g->tlas.inst_mesh[k]];
        il[nk + 2 * j + 1] = inst_leaf[j];
    }
    for (uint32_t m = 0; m < g->mesh_count; m++) {
        if (list[m] == SPT_INST_LIGHT_NONE)
            continue;
        uint32_t f = g->mesh_emitter_first[m], c = g->mesh_emitter_first[m + 1] - f;
        Distrib d;
        distrib_build(&d, g->mesh_emitter_power + f, c);
        il[list[m]] = c;
        il[list[m] + 1] = (uint32_t)at;
        memcpy(L->cdf_all + at, d.cdf, sizeof(float) * (c + 1));
        at += c + 1;
        for (uint32_t t = 0; t < c; t++) {
            il[list[m] + 2 + t] = g->mesh_emitter_prims[f + t];
            L->tri_light_pdf[g->mesh_emitter_prims[f + t]] = distrib_prob(&d, t);
        }
        distrib_free(&d);
    }
    free(list);
}

/* The lights of a render and the selection among them. */
int render_lights_setup(RenderLights *L, const GpuScene *g, const RenderSettings *rs,
                               SptError *e)
{
    memset(L, 0, sizeof *L);
    int rc = env_setup(rs, g, &L->env, e);
    if (rc)
        return rc;
    lights_build_selection(&L->select, g->emitter_power, g->emitter_count, g->lights, g->light_count,
                           g->spectra, &L->env, g->scene_radius);
    uint32_t n = g->prim_total;
    L->tri_light_pdf = spt_calloc(n ? n : 1, sizeof(float));
    for (uint32_t k = 0; k < g->tri_emitter_count; k++)
        L->tri_light_pdf[g->emitters[k]] = distrib_prob(&L->select, k) / g->emitter_area[k];
    if (L->env.env.kind != SPT_ENV_NONE && L->select.n > 0)
        L->env_prob = distrib_prob(&L->select, L->select.n - 1);
    uint32_t ni = g->emitter_count - g->tri_emitter_count;
    uint32_t *inst_leaf = spt_malloc(sizeof(uint32_t) * (ni ? ni : 1));
    for (uint32_t j = 0; j < ni; j++)
        inst_leaf[j] = SPT_TREE_NONE;
    if (render_lights_use_tree(g, rs))
        tree_setup(L, g, inst_leaf);
    cdf_setup(L, g, inst_leaf);
    free(inst_leaf);
    return 0;
}
