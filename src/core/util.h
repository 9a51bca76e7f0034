/* Errors, messages and exit codes shared by every module. */
#ifndef SPT_UTIL_H
#define SPT_UTIL_H

#include <stddef.h>

/* Documented exit codes (README.md, "Exit codes"). */
enum {
    SPT_EXIT_OK = 0,
    SPT_EXIT_FAILURE = 1,   /* internal or unexpected failure */
    SPT_EXIT_USAGE = 2,     /* bad command line */
    SPT_EXIT_INPUT = 3,     /* a scene, SPD, CSV or checkpoint file is unreadable or invalid */
    SPT_EXIT_DEVICE = 4,    /* no OpenCL platform/device, build failure, device limits */
    SPT_EXIT_OUTPUT = 5,    /* an output cannot be written */
    SPT_EXIT_INTERRUPTED = 130 /* stopped by a signal before anything could be written */
};

/* The largest radiometric value an input may give (an SPD sample, a light's
 * intensity after its unit conversion, an environment texel times its intensity,
 * an emissive strength): the kernels compute in float (at most 3.4e38) and
 * multiply these by sampling weights, so larger values overflow to infinity and
 * the samples are dropped (a black image). 1e30 is far above any physical
 * scene (the sun is about 1e9 cd/m^2). */
#define SPT_MAX_INPUT_VALUE 1e30

/* A failure on user input: an exit code and one line of text naming the file, the
 * object and the reason (without the leading "error: "). */
typedef struct SptError {
    int code;
    char msg[1024];
} SptError;

/* Fills e (when not NULL) and returns code, so callers can write
 * `return spt_fail(e, SPT_EXIT_INPUT, "%s: meshes[%d]: ...", ...)`. */
int spt_fail(SptError *e, int code, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));

/* One line to stderr with the prefix "error: ", "warning: " or "note: ". */
void spt_error(const char *fmt, ...) __attribute__((format(printf, 1, 2)));
void spt_warn(const char *fmt, ...) __attribute__((format(printf, 1, 2)));
void spt_note(const char *fmt, ...) __attribute__((format(printf, 1, 2)));

/* With show 0, a warning or note already printed is not printed again (a frame
 * sequence loads its scene once per frame: docs/gltf.md, "Frame sequences");
 * 1, the default, prints every one. Errors always print. */
void spt_warn_repeats(int show);

/* Prints e as an error line and returns its code. */
int spt_report(const SptError *e);

/* The memory a render may use, in bytes: SPECTRACE_MAX_MEMORY_MB when set, else
 * MemAvailable of /proc/meminfo; 0 when neither is known (no limit). Under a
 * limit on the address space (RLIMIT_AS, ulimit -v), at most what it leaves:
 * allocations past it fail whatever memory is free. */
double spt_memory_limit(void);
/* The last spt_memory_limit's source, to follow "more than the N GiB":
 * "available (SPECTRACE_MAX_MEMORY_MB sets the limit)" or "that the
 * address-space limit (ulimit -v) leaves". */
const char *spt_memory_limit_why(void);

/* bytes for a message, into buf (n bytes): "12.5 GiB", "1.50 GiB", "612.3 MiB",
 * "0.2 MiB" (GiB from 1 GiB on, so that an amount never reads 0.0 GiB). */
const char *spt_format_bytes(char *buf, size_t n, double bytes);

/* Monotonic wall clock in seconds. */
double spt_now(void);

/* malloc/calloc/realloc that abort with a message on exhaustion (the host has no
 * sensible recovery from a failed small allocation; large scene allocations check
 * their sizes first). */
void *spt_malloc(size_t n);
void *spt_calloc(size_t count, size_t size);
void *spt_realloc(void *p, size_t n);
char *spt_strdup(const char *s);

#endif
