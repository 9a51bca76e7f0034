#include "commands.h"
#include "util.h"

int cmd_info(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    spt_error("'spectrace info' is not implemented yet");
    return SPT_EXIT_FAILURE;
}
