/* Atomic file writes (src/io/atomic_file.h). */
#include "io/atomic_file.h"

#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
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

void atomic_resolve(const char *path, char *out, size_t out_size)
{
    struct stat st;
    char *real = NULL;
    if (lstat(path, &st) == 0 && S_ISLNK(st.st_mode) && (real = realpath(path, NULL)) &&
        strlen(real) < out_size)
        snprintf(out, out_size, "%s", real);
    else
        snprintf(out, out_size, "%s", path);
    free(real);
}

int atomic_path_check(const char *path, SptError *e)
{
    if (strlen(path) >= PATH_MAX)
        return spt_fail(e, SPT_EXIT_OUTPUT, "%.200s...: the path is %zu bytes, longer than the "
                        "%d the system allows", path, strlen(path), PATH_MAX);
    struct stat st;
    if (lstat(path, &st) == 0 && S_ISLNK(st.st_mode) && stat(path, &st) != 0)
        return spt_fail(e, SPT_EXIT_OUTPUT, "%s: a symbolic link to a file that cannot be "
                        "reached: %s", path, strerror(errno));
    char real[PATH_MAX], dir[PATH_MAX];
    const char *base;
    atomic_resolve(path, real, sizeof real);
    atomic_split_path(real, dir, sizeof dir, &base);
    errno = 0;
    long name_max = pathconf(dir, _PC_NAME_MAX);
    if (name_max <= 0)
        name_max = NAME_MAX;
    if (strlen(base) > (size_t)name_max)
        return spt_fail(e, SPT_EXIT_OUTPUT, "%.80s...: the file name is %zu bytes, longer than "
                        "the %ld its file system allows", path, strlen(base), name_max);
    return SPT_EXIT_OK;
}

/* The staged commits of atomic_stage_begin: temporary and destination names. */
static struct {
    int active, count, cap;
    char (*tmp)[PATH_MAX + 64];
    char (*dst)[PATH_MAX];
} stage;

void atomic_stage_begin(void)
{
    stage.active = 1;
    stage.count = 0;
}

int atomic_stage_finish(int commit, SptError *e)
{
    int rc = SPT_EXIT_OK;
    for (int i = 0; i < stage.count; i++) {
        if (commit && !rc && rename(stage.tmp[i], stage.dst[i]) != 0)
            rc = spt_fail(e, SPT_EXIT_OUTPUT, "%s: cannot replace the file: %s", stage.dst[i],
                          strerror(errno));
        else if (!commit || rc)
            unlink(stage.tmp[i]);
    }
    free(stage.tmp);
    free(stage.dst);
    memset(&stage, 0, sizeof stage);
    return rc;
}

int atomic_temp_create(const char *path_in, char *tmp, size_t tmp_size, SptError *e)
{
    static atomic_uint counter;
    char dir[PATH_MAX], path[PATH_MAX];
    const char *base;
    atomic_resolve(path_in, path, sizeof path);
    atomic_split_path(path, dir, sizeof dir, &base);
    const char *dot = strrchr(base, '.');
    const char *ext = dot ? dot : "";
    for (int attempt = 0; attempt < 100; ++attempt) {
        unsigned n = atomic_fetch_add(&counter, 1u);
        /* The base name is shortened so the temporary name fits NAME_MAX. */
        int len = snprintf(tmp, tmp_size, "%s/.%.120s%s%ld-%u%.16s", dir, base,
                           SPT_ATOMIC_TEMP_MARK, (long)getpid(), n, ext);
        if (len < 0 || (size_t)len >= tmp_size)
            return spt_fail(e, SPT_EXIT_OUTPUT, "%s: path too long", path_in);
        int fd = open(tmp, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
        if (fd >= 0) {
            close(fd);
            return SPT_EXIT_OK;
        }
        if (errno != EEXIST)
            return spt_fail(e, SPT_EXIT_OUTPUT, "%s: cannot create a file in folder '%s': %s",
                            path_in, dir, strerror(errno));
    }
    return spt_fail(e, SPT_EXIT_OUTPUT, "%s: cannot find a free temporary name in folder '%s'",
                    path_in, dir);
}

/* The test hook of src/io/atomic_file.h. */
int atomic_test_fail_commits;
int atomic_test_fail_commit_at;

int atomic_temp_commit(const char *tmp, const char *path, SptError *e)
{
    int rc = SPT_EXIT_OK;
    char dst[PATH_MAX];
    atomic_resolve(path, dst, sizeof dst);
    int fd = open(tmp, O_RDONLY | O_CLOEXEC);
    if (fd < 0 || fsync(fd) != 0)
        rc = spt_fail(e, SPT_EXIT_OUTPUT, "%s: cannot write: %s", path, strerror(errno));
    if (fd >= 0)
        close(fd);
    if (!rc && atomic_test_fail_commit_at > 0 && --atomic_test_fail_commit_at == 0)
        rc = spt_fail(e, SPT_EXIT_OUTPUT, "%s: cannot write: injected failure (test hook)", path);
    if (!rc && atomic_test_fail_commits)
        rc = spt_fail(e, SPT_EXIT_OUTPUT, "%s: cannot write: injected failure (test hook)", path);
    if (!rc && stage.active) {
        if (stage.count == stage.cap) {
            stage.cap = stage.cap ? 2 * stage.cap : 8;
            stage.tmp = spt_realloc(stage.tmp, (size_t)stage.cap * sizeof *stage.tmp);
            stage.dst = spt_realloc(stage.dst, (size_t)stage.cap * sizeof *stage.dst);
        }
        snprintf(stage.tmp[stage.count], sizeof stage.tmp[0], "%s", tmp);
        snprintf(stage.dst[stage.count], sizeof stage.dst[0], "%s", dst);
        stage.count++;
        return SPT_EXIT_OK;
    }
    if (!rc && rename(tmp, dst) != 0)
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
