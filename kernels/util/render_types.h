/* Structs the host uploads for the wavefront kernels, and the buffer lists that
 * both sides expand (so a kernel argument is named once, here). Valid C99 and
 * OpenCL C: 32-bit scalars and fixed arrays only, padded by hand. */
#ifndef SPT_RENDER_TYPES_H
#define SPT_RENDER_TYPES_H

#include "util/portable.h"

/* A spectrum as a material or light stores it:
 *   kind SPT_SPEC_SIGMOID: scale * sigmoid(c0 l^2 + c1 l + c2) (Jakob-Hanika),
 *        times the normalised D65 table when flags has SPT_SPEC_ILLUMINANT;
 *   kind SPT_SPEC_TABLE: scale * table[offset + (l - 360)] on the 1 nm grid
 *        (linear interpolation), from the spectra buffer. */
/* The largest work-group the kernels run with: their local arrays' size
 * (src/render/wavefront.c picks each kernel's group size within it). */
#define SPT_GROUP_MAX 256

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
#define SPT_MAT_UNLIT 16u        /* KHR_materials_unlit: emits, reflects nothing */
#define SPT_MAT_VERTEX_COLOR 32u /* some of its triangles have COLOR_0 (vtx_color) */
#define SPT_MAT_TEXTURED 64u     /* some slot has a texture */
#define SPT_MAT_UV1 128u         /* some slot reads TEXCOORD_1 (vtx_uv1) */
#define SPT_MAT_VOLUME 256u      /* KHR_materials_volume thicknessFactor > 0: not thin-walled */
#define SPT_MAT_TANGENTS 512u    /* some of its triangles have TANGENT (vtx_tangent) */

/* The texture slots of a material (the same numbers as scene.h's SPT_SLOT_*):
 * which channels each reads is in kernels/integrator/wavefront.cl (material_bsdf). */
#define SPT_TS_BASE 0
#define SPT_TS_METALLIC_ROUGHNESS 1
#define SPT_TS_NORMAL 2
#define SPT_TS_EMISSIVE 3
#define SPT_TS_TRANSMISSION 4
#define SPT_TS_SPECULAR 5
#define SPT_TS_SPECULAR_COLOR 6
#define SPT_TS_CLEARCOAT 7
#define SPT_TS_CLEARCOAT_ROUGHNESS 8
#define SPT_TS_CLEARCOAT_NORMAL 9
#define SPT_TS_SHEEN_COLOR 10
#define SPT_TS_SHEEN_ROUGHNESS 11
#define SPT_TS_IRIDESCENCE 12
#define SPT_TS_IRIDESCENCE_THICKNESS 13
#define SPT_TS_ANISOTROPY 14
#define SPT_TS_DIFFUSE_TRANSMISSION 15
#define SPT_TS_DIFFUSE_TRANSMISSION_COLOR 16
#define SPT_TS_COUNT 17

/* A material's use of a texture: which one (-1: none), read at which texture
 * coordinates (0: TEXCOORD_0, 1: TEXCOORD_1), through which KHR_texture_transform
 * (uv' = M (u, v, 1), M 2x3 row-major; the identity when absent). */
typedef struct GpuTexSlot {
    spt_i32 tex;
    spt_u32 uv_set;
    float m[6];
} GpuTexSlot; /* 32 bytes */

/* A material: glTF metallic-roughness with its extensions (kernels/closure/bsdf.h). Each
 * factor is multiplied by its slot's texture where it has one. */
typedef struct GpuMaterial {
    SpecRef reflectance;   /* base colour: diffuse albedo, metal F0, transmission tint */
    SpecRef emission;      /* emitted radiance, one-sided (front face) */
    SpecRef spec_tint;     /* KHR_materials_specular colour (SIGMOID, scale = its max) */
    SpecRef attenuation;   /* KHR_materials_volume attenuationColor; NONE = clear */
    SpecRef sheen;         /* KHR_materials_sheen colour (SIGMOID, scale = its max3); NONE = no sheen */
    SpecRef dt_color;      /* KHR_materials_diffuse_transmission colour; with diffuse_transmission */
    spt_u32 flags;
    float alpha_cutoff;    /* SPT_MAT_ALPHA_MASK: opaque where alpha >= cutoff */
    float alpha;           /* base colour alpha factor */
    float metallic;
    float roughness;       /* perceptual; alpha = roughness^2 */
    float transmission;    /* KHR_materials_transmission */
    float ior;             /* KHR_materials_ior (at the d line with dispersion) */
    float dispersion;      /* KHR_materials_dispersion: 20 / Abbe number */
    float specular;        /* KHR_materials_specular factor */
    float normal_scale;
    float attenuation_distance; /* metres; with attenuation */
    spt_i32 conductor;     /* 0 none, else SPT_CONDUCTOR_* + 1 (measured eta, k) */
    float clearcoat;       /* KHR_materials_clearcoat factor; 0 = no coat */
    float cc_roughness;    /* clearcoatRoughnessFactor */
    float cc_normal_scale; /* clearcoatNormalTexture.scale */
    float sheen_roughness; /* sheenRoughnessFactor */
    float iridescence;     /* KHR_materials_iridescence factor; 0 = no film */
    float irid_ior;        /* iridescenceIor */
    float irid_min_nm;     /* iridescenceThicknessMinimum (nm) */
    float irid_max_nm;     /* iridescenceThicknessMaximum (nm): the thickness without a texture */
    float aniso;           /* KHR_materials_anisotropy anisotropyStrength; 0 = isotropic */
    float aniso_cos, aniso_sin; /* anisotropyRotation's cosine and sine */
    float diffuse_transmission; /* diffuseTransmissionFactor; 0 = none */
    GpuTexSlot slot[SPT_TS_COUNT];
} GpuMaterial; /* 832 bytes */

/* Texture kinds: how a texel's four floats read. COLOR: sigmoid coefficients
 * (c0, c1, c2) of the texel's linear RGB, alpha in w (base colour, emissive,
 * specular colour). SCALED: the coefficients of RGB / max(RGB) and that maximum
 * in w (a colour whose largest component a material needs: sheen). DATA: the
 * linear RGBA values as stored (metallic-roughness, normals, factors' channels). */
#define SPT_TEXKIND_COLOR 0u
#define SPT_TEXKIND_SCALED 1u
#define SPT_TEXKIND_DATA 2u

/* Texture flags. */
#define SPT_TEX_NEAREST 1u     /* sampler magFilter NEAREST: magnified texels stay square */

/* A texture in the texels buffer: a mip pyramid of float4 texels from offset,
 * level 0 width x height, level k max(1, width >> k) x max(1, height >> k),
 * levels one after another, rows from the image's top (v = 0). */
typedef struct GpuTexture {
    spt_u32 offset;
    spt_i32 width, height;
    spt_i32 wrap_s, wrap_t;
    spt_u32 levels;
    spt_u32 kind;          /* SPT_TEXKIND_* */
    spt_u32 flags;         /* SPT_TEX_* */
} GpuTexture; /* 32 bytes */

/* Per packed triangle: vertex indices into the vertex arrays and the material. */
typedef struct TriShade {
    spt_u32 v[3];
    spt_u32 material;
} TriShade; /* 16 bytes */

#define SPT_PUNCTUAL_POINT 0u
#define SPT_PUNCTUAL_SPOT 1u
#define SPT_PUNCTUAL_DIRECTIONAL 2u

/* A punctual light. spectrum: I(l) W/(sr nm) for point/spot, E(l) W/(m^2 nm) for
 * directional (usually SPT_SPEC_TABLE into the spectra buffer). Spot falloff per
 * the KHR_lights_punctual specification's smooth falloff, t^2 with t =
 * (cos(angle) - cos(outer)) / (cos(inner) - cos(outer)) clamped to [0, 1],
 * written in x = 1 - cos, which float carries for narrow cones where cos
 * rounds to 1 (kernels/light/lights.h, light_spot_falloff):
 * t = clamp((spot_span - x) * spot_scale, 0, 1), with spot_span = 1 - cos(outer)
 * and spot_scale = 1 / (cos(inner) - cos(outer)), both computed in double;
 * a hard edge (inner = outer) has spot_scale 1e30. The specification's sample
 * code bounds cos(inner) - cos(outer) below by 0.001, which dims every cone
 * narrower than about 2.6 degrees (to 0.17 of its flux at 1.5/2 degrees): the
 * falloff here has no such bound. Point lights: spot_span 2 (the whole
 * sphere), spot_scale 0. */
typedef struct GpuLight {
    float pos[3];      /* world position (point, spot) */
    spt_u32 type;      /* SPT_PUNCTUAL_* (same values as scene.h SPT_LIGHT_*) */
    float dir[3];      /* unit direction the light shines toward (spot, directional) */
    float cos_outer;   /* spot: cos(outerConeAngle), 0 outside the cone */
    float cos_inner;   /* spot: cos(innerConeAngle), full intensity inside */
    float spot_scale;
    float spot_span;
    float pad;
    SpecRef spectrum;
} GpuLight; /* 80 bytes */

/* A node of the light tree (kernels/light/light_tree.h). Children are adjacent: an interior node's
 * are `child` and `child + 1`; a leaf holds one light, `child` its index in
 * the light selection ([emitters | punctual lights], kernels/light/lights.h).
 * The root is node 0; `parent` of the root is SPT_TREE_NONE. power is
 * relative (the root's is 1). */
typedef struct LightTreeNode {
    float lo[3];
    float power;
    float hi[3];
    float cos_o;       /* cos theta_o: the spread of the normals about axis */
    float axis[3];
    float cos_e;       /* cos theta_e: emission beyond a normal */
    spt_u32 child;
    spt_u32 parent;
    spt_u32 leaf;      /* 1: a leaf */
    spt_u32 two_sided; /* emits on both sides of its normals */
} LightTreeNode; /* 64 bytes */

#define SPT_TREE_NONE 0xffffffffu

/* Environment kinds. */
#define SPT_ENV_NONE 0u
#define SPT_ENV_UNIFORM 1u
#define SPT_ENV_MAP 2u

/* The environment. Map: width x height texels, rows top (+Y) to bottom, in the
 * env data float buffer from texel_offset, 4 floats each: sigmoid coefficients
 * c0, c1, c2 and a scale, radiance = scale * sigmoid(c)(l) * D65norm(l) (the
 * map's intensity already folded in). marginal_offset: height + 1 floats, the CDF
 * over rows; conditional_offset: height CDFs of width + 1 floats each (row y at
 * conditional_offset + y (width + 1)). Direction of map coordinates (u, v) in
 * [0,1]^2, before rotation: theta = pi v from +Y, phi = 2 pi u,
 * d = (-sin(phi) sin(theta), cos(theta), cos(phi) sin(theta)): the image centre
 * (u = 1/2) faces -Z (where a default glTF camera looks), u = 3/4 faces +X,
 * u = 0 faces +Z. World direction = R_y(rotation) d (right-handed about +Y).
 * Uniform: radiance = uniform (any SpecRef; a table lives in the env data buffer
 * at uniform.offset), sampled uniformly over the sphere. */
typedef struct GpuEnvMap {
    spt_u32 kind;          /* SPT_ENV_* */
    spt_i32 width, height;
    spt_u32 texel_offset;
    spt_u32 marginal_offset;
    spt_u32 conditional_offset;
    float rot_cos, rot_sin; /* cos and sin of the rotation about +Y */
    SpecRef uniform;
} GpuEnvMap; /* 64 bytes */

/* The samplers of RenderParams.sampler (kernels/sample/rng.h). */
#define SPT_SAMPLER_SOBOL 0u       /* padded Owen-scrambled Sobol in every dim */
#define SPT_SAMPLER_INDEPENDENT 1u /* a hash of (seed, pixel, sample, dim) */
#define SPT_SAMPLER_ZSOBOL 2u      /* Sobol over the pixels in Morton order (blue-noise error) */

/* Most caustic spheres (RenderParams.caustic). */
#define SPT_CAUSTIC_MAX 4

/* Everything a pass needs besides buffers; passed by value. */
typedef struct RenderParams {
    /* camera: position, right/up scaled by tan(fov/2) (and aspect), forward; the
     * ray cone that texture filtering follows (kernels/integrator/path.h): its width at the
     * camera in cam_pos[3] (orthographic: a pixel's size; else 0) and its spread
     * in cam_fwd[3] (a pixel's angle; 0 orthographic) */
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
    spt_u32 emitter_count;  /* emitters (triangles, then instances): the first entries of light_cdf */
    float emitter_total;    /* sum of the selection weights, for pdfs */
    spt_u32 node_count;
    spt_u32 inst_count;     /* instances (docs/architecture.md, "Instances (two levels)"):
                               0 traces nodes alone, else tlas_top over tlas_inst */
    spt_u32 rr_depth;       /* Russian roulette from this many segments on */
    spt_u32 has_alpha;      /* some material is MASK or BLEND: shadow rays test alpha */
    spt_u32 orthographic;   /* 1: parallel rays along cam_fwd from the image plane */
    spt_u32 light_count;    /* punctual lights: light_cdf entries after the emitters */
    spt_u32 select_count;   /* entries of light_cdf: emitters, punctual, environment */
    /* Thin lens: radius (0 = pinhole) and focus distance along the view axis. */
    float lens_radius;
    float focus_distance;
    float env_prob;         /* probability that light selection picks the environment */
    /* The light-tracing pass (kernels/integrator/light_trace.h): light paths per
     * sample index (0: no pass), and the chunk's work index of its first light
     * path (the camera paths come first: work_begin .. light_begin). */
    spt_u32 light_paths;
    spt_u32 light_begin;
    /* The scene's bounding sphere (a directional light's paths start on a disc
     * that covers it). */
    float scene_center[3];
    float scene_radius;
    /* The caustic spheres (kernels/light/lights.h, lt_aim_cones): per
     * material that may take a delta lobe (all such materials in one when
     * there are more than SPT_CAUSTIC_MAX), the bounding sphere of its
     * triangles, centre and radius; caustic_count 0: none. Only a light path
     * that meets one of them first goes on. */
    float caustic[4 * SPT_CAUSTIC_MAX]; /* sphere k: 4 k .. 4 k + 3 (Mesa 22.3's
                                           rusticl misjudges the size of a kernel
                                           argument with a 2D array member) */
    spt_u32 caustic_count;
    spt_u32 sampler;        /* SPT_SAMPLER_* (kernels/sample/rng.h) */
    /* SPT_SAMPLER_ZSOBOL: log2 of the samples per pixel rounded up to a power
     * of two, and the base-4 digits of a Morton index (spt_zsobol_digits). */
    spt_u32 zsobol_log2spp;
    spt_u32 zsobol_digits;
    /* What rays that leave the scene see (kernels/light/lights.h): a map, a uniform sky
     * or nothing; its data (texels, CDFs or a table) in the env_data buffer. */
    GpuEnvMap env;
    /* The light tree (kernels/light/light_tree.h): its nodes (0: next-event
     * estimation picks by power from the light_cdf's first select_count
     * entries), and the aside distribution's entries in light_cdf from
     * aside_offset. */
    spt_u32 tree_nodes;
    spt_u32 aside_offset;
    spt_u32 aside_count;
    /* The light selection's first tri_emitters entries are triangles, the
     * rest of its emitter_count emitters instances (kernels/light/inst_lights.h). */
    spt_u32 tri_emitters;
    /* Photon merging (kernels/integrator/photon_merge.h): on (1) or off; the
     * photon grid's bucket mask (buckets - 1) and photons; the initial
     * radius (kernels/integrator/photon_grid.h). */
    spt_u32 merge;
    spt_u32 pm_mask;
    spt_u32 pm_count;
    float pm_r0;
} RenderParams;

/* Counters, one uint each in the counters buffer; the host reads them back. */
#define SPT_CNT_EXTEND 0   /* paths queued for extend this iteration */
#define SPT_CNT_SHADOW 1   /* shadow rays queued */
#define SPT_CNT_WORK 2     /* next work index handed out (relative to work_begin) */
#define SPT_CNT_DONE 3     /* paths finished in this chunk */
#define SPT_CNT_NAN 4      /* paths whose radiance was NaN/Inf and was dropped */
#define SPT_CNT_COUNT 8

/* Light-tracing state of a path (ps_lt), kernels/integrator/light_trace.h. A camera
 * path: SPT_LT_CHAIN once its first vertex sampled a non-delta lobe,
 * SPT_LT_SPEC while its last vertex sampled a delta one. A light path:
 * SPT_LT_LIGHT, and SPT_LT_SPEC once its first vertex sampled a delta lobe. */
#define SPT_LT_CHAIN 1u
#define SPT_LT_SPEC 2u
#define SPT_LT_LIGHT 4u
/* A camera sample of a pixel that adaptive sampling leaves out of this chunk
 * (pixel_lag SPT_PIXEL_SKIP): it ends at once and path_finish writes it as
 * dropped. */
#define SPT_LT_SKIP 8u
#define SPT_PIXEL_SKIP 0xffffffffu
/* Photon merging's state (kernels/integrator/photon_merge.h). A camera path:
 * SPT_PM_SEEN_D once a vertex sampled a non-delta lobe (the first: the
 * merge's vertex); after it, SPT_PM_LAST_D while the last vertex's BSDF has a
 * non-delta lobe, and the vertices with one before that (up to 7) in the three
 * bits from SPT_PM_COUNT_SHIFT (pm_camera_next). A light path: its photons
 * so far in those three bits. A camera path with merging: SPT_PM_HERO once a
 * dispersive refraction left it its hero wavelength alone (pm_camera_hero). */
#define SPT_PM_SEEN_D 16u
#define SPT_PM_LAST_D 32u
#define SPT_PM_COUNT_SHIFT 6
#define SPT_PM_COUNT_MAX 7u
#define SPT_PM_HERO 512u
#define SPT_PM_BITS 0x3f0u

/* The light film (light_film): per pixel, X, Y and Z of the light paths'
 * splats as 64-bit fixed-point sums (two words each, low first) in units of
 * 2^-SPT_SPLAT_BITS, so the sum does not depend on the order of the atomics. */
#define SPT_SPLAT_BITS 20
#define SPT_SPLAT_WORDS 6u

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
    X(uint, medium)         \
    X(float, bsdf_pdf)      \
    X(float, env_pdf)       \
    X(uint, lt)             \
    X(float4, light_ctx)    \
    X(uint, inst)

/* Shadow-ray queue entries, one buffer per field. */
#define SPT_SHADOW_STATE(X) \
    X(float4, ray_o)        \
    X(float4, ray_d)        \
    X(float4, contrib)      \
    X(uint, path)

/* Scene buffers (read only) and film/queue buffers. */
#define SPT_SCENE_BUFFERS(X)          \
    X(const BvhNode, nodes)           \
    X(const float, tris)              \
    X(const BvhNode, tlas_top)        \
    X(const BvhInstance, tlas_inst)   \
    X(const TriShade, tri_shade)      \
    X(const float, vtx_pos)           \
    X(const float, vtx_normal)        \
    X(const float, vtx_uv)            \
    X(const float, vtx_uv1)           \
    X(const float4, vtx_color)        \
    X(const float4, vtx_tangent)      \
    X(const GpuMaterial, materials)   \
    X(const float, spectra)           \
    X(const GpuTexture, textures)     \
    X(const float4, texels)           \
    X(const uint, emitters)           \
    X(const float, light_cdf)         \
    X(const float, tri_light_pdf)     \
    X(const GpuLight, lights)         \
    X(const float, env_data)          \
    X(const LightTreeNode, light_tree) \
    X(const uint, tri_light_leaf)     \
    X(const uint, inst_light)

/* With AOVs (kernels built with SPT_AOV): aov_sample holds 3 float4 per
 * sample of the chunk, (albedo RGB, recorded flag), (N, Z), (P, 0), and
 * aov_sum SPT_AOV_CHUNK_FLOATS / 4 float4 per pixel (src/render/film.h);
 * without, one unused float4 each. With spectral bands (kernels built with
 * SPT_BANDS = their number): spec_sample holds 2 float4 per sample, the weights
 * of its four wavelengths and their bands (as floats), and spec_sum SPT_BANDS
 * floats per pixel (src/render/film.h); without, one unused element each.
 * pixel_lag: per pixel, how many sample indices its own samples lag behind
 * the chunk's (adaptive sampling, src/render/adaptive.h: sample index s of the
 * chunk is the pixel's sample s - lag, so a pixel's samples are always the
 * first of its sequence), or SPT_PIXEL_SKIP: the pixel takes none of the
 * chunk's samples; 0 without adaptive sampling. chunk_sq: per pixel,
 * the sums of the squares of its kept samples' linear sRGB over 2^(2 w) in
 * xyz, and w (the variance that adaptive sampling weighs). With photon
 * merging (RenderParams.merge; kernels/integrator/photon_grid.h): pm_photon
 * holds the chunk's photons (SPT_PM_PER_PATH slots of SPT_PM_PHOTON_FLOAT4
 * per light path while they are left, then sorted by bucket), pm_cell the
 * first photon of each bucket (pm_mask + 2 words), pm_radius per sample slot
 * of the chunk its radius and its cells' inverse edge; without, one unused
 * element each. */
#define SPT_WORK_BUFFERS(X)           \
    X(uint, counters)                 \
    X(uint, queue_extend)             \
    X(float4, contrib)                \
    X(float4, chunk_sum)              \
    X(const uint, pixel_lag)          \
    X(float4, chunk_sq)               \
    X(uint, light_film)               \
    X(float4, aov_sample)             \
    X(float4, aov_sum)                \
    X(float4, spec_sample)            \
    X(float, spec_sum)                \
    X(float4, pm_photon)              \
    X(const uint, pm_cell)            \
    X(const float, pm_radius)

#endif
