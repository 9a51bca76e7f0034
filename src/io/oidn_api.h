/* The few declarations of Intel Open Image Denoise 2's C API that spectrace
 * uses, for loading the library at run time (src/io/denoise.c): as declared in
 * OpenImageDenoise/oidn.h of Open Image Denoise 2.x (checked against 2.5.1, the
 * version the PyPI package pyoidn 2.5.1.0 ships; the API is stable within
 * major version 2). Handles are opaque pointers; enums are C ints. */
#ifndef SPT_OIDN_API_H
#define SPT_OIDN_API_H

#include <stdbool.h>
#include <stddef.h>

typedef void *OIDNDevice;
typedef void *OIDNFilter;

#define OIDN_DEVICE_TYPE_DEFAULT 0 /* OIDNDeviceType */
#define OIDN_DEVICE_TYPE_CPU 1
#define OIDN_FORMAT_FLOAT3 3 /* OIDNFormat */
#define OIDN_ERROR_NONE 0    /* OIDNError */

/* X(return type, name, parameters) for each function used. */
#define SPT_OIDN_FUNCTIONS(X)                                                                   \
    X(OIDNDevice, oidnNewDevice, (int type))                                                    \
    X(void, oidnCommitDevice, (OIDNDevice device))                                              \
    X(void, oidnReleaseDevice, (OIDNDevice device))                                             \
    X(int, oidnGetDeviceError, (OIDNDevice device, const char **out_message))                   \
    X(OIDNFilter, oidnNewFilter, (OIDNDevice device, const char *type))                         \
    X(void, oidnSetSharedFilterImage,                                                           \
      (OIDNFilter filter, const char *name, void *dev_ptr, int format, size_t width,            \
       size_t height, size_t byte_offset, size_t pixel_byte_stride, size_t row_byte_stride))    \
    X(void, oidnSetFilterBool, (OIDNFilter filter, const char *name, bool value))               \
    X(void, oidnCommitFilter, (OIDNFilter filter))                                              \
    X(void, oidnExecuteFilter, (OIDNFilter filter))                                             \
    X(void, oidnReleaseFilter, (OIDNFilter filter))

#endif
