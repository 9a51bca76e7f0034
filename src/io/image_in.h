/* Reading an image whole (an environment map: src/scene/sky.c; tests reading
 * back what src/io/image_out.c wrote), through OpenImageIO (src/io/image_io.h),
 * which reads EXR too. The writer is src/io/image_out.h. */
#ifndef SPT_IMAGE_IN_H
#define SPT_IMAGE_IN_H

#include "core/util.h"

/* Reads any image OpenImageIO can read as linear-as-stored RGB floats (the first
 * three channels; a grey image is replicated): *rgb is malloc'd, width*height*3
 * floats, rows top to bottom; 8-bit files give value/255 (no sRGB decoding).
 * Returns SPT_EXIT_OK or SPT_EXIT_INPUT. */
int image_read_rgb(const char *path, float **rgb, int *width, int *height, SptError *e);

#endif
