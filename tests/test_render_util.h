/* Shared set-up of the tests that render through the library (src/render/):
 * the CPU device every such test renders on, and one render of a Scene. Include
 * after test_util.h. */
#ifndef SPT_TEST_RENDER_UTIL_H
#define SPT_TEST_RENDER_UTIL_H

#include <stdio.h>
#include <string.h>

#include "cl/cl_device.h"
#include "render/film.h"
#include "render/render.h"
#include "scene/scene.h"

static ClDeviceList devices;
static const ClDeviceInfo *device; /* the first CPU device */

/* cmocka group set-up: lists the devices and picks the CPU. */
static int setup_cpu_device(void **state)
{
    (void)state;
    SptError e = {0};
    int sel[64], n = 0;
    if (cl_device_list(&devices, &e) || cl_device_select(&devices, "cpu", sel, &n, &e)) {
        fprintf(stderr, "no OpenCL CPU device: %s\n", e.msg);
        return -1;
    }
    device = &devices.devices[sel[0]];
    return 0;
}

static int teardown_cpu_device(void **state)
{
    (void)state;
    cl_device_list_free(&devices);
    return 0;
}

#endif
