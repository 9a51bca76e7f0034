/* Photon merging (--merge, kernels/integrator/photon_merge.h): caustics seen
 * through glass. The slab of tests/caustic_slab.h over its floor, seen from
 * above through the slab: the floor under the slab is lit only through the
 * glass (shadow rays do not pass it), and the camera sees it through the
 * glass again, so every path that lights those pixels is camera - S - S -
 * D - S - S - light, which the merge owns. The floor point a pixel sees
 * follows from Snell's law, and its radiance is the floor's analytic
 * radiance times (1 - R(theta_view))^2 (the two interfaces; the n^2 of
 * entering the glass cancels on leaving it). With max_depth 6 nothing else
 * reaches those pixels: the internal reflections need 8 segments or more.
 * Without merging, a spot light's caustic seen through the glass is black
 * (no path of the camera's reaches a punctual light), and the area light's
 * the camera paths find alone: the two agree (the partition counts every
 * path once). */
#include "test_util.h"
#include "test_render_util.h"

#include "caustic_slab.h"

/* The camera over the slab: at (0, CAM_Y, CAM_Z) toward the floor's centre. */
#define CAM_Y 1.7
#define CAM_Z 1.2
#define CAM_FOV 0.6f
/* The image's width: 48, and 24 in rusticl's form (test_on_rusticl,
 * docs/testing.md), which runs the spot's test and the split invariance
 * only, at a quarter of the pixels: the others need hundreds of samples per
 * pixel to hold their tolerances. */
#define W (test_on_rusticl() ? 24 : 48)
/* A count of pixels at 48 x 48, scaled to W x W. */
#define AT_W(n) ((n) * W * W / (48 * 48))

static void skip_on_rusticl(void)
{
    if (test_on_rusticl()) {
        print_message("  left out of rusticl's form\n");
        skip();
    }
}

static void merge_scene(Scene *s, int light)
{
    slab_scene(s, light, 1);
    aim_camera(s, CAM_Y, CAM_Z, CAM_Y, CAM_Z, CAM_FOV);
}

/* Whether a ray that rises from the slab's top reaches the light's height
 * at (x, z) within the area light (and a margin for the pixel's spread). */
static int sees_light(double x, double z)
{
    return fabs(x) < AREA_HALF + 0.05 && fabs(z) < AREA_HALF + 0.05;
}

/* The direction (not normalized) of pixel (px, py)'s centre ray from the
 * camera of s. */
static void pixel_dir(const Scene *s, int px, int py, double d[3])
{
    double tf = tan(0.5 * s->camera.yfov);
    double sx = (2.0 * (px + 0.5) / W - 1.0) * tf, sy = (1.0 - 2.0 * (py + 0.5) / W) * tf;
    for (int k = 0; k < 3; k++)
        d[k] = s->camera.forward[k] + sx * s->camera.right[k] + sy * s->camera.up[k];
}

/* Where pixel (px, py)'s centre ray meets the floor through the slab (x, z),
 * and the slab's transmittance along it (*t); 0 when it does not, or when its
 * reflection off the slab's top or bottom reaches the area light (that pixel
 * then sees the light too: right above the floor's centre, so the area
 * light's rings leave out the centre). */
static int pixel_floor_through(const Scene *s, int light, int px, int py, double *x, double *z, double *t)
{
    double d[3], o[3];
    pixel_dir(s, px, py, d);
    for (int k = 0; k < 3; k++)
        o[k] = s->camera.position[k];
    double len = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    for (int k = 0; k < 3; k++)
        d[k] /= len;
    if (!(d[1] < 0.0))
        return 0;
    double cos_i = -d[1];
    /* On the slab's top; its reflection rises to the light's height. */
    double u = (SLAB_TOP - o[1]) / d[1];
    double p[3] = {o[0] + u * d[0], SLAB_TOP, o[2] + u * d[2]};
    double ur = (AREA_Y - SLAB_TOP) / cos_i;
    if (light == LIGHT_AREA && sees_light(p[0] + ur * d[0], p[2] + ur * d[2]))
        return 0;
    /* Through the glass: the horizontal components over n; its reflection
     * off the bottom leaves the top 2 ut further on. */
    double hx = d[0] / SLAB_IOR, hz = d[2] / SLAB_IOR, cos_t = sqrt(1.0 - hx * hx - hz * hz);
    double ut = (SLAB_TOP - SLAB_BOTTOM) / cos_t;
    if (light == LIGHT_AREA && sees_light(p[0] + 2.0 * ut * hx + ur * d[0], p[2] + 2.0 * ut * hz + ur * d[2]))
        return 0;
    p[0] += ut * hx;
    p[2] += ut * hz;
    double uf = SLAB_BOTTOM / cos_i;
    *x = p[0] + uf * d[0];
    *z = p[2] + uf * d[2];
    double tr = 1.0 - fresnel(cos_i, SLAB_IOR);
    *t = tr * tr;
    return fabs(p[0]) < 1.4 && fabs(p[2]) < 1.4;
}

static void render_merge(int light, int merge, int spp, uint32_t seed, uint32_t sample_begin, uint32_t pool,
                         Film *f)
{
    Scene s;
    merge_scene(&s, light);
    RenderSettings rs = square_settings(W, spp, 6, seed);
    rs.caustics = SPT_SWITCH_ON;
    rs.merge = merge;
    rs.sample_begin = sample_begin;
    rs.pool_size = pool;
    render_caustic_scene(&s, &rs, f);
    scene_free(&s);
}

/* The mean film Y of the pixels that see the floor within r_max of the axis
 * through the slab, against the analytic one (within rel), and of three
 * rings (within 3 rel); returns the mean's ratio to the analytic one. */
static double check_through(const Film *f, int light, double r_max, double rel, const char *what)
{
    Scene s;
    merge_scene(&s, light);
    SlabRings g = {0};
    for (int py = 0; py < W; py++)
        for (int px = 0; px < W; px++) {
            double x, z, t;
            if (!pixel_floor_through(&s, light, px, py, &x, &z, &t))
                continue;
            double r = sqrt(x * x + z * z);
            if (r >= r_max)
                continue;
            size_t i = (size_t)py * W + px;
            slab_rings_add(&g, r, r_max, f->xyz[3 * i + 1] / f->count[i], t * expected_y(light, x, z));
        }
    scene_free(&s);
    slab_rings_check(&g, rel, what, "floor seen through the slab");
    assert_true(g.n > AT_W(200));
    for (int k = light == LIGHT_AREA ? 1 : 0; k < 3; k++)
        assert_true(g.ring_n[k] > AT_W(20));
    return g.got / g.want;
}

/* A spot light's caustic seen through the slab: the analytic one with
 * merging, black without. Within 2%, and 4% in rusticl's form: at 24 x 24
 * the mean's deviation over seeds 3 to 7 (on PoCL's GPU path) was 1.1% rms,
 * 1.5% at most. */
TEST(test_merge_spot_through_glass)
{
    Film f;
    render_merge(LIGHT_SPOT, SPT_SWITCH_ON, 64, 3, 0, 0, &f);
    check_through(&f, LIGHT_SPOT, 0.5, test_on_rusticl() ? 0.04 : 0.02, "spot, --merge on");
    film_free(&f);
    render_merge(LIGHT_SPOT, SPT_SWITCH_OFF, 4, 3, 0, 0, &f);
    double ratio = check_through(&f, LIGHT_SPOT, 0.5, 0.0, "spot, --merge off");
    assert_true(ratio == 0.0);
    film_free(&f);
}

/* An area light's: merging and the camera paths alone both find the analytic
 * one. */
TEST(test_merge_area_through_glass)
{
    skip_on_rusticl();
    Film f;
    render_merge(LIGHT_AREA, SPT_SWITCH_ON, 256, 3, 0, 0, &f);
    check_through(&f, LIGHT_AREA, 0.5, 0.02, "area light, --merge on");
    film_free(&f);
    skip_if_quick();
    render_merge(LIGHT_AREA, SPT_SWITCH_OFF, 1024, 3, 0, 0, &f);
    check_through(&f, LIGHT_AREA, 0.5, 0.03, "area light, --merge off");
    film_free(&f);
}

/* Dispersive glass (KHR_materials_dispersion) seen in a mirror: the slab's
 * spot caustic on the floor, seen by a camera under the slab in a vertical
 * mirror (metallic, white, smooth: reflectance 1) that the spot's cone does
 * not reach. Every path that lights those pixels is camera - S (mirror) - D -
 * S - S - spot, the merge's alone. The camera path keeps its four
 * wavelengths up to the merge, whose photons (through the dispersive slab)
 * kept only their hero; then most of its BSDF samples at the floor enter the
 * slab, where it keeps only its hero too: what it merged before must keep
 * its weight (pm_camera_hero). The slab's index varies by 2.8e-3 over
 * 400-700 nm (dispersion 0.05: Abbe number 400), which moves the analytic
 * floor radiance (the same formula at each wavelength's index) by under
 * 0.1%, so the analytic value of the index 1.5 holds. */
#define MIRROR_Z (-1.0)
#define MIRROR_TOP 0.95

static void mirror_scene(Scene *s)
{
    slab_scene(s, LIGHT_SPOT, 1);
    s->materials[1].dispersion = 0.05f;
    const float h = (float)MIRROR_TOP, z = (float)MIRROR_Z;
    /* Counter-clockwise seen from +z: its front faces the camera. */
    const float mc[4][3] = {{-1.2f, 0.0f, z}, {1.2f, 0.0f, z}, {1.2f, h, z}, {-1.2f, h, z}};
    SceneMaterial *m = append_rect(s, mc);
    m->metallic = 1.0f;
    m->specular = 1.0f;
    m->roughness = 0.0f;
    for (int k = 0; k < 3; k++)
        m->base_color[k] = 1.0f;
    /* From (0, 0.9, 0.3) toward the mirror, 22 degrees down. */
    aim_camera(s, 0.9, 0.3, 0.404, 1.0, 0.5f);
}

/* Where pixel (px, py)'s centre ray, reflected by the mirror, meets the
 * floor (x, z); 0 when it misses the mirror. */
static int pixel_floor_mirrored(const Scene *s, int px, int py, double *x, double *z)
{
    double d[3];
    pixel_dir(s, px, py, d);
    const float *o = s->camera.position;
    if (!(d[2] < 0.0) || !(d[1] < 0.0))
        return 0;
    double u = (MIRROR_Z - o[2]) / d[2], mx = o[0] + u * d[0], my = o[1] + u * d[1];
    if (!(my > 0.0 && my < MIRROR_TOP && fabs(mx) < 1.2))
        return 0;
    double v = my / -d[1];
    *x = mx + v * d[0];
    *z = MIRROR_Z - v * d[2];
    return 1;
}

TEST(test_merge_dispersive_in_mirror)
{
    skip_on_rusticl();
    Scene s;
    mirror_scene(&s);
    RenderSettings rs = square_settings(W, 64, 6, 3);
    rs.caustics = SPT_SWITCH_ON;
    rs.merge = SPT_SWITCH_ON;
    Film f;
    render_caustic_scene(&s, &rs, &f);
    const double r_max = 0.5;
    SlabRings g = {0};
    for (int py = 0; py < W; py++)
        for (int px = 0; px < W; px++) {
            double x, z;
            if (!pixel_floor_mirrored(&s, px, py, &x, &z))
                continue;
            double r = sqrt(x * x + z * z);
            if (r >= r_max)
                continue;
            size_t i = (size_t)py * W + px;
            slab_rings_add(&g, r, r_max, f.xyz[3 * i + 1] / f.count[i], expected_y(LIGHT_SPOT, x, z));
        }
    film_free(&f);
    scene_free(&s);
    slab_rings_check(&g, 0.03, "dispersive slab, spot, --merge on", "floor seen in the mirror");
    assert_true(g.n > AT_W(200));
    for (int k = 0; k < 3; k++)
        assert_true(g.ring_n[k] > AT_W(20));
}

/* Under adaptive sampling (a pixel's samples run behind the chunk's sample
 * slots once it has fewer than its neighbours): the spot's caustic seen
 * through the slab is still the analytic one, and the pixels took unequal
 * samples (the lag was exercised). */
TEST(test_merge_adaptive)
{
    skip_on_rusticl();
    Scene s;
    merge_scene(&s, LIGHT_SPOT);
    RenderSettings rs = square_settings(W, 128, 6, 3);
    rs.caustics = SPT_SWITCH_ON;
    rs.merge = SPT_SWITCH_ON;
    rs.adaptive = SPT_SWITCH_ON;
    Film f;
    render_caustic_scene(&s, &rs, &f);
    scene_free(&s);
    /* Pixels by their samples: 16, 32, ..., 128 (a count that is not a power
     * of two took a segment after skipping one: its samples lagged). */
    int by[9] = {0}, lagged = 0;
    for (int i = 0; i < W * W; i++) {
        int n = (int)f.count[i];
        by[n / 16 <= 8 ? n / 16 : 8]++;
        lagged += n != 16 && n != 32 && n != 64 && n != 128;
    }
    printf("--adaptive on: pixels of 16, 32, ..., 128 samples: %d %d %d %d %d %d %d %d\n", by[1], by[2], by[3],
           by[4], by[5], by[6], by[7], by[8]);
    assert_true(lagged > 0);
    check_through(&f, LIGHT_SPOT, 0.5, 0.03, "spot, --merge on --adaptive on");
    film_free(&f);
}

/* A pure function of the samples: a small path pool (other orders of the
 * light paths' photons and of the atomics) gives the same film bit for bit,
 * and renders of samples [0, 4) and [4, 8) add up to the render of [0, 8)
 * (other chunks, so other grids, whose buckets a gather walks cell by cell
 * in slot order). */
TEST(test_merge_split_invariance)
{
    Film a, b, c, d;
    render_merge(LIGHT_SPOT, SPT_SWITCH_ON, 8, 5, 0, 0, &a);
    render_merge(LIGHT_SPOT, SPT_SWITCH_ON, 8, 5, 0, 1000, &b);
    size_t n = (size_t)a.width * a.height;
    assert_memory_equal(a.xyz, b.xyz, 3 * n * sizeof(double));
    render_merge(LIGHT_SPOT, SPT_SWITCH_ON, 4, 5, 0, 0, &c);
    render_merge(LIGHT_SPOT, SPT_SWITCH_ON, 4, 5, 4, 0, &d);
    film_add(&c, &d);
    double worst = 0, sum = 0;
    for (size_t i = 0; i < 3 * n; i++) {
        worst = fmax(worst, fabs(c.xyz[i] - a.xyz[i]) / fmax(fabs(a.xyz[i]), 1e-6));
        sum += a.xyz[i];
    }
    printf("--merge on, split [0,8) vs [0,4) + [4,8): largest relative difference %.3g\n", worst);
    assert_true(sum > 0.0);
    assert_true(worst < 1e-5);
    film_free(&a);
    film_free(&b);
    film_free(&c);
    film_free(&d);
}

/* The glass sphere on its floor under the square light of
 * tests/data/scenes/caustic_sphere_area.gltf, seen from above through the
 * sphere (every pixel: camera - S - S - floor - S - S - light, where the
 * sphere focuses the light around its contact point, or the sphere's
 * shadow): merging at SPHERE_SPP and 4 times that against the camera paths
 * alone at SPHERE_REF_SPP (two seeds, whose difference measures the
 * reference's own noise), by the 4 x 4 blocks' means per channel. Each
 * block agrees with the reference within 5 standard errors (of the
 * difference, from the pixels' spread in the block and the reference's),
 * and the squared error at 4 times the samples is under 0.75 of the first
 * (the estimate converges as the radius shrinks, not to a blurred image). */
#define SPHERE_W 32
#define SPHERE_SPP 64
#define SPHERE_REF_SPP 2048

static void render_sphere(int merge, int spp, uint32_t seed, double means[48], double se[48])
{
    Scene s;
    SptError e = {0};
    assert_int_equal(scene_load_gltf(&s, "tests/data/scenes/caustic_sphere_area.gltf", &e), 0);
    camera_down(&s, 0.0f, 2.2f, 0.5f, 1.0f);
    scene_update_bounds(&s);
    RenderSettings rs = square_settings(SPHERE_W, spp, 8, seed);
    rs.caustics = SPT_SWITCH_ON;
    rs.merge = merge;
    Film f;
    render_caustic_scene(&s, &rs, &f);
    float *rgb = malloc(sizeof(float) * 3 * SPHERE_W * SPHERE_W);
    film_to_linear_srgb(&f, rgb);
    block_means_4x4(rgb, SPHERE_W, means);
    /* The standard error of each block's mean from its pixels' spread (which
     * their differing expected values inflate: a loose bound). */
    const int bs = SPHERE_W / 4;
    for (int b = 0; b < 16; b++)
        for (int c = 0; c < 3; c++) {
            double m2 = 0;
            for (int y = (b / 4) * bs; y < (b / 4 + 1) * bs; y++)
                for (int x = (b % 4) * bs; x < (b % 4 + 1) * bs; x++) {
                    double d = rgb[3 * (y * SPHERE_W + x) + c] - means[3 * b + c];
                    m2 += d * d;
                }
            se[3 * b + c] = sqrt(m2 / (bs * bs - 1) / (bs * bs));
        }
    free(rgb);
    film_free(&f);
    scene_free(&s);
}

TEST(test_merge_sphere_converges)
{
    skip_if_quick();
    double ra[48], rb[48], sa[48], sb[48], m1[48], s1[48], m4[48], s4[48];
    render_sphere(SPT_SWITCH_OFF, SPHERE_REF_SPP, 11, ra, sa);
    render_sphere(SPT_SWITCH_OFF, SPHERE_REF_SPP, 12, rb, sb);
    render_sphere(SPT_SWITCH_ON, SPHERE_SPP, 5, m1, s1);
    render_sphere(SPT_SWITCH_ON, 4 * SPHERE_SPP, 6, m4, s4);
    double e1 = 0, e4 = 0, eref = 0, worst = 0, level = 0;
    for (int k = 0; k < 48; k++) {
        double r = 0.5 * (ra[k] + rb[k]), se_r = 0.5 * sqrt(sa[k] * sa[k] + sb[k] * sb[k]);
        e1 += (m1[k] - r) * (m1[k] - r);
        e4 += (m4[k] - r) * (m4[k] - r);
        eref += 0.25 * (ra[k] - rb[k]) * (ra[k] - rb[k]);
        worst = fmax(worst, fabs(m4[k] - r) / sqrt(s4[k] * s4[k] + se_r * se_r));
        level += r / 48.0;
    }
    printf("sphere seen through, blocks' rms error against camera paths alone (%d spp x 2, their own "
           "%.3g): --merge on %d spp %.3g, %d spp %.3g (ratio of squares %.2f); largest block difference "
           "%.2f standard errors; mean level %.3g\n",
           SPHERE_REF_SPP, sqrt(eref / 48), SPHERE_SPP, sqrt(e1 / 48), 4 * SPHERE_SPP, sqrt(e4 / 48), e4 / e1,
           worst, level);
    assert_true(level > 0.0);
    assert_true(e4 < 0.75 * e1);
    assert_true(worst < 5.0);
}

/* The spot's caustic lighting the floor again off a diffuse wall: a white
 * Lambertian wall under the slab at x = WALL_X, which the caustic lights
 * (the spot itself does not reach it). The floor beyond the caustic (r from
 * 0.8 to 1.3) is lit only by paths with more vertices with a non-delta lobe
 * between it and the glass (wall, caustic), camera - S - S - D - D - D - S -
 * S - spot seen through the slab: the merge's from the light paths' second
 * and later photons, where the camera's own paths can never reach the spot.
 * The slab_scene camera sees the same floor directly (camera - D - ... - S -
 * S - spot, the light-tracing pass's connections, an independent
 * technique); the floor is Lambertian, so the pixels through the slab over
 * their transmittance must agree with it, floor cell by floor cell. */
#define WALL_X (-1.0)
#define WALL_SPP 256
#define WALL_DEPTH 10

static void wall_scene(Scene *s, int through)
{
    slab_scene(s, LIGHT_SPOT, 1);
    const float x = (float)WALL_X;
    /* Counter-clockwise seen from +x: its front faces the floor's centre. */
    const float wc[4][3] = {{x, 0.0f, -1.4f}, {x, 0.0f, 1.4f}, {x, 0.95f, 1.4f}, {x, 0.95f, -1.4f}};
    SceneMaterial *m = append_rect(s, wc);
    m->specular = 0.0f;
    for (int k = 0; k < 3; k++)
        m->base_color[k] = 0.8f;
    if (through)
        aim_camera(s, CAM_Y, CAM_Z, CAM_Y, CAM_Z, CAM_FOV);
    else
        scene_update_bounds(s);
}

/* Where pixel (px, py)'s centre ray from slab_scene's camera (under the
 * slab) meets the floor (x, z). */
static int pixel_floor_direct(const Scene *s, int px, int py, double *x, double *z)
{
    double d[3];
    pixel_dir(s, px, py, d);
    const float *o = s->camera.position;
    if (!(d[1] < 0.0))
        return 0;
    double u = -o[1] / d[1];
    *x = o[0] + u * d[0];
    *z = o[2] + u * d[2];
    return 1;
}

/* The floor cell (0.1 m) of (x, z) beyond the caustic and clear of the
 * wall, or -1. */
#define WALL_CELLS 30
static int wall_cell(double x, double z)
{
    double r = sqrt(x * x + z * z);
    if (!(r > 0.8 && r < 1.3 && x > WALL_X + 0.1))
        return -1;
    return (int)floor((x + 1.5) / 0.1) * WALL_CELLS + (int)floor((z + 1.5) / 0.1);
}

TEST(test_merge_caustic_off_a_wall)
{
    skip_on_rusticl(); /* two renders of 256 spp: minutes at llvmpipe's rate */
    Scene s;
    Film f[2];
    for (int through = 0; through < 2; through++) {
        wall_scene(&s, through);
        RenderSettings rs = square_settings(W, WALL_SPP, WALL_DEPTH, 7);
        rs.caustics = SPT_SWITCH_ON;
        rs.merge = through ? SPT_SWITCH_ON : SPT_SWITCH_OFF;
        render_caustic_scene(&s, &rs, &f[through]);
        scene_free(&s);
    }
    static double sum[2][WALL_CELLS * WALL_CELLS];
    static int n[2][WALL_CELLS * WALL_CELLS];
    memset(sum, 0, sizeof sum);
    memset(n, 0, sizeof n);
    for (int through = 0; through < 2; through++) {
        wall_scene(&s, through);
        for (int py = 0; py < W; py++)
            for (int px = 0; px < W; px++) {
                double x, z, t = 1.0;
                if (!(through ? pixel_floor_through(&s, LIGHT_SPOT, px, py, &x, &z, &t)
                              : pixel_floor_direct(&s, px, py, &x, &z)))
                    continue;
                int c = wall_cell(x, z);
                if (c < 0)
                    continue;
                size_t i = (size_t)py * W + px;
                sum[through][c] += f[through].xyz[3 * i + 1] / f[through].count[i] / t;
                n[through][c]++;
            }
        scene_free(&s);
        film_free(&f[through]);
    }
    /* The cells both see: the means of their means. */
    double m[2] = {0, 0};
    int cells = 0;
    for (int c = 0; c < WALL_CELLS * WALL_CELLS; c++) {
        if (n[0][c] < 2 || n[1][c] < 2)
            continue;
        for (int k = 0; k < 2; k++)
            m[k] += sum[k][c] / n[k][c];
        cells++;
    }
    printf("floor lit off the wall, %d cells: seen directly (light tracing) %.4g, through the slab "
           "(--merge on) %.4g, ratio %.3f\n",
           cells, m[0] / cells, m[1] / cells, m[1] / m[0]);
    assert_true(cells > 20);
    assert_true(m[0] > 0.0);
    assert_true(fabs(m[1] / m[0] - 1.0) < 0.05);
}

TEST_MAIN("tests", setup_cpu_device, teardown_cpu_device)
