/* The sRGB transfer curve (IEC 61966-2-1; the formulas of docs/architecture.md,
 * "The physics it implements"): how 8-bit images store linear values. Image
 * output encodes display pixels with it (src/io/image_out.c), texture and
 * environment map reading decodes colour texels with it (src/io/oiio_lib.c,
 * src/scene/sky.c), and the colour science of src/color/spd.h offers it with
 * the sRGB matrices. */
#ifndef SPT_SRGB_H
#define SPT_SRGB_H

double srgb_encode(double linear);  /* transfer curve, linear -> encoded */
double srgb_decode(double encoded); /* inverse */
int srgb_to_8bit(double linear);    /* round(255 * clamp(encode(linear), 0, 1)); NaN -> 0 */

#endif
