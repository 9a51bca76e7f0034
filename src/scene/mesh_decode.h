/* Compressed mesh data of glTF files: KHR_draco_mesh_compression (libdraco) and
 * EXT_meshopt_compression (libmeshoptimizer). The only Draco and meshoptimizer
 * code of the loader lives in src/scene/mesh_decode.cpp. */
#ifndef SPT_MESH_DECODE_H
#define SPT_MESH_DECODE_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef struct DracoDecoded DracoDecoded;

/* Decodes a Draco mesh (triangles). Returns NULL with a short reason in why. */
DracoDecoded *mesh_draco_decode(const void *data, size_t size, char *why, size_t why_size);
uint32_t mesh_draco_points(const DracoDecoded *d);
uint32_t mesh_draco_faces(const DracoDecoded *d);
/* 3 point indices per face into out (3 * faces entries). */
void mesh_draco_indices(const DracoDecoded *d, uint32_t *out);
/* The attribute with this unique id as floats, ncomp per point (points * ncomp
 * entries; integer attributes converted to float, normalised when the attribute
 * says so). Returns 0, or -1 when there is no such attribute or it has fewer
 * components. */
int mesh_draco_attribute(const DracoDecoded *d, int unique_id, int ncomp, float *out);
void mesh_draco_free(DracoDecoded *d);

enum { SPT_MESHOPT_ATTRIBUTES = 0, SPT_MESHOPT_TRIANGLES = 1, SPT_MESHOPT_INDICES = 2 };
enum { SPT_MESHOPT_NONE = 0, SPT_MESHOPT_OCTAHEDRAL = 1, SPT_MESHOPT_QUATERNION = 2,
       SPT_MESHOPT_EXPONENTIAL = 3 };

/* Decodes one EXT_meshopt_compression buffer view into dst (count * stride
 * bytes), then applies the filter. Returns 0, or -1 with a reason in why (bad
 * stride or data). */
int mesh_meshopt_decode(void *dst, size_t count, size_t stride, const void *src, size_t size,
                        int mode, int filter, char *why, size_t why_size);

#ifdef __cplusplus
}
#endif

#endif
