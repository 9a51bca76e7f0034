#!/usr/bin/env python3
"""Writes the glTF files of tests/test_gltf_wild.c into tests/data/gltf/wild_*.

    python3 tools/gen_wild_tests.py [OUT_DIR]

Files "from the wild": texture transforms, legacy specular-glossiness, ignored
material extensions, one small bumpy grid mesh as a plain, a quantised
(KHR_mesh_quantization), a meshopt (EXT_meshopt_compression, octahedral normals) and a Draco
(KHR_draco_mesh_compression) copy, and a WebP texture (EXT_texture_webp). Each
file is a few KB. Needs numpy and the PyPI packages meshoptimizer, DracoPy and Pillow
(pip install meshoptimizer DracoPy pillow); the test compares the copies with each other, so the encoders
only have to be faithful, never exact."""
import base64
import json
import math
import os
import struct
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import gen_gltf_tests as gg  # noqa: E402

OUT = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), "..", "tests", "data", "gltf")
gg.OUT = OUT
G, FLOAT, U8, U16 = gg.G, gg.FLOAT, gg.U8, gg.U16
I8, I16 = 5120, 5122


def grid():
    """A 5x5-vertex grid over [-1,1]^2 with a bump: 32 triangles."""
    pos, nrm, uv, idx = [], [], [], []
    n = 5
    for j in range(n):
        for i in range(n):
            x, y = -1 + 2 * i / (n - 1), -1 + 2 * j / (n - 1)
            z = 0.3 * math.cos(0.5 * math.pi * x) * math.cos(0.5 * math.pi * y)
            pos.append((x, y, z))
            # Normal of z = f(x, y): (-fx, -fy, 1) normalised.
            fx = -0.3 * 0.5 * math.pi * math.sin(0.5 * math.pi * x) * math.cos(0.5 * math.pi * y)
            fy = -0.3 * 0.5 * math.pi * math.cos(0.5 * math.pi * x) * math.sin(0.5 * math.pi * y)
            ln = math.sqrt(fx * fx + fy * fy + 1)
            nrm.append((-fx / ln, -fy / ln, 1 / ln))
            uv.append((i / (n - 1), j / (n - 1)))
    for j in range(n - 1):
        for i in range(n - 1):
            a, b, c, d = j * n + i, j * n + i + 1, (j + 1) * n + i + 1, (j + 1) * n + i
            idx += [a, b, c, a, c, d]
    return pos, nrm, uv, idx


def material_files():
    # Texture transforms on every slot; the 2x2 PNG of gen_gltf_tests as image.
    g = G()
    g.doc["images"] = [{"uri": "data:image/png;base64," + base64.b64encode(gg.PNG_2X2).decode()}]
    g.doc["textures"] = [{"source": 0}]

    def tt(**kw):
        return {"index": 0, "extensions": {"KHR_texture_transform": kw}}
    g.doc["materials"] = [{
        "name": "transformed",
        "pbrMetallicRoughness": {
            "baseColorTexture": tt(offset=[0.25, 0.5], rotation=math.pi / 6, scale=[2, 3]),
            "metallicRoughnessTexture": tt(scale=[4, 0.5])},
        "emissiveTexture": tt(offset=[-1, 2]),
        "normalTexture": tt(rotation=math.pi / 2, texCoord=1),
    }, {"name": "plain", "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}]
    g.node(mesh=g.mesh([g.prim(gg.TRI, [0, 1, 2], material=0), g.prim(gg.TRI, [0, 1, 2], material=1)]))
    g.doc["extensionsUsed"] = ["KHR_texture_transform"]
    g.doc["extensionsRequired"] = ["KHR_texture_transform"]
    g.gltf("wild_texture_transform.gltf")

    # Legacy specular-glossiness: a dielectric, a metal, and ignored extensions.
    g = G()
    sg = "KHR_materials_pbrSpecularGlossiness"
    g.doc["materials"] = [
        {"name": "dielectric", "extensions": {sg: {
            "diffuseFactor": [0.5, 0.5, 0.5, 0.8], "specularFactor": [0, 0, 0], "glossinessFactor": 0.3}}},
        {"name": "metal", "extensions": {sg: {
            "diffuseFactor": [0, 0, 0, 1], "specularFactor": [1, 1, 1], "glossinessFactor": 0.8}}},
        {"name": "velvet", "extensions": {"KHR_materials_sheen": {"sheenColorFactor": [1, 0, 0],
                                                                  "sheenRoughnessFactor": 0.4}}},
        {"name": "carpaint", "extensions": {"KHR_materials_clearcoat": {"clearcoatFactor": 1,
                                                                       "clearcoatRoughnessFactor": 0.1},
                                            "KHR_materials_sheen": {}}},
        {"name": "plastic", "extensions": {"KHR_materials_specular": {"specularFactor": 0.5}}},
        {"name": "soap", "extensions": {"KHR_materials_iridescence": {"iridescenceFactor": 1}}},
        {"name": "brushed", "extensions": {"KHR_materials_anisotropy": {"anisotropyStrength": 0.5},
                                           "KHR_materials_iridescence": {}}},
    ]
    g.node(mesh=g.mesh([g.prim(gg.TRI, [0, 1, 2], material=k) for k in range(7)]))
    g.doc["extensionsUsed"] = [sg, "KHR_materials_sheen", "KHR_materials_clearcoat",
                               "KHR_materials_specular", "KHR_materials_iridescence",
                               "KHR_materials_anisotropy", "EXT_spectrace_unknown", "EXT_other_unknown"]
    g.gltf("wild_specgloss.gltf")


def snorm(v, bits):
    scale = (1 << (bits - 1)) - 1
    v = max(-1.0, min(1.0, v))
    return int(v * scale + (0.5 if v >= 0 else -0.5))


def oct_encode(n):
    """meshopt_encodeFilterOct for one unit vector, 8 bits, stride 4 (the
    encoder of meshoptimizer's src/vertexfilter.cpp): u, v, 1, w as snorm8."""
    nx, ny, nz = n
    nl = abs(nx) + abs(ny) + abs(nz)
    ns = 0 if nl == 0 else 1 / nl
    nx, ny = nx * ns, ny * ns
    u = nx if nz >= 0 else (1 - abs(ny)) * (1 if nx >= 0 else -1)
    v = ny if nz >= 0 else (1 - abs(nx)) * (1 if ny >= 0 else -1)
    return [snorm(u, 8), snorm(v, 8), snorm(1, 8), 0]


def instanced_file():
    # One mesh of two primitives that share their vertex accessors (two materials),
    # on three nodes.
    g = G()
    quad = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)]
    pa, ta = g.floats(quad, "VEC3"), g.floats([(0, 0), (1, 0), (1, 1), (0, 1)], "VEC2")
    g.doc["materials"] = [{"name": "a"}, {"name": "b"}]
    prims = [{"attributes": {"POSITION": pa, "TEXCOORD_0": ta}, "indices": g.indices(ix), "material": k}
             for k, ix in enumerate([[0, 1, 2], [0, 2, 3]])]
    m = g.mesh(prims)
    for x in range(3):
        g.node(mesh=m, translation=[2 * x, 0, 0])
    g.gltf("wild_instanced.gltf")


def mesh_files():
    import numpy as np
    pos, nrm, uv, idx = grid()
    # Plain floats.
    g = G()
    g.node(mesh=g.mesh([g.prim(pos, idx, normals=nrm, uvs=uv)]))
    g.gltf("wild_plain.gltf")

    # KHR_mesh_quantization: int16 positions (not normalised) dequantised by the
    # node's scale and translation, int8 normalised normals, uint16 normalised uvs.
    lo = [min(p[k] for p in pos) for k in range(3)]
    hi = [max(p[k] for p in pos) for k in range(3)]
    # One step for all axes (as gltfpack does): a non-uniform node scale would
    # bend the normals, which the node transform also applies to.
    step = [max(hi[k] - lo[k] for k in range(3)) / 32767] * 3
    q = [[round((p[k] - lo[k]) / step[k]) for k in range(3)] for p in pos]
    g = G()
    qp = g.acc(g.view(struct.pack("<%dh" % (len(q) * 4), *[c for r in q for c in r + [0]]), stride=8),
               I16, len(q), "VEC3")
    qn = g.acc(g.view(struct.pack("<%db" % (len(nrm) * 4),
                                  *[c for r in nrm for c in [round(v * 127) for v in r] + [0]]), stride=4),
               I8, len(nrm), "VEC3", normalized=True)
    qt = g.acc(g.view(struct.pack("<%dH" % (len(uv) * 2), *[round(v * 65535) for r in uv for v in r])),
               U16, len(uv), "VEC2", normalized=True)
    prim = {"attributes": {"POSITION": qp, "NORMAL": qn, "TEXCOORD_0": qt}, "indices": g.indices(idx)}
    g.node(mesh=g.mesh([prim]), translation=lo, scale=step)
    g.doc["extensionsUsed"] = ["KHR_mesh_quantization"]
    g.doc["extensionsRequired"] = ["KHR_mesh_quantization"]
    g.gltf("wild_quantized.gltf")

    # EXT_meshopt_compression: buffer 0 holds the compressed streams, buffer 1 is
    # the uri-less fallback the views point into (as gltfpack writes them).
    import meshoptimizer as mo
    mo.encode_vertex_version(0)  # the format Debian's libmeshoptimizer 0.18 decodes
    mo.encode_index_version(1)
    comp = bytearray()
    views, accs, fallback = [], [], 0

    def add(raw, count, stride, mode, encoded):
        nonlocal fallback
        while len(comp) % 4:
            comp.append(0)
        ext = {"buffer": 0, "byteOffset": len(comp), "byteLength": len(encoded),
               "byteStride": stride, "count": count, "mode": mode}
        comp.extend(encoded)
        v = {"buffer": 1, "byteOffset": fallback, "byteLength": len(raw),
             "extensions": {"EXT_meshopt_compression": ext}}
        if mode == "ATTRIBUTES":
            v["byteStride"] = stride
        fallback += len(raw) + (-len(raw) % 4)
        views.append(v)
        return len(views) - 1
    arrays = [(np.array(pos, dtype=np.float32), "VEC3"), (np.array(nrm, dtype=np.float32), "VEC3"),
              (np.array(uv, dtype=np.float32), "VEC2")]
    for k, (arr, typ) in enumerate(arrays):
        if k == 1:
            # Normals: 8-bit octahedral (filter OCTAHEDRAL), stored as normalised
            # int8 x4 (KHR_mesh_quantization), as gltfpack writes them.
            oct_ = np.array([oct_encode(n) for n in nrm], dtype=np.int8)
            v = add(oct_.tobytes(), len(oct_), 4, "ATTRIBUTES", mo.encode_vertex_buffer(oct_, len(oct_), 4))
            views[v]["extensions"]["EXT_meshopt_compression"]["filter"] = "OCTAHEDRAL"
            accs.append({"bufferView": v, "componentType": I8, "normalized": True, "count": len(arr),
                         "type": "VEC3"})
            continue
        v = add(arr.tobytes(), len(arr), arr.shape[1] * 4, "ATTRIBUTES",
                mo.encode_vertex_buffer(arr, len(arr), arr.shape[1] * 4))
        accs.append({"bufferView": v, "componentType": FLOAT, "count": len(arr), "type": typ})
    ia = np.array(idx, dtype=np.uint32)
    v = add(ia.astype(np.uint16).tobytes(), len(ia), 2, "TRIANGLES",
            mo.encode_index_buffer(ia, len(ia), len(pos)))
    accs.append({"bufferView": v, "componentType": U16, "count": len(ia), "type": "SCALAR"})
    accs[0]["min"], accs[0]["max"] = lo, hi
    d = {"asset": {"version": "2.0", "generator": "tools/gen_wild_tests.py"},
         "extensionsUsed": ["EXT_meshopt_compression", "KHR_mesh_quantization"],
         "extensionsRequired": ["EXT_meshopt_compression", "KHR_mesh_quantization"],
         "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
         "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2}, "indices": 3}]}],
         "accessors": accs, "bufferViews": views,
         "buffers": [{"byteLength": len(comp), "uri": "data:application/octet-stream;base64,"
                      + base64.b64encode(bytes(comp)).decode()},
                     {"byteLength": fallback, "extensions": {"EXT_meshopt_compression": {"fallback": True}}}]}
    gg.write("wild_meshopt.gltf", json.dumps(d, separators=(",", ":")).encode())
    # The same as .glb: buffer 0 is the BIN chunk, the fallback has no uri.
    d["buffers"][0] = {"byteLength": len(comp)}
    binary = bytes(comp) + b"\0" * (-len(comp) % 4)
    js = json.dumps(d, separators=(",", ":")).encode()
    js += b" " * (-len(js) % 4)
    body = struct.pack("<II", len(js), 0x4E4F534A) + js + struct.pack("<II", len(binary), 0x004E4942) + binary
    gg.write("wild_meshopt.glb", struct.pack("<4sII", b"glTF", 2, 12 + len(body)) + body)

    # KHR_draco_mesh_compression, 14-bit positions, order preserved.
    import DracoPy
    blob = DracoPy.encode(np.array(pos, dtype=np.float32), np.array(idx, dtype=np.uint32).reshape(-1, 3),
                          quantization_bits=14, preserve_order=True,
                          normals=np.array(nrm, dtype=np.float64), tex_coord=np.array(uv, dtype=np.float64),
                          normal_quantization_bits=10, tex_coord_quantization_bits=12)
    pad = bytes(blob) + b"\0" * (-len(blob) % 4)
    d = {"asset": {"version": "2.0", "generator": "tools/gen_wild_tests.py"},
         "extensionsUsed": ["KHR_draco_mesh_compression"], "extensionsRequired": ["KHR_draco_mesh_compression"],
         "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
         "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2}, "indices": 3,
                                     "extensions": {"KHR_draco_mesh_compression": {
                                         "bufferView": 0, "attributes": draco_ids()}}}]}],
         "accessors": [{"componentType": FLOAT, "count": len(pos), "type": "VEC3", "min": lo, "max": hi},
                       {"componentType": FLOAT, "count": len(pos), "type": "VEC3"},
                       {"componentType": FLOAT, "count": len(pos), "type": "VEC2"},
                       {"componentType": U16, "count": len(idx), "type": "SCALAR"}],
         "bufferViews": [{"buffer": 0, "byteLength": len(blob)}],
         "buffers": [{"byteLength": len(pad), "uri": "data:application/octet-stream;base64,"
                      + base64.b64encode(pad).decode()}]}
    gg.write("wild_draco.gltf", json.dumps(d, separators=(",", ":")).encode())


def draco_ids():
    """The unique ids DracoPy 2.2 gives its attributes (read back with libdraco:
    texture coordinates 0, normals 1, positions 2)."""
    return {"POSITION": 2, "NORMAL": 1, "TEXCOORD_0": 0}


def webp_file():
    # 2x2 lossless WebP of the texels of gen_gltf_tests' PNG_2X2 (Pillow; the
    # WebP writer of OpenImageIO 2.4 is lossy even when asked for lossless).
    import io
    from PIL import Image
    im = Image.new("RGB", (2, 2))
    im.putdata([(0, 64, 128), (255, 255, 255), (128, 0, 255), (10, 20, 30)])
    out = io.BytesIO()
    im.save(out, format="WEBP", lossless=True, exact=True)
    webp = out.getvalue()
    g = G()
    g.doc["images"] = [{"uri": "data:image/png;base64," + base64.b64encode(gg.png(1, 1, [[9, 9, 9]])).decode()},
                       {"mimeType": "image/webp", "bufferView": g.view(webp)}]
    g.doc["textures"] = [{"source": 0, "extensions": {"EXT_texture_webp": {"source": 1}}}]
    g.doc["materials"] = [{"name": "webp", "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}]
    g.node(mesh=g.mesh([g.prim(gg.TRI, [0, 1, 2], material=0)]))
    g.doc["extensionsUsed"] = ["EXT_texture_webp"]
    g.glb("wild_webp.glb")


if __name__ == "__main__":
    os.makedirs(OUT, exist_ok=True)
    material_files()
    instanced_file()
    mesh_files()
    webp_file()
