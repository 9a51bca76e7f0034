#include "core/util.h"

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

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

static void say(const char *prefix, const char *fmt, va_list ap)
{
    char line[2048];
    vsnprintf(line, sizeof line, fmt, ap);
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

double spt_memory_limit(void)
{
    const char *s = getenv("SPECTRACE_MAX_MEMORY_MB");
    if (s && *s) {
        char *end;
        double mb = strtod(s, &end);
        if (!*end && mb > 0)
            return mb * 1048576.0;
        spt_warn("SPECTRACE_MAX_MEMORY_MB '%s' is not a positive number of MiB; ignored", s);
    }
    FILE *f = fopen("/proc/meminfo", "r");
    double kb = 0;
    char line[256];
    while (f && fgets(line, sizeof line, f))
        if (sscanf(line, "MemAvailable: %lf kB", &kb) == 1)
            break;
    if (f)
        fclose(f);
    return kb * 1024.0;
}
