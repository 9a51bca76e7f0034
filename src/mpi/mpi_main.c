/* build/spectrace-mpi: the command line of build/spectrace, with `render` spread
 * over the ranks of an MPI job (`mpirun -n N build/spectrace-mpi render ...`).
 *
 * Rank 0 runs the ordinary command line (src/cli/main.c, compiled here as
 * spectrace_main): it alone reads the scene, the checkpoint and writes files and
 * progress. When the library's render (src/api/spectrace.c, which the command
 * line is a client of) reaches render_devices, spt_dist_render (below) sends
 * every other rank the job (the settings and the loaded scene, packed by
 * src/scene/scene_pack.c, so buffers and textures need not exist on the other
 * machines), then renders on its own devices while a server thread hands out
 * chunks of sample indices to the ranks that ask and adds the sums of every
 * chunk they finish to the one film, which is also what checkpoints save. A
 * chunk counts as done only once its sums are in rank 0's film.
 *
 * The other ranks wait for the job, select their own devices (their --device,
 * else SPECTRACE_DEVICE), build the scene and render with render_devices whose
 * hooks ask rank 0 for chunks and send each finished chunk's sums back, then
 * report their status. Any rank that fails fails the run: rank 0 prints one
 * `error:` line naming the rank and the reason, and writes no image.
 *
 * MPI calls are made by one thread at a time (MPI_THREAD_SERIALIZED): on rank 0
 * by the server thread during the render, elsewhere under the render's
 * scheduler lock. Waits poll with short sleeps instead of blocking in MPI,
 * because Open MPI's blocking calls spin a core that the renderer needs. */
#include <mpi.h>
#include <pthread.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "cl/cl_device.h"
#include "mpi/mpi_hook.h"
#include "render/film.h"
#include "render/render.h"
#include "render/test_hooks.h"
#include "scene/scene.h"
#include "scene/scene_pack.h"
#include "core/util.h"

int spectrace_main(int argc, char **argv); /* src/cli/main.c's main, renamed by the Makefile */

enum { TAG_JOB = 1, TAG_REQ, TAG_CHUNK, TAG_DONE, TAG_FILM, TAG_BACK, TAG_FINISH };

/* The settings of a render as they travel to the other ranks: the options of
 * RenderSettings (src/render/render_options.h; those marked SPT_OPT_MPI are
 * sent), the first sample and the camera. The job message is this, then
 * scene_bytes of the packed scene, then the packed sky. */
typedef struct JobSettings {
    SPT_RENDER_OPTIONS(SPT_OPT_RS_FIELD)
    uint32_t sample_begin;
    SceneCamera cam;
    /* Rank 0's BVH: the build that made it, and whether it was refitted to
     * this scene (a frame sequence); a rank refits the tree it built for that
     * build, so every rank traces the same tree and the image does not
     * depend on which rank rendered which samples. */
    uint32_t bvh_build;
    int32_t bvh_refitted;
    uint64_t scene_bytes;
} JobSettings;

#define JOB_COPY(where, kind, type, name, option, short_name, metavar, def, lo, hi, flags, ...) \
    SPT_OPT_IF_RS_##where(if ((flags) & SPT_OPT_MPI) JOB_TO.name = JOB_FROM.name;)

typedef struct DoneMsg {
    uint32_t begin, n;
} DoneMsg;

typedef struct FinishMsg {
    int32_t rc;
    uint32_t samples;
    uint64_t paths, rays_extend, rays_shadow, nan_dropped;
    char msg[1024];
} FinishMsg;

static int g_rank, g_size;

/* A request to stop after the current chunks, then write what is done (as
 * Ctrl-C does for build/spectrace): SIGUSR2 on every rank (mpirun passes SIGUSR1
 * and SIGUSR2 on to all ranks; on SIGINT or SIGTERM it ends the job itself after
 * a one-second grace time). Not SIGUSR1: the LLVM that PoCL loads takes SIGUSR1
 * for itself, while it passes SIGUSR2 on to the handler installed before it. */
static volatile sig_atomic_t g_stop;

static void on_signal(int sig)
{
    (void)sig;
    g_stop = 1;
}

/* Polls until a message from src with tag arrives; fills st. */
static void wait_message(int src, int tag, MPI_Status *st)
{
    int flag = 0;
    for (;;) {
        MPI_Iprobe(src, tag, MPI_COMM_WORLD, &flag, st);
        if (flag)
            return;
        usleep(300);
    }
}

/* ---- chunks in flight on this rank ---------------------------------------- */

typedef struct Inflight {
    uint32_t *begin, *n;
    int count, cap;
} Inflight;

static void inflight_add(Inflight *f, uint32_t begin, uint32_t n)
{
    if (f->count == f->cap) {
        f->cap = f->cap ? 2 * f->cap : 8;
        f->begin = spt_realloc(f->begin, (size_t)f->cap * sizeof(uint32_t));
        f->n = spt_realloc(f->n, (size_t)f->cap * sizeof(uint32_t));
    }
    f->begin[f->count] = begin;
    f->n[f->count] = n;
    f->count++;
}

/* Removes and returns the chunk whose first sample is now marked done (the one
 * chunk render_devices just finished); 0 when none is. */
static int inflight_pop_done(Inflight *f, const unsigned char *done, uint32_t *begin, uint32_t *n)
{
    for (int i = 0; i < f->count; i++)
        if (done[f->begin[i]]) {
            *begin = f->begin[i];
            *n = f->n[i];
            f->count--;
            f->begin[i] = f->begin[f->count];
            f->n[i] = f->n[f->count];
            return 1;
        }
    return 0;
}

static void inflight_remove(Inflight *f, uint32_t begin)
{
    for (int i = 0; i < f->count; i++)
        if (f->begin[i] == begin) {
            f->count--;
            f->begin[i] = f->begin[f->count];
            f->n[i] = f->n[f->count];
            return;
        }
}

/* ---- rank 0 ----------------------------------------------------------------- */

typedef struct Global {
    pthread_mutex_t lock;
    const RenderSettings *rs;
    Film *film;                /* the output film: every rank's finished chunks */
    unsigned char *done;       /* per sample index: in film (or resumed) */
    unsigned char *handed;     /* per sample index: handed out (or done) */
    uint32_t total, next, done_count;
    uint32_t *ret_begin, *ret_n; /* chunks given back by failed devices */
    int ret_count, abort;      /* abort: a rank failed, hand out nothing more */
    double t0;                 /* the first chunk handed out (0 before): --time
                                  counts from there, not from the kernel builds */
    uint64_t paths;
    int decile;
    Inflight local;            /* chunks on rank 0's own devices */
    Film local_film;           /* rank 0's devices render into this */
    FinishMsg *finish;         /* per rank */
    int finished;              /* ranks other than 0 that reported */
    unsigned char *started;    /* per rank: had a chunk, or reported its end */
    int started_count;         /* ranks other than 0 marked in started */
    int local_started;         /* rank 0's devices had a chunk, or ended */
} Global;

/* The test hook ranks_first (G locked): whether a rank that had its first chunk
 * must wait before its next one, because some rank has not had its first yet.
 * Rank 0's devices wait for every other rank; the others wait for rank 0. */
static int g_hold_second(const Global *G)
{
    return G->rs->test.ranks_first && !G->abort && !g_stop &&
           !(G->started_count == g_size - 1 && G->local_started);
}

/* Marks rank r as started (G locked). */
static void g_started(Global *G, int r)
{
    if (r > 0 && r < g_size && !G->started[r]) {
        G->started[r] = 1;
        G->started_count++;
    }
}

/* Takes up to want samples (G locked); 0 when nothing is left or stopping. */
static int g_take(Global *G, uint32_t want, uint32_t *begin, uint32_t *n)
{
    const RenderSettings *rs = G->rs;
    if (G->t0 == 0.0)
        G->t0 = spt_now();
    if (G->abort || g_stop || (rs->stop && *rs->stop) ||
        (rs->time_limit > 0 && spt_now() - G->t0 >= rs->time_limit))
        return 0;
    if (G->ret_count > 0) {
        G->ret_count--;
        *begin = G->ret_begin[G->ret_count];
        *n = G->ret_n[G->ret_count];
        return 1;
    }
    while (G->next < G->total && G->handed[G->next])
        G->next++;
    if (G->next >= G->total)
        return 0;
    uint32_t k = 0;
    while (k < want && G->next + k < G->total && !G->handed[G->next + k])
        G->handed[G->next + k++] = 1;
    *begin = G->next;
    *n = k;
    return 1;
}

static void g_give_back(Global *G, uint32_t begin, uint32_t n)
{
    G->ret_begin = spt_realloc(G->ret_begin, (size_t)(G->ret_count + 1) * sizeof(uint32_t));
    G->ret_n = spt_realloc(G->ret_n, (size_t)(G->ret_count + 1) * sizeof(uint32_t));
    G->ret_begin[G->ret_count] = begin;
    G->ret_n[G->ret_count] = n;
    G->ret_count++;
}

/* The progress of the whole render (G locked): its own line when rs->progress
 * (the command line's, with the ranks), else the caller's on_progress hook. */
static void g_progress(Global *G)
{
    const RenderSettings *rs = G->rs;
    if (!rs->progress) {
        if (rs->on_progress)
            rs->on_progress(rs->on_progress_ctx, G->done_count, G->total,
                            G->t0 > 0.0 ? spt_now() - G->t0 : 0.0, G->paths);
        return;
    }
    double frac = G->total ? (double)G->done_count / G->total : 1.0;
    int tty = isatty(2), decile = (int)(frac * 10.0);
    if (!tty && decile == G->decile)
        return;
    G->decile = decile;
    double el = spt_now() - G->t0;
    fprintf(stderr, "%srender: %5.1f%%  %u/%u spp  %.2f Mpaths/s  %.1f s elapsed  %d ranks%s",
            tty ? "\r" : "", 100.0 * frac, G->done_count, G->total,
            el > 0 ? G->paths / el * 1e-6 : 0.0, el, g_size, tty ? "   " : "\n");
    fflush(stderr);
}

/* A finished chunk (G locked): sums are added, the samples marked done, and the
 * caller's on_chunk (the checkpoint writer) sees the whole film. */
static void g_chunk_done(Global *G, uint32_t begin, uint32_t n, const Film *sums)
{
    film_add(G->film, sums);
    for (uint32_t i = 0; i < n; i++)
        G->done[begin + i] = 1;
    G->done_count += n;
    G->paths += (uint64_t)n * G->film->width * G->film->height;
    g_progress(G);
    if (G->rs->on_chunk)
        G->rs->on_chunk(G->rs->on_chunk_ctx, G->film, G->done, G->total);
}

/* Hooks of rank 0's own render_devices (called under its scheduler lock). */
static int local_take(void *ctx, uint32_t want, uint32_t *begin, uint32_t *n)
{
    Global *G = ctx;
    pthread_mutex_lock(&G->lock);
    /* The test hook ranks_first: wait until each other rank has had a chunk. */
    while (G->rs->test.ranks_first && G->started_count < g_size - 1 && !G->abort && !g_stop) {
        pthread_mutex_unlock(&G->lock);
        usleep(1000);
        pthread_mutex_lock(&G->lock);
    }
    int ok = g_take(G, want, begin, n);
    if (ok)
        inflight_add(&G->local, *begin, *n);
    G->local_started = 1;
    pthread_mutex_unlock(&G->lock);
    return ok;
}

static void local_back(void *ctx, uint32_t begin, uint32_t n)
{
    Global *G = ctx;
    pthread_mutex_lock(&G->lock);
    inflight_remove(&G->local, begin);
    g_give_back(G, begin, n);
    pthread_mutex_unlock(&G->lock);
}

static void local_done(void *ctx, const Film *film, const unsigned char *done, uint32_t total)
{
    (void)film;
    (void)total;
    Global *G = ctx;
    pthread_mutex_lock(&G->lock);
    uint32_t begin, n;
    if (inflight_pop_done(&G->local, done, &begin, &n)) {
        g_chunk_done(G, begin, n, &G->local_film);
        film_clear(&G->local_film);
    }
    pthread_mutex_unlock(&G->lock);
}

/* Serves the other ranks until every one has reported its end. */
static void *server_main(void *arg)
{
    Global *G = arg;
    Film in;
    film_init_full(&in, G->film->width, G->film->height, G->film->aov != NULL, G->film->bands);
    size_t nd = film_doubles(&in);
    double *buf = spt_malloc(nd * sizeof(double));
    /* Requests held back by the test hook ranks_first: 1 + the samples wanted. */
    uint64_t *held = spt_calloc((size_t)g_size, sizeof *held);
    while (G->finished < g_size - 1) {
        pthread_mutex_lock(&G->lock);
        int hold = g_hold_second(G);
        pthread_mutex_unlock(&G->lock);
        for (int r = 1; r < g_size && !hold; r++)
            if (held[r]) {
                uint32_t reply[3] = {0, 0, 0};
                pthread_mutex_lock(&G->lock);
                reply[0] = (uint32_t)g_take(G, (uint32_t)(held[r] - 1), &reply[1], &reply[2]);
                pthread_mutex_unlock(&G->lock);
                held[r] = 0;
                MPI_Send(reply, 3, MPI_UINT32_T, r, TAG_CHUNK, MPI_COMM_WORLD);
            }
        MPI_Status st;
        int flag = 0;
        MPI_Iprobe(MPI_ANY_SOURCE, MPI_ANY_TAG, MPI_COMM_WORLD, &flag, &st);
        if (!flag) {
            usleep(300);
            continue;
        }
        int src = st.MPI_SOURCE;
        if (st.MPI_TAG == TAG_REQ) {
            uint32_t want, reply[3] = {0, 0, 0};
            MPI_Recv(&want, 1, MPI_UINT32_T, src, TAG_REQ, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
            pthread_mutex_lock(&G->lock);
            if (G->started[src] && g_hold_second(G)) {
                held[src] = 1 + (uint64_t)want;
                pthread_mutex_unlock(&G->lock);
                continue;
            }
            reply[0] = (uint32_t)g_take(G, want, &reply[1], &reply[2]);
            if (reply[0])
                g_started(G, src);
            pthread_mutex_unlock(&G->lock);
            MPI_Send(reply, 3, MPI_UINT32_T, src, TAG_CHUNK, MPI_COMM_WORLD);
        } else if (st.MPI_TAG == TAG_DONE) {
            DoneMsg d;
            MPI_Recv(&d, (int)sizeof d, MPI_BYTE, src, TAG_DONE, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
            MPI_Recv(buf, (int)nd, MPI_DOUBLE, src, TAG_FILM, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
            film_unpack(&in, buf);
            pthread_mutex_lock(&G->lock);
            if (d.begin < G->total && d.n <= G->total - d.begin)
                g_chunk_done(G, d.begin, d.n, &in);
            pthread_mutex_unlock(&G->lock);
        } else if (st.MPI_TAG == TAG_BACK) {
            DoneMsg d;
            MPI_Recv(&d, (int)sizeof d, MPI_BYTE, src, TAG_BACK, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
            pthread_mutex_lock(&G->lock);
            g_give_back(G, d.begin, d.n);
            pthread_mutex_unlock(&G->lock);
        } else if (st.MPI_TAG == TAG_FINISH) {
            FinishMsg f;
            MPI_Recv(&f, (int)sizeof f, MPI_BYTE, src, TAG_FINISH, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
            f.msg[sizeof f.msg - 1] = 0;
            pthread_mutex_lock(&G->lock);
            G->finish[src] = f;
            G->finished++;
            g_started(G, src);
            if (f.rc)
                G->abort = 1; /* a failed rank fails the run: hand out nothing more */
            pthread_mutex_unlock(&G->lock);
        } else {
            /* Not ours: drain it so the loop goes on. */
            int count = 0;
            MPI_Get_count(&st, MPI_BYTE, &count);
            char *junk = spt_malloc(count > 0 ? (size_t)count : 1);
            MPI_Recv(junk, count, MPI_BYTE, src, st.MPI_TAG, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
            free(junk);
        }
    }
    free(held);
    free(buf);
    film_free(&in);
    return NULL;
}

/* Sends the job (settings and packed scene) to every other rank. */
static void send_job(const RenderSettings *rs, const Scene *scene, const SceneCamera *cam,
                     const GpuScene *g)
{
    JobSettings js;
    memset(&js, 0, sizeof js);
#define JOB_TO js
#define JOB_FROM (*rs)
    SPT_RENDER_OPTIONS(JOB_COPY)
#undef JOB_TO
#undef JOB_FROM
    js.sample_begin = rs->sample_begin;
    js.cam = *cam;
    js.bvh_build = g->bvh.build;
    js.bvh_refitted = g->bvh.refitted;
    size_t n, nsky;
    Sky none;
    memset(&none, 0, sizeof none);
    unsigned char *packed = scene_pack(scene, &n);
    unsigned char *sky = sky_pack(rs->sky ? rs->sky : &none, &nsky);
    js.scene_bytes = n;
    unsigned char *msg = spt_malloc(sizeof js + n + nsky);
    memcpy(msg, &js, sizeof js);
    memcpy(msg + sizeof js, packed, n);
    memcpy(msg + sizeof js + n, sky, nsky);
    free(packed);
    free(sky);
    for (int r = 1; r < g_size; r++)
        MPI_Send(msg, (int)(sizeof js + n + nsky), MPI_BYTE, r, TAG_JOB, MPI_COMM_WORLD);
    free(msg);
}

static int mpi_render(const ClDeviceInfo *const *infos, int count, const GpuScene *g,
                      const Scene *scene, const SceneCamera *cam, const RenderSettings *rs,
                      Film *film, RenderStats *stats, RenderDeviceStats *per_device, SptError *e)
{
    send_job(rs, scene, cam, g);
    Global G;
    memset(&G, 0, sizeof G);
    pthread_mutex_init(&G.lock, NULL);
    G.rs = rs;
    G.film = film;
    G.total = rs->spp > 0 ? (uint32_t)rs->spp : 0;
    G.done = spt_calloc(G.total ? G.total : 1, 1);
    G.handed = spt_calloc(G.total ? G.total : 1, 1);
    if (rs->done_in)
        for (uint32_t i = 0; i < G.total; i++)
            if (rs->done_in[i]) {
                G.done[i] = G.handed[i] = 1;
                G.done_count++;
            }
    G.decile = -1;
    G.finish = spt_calloc((size_t)g_size, sizeof(FinishMsg));
    G.started = spt_calloc((size_t)g_size, 1);
    film_init_full(&G.local_film, film->width, film->height, film->aov != NULL, film->bands);
    pthread_t server;
    pthread_create(&server, NULL, server_main, &G);

    RenderSettings lrs = *rs;
    lrs.progress = 0;
    lrs.done_in = NULL;
    lrs.take_chunk = local_take;
    lrs.give_back = local_back;
    lrs.chunk_ctx = &G;
    lrs.on_chunk = local_done;
    lrs.on_chunk_ctx = &G;
    lrs.on_progress = NULL; /* the whole render's progress is g_progress's */
    RenderStats lst;
    SptError le = {0};
    int rc0 = render_devices(infos, count, g, cam, &lrs, &G.local_film, &lst, per_device, &le);
    pthread_mutex_lock(&G.lock);
    G.local_started = 1;
    if (rc0)
        G.abort = 1;
    pthread_mutex_unlock(&G.lock);
    pthread_join(server, NULL);
    if (rs->progress && isatty(2))
        fputc('\n', stderr);

    *stats = lst;
    stats->seconds = G.t0 > 0.0 ? spt_now() - G.t0 : 0.0;
    stats->spp_done = G.done_count;
    int rc = 0;
    if (rc0)
        rc = spt_fail(e, rc0, "rank 0: %s", le.msg);
    for (int r = 1; r < g_size; r++) {
        stats->paths += G.finish[r].paths;
        stats->rays_extend += G.finish[r].rays_extend;
        stats->rays_shadow += G.finish[r].rays_shadow;
        stats->nan_dropped += G.finish[r].nan_dropped;
        if (G.finish[r].rc && !rc)
            rc = spt_fail(e, G.finish[r].rc, "rank %d: %s", r, G.finish[r].msg);
    }
    int stopped = g_stop || (rs->stop && *rs->stop) ||
                  (rs->time_limit > 0 && G.t0 > 0.0 && spt_now() - G.t0 >= rs->time_limit);
    if (!rc && g_stop)
        spt_note("render: stopped by a signal (SIGUSR2) after %u of %u samples per pixel; writing them",
                 G.done_count, G.total);
    if (!rc && G.done_count < G.total && !stopped)
        rc = spt_fail(e, SPT_EXIT_FAILURE, "render incomplete: %u of %u samples per pixel done on %d ranks",
                      G.done_count, G.total, g_size);
    if (rs->progress && !rc) {
        fprintf(stderr, "ranks:");
        for (int r = 0; r < g_size; r++)
            fprintf(stderr, " %d: %u spp%s", r,
                    r ? G.finish[r].samples : (uint32_t)(lst.paths / ((uint64_t)film->width * film->height)),
                    r + 1 < g_size ? "," : "\n");
    }
    film_free(&G.local_film);
    free(G.done);
    free(G.handed);
    free(G.ret_begin);
    free(G.ret_n);
    free(G.finish);
    free(G.started);
    free(G.local.begin);
    free(G.local.n);
    pthread_mutex_destroy(&G.lock);
    return rc;
}

/* ---- the other ranks ---------------------------------------------------------- */

typedef struct Worker {
    Inflight inflight;
    Film film;            /* one chunk's sums at a time */
    double *buf;
    uint32_t samples;
} Worker;

static int remote_take(void *ctx, uint32_t want, uint32_t *begin, uint32_t *n)
{
    Worker *w = ctx;
    MPI_Send(&want, 1, MPI_UINT32_T, 0, TAG_REQ, MPI_COMM_WORLD);
    MPI_Status st;
    wait_message(0, TAG_CHUNK, &st);
    uint32_t reply[3];
    MPI_Recv(reply, 3, MPI_UINT32_T, 0, TAG_CHUNK, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
    if (!reply[0])
        return 0;
    *begin = reply[1];
    *n = reply[2];
    inflight_add(&w->inflight, *begin, *n);
    return 1;
}

static void remote_back(void *ctx, uint32_t begin, uint32_t n)
{
    Worker *w = ctx;
    inflight_remove(&w->inflight, begin);
    DoneMsg d = {begin, n};
    MPI_Send(&d, (int)sizeof d, MPI_BYTE, 0, TAG_BACK, MPI_COMM_WORLD);
}

static void remote_done(void *ctx, const Film *film, const unsigned char *done, uint32_t total)
{
    (void)film;
    (void)total;
    Worker *w = ctx;
    DoneMsg d;
    if (!inflight_pop_done(&w->inflight, done, &d.begin, &d.n))
        return;
    film_pack(&w->film, w->buf);
    film_clear(&w->film);
    MPI_Send(&d, (int)sizeof d, MPI_BYTE, 0, TAG_DONE, MPI_COMM_WORLD);
    MPI_Send(w->buf, (int)film_doubles(&w->film), MPI_DOUBLE, 0, TAG_FILM, MPI_COMM_WORLD);
    w->samples += d.n;
}

/* This rank's --device (the last one given, as getopt does), else NULL. */
static const char *device_arg(int argc, char **argv)
{
    const char *sel = NULL;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--device") && i + 1 < argc)
            sel = argv[++i];
        else if (!strncmp(argv[i], "--device=", 9))
            sel = argv[i] + 9;
    }
    return sel;
}

/* This rank's devices, chosen for its first job, and the programs kept for
 * the later ones (a frame sequence sends a job per frame). */
typedef struct RankDevices {
    ClDeviceList list;
    const ClDeviceInfo *devs[64];
    int nsel;
    RenderPrograms programs;
    /* The last job's BVH, built for rank 0's build bvh_for over tris
     * triangles (JobSettings). */
    Bvh bvh;
    uint32_t bvh_for, bvh_tris;
} RankDevices;

/* The job's scene as the devices' arrays, its BVH as rank 0's: refitted from
 * the tree built for the same build of rank 0 when rank 0 refitted, else
 * built. */
static int rank_scene(RankDevices *rd, const JobSettings *js, const Scene *scene, GpuScene *gpu,
                      SptError *e)
{
    if (js->bvh_refitted && rd->bvh.nodes && rd->bvh_for == js->bvh_build &&
        bvh_refit(&rd->bvh, scene->tri_pos, scene->tri_count, rd->bvh_tris))
        return gpu_scene_build_with(gpu, scene, &rd->bvh, e);
    bvh_free(&rd->bvh);
    rd->bvh_for = js->bvh_refitted ? 0 : js->bvh_build; /* 0: no build of rank 0's */
    return gpu_scene_build(gpu, scene, e);
}

static int rank_devices(RankDevices *d, const char *device_sel, SptError *e)
{
    if (d->nsel)
        return 0;
    int sel[64], n = 0, rc;
    if ((rc = cl_device_list(&d->list, e)) || (rc = cl_device_select(&d->list, device_sel, sel, &n, e)))
        return rc;
    for (int i = 0; i < n && i < 64; i++)
        d->devs[i] = &d->list.devices[sel[i]];
    d->nsel = n < 64 ? n : 64;
    render_programs_init(&d->programs, d->nsel);
    return 0;
}

/* Renders one job for rank 0; every failure goes to rank 0 in the finish message. */
static int worker_run(const unsigned char *job, size_t len, RankDevices *rd, const char *device_sel,
                      FinishMsg *fin)
{
    SptError e = {0};
    JobSettings js;
    Scene scene;
    memset(&scene, 0, sizeof scene);
    Sky sky;
    memset(&sky, 0, sizeof sky);
    GpuScene gpu;
    memset(&gpu, 0, sizeof gpu);
    Worker w;
    memset(&w, 0, sizeof w);
    int rc;
    if (len < sizeof js) {
        rc = spt_fail(&e, SPT_EXIT_FAILURE, "job message too short (%zu bytes)", len);
        goto out;
    }
    memcpy(&js, job, sizeof js);
    if (js.scene_bytes > len - sizeof js) {
        rc = spt_fail(&e, SPT_EXIT_FAILURE, "job message too short (%zu bytes)", len);
        goto out;
    }
    if ((rc = scene_unpack(&scene, job + sizeof js, (size_t)js.scene_bytes, "the scene from rank 0",
                           &e)) ||
        (rc = sky_unpack(&sky, job + sizeof js + js.scene_bytes,
                         len - sizeof js - (size_t)js.scene_bytes, "the sky from rank 0", &e)))
        goto out;
    if ((rc = rank_devices(rd, device_sel, &e)) || (rc = rank_scene(rd, &js, &scene, &gpu, &e)))
        goto out;
    RenderSettings rs;
    memset(&rs, 0, sizeof rs);
#define JOB_TO rs
#define JOB_FROM js
    SPT_RENDER_OPTIONS(JOB_COPY)
#undef JOB_TO
#undef JOB_FROM
    rs.sample_begin = js.sample_begin;
    rs.sky = &sky;
    render_test_hooks_env(&rs);
    rs.stop = &g_stop;
    rs.take_chunk = remote_take;
    rs.give_back = remote_back;
    rs.chunk_ctx = &w;
    rs.on_chunk = remote_done;
    rs.on_chunk_ctx = &w;
    rs.programs = &rd->programs;
    film_init_full(&w.film, rs.width, rs.height, render_keeps_aov(&rs), rs.spectral);
    w.buf = spt_malloc(film_doubles(&w.film) * sizeof(double));
    RenderStats st;
    rc = render_devices(rd->devs, rd->nsel, &gpu, &js.cam, &rs, &w.film, &st, NULL, &e);
    fin->paths = st.paths;
    fin->rays_extend = st.rays_extend;
    fin->rays_shadow = st.rays_shadow;
    fin->nan_dropped = st.nan_dropped;
out:
    fin->rc = rc;
    fin->samples = w.samples;
    snprintf(fin->msg, sizeof fin->msg, "%s", rc ? e.msg : "");
    free(w.buf);
    free(w.inflight.begin);
    free(w.inflight.n);
    film_free(&w.film);
    /* The tree kept for the next job's refit. */
    bvh_free(&rd->bvh);
    if (!scene.mesh_count) { /* a two-level scene's world tree is not the whole scene's */
        rd->bvh = gpu.bvh;
        rd->bvh_tris = scene.tri_count;
        memset(&gpu.bvh, 0, sizeof gpu.bvh);
    }
    gpu_scene_free(&gpu);
    sky_free(&sky);
    scene_free(&scene);
    return rc;
}

/* Runs rank 0's jobs (one, or one per frame of --frames) until its word that
 * there are no more (an empty job). */
static void worker_main(int argc, char **argv)
{
    RankDevices rd;
    memset(&rd, 0, sizeof rd);
    for (;;) {
        MPI_Status st;
        wait_message(0, TAG_JOB, &st);
        int len = 0;
        MPI_Get_count(&st, MPI_BYTE, &len);
        unsigned char *job = spt_malloc(len > 0 ? (size_t)len : 1);
        MPI_Recv(job, len, MPI_BYTE, 0, TAG_JOB, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
        if (len > 0) {
            FinishMsg fin;
            memset(&fin, 0, sizeof fin);
            worker_run(job, (size_t)len, &rd, device_arg(argc, argv), &fin);
            MPI_Send(&fin, (int)sizeof fin, MPI_BYTE, 0, TAG_FINISH, MPI_COMM_WORLD);
        }
        free(job);
        if (len <= 0)
            break;
    }
    if (rd.programs.w)
        render_programs_free(&rd.programs);
    bvh_free(&rd.bvh);
    cl_device_list_free(&rd.list);
}

int main(int argc, char **argv)
{
    int provided = 0;
    if (MPI_Init_thread(&argc, &argv, MPI_THREAD_SERIALIZED, &provided) != MPI_SUCCESS) {
        spt_error("spectrace-mpi: MPI_Init_thread failed");
        return SPT_EXIT_FAILURE;
    }
    MPI_Comm_rank(MPI_COMM_WORLD, &g_rank);
    MPI_Comm_size(MPI_COMM_WORLD, &g_size);
    if (provided < MPI_THREAD_SERIALIZED) {
        if (g_rank == 0)
            spt_error("spectrace-mpi: the MPI library does not support MPI_THREAD_SERIALIZED");
        MPI_Finalize();
        return SPT_EXIT_FAILURE;
    }
    int rc = 0;
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    sigaction(SIGUSR2, &sa, NULL);
    if (g_rank == 0) {
        if (g_size > 1)
            spt_dist_render = mpi_render;
        rc = spectrace_main(argc, argv);
        /* The command ended (after its renders, or without one): the other
         * ranks are told there are no more jobs. */
        for (int r = 1; r < g_size; r++)
            MPI_Send(NULL, 0, MPI_BYTE, r, TAG_JOB, MPI_COMM_WORLD);
    } else {
        sigaction(SIGINT, &sa, NULL);
        sigaction(SIGTERM, &sa, NULL);
        worker_main(argc, argv);
    }
    MPI_Finalize();
    return rc;
}
