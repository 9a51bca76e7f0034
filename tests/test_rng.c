/* kernels/sample/rng.h: the counter-based generator and the Owen-scrambled Sobol sampler. */
#include "test_util.h"

#include <stdlib.h>
#include <string.h>

#include "chi2.h"
#include "cl/cl_device.h"
#include "sample/rng.h"
#include "sample/sampling.h"

/* Chi-square tests in this binary, for the Sidak correction. */
#define RNG_CHI2_TESTS 11

/* Values from an independent Python implementation of the hashes
 * (arbitrary-precision integers masked to 32 bits). */
TEST(test_rand_matches_reference)
{
    static const spt_u32 want[][5] = {
        {0u, 0u, 0u, 0u, 0x52fa79b7u},
        {1u, 2u, 3u, 4u, 0x48c7ebb6u},
        {3735928559u, 123456u, 789u, 17u, 0xd5ca7056u},
        {4294967295u, 4294967295u, 4294967295u, 4294967295u, 0x809aacf4u},
    };
    for (int i = 0; i < 4; i++) {
        const spt_u32 *w = want[i];
        spt_u32 got = spt_rand_bits(spt_rng_key(w[0], w[1], w[2]), w[3]);
        if (got != w[4])
            fail_msg("bits(%u,%u,%u,%u) = 0x%08x, expected 0x%08x", w[0], w[1], w[2], w[3], got,
                     w[4]);
        assert_true(spt_rand(w[0], w[1], w[2], w[3]) == (float)(w[4] >> 8) / 16777216.0f);
    }
    static const spt_u32 sob[][4] = {
        {0u, 0u, 0x00000000u, 0x5bc384eau},
        {1u, 1u, 0x00003039u, 0xed8854deu},
        {37u, 3u, 0xcafef00du, 0x79cd819du},
        {1000000u, 7u, 0xffffffffu, 0xc2328008u},
    };
    for (int i = 0; i < 4; i++) {
        spt_u32 got = spt_sobol_owen_u32(sob[i][0], sob[i][1], sob[i][2]);
        if (got != sob[i][3])
            fail_msg("sobol_owen(%u,%u,0x%08x) = 0x%08x, expected 0x%08x", sob[i][0], sob[i][1],
                     sob[i][2], got, sob[i][3]);
    }
}

/* Same arguments, same number, in any order of calls (no hidden state). */
TEST(test_rand_is_deterministic)
{
    float first[64];
    for (int i = 0; i < 64; i++)
        first[i] = spt_rand(7u, (spt_u32)i * 31u, (spt_u32)i, (spt_u32)i % 9u);
    for (int i = 63; i >= 0; i--) {
        (void)spt_rand(8u, 1u, 2u, 3u);
        assert_true(spt_rand(7u, (spt_u32)i * 31u, (spt_u32)i, (spt_u32)i % 9u) == first[i]);
    }
}

/* The conversion never returns 1, and 10^6 outputs lie in [0, 1). */
TEST(test_rand_range)
{
    assert_true(spt_u32_to_unit(0xffffffffu) < 1.0f);
    assert_true(spt_u32_to_unit(0xffffffffu) == 1.0f - 1.0f / 16777216.0f);
    assert_true(spt_u32_to_unit(0u) == 0.0f);
    assert_true(spt_u32_to_unit(0x80000000u) == 0.5f);
    for (spt_u32 i = 0; i < 1000000u; i++) {
        float u = spt_rand(3u, i >> 6, i & 63u, i % 97u);
        if (!(u >= 0.0f && u < 1.0f))
            fail_msg("spt_rand = %.9g for i = %u", u, i);
    }
}

/* 10^6 values over pixels, samples and dims into 1000 equal bins. */
TEST(test_rand_uniform_1d)
{
    enum { BINS = 1000 };
    static double obs[BINS], expct[BINS];
    memset(obs, 0, sizeof obs);
    const spt_u32 n = CHI2_DEFAULT_SAMPLES;
    for (spt_u32 i = 0; i < n; i++) {
        float u = spt_rand(11u, i % 1021u, i / 1021u, i % 37u);
        obs[(int)(u * BINS)] += 1.0;
    }
    for (int b = 0; b < BINS; b++)
        expct[b] = (double)n / BINS;
    Chi2Result r;
    chi2_test_counts("spt_rand 1D", obs, expct, BINS, chi2_sidak(0.01, RNG_CHI2_TESTS), &r);
    require_pass(&r);
}

/* Pairs of spt_rand values that differ in one argument; 2D uniformity of the pairs
 * shows the two are independent. */
typedef struct PairCtx {
    int which; /* 0: dims, 1: pixels, 2: samples, 3: seeds, 4: same dim of two bounces */
} PairCtx;

/* Sample i: a pair of spt_rand values differing in the argument ctx names. */
static int pair_sample(void *ctx, uint32_t i, double p[3])
{
    const PairCtx *c = ctx;
    spt_u32 seed = 5u, pixel = i % 4099u, sample = i / 4099u, dim = 9u;
    switch (c->which) {
    case 0:
        p[0] = spt_rand(seed, pixel, sample, dim);
        p[1] = spt_rand(seed, pixel, sample, dim + 1u);
        break;
    case 1:
        p[0] = spt_rand(seed, 2u * pixel, sample, dim);
        p[1] = spt_rand(seed, 2u * pixel + 1u, sample, dim);
        break;
    case 2:
        p[0] = spt_rand(seed, pixel, 2u * sample, dim);
        p[1] = spt_rand(seed, pixel, 2u * sample + 1u, dim);
        break;
    case 3:
        p[0] = spt_rand(i, pixel, sample, dim);
        p[1] = spt_rand(i + 1u, pixel, sample, dim);
        break;
    default:
        p[0] = spt_rand(seed, pixel, sample, spt_dim_bounce(1u, SPT_DIM_BSDF_U));
        p[1] = spt_rand(seed, pixel, sample, spt_dim_bounce(2u, SPT_DIM_BSDF_U));
        break;
    }
    return 1;
}

/* The uniform density on the unit square. */
static double uniform_pdf(void *ctx, const double p[3])
{
    (void)ctx;
    (void)p;
    return 1.0;
}

TEST(test_rand_independent_pairs)
{
    static const char *names[5] = {"pairs of dims", "pairs of pixels", "pairs of samples",
                                   "pairs of seeds", "one dim of two bounces"};
    for (int w = 0; w < 5; w++) {
        PairCtx c = {w};
        Chi2Grid g =
            chi2_plane(names[w], 0.0, 1.0, 0.0, 1.0, 32, 32, RNG_CHI2_TESTS, pair_sample, uniform_pdf, &c);
        chi2_require(&g);
    }
}

/* The direction-number table equals the one built here from Joe and Kuo's
 * (s, a, m) with the textbook recurrence
 * m_k = 2 a_1 m_{k-1} ^ 4 a_2 m_{k-2} ^ ... ^ 2^s m_{k-s} ^ m_{k-s}. */
TEST(test_sobol_directions_match_joe_kuo)
{
    static const struct { int s, a; spt_u32 m[5]; } jk[7] = {
        {1, 0, {1}}, {2, 1, {1, 3}}, {3, 1, {1, 3, 1}}, {3, 2, {1, 1, 1}},
        {4, 1, {1, 1, 3, 3}}, {4, 4, {1, 3, 5, 13}}, {5, 2, {1, 1, 5, 5, 17}},
    };
    for (int k = 0; k < 32; k++)
        assert_int_equal(SPT_SOBOL_DIRECTIONS[k], 1u << (31 - k));
    for (int d = 0; d < 7; d++) {
        uint64_t m[33];
        int s = jk[d].s;
        for (int k = 1; k <= 32; k++) {
            if (k <= s) {
                m[k] = jk[d].m[k - 1];
                continue;
            }
            uint64_t v = m[k - s] ^ (m[k - s] << s);
            for (int j = 1; j < s; j++)
                if ((jk[d].a >> (s - 1 - j)) & 1)
                    v ^= m[k - j] << j;
            m[k] = v;
        }
        for (int k = 1; k <= 32; k++) {
            spt_u32 want = (spt_u32)(m[k] << (32 - k));
            spt_u32 got = SPT_SOBOL_DIRECTIONS[(d + 1) * 32 + (k - 1)];
            if (got != want)
                fail_msg("Sobol dim %d direction %d: 0x%08x, expected 0x%08x", d + 1, k, got,
                         want);
        }
    }
    /* The first points of Sobol dim 1 in natural order, by hand from v = 1/2, 3/4, 5/8. */
    static const float first[8] = {0.0f, 0.5f, 0.75f, 0.25f, 0.625f, 0.125f, 0.375f, 0.875f};
    for (spt_u32 i = 0; i < 8; i++)
        assert_true(spt_u32_to_unit(spt_sobol_u32(i, 1)) == first[i]);
}

/* Every Sobol dim as spt_sobol_u32 computes it (dim 1 by its closed form,
 * Pascal's triangle mod 2; dims 2 and up from the table of 4-bit digits)
 * equals the XOR of the direction numbers of the index's bits, for indices
 * with bits everywhere (and so every entry of SPT_SOBOL_NIBBLE_REV is right). */
TEST(test_sobol_dims_match_directions)
{
    for (spt_u32 dim = 0; dim < SPT_SOBOL_DIMS; dim++)
        for (spt_u32 i = 0; i < 100000u; i++) {
            spt_u32 index = i < 50000u ? i : spt_hash_u32(i ^ dim);
            spt_u32 want = 0u;
            for (int k = 0; k < 32; k++)
                if ((index >> k) & 1u)
                    want ^= SPT_SOBOL_DIRECTIONS[32u * dim + (spt_u32)k];
            spt_u32 got = spt_sobol_u32(index, dim);
            if (got != want)
                fail_msg("Sobol dim %u of index 0x%08x: 0x%08x, expected 0x%08x", dim, index, got, want);
        }
}

/* The kernels' shortcuts spt_sample_pair and the SptSampler functions give exactly spt_sample_1d of the dims they stand for
 * (spt_rand for the independent sampler), at the camera dims and at the dims of
 * several bounces. */
TEST(test_sample_pair_matches_1d)
{
    enum { GROUPS = SPT_DIM_BOUNCE_BASE / 2u + 6u * SPT_DIM_BOUNCE_BLOCK / 2u };
    for (spt_u32 n = 0; n < 20000u; n++) {
        spt_u32 seed = n % 7u, pixel = spt_hash_u32(n) % 1000003u, sample = n * 37u % 4099u;
        spt_u32 key = spt_sobol_pixel_key(seed, pixel);
        SptSampler sob = spt_sampler(SPT_SAMPLER_SOBOL, seed, pixel, sample);
        SptSampler ind = spt_sampler(SPT_SAMPLER_INDEPENDENT, seed, pixel, sample);
        for (spt_u32 group = 0; group < GROUPS; group++) {
            spt_u32 d = 2u * group;
            float u0, u1, s0, s1, i0, i1;
            spt_sample_pair(key, sample, group, &u0, &u1);
            spt_sampler_pair(sob, d, &s0, &s1);
            spt_sampler_pair(ind, d, &i0, &i1);
            float w0 = spt_sample_1d(seed, pixel, sample, d), w1 = spt_sample_1d(seed, pixel, sample, d + 1u);
            if (u0 != w0 || u1 != w1 || s0 != w0 || s1 != w1)
                fail_msg("pair group %u of (%u, %u, %u): (%.9g, %.9g) and (%.9g, %.9g), spt_sample_1d "
                         "(%.9g, %.9g)", group, seed, pixel, sample, u0, u1, s0, s1, w0, w1);
            if (spt_sampler_1d(sob, d) != w0 || spt_sampler_1d(sob, d + 1u) != w1)
                fail_msg("spt_sampler_1d of dims %u, %u differs from spt_sample_1d", d, d + 1u);
            if (i0 != spt_rand(seed, pixel, sample, d) || i1 != spt_rand(seed, pixel, sample, d + 1u) ||
                spt_sampler_1d(ind, d + 1u) != i1)
                fail_msg("the independent sampler's dims %u, %u are not spt_rand's", d, d + 1u);
        }
    }
}

/* Whether the points p[i] (s coordinates each, i < 2^k) form a (t,k,s)-net in
 * base 2: for every d_1 + ... + d_s = k - t, each box of sides 2^-d_j holds
 * 2^t points. d is the composition being filled from coordinate j on. */
static int is_net_rec(const float (*p)[6], int s, int k, int t, int *d, int j, int left, int *count,
                      char *why, size_t why_len)
{
    if (j == s - 1) {
        d[j] = left;
        int boxes = 1 << (k - t);
        memset(count, 0, sizeof(int) * (size_t)boxes);
        for (int i = 0; i < (1 << k); i++) {
            int b = 0;
            for (int c = 0; c < s; c++)
                b = (b << d[c]) | (int)(p[i][c] * (float)(1 << d[c]));
            count[b]++;
        }
        for (int b = 0; b < boxes; b++)
            if (count[b] != 1 << t) {
                snprintf(why, why_len, "k = %d, t = %d, sides 2^-(%d %d %d %d %d %d): box %d holds %d points",
                         k, t, d[0], s > 1 ? d[1] : 0, s > 2 ? d[2] : 0, s > 3 ? d[3] : 0, s > 4 ? d[4] : 0,
                         s > 5 ? d[5] : 0, b, count[b]);
                return 0;
            }
        return 1;
    }
    for (int a = 0; a <= left; a++) {
        d[j] = a;
        if (!is_net_rec(p, s, k, t, d, j + 1, left - a, count, why, why_len))
            return 0;
    }
    return 1;
}

static int is_net(const float (*p)[6], int s, int k, int t, char *why, size_t why_len)
{
    if (t >= k)
        return 1; /* every box is the whole cube */
    int d[6];
    int *count = calloc((size_t)1 << (k - t), sizeof(int));
    int ok = is_net_rec(p, s, k, t, d, 0, k - t, count, why, why_len);
    free(count);
    return ok;
}

/* is_net of the 2D points (x[i], y[i]). */
static int is_pair_t_net(const float *x, const float *y, int k, int t, char *why, size_t why_len)
{
    static float p[1 << 12][6];
    for (int i = 0; i < (1 << k); i++) {
        p[i][0] = x[i];
        p[i][1] = y[i];
    }
    return is_net((const float (*)[6])p, 2, k, t, why, why_len);
}

/* Whether points (x[i], y[i]), i < 2^k, form a (0,k,2)-net in base 2: for every
 * a + b = k, each box [i/2^a, (i+1)/2^a) x [j/2^b, (j+1)/2^b) holds one point. */
static int is_02_net(const float *x, const float *y, int k, char *why, size_t why_len)
{
    return is_pair_t_net(x, y, k, 0, why, why_len);
}

/* The t of the Sobol dims a joined pair group takes (rng.h): the bound of
 * Sobol's construction, t <= sum (e_j - 1) over the dims' primitive
 * polynomials' degrees e_j (Joe and Kuo's dims 3-6: x^2+x+1, x^3+x+1,
 * x^3+x^2+1, x^4+x+1), so 1 + 2 for Sobol dims 2-3 and 2 + 3 for dims 4-5;
 * Owen scrambling and the aligned-block shuffle keep a net a net. 0 for a
 * padded group (Sobol dims 0-1, a (0,2)-sequence). */
static int joined_pair_t(spt_u32 dim)
{
    if (dim >> 1 == SPT_GROUP_JOINT_LIGHT)
        return 3;
    if (dim >> 1 == SPT_GROUP_JOINT_BSDF)
        return 5;
    return 0;
}

/* Every power-of-two prefix (and later aligned blocks) of a pixel's 2D samples
 * is a (0,k,2)-net: the pixel and lens pairs, and at bounces 0, 1 and 7 the
 * pairs (light choice, BSDF lobe), the point on the light, the BSDF direction
 * and (roulette, spare), for several pixels and seeds; the two pairs at bounce
 * 1 joined to the BSDF direction at bounce 0 are (t,k,2)-nets with the t of
 * their Sobol dims. */
TEST(test_sobol_prefixes_are_nets)
{
    enum { K = 10 };
    static float x[1 << K], y[1 << K];
    char why[200];
    static const spt_u32 pixels[3] = {0u, 1u, 987654u};
    spt_u32 dims[2 + 3 * 4], nd = 0;
    dims[nd++] = SPT_DIM_PIXEL_X;
    dims[nd++] = SPT_DIM_LENS_U;
    static const spt_u32 bounces[3] = {0u, 1u, 7u};
    for (int b = 0; b < 3; b++)
        for (spt_u32 k = 0; k < SPT_DIM_BOUNCE_BLOCK; k += 2u)
            dims[nd++] = spt_dim_bounce(bounces[b], k);
    assert_int_equal(spt_dim_bounce(0, SPT_DIM_LIGHT_SELECT) + 1u, spt_dim_bounce(0, SPT_DIM_BSDF_LOBE));
    assert_int_equal(spt_dim_bounce(0, SPT_DIM_LIGHT_U) + 1u, spt_dim_bounce(0, SPT_DIM_LIGHT_V));
    assert_int_equal(spt_dim_bounce(0, SPT_DIM_BSDF_U) + 1u, spt_dim_bounce(0, SPT_DIM_BSDF_V));
    for (int pi = 0; pi < 3; pi++)
        for (spt_u32 j = 0; j < nd; j++) {
            spt_u32 d = dims[j];
            assert_int_equal(d % 2u, 0);
            for (int k = 0; k <= K; k++)
                for (spt_u32 block = 0; block < 3; block++) {
                    spt_u32 start = block << k;
                    for (int i = 0; i < (1 << k); i++) {
                        x[i] = spt_sample_1d(42u + (spt_u32)pi, pixels[pi], start + (spt_u32)i, d);
                        y[i] = spt_sample_1d(42u + (spt_u32)pi, pixels[pi], start + (spt_u32)i, d + 1u);
                    }
                    if (!is_pair_t_net(x, y, k, joined_pair_t(d), why, sizeof why))
                        fail_msg("pixel %u, dims %u-%u, samples %u..%u: %s", pixels[pi], d, d + 1u, start,
                                 start + (1u << k) - 1u, why);
                }
        }
}

/* The BSDF direction at bounce 0, the point on the light and the BSDF
 * direction at bounce 1 and the hero wavelength are one Sobol point set
 * (Sobol dims 0-6): every power-of-two prefix of a pixel's samples in the
 * first 6 is a (t,k,6)-net with Sobol's bound t <= 0 + 0 + 1 + 2 + 2 + 3 = 8
 * (joined_pair_t), in the first 4 a (3,k,4)-net, and the first direction
 * with the wavelength (Sobol dims 0, 1, 6; x^4+x^3+1) a (3,k,3)-net; padded
 * pairs are not stratified together (the point on the light and the BSDF
 * direction at bounce 0, as 4 dims, are no (3,10,4)-net). */
TEST(test_sobol_joined_dims)
{
    enum { K = 10 };
    static float p[1 << K][6];
    char why[200];
    static const spt_u32 pixels[3] = {0u, 1u, 987654u};
    const spt_u32 dims[6] = {spt_dim_bounce(0, SPT_DIM_BSDF_U), spt_dim_bounce(0, SPT_DIM_BSDF_V),
                             spt_dim_bounce(1, SPT_DIM_LIGHT_U), spt_dim_bounce(1, SPT_DIM_LIGHT_V),
                             spt_dim_bounce(1, SPT_DIM_BSDF_U), spt_dim_bounce(1, SPT_DIM_BSDF_V)};
    assert_int_equal(dims[0] >> 1, SPT_GROUP_JOINT_BASE);
    for (int pi = 0; pi < 3; pi++)
        for (int k = 0; k <= K; k++)
            for (spt_u32 block = 0; block < 2; block++) {
                spt_u32 start = block << k;
                for (int i = 0; i < (1 << k); i++)
                    for (int c = 0; c < 6; c++)
                        p[i][c] = spt_sample_1d(7u + (spt_u32)pi, pixels[pi], start + (spt_u32)i, dims[c]);
                if (!is_net((const float (*)[6])p, 6, k, 8, why, sizeof why))
                    fail_msg("pixel %u, samples %u..%u, 6 joined dims: %s", pixels[pi], start,
                             start + (1u << k) - 1u, why);
                if (!is_net((const float (*)[6])p, 4, k, 3, why, sizeof why))
                    fail_msg("pixel %u, samples %u..%u, first 4 joined dims: %s", pixels[pi], start,
                             start + (1u << k) - 1u, why);
                for (int i = 0; i < (1 << k); i++)
                    p[i][2] = spt_sample_1d(7u + (spt_u32)pi, pixels[pi], start + (spt_u32)i, SPT_DIM_WAVELENGTH);
                if (!is_net((const float (*)[6])p, 3, k, 3, why, sizeof why))
                    fail_msg("pixel %u, samples %u..%u, first direction and wavelength: %s", pixels[pi], start,
                             start + (1u << k) - 1u, why);
            }
    const spt_u32 padded[4] = {spt_dim_bounce(0, SPT_DIM_LIGHT_U), spt_dim_bounce(0, SPT_DIM_LIGHT_V),
                               spt_dim_bounce(0, SPT_DIM_BSDF_U), spt_dim_bounce(0, SPT_DIM_BSDF_V)};
    for (int i = 0; i < (1 << K); i++)
        for (int c = 0; c < 4; c++)
            p[i][c] = spt_sample_1d(7u, 0u, (spt_u32)i, padded[c]);
    assert_false(is_net((const float (*)[6])p, 4, K, 3, why, sizeof why));
}

/* The integral of a smooth function over a pixel's BSDF direction pair
 * converges faster than 1/N with the Sobol sampler (Owen scrambling: N^-1.5 for
 * smooth integrands), and like 1/sqrt(N) with the independent one. The RMS error
 * over 512 pixels (independent scrambles) of the N-sample estimate of the
 * integral of u exp(u v) over the unit square, e - 2. */
static double smooth_rms_error(spt_u32 kind, spt_u32 n)
{
    enum { PIXELS = 512 };
    const double exact = exp(1.0) - 2.0;
    spt_u32 d = spt_dim_bounce(0, SPT_DIM_BSDF_U);
    double se = 0;
    for (spt_u32 p = 0; p < PIXELS; p++) {
        double sum = 0;
        for (spt_u32 i = 0; i < n; i++) {
            float u, v;
            spt_sampler_pair(spt_sampler(kind, 5u, p * 7919u, i), d, &u, &v);
            sum += u * exp((double)u * v);
        }
        double err = sum / n - exact;
        se += err * err;
    }
    return sqrt(se / PIXELS);
}

TEST(test_sobol_converges_faster)
{
    double sob16 = smooth_rms_error(SPT_SAMPLER_SOBOL, 16u), sob1k = smooth_rms_error(SPT_SAMPLER_SOBOL, 1024u);
    double ind16 = smooth_rms_error(SPT_SAMPLER_INDEPENDENT, 16u),
           ind1k = smooth_rms_error(SPT_SAMPLER_INDEPENDENT, 1024u);
    double sob_slope = log(sob1k / sob16) / log(64.0), ind_slope = log(ind1k / ind16) / log(64.0);
    printf("smooth 2D integrand, RMS error at 16 and 1024 samples: sobol %.3g %.3g (slope %.2f), "
           "independent %.3g %.3g (slope %.2f)\n", sob16, sob1k, sob_slope, ind16, ind1k, ind_slope);
    /* 1/N would be a slope of -1; Owen-scrambled Sobol reaches about -1.5. */
    assert_true(sob_slope < -1.25);
    assert_true(ind_slope > -0.65 && ind_slope < -0.35);
    assert_true(sob1k < 0.02 * ind1k);
}

/* Every Sobol dim (and the wavelength dim) is stratified in 1D: the first 2^k
 * points fall one in each interval of length 2^-k. */
TEST(test_sobol_1d_stratified)
{
    enum { K = 12 };
    static int count[1 << K];
    for (spt_u32 dim = 0; dim <= SPT_SOBOL_DIMS; dim++)
        for (int k = 0; k <= K; k++) {
            int n = 1 << k;
            memset(count, 0, sizeof(int) * (size_t)n);
            for (int i = 0; i < n; i++) {
                /* dim == SPT_SOBOL_DIMS stands for the renderer's wavelength dim. */
                float u = dim < SPT_SOBOL_DIMS
                              ? spt_sobol_owen((spt_u32)i, dim, 0x1234567u + dim)
                              : spt_sample_1d(9u, 77u, (spt_u32)i, SPT_DIM_WAVELENGTH);
                count[(int)(u * (float)n)]++;
            }
            for (int c = 0; c < n; c++)
                if (count[c] != 1)
                    fail_msg("dim %u, first %d points: interval %d holds %d", dim, n, c,
                             count[c]);
        }
}

/* The first sample of each pixel is a uniform random point (a chi-square over
 * 2^18 pixels): different pixels get independent scrambles. */
static int first_point_sample(void *ctx, uint32_t i, double p[3])
{
    (void)ctx;
    p[0] = spt_sample_1d(1u, i, 0u, SPT_DIM_PIXEL_X);
    p[1] = spt_sample_1d(1u, i, 0u, SPT_DIM_PIXEL_Y);
    return 1;
}

/* Dims of different groups over the samples of one pixel: the point on the
 * light against the BSDF direction at bounce 0 (padded groups, decorrelated by
 * their shuffles), and the BSDF direction at bounce 0 against bounce 1 (joined
 * groups: Sobol dims 0 and 4 of one sequence, stratified together). */
static int light_bsdf_sample(void *ctx, uint32_t i, double p[3])
{
    (void)ctx;
    p[0] = spt_sample_1d(1u, 5u, i, spt_dim_bounce(0, SPT_DIM_LIGHT_U));
    p[1] = spt_sample_1d(1u, 5u, i, spt_dim_bounce(0, SPT_DIM_BSDF_V));
    return 1;
}

static int bounce01_sample(void *ctx, uint32_t i, double p[3])
{
    (void)ctx;
    p[0] = spt_sample_1d(1u, 5u, i, spt_dim_bounce(0, SPT_DIM_BSDF_U));
    p[1] = spt_sample_1d(1u, 5u, i, spt_dim_bounce(1, SPT_DIM_BSDF_U));
    return 1;
}

/* Pixel dim 0 against lens dim 2 over the samples of one pixel: the two Sobol
 * groups must be decorrelated by their shuffles (identical shuffles would put
 * every point on the diagonal). */
static int pixel_lens_sample(void *ctx, uint32_t i, double p[3])
{
    (void)ctx;
    p[0] = spt_sample_1d(1u, 5u, i, SPT_DIM_PIXEL_X);
    p[1] = spt_sample_1d(1u, 5u, i, SPT_DIM_LENS_U);
    return 1;
}

/* A chi-square grid of 16 x 16 cells over the unit square against the
 * uniform density, for the points that sample() makes. */
static Chi2Grid uniform_square_grid(const char *name, uint32_t samples,
                                    int (*sample)(void *, uint32_t, double[3]))
{
    Chi2Grid g = chi2_plane(name, 0.0, 1.0, 0.0, 1.0, 16, 16, RNG_CHI2_TESTS, sample, uniform_pdf, NULL);
    g.samples = samples;
    return g;
}

TEST(test_sobol_scrambles_differ)
{
    Chi2Grid g = uniform_square_grid("", 0, NULL);
    Chi2Result r;

    g.name = "first sample of 2^18 pixels";
    g.samples = 1u << 18;
    g.sample = first_point_sample;
    chi2_grid_run(&g, &r);
    require_pass(&r);

    g.name = "pixel x against lens u";
    g.samples = 1u << 16;
    g.sample = pixel_lens_sample;
    chi2_grid_run(&g, &r);
    require_pass(&r);

    g.name = "light u against BSDF v at bounce 0";
    g.sample = light_bsdf_sample;
    chi2_grid_run(&g, &r);
    require_pass(&r);

    g.name = "BSDF u at bounce 0 against bounce 1";
    g.sample = bounce01_sample;
    chi2_grid_run(&g, &r);
    require_pass(&r);

    /* Two neighbouring pixels never share a sequence. */
    int same = 0;
    for (spt_u32 i = 0; i < 1024u; i++)
        same += spt_sample_1d(1u, 10u, i, 0u) == spt_sample_1d(1u, 11u, i, 0u);
    assert_true(same < 4);
}

/* ---- ZSobol ------------------------------------------------------------------ */

/* Dims (d, d + 1) of sample s of pixel (x, y) under ZSobol, 2^l samples per
 * pixel, in a 64 x 48 image. */
static void zs_point(spt_u32 seed, spt_u32 x, spt_u32 y, spt_u32 l, spt_u32 s, spt_u32 d, float *u, float *v)
{
    *u = spt_zsobol_1d(seed, x, y, 64u, 48u, l, s, d);
    *v = spt_zsobol_1d(seed, x, y, 64u, 48u, l, s, d + 1u);
}

/* A pixel's 2^l samples are a (0,l,2)-net in every pair of dims, and so are
 * their first 2^k for k < l of l's parity (the Sobol index's low base-4
 * digits, below them the single bit of an odd l, vary first), for several
 * pixels, seeds, l and pair groups. */
TEST(test_zsobol_pixel_nets)
{
    static float x[1 << 10], y[1 << 10];
    char why[200];
    static const spt_u32 px[3][2] = {{0u, 0u}, {5u, 3u}, {63u, 47u}};
    static const spt_u32 dims[5] = {SPT_DIM_PIXEL_X, SPT_DIM_LENS_U, 6u, 10u, 6u + 8u * 7u + 4u};
    for (spt_u32 l = 0; l <= 10u; l++)
        for (int p = 0; p < 3; p++)
            for (int j = 0; j < 5; j++) {
                for (spt_u32 s = 0; s < (1u << l); s++)
                    zs_point(7u + (spt_u32)p, px[p][0], px[p][1], l, s, dims[j], &x[s], &y[s]);
                if (!is_02_net(x, y, (int)l, why, sizeof why))
                    fail_msg("pixel (%u, %u), 2^%u samples, dims %u-%u: %s", px[p][0], px[p][1], l, dims[j],
                             dims[j] + 1u, why);
                for (spt_u32 k = l & 1u; k < l; k += 2u)
                    if (!is_02_net(x, y, (int)k, why, sizeof why))
                        fail_msg("pixel (%u, %u), 2^%u samples, the first 2^%u, dims %u-%u: %s", px[p][0],
                                 px[p][1], l, k, dims[j], dims[j] + 1u, why);
            }
}

/* Ahmed and Wonka's property: the samples of an aligned block of 2^b x 2^b
 * pixels together form a (0, l + 2b, 2)-net, so neighbouring pixels fill each
 * other's gaps (blue-noise error); at one sample per pixel, for example, each
 * 4 x 4 block's 16 pixels hold one point in each 1/4 x 1/4 square. */
TEST(test_zsobol_pixel_blocks_are_nets)
{
    static float x[1 << 10], y[1 << 10];
    char why[200];
    for (spt_u32 l = 0; l <= 3u; l++)
        for (spt_u32 b = 1; b <= 3u; b++) {
            spt_u32 side = 1u << b;
            for (spt_u32 by = 0; by < 48u; by += side)
                for (spt_u32 bx = 0; bx < 64u; bx += side)
                    for (spt_u32 d = 0; d < 12u; d += 2u) {
                        spt_u32 n = 0;
                        for (spt_u32 py = by; py < by + side; py++)
                            for (spt_u32 pxl = bx; pxl < bx + side; pxl++)
                                for (spt_u32 s = 0; s < (1u << l); s++, n++)
                                    zs_point(3u, pxl, py, l, s, d, &x[n], &y[n]);
                        if (!is_02_net(x, y, (int)(l + 2u * b), why, sizeof why))
                            fail_msg("block of %u x %u pixels at (%u, %u), 2^%u samples, dims %u-%u: %s", side,
                                     side, bx, by, l, d, d + 1u, why);
                    }
        }
}

/* Every pixel's first sample is a uniform random point at 2^20 samples per
 * pixel (as a --time render's cap may make it: the pixel's bits lie far above
 * the sample's there, and only the digit permutations keep the pixels apart). */
static int zs_first_point(void *ctx, uint32_t i, double p[3])
{
    (void)ctx;
    p[0] = spt_zsobol_1d(1u, i % 256u, i / 256u, 256u, 256u, 20u, 0u, SPT_DIM_PIXEL_X);
    p[1] = spt_zsobol_1d(1u, i % 256u, i / 256u, 256u, 256u, 20u, 0u, SPT_DIM_PIXEL_Y);
    return 1;
}

/* The kernels' form (spt_sampler_for, spt_sampler_pair and spt_sampler_1d)
 * gives spt_zsobol_1d's values, and the first samples of 2^16 pixels pass a
 * chi-square for uniformity. */
TEST(test_zsobol_sampler)
{
    RenderParams p;
    memset(&p, 0, sizeof p);
    p.width = 37;
    p.height = 23;
    p.seed = 99u;
    p.sampler = SPT_SAMPLER_ZSOBOL;
    p.zsobol_log2spp = 5u;
    p.zsobol_digits = spt_zsobol_digits(37u, 23u, 5u);
    for (spt_u32 pixel = 0; pixel < 37u * 23u; pixel += 17u)
        for (spt_u32 s = 0; s < 32u; s += 3u) {
            SptSampler smp = spt_sampler_for(&p, pixel, s);
            for (spt_u32 d = 0; d < 40u; d += 2u) {
                float u, v;
                spt_sampler_pair(smp, d, &u, &v);
                float eu = spt_zsobol_1d(99u, pixel % 37u, pixel / 37u, 37u, 23u, 5u, s, d);
                float ev = spt_zsobol_1d(99u, pixel % 37u, pixel / 37u, 37u, 23u, 5u, s, d + 1u);
                assert_true(u == eu && v == ev);
                assert_true(spt_sampler_1d(smp, d) == eu && spt_sampler_1d(smp, d + 1u) == ev);
            }
        }
    Chi2Grid g = uniform_square_grid("ZSobol: first sample of 2^16 pixels at 2^20 samples per pixel", 1u << 16,
                                     zs_first_point);
    Chi2Result r;
    chi2_grid_run(&g, &r);
    require_pass(&r);
}

/* ---- Host and device agree ------------------------------------------------------ */

static const char device_src[] =
    "#include \"sample/rng.h\"\n"
    "#include \"sample/sampling.h\"\n"
    "__kernel void k_rng_check(__global uint *bits, __global float *f,\n"
    "                          __global const float *cdf, uint ncdf)\n"
    "{\n"
    "    uint i = get_global_id(0);\n"
    "    bits[13 * i + 0] = spt_rand_bits(spt_rng_key(7u, i * 3u, i / 5u), i % 41u);\n"
    "    bits[13 * i + 1] = spt_sobol_owen_u32(i, i % SPT_SOBOL_DIMS, 0x9e3779b9u * i);\n"
    "    bits[13 * i + 2] = as_uint(spt_sample_1d(3u, i / 64u, i % 64u, i % 23u));\n"
    "    float prob, ur;\n"
    "    bits[13 * i + 3] = (uint)spt_discrete_sample(cdf, ncdf, spt_rand(1u, i, 0u, 0u), &prob, &ur);\n"
    "    bits[13 * i + 4] = as_uint(spt_zsobol_1d(3u, i % 37u, i / 37u, 37u, 111u, i % 7u,\n"
    "                                            (i * 13u) & ((1u << (i % 7u)) - 1u), i % 13u));\n"
    "    float ub[SPT_DIM_BOUNCE_BLOCK];\n"
    "    spt_sample_bounce(spt_sobol_pixel_key(5u, i / 16u), i * 2654435769u, i % 5u, ub);\n"
    "    for (uint k = 0u; k < SPT_DIM_BOUNCE_BLOCK; k++)\n"
    "        bits[13 * i + 5u + k] = as_uint(ub[k]);\n"
    "    float u1 = spt_rand(2u, i, 0u, 0u), u2 = spt_rand(2u, i, 0u, 1u);\n"
    "    vec3 c = spt_sample_cosine_hemisphere(u1, u2);\n"
    "    vec3 s = spt_sample_uniform_sphere(u1, u2);\n"
    "    vec3 t = spt_sample_triangle_bary(u1, u2);\n"
    "    __global float *o = f + 12 * i;\n"
    "    o[0] = c.x; o[1] = c.y; o[2] = c.z; o[3] = s.x; o[4] = s.y; o[5] = s.z;\n"
    "    o[6] = t.x; o[7] = t.y; o[8] = t.z; o[9] = prob; o[10] = ur;\n"
    "    o[11] = spt_power_heuristic(u1, u2);\n"
    "}\n";

/* The same computations as k_rng_check, on the host, for item i; a bounce's
 * dims (spt_sample_bounce's eight lanes on the device, bounces 0-4: bounce 1
 * holds the joined groups) from their definition, spt_sample_1d. */
static void host_check(spt_u32 i, const float *cdf, spt_u32 ncdf, spt_u32 bits[13], float f[12])
{
    for (spt_u32 k = 0; k < SPT_DIM_BOUNCE_BLOCK; k++) {
        float b = spt_sample_1d(5u, i / 16u, i * 2654435769u, spt_dim_bounce(i % 5u, k));
        memcpy(&bits[5 + k], &b, sizeof b);
    }
    float u = spt_sample_1d(3u, i / 64u, i % 64u, i % 23u); /* dims of groups 0-11 */
    float z = spt_zsobol_1d(3u, i % 37u, i / 37u, 37u, 111u, i % 7u, (i * 13u) & ((1u << (i % 7u)) - 1u),
                            i % 13u);
    memcpy(&bits[4], &z, sizeof z);
    bits[0] = spt_rand_bits(spt_rng_key(7u, i * 3u, i / 5u), i % 41u);
    bits[1] = spt_sobol_owen_u32(i, i % SPT_SOBOL_DIMS, 0x9e3779b9u * i);
    memcpy(&bits[2], &u, sizeof u);
    float prob, ur;
    bits[3] = (spt_u32)spt_discrete_sample(cdf, ncdf, spt_rand(1u, i, 0u, 0u), &prob, &ur);
    float u1 = spt_rand(2u, i, 0u, 0u), u2 = spt_rand(2u, i, 0u, 1u);
    vec3 c = spt_sample_cosine_hemisphere(u1, u2);
    vec3 s = spt_sample_uniform_sphere(u1, u2);
    vec3 t = spt_sample_triangle_bary(u1, u2);
    float v[12] = {c.x, c.y, c.z, s.x, s.y, s.z, t.x, t.y, t.z, prob, ur,
                   spt_power_heuristic(u1, u2)};
    memcpy(f, v, sizeof v);
}

/* Runs k_rng_check built with `options` on d and compares with the host: the
 * integer outputs (hashes, Sobol points, sampler values as bits, discrete
 * choices) exactly, the warps to within float_tol. */
static void run_device_check(ClDevice *d, const char *options, float float_tol)
{
    enum { N = 4096, NCDF = 5 };
    const float cdf[NCDF + 1] = {0.0f, 0.125f, 0.125f, 0.5f, 0.875f, 1.0f};
    SptError e = {0};
    cl_program prog = NULL;
    if (cl_program_build_text(d, "kernels/test_rng_check.cl", device_src, options, &prog, &e)) {
        cl_device_report(d, &e);
        fail_msg("kernel build failed: %s", e.msg);
    }
    cl_int err = CL_SUCCESS;
    cl_kernel k = clCreateKernel(prog, "k_rng_check", &err);
    assert_int_equal(err, CL_SUCCESS);
    cl_mem bits_buf = NULL, f_buf = NULL, cdf_buf = NULL;
    assert_int_equal(cl_buffer_create(d, "bits", CL_MEM_WRITE_ONLY, sizeof(cl_uint) * 13 * N, NULL,
                                      &bits_buf, &e),
                     0);
    assert_int_equal(cl_buffer_create(d, "floats", CL_MEM_WRITE_ONLY, sizeof(float) * 12 * N,
                                      NULL, &f_buf, &e),
                     0);
    assert_int_equal(cl_buffer_create(d, "cdf", CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR,
                                      sizeof cdf, (void *)cdf, &cdf_buf, &e),
                     0);
    cl_uint ncdf = NCDF;
    assert_int_equal(clSetKernelArg(k, 0, sizeof bits_buf, &bits_buf), CL_SUCCESS);
    assert_int_equal(clSetKernelArg(k, 1, sizeof f_buf, &f_buf), CL_SUCCESS);
    assert_int_equal(clSetKernelArg(k, 2, sizeof cdf_buf, &cdf_buf), CL_SUCCESS);
    assert_int_equal(clSetKernelArg(k, 3, sizeof ncdf, &ncdf), CL_SUCCESS);
    size_t global = N;
    assert_int_equal(clEnqueueNDRangeKernel(d->queue, k, 1, NULL, &global, NULL, 0, NULL, NULL),
                     CL_SUCCESS);
    static cl_uint bits[13 * N];
    static float f[12 * N];
    assert_int_equal(clEnqueueReadBuffer(d->queue, bits_buf, CL_TRUE, 0, sizeof bits, bits, 0,
                                         NULL, NULL),
                     CL_SUCCESS);
    assert_int_equal(
        clEnqueueReadBuffer(d->queue, f_buf, CL_TRUE, 0, sizeof f, f, 0, NULL, NULL),
        CL_SUCCESS);
    clReleaseMemObject(bits_buf);
    clReleaseMemObject(f_buf);
    clReleaseMemObject(cdf_buf);
    clReleaseKernel(k);
    clReleaseProgram(prog);
    float worst = 0.0f;
    for (spt_u32 i = 0; i < N; i++) {
        spt_u32 hb[13];
        float hf[12];
        host_check(i, cdf, NCDF, hb, hf);
        for (int j = 0; j < 13; j++)
            if (bits[13 * i + j] != hb[j])
                fail_msg("options \"%s\": item %u, integer output %d: device 0x%08x, host 0x%08x",
                         options, i, j, bits[13 * i + j], hb[j]);
        for (int j = 0; j < 12; j++) {
            /* Output 2, the cosine-hemisphere z = sqrt(1 - x^2 - y^2), is
             * compared through z^2: near the horizon sqrt magnifies an error
             * of z^2 by 1/(2z), and OpenCL allows such errors (see the
             * tolerance at the call). */
            float diff = j == 2 ? fabsf(f[12 * i + j] * f[12 * i + j] - hf[j] * hf[j])
                                : fabsf(f[12 * i + j] - hf[j]);
            if (!(diff <= float_tol))
                fail_msg("options \"%s\": item %u, float output %d: device %.9g, host %.9g",
                         options, i, j, f[12 * i + j], hf[j]);
            worst = fmaxf(worst, diff);
        }
    }
    print_message("  options \"%s\": integer outputs identical, warps within %.3g\n", options,
                  worst);
}

/* The headers compile as OpenCL C 1.2, and the default OpenCL device (a GPU when
 * there is one) produces the host's random numbers bit for bit, also under
 * -cl-fast-relaxed-math (the "Scale" principle: a sample's numbers do not depend
 * on the device), and the host's warps to float precision (loosely under fast
 * math, which allows approximate sin and cos). Skipped without an OpenCL device. */
TEST(test_device_matches_host)
{
    SptError e = {0};
    ClDevice *devs = NULL;
    int count = 0;
    if (cl_devices_open(NULL, 0, &devs, &count, &e)) {
        print_message("no OpenCL device: %s\n", e.msg);
        skip();
    }
    print_message("  device: %s (%s)\n", devs[0].info.name, devs[0].info.platform_name);
    /* The warps' tolerance, from what OpenCL C 1.2 allows a device: sin and
     * cos within 4 ulp and division within 2.5 ulp (section 7.4), so the
     * concentric disk's x = r cos(pi/4 b/a) and y are within 8 ulp, a
     * relative 8 * 2^-23; and contraction of a*b + c into an FMA (FP_CONTRACT
     * is on by default, section 6.10), which skips up to three roundings of
     * 2^-24 in 1 - x*x - y*y.
     * Hence |x|, |y| off by at most 4.8e-7 and z^2 by at most
     * 2 (x^2 + y^2) 8 2^-23 + 3 2^-24 = 2.1e-6; the other warps are of the
     * same kind with smaller terms. */
    run_device_check(&devs[0], "", 2.1e-6f);
    run_device_check(&devs[0], "-cl-fast-relaxed-math", 1e-3f);
    cl_devices_close(devs, count);
}

TEST_MAIN("rng", NULL, NULL)
