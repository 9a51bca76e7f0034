/* Atomic file writes: every output goes to a temporary file in the destination's
 * folder, which is renamed over the destination only once it is complete, so a
 * failed write never leaves a partial file and never touches an existing one.
 * Used by the image writers (src/io/image_out.c, src/io/exr.c).
 */
#ifndef SPT_ATOMIC_FILE_H
#define SPT_ATOMIC_FILE_H

#include <stddef.h>

#include "core/util.h"

/* Splits path into its folder ("." when none; "/" for files at the root), written
 * to dir, and the file name (*base points into path). */
void atomic_split_path(const char *path, char *dir, size_t dir_size, const char **base);

/* Creates a new, empty, uniquely named file in path's folder whose name ends with
 * path's extension (".<name>.spt-tmp-<pid>-<n>.<ext>"), with the usual permissions
 * (0666 minus the umask), and writes its name to tmp. Returns SPT_EXIT_OK or
 * SPT_EXIT_OUTPUT with a message naming path and the reason. */
int atomic_temp_create(const char *path, char *tmp, size_t tmp_size, SptError *e);

/* Makes tmp durable (fsync), then renames it over path. On any failure, including
 * the atomic_test_fail_commits hook, removes tmp, leaves path as it was and
 * returns SPT_EXIT_OUTPUT naming path. */
int atomic_temp_commit(const char *tmp, const char *path, SptError *e);

/* Writes n bytes to a new temporary file and commits it over path, checking every
 * write and the close (a full disk may only show there). */
int atomic_write_bytes(const char *path, const void *data, size_t n, SptError *e);

/* Pre-flight check of an output path's name: the file name fits the file
 * system's NAME_MAX (pathconf of its folder) and the whole path PATH_MAX; a
 * symbolic link must point to an existing file (its target is what gets
 * replaced). Returns SPT_EXIT_OK or SPT_EXIT_OUTPUT naming path and the limit. */
int atomic_path_check(const char *path, SptError *e);

/* The file a write to path replaces: path itself, or the target of a symbolic
 * link (resolved with realpath when the target exists), written to out. An output
 * that is a link keeps being a link: the target's content changes. */
void atomic_resolve(const char *path, char *out, size_t out_size);

/* Staged commits, so that a run with several outputs replaces all of them or none:
 * after atomic_stage_begin, atomic_temp_commit makes each temporary file durable
 * but keeps it; atomic_stage_finish(1) then renames every one over its
 * destination, atomic_stage_finish(0) removes them all (nothing replaced). A
 * failed rename during finish is reported; the later temporaries are removed. */
void atomic_stage_begin(void);
int atomic_stage_finish(int commit, SptError *e);

/* Test hook: while non-zero, every commit fails after its temporary file was
 * written and before the rename, as a full disk would; the error says so. Only
 * tests set it. */
extern int atomic_test_fail_commits;

/* Test hook: when N > 0, the N-th commit from now on (counting from 1) fails in the
 * same way, the others succeed; reset to 0 after it fired. Set by `spectrace
 * render` from SPECTRACE_TEST_FAIL_OUTPUT=N (a full disk at the N-th output). */
extern int atomic_test_fail_commit_at;

/* Marks of a temporary file, for tests that check none is left behind. */
#define SPT_ATOMIC_TEMP_MARK ".spt-tmp-"

#endif
