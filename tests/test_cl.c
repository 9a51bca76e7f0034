/* src/cl/cl_device.c on PoCL: listing, selection (also with two PoCL devices, in a
 * child process), no platform, include resolution, build errors with their log,
 * the binary cache, a trivial kernel, memory checks, error names and the layout
 * check of shared structs. PoCL compiles slowly, so the tests share one open
 * device and compile only three distinct programs. */
#include "test_util.h"

#include <fcntl.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "cl/cl_device.h"
#include "util/layout_list.h"

static ClDeviceList g_list;
static ClDevice g_dev;         /* device 0, profiling queue */
static char g_tmp[256];        /* scratch folder of this run */
static char g_self[4096];      /* this test binary, for child processes */

/* ---- helpers ---------------------------------------------------------------- */

static void write_text(const char *path, const char *text)
{
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(text, 1, strlen(text), f), strlen(text));
    assert_int_equal(fclose(f), 0);
}

/* Makes the new folder g_tmp/name, its path into dir. */
static void new_folder(char *dir, size_t cap, const char *name)
{
    snprintf(dir, cap, "%s/%s", g_tmp, name);
    assert_int_equal(mkdir(dir, 0755), 0);
}

static long file_size(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0 ? (long)st.st_size : -1;
}

/* Number of lines in s (a last line without newline counts). */
static int count_lines(const char *s)
{
    int n = 0;
    for (const char *p = s; *p; p++)
        n += *p == '\n';
    if (*s && s[strlen(s) - 1] != '\n')
        n++;
    return n;
}

/* Child mode: lists devices, resolves each selection argument and prints
 * "SEL -> i,j" or "SEL -> error". Runs in a fresh process so PoCL reads its
 * environment (POCL_DEVICES) before its first use. */
static int child_select(int argc, char **argv)
{
    ClDeviceList list;
    SptError e = {0};
    if (cl_device_list(&list, &e))
        return spt_report(&e);
    printf("count %d\n", list.count);
    int *sel = calloc((size_t)list.count, sizeof *sel);
    for (int a = 0; a < argc; a++) {
        int n = 0;
        if (!strncmp(argv[a], "open:", 5)) { /* open the selected devices */
            ClDevice *devs = NULL;
            int rc = cl_devices_open(argv[a] + 5, 0, &devs, &n, &e);
            printf("%s -> %s %d", argv[a], rc ? "error" : "opened", n);
            for (int k = 0; k < n; k++)
                printf(" %d:%s", devs[k].info.index,
                       devs[k].context && devs[k].queue ? "ok" : "-");
            printf("\n");
            cl_devices_close(devs, n);
            continue;
        }
        printf("%s ->", argv[a]);
        if (cl_device_select(&list, argv[a], sel, &n, &e)) {
            printf(" error\n");
            continue;
        }
        for (int k = 0; k < n; k++)
            printf("%s%d", k ? "," : " ", sel[k]);
        printf("\n");
    }
    free(sel);
    cl_device_list_free(&list);
    return 0;
}

/* ---- fixtures --------------------------------------------------------------- */

static int setup(void **state)
{
    (void)state;
    snprintf(g_tmp, sizeof g_tmp, "/tmp/spt_test_cl_XXXXXX");
    if (!mkdtemp(g_tmp))
        return -1;
    ssize_t n = readlink("/proc/self/exe", g_self, sizeof g_self - 1);
    if (n <= 0)
        return -1;
    g_self[n] = 0;
    char cache[512];
    snprintf(cache, sizeof cache, "%s/cache", g_tmp);
    setenv("SPECTRACE_CACHE_DIR", cache, 1);
    unsetenv("SPECTRACE_DEVICE");
    unsetenv("SPECTRACE_KERNEL_DIR");
    SptError e = {0};
    if (cl_device_list(&g_list, &e) || cl_device_open(&g_dev, &g_list.devices[0], 1, &e)) {
        fprintf(stderr, "setup: %s\n", e.msg);
        return -1;
    }
    return 0;
}

static int teardown(void **state)
{
    (void)state;
    cl_device_close(&g_dev);
    cl_device_list_free(&g_list);
    char cmd[600];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", g_tmp);
    return system(cmd) == 0 ? 0 : -1;
}

/* ---- listing and selection -------------------------------------------------- */

TEST(test_list_matches_direct_query)
{
    /* Count devices with the raw API, independently of cl_device_list. */
    cl_uint np = 0, total = 0;
    assert_int_equal(clGetPlatformIDs(0, NULL, &np), CL_SUCCESS);
    cl_platform_id plats[16];
    assert_int_equal(clGetPlatformIDs(np < 16 ? np : 16, plats, NULL), CL_SUCCESS);
    cl_device_id first = NULL;
    for (cl_uint p = 0; p < np && p < 16; p++) {
        cl_uint nd = 0;
        if (clGetDeviceIDs(plats[p], CL_DEVICE_TYPE_ALL, 0, NULL, &nd) == CL_SUCCESS) {
            if (!first && nd)
                clGetDeviceIDs(plats[p], CL_DEVICE_TYPE_ALL, 1, &first, NULL);
            total += nd;
        }
    }
    assert_true(g_list.count >= 1);
    assert_int_equal(g_list.count, (int)total);
    char name[256];
    assert_int_equal(clGetDeviceInfo(first, CL_DEVICE_NAME, sizeof name, name, NULL),
                     CL_SUCCESS);
    assert_string_equal(g_list.devices[0].name, name);
    for (int i = 0; i < g_list.count; i++) {
        const ClDeviceInfo *d = &g_list.devices[i];
        assert_int_equal(d->index, i);
        assert_true(d->compute_units >= 1);
        assert_true(d->max_alloc > 0 && d->max_alloc <= d->global_mem);
        assert_true(d->max_work_group_size >= 1);
        assert_non_null(strstr(d->opencl_c_version, "OpenCL C"));
        assert_true(d->driver_version[0] != 0);
    }
}

TEST(test_select_by_index_and_default)
{
    int sel[64], n = 0;
    SptError e = {0};
    assert_int_equal(cl_device_select(&g_list, " 0 ", sel, &n, &e), SPT_EXIT_OK);
    assert_int_equal(n, 1);
    assert_int_equal(sel[0], 0);
    /* Default: the first GPU, else the first CPU. */
    int want = -1;
    for (int i = 0; i < g_list.count && want < 0; i++)
        if (g_list.devices[i].type & CL_DEVICE_TYPE_GPU)
            want = i;
    for (int i = 0; i < g_list.count && want < 0; i++)
        if (g_list.devices[i].type & CL_DEVICE_TYPE_CPU)
            want = i;
    assert_int_equal(cl_device_select(&g_list, NULL, sel, &n, &e), SPT_EXIT_OK);
    assert_int_equal(n, 1);
    assert_int_equal(sel[0], want < 0 ? 0 : want);
}

TEST(test_select_by_name_ignores_case)
{
    const char *name = g_list.devices[0].name;
    assert_true(strlen(name) >= 4);
    /* A middle part of the name with its letter case flipped. */
    char part[8] = {0};
    size_t off = strlen(name) / 2 - 2;
    for (int i = 0; i < 4; i++) {
        char c = name[off + (size_t)i];
        part[i] = (char)(c >= 'a' && c <= 'z' ? c - 32 : c >= 'A' && c <= 'Z' ? c + 32 : c);
    }
    int sel[64], n = 0;
    SptError e = {0};
    assert_int_equal(cl_device_select(&g_list, part, sel, &n, &e), SPT_EXIT_OK);
    assert_int_equal(n, 1);
    /* The first device whose name has that part (case-insensitively). */
    int want = -1;
    for (int i = 0; i < g_list.count && want < 0; i++)
        if (strcasestr(g_list.devices[i].name, part) ||
            strcasestr(g_list.devices[i].vendor, part) ||
            strcasestr(g_list.devices[i].platform_name, part))
            want = i;
    assert_int_equal(sel[0], want);
}

/* Selection on a made-up list of four devices: CPU, GPU, GPU, accelerator. */
static void expect_selection(const ClDeviceList *list, const char *sel, const char *want)
{
    int out[8], n = 0;
    SptError e = {0};
    char got[64] = "error";
    if (cl_device_select(list, sel, out, &n, &e) == SPT_EXIT_OK) {
        got[0] = 0;
        for (int k = 0; k < n; k++)
            snprintf(got + strlen(got), sizeof got - strlen(got), "%s%d", k ? "," : "", out[k]);
    }
    if (strcmp(got, want))
        fail_msg("selection '%s' gave %s, expected %s (%s)", sel ? sel : "(null)", got, want,
                 e.msg);
}

/* A device entry as cl_device_list would fill it, for the selection rules. */
static void made_up_device(ClDeviceInfo *d, int index, cl_device_type type, const char *name,
                           const char *vendor, const char *platform, const char *impl)
{
    memset(d, 0, sizeof *d);
    d->index = index;
    d->type = type;
    snprintf(d->name, sizeof d->name, "%s", name);
    snprintf(d->vendor, sizeof d->vendor, "%s", vendor);
    snprintf(d->platform_name, sizeof d->platform_name, "%s", platform);
    snprintf(d->impl, sizeof d->impl, "%s", impl);
}

TEST(test_select_rules_on_made_up_devices)
{
    ClDeviceInfo d[4];
    const char *names[4] = {"Xeon CPU", "Radeon GPU A", "Radeon GPU B", "FPGA thing"};
    cl_device_type types[4] = {CL_DEVICE_TYPE_CPU, CL_DEVICE_TYPE_GPU, CL_DEVICE_TYPE_GPU,
                               CL_DEVICE_TYPE_ACCELERATOR};
    const char *platforms[4] = {"Platform 0", "Platform 1", "Platform 2", "Platform 3"};
    for (int i = 0; i < 4; i++)
        /* The CPU on PoCL, the GPUs on AMD's runtime, the FPGA on none known. */
        made_up_device(&d[i], i, types[i], names[i], i == 0 ? "Intel" : "AMD", platforms[i],
                       i == 0 ? "pocl" : i < 3 ? "amd" : "fpga");
    ClDeviceList list = {d, 4};
    expect_selection(&list, NULL, "1");      /* the first GPU */
    expect_selection(&list, "", "1");
    expect_selection(&list, "all", "0,1,2,3");
    expect_selection(&list, "3, 0", "3,0");
    expect_selection(&list, "gpu,gpu", "1,2");
    expect_selection(&list, "gpu,gpu,gpu", "1,2"); /* no third GPU: nothing more */
    expect_selection(&list, "radeon gpu b", "2");
    expect_selection(&list, "amd,amd", "1,2");  /* implementation */
    expect_selection(&list, "intel", "error");   /* an implementation, not the vendor */
    expect_selection(&list, "xeon", "0");        /* device name */
    expect_selection(&list, "platform 3", "3");  /* platform name */
    expect_selection(&list, "CPU", "0");         /* type, not the name "Xeon CPU" */
    expect_selection(&list, "accelerator,cpu", "3,0");
    expect_selection(&list, "4", "error");
    expect_selection(&list, "-1", "error");
    expect_selection(&list, "2,nvidia", "error");
    /* Without a GPU the default is the first CPU. */
    d[1].type = d[2].type = CL_DEVICE_TYPE_ACCELERATOR;
    d[3].type = CL_DEVICE_TYPE_CPU;
    expect_selection(&list, NULL, "0");
    d[0].type = CL_DEVICE_TYPE_ACCELERATOR;
    expect_selection(&list, NULL, "3");
}

TEST(test_select_out_of_range_lists_devices)
{
    int sel[64], n = 5;
    SptError e = {0};
    char bad[16];
    snprintf(bad, sizeof bad, "%d", g_list.count);
    assert_int_equal(cl_device_select(&g_list, bad, sel, &n, &e), SPT_EXIT_DEVICE);
    assert_int_equal(e.code, SPT_EXIT_DEVICE);
    assert_int_equal(n, 0);
    assert_non_null(strstr(e.msg, "out of range"));
    assert_non_null(strstr(e.msg, "[0]"));
    assert_non_null(strstr(e.msg, g_list.devices[0].name));
    assert_null(strchr(e.msg, '\n'));
}

TEST(test_select_no_match_lists_devices)
{
    int sel[64], n = 0;
    SptError e = {0};
    assert_int_equal(cl_device_select(&g_list, "0,no-such-device-xyz", sel, &n, &e),
                     SPT_EXIT_DEVICE);
    assert_non_null(strstr(e.msg, "no device matches 'no-such-device-xyz'"));
    assert_non_null(strstr(e.msg, g_list.devices[0].name));
    /* The environment variable is used when no selection is given, and named. */
    setenv("SPECTRACE_DEVICE", "no-such-device-xyz", 1);
    memset(&e, 0, sizeof e);
    int rc = cl_device_select(&g_list, NULL, sel, &n, &e);
    unsetenv("SPECTRACE_DEVICE");
    assert_int_equal(rc, SPT_EXIT_DEVICE);
    assert_non_null(strstr(e.msg, "SPECTRACE_DEVICE"));
}

TEST(test_two_pocl_devices_all_and_lists)
{
    char cmd[5000], out[4096];
    snprintf(cmd, sizeof cmd,
             "POCL_DEVICES='pthread pthread' POCL_MAX_PTHREAD_COUNT=1 '%s' --child-select "
             "all 1,0 PTHREAD,pthread cpu,cpu 0,0 2 all,0 open:1,0 open:0,7",
             g_self);
    int rc = test_sh(cmd, TEST_BOTH, out, sizeof out);
    assert_int_equal(rc, 0);
    const char *want = "count 2\n"
                       "all -> 0,1\n"
                       "1,0 -> 1,0\n"
                       "PTHREAD,pthread -> 0,1\n"
                       "cpu,cpu -> 0,1\n"
                       "0,0 -> 0\n"
                       "2 -> error\n"
                       "all,0 -> 0,1\n"
                       "open:1,0 -> opened 2 1:ok 0:ok\n"
                       "open:0,7 -> error 0\n";
    if (strcmp(out, want))
        fail_msg("child printed:\n%s\nexpected:\n%s", out, want);
}

TEST(test_no_platform_says_how_to_install)
{
    char empty[512];
    snprintf(empty, sizeof empty, "%s/no_vendors", g_tmp);
    assert_int_equal(mkdir(empty, 0755), 0);
    char env[600], out[4096];
    snprintf(env, sizeof env, "OCL_ICD_VENDORS='%s'", empty);
    int rc = test_spectrace(env, 0, "devices", TEST_BOTH, out, sizeof out);
    assert_int_equal(rc, SPT_EXIT_DEVICE);
    assert_int_equal(strncmp(out, "error: ", 7), 0);
    assert_non_null(strstr(out, "no OpenCL platform"));
    assert_non_null(strstr(out, "apt-get install pocl-opencl-icd ocl-icd-opencl-dev"));
    assert_int_equal(count_lines(out), 1);
}

TEST(test_devices_command_lists_and_marks)
{
    char args[64], out[8192], want[600];
    assert_int_equal(test_spectrace("", 0, "devices --device 0", TEST_BOTH, out, sizeof out), 0);
    snprintf(want, sizeof want, " *[0] %s\n", g_list.devices[0].name);
    if (!strstr(out, want) || !strstr(out, "selected: 0\n") || !strstr(out, "fp64 "))
        fail_msg("spectrace devices printed:\n%s", out);
    snprintf(args, sizeof args, "devices --device %d", g_list.count);
    assert_int_equal(test_spectrace("", 0, args, TEST_BOTH, out, sizeof out), SPT_EXIT_DEVICE);
    /* The listing, then exactly one error line at the end. */
    const char *err = strstr(out, "error: ");
    assert_non_null(err);
    assert_non_null(strstr(err, "out of range"));
    assert_int_equal(count_lines(err), 1);
    assert_non_null(strstr(out, "  [0] "));
}

/* ---- sources and builds ------------------------------------------------------ */

TEST(test_includes_resolve_once_with_line_markers)
{
    char dir[512], path[600];
    new_folder(dir, sizeof dir, "kinc");
    snprintf(path, sizeof path, "%s/a.cl", dir);
    write_text(path, "x\n#include \"b.h\"\ny\n  #  include \"b.h\"\nz");
    snprintf(path, sizeof path, "%s/b.h", dir);
    write_text(path, "#include \"c.h\"\nB\n");
    snprintf(path, sizeof path, "%s/c.h", dir);
    write_text(path, "C\n");
    setenv("SPECTRACE_KERNEL_DIR", dir, 1);
    char *out = NULL;
    SptError e = {0};
    int rc = cl_source_resolve("a.cl", &out, &e);
    /* A missing include names the file, the line and where it looked. */
    snprintf(path, sizeof path, "%s/d.cl", dir);
    write_text(path, "one\ntwo\n#include \"nothere.h\"\n");
    SptError e2 = {0};
    char *out2 = NULL;
    int rc2 = cl_source_resolve("kernels/d.cl", &out2, &e2);
    unsetenv("SPECTRACE_KERNEL_DIR");
    assert_int_equal(rc, SPT_EXIT_OK);
    const char *want = "#line 1 \"kernels/a.cl\"\n"
                       "x\n"
                       "#line 1 \"kernels/b.h\"\n"
                       "#line 1 \"kernels/c.h\"\n"
                       "C\n"
                       "#line 2 \"kernels/b.h\"\n"
                       "B\n"
                       "#line 3 \"kernels/a.cl\"\n"
                       "y\n"
                       "/* #include \"b.h\": already included */\n"
                       "z\n";
    assert_string_equal(out, want);
    free(out);
    assert_int_equal(rc2, SPT_EXIT_DEVICE);
    assert_null(out2);
    assert_non_null(strstr(e2.msg, "kernels/d.cl:3"));
    assert_non_null(strstr(e2.msg, "kernels/nothere.h"));
    assert_non_null(strstr(e2.msg, "SPECTRACE_KERNEL_DIR"));
}

TEST(test_embedded_sources_resolve)
{
    char *out = NULL;
    SptError e = {0};
    assert_int_equal(cl_source_resolve("kernels/util/layout_check.cl", &out, &e), SPT_EXIT_OK);
    const char *head = "#line 1 \"kernels/util/layout_check.cl\"\n";
    assert_int_equal(strncmp(out, head, strlen(head)), 0);
    assert_non_null(strstr(out, "#line 1 \"kernels/util/portable.h\"\n"));
    assert_non_null(strstr(out, "#line 1 \"kernels/util/layout_list.h\"\n"));
    /* portable.h is included by both; it is spliced once. */
    char *first = strstr(out, "#define SPT_PORTABLE_H");
    assert_non_null(first);
    assert_null(strstr(first + 1, "#define SPT_PORTABLE_H"));
    free(out);
}

TEST(test_build_error_reports_device_and_log)
{
    char dir[512], path[600];
    new_folder(dir, sizeof dir, "kbroken");
    snprintf(path, sizeof path, "%s/broken.cl", dir);
    write_text(path, "#include \"helper.h\"\n"
                     "__kernel void k_broken(__global int *o) { o[0] = helper(); }\n");
    snprintf(path, sizeof path, "%s/helper.h", dir);
    write_text(path, "/* helper */\n"
                     "int helper(void)\n"
                     "{ return undeclared_thing_42; }\n");
    setenv("SPECTRACE_KERNEL_DIR", dir, 1);
    cl_program prog = NULL;
    SptError e = {0};
    int misses = g_dev.cache_misses;
    int rc = cl_program_build(&g_dev, "kernels/broken.cl", "-DSPT_TEST=1", &prog, &e);
    unsetenv("SPECTRACE_KERNEL_DIR");
    assert_int_equal(rc, SPT_EXIT_DEVICE);
    assert_null(prog);
    assert_int_equal(g_dev.cache_misses, misses + 1);
    assert_null(strchr(e.msg, '\n'));
    assert_non_null(strstr(e.msg, "kernels/broken.cl"));
    assert_non_null(strstr(e.msg, g_dev.info.name));
    assert_non_null(strstr(e.msg, g_dev.info.driver_version));
    assert_non_null(strstr(e.msg, "CL_BUILD_PROGRAM_FAILURE"));
    assert_non_null(g_dev.build_log);
    /* The log names the real file and line, thanks to the #line markers. */
    if (!strstr(g_dev.build_log, "kernels/helper.h:3") ||
        !strstr(g_dev.build_log, "undeclared_thing_42"))
        fail_msg("build log lacks kernels/helper.h:3 / the identifier:\n%s", g_dev.build_log);
    /* A failed build leaves nothing in the cache. */
    assert_int_equal(access(g_dev.last_cache_path, F_OK), -1);
}

/* ---- cache and a trivial kernel --------------------------------------------- */

static const char square_src[] =
    "#include \"util/portable.h\"\n"
    "__kernel void k_square(__global uint *o)\n"
    "{\n"
    "    uint i = get_global_id(0);\n"
    "    o[i] = i * i + SPT_ADD;\n"
    "}\n";

/* Runs k_square over 64 items and checks o[i] = i*i + 7 (SPT_ADD = 7). */
static void run_square(cl_program prog)
{
    enum { N = 64 };
    cl_int err = CL_SUCCESS;
    cl_kernel k = clCreateKernel(prog, "k_square", &err);
    assert_int_equal(err, CL_SUCCESS);
    cl_mem buf = NULL;
    SptError e = {0};
    assert_int_equal(cl_buffer_create(&g_dev, "squares", CL_MEM_WRITE_ONLY, N * sizeof(cl_uint),
                                      NULL, &buf, &e),
                     SPT_EXIT_OK);
    assert_int_equal(clSetKernelArg(k, 0, sizeof buf, &buf), CL_SUCCESS);
    size_t global = N;
    cl_event ev = NULL;
    assert_int_equal(clEnqueueNDRangeKernel(g_dev.queue, k, 1, NULL, &global, NULL, 0, NULL, &ev),
                     CL_SUCCESS);
    cl_uint out[N];
    assert_int_equal(
        clEnqueueReadBuffer(g_dev.queue, buf, CL_TRUE, 0, sizeof out, out, 0, NULL, NULL),
        CL_SUCCESS);
    for (cl_uint i = 0; i < N; i++)
        if (out[i] != i * i + 7)
            fail_msg("o[%u] = %u, expected %u", i, out[i], i * i + 7);
    /* The queue was opened for profiling: the event has timestamps. */
    cl_ulong t0 = 0, t1 = 0;
    assert_int_equal(clGetEventProfilingInfo(ev, CL_PROFILING_COMMAND_START, sizeof t0, &t0, NULL),
                     CL_SUCCESS);
    assert_int_equal(clGetEventProfilingInfo(ev, CL_PROFILING_COMMAND_END, sizeof t1, &t1, NULL),
                     CL_SUCCESS);
    assert_true(t1 >= t0 && t0 > 0);
    clReleaseEvent(ev);
    clReleaseMemObject(buf);
    clReleaseKernel(k);
}

/* Builds square_src; checks whether it came from the cache. */
static void build_square(int want_hit)
{
    cl_program prog = NULL;
    SptError e = {0};
    int hits = g_dev.cache_hits, misses = g_dev.cache_misses;
    int rc = cl_program_build_text(&g_dev, "kernels/test_square.cl", square_src, "-DSPT_ADD=7u",
                                   &prog, &e);
    if (rc)
        fail_msg("%s\n%s", e.msg, g_dev.build_log ? g_dev.build_log : "");
    assert_int_equal(g_dev.last_from_cache, want_hit);
    assert_int_equal(g_dev.cache_hits, hits + want_hit);
    assert_int_equal(g_dev.cache_misses, misses + !want_hit);
    assert_true(file_size(g_dev.last_cache_path) > 0);
    run_square(prog);
    clReleaseProgram(prog);
}

TEST(test_cache_hit_and_corrupt_entries_rebuilt)
{
    build_square(0); /* compiled, stored */
    char path[sizeof g_dev.last_cache_path];
    snprintf(path, sizeof path, "%s", g_dev.last_cache_path);
    char dir[512];
    snprintf(dir, sizeof dir, "%s/cache/", g_tmp);
    assert_int_equal(strncmp(path, dir, strlen(dir)), 0);
    build_square(1); /* loaded from the cache, and it runs */
    assert_int_equal(g_dev.cache_rejected, 0);

    /* Flip bytes in the middle of the entry: rejected, rebuilt, rewritten. */
    long size = file_size(path);
    int fd = open(path, O_WRONLY);
    assert_true(fd >= 0);
    assert_int_equal(pwrite(fd, "garbage!", 8, size / 2), 8);
    close(fd);
    build_square(0);
    assert_int_equal(g_dev.cache_rejected, 1);
    /* (The rewritten entry may differ in size: PoCL puts the kernels it has
     * compiled meanwhile into its binaries.) */
    build_square(1);

    /* A truncated entry likewise. */
    assert_int_equal(truncate(path, 12), 0);
    build_square(0);
    assert_int_equal(g_dev.cache_rejected, 2);
    build_square(1);

    /* Other options are another entry. */
    cl_program prog = NULL;
    SptError e = {0};
    assert_int_equal(cl_program_build_text(&g_dev, "kernels/test_square.cl", square_src,
                                           "-DSPT_ADD=8u", &prog, &e),
                     SPT_EXIT_OK);
    assert_int_equal(g_dev.last_from_cache, 0);
    assert_string_not_equal(g_dev.last_cache_path, path);
    clReleaseProgram(prog);
}

TEST(test_unwritable_cache_warns_once)
{
    /* A cache folder below a regular file cannot be created, even as root. */
    char file[512], cache[600], log[600];
    snprintf(file, sizeof file, "%s/plainfile", g_tmp);
    write_text(file, "x");
    snprintf(cache, sizeof cache, "%s/sub", file);
    snprintf(log, sizeof log, "%s/stderr.txt", g_tmp);
    char old[512];
    snprintf(old, sizeof old, "%s", getenv("SPECTRACE_CACHE_DIR"));
    setenv("SPECTRACE_CACHE_DIR", cache, 1);
    fflush(stderr);
    int saved = dup(2);
    int fd = open(log, O_WRONLY | O_CREAT | O_TRUNC, 0644);
    dup2(fd, 2);
    close(fd);
    int rc[2];
    for (int i = 0; i < 2; i++) {
        cl_program prog = NULL;
        SptError e = {0};
        rc[i] = cl_program_build_text(&g_dev, "kernels/test_square.cl", square_src,
                                      "-DSPT_ADD=7u", &prog, &e);
        if (prog)
            clReleaseProgram(prog);
    }
    fflush(stderr);
    dup2(saved, 2);
    close(saved);
    setenv("SPECTRACE_CACHE_DIR", old, 1);
    assert_int_equal(rc[0], SPT_EXIT_OK);
    assert_int_equal(rc[1], SPT_EXIT_OK);
    char text[4096] = {0};
    FILE *f = fopen(log, "rb");
    assert_non_null(f);
    size_t n = fread(text, 1, sizeof text - 1, f);
    text[n] = 0;
    fclose(f);
    assert_int_equal(count_lines(text), 1);
    assert_int_equal(strncmp(text, "warning: ", 9), 0);
    assert_non_null(strstr(text, cache));
}

TEST(test_cache_dir_choice)
{
    char old[512], buf[600];
    snprintf(old, sizeof old, "%s", getenv("SPECTRACE_CACHE_DIR"));
    const char *xdg = getenv("XDG_CACHE_HOME");
    char old_xdg[512] = {0}, old_home[512] = {0};
    if (xdg)
        snprintf(old_xdg, sizeof old_xdg, "%s", xdg);
    snprintf(old_home, sizeof old_home, "%s", getenv("HOME") ? getenv("HOME") : "");
    setenv("SPECTRACE_CACHE_DIR", "/c/d", 1);
    setenv("XDG_CACHE_HOME", "/x", 1);
    setenv("HOME", "/h", 1);
    char a[600], b[600], c[600], d[600];
    snprintf(a, sizeof a, "%s", cl_cache_dir(buf, sizeof buf));
    unsetenv("SPECTRACE_CACHE_DIR");
    snprintf(b, sizeof b, "%s", cl_cache_dir(buf, sizeof buf));
    unsetenv("XDG_CACHE_HOME");
    snprintf(c, sizeof c, "%s", cl_cache_dir(buf, sizeof buf));
    setenv("SPECTRACE_CACHE_DIR", "off", 1);
    snprintf(d, sizeof d, "%s", cl_cache_dir(buf, sizeof buf));
    setenv("SPECTRACE_CACHE_DIR", old, 1);
    setenv("HOME", old_home, 1);
    if (old_xdg[0])
        setenv("XDG_CACHE_HOME", old_xdg, 1);
    assert_string_equal(a, "/c/d");
    assert_string_equal(b, "/x/spectrace");
    assert_string_equal(c, "/h/.cache/spectrace");
    assert_string_equal(d, "");
}

TEST(test_fnv1a_reference_values)
{
    /* Published FNV-1a 64-bit test vectors. */
    assert_true(cl_fnv1a(SPT_FNV1A_INIT, "", 0) == 0xcbf29ce484222325ull);
    assert_true(cl_fnv1a(SPT_FNV1A_INIT, "a", 1) == 0xaf63dc4c8601ec8cull);
    assert_true(cl_fnv1a(SPT_FNV1A_INIT, "foobar", 6) == 0x85944171f73967e8ull);
}

/* ---- memory checks, errors, layout ----------------------------------------- */

TEST(test_memory_limits_checked_before_allocating)
{
    ClDeviceInfo info = {0};
    snprintf(info.name, sizeof info.name, "tiny");
    info.max_alloc = 1000;
    info.global_mem = 2500;
    SptError e = {0};
    ClAlloc ok[3] = {{"a", 1000}, {"b", 1000}, {"c", 500}}; /* both limits exactly */
    assert_int_equal(cl_device_check_memory(&info, ok, 3, &e), SPT_EXIT_OK);
    ClAlloc big[2] = {{"a", 10}, {"triangles", 1001}};
    assert_int_equal(cl_device_check_memory(&info, big, 2, &e), SPT_EXIT_DEVICE);
    assert_non_null(strstr(e.msg, "'triangles'"));
    assert_non_null(strstr(e.msg, "1001 bytes"));
    assert_non_null(strstr(e.msg, "1000 bytes"));
    assert_non_null(strstr(e.msg, "CL_DEVICE_MAX_MEM_ALLOC_SIZE"));
    ClAlloc many[3] = {{"a", 900}, {"b", 900}, {"c", 900}};
    assert_int_equal(cl_device_check_memory(&info, many, 3, &e), SPT_EXIT_DEVICE);
    assert_non_null(strstr(e.msg, "2700 bytes"));
    assert_non_null(strstr(e.msg, "2500 bytes"));
    assert_non_null(strstr(e.msg, "CL_DEVICE_GLOBAL_MEM_SIZE"));
    /* On the real device: refused before OpenCL is asked. */
    cl_mem m = NULL;
    size_t huge = (size_t)g_dev.info.max_alloc + 1;
    assert_int_equal(cl_buffer_create(&g_dev, "film", CL_MEM_READ_WRITE, huge, NULL, &m, &e),
                     SPT_EXIT_DEVICE);
    assert_null(m);
    assert_non_null(strstr(e.msg, "'film'"));
}

/* Fails through SPT_CL_CHECK on purpose. */
static int release_null_buffer(SptError *e)
{
    SPT_CL_CHECK(e, clReleaseMemObject(NULL));
    return SPT_EXIT_OK;
}

TEST(test_error_names_and_check_macro)
{
    assert_string_equal(cl_error_name(CL_SUCCESS), "CL_SUCCESS");
    assert_string_equal(cl_error_name(CL_BUILD_PROGRAM_FAILURE), "CL_BUILD_PROGRAM_FAILURE");
    assert_string_equal(cl_error_name(CL_INVALID_KERNEL_ARGS), "CL_INVALID_KERNEL_ARGS");
    assert_string_equal(cl_error_name(CL_INVALID_DEVICE_PARTITION_COUNT),
                        "CL_INVALID_DEVICE_PARTITION_COUNT");
    assert_string_equal(cl_error_name(12345), "unknown OpenCL error");
    /* Every OpenCL 1.2 code (0..-19, -30..-68) has its own name. */
    const char *seen[128];
    int n = 0;
    for (int c = 0; c >= -68; c--) {
        if (c < -19 && c > -30)
            continue;
        const char *name = cl_error_name(c);
        if (!strcmp(name, "unknown OpenCL error"))
            fail_msg("no name for OpenCL error %d", c);
        for (int k = 0; k < n; k++)
            assert_string_not_equal(seen[k], name);
        seen[n++] = name;
    }
    SptError e = {0};
    assert_int_equal(release_null_buffer(&e), SPT_EXIT_DEVICE);
    assert_non_null(strstr(e.msg, "clReleaseMemObject failed at tests/test_cl.c:"));
    assert_non_null(strstr(e.msg, "CL_INVALID_MEM_OBJECT (-38)"));
    assert_int_equal(cl_check(CL_INVALID_BUFFER_SIZE,
                              "(m = clCreateBuffer(c, 0, 0, 0, &err), err)", "x.c", 7, &e),
                     SPT_EXIT_DEVICE);
    assert_string_equal(e.msg,
                        "OpenCL: clCreateBuffer failed at x.c:7: CL_INVALID_BUFFER_SIZE (-61)");
}

TEST(test_layout_matches_host)
{
    /* The host's values, straight from the list. */
    static const struct {
        const char *name;
        unsigned value;
    } host[] = {
#define HOST_SIZE(T) {"sizeof(" #T ")", (unsigned)sizeof(T)},
#define HOST_FIELD(T, f) {"offsetof(" #T ", " #f ")", (unsigned)offsetof(T, f)},
        SPT_LAYOUT_STRUCTS(HOST_SIZE) SPT_LAYOUT_FIELDS(HOST_FIELD)
#undef HOST_SIZE
#undef HOST_FIELD
    };
    int n = (int)(sizeof host / sizeof host[0]);
    assert_int_equal(cl_layout_count(), n);
    /* The probe by hand: 8 four-byte words, v at 4, count at 16, pad at 24. */
    assert_int_equal(sizeof(LayoutProbe), 32);
    assert_int_equal(offsetof(LayoutProbe, count), 16);
    unsigned dev[256];
    assert_true(n <= 256);
    SptError e = {0};
    int rc = cl_layout_query(&g_dev, dev, n, &e);
    if (rc)
        fail_msg("%s\n%s", e.msg, g_dev.build_log ? g_dev.build_log : "");
    int bad = 0;
    for (int i = 0; i < n; i++)
        if (dev[i] != host[i].value) {
            print_error("%s: device %u, host %u\n", host[i].name, dev[i], host[i].value);
            bad++;
        }
    assert_int_equal(bad, 0);
    /* The same comparison inside the library (second build: from the cache). */
    assert_int_equal(cl_layout_check(&g_dev, &e), SPT_EXIT_OK);
    assert_int_equal(g_dev.last_from_cache, 1);
}

/* Implementation names: classified from the platform's name, vendor and ICD
 * suffix; "intel" selects Intel's runtime, not PoCL's device on an Intel CPU
 * (whose name contains "Intel") listed before it. No OpenCL call. */
TEST(test_impl_names_and_selection)
{
    static const char *cases[][4] = {
        {"Portable Computing Language", "The pocl project", "POCL", "pocl"},
        {"Intel(R) OpenCL", "Intel(R) Corporation", "INTEL", "intel"},
        {"Intel(R) OpenCL Graphics", "Intel(R) Corporation", "INTEL", "intel"},
        {"rusticl", "Mesa/X.org", "MESA", "rusticl"},
        {"Clover", "Mesa", "MESA", "clover"},
        {"NVIDIA CUDA", "NVIDIA Corporation", "NV", "nvidia"},
        {"AMD Accelerated Parallel Processing", "Advanced Micro Devices, Inc.", "AMD", "amd"},
        {"Oclgrind", "University of Bristol", "oclg", "oclgrind"},
        {"Foo CL", "Foo Inc.", "", "foo"},
    };
    char s[32];
    for (size_t k = 0; k < sizeof cases / sizeof cases[0]; k++) {
        cl_impl_name(cases[k][0], cases[k][1], cases[k][2], s, sizeof s);
        assert_string_equal(s, cases[k][3]);
    }
    ClDeviceInfo d[2];
    made_up_device(&d[0], 0, CL_DEVICE_TYPE_CPU, "pthread-skylake-avx512-Intel(R) Xeon(R) Gold 6230",
                   "GenuineIntel", "Portable Computing Language", "pocl");
    made_up_device(&d[1], 1, CL_DEVICE_TYPE_CPU, "Intel(R) Xeon(R) Gold 6230",
                   "Intel(R) Corporation", "Intel(R) OpenCL", "intel");
    ClDeviceList list = {d, 2};
    int out[2], n = 0;
    SptError e = {0};
    assert_int_equal(cl_device_select(&list, "intel", out, &n, &e), 0);
    assert_int_equal(n, 1);
    assert_int_equal(out[0], 1);
    assert_int_equal(cl_device_select(&list, "POCL", out, &n, &e), 0);
    assert_int_equal(n, 1);
    assert_int_equal(out[0], 0);
    assert_int_equal(cl_device_select(&list, "intel,pocl", out, &n, &e), 0);
    assert_int_equal(n, 2);
    assert_int_equal(out[0], 1);
    assert_int_equal(out[1], 0);
    /* Not an implementation's name: a part of a name, the first match. */
    assert_int_equal(cl_device_select(&list, "xeon", out, &n, &e), 0);
    assert_int_equal(out[0], 0);
    assert_int_equal(cl_device_select(&list, "rusticl", out, &n, &e), SPT_EXIT_DEVICE);
    assert_non_null(strstr(e.msg, "rusticl"));
}

/* `test_cl --child-select ...` is the child process of the selection tests. */
static int child_mode(int argc, char **argv)
{
    if (argc >= 2 && !strcmp(argv[1], "--child-select"))
        return child_select(argc - 2, argv + 2);
    return TEST_GO_ON;
}

TEST_MAIN_HOOK("cl", setup, teardown, child_mode)
