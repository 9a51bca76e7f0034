/* Image output: format dispatch by file extension, pre-flight checks of the output
 * path, display transforms (exposure, tone map, sRGB transfer) and atomic writes.
 *
 * Formats (by extension, case-insensitive):
 *   .exr          32-bit float linear RGB (channels R, G, B), ZIP, sRGB chromaticities,
 *                 metadata attributes; written with OpenEXRCore (src/io/exr.c)
 *   .hdr          Radiance RGBE, linear (OpenImageIO)
 *   .tif/.tiff    32-bit float linear RGB, ZIP (OpenImageIO)
 *   .png          8-bit sRGB after the display transform, tagged sRGB (OpenImageIO)
 *   .jpg/.jpeg    8-bit sRGB after the display transform, quality 95 (OpenImageIO)
 * Linear formats are never exposed nor tone mapped: they hold the film's values.
 *
 * Every write is atomic (src/io/atomic_file.h): a failed write never leaves a
 * partial file and never touches an existing output. */
#ifndef SPT_IMAGE_OUT_H
#define SPT_IMAGE_OUT_H

#include <stddef.h>
#include <stdint.h>

#include "core/util.h"
#include "io/exr.h"

/* Tone maps for display formats. */
#define SPT_TONEMAP_NONE 0
#define SPT_TONEMAP_NEUTRAL 1 /* Khronos PBR Neutral (2024) */

/* How display formats (PNG, JPEG) turn linear values into pixels: the linear value
 * times 2^exposure_ev, then the tone map, then the sRGB transfer and 8-bit rounding.
 * All zeros (or a NULL pointer) means no exposure change and no tone map. */
typedef struct DisplayOptions {
    float exposure_ev;
    int tonemap; /* SPT_TONEMAP_* */
} DisplayOptions;

#define SPT_IMAGE_META_MAX_EXTRA 8

/* What an image records about how it was made. Strings are borrowed (may be NULL);
 * they must stay valid during image_write. */
typedef struct ImageMeta {
    int spp;               /* samples per pixel */
    double render_seconds; /* wall-clock render time */
    const char *device;    /* e.g. "pthread-Intel(R) Xeon(R) (PoCL 5.0)" */
    uint32_t seed;
    const char *scene;     /* the scene path as given */
    const ExrChannel *layers; /* EXR only: more channels beside R, G, B (AOV layers) */
    int layer_count;
    const ExrAttr *exr_attrs; /* EXR only: attributes named as given (layouts' own) */
    int exr_attr_count;
    int extra_count;
    struct {
        const char *key;   /* [A-Za-z0-9_.]+, stored as "spectrace:<key>" */
        const char *value;
    } extra[SPT_IMAGE_META_MAX_EXTRA];
} ImageMeta;

/* Appends one extra key/value (both borrowed). Returns 0, or -1 when the list is
 * full. */
int image_meta_add(ImageMeta *meta, const char *key, const char *value);

/* Pre-flight check before rendering: path has a known extension (else
 * SPT_EXIT_USAGE), its name fits the file system (atomic_path_check), its folder
 * exists, is a folder and is writable (proved by creating and removing a
 * temporary file there), and path itself is not a folder (else SPT_EXIT_OUTPUT).
 * The message names the file and the reason. */
int image_output_check(const char *path, SptError *e);

/* Pre-flight check of the image size for path's format, once the resolution is
 * known: positive, and within what the format allows (JPEG: 65500 pixels per side).
 * Returns SPT_EXIT_OK, SPT_EXIT_USAGE (unknown extension) or SPT_EXIT_OUTPUT. */
int image_output_check_size(const char *path, int width, int height, SptError *e);

/* Writes rgb (linear sRGB, 3 floats per pixel, width*height pixels, rows top to
 * bottom) to path in the format its extension names; meta may be NULL; disp applies
 * to display formats only (NULL = defaults). Atomic as described above. Returns
 * SPT_EXIT_OK, SPT_EXIT_USAGE for an unknown extension, or SPT_EXIT_OUTPUT (folder
 * missing, no permission, disk full, encoder failure). */
int image_write(const char *path, const float *rgb, int width, int height,
                const ImageMeta *meta, const DisplayOptions *disp, SptError *e);

/* The Khronos PBR Neutral tone mapper on one linear Rec. 709 colour. Negative and
 * NaN components count as 0 (the specification is for non-negative input); an
 * infinite component gives white (the limit). Output in [0, 1]. */
void image_tonemap_neutral(const float in[3], float out[3]);

/* The display transform of one linear colour: NaN -> 0, times 2^exposure_ev, tone
 * map, then srgb_to_8bit per channel. disp NULL = defaults. */
void image_display_pixel(const float in[3], const DisplayOptions *disp, uint8_t out[3]);

/* "none" or "neutral" (case-insensitive) -> SPT_TONEMAP_*; returns 0, or -1 for an
 * unknown name. */
int image_tonemap_parse(const char *name, int *tonemap);

/* Returns 1 when path's extension is one image_write knows, else 0; is_display
 * (may be NULL) is set to 1 for the 8-bit display-referred ones (png, jpg, jpeg). */
int image_format_known(const char *path, int *is_display);

#endif
