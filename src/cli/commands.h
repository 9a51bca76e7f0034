/* The subcommands of build/spectrace; each returns an exit code (src/core/util.h). */
#ifndef SPT_COMMANDS_H
#define SPT_COMMANDS_H

int cmd_color(int argc, char **argv);   /* src/cli/cmd_color.c */
int cmd_info(int argc, char **argv);    /* src/cli/cmd_info.c */
int cmd_devices(int argc, char **argv); /* src/cli/cmd_devices.c */
int cmd_render(int argc, char **argv);  /* src/cli/cmd_render.c */

#endif
