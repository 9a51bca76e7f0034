/* Program builds: from the cache when it holds the binary, else compiled (and
 * stored), with the build log kept for the error message. */
#include "cl/cl_internal.h"

#include <errno.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
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
    err = clBuildProgram(prog, 1, &d->info.id, opts.s, NULL, NULL);
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
