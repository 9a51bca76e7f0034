/* Shared OpenCL set-up for the tests that run kernels/ headers on a device
 * and compare with the host. */
#ifndef SPT_TEST_CL_UTIL_H
#define SPT_TEST_CL_UTIL_H

#include <CL/cl.h>

#include "cl/cl_device.h"
#include "test_util.h"

/* Opens the first device of the first platform with a context and an in-order
 * queue; without one, skips the calling test with a message. */
static void test_cl_open_first(cl_device_id *dev, cl_context *ctx, cl_command_queue *q)
{
    cl_platform_id plat;
    cl_uint np = 0;
    cl_runtime_defaults();
    if (clGetPlatformIDs(1, &plat, &np) != CL_SUCCESS || np == 0 ||
        clGetDeviceIDs(plat, CL_DEVICE_TYPE_ALL, 1, dev, NULL) != CL_SUCCESS) {
        print_message("no OpenCL device: skipped\n");
        skip();
    }
    cl_int err;
    *ctx = clCreateContext(NULL, 1, dev, NULL, NULL, &err);
    assert_int_equal(err, CL_SUCCESS);
    *q = clCreateCommandQueue(*ctx, *dev, 0, &err);
    assert_int_equal(err, CL_SUCCESS);
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

#endif
