/* Load-time benchmark (`make bench`): writes a generated glTF binary of about
 * TRIANGLES triangles (default 10 million) into a temporary folder, then times
 * scene_load_gltf, bvh_build and both together, and removes the file. The model
 * is a bumpy grid in two primitives (two materials) that share one POSITION and
 * TEXCOORD_0 accessor, as exporters write multi-material meshes, placed on two
 * nodes (one mesh, two instances) so the cost of flattening shows.
 * Usage: bench_load [TRIANGLES] */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "accel/bvh_build.h"
#include "scene/scene.h"
#include "core/util.h"

static int write_all(FILE *f, const void *p, size_t n) { return fwrite(p, 1, n, f) == n ? 0 : -1; }

/* Writes the .glb; returns 0 or -1. */
static int write_model(const char *path, uint32_t side, double *bytes_out)
{
    uint32_t nv = (side + 1) * (side + 1);
    uint64_t nidx = (uint64_t)side * side * 6;
    uint64_t half = nidx / 2 / 3 * 3;
    size_t pos_bytes = (size_t)nv * 12, uv_bytes = (size_t)nv * 8, idx_bytes = (size_t)nidx * 4;
    size_t bin = pos_bytes + uv_bytes + idx_bytes;
    char json[4096];
    int n = snprintf(json, sizeof json,
        "{\"asset\":{\"version\":\"2.0\",\"generator\":\"tools/bench_load.c\"},\"scene\":0,"
        "\"scenes\":[{\"nodes\":[0,1]}],"
        "\"nodes\":[{\"mesh\":0},{\"mesh\":0,\"translation\":[0,0,-3]}],"
        "\"materials\":[{\"name\":\"a\"},{\"name\":\"b\",\"pbrMetallicRoughness\":{\"metallicFactor\":0}}],"
        "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0,\"TEXCOORD_0\":1},\"indices\":2,\"material\":0},"
        "{\"attributes\":{\"POSITION\":0,\"TEXCOORD_0\":1},\"indices\":3,\"material\":1}]}],"
        "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":%u,\"type\":\"VEC3\","
        "\"min\":[-1,-1,0],\"max\":[1,1,0.1]},"
        "{\"bufferView\":1,\"componentType\":5126,\"count\":%u,\"type\":\"VEC2\"},"
        "{\"bufferView\":2,\"componentType\":5125,\"count\":%llu,\"type\":\"SCALAR\"},"
        "{\"bufferView\":2,\"byteOffset\":%llu,\"componentType\":5125,\"count\":%llu,\"type\":\"SCALAR\"}],"
        "\"bufferViews\":[{\"buffer\":0,\"byteLength\":%zu},{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu},"
        "{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu}],"
        "\"buffers\":[{\"byteLength\":%zu}]}",
        nv, nv, (unsigned long long)half, (unsigned long long)(half * 4),
        (unsigned long long)(nidx - half), pos_bytes, pos_bytes, uv_bytes, pos_bytes + uv_bytes,
        idx_bytes, bin);
    while (n % 4) json[n++] = ' ';
    FILE *f = fopen(path, "wb");
    if (!f) return -1;
    uint32_t hdr[5] = {0x46546C67, 2, (uint32_t)(12 + 8 + n + 8 + bin), (uint32_t)n, 0x4E4F534A};
    uint32_t binhdr[2] = {(uint32_t)bin, 0x004E4942};
    int rc = write_all(f, hdr, 20) | write_all(f, json, (size_t)n) | write_all(f, binhdr, 8);
    float *buf = malloc((size_t)(side + 1) * 12);
    for (uint32_t j = 0; j <= side && !rc; j++) {
        for (uint32_t i = 0; i <= side; i++) {
            float x = -1 + 2.0f * i / side, y = -1 + 2.0f * j / side;
            buf[i * 3] = x;
            buf[i * 3 + 1] = y;
            buf[i * 3 + 2] = 0.05f * (1 + sinf(40 * x) * cosf(40 * y));
        }
        rc |= write_all(f, buf, (size_t)(side + 1) * 12);
    }
    for (uint32_t j = 0; j <= side && !rc; j++) {
        for (uint32_t i = 0; i <= side; i++) {
            buf[i * 2] = (float)i / side;
            buf[i * 2 + 1] = (float)j / side;
        }
        rc |= write_all(f, buf, (size_t)(side + 1) * 8);
    }
    free(buf);
    uint32_t *row = malloc((size_t)side * 6 * 4);
    for (uint32_t j = 0; j < side && !rc; j++) {
        for (uint32_t i = 0; i < side; i++) {
            uint32_t a = j * (side + 1) + i, b = a + 1, c = a + side + 2, d = a + side + 1;
            uint32_t q[6] = {a, b, c, a, c, d};
            memcpy(row + i * 6, q, sizeof q);
        }
        rc |= write_all(f, row, (size_t)side * 6 * 4);
    }
    free(row);
    rc |= fclose(f);
    *bytes_out = 20.0 + n + 8 + bin;
    return rc ? -1 : 0;
}

int main(int argc, char **argv)
{
    double want = argc > 1 ? atof(argv[1]) : 10e6;
    if (!(want >= 2)) {
        fprintf(stderr, "usage: bench_load [TRIANGLES]\n");
        return 2;
    }
    /* Two instances of a side x side grid of 2 triangles per cell. */
    uint32_t side = (uint32_t)ceil(sqrt(want / 4));
    char dir[] = "/tmp/spectrace-bench-XXXXXX";
    if (!mkdtemp(dir)) {
        perror("error: bench_load: mkdtemp");
        return 1;
    }
    char path[256];
    snprintf(path, sizeof path, "%s/grid.glb", dir);
    double bytes = 0, t0 = spt_now();
    if (write_model(path, side, &bytes)) {
        fprintf(stderr, "error: bench_load: cannot write %s\n", path);
        unlink(path);
        rmdir(dir);
        return 1;
    }
    double t_gen = spt_now() - t0;
    Scene s;
    SptError e = {0};
    t0 = spt_now();
    int rc = scene_load_gltf(&s, path, &e);
    double t_load = spt_now() - t0;
    unlink(path);
    rmdir(dir);
    if (rc) return spt_report(&e);
    Bvh bvh = {0};
    t0 = spt_now();
    rc = bvh_build(&bvh, s.tri_pos, s.tri_count, &e);
    double t_bvh = spt_now() - t0;
    if (rc) return spt_report(&e);
    printf("load: %.1f M triangles (2 instances of a 2-primitive mesh), %.1f M vertices, %.0f MB "
           ".glb (written in %.1f s)\n",
           s.tri_count / 1e6, s.vertex_count / 1e6, bytes / 1e6, t_gen);
    printf("load: scene_load_gltf %.2f s, bvh_build %.2f s, total %.2f s (target < 30 s)\n", t_load,
           t_bvh, t_load + t_bvh);
    bvh_free(&bvh);
    scene_free(&s);
    return 0;
}
