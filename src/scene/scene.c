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

void scene_update_bounds(Scene *s)
{
    for (int k = 0; k < 3; k++) {
        s->bounds_min[k] = FLT_MAX;
        s->bounds_max[k] = -FLT_MAX;
    }
    for (uint64_t i = 0; i < (uint64_t)s->tri_count * 9; i++) {
        float v = s->tri_pos[i];
        int k = (int)(i % 3);
        if (v < s->bounds_min[k]) s->bounds_min[k] = v;
        if (v > s->bounds_max[k]) s->bounds_max[k] = v;
    }
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
