/* Texture image decoding for the scene loader: image files or encoded bytes in
 * memory (PNG, JPEG, WebP and whatever else OpenImageIO reads) into float texels.
 * Its OpenImageIO code, src/io/texture_io.cpp, is part of the OpenImageIO
 * library libspectrace-oiio.so (src/io/oiio_lib.h), so it sits here beside the
 * rest of that library; src/io/oiio_lib.c implements these functions through it. */
#ifndef SPT_TEXTURE_IO_H
#define SPT_TEXTURE_IO_H

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Largest texture accepted, in texels per side and in bytes of float texels. */
#define SPT_TEXTURE_MAX_SIDE 32768
#define SPT_TEXTURE_MAX_BYTES ((size_t)1 << 30)

/* A decoded image: width*height*channels floats, the first row is the top of the
 * image (glTF v = 0), values as stored in the file scaled to [0,1] for integer
 * formats, without any colour conversion. */
typedef struct TextureImage {
    int width, height;
    int channels; /* 1..4 (extra channels are dropped) */
    float *texels;
} TextureImage;

/* Decodes the image file at path. Returns 0, or -1 with a short reason (no file
 * name) in why; img is then empty. */
int texture_io_load_file(const char *path, TextureImage *img, char *why, size_t why_size);

/* Decodes an encoded image held in memory (PNG, JPEG, WebP; the format is found
 * from its first bytes, mime_type is a hint and may be NULL). Same contract as
 * texture_io_load_file. */
int texture_io_load_memory(const void *data, size_t size, const char *mime_type,
                           TextureImage *img, char *why, size_t why_size);

/* Applies the exact inverse sRGB transfer to the colour channels of every texel
 * (grey of 1-2 channel images, RGB of 3-4 channel ones); alpha stays linear. */
void texture_io_srgb_to_linear(float *texels, size_t texel_count, int channels);

void texture_io_free(TextureImage *img);

#ifdef __cplusplus
}
#endif

#endif
