/* Checkpoints: the film, its sample counts and what identifies the render, as
 * EXR layers (contracts and the file layout in src/render/checkpoint.h). */
#include "render/checkpoint.h"

#include <errno.h>
#include <stdarg.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>

#include "cl/cl_device.h"
#include "sample/rng.h"
#include "cl/embedded.h"
#include "io/exr.h"
#include "io/image_out.h"
#include "core/input_file.h"
#include "render/render_options.h"

/* Version 2 added spectrace:checksum; version 1 files are refused (docs/outputs.md,
 * "Checkpoints"). */
#define CKPT_VERSION 2

/* The channels of the film's AOV sums (src/render/film.h, in its order), after
 * "aov_sum." (the sums rounded to float) and "aov_sum_lo." (what that lost). */
static const char *const aov_sum_names[SPT_AOV_SUMS] = {
    "albedo.R", "albedo.G", "albedo.B", "N.X", "N.Y", "N.Z", "Z",
    "P.X",      "P.Y",      "P.Z",      "sq.R", "sq.G", "sq.B"};

/* FNV-1a 64 of a whole file's bytes. */
static int hash_file(const char *path, unsigned long long *h, SptError *e)
{
    int rc = input_check(path, "scene file", e);
    if (rc)
        return rc;
    FILE *f = fopen(path, "rb");
    if (!f)
        return spt_fail(e, SPT_EXIT_INPUT, "%s: cannot read: %s", path, strerror(errno));
    unsigned long long x = SPT_FNV1A_INIT;
    char buf[65536];
    size_t n;
    while ((n = fread(buf, 1, sizeof buf, f)) > 0)
        x = cl_fnv1a(x, buf, n);
    int bad = ferror(f);
    fclose(f);
    if (bad)
        return spt_fail(e, SPT_EXIT_INPUT, "%s: read error", path);
    *h = x;
    return 0;
}

static int is_regular_file(const char *path)
{
    struct stat st;
    return path && stat(path, &st) == 0 && S_ISREG(st.st_mode);
}

/* Appends "name=value;" to the key's list (truncated at its end). */
static void key_add(CheckpointKey *k, const char *name, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));
static void key_add(CheckpointKey *k, const char *name, const char *fmt, ...)
{
    size_t len = strlen(k->settings);
    char value[640];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(value, sizeof value, fmt, ap);
    va_end(ap);
    /* ';' and '=' separate the entries. */
    for (char *p = value; *p; p++)
        if (*p == ';' || *p == '=')
            *p = '_';
    snprintf(k->settings + len, sizeof k->settings - len, "%s=%s;", name, value);
}

/* The key entry of a file named by an option, by content: "default" when the
 * option is not given, a hash when it names a regular file (an --env map, a
 * --background CSV), else the text itself (a --background colour or name). */
static int key_add_file(CheckpointKey *k, const char *name, const char *value, SptError *e)
{
    unsigned long long h;
    if (!value) {
        key_add(k, name, "default");
    } else if (is_regular_file(value)) {
        int rc = hash_file(value, &h, e);
        if (rc)
            return rc;
        key_add(k, name, "file-fnv:%016llx", h);
    } else {
        key_add(k, name, "%s", value);
    }
    return 0;
}

int checkpoint_key(CheckpointKey *k, const char *scene_path, const RenderSettings *given,
                   SptError *e)
{
    memset(k, 0, sizeof *k);
    /* The settings as rendered: light_paths 0 (a RenderSettings of zeros) is
     * the default, which the command line writes out. */
    RenderSettings eff = *given;
    if (!(eff.light_paths > 0.0f))
        eff.light_paths = (float)SPT_LIGHT_PATHS_DEFAULT;
    const RenderSettings *rs = &eff;
    unsigned long long h;
    int rc = hash_file(scene_path, &h, e);
    if (rc)
        return rc;
    snprintf(k->scene_hash, sizeof k->scene_hash, "%016llx", h);
    /* Every option of src/render/render_options.h that changes the image: the
     * settings by value, the sky's files by content. */
#define KEY_RS_INT(name) key_add(k, #name, "%d", rs->name);
#define KEY_RS_U32(name) key_add(k, #name, "%u", rs->name);
#define KEY_RS_FLT(name) key_add(k, #name, "%.9g", rs->name);
#define KEY_RS_DBL(name) key_add(k, #name, "%.17g", rs->name);
/* A STR row of RenderSettings (--at, --animation, --camera) by its text; NULL,
 * the value of a RenderSettings of zeros, is not given. */
#define KEY_RS_STR(name) key_add(k, #name, "%s", rs->name ? rs->name : "default");
#define KEY_RS_FLAG(name) key_add(k, #name, "%d", rs->name);
#define KEY_RS_SWITCH(name) key_add(k, #name, "%d", rs->name);
#define KEY_RS_SAMPLER(name) key_add(k, #name, "%u", rs->name);
#define KEY_RS_AOV(name) key_add(k, #name, "%u", rs->name);
#define KEY_SKY_STR(name)                                                                  \
    if ((rc = key_add_file(k, #name, rs->sky ? rs->sky->name : NULL, e)))                  \
        return rc;
/* Rows of other kinds never change the image; one that did would need its
 * entry here (tests/test_options.c finds it missing). */
#define KEY_NONE(name)
#define KEY_CLI_STR KEY_NONE
#define KEY_CLI_LIST KEY_NONE
#define KEY_CLI_INT KEY_NONE
#define KEY_CLI_U32 KEY_NONE
#define KEY_CLI_DBL KEY_NONE
#define KEY_CLI_FLT KEY_NONE
#define KEY_CLI_FLAG KEY_NONE
#define KEY_CLI_TONEMAP KEY_NONE
#define KEY_CLI_HELP KEY_NONE
#define KEY(where, kind, type, name, option, short_name, metavar, def, lo, hi, flags, ...)  \
    if ((flags) & SPT_OPT_IMAGE) {                                                          \
        KEY_##where##_##kind(name)                                                          \
    }
    SPT_RENDER_OPTIONS(KEY)
#undef KEY
    /* The kernels decide what a sample computes: another renderer version gives
     * another image. */
    unsigned long long kh = SPT_FNV1A_INIT;
    for (int i = 0; i < spt_kernel_file_count; i++) {
        kh = cl_fnv1a(kh, spt_kernel_files[i].path, strlen(spt_kernel_files[i].path));
        kh = cl_fnv1a(kh, spt_kernel_files[i].text, strlen(spt_kernel_files[i].text));
    }
    key_add(k, "kernels", "%016llx", kh);
    /* ZSobol's sequence depends on the samples per pixel, rounded up to a
     * power of two: a resumed render must keep that power. */
    if (rs->sampler == SPT_SAMPLER_ZSOBOL)
        key_add(k, "zsobol_spp", "%llu", 1ull << spt_ceil_log2((uint32_t)(rs->spp > 0 ? rs->spp : 1)));
    k->settings[strlen(k->settings) - 1] = 0; /* the last ';' */
    k->seed = rs->seed;
    k->width = rs->width;
    k->height = rs->height;
    return 0;
}

/* The done flags as ranges "a-b,c-d" (inclusive), malloc'd. */
static char *ranges_format(const unsigned char *done, uint32_t total, uint32_t *count)
{
    size_t cap = 64, len = 0;
    char *s = spt_malloc(cap);
    s[0] = 0;
    *count = 0;
    for (uint32_t i = 0; i < total;) {
        if (!done[i]) {
            i++;
            continue;
        }
        uint32_t j = i;
        while (j + 1 < total && done[j + 1])
            j++;
        *count += j - i + 1;
        if (cap - len < 32) {
            cap *= 2;
            s = spt_realloc(s, cap);
        }
        len += (size_t)snprintf(s + len, cap - len, "%s%u-%u", len ? "," : "", i, j);
        i = j + 1;
    }
    return s;
}

/* Parses ranges into flags (limit entries, all zero first); -1 when malformed or
 * out of order; *end is the largest index + 1. */
static int ranges_parse(const char *s, unsigned char *done, uint32_t limit, uint32_t *count,
                        uint32_t *end)
{
    *count = 0;
    *end = 0;
    const char *p = s;
    long long prev = -1;
    while (*p) {
        char *q;
        errno = 0;
        unsigned long a = strtoul(p, &q, 10);
        if (q == p || *q != '-' || errno)
            return -1;
        p = q + 1;
        unsigned long b = strtoul(p, &q, 10);
        if (q == p || errno || b < a || (long long)a <= prev || b >= (1ul << 24))
            return -1;
        p = q;
        if (*p == ',')
            p++;
        else if (*p)
            return -1;
        for (unsigned long i = a; i <= b; i++)
            if (i < limit)
                done[i] = 1;
        *count += (uint32_t)(b - a + 1);
        *end = (uint32_t)b + 1;
        prev = (long long)b;
    }
    return 0;
}

/* qsort order of ExrChannel pointers: by name. */
static int channel_name_cmp(const void *a, const void *b)
{
    return strcmp((*(const ExrChannel *const *)a)->name, (*(const ExrChannel *const *)b)->name);
}

/* Adds a string and its terminating 0 to h. */
static unsigned long long hash_str(unsigned long long h, const char *s)
{
    return cl_fnv1a(h, s, strlen(s) + 1);
}

/* One step of FNV-1a 64 with a 64-bit word in place of a byte, then an
 * xor-shift: a multiplication carries a bit only upwards, so without it the
 * high half of a word would reach only the high half of the hash. Each step is
 * a bijection of h, so a change of any one word always changes the result. */
#define CKPT_FNV_PRIME 0x100000001b3ull
static inline unsigned long long ckpt_mix(unsigned long long h, unsigned long long w)
{
    h = (h ^ w) * CKPT_FNV_PRIME;
    return h ^ (h >> 29);
}

/* The pixels of a block, hashed channel by channel: the file's channels
 * (separate arrays) are read in runs, and checkpoint_write's interleaved
 * buffers (47 bands a pixel) stay in cache across the block's channels. The
 * whole image channel by channel, or pixel by pixel, takes about 1 s for a
 * 512x512 checkpoint with 47 bands and every AOV (130 channels) in one of the
 * two layouts; blocks take 0.06-0.14 s in both. */
#define CKPT_HASH_BLOCK 512

/* The checksum of a checkpoint (spectrace:checksum, 16 hex digits): FNV-1a 64
 * over the size, the attributes a resume uses (scene_hash, settings,
 * samples_done, spp_done) and the channels' names and types in name order,
 * then ckpt_mix over the exact bits of every value as 32-bit words, two to
 * a 64-bit word (the first in the low half), in blocks of CKPT_HASH_BLOCK
 * pixels, in each block channel by channel in name order. */
static void checkpoint_checksum(int width, int height, const ExrChannel *ch, int nch,
                                const char *scene_hash, const char *settings,
                                const char *ranges, int32_t spp_done, char hex[17])
{
    unsigned char head[16];
    uint32_t words[4] = {(uint32_t)width, (uint32_t)height, (uint32_t)spp_done, (uint32_t)nch};
    for (int i = 0; i < 16; i++)
        head[i] = (unsigned char)(words[i / 4] >> (8 * (i % 4)));
    unsigned long long h = cl_fnv1a(SPT_FNV1A_INIT, head, sizeof head);
    h = hash_str(h, scene_hash);
    h = hash_str(h, settings);
    h = hash_str(h, ranges);
    int m = nch > 0 ? nch : 1;
    const ExrChannel **order = spt_malloc((size_t)m * sizeof *order);
    const uint32_t **data = spt_malloc((size_t)m * sizeof *data);
    size_t *stride = spt_malloc((size_t)m * sizeof *stride);
    for (int c = 0; c < nch; c++)
        order[c] = &ch[c];
    qsort(order, (size_t)nch, sizeof *order, channel_name_cmp);
    for (int c = 0; c < nch; c++) {
        unsigned char type = (unsigned char)order[c]->type;
        h = hash_str(h, order[c]->name);
        h = cl_fnv1a(h, &type, 1);
        /* Float and uint channels both hold 4-byte values. */
        data[c] = order[c]->data;
        stride[c] = order[c]->stride > 0 ? (size_t)order[c]->stride : 1;
    }
    size_t n = (size_t)width * (size_t)height;
    unsigned long long w = 0;
    int half = 0;
    for (size_t i0 = 0; i0 < n; i0 += CKPT_HASH_BLOCK) {
        size_t i1 = n - i0 < CKPT_HASH_BLOCK ? n : i0 + CKPT_HASH_BLOCK;
        for (int c = 0; c < nch; c++)
            for (size_t i = i0; i < i1; i++) {
                unsigned long long v = data[c][i * stride[c]];
                if (half)
                    h = ckpt_mix(h, w | v << 32);
                else
                    w = v;
                half = !half;
            }
    }
    if (half)
        h = ckpt_mix(h, w);
    free(order);
    free(data);
    free(stride);
    snprintf(hex, 17, "%016llx", h);
}

int checkpoint_write(const char *path, const CheckpointKey *k, const Film *film,
                     const unsigned char *done, uint32_t total, SptError *e)
{
    /* The sums of squares count only for the variance layer, which a render
     * refuses when they pass float's range (docs/limits.md); they are kept
     * here as +inf, so a render without that layer checkpoints and resumes at
     * any brightness the scene limits allow. */
    size_t bad = film_nonfinite_except_squares(film);
    if (bad)
        return spt_fail(e, SPT_EXIT_FAILURE,
                        "%s: checkpoint not written: %zu pixel%s of the film came out NaN or "
                        "infinite (an internal error)",
                        path, bad, bad == 1 ? "" : "s");
    size_t n = (size_t)film->width * film->height;
    float *hi = spt_malloc(3 * n * sizeof(float));
    float *lo = spt_malloc(3 * n * sizeof(float));
    float *rgb = spt_malloc(3 * n * sizeof(float));
    uint32_t *cnt = spt_malloc(n * sizeof(uint32_t));
    for (size_t i = 0; i < 3 * n; i++) {
        hi[i] = (float)film->xyz[i];
        lo[i] = (float)(film->xyz[i] - (double)hi[i]);
    }
    for (size_t i = 0; i < n; i++)
        cnt[i] = (uint32_t)film->count[i];
    film_to_linear_srgb(film, rgb);
    ExrChannel *ch = spt_malloc((size_t)(10 + 2 * SPT_AOV_SUMS + 2 * film->bands) * sizeof *ch);
    ExrChannel base[10] = {
        {"sum.X", SPT_EXR_FLOAT, hi + 0, 3},    {"sum.Y", SPT_EXR_FLOAT, hi + 1, 3},
        {"sum.Z", SPT_EXR_FLOAT, hi + 2, 3},    {"sum_lo.X", SPT_EXR_FLOAT, lo + 0, 3},
        {"sum_lo.Y", SPT_EXR_FLOAT, lo + 1, 3}, {"sum_lo.Z", SPT_EXR_FLOAT, lo + 2, 3},
        {"count", SPT_EXR_UINT, cnt, 1},        {"R", SPT_EXR_FLOAT, rgb + 0, 3},
        {"G", SPT_EXR_FLOAT, rgb + 1, 3},       {"B", SPT_EXR_FLOAT, rgb + 2, 3},
    };
    memcpy(ch, base, sizeof base);
    int nch = 10;
    float *ahi = NULL, *alo = NULL;
    char names[2 * SPT_AOV_SUMS][32];
    if (film->aov) {
        ahi = spt_malloc(SPT_AOV_SUMS * n * sizeof(float));
        alo = spt_malloc(SPT_AOV_SUMS * n * sizeof(float));
        for (size_t i = 0; i < SPT_AOV_SUMS * n; i++) {
            ahi[i] = (float)film->aov[i];
            alo[i] = isfinite(ahi[i]) ? (float)(film->aov[i] - (double)ahi[i]) : 0.0f;
        }
        for (int k = 0; k < SPT_AOV_SUMS; k++) {
            snprintf(names[2 * k], sizeof names[0], "aov_sum.%s", aov_sum_names[k]);
            snprintf(names[2 * k + 1], sizeof names[0], "aov_sum_lo.%s", aov_sum_names[k]);
            ch[nch++] = (ExrChannel){names[2 * k], SPT_EXR_FLOAT, ahi + k, SPT_AOV_SUMS};
            ch[nch++] = (ExrChannel){names[2 * k + 1], SPT_EXR_FLOAT, alo + k, SPT_AOV_SUMS};
        }
    }
    /* Spectral band sums: "band_sum.NNN" and "band_sum_lo.NNN" (band NNN). */
    float *shi = NULL, *slo = NULL;
    char (*bnames)[32] = film->bands ? spt_malloc((size_t)(2 * film->bands) * sizeof *bnames) : NULL;
    if (film->bands) {
        size_t nb = (size_t)film->bands * n;
        shi = spt_malloc(nb * sizeof(float));
        slo = spt_malloc(nb * sizeof(float));
        for (size_t i = 0; i < nb; i++) {
            shi[i] = (float)film->spec[i];
            slo[i] = (float)(film->spec[i] - (double)shi[i]);
        }
        for (int b = 0; b < film->bands; b++) {
            snprintf(bnames[2 * b], sizeof bnames[0], "band_sum.%03d", b);
            snprintf(bnames[2 * b + 1], sizeof bnames[0], "band_sum_lo.%03d", b);
            ch[nch++] = (ExrChannel){bnames[2 * b], SPT_EXR_FLOAT, shi + b, film->bands};
            ch[nch++] = (ExrChannel){bnames[2 * b + 1], SPT_EXR_FLOAT, slo + b, film->bands};
        }
    }
    uint32_t ndone;
    char *ranges = ranges_format(done, total, &ndone);
    char seed[16], sum[17];
    snprintf(seed, sizeof seed, "%u", k->seed);
    checkpoint_checksum(film->width, film->height, ch, nch, k->scene_hash, k->settings, ranges,
                        (int32_t)ndone, sum);
    ExrAttr at[] = {
        {"spectrace:checkpoint", SPT_EXR_ATTR_INT, NULL, CKPT_VERSION, 0},
        {"spectrace:checksum", SPT_EXR_ATTR_STRING, sum, 0, 0},
        {"spectrace:scene_hash", SPT_EXR_ATTR_STRING, k->scene_hash, 0, 0},
        {"spectrace:settings", SPT_EXR_ATTR_STRING, k->settings, 0, 0},
        {"spectrace:samples_done", SPT_EXR_ATTR_STRING, ranges, 0, 0},
        {"spectrace:spp_done", SPT_EXR_ATTR_INT, NULL, (int32_t)ndone, 0},
        {"spectrace:spp_target", SPT_EXR_ATTR_INT, NULL, (int32_t)total, 0},
        {"spectrace:seed", SPT_EXR_ATTR_STRING, seed, 0, 0},
    };
    int rc = exr_write_layers(path, film->width, film->height, ch, nch, at,
                              (int)(sizeof at / sizeof at[0]), e);
    free(ahi);
    free(alo);
    free(shi);
    free(slo);
    free(bnames);
    free(ch);
    free(ranges);
    free(hi);
    free(lo);
    free(rgb);
    free(cnt);
    return rc;
}

/* Splits a "k=v;k=v" list (copied into buf) into at most max keys and values. */
static int settings_split(const char *list, char *buf, size_t cap, char **keys, char **vals, int max)
{
    snprintf(buf, cap, "%s", list);
    int n = 0;
    for (char *save = NULL, *t = strtok_r(buf, ";", &save); t && n < max;
         t = strtok_r(NULL, ";", &save)) {
        char *eq = strchr(t, '=');
        keys[n] = t;
        vals[n] = eq ? (*eq = 0, eq + 1) : t + strlen(t);
        n++;
    }
    return n;
}

/* The key entries of the options (src/render/render_options.h): the field's
 * name, the option as typed and its kind. */
enum { OPT_PLAIN, OPT_FLAG, OPT_SWITCH, OPT_SAMPLER, OPT_AOV, OPT_FILE };
#define OPT_KIND_INT OPT_PLAIN
#define OPT_KIND_U32 OPT_PLAIN
#define OPT_KIND_DBL OPT_PLAIN
#define OPT_KIND_FLT OPT_PLAIN
#define OPT_KIND_STR OPT_FILE
#define OPT_KIND_LIST OPT_PLAIN
#define OPT_KIND_TONEMAP OPT_PLAIN
#define OPT_KIND_HELP OPT_PLAIN
#define OPT_KIND_FLAG OPT_FLAG
#define OPT_KIND_SWITCH OPT_SWITCH
#define OPT_KIND_SAMPLER OPT_SAMPLER
#define OPT_KIND_AOV OPT_AOV
static const struct {
    const char *name, *option;
    int kind;
} key_options[] = {
#define OPT_ROW(where, kind, type, name, option, ...) {#name, option, OPT_KIND_##kind},
    SPT_RENDER_OPTIONS(OPT_ROW)
#undef OPT_ROW
};

/* A key entry's value as the user types the option (the names of
 * src/render/render_options.h): "on" rather than "2", "albedo,N" rather than
 * "3"; "not given" for a flag, --aov or file option not given. */
static const char *key_value_text(int kind, const char *v, char *buf, size_t cap)
{
    static const char *const switches[] = SPT_SWITCH_NAMES, *const samplers[] = SPT_SAMPLER_NAMES,
                             *const aovs[] = SPT_AOV_NAMES;
    char *end;
    unsigned long x = strtoul(v, &end, 10);
    int num = *v && !*end;
    if (kind == OPT_FLAG && num)
        return x ? "given" : "not given";
    if (kind == OPT_SWITCH && num && x < sizeof switches / sizeof switches[0])
        return switches[x];
    if (kind == OPT_SAMPLER && num && x < sizeof samplers / sizeof samplers[0])
        return samplers[x];
    if (kind == OPT_FILE && !strcmp(v, "default"))
        return "not given";
    if (kind == OPT_FILE && !strncmp(v, "file-fnv:", 9)) {
        snprintf(buf, cap, "a file of content hash %s", v + 9);
        return buf;
    }
    if (kind == OPT_AOV && num) {
        size_t len = 0;
        buf[0] = 0;
        if (x == 0)
            return "not given";
        if (x == SPT_AOV_ALL)
            return "all";
        for (unsigned k = 0; k < sizeof aovs / sizeof aovs[0] && len < cap; k++)
            if (x & (1ul << k))
                len += (size_t)snprintf(buf + len, cap - len, "%s%s", len ? "," : "", aovs[k]);
        return buf;
    }
    return v;
}

/* "name A here, B in the checkpoint" for every setting that differs; an
 * option's entry as "--option VALUE here, VALUE in the checkpoint" with the
 * values as typed. */
static void settings_diff(const char *mine, const char *theirs, char *out, size_t cap)
{
    char ba[2048], bb[2048], *ka[32], *va[32], *kb[32], *vb[32];
    int na = settings_split(mine, ba, sizeof ba, ka, va, 32);
    int nb = settings_split(theirs, bb, sizeof bb, kb, vb, 32);
    size_t len = 0;
    out[0] = 0;
    for (int pass = 0; pass < 2; pass++) {
        int n1 = pass ? nb : na, n2 = pass ? na : nb;
        char **k1 = pass ? kb : ka, **v1 = pass ? vb : va, **k2 = pass ? ka : kb, **v2 = pass ? va : vb;
        for (int i = 0; i < n1 && len < cap; i++) {
            const char *other = NULL;
            for (int j = 0; j < n2; j++)
                if (!strcmp(k1[i], k2[j]))
                    other = v2[j];
            if (other && (pass || !strcmp(other, v1[i])))
                continue;
            const char *here = pass ? "(none)" : v1[i];
            const char *there = pass ? v1[i] : other ? other : "(none)";
            char name[64], bh[128], bt[128];
            /* The entries that are no option (checkpoint_key). */
            snprintf(name, sizeof name, "%s",
                     !strcmp(k1[i], "kernels")      ? "the renderer's kernel sources"
                     : !strcmp(k1[i], "zsobol_spp") ? "--spp rounded up to a power of two"
                                                    : k1[i]);
            for (size_t o = 0; o < sizeof key_options / sizeof key_options[0]; o++)
                if (!strcmp(k1[i], key_options[o].name)) {
                    snprintf(name, sizeof name, "--%s", key_options[o].option);
                    here = key_value_text(key_options[o].kind, here, bh, sizeof bh);
                    there = key_value_text(key_options[o].kind, there, bt, sizeof bt);
                }
            len += (size_t)snprintf(out + len, cap - len, "%s%s %s here, %s in the checkpoint",
                                    len ? "; " : "", name, here, there);
        }
    }
}

/* The whole-number value of setting `name` in a "k=v;k=v" list; 0 when absent. */
static long settings_long(const char *list, const char *name)
{
    size_t len = strlen(name);
    for (const char *p = list; p && *p;) {
        if (!strncmp(p, name, len) && p[len] == '=')
            return strtol(p + len + 1, NULL, 10);
        p = strchr(p, ';');
        if (p)
            p++;
    }
    return 0;
}

/* The most negative linear sRGB component of the albedo AOV of any reflectance
 * in [0, 1] under D65 (kernels/material/material_eval.h, material_albedo): -0.484
 * for R, from the CIE 1931 functions at its 10 nm steps. A pixel's albedo sum
 * below -0.5 per sample is no render's. */
#define CKPT_ALBEDO_MIN (-0.5)

/* hi + lo of a channel pair at pixel i into *v, or the reason the pair is not
 * what checkpoint_write makes: a value not finite, a negative sum where
 * nonneg, or a lo beyond half a unit in the last place of hi (what rounding the
 * double sum to hi can leave). nonneg 2: a sum of squares, +inf allowed. */
static const char *pair_value(const ExrChannel *hi, const ExrChannel *lo, size_t i, int nonneg,
                              double *v)
{
    float h = ((const float *)hi->data)[i], l = ((const float *)lo->data)[i];
    *v = (double)h + (double)l;
    /* A sum of squares past float's range is written as +inf, low part 0
     * (checkpoint_write); other non-negative sums never are. */
    if (nonneg == 2 && h == INFINITY && l == 0)
        return NULL;
    if (!isfinite(h) || !isfinite(l))
        return "is not finite";
    if (nonneg && (h < 0 || *v < 0))
        return "is negative";
    double ulp = (double)nextafterf(fabsf(h), INFINITY) - (double)fabsf(h);
    if (fabs((double)l) > 0.5 * ulp)
        return "has a low part larger than the rounding of its high part leaves";
    return NULL;
}

int checkpoint_read(const char *path, const CheckpointKey *k, uint32_t spp, Film *film,
                    unsigned char **done, SptError *e)
{
    memset(film, 0, sizeof *film);
    *done = NULL;
    ExrLayers L;
    SptError e2 = {0};
    int rc0 = input_check(path, "checkpoint", e);
    if (rc0)
        return rc0;
    if (exr_read_layers(path, NULL, 0, &L, &e2))
        return spt_fail(e, SPT_EXIT_INPUT, "%s (a damaged, truncated or unreadable checkpoint: "
                        "cannot resume from it)", e2.msg);
    int rc = 0;
    unsigned char *flags = NULL;
    char (*want)[32] = NULL;
    const ExrAttr *ver = exr_layers_attr(&L, "spectrace:checkpoint", SPT_EXR_ATTR_INT);
    const ExrAttr *cs = exr_layers_attr(&L, "spectrace:checksum", SPT_EXR_ATTR_STRING);
    const ExrAttr *sh = exr_layers_attr(&L, "spectrace:scene_hash", SPT_EXR_ATTR_STRING);
    const ExrAttr *set = exr_layers_attr(&L, "spectrace:settings", SPT_EXR_ATTR_STRING);
    const ExrAttr *rg = exr_layers_attr(&L, "spectrace:samples_done", SPT_EXR_ATTR_STRING);
    const ExrAttr *nd = exr_layers_attr(&L, "spectrace:spp_done", SPT_EXR_ATTR_INT);
    if (!ver) {
        rc = spt_fail(e, SPT_EXIT_INPUT,
                      "%s: not a spectrace checkpoint (an EXR without the spectrace:checkpoint "
                      "attribute; an image output cannot be resumed)", path);
        goto out;
    }
    if (ver->i == 1) {
        rc = spt_fail(e, SPT_EXIT_INPUT,
                      "%s: a checkpoint of an earlier spectrace (format 1, without a checksum of "
                      "its data, so edits cannot be told from a render): render it again",
                      path);
        goto out;
    }
    if (ver->i != CKPT_VERSION) {
        rc = spt_fail(e, SPT_EXIT_INPUT, "%s: checkpoint format version %d, this build reads %d",
                      path, ver->i, CKPT_VERSION);
        goto out;
    }
    if (!cs || !sh || !set || !rg || !nd) {
        rc = spt_fail(e, SPT_EXIT_INPUT, "%s: damaged checkpoint: spectrace:%s attribute missing", path,
                      !cs ? "checksum" : !sh ? "scene_hash" : !set ? "settings" : !rg ? "samples_done"
                                                                                 : "spp_done");
        goto out;
    }
    if (strcmp(sh->s, k->scene_hash)) {
        rc = spt_fail(e, SPT_EXIT_INPUT,
                      "%s: checkpoint of another scene: its scene file hash is %s, this scene's is %s",
                      path, sh->s, k->scene_hash);
        goto out;
    }
    if (strcmp(set->s, k->settings)) {
        char diff[900];
        settings_diff(k->settings, set->s, diff, sizeof diff);
        rc = spt_fail(e, SPT_EXIT_INPUT, "%s: settings differ from the checkpoint's: %s", path, diff);
        goto out;
    }
    if (L.width != k->width || L.height != k->height) {
        rc = spt_fail(e, SPT_EXIT_INPUT, "%s: damaged checkpoint: %dx%d pixels, its settings say %dx%d",
                      path, L.width, L.height, k->width, k->height);
        goto out;
    }
    flags = spt_calloc(spp ? spp : 1, 1);
    uint32_t ndone, end;
    if (ranges_parse(rg->s, flags, spp, &ndone, &end) || (int32_t)ndone != nd->i || ndone == 0) {
        rc = spt_fail(e, SPT_EXIT_INPUT, "%s: damaged checkpoint: spectrace:samples_done '%.60s' is "
                      "malformed or disagrees with spectrace:spp_done %d", path, rg->s, nd->i);
        goto out;
    }
    if (end > spp) {
        rc = spt_fail(e, SPT_EXIT_USAGE,
                      "%s: the checkpoint holds samples up to index %u; --spp %u must be at least %u",
                      path, end - 1, spp, end);
        goto out;
    }
    /* Exactly the channels checkpoint_write makes for these settings (their
     * values are in the key, compared above): the film's, the AOV sums with
     * --aov or --denoise, two per band with --spectral. */
    int aov = settings_long(k->settings, "aov") != 0 || settings_long(k->settings, "denoise") != 0;
    long bands = settings_long(k->settings, "spectral");
    if (bands < 0 || bands > 470)
        bands = 0;
    static const char *const base[10] = {"sum.X",    "sum.Y",    "sum.Z", "sum_lo.X", "sum_lo.Y",
                                         "sum_lo.Z", "count",    "R",     "G",        "B"};
    int nwant = 10 + (aov ? 2 * SPT_AOV_SUMS : 0) + 2 * (int)bands;
    want = spt_malloc((size_t)nwant * sizeof *want);
    const ExrChannel **ch = spt_malloc((size_t)nwant * sizeof *ch);
    for (int i = 0; i < 10; i++)
        snprintf(want[i], sizeof want[i], "%s", base[i]);
    for (int j = 0; aov && j < SPT_AOV_SUMS; j++) {
        snprintf(want[10 + 2 * j], sizeof want[0], "aov_sum.%s", aov_sum_names[j]);
        snprintf(want[11 + 2 * j], sizeof want[0], "aov_sum_lo.%s", aov_sum_names[j]);
    }
    int b0 = 10 + (aov ? 2 * SPT_AOV_SUMS : 0);
    for (int b = 0; b < (int)bands; b++) {
        snprintf(want[b0 + 2 * b], sizeof want[0], "band_sum.%03d", b);
        snprintf(want[b0 + 2 * b + 1], sizeof want[0], "band_sum_lo.%03d", b);
    }
    for (int i = 0; i < nwant; i++) {
        ch[i] = exr_layers_channel(&L, want[i]);
        if (!ch[i] || ch[i]->type != (i == 6 ? SPT_EXR_UINT : SPT_EXR_FLOAT)) {
            const char *why = i >= b0  ? "the settings' --spectral bands need it"
                              : i >= 10 ? "the settings' --aov or --denoise need the AOV sums"
                                        : "every checkpoint has it";
            rc = spt_fail(e, SPT_EXIT_INPUT,
                          "%s: damaged checkpoint: channel %s %s (%s)", path, want[i],
                          ch[i] ? "of the wrong type" : "missing", why);
            free(ch);
            goto out;
        }
    }
    if (L.channel_count != nwant) {
        const char *extra = "?";
        for (int c = 0; c < L.channel_count && !strcmp(extra, "?"); c++) {
            int known = 0;
            for (int i = 0; i < nwant && !known; i++)
                known = !strcmp(L.channels[c].name, want[i]);
            if (!known)
                extra = L.channels[c].name;
        }
        rc = spt_fail(e, SPT_EXIT_INPUT,
                      "%s: damaged checkpoint: channel %s, which a checkpoint of its settings "
                      "does not have", path, extra);
        free(ch);
        goto out;
    }
    /* The values: each pair what checkpoint_write makes, no negative sum of
     * radiance (the colour matching functions and the bands' weights are never
     * negative) or of squares, no albedo below any reflectance's, no more
     * samples than were done, and no AOV or band sums in a pixel without
     * samples (those count kept samples only; the XYZ sums also take the light
     * paths' splats, docs/outputs.md, "Checkpoints"). In blocks of pixels,
     * channel by channel, as checkpoint_checksum reads them. */
    size_t n = (size_t)L.width * L.height;
    film_init_full(film, L.width, L.height, aov, (int)bands);
    const uint32_t *cnt = ch[6]->data;
    const char *bad = NULL, *bad_ch = NULL;
    double bad_v = 0, v = 0;
    size_t bad_i = 0;
    for (size_t i0 = 0; i0 < n && !bad; i0 += CKPT_HASH_BLOCK) {
        size_t i1 = n - i0 < CKPT_HASH_BLOCK ? n : i0 + CKPT_HASH_BLOCK, i = i0;
        for (int j = 0; j < 3 && !bad; j++)
            for (i = i0, bad_ch = want[j]; i < i1 && !bad; i++) {
                bad = pair_value(ch[j], ch[3 + j], i, 1, &v);
                film->xyz[3 * i + j] = v;
            }
        for (int j = 0; aov && j < SPT_AOV_SUMS && !bad; j++)
            for (i = i0, bad_ch = want[10 + 2 * j]; i < i1 && !bad; i++) {
                bad = pair_value(ch[10 + 2 * j], ch[11 + 2 * j], i, j >= SPT_AOV_S_SQ ? 2 : 0, &v);
                if (!bad && j < SPT_AOV_S_ALBEDO + 3 && v < CKPT_ALBEDO_MIN * (double)cnt[i])
                    bad = "is below what any reflectance gives";
                film->aov[SPT_AOV_SUMS * i + (size_t)j] = v;
            }
        for (int b = 0; b < (int)bands && !bad; b++)
            for (i = i0, bad_ch = want[b0 + 2 * b]; i < i1 && !bad; i++) {
                bad = pair_value(ch[b0 + 2 * b], ch[b0 + 2 * b + 1], i, 1, &v);
                film->spec[i * (size_t)bands + (size_t)b] = v;
            }
        bad_v = v;
        bad_i = i - 1; /* the loops stop one past the bad pixel */
        for (i = i0; i < i1 && !bad; i++) {
            int nonzero = 0; /* an AOV or band sum is not 0 */
            for (int j = 0; aov && j < SPT_AOV_SUMS; j++)
                nonzero |= film->aov[SPT_AOV_SUMS * i + (size_t)j] != 0;
            for (int b = 0; b < (int)bands; b++)
                nonzero |= film->spec[i * (size_t)bands + (size_t)b] != 0;
            bad_ch = "count";
            bad_i = i;
            bad_v = cnt[i];
            if (cnt[i] > ndone)
                bad = "is more than the samples done";
            else if (cnt[i] == 0 && nonzero)
                bad = "is 0 while the pixel's AOV or band sums are not";
            film->count[i] = cnt[i];
        }
    }
    if (bad) {
        char value[64] = "";
        if (strcmp(bad_ch, "count") || cnt[bad_i])
            snprintf(value, sizeof value, " (%.9g)", bad_v);
        rc = spt_fail(e, SPT_EXIT_INPUT, "%s: damaged checkpoint: pixel (%zu, %zu): %s %s%s, with "
                      "%u samples per pixel done", path, bad_i % (size_t)L.width,
                      bad_i / (size_t)L.width, bad_ch, bad, value, ndone);
        free(ch);
        goto out;
    }
    free(ch);
    /* Last, the checksum: what the checks above cannot see, such as a count or
     * a sum changed to another plausible value. */
    char sum[17];
    checkpoint_checksum(L.width, L.height, L.channels, L.channel_count, sh->s, set->s, rg->s,
                        nd->i, sum);
    if (strcmp(sum, cs->s)) {
        rc = spt_fail(e, SPT_EXIT_INPUT,
                      "%s: damaged checkpoint: its data does not match its checksum "
                      "(spectrace:checksum %.16s, the data gives %s): changed after it was written",
                      path, cs->s, sum);
        goto out;
    }
    *done = flags;
    flags = NULL;
out:
    if (rc)
        film_free(film);
    free(flags);
    free(want);
    exr_layers_free(&L);
    return rc;
}

void checkpoint_writer_init(CheckpointWriter *w, const char *path, double every,
                            const CheckpointKey *k, const unsigned char *done_in,
                            uint32_t total)
{
    memset(w, 0, sizeof *w);
    w->path = path;
    w->every = every;
    w->last = spt_now();
    if (k)
        w->key = *k;
    w->total = total;
    if (done_in) {
        w->done = spt_malloc(total ? total : 1);
        memcpy(w->done, done_in, total);
    }
}

void checkpoint_on_chunk(void *ctx, const Film *film, const unsigned char *done, uint32_t total)
{
    CheckpointWriter *w = ctx;
    if (!w->done || w->total != total) {
        free(w->done);
        w->done = spt_malloc(total ? total : 1);
        w->total = total;
    }
    memcpy(w->done, done, total);
    if (!w->path || spt_now() - w->last < w->every)
        return;
    SptError e = {0};
    if (checkpoint_write(w->path, &w->key, film, w->done, w->total, &e)) {
        if (!w->warned)
            spt_warn("checkpoint not written (rendering goes on): %s", e.msg);
        w->warned = 1;
    } else {
        w->writes++;
    }
    w->last = spt_now();
}

int checkpoint_writer_finish(CheckpointWriter *w, const Film *film, SptError *e)
{
    if (!w->path || !w->done)
        return 0;
    int rc = checkpoint_write(w->path, &w->key, film, w->done, w->total, e);
    if (!rc)
        w->writes++;
    return rc;
}

void checkpoint_writer_free(CheckpointWriter *w)
{
    free(w->done);
    w->done = NULL;
}

int checkpoint_path_check(const char *path, SptError *e)
{
    size_t n = strlen(path);
    if (n < 4 || strcasecmp(path + n - 4, ".exr"))
        return spt_fail(e, SPT_EXIT_USAGE, "%s: a checkpoint is an EXR file: its name must end in .exr",
                        path);
    return image_output_check(path, e);
}

int checkpoint_run_begin(CheckpointRun *run, const char *scene_path, const char *path,
                         double every, const char *resume, RenderSettings *rs, Film *film,
                         SptError *e)
{
    memset(run, 0, sizeof *run);
    const char *out = path ? path : resume;
    uint32_t total = rs->spp > 0 ? (uint32_t)rs->spp : 0;
    CheckpointKey key;
    int rc;
    if (!out) {
        film_init_full(film, rs->width, rs->height, render_keeps_aov(rs), rs->spectral);
        checkpoint_writer_init(&run->writer, NULL, 0, NULL, NULL, total);
        return 0;
    }
    if ((rc = checkpoint_key(&key, scene_path, rs, e)))
        return rc;
    if (resume) {
        if ((rc = checkpoint_read(resume, &key, total, film, &run->done_in, e)))
            return rc;
        for (uint32_t i = 0; i < total; i++)
            run->resumed += run->done_in[i];
        rs->done_in = run->done_in;
    } else {
        film_init_full(film, rs->width, rs->height, render_keeps_aov(rs), rs->spectral);
    }
    checkpoint_writer_init(&run->writer, out, every, &key, run->done_in, total);
    rs->on_chunk = checkpoint_on_chunk;
    rs->on_chunk_ctx = &run->writer;
    return 0;
}

int checkpoint_run_end(CheckpointRun *run, const Film *film, int quiet, SptError *e)
{
    int rc = checkpoint_writer_finish(&run->writer, film, e);
    if (!rc)
        checkpoint_run_report(run, quiet);
    return rc;
}

void checkpoint_run_report(const CheckpointRun *run, int quiet)
{
    if (run->writer.path && run->writer.done && !quiet) {
        uint32_t n = 0;
        for (uint32_t i = 0; i < run->writer.total; i++)
            n += run->writer.done[i];
        fprintf(stderr, "wrote checkpoint %s (%u spp; continue with --resume %s)\n",
                run->writer.path, n, run->writer.path);
    }
}

void checkpoint_run_free(CheckpointRun *run)
{
    checkpoint_writer_free(&run->writer);
    free(run->done_in);
    run->done_in = NULL;
}
