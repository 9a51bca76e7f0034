/* The light tree's construction (see render/light_tree.h). */
#include "render/light_tree.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/util.h"

#define BINS 12
/* Below this depth splits minimise the SAOH; from it on they halve the
 * lights (by centroid along the widest axis), so the depth stays within
 * about 48 + log2(n) whatever the lights' layout. */
#define SAOH_DEPTH 48

/* A node's bounds while building: the box, the cone of normals and the
 * emission spread, the power, and whether some light is two-sided. */
typedef struct Bounds {
    double lo[3], hi[3], axis[3];
    double theta_o, theta_e, power;
    int two_sided, empty;
} Bounds;

static void bounds_empty(Bounds *b)
{
    memset(b, 0, sizeof *b);
    b->empty = 1;
}

static Bounds bounds_of(const LightBound *l)
{
    Bounds b;
    memcpy(b.lo, l->lo, sizeof b.lo);
    memcpy(b.hi, l->hi, sizeof b.hi);
    memcpy(b.axis, l->axis, sizeof b.axis);
    b.theta_o = l->theta_o;
    b.theta_e = l->theta_e;
    b.power = l->power;
    b.two_sided = l->two_sided;
    b.empty = 0;
    return b;
}

/* The smallest cone holding cones (a, ta) and (c, tc): the wider one when it
 * holds the other, else the cone whose edges touch both, its axis turned from
 * the wider one's toward the other's (the cone union of Conty Estevez and
 * Kulla 2018, section 4.1). */
static void cone_union(double *axis, double *theta, const double *a, double ta, const double *c, double tc)
{
    if (tc > ta) {
        const double *s = a;
        a = c;
        c = s;
        double st = ta;
        ta = tc;
        tc = st;
    }
    double dot = a[0] * c[0] + a[1] * c[1] + a[2] * c[2];
    double d = acos(fmax(-1.0, fmin(1.0, dot)));
    memcpy(axis, a, 3 * sizeof(double));
    if (fmin(d + tc, M_PI) <= ta) {
        *theta = ta;
        return;
    }
    double t = 0.5 * (ta + d + tc);
    double perp[3] = {c[0] - dot * a[0], c[1] - dot * a[1], c[2] - dot * a[2]};
    double pl = sqrt(perp[0] * perp[0] + perp[1] * perp[1] + perp[2] * perp[2]);
    if (t >= M_PI || !(pl > 1e-12)) {
        *theta = M_PI;
        return;
    }
    double r = t - ta;
    for (int k = 0; k < 3; k++)
        axis[k] = a[k] * cos(r) + perp[k] / pl * sin(r);
    double al = sqrt(axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]);
    for (int k = 0; k < 3; k++)
        axis[k] /= al;
    *theta = t;
}

static void bounds_add(Bounds *b, const Bounds *o)
{
    if (o->empty)
        return;
    if (b->empty) {
        *b = *o;
        return;
    }
    for (int k = 0; k < 3; k++) {
        b->lo[k] = fmin(b->lo[k], o->lo[k]);
        b->hi[k] = fmax(b->hi[k], o->hi[k]);
    }
    double axis[3], t;
    cone_union(axis, &t, b->axis, b->theta_o, o->axis, o->theta_o);
    memcpy(b->axis, axis, sizeof axis);
    b->theta_o = t;
    b->theta_e = fmax(b->theta_e, o->theta_e);
    b->power += o->power;
    b->two_sided |= o->two_sided;
}

/* The paper's orientation measure M_omega: the solid angle of the normals'
 * cone, widened by theta_e and weighted by cosine. */
static double orientation_measure(double to, double te)
{
    double tw = fmin(to + te, M_PI);
    return 2.0 * M_PI * (1.0 - cos(to)) +
           0.5 * M_PI * (2.0 * tw * sin(to) - cos(to - 2.0 * tw) - 2.0 * to * sin(to) + cos(to));
}

/* The SAOH cost of b: power x orientation x surface area, each side of the
 * box at least `floor` long (a row of lamps has a flat box, whose area alone
 * would make every split of it free). */
static double bounds_cost(const Bounds *b, double floor)
{
    if (b->empty)
        return 0.0;
    double e[3];
    for (int k = 0; k < 3; k++)
        e[k] = fmax(b->hi[k] - b->lo[k], floor);
    double area = 2.0 * (e[0] * e[1] + e[1] * e[2] + e[2] * e[0]);
    return b->power * orientation_measure(b->theta_o, b->theta_e) * area;
}

typedef struct Build {
    const LightBound *lights;
    const uint32_t *ids;
    uint32_t *order;
    LightTreeNode *nodes;
    uint32_t count;
    uint32_t *leaf_of;
    double total;
    double *key; /* scratch for the median split */
} Build;

static double centroid(const LightBound *l, int k)
{
    return 0.5 * (l->lo[k] + l->hi[k]);
}

static void node_write(LightTreeNode *nd, const Bounds *b, double total)
{
    for (int k = 0; k < 3; k++) {
        nd->lo[k] = (float)b->lo[k];
        nd->hi[k] = (float)b->hi[k];
        nd->axis[k] = (float)b->axis[k];
    }
    /* float rounding must not narrow the box or the cones. */
    for (int k = 0; k < 3; k++) {
        if ((double)nd->lo[k] > b->lo[k])
            nd->lo[k] = nextafterf(nd->lo[k], -INFINITY);
        if ((double)nd->hi[k] < b->hi[k])
            nd->hi[k] = nextafterf(nd->hi[k], INFINITY);
    }
    const double slack = 1e-5;
    nd->cos_o = b->theta_o + slack >= M_PI ? -1.0f : (float)cos(b->theta_o + slack);
    /* theta_e 0 is a spot's exact cone: keep cos_e at 1 (the kernel's test
     * passes only directions inside the cone of normals, where theta' is 0). */
    nd->cos_e = b->theta_e <= 0.0 ? 1.0f : (b->theta_e + slack >= M_PI ? -1.0f : (float)cos(b->theta_e + slack));
    nd->power = (float)(b->power / total);
    nd->two_sided = (spt_u32)b->two_sided;
}

static int cmp_key(const void *a, const void *b, void *ctx)
{
    const double *key = ctx;
    double x = key[*(const uint32_t *)a], y = key[*(const uint32_t *)b];
    return x < y ? -1 : (x > y ? 1 : (int)(*(const uint32_t *)a > *(const uint32_t *)b) -
                                          (int)(*(const uint32_t *)a < *(const uint32_t *)b));
}

/* Sorts order[0..n) by key (ties by index), without qsort_r's portability. */
static void sort_by_key(uint32_t *order, uint32_t n, const double *key)
{
    for (uint32_t w = 1; w < n; w *= 2) {
        /* bottom-up merge sort through a scratch copy */
        uint32_t *tmp = spt_malloc(sizeof(uint32_t) * n);
        for (uint32_t i = 0; i < n; i += 2 * w) {
            uint32_t m = i + w < n ? i + w : n, e = i + 2 * w < n ? i + 2 * w : n;
            uint32_t a = i, b = m, o = i;
            while (a < m && b < e)
                tmp[o++] = cmp_key(&order[b], &order[a], (void *)key) < 0 ? order[b++] : order[a++];
            while (a < m)
                tmp[o++] = order[a++];
            while (b < e)
                tmp[o++] = order[b++];
        }
        memcpy(order, tmp, sizeof(uint32_t) * n);
        free(tmp);
    }
}

/* Splits order[0..n) (n >= 2) in two; returns the size of the first part. */
static uint32_t split(Build *B, uint32_t *order, uint32_t n, const Bounds *nb, int depth)
{
    double clo[3] = {INFINITY, INFINITY, INFINITY}, chi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (uint32_t i = 0; i < n; i++)
        for (int k = 0; k < 3; k++) {
            double c = centroid(&B->lights[order[i]], k);
            clo[k] = fmin(clo[k], c);
            chi[k] = fmax(chi[k], c);
        }
    double ext[3], emax = 0.0;
    for (int k = 0; k < 3; k++) {
        ext[k] = nb->hi[k] - nb->lo[k];
        emax = fmax(emax, ext[k]);
    }
    int best_axis = -1, best_bin = 0;
    double best = INFINITY;
    if (depth < SAOH_DEPTH) {
        for (int k = 0; k < 3; k++) {
            if (!(chi[k] > clo[k]))
                continue;
            Bounds bin[BINS];
            for (int j = 0; j < BINS; j++)
                bounds_empty(&bin[j]);
            double scale = BINS / (chi[k] - clo[k]);
            for (uint32_t i = 0; i < n; i++) {
                const LightBound *l = &B->lights[order[i]];
                int j = (int)((centroid(l, k) - clo[k]) * scale);
                j = j < 0 ? 0 : (j >= BINS ? BINS - 1 : j);
                Bounds lb = bounds_of(l);
                bounds_add(&bin[j], &lb);
            }
            double below[BINS];
            Bounds acc;
            bounds_empty(&acc);
            for (int j = 0; j < BINS - 1; j++) {
                bounds_add(&acc, &bin[j]);
                below[j] = bounds_cost(&acc, 1e-3 * emax);
            }
            bounds_empty(&acc);
            double kr = emax / fmax(ext[k], 1e-12 * emax + 1e-30);
            for (int j = BINS - 1; j > 0; j--) {
                bounds_add(&acc, &bin[j]);
                if (acc.empty)
                    continue;
                /* split after bin j - 1: both sides must hold a light */
                int has_below = 0;
                for (int q = 0; q < j; q++)
                    has_below |= !bin[q].empty;
                if (!has_below)
                    continue;
                double cost = kr * (below[j - 1] + bounds_cost(&acc, 1e-3 * emax));
                if (cost < best) {
                    best = cost;
                    best_axis = k;
                    best_bin = j;
                }
            }
        }
    }
    if (best_axis >= 0) {
        int k = best_axis;
        double scale = BINS / (chi[k] - clo[k]);
        uint32_t a = 0, b = n;
        while (a < b) {
            int j = (int)((centroid(&B->lights[order[a]], k) - clo[k]) * scale);
            j = j < 0 ? 0 : (j >= BINS ? BINS - 1 : j);
            if (j < best_bin) {
                a++;
            } else {
                b--;
                uint32_t s = order[a];
                order[a] = order[b];
                order[b] = s;
            }
        }
        if (a > 0 && a < n)
            return a;
    }
    /* Halve along the widest spread of centroids (order by index when they
     * all coincide). */
    int k = 0;
    for (int q = 1; q < 3; q++)
        if (chi[q] - clo[q] > chi[k] - clo[k])
            k = q;
    for (uint32_t i = 0; i < n; i++)
        B->key[order[i]] = centroid(&B->lights[order[i]], k);
    sort_by_key(order, n, B->key);
    return n / 2;
}

/* Builds node `node` over order[0..n) and returns its bounds: a leaf's are
 * its light's, an interior node's the union of its children's (so each
 * node's cone holds its children's cones, not just their lights' normals). */
static Bounds build_node(Build *B, uint32_t node, uint32_t parent, uint32_t *order, uint32_t n, int depth)
{
    Bounds b;
    if (n == 1) {
        b = bounds_of(&B->lights[order[0]]);
        LightTreeNode *nd = &B->nodes[node];
        node_write(nd, &b, B->total);
        nd->parent = parent;
        nd->leaf = 1u;
        nd->child = B->ids[order[0]];
        B->leaf_of[order[0]] = node;
        return b;
    }
    /* The split needs the box alone. */
    bounds_empty(&b);
    for (uint32_t i = 0; i < n; i++) {
        const LightBound *l = &B->lights[order[i]];
        for (int k = 0; k < 3; k++) {
            b.lo[k] = i ? fmin(b.lo[k], l->lo[k]) : l->lo[k];
            b.hi[k] = i ? fmax(b.hi[k], l->hi[k]) : l->hi[k];
        }
    }
    uint32_t m = split(B, order, n, &b, depth);
    uint32_t c = B->count;
    B->count += 2;
    Bounds l = build_node(B, c, node, order, m, depth + 1);
    Bounds r = build_node(B, c + 1, node, order + m, n - m, depth + 1);
    bounds_add(&l, &r);
    LightTreeNode *nd = &B->nodes[node];
    node_write(nd, &l, B->total);
    nd->parent = parent;
    nd->leaf = 0u;
    nd->child = c;
    return l;
}

void light_tree_build(LightTree *t, const LightBound *lights, const uint32_t *ids, uint32_t n)
{
    memset(t, 0, sizeof *t);
    if (n == 0)
        return;
    Build B;
    memset(&B, 0, sizeof B);
    B.lights = lights;
    B.ids = ids;
    B.order = spt_malloc(sizeof(uint32_t) * n);
    B.key = spt_malloc(sizeof(double) * n);
    B.nodes = spt_calloc(2 * (size_t)n - 1, sizeof(LightTreeNode));
    B.leaf_of = spt_malloc(sizeof(uint32_t) * n);
    for (uint32_t i = 0; i < n; i++) {
        B.order[i] = i;
        B.total += lights[i].power;
    }
    B.count = 1;
    build_node(&B, 0, SPT_TREE_NONE, B.order, n, 0);
    free(B.order);
    free(B.key);
    t->nodes = B.nodes;
    t->count = B.count;
    t->leaf_of = B.leaf_of;
}

void light_tree_free(LightTree *t)
{
    free(t->nodes);
    free(t->leaf_of);
    memset(t, 0, sizeof *t);
}
