/* The command line of `spectrace render` (src/cli/render_args.h), generated from
 * the option list of src/render/render_options.h. */
#include "api/render_args.h"

#include <float.h>
#include <getopt.h>
#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "io/image_out.h"
#include "render/film.h"

enum { KIND_LIST, KIND_INT, KIND_U32, KIND_DBL, KIND_FLT, KIND_STR, KIND_FLAG, KIND_TONEMAP,
       KIND_SWITCH, KIND_SAMPLER, KIND_AOV, KIND_HELP };

/* One row of the list, with where its value goes in RenderArgs. */
typedef struct OptRow {
    int kind;
    const char *option;
    int short_name;
    const char *metavar;
    double lo, hi;
    unsigned flags;
    const char *expect;
    const char *help;
    size_t offset;
} OptRow;

#define FIELD_OFFSET(where, name) \
    SPT_OPT_IF_RS_##where(offsetof(RenderArgs, rs.name)) SPT_OPT_IF_CLI_##where(offsetof(RenderArgs, name))
static const OptRow rows[SPT_ARG_COUNT] = {
#define ROW(where, kind, type, name, option, short_name, metavar, def, lo, hi, flags, expect, help) \
    {KIND_##kind, option, short_name, metavar, lo, hi, flags, expect, help, FIELD_OFFSET(where, name)},
    SPT_RENDER_OPTIONS(ROW)
#undef ROW
};

static const char usage_head[] =
    "usage: spectrace render SCENE [options]\n"
    "\n"
    "Renders a glTF 2.0 scene (.gltf or .glb) with spectral path tracing.\n"
    "\n";

static const char usage_tail[] =
    "\n"
    "Ctrl-C (SIGINT), SIGTERM or SIGHUP stops after the current chunk and writes the\n"
    "image of the samples done so far (and the checkpoint, with --checkpoint); a\n"
    "chunk that takes long (one sample of a large image) is dropped at once instead,\n"
    "and a second signal stops at once, dropping the chunk in progress.\n";

/* The help column starts at column 25; an option too long for its column is
 * followed by two spaces. */
#define HELP_COLUMN 25

void render_args_usage(FILE *f)
{
    fputs(usage_head, f);
    for (int i = 0; i < SPT_ARG_COUNT; i++) {
        const OptRow *r = &rows[i];
        char left[96];
        if (r->short_name)
            snprintf(left, sizeof left, "  -%c, --%s%s%s", r->short_name, r->option,
                     r->metavar[0] ? " " : "", r->metavar);
        else
            snprintf(left, sizeof left, "      --%s%s%s", r->option, r->metavar[0] ? " " : "",
                     r->metavar);
        int len = (int)strlen(left);
        fprintf(f, "%s%*s", left, len < HELP_COLUMN ? HELP_COLUMN - len : 2, "");
        for (const char *h = r->help; *h;) {
            const char *nl = strchr(h, '\n');
            int n = nl ? (int)(nl - h) : (int)strlen(h);
            fprintf(f, "%.*s\n", n, h);
            if (!nl)
                break;
            h = nl + 1;
            fprintf(f, "%*s", HELP_COLUMN, "");
        }
    }
    fputs(usage_tail, f);
}

/* Parses a whole number in [lo, hi]; 0 on success. */
static int parse_long(const char *s, long lo, long hi, long *out)
{
    char *end;
    long v = strtol(s, &end, 10);
    if (!*s || *end || v < lo || v > hi)
        return -1;
    *out = v;
    return 0;
}

/* Parses a number (not NaN); 0 on success. */
static int parse_double(const char *s, double *out)
{
    char *end;
    double v = strtod(s, &end);
    if (!*s || *end || !(v == v))
        return -1;
    *out = v;
    return 0;
}

/* Stores optarg into row r's field of a; SPT_EXIT_USAGE (with the row's error
 * in e) when it is not a valid value. */
static int store(RenderArgs *a, const OptRow *r, const char *arg, SptError *e)
{
    void *field = (char *)a + r->offset;
    int ok = 1;
    switch (r->kind) {
    case KIND_LIST: {
        int *count = (int *)((char *)field + sizeof(const char *[SPT_MAX_OUTPUTS]));
        if (*count == SPT_MAX_OUTPUTS)
            return spt_fail(e, SPT_EXIT_USAGE, "render: too many outputs (at most %d)",
                            SPT_MAX_OUTPUTS);
        ((const char **)field)[(*count)++] = arg;
        break;
    }
    case KIND_INT:
    case KIND_U32: {
        long v;
        ok = !parse_long(arg, (long)r->lo, (long)r->hi, &v) &&
             !((r->flags & SPT_OPT_NOT_ZERO) && v == 0);
        if (ok && r->kind == KIND_INT)
            *(int *)field = (int)v;
        else if (ok)
            *(uint32_t *)field = (uint32_t)v;
        break;
    }
    case KIND_DBL:
    case KIND_FLT: {
        double v;
        ok = !parse_double(arg, &v) && !((r->flags & SPT_OPT_FINITE) && !isfinite(v)) &&
             !((r->flags & SPT_OPT_POSITIVE) && !(v > 0)) && !(v < r->lo || v > r->hi);
        if (ok && r->kind == KIND_DBL) {
            *(double *)field = v;
        } else if (ok && isfinite(v) && (fabs(v) > FLT_MAX || (v != 0 && fabs(v) < FLT_MIN))) {
            /* The value goes to the kernels as a 32-bit float: 1e-46 would become
             * 0 (for --light-paths, the default) and 1e39 infinity. Values below
             * FLT_MIN are refused too, since GPUs may flush such denormals to 0. */
            return spt_fail(e, SPT_EXIT_USAGE,
                            "render: --%s '%s': %s a 32-bit float can hold (%g to %g)", r->option,
                            arg, fabs(v) > FLT_MAX ? "larger than" : "closer to 0 than",
                            (double)FLT_MIN, (double)FLT_MAX);
        } else if (ok) {
            *(float *)field = (float)v;
        }
        break;
    }
    case KIND_STR:
        *(const char **)field = arg;
        break;
    case KIND_FLAG:
    case KIND_HELP:
        *(int *)field = 1;
        break;
    case KIND_TONEMAP:
        ok = !image_tonemap_parse(arg, (int *)field);
        break;
    case KIND_SWITCH: {
        /* Option values are case-insensitive throughout (README.md, "Rendering"). */
        static const char *const names[] = SPT_SWITCH_NAMES; /* by value */
        ok = 0;
        for (int v = 0; v < (int)(sizeof names / sizeof names[0]) && !ok; v++)
            if (!strcasecmp(arg, names[v])) {
                *(int *)field = v;
                ok = 1;
            }
        break;
    }
    case KIND_SAMPLER:
        ok = !render_sampler_parse(arg, (uint32_t *)field);
        break;
    case KIND_AOV:
        ok = !film_aov_parse(arg, (unsigned *)field);
        break;
    }
    if (!ok)
        return spt_fail(e, SPT_EXIT_USAGE, "render: --%s '%s': %s", r->option, arg, r->expect);
    return SPT_EXIT_OK;
}

/* --frames "A:B" or "A:B:STEP": whole numbers 0 <= A <= B <= SPT_FRAME_MAX and
 * STEP >= 1, nothing else. Returns 0, or -1 for any other text. */
#define SPT_FRAME_MAX 9999999L
static int parse_frames(const char *text, long *first, long *last, long *step)
{
    long v[3] = {0, 0, 1};
    int n = 0;
    const char *p = text;
    for (;;) {
        if (*p < '0' || *p > '9' || n == 3)
            return -1;
        char *end;
        v[n++] = strtol(p, &end, 10);
        if (v[n - 1] > SPT_FRAME_MAX)
            return -1;
        if (*end == 0)
            break;
        if (*end != ':')
            return -1;
        p = end + 1;
    }
    if (n < 2 || v[0] > v[1] || v[2] < 1)
        return -1;
    *first = v[0];
    *last = v[1];
    *step = v[2];
    return 0;
}

/* Every option at its default. */
void render_args_defaults(RenderArgs *a)
{
    memset(a, 0, sizeof *a);
#define DEF_LIST(f, def)
#define DEF_STR(f, def)
#define DEF_INT(f, def) f = (def);
#define DEF_U32(f, def) f = (def);
#define DEF_DBL(f, def) f = (def);
#define DEF_FLT(f, def) f = (def);
#define DEF_FLAG(f, def) f = (def);
#define DEF_TONEMAP(f, def) f = (def);
#define DEF_SWITCH(f, def) f = (def);
#define DEF_SAMPLER(f, def) f = (def);
#define DEF_AOV(f, def) f = (def);
#define DEF_HELP(f, def) f = (def);
#define DEFAULT(where, kind, type, name, option, short_name, metavar, def, ...) \
    DEF_##kind(SPT_OPT_IF_RS_##where(a->rs.name) SPT_OPT_IF_CLI_##where(a->name), def)
    SPT_RENDER_OPTIONS(DEFAULT)
#undef DEFAULT
}

int render_args_parse(RenderArgs *a, int argc, char **argv)
{
    render_args_defaults(a);
    struct option opts[SPT_ARG_COUNT + 1];
    char shorts[2 * SPT_ARG_COUNT + 2];
    int ns = 0;
    shorts[ns++] = ':'; /* getopt reports nothing: one error line of ours instead */
    for (int i = 0; i < SPT_ARG_COUNT; i++) {
        int arg = rows[i].kind != KIND_FLAG && rows[i].kind != KIND_HELP;
        opts[i].name = rows[i].option;
        opts[i].has_arg = arg ? required_argument : no_argument;
        opts[i].flag = NULL;
        opts[i].val = rows[i].short_name ? rows[i].short_name : 256 + i;
        if (rows[i].short_name) {
            shorts[ns++] = (char)rows[i].short_name;
            if (arg)
                shorts[ns++] = ':';
        }
    }
    memset(&opts[SPT_ARG_COUNT], 0, sizeof opts[SPT_ARG_COUNT]);
    shorts[ns] = 0;
    int c;
    optind = 0; /* glibc: a full reset (1 keeps the place inside a group of short options) */
    opterr = 0;
    while ((c = getopt_long(argc, argv, shorts, opts, NULL)) != -1) {
        if (c == '?' || c == ':') {
            const char *arg = optind - 1 < argc ? argv[optind - 1] : "";
            char shortopt[3] = {'-', (char)optopt, 0};
            /* A short option inside a group names only its letter. */
            const char *name = optopt && strncmp(arg, "--", 2) ? shortopt : arg;
            if (c == ':')
                spt_error("render: option '%s' needs a value (try: spectrace render --help)", name);
            else
                spt_error("render: unknown option '%s' (try: spectrace render --help)", name);
            return SPT_EXIT_USAGE;
        }
        int row = -1;
        if (c >= 256 && c < 256 + SPT_ARG_COUNT)
            row = c - 256;
        for (int i = 0; i < SPT_ARG_COUNT && row < 0; i++)
            if (rows[i].short_name && rows[i].short_name == c)
                row = i;
        if (row < 0) {
            render_args_usage(stderr);
            return SPT_EXIT_USAGE;
        }
        SptError e = {0};
        int rc = store(a, &rows[row], optarg, &e);
        if (rc)
            return spt_report(&e);
        a->given[row] = 1;
        if (rows[row].kind == KIND_HELP) {
            render_args_usage(stdout);
            return SPT_EXIT_OK;
        }
    }
    if (optind != argc - 1) {
        spt_error("render: expected exactly one SCENE (try: spectrace render --help)");
        return SPT_EXIT_USAGE;
    }
    a->scene = argv[optind];
    /* --at is kept as typed (NULL, a RenderSettings' zero, is the rest pose);
     * its value is checked here. */
    double at;
    if (a->rs.at && (parse_double(a->rs.at, &at) || !isfinite(at))) {
        spt_error("render: --at '%s': %s", a->rs.at, rows[SPT_ARG_at].expect);
        return SPT_EXIT_USAGE;
    }
    if (a->frames && parse_frames(a->frames, &a->frame_first, &a->frame_last, &a->frame_step)) {
        spt_error("render: --frames '%s': %s", a->frames, rows[SPT_ARG_frames].expect);
        return SPT_EXIT_USAGE;
    }
    if (a->frames && a->rs.at) {
        spt_error("render: --frames poses each frame at its own time; it cannot be combined with "
                  "--at");
        return SPT_EXIT_USAGE;
    }
    if (a->given[SPT_ARG_time_limit] && !a->given[SPT_ARG_spp])
        a->rs.spp = 1 << 24;
    return SPT_EXIT_OK;
}

int render_args_find(const char *option)
{
    for (int i = 0; i < SPT_ARG_COUNT; i++)
        if (!strcmp(rows[i].option, option))
            return i;
    return -1;
}

int render_args_set(RenderArgs *a, int i, const char *value, SptError *e)
{
    const OptRow *r = &rows[i];
    if (r->kind == KIND_FLAG || r->kind == KIND_HELP) {
        /* A flag takes no value on the command line; here it is set or cleared. */
        static const char *const on[] = {"1", "on", "true", "yes"}, *const off[] = {"0", "off", "false", "no"};
        for (int k = 0; k < 4; k++)
            if (!strcasecmp(value, on[k]) || !strcasecmp(value, off[k])) {
                *(int *)((char *)a + r->offset) = !strcasecmp(value, on[k]);
                a->given[i] = 1;
                return SPT_EXIT_OK;
            }
        return spt_fail(e, SPT_EXIT_USAGE, "render: --%s '%s': expected 1 or 0 (on or off)",
                        r->option, value);
    }
    int rc = store(a, r, value, e);
    if (!rc)
        a->given[i] = 1;
    return rc;
}

const char *render_args_option_name(int i)
{
    return rows[i].option;
}

const char *render_args_option_help(int i)
{
    return rows[i].help;
}

const char *render_args_option_kind(int i)
{
    static const char *const kinds[] = {"list",   "int",    "int",     "double", "double", "string",
                                        "flag",   "choice", "choice",  "choice", "list",   "flag"};
    return kinds[rows[i].kind];
}

/* The names of a choice option's values, by value. */
static const char *choice_name(int kind, int v)
{
    static const char *const switches[] = SPT_SWITCH_NAMES, *const samplers[] = SPT_SAMPLER_NAMES;
    static const char *const tonemaps[] = {"none", "neutral"};
    const char *const *names = kind == KIND_SWITCH ? switches : kind == KIND_SAMPLER ? samplers : tonemaps;
    int n = kind == KIND_SWITCH ? 3 : kind == KIND_SAMPLER ? 3 : 2;
    return v >= 0 && v < n ? names[v] : "?";
}

void render_args_format(const RenderArgs *a, int i, char *out, size_t n)
{
    const OptRow *r = &rows[i];
    const void *field = (const char *)a + r->offset;
    out[0] = 0;
    switch (r->kind) {
    case KIND_LIST: {
        int count = *(const int *)((const char *)field + sizeof(const char *[SPT_MAX_OUTPUTS]));
        size_t len = 0;
        for (int k = 0; k < count && len < n; k++)
            len += (size_t)snprintf(out + len, n - len, "%s%s", k ? "," : "", ((const char *const *)field)[k]);
        break;
    }
    case KIND_INT:
    case KIND_FLAG:
    case KIND_HELP:
        snprintf(out, n, "%d", *(const int *)field);
        break;
    case KIND_U32:
        snprintf(out, n, "%u", (unsigned)*(const uint32_t *)field);
        break;
    case KIND_DBL:
        snprintf(out, n, "%.17g", *(const double *)field);
        break;
    case KIND_FLT:
        snprintf(out, n, "%.9g", (double)*(const float *)field);
        break;
    case KIND_STR:
        snprintf(out, n, "%s", *(const char *const *)field ? *(const char *const *)field : "");
        break;
    case KIND_TONEMAP:
    case KIND_SWITCH:
        snprintf(out, n, "%s", choice_name(r->kind, *(const int *)field));
        break;
    case KIND_SAMPLER:
        snprintf(out, n, "%s", choice_name(r->kind, (int)*(const uint32_t *)field));
        break;
    case KIND_AOV: {
        static const char *const aovs[] = SPT_AOV_NAMES;
        unsigned mask = *(const unsigned *)field;
        size_t len = 0;
        for (int b = 0; b < (int)(sizeof aovs / sizeof aovs[0]) && len < n; b++)
            if (mask & (1u << b))
                len += (size_t)snprintf(out + len, n - len, "%s%s", len ? "," : "", aovs[b]);
        break;
    }
    }
}
