/* What the files of src/cl/ share and nothing else uses. */
#ifndef SPT_CL_INTERNAL_H
#define SPT_CL_INTERNAL_H

#include <stddef.h>

#include "cl/cl_device.h"

/* A growing string. */
typedef struct Buf {
    char *s;
    size_t len, cap;
} Buf;

void cl_buf_add(Buf *b, const char *s, size_t n);
void cl_buf_printf(Buf *b, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

/* Reads a whole file; NULL when it cannot. *len (may be NULL) gets its size. */
char *cl_read_file(const char *path, size_t *len);

/* The text of kernel file `path` ("kernels/x.h"), malloc'd: from
 * SPECTRACE_KERNEL_DIR when set, else embedded. NULL when missing. */
char *cl_kernel_file_load(const char *path);

/* The cached binary for key at path (NULL when absent or not valid; *corrupt
 * set when a file was there but damaged), and the storing of one. */
unsigned char *cl_cache_load(const char *path, const char *key, size_t *bin_len, int *corrupt);
void cl_cache_store(const char *dir, const char *path, const char *key, const unsigned char *bin,
                    size_t bin_len);

/* The text of kernel file path (made "kernels/..." into full, cap bytes),
 * malloc'd; NULL with SPT_EXIT_DEVICE in e, naming where it looked, when it is
 * missing. */
char *cl_kernel_file_open(const char *path, char *full, size_t cap, SptError *e);

/* The path of a kernel file as used in #line markers: "kernels/" + name unless
 * it has it already. */
void cl_kernel_path(const char *name, char *out, size_t cap);

/* Puts prefix in front of e's message (truncating at the end); e may be NULL. */
void cl_prefix_error(SptError *e, const char *prefix);

#endif
