/* The structs shared by host and kernels whose layout must agree on both sides.
 * kernels/util/layout_check.cl reports the device's sizeof of every struct of
 * SPT_LAYOUT_STRUCTS and the offset of every field of SPT_LAYOUT_FIELDS;
 * tests/test_cl.c (and `spectrace devices --check`) compares them with the host
 * compiler's. When you add a shared struct, include its header here and add it
 * to SPT_LAYOUT_STRUCTS, plus the fields whose placement is easy to get wrong
 * (after arrays, before padding) to SPT_LAYOUT_FIELDS. */
#ifndef SPT_LAYOUT_LIST_H
#define SPT_LAYOUT_LIST_H

#include "util/portable.h"
#include "bvh/bvh.h"
#include "util/render_types.h"
#include "light/lights.h"

/* A probe of the rules in kernels/util/portable.h (mixed 32-bit scalars, a fixed
 * array, hand padding), so the check has something to compare even before any
 * other shared struct exists. */
typedef struct LayoutProbe {
    spt_u32 id;
    float v[3];
    spt_i32 count;
    float w;
    spt_u32 pad[2];
} LayoutProbe; /* 32 bytes */

/* X(Type) for each shared struct. */
#define SPT_LAYOUT_STRUCTS(X)     \
    X(LayoutProbe)                \
    X(SpecRef)                    \
    X(GpuMaterial)                \
    X(GpuTexSlot)                 \
    X(GpuTexture)                 \
    X(TriShade)                   \
    X(RenderParams)               \
    X(BvhNode)                    \
    X(BvhHit)                     \
    X(GpuLight)                   \
    X(GpuEnvMap)                  \
    X(LightTreeNode)

/* X(Type, field) for each field whose offset is checked. */
#define SPT_LAYOUT_FIELDS(X)      \
    X(LayoutProbe, v)             \
    X(LayoutProbe, count)         \
    X(LayoutProbe, pad)           \
    X(SpecRef, kind)              \
    X(GpuMaterial, emission)      \
    X(GpuMaterial, sheen)         \
    X(GpuMaterial, attenuation)   \
    X(GpuMaterial, conductor)     \
    X(GpuMaterial, sheen_roughness) \
    X(GpuMaterial, dt_color)      \
    X(GpuMaterial, diffuse_transmission) \
    X(GpuMaterial, slot)          \
    X(GpuTexSlot, m)              \
    X(GpuTexture, flags)          \
    X(RenderParams, width)        \
    X(RenderParams, sample_begin) \
    X(RenderParams, rr_depth)     \
    X(RenderParams, env_prob)     \
    X(RenderParams, env)          \
    X(RenderParams, tree_nodes)   \
    X(LightTreeNode, child)       \
    X(BvhNode, child)             \
    X(BvhNode, count)             \
    X(BvhHit, prim)               \
    X(GpuLight, cos_outer)        \
    X(GpuLight, spectrum)         \
    X(GpuEnvMap, rot_cos)         \
    X(GpuEnvMap, uniform)

#endif
