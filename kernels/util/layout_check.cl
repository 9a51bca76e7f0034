/* The layout check of the structs shared by host and kernels (see
 * kernels/util/layout_list.h): one work-item writes sizeof of each struct of
 * SPT_LAYOUT_STRUCTS, then the byte offset of each field of SPT_LAYOUT_FIELDS,
 * in list order. The host compares them with its own (cl_layout_check). */
#include "util/portable.h"
#include "util/layout_list.h"

/* Byte offset of field f in T, without relying on offsetof in OpenCL C. */
#define SPT_LAYOUT_OFFSET(T, f) \
    ((uint)((__private char *)&probe_##T.f - (__private char *)&probe_##T))

__kernel void k_layout_sizes(__global uint *out)
{
    if (get_global_id(0) != 0)
        return;
    uint i = 0;
#define SPT_LAYOUT_SIZE(T) out[i++] = (uint)sizeof(T);
    SPT_LAYOUT_STRUCTS(SPT_LAYOUT_SIZE)
#undef SPT_LAYOUT_SIZE
    /* One private instance per struct gives fields an address to measure. */
#define SPT_LAYOUT_PROBE(T) T probe_##T;
    SPT_LAYOUT_STRUCTS(SPT_LAYOUT_PROBE)
#undef SPT_LAYOUT_PROBE
#define SPT_LAYOUT_FIELD(T, f) out[i++] = SPT_LAYOUT_OFFSET(T, f);
    SPT_LAYOUT_FIELDS(SPT_LAYOUT_FIELD)
#undef SPT_LAYOUT_FIELD
}
