/* src/core/util.c: error records. */
#include "test_util.h"

#include <string.h>

#include "core/util.h"

TEST(test_fail_fills_record)
{
    SptError e = {0};
    int rc = spt_fail(&e, SPT_EXIT_INPUT, "%s: meshes[%d]: %s", "a.gltf", 2, "bad");
    assert_int_equal(rc, SPT_EXIT_INPUT);
    assert_int_equal(e.code, SPT_EXIT_INPUT);
    assert_string_equal(e.msg, "a.gltf: meshes[2]: bad");
}

TEST(test_fail_truncates_long_messages)
{
    SptError e = {0};
    char big[4000];
    memset(big, 'x', sizeof big - 1);
    big[sizeof big - 1] = 0;
    spt_fail(&e, SPT_EXIT_FAILURE, "%s", big);
    assert_int_equal(strlen(e.msg), sizeof e.msg - 1);
}

TEST_MAIN("util", NULL, NULL)
