/* The host scene: flat arrays in world space, filled by the glTF loader
 * (src/scene/gltf_load.cpp) or built in code (tests, tools), consumed by the BVH
 * builder and the renderer's upload step. */
#ifndef SPT_SCENE_H
#define SPT_SCENE_H

#include <stdint.h>

#include "color/spd.h"
#include "core/util.h"

/* glTF sampler wrap codes, kept as the file gives them. */
#define SPT_WRAP_REPEAT 10497
#define SPT_WRAP_CLAMP 33071
#define SPT_WRAP_MIRROR 33648

typedef struct SceneTexture {
    char name[128];      /* image name or uri, for messages and `info` */
    int width, height;
    int channels;        /* 1..4 */
    int srgb_decoded;    /* 1: colour texture, decoded from sRGB to linear on load */
    int wrap_s, wrap_t;  /* SPT_WRAP_* */
    int nearest;         /* 1: sampler magFilter NEAREST (else magnified bilinear) */
    float *texels;       /* width*height*channels linear floats, first row = v 0 */
} SceneTexture;

enum { SPT_ALPHA_OPAQUE = 0, SPT_ALPHA_MASK = 1, SPT_ALPHA_BLEND = 2 };

/* A material's texture slots, in the order of kernels/util/render_types.h's SPT_TS_*
 * (which has no occlusion: a path tracer computes occlusion itself, so the
 * occlusion texture is only reported). */
enum {
    SPT_SLOT_BASE = 0,              /* baseColorTexture: RGB (sRGB) x factor, A x alpha */
    SPT_SLOT_METALLIC_ROUGHNESS,    /* metallicRoughnessTexture: B metallic, G roughness */
    SPT_SLOT_NORMAL,                /* normalTexture (with its scale) */
    SPT_SLOT_EMISSIVE,              /* emissiveTexture: RGB (sRGB) */
    SPT_SLOT_TRANSMISSION,          /* KHR_materials_transmission: R */
    SPT_SLOT_SPECULAR,              /* KHR_materials_specular specularTexture: A */
    SPT_SLOT_SPECULAR_COLOR,        /* ... specularColorTexture: RGB (sRGB) */
    SPT_SLOT_CLEARCOAT,             /* KHR_materials_clearcoat clearcoatTexture: R */
    SPT_SLOT_CLEARCOAT_ROUGHNESS,   /* ... clearcoatRoughnessTexture: G */
    SPT_SLOT_CLEARCOAT_NORMAL,      /* ... clearcoatNormalTexture (with its scale) */
    SPT_SLOT_SHEEN_COLOR,           /* KHR_materials_sheen sheenColorTexture: RGB (sRGB) */
    SPT_SLOT_SHEEN_ROUGHNESS,       /* ... sheenRoughnessTexture: A */
    SPT_SLOT_IRIDESCENCE,           /* KHR_materials_iridescence iridescenceTexture: R */
    SPT_SLOT_IRIDESCENCE_THICKNESS, /* ... iridescenceThicknessTexture: G */
    SPT_SLOT_ANISOTROPY,            /* KHR_materials_anisotropy anisotropyTexture: RG direction, B strength */
    SPT_SLOT_DIFFUSE_TRANSMISSION,  /* KHR_materials_diffuse_transmission diffuseTransmissionTexture: A */
    SPT_SLOT_DIFFUSE_TRANSMISSION_COLOR, /* ... diffuseTransmissionColorTexture: RGB (sRGB) */
    SPT_SLOT_OCCLUSION,             /* occlusionTexture: read, not rendered */
    SPT_SLOT_COUNT
};

/* A texture slot's reference: the scene texture (-1: none or unusable), the file's
 * textures[] index it came from (-1: none; for `info`), the texture coordinate
 * set (texCoord, 0 or 1), and KHR_texture_transform: uv' = M (u, v, 1), M a 2x3
 * row-major affine matrix, the identity when absent. */
typedef struct SceneTexRef {
    int tex;
    int gltf_index;
    int texcoord;
    float transform[6];
} SceneTexRef;

typedef struct SceneMaterial {
    char name[128];
    float base_color[4];        /* linear RGBA factor */
    float metallic, roughness;
    float emissive[3];          /* linear RGB factor */
    float emissive_strength;    /* KHR_materials_emissive_strength, default 1 */
    float normal_scale;
    float ior;                  /* KHR_materials_ior, default 1.5 */
    float transmission;         /* KHR_materials_transmission factor, default 0 */
    float dispersion;           /* KHR_materials_dispersion, 0 = none */
    float attenuation_color[3]; /* KHR_materials_volume, default 1,1,1 */
    float attenuation_distance; /* default +inf (stored as 0 = infinite) */
    float thickness;
    float specular;             /* KHR_materials_specular specularFactor, default 1 */
    float specular_color[3];    /* specularColorFactor, default 1,1,1 */
    float clearcoat;            /* KHR_materials_clearcoat clearcoatFactor, default 0 */
    float clearcoat_roughness;  /* clearcoatRoughnessFactor, default 0 */
    float clearcoat_normal_scale; /* clearcoatNormalTexture.scale, default 1 */
    float sheen_color[3];       /* KHR_materials_sheen sheenColorFactor, default 0,0,0 */
    float sheen_roughness;      /* sheenRoughnessFactor, default 0 */
    float iridescence;          /* KHR_materials_iridescence iridescenceFactor, default 0 */
    float iridescence_ior;      /* iridescenceIor, default 1.3 */
    float iridescence_min_nm;   /* iridescenceThicknessMinimum, default 100 */
    float iridescence_max_nm;   /* iridescenceThicknessMaximum, default 400 */
    float anisotropy;           /* KHR_materials_anisotropy anisotropyStrength, default 0 */
    float anisotropy_rotation;  /* anisotropyRotation (radians), default 0 */
    float diffuse_transmission; /* KHR_materials_diffuse_transmission diffuseTransmissionFactor, default 0 */
    float diffuse_transmission_color[3]; /* diffuseTransmissionColorFactor, default 1,1,1 */
    int double_sided;
    int alpha_mode;             /* SPT_ALPHA_* */
    float alpha_cutoff;         /* default 0.5 */
    int unlit;                  /* KHR_materials_unlit */
    /* Spectral extras ("extras": {"spectrace": {...}}); count 0 = absent. They
     * override the RGB base colour / emission. */
    Spd reflectance_spd;
    Spd emission_spd;
    char conductor[16];         /* "" or a conductor name such as "Au" */
    SceneTexRef tex[SPT_SLOT_COUNT]; /* texture slots (SPT_SLOT_*) */
} SceneMaterial;

enum { SPT_LIGHT_POINT = 0, SPT_LIGHT_SPOT = 1, SPT_LIGHT_DIRECTIONAL = 2 };

typedef struct SceneLight {
    char name[128];
    char object[64];      /* the file's object, "extensions.KHR_lights_punctual.lights[N]";
                             "" for a light made in code */
    int type;
    float position[3];    /* world space */
    float direction[3];   /* world space, unit: where the light points (-Z of its node) */
    float color[3];       /* linear RGB, default 1 */
    float intensity;      /* candela (point, spot) or lux (directional), as in the file */
    /* extras.spectrace.emission: the spectrum's shape (count and line_count 0 =
     * absent: the colour's), replacing the colour; scaled to the intensity when
     * the light is built (render/host_lights.h). */
    Spd spd;
    float range;          /* 0 = infinite */
    float inner_cone, outer_cone; /* radians (spot) */
} SceneLight;

typedef struct SceneCamera {
    float position[3];
    float forward[3], up[3], right[3]; /* world-space unit axes (-Z, +Y, +X of the node) */
    float yfov;           /* radians */
    float aspect;         /* width/height, 0 = not given */
    float znear, zfar;    /* zfar 0 = infinite */
    int orthographic;     /* 1: xmag/ymag used instead of yfov */
    float xmag, ymag;
    int is_default;       /* 1: made up by the loader because the file had none */
} SceneCamera;

/* What the loader counted while flattening, for `info` and warnings. */
typedef struct SceneStats {
    uint32_t meshes, instances, primitives;
    uint32_t dropped_nonfinite;   /* NaN/Inf or |coordinate| >= 1e18 */
    uint32_t dropped_degenerate;  /* zero area or repeated index */
    uint32_t skipped_primitives;  /* points/lines: unsupported modes */
    uint32_t emissive_triangles;
    uint32_t unusable_images;     /* missing, corrupt or outside the scene folder:
                                     the material factors are used instead */
    /* Meshes placed more than once and flattened (--instancing off, or a mesh
     * that must be: docs/gltf.md, "Instancing"), and the triangles and
     * vertices their second and later placements added. */
    uint32_t instanced_meshes;
    uint32_t flattened_triangles, flattened_vertices;
} SceneStats;

/* The file's cameras and animations as `spectrace info` lists them
 * (docs/gltf.md, "Animation, skins and morph targets"). */
typedef struct SceneCameraInfo {
    char name[128];       /* "" when the file gives none */
    int orthographic;
    int node;             /* the first node in scene order that places it; -1: none */
} SceneCameraInfo;

typedef struct SceneAnimationInfo {
    char name[128];       /* "" when the file gives none */
    double start, end;    /* seconds: the first and last key time of its channels */
    uint32_t channels;
} SceneAnimationInfo;

/* What pose the loader puts the scene in (docs/gltf.md, "Animation, skins and
 * morph targets"). A pose of zeros with at = NAN, or a NULL pose, is the file's
 * rest state. */
typedef struct ScenePose {
    double at;             /* seconds; NAN: no animation sampled (the rest state) */
    const char *animation; /* index or name of the one animation played; NULL: all */
    const char *camera;    /* index or name into the file's cameras; NULL: the first
                              camera in scene order */
    int instancing;        /* SCENE_INSTANCING_*: which meshes are placed by reference
                              (docs/gltf.md, "Instancing") */
} ScenePose;

/* ScenePose.instancing (--instancing; the values of SPT_SWITCH_* in
 * src/render/render_options.h): AUTO places a mesh by reference when two or
 * more nodes or EXT_mesh_gpu_instancing instances place it, OFF flattens every
 * placement into world-space triangles, ON places by reference also the
 * meshes used once. Skinned, morphed, emitting and TANGENT meshes are always
 * flattened (docs/gltf.md, "Instancing"). */
enum { SCENE_INSTANCING_AUTO = 0, SCENE_INSTANCING_OFF = 1, SCENE_INSTANCING_ON = 2 };

typedef struct Scene {
    char *path;
    /* Triangles, world space, counter-clockwise front faces (a mirrored transform
     * has already been compensated). */
    uint32_t tri_count;
    float *tri_pos;       /* 9 floats per triangle: v0, v1, v2 */
    uint32_t *tri_vidx;   /* 3 per triangle: indices into the vertex arrays */
    uint32_t *tri_mat;    /* material index per triangle */
    uint32_t vertex_count;
    float *vtx_normal;    /* 3 per vertex, unit world-space shading normal, or 0,0,0
                             where the file had none (use the geometric normal) */
    float *vtx_uv;        /* 2 per vertex (TEXCOORD_0, 0,0 when absent) */
    float *vtx_uv1;       /* 2 per vertex (TEXCOORD_1; TEXCOORD_0 where a primitive has
                             none), NULL when no primitive has TEXCOORD_1 */
    float *vtx_color;     /* 4 per vertex (COLOR_0 as linear RGBA in [0, 1]; 1,1,1,1
                             where a primitive has none), NULL when none has COLOR_0 */
    float *vtx_tangent;   /* 4 per vertex (TANGENT in world space, a mesh placed by
                             reference's in its own: unit xyz, w +-1 the bitangent's
                             sign; 0,0,0,0 where a primitive has none), NULL when
                             none has TANGENT */
    SceneMaterial *materials;
    uint32_t material_count;
    SceneTexture *textures;
    uint32_t texture_count;
    SceneLight *lights;
    uint32_t light_count;
    SceneCamera camera;
    /* For `info` only (not sent to MPI ranks): the file's cameras and animations. */
    SceneCameraInfo *camera_info;
    uint32_t camera_info_count;
    SceneAnimationInfo *animation_info;
    uint32_t animation_info_count;
    float bounds_min[3], bounds_max[3]; /* of the kept triangles; min > max when empty */
    SceneStats stats;
    /* Meshes placed by reference (docs/architecture.md, "Instances (two
     * levels)"); mesh_count 0: every triangle is in world space. Otherwise the
     * last triangles of the arrays are the meshes' in their own space, mesh m's
     * mesh_tri_count[m] after mesh m - 1's (those before them are in world
     * space), and instance k places mesh inst_mesh[k] by the rows
     * inst_xf[12 k .. 12 k + 12) of a 3x4 matrix (column 3 the translation).
     * The glTF loader fills them for meshes placed several times (docs/gltf.md,
     * "Instancing"). Their meshes must not emit (gpu_scene_build refuses
     * them). */
    uint32_t mesh_count;
    uint32_t *mesh_tri_count;
    uint32_t inst_count;
    uint32_t *inst_mesh;
    float *inst_xf;
} Scene;

/* glTF defaults for a material (the glTF default material when used as is). */
void scene_material_default(SceneMaterial *m);

/* Loads a .gltf or .glb file into s (zeroed first). Returns 0, or an exit code
 * with e naming the file, the object and the reason; s is then empty. */
int scene_load_gltf(Scene *s, const char *path, SptError *e);

/* The same posed: pose (NULL: the rest state) samples the file's animations at a
 * time and picks the camera. An --animation or --camera the file lacks is an
 * error naming the file and it (SPT_EXIT_INPUT). */
int scene_load_gltf_posed(Scene *s, const char *path, const ScenePose *pose, SptError *e);

/* The same from the file's bytes in memory (.gltf or .glb, told apart by the GLB
 * magic); name stands for the file in messages and its folder is where external
 * buffers and images are looked up. For tests, fuzzing and the library
 * (src/api/spectrace.h). */
int scene_load_gltf_memory(Scene *s, const void *data, size_t size, const char *name,
                           SptError *e);
/* The same posed (as scene_load_gltf_posed). */
int scene_load_gltf_memory_posed(Scene *s, const void *data, size_t size, const char *name,
                                 const ScenePose *pose, SptError *e);

/* A default perspective camera that frames the bounds from +Z looking toward -Z,
 * yfov 45 degrees. */
void scene_default_camera(Scene *s);

/* Recomputes bounds_min/max from the triangles: the world-space ones and
 * each instance's mesh through its transform (in double, rounded to float). */
void scene_update_bounds(Scene *s);

void scene_free(Scene *s);

#endif
