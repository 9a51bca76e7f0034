/* Open Image Denoise 2 through dlopen (src/io/denoise.h). */
#include "io/denoise.h"

#include <dlfcn.h>
#include <errno.h>
#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#define OIDN_SONAME "libOpenImageDenoise.so.2"

/* Loads path and every function; 0 when all are there. */
static int try_load(Denoiser *d, const char *path)
{
    void *lib = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (!lib) {
        const char *why = dlerror();
        snprintf(d->path, sizeof d->path, "%s", why ? why : "cannot load");
        return -1;
    }
    int ok = 1;
#define SPT_OIDN_LOAD(ret, name, params)                                                       \
    *(void **)(&d->name) = dlsym(lib, #name);                                                  \
    ok &= d->name != NULL;
    SPT_OIDN_FUNCTIONS(SPT_OIDN_LOAD)
#undef SPT_OIDN_LOAD
    if (!ok) {
        dlclose(lib);
        snprintf(d->path, sizeof d->path, "%s: an Open Image Denoise 2 function is missing", path);
        return -1;
    }
    d->lib = lib;
    snprintf(d->path, sizeof d->path, "%s", path);
    return 0;
}

int denoiser_open(Denoiser *d, SptError *e)
{
    memset(d, 0, sizeof *d);
    const char *env = getenv("SPECTRACE_OIDN");
    if (env && *env) {
        /* dlopen of a FIFO waits for a writer, and of a device file reads it:
         * only a regular file (or a link to one) can be the library. */
        struct stat st;
        if (stat(env, &st))
            return spt_fail(e, SPT_EXIT_USAGE, "render: --denoise: SPECTRACE_OIDN names %s: %s", env,
                            strerror(errno));
        if (!S_ISREG(st.st_mode))
            return spt_fail(e, SPT_EXIT_USAGE,
                            "render: --denoise: SPECTRACE_OIDN names %s, which is not a regular file (%s), "
                            "so not an Open Image Denoise 2 library",
                            env, S_ISDIR(st.st_mode) ? "a folder" : S_ISFIFO(st.st_mode) ? "a FIFO"
                                 : S_ISCHR(st.st_mode) || S_ISBLK(st.st_mode) ? "a device file" : "a socket");
        if (!try_load(d, env))
            return 0;
        return spt_fail(e, SPT_EXIT_USAGE,
                        "render: --denoise: SPECTRACE_OIDN names %s, which is not a loadable Open Image "
                        "Denoise 2 library (%s)",
                        env, d->path);
    }
    /* deps/oidn/lib/ beside the folder of the program, or of the file this
     * code is in (build/libspectrace.so, loaded by another program: docs/
     * api.md), or the folder above it. */
    char bases[2][PATH_MAX];
    int nb = 0;
    ssize_t n = readlink("/proc/self/exe", bases[0], sizeof bases[0] - 1);
    if (n > 0)
        bases[nb++][n] = 0;
    Dl_info self;
    if (dladdr((void *)denoiser_open, &self) && self.dli_fname && self.dli_fname[0] == '/')
        snprintf(bases[nb++], sizeof bases[0], "%s", self.dli_fname);
    for (int b = 0; b < nb; b++) {
        char exe[PATH_MAX];
        memcpy(exe, bases[b], sizeof exe);
        for (int up = 1; up <= 2; up++) {
            char *slash = strrchr(exe, '/');
            if (!slash)
                break;
            *slash = 0;
            char path[PATH_MAX + 64];
            snprintf(path, sizeof path, "%s/../deps/oidn/lib/" OIDN_SONAME, exe);
            if (access(path, R_OK) == 0 && !try_load(d, path))
                return 0;
        }
    }
    if (!try_load(d, OIDN_SONAME))
        return 0;
    return spt_fail(e, SPT_EXIT_USAGE,
                    "render: --denoise needs Intel Open Image Denoise 2 (" OIDN_SONAME
                    "), which is not installed: run `make denoise` in the spectrace folder (it "
                    "installs the PyPI package pyoidn's libraries into deps/oidn/), or set "
                    "SPECTRACE_OIDN to the library's path");
}

void denoiser_close(Denoiser *d)
{
    if (d->lib)
        dlclose(d->lib);
    memset(d, 0, sizeof *d);
}

/* The device's pending error as an SptError; 0 when none. */
static int device_error(Denoiser *d, OIDNDevice dev, const char *stage, SptError *e)
{
    const char *msg = NULL;
    if (d->oidnGetDeviceError(dev, &msg) == OIDN_ERROR_NONE)
        return 0;
    return spt_fail(e, SPT_EXIT_FAILURE, "render: --denoise: Open Image Denoise (%s) failed on the %s: %s; no "
                    "output written", d->path, stage, msg ? msg : "no message");
}

/* Commits the filter f, runs it and releases it; stage names it in errors. */
static int execute_filter(Denoiser *d, OIDNDevice dev, OIDNFilter f, const char *stage, SptError *e)
{
    d->oidnCommitFilter(f);
    int rc = device_error(d, dev, stage, e);
    if (!rc) {
        d->oidnExecuteFilter(f);
        rc = device_error(d, dev, stage, e);
    }
    d->oidnReleaseFilter(f);
    return rc;
}

/* One RT filter: color (and the guides when given) into out. */
static int run_filter(Denoiser *d, OIDNDevice dev, float *color, float *albedo, float *normal, int width,
                      int height, int hdr, int clean_aux, float *out, const char *stage, SptError *e)
{
    OIDNFilter f = d->oidnNewFilter(dev, "RT");
    if (!f)
        return device_error(d, dev, stage, e) ? SPT_EXIT_FAILURE
                                                : spt_fail(e, SPT_EXIT_FAILURE, "render: --denoise: no RT filter");
    size_t w = (size_t)width, h = (size_t)height;
    d->oidnSetSharedFilterImage(f, "color", color, OIDN_FORMAT_FLOAT3, w, h, 0, 0, 0);
    if (albedo)
        d->oidnSetSharedFilterImage(f, "albedo", albedo, OIDN_FORMAT_FLOAT3, w, h, 0, 0, 0);
    if (normal)
        d->oidnSetSharedFilterImage(f, "normal", normal, OIDN_FORMAT_FLOAT3, w, h, 0, 0, 0);
    d->oidnSetSharedFilterImage(f, "output", out, OIDN_FORMAT_FLOAT3, w, h, 0, 0, 0);
    d->oidnSetFilterBool(f, "hdr", hdr != 0);
    if (albedo)
        d->oidnSetFilterBool(f, "cleanAux", clean_aux != 0);
    return execute_filter(d, dev, f, stage, e);
}

/* Prefilters a noisy guide in place: an RT filter with only that image
 * ("albedo" or "normal") as input, as Open Image Denoise's documentation
 * describes. */
static int prefilter(Denoiser *d, OIDNDevice dev, const char *name, float *img, int width, int height,
                     SptError *e)
{
    OIDNFilter f = d->oidnNewFilter(dev, "RT");
    if (!f)
        return device_error(d, dev, name, e) ? SPT_EXIT_FAILURE
                                               : spt_fail(e, SPT_EXIT_FAILURE, "render: --denoise: no RT filter");
    d->oidnSetSharedFilterImage(f, name, img, OIDN_FORMAT_FLOAT3, (size_t)width, (size_t)height, 0, 0, 0);
    d->oidnSetSharedFilterImage(f, "output", img, OIDN_FORMAT_FLOAT3, (size_t)width, (size_t)height, 0, 0, 0);
    return execute_filter(d, dev, f, name, e);
}

/* The power of two nearest the mean absolute value of the n floats of v (1 for
 * a black image): the level the image is brought to 1 by, exactly (a power of
 * two changes no bit of a float's significand). */
static double image_level(const float *v, size_t n)
{
    double sum = 0;
    for (size_t i = 0; i < n; i++)
        sum += fabs((double)v[i]);
    double mean = n ? sum / (double)n : 0;
    if (!(mean > 0) || !isfinite(mean))
        return 1;
    return ldexp(1.0, (int)lround(log2(mean)));
}

int denoiser_run(Denoiser *d, const float *color, float *albedo, float *normal, int width, int height,
                 int clean_aux, float *out, SptError *e)
{
    /* Open Image Denoise's HDR filter works on values in a normal range: its
     * automatic exposure leaves an image whose values all lie below about 1e-8
     * as it is, which then comes out unrelated to its input. The image is
     * brought to a mean of about 1 and the result back by the same power of
     * two (docs/outputs.md, "Denoising"); the guides (albedo, normal) do not
     * depend on the light. */
    size_t n = 3 * (size_t)width * (size_t)height;
    double level = image_level(color, n);
    float *scaled = spt_malloc(n * sizeof(float));
    for (size_t i = 0; i < n; i++)
        scaled[i] = (float)(color[i] / level);
    OIDNDevice dev = d->oidnNewDevice(OIDN_DEVICE_TYPE_DEFAULT);
    if (!dev) {
        free(scaled);
        return spt_fail(e, SPT_EXIT_FAILURE, "render: --denoise: Open Image Denoise found no device");
    }
    d->oidnCommitDevice(dev);
    int rc = device_error(d, dev, "device", e);
    if (!rc && !clean_aux)
        rc = prefilter(d, dev, "albedo", albedo, width, height, e);
    if (!rc && !clean_aux)
        rc = prefilter(d, dev, "normal", normal, width, height, e);
    if (!rc)
        rc = run_filter(d, dev, scaled, albedo, normal, width, height, 1, 1, out, "image", e);
    d->oidnReleaseDevice(dev);
    free(scaled);
    for (size_t i = 0; i < n && !rc; i++)
        out[i] = (float)(out[i] * level);
    return rc;
}
