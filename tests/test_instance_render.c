/* The renderer on instanced scenes (docs/architecture.md, "Instances (two
 * levels)"): a scene whose meshes are placed by reference renders the image
 * of the same scene with its instances flattened into world-space triangles
 * (as the glTF loader does: vertices through the transform in double,
 * normals through its inverse transpose, a mirrored instance's triangles
 * reversed), up to the float rounding of the transforms, on the CPU path
 * (megakernel and stages) and the GPU-shaped path. The scene has rotated,
 * non-uniformly scaled and mirrored instances, smooth vertex normals, an
 * alpha-blended mesh (shadow rays walk through it) and a world-space
 * emitter. */
#include "test_util.h"
#include "test_render_util.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "light/inst_lights.h"
#include "light/light_tree.h"
#include "render/gpu_scene.h"
#include "render/render_lights.h"
#include "scene/scene_pack.h"

enum { MESH_BALL, MESH_CARD, MESH_COUNT };

/* The instances: mesh and rows of the 3x4 transform. */
typedef struct TestInstance {
    uint32_t mesh;
    double xf[12];
} TestInstance;

/* Rotation by a about axis (0 x, 1 y), then scale sc, then translation t. */
static TestInstance make_instance(uint32_t mesh, int axis, double a, const double sc[3],
                                  const double t[3])
{
    TestInstance in;
    double c = cos(a), s = sin(a), r[9];
    if (axis == 0) {
        const double rx[9] = {1, 0, 0, 0, c, -s, 0, s, c};
        memcpy(r, rx, sizeof r);
    } else {
        const double ry[9] = {c, 0, s, 0, 1, 0, -s, 0, c};
        memcpy(r, ry, sizeof r);
    }
    in.mesh = mesh;
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 3; j++)
            in.xf[4 * i + j] = sc[i] * r[3 * i + j];
        in.xf[4 * i + 3] = t[i];
    }
    return in;
}

#define N_INST 5

static void test_instances(TestInstance out[N_INST])
{
    const double one[3] = {1, 1, 1};
    const double s1[3] = {1.0, 0.6, 1.6}, s2[3] = {-1.0, 1.2, 1.0}, s4[3] = {1.0, -1.0, 1.0};
    const double t0[3] = {-1.8, -0.3, 0.0}, t1[3] = {1.8, -0.4, 0.3}, t2[3] = {0.0, 0.1, -1.6};
    const double t3[3] = {-0.4, -0.1, 1.6}, t4[3] = {0.9, 0.2, 1.2};
    out[0] = make_instance(MESH_BALL, 1, 0.5, one, t0);
    out[1] = make_instance(MESH_BALL, 0, 0.3, s1, t1);
    out[2] = make_instance(MESH_BALL, 0, 0.45, s2, t2);
    out[3] = make_instance(MESH_CARD, 1, 0.25, one, t3);
    out[4] = make_instance(MESH_CARD, 1, -0.6, s4, t4);
}

/* A mesh in its own space: tri triangles of 3 vertices each, positions and
 * unit vertex normals (9 floats per triangle each), all of material mat. */
typedef struct TestMesh {
    uint32_t tris, mat;
    float *pos, *nrm;
} TestMesh;

static void test_meshes(TestMesh m[MESH_COUNT], uint32_t mat_ball, uint32_t mat_card)
{
    const float c[3] = {0, 0, 0};
    uint32_t n = 0;
    m[MESH_BALL].pos = bvh_gen_sphere(10, 20, 0.7f, c, 0.0f, &n);
    m[MESH_BALL].tris = n;
    m[MESH_BALL].mat = mat_ball;
    m[MESH_BALL].nrm = malloc(sizeof(float) * 9 * n);
    for (uint32_t v = 0; v < 3 * n; v++) {
        const float *p = m[MESH_BALL].pos + 3 * v;
        float l = sqrtf(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
        for (int k = 0; k < 3; k++)
            m[MESH_BALL].nrm[3 * v + k] = p[k] / l;
    }
    /* The card: a unit square in z = 0, facing +z, normals bent outward so the
     * shading normal differs from the face's. */
    static const float q[6][3] = {{-0.8f, -0.8f, 0}, {0.8f, -0.8f, 0}, {0.8f, 0.8f, 0},
                                  {-0.8f, -0.8f, 0}, {0.8f, 0.8f, 0},  {-0.8f, 0.8f, 0}};
    m[MESH_CARD].tris = 2;
    m[MESH_CARD].mat = mat_card;
    m[MESH_CARD].pos = malloc(sizeof q);
    m[MESH_CARD].nrm = malloc(sizeof q);
    memcpy(m[MESH_CARD].pos, q, sizeof q);
    for (int v = 0; v < 6; v++) {
        float nx = 0.3f * q[v][0], ny = 0.3f * q[v][1], l = sqrtf(nx * nx + ny * ny + 1.0f);
        m[MESH_CARD].nrm[3 * v] = nx / l;
        m[MESH_CARD].nrm[3 * v + 1] = ny / l;
        m[MESH_CARD].nrm[3 * v + 2] = 1.0f / l;
    }
}

/* Appends mesh triangles (positions p, normals n: 9 floats per triangle) of
 * material mat to s. */
static void append_tris(Scene *s, const float *p, const float *n, uint32_t tris, uint32_t mat)
{
    uint32_t t0 = grow_triangles(s, tris);
    memcpy(s->tri_pos + 9 * (size_t)t0, p, sizeof(float) * 9 * tris);
    memcpy(s->vtx_normal + 9 * (size_t)t0, n, sizeof(float) * 9 * tris);
    for (uint32_t t = 0; t < tris; t++)
        s->tri_mat[t0 + t] = mat;
}

/* The world-space part: a floor, a light facing down (both Lambertian), and
 * the materials of the meshes (a grey ball, a half-transparent red card). */
static void world_part(Scene *s, uint32_t *mat_ball, uint32_t *mat_card)
{
    memset(s, 0, sizeof *s);
    SceneMaterial *floor = append_quad(s, -1.0f);
    for (int k = 0; k < 3; k++)
        floor->base_color[k] = 0.6f;
    const float lc[4][3] = {{-1, 3, -1}, {1, 3, -1}, {1, 3, 1}, {-1, 3, 1}};
    SceneMaterial *light = append_rect(s, lc);
    for (int k = 0; k < 3; k++) {
        light->base_color[k] = 0.0f;
        light->emissive[k] = 4.0f;
    }
    s->materials = realloc(s->materials, sizeof(SceneMaterial) * (s->material_count + 2));
    SceneMaterial *ball = &s->materials[s->material_count];
    scene_material_default(ball);
    ball->base_color[0] = 0.5f;
    ball->base_color[1] = 0.7f;
    ball->base_color[2] = 0.4f;
    ball->roughness = 0.4f;
    SceneMaterial *card = ball + 1;
    scene_material_default(card);
    card->base_color[0] = 0.9f;
    card->base_color[1] = 0.2f;
    card->base_color[2] = 0.1f;
    card->base_color[3] = 0.5f;
    card->alpha_mode = SPT_ALPHA_BLEND;
    card->double_sided = 1;
    *mat_ball = s->material_count;
    *mat_card = s->material_count + 1;
    s->material_count += 2;
}

static void aim(Scene *s)
{
    aim_camera(s, 2.5, 5.5, 0.45, 1.0, 0.75f);
}

/* Adds meshes mesh[0 .. nm) to s placed by the n instances in, by
 * reference (instanced 1) or flattened as the glTF loader flattens them
 * (0): vertices through the transform in double, normals through its
 * inverse transpose, a mirrored instance's triangles reversed. */
static void add_meshes(Scene *s, const TestMesh *mesh, uint32_t nm, const TestInstance *in, int n, int instanced)
{
    if (instanced) {
        s->mesh_count = nm;
        s->mesh_tri_count = malloc(sizeof(uint32_t) * nm);
        for (uint32_t m = 0; m < nm; m++) {
            append_tris(s, mesh[m].pos, mesh[m].nrm, mesh[m].tris, mesh[m].mat);
            s->mesh_tri_count[m] = mesh[m].tris;
        }
        s->inst_count = (uint32_t)n;
        s->inst_mesh = malloc(sizeof(uint32_t) * n);
        s->inst_xf = malloc(sizeof(float) * 12 * n);
        for (int k = 0; k < n; k++) {
            s->inst_mesh[k] = in[k].mesh;
            for (int j = 0; j < 12; j++)
                s->inst_xf[12 * k + j] = (float)in[k].xf[j];
        }
        return;
    }
    for (int k = 0; k < n; k++) {
        const TestMesh *m = &mesh[in[k].mesh];
        /* The transform as the instanced scene rounds it, in double. */
        double x[12];
        for (int j = 0; j < 12; j++)
            x[j] = (double)(float)in[k].xf[j];
        double cof[9] = {x[5] * x[10] - x[6] * x[9], x[6] * x[8] - x[4] * x[10],
                         x[4] * x[9] - x[5] * x[8], x[2] * x[9] - x[1] * x[10],
                         x[0] * x[10] - x[2] * x[8], x[1] * x[8] - x[0] * x[9],
                         x[1] * x[6] - x[2] * x[5], x[2] * x[4] - x[0] * x[6],
                         x[0] * x[5] - x[1] * x[4]};
        double det = x[0] * cof[0] + x[1] * cof[1] + x[2] * cof[2];
        float *p = malloc(sizeof(float) * 9 * m->tris), *nr = malloc(sizeof(float) * 9 * m->tris);
        for (uint32_t t = 0; t < m->tris; t++)
            for (int v = 0; v < 3; v++) {
                /* A mirrored instance's triangle is reversed (glTF). */
                int src = det < 0 && v ? 3 - v : v;
                const float *lp = m->pos + 9 * t + 3 * src, *ln = m->nrm + 9 * t + 3 * src;
                double w[3], l = 0;
                for (int r = 0; r < 3; r++) {
                    p[9 * t + 3 * v + r] = (float)(x[4 * r] * lp[0] + x[4 * r + 1] * lp[1] +
                                                   x[4 * r + 2] * lp[2] + x[4 * r + 3]);
                    w[r] = cof[3 * r] * ln[0] + cof[3 * r + 1] * ln[1] + cof[3 * r + 2] * ln[2];
                    l += w[r] * w[r];
                }
                for (int r = 0; r < 3; r++)
                    nr[9 * t + 3 * v + r] = (float)(w[r] / sqrt(l) * (det < 0 ? -1 : 1));
            }
        append_tris(s, p, nr, m->tris, m->mat);
        free(p);
        free(nr);
    }
}

/* The bounds of the placed meshes (the camera and the sky use them) of an
 * instanced scene s: its world-space triangles' and its meshes' flattened. */
static void instanced_bounds(Scene *s, const TestMesh *mesh, uint32_t nm, const TestInstance *in, int n)
{
    Scene f;
    memset(&f, 0, sizeof f);
    uint32_t world = s->tri_count;
    for (uint32_t m = 0; m < s->mesh_count; m++)
        world -= s->mesh_tri_count[m];
    uint32_t t0 = grow_triangles(&f, world);
    memcpy(f.tri_pos + 9 * (size_t)t0, s->tri_pos, sizeof(float) * 9 * world);
    add_meshes(&f, mesh, nm, in, n, 0);
    scene_update_bounds(&f);
    memcpy(s->bounds_min, f.bounds_min, sizeof s->bounds_min);
    memcpy(s->bounds_max, f.bounds_max, sizeof s->bounds_max);
    scene_free(&f);
}

/* The scene with its meshes placed by reference (instanced 1) or flattened as
 * the glTF loader flattens them (0). */
static void instanced_scene(Scene *s, int instanced)
{
    uint32_t mb, mc;
    world_part(s, &mb, &mc);
    TestMesh mesh[MESH_COUNT];
    test_meshes(mesh, mb, mc);
    TestInstance in[N_INST];
    test_instances(in);
    add_meshes(s, mesh, MESH_COUNT, in, N_INST, instanced);
    aim(s);
    if (instanced)
        instanced_bounds(s, mesh, MESH_COUNT, in, N_INST);
    for (int m = 0; m < MESH_COUNT; m++) {
        free(mesh[m].pos);
        free(mesh[m].nrm);
    }
}

#define W 48
/* Samples per pixel and the block bound of the instanced emitters' image test. */
#define LIT_SPP 64
#define LIT_BLOCK_TOL 0.05

/* The two scenes' images agree on every kernel path (assert_renders_agree,
 * tests/test_render_util.h). */
TEST(test_instanced_matches_flattened)
{
    Scene si, sf;
    instanced_scene(&si, 1);
    instanced_scene(&sf, 0);
    GpuScene g;
    SptError e = {0};
    assert_int_equal(gpu_scene_build(&g, &si, &e), 0);
    /* The world's triangles under the identity and the five instances. */
    assert_int_equal(g.tlas.inst_count, N_INST + 1);
    /* Each mesh stored once: the world's 4 triangles and one ball and one card. */
    assert_int_equal(g.prim_total, 4 + (sf.tri_count - 4 - 2 * 2) / 3 + 2);
    gpu_scene_free(&g);
    /* The flattened scene has none: on the CPU path its program is built
     * without the instances' code (SPT_INSTANCES=0, src/render/wavefront.c),
     * the instanced scene's with it, so the CPU path's renders below compare
     * the two programs. */
    assert_int_equal(gpu_scene_build(&g, &sf, &e), 0);
    assert_int_equal(g.tlas.inst_count, 0);
    gpu_scene_free(&g);
    assert_renders_agree(&si, &sf, W);
    scene_free(&si);
    scene_free(&sf);
}

/* The instanced scene whose ball mesh emits (on its three instances:
 * rotated, non-uniformly scaled, mirrored), beside the world's light. */
static void lit_scene(Scene *s, int instanced)
{
    instanced_scene(s, instanced);
    SceneMaterial *ball = &s->materials[s->material_count - 2];
    ball->emissive[0] = 2.0f;
    ball->emissive[1] = 1.2f;
    ball->emissive[2] = 0.5f;
}

/* The light-tracing pass's scene: a mirror floor, three instances of an
 * emissive card facing down (rotated, non-uniformly scaled, mirrored; the
 * ball mesh has no instance), and a white wall above them, which only
 * light by way of the floor reaches: the paths of the light-tracing pass
 * (x1 the wall, x2 the floor), which camera paths leave to it. */
static void mirror_scene(Scene *s, int instanced)
{
    memset(s, 0, sizeof *s);
    SceneMaterial *floor = append_quad(s, -1.0f);
    floor->metallic = 1.0f;
    floor->roughness = 0.0f;
    for (int k = 0; k < 3; k++)
        floor->base_color[k] = 0.9f;
    const float wc[4][3] = {{-3, 1.2f, -2.5f}, {3, 1.2f, -2.5f}, {3, 3.5f, -2.5f}, {-3, 3.5f, -2.5f}};
    SceneMaterial *wall = append_rect(s, wc);
    for (int k = 0; k < 3; k++)
        wall->base_color[k] = 0.8f;
    s->materials = realloc(s->materials, sizeof(SceneMaterial) * (s->material_count + 1));
    SceneMaterial *card = &s->materials[s->material_count];
    scene_material_default(card);
    for (int k = 0; k < 3; k++)
        card->base_color[k] = 0.0f;
    card->emissive[0] = 6.0f;
    card->emissive[1] = 4.0f;
    card->emissive[2] = 2.0f;
    uint32_t mat = s->material_count++;
    TestMesh mesh[MESH_COUNT];
    test_meshes(mesh, mat, mat);
    const double one[3] = {1, 1, 1}, s1[3] = {1.3, 1.0, 0.7}, s2[3] = {-1.0, 1.0, 1.0};
    const double t0[3] = {-1.5, 0.8, 0.0}, t1[3] = {0.2, 0.9, -0.5}, t2[3] = {1.6, 0.7, 0.4};
    /* A quarter turn about x takes the card's +z to -y. */
    TestInstance in[3] = {make_instance(MESH_CARD, 0, 0.5 * M_PI, one, t0),
                          make_instance(MESH_CARD, 0, 0.5 * M_PI, s1, t1),
                          make_instance(MESH_CARD, 0, 0.5 * M_PI, s2, t2)};
    add_meshes(s, mesh, MESH_COUNT, in, 3, instanced);
    aim_camera(s, 1.5, 5.5, 0.15, 1.0, 0.75f);
    if (instanced)
        instanced_bounds(s, mesh, MESH_COUNT, in, 3);
    for (int m = 0; m < MESH_COUNT; m++) {
        free(mesh[m].pos);
        free(mesh[m].nrm);
    }
}

/* The mean of each quarter (2 x 2 of them) of a w x w image, per channel. */
static void quarter_means(const float *rgb, int w, double out[12])
{
    double blocks[48];
    block_means_4x4(rgb, w, blocks);
    memset(out, 0, 12 * sizeof(double));
    for (int i = 0; i < 16; i++)
        for (int c = 0; c < 3; c++)
            out[3 * (2 * (i / 8) + (i % 4) / 2) + c] += 0.25 * blocks[3 * i + c];
}

/* The mean of a w x w image's channels. */
static double image_mean(const float *rgb, int w)
{
    double sum = 0;
    for (int i = 0; i < 3 * w * w; i++)
        sum += rgb[i];
    return sum / (3 * w * w);
}

/* Mean |a - b| over the mean of b, the worst 4x4 block's relative
 * difference and the worst quarter's (a block or quarter darker than a
 * tenth of b's mean relative to that). */
static void image_diff(const float *a, const float *b, int w, double *mean_rel, double *worst, double *worst_q)
{
    double qa[12], qb[12];
    quarter_means(a, w, qa);
    quarter_means(b, w, qb);
    double sum = 0, diff = 0, ba[48], bb[48];
    for (int i = 0; i < 3 * w * w; i++) {
        sum += b[i];
        diff += fabs((double)a[i] - b[i]);
    }
    block_means_4x4(a, w, ba);
    block_means_4x4(b, w, bb);
    /* Blocks darker than a tenth of the image's mean count against that. */
    double floor = 0.1 * sum / (3 * w * w);
    *worst = 0;
    for (int i = 0; i < 48; i++)
        *worst = fmax(*worst, fabs(ba[i] - bb[i]) / fmax(bb[i], floor));
    *worst_q = 0;
    for (int i = 0; i < 12; i++)
        *worst_q = fmax(*worst_q, fabs(qa[i] - qb[i]) / fmax(qb[i], floor));
    *mean_rel = diff / fmax(sum, 1e-30);
}

/* rusticl's form of test_instanced_emitters_match_flattened: the GPU path
 * alone (the one rusticl takes), light tree off and on, LIT_RUSTICL_W
 * square at LIT_RUSTICL_SPP samples; the bound of the two images' means'
 * relative difference there (below). */
#define LIT_RUSTICL_W 16
#define LIT_RUSTICL_SPP 16
#define LIT_RUSTICL_LEVEL_TOL 0.005

/* Emitters on instanced meshes are lights once per instance: the image of
 * the scene whose instanced balls emit agrees with the flattened scene's,
 * whose balls' triangles are lights of their own, with the light tree off
 * and on, on the CPU path and the GPU-shaped path; and so does the mirror
 * scene's, lit by the light-tracing pass. The two pick their lights
 * differently (per instance, then per triangle), so their noise differs
 * where the picks matter: each 4x4 block within LIT_BLOCK_TOL (3 times the
 * largest difference seen, 1.7%; two seeds of one scene differ by 8%); the
 * mirror scene's quarters within 3 times the difference of two seeds
 * (seen: 1.4% against 2.7%; a mirrored card emitting on the wrong side
 * makes 45%). rusticl (a few hundred paths a second here) runs the lit
 * scene's GPU-path renders only, smaller (LIT_RUSTICL_W; 81 s with the
 * program built), whose blocks are too noisy for LIT_BLOCK_TOL (two seeds
 * differ by 50%): there each quarter within 3 times the seeds'
 * difference, and the whole image's mean within LIT_RUSTICL_LEVEL_TOL of
 * the flattened scene's (seen on rusticl and PoCL's GPU path: 0.11%; two
 * seeds differ by 0.8 to 2.2%; an instance's light samples counted twice,
 * their probability per area halved, make 1.3 to 1.4% and leave the
 * quarters within bounds). */
TEST(test_instanced_emitters_match_flattened)
{
    static const struct {
        int path, tree, mirror;
    } runs[5] = {{SPT_KERNEL_PATH_CPU, SPT_SWITCH_OFF, 0}, {SPT_KERNEL_PATH_CPU, SPT_SWITCH_ON, 0},
                 {SPT_KERNEL_PATH_GPU, SPT_SWITCH_OFF, 0}, {SPT_KERNEL_PATH_GPU, SPT_SWITCH_ON, 0},
                 {SPT_KERNEL_PATH_CPU, SPT_SWITCH_AUTO, 1}};
    int rusticl = test_on_rusticl();
    int w = rusticl ? LIT_RUSTICL_W : W, spp = rusticl ? LIT_RUSTICL_SPP : LIT_SPP, ran = 0;
    float *a = malloc(sizeof(float) * 3 * w * w), *b = malloc(sizeof(float) * 3 * w * w);
    for (int k = 0; k < 5; k++) {
        if (rusticl && (runs[k].path != SPT_KERNEL_PATH_GPU || runs[k].mirror))
            continue;
        Scene si, sf;
        if (runs[k].mirror) {
            mirror_scene(&si, 1);
            mirror_scene(&sf, 0);
        } else {
            lit_scene(&si, 1);
            lit_scene(&sf, 0);
        }
        RenderSettings rs = square_settings(w, spp, 5, 7u);
        rs.test.kernel_path = runs[k].path;
        rs.light_tree = runs[k].tree;
        if (runs[k].mirror) {
            rs.caustics = SPT_SWITCH_ON;
            rs.light_paths = (float)SPT_LIGHT_PATHS_MAX;
        }
        SptError e = {0};
        assert_int_equal(render_scene_rgb(&si, &rs, a, &e), 0);
        assert_int_equal(render_scene_rgb(&sf, &rs, b, &e), 0);
        double mean_rel, worst, worst_q, noise_mean, noise_worst, noise_q;
        image_diff(a, b, w, &mean_rel, &worst, &worst_q);
        double level = image_mean(a, w) / image_mean(b, w) - 1;
        rs.seed = 8u;
        assert_int_equal(render_scene_rgb(&sf, &rs, a, &e), 0);
        image_diff(a, b, w, &noise_mean, &noise_worst, &noise_q);
        double noise_level = image_mean(a, w) / image_mean(b, w) - 1;
        printf("path %d tree %d mirror %d: mean |diff| %.3g%% (seeds: %.3g%%), worst block %.3g%% "
               "(seeds: %.3g%%), worst quarter %.3g%% (seeds: %.3g%%), image mean %+.3g%% (seeds: %+.3g%%)\n",
               runs[k].path, runs[k].tree, runs[k].mirror, 100 * mean_rel, 100 * noise_mean, 100 * worst,
               100 * noise_worst, 100 * worst_q, 100 * noise_q, 100 * level, 100 * noise_level);
        /* The light paths' splats are noisier than the camera paths:
         * there the quarters, against 3 times the seeds' difference; and
         * so on rusticl's smaller renders. */
        if (runs[k].mirror || rusticl)
            assert_true(worst_q < 3 * noise_q);
        if (rusticl)
            assert_true(fabs(level) < LIT_RUSTICL_LEVEL_TOL);
        else if (!runs[k].mirror)
            assert_true(worst < LIT_BLOCK_TOL);
        assert_true(mean_rel < 1.5 * noise_mean + 1e-3);
        scene_free(&si);
        scene_free(&sf);
        ran++;
    }
    assert_int_equal(ran, rusticl ? 2 : 5);
    free(a);
    free(b);
}

/* The probability with which next-event estimation picks (instance k,
 * triangle prim) at (p, n, ts), as a BSDF-sampled hit's MIS weight
 * recomputes it (kernels/integrator/shade_surface.h): a world triangle's
 * tri_light_pdf times its area (times the tree's pick of its leaf), an
 * instance's entry's probability times the triangle's in its mesh. */
static double pick_prob(const GpuScene *g, const RenderLights *L, uint32_t k, uint32_t prim, vec3 p, vec3 n,
                        int ts)
{
    uint32_t e = g->emitter_count > g->tri_emitter_count ? L->inst_light[k] : SPT_INST_LIGHT_NONE;
    if (e == SPT_INST_LIGHT_NONE) {
        double pa = 0;
        for (uint32_t j = 0; j < g->tri_emitter_count; j++)
            if (g->emitters[j] == prim)
                pa = (double)L->tri_light_pdf[prim] * g->emitter_area[j];
        if (L->tree.count && pa > 0)
            pa *= light_tree_pmf(L->tree.nodes, L->tri_leaf[prim], p, n, ts);
        return pa;
    }
    double pe = spt_discrete_pdf(L->cdf_all, e);
    if (L->tree.count) {
        uint32_t leaf = inst_light_leaf(L->inst_light, g->tlas.inst_count, e - g->tri_emitter_count);
        pe = leaf == SPT_TREE_NONE ? 0.0
                                   : spt_discrete_pdf(L->cdf_all + L->aside_offset, 0) *
                                         light_tree_pmf(L->tree.nodes, leaf, p, n, ts);
    }
    return pe * L->tri_light_pdf[prim];
}

static uint64_t lit_rng = 99;
static float lit_u(void)
{
    lit_rng = lit_rng * 6364136223846793005ull + 1442695040888963407ull;
    return (float)((lit_rng >> 40) * 0x1p-24);
}

/* The light selection with instanced emitters, light tree off and on: at
 * random points and normals, the pick probabilities of every (instance,
 * triangle) sum to 1 within float rounding (no punctual light or sky here),
 * each instance's entry counts once per instance (its triangles' share is
 * its placed power's), and picks drawn as the kernels draw them
 * (light_tree_pick or the power CDF, then inst_light_pick) follow those
 * probabilities (chi-square), each reporting the probability its MIS weight
 * recomputes. */
TEST(test_instanced_emitter_pick_pdf)
{
    Scene s;
    lit_scene(&s, 1);
    GpuScene g;
    SptError e = {0};
    assert_int_equal(gpu_scene_build(&g, &s, &e), 0);
    /* The world's light (2 triangles) and the three ball instances. */
    assert_int_equal(g.tri_emitter_count, 2);
    assert_int_equal(g.emitter_count, 2 + 3);
    for (int tree = 0; tree < 2; tree++) {
        RenderSettings rs = square_settings(W, 1, 5, 7u);
        rs.light_tree = tree ? SPT_SWITCH_ON : SPT_SWITCH_OFF;
        RenderLights L;
        assert_int_equal(render_lights_setup(&L, &g, &rs, &e), 0);
        assert_int_equal(L.tree.count > 0, tree);
        for (int trial = 0; trial < 40; trial++) {
            vec3 p = v3(4 * lit_u() - 2, 4 * lit_u() - 1, 4 * lit_u() - 2);
            vec3 n = v3_normalize(v3(lit_u() - 0.5f, lit_u() - 0.5f, lit_u() - 0.5f));
            int ts = trial % 3 == 0;
            n = light_ctx_normal(light_ctx_pack(n, ts), &ts);
            double sum = 0;
            for (uint32_t k = 0; k < g.tlas.inst_count; k++) {
                uint32_t m = g.tlas.inst_mesh[k];
                for (uint32_t prim = g.mesh_prims[m]; prim < g.mesh_prims[m + 1]; prim++)
                    sum += pick_prob(&g, &L, k, prim, p, n, ts);
            }
            assert_close_rel(sum, 1.0, 2e-5);
        }
        /* Without the tree the instances' shares are their placed powers:
         * the instance scaled by (1, 0.6, 1.6) and the others' (unit
         * scale) against the flattened balls' triangles' powers. */
        if (!tree) {
            Scene f;
            lit_scene(&f, 0);
            GpuScene gf;
            assert_int_equal(gpu_scene_build(&gf, &f, &e), 0);
            double flat = 0, inst = 0;
            for (uint32_t j = 0; j < gf.emitter_count; j++)
                flat += gf.emitter_power[j];
            for (uint32_t j = 0; j < g.emitter_count; j++)
                inst += g.emitter_power[j];
            assert_close_rel(inst, flat, 1e-4);
            gpu_scene_free(&gf);
            scene_free(&f);
        }
        /* Chi-square of picks at one point against pick_prob. */
        vec3 p = v3(0.3f, 1.0f, 0.2f), n = v3(0, -1, 0);
        int ts = 0;
        n = light_ctx_normal(light_ctx_pack(n, 0), &ts);
        uint32_t np = g.prim_total, ni = g.tlas.inst_count;
        double *want = calloc((size_t)np * ni, sizeof(double));
        double *got = calloc((size_t)np * ni, sizeof(double));
        for (uint32_t k = 0; k < ni; k++) {
            uint32_t m = g.tlas.inst_mesh[k];
            for (uint32_t prim = g.mesh_prims[m]; prim < g.mesh_prims[m + 1]; prim++)
                want[(size_t)k * np + prim] = pick_prob(&g, &L, k, prim, p, n, ts);
        }
        const int N = 400000;
        int worst_prob = 0;
        for (int i = 0; i < N; i++) {
            float prob, tp;
            int sel = tree ? light_tree_pick(L.cdf_all + L.aside_offset, L.aside.n, L.tree.nodes, g.emitter_count,
                                             p, n, ts, lit_u(), &prob, &tp)
                           : spt_discrete_sample(L.cdf_all, L.select.n, lit_u(), &prob, NULL);
            assert_true(sel >= 0 && (uint32_t)sel < g.emitter_count);
            uint32_t k, prim = g.emitters[sel];
            if ((uint32_t)sel >= g.tri_emitter_count) {
                float pt;
                k = prim;
                prim = inst_light_pick(L.inst_light, L.cdf_all, ni, (uint32_t)sel - g.tri_emitter_count, lit_u(),
                                       &pt);
                prob *= pt;
            } else {
                for (k = 0; k < ni && g.tlas.inst_mesh[k] != 0; k++) {
                }
            }
            double w = want[(size_t)k * np + prim];
            worst_prob |= !(fabs(prob - w) <= 1e-4 * w);
            got[(size_t)k * np + prim] += 1;
        }
        assert_false(worst_prob);
        /* Cells of expected count >= 5, the rest pooled. */
        double chi2 = 0, pool_w = 0, pool_g = 0;
        int df = 0;
        for (size_t c = 0; c < (size_t)np * ni; c++) {
            double x = want[c] * N;
            if (x >= 5) {
                chi2 += (got[c] - x) * (got[c] - x) / x;
                df++;
            } else {
                pool_w += x;
                pool_g += got[c];
            }
        }
        if (pool_w > 0)
            chi2 += (pool_g - pool_w) * (pool_g - pool_w) / pool_w;
        double z = (chi2 - df) / sqrt(2.0 * df);
        printf("tree %d: chi2 %.1f over %d cells (z %.2f)\n", tree, chi2, df + 1, z);
        assert_true(df > 100);
        assert_true(z < 4.0);
        free(want);
        free(got);
        render_lights_free(&L);
    }
    gpu_scene_free(&g);
    scene_free(&s);
}

/* The MPI ranks get the instances: a packed scene unpacks with the same. */
TEST(test_instances_packed)
{
    Scene s, u;
    instanced_scene(&s, 1);
    size_t n = 0;
    void *bytes = scene_pack(&s, &n);
    SptError e = {0};
    assert_int_equal(scene_unpack(&u, bytes, n, "packed", &e), 0);
    assert_int_equal(u.mesh_count, MESH_COUNT);
    assert_int_equal(u.inst_count, N_INST);
    assert_memory_equal(u.mesh_tri_count, s.mesh_tri_count, sizeof(uint32_t) * MESH_COUNT);
    assert_memory_equal(u.inst_mesh, s.inst_mesh, sizeof(uint32_t) * N_INST);
    assert_memory_equal(u.inst_xf, s.inst_xf, sizeof(float) * 12 * N_INST);
    /* A block cut short is refused. */
    Scene v;
    assert_int_equal(scene_unpack(&v, bytes, n - 4, "packed", &e), SPT_EXIT_INPUT);
    free(bytes);
    scene_free(&s);
    scene_free(&u);
}

TEST_MAIN("instance_render", setup_cpu_device, teardown_cpu_device)
