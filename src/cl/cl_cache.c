/* The program binary cache: one file per device, driver, source and options,
 * checked by its key and a checksum before use. */
#include "cl/cl_internal.h"

#include <errno.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

unsigned long long cl_fnv1a(unsigned long long h, const void *data, size_t n)
{
    const unsigned char *p = data;
    for (size_t i = 0; i < n; i++) {
        h ^= p[i];
        h *= 0x100000001b3ull;
    }
    return h;
}

const char *cl_cache_dir(char *buf, size_t n)
{
    const char *s = getenv("SPECTRACE_CACHE_DIR");
    const char *x = getenv("XDG_CACHE_HOME");
    const char *home = getenv("HOME");
    if (s && *s)
        snprintf(buf, n, "%s", strcmp(s, "off") ? s : "");
    else if (x && *x)
        snprintf(buf, n, "%s/spectrace", x);
    else if (home && *home)
        snprintf(buf, n, "%s/.cache/spectrace", home);
    else
        buf[0] = 0;
    return buf;
}

/* mkdir -p; 0 on success. */
static int make_dirs(const char *path)
{
    char tmp[4096];
    snprintf(tmp, sizeof tmp, "%s", path);
    for (char *p = tmp + 1; *p; p++) {
        if (*p != '/')
            continue;
        *p = 0;
        if (mkdir(tmp, 0755) && errno != EEXIST)
            return -1;
        *p = '/';
    }
    if (mkdir(tmp, 0755) && errno != EEXIST)
        return -1;
    struct stat st;
    return stat(tmp, &st) == 0 && S_ISDIR(st.st_mode) ? 0 : -1;
}

static int cache_warned; /* the unwritable-folder warning is given once */

/* Cache file layout: magic "SPTCLBN1", u32 key length, key, u64 binary length,
 * binary, u64 FNV-1a of everything before it. The key (device, driver,
 * platform, source hash, options) is checked in full, so a file-name hash
 * collision cannot load the wrong binary. */
static const char cache_magic[8] = {'S', 'P', 'T', 'C', 'L', 'B', 'N', '1'};

/* The binary of a valid cache entry for key, malloc'd; NULL when absent or
 * invalid (*corrupt set when the file exists but is unusable). */
unsigned char *cl_cache_load(const char *path, const char *key, size_t *bin_len,
                                 int *corrupt)
{
    size_t len = 0;
    *corrupt = 0;
    unsigned char *f = (unsigned char *)cl_read_file(path, &len);
    if (!f)
        return NULL;
    *corrupt = 1;
    size_t klen = strlen(key);
    size_t off = 0;
    uint32_t kl;
    uint64_t bl, sum;
    if (len < sizeof cache_magic + 4 + 8 + 8 || memcmp(f, cache_magic, sizeof cache_magic))
        goto bad;
    off = sizeof cache_magic;
    memcpy(&kl, f + off, 4);
    off += 4;
    if (kl != klen || len - off < (size_t)kl + 16 || memcmp(f + off, key, klen))
        goto bad;
    off += kl;
    memcpy(&bl, f + off, 8);
    off += 8;
    if (bl == 0 || bl != len - off - 8)
        goto bad;
    memcpy(&sum, f + len - 8, 8);
    if (sum != cl_fnv1a(SPT_FNV1A_INIT, f, len - 8))
        goto bad;
    unsigned char *bin = spt_malloc((size_t)bl);
    memcpy(bin, f + off, (size_t)bl);
    free(f);
    *bin_len = (size_t)bl;
    *corrupt = 0;
    return bin;
bad:
    free(f);
    return NULL;
}

/* Writes a cache entry atomically (temporary file, then rename); warns once
 * when the folder cannot be written. */
void cl_cache_store(const char *dir, const char *path, const char *key,
                        const unsigned char *bin, size_t bin_len)
{
    char tmp[4200];
    /* Unique per process and per call, so that two processes, or two devices of
     * one process building in threads, never share a temporary file. */
    static unsigned serial;
    snprintf(tmp, sizeof tmp, "%s.tmp.%ld.%p.%u", path, (long)getpid(), (const void *)&tmp,
             serial++);
    const char *why = NULL;
    FILE *f = NULL;
    if (make_dirs(dir))
        why = strerror(errno);
    else if (!(f = fopen(tmp, "wb")))
        why = strerror(errno);
    if (f) {
        uint32_t kl = (uint32_t)strlen(key);
        uint64_t bl = bin_len;
        Buf b = {0};
        cl_buf_add(&b, cache_magic, sizeof cache_magic);
        cl_buf_add(&b, (const char *)&kl, 4);
        cl_buf_add(&b, key, kl);
        cl_buf_add(&b, (const char *)&bl, 8);
        cl_buf_add(&b, (const char *)bin, bin_len);
        uint64_t sum = cl_fnv1a(SPT_FNV1A_INIT, b.s, b.len);
        cl_buf_add(&b, (const char *)&sum, 8);
        int ok = fwrite(b.s, 1, b.len, f) == b.len;
        ok &= fclose(f) == 0;
        free(b.s);
        if (!ok)
            why = "write failed (disk full?)";
        else if (rename(tmp, path))
            why = strerror(errno);
        if (why)
            unlink(tmp);
    }
    if (why && !cache_warned) {
        cache_warned = 1;
        spt_warn("kernel cache folder %s is not writable (%s); kernels are compiled on "
                 "every run (set SPECTRACE_CACHE_DIR to change the folder)",
                 dir, why);
    }
}
