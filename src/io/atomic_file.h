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

/* Test hook: while non-zero, every commit fails after its temporary file was
 * written and before the rename, as a full disk would; the error says so. Only
 * tests set it. */
extern int atomic_test_fail_commits;

/* Marks of a temporary file, for tests that check none is left behind. */
#define SPT_ATOMIC_TEMP_MARK ".spt-tmp-"

#endif
