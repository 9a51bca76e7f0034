/* The hook through which build/spectrace-mpi spreads one render over MPI ranks
 * (src/mpi/). build/spectrace leaves it NULL and renders in its own process. */
#ifndef SPT_MPI_HOOK_H
#define SPT_MPI_HOOK_H

#include "render/film.h"
#include "render/render.h"
#include "scene/scene.h"

/* Renders like render_devices on this process's devices, with the other ranks
 * taking chunks of the same render; film receives every rank's samples. The
 * scene is what the other ranks receive (they rebuild its GpuScene). */
typedef int (*SptDistRender)(const ClDeviceInfo *const *infos, int count, const GpuScene *g,
                             const Scene *scene, const SceneCamera *cam,
                             const RenderSettings *rs, Film *film, RenderStats *stats,
                             RenderDeviceStats *per_device, SptError *e);

/* NULL unless build/spectrace-mpi runs with more than one rank (set on rank 0). */
extern SptDistRender spt_dist_render;

#endif
