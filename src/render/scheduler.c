/* Rendering on several devices at once: one worker thread per device, each with
 * its own wavefront, taking chunks of samples from one scheduler; the chunks of a
 * device that fails go back to the others. */
#include "render/render.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <pthread.h>
#include <unistd.h>

#include "closure/bsdf.h"
#include "render/adaptive.h"
#include "render/render_lights.h"
#include "render/wavefront.h"
#include "sample/rng.h"

/* The camera of the kernels: right and up scaled so that screen coordinates in
 * [-1, 1] span the field of view at the image's aspect ratio. */
static void camera_params(RenderParams *p, const SceneCamera *c, int width, int height)
{
    float t = tanf(0.5f * c->yfov);
    float aspect = (float)width / (float)height;
    /* Orthographic (glTF xmag/ymag: half the view's width and height): right and up
     * span the image plane itself; the image's aspect follows ymag. */
    float sx = c->orthographic ? c->ymag * aspect : t * aspect;
    float sy = c->orthographic ? c->ymag : t;
    p->orthographic = c->orthographic ? 1u : 0u;
    for (int i = 0; i < 3; i++) {
        p->cam_pos[i] = c->position[i];
        p->cam_fwd[i] = c->forward[i];
        p->cam_right[i] = c->right[i] * sx;
        p->cam_up[i] = c->up[i] * sy;
    }
    p->cam_right[3] = p->cam_up[3] = 0.0f;
    /* The ray cone that texture filtering follows (kernels/integrator/path.h): a pixel's
     * size at the camera (orthographic), or a pixel's angle (perspective, at the
     * image's centre). */
    p->cam_pos[3] = c->orthographic ? 2.0f * sy / (float)height : 0.0f;
    p->cam_fwd[3] = c->orthographic ? 0.0f : 2.0f * t / (float)height;
}

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
    progress_print(s->rs, s->done_count, s->total, spt_now() - s->t0, s->paths, &s->decile);
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

static void *worker_main(void *arg)
{
    Worker *wk = arg;
    const RenderSettings *rs = wk->s->rs;
    Wavefront w;
    wk->rc = wavefront_create(&w, wk->info, wk->g, rs, wk->lights, wk->base->light_paths > 0, &wk->e);
    wk->st.build_seconds = w.dev.last_build_seconds;
    if (wk->rc) {
        if (w.dev.build_log)
            wk->build_log = spt_strdup(w.dev.build_log);
        wavefront_free(&w);
        sched_leave(wk->s, wk->index);
        return NULL;
    }
    sched_start(wk->s);
    RenderParams p = *wk->base;
    p.pool_size = w.pool;
    w.stop = rs->stop;
    /* The host arrays as planned (wavefront_plan), which render_memory counts. */
    float *sums = spt_malloc(w.plan.host_sums);
    float *aov_sums = w.plan.host_aov ? spt_malloc(w.plan.host_aov) : NULL;
    float *spec_sums = w.plan.host_spec ? spt_malloc(w.plan.host_spec) : NULL;
    float *sq_sums = wk->s->adaptive ? spt_malloc(w.plan.host_sq) : NULL;
    int mask_gen = 0; /* the adaptive mask on the device: all pixels at first */
    /* The test hooks that concern this device. */
    int fail_after = rs->test.fail_device == wk->index + 1 ? rs->test.fail_after : -1;
    int slow_ms = rs->test.slow_device == wk->index + 1 ? rs->test.slow_ms : 0;
    int chunks = 0;
    uint32_t begin, n;
    double per_sample = 0.0; /* seconds per sample of this device's last chunk */
    for (;;) {
        uint32_t want = w.chunk_spp;
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
                wk->rc = wavefront_set_lags(&w, wk->s->lag, (size_t)rs->width * rs->height, &wk->e);
            }
            if (!wk->rc)
                wk->rc = render_chunk(&w, &p, rs->sample_begin + begin, n, rs->profile, sums,
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
    wavefront_free(&w);
    sched_leave(wk->s, wk->index);
    return NULL;
}

/* Whether material m may take a delta lobe somewhere: a smooth base (its
 * roughness factor, or a roughness texture that may lower it) or a clear coat
 * that may be smooth. A light path goes on only through such a surface. */
static int material_may_be_delta(const GpuMaterial *m)
{
    if (m->roughness * m->roughness < BSDF_DELTA_ALPHA || m->slot[SPT_TS_METALLIC_ROUGHNESS].tex >= 0)
        return 1;
    return m->clearcoat > 0.0f && (m->cc_roughness * m->cc_roughness < BSDF_DELTA_ALPHA ||
                                   m->slot[SPT_TS_CLEARCOAT_ROUGHNESS].tex >= 0);
}

/* The caustic spheres (p->caustic, p->caustic_count; none when no triangle's
 * material may take a delta lobe): one per such material, or one for all of
 * them when there are more than SPT_CAUSTIC_MAX; each about the centre of the
 * box around its triangles' vertices, through the farthest of them, widened
 * by float rounding. A light path goes on only from such a surface, so its
 * first ray is aimed at these spheres (kernels/light/lights.h): one sphere
 * per material wastes fewer rays than one around all (on the Cornell box it
 * held the glass and the gold spheres and the space between them). */
static void caustic_bounds(RenderParams *p, const GpuScene *g)
{
    int32_t *group = spt_calloc(g->material_count ? g->material_count : 1, sizeof(int32_t));
    uint32_t n = 0;
    for (uint32_t m = 0; m < g->material_count; m++)
        group[m] = -1;
    for (uint32_t i = 0; i < g->bvh.prim_count; i++) {
        uint32_t m = g->tri_shade[i].material;
        if (m < g->material_count && group[m] < 0 && material_may_be_delta(&g->materials[m]))
            group[m] = (int32_t)n++;
    }
    if (n > SPT_CAUSTIC_MAX) {
        for (uint32_t m = 0; m < g->material_count; m++)
            if (group[m] >= 0)
                group[m] = 0;
        n = 1;
    }
    float lo[SPT_CAUSTIC_MAX][3], hi[SPT_CAUSTIC_MAX][3];
    double m_abs[SPT_CAUSTIC_MAX] = {0}, r2[SPT_CAUSTIC_MAX] = {0};
    for (uint32_t k = 0; k < n; k++)
        for (int c = 0; c < 3; c++) {
            lo[k][c] = INFINITY;
            hi[k][c] = -INFINITY;
        }
    for (uint32_t i = 0; i < g->bvh.prim_count; i++) {
        const TriShade *ts = &g->tri_shade[i];
        if (ts->material >= g->material_count || group[ts->material] < 0)
            continue;
        int k = group[ts->material];
        for (int v = 0; v < 3; v++)
            for (int c = 0; c < 3; c++) {
                float x = g->vtx_pos[3 * (size_t)ts->v[v] + c];
                lo[k][c] = fminf(lo[k][c], x);
                hi[k][c] = fmaxf(hi[k][c], x);
            }
    }
    for (uint32_t k = 0; k < n; k++)
        for (int c = 0; c < 3; c++) {
            p->caustic[4 * k + c] = 0.5f * (lo[k][c] + hi[k][c]);
            m_abs[k] = fmax(m_abs[k], fmax(fabs((double)lo[k][c]), fabs((double)hi[k][c])));
        }
    /* The farthest vertex from the box's centre (a sphere's mesh gets its own
     * radius, not the box's half diagonal, sqrt(3) times as long). */
    for (uint32_t i = 0; i < g->bvh.prim_count; i++) {
        const TriShade *ts = &g->tri_shade[i];
        if (ts->material >= g->material_count || group[ts->material] < 0)
            continue;
        int k = group[ts->material];
        for (int v = 0; v < 3; v++) {
            double d2 = 0;
            for (int c = 0; c < 3; c++) {
                double x = (double)g->vtx_pos[3 * (size_t)ts->v[v] + c] - p->caustic[4 * k + c];
                d2 += x * x;
            }
            r2[k] = fmax(r2[k], d2);
        }
    }
    for (uint32_t k = 0; k < n; k++)
        p->caustic[4 * k + 3] = (float)(sqrt(r2[k]) * (1.0 + 1e-5) + 1e-5 * m_abs[k] + 1e-6);
    p->caustic_count = n;
    free(group);
}

/* Whether the ray from o along unit d meets a caustic sphere of p. */
static int ray_meets_caustic(const RenderParams *p, vec3 o, vec3 d)
{
    for (uint32_t k = 0; k < p->caustic_count; k++)
        if (lt_meets_caustic(p, k, o, d))
            return 1;
    return 0;
}

static float share_u(uint64_t *state)
{
    uint64_t z = (*state += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return (float)((z ^ (z >> 31)) >> 40) * 0x1p-24f;
}

/* The light-tracing pass sizing: the light paths' first rays are aimed at the
 * caustic spheres (lt_aim_cones), where sampling the lights' emission as such
 * would send most of them elsewhere, to end at their first vertex.
 * --light-paths R asks for as many paths that head for a sphere as R light
 * paths per camera path sampled without aiming would give: the pass traces
 * R s per camera path, s = (the share of unaimed paths whose first ray meets
 * a sphere) / (the share of the pass's paths that do: all that are aimed, the
 * rest as unaimed). Estimated from SHARE_N light samples drawn as lt_start
 * draws them (stratified over the light selection, fixed numbers: the same on
 * every rank and device); 1 without caustic spheres or a light that reaches
 * them. */
#define SHARE_N 16384
static double caustic_share(const RenderParams *p, const RenderLights *L, const GpuScene *g)
{
    if (p->caustic_count == 0 || L->select.n == 0)
        return 1.0;
    vec3 cs = v3(p->scene_center[0], p->scene_center[1], p->scene_center[2]);
    uint64_t st = 0x5eed5eedull;
    double old_hits = 0, new_hits = 0;
    for (int k = 0; k < SHARE_N; k++) {
        float prob;
        int e = spt_discrete_sample(L->select.cdf, L->select.n, ((float)k + share_u(&st)) / SHARE_N, &prob, NULL);
        float u1 = share_u(&st), u2 = share_u(&st), u3 = share_u(&st), u4 = share_u(&st), u5 = share_u(&st);
        float omega;
        if (e < 0 || !(prob > 0.0f))
            continue;
        if ((uint32_t)e < g->emitter_count) {
            const TriShade *ts = &g->tri_shade[g->emitters[e]];
            vec3 a = v3_load(g->vtx_pos + 3 * (size_t)ts->v[0]);
            vec3 b = v3_load(g->vtx_pos + 3 * (size_t)ts->v[1]);
            vec3 c = v3_load(g->vtx_pos + 3 * (size_t)ts->v[2]);
            vec3 cr = v3_cross(v3_sub(b, a), v3_sub(c, a));
            float area2 = v3_length(cr);
            if (!(area2 > 0.0f))
                continue;
            vec3 q = spt_sample_triangle(a, b, c, u1, u2);
            vec3 n = v3_scale(cr, 1.0f / area2);
            if ((g->materials[ts->material].flags & SPT_MAT_DOUBLE_SIDED_EMISSION) && u5 < 0.5f)
                n = v3_scale(n, -1.0f);
            vec3 t_, b_;
            v3_basis(n, &t_, &b_);
            vec3 l = spt_sample_cosine_hemisphere(u3, u4);
            vec3 d = v3_add(v3_add(v3_scale(t_, l.x), v3_scale(b_, l.y)), v3_scale(n, l.z));
            int hit = ray_meets_caustic(p, q, v3_normalize(d));
            old_hits += hit;
            new_hits += lt_aim_cones(p, q, &omega) ? 1 : hit;
        } else if ((uint32_t)e < g->emitter_count + g->light_count) {
            const GpuLight *l = &g->lights[(uint32_t)e - g->emitter_count];
            vec3 ax = v3(l->dir[0], l->dir[1], l->dir[2]), t_, b_;
            v3_basis(ax, &t_, &b_);
            if (l->type == SPT_PUNCTUAL_DIRECTIONAL) {
                vec3 disk = spt_sample_concentric_disk(u3, u4);
                float R = p->scene_radius;
                vec3 o = v3_add(v3_add(cs, v3_scale(v3_add(v3_scale(t_, disk.x), v3_scale(b_, disk.y)), R)),
                                v3_scale(ax, -R));
                old_hits += ray_meets_caustic(p, o, ax);
                new_hits += 1;
                continue;
            }
            vec3 pos = v3(l->pos[0], l->pos[1], l->pos[2]);
            float x = u3 * l->spot_span, ct = 1.0f - x, sn = sqrtf(fmaxf(0.0f, x * (2.0f - x)));
            float phi = 2.0f * SPT_PI * u4;
            vec3 d = v3_add(v3_add(v3_scale(t_, sn * cosf(phi)), v3_scale(b_, sn * sinf(phi))), v3_scale(ax, ct));
            int hit = ray_meets_caustic(p, pos, v3_normalize(d));
            old_hits += hit;
            new_hits += lt_aims_punctual(p, l, &omega) ? 1 : hit;
        } else if (L->env.env.kind == SPT_ENV_MAP) {
            /* Already aimed (its disc covers the sphere). */
            old_hits += 1;
            new_hits += 1;
        }
    }
    return new_hits > 0 ? old_hits / new_hits : 1.0;
}

/* Whether material m has a delta lobe that passes or turns light: smooth
 * transmission, smooth metal, a smooth clear coat. */
static int material_turns_light(const GpuMaterial *m)
{
    int smooth = m->roughness * m->roughness < BSDF_DELTA_ALPHA;
    int cc_smooth = m->cc_roughness * m->cc_roughness < BSDF_DELTA_ALPHA;
    return (smooth && (m->transmission > 0.0f || m->metallic > 0.0f)) || (m->clearcoat > 0.0f && cc_smooth);
}

/* Whether a triangle of the scene has a material that material_turns_light:
 * a material that only the file defines, on no rendered triangle, makes no
 * caustics. */
static int scene_turns_light(const GpuScene *g)
{
    unsigned char *used = spt_calloc(g->material_count ? g->material_count : 1, 1);
    int any = 0;
    for (uint32_t i = 0; i < g->bvh.prim_count; i++)
        if (g->tri_shade[i].material < g->material_count)
            used[g->tri_shade[i].material] = 1;
    for (uint32_t i = 0; i < g->material_count && !any; i++)
        any = used[i] && material_turns_light(&g->materials[i]);
    free(used);
    return any;
}

/* Whether the light-tracing pass runs (--caustics): on, or auto and the scene
 * has a light (an emitter, a punctual light, or an --env map that the light
 * selection holds; not a uniform sky, whose light through glass the camera
 * paths keep) and a
 * triangle whose surface has a delta lobe that passes or turns light
 * (material_turns_light). It needs a perspective camera (pinhole or thin
 * lens). */
static int caustics_may_run(const RenderSettings *rs, const RenderLights *L, const GpuScene *g,
                            const SceneCamera *cam, int warn)
{
    if (rs->caustics == SPT_SWITCH_OFF)
        return 0;
    /* Light paths splat XYZ into the image only: the spectral bands and the
     * variance layer are made of camera samples, which then carry every
     * path (caustics included) themselves. */
    if (rs->spectral > 0 || (rs->aov & SPT_AOV_VARIANCE)) {
        if (rs->caustics == SPT_SWITCH_ON && warn)
            spt_warn("--caustics on: the light-tracing pass adds to the image only, not to %s; "
                     "rendering without it", rs->spectral > 0 ? "--spectral's bands" : "the variance layer");
        return 0;
    }
    if (cam->orthographic) {
        if (rs->caustics == SPT_SWITCH_ON && warn)
            spt_warn("--caustics on: the light-tracing pass needs a perspective camera (this one is "
                     "orthographic); rendering without it");
        return 0;
    }
    if (rs->caustics == SPT_SWITCH_ON)
        return 1;
    if (g->emitter_count == 0 && g->light_count == 0 && L &&
        !(L->env.env.kind == SPT_ENV_MAP && L->env_prob > 0.0f))
        return 0;
    return scene_turns_light(g);
}

static int caustics_enabled(const RenderSettings *rs, const RenderLights *L, const GpuScene *g,
                            const SceneCamera *cam)
{
    return caustics_may_run(rs, L, g, cam, 1);
}

int render_sampler_parse(const char *name, uint32_t *sampler)
{
    static const char *const names[] = SPT_SAMPLER_NAMES; /* by value */
    for (uint32_t v = 0; v < sizeof names / sizeof names[0]; v++)
        if (name && !strcasecmp(name, names[v])) {
            *sampler = v;
            return 0;
        }
    return -1;
}

/* The parameters every chunk of a render shares. */
static void base_params(RenderParams *p, const RenderLights *L, const GpuScene *g,
                        const SceneCamera *cam, const RenderSettings *rs)
{
    memset(p, 0, sizeof *p);
    camera_params(p, cam, rs->width, rs->height);
    p->width = rs->width;
    p->height = rs->height;
    p->seed = rs->seed;
    p->sampler = rs->sampler;
    if (rs->sampler == SPT_SAMPLER_ZSOBOL) {
        /* The samples per pixel (the cap under --time) rounded up to a power
         * of two fix the sequence (kernels/sample/rng.h, ZSobol). */
        p->zsobol_log2spp = spt_ceil_log2((uint32_t)(rs->spp > 0 ? rs->spp : 1));
        p->zsobol_digits = spt_zsobol_digits((uint32_t)rs->width, (uint32_t)rs->height, p->zsobol_log2spp);
    }
    p->max_depth = rs->max_depth;
    p->emitter_count = g->emitter_count;
    p->light_count = g->light_count;
    p->select_count = L->select.n;
    p->emitter_total = (float)L->select.total;
    p->env = L->env.env;
    p->env_prob = L->env_prob;
    p->node_count = g->bvh.node_count;
    /* Russian roulette from the fifth segment on (Mitsuba 3's default): on
     * the 1M-triangle mesh scene of tools/bench_mitsuba.py (256x256, 64 spp)
     * it lowers relMSE x spp from 0.21 to 0.149 for 18% more time, 1.18
     * times the clean image per second of starting at the third segment
     * (docs/performance.md, "Russian roulette"). */
    p->rr_depth = 5;
    for (uint32_t i = 0; i < g->material_count; i++)
        if (g->materials[i].flags & (SPT_MAT_ALPHA_MASK | SPT_MAT_ALPHA_BLEND))
            p->has_alpha = 1;
    p->scene_radius = g->scene_radius;
    for (int k = 0; k < 3; k++)
        p->scene_center[k] = g->scene_center[k];
    caustic_bounds(p, g);
    /* rs->light_paths (0: the default) light paths per camera path, times
     * caustic_share: that many times the pixels per sample index, rounded, at
     * least one. */
    if (caustics_enabled(rs, L, g, cam)) {
        double r = rs->light_paths > 0.0f ? (double)rs->light_paths : SPT_LIGHT_PATHS_DEFAULT;
        double n = floor(fmin(r, SPT_LIGHT_PATHS_MAX) * caustic_share(p, L, g) * (double)rs->width *
                             (double)rs->height +
                         0.5);
        p->light_paths = n < 1.0 ? 1u : (uint32_t)n;
    }
    p->lens_radius = rs->aperture;
    p->focus_distance = rs->focus_distance;
    if (rs->aperture > 0 && !(rs->focus_distance > 0)) {
        /* Focus at the distance seen at the image centre (1 km when nothing is there). */
        BvhHit hit;
        vec3 o = v3(cam->position[0], cam->position[1], cam->position[2]);
        vec3 d = v3(cam->forward[0], cam->forward[1], cam->forward[2]);
        p->focus_distance = g->bvh.prim_count && bvh_intersect(g->bvh.nodes, g->bvh.tri_data, o, d, 1e30f, &hit)
                                ? hit.t : 1000.0f;
    }
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
    int light_film = caustics_may_run(rs, NULL, g, cam, 0);
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
        m->devices += p.host_sums + p.host_aov + p.host_spec + p.host_sq;
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
        base_params(&base, &lights, g, cam, rs);
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
