/* src/accel/bvh_build.c and kernels/bvh/bvh.h: tree structure, closest and any hit against an
 * independent double-precision brute force, watertightness, garbage input. */
#include "test_cl_util.h"

#include <float.h>
#include <stdlib.h>
#include <string.h>

#include "accel/bvh_build.h"
#include "ref_triangle.h"

/* The test data's random numbers (bvh_gen_uniform), reseeded by each test. */
static uint64_t rng_state = 1;
static double rnd(void) { return bvh_gen_uniform(&rng_state); }
static double rnd_range(double a, double b) { return a + (b - a) * rnd(); }

static void rnd_dir(double d[3])
{
    double z = rnd_range(-1, 1), phi = rnd_range(0, 2 * M_PI), s = sqrt(1 - z * z);
    d[0] = s * cos(phi);
    d[1] = s * sin(phi);
    d[2] = z;
}

/* ref_tri_d on the float triangle p (9 floats). */
static int ref_tri(const float *p, const double o[3], const double d[3], double eps, double *t,
                   double *margin)
{
    double v[9];
    for (int k = 0; k < 9; k++)
        v[k] = p[k];
    return ref_tri_d(v, o, d, eps, t, margin);
}

typedef struct RefHit {
    int hit;
    double t, margin;
    uint32_t id;
} RefHit;

/* Closest hit over every triangle whose keep[] flag is set (all when NULL). */
static RefHit ref_closest(const float *tris, uint32_t n, const unsigned char *keep,
                          const double o[3], const double d[3])
{
    RefHit h = {0, INFINITY, 0, 0};
    for (uint32_t i = 0; i < n; i++) {
        double t, m;
        if (keep && !keep[i])
            continue;
        if (ref_tri(tris + (size_t)i * 9, o, d, 0.0, &t, &m) && t < h.t) {
            h.hit = 1;
            h.t = t;
            h.margin = m;
            h.id = i;
        }
    }
    return h;
}

/* Fires rays (origins uniform in [lo, hi]^3, uniform directions) and compares
 * closest hit (hit/miss, t, triangle) and any hit with the brute force. Near-ties
 * (a ray within 1e-5 barycentric of an edge, or two triangles at the same t) may
 * legitimately differ between float and double; at most 1 in 1000 rays may be
 * such a tie, and a tie still needs the BVH's triangle to be hit at its t. */
static void check_rays(const Bvh *bvh, const float *tris, uint32_t n, const unsigned char *keep,
                       int rays, double lo, double hi)
{
    int ties = 0, hits = 0;
    for (int r = 0; r < rays; r++) {
        double o[3], d[3];
        for (int a = 0; a < 3; a++)
            o[a] = rnd_range(lo, hi);
        rnd_dir(d);
        vec3 org = v3((float)o[0], (float)o[1], (float)o[2]);
        vec3 dir = v3((float)d[0], (float)d[1], (float)d[2]);
        for (int a = 0; a < 3; a++) { /* the reference sees the float ray */
            o[a] = (a == 0 ? org.x : a == 1 ? org.y : org.z);
            d[a] = (a == 0 ? dir.x : a == 1 ? dir.y : dir.z);
        }
        RefHit ref = ref_closest(tris, n, keep, o, d);
        BvhHit h = {0, 0, 0, 0};
        int got = bvh_intersect(bvh->nodes, bvh->tri_data, org, dir, 1e30f, &h);
        hits += got;
        int tie = 0;
        if (got) {
            assert_true(h.prim < bvh->prim_count);
            uint32_t id = bvh->prim_index[h.prim];
            double tb, mb;
            int on_tri = ref_tri(tris + (size_t)id * 9, o, d, 1e-5, &tb, &mb);
            if (!on_tri || fabs(tb - h.t) > 1e-4 * fmax(1.0, tb))
                fail_msg("ray %d: BVH hit triangle %u at t=%.9g, which the reference puts at "
                         "%s %.9g", r, id, h.t, on_tri ? "t =" : "a miss,", on_tri ? tb : 0.0);
            /* barycentrics reproduce the hit point */
            vec3 v0, v1, v2;
            bvh_vertices(bvh, h.prim, &v0, &v1, &v2);
            vec3 p = v3_add(v3_add(v3_scale(v0, 1 - h.u - h.v), v3_scale(v1, h.u)),
                            v3_scale(v2, h.v));
            vec3 q = v3_add(org, v3_scale(dir, h.t));
            assert_close(v3_length(v3_sub(p, q)), 0.0, 1e-3 * fmax(1.0, h.t));
            if (!ref.hit) {
                tie = 1;
            } else if (id != ref.id || fabs(h.t - ref.t) > 1e-4 * fmax(1.0, ref.t)) {
                if (fabs(tb - ref.t) > 1e-4 * fmax(1.0, ref.t))
                    fail_msg("ray %d: BVH t=%.9g (triangle %u), brute force t=%.9g (triangle "
                             "%u)", r, h.t, id, ref.t, ref.id);
                tie = 1;
            }
        } else if (ref.hit) {
            if (ref.margin > 1e-5)
                fail_msg("ray %d: BVH missed, brute force hit triangle %u at t=%.9g "
                         "(margin %.3g)", r, ref.id, ref.t, ref.margin);
            tie = 1;
        }
        ties += tie;
        /* any hit with a random tmax agrees with the closest hit */
        float tmax = (float)rnd_range(0.01, 2.0 * (hi - lo));
        int occ = bvh_occluded(bvh->nodes, bvh->tri_data, org, dir, tmax);
        int want = ref.hit && ref.t < tmax;
        if (occ != want && !tie && !(ref.hit && fabs(ref.t - tmax) < 1e-4 * tmax))
            fail_msg("ray %d: occluded(tmax=%.9g) = %d, brute force closest t = %.9g", r, tmax,
                     occ, ref.hit ? ref.t : -1.0);
    }
    if (ties > rays / 1000)
        fail_msg("%d of %d rays were near-ties, more than 1 in 1000", ties, rays);
    /* the rays must exercise hits as well as misses */
    assert_true(hits > rays / 20);
    assert_true(hits < rays);
}

/* Checks the tree: every node reached once, child boxes inside their parent's
 * box, unused slots empty, leaves bound their triangles, every kept triangle in
 * exactly one leaf, packed data equal to the input, depth within the traversal
 * stack's bound. keep may be NULL. */
static void check_structure(const Bvh *bvh, const float *tris, uint32_t n,
                            const unsigned char *keep)
{
    uint32_t want_kept = 0;
    for (uint32_t i = 0; i < n; i++)
        want_kept += keep ? keep[i] : 1;
    assert_int_equal(bvh->prim_count, want_kept);
    assert_true(bvh->node_count >= 1);
    unsigned char *seen = calloc(bvh->prim_count + 1, 1);
    unsigned char *seen_in = calloc(n + 1, 1);
    unsigned char *visited = calloc(bvh->node_count, 1);
    /* each node is pushed once, with its depth and the box its parent gave it */
    uint32_t *stack = malloc(bvh->node_count * sizeof *stack);
    uint32_t *depth = malloc(bvh->node_count * sizeof *depth);
    float(*pbox)[6] = malloc(bvh->node_count * sizeof *pbox);
    int sp = 0;
    stack[sp] = 0;
    depth[sp] = 0;
    for (int a = 0; a < 3; a++) {
        pbox[sp][a] = -INFINITY;
        pbox[sp][3 + a] = INFINITY;
    }
    sp++;
    uint32_t visits = 0, leaves = 0, max_depth = 0;
    while (sp) {
        sp--;
        uint32_t i = stack[sp], dep = depth[sp];
        float parent[6];
        memcpy(parent, pbox[sp], sizeof parent);
        assert_true(i < bvh->node_count);
        assert_false(visited[i]);
        visited[i] = 1;
        visits++;
        max_depth = dep > max_depth ? dep : max_depth;
        assert_true(dep < BVH_MAX_DEPTH);
        const BvhNode *nd = &bvh->nodes[i];
        for (int c = 0; c < BVH_WIDTH; c++) {
            float lo[3], hi[3];
            for (int a = 0; a < 3; a++) {
                lo[a] = nd->bounds[2 * a][c];
                hi[a] = nd->bounds[2 * a + 1][c];
            }
            if (nd->count[c] == 0 && nd->child[c] == 0) {
                /* unused: an empty box no ray enters */
                for (int a = 0; a < 3; a++) {
                    assert_true(lo[a] == FLT_MAX);
                    assert_true(hi[a] == -FLT_MAX);
                }
                continue;
            }
            for (int a = 0; a < 3; a++) {
                assert_true(isfinite(lo[a]) && isfinite(hi[a]));
                assert_true(lo[a] <= hi[a]);
                assert_true(lo[a] >= parent[a]);
                assert_true(hi[a] <= parent[3 + a]);
            }
            if (nd->count[c]) {
                leaves++;
                /* the leaf's block: in the buffer, its first triangle, its
                 * size and at most BVH_LEAF_VERTS distinct vertices */
                uint32_t blk = nd->child[c], cnt = nd->count[c] & 255;
                const float *p = bvh->tri_data + blk;
                assert_true((blk + 2) * sizeof(float) <= bvh->tri_data_bytes);
                uint32_t first = bvh_word(p, 0), nv = bvh_word(p, 1) & 255;
                assert_int_equal(bvh_word(p, 1) >> 8, cnt);
                assert_int_equal(nd->count[c] >> 8, nv);
                assert_true(nv >= 3 && nv <= BVH_LEAF_VERTS && nv <= 3 * cnt);
                assert_true((blk + bvh_leaf_words(cnt, nv) + BVH_TRI_PAD) * sizeof(float) <=
                            bvh->tri_data_bytes);
                const uint8_t *idx = (const uint8_t *)(p + 2 + 3 * nv);
                for (uint32_t k = 0; k < 3 * cnt; k++)
                    assert_true(idx[k] < nv);
                assert_true(first + cnt <= bvh->prim_count);
                for (uint32_t k = first; k < first + cnt; k++) {
                    assert_false(seen[k]);
                    seen[k] = 1;
                    uint32_t id = bvh->prim_index[k];
                    assert_true(id < n);
                    assert_true(keep == NULL || keep[id]);
                    assert_false(seen_in[id]);
                    seen_in[id] = 1;
                    /* its leaf record and its vertices, read through it */
                    assert_int_equal(bvh->tri_leaf[k], blk);
                    vec3 v[3];
                    bvh_vertices(bvh, k, &v[0], &v[1], &v[2]);
                    float pv[9];
                    for (int j = 0; j < 3; j++) {
                        pv[3 * j] = v[j].x;
                        pv[3 * j + 1] = v[j].y;
                        pv[3 * j + 2] = v[j].z;
                    }
                    assert_memory_equal(pv, tris + (size_t)id * 9, 36);
                    for (int a = 0; a < 9; a++) {
                        assert_true(pv[a] >= lo[a % 3]);
                        assert_true(pv[a] <= hi[a % 3]);
                    }
                }
            } else {
                assert_true(nd->child[c] > i && nd->child[c] < bvh->node_count);
                assert_true(sp < (int)bvh->node_count);
                stack[sp] = nd->child[c];
                depth[sp] = dep + 1;
                for (int a = 0; a < 3; a++) {
                    pbox[sp][a] = lo[a];
                    pbox[sp][3 + a] = hi[a];
                }
                sp++;
            }
        }
    }
    assert_int_equal(visits, bvh->node_count);
    assert_true(((uintptr_t)bvh->nodes) % 64 == 0 || bvh->prim_count == 0);
    assert_int_equal(leaves, bvh->stats.leaf_count);
    assert_int_equal(max_depth, bvh->stats.max_depth);
    for (uint32_t k = 0; k < bvh->prim_count; k++)
        assert_true(seen[k]);
    free(seen);
    free(seen_in);
    free(visited);
    free(stack);
    free(depth);
    free(pbox);
}

/* Quantised boxes (kernels/bvh/bvh_node.h): random child boxes of nodes of
 * every size, near and far from the origin (where org + q 2^e rounds), and
 * degenerate ones, decode to boxes that contain them, looser by at most a
 * step of their node's grid plus an ulp of the plane (the rounding of
 * org + q 2^e); unused slots are marked. */
TEST(test_quantised_boxes_conservative)
{
    rng_state = 31;
    int loose = 0;
    for (int k = 0; k < 20000; k++) {
        double centre = rnd_range(-1, 1) * pow(10.0, rnd_range(-3, 7));
        double size = pow(10.0, rnd_range(-7, 4));
        float box[6][BVH_WIDTH];
        int nused = 1 + (int)(rnd() * BVH_WIDTH);
        for (int i = 0; i < BVH_WIDTH; i++) {
            for (int a = 0; a < 3; a++) {
                double l = centre + size * rnd_range(-1, 1);
                double w = k % 7 == 0 ? 0.0 : size * rnd();
                box[2 * a][i] = i < nused ? (float)l : FLT_MAX;
                box[2 * a + 1][i] = i < nused ? (float)(l + w) : -FLT_MAX;
                if (box[2 * a + 1][i] < box[2 * a][i] && i < nused)
                    box[2 * a + 1][i] = box[2 * a][i];
            }
        }
        BvhNode f;
        memcpy(f.bounds, box, sizeof box);
        BvhQNode n;
        memset(&n, 0xab, sizeof n);
        bvh_node_quantise(&n, &f);
        for (int i = 0; i < BVH_WIDTH; i++) {
            assert_int_equal(n.used >> i & 1u, i < nused);
            if (i >= nused)
                continue;
            float lo[3], hi[3];
            bvh_qnode_box(&n, i, lo, hi);
            for (int a = 0; a < 3; a++) {
                float step = bvh_qstep(n.exp[a]);
                assert_true(lo[a] <= box[2 * a][i]);
                assert_true(hi[a] >= box[2 * a + 1][i]);
                double ulo = nextafterf(fabsf(lo[a]), INFINITY) - fabsf(lo[a]);
                double uhi = nextafterf(fabsf(hi[a]), INFINITY) - fabsf(hi[a]);
                loose += (double)box[2 * a][i] - lo[a] > step + ulo;
                loose += (double)hi[a] - box[2 * a + 1][i] > step + uhi;
            }
        }
    }
    assert_int_equal(loose, 0);
}

/* Checks bvh's nodes quantised (bvh_quantise_nodes): child and count kept,
 * used marking the used slots, steps in range, and every decoded box
 * containing the float box it stands for. */
static void check_quantised(const Bvh *bvh)
{
    BvhQNode *q = bvh_quantise_nodes(bvh->nodes, bvh->node_count);
    assert_true(((uintptr_t)q) % 64 == 0);
    for (uint32_t k = 0; k < bvh->node_count; k++) {
        const BvhNode *f = &bvh->nodes[k];
        for (int a = 0; a < 3; a++)
            assert_true(q[k].exp[a] >= BVH_QEXP_MIN && q[k].exp[a] <= BVH_QEXP_MAX);
        for (int c = 0; c < BVH_WIDTH; c++) {
            assert_int_equal(q[k].child[c], f->child[c]);
            assert_int_equal(q[k].count[c], f->count[c]);
            int used = f->count[c] || f->child[c];
            assert_int_equal(q[k].used >> c & 1u, used);
            if (!used)
                continue;
            float lo[3], hi[3];
            bvh_qnode_box(&q[k], c, lo, hi);
            for (int a = 0; a < 3; a++) {
                assert_true(lo[a] <= f->bounds[2 * a][c]);
                assert_true(hi[a] >= f->bounds[2 * a + 1][c]);
            }
        }
    }
    free(q);
}

/* n random triangles of size up to `size` inside [-1, 1]^3. */
static float *make_soup(uint32_t n, double size)
{
    float *t = malloc((size_t)n * 9 * sizeof *t);
    for (uint32_t i = 0; i < n; i++) {
        double c[3];
        for (int a = 0; a < 3; a++)
            c[a] = rnd_range(-1, 1);
        for (int k = 0; k < 9; k++)
            t[i * 9 + k] = (float)(c[k % 3] + rnd_range(-size, size));
    }
    return t;
}

TEST(test_soup_matches_brute_force)
{
    rng_state = 11;
    uint32_t n = 1000;
    float *t = make_soup(n, 0.15);
    Bvh bvh;
    assert_int_equal(bvh_build(&bvh, t, n, NULL), 0);
    assert_int_equal(bvh.stats.dropped, 0);
    check_structure(&bvh, t, n, NULL);
    check_quantised(&bvh);
    /* Soup triangles share no vertices, so no leaf holds more than five (16
     * vertices): the SAH's larger leaves were split into runs. */
    assert_true(bvh.stats.max_leaf_size >= 1 && bvh.stats.max_leaf_size <= 5);
    check_rays(&bvh, t, n, NULL, 40000, -1.5, 1.5);
    bvh_free(&bvh);
    free(t);
}

TEST(test_sphere_matches_brute_force)
{
    rng_state = 12;
    uint32_t n;
    const float c[3] = {0.3f, -0.2f, 0.1f};
    float *t = bvh_gen_sphere(30, 50, 1.0f, c, 0.2f, &n);
    assert_int_equal(n, 3000);
    Bvh bvh;
    assert_int_equal(bvh_build(&bvh, t, n, NULL), 0);
    check_structure(&bvh, t, n, NULL);
    check_quantised(&bvh);
    check_rays(&bvh, t, n, NULL, 40000, -1.5, 1.5);
    bvh_free(&bvh);
    free(t);
}

/* Scene 0 of the traversal tests, a dense soup (boxes entered several at a
 * time), or 1, a sphere of small leaves (a deeper tree): builds bvh over it and
 * returns its triangles (free them). */
static float *traversal_scene(int scene, Bvh *bvh)
{
    uint32_t n = 4000;
    const float c[3] = {0.1f, -0.1f, 0.2f};
    float *t = scene == 0 ? make_soup(n, 0.3) : bvh_gen_sphere(40, 80, 1.0f, c, 0.3f, &n);
    BvhOptions opt = bvh_default_options();
    opt.max_leaf = scene == 0 ? opt.max_leaf : 2;
    assert_int_equal(bvh_build_ex(bvh, t, n, &opt, NULL), 0);
    return t;
}

/* A random ray of the traversal tests: origin in [-1.6, 1.6]^3, inside or
 * outside their scenes, and a uniform direction. */
static void traversal_ray(vec3 *org, vec3 *dir)
{
    double o[3], d[3];
    for (int a = 0; a < 3; a++)
        o[a] = rnd_range(-1.6, 1.6);
    rnd_dir(d);
    *org = v3((float)o[0], (float)o[1], (float)o[2]);
    *dir = v3((float)d[0], (float)d[1], (float)d[2]);
}

/* The GPU path's short-stack traversal with restarts (bvh_traverse_short)
 * visits the full stack's items in the full stack's order, so closest hits
 * (t, barycentrics, triangle) and any-hit answers are the same bit for bit,
 * with stacks of 1, 2 and 3 entries (which overflow and restart on most rays
 * that hit) and the kernels' size; a dense soup (boxes entered several at a
 * time) and a sphere of small leaves (a deeper tree), rays from inside and
 * outside, random tmax. */
TEST(test_short_stack_matches_full)
{
    rng_state = 19;
    const int caps[4] = {1, 2, 3, BVH_SHORT_STACK_SIZE};
    for (int scene = 0; scene < 2; scene++) {
        Bvh bvh;
        float *t = traversal_scene(scene, &bvh);
        int restarted[4] = {0, 0, 0, 0}, hits = 0;
        const int rays = 20000;
        for (int r = 0; r < rays; r++) {
            vec3 org, dir;
            traversal_ray(&org, &dir);
            float tmax = r % 3 ? 1e30f : (float)rnd_range(0.05, 3.0);
            BvhHit want = {0, 0, 0, 0};
            int want_found = bvh_intersect(bvh.nodes, bvh.tri_data, org, dir, tmax, &want);
            int want_occ = bvh_occluded(bvh.nodes, bvh.tri_data, org, dir, tmax);
            hits += want_found;
            for (int k = 0; k < 4; k++) {
                BvhShort s;
                bvh_short_init(&s, org, dir, tmax);
                while (bvh_short_step(bvh.nodes, bvh.tri_data, &s, 0, caps[k]))
                    ;
                restarted[k] += s.dropped;
                assert_int_equal(s.found, want_found);
                if (want_found) {
                    if (memcmp(&s.hit, &want, sizeof want))
                        fail_msg("scene %d, ray %d, stack of %d: hit t=%.9g prim %u, full stack "
                                 "t=%.9g prim %u", scene, r, caps[k], s.hit.t, s.hit.prim, want.t,
                                 want.prim);
                }
                BvhHit h;
                assert_int_equal(bvh_traverse_short(bvh.nodes, bvh.tri_data, org, dir, tmax, 1,
                                                    caps[k], &h),
                                 want_occ);
            }
        }
        /* Both kinds of ray, and the small stacks did overflow. */
        assert_true(hits > rays / 10 && hits < rays);
        for (int k = 0; k < 3; k++)
            assert_true(restarted[k] > rays / 20);
        print_message("scene %d: rays that restarted with stacks of 1, 2, 3, %d: %d %d %d %d of "
                      "%d\n", scene, BVH_SHORT_STACK_SIZE, restarted[0], restarted[1],
                      restarted[2], restarted[3], rays);
        bvh_free(&bvh);
        free(t);
    }
}

/* The CPU kernels' paired traversal (two rays a step each in turn) gives each
 * ray the single-ray answer: bvh_intersect2's hits equal bvh_intersect's bit
 * for bit; a dense soup and a sphere of small leaves, rays from inside and
 * outside. */
TEST(test_pairs_match_single)
{
    rng_state = 23;
    for (int scene = 0; scene < 2; scene++) {
        Bvh bvh;
        float *t = traversal_scene(scene, &bvh);
        int hits = 0;
        const int pairs = 10000;
        for (int r = 0; r < pairs; r++) {
            vec3 org[2], dir[2];
            traversal_ray(&org[0], &dir[0]);
            traversal_ray(&org[1], &dir[1]);
            int found[2];
            BvhHit hit[2];
            bvh_intersect2(bvh.nodes, bvh.tri_data, org[0], dir[0], org[1], dir[1], 1e30f, found, hit);
            for (int k = 0; k < 2; k++) {
                BvhHit want = {0, 0, 0, 0};
                int want_found = bvh_intersect(bvh.nodes, bvh.tri_data, org[k], dir[k], 1e30f, &want);
                assert_int_equal(found[k], want_found);
                if (want_found && memcmp(&hit[k], &want, sizeof want))
                    fail_msg("scene %d, pair %d, ray %d: hit t=%.9g prim %u, alone t=%.9g prim %u", scene, r,
                             k, hit[k].t, hit[k].prim, want.t, want.prim);
                hits += found[k];
            }
        }
        /* Both answers occur. */
        assert_true(hits > pairs / 10 && hits < 2 * pairs);
        bvh_free(&bvh);
        free(t);
    }
}

/* The full-sweep reference builder makes a valid tree too, with SAH cost no
 * higher than the binned one's by more than rounding (it searches a superset). */
TEST(test_full_sweep_builder)
{
    rng_state = 13;
    uint32_t n = 2000;
    float *t = make_soup(n, 0.1);
    Bvh a, b;
    BvhOptions o = bvh_default_options();
    assert_int_equal(bvh_build_ex(&a, t, n, &o, NULL), 0);
    o.full_sweep = 1;
    assert_int_equal(bvh_build_ex(&b, t, n, &o, NULL), 0);
    check_structure(&b, t, n, NULL);
    check_quantised(&b);
    check_rays(&b, t, n, NULL, 10000, -1.5, 1.5);
    assert_true(b.stats.sah_cost <= a.stats.sah_cost * 1.02);
    bvh_free(&a);
    bvh_free(&b);
    free(t);
}

/* The root's subtrees built on threads make the tree one thread makes, node
 * for node and word for word (src/accel/bvh_build.c, build_root), on a mesh
 * and on a soup (whose leaves pack_leaf splits). */
TEST(test_threads_same_tree)
{
    rng_state = 15;
    const float c[3] = {0, 0, 0};
    for (int scene = 0; scene < 2; scene++) {
        uint32_t n = 20000;
        float *t = scene == 0 ? bvh_gen_sphere(100, 100, 1.0f, c, 0.3f, &n) : make_soup(n, 0.05);
        Bvh one, many;
        BvhOptions o = bvh_default_options();
        o.threads = 1;
        assert_int_equal(bvh_build_ex(&one, t, n, &o, NULL), 0);
        o.threads = 3;
        assert_int_equal(bvh_build_ex(&many, t, n, &o, NULL), 0);
        assert_int_equal(one.stats.build_threads, 1);
        assert_int_equal(many.stats.build_threads, 3);
        assert_true(one.node_count > 8);
        assert_int_equal(one.node_count, many.node_count);
        assert_memory_equal(one.nodes, many.nodes, one.node_count * sizeof *one.nodes);
        assert_int_equal(one.tri_data_bytes, many.tri_data_bytes);
        assert_memory_equal(one.tri_data, many.tri_data, one.tri_data_bytes);
        assert_int_equal(one.prim_count, many.prim_count);
        assert_memory_equal(one.prim_index, many.prim_index, one.prim_count * sizeof *one.prim_index);
        assert_memory_equal(one.tri_leaf, many.tri_leaf, one.prim_count * sizeof *one.tri_leaf);
        assert_int_equal(one.stats.leaf_count, many.stats.leaf_count);
        assert_int_equal(one.stats.max_depth, many.stats.max_depth);
        /* The SAH sums add the subtrees' terms in another order. */
        assert_close_rel(one.stats.sah_cost, many.stats.sah_cost, 1e-9);
        check_rays(&many, t, n, NULL, 2000, -1.5, 1.5);
        bvh_free(&one);
        bvh_free(&many);
        free(t);
    }
}

TEST(test_million_triangles)
{
    rng_state = 14;
    uint32_t n;
    const float c[3] = {0, 0, 0};
    float *t = bvh_gen_sphere(500, 1000, 1.0f, c, 0.3f, &n);
    assert_int_equal(n, 1000000);
    Bvh bvh;
    assert_int_equal(bvh_build(&bvh, t, n, NULL), 0);
    assert_int_equal(bvh.prim_count, n);
    assert_true(bvh.stats.max_depth < BVH_MAX_DEPTH);
    assert_true(bvh.stats.bytes_per_tri <= 64.0);
    check_rays(&bvh, t, n, NULL, 40, -1.0, 1.0);
    bvh_free(&bvh);
    free(t);
}

/* Rays from inside a closed mesh must all hit, also far from the origin. */
TEST(test_watertight)
{
    rng_state = 15;
    const double offsets[3] = {0.0, 1e4, 1e5};
    const float radius[3] = {1.0f, 4.0f, 4.0f};
    int rays = 35000, misses = 0;
    for (int k = 0; k < 3; k++) {
        uint32_t n;
        float c[3] = {(float)offsets[k], (float)(-0.7 * offsets[k]), (float)(0.3 * offsets[k])};
        float *t = bvh_gen_sphere(100, 200, radius[k], c, 0.2f, &n);
        Bvh bvh;
        assert_int_equal(bvh_build(&bvh, t, n, NULL), 0);
        int miss_here = 0;
        for (int r = 0; r < rays; r++) {
            double d[3];
            rnd_dir(d);
            vec3 org = v3(c[0] + (float)rnd_range(-0.3, 0.3) * radius[k],
                          c[1] + (float)rnd_range(-0.3, 0.3) * radius[k],
                          c[2] + (float)rnd_range(-0.3, 0.3) * radius[k]);
            vec3 dir = v3((float)d[0], (float)d[1], (float)d[2]);
            BvhHit h;
            if (!bvh_intersect(bvh.nodes, bvh.tri_data, org, dir, 1e30f, &h))
                miss_here++;
            else
                assert_true(h.t > 0.2f * radius[k] && h.t < 1.8f * radius[k]);
        }
        if (miss_here)
            print_message("offset %g: %d of %d rays from inside missed\n", offsets[k], miss_here,
                          rays);
        misses += miss_here;
        bvh_free(&bvh);
        free(t);
    }
    assert_true(misses <= (int)(2e-5 * 3 * rays));
}

/* Bad triangles are dropped and counted; the rest is indexed and traced. */
TEST(test_garbage_dropped)
{
    rng_state = 16;
    uint32_t good = 500, n = good + 8;
    float *t = make_soup(n, 0.2);
    unsigned char *keep = malloc(n);
    memset(keep, 1, n);
    uint32_t g = good;
    t[g * 9 + 4] = NAN; keep[g++] = 0;
    t[g * 9 + 0] = INFINITY; keep[g++] = 0;
    t[g * 9 + 8] = -INFINITY; keep[g++] = 0;
    t[g * 9 + 3] = 1e18f; keep[g++] = 0;
    t[g * 9 + 7] = -3e20f; keep[g++] = 0;
    /* collinear: v2 = 2 v1 - v0 exactly (small integers) */
    for (int a = 0; a < 3; a++) {
        t[g * 9 + a] = (float)a;
        t[g * 9 + 3 + a] = (float)(a + 1) * 0.5f;
        t[g * 9 + 6 + a] = 2 * t[g * 9 + 3 + a] - t[g * 9 + a];
    }
    keep[g++] = 0;
    memcpy(t + g * 9 + 3, t + g * 9, 3 * sizeof *t); /* two equal vertices */
    keep[g++] = 0;
    for (int k = 0; k < 9; k++) /* a huge but valid triangle is kept */
        t[g * 9 + k] = (float)((k % 3 == k / 3) ? 9e17 : 0.0);
    keep[g++] = 1;
    assert_int_equal(g, n);
    Bvh bvh;
    assert_int_equal(bvh_build(&bvh, t, n, NULL), 0);
    assert_int_equal(bvh.stats.dropped_nonfinite, 5);
    assert_int_equal(bvh.stats.dropped_degenerate, 2);
    assert_int_equal(bvh.stats.dropped, 7);
    check_structure(&bvh, t, n, keep);
    check_quantised(&bvh);
    check_rays(&bvh, t, n, keep, 10000, -1.5, 1.5);
    bvh_free(&bvh);
    free(keep);
    free(t);
}

/* 100,000 identical triangles: no SAH split exists; the tree stays shallow. */
TEST(test_identical_triangles)
{
    uint32_t n = 100000;
    float *t = malloc((size_t)n * 9 * sizeof *t);
    const float tri[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    for (uint32_t i = 0; i < n; i++)
        memcpy(t + (size_t)i * 9, tri, sizeof tri);
    Bvh bvh;
    assert_int_equal(bvh_build(&bvh, t, n, NULL), 0);
    check_structure(&bvh, t, n, NULL);
    check_quantised(&bvh);
    /* halving down to leaves of at most 8: ceil(log2(100000 / 8)) = 14 binary
     * levels, at least two of them per wide level */
    assert_true(bvh.stats.max_depth <= 7);
    assert_true(bvh.stats.build_seconds < 5.0);
    BvhHit h;
    assert_true(bvh_intersect(bvh.nodes, bvh.tri_data, v3(0.25f, 0.25f, 2.0f),
                              v3(0, 0, -1), 1e30f, &h));
    assert_close(h.t, 2.0, 1e-6);
    assert_close(h.u, 0.25, 1e-6);
    assert_close(h.v, 0.25, 1e-6);
    assert_false(bvh_occluded(bvh.nodes, bvh.tri_data, v3(0.25f, 0.25f, 2.0f), v3(0, 0, -1),
                              1.999f));
    bvh_free(&bvh);
    free(t);
}

/* The default leaves: a row of the CPU devices' leaf test (8 or 16) at a
 * node cost of as many triangles, and 16 for a tree far beyond any cache
 * (2^32 triangles). */
TEST(test_default_leaves)
{
    BvhOptions small = bvh_default_options(), huge = bvh_default_options_for(0xffffffffu);
    assert_true(small.max_leaf == 8 || small.max_leaf == 16);
    assert_true(small.cost_node == (float)small.max_leaf);
    assert_int_equal(huge.max_leaf, 16);
    assert_true(huge.cost_node == 16.0f);
}

/* No triangles, or only bad ones: a tree every ray misses. */
TEST(test_empty_scene)
{
    rng_state = 17;
    float bad[9] = {NAN, 0, 0, 1, 0, 0, 0, 1, 0};
    for (int k = 0; k < 2; k++) {
        Bvh bvh;
        assert_int_equal(bvh_build(&bvh, k ? bad : NULL, k, NULL), 0);
        assert_int_equal(bvh.prim_count, 0);
        assert_int_equal(bvh.node_count, 1);
        assert_true(bvh.tri_data_bytes > 0);
        assert_int_equal(bvh.stats.dropped, k);
        for (int r = 0; r < 1000; r++) {
            double d[3];
            rnd_dir(d);
            vec3 o = v3((float)rnd_range(-1, 1), (float)rnd_range(-1, 1), (float)rnd_range(-1, 1));
            vec3 dir = v3((float)d[0], (float)d[1], (float)d[2]);
            BvhHit h;
            assert_false(bvh_intersect(bvh.nodes, bvh.tri_data, o, dir, 1e30f, &h));
            assert_false(bvh_occluded(bvh.nodes, bvh.tri_data, o, dir, 1e30f));
        }
        bvh_free(&bvh);
    }
}

/* The kernels run this traversal: compiled by the OpenCL device from kernels/
 * (without fast-math options), with the lane-by-lane leaf test that GPUs run, with
 * the vector ones of x86 CPUs (SPT_BVH_SIMD: rows of 8 triangles with AVX2,
 * forced with SPT_BVH_NO_AVX512, and of 16 with AVX-512 where the CPU has it), with two rays traced
 * together (SPT_BVH_PAIRS) and with the GPU path's short stack
 * (SPT_BVH_SHORT_STACK; also with 2 entries, which restarts often), each
 * also on quantised nodes (SPT_BVH_QNODES), it reports the host's node size and returns
 * bit-identical hits to the host build for the same rays. Skipped without
 * an OpenCL device. */
static const char *k_device_src =
    "#include \"bvh/bvh.h\"\n"
    "__kernel void k_bvh_test(__global const BvhNode *nodes, __global const float *tris,\n"
    "                         __global const float *rays, __global float *out, int n)\n"
    "{\n"
    "    int i = get_global_id(0);\n"
    "    if (i >= n) return;\n"
    "    vec3 o = v3(rays[i * 6], rays[i * 6 + 1], rays[i * 6 + 2]);\n"
    "    vec3 d = v3(rays[i * 6 + 3], rays[i * 6 + 4], rays[i * 6 + 5]);\n"
    "    BvhHit h;\n"
    "#ifdef SPT_BVH_PAIRS\n"
    "    /* ray i traced with its neighbour, in either slot of the pair */\n"
    "    int j = (i ^ 1) < n ? (i ^ 1) : i, s = i & 1;\n"
    "    vec3 o2 = v3(rays[j * 6], rays[j * 6 + 1], rays[j * 6 + 2]);\n"
    "    vec3 d2 = v3(rays[j * 6 + 3], rays[j * 6 + 4], rays[j * 6 + 5]);\n"
    "    int f[2];\n"
    "    BvhHit hh[2];\n"
    "    bvh_intersect2(nodes, tris, s ? o2 : o, s ? d2 : d, s ? o : o2, s ? d : d2, 1e30f, f, hh);\n"
    "    int hit = f[s];\n"
    "    if (hit)\n"
    "        h = hh[s];\n"
    "#else\n"
    "    int hit = bvh_intersect(nodes, tris, o, d, 1e30f, &h);\n"
    "#endif\n"
    "    out[i * 4] = hit ? h.t : -1.0f;\n"
    "    out[i * 4 + 1] = hit ? (float)h.prim : -1.0f;\n"
    "    out[i * 4 + 2] = (float)bvh_occluded(nodes, tris, o, d, 1e30f);\n"
    "    out[i * 4 + 3] = (float)sizeof(BvhNode);\n"
    "}\n";

/* Builds k_device_src with options, runs it on the rays and counts the rays whose
 * hit, prim or occlusion differs from the host traversal. */
static int device_differences(const TestCl *cl, const char *options, const Bvh *bvh, const float *rays,
                              int nr, int *hits)
{
    float *out = malloc((size_t)nr * 4 * sizeof *out);
    /* With SPT_BVH_QNODES the device reads the nodes quantised, and must
     * still find the host's hits (on these rays no two hits tie) */
    int quantised = options && strstr(options, "SPT_BVH_QNODES");
    BvhQNode *qn = quantised ? bvh_quantise_nodes(bvh->nodes, bvh->node_count) : NULL;
    const TestClArg args[3] = {{quantised ? (const void *)qn : bvh->nodes,
                                bvh->node_count * (quantised ? sizeof(BvhQNode) : sizeof(BvhNode))},
                               {bvh->tri_data, bvh->tri_data_bytes},
                               {rays, (size_t)nr * 6 * sizeof *rays}};
    /* Work-groups of 64, as the renderer's: PoCL keeps every work-item's
     * private traversal stacks of a group at once, on a thread's stack. */
    test_cl_run(cl, k_device_src, options, "kernels/bvh/bvh.h", "k_bvh_test", args, 3, out,
                (size_t)nr * 4 * sizeof *out, nr, 64);
    assert_close(out[3], quantised ? sizeof(BvhQNode) : sizeof(BvhNode), 0);
    free(qn);
    int differ = 0;
    *hits = 0;
    for (int i = 0; i < nr; i++) {
        vec3 o = v3(rays[i * 6], rays[i * 6 + 1], rays[i * 6 + 2]);
        vec3 d = v3(rays[i * 6 + 3], rays[i * 6 + 4], rays[i * 6 + 5]);
        BvhHit h;
        int hit = bvh_intersect(bvh->nodes, bvh->tri_data, o, d, 1e30f, &h);
        int occ = bvh_occluded(bvh->nodes, bvh->tri_data, o, d, 1e30f);
        *hits += hit;
        if (out[i * 4] != (hit ? h.t : -1.0f) || out[i * 4 + 1] != (hit ? (float)h.prim : -1.0f) ||
            out[i * 4 + 2] != (float)occ) {
            if (differ++ < 5)
                print_message("%s: ray %d: device t=%.9g prim=%g occ=%g, host t=%.9g prim=%d "
                              "occ=%d\n",
                              options ? options : "-", i, out[i * 4], out[i * 4 + 1], out[i * 4 + 2],
                              hit ? h.t : -1.0f, hit ? (int)h.prim : -1, occ);
        }
    }
    free(out);
    return differ;
}

TEST(test_device_matches_host)
{
    TestCl cl = test_cl_open();
    rng_state = 18;
    uint32_t n;
    const float c[3] = {0.1f, 0.2f, -0.3f};
    float *t = bvh_gen_sphere(60, 120, 1.0f, c, 0.3f, &n);
    /* A tree of leaves of up to 16 triangles (AVX-512's default: the AVX2
     * form tests them in one and in two rows of 8) and one of leaves of at
     * most 3. */
    BvhOptions opt = bvh_default_options();
    const int max_leaf[2] = {16, 3};
    const float cost_node[2] = {16.0f, 2.0f};
    int nr = 20000;
    float *rays = malloc((size_t)nr * 6 * sizeof *rays);
    for (int i = 0; i < nr; i++) {
        double d[3];
        rnd_dir(d);
        for (int a = 0; a < 3; a++) {
            rays[i * 6 + a] = (float)rnd_range(-1.4, 1.4);
            rays[i * 6 + 3 + a] = (float)d[a];
        }
    }
    for (int m = 0; m < 2; m++) {
        Bvh bvh;
        opt.max_leaf = max_leaf[m];
        opt.cost_node = cost_node[m];
        assert_int_equal(bvh_build_ex(&bvh, t, n, &opt, NULL), 0);
        if (m == 0)
            assert_true(bvh.stats.max_leaf_size > 8);
        const char *options[9] = {
            NULL,
            "-DSPT_BVH_SIMD=1 -DSPT_BVH_NO_AVX512=1",
            "-DSPT_BVH_SIMD=1 -DSPT_BVH_PAIRS=1 -DSPT_BVH_STEP_PREFETCH=1",
            "-DSPT_BVH_SHORT_STACK=1",
            "-DSPT_BVH_SHORT_STACK=1 -DBVH_SHORT_STACK_SIZE=2",
            "-DSPT_BVH_QNODES=1",
            "-DSPT_BVH_QNODES=1 -DSPT_BVH_SIMD=1 -DSPT_BVH_PAIRS=1 -DSPT_BVH_STEP_PREFETCH=1",
            "-DSPT_BVH_QNODES=1 -DSPT_BVH_SHORT_STACK=1",
            "-DSPT_BVH_QNODES=1 -DSPT_BVH_SHORT_STACK=1 -DBVH_SHORT_STACK_SIZE=2"};
        for (int o = 0; o < 9; o++) {
            int hits;
            assert_int_equal(device_differences(&cl, options[o], &bvh, rays, nr, &hits), 0);
            assert_true(hits > nr / 4);
        }
        bvh_free(&bvh);
    }
    test_cl_close(&cl);
    free(rays);
    free(t);
}

TEST_MAIN("bvh", NULL, NULL)
