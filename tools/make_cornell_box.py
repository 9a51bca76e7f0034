#!/usr/bin/env python3
"""Writes the default scene, the Cornell box, as a self-contained glTF 2.0 file.

    python3 tools/make_cornell_box.py                       # -> scenes/cornell_box.gltf
    python3 tools/make_cornell_box.py --rgb-only --classic tests/data/scenes/cornell_box_rgb.gltf

Geometry, camera, reflectances and light spectrum are the Cornell Program of
Computer Graphics' published data for the physical box
(https://www.graphics.cornell.edu/online/box/data.html), in mm divided by 1000.
The scene keeps the classic frame (x from the green wall at x=0 to the red wall
at x~0.55, y up, z from the open side at 0 to the back wall at 0.559); the camera
node is rotated 180 degrees about +Y so that its -Z looks along +z, and its +X
(image right) is world -x: red wall on the left, green on the right.

The walls, blocks and the light are pure Lambertian (KHR_materials_specular
specularFactor 0: no glTF dielectric specular layer), so Mitsuba's `diffuse`
renders them exactly. The default scene replaces the short block with two
objects that show the materials: a smooth sphere of measured gold
(extras.spectrace.conductor "Au") and a dispersive glass sphere
(KHR_materials_transmission 1, KHR_materials_ior 1.5, KHR_materials_dispersion
2, i.e. Abbe number 10) whose caustic on the floor splits the light into
colours; --classic keeps the two published blocks instead.

Also a small glTF writer used by tools/make_test_scenes.py. Needs only the
Python standard library (kernels/spectrum/cie_data.h is read for the light's RGB).
"""
import argparse
import base64
import json
import math
import os
import re
import struct
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from data_table import read_columns  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)

# ---------------------------------------------------------------------------
# Cornell data (https://www.graphics.cornell.edu/online/box/data.html), mm.
# Each quad as published (a block's sides, as published, drop the edges of its
# top to the floor: block_faces writes them so); winding is fixed below so
# front faces point into the box (walls) or out of the blocks, and the light
# faces down.
# ---------------------------------------------------------------------------
FLOOR = [(552.8, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 559.2), (549.6, 0.0, 559.2)]
CEILING = [(556.0, 548.8, 0.0), (556.0, 548.8, 559.2), (0.0, 548.8, 559.2), (0.0, 548.8, 0.0)]
BACK_WALL = [(549.6, 0.0, 559.2), (0.0, 0.0, 559.2), (0.0, 548.8, 559.2), (556.0, 548.8, 559.2)]
RIGHT_WALL = [(0.0, 0.0, 559.2), (0.0, 0.0, 0.0), (0.0, 548.8, 0.0), (0.0, 548.8, 559.2)]   # green
LEFT_WALL = [(552.8, 0.0, 0.0), (549.6, 0.0, 559.2), (556.0, 548.8, 559.2), (556.0, 548.8, 0.0)]  # red


def block_faces(top, side_corners):
    """A block as published: its top face, then one side per edge of the top,
    from top corner k down to the floor and across to corner k - 1, taking k in
    side_corners (the published order of the sides)."""
    return [top] + [[(top[k][0], 0.0, top[k][2]), top[k], top[k - 1], (top[k - 1][0], 0.0, top[k - 1][2])]
                    for k in side_corners]


SHORT_BLOCK = block_faces([(130.0, 165.0, 65.0), (82.0, 165.0, 225.0), (240.0, 165.0, 272.0), (290.0, 165.0, 114.0)],
                          (3, 0, 1, 2))
TALL_BLOCK = block_faces([(423.0, 330.0, 247.0), (265.0, 330.0, 296.0), (314.0, 330.0, 456.0), (472.0, 330.0, 406.0)],
                         (0, 3, 2, 1))
# The published light sits in a hole of the ceiling at y = 548.8; here the
# ceiling is whole and the light quad is 0.5 mm below it (as in Mitsuba's cbox).
LIGHT_Y = 548.3
LIGHT = [(343.0, LIGHT_Y, 227.0), (343.0, LIGHT_Y, 332.0), (213.0, LIGHT_Y, 332.0), (213.0, LIGHT_Y, 227.0)]

CAMERA_POS_MM = (278.0, 273.0, -800.0)
FOCAL_MM, FILM_MM = 35.0, 25.0   # 35 mm lens, 25 mm x 25 mm film
YFOV = 2.0 * math.atan(0.5 * FILM_MM / FOCAL_MM)  # 0.68611 rad = 39.3077 degrees

# Spectral reflectances, 400..700 nm in 4 nm steps (76 values), from the same
# page (tools/data/cornell_box_reflectance.csv).
_REFL = read_columns("cornell_box_reflectance.csv")
WL_4NM = [int(w) for w in _REFL["wavelength_nm"]]
WHITE_REFL, GREEN_REFL, RED_REFL = _REFL["white"], _REFL["green"], _REFL["red"]
# The material objects of the default scene (mm, on the floor where the short
# block stands, and in front of the tall block).
GLASS_CENTER_MM, GLASS_RADIUS_MM = (186.0, 100.0, 169.0), 100.0
GLASS_IOR, GLASS_DISPERSION = 1.5, 2.0
GOLD_CENTER_MM, GOLD_RADIUS_MM = (400.0, 80.0, 130.0), 80.0
SPHERE_STACKS, SPHERE_SLICES = 48, 96

# Light: spectral radiance (the page's "light spectrum"), and its reflectance 0.78.
LIGHT_EMISSION = [(400.0, 0.0), (500.0, 8.0), (600.0, 15.6), (700.0, 18.4)]
LIGHT_REFL = 0.78

# Classic RGB albedos (Benedikt Bitterli's "Rendering Resources" Cornell box,
# https://benedikt-bitterli.me/resources/, also pbrt-v4-scenes cornell-box).
WHITE_RGB = (0.725, 0.71, 0.68)
RED_RGB = (0.63, 0.065, 0.05)
GREEN_RGB = (0.14, 0.45, 0.091)
LIGHT_RGB_ALBEDO = (0.78, 0.78, 0.78)

# XYZ -> linear sRGB (docs/architecture.md).
XYZ_TO_SRGB = ((3.2406, -1.5372, -0.4986), (-0.9689, 1.8758, 0.0415), (0.0557, -0.2040, 1.0570))


# ---------------------------------------------------------------------------
# Colour helpers
# ---------------------------------------------------------------------------
def load_cie_1931(path=os.path.join(ROOT, "kernels", "spectrum", "cie_data.h")):
    """The CIE 1931 CMFs at 1 nm from 360 to 830 nm, parsed from kernels/spectrum/cie_data.h."""
    text = open(path).read()
    tables = {}
    for name in ("X", "Y", "Z"):
        m = re.search(r"SPT_CIE_%s\[SPT_CIE_SAMPLES\]\s*=\s*\{([^}]*)\}" % name, text)
        tables[name] = [float(v.rstrip("f")) for v in re.findall(r"[-+0-9.eE]+f", m.group(1))]
    return list(range(360, 831)), tables["X"], tables["Y"], tables["Z"]


def interp(table, nm):
    """Piecewise-linear table [(nm, v)] at nm, zero outside its range."""
    if nm < table[0][0] or nm > table[-1][0]:
        return 0.0
    for (a, va), (b, vb) in zip(table, table[1:]):
        if a <= nm <= b:
            return va + (vb - va) * (nm - a) / (b - a)
    return table[-1][1]


def spectrum_to_linear_srgb(table):
    """Linear sRGB of a spectral radiance table in the Mitsuba 3 / spectrace
    normalisation: XYZ = sum(cmf * P) / sum(ybar) over the 1 nm samples, so a
    constant spectrum of value 1 has Y = 1."""
    wl, xb, yb, zb = load_cie_1931()
    p = [interp(table, w) for w in wl]
    ysum = sum(yb)
    xyz = [sum(c * v for c, v in zip(cmf, p)) / ysum for cmf in (xb, yb, zb)]
    return [sum(m * c for m, c in zip(row, xyz)) for row in XYZ_TO_SRGB]


# ---------------------------------------------------------------------------
# A minimal glTF 2.0 writer (one embedded buffer)
# ---------------------------------------------------------------------------
def _sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def _cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _normalize(a):
    n = math.sqrt(_dot(a, a))
    return (a[0] / n, a[1] / n, a[2] / n)


def orient_quad(quad, toward):
    """The quad's 4 vertices ordered so its counter-clockwise front face (normal
    (v1-v0)x(v2-v0)) points along `toward`."""
    n = _cross(_sub(quad[1], quad[0]), _sub(quad[2], quad[0]))
    return list(quad) if _dot(n, toward) > 0 else list(reversed(quad))


def uv_sphere(stacks, slices, radius=1.0, center=(0.0, 0.0, 0.0), smooth=False):
    """A closed UV sphere with shared vertices (watertight): positions,
    triangles counter-clockwise seen from outside, and unit normals when smooth
    (else None: renderers then use the flat geometric normals). stacks >= 2,
    slices >= 3; the poles are single vertices."""
    pos, nrm = [], []
    for i in range(stacks + 1):
        th = math.pi * i / stacks
        ring = [(0.0, math.cos(th), 0.0)] if i in (0, stacks) else [
            (math.sin(th) * math.cos(2 * math.pi * j / slices), math.cos(th),
             -math.sin(th) * math.sin(2 * math.pi * j / slices)) for j in range(slices)]
        for d in ring:
            nrm.append(d)
            pos.append(tuple(c + radius * v for c, v in zip(center, d)))

    def vid(i, j):   # ring i (0 = north pole), column j
        if i == 0:
            return 0
        if i == stacks:
            return len(pos) - 1
        return 1 + (i - 1) * slices + j % slices

    tris = []
    for i in range(stacks):
        for j in range(slices):
            a, b = vid(i, j), vid(i, j + 1)
            c, d = vid(i + 1, j), vid(i + 1, j + 1)
            if i > 0:
                tris.append((a, c, b))
            if i < stacks - 1:
                tris.append((b, c, d))
    # Check the winding once: the first triangle's normal points away from the centre.
    t = tris[len(tris) // 2]
    n = _cross(_sub(pos[t[1]], pos[t[0]]), _sub(pos[t[2]], pos[t[0]]))
    assert _dot(n, _sub(pos[t[0]], center)) > 0, "sphere winding"
    return pos, tris, (nrm if smooth else None)


class GltfBuilder:
    """Collects meshes, materials, nodes and a camera; writes one .gltf with the
    binary data as a base64 data URI."""

    def __init__(self, generator):
        self.doc = {"asset": {"version": "2.0", "generator": generator},
                    "scene": 0, "scenes": [{"nodes": []}], "nodes": [], "meshes": [],
                    "materials": [], "accessors": [], "bufferViews": [], "buffers": []}
        self.blob = bytearray()
        self.extensions_used = set()

    def _view(self, data, target):
        while len(self.blob) % 4:
            self.blob.append(0)
        self.doc["bufferViews"].append({"buffer": 0, "byteOffset": len(self.blob),
                                        "byteLength": len(data), "target": target})
        self.blob.extend(data)
        return len(self.doc["bufferViews"]) - 1

    def _accessor(self, view, ctype, count, atype, mn=None, mx=None):
        acc = {"bufferView": view, "componentType": ctype, "count": count, "type": atype}
        if mn is not None:
            acc["min"], acc["max"] = mn, mx
        self.doc["accessors"].append(acc)
        return len(self.doc["accessors"]) - 1

    def material(self, name, base_rgb, emissive=None, strength=1.0, reflectance=None,
                 emission=None, double_sided=False, pure_diffuse=False):
        """A Lambertian material (metallic 0, roughness 1). emissive: RGB factor;
        strength > 1 is written as KHR_materials_emissive_strength. reflectance /
        emission: [(nm, value)] tables for extras.spectrace. pure_diffuse adds
        KHR_materials_specular with specularFactor 0, which removes glTF's 4%
        dielectric specular layer: the surface is then exactly Lambertian (what
        Mitsuba's `diffuse` is)."""
        m = {"name": name, "pbrMetallicRoughness": {
            "baseColorFactor": [float(c) for c in base_rgb] + [1.0],
            "metallicFactor": 0.0, "roughnessFactor": 1.0}}
        if double_sided:
            m["doubleSided"] = True
        if pure_diffuse:
            m.setdefault("extensions", {})["KHR_materials_specular"] = {"specularFactor": 0.0}
            self.extensions_used.add("KHR_materials_specular")
        if emissive is not None:
            m["emissiveFactor"] = [float(c) for c in emissive]
            if strength != 1.0:
                m.setdefault("extensions", {})["KHR_materials_emissive_strength"] = {
                    "emissiveStrength": float(strength)}
                self.extensions_used.add("KHR_materials_emissive_strength")
        spec = {}
        if reflectance is not None:
            spec["reflectance"] = [[float(a), float(b)] for a, b in reflectance]
        if emission is not None:
            spec["emission"] = [[float(a), float(b)] for a, b in emission]
        if spec:
            m["extras"] = {"spectrace": spec}
        self.doc["materials"].append(m)
        return len(self.doc["materials"]) - 1

    def pbr_material(self, name, base_rgb=(1.0, 1.0, 1.0), metallic=0.0, roughness=1.0,
                     extensions=None, spectrace=None):
        """A glTF metallic-roughness material with the given extensions
        ({name: object}, each added to extensionsUsed) and extras.spectrace."""
        m = {"name": name, "pbrMetallicRoughness": {
            "baseColorFactor": [float(c) for c in base_rgb] + [1.0],
            "metallicFactor": float(metallic), "roughnessFactor": float(roughness)}}
        if extensions:
            m["extensions"] = extensions
            self.extensions_used.update(extensions)
        if spectrace:
            m["extras"] = {"spectrace": spectrace}
        self.doc["materials"].append(m)
        return len(self.doc["materials"]) - 1

    def geometry(self, positions, triangles, normals=None, small_indices=True):
        """Writes vertex and index data once; returns (attributes, indices accessor)
        for mesh_from (several meshes may share them). Indices are u16 when the
        vertices allow it and small_indices, else u32."""
        pos = b"".join(struct.pack("<3f", *p) for p in positions)
        mn = [min(p[k] for p in positions) for k in range(3)]
        mx = [max(p[k] for p in positions) for k in range(3)]
        attrs = {"POSITION": self._accessor(self._view(pos, 34962), 5126, len(positions), "VEC3", mn, mx)}
        if normals is not None:
            nrm = b"".join(struct.pack("<3f", *n) for n in normals)
            attrs["NORMAL"] = self._accessor(self._view(nrm, 34962), 5126, len(normals), "VEC3")
        if small_indices and len(positions) < 65536:
            idx = b"".join(struct.pack("<3H", *t) for t in triangles)
            ind = self._accessor(self._view(idx, 34963), 5123, 3 * len(triangles), "SCALAR")
        else:
            idx = b"".join(struct.pack("<3I", *t) for t in triangles)
            ind = self._accessor(self._view(idx, 34963), 5125, 3 * len(triangles), "SCALAR")
        return attrs, ind

    def mesh_from(self, name, geometry, material, translation=None, scale=None):
        """A mesh node of one primitive over geometry() data, placed by a
        translation and a uniform scale."""
        attrs, ind = geometry
        self.doc["meshes"].append({"name": name, "primitives": [
            {"attributes": dict(attrs), "indices": ind, "material": material, "mode": 4}]})
        node = {"name": name, "mesh": len(self.doc["meshes"]) - 1}
        if translation is not None:
            node["translation"] = [float(c) for c in translation]
        if scale is not None:
            node["scale"] = [float(scale)] * 3
        self.node(node)

    def point_light(self, name, intensity, position, color=(1.0, 1.0, 1.0)):
        """A KHR_lights_punctual point light of `intensity` candela at position."""
        ext = self.doc.setdefault("extensions", {}).setdefault("KHR_lights_punctual", {"lights": []})
        ext["lights"].append({"name": name, "type": "point", "intensity": float(intensity),
                              "color": [float(c) for c in color]})
        self.extensions_used.add("KHR_lights_punctual")
        self.node({"name": name, "translation": [float(c) for c in position],
                   "extensions": {"KHR_lights_punctual": {"light": len(ext["lights"]) - 1}}})

    def spot_light(self, name, intensity, position, inner_cone, outer_cone, rotation=None,
                   color=(1.0, 1.0, 1.0)):
        """A KHR_lights_punctual spot light of `intensity` candela at position,
        pointing along the node's -Z (turned by the quaternion rotation), with
        cone half-angles inner_cone < outer_cone (radians)."""
        ext = self.doc.setdefault("extensions", {}).setdefault("KHR_lights_punctual", {"lights": []})
        ext["lights"].append({"name": name, "type": "spot", "intensity": float(intensity),
                              "color": [float(c) for c in color],
                              "spot": {"innerConeAngle": float(inner_cone), "outerConeAngle": float(outer_cone)}})
        self.extensions_used.add("KHR_lights_punctual")
        node = {"name": name, "translation": [float(c) for c in position],
                "extensions": {"KHR_lights_punctual": {"light": len(ext["lights"]) - 1}}}
        if rotation is not None:
            node["rotation"] = [float(c) for c in rotation]
        self.node(node)

    def mesh(self, name, positions, triangles, material, normals=None):
        """A triangle mesh node. positions: [(x,y,z)], triangles: [(i,j,k)]
        counter-clockwise seen from the front (u32 indices)."""
        self.mesh_from(name, self.geometry(positions, triangles, normals, small_indices=False), material)

    def quads_mesh(self, name, quads, material):
        """A mesh of flat quads (4 vertices each, already oriented), two triangles
        per quad, with flat normals."""
        pos, nrm, tris = [], [], []
        for q in quads:
            n = _normalize(_cross(_sub(q[1], q[0]), _sub(q[2], q[0])))
            b = len(pos)
            pos.extend(q)
            nrm.extend([n] * 4)
            tris.extend([(b, b + 1, b + 2), (b, b + 2, b + 3)])
        self.mesh(name, pos, tris, material, nrm)

    def node(self, node):
        self.doc["nodes"].append(node)
        self.doc["scenes"][0]["nodes"].append(len(self.doc["nodes"]) - 1)

    def camera(self, name, yfov, translation, rotation=None, aspect=1.0, znear=0.01):
        """A perspective camera node (looking along the node's -Z)."""
        self.doc.setdefault("cameras", []).append({"name": name, "type": "perspective", "perspective": {
            "aspectRatio": aspect, "yfov": yfov, "znear": znear}})
        node = {"name": name, "camera": len(self.doc["cameras"]) - 1,
                "translation": [float(c) for c in translation]}
        if rotation is not None:
            node["rotation"] = [float(c) for c in rotation]
        self.node(node)

    def write(self, path, extras=None):
        self.doc["buffers"] = [{"byteLength": len(self.blob), "uri": "data:application/octet-stream;base64,"
                                + base64.b64encode(bytes(self.blob)).decode("ascii")}]
        if self.extensions_used:
            self.doc["extensionsUsed"] = sorted(self.extensions_used)
        if extras:
            self.doc["asset"]["extras"] = extras
        os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
        tmp = path + ".tmp"
        with open(tmp, "w") as f:
            json.dump(self.doc, f, indent=1)
            f.write("\n")
        os.replace(tmp, path)


# ---------------------------------------------------------------------------
def light_emission_rgb():
    """(emissiveFactor, emissiveStrength): the linear sRGB of the Cornell light
    spectrum, split into a factor with max 1 and a strength."""
    rgb = spectrum_to_linear_srgb(LIGHT_EMISSION)
    s = max(rgb)
    return [c / s for c in rgb], s


def build(rgb_only=False, classic=False):
    mm = 1e-3
    centre = (278.0, 274.4, 279.6)   # inside the box: walls face it

    def m(quad):
        return [tuple(c * mm for c in v) for v in quad]

    def toward_centre(quad):
        c = tuple(sum(v[k] for v in quad) / 4 for k in range(3))
        return orient_quad(quad, _sub(centre, c))

    def block(faces):
        bc = tuple(sum(v[k] for f in faces for v in f) / (4 * len(faces)) for k in range(3))
        out = []
        for q in faces:
            c = tuple(sum(v[k] for v in q) / 4 for k in range(3))
            d = _sub(c, bc)
            if q[0][1] == q[1][1] == q[2][1]:   # the top face: up
                d = (0.0, 1.0, 0.0)
            out.append(orient_quad(q, d))
        return out

    g = GltfBuilder("spectrace tools/make_cornell_box.py" + (" --rgb-only" if rgb_only else "")
                    + (" --classic" if classic else ""))
    spec = (lambda t: None) if rgb_only else (lambda t: t)
    white = g.material("white", WHITE_RGB, reflectance=spec(list(zip(WL_4NM, WHITE_REFL))), pure_diffuse=True)
    red = g.material("red", RED_RGB, reflectance=spec(list(zip(WL_4NM, RED_REFL))), pure_diffuse=True)
    green = g.material("green", GREEN_RGB, reflectance=spec(list(zip(WL_4NM, GREEN_REFL))), pure_diffuse=True)
    factor, strength = light_emission_rgb()
    light = g.material("light", LIGHT_RGB_ALBEDO, emissive=factor, strength=strength,
                       reflectance=spec([(400.0, LIGHT_REFL), (700.0, LIGHT_REFL)]),
                       emission=spec(LIGHT_EMISSION), pure_diffuse=True)

    g.quads_mesh("floor", [m(toward_centre(FLOOR))], white)
    g.quads_mesh("ceiling", [m(toward_centre(CEILING))], white)
    g.quads_mesh("back_wall", [m(toward_centre(BACK_WALL))], white)
    g.quads_mesh("left_wall_red", [m(toward_centre(LEFT_WALL))], red)
    g.quads_mesh("right_wall_green", [m(toward_centre(RIGHT_WALL))], green)
    if classic:
        g.quads_mesh("short_block", [m(q) for q in block(SHORT_BLOCK)], white)
    else:
        # One unit sphere (smooth normals) placed twice by node translation and scale.
        pos, tris, nrm = uv_sphere(SPHERE_STACKS, SPHERE_SLICES, smooth=True)
        unit = g.geometry(pos, tris, nrm)
        gold = g.pbr_material("gold", (1.0, 0.766, 0.336), metallic=1.0, roughness=0.0,
                              spectrace=None if rgb_only else {"conductor": "Au"})
        glass = g.pbr_material("dispersive_glass", (1.0, 1.0, 1.0), metallic=0.0, roughness=0.0, extensions={
            "KHR_materials_transmission": {"transmissionFactor": 1.0},
            "KHR_materials_ior": {"ior": GLASS_IOR},
            "KHR_materials_dispersion": {"dispersion": GLASS_DISPERSION}})
        g.mesh_from("glass_sphere", unit, glass, [c * mm for c in GLASS_CENTER_MM], GLASS_RADIUS_MM * mm)
        g.mesh_from("gold_sphere", unit, gold, [c * mm for c in GOLD_CENTER_MM], GOLD_RADIUS_MM * mm)
    g.quads_mesh("tall_block", [m(q) for q in block(TALL_BLOCK)], white)
    g.quads_mesh("light", [m(orient_quad(LIGHT, (0.0, -1.0, 0.0)))], light)
    # 180 degrees about +Y: node -Z -> world +z, node +X -> world -x.
    g.camera("camera", YFOV, [c * mm for c in CAMERA_POS_MM], rotation=[0.0, 1.0, 0.0, 0.0])
    return g


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("output", nargs="?", default=os.path.join(ROOT, "scenes", "cornell_box.gltf"),
                    help="output .gltf (default scenes/cornell_box.gltf)")
    ap.add_argument("--rgb-only", action="store_true",
                    help="leave out the spectral extras (RGB materials and emission only)")
    ap.add_argument("--print-light-rgb", action="store_true",
                    help="print the linear sRGB of the Cornell light spectrum and exit")
    ap.add_argument("--classic", action="store_true",
                    help="the two published blocks only (no gold and glass spheres)")
    a = ap.parse_args(argv)
    if a.print_light_rgb:
        print("light linear sRGB: %.5f %.5f %.5f" % tuple(spectrum_to_linear_srgb(LIGHT_EMISSION)))
        return 0
    g = build(a.rgb_only, a.classic)
    g.write(a.output, extras={"source": "Cornell box, https://www.graphics.cornell.edu/online/box/data.html",
                              "units": "metres"})
    print("wrote %s" % a.output)
    return 0


if __name__ == "__main__":
    sys.exit(main())
