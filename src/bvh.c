/* Binned SAH BVH builder (Wald 2007, "On fast Construction of SAH-based Bounding
 * Volume Hierarchies") into the flat layout of kernels/bvh.h, with an exact
 * full-sweep SAH builder as a quality reference. */
#include "bvh.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#ifdef __SSE2__
#include <emmintrin.h>
#endif

/* Below this depth splits follow the SAH; from it on they are object medians,
 * which halve the triangle count, so 2^32 triangles still end in leaves at depth
 * BVH_MEDIAN_DEPTH + 32 <= BVH_MAX_DEPTH - 1. */
#define BVH_MEDIAN_DEPTH (BVH_MAX_DEPTH - 1 - 32)
/* Most triangles indexed: node indices and counts must fit in 31 bits. */
#define BVH_MAX_TRIS (1u << 30)

/* A triangle's bounds while building; its centroid (doubled) is lo + hi. */
typedef struct PrimRef {
    float lo[3];
    uint32_t id;
    float hi[3];
    float pad;
} PrimRef;

/* Compare-based min/max: fminf/fmaxf are library calls without -ffast-math. */
static inline float minf(float a, float b) { return a < b ? a : b; }
static inline float maxf(float a, float b) { return a > b ? a : b; }

typedef struct Box {
    float lo[3], hi[3];
} Box;

/* A chosen split of refs[begin, end): [begin, mid) left, [mid, end) right. */
typedef struct Split {
    uint32_t mid;
    Box lb, rb;   /* child bounds */
    Box lcb, rcb; /* child centroid bounds (doubled centroids) */
} Split;

typedef struct SweepKey {
    float key;
    uint32_t id;
    uint32_t ref; /* position in refs */
} SweepKey;

typedef struct Builder {
    PrimRef *refs;
    BvhNode *nodes;
    uint32_t node_count;
    uint32_t max_depth;
    BvhOptions opt;
    /* full-sweep scratch, sized for all refs */
    SweepKey *keys;
    float *right_area;
    PrimRef *tmp;
} Builder;

BvhOptions bvh_default_options(void)
{
    BvhOptions o;
    o.bins = 16;
    o.max_leaf = 8;
    o.full_sweep = 0;
    o.cost_node = 2.0f;
    o.cost_tri = 1.0f;
    return o;
}

static void box_empty(Box *b)
{
    for (int a = 0; a < 3; a++) {
        b->lo[a] = FLT_MAX;
        b->hi[a] = -FLT_MAX;
    }
}

static void box_grow_box(Box *b, const Box *o)
{
    for (int a = 0; a < 3; a++) {
        b->lo[a] = minf(b->lo[a], o->lo[a]);
        b->hi[a] = maxf(b->hi[a], o->hi[a]);
    }
}

static void box_grow_ref(Box *b, const PrimRef *r)
{
    for (int a = 0; a < 3; a++) {
        b->lo[a] = minf(b->lo[a], r->lo[a]);
        b->hi[a] = maxf(b->hi[a], r->hi[a]);
    }
}

static void box_grow_centroid(Box *b, const PrimRef *r)
{
    for (int a = 0; a < 3; a++) {
        float c = r->lo[a] + r->hi[a];
        b->lo[a] = minf(b->lo[a], c);
        b->hi[a] = maxf(b->hi[a], c);
    }
}

/* Half the surface area; 0 for an empty box. */
static float box_half_area(const Box *b)
{
    float dx = b->hi[0] - b->lo[0], dy = b->hi[1] - b->lo[1], dz = b->hi[2] - b->lo[2];
    if (dx < 0.0f || dy < 0.0f || dz < 0.0f)
        return 0.0f;
    return dx * dy + dy * dz + dz * dx;
}

/* Bounds and centroid bounds of refs[begin, end). */
static void refs_bounds(const PrimRef *refs, uint32_t begin, uint32_t end, Box *b, Box *cb)
{
    box_empty(b);
    box_empty(cb);
    for (uint32_t i = begin; i < end; i++) {
        box_grow_ref(b, &refs[i]);
        box_grow_centroid(cb, &refs[i]);
    }
}

/* SAH cost of splitting a node of half area `area` into the two sides. */
static float sah_split_cost(const BvhOptions *o, float area, float la, uint32_t ln, float ra,
                            uint32_t rn)
{
    return o->cost_node + o->cost_tri * (la * (float)ln + ra * (float)rn) / area;
}

typedef struct Bin {
    Box b;
    uint32_t n;
} Bin;

/* Binned SAH split of refs[begin, end) with centroid bounds cb. Returns 1 with s
 * and *cost filled, or 0 when the centroids cannot be told apart. */
static int split_binned(Builder *bd, uint32_t begin, uint32_t end, const Box *bounds,
                        const Box *cb, Split *s, float *cost)
{
    /* Few bins for small nodes: there are many of them and little to gain. */
    uint32_t cnt = end - begin;
    const int nb = cnt < (uint32_t)bd->opt.bins ? (cnt < 4 ? 4 : (int)cnt) : bd->opt.bins;
    Bin bins[3][BVH_MAX_BINS];
    float scale[3];
    int usable = 0;
    for (int a = 0; a < 3; a++) {
        float ext = cb->hi[a] - cb->lo[a];
        float sc = ext > 0.0f ? (float)nb * 0.99999f / ext : 0.0f;
        scale[a] = sc < FLT_MAX ? sc : 0.0f; /* a subnormal extent cannot be binned */
        usable |= scale[a] > 0.0f;
        for (int k = 0; k < nb; k++) {
            box_empty(&bins[a][k].b);
            bins[a][k].n = 0;
        }
    }
    if (!usable)
        return 0;
    PrimRef *refs = bd->refs;
#ifdef __SSE2__
    /* The same bin expression as the scalar loop and the partition, 4 lanes at a
     * time; lane 3 (the id bits) is ignored. */
    __m128 blo[3][BVH_MAX_BINS], bhi[3][BVH_MAX_BINS];
    uint32_t bn[3][BVH_MAX_BINS];
    for (int a = 0; a < 3; a++) {
        for (int k = 0; k < nb; k++) {
            blo[a][k] = _mm_set1_ps(FLT_MAX);
            bhi[a][k] = _mm_set1_ps(-FLT_MAX);
            bn[a][k] = 0;
        }
    }
    const __m128 vmin = _mm_setr_ps(cb->lo[0], cb->lo[1], cb->lo[2], 0.0f);
    const __m128 vscale = _mm_setr_ps(scale[0], scale[1], scale[2], 0.0f);
    for (uint32_t i = begin; i < end; i++) {
        const PrimRef *r = &refs[i];
        __m128 lo = _mm_loadu_ps(r->lo), hi = _mm_loadu_ps(r->hi);
        __m128 kf = _mm_mul_ps(_mm_sub_ps(_mm_add_ps(lo, hi), vmin), vscale);
        int32_t k[4];
        _mm_storeu_si128((__m128i *)k, _mm_cvttps_epi32(kf));
        for (int a = 0; a < 3; a++) {
            int kk = k[a] < nb - 1 ? k[a] : nb - 1;
            blo[a][kk] = _mm_min_ps(blo[a][kk], lo);
            bhi[a][kk] = _mm_max_ps(bhi[a][kk], hi);
            bn[a][kk]++;
        }
    }
    for (int a = 0; a < 3; a++) {
        for (int k = 0; k < nb; k++) {
            float l4[4], h4[4];
            _mm_storeu_ps(l4, blo[a][k]);
            _mm_storeu_ps(h4, bhi[a][k]);
            memcpy(bins[a][k].b.lo, l4, sizeof bins[a][k].b.lo);
            memcpy(bins[a][k].b.hi, h4, sizeof bins[a][k].b.hi);
            bins[a][k].n = bn[a][k];
        }
    }
#else
    for (uint32_t i = begin; i < end; i++) {
        const PrimRef *r = &refs[i];
        for (int a = 0; a < 3; a++) {
            int k = (int)((r->lo[a] + r->hi[a] - cb->lo[a]) * scale[a]);
            k = k < nb - 1 ? k : nb - 1;
            Bin *bin = &bins[a][k];
            bin->n++;
            for (int c = 0; c < 3; c++) {
                bin->b.lo[c] = minf(bin->b.lo[c], r->lo[c]);
                bin->b.hi[c] = maxf(bin->b.hi[c], r->hi[c]);
            }
        }
    }
#endif
    float area = box_half_area(bounds);
    float best = FLT_MAX;
    int best_axis = -1, best_k = -1;
    for (int a = 0; a < 3; a++) {
        if (scale[a] == 0.0f)
            continue;
        float rarea[BVH_MAX_BINS];
        uint32_t rcount[BVH_MAX_BINS];
        Box acc;
        box_empty(&acc);
        uint32_t n = 0;
        for (int k = nb - 1; k > 0; k--) {
            box_grow_box(&acc, &bins[a][k].b);
            n += bins[a][k].n;
            rarea[k] = box_half_area(&acc);
            rcount[k] = n;
        }
        box_empty(&acc);
        n = 0;
        for (int k = 0; k < nb - 1; k++) {
            box_grow_box(&acc, &bins[a][k].b);
            n += bins[a][k].n;
            if (n == 0 || rcount[k + 1] == 0)
                continue;
            float c = sah_split_cost(&bd->opt, area, box_half_area(&acc), n, rarea[k + 1], rcount[k + 1]);
            if (c < best) {
                best = c;
                best_axis = a;
                best_k = k;
            }
        }
    }
    if (best_axis < 0)
        return 0;
    int a = best_axis;
    box_empty(&s->lb);
    box_empty(&s->rb);
    for (int k = 0; k < nb; k++)
        box_grow_box(k <= best_k ? &s->lb : &s->rb, &bins[a][k].b);
    /* Partition with the same bin expression as above, so the sides match the
     * bins whose bounds became the child bounds. */
    box_empty(&s->lcb);
    box_empty(&s->rcb);
    uint32_t lo = begin, hi = end;
    const float cmin = cb->lo[a], sc = scale[a];
    while (lo < hi) {
        PrimRef *r = &refs[lo];
        int k = (int)((r->lo[a] + r->hi[a] - cmin) * sc);
        k = k < nb - 1 ? k : nb - 1;
        if (k <= best_k) {
            box_grow_centroid(&s->lcb, r);
            lo++;
        } else {
            hi--;
            box_grow_centroid(&s->rcb, r);
            PrimRef t = *r;
            *r = refs[hi];
            refs[hi] = t;
        }
    }
    s->mid = lo;
    *cost = best;
    return lo > begin && lo < end;
}

/* Centroid (doubled) of r along axis a. */
static float ref_key(const PrimRef *r, int a) { return r->lo[a] + r->hi[a]; }

/* Reorders refs[begin, end) so that position k holds the element a sort by
 * centroid along axis a would put there, smaller before, larger after
 * (Hoare quickselect). */
static void select_nth(PrimRef *refs, uint32_t begin, uint32_t end, uint32_t k, int a)
{
    int64_t l = begin, r = (int64_t)end - 1;
    while (r > l) {
        float pivot = ref_key(&refs[l + (r - l) / 2], a);
        int64_t i = l, j = r;
        while (i <= j) {
            while (ref_key(&refs[i], a) < pivot) i++;
            while (ref_key(&refs[j], a) > pivot) j--;
            if (i <= j) {
                PrimRef t = refs[i];
                refs[i] = refs[j];
                refs[j] = t;
                i++;
                j--;
            }
        }
        if ((int64_t)k <= j)
            r = j;
        else if ((int64_t)k >= i)
            l = i;
        else
            break;
    }
}

/* Object median split of refs[begin, end) (count >= 2) along the widest centroid
 * axis, or by position when all centroids coincide. Always splits. */
static void split_median(Builder *bd, uint32_t begin, uint32_t end, const Box *cb, Split *s)
{
    int a = 0;
    float ext = cb->hi[0] - cb->lo[0];
    for (int c = 1; c < 3; c++) {
        if (cb->hi[c] - cb->lo[c] > ext) {
            ext = cb->hi[c] - cb->lo[c];
            a = c;
        }
    }
    uint32_t mid = begin + (end - begin) / 2;
    if (ext > 0.0f)
        select_nth(bd->refs, begin, end, mid, a);
    s->mid = mid;
    refs_bounds(bd->refs, begin, mid, &s->lb, &s->lcb);
    refs_bounds(bd->refs, mid, end, &s->rb, &s->rcb);
}

static int sweep_key_cmp(const void *pa, const void *pb)
{
    const SweepKey *a = pa, *b = pb;
    if (a->key != b->key)
        return a->key < b->key ? -1 : 1;
    return a->id < b->id ? -1 : (a->id > b->id);
}

/* Fills keys[0, n) with refs[begin, end) sorted by centroid along axis a. */
static void sweep_sort(Builder *bd, uint32_t begin, uint32_t end, int a)
{
    uint32_t n = end - begin;
    for (uint32_t i = 0; i < n; i++) {
        const PrimRef *r = &bd->refs[begin + i];
        bd->keys[i].key = ref_key(r, a);
        bd->keys[i].id = r->id;
        bd->keys[i].ref = begin + i;
    }
    qsort(bd->keys, n, sizeof *bd->keys, sweep_key_cmp);
}

/* Exact SAH split of refs[begin, end): every position of a sort by centroid along
 * each axis. Returns 1 with s and *cost filled (count >= 2 always splits). */
static int split_sweep(Builder *bd, uint32_t begin, uint32_t end, const Box *bounds, Split *s,
                       float *cost)
{
    uint32_t n = end - begin;
    float area = box_half_area(bounds);
    float best = FLT_MAX;
    int best_axis = -1;
    uint32_t best_i = 0;
    for (int a = 0; a < 3; a++) {
        sweep_sort(bd, begin, end, a);
        Box acc;
        box_empty(&acc);
        for (uint32_t i = n - 1; i > 0; i--) {
            box_grow_ref(&acc, &bd->refs[bd->keys[i].ref]);
            bd->right_area[i] = box_half_area(&acc);
        }
        box_empty(&acc);
        for (uint32_t i = 1; i < n; i++) {
            box_grow_ref(&acc, &bd->refs[bd->keys[i - 1].ref]);
            float c = sah_split_cost(&bd->opt, area, box_half_area(&acc), i, bd->right_area[i], n - i);
            if (c < best) {
                best = c;
                best_axis = a;
                best_i = i;
            }
        }
    }
    if (best_axis < 0)
        return 0;
    sweep_sort(bd, begin, end, best_axis);
    for (uint32_t i = 0; i < n; i++)
        bd->tmp[i] = bd->refs[bd->keys[i].ref];
    memcpy(&bd->refs[begin], bd->tmp, n * sizeof *bd->tmp);
    s->mid = begin + best_i;
    refs_bounds(bd->refs, begin, s->mid, &s->lb, &s->lcb);
    refs_bounds(bd->refs, s->mid, end, &s->rb, &s->rcb);
    *cost = best;
    return 1;
}

/* Builds the subtree over refs[begin, end) (non-empty) into node idx; its
 * children, if any, become the next free (even-aligned) pair of nodes. */
static void build_node(Builder *bd, uint32_t idx, uint32_t begin, uint32_t end,
                       const Box *bounds, const Box *cb, uint32_t depth)
{
    BvhNode *node = &bd->nodes[idx];
    for (int a = 0; a < 3; a++) {
        node->lo[a] = bounds->lo[a];
        node->hi[a] = bounds->hi[a];
    }
    if (depth > bd->max_depth)
        bd->max_depth = depth;
    uint32_t count = end - begin;
    int leaf = count == 1;
    Split s;
    if (!leaf) {
        float cost = 0.0f;
        int ok = 0;
        if (depth < BVH_MEDIAN_DEPTH) {
            ok = bd->opt.full_sweep ? split_sweep(bd, begin, end, bounds, &s, &cost)
                                    : split_binned(bd, begin, end, bounds, cb, &s, &cost);
        }
        if ((int)count <= bd->opt.max_leaf && (!ok || bd->opt.cost_tri * count <= cost))
            leaf = 1;
        else if (!ok)
            split_median(bd, begin, end, cb, &s);
    }
    if (leaf) {
        node->offset = begin;
        node->count = BVH_LEAF_BIT | count;
        return;
    }
    node->count = 0;
    uint32_t pair = bd->node_count;
    bd->node_count += 2;
    node->offset = pair;
    build_node(bd, pair, begin, s.mid, &s.lb, &s.lcb, depth + 1);
    build_node(bd, pair + 1, s.mid, end, &s.rb, &s.rcb, depth + 1);
}

/* 1 when every coordinate is finite with magnitude below 1e18. */
static int tri_finite(const float *p)
{
    for (int i = 0; i < 9; i++) {
        if (!(fabsf(p[i]) < 1e18f))
            return 0;
    }
    return 1;
}

/* 1 when the cross product of the edges (in float, as the renderer computes a
 * geometric normal) is the zero vector. Inputs are finite and below 1e18, so it
 * cannot overflow. */
static int tri_zero_area(const float *p)
{
    float e1[3], e2[3];
    for (int a = 0; a < 3; a++) {
        e1[a] = p[3 + a] - p[a];
        e2[a] = p[6 + a] - p[a];
    }
    float nx = e1[1] * e2[2] - e1[2] * e2[1];
    float ny = e1[2] * e2[0] - e1[0] * e2[2];
    float nz = e1[0] * e2[1] - e1[1] * e2[0];
    return nx == 0.0f && ny == 0.0f && nz == 0.0f;
}

/* Area-weighted SAH cost, leaf statistics and memory use of a finished tree. */
static void bvh_compute_stats(Bvh *bvh, const BvhOptions *o)
{
    BvhStats *st = &bvh->stats;
    st->node_count = bvh->node_count;
    st->leaf_count = 0;
    st->max_leaf_size = 0;
    double cost = 0.0;
    Box root;
    memcpy(root.lo, bvh->nodes[0].lo, sizeof root.lo);
    memcpy(root.hi, bvh->nodes[0].hi, sizeof root.hi);
    double root_area = box_half_area(&root);
    for (uint32_t i = 0; i < bvh->node_count; i++) {
        const BvhNode *n = &bvh->nodes[i];
        Box b;
        memcpy(b.lo, n->lo, sizeof b.lo);
        memcpy(b.hi, n->hi, sizeof b.hi);
        double area = box_half_area(&b);
        if (n->count & BVH_LEAF_BIT) {
            uint32_t c = n->count & ~BVH_LEAF_BIT;
            st->leaf_count++;
            if (c > st->max_leaf_size)
                st->max_leaf_size = c;
            cost += area * o->cost_tri * c;
        } else {
            cost += area * o->cost_node;
        }
    }
    st->sah_cost = root_area > 0.0 ? cost / root_area : 0.0;
    st->avg_leaf_size = st->leaf_count ? (double)bvh->prim_count / st->leaf_count : 0.0;
    st->bytes_per_tri = bvh->prim_count
        ? (double)(bvh->node_count * sizeof(BvhNode) + bvh->tri_data_bytes) / bvh->prim_count
        : 0.0;
}

int bvh_build(Bvh *bvh, const float *tri_pos, uint32_t tri_count, SptError *e)
{
    return bvh_build_ex(bvh, tri_pos, tri_count, NULL, e);
}

int bvh_build_ex(Bvh *bvh, const float *tri_pos, uint32_t tri_count, const BvhOptions *opt,
                 SptError *e)
{
    double t0 = spt_now();
    memset(bvh, 0, sizeof *bvh);
    Builder bd;
    memset(&bd, 0, sizeof bd);
    bd.opt = opt ? *opt : bvh_default_options();
    if (bd.opt.bins < 2 || bd.opt.bins > BVH_MAX_BINS || bd.opt.max_leaf < 1 ||
        bd.opt.max_leaf > BVH_MAX_LEAF || !(bd.opt.cost_node > 0.0f) || !(bd.opt.cost_tri > 0.0f))
        return spt_fail(e, SPT_EXIT_USAGE, "bvh: invalid options (bins %d, max_leaf %d)",
                        bd.opt.bins, bd.opt.max_leaf);

    /* Keep the valid triangles as references with their bounds. */
    bd.refs = spt_malloc((tri_count ? tri_count : 1) * sizeof *bd.refs);
    uint32_t kept = 0;
    Box bounds, cb;
    box_empty(&bounds);
    box_empty(&cb);
    for (uint32_t i = 0; i < tri_count; i++) {
        const float *p = tri_pos + (size_t)i * 9;
        if (!tri_finite(p)) {
            bvh->stats.dropped_nonfinite++;
            continue;
        }
        if (tri_zero_area(p)) {
            bvh->stats.dropped_degenerate++;
            continue;
        }
        PrimRef *r = &bd.refs[kept++];
        for (int a = 0; a < 3; a++) {
            r->lo[a] = minf(minf(p[a], p[3 + a]), p[6 + a]);
            r->hi[a] = maxf(maxf(p[a], p[3 + a]), p[6 + a]);
        }
        r->id = i;
        r->pad = 0.0f;
        box_grow_ref(&bounds, r);
        box_grow_centroid(&cb, r);
    }
    bvh->stats.dropped = bvh->stats.dropped_nonfinite + bvh->stats.dropped_degenerate;
    if (kept > BVH_MAX_TRIS) {
        free(bd.refs);
        BvhStats st = bvh->stats;
        memset(bvh, 0, sizeof *bvh);
        bvh->stats = st;
        return spt_fail(e, SPT_EXIT_INPUT, "bvh: %u triangles, more than the %u supported",
                        kept, BVH_MAX_TRIS);
    }

    if (kept == 0) {
        /* One empty leaf; a dummy triangle and index keep the buffers non-empty. */
        bvh->nodes = spt_calloc(1, sizeof *bvh->nodes);
        bvh->nodes[0].count = BVH_LEAF_BIT;
        bvh->node_count = 1;
        bvh->tri_data = spt_calloc(1, sizeof(BvhTri));
        bvh->tri_data_bytes = sizeof(BvhTri);
        bvh->prim_index = spt_calloc(1, sizeof *bvh->prim_index);
        bvh->prim_count = 0;
    } else {
        /* Root at 0, an unused zeroed node at 1, then sibling pairs from 2. */
        bd.nodes = spt_calloc(2 * (size_t)kept, sizeof *bd.nodes);
        bd.node_count = 2;
        if (bd.opt.full_sweep) {
            bd.keys = spt_malloc(kept * sizeof *bd.keys);
            bd.right_area = spt_malloc(kept * sizeof *bd.right_area);
            bd.tmp = spt_malloc(kept * sizeof *bd.tmp);
        }
        build_node(&bd, 0, 0, kept, &bounds, &cb, 0);
        free(bd.keys);
        free(bd.right_area);
        free(bd.tmp);
        /* 64-byte aligned, so each sibling pair is one cache line. */
        size_t bytes = ((bd.node_count * sizeof(BvhNode) + 63) / 64) * 64;
        bvh->nodes = aligned_alloc(64, bytes);
        if (!bvh->nodes)
            bvh->nodes = spt_malloc(bytes);
        memcpy(bvh->nodes, bd.nodes, bd.node_count * sizeof *bd.nodes);
        free(bd.nodes);
        bvh->node_count = bd.node_count;
        BvhTri *tris = spt_malloc(kept * sizeof *tris);
        bvh->prim_index = spt_malloc(kept * sizeof *bvh->prim_index);
        for (uint32_t i = 0; i < kept; i++) {
            uint32_t id = bd.refs[i].id;
            bvh->prim_index[i] = id;
            memcpy(tris[i].v, tri_pos + (size_t)id * 9, sizeof tris[i].v);
        }
        bvh->tri_data = tris;
        bvh->tri_data_bytes = kept * sizeof *tris;
        bvh->prim_count = kept;
    }
    free(bd.refs);
    bvh->stats.max_depth = bd.max_depth;
    bvh_compute_stats(bvh, &bd.opt);
    bvh->stats.build_seconds = spt_now() - t0;
    return SPT_EXIT_OK;
}

void bvh_free(Bvh *bvh)
{
    if (!bvh)
        return;
    free(bvh->nodes);
    free(bvh->tri_data);
    free(bvh->prim_index);
    memset(bvh, 0, sizeof *bvh);
}

float *bvh_gen_sphere(uint32_t stacks, uint32_t slices, float radius, const float center[3],
                      float amplitude, uint32_t *tri_count)
{
    /* Vertex 0 = north pole, 1 = south pole, then ring r (0-based, north to
     * south), slice j at 2 + r * slices + j. */
    size_t nv = 2 + (size_t)stacks * slices;
    float *v = spt_malloc(nv * 3 * sizeof *v);
    for (int s = 0; s < 2; s++) {
        v[s * 3 + 0] = center[0];
        v[s * 3 + 1] = center[1];
        v[s * 3 + 2] = center[2] + (s ? -radius : radius);
    }
    for (uint32_t r = 0; r < stacks; r++) {
        double theta = M_PI * (r + 1) / (stacks + 1);
        for (uint32_t j = 0; j < slices; j++) {
            double phi = 2.0 * M_PI * j / slices;
            double rad = radius * (1.0 + amplitude * sin(6.0 * theta) * cos(9.0 * phi));
            float *p = v + (2 + (size_t)r * slices + j) * 3;
            p[0] = (float)(center[0] + rad * sin(theta) * cos(phi));
            p[1] = (float)(center[1] + rad * sin(theta) * sin(phi));
            p[2] = (float)(center[2] + rad * cos(theta));
        }
    }
    uint32_t nt = 2 * slices * stacks;
    float *t = spt_malloc((size_t)nt * 9 * sizeof *t);
    size_t k = 0;
#define RING(r, j) (2 + (size_t)(r) * slices + ((j) % slices))
#define EMIT(a, b, c)                                                                   \
    do {                                                                                \
        memcpy(t + k * 9 + 0, v + (a) * 3, 3 * sizeof *t);                              \
        memcpy(t + k * 9 + 3, v + (b) * 3, 3 * sizeof *t);                              \
        memcpy(t + k * 9 + 6, v + (c) * 3, 3 * sizeof *t);                              \
        k++;                                                                            \
    } while (0)
    for (uint32_t j = 0; j < slices; j++) {
        EMIT(0, RING(0, j), RING(0, j + 1));
        EMIT(1, RING(stacks - 1, j + 1), RING(stacks - 1, j));
        for (uint32_t r = 0; r + 1 < stacks; r++) {
            EMIT(RING(r, j), RING(r + 1, j), RING(r + 1, j + 1));
            EMIT(RING(r, j), RING(r + 1, j + 1), RING(r, j + 1));
        }
    }
#undef RING
#undef EMIT
    free(v);
    *tri_count = nt;
    return t;
}
