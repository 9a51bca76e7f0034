#!/usr/bin/env python3
"""Writes the small glTF test files of tests/test_gltf.c into tests/data/gltf/.

    python3 tools/gen_gltf_tests.py [OUT_DIR]

Every file is a few hundred bytes: valid scenes whose loaded values the test
checks against hand-computed numbers, and broken ones (one defect each) that the
loader must refuse with an error naming the object. Only the standard library is
used (PNG images are written with zlib)."""
import base64
import copy
import json
import math
import os
import struct
import sys
import zlib

from gltf_doc import GltfDoc

OUT = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), "..", "tests", "data", "gltf")

FLOAT, U8, U16, U32 = 5126, 5121, 5123, 5125


def png(width, height, rows, channels=3):
    """An 8-bit PNG; rows = list of bytes objects (top row first)."""
    ctype = {1: 0, 2: 4, 3: 2, 4: 6}[channels]
    raw = b"".join(b"\x00" + bytes(r) for r in rows)

    def chunk(tag, data):
        c = struct.pack(">I", len(data)) + tag + data
        return c + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF)

    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, ctype, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))


# 2x2 RGB: top row (0,64,128) (255,255,255); bottom row (128,0,255) (10,20,30)
PNG_2X2 = png(2, 2, [[0, 64, 128, 255, 255, 255], [128, 0, 255, 10, 20, 30]])


class G(GltfDoc):
    """A glTF document with one binary buffer built up in memory."""

    def __init__(self):
        super().__init__("tools/gen_gltf_tests.py")

    def acc(self, view, ctype, count, typ, offset=0, normalized=False, **kw):
        a = {"bufferView": view, "componentType": ctype, "count": count, "type": typ}
        if offset:
            a["byteOffset"] = offset
        if normalized:
            a["normalized"] = True
        a.update(kw)
        self.doc["accessors"].append(a)
        return len(self.doc["accessors"]) - 1

    def floats(self, rows, typ):
        flat = [x for r in rows for x in r]
        return self.acc(self.view(struct.pack("<%df" % len(flat), *flat)), FLOAT, len(rows), typ)

    def indices(self, idx, ctype=U16):
        fmt = {U8: "B", U16: "H", U32: "I"}[ctype]
        return self.acc(self.view(struct.pack("<%d%s" % (len(idx), fmt), *idx)), ctype, len(idx), "SCALAR")

    def prim(self, pos, idx=None, ctype=U16, mode=None, material=None, normals=None, uvs=None):
        p = {"attributes": {"POSITION": self.floats(pos, "VEC3")}}
        if normals:
            p["attributes"]["NORMAL"] = self.floats(normals, "VEC3")
        if uvs:
            p["attributes"]["TEXCOORD_0"] = self.floats(uvs, "VEC2")
        if idx is not None:
            p["indices"] = self.indices(idx, ctype)
        if mode is not None:
            p["mode"] = mode
        if material is not None:
            p["material"] = material
        return p

    def mesh(self, prims):
        self.doc["meshes"].append({"primitives": prims})
        return len(self.doc["meshes"]) - 1

    def node(self, root=True, **kw):
        self.doc["nodes"].append(kw)
        n = len(self.doc["nodes"]) - 1
        if root:
            self.doc["scenes"][0]["nodes"].append(n)
        return n

    def finish(self):
        d = copy.deepcopy(self.doc)
        for k in ["nodes", "meshes", "accessors", "bufferViews", "buffers"]:
            if not d[k] and k != "buffers":
                del d[k]
        return d

    def gltf(self, name, external_bin=None, mutate=None):
        d = self.finish()
        if self.bin:
            if external_bin:
                with open(os.path.join(OUT, external_bin), "wb") as f:
                    f.write(self.bin)
                d["buffers"] = [{"byteLength": len(self.bin), "uri": external_bin}]
            else:
                d["buffers"] = [{"byteLength": len(self.bin), "uri": "data:application/octet-stream;base64,"
                                 + base64.b64encode(bytes(self.bin)).decode()}]
        else:
            d.pop("buffers", None)
        if mutate:
            mutate(d)
        write(name, json.dumps(d, separators=(",", ":")).encode())

    def glb(self, name):
        d = self.finish()
        binary = bytes(self.bin) + b"\0" * (-len(self.bin) % 4)
        d["buffers"] = [{"byteLength": len(self.bin)}]
        js = json.dumps(d, separators=(",", ":")).encode()
        js += b" " * (-len(js) % 4)
        body = struct.pack("<II", len(js), 0x4E4F534A) + js + struct.pack("<II", len(binary), 0x004E4942) + binary
        write(name, struct.pack("<4sII", b"glTF", 2, 12 + len(body)) + body)


def write(name, data):
    with open(os.path.join(OUT, name), "wb") as f:
        f.write(data)


TRI = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
TRI_N = [(0, 0, 1)] * 3
TRI_UV = [(0, 0), (1, 0), (0, 1)]


def tri_scene(**node):
    g = G()
    m = g.mesh([g.prim(TRI, [0, 1, 2], normals=TRI_N, uvs=TRI_UV)])
    g.node(mesh=m, **node)
    return g


def valid_files():
    # External .bin, TRS translation.
    tri_scene(translation=[1, 2, 3]).gltf("tri_external.gltf", external_bin="tri_external.bin")
    # Data URI, matrix: scale 2 then translate (0, 0, -5) (column-major).
    tri_scene(matrix=[2, 0, 0, 0, 0, 2, 0, 0, 0, 0, 2, 0, 0, 0, -5, 1]).gltf("tri_datauri.gltf")
    # GLB, rotation 90 degrees about +Z: (x, y, z) -> (-y, x, z); scale 3 on x first.
    s = math.sqrt(0.5)
    tri_scene(rotation=[0, 0, s, s], scale=[3, 1, 1]).glb("tri.glb")
    # Mirrored: scale -1 on x.
    tri_scene(scale=[-1, 1, 1]).gltf("mirrored.gltf")

    # Primitive modes and index types: one mesh, several primitives.
    g = G()
    strip = [(0, 0, 0), (0, 1, 0), (1, 0, 0), (1, 1, 0), (2, 0, 0)]
    fan = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (-1, 1, 0)]
    quad = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)]
    prims = [g.prim(strip, mode=5),                      # 3 triangles, no indices
             g.prim(fan, [0, 1, 2, 3, 4], mode=6),        # 3 triangles, u16
             g.prim(quad, [0, 1, 2, 0, 2, 3], ctype=U8),  # 2 triangles
             g.prim(quad, [0, 1, 2, 0, 2, 3], ctype=U32),  # 2 triangles
             g.prim(quad, mode=0),                       # points: skipped
             g.prim(quad, [0, 1, 1, 2], mode=1)]         # lines: skipped
    g.node(mesh=g.mesh(prims), translation=[0, 0, 1])
    g.gltf("modes.gltf")

    # Garbage geometry: one good triangle among bad ones.
    g = G()
    nan, inf = float("nan"), float("inf")
    pos = [(0, 0, 0), (1, 0, 0), (0, 1, 0),      # good
           (nan, 0, 0), (1, 0, 0), (0, 1, 0),    # NaN
           (0, 0, 0), (inf, 0, 0), (0, 1, 0),    # Inf
           (0, 0, 0), (1e19, 0, 0), (0, 1, 0),   # huge
           (0, 0, 0), (1, 1, 1), (2, 2, 2)]      # collinear: zero area
    idx = list(range(15)) + [0, 1, 1]            # repeated index
    g.node(mesh=g.mesh([g.prim(pos, idx)]))
    g.gltf("garbage.gltf")

    # Materials, textures, extensions and extras.
    g = G()
    img_view = g.view(PNG_2X2)
    m = g.mesh([g.prim(TRI, [0, 1, 2], material=i, uvs=TRI_UV) for i in range(5)]
               + [g.prim(TRI, [0, 1, 2])])  # no material: the default one
    g.node(mesh=m)
    d = g.doc
    d["images"] = [{"bufferView": img_view, "mimeType": "image/png"},
                   {"uri": "tex_2x2.png"},
                   {"uri": "data:image/png;base64," + base64.b64encode(PNG_2X2).decode()},
                   {"uri": "../../test_util.h"},
                   {"uri": "missing.png"},
                   {"uri": "corrupt.png"}]
    d["samplers"] = [{"wrapS": 33071, "wrapT": 33648}]
    d["textures"] = [{"source": 0, "sampler": 0}, {"source": 1}, {"source": 2},
                     {"source": 3}, {"source": 4}, {"source": 5}]
    d["extensionsUsed"] = ["KHR_materials_emissive_strength", "KHR_materials_ior",
                           "KHR_materials_transmission", "KHR_materials_dispersion",
                           "KHR_materials_volume", "KHR_materials_unlit", "KHR_texture_transform"]
    d["materials"] = [
        {"name": "textured",
         "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.25, 1, 1], "baseColorTexture": {"index": 0},
                                  "metallicFactor": 0.3, "roughnessFactor": 0.7,
                                  "metallicRoughnessTexture": {"index": 0}},
         "normalTexture": {"index": 1, "scale": 0.5},
         "emissiveTexture": {"index": 2}, "emissiveFactor": [1, 0.5, 0.25],
         "alphaMode": "MASK", "alphaCutoff": 0.3, "doubleSided": True,
         "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 4.0}}},
        {"name": "glass",
         "extensions": {"KHR_materials_ior": {"ior": 1.7},
                        "KHR_materials_transmission": {"transmissionFactor": 0.9, "transmissionTexture": {"index": 1}},
                        "KHR_materials_dispersion": {"dispersion": 20},
                        "KHR_materials_volume": {"thicknessFactor": 0.1, "attenuationDistance": 2.0,
                                                 "attenuationColor": [0.9, 0.8, 0.7]}},
         "alphaMode": "BLEND"},
        {"name": "lamp", "emissiveFactor": [1, 1, 1],
         "extensions": {"KHR_materials_unlit": {}},
         "extras": {"spectrace": {"emission": "D65",
                                  "reflectance": [[400, 0.1], [500, 0.5], [700, 0.9]]}}},
        {"name": "gold", "extras": {"spectrace": {"conductor": "Au"}, "other": 1}},
        {"name": "fallbacks", "pbrMetallicRoughness": {"baseColorTexture": {"index": 3},
                                                       "metallicRoughnessTexture": {"index": 4}},
         "emissiveTexture": {"index": 5}}]
    g.gltf("materials.gltf")
    write("tex_2x2.png", PNG_2X2)
    write("corrupt.png", PNG_2X2[:40])

    # Lights and a camera under a parent transform.
    g = G()
    s = math.sqrt(0.5)
    g.node(mesh=g.mesh([g.prim(TRI, [0, 1, 2])]))
    cam = g.node(root=False, camera=0, rotation=[-s, 0, 0, s])  # looks down -Y
    g.node(translation=[0, 10, 0], children=[cam])
    g.node(translation=[1, 2, 3], extensions={"KHR_lights_punctual": {"light": 0}})
    g.node(translation=[0, 5, 0], rotation=[-s, 0, 0, s], extensions={"KHR_lights_punctual": {"light": 1}})
    g.node(rotation=[0, s, 0, s], extensions={"KHR_lights_punctual": {"light": 2}})  # -Z -> -X
    d = g.doc
    d["cameras"] = [{"type": "perspective", "perspective": {"yfov": 0.8, "aspectRatio": 1.5, "znear": 0.1, "zfar": 100}},
                    {"type": "perspective", "perspective": {"yfov": 0.3, "znear": 0.1}}]
    g.node(camera=1)  # a second camera: not used
    d["extensionsUsed"] = ["KHR_lights_punctual"]
    d["extensionsRequired"] = ["KHR_lights_punctual"]
    d["extensions"] = {"KHR_lights_punctual": {"lights": [
        {"type": "point", "color": [1, 0.5, 0.25], "intensity": 100, "range": 20, "name": "bulb"},
        {"type": "spot", "intensity": 50, "spot": {"innerConeAngle": 0.2, "outerConeAngle": 0.5}},
        {"type": "directional", "intensity": 3}]}}
    g.gltf("lights.gltf")

    # Lights with spectra of their own (extras.spectrace.emission): a named SPD
    # of lines (its colour is replaced), an inline table, a named continuum.
    g = tri_scene()
    g.node(translation=[0, 2, 0], extensions={"KHR_lights_punctual": {"light": 0}})
    g.node(translation=[0, 3, 0], rotation=[-s, 0, 0, s], extensions={"KHR_lights_punctual": {"light": 1}})
    g.node(extensions={"KHR_lights_punctual": {"light": 2}})
    g.doc["extensionsUsed"] = ["KHR_lights_punctual"]
    g.doc["extensions"] = {"KHR_lights_punctual": {"lights": [
        {"type": "point", "name": "hg", "color": [1, 0, 0], "intensity": 100,
         "extras": {"spectrace": {"emission": "mercury"}}},
        {"type": "spot", "intensity": 50, "spot": {"innerConeAngle": 0.2, "outerConeAngle": 0.5},
         "extras": {"spectrace": {"emission": [[700, 1], [400, 1]]}}},
        {"type": "directional", "intensity": 3, "extras": {"spectrace": {"emission": "D65"}}}]}}
    g.gltf("spectral_lights.gltf")

    g = tri_scene()
    g.node(camera=0, translation=[0, 0, 5])
    g.doc["cameras"] = [{"type": "orthographic", "orthographic": {"xmag": 2, "ymag": 1, "znear": 0.01, "zfar": 50}}]
    g.gltf("ortho.gltf")


def bad(name, mutate, base=None):
    (base or tri_scene()).gltf(name, mutate=mutate)


def bad_files():
    write("bad_empty.gltf", b"")
    write("bad_notjson.gltf", b"hello, this is not JSON")
    tri_scene().gltf("_tmp.gltf")
    full = open(os.path.join(OUT, "_tmp.gltf"), "rb").read()
    os.remove(os.path.join(OUT, "_tmp.gltf"))
    write("bad_truncated.gltf", full[: len(full) // 2])
    tri_scene().glb("_tmp.glb")
    glb = bytearray(open(os.path.join(OUT, "_tmp.glb"), "rb").read())
    os.remove(os.path.join(OUT, "_tmp.glb"))
    v = bytearray(glb); v[4] = 1
    write("bad_glb_version.glb", bytes(v))
    write("bad_glb_truncated.glb", bytes(glb[:-8]))
    v = bytearray(glb)
    jl = struct.unpack_from("<I", v, 12)[0]
    struct.pack_into("<I", v, 20 + jl, 4096)  # BIN chunk longer than the file
    write("bad_glb_chunk.glb", bytes(v))
    v = bytearray(glb); v[0:4] = b"glTf"
    write("bad_glb_magic.glb", bytes(v))
    # tinygltf 2.7 checks the BIN chunk against the file without its 8-byte
    # header, so this one made it read past the end: a regression file.
    os.makedirs(os.path.join(OUT, "regress"), exist_ok=True)
    v = bytearray(glb)
    struct.pack_into("<I", v, 20 + jl, len(glb) - 20 - jl - 4)
    write(os.path.join("regress", "glb_bin_chunk_off_by_8.glb"), bytes(v))

    def set_(path, value):
        def f(d):
            o = d
            for k in path[:-1]:
                o = o[k]
            if value is DELETE:
                del o[path[-1]]
            else:
                o[path[-1]] = value
        return f

    bad("bad_no_version.gltf", set_(["asset", "version"], DELETE))
    bad("bad_version.gltf", set_(["asset", "version"], "1.0"))
    # Dangling indices.
    bad("bad_dangling_accessor.gltf", set_(["meshes", 0, "primitives", 0, "attributes", "POSITION"], 9))
    bad("bad_dangling_bufferview.gltf", set_(["accessors", 1, "bufferView"], 9))
    bad("bad_dangling_mesh.gltf", set_(["nodes", 0, "mesh"], 3))
    bad("bad_dangling_material.gltf", set_(["meshes", 0, "primitives", 0, "material"], 2))
    bad("bad_dangling_node.gltf", set_(["nodes", 0, "children"], [5]))
    bad("bad_dangling_scene_node.gltf", set_(["scenes", 0, "nodes"], [0, 4]))

    def dangling_texture(d):
        d["materials"] = [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 4}}}]
        d["meshes"][0]["primitives"][0]["material"] = 0
    bad("bad_dangling_texture.gltf", dangling_texture)
    # Ranges. accessors: 0 POSITION, 1 NORMAL, 2 TEXCOORD_0, 3 indices (views alike).
    bad("bad_accessor_range.gltf", set_(["accessors", 0, "count"], 4))
    bad("bad_accessor_offset.gltf", set_(["accessors", 0, "byteOffset"], 8))
    bad("bad_view_range.gltf", set_(["bufferViews", 3, "byteLength"], 400))
    bad("bad_count0.gltf", set_(["accessors", 0, "count"], 0))
    bad("bad_count_overflow.gltf", set_(["accessors", 0, "count"], 2 ** 62 + 1))
    bad("bad_stride.gltf", set_(["bufferViews", 0, "byteStride"], 8))  # < 12-byte VEC3
    # Indices and types.
    g = tri_scene()
    g.doc["meshes"][0]["primitives"][0]["indices"] = g.indices([0, 1, 7])
    g.gltf("bad_index_range.gltf")
    bad("bad_position_type.gltf", set_(["accessors", 0, "componentType"], U16))
    bad("bad_position_vec2.gltf", set_(["accessors", 0, "type"], "VEC2"))
    bad("bad_index_float.gltf", set_(["accessors", 3, "componentType"], FLOAT))
    bad("bad_unequal_counts.gltf", set_(["accessors", 1, "count"], 2))
    bad("bad_mode.gltf", set_(["meshes", 0, "primitives", 0, "mode"], 9))
    # Hierarchy.
    g = tri_scene()
    a = g.node(root=False, children=[2])
    g.doc["nodes"][a]["children"] = [a + 1]
    g.node(root=False, children=[a])
    g.gltf("bad_node_loop.gltf")
    g = tri_scene()
    g.doc["nodes"][0]["children"] = [0]
    g.gltf("bad_node_self.gltf")
    g = tri_scene()
    c = g.node(root=False)
    g.doc["nodes"][0]["children"] = [c]
    g.node(children=[c])
    g.gltf("bad_two_parents.gltf")
    # Extensions.
    bad("bad_ext_required.gltf", lambda d: d.update(
        extensionsUsed=["KHR_texture_basisu", "EXT_spectrace_nope", "KHR_materials_ior",
                        "KHR_draco_mesh_compression"],
        extensionsRequired=["KHR_texture_basisu", "KHR_materials_ior", "EXT_spectrace_nope",
                            "KHR_draco_mesh_compression"]))
    # Cameras.
    def cam(persp):
        def f(d):
            d["cameras"] = [{"type": "perspective", "perspective": persp}]
            d["nodes"][0]["camera"] = 0
        return f
    bad("bad_camera_yfov.gltf", cam({"yfov": 0, "znear": 0.1}))
    bad("bad_camera_zfar.gltf", cam({"yfov": 0.5, "znear": 1, "zfar": 0.5}))
    # Buffers.
    bad("bad_buffer_missing.gltf", lambda d: d["buffers"][0].update(uri="missing.bin"))
    bad("bad_buffer_escape.gltf", lambda d: d["buffers"][0].update(uri="../../../README.md"))
    bad("bad_buffer_size.gltf", lambda d: d["buffers"][0].update(uri="tri_external.bin", byteLength=8))
    # Required properties and JSON types that tinygltf checks (named by us).
    bad("bad_accessor_no_type.gltf", set_(["accessors", 2, "componentType"], DELETE))
    bad("bad_node_not_object.gltf", set_(["nodes", 0], 3))
    bad("bad_buffer_datauri.gltf", lambda d: d["buffers"][0].update(byteLength=d["buffers"][0]["byteLength"] + 4))
    # Spectral extras.
    def extras(x):
        def f(d):
            d["materials"] = [{"name": "lamp", "extras": {"spectrace": x}}]
            d["meshes"][0]["primitives"][0]["material"] = 0
        return f
    bad("bad_extras_name.gltf", extras({"emission": "no-such-illuminant"}))
    bad("bad_extras_table.gltf", extras({"reflectance": [[400, 0.5], [500]]}))
    bad("bad_extras_key.gltf", extras({"emision": "D65"}))
    bad("bad_extras_conductor.gltf", extras({"conductor": "Unobtainium"}))
    # Lights.
    bad("bad_light.gltf", lambda d: (d.update(extensions={"KHR_lights_punctual": {"lights": [
        {"type": "spot", "spot": {"innerConeAngle": 0.8, "outerConeAngle": 0.4}}]}}),
        d["nodes"][0].update(extensions={"KHR_lights_punctual": {"light": 0}})))
    def light_extras(x):
        def f(d):
            d.update(extensions={"KHR_lights_punctual": {"lights": [
                {"type": "point", "name": "lamp", "extras": {"spectrace": x}}]}})
            d["nodes"][0].update(extensions={"KHR_lights_punctual": {"light": 0}})
        return f
    bad("bad_light_extras_name.gltf", light_extras({"emission": "D56"}))
    bad("bad_light_extras_table.gltf", light_extras({"emission": [[400, 1], [500, -1]]}))
    bad("bad_light_extras_key.gltf", light_extras({"emision": "D65"}))
    bad("bad_light_extras_dark.gltf", light_extras({"emission": [[200, 1], [300, 1]]}))
    bad("bad_light_index.gltf", lambda d: d["nodes"][0].update(extensions={"KHR_lights_punctual": {"light": 3}}))


class _Delete:
    pass


DELETE = _Delete()

if __name__ == "__main__":
    os.makedirs(OUT, exist_ok=True)
    valid_files()
    bad_files()
