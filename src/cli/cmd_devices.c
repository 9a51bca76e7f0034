/* `spectrace devices`: lists every OpenCL platform and device with a global
 * index, marks the devices a selection picks, and optionally checks the
 * selected devices (context, program build, shared struct layout). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cl/cl_device.h"
#include "cli/commands.h"
#include "core/util.h"

static const char devices_usage[] =
    "usage: spectrace devices [--device SEL] [--check]\n"
    "\n"
    "Lists OpenCL platforms and devices. Devices marked '*' are the ones SEL selects\n"
    "(default: $SPECTRACE_DEVICE, else the first GPU, else the first CPU).\n"
    "SEL: 'all', or a comma list of device indices, 'gpu', 'cpu', 'accelerator',\n"
    "implementation names (pocl, intel, rusticl, nvidia, amd, ...; shown as 'impl') or\n"
    "case-insensitive parts of a device, vendor or platform name (\"0,2\", \"pocl,intel\").\n"
    "--check  on each selected device: open a context, build the layout-check kernel\n"
    "         (through the kernel cache) and compare shared struct sizes with the host.\n";

/* Memory in GiB with two decimals (MiB below 1 GiB). */
static void print_mem(const char *label, unsigned long long bytes)
{
    if (bytes >= (1ull << 30))
        printf("%s %.2f GiB", label, (double)bytes / (double)(1ull << 30));
    else
        printf("%s %.1f MiB", label, (double)bytes / (double)(1ull << 20));
}

/* Prints the listing; sel[0..nsel) are marked. */
static void print_devices(const ClDeviceList *list, const int *sel, int nsel)
{
    int last_platform = -1;
    for (int i = 0; i < list->count; i++) {
        const ClDeviceInfo *d = &list->devices[i];
        if (d->platform_index != last_platform) {
            printf("platform %d: %s (%s), impl %s\n", d->platform_index, d->platform_name,
                   d->platform_version, d->impl);
            last_platform = d->platform_index;
        }
        int mark = 0;
        for (int k = 0; k < nsel; k++)
            mark |= sel[k] == i;
        printf(" %c[%d] %s\n", mark ? '*' : ' ', d->index, d->name);
        printf("      type %s, vendor %s, driver %s\n", cl_device_type_name(d->type),
               d->vendor, d->driver_version);
        printf("      compute units %u, max work-group size %zu\n", d->compute_units,
               d->max_work_group_size);
        print_mem("     ", d->global_mem);
        print_mem(" global memory,", d->max_alloc);
        printf(" max allocation\n");
        printf("      %s, fp64 %s\n", d->opencl_c_version, d->fp64 ? "yes" : "no");
    }
}

/* Opens d, runs the layout check, and prints one line; returns an exit code. */
static int check_device(const ClDeviceInfo *info)
{
    ClDevice d;
    SptError e = {0};
    int rc = cl_device_open(&d, info, 0, &e);
    if (rc)
        return spt_report(&e);
    rc = cl_layout_check(&d, &e);
    if (rc)
        cl_device_report(&d, &e);
    else
        printf("[%d] %s: layout check passed (%d values; kernel %s in %.3f s)\n", info->index,
               info->name, cl_layout_count(), d.last_from_cache ? "from cache" : "compiled",
               d.last_build_seconds);
    cl_device_close(&d);
    return rc;
}

int cmd_devices(int argc, char **argv)
{
    const char *selection = NULL;
    int check = 0;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--help") || !strcmp(argv[i], "-h")) {
            fputs(devices_usage, stdout);
            return SPT_EXIT_OK;
        } else if (!strcmp(argv[i], "--check")) {
            check = 1;
        } else if ((!strcmp(argv[i], "--device") || !strcmp(argv[i], "-d")) && i + 1 < argc) {
            selection = argv[++i];
        } else if (!strncmp(argv[i], "--device=", 9)) {
            selection = argv[i] + 9;
        } else {
            spt_error("devices: unknown or incomplete option '%s'", argv[i]);
            fputs(devices_usage, stderr);
            return SPT_EXIT_USAGE;
        }
    }
    ClDeviceList list;
    SptError e = {0};
    int rc = cl_device_list(&list, &e);
    if (rc)
        return spt_report(&e);
    int *sel = spt_calloc((size_t)list.count, sizeof *sel);
    int nsel = 0;
    rc = cl_device_select(&list, selection, sel, &nsel, &e);
    if (rc) {
        /* Still show the listing: it is what the user asked for. */
        print_devices(&list, NULL, 0);
        fflush(stdout);
        spt_report(&e);
    } else {
        print_devices(&list, sel, nsel);
        printf("selected:");
        for (int k = 0; k < nsel; k++)
            printf("%s %d", k ? "," : "", sel[k]);
        printf("\n");
        fflush(stdout);
        for (int k = 0; check && k < nsel; k++) {
            int r = check_device(&list.devices[sel[k]]);
            if (r && !rc)
                rc = r;
        }
    }
    free(sel);
    cl_device_list_free(&list);
    return rc;
}
