/* libFuzzer target for the glTF loader: the input is a whole .gltf or .glb file
 * (told apart by the GLB magic). It is named as if it sat in tests/data/gltf/, so
 * external buffers and images of the seed corpus resolve when run from the
 * repository root (tools/fuzz/run_fuzz.sh does). */
#include <stddef.h>
#include <stdint.h>

#include "scene/scene.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

/* Loads the input; any outcome but a crash, hang, leak or sanitizer report is
 * fine (0 or SPT_EXIT_INPUT). */
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    Scene s;
    SptError e;
    if (scene_load_gltf_memory(&s, data, size, "tests/data/gltf/fuzz_input", &e) == 0)
        scene_free(&s);
    return 0;
}
