// Draco and meshoptimizer decoding (see src/scene/mesh_decode.h for the contract).
#include "scene/mesh_decode.h"

#include <draco/compression/decode.h>
#include <draco/mesh/mesh.h>
#include <meshoptimizer.h>

#include <cstdio>
#include <cstring>
#include <memory>
#include <new>
#include <string>

struct DracoDecoded {
    std::unique_ptr<draco::Mesh> mesh;
};

namespace {
void say(char *why, size_t why_size, const std::string &text)
{
    if (why && why_size) snprintf(why, why_size, "%s", text.c_str());
}
} // namespace

extern "C" DracoDecoded *mesh_draco_decode(const void *data, size_t size, char *why,
                                           size_t why_size)
{
    try {
        draco::DecoderBuffer buf;
        buf.Init((const char *)data, size);
        auto type = draco::Decoder::GetEncodedGeometryType(&buf);
        if (!type.ok() || type.value() != draco::TRIANGULAR_MESH) {
            say(why, why_size, "not a Draco triangle mesh");
            return nullptr;
        }
        draco::Decoder dec;
        auto res = dec.DecodeMeshFromBuffer(&buf);
        if (!res.ok()) {
            say(why, why_size, std::string("Draco: ") + res.status().error_msg_string());
            return nullptr;
        }
        DracoDecoded *d = new DracoDecoded;
        d->mesh = std::move(res).value();
        return d;
    } catch (const std::exception &ex) {
        say(why, why_size, std::string("Draco: ") + ex.what());
        return nullptr;
    }
}

extern "C" uint32_t mesh_draco_points(const DracoDecoded *d) { return d->mesh->num_points(); }

extern "C" uint32_t mesh_draco_faces(const DracoDecoded *d) { return d->mesh->num_faces(); }

extern "C" void mesh_draco_indices(const DracoDecoded *d, uint32_t *out)
{
    uint32_t n = d->mesh->num_faces();
    for (uint32_t f = 0; f < n; f++) {
        const auto &face = d->mesh->face(draco::FaceIndex(f));
        for (int k = 0; k < 3; k++) out[f * 3 + k] = face[k].value();
    }
}

extern "C" int mesh_draco_attribute(const DracoDecoded *d, int unique_id, int ncomp, float *out)
{
    const draco::PointAttribute *a = d->mesh->GetAttributeByUniqueId((uint32_t)unique_id);
    if (!a || a->num_components() < ncomp || ncomp < 1 || ncomp > 4) return -1;
    uint32_t n = d->mesh->num_points();
    float v[4];
    for (uint32_t i = 0; i < n; i++) {
        if (!a->ConvertValue<float>(a->mapped_index(draco::PointIndex(i)), (int8_t)ncomp, v))
            return -1;
        memcpy(out + (size_t)i * ncomp, v, sizeof(float) * (size_t)ncomp);
    }
    return 0;
}

extern "C" void mesh_draco_free(DracoDecoded *d) { delete d; }

extern "C" int mesh_meshopt_decode(void *dst, size_t count, size_t stride, const void *src,
                                   size_t size, int mode, int filter, char *why, size_t why_size)
{
    const unsigned char *b = (const unsigned char *)src;
    int rc;
    if (mode == SPT_MESHOPT_ATTRIBUTES) {
        if (stride == 0 || stride > 256 || stride % 4) {
            say(why, why_size, "byteStride must be a multiple of 4 in 4..256");
            return -1;
        }
        rc = meshopt_decodeVertexBuffer(dst, count, stride, b, size);
    } else {
        if (stride != 2 && stride != 4) {
            say(why, why_size, "byteStride must be 2 or 4 for indices");
            return -1;
        }
        if (mode == SPT_MESHOPT_TRIANGLES && count % 3) {
            say(why, why_size, "count is not a multiple of 3 for TRIANGLES");
            return -1;
        }
        rc = mode == SPT_MESHOPT_TRIANGLES ? meshopt_decodeIndexBuffer(dst, count, stride, b, size)
                                           : meshopt_decodeIndexSequence(dst, count, stride, b, size);
    }
    if (rc != 0) {
        say(why, why_size, "corrupt compressed data (meshoptimizer error " + std::to_string(rc) + ")");
        return -1;
    }
    if (filter == SPT_MESHOPT_OCTAHEDRAL || filter == SPT_MESHOPT_QUATERNION) {
        if (mode != SPT_MESHOPT_ATTRIBUTES || (stride != 4 && stride != 8) ||
            (filter == SPT_MESHOPT_QUATERNION && stride != 8)) {
            say(why, why_size, "filter needs ATTRIBUTES with byteStride 4 or 8 (QUATERNION: 8)");
            return -1;
        }
        if (filter == SPT_MESHOPT_OCTAHEDRAL)
            meshopt_decodeFilterOct(dst, count, stride);
        else
            meshopt_decodeFilterQuat(dst, count, stride);
    } else if (filter == SPT_MESHOPT_EXPONENTIAL) {
        if (mode != SPT_MESHOPT_ATTRIBUTES) {
            say(why, why_size, "EXPONENTIAL filter needs ATTRIBUTES");
            return -1;
        }
        meshopt_decodeFilterExp(dst, count, stride);
    }
    return 0;
}
