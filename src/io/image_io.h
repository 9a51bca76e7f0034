/* The only OpenImageIO code (src/io/image_io.cpp), behind a C interface: writing
 * PNG, JPEG, TIFF and HDR files (encoded in memory; src/io/image_out.c writes the
 * bytes atomically) and reading any image back (for tests and tools). */
#ifndef SPT_IMAGE_IO_H
#define SPT_IMAGE_IO_H

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

#include "core/util.h" /* a C header without its own extern "C" */

/* Pixel types of image_io_write buffers. */
#define SPT_IMAGE_IO_U8 0
#define SPT_IMAGE_IO_F32 1

/* One string attribute of the written file (OpenImageIO names: "Software",
 * "ImageDescription", "oiio:ColorSpace", "Compression", or free names that formats
 * with free text, such as PNG, keep). */
typedef struct ImageIoAttr {
    const char *name;
    const char *value;
} ImageIoAttr;

/* Encodes width*height pixels of `channels` interleaved values (rows top to bottom)
 * of type SPT_IMAGE_IO_U8 or SPT_IMAGE_IO_F32 into a file image in memory, in the
 * format named by path's extension (path is only used for that and for messages);
 * OpenImageIO converts to what the format stores (HDR: RGBE). An integer attribute
 * is given as its decimal text with the name prefixed by "int:" (e.g.
 * "int:CompressionQuality"). On success *data (malloc'd) and *size hold the file's
 * bytes; the caller writes them, so every write error is seen (OpenImageIO's own
 * file writing does not report all of them). Returns SPT_EXIT_OK, or
 * SPT_EXIT_OUTPUT with OpenImageIO's reason, naming path. */
int image_io_encode(const char *path, const void *pixels, int pixel_type, int width,
                    int height, int channels, const ImageIoAttr *attrs, int attr_count,
                    unsigned char **data, size_t *size, SptError *e);

/* Loads the OpenImageIO library (src/io/oiio_lib.h) now, as the functions here do
 * on first use. Returns SPT_EXIT_OK, or SPT_EXIT_OUTPUT naming path (the output
 * that needs it) and why the library could not be loaded. */
int image_io_load(const char *path, SptError *e);

/* What a file holds, from its header. */
typedef struct ImageIoInfo {
    int width, height, channels;
    char format[32];           /* OpenImageIO's name of the pixel type: "uint8", "half", "float", "uint" */
    char format_name[32];      /* "openexr", "png", "tiff", "hdr", "jpeg" */
    char channel_names[8][32]; /* the first 8 */
} ImageIoInfo;

/* Reads the header of path. Returns SPT_EXIT_OK or SPT_EXIT_INPUT. */
int image_io_info(const char *path, ImageIoInfo *info, SptError *e);

/* Reads all channels of path as floats: *pixels is malloc'd, width*height*channels,
 * rows top to bottom (8-bit values become value/255, as stored, no transfer curve).
 * Returns SPT_EXIT_OK or SPT_EXIT_INPUT. */
int image_io_read(const char *path, float **pixels, int *width, int *height,
                  int *channels, SptError *e);

/* The metadata attribute `name` of path as text (numbers printed by OpenImageIO),
 * truncated to out_size. Returns 1 when present, 0 when absent, -1 when the file
 * cannot be opened (e filled). */
int image_io_attr(const char *path, const char *name, char *out, size_t out_size,
                  SptError *e);

#ifdef __cplusplus
}
#endif

#endif
