#!/usr/bin/env python3
"""Writes the texture and material-layer test scenes of tests/test_textures.c into
tests/data/textures/.

    python3 tools/make_texture_scenes.py [OUT_DIR]

Each scene is a small self-contained .gltf (buffers and PNG images as data URIs):
mostly a 2 x 2 m plane at z = 0 seen head-on by an orthographic camera whose view
is exactly the plane, so image pixel (x, y) of a W x H render sees texture
coordinate ((x + 0.5) / W, (y + 0.5) / H): the rendered image is the texture the
right way up when the glTF orientation rule holds (uv (0, 0) is the first pixel
of the image, its upper-left corner). The test asserts where the texture's cells
land. Which values each scene must give, and why, is in tests/test_textures.c.
Only the standard library is used; the output is deterministic."""
import json
import os
import struct
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import gen_gltf_tests as gg  # noqa: E402  (png(), the G document builder)

OUT = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), "..", "tests", "data",
                                                            "textures")
FLOAT, U8, U16 = 5126, 5121, 5123


def data_uri_png(png_bytes):
    import base64
    return "data:image/png;base64," + base64.b64encode(png_bytes).decode()


def cells_png(cells, px, channels=3):
    """A PNG of a grid of cells (cells[row][col] = tuple of 8-bit channel values),
    each cell px x px pixels; row 0 is the top of the image."""
    rows = []
    for crow in cells:
        line = []
        for c in crow:
            line += list(c) * px
        rows += [line] * px
    return gg.png(len(cells[0]) * px, len(cells) * px, rows, channels)


# The base colour pattern: 4 x 4 cells of 16 different sRGB colours, none of them
# equal to another under a flip or a transpose of the grid. Components from
# {40, 120, 200} (linear 0.0212, 0.188, 0.578).
LEVELS = (40, 120, 200)
PALETTE = [(LEVELS[(i // 9) % 3], LEVELS[(i // 3) % 3], LEVELS[i % 3]) for i in range(27)]
BASE_CELLS = [[PALETTE[(5 * (r * 4 + c) + 3) % 27] for c in range(4)] for r in range(4)]


class Scene(gg.G):
    """A glTF document with materials, textures, samplers and images."""

    def __init__(self):
        super().__init__()
        self.doc["asset"]["generator"] = "tools/make_texture_scenes.py"
        for k in ("materials", "textures", "images", "samplers", "cameras"):
            self.doc[k] = []

    def image(self, png_bytes):
        self.doc["images"].append({"uri": data_uri_png(png_bytes), "mimeType": "image/png"})
        return len(self.doc["images"]) - 1

    def texture(self, png_bytes, sampler=None):
        t = {"source": self.image(png_bytes)}
        if sampler is not None:
            self.doc["samplers"].append(sampler)
            t["sampler"] = len(self.doc["samplers"]) - 1
        self.doc["textures"].append(t)
        return len(self.doc["textures"]) - 1

    def material(self, m):
        self.doc["materials"].append(m)
        return len(self.doc["materials"]) - 1

    def ortho_camera(self, z=2.0, half=1.0):
        self.doc["cameras"].append({"type": "orthographic",
                                    "orthographic": {"xmag": half, "ymag": half, "znear": 0.01, "zfar": 100}})
        self.node(camera=len(self.doc["cameras"]) - 1, translation=[0, 0, z])

    def grid_plane(self, material, n=1, extra=None, uv=True, z=0.0):
        """The plane [-1, 1]^2 at height z as an n x n grid of quads (normal +Z),
        TEXCOORD_0 = ((x + 1) / 2, (1 - y) / 2): the image upright in the camera's
        view. extra(attributes, xs, ys): adds attributes given the vertex
        coordinates."""
        xs, ys, pos = [], [], []
        for j in range(n + 1):
            for i in range(n + 1):
                x, y = -1 + 2 * i / n, -1 + 2 * j / n
                xs.append(x)
                ys.append(y)
                pos.append((x, y, z))
        idx = []
        for j in range(n):
            for i in range(n):
                a = j * (n + 1) + i
                idx += [a, a + 1, a + n + 2, a, a + n + 2, a + n + 1]
        p = {"attributes": {"POSITION": self.floats(pos, "VEC3")}, "indices": self.indices(idx),
             "material": material}
        self.doc["accessors"][p["attributes"]["POSITION"]].update(min=[-1, -1, z], max=[1, 1, z])
        if uv:
            p["attributes"]["TEXCOORD_0"] = self.floats([((x + 1) / 2, (1 - y) / 2) for x, y in zip(xs, ys)],
                                                        "VEC2")
        if extra:
            extra(self, p["attributes"], xs, ys)
        self.node(mesh=self.mesh([p]))
        return p

    def save(self, name):
        d = self.finish()
        for k in ("materials", "textures", "images", "samplers", "cameras"):
            if not d[k]:
                del d[k]
        import base64
        d["buffers"] = [{"byteLength": len(self.bin), "uri": "data:application/octet-stream;base64,"
                         + base64.b64encode(bytes(self.bin)).decode()}]
        with open(os.path.join(OUT, name), "w") as f:
            json.dump(d, f, separators=(",", ":"))
            f.write("\n")


def lambert(extra=None, **pbr):
    """A Lambertian material (metallic 0, KHR_materials_specular factor 0): under
    the default sky of radiance 1 it shows its albedo."""
    m = {"pbrMetallicRoughness": dict({"metallicFactor": 0.0}, **pbr),
         "extensions": {"KHR_materials_specular": {"specularFactor": 0.0}}}
    if extra:
        m.update(extra)
    return m


def base_scenes():
    png = cells_png(BASE_CELLS, 4)
    # No sampler, and an empty sampler object: both mean linear filtering, repeat.
    for name, sampler in (("base_nosampler.gltf", None), ("base_emptysampler.gltf", {})):
        s = Scene()
        tex = s.texture(png, sampler)
        s.grid_plane(s.material(lambert(baseColorTexture={"index": tex})))
        s.ortho_camera()
        s.save(name)


if __name__ == "__main__":
    os.makedirs(OUT, exist_ok=True)
    base_scenes()
