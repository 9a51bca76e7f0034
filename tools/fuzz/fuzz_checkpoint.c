/* libFuzzer target for the checkpoint reader: the input is a whole checkpoint
 * (an EXR file), written to a file in /dev/shm (checkpoint_read reads a path).
 * The key it is checked against is taken from the input's own attributes where
 * it has them, so the fuzzer reaches the film and sample-range checks past the
 * key comparison. */
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "io/exr.h"
#include "render/checkpoint.h"
#include "render/film.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static char path[64];
    if (!path[0])
        snprintf(path, sizeof path, "/dev/shm/spt_fuzz_ckpt_%d.exr", (int)getpid());
    FILE *f = fopen(path, "wb");
    if (!f)
        return 0;
    fwrite(data, 1, size, f);
    fclose(f);
    CheckpointKey k;
    memset(&k, 0, sizeof k);
    ExrLayers L;
    SptError e;
    if (exr_read_layers(path, NULL, 0, &L, &e) == 0) {
        const ExrAttr *sh = exr_layers_attr(&L, "spectrace:scene_hash", SPT_EXR_ATTR_STRING);
        const ExrAttr *set = exr_layers_attr(&L, "spectrace:settings", SPT_EXR_ATTR_STRING);
        if (sh)
            snprintf(k.scene_hash, sizeof k.scene_hash, "%s", sh->s);
        if (set)
            snprintf(k.settings, sizeof k.settings, "%s", set->s);
        k.width = L.width;
        k.height = L.height;
        exr_layers_free(&L);
    }
    Film film;
    unsigned char *done = NULL;
    for (uint32_t spp = 1; spp <= 64; spp *= 8)
        if (checkpoint_read(path, &k, spp, &film, &done, &e) == 0) {
            film_free(&film);
            free(done);
        }
    return 0;
}
