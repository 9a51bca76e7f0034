/* spectrace render: load a glTF scene, render it on OpenCL devices, write the
 * outputs. The options are those of src/render/render_options.h (parsed by
 * src/api/render_args.c). A client of the library's API (src/api/spectrace.h):
 * one image (render_image_api) or a frame sequence (render_frames, one scene
 * posed at each frame's time); build/spectrace-mpi spreads the renders over
 * its ranks inside the library (src/mpi/mpi_hook.h). */
#include <math.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include <strings.h>

#include "api/render_args.h"
#include "api/spectrace.h"
#include "cl/cl_device.h"
#include "cli/commands.h"
#include "core/input_file.h"
#include "core/util.h"
#include "io/denoise.h"
#include "io/image_out.h"
#include "mpi/mpi_hook.h"
#include "render/checkpoint.h"
#include "render/render.h"

/* Everything one `spectrace render` holds. */
typedef struct RenderJob {
    RenderArgs a;
    char def_exr[512], def_png[512]; /* the default output names */
    Denoiser den; /* --denoise: Open Image Denoise, opened to fail before any work */
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
 * (the command line's own, -o, --device, -q, --frames, are not settings);
 * at, checkpoint and resume as a frame of --frames has them (frame_names). */
static spectrace_settings *settings_of(const RenderArgs *a, spectrace_error *err)
{
    spectrace_settings *set = spectrace_settings_new();
    char value[4096];
    for (int i = 0; i < SPT_ARG_COUNT; i++) {
        if (!a->given[i] || i == SPT_ARG_outputs || i == SPT_ARG_device || i == SPT_ARG_quiet ||
            i == SPT_ARG_help || i == SPT_ARG_frames || i == SPT_ARG_at ||
            i == SPT_ARG_checkpoint || i == SPT_ARG_resume)
            continue;
        render_args_format(a, i, value, sizeof value);
        if (spectrace_settings_set(set, render_args_option_name(i), value, err)) {
            spectrace_settings_free(set);
            return NULL;
        }
    }
    if ((a->rs.at && spectrace_settings_set(set, "at", a->rs.at, err)) ||
        (a->checkpoint && spectrace_settings_set(set, "checkpoint", a->checkpoint, err)) ||
        (a->resume && spectrace_settings_set(set, "resume", a->resume, err))) {
        spectrace_settings_free(set);
        return NULL;
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

/* What one image through the library holds; a frame sequence keeps the
 * renderer and the scene from frame to frame. */
typedef struct ApiRender {
    spectrace_settings *set;
    spectrace_scene *scene;
    spectrace_renderer *r;
    spectrace_image *img;
    int frames; /* --frames: the scene keeps its programs and buffers */
} ApiRender;

/* The devices of --device, named on stderr unless quiet. */
static int open_renderer(const RenderArgs *a, ApiRender *x, spectrace_error *err)
{
    if (!(x->r = spectrace_renderer_open(a->device, err)))
        return err->code;
    for (int i = 0; i < spectrace_renderer_device_count(x->r) && !a->quiet; i++) {
        spectrace_device_info d;
        spectrace_renderer_device_info(x->r, i, &d, NULL);
        fprintf(stderr, "device %d: %s (%s, %s)\n", d.index, d.name, d.platform, d.driver);
    }
    return SPT_EXIT_OK;
}

/* One image as spectrace_* calls: the scene loaded (a frame sequence's
 * later frames: posed at their time t), the outputs checked against the
 * inputs, the devices (once), the device arrays and memory, the render and
 * the outputs, with the messages, notes and exit codes of
 * docs/architecture.md ("Source layout"). */
static int api_steps(const RenderArgs *a, ApiRender *x, double t)
{
    spectrace_error err = {0};
    const char *const *outputs = (const char *const *)a->outputs;
    if (!(x->set = settings_of(a, &err)) ||
        (x->scene ? spectrace_scene_set_time(x->scene, t, &err)
                  : !(x->scene = spectrace_scene_load(a->scene, x->set, &err))) ||
        spectrace_scene_check_outputs(x->scene, x->set, outputs, a->outputs_count, &err) ||
        (!x->r && open_renderer(a, x, &err)))
        return report_api(&err);
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
    /* One image: the programs and device buffers are not needed for writing. */
    if (!x->frames)
        spectrace_scene_release_devices(x->scene);
    if (spectrace_image_write_outputs(x->img, outputs, a->outputs_count, &err))
        return report_api(&err);
    report_written(a, st.checkpoint, st.checkpoint_spp);
    return SPT_EXIT_OK;
}

/* What api_steps made for one image (a frame sequence keeps the renderer
 * and the scene). */
static void image_free(ApiRender *x)
{
    spectrace_image_free(x->img);
    spectrace_settings_free(x->set);
    x->img = NULL;
    x->set = NULL;
}

static void api_free(ApiRender *x)
{
    image_free(x);
    spectrace_renderer_close(x->r);
    spectrace_scene_free(x->scene);
}

static int render_image_api(const RenderArgs *a)
{
    ApiRender x = {0};
    int rc = api_steps(a, &x, NAN);
    api_free(&x);
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
    if (rc)
        spt_report(&e);
    /* One renderer and one scene for every frame: the scene keeps its
     * programs and buffers, and is posed at each frame's time
     * (spectrace_scene_set_time, which refits the last frame's BVH). */
    ApiRender x = {.frames = 1};
    spectrace_error err = {0};
    if (!rc && open_renderer(a, &x, &err))
        rc = report_api(&err);
    if (rc) {
        free(names);
        return rc;
    }
    a->quiet = 1; /* one line per frame instead of the render's own */
    spt_warn_repeats(0);
    double t0 = spt_now();
    long total = (a->frame_last - a->frame_first) / a->frame_step + 1;
    for (long f = a->frame_first; f <= a->frame_last && !stop_requested; f += a->frame_step) {
        frame_names(a, pat, npat, ckpt, resume, f, names);
        snprintf(at, sizeof at, "%.17g", (double)f / a->fps);
        a->rs.at = at;
        double tf = spt_now();
        int frc = api_steps(a, &x, (double)f / a->fps);
        if (!frc && !quiet) {
            spectrace_scene_timing tm;
            spectrace_scene_timing_get(x.scene, &tm);
            fprintf(stderr, "frame %ld (%.4g s): %d spp in %.2f s (scene %.2f s, BVH %s in %.4f s)",
                    f, (double)f / a->fps, spectrace_image_spp(x.img), spt_now() - tf,
                    tm.load_seconds, tm.bvh_refitted ? "refitted" : "built", tm.bvh_seconds);
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
        image_free(&x);
    }
    a->rs.at = NULL;
    spt_warn_repeats(1);
    spectrace_scene_stats ss = {0};
    if (x.scene)
        spectrace_scene_stats_get(x.scene, &ss);
    if (!quiet)
        fprintf(stderr, "rendered %ld of %ld frames in %.2f s (%d program build%s)\n",
                written, total, spt_now() - t0, ss.program_builds,
                ss.program_builds == 1 ? "" : "s");
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
    api_free(&x);
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
        /* Through the library: one image, or a frame sequence; spectrace-mpi
         * spreads the renders over its ranks (docs/architecture.md, "Source
         * layout"). */
        rc = j->a.frame_step ? render_frames(j) : render_image_api(&j->a);
    signals_restore();
    /* A kernel build given up at a second signal still runs in its thread:
     * exit's clean-up of the OpenCL implementation could meet it, so the
     * process ends here (nothing of ours is left to write or remove). */
    if (cl_builds_abandoned()) {
        fflush(NULL);
        _exit(rc);
    }
    denoiser_close(&j->den);
    free(j);
    input_seen_reset();
    return rc;
}
