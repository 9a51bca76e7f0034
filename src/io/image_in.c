/* Reading an image whole as RGB floats (src/io/image_in.h). */
#include "io/image_in.h"

#include <stdlib.h>

#include "io/image_io.h"

int image_read_rgb(const char *path, float **rgb, int *width, int *height, SptError *e)
{
    float *all = NULL;
    int w = 0, h = 0, ch = 0;
    *rgb = NULL;
    int rc = image_io_read(path, &all, &w, &h, &ch, e);
    if (rc)
        return rc;
    size_t count = (size_t)w * (size_t)h;
    float *out = spt_malloc(count * 3 * sizeof(float));
    for (size_t i = 0; i < count; ++i)
        for (int c = 0; c < 3; ++c)
            out[3 * i + c] = all[i * (size_t)ch + (size_t)(ch >= 3 ? c : 0)];
    free(all);
    *rgb = out;
    *width = w;
    *height = h;
    return SPT_EXIT_OK;
}
