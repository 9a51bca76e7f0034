/* The scheduler of a render: one worker thread per device (one or several),
 * each with its own wavefront (src/render/wavefront.h), taking chunks of
 * samples from one counter, so a faster device takes more; the chunks of a
 * device that fails go back to the others; under --adaptive the chunks go
 * segment by segment to the pixels adaptive.c chooses (docs/architecture.md,
 * "Scale: the sample is the unit of work", "Adaptive sampling"). What every
 * chunk shares is set up by render_params.c and light_plan.c. */
#include "render/render.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <pthread.h>
#include <unistd.h>

#include "render/adaptive.h"
#include "render/light_plan.h"
#include "render/render_lights.h"
#include "render/render_params.h"
#include "render/wavefront.h"

/* The progress display: one line rewritten in place on a terminal, else a plain
 * line at every tenth of the work. */
static void progress_print(const RenderSettings *rs, uint32_t done, uint32_t total,
                           double elapsed, uint64_t paths, int *last_decile)
{
    if (!rs->progress)
        return;
    double frac = total ? (double)done / total : 1.0;
    int tty = isatty(2);
    int decile = (int)(frac * 10.0);
    if (!tty && decile == *last_decile)
        return;
    *last_decile = decile;
    double rate = elapsed > 0 ? paths / elapsed : 0.0;
    double remain = frac > 0 ? elapsed * (1.0 - frac) / frac : 0.0;
    if (rs->time_limit > 0 && rs->time_limit - elapsed < remain)
        remain = rs->time_limit - elapsed > 0 ? rs->time_limit - elapsed : 0;
    fprintf(stderr, "%srender: %5.1f%%  %u/%u spp  %.2f Mpaths/s  %.1f s elapsed  %.1f s left%s",
            tty ? "\r" : "", 100.0 * frac, done, total, rate * 1e-6, elapsed, remain,
            tty ? "   " : "\n");
    fflush(stderr);
}

/* Hands out chunks of sample indices to the devices, in order, and takes back
 * the chunks of devices that failed. Every field is guarded by lock. */
typedef struct Scheduler {
    pthread_mutex_t lock;
    const RenderSettings *rs;
    uint32_t next;            /* next sample index (relative to sample_begin) to hand out */
    uint32_t total;           /* samples per pixel asked for */
    uint32_t *ret_begin, *ret_n; /* chunks given back by failed devices */
    int active;               /* workers rendering a chunk right now */
    int ret_count;
    unsigned char *done;      /* per relative sample index: rendered into a film */
    uint32_t done_count;
    uint64_t paths;
    double t0;                /* the render's start (sched_start); 0 before it */
    int decile;
    Film *film;               /* every completed chunk is added here */
    int workers;              /* devices rendering */
    int turn;                 /* with rs->test.take_turns: the worker whose turn it is */
    unsigned char *gone;      /* per worker: has stopped taking chunks */
    int deadline;             /* a worker stopped because no sample fits the time left */
    /* Adaptive sampling (rs->adaptive; src/render/adaptive.h): chunks stay
     * within the segment [seg_end / 2, seg_end) of the sample indices (the
     * first is [0, SPT_ADAPTIVE_FIRST)), the next segment starts when all of
     * this one is done, with lag (per pixel: the lag of its own samples
     * behind the segment's, or SPT_PIXEL_SKIP) whose generation mask_gen the
     * workers compare with what they uploaded; taken: per pixel, its samples
     * up to the end of the segment. */
    int adaptive;
    uint32_t seg_end;
    uint32_t *lag;
    uint32_t *taken;
    int mask_gen;
    double *sq;               /* per pixel, the sums of the squares of linear sRGB */
} Scheduler;

/* Passes the turn to the next worker still taking chunks. */
static void sched_pass_turn(Scheduler *s)
{
    for (int k = 1; k <= s->workers; k++) {
        int t = (s->turn + k) % s->workers;
        if (!s->gone[t]) {
            s->turn = t;
            return;
        }
    }
}

/* Whether worker who must wait for its turn (rs->test.take_turns) to take the next
 * chunk from the counter. */
static int sched_not_my_turn(const Scheduler *s, int who)
{
    const RenderSettings *rs = s->rs;
    return rs->test.take_turns && s->turn != who && s->ret_count == 0 && s->next < s->total &&
           !rs->take_chunk;
}

/* Takes up to want samples into [*begin, *begin + *n) for worker who; 0 when
 * nothing is left or the render must stop (signal, time limit). */
static int sched_take(Scheduler *s, int who, uint32_t want, uint32_t *begin, uint32_t *n)
{
    int ok = 0;
    const RenderSettings *rs = s->rs;
    pthread_mutex_lock(&s->lock);
    /* Nothing to hand out while another device still renders: wait, since a
     * failure there gives its chunk back. */
    while (((s->ret_count == 0 && s->next >= s->total && !rs->take_chunk && s->active > 0) ||
            (s->adaptive && s->ret_count == 0 && s->next >= s->seg_end && s->next < s->total &&
             s->active > 0) ||
            sched_not_my_turn(s, who)) &&
           !(rs->stop && *rs->stop)) {
        pthread_mutex_unlock(&s->lock);
        usleep(2000);
        pthread_mutex_lock(&s->lock);
    }
    int stopping = (rs->stop && *rs->stop) ||
                   (rs->time_limit > 0 && spt_now() - s->t0 >= rs->time_limit);
    if (!stopping) {
        if (s->ret_count > 0) {
            s->ret_count--;
            *begin = s->ret_begin[s->ret_count];
            *n = s->ret_n[s->ret_count];
            ok = 1;
        } else if (rs->take_chunk) {
            ok = rs->take_chunk(rs->chunk_ctx, want, begin, n);
        } else {
            /* The next run of samples not done yet, at most want long (and
             * within the adaptive segment, which ends when all of it is done:
             * the next one's mask follows from the film then). */
            while (s->next < s->total && s->done[s->next])
                s->next++;
            if (s->adaptive && s->next >= s->seg_end && s->next < s->total) {
                /* The pixels the mask keeps take the segment's c samples as
                 * their next c (the first of their own sequence still unused). */
                const Film *f = s->film;
                uint32_t npix = (uint32_t)(f->width * f->height), c = s->seg_end;
                adaptive_mask((uint32_t)f->width, (uint32_t)f->height, f->xyz, f->count, s->sq, c,
                              s->lag);
                for (uint32_t i = 0; i < npix; i++) {
                    if (s->lag[i]) {
                        s->lag[i] = c - s->taken[i];
                        s->taken[i] += c;
                    } else {
                        s->lag[i] = SPT_PIXEL_SKIP;
                    }
                }
                s->seg_end *= 2u;
                s->mask_gen++;
            }
            uint32_t end = s->adaptive && s->seg_end < s->total ? s->seg_end : s->total;
            if (s->next < end) {
                uint32_t k = 0;
                while (k < want && s->next + k < end && !s->done[s->next + k])
                    k++;
                *begin = s->next;
                *n = k;
                s->next += k;
                ok = 1;
                if (rs->test.take_turns)
                    sched_pass_turn(s);
            }
        }
    }
    s->active += ok;
    pthread_mutex_unlock(&s->lock);
    return ok;
}

uint32_t render_deadline_chunk(uint32_t want, double left, double per_sample)
{
    if (want == 0 || !(left > 0.0))
        return 0;
    if (!(per_sample > 0.0))
        return 1;
    double fit = left / per_sample;
    if (fit < 1.0)
        return 0;
    double n = floor(0.5 * fit);
    if (n < 1.0)
        n = 1.0;
    return n < (double)want ? (uint32_t)n : want;
}

/* A device is ready to render (its program built, its buffers made): the
 * render's time, which --time limits, starts with the first such device, so
 * that a kernel build (seconds, or minutes on some implementations when not
 * cached) is not counted against it (README.md, "--time"). */
static void sched_start(Scheduler *s)
{
    pthread_mutex_lock(&s->lock);
    if (s->t0 == 0.0)
        s->t0 = spt_now();
    pthread_mutex_unlock(&s->lock);
}

/* Worker who takes no more chunks. */
static void sched_leave(Scheduler *s, int who)
{
    pthread_mutex_lock(&s->lock);
    s->gone[who] = 1;
    if (s->turn == who)
        sched_pass_turn(s);
    pthread_mutex_unlock(&s->lock);
}

static void sched_give_back(Scheduler *s, uint32_t begin, uint32_t n)
{
    pthread_mutex_lock(&s->lock);
    if (s->rs->give_back) {
        s->rs->give_back(s->rs->chunk_ctx, begin, n);
        s->active--;
        pthread_mutex_unlock(&s->lock);
        return;
    }
    s->ret_begin = spt_realloc(s->ret_begin, (size_t)(s->ret_count + 1) * sizeof(uint32_t));
    s->ret_n = spt_realloc(s->ret_n, (size_t)(s->ret_count + 1) * sizeof(uint32_t));
    s->ret_begin[s->ret_count] = begin;
    s->ret_n[s->ret_count] = n;
    s->ret_count++;
    s->active--;
    pthread_mutex_unlock(&s->lock);
}

static void sched_done(Scheduler *s, uint32_t begin, uint32_t n, uint64_t paths, const float *sums,
                       const float *aov_sums, const float *spec_sums, const float *sq_sums)
{
    pthread_mutex_lock(&s->lock);
    film_add_chunk(s->film, sums, aov_sums, spec_sums);
    if (s->sq && sq_sums) {
        size_t npix = (size_t)s->film->width * s->film->height;
        for (size_t i = 0; i < npix; i++)
            for (int k = 0; k < 3; k++)
                s->sq[3 * i + k] += ldexp((double)sq_sums[4 * i + k], 2 * (int)sq_sums[4 * i + 3]);
    }
    for (uint32_t i = 0; i < n; i++)
        s->done[begin + i] = 1;
    s->done_count += n;
    s->active--;
    s->paths += paths;
    double elapsed = spt_now() - s->t0;
    progress_print(s->rs, s->done_count, s->total, elapsed, s->paths, &s->decile);
    if (s->rs->on_progress)
        s->rs->on_progress(s->rs->on_progress_ctx, s->done_count, s->total, elapsed, s->paths);
    if (s->rs->on_chunk)
        s->rs->on_chunk(s->rs->on_chunk_ctx, s->film, s->done, s->total);
    pthread_mutex_unlock(&s->lock);
}

typedef struct Worker {
    int index;                 /* position in the selection */
    const RenderParams *base;  /* the parameters every chunk shares */
    const RenderLights *lights;
    const ClDeviceInfo *info;
    const GpuScene *g;
    const SceneCamera *cam;
    Scheduler *s;
    RenderStats st;
    double busy_seconds;       /* time spent rendering chunks */
    uint32_t samples;          /* samples per pixel it rendered */
    int rc;
    SptError e;
    char *build_log;
} Worker;

void render_programs_init(RenderPrograms *p, int count)
{
    memset(p, 0, sizeof *p);
    p->count = count;
    p->w = spt_calloc((size_t)(count > 0 ? count : 1), sizeof *p->w);
}

void render_programs_free(RenderPrograms *p)
{
    for (int i = 0; i < p->count; i++)
        if (p->w[i]) {
            wavefront_free(p->w[i]);
            free(p->w[i]);
        }
    free(p->w);
    memset(p, 0, sizeof *p);
}

/* The worker's wavefront: with kept programs (rs->programs) the device's kept
 * one, opened (and counted) by the first render, and again by a render
 * whose kernel options differ, and given this render's buffers; else its
 * own, *own. */
static int worker_wavefront(Worker *wk, Wavefront *own, Wavefront **out)
{
    const RenderSettings *rs = wk->s->rs;
    RenderPrograms *keep = rs->programs;
    uint32_t light_film = wk->base->light_paths;
    if (!keep) {
        *out = own;
        return wavefront_create(own, wk->info, wk->g, rs, wk->lights, light_film, &wk->e);
    }
    Wavefront **slot = &keep->w[wk->index];
    int rc = 0, fits = *slot ? wavefront_fits(*slot, wk->g, rs) : SPT_WAVEFRONT_REOPEN;
    if (*slot && fits == SPT_WAVEFRONT_REOPEN) {
        wavefront_free(*slot);
        free(*slot);
        *slot = NULL;
    }
    if (!*slot) {
        *slot = spt_calloc(1, sizeof **slot);
        rc = wavefront_create(*slot, wk->info, wk->g, rs, wk->lights, light_film, &wk->e);
        __atomic_add_fetch(&keep->builds, 1, __ATOMIC_SEQ_CST);
    } else {
        (*slot)->dev.last_build_seconds = 0.0;
        (*slot)->uploaded = 0;
        if (fits == SPT_WAVEFRONT_REBUILD) {
            rc = wavefront_program(*slot, wk->g, rs, &wk->e);
            __atomic_add_fetch(&keep->builds, 1, __ATOMIC_SEQ_CST);
        }
        if (!rc)
            rc = wavefront_buffers(*slot, wk->g, rs, wk->lights, light_film, &wk->e);
    }
    /* What went to the device, counted under the scheduler's lock. */
    pthread_mutex_lock(&wk->s->lock);
    for (int i = 0; i < SPT_SCENE_BUFFER_COUNT; i++)
        if ((*slot)->uploaded & (1u << i)) {
            keep->uploads[i]++;
            keep->upload_bytes += (*slot)->scene_bytes[i];
        }
    pthread_mutex_unlock(&wk->s->lock);
    *out = *slot;
    return rc;
}

/* After the worker's last chunk: a kept wavefront keeps its program, and with
 * keep_scene its scene buffers, unless the render failed on it (the next
 * render opens the device again). */
static void worker_wavefront_done(Worker *wk, Wavefront *w)
{
    RenderPrograms *keep = wk->s->rs->programs;
    if (keep && !wk->rc) {
        if (keep->keep_scene)
            wavefront_release_work_buffers(w);
        else
            wavefront_release_buffers(w);
        return;
    }
    wavefront_free(w);
    if (keep) {
        free(keep->w[wk->index]);
        keep->w[wk->index] = NULL;
    }
}

static void *worker_main(void *arg)
{
    Worker *wk = arg;
    const RenderSettings *rs = wk->s->rs;
    Wavefront own, *wp;
    memset(&own, 0, sizeof own);
    wk->rc = worker_wavefront(wk, &own, &wp);
    Wavefront *w = wp;
    wk->st.build_seconds = w->dev.last_build_seconds;
    if (wk->rc) {
        if (w->dev.build_log)
            wk->build_log = spt_strdup(w->dev.build_log);
        worker_wavefront_done(wk, w);
        sched_leave(wk->s, wk->index);
        return NULL;
    }
    sched_start(wk->s);
    RenderParams p = *wk->base;
    p.pool_size = w->pool;
    w->stop = rs->stop;
    /* The host arrays as planned (wavefront_plan), which render_memory counts. */
    float *sums = spt_malloc(w->plan.host_sums);
    float *aov_sums = w->plan.host_aov ? spt_malloc(w->plan.host_aov) : NULL;
    float *spec_sums = w->plan.host_spec ? spt_malloc(w->plan.host_spec) : NULL;
    float *sq_sums = wk->s->adaptive ? spt_malloc(w->plan.host_sq) : NULL;
    int mask_gen = 0; /* the adaptive mask on the device: all pixels at first */
    /* The test hooks that concern this device. */
    int fail_after = rs->test.fail_device == wk->index + 1 ? rs->test.fail_after : -1;
    int slow_ms = rs->test.slow_device == wk->index + 1 ? rs->test.slow_ms : 0;
    int chunks = 0;
    uint32_t begin, n;
    double per_sample = 0.0; /* seconds per sample of this device's last chunk */
    for (;;) {
        uint32_t want = w->chunk_spp;
        if (rs->time_limit > 0 &&
            !(want = render_deadline_chunk(want, rs->time_limit - (spt_now() - wk->s->t0),
                                           per_sample))) {
            pthread_mutex_lock(&wk->s->lock);
            wk->s->deadline = 1;
            pthread_mutex_unlock(&wk->s->lock);
            break;
        }
        if (!sched_take(wk->s, wk->index, want, &begin, &n))
            break;
        double t = spt_now();
        if (chunks == fail_after) {
            wk->rc = spt_fail(&wk->e, SPT_EXIT_DEVICE, "injected failure (test hook)");
        } else {
            if (slow_ms > 0)
                usleep((useconds_t)slow_ms * 1000u);
            uint64_t before = wk->st.paths;
            /* The segment's mask does not change while this chunk is taken. */
            if (wk->s->adaptive && mask_gen != wk->s->mask_gen) {
                mask_gen = wk->s->mask_gen;
                wk->rc = wavefront_set_lags(w, wk->s->lag, (size_t)rs->width * rs->height, &wk->e);
            }
            if (!wk->rc)
                wk->rc = render_chunk(w, &p, rs->sample_begin + begin, n, rs->profile, sums,
                                      aov_sums, spec_sums, sq_sums, &wk->st, &wk->e);
            if (!wk->rc) {
                per_sample = (spt_now() - t) / n;
                wk->busy_seconds += spt_now() - t;
                wk->samples += n;
                sched_done(wk->s, begin, n, wk->st.paths - before, sums, aov_sums, spec_sums,
                           sq_sums);
            }
        }
        if (wk->rc) {
            sched_give_back(wk->s, begin, n);
            if (wk->rc == SPT_EXIT_INTERRUPTED)
                wk->rc = 0; /* stopped at once by a second signal: not a failure */
            break;
        }
        chunks++;
    }
    free(sums);
    free(aov_sums);
    free(spec_sums);
    free(sq_sums);
    worker_wavefront_done(wk, w);
    sched_leave(wk->s, wk->index);
    return NULL;
}

/* Adaptive sampling's per-pixel arrays of the scheduler (lag, taken, sq), and
 * whether a render has them. */
#define SCHED_LAG_BYTES sizeof(uint32_t)
#define SCHED_TAKEN_BYTES sizeof(uint32_t)
#define SCHED_SQ_BYTES (3 * sizeof(double))
static int sched_adaptive(const RenderSettings *rs)
{
    return rs->adaptive == SPT_SWITCH_ON && !rs->take_chunk;
}

void render_memory(const ClDeviceInfo *const *infos, int count, const GpuScene *g,
                   const SceneCamera *cam, const RenderSettings *rs, RenderMemory *m)
{
    uint32_t light_film = light_plan_runs(rs, NULL, g, cam, 0) ? light_plan_max_paths(rs) : 0;
    memset(m, 0, sizeof *m);
    size_t npix = (size_t)rs->width * (size_t)rs->height;
    if (sched_adaptive(rs))
        m->scheduler = npix * (SCHED_LAG_BYTES + SCHED_TAKEN_BYTES + SCHED_SQ_BYTES);
    const Sky *sky = rs->sky;
    size_t env_floats = sky && sky->kind == SPT_SKY_MAP ? sky_map_data_floats(sky->map_width, sky->map_height) : 0;
    m->lights = env_floats * sizeof(float);
    for (int i = 0; i < count; i++) {
        WavefrontPlan p;
        wavefront_plan(&p, infos[i], g, rs, NULL, env_floats, light_film);
        m->devices += p.host_sums + p.host_aov + p.host_spec + p.host_sq + p.host_pm;
        if (infos[i]->type & CL_DEVICE_TYPE_CPU)
            m->devices += p.device;
    }
    m->total = m->scheduler + m->lights + m->devices;
}

int render_devices(const ClDeviceInfo *const *infos, int count, const GpuScene *g,
                   const SceneCamera *cam, const RenderSettings *rs, Film *film,
                   RenderStats *stats, RenderDeviceStats *per_device, SptError *e)
{
    memset(stats, 0, sizeof *stats);
    Scheduler s;
    memset(&s, 0, sizeof s);
    pthread_mutex_init(&s.lock, NULL);
    s.rs = rs;
    s.total = rs->spp > 0 ? (uint32_t)rs->spp : 0;
    s.done = spt_calloc(s.total ? s.total : 1, 1);
    s.decile = -1;
    s.film = film;
    if (sched_adaptive(rs)) {
        size_t npix = (size_t)film->width * film->height;
        s.adaptive = 1;
        s.seg_end = SPT_ADAPTIVE_FIRST;
        s.lag = spt_calloc(npix, SCHED_LAG_BYTES);
        s.taken = spt_malloc(npix * SCHED_TAKEN_BYTES);
        for (size_t i = 0; i < npix; i++)
            s.taken[i] = SPT_ADAPTIVE_FIRST;
        s.sq = spt_calloc(npix, SCHED_SQ_BYTES);
    }
    s.workers = count;
    s.gone = spt_calloc((size_t)(count > 0 ? count : 1), 1);
    if (rs->done_in)
        for (uint32_t i = 0; i < s.total; i++)
            if (rs->done_in[i]) {
                s.done[i] = 1;
                s.done_count++;
            }
    RenderParams base;
    RenderLights lights;
    int rc0 = render_lights_setup(&lights, g, rs, e);
    if (!rc0)
        render_params(&base, &lights, g, cam, rs);
    if (rc0) {
        render_lights_free(&lights);
        free(s.done);
        free(s.gone);
        free(s.lag);
        free(s.taken);
        free(s.sq);
        pthread_mutex_destroy(&s.lock);
        return rc0;
    }
    Worker *wk = spt_calloc((size_t)count, sizeof(Worker));
    pthread_t *th = spt_calloc((size_t)count, sizeof(pthread_t));
    for (int i = 0; i < count; i++) {
        wk[i].index = i;
        wk[i].info = infos[i];
        wk[i].g = g;
        wk[i].cam = cam;
        wk[i].s = &s;
        wk[i].base = &base;
        wk[i].lights = &lights;
    }
    if (count == 1) {
        worker_main(&wk[0]);
    } else {
        for (int i = 0; i < count; i++)
            pthread_create(&th[i], NULL, worker_main, &wk[i]);
        for (int i = 0; i < count; i++)
            pthread_join(th[i], NULL);
    }
    stats->seconds = s.t0 > 0.0 ? spt_now() - s.t0 : 0.0;
    if (rs->progress && isatty(2) && s.done_count > 0)
        fputc('\n', stderr);
    int failed = 0, rc = 0;
    for (int i = 0; i < count; i++) {
        stats->paths += wk[i].st.paths;
        stats->rays_extend += wk[i].st.rays_extend;
        stats->rays_shadow += wk[i].st.rays_shadow;
        stats->nan_dropped += wk[i].st.nan_dropped;
        if (wk[i].st.build_seconds > stats->build_seconds)
            stats->build_seconds = wk[i].st.build_seconds;
        for (int k = 0; k < SPT_STAGES; k++)
            stats->stage_seconds[k] += wk[i].st.stage_seconds[k];
        if (per_device) {
            per_device[i].samples = wk[i].samples;
            per_device[i].paths_per_second =
                wk[i].busy_seconds > 0 ? wk[i].st.paths / wk[i].busy_seconds : 0.0;
            per_device[i].failed = wk[i].rc != 0;
        }
        if (wk[i].rc) {
            failed++;
            if (count > 1 && wk[i].rc != SPT_EXIT_INTERRUPTED)
                spt_warn("device %d (%s) dropped: %s%s", i, infos[i]->name, wk[i].e.msg,
                         wk[i].build_log ? " (build log follows)" : "");
            if (wk[i].build_log)
                fprintf(stderr, "%s\n", wk[i].build_log);
            if (!rc) {
                rc = wk[i].rc;
                *e = wk[i].e;
            }
        }
    }
    int stopped = (rs->stop && *rs->stop) || s.deadline ||
                  (rs->time_limit > 0 && s.t0 > 0.0 && spt_now() - s.t0 >= rs->time_limit);
    if (failed == count && count > 1 && rc != SPT_EXIT_INTERRUPTED)
        rc = spt_fail(e, SPT_EXIT_DEVICE, "every device failed; the last error: %s", e->msg);
    else if (failed < count && s.done_count < s.total && !stopped && !rs->take_chunk)
        rc = spt_fail(e, SPT_EXIT_FAILURE, "render incomplete: %u of %u samples per pixel done",
                      s.done_count, s.total);
    else if (failed < count)
        rc = 0; /* the other devices carried the render to its end */
    stats->spp_done = s.done_count;
    for (int i = 0; i < count; i++)
        free(wk[i].build_log);
    free(wk);
    free(th);
    free(s.done);
    free(s.ret_begin);
    free(s.ret_n);
    free(s.gone);
    free(s.lag);
    free(s.taken);
    free(s.sq);
    render_lights_free(&lights);
    pthread_mutex_destroy(&s.lock);
    return rc;
}

int render_device(const ClDeviceInfo *info, const GpuScene *g, const SceneCamera *cam,
                  const RenderSettings *rs, Film *film, RenderStats *stats, SptError *e)
{
    const ClDeviceInfo *one[1] = {info};
    return render_devices(one, 1, g, cam, rs, film, stats, NULL, e);
}
