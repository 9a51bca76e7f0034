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
void cl_prefix_error(SptError *e, const char *prefix)
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

/* The implementations users name, each with a part of its platform name, vendor
 * or ICD suffix. */
static const struct {
    const char *name, *part;
} known[] = {
    {"pocl", "Portable Computing Language"}, {"pocl", "POCL"},
    {"rusticl", "rusticl"},                  {"clover", "Clover"},
    {"oclgrind", "Oclgrind"},                {"nvidia", "NVIDIA"},
    {"amd", "AMD Accelerated Parallel Processing"}, {"amd", "Advanced Micro Devices"},
    {"intel", "Intel"},
};

void cl_impl_name(const char *platform_name, const char *platform_vendor, const char *icd_suffix,
                  char *out, size_t n)
{
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

/* Does the selection token name an implementation: a known one (installed or
 * not) or that of one of the devices? Such a token selects only that
 * implementation's devices (README.md, "Devices"): "intel" must not
 * fall back to PoCL's device on an Intel CPU, whose vendor name contains it. */
static int token_is_impl(const ClDeviceList *all, const char *tok)
{
    for (size_t k = 0; k < sizeof known / sizeof known[0]; k++)
        if (!strcasecmp(known[k].name, tok))
            return 1;
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
            if (!any && by_impl) {
                rc = spt_fail(e, SPT_EXIT_DEVICE,
                              "%s '%s': no device of the OpenCL implementation '%s' (it is not "
                              "installed, or the ICD loader does not see it: OCL_ICD_VENDORS)",
                              origin, selection, tok);
                append_device_list(e ? e->msg : NULL, e ? sizeof e->msg : 0, all);
                break;
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
    cl_prefix_error(e, prefix);
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
