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
#define W 48

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

/* Where pixel (px, py)'s centre ray meets the floor through the slab (x, z),
 * and the slab's transmittance along it (*t); 0 when it does not, or when its
 * reflection off the slab's top or bottom reaches the area light (that pixel
 * then sees the light too: right above the floor's centre, so the area
 * light's rings leave out the centre). */
static int pixel_floor_through(const Scene *s, int light, int px, int py, double *x, double *z, double *t)
{
    double tf = tan(0.5 * s->camera.yfov), d[3], o[3];
    double sx = (2.0 * (px + 0.5) / W - 1.0) * tf, sy = (1.0 - 2.0 * (py + 0.5) / W) * tf;
    for (int k = 0; k < 3; k++) {
        d[k] = s->camera.forward[k] + sx * s->camera.right[k] + sy * s->camera.up[k];
        o[k] = s->camera.position[k];
    }
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

static void render_merge(int light, int merge, int spp, uint32_t seed, uint32_t sample_begin, Film *f)
{
    Scene s;
    merge_scene(&s, light);
    RenderSettings rs = square_settings(W, spp, 6, seed);
    rs.caustics = SPT_SWITCH_ON;
    rs.merge = merge;
    rs.sample_begin = sample_begin;
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
    double got = 0, want = 0, ring_got[3] = {0}, ring_want[3] = {0};
    int n = 0, ring_n[3] = {0};
    for (int py = 0; py < W; py++)
        for (int px = 0; px < W; px++) {
            double x, z, t;
            if (!pixel_floor_through(&s, light, px, py, &x, &z, &t))
                continue;
            double r = sqrt(x * x + z * z);
            if (r >= r_max)
                continue;
            size_t i = (size_t)py * W + px;
            double y = f->xyz[3 * i + 1] / f->count[i], e = t * expected_y(light, x, z);
            got += y;
            want += e;
            int ring = (int)(3.0 * r / r_max);
            ring_got[ring] += y;
            ring_want[ring] += e;
            ring_n[ring]++;
            n++;
        }
    scene_free(&s);
    printf("%s: floor seen through the slab, %d pixels: mean Y %.5g, predicted %.5g (%+.2f%%); rings", what, n,
           got / n, want / n, 100.0 * (got / want - 1.0));
    for (int k = 0; k < 3; k++)
        printf(" %+.2f%% (%d)", 100.0 * (ring_got[k] / ring_want[k] - 1.0), ring_n[k]);
    printf("\n");
    assert_true(n > 200);
    for (int k = light == LIGHT_AREA ? 1 : 0; k < 3; k++)
        assert_true(ring_n[k] > 20);
    if (rel > 0.0) {
        assert_close_rel(got, want, rel);
        for (int k = 0; k < 3; k++)
            if (ring_n[k])
                assert_close_rel(ring_got[k], ring_want[k], 3.0 * rel);
    }
    return got / want;
}

/* A spot light's caustic seen through the slab: the analytic one with
 * merging, black without. */
TEST(test_merge_spot_through_glass)
{
    Film f;
    render_merge(LIGHT_SPOT, SPT_SWITCH_ON, 64, 3, 0, &f);
    check_through(&f, LIGHT_SPOT, 0.5, 0.02, "spot, --merge on");
    film_free(&f);
    render_merge(LIGHT_SPOT, SPT_SWITCH_OFF, 4, 3, 0, &f);
    double ratio = check_through(&f, LIGHT_SPOT, 0.5, 0.0, "spot, --merge off");
    assert_true(ratio == 0.0);
    film_free(&f);
}

/* An area light's: merging and the camera paths alone both find the analytic
 * one. */
TEST(test_merge_area_through_glass)
{
    Film f;
    render_merge(LIGHT_AREA, SPT_SWITCH_ON, 64, 3, 0, &f);
    check_through(&f, LIGHT_AREA, 0.5, 0.02, "area light, --merge on");
    film_free(&f);
    skip_if_quick();
    render_merge(LIGHT_AREA, SPT_SWITCH_OFF, 1024, 3, 0, &f);
    check_through(&f, LIGHT_AREA, 0.5, 0.03, "area light, --merge off");
    film_free(&f);
}

TEST_MAIN("tests", setup_cpu_device, teardown_cpu_device)
