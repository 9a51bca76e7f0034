/* Kernel sources: the embedded files (or SPECTRACE_KERNEL_DIR), with their
 * #include "..." lines spliced in, and the growing strings that hold them. */
#include "cl/cl_internal.h"

#include <errno.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "cl/embedded.h"

void cl_buf_add(Buf *b, const char *s, size_t n)
{
    if (b->len + n + 1 > b->cap) {
        b->cap = (b->len + n + 1) * 2;
        b->s = spt_realloc(b->s, b->cap);
    }
    memcpy(b->s + b->len, s, n);
    b->len += n;
    b->s[b->len] = 0;
}

void cl_buf_printf(Buf *b, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
void cl_buf_printf(Buf *b, const char *fmt, ...)
{
    char tmp[1200];
    va_list ap;
    va_start(ap, fmt);
    int n = vsnprintf(tmp, sizeof tmp, fmt, ap);
    va_end(ap);
    if (n > (int)sizeof tmp - 1)
        n = (int)sizeof tmp - 1;
    cl_buf_add(b, tmp, (size_t)n);
}

/* Reads a whole file; NULL when it cannot. *len gets its size. */
char *cl_read_file(const char *path, size_t *len)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    Buf b = {0};
    char chunk[65536];
    size_t n;
    while ((n = fread(chunk, 1, sizeof chunk, f)) > 0)
        cl_buf_add(&b, chunk, n);
    int bad = ferror(f);
    fclose(f);
    if (bad) {
        free(b.s);
        return NULL;
    }
    if (!b.s)
        b.s = spt_calloc(1, 1);
    if (len)
        *len = b.len;
    return b.s;
}

/* The text of kernel file `path` ("kernels/x.h"), malloc'd: from
 * SPECTRACE_KERNEL_DIR when set, else embedded. NULL when missing. */
char *cl_kernel_file_load(const char *path)
{
    const char *dir = getenv("SPECTRACE_KERNEL_DIR");
    if (dir && *dir) {
        const char *rel = strncmp(path, "kernels/", 8) ? path : path + 8;
        char full[4096];
        snprintf(full, sizeof full, "%s/%s", dir, rel);
        return cl_read_file(full, NULL);
    }
    for (int i = 0; i < spt_kernel_file_count; i++)
        if (!strcmp(spt_kernel_files[i].path, path))
            return spt_strdup(spt_kernel_files[i].text);
    return NULL;
}

/* Paths already spliced into the current program. */
typedef struct Seen {
    char **paths;
    int count;
} Seen;

static int seen_add(Seen *s, const char *path)
{
    for (int i = 0; i < s->count; i++)
        if (!strcmp(s->paths[i], path))
            return 0;
    s->paths = spt_realloc(s->paths, (s->count + 1) * sizeof *s->paths);
    s->paths[s->count++] = spt_strdup(path);
    return 1;
}

/* If `line` (length n) is `#include "name"`, copies name into out and returns 1. */
static int parse_include(const char *line, size_t n, char *out, size_t cap)
{
    const char *p = line, *end = line + n;
    while (p < end && (*p == ' ' || *p == '\t'))
        p++;
    if (p >= end || *p != '#')
        return 0;
    p++;
    while (p < end && (*p == ' ' || *p == '\t'))
        p++;
    if (end - p < 7 || strncmp(p, "include", 7))
        return 0;
    p += 7;
    while (p < end && (*p == ' ' || *p == '\t'))
        p++;
    if (p >= end || *p != '"')
        return 0;
    const char *q = memchr(p + 1, '"', (size_t)(end - p - 1));
    if (!q || (size_t)(q - p - 1) >= cap || q == p + 1)
        return 0;
    memcpy(out, p + 1, (size_t)(q - p - 1));
    out[q - p - 1] = 0;
    return 1;
}

/* The path of a kernel file as used in #line markers: "kernels/" + name unless
 * it has it already. */
void cl_kernel_path(const char *name, char *out, size_t cap)
{
    if (!strncmp(name, "kernels/", 8))
        snprintf(out, cap, "%s", name);
    else
        snprintf(out, cap, "kernels/%s", name);
}

/* Appends the resolved `text` of file `name` to b. */
static int resolve_into(Buf *b, const char *name, const char *text, Seen *seen, int depth,
                        SptError *e)
{
    if (depth > 64)
        return spt_fail(e, SPT_EXIT_DEVICE, "%s: kernel includes nest deeper than 64", name);
    cl_buf_printf(b, "#line 1 \"%s\"\n", name);
    int lineno = 1;
    const char *p = text;
    while (*p) {
        const char *nl = strchr(p, '\n');
        size_t n = nl ? (size_t)(nl - p) : strlen(p);
        char inc[512];
        if (parse_include(p, n, inc, sizeof inc)) {
            char path[600];
            cl_kernel_path(inc, path, sizeof path);
            if (seen_add(seen, path)) {
                char *sub = cl_kernel_file_load(path);
                if (!sub) {
                    const char *dir = getenv("SPECTRACE_KERNEL_DIR");
                    return spt_fail(e, SPT_EXIT_DEVICE,
                                    "%s:%d: included kernel file '%s' not found (%s%s)", name,
                                    lineno, path,
                                    dir && *dir ? "looked in SPECTRACE_KERNEL_DIR=" :
                                                  "not among the embedded kernel sources",
                                    dir && *dir ? dir : "");
                }
                int rc = resolve_into(b, path, sub, seen, depth + 1, e);
                free(sub);
                if (rc)
                    return rc;
                cl_buf_printf(b, "#line %d \"%s\"\n", lineno + 1, name);
            } else {
                cl_buf_printf(b, "/* #include \"%s\": already included */\n", inc);
            }
        } else {
            cl_buf_add(b, p, n);
            cl_buf_add(b, "\n", 1);
        }
        lineno++;
        if (!nl)
            break;
        p = nl + 1;
    }
    return SPT_EXIT_OK;
}

int cl_source_resolve_text(const char *name, const char *text, char **out, SptError *e)
{
    Buf b = {0};
    Seen seen = {0};
    seen_add(&seen, name);
    int rc = resolve_into(&b, name, text, &seen, 0, e);
    for (int i = 0; i < seen.count; i++)
        free(seen.paths[i]);
    free(seen.paths);
    if (rc) {
        free(b.s);
        *out = NULL;
        return rc;
    }
    *out = b.s ? b.s : spt_calloc(1, 1);
    return SPT_EXIT_OK;
}

char *cl_kernel_file_open(const char *path, char *full, size_t cap, SptError *e)
{
    cl_kernel_path(path, full, cap);
    char *text = cl_kernel_file_load(full);
    if (!text) {
        const char *dir = getenv("SPECTRACE_KERNEL_DIR");
        spt_fail(e, SPT_EXIT_DEVICE, "kernel file '%s' not found (%s%s)", full,
                 dir && *dir ? "looked in SPECTRACE_KERNEL_DIR=" : "not among the embedded kernel sources",
                 dir && *dir ? dir : "");
    }
    return text;
}

int cl_source_resolve(const char *path, char **out, SptError *e)
{
    char full[600];
    char *text = cl_kernel_file_open(path, full, sizeof full, e);
    if (!text) {
        *out = NULL;
        return SPT_EXIT_DEVICE;
    }
    int rc = cl_source_resolve_text(full, text, out, e);
    free(text);
    return rc;
}
