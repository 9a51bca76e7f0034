/* spectrace as a library: the public C API of build/libspectrace.so
 * (docs/api.md). A program opens devices (a renderer), loads a scene once,
 * renders it with settings as many times as it likes, changing materials and
 * lights in between, and reads each render's image as arrays or writes it with
 * the command line's writers. `spectrace render` (one image, a frame
 * sequence, and build/spectrace-mpi over several ranks) is itself a client of
 * this API (src/cli/cmd_render.c).
 *
 * The API is versioned: SPECTRACE_API_VERSION in this header, and
 * spectrace_version() in the library, whose major number must match (a new
 * minor version only adds). Every name of the library starts with spectrace_;
 * nothing else is exported except three functions libspectrace-oiio.so calls
 * back (src/io/oiio_exports.list).
 *
 * Errors: every function that can fail returns 0 or one of the codes below
 * (the command line's exit codes, README.md "Exit codes") and fills the
 * spectrace_error it is given (NULL: not wanted) with the code and the one-line
 * message the command line prints after "error: ". The library never exits the
 * process and prints nothing but warnings ("warning: ..." on stderr, as the
 * command line does).
 *
 * Threads: the library keeps no state of its own beyond a lock around scene
 * loading and image writing (the loaders' bookkeeping of files read is one
 * per process). Objects are not shared between threads while in use: two
 * threads may render at once with a renderer and a scene each. */
#ifndef SPECTRACE_H
#define SPECTRACE_H

#include <signal.h>
#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define SPECTRACE_API_VERSION_MAJOR 1
#define SPECTRACE_API_VERSION_MINOR 3
/* major * 10000 + minor * 100 */
#define SPECTRACE_API_VERSION (SPECTRACE_API_VERSION_MAJOR * 10000 + SPECTRACE_API_VERSION_MINOR * 100)

/* The codes (README.md, "Exit codes"). */
enum {
    SPECTRACE_OK = 0,
    SPECTRACE_ERR_FAILURE = 1,    /* internal or unexpected failure */
    SPECTRACE_ERR_USAGE = 2,      /* a bad setting, name or argument */
    SPECTRACE_ERR_INPUT = 3,      /* a scene, SPD or image file unreadable or invalid */
    SPECTRACE_ERR_DEVICE = 4,     /* no OpenCL device, a build failure, device limits */
    SPECTRACE_ERR_OUTPUT = 5,     /* an output cannot be written */
    SPECTRACE_ERR_CANCELLED = 130 /* the progress callback stopped the render */
};

typedef struct spectrace_error {
    int code;
    char message[1024];
} spectrace_error;

/* The library's version, SPECTRACE_API_VERSION's form. */
int spectrace_version(void);

/* ---- Devices ---------------------------------------------------------- */

typedef struct spectrace_renderer spectrace_renderer;

/* Opens the OpenCL devices of selector, as the command line's --device takes
 * it (an index, a name substring, cpu, gpu, a comma list or all; NULL: the
 * SPECTRACE_DEVICE variable, else the first GPU, else the CPU). NULL on
 * failure, with err filled. A render on several devices splits the samples
 * between them. */
spectrace_renderer *spectrace_renderer_open(const char *selector, spectrace_error *err);
void spectrace_renderer_close(spectrace_renderer *r);
/* The devices chosen and each one's "NAME (PLATFORM)". */
int spectrace_renderer_device_count(const spectrace_renderer *r);
const char *spectrace_renderer_device_name(const spectrace_renderer *r, int i);
/* Device i's index in the list of `spectrace devices`, name, platform and
 * driver version (since 1.2); the strings live as long as r. */
typedef struct spectrace_device_info {
    int index;
    const char *name, *platform, *driver;
} spectrace_device_info;

int spectrace_renderer_device_info(const spectrace_renderer *r, int i, spectrace_device_info *out,
                                   spectrace_error *err);

/* ---- Settings --------------------------------------------------------- */

/* A render's settings: every option of `spectrace render` (src/render/
 * render_options.h, README.md "Rendering"), by its command-line name without
 * "--" ("spp", "width", "max-depth", "aov", ...), parsed and checked as the
 * command line does, so a new option is here without code of its own. Not
 * settings of a render here: output, device (spectrace_renderer_open), quiet
 * and help, which are refused; exposure and tonemap apply to
 * spectrace_image_write. denoise (since 1.1) denoises the image as the
 * command line does (Open Image Denoise, loaded by the first render that asks
 * for it: README.md, "--denoise"). checkpoint, checkpoint-every and resume
 * (since 1.2) checkpoint and resume a render as the command line does
 * (docs/outputs.md, "Checkpoints"): the render writes its checkpoint every
 * checkpoint-every seconds and at its end (or with its outputs: see
 * spectrace_render_with), and a render with resume starts from the samples
 * of that checkpoint, which the scene (its file) and the settings that change
 * the image must match; the result is the uninterrupted render's, bit for
 * bit. */
typedef struct spectrace_settings spectrace_settings;

spectrace_settings *spectrace_settings_new(void); /* every option at its default */
spectrace_settings *spectrace_settings_copy(const spectrace_settings *s);
void spectrace_settings_free(spectrace_settings *s);
/* Sets option name from text as the command line takes it ("64", "0.5",
 * "on", "albedo,N"); a flag takes 1/0, on/off, true/false, yes/no. */
int spectrace_settings_set(spectrace_settings *s, const char *name, const char *value,
                           spectrace_error *err);
/* Typed: the number is written out and parsed as above (the same checks). */
int spectrace_settings_set_int(spectrace_settings *s, const char *name, long long value,
                               spectrace_error *err);
int spectrace_settings_set_double(spectrace_settings *s, const char *name, double value,
                                  spectrace_error *err);
/* Option name's value as text ("16", "sobol", "albedo,Z", "" for a string
 * not set) into out (cap bytes). */
int spectrace_settings_get(const spectrace_settings *s, const char *name, char *out, size_t cap,
                           spectrace_error *err);
/* The options one by one: their count, and option i's name, kind ("int",
 * "double", "string", "flag", "choice" or "list") and help text. */
int spectrace_settings_count(void);
const char *spectrace_settings_name(int i);
const char *spectrace_settings_kind(int i);
const char *spectrace_settings_help(int i);

/* ---- Scenes ----------------------------------------------------------- */

typedef struct spectrace_scene spectrace_scene;

/* Loads a .gltf or .glb file. settings (may be NULL) gives the pose: its "at",
 * "animation" and "camera" (docs/gltf.md); a render whose settings name
 * another pose is refused. Since 1.2 it also reads the sky of settings' env
 * and background first, as the command line does (a render with another sky
 * reads that one). NULL on failure, with err filled. */
spectrace_scene *spectrace_scene_load(const char *path, const spectrace_settings *settings,
                                      spectrace_error *err);
/* The same from the file's bytes (.gltf or .glb); its external buffers and
 * images are read from folder base_dir (NULL: the current folder). _memory
 * loads the rest pose and the first camera; _memory_posed (since 1.1) the
 * pose of settings (may be NULL), as spectrace_scene_load. */
spectrace_scene *spectrace_scene_load_memory(const void *data, size_t size, const char *base_dir,
                                             spectrace_error *err);
spectrace_scene *spectrace_scene_load_memory_posed(const void *data, size_t size,
                                                   const char *base_dir,
                                                   const spectrace_settings *settings,
                                                   spectrace_error *err);
void spectrace_scene_free(spectrace_scene *s);

/* Before rendering (since 1.2): refuses (SPECTRACE_ERR_USAGE, the command
 * line's message) outputs (count file names) that would replace a file the
 * scene's load read (the scene, its buffers and textures, the sky's files),
 * the checkpoint that settings resume (an image output), or each other; the
 * checkpoint of settings (checkpoint, else resume) counts as an output. Files
 * compared by device and inode, so links and other names are caught too. */
int spectrace_scene_check_outputs(const spectrace_scene *s, const spectrace_settings *settings,
                                  const char *const *outputs, int count, spectrace_error *err);

/* Releases what the scene keeps on a renderer's devices between renders (its
 * programs and buffers; since 1.2), as spectrace_scene_free does, keeping the
 * scene: the next render builds and uploads them again. */
void spectrace_scene_release_devices(spectrace_scene *s);

/* ---- Animation (since 1.3) ---------------------------------------------
 *
 * A frame sequence renders one scene at one time after another (docs/api.md,
 * "Frame sequences"; the command line's --frames is this API's client):
 * spectrace_scene_set_time poses the scene at a time, keeping what it holds
 * on a renderer's devices (its programs, and its buffers, of which the next
 * render uploads only those whose contents changed), and the next render
 * refits the last pose's BVH to the moved triangles instead of building one
 * when the new pose has the same triangles (count, vertices and materials;
 * a scene with meshes placed by reference is built again), which gives the
 * same image as a scene loaded at that time (docs/gltf.md, "Frame
 * sequences"). Frame F of a sequence at R frames per second is at time F / R
 * (the command line's --fps, 24 by default); the file's animations give
 * their first and last key times. */

/* The file's animations: their count, and animation i's name ("" when the
 * file gives none), first and last key time in seconds, and channels. The
 * name lives as long as the scene's pose. */
typedef struct spectrace_animation_info {
    const char *name;
    double start, end;
    int channels;
} spectrace_animation_info;

int spectrace_scene_animation_count(const spectrace_scene *s);
int spectrace_scene_animation_info(const spectrace_scene *s, int i, spectrace_animation_info *out,
                                   spectrace_error *err);

/* The time the scene is posed at in seconds (its load's "at", or the last
 * spectrace_scene_set_time); NaN: the rest pose. */
double spectrace_scene_time(const spectrace_scene *s);

/* Poses the scene at seconds (finite) with the animation and camera it was
 * loaded with: the scene is read again from its file (or the bytes it was
 * loaded from, which it keeps) at that time, so changes of its materials and
 * lights made since its load are replaced by the file's. Its "at" becomes
 * the time written with 17 digits ("%.17g"), which a render's settings must
 * give as their at (or leave it to Python's Scene.time). The sky stays. On
 * failure (the file is gone, say) the scene stays as it was. */
int spectrace_scene_set_time(spectrace_scene *s, double seconds, spectrace_error *err);

/* What the scene's last pose cost: the seconds of its load (spectrace_scene_
 * load or _set_time: reading and posing the file), and of its BVH's build or
 * refit (the next render's), whether that BVH was refitted, and the refits
 * so far (the builds are spectrace_scene_stats.bvh_builds). */
typedef struct spectrace_scene_timing {
    double load_seconds;
    double bvh_seconds;
    int bvh_refitted;
    int bvh_refits;
} spectrace_scene_timing;

void spectrace_scene_timing_get(const spectrace_scene *s, spectrace_scene_timing *out);

/* Materials: their count, index i's name, and the index of the first named
 * name (-1: none). */
int spectrace_scene_material_count(const spectrace_scene *s);
const char *spectrace_scene_material_name(const spectrace_scene *s, int i);
int spectrace_scene_material_find(const spectrace_scene *s, const char *name);
/* A material's parameter (glTF's, docs/api.md "Materials and lights"):
 * base_color (4 values), metallic, roughness, emissive (3), emissive_strength,
 * ior, transmission, dispersion, attenuation_color (3), attenuation_distance,
 * thickness, specular, specular_color (3), clearcoat, clearcoat_roughness,
 * sheen_color (3), sheen_roughness. get returns the number of values (at most
 * 4) written to values; set takes exactly that many. Values are checked as the
 * loader checks the file's (finite, within range). The next render uses them. */
int spectrace_scene_material_get(const spectrace_scene *s, int i, const char *param,
                                 float *values, spectrace_error *err);
int spectrace_scene_material_set(spectrace_scene *s, int i, const char *param,
                                 const float *values, int count, spectrace_error *err);
/* A material's spectrum, "reflectance" or "emission" (the spectrace extras of
 * docs/gltf.md, which replace the RGB base colour or emission), as count
 * (nm, value) pairs, nm increasing; count 0 removes it. */
int spectrace_scene_material_set_spectrum(spectrace_scene *s, int i, const char *which,
                                          const double *nm, const double *value, int count,
                                          spectrace_error *err);

/* Punctual lights (KHR_lights_punctual): count, name, parameters intensity
 * (candela or lux, as in the file), color (3), range, inner_cone_angle,
 * outer_cone_angle (radians), and the "emission" spectrum, as for materials. */
int spectrace_scene_light_count(const spectrace_scene *s);
const char *spectrace_scene_light_name(const spectrace_scene *s, int i);
int spectrace_scene_light_get(const spectrace_scene *s, int i, const char *param, float *values,
                              spectrace_error *err);
int spectrace_scene_light_set(spectrace_scene *s, int i, const char *param, const float *values,
                              int count, spectrace_error *err);
int spectrace_scene_light_set_spectrum(spectrace_scene *s, int i, const double *nm,
                                       const double *value, int count, spectrace_error *err);

/* ---- Rendering -------------------------------------------------------- */

typedef struct spectrace_image spectrace_image;

/* Called after every chunk of samples with the samples per pixel done and
 * asked for; a non-zero return stops the render after the chunks in progress
 * (SPECTRACE_ERR_CANCELLED). Called from a render thread, one call at a time. */
typedef int (*spectrace_progress_fn)(void *user, uint32_t done, uint32_t total);

/* Renders scene with settings (NULL: the defaults) on r's devices, blocking,
 * into *out (free with spectrace_image_free). A scene's BVH is built once;
 * changed materials and lights are rebuilt before the render. The scene keeps
 * its programs and its device buffers on r's devices from one render to the
 * next: a render uploads only the buffers whose contents changed (the
 * materials after a material's change), and builds a program again only when
 * its kernel options change (AOVs, spectral bands) or
 * the scene is rendered with another renderer (whose devices then take over).
 * What it keeps (the buffers, and on a CPU device their host memory) is
 * released by spectrace_scene_free.
 * The image is the command line's for the same scene and settings, bit for
 * bit. */
int spectrace_render(spectrace_renderer *r, spectrace_scene *scene,
                     const spectrace_settings *settings, spectrace_progress_fn progress,
                     void *user, spectrace_image **out, spectrace_error *err);

/* What a scene's renders have cost so far (since version 1.1): the renders
 * that completed; the BVH builds (one per load and per pose of
 * spectrace_scene_set_time whose tree is not refitted, again when a material
 * change could not be applied to the kept one); the programs built or loaded
 * from the program cache (one per device, again when the kernel options
 * change); the uploads of the geometry (BVH, triangles and vertex arrays) and
 * of the materials array to the devices (one per device each time it
 * changed); and every byte uploaded of the scene's buffers. */
typedef struct spectrace_scene_stats {
    int renders;
    int bvh_builds;
    int program_builds;
    int geometry_uploads;
    int material_uploads;
    double bytes_uploaded;
} spectrace_scene_stats;

void spectrace_scene_stats_get(const spectrace_scene *s, spectrace_scene_stats *out);

/* The steps of spectrace_render one by one, for a program that reports them
 * as the command line does (since 1.2).
 *
 * spectrace_render_prepare builds the scene's device arrays (once, as
 * spectrace_render would) and reads the settings' sky, then checks the host
 * memory the render will take (the film, the render, and writing outputs:
 * count file names, whose formats count) against what is available
 * (docs/limits.md, "The memory estimate"), refusing too much with
 * SPECTRACE_ERR_DEVICE. mem (may be NULL) receives the estimate in bytes, also
 * when it is refused: what is loaded (the scene's device arrays and the
 * environment map), and the render's need: the film, then the larger of the
 * render's own and the outputs'. spectrace_render calls it itself. */
typedef struct spectrace_memory {
    double loaded, need, film, render, outputs;
} spectrace_memory;

int spectrace_render_prepare(spectrace_renderer *r, spectrace_scene *scene,
                             const spectrace_settings *settings, const char *const *outputs,
                             int count, spectrace_memory *mem, spectrace_error *err);

/* What spectrace_render_with reports as the render goes: the samples per
 * pixel done and asked for, the seconds since the render started (after the
 * program builds) and the paths traced so far. */
typedef struct spectrace_progress_info {
    uint32_t done, total;
    double elapsed;
    double paths;
} spectrace_progress_info;

/* A non-zero return stops the render as spectrace_progress_fn's does. */
typedef int (*spectrace_progress_info_fn)(void *user, const spectrace_progress_info *p);

typedef struct spectrace_render_options {
    spectrace_progress_info_fn progress; /* may be NULL */
    void *user;
    /* A flag the caller may set (from a signal handler too): 1 stops the
     * render after the chunks in progress (a long one at once), 2 at once,
     * dropping them. A progress callback's non-zero return sets it to 1. May
     * be NULL. */
    volatile sig_atomic_t *stop;
    /* A render stopped after some samples returns them (SPECTRACE_OK, with
     * spectrace_render_stats.stopped set) instead of SPECTRACE_ERR_CANCELLED. */
    int keep_stopped;
    /* The command line's notes on stderr: a kernel build not found in the
     * program cache, "resuming ...", the final checkpoint written. In
     * build/spectrace-mpi over several ranks (since 1.3), where every render
     * is spread over the ranks (docs/api.md, "Several MPI ranks"), a verbose
     * render with a progress callback prints the ranks' progress line and
     * each rank's samples instead of calling the callback. */
    int verbose;
    /* The final checkpoint is written by spectrace_image_write_outputs with
     * the outputs (all or none replaced) instead of at the render's end. */
    int checkpoint_with_outputs;
} spectrace_render_options;

/* spectrace_render with options (NULL: as spectrace_render without a
 * progress callback). spectrace_render(r, s, settings, fn, user, out, err)
 * is this with the options' progress reporting fn's figures. */
int spectrace_render_with(spectrace_renderer *r, spectrace_scene *scene,
                          const spectrace_settings *settings,
                          const spectrace_render_options *options, spectrace_image **out,
                          spectrace_error *err);

void spectrace_image_free(spectrace_image *img);

/* A render's figures (since 1.2; the command line's "rendered ..." line and
 * --profile): the samples per pixel done, of them those resumed from a
 * checkpoint, whether the render was stopped (keep_stopped), the seconds of
 * the render and of the program builds, the paths and rays traced, the
 * samples dropped as NaN or infinite, each stage's seconds (the kernels
 * generate, extend, shade, connect, accumulate and, on CPU devices, paths,
 * which runs the first four for whole paths), the denoising's seconds and the
 * Open Image Denoise library used (NULL: not denoised), the devices as the
 * EXR's metadata names them, and the checkpoint of the render (written at
 * its end, or to be written with its outputs; NULL: none, or no sample done)
 * with the samples per pixel it holds. The strings live as long as img. */
#define SPECTRACE_STAGES 6
typedef struct spectrace_render_stats {
    uint32_t spp_done, spp_resumed;
    int stopped;
    double seconds, build_seconds;
    uint64_t paths, rays_extend, rays_shadow, nan_dropped;
    double stage_seconds[SPECTRACE_STAGES];
    double denoise_seconds;
    const char *denoiser;
    const char *devices;
    const char *checkpoint;
    uint32_t checkpoint_spp;
} spectrace_render_stats;

void spectrace_image_stats(const spectrace_image *img, spectrace_render_stats *out);
int spectrace_image_width(const spectrace_image *img);
int spectrace_image_height(const spectrace_image *img);
/* Samples per pixel rendered, and the render's seconds. */
int spectrace_image_spp(const spectrace_image *img);
double spectrace_image_seconds(const spectrace_image *img);

/* The arrays, rows top to bottom, into out (allocated by the caller):
 * - rgb: linear sRGB, 3 floats per pixel (the EXR's R, G, B): with the
 *   "denoise" setting the denoised image, whose noisy one noisy_rgb gives
 *   (since 1.1; the EXR's noisy.R, G, B), the same as rgb without it;
 * - xyz: CIE XYZ, 3 floats per pixel (luminance Y in cd/m^2);
 * - counts: the samples kept per pixel, 1 float per pixel;
 * - aov: layer name ("albedo", "N", "Z", "P", "variance", "spp") of a render
 *   with that layer in its "aov" setting, 3 floats per pixel (1 for Z and
 *   spp); returns the channels (1 or 3), or an error code as a negative number;
 * - bands: a render with "spectral" N: N floats per pixel, each band's mean
 *   spectral radiance (W m^-2 sr^-1 nm^-1) over N equal bands of 360-830 nm
 *   (band b's centre is 360 + (b + 0.5) * 470 / N nm). */
int spectrace_image_rgb(const spectrace_image *img, float *out);
int spectrace_image_noisy_rgb(const spectrace_image *img, float *out);
int spectrace_image_xyz(const spectrace_image *img, float *out);
int spectrace_image_counts(const spectrace_image *img, float *out);
int spectrace_image_aov(const spectrace_image *img, const char *layer, float *out,
                        spectrace_error *err);
int spectrace_image_band_count(const spectrace_image *img);
int spectrace_image_bands(const spectrace_image *img, float *out);

/* Writes the image as the command line does (the format from the extension:
 * .exr with the AOV layers and bands, .png, .jpg, .tif, .hdr), with the
 * render's settings' exposure and tonemap for display formats. */
int spectrace_image_write(const spectrace_image *img, const char *path, spectrace_error *err);

/* Writes the image to count outputs as spectrace_image_write does, and with
 * checkpoint_with_outputs the render's final checkpoint (since 1.2): each to a
 * temporary file, renamed over its name only when every one was written, so
 * a failure (a full disk at the second output) leaves every existing file as
 * it was. */
int spectrace_image_write_outputs(spectrace_image *img, const char *const *outputs, int count,
                                  spectrace_error *err);

/* Writes any linear sRGB array (3 floats per pixel, rows top to bottom: a
 * contact sheet of several renders) with the same writers, without metadata;
 * display formats get the sRGB transfer curve and no exposure or tone map. */
int spectrace_write_rgb(const char *path, const float *rgb, int width, int height,
                        spectrace_error *err);

/* ---- Colour ----------------------------------------------------------- */

/* What `spectrace color` prints for an SPD: its CIE 1931 XYZ normalised to
 * Y = 1 (with reflectance: as a reflectance under D65, a perfect white
 * reflector at Y = 1), the linear sRGB of that XYZ (unclamped), 8-bit sRGB
 * and the chromaticity x, y. spd is as the command takes it (A, D65, F2, F7,
 * F11, mercury, blackbody:K, or a CSV file), or NULL with count (nm, value)
 * pairs, nm increasing. */
typedef struct spectrace_color_info {
    double xyz[3];
    double linear_srgb[3];
    int srgb8[3];
    double x, y;
} spectrace_color_info;

int spectrace_color(const char *spd, const double *nm, const double *value, int count,
                    int reflectance, spectrace_color_info *out, spectrace_error *err);

#ifdef __cplusplus
}
#endif

#endif
