/* Shared helpers for the cmocka tests. Each test file is one binary. */
#ifndef SPT_TEST_UTIL_H
#define SPT_TEST_UTIL_H

#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include "test_main.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/time.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "scene/scene.h"

/* Fails with both values printed when |got - want| > tol. */
#define assert_close(got, want, tol)                                                    \
    do {                                                                                \
        double g_ = (double)(got), w_ = (double)(want), t_ = (double)(tol);             \
        if (!(fabs(g_ - w_) <= t_))                                                     \
            fail_msg("%s = %.9g, expected %.9g within %.3g (off by %.3g)", #got, g_, w_, \
                     t_, fabs(g_ - w_));                                                \
    } while (0)

/* Relative version: |got - want| <= rel * |want|. */
#define assert_close_rel(got, want, rel)                                                \
    do {                                                                                \
        double g_ = (double)(got), w_ = (double)(want), r_ = (double)(rel);             \
        if (!(fabs(g_ - w_) <= r_ * fabs(w_)))                                          \
            fail_msg("%s = %.9g, expected %.9g within %.3g relative (off by %.3g)",     \
                     #got, g_, w_, r_, fabs(g_ - w_) / fabs(w_));                       \
    } while (0)

/* ---- running programs: the one process runner of the tests ------------------ */

/* What test_sh captures of a command's output. */
enum test_capture {
    TEST_STDERR, /* stderr; stdout discarded */
    TEST_STDOUT, /* stdout; stderr discarded */
    TEST_BOTH,   /* stdout and stderr, interleaved */
};

/* The spectrace program: $SPECTRACE_EXE (tests/run_tests.sh sets it), else the
 * one make builds beside the tests (BUILD/spectrace for BUILD/tests/test_x), so
 * that a test binary run by hand tests the program too; fails when neither is
 * there, so no test passes for want of it. */
static inline const char *test_exe(void)
{
    static char path[4096];
    const char *env = getenv("SPECTRACE_EXE");
    if (env && *env) {
        if (access(env, X_OK))
            fail_msg("SPECTRACE_EXE=%s is not an executable", env);
        return env;
    }
    ssize_t n = readlink("/proc/self/exe", path, sizeof path - 16);
    if (n <= 0)
        fail_msg("SPECTRACE_EXE is not set and /proc/self/exe cannot be read");
    path[n] = 0;
    for (int up = 0; up < 2; up++) { /* BUILD/tests/test_x -> BUILD */
        char *slash = strrchr(path, '/');
        if (!slash)
            fail_msg("SPECTRACE_EXE is not set and %s has no build folder", path);
        *slash = 0;
    }
    strcat(path, "/spectrace");
    if (access(path, X_OK))
        fail_msg("SPECTRACE_EXE is not set and %s is not built (make; or run through "
                 "tests/run_tests.sh)", path);
    return path;
}

/* Runs the shell command line cmd with what it prints (which: enum
 * test_capture) into out, its first cap - 1 bytes, 0-terminated (out NULL:
 * discarded); returns the exit status (-1: killed by a signal). */
static inline int test_sh(const char *cmd, enum test_capture which, char *out, size_t cap)
{
    static const char *redir[] = {"2>&1 >/dev/null", "2>/dev/null", "2>&1"};
    char *full = malloc(strlen(cmd) + 32);
    assert_non_null(full);
    sprintf(full, "( %s ) %s", cmd, redir[which]);
    FILE *p = popen(full, "r");
    free(full);
    assert_non_null(p);
    char sink[4096];
    if (!out || !cap) {
        out = sink;
        cap = sizeof sink;
    }
    size_t n = 0, got;
    while ((got = fread(out + n, 1, cap - 1 - n, p)) > 0)
        n += got;
    out[n] = 0;
    while (fread(sink, 1, sizeof sink, p) > 0) /* the rest, so the program never blocks */
        ;
    int st = pclose(p);
    return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
}

/* Runs `env timeout -s KILL secs spectrace args` (env: "VAR=value " prefixes,
 * or ""; secs 0: no time limit) with which of its output into out (as
 * test_sh); returns the exit status (-1: killed, as by the timeout). */
static inline int test_spectrace(const char *env, int secs, const char *args,
                                 enum test_capture which, char *out, size_t cap)
{
    const char *exe = test_exe();
    char *cmd = malloc(strlen(env) + strlen(exe) + strlen(args) + 64);
    assert_non_null(cmd);
    if (secs > 0)
        sprintf(cmd, "%s timeout -s KILL %d '%s' %s", env, secs, exe, args);
    else
        sprintf(cmd, "%s '%s' %s", env, exe, args);
    int rc = test_sh(cmd, which, out, cap);
    free(cmd);
    return rc;
}

/* test_spectrace with stderr into err, stdout discarded. */
static inline int test_run_exe(const char *env, int secs, const char *args, char *err, size_t cap)
{
    return test_spectrace(env, secs, args, TEST_STDERR, err, cap);
}

/* err (a program's stderr) is exactly one line, "error: ..." containing want
 * (NULL: anything). */
static inline void test_one_error(const char *err, const char *want)
{
    const char *nl = strchr(err, '\n');
    if (strncmp(err, "error: ", 7) != 0 || !nl || nl[1] != 0)
        fail_msg("expected one error line, got:\n%s", err);
    if (want && !strstr(err, want))
        fail_msg("expected '%s' in: %s", want, err);
}

/* How test_run_child runs the program and signals it. */
typedef struct {
    unsigned long long as_bytes; /* the child's address-space limit (0: none) */
    const char *wait_for;        /* the first signal once a stderr line starts with this (NULL: none) */
    const char *then_on;         /* the second once a later line starts with this (the first one's note) */
    const int *sigs;             /* the signals; any after the second follow it at once */
    int nsig;
    /* Filled in: */
    double t_second;             /* seconds from the second signal to the end of stderr (-1: not sent) */
    long maxrss_kb;              /* the child's peak resident memory (ru_maxrss) */
} TestChild;

static inline double test_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* Runs spectrace with args (split at spaces) as a child of this process (so
 * that it can be signalled and its memory limited and measured, as c says),
 * stdout to /dev/null and stderr into err; a hang ends as SIGALRM after 300 s.
 * Returns the exit status (-1: killed by a signal). */
static inline int test_run_child(const char *args, TestChild *c, char *err, size_t cap)
{
    char buf[2048];
    snprintf(buf, sizeof buf, "%s", args);
    char *argv[64];
    int argc = 0;
    argv[argc++] = (char *)test_exe();
    for (char *save = NULL, *t = strtok_r(buf, " ", &save); t && argc < 63;
         t = strtok_r(NULL, " ", &save))
        argv[argc++] = t;
    argv[argc] = NULL;
    int fds[2];
    assert_int_equal(pipe(fds), 0);
    pid_t pid = fork();
    assert_true(pid >= 0);
    if (pid == 0) {
        dup2(fds[1], 2);
        close(fds[0]);
        close(fds[1]);
        int null = open("/dev/null", O_WRONLY);
        dup2(null, 1);
        if (c->as_bytes) {
            struct rlimit rl = {c->as_bytes, c->as_bytes};
            setrlimit(RLIMIT_AS, &rl);
        }
        alarm(300); /* a hang ends as SIGALRM, which fails the test */
        execv(argv[0], argv);
        _exit(127);
    }
    close(fds[1]);
    FILE *f = fdopen(fds[0], "r");
    size_t n = 0;
    int sent = 0, waiting = c->wait_for != NULL;
    double t2 = 0.0;
    char line[4096];
    err[0] = 0;
    while (fgets(line, sizeof line, f)) {
        size_t len = strlen(line);
        if (n + len < cap) {
            memcpy(err + n, line, len + 1);
            n += len;
        }
        if (!c->wait_for || sent >= c->nsig)
            continue;
        if (waiting && !strncmp(line, c->wait_for, strlen(c->wait_for)))
            waiting = 0;
        /* The first signal once the awaited line is there, the next once the
         * line then_on shows (the handler's note: the first was caught). */
        if (!waiting && (sent == 0 || !strncmp(line, c->then_on, strlen(c->then_on)))) {
            kill(pid, c->sigs[sent++]);
            if (sent == 2)
                t2 = test_now();
            while (sent < c->nsig && sent > 1)
                kill(pid, c->sigs[sent++]);
        }
    }
    fclose(f);
    c->t_second = sent >= 2 ? test_now() - t2 : -1.0;
    int st;
    struct rusage ru;
    wait4(pid, &st, 0, &ru);
    c->maxrss_kb = ru.ru_maxrss;
    return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
}

/* ---- files: the test's temporary folder, whole files --------------------------- */

/* The test binary's temporary folder, made by test_dir_make. */
static inline char *test_dir(void)
{
    static char dir[64];
    return dir;
}

/* Makes a new folder /tmp/<name>_XXXXXX as test_dir(); returns 0, or -1 (as a
 * cmocka set-up returns). */
static inline int test_dir_make(const char *name)
{
    snprintf(test_dir(), 64, "/tmp/%s_XXXXXX", name);
    return mkdtemp(test_dir()) ? 0 : -1;
}

/* Removes test_dir() with what is in it; returns 0, or -1. */
static inline int test_dir_remove(void)
{
    char cmd[300];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", test_dir());
    return system(cmd) == 0 ? 0 : -1;
}

/* Group set-up and tear-down of a file that needs only test_dir(), named after
 * the test binary (/tmp/test_x_XXXXXX). */
static inline int test_dir_setup(void **state)
{
    (void)state;
    char self[4096];
    ssize_t n = readlink("/proc/self/exe", self, sizeof self - 1);
    self[n > 0 ? n : 0] = 0;
    const char *base = strrchr(self, '/');
    return test_dir_make(base ? base + 1 : "spt_test");
}

static inline int test_dir_teardown(void **state)
{
    (void)state;
    return test_dir_remove();
}

/* test_dir()/name, in one of 8 rotating buffers (so a call may name several). */
static inline const char *test_path(const char *name)
{
    static char buf[8][512];
    static int k;
    k = (k + 1) % 8;
    snprintf(buf[k], sizeof buf[k], "%s/%s", test_dir(), name);
    return buf[k];
}

/* 1 when path names anything (a link too, even a broken one). */
static inline int test_exists(const char *path)
{
    struct stat st;
    return lstat(path, &st) == 0;
}

/* The whole file, malloc'd and 0-terminated (so text may be read as a string),
 * its size in *n (may be NULL); fails when it cannot be read. */
static inline char *test_slurp(const char *path, size_t *n)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        fail_msg("%s: %s", path, strerror(errno));
    fseek(f, 0, SEEK_END);
    long len = ftell(f);
    fseek(f, 0, SEEK_SET);
    assert_true(len >= 0);
    char *b = malloc((size_t)len + 1);
    assert_non_null(b);
    assert_int_equal(fread(b, 1, (size_t)len, f), (size_t)len);
    fclose(f);
    b[len] = 0;
    if (n)
        *n = (size_t)len;
    return b;
}

/* The file at path holds the n bytes want (as before a failed write); fails
 * naming it otherwise. */
static inline void test_assert_file_is(const char *path, const void *want, size_t n)
{
    size_t m;
    char *got = test_slurp(path, &m);
    if (m != n || memcmp(got, want, n))
        fail_msg("%s changed (%zu bytes, %zu before)", path, m, n);
    free(got);
}

/* Writes to dst the file src with its first occurrence of find (which must
 * be there) replaced by repl. */
static inline void test_copy_replacing(const char *src, const char *find, const char *repl, const char *dst)
{
    char *text = test_slurp(src, NULL);
    char *at = strstr(text, find);
    if (!at)
        fail_msg("%s has no %s", src, find);
    FILE *o = fopen(dst, "w");
    if (!o)
        fail_msg("%s: %s", dst, strerror(errno));
    fprintf(o, "%.*s%s%s", (int)(at - text), text, repl, at + strlen(find));
    assert_int_equal(fclose(o), 0);
    free(text);
}

/* Writes text to path (replacing it); fails when it cannot. */
static inline void test_write_text(const char *path, const char *text)
{
    FILE *f = fopen(path, "w");
    if (!f)
        fail_msg("%s: %s", path, strerror(errno));
    fputs(text, f);
    assert_int_equal(fclose(f), 0);
}

/* 1 when tests/run_tests.sh runs the device tests in quick form
 * (SPECTRACE_TEST_QUICK=1): on an OpenCL implementation that spends far longer per
 * kernel launch than PoCL (rusticl on llvmpipe, about 10 ms here, so that a
 * 24x24 furnace of unlimited depth takes a minute and a half). The long
 * statistical renders, whose result does not depend on the implementation once
 * the device-versus-host tests agree, are then left out as skipped
 * (skip_if_quick), and some tests render fewer cases. */
static inline int test_quick(void)
{
    const char *q = getenv("SPECTRACE_TEST_QUICK");
    return q && *q && strcmp(q, "0") != 0;
}

/* 1 when the tests run on rusticl (tests/run_tests.sh names the implementation
 * in SPECTRACE_TEST_IMPL): llvmpipe traces about 600 paths a second here
 * (docs/performance.md, "Implementations"), so the renders of its quick form
 * are smaller still where a test says so. */
static inline int test_on_rusticl(void)
{
    const char *impl = getenv("SPECTRACE_TEST_IMPL");
    return impl && strcmp(impl, "rusticl") == 0;
}

#define skip_if_quick()                                                              \
    do {                                                                             \
        if (test_quick()) {                                                          \
            print_message("  left out of the quick run on %s\n",                     \
                          getenv("SPECTRACE_TEST_IMPL") ? getenv("SPECTRACE_TEST_IMPL") \
                                                        : "this implementation");    \
            skip();                                                                  \
        }                                                                            \
    } while (0)

/* SplitMix64 (Steele, Lea and Flood 2014) of i as a float in [0, 1) (its top 24
 * bits): a reproducible stream of uniform numbers for sampling tests. */
static inline float test_uniform(uint64_t i)
{
    uint64_t z = i * 0x9e3779b97f4a7c15ull + 0x632be59bd9b4e019ull;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    z ^= z >> 31;
    return (float)(z >> 40) * (1.0f / 16777216.0f);
}

/* Loads the scene file at path into s; fails the test with the loader's message
 * when it cannot. */
static inline void test_load_scene(Scene *s, const char *path)
{
    SptError e = {0};
    if (scene_load_gltf(s, path, &e))
        fail_msg("load %s: %s", path, e.msg);
}

/* The source tree's root, for test data: tests run from it (tests/run_tests.sh). */
#define SPT_TEST_DATA(rel) ("tests/data/" rel)

#endif
