/* Atomic file writes (src/io/atomic_file.h). */
#include "io/atomic_file.h"

#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

void atomic_split_path(const char *path, char *dir, size_t dir_size, const char **base)
{
    const char *slash = strrchr(path, '/');
    if (!slash) {
        snprintf(dir, dir_size, ".");
        *base = path;
    } else if (slash == path) {
        snprintf(dir, dir_size, "/");
        *base = slash + 1;
    } else {
        snprintf(dir, dir_size, "%.*s", (int)(slash - path), path);
        *base = slash + 1;
    }
}

int atomic_temp_create(const char *path, char *tmp, size_t tmp_size, SptError *e)
{
    static atomic_uint counter;
    char dir[PATH_MAX];
    const char *base;
    atomic_split_path(path, dir, sizeof dir, &base);
    const char *dot = strrchr(base, '.');
    const char *ext = dot ? dot : "";
    for (int attempt = 0; attempt < 100; ++attempt) {
        unsigned n = atomic_fetch_add(&counter, 1u);
        /* The base name is shortened so the temporary name fits NAME_MAX. */
        int len = snprintf(tmp, tmp_size, "%s/.%.120s%s%ld-%u%.16s", dir, base,
                           SPT_ATOMIC_TEMP_MARK, (long)getpid(), n, ext);
        if (len < 0 || (size_t)len >= tmp_size)
            return spt_fail(e, SPT_EXIT_OUTPUT, "%s: path too long", path);
        int fd = open(tmp, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
        if (fd >= 0) {
            close(fd);
            return SPT_EXIT_OK;
        }
        if (errno != EEXIST)
            return spt_fail(e, SPT_EXIT_OUTPUT, "%s: cannot create a file in folder '%s': %s",
                            path, dir, strerror(errno));
    }
    return spt_fail(e, SPT_EXIT_OUTPUT, "%s: cannot find a free temporary name in folder '%s'",
                    path, dir);
}

/* The test hook of src/io/atomic_file.h. */
int atomic_test_fail_commits;

int atomic_temp_commit(const char *tmp, const char *path, SptError *e)
{
    int rc = SPT_EXIT_OK;
    int fd = open(tmp, O_RDONLY | O_CLOEXEC);
    if (fd < 0 || fsync(fd) != 0)
        rc = spt_fail(e, SPT_EXIT_OUTPUT, "%s: cannot write: %s", path, strerror(errno));
    if (fd >= 0)
        close(fd);
    if (!rc && atomic_test_fail_commits)
        rc = spt_fail(e, SPT_EXIT_OUTPUT, "%s: cannot write: injected failure (test hook)", path);
    if (!rc && rename(tmp, path) != 0)
        rc = spt_fail(e, SPT_EXIT_OUTPUT, "%s: cannot replace the file: %s", path,
                      strerror(errno));
    if (rc)
        unlink(tmp);
    return rc;
}

int atomic_write_bytes(const char *path, const void *data, size_t n, SptError *e)
{
    char tmp[PATH_MAX + 64];
    int rc = atomic_temp_create(path, tmp, sizeof tmp, e);
    if (rc)
        return rc;
    int err = 0;
    int fd = open(tmp, O_WRONLY | O_TRUNC | O_CLOEXEC);
    if (fd < 0)
        err = errno;
    const unsigned char *p = data;
    size_t left = n;
    while (!err && left > 0) {
        ssize_t k = write(fd, p, left);
        if (k < 0 && errno == EINTR)
            continue;
        if (k <= 0) {
            err = k < 0 ? errno : ENOSPC;
            break;
        }
        p += k;
        left -= (size_t)k;
    }
    if (fd >= 0 && close(fd) != 0 && !err)
        err = errno;
    if (err) {
        unlink(tmp);
        return spt_fail(e, SPT_EXIT_OUTPUT, "%s: cannot write: %s", path, strerror(err));
    }
    return atomic_temp_commit(tmp, path, e);
}
