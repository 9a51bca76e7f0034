/* Random numbers for the renderer, shared by the kernels and host tests (C99 and
 * OpenCL C 1.2).
 *
 * Every random number of a sample is a pure function of (seed, pixel, sample
 * index, dimension): no generator state, no dependence on a path-pool slot, a
 * device or the order of work (docs/architecture.md, "Scale"). Films of disjoint sample
 * ranges therefore add up to the same image however the work is split.
 *
 * Two generators:
 *
 * - spt_rand(seed, pixel, sample, dim): a counter-based generator. The four
 *   32-bit words are folded one at a time through Chris Wellons' "triple32"
 *   integer hash (hash-prospector, 2018): three xorshift-multiply rounds, a
 *   bijection of 32-bit words with the lowest avalanche bias measured for a
 *   32-bit hash (~0.021, statistically indistinguishable from a random
 *   permutation in his tests). Being a bijection, distinct dims of one sample (and
 *   distinct samples of one pixel) never collide. Only 32-bit integer operations:
 *   bit-identical on every OpenCL device and on the host.
 *
 * - spt_sobol_owen(index, dim, seed): the Sobol sequence (direction numbers of
 *   Joe and Kuo 2008, new-joe-kuo-6.21201), Owen-scrambled and index-shuffled
 *   with the hash-based method of Burley 2020 ("Practical Hash-based Owen
 *   Scrambling", JCGT 9(4)); the Laine-Karras style hash is Vegdahl's improved
 *   one (2021, "Building a Better LK Hash"). Because the shuffle is itself a
 *   nested (Owen) scramble of the index bits, the first 2^k indices map onto one
 *   aligned block of 2^k Sobol points, so every power-of-two prefix of a pixel's
 *   samples is a (0,k,2)-net in Sobol dims 0-1 (and stratified in every 1D
 *   projection), whatever the total sample count.
 *
 * Dimension plan for the renderer. Every dim d of a sample is Sobol dim (d & 1)
 * of the scrambled sequence of group d >> 1, whose shuffle seed is a hash of
 * (seed, pixel, group): consecutive dims 2g, 2g + 1 form a 2D pair.
 *
 *   dims 0-1   pixel position x, y      group 0
 *   dims 2-3   lens u, v                group 1
 *   dim 4      hero wavelength          group 2 (dim 5 is spare)
 *   dims 6 + 8 b + k, bounce b (0 = the camera ray's hit), k:
 *     0-1      light selection, BSDF lobe choice
 *     2-3      point on the light
 *     4-5      BSDF direction
 *     6-7      Russian roulette, alpha (the first cut-out or blended surface
 *              passed on the way to the next hit)
 *
 * The groups are "padded" (Burley 2020, section 4; pbrt-v4's PaddedSobolSampler):
 * each pair uses the best 2D projection (Sobol dims 0 and 1, a (0,2)-sequence)
 * with its own index shuffle and value scrambles, which decorrelates the groups
 * from each other while each stays stratified over a pixel's samples. The same
 * sample index therefore gives well spread light, BSDF and roulette samples at
 * every bounce, not only well spread pixel positions.
 *
 * The ZSobol sampler (SPT_SAMPLER_ZSOBOL, `--sampler zsobol`; pbrt-v4's
 * ZSobolSampler, after Ahmed and Wonka 2020, "Screen-Space Blue-Noise
 * Diffusion of Monte Carlo Sampling Error via Hierarchical Ordering of
 * Pixels") numbers the samples of the whole image along a Morton curve: sample
 * s of pixel (x, y) is index morton(x, y) 2^L + s of one Sobol sequence, L =
 * log2 of the samples per pixel rounded up (so the count must be known before
 * rendering), and each base-4 digit of that index is permuted by a hash of the
 * digits above it and of the pair group, which keeps every aligned block of 4^j
 * indices an aligned block of Sobol points. A pixel's 2^L samples are then a
 * (0,L,2)-net in each pair of dims, and so are the samples of each aligned
 * 2^j x 2^j block of pixels together, up to the 8 x 8 tiles whose pixels
 * share their value scrambles: neighbouring pixels' errors are
 * anti-correlated, noise of a high frequency (blue), which the eye and a
 * denoiser average away better. Each pair group g takes Sobol dims 0-1 at its
 * own permuted index, the values Owen-scrambled by a hash of (seed, g, the
 * pixel's 8 x 8 tile).
 *
 * The independent sampler (SPT_SAMPLER_INDEPENDENT, `--sampler independent`)
 * takes every dim from spt_rand instead: the reference the Sobol sampler is
 * measured against. */
#ifndef SPT_RNG_H
#define SPT_RNG_H

#include "shared/portable.h"
#include "shared/vecmath.h"
#include "shared/render_types.h" /* SPT_SAMPLER_* */

/* ---- Dimension plan ---------------------------------------------------------- */

#define SPT_DIM_PIXEL_X 0u
#define SPT_DIM_PIXEL_Y 1u
#define SPT_DIM_LENS_U 2u
#define SPT_DIM_LENS_V 3u
#define SPT_DIM_WAVELENGTH 4u
/* First dim of bounce 0, and the dims each bounce owns. */
#define SPT_DIM_BOUNCE_BASE 6u
#define SPT_DIM_BOUNCE_BLOCK 8u
/* Offsets k inside a bounce block; pairs (2j, 2j + 1) share a Sobol group. */
#define SPT_DIM_LIGHT_SELECT 0u /* light selection (spt_discrete_sample) */
#define SPT_DIM_BSDF_LOBE 1u    /* choice of BSDF lobe / layer */
#define SPT_DIM_LIGHT_U 2u      /* point on the light */
#define SPT_DIM_LIGHT_V 3u
#define SPT_DIM_BSDF_U 4u       /* BSDF direction sample */
#define SPT_DIM_BSDF_V 5u
#define SPT_DIM_ROULETTE 6u     /* Russian roulette */
#define SPT_DIM_ALPHA 7u        /* passing a cut-out / blended surface (shade_alpha_with) */
#define SPT_DIM_SPARE 7u        /* the same dim, where a light path's hashed numbers use it */

/* The number of Sobol dims spt_sobol_u32 and spt_sobol_owen support. */
#define SPT_SOBOL_DIMS 8u

/* Dim k (0 .. SPT_DIM_BOUNCE_BLOCK-1) of the given bounce (0 = first hit). */
SPT_FN spt_u32 spt_dim_bounce(spt_u32 bounce, spt_u32 k)
{
    return SPT_DIM_BOUNCE_BASE + bounce * SPT_DIM_BOUNCE_BLOCK + k;
}

/* ---- Hashing ----------------------------------------------------------------- */

/* Wellons' triple32: a bijection on 32-bit words with near-ideal avalanche. */
SPT_FN spt_u32 spt_hash_u32(spt_u32 x)
{
    x ^= x >> 17;
    x *= 0xed5ad4bbu;
    x ^= x >> 11;
    x *= 0xac4c1b51u;
    x ^= x >> 15;
    x *= 0x31848babu;
    x ^= x >> 14;
    return x;
}

/* The top 24 bits of h as a float in [0, 1): exactly k / 2^24, at most
 * 1 - 2^-24, never 1 (a float has 24 significant bits, so no rounding). */
SPT_FN float spt_u32_to_unit(spt_u32 h)
{
    return (float)(h >> 8) * 5.9604644775390625e-8f;
}

/* A per-(seed, pixel, sample) key: hash the sample's words once and reuse it for
 * all its dims with spt_rand_key. Distinct tag constants keep the streams of
 * spt_rand and of the Sobol scrambles apart. */
SPT_FN spt_u32 spt_rng_key(spt_u32 seed, spt_u32 pixel, spt_u32 sample)
{
    spt_u32 k = spt_hash_u32(seed ^ 0x6a09e667u);
    k = spt_hash_u32(k ^ pixel);
    return spt_hash_u32(k ^ sample);
}

/* The 32 random bits of dim of the sample whose key is key. */
SPT_FN spt_u32 spt_rand_bits(spt_u32 key, spt_u32 dim)
{
    return spt_hash_u32(key ^ (dim * 0x9e3779b9u + 0xbb67ae85u));
}

/* A uniform float in [0, 1) for dim of the sample whose key is key. */
SPT_FN float spt_rand_key(spt_u32 key, spt_u32 dim)
{
    return spt_u32_to_unit(spt_rand_bits(key, dim));
}

/* A uniform float in [0, 1), a pure function of its four arguments. */
SPT_FN float spt_rand(spt_u32 seed, spt_u32 pixel, spt_u32 sample, spt_u32 dim)
{
    return spt_rand_key(spt_rng_key(seed, pixel, sample), dim);
}

/* ---- Owen-scrambled Sobol ---------------------------------------------------- */

/* Direction numbers v_k (k = 0..31, most significant bit first) for Sobol dims
 * 0..7: dim 0 is van der Corput (the identity matrix), dims 1..7 come from Joe and
 * Kuo's new-joe-kuo-6.21201, lines d = 2..8:
 *   (s, a, m) = (1,0,{1}) (2,1,{1,3}) (3,1,{1,3,1}) (3,2,{1,1,1}) (4,1,{1,1,3,3})
 *               (4,4,{1,3,5,13}) (5,2,{1,1,5,5,17})
 * expanded with the standard recurrence to 32 bits (tests/test_rng.c rebuilds
 * them from these triples). */
SPT_CONSTANT spt_u32 SPT_SOBOL_DIRECTIONS[SPT_SOBOL_DIMS * 32] = {
    /* dim 0 */
    0x80000000u, 0x40000000u, 0x20000000u, 0x10000000u,
    0x08000000u, 0x04000000u, 0x02000000u, 0x01000000u,
    0x00800000u, 0x00400000u, 0x00200000u, 0x00100000u,
    0x00080000u, 0x00040000u, 0x00020000u, 0x00010000u,
    0x00008000u, 0x00004000u, 0x00002000u, 0x00001000u,
    0x00000800u, 0x00000400u, 0x00000200u, 0x00000100u,
    0x00000080u, 0x00000040u, 0x00000020u, 0x00000010u,
    0x00000008u, 0x00000004u, 0x00000002u, 0x00000001u,
    /* dim 1 */
    0x80000000u, 0xc0000000u, 0xa0000000u, 0xf0000000u,
    0x88000000u, 0xcc000000u, 0xaa000000u, 0xff000000u,
    0x80800000u, 0xc0c00000u, 0xa0a00000u, 0xf0f00000u,
    0x88880000u, 0xcccc0000u, 0xaaaa0000u, 0xffff0000u,
    0x80008000u, 0xc000c000u, 0xa000a000u, 0xf000f000u,
    0x88008800u, 0xcc00cc00u, 0xaa00aa00u, 0xff00ff00u,
    0x80808080u, 0xc0c0c0c0u, 0xa0a0a0a0u, 0xf0f0f0f0u,
    0x88888888u, 0xccccccccu, 0xaaaaaaaau, 0xffffffffu,
    /* dim 2 */
    0x80000000u, 0xc0000000u, 0x60000000u, 0x90000000u,
    0xe8000000u, 0x5c000000u, 0x8e000000u, 0xc5000000u,
    0x68800000u, 0x9cc00000u, 0xee600000u, 0x55900000u,
    0x80680000u, 0xc09c0000u, 0x60ee0000u, 0x90550000u,
    0xe8808000u, 0x5cc0c000u, 0x8e606000u, 0xc5909000u,
    0x6868e800u, 0x9c9c5c00u, 0xeeee8e00u, 0x5555c500u,
    0x8000e880u, 0xc0005cc0u, 0x60008e60u, 0x9000c590u,
    0xe8006868u, 0x5c009c9cu, 0x8e00eeeeu, 0xc5005555u,
    /* dim 3 */
    0x80000000u, 0xc0000000u, 0x20000000u, 0x50000000u,
    0xf8000000u, 0x74000000u, 0xa2000000u, 0x93000000u,
    0xd8800000u, 0x25400000u, 0x59e00000u, 0xe6d00000u,
    0x78080000u, 0xb40c0000u, 0x82020000u, 0xc3050000u,
    0x208f8000u, 0x51474000u, 0xfbea2000u, 0x75d93000u,
    0xa0858800u, 0x914e5400u, 0xdbe79e00u, 0x25db6d00u,
    0x58800080u, 0xe54000c0u, 0x79e00020u, 0xb6d00050u,
    0x800800f8u, 0xc00c0074u, 0x200200a2u, 0x50050093u,
    /* dim 4 */
    0x80000000u, 0x40000000u, 0x20000000u, 0xb0000000u,
    0xf8000000u, 0xdc000000u, 0x7a000000u, 0x9d000000u,
    0x5a800000u, 0x2fc00000u, 0xa1600000u, 0xf0b00000u,
    0xda880000u, 0x6fc40000u, 0x81620000u, 0x40bb0000u,
    0x22878000u, 0xb3c9c000u, 0xfb65a000u, 0xddb2d000u,
    0x78022800u, 0x9c0b3c00u, 0x5a0fb600u, 0x2d0ddb00u,
    0xa2878080u, 0xf3c9c040u, 0xdb65a020u, 0x6db2d0b0u,
    0x800228f8u, 0x400b3cdcu, 0x200fb67au, 0xb00ddb9du,
    /* dim 5 */
    0x80000000u, 0x40000000u, 0x60000000u, 0x30000000u,
    0xc8000000u, 0x24000000u, 0x56000000u, 0xfb000000u,
    0xe0800000u, 0x70400000u, 0xa8600000u, 0x14300000u,
    0x9ec80000u, 0xdf240000u, 0xb6d60000u, 0x8bbb0000u,
    0x48008000u, 0x64004000u, 0x36006000u, 0xcb003000u,
    0x2880c800u, 0x54402400u, 0xfe605600u, 0xef30fb00u,
    0x7e48e080u, 0xaf647040u, 0x1eb6a860u, 0x9f8b1430u,
    0xd6c81ec8u, 0xbb249f24u, 0x80d6d6d6u, 0x40bbbbbbu,
    /* dim 6 */
    0x80000000u, 0xc0000000u, 0xa0000000u, 0xd0000000u,
    0x58000000u, 0x94000000u, 0x3e000000u, 0xe3000000u,
    0xbe800000u, 0x23c00000u, 0x1e200000u, 0xf3100000u,
    0x46780000u, 0x67840000u, 0x78460000u, 0x84670000u,
    0xc6788000u, 0xa784c000u, 0xd846a000u, 0x5467d000u,
    0x9e78d800u, 0x33845400u, 0xe6469e00u, 0xb7673300u,
    0x20f86680u, 0x104477c0u, 0xf8668020u, 0x4477c010u,
    0x668020f8u, 0x77c01044u, 0x8020f866u, 0xc0104477u,
    /* dim 7 */
    0x80000000u, 0x40000000u, 0xa0000000u, 0x50000000u,
    0x88000000u, 0x24000000u, 0x12000000u, 0x2d000000u,
    0x76800000u, 0x9e400000u, 0x08200000u, 0x64100000u,
    0xb2280000u, 0x7d140000u, 0xfea20000u, 0xba490000u,
    0x1a248000u, 0x491b4000u, 0xc4b5a000u, 0xe3739000u,
    0xf6800800u, 0xde400400u, 0xa8200a00u, 0x34100500u,
    0x3a280880u, 0x59140240u, 0xeca20120u, 0x974902d0u,
    0x6ca48768u, 0xd75b49e4u, 0xcc95a082u, 0x87639641u,
};

/* Bit reversal of a 32-bit word (OpenCL 1.2 has no built-in for it; clang's
 * __builtin_bitreverse32 becomes llvm.bitreverse, which Oclgrind cannot run). */
SPT_FN spt_u32 spt_reverse_bits(spt_u32 x)
{
    x = ((x >> 1) & 0x55555555u) | ((x & 0x55555555u) << 1);
    x = ((x >> 2) & 0x33333333u) | ((x & 0x33333333u) << 2);
    x = ((x >> 4) & 0x0f0f0f0fu) | ((x & 0x0f0f0f0fu) << 4);
    x = ((x >> 8) & 0x00ff00ffu) | ((x & 0x00ff00ffu) << 8);
    return (x >> 16) | (x << 16);
}

/* Point index of the unscrambled Sobol sequence, dim < SPT_SOBOL_DIMS, as a
 * 32-bit fixed-point fraction with its bits reversed: bit i is the coefficient
 * of 2^-(i+1) (natural order, not Gray code). The Owen scramble works on
 * reversed bits, so spt_sobol_owen_u32 saves two reversals by taking this. */
SPT_FN spt_u32 spt_sobol_rev_u32(spt_u32 index, spt_u32 dim)
{
    /* Dim 0's matrix is the identity on reversed bits. */
    if (dim == 0u)
        return index;
    /* Dim 1's matrix is Pascal's triangle mod 2: by Lucas' theorem, reversed
     * output bit j is the XOR of the index bits k whose binary digits include
     * j's (k & j == j). That superset sum over the 5 bits of a bit position
     * takes one shift-mask-xor per position bit, instead of one step per index
     * bit (tests/test_rng.c checks it against the direction numbers). */
    if (dim == 1u) {
        spt_u32 x = index;
        x ^= (x >> 1) & 0x55555555u;
        x ^= (x >> 2) & 0x33333333u;
        x ^= (x >> 4) & 0x0f0f0f0fu;
        x ^= (x >> 8) & 0x00ff00ffu;
        x ^= (x >> 16) & 0x0000ffffu;
        return x;
    }
    spt_u32 x = 0u;
    spt_u32 base = dim * 32u;
    /* Branch-free: shuffled indices have random bits, which defeat a CPU's
     * branch predictor and diverge on a GPU. */
    for (spt_u32 k = 0u; index != 0u; index >>= 1, ++k)
        x ^= SPT_SOBOL_DIRECTIONS[base + k] & (0u - (index & 1u));
    return spt_reverse_bits(x);
}

/* Point index of the unscrambled Sobol sequence, dim < SPT_SOBOL_DIMS, as a
 * 32-bit fixed-point fraction (natural order, not Gray code). */
SPT_FN spt_u32 spt_sobol_u32(spt_u32 index, spt_u32 dim)
{
    return spt_reverse_bits(spt_sobol_rev_u32(index, dim));
}

/* Laine-Karras style hash (Vegdahl 2021): every operation only lets a bit
 * influence more significant bits, so output bit i depends on input bits 0..i
 * only. */
SPT_FN spt_u32 spt_lk_hash(spt_u32 x, spt_u32 seed)
{
    x ^= x * 0x3d20adeau;
    x += seed;
    x *= (seed >> 16) | 1u;
    x ^= x * 0x05526c56u;
    x ^= x * 0x53a22864u;
    return x;
}

/* A nested uniform (Owen) scramble of the 32-bit fraction x: each bit is flipped
 * by a random function of the more significant bits only. A bijection. */
SPT_FN spt_u32 spt_owen_scramble(spt_u32 x, spt_u32 seed)
{
    return spt_reverse_bits(spt_lk_hash(spt_reverse_bits(x), seed));
}

/* Sobol dim (< SPT_SOBOL_DIMS) of point index of one scrambled sequence, as a
 * float in [0, 1). seed selects the sequence: the index shuffle uses seed itself
 * (so pass the same seed for every dim of one point), the value scramble a hash of
 * (seed, dim). */
SPT_FN spt_u32 spt_sobol_owen_u32(spt_u32 index, spt_u32 dim, spt_u32 seed)
{
    spt_u32 shuffled = spt_owen_scramble(index, seed);
    spt_u32 v = spt_sobol_rev_u32(shuffled, dim);
    /* spt_owen_scramble of the unreversed value, whose inner reversal cancels. */
    return spt_reverse_bits(spt_lk_hash(v, spt_hash_u32(seed ^ (dim * 0x9e3779b9u + 0x3c6ef372u))));
}

/* As spt_sobol_owen_u32, as a float in [0, 1). */
SPT_FN float spt_sobol_owen(spt_u32 index, spt_u32 dim, spt_u32 seed)
{
    return spt_u32_to_unit(spt_sobol_owen_u32(index, dim, seed));
}

/* The part of spt_sobol_seed shared by all Sobol groups of one pixel. */
SPT_FN spt_u32 spt_sobol_pixel_key(spt_u32 seed, spt_u32 pixel)
{
    return spt_hash_u32(spt_hash_u32(seed ^ 0x510e527fu) ^ pixel);
}

/* The scramble seed of Sobol group (0: pixel, 1: lens, 2: wavelength) of one
 * pixel: a hash of (seed, pixel, group), independent of the sample. */
SPT_FN spt_u32 spt_sobol_seed(spt_u32 seed, spt_u32 pixel, spt_u32 group)
{
    return spt_hash_u32(spt_sobol_pixel_key(seed, pixel) ^ group);
}

/* ---- The renderer's sampler -------------------------------------------------- */

/* Sample value of dim for (seed, pixel, sample), following the dimension plan
 * above: Sobol dim (dim & 1) of group dim >> 1. In [0, 1). This is the
 * definition; the kernels use the faster spt_sample_pair and friends, which the
 * tests check against it. */
SPT_FN float spt_sample_1d(spt_u32 seed, spt_u32 pixel, spt_u32 sample, spt_u32 dim)
{
    return spt_sobol_owen(sample, dim & 1u, spt_sobol_seed(seed, pixel, dim >> 1));
}

/* Both dims of Sobol pair group (dims 2 group and 2 group + 1) of a sample, given
 * its pixel's spt_sobol_pixel_key: exactly spt_sample_1d of those dims, with the
 * group's seed and the index shuffle computed once. */
SPT_FN SPT_ALWAYS_INLINE void spt_sample_pair(spt_u32 pixel_key, spt_u32 sample, spt_u32 group, float *u0, float *u1)
{
    spt_u32 seed = spt_hash_u32(pixel_key ^ group);
    spt_u32 shuffled = spt_owen_scramble(sample, seed);
    spt_u32 h0 = spt_hash_u32(seed ^ 0x3c6ef372u);
    spt_u32 h1 = spt_hash_u32(seed ^ (0x9e3779b9u + 0x3c6ef372u));
    *u0 = spt_u32_to_unit(spt_reverse_bits(spt_lk_hash(spt_sobol_rev_u32(shuffled, 0u), h0)));
    *u1 = spt_u32_to_unit(spt_reverse_bits(spt_lk_hash(spt_sobol_rev_u32(shuffled, 1u), h1)));
}

/* The single Sobol dim of group 2 (the hero wavelength) of a sample, given its
 * pixel's spt_sobol_pixel_key: exactly spt_sample_1d of SPT_DIM_WAVELENGTH. */
SPT_FN float spt_sample_wavelength_u(spt_u32 pixel_key, spt_u32 sample)
{
    return spt_sobol_owen(sample, 0u, spt_hash_u32(pixel_key ^ 2u));
}

/* ---- ZSobol ------------------------------------------------------------------ */

/* The 24 permutations of the base-4 digits {0, 1, 2, 3} in lexicographic
 * order, each as four 2-bit fields: digit d goes to field d. */
SPT_CONSTANT spt_u32 SPT_ZSOBOL_PERMS[24] = {
    0xe4u, 0xb4u, 0xd8u, 0x78u, 0x9cu, 0x6cu, 0xe1u, 0xb1u, 0xc9u, 0x39u, 0x8du, 0x2du,
    0xd2u, 0x72u, 0xc6u, 0x36u, 0x4eu, 0x1eu, 0x93u, 0x63u, 0x87u, 0x27u, 0x4bu, 0x1bu,
};

/* Bits 0..15 of v spread to the even bits of the result. */
SPT_FN spt_u32 spt_spread_bits(spt_u32 v)
{
    v &= 0x0000ffffu;
    v = (v | (v << 8)) & 0x00ff00ffu;
    v = (v | (v << 4)) & 0x0f0f0f0fu;
    v = (v | (v << 2)) & 0x33333333u;
    v = (v | (v << 1)) & 0x55555555u;
    return v;
}

/* The Morton index of pixel (x, y), both below 2^16: x in the even bits. */
SPT_FN spt_u32 spt_morton2(spt_u32 x, spt_u32 y)
{
    return spt_spread_bits(x) | (spt_spread_bits(y) << 1);
}

/* log2 of the smallest power of two >= n (0 for n <= 1). */
SPT_FN spt_u32 spt_ceil_log2(spt_u32 n)
{
    spt_u32 k = 0u;
    while (k < 32u && ((spt_u32)1u << k) < n)
        k++;
    return k;
}

/* The base-4 digits of a ZSobol index for an image of width x height pixels
 * and 2^log2spp samples per pixel (pbrt-v4's nBase4Digits). */
SPT_FN spt_u32 spt_zsobol_digits(spt_u32 width, spt_u32 height, spt_u32 log2spp)
{
    return spt_ceil_log2(width > height ? width : height) + (log2spp + 1u) / 2u;
}

/* Chris Wellons' "lowbias32" (hash-prospector): two multiply rounds, enough
 * for picking one of 24 permutations, at half triple32's cost. */
SPT_FN spt_u32 spt_hash_fast_u32(spt_u32 x)
{
    x ^= x >> 16;
    x *= 0x7feb352du;
    x ^= x >> 15;
    x *= 0x846ca68bu;
    x ^= x >> 16;
    return x;
}

/* The Sobol index (its low 32 bits: a 32-bit value needs no more) of Morton
 * index m (morton(pixel) 2^log2spp + sample) for the permutations of tag:
 * from the top, each base-4 digit through the permutation a hash of the
 * digits above it picks; with an odd log2spp the last, single bit is flipped
 * by such a hash. */
SPT_FN spt_u32 spt_zsobol_index(spt_u64 m, spt_u32 digits, spt_u32 log2spp, spt_u32 tag)
{
    spt_u32 odd = log2spp & 1u;
    spt_u32 index = 0u;
    for (spt_i32 i = (spt_i32)digits - 1; i >= (spt_i32)odd; --i) {
        spt_u32 shift = 2u * (spt_u32)i - odd;
        spt_u64 higher = m >> (shift + 2u);
        if (shift >= 32u)
            continue; /* beyond the index's low 32 bits */
        spt_u32 h = spt_hash_fast_u32((spt_u32)higher ^ ((spt_u32)(higher >> 32) * 0x9e3779b9u) ^ tag);
        spt_u32 digit = (spt_u32)(m >> shift) & 3u;
        /* (h >> 8) 24 / 2^24: one of the 24 from the hash's top bits. */
        digit = (SPT_ZSOBOL_PERMS[((h >> 8) * 24u) >> 24] >> (2u * digit)) & 3u;
        index |= digit << shift;
    }
    if (odd) {
        spt_u64 higher = m >> 1;
        spt_u32 h = spt_hash_fast_u32((spt_u32)higher ^ ((spt_u32)(higher >> 32) * 0x9e3779b9u) ^ tag);
        index |= ((spt_u32)m & 1u) ^ (h >> 31);
    }
    return index;
}

/* The permutation tag of pair group g (dims 2 g, 2 g + 1) under seed, and the
 * value scramble seeds of its two dims: the same for every pixel. */
SPT_FN spt_u32 spt_zsobol_tag(spt_u32 seed, spt_u32 group)
{
    return spt_hash_u32(spt_hash_u32(seed ^ 0x9b05688cu) ^ group);
}

/* The pixels of a tile share their value scrambles: log2 of its side. */
#define SPT_ZSOBOL_TILE_LOG2 3u

/* The tile of Morton index m: its Morton index over the tiles. */
SPT_FN spt_u32 spt_zsobol_tile(spt_u64 m, spt_u32 log2spp)
{
    return (spt_u32)(m >> (log2spp + 2u * SPT_ZSOBOL_TILE_LOG2));
}

/* Sobol dim d (0 or 1) of Sobol index index, Owen-scrambled for tag and the
 * tile: one scramble per tile of 8 x 8 pixels (pbrt-v4 has one for the whole
 * image), so the blocks of pixels up to a tile stay nets while the tiles'
 * errors are independent: one unlucky scramble does not set every pixel's
 * error, and the image's mean squared error varies from seed to seed as the
 * padded sampler's does. */
SPT_FN float spt_zsobol_value(spt_u32 index, spt_u32 d, spt_u32 tag, spt_u32 tile)
{
    spt_u32 h = spt_hash_u32(tag ^ spt_hash_u32(tile ^ (d ? 0x1f83d9abu : 0x5be0cd19u)));
    return spt_u32_to_unit(spt_reverse_bits(spt_lk_hash(spt_sobol_rev_u32(index, d), h)));
}

/* The definition of a ZSobol sample value, as spt_sample_1d is the padded
 * sampler's: dim of sample s of pixel (x, y) with 2^log2spp samples per pixel
 * in a width x height image. */
SPT_FN float spt_zsobol_1d(spt_u32 seed, spt_u32 x, spt_u32 y, spt_u32 width, spt_u32 height,
                           spt_u32 log2spp, spt_u32 sample, spt_u32 dim)
{
    spt_u64 m = ((spt_u64)spt_morton2(x, y) << log2spp) | sample;
    spt_u32 tag = spt_zsobol_tag(seed, dim >> 1);
    return spt_zsobol_value(spt_zsobol_index(m, spt_zsobol_digits(width, height, log2spp), log2spp, tag),
                            dim & 1u, tag, spt_zsobol_tile(m, log2spp));
}

/* ---- The renderer's sampler -------------------------------------------------- */

/* What the kernels need to draw any dim of one sample with any sampler. */
typedef struct SptSampler {
    spt_u32 kind;      /* SPT_SAMPLER_* */
    spt_u32 pixel_key; /* spt_sobol_pixel_key(seed, pixel) */
    spt_u32 rand_key;  /* spt_rng_key(seed, pixel, sample) */
    spt_u32 sample;
    /* ZSobol: the Morton index (morton(pixel) 2^log2spp + sample), its digits
     * and log2spp, and the seed's part of the tags. */
    spt_u64 zindex;
    spt_u32 zdigits, zlog2spp, zseed;
} SptSampler;

SPT_FN SptSampler spt_sampler(spt_u32 kind, spt_u32 seed, spt_u32 pixel, spt_u32 sample)
{
    SptSampler s;
    s.kind = kind;
    s.pixel_key = spt_sobol_pixel_key(seed, pixel);
    s.rand_key = spt_rng_key(seed, pixel, sample);
    s.sample = sample;
    s.zindex = 0u;
    s.zdigits = 0u;
    s.zlog2spp = 0u;
    s.zseed = 0u;
    return s;
}

/* The sampler of a camera path's sample of the render p: spt_sampler, and for
 * ZSobol its Morton index from the pixel's position. */
SPT_FN SptSampler spt_sampler_for(const RenderParams *p, spt_u32 pixel, spt_u32 sample)
{
    SptSampler s = spt_sampler(p->sampler, p->seed, pixel, sample);
    if (p->sampler == SPT_SAMPLER_ZSOBOL) {
        spt_u32 w = (spt_u32)p->width;
        s.zlog2spp = p->zsobol_log2spp;
        s.zdigits = p->zsobol_digits;
        s.zindex = ((spt_u64)spt_morton2(pixel % w, pixel / w) << s.zlog2spp) | sample;
        s.zseed = spt_hash_u32(p->seed ^ 0x9b05688cu);
    }
    return s;
}

/* Dims dim and dim + 1 (dim even) of the sample: spt_sample_1d of them for the
 * Sobol sampler, spt_zsobol_1d for ZSobol, spt_rand for the independent one. */
SPT_FN SPT_ALWAYS_INLINE void spt_sampler_pair(SptSampler s, spt_u32 dim, float *u0, float *u1)
{
    if (s.kind == SPT_SAMPLER_INDEPENDENT) {
        *u0 = spt_rand_key(s.rand_key, dim);
        *u1 = spt_rand_key(s.rand_key, dim + 1u);
    } else if (s.kind == SPT_SAMPLER_ZSOBOL) {
        spt_u32 tag = spt_hash_u32(s.zseed ^ (dim >> 1));
        spt_u32 index = spt_zsobol_index(s.zindex, s.zdigits, s.zlog2spp, tag);
        spt_u32 tile = spt_zsobol_tile(s.zindex, s.zlog2spp);
        *u0 = spt_zsobol_value(index, 0u, tag, tile);
        *u1 = spt_zsobol_value(index, 1u, tag, tile);
    } else {
        spt_sample_pair(s.pixel_key, s.sample, dim >> 1, u0, u1);
    }
}

/* Dim dim of the sample, as spt_sampler_pair. */
SPT_FN SPT_ALWAYS_INLINE float spt_sampler_1d(SptSampler s, spt_u32 dim)
{
    if (s.kind == SPT_SAMPLER_INDEPENDENT)
        return spt_rand_key(s.rand_key, dim);
    if (s.kind == SPT_SAMPLER_ZSOBOL) {
        spt_u32 tag = spt_hash_u32(s.zseed ^ (dim >> 1));
        return spt_zsobol_value(spt_zsobol_index(s.zindex, s.zdigits, s.zlog2spp, tag), dim & 1u, tag,
                                spt_zsobol_tile(s.zindex, s.zlog2spp));
    }
    return spt_sobol_owen(s.sample, dim & 1u, spt_hash_u32(s.pixel_key ^ (dim >> 1)));
}

#endif
