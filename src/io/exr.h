/* OpenEXR files through the OpenEXR C API (OpenEXRCore, <openexr.h>): the linear
 * RGB image output, and multi-channel files for checkpoints (film sums and
 * per-pixel sample counts as named channels, with string/int/double attributes).
 *
 * Files are single-part scanline images, ZIP compressed (lossless), data window =
 * display window = (0,0)-(width-1,height-1), rows stored top to bottom. Writes are
 * atomic (temporary file in the same folder, then rename; see src/io/atomic_file.h,
 * including its test hook). */
#ifndef SPT_EXR_H
#define SPT_EXR_H

#include <stdint.h>

#include "core/util.h"

/* Channel sample types. */
#define SPT_EXR_FLOAT 0 /* 32-bit float (half channels read back as float too) */
#define SPT_EXR_UINT 1  /* 32-bit unsigned int: exact sample counts */

/* Attribute value types. */
#define SPT_EXR_ATTR_STRING 0
#define SPT_EXR_ATTR_INT 1    /* int32 */
#define SPT_EXR_ATTR_DOUBLE 2

/* One channel. Writing: name (EXR sorts channels by name; any order here), type,
 * data = width*height values of that type read as data[(y*width + x) * stride]
 * (stride in values, 0 means 1, so interleaved buffers need no copy).
 * Reading (ExrLayers): the file's channel, data owned by the ExrLayers, stride 1,
 * uint channels as uint32_t, float and half channels as float. */
typedef struct ExrChannel {
    const char *name;
    int type; /* SPT_EXR_FLOAT or SPT_EXR_UINT */
    const void *data;
    int stride;
} ExrChannel;

/* One header attribute: name (at most 255 bytes; avoid the names of the standard
 * attributes such as "channels" or "compression"), type and the matching value. */
typedef struct ExrAttr {
    const char *name;
    int type; /* SPT_EXR_ATTR_* */
    const char *s;
    int32_t i;
    double d;
} ExrAttr;

/* Writes `channel_count` channels of width*height pixels and `attr_count`
 * attributes to path atomically. Returns SPT_EXIT_OK, or SPT_EXIT_OUTPUT naming
 * path and the reason (folder missing or not writable, disk full, bad argument). */
int exr_write_layers(const char *path, int width, int height, const ExrChannel *channels,
                     int channel_count, const ExrAttr *attrs, int attr_count, SptError *e);

/* The image output: rgb is linear sRGB, 3 interleaved floats per pixel, rows top to
 * bottom; written as float channels R, G, B with the sRGB/Rec. 709 primaries and D65
 * white as the standard "chromaticities" attribute, plus attrs. Atomic. */
int exr_write_rgb(const char *path, const float *rgb, int width, int height,
                  const ExrAttr *attrs, int attr_count, SptError *e);

/* exr_write_rgb with more channels: layer_count channels of layers (names as
 * OpenEXR's layer.channel convention has them, e.g. "albedo.R", "Z") beside R,
 * G and B. */
int exr_write_rgb_layers(const char *path, const float *rgb, int width, int height,
                         const ExrChannel *layers, int layer_count, const ExrAttr *attrs,
                         int attr_count, SptError *e);

/* The content of a file read by exr_read_layers; free with exr_layers_free. */
typedef struct ExrLayers {
    int width, height;
    int channel_count;
    ExrChannel *channels; /* names and data owned here */
    int attr_count;
    ExrAttr *attrs;       /* the file's string, int and double attributes (others
                             are skipped); names and strings owned here */
} ExrLayers;

/* Reads every channel and the string/int/double attributes of path. Refuses with
 * SPT_EXIT_INPUT and a message naming path and the reason: a missing, damaged or
 * truncated file, a tiled, deep or multi-part file, subsampled channels, a data
 * window wider or taller than SPT_EXR_READ_MAX_SIDE (it reads what spectrace
 * writes: checkpoints; a damaged header must not claim gigabytes), and a file
 * that lacks one of the `required_count` channel names in `required` (may be NULL
 * when 0). On failure *out is empty. */
#define SPT_EXR_READ_MAX_SIDE 16384 /* the largest --width/--height */
int exr_read_layers(const char *path, const char *const *required, int required_count,
                    ExrLayers *out, SptError *e);

void exr_layers_free(ExrLayers *l);

/* The channel of that name, or NULL. */
const ExrChannel *exr_layers_channel(const ExrLayers *l, const char *name);

/* The attribute of that name and type, or NULL. */
const ExrAttr *exr_layers_attr(const ExrLayers *l, const char *name, int type);

#endif
