/* The check that a render's outputs replace none of its inputs, nor the
 * checkpoint it resumes, nor each other (README.md, "Outputs"), for the
 * library's spectrace_scene_check_outputs and the command line's frame
 * sequences. */
#ifndef SPT_OUTPUT_CHECK_H
#define SPT_OUTPUT_CHECK_H

#include "core/input_file.h"
#include "core/util.h"

/* outputs (count image files) and the checkpoint (checkpoint, else resume;
 * either may be NULL) against the files of inputs, compared by device and
 * inode so that other names of a file (links, "./", "..") are caught too: an
 * output that is an input, an image output that is the checkpoint resumed,
 * and two outputs naming one file are refused with SPT_EXIT_USAGE. */
int outputs_check_not_inputs(const InputList *inputs, const char *const *outputs, int count,
                             const char *checkpoint, const char *resume, SptError *e);

#endif
