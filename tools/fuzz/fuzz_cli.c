/* libFuzzer target for the command line of `spectrace render`: the input is
 * split at newlines (and NUL bytes) into arguments after "render", parsed by
 * render_args_parse (getopt_long, number parsing and range checks), and the
 * outputs' pre-flight name checks (atomic_path_check) run on the -o values. */
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "api/render_args.h"
#include "io/atomic_file.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size > 4096)
        return 0;
    char *text = malloc(size + 1);
    memcpy(text, data, size);
    text[size] = 0;
    char *argv[66];
    int argc = 0;
    argv[argc++] = (char *)"render";
    char *p = text;
    for (size_t i = 0; i <= size && argc < 65; i++)
        if (i == size || text[i] == '\n' || text[i] == 0) {
            text[i] = 0;
            argv[argc++] = p;
            p = text + i + 1;
        }
    argv[argc] = NULL;
    RenderArgs a;
    memset(&a, 0, sizeof a);
    if (render_args_parse(&a, argc, argv) == 0)
        for (int i = 0; i < a.outputs_count; i++) {
            SptError e;
            atomic_path_check(a.outputs[i], &e);
        }
    free(text);
    return 0;
}
