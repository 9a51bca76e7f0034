/* Binned SAH BVH builder (Wald 2007, "On fast Construction of SAH-based Bounding
 * Volume Hierarchies") into the flat 8-wide layout of kernels/shared/bvh.h, with an
 * exact full-sweep SAH builder as a quality reference. The binary SAH tree is
 * decided top down and its nodes gathered into 8-wide nodes as it goes; it is
 * never stored. One thread, SSE where available: about 7 million triangles per
 * second of one core on the bench's 1M-triangle mesh (default options). */
#include "accel/bvh_build.h"

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

/* 4-lane float vectors for the binning hot loops: SSE where the compiler offers
 * it (every x86-64), plain arrays elsewhere; both give the same results, lane by
 * lane, since each lane is one IEEE operation. Lane 3 is don't-care. */
#ifdef __SSE2__
typedef __m128 L4;
/* Lanes 0..2 of p; lane 3 (a PrimRef's id bits, maybe a denormal or NaN as a
 * float) reads as 0, so it never slows or poisons the arithmetic. */
static inline L4 l4_load(const float *p)
{
    return _mm_and_ps(_mm_loadu_ps(p), _mm_castsi128_ps(_mm_setr_epi32(-1, -1, -1, 0)));
}
static inline L4 l4_set1(float a) { return _mm_set1_ps(a); }
static inline L4 l4_set3(float a, float b, float c) { return _mm_setr_ps(a, b, c, 0.0f); }
static inline L4 l4_add(L4 a, L4 b) { return _mm_add_ps(a, b); }
static inline L4 l4_sub(L4 a, L4 b) { return _mm_sub_ps(a, b); }
static inline L4 l4_mul(L4 a, L4 b) { return _mm_mul_ps(a, b); }
static inline L4 l4_min(L4 a, L4 b) { return _mm_min_ps(a, b); }
static inline L4 l4_max(L4 a, L4 b) { return _mm_max_ps(a, b); }
/* Truncates lanes 0..2 (non-negative, < 2^31) to integers. */
static inline void l4_trunc3(L4 a, int32_t k[3])
{
    __m128i i = _mm_cvttps_epi32(a);
    k[0] = _mm_cvtsi128_si32(i);
    k[1] = _mm_cvtsi128_si32(_mm_shuffle_epi32(i, _MM_SHUFFLE(1, 1, 1, 1)));
    k[2] = _mm_cvtsi128_si32(_mm_shuffle_epi32(i, _MM_SHUFFLE(2, 2, 2, 2)));
}
/* Half the surface area of the box [lo, hi] (lanes 0..2), which must not be empty. */
static inline float l4_half_area(L4 lo, L4 hi)
{
    __m128 d = _mm_sub_ps(hi, lo);
    __m128 p = _mm_mul_ps(d, _mm_shuffle_ps(d, d, _MM_SHUFFLE(3, 0, 2, 1)));
    return _mm_cvtss_f32(_mm_add_ss(_mm_add_ss(p, _mm_shuffle_ps(p, p, 1)),
                                    _mm_shuffle_ps(p, p, 2)));
}
static inline void l4_store(float *p, L4 a) { _mm_storeu_ps(p, a); }
static inline L4 l4_abs(L4 a) { return _mm_and_ps(a, _mm_castsi128_ps(_mm_set1_epi32(0x7fffffff))); }
/* (a1, a2, a3, a3). */
static inline L4 l4_shift_down(L4 a) { return _mm_shuffle_ps(a, a, _MM_SHUFFLE(3, 3, 2, 1)); }
/* Raw 16-byte moves (lane 3 included, bit for bit) and lane 3 cleared. */
static inline L4 l4_loadu(const void *p) { return _mm_loadu_ps((const float *)p); }
static inline void l4_storeu(void *p, L4 a) { _mm_storeu_ps((float *)p, a); }
static inline L4 l4_clear3(L4 a) { return _mm_and_ps(a, _mm_castsi128_ps(_mm_setr_epi32(-1, -1, -1, 0))); }
/* 1 when a < b in every lane. */
static inline int l4_all_lt(L4 a, L4 b) { return _mm_movemask_ps(_mm_cmplt_ps(a, b)) == 15; }
/* Masks: all ones in the lanes where a < b. */
static inline L4 l4_lt(L4 a, L4 b) { return _mm_cmplt_ps(a, b); }
static inline L4 l4_and(L4 a, L4 b) { return _mm_and_ps(a, b); }
/* Lanes of a where m is all ones, of b where it is zero. */
static inline L4 l4_select(L4 m, L4 a, L4 b) { return _mm_or_ps(_mm_and_ps(m, a), _mm_andnot_ps(m, b)); }
static inline L4 l4_mask(int on) { return _mm_castsi128_ps(_mm_set1_epi32(-on)); }
/* The half areas of three boxes (lo[i], hi[i]) in lanes 0..2. */
static inline L4 l4_half_area3(const L4 lo[3], const L4 hi[3])
{
    __m128 x = _mm_sub_ps(hi[0], lo[0]), y = _mm_sub_ps(hi[1], lo[1]);
    __m128 z = _mm_sub_ps(hi[2], lo[2]), w = _mm_setzero_ps();
    _MM_TRANSPOSE4_PS(x, y, z, w);
    return _mm_add_ps(_mm_add_ps(_mm_mul_ps(x, y), _mm_mul_ps(y, z)), _mm_mul_ps(z, x));
}
#else
typedef struct L4 {
    float f[4];
} L4;
static inline L4 l4_load(const float *p) { L4 r = {{p[0], p[1], p[2], 0.0f}}; return r; }
static inline L4 l4_set1(float a) { L4 r = {{a, a, a, a}}; return r; }
static inline L4 l4_set3(float a, float b, float c) { L4 r = {{a, b, c, 0.0f}}; return r; }
#define L4_OP(name, expr)                                                 \
    static inline L4 name(L4 a, L4 b)                                     \
    {                                                                     \
        L4 r;                                                             \
        for (int i = 0; i < 4; i++) r.f[i] = (expr);                      \
        return r;                                                         \
    }
L4_OP(l4_add, a.f[i] + b.f[i])
L4_OP(l4_sub, a.f[i] - b.f[i])
L4_OP(l4_mul, a.f[i] * b.f[i])
L4_OP(l4_min, a.f[i] < b.f[i] ? a.f[i] : b.f[i])
L4_OP(l4_max, a.f[i] > b.f[i] ? a.f[i] : b.f[i])
static inline void l4_trunc3(L4 a, int32_t k[3])
{
    for (int i = 0; i < 3; i++) k[i] = (int32_t)a.f[i];
}
static inline float l4_half_area(L4 lo, L4 hi)
{
    float dx = hi.f[0] - lo.f[0], dy = hi.f[1] - lo.f[1], dz = hi.f[2] - lo.f[2];
    return dx * dy + dy * dz + dz * dx;
}
static inline void l4_store(float *p, L4 a) { memcpy(p, a.f, sizeof a.f); }
static inline L4 l4_loadu(const void *p) { L4 r; memcpy(r.f, p, sizeof r.f); return r; }
static inline L4 l4_shift_down(L4 a) { L4 r = {{a.f[1], a.f[2], a.f[3], a.f[3]}}; return r; }
static inline L4 l4_abs(L4 a)
{
    for (int i = 0; i < 4; i++) a.f[i] = fabsf(a.f[i]);
    return a;
}
static inline void l4_storeu(void *p, L4 a) { memcpy(p, a.f, sizeof a.f); }
static inline L4 l4_clear3(L4 a) { a.f[3] = 0.0f; return a; }
static inline int l4_all_lt(L4 a, L4 b)
{
    return a.f[0] < b.f[0] && a.f[1] < b.f[1] && a.f[2] < b.f[2] && a.f[3] < b.f[3];
}
/* Masks are lanes of 1 (on) or 0 (off) here. */
L4_OP(l4_lt, a.f[i] < b.f[i] ? 1.0f : 0.0f)
L4_OP(l4_and, a.f[i] != 0.0f && b.f[i] != 0.0f ? 1.0f : 0.0f)
#undef L4_OP
static inline L4 l4_select(L4 m, L4 a, L4 b)
{
    L4 r;
    for (int i = 0; i < 4; i++) r.f[i] = m.f[i] != 0.0f ? a.f[i] : b.f[i];
    return r;
}
static inline L4 l4_mask(int on) { return l4_set1(on ? 1.0f : 0.0f); }
static inline L4 l4_half_area3(const L4 lo[3], const L4 hi[3])
{
    L4 r = l4_set1(0.0f);
    for (int i = 0; i < 3; i++) r.f[i] = l4_half_area(lo[i], hi[i]);
    return r;
}
#endif

typedef struct Box {
    float lo[3], hi[3];
} Box;

/* A chosen split of refs[begin, end): [begin, mid) left, [mid, end) right. */
typedef struct Split {
    uint32_t mid;
} Split;

typedef struct SweepKey {
    float key;
    uint32_t id;
    uint32_t ref; /* position in refs */
} SweepKey;

/* A node of the binary SAH tree, decided but not stored: its refs [begin, end),
 * its bounds, and unless it is a leaf the split point mid (the refs are already
 * partitioned). The 8-wide nodes are made from these as the build goes. */
typedef struct Item {
    uint32_t begin, end, mid;
    uint32_t depth; /* in the binary tree, root = 0 */
    int leaf;
    Box bounds;
} Item;

typedef struct Builder {
    PrimRef *refs;
    BvhNode *wide;      /* the 8-wide nodes made so far */
    uint32_t wide_count, wide_cap;
    double sah;         /* the binary tree's SAH cost times its root's area */
    BvhStats *st;
    BvhOptions opt;
    /* full-sweep scratch, sized for all refs */
    SweepKey *keys;
    float *right_area;
    PrimRef *tmp;
    uint32_t *leaf_slot; /* per ref: at a leaf's first ref, node * BVH_WIDTH + slot + 1 of
                            the leaf, else 0 */
    const float *tri_pos; /* the input triangles */
} Builder;

BvhOptions bvh_default_options(void)
{
    BvhOptions o;
    o.bins = 16;
    /* A CPU device with AVX-512 tests all of a leaf's triangles (up to 16)
     * with one 16-lane test (kernels/shared/bvh.h), and a node visit costs about one
     * such test; leaves of up to 16 at a node cost of 16 made the fastest trees
     * on PoCL (measured with the earlier two float8 tests per leaf). On the
     * bench's 1M-triangle mesh, against leaves of at most 8 at a node cost of 2
     * (this builder's earlier setting): leaves of 11.4 triangles instead of 3,
     * fewer bytes per triangle, faster builds, and extend ~12% less CPU time
     * than at 8/8 (the Cornell box's stages unchanged). A GPU loops over a leaf
     * and pays for the larger leaves. */
    o.max_leaf = 16;
    o.full_sweep = 0;
    o.cost_node = 16.0f;
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

static void box_grow_ref(Box *b, const PrimRef *r)
{
    for (int a = 0; a < 3; a++) {
        b->lo[a] = minf(b->lo[a], r->lo[a]);
        b->hi[a] = maxf(b->hi[a], r->hi[a]);
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

/* A binned SAH split of refs[begin, end): the centroid bins along axis ... <= k
 * go left. */
typedef struct BinSplit {
    int axis, k, nb;
    float cmin, scale; /* bin of a ref = min((centroid - cmin) * scale, nb - 1) */
} BinSplit;

/* Refs binned at a large node (see split_binned). */
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
static int split_binned(Builder *bd, uint32_t begin, uint32_t end, const Box *bounds,
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
 * from split_binned on this range). */
static int partition_binned(Builder *bd, uint32_t begin, uint32_t end, const BinSplit *bs,
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
    *cost = best;
    return 1;
}

/* The distinct vertices (by their exact coordinates) of the triangles of
 * refs[begin, end) into verts (3 floats each), and into corner[3 l + c] the
 * vertex of corner c of triangle begin + l; stops counting at
 * BVH_LEAF_VERTS + 1. Each vertex is compared with all 16 slots at once (a loop
 * the compiler vectorises). */
static uint32_t leaf_vertices(const Builder *bd, uint32_t begin, uint32_t end, float *verts,
                              uint8_t *corner)
{
    uint32_t ux[BVH_LEAF_VERTS] = {0}, uy[BVH_LEAF_VERTS] = {0}, uz[BVH_LEAF_VERTS] = {0};
    uint32_t nv = 0, used = 0; /* used: bit k set for the filled slots */
    for (uint32_t i = begin; i < end; i++) {
        const float *p = bd->tri_pos + (size_t)bd->refs[i].id * 9;
        for (int c = 0; c < 3; c++, p += 3) {
            uint32_t x, y, z;
            memcpy(&x, p, 4);
            memcpy(&y, p + 1, 4);
            memcpy(&z, p + 2, 4);
            uint32_t match = 0;
#if defined(__SSE2__)
            __m128i vx = _mm_set1_epi32((int)x), vy = _mm_set1_epi32((int)y), vz = _mm_set1_epi32((int)z);
            for (uint32_t k = 0; k < nv; k += 4) {
                __m128i e = _mm_and_si128(
                    _mm_and_si128(_mm_cmpeq_epi32(_mm_loadu_si128((const __m128i *)(ux + k)), vx),
                                  _mm_cmpeq_epi32(_mm_loadu_si128((const __m128i *)(uy + k)), vy)),
                    _mm_cmpeq_epi32(_mm_loadu_si128((const __m128i *)(uz + k)), vz));
                match |= (uint32_t)_mm_movemask_ps(_mm_castsi128_ps(e)) << k;
            }
#else
            for (uint32_t k = 0; k < BVH_LEAF_VERTS; k++)
                match |= (uint32_t)((ux[k] == x) & (uy[k] == y) & (uz[k] == z)) << k;
#endif
            match &= used;
            if (!match) {
                if (nv == BVH_LEAF_VERTS)
                    return BVH_LEAF_VERTS + 1;
                ux[nv] = x;
                uy[nv] = y;
                uz[nv] = z;
                memcpy(verts + 3 * nv, p, 3 * sizeof *p);
                used |= 1u << nv;
                match = 1u << nv++;
            }
            corner[3 * (i - begin) + c] = (uint8_t)__builtin_ctz(match);
        }
    }
    return nv;
}

/* Decides the binary node over refs[begin, end) (non-empty) at binary depth
 * depth: its bounds, and whether it is a leaf or where it splits (partitioning
 * the refs). Adds its term to the SAH cost. */
static void decide(Builder *bd, uint32_t begin, uint32_t end, uint32_t depth, Item *it)
{
    Box cb;
    refs_bounds(bd->refs, begin, end, &it->bounds, &cb);
    it->begin = begin;
    it->end = end;
    it->mid = 0;
    it->depth = depth;
    uint32_t count = end - begin;
    const float area = box_half_area(&it->bounds);
    /* A split costs at least cost_node, so a node whose triangles cost no more
     * is a leaf without looking for one. */
    int leaf = count == 1 || ((int)count <= bd->opt.max_leaf &&
                              bd->opt.cost_tri * (float)count <= bd->opt.cost_node);
    if (!leaf && (int)count <= bd->opt.max_leaf) {
        /* Each child box holds its triangles' boxes, so a split costs at least
         * cost_node + cost_tri * (sum of their areas) / area: when that is no
         * cheaper than a leaf, skip the search. */
        float sum = 0.0f;
        for (uint32_t i = begin; i < end; i++)
            sum += l4_half_area(l4_load(bd->refs[i].lo), l4_load(bd->refs[i].hi));
        leaf = bd->opt.cost_tri * (float)count <=
               bd->opt.cost_node + bd->opt.cost_tri * sum / area;
    }
    Split s = {0};
    if (!leaf) {
        float cost = 0.0f;
        int ok = 0;
        BinSplit bs;
        if (depth < BVH_MEDIAN_DEPTH) {
            ok = bd->opt.full_sweep ? split_sweep(bd, begin, end, &it->bounds, &s, &cost)
                                    : split_binned(bd, begin, end, &it->bounds, &cb, &bs, &cost);
        }
        if ((int)count <= bd->opt.max_leaf && (!ok || bd->opt.cost_tri * (float)count <= cost))
            leaf = 1;
        else if (ok && !bd->opt.full_sweep)
            ok = partition_binned(bd, begin, end, &bs, &s);
        if (!leaf && !ok)
            split_median(bd, begin, end, &cb, &s);
    }
    it->leaf = leaf;
    it->mid = s.mid;
    bd->sah += (double)area * (leaf ? bd->opt.cost_tri * (double)count : bd->opt.cost_node);
}

/* Index of a new 8-wide node (the array grows by doubling). */
static uint32_t wide_new(Builder *bd)
{
    if (bd->wide_count == bd->wide_cap) {
        uint32_t cap = bd->wide_cap * 2;
        BvhNode *w = aligned_alloc(64, (size_t)cap * sizeof *w);
        if (!w)
            w = spt_malloc((size_t)cap * sizeof *w);
        memcpy(w, bd->wide, (size_t)bd->wide_count * sizeof *w);
        free(bd->wide);
        bd->wide = w;
        bd->wide_cap = cap;
    }
    return bd->wide_count++;
}

/* Fills slot i of 8-wide node w with item it (NULL: unused). */
static void wide_slot(Builder *bd, uint32_t w, int i, const Item *it)
{
    BvhNode *node = &bd->wide[w];
    for (int a = 0; a < 3; a++) {
        node->bounds[2 * a][i] = it ? it->bounds.lo[a] : FLT_MAX;
        node->bounds[2 * a + 1][i] = it ? it->bounds.hi[a] : -FLT_MAX;
    }
    node->child[i] = it && it->leaf ? it->begin : 0;
    node->count[i] = it && it->leaf ? it->end - it->begin : 0;
    if (it && it->leaf) {
        bd->leaf_slot[it->begin] = w * BVH_WIDTH + (uint32_t)i + 1;
        bd->st->leaf_count++;
    }
}

/* Builds 8-wide node w (at depth wdepth) for the interior binary node it: the
 * slots start as its two children, and the interior slot of largest area
 * (ties: the fewest binary levels down) is replaced by its two children while
 * there is room. Then the interior slots are built the same way. */
static void build_wide(Builder *bd, uint32_t w, const Item *it, uint32_t wdepth)
{
    Item slot[BVH_WIDTH];
    int gen[BVH_WIDTH] = {0};
    int n = 2;
    decide(bd, it->begin, it->mid, it->depth + 1, &slot[0]);
    decide(bd, it->mid, it->end, it->depth + 1, &slot[1]);
    while (n < BVH_WIDTH) {
        int pick = -1;
        float pick_area = -1.0f;
        for (int i = 0; i < n; i++) {
            if (slot[i].leaf)
                continue;
            float area = box_half_area(&slot[i].bounds);
            if (area > pick_area || (area == pick_area && gen[i] < gen[pick])) {
                pick_area = area;
                pick = i;
            }
        }
        if (pick < 0)
            break;
        Item p = slot[pick];
        decide(bd, p.begin, p.mid, p.depth + 1, &slot[pick]);
        decide(bd, p.mid, p.end, p.depth + 1, &slot[n]);
        gen[n++] = ++gen[pick];
    }
    if (wdepth > bd->st->max_depth)
        bd->st->max_depth = wdepth;
    uint32_t child[BVH_WIDTH];
    for (int i = 0; i < BVH_WIDTH; i++) {
        child[i] = i < n && !slot[i].leaf ? wide_new(bd) : 0;
        wide_slot(bd, w, i, i < n ? &slot[i] : NULL);
        bd->wide[w].child[i] = i < n && !slot[i].leaf ? child[i] : bd->wide[w].child[i];
    }
    for (int i = 0; i < n; i++) {
        if (!slot[i].leaf)
            build_wide(bd, child[i], &slot[i], wdepth + 1);
    }
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

/* Writes the block of the leaf refs[first, first + n) with its nv distinct
 * vertices v (kernels/shared/bvh.h) at word *words of tris, and points slot c of
 * node k at it. */
static void write_block(Builder *bd, Bvh *bvh, uint32_t k, int c, uint32_t first, uint32_t n,
                        const float *v, uint32_t nv, const uint8_t *corner, float *tris,
                        size_t *words)
{
    float *p = tris + *words;
    union { float f; uint32_t u; } w;
    w.u = first;
    p[0] = w.f;
    w.u = nv | n << 8;
    p[1] = w.f;
    for (uint32_t j = 0; j < nv; j++)
        for (int a = 0; a < 3; a++)
            p[2 + a * nv + j] = v[3 * j + a];
    uint8_t *idx = (uint8_t *)(p + 2 + 3 * nv);
    memset(idx, 0, 4 * ((3 * n + 3) / 4));
    for (uint32_t l = 0; l < n; l++) {
        bvh->prim_index[first + l] = bd->refs[first + l].id;
        bvh->tri_leaf[first + l] = (uint32_t)*words;
        for (uint32_t j = 0; j < 3; j++)
            idx[j * n + l] = corner[3 * l + j];
    }
    bd->wide[k].child[c] = (uint32_t)*words;
    bd->wide[k].count[c] = n | nv << 8;
    *words += bvh_leaf_words(n, nv);
}

/* Packs the leaf in slot c of node k (at depth k_depth). A leaf with more than
 * BVH_LEAF_VERTS distinct vertices (triangles that share few, as in a triangle
 * soup) is replaced by a new node whose leaves are runs of its triangles that
 * fit. */
static void pack_leaf(Builder *bd, Bvh *bvh, uint32_t k, int c, uint32_t k_depth, float *tris,
                      size_t *words)
{
    uint32_t first = bd->wide[k].child[c], n = bd->wide[k].count[c];
    float v[3 * BVH_LEAF_VERTS];
    uint8_t corner[3 * BVH_LEAF_MAX];
    uint32_t nv = leaf_vertices(bd, first, first + n, v, corner);
    if (nv <= BVH_LEAF_VERTS) {
        write_block(bd, bvh, k, c, first, n, v, nv, corner, tris, words);
        return;
    }
    /* Runs of at least five triangles (at most 15 vertices), so at most four. */
    uint32_t node = wide_new(bd);
    for (int i = 0; i < BVH_WIDTH; i++)
        wide_slot(bd, node, i, NULL);
    bd->wide[k].child[c] = node;
    bd->wide[k].count[c] = 0;
    bd->st->leaf_count--;
    if (k_depth + 1 > bd->st->max_depth)
        bd->st->max_depth = k_depth + 1;
    int slot = 0;
    for (uint32_t b = first, end = first + n; b < end; slot++) {
        uint32_t e = b + 1;
        while (e < end && leaf_vertices(bd, b, e + 1, v, corner) <= BVH_LEAF_VERTS)
            e++;
        Item it;
        memset(&it, 0, sizeof it);
        Box cb;
        refs_bounds(bd->refs, b, e, &it.bounds, &cb);
        it.begin = b;
        it.end = e;
        it.leaf = 1;
        wide_slot(bd, node, slot, &it);
        nv = leaf_vertices(bd, b, e, v, corner);
        write_block(bd, bvh, node, slot, b, e - b, v, nv, corner, tris, words);
        b = e;
    }
}

/* Leaf size average and memory use of a finished tree. */
static void bvh_finish_stats(Bvh *bvh)
{
    BvhStats *st = &bvh->stats;
    st->node_count = bvh->node_count;
    /* of the leaves as packed (a soup's leaves split into runs) */
    st->max_leaf_size = 0;
    for (uint32_t k = 0; k < bvh->node_count; k++)
        for (int c = 0; c < BVH_WIDTH; c++)
            if ((bvh->nodes[k].count[c] & 255) > st->max_leaf_size)
                st->max_leaf_size = bvh->nodes[k].count[c] & 255;
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
    for (uint32_t i = 0; i < tri_count; i++) {
        const float *p = tri_pos + (size_t)i * 9;
        /* Lanes 0..2 of (p[0..3]), (p[3..6]) and (p[5..8] shifted down one)
         * are the three vertices; nothing past p[8] is read. */
        L4 v0 = l4_loadu(p), v1 = l4_loadu(p + 3), v2 = l4_shift_down(l4_loadu(p + 5));
        const L4 big = l4_set1(1e18f);
        /* Every coordinate finite with magnitude below 1e18 (NaN compares
         * false). */
        if (!(l4_all_lt(l4_abs(v0), big) && l4_all_lt(l4_abs(v1), big) &&
              l4_all_lt(l4_abs(v2), big))) {
            bvh->stats.dropped_nonfinite++;
            continue;
        }
        if (tri_zero_area(p)) {
            bvh->stats.dropped_degenerate++;
            continue;
        }
        PrimRef *r = &bd.refs[kept++];
        l4_storeu(r->lo, l4_min(l4_min(v0, v1), v2));
        l4_storeu(r->hi, l4_max(l4_max(v0, v1), v2));
        r->id = i;
        r->pad = 0.0f;
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
        /* A root with no children; a dummy triangle and index keep the buffers
         * non-empty. */
        bvh->nodes = spt_calloc(1, sizeof *bvh->nodes);
        for (int i = 0; i < BVH_WIDTH; i++) {
            for (int a = 0; a < 3; a++) {
                bvh->nodes[0].bounds[2 * a][i] = FLT_MAX;
                bvh->nodes[0].bounds[2 * a + 1][i] = -FLT_MAX;
            }
        }
        bvh->node_count = 1;
        bvh->tri_data_bytes = (2 + BVH_TRI_PAD) * sizeof(float);
        bvh->tri_data = spt_calloc(1, bvh->tri_data_bytes);
        bvh->tri_leaf = spt_calloc(1, sizeof *bvh->tri_leaf);
        bvh->prim_index = spt_calloc(1, sizeof *bvh->prim_index);
        bvh->prim_count = 0;
    } else {
        if (bd.opt.full_sweep) {
            bd.keys = spt_malloc(kept * sizeof *bd.keys);
            bd.right_area = spt_malloc(kept * sizeof *bd.right_area);
            bd.tmp = spt_malloc(kept * sizeof *bd.tmp);
        }
        /* About one 8-wide node per 32 triangles with the default options; the
         * array doubles when a tree needs more. 64-byte aligned, so a node is
         * four cache lines. Pages past the last node are never touched. */
        bd.wide_cap = kept / 8 + 16;
        bd.wide = aligned_alloc(64, (size_t)bd.wide_cap * sizeof *bd.wide);
        if (!bd.wide)
            bd.wide = spt_malloc((size_t)bd.wide_cap * sizeof *bd.wide);
        bd.st = &bvh->stats;
        bd.leaf_slot = spt_calloc(kept, sizeof *bd.leaf_slot);
        bd.tri_pos = tri_pos;
        Item root;
        decide(&bd, 0, kept, 0, &root);
        uint32_t w = wide_new(&bd);
        if (root.leaf) {
            /* The whole tree is one leaf: slot 0 of the root. */
            for (int i = 0; i < BVH_WIDTH; i++)
                wide_slot(&bd, w, i, i == 0 ? &root : NULL);
        } else {
            build_wide(&bd, w, &root, 0);
        }
        float root_area = box_half_area(&root.bounds);
        bvh->stats.sah_cost = root_area > 0.0f ? bd.sah / root_area : 0.0;
        free(bd.keys);
        free(bd.right_area);
        free(bd.tmp);
        /* Each leaf as a block of its distinct vertices and their indices
         * (kernels/shared/bvh.h), in node order. A block takes at most 12 n words. */
        size_t cap = (size_t)kept * 12 + BVH_TRI_PAD;
        float *tris = spt_malloc(cap * sizeof *tris);
        bvh->prim_index = spt_malloc(kept * sizeof *bvh->prim_index);
        bvh->tri_leaf = spt_malloc(kept * sizeof *bvh->tri_leaf);
        size_t words = 0;
        bvh->prim_count = kept;
        /* Node depths (a child's index is above its parent's), for the nodes
         * pack_leaf appends. */
        uint8_t *depth = spt_calloc(bd.wide_count, 1);
        for (uint32_t k = 0; k < bd.wide_count; k++)
            for (int c = 0; c < BVH_WIDTH; c++)
                if (!bd.wide[k].count[c] && bd.wide[k].child[c])
                    depth[bd.wide[k].child[c]] = (uint8_t)(depth[k] + 1);
        /* The leaves in triangle order, so their blocks lie in that order and
         * the gather from tri_pos can be asked for ahead. */
        for (uint32_t i = 0; i < kept;) {
            uint32_t ks = bd.leaf_slot[i] - 1, k = ks / BVH_WIDTH, n = bd.wide[k].count[ks % BVH_WIDTH];
            for (uint32_t j = i + 32; j < i + 32 + n && j < kept; j++)
                __builtin_prefetch(tri_pos + (size_t)bd.refs[j].id * 9);
            pack_leaf(&bd, bvh, k, (int)(ks % BVH_WIDTH), depth[k], tris, &words);
            i += n;
        }
        free(depth);
        memset(tris + words, 0, BVH_TRI_PAD * sizeof *tris);
        words += BVH_TRI_PAD;
        float *shrunk = realloc(tris, words * sizeof *tris);
        tris = shrunk ? shrunk : tris;
        bvh->nodes = bd.wide;
        bvh->node_count = bd.wide_count;
        size_t nf = words;
        free(bd.leaf_slot);
        bvh->tri_data = tris;
        bvh->tri_data_bytes = nf * sizeof *tris;
        bvh->prim_count = kept;
    }
    free(bd.refs);
    bvh_finish_stats(bvh);
    bvh->stats.build_seconds = spt_now() - t0;
    return SPT_EXIT_OK;
}

void bvh_bounds(const Bvh *bvh, float lo[3], float hi[3])
{
    for (int a = 0; a < 3; a++) {
        lo[a] = FLT_MAX;
        hi[a] = -FLT_MAX;
        for (int i = 0; i < BVH_WIDTH && bvh->node_count; i++) {
            lo[a] = minf(lo[a], bvh->nodes[0].bounds[2 * a][i]);
            hi[a] = maxf(hi[a], bvh->nodes[0].bounds[2 * a + 1][i]);
        }
    }
}

void bvh_free(Bvh *bvh)
{
    if (!bvh)
        return;
    free(bvh->nodes);
    free(bvh->tri_data);
    free(bvh->tri_leaf);
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
