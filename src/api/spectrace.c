/* The library's C API (src/api/spectrace.h), which the command line's
 * `spectrace render` is a client of (docs/architecture.md, "Source layout"):
 * the option list and parsing (src/api/render_args.h), the glTF loader, the
 * device arrays (src/render/gpu_scene.h), the scheduler (render_devices),
 * checkpoints and the writers. */
#include "api/spectrace.h"

#include <math.h>
#include <pthread.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "accel/bvh_build.h"
#include "cl/cl_device.h"
#include "api/output_check.h"
#include "api/render_args.h"
#include "api/render_stats.h"
#include "color/spd.h"
#include "core/input_file.h"
#include "core/util.h"
#include "io/image_out.h"
#include "io/srgb.h"
#include "mpi/mpi_hook.h"
#include "render/checkpoint.h"
#include "render/film.h"
#include "render/film_layers.h"
#include "render/gpu_scene.h"
#include "render/render.h"
#include "render/render_result.h"
#include "render/test_hooks.h"
#include "scene/scene.h"
#include "scene/sky.h"

#define MAX_DEVICES 64

_Static_assert(sizeof(((spectrace_error *)0)->message) == sizeof(((SptError *)0)->msg),
               "spectrace_error mirrors SptError");

/* The loaders note every file they read (src/core/input_file.h) in one list per
 * process, and the EXR writer keeps its last message in one: loads and writes
 * take turns. */
static pthread_mutex_t io_lock = PTHREAD_MUTEX_INITIALIZER;

static int fail(spectrace_error *err, int code, const char *fmt, ...) __attribute__((format(printf, 3, 4)));

static int fail(spectrace_error *err, int code, const char *fmt, ...)
{
    if (err) {
        va_list ap;
        va_start(ap, fmt);
        err->code = code;
        vsnprintf(err->message, sizeof err->message, fmt, ap);
        va_end(ap);
    }
    return code;
}

/* An SptError's code and message into err. */
static int pass(spectrace_error *err, const SptError *e, int rc)
{
    if (err) {
        err->code = rc;
        snprintf(err->message, sizeof err->message, "%s", e->msg);
    }
    return rc;
}

int spectrace_version(void)
{
    return SPECTRACE_API_VERSION;
}

/* ---- Devices ---------------------------------------------------------- */

struct spectrace_renderer {
    unsigned serial; /* which renderer a scene's kept programs belong to */
    ClDeviceList list;
    const ClDeviceInfo *devs[MAX_DEVICES];
    char names[MAX_DEVICES][520];
    int count;
    Denoiser den;     /* Open Image Denoise, loaded by the first render asking for it */
    int den_loaded;
};

spectrace_renderer *spectrace_renderer_open(const char *selector, spectrace_error *err)
{
    static unsigned serials;
    spectrace_renderer *r = spt_calloc(1, sizeof *r);
    r->serial = __atomic_add_fetch(&serials, 1, __ATOMIC_SEQ_CST);
    SptError e = {0};
    int sel[MAX_DEVICES], rc;
    if ((rc = cl_device_list(&r->list, &e)) ||
        (rc = cl_device_select(&r->list, selector, sel, &r->count, &e))) {
        pass(err, &e, rc);
        spectrace_renderer_close(r);
        return NULL;
    }
    for (int i = 0; i < r->count; i++) {
        r->devs[i] = &r->list.devices[sel[i]];
        snprintf(r->names[i], sizeof r->names[i], "%s (%s)", r->devs[i]->name, r->devs[i]->platform_name);
    }
    return r;
}

void spectrace_renderer_close(spectrace_renderer *r)
{
    if (!r)
        return;
    cl_device_list_free(&r->list);
    if (r->den_loaded)
        denoiser_close(&r->den);
    free(r);
}

int spectrace_renderer_device_count(const spectrace_renderer *r)
{
    return r->count;
}

const char *spectrace_renderer_device_name(const spectrace_renderer *r, int i)
{
    return i >= 0 && i < r->count ? r->names[i] : NULL;
}

int spectrace_renderer_device_info(const spectrace_renderer *r, int i, spectrace_device_info *out,
                                   spectrace_error *err)
{
    if (i < 0 || i >= r->count)
        return fail(err, SPECTRACE_ERR_USAGE, "renderer: device %d does not exist (it has %d)", i,
                    r->count);
    const ClDeviceInfo *d = r->devs[i];
    *out = (spectrace_device_info){d->index, d->name, d->platform_name, d->driver_version};
    return SPECTRACE_OK;
}

/* ---- Settings --------------------------------------------------------- */

struct spectrace_settings {
    RenderArgs a;
    char *owned[SPT_ARG_COUNT]; /* each option's text, which a borrows */
};

spectrace_settings *spectrace_settings_new(void)
{
    spectrace_settings *s = spt_calloc(1, sizeof *s);
    render_args_defaults(&s->a);
    return s;
}

spectrace_settings *spectrace_settings_copy(const spectrace_settings *src)
{
    spectrace_settings *s = spectrace_settings_new();
    char buf[4096];
    for (int i = 0; i < SPT_ARG_COUNT; i++)
        if (src->a.given[i]) {
            render_args_format(&src->a, i, buf, sizeof buf);
            spectrace_settings_set(s, render_args_option_name(i), buf, NULL);
        }
    return s;
}

void spectrace_settings_free(spectrace_settings *s)
{
    if (!s)
        return;
    for (int i = 0; i < SPT_ARG_COUNT; i++)
        free(s->owned[i]);
    free(s);
}

/* The options that are not settings of a render here (spectrace.h). */
static int not_a_setting(int i)
{
    return i == SPT_ARG_outputs || i == SPT_ARG_device || i == SPT_ARG_quiet || i == SPT_ARG_help;
}

static int find_option(const char *name, spectrace_error *err)
{
    int i = name ? render_args_find(name) : -1;
    if (i < 0)
        return -fail(err, SPECTRACE_ERR_USAGE, "settings: unknown option '%s' (the options of "
                     "spectrace render --help, without --)", name ? name : "(null)");
    if (not_a_setting(i))
        return -fail(err, SPECTRACE_ERR_USAGE, "settings: --%s is the command line's, not a "
                     "render setting of the library (docs/api.md)", name);
    return i;
}

int spectrace_settings_set(spectrace_settings *s, const char *name, const char *value,
                           spectrace_error *err)
{
    int i = find_option(name, err);
    if (i < 0)
        return -i;
    if (!value)
        return fail(err, SPECTRACE_ERR_USAGE, "settings: --%s: no value", name);
    /* Parsed into a copy, so a bad value leaves the settings as they were. */
    char *text = spt_strdup(value);
    RenderArgs a = s->a;
    SptError e = {0};
    int rc = render_args_set(&a, i, text, &e);
    if (!rc && i == SPT_ARG_at) {
        char *end;
        double at = strtod(text, &end);
        if (!*text || *end || !isfinite(at))
            rc = spt_fail(&e, SPT_EXIT_USAGE, "render: --at '%s': expected a finite time in seconds", text);
    }
    if (rc) {
        free(text);
        return pass(err, &e, rc);
    }
    s->a = a;
    free(s->owned[i]);
    s->owned[i] = text;
    return SPECTRACE_OK;
}

int spectrace_settings_set_int(spectrace_settings *s, const char *name, long long value,
                               spectrace_error *err)
{
    char buf[32];
    snprintf(buf, sizeof buf, "%lld", value);
    return spectrace_settings_set(s, name, buf, err);
}

int spectrace_settings_set_double(spectrace_settings *s, const char *name, double value,
                                  spectrace_error *err)
{
    char buf[64];
    snprintf(buf, sizeof buf, "%.17g", value);
    return spectrace_settings_set(s, name, buf, err);
}

int spectrace_settings_get(const spectrace_settings *s, const char *name, char *out, size_t cap,
                           spectrace_error *err)
{
    int i = find_option(name, err);
    if (i < 0)
        return -i;
    render_args_format(&s->a, i, out, cap);
    return SPECTRACE_OK;
}

int spectrace_settings_count(void)
{
    return SPT_ARG_COUNT;
}

const char *spectrace_settings_name(int i)
{
    return i >= 0 && i < SPT_ARG_COUNT ? render_args_option_name(i) : NULL;
}

const char *spectrace_settings_kind(int i)
{
    return i >= 0 && i < SPT_ARG_COUNT ? render_args_option_kind(i) : NULL;
}

const char *spectrace_settings_help(int i)
{
    return i >= 0 && i < SPT_ARG_COUNT ? render_args_option_help(i) : NULL;
}

/* ---- Scenes ----------------------------------------------------------- */

struct spectrace_scene {
    Scene scene;
    /* The pose (NULL: not given): at as loaded or set by
     * spectrace_scene_set_time ("%.17g" of its seconds). */
    char *pose_at, *pose_animation, *pose_camera;
    int instancing;    /* the loader's SCENE_INSTANCING_* */
    int from_file;     /* loaded from a file (a checkpoint's key hashes it) */
    /* Where spectrace_scene_set_time reads the scene again: the file's path,
     * or (a scene from memory) a copy of its bytes and the name standing for
     * them. */
    char *path;
    void *data;
    size_t size;
    char *data_name;
    InputList inputs;  /* the files its loads read, for spectrace_scene_check_outputs */
    GpuScene gpu;
    int gpu_built;     /* the BVH and the device arrays exist */
    /* The last pose's BVH, kept by spectrace_scene_set_time when the new pose
     * has the same triangles (moved): the next build refits it. */
    Bvh refit_bvh;
    spectrace_scene_timing timing;
    int shading_dirty; /* a material or light changed since */
    Sky sky;           /* the last render's, kept while its env and background stay */
    char *sky_env, *sky_background;
    int sky_loaded;
    /* The programs and scene buffers kept on the devices of the renderer
     * programs_of (its serial; 0: none) between renders. */
    RenderPrograms programs;
    unsigned programs_of;
    spectrace_scene_stats stats;
};

/* The "instancing" setting's values are the loader's (src/scene/scene.h). */
_Static_assert((int)SCENE_INSTANCING_AUTO == (int)SPT_SWITCH_AUTO &&
                   (int)SCENE_INSTANCING_OFF == (int)SPT_SWITCH_OFF &&
                   (int)SCENE_INSTANCING_ON == (int)SPT_SWITCH_ON,
               "ScenePose.instancing takes the instancing setting's value");

static char *dup_or_null(const char *s)
{
    return s ? spt_strdup(s) : NULL;
}

static int same_text(const char *a, const char *b)
{
    return (!a && !b) || (a && b && !strcmp(a, b));
}

/* A scene from the file at path, or from data (size bytes) standing for the
 * file name; NULL with err filled on failure. */
static spectrace_scene *load(const char *path, const void *data, size_t size, const char *name,
                             const RenderArgs *a, spectrace_error *err)
{
    spectrace_scene *s = spt_calloc(1, sizeof *s);
    const RenderSettings *rs = a ? &a->rs : NULL;
    s->from_file = path != NULL;
    if (rs) {
        s->pose_at = dup_or_null(rs->at);
        s->pose_animation = dup_or_null(rs->animation);
        s->pose_camera = dup_or_null(rs->camera);
        s->instancing = rs->instancing;
    }
    s->path = dup_or_null(path);
    if (data) {
        s->data = spt_malloc(size ? size : 1);
        memcpy(s->data, data, size);
        s->size = size;
        s->data_name = spt_strdup(name);
    }
    ScenePose pose = {s->pose_at ? strtod(s->pose_at, NULL) : NAN, s->pose_animation, s->pose_camera,
                      s->instancing};
    SptError e = {0};
    pthread_mutex_lock(&io_lock);
    input_seen_reset();
    /* The sky first, as the command line reads it (its errors come first). */
    int rc = a ? sky_from_args(&s->sky, a->env, a->background, &e) : SPT_EXIT_OK;
    if (!rc && a) {
        s->sky_loaded = 1;
        s->sky_env = dup_or_null(a->env);
        s->sky_background = dup_or_null(a->background);
    }
    double t0 = spt_now();
    if (!rc)
        rc = data ? scene_load_gltf_memory_posed(&s->scene, data, size, name, &pose, &e)
                  : scene_load_gltf_posed(&s->scene, path, &pose, &e);
    s->timing.load_seconds = spt_now() - t0;
    input_seen_copy(&s->inputs);
    input_seen_reset();
    pthread_mutex_unlock(&io_lock);
    if (rc) {
        pass(err, &e, rc);
        spectrace_scene_free(s);
        return NULL;
    }
    return s;
}

spectrace_scene *spectrace_scene_load(const char *path, const spectrace_settings *settings,
                                      spectrace_error *err)
{
    if (!path) {
        fail(err, SPECTRACE_ERR_USAGE, "scene: no path");
        return NULL;
    }
    return load(path, NULL, 0, NULL, settings ? &settings->a : NULL, err);
}

spectrace_scene *spectrace_scene_load_memory(const void *data, size_t size, const char *base_dir,
                                             spectrace_error *err)
{
    return spectrace_scene_load_memory_posed(data, size, base_dir, NULL, err);
}

spectrace_scene *spectrace_scene_load_memory_posed(const void *data, size_t size,
                                                   const char *base_dir,
                                                   const spectrace_settings *settings,
                                                   spectrace_error *err)
{
    if (!data) {
        fail(err, SPECTRACE_ERR_USAGE, "scene: no data");
        return NULL;
    }
    /* The loader looks up external files in the folder of the name. */
    char name[4096];
    snprintf(name, sizeof name, "%s/(memory)", base_dir && *base_dir ? base_dir : ".");
    return load(NULL, data, size, name, settings ? &settings->a : NULL, err);
}

int spectrace_scene_check_outputs(const spectrace_scene *s, const spectrace_settings *settings,
                                  const char *const *outputs, int count, spectrace_error *err)
{
    const char *checkpoint = settings ? settings->a.checkpoint : NULL;
    const char *resume = settings ? settings->a.resume : NULL;
    SptError e = {0};
    int rc = SPT_EXIT_OK;
    for (int i = 0; i < count && !rc; i++)
        if (!outputs[i])
            rc = spt_fail(&e, SPT_EXIT_USAGE, "image: no path");
    if (!rc)
        rc = outputs_check_not_inputs(&s->inputs, outputs, count, checkpoint, resume, &e);
    return rc ? pass(err, &e, rc) : SPECTRACE_OK;
}

void spectrace_scene_release_devices(spectrace_scene *s)
{
    if (s->programs_of) {
        spectrace_scene_stats_get(s, &s->stats);
        render_programs_free(&s->programs);
        memset(&s->programs, 0, sizeof s->programs);
    }
    s->programs_of = 0;
}

void spectrace_scene_free(spectrace_scene *s)
{
    if (!s)
        return;
    if (s->programs_of)
        render_programs_free(&s->programs);
    input_list_free(&s->inputs);
    if (s->gpu_built)
        gpu_scene_free(&s->gpu);
    bvh_free(&s->refit_bvh);
    free(s->path);
    free(s->data);
    free(s->data_name);
    if (s->sky_loaded)
        sky_free(&s->sky);
    scene_free(&s->scene);
    free(s->pose_at);
    free(s->pose_animation);
    free(s->pose_camera);
    free(s->sky_env);
    free(s->sky_background);
    free(s);
}

/* ---- Animation (since 1.3) -------------------------------------------- */

int spectrace_scene_animation_count(const spectrace_scene *s)
{
    return (int)s->scene.animation_info_count;
}

int spectrace_scene_animation_info(const spectrace_scene *s, int i, spectrace_animation_info *out,
                                   spectrace_error *err)
{
    if (i < 0 || (uint32_t)i >= s->scene.animation_info_count)
        return fail(err, SPECTRACE_ERR_USAGE, "scene: animation %d does not exist (the scene has %u)",
                    i, s->scene.animation_info_count);
    const SceneAnimationInfo *a = &s->scene.animation_info[i];
    *out = (spectrace_animation_info){a->name, a->start, a->end, (int)a->channels};
    return SPECTRACE_OK;
}

double spectrace_scene_time(const spectrace_scene *s)
{
    return s->pose_at ? strtod(s->pose_at, NULL) : NAN;
}

/* Whether scenes a and b have the same triangles (count, vertex indices and
 * materials), of which only the positions may differ. */
static int same_triangles(const Scene *a, const Scene *b)
{
    return a->tri_count == b->tri_count &&
           !memcmp(a->tri_vidx, b->tri_vidx, (size_t)a->tri_count * 3 * sizeof(uint32_t)) &&
           !memcmp(a->tri_mat, b->tri_mat, (size_t)a->tri_count * sizeof(uint32_t));
}

/* The inputs of the scene's loads into the loaders' record (io_lock held), so
 * that the next load adds its own to them. */
static void inputs_reseed(const InputList *list)
{
    input_seen_reset();
    for (int i = 0; i < list->count; i++) {
        struct stat st;
        memset(&st, 0, sizeof st);
        st.st_dev = list->files[i].dev;
        st.st_ino = list->files[i].ino;
        input_seen_add(list->files[i].path, &st);
    }
}

int spectrace_scene_set_time(spectrace_scene *s, double seconds, spectrace_error *err)
{
    if (!isfinite(seconds))
        return fail(err, SPECTRACE_ERR_USAGE, "scene: time %g: expected a finite time in seconds",
                    seconds);
    ScenePose pose = {seconds, s->pose_animation, s->pose_camera, s->instancing};
    Scene next;
    SptError e = {0};
    pthread_mutex_lock(&io_lock);
    inputs_reseed(&s->inputs);
    double t0 = spt_now();
    int rc = s->data ? scene_load_gltf_memory_posed(&next, s->data, s->size, s->data_name, &pose, &e)
                     : scene_load_gltf_posed(&next, s->path, &pose, &e);
    double load_seconds = spt_now() - t0;
    if (!rc) {
        input_list_free(&s->inputs);
        input_seen_copy(&s->inputs);
    }
    input_seen_reset();
    pthread_mutex_unlock(&io_lock);
    if (rc)
        return pass(err, &e, rc); /* the scene stays as it was */
    /* The BVH of the last pose is refitted by the next build when only the
     * triangles' positions moved (docs/gltf.md, "Frame sequences"); a
     * two-level scene's world tree is not the whole scene's. */
    bvh_free(&s->refit_bvh);
    if (s->gpu_built && s->gpu.bvh.nodes && !s->scene.mesh_count && !next.mesh_count &&
        same_triangles(&s->scene, &next)) {
        s->refit_bvh = s->gpu.bvh;
        memset(&s->gpu.bvh, 0, sizeof s->gpu.bvh);
    }
    if (s->gpu_built)
        gpu_scene_free(&s->gpu);
    s->gpu_built = 0;
    s->shading_dirty = 0;
    scene_free(&s->scene);
    s->scene = next;
    char at[64];
    snprintf(at, sizeof at, "%.17g", seconds);
    free(s->pose_at);
    s->pose_at = spt_strdup(at);
    s->timing.load_seconds = load_seconds;
    return SPECTRACE_OK;
}

void spectrace_scene_timing_get(const spectrace_scene *s, spectrace_scene_timing *out)
{
    *out = s->timing;
}

/* A parameter of a material or a light: its name, where it lies in the
 * struct, how many floats, and the range the loader accepts (docs/gltf.md). */
typedef struct Param {
    const char *name;
    size_t offset;
    int count;
    float lo, hi;
} Param;

#define MAT(field, n, lo, hi) {#field, offsetof(SceneMaterial, field), n, lo, hi}
static const Param material_params[] = {
    MAT(base_color, 4, 0, 1),        MAT(metallic, 1, 0, 1),
    MAT(roughness, 1, 0, 1),         MAT(emissive, 3, 0, 1),
    MAT(emissive_strength, 1, 0, HUGE_VALF), MAT(ior, 1, 1, HUGE_VALF),
    MAT(transmission, 1, 0, 1),      MAT(dispersion, 1, 0, HUGE_VALF),
    MAT(attenuation_color, 3, 0, 1), MAT(attenuation_distance, 1, 0, HUGE_VALF),
    MAT(thickness, 1, 0, HUGE_VALF), MAT(specular, 1, 0, 1),
    MAT(specular_color, 3, 0, HUGE_VALF), MAT(clearcoat, 1, 0, 1),
    MAT(clearcoat_roughness, 1, 0, 1), MAT(sheen_color, 3, 0, 1),
    MAT(sheen_roughness, 1, 0, 1),
};
#undef MAT

#define LIGHT(name, field, n, lo, hi) {name, offsetof(SceneLight, field), n, lo, hi}
static const Param light_params[] = {
    LIGHT("intensity", intensity, 1, 0, SPT_MAX_INPUT_VALUE),
    LIGHT("color", color, 3, 0, HUGE_VALF),
    LIGHT("range", range, 1, 0, HUGE_VALF),
    LIGHT("inner_cone_angle", inner_cone, 1, 0, (float)(M_PI / 2)),
    LIGHT("outer_cone_angle", outer_cone, 1, 0, (float)(M_PI / 2)),
};
#undef LIGHT

static const Param *find_param(const Param *table, size_t n, const char *name)
{
    for (size_t k = 0; k < n && name; k++)
        if (!strcmp(table[k].name, name))
            return &table[k];
    return NULL;
}

int spectrace_scene_material_count(const spectrace_scene *s)
{
    return (int)s->scene.material_count;
}

const char *spectrace_scene_material_name(const spectrace_scene *s, int i)
{
    return i >= 0 && i < (int)s->scene.material_count ? s->scene.materials[i].name : NULL;
}

int spectrace_scene_material_find(const spectrace_scene *s, const char *name)
{
    for (uint32_t i = 0; i < s->scene.material_count && name; i++)
        if (!strcmp(s->scene.materials[i].name, name))
            return (int)i;
    return -1;
}

int spectrace_scene_light_count(const spectrace_scene *s)
{
    return (int)s->scene.light_count;
}

const char *spectrace_scene_light_name(const spectrace_scene *s, int i)
{
    return i >= 0 && i < (int)s->scene.light_count ? s->scene.lights[i].name : NULL;
}

/* The object (a material or a light, what names it in messages) a parameter
 * belongs to: i in [0, n), else an error. */
static int check_index(int i, uint32_t n, const char *what, spectrace_error *err)
{
    if (i < 0 || (uint32_t)i >= n)
        return fail(err, SPECTRACE_ERR_USAGE, "scene: %s %d does not exist (the scene has %u)", what, i, n);
    return SPECTRACE_OK;
}

static int param_get(void *obj, const Param *table, size_t n, const char *what, const char *param,
                     float *values, spectrace_error *err)
{
    const Param *p = find_param(table, n, param);
    if (!p)
        return -fail(err, SPECTRACE_ERR_USAGE, "scene: %s has no parameter '%s'", what, param ? param : "(null)");
    memcpy(values, (char *)obj + p->offset, (size_t)p->count * sizeof(float));
    return p->count;
}

static int param_set(void *obj, const Param *table, size_t n, const char *what, const char *param,
                     const float *values, int count, spectrace_error *err)
{
    const Param *p = find_param(table, n, param);
    if (!p)
        return fail(err, SPECTRACE_ERR_USAGE, "scene: %s has no parameter '%s'", what, param ? param : "(null)");
    if (count != p->count)
        return fail(err, SPECTRACE_ERR_USAGE, "scene: %s: %s takes %d value%s, not %d", what, param,
                    p->count, p->count > 1 ? "s" : "", count);
    for (int k = 0; k < count; k++)
        if (!isfinite(values[k]) || values[k] < p->lo || values[k] > p->hi)
            return fail(err, SPECTRACE_ERR_USAGE, "scene: %s: %s %g is outside [%g, %g]", what, param,
                        (double)values[k], (double)p->lo, (double)p->hi);
    memcpy((char *)obj + p->offset, values, (size_t)count * sizeof(float));
    return SPECTRACE_OK;
}

int spectrace_scene_material_get(const spectrace_scene *s, int i, const char *param,
                                 float *values, spectrace_error *err)
{
    int rc = check_index(i, s->scene.material_count, "material", err);
    if (rc)
        return -rc;
    return param_get(&s->scene.materials[i], material_params,
                     sizeof material_params / sizeof material_params[0], s->scene.materials[i].name,
                     param, values, err);
}

int spectrace_scene_material_set(spectrace_scene *s, int i, const char *param,
                                 const float *values, int count, spectrace_error *err)
{
    int rc = check_index(i, s->scene.material_count, "material", err);
    if (!rc)
        rc = param_set(&s->scene.materials[i], material_params,
                       sizeof material_params / sizeof material_params[0],
                       s->scene.materials[i].name, param, values, count, err);
    s->shading_dirty |= !rc;
    return rc;
}

int spectrace_scene_light_get(const spectrace_scene *s, int i, const char *param, float *values,
                              spectrace_error *err)
{
    int rc = check_index(i, s->scene.light_count, "light", err);
    if (rc)
        return -rc;
    return param_get(&s->scene.lights[i], light_params, sizeof light_params / sizeof light_params[0],
                     s->scene.lights[i].name, param, values, err);
}

int spectrace_scene_light_set(spectrace_scene *s, int i, const char *param, const float *values,
                              int count, spectrace_error *err)
{
    int rc = check_index(i, s->scene.light_count, "light", err);
    if (!rc)
        rc = param_set(&s->scene.lights[i], light_params, sizeof light_params / sizeof light_params[0],
                       s->scene.lights[i].name, param, values, count, err);
    s->shading_dirty |= !rc;
    return rc;
}

/* An SPD from count (nm, value) pairs into *dst (count 0: none). */
static int set_spd(Spd *dst, const char *what, const double *nm, const double *value, int count,
                   spectrace_error *err)
{
    Spd spd = {0};
    if (count < 0 || (count > 0 && (!nm || !value)))
        return fail(err, SPECTRACE_ERR_USAGE, "scene: %s: no samples", what);
    for (int k = 0; k < count; k++)
        if (!(value[k] >= 0 && value[k] <= SPT_MAX_INPUT_VALUE))
            return fail(err, SPECTRACE_ERR_USAGE, "scene: %s: the value at %g nm, %g, is outside [0, %g]",
                        what, nm[k], value[k], SPT_MAX_INPUT_VALUE);
    SptError e = {0};
    int rc = count > 0 ? spd_from_samples(&spd, nm, value, count, &e) : 0;
    if (rc)
        return fail(err, SPECTRACE_ERR_USAGE, "scene: %s: %s", what, e.msg);
    spd_free(dst);
    *dst = spd;
    return SPECTRACE_OK;
}

int spectrace_scene_material_set_spectrum(spectrace_scene *s, int i, const char *which,
                                          const double *nm, const double *value, int count,
                                          spectrace_error *err)
{
    int rc = check_index(i, s->scene.material_count, "material", err);
    if (rc)
        return rc;
    SceneMaterial *m = &s->scene.materials[i];
    Spd *dst = which && !strcmp(which, "reflectance") ? &m->reflectance_spd
               : which && !strcmp(which, "emission")  ? &m->emission_spd
                                                      : NULL;
    if (!dst)
        return fail(err, SPECTRACE_ERR_USAGE, "scene: %s: the spectrum '%s' is not reflectance or emission",
                    m->name, which ? which : "(null)");
    char what[256];
    snprintf(what, sizeof what, "%s: %s", m->name, which);
    rc = set_spd(dst, what, nm, value, count, err);
    s->shading_dirty |= !rc;
    return rc;
}

int spectrace_scene_light_set_spectrum(spectrace_scene *s, int i, const double *nm,
                                       const double *value, int count, spectrace_error *err)
{
    int rc = check_index(i, s->scene.light_count, "light", err);
    if (rc)
        return rc;
    char what[256];
    snprintf(what, sizeof what, "%s: emission", s->scene.lights[i].name);
    rc = set_spd(&s->scene.lights[i].spd, what, nm, value, count, err);
    s->shading_dirty |= !rc;
    return rc;
}

/* ---- Rendering -------------------------------------------------------- */

struct spectrace_image {
    Film film;
    RenderStats st;
    RenderSettings rs; /* as rendered; its pose (at, animation, camera) in pose */
    char *pose[3];
    float *denoised;   /* with denoise: the image denoised (the film's is the noisy one) */
    double denoise_seconds;
    char *denoiser;    /* the Open Image Denoise library that denoised it */
    DisplayOptions disp;
    char *scene_path;
    char device[4096];
    CheckpointRun ckpt; /* the checkpoint side of the render (a writer without a path: none) */
    char *ckpt_path[2]; /* its checkpoint and resume paths, which ckpt borrows */
    int ckpt_pending;   /* its final write waits for spectrace_image_write_outputs */
    int stopped;
};

/* The progress callbacks through the scheduler's on_progress hook. */
typedef struct Progress {
    spectrace_progress_fn fn;          /* spectrace_render's */
    spectrace_progress_info_fn info_fn; /* spectrace_render_with's */
    void *user;
    volatile sig_atomic_t own_stop, *stop;
} Progress;

static void on_progress(void *ctx, uint32_t done, uint32_t total, double elapsed, uint64_t paths)
{
    Progress *p = ctx;
    spectrace_progress_info info = {done, total, elapsed, (double)paths};
    int stop = p->fn ? p->fn(p->user, done, total) : p->info_fn ? p->info_fn(p->user, &info) : 0;
    if (stop && !*p->stop)
        *p->stop = 1;
}

/* The scene's device arrays and sky for rs: built once, the materials and
 * lights again after a change, the sky again when its options change. */
static int prepare_scene(spectrace_scene *s, const RenderArgs *a, SptError *e)
{
    int rc;
    if (!s->gpu_built) {
        /* After spectrace_scene_set_time: the last pose's BVH refitted when
         * it can index the new positions, else built. */
        RenderSettings hooks = a->rs;
        render_test_hooks_env(&hooks);
        uint32_t n = s->scene.tri_count;
        int refit = s->refit_bvh.nodes && !hooks.test.bvh_rebuild &&
                    bvh_refit(&s->refit_bvh, s->scene.tri_pos, n, n);
        if (!refit)
            bvh_free(&s->refit_bvh);
        rc = refit ? gpu_scene_build_with(&s->gpu, &s->scene, &s->refit_bvh, e)
                   : gpu_scene_build(&s->gpu, &s->scene, e);
        if (rc)
            return rc;
        s->gpu_built = 1;
        s->stats.bvh_builds += !refit;
        s->timing.bvh_refits += refit;
        s->timing.bvh_refitted = refit;
        s->timing.bvh_seconds = s->gpu.bvh.stats.build_seconds;
        s->shading_dirty = 0;
    } else if (s->shading_dirty) {
        if ((rc = gpu_scene_build_shading(&s->gpu, &s->scene, e))) {
            s->gpu_built = 0; /* freed: built anew next time */
            return rc;
        }
        s->shading_dirty = 0;
    }
    if (!s->sky_loaded || !same_text(s->sky_env, a->env) || !same_text(s->sky_background, a->background)) {
        if (s->sky_loaded)
            sky_free(&s->sky);
        s->sky_loaded = 0;
        pthread_mutex_lock(&io_lock);
        rc = sky_from_args(&s->sky, a->env, a->background, e);
        pthread_mutex_unlock(&io_lock);
        if (rc)
            return rc;
        s->sky_loaded = 1;
        free(s->sky_env);
        free(s->sky_background);
        s->sky_env = dup_or_null(a->env);
        s->sky_background = dup_or_null(a->background);
    }
    return SPT_EXIT_OK;
}

/* The settings of a render as the command line completes them: the image
 * size from the camera's aspect ratio, adaptive sampling's auto (off with
 * checkpoints, which keep no sums of squares), --time without --spp, the
 * sky, the test hooks of the environment. */
static RenderSettings complete(const RenderArgs *a, const spectrace_scene *scene)
{
    RenderSettings rs = a->rs;
    render_image_size(&rs, &scene->scene.camera);
    /* Adaptive sampling's auto is off over MPI ranks too (src/mpi/mpi_hook.h). */
    render_adaptive_resolve(&rs, !spt_dist_render && !a->checkpoint && !a->resume);
    if (a->given[SPT_ARG_time_limit] && !a->given[SPT_ARG_spp])
        rs.spp = 1 << 24;
    rs.sky = &scene->sky;
    render_test_hooks_env(&rs);
    return rs;
}

int spectrace_render_prepare(spectrace_renderer *r, spectrace_scene *scene,
                             const spectrace_settings *settings, const char *const *outputs,
                             int count, spectrace_memory *mem, spectrace_error *err)
{
    spectrace_settings *defaults = settings ? NULL : spectrace_settings_new();
    const RenderArgs *a = settings ? &settings->a : &defaults->a;
    SptError e = {0};
    int rc = prepare_scene(scene, a, &e);
    if (!rc) {
        RenderSettings rs = complete(a, scene);
        RenderHostMemory m;
        rc = render_host_memory(r->devs, r->count, &scene->gpu, &scene->scene.camera, &rs,
                                outputs, count, &m, &e);
        if (mem)
            *mem = (spectrace_memory){m.loaded, m.need, m.film, m.render, m.outputs};
    }
    spectrace_settings_free(defaults);
    return rc ? pass(err, &e, rc) : SPECTRACE_OK;
}

/* The image's denoised array (render_denoise) and its figures. */
static int denoise_image(spectrace_renderer *r, spectrace_image *img, const RenderSettings *rs,
                         SptError *e)
{
    size_t floats = (size_t)rs->width * rs->height * 3;
    float *noisy = spt_malloc(floats * sizeof(float));
    film_to_linear_srgb(&img->film, noisy);
    img->denoised = spt_malloc(floats * sizeof(float));
    double t0 = spt_now();
    int rc = render_denoise(&r->den, &img->film, rs, noisy, img->denoised, e);
    img->denoise_seconds = spt_now() - t0;
    img->denoiser = spt_strdup(r->den.path);
    free(noisy);
    return rc;
}

/* spectrace_render_with, or with fn (not NULL) spectrace_render with its
 * callback. */
static int render_image(spectrace_renderer *r, spectrace_scene *scene,
                        const spectrace_settings *settings, const spectrace_render_options *options,
                        spectrace_progress_fn fn, spectrace_image **out, spectrace_error *err)
{
    *out = NULL;
    spectrace_render_options none = {0};
    const spectrace_render_options *o = options ? options : &none;
    spectrace_settings *defaults = settings ? NULL : spectrace_settings_new();
    const RenderArgs *a = settings ? &settings->a : &defaults->a;
    const char *ckpt_path = a->checkpoint ? a->checkpoint : a->resume;
    SptError e = {0};
    int rc = SPT_EXIT_OK;
    if (!same_text(a->rs.at, scene->pose_at) || !same_text(a->rs.animation, scene->pose_animation) ||
        !same_text(a->rs.camera, scene->pose_camera))
        rc = fail(err, SPECTRACE_ERR_USAGE, "render: the settings' at, animation or camera differ "
                  "from the pose the scene was loaded in (load it with these settings)");
    else if (a->rs.adaptive == SPT_SWITCH_ON && spt_dist_render)
        rc = fail(err, SPECTRACE_ERR_USAGE, "render: --adaptive on is not supported across MPI ranks");
    else if (ckpt_path && !scene->from_file)
        rc = fail(err, SPECTRACE_ERR_USAGE, "render: a checkpoint identifies its scene by the "
                  "scene's file: load the scene from its file to checkpoint or resume");
    else if (ckpt_path && (rc = checkpoint_path_check(ckpt_path, &e)))
        pass(err, &e, rc);
    else if ((rc = spectrace_render_prepare(r, scene, settings, NULL, 0, NULL, err)))
        ;
    else if (a->rs.denoise && !r->den_loaded && (rc = denoiser_open(&r->den, &e)))
        pass(err, &e, rc);
    if (rc) {
        spectrace_settings_free(defaults);
        return rc;
    }
    r->den_loaded |= a->rs.denoise;
    const char *scene_name = scene->scene.path ? scene->scene.path : "(memory)";
    RenderSettings rs = complete(a, scene);
    render_warn_unlit(&scene->gpu, &scene->scene, &scene->sky, rs.env_intensity, scene_name);
    Progress prog = {0};
    prog.fn = fn;
    prog.info_fn = o->progress;
    prog.user = o->user;
    prog.stop = o->stop ? o->stop : &prog.own_stop;
    rs.progress = 0;
    rs.announce = o->verbose;
    rs.stop = prog.stop;
    rs.on_progress = on_progress;
    rs.on_progress_ctx = &prog;
    /* The programs and buffers kept from the scene's last render on these
     * devices; another renderer's are closed first. */
    if (scene->programs_of != r->serial) {
        spectrace_scene_release_devices(scene);
        render_programs_init(&scene->programs, r->count);
        scene->programs.keep_scene = 1;
        scene->programs_of = r->serial;
    }
    rs.programs = &scene->programs;
    spectrace_image *img = spt_calloc(1, sizeof *img);
    /* The film, from the checkpoint resumed or empty; checkpoints hook in. */
    img->ckpt_path[0] = dup_or_null(a->checkpoint);
    img->ckpt_path[1] = dup_or_null(a->resume);
    if ((rc = checkpoint_run_begin(&img->ckpt, scene_name, img->ckpt_path[0], a->checkpoint_every,
                                   img->ckpt_path[1], &rs, &img->film, &e))) {
        pass(err, &e, rc);
        spectrace_image_free(img);
        spectrace_settings_free(defaults);
        return rc;
    }
    if (img->ckpt.resumed && o->verbose)
        fprintf(stderr, "resuming %s: %u of %ld samples per pixel done\n", a->resume,
                img->ckpt.resumed, (long)rs.spp);
    RenderDeviceStats per_dev[MAX_DEVICES];
    /* In build/spectrace-mpi with several ranks the render is spread over
     * them (src/mpi/mpi_hook.h); its own progress line and the ranks' samples
     * are printed there when the caller is verbose with a progress callback. */
    if (spt_dist_render) {
        rs.progress = o->verbose && (o->progress || fn);
        rc = spt_dist_render(r->devs, r->count, &scene->gpu, &scene->scene, &scene->scene.camera,
                             &rs, &img->film, &img->st, per_dev, &e);
    } else {
        rc = render_devices(r->devs, r->count, &scene->gpu, &scene->scene.camera, &rs, &img->film,
                            &img->st, per_dev, &e);
    }
    img->stopped = *prog.stop != 0;
    if (rc)
        pass(err, &e, rc);
    else if (img->st.spp_done == 0)
        rc = fail(err, SPECTRACE_ERR_CANCELLED, "render: stopped before any pass completed; nothing written");
    else if (img->stopped && !o->keep_stopped) {
        /* The samples done stay in the checkpoint, to resume from. */
        if ((rc = checkpoint_run_end(&img->ckpt, &img->film, !o->verbose, &e)))
            pass(err, &e, rc);
        else
            rc = fail(err, SPECTRACE_ERR_CANCELLED, "render: stopped by the progress callback%s after "
                  "%u of %d samples per pixel", o->stop ? " or the stop flag" : "",
                  img->st.spp_done, rs.spp);
    } else if ((rc = render_film_check(&img->film, &rs, scene_name, &e)))
        pass(err, &e, rc);
    else if (rs.denoise && (rc = denoise_image(r, img, &rs, &e)))
        pass(err, &e, rc);
    else if (o->checkpoint_with_outputs)
        img->ckpt_pending = 1;
    else if ((rc = checkpoint_run_end(&img->ckpt, &img->film, !o->verbose, &e)))
        pass(err, &e, rc);
    if (rc) {
        spectrace_image_free(img);
        spectrace_settings_free(defaults);
        return rc;
    }
    /* What the checkpoint hooks pointed into belongs to the image now. */
    rs.done_in = NULL;
    rs.on_chunk = NULL;
    rs.on_chunk_ctx = NULL;
    rs.on_progress = NULL;
    rs.on_progress_ctx = NULL;
    rs.stop = NULL;
    img->rs = rs;
    img->rs.at = img->pose[0] = dup_or_null(rs.at);
    img->rs.animation = img->pose[1] = dup_or_null(rs.animation);
    img->rs.camera = img->pose[2] = dup_or_null(rs.camera);
    img->disp = (DisplayOptions){(float)a->exposure, a->tonemap};
    img->scene_path = spt_strdup(scene_name);
    render_device_description(r->devs, r->count, per_dev, img->device, sizeof img->device);
    scene->stats.renders++;
    *out = img;
    spectrace_settings_free(defaults);
    return SPECTRACE_OK;
}

int spectrace_render_with(spectrace_renderer *r, spectrace_scene *scene,
                          const spectrace_settings *settings,
                          const spectrace_render_options *options, spectrace_image **out,
                          spectrace_error *err)
{
    return render_image(r, scene, settings, options, NULL, out, err);
}

int spectrace_render(spectrace_renderer *r, spectrace_scene *scene,
                     const spectrace_settings *settings, spectrace_progress_fn progress,
                     void *user, spectrace_image **out, spectrace_error *err)
{
    spectrace_render_options o = {NULL, user, NULL, 0, 0, 0};
    return render_image(r, scene, settings, &o, progress, out, err);
}

void spectrace_scene_stats_get(const spectrace_scene *s, spectrace_scene_stats *out)
{
    const RenderPrograms *p = &s->programs;
    *out = s->stats; /* with the counts of the renderers it had before */
    out->program_builds += p->builds;
    out->geometry_uploads += p->w ? p->uploads[SPT_SB_nodes] : 0;
    out->material_uploads += p->w ? p->uploads[SPT_SB_materials] : 0;
    out->bytes_uploaded += (double)p->upload_bytes;
}

void spectrace_image_free(spectrace_image *img)
{
    if (!img)
        return;
    film_free(&img->film);
    free(img->scene_path);
    for (int k = 0; k < 3; k++)
        free(img->pose[k]);
    free(img->denoised);
    free(img->denoiser);
    checkpoint_run_free(&img->ckpt);
    free(img->ckpt_path[0]);
    free(img->ckpt_path[1]);
    free(img);
}

void spectrace_image_stats(const spectrace_image *img, spectrace_render_stats *out)
{
    render_stats_public(&img->st, &img->ckpt, out);
    out->stopped = img->stopped;
    out->denoise_seconds = img->denoise_seconds;
    out->denoiser = img->denoiser;
    out->devices = img->device;
}

int spectrace_image_width(const spectrace_image *img)
{
    return img->film.width;
}

int spectrace_image_height(const spectrace_image *img)
{
    return img->film.height;
}

int spectrace_image_spp(const spectrace_image *img)
{
    return (int)img->st.spp_done;
}

double spectrace_image_seconds(const spectrace_image *img)
{
    return img->st.seconds;
}

int spectrace_image_rgb(const spectrace_image *img, float *out)
{
    if (img->denoised)
        memcpy(out, img->denoised, (size_t)img->film.width * img->film.height * 3 * sizeof(float));
    else
        film_to_linear_srgb(&img->film, out);
    return SPECTRACE_OK;
}

int spectrace_image_noisy_rgb(const spectrace_image *img, float *out)
{
    film_to_linear_srgb(&img->film, out);
    return SPECTRACE_OK;
}

int spectrace_image_xyz(const spectrace_image *img, float *out)
{
    size_t npix = (size_t)img->film.width * img->film.height;
    for (size_t i = 0; i < npix; i++) {
        double n = img->film.count[i];
        for (int k = 0; k < 3; k++)
            out[3 * i + k] = n > 0 ? (float)(img->film.xyz[3 * i + k] / n) : 0.0f;
    }
    return SPECTRACE_OK;
}

int spectrace_image_counts(const spectrace_image *img, float *out)
{
    size_t npix = (size_t)img->film.width * img->film.height;
    for (size_t i = 0; i < npix; i++)
        out[i] = (float)img->film.count[i];
    return SPECTRACE_OK;
}

int spectrace_image_aov(const spectrace_image *img, const char *layer, float *out,
                        spectrace_error *err)
{
    unsigned bit = 0;
    if (!layer || film_aov_parse(layer, &bit) || (bit & (bit - 1)))
        return -fail(err, SPECTRACE_ERR_USAGE, "image: '%s' is not an AOV layer (albedo, N, Z, P, "
                     "variance, spp)", layer ? layer : "(null)");
    if (!(img->rs.aov & bit))
        return -fail(err, SPECTRACE_ERR_USAGE, "image: the render has no %s layer (add it to the "
                     "aov setting)", layer);
    return film_aov_layer(&img->film, bit, out);
}

int spectrace_image_band_count(const spectrace_image *img)
{
    return img->film.bands;
}

int spectrace_image_bands(const spectrace_image *img, float *out)
{
    if (img->film.bands > 0)
        film_spectral_layer(&img->film, out);
    return SPECTRACE_OK;
}

/* The image's metadata and extra channels (render_image_meta) into meta, and
 * the array its outputs show: linear (the film's linear sRGB, which the
 * caller allocated) or, denoised, the denoised image with linear as its noisy
 * layer (docs/outputs.md, "Denoising"). */
static const float *image_meta(const spectrace_image *img, float *linear, RenderImageMeta *meta)
{
    film_to_linear_srgb(&img->film, linear);
    render_image_meta(meta, &img->film, &img->rs, &img->st, img->device, img->scene_path, 3);
    if (!img->denoised)
        return linear;
    render_image_meta_noisy(meta, linear);
    return img->denoised;
}

/* The image written to count outputs, then ckpt's final checkpoint (may be
 * NULL), all replaced or none (render_write_outputs). */
static int write_images(const spectrace_image *img, const char *const *outputs, int count,
                        CheckpointWriter *ckpt, spectrace_error *err)
{
    const Film *f = &img->film;
    SptError e = {0};
    int rc = SPT_EXIT_OK;
    for (int i = 0; i < count && !rc; i++)
        rc = outputs[i] ? image_output_check(outputs[i], &e)
                        : spt_fail(&e, SPT_EXIT_USAGE, "image: no path");
    if (rc)
        return pass(err, &e, rc);
    float *linear = spt_malloc((size_t)f->width * f->height * 3 * sizeof(float));
    RenderImageMeta meta;
    const float *rgb = image_meta(img, linear, &meta);
    pthread_mutex_lock(&io_lock);
    rc = render_write_outputs(outputs, count, rgb, f->width, f->height, &meta.meta, &img->disp,
                              ckpt, f, &e);
    pthread_mutex_unlock(&io_lock);
    render_image_meta_free(&meta);
    free(linear);
    return rc ? pass(err, &e, rc) : SPECTRACE_OK;
}

int spectrace_image_write(const spectrace_image *img, const char *path, spectrace_error *err)
{
    return write_images(img, &path, 1, NULL, err);
}

int spectrace_image_write_outputs(spectrace_image *img, const char *const *outputs, int count,
                                  spectrace_error *err)
{
    int rc = write_images(img, outputs, count, img->ckpt_pending ? &img->ckpt.writer : NULL, err);
    if (!rc)
        img->ckpt_pending = 0;
    return rc;
}

int spectrace_write_rgb(const char *path, const float *rgb, int width, int height,
                        spectrace_error *err)
{
    SptError e = {0};
    int rc = !path || !rgb ? spt_fail(&e, SPT_EXIT_USAGE, "image: no path or no pixels")
             : width < 1 || height < 1 || width > 65536 || height > 65536
                 ? spt_fail(&e, SPT_EXIT_USAGE, "%s: a %dx%d image is not writable", path, width, height)
                 : image_output_check(path, &e);
    if (rc)
        return pass(err, &e, rc);
    pthread_mutex_lock(&io_lock);
    rc = image_write(path, rgb, width, height, NULL, NULL, &e);
    pthread_mutex_unlock(&io_lock);
    return rc ? pass(err, &e, rc) : SPECTRACE_OK;
}

/* ---- Colour ----------------------------------------------------------- */

int spectrace_color(const char *spd_text, const double *nm, const double *value, int count,
                    int reflectance, spectrace_color_info *out, spectrace_error *err)
{
    Spd spd = {0};
    SptError e = {0};
    int rc;
    pthread_mutex_lock(&io_lock);
    rc = spd_text ? spd_parse(&spd, spd_text, &e)
         : count > 0 && nm && value ? spd_from_samples(&spd, nm, value, count, &e)
                                    : spt_fail(&e, SPT_EXIT_USAGE, "color: no SPD given");
    pthread_mutex_unlock(&io_lock);
    if (rc)
        return pass(err, &e, rc);
    const char *name = spd_text ? spd_text : "the SPD";
    double xyz[3];
    if (reflectance) {
        spd_reflectance_to_xyz(&spd, xyz);
    } else {
        spd_to_xyz(&spd, xyz);
        if (!(xyz[1] > 0.0)) {
            spd_free(&spd);
            return fail(err, SPECTRACE_ERR_INPUT, "%s: the SPD has no luminance (Y = %g), so it cannot "
                        "be normalised to Y = 1", name, xyz[1]);
        }
        double y = xyz[1];
        for (int k = 0; k < 3; k++)
            xyz[k] /= y;
    }
    spd_free(&spd);
    if (!isfinite(xyz[0]) || !isfinite(xyz[1]) || !isfinite(xyz[2]))
        return fail(err, SPECTRACE_ERR_INPUT, "%s: the SPD's colour is not finite (XYZ %g %g %g)", name,
                    xyz[0], xyz[1], xyz[2]);
    memcpy(out->xyz, xyz, sizeof xyz);
    xyz_to_linear_srgb(xyz, out->linear_srgb);
    for (int k = 0; k < 3; k++)
        out->srgb8[k] = srgb_to_8bit(out->linear_srgb[k]);
    double sum = xyz[0] + xyz[1] + xyz[2];
    out->x = sum > 0 ? xyz[0] / sum : 0;
    out->y = sum > 0 ? xyz[1] / sum : 0;
    return SPECTRACE_OK;
}
