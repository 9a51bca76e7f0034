#include "commands.h"
#include "util.h"

int cmd_color(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    spt_error("'spectrace color' is not implemented yet");
    return SPT_EXIT_FAILURE;
}
