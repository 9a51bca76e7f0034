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

#include "render/gpu_scene.h"
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
    if (instanced) {
        s->mesh_count = MESH_COUNT;
        s->mesh_tri_count = malloc(sizeof(uint32_t) * MESH_COUNT);
        for (int m = 0; m < MESH_COUNT; m++) {
            append_tris(s, mesh[m].pos, mesh[m].nrm, mesh[m].tris, mesh[m].mat);
            s->mesh_tri_count[m] = mesh[m].tris;
        }
        s->inst_count = N_INST;
        s->inst_mesh = malloc(sizeof(uint32_t) * N_INST);
        s->inst_xf = malloc(sizeof(float) * 12 * N_INST);
        for (int k = 0; k < N_INST; k++) {
            s->inst_mesh[k] = in[k].mesh;
            for (int j = 0; j < 12; j++)
                s->inst_xf[12 * k + j] = (float)in[k].xf[j];
        }
    } else {
        for (int k = 0; k < N_INST; k++) {
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
            float *p = malloc(sizeof(float) * 9 * m->tris), *n = malloc(sizeof(float) * 9 * m->tris);
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
                        n[9 * t + 3 * v + r] = (float)(w[r] / sqrt(l) * (det < 0 ? -1 : 1));
                }
            append_tris(s, p, n, m->tris, m->mat);
            free(p);
            free(n);
        }
    }
    for (int m = 0; m < MESH_COUNT; m++) {
        free(mesh[m].pos);
        free(mesh[m].nrm);
    }
    aim(s);
    if (instanced) {
        /* The bounds of the placed meshes (the camera and the sky use them). */
        Scene f;
        instanced_scene(&f, 0);
        memcpy(s->bounds_min, f.bounds_min, sizeof s->bounds_min);
        memcpy(s->bounds_max, f.bounds_max, sizeof s->bounds_max);
        scene_free(&f);
    }
}

#define W 48

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
    assert_renders_agree(&si, &sf, W);
    scene_free(&si);
    scene_free(&sf);
}

/* A mesh of an instance that emits is refused: the light selection counts
 * world-space triangles only. */
TEST(test_instanced_emitter_refused)
{
    Scene s;
    instanced_scene(&s, 1);
    s.materials[s.material_count - 2].emissive[0] = 1.0f;
    GpuScene g;
    SptError e = {0};
    assert_int_equal(gpu_scene_build(&g, &s, &e), SPT_EXIT_INPUT);
    assert_non_null(strstr(e.msg, "emits"));
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
