/* One main for every cmocka test binary: tests register themselves.
 *
 *     TEST(test_name) { ... }                       a test
 *     TEST_FIXTURE(test_name, setup, teardown) { }  a test with its own fixture
 *     TEST_MAIN("group", group_setup, group_teardown)
 *     TEST_MAIN_ENV("group", group_setup, group_teardown, "NAME=value", ...)
 *     TEST_MAIN_HOOK("group", group_setup, group_teardown, hook)
 *
 * TEST declares `static void test_name(void **state)` (state may go unused) and
 * a constructor that records it with its line; TEST_MAIN's main sorts the tests
 * by line, so they run in the order the file defines them, and hands them to
 * cmocka under the test's own name. TEST_MAIN_ENV first sets the environment
 * variables given (before any OpenCL call: PoCL reads POCL_DEVICES once). The
 * hook, `static int hook(int argc, char **argv)`, runs first: it sets the
 * environment, adds tests made at run time (test_add) or keeps only some
 * (test_keep_only), and returns TEST_GO_ON, or an exit status to stop there.
 * A binary that ends with no test fails: no file passes for want of tests.
 * A file may keep its own main and cmocka's array instead (nothing here runs
 * unless it uses TEST or TEST_MAIN). See docs/testing.md, "Writing a test". */
#ifndef SPT_TEST_MAIN_H
#define SPT_TEST_MAIN_H

#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define TEST_GO_ON (-1)

struct test_entry {
    struct CMUnitTest test;
    long line; /* the order: the line of the definition; run-time tests after */
};

struct test_registry {
    struct test_entry *entries;
    size_t n, cap;
};

static inline struct test_registry *test_registry(void)
{
    static struct test_registry reg;
    return &reg;
}

static inline void test_add_at(const char *name, CMUnitTestFunction fn, CMFixtureFunction setup,
                               CMFixtureFunction teardown, void *state, long line)
{
    struct test_registry *r = test_registry();
    if (r->n == r->cap) {
        r->cap = r->cap ? 2 * r->cap : 64;
        r->entries = realloc(r->entries, r->cap * sizeof *r->entries);
        if (!r->entries) {
            fprintf(stderr, "out of memory registering test %s\n", name);
            exit(1);
        }
    }
    struct test_entry e = {{name, fn, setup, teardown, state}, line};
    r->entries[r->n++] = e;
}

/* A test made at run time (one per data case, say): it runs after the file's
 * TESTs, in the order added, with `state` as its initial *state. */
static inline void test_add(const char *name, CMUnitTestFunction fn, void *state)
{
    test_add_at(name, fn, NULL, NULL, state, 1L << 30 | (long)test_registry()->n);
}

/* Keeps only the test called `name` (none when there is no such test, and the
 * binary then fails). */
static inline void test_keep_only(const char *name)
{
    struct test_registry *r = test_registry();
    size_t kept = 0;
    for (size_t i = 0; i < r->n; i++)
        if (!strcmp(r->entries[i].test.name, name))
            r->entries[kept++] = r->entries[i];
    r->n = kept;
}

/* Sets each "NAME=value" of `assignments`. */
static inline void test_set_env(const char *const *assignments, size_t n)
{
    for (size_t i = 0; i < n; i++) {
        char name[256];
        const char *eq = strchr(assignments[i], '=');
        size_t len = eq ? (size_t)(eq - assignments[i]) : 0;
        if (!eq || len >= sizeof name) {
            fprintf(stderr, "test_set_env: '%s' is not NAME=value\n", assignments[i]);
            exit(1);
        }
        memcpy(name, assignments[i], len);
        name[len] = 0;
        setenv(name, eq + 1, 1);
    }
}

static inline int test_entry_cmp(const void *a, const void *b)
{
    long la = ((const struct test_entry *)a)->line, lb = ((const struct test_entry *)b)->line;
    return (la > lb) - (la < lb);
}

static inline int test_run_all(const char *group, CMFixtureFunction setup,
                               CMFixtureFunction teardown)
{
    struct test_registry *r = test_registry();
    if (r->n == 0) {
        fprintf(stderr, "%s: no test registered\n", group);
        return 1;
    }
    qsort(r->entries, r->n, sizeof *r->entries, test_entry_cmp);
    struct CMUnitTest *tests = calloc(r->n, sizeof *tests);
    if (!tests)
        return 1;
    for (size_t i = 0; i < r->n; i++)
        tests[i] = r->entries[i].test;
    int rc = _cmocka_run_group_tests(group, tests, r->n, setup, teardown);
    free(tests);
    free(r->entries);
    r->entries = NULL;
    r->n = r->cap = 0;
    return rc;
}

#define TEST_FIXTURE(name, setup, teardown)                                    \
    static void name(void **state __attribute__((unused)));                    \
    __attribute__((constructor)) static void name##_register(void)             \
    {                                                                          \
        test_add_at(#name, name, setup, teardown, NULL, __LINE__);             \
    }                                                                          \
    static void name(void **state __attribute__((unused)))

#define TEST(name) TEST_FIXTURE(name, NULL, NULL)

#define TEST_MAIN_HOOK(group, setup, teardown, hook)                           \
    int main(int argc, char **argv)                                            \
    {                                                                          \
        int rc_ = hook(argc, argv);                                            \
        return rc_ != TEST_GO_ON ? rc_ : test_run_all(group, setup, teardown); \
    }

#define TEST_MAIN(group, setup, teardown)                                      \
    int main(void) { return test_run_all(group, setup, teardown); }

#define TEST_MAIN_ENV(group, setup, teardown, ...)                             \
    int main(void)                                                             \
    {                                                                          \
        static const char *const env_[] = {__VA_ARGS__};                       \
        test_set_env(env_, sizeof env_ / sizeof env_[0]);                      \
        return test_run_all(group, setup, teardown);                           \
    }

#endif
