/* 4-lane float helpers of the BVH builder (src/accel/bvh_build.c, bvh_split.c). */
#ifndef SPT_BVH_LANES_H
#define SPT_BVH_LANES_H

#include <stdint.h>
#include <string.h>
#ifdef __SSE2__
#include <emmintrin.h>
#endif


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

#endif
