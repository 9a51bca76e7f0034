/* The MPI render hook (src/mpi/mpi_hook.h); build/spectrace-mpi sets it on rank 0. */
#include "mpi/mpi_hook.h"

SptDistRender spt_dist_render = NULL;
