/* The Cornell box with its light's emissive strength scaled, and the sums that
 * compare its images across scales, for the tests of radiance far from 1
 * (test_hostile_denoise, test_hostile_radiance). */
#ifndef SPT_SCALED_BOX_H
#define SPT_SCALED_BOX_H

#include <math.h>
#include <stdio.h>

#include "io/exr.h"
#include "test_util.h"

#define BOX "tests/data/scenes/cornell_box_rgb.gltf"
/* The light's strength as BOX writes it, the text that box_times replaces. */
#define BOX_STRENGTH "\"emissiveStrength\": 20.717675477527486"

/* A copy of BOX in test_dir() with its light's emissive strength times k. */
static inline const char *box_times(double k)
{
    static char path[256];
    char repl[64];
    snprintf(path, sizeof path, "%s/box_%g.gltf", test_dir(), k);
    snprintf(repl, sizeof repl, "\"emissiveStrength\": %.17g", k * 20.717675477527486);
    test_copy_replacing(BOX, BOX_STRENGTH, repl, path);
    return path;
}

/* Sum of channel name over the image. */
static inline double channel_sum(const ExrLayers *l, const char *name)
{
    const ExrChannel *c = exr_layers_channel(l, name);
    if (!c)
        fail_msg("no channel %s", name);
    const float *v = c->data;
    double s = 0;
    for (int i = 0; i < l->width * l->height; i++)
        s += v[i];
    return s;
}

/* Sum over pixels of |a / ka - b / kb| for one channel of two images. */
static inline double channel_diff(const ExrLayers *a, double ka, const ExrLayers *b, double kb, const char *name)
{
    const float *x = exr_layers_channel(a, name)->data, *y = exr_layers_channel(b, name)->data;
    double s = 0;
    for (int i = 0; i < a->width * a->height; i++)
        s += fabs(x[i] / ka - y[i] / kb);
    return s;
}

#endif
