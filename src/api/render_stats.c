/* A render's figures for the library (src/api/render_stats.h). */
#include "api/render_stats.h"

#include <string.h>

_Static_assert(SPECTRACE_STAGES == SPT_STAGES, "the stages of RenderStats");

void render_stats_public(const RenderStats *st, const CheckpointRun *ckpt,
                         spectrace_render_stats *out)
{
    memset(out, 0, sizeof *out);
    out->spp_done = st->spp_done;
    out->spp_resumed = ckpt->resumed;
    out->seconds = st->seconds;
    out->build_seconds = st->build_seconds;
    out->paths = st->paths;
    out->rays_extend = st->rays_extend;
    out->rays_shadow = st->rays_shadow;
    out->nan_dropped = st->nan_dropped;
    for (int i = 0; i < SPT_STAGES; i++)
        out->stage_seconds[i] = st->stage_seconds[i];
    const CheckpointWriter *w = &ckpt->writer;
    out->checkpoint = w->done ? w->path : NULL;
    for (uint32_t i = 0; w->done && i < w->total; i++)
        out->checkpoint_spp += w->done[i];
}
