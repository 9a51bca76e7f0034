#include "commands.h"
#include "util.h"

int cmd_devices(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    spt_error("'spectrace devices' is not implemented yet");
    return SPT_EXIT_FAILURE;
}
