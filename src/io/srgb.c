/* The sRGB transfer curve (src/io/srgb.h). */
#include "io/srgb.h"

#include <math.h>

double srgb_encode(double c)
{
    return c <= 0.0031308 ? 12.92 * c : 1.055 * pow(c, 1.0 / 2.4) - 0.055;
}

double srgb_decode(double c)
{
    return c <= 0.04045 ? c / 12.92 : pow((c + 0.055) / 1.055, 2.4);
}

int srgb_to_8bit(double linear)
{
    if (!(linear > 0.0)) /* NaN and negatives */
        return 0;
    if (linear >= 1.0)
        return 255;
    double v = srgb_encode(linear);
    if (v < 0)
        v = 0;
    if (v > 1)
        v = 1;
    return (int)floor(255.0 * v + 0.5);
}
