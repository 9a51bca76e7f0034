/* src/accel/tlas_build.c and kernels/bvh/bvh_tlas.h: a scene of instances
 * traced by reference (two levels) against the same scene flattened into
 * world-space triangles (one level), with a double-precision check of every
 * ray where the two disagree; the GPU path's short stacks (with restarts at
 * both levels) against the CPU path; normals through the inverse transpose
 * and mirrored instances; the device against the host. */
#include "test_cl_util.h"

#include <float.h>
#include <stdlib.h>
#include <string.h>

#include "accel/tlas_build.h"
#include "scene/scene.h"
#include "ref_triangle.h"

static uint64_t rng_state = 1;
static double rnd(void) { return bvh_gen_uniform(&rng_state); }
static double rnd_range(double a, double b) { return a + (b - a) * rnd(); }

/* A scene of instances of two meshes and the same scene flattened. */
typedef struct InstScene {
    float *mesh_tris[2];
    uint32_t mesh_n[2];
    Bvh mesh[2];
    uint32_t prim_base[2];
    uint32_t ninst;
    float *xf;           /* 12 per instance */
    uint32_t *inst_mesh;
    Tlas tlas;
    float *flat_tris;    /* every instance's triangles placed, in double, rounded */
    uint32_t flat_n;
    uint32_t *flat_inst, *flat_prim; /* per flat triangle: instance, mesh triangle */
    Bvh flat;
} InstScene;

/* Row r of instance i's transform applied to p (w 1: a point) in double. */
static double xf_row(const float *m, int r, const double p[3], double w)
{
    return (double)m[4 * r] * p[0] + (double)m[4 * r + 1] * p[1] + (double)m[4 * r + 2] * p[2] +
           (double)m[4 * r + 3] * w;
}

/* A random rotation (a uniform unit quaternion) times per-axis scales in
 * [0.3, 1.5], a third of the instances with one of them negative (mirrored),
 * and a translation in [-span, span]^3. */
static void random_xf(float *m, double span)
{
    double q[4], n = 0.0;
    do {
        n = 0.0;
        for (int k = 0; k < 4; k++) {
            q[k] = rnd_range(-1, 1);
            n += q[k] * q[k];
        }
    } while (n > 1.0 || n < 1e-3);
    n = sqrt(n);
    double x = q[0] / n, y = q[1] / n, z = q[2] / n, w = q[3] / n;
    double r[9] = {1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y),
                   2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
                   2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)};
    double s[3] = {rnd_range(0.3, 1.5), rnd_range(0.3, 1.5), rnd_range(0.3, 1.5)};
    if (rnd() < 1.0 / 3.0)
        s[(int)(rnd() * 3.0) % 3] *= -1.0;
    for (int row = 0; row < 3; row++) {
        for (int c = 0; c < 3; c++)
            m[4 * row + c] = (float)(r[3 * row + c] * s[c]);
        m[4 * row + 3] = (float)rnd_range(-span, span);
    }
}

static void iscene_make(InstScene *s, uint32_t ninst, double span)
{
    memset(s, 0, sizeof *s);
    const float c0[3] = {0, 0, 0}, c1[3] = {0.3f, -0.2f, 0.1f};
    s->mesh_tris[0] = bvh_gen_sphere(16, 32, 1.0f, c0, 0.3f, &s->mesh_n[0]);
    s->mesh_tris[1] = bvh_gen_sphere(6, 11, 0.7f, c1, -0.4f, &s->mesh_n[1]);
    for (int m = 0; m < 2; m++)
        assert_int_equal(bvh_build(&s->mesh[m], s->mesh_tris[m], s->mesh_n[m], NULL), 0);
    s->prim_base[0] = 0;
    s->prim_base[1] = s->mesh_n[0];
    s->ninst = ninst;
    s->xf = malloc((size_t)ninst * 12 * sizeof *s->xf);
    s->inst_mesh = malloc((size_t)ninst * sizeof *s->inst_mesh);
    s->flat_n = 0;
    for (uint32_t i = 0; i < ninst; i++) {
        random_xf(s->xf + 12 * i, span);
        s->inst_mesh[i] = rnd() < 0.7 ? 0 : 1;
        s->flat_n += s->mesh_n[s->inst_mesh[i]];
    }
    assert_int_equal(tlas_build(&s->tlas, s->mesh, s->prim_base, 2, s->xf, s->inst_mesh, ninst, NULL),
                     0);
    s->flat_tris = malloc((size_t)s->flat_n * 9 * sizeof *s->flat_tris);
    s->flat_inst = malloc((size_t)s->flat_n * sizeof *s->flat_inst);
    s->flat_prim = malloc((size_t)s->flat_n * sizeof *s->flat_prim);
    uint32_t k = 0;
    for (uint32_t i = 0; i < ninst; i++) {
        uint32_t m = s->inst_mesh[i];
        for (uint32_t t = 0; t < s->mesh_n[m]; t++, k++) {
            for (int c = 0; c < 3; c++) {
                const float *v = s->mesh_tris[m] + 9 * (size_t)t + 3 * c;
                double p[3] = {v[0], v[1], v[2]};
                for (int r = 0; r < 3; r++)
                    s->flat_tris[9 * (size_t)k + 3 * c + r] = (float)xf_row(s->xf + 12 * i, r, p, 1.0);
            }
            s->flat_inst[k] = i;
            s->flat_prim[k] = t;
        }
    }
    assert_int_equal(bvh_build(&s->flat, s->flat_tris, s->flat_n, NULL), 0);
}

static void iscene_free(InstScene *s)
{
    for (int m = 0; m < 2; m++) {
        free(s->mesh_tris[m]);
        bvh_free(&s->mesh[m]);
    }
    tlas_free(&s->tlas);
    bvh_free(&s->flat);
    free(s->xf);
    free(s->inst_mesh);
    free(s->flat_tris);
    free(s->flat_inst);
    free(s->flat_prim);
}

/* A two-level hit as (input instance, mesh input triangle). */
static void inst_hit_ids(const InstScene *s, const BvhInstHit *h, uint32_t *inst, uint32_t *prim)
{
    *inst = s->tlas.inst_index[h->inst];
    uint32_t m = s->inst_mesh[*inst];
    assert_true(h->h.prim >= s->prim_base[m] && h->h.prim - s->prim_base[m] < s->mesh[m].prim_count);
    *prim = s->mesh[m].prim_index[h->h.prim - s->prim_base[m]];
}

/* ref_tri_d on mesh triangle prim of instance inst, its vertices placed in
 * double: 1 when hit with t > 0 (barycentrics down to -1); *t and *margin
 * (the smallest barycentric) filled. */
static int ref_hit(const InstScene *s, uint32_t inst, uint32_t prim, const double o[3],
                   const double d[3], double *t, double *margin)
{
    double v[9];
    const float *src = s->mesh_tris[s->inst_mesh[inst]] + 9 * (size_t)prim;
    for (int c = 0; c < 3; c++) {
        double p[3] = {src[3 * c], src[3 * c + 1], src[3 * c + 2]};
        for (int r = 0; r < 3; r++)
            v[3 * c + r] = xf_row(s->xf + 12 * inst, r, p, 1.0);
    }
    return ref_tri_d(v, o, d, 1.0, t, margin);
}

/* nr rays: from random points of the scene's cube toward random instances'
 * origins (jittered), so most hit; 6 floats each. */
static float *make_rays(const InstScene *s, int nr, double span)
{
    float *rays = malloc((size_t)nr * 6 * sizeof *rays);
    for (int i = 0; i < nr; i++) {
        const float *m = s->xf + 12 * (size_t)(rnd() * s->ninst);
        for (int a = 0; a < 3; a++) {
            double o = rnd_range(-1.3 * span, 1.3 * span);
            rays[6 * i + a] = (float)o;
            rays[6 * i + 3 + a] = (float)(m[4 * a + 3] + rnd_range(-1.2, 1.2) - o);
        }
    }
    return rays;
}

/* Where the two levels and the flattened scene find different closest hits
 * (another triangle, or a hit against a miss), the double-precision
 * intersection must say the ray is ambiguous at float rounding: both
 * triangles hit (margins >= -tol) at distances within tol, or the hit one
 * grazed (margin < tol). Returns 1 for such a ray, fails otherwise. */
static int check_ambiguous(const InstScene *s, int i, const float *ray, int hi, uint32_t ii, uint32_t ip,
                           int hf, uint32_t fi, uint32_t fp)
{
    const double tol = 1e-4;
    double o[3] = {ray[0], ray[1], ray[2]}, d[3] = {ray[3], ray[4], ray[5]};
    double ti = 0, mi = -1, tf = 0, mf = -1;
    int ri = hi && ref_hit(s, ii, ip, o, d, &ti, &mi);
    int rf = hf && ref_hit(s, fi, fp, o, d, &tf, &mf);
    if (hi && hf && ri && rf && mi >= -tol && mf >= -tol && fabs(ti - tf) <= tol * (1.0 + tf))
        return 1;
    if (hi != hf && (hi ? ri && mi < tol : rf && mf < tol))
        return 1;
    fail_msg("ray %d: two levels %s (instance %u, triangle %u, t %.9g margin %.3g), flattened %s "
             "(instance %u, triangle %u, t %.9g margin %.3g)",
             i, hi ? "hit" : "miss", ii, ip, ti, mi, hf ? "hit" : "miss", fi, fp, tf, mf);
    return 0;
}

/* The two levels (the CPU path: top-level stack of 8, a mesh's full stack;
 * and every top-level stack size down to 1, which restarts often, bit for
 * bit the same) against the flattened scene: the same triangle at the same
 * distance up to float rounding, or a ray the double reference calls
 * ambiguous; shadow queries agree with the closest hits. */
TEST(test_instanced_matches_flattened)
{
    rng_state = 38;
    const double span = 12.0;
    InstScene s;
    iscene_make(&s, 300, span);
    assert_int_equal(s.tlas.inst_count, 300);
    assert_int_equal(s.tlas.stats.instanced_tris, s.flat_n);
    assert_int_equal(s.tlas.stats.unique_tris, s.mesh_n[0] + s.mesh_n[1]);
    int nr = 20000, hits = 0, ambiguous = 0;
    float *rays = make_rays(&s, nr, span);
    for (int i = 0; i < nr; i++) {
        const float *ray = rays + 6 * i;
        vec3 o = v3(ray[0], ray[1], ray[2]), d = v3(ray[3], ray[4], ray[5]);
        BvhInstHit hi;
        BvhHit hf;
        int fi = bvh_tlas_intersect(s.tlas.top, s.tlas.inst, s.tlas.nodes, s.tlas.tris, o, d, 1e30f, &hi);
        int ff = bvh_intersect(s.flat.nodes, s.flat.tri_data, o, d, 1e30f, &hf);
        for (int cap = 1; cap < BVH_SHORT_STACK_SIZE; cap++) {
            BvhInstHit hc;
            int fc = bvh_tlas_traverse_cap(s.tlas.top, s.tlas.inst, s.tlas.nodes, s.tlas.tris, o, d,
                                           1e30f, 0, cap, &hc);
            assert_int_equal(fc, fi);
            if (fc) {
                assert_true(hc.h.t == hi.h.t && hc.h.u == hi.h.u && hc.h.v == hi.h.v);
                assert_int_equal(hc.h.prim, hi.h.prim);
                assert_int_equal(hc.inst, hi.inst);
            }
        }
        uint32_t ii = 0, ip = 0, ffi = 0, ffp = 0;
        if (fi)
            inst_hit_ids(&s, &hi, &ii, &ip);
        if (ff) {
            uint32_t k = s.flat.prim_index[hf.prim];
            ffi = s.flat_inst[k];
            ffp = s.flat_prim[k];
        }
        hits += fi;
        if (fi != ff || (fi && (ii != ffi || ip != ffp)))
            ambiguous += check_ambiguous(&s, i, ray, fi, ii, ip, ff, ffi, ffp);
        else if (fi)
            assert_true(fabsf(hi.h.t - hf.t) <= 1e-4f * (1.0f + hf.t));
        int occ = bvh_tlas_occluded(s.tlas.top, s.tlas.inst, s.tlas.nodes, s.tlas.tris, o, d, 1e30f);
        assert_int_equal(occ, fi);
        if (fi) {
            /* Nothing nearer than the closest hit; something within 1%. */
            assert_false(bvh_tlas_occluded(s.tlas.top, s.tlas.inst, s.tlas.nodes, s.tlas.tris, o, d,
                                           hi.h.t * 0.99f));
            assert_true(bvh_tlas_occluded(s.tlas.top, s.tlas.inst, s.tlas.nodes, s.tlas.tris, o, d,
                                          hi.h.t * 1.01f));
        }
    }
    print_message("%d rays, %d hits, %d ambiguous at float rounding\n", nr, hits, ambiguous);
    assert_true(hits > nr / 2);
    assert_true(ambiguous <= nr / 200);
    free(rays);
    iscene_free(&s);
}

/* A hit's normal through the inverse transpose is the flattened triangle's
 * geometric normal, reversed for a mirrored instance (whose winding the
 * transform reverses), and the flag is set exactly for those. */
TEST(test_instance_normals_and_mirroring)
{
    rng_state = 39;
    InstScene s;
    iscene_make(&s, 60, 6.0);
    int mirrored = 0;
    for (uint32_t k = 0; k < s.tlas.inst_count; k++) {
        const BvhInstance *in = &s.tlas.inst[k];
        uint32_t i = s.tlas.inst_index[k];
        const float *m = s.xf + 12 * i;
        double det = (double)m[0] * ((double)m[5] * m[10] - (double)m[6] * m[9]) -
                     (double)m[1] * ((double)m[4] * m[10] - (double)m[6] * m[8]) +
                     (double)m[2] * ((double)m[4] * m[9] - (double)m[5] * m[8]);
        assert_int_equal(!!(in->flags & BVH_INSTANCE_MIRRORED), det < 0.0);
        mirrored += det < 0.0;
        uint32_t mesh = s.inst_mesh[i];
        for (uint32_t t = 0; t < s.mesh_n[mesh]; t += 7) {
            const float *p = s.mesh_tris[mesh] + 9 * (size_t)t;
            vec3 e1 = v3(p[3] - p[0], p[4] - p[1], p[5] - p[2]);
            vec3 e2 = v3(p[6] - p[0], p[7] - p[1], p[8] - p[2]);
            vec3 n = bvh_xf_normal(in, v3(e1.y * e2.z - e1.z * e2.y, e1.z * e2.x - e1.x * e2.z,
                                          e1.x * e2.y - e1.y * e2.x));
            if (in->flags & BVH_INSTANCE_MIRRORED)
                n = v3(-n.x, -n.y, -n.z);
            /* the flattened triangle's normal, from its placed vertices */
            double w[3][3];
            for (int c = 0; c < 3; c++) {
                double q[3] = {p[3 * c], p[3 * c + 1], p[3 * c + 2]};
                for (int r = 0; r < 3; r++)
                    w[c][r] = xf_row(m, r, q, 1.0);
            }
            double a[3], b[3], fn[3];
            for (int r = 0; r < 3; r++) {
                a[r] = w[1][r] - w[0][r];
                b[r] = w[2][r] - w[0][r];
            }
            fn[0] = a[1] * b[2] - a[2] * b[1];
            fn[1] = a[2] * b[0] - a[0] * b[2];
            fn[2] = a[0] * b[1] - a[1] * b[0];
            double ln = sqrt((double)n.x * n.x + (double)n.y * n.y + (double)n.z * n.z);
            double lf = sqrt(fn[0] * fn[0] + fn[1] * fn[1] + fn[2] * fn[2]);
            double cosang = (n.x * fn[0] + n.y * fn[1] + n.z * fn[2]) / (ln * lf);
            assert_true(cosang > 0.99999);
        }
    }
    assert_true(mirrored > 5 && mirrored < 55);
    iscene_free(&s);
}

/* No instances, and instances that cannot be inverted (a zero scale, a NaN),
 * which are dropped: every ray misses, and the rest still hit. */
TEST(test_empty_and_singular_instances)
{
    uint32_t n;
    const float c[3] = {0, 0, 0};
    float *t = bvh_gen_sphere(4, 8, 1.0f, c, 0.0f, &n);
    Bvh mesh;
    assert_int_equal(bvh_build(&mesh, t, n, NULL), 0);
    const float xf[3][12] = {{1, 0, 0, 5, 0, 1, 0, 0, 0, 0, 1, 0},
                             {1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 1, 0},
                             {1, 0, 0, 0, 0, 1, 0, NAN, 0, 0, 1, 0}};
    const uint32_t which[3] = {0, 0, 0};
    for (uint32_t count = 0; count <= 3; count += 3) {
        Tlas tl;
        assert_int_equal(tlas_build(&tl, &mesh, NULL, 1, &xf[0][0], which, count, NULL), 0);
        assert_int_equal(tl.inst_count, count ? 1 : 0);
        assert_int_equal(tl.stats.dropped, count ? 2 : 0);
        BvhInstHit h;
        /* through the origin, where the dropped ones would be */
        assert_false(bvh_tlas_intersect(tl.top, tl.inst, tl.nodes, tl.tris, v3(0, 0, -5), v3(0, 0, 1),
                                        1e30f, &h));
        /* through instance 0 at x = 5 */
        assert_int_equal(bvh_tlas_intersect(tl.top, tl.inst, tl.nodes, tl.tris, v3(5, 0, -5),
                                            v3(0, 0, 1), 1e30f, &h),
                         count ? 1 : 0);
        if (count)
            assert_close(h.h.t, 4.0f, 1e-5);
        tlas_free(&tl);
    }
    SptError e = {0};
    Tlas tl;
    const uint32_t bad = 1;
    assert_int_equal(tlas_build(&tl, &mesh, NULL, 1, &xf[0][0], &bad, 1, &e), SPT_EXIT_INPUT);
    bvh_free(&mesh);
    free(t);
}

/* Instances of a cube placed by scales and translations alone, so its faces
 * lie on the planes of their world-space boxes, where the rounding of the
 * box and of the ray's transform meet: every ray aimed at a face hits it,
 * as it does in the flattened scene. */
TEST(test_faces_on_instance_boxes)
{
    rng_state = 41;
    float cube[12 * 9];
    uint32_t nt = 0;
    for (int a = 0; a < 3; a++)
        for (int side = 0; side < 2; side++) {
            /* face of axis a at coordinate side (0 or 1): two triangles */
            int b = (a + 1) % 3, c = (a + 2) % 3;
            const float uv[6][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 0}, {1, 1}, {0, 1}};
            for (int k = 0; k < 6; k++) {
                float *v = cube + 9 * nt + 3 * (k % 3);
                v[a] = (float)side;
                v[b] = uv[k][0];
                v[c] = uv[k][1];
                if (k % 3 == 2)
                    nt++;
            }
        }
    Bvh mesh;
    assert_int_equal(bvh_build(&mesh, cube, nt, NULL), 0);
    const uint32_t ninst = 200;
    float *xf = calloc((size_t)ninst * 12, sizeof *xf);
    uint32_t *which = calloc(ninst, sizeof *which);
    for (uint32_t i = 0; i < ninst; i++)
        for (int r = 0; r < 3; r++) {
            xf[12 * i + 5 * r] = (float)(rnd_range(0.01, 3.0) * (rnd() < 0.3 ? -1 : 1));
            xf[12 * i + 4 * r + 3] = (float)rnd_range(-1000, 1000);
        }
    Tlas tl;
    assert_int_equal(tlas_build(&tl, &mesh, NULL, 1, xf, which, ninst, NULL), 0);
    int tested = 0;
    for (uint32_t i = 0; i < ninst; i++) {
        const float *m = xf + 12 * i;
        for (int k = 0; k < 50; k++) {
            /* a point of a random face, a third of the time on an edge or
             * a corner of it, and a ray toward it from outside the cube
             * heading into it (in the cube's space, then placed) */
            int a = (int)(rnd() * 3) % 3, side = rnd() < 0.5;
            double p[3], w[3], dir[3], dobj[3];
            for (int r = 0; r < 3; r++) {
                double pick = rnd();
                p[r] = r == a ? side : pick < 1.0 / 6 ? 0.0 : pick < 1.0 / 3 ? 1.0 : rnd_range(0.05, 0.95);
                dobj[r] = r == a ? (side ? -1.0 : 1.0) * rnd_range(0.5, 1.0)
                          : p[r] == 0.0 ? rnd_range(0.05, 0.3)
                          : p[r] == 1.0 ? -rnd_range(0.05, 0.3)
                                        : rnd_range(-0.3, 0.3);
            }
            for (int r = 0; r < 3; r++) {
                w[r] = xf_row(m, r, p, 1.0);
                dir[r] = xf_row(m, r, dobj, 0.0);
            }
            vec3 o = v3((float)(w[0] - 4.0 * dir[0]), (float)(w[1] - 4.0 * dir[1]),
                        (float)(w[2] - 4.0 * dir[2]));
            vec3 d = v3((float)dir[0], (float)dir[1], (float)dir[2]);
            BvhInstHit h;
            /* the nearest hit is this instance's face (instances may overlap:
             * then any hit no farther than this face will do) */
            assert_true(bvh_tlas_intersect(tl.top, tl.inst, tl.nodes, tl.tris, o, d, 1e30f, &h));
            /* 4 up to the float origin's rounding; the ray crosses the
             * cube in at least 1 of t (its direction has |component| <= 1
             * in the cube's space, where t is the same), so the far side
             * lies beyond 5 */
            if (!(h.h.t <= 4.5f))
                fail_msg("instance %u ray %d: t %.9g, not 4", i, k, h.h.t);
            tested++;
        }
    }
    assert_int_equal(tested, 50 * (int)ninst);
    tlas_free(&tl);
    bvh_free(&mesh);
    free(xf);
    free(which);
}

/* The light selection's per-instance power: each instance's emitting
 * triangles' world areas times their weights, against the flattened scene's
 * triangles summed per instance (their placed float vertices, in double). */
TEST(test_emitter_power_per_instance)
{
    rng_state = 42;
    InstScene s;
    iscene_make(&s, 80, 8.0);
    /* mesh 0: every third triangle emits with weight 1 + t % 5; mesh 1: none */
    float *w0 = malloc(s.mesh_n[0] * sizeof *w0);
    for (uint32_t t = 0; t < s.mesh_n[0]; t++)
        w0[t] = t % 3 ? 0.0f : (float)(1 + t % 5);
    const float *weight[2] = {w0, NULL};
    double *power = malloc(s.tlas.inst_count * sizeof *power);
    tlas_emitter_power(&s.tlas, s.mesh, weight, power);
    double *want = calloc(s.ninst, sizeof *want);
    for (uint32_t k = 0; k < s.flat_n; k++) {
        uint32_t i = s.flat_inst[k], t = s.flat_prim[k];
        if (s.inst_mesh[i] != 0 || w0[t] == 0.0f)
            continue;
        const float *p = s.flat_tris + 9 * (size_t)k;
        double e1[3], e2[3];
        for (int r = 0; r < 3; r++) {
            e1[r] = (double)p[3 + r] - p[r];
            e2[r] = (double)p[6 + r] - p[r];
        }
        double cx = e1[1] * e2[2] - e1[2] * e2[1], cy = e1[2] * e2[0] - e1[0] * e2[2],
               cz = e1[0] * e2[1] - e1[1] * e2[0];
        want[i] += w0[t] * 0.5 * sqrt(cx * cx + cy * cy + cz * cz);
    }
    int emitting = 0;
    for (uint32_t k = 0; k < s.tlas.inst_count; k++) {
        uint32_t i = s.tlas.inst_index[k];
        assert_int_equal(s.tlas.inst_mesh[k], s.inst_mesh[i]);
        assert_close_rel(power[k], want[i], 1e-5);
        emitting += power[k] > 0.0;
    }
    assert_true(emitting > 20 && emitting < 80);
    free(want);
    free(power);
    free(w0);
    iscene_free(&s);
}

/* Writes a glTF of one triangle, (0,0,0) (1,0,0) (0,1,0), on node 0 with
 * EXT_mesh_gpu_instancing (scale_count SCALE elements; rotation_normalized 0
 * makes ROTATION's shorts unnormalised, which the extension forbids) under
 * node 1 (scale 2), and on node 2 plainly; loads it into s (instancing:
 * ScenePose.instancing). */
static int load_gpu_instances(Scene *s, int scale_count, int rotation_normalized, int instancing,
                              SptError *e)
{
    unsigned char bin[132];
    const float pos[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    const float tr[9] = {10, 0, 0, 0, 5, 0, 0, 0, -3};
    /* 90 degrees about z; the identity; 180 degrees about x */
    const int16_t rot[12] = {0, 0, 23170, 23170, 0, 0, 0, 32767, 32767, 0, 0, 0};
    const float sc[9] = {2, 1, 1, 1, 1, 1, 1, -1, 1};
    memcpy(bin, pos, 36);
    memcpy(bin + 36, tr, 36);
    memcpy(bin + 72, rot, 24);
    memcpy(bin + 96, sc, 36);
    char path[160], json[4096];
    snprintf(path, sizeof path, "%s/inst.bin", test_dir());
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(bin, 1, sizeof bin, f), sizeof bin);
    fclose(f);
    snprintf(json, sizeof json,
             "{\"asset\":{\"version\":\"2.0\"},\"extensionsUsed\":[\"EXT_mesh_gpu_instancing\"],"
             "\"extensionsRequired\":[\"EXT_mesh_gpu_instancing\"],"
             "\"scene\":0,\"scenes\":[{\"nodes\":[1,2]}],"
             "\"nodes\":[{\"mesh\":0,\"translation\":[0,0,1],\"extensions\":{\"EXT_mesh_gpu_instancing\":"
             "{\"attributes\":{\"TRANSLATION\":1,\"ROTATION\":2,\"SCALE\":3}}}},"
             "{\"scale\":[2,2,2],\"children\":[0]},{\"mesh\":0,\"translation\":[0,0,40]}],"
             "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0}}]}],"
             "\"buffers\":[{\"byteLength\":132,\"uri\":\"inst.bin\"}],"
             "\"bufferViews\":[{\"buffer\":0,\"byteOffset\":0,\"byteLength\":36},"
             "{\"buffer\":0,\"byteOffset\":36,\"byteLength\":36},"
             "{\"buffer\":0,\"byteOffset\":72,\"byteLength\":24},"
             "{\"buffer\":0,\"byteOffset\":96,\"byteLength\":36}],"
             "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\","
             "\"min\":[0,0,0],\"max\":[1,1,0]},"
             "{\"bufferView\":1,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\"},"
             "{\"bufferView\":2,\"componentType\":5122,\"normalized\":%s,\"count\":3,\"type\":\"VEC4\"},"
             "{\"bufferView\":3,\"componentType\":5126,\"count\":%d,\"type\":\"VEC3\"}]}",
             rotation_normalized ? "true" : "false", scale_count);
    snprintf(path, sizeof path, "%s/inst.gltf", test_dir());
    f = fopen(path, "w");
    assert_non_null(f);
    fputs(json, f);
    fclose(f);
    return scene_load_gltf_posed(s, path, &(ScenePose){NAN, NULL, NULL, instancing}, e);
}

/* Vertex k of triangle t is (x, y, z) within 1e-4 (the rotation's shorts). */
static void assert_vertex_near(const Scene *s, uint32_t t, int k, double x, double y, double z)
{
    const float *p = &s->tri_pos[t * 9 + k * 3];
    if (fabs(p[0] - x) > 1e-4 || fabs(p[1] - y) > 1e-4 || fabs(p[2] - z) > 1e-4)
        fail_msg("triangle %u vertex %d is (%g, %g, %g), expected (%g, %g, %g)", t, k, p[0], p[1],
                 p[2], x, y, z);
}

/* EXT_mesh_gpu_instancing: each element's T R S (rotations as normalised
 * shorts) in the node's space, under its parent's transform; a mirrored
 * instance keeps counter-clockwise front faces; a plain node sharing the
 * mesh adds its own copy. Vertices computed by hand: world = S2 T(0,0,1)
 * T_i R_i S_i. */
TEST(test_gltf_gpu_instancing)
{
    Scene s;
    SptError e = {0};
    if (load_gpu_instances(&s, 3, 1, SCENE_INSTANCING_OFF, &e))
        fail_msg("%s", e.msg);
    assert_int_equal(s.tri_count, 4);
    assert_int_equal(s.stats.instances, 4);
    /* 0: scale x 2, 90 degrees about z, (10, 0, 0): (x, y) -> (10 - y, 2 x) */
    assert_vertex_near(&s, 0, 0, 20, 0, 2);
    assert_vertex_near(&s, 0, 1, 20, 4, 2);
    assert_vertex_near(&s, 0, 2, 18, 0, 2);
    /* 1: (0, 5, 0) */
    assert_vertex_near(&s, 1, 0, 0, 10, 2);
    assert_vertex_near(&s, 1, 1, 2, 10, 2);
    assert_vertex_near(&s, 1, 2, 0, 12, 2);
    /* 2: scale y -1 then 180 degrees about x: z mirrored, at z -3: the
     * winding swapped (vertices 1 and 2) */
    assert_vertex_near(&s, 2, 0, 0, 0, -4);
    assert_vertex_near(&s, 2, 1, 0, 2, -4);
    assert_vertex_near(&s, 2, 2, 2, 0, -4);
    /* node 2, the same mesh plainly */
    assert_vertex_near(&s, 3, 0, 0, 0, 40);
    assert_vertex_near(&s, 3, 1, 1, 0, 40);
    /* By reference (the default): the triangle once, and instance k's
     * transform places it where the flattened triangle k lies (the
     * triangle's vertices in the flattened winding: mirrored ones swapped). */
    Scene r;
    if (load_gpu_instances(&r, 3, 1, SCENE_INSTANCING_AUTO, &e))
        fail_msg("%s", e.msg);
    assert_int_equal(r.tri_count, 1);
    assert_int_equal(r.mesh_count, 1);
    assert_int_equal(r.inst_count, 4);
    assert_int_equal(r.stats.instances, 4);
    for (uint32_t k = 0; k < 4; k++) {
        const float *x = r.inst_xf + 12 * k;
        double det = x[0] * (x[5] * x[10] - x[6] * x[9]) - x[1] * (x[4] * x[10] - x[6] * x[8]) +
                     x[2] * (x[4] * x[9] - x[5] * x[8]);
        for (int v = 0; v < 3; v++) {
            int src = det < 0 && v ? 3 - v : v;
            const float *p = r.tri_pos + 3 * src;
            double w[3];
            for (int i = 0; i < 3; i++)
                w[i] = x[4 * i] * p[0] + x[4 * i + 1] * p[1] + x[4 * i + 2] * p[2] + x[4 * i + 3];
            assert_vertex_near(&s, k, v, w[0], w[1], w[2]);
        }
    }
    scene_free(&r);
    scene_free(&s);
    /* attributes of different counts, unnormalised short rotations: refused,
     * naming the node and the attribute */
    assert_int_equal(load_gpu_instances(&s, 2, 1, SCENE_INSTANCING_AUTO, &e), SPT_EXIT_INPUT);
    assert_non_null(strstr(e.msg, "nodes[0].extensions.EXT_mesh_gpu_instancing.attributes.SCALE"));
    assert_int_equal(load_gpu_instances(&s, 3, 0, SCENE_INSTANCING_AUTO, &e), SPT_EXIT_INPUT);
    assert_non_null(strstr(e.msg, "attributes.ROTATION"));
}

/* The two-level queries compiled by the OpenCL device from kernels/, on the
 * CPU path (with the x86 leaf tests where the device has them) and the GPU
 * path (SPT_BVH_SHORT_STACK; with 2 entries too, which restarts at both
 * levels), on float and on quantised nodes (SPT_BVH_QNODES), return the
 * host's hits bit for bit. */
static const char *k_device_src =
    "#include \"bvh/bvh_tlas.h\"\n"
    "__kernel void k_tlas_test(__global const BvhNode *top, __global const BvhInstance *inst,\n"
    "                          __global const BvhNode *nodes, __global const float *tris,\n"
    "                          __global const float *rays, __global float *out, int n)\n"
    "{\n"
    "    int i = get_global_id(0);\n"
    "    if (i >= n) return;\n"
    "    __global const float *ray = rays + 6 * i;\n"
    "    vec3 o = v3(ray[0], ray[1], ray[2]), d = v3(ray[3], ray[4], ray[5]);\n"
    "    BvhInstHit h;\n"
    "    int hit = bvh_tlas_intersect(top, inst, nodes, tris, o, d, 1e30f, &h);\n"
    "    out[i * 5] = hit ? h.h.t : -1.0f;\n"
    "    out[i * 5 + 1] = hit ? (float)h.h.prim : -1.0f;\n"
    "    out[i * 5 + 2] = hit ? (float)h.inst : -1.0f;\n"
    "    out[i * 5 + 3] = (float)bvh_tlas_occluded(top, inst, nodes, tris, o, d, 1e30f);\n"
    "    out[i * 5 + 4] = (float)sizeof(BvhInstance);\n"
    "}\n";

TEST(test_tlas_device_matches_host)
{
    TestCl cl = test_cl_open();
    rng_state = 40;
    const double span = 12.0;
    InstScene s;
    iscene_make(&s, 300, span);
    int nr = 8000;
    float *rays = make_rays(&s, nr, span);
    float *out = malloc((size_t)nr * 5 * sizeof *out);
    /* the same levels with quantised nodes (SPT_BVH_QNODES) */
    BvhQNode *qtop = bvh_quantise_nodes(s.tlas.top, s.tlas.top_count);
    BvhQNode *qnodes = bvh_quantise_nodes(s.tlas.nodes, s.tlas.node_count);
    const char *options[8] = {NULL, "-DSPT_BVH_SIMD=1", "-DSPT_BVH_SHORT_STACK=1",
                              "-DSPT_BVH_SHORT_STACK=1 -DBVH_SHORT_STACK_SIZE=2",
                              "-DSPT_BVH_QNODES=1", "-DSPT_BVH_QNODES=1 -DSPT_BVH_SIMD=1",
                              "-DSPT_BVH_QNODES=1 -DSPT_BVH_SHORT_STACK=1",
                              "-DSPT_BVH_QNODES=1 -DSPT_BVH_SHORT_STACK=1 -DBVH_SHORT_STACK_SIZE=2"};
    for (int k = 0; k < 8; k++) {
        int q = k >= 4;
        const TestClArg args[5] = {
            {q ? (const void *)qtop : s.tlas.top, s.tlas.top_count * (q ? sizeof(BvhQNode) : sizeof(BvhNode))},
            {s.tlas.inst, s.tlas.inst_count * sizeof(BvhInstance)},
            {q ? (const void *)qnodes : s.tlas.nodes,
             s.tlas.node_count * (q ? sizeof(BvhQNode) : sizeof(BvhNode))},
            {s.tlas.tris, s.tlas.tri_words * sizeof(float)},
            {rays, (size_t)nr * 6 * sizeof *rays}};
        test_cl_run(&cl, k_device_src, options[k], "kernels/bvh/bvh_tlas.h", "k_tlas_test", args, 5, out,
                    (size_t)nr * 5 * sizeof *out, nr, 64);
        assert_close(out[4], sizeof(BvhInstance), 0);
        int differ = 0, hits = 0;
        for (int i = 0; i < nr; i++) {
            const float *ray = rays + 6 * i;
            vec3 o = v3(ray[0], ray[1], ray[2]), d = v3(ray[3], ray[4], ray[5]);
            BvhInstHit h;
            int hit = bvh_tlas_intersect(s.tlas.top, s.tlas.inst, s.tlas.nodes, s.tlas.tris, o, d,
                                         1e30f, &h);
            int occ = bvh_tlas_occluded(s.tlas.top, s.tlas.inst, s.tlas.nodes, s.tlas.tris, o, d, 1e30f);
            hits += hit;
            const float *g = out + 5 * i;
            if (g[0] != (hit ? h.h.t : -1.0f) || g[1] != (hit ? (float)h.h.prim : -1.0f) ||
                g[2] != (hit ? (float)h.inst : -1.0f) || g[3] != (float)occ) {
                if (differ++ < 5)
                    print_message("%s: ray %d: device t=%.9g prim=%g inst=%g occ=%g, host t=%.9g "
                                  "prim=%d inst=%d occ=%d\n",
                                  options[k] ? options[k] : "-", i, g[0], g[1], g[2], g[3],
                                  hit ? h.h.t : -1.0f, hit ? (int)h.h.prim : -1,
                                  hit ? (int)h.inst : -1, occ);
            }
        }
        assert_int_equal(differ, 0);
        assert_true(hits > nr / 2);
    }
    free(qtop);
    free(qnodes);
    free(out);
    free(rays);
    iscene_free(&s);
    test_cl_close(&cl);
}

TEST_MAIN("instancing", test_dir_setup, test_dir_teardown)
