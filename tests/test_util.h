/* Shared helpers for the cmocka tests. Each test file is one binary. */
#ifndef SPT_TEST_UTIL_H
#define SPT_TEST_UTIL_H

#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>

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

/* Runs `env timeout -s KILL secs $SPECTRACE_EXE args` (env: "VAR=value "
 * prefixes, or ""), stderr into err (stdout discarded); returns the exit
 * status (-1: killed, as by the timeout). */
static inline int test_run_exe(const char *env, int secs, const char *args, char *err, size_t cap)
{
    const char *exe = getenv("SPECTRACE_EXE");
    if (!exe)
        fail_msg("SPECTRACE_EXE is not set (run through tests/run_tests.sh)");
    char cmd[4096];
    snprintf(cmd, sizeof cmd, "%s timeout -s KILL %d '%s' %s 2>&1 >/dev/null", env, secs, exe, args);
    FILE *p = popen(cmd, "r");
    assert_non_null(p);
    size_t n = fread(err, 1, cap - 1, p);
    err[n] = 0;
    int st = pclose(p);
    return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
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

/* The source tree's root, for test data: tests run from it (tests/run_tests.sh). */
#define SPT_TEST_DATA(rel) ("tests/data/" rel)

#endif
