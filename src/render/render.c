/* The wavefront loop on one device (DESIGN.md, "Data flow") and the upload of the
 * scene into the arrays the kernels read. */
#include "render/render.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <pthread.h>
#include <unistd.h>
#include <sys/mman.h>

#include "shared/cie_data.h"
#include "shared/spectrum.h"

/* Host spellings of the kernel types named in the buffer lists. */
typedef cl_float4 float4;
typedef cl_uint uint;

/* ---- Scene upload ------------------------------------------------------------ */

/* A spectrum reference from an SPD: its 1 nm grid appended to spectra. */
static SpecRef spec_from_spd(const Spd *spd, float scale, float **spectra, uint32_t *count)
{
    SpecRef r;
    memset(&r, 0, sizeof r);
    r.kind = SPT_SPEC_TABLE;
    r.scale = scale;
    r.offset = *count;
    *spectra = spt_realloc(*spectra, (*count + SPT_CIE_SAMPLES) * sizeof(float));
    spd_to_grid(spd, *spectra + *count);
    *count += SPT_CIE_SAMPLES;
    return r;
}

/* Luminance (Y, with Y = 1 for the normalised D65) of a material's emission. */
static double emission_luminance(const GpuMaterial *m, const float *spectra)
{
    const SpecRef *s = &m->emission;
    double y = 0.0;
    for (int i = 0; i < SPT_CIE_SAMPLES; i++) {
        double l = SPT_CIE_LAMBDA_MIN + i, v;
        if (s->kind == SPT_SPEC_TABLE) {
            v = spectra[s->offset + i];
        } else if (s->kind == SPT_SPEC_SIGMOID) {
            v = spt_sigmoid_poly(s->c[0], s->c[1], s->c[2], (float)l);
            if (s->flags & SPT_SPEC_ILLUMINANT)
                v *= spt_d65_norm((float)l);
        } else {
            v = 0.0;
        }
        y += v * SPT_CIE_Y[i];
    }
    return s->scale * y / SPT_CIE_Y_INTEGRAL;
}

/* Index (0..SPT_CONDUCTOR_COUNT-1) of a conductor name of the spectral extras,
 * -1 when unknown. The loader accepts only the names of kernels/device/conductors.h. */
static int conductor_id(const char *name)
{
    /* The order of SPT_CONDUCTOR_AU, _AG, _CU, _AL in kernels/device/conductors.h. */
    static const char *const names[4] = {"Au", "Ag", "Cu", "Al"};
    for (int i = 0; i < 4; i++)
        if (!strcmp(name, names[i]))
            return i;
    return -1;
}

/* A reflectance-like spectrum of linear RGB rgb (components >= 0, possibly above
 * 1): sigmoid coefficients of rgb / max, scaled by max. */
static SpecRef spec_from_rgb_scaled(const float rgb[3])
{
    SpecRef r;
    memset(&r, 0, sizeof r);
    float mx = fmaxf(rgb[0], fmaxf(rgb[1], rgb[2]));
    r.kind = SPT_SPEC_SIGMOID;
    r.scale = mx > 0.0f ? mx : 0.0f;
    float c[3] = {mx > 0 ? rgb[0] / mx : 0, mx > 0 ? rgb[1] / mx : 0, mx > 0 ? rgb[2] / mx : 0};
    rgb_to_coeffs(c, r.c);
    return r;
}

/* How each texture slot's texels are read (SPT_TEXKIND_*; kernels/device/wavefront.cl,
 * material_bsdf, says which channels). */
static const uint32_t k_slot_kind[SPT_TS_COUNT] = {
    [SPT_TS_BASE] = SPT_TEXKIND_COLOR,
    [SPT_TS_METALLIC_ROUGHNESS] = SPT_TEXKIND_DATA,
    [SPT_TS_NORMAL] = SPT_TEXKIND_DATA,
    [SPT_TS_EMISSIVE] = SPT_TEXKIND_COLOR,
    [SPT_TS_TRANSMISSION] = SPT_TEXKIND_DATA,
    [SPT_TS_SPECULAR] = SPT_TEXKIND_DATA,
    [SPT_TS_SPECULAR_COLOR] = SPT_TEXKIND_SCALED,
    [SPT_TS_CLEARCOAT] = SPT_TEXKIND_DATA,
    [SPT_TS_CLEARCOAT_ROUGHNESS] = SPT_TEXKIND_DATA,
    [SPT_TS_CLEARCOAT_NORMAL] = SPT_TEXKIND_DATA,
    [SPT_TS_SHEEN_COLOR] = SPT_TEXKIND_SCALED,
    [SPT_TS_SHEEN_ROUGHNESS] = SPT_TEXKIND_DATA,
};

/* The scene's slots are the device's, with occlusion last and not uploaded. */
SPT_STATIC_ASSERT(SPT_SLOT_BASE == SPT_TS_BASE && SPT_SLOT_EMISSIVE == SPT_TS_EMISSIVE &&
                      SPT_SLOT_SHEEN_ROUGHNESS == SPT_TS_SHEEN_ROUGHNESS && SPT_SLOT_OCCLUSION == SPT_TS_COUNT,
                  "scene.h SPT_SLOT_* and render_types.h SPT_TS_* differ");

/* The device textures made so far: scene texture, kind and the linear RGB factor
 * its colours were multiplied by. */
typedef struct TexUploads {
    int n;
    struct {
        int tex;
        uint32_t kind;
        float factor[3];
    } *key;
} TexUploads;

static void texture_upload(GpuTexture *gt, const SceneTexture *t, uint32_t kind, const float *factor,
                           float **texels, size_t *count);

/* The device texture of scene texture t read as kind, its colours multiplied by
 * factor (NULL: 1), uploaded on first use. */
static int device_texture(GpuScene *g, const Scene *s, TexUploads *u, int t, uint32_t kind, const float *factor)
{
    static const float one[3] = {1.0f, 1.0f, 1.0f};
    if (t < 0 || (uint32_t)t >= s->texture_count)
        return -1;
    if (!factor || kind == SPT_TEXKIND_DATA)
        factor = one;
    for (int i = 0; i < u->n; i++)
        if (u->key[i].tex == t && u->key[i].kind == kind && !memcmp(u->key[i].factor, factor, sizeof one))
            return i;
    u->key = spt_realloc(u->key, (size_t)(u->n + 1) * sizeof *u->key);
    u->key[u->n].tex = t;
    u->key[u->n].kind = kind;
    memcpy(u->key[u->n].factor, factor, sizeof one);
    g->textures = spt_realloc(g->textures, (size_t)(u->n + 1) * sizeof(GpuTexture));
    texture_upload(&g->textures[u->n], &s->textures[t], kind, factor, &g->texels, &g->texel_count);
    g->texture_count = (uint32_t)++u->n;
    return u->n - 1;
}

/* A slot's device form: its texture read as the slot's kind, the colours
 * multiplied by factor (the slot's RGB factor, folded into the texels so that the
 * product is the RGB product glTF defines; NULL: none), the uv set (TEXCOORD_1
 * only when the scene has it) and the transform. */
static void set_slot(GpuTexSlot *gs, int k, const SceneTexRef *r, const float *factor, GpuScene *g,
                     const Scene *s, TexUploads *u)
{
    gs->tex = r->tex >= 0 ? device_texture(g, s, u, r->tex, k_slot_kind[k], factor) : -1;
    gs->uv_set = r->texcoord == 1 && s->vtx_uv1 ? 1u : 0u;
    memcpy(gs->m, r->transform, sizeof gs->m);
}

/* A white reflectance-like spectrum (what a factor becomes once folded into its
 * texture). */
static SpecRef spec_white(void)
{
    SpecRef r;
    memset(&r, 0, sizeof r);
    const float one[3] = {1.0f, 1.0f, 1.0f};
    r.kind = SPT_SPEC_SIGMOID;
    r.scale = 1.0f;
    rgb_to_coeffs(one, r.c);
    return r;
}

/* A material's device form, its textures uploaded through u. Colour factors
 * with a texture are folded into the texture (the factor's spectrum becomes
 * white), so that factor x texture is their RGB product, as glTF defines it,
 * rather than the product of two upsampled spectra. */
static void material_upload(GpuMaterial *gm, const SceneMaterial *m, GpuScene *g, const Scene *s, TexUploads *u)
{
    float **spectra = &g->spectra;
    uint32_t *count = &g->spectra_count;
    int spectral_base = m->reflectance_spd.count > 0 || m->reflectance_spd.line_count > 0;
    int spectral_emission = m->emission_spd.count > 0 || m->emission_spd.line_count > 0;
    memset(gm, 0, sizeof *gm);
    for (int k = 0; k < SPT_TS_COUNT; k++) {
        const float *factor = NULL;
        if (k == SPT_TS_BASE && !spectral_base)
            factor = m->base_color;
        else if (k == SPT_TS_EMISSIVE && !spectral_emission && !m->unlit)
            factor = m->emissive;
        else if (k == SPT_TS_SPECULAR_COLOR)
            factor = m->specular_color;
        else if (k == SPT_TS_SHEEN_COLOR)
            factor = m->sheen_color;
        set_slot(&gm->slot[k], k, &m->tex[k], factor, g, s, u);
    }
    if (m->reflectance_spd.count > 0 || m->reflectance_spd.line_count > 0) {
        gm->reflectance = spec_from_spd(&m->reflectance_spd, 1.0f, spectra, count);
    } else if (gm->slot[SPT_TS_BASE].tex >= 0) {
        gm->reflectance = spec_white();
    } else {
        gm->reflectance.kind = SPT_SPEC_SIGMOID;
        gm->reflectance.scale = 1.0f;
        rgb_to_coeffs(m->base_color, gm->reflectance.c);
    }
    gm->alpha_cutoff = m->alpha_cutoff;
    gm->alpha = m->base_color[3];
    if (m->alpha_mode == SPT_ALPHA_MASK)
        gm->flags |= SPT_MAT_ALPHA_MASK;
    else if (m->alpha_mode == SPT_ALPHA_BLEND && !(m->base_color[3] >= 1.0f && m->tex[SPT_SLOT_BASE].tex < 0))
        gm->flags |= SPT_MAT_ALPHA_BLEND;
    float strength = m->emissive_strength;
    if (m->unlit) {
        /* KHR_materials_unlit: the surface shows its base colour whatever the
         * lighting: an emitter of that colour (times its texture and COLOR_0)
         * that reflects nothing; the base colour slot still gives the alpha. */
        gm->reflectance.scale = 0.0f;
        gm->flags |= SPT_MAT_UNLIT;
        float rgb[3] = {m->base_color[0], m->base_color[1], m->base_color[2]};
        if (rgb[0] > 0.0f || rgb[1] > 0.0f || rgb[2] > 0.0f) {
            if (gm->slot[SPT_TS_BASE].tex >= 0) /* the colour is in the texture */
                rgb[0] = rgb[1] = rgb[2] = 1.0f;
            gm->emission.kind = SPT_SPEC_SIGMOID;
            gm->emission.flags = SPT_SPEC_ILLUMINANT;
            rgb_illuminant_coeffs(rgb, gm->emission.c, &gm->emission.scale);
            gm->flags |= SPT_MAT_EMISSIVE | SPT_MAT_DOUBLE_SIDED_EMISSION;
        }
        for (int k = 0; k < SPT_TS_COUNT; k++)
            if (k != SPT_TS_BASE)
                gm->slot[k].tex = -1;
        gm->slot[SPT_TS_EMISSIVE] = gm->slot[SPT_TS_BASE];
        return;
    }
    if (m->emission_spd.count > 0 || m->emission_spd.line_count > 0) {
        /* Spectral extras are absolute radiance and override factor and strength. */
        gm->emission = spec_from_spd(&m->emission_spd, 1.0f, spectra, count);
        gm->flags |= SPT_MAT_EMISSIVE;
    } else {
        float rgb[3] = {m->emissive[0] * strength, m->emissive[1] * strength,
                        m->emissive[2] * strength};
        if ((rgb[0] > 0.0f || rgb[1] > 0.0f || rgb[2] > 0.0f) && gm->slot[SPT_TS_EMISSIVE].tex >= 0)
            rgb[0] = rgb[1] = rgb[2] = strength; /* the colour is in the texture */
        if (rgb[0] > 0.0f || rgb[1] > 0.0f || rgb[2] > 0.0f) {
            gm->emission.kind = SPT_SPEC_SIGMOID;
            gm->emission.flags = SPT_SPEC_ILLUMINANT;
            rgb_illuminant_coeffs(rgb, gm->emission.c, &gm->emission.scale);
            gm->flags |= SPT_MAT_EMISSIVE;
        }
    }
    if (!(gm->flags & SPT_MAT_EMISSIVE))
        gm->slot[SPT_TS_EMISSIVE].tex = -1;

    /* The BSDF (kernels/device/bsdf.h). */
    gm->metallic = m->metallic;
    gm->roughness = m->roughness;
    gm->normal_scale = m->normal_scale;
    gm->transmission = m->transmission;
    gm->ior = m->ior >= 1.0f ? m->ior : 1.5f;
    gm->dispersion = m->dispersion;
    gm->specular = m->specular;
    if ((m->specular_color[0] != 1.0f || m->specular_color[1] != 1.0f || m->specular_color[2] != 1.0f) &&
        gm->slot[SPT_TS_SPECULAR_COLOR].tex < 0)
        gm->spec_tint = spec_from_rgb_scaled(m->specular_color);
    int cid = m->conductor[0] ? conductor_id(m->conductor) : -1;
    gm->conductor = cid >= 0 ? cid + 1 : 0;
    const float *ac = m->attenuation_color;
    if (m->attenuation_distance > 0.0f && (ac[0] < 1.0f || ac[1] < 1.0f || ac[2] < 1.0f)) {
        gm->attenuation.kind = SPT_SPEC_SIGMOID;
        gm->attenuation.scale = 1.0f;
        rgb_to_coeffs(ac, gm->attenuation.c);
        gm->attenuation_distance = m->attenuation_distance;
    }
    /* KHR_materials_clearcoat and KHR_materials_sheen: off with a zero factor,
     * whatever their textures. */
    gm->clearcoat = m->clearcoat;
    gm->cc_roughness = m->clearcoat_roughness;
    gm->cc_normal_scale = m->clearcoat_normal_scale;
    if (!(m->clearcoat > 0.0f))
        for (int k = SPT_TS_CLEARCOAT; k <= SPT_TS_CLEARCOAT_NORMAL; k++)
            gm->slot[k].tex = -1;
    const float *sc = m->sheen_color;
    if (sc[0] > 0.0f || sc[1] > 0.0f || sc[2] > 0.0f) {
        gm->sheen = gm->slot[SPT_TS_SHEEN_COLOR].tex >= 0 ? spec_white() : spec_from_rgb_scaled(sc);
        gm->sheen_roughness = m->sheen_roughness;
    } else {
        gm->slot[SPT_TS_SHEEN_COLOR].tex = gm->slot[SPT_TS_SHEEN_ROUGHNESS].tex = -1;
    }
}

/* The luminance of a colour factor folded into an emissive texture (which the
 * emission spectrum no longer holds), for the emitters' selection weights; 1
 * without such a texture. */
static double textured_emission_y(const SceneMaterial *m)
{
    const float *c = m->unlit ? m->base_color : m->emissive;
    int slot = m->unlit ? SPT_SLOT_BASE : SPT_SLOT_EMISSIVE;
    if (m->tex[slot].tex < 0 || m->emission_spd.count > 0 || m->emission_spd.line_count > 0)
        return 1.0;
    return 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
}

/* Sets the flags that follow from a material's slots. */
static void material_slot_flags(GpuMaterial *gm)
{
    for (int k = 0; k < SPT_TS_COUNT; k++) {
        if (gm->slot[k].tex < 0)
            continue;
        gm->flags |= SPT_MAT_TEXTURED;
        if (gm->slot[k].uv_set == 1u)
            gm->flags |= SPT_MAT_UV1;
    }
}

/* One axis of a box-filtered reduction: dst[i] = the mean of src over
 * [i n / m, (i + 1) n / m) (n source texels, m <= n destination texels), each
 * source texel weighted by its overlap; 4 floats per texel, stride apart. */
static void box_reduce(const float *src, int n, float *dst, int m, size_t stride)
{
    double scale = (double)n / m;
    for (int i = 0; i < m; i++) {
        double lo = i * scale, hi = (i + 1) * scale, acc[4] = {0, 0, 0, 0};
        for (int j = (int)lo; j < n && j < hi; j++) {
            double w = fmin(hi, j + 1.0) - fmax(lo, (double)j);
            for (int c = 0; c < 4; c++)
                acc[c] += w * src[(size_t)j * stride + c];
        }
        for (int c = 0; c < 4; c++)
            dst[(size_t)i * stride + c] = (float)(acc[c] / scale);
    }
}

/* Texels in the mip pyramid of a w x h texture (levels down to 1 x 1). */
static size_t mip_texels(int w, int h, uint32_t *levels)
{
    size_t n = 0;
    uint32_t l = 0;
    for (;; l++) {
        int lw = w >> l > 1 ? w >> l : 1, lh = h >> l > 1 ? h >> l : 1;
        n += (size_t)lw * lh;
        if (lw == 1 && lh == 1)
            break;
    }
    *levels = l + 1;
    return n;
}

/* A device texture from a scene texture, read as kind: its linear RGBA (a grey
 * image's grey in R, G and B, RGB times factor; alpha 1 without an alpha channel),
 * the mip pyramid
 * of box-filtered levels in linear values, then each texel in the kind's form:
 * COLOR the sigmoid coefficients of RGB (clamped to [0, 1]) and alpha; SCALED
 * the coefficients of RGB / max and max; DATA the values. */
static void texture_upload(GpuTexture *gt, const SceneTexture *t, uint32_t kind, const float *factor,
                           float **texels, size_t *count)
{
    memset(gt, 0, sizeof *gt);
    size_t n0 = (size_t)t->width * (size_t)t->height;
    size_t total = mip_texels(t->width, t->height, &gt->levels);
    gt->offset = (uint32_t)*count;
    gt->width = t->width;
    gt->height = t->height;
    gt->wrap_s = t->wrap_s;
    gt->wrap_t = t->wrap_t;
    gt->kind = kind;
    gt->flags = t->nearest ? SPT_TEX_NEAREST : 0u;
    *texels = spt_realloc(*texels, (*count + total) * 4 * sizeof(float));
    float *out = *texels + 4 * *count;
    int ch = t->channels;
    for (size_t i = 0; i < n0; i++) {
        const float *px = t->texels + i * (size_t)ch;
        for (int c = 0; c < 3; c++)
            out[4 * i + c] = px[ch >= 3 ? c : 0] * factor[c];
        out[4 * i + 3] = ch == 4 ? px[3] : ch == 2 ? px[1] : 1.0f;
    }
    /* Each further level from the one before: rows, then columns. */
    float *lvl = out;
    int w = t->width, h = t->height;
    float *tmp = spt_malloc((size_t)(w > 1 ? w / 2 : 1) * h * 4 * sizeof(float));
    for (uint32_t l = 1; l < gt->levels; l++) {
        int nw = w > 1 ? w / 2 : 1, nh = h > 1 ? h / 2 : 1;
        float *next = lvl + (size_t)w * h * 4;
        for (int y = 0; y < h; y++)
            box_reduce(lvl + (size_t)y * w * 4, w, tmp + (size_t)y * nw * 4, nw, 4);
        for (int x = 0; x < nw; x++)
            box_reduce(tmp + (size_t)x * 4, h, next + (size_t)x * 4, nh, (size_t)nw * 4);
        lvl = next;
        w = nw;
        h = nh;
    }
    free(tmp);
    for (size_t i = 0; i < total && kind != SPT_TEXKIND_DATA; i++) {
        float *v = out + 4 * i, rgb[3] = {v[0], v[1], v[2]};
        if (kind == SPT_TEXKIND_SCALED) {
            float mx = fmaxf(rgb[0], fmaxf(rgb[1], rgb[2]));
            for (int c = 0; c < 3; c++)
                rgb[c] = mx > 0.0f ? rgb[c] / mx : 0.0f;
            v[3] = mx > 0.0f ? mx : 0.0f;
        }
        rgb_to_coeffs_fast(rgb, v);
    }
    *count += total;
}

int gpu_scene_build(GpuScene *g, const Scene *s, SptError *e)
{
    memset(g, 0, sizeof *g);
    int rc = bvh_build(&g->bvh, s->tri_pos, s->tri_count, e);
    if (rc)
        return rc;
    uint32_t n = g->bvh.prim_count;
    g->tri_shade = spt_calloc(n ? n : 1, sizeof(TriShade));
    for (uint32_t i = 0; i < n; i++) {
        uint32_t t = g->bvh.prim_index[i];
        for (int k = 0; k < 3; k++)
            g->tri_shade[i].v[k] = s->tri_vidx[3 * (size_t)t + k];
        g->tri_shade[i].material = s->tri_mat[t];
    }
    g->vtx_normal = s->vtx_normal;
    g->vtx_uv = s->vtx_uv;
    g->vtx_uv1 = s->vtx_uv1;
    g->vertex_count = s->vertex_count;
    /* Vertex positions for shading: a vertex shared by triangles has one
     * position, the one every kept triangle using it carries. */
    g->vtx_pos = spt_calloc(s->vertex_count ? (size_t)s->vertex_count * 3 : 1, sizeof(float));
    for (uint32_t i = 0; i < n; i++) {
        uint32_t t = g->bvh.prim_index[i];
        for (int k = 0; k < 3; k++)
            memcpy(g->vtx_pos + 3 * (size_t)s->tri_vidx[3 * (size_t)t + k],
                   s->tri_pos + 9 * (size_t)t + 3 * k, 3 * sizeof(float));
    }
    /* COLOR_0 as each vertex's sigmoid coefficients and alpha (the kernels blend
     * the vertices' spectra, which blends their RGB). */
    if (s->vtx_color) {
        g->vtx_color = spt_malloc((size_t)s->vertex_count * 4 * sizeof(float));
        for (uint32_t v = 0; v < s->vertex_count; v++) {
            const float *c = s->vtx_color + 4 * (size_t)v;
            rgb_to_coeffs_fast(c, g->vtx_color + 4 * (size_t)v);
            g->vtx_color[4 * (size_t)v + 3] = c[3];
        }
    }

    /* Materials, their textures uploaded on first use (once per kind and factor). */
    TexUploads uploads = {0, NULL};
    g->material_count = s->material_count;
    g->materials = spt_calloc(s->material_count ? s->material_count : 1, sizeof(GpuMaterial));
    for (uint32_t i = 0; i < s->material_count; i++) {
        material_upload(&g->materials[i], &s->materials[i], g, s, &uploads);
        material_slot_flags(&g->materials[i]);
    }
    free(uploads.key);
    if (!g->textures)
        g->textures = spt_calloc(1, sizeof(GpuTexture));
    /* Materials some of whose triangles have a colour other than white. */
    for (uint32_t i = 0; i < n && s->vtx_color; i++) {
        const TriShade *ts = &g->tri_shade[i];
        for (int k = 0; k < 3; k++) {
            const float *c = s->vtx_color + 4 * (size_t)ts->v[k];
            if (ts->material < g->material_count && (c[0] != 1.0f || c[1] != 1.0f || c[2] != 1.0f || c[3] != 1.0f)) {
                g->materials[ts->material].flags |= SPT_MAT_VERTEX_COLOR;
                /* COLOR_0's alpha blends too. */
                if (s->materials[ts->material].alpha_mode == SPT_ALPHA_BLEND && c[3] < 1.0f)
                    g->materials[ts->material].flags |= SPT_MAT_ALPHA_BLEND;
            }
        }
    }

    /* Emitters: every packed triangle whose material emits, weighted by its
     * Y-weighted power pi * area * Y(Le) (kernels/shared/lights.h's selection units). */
    double *mat_y = spt_calloc(g->material_count ? g->material_count : 1, sizeof(double));
    for (uint32_t i = 0; i < g->material_count; i++)
        if (g->materials[i].flags & SPT_MAT_EMISSIVE)
            mat_y[i] = emission_luminance(&g->materials[i], g->spectra) * textured_emission_y(&s->materials[i]);
    for (uint32_t i = 0; i < n; i++) {
        uint32_t m = g->tri_shade[i].material;
        if (!(m < g->material_count && (g->materials[m].flags & SPT_MAT_EMISSIVE)))
            continue;
        vec3 a, b, c;
        bvh_vertices(&g->bvh, i, &a, &b, &c);
        float area = 0.5f * v3_length(v3_cross(v3_sub(b, a), v3_sub(c, a)));
        float w = (float)(M_PI * area * mat_y[m]);
        if (!(w > 0.0f))
            continue;
        g->emitters = spt_realloc(g->emitters, (g->emitter_count + 1) * sizeof(uint32_t));
        g->emitter_power = spt_realloc(g->emitter_power, (g->emitter_count + 1) * sizeof(float));
        g->emitter_area = spt_realloc(g->emitter_area, (g->emitter_count + 1) * sizeof(float));
        g->emitters[g->emitter_count] = i;
        g->emitter_power[g->emitter_count] = w;
        g->emitter_area[g->emitter_count] = area;
        g->emitter_count++;
    }
    free(mat_y);

    /* Punctual lights, their spectra appended to the spectra table. */
    float r2 = 0.0f;
    for (int k = 0; k < 3; k++) {
        float d = s->bounds_max[k] - s->bounds_min[k];
        r2 += d > 0.0f ? d * d : 0.0f;
    }
    g->scene_radius = r2 > 0.0f ? 0.5f * sqrtf(r2) : 1.0f;
    g->lights = spt_calloc(s->light_count ? s->light_count : 1, sizeof(GpuLight));
    for (uint32_t i = 0; i < s->light_count; i++) {
        g->spectra = spt_realloc(g->spectra, (g->spectra_count + SPT_CIE_SAMPLES) * sizeof(float));
        rc = light_from_scene(&s->lights[i], g->spectra + g->spectra_count, g->spectra_count,
                              &g->lights[g->light_count], e);
        if (rc) {
            gpu_scene_free(g);
            return rc;
        }
        g->spectra_count += SPT_CIE_SAMPLES;
        g->light_count++;
    }
    return 0;
}

void gpu_scene_free(GpuScene *g)
{
    bvh_free(&g->bvh);
    free(g->tri_shade);
    free(g->vtx_pos);
    free(g->vtx_color);
    free(g->materials);
    free(g->spectra);
    free(g->textures);
    free(g->texels);
    free(g->emitters);
    free(g->emitter_power);
    free(g->emitter_area);
    free(g->lights);
    memset(g, 0, sizeof *g);
}

/* The lights of one render: the scene's emitters and punctual lights plus the
 * environment of the render settings, and the one distribution that picks among
 * them in proportion to power. */
typedef struct RenderLights {
    EnvLight env;
    Distrib select;          /* [emitters | punctual lights | environment] */
    float *tri_light_pdf;    /* per packed triangle: P(select) / area, 0 if not emitting */
    float env_prob;
} RenderLights;

static void render_lights_free(RenderLights *L)
{
    env_free(&L->env);
    distrib_free(&L->select);
    free(L->tri_light_pdf);
    memset(L, 0, sizeof *L);
}

/* Byte sizes of the scene buffers, never 0 (OpenCL refuses empty buffers). L may
 * be NULL (an estimate for `info`: no environment). */
static size_t NZ(size_t x) { return x ? x : 16; }
static size_t scene_buffer_bytes(const GpuScene *g, const RenderLights *L, const char *name)
{
    uint32_t n = g->bvh.prim_count;
    if (!strcmp(name, "nodes")) return NZ((size_t)g->bvh.node_count * sizeof(BvhNode));
    if (!strcmp(name, "tris")) return NZ(g->bvh.tri_data_bytes);
    if (!strcmp(name, "tri_shade")) return NZ((size_t)n * sizeof(TriShade));
    if (!strcmp(name, "vtx_pos")) return NZ((size_t)g->vertex_count * 3 * sizeof(float));
    if (!strcmp(name, "vtx_normal")) return NZ((size_t)g->vertex_count * 3 * sizeof(float));
    if (!strcmp(name, "vtx_uv")) return NZ((size_t)g->vertex_count * 2 * sizeof(float));
    if (!strcmp(name, "vtx_uv1")) return NZ(g->vtx_uv1 ? (size_t)g->vertex_count * 2 * sizeof(float) : 0);
    if (!strcmp(name, "vtx_color")) return NZ(g->vtx_color ? (size_t)g->vertex_count * 4 * sizeof(float) : 0);
    if (!strcmp(name, "materials")) return NZ((size_t)g->material_count * sizeof(GpuMaterial));
    if (!strcmp(name, "spectra")) return NZ((size_t)g->spectra_count * sizeof(float));
    if (!strcmp(name, "textures")) return NZ((size_t)g->texture_count * sizeof(GpuTexture));
    if (!strcmp(name, "texels")) return NZ(g->texel_count * 4 * sizeof(float));
    if (!strcmp(name, "emitters")) return NZ((size_t)g->emitter_count * sizeof(uint32_t));
    if (!strcmp(name, "light_cdf"))
        return L ? (L->select.n ? ((size_t)L->select.n + 1) * sizeof(float) : 16)
                 : ((size_t)g->emitter_count + g->light_count + 2) * sizeof(float);
    if (!strcmp(name, "tri_light_pdf")) return NZ((size_t)n * sizeof(float));
    if (!strcmp(name, "lights")) return NZ((size_t)g->light_count * sizeof(GpuLight));
    if (!strcmp(name, "env_data")) return NZ(L ? (size_t)L->env.data_count * sizeof(float) : 0);
    return 16;
}

static const void *scene_buffer_data(const GpuScene *g, const RenderLights *L, const char *name)
{
    if (!strcmp(name, "nodes")) return g->bvh.nodes;
    if (!strcmp(name, "tris")) return g->bvh.tri_data;
    if (!strcmp(name, "tri_shade")) return g->tri_shade;
    if (!strcmp(name, "vtx_pos")) return g->vtx_pos;
    if (!strcmp(name, "vtx_normal")) return g->vtx_normal;
    if (!strcmp(name, "vtx_uv")) return g->vtx_uv;
    if (!strcmp(name, "vtx_uv1")) return g->vtx_uv1;
    if (!strcmp(name, "vtx_color")) return g->vtx_color;
    if (!strcmp(name, "materials")) return g->materials;
    if (!strcmp(name, "spectra")) return g->spectra;
    if (!strcmp(name, "textures")) return g->textures;
    if (!strcmp(name, "texels")) return g->texels;
    if (!strcmp(name, "emitters")) return g->emitters;
    if (!strcmp(name, "light_cdf")) return L && L->select.n ? L->select.cdf : NULL;
    if (!strcmp(name, "tri_light_pdf")) return L ? L->tri_light_pdf : NULL;
    if (!strcmp(name, "lights")) return g->lights;
    if (!strcmp(name, "env_data")) return L ? L->env.data : NULL;
    return NULL;
}

size_t gpu_scene_bytes(const GpuScene *g)
{
    size_t total = 0;
#define ADD(type, name) total += scene_buffer_bytes(g, NULL, #name);
    SPT_SCENE_BUFFERS(ADD)
#undef ADD
    return total;
}

/* ---- The wavefront loop ------------------------------------------------------ */

enum { K_GENERATE, K_EXTEND, K_SHADE, K_CONNECT, K_ACCUMULATE, K_COUNT };
static const char *const kernel_names[K_COUNT] = {"k_generate", "k_extend", "k_shade",
                                                  "k_connect", "k_accumulate"};

/* Every device buffer, named once through the lists of kernels/shared/render_types.h. */
typedef struct Buffers {
#define MEMBER(type, name) cl_mem name;
#define PS_MEMBER(type, name) cl_mem ps_##name;
#define SH_MEMBER(type, name) cl_mem sh_##name;
    SPT_SCENE_BUFFERS(MEMBER)
    SPT_WORK_BUFFERS(MEMBER)
    SPT_PATH_STATE(PS_MEMBER)
    SPT_SHADOW_STATE(SH_MEMBER)
#undef MEMBER
#undef PS_MEMBER
#undef SH_MEMBER
} Buffers;

typedef struct Wavefront {
    ClDevice dev;
    cl_program program;
    cl_kernel k[K_COUNT];
    Buffers b;
    size_t local[K_COUNT]; /* work-group size of each kernel */
    uint32_t pool;
    uint32_t chunk_spp;
    int ray_pairs;         /* 1: k_extend traces two rays per work-item (CPU devices) */
    void *host_mem[16];    /* memory of the scene buffers used in place (CPU devices) */
    int host_mem_count;
} Wavefront;

static void wavefront_free(Wavefront *w)
{
#define REL(type, name) if (w->b.name) clReleaseMemObject(w->b.name);
#define PS_REL(type, name) if (w->b.ps_##name) clReleaseMemObject(w->b.ps_##name);
#define SH_REL(type, name) if (w->b.sh_##name) clReleaseMemObject(w->b.sh_##name);
    SPT_SCENE_BUFFERS(REL)
    SPT_WORK_BUFFERS(REL)
    SPT_PATH_STATE(PS_REL)
    SPT_SHADOW_STATE(SH_REL)
#undef REL
#undef PS_REL
#undef SH_REL
    for (int i = 0; i < K_COUNT; i++)
        if (w->k[i])
            clReleaseKernel(w->k[i]);
    if (w->program)
        clReleaseProgram(w->program);
    cl_device_close(&w->dev);
    for (int i = 0; i < w->host_mem_count; i++)
        free(w->host_mem[i]);
    memset(w, 0, sizeof *w);
}

/* Read-only scene buffer name of bytes bytes from data. On a CPU device the
 * large ones (over 4 MiB: BVH nodes and triangles, vertex arrays, which the
 * kernels read at random) live in memory of our own that the device uses in
 * place (CL_MEM_USE_HOST_PTR; PoCL does not copy it), aligned to 2 MiB and
 * marked for transparent huge pages before it is first written, so a random
 * read of a 44 MB BVH misses the TLB far less often: the displaced sphere's
 * bounce rays ran 7% faster (median of 8 alternated pairs, all faster), host
 * traversal 8-13%. Linux only gives huge pages to memory so marked when
 * transparent_hugepage is "madvise" (Debian's default) or "always"; elsewhere
 * this is plain memory. */
static int scene_buffer_create(Wavefront *w, const char *name, size_t bytes, const void *data,
                               cl_mem *out, SptError *e)
{
    static const char zeros[16];
    const size_t huge = (size_t)2 << 20;
    if ((w->dev.info.type & CL_DEVICE_TYPE_CPU) && data && bytes > 2 * huge &&
        w->host_mem_count < (int)(sizeof w->host_mem / sizeof w->host_mem[0])) {
        size_t size = (bytes + huge - 1) & ~(huge - 1);
        void *mem = aligned_alloc(huge, size);
        if (mem) {
#ifdef MADV_HUGEPAGE
            madvise(mem, size, MADV_HUGEPAGE); /* advice: failure only loses speed */
#endif
            memcpy(mem, data, bytes);
            w->host_mem[w->host_mem_count++] = mem;
            return cl_buffer_create(&w->dev, name, CL_MEM_READ_ONLY | CL_MEM_USE_HOST_PTR, bytes,
                                    mem, out, e);
        }
    }
    return cl_buffer_create(&w->dev, name, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, bytes,
                            (void *)(data ? data : zeros), out, e);
}

/* Sets every buffer argument of kernel k, in list order, then the params. */
static int set_args(cl_kernel k, const Buffers *b, const RenderParams *p, SptError *e)
{
    cl_uint i = 0;
#define SET(type, name) SPT_CL_CHECK(e, clSetKernelArg(k, i++, sizeof(cl_mem), &b->name));
#define PS_SET(type, name) SPT_CL_CHECK(e, clSetKernelArg(k, i++, sizeof(cl_mem), &b->ps_##name));
#define SH_SET(type, name) SPT_CL_CHECK(e, clSetKernelArg(k, i++, sizeof(cl_mem), &b->sh_##name));
    SPT_SCENE_BUFFERS(SET)
    SPT_WORK_BUFFERS(SET)
    SPT_PATH_STATE(PS_SET)
    SPT_SHADOW_STATE(SH_SET)
#undef SET
#undef PS_SET
#undef SH_SET
    SPT_CL_CHECK(e, clSetKernelArg(k, i++, sizeof(RenderParams), p));
    return 0;
}

/* Fills buffer m with the 32-bit word pat (every buffer here is a whole number
 * of words). */
static int fill_words(ClDevice *dev, cl_mem m, cl_uint pat, SptError *e)
{
    size_t bytes = 0;
    SPT_CL_CHECK(e, clGetMemObjectInfo(m, CL_MEM_SIZE, sizeof bytes, &bytes, NULL));
    SPT_CL_CHECK(e, clEnqueueFillBuffer(dev->queue, m, &pat, sizeof pat, 0, bytes, 0, NULL, NULL));
    return 0;
}

/* Path pool size for a device: enough paths to fill it, bounded by memory. */
static uint32_t pool_size_for(const ClDeviceInfo *info, uint64_t work)
{
    uint64_t pool = (info->type & CL_DEVICE_TYPE_GPU) ? (1u << 20) : (1u << 16);
    const char *env = getenv("SPECTRACE_POOL");
    if (env && atoi(env) > 0)
        pool = (uint64_t)atoi(env);
    if (pool > work)
        pool = work;
    return (uint32_t)(pool ? pool : 1);
}

static int wavefront_create(Wavefront *w, const ClDeviceInfo *info, const GpuScene *g,
                            const RenderSettings *rs, const RenderLights *L, SptError *e)
{
    int rc;
    memset(w, 0, sizeof *w);
    uint64_t npix = (uint64_t)rs->width * (uint64_t)rs->height;
    /* Samples per chunk: the pool 16 times over, with the per-sample
     * contribution buffer under 64 MiB. A chunk ends with its last paths
     * running in a near-empty pool and a wait for the host, so fewer, larger
     * chunks keep the device busier: 16 pools instead of 4 rendered the Cornell
     * box 6.5% faster (PoCL, 2 cores, median of 16 alternated 512x512 renders),
     * and a chunk still takes well under a second there. But a render keeps at
     * least 16 chunks (when it has the samples), so that several devices or MPI
     * processes sharing it end close together: with 4 chunks, two processes
     * reached 1.79x one instead of 1.95x. */
    w->pool = pool_size_for(info, npix * (uint64_t)(rs->spp > 0 ? rs->spp : 1));
    uint64_t spp = (16ull * w->pool + npix - 1) / npix;
    if (rs->spp > 0 && spp > ((uint64_t)rs->spp + 15) / 16)
        spp = ((uint64_t)rs->spp + 15) / 16;
    uint64_t cap = (64ull << 20) / (npix * 16ull);
    if (spp > cap)
        spp = cap;
    if (spp < 1)
        spp = 1;
    if (rs->spp > 0 && spp > (uint64_t)rs->spp)
        spp = (uint64_t)rs->spp;
    w->chunk_spp = (uint32_t)spp;

    /* Check everything against the device before allocating. */
    ClAlloc allocs[64];
    int na = 0;
#define PLAN(type, nm) allocs[na].name = #nm; allocs[na++].bytes = scene_buffer_bytes(g, L, #nm);
    SPT_SCENE_BUFFERS(PLAN)
#undef PLAN
    allocs[na].name = "film contributions";
    allocs[na++].bytes = (size_t)(npix * w->chunk_spp * 16ull);
    allocs[na].name = "path state";
    allocs[na++].bytes = (size_t)w->pool * 160;
    if ((rc = cl_device_check_memory(info, allocs, na, e)))
        return rc;

    if ((rc = cl_device_open(&w->dev, info, rs->profile, e)))
        return rc;
    /* Test hook: SPECTRACE_TEST_INJECT_NAN=1 makes pixel 0's radiance NaN, to show
     * that the NaN guard keeps it off the film. */
    const char *nan_hook = getenv("SPECTRACE_TEST_INJECT_NAN");
    /* CPUs test a BVH leaf's triangles with one 16-lane test (x86 with AVX-512
     * or AVX2) and trace two rays per extend work-item, interleaved
     * (kernels/shared/bvh.h); GPUs, whose work-items are the SIMD lanes and which hide
     * memory latency with other work-items, loop over a leaf's triangles and
     * trace one ray each. */
    w->ray_pairs = (info->type & CL_DEVICE_TYPE_CPU) != 0;
    /* SPECTRACE_KERNEL_PATH=cpu or gpu overrides that choice, so both paths run
     * on any device: tools/check_kernels.sh runs the CPU path under Oclgrind
     * (a GPU to us) and tests/test_render.c the GPU path on PoCL. */
    const char *path_env = getenv("SPECTRACE_KERNEL_PATH");
    if (path_env && !strcmp(path_env, "cpu"))
        w->ray_pairs = 1;
    else if (path_env && !strcmp(path_env, "gpu"))
        w->ray_pairs = 0;
    cl_ulong cache = 0;
    if (w->ray_pairs)
        SPT_CL_CHECK(e, clGetDeviceInfo(info->id, CL_DEVICE_GLOBAL_MEM_CACHE_SIZE, sizeof cache,
                                        &cache, NULL));
    /* A BVH larger than a quarter of the device's cache (shared by its cores
     * and other programs) is read mostly from memory: each traversal step then
     * asks early for the next one's data (SPT_BVH_STEP_PREFETCH); in a small
     * scene those requests only cost time. */
    double bvh_bytes = (double)g->bvh.node_count * sizeof(BvhNode) + (double)g->bvh.tri_data_bytes;
    int step_prefetch = w->ray_pairs && bvh_bytes > 0.25 * (double)cache;
    char options[160];
    snprintf(options, sizeof options, "%s%s%s",
             w->ray_pairs ? "-DSPT_BVH_SIMD=1 -DSPT_BVH_PAIRS=1 " : "",
             step_prefetch ? "-DSPT_BVH_STEP_PREFETCH=1 " : "",
             nan_hook && *nan_hook && strcmp(nan_hook, "0") ? "-DSPT_TEST_INJECT_NAN=1" : "");
    if ((rc = cl_program_build(&w->dev, "kernels/device/wavefront.cl", options, &w->program, e)))
        return rc;
    for (int i = 0; i < K_COUNT; i++) {
        cl_int err;
        SPT_CL_CHECK(e, (w->k[i] = clCreateKernel(w->program, kernel_names[i], &err), err));
        /* 64 work-items per group where the kernel allows it: the queues take
         * one global atomic per group. */
        size_t max_wg = 1;
        SPT_CL_CHECK(e, clGetKernelWorkGroupInfo(w->k[i], w->dev.info.id, CL_KERNEL_WORK_GROUP_SIZE,
                                                 sizeof max_wg, &max_wg, NULL));
        w->local[i] = max_wg < 64 ? max_wg : 64;
    }
#define MAKE_RO(type, name)                                                             \
    if ((rc = scene_buffer_create(w, #name, scene_buffer_bytes(g, L, #name),              \
                                  scene_buffer_data(g, L, #name), &w->b.name, e)))        \
        return rc;
    SPT_SCENE_BUFFERS(MAKE_RO)
#undef MAKE_RO
    size_t pool = w->pool;
#define MAKE_PS(type, name)                                                              \
    if ((rc = cl_buffer_create(&w->dev, "path " #name, CL_MEM_READ_WRITE, pool * sizeof(type), \
                               NULL, &w->b.ps_##name, e)))                                 \
        return rc;
#define MAKE_SH(type, name)                                                              \
    if ((rc = cl_buffer_create(&w->dev, "shadow " #name, CL_MEM_READ_WRITE, pool * sizeof(type), \
                               NULL, &w->b.sh_##name, e)))                                 \
        return rc;
    SPT_PATH_STATE(MAKE_PS)
    SPT_SHADOW_STATE(MAKE_SH)
#undef MAKE_PS
#undef MAKE_SH
    if ((rc = cl_buffer_create(&w->dev, "counters", CL_MEM_READ_WRITE,
                               SPT_CNT_COUNT * sizeof(cl_uint), NULL, &w->b.counters, e)) ||
        (rc = cl_buffer_create(&w->dev, "queue_extend", CL_MEM_READ_WRITE,
                               pool * sizeof(cl_uint), NULL, &w->b.queue_extend, e)) ||
        (rc = cl_buffer_create(&w->dev, "film contributions", CL_MEM_READ_WRITE,
                               (size_t)(npix * w->chunk_spp * 16ull), NULL, &w->b.contrib, e)) ||
        (rc = cl_buffer_create(&w->dev, "chunk sums", CL_MEM_READ_WRITE, (size_t)npix * 16,
                               NULL, &w->b.chunk_sum, e)))
        return rc;
    /* Test hook (README, "Rendering"): SPECTRACE_TEST_POISON=PATTERN fills every
     * path, shadow, queue, counter and film buffer with that 32-bit word first, so
     * that a value read before anything wrote it shows (NaN, all ones) rather than
     * whatever the fresh allocation held. */
    const char *poison = getenv("SPECTRACE_TEST_POISON");
    if (poison && *poison) {
        cl_uint pat = (cl_uint)strtoul(poison, NULL, 0);
#define POISON(type, name) if (!rc) rc = fill_words(&w->dev, w->b.name, pat, e);
#define PS_POISON(type, name) POISON(type, ps_##name)
#define SH_POISON(type, name) POISON(type, sh_##name)
        SPT_WORK_BUFFERS(POISON)
        SPT_PATH_STATE(PS_POISON)
        SPT_SHADOW_STATE(SH_POISON)
#undef POISON
#undef PS_POISON
#undef SH_POISON
        if (rc)
            return rc;
    }
    /* Every slot starts free (SPT_PATH_DEAD = 0). */
    cl_uint zero = 0;
    SPT_CL_CHECK(e, clEnqueueFillBuffer(w->dev.queue, w->b.ps_flags, &zero, sizeof zero, 0,
                                        pool * sizeof(cl_uint), 0, NULL, NULL));
    return 0;
}

/* The camera of the kernels: right and up scaled so that screen coordinates in
 * [-1, 1] span the field of view at the image's aspect ratio. */
static void camera_params(RenderParams *p, const SceneCamera *c, int width, int height)
{
    float t = tanf(0.5f * c->yfov);
    float aspect = (float)width / (float)height;
    /* Orthographic (glTF xmag/ymag: half the view's width and height): right and up
     * span the image plane itself; the image's aspect follows ymag. */
    float sx = c->orthographic ? c->ymag * aspect : t * aspect;
    float sy = c->orthographic ? c->ymag : t;
    p->orthographic = c->orthographic ? 1u : 0u;
    for (int i = 0; i < 3; i++) {
        p->cam_pos[i] = c->position[i];
        p->cam_fwd[i] = c->forward[i];
        p->cam_right[i] = c->right[i] * sx;
        p->cam_up[i] = c->up[i] * sy;
    }
    p->cam_right[3] = p->cam_up[3] = 0.0f;
    /* The ray cone that texture filtering follows (kernels/device/path.h): a pixel's
     * size at the camera (orthographic), or a pixel's angle (perspective, at the
     * image's centre). */
    p->cam_pos[3] = c->orthographic ? 2.0f * sy / (float)height : 0.0f;
    p->cam_fwd[3] = c->orthographic ? 0.0f : 2.0f * t / (float)height;
}

/* The progress display: one line rewritten in place on a terminal, else a plain
 * line at every tenth of the work. */
static void progress_print(const RenderSettings *rs, uint32_t done, uint32_t total,
                           double elapsed, uint64_t paths, int *last_decile)
{
    if (!rs->progress)
        return;
    double frac = total ? (double)done / total : 1.0;
    int tty = isatty(2);
    int decile = (int)(frac * 10.0);
    if (!tty && decile == *last_decile)
        return;
    *last_decile = decile;
    double rate = elapsed > 0 ? paths / elapsed : 0.0;
    double remain = frac > 0 ? elapsed * (1.0 - frac) / frac : 0.0;
    if (rs->time_limit > 0 && rs->time_limit - elapsed < remain)
        remain = rs->time_limit - elapsed > 0 ? rs->time_limit - elapsed : 0;
    fprintf(stderr, "%srender: %5.1f%%  %u/%u spp  %.2f Mpaths/s  %.1f s elapsed  %.1f s left%s",
            tty ? "\r" : "", 100.0 * frac, done, total, rate * 1e-6, elapsed, remain,
            tty ? "   " : "\n");
    fflush(stderr);
}

static double event_seconds(cl_event ev)
{
    cl_ulong a = 0, b = 0;
    clGetEventProfilingInfo(ev, CL_PROFILING_COMMAND_START, sizeof a, &a, NULL);
    clGetEventProfilingInfo(ev, CL_PROFILING_COMMAND_END, sizeof b, &b, NULL);
    return b > a ? (double)(b - a) * 1e-9 : 0.0;
}

/* Enqueues kernel k over n work-items (rounded up); with profiling, adds its
 * device time to *acc. */
static int run_kernel(Wavefront *w, int k, size_t n, double *acc, SptError *e)
{
    cl_event ev = NULL;
    size_t local = w->local[k];
    size_t global = (n + local - 1) / local * local;
    SPT_CL_CHECK(e, clEnqueueNDRangeKernel(w->dev.queue, w->k[k], 1, NULL, &global, &local, 0,
                                           NULL, acc ? &ev : NULL));
    if (ev) {
        clWaitForEvents(1, &ev);
        *acc += event_seconds(ev);
        clReleaseEvent(ev);
    }
    return 0;
}

/* Renders samples [sample_begin, sample_begin + n) of every pixel on w and adds
 * their per-pixel sums to film. */
static int render_chunk(Wavefront *w, const RenderParams *base, uint32_t sample_begin, uint32_t n,
                        int profile, float *sums, RenderStats *st, SptError *e)
{
    RenderParams p = *base;
    uint32_t npix = (uint32_t)(p.width * p.height);
    p.sample_begin = sample_begin;
    p.work_begin = 0;
    p.work_end = n * npix;
    cl_uint counters[SPT_CNT_COUNT] = {0};
    SPT_CL_CHECK(e, clEnqueueWriteBuffer(w->dev.queue, w->b.counters, CL_TRUE, 0, sizeof counters,
                                         counters, 0, NULL, NULL));
    int rc;
    for (int k = 0; k < K_COUNT; k++)
        if ((rc = set_args(w->k[k], &w->b, &p, e)))
            return rc;
    double *acc = profile ? st->stage_seconds : NULL;
    for (;;) {
        static const cl_uint two_zeros[2] = {0, 0};
        SPT_CL_CHECK(e, clEnqueueWriteBuffer(w->dev.queue, w->b.counters, CL_FALSE, 0,
                                             sizeof two_zeros, two_zeros, 0, NULL, NULL));
        if ((rc = run_kernel(w, K_GENERATE, w->pool, acc ? acc + 0 : NULL, e)) ||
            (rc = run_kernel(w, K_EXTEND, w->ray_pairs ? (w->pool + 1) / 2 : w->pool,
                             acc ? acc + 1 : NULL, e)) ||
            (rc = run_kernel(w, K_SHADE, w->pool, acc ? acc + 2 : NULL, e)) ||
            (rc = run_kernel(w, K_CONNECT, w->pool, acc ? acc + 3 : NULL, e)))
            return rc;
        SPT_CL_CHECK(e, clEnqueueReadBuffer(w->dev.queue, w->b.counters, CL_TRUE, 0,
                                            sizeof counters, counters, 0, NULL, NULL));
        st->rays_extend += counters[SPT_CNT_EXTEND];
        st->rays_shadow += counters[SPT_CNT_SHADOW];
        if (counters[SPT_CNT_DONE] >= p.work_end)
            break;
    }
    if ((rc = run_kernel(w, K_ACCUMULATE, npix, acc ? acc + 4 : NULL, e)))
        return rc;
    SPT_CL_CHECK(e, clEnqueueReadBuffer(w->dev.queue, w->b.chunk_sum, CL_TRUE, 0,
                                        (size_t)npix * 16, sums, 0, NULL, NULL));
    st->nan_dropped += counters[SPT_CNT_NAN];
    st->paths += p.work_end;
    return 0;
}

/* Hands out chunks of sample indices to the devices, in order, and takes back
 * the chunks of devices that failed. Every field is guarded by lock. */
typedef struct Scheduler {
    pthread_mutex_t lock;
    const RenderSettings *rs;
    uint32_t next;            /* next sample index (relative to sample_begin) to hand out */
    uint32_t total;           /* samples per pixel asked for */
    uint32_t *ret_begin, *ret_n; /* chunks given back by failed devices */
    int active;               /* workers rendering a chunk right now */
    int ret_count;
    unsigned char *done;      /* per relative sample index: rendered into a film */
    uint32_t done_count;
    uint64_t paths;
    double t0;
    int decile;
    Film *film;               /* every completed chunk is added here */
} Scheduler;

/* Takes up to want samples into [*begin, *begin + *n); 0 when nothing is left or
 * the render must stop (signal, time limit). */
static int sched_take(Scheduler *s, uint32_t want, uint32_t *begin, uint32_t *n)
{
    int ok = 0;
    const RenderSettings *rs = s->rs;
    pthread_mutex_lock(&s->lock);
    /* Nothing to hand out while another device still renders: wait, since a
     * failure there gives its chunk back. */
    while (s->ret_count == 0 && s->next >= s->total && !rs->take_chunk && s->active > 0 &&
           !(rs->stop && *rs->stop)) {
        pthread_mutex_unlock(&s->lock);
        usleep(2000);
        pthread_mutex_lock(&s->lock);
    }
    int stopping = (rs->stop && *rs->stop) ||
                   (rs->time_limit > 0 && spt_now() - s->t0 >= rs->time_limit);
    if (!stopping) {
        if (s->ret_count > 0) {
            s->ret_count--;
            *begin = s->ret_begin[s->ret_count];
            *n = s->ret_n[s->ret_count];
            ok = 1;
        } else if (rs->take_chunk) {
            ok = rs->take_chunk(rs->chunk_ctx, want, begin, n);
        } else {
            /* The next run of samples not done yet, at most want long. */
            while (s->next < s->total && s->done[s->next])
                s->next++;
            if (s->next < s->total) {
                uint32_t k = 0;
                while (k < want && s->next + k < s->total && !s->done[s->next + k])
                    k++;
                *begin = s->next;
                *n = k;
                s->next += k;
                ok = 1;
            }
        }
    }
    s->active += ok;
    pthread_mutex_unlock(&s->lock);
    return ok;
}

static void sched_give_back(Scheduler *s, uint32_t begin, uint32_t n)
{
    pthread_mutex_lock(&s->lock);
    if (s->rs->give_back) {
        s->rs->give_back(s->rs->chunk_ctx, begin, n);
        s->active--;
        pthread_mutex_unlock(&s->lock);
        return;
    }
    s->ret_begin = spt_realloc(s->ret_begin, (size_t)(s->ret_count + 1) * sizeof(uint32_t));
    s->ret_n = spt_realloc(s->ret_n, (size_t)(s->ret_count + 1) * sizeof(uint32_t));
    s->ret_begin[s->ret_count] = begin;
    s->ret_n[s->ret_count] = n;
    s->ret_count++;
    s->active--;
    pthread_mutex_unlock(&s->lock);
}

static void sched_done(Scheduler *s, uint32_t begin, uint32_t n, uint64_t paths, const float *sums)
{
    pthread_mutex_lock(&s->lock);
    film_add_chunk(s->film, sums);
    for (uint32_t i = 0; i < n; i++)
        s->done[begin + i] = 1;
    s->done_count += n;
    s->active--;
    s->paths += paths;
    progress_print(s->rs, s->done_count, s->total, spt_now() - s->t0, s->paths, &s->decile);
    if (s->rs->on_chunk)
        s->rs->on_chunk(s->rs->on_chunk_ctx, s->film, s->done, s->total);
    pthread_mutex_unlock(&s->lock);
}

/* Test hooks, documented in README.md ("Several devices"): SPECTRACE_TEST_FAIL_DEVICE
 * = "I:N" makes the I-th selected device fail when it starts its (N+1)-th chunk;
 * SPECTRACE_TEST_SLOW_DEVICE = "I:MS" delays each of its chunks by MS ms. */
static int test_hook(const char *name, int device, int *value)
{
    const char *v = getenv(name);
    int d, x;
    if (!v || sscanf(v, "%d:%d", &d, &x) != 2 || d != device)
        return 0;
    *value = x;
    return 1;
}

typedef struct Worker {
    int index;                 /* position in the selection */
    const RenderParams *base;  /* the parameters every chunk shares */
    const RenderLights *lights;
    const ClDeviceInfo *info;
    const GpuScene *g;
    const SceneCamera *cam;
    Scheduler *s;
    RenderStats st;
    double busy_seconds;       /* time spent rendering chunks */
    uint32_t samples;          /* samples per pixel it rendered */
    int rc;
    SptError e;
    char *build_log;
} Worker;

static void *worker_main(void *arg)
{
    Worker *wk = arg;
    const RenderSettings *rs = wk->s->rs;
    Wavefront w;
    wk->rc = wavefront_create(&w, wk->info, wk->g, rs, wk->lights, &wk->e);
    wk->st.build_seconds = w.dev.last_build_seconds;
    if (wk->rc) {
        if (w.dev.build_log)
            wk->build_log = spt_strdup(w.dev.build_log);
        wavefront_free(&w);
        return NULL;
    }
    RenderParams p = *wk->base;
    p.pool_size = w.pool;
    float *sums = spt_malloc((size_t)rs->width * rs->height * 4 * sizeof(float));
    int fail_after = -1, slow_ms = 0, chunks = 0;
    test_hook("SPECTRACE_TEST_FAIL_DEVICE", wk->index, &fail_after);
    test_hook("SPECTRACE_TEST_SLOW_DEVICE", wk->index, &slow_ms);
    uint32_t begin, n;
    while (sched_take(wk->s, w.chunk_spp, &begin, &n)) {
        double t = spt_now();
        if (chunks == fail_after) {
            wk->rc = spt_fail(&wk->e, SPT_EXIT_DEVICE, "injected failure (SPECTRACE_TEST_FAIL_DEVICE)");
        } else {
            if (slow_ms > 0)
                usleep((useconds_t)slow_ms * 1000u);
            uint64_t before = wk->st.paths;
            wk->rc = render_chunk(&w, &p, rs->sample_begin + begin, n, rs->profile, sums,
                                  &wk->st, &wk->e);
            if (!wk->rc) {
                wk->busy_seconds += spt_now() - t;
                wk->samples += n;
                sched_done(wk->s, begin, n, wk->st.paths - before, sums);
            }
        }
        if (wk->rc) {
            sched_give_back(wk->s, begin, n);
            break;
        }
        chunks++;
    }
    free(sums);
    wavefront_free(&w);
    return NULL;
}

/* The environment of a render (RenderSettings env_path, background): a map from
 * --env, a uniform sky from --background (linear sRGB upsampled as an illuminant,
 * or an SPD normalised to luminance Y = 1), nothing for "black", and for a scene
 * with no light at all the default sky, D65 of radiance 1 (linear sRGB 1, 1, 1),
 * with a note. */
static int env_setup(const RenderSettings *rs, const GpuScene *g, EnvLight *env, SptError *e)
{
    memset(env, 0, sizeof *env);
    env->env.rot_cos = 1.0f;
    const char *bg = rs->background;
    float rgb[3];
    char extra;
    if (rs->env_path && bg)
        return spt_fail(e, SPT_EXIT_USAGE, "--env and --background both set the sky; give one of them");
    if (!(rs->env_intensity >= 0.0f) || !isfinite(rs->env_intensity))
        return spt_fail(e, SPT_EXIT_USAGE, "--env-intensity must be finite and >= 0");
    if (rs->env_path)
        return env_load_map(env, rs->env_path, rs->env_rotation_deg * (float)(M_PI / 180.0),
                            rs->env_intensity, e);
    if (!bg) {
        if (g->emitter_count > 0 || g->light_count > 0)
            return 0;
        spt_note("the scene has no lights: it is lit by a uniform white sky (D65, radiance 1); "
                 "use --env FILE or --background R,G,B|SPD|black to change it");
        bg = "1,1,1";
    }
    if (!strcasecmp(bg, "black") || !strcasecmp(bg, "none"))
        return 0;
    if (sscanf(bg, "%f,%f,%f%c", &rgb[0], &rgb[1], &rgb[2], &extra) == 3) {
        if (!(rgb[0] >= 0 && rgb[1] >= 0 && rgb[2] >= 0) || !isfinite(rgb[0] + rgb[1] + rgb[2]))
            return spt_fail(e, SPT_EXIT_USAGE, "--background '%s': colour components must be finite and >= 0", bg);
        if (rgb[0] > 0 || rgb[1] > 0 || rgb[2] > 0)
            env_build_uniform(env, rgb, 1.0f);
        return 0;
    }
    /* An SPD, normalised to luminance Y = 1: a table in the environment's data. */
    Spd spd;
    SptError e2 = {0};
    if (spd_parse(&spd, bg, &e2))
        return spt_fail(e, SPT_EXIT_USAGE, "--background '%s': %s", bg, e2.msg);
    double xyz[3];
    spd_to_xyz(&spd, xyz);
    env->data = spt_calloc(SPT_CIE_SAMPLES, sizeof(float));
    env->data_count = SPT_CIE_SAMPLES;
    spd_to_grid(&spd, env->data);
    spd_free(&spd);
    if (!(xyz[1] > 0)) {
        env_free(env);
        return spt_fail(e, SPT_EXIT_USAGE, "--background '%s': the SPD has no luminance", bg);
    }
    env->env.kind = SPT_ENV_UNIFORM;
    env->env.uniform.kind = SPT_SPEC_TABLE;
    env->env.uniform.scale = (float)(SPT_CIE_Y_INTEGRAL / xyz[1]);
    env->env.uniform.offset = 0;
    env->y_mean = 1.0;
    return 0;
}

/* The lights of a render and the selection among them. */
static int render_lights_setup(RenderLights *L, const GpuScene *g, const RenderSettings *rs,
                               SptError *e)
{
    memset(L, 0, sizeof *L);
    int rc = env_setup(rs, g, &L->env, e);
    if (rc)
        return rc;
    lights_build_selection(&L->select, g->emitter_power, g->emitter_count, g->lights, g->light_count,
                           g->spectra, &L->env, g->scene_radius);
    uint32_t n = g->bvh.prim_count;
    L->tri_light_pdf = spt_calloc(n ? n : 1, sizeof(float));
    for (uint32_t k = 0; k < g->emitter_count; k++)
        L->tri_light_pdf[g->emitters[k]] = distrib_prob(&L->select, k) / g->emitter_area[k];
    if (L->env.env.kind != SPT_ENV_NONE && L->select.n > 0)
        L->env_prob = distrib_prob(&L->select, L->select.n - 1);
    return 0;
}

/* The parameters every chunk of a render shares. */
static void base_params(RenderParams *p, const RenderLights *L, const GpuScene *g,
                        const SceneCamera *cam, const RenderSettings *rs)
{
    memset(p, 0, sizeof *p);
    camera_params(p, cam, rs->width, rs->height);
    p->width = rs->width;
    p->height = rs->height;
    p->seed = rs->seed;
    p->max_depth = rs->max_depth;
    p->emitter_count = g->emitter_count;
    p->light_count = g->light_count;
    p->select_count = L->select.n;
    p->emitter_total = (float)L->select.total;
    p->env = L->env.env;
    p->env_prob = L->env_prob;
    p->node_count = g->bvh.node_count;
    p->rr_depth = 3;
    for (uint32_t i = 0; i < g->material_count; i++)
        if (g->materials[i].flags & (SPT_MAT_ALPHA_MASK | SPT_MAT_ALPHA_BLEND))
            p->has_alpha = 1;
    p->lens_radius = rs->aperture;
    p->focus_distance = rs->focus_distance;
    if (rs->aperture > 0 && !(rs->focus_distance > 0)) {
        /* Focus at the distance seen at the image centre (1 km when nothing is there). */
        BvhHit hit;
        vec3 o = v3(cam->position[0], cam->position[1], cam->position[2]);
        vec3 d = v3(cam->forward[0], cam->forward[1], cam->forward[2]);
        p->focus_distance = g->bvh.prim_count && bvh_intersect(g->bvh.nodes, g->bvh.tri_data, o, d, 1e30f, &hit)
                                ? hit.t : 1000.0f;
    }
}

int render_devices(const ClDeviceInfo *const *infos, int count, const GpuScene *g,
                   const SceneCamera *cam, const RenderSettings *rs, Film *film,
                   RenderStats *stats, RenderDeviceStats *per_device, SptError *e)
{
    memset(stats, 0, sizeof *stats);
    Scheduler s;
    memset(&s, 0, sizeof s);
    pthread_mutex_init(&s.lock, NULL);
    s.rs = rs;
    s.total = rs->spp > 0 ? (uint32_t)rs->spp : 0;
    s.done = spt_calloc(s.total ? s.total : 1, 1);
    s.decile = -1;
    s.t0 = spt_now();
    s.film = film;
    if (rs->done_in)
        for (uint32_t i = 0; i < s.total; i++)
            if (rs->done_in[i]) {
                s.done[i] = 1;
                s.done_count++;
            }
    RenderParams base;
    RenderLights lights;
    int rc0 = render_lights_setup(&lights, g, rs, e);
    if (!rc0)
        base_params(&base, &lights, g, cam, rs);
    if (rc0) {
        render_lights_free(&lights);
        free(s.done);
        pthread_mutex_destroy(&s.lock);
        return rc0;
    }
    Worker *wk = spt_calloc((size_t)count, sizeof(Worker));
    pthread_t *th = spt_calloc((size_t)count, sizeof(pthread_t));
    for (int i = 0; i < count; i++) {
        wk[i].index = i;
        wk[i].info = infos[i];
        wk[i].g = g;
        wk[i].cam = cam;
        wk[i].s = &s;
        wk[i].base = &base;
        wk[i].lights = &lights;
    }
    if (count == 1) {
        worker_main(&wk[0]);
    } else {
        for (int i = 0; i < count; i++)
            pthread_create(&th[i], NULL, worker_main, &wk[i]);
        for (int i = 0; i < count; i++)
            pthread_join(th[i], NULL);
    }
    stats->seconds = spt_now() - s.t0;
    if (rs->progress && isatty(2) && s.done_count > 0)
        fputc('\n', stderr);
    int failed = 0, rc = 0;
    for (int i = 0; i < count; i++) {
        stats->paths += wk[i].st.paths;
        stats->rays_extend += wk[i].st.rays_extend;
        stats->rays_shadow += wk[i].st.rays_shadow;
        stats->nan_dropped += wk[i].st.nan_dropped;
        if (wk[i].st.build_seconds > stats->build_seconds)
            stats->build_seconds = wk[i].st.build_seconds;
        for (int k = 0; k < 5; k++)
            stats->stage_seconds[k] += wk[i].st.stage_seconds[k];
        if (per_device) {
            per_device[i].samples = wk[i].samples;
            per_device[i].paths_per_second =
                wk[i].busy_seconds > 0 ? wk[i].st.paths / wk[i].busy_seconds : 0.0;
            per_device[i].failed = wk[i].rc != 0;
        }
        if (wk[i].rc) {
            failed++;
            if (count > 1)
                spt_warn("device %d (%s) dropped: %s%s", i, infos[i]->name, wk[i].e.msg,
                         wk[i].build_log ? " (build log follows)" : "");
            if (wk[i].build_log)
                fprintf(stderr, "%s\n", wk[i].build_log);
            if (!rc) {
                rc = wk[i].rc;
                *e = wk[i].e;
            }
        }
    }
    int stopped = (rs->stop && *rs->stop) ||
                  (rs->time_limit > 0 && spt_now() - s.t0 >= rs->time_limit);
    if (failed == count && count > 1)
        rc = spt_fail(e, SPT_EXIT_DEVICE, "every device failed; the last error: %s", e->msg);
    else if (failed < count && s.done_count < s.total && !stopped && !rs->take_chunk)
        rc = spt_fail(e, SPT_EXIT_FAILURE, "render incomplete: %u of %u samples per pixel done",
                      s.done_count, s.total);
    else if (failed < count)
        rc = 0; /* the other devices carried the render to its end */
    stats->spp_done = s.done_count;
    for (int i = 0; i < count; i++)
        free(wk[i].build_log);
    free(wk);
    free(th);
    free(s.done);
    free(s.ret_begin);
    free(s.ret_n);
    render_lights_free(&lights);
    pthread_mutex_destroy(&s.lock);
    return rc;
}

int render_device(const ClDeviceInfo *info, const GpuScene *g, const SceneCamera *cam,
                  const RenderSettings *rs, Film *film, RenderStats *stats, SptError *e)
{
    const ClDeviceInfo *one[1] = {info};
    return render_devices(one, 1, g, cam, rs, film, stats, NULL, e);
}
