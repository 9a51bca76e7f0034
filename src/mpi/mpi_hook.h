/* The hook through which build/spectrace-mpi spreads one render over MPI ranks
 * (src/mpi/). build/spectrace and build/libspectrace.so leave it NULL and
 * render in their own process. The library's render (src/api/spectrace.c)
 * calls it in place of render_devices, with the scene and the film the API
 * owns, so the command line, a client of the library, renders over the ranks
 * unchanged: one image and every frame of --frames. */
#ifndef SPT_MPI_HOOK_H
#define SPT_MPI_HOOK_H

#include "render/film.h"
#include "render/render.h"
#include "scene/scene.h"

/* Renders like render_devices on this process's devices, with the other ranks
 * taking chunks of the same render; film receives every rank's samples. The
 * scene is what the other ranks receive (they rebuild its GpuScene, refitting
 * their last tree when g's BVH was refitted). Progress: with rs->progress the
 * hook's own line (the ranks' figures) and, at the end, each rank's samples;
 * otherwise rs->on_progress with the whole render's figures. */
typedef int (*SptDistRender)(const ClDeviceInfo *const *infos, int count, const GpuScene *g,
                             const Scene *scene, const SceneCamera *cam,
                             const RenderSettings *rs, Film *film, RenderStats *stats,
                             RenderDeviceStats *per_device, SptError *e);

/* NULL unless build/spectrace-mpi runs with more than one rank (set on rank 0). */
extern SptDistRender spt_dist_render;

#endif
