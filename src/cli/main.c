/* build/spectrace: the command line. Each subcommand lives in its own file. */
#include <stdio.h>
#include <string.h>

#include "cli/commands.h"
#include "core/util.h"

static const char usage[] =
    "usage: spectrace COMMAND [ARGS]\n"
    "\n"
    "commands:\n"
    "  render SCENE [options]   render a glTF 2.0 scene to EXR/PNG (spectrace render --help)\n"
    "  info SCENE               summarise a scene: geometry, materials, lights, BVH, memory\n"
    "  color [--reflectance] SPD  XYZ, linear sRGB and 8-bit sRGB of an SPD normalised to Y = 1\n"
    "  devices                  list OpenCL platforms and devices\n"
    "  help                     this text\n"
    "\n"
    "SPD: A, D65, F2, F7, F11, mercury, blackbody:KELVIN, or a CSV file of wavelength_nm,value.\n"
    "Exit codes: 0 ok, 1 internal failure, 2 usage, 3 bad input file, 4 OpenCL device,\n"
    "5 output not writable, 130 interrupted before anything was written.\n";

int main(int argc, char **argv)
{
    if (argc < 2) {
        fputs(usage, stderr);
        return SPT_EXIT_USAGE;
    }
    const char *cmd = argv[1];
    if (!strcmp(cmd, "help") || !strcmp(cmd, "--help") || !strcmp(cmd, "-h")) {
        fputs(usage, stdout);
        return SPT_EXIT_OK;
    }
    if (!strcmp(cmd, "color") || !strcmp(cmd, "colour"))
        return cmd_color(argc - 1, argv + 1);
    if (!strcmp(cmd, "info"))
        return cmd_info(argc - 1, argv + 1);
    if (!strcmp(cmd, "devices"))
        return cmd_devices(argc - 1, argv + 1);
    if (!strcmp(cmd, "render"))
        return cmd_render(argc - 1, argv + 1);
    spt_error("unknown command '%s' (try: spectrace help)", cmd);
    return SPT_EXIT_USAGE;
}
