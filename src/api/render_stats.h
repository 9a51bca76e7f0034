/* A render's figures as the library reports them (spectrace_render_stats of
 * src/api/spectrace.h), for spectrace_image_stats and for the command line's
 * renders outside the API (frame sequences, MPI ranks). */
#ifndef SPT_API_RENDER_STATS_H
#define SPT_API_RENDER_STATS_H

#include "api/spectrace.h"
#include "render/checkpoint.h"
#include "render/render.h"

/* out from st and the render's checkpoint side ckpt: the samples, seconds,
 * paths, rays and stages, the samples resumed, and the checkpoint written
 * with the samples it holds (NULL when none was or no sample is done); the
 * rest of out zero. */
void render_stats_public(const RenderStats *st, const CheckpointRun *ckpt,
                         spectrace_render_stats *out);

#endif
