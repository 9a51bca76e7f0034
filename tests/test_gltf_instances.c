/* The glTF loader's instancing (docs/gltf.md, "Instancing") on
 * tests/data/scenes/instancing.gltf (tools/make_instancing_scene.py): a mesh
 * placed by several nodes (rotated, non-uniformly scaled, mirrored, nested)
 * and by EXT_mesh_gpu_instancing nodes (float and normalised byte rotations)
 * loads as one mesh and its instances, whose transforms are numpy's
 * composition of the file's (instancing_expected.txt); a mesh placed once
 * stays flattened, an emitting mesh placed twice does not; and the scene renders
 * the image of its flattened load (--instancing off) up to the float
 * rounding of the transforms, on the CPU path (megakernel and stages) and
 * the GPU-shaped path; so do meshes with TANGENT (normal-mapped and
 * anisotropic) on tests/data/scenes/instancing_tangents.gltf
 * (tools/make_tangent_instancing_scene.py). */
#include "test_util.h"
#include "test_render_util.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define SCENE SPT_TEST_DATA("scenes/instancing.gltf")
#define BALL_TRIS 224 /* 8 rings of 16 segments, the poles' one triangle each */

static void load(Scene *s, int instancing)
{
    SptError e = {0};
    if (scene_load_gltf_posed(s, SCENE, &(ScenePose){NAN, NULL, NULL, instancing}, &e))
        fail_msg("%s", e.msg);
}

/* The expected instances: mesh and 3x4 rows each; returns their count. */
static int read_expected(uint32_t mesh[32], double xf[32][12])
{
    FILE *f = fopen(SPT_TEST_DATA("scenes/instancing_expected.txt"), "r");
    assert_non_null(f);
    char line[1024];
    int n = 0;
    while (fgets(line, sizeof line, f)) {
        if (line[0] == '#')
            continue;
        assert_true(n < 32);
        char *p = line;
        mesh[n] = (uint32_t)strtoul(p, &p, 10);
        for (int k = 0; k < 12; k++)
            xf[n][k] = strtod(p, &p);
        n++;
    }
    fclose(f);
    return n;
}

TEST(test_instances_loaded)
{
    Scene s;
    load(&s, SCENE_INSTANCING_AUTO);
    /* The ball, the card and the emitting quad (placed twice) by reference;
     * the floor (placed once) flattened: 2 world triangles. */
    assert_int_equal(s.mesh_count, 3);
    /* The expected file numbers the ball 0 and the card 1: each loaded mesh
     * is told by its triangles (the ball's count, the quad's emission). */
    uint32_t as_loaded[2] = {3, 3}, first = 2, light = 3;
    for (uint32_t m = 0; m < s.mesh_count; m++) {
        const SceneMaterial *sm = &s.materials[s.tri_mat[first]];
        if (s.mesh_tri_count[m] == BALL_TRIS)
            as_loaded[0] = m;
        else if (sm->emissive[0] > 0.0f)
            light = m;
        else
            as_loaded[1] = m;
        first += s.mesh_tri_count[m];
    }
    assert_true(as_loaded[0] < 3 && as_loaded[1] < 3 && light < 3);
    assert_int_equal(s.mesh_tri_count[as_loaded[1]], 2);
    assert_int_equal(s.mesh_tri_count[light], 2);
    assert_int_equal(s.tri_count, 2 + BALL_TRIS + 2 + 2);
    assert_int_equal(s.stats.instances, 1 + 2 + 5 + 6);
    assert_int_equal(s.stats.instanced_meshes, 0); /* none flattened more than once */
    /* Emitting triangles count per placement, as flattened. */
    assert_int_equal(s.stats.emissive_triangles, 4);
    uint32_t mesh[32];
    double xf[32][12];
    int n = read_expected(mesh, xf);
    assert_int_equal(n, 11);
    /* The expected file lists the ball's and the card's instances; the
     * emitting quad's two follow. */
    assert_int_equal(s.inst_count, (uint32_t)n + 2);
    /* Each expected instance matches one loaded instance (in any order). */
    int used[32] = {0}, mirrored = 0;
    for (int i = 0; i < n; i++) {
        int found = -1;
        for (int k = 0; k < (int)s.inst_count && found < 0; k++) {
            if (used[k] || mesh[i] > 1 || s.inst_mesh[k] != as_loaded[mesh[i]])
                continue;
            double worst = 0;
            for (int j = 0; j < 12; j++)
                worst = fmax(worst, fabs(s.inst_xf[12 * k + j] - xf[i][j]));
            if (worst < 1e-6)
                found = k;
        }
        if (found < 0)
            fail_msg("expected instance %d (mesh %u) not loaded", i, mesh[i]);
        used[found] = 1;
        const double *x = xf[i];
        double det = x[0] * (x[5] * x[10] - x[6] * x[9]) - x[1] * (x[4] * x[10] - x[6] * x[8]) +
                     x[2] * (x[4] * x[9] - x[5] * x[8]);
        mirrored += det < 0;
    }
    assert_int_equal(mirrored, 2); /* the ball's scale -1 and the card's -0.7 */
    /* A mesh's vertex normals stay in its own space: the ball's are its
     * positions over its radius. */
    uint32_t t = 2; /* the ball's first triangle, after the floor's two */
    for (uint32_t m = 0; m < as_loaded[0]; m++)
        t += s.mesh_tri_count[m];
    for (int k = 0; k < 3; k++) {
        uint32_t v = s.tri_vidx[3 * t + k];
        for (int r = 0; r < 3; r++)
            assert_close(s.vtx_normal[3 * v + r], s.tri_pos[9 * t + 3 * k + r] / 0.6, 1e-6);
    }
    /* The bounds are the flattened scene's, up to the rounding of the
     * transforms to float. */
    Scene f;
    load(&f, SCENE_INSTANCING_OFF);
    assert_int_equal(f.mesh_count, 0);
    assert_int_equal(f.inst_count, 0);
    assert_int_equal(f.tri_count, 6 + 5 * BALL_TRIS + 6 * 2);
    assert_int_equal(f.stats.instances, s.stats.instances);
    assert_int_equal(f.stats.primitives, s.stats.primitives);
    for (int k = 0; k < 3; k++) {
        assert_close(s.bounds_min[k], f.bounds_min[k], 1e-5);
        assert_close(s.bounds_max[k], f.bounds_max[k], 1e-5);
    }
    scene_free(&f);
    /* on: the floor by reference too. */
    load(&f, SCENE_INSTANCING_ON);
    assert_int_equal(f.mesh_count, 4);
    assert_int_equal(f.inst_count, 14);
    assert_int_equal(f.tri_count, 2 + 2 + BALL_TRIS + 2);
    scene_free(&f);
    scene_free(&s);
}

/* The two loads render alike on every kernel path: the emitting quad is two
 * instances in one and four world-space triangles in the other, so the light
 * selection's random streams differ and the images agree within their noise
 * (assert_renders_agree_noisy, tests/test_render_util.h). At 48 x 48 and 64
 * samples; on rusticl (test_on_rusticl) 24 x 24 at 16, 16 times fewer paths,
 * whose noise leaves a coarse check (a ray not carried into an instance's
 * space fails it; a normal carried wrongly, which test_instance_render's
 * exact comparison catches there, does not). */
TEST(test_instanced_gltf_matches_flattened)
{
    Scene si, sf;
    load(&si, SCENE_INSTANCING_AUTO);
    load(&sf, SCENE_INSTANCING_OFF);
    if (test_on_rusticl())
        assert_renders_agree_noisy(&si, &sf, 24, 16);
    else
        assert_renders_agree_noisy(&si, &sf, 48, 64);
    scene_free(&si);
    scene_free(&sf);
}

#define TANGENT_SCENE SPT_TEST_DATA("scenes/instancing_tangents.gltf")
#define TANGENT_BALL_TRIS 360 /* 10 rings of 20 segments, the poles' one triangle each */

/* Meshes with TANGENT load by reference, their tangents in their own space,
 * and render the image of their flattened load, whose tangents the loader
 * moved to world space in double (instancing_tangents.gltf,
 * tools/make_tangent_instancing_scene.py: a normal-mapped ball and an
 * anisotropic one, placed by rotated, non-uniformly scaled and mirrored
 * nodes). Neither emits, so both loads draw the same random numbers and the
 * images agree within assert_images_agree's rounding tolerance. */
TEST(test_instanced_tangents_match_flattened)
{
    Scene si, sf;
    SptError e = {0};
    ScenePose on = {NAN, NULL, NULL, SCENE_INSTANCING_AUTO}, off = {NAN, NULL, NULL, SCENE_INSTANCING_OFF};
    if (scene_load_gltf_posed(&si, TANGENT_SCENE, &on, &e) || scene_load_gltf_posed(&sf, TANGENT_SCENE, &off, &e))
        fail_msg("%s", e.msg);
    assert_int_equal(si.mesh_count, 2);
    assert_int_equal(si.inst_count, 5 + 3);
    assert_int_equal(si.tri_count, 2 + 2 * TANGENT_BALL_TRIS);
    assert_int_equal(sf.mesh_count, 0);
    assert_int_equal(sf.tri_count, 2 + 8 * TANGENT_BALL_TRIS);
    /* The meshes' tangents as the file gives them: (-sin phi, 0, cos phi, -1)
     * at the vertex of position r (sin th cos phi, cos th, sin th sin phi). */
    assert_non_null(si.vtx_tangent);
    for (uint32_t t = 2; t < si.tri_count; t += 37)
        for (int k = 0; k < 3; k++) {
            uint32_t v = si.tri_vidx[3 * t + k];
            const float *p = &si.tri_pos[9 * t + 3 * k], *tg = &si.vtx_tangent[4 * v];
            double rho = hypot(p[0], p[2]);
            assert_close(tg[3], -1.0, 0);
            assert_close(tg[1], 0.0, 1e-6);
            if (rho > 1e-3) {
                assert_close(tg[0], -p[2] / rho, 1e-5);
                assert_close(tg[2], p[0] / rho, 1e-5);
            }
        }
    /* 24 pixels wide on rusticl: the comparison is exact, so it stays strict. */
    assert_renders_agree(&si, &sf, test_on_rusticl() ? 24 : 48);
    scene_free(&si);
    scene_free(&sf);
}

TEST_MAIN("gltf_instances", setup_cpu_device, teardown_cpu_device)
