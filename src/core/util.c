#include "core/util.h"

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <sys/resource.h>

int spt_fail(SptError *e, int code, const char *fmt, ...)
{
    if (e) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(e->msg, sizeof e->msg, fmt, ap);
        va_end(ap);
        e->code = code;
    }
    return code;
}

/* spt_warn_repeats(0): the FNV-1a hashes of the warnings and notes printed
 * (the first 256; later ones always print). */
static int hide_repeats;
static unsigned long long said[256];
static int said_count;

void spt_warn_repeats(int show)
{
    hide_repeats = !show;
    said_count = 0;
}

/* 1 when line was said before under spt_warn_repeats(0) (and records it). */
static int said_before(const char *line)
{
    if (!hide_repeats)
        return 0;
    unsigned long long h = 1469598103934665603ull;
    for (const char *c = line; *c; c++)
        h = (h ^ (unsigned char)*c) * 1099511628211ull;
    for (int i = 0; i < said_count; i++)
        if (said[i] == h)
            return 1;
    if (said_count < (int)(sizeof said / sizeof said[0]))
        said[said_count++] = h;
    return 0;
}

static void say(const char *prefix, const char *fmt, va_list ap)
{
    char line[2048];
    vsnprintf(line, sizeof line, fmt, ap);
    if (*prefix != 'e' && said_before(line))
        return;
    fprintf(stderr, "%s%s\n", prefix, line);
}

void spt_error(const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    say("error: ", fmt, ap);
    va_end(ap);
}

void spt_warn(const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    say("warning: ", fmt, ap);
    va_end(ap);
}

void spt_note(const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    say("note: ", fmt, ap);
    va_end(ap);
}

int spt_report(const SptError *e)
{
    spt_error("%s", e->msg);
    return e->code ? e->code : SPT_EXIT_FAILURE;
}

double spt_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static void *check(void *p, size_t n)
{
    if (!p && n) {
        fprintf(stderr, "error: out of host memory (asked for %zu bytes)\n", n);
        exit(SPT_EXIT_FAILURE);
    }
    return p;
}

void *spt_malloc(size_t n) { return check(malloc(n ? n : 1), n); }
void *spt_calloc(size_t count, size_t size) { return check(calloc(count ? count : 1, size ? size : 1), count * size); }
void *spt_realloc(void *p, size_t n) { return check(realloc(p, n ? n : 1), n); }
char *spt_strdup(const char *s) { return check(strdup(s), strlen(s) + 1); }

/* What a kernel build from source maps beyond the memory we count (LLVM, PoCL's
 * threads): a cold build on PoCL crashed (SIGSEGV in LLVM) with about 190 MiB
 * of address space left after loading and worked with 580 MiB. */
#define SPT_AS_RESERVE (512.0 * 1048576.0)

/* The value of the line "field: value kB" of the /proc file path, in kB; 0
 * when there is none. */
static double proc_kb(const char *path, const char *field)
{
    FILE *f = fopen(path, "r");
    double kb = 0, v;
    char line[256], name[64];
    while (f && fgets(line, sizeof line, f))
        if (sscanf(line, "%63[^:]: %lf", name, &v) == 2 && !strcmp(name, field)) {
            kb = v;
            break;
        }
    if (f)
        fclose(f);
    return kb;
}

/* The address space a limit (RLIMIT_AS: ulimit -v) leaves the process: the
 * limit less what is mapped now (VmSize of /proc/self/status) and less
 * SPT_AS_RESERVE for the OpenCL implementation (docs/limits.md); -1 without a
 * limit. */
static double address_space_left(void)
{
    struct rlimit rl;
    if (getrlimit(RLIMIT_AS, &rl) != 0 || rl.rlim_cur == RLIM_INFINITY)
        return -1.0;
    double kb = proc_kb("/proc/self/status", "VmSize");
    double left = (double)rl.rlim_cur - kb * 1024.0 - SPT_AS_RESERVE;
    return left > 0.0 ? left : 0.0;
}

/* SPECTRACE_MAX_MEMORY_MB, else MemAvailable; 0 when neither is known. */
static double memory_available(void)
{
    const char *s = getenv("SPECTRACE_MAX_MEMORY_MB");
    if (s && *s) {
        char *end;
        double mb = strtod(s, &end);
        if (!*end && mb > 0)
            return mb * 1048576.0;
        spt_warn("SPECTRACE_MAX_MEMORY_MB '%s' is not a positive number of MiB; ignored", s);
    }
    return proc_kb("/proc/meminfo", "MemAvailable") * 1024.0;
}

static int limit_is_address_space;

double spt_memory_limit(void)
{
    double as = address_space_left(), limit = memory_available();
    limit_is_address_space = as >= 0.0 && (limit <= 0.0 || as < limit);
    if (limit_is_address_space)
        limit = as > 0.0 ? as : 1.0; /* 0 would mean no limit */
    return limit;
}

const char *spt_memory_limit_why(void)
{
    return limit_is_address_space ? "that the address-space limit (ulimit -v) leaves"
                                  : "available (SPECTRACE_MAX_MEMORY_MB sets the limit)";
}

const char *spt_format_bytes(char *buf, size_t n, double bytes)
{
    double gib = bytes / 1073741824.0;
    if (gib >= 10.0)
        snprintf(buf, n, "%.1f GiB", gib);
    else if (gib >= 1.0)
        snprintf(buf, n, "%.2f GiB", gib);
    else
        snprintf(buf, n, "%.1f MiB", bytes / 1048576.0);
    return buf;
}
