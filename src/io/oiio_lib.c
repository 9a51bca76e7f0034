/* Loads libspectrace-oiio.so on first use (src/io/oiio_lib.h) and implements
 * image_io.h and texture_io.h through it. */
#include "io/oiio_lib.h"

#include <dlfcn.h>
#include <limits.h>
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "core/input_file.h"
#include "io/srgb.h"

#define OIIO_LIB_NAME "libspectrace-oiio.so"

/* The library's entry points, by name. */
#define OIIO_ENTRIES(X)                                                                  \
    X(oiio_image_encode)                                                                 \
    X(oiio_image_info)                                                                   \
    X(oiio_image_read)                                                                   \
    X(oiio_image_attr)                                                                   \
    X(oiio_texture_load_file)                                                            \
    X(oiio_texture_load_memory)

static struct {
#define FIELD(name) __typeof__(name) *name;
    OIIO_ENTRIES(FIELD)
#undef FIELD
} lib;
/* What the library calls back in the program (src/io/oiio_exports.list).
 * Named here, they are linked into every program that can load the library,
 * whatever else it uses of libspectrace.a (a static library brings only the
 * objects that something references). */
__attribute__((used)) static const void *const lib_callbacks[] = {
    (const void *)spt_fail, (const void *)input_check, (const void *)texture_io_free};
static pthread_once_t lib_once = PTHREAD_ONCE_INIT;
static char lib_error[600]; /* why the library could not be loaded; empty when loaded */

/* dlopen of dir/OIIO_LIB_NAME when that file exists: *tried = 1, and NULL with
 * the reason in lib_error when it does not load. */
static void *open_in(const char *dir, int *tried)
{
    char path[PATH_MAX + 32];
    snprintf(path, sizeof path, "%s/%s", dir, OIIO_LIB_NAME);
    if (*tried || access(path, F_OK) != 0)
        return NULL;
    *tried = 1;
    void *h = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (!h)
        snprintf(lib_error, sizeof lib_error, "%s", dlerror());
    return h;
}

/* Looks for the library in SPECTRACE_OIIO_DIR when set, else beside the program,
 * then in the folder above it (the test and tool programs in build/tests and
 * build/tools), then in the build folder it was built in; the first that
 * exists is loaded. */
static void lib_load(void)
{
    snprintf(lib_error, sizeof lib_error,
             "%s was not found beside the program (or in SPECTRACE_OIIO_DIR)", OIIO_LIB_NAME);
    void *h = NULL;
    int tried = 0;
    const char *env = getenv("SPECTRACE_OIIO_DIR");
    if (env && *env) {
        h = open_in(env, &tried);
    } else {
        char dir[PATH_MAX];
        ssize_t n = readlink("/proc/self/exe", dir, sizeof dir - 1);
        char *slash = n > 0 ? (dir[n] = 0, strrchr(dir, '/')) : NULL;
        if (slash) {
            *slash = 0;
            h = open_in(dir, &tried);
            if ((slash = strrchr(dir, '/'))) {
                *slash = 0;
                h = h ? h : open_in(dir, &tried);
            }
        }
#ifdef SPT_OIIO_BUILD_DIR
        h = h ? h : open_in(SPT_OIIO_BUILD_DIR, &tried);
#endif
    }
    if (!h)
        return;
#define RESOLVE(name)                                                                    \
    if (!(lib.name = (__typeof__(name) *)dlsym(h, #name))) {                            \
        snprintf(lib_error, sizeof lib_error, "%s: no %s", OIIO_LIB_NAME, #name);        \
        return;                                                                          \
    }
    OIIO_ENTRIES(RESOLVE)
#undef RESOLVE
    lib_error[0] = 0;
}

/* 1 when the library is loaded; else 0 with the reason in lib_error. */
static int lib_ready(void)
{
    pthread_once(&lib_once, lib_load);
    return lib_error[0] == 0;
}

/* SPT_EXIT_OK when the library is loaded, else code with one line naming path
 * and what (the image "writer" or "reader") could not be loaded. */
static int lib_need(const char *path, const char *what, int code, SptError *e)
{
    if (lib_ready())
        return SPT_EXIT_OK;
    return spt_fail(e, code, "%s: cannot load the image %s: %s", path, what, lib_error);
}

int image_io_load(const char *path, SptError *e)
{
    return lib_need(path, "writer", SPT_EXIT_OUTPUT, e);
}

int image_io_encode(const char *path, const void *pixels, int pixel_type, int width,
                    int height, int channels, const ImageIoAttr *attrs, int attr_count,
                    unsigned char **data, size_t *size, SptError *e)
{
    int rc = lib_need(path, "writer", SPT_EXIT_OUTPUT, e);
    return rc ? rc
              : lib.oiio_image_encode(path, pixels, pixel_type, width, height, channels,
                                      attrs, attr_count, data, size, e);
}

int image_io_info(const char *path, ImageIoInfo *info, SptError *e)
{
    int rc = lib_need(path, "reader", SPT_EXIT_INPUT, e);
    return rc ? rc : lib.oiio_image_info(path, info, e);
}

int image_io_read(const char *path, float **pixels, int *width, int *height, int *channels,
                  SptError *e)
{
    int rc = lib_need(path, "reader", SPT_EXIT_INPUT, e);
    return rc ? rc : lib.oiio_image_read(path, pixels, width, height, channels, e);
}

int image_io_attr(const char *path, const char *name, char *out, size_t out_size, SptError *e)
{
    return lib_need(path, "reader", SPT_EXIT_INPUT, e)
               ? -1
               : lib.oiio_image_attr(path, name, out, out_size, e);
}

/* 0 when the library is loaded, else -1 with an empty img and the reason in why. */
static int texture_lib_need(TextureImage *img, char *why, size_t why_size)
{
    if (lib_ready())
        return 0;
    memset(img, 0, sizeof *img);
    snprintf(why, why_size, "cannot load the image reader: %s", lib_error);
    return -1;
}

int texture_io_load_file(const char *path, TextureImage *img, char *why, size_t why_size)
{
    return texture_lib_need(img, why, why_size) ? -1
                                                : lib.oiio_texture_load_file(path, img, why,
                                                                             why_size);
}

int texture_io_load_memory(const void *data, size_t size, const char *mime_type,
                           TextureImage *img, char *why, size_t why_size)
{
    return texture_lib_need(img, why, why_size)
               ? -1
               : lib.oiio_texture_load_memory(data, size, mime_type, img, why, why_size);
}

void texture_io_srgb_to_linear(float *texels, size_t texel_count, int channels)
{
    int colour = channels >= 3 ? 3 : 1; /* grey(+alpha) or RGB(+alpha) */
    for (size_t i = 0; i < texel_count; i++) {
        for (int c = 0; c < colour; c++) {
            float *v = &texels[i * (size_t)channels + (size_t)c];
            *v = (float)srgb_decode(*v);
        }
    }
}

void texture_io_free(TextureImage *img)
{
    free(img->texels);
    memset(img, 0, sizeof *img);
}
