/* The OpenCL runtime (src/cl/cl_device.h). */
#include "cl/cl_device.h"

#include <ctype.h>
#include <errno.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "cl/embedded.h"
#include "shared/layout_list.h"

#define SPT_POCL_HINT                                                                  \
    "install an OpenCL driver; for the CPU: apt-get install pocl-opencl-icd "          \
    "ocl-icd-opencl-dev"

/* ---- error names ---------------------------------------------------------- */

static const struct {
    cl_int code;
    const char *name;
} cl_errors[] = {
    {0, "CL_SUCCESS"},
    {-1, "CL_DEVICE_NOT_FOUND"},
    {-2, "CL_DEVICE_NOT_AVAILABLE"},
    {-3, "CL_COMPILER_NOT_AVAILABLE"},
    {-4, "CL_MEM_OBJECT_ALLOCATION_FAILURE"},
    {-5, "CL_OUT_OF_RESOURCES"},
    {-6, "CL_OUT_OF_HOST_MEMORY"},
    {-7, "CL_PROFILING_INFO_NOT_AVAILABLE"},
    {-8, "CL_MEM_COPY_OVERLAP"},
    {-9, "CL_IMAGE_FORMAT_MISMATCH"},
    {-10, "CL_IMAGE_FORMAT_NOT_SUPPORTED"},
    {-11, "CL_BUILD_PROGRAM_FAILURE"},
    {-12, "CL_MAP_FAILURE"},
    {-13, "CL_MISALIGNED_SUB_BUFFER_OFFSET"},
    {-14, "CL_EXEC_STATUS_ERROR_FOR_EVENTS_IN_WAIT_LIST"},
    {-15, "CL_COMPILE_PROGRAM_FAILURE"},
    {-16, "CL_LINKER_NOT_AVAILABLE"},
    {-17, "CL_LINK_PROGRAM_FAILURE"},
    {-18, "CL_DEVICE_PARTITION_FAILED"},
    {-19, "CL_KERNEL_ARG_INFO_NOT_AVAILABLE"},
    {-30, "CL_INVALID_VALUE"},
    {-31, "CL_INVALID_DEVICE_TYPE"},
    {-32, "CL_INVALID_PLATFORM"},
    {-33, "CL_INVALID_DEVICE"},
    {-34, "CL_INVALID_CONTEXT"},
    {-35, "CL_INVALID_QUEUE_PROPERTIES"},
    {-36, "CL_INVALID_COMMAND_QUEUE"},
    {-37, "CL_INVALID_HOST_PTR"},
    {-38, "CL_INVALID_MEM_OBJECT"},
    {-39, "CL_INVALID_IMAGE_FORMAT_DESCRIPTOR"},
    {-40, "CL_INVALID_IMAGE_SIZE"},
    {-41, "CL_INVALID_SAMPLER"},
    {-42, "CL_INVALID_BINARY"},
    {-43, "CL_INVALID_BUILD_OPTIONS"},
    {-44, "CL_INVALID_PROGRAM"},
    {-45, "CL_INVALID_PROGRAM_EXECUTABLE"},
    {-46, "CL_INVALID_KERNEL_NAME"},
    {-47, "CL_INVALID_KERNEL_DEFINITION"},
    {-48, "CL_INVALID_KERNEL"},
    {-49, "CL_INVALID_ARG_INDEX"},
    {-50, "CL_INVALID_ARG_VALUE"},
    {-51, "CL_INVALID_ARG_SIZE"},
    {-52, "CL_INVALID_KERNEL_ARGS"},
    {-53, "CL_INVALID_WORK_DIMENSION"},
    {-54, "CL_INVALID_WORK_GROUP_SIZE"},
    {-55, "CL_INVALID_WORK_ITEM_SIZE"},
    {-56, "CL_INVALID_GLOBAL_OFFSET"},
    {-57, "CL_INVALID_EVENT_WAIT_LIST"},
    {-58, "CL_INVALID_EVENT"},
    {-59, "CL_INVALID_OPERATION"},
    {-60, "CL_INVALID_GL_OBJECT"},
    {-61, "CL_INVALID_BUFFER_SIZE"},
    {-62, "CL_INVALID_MIP_LEVEL"},
    {-63, "CL_INVALID_GLOBAL_WORK_SIZE"},
    {-64, "CL_INVALID_PROPERTY"},
    {-65, "CL_INVALID_IMAGE_DESCRIPTOR"},
    {-66, "CL_INVALID_COMPILER_OPTIONS"},
    {-67, "CL_INVALID_LINKER_OPTIONS"},
    {-68, "CL_INVALID_DEVICE_PARTITION_COUNT"},
    /* OpenCL 2.x/3.0 and extensions a driver may still return. */
    {-69, "CL_INVALID_PIPE_SIZE"},
    {-70, "CL_INVALID_DEVICE_QUEUE"},
    {-71, "CL_INVALID_SPEC_ID"},
    {-72, "CL_MAX_SIZE_RESTRICTION_EXCEEDED"},
    {-1000, "CL_INVALID_GL_SHAREGROUP_REFERENCE_KHR"},
    {-1001, "CL_PLATFORM_NOT_FOUND_KHR"},
    {-1057, "CL_DEVICE_PARTITION_FAILED_EXT"},
    {-1058, "CL_INVALID_PARTITION_COUNT_EXT"},
    {-1059, "CL_INVALID_PARTITION_NAME_EXT"},
};

const char *cl_error_name(cl_int err)
{
    for (size_t i = 0; i < sizeof cl_errors / sizeof cl_errors[0]; i++)
        if (cl_errors[i].code == err)
            return cl_errors[i].name;
    return "unknown OpenCL error";
}

int cl_check(cl_int err, const char *call, const char *file, int line, SptError *e)
{
    if (err == CL_SUCCESS)
        return 0;
    /* Name the first OpenCL function in the expression: "clFoo(" after a
     * non-identifier character. */
    const char *name = call;
    size_t len = strcspn(call, "(");
    for (const char *p = call; *p; p++) {
        if (p[0] == 'c' && p[1] == 'l' && isupper((unsigned char)p[2]) &&
            (p == call || !(isalnum((unsigned char)p[-1]) || p[-1] == '_'))) {
            name = p;
            len = 0;
            while (isalnum((unsigned char)name[len]) || name[len] == '_')
                len++;
            break;
        }
    }
    return spt_fail(e, SPT_EXIT_DEVICE, "OpenCL: %.*s failed at %s:%d: %s (%d)", (int)len,
                    name, file, line, cl_error_name(err), (int)err);
}

/* Puts prefix in front of e's message (truncating at the end); e may be NULL. */
static void prefix_error(SptError *e, const char *prefix)
{
    if (!e)
        return;
    char tmp[sizeof e->msg];
    size_t pl = strlen(prefix), ml = strlen(e->msg);
    if (pl > sizeof tmp - 1)
        pl = sizeof tmp - 1;
    if (ml > sizeof tmp - 1 - pl)
        ml = sizeof tmp - 1 - pl;
    memcpy(tmp, prefix, pl);
    memcpy(tmp + pl, e->msg, ml);
    tmp[pl + ml] = 0;
    memcpy(e->msg, tmp, sizeof tmp);
}

/* ---- listing -------------------------------------------------------------- */

/* Reads a string device/platform property into buf; "" on failure. */
static void get_dev_str(cl_device_id dev, cl_device_info what, char *buf, size_t n)
{
    buf[0] = 0;
    if (clGetDeviceInfo(dev, what, n, buf, NULL) != CL_SUCCESS)
        buf[0] = 0;
    buf[n - 1] = 0;
}

static void get_plat_str(cl_platform_id p, cl_platform_info what, char *buf, size_t n)
{
    buf[0] = 0;
    if (clGetPlatformInfo(p, what, n, buf, NULL) != CL_SUCCESS)
        buf[0] = 0;
    buf[n - 1] = 0;
}

/* Fills the properties of one device; the OpenCL calls that must succeed are
 * checked. */
static int describe_device(ClDeviceInfo *d, cl_device_id dev, SptError *e)
{
    d->id = dev;
    get_dev_str(dev, CL_DEVICE_NAME, d->name, sizeof d->name);
    get_dev_str(dev, CL_DEVICE_VENDOR, d->vendor, sizeof d->vendor);
    get_dev_str(dev, CL_DRIVER_VERSION, d->driver_version, sizeof d->driver_version);
    get_dev_str(dev, CL_DEVICE_VERSION, d->version, sizeof d->version);
    get_dev_str(dev, CL_DEVICE_OPENCL_C_VERSION, d->opencl_c_version,
                sizeof d->opencl_c_version);
    SPT_CL_CHECK(e, clGetDeviceInfo(dev, CL_DEVICE_TYPE, sizeof d->type, &d->type, NULL));
    SPT_CL_CHECK(e, clGetDeviceInfo(dev, CL_DEVICE_MAX_COMPUTE_UNITS, sizeof d->compute_units,
                                    &d->compute_units, NULL));
    SPT_CL_CHECK(e, clGetDeviceInfo(dev, CL_DEVICE_GLOBAL_MEM_SIZE, sizeof d->global_mem,
                                    &d->global_mem, NULL));
    SPT_CL_CHECK(e, clGetDeviceInfo(dev, CL_DEVICE_MAX_MEM_ALLOC_SIZE, sizeof d->max_alloc,
                                    &d->max_alloc, NULL));
    SPT_CL_CHECK(e, clGetDeviceInfo(dev, CL_DEVICE_MAX_WORK_GROUP_SIZE,
                                    sizeof d->max_work_group_size, &d->max_work_group_size,
                                    NULL));
    cl_device_fp_config fp = 0;
    if (clGetDeviceInfo(dev, CL_DEVICE_DOUBLE_FP_CONFIG, sizeof fp, &fp, NULL) != CL_SUCCESS)
        fp = 0;
    size_t ext_len = 0;
    int khr_fp64 = 0;
    if (clGetDeviceInfo(dev, CL_DEVICE_EXTENSIONS, 0, NULL, &ext_len) == CL_SUCCESS &&
        ext_len > 0) {
        char *ext = spt_malloc(ext_len + 1);
        if (clGetDeviceInfo(dev, CL_DEVICE_EXTENSIONS, ext_len, ext, NULL) == CL_SUCCESS) {
            ext[ext_len] = 0;
            khr_fp64 = strstr(ext, "cl_khr_fp64") != NULL;
        }
        free(ext);
    }
    d->fp64 = fp != 0 || khr_fp64;
    return SPT_EXIT_OK;
}

void cl_runtime_defaults(void)
{
    /* Intel's CPU runtime (2026.2) vectorises kernels across work-items wrongly
     * for ours: lanes of bsdf_sample took other lanes' lobes (tests/test_bsdf.c's
     * device check) and k_connect crashed in a freshly built program. Its own
     * switch turns that vectoriser off; a value the user set stays. Other
     * implementations ignore the variable. */
    setenv("CL_CONFIG_USE_VECTORIZER", "False", 0);
}

int cl_device_list(ClDeviceList *out, SptError *e)
{
    out->devices = NULL;
    out->count = 0;
    cl_runtime_defaults();
    cl_uint nplat = 0;
    cl_int err = clGetPlatformIDs(0, NULL, &nplat);
    if (err == -1001 /* CL_PLATFORM_NOT_FOUND_KHR */ || (err == CL_SUCCESS && nplat == 0))
        return spt_fail(e, SPT_EXIT_DEVICE, "no OpenCL platform found; " SPT_POCL_HINT);
    SPT_CL_CHECK(e, err);
    cl_platform_id *plats = spt_calloc(nplat, sizeof *plats);
    int rc = SPT_EXIT_OK;
    SPT_CL_CHECK_GOTO(e, clGetPlatformIDs(nplat, plats, NULL), rc, done);
    for (cl_uint p = 0; p < nplat && !rc; p++) {
        cl_uint ndev = 0;
        err = clGetDeviceIDs(plats[p], CL_DEVICE_TYPE_ALL, 0, NULL, &ndev);
        if (err == CL_DEVICE_NOT_FOUND)
            continue; /* a platform without devices is not an error */
        SPT_CL_CHECK_GOTO(e, err, rc, done);
        if (ndev == 0)
            continue;
        cl_device_id *ids = spt_calloc(ndev, sizeof *ids);
        out->devices = spt_realloc(out->devices, (out->count + ndev) * sizeof *out->devices);
        SPT_CL_CHECK_GOTO(e, clGetDeviceIDs(plats[p], CL_DEVICE_TYPE_ALL, ndev, ids, NULL), rc,
                          next);
        for (cl_uint i = 0; i < ndev && !rc; i++) {
            ClDeviceInfo *d = &out->devices[out->count];
            memset(d, 0, sizeof *d);
            d->index = out->count;
            d->platform_index = (int)p;
            d->platform = plats[p];
            get_plat_str(plats[p], CL_PLATFORM_NAME, d->platform_name, sizeof d->platform_name);
            get_plat_str(plats[p], CL_PLATFORM_VERSION, d->platform_version,
                         sizeof d->platform_version);
            char vendor[256], suffix[64];
            get_plat_str(plats[p], CL_PLATFORM_VENDOR, vendor, sizeof vendor);
            get_plat_str(plats[p], 0x0920 /* CL_PLATFORM_ICD_SUFFIX_KHR */, suffix, sizeof suffix);
            cl_impl_name(d->platform_name, vendor, suffix, d->impl, sizeof d->impl);
            rc = describe_device(d, ids[i], e);
            if (!rc)
                out->count++;
        }
    next:
        free(ids);
    }
    if (rc)
        goto done;
    if (out->count == 0)
        rc = spt_fail(e, SPT_EXIT_DEVICE,
                      "%u OpenCL platform(s) found but no device; " SPT_POCL_HINT, nplat);
done:
    free(plats);
    if (rc)
        cl_device_list_free(out);
    return rc;
}

void cl_device_list_free(ClDeviceList *list)
{
    free(list->devices);
    list->devices = NULL;
    list->count = 0;
}

const char *cl_device_type_name(cl_device_type type)
{
    if (type & CL_DEVICE_TYPE_GPU)
        return "GPU";
    if (type & CL_DEVICE_TYPE_CPU)
        return "CPU";
    if (type & CL_DEVICE_TYPE_ACCELERATOR)
        return "accelerator";
    if (type & CL_DEVICE_TYPE_CUSTOM)
        return "custom";
    return "default";
}

/* ---- selection ------------------------------------------------------------ */

/* Case-insensitive substring test. */
static int contains_nocase(const char *hay, const char *needle)
{
    size_t n = strlen(needle);
    if (n == 0)
        return 0;
    for (; *hay; hay++)
        if (strncasecmp(hay, needle, n) == 0)
            return 1;
    return 0;
}

/* Appends "; available: [0] name (type), [1] ..." to msg (size cap). */
static void append_device_list(char *msg, size_t cap, const ClDeviceList *all)
{
    if (!msg)
        return;
    size_t len = strlen(msg);
    len += (size_t)snprintf(msg + len, len < cap ? cap - len : 0, "; available devices:");
    for (int i = 0; i < all->count && len < cap; i++)
        len += (size_t)snprintf(msg + len, cap - len, "%s [%d] %s (%s)", i ? "," : "", i,
                                all->devices[i].name,
                                cl_device_type_name(all->devices[i].type));
}

/* The default device: first GPU, else first CPU, else device 0. */
static int default_device(const ClDeviceList *all)
{
    for (int i = 0; i < all->count; i++)
        if (all->devices[i].type & CL_DEVICE_TYPE_GPU)
            return i;
    for (int i = 0; i < all->count; i++)
        if (all->devices[i].type & CL_DEVICE_TYPE_CPU)
            return i;
    return 0;
}

void cl_impl_name(const char *platform_name, const char *platform_vendor, const char *icd_suffix,
                  char *out, size_t n)
{
    static const struct {
        const char *name, *part; /* part of the platform name, vendor or ICD suffix */
    } known[] = {
        {"pocl", "Portable Computing Language"}, {"pocl", "POCL"},
        {"rusticl", "rusticl"},                  {"clover", "Clover"},
        {"oclgrind", "Oclgrind"},                {"nvidia", "NVIDIA"},
        {"amd", "AMD Accelerated Parallel Processing"}, {"amd", "Advanced Micro Devices"},
        {"intel", "Intel"},
    };
    for (size_t k = 0; k < sizeof known / sizeof known[0]; k++)
        if (contains_nocase(platform_name, known[k].part) ||
            contains_nocase(platform_vendor, known[k].part) ||
            (icd_suffix && *icd_suffix && !strcasecmp(icd_suffix, known[k].part))) {
            snprintf(out, n, "%s", known[k].name);
            return;
        }
    size_t i = 0;
    for (; platform_name[i] && !isspace((unsigned char)platform_name[i]) && i + 1 < n; i++)
        out[i] = (char)tolower((unsigned char)platform_name[i]);
    out[i] = 0;
}

/* Does the selection token name an implementation of one of the devices? */
static int token_is_impl(const ClDeviceList *all, const char *tok)
{
    for (int i = 0; i < all->count; i++)
        if (!strcasecmp(all->devices[i].impl, tok))
            return 1;
    return 0;
}

/* Does the selection token (trimmed, non-empty) match device d? */
static int token_matches(const ClDeviceInfo *d, const char *tok)
{
    if (!strcasecmp(tok, "gpu"))
        return (d->type & CL_DEVICE_TYPE_GPU) != 0;
    if (!strcasecmp(tok, "cpu"))
        return (d->type & CL_DEVICE_TYPE_CPU) != 0;
    if (!strcasecmp(tok, "accelerator"))
        return (d->type & CL_DEVICE_TYPE_ACCELERATOR) != 0;
    return contains_nocase(d->name, tok) || contains_nocase(d->vendor, tok) ||
           contains_nocase(d->platform_name, tok);
}

int cl_device_select(const ClDeviceList *all, const char *selection, int *out, int *count,
                     SptError *e)
{
    *count = 0;
    const char *origin = "device selection";
    if (!selection || !*selection) {
        selection = getenv("SPECTRACE_DEVICE");
        origin = "SPECTRACE_DEVICE";
    }
    if (all->count == 0)
        return spt_fail(e, SPT_EXIT_DEVICE, "no OpenCL device found; " SPT_POCL_HINT);
    if (!selection || !*selection) {
        out[0] = default_device(all);
        *count = 1;
        return SPT_EXIT_OK;
    }
    char *copy = spt_strdup(selection);
    int rc = SPT_EXIT_OK;
    char *save = NULL;
    for (char *tok = strtok_r(copy, ",", &save); tok && rc == SPT_EXIT_OK;
         tok = strtok_r(NULL, ",", &save)) {
        while (isspace((unsigned char)*tok))
            tok++;
        size_t tl = strlen(tok);
        while (tl > 0 && isspace((unsigned char)tok[tl - 1]))
            tok[--tl] = 0;
        if (!*tok)
            continue;
        int chosen[2] = {-1, 0}; /* device, 1 when it is already selected */
        if (!strcasecmp(tok, "all")) {
            for (int i = 0; i < all->count; i++) {
                int dup = 0;
                for (int k = 0; k < *count; k++)
                    dup |= out[k] == i;
                if (!dup)
                    out[(*count)++] = i;
            }
            continue;
        }
        char *end = NULL;
        long idx = strtol(tok, &end, 10);
        if (end != tok && *end == 0) {
            if (idx < 0 || idx >= all->count) {
                rc = spt_fail(e, SPT_EXIT_DEVICE,
                              "%s '%s': device index %ld is out of range (0..%d)", origin,
                              selection, idx, all->count - 1);
                append_device_list(e ? e->msg : NULL, e ? sizeof e->msg : 0, all);
                break;
            }
            chosen[0] = (int)idx;
        } else {
            int any = 0, by_impl = token_is_impl(all, tok);
            for (int i = 0; i < all->count && chosen[0] < 0; i++) {
                if (by_impl ? strcasecmp(all->devices[i].impl, tok) != 0
                            : !token_matches(&all->devices[i], tok))
                    continue;
                any = 1;
                int dup = 0;
                for (int k = 0; k < *count; k++)
                    dup |= out[k] == i;
                if (!dup)
                    chosen[0] = i;
            }
            if (!any) {
                rc = spt_fail(e, SPT_EXIT_DEVICE, "%s '%s': no device matches '%s'", origin,
                              selection, tok);
                append_device_list(e ? e->msg : NULL, e ? sizeof e->msg : 0, all);
                break;
            }
            if (chosen[0] < 0)
                continue; /* every match is already selected */
        }
        for (int k = 0; k < *count; k++)
            chosen[1] |= out[k] == chosen[0];
        if (!chosen[1])
            out[(*count)++] = chosen[0];
    }
    free(copy);
    if (rc == SPT_EXIT_OK && *count == 0)
        rc = spt_fail(e, SPT_EXIT_DEVICE, "%s '%s' selects no device", origin, selection);
    if (rc)
        *count = 0;
    return rc;
}

/* ---- context and queue ---------------------------------------------------- */

int cl_device_open(ClDevice *d, const ClDeviceInfo *info, int profiling, SptError *e)
{
    memset(d, 0, sizeof *d);
    d->info = *info;
    d->profiling = profiling != 0;
    cl_context_properties props[] = {CL_CONTEXT_PLATFORM, (cl_context_properties)info->platform,
                                     0};
    cl_int err = CL_SUCCESS;
    int rc = SPT_EXIT_OK;
    SPT_CL_CHECK_GOTO(e, (d->context = clCreateContext(props, 1, &info->id, NULL, NULL, &err),
                          err),
                      rc, fail);
    cl_command_queue_properties qp = profiling ? CL_QUEUE_PROFILING_ENABLE : 0;
    SPT_CL_CHECK_GOTO(e, (d->queue = clCreateCommandQueue(d->context, info->id, qp, &err), err),
                      rc, fail);
    return SPT_EXIT_OK;
fail:
    /* Name the device: the call alone does not say which one failed. */
    char prefix[300];
    snprintf(prefix, sizeof prefix, "device [%d] %.256s: ", info->index, info->name);
    prefix_error(e, prefix);
    cl_device_close(d);
    return rc;
}

int cl_devices_open(const char *selection, int profiling, ClDevice **out, int *count,
                    SptError *e)
{
    *out = NULL;
    *count = 0;
    ClDeviceList list;
    int rc = cl_device_list(&list, e);
    if (rc)
        return rc;
    int *sel = spt_calloc((size_t)list.count, sizeof *sel);
    int n = 0;
    rc = cl_device_select(&list, selection, sel, &n, e);
    ClDevice *devs = rc ? NULL : spt_calloc((size_t)n, sizeof *devs);
    for (int k = 0; k < n && !rc; k++) {
        rc = cl_device_open(&devs[k], &list.devices[sel[k]], profiling, e);
        if (rc)
            cl_devices_close(devs, k);
        else
            *count = k + 1;
    }
    if (!rc)
        *out = devs;
    else
        *count = 0;
    free(sel);
    cl_device_list_free(&list);
    return rc;
}

void cl_devices_close(ClDevice *devs, int count)
{
    for (int k = 0; devs && k < count; k++)
        cl_device_close(&devs[k]);
    free(devs);
}

void cl_device_close(ClDevice *d)
{
    if (d->queue) {
        clFinish(d->queue);
        clReleaseCommandQueue(d->queue);
    }
    if (d->context)
        clReleaseContext(d->context);
    free(d->build_log);
    d->queue = NULL;
    d->context = NULL;
    d->build_log = NULL;
}

int cl_device_report(const ClDevice *d, const SptError *e)
{
    int code = spt_report(e);
    if (d && d->build_log && d->build_log[0]) {
        size_t n = strlen(d->build_log);
        fputs(d->build_log, stderr);
        if (d->build_log[n - 1] != '\n')
            fputc('\n', stderr);
    }
    return code;
}

/* ---- source resolution ---------------------------------------------------- */

/* A growing string. */
typedef struct Buf {
    char *s;
    size_t len, cap;
} Buf;

static void buf_add(Buf *b, const char *s, size_t n)
{
    if (b->len + n + 1 > b->cap) {
        b->cap = (b->len + n + 1) * 2;
        b->s = spt_realloc(b->s, b->cap);
    }
    memcpy(b->s + b->len, s, n);
    b->len += n;
    b->s[b->len] = 0;
}

static void buf_printf(Buf *b, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void buf_printf(Buf *b, const char *fmt, ...)
{
    char tmp[1200];
    va_list ap;
    va_start(ap, fmt);
    int n = vsnprintf(tmp, sizeof tmp, fmt, ap);
    va_end(ap);
    if (n > (int)sizeof tmp - 1)
        n = (int)sizeof tmp - 1;
    buf_add(b, tmp, (size_t)n);
}

/* Reads a whole file; NULL when it cannot. *len gets its size. */
static char *read_file(const char *path, size_t *len)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    Buf b = {0};
    char chunk[65536];
    size_t n;
    while ((n = fread(chunk, 1, sizeof chunk, f)) > 0)
        buf_add(&b, chunk, n);
    int bad = ferror(f);
    fclose(f);
    if (bad) {
        free(b.s);
        return NULL;
    }
    if (!b.s)
        b.s = spt_calloc(1, 1);
    if (len)
        *len = b.len;
    return b.s;
}

/* The text of kernel file `path` ("kernels/x.h"), malloc'd: from
 * SPECTRACE_KERNEL_DIR when set, else embedded. NULL when missing. */
static char *load_kernel_file(const char *path)
{
    const char *dir = getenv("SPECTRACE_KERNEL_DIR");
    if (dir && *dir) {
        const char *rel = strncmp(path, "kernels/", 8) ? path : path + 8;
        char full[4096];
        snprintf(full, sizeof full, "%s/%s", dir, rel);
        return read_file(full, NULL);
    }
    for (int i = 0; i < spt_kernel_file_count; i++)
        if (!strcmp(spt_kernel_files[i].path, path))
            return spt_strdup(spt_kernel_files[i].text);
    return NULL;
}

/* Paths already spliced into the current program. */
typedef struct Seen {
    char **paths;
    int count;
} Seen;

static int seen_add(Seen *s, const char *path)
{
    for (int i = 0; i < s->count; i++)
        if (!strcmp(s->paths[i], path))
            return 0;
    s->paths = spt_realloc(s->paths, (s->count + 1) * sizeof *s->paths);
    s->paths[s->count++] = spt_strdup(path);
    return 1;
}

/* If `line` (length n) is `#include "name"`, copies name into out and returns 1. */
static int parse_include(const char *line, size_t n, char *out, size_t cap)
{
    const char *p = line, *end = line + n;
    while (p < end && (*p == ' ' || *p == '\t'))
        p++;
    if (p >= end || *p != '#')
        return 0;
    p++;
    while (p < end && (*p == ' ' || *p == '\t'))
        p++;
    if (end - p < 7 || strncmp(p, "include", 7))
        return 0;
    p += 7;
    while (p < end && (*p == ' ' || *p == '\t'))
        p++;
    if (p >= end || *p != '"')
        return 0;
    const char *q = memchr(p + 1, '"', (size_t)(end - p - 1));
    if (!q || (size_t)(q - p - 1) >= cap || q == p + 1)
        return 0;
    memcpy(out, p + 1, (size_t)(q - p - 1));
    out[q - p - 1] = 0;
    return 1;
}

/* The path of a kernel file as used in #line markers: "kernels/" + name unless
 * it has it already. */
static void kernel_path(const char *name, char *out, size_t cap)
{
    if (!strncmp(name, "kernels/", 8))
        snprintf(out, cap, "%s", name);
    else
        snprintf(out, cap, "kernels/%s", name);
}

/* Appends the resolved `text` of file `name` to b. */
static int resolve_into(Buf *b, const char *name, const char *text, Seen *seen, int depth,
                        SptError *e)
{
    if (depth > 64)
        return spt_fail(e, SPT_EXIT_DEVICE, "%s: kernel includes nest deeper than 64", name);
    buf_printf(b, "#line 1 \"%s\"\n", name);
    int lineno = 1;
    const char *p = text;
    while (*p) {
        const char *nl = strchr(p, '\n');
        size_t n = nl ? (size_t)(nl - p) : strlen(p);
        char inc[512];
        if (parse_include(p, n, inc, sizeof inc)) {
            char path[600];
            kernel_path(inc, path, sizeof path);
            if (seen_add(seen, path)) {
                char *sub = load_kernel_file(path);
                if (!sub) {
                    const char *dir = getenv("SPECTRACE_KERNEL_DIR");
                    return spt_fail(e, SPT_EXIT_DEVICE,
                                    "%s:%d: included kernel file '%s' not found (%s%s)", name,
                                    lineno, path,
                                    dir && *dir ? "looked in SPECTRACE_KERNEL_DIR=" :
                                                  "not among the embedded kernel sources",
                                    dir && *dir ? dir : "");
                }
                int rc = resolve_into(b, path, sub, seen, depth + 1, e);
                free(sub);
                if (rc)
                    return rc;
                buf_printf(b, "#line %d \"%s\"\n", lineno + 1, name);
            } else {
                buf_printf(b, "/* #include \"%s\": already included */\n", inc);
            }
        } else {
            buf_add(b, p, n);
            buf_add(b, "\n", 1);
        }
        lineno++;
        if (!nl)
            break;
        p = nl + 1;
    }
    return SPT_EXIT_OK;
}

int cl_source_resolve_text(const char *name, const char *text, char **out, SptError *e)
{
    Buf b = {0};
    Seen seen = {0};
    seen_add(&seen, name);
    int rc = resolve_into(&b, name, text, &seen, 0, e);
    for (int i = 0; i < seen.count; i++)
        free(seen.paths[i]);
    free(seen.paths);
    if (rc) {
        free(b.s);
        *out = NULL;
        return rc;
    }
    *out = b.s ? b.s : spt_calloc(1, 1);
    return SPT_EXIT_OK;
}

int cl_source_resolve(const char *path, char **out, SptError *e)
{
    char full[600];
    kernel_path(path, full, sizeof full);
    char *text = load_kernel_file(full);
    if (!text) {
        const char *dir = getenv("SPECTRACE_KERNEL_DIR");
        *out = NULL;
        return spt_fail(e, SPT_EXIT_DEVICE, "kernel file '%s' not found (%s%s)", full,
                        dir && *dir ? "looked in SPECTRACE_KERNEL_DIR=" :
                                      "not among the embedded kernel sources",
                        dir && *dir ? dir : "");
    }
    int rc = cl_source_resolve_text(full, text, out, e);
    free(text);
    return rc;
}

/* ---- binary cache --------------------------------------------------------- */

unsigned long long cl_fnv1a(unsigned long long h, const void *data, size_t n)
{
    const unsigned char *p = data;
    for (size_t i = 0; i < n; i++) {
        h ^= p[i];
        h *= 0x100000001b3ull;
    }
    return h;
}

const char *cl_cache_dir(char *buf, size_t n)
{
    const char *s = getenv("SPECTRACE_CACHE_DIR");
    const char *x = getenv("XDG_CACHE_HOME");
    const char *home = getenv("HOME");
    if (s && *s)
        snprintf(buf, n, "%s", strcmp(s, "off") ? s : "");
    else if (x && *x)
        snprintf(buf, n, "%s/spectrace", x);
    else if (home && *home)
        snprintf(buf, n, "%s/.cache/spectrace", home);
    else
        buf[0] = 0;
    return buf;
}

/* mkdir -p; 0 on success. */
static int make_dirs(const char *path)
{
    char tmp[4096];
    snprintf(tmp, sizeof tmp, "%s", path);
    for (char *p = tmp + 1; *p; p++) {
        if (*p != '/')
            continue;
        *p = 0;
        if (mkdir(tmp, 0755) && errno != EEXIST)
            return -1;
        *p = '/';
    }
    if (mkdir(tmp, 0755) && errno != EEXIST)
        return -1;
    struct stat st;
    return stat(tmp, &st) == 0 && S_ISDIR(st.st_mode) ? 0 : -1;
}

static int cache_warned; /* the unwritable-folder warning is given once */

/* Cache file layout: magic "SPTCLBN1", u32 key length, key, u64 binary length,
 * binary, u64 FNV-1a of everything before it. The key (device, driver,
 * platform, source hash, options) is checked in full, so a file-name hash
 * collision cannot load the wrong binary. */
static const char cache_magic[8] = {'S', 'P', 'T', 'C', 'L', 'B', 'N', '1'};

/* The binary of a valid cache entry for key, malloc'd; NULL when absent or
 * invalid (*corrupt set when the file exists but is unusable). */
static unsigned char *cache_load(const char *path, const char *key, size_t *bin_len,
                                 int *corrupt)
{
    size_t len = 0;
    *corrupt = 0;
    unsigned char *f = (unsigned char *)read_file(path, &len);
    if (!f)
        return NULL;
    *corrupt = 1;
    size_t klen = strlen(key);
    size_t off = 0;
    uint32_t kl;
    uint64_t bl, sum;
    if (len < sizeof cache_magic + 4 + 8 + 8 || memcmp(f, cache_magic, sizeof cache_magic))
        goto bad;
    off = sizeof cache_magic;
    memcpy(&kl, f + off, 4);
    off += 4;
    if (kl != klen || len - off < (size_t)kl + 16 || memcmp(f + off, key, klen))
        goto bad;
    off += kl;
    memcpy(&bl, f + off, 8);
    off += 8;
    if (bl == 0 || bl != len - off - 8)
        goto bad;
    memcpy(&sum, f + len - 8, 8);
    if (sum != cl_fnv1a(SPT_FNV1A_INIT, f, len - 8))
        goto bad;
    unsigned char *bin = spt_malloc((size_t)bl);
    memcpy(bin, f + off, (size_t)bl);
    free(f);
    *bin_len = (size_t)bl;
    *corrupt = 0;
    return bin;
bad:
    free(f);
    return NULL;
}

/* Writes a cache entry atomically (temporary file, then rename); warns once
 * when the folder cannot be written. */
static void cache_store(const char *dir, const char *path, const char *key,
                        const unsigned char *bin, size_t bin_len)
{
    char tmp[4200];
    /* Unique per process and per call, so that two processes, or two devices of
     * one process building in threads, never share a temporary file. */
    static unsigned serial;
    snprintf(tmp, sizeof tmp, "%s.tmp.%ld.%p.%u", path, (long)getpid(), (const void *)&tmp,
             serial++);
    const char *why = NULL;
    FILE *f = NULL;
    if (make_dirs(dir))
        why = strerror(errno);
    else if (!(f = fopen(tmp, "wb")))
        why = strerror(errno);
    if (f) {
        uint32_t kl = (uint32_t)strlen(key);
        uint64_t bl = bin_len;
        Buf b = {0};
        buf_add(&b, cache_magic, sizeof cache_magic);
        buf_add(&b, (const char *)&kl, 4);
        buf_add(&b, key, kl);
        buf_add(&b, (const char *)&bl, 8);
        buf_add(&b, (const char *)bin, bin_len);
        uint64_t sum = cl_fnv1a(SPT_FNV1A_INIT, b.s, b.len);
        buf_add(&b, (const char *)&sum, 8);
        int ok = fwrite(b.s, 1, b.len, f) == b.len;
        ok &= fclose(f) == 0;
        free(b.s);
        if (!ok)
            why = "write failed (disk full?)";
        else if (rename(tmp, path))
            why = strerror(errno);
        if (why)
            unlink(tmp);
    }
    if (why && !cache_warned) {
        cache_warned = 1;
        spt_warn("kernel cache folder %s is not writable (%s); kernels are compiled on "
                 "every run (set SPECTRACE_CACHE_DIR to change the folder)",
                 dir, why);
    }
}

/* ---- program build -------------------------------------------------------- */

/* Stores the build log of prog on d (replacing an older one). */
static void keep_build_log(ClDevice *d, cl_program prog)
{
    free(d->build_log);
    d->build_log = NULL;
    size_t n = 0;
    if (clGetProgramBuildInfo(prog, d->info.id, CL_PROGRAM_BUILD_LOG, 0, NULL, &n) !=
            CL_SUCCESS ||
        n == 0)
        return;
    d->build_log = spt_malloc(n + 1);
    if (clGetProgramBuildInfo(prog, d->info.id, CL_PROGRAM_BUILD_LOG, n, d->build_log, NULL) !=
        CL_SUCCESS)
        n = 0;
    d->build_log[n] = 0;
}

/* The binary of a built single-device program, malloc'd; NULL when the driver
 * gives none. */
static unsigned char *program_binary(cl_program prog, size_t *len)
{
    size_t size = 0;
    if (clGetProgramInfo(prog, CL_PROGRAM_BINARY_SIZES, sizeof size, &size, NULL) !=
            CL_SUCCESS ||
        size == 0)
        return NULL;
    unsigned char *bin = spt_malloc(size);
    if (clGetProgramInfo(prog, CL_PROGRAM_BINARIES, sizeof bin, &bin, NULL) != CL_SUCCESS) {
        free(bin);
        return NULL;
    }
    *len = size;
    return bin;
}

/* Tries to make a program from a cached binary; NULL when that fails. */
static cl_program program_from_binary(ClDevice *d, const unsigned char *bin, size_t len,
                                      const char *options)
{
    cl_int status = CL_SUCCESS, err = CL_SUCCESS;
    cl_program prog =
        clCreateProgramWithBinary(d->context, 1, &d->info.id, &len, &bin, &status, &err);
    if (err != CL_SUCCESS || status != CL_SUCCESS || !prog) {
        if (prog)
            clReleaseProgram(prog);
        return NULL;
    }
    if (clBuildProgram(prog, 1, &d->info.id, options, NULL, NULL) != CL_SUCCESS) {
        clReleaseProgram(prog);
        return NULL;
    }
    return prog;
}

int cl_program_build_text(ClDevice *d, const char *name, const char *text,
                          const char *options, cl_program *out, SptError *e)
{
    double t0 = spt_now();
    *out = NULL;
    free(d->build_log);
    d->build_log = NULL;
    d->last_from_cache = 0;
    d->last_cache_path[0] = 0;
    char *src = NULL;
    int rc = cl_source_resolve_text(name, text, &src, e);
    if (rc)
        return rc;
    Buf opts = {0};
    if (options && *options) {
        buf_add(&opts, options, strlen(options));
        buf_add(&opts, " ", 1);
    }
    buf_add(&opts, "-cl-std=CL1.2", 13);

    /* Cache key: everything that changes the binary. */
    Buf key = {0};
    unsigned long long src_hash = cl_fnv1a(SPT_FNV1A_INIT, src, strlen(src));
    buf_printf(&key, "device=%s\ndriver=%s\nplatform=%s\nplatform_version=%s\n", d->info.name,
               d->info.driver_version, d->info.platform_name, d->info.platform_version);
    buf_printf(&key, "source=%016llx+%zu\noptions=", src_hash, strlen(src));
    buf_add(&key, opts.s, opts.len);
    unsigned long long key_hash = cl_fnv1a(SPT_FNV1A_INIT, key.s, key.len);
    char dir[4096];
    cl_cache_dir(dir, sizeof dir);
    if (dir[0]) {
        if (snprintf(d->last_cache_path, sizeof d->last_cache_path, "%s/%016llx.clbin", dir,
                     key_hash) >= (int)sizeof d->last_cache_path)
            dir[0] = d->last_cache_path[0] = 0; /* an absurdly long path: no cache */
    }
    if (dir[0]) {
        size_t bl = 0;
        int corrupt = 0;
        unsigned char *bin = cache_load(d->last_cache_path, key.s, &bl, &corrupt);
        if (bin) {
            cl_program prog = program_from_binary(d, bin, bl, opts.s);
            free(bin);
            if (prog) {
                d->cache_hits++;
                d->last_from_cache = 1;
                *out = prog;
                goto done;
            }
            corrupt = 1;
        }
        d->cache_rejected += corrupt;
    }

    d->cache_misses++;
    cl_int err = CL_SUCCESS;
    const char *srcp = src;
    cl_program prog = NULL;
    SPT_CL_CHECK_GOTO(e, (prog = clCreateProgramWithSource(d->context, 1, &srcp, NULL, &err), err),
                      rc, done);
    err = clBuildProgram(prog, 1, &d->info.id, opts.s, NULL, NULL);
    if (err != CL_SUCCESS) {
        keep_build_log(d, prog);
        clReleaseProgram(prog);
        rc = spt_fail(e, SPT_EXIT_DEVICE,
                      "kernel build of %s failed on device [%d] %s (driver %s, platform %s): "
                      "%s (%d); build log follows",
                      name, d->info.index, d->info.name, d->info.driver_version,
                      d->info.platform_name, cl_error_name(err), (int)err);
        if (!d->build_log || !d->build_log[0]) {
            free(d->build_log);
            d->build_log = spt_strdup("(the driver gave no build log)\n");
        }
        goto done;
    }
    if (dir[0]) {
        size_t bl = 0;
        unsigned char *bin = program_binary(prog, &bl);
        if (bin)
            cache_store(dir, d->last_cache_path, key.s, bin, bl);
        free(bin);
    }
    *out = prog;
done:
    free(src);
    free(opts.s);
    free(key.s);
    d->last_build_seconds = spt_now() - t0;
    return rc;
}

int cl_program_build(ClDevice *d, const char *path, const char *options, cl_program *out,
                     SptError *e)
{
    char full[600];
    kernel_path(path, full, sizeof full);
    char *text = load_kernel_file(full);
    if (!text) {
        const char *dir = getenv("SPECTRACE_KERNEL_DIR");
        *out = NULL;
        return spt_fail(e, SPT_EXIT_DEVICE, "kernel file '%s' not found (%s%s)", full,
                        dir && *dir ? "looked in SPECTRACE_KERNEL_DIR=" :
                                      "not among the embedded kernel sources",
                        dir && *dir ? dir : "");
    }
    int rc = cl_program_build_text(d, full, text, options, out, e);
    free(text);
    return rc;
}

/* ---- memory checks -------------------------------------------------------- */

/* "1.50 GiB", "12.0 MiB", "512 B". */
static const char *fmt_bytes(char *buf, size_t n, unsigned long long bytes)
{
    static const char *units[] = {"B", "KiB", "MiB", "GiB", "TiB"};
    double v = (double)bytes;
    int u = 0;
    while (v >= 1024.0 && u < 4) {
        v /= 1024.0;
        u++;
    }
    if (u == 0)
        snprintf(buf, n, "%llu B", bytes);
    else
        snprintf(buf, n, "%.2f %s", v, units[u]);
    return buf;
}

int cl_device_check_memory(const ClDeviceInfo *info, const ClAlloc *allocs, int n,
                           SptError *e)
{
    char a[32], b[32];
    unsigned long long total = 0;
    for (int i = 0; i < n; i++) {
        if (allocs[i].bytes > info->max_alloc)
            return spt_fail(e, SPT_EXIT_DEVICE,
                            "device [%d] %s: buffer '%s' needs %s (%zu bytes) but the device "
                            "allows at most %s (%llu bytes) per allocation "
                            "(CL_DEVICE_MAX_MEM_ALLOC_SIZE)",
                            info->index, info->name, allocs[i].name,
                            fmt_bytes(a, sizeof a, allocs[i].bytes), allocs[i].bytes,
                            fmt_bytes(b, sizeof b, info->max_alloc),
                            (unsigned long long)info->max_alloc);
        total += allocs[i].bytes;
    }
    if (total > info->global_mem)
        return spt_fail(e, SPT_EXIT_DEVICE,
                        "device [%d] %s: the %d buffers need %s (%llu bytes) in total but the "
                        "device has %s (%llu bytes) of global memory (CL_DEVICE_GLOBAL_MEM_SIZE)",
                        info->index, info->name, n, fmt_bytes(a, sizeof a, total), total,
                        fmt_bytes(b, sizeof b, info->global_mem),
                        (unsigned long long)info->global_mem);
    return SPT_EXIT_OK;
}

int cl_buffer_create(ClDevice *d, const char *name, cl_mem_flags flags, size_t bytes,
                     void *host, cl_mem *out, SptError *e)
{
    *out = NULL;
    ClAlloc a = {name, bytes};
    int rc = cl_device_check_memory(&d->info, &a, 1, e);
    if (rc)
        return rc;
    cl_int err = CL_SUCCESS;
    /* OpenCL rejects zero-sized buffers; a one-byte buffer keeps empty scenes
     * (no lights, no textures) legal. */
    rc = cl_check((*out = clCreateBuffer(d->context, flags, bytes ? bytes : 1, host, &err), err),
                  "clCreateBuffer", __FILE__, __LINE__, e);
    if (rc) {
        char prefix[700], sz[32];
        snprintf(prefix, sizeof prefix, "device [%d] %.256s: buffer '%.256s' (%s): ",
                 d->info.index, d->info.name, name, fmt_bytes(sz, sizeof sz, bytes));
        prefix_error(e, prefix);
    }
    return rc;
}

/* ---- layout check --------------------------------------------------------- */

typedef struct LayoutEntry {
    const char *name;
    unsigned value;
} LayoutEntry;

#define SPT_LAYOUT_HOST_SIZE(T) {#T, (unsigned)sizeof(T)},
#define SPT_LAYOUT_HOST_FIELD(T, f) {#T "." #f, (unsigned)offsetof(T, f)},
static const LayoutEntry layout_host[] = {SPT_LAYOUT_STRUCTS(SPT_LAYOUT_HOST_SIZE)
                                              SPT_LAYOUT_FIELDS(SPT_LAYOUT_HOST_FIELD)};
#undef SPT_LAYOUT_HOST_SIZE
#undef SPT_LAYOUT_HOST_FIELD

int cl_layout_count(void)
{
    return (int)(sizeof layout_host / sizeof layout_host[0]);
}

int cl_layout_query(ClDevice *d, unsigned *values, int n, SptError *e)
{
    if (n != cl_layout_count())
        return spt_fail(e, SPT_EXIT_FAILURE, "cl_layout_query: %d values asked, %d listed", n,
                        cl_layout_count());
    cl_program prog = NULL;
    cl_kernel k = NULL;
    cl_mem buf = NULL;
    cl_int err = CL_SUCCESS;
    int rc = cl_program_build(d, "kernels/device/layout_check.cl", NULL, &prog, e);
    if (rc)
        return rc;
    size_t bytes = (size_t)n * sizeof(cl_uint);
    cl_uint *tmp = spt_calloc((size_t)n, sizeof(cl_uint));
    SPT_CL_CHECK_GOTO(e, (k = clCreateKernel(prog, "k_layout_sizes", &err), err), rc, done);
    SPT_CL_CHECK_GOTO(e, (buf = clCreateBuffer(d->context, CL_MEM_WRITE_ONLY, bytes, NULL, &err),
                          err),
                      rc, done);
    SPT_CL_CHECK_GOTO(e, clSetKernelArg(k, 0, sizeof buf, &buf), rc, done);
    size_t global = 1;
    SPT_CL_CHECK_GOTO(e, clEnqueueNDRangeKernel(d->queue, k, 1, NULL, &global, NULL, 0, NULL,
                                                NULL),
                      rc, done);
    SPT_CL_CHECK_GOTO(e, clEnqueueReadBuffer(d->queue, buf, CL_TRUE, 0, bytes, tmp, 0, NULL,
                                             NULL),
                      rc, done);
    for (int i = 0; i < n; i++)
        values[i] = tmp[i];
done:
    free(tmp);
    if (buf)
        clReleaseMemObject(buf);
    if (k)
        clReleaseKernel(k);
    clReleaseProgram(prog);
    return rc;
}

int cl_layout_check(ClDevice *d, SptError *e)
{
    int n = cl_layout_count();
    unsigned *dev = spt_calloc((size_t)n, sizeof *dev);
    int rc = cl_layout_query(d, dev, n, e);
    for (int i = 0; i < n && !rc; i++)
        if (dev[i] != layout_host[i].value)
            rc = spt_fail(e, SPT_EXIT_DEVICE,
                          "device [%d] %s: shared struct layout differs: %s %s %u on the "
                          "device but %u on the host (kernels/shared/layout_list.h)",
                          d->info.index, d->info.name, layout_host[i].name,
                          strchr(layout_host[i].name, '.') ? "is at offset" : "has size",
                          dev[i], layout_host[i].value);
    free(dev);
    return rc;
}
