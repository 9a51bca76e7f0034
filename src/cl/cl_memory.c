/* Device memory: the check of a render's buffers against the device's limits
 * before allocating, and buffer creation with errors that name the buffer. */
#include "cl/cl_internal.h"

#include <errno.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

/* "1.50 GiB", "12.0 MiB", "512 B". */
static const char *fmt_bytes(char *buf, size_t n, unsigned long long bytes)
{
    static const char *units[] = {"B", "KiB", "MiB", "GiB", "TiB"};
    double v = (double)bytes;
    int u = 0;
    while (v >= 1024.0 && u < 4) {
        v /= 1024.0;
        u++;
    }
    if (u == 0)
        snprintf(buf, n, "%llu B", bytes);
    else
        snprintf(buf, n, "%.2f %s", v, units[u]);
    return buf;
}

int cl_device_check_memory(const ClDeviceInfo *info, const ClAlloc *allocs, int n,
                           SptError *e)
{
    char a[32], b[32];
    unsigned long long total = 0;
    for (int i = 0; i < n; i++) {
        if (allocs[i].bytes > info->max_alloc)
            return spt_fail(e, SPT_EXIT_DEVICE,
                            "device [%d] %s: buffer '%s' needs %s (%zu bytes) but the device "
                            "allows at most %s (%llu bytes) per allocation "
                            "(CL_DEVICE_MAX_MEM_ALLOC_SIZE)",
                            info->index, info->name, allocs[i].name,
                            fmt_bytes(a, sizeof a, allocs[i].bytes), allocs[i].bytes,
                            fmt_bytes(b, sizeof b, info->max_alloc),
                            (unsigned long long)info->max_alloc);
        total += allocs[i].bytes;
    }
    if (total > info->global_mem)
        return spt_fail(e, SPT_EXIT_DEVICE,
                        "device [%d] %s: the %d buffers need %s (%llu bytes) in total but the "
                        "device has %s (%llu bytes) of global memory (CL_DEVICE_GLOBAL_MEM_SIZE)",
                        info->index, info->name, n, fmt_bytes(a, sizeof a, total), total,
                        fmt_bytes(b, sizeof b, info->global_mem),
                        (unsigned long long)info->global_mem);
    return SPT_EXIT_OK;
}

int cl_buffer_create(ClDevice *d, const char *name, cl_mem_flags flags, size_t bytes,
                     void *host, cl_mem *out, SptError *e)
{
    *out = NULL;
    ClAlloc a = {name, bytes};
    int rc = cl_device_check_memory(&d->info, &a, 1, e);
    if (rc)
        return rc;
    cl_int err = CL_SUCCESS;
    /* OpenCL rejects zero-sized buffers; a one-byte buffer keeps empty scenes
     * (no lights, no textures) legal. */
    rc = cl_check((*out = clCreateBuffer(d->context, flags, bytes ? bytes : 1, host, &err), err),
                  "clCreateBuffer", __FILE__, __LINE__, e);
    if (rc) {
        char prefix[700], sz[32];
        snprintf(prefix, sizeof prefix, "device [%d] %.256s: buffer '%.256s' (%s): ",
                 d->info.index, d->info.name, name, fmt_bytes(sz, sizeof sz, bytes));
        cl_prefix_error(e, prefix);
    }
    return rc;
}
