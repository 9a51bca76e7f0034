#!/usr/bin/env python3
"""Writes the many-light scenes of the light tree's measurements (issue 40,
docs/performance.md "Light tree"):

    python3 tools/make_light_scenes.py OUTDIR

  street.gltf  a street of 1,000 lamps, two rows of 500 along +X, 4 m apart,
               5 m up over a 2 km ground plane with blocks of buildings on
               both sides; every other lamp is a small emissive quad facing
               down (0.4 m x 0.4 m), the others spot lights pointing down
               (inner 40, outer 60 degrees). Each lamp lights a patch of the
               street around it. The camera looks down the street from 25 m.
  field.gltf   a 10 m x 10 m floor lit by 200 small emissive quads
               (0.15 m x 0.15 m, facing down, 0.3-1.2 m up, of random
               colours), seen obliquely.
  street_coloured.gltf, field_coloured.gltf  the same with saturated lights:
               each lamp, spot and quad red, green or blue (one primary at 1,
               the others at 0.03; in turn along the street, at random in the
               field), to measure what weighting the tree's power by the
               path's wavelengths instead of luminance does.
Every surface is Lambertian (albedo 0.5 ground, 0.6 buildings). Plain Python,
deterministic (a fixed seed).
"""
import math
import os
import random
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from make_cornell_box import GltfBuilder  # noqa: E402


def quat_mul(a, b):
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
            aw * bw - ax * bx - ay * by - az * bz)


def look(yaw_deg, pitch_deg):
    """The camera rotation (glTF x, y, z, w) that turns -Z by yaw about +Y and
    then pitches it by pitch (negative: down)."""
    y, p = math.radians(yaw_deg) / 2, math.radians(pitch_deg) / 2
    return quat_mul((0.0, math.sin(y), 0.0, math.cos(y)), (math.sin(p), 0.0, 0.0, math.cos(p)))


DOWN = (-math.sqrt(0.5), 0.0, 0.0, math.sqrt(0.5))  # -Z turned to -Y


def down_quad(cx, y, cz, h):
    """A horizontal square of half side h at height y, facing down (-Y)."""
    return [(cx - h, y, cz - h), (cx + h, y, cz - h), (cx + h, y, cz + h), (cx - h, y, cz + h)]


def box_quads(x0, x1, y0, y1, z0, z1):
    """The 5 outward faces (no bottom) of a box."""
    return [
        [(x0, y1, z0), (x0, y1, z1), (x1, y1, z1), (x1, y1, z0)],   # top (+Y)
        [(x0, y0, z1), (x1, y0, z1), (x1, y1, z1), (x0, y1, z1)],   # +Z
        [(x1, y0, z0), (x0, y0, z0), (x0, y1, z0), (x1, y1, z0)],   # -Z
        [(x1, y0, z1), (x1, y0, z0), (x1, y1, z0), (x1, y1, z1)],   # +X
        [(x0, y0, z0), (x0, y0, z1), (x0, y1, z1), (x0, y1, z0)],   # -X
    ]


PRIMARIES = ((1.0, 0.03, 0.03), (0.03, 1.0, 0.03), (0.03, 0.03, 1.0))


def street(path, coloured=False):
    rng = random.Random(40)
    g = GltfBuilder("spectrace tools/make_light_scenes.py")
    ground = g.material("ground", (0.5, 0.5, 0.5), pure_diffuse=True)
    wall = g.material("building", (0.6, 0.55, 0.5), pure_diffuse=True)
    lamps = [g.material("lamp", (0.0, 0.0, 0.0), emissive=(1.0, 0.8, 0.55), strength=3000.0)]
    if coloured:
        lamps = [g.material("lamp%d" % k, (0.0, 0.0, 0.0), emissive=c, strength=3000.0)
                 for k, c in enumerate(PRIMARIES)]
    g.quads_mesh("ground", [[(-20.0, 0.0, -40.0), (-20.0, 0.0, 40.0), (2020.0, 0.0, 40.0),
                             (2020.0, 0.0, -40.0)]], ground)
    walls = []
    for side in (-1.0, 1.0):
        x = -10.0
        while x < 2010.0:
            length = rng.uniform(12.0, 30.0)
            height = rng.uniform(8.0, 24.0)
            z0, z1 = (10.0, 22.0) if side > 0 else (-22.0, -10.0)
            walls += box_quads(x, x + length, 0.0, height, z0, z1)
            x += length + rng.uniform(2.0, 6.0)
    g.quads_mesh("buildings", walls, wall)
    quads = [[] for _ in lamps]
    for row, z in enumerate((-6.0, 6.0)):
        for i in range(500):
            x = 4.0 * i + 2.0 * row
            if (i + row) % 2 == 0:
                quads[(i // 2) % len(lamps)].append(down_quad(x, 5.0, z, 0.2))
            else:
                g.spot_light("spot%d_%d" % (row, i), 400.0, (x, 4.95, z), math.radians(40.0),
                             math.radians(60.0), rotation=DOWN,
                             color=PRIMARIES[(i // 2 + 1) % 3] if coloured else (1.0, 0.9, 0.8))
    for k, m in enumerate(lamps):
        g.quads_mesh("lamps%d" % k if coloured else "lamps", quads[k], m)
    g.camera("camera", math.radians(40.0), (-20.0, 25.0, 0.0), rotation=look(-90.0, -35.0), aspect=1.5)
    g.write(path)


def field(path, coloured=False):
    rng = random.Random(200)
    g = GltfBuilder("spectrace tools/make_light_scenes.py")
    floor = g.material("floor", (0.5, 0.5, 0.5), pure_diffuse=True)
    g.quads_mesh("floor", [[(-5.0, 0.0, -5.0), (-5.0, 0.0, 5.0), (5.0, 0.0, 5.0), (5.0, 0.0, -5.0)]], floor)
    for i in range(200):
        c = [rng.uniform(0.2, 1.0) for _ in range(3)]
        if coloured:
            c = PRIMARIES[rng.randrange(3)]
        m = max(c)
        mat = g.material("quad%d" % i, (0.0, 0.0, 0.0), emissive=[v / m for v in c], strength=200.0)
        g.quads_mesh("quad%d" % i, [down_quad(rng.uniform(-4.5, 4.5), rng.uniform(0.3, 1.2),
                                              rng.uniform(-4.5, 4.5), 0.075)], mat)
    g.camera("camera", math.radians(50.0), (0.0, 6.0, 9.0), rotation=look(0.0, -35.0), aspect=1.0)
    g.write(path)


def main(argv):
    out = argv[1] if len(argv) > 1 else "."
    street(os.path.join(out, "street.gltf"))
    field(os.path.join(out, "field.gltf"))
    street(os.path.join(out, "street_coloured.gltf"), coloured=True)
    field(os.path.join(out, "field_coloured.gltf"), coloured=True)
    print("wrote %s and %s" % (os.path.join(out, "street.gltf"), os.path.join(out, "field.gltf")))


if __name__ == "__main__":
    main(sys.argv)
