/* `spectrace info SCENE`: what the loader made of a glTF scene, the BVH built over
 * it and an estimate of the device memory a render needs. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "accel/bvh_build.h"
#include "cli/commands.h"
#include "render/gpu_scene.h"
#include "render/host_lights.h"
#include "scene/scene.h"
#include "core/util.h"

static const char info_usage[] =
    "usage: spectrace info SCENE [--no-bvh] [--instancing auto|off|on]\n"
    "\n"
    "Loads a glTF 2.0 scene (.gltf or .glb) and prints: triangles kept and dropped\n"
    "(NaN/Inf/huge coordinates, degenerate), skipped primitives, meshes, instances,\n"
    "materials, textures with their sizes, emissive triangles, punctual lights, the\n"
    "camera (and the file's cameras, for render --camera), the animations with their\n"
    "times (for render --at and --animation), the bounds, the load time, the BVH statistics and build time, and an\n"
    "estimate of the device memory for the scene (film and path state excluded).\n"
    "\n"
    "  --no-bvh   skip the BVH build\n"
    "  --instancing MODE  which meshes are placed by reference, as render's option\n"
    "             (auto, off, on); with instances the BVH line gives each level\n"
    "\n"
    "Exit codes: 0 ok, 2 usage, 3 the scene file is unreadable or invalid.\n";

static double mib(double bytes) { return bytes / (1024.0 * 1024.0); }

/* Prints a byte count with a unit that keeps small scenes readable. */
static void print_bytes(double bytes)
{
    if (bytes < 1024)
        printf("%.0f B", bytes);
    else if (bytes < 1024 * 1024)
        printf("%.1f KiB", bytes / 1024.0);
    else if (bytes < 1024.0 * 1024 * 1024)
        printf("%.2f MiB", mib(bytes));
    else
        printf("%.2f GiB", bytes / (1024.0 * 1024 * 1024));
}

/* -0 prints as 0. */
static double z(float v) { return v == 0.0f ? 0.0 : (double)v; }

static const char *wrap_name(int w)
{
    return w == SPT_WRAP_CLAMP ? "clamp" : w == SPT_WRAP_MIRROR ? "mirror" : "repeat";
}

/* The texture slots' names (SPT_SLOT_* order). */
static const char *const slot_names[SPT_SLOT_COUNT] = {
    "baseColor", "metallicRoughness", "normal", "emissive", "transmission", "specular",
    "specularColor", "clearcoat", "clearcoatRoughness", "clearcoatNormal", "sheenColor",
    "sheenRoughness", "iridescence", "iridescenceThickness", "anisotropy", "diffuseTransmission",
    "diffuseTransmissionColor", "occlusion",
};

static void print_materials(const Scene *s)
{
    static const char *alpha[] = {"opaque", "mask", "blend"};
    printf("materials    %u\n", s->material_count);
    for (uint32_t i = 0; i < s->material_count; i++) {
        const SceneMaterial *m = &s->materials[i];
        printf("  [%u] %-20s base %.3g %.3g %.3g metallic %.3g roughness %.3g", i, m->name,
               m->base_color[0], m->base_color[1], m->base_color[2], m->metallic, m->roughness);
        if (m->emissive[0] > 0 || m->emissive[1] > 0 || m->emissive[2] > 0)
            printf(" emissive %.3g %.3g %.3g x %.3g", m->emissive[0], m->emissive[1],
                   m->emissive[2], m->emissive_strength);
        if (m->transmission > 0) printf(" transmission %.3g ior %.3g", m->transmission, m->ior);
        if (m->dispersion > 0) printf(" dispersion %.3g", m->dispersion);
        if (m->alpha_mode) printf(" alpha %s", alpha[m->alpha_mode]);
        if (m->double_sided) printf(" double-sided");
        if (m->unlit) printf(" unlit");
        if (m->reflectance_spd.count) printf(" spectral-reflectance");
        if (m->emission_spd.count || m->emission_spd.line_count) printf(" spectral-emission");
        if (m->conductor[0]) printf(" conductor %s", m->conductor);
        if (m->clearcoat > 0)
            printf(" clearcoat %.3g roughness %.3g", m->clearcoat, m->clearcoat_roughness);
        if (m->sheen_color[0] > 0 || m->sheen_color[1] > 0 || m->sheen_color[2] > 0)
            printf(" sheen %.3g %.3g %.3g roughness %.3g", m->sheen_color[0], m->sheen_color[1],
                   m->sheen_color[2], m->sheen_roughness);
        if (m->iridescence > 0)
            printf(" iridescence %.3g ior %.3g thickness %.4g-%.4g nm", m->iridescence, m->iridescence_ior,
                   m->iridescence_min_nm, m->iridescence_max_nm);
        if (m->anisotropy > 0)
            printf(" anisotropy %.3g rotation %.3g", m->anisotropy, m->anisotropy_rotation);
        if (m->diffuse_transmission > 0)
            printf(" diffuse-transmission %.3g colour %.3g %.3g %.3g", m->diffuse_transmission,
                   m->diffuse_transmission_color[0], m->diffuse_transmission_color[1],
                   m->diffuse_transmission_color[2]);
        printf("\n");
        /* The texture slots: the file's texture, the uv set, the loaded texture
         * (-: its image was unusable, the factor is used). */
        int any = 0;
        for (int k = 0; k < SPT_SLOT_COUNT; k++) {
            const SceneTexRef *r = &m->tex[k];
            if (r->gltf_index < 0)
                continue;
            printf("%s%s textures[%d] uv %d", any ? ", " : "       textures: ", slot_names[k], r->gltf_index,
                   r->texcoord);
            if (k == SPT_SLOT_OCCLUSION)
                printf(" (not rendered)");
            else if (r->tex < 0)
                printf(" (unusable: factor only)");
            else
                printf(" -> [%d]", r->tex);
            any = 1;
        }
        if (any)
            printf("\n");
    }
}

static double print_textures(const Scene *s)
{
    double bytes = 0;
    printf("textures     %u", s->texture_count);
    if (s->stats.unusable_images)
        printf(" (%u image(s) missing, corrupt or outside the scene folder: factors used)",
               s->stats.unusable_images);
    printf("\n");
    for (uint32_t i = 0; i < s->texture_count; i++) {
        const SceneTexture *t = &s->textures[i];
        double b = (double)t->width * t->height * t->channels * sizeof(float);
        bytes += b;
        printf("  [%u] %-24s %dx%d, %d channel(s), %s, wrap %s/%s, %s, ", i, t->name, t->width,
               t->height, t->channels, t->srgb_decoded ? "sRGB->linear" : "linear",
               wrap_name(t->wrap_s), wrap_name(t->wrap_t), t->nearest ? "nearest" : "linear");
        print_bytes(b);
        printf("\n");
    }
    return bytes;
}

static void print_lights(const Scene *s)
{
    static const char *type[] = {"point", "spot", "directional"};
    printf("lights       %u punctual\n", s->light_count);
    for (uint32_t i = 0; i < s->light_count; i++) {
        const SceneLight *l = &s->lights[i];
        printf("  [%u] %-12s %-20s ", i, type[l->type], l->name);
        if (l->spd.count > 0 || l->spd.line_count > 0) {
            /* extras.spectrace.emission replaces the colour: its chromaticity and
             * luminous efficacy instead. */
            double xyz[3];
            spd_to_xyz(&l->spd, xyz);
            double sum = xyz[0] + xyz[1] + xyz[2];
            printf("spectrum (%d samples, %d lines) xy %.4f %.4f, %.4g lm/W", l->spd.count,
                   l->spd.line_count, sum > 0 ? xyz[0] / sum : 0.0, sum > 0 ? xyz[1] / sum : 0.0,
                   spd_luminous_efficacy(&l->spd));
        } else {
            printf("colour %.3g %.3g %.3g", l->color[0], l->color[1], l->color[2]);
        }
        printf(", %g %s", l->intensity, l->type == SPT_LIGHT_DIRECTIONAL ? "lx" : "cd");
        if (l->type != SPT_LIGHT_DIRECTIONAL)
            printf(", at %.4g %.4g %.4g", l->position[0], l->position[1], l->position[2]);
        if (l->type != SPT_LIGHT_POINT)
            printf(", toward %.3g %.3g %.3g", l->direction[0], l->direction[1], l->direction[2]);
        if (l->type == SPT_LIGHT_SPOT)
            printf(", cone %.3g-%.3g deg", l->inner_cone * 180 / M_PI, l->outer_cone * 180 / M_PI);
        if (l->range > 0) printf(", range %g", l->range);
        printf("\n");
    }
}

static void print_camera(const SceneCamera *c)
{
    if (c->orthographic)
        printf("camera       orthographic xmag %g ymag %g", c->xmag, c->ymag);
    else
        printf("camera       perspective yfov %.4g deg", c->yfov * 180 / M_PI);
    if (c->aspect > 0) printf(" aspect %.4g", c->aspect);
    printf(" znear %g zfar ", c->znear);
    if (c->zfar > 0)
        printf("%g", c->zfar);
    else
        printf("inf");
    printf("%s\n", c->is_default ? " (default: the file has none)" : "");
    printf("             at %.4g %.4g %.4g, forward %.3g %.3g %.3g, up %.3g %.3g %.3g\n",
           z(c->position[0]), z(c->position[1]), z(c->position[2]), z(c->forward[0]),
           z(c->forward[1]), z(c->forward[2]), z(c->up[0]), z(c->up[1]), z(c->up[2]));
}

/* The file's cameras (the one rendered is the first placed, or render
 * --camera's) and animations with their key times (docs/gltf.md, "Animation,
 * skins and morph targets"). */
static void print_cameras_and_animations(const Scene *s)
{
    for (uint32_t i = 0; i < s->camera_info_count; i++) {
        const SceneCameraInfo *c = &s->camera_info[i];
        printf("%s %u%s%s%s %s, ", i ? "            " : "cameras     ", i, c->name[0] ? " '" : "",
               c->name, c->name[0] ? "'" : "", c->orthographic ? "orthographic" : "perspective");
        if (c->node >= 0)
            printf("placed by nodes[%d]\n", c->node);
        else
            printf("placed by no node of the scene\n");
    }
    if (!s->animation_info_count)
        printf("animations   none\n");
    for (uint32_t i = 0; i < s->animation_info_count; i++) {
        const SceneAnimationInfo *a = &s->animation_info[i];
        printf("%s %u%s%s%s %.4g s (keys %.4g .. %.4g s), %u channel(s)\n",
               i ? "            " : "animations  ", i, a->name[0] ? " '" : "", a->name,
               a->name[0] ? "'" : "", a->end, a->start, a->end, a->channels);
    }
}

/* The meshes placed by reference (docs/gltf.md, "Instancing"): the
 * triangles stored once against those their instances place. */
static void print_instancing(const Scene *s)
{
    uint64_t mesh_tris = 0, placed = 0;
    for (uint32_t m = 0; m < s->mesh_count; m++)
        mesh_tris += s->mesh_tri_count[m];
    for (uint32_t k = 0; k < s->inst_count; k++)
        placed += s->mesh_tri_count[s->inst_mesh[k]];
    printf("instancing   %u mesh(es) placed by reference, %u instance(s): %llu unique "
           "triangle(s) (%llu in the meshes), %llu placed (%llu by the instances)\n",
           s->mesh_count, s->inst_count, (unsigned long long)s->tri_count,
           (unsigned long long)mesh_tris,
           (unsigned long long)(s->tri_count - mesh_tris + placed), (unsigned long long)placed);
}

/* The two levels of an instanced scene as the renderer builds them
 * (docs/architecture.md, "Instances (two levels)"): their device memory
 * added to *bytes, the bottom level's bytes per stored triangle into
 * *per_tri. Returns 0 or the build's exit code (reported). */
static int print_levels(const Scene *s, double *bytes, double *per_tri)
{
    GpuScene g;
    SptError e = {0};
    double t0 = spt_now();
    if (gpu_scene_build(&g, s, &e))
        return spt_report(&e);
    const TlasStats *t = &g.tlas.stats;
    printf("bvh          two levels built in %.1f ms: bottom %u mesh(es) with the world's "
           "triangles, %llu triangles, ",
           (spt_now() - t0) * 1e3, s->mesh_count, (unsigned long long)t->unique_tris);
    print_bytes((double)t->bottom_bytes);
    printf("; top %u instance(s) placing %llu triangles (%u dropped as singular), ",
           t->instances, (unsigned long long)t->instanced_tris, t->dropped);
    print_bytes((double)t->top_bytes);
    printf("\n");
    *bytes += (double)t->bottom_bytes + (double)t->top_bytes;
    *per_tri = t->unique_tris ? (double)t->bottom_bytes / (double)t->unique_tris : 0;
    gpu_scene_free(&g);
    return SPT_EXIT_OK;
}

int cmd_info(int argc, char **argv)
{
    const char *path = NULL;
    int want_bvh = 1, instancing = SCENE_INSTANCING_AUTO;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--help") || !strcmp(argv[i], "-h")) {
            fputs(info_usage, stdout);
            return SPT_EXIT_OK;
        } else if (!strcmp(argv[i], "--no-bvh")) {
            want_bvh = 0;
        } else if (!strcmp(argv[i], "--instancing")) {
            const char *v = i + 1 < argc ? argv[++i] : "";
            instancing = !strcmp(v, "auto") ? SCENE_INSTANCING_AUTO
                         : !strcmp(v, "off") ? SCENE_INSTANCING_OFF
                         : !strcmp(v, "on")  ? SCENE_INSTANCING_ON
                                             : -1;
            if (instancing < 0) {
                spt_error("info: --instancing '%s': expected auto, off or on", v);
                return SPT_EXIT_USAGE;
            }
        } else if (argv[i][0] == '-' && argv[i][1]) {
            spt_error("info: unknown option '%s' (try: spectrace info --help)", argv[i]);
            return SPT_EXIT_USAGE;
        } else if (path) {
            spt_error("info: one scene only (got '%s' and '%s')", path, argv[i]);
            return SPT_EXIT_USAGE;
        } else {
            path = argv[i];
        }
    }
    if (!path) {
        fputs(info_usage, stderr);
        return SPT_EXIT_USAGE;
    }

    SptError e = {0};
    Scene s;
    double t0 = spt_now();
    if (scene_load_gltf_posed(&s, path, &(ScenePose){NAN, NULL, NULL, instancing}, &e))
        return spt_report(&e);
    double load_s = spt_now() - t0;
    const SceneStats *st = &s.stats;

    printf("scene        %s (loaded in %.1f ms)\n", path, load_s * 1e3);
    printf("triangles    %u kept, %u dropped (%u NaN/Inf/huge coordinates, %u degenerate)\n",
           s.tri_count, st->dropped_nonfinite + st->dropped_degenerate, st->dropped_nonfinite,
           st->dropped_degenerate);
    printf("primitives   %u triangle primitive(s) instanced, %u skipped (points, lines or no "
           "POSITION)\n",
           st->primitives, st->skipped_primitives);
    printf("meshes       %u used, %u instance(s), %u vertices\n", st->meshes, st->instances,
           s.vertex_count);
    print_materials(&s);
    double tex_bytes = print_textures(&s);
    printf("emissive     %u triangle(s)\n", st->emissive_triangles);
    print_lights(&s);
    /* A light that render would refuse (src/render/host_lights.c: its level,
     * its spectrum) is an error here too, after the description. */
    int light_rc = SPT_EXIT_OK;
    for (uint32_t i = 0; i < s.light_count && !light_rc; i++) {
        float table[SPT_CIE_SAMPLES];
        GpuLight gl;
        if ((light_rc = light_from_scene(&s.lights[i], table, 0, &gl, &e)))
            spt_error("%s: %s", path, e.msg);
    }
    print_camera(&s.camera);
    print_cameras_and_animations(&s);
    if (s.tri_count)
        printf("bounds       %.4g %.4g %.4g .. %.4g %.4g %.4g\n", s.bounds_min[0], s.bounds_min[1],
               s.bounds_min[2], s.bounds_max[0], s.bounds_max[1], s.bounds_max[2]);
    else
        printf("bounds       empty (no triangles)\n");

    /* Device buffers: per-vertex positions, normals and uvs, per-triangle vertex
     * indices and material ids, textures as floats, materials and lights (upper
     * bound of 512 bytes each), plus the BVH nodes and packed triangles. */
    double bytes = (double)s.vertex_count * 8 * sizeof(float) + (double)s.tri_count * 4 * 4 +
                   tex_bytes + (double)(s.material_count + s.light_count) * 512;
    int rc = SPT_EXIT_OK;
    double bvh_bytes_per_tri = 9 * sizeof(float); /* without the BVH: the positions */
    if (want_bvh && s.mesh_count) {
        rc = print_levels(&s, &bytes, &bvh_bytes_per_tri);
    } else if (want_bvh) {
        Bvh bvh = {0};
        if (bvh_build(&bvh, s.tri_pos, s.tri_count, &e)) {
            rc = spt_report(&e);
        } else {
            const BvhStats *b = &bvh.stats;
            printf("bvh          %u nodes, %u leaves, depth %u, leaf size avg %.2f max %u, SAH "
                   "cost %.2f, %.1f bytes/triangle, built in %.1f ms\n",
                   b->node_count, b->leaf_count, b->max_depth, b->avg_leaf_size,
                   b->max_leaf_size, b->sah_cost, b->bytes_per_tri, b->build_seconds * 1e3);
            bytes += (double)bvh.node_count * sizeof(BvhNode) + (double)bvh.tri_data_bytes;
            bvh_bytes_per_tri = b->bytes_per_tri;
            bvh_free(&bvh);
        }
    } else {
        bytes += (double)s.tri_count * 9 * sizeof(float); /* at least the positions */
    }
    if (rc == SPT_EXIT_OK)
    {
        printf("device mem   ~");
        print_bytes(bytes);
        printf(" for the scene%s (film and path state come on top)\n",
               want_bvh ? "" : " without the BVH");
        /* Meshes placed several times and flattened (one copy of the triangles
         * per placement): their cost. */
        if (st->instanced_meshes) {
            printf("flattened    %u mesh(es) placed several times, flattened: %u triangles and %u "
                   "vertices are copies, ~",
                   st->instanced_meshes, st->flattened_triangles, st->flattened_vertices);
            print_bytes((double)st->flattened_triangles * (4 * 4 + bvh_bytes_per_tri) +
                        (double)st->flattened_vertices * 5 * sizeof(float));
            printf(" of the device memory\n");
            /* of those placed, each mesh's own once (what two levels would keep:
             * docs/architecture.md, "Instances (two levels)") */
            if (!s.mesh_count)
                printf("             %u unique triangle(s), %u placed by the instances\n",
                       s.tri_count - st->flattened_triangles, s.tri_count);
        }
        if (s.mesh_count)
            print_instancing(&s);
    }
    scene_free(&s);
    return rc ? rc : light_rc;
}
