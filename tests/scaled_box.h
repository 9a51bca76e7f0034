/* The Cornell box with its light's emissive strength scaled, for the tests of
 * radiance far from 1 (test_hostile_denoise, test_hostile_radiance). */
#ifndef SPT_SCALED_BOX_H
#define SPT_SCALED_BOX_H

#include <stdio.h>

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

#endif
