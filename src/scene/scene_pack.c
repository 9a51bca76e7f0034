/* Scene to bytes and back (contract in src/scene/scene_pack.h). */
#include "scene/scene_pack.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "spectrum/cie_data.h"

#define PACK_MAGIC 0x53505453u /* "SPTS" */
#define SKY_MAGIC 0x4b545053u  /* "SPTK" */

typedef struct Buf {
    unsigned char *p;
    size_t len, cap;
} Buf;

static void put(Buf *b, const void *data, size_t n)
{
    if (b->len + n > b->cap) {
        while (b->len + n > b->cap)
            b->cap = b->cap ? 2 * b->cap : 4096;
        b->p = spt_realloc(b->p, b->cap);
    }
    if (n)
        memcpy(b->p + b->len, data, n);
    b->len += n;
}

static void put_u64(Buf *b, uint64_t v)
{
    put(b, &v, sizeof v);
}

/* An array as its byte count and bytes. */
static void put_array(Buf *b, const void *data, size_t n)
{
    put_u64(b, n);
    put(b, data, n);
}

static void put_spd(Buf *b, const Spd *s)
{
    put_array(b, s->nm, (size_t)s->count * sizeof(double));
    put_array(b, s->value, (size_t)s->count * sizeof(double));
    put_array(b, s->line_nm, (size_t)s->line_count * sizeof(double));
    put_array(b, s->line_power, (size_t)s->line_count * sizeof(double));
}

void *scene_pack(const Scene *s, size_t *size)
{
    Buf b = {0};
    uint32_t magic = PACK_MAGIC;
    put(&b, &magic, sizeof magic);
    /* The struct itself (counts, camera, bounds, stats); its pointers are
     * meaningless on the other side and replaced there. */
    put(&b, s, sizeof *s);
    put_array(&b, s->path, s->path ? strlen(s->path) + 1 : 0);
    put_array(&b, s->tri_pos, (size_t)s->tri_count * 9 * sizeof(float));
    put_array(&b, s->tri_vidx, (size_t)s->tri_count * 3 * sizeof(uint32_t));
    put_array(&b, s->tri_mat, (size_t)s->tri_count * sizeof(uint32_t));
    put_array(&b, s->vtx_normal, s->vtx_normal ? (size_t)s->vertex_count * 3 * sizeof(float) : 0);
    put_array(&b, s->vtx_uv, s->vtx_uv ? (size_t)s->vertex_count * 2 * sizeof(float) : 0);
    put_array(&b, s->vtx_uv1, s->vtx_uv1 ? (size_t)s->vertex_count * 2 * sizeof(float) : 0);
    put_array(&b, s->vtx_color, s->vtx_color ? (size_t)s->vertex_count * 4 * sizeof(float) : 0);
    put_array(&b, s->vtx_tangent, s->vtx_tangent ? (size_t)s->vertex_count * 4 * sizeof(float) : 0);
    put_array(&b, s->materials, (size_t)s->material_count * sizeof(SceneMaterial));
    for (uint32_t i = 0; i < s->material_count; i++) {
        put_spd(&b, &s->materials[i].reflectance_spd);
        put_spd(&b, &s->materials[i].emission_spd);
    }
    put_array(&b, s->textures, (size_t)s->texture_count * sizeof(SceneTexture));
    for (uint32_t i = 0; i < s->texture_count; i++) {
        const SceneTexture *t = &s->textures[i];
        put_array(&b, t->texels, t->texels ? (size_t)t->width * t->height * t->channels * sizeof(float) : 0);
    }
    put_array(&b, s->lights, (size_t)s->light_count * sizeof(SceneLight));
    for (uint32_t i = 0; i < s->light_count; i++)
        put_spd(&b, &s->lights[i].spd);
    /* The instances (docs/architecture.md, "Instances (two levels)"). */
    put_array(&b, s->mesh_tri_count, (size_t)s->mesh_count * sizeof(uint32_t));
    put_array(&b, s->inst_mesh, (size_t)s->inst_count * sizeof(uint32_t));
    put_array(&b, s->inst_xf, (size_t)s->inst_count * 12 * sizeof(float));
    *size = b.len;
    return b.p;
}

typedef struct Reader {
    const unsigned char *p;
    size_t len, at;
    int bad;
} Reader;

static int get(Reader *r, void *out, size_t n)
{
    if (r->bad || n > r->len - r->at) {
        r->bad = 1;
        return -1;
    }
    memcpy(out, r->p + r->at, n);
    r->at += n;
    return 0;
}

/* A malloc'd copy of the next array, which must be `want` bytes long; NULL for
 * an empty one. */
static void *get_array(Reader *r, size_t want)
{
    uint64_t n = 0;
    if (get(r, &n, sizeof n) || n != want || n > r->len - r->at) {
        r->bad = 1;
        return NULL;
    }
    if (n == 0)
        return NULL;
    void *p = spt_malloc((size_t)n);
    get(r, p, (size_t)n);
    return p;
}

static void get_spd(Reader *r, Spd *s)
{
    s->nm = get_array(r, (size_t)s->count * sizeof(double));
    s->value = get_array(r, (size_t)s->count * sizeof(double));
    s->line_nm = get_array(r, (size_t)s->line_count * sizeof(double));
    s->line_power = get_array(r, (size_t)s->line_count * sizeof(double));
}

int scene_unpack(Scene *s, const void *bytes, size_t size, const char *what, SptError *e)
{
    Reader r = {bytes, size, 0, 0};
    uint32_t magic = 0;
    memset(s, 0, sizeof *s);
    if (get(&r, &magic, sizeof magic) || magic != PACK_MAGIC || get(&r, s, sizeof *s)) {
        memset(s, 0, sizeof *s);
        return spt_fail(e, SPT_EXIT_INPUT, "%s: not a packed scene", what);
    }
    /* Every pointer now comes from the block; until then none may be freed. */
    uint32_t nmat = s->material_count, ntex = s->texture_count;
    s->path = NULL;
    s->tri_pos = NULL;
    s->tri_vidx = s->tri_mat = NULL;
    s->vtx_normal = s->vtx_uv = s->vtx_uv1 = s->vtx_color = s->vtx_tangent = NULL;
    s->materials = NULL;
    s->textures = NULL;
    /* `info`'s lists are not packed: the ranks render, they do not list. */
    s->camera_info = NULL;
    s->animation_info = NULL;
    s->camera_info_count = s->animation_info_count = 0;
    s->lights = NULL;
    s->mesh_tri_count = s->inst_mesh = NULL;
    s->inst_xf = NULL;
    uint32_t nmesh = s->mesh_count, ninst = s->inst_count;
    s->mesh_count = s->inst_count = 0;
    uint64_t plen = 0;
    size_t at = r.at;
    if (!get(&r, &plen, sizeof plen)) {
        r.at = at;
        s->path = get_array(&r, (size_t)plen);
        if (s->path && s->path[plen - 1])
            r.bad = 1;
    }
    s->tri_pos = get_array(&r, (size_t)s->tri_count * 9 * sizeof(float));
    s->tri_vidx = get_array(&r, (size_t)s->tri_count * 3 * sizeof(uint32_t));
    s->tri_mat = get_array(&r, (size_t)s->tri_count * sizeof(uint32_t));
    /* Vertex arrays may be absent (an empty array) or complete. */
    float **arrays[5] = {&s->vtx_normal, &s->vtx_uv, &s->vtx_uv1, &s->vtx_color, &s->vtx_tangent};
    const size_t per_vertex[5] = {3, 2, 2, 4, 4};
    for (int k = 0; k < 5 && !r.bad; k++) {
        uint64_t n = 0;
        size_t pos = r.at;
        get(&r, &n, sizeof n);
        r.at = pos;
        size_t full = (size_t)s->vertex_count * per_vertex[k] * sizeof(float);
        *arrays[k] = get_array(&r, n ? full : 0);
    }
    s->material_count = 0;
    s->materials = get_array(&r, (size_t)nmat * sizeof(SceneMaterial));
    for (uint32_t i = 0; i < nmat && s->materials; i++) {
        SceneMaterial *m = &s->materials[i];
        m->reflectance_spd.nm = m->reflectance_spd.value = NULL;
        m->reflectance_spd.line_nm = m->reflectance_spd.line_power = NULL;
        m->emission_spd.nm = m->emission_spd.value = NULL;
        m->emission_spd.line_nm = m->emission_spd.line_power = NULL;
    }
    if (s->materials)
        s->material_count = nmat;
    for (uint32_t i = 0; i < s->material_count; i++) {
        get_spd(&r, &s->materials[i].reflectance_spd);
        get_spd(&r, &s->materials[i].emission_spd);
    }
    s->texture_count = 0;
    s->textures = get_array(&r, (size_t)ntex * sizeof(SceneTexture));
    for (uint32_t i = 0; i < ntex && s->textures; i++)
        s->textures[i].texels = NULL;
    if (s->textures)
        s->texture_count = ntex;
    for (uint32_t i = 0; i < s->texture_count; i++) {
        SceneTexture *t = &s->textures[i];
        uint64_t n = 0;
        size_t pos = r.at;
        get(&r, &n, sizeof n);
        r.at = pos;
        t->texels = get_array(&r, n ? (size_t)t->width * t->height * t->channels * sizeof(float) : 0);
    }
    uint32_t nl = s->light_count;
    s->light_count = 0;
    s->lights = get_array(&r, (size_t)nl * sizeof(SceneLight));
    for (uint32_t i = 0; i < nl && s->lights; i++) {
        Spd *sp = &s->lights[i].spd;
        sp->nm = sp->value = sp->line_nm = sp->line_power = NULL;
    }
    if (s->lights)
        s->light_count = nl;
    for (uint32_t i = 0; i < s->light_count; i++)
        get_spd(&r, &s->lights[i].spd);
    s->mesh_tri_count = get_array(&r, (size_t)nmesh * sizeof(uint32_t));
    s->inst_mesh = get_array(&r, (size_t)ninst * sizeof(uint32_t));
    s->inst_xf = get_array(&r, (size_t)ninst * 12 * sizeof(float));
    if (!r.bad) {
        s->mesh_count = nmesh;
        s->inst_count = ninst;
    }
    if (r.bad || r.at != r.len || (nl && !s->lights) || (nmat && !s->materials) ||
        (ntex && !s->textures) || (nmesh && !s->mesh_tri_count) || (ninst && !s->inst_xf)) {
        scene_free(s);
        return spt_fail(e, SPT_EXIT_INPUT, "%s: packed scene is truncated or inconsistent", what);
    }
    return 0;
}

/* A string as an array with its terminating 0; NULL as an empty array. */
static void put_string(Buf *b, const char *s)
{
    put_array(b, s, s ? strlen(s) + 1 : 0);
}

static char *get_string(Reader *r)
{
    uint64_t n = 0;
    size_t pos = r->at;
    if (get(r, &n, sizeof n))
        return NULL;
    r->at = pos;
    char *s = get_array(r, (size_t)n);
    if (s && s[n - 1])
        r->bad = 1;
    return s;
}

void *sky_pack(const Sky *sky, size_t *size)
{
    Buf b = {0};
    uint32_t magic = SKY_MAGIC;
    put(&b, &magic, sizeof magic);
    Sky head = *sky;
    head.spd = head.map = NULL;
    head.env = head.background = NULL;
    put(&b, &head, sizeof head);
    put_array(&b, sky->spd, sky->spd ? SPT_CIE_SAMPLES * sizeof(float) : 0);
    put_array(&b, sky->map, sky->map ? (size_t)sky->map_width * sky->map_height * 3 * sizeof(float) : 0);
    put_string(&b, sky->env);
    put_string(&b, sky->background);
    *size = b.len;
    return b.p;
}

int sky_unpack(Sky *sky, const void *bytes, size_t size, const char *what, SptError *e)
{
    Reader r = {bytes, size, 0, 0};
    uint32_t magic = 0;
    memset(sky, 0, sizeof *sky);
    if (get(&r, &magic, sizeof magic) || magic != SKY_MAGIC || get(&r, sky, sizeof *sky)) {
        memset(sky, 0, sizeof *sky);
        return spt_fail(e, SPT_EXIT_INPUT, "%s: not a packed sky", what);
    }
    int want_spd = sky->kind == SPT_SKY_SPD, want_map = sky->kind == SPT_SKY_MAP;
    sky->spd = sky->map = NULL;
    sky->env = sky->background = NULL;
    if (want_map && (sky->map_width < 1 || sky->map_height < 1 ||
                     (uint64_t)sky->map_width * (uint64_t)sky->map_height > ((uint64_t)1 << 28)))
        r.bad = 1;
    sky->spd = get_array(&r, want_spd ? SPT_CIE_SAMPLES * sizeof(float) : 0);
    if (!r.bad)
        sky->map = get_array(&r, want_map ? (size_t)sky->map_width * sky->map_height * 3 * sizeof(float) : 0);
    sky->env = get_string(&r);
    sky->background = get_string(&r);
    if (r.bad || r.at != r.len || (want_spd && !sky->spd) || (want_map && !sky->map)) {
        sky_free(sky);
        return spt_fail(e, SPT_EXIT_INPUT, "%s: packed sky is truncated or inconsistent", what);
    }
    return 0;
}
