/* The layout check: the device's sizeof and offsetof of every struct shared with
 * the host (kernels/util/layout_list.h), compared with the host's. */
#include "cl/cl_internal.h"

#include <errno.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "util/layout_list.h"

typedef struct LayoutEntry {
    const char *name;
    unsigned value;
} LayoutEntry;

#define SPT_LAYOUT_HOST_SIZE(T) {#T, (unsigned)sizeof(T)},
#define SPT_LAYOUT_HOST_FIELD(T, f) {#T "." #f, (unsigned)offsetof(T, f)},
static const LayoutEntry layout_host[] = {SPT_LAYOUT_STRUCTS(SPT_LAYOUT_HOST_SIZE)
                                              SPT_LAYOUT_FIELDS(SPT_LAYOUT_HOST_FIELD)};
#undef SPT_LAYOUT_HOST_SIZE
#undef SPT_LAYOUT_HOST_FIELD

int cl_layout_count(void)
{
    return (int)(sizeof layout_host / sizeof layout_host[0]);
}

int cl_layout_query(ClDevice *d, unsigned *values, int n, SptError *e)
{
    if (n != cl_layout_count())
        return spt_fail(e, SPT_EXIT_FAILURE, "cl_layout_query: %d values asked, %d listed", n,
                        cl_layout_count());
    cl_program prog = NULL;
    cl_kernel k = NULL;
    cl_mem buf = NULL;
    cl_int err = CL_SUCCESS;
    int rc = cl_program_build(d, "kernels/util/layout_check.cl", NULL, &prog, e);
    if (rc)
        return rc;
    size_t bytes = (size_t)n * sizeof(cl_uint);
    cl_uint *tmp = spt_calloc((size_t)n, sizeof(cl_uint));
    SPT_CL_CHECK_GOTO(e, (k = clCreateKernel(prog, "k_layout_sizes", &err), err), rc, done);
    SPT_CL_CHECK_GOTO(e, (buf = clCreateBuffer(d->context, CL_MEM_WRITE_ONLY, bytes, NULL, &err),
                          err),
                      rc, done);
    SPT_CL_CHECK_GOTO(e, clSetKernelArg(k, 0, sizeof buf, &buf), rc, done);
    size_t global = 1;
    SPT_CL_CHECK_GOTO(e, clEnqueueNDRangeKernel(d->queue, k, 1, NULL, &global, NULL, 0, NULL,
                                                NULL),
                      rc, done);
    SPT_CL_CHECK_GOTO(e, clEnqueueReadBuffer(d->queue, buf, CL_TRUE, 0, bytes, tmp, 0, NULL,
                                             NULL),
                      rc, done);
    for (int i = 0; i < n; i++)
        values[i] = tmp[i];
done:
    free(tmp);
    if (buf)
        clReleaseMemObject(buf);
    if (k)
        clReleaseKernel(k);
    clReleaseProgram(prog);
    return rc;
}

int cl_layout_check(ClDevice *d, SptError *e)
{
    int n = cl_layout_count();
    unsigned *dev = spt_calloc((size_t)n, sizeof *dev);
    int rc = cl_layout_query(d, dev, n, e);
    for (int i = 0; i < n && !rc; i++)
        if (dev[i] != layout_host[i].value)
            rc = spt_fail(e, SPT_EXIT_DEVICE,
                          "device [%d] %s: shared struct layout differs: %s %s %u on the "
                          "device but %u on the host (kernels/util/layout_list.h)",
                          d->info.index, d->info.name, layout_host[i].name,
                          strchr(layout_host[i].name, '.') ? "is at offset" : "has size",
                          dev[i], layout_host[i].value);
    free(dev);
    return rc;
}
