#include "commands.h"
#include "util.h"

int cmd_render(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    spt_error("'spectrace render' is not implemented yet");
    return SPT_EXIT_FAILURE;
}
