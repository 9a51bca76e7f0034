/* The light-tracing pass for caustics (kernels/integrator/light_trace.h, --caustics):
 * a diffuse floor under a smooth glass slab lit from above. Below the slab the
 * floor gets light only through the glass, and its irradiance follows from
 * Snell's law and the Fresnel equations: a point source at height a (the air
 * on the way) above the floor and a slab of thickness t and index n between
 * them send the ray leaving at angle theta to the floor at distance
 * r(theta) = a tan(theta) + t tan(theta_t), sin(theta_t) = sin(theta) / n, so
 * E(r) = I(theta) T(theta) sin(theta) / (r dr/dtheta) with
 * T = (1 - R(theta))^2 (the two interfaces, unpolarised Fresnel R), and at
 * r = 0 E = I T / (a + t/n)^2. An area light is a sum of such sources, I =
 * Le cos(theta) dA each; a directional light's beam passes with
 * E = E_dir T(0) (parallel light does not spread). The floor's radiance is
 * rho E / pi. With max_depth 4, nothing else reaches the floor there (the
 * internal reflections need 6 segments, shadow rays do not pass glass).
 *
 * The same through a thin lens. Also: camera paths alone (--caustics off) find the area light's caustic
 * too, and must agree (the two techniques split path space, nothing counts
 * twice); a scene without delta surfaces renders bit for bit as without the
 * pass; and the pass's splats do not depend on the path pool (scheduling) and
 * add up across chunks. */
#include "test_util.h"
#include "test_render_util.h"

#include "caustic_slab.h"

/* Where the ray of pixel (px, py)'s centre meets the floor (x, z); 0 when it
 * does not. Mirrors the camera of slab_scene and k_generate's rays. */
static int pixel_floor(const Scene *s, int w, int px, int py, double *x, double *z)
{
    double t = tan(0.5 * s->camera.yfov);
    double sx = (2.0 * (px + 0.5) / w - 1.0) * t, sy = (1.0 - 2.0 * (py + 0.5) / w) * t;
    double d[3];
    for (int k = 0; k < 3; k++)
        d[k] = s->camera.forward[k] + sx * s->camera.right[k] + sy * s->camera.up[k];
    if (!(d[1] < 0.0))
        return 0;
    double u = -s->camera.position[1] / d[1];
    *x = s->camera.position[0] + u * d[0];
    *z = s->camera.position[2] + u * d[2];
    return fabs(*x) < 2.0 && fabs(*z) < 2.0;
}

/* The thin lens of render_slab's camera: radius (0: pinhole) and focus distance. */
static float slab_aperture, slab_focus;

/* Renders slab_scene(light, glass) at W x W into film (initialised here). */
static void render_slab(int light, int glass, int caustics, int spp, int depth, uint32_t pool,
                        uint32_t sample_begin, Film *film)
{
    Scene s;
    slab_scene(&s, light, glass);
    if (!glass && s.light_count) {
        /* Without glass: a point light under the slab, so the floor is lit. */
        s.lights[0].type = SPT_LIGHT_POINT;
        s.lights[0].position[1] = 0.8f;
    }
    RenderSettings rs = square_settings(48, spp, depth, 3);
    rs.caustics = caustics;
    rs.pool_size = pool;
    rs.sample_begin = sample_begin;
    rs.aperture = slab_aperture;
    rs.focus_distance = slab_focus;
    render_caustic_scene(&s, &rs, film);
    scene_free(&s);
}

/* Compares the floor's film Y under the slab with expected_y: the mean over
 * the pixels whose floor point lies within radius r_max of the axis (within
 * rel), and the means of three rings (within 3 rel). Returns the pixel count. */
static int check_floor(const Film *f, int light, double r_max, double rel, const char *what)
{
    Scene s;
    slab_scene(&s, light, 1);
    int w = f->width;
    SlabRings g = {0};
    for (int py = 0; py < w; py++)
        for (int px = 0; px < w; px++) {
            double x, z;
            if (!pixel_floor(&s, w, px, py, &x, &z))
                continue;
            double r = sqrt(x * x + z * z);
            if (r >= r_max)
                continue;
            size_t i = (size_t)py * w + px;
            slab_rings_add(&g, r, r_max, f->xyz[3 * i + 1] / f->count[i], expected_y(light, x, z));
        }
    scene_free(&s);
    slab_rings_check(&g, rel, what, "floor under the slab");
    assert_true(g.n > 100);
    for (int k = 0; k < 3; k++)
        assert_true(g.ring_n[k] > 0);
    return g.n;
}

/* render_slab through the glass (depth 4) checked by check_floor. */
static void slab_floor(int light, int caustics, int spp, double r_max, double rel, const char *what)
{
    Film f;
    render_slab(light, 1, caustics, spp, 4, 0, 0, &f);
    check_floor(&f, light, r_max, rel, what);
    film_free(&f);
}

/* A spot light and a directional light through the slab: without the pass the
 * floor under the slab is black (punctual lights never pass glass); with it,
 * its radiance is the analytic one. */
TEST(test_punctual_through_glass)
{
    Film f;
    slab_floor(LIGHT_SPOT, SPT_SWITCH_ON, 64, 0.5, 0.01, "spot through glass");
    skip_if_quick();
    render_slab(LIGHT_SPOT, 1, SPT_SWITCH_OFF, 4, 4, 0, 0, &f);
    double dark = 0;
    for (int i = 0; i < f.width * f.height; i++)
        dark = fmax(dark, f.xyz[3 * i + 1] / f.count[i]);
    printf("spot, --caustics off: brightest pixel Y %.3g (the floor under glass is black)\n", dark);
    assert_true(dark == 0.0);
    film_free(&f);
    slab_floor(LIGHT_DIRECTIONAL, SPT_SWITCH_ON, 128, 0.6, 0.02, "directional through glass");
}

/* A thin lens: light paths connect to points of its aperture. Focused on the
 * floor's centre, with a lens of 3 cm, the floor's smooth caustic looks as it
 * does through the pinhole. */
TEST(test_thin_lens)
{
    skip_if_quick();
    slab_aperture = 0.03f;
    slab_focus = (float)sqrt(0.9 * 0.9 + 2.5 * 2.5);
    slab_floor(LIGHT_SPOT, SPT_SWITCH_ON, 64, 0.5, 0.015, "spot through glass, thin lens");
    slab_aperture = slab_focus = 0.0f;
}

/* An area light through the slab: the light paths (on) and the camera paths
 * alone (off) both find the analytic caustic, so the pass takes over exactly
 * what the camera paths give up. */
TEST(test_area_light_caustic)
{
    /* 256 spp: the mean's noise is about 0.65% there (1.2% at 64 spp, where a
     * 1% tolerance was a coin toss between seeds and samplers). */
    slab_floor(LIGHT_AREA, SPT_SWITCH_ON, 256, 0.5, 0.02, "area light, --caustics on");
    skip_if_quick();
    slab_floor(LIGHT_AREA, SPT_SWITCH_OFF, 1024, 0.5, 0.03, "area light, --caustics off");
}

/* Without delta surfaces the pass adds nothing: the image is the same bit for
 * bit (light paths end at their first vertex, and camera paths drop nothing). */
TEST(test_no_delta_unchanged)
{
    skip_if_quick();
    Film a, b;
    render_slab(LIGHT_SPOT, 0, SPT_SWITCH_OFF, 8, -1, 0, 0, &a);
    render_slab(LIGHT_SPOT, 0, SPT_SWITCH_ON, 8, -1, 0, 0, &b);
    size_t n = (size_t)a.width * a.height;
    assert_memory_equal(a.xyz, b.xyz, 3 * n * sizeof(double));
    assert_memory_equal(a.count, b.count, n * sizeof(double));
    double sum = 0;
    for (size_t i = 0; i < 3 * n; i++)
        sum += a.xyz[i];
    assert_true(sum > 0.0);
    film_free(&a);
    film_free(&b);
}

/* slab_scene's floor and light with two glass cubes under the light instead
 * of the slab: one at height 0.8-1.1, the other lower and to the side (height
 * 0.2-0.5), so that from the light their bounding spheres' cones overlap. Of
 * two glass materials (two caustic spheres) or, shared = 1, of one (one
 * sphere around both); the same scene either way. */
static void two_cubes_scene(Scene *s, int light, int shared)
{
    slab_scene(s, light, 1);
    /* The slab's 12 triangles (after the floor's 2) become the upper cube. */
    for (uint32_t t = 2; t < 14; t++)
        for (int c = 0; c < 3; c++) {
            float *v = s->tri_pos + 9 * t + 3 * c;
            v[0] = v[0] > 0.0f ? 0.15f : -0.15f;
            v[1] = v[1] > 1.1f ? 1.1f : 0.8f;
            v[2] = v[2] > 0.0f ? 0.15f : -0.15f;
        }
    const float lo[3] = {0.05f, 0.2f, -0.15f}, hi[3] = {0.35f, 0.5f, 0.15f};
    SceneMaterial *g = append_box(s, lo, hi);
    *g = s->materials[1];
    if (shared)
        for (uint32_t t = s->tri_count - 12; t < s->tri_count; t++)
            s->tri_mat[t] = 1;
}

/* Renders two_cubes_scene at 48 x 48 with the pass on; returns the mean film Y
 * of the pixels that see the floor within 0.6 of the point under the light
 * (the cubes' caustics and shadows). */
static double render_two_cubes(int light, int shared, int spp, uint32_t seed)
{
    Scene s;
    two_cubes_scene(&s, light, shared);
    RenderSettings rs = square_settings(48, spp, 4, seed);
    rs.caustics = SPT_SWITCH_ON;
    Film f;
    render_caustic_scene(&s, &rs, &f);
    double sum = 0;
    int n = 0;
    for (int py = 0; py < 48; py++)
        for (int px = 0; px < 48; px++) {
            double x, z;
            if (!pixel_floor(&s, 48, px, py, &x, &z) || x * x + z * z > 0.36)
                continue;
            size_t i = (size_t)py * 48 + px;
            sum += f.xyz[3 * i + 1] / f.count[i];
            n++;
        }
    assert_true(n > 100);
    film_free(&f);
    scene_free(&s);
    return sum / n;
}

/* Light paths aimed at two caustic spheres whose cones overlap (a cone in
 * proportion to its solid angle, a direction's density counting every cone
 * it lies in; for the directional light, discs) give the floor of the same
 * scene as one sphere around both cubes, for the area light's, the spot's
 * and the directional light's aiming. */
TEST(test_two_caustic_spheres)
{
    skip_if_quick();
    const int lights[3] = {LIGHT_AREA, LIGHT_SPOT, LIGHT_DIRECTIONAL};
    for (int k = 0; k < 3; k++) {
        double two = render_two_cubes(lights[k], 0, 256, 5);
        double one = render_two_cubes(lights[k], 1, 256, 6);
        printf("light %d: two spheres %.5f, one sphere %.5f (%.2f%%)\n", lights[k], two, one,
               100.0 * (two / one - 1.0));
        assert_true(one > 0.0);
        assert_true(fabs(two / one - 1.0) < 0.02);
    }
}

/* The closest-hit rays (camera and light paths) of a 48 x 48, 4 spp render of
 * s with --caustics caustics, and its film in *film. */
static uint64_t render_counting(const Scene *s, int caustics, Film *film)
{
    SptError e = {0};
    RenderSettings rs = square_settings(48, 4, -1, 3);
    rs.caustics = caustics;
    RenderStats st;
    int rc = render_film(s, &rs, film, &st, &e);
    if (rc)
        fprintf(stderr, "render: %s\n", e.msg);
    assert_int_equal(rc, 0);
    return st.rays_extend;
}

/* A glass material that only the scene's list holds, on no triangle, makes no
 * caustics: --caustics auto then traces no light paths (the same closest-hit
 * rays and film as with the pass off), while on the slab it turns the pass on
 * (more rays than with it off). */
TEST(test_unused_glass_no_pass)
{
    for (int used = 0; used <= 1; used++) {
        Scene s;
        slab_scene(&s, LIGHT_SPOT, used);
        if (!used) {
            /* A Lambertian slab, a point light under it (render_slab's), and
             * a smooth glass material at the end of the list. */
            s.lights[0].type = SPT_LIGHT_POINT;
            s.lights[0].position[1] = 0.8f;
            s.materials = realloc(s.materials, sizeof(SceneMaterial) * (s.material_count + 1));
            SceneMaterial *m = &s.materials[s.material_count++];
            scene_material_default(m);
            m->metallic = 0.0f;
            m->roughness = 0.0f;
            m->transmission = 1.0f;
        }
        Film a, b;
        uint64_t rays_auto = render_counting(&s, SPT_SWITCH_AUTO, &a);
        uint64_t rays_off = render_counting(&s, SPT_SWITCH_OFF, &b);
        if (used) {
            assert_true(rays_auto > rays_off);
        } else {
            assert_true(rays_auto == rays_off);
            size_t n = (size_t)a.width * a.height;
            assert_memory_equal(a.xyz, b.xyz, 3 * n * sizeof(double));
        }
        film_free(&a);
        film_free(&b);
        scene_free(&s);
    }
}

/* The splats do not depend on scheduling: a small path pool (other paths in
 * flight, other orders of the atomics) gives the same film bit for bit; and
 * two renders of samples [0, 4) and [4, 8) add up to the render of [0, 8). */
TEST(test_split_invariance)
{
    skip_if_quick();
    Film a, b, c, d;
    render_slab(LIGHT_SPOT, 1, SPT_SWITCH_ON, 8, -1, 0, 0, &a);
    render_slab(LIGHT_SPOT, 1, SPT_SWITCH_ON, 8, -1, 1000, 0, &b);
    size_t n = (size_t)a.width * a.height;
    assert_memory_equal(a.xyz, b.xyz, 3 * n * sizeof(double));
    render_slab(LIGHT_SPOT, 1, SPT_SWITCH_ON, 4, -1, 0, 0, &c);
    render_slab(LIGHT_SPOT, 1, SPT_SWITCH_ON, 4, -1, 0, 4, &d);
    film_add(&c, &d);
    double worst = 0, sum = 0;
    for (size_t i = 0; i < 3 * n; i++) {
        worst = fmax(worst, fabs(c.xyz[i] - a.xyz[i]) / fmax(fabs(a.xyz[i]), 1e-6));
        sum += a.xyz[i];
    }
    printf("split [0,8) vs [0,4) + [4,8): largest relative difference %.3g\n", worst);
    assert_true(sum > 0.0);
    assert_true(worst < 1e-5);
    film_free(&a);
    film_free(&b);
    film_free(&c);
    film_free(&d);
}

/* A closed box whose six walls are Lambertian (albedo BOX_ALBEDO) and emit
 * BOX_LE on their inside, with a clear smooth glass cube in it: the radiance
 * is BOX_LE / (1 - BOX_ALBEDO) everywhere in the air (a wall sends out its
 * emission plus BOX_ALBEDO of a uniform field, and lossless glass keeps a
 * uniform field uniform), so every pixel of a camera inside sees it, through
 * the glass too. With the pass on, the paths through the glass are split
 * between the two techniques at every depth (a wall seen from the camera,
 * lit by a wall that sees a light through the glass: the light paths'), so a
 * share counted twice or by neither shows as a departure from the furnace.
 * light_patch instead makes the box's walls plain and puts one light, a
 * square under the ceiling, above the cube (the closed-box caustic scene of
 * test_closed_box_one_light). */
#define BOX_ALBEDO 0.8
#define BOX_LE 1.0

static void closed_box_scene(Scene *s, int light_patch)
{
    memset(s, 0, sizeof *s);
    const float lo[3] = {-1, -1, -1}, hi[3] = {1, 1, 1};
    SceneMaterial *w = append_box(s, lo, hi);
    /* Faces inward: each triangle's winding reversed. */
    for (uint32_t t = s->tri_count - 12; t < s->tri_count; t++)
        for (int k = 0; k < 3; k++) {
            float tmp = s->tri_pos[9 * t + 3 + k];
            s->tri_pos[9 * t + 3 + k] = s->tri_pos[9 * t + 6 + k];
            s->tri_pos[9 * t + 6 + k] = tmp;
        }
    w->metallic = 0.0f;
    w->specular = 0.0f;
    for (int k = 0; k < 3; k++) {
        w->base_color[k] = (float)BOX_ALBEDO;
        w->emissive[k] = light_patch ? 0.0f : 1.0f;
    }
    w->emissive_strength = (float)BOX_LE;
    const float glo[3] = {-0.5f, -0.7f, -0.5f}, ghi[3] = {0.5f, 0.2f, 0.5f};
    set_clear_glass(append_box(s, glo, ghi), 1.5f);
    if (light_patch) {
        /* Counter-clockwise seen from below: the front faces down. */
        const float h = 0.25f, y = 0.99f;
        const float lc[4][3] = {{-h, y, -h}, {h, y, -h}, {h, y, h}, {-h, y, h}};
        SceneMaterial *lm = append_rect(s, lc);
        for (int k = 0; k < 3; k++) {
            lm->base_color[k] = 0.0f;
            lm->emissive[k] = 1.0f;
        }
        lm->emissive_strength = 10.0f;
    }
    /* From near the front wall, a little above the cube, toward the box's
     * centre below. */
    aim_camera(s, 0.3, 0.95, 0.35, 1.0, 1.2f);
}

/* Photon merging (--merge) in render_closed_box's renders. */
static int closed_box_merge = SPT_SWITCH_OFF;

static void render_closed_box(int light_patch, int caustics, int w, int spp, Film *film)
{
    Scene s;
    closed_box_scene(&s, light_patch);
    RenderSettings rs = square_settings(w, spp, -1, 5);
    rs.caustics = caustics;
    rs.merge = closed_box_merge;
    render_caustic_scene(&s, &rs, film);
    scene_free(&s);
}

/* The furnace of closed_box_scene with the pass on: the mean of each quarter
 * of the image (the glass cube fills much of the lower half) and of the
 * whole, against BOX_LE / (1 - BOX_ALBEDO). */
static void check_closed_box_furnace(const char *what)
{
    Film f;
    enum { W = 32 };
    render_closed_box(0, SPT_SWITCH_ON, W, 64, &f);
    double want = BOX_LE / (1.0 - BOX_ALBEDO), q[4] = {0}, all = 0;
    for (int py = 0; py < W; py++)
        for (int px = 0; px < W; px++) {
            size_t i = (size_t)py * W + px;
            double y = f.xyz[3 * i + 1] / f.count[i];
            q[2 * (py >= W / 2) + (px >= W / 2)] += y / (W * W / 4);
            all += y / (W * W);
        }
    printf("closed furnace box with a glass cube, %s: mean Y %.4f (%+.2f%%), quarters %+.2f%% "
           "%+.2f%% %+.2f%% %+.2f%%, expected %.4f\n",
           what, all, 100.0 * (all / want - 1.0), 100.0 * (q[0] / want - 1.0), 100.0 * (q[1] / want - 1.0),
           100.0 * (q[2] / want - 1.0), 100.0 * (q[3] / want - 1.0), want);
    assert_close_rel(all, want, 0.01);
    for (int k = 0; k < 4; k++)
        assert_close_rel(q[k], want, 0.03);
    film_free(&f);
}

TEST(test_closed_box_furnace)
{
    skip_if_quick();
    check_closed_box_furnace("--caustics on");
}

/* The same with photon merging, which takes the paths camera - glass -
 * wall - glass - emitting wall from the camera paths: counted twice or by
 * neither, the quarters that see the walls through the cube would show it. */
TEST(test_closed_box_furnace_merge)
{
    closed_box_merge = SPT_SWITCH_ON;
    check_closed_box_furnace("--caustics on --merge on");
    closed_box_merge = SPT_SWITCH_OFF;
}

/* One light in the closed box (closed_box_scene's light_patch): the caustic
 * of the glass cube on the floor lights the walls in turn (camera - wall -
 * floor - glass - light, the light paths' with the pass on), and camera paths
 * alone (--caustics off, at 8 times the samples) find the same light: the
 * means of the image's 4 x 4 blocks agree within their noise (the standard
 * error of each block's mean from its pixels' spread) and the whole image's
 * within 1%. */
TEST(test_closed_box_one_light)
{
    skip_if_quick();
    enum { W = 32, B = 4 };
    Film on, off;
    render_closed_box(1, SPT_SWITCH_ON, W, 64, &on);
    render_closed_box(1, SPT_SWITCH_OFF, W, 512, &off);
    double sum_on = 0, sum_off = 0, worst = 0;
    for (int by = 0; by < B; by++)
        for (int bx = 0; bx < B; bx++) {
            double m[2] = {0}, m2[2] = {0};
            int n = 0;
            for (int py = by * W / B; py < (by + 1) * W / B; py++)
                for (int px = bx * W / B; px < (bx + 1) * W / B; px++, n++) {
                    size_t i = (size_t)py * W + px;
                    const Film *f[2] = {&on, &off};
                    for (int k = 0; k < 2; k++) {
                        double y = f[k]->xyz[3 * i + 1] / f[k]->count[i];
                        m[k] += y;
                        m2[k] += y * y;
                    }
                }
            /* Pixels of a block differ in their expected values too, so the
             * spread overstates each estimate's noise: a loose bound. */
            double var = 0;
            for (int k = 0; k < 2; k++) {
                double mean = m[k] / n;
                var += fmax(m2[k] / n - mean * mean, 0.0) / n;
            }
            double z = (m[0] - m[1]) / n / sqrt(var);
            worst = fmax(worst, fabs(z));
            sum_on += m[0];
            sum_off += m[1];
        }
    printf("closed box, one light over a glass cube: mean Y --caustics on %.5g, off %.5g (%+.2f%%); "
           "largest block difference %.2f standard errors\n",
           sum_on / (W * W), sum_off / (W * W), 100.0 * (sum_on / sum_off - 1.0), worst);
    assert_close_rel(sum_on, sum_off, 0.01);
    assert_true(worst < 4.0);
    film_free(&on);
    film_free(&off);
}

TEST_MAIN("tests", setup_cpu_device, teardown_cpu_device)
