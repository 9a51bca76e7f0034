/* Safe reading of input files (src/core/input_file.h). */
#include "core/input_file.h"

#include <errno.h>
#include <fcntl.h>
#include <pthread.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

size_t input_max_bytes(void)
{
    static int warned;
    const char *s = getenv("SPECTRACE_MAX_INPUT_MB");
    unsigned long long mb = SPT_INPUT_DEFAULT_MAX_MB;
    if (s && *s) {
        char *end;
        errno = 0;
        unsigned long long v = strtoull(s, &end, 10);
        if (*end || errno || v == 0 || v > (SIZE_MAX >> 20) || s[0] == '-') {
            if (!warned)
                spt_warn("SPECTRACE_MAX_INPUT_MB '%s' is not a positive whole number of MiB; "
                         "using %d", s, SPT_INPUT_DEFAULT_MAX_MB);
            warned = 1;
        } else {
            mb = v;
        }
    }
    return (size_t)mb << 20;
}

static const char *kind_of(mode_t m)
{
    return S_ISDIR(m) ? "a folder" : S_ISCHR(m) ? "a character device" : S_ISBLK(m) ? "a block device"
         : S_ISSOCK(m) ? "a socket" : S_ISFIFO(m) ? "a pipe" : "not a regular file";
}

static int too_large(const char *path, const char *what, unsigned long long size, SptError *e)
{
    return spt_fail(e, SPT_EXIT_INPUT, "%s: %s of %llu bytes is larger than the input limit of "
                    "%zu MiB (raise it with SPECTRACE_MAX_INPUT_MB)", path, what, size,
                    input_max_bytes() >> 20);
}

int input_check(const char *path, const char *what, SptError *e)
{
    struct stat st;
    if (stat(path, &st) != 0)
        return spt_fail(e, SPT_EXIT_INPUT, "%s: cannot read the %s: %s", path, what,
                        strerror(errno));
    if (!S_ISREG(st.st_mode))
        return spt_fail(e, SPT_EXIT_INPUT, "%s: the %s is %s, not a regular file", path, what,
                        kind_of(st.st_mode));
    if ((unsigned long long)st.st_size > input_max_bytes())
        return too_large(path, what, (unsigned long long)st.st_size, e);
    input_seen_add(path, &st);
    return SPT_EXIT_OK;
}

int input_read(const char *path, const char *what, unsigned char **data, size_t *size,
               SptError *e)
{
    *data = NULL;
    *size = 0;
    /* O_NONBLOCK: opening a FIFO without a writer does not wait; cleared below. */
    int fd = open(path, O_RDONLY | O_CLOEXEC | O_NONBLOCK);
    if (fd < 0)
        return spt_fail(e, SPT_EXIT_INPUT, "%s: cannot read the %s: %s", path, what,
                        strerror(errno));
    struct stat st;
    if (fstat(fd, &st) != 0 || !(S_ISREG(st.st_mode) || S_ISFIFO(st.st_mode))) {
        int rc = spt_fail(e, SPT_EXIT_INPUT, "%s: the %s is %s, not a regular file", path, what,
                          kind_of(st.st_mode));
        close(fd);
        return rc;
    }
    size_t cap = input_max_bytes();
    if (S_ISREG(st.st_mode) && (unsigned long long)st.st_size > cap) {
        close(fd);
        return too_large(path, what, (unsigned long long)st.st_size, e);
    }
    fcntl(fd, F_SETFL, fcntl(fd, F_GETFL) & ~O_NONBLOCK);
    size_t n = 0, alloc = S_ISREG(st.st_mode) ? (size_t)st.st_size + 1 : 65536;
    unsigned char *buf = malloc(alloc);
    if (!buf) {
        close(fd);
        return spt_fail(e, SPT_EXIT_INPUT, "%s: the %s of %zu bytes does not fit in memory", path,
                        what, alloc);
    }
    int err = 0;
    for (;;) {
        if (n + 1 >= alloc) {
            if (n > cap)
                break;
            size_t next = alloc * 2 > cap + 2 ? cap + 2 : alloc * 2;
            unsigned char *grown = next > alloc ? realloc(buf, next) : NULL;
            if (!grown) {
                err = ENOMEM;
                break;
            }
            buf = grown;
            alloc = next;
        }
        ssize_t k = read(fd, buf + n, alloc - 1 - n);
        if (k < 0 && errno == EINTR)
            continue;
        if (k < 0) {
            err = errno;
            break;
        }
        if (k == 0)
            break;
        n += (size_t)k;
    }
    close(fd);
    if (err) {
        free(buf);
        return spt_fail(e, SPT_EXIT_INPUT, "%s: cannot read the %s: %s", path, what,
                        strerror(err));
    }
    if (n > cap) {
        free(buf);
        return too_large(path, what, (unsigned long long)n, e);
    }
    buf[n] = 0;
    *data = buf;
    *size = n;
    input_seen_add(path, &st);
    return SPT_EXIT_OK;
}

/* The inputs read, by device and inode (several threads may load textures). */
static pthread_mutex_t seen_lock = PTHREAD_MUTEX_INITIALIZER;
static InputList seen;

static void list_add(InputList *list, const char *path, dev_t dev, ino_t ino)
{
    if (list->count == list->cap) {
        list->cap = list->cap ? 2 * list->cap : 16;
        list->files = spt_realloc(list->files, (size_t)list->cap * sizeof *list->files);
    }
    list->files[list->count++] = (InputFile){dev, ino, spt_strdup(path)};
}

void input_seen_add(const char *path, const struct stat *st)
{
    pthread_mutex_lock(&seen_lock);
    if (!input_list_match(&seen, st))
        list_add(&seen, path, st->st_dev, st->st_ino);
    pthread_mutex_unlock(&seen_lock);
}

const char *input_list_match(const InputList *list, const struct stat *st)
{
    for (int i = 0; i < list->count; i++)
        if (list->files[i].dev == st->st_dev && list->files[i].ino == st->st_ino)
            return list->files[i].path;
    return NULL;
}

const char *input_seen_match(const struct stat *st)
{
    pthread_mutex_lock(&seen_lock);
    const char *p = input_list_match(&seen, st);
    pthread_mutex_unlock(&seen_lock);
    return p;
}

void input_seen_copy(InputList *list)
{
    memset(list, 0, sizeof *list);
    pthread_mutex_lock(&seen_lock);
    for (int i = 0; i < seen.count; i++)
        list_add(list, seen.files[i].path, seen.files[i].dev, seen.files[i].ino);
    pthread_mutex_unlock(&seen_lock);
}

void input_list_free(InputList *list)
{
    for (int i = 0; i < list->count; i++)
        free(list->files[i].path);
    free(list->files);
    memset(list, 0, sizeof *list);
}

void input_seen_reset(void)
{
    pthread_mutex_lock(&seen_lock);
    input_list_free(&seen);
    pthread_mutex_unlock(&seen_lock);
}
