/* Reading input files safely: every file spectrace reads (scene, buffers,
 * textures, environment map, SPD/CSV, checkpoint) is first checked to be a
 * regular file (or, where it is read whole, a FIFO, read up to the same cap) no
 * larger than the input size limit, so a device such as /dev/zero or a
 * multi-gigabyte file is refused before it is read. Each file read is also
 * recorded by device and inode, so that `spectrace render` can refuse an output
 * that would replace one of its inputs.
 *
 * The limit is SPT_INPUT_DEFAULT_MAX_MB MiB per file, changed with the
 * environment variable SPECTRACE_MAX_INPUT_MB (a whole number of MiB); README.md
 * documents both. */
#ifndef SPT_INPUT_FILE_H
#define SPT_INPUT_FILE_H

#include <stddef.h>
#include <sys/stat.h>

#include "core/util.h"

#define SPT_INPUT_DEFAULT_MAX_MB 2048

/* The size limit in bytes (SPECTRACE_MAX_INPUT_MB, else the default; a value that
 * is not a positive whole number is ignored with one warning). */
size_t input_max_bytes(void);

/* Checks path before a library opens it by name: it exists, is a regular file and
 * is no larger than input_max_bytes(). what names the input in the error
 * ("environment map", "texture", ...). Records the file (input_seen). Returns
 * SPT_EXIT_OK or SPT_EXIT_INPUT with one line naming path, what and the reason. */
int input_check(const char *path, const char *what, SptError *e);

/* Reads a regular file or a FIFO whole into *data (malloc'd, plus one zero byte
 * after the end that *size does not count), refusing anything else and anything
 * longer than input_max_bytes() before reading it (a FIFO: once the cap is
 * passed). Records the file. Returns SPT_EXIT_OK or SPT_EXIT_INPUT. */
int input_read(const char *path, const char *what, unsigned char **data, size_t *size,
               SptError *e);

/* The inputs read since the last input_seen_reset: the path of the one that is the
 * same file as st (device and inode), or NULL. */
const char *input_seen_match(const struct stat *st);
void input_seen_add(const char *path, const struct stat *st);
void input_seen_reset(void);

/* A copy of the inputs recorded (input_seen_copy), kept by a caller that checks
 * its outputs against them later, after other loads have reset the record. */
typedef struct InputFile {
    dev_t dev;
    ino_t ino;
    char *path;
} InputFile;

typedef struct InputList {
    InputFile *files;
    int count, cap;
} InputList;

void input_seen_copy(InputList *list); /* list: empty or freed before */
/* The path of the file of list that is the same file as st, or NULL. */
const char *input_list_match(const InputList *list, const struct stat *st);
void input_list_free(InputList *list);

#endif
