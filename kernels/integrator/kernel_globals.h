/* What the wavefront kernels (kernels/integrator/wavefront.cl) take and how
 * their helpers reach it (docs/architecture.md, "Kernel buffers"). Every
 * kernel takes every buffer of the lists of kernels/util/render_types.h, in
 * their order, and then the RenderParams by value (KERNEL_ARGS), so the host
 * sets the arguments from the same lists (src/render/wavefront.c). A kernel
 * gathers them into a private KernelGlobals (KERNEL_GLOBALS, as Cycles'
 * OpenCL kernels did) and hands its helpers a pointer to it, `kg`; a helper
 * that reads only a few buffers takes those instead. A kernel without
 * barriers builds it at its top; one with barriers (k_generate, k_shade,
 * k_shade_light) within the stretch between barriers that calls the
 * helpers, so that it never lives across a barrier: PoCL keeps such a
 * private variable in an array of one per work-item of the group, which
 * slowed k_shade's shading (docs/performance.md, "Calls"). */
#ifndef SPT_KERNEL_GLOBALS_H
#define SPT_KERNEL_GLOBALS_H

#include "util/portable.h"
#include "util/render_types.h"
#include "bvh/bvh_node.h" /* BvhNode */
#include "bvh/bvh_tlas.h" /* BvhInstance */

SPT_DEVICE_ONLY

#define SPT_KG_PARAM(type, name) __global type *name,
#define SPT_KG_PS_PARAM(type, name) __global type *ps_##name,
#define SPT_KG_SH_PARAM(type, name) __global type *sh_##name,
#define KERNEL_ARGS                       \
    SPT_SCENE_BUFFERS(SPT_KG_PARAM)       \
    SPT_WORK_BUFFERS(SPT_KG_PARAM)        \
    SPT_PATH_STATE(SPT_KG_PS_PARAM)       \
    SPT_SHADOW_STATE(SPT_KG_SH_PARAM)     \
    const RenderParams params

#define SPT_KG_FIELD(type, name) __global type *name;
#define SPT_KG_PS_FIELD(type, name) __global type *ps_##name;
#define SPT_KG_SH_FIELD(type, name) __global type *sh_##name;
/* The buffers under the kernel parameters' names, and the parameters. The
 * RenderParams stay where the kernel received them and are reached through
 * p: a helper left a call does not copy the struct onto its stack. */
typedef struct KernelGlobals {
    SPT_SCENE_BUFFERS(SPT_KG_FIELD)
    SPT_WORK_BUFFERS(SPT_KG_FIELD)
    SPT_PATH_STATE(SPT_KG_PS_FIELD)
    SPT_SHADOW_STATE(SPT_KG_SH_FIELD)
    const RenderParams *p;
} KernelGlobals;

/* Whether the scene has instances (docs/architecture.md, "Instances (two
 * levels)"), for the RenderParams p. Every instance branch of the kernels
 * tests this: the CPU path builds a scene without instances with
 * SPT_INSTANCES=0 (src/render/wavefront.c, wavefront_options), where it is the
 * constant 0 and the compiler drops those branches, so that the one-level path
 * carries no instance code (docs/performance.md, "Instances: two levels"). */
#if defined(SPT_INSTANCES) && SPT_INSTANCES == 0
#define SPT_HAS_INSTANCES(p) 0
#else
#define SPT_HAS_INSTANCES(p) ((p)->inst_count > 0u)
#endif

#define SPT_KG_ARG(type, name) name,
#define SPT_KG_PS_ARG(type, name) ps_##name,
#define SPT_KG_SH_ARG(type, name) sh_##name,
/* A kernel's KernelGlobals, and kg pointing to it. */
#define KERNEL_GLOBALS                                                                            \
    const KernelGlobals kg_ = {SPT_SCENE_BUFFERS(SPT_KG_ARG) SPT_WORK_BUFFERS(SPT_KG_ARG)         \
                                   SPT_PATH_STATE(SPT_KG_PS_ARG) SPT_SHADOW_STATE(SPT_KG_SH_ARG) \
                                       &params};                                                  \
    const KernelGlobals *kg = &kg_

#endif
