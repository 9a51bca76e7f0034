/* The upload of a scene into the arrays the kernels read (GpuScene): packed
 * triangles and their shading data, materials with their spectra, textures as
 * sigmoid coefficients, emitters and punctual lights. */
#include "render/gpu_scene.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "render/render_lights.h"
#include "spectrum/cie_data.h"
#include "spectrum/spectrum.h"

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
 * -1 when unknown. The loader accepts only the names of kernels/closure/conductors.h. */
static int conductor_id(const char *name)
{
    /* The order of SPT_CONDUCTOR_AU, _AG, _CU, _AL in kernels/closure/conductors.h. */
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

/* How each texture slot's texels are read (SPT_TEXKIND_*; kernels/integrator/wavefront.cl,
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
    [SPT_TS_IRIDESCENCE] = SPT_TEXKIND_DATA,
    [SPT_TS_IRIDESCENCE_THICKNESS] = SPT_TEXKIND_DATA,
    [SPT_TS_ANISOTROPY] = SPT_TEXKIND_DATA,
    [SPT_TS_DIFFUSE_TRANSMISSION] = SPT_TEXKIND_DATA,
    [SPT_TS_DIFFUSE_TRANSMISSION_COLOR] = SPT_TEXKIND_COLOR,
};

/* The scene's slots are the device's, with occlusion last and not uploaded. */
SPT_STATIC_ASSERT(SPT_SLOT_BASE == SPT_TS_BASE && SPT_SLOT_EMISSIVE == SPT_TS_EMISSIVE &&
                      SPT_SLOT_SHEEN_ROUGHNESS == SPT_TS_SHEEN_ROUGHNESS &&
                      SPT_SLOT_ANISOTROPY == SPT_TS_ANISOTROPY &&
                      SPT_SLOT_DIFFUSE_TRANSMISSION_COLOR == SPT_TS_DIFFUSE_TRANSMISSION_COLOR &&
                      SPT_SLOT_OCCLUSION == SPT_TS_COUNT,
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

/* KHR_materials_anisotropy and KHR_materials_diffuse_transmission of m into gm
 * (its slots already set): each off, its textures dropped, with a zero factor;
 * the rotation as its cosine and sine; the colour white when its texture holds
 * it (set_slot folded the factor in). SPT_MAT_VOLUME: KHR_materials_volume's
 * thickness, which makes a diffuse transmitter a volume's boundary. */
static void material_upload_ext(GpuMaterial *gm, const SceneMaterial *m)
{
    if (m->anisotropy > 0.0f) {
        gm->aniso = m->anisotropy;
        gm->aniso_cos = cosf(m->anisotropy_rotation);
        gm->aniso_sin = sinf(m->anisotropy_rotation);
    } else {
        gm->slot[SPT_TS_ANISOTROPY].tex = -1;
    }
    if (m->diffuse_transmission > 0.0f) {
        gm->diffuse_transmission = m->diffuse_transmission;
        gm->dt_color = gm->slot[SPT_TS_DIFFUSE_TRANSMISSION_COLOR].tex >= 0
                           ? spec_white()
                           : spec_from_rgb_scaled(m->diffuse_transmission_color);
    } else {
        gm->slot[SPT_TS_DIFFUSE_TRANSMISSION].tex = gm->slot[SPT_TS_DIFFUSE_TRANSMISSION_COLOR].tex = -1;
    }
    if (m->thickness > 0.0f)
        gm->flags |= SPT_MAT_VOLUME;
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
        else if (k == SPT_TS_DIFFUSE_TRANSMISSION_COLOR)
            factor = m->diffuse_transmission_color;
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

    /* The BSDF (kernels/closure/bsdf.h). */
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
    /* KHR_materials_iridescence: off with a zero factor, whatever its textures. */
    if (m->iridescence > 0.0f) {
        gm->iridescence = m->iridescence;
        gm->irid_ior = m->iridescence_ior;
        gm->irid_min_nm = m->iridescence_min_nm;
        gm->irid_max_nm = m->iridescence_max_nm;
    } else {
        gm->slot[SPT_TS_IRIDESCENCE].tex = gm->slot[SPT_TS_IRIDESCENCE_THICKNESS].tex = -1;
    }
    material_upload_ext(gm, m);
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

/* rc, with the scene's file put in front of e's message about its content. */
static int in_scene_file(const Scene *s, int rc, SptError *e)
{
    if (s->path && e) {
        char msg[sizeof e->msg];
        memcpy(msg, e->msg, sizeof msg);
        spt_fail(e, rc, "%s: %s", s->path, msg);
    }
    return rc;
}

/* The BVHs of s (docs/architecture.md, "Instances (two levels)"): g->bvh over
 * its world-space triangles and, with instances, each mesh's and the top
 * level (g->tlas, mesh 0 being g->bvh under the identity). *src (allocated)
 * gets each packed triangle's index in s. Returns 0 or an exit code (e
 * filled). */
static int build_levels(GpuScene *g, const Scene *s, uint32_t **src, SptError *e)
{
    uint64_t mesh_tris = 0;
    for (uint32_t m = 0; m < s->mesh_count; m++)
        mesh_tris += s->mesh_tri_count[m];
    if (mesh_tris > s->tri_count)
        return spt_fail(e, SPT_EXIT_INPUT, "instances: the meshes hold %llu triangles of %u",
                        (unsigned long long)mesh_tris, s->tri_count);
    uint32_t world = s->tri_count - (uint32_t)mesh_tris;
    int rc = bvh_build(&g->bvh, s->tri_pos, world, e);
    if (rc)
        return rc;
    if (!s->mesh_count) {
        g->prim_total = g->bvh.prim_count;
        *src = spt_malloc((g->prim_total ? g->prim_total : 1) * sizeof(uint32_t));
        memcpy(*src, g->bvh.prim_index, g->prim_total * sizeof(uint32_t));
        return 0;
    }
    uint32_t nm = s->mesh_count + 1;
    Bvh *mesh = spt_calloc(nm, sizeof(Bvh));
    uint32_t *prim_base = spt_calloc(nm, sizeof(uint32_t)), *first = spt_calloc(nm, sizeof(uint32_t));
    mesh[0] = g->bvh;
    uint64_t total = g->bvh.prim_count;
    for (uint32_t m = 1; m < nm && !rc; m++) {
        first[m] = m == 1 ? world : first[m - 1] + s->mesh_tri_count[m - 2];
        rc = bvh_build(&mesh[m], s->tri_pos + 9 * (size_t)first[m], s->mesh_tri_count[m - 1], e);
        prim_base[m] = (uint32_t)total;
        total += mesh[m].prim_count;
    }
    /* Instance 0 places the world-space triangles by the identity; the
     * Scene's follow, their meshes counted from 1. */
    uint32_t ni = s->inst_count + 1;
    float *xf = spt_calloc((size_t)ni * 12, sizeof(float));
    uint32_t *im = spt_calloc(ni, sizeof(uint32_t));
    xf[0] = xf[5] = xf[10] = 1.0f;
    for (uint32_t k = 0; k < s->inst_count; k++) {
        memcpy(xf + 12 * (size_t)(k + 1), s->inst_xf + 12 * (size_t)k, 12 * sizeof(float));
        im[k + 1] = s->inst_mesh[k] < s->mesh_count ? s->inst_mesh[k] + 1 : nm;
    }
    if (!rc && total > UINT32_MAX - 1)
        rc = spt_fail(e, SPT_EXIT_INPUT, "instances: %llu triangles in the meshes",
                      (unsigned long long)total);
    if (!rc)
        rc = tlas_build(&g->tlas, mesh, prim_base, nm, xf, im, ni, e);
    if (!rc) {
        g->prim_total = (uint32_t)total;
        g->mesh_prims = spt_malloc((nm + 1) * sizeof(uint32_t));
        memcpy(g->mesh_prims, prim_base, nm * sizeof(uint32_t));
        g->mesh_prims[nm] = g->prim_total;
        *src = spt_malloc((total ? total : 1) * sizeof(uint32_t));
        for (uint32_t m = 0; m < nm; m++)
            for (uint32_t i = 0; i < mesh[m].prim_count; i++)
                (*src)[prim_base[m] + i] = first[m] + mesh[m].prim_index[i];
    }
    for (uint32_t m = 1; m < nm; m++)
        bvh_free(&mesh[m]);
    free(mesh);
    free(prim_base);
    free(first);
    free(xf);
    free(im);
    return rc;
}

int gpu_scene_build(GpuScene *g, const Scene *s, SptError *e)
{
    return gpu_scene_build_with(g, s, NULL, e);
}

int gpu_scene_build_with(GpuScene *g, const Scene *s, Bvh *bvh, SptError *e)
{
    memset(g, 0, sizeof *g);
    uint32_t *src = NULL;
    int rc = 0;
    if (bvh && bvh->nodes && !s->mesh_count) {
        /* One level: the given tree is the whole scene's. */
        g->bvh = *bvh;
        memset(bvh, 0, sizeof *bvh);
        g->prim_total = g->bvh.prim_count;
        src = spt_malloc((g->prim_total ? g->prim_total : 1) * sizeof(uint32_t));
        memcpy(src, g->bvh.prim_index, g->prim_total * sizeof(uint32_t));
    } else {
        if (bvh)
            bvh_free(bvh);
        rc = build_levels(g, s, &src, e);
    }
    if (rc) {
        free(src);
        gpu_scene_free(g);
        return in_scene_file(s, rc, e);
    }
    uint32_t n = g->prim_total;
    g->tri_shade = spt_calloc(n ? n : 1, sizeof(TriShade));
    for (uint32_t i = 0; i < n; i++) {
        uint32_t t = src[i];
        for (int k = 0; k < 3; k++)
            g->tri_shade[i].v[k] = s->tri_vidx[3 * (size_t)t + k];
        g->tri_shade[i].material = s->tri_mat[t];
    }
    g->vtx_normal = s->vtx_normal;
    g->vtx_uv = s->vtx_uv;
    g->vtx_uv1 = s->vtx_uv1;
    g->vtx_tangent = s->vtx_tangent;
    g->vertex_count = s->vertex_count;
    /* Vertex positions for shading: a vertex shared by triangles has one
     * position, the one every kept triangle using it carries. */
    g->vtx_pos = spt_calloc(s->vertex_count ? (size_t)s->vertex_count * 3 : 1, sizeof(float));
    for (uint32_t i = 0; i < n; i++) {
        uint32_t t = src[i];
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
    free(src);
    if (bvh_qnodes_wanted()) {
        const Tlas *tl = &g->tlas;
        g->qnodes = tl->inst_count ? bvh_quantise_nodes(tl->nodes, tl->node_count)
                                   : bvh_quantise_nodes(g->bvh.nodes, g->bvh.node_count);
        g->qtop = tl->inst_count ? bvh_quantise_nodes(tl->top, tl->top_count) : NULL;
    }

    return gpu_scene_build_shading(g, s, e);
}

void gpu_scene_tri(const GpuScene *g, uint32_t prim, vec3 *a, vec3 *b, vec3 *c)
{
    const TriShade *ts = &g->tri_shade[prim];
    *a = v3_load(g->vtx_pos + 3 * (size_t)ts->v[0]);
    *b = v3_load(g->vtx_pos + 3 * (size_t)ts->v[1]);
    *c = v3_load(g->vtx_pos + 3 * (size_t)ts->v[2]);
}

/* The emitters of the instanced meshes (docs/architecture.md, "Instances
 * (two levels)"): per mesh its emitting triangles once, weighted by their
 * power in the mesh's space, and per instance of such a mesh one emitter
 * after the triangles, weighted by the power of its triangles placed
 * (pi * world area * Y(Le), mat_y the materials' Y(Le)). */
static void instanced_emitters(GpuScene *g, const Scene *s, const double *mat_y)
{
    uint32_t nm = s->mesh_count + 1;
    g->mesh_count = nm;
    g->mesh_emitter_first = spt_calloc(nm + 1, sizeof(uint32_t));
    uint32_t cap = 0, count = 0;
    for (uint32_t m = 1; m < nm; m++) {
        g->mesh_emitter_first[m] = count;
        for (uint32_t i = g->mesh_prims[m]; i < g->mesh_prims[m + 1]; i++) {
            uint32_t mat = g->tri_shade[i].material;
            if (!(mat < g->material_count && (g->materials[mat].flags & SPT_MAT_EMISSIVE)))
                continue;
            vec3 a, b, c;
            gpu_scene_tri(g, i, &a, &b, &c);
            float w = (float)(M_PI * 0.5 * v3_length(v3_cross(v3_sub(b, a), v3_sub(c, a))) * mat_y[mat]);
            if (!(w > 0.0f))
                continue;
            if (count == cap) {
                cap = cap ? 2 * cap : 64;
                g->mesh_emitter_prims = spt_realloc(g->mesh_emitter_prims, cap * sizeof(uint32_t));
                g->mesh_emitter_power = spt_realloc(g->mesh_emitter_power, cap * sizeof(float));
            }
            g->mesh_emitter_prims[count] = i;
            g->mesh_emitter_power[count++] = w;
        }
    }
    g->mesh_emitter_first[nm] = count;
    for (uint32_t k = 0; k < g->tlas.inst_count; k++) {
        uint32_t m = g->tlas.inst_mesh[k];
        if (m == 0 || m >= nm || g->mesh_emitter_first[m] == g->mesh_emitter_first[m + 1])
            continue;
        double power = 0.0;
        for (uint32_t j = g->mesh_emitter_first[m]; j < g->mesh_emitter_first[m + 1]; j++) {
            uint32_t i = g->mesh_emitter_prims[j];
            vec3 a, b, c;
            gpu_scene_tri(g, i, &a, &b, &c);
            power += M_PI * mat_y[g->tri_shade[i].material] *
                     tlas_placed_tri(&g->tlas.inst[k], a, b, c, NULL, NULL, NULL);
        }
        uint32_t n = g->emitter_count + 1;
        g->emitters = spt_realloc(g->emitters, n * sizeof(uint32_t));
        g->emitter_power = spt_realloc(g->emitter_power, n * sizeof(float));
        g->emitter_area = spt_realloc(g->emitter_area, n * sizeof(float));
        g->emitters[n - 1] = k;
        g->emitter_power[n - 1] = (float)power;
        g->emitter_area[n - 1] = 0.0f;
        g->emitter_count = n;
    }
}

/* Frees what gpu_scene_build_shading makes. */
static void shading_free(GpuScene *g)
{
    free(g->materials);
    free(g->spectra);
    free(g->textures);
    free(g->texels);
    free(g->emitters);
    free(g->emitter_power);
    free(g->emitter_area);
    free(g->mesh_emitter_first);
    free(g->mesh_emitter_prims);
    free(g->mesh_emitter_power);
    free(g->lights);
    g->materials = NULL;
    g->spectra = NULL;
    g->textures = NULL;
    g->texels = NULL;
    g->emitters = NULL;
    g->emitter_power = g->emitter_area = NULL;
    g->mesh_emitter_first = g->mesh_emitter_prims = NULL;
    g->mesh_emitter_power = NULL;
    g->mesh_count = 0;
    g->lights = NULL;
    g->material_count = g->spectra_count = g->texture_count = 0;
    g->texel_count = 0;
    g->emitter_count = g->tri_emitter_count = g->light_count = 0;
}

int gpu_scene_build_shading(GpuScene *g, const Scene *s, SptError *e)
{
    shading_free(g);
    uint32_t n = g->prim_total;
    int rc;
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

    /* Materials some of whose triangles have TANGENT at all three vertices
     * (kernels/material/material_eval.h then reads vtx_tangent). */
    for (uint32_t i = 0; i < n && s->vtx_tangent; i++) {
        const TriShade *ts = &g->tri_shade[i];
        int all = 1;
        for (int k = 0; k < 3; k++)
            all &= s->vtx_tangent[4 * (size_t)ts->v[k] + 3] != 0.0f;
        if (all && ts->material < g->material_count)
            g->materials[ts->material].flags |= SPT_MAT_TANGENTS;
    }

    /* Emitters: every packed triangle whose material emits, weighted by its
     * Y-weighted power pi * area * Y(Le) (kernels/light/lights.h's selection units). */
    double *mat_y = spt_calloc(g->material_count ? g->material_count : 1, sizeof(double));
    for (uint32_t i = 0; i < g->material_count; i++)
        if (g->materials[i].flags & SPT_MAT_EMISSIVE)
            mat_y[i] = emission_luminance(&g->materials[i], g->spectra) * textured_emission_y(&s->materials[i]);
    for (uint32_t i = 0; i < g->bvh.prim_count; i++) {
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
    g->tri_emitter_count = g->emitter_count;
    if (g->tlas.inst_count)
        instanced_emitters(g, s, mat_y);
    free(mat_y);

    /* Punctual lights, their spectra appended to the spectra table. */
    float r2 = 0.0f;
    for (int k = 0; k < 3; k++) {
        float d = s->bounds_max[k] - s->bounds_min[k];
        r2 += d > 0.0f ? d * d : 0.0f;
    }
    g->scene_radius = r2 > 0.0f ? 0.5f * sqrtf(r2) : 1.0f;
    for (int k = 0; k < 3; k++)
        g->scene_center[k] = r2 > 0.0f ? 0.5f * (s->bounds_min[k] + s->bounds_max[k]) : 0.0f;
    g->lights = spt_calloc(s->light_count ? s->light_count : 1, sizeof(GpuLight));
    g->line_spectrum = 0;
    for (uint32_t i = 0; i < s->light_count; i++) {
        g->spectra = spt_realloc(g->spectra, (g->spectra_count + SPT_CIE_SAMPLES) * sizeof(float));
        rc = light_from_scene(&s->lights[i], g->spectra + g->spectra_count, g->spectra_count,
                              &g->lights[g->light_count], e);
        if (rc) {
            gpu_scene_free(g);
            return in_scene_file(s, rc, e);
        }
        g->spectra_count += SPT_CIE_SAMPLES;
        g->light_count++;
        g->line_spectrum |= s->lights[i].spd.line_count > 0;
    }
    for (uint32_t i = 0; i < s->material_count; i++)
        g->line_spectrum |= s->materials[i].emission_spd.line_count > 0;
    return 0;
}

void gpu_scene_free(GpuScene *g)
{
    bvh_free(&g->bvh);
    tlas_free(&g->tlas);
    free(g->qnodes);
    free(g->qtop);
    free(g->mesh_prims);
    free(g->tri_shade);
    free(g->vtx_pos);
    free(g->vtx_color);
    shading_free(g);
    memset(g, 0, sizeof *g);
}


/* OpenCL refuses empty buffers: an empty one is 16 bytes of zeros. */
#define NZ(x) (pad ? nz(x) : (size_t)(x))
static size_t nz(size_t x) { return x ? x : 16; }

/* The buffer's size, padded (pad) as the device gets it or as its data holds. */
static size_t buffer_bytes(const GpuScene *g, const RenderLights *L, const char *name, int pad)
{
    uint32_t n = g->prim_total;
    const Tlas *tl = &g->tlas;
    size_t node_bytes = g->qnodes ? sizeof(BvhQNode) : sizeof(BvhNode);
    if (!strcmp(name, "nodes"))
        return NZ((tl->inst_count ? tl->node_count : g->bvh.node_count) * node_bytes);
    if (!strcmp(name, "tris"))
        return NZ(tl->inst_count ? tl->tri_words * sizeof(float) : g->bvh.tri_data_bytes);
    if (!strcmp(name, "tlas_top")) return NZ((size_t)tl->top_count * node_bytes);
    if (!strcmp(name, "tlas_inst")) return NZ((size_t)tl->inst_count * sizeof(BvhInstance));
    if (!strcmp(name, "tri_shade")) return NZ((size_t)n * sizeof(TriShade));
    if (!strcmp(name, "vtx_pos")) return NZ((size_t)g->vertex_count * 3 * sizeof(float));
    if (!strcmp(name, "vtx_normal")) return NZ((size_t)g->vertex_count * 3 * sizeof(float));
    if (!strcmp(name, "vtx_uv")) return NZ((size_t)g->vertex_count * 2 * sizeof(float));
    if (!strcmp(name, "vtx_uv1")) return NZ(g->vtx_uv1 ? (size_t)g->vertex_count * 2 * sizeof(float) : 0);
    if (!strcmp(name, "vtx_color")) return NZ(g->vtx_color ? (size_t)g->vertex_count * 4 * sizeof(float) : 0);
    if (!strcmp(name, "vtx_tangent"))
        return NZ(g->vtx_tangent ? (size_t)g->vertex_count * 4 * sizeof(float) : 0);
    if (!strcmp(name, "materials")) return NZ((size_t)g->material_count * sizeof(GpuMaterial));
    if (!strcmp(name, "spectra")) return NZ((size_t)g->spectra_count * sizeof(float));
    if (!strcmp(name, "textures")) return NZ((size_t)g->texture_count * sizeof(GpuTexture));
    if (!strcmp(name, "texels")) return NZ(g->texel_count * 4 * sizeof(float));
    if (!strcmp(name, "emitters")) return NZ((size_t)g->emitter_count * sizeof(uint32_t));
    /* Without L, the instanced meshes' lists and CDFs at their largest. */
    size_t mesh_lists = g->mesh_count ? g->mesh_emitter_first[g->mesh_count] + 2 * (size_t)g->mesh_count : 0;
    if (!strcmp(name, "light_cdf"))
        return L ? (L->select.n ? (size_t)L->cdf_count * sizeof(float) : 16)
                 : ((size_t)g->emitter_count + 2 * g->light_count + 5 + mesh_lists) * sizeof(float);
    if (!strcmp(name, "inst_light"))
        return NZ(L ? (size_t)L->inst_light_count * sizeof(uint32_t)
                    : (g->emitter_count > g->tri_emitter_count
                           ? (g->tlas.inst_count + 2 * (size_t)(g->emitter_count - g->tri_emitter_count) +
                              mesh_lists) * sizeof(uint32_t)
                           : 0));
    /* Without L (the estimate of gpu_scene_bytes), the tree's largest size. */
    if (!strcmp(name, "light_tree"))
        return NZ((L ? (size_t)L->tree.count : 2 * ((size_t)g->emitter_count + g->light_count)) *
                  sizeof(LightTreeNode));
    if (!strcmp(name, "tri_light_leaf")) return NZ(!L || L->tree.count ? (size_t)n * sizeof(uint32_t) : 0);
    if (!strcmp(name, "tri_light_pdf")) return NZ((size_t)n * sizeof(float));
    if (!strcmp(name, "lights")) return NZ((size_t)g->light_count * sizeof(GpuLight));
    if (!strcmp(name, "env_data")) return NZ(L ? (size_t)L->env.data_count * sizeof(float) : 0);
    return pad ? 16 : 0;
}
#undef NZ

size_t gpu_scene_buffer_bytes(const GpuScene *g, const RenderLights *L, const char *name)
{
    return buffer_bytes(g, L, name, 1);
}

/* A buffer whose data holds fewer bytes than the device's buffer (an empty
 * array padded to 16 bytes, whose placeholder allocation is smaller) is
 * given no data: the device's copy is zeros. */
const void *gpu_scene_buffer_data(const GpuScene *g, const RenderLights *L, const char *name)
{
    if (buffer_bytes(g, L, name, 0) < buffer_bytes(g, L, name, 1))
        return NULL;
    if (!strcmp(name, "nodes"))
        return g->qnodes ? (const void *)g->qnodes : g->tlas.inst_count ? g->tlas.nodes : g->bvh.nodes;
    if (!strcmp(name, "tris")) return g->tlas.inst_count ? g->tlas.tris : g->bvh.tri_data;
    if (!strcmp(name, "tlas_top")) return g->qtop ? (const void *)g->qtop : g->tlas.top;
    if (!strcmp(name, "tlas_inst")) return g->tlas.inst;
    if (!strcmp(name, "tri_shade")) return g->tri_shade;
    if (!strcmp(name, "vtx_pos")) return g->vtx_pos;
    if (!strcmp(name, "vtx_normal")) return g->vtx_normal;
    if (!strcmp(name, "vtx_uv")) return g->vtx_uv;
    if (!strcmp(name, "vtx_uv1")) return g->vtx_uv1;
    if (!strcmp(name, "vtx_color")) return g->vtx_color;
    if (!strcmp(name, "vtx_tangent")) return g->vtx_tangent;
    if (!strcmp(name, "materials")) return g->materials;
    if (!strcmp(name, "spectra")) return g->spectra;
    if (!strcmp(name, "textures")) return g->textures;
    if (!strcmp(name, "texels")) return g->texels;
    if (!strcmp(name, "emitters")) return g->emitters;
    if (!strcmp(name, "light_cdf")) return L && L->select.n ? L->cdf_all : NULL;
    if (!strcmp(name, "inst_light")) return L ? L->inst_light : NULL;
    if (!strcmp(name, "light_tree")) return L ? L->tree.nodes : NULL;
    if (!strcmp(name, "tri_light_leaf")) return L ? L->tri_leaf : NULL;
    if (!strcmp(name, "tri_light_pdf")) return L ? L->tri_light_pdf : NULL;
    if (!strcmp(name, "lights")) return g->lights;
    if (!strcmp(name, "env_data")) return L ? L->env.data : NULL;
    return NULL;
}

size_t gpu_scene_bytes(const GpuScene *g)
{
    size_t total = 0;
#define ADD(type, name) total += gpu_scene_buffer_bytes(g, NULL, #name);
    SPT_SCENE_BUFFERS(ADD)
#undef ADD
    return total;
}
