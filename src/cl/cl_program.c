/* Program builds: from the cache when it holds the binary, else compiled (and
 * stored), with the build log kept for the error message. */
#include "cl/cl_internal.h"

#include <errno.h>
#include <pthread.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

/* Stores the build log of prog on d (replacing an older one). */
static void keep_build_log(ClDevice *d, cl_program prog)
{
    free(d->build_log);
    d->build_log = NULL;
    size_t n = 0;
    if (clGetProgramBuildInfo(prog, d->info.id, CL_PROGRAM_BUILD_LOG, 0, NULL, &n) !=
            CL_SUCCESS ||
        n == 0)
        return;
    d->build_log = spt_malloc(n + 1);
    if (clGetProgramBuildInfo(prog, d->info.id, CL_PROGRAM_BUILD_LOG, n, d->build_log, NULL) !=
        CL_SUCCESS)
        n = 0;
    d->build_log[n] = 0;
}

/* The binary of a built single-device program, malloc'd; NULL when the driver
 * gives none. */
static unsigned char *program_binary(cl_program prog, size_t *len)
{
    size_t size = 0;
    if (clGetProgramInfo(prog, CL_PROGRAM_BINARY_SIZES, sizeof size, &size, NULL) !=
            CL_SUCCESS ||
        size == 0)
        return NULL;
    unsigned char *bin = spt_malloc(size);
    if (clGetProgramInfo(prog, CL_PROGRAM_BINARIES, sizeof bin, &bin, NULL) != CL_SUCCESS) {
        free(bin);
        return NULL;
    }
    *len = size;
    return bin;
}

/* Tries to make a program from a cached binary; NULL when that fails. */
static cl_program program_from_binary(ClDevice *d, const unsigned char *bin, size_t len,
                                      const char *options)
{
    cl_int status = CL_SUCCESS, err = CL_SUCCESS;
    cl_program prog =
        clCreateProgramWithBinary(d->context, 1, &d->info.id, &len, &bin, &status, &err);
    if (err != CL_SUCCESS || status != CL_SUCCESS || !prog) {
        if (prog)
            clReleaseProgram(prog);
        return NULL;
    }
    if (clBuildProgram(prog, 1, &d->info.id, options, NULL, NULL) != CL_SUCCESS) {
        clReleaseProgram(prog);
        return NULL;
    }
    return prog;
}

/* A compile from source in a thread of its own (cl_program_build_text). Every
 * field after the first four is guarded by lock; the waiter or, when the
 * waiter gave up (abandoned), the thread frees the job. */
typedef struct BuildJob {
    cl_program prog;
    cl_device_id dev;
    char *opts;
    cl_int err;
    pthread_mutex_t lock;
    pthread_cond_t cond;
    int done, abandoned;
} BuildJob;

static pthread_mutex_t abandoned_lock = PTHREAD_MUTEX_INITIALIZER;
static int abandoned_count;

int cl_builds_abandoned(void)
{
    pthread_mutex_lock(&abandoned_lock);
    int n = abandoned_count;
    pthread_mutex_unlock(&abandoned_lock);
    return n;
}

static void build_job_free(BuildJob *b)
{
    free(b->opts);
    pthread_mutex_destroy(&b->lock);
    pthread_cond_destroy(&b->cond);
    free(b);
}

static void *build_thread(void *arg)
{
    BuildJob *b = arg;
    cl_int err = clBuildProgram(b->prog, 1, &b->dev, b->opts, NULL, NULL);
    pthread_mutex_lock(&b->lock);
    b->err = err;
    b->done = 1;
    int gone = b->abandoned;
    pthread_cond_signal(&b->cond);
    pthread_mutex_unlock(&b->lock);
    if (gone) {
        clReleaseProgram(b->prog);
        build_job_free(b);
    }
    return NULL;
}

/* clBuildProgram(prog) for d, given up when *d->stop reaches 2: the build's
 * status, or 1 (not an OpenCL status) when given up, prog then no longer the
 * caller's. Without a stop flag, or when no thread can be made, it builds in
 * this thread. */
static cl_int build_stoppable(ClDevice *d, cl_program prog, const char *opts)
{
    if (!d->stop)
        return clBuildProgram(prog, 1, &d->info.id, opts, NULL, NULL);
    BuildJob *b = spt_calloc(1, sizeof *b);
    b->prog = prog;
    b->dev = d->info.id;
    b->opts = spt_strdup(opts);
    pthread_mutex_init(&b->lock, NULL);
    pthread_cond_init(&b->cond, NULL);
    pthread_t th;
    if (pthread_create(&th, NULL, build_thread, b)) {
        build_job_free(b);
        return clBuildProgram(prog, 1, &d->info.id, opts, NULL, NULL);
    }
    pthread_mutex_lock(&b->lock);
    /* The signal handler only sets the flag: look at it every 20 ms. */
    while (!b->done && *d->stop < 2) {
        struct timespec ts;
        clock_gettime(CLOCK_REALTIME, &ts);
        ts.tv_nsec += 20000000L;
        if (ts.tv_nsec >= 1000000000L) {
            ts.tv_sec++;
            ts.tv_nsec -= 1000000000L;
        }
        pthread_cond_timedwait(&b->cond, &b->lock, &ts);
    }
    if (!b->done) {
        b->abandoned = 1;
        pthread_mutex_unlock(&b->lock);
        pthread_detach(th);
        pthread_mutex_lock(&abandoned_lock);
        abandoned_count++;
        pthread_mutex_unlock(&abandoned_lock);
        return 1;
    }
    cl_int err = b->err;
    pthread_mutex_unlock(&b->lock);
    pthread_join(th, NULL);
    build_job_free(b);
    return err;
}

int cl_program_build_text(ClDevice *d, const char *name, const char *text,
                          const char *options, cl_program *out, SptError *e)
{
    double t0 = spt_now();
    *out = NULL;
    free(d->build_log);
    d->build_log = NULL;
    d->last_from_cache = 0;
    d->last_cache_path[0] = 0;
    char *src = NULL;
    int rc = cl_source_resolve_text(name, text, &src, e);
    if (rc)
        return rc;
    Buf opts = {0};
    if (options && *options) {
        cl_buf_add(&opts, options, strlen(options));
        cl_buf_add(&opts, " ", 1);
    }
    cl_buf_add(&opts, "-cl-std=CL1.2", 13);

    /* Cache key: everything that changes the binary. */
    Buf key = {0};
    unsigned long long src_hash = cl_fnv1a(SPT_FNV1A_INIT, src, strlen(src));
    cl_buf_printf(&key, "device=%s\ndriver=%s\nplatform=%s\nplatform_version=%s\n", d->info.name,
               d->info.driver_version, d->info.platform_name, d->info.platform_version);
    /* Intel's CPU runtime compiles differently with its vectoriser on or off
     * (cl_runtime_defaults; the environment, not a build option). */
    if (!strcmp(d->info.impl, "intel")) {
        const char *vec = getenv("CL_CONFIG_USE_VECTORIZER");
        cl_buf_printf(&key, "CL_CONFIG_USE_VECTORIZER=%s\n", vec ? vec : "(unset)");
    }
    cl_buf_printf(&key, "source=%016llx+%zu\noptions=", src_hash, strlen(src));
    cl_buf_add(&key, opts.s, opts.len);
    unsigned long long key_hash = cl_fnv1a(SPT_FNV1A_INIT, key.s, key.len);
    char dir[4096];
    cl_cache_dir(dir, sizeof dir);
    if (dir[0]) {
        if (snprintf(d->last_cache_path, sizeof d->last_cache_path, "%s/%016llx.clbin", dir,
                     key_hash) >= (int)sizeof d->last_cache_path)
            dir[0] = d->last_cache_path[0] = 0; /* an absurdly long path: no cache */
    }
    if (dir[0]) {
        size_t bl = 0;
        int corrupt = 0;
        unsigned char *bin = cl_cache_load(d->last_cache_path, key.s, &bl, &corrupt);
        if (bin) {
            cl_program prog = program_from_binary(d, bin, bl, opts.s);
            free(bin);
            if (prog) {
                d->cache_hits++;
                d->last_from_cache = 1;
                *out = prog;
                goto done;
            }
            corrupt = 1;
        }
        d->cache_rejected += corrupt;
    }

    d->cache_misses++;
    cl_int err = CL_SUCCESS;
    const char *srcp = src;
    cl_program prog = NULL;
    SPT_CL_CHECK_GOTO(e, (prog = clCreateProgramWithSource(d->context, 1, &srcp, NULL, &err), err),
                      rc, done);
    if (d->announce) {
        fprintf(stderr, "device %d: building the kernels (not in the cache; seconds to minutes)\n",
                d->info.index);
        fflush(stderr);
    }
    err = build_stoppable(d, prog, opts.s);
    if (err == 1) {
        rc = spt_fail(e, SPT_EXIT_INTERRUPTED, "render: stopped by a second signal during the "
                      "kernel build of device [%d] %s; nothing written", d->info.index, d->info.name);
        goto done;
    }
    if (err != CL_SUCCESS) {
        keep_build_log(d, prog);
        clReleaseProgram(prog);
        rc = spt_fail(e, SPT_EXIT_DEVICE,
                      "kernel build of %s failed on device [%d] %s (driver %s, platform %s): "
                      "%s (%d); build log follows",
                      name, d->info.index, d->info.name, d->info.driver_version,
                      d->info.platform_name, cl_error_name(err), (int)err);
        if (!d->build_log || !d->build_log[0]) {
            free(d->build_log);
            d->build_log = spt_strdup("(the driver gave no build log)\n");
        }
        goto done;
    }
    if (dir[0]) {
        size_t bl = 0;
        unsigned char *bin = program_binary(prog, &bl);
        if (bin)
            cl_cache_store(dir, d->last_cache_path, key.s, bin, bl);
        free(bin);
    }
    *out = prog;
done:
    free(src);
    free(opts.s);
    free(key.s);
    d->last_build_seconds = spt_now() - t0;
    return rc;
}

int cl_program_build(ClDevice *d, const char *path, const char *options, cl_program *out,
                     SptError *e)
{
    char full[600];
    char *text = cl_kernel_file_open(path, full, sizeof full, e);
    if (!text) {
        *out = NULL;
        return SPT_EXIT_DEVICE;
    }
    int rc = cl_program_build_text(d, full, text, options, out, e);
    free(text);
    return rc;
}
