#!/usr/bin/env python3
"""Writes the two hard-light scenes of the race against Blender Cycles that
the project has no file for (tools/bench_cycles.py, docs/performance.md
"Against Blender Cycles"):

    python3 tools/make_race_scenes.py OUTDIR

  table.gltf   a smooth glass sphere (ior 1.5, radius 0.15 m) on a wooden
               table in a closed grey room, under one small emissive square
               (0.1 m x 0.1 m, 1.1 m above the table top, facing down): the
               sphere's caustic on the table, the table seen through the
               sphere, the room lit by what the table and the floor send back.
  window.gltf  a closed room (5 m x 3 m x 5 m) lit by a sun (a directional
               light of 10 lux, 45 degrees high) through one window (2 m x 1.2
               m) in its -X wall: a bright patch on the floor and a block in
               it, every other surface lit indirectly. The camera looks at the
               window wall from the far side of the room.

Every opaque surface is Lambertian (KHR_materials_specular specularFactor 0).
Plain Python, deterministic.
"""
import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from make_cornell_box import GltfBuilder, orient_quad, uv_sphere  # noqa: E402
from make_light_scenes import box_quads, look  # noqa: E402

GEN = "spectrace tools/make_race_scenes.py"


def room_quads(x0, x1, y0, y1, z0, z1):
    """The six inward faces of a closed box, as {name: quad}."""
    c = ((x0 + x1) / 2, (y0 + y1) / 2, (z0 + z1) / 2)
    faces = {
        "floor": [(x0, y0, z0), (x1, y0, z0), (x1, y0, z1), (x0, y0, z1)],
        "ceiling": [(x0, y1, z0), (x1, y1, z0), (x1, y1, z1), (x0, y1, z1)],
        "wall_-z": [(x0, y0, z0), (x1, y0, z0), (x1, y1, z0), (x0, y1, z0)],
        "wall_+z": [(x0, y0, z1), (x1, y0, z1), (x1, y1, z1), (x0, y1, z1)],
        "wall_-x": [(x0, y0, z0), (x0, y1, z0), (x0, y1, z1), (x0, y0, z1)],
        "wall_+x": [(x1, y0, z0), (x1, y1, z0), (x1, y1, z1), (x1, y0, z1)],
    }
    out = {}
    for name, q in faces.items():
        centre = [sum(p[k] for p in q) / 4 for k in range(3)]
        out[name] = orient_quad(q, [c[k] - centre[k] for k in range(3)])
    return out


def quat_to(d):
    """The glTF rotation (x, y, z, w) that turns -Z onto the unit direction d."""
    a = (0.0, 0.0, -1.0)
    axis = (a[1] * d[2] - a[2] * d[1], a[2] * d[0] - a[0] * d[2], a[0] * d[1] - a[1] * d[0])
    s = math.sqrt(sum(v * v for v in axis))
    ang = math.acos(max(-1.0, min(1.0, sum(x * y for x, y in zip(a, d)))))
    if s < 1e-12:
        return (0.0, 1.0, 0.0, 0.0) if ang > 1.0 else (0.0, 0.0, 0.0, 1.0)
    k = math.sin(ang / 2) / s
    return (axis[0] * k, axis[1] * k, axis[2] * k, math.cos(ang / 2))


def table(path):
    g = GltfBuilder(GEN)
    grey = g.material("walls", (0.6, 0.6, 0.6), pure_diffuse=True)
    floor = g.material("floor", (0.4, 0.4, 0.4), pure_diffuse=True)
    wood = g.material("wood", (0.55, 0.35, 0.2), pure_diffuse=True)
    lamp = g.material("lamp", (0.0, 0.0, 0.0), emissive=(1.0, 1.0, 1.0), strength=300.0)
    glass = g.pbr_material("glass", (1.0, 1.0, 1.0), 0.0, 0.0, extensions={
        "KHR_materials_transmission": {"transmissionFactor": 1.0}, "KHR_materials_ior": {"ior": 1.5}})
    room = room_quads(-2.0, 2.0, 0.0, 2.6, -2.0, 2.0)
    g.quads_mesh("floor", [room.pop("floor")], floor)
    g.quads_mesh("room", list(room.values()), grey)
    top = 0.75
    parts = box_quads(-0.6, 0.6, top - 0.05, top, -0.4, 0.4)
    parts.append(orient_quad([(-0.6, top - 0.05, -0.4), (0.6, top - 0.05, -0.4), (0.6, top - 0.05, 0.4),
                              (-0.6, top - 0.05, 0.4)], (0, -1, 0)))
    for lx in (-0.55, 0.5):
        for lz in (-0.35, 0.3):
            parts += box_quads(lx, lx + 0.05, 0.0, top - 0.05, lz, lz + 0.05)
    g.quads_mesh("table", parts, wood)
    pos, tris, nrm = uv_sphere(48, 96, 0.15, (0.0, top + 0.15, 0.0), smooth=True)
    g.mesh_from("sphere", g.geometry(pos, tris, nrm), glass)
    h, y = 0.05, top + 1.1
    g.quads_mesh("lamp", [orient_quad([(0.1 - h, y, -0.1 - h), (0.1 + h, y, -0.1 - h), (0.1 + h, y, -0.1 + h),
                                       (0.1 - h, y, -0.1 + h)], (0, -1, 0))], lamp)
    g.camera("camera", math.radians(40.0), (0.0, 1.25, 1.5), rotation=look(0.0, -17.0), aspect=1.0)
    g.write(path, extras={"about": "race scene (tools/make_race_scenes.py)", "units": "metres"})


def window(path):
    g = GltfBuilder(GEN)
    grey = g.material("walls", (0.7, 0.7, 0.7), pure_diffuse=True)
    floor = g.material("floor", (0.45, 0.4, 0.35), pure_diffuse=True)
    block = g.material("block", (0.3, 0.4, 0.6), pure_diffuse=True)
    room = room_quads(0.0, 5.0, 0.0, 3.0, 0.0, 5.0)
    g.quads_mesh("floor", [room.pop("floor")], floor)
    del room["wall_-x"]
    # The -X wall around its window (y 1-2.2, z 1.5-3.5), facing +X.
    wy0, wy1, wz0, wz1 = 1.0, 2.2, 1.5, 3.5
    wall = [[(0.0, 0.0, 0.0), (0.0, 0.0, 5.0), (0.0, wy0, 5.0), (0.0, wy0, 0.0)],
            [(0.0, wy1, 0.0), (0.0, wy1, 5.0), (0.0, 3.0, 5.0), (0.0, 3.0, 0.0)],
            [(0.0, wy0, 0.0), (0.0, wy0, wz0), (0.0, wy1, wz0), (0.0, wy1, 0.0)],
            [(0.0, wy0, wz1), (0.0, wy0, 5.0), (0.0, wy1, 5.0), (0.0, wy1, wz1)]]
    g.quads_mesh("room", list(room.values()) + [orient_quad(q, (1, 0, 0)) for q in wall], grey)
    g.quads_mesh("block", box_quads(1.6, 2.4, 0.0, 0.8, 2.1, 2.9), block)
    # The sun's light travels along d: into the room (+X), down 45 degrees, a little towards +Z.
    d = (0.68, -0.7071, 0.19)
    n = math.sqrt(sum(v * v for v in d))
    ext = g.doc.setdefault("extensions", {}).setdefault("KHR_lights_punctual", {"lights": []})
    ext["lights"].append({"name": "sun", "type": "directional", "intensity": 10.0, "color": [1.0, 0.95, 0.9]})
    g.extensions_used.add("KHR_lights_punctual")
    g.node({"name": "sun", "rotation": list(quat_to(tuple(v / n for v in d))),
            "extensions": {"KHR_lights_punctual": {"light": len(ext["lights"]) - 1}}})
    g.camera("camera", math.radians(60.0), (4.7, 1.5, 3.4), rotation=look(75.0, -12.0), aspect=1.0)
    g.write(path, extras={"about": "race scene (tools/make_race_scenes.py)", "units": "metres"})


def main(argv):
    out = argv[1] if len(argv) > 1 else "."
    table(os.path.join(out, "table.gltf"))
    window(os.path.join(out, "window.gltf"))
    print("wrote %s and %s" % (os.path.join(out, "table.gltf"), os.path.join(out, "window.gltf")))


if __name__ == "__main__":
    main(sys.argv)
