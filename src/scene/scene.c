/* The host scene's plain-C helpers: defaults, bounds, the default camera, freeing.
 * Loading lives in src/scene/gltf_load.cpp. */
#include "scene/scene.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

void scene_material_default(SceneMaterial *m)
{
    memset(m, 0, sizeof *m);
    strcpy(m->name, "default");
    for (int i = 0; i < 4; i++) m->base_color[i] = 1.0f;
    m->metallic = 1.0f;
    m->roughness = 1.0f;
    m->emissive_strength = 1.0f;
    m->normal_scale = 1.0f;
    m->clearcoat_normal_scale = 1.0f;
    m->ior = 1.5f;
    for (int i = 0; i < 3; i++) m->attenuation_color[i] = 1.0f;
    m->specular = 1.0f;
    for (int i = 0; i < 3; i++) m->specular_color[i] = 1.0f;
    m->iridescence_ior = 1.3f;
    m->iridescence_min_nm = 100.0f;
    m->iridescence_max_nm = 400.0f;
    for (int i = 0; i < 3; i++) m->diffuse_transmission_color[i] = 1.0f;
    m->alpha_mode = SPT_ALPHA_OPAQUE;
    m->alpha_cutoff = 0.5f;
    for (int k = 0; k < SPT_SLOT_COUNT; k++) {
        m->tex[k].tex = -1;
        m->tex[k].gltf_index = -1;
        m->tex[k].transform[0] = 1.0f;
        m->tex[k].transform[4] = 1.0f;
    }
}

static void grow_bounds(Scene *s, const double p[3])
{
    for (int k = 0; k < 3; k++) {
        float v = (float)p[k];
        if (v < s->bounds_min[k]) s->bounds_min[k] = v;
        if (v > s->bounds_max[k]) s->bounds_max[k] = v;
    }
}

void scene_update_bounds(Scene *s)
{
    for (int k = 0; k < 3; k++) {
        s->bounds_min[k] = FLT_MAX;
        s->bounds_max[k] = -FLT_MAX;
    }
    uint64_t mesh_tris = 0;
    for (uint32_t m = 0; m < s->mesh_count; m++)
        mesh_tris += s->mesh_tri_count[m];
    if (mesh_tris > s->tri_count)
        return; /* inconsistent: gpu_scene_build refuses it */
    uint32_t world = s->tri_count - (uint32_t)mesh_tris;
    for (uint64_t i = 0; i < (uint64_t)world * 3; i++) {
        const float *v = s->tri_pos + 3 * i;
        const double p[3] = {v[0], v[1], v[2]};
        grow_bounds(s, p);
    }
    if (!s->mesh_count || !s->inst_count)
        return;
    /* Each mesh's vertices once (a vertex shared by triangles is one point),
     * placed by every instance: instances x vertices, not x triangles. */
    uint32_t *first = malloc(((size_t)s->mesh_count + 1) * sizeof *first);
    first[0] = world;
    for (uint32_t m = 0; m < s->mesh_count; m++)
        first[m + 1] = first[m] + s->mesh_tri_count[m];
    uint8_t *seen = calloc(s->vertex_count ? s->vertex_count : 1, 1);
    float **pts = calloc(s->mesh_count, sizeof *pts);
    size_t *npts = calloc(s->mesh_count, sizeof *npts);
    for (uint32_t m = 0; m < s->mesh_count; m++) {
        pts[m] = malloc((size_t)s->mesh_tri_count[m] * 9 * sizeof(float) + 1);
        for (uint64_t c = (uint64_t)first[m] * 3; c < (uint64_t)first[m + 1] * 3; c++) {
            uint32_t v = s->tri_vidx[c];
            if (v < s->vertex_count && seen[v])
                continue;
            if (v < s->vertex_count)
                seen[v] = 1;
            memcpy(pts[m] + 3 * npts[m]++, s->tri_pos + 3 * c, 3 * sizeof(float));
        }
    }
    for (uint32_t k = 0; k < s->inst_count; k++) {
        uint32_t m = s->inst_mesh[k];
        if (m >= s->mesh_count)
            continue;
        const float *x = s->inst_xf + 12 * (size_t)k;
        for (size_t i = 0; i < npts[m]; i++) {
            const float *v = pts[m] + 3 * i;
            double p[3];
            for (int r = 0; r < 3; r++)
                p[r] = (double)x[4 * r] * v[0] + (double)x[4 * r + 1] * v[1] +
                       (double)x[4 * r + 2] * v[2] + x[4 * r + 3];
            grow_bounds(s, p);
        }
    }
    for (uint32_t m = 0; m < s->mesh_count; m++)
        free(pts[m]);
    free(pts);
    free(npts);
    free(seen);
    free(first);
}

/* The bounding sphere of the bounds is placed inside a 45 degree cone around -Z,
 * so every triangle is visible for any aspect ratio >= 1 (and at least the
 * vertical extent for narrower images). */
void scene_default_camera(Scene *s)
{
    SceneCamera *c = &s->camera;
    memset(c, 0, sizeof *c);
    c->yfov = (float)(45.0 * M_PI / 180.0);
    c->forward[2] = -1.0f;
    c->up[1] = 1.0f;
    c->right[0] = 1.0f;
    c->is_default = 1;
    double centre[3] = {0, 0, 0}, radius = 0;
    if (s->bounds_min[0] <= s->bounds_max[0]) {
        double r2 = 0;
        for (int k = 0; k < 3; k++) {
            centre[k] = 0.5 * ((double)s->bounds_min[k] + (double)s->bounds_max[k]);
            double h = 0.5 * ((double)s->bounds_max[k] - (double)s->bounds_min[k]);
            r2 += h * h;
        }
        radius = sqrt(r2);
    }
    if (!(radius > 0)) radius = 1.0; /* empty or a single point: any distance works */
    double dist = radius / sin(0.5 * (double)c->yfov);
    c->position[0] = (float)centre[0];
    c->position[1] = (float)centre[1];
    c->position[2] = (float)(centre[2] + dist);
    c->znear = (float)fmax(1e-4 * dist, 0.5 * (dist - radius));
    c->zfar = 0.0f;
}

void scene_free(Scene *s)
{
    if (!s) return;
    free(s->path);
    free(s->tri_pos);
    free(s->tri_vidx);
    free(s->tri_mat);
    free(s->vtx_normal);
    free(s->vtx_uv);
    free(s->vtx_uv1);
    free(s->vtx_color);
    free(s->vtx_tangent);
    for (uint32_t i = 0; i < s->material_count; i++) {
        spd_free(&s->materials[i].reflectance_spd);
        spd_free(&s->materials[i].emission_spd);
    }
    free(s->materials);
    for (uint32_t i = 0; i < s->texture_count; i++) free(s->textures[i].texels);
    free(s->textures);
    for (uint32_t i = 0; i < s->light_count; i++) spd_free(&s->lights[i].spd);
    free(s->lights);
    free(s->camera_info);
    free(s->animation_info);
    free(s->mesh_tri_count);
    free(s->inst_mesh);
    free(s->inst_xf);
    memset(s, 0, sizeof *s);
}
