/* Shared OpenCL set-up for the tests that run kernels/ headers on a device
 * and compare with the host. */
#ifndef SPT_TEST_CL_UTIL_H
#define SPT_TEST_CL_UTIL_H

#include <CL/cl.h>
#include <math.h>

#include "cl/cl_device.h"
#include "test_util.h"

/* The first device of the first platform with a context and an in-order queue. */
typedef struct {
    cl_device_id dev;
    cl_context ctx;
    cl_command_queue q;
} TestCl;

/* Opens TestCl; without a device, skips the calling test with a message. */
static inline TestCl test_cl_open(void)
{
    TestCl c;
    cl_platform_id plat;
    cl_uint np = 0;
    cl_runtime_defaults();
    if (clGetPlatformIDs(1, &plat, &np) != CL_SUCCESS || np == 0 ||
        clGetDeviceIDs(plat, CL_DEVICE_TYPE_ALL, 1, &c.dev, NULL) != CL_SUCCESS) {
        print_message("no OpenCL device: skipped\n");
        skip();
    }
    cl_int err;
    c.ctx = clCreateContext(NULL, 1, &c.dev, NULL, NULL, &err);
    assert_int_equal(err, CL_SUCCESS);
    c.q = clCreateCommandQueue(c.ctx, c.dev, 0, &err);
    assert_int_equal(err, CL_SUCCESS);
    return c;
}

static inline void test_cl_close(TestCl *c)
{
    clReleaseCommandQueue(c->q);
    clReleaseContext(c->ctx);
}

/* Builds the OpenCL C source src on dev (kernels/ on the include path, OpenCL C
 * 1.2, then options, may be NULL); fails the test with the build log, naming
 * what, when it does not build. */
static cl_program test_cl_build(cl_context ctx, cl_device_id dev, const char *src,
                                const char *options, const char *what)
{
    char opts[512];
    snprintf(opts, sizeof opts, "-I kernels -cl-std=CL1.2%s%s", options ? " " : "",
             options ? options : "");
    cl_int err;
    cl_program prog = clCreateProgramWithSource(ctx, 1, &src, NULL, &err);
    assert_int_equal(err, CL_SUCCESS);
    if (clBuildProgram(prog, 1, &dev, opts, NULL, NULL) != CL_SUCCESS) {
        char log[8192] = "";
        clGetProgramBuildInfo(prog, dev, CL_PROGRAM_BUILD_LOG, sizeof log - 1, log, NULL);
        fail_msg("%s does not build as OpenCL C (%s): %s", what, opts, log);
    }
    return prog;
}

/* ---- The device-versus-host harness ------------------------------------------
 * A test kernel takes read-only input buffers, one output buffer and the count
 * of work-items n, and writes per work-item what the host then computes with
 * the same header (docs/testing.md: the kernels' headers compile on the host
 * too); test_cl_run runs the device half and test_cl_assert_agree compares. */

/* One read-only input buffer of a test kernel. */
typedef struct {
    const void *data;
    size_t size;
} TestClArg;

/* Builds src with options (test_cl_build; what names it) and runs its kernel
 * named kernel over n work-items, in work-groups of local (0: the
 * implementation's choice; otherwise n is rounded up to a multiple of local, so
 * the kernel must return for ids >= n), with the arguments in[0..nin), an output
 * buffer of out_size bytes, and int n; reads the output buffer into out. */
static inline void test_cl_run(const TestCl *cl, const char *src, const char *options, const char *what,
                               const char *kernel,
                               const TestClArg *in, int nin, void *out, size_t out_size, int n,
                               size_t local)
{
    cl_program prog = test_cl_build(cl->ctx, cl->dev, src, options, what);
    cl_int err;
    cl_kernel k = clCreateKernel(prog, kernel, &err);
    assert_int_equal(err, CL_SUCCESS);
    cl_mem bufs[9];
    assert_true(nin >= 0 && nin < 9);
    for (int i = 0; i <= nin; i++) {
        bufs[i] = i < nin ? clCreateBuffer(cl->ctx, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, in[i].size,
                                           (void *)in[i].data, &err)
                          : clCreateBuffer(cl->ctx, CL_MEM_WRITE_ONLY, out_size, NULL, &err);
        assert_int_equal(err, CL_SUCCESS);
        assert_int_equal(clSetKernelArg(k, (cl_uint)i, sizeof(cl_mem), &bufs[i]), CL_SUCCESS);
    }
    assert_int_equal(clSetKernelArg(k, (cl_uint)nin + 1, sizeof n, &n), CL_SUCCESS);
    size_t global = local ? ((size_t)n + local - 1) / local * local : (size_t)n;
    assert_int_equal(clEnqueueNDRangeKernel(cl->q, k, 1, NULL, &global, local ? &local : NULL, 0, NULL,
                                            NULL),
                     CL_SUCCESS);
    assert_int_equal(clEnqueueReadBuffer(cl->q, bufs[nin], CL_TRUE, 0, out_size, out, 0, NULL, NULL),
                     CL_SUCCESS);
    for (int i = 0; i <= nin; i++)
        clReleaseMemObject(bufs[i]);
    clReleaseKernel(k);
    clReleaseProgram(prog);
}

/* The device's outputs got[0..count) of input i equal the host's want within
 * rel of max(1, |want|) (float rounding: the device may contract a * b + c into
 * one fma); fails naming the input and output otherwise. */
static inline void test_cl_assert_agree(int i, const float *got, const float *want, int count, float rel)
{
    for (int j = 0; j < count; j++)
        if (!(fabsf(got[j] - want[j]) <= rel * fmaxf(1.0f, fabsf(want[j]))))
            fail_msg("input %d, output %d: device %.9g, host %.9g", i, j, got[j], want[j]);
}

#endif
