/* The options of `spectrace render`, declared once. Every other place that needs
 * them is generated from this list:
 *   - the fields of RenderSettings (src/render/render.h, rows marked RS) and of
 *     the command line's RenderArgs (src/api/render_args.h, rows marked CLI);
 *   - the option parsing and its error messages, and the usage text
 *     (src/api/render_args.c);
 *   - what MPI rank 0 sends to the other ranks (src/mpi/mpi_main.c, rows with
 *     SPT_OPT_MPI);
 *   - the checkpoint's settings key (src/render/checkpoint.c, rows with
 *     SPT_OPT_IMAGE: a resumed render must use the same values).
 * Adding an option is one row here and the code that uses its value; a row that
 * changes the image must carry SPT_OPT_IMAGE (tests/test_options.c checks that
 * each such row changes the checkpoint key).
 *
 * X(where, kind, type, name, option, short, metavar, default, lo, hi, flags,
 *   expect, help)
 *   where    RS: a field of RenderSettings; SKY: of the Sky the command line
 *            builds (src/scene/sky.h), which RenderSettings points to; CLI: of
 *            the command line only (RenderArgs holds the SKY and CLI rows)
 *   kind     INT, U32 (whole numbers in [lo, hi]), DBL, FLT (numbers in [lo, hi],
 *            parsed as double), STR, FLAG, LIST (repeatable string), TONEMAP,
 *            SWITCH (auto, off, on: SPT_SWITCH_*), SAMPLER (sobol, zsobol or
 *            independent: SPT_SAMPLER_*), AOV (a list of AOV layers into a
 *            mask: src/render/film.h), HELP
 *   type     the field's C type
 *   default  the value when the option is not given
 *   flags    SPT_OPT_* below
 *   expect   the error text for a bad value ("render: --NAME 'VALUE': EXPECT")
 *   help     the usage text; "\n" starts a continuation line */
#ifndef SPT_RENDER_OPTIONS_H
#define SPT_RENDER_OPTIONS_H

#include <math.h>

#define SPT_OPT_IMAGE 1u    /* changes what a sample computes: in the checkpoint key */
#define SPT_OPT_MPI 2u      /* sent to the other MPI ranks */
#define SPT_OPT_NOT_ZERO 4u /* INT: 0 is refused */
#define SPT_OPT_POSITIVE 8u /* DBL/FLT: must be > 0 */
#define SPT_OPT_FINITE 16u  /* DBL/FLT: must be finite */

/* Options of kind SWITCH (--caustics, --adaptive): auto, off or on. Auto is
 * 0, so a RenderSettings of zeros has the default. */
enum { SPT_SWITCH_AUTO = 0, SPT_SWITCH_OFF = 1, SPT_SWITCH_ON = 2 };

/* The values of the options of each kind as the user types them, indexed by
 * their value: SWITCH (SPT_SWITCH_*), SAMPLER (SPT_SAMPLER_*,
 * kernels/util/render_types.h) and the AOV layers (bit k of the mask,
 * src/render/film.h). The parsers and the checkpoint's mismatch messages
 * (src/render/checkpoint.c) take the names from here. */
#define SPT_SWITCH_NAMES {"auto", "off", "on"}
#define SPT_SAMPLER_NAMES {"sobol", "independent", "zsobol"}
#define SPT_AOV_NAMES {"albedo", "N", "Z", "P", "variance", "spp"}

/* --light-paths: light paths per camera path of the light-tracing pass (the
 * measurement that chose the default is in docs/architecture.md, "Caustics").
 * A RenderSettings with 0 gets the default. At most SPT_LIGHT_PATHS_MAX, so a
 * chunk's work items (camera and light paths) stay within 32 bits at the
 * largest image (16384 x 16384 at one sample per chunk). */
#define SPT_LIGHT_PATHS_DEFAULT 2.0
#define SPT_LIGHT_PATHS_MAX 8.0

#define SPT_RENDER_OPTIONS(X)                                                                   \
    X(CLI, LIST, const char *, outputs, "output", 'o', "FILE", NULL, 0, 0, 0, "",               \
      "output image; repeatable; the format follows the extension:\n"                          \
      ".exr (linear, 32-bit float), .png/.jpg (sRGB 8-bit),\n"                                 \
      ".tif (float), .hdr (linear). Default: SCENE-NAME.exr and .png")                         \
    X(RS, INT, int, spp, "spp", 0, "N", 16, 1, 16777216, SPT_OPT_MPI,                           \
      "expected a whole number from 1 to 16777216", "samples per pixel (default 16)")           \
    X(RS, DBL, double, time_limit, "time", 0, "SECONDS", 0, -HUGE_VAL, HUGE_VAL,                \
      SPT_OPT_MPI | SPT_OPT_POSITIVE, "expected a positive number of seconds",                  \
      "render for this long instead (whole samples per pixel; --spp is the cap)")               \
    X(RS, INT, int, width, "width", 0, "W", 0, 1, 16384, SPT_OPT_IMAGE | SPT_OPT_MPI,          \
      "expected a whole number from 1 to 16384", "image width (default 512)")                   \
    X(RS, INT, int, height, "height", 0, "H", 0, 1, 16384, SPT_OPT_IMAGE | SPT_OPT_MPI,        \
      "expected a whole number from 1 to 16384",                                                \
      "image height (default: from the camera's aspect ratio)")                                 \
    X(RS, INT, int, max_depth, "max-depth", 0, "D", -1, -1, 100000,                             \
      SPT_OPT_IMAGE | SPT_OPT_MPI | SPT_OPT_NOT_ZERO,                                           \
      "expected -1 (unlimited) or a whole number >= 1",                                         \
      "path segments from the camera: 1 emitters only, 2 direct\n"                             \
      "light, ...; -1 unlimited, ended by Russian roulette (default -1)")                      \
    X(RS, U32, uint32_t, seed, "seed", 0, "S", 0, 0, 4294967295.0, SPT_OPT_IMAGE | SPT_OPT_MPI, \
      "expected a whole number from 0 to 4294967295",                                           \
      "random seed (default 0); the same seed on the same device\n"                            \
      "gives the same image bit for bit")                                                      \
    X(RS, SAMPLER, uint32_t, sampler, "sampler", 0, "NAME", 0, 0, 0, SPT_OPT_IMAGE | SPT_OPT_MPI, \
      "expected sobol, zsobol or independent",                                                  \
      "sobol (default): Owen-scrambled Sobol points in every\n"                                 \
      "dimension of a path; zsobol: the same spread over the\n"                               \
      "pixels in Morton order, so neighbours' errors cancel (blue\n"                          \
      "noise; its sequence follows --spp rounded up to a power\n"                             \
      "of two); independent: uniform random numbers")                                         \
    X(RS, SWITCH, int, adaptive, "adaptive", 0, "MODE", SPT_SWITCH_AUTO, 0, 0,                 \
      SPT_OPT_IMAGE | SPT_OPT_MPI, "expected auto, off or on",                                  \
      "adaptive sampling: after 16 samples per pixel, each\n"                                  \
      "doubling of the samples goes to the pixels whose error it\n"                          \
      "lowers most; auto (default): on with --time (the cleaner\n"                            \
      "image in the time), else off; not with --checkpoint,\n"                                \
      "--resume or MPI ranks")                                                                  \
    X(CLI, STR, const char *, device, "device", 0, "SEL", NULL, 0, 0, 0, "",                    \
      "OpenCL device(s): index, name substring, cpu or gpu, a comma\n"                         \
      "list, or all (default: SPECTRACE_DEVICE, else the first GPU,\n"                         \
      "else the CPU); several devices share the samples")                                      \
    X(RS, AOV, unsigned, aov, "aov", 0, "LIST", 0, 0, 0, SPT_OPT_IMAGE | SPT_OPT_MPI,          \
      "expected a comma list of albedo, N, Z, P, variance, spp, or all",                        \
      "AOV layers added to the EXR, a comma list: albedo, N\n"                                \
      "(normal), Z (depth), P (position), variance, spp; or all")                              \
    X(RS, INT, int, spectral, "spectral", 0, "N", 0, 1, 470, SPT_OPT_IMAGE | SPT_OPT_MPI,       \
      "expected a number of bands from 1 to 470",                                                \
      "N spectral bands over 360-830 nm in the EXR (47: 10 nm),\n"                             \
      "as Fichet, Pacanowski and Wilkie 2021 lay them out")                                    \
    X(RS, FLAG, int, denoise, "denoise", 0, "", 0, 0, 0, SPT_OPT_IMAGE | SPT_OPT_MPI, "",         \
      "denoise with Intel Open Image Denoise 2 (`make denoise`\n"                             \
      "installs it); an EXR keeps the noisy image as noisy.R/G/B")                            \
    X(CLI, DBL, double, exposure, "exposure", 0, "EV", 0, -64, 64, 0,                           \
      "expected a number of stops from -64 to 64",                                              \
      "display outputs (PNG, JPEG) are scaled by 2^EV")                                         \
    X(CLI, TONEMAP, int, tonemap, "tonemap", 0, "MODE", 0, 0, 0, 0, "expected none or neutral", \
      "display tone map: none (default) or neutral (Khronos PBR Neutral)")                      \
    X(SKY, STR, const char *, env, "env", 0, "FILE", NULL, 0, 0, SPT_OPT_IMAGE, "",             \
      "equirectangular environment map (.hdr, .exr) lighting the scene")                        \
    X(RS, FLT, float, env_rotation, "env-rotation", 0, "DEG", 0, -HUGE_VAL, HUGE_VAL,           \
      SPT_OPT_IMAGE | SPT_OPT_MPI | SPT_OPT_FINITE, "expected a number",                        \
      "rotate the environment about +Y (default 0)")                                            \
    X(RS, FLT, float, env_intensity, "env-intensity", 0, "X", 1, 0, HUGE_VAL,                   \
      SPT_OPT_IMAGE | SPT_OPT_MPI | SPT_OPT_FINITE, "expected a non-negative number",           \
      "scale the environment (default 1)")                                                      \
    X(SKY, STR, const char *, background, "background", 0, "SKY", NULL, 0, 0, SPT_OPT_IMAGE, "", \
      "uniform sky: R,G,B (linear sRGB, upsampled as an illuminant),\n"                        \
      "an SPD (name, blackbody:K, CSV), or black. Default: a scene\n"                          \
      "without lights gets a white (D65, radiance 1) sky")                                     \
    X(RS, FLT, float, aperture, "aperture", 0, "R", 0, 0, HUGE_VAL,                             \
      SPT_OPT_IMAGE | SPT_OPT_MPI | SPT_OPT_FINITE, "expected a non-negative number",           \
      "thin-lens radius in metres (default 0: pinhole)")                                        \
    X(RS, FLT, float, focus_distance, "focus-distance", 0, "D", 0, 0, HUGE_VAL,                 \
      SPT_OPT_IMAGE | SPT_OPT_MPI | SPT_OPT_FINITE, "expected a non-negative number",           \
      "focus distance in metres (default: the distance at the\n"                               \
      "image centre)")                                                                          \
    X(RS, SWITCH, int, caustics, "caustics", 0, "MODE", SPT_SWITCH_AUTO, 0, 0,                 \
      SPT_OPT_IMAGE | SPT_OPT_MPI, "expected auto, off or on",                                  \
      "light tracing for caustics (light through glass or off\n"                               \
      "smooth metal onto diffuse surfaces, punctual lights\n"                                  \
      "behind glass): auto (default: when the scene has such\n"                                \
      "surfaces and a light), on or off; perspective cameras")                                  \
    X(RS, FLT, float, light_paths, "light-paths", 0, "R", SPT_LIGHT_PATHS_DEFAULT, 0,           \
      SPT_LIGHT_PATHS_MAX, SPT_OPT_IMAGE | SPT_OPT_MPI | SPT_OPT_POSITIVE | SPT_OPT_FINITE,     \
      "expected a number of light paths per camera path above 0 and at most 8",                 \
      "light paths per camera path of the light tracing (default\n"                            \
      "2), counted as if sent from the lights unaimed: the pass aims\n"                       \
      "them at the glass and mirrors, so it traces fewer; lower it\n"                         \
      "where caustics are a small part of the image")                                           \
    X(RS, SWITCH, int, merge, "merge", 0, "MODE", SPT_SWITCH_AUTO, 0, 0,                        \
      SPT_OPT_IMAGE | SPT_OPT_MPI, "expected auto, off or on",                                  \
      "photon merging for caustics seen through glass or in a\n"                               \
      "mirror, on the light tracing's paths: auto (default: on\n"                              \
      "where the light tracing runs for glass or mirrors, unless\n"                          \
      "the glass is dispersive and a light has a line spectrum),\n"                          \
      "off, or on (needs the light tracing)")                                                   \
    X(RS, SWITCH, int, light_tree, "light-tree", 0, "MODE", SPT_SWITCH_AUTO, 0, 0,              \
      SPT_OPT_IMAGE | SPT_OPT_MPI, "expected auto, off or on",                                  \
      "next-event estimation picks lights with a light tree, by\n"                            \
      "their bounds' importance at the shading point: auto\n"                                 \
      "(default: when it holds two lights or more), on or off\n"                              \
      "(by power alone)")                                                                       \
    X(CLI, STR, const char *, checkpoint, "checkpoint", 0, "FILE", NULL, 0, 0, 0, "",           \
      "write the resumable film (an EXR) every --checkpoint-every\n"                           \
      "seconds, at the end and when stopped by a signal")                                      \
    X(CLI, DBL, double, checkpoint_every, "checkpoint-every", 0, "SECONDS", 60, 0, HUGE_VAL,    \
      SPT_OPT_FINITE, "expected a number of seconds >= 0", "(default 60)")                      \
    X(CLI, STR, const char *, resume, "resume", 0, "FILE", NULL, 0, 0, 0, "",                   \
      "continue the checkpoint FILE to --spp samples per pixel in\n"                           \
      "total (same scene and settings; keeps checkpointing to FILE)")                          \
    X(RS, STR, const char *, at, "at", 0, "SECONDS", NULL, 0, 0, SPT_OPT_IMAGE,               \
      "expected a finite time in seconds",                                                      \
      "pose the scene at this time of its glTF animations (all\n"                             \
      "of them, or --animation's), clamped to each one's keys\n"                             \
      "(default: the file's rest pose, no animation)")                                          \
    X(RS, STR, const char *, animation, "animation", 0, "N|NAME", NULL, 0, 0, SPT_OPT_IMAGE, "", \
      "play only this animation (index or name) at --at (default\n"                          \
      "all; without --at at its time 0)")                                                     \
    X(RS, STR, const char *, camera, "camera", 0, "N|NAME", NULL, 0, 0, SPT_OPT_IMAGE, "",       \
      "the file's camera (index or name; default the first in\n"                             \
      "scene order), placed by the first node that uses it")                                  \
    X(RS, SWITCH, int, instancing, "instancing", 0, "MODE", SPT_SWITCH_AUTO, 0, 0,              \
      SPT_OPT_IMAGE, "expected auto, off or on",                                                \
      "glTF meshes placed by reference (one copy, a two-level\n"                              \
      "BVH): auto (default) those placed two or more times, off\n"                           \
      "none (every placement flattened), on also those placed\n"                            \
      "once; skinned, morphed, emitting and TANGENT meshes are\n"                           \
      "always flattened")                                                                       \
    X(CLI, STR, const char *, frames, "frames", 0, "A:B[:STEP]", NULL, 0, 0, 0,                 \
      "expected A:B or A:B:STEP, frame numbers 0 <= A <= B <= 9999999 and STEP >= 1",        \
      "render frames A to B (every STEP-th) of the animations,\n"                           \
      "frame F posed at time F / --fps; each -o (and --checkpoint)\n"                      \
      "name takes the frame number in place of its last run of\n"                          \
      "#s (out_####.png: out_0007.png), else before its extension")                          \
    X(CLI, DBL, double, fps, "fps", 0, "F", 24, 0, HUGE_VAL, SPT_OPT_POSITIVE | SPT_OPT_FINITE, \
      "expected a positive number of frames per second",                                       \
      "frames per second of --frames (default 24)")                                            \
    X(RS, FLAG, int, profile, "profile", 0, "", 0, 0, 0, SPT_OPT_MPI, "",                       \
      "time the kernel stages and print where the time went")                                   \
    X(CLI, FLAG, int, quiet, "quiet", 'q', "", 0, 0, 0, 0, "", "no progress display")           \
    X(CLI, HELP, int, help, "help", 'h', "", 0, 0, 0, 0, "", "this text")

/* Helpers for generating code from the list: SPT_OPT_IF_RS_##where(x) keeps x
 * only in RS rows, SPT_OPT_IF_CLI_##where(x) only in the rows RenderArgs holds
 * (CLI and SKY). */
#define SPT_OPT_IF_RS_RS(x) x
#define SPT_OPT_IF_RS_SKY(x)
#define SPT_OPT_IF_RS_CLI(x)
#define SPT_OPT_IF_CLI_RS(x)
#define SPT_OPT_IF_CLI_SKY(x) x
#define SPT_OPT_IF_CLI_CLI(x) x

/* The RenderSettings fields of the RS rows. */
#define SPT_OPT_RS_FIELD(where, kind, type, name, ...) SPT_OPT_IF_RS_##where(type name;)

#endif
