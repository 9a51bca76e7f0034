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
 *   dim 4      hero wavelength          group 2 (dim 5 is spare; joined, below)
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
 * Three groups are the exception, joined to the BSDF direction at bounce 0
 * (group 5): at bounce 1, the point on the light (group 8) and the BSDF
 * direction (group 9) are Sobol dims 2-3 and 4-5 of group 5's sequence (its
 * index shuffle; their own value scrambles), and the hero wavelength (group
 * 2) is its Sobol dim 6, so those seven dims are one Owen-scrambled Sobol
 * point set, stratified jointly (as pbrt-v4's unpadded SobolSampler is) and
 * not only pair by pair. The light reaching the first hit from other
 * surfaces, most of the noise of a diffuse interior, is an integral over
 * these dims together; padded pairs stratify the first direction and the
 * next vertex's samples each alone. Each joined pair is then a
 * (t,2)-sequence with t up to the Sobol bound (dims 2-3: t <= 3, dims 4-5:
 * t <= 5) rather than a (0,2)-sequence: coarser per pair, finer together
 * (docs/performance.md, "Joined dims at the first bounce", has the
 * measurements). The ZSobol and independent samplers keep every group
 * separate.
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

#include "util/portable.h"
#include "util/vecmath.h"
#include "util/render_types.h" /* SPT_SAMPLER_* */

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

/* The direction numbers of dims 2 .. SPT_SOBOL_DIMS - 1 by 4-bit digits of the
 * index: entry (dim - 2) 128 + 16 p + n is the XOR of v_{4p+b} over the set bits
 * b of n, its bits reversed (derived from SPT_SOBOL_DIRECTIONS; tests/test_rng.c
 * checks every entry against them). */
SPT_CONSTANT spt_u32 SPT_SOBOL_NIBBLE_REV[(SPT_SOBOL_DIMS - 2u) * 128u] = {
    /* dim 2 */
    0x00000000u, 0x00000001u, 0x00000003u, 0x00000002u, 0x00000006u, 0x00000007u, 0x00000005u, 0x00000004u,
    0x00000009u, 0x00000008u, 0x0000000au, 0x0000000bu, 0x0000000fu, 0x0000000eu, 0x0000000cu, 0x0000000du,
    0x00000000u, 0x00000017u, 0x0000003au, 0x0000002du, 0x00000071u, 0x00000066u, 0x0000004bu, 0x0000005cu,
    0x000000a3u, 0x000000b4u, 0x00000099u, 0x0000008eu, 0x000000d2u, 0x000000c5u, 0x000000e8u, 0x000000ffu,
    0x00000000u, 0x00000116u, 0x00000339u, 0x0000022fu, 0x00000677u, 0x00000761u, 0x0000054eu, 0x00000458u,
    0x000009aau, 0x000008bcu, 0x00000a93u, 0x00000b85u, 0x00000fddu, 0x00000ecbu, 0x00000ce4u, 0x00000df2u,
    0x00000000u, 0x00001601u, 0x00003903u, 0x00002f02u, 0x00007706u, 0x00006107u, 0x00004e05u, 0x00005804u,
    0x0000aa09u, 0x0000bc08u, 0x0000930au, 0x0000850bu, 0x0000dd0fu, 0x0000cb0eu, 0x0000e40cu, 0x0000f20du,
    0x00000000u, 0x00010117u, 0x0003033au, 0x0002022du, 0x00060671u, 0x00070766u, 0x0005054bu, 0x0004045cu,
    0x000909a3u, 0x000808b4u, 0x000a0a99u, 0x000b0b8eu, 0x000f0fd2u, 0x000e0ec5u, 0x000c0ce8u, 0x000d0dffu,
    0x00000000u, 0x00171616u, 0x003a3939u, 0x002d2f2fu, 0x00717777u, 0x00666161u, 0x004b4e4eu, 0x005c5858u,
    0x00a3aaaau, 0x00b4bcbcu, 0x00999393u, 0x008e8585u, 0x00d2ddddu, 0x00c5cbcbu, 0x00e8e4e4u, 0x00fff2f2u,
    0x00000000u, 0x01170001u, 0x033a0003u, 0x022d0002u, 0x06710006u, 0x07660007u, 0x054b0005u, 0x045c0004u,
    0x09a30009u, 0x08b40008u, 0x0a99000au, 0x0b8e000bu, 0x0fd2000fu, 0x0ec5000eu, 0x0ce8000cu, 0x0dff000du,
    0x00000000u, 0x16160017u, 0x3939003au, 0x2f2f002du, 0x77770071u, 0x61610066u, 0x4e4e004bu, 0x5858005cu,
    0xaaaa00a3u, 0xbcbc00b4u, 0x93930099u, 0x8585008eu, 0xdddd00d2u, 0xcbcb00c5u, 0xe4e400e8u, 0xf2f200ffu,
    /* dim 3 */
    0x00000000u, 0x00000001u, 0x00000003u, 0x00000002u, 0x00000004u, 0x00000005u, 0x00000007u, 0x00000006u,
    0x0000000au, 0x0000000bu, 0x00000009u, 0x00000008u, 0x0000000eu, 0x0000000fu, 0x0000000du, 0x0000000cu,
    0x00000000u, 0x0000001fu, 0x0000002eu, 0x00000031u, 0x00000045u, 0x0000005au, 0x0000006bu, 0x00000074u,
    0x000000c9u, 0x000000d6u, 0x000000e7u, 0x000000f8u, 0x0000008cu, 0x00000093u, 0x000000a2u, 0x000000bdu,
    0x00000000u, 0x0000011bu, 0x000002a4u, 0x000003bfu, 0x0000079au, 0x00000681u, 0x0000053eu, 0x00000425u,
    0x00000b67u, 0x00000a7cu, 0x000009c3u, 0x000008d8u, 0x00000cfdu, 0x00000de6u, 0x00000e59u, 0x00000f42u,
    0x00000000u, 0x0000101eu, 0x0000302du, 0x00002033u, 0x00004041u, 0x0000505fu, 0x0000706cu, 0x00006072u,
    0x0000a0c3u, 0x0000b0ddu, 0x000090eeu, 0x000080f0u, 0x0000e082u, 0x0000f09cu, 0x0000d0afu, 0x0000c0b1u,
    0x00000000u, 0x0001f104u, 0x0002e28au, 0x0003138eu, 0x000457dfu, 0x0005a6dbu, 0x0006b555u, 0x00074451u,
    0x000c9baeu, 0x000d6aaau, 0x000e7924u, 0x000f8820u, 0x0008cc71u, 0x00093d75u, 0x000a2efbu, 0x000bdfffu,
    0x00000000u, 0x0011a105u, 0x002a7289u, 0x003bd38cu, 0x0079e7dbu, 0x006846deu, 0x00539552u, 0x00423457u,
    0x00b6dba4u, 0x00a77aa1u, 0x009ca92du, 0x008d0828u, 0x00cf3c7fu, 0x00de9d7au, 0x00e54ef6u, 0x00f4eff3u,
    0x00000000u, 0x0100011au, 0x030002a7u, 0x020003bdu, 0x0400079eu, 0x05000684u, 0x07000539u, 0x06000423u,
    0x0a000b6du, 0x0b000a77u, 0x090009cau, 0x080008d0u, 0x0e000cf3u, 0x0f000de9u, 0x0d000e54u, 0x0c000f4eu,
    0x00000000u, 0x1f001001u, 0x2e003003u, 0x31002002u, 0x45004004u, 0x5a005005u, 0x6b007007u, 0x74006006u,
    0xc900a00au, 0xd600b00bu, 0xe7009009u, 0xf8008008u, 0x8c00e00eu, 0x9300f00fu, 0xa200d00du, 0xbd00c00cu,
    /* dim 4 */
    0x00000000u, 0x00000001u, 0x00000002u, 0x00000003u, 0x00000004u, 0x00000005u, 0x00000006u, 0x00000007u,
    0x0000000du, 0x0000000cu, 0x0000000fu, 0x0000000eu, 0x00000009u, 0x00000008u, 0x0000000bu, 0x0000000au,
    0x00000000u, 0x0000001fu, 0x0000003bu, 0x00000024u, 0x0000005eu, 0x00000041u, 0x00000065u, 0x0000007au,
    0x000000b9u, 0x000000a6u, 0x00000082u, 0x0000009du, 0x000000e7u, 0x000000f8u, 0x000000dcu, 0x000000c3u,
    0x00000000u, 0x0000015au, 0x000003f4u, 0x000002aeu, 0x00000685u, 0x000007dfu, 0x00000571u, 0x0000042bu,
    0x00000d0fu, 0x00000c55u, 0x00000efbu, 0x00000fa1u, 0x00000b8au, 0x00000ad0u, 0x0000087eu, 0x00000924u,
    0x00000000u, 0x0000115bu, 0x000023f6u, 0x000032adu, 0x00004681u, 0x000057dau, 0x00006577u, 0x0000742cu,
    0x0000dd02u, 0x0000cc59u, 0x0000fef4u, 0x0000efafu, 0x00009b83u, 0x00008ad8u, 0x0000b875u, 0x0000a92eu,
    0x00000000u, 0x0001e144u, 0x000393cdu, 0x00027289u, 0x0005a6dfu, 0x0004479bu, 0x00063512u, 0x0007d456u,
    0x000b4dbbu, 0x000aacffu, 0x0008de76u, 0x00093f32u, 0x000eeb64u, 0x000f0a20u, 0x000d78a9u, 0x000c99edu,
    0x00000000u, 0x0014401eu, 0x003cd039u, 0x00289027u, 0x006df05au, 0x0079b044u, 0x00512063u, 0x0045607du,
    0x00dbb0b4u, 0x00cff0aau, 0x00e7608du, 0x00f32093u, 0x00b640eeu, 0x00a200f0u, 0x008a90d7u, 0x009ed0c9u,
    0x00000000u, 0x0101e145u, 0x020393cfu, 0x0302728au, 0x0405a6dbu, 0x0504479eu, 0x06063514u, 0x0707d451u,
    0x0d0b4db6u, 0x0c0aacf3u, 0x0f08de79u, 0x0e093f3cu, 0x090eeb6du, 0x080f0a28u, 0x0b0d78a2u, 0x0a0c99e7u,
    0x00000000u, 0x1f144001u, 0x3b3cd002u, 0x24289003u, 0x5e6df004u, 0x4179b005u, 0x65512006u, 0x7a456007u,
    0xb9dbb00du, 0xa6cff00cu, 0x82e7600fu, 0x9df3200eu, 0xe7b64009u, 0xf8a20008u, 0xdc8a900bu, 0xc39ed00au,
    /* dim 5 */
    0x00000000u, 0x00000001u, 0x00000002u, 0x00000003u, 0x00000006u, 0x00000007u, 0x00000004u, 0x00000005u,
    0x0000000cu, 0x0000000du, 0x0000000eu, 0x0000000fu, 0x0000000au, 0x0000000bu, 0x00000008u, 0x00000009u,
    0x00000000u, 0x00000013u, 0x00000024u, 0x00000037u, 0x0000006au, 0x00000079u, 0x0000004eu, 0x0000005du,
    0x000000dfu, 0x000000ccu, 0x000000fbu, 0x000000e8u, 0x000000b5u, 0x000000a6u, 0x00000091u, 0x00000082u,
    0x00000000u, 0x00000107u, 0x0000020eu, 0x00000309u, 0x00000615u, 0x00000712u, 0x0000041bu, 0x0000051cu,
    0x00000c28u, 0x00000d2fu, 0x00000e26u, 0x00000f21u, 0x00000a3du, 0x00000b3au, 0x00000833u, 0x00000934u,
    0x00000000u, 0x00001379u, 0x000024fbu, 0x00003782u, 0x00006b6du, 0x00007814u, 0x00004f96u, 0x00005cefu,
    0x0000ddd1u, 0x0000cea8u, 0x0000f92au, 0x0000ea53u, 0x0000b6bcu, 0x0000a5c5u, 0x00009247u, 0x0000813eu,
    0x00000000u, 0x00010012u, 0x00020026u, 0x00030034u, 0x0006006cu, 0x0007007eu, 0x0004004au, 0x00050058u,
    0x000c00d3u, 0x000d00c1u, 0x000e00f5u, 0x000f00e7u, 0x000a00bfu, 0x000b00adu, 0x00080099u, 0x0009008bu,
    0x00000000u, 0x00130114u, 0x0024022au, 0x0037033eu, 0x006a067fu, 0x0079076bu, 0x004e0455u, 0x005d0541u,
    0x00df0cf7u, 0x00cc0de3u, 0x00fb0eddu, 0x00e80fc9u, 0x00b50a88u, 0x00a60b9cu, 0x009108a2u, 0x008209b6u,
    0x00000000u, 0x0107127eu, 0x020e26f5u, 0x0309348bu, 0x06156d78u, 0x07127f06u, 0x041b4b8du, 0x051c59f3u,
    0x0c28d1f9u, 0x0d2fc387u, 0x0e26f70cu, 0x0f21e572u, 0x0a3dbc81u, 0x0b3aaeffu, 0x08339a74u, 0x0934880au,
    0x00000000u, 0x1378136bu, 0x24f924ddu, 0x378137b6u, 0x6b6b6b01u, 0x7813786au, 0x4f924fdcu, 0x5cea5cb7u,
    0xdddddd02u, 0xcea5ce69u, 0xf924f9dfu, 0xea5ceab4u, 0xb6b6b603u, 0xa5cea568u, 0x924f92deu, 0x813781b5u,
    /* dim 6 */
    0x00000000u, 0x00000001u, 0x00000003u, 0x00000002u, 0x00000005u, 0x00000004u, 0x00000006u, 0x00000007u,
    0x0000000bu, 0x0000000au, 0x00000008u, 0x00000009u, 0x0000000eu, 0x0000000fu, 0x0000000du, 0x0000000cu,
    0x00000000u, 0x0000001au, 0x00000029u, 0x00000033u, 0x0000007cu, 0x00000066u, 0x00000055u, 0x0000004fu,
    0x000000c7u, 0x000000ddu, 0x000000eeu, 0x000000f4u, 0x000000bbu, 0x000000a1u, 0x00000092u, 0x00000088u,
    0x00000000u, 0x0000017du, 0x000003c4u, 0x000002b9u, 0x00000478u, 0x00000505u, 0x000007bcu, 0x000006c1u,
    0x000008cfu, 0x000009b2u, 0x00000b0bu, 0x00000a76u, 0x00000cb7u, 0x00000dcau, 0x00000f73u, 0x00000e0eu,
    0x00000000u, 0x00001e62u, 0x000021e6u, 0x00003f84u, 0x0000621eu, 0x00007c7cu, 0x000043f8u, 0x00005d9au,
    0x0000e621u, 0x0000f843u, 0x0000c7c7u, 0x0000d9a5u, 0x0000843fu, 0x00009a5du, 0x0000a5d9u, 0x0000bbbbu,
    0x00000000u, 0x00011e63u, 0x000321e5u, 0x00023f86u, 0x0005621bu, 0x00047c78u, 0x000643feu, 0x00075d9du,
    0x000be62au, 0x000af849u, 0x0008c7cfu, 0x0009d9acu, 0x000e8431u, 0x000f9a52u, 0x000da5d4u, 0x000cbbb7u,
    0x00000000u, 0x001b1e79u, 0x002a21ccu, 0x00313fb5u, 0x00796267u, 0x00627c1eu, 0x005343abu, 0x00485dd2u,
    0x00cce6edu, 0x00d7f894u, 0x00e6c721u, 0x00fdd958u, 0x00b5848au, 0x00ae9af3u, 0x009fa546u, 0x0084bb3fu,
    0x00000000u, 0x01661f04u, 0x03ee2208u, 0x02883d0cu, 0x0401661fu, 0x0567791bu, 0x07ef4417u, 0x06895b13u,
    0x0803ee22u, 0x0965f126u, 0x0bedcc2au, 0x0a8bd32eu, 0x0c02883du, 0x0d649739u, 0x0fecaa35u, 0x0e8ab531u,
    0x00000000u, 0x1f040166u, 0x220803eeu, 0x3d0c0288u, 0x661f0401u, 0x791b0567u, 0x441707efu, 0x5b130689u,
    0xee220803u, 0xf1260965u, 0xcc2a0bedu, 0xd32e0a8bu, 0x883d0c02u, 0x97390d64u, 0xaa350fecu, 0xb5310e8au,
    /* dim 7 */
    0x00000000u, 0x00000001u, 0x00000002u, 0x00000003u, 0x00000005u, 0x00000004u, 0x00000007u, 0x00000006u,
    0x0000000au, 0x0000000bu, 0x00000008u, 0x00000009u, 0x0000000fu, 0x0000000eu, 0x0000000du, 0x0000000cu,
    0x00000000u, 0x00000011u, 0x00000024u, 0x00000035u, 0x00000048u, 0x00000059u, 0x0000006cu, 0x0000007du,
    0x000000b4u, 0x000000a5u, 0x00000090u, 0x00000081u, 0x000000fcu, 0x000000edu, 0x000000d8u, 0x000000c9u,
    0x00000000u, 0x0000016eu, 0x00000279u, 0x00000317u, 0x00000410u, 0x0000057eu, 0x00000669u, 0x00000707u,
    0x00000826u, 0x00000948u, 0x00000a5fu, 0x00000b31u, 0x00000c36u, 0x00000d58u, 0x00000e4fu, 0x00000f21u,
    0x00000000u, 0x0000144du, 0x000028beu, 0x00003cf3u, 0x0000457fu, 0x00005132u, 0x00006dc1u, 0x0000798cu,
    0x0000925du, 0x00008610u, 0x0000bae3u, 0x0000aeaeu, 0x0000d722u, 0x0000c36fu, 0x0000ff9cu, 0x0000ebd1u,
    0x00000000u, 0x00012458u, 0x0002d892u, 0x0003fccau, 0x0005ad23u, 0x0004897bu, 0x000775b1u, 0x000651e9u,
    0x0009cec7u, 0x0008ea9fu, 0x000b1655u, 0x000a320du, 0x000c63e4u, 0x000d47bcu, 0x000ebb76u, 0x000f9f2eu,
    0x00000000u, 0x0010016fu, 0x0020027bu, 0x00300314u, 0x00500415u, 0x0040057au, 0x0070066eu, 0x00600701u,
    0x00a0082cu, 0x00b00943u, 0x00800a57u, 0x00900b38u, 0x00f00c39u, 0x00e00d56u, 0x00d00e42u, 0x00c00f2du,
    0x00000000u, 0x0110145cu, 0x0240289au, 0x03503cc6u, 0x04804537u, 0x0590516bu, 0x06c06dadu, 0x07d079f1u,
    0x0b4092e9u, 0x0a5086b5u, 0x0900ba73u, 0x0810ae2fu, 0x0fc0d7deu, 0x0ed0c382u, 0x0d80ff44u, 0x0c90eb18u,
    0x00000000u, 0x16e12536u, 0x2792daebu, 0x3173ffddu, 0x4105a933u, 0x57e48c05u, 0x669773d8u, 0x707656eeu,
    0x8269c6e1u, 0x9488e3d7u, 0xa5fb1c0au, 0xb31a393cu, 0xc36c6fd2u, 0xd58d4ae4u, 0xe4feb539u, 0xf21f900fu,
};

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
    /* The others: the XOR of a table entry per 4-bit digit of the index (a
     * shuffled index has all 32 bits random, and a step per bit took a
     * 32-step loop). */
    spt_u32 base = (dim - 2u) * 128u;
    spt_u32 x = 0u;
    for (spt_u32 p = 0u; p < 8u; p++)
        x ^= SPT_SOBOL_NIBBLE_REV[base + 16u * p + ((index >> (4u * p)) & 15u)];
    return x;
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

/* The part of the Sobol groups' scramble seeds shared by all groups of one
 * pixel: group g's seed is spt_hash_u32(key ^ g), independent of the sample. */
SPT_FN spt_u32 spt_sobol_pixel_key(spt_u32 seed, spt_u32 pixel)
{
    return spt_hash_u32(spt_hash_u32(seed ^ 0x510e527fu) ^ pixel);
}

/* ---- The renderer's sampler -------------------------------------------------- */

/* The groups joined to the BSDF direction at bounce 0 (the header comment):
 * the group whose index shuffle they take, and theirs. */
#define SPT_GROUP_JOINT_BASE ((SPT_DIM_BOUNCE_BASE + SPT_DIM_BSDF_U) / 2u)
#define SPT_GROUP_JOINT_LIGHT ((SPT_DIM_BOUNCE_BASE + SPT_DIM_BOUNCE_BLOCK + SPT_DIM_LIGHT_U) / 2u)
#define SPT_GROUP_JOINT_BSDF ((SPT_DIM_BOUNCE_BASE + SPT_DIM_BOUNCE_BLOCK + SPT_DIM_BSDF_U) / 2u)
#define SPT_GROUP_JOINT_WAVELENGTH (SPT_DIM_WAVELENGTH / 2u)

/* The first Sobol dim of pair group group, and in *index_group the group whose
 * index shuffle it takes: 0 and itself, but for the joined groups. */
SPT_FN spt_u32 spt_group_sobol_dim(spt_u32 group, spt_u32 *index_group)
{
    *index_group = group;
    if (group == SPT_GROUP_JOINT_LIGHT) {
        *index_group = SPT_GROUP_JOINT_BASE;
        return 2u;
    }
    if (group == SPT_GROUP_JOINT_BSDF) {
        *index_group = SPT_GROUP_JOINT_BASE;
        return 4u;
    }
    if (group == SPT_GROUP_JOINT_WAVELENGTH) {
        *index_group = SPT_GROUP_JOINT_BASE;
        return 6u;
    }
    return 0u;
}

/* Sample value of dim for the pixel whose spt_sobol_pixel_key is pixel_key,
 * following the dimension plan above: Sobol dim (dim & 1) of group dim >> 1
 * (dims 2-6 of group 5 for the joined groups), the index shuffled by the seed
 * of the group whose sequence it is and the value scrambled by its own
 * group's. In [0, 1). */
SPT_FN float spt_sample_1d_key(spt_u32 pixel_key, spt_u32 sample, spt_u32 dim)
{
    spt_u32 index_group;
    spt_u32 d = spt_group_sobol_dim(dim >> 1, &index_group) + (dim & 1u);
    spt_u32 shuffled = spt_owen_scramble(sample, spt_hash_u32(pixel_key ^ index_group));
    spt_u32 v = spt_sobol_rev_u32(shuffled, d);
    spt_u32 vseed = spt_hash_u32(pixel_key ^ (dim >> 1));
    return spt_u32_to_unit(
        spt_reverse_bits(spt_lk_hash(v, spt_hash_u32(vseed ^ ((dim & 1u) * 0x9e3779b9u + 0x3c6ef372u)))));
}

/* Sample value of dim for (seed, pixel, sample): spt_sample_1d_key. This is
 * the definition; the kernels draw pairs with the faster spt_sample_pair,
 * which the tests check against it. */
SPT_FN float spt_sample_1d(spt_u32 seed, spt_u32 pixel, spt_u32 sample, spt_u32 dim)
{
    return spt_sample_1d_key(spt_sobol_pixel_key(seed, pixel), sample, dim);
}

/* Both dims of Sobol pair group (dims 2 group and 2 group + 1) of a sample, given
 * its pixel's spt_sobol_pixel_key: exactly spt_sample_1d of those dims, with the
 * group's seed and the index shuffle computed once. */
SPT_FN SPT_ALWAYS_INLINE void spt_sample_pair(spt_u32 pixel_key, spt_u32 sample, spt_u32 group, float *u0, float *u1)
{
    spt_u32 index_group;
    spt_u32 d = spt_group_sobol_dim(group, &index_group);
    spt_u32 seed = spt_hash_u32(pixel_key ^ group);
    spt_u32 shuffled = spt_owen_scramble(sample, spt_hash_u32(pixel_key ^ index_group));
    spt_u32 h0 = spt_hash_u32(seed ^ 0x3c6ef372u);
    spt_u32 h1 = spt_hash_u32(seed ^ (0x9e3779b9u + 0x3c6ef372u));
    *u0 = spt_u32_to_unit(spt_reverse_bits(spt_lk_hash(spt_sobol_rev_u32(shuffled, d), h0)));
    *u1 = spt_u32_to_unit(spt_reverse_bits(spt_lk_hash(spt_sobol_rev_u32(shuffled, d + 1u), h1)));
}

/* ---- A bounce's dims at once ------------------------------------------------ */

#if SPT_DEVICE
/* spt_hash_u32, spt_reverse_bits and spt_lk_hash lane by lane. */
SPT_FN uint8 spt_hash_u32x8(uint8 x)
{
    x ^= x >> 17u;
    x *= 0xed5ad4bbu;
    x ^= x >> 11u;
    x *= 0xac4c1b51u;
    x ^= x >> 15u;
    x *= 0x31848babu;
    x ^= x >> 14u;
    return x;
}

SPT_FN uint8 spt_reverse_bits_x8(uint8 x)
{
    x = ((x >> 1u) & 0x55555555u) | ((x & 0x55555555u) << 1u);
    x = ((x >> 2u) & 0x33333333u) | ((x & 0x33333333u) << 2u);
    x = ((x >> 4u) & 0x0f0f0f0fu) | ((x & 0x0f0f0f0fu) << 4u);
    x = ((x >> 8u) & 0x00ff00ffu) | ((x & 0x00ff00ffu) << 8u);
    return (x >> 16u) | (x << 16u);
}

SPT_FN uint8 spt_lk_hash_x8(uint8 x, uint8 seed)
{
    x ^= x * 0x3d20adeau;
    x += seed;
    x *= (seed >> 16u) | 1u;
    x ^= x * 0x05526c56u;
    x ^= x * 0x53a22864u;
    return x;
}
#endif

SPT_STATIC_ASSERT(SPT_DIM_BOUNCE_BLOCK == 8u, "spt_sample_bounce draws a bounce's dims in 8 lanes");
/* The joined groups spt_sample_bounce draws in straight-line code: those of
 * the light point and the BSDF direction are lanes 2-5 of bounce 1, with Sobol
 * dims 2-5 (spt_group_sobol_dim), and the wavelength's group lies before every
 * bounce. */
SPT_STATIC_ASSERT(SPT_DIM_LIGHT_U == 2u && SPT_DIM_BSDF_U == 4u, "spt_sample_bounce: joined lanes 2-5");
SPT_STATIC_ASSERT(SPT_GROUP_JOINT_LIGHT == (SPT_DIM_BOUNCE_BASE + SPT_DIM_BOUNCE_BLOCK + 2u) / 2u &&
                      SPT_GROUP_JOINT_BSDF == SPT_GROUP_JOINT_LIGHT + 1u,
                  "spt_sample_bounce: the joined groups are bounce 1's second and third");
SPT_STATIC_ASSERT(SPT_GROUP_JOINT_WAVELENGTH < SPT_DIM_BOUNCE_BASE / 2u,
                  "spt_sample_bounce: the wavelength's group is in no bounce");

/* All SPT_DIM_BOUNCE_BLOCK dims of a bounce, u[k] = spt_sample_1d_key(pixel_key,
 * sample, spt_dim_bounce(bounce, k)) bit for bit. A shading step uses most of
 * them (the light, the lobe, the BSDF direction, the roulette), and each
 * costs three hashes, two scrambles and their bit reversals: on the device
 * the eight are one 8-lane computation (docs/performance.md, "The sampler's
 * dims in lanes"), on the host a loop over the definition. */
SPT_FN void spt_sample_bounce(spt_u32 pixel_key, spt_u32 sample, spt_u32 bounce,
                              float u[SPT_DIM_BOUNCE_BLOCK])
{
#if SPT_DEVICE
    uint8 lane = (uint8)(0u, 1u, 2u, 3u, 4u, 5u, 6u, 7u);
    uint8 group = (uint8)(spt_dim_bounce(bounce, 0u) >> 1) + (lane >> 1u);
    uint8 odd = lane & 1u;
    uint8 seed = spt_hash_u32x8((uint8)(pixel_key) ^ group);
    uint rsample = spt_reverse_bits(sample);
    uint8 shuffled = spt_reverse_bits_x8(spt_lk_hash_x8((uint8)(rsample), seed));
    /* Sobol dims 0 (the identity) and 1 (spt_sobol_rev_u32's superset sum). */
    uint8 x = shuffled;
    x ^= (x >> 1u) & 0x55555555u;
    x ^= (x >> 2u) & 0x33333333u;
    x ^= (x >> 4u) & 0x0f0f0f0fu;
    x ^= (x >> 8u) & 0x00ff00ffu;
    x ^= (x >> 16u) & 0x0000ffffu;
    uint8 v = select(shuffled, x, as_int8(odd) != (int8)(0));
    if (bounce == 1u) {
        /* The joined groups (lanes 2-5, the static asserts above) take Sobol
         * dims 2-5 of one index, shuffled by SPT_GROUP_JOINT_BASE's seed. */
        uint js = spt_reverse_bits(spt_lk_hash(rsample, spt_hash_u32(pixel_key ^ SPT_GROUP_JOINT_BASE)));
        uint4 j = (uint4)(spt_sobol_rev_u32(js, 2u), spt_sobol_rev_u32(js, 3u), spt_sobol_rev_u32(js, 4u),
                          spt_sobol_rev_u32(js, 5u));
        v = (uint8)(v.s01, j, v.s67);
    }
    uint8 h = spt_hash_u32x8(seed ^ select((uint8)(0x3c6ef372u), (uint8)(0x9e3779b9u + 0x3c6ef372u),
                                           as_int8(odd) != (int8)(0)));
    uint8 r = spt_reverse_bits_x8(spt_lk_hash_x8(v, h));
    vstore8(convert_float8(r >> 8u) * 5.9604644775390625e-8f, 0, u);
#else
    for (spt_u32 k = 0; k < SPT_DIM_BOUNCE_BLOCK; k++)
        u[k] = spt_sample_1d_key(pixel_key, sample, spt_dim_bounce(bounce, k));
#endif
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
    return spt_sample_1d_key(s.pixel_key, s.sample, dim);
}

#endif
