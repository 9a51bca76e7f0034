/* The test hooks from the environment (src/render/test_hooks.h). */
#include "render/test_hooks.h"

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* "I:X" of variable name: device I + 1 into *device, X into *value; both 0 when
 * the variable is unset or malformed. */
static void device_hook(const char *name, int *device, int *value)
{
    const char *v = getenv(name);
    int d, x;
    *device = *value = 0;
    if (v && sscanf(v, "%d:%d", &d, &x) == 2 && d >= 0) {
        *device = d + 1;
        *value = x;
    }
}

void render_test_hooks_env(RenderSettings *rs)
{
    device_hook("SPECTRACE_TEST_FAIL_DEVICE", &rs->test.fail_device, &rs->test.fail_after);
    device_hook("SPECTRACE_TEST_SLOW_DEVICE", &rs->test.slow_device, &rs->test.slow_ms);
    const char *nan = getenv("SPECTRACE_TEST_INJECT_NAN");
    rs->test.inject_nan = nan && *nan && strcmp(nan, "0") != 0;
    const char *poison = getenv("SPECTRACE_TEST_POISON");
    rs->test.poison = poison && *poison;
    rs->test.poison_word = rs->test.poison ? (uint32_t)strtoul(poison, NULL, 0) : 0;
    const char *first = getenv("SPECTRACE_TEST_RANKS_FIRST");
    rs->test.ranks_first = first && *first && strcmp(first, "0") != 0;
    const char *film_nan = getenv("SPECTRACE_TEST_FILM_NAN");
    rs->test.film_nan = film_nan ? atol(film_nan) : 0;
    const char *rebuild = getenv("SPECTRACE_TEST_BVH_REBUILD");
    rs->test.bvh_rebuild = rebuild && *rebuild && strcmp(rebuild, "0") != 0;
    const char *pool = getenv("SPECTRACE_POOL");
    if (pool && atoi(pool) > 0)
        rs->pool_size = (uint32_t)atoi(pool);
}
