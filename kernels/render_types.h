/* Structs the host uploads for the wavefront kernels, and the buffer lists that
 * both sides expand (so a kernel argument is named once, here). Valid C99 and
 * OpenCL C: 32-bit scalars and fixed arrays only, padded by hand. */
#ifndef SPT_RENDER_TYPES_H
#define SPT_RENDER_TYPES_H

#include "shared.h"

/* A spectrum as a material or light stores it:
 *   kind SPT_SPEC_SIGMOID: scale * sigmoid(c0 l^2 + c1 l + c2) (Jakob-Hanika),
 *        times the normalised D65 table when flags has SPT_SPEC_ILLUMINANT;
 *   kind SPT_SPEC_TABLE: scale * table[offset + (l - 360)] on the 1 nm grid
 *        (linear interpolation), from the spectra buffer. */
#define SPT_SPEC_NONE 0
#define SPT_SPEC_SIGMOID 1
#define SPT_SPEC_TABLE 2
#define SPT_SPEC_ILLUMINANT 1u

typedef struct SpecRef {
    float c[3];
    float scale;
    spt_u32 kind;
    spt_u32 flags;
    spt_u32 offset; /* into the spectra buffer, SPT_SPEC_TABLE */
    spt_u32 pad;
} SpecRef; /* 32 bytes */

/* Material flags. */
#define SPT_MAT_EMISSIVE 1u
#define SPT_MAT_DOUBLE_SIDED_EMISSION 2u
#define SPT_MAT_ALPHA_MASK 4u    /* glTF alphaMode MASK: cut out below the cutoff */
#define SPT_MAT_ALPHA_BLEND 8u   /* glTF alphaMode BLEND: stochastic opacity alpha */

typedef struct GpuMaterial {
    SpecRef reflectance;   /* diffuse albedo */
    SpecRef emission;      /* emitted radiance, one-sided (front face) */
    spt_i32 base_tex;      /* texture index or -1: coefficients texture, multiplies reflectance */
    spt_i32 emissive_tex;  /* texture index or -1: coefficients texture, multiplies emission */
    spt_u32 flags;
    float alpha_cutoff;    /* SPT_MAT_ALPHA_MASK: opaque where alpha >= cutoff */
    float alpha;           /* base colour alpha factor */
    float pad[3];
    float base_uv[8];      /* KHR_texture_transform of the base colour texture: 2x3, padded */
    float emissive_uv[8];  /* the same for the emissive texture */
} GpuMaterial; /* 160 bytes */

/* A texture in the texels buffer: width*height float4 texels from offset. Each
 * texel holds sigmoid coefficients (c0, c1, c2) of its RGB and its alpha in w. */
typedef struct GpuTexture {
    spt_u32 offset;
    spt_i32 width, height;
    spt_i32 wrap_s, wrap_t;
    spt_u32 pad[3];
} GpuTexture; /* 32 bytes */

/* Per packed triangle: vertex indices into the vertex arrays and the material. */
typedef struct TriShade {
    spt_u32 v[3];
    spt_u32 material;
} TriShade; /* 16 bytes */

/* Everything a pass needs besides buffers; passed by value. */
typedef struct RenderParams {
    /* camera: position, right/up scaled by tan(fov/2) (and aspect), forward */
    float cam_pos[4];
    float cam_right[4];
    float cam_up[4];
    float cam_fwd[4];
    spt_i32 width, height;
    spt_u32 seed;
    spt_i32 max_depth;      /* path segments from the camera; <= 0 unlimited */
    spt_u32 pool_size;
    spt_u32 work_begin;     /* first linear work index of this chunk */
    spt_u32 work_end;       /* one past the last */
    spt_u32 sample_begin;   /* sample index of work_begin (work = pixel + W*H*(sample - sample_begin)) */
    spt_u32 emitter_count;
    float emitter_total;    /* sum of emitter weights, for pdfs */
    spt_u32 node_count;
    spt_u32 rr_depth;       /* Russian roulette from this many segments on */
    spt_u32 has_alpha;      /* some material is MASK or BLEND: shadow rays test alpha */
    spt_u32 orthographic;   /* 1: parallel rays along cam_fwd from the image plane */
    spt_u32 pad0_[2];
    /* Thin lens: radius (0 = pinhole) and focus distance along the view axis. */
    float lens_radius;
    float focus_distance;
    float pad_[2];
    /* Radiance of rays that leave the scene (a uniform sky); kind NONE = black.
     * A table lives in the bg_table buffer (offset 0). */
    SpecRef background;
} RenderParams;

/* Counters, one uint each in the counters buffer; the host reads them back. */
#define SPT_CNT_EXTEND 0   /* paths queued for extend this iteration */
#define SPT_CNT_SHADOW 1   /* shadow rays queued */
#define SPT_CNT_WORK 2     /* next work index handed out (relative to work_begin) */
#define SPT_CNT_DONE 3     /* paths finished in this chunk */
#define SPT_CNT_NAN 4      /* paths whose radiance was NaN/Inf and was dropped */
#define SPT_CNT_COUNT 8

/* Path flags. */
#define SPT_PATH_DEAD 0u       /* slot free */
#define SPT_PATH_ALIVE 1u      /* ray to trace */
#define SPT_PATH_FINISHED 2u   /* done: contribution to be written by generate */

/* The path state, one structure-of-arrays buffer per field, declared once:
 * X(type, name) expands into kernel parameters `ps_name`, host cl_mem fields and
 * allocation sizes. lambda/lambda_pdf/throughput/radiance carry the 4 wavelengths. */
#define SPT_PATH_STATE(X)   \
    X(float4, ray_o)        \
    X(float4, ray_d)        \
    X(float4, throughput)   \
    X(float4, radiance)     \
    X(float4, lambda)       \
    X(float4, lambda_pdf)   \
    X(float4, hit)          \
    X(uint, work)           \
    X(uint, depth)          \
    X(uint, flags)          \
    X(uint, passes)         \
    X(float, bsdf_pdf)

/* Shadow-ray queue entries, one buffer per field. */
#define SPT_SHADOW_STATE(X) \
    X(float4, ray_o)        \
    X(float4, ray_d)        \
    X(float4, contrib)      \
    X(uint, path)

/* Scene buffers (read only) and film/queue buffers. */
#define SPT_SCENE_BUFFERS(X)          \
    X(const BvhNode, nodes)           \
    X(const BvhTri, tris)             \
    X(const TriShade, tri_shade)      \
    X(const float, vtx_normal)        \
    X(const float, vtx_uv)            \
    X(const GpuMaterial, materials)   \
    X(const float, spectra)           \
    X(const GpuTexture, textures)     \
    X(const float4, texels)           \
    X(const uint, emitters)           \
    X(const float, emitter_cdf)       \
    X(const float, tri_light_pdf)

#define SPT_WORK_BUFFERS(X)           \
    X(uint, counters)                 \
    X(uint, queue_extend)             \
    X(float4, contrib)                \
    X(float4, chunk_sum)              \
    X(const float, bg_table)

#endif
