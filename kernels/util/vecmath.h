/* 3-vectors for code shared by host and kernels: float3 on the device, a plain
 * struct on the host, with the same function names on both sides. */
#ifndef SPT_VECMATH_H
#define SPT_VECMATH_H

#include "util/portable.h"

#if SPT_DEVICE
typedef float3 vec3;
SPT_FN vec3 v3(float x, float y, float z) { return (float3)(x, y, z); }
SPT_FN vec3 v3_add(vec3 a, vec3 b) { return a + b; }
SPT_FN vec3 v3_sub(vec3 a, vec3 b) { return a - b; }
SPT_FN vec3 v3_mul(vec3 a, vec3 b) { return a * b; }
SPT_FN vec3 v3_scale(vec3 a, float s) { return a * s; }
SPT_FN float v3_dot(vec3 a, vec3 b) { return dot(a, b); }
SPT_FN vec3 v3_cross(vec3 a, vec3 b) { return cross(a, b); }
SPT_FN vec3 v3_min(vec3 a, vec3 b) { return fmin(a, b); }
SPT_FN vec3 v3_max(vec3 a, vec3 b) { return fmax(a, b); }
/* normalize(a) without its range checks where |a|^2 is a normal float:
 * PoCL's normalize is then a * rsqrt(dot(a, a)) bit for bit, and the checks
 * (a scaling for tiny or huge vectors) were most of its 47 instructions per
 * call (docs/performance.md, "Generality a scene does not use"); other
 * vectors, zero among them, still take normalize. */
SPT_FN vec3 v3_unit(vec3 a)
{
    float d = dot(a, a);
    return d >= FLT_MIN && d <= FLT_MAX ? a * rsqrt(d) : normalize(a);
}
#else
typedef struct vec3 { float x, y, z; } vec3;
SPT_FN vec3 v3(float x, float y, float z) { vec3 r = {x, y, z}; return r; }
SPT_FN vec3 v3_add(vec3 a, vec3 b) { return v3(a.x + b.x, a.y + b.y, a.z + b.z); }
SPT_FN vec3 v3_sub(vec3 a, vec3 b) { return v3(a.x - b.x, a.y - b.y, a.z - b.z); }
SPT_FN vec3 v3_mul(vec3 a, vec3 b) { return v3(a.x * b.x, a.y * b.y, a.z * b.z); }
SPT_FN vec3 v3_scale(vec3 a, float s) { return v3(a.x * s, a.y * s, a.z * s); }
SPT_FN float v3_dot(vec3 a, vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
SPT_FN vec3 v3_cross(vec3 a, vec3 b)
{
    return v3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
SPT_FN vec3 v3_min(vec3 a, vec3 b) { return v3(fminf(a.x, b.x), fminf(a.y, b.y), fminf(a.z, b.z)); }
SPT_FN vec3 v3_max(vec3 a, vec3 b) { return v3(fmaxf(a.x, b.x), fmaxf(a.y, b.y), fmaxf(a.z, b.z)); }
#endif

SPT_FN float v3_length(vec3 a) { return sqrtf(v3_dot(a, a)); }
SPT_FN vec3 v3_normalize(vec3 a) { return v3_scale(a, 1.0f / v3_length(a)); }
/* Element i (0..2) of a; a read from a float[3] array at p. */
SPT_FN vec3 v3_load(const SPT_GLOBAL float *p) { return v3(p[0], p[1], p[2]); }

/* An orthonormal basis around unit n (Duff et al. 2017, "Building an Orthonormal
 * Basis, Revisited"). */
SPT_FN void v3_basis(vec3 n, vec3 *t, vec3 *b)
{
    float sign = copysignf(1.0f, n.z);
    float a = -1.0f / (sign + n.z);
    float bb = n.x * n.y * a;
    *t = v3(1.0f + sign * n.x * n.x * a, sign * bb, -sign * n.x);
    *b = v3(bb, sign + n.y * n.y * a, -n.y);
}

/* 4-wide spectral values (the path's SPT_NUM_LAMBDA wavelengths): float4 on the
 * device, a plain struct on the host, with the same function names. Added for the
 * BSDF library (kernels/closure/bsdf.h). */
#if SPT_DEVICE
typedef float4 vec4;
SPT_FN vec4 v4(float x, float y, float z, float w) { return (float4)(x, y, z, w); }
SPT_FN vec4 v4_add(vec4 a, vec4 b) { return a + b; }
SPT_FN vec4 v4_sub(vec4 a, vec4 b) { return a - b; }
SPT_FN vec4 v4_mul(vec4 a, vec4 b) { return a * b; }
SPT_FN vec4 v4_scale(vec4 a, float s) { return a * s; }
#else
typedef struct vec4 { float x, y, z, w; } vec4;
SPT_FN vec4 v4(float x, float y, float z, float w) { vec4 r = {x, y, z, w}; return r; }
SPT_FN vec4 v4_add(vec4 a, vec4 b) { return v4(a.x + b.x, a.y + b.y, a.z + b.z, a.w + b.w); }
SPT_FN vec4 v4_sub(vec4 a, vec4 b) { return v4(a.x - b.x, a.y - b.y, a.z - b.z, a.w - b.w); }
SPT_FN vec4 v4_mul(vec4 a, vec4 b) { return v4(a.x * b.x, a.y * b.y, a.z * b.z, a.w * b.w); }
SPT_FN vec4 v4_scale(vec4 a, float s) { return v4(a.x * s, a.y * s, a.z * s, a.w * s); }
#endif
SPT_FN vec4 v4_splat(float s) { return v4(s, s, s, s); }

#endif
