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
import math
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

    def grid_plane(self, material, n=1, extra=None, uv=True, z=0.0, scale=1.0):
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
                pos.append((scale * x, scale * y, z))
        idx = []
        for j in range(n):
            for i in range(n):
                a = j * (n + 1) + i
                idx += [a, a + 1, a + n + 2, a, a + n + 2, a + n + 1]
        p = {"attributes": {"POSITION": self.floats(pos, "VEC3")}, "indices": self.indices(idx),
             "material": material}
        self.doc["accessors"][p["attributes"]["POSITION"]].update(min=[-scale, -scale, z], max=[scale, scale, z])
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


def material(base=None, specular=None, extensions=None, **kw):
    """A material dict: pbrMetallicRoughness from base (metallic 0 unless given),
    KHR_materials_specular factor `specular` (0: Lambertian; None: absent), other
    extensions and top-level keys."""
    m = {"pbrMetallicRoughness": dict({"metallicFactor": 0.0}, **(base or {}))}
    ext = dict(extensions or {})
    if specular is not None:
        ext["KHR_materials_specular"] = dict({"specularFactor": specular}, **ext.get("KHR_materials_specular", {}))
    if ext:
        m["extensions"] = ext
    m.update(kw)
    return m


def lambert(extra=None, **pbr):
    """A Lambertian material (metallic 0, KHR_materials_specular factor 0): under
    the default sky of radiance 1 it shows its albedo."""
    m = material(pbr, specular=0.0)
    if extra:
        m.update(extra)
    return m


def quat_z_to(d):
    """The unit quaternion [x, y, z, w] rotating +Z onto unit vector d (a node's
    -Z, where cameras look and lights shine, then points along -d)."""
    z = (0.0, 0.0, 1.0)
    c = sum(a * b for a, b in zip(z, d))
    axis = (z[1] * d[2] - z[2] * d[1], z[2] * d[0] - z[0] * d[2], z[0] * d[1] - z[1] * d[0])
    n = math.sqrt(sum(a * a for a in axis))
    if n < 1e-12:
        return [0.0, 0.0, 0.0, 1.0] if c > 0 else [1.0, 0.0, 0.0, 0.0]
    half = math.acos(max(-1.0, min(1.0, c))) / 2
    return [a / n * math.sin(half) for a in axis] + [math.cos(half)]


def directional_light(s, toward_light, lux=math.pi):
    """A white directional light of `lux` (pi: a white Lambertian facing it reads
    1) shining from direction toward_light (unit, from the surface to the light)."""
    ext = s.doc.setdefault("extensions", {}).setdefault("KHR_lights_punctual", {"lights": []})
    ext["lights"].append({"type": "directional", "intensity": lux})
    s.doc.setdefault("extensionsUsed", []).append("KHR_lights_punctual")
    s.node(rotation=quat_z_to(toward_light), extensions={"KHR_lights_punctual": {"light": len(ext["lights"]) - 1}})


def uses(s, *names):
    for n in names:
        if n not in s.doc.setdefault("extensionsUsed", []):
            s.doc["extensionsUsed"].append(n)


def save_plane(s, mat, name, *used, lit=False):
    """Saves s as name: the grid plane of material mat seen by the orthographic
    camera, lit head-on by pi lux when lit, with the extensions used."""
    s.grid_plane(mat)
    s.ortho_camera()
    if lit:
        directional_light(s, (0.0, 0.0, 1.0))
    uses(s, *used)
    s.save(name)


def base_scenes():
    png = cells_png(BASE_CELLS, 4)
    # No sampler, and an empty sampler object: both mean linear filtering, repeat.
    for name, sampler in (("base_nosampler.gltf", None), ("base_emptysampler.gltf", {})):
        s = Scene()
        tex = s.texture(png, sampler)
        s.grid_plane(s.material(lambert(baseColorTexture={"index": tex})))
        s.ortho_camera()
        s.save(name)
    # The same texture times a coloured baseColorFactor.
    s = Scene()
    tex = s.texture(png)
    save_plane(s, s.material(lambert(baseColorFactor=list(BASE_FACTOR), baseColorTexture={"index": tex})),
               "base_factor.gltf")


BASE_FACTOR = (0.5, 0.8, 1.0, 1.0)


def grid_cells(values, px=4, channels=3):
    """A 4 x 4 grid image of cells[row][col] given as tuples."""
    return cells_png(values, px, channels)


# A 4 x 4 arrangement of four kinds of cell (0..3) with no symmetry under flips
# and transposes of the grid, for the data textures.
KIND_GRID = [[0, 1, 2, 3],
             [1, 1, 0, 2],
             [3, 0, 2, 2],
             [0, 3, 3, 1]]


ALPHA_RGB = ((200, 100, 50), (40, 200, 120), (120, 40, 200), (200, 200, 40))


def alpha_scenes():
    """Lambertian planes whose base colour texture's alpha (linear) cuts or blends
    them over the white sky: black (factor 0) with BLEND shows 1 - alpha, with
    MASK (cutoff 0.6) 1 where alpha < 0.6, else 0; white and OPAQUE shows the
    texels' colours whatever their alpha (glTF's colours are not premultiplied)."""
    alphas = (51, 128, 204, 255)  # 0.2, 0.502, 0.8, 1
    png = grid_cells([[ALPHA_RGB[k] + (alphas[k],) for k in row] for row in KIND_GRID], channels=4)
    for name, mode, factor in (("alpha_blend.gltf", {"alphaMode": "BLEND"}, 0),
                               ("alpha_mask.gltf", {"alphaMode": "MASK", "alphaCutoff": 0.6}, 0),
                               ("alpha_opaque.gltf", {}, 1)):
        s = Scene()
        tex = s.texture(png)
        s.grid_plane(s.material(material({"baseColorFactor": [factor] * 3 + [1], "baseColorTexture": {"index": tex}},
                                         specular=0.0, **mode)))
        s.ortho_camera()
        uses(s, "KHR_materials_specular")
        s.save(name)


def alpha_mask_far_scene():
    """A black plane cut out (MASK, cutoff 0.5) by a checkerboard of alpha 0 and 1
    texels repeated 64 times across it, eight texels to a pixel of a 64-pixel
    image: half of it is there (bilinear alpha >= 0.5 on exactly half of a
    checkerboard, by its symmetry a <-> 1 - a), so it reads 0.5 over the white
    sky."""
    def fine_uv(s, attrs, xs, ys):
        attrs["TEXCOORD_0"] = s.floats([(32 * (x + 1), 32 * (1 - y)) for x, y in zip(xs, ys)], "VEC2")
    rows = [[v for x in range(8) for v in (0, 0, 0, 255 if (x + y) % 2 == 0 else 0)] for y in range(8)]
    s = Scene()
    tex = s.texture(gg.png(8, 8, rows, 4))
    s.grid_plane(s.material(material({"baseColorFactor": [0, 0, 0, 1], "baseColorTexture": {"index": tex}},
                                     specular=0.0, alphaMode="MASK", alphaCutoff=0.5)), extra=fine_uv)
    s.ortho_camera()
    uses(s, "KHR_materials_specular")
    s.save("alpha_mask_far.gltf")


def metallic_roughness_scene():
    """A white plane (metallic and roughness factors 1) whose metallicRoughness
    texture (B metallic, G roughness, linear) has four kinds of cell, lit head-on
    by a directional light of pi lux under a black sky."""
    kinds = [(0, 255, 255), (0, 128, 255), (0, 0, 255), (0, 255, 0)]  # (R, G rough, B metal)
    png = grid_cells([[kinds[k] for k in row] for row in KIND_GRID])
    s = Scene()
    tex = s.texture(png)
    save_plane(s, s.material(material({"metallicFactor": 1.0, "roughnessFactor": 1.0,
                                       "metallicRoughnessTexture": {"index": tex}})),
               "metallic_roughness.gltf", lit=True)


NORMAL_CODES = [(128, 128, 255),   # flat
                (218, 128, 218),   # tilted toward +X (the texture's right)
                (38, 128, 218),    # toward -X
                (128, 218, 218)]   # toward the texture's +Y (up in the image)


def normal_scene():
    """A white Lambertian plane with a normal texture of four kinds of cell (scale
    0.7), lit by a directional light of pi lux from normalize(2, 1, 3) under a
    black sky: each cell shows the cosine between its normal and the light."""
    png = grid_cells([[NORMAL_CODES[k] for k in row] for row in KIND_GRID])

    def mirrored(s, attrs, xs, ys):
        attrs["TEXCOORD_0"] = s.floats([((1 - x) / 2, (1 - y) / 2) for x, y in zip(xs, ys)], "VEC2")
    # The second file mirrors the texture coordinates (u grows toward -X): the
    # tangent follows u, the bitangent still points to the image's top (+Y).
    for name, extra in (("normal.gltf", None), ("normal_mirrored.gltf", mirrored)):
        s = Scene()
        tex = s.texture(png)
        s.grid_plane(s.material(lambert(normalTexture={"index": tex, "scale": 0.7})), extra=extra)
        s.doc["materials"][-1]["normalTexture"] = s.doc["materials"][-1]["pbrMetallicRoughness"].pop("normalTexture")
        s.ortho_camera()
        n = math.sqrt(14.0)
        directional_light(s, (2 / n, 1 / n, 3 / n))
        s.save(name)


def emissive_scene():
    """A black plane whose emissive texture (the base pattern, sRGB) times
    emissiveFactor (1, 0.8, 0.6) times KHR_materials_emissive_strength 2 shows
    under a black sky."""
    s = Scene()
    tex = s.texture(cells_png(BASE_CELLS, 4))
    save_plane(s, s.material(material({"baseColorFactor": [0, 0, 0, 1]}, specular=0.0,
                                      extensions={"KHR_materials_emissive_strength": {"emissiveStrength": 2.0}},
                                      emissiveFactor=[1.0, 0.8, 0.6], emissiveTexture={"index": tex})),
               "emissive.gltf", "KHR_materials_emissive_strength", "KHR_materials_specular")


def transmission_scene():
    """A smooth white plane of ior 1 (no refraction, no Fresnel) with transmission
    factor 1 times its transmission texture (R, linear), in front of an emitter
    of radiance 1 under a black sky: each cell shows its transmission."""
    levels = (0, 64, 128, 255)
    s = Scene()
    tex = s.texture(grid_cells([[(levels[k], 0, 0) for k in row] for row in KIND_GRID]))
    s.grid_plane(s.material(material({"roughnessFactor": 0.0}, extensions={
        "KHR_materials_transmission": {"transmissionFactor": 1.0, "transmissionTexture": {"index": tex}},
        "KHR_materials_ior": {"ior": 1.0}})))
    # The emitter: a larger plane 1 m behind, facing +Z.
    s.grid_plane(s.material(material({"baseColorFactor": [0, 0, 0, 1]}, specular=0.0,
                                      emissiveFactor=[1.0, 1.0, 1.0])), uv=False, z=-1.0, scale=3.0)
    s.ortho_camera()
    uses(s, "KHR_materials_transmission", "KHR_materials_ior", "KHR_materials_specular")
    s.save("transmission.gltf")


def texcoord1_scene():
    """The base colour pattern read through TEXCOORD_1 (texCoord 1), the plane's
    TEXCOORD_0 being one constant point; the primitive also has a TEXCOORD_2,
    which is not read (a warning)."""
    def extra(s, attrs, xs, ys):
        attrs["TEXCOORD_0"] = s.floats([(0.9, 0.9)] * len(xs), "VEC2")
        attrs["TEXCOORD_1"] = s.floats([((x + 1) / 2, (1 - y) / 2) for x, y in zip(xs, ys)], "VEC2")
        attrs["TEXCOORD_2"] = s.floats([(0.0, 0.0)] * len(xs), "VEC2")
    s = Scene()
    tex = s.texture(cells_png(BASE_CELLS, 4))
    s.grid_plane(s.material(lambert(baseColorTexture={"index": tex, "texCoord": 1})), uv=False, extra=extra)
    s.ortho_camera()
    s.save("texcoord1.gltf")


# COLOR_0 of the 3 x 3 vertices of the colour scenes (row-major from y = -1),
# linear RGBA.
VERTEX_COLORS = [(0.9, 0.1, 0.1, 1.0), (0.1, 0.9, 0.1, 0.5), (0.1, 0.1, 0.9, 1.0),
                 (0.9, 0.9, 0.1, 0.8), (0.5, 0.5, 0.5, 0.2), (0.1, 0.9, 0.9, 1.0),
                 (0.9, 0.1, 0.9, 0.6), (0.3, 0.6, 0.9, 1.0), (0.9, 0.6, 0.3, 0.4)]


def color_scenes():
    """A white Lambertian plane of 2 x 2 quads whose COLOR_0 varies per vertex:
    VEC3 floats and VEC3 normalised unsigned shorts (opaque), and VEC4 normalised
    unsigned bytes with alphaMode BLEND (the alpha blends the plane over the white
    sky)."""
    def vec3(s, attrs, xs, ys):
        attrs["COLOR_0"] = s.floats([c[:3] for c in VERTEX_COLORS], "VEC3")

    def vec3u16(s, attrs, xs, ys):
        # 6-byte elements padded to a stride of 8: glTF aligns vertex attributes to 4 bytes.
        data = b"".join(struct.pack("<3Hxx", *(round(v * 65535) for v in c[:3])) for c in VERTEX_COLORS)
        attrs["COLOR_0"] = s.acc(s.view(data, stride=8), U16, len(VERTEX_COLORS), "VEC3", normalized=True)

    def vec4u8(s, attrs, xs, ys):
        data = bytes(round(v * 255) for c in VERTEX_COLORS for v in c)
        attrs["COLOR_0"] = s.acc(s.view(data), U8, len(VERTEX_COLORS), "VEC4", normalized=True)
    for name, extra, mode in (("color0_vec3_float.gltf", vec3, {}), ("color0_vec3_ushort.gltf", vec3u16, {}),
                              ("color0_vec4_ubyte.gltf", vec4u8, {"alphaMode": "BLEND"})):
        s = Scene()
        s.grid_plane(s.material(material({}, specular=0.0, **mode)), n=2, uv=False, extra=extra)
        s.ortho_camera()
        uses(s, "KHR_materials_specular")
        s.save(name)


def filter_scenes():
    """A 2 x 1 texture (white, black), clamped, magnified over the plane with
    magFilter NEAREST and LINEAR."""
    png = gg.png(2, 1, [[255, 255, 255, 0, 0, 0]])
    for name, mag in (("filter_nearest.gltf", 9728), ("filter_linear.gltf", 9729)):
        s = Scene()
        tex = s.texture(png, {"magFilter": mag, "minFilter": 9987, "wrapS": 33071, "wrapT": 33071})
        s.grid_plane(s.material(lambert(baseColorTexture={"index": tex})))
        s.ortho_camera()
        s.save(name)


def horizon_scene():
    """A Lambertian checkerboard floor (a 64 x 64 texture of 8 x 8 black and white
    squares, repeated every 4 m: squares of 0.5 m) of 4 km x 4 km under the white
    sky, seen from 1 m above it looking along it, yfov 40 degrees: the horizon is
    the image's middle row."""
    s = Scene()
    rows = [[255 if (x // 8 + y // 8) % 2 == 0 else 0 for x in range(64) for _ in range(3)] for y in range(64)]
    tex = s.texture(gg.png(64, 64, rows))
    m = s.material(lambert(baseColorTexture={"index": tex}))
    h = 2000.0
    pos = [(-h, 0.0, -h), (h, 0.0, -h), (h, 0.0, h), (-h, 0.0, h)]
    uv = [(x / 4.0, z / 4.0) for x, _, z in pos]
    p = {"attributes": {"POSITION": s.floats(pos, "VEC3"), "TEXCOORD_0": s.floats(uv, "VEC2")},
         "indices": s.indices([0, 2, 1, 0, 3, 2]), "material": m}
    s.doc["accessors"][p["attributes"]["POSITION"]].update(min=[-h, 0, -h], max=[h, 0, h])
    s.node(mesh=s.mesh([p]))
    s.doc["cameras"].append({"type": "perspective", "perspective": {"yfov": math.radians(40), "znear": 0.01,
                                                                    "aspectRatio": 1.0}})
    s.node(camera=0, translation=[0.0, 1.0, 0.0])
    s.save("horizon.gltf")


def clearcoat_scenes():
    """A black base under a clear coat whose factor (R) and roughness (G) come from
    textures, lit head-on by pi lux under a black sky; and the same coat with a
    clearcoat normal texture tilting the coat's normal 30 degrees toward +X over
    half the plane (the left half flat)."""
    kinds = [(255, 128, 0), (255, 255, 0), (128, 128, 0), (0, 128, 0)]  # (coat R, rough G)
    s = Scene()
    tex = s.texture(grid_cells([[kinds[k] for k in row] for row in KIND_GRID]))
    save_plane(s, s.material(material({"baseColorFactor": [0, 0, 0, 1]}, specular=0.0, extensions={
        "KHR_materials_clearcoat": {"clearcoatFactor": 1.0, "clearcoatRoughnessFactor": 1.0,
                                     "clearcoatTexture": {"index": tex},
                                     "clearcoatRoughnessTexture": {"index": tex}}})),
               "clearcoat.gltf", "KHR_materials_clearcoat", "KHR_materials_specular", lit=True)

    s = Scene()
    ntex = s.texture(gg.png(2, 1, [[128, 128, 255, 191, 128, 238]]),
                     {"magFilter": 9728, "wrapS": 33071, "wrapT": 33071})
    save_plane(s, s.material(material({"baseColorFactor": [0, 0, 0, 1]}, specular=0.0, extensions={
        "KHR_materials_clearcoat": {"clearcoatFactor": 1.0, "clearcoatRoughnessFactor": 0.5,
                                     "clearcoatNormalTexture": {"index": ntex}}})),
               "clearcoat_normal.gltf", "KHR_materials_clearcoat", "KHR_materials_specular", lit=True)

    # An emitter of radiance 1 under a smooth coat, under a black sky: the coat
    # passes 1 - clearcoat Fc(1) = 0.96 of the emission.
    s = Scene()
    save_plane(s, s.material(material({"baseColorFactor": [0, 0, 0, 1]}, specular=0.0, emissiveFactor=[1.0, 1.0, 1.0],
                                      extensions={"KHR_materials_clearcoat": {"clearcoatFactor": 1.0}})),
               "clearcoat_emissive.gltf", "KHR_materials_clearcoat", "KHR_materials_specular")


def sheen_scene():
    """A black base under a sheen whose colour (RGB, sRGB) and roughness (A) come
    from one texture, seen by an orthographic camera 60 degrees off the normal and
    lit from the camera's direction by pi lux under a black sky."""
    kinds = [(255, 255, 255, 77), (188, 188, 188, 153), (255, 255, 255, 255), (0, 0, 0, 255)]
    s = Scene()
    tex = s.texture(grid_cells([[kinds[k] for k in row] for row in KIND_GRID], channels=4))
    s.grid_plane(s.material(material({"baseColorFactor": [0, 0, 0, 1]}, specular=0.0, extensions={
        "KHR_materials_sheen": {"sheenColorFactor": [1.0, 1.0, 1.0], "sheenRoughnessFactor": 1.0,
                                "sheenColorTexture": {"index": tex}, "sheenRoughnessTexture": {"index": tex}}})))
    t = math.radians(60)
    view = (0.0, -math.sin(t), math.cos(t))  # from the plane toward the camera
    s.doc["cameras"].append({"type": "orthographic",
                             "orthographic": {"xmag": 1.0, "ymag": math.cos(t), "znear": 0.01, "zfar": 100}})
    s.node(camera=len(s.doc["cameras"]) - 1, translation=[2 * v for v in view], rotation=quat_z_to(view))
    directional_light(s, view)
    uses(s, "KHR_materials_sheen", "KHR_materials_specular")
    s.save("sheen.gltf")


def specular_scene():
    """A black dielectric (roughness 0.5) whose KHR_materials_specular factor comes
    from specularTexture (A) and its colour from specularColorTexture (sRGB), lit
    head-on by pi lux under a black sky: the GGX lobe's F0 = 0.04 colour factor."""
    kinds = [(255, 255, 255, 255), (255, 128, 64, 255), (255, 255, 255, 128), (255, 255, 255, 0)]
    s = Scene()
    tex = s.texture(grid_cells([[kinds[k] for k in row] for row in KIND_GRID], channels=4))
    save_plane(s, s.material(material({"baseColorFactor": [0, 0, 0, 1], "roughnessFactor": 0.5},
                                      specular=1.0, extensions={"KHR_materials_specular": {
                                          "specularTexture": {"index": tex}, "specularColorTexture": {"index": tex}}})),
               "specular.gltf", "KHR_materials_specular", lit=True)


if __name__ == "__main__":
    os.makedirs(OUT, exist_ok=True)
    base_scenes()
    alpha_scenes()
    alpha_mask_far_scene()
    metallic_roughness_scene()
    normal_scene()
    emissive_scene()
    transmission_scene()
    texcoord1_scene()
    color_scenes()
    filter_scenes()
    horizon_scene()
    clearcoat_scenes()
    sheen_scene()
    specular_scene()
