/* Every header under kernels/ compiles alone, as a translation unit of the one
 * line `#include "x/y.h"`: as OpenCL C on the device (through the project's
 * include resolver, cl_program_build_text), under the options of both kernel
 * code paths, and with the host C compiler when it is meant for the host too:
 * every header without a line holding only SPT_DEVICE_ONLY
 * (kernels/util/portable.h; docs/architecture.md, "Portability rules"). The
 * headers are those embedded in the program (build/gen/kernel_sources.c, every
 * kernels/x/y.h of the tree), so a new header is covered without a change here. */
#include "test_util.h"

#include "cl/cl_device.h"
#include "cl/embedded.h"

static int is_header(const char *path)
{
    size_t n = strlen(path);
    return n > 2 && !strcmp(path + n - 2, ".h");
}

/* Whether the file's text has a line holding only SPT_DEVICE_ONLY (leading and
 * trailing blanks aside). */
static int is_device_only(const char *text)
{
    const char *m = "SPT_DEVICE_ONLY";
    size_t mn = strlen(m);
    for (const char *line = text; *line;) {
        const char *end = strchr(line, '\n');
        if (!end)
            end = line + strlen(line);
        const char *a = line, *b = end;
        while (a < b && (*a == ' ' || *a == '\t'))
            a++;
        while (b > a && (b[-1] == ' ' || b[-1] == '\t' || b[-1] == '\r'))
            b--;
        if ((size_t)(b - a) == mn && !memcmp(a, m, mn))
            return 1;
        line = *end ? end + 1 : end;
    }
    return 0;
}

/* The path without its leading "kernels/" (as the includes name it). */
static const char *include_name(const char *path)
{
    return strncmp(path, "kernels/", 8) ? path : path + 8;
}

/* Writes text to path under test_dir(), making the folders on its way. */
static void write_tree_file(const char *path, const char *text)
{
    char dir[1024];
    snprintf(dir, sizeof dir, "%s", path);
    for (char *c = dir + strlen(test_dir()) + 1; *c; c++)
        if (*c == '/') {
            *c = 0;
            mkdir(dir, 0755);
            *c = '/';
        }
    test_write_text(path, text);
}

/* The embedded tree holds the headers the tests below go through: the
 * folders of docs/architecture.md, "Source layout", a header each at least. */
TEST(test_embedded_tree_lists_the_headers)
{
    const char *folders[] = {"util/", "sample/", "spectrum/", "bvh/", "closure/",
                             "material/", "light/", "integrator/"};
    for (size_t k = 0; k < sizeof folders / sizeof folders[0]; k++) {
        int n = 0;
        for (int i = 0; i < spt_kernel_file_count; i++)
            n += is_header(spt_kernel_files[i].path) &&
                 !strncmp(include_name(spt_kernel_files[i].path), folders[k], strlen(folders[k]));
        if (n == 0)
            fail_msg("no header of kernels/%s is embedded", folders[k]);
    }
    /* The marker test finds the line and nothing else. */
    assert_true(is_device_only("#include \"a.h\"\n\nSPT_DEVICE_ONLY\n"));
    assert_true(is_device_only("  SPT_DEVICE_ONLY  \r\nx"));
    assert_false(is_device_only("#define SPT_DEVICE_ONLY\n"));
    assert_false(is_device_only("/* says SPT_DEVICE_ONLY */\n"));
}

/* Each header alone with the host's C compiler ($CC, else cc), as the project
 * compiles its host code (C11, -Wall -Wextra), warnings as errors. */
TEST(test_host_headers_compile_alone)
{
    const char *cc = getenv("CC");
    if (!cc || !*cc)
        cc = "cc";
    char cmd[4096], log[4096];
    snprintf(cmd, sizeof cmd, "%s --version", cc);
    if (test_sh(cmd, TEST_BOTH, NULL, 0) != 0) {
        print_message("no host C compiler (%s): skipped\n", cc);
        skip();
    }
    for (int i = 0; i < spt_kernel_file_count; i++)
        write_tree_file(test_path(spt_kernel_files[i].path), spt_kernel_files[i].text);
    int host = 0, failed = 0;
    char failures[2048] = "";
    for (int i = 0; i < spt_kernel_file_count; i++) {
        const SptEmbeddedFile *f = &spt_kernel_files[i];
        if (!is_header(f->path) || is_device_only(f->text))
            continue;
        host++;
        char text[600];
        snprintf(text, sizeof text, "#include \"%s\"\n", include_name(f->path));
        test_write_text(test_path("host_tu.c"), text);
        snprintf(cmd, sizeof cmd, "%s -std=c11 -Wall -Wextra -Werror -fsyntax-only -I '%s' '%s'", cc,
                 test_path("kernels"), test_path("host_tu.c"));
        if (test_sh(cmd, TEST_BOTH, log, sizeof log) != 0) {
            /* stderr: cmocka's print_message cuts a message at 1 KB. */
            fprintf(stderr, "%s does not compile alone on the host:\n%s\n\n", f->path, log);
            size_t used = strlen(failures);
            snprintf(failures + used, sizeof failures - used, " %s", f->path);
            failed++;
        }
    }
    print_message("%d headers for the host\n", host);
    assert_true(host >= 1);
    if (failed)
        fail_msg("%d headers do not compile alone on the host:%s", failed, failures);
}

/* Each header alone as OpenCL C on the first device, once with the options of
 * the CPU code path and once with those of the GPU path
 * (src/render/wavefront.c), the optional parts (AOVs, spectral bands, the
 * NaN test hook) switched on, the CPU path's without instances' code. */
TEST(test_device_headers_compile_alone)
{
    const char *options[] = {
        "-DSPT_BVH_SIMD=1 -DSPT_BVH_PAIRS=1 -DSPT_BVH_STEP_PREFETCH=1 -DSPT_AOV=1 "
        "-DSPT_BANDS=16 -DSPT_TEST_INJECT_NAN=1 -DSPT_INSTANCES=0",
        "-DSPT_BVH_SHORT_STACK=1 -DSPT_AOV=1 -DSPT_BANDS=16",
    };
    ClDeviceList list;
    ClDevice dev;
    SptError e = {0};
    unsetenv("SPECTRACE_KERNEL_DIR");
    if (cl_device_list(&list, &e) || cl_device_open(&dev, &list.devices[0], 0, &e))
        fail_msg("no OpenCL device: %s", e.msg);
    int built = 0, failed = 0;
    char failures[2048] = "";
    for (int i = 0; i < spt_kernel_file_count; i++) {
        const SptEmbeddedFile *f = &spt_kernel_files[i];
        if (!is_header(f->path))
            continue;
        char text[600];
        snprintf(text, sizeof text, "#include \"%s\"\n", include_name(f->path));
        for (size_t k = 0; k < sizeof options / sizeof options[0]; k++) {
            cl_program prog = NULL;
            e = (SptError){0};
            if (cl_program_build_text(&dev, "kernels/header_test.cl", text, options[k], &prog, &e)) {
                fprintf(stderr, "%s does not compile alone on the device (%s): %s\n%.3000s\n\n", f->path,
                        options[k], e.msg, dev.build_log ? dev.build_log : "");
                size_t used = strlen(failures);
                snprintf(failures + used, sizeof failures - used, " %s", f->path);
                failed++;
                continue;
            }
            clReleaseProgram(prog);
            built++;
        }
    }
    cl_device_close(&dev);
    cl_device_list_free(&list);
    print_message("%d header builds on the device\n", built);
    assert_true(built + failed >= 2);
    if (failed)
        fail_msg("%d header builds failed on the device:%s", failed, failures);
}

TEST_MAIN("kernel_headers", test_dir_setup, test_dir_teardown)
