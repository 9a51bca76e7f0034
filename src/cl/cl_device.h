/* The OpenCL runtime: platforms and devices, device selection, one context and
 * queue per device, program builds from the embedded kernel sources (or
 * SPECTRACE_KERNEL_DIR) with a program-binary cache, memory-limit checks, the
 * layout check of shared structs, and the error-checking macro for every
 * OpenCL call. README.md, "Devices", describes the user side. */
#ifndef SPT_CL_DEVICE_H
#define SPT_CL_DEVICE_H

#include <signal.h>
#include <stddef.h>

#include <CL/cl.h>

#include "core/util.h"

/* One device as listed: everything `spectrace devices` prints. `index` is the
 * global index across platforms, the one a selection string uses. */
typedef struct ClDeviceInfo {
    int index;
    int platform_index;
    cl_platform_id platform;
    cl_device_id id;
    char platform_name[256];
    char platform_version[256];
    char impl[32];              /* the implementation as users name it (cl_impl_name) */
    char name[256];
    char vendor[256];
    char driver_version[256];
    char version[256];          /* CL_DEVICE_VERSION, e.g. "OpenCL 3.0 PoCL ..." */
    char opencl_c_version[256]; /* CL_DEVICE_OPENCL_C_VERSION */
    cl_device_type type;
    cl_uint compute_units;
    cl_ulong global_mem;        /* CL_DEVICE_GLOBAL_MEM_SIZE */
    cl_ulong max_alloc;         /* CL_DEVICE_MAX_MEM_ALLOC_SIZE */
    size_t max_work_group_size;
    int fp64;                   /* cl_khr_fp64 or a non-zero CL_DEVICE_DOUBLE_FP_CONFIG */
} ClDeviceInfo;

/* All devices of all platforms, in global index order. */
typedef struct ClDeviceList {
    ClDeviceInfo *devices;
    int count;
} ClDeviceList;

/* An open device: its own context and in-order queue, plus the build state of
 * the last program build on it. */
typedef struct ClDevice {
    ClDeviceInfo info;
    cl_context context;
    cl_command_queue queue;
    int profiling;             /* queue made with CL_QUEUE_PROFILING_ENABLE */
    /* Program builds on this device (cl_program_build*). */
    int cache_hits;            /* programs loaded from the binary cache */
    int cache_misses;          /* programs compiled from source */
    int cache_rejected;        /* cache entries found corrupt or unusable, then rebuilt */
    int last_from_cache;       /* 1 when the last successful build was a cache hit */
    double last_build_seconds; /* wall time of the last build, cache lookup included */
    char last_cache_path[4096];/* cache entry of the last build ("" without cache) */
    char *build_log;           /* full log of the last failed build, or NULL */
    /* Set by the caller before a build: a compile from source says so on
     * stderr when announce ("device N: building the kernels"), and gives up
     * when *stop (may be NULL) reaches 2 (a second signal, README.md). */
    volatile sig_atomic_t *stop;
    int announce;
} ClDevice;

/* A named buffer size, for cl_device_check_memory. */
typedef struct ClAlloc {
    const char *name;
    size_t bytes;
} ClAlloc;

/* Name of an OpenCL error code ("CL_INVALID_VALUE"), for every OpenCL 1.2 code
 * and the common later and extension ones; "unknown OpenCL error" otherwise. */
const char *cl_error_name(cl_int err);

/* 0 when err is CL_SUCCESS; otherwise fills e with "<clCall> failed at
 * file:line: CL_NAME (code)" (clCall is the first OpenCL function named in
 * `call`, the stringified expression) and returns SPT_EXIT_DEVICE. */
int cl_check(cl_int err, const char *call, const char *file, int line, SptError *e);

/* Checks one OpenCL call (an expression of type cl_int: the call's result, or
 * `(x = clCreateFoo(..., &err), err)` for calls with an error out-parameter).
 * On failure fills e and returns SPT_EXIT_DEVICE from the calling function. */
#define SPT_CL_CHECK(e, call)                                             \
    do {                                                                  \
        int spt_cl_rc_ = cl_check((call), #call, __FILE__, __LINE__, (e)); \
        if (spt_cl_rc_)                                                   \
            return spt_cl_rc_;                                            \
    } while (0)

/* The same check for functions that clean up: on failure fills e, stores
 * SPT_EXIT_DEVICE in rc and jumps to label. */
#define SPT_CL_CHECK_GOTO(e, call, rc, label)                            \
    do {                                                                 \
        if (((rc) = cl_check((call), #call, __FILE__, __LINE__, (e))))   \
            goto label;                                                  \
    } while (0)

/* Sets the environment the OpenCL implementations read when they load (where
 * the user has not set it): workarounds for their bugs. Call before the first
 * OpenCL call; cl_device_list does. */
void cl_runtime_defaults(void);

/* Lists every device of every platform into *out (free with
 * cl_device_list_free). No platform or no device at all: SPT_EXIT_DEVICE with
 * a message telling how to install PoCL. */
int cl_device_list(ClDeviceList *out, SptError *e);
void cl_device_list_free(ClDeviceList *list);

/* The name users give an OpenCL implementation, from its platform's name, vendor
 * and ICD suffix (cl_khr_icd; "" when unknown), into out: "pocl", "intel" (Intel's
 * CPU and GPU runtimes), "rusticl", "clover", "oclgrind", "nvidia", "amd", else
 * the platform name's first word in lower case. */
void cl_impl_name(const char *platform_name, const char *platform_vendor, const char *icd_suffix,
                  char *out, size_t n);

/* "GPU", "CPU", "accelerator", "custom" or "default" (the first that applies). */
const char *cl_device_type_name(cl_device_type type);

/* Resolves a selection string into device indices of `all`, in the order
 * given, without duplicates. `selection` NULL or "" means the environment
 * variable SPECTRACE_DEVICE, and when that is unset or empty the default: the
 * first GPU, else the first CPU, else device 0. Syntax: "all", or a comma list
 * of tokens, each a global index ("2"), a device type ("gpu", "cpu",
 * "accelerator": the first such device not yet selected), an implementation's
 * name ("pocl", "intel", "rusticl", ...: the first device of that implementation
 * not yet selected; a device whose name merely contains it, such as PoCL's
 * device on an Intel CPU, is not one) or a case-insensitive substring of the
 * device's name, vendor or platform name (the first matching device not yet
 * selected). `out` needs room for all->count indices; *count
 * receives how many were chosen (at least 1 on success). An index out of range
 * or a token that matches nothing: SPT_EXIT_DEVICE with a message listing the
 * available devices. */
int cl_device_select(const ClDeviceList *all, const char *selection, int *out, int *count,
                     SptError *e);

/* Opens a context and an in-order command queue on `info`'s device (with
 * CL_QUEUE_PROFILING_ENABLE when `profiling`). On failure *d is left closed. */
int cl_device_open(ClDevice *d, const ClDeviceInfo *info, int profiling, SptError *e);

/* Releases everything cl_device_open made; a zeroed or closed ClDevice is fine. */
void cl_device_close(ClDevice *d);

/* Lists the devices, resolves `selection` (as cl_device_select) and opens each
 * selected device: *out (count entries) is malloc'd, free it with
 * cl_devices_close. On failure nothing stays open. */
int cl_devices_open(const char *selection, int profiling, ClDevice **out, int *count,
                    SptError *e);
void cl_devices_close(ClDevice *devs, int count);

/* Reports a failure from a function taking d: prints e as one `error:` line
 * and then, when d holds the log of a failed build, the full build log.
 * Returns e's code. */
int cl_device_report(const ClDevice *d, const SptError *e);

/* The kernel source text of `path` ("kernels/x.h" or "x.h") with every
 * `#include "y.h"` line replaced by that file's resolved text (each file
 * spliced once, at its first include; later includes become blank lines),
 * framed by #line markers so compiler messages name the real file and line.
 * Files come from SPECTRACE_KERNEL_DIR when set, else from the sources embedded
 * at build time. *out is malloc'd. A missing file: SPT_EXIT_DEVICE. */
int cl_source_resolve(const char *path, char **out, SptError *e);

/* The same for source text given by the caller; `name` labels it in #line
 * markers and messages (e.g. "kernels/test.cl"). */
int cl_source_resolve_text(const char *name, const char *text, char **out, SptError *e);

/* Builds the program whose entry file is `path` (e.g. "kernels/integrator/wavefront.cl")
 * for d, with `options` (may be NULL; e.g. "-DFOO=1") plus -cl-std=CL1.2. Uses
 * the program-binary cache (cl_cache_dir) when it can; a corrupt or unusable
 * entry is rebuilt silently, an unwritable cache folder warns once per
 * process. A failed build: SPT_EXIT_DEVICE, e names the file, device, driver
 * and platform, and d->build_log holds the full log (cl_device_report prints
 * both). Updates d's cache counters and timing. */
int cl_program_build(ClDevice *d, const char *path, const char *options, cl_program *out,
                     SptError *e);

/* A build from source runs in a thread of its own (clBuildProgram cannot be
 * interrupted): when *d->stop reaches 2 the build function returns
 * SPT_EXIT_INTERRUPTED at once and leaves the compile to end in that thread,
 * which then drops it (nothing goes to the cache). cl_builds_abandoned says
 * how many were left so: a process with one must end with _exit, as exit's
 * clean-up of the OpenCL implementation could meet the compile still running. */
int cl_builds_abandoned(void);

/* The same for source text given by the caller (its includes resolved as in
 * cl_source_resolve_text). */
int cl_program_build_text(ClDevice *d, const char *name, const char *text,
                          const char *options, cl_program *out, SptError *e);

/* The program-binary cache folder: $SPECTRACE_CACHE_DIR, else
 * $XDG_CACHE_HOME/spectrace, else $HOME/.cache/spectrace; "" when caching is
 * off (SPECTRACE_CACHE_DIR=off, or no HOME). Written into buf (size n). */
const char *cl_cache_dir(char *buf, size_t n);

/* 64-bit FNV-1a of n bytes, continuing from h (start with SPT_FNV1A_INIT). */
#define SPT_FNV1A_INIT 0xcbf29ce484222325ull
unsigned long long cl_fnv1a(unsigned long long h, const void *data, size_t n);

/* Checks planned buffers against the device before allocating: each against
 * CL_DEVICE_MAX_MEM_ALLOC_SIZE and their sum against CL_DEVICE_GLOBAL_MEM_SIZE.
 * Too big: SPT_EXIT_DEVICE with a message naming the buffer (or the total),
 * what it needs and what the device allows. */
int cl_device_check_memory(const ClDeviceInfo *info, const ClAlloc *allocs, int n,
                           SptError *e);

/* Creates a buffer of `bytes` on d named `name` (for messages) after checking
 * it against the device's allocation limit. host may be NULL. */
int cl_buffer_create(ClDevice *d, const char *name, cl_mem_flags flags, size_t bytes,
                     void *host, cl_mem *out, SptError *e);

/* Builds kernels/util/layout_check.cl on d and writes the device's sizeof of each
 * struct of SPT_LAYOUT_STRUCTS, then the offset of each field of
 * SPT_LAYOUT_FIELDS, in list order, into values (room for n; n must be
 * cl_layout_count()). */
int cl_layout_query(ClDevice *d, unsigned *values, int n, SptError *e);

/* Number of values cl_layout_query writes. */
int cl_layout_count(void);

/* Compares the device's struct sizes and field offsets (cl_layout_query) with
 * the host's; a mismatch: SPT_EXIT_DEVICE naming the struct or field and both
 * values. */
int cl_layout_check(ClDevice *d, SptError *e);

#endif
