/* spectrace render: load a glTF scene, render it on OpenCL devices, write the
 * outputs. The options are those of src/render/render_options.h (parsed by
 * src/api/render_args.c). One image is a client of the library's API
 * (render_image_api: spectrace_* calls); frame sequences and spectrace-mpi's
 * renders over ranks run the renderer's steps below (render_image), as
 * docs/architecture.md ("Source layout") says why. */
#include <math.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include <strings.h>

#include "api/output_check.h"
#include "api/render_args.h"
#include "api/render_stats.h"
#include "api/spectrace.h"
#include "cl/cl_device.h"
#include "cli/commands.h"
#include "core/input_file.h"
#include "core/util.h"
#include "io/denoise.h"
#include "io/image_out.h"
#include "mpi/mpi_hook.h"
#include "render/checkpoint.h"
#include "render/film.h"
#include "render/render.h"
#include "render/render_result.h"
#include "render/test_hooks.h"
#include "scene/scene.h"
#include "scene/sky.h"

#define MAX_DEVICES 64

/* Everything one `spectrace render` holds, freed by job_free. */
typedef struct RenderJob {
    RenderArgs a;
    char def_exr[512], def_png[512]; /* the default output names */
    Sky sky;
    Scene scene;
    ClDeviceList devices;
    const ClDeviceInfo *devs[MAX_DEVICES];
    int nsel;
    GpuScene gpu;
    Film film;
    CheckpointRun ckpt;
    RenderStats st;
    RenderDeviceStats per_dev[MAX_DEVICES];
    float *rgb;
    RenderImageMeta meta; /* the outputs' metadata; AOV, spectral and noisy channels */
    Denoiser den;        /* --denoise: Open Image Denoise, loaded before rendering */
    float *noisy;        /* --denoise: the image before denoising */
    double denoise_seconds;
    int sky_loaded;      /* the sky is read once, for every frame */
    /* --frames (render_frames): the programs kept for every frame; the last
     * frame's BVH and the triangles it indexes (count, vertex indices,
     * materials), which the next frame refits when only their positions
     * moved; how long this frame's scene load and BVH took. */
    RenderPrograms programs;
    Bvh last_bvh;
    uint32_t last_tri_count;
    uint32_t *last_vidx, *last_mat;
    int refitted;
    double load_seconds, bvh_seconds;
} RenderJob;

static volatile sig_atomic_t stop_requested;
static int signal_quiet; /* -q: on_signal prints nothing */

/* SIGINT, SIGTERM and SIGHUP: the first stops after the current chunks (and
 * writes what is complete; a long chunk, render/wavefront.h, is dropped at
 * once), a second stops at once, dropping the chunks in progress. */
static void on_signal(int sig)
{
    (void)sig;
    static const char first[] = "note: stopping after the current chunk, or at once if it "
                                "is long (a second signal stops at once)\n";
    /* The flag before the note: whoever reads the note and sends a second
     * signal finds the first one counted (that handler may run in another
     * thread while this one is still writing). */
    int first_signal = stop_requested == 0;
    stop_requested = first_signal ? 1 : 2;
    if (first_signal && !signal_quiet && write(2, first, sizeof first - 1) < 0)
        return; /* nothing to do when stderr is gone */
}

static struct sigaction old_int, old_term, old_hup;

static void signals_catch(void)
{
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    sigaction(SIGINT, &sa, &old_int);
    sigaction(SIGTERM, &sa, &old_term);
    sigaction(SIGHUP, &sa, &old_hup);
}

/* Once a signal was caught the run ends with exit 130, and a further signal
 * during the clean-up (one sent after the first was noted) must not kill the
 * process midway: the handler stays. */
static void signals_restore(void)
{
    if (stop_requested)
        return;
    sigaction(SIGINT, &old_int, NULL);
    sigaction(SIGTERM, &old_term, NULL);
    sigaction(SIGHUP, &old_hup, NULL);
}

/* SCENE's file name without folder and extension, for default output names. */
static void scene_stem(const char *path, char *out, size_t n)
{
    const char *base = strrchr(path, '/');
    base = base ? base + 1 : path;
    snprintf(out, n, "%s", base);
    char *dot = strrchr(out, '.');
    if (dot && dot != out)
        *dot = 0;
}

/* The outputs (SCENE-NAME.exr and .png when none is given) and the checkpoint
 * file, checked before any work: a run that cannot write them fails at once. */
static int check_outputs(RenderJob *j, SptError *e)
{
    RenderArgs *a = &j->a;
    if (a->outputs_count == 0) {
        char stem[256];
        scene_stem(a->scene, stem, sizeof stem);
        snprintf(j->def_exr, sizeof j->def_exr, "%s.exr", stem);
        snprintf(j->def_png, sizeof j->def_png, "%s.png", stem);
        a->outputs[a->outputs_count++] = j->def_exr;
        a->outputs[a->outputs_count++] = j->def_png;
    }
    int rc, exr = 0;
    for (int i = 0; i < a->outputs_count; i++) {
        if ((rc = image_output_check(a->outputs[i], e)))
            return rc;
        size_t len = strlen(a->outputs[i]);
        exr |= len >= 4 && !strcasecmp(a->outputs[i] + len - 4, ".exr");
    }
    if ((a->rs.aov || a->rs.spectral) && !exr)
        return spt_fail(e, SPT_EXIT_USAGE,
                        "render: --%s adds layers to an EXR output, and no output is an .exr "
                        "(add -o NAME.exr)", a->rs.aov ? "aov" : "spectral");
    /* --denoise without the library fails here, before any rendering. */
    if (a->rs.denoise && (rc = denoiser_open(&j->den, e)))
        return rc;
    /* A checkpoint keeps the film's sums and the samples done, not the sums of
     * squares that adaptive sampling chooses its pixels by. */
    if (a->rs.adaptive == SPT_SWITCH_ON && spt_dist_render)
        return spt_fail(e, SPT_EXIT_USAGE,
                        "render: --adaptive on is not supported across MPI ranks");
    if (a->rs.adaptive == SPT_SWITCH_ON && (a->checkpoint || a->resume))
        return spt_fail(e, SPT_EXIT_USAGE, "render: --adaptive on cannot be combined with --%s",
                        a->checkpoint ? "checkpoint" : "resume");
    render_adaptive_resolve(&a->rs, !spt_dist_render && !a->checkpoint && !a->resume);
    if (a->checkpoint || a->resume)
        return checkpoint_path_check(a->checkpoint ? a->checkpoint : a->resume, e);
    return SPT_EXIT_OK;
}

/* After the inputs are read and before any work: no output (-o or the
 * checkpoint) may be one of the files read (scene, buffers, textures, the
 * environment map, SPD files), the checkpoint resumed, or another output
 * (outputs_check_not_inputs). */
static int check_outputs_are_not_inputs(const RenderJob *j, SptError *e)
{
    const RenderArgs *a = &j->a;
    InputList inputs;
    input_seen_copy(&inputs);
    int rc = outputs_check_not_inputs(&inputs, (const char *const *)a->outputs, a->outputs_count,
                                      a->checkpoint, a->resume, e);
    input_list_free(&inputs);
    return rc;
}

/* --instancing's values are the loader's (src/scene/scene.h). */
_Static_assert((int)SCENE_INSTANCING_AUTO == (int)SPT_SWITCH_AUTO &&
                   (int)SCENE_INSTANCING_OFF == (int)SPT_SWITCH_OFF &&
                   (int)SCENE_INSTANCING_ON == (int)SPT_SWITCH_ON,
               "ScenePose.instancing takes --instancing's value");

/* The sky of --env/--background, the scene, the check that no output replaces an
 * input, and the image size (--width 512 by default, the other side from the
 * camera's aspect ratio). */
static int load_scene(RenderJob *j, SptError *e)
{
    RenderSettings *rs = &j->a.rs;
    int rc;
    if (!j->sky_loaded) {
        input_seen_reset();
        if ((rc = sky_from_args(&j->sky, j->a.env, j->a.background, e)))
            return rc;
        j->sky_loaded = 1;
    }
    double t0 = spt_now();
    rc = scene_load_gltf_posed(&j->scene, j->a.scene,
                               &(ScenePose){rs->at ? strtod(rs->at, NULL) : NAN, rs->animation,
                                            rs->camera, rs->instancing},
                               e);
    j->load_seconds = spt_now() - t0;
    if (rc || (rc = check_outputs_are_not_inputs(j, e)))
        return rc;
    render_image_size(rs, &j->scene.camera);
    return SPT_EXIT_OK;
}

/* The devices of --device (named on stderr unless quiet). */
static int select_devices(RenderJob *j, SptError *e)
{
    int sel[MAX_DEVICES], rc;
    if ((rc = cl_device_list(&j->devices, e)) ||
        (rc = cl_device_select(&j->devices, j->a.device, sel, &j->nsel, e)))
        return rc;
    for (int i = 0; i < j->nsel; i++) {
        j->devs[i] = &j->devices.devices[sel[i]];
        if (!j->a.quiet)
            fprintf(stderr, "device %d: %s (%s, %s)\n", sel[i], j->devs[i]->name,
                    j->devs[i]->platform_name, j->devs[i]->driver_version);
    }
    return SPT_EXIT_OK;
}

/* Whether the scene has the last frame's triangles (count, vertices and
 * materials), which only their positions may have moved since. */
static int same_triangles(const RenderJob *j)
{
    const Scene *s = &j->scene;
    return j->last_bvh.nodes && s->tri_count == j->last_tri_count &&
           !memcmp(s->tri_vidx, j->last_vidx, (size_t)s->tri_count * 3 * sizeof(uint32_t)) &&
           !memcmp(s->tri_mat, j->last_mat, (size_t)s->tri_count * sizeof(uint32_t));
}

/* The scene as the devices' arrays: in a frame sequence, the last frame's BVH
 * refitted when only the triangles' positions moved (docs/gltf.md, "Frame
 * sequences"), else (or when the refit cannot index them) built. */
static int build_device_scene(RenderJob *j, SptError *e)
{
    double t0 = spt_now();
    j->refitted = 0;
    int rc;
    if (same_triangles(j) && !j->a.rs.test.bvh_rebuild &&
        bvh_refit(&j->last_bvh, j->scene.tri_pos, j->scene.tri_count, j->last_tri_count)) {
        j->refitted = 1;
        rc = gpu_scene_build_with(&j->gpu, &j->scene, &j->last_bvh, e);
    } else {
        bvh_free(&j->last_bvh);
        rc = gpu_scene_build(&j->gpu, &j->scene, e);
    }
    j->bvh_seconds = spt_now() - t0;
    return rc;
}

/* --profile's estimate of the host memory (render_host_memory, docs/limits.md
 * "The memory estimate"), unless quiet. */
static void report_memory(const RenderArgs *ra, const spectrace_memory *m)
{
    char a[32], b[32], c[32], d[32], f[32], g[32];
    if (ra->rs.profile && !ra->quiet)
        fprintf(stderr, "memory: about %s of host memory: %s loaded, %s for the render (film %s, "
                "then the larger of the render's %s and the outputs' %s)\n",
                spt_format_bytes(a, sizeof a, m->loaded + m->need),
                spt_format_bytes(b, sizeof b, m->loaded), spt_format_bytes(c, sizeof c, m->need),
                spt_format_bytes(d, sizeof d, m->film), spt_format_bytes(f, sizeof f, m->render),
                spt_format_bytes(g, sizeof g, m->outputs));
}

/* Before any device memory is taken: the host memory the render will take on
 * top of what is loaded, against what is available (render_host_memory). */
static int check_host_memory(RenderJob *j, SptError *e)
{
    RenderSettings *rs = &j->a.rs;
    rs->sky = &j->sky; /* render_memory reads the map's size */
    RenderHostMemory m;
    int rc = render_host_memory((const ClDeviceInfo *const *)j->devs, j->nsel, &j->gpu,
                                &j->scene.camera, rs, (const char *const *)j->a.outputs,
                                j->a.outputs_count, &m, e);
    report_memory(&j->a, &(spectrace_memory){m.loaded, m.need, m.film, m.render, m.outputs});
    return rc;
}

/* What the renderer needs beyond the options: the sky, progress, the stop flag,
 * the test hooks of the environment; and a warning when nothing lights the
 * scene. */
static void complete_settings(RenderJob *j)
{
    RenderSettings *rs = &j->a.rs;
    rs->sky = &j->sky;
    rs->progress = !j->a.quiet;
    rs->stop = &stop_requested;
    render_test_hooks_env(rs);
    render_warn_unlit(&j->gpu, &j->scene, &j->sky, rs->env_intensity, j->a.scene);
}

/* The render itself, on this process's devices or (spectrace-mpi) over MPI
 * ranks, resuming and checkpointing as asked; a signal stops it (on_signal). */
static int render(RenderJob *j, SptError *e)
{
    RenderArgs *a = &j->a;
    RenderSettings *rs = &a->rs;
    int rc = checkpoint_run_begin(&j->ckpt, a->scene, a->checkpoint, a->checkpoint_every,
                                  a->resume, rs, &j->film, e);
    if (rc)
        return rc;
    if (j->ckpt.resumed && !a->quiet)
        fprintf(stderr, "resuming %s: %u of %ld samples per pixel done\n", a->resume,
                j->ckpt.resumed, (long)rs->spp);
    const SceneCamera *cam = &j->scene.camera;
    rc = spt_dist_render ? spt_dist_render(j->devs, j->nsel, &j->gpu, &j->scene, cam, rs,
                                           &j->film, &j->st, j->per_dev, e)
                         : render_devices(j->devs, j->nsel, &j->gpu, cam, rs, &j->film, &j->st,
                                          j->per_dev, e);
    return rc;
}

/* The notes after a render: how it stopped and the samples dropped. */
static void report_notes(const RenderArgs *a, const spectrace_render_stats *st)
{
    if (stop_requested)
        spt_note("render: stopped by a signal after %u of %ld samples per pixel; writing them",
                 st->spp_done, (long)a->rs.spp);
    if (st->nan_dropped)
        spt_warn("render: %llu samples had NaN or infinite radiance and were dropped",
                 (unsigned long long)st->nan_dropped);
}

/* A film with a NaN or infinite pixel is never written (render_film_check). */
static int check_film(RenderJob *j)
{
    SptError e = {0};
    int rc = render_film_check(&j->film, &j->a.rs, j->a.scene, &e);
    return rc ? spt_report(&e) : SPT_EXIT_OK;
}

/* Speed and (with --profile) where the time went, unless quiet. */
static void report_speed(const RenderArgs *a, int width, int height,
                         const spectrace_render_stats *st)
{
    if (a->quiet)
        return;
    fprintf(stderr, "rendered %dx%d, %u spp in %.2f s (%.3f Mpaths/s; program build %.2f s)\n",
            width, height, st->spp_done, st->seconds,
            st->seconds > 0 ? st->paths / st->seconds * 1e-6 : 0.0, st->build_seconds);
    if (a->rs.profile) {
        /* Each stage's seconds, share, and time per path segment (closest-hit
         * ray); k_paths (the CPU devices' megakernel) runs the first four in one. */
        static const char *names[SPT_STAGES] = {"generate", "extend",     "shade",
                                                "connect",  "accumulate", "paths"};
        double tot = 0;
        for (int i = 0; i < SPT_STAGES; i++)
            tot += st->stage_seconds[i];
        fprintf(stderr, "  %llu path segments, %llu shadow rays\n",
                (unsigned long long)st->rays_extend, (unsigned long long)st->rays_shadow);
        for (int i = 0; i < SPT_STAGES; i++)
            if (st->stage_seconds[i] > 0 || i < 5)
                fprintf(stderr, "  %-10s %8.3f s  %5.1f%%  %7.1f ns/segment\n", names[i],
                        st->stage_seconds[i], tot > 0 ? 100.0 * st->stage_seconds[i] / tot : 0.0,
                        st->rays_extend ? st->stage_seconds[i] * 1e9 / (double)st->rays_extend
                                        : 0.0);
    }
}

/* The devices of the outputs' metadata (render_device_description), printed
 * unless quiet when the render had several. */
static void report_devices(const RenderArgs *a, int count, const char *description)
{
    if (count > 1 && !a->quiet)
        fprintf(stderr, "devices: %s\n", description);
}

/* --denoise: how long it took, with which library, unless quiet. */
static void report_denoise(const RenderArgs *a, double seconds, const char *library)
{
    if (!a->quiet)
        fprintf(stderr, "denoised in %.2f s (Open Image Denoise, %s)\n", seconds, library);
}

/* The outputs written, unless quiet, and the checkpoint's note (unless quiet
 * and not stopped by a signal). */
static void report_written(const RenderArgs *a, const char *checkpoint, uint32_t checkpoint_spp)
{
    for (int i = 0; i < a->outputs_count && !a->quiet; i++)
        fprintf(stderr, "wrote %s\n", a->outputs[i]);
    if (checkpoint && (!a->quiet || stop_requested))
        fprintf(stderr, "wrote checkpoint %s (%u spp; continue with --resume %s)\n", checkpoint,
                checkpoint_spp, checkpoint);
}

/* --denoise: the image (j->rgb) denoised (render_denoise); j->noisy keeps the
 * image as it was. */
static int denoise(RenderJob *j, SptError *e)
{
    const RenderSettings *rs = &j->a.rs;
    j->noisy = j->rgb;
    j->rgb = spt_malloc((size_t)rs->width * rs->height * 3 * sizeof(float));
    double t0 = spt_now();
    int rc = render_denoise(&j->den, &j->film, rs, j->noisy, j->rgb, e);
    j->denoise_seconds = spt_now() - t0;
    if (!rc)
        report_denoise(&j->a, j->denoise_seconds, j->den.path);
    return rc;
}

/* The film as every output image (with the render's metadata), then the final
 * checkpoint: all written to temporary files first and renamed over their names
 * only when every one was written, so a failed run (a full disk at the second
 * output) leaves every existing file as it was. */
static int write_outputs(RenderJob *j, SptError *e)
{
    const RenderArgs *a = &j->a;
    const RenderSettings *rs = &a->rs;
    j->rgb = spt_malloc((size_t)rs->width * rs->height * 3 * sizeof(float));
    film_to_linear_srgb(&j->film, j->rgb);
    int rc;
    if (rs->denoise && (rc = denoise(j, e)))
        return rc;
    char devdesc[4096];
    render_device_description(j->devs, j->nsel, j->per_dev, devdesc, sizeof devdesc);
    report_devices(a, j->nsel, devdesc);
    RenderImageMeta *m = &j->meta;
    render_image_meta(m, &j->film, rs, &j->st, devdesc, a->scene, 3);
    if (j->noisy)
        render_image_meta_noisy(m, j->noisy);
    DisplayOptions disp = {(float)a->exposure, a->tonemap};
    if ((rc = render_write_outputs((const char *const *)a->outputs, a->outputs_count, j->rgb,
                                   rs->width, rs->height, &m->meta, &disp, &j->ckpt.writer,
                                   &j->film, e)))
        return rc;
    spectrace_render_stats st;
    render_stats_public(&j->st, &j->ckpt, &st);
    report_written(a, st.checkpoint, st.checkpoint_spp);
    return SPT_EXIT_OK;
}

/* What one image holds (the posed scene, its device arrays, the film and the
 * outputs' memory), freed after each frame; the BVH and the triangles it
 * indexes are kept for the next frame's refit. */
static void image_free(RenderJob *j)
{
    checkpoint_run_free(&j->ckpt);
    free(j->rgb);
    free(j->noisy);
    render_image_meta_free(&j->meta);
    j->rgb = j->noisy = NULL;
    film_free(&j->film);
    if (j->gpu.bvh.nodes && j->programs.w && !j->scene.mesh_count) {
        bvh_free(&j->last_bvh);
        j->last_bvh = j->gpu.bvh;
        memset(&j->gpu.bvh, 0, sizeof j->gpu.bvh);
        size_t n = (size_t)j->scene.tri_count;
        j->last_tri_count = j->scene.tri_count;
        j->last_vidx = spt_realloc(j->last_vidx, (n ? n : 1) * 3 * sizeof(uint32_t));
        j->last_mat = spt_realloc(j->last_mat, (n ? n : 1) * sizeof(uint32_t));
        memcpy(j->last_vidx, j->scene.tri_vidx, n * 3 * sizeof(uint32_t));
        memcpy(j->last_mat, j->scene.tri_mat, n * sizeof(uint32_t));
    }
    gpu_scene_free(&j->gpu);
    scene_free(&j->scene);
    memset(&j->st, 0, sizeof j->st);
    memset(j->per_dev, 0, sizeof j->per_dev);
    /* What checkpoint_run_begin hooked in pointed into this image's run. */
    j->a.rs.done_in = NULL;
    j->a.rs.on_chunk = NULL;
    j->a.rs.on_chunk_ctx = NULL;
}

static void job_free(RenderJob *j)
{
    image_free(j);
    bvh_free(&j->last_bvh);
    free(j->last_vidx);
    free(j->last_mat);
    if (j->programs.w)
        render_programs_free(&j->programs);
    denoiser_close(&j->den);
    cl_device_list_free(&j->devices);
    sky_free(&j->sky);
}

/* One image: the scene posed as asked, the devices (chosen for the first
 * image), the render and the outputs. Every failure is reported here; returns
 * the exit code. */
static int render_image(RenderJob *j)
{
    SptError e = {0};
    int rc;
    if ((rc = load_scene(j, &e)) || (!j->nsel && (rc = select_devices(j, &e))) ||
        (rc = build_device_scene(j, &e)) || (rc = check_host_memory(j, &e))) {
        spt_report(&e);
    } else if (stop_requested) {
        spt_error("render: stopped by a signal before rendering; nothing written");
        rc = SPT_EXIT_INTERRUPTED;
    } else {
        complete_settings(j);
        if ((rc = render(j, &e))) {
            if (e.msg[0])
                spt_report(&e);
        } else if (j->st.spp_done == 0) {
            spt_error("render: stopped before any pass completed; nothing written");
            rc = SPT_EXIT_INTERRUPTED;
        } else {
            spectrace_render_stats st;
            render_stats_public(&j->st, &j->ckpt, &st);
            report_notes(&j->a, &st);
            if (!(rc = check_film(j))) {
                report_speed(&j->a, j->a.rs.width, j->a.rs.height, &st);
                if ((rc = write_outputs(j, &e)))
                    spt_report(&e);
            }
        }
    }
    return rc;
}

/* ---- One image through the library (src/api/spectrace.h) ---------------- */

/* The library's error as the command line reports it: its message after
 * "error: " (none when it has none), and its code as the exit code. */
static int report_api(const spectrace_error *err)
{
    if (err->message[0])
        spt_error("%s", err->message);
    return err->code ? err->code : SPT_EXIT_FAILURE;
}

/* The options given on the command line as the library's settings, by name
 * (the command line's own, -o, --device, -q, are not settings). */
static spectrace_settings *settings_of(const RenderArgs *a, spectrace_error *err)
{
    spectrace_settings *set = spectrace_settings_new();
    char value[4096];
    for (int i = 0; i < SPT_ARG_COUNT; i++) {
        if (!a->given[i] || i == SPT_ARG_outputs || i == SPT_ARG_device || i == SPT_ARG_quiet ||
            i == SPT_ARG_help)
            continue;
        render_args_format(a, i, value, sizeof value);
        if (spectrace_settings_set(set, render_args_option_name(i), value, err)) {
            spectrace_settings_free(set);
            return NULL;
        }
    }
    return set;
}

/* The progress line of the scheduler's display (src/render/scheduler.c):
 * rewritten in place on a terminal, else a plain line at every tenth. */
typedef struct ProgressLine {
    double time_limit;
    int decile, printed;
} ProgressLine;

static int on_progress(void *user, const spectrace_progress_info *p)
{
    ProgressLine *pl = user;
    double frac = p->total ? (double)p->done / p->total : 1.0;
    int tty = isatty(2), decile = (int)(frac * 10.0);
    if (!tty && decile == pl->decile)
        return 0;
    pl->decile = decile;
    pl->printed = 1;
    double rate = p->elapsed > 0 ? p->paths / p->elapsed : 0.0;
    double remain = frac > 0 ? p->elapsed * (1.0 - frac) / frac : 0.0;
    if (pl->time_limit > 0 && pl->time_limit - p->elapsed < remain)
        remain = pl->time_limit - p->elapsed > 0 ? pl->time_limit - p->elapsed : 0;
    fprintf(stderr, "%srender: %5.1f%%  %u/%u spp  %.2f Mpaths/s  %.1f s elapsed  %.1f s left%s",
            tty ? "\r" : "", 100.0 * frac, p->done, p->total, rate * 1e-6, p->elapsed, remain,
            tty ? "   " : "\n");
    fflush(stderr);
    return 0;
}

/* What one image through the library holds. */
typedef struct ApiRender {
    spectrace_settings *set;
    spectrace_scene *scene;
    spectrace_renderer *r;
    spectrace_image *img;
} ApiRender;

/* The steps of render_image (load, devices, device arrays and memory,
 * render, outputs) as spectrace_* calls: the same messages, notes and exit
 * codes. */
static int api_steps(const RenderArgs *a, ApiRender *x)
{
    spectrace_error err = {0};
    const char *const *outputs = (const char *const *)a->outputs;
    if (!(x->set = settings_of(a, &err)) || !(x->scene = spectrace_scene_load(a->scene, x->set, &err)) ||
        spectrace_scene_check_outputs(x->scene, x->set, outputs, a->outputs_count, &err) ||
        !(x->r = spectrace_renderer_open(a->device, &err)))
        return report_api(&err);
    for (int i = 0; i < spectrace_renderer_device_count(x->r) && !a->quiet; i++) {
        spectrace_device_info d;
        spectrace_renderer_device_info(x->r, i, &d, NULL);
        fprintf(stderr, "device %d: %s (%s, %s)\n", d.index, d.name, d.platform, d.driver);
    }
    spectrace_memory mem = {.need = -1.0};
    int rc = spectrace_render_prepare(x->r, x->scene, x->set, outputs, a->outputs_count, &mem, &err);
    if (mem.need >= 0)
        report_memory(a, &mem);
    if (rc)
        return report_api(&err);
    if (stop_requested) {
        spt_error("render: stopped by a signal before rendering; nothing written");
        return SPT_EXIT_INTERRUPTED;
    }
    ProgressLine pl = {a->rs.time_limit, -1, 0};
    spectrace_render_options o = {a->quiet ? NULL : on_progress, &pl, &stop_requested, 1,
                                  !a->quiet, 1};
    rc = spectrace_render_with(x->r, x->scene, x->set, &o, &x->img, &err);
    if (pl.printed && isatty(2))
        fputc('\n', stderr);
    if (rc)
        return report_api(&err);
    spectrace_render_stats st;
    spectrace_image_stats(x->img, &st);
    report_notes(a, &st);
    report_speed(a, spectrace_image_width(x->img), spectrace_image_height(x->img), &st);
    if (st.denoiser)
        report_denoise(a, st.denoise_seconds, st.denoiser);
    report_devices(a, spectrace_renderer_device_count(x->r), st.devices);
    /* The programs and device buffers are not needed for writing. */
    spectrace_scene_release_devices(x->scene);
    if (spectrace_image_write_outputs(x->img, outputs, a->outputs_count, &err))
        return report_api(&err);
    report_written(a, st.checkpoint, st.checkpoint_spp);
    return SPT_EXIT_OK;
}

static int render_image_api(const RenderArgs *a)
{
    ApiRender x = {0};
    int rc = api_steps(a, &x);
    spectrace_image_free(x.img);
    spectrace_renderer_close(x.r);
    spectrace_scene_free(x.scene);
    spectrace_settings_free(x.set);
    return rc;
}

/* --frames: name (an -o or --checkpoint name) for frame f: its last run of
 * '#' replaced by f with as many digits, zeros in front (Blender's rule), or
 * without '#' f in four digits before the file name's extension (at its end
 * when it has none). */
static void frame_name(const char *name, long f, char *out, size_t cap)
{
    const char *end = strrchr(name, '#');
    if (end) {
        const char *run = end;
        while (run > name && run[-1] == '#')
            run--;
        snprintf(out, cap, "%.*s%0*ld%s", (int)(run - name), name, (int)(end + 1 - run), f,
                 end + 1);
        return;
    }
    const char *base = strrchr(name, '/');
    base = base ? base + 1 : name;
    const char *dot = strrchr(base, '.');
    if (!dot || dot == base)
        dot = name + strlen(name);
    snprintf(out, cap, "%.*s%04ld%s", (int)(dot - name), name, f, dot);
}

#define FRAME_NAME_MAX 4096

/* The names of frame f (outputs, checkpoint, resume) from the patterns into
 * names, pointed to by a. --resume's frame without its file starts afresh,
 * checkpointing to that name. */
static void frame_names(RenderArgs *a, const char *const *pat, int npat, const char *ckpt,
                        const char *resume, long f, char (*names)[FRAME_NAME_MAX])
{
    for (int i = 0; i < npat; i++) {
        frame_name(pat[i], f, names[i], FRAME_NAME_MAX);
        a->outputs[i] = names[i];
    }
    a->checkpoint = a->resume = NULL;
    if (ckpt) {
        frame_name(ckpt, f, names[npat], FRAME_NAME_MAX);
        a->checkpoint = names[npat];
    }
    if (resume) {
        frame_name(resume, f, names[npat + 1], FRAME_NAME_MAX);
        if (access(names[npat + 1], F_OK) == 0)
            a->resume = names[npat + 1];
        else if (!a->checkpoint)
            a->checkpoint = names[npat + 1];
    }
}

/* --frames A:B[:STEP]: each frame posed at its time F / --fps (as `--at`
 * would pose it, the time written with 17 digits so that it reads back the
 * same), rendered and written under its own names with the programs built
 * once; a frame that fails is reported and the others go on. One line per
 * frame unless quiet. Returns 0, the exit code of the first frame that
 * failed, or SPT_EXIT_INTERRUPTED when a signal left frames unrendered
 * (README.md, "Frame sequences"). */
static int render_frames(RenderJob *j)
{
    RenderArgs *a = &j->a;
    int quiet = a->quiet, npat = a->outputs_count, rc = SPT_EXIT_OK, failed = 0;
    long written = 0, last = a->frame_first;
    const char *pat[SPT_MAX_OUTPUTS], *ckpt = a->checkpoint, *resume = a->resume;
    char (*names)[FRAME_NAME_MAX] = spt_malloc((size_t)(npat + 2) * FRAME_NAME_MAX);
    char at[64], failed_list[256] = "";
    memcpy(pat, a->outputs, sizeof pat);
    /* Every frame's names before any work: a run that cannot write them fails
     * at once. */
    SptError e = {0};
    for (long f = a->frame_first; f <= a->frame_last && !rc; f += a->frame_step) {
        frame_names(a, pat, npat, ckpt, resume, f, names);
        for (int i = 0; i < npat && !rc; i++)
            rc = image_output_check(a->outputs[i], &e);
    }
    if (rc || (rc = select_devices(j, &e))) {
        spt_report(&e);
        free(names);
        return rc;
    }
    render_programs_init(&j->programs, j->nsel);
    a->rs.programs = &j->programs;
    a->quiet = 1; /* one line per frame instead of the render's own */
    spt_warn_repeats(0);
    double t0 = spt_now();
    long total = (a->frame_last - a->frame_first) / a->frame_step + 1;
    for (long f = a->frame_first; f <= a->frame_last && !stop_requested; f += a->frame_step) {
        frame_names(a, pat, npat, ckpt, resume, f, names);
        snprintf(at, sizeof at, "%.17g", (double)f / a->fps);
        a->rs.at = at;
        double tf = spt_now();
        int frc = render_image(j);
        if (!frc && !quiet) {
            fprintf(stderr, "frame %ld (%.4g s): %u spp in %.2f s (scene %.2f s, BVH %s in %.4f s)",
                    f, (double)f / a->fps, j->st.spp_done, spt_now() - tf, j->load_seconds,
                    j->refitted ? "refitted" : "built", j->gpu.bvh.stats.build_seconds);
            for (int i = 0; i < npat; i++)
                fprintf(stderr, "%s%s", i ? ", " : ": ", a->outputs[i]);
            fputc('\n', stderr);
        }
        if (frc && frc != SPT_EXIT_INTERRUPTED) {
            if (!failed++)
                rc = frc;
            size_t len = strlen(failed_list);
            if (len < sizeof failed_list - 16)
                snprintf(failed_list + len, sizeof failed_list - len, "%s%ld", len ? ", " : "", f);
            else if (!strstr(failed_list, "..."))
                strcat(failed_list, ", ...");
            if (!quiet)
                fprintf(stderr, "frame %ld (%.4g s): failed (exit %d)\n", f, (double)f / a->fps, frc);
        }
        written += !frc;
        last = f;
        image_free(j);
    }
    a->rs.at = NULL;
    spt_warn_repeats(1);
    if (!quiet)
        fprintf(stderr, "rendered %ld of %ld frames in %.2f s (%d program build%s)\n",
                written, total, spt_now() - t0, j->programs.builds,
                j->programs.builds == 1 ? "" : "s");
    if (failed)
        spt_error("render: %d of %ld frames failed (frame%s %s); %s", failed, total,
                  failed == 1 ? "" : "s", failed_list,
                  written ? "the others were written" : "nothing written");
    if (!rc && stop_requested && written + failed < total) {
        spt_error("render: stopped by a signal at frame %ld; %ld of %ld frames not written", last,
                  total - written - failed, total);
        rc = SPT_EXIT_INTERRUPTED;
    }
    a->quiet = quiet;
    free(names);
    return rc;
}

int cmd_render(int argc, char **argv)
{
    RenderJob *j = spt_calloc(1, sizeof *j);
    SptError e = {0};
    int rc = render_args_parse(&j->a, argc, argv);
    if (rc || j->a.help) {
        free(j);
        return rc;
    }
    /* Signals are caught from the start: one during loading ends the run once
     * the step in progress is over (exit 130, nothing written). */
    stop_requested = 0;
    signal_quiet = j->a.quiet;
    signals_catch();
    if ((rc = check_outputs(j, &e)))
        spt_report(&e);
    else
        /* One image through the library; frame sequences, and spectrace-mpi's
         * renders over ranks, on the renderer's own steps (docs/architecture.md,
         * "Source layout"). */
        rc = j->a.frame_step ? render_frames(j) : spt_dist_render ? render_image(j)
                                                                  : render_image_api(&j->a);
    signals_restore();
    /* A kernel build given up at a second signal still runs in its thread:
     * exit's clean-up of the OpenCL implementation could meet it, so the
     * process ends here (nothing of ours is left to write or remove). */
    if (cl_builds_abandoned()) {
        fflush(NULL);
        _exit(rc);
    }
    job_free(j);
    free(j);
    input_seen_reset();
    return rc;
}
