/* The OpenImageIO part of spectrace (src/io/image_io.cpp, src/io/texture_io.cpp)
 * is its own shared library, libspectrace-oiio.so beside the program, which
 * src/io/oiio_lib.c loads when an image is first read or written (a PNG, JPEG,
 * TIFF or HDR output, a texture, an environment map). A run that reads and
 * writes no such image (an EXR-only render, `spectrace info`, every early
 * error) then does not load OpenImageIO's 260 shared libraries, which cost about
 * 0.4 s of CPU time per process. image_io.h and texture_io.h keep their
 * contracts; these are the library's entry points behind them. The library
 * calls back into the program for spt_fail, input_check and texture_io_free
 * (exported by the programs: src/io/oiio_exports.list). */
#ifndef SPT_OIIO_LIB_H
#define SPT_OIIO_LIB_H

#include "io/image_io.h"
#include "io/texture_io.h"

#ifdef __cplusplus
extern "C" {
#endif

int oiio_image_encode(const char *path, const void *pixels, int pixel_type, int width,
                      int height, int channels, const ImageIoAttr *attrs, int attr_count,
                      unsigned char **data, size_t *size, SptError *e);
int oiio_image_info(const char *path, ImageIoInfo *info, SptError *e);
int oiio_image_read(const char *path, float **pixels, int *width, int *height, int *channels,
                    SptError *e);
int oiio_image_attr(const char *path, const char *name, char *out, size_t out_size,
                    SptError *e);
int oiio_texture_load_file(const char *path, TextureImage *img, char *why, size_t why_size);
int oiio_texture_load_memory(const void *data, size_t size, const char *mime_type,
                             TextureImage *img, char *why, size_t why_size);

#ifdef __cplusplus
}
#endif

#endif
