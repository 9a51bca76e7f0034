/* The light tree (kernels/light/light_tree.h, src/render/light_tree.c) on the
 * host: its pick probabilities over all lights sum to 1 at random points, its
 * picks follow them (chi-square), a light it never picks cannot light the
 * point (checked by brute force over the light's surface), its nodes bound
 * their children, and the packed normal of a path's light context comes
 * back within the slack the importance allows for it. */
#include "film_test.h"
#include "test_util.h"
#include "chi2.h"
#include "test_main.h"
#include "test_render_util.h"

#include <math.h>

#include "light/light_tree.h"
#include "render/light_tree.h"

#define LT_LIGHTS 300
#define LT_POINTS 200

/* A light of the test set: a triangle (kind 0, one- or two-sided), a point
 * light (1) or a spot (2), in a 20 m x 4 m x 20 m region. */
typedef struct TLight {
    int kind;
    double v[3][3];
    double pos[3], dir[3];
    double outer;
    int two_sided;
    double power;
} TLight;

static double tl_rand(uint64_t *s)
{
    *s += 1;
    return test_uniform(*s * 7919u + 13u);
}

static void unit_dir(uint64_t *s, double *d)
{
    double z = 2.0 * tl_rand(s) - 1.0, phi = 2.0 * M_PI * tl_rand(s), r = sqrt(fmax(0.0, 1.0 - z * z));
    d[0] = r * cos(phi);
    d[1] = r * sin(phi);
    d[2] = z;
}

static void make_lights(TLight *L, LightBound *b, uint32_t *ids, int n, uint64_t seed)
{
    uint64_t s = seed;
    for (int i = 0; i < n; i++) {
        TLight *l = &L[i];
        memset(l, 0, sizeof *l);
        l->kind = i % 5 == 3 ? 1 : (i % 5 == 4 ? 2 : 0);
        double c[3] = {20.0 * tl_rand(&s) - 10.0, 4.0 * tl_rand(&s), 20.0 * tl_rand(&s) - 10.0};
        l->power = 0.1 + 2.0 * tl_rand(&s);
        LightBound *lb = &b[i];
        memset(lb, 0, sizeof *lb);
        if (l->kind == 0) {
            for (int k = 0; k < 3; k++)
                for (int q = 0; q < 3; q++)
                    l->v[k][q] = c[q] + 0.6 * (tl_rand(&s) - 0.5);
            l->two_sided = i % 7 == 0;
            double e1[3], e2[3];
            for (int q = 0; q < 3; q++) {
                e1[q] = l->v[1][q] - l->v[0][q];
                e2[q] = l->v[2][q] - l->v[0][q];
            }
            double nrm[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                             e1[0] * e2[1] - e1[1] * e2[0]};
            double len = sqrt(nrm[0] * nrm[0] + nrm[1] * nrm[1] + nrm[2] * nrm[2]);
            for (int q = 0; q < 3; q++) {
                l->dir[q] = nrm[q] / len;
                lb->lo[q] = fmin(fmin(l->v[0][q], l->v[1][q]), l->v[2][q]);
                lb->hi[q] = fmax(fmax(l->v[0][q], l->v[1][q]), l->v[2][q]);
                lb->axis[q] = l->dir[q];
            }
            lb->theta_o = 0.0;
            lb->theta_e = 0.5 * M_PI;
            lb->two_sided = l->two_sided;
        } else {
            memcpy(l->pos, c, sizeof c);
            memcpy(lb->lo, c, sizeof c);
            memcpy(lb->hi, c, sizeof c);
            if (l->kind == 2) {
                unit_dir(&s, l->dir);
                l->outer = 0.1 + 0.9 * tl_rand(&s);
                memcpy(lb->axis, l->dir, sizeof l->dir);
                lb->theta_o = l->outer;
                lb->theta_e = 0.0;
            } else {
                lb->axis[2] = 1.0;
                lb->theta_o = M_PI;
                lb->theta_e = 0.5 * M_PI;
            }
        }
        lb->power = l->power;
        ids[i] = (uint32_t)(1000 + i);
    }
}

/* Whether light l can send light to point p with normal n (one side, or
 * both): for a triangle, whether some point of a fine grid on it sees p from
 * its emitting side(s) with p seeing it above its horizon; for a point light,
 * whether it lies above the horizon; a spot also within its cone. */
static int can_light(const TLight *l, const double *p, const double *n, int two_sided)
{
    if (l->kind != 0) {
        double d[3] = {l->pos[0] - p[0], l->pos[1] - p[1], l->pos[2] - p[2]};
        double dn = d[0] * n[0] + d[1] * n[1] + d[2] * n[2];
        if (!(two_sided ? fabs(dn) > 0.0 : dn > 0.0))
            return 0;
        if (l->kind == 1)
            return 1;
        double len = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        double c = -(d[0] * l->dir[0] + d[1] * l->dir[1] + d[2] * l->dir[2]) / len;
        return c > cos(l->outer);
    }
    const int G = 24;
    for (int a = 0; a <= G; a++)
        for (int b = 0; a + b <= G; b++) {
            double u = (double)a / G, v = (double)b / G, w = 1.0 - u - v;
            double q[3], d[3];
            for (int k = 0; k < 3; k++) {
                q[k] = w * l->v[0][k] + u * l->v[1][k] + v * l->v[2][k];
                d[k] = q[k] - p[k];
            }
            double dn = d[0] * n[0] + d[1] * n[1] + d[2] * n[2];
            double dl = -(d[0] * l->dir[0] + d[1] * l->dir[1] + d[2] * l->dir[2]);
            if ((two_sided ? fabs(dn) > 1e-9 : dn > 1e-9) && (l->two_sided ? fabs(dl) > 1e-9 : dl > 1e-9))
                return 1;
        }
    return 0;
}

/* A shading point of the test: inside the lights' region or around it, its
 * normal random, one side or (every third) two. */
static void make_point(uint64_t *s, int i, float p[3], float n[3], int *two_sided)
{
    double d[3];
    for (int k = 0; k < 3; k++)
        p[k] = (float)(30.0 * tl_rand(s) - 15.0);
    p[1] = (float)(8.0 * tl_rand(s) - 2.0);
    unit_dir(s, d);
    for (int k = 0; k < 3; k++)
        n[k] = (float)d[k];
    *two_sided = i % 3 == 0;
}

static TLight g_lights[LT_LIGHTS];
static LightBound g_bounds[LT_LIGHTS];
static uint32_t g_ids[LT_LIGHTS];

/* The sum of the pick probabilities over all lights is 1 (or 0 when no
 * light can reach the point, and the pick then fails), a pick's reported
 * probability is the pmf of what it picked, and no light the tree gives
 * probability 0 could light the point. */
TEST(test_light_tree_pmf_sums_to_one)
{
    make_lights(g_lights, g_bounds, g_ids, LT_LIGHTS, 1);
    LightTree t;
    light_tree_build(&t, g_bounds, g_ids, LT_LIGHTS);
    assert_int_equal(t.count, 2 * LT_LIGHTS - 1);
    uint64_t s = 99;
    int ones = 0, lost = 0;
    double worst = 0.0;
    for (int i = 0; i < LT_POINTS; i++) {
        float pf[3], nf[3];
        int ts;
        make_point(&s, i, pf, nf, &ts);
        vec3 p = v3(pf[0], pf[1], pf[2]);
        spt_i32 dts;
        vec3 n = light_ctx_normal(light_ctx_pack(v3(nf[0], nf[1], nf[2]), ts), &dts);
        assert_int_equal(dts, ts);
        double sum = 0.0;
        for (int k = 0; k < LT_LIGHTS; k++) {
            float pm = light_tree_pmf(t.nodes, t.leaf_of[k], p, n, ts);
            assert_true(pm >= 0.0f && pm <= 1.0f);
            sum += pm;
            double pd[3] = {pf[0], pf[1], pf[2]}, nd[3] = {nf[0], nf[1], nf[2]};
            if (pm == 0.0f && can_light(&g_lights[k], pd, nd, ts)) {
                lost++;
                print_error("point %d: light %d (kind %d) has pmf 0 but lights it\n", i, k, g_lights[k].kind);
            }
        }
        float prob;
        spt_i32 e = light_tree_sample(t.nodes, p, n, ts, tl_rand(&s), &prob);
        if (sum == 0.0) {
            assert_int_equal(e, -1);
            continue;
        }
        ones++;
        worst = fmax(worst, fabs(sum - 1.0));
        assert_true(e >= 1000 && e < 1000 + LT_LIGHTS);
        float pm = light_tree_pmf(t.nodes, t.leaf_of[e - 1000], p, n, ts);
        assert_float_equal(prob, pm, 1e-5 * pm);
    }
    print_message("pmf sums at %d points: largest |sum - 1| = %.3g\n", ones, worst);
    assert_true(ones > LT_POINTS / 2);
    assert_true(worst < 1e-5);
    assert_int_equal(lost, 0);
    light_tree_free(&t);
}

/* Picks with independent uniform u at a few points follow the pmf (chi-square over
 * the lights, Sidak-corrected over the points). */
TEST(test_light_tree_picks_chi2)
{
    make_lights(g_lights, g_bounds, g_ids, LT_LIGHTS, 2);
    LightTree t;
    light_tree_build(&t, g_bounds, g_ids, LT_LIGHTS);
    const int points = 6;
    const uint32_t N = 400000;
    double *obs = calloc(LT_LIGHTS, sizeof(double)), *expct = calloc(LT_LIGHTS, sizeof(double));
    uint64_t s = 7;
    for (int i = 0; i < points; i++) {
        float pf[3], nf[3];
        int ts;
        make_point(&s, i, pf, nf, &ts);
        pf[1] = 1.0f; /* within the lights' slab: many light it */
        vec3 p = v3(pf[0], pf[1], pf[2]);
        spt_i32 dts;
        vec3 n = light_ctx_normal(light_ctx_pack(v3(nf[0], nf[1], nf[2]), ts), &dts);
        memset(obs, 0, sizeof(double) * LT_LIGHTS);
        double sum = 0.0;
        for (int k = 0; k < LT_LIGHTS; k++) {
            expct[k] = (double)N * light_tree_pmf(t.nodes, t.leaf_of[k], p, n, ts);
            sum += expct[k];
        }
        assert_true(sum > 0.5 * N);
        for (uint32_t j = 0; j < N; j++) {
            float prob;
            float u = test_uniform(1000003u * (uint64_t)i + j);
            spt_i32 e = light_tree_sample(t.nodes, p, n, ts, u, &prob);
            assert_true(e >= 1000 && e < 1000 + LT_LIGHTS);
            obs[e - 1000] += 1.0;
        }
        Chi2Result r;
        int ok = chi2_test_counts("light tree picks", obs, expct, LT_LIGHTS, chi2_sidak(0.01, points), &r);
        print_message("point %d: chi2 %.1f, dof %d, p %.3g\n", i, r.stat, r.dof, r.pvalue);
        if (!ok)
            fail_msg("%s", r.message);
    }
    free(obs);
    free(expct);
    light_tree_free(&t);
}

/* Each interior node's box holds its children's, its power is their sum,
 * its cone of normals holds their axes (within their own spread), and each
 * light's leaf holds it. */
TEST(test_light_tree_bounds_nest)
{
    make_lights(g_lights, g_bounds, g_ids, LT_LIGHTS, 3);
    LightTree t;
    light_tree_build(&t, g_bounds, g_ids, LT_LIGHTS);
    assert_true(fabsf(t.nodes[0].power - 1.0f) < 1e-5f);
    assert_int_equal(t.nodes[0].parent, SPT_TREE_NONE);
    for (uint32_t i = 0; i < t.count; i++) {
        const LightTreeNode *a = &t.nodes[i];
        if (a->leaf)
            continue;
        for (uint32_t c = a->child; c < a->child + 2; c++) {
            const LightTreeNode *b = &t.nodes[c];
            assert_int_equal(b->parent, i);
            for (int k = 0; k < 3; k++) {
                assert_true(a->lo[k] <= b->lo[k]);
                assert_true(a->hi[k] >= b->hi[k]);
            }
            double dot = a->axis[0] * b->axis[0] + a->axis[1] * b->axis[1] + a->axis[2] * b->axis[2];
            double cx = (double)a->axis[1] * b->axis[2] - (double)a->axis[2] * b->axis[1],
                   cy = (double)a->axis[2] * b->axis[0] - (double)a->axis[0] * b->axis[2],
                   cz = (double)a->axis[0] * b->axis[1] - (double)a->axis[1] * b->axis[0];
            double ang = atan2(sqrt(cx * cx + cy * cy + cz * cz), dot);
            double ta = acos(fmax(-1.0, fmin(1.0, (double)a->cos_o)));
            double tb = acos(fmax(-1.0, fmin(1.0, (double)b->cos_o)));
            if (!(ta >= M_PI - 1e-6 || ang + tb <= ta + 1e-5))
                fail_msg("node %u child %u: angle %g + %g > %g", i, c, ang, tb, ta);
            assert_true(a->cos_e <= b->cos_e);
            assert_true(a->two_sided >= b->two_sided);
        }
        float ps = t.nodes[a->child].power + t.nodes[a->child + 1].power;
        assert_true(fabsf(ps - a->power) <= 1e-5f * a->power + 1e-7f);
    }
    for (int k = 0; k < LT_LIGHTS; k++) {
        const LightTreeNode *l = &t.nodes[t.leaf_of[k]];
        assert_int_equal(l->leaf, 1);
        assert_int_equal(l->child, g_ids[k]);
        for (int q = 0; q < 3; q++) {
            assert_true(l->lo[q] <= g_bounds[k].lo[q]);
            assert_true(l->hi[q] >= g_bounds[k].hi[q]);
        }
    }
    light_tree_free(&t);
}

/* A light context's normal comes back within 2e-3 rad (the importance
 * widens its horizon test by SPT_TREE_NORMAL_SLACK, 4e-3), its sides too. */
TEST(test_light_tree_normal_packing)
{
    assert_float_equal(SPT_TREE_SLACK_COS, cos(SPT_TREE_NORMAL_SLACK), 1e-7);
    assert_float_equal(SPT_TREE_SLACK_SIN, sin(SPT_TREE_NORMAL_SLACK), 1e-9);
    uint64_t s = 5;
    double worst = 0.0;
    for (int i = 0; i < 100000; i++) {
        double d[3];
        unit_dir(&s, d);
        if (i < 6) {
            memset(d, 0, sizeof d);
            d[i / 2] = i % 2 ? -1.0 : 1.0;
        }
        spt_i32 ts;
        float w = light_ctx_pack(v3((float)d[0], (float)d[1], (float)d[2]), i & 1);
        assert_true(fabsf(w) <= 16777216.0f && floorf(w) == w);
        vec3 n = light_ctx_normal(w, &ts);
        assert_int_equal(ts, i & 1);
        double c = n.x * d[0] + n.y * d[1] + n.z * d[2];
        double a = acos(fmin(1.0, c));
        worst = fmax(worst, a);
    }
    print_message("largest angle of a packed normal: %.3g rad\n", worst);
    assert_true(worst < 2e-3);
}

/* One light: the tree is its leaf, picked with probability 1 wherever it
 * can light the point. */
TEST(test_light_tree_single_light)
{
    make_lights(g_lights, g_bounds, g_ids, 1, 4);
    LightTree t;
    light_tree_build(&t, g_bounds, g_ids, 1);
    assert_int_equal(t.count, 1);
    float prob;
    spt_i32 e = light_tree_sample(t.nodes, v3(0.0f, 10.0f, 0.0f), v3(0.0f, -1.0f, 0.0f), 1, 0.5f, &prob);
    assert_int_equal(e, 1000);
    assert_float_equal(prob, 1.0f, 0.0f);
    assert_float_equal(light_tree_pmf(t.nodes, 0, v3(0.0f, 10.0f, 0.0f), v3(0.0f, -1.0f, 0.0f), 1), 1.0f, 0.0f);
    light_tree_free(&t);
}

/* A lamp-lit yard built in code: a grey floor, a rough metal box (whose
 * glossy reflections of the lamps weigh light sampling against BSDF sampling
 * by MIS), 24 small lamps facing down at several heights and strengths, an
 * unlit (double-sided) quad standing up, 3 spot lights, a point light, a
 * dim directional light and a dim uniform sky (the last two outside the
 * tree). */
static void yard_scene(Scene *s)
{
    grey_quad_scene(s);
    const float lo[3] = {-1.0f, 0.0f, -1.0f}, hi[3] = {0.5f, 0.8f, 0.2f};
    SceneMaterial *box = append_box(s, lo, hi);
    box->metallic = 1.0f;
    box->roughness = 0.3f;
    for (int i = 0; i < 24; i++) {
        float x = -4.5f + 1.8f * (float)(i % 6) + 0.3f * (float)(i / 6), z = -4.0f + 2.4f * (float)(i / 6);
        float y = 1.0f + 0.25f * (float)(i % 4), h = 0.1f + 0.02f * (float)(i % 3);
        /* Counter-clockwise seen from below: the front faces down. */
        const float c[4][3] = {{x - h, y, z - h}, {x + h, y, z - h}, {x + h, y, z + h}, {x - h, y, z + h}};
        SceneMaterial *m = append_rect(s, c);
        for (int k = 0; k < 3; k++) {
            m->base_color[k] = 0.0f;
            m->emissive[k] = k == i % 3 ? 1.0f : 0.6f;
        }
        m->emissive_strength = 20.0f + 15.0f * (float)(i % 5);
    }
    const float u[4][3] = {{2.0f, 0.0f, 1.0f}, {3.0f, 0.0f, 1.0f}, {3.0f, 0.6f, 1.0f}, {2.0f, 0.6f, 1.0f}};
    SceneMaterial *un = append_rect(s, u);
    un->unlit = 1;
    un->base_color[0] = 2.0f;
    un->base_color[1] = 1.0f;
    un->base_color[2] = 0.5f;
    s->light_count = 5;
    s->lights = calloc(5, sizeof(SceneLight));
    for (int j = 0; j < 5; j++) {
        SceneLight *l = &s->lights[j];
        l->type = j < 3 ? SPT_LIGHT_SPOT : (j == 3 ? SPT_LIGHT_POINT : SPT_LIGHT_DIRECTIONAL);
        l->position[0] = -3.0f + 2.5f * (float)j;
        l->position[1] = 2.0f;
        l->position[2] = j == 3 ? 3.0f : -1.0f;
        l->direction[0] = j == 4 ? 0.3f : 0.0f;
        l->direction[1] = j == 4 ? -0.954f : -1.0f;
        l->intensity = j < 3 ? 8.0f + 4.0f * (float)j : (j == 3 ? 3.0f : 0.05f);
        l->inner_cone = 0.3f;
        l->outer_cone = 0.5f;
        for (int k = 0; k < 3; k++)
            l->color[k] = 1.0f;
    }
    aim_camera(s, 5.0, 7.0, 5.0, 7.0, 0.9f);
}

/* The yard with and without the tree: the means of the image's 4 x 4 blocks
 * over R independent renders (seeds) agree by Welch's test, and so does the
 * whole image's. On rusticl (test_on_rusticl) 16 x 16 at 8 samples: the
 * blocks' standard errors grow about 6 times, which still tells a light the
 * tree never picks or a pick probability off by a factor. */
TEST(test_light_tree_images_agree)
{
    enum { B = 4, R = 8 };
    const int W = test_on_rusticl() ? 16 : 32;
    const int spp = test_on_rusticl() ? 8 : test_quick() ? 64 : 256;
    Scene s;
    yard_scene(&s);
    double m[2][B * B], m2[2][B * B], all[2] = {0}, all2[2] = {0};
    memset(m, 0, sizeof m);
    memset(m2, 0, sizeof m2);
    for (int r = 0; r < R; r++)
        for (int mode = 0; mode < 2; mode++) {
            RenderSettings rs = square_settings(W, spp, -1, (uint32_t)(11 + r));
            rs.light_tree = mode ? SPT_SWITCH_ON : SPT_SWITCH_OFF;
            Sky sky;
            SptError e = {0};
            assert_int_equal(sky_from_args(&sky, NULL, "0.05,0.05,0.05", &e), 0);
            rs.sky = &sky;
            float *rgb = malloc(sizeof(float) * 3 * W * W);
            if (render_scene_rgb(&s, &rs, rgb, &e))
                fail_msg("render: %s", e.msg);
            sky_free(&sky);
            double bm[48], img = 0.0;
            block_means_4x4(rgb, W, bm);
            for (int b = 0; b < B * B; b++) {
                double y = 0.2126 * bm[3 * b] + 0.7152 * bm[3 * b + 1] + 0.0722 * bm[3 * b + 2];
                m[mode][b] += y;
                m2[mode][b] += y * y;
                img += y / (B * B);
            }
            all[mode] += img;
            all2[mode] += img * img;
            free(rgb);
        }
    double worst = 0.0;
    for (int b = 0; b < B * B; b++) {
        double mean[2], var = 0.0;
        for (int k = 0; k < 2; k++) {
            mean[k] = m[k][b] / R;
            var += fmax(m2[k][b] / R - mean[k] * mean[k], 0.0) / (R - 1);
        }
        if (var > 0.0)
            worst = fmax(worst, fabs(mean[0] - mean[1]) / sqrt(var));
    }
    double mo = all[0] / R, mn = all[1] / R;
    double se = sqrt((fmax(all2[0] / R - mo * mo, 0.0) + fmax(all2[1] / R - mn * mn, 0.0)) / (R - 1));
    print_message("yard, %d runs of %d spp: mean Y off %.5g, on %.5g (%.2f standard errors); "
                  "largest block difference %.2f standard errors\n",
                  R, spp, mo, mn, fabs(mo - mn) / se, worst);
    /* 16 blocks and the image: Sidak's 0.01 over 17 tests of t with 14
     * degrees of freedom is about 4.2; 5 leaves room for the blocks' heavy
     * tails (the lamps seen in the metal). */
    assert_true(fabs(mo - mn) / se < 5.0);
    assert_true(worst < 5.0);
    scene_free(&s);
}

/* Split invariance with the tree: samples [0, 3) and [3, 8) of the yard add
 * up to [0, 8), and a small path pool (another schedule of the same
 * samples) gives the same film bit for bit. */
TEST(test_light_tree_split)
{
    enum { W = 24 };
    Scene s;
    yard_scene(&s);
    const uint32_t begin[4] = {0, 0, 3, 0}, count[4] = {8, 3, 5, 8}, pool[4] = {0, 0, 0, 1000};
    Film f[4];
    for (int k = 0; k < 4; k++) {
        RenderSettings rs = square_settings(W, (int)count[k], -1, 5);
        rs.light_tree = SPT_SWITCH_ON;
        rs.sample_begin = begin[k];
        rs.pool_size = pool[k];
        RenderStats st;
        SptError e = {0};
        if (render_film(&s, &rs, &f[k], &st, &e))
            fail_msg("render: %s", e.msg);
    }
    assert_split_films(f, "yard with the tree, [0,8) vs [0,3) + [3,8)");
    for (int k = 0; k < 4; k++)
        film_free(&f[k]);
    scene_free(&s);
}

TEST_MAIN("light_tree", setup_cpu_device, teardown_cpu_device)
