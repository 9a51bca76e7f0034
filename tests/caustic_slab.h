/* The glass slab over a diffuse floor of tests/test_caustics.c and
 * tests/test_caustics_merge.c, with its analytic caustic: a point source at
 * height a (the air on the way) above the floor and a slab of thickness t and
 * index n between them send the ray leaving at angle theta to the floor at
 * distance r(theta) = a tan(theta) + t tan(theta_t), sin(theta_t) =
 * sin(theta) / n, so E(r) = I(theta) T(theta) sin(theta) / (r dr/dtheta) with
 * T = (1 - R(theta))^2 (the two interfaces, unpolarised Fresnel R), and at
 * r = 0 E = I T / (a + t/n)^2. An area light is a sum of such sources, I =
 * Le cos(theta) dA each; a directional light's beam passes with E = E_dir
 * T(0) (parallel light does not spread). The floor's radiance is rho E / pi. */
#ifndef SPT_TEST_CAUSTIC_SLAB_H
#define SPT_TEST_CAUSTIC_SLAB_H

#include "test_util.h"
#include "test_render_util.h"

#define SLAB_TOP 1.2
#define SLAB_BOTTOM 1.0
#define SLAB_IOR 1.5
#define FLOOR_ALBEDO 0.5

enum { LIGHT_SPOT, LIGHT_AREA, LIGHT_DIRECTIONAL };

/* The area light: a square of half-size AREA_HALF at height AREA_Y facing down,
 * emitting white of film radiance AREA_LE. */
#define AREA_HALF 0.2
#define AREA_Y 2.0
#define AREA_LE 20.0
/* The spot: 100 cd at (0, 2, 0) pointing down, cones 0.3 and 0.35 rad. */
#define SPOT_Y 2.0
#define SPOT_I 100.0
#define SPOT_INNER 0.3
/* The directional light: 1000 lux straight down. */
#define DIR_E 1000.0

/* The floor (albedo 0.5, 4 x 4 m), the slab (3 x 3 m, clear smooth glass),
 * one light, and a camera under the slab's level looking at the floor's
 * centre from the side (so its rays never meet the glass). glass = 0 makes the
 * slab a Lambertian (a scene without delta surfaces). */
static inline void slab_scene(Scene *s, int light, int glass)
{
    memset(s, 0, sizeof *s);
    const float floor_c[4][3] = {{-2, 0, -2}, {-2, 0, 2}, {2, 0, 2}, {2, 0, -2}};
    SceneMaterial *fl = append_rect(s, floor_c);
    for (int k = 0; k < 3; k++)
        fl->base_color[k] = FLOOR_ALBEDO;
    const float lo[3] = {-1.5f, (float)SLAB_BOTTOM, -1.5f}, hi[3] = {1.5f, (float)SLAB_TOP, 1.5f};
    SceneMaterial *g = append_box(s, lo, hi);
    g->metallic = 0.0f;
    if (glass) {
        set_clear_glass(g, (float)SLAB_IOR);
    } else {
        g->specular = 0.0f;
        for (int k = 0; k < 3; k++)
            g->base_color[k] = 0.5f;
    }
    if (light == LIGHT_AREA) {
        const float h = (float)AREA_HALF, y = (float)AREA_Y;
        /* Counter-clockwise seen from below: the front faces down. */
        const float lc[4][3] = {{-h, y, -h}, {h, y, -h}, {h, y, h}, {-h, y, h}};
        SceneMaterial *lm = append_rect(s, lc);
        for (int k = 0; k < 3; k++) {
            lm->base_color[k] = 0.0f;
            lm->emissive[k] = 1.0f;
        }
        lm->emissive_strength = (float)AREA_LE;
    } else {
        s->light_count = 1;
        s->lights = calloc(1, sizeof(SceneLight));
        SceneLight *l = &s->lights[0];
        l->type = light == LIGHT_SPOT ? SPT_LIGHT_SPOT : SPT_LIGHT_DIRECTIONAL;
        l->position[1] = (float)SPOT_Y;
        l->direction[1] = -1.0f;
        l->intensity = light == LIGHT_SPOT ? (float)SPOT_I : (float)DIR_E;
        l->inner_cone = (float)SPOT_INNER;
        l->outer_cone = 0.35f;
        for (int k = 0; k < 3; k++)
            l->color[k] = 1.0f;
    }
    /* Camera at (0, 0.9, 2.5) toward the origin. */
    aim_camera(s, 0.9, 2.5, 0.9, 2.5, 0.55f);
}

/* The floor's irradiance at horizontal distance r from a point source of
 * intensity I(theta) = i0 cos(theta)^cos_pow whose rays cross air of total
 * height a and the slab; 0 beyond theta_max. */
static inline double slab_irradiance(double r, double a, double i0, int cos_pow, double theta_max)
{
    const double t = SLAB_TOP - SLAB_BOTTOM, n = SLAB_IOR;
    if (r < 1e-9) {
        double T = 1.0 - fresnel(1.0, n);
        return i0 * T * T / ((a + t / n) * (a + t / n));
    }
    double lo = 0.0, hi = 0.5 * M_PI - 1e-9;
    for (int k = 0; k < 100; k++) {
        double th = 0.5 * (lo + hi), st = sin(th) / n;
        double rr = a * tan(th) + t * st / sqrt(1.0 - st * st);
        if (rr < r)
            lo = th;
        else
            hi = th;
    }
    double th = 0.5 * (lo + hi);
    if (th > theta_max)
        return 0.0;
    double st = sin(th) / n, ct = sqrt(1.0 - st * st);
    double drdth = a / (cos(th) * cos(th)) + t * cos(th) / (n * ct * ct * ct);
    double T = 1.0 - fresnel(cos(th), n);
    return i0 * pow(cos(th), cos_pow) * T * T * sin(th) / (r * drdth);
}

/* The floor's expected film Y at (x, z) under light. */
static inline double expected_y(int light, double x, double z)
{
    double E = 0.0;
    const double air = SLAB_BOTTOM + (SPOT_Y - SLAB_TOP);
    if (light == LIGHT_SPOT) {
        E = slab_irradiance(sqrt(x * x + z * z), air, SPOT_I, 0, SPOT_INNER);
    } else if (light == LIGHT_DIRECTIONAL) {
        double T = 1.0 - fresnel(1.0, SLAB_IOR);
        E = DIR_E * T * T;
    } else {
        /* The square as a 48 x 48 grid of Lambertian sources. */
        enum { G = 48 };
        double cell = 2.0 * AREA_HALF / G;
        for (int i = 0; i < G; i++)
            for (int j = 0; j < G; j++) {
                double lx = -AREA_HALF + (i + 0.5) * cell, lz = -AREA_HALF + (j + 0.5) * cell;
                double r = sqrt((x - lx) * (x - lx) + (z - lz) * (z - lz));
                E += slab_irradiance(r, SLAB_BOTTOM + (AREA_Y - SLAB_TOP), AREA_LE * cell * cell, 1, M_PI);
            }
    }
    return FLOOR_ALBEDO / M_PI * E;
}

/* The floor's film Y against the analytic one over pixels within r_max of
 * the axis, in all and in three rings. */
typedef struct SlabRings {
    double got, want, ring_got[3], ring_want[3];
    int n, ring_n[3];
} SlabRings;

/* Adds a pixel whose floor point lies at r (< r_max): film Y y, analytic e. */
static inline void slab_rings_add(SlabRings *g, double r, double r_max, double y, double e)
{
    int ring = (int)(3.0 * r / r_max);
    g->got += y;
    g->want += e;
    g->ring_got[ring] += y;
    g->ring_want[ring] += e;
    g->ring_n[ring]++;
    g->n++;
}

/* Prints the means against the analytic ones and, with rel > 0, checks the
 * whole within rel and each ring that has pixels within 3 rel. */
static inline void slab_rings_check(const SlabRings *g, double rel, const char *what, const char *where)
{
    printf("%s: %s, %d pixels: mean Y %.5g, predicted %.5g (%+.2f%%); rings", what, where, g->n, g->got / g->n,
           g->want / g->n, 100.0 * (g->got / g->want - 1.0));
    for (int k = 0; k < 3; k++)
        printf(" %+.2f%% (%d)", 100.0 * (g->ring_got[k] / g->ring_want[k] - 1.0), g->ring_n[k]);
    printf("\n");
    if (rel > 0.0) {
        assert_close_rel(g->got, g->want, rel);
        for (int k = 0; k < 3; k++)
            if (g->ring_n[k])
                assert_close_rel(g->ring_got[k], g->ring_want[k], 3.0 * rel);
    }
}

#endif
