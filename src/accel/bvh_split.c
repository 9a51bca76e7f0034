/* The split searches of the BVH builder: binned SAH (the default), object median
 * (deep in the tree) and the exact full-sweep SAH (the quality reference). */
#include "accel/bvh_builder.h"

#include <float.h>
#include <stdlib.h>
#include <string.h>

/* Bounds and centroid bounds of refs[begin, end). */
void bvh_refs_bounds(const PrimRef *refs, uint32_t begin, uint32_t end, Box *b, Box *cb)
{
    L4 lo = l4_set1(FLT_MAX), hi = l4_set1(-FLT_MAX), clo = lo, chi = hi;
    for (uint32_t i = begin; i < end; i++) {
        L4 rl = l4_load(refs[i].lo), rh = l4_load(refs[i].hi), c = l4_add(rl, rh);
        lo = l4_min(lo, rl);
        hi = l4_max(hi, rh);
        clo = l4_min(clo, c);
        chi = l4_max(chi, c);
    }
    float t[4];
    l4_store(t, lo); memcpy(b->lo, t, sizeof b->lo);
    l4_store(t, hi); memcpy(b->hi, t, sizeof b->hi);
    l4_store(t, clo); memcpy(cb->lo, t, sizeof cb->lo);
    l4_store(t, chi); memcpy(cb->hi, t, sizeof cb->hi);
}

/* SAH cost of splitting a node of half area `area` into the two sides. */
static float sah_split_cost(const BvhOptions *o, float area, float la, uint32_t ln, float ra,
                            uint32_t rn)
{
    return o->cost_node + o->cost_tri * (la * (float)ln + ra * (float)rn) / area;
}

/* Refs binned at a large node (see bvh_split_binned). */
#define BVH_SAMPLE 1024u

/* Bin index along each axis of the doubled centroid lo + hi, by the one
 * expression that the binning and the partition share (so a ref's side always
 * matches the bins whose union became the child's bounds). */
static inline L4 bin_coord(L4 lo, L4 hi, L4 vmin, L4 vscale, L4 vlast)
{
    return l4_min(l4_mul(l4_sub(l4_add(lo, hi), vmin), vscale), vlast);
}

/* Per bin and axis: the bounds of the refs whose centroid falls in it, and
 * their number (lane 3 of n is 0). */
typedef struct BinSet {
    L4 lo[BVH_MAX_BINS][3], hi[BVH_MAX_BINS][3];
    uint32_t n[BVH_MAX_BINS][4];
} BinSet;

static void binset_clear(BinSet *b, int nb)
{
    const L4 empty_lo = l4_set1(FLT_MAX), empty_hi = l4_set1(-FLT_MAX);
    for (int k = 0; k < nb; k++) {
        for (int a = 0; a < 3; a++) {
            b->lo[k][a] = empty_lo;
            b->hi[k][a] = empty_hi;
        }
        memset(b->n[k], 0, sizeof b->n[k]);
    }
}

static inline void binset_add(BinSet *b, const PrimRef *r, L4 vmin, L4 vscale, L4 vlast)
{
    L4 lo = l4_load(r->lo), hi = l4_load(r->hi);
    int32_t k[3];
    l4_trunc3(bin_coord(lo, hi, vmin, vscale, vlast), k);
    for (int a = 0; a < 3; a++) {
        b->lo[k[a]][a] = l4_min(b->lo[k[a]][a], lo);
        b->hi[k[a]][a] = l4_max(b->hi[k[a]][a], hi);
        b->n[k[a]][a]++;
    }
}

/* Binned SAH split of refs[begin, end) (count >= 2) with bounds and centroid
 * bounds cb. Returns 1 with bs and *cost filled, or 0 when the centroids cannot
 * be told apart. */
int bvh_split_binned(Builder *bd, uint32_t begin, uint32_t end, const Box *bounds,
                        const Box *cb, BinSplit *bs, float *cost)
{
    /* Few bins for small nodes: there are many of them and little to gain. */
    uint32_t cnt = end - begin;
    int nb = cnt < 16 ? 4 : cnt < 64 ? 8 : bd->opt.bins;
    nb = nb < bd->opt.bins ? nb : bd->opt.bins;
    float scale[3];
    int usable = 0;
    for (int a = 0; a < 3; a++) {
        float ext = cb->hi[a] - cb->lo[a];
        float sc = ext > 0.0f ? (float)nb * 0.99999f / ext : 0.0f;
        scale[a] = sc < FLT_MAX ? sc : 0.0f; /* a subnormal extent cannot be binned */
        usable |= scale[a] > 0.0f;
    }
    if (!usable)
        return 0;
    const L4 vmin = l4_set3(cb->lo[0], cb->lo[1], cb->lo[2]);
    const L4 vscale = l4_set3(scale[0], scale[1], scale[2]);
    const L4 vlast = l4_set1((float)(nb - 1));
    const PrimRef *refs = bd->refs;
    BinSet bins[2];
    binset_clear(&bins[0], nb);
    /* Large nodes bin an evenly strided sample of about BVH_SAMPLE refs: it
     * places the plane as well as all of them would, and the partition then
     * measures the children's bounds exactly. */
    const uint32_t stride = cnt >= 2 * BVH_SAMPLE ? cnt / BVH_SAMPLE : 1;
    if (cnt >= 64) {
        /* Neighbouring refs tend to share bins; alternating two sets halves the
         * chains of dependent updates through memory. */
        binset_clear(&bins[1], nb);
        uint32_t i = begin;
        for (; i + stride < end; i += 2 * stride) {
            binset_add(&bins[0], &refs[i], vmin, vscale, vlast);
            binset_add(&bins[1], &refs[i + stride], vmin, vscale, vlast);
        }
        if (i < end)
            binset_add(&bins[0], &refs[i], vmin, vscale, vlast);
        for (int k = 0; k < nb; k++) {
            for (int a = 0; a < 3; a++) {
                bins[0].lo[k][a] = l4_min(bins[0].lo[k][a], bins[1].lo[k][a]);
                bins[0].hi[k][a] = l4_max(bins[0].hi[k][a], bins[1].hi[k][a]);
                bins[0].n[k][a] += bins[1].n[k][a];
            }
        }
    } else {
        for (uint32_t i = begin; i < end; i++)
            binset_add(&bins[0], &refs[i], vmin, vscale, vlast);
    }
    const BinSet *b = &bins[0];
    /* Sweep the three axes at once (lane a = axis a): right-side areas and
     * counts from the end, then the left side. The cost compared is
     * area_l n_l + area_r n_r, the SAH cost up to constants. */
    L4 rarea[BVH_MAX_BINS], rcount[BVH_MAX_BINS];
    const L4 empty_lo = l4_set1(FLT_MAX), empty_hi = l4_set1(-FLT_MAX), zero = l4_set1(0.0f);
    L4 alo[3] = {empty_lo, empty_lo, empty_lo}, ahi[3] = {empty_hi, empty_hi, empty_hi};
    uint32_t n[3] = {0, 0, 0};
    for (int k = nb - 1; k > 0; k--) {
        for (int a = 0; a < 3; a++) {
            alo[a] = l4_min(alo[a], b->lo[k][a]);
            ahi[a] = l4_max(ahi[a], b->hi[k][a]);
            n[a] += b->n[k][a];
        }
        rarea[k] = l4_half_area3(alo, ahi);
        rcount[k] = l4_set3((float)n[0], (float)n[1], (float)n[2]);
    }
    for (int a = 0; a < 3; a++) {
        alo[a] = empty_lo;
        ahi[a] = empty_hi;
        n[a] = 0;
    }
    L4 best = l4_set1(FLT_MAX), best_k = zero;
    for (int k = 0; k < nb - 1; k++) {
        for (int a = 0; a < 3; a++) {
            alo[a] = l4_min(alo[a], b->lo[k][a]);
            ahi[a] = l4_max(ahi[a], b->hi[k][a]);
            n[a] += b->n[k][a];
        }
        L4 lcount = l4_set3((float)n[0], (float)n[1], (float)n[2]);
        L4 c = l4_add(l4_mul(l4_half_area3(alo, ahi), lcount), l4_mul(rarea[k + 1], rcount[k + 1]));
        /* Both sides non-empty and cheaper (the first of equal costs wins). */
        L4 better = l4_and(l4_and(l4_lt(zero, lcount), l4_lt(zero, rcount[k + 1])), l4_lt(c, best));
        best = l4_select(better, c, best);
        best_k = l4_select(better, l4_set1((float)k), best_k);
    }
    float bc[4], bk[4];
    l4_store(bc, best);
    l4_store(bk, best_k);
    int a = -1;
    for (int ax = 0; ax < 3; ax++) {
        if (bc[ax] < FLT_MAX && (a < 0 || bc[ax] < bc[a]))
            a = ax;
    }
    if (a < 0)
        return 0;
    const int best_k_a = (int)bk[a];
    bs->axis = a;
    bs->k = best_k_a;
    bs->nb = nb;
    bs->cmin = cb->lo[a];
    bs->scale = scale[a];
    *cost = bd->opt.cost_node + bd->opt.cost_tri * bc[a] / box_half_area(bounds);
    return 1;
}

/* Partitions refs[begin, end) by bs and sets s->mid. Branch-free (Lomuto):
 * which side a ref goes to is hard to predict once the order no longer follows
 * the split axis. Returns 1 when both sides are non-empty (always, when bs came
 * from bvh_split_binned on this range). */
int bvh_partition_binned(Builder *bd, uint32_t begin, uint32_t end, const BinSplit *bs,
                            Split *s)
{
    PrimRef *refs = bd->refs;
    const int a = bs->axis;
    /* Lane a of the binning's bin_coord before its clamp, and 0 in the other
     * lanes; a ref goes left when its bin, trunc(min(x, nb - 1)), is <= k,
     * that is when x < k + 1 (x >= 0, k + 1 <= nb - 1). */
    float m3[3] = {0.0f, 0.0f, 0.0f}, s3[3] = {0.0f, 0.0f, 0.0f};
    m3[a] = bs->cmin;
    s3[a] = bs->scale;
    const L4 vmin = l4_set3(m3[0], m3[1], m3[2]), vscale = l4_set3(s3[0], s3[1], s3[2]);
    const L4 vk1 = l4_set1((float)(bs->k + 1));
    uint32_t l = begin;
    for (uint32_t i = begin; i < end; i++) {
        /* Whole refs move as two raw 16-byte halves (the id rides in lane 3). */
        L4 r0 = l4_loadu(refs[i].lo), r1 = l4_loadu(refs[i].hi);
        L4 c = l4_add(l4_clear3(r0), l4_clear3(r1));
        int left = l4_all_lt(l4_mul(l4_sub(c, vmin), vscale), vk1);
        l4_storeu(refs[i].lo, l4_loadu(refs[l].lo));
        l4_storeu(refs[i].hi, l4_loadu(refs[l].hi));
        l4_storeu(refs[l].lo, r0);
        l4_storeu(refs[l].hi, r1);
        l += (uint32_t)left;
    }
    s->mid = l;
    return l > begin && l < end;
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
void bvh_split_median(Builder *bd, uint32_t begin, uint32_t end, const Box *cb, Split *s)
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
int bvh_split_sweep(Builder *bd, uint32_t begin, uint32_t end, const Box *bounds, Split *s,
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
    *cost = best;
    return 1;
}
