/* The kernel sources embedded at build time (build/gen/kernel_sources.c). */
#ifndef SPT_EMBEDDED_H
#define SPT_EMBEDDED_H

typedef struct SptEmbeddedFile {
    const char *path; /* as given to the build, e.g. "kernels/bvh/bvh.h" */
    const char *text;
} SptEmbeddedFile;

extern const SptEmbeddedFile spt_kernel_files[];
extern const int spt_kernel_file_count;

#endif
