/* Checkpoints: the resumable state of a render in one EXR file, so a render can
 * stop and continue later on any devices, processes or MPI ranks.
 *
 * The file (written with exr_write_layers, so atomically) holds, per pixel:
 *   sum.X, sum.Y, sum.Z      float: the film's double sums rounded to float
 *   sum_lo.X, sum_lo.Y, ...  float: what that rounding lost (sum - hi), so the
 *                            pair keeps about 48 bits of the double sums
 *   count                    uint: samples kept (NaN/Inf samples are dropped)
 *   aov_sum.*, aov_sum_lo.*  float: with --aov, the film's AOV sums as such pairs
 *                            (albedo.R, ..., N.X, ..., Z, P.X, ..., sq.R, ...)
 *   band_sum.NNN, band_sum_lo.NNN  float: with --spectral, band NNN's sums
 *   R, G, B                  float: a linear sRGB preview of the samples done
 * and the attributes
 *   spectrace:checkpoint     int 2 (the format version; absent: not a checkpoint)
 *   spectrace:checksum       a 64-bit hash (FNV-1a, over 64-bit words for the
 *                            values; checkpoint.c) of the size, scene_hash,
 *                            settings, samples_done, spp_done and every
 *                            channel's bits, hex
 *   spectrace:scene_hash     FNV-1a 64 of the scene file's bytes, hex
 *   spectrace:settings       every setting that changes the image, "k=v;k=v;..."
 *                            (size, max depth, seed, sky, lens, kernel sources)
 *   spectrace:samples_done   the sample indices rendered, as ranges "0-31,40-47"
 *   spectrace:spp_done, spectrace:spp_target, spectrace:seed.
 * A resumed render must use the same scene file and settings; its --spp may be
 * larger than the checkpoint's target. */
#ifndef SPT_CHECKPOINT_H
#define SPT_CHECKPOINT_H

#include <stdint.h>

#include "render/film.h"
#include "render/render.h"
#include "core/util.h"

/* What identifies the image a checkpoint belongs to. */
typedef struct CheckpointKey {
    char scene_hash[17];   /* hex of the scene file's FNV-1a 64 */
    char settings[2048];   /* canonical list, see checkpoint_key */
    uint32_t seed;
    int width, height;
} CheckpointKey;

/* The key of a render of the scene file at scene_path with settings rs (reads
 * the scene file, and the --env and --background files when they name files).
 * Returns 0, or SPT_EXIT_INPUT when a file cannot be read. */
int checkpoint_key(CheckpointKey *k, const char *scene_path, const RenderSettings *rs,
                   SptError *e);

/* Writes film and the done flags (total entries, one per sample index) to path
 * atomically. Returns 0, SPT_EXIT_OUTPUT, or SPT_EXIT_FAILURE (nothing written)
 * when a pixel of the film is NaN or infinite. */
int checkpoint_write(const char *path, const CheckpointKey *k, const Film *film,
                     const unsigned char *done, uint32_t total, SptError *e);

/* Reads the checkpoint at path for a render of key k to spp samples per pixel:
 * film (initialised here, k's size) receives its sums and counts, *done (malloc'd,
 * spp flags) the samples it holds. Refuses, with path named and the reason, and
 * SPT_EXIT_INPUT: an unreadable, damaged or truncated file, a file that is not a
 * checkpoint or of format 1 (no checksum), another scene, other settings (each
 * differing setting named with both values), channels other than its settings
 * make, implausible values, data that does not match its checksum (the checks in
 * docs/outputs.md, "Checkpoints"); SPT_EXIT_USAGE: spp smaller than the samples
 * it already holds.
 * On failure film and *done are left empty. */
int checkpoint_read(const char *path, const CheckpointKey *k, uint32_t spp, Film *film,
                    unsigned char **done, SptError *e);

/* Periodic checkpoints of one render: hook checkpoint_on_chunk in as
 * RenderSettings.on_chunk with the writer as its context. */
typedef struct CheckpointWriter {
    const char *path;      /* NULL: no checkpoints are written */
    double every;          /* seconds between writes */
    double last;           /* spt_now() of the last write (or of the start) */
    CheckpointKey key;
    unsigned char *done;   /* latest done flags (total), NULL before any */
    uint32_t total;
    int writes;            /* files written */
    int warned;            /* a periodic write failed once (warned, not fatal) */
} CheckpointWriter;

/* Starts a writer for path (may be NULL) with done_in (may be NULL: nothing
 * done yet) as the samples already in the film. */
void checkpoint_writer_init(CheckpointWriter *w, const char *path, double every,
                            const CheckpointKey *k, const unsigned char *done_in,
                            uint32_t total);

/* Records the film's state; writes a checkpoint when `every` seconds passed since
 * the last one. A failed periodic write gives one warning and rendering goes on.
 * Matches RenderSettings.on_chunk (ctx = the writer). */
void checkpoint_on_chunk(void *ctx, const Film *film, const unsigned char *done,
                         uint32_t total);

/* The final write (end of the render, or stopped by a signal). Returns 0 or
 * SPT_EXIT_OUTPUT. Nothing is written when the writer has no path. */
int checkpoint_writer_finish(CheckpointWriter *w, const Film *film, SptError *e);

void checkpoint_writer_free(CheckpointWriter *w);

/* Before rendering, for `spectrace render`: checks that a checkpoint path ends in
 * .exr (else SPT_EXIT_USAGE) and that its folder is writable (SPT_EXIT_OUTPUT). */
int checkpoint_path_check(const char *path, SptError *e);

/* The checkpoint side of one `spectrace render`. */
typedef struct CheckpointRun {
    CheckpointWriter writer;
    unsigned char *done_in; /* the resumed samples (owned) */
    uint32_t resumed;       /* samples per pixel taken from the checkpoint */
} CheckpointRun;

/* Sets up film (initialised here) and rs for checkpoints to `path` every `every`
 * seconds and for resuming from `resume` (either may be NULL; a resumed render
 * keeps checkpointing to `resume` unless `path` is given): a resume fills film
 * and sets rs->done_in; checkpoints hook rs->on_chunk. Returns 0, or the refusal
 * of checkpoint_read (film then empty). */
int checkpoint_run_begin(CheckpointRun *run, const char *scene_path, const char *path,
                         double every, const char *resume, RenderSettings *rs, Film *film,
                         SptError *e);

/* After the render (complete or stopped): the final checkpoint, with a note
 * naming it unless quiet. Returns 0 or SPT_EXIT_OUTPUT. */
int checkpoint_run_end(CheckpointRun *run, const Film *film, int quiet, SptError *e);

/* The note of checkpoint_run_end alone (the file written; nothing unless quiet is
 * 0 and a checkpoint was written): for callers that write the final checkpoint
 * with checkpoint_writer_finish among other outputs. */
void checkpoint_run_report(const CheckpointRun *run, int quiet);

void checkpoint_run_free(CheckpointRun *run);

#endif
