/* The command line of `spectrace render`: its options, parsed and checked from
 * the list of src/render/render_options.h, and its usage text. */
#ifndef SPT_RENDER_ARGS_H
#define SPT_RENDER_ARGS_H

#include <stdio.h>

#include "render/render.h"
#include "render/render_options.h"

#define SPT_MAX_OUTPUTS 16

/* The fields of the CLI rows (a LIST row is an array and its count). */
#define SPT_ARGS_FIELD_LIST(type, name) type name[SPT_MAX_OUTPUTS]; int name##_count;
#define SPT_ARGS_FIELD_INT(type, name) type name;
#define SPT_ARGS_FIELD_U32(type, name) type name;
#define SPT_ARGS_FIELD_DBL(type, name) type name;
#define SPT_ARGS_FIELD_FLT(type, name) type name;
#define SPT_ARGS_FIELD_STR(type, name) type name;
#define SPT_ARGS_FIELD_FLAG(type, name) type name;
#define SPT_ARGS_FIELD_TONEMAP(type, name) type name;
#define SPT_ARGS_FIELD_SWITCH(type, name) type name;
#define SPT_ARGS_FIELD_AOV(type, name) type name;
#define SPT_ARGS_FIELD_HELP(type, name) type name;
#define SPT_ARGS_CLI_FIELD(where, kind, type, name, ...) \
    SPT_OPT_IF_CLI_##where(SPT_ARGS_FIELD_##kind(type, name))

/* One option of the list, by its position. */
enum {
#define SPT_ARGS_ID(where, kind, type, name, ...) SPT_ARG_##name,
    SPT_RENDER_OPTIONS(SPT_ARGS_ID)
#undef SPT_ARGS_ID
    SPT_ARG_COUNT
};

typedef struct RenderArgs {
    RenderSettings rs;              /* the RS rows (the rest of rs zero) */
    SPT_RENDER_OPTIONS(SPT_ARGS_CLI_FIELD)
    const char *scene;              /* SCENE */
    long frame_first, frame_last, frame_step; /* --frames A:B[:STEP]; step 0: no --frames */
    unsigned char given[SPT_ARG_COUNT]; /* per option: given on the command line */
} RenderArgs;

/* Parses argv (argv[0] is "render") into a: every option at its default, then
 * what the command line gives. A bad value, an unknown option or not exactly
 * one SCENE prints one error (or getopt's and the usage text) and returns
 * SPT_EXIT_USAGE; --help prints the usage text to stdout, sets a->help and
 * returns SPT_EXIT_OK. --time without --spp sets spp to its largest value. */
int render_args_parse(RenderArgs *a, int argc, char **argv);

/* The usage text of `spectrace render`. */
void render_args_usage(FILE *f);

/* Every option at its default: the state render_args_parse starts from. */
void render_args_defaults(RenderArgs *a);

/* The options one by one, for the library's settings (src/api/spectrace.h):
 * the position of the option named option (as on the command line, without
 * "--"), or -1; option i set from value as the command line parses it (a flag
 * takes 1/0, on/off, true/false, yes/no; a list value is appended); value is
 * borrowed. Returns 0, or SPT_EXIT_USAGE with the command line's message in e. */
int render_args_find(const char *option);
int render_args_set(RenderArgs *a, int i, const char *value, SptError *e);
/* Option i's name, help text, kind ("int", "double", "string", "flag",
 * "choice" or "list") and value as text (a choice by its name, a list comma
 * separated) into out (n bytes). */
const char *render_args_option_name(int i);
const char *render_args_option_help(int i);
const char *render_args_option_kind(int i);
void render_args_format(const RenderArgs *a, int i, char *out, size_t n);

#endif
