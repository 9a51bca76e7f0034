/* Denoising with Intel Open Image Denoise 2 (--denoise), loaded at run time so
 * that spectrace builds and renders without it: `make denoise` installs the
 * shared libraries of the PyPI package pyoidn into deps/oidn/lib/ of the
 * project (tools/install_oidn.sh). */
#ifndef SPT_DENOISE_H
#define SPT_DENOISE_H

#include <stddef.h>

#include "core/util.h"
#include "io/oidn_api.h"

typedef struct Denoiser {
    void *lib;      /* dlopen handle */
    char path[1024]; /* the library loaded (after a failure: why) */
#define SPT_OIDN_POINTER(ret, name, params) ret(*name) params;
    SPT_OIDN_FUNCTIONS(SPT_OIDN_POINTER)
#undef SPT_OIDN_POINTER
} Denoiser;

/* Loads libOpenImageDenoise.so.2 from, in order: the file SPECTRACE_OIDN names;
 * deps/oidn/lib/ of the project (next to the program's folder, or one above:
 * build/spectrace and build/tests/); the system's library path. Returns 0, or
 * SPT_EXIT_USAGE with one message saying how to install it. */
int denoiser_open(Denoiser *d, SptError *e);

void denoiser_close(Denoiser *d);

/* Denoises color (linear RGB, 3 floats per pixel, HDR) into out with the RT
 * filter, guided by albedo and normal (3 floats per pixel each). clean_aux: the
 * guides are free of noise (OIDN's cleanAux); otherwise they are first
 * denoised themselves, in place, as Open Image Denoise recommends. The colour
 * is denoised divided by its level (a power of two), and out multiplied back,
 * so the result does not depend on the image's scale. Returns 0 or
 * SPT_EXIT_FAILURE with the library's message. */
int denoiser_run(Denoiser *d, const float *color, float *albedo, float *normal, int width, int height,
                 int clean_aux, float *out, SptError *e);

#endif
