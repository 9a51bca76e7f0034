/* The test hooks of RenderSettings.test, filled from SPECTRACE_TEST_* variables
 * by both programs, spectrace (src/cli/cmd_render.c) and spectrace-mpi
 * (src/mpi/mpi_main.c), so it sits in render/, which both may include
 * (docs/architecture.md, "Source layout"); the renderer does not call it
 * (docs/architecture.md, "Options declared once"). */
#ifndef SPT_TEST_HOOKS_H
#define SPT_TEST_HOOKS_H

#include "render/render.h"

/* The test hooks of the environment into rs.test (RenderTestHooks):
 * SPECTRACE_TEST_FAIL_DEVICE = "I:N" (the I-th device fails as it starts its
 * (N+1)-th chunk), SPECTRACE_TEST_SLOW_DEVICE = "I:MS" (the I-th device waits
 * MS ms before each chunk), SPECTRACE_TEST_INJECT_NAN = 1 (pixel 0's radiance is
 * NaN), SPECTRACE_TEST_POISON = WORD (buffers start filled with WORD),
 * SPECTRACE_TEST_FILM_NAN = N (the first N film pixels become NaN),
 * SPECTRACE_TEST_RANKS_FIRST = 1 (spectrace-mpi: every rank takes a chunk
 * before rank 0's devices do), SPECTRACE_TEST_BVH_REBUILD = 1 (spectrace render
 * --frames builds every frame's BVH anew instead of refitting it); and the
 * path pool size SPECTRACE_POOL into
 * rs.pool_size. (SPECTRACE_KERNEL_PATH, the kernel code path, is read where
 * the wavefront is made: src/render/wavefront.c.) Only tests, tools and
 * benchmarks set them. */
void render_test_hooks_env(RenderSettings *rs);

#endif
