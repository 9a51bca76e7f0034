/* Shared by the tests of --denoise (tests/test_denoise.c,
 * tests/test_hostile_denoise.c): whether Open Image Denoise loads here, and
 * the skip of the tests that need it. Include after test_util.h. */
#ifndef SPT_DENOISE_TEST_H
#define SPT_DENOISE_TEST_H

#include <stdio.h>

#include "core/util.h"
#include "io/denoise.h"

static int have_oidn;

/* Opens the denoiser into d (closed by the caller); sets have_oidn, and says
 * why the tests that need it will skip when it does not load. */
static inline void oidn_probe(Denoiser *d)
{
    SptError e = {0};
    have_oidn = denoiser_open(d, &e) == 0;
    if (!have_oidn)
        printf("Open Image Denoise not loadable (%s): the tests that need it skip\n", e.msg);
}

/* Skips the calling test, saying why, where the denoiser cannot run. */
static inline void need_oidn(void)
{
#if defined(__SANITIZE_ADDRESS__)
    /* Open Image Denoise's TBB loads libtbbbind with RTLD_DEEPBIND, which
     * AddressSanitizer refuses (it ends the process). */
    print_message("  skipped in the sanitizer build (TBB's RTLD_DEEPBIND); the plain build runs it\n");
    skip();
#endif
    if (!have_oidn) {
        print_message("  Open Image Denoise not installed (make denoise): skipped\n");
        skip();
    }
}

#endif
