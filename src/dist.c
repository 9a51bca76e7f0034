/* The MPI render hook (src/dist.h); build/spectrace-mpi sets it on rank 0. */
#include "dist.h"

SptDistRender spt_dist_render = NULL;
