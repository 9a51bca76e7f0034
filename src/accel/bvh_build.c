/* Binned SAH BVH builder (Wald 2007, "On fast Construction of SAH-based Bounding
 * Volume Hierarchies") into the flat 8-wide layout of kernels/bvh/bvh.h, with an
 * exact full-sweep SAH builder as a quality reference. The binary SAH tree is
 * decided top down and its nodes gathered into 8-wide nodes as it goes; it is
 * never stored. SSE where available: about 7 million triangles per second of
 * one core on the bench's 1M-triangle mesh (default options); the root's
 * subtrees are built on threads (BvhOptions.threads), into the same tree. */
#include "accel/bvh_build.h"

#include "accel/bvh_builder.h"

#include <float.h>
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* Threads for the subtrees under the root of a tree of count triangles by
 * default: the CPUs online, at most one per slot, where the build is long
 * enough to pay for starting them (a scene of many small meshes builds each
 * on one). */
#define BVH_THREADS_MIN_TRIS 65536u

static int bvh_build_threads(uint32_t count)
{
    long n = sysconf(_SC_NPROCESSORS_ONLN);
    if (count < BVH_THREADS_MIN_TRIS || n < 1)
        return 1;
    return n > BVH_WIDTH ? BVH_WIDTH : (int)n;
}

/* Whether the CPU this runs on has AVX-512F: the CPU devices (PoCL, Intel's
 * runtime) run on it too. */
static int host_has_avx512(void)
{
#if (defined(__x86_64__) || defined(__i386__)) && (defined(__GNUC__) || defined(__clang__))
    return __builtin_cpu_supports("avx512f");
#else
    return 0;
#endif
}

/* The host CPU's last-level cache in bytes, as Linux describes the first
 * CPU's caches (sysconf's figure can be the whole package's), else 8 MiB. */
static double host_cache_bytes(void)
{
    double best = 0.0;
    int best_level = 0;
    for (int i = 0; i < 8; i++) {
        char path[96], buf[32];
        int level = 0;
        snprintf(path, sizeof path, "/sys/devices/system/cpu/cpu0/cache/index%d/level", i);
        FILE *f = fopen(path, "r");
        if (!f)
            continue;
        if (fscanf(f, "%d", &level) != 1)
            level = 0;
        fclose(f);
        snprintf(path, sizeof path, "/sys/devices/system/cpu/cpu0/cache/index%d/size", i);
        f = fopen(path, "r");
        if (!f)
            continue;
        char *end = NULL;
        double size = fgets(buf, sizeof buf, f) ? strtod(buf, &end) : 0.0;
        fclose(f);
        if (end && *end == 'K')
            size *= 1024.0;
        else if (end && *end == 'M')
            size *= 1024.0 * 1024.0;
        if (level > best_level && size > 0.0) {
            best_level = level;
            best = size;
        }
    }
    return best > 0.0 ? best : 8.0 * 1024 * 1024;
}

BvhOptions bvh_default_options_for(uint32_t tri_count)
{
    BvhOptions o;
    o.bins = 16;
    /* A CPU device tests a leaf's triangles a row at a time
     * (kernels/bvh/bvh.h): 16 with AVX-512, 8 with AVX2, and a node visit
     * costs about one such row, so the node cost is a row's triangles and
     * leaves hold at most a row. With AVX-512, leaves of up to 16 at a node
     * cost of 16 made the fastest trees on PoCL (against leaves of at most 8
     * at a node cost of 2: leaves of 11.4 triangles instead of 3 on the
     * bench's 1M-triangle mesh, fewer bytes per triangle, faster builds, about
     * 12% less extend time). With AVX2, leaves of up to 8 at a node cost of 8
     * render the Cornell box 7-8% faster than those of 16, but make a tree of
     * about 36 bytes per triangle instead of 24; one larger than a quarter of
     * the cache (as the kernels' SPT_BVH_STEP_PREFETCH) is read mostly from
     * memory, and there the smaller tree of 16 wins (the 1M-triangle mesh, 4%;
     * docs/performance.md, "What sets the speed"). A GPU loops over a leaf and
     * pays for the larger leaves. */
    int row = host_has_avx512() || 36.0 * (double)tri_count > 0.25 * host_cache_bytes() ? 16 : 8;
    o.max_leaf = row;
    o.full_sweep = 0;
    o.threads = 0;
    o.cost_node = (float)row;
    o.cost_tri = 1.0f;
    return o;
}

BvhOptions bvh_default_options(void) { return bvh_default_options_for(0); }

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
    bvh_refs_bounds(bd->refs, begin, end, &it->bounds, &cb);
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
            ok = bd->opt.full_sweep ? bvh_split_sweep(bd, begin, end, &it->bounds, &s, &cost)
                                    : bvh_split_binned(bd, begin, end, &it->bounds, &cb, &bs, &cost);
        }
        if ((int)count <= bd->opt.max_leaf && (!ok || bd->opt.cost_tri * (float)count <= cost))
            leaf = 1;
        else if (ok && !bd->opt.full_sweep)
            ok = bvh_partition_binned(bd, begin, end, &bs, &s);
        if (!leaf && !ok)
            bvh_split_median(bd, begin, end, &cb, &s);
    }
    it->leaf = leaf;
    it->mid = s.mid;
    bd->sah += (double)area * (leaf ? bd->opt.cost_tri * (double)count : bd->opt.cost_node);
}

/* An array of cap 8-wide nodes, 64-byte aligned where the allocator can, so
 * a node is four cache lines. */
static BvhNode *wide_alloc(uint32_t cap)
{
    BvhNode *w = aligned_alloc(64, (size_t)cap * sizeof *w);
    return w ? w : spt_malloc((size_t)cap * sizeof *w);
}

/* Index of a new 8-wide node (the array grows by doubling). */
static uint32_t wide_new(Builder *bd)
{
    if (bd->wide_count == bd->wide_cap) {
        uint32_t cap = bd->wide_cap * 2;
        BvhNode *w = wide_alloc(cap);
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

/* The slots of the 8-wide node (at depth wdepth) for the interior binary node
 * it: they start as its two children, and the interior slot of largest area
 * (ties: the fewest binary levels down) is replaced by its two children while
 * there is room. Returns their number. */
static int wide_expand(Builder *bd, const Item *it, uint32_t wdepth, Item slot[BVH_WIDTH])
{
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
    return n;
}

/* Fills node w with its n slots, child[i] the new node of each interior one. */
static void wide_fill(Builder *bd, uint32_t w, const Item slot[BVH_WIDTH], int n,
                      uint32_t child[BVH_WIDTH])
{
    for (int i = 0; i < BVH_WIDTH; i++) {
        child[i] = i < n && !slot[i].leaf ? wide_new(bd) : 0;
        wide_slot(bd, w, i, i < n ? &slot[i] : NULL);
        bd->wide[w].child[i] = i < n && !slot[i].leaf ? child[i] : bd->wide[w].child[i];
    }
}

/* Builds 8-wide node w (at depth wdepth) for the interior binary node it, then
 * its interior slots the same way, depth first: each subtree's nodes follow
 * its root's siblings in one contiguous run. */
static void build_wide(Builder *bd, uint32_t w, const Item *it, uint32_t wdepth)
{
    Item slot[BVH_WIDTH];
    uint32_t child[BVH_WIDTH];
    int n = wide_expand(bd, it, wdepth, slot);
    wide_fill(bd, w, slot, n, child);
    for (int i = 0; i < n; i++) {
        if (!slot[i].leaf)
            build_wide(bd, child[i], &slot[i], wdepth + 1);
    }
}

/* A subtree under the root, built into nodes of its own (its root the first),
 * with its own SAH sum and counts. */
typedef struct SubBuild {
    Builder bd;
    BvhStats st;
    Item item;
} SubBuild;

typedef struct SubPool {
    SubBuild *sub;
    int count;
    int next; /* the next subtree to take (atomic) */
} SubPool;

static void *sub_worker(void *arg)
{
    SubPool *pool = arg;
    for (;;) {
        int i = __atomic_fetch_add(&pool->next, 1, __ATOMIC_RELAXED);
        if (i >= pool->count)
            return NULL;
        SubBuild *sb = &pool->sub[i];
        build_wide(&sb->bd, wide_new(&sb->bd), &sb->item, 1);
    }
}

/* The node index, in the whole tree, of node j of subtree sb whose root is
 * node root and whose other nodes start at base. */
static uint32_t sub_index(uint32_t j, uint32_t root, uint32_t base)
{
    return j == 0 ? root : base + j - 1;
}

/* build_wide for the root (node w), its subtrees built by up to `threads`
 * threads: the root's slots as build_wide decides them, then each interior
 * slot's subtree on its own nodes, whose runs are appended in slot order and
 * renumbered, so the tree is the one build_wide makes (docs/performance.md,
 * "What sets the speed"). Returns the threads that built. */
static int build_root(Builder *bd, uint32_t w, const Item *root, int threads)
{
    Item slot[BVH_WIDTH];
    uint32_t child[BVH_WIDTH];
    int n = wide_expand(bd, root, 0, slot);
    wide_fill(bd, w, slot, n, child);
    SubBuild sub[BVH_WIDTH];
    int ns = 0, at[BVH_WIDTH];
    for (int i = 0; i < n; i++) {
        if (slot[i].leaf)
            continue;
        SubBuild *sb = &sub[ns];
        memset(sb, 0, sizeof *sb);
        sb->bd = *bd;
        sb->bd.sah = 0.0;
        sb->bd.st = &sb->st;
        sb->bd.wide_cap = (slot[i].end - slot[i].begin) / 8 + 16;
        sb->bd.wide_count = 0;
        sb->bd.wide = wide_alloc(sb->bd.wide_cap);
        sb->item = slot[i];
        at[ns++] = i;
    }
    SubPool pool = {sub, ns, 0};
    pthread_t tid[BVH_WIDTH];
    int started = 0;
    while (started + 1 < threads && started + 1 < ns &&
           pthread_create(&tid[started], NULL, sub_worker, &pool) == 0)
        started++;
    sub_worker(&pool);
    for (int t = 0; t < started; t++)
        pthread_join(tid[t], NULL);
    for (int k = 0; k < ns; k++) {
        Builder *sbd = &sub[k].bd;
        uint32_t r = child[at[k]], base = bd->wide_count;
        for (uint32_t j = 0; j < sbd->wide_count; j++) {
            BvhNode *node = &sbd->wide[j];
            for (int c = 0; c < BVH_WIDTH; c++)
                if (!node->count[c] && node->child[c])
                    node->child[c] = sub_index(node->child[c], r, base);
            uint32_t dst = j == 0 ? r : wide_new(bd);
            bd->wide[dst] = *node;
        }
        /* Its leaves' slots, recorded at their first refs. */
        for (uint32_t q = sub[k].item.begin; q < sub[k].item.end; q++) {
            uint32_t ls = bd->leaf_slot[q];
            if (ls) {
                uint32_t node = (ls - 1) / BVH_WIDTH, c = (ls - 1) % BVH_WIDTH;
                bd->leaf_slot[q] = sub_index(node, r, base) * BVH_WIDTH + c + 1;
            }
        }
        bd->sah += sbd->sah;
        bd->st->leaf_count += sub[k].st.leaf_count;
        if (sub[k].st.max_depth > bd->st->max_depth)
            bd->st->max_depth = sub[k].st.max_depth;
        free(sbd->wide);
    }
    return started + 1;
}

int bvh_tri_zero_area(const float *p)
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
 * vertices v (kernels/bvh/bvh.h) at word *words of tris, and points slot c of
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
        bvh_refs_bounds(bd->refs, b, e, &it.bounds, &cb);
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

/* The biased exponent of the smallest power of two 2^e with 255 steps from
 * org reaching hi in bvh_qplane's float arithmetic (BVH_QEXP_MAX at most). */
static uint32_t qexp_for(float org, float hi)
{
    int e;
    double ext = (double)hi - (double)org;
    frexp(ext / 255.0, &e); /* 2^(e - 1) <= ext / 255 < 2^e: start at 2^(e - 1) */
    long b = ext > 0.0 ? (long)e + 126 : BVH_QEXP_MIN;
    if (b < BVH_QEXP_MIN)
        b = BVH_QEXP_MIN;
    if (b > BVH_QEXP_MAX)
        b = BVH_QEXP_MAX;
    while (b < BVH_QEXP_MAX && bvh_qplane(org, bvh_qstep((spt_u32)b), 255u) < hi)
        b++;
    return (uint32_t)b;
}

void bvh_node_quantise(BvhQNode *q, const BvhNode *n)
{
    float lo[3], hi[3];
    memset(q, 0, sizeof *q);
    for (int a = 0; a < 3; a++) {
        lo[a] = FLT_MAX;
        hi[a] = -FLT_MAX;
    }
    for (int i = 0; i < BVH_WIDTH; i++) {
        q->child[i] = n->child[i];
        q->count[i] = n->count[i];
        if (!(n->bounds[0][i] <= n->bounds[1][i] && n->bounds[2][i] <= n->bounds[3][i] &&
              n->bounds[4][i] <= n->bounds[5][i]))
            continue; /* unused: an empty box */
        q->used |= (spt_u8)(1u << i);
        for (int a = 0; a < 3; a++) {
            lo[a] = minf(lo[a], n->bounds[2 * a][i]);
            hi[a] = maxf(hi[a], n->bounds[2 * a + 1][i]);
        }
    }
    for (int a = 0; a < 3; a++) {
        if (!q->used)
            lo[a] = hi[a] = 0.0f;
        uint32_t b = qexp_for(lo[a], hi[a]);
        float step = bvh_qstep(b);
        q->org[a] = lo[a];
        q->exp[a] = (spt_u8)b;
        for (int i = 0; i < BVH_WIDTH; i++) {
            if (!(q->used >> i & 1u))
                continue;
            float bl = n->bounds[2 * a][i], bh = n->bounds[2 * a + 1][i];
            /* A first guess from the quotient in double, then moved until the
             * float plane is outside the box: low planes down, high planes up. */
            double fl = floor(((double)bl - (double)lo[a]) / (double)step);
            double fh = ceil(((double)bh - (double)lo[a]) / (double)step);
            uint32_t ql = fl < 0.0 ? 0u : fl > 255.0 ? 255u : (uint32_t)fl;
            uint32_t qh = fh < 0.0 ? 0u : fh > 255.0 ? 255u : (uint32_t)fh;
            while (ql > 0 && bvh_qplane(lo[a], step, ql) > bl)
                ql--;
            while (qh < 255 && bvh_qplane(lo[a], step, qh) < bh)
                qh++;
            q->q[2 * a][i] = (spt_u8)ql;
            q->q[2 * a + 1][i] = (spt_u8)qh;
        }
    }
}

BvhQNode *bvh_quantise_nodes(const BvhNode *nodes, size_t count)
{
    size_t n = count ? count : 1;
    BvhQNode *q = aligned_alloc(64, n * sizeof *q);
    if (!q)
        q = spt_malloc(n * sizeof *q);
    memset(q, 0, n * sizeof *q);
    for (size_t k = 0; k < count; k++)
        bvh_node_quantise(&q[k], &nodes[k]);
    return q;
}

int bvh_qnodes_wanted(void)
{
    const char *v = getenv("SPECTRACE_BVH_NODES");
    return v && !strcmp(v, "quantised");
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
    bvh->stats.build_threads = 1;
    Builder bd;
    memset(&bd, 0, sizeof bd);
    bd.opt = opt ? *opt : bvh_default_options_for(tri_count);
    if (bd.opt.bins < 2 || bd.opt.bins > BVH_MAX_BINS || bd.opt.max_leaf < 1 ||
        bd.opt.max_leaf > BVH_MAX_LEAF || !(bd.opt.cost_node > 0.0f) || !(bd.opt.cost_tri > 0.0f) ||
        bd.opt.threads < 0)
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
        if (bvh_tri_zero_area(p)) {
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
         * array doubles when a tree needs more. Pages past the last node are
         * never touched. */
        bd.wide_cap = kept / 8 + 16;
        bd.wide = wide_alloc(bd.wide_cap);
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
            /* The full-sweep builder's scratch is shared: one thread. */
            int threads =
                bd.opt.full_sweep ? 1 : bd.opt.threads > 0 ? bd.opt.threads : bvh_build_threads(kept);
            bvh->stats.build_threads = (uint32_t)build_root(&bd, w, &root, threads);
        }
        float root_area = box_half_area(&root.bounds);
        bvh->stats.sah_cost = root_area > 0.0f ? bd.sah / root_area : 0.0;
        free(bd.keys);
        free(bd.right_area);
        free(bd.tmp);
        /* Each leaf as a block of its distinct vertices and their indices
         * (kernels/bvh/bvh.h), in node order. A block takes at most 12 n words. */
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
    static uint32_t builds;
    bvh->build = __atomic_add_fetch(&builds, 1, __ATOMIC_RELAXED);
    return SPT_EXIT_OK;
}

int bvh_build_boxes(const float *boxes, uint32_t count, BvhNode **nodes, uint32_t *node_count,
                    uint32_t *order, SptError *e)
{
    if (count > BVH_MAX_TRIS)
        return spt_fail(e, SPT_EXIT_INPUT, "bvh: %u boxes, more than the %u supported", count,
                        BVH_MAX_TRIS);
    Builder bd;
    memset(&bd, 0, sizeof bd);
    BvhStats st;
    memset(&st, 0, sizeof st);
    /* One box per leaf: a leaf's test is a whole lower-level traversal, so
     * the SAH weighs a node visit as one such test. */
    bd.opt = bvh_default_options();
    bd.opt.max_leaf = 1;
    bd.opt.cost_node = 1.0f;
    bd.opt.cost_tri = 1.0f;
    bd.st = &st;
    bd.refs = spt_malloc((count ? count : 1) * sizeof *bd.refs);
    for (uint32_t i = 0; i < count; i++) {
        PrimRef *r = &bd.refs[i];
        memcpy(r->lo, boxes + 6 * (size_t)i, 3 * sizeof(float));
        memcpy(r->hi, boxes + 6 * (size_t)i + 3, 3 * sizeof(float));
        r->id = i;
        r->pad = 0.0f;
    }
    bd.wide_cap = count / 4 + 16;
    bd.wide = spt_malloc((size_t)bd.wide_cap * sizeof *bd.wide);
    bd.leaf_slot = spt_calloc(count ? count : 1, sizeof *bd.leaf_slot);
    uint32_t w = wide_new(&bd);
    if (count == 0) {
        for (int i = 0; i < BVH_WIDTH; i++)
            wide_slot(&bd, w, i, NULL);
    } else {
        Item root;
        decide(&bd, 0, count, 0, &root);
        if (root.leaf) {
            for (int i = 0; i < BVH_WIDTH; i++)
                wide_slot(&bd, w, i, i == 0 ? &root : NULL);
        } else {
            build_wide(&bd, w, &root, 0);
        }
    }
    for (uint32_t i = 0; i < count; i++)
        order[i] = bd.refs[i].id;
    free(bd.refs);
    free(bd.leaf_slot);
    *nodes = bd.wide;
    *node_count = bd.wide_count;
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

double bvh_gen_uniform(uint64_t *state)
{
    uint64_t z = (*state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    z ^= z >> 31;
    return (double)(z >> 11) * (1.0 / 9007199254740992.0);
}
