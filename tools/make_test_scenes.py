#!/usr/bin/env python3
"""Writes the analytic test scenes into tests/data/scenes/ with their expected
values (tests/data/scenes/expected.json; tests/data/scenes/README.md explains).

    python3 tools/make_test_scenes.py [OUTDIR]

Scenes:
  furnace.gltf           closed inward-facing cube, albedo 0.8, emissive (1,1,1):
                         radiance Le (1 - a^D) / (1 - a), 5 at unlimited depth
  furnace_spectral.gltf  the same with extras.spectrace tables: reflectance 0.8
                         and emission 1 at every wavelength (360-830 nm)
  plane_irradiance.gltf  Lambertian plane (albedo 0.5) under a parallel coaxial
                         emissive square (radiance 2), camera framing the centre
  grey_box_sky.gltf      a Lambertian cube (albedo 0.5, one face normal per face)
                         seen across a corner, no light: under the default white
                         sky (D65, radiance 1) every face has radiance 0.5, the sky
                         1; a convex object sees only the sky, so the per-pixel
                         noise is that of the estimator alone (the sampler test)
Every material is pure Lambertian (KHR_materials_specular specularFactor 0, which
removes glTF's dielectric specular layer), as the analytic values assume.
Plain Python (json, struct, base64, math); no numpy needed.
"""
import json
import math
import os
import re
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from make_cornell_box import GltfBuilder, ROOT, load_cie_1931, XYZ_TO_SRGB  # noqa: E402

OUT = os.path.join(ROOT, "tests", "data", "scenes")

FURNACE_ALBEDO = 0.8
FURNACE_HALF = 1.0           # cube [-1, 1]^3 m
FURNACE_YFOV_DEG = 60.0
DEPTHS = [1, 2, 3, 4, 5, 8, 16]

PLANE_ALBEDO = 0.5
PLANE_L0 = 2.0               # emitted radiance (emissive (1,1,1) * strength 2)
PLANE_H = 1.0                # emitter height above the plane (m)
PLANE_S = 5.0                # emitter half side (m): 10 m x 10 m square
PLANE_HALF = 5.0             # the lit plane's half side (m)
PLANE_CAM_Y = 0.5            # camera height (between plane and emitter, looking down)
PLANE_YFOV_DEG = 10.0


def cube_inward(h):
    """8 shared vertices and 12 triangles of the cube [-h, h]^3 whose
    counter-clockwise front faces point inward."""
    v = [(x, y, z) for x in (-h, h) for y in (-h, h) for z in (-h, h)]
    idx = {p: i for i, p in enumerate(v)}
    tris = []
    for axis in range(3):
        for sgn in (-1, 1):
            # The face at coordinate sgn*h on `axis`; inward normal is -sgn along axis.
            a, b = (axis + 1) % 3, (axis + 2) % 3
            quad = []
            for ua, ub in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
                p = [0.0, 0.0, 0.0]
                p[axis], p[a], p[b] = sgn * h, ua * h, ub * h
                quad.append(idx[tuple(p)])
            # (a, b, axis) is right-handed, so this loop is counter-clockwise about +axis.
            if sgn > 0:   # inward = -axis: reverse
                quad = quad[::-1]
            tris += [(quad[0], quad[1], quad[2]), (quad[0], quad[2], quad[3])]
    return v, tris


def furnace(path, spectral):
    g = GltfBuilder("spectrace tools/make_test_scenes.py")
    a = FURNACE_ALBEDO
    if spectral:
        mat = g.material("furnace_spectral", (a, a, a), emissive=(1.0, 1.0, 1.0),
                         reflectance=[(360.0, a), (830.0, a)], emission=[(360.0, 1.0), (830.0, 1.0)],
                         pure_diffuse=True)
    else:
        mat = g.material("furnace", (a, a, a), emissive=(1.0, 1.0, 1.0), pure_diffuse=True)
    v, t = cube_inward(FURNACE_HALF)
    g.mesh("cube", v, t, mat)
    g.camera("camera", math.radians(FURNACE_YFOV_DEG), (0.0, 0.0, 0.0))
    g.write(path)


def plane_irradiance(path):
    g = GltfBuilder("spectrace tools/make_test_scenes.py")
    plane = g.material("plane", (PLANE_ALBEDO,) * 3, pure_diffuse=True)
    light = g.material("emitter", (0.0, 0.0, 0.0), emissive=(1.0, 1.0, 1.0), strength=PLANE_L0,
                       pure_diffuse=True)
    p, s, h = PLANE_HALF, PLANE_S, PLANE_H
    # Plane at y = 0 facing +y; emitter at y = h facing -y (both counter-clockwise).
    g.mesh("plane", [(-p, 0, -p), (-p, 0, p), (p, 0, p), (p, 0, -p)], [(0, 1, 2), (0, 2, 3)], plane,
           [(0, 1, 0)] * 4)
    g.mesh("emitter", [(-s, h, -s), (s, h, -s), (s, h, s), (-s, h, s)], [(0, 1, 2), (0, 2, 3)], light,
           [(0, -1, 0)] * 4)
    # -90 degrees about +X: the node's -Z looks down (-y), its +Y (image up) is -z.
    r = math.sqrt(0.5)
    g.camera("camera", math.radians(PLANE_YFOV_DEG), (0.0, PLANE_CAM_Y, 0.0), rotation=(-r, 0.0, 0.0, r))
    g.write(path)


GREY_ALBEDO = 0.5
GREY_HALF = 1.0
GREY_YFOV_DEG = 40.0


def cube_outward_faces(h):
    """24 vertices (4 per face, each with its face normal) and 12 triangles of the
    cube [-h, h]^3 whose counter-clockwise front faces point outward."""
    v, n, tris = [], [], []
    for axis in range(3):
        for sgn in (-1, 1):
            a, b = (axis + 1) % 3, (axis + 2) % 3
            base = len(v)
            for ua, ub in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
                p = [0.0, 0.0, 0.0]
                p[axis], p[a], p[b] = sgn * h, ua * h, ub * h
                v.append(tuple(p))
                nn = [0.0, 0.0, 0.0]
                nn[axis] = float(sgn)
                n.append(tuple(nn))
            q = [base, base + 1, base + 2, base + 3]
            if sgn < 0:   # outward = -axis: reverse the loop that is counter-clockwise about +axis
                q = q[::-1]
            tris += [(q[0], q[1], q[2]), (q[0], q[2], q[3])]
    return v, n, tris


def grey_box_sky(path):
    g = GltfBuilder("spectrace tools/make_test_scenes.py")
    mat = g.material("grey", (GREY_ALBEDO,) * 3, pure_diffuse=True)
    v, n, t = cube_outward_faces(GREY_HALF)
    g.mesh("cube", v, t, mat, n)
    # The camera on the diagonal (1, 1, 1) * 2.6, looking at the origin: three faces
    # fill most of the frame. Rotation: yaw 45 degrees about +Y, then pitch down
    # by atan(1/sqrt(2)) about the node's +X.
    yaw, pitch = math.radians(45.0), -math.atan(1.0 / math.sqrt(2.0))
    qy = (0.0, math.sin(yaw / 2), 0.0, math.cos(yaw / 2))
    qx = (math.sin(pitch / 2), 0.0, 0.0, math.cos(pitch / 2))
    x1, y1, z1, w1 = qy
    x2, y2, z2, w2 = qx
    q = (w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2, w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
         w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2, w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2)
    d = 2.6 * GREY_HALF
    g.camera("camera", math.radians(GREY_YFOV_DEG), (d, d, d), rotation=q)
    g.write(path)


def corner_view_factor(a, b, h):
    """View factor from a differential area to a parallel a x b rectangle at
    distance h whose corner lies on the area's normal."""
    A, B = a / h, b / h
    sa, sb = math.sqrt(1 + A * A), math.sqrt(1 + B * B)
    return (A / sa * math.atan(B / sa) + B / sb * math.atan(A / sb)) / (2 * math.pi)


def view_factor(x, z):
    """Point (x, 0, z) to the emitter square [-s, s]^2 at height h: the sum of the
    four corner rectangles (all positive while |x|, |z| < s)."""
    s, h = PLANE_S, PLANE_H
    return sum(corner_view_factor(a, b, h) for a in (s - x, s + x) for b in (s - z, s + z))


def plane_expected(n=400):
    w = PLANE_CAM_Y * math.tan(math.radians(PLANE_YFOV_DEG) / 2)  # half width of the framed square
    tot = 0.0
    for i in range(n):
        for j in range(n):
            tot += view_factor(-w + (i + 0.5) * 2 * w / n, -w + (j + 0.5) * 2 * w / n)
    f_mean = tot / (n * n)
    X = PLANE_S / PLANE_H
    f_centre_closed = 4 / math.pi * X / math.sqrt(1 + X * X) * math.atan(X / math.sqrt(1 + X * X))
    return w, f_centre_closed, view_factor(0, 0), view_factor(w, w), f_mean


def equal_energy_srgb():
    """Linear sRGB of a spectrum of 1 at every wavelength (XYZ = sum(cmf)/sum(ybar))."""
    _, xb, yb, zb = load_cie_1931()
    xyz = [sum(xb) / sum(yb), 1.0, sum(zb) / sum(yb)]
    return [sum(m * c for m, c in zip(row, xyz)) for row in XYZ_TO_SRGB], xyz


def dump_json(obj):
    """JSON with numbers rounded to 9 significant digits and number lists on one line."""
    def r(o):
        if isinstance(o, float):
            return float("%.9g" % o)
        if isinstance(o, dict):
            return {k: r(v) for k, v in o.items()}
        if isinstance(o, list):
            return [r(v) for v in o]
        return o
    text = json.dumps(r(obj), indent=1)
    return re.sub(r"\[\s*([-0-9.e+,\s]+?)\s*\]", lambda m: "[" + ", ".join(m.group(1).split()).replace(",,", ",") + "]",
                  text)


def main(argv):
    out = argv[1] if len(argv) > 1 else OUT
    os.makedirs(out, exist_ok=True)
    furnace(os.path.join(out, "furnace.gltf"), spectral=False)
    furnace(os.path.join(out, "furnace_spectral.gltf"), spectral=True)
    plane_irradiance(os.path.join(out, "plane_irradiance.gltf"))
    grey_box_sky(os.path.join(out, "grey_box_sky.gltf"))

    a = FURNACE_ALBEDO
    geo = lambda d: 1.0 / (1 - a) if d < 0 else (1 - a ** d) / (1 - a)  # noqa: E731
    ee_rgb, ee_xyz = equal_energy_srgb()
    w, fc, fc_num, f_corner, f_mean = plane_expected()
    plane_value = PLANE_ALBEDO * PLANE_L0 * f_mean
    expected = {
        "about": "Expected image means (linear sRGB, every channel) of the analytic scenes, written by "
                 "tools/make_test_scenes.py; see README.md. by_max_depth: --max-depth D (path segments "
                 "from the camera, -1 = unlimited). Tolerances are the test's business.",
        "furnace.gltf": {
            "albedo": a, "emitted_radiance": 1.0,
            "formula": "Le * (1 - a^D) / (1 - a); Le / (1 - a) unlimited",
            "rgb_unlimited": [geo(-1)] * 3,
            "by_max_depth": {str(d): [geo(d)] * 3 for d in DEPTHS},
        },
        "furnace_spectral.gltf": {
            "albedo": a, "emitted_radiance": "1 at every wavelength 360-830 nm (equal-energy white, Y = 1)",
            "formula": "srgb(E) * (1 - a^D) / (1 - a), srgb(E) = linear sRGB of XYZ (sum xbar/sum ybar, 1, "
                       "sum zbar/sum ybar)",
            "equal_energy_xyz": ee_xyz, "equal_energy_srgb": ee_rgb,
            "rgb_unlimited": [c * geo(-1) for c in ee_rgb],
            "by_max_depth": {str(d): [c * geo(d) for c in ee_rgb] for d in DEPTHS},
        },
        "plane_irradiance.gltf": {
            "albedo": PLANE_ALBEDO, "emitted_radiance": PLANE_L0, "emitter_half_side_m": PLANE_S,
            "emitter_height_m": PLANE_H, "framed_half_width_m": w,
            "formula": "rho * L0 * F, F = view factor point -> parallel coaxial square; centre: "
                       "F = (4/pi) X/sqrt(1+X^2) atan(X/sqrt(1+X^2)), X = s/h; image mean = rho L0 mean(F) "
                       "over the framed square",
            "view_factor_centre": fc, "view_factor_framed_corner": f_corner, "view_factor_framed_mean": f_mean,
            "rgb_unlimited": [plane_value] * 3,
            "by_max_depth": {str(d): [0.0 if d == 1 else plane_value] * 3 for d in DEPTHS},
        },
        "grey_box_sky.gltf": {
            "albedo": GREY_ALBEDO, "sky": "spectrace's default white sky: D65 of radiance 1 (linear sRGB 1, 1, 1)",
            "formula": "every face: rho * 1 (a convex Lambertian object under a uniform sky); the sky: 1",
            "face_rgb": [GREY_ALBEDO] * 3,
            "by_max_depth": {str(d): [0.0 if d == 1 else GREY_ALBEDO] * 3 for d in DEPTHS},
        },
    }
    assert abs(fc - fc_num) < 1e-12
    with open(os.path.join(out, "expected.json"), "w") as f:
        f.write(dump_json(expected) + "\n")
    print("wrote furnace.gltf, furnace_spectral.gltf, plane_irradiance.gltf, grey_box_sky.gltf, "
          "expected.json in %s" % out)
    print("furnace: %.6f unlimited; furnace_spectral: %s" % (geo(-1), " ".join("%.6f" % (c * geo(-1)) for c in ee_rgb)))
    print("plane: F centre %.8f, framed corner %.8f, framed mean %.8f -> radiance %.8f"
          % (fc, f_corner, f_mean, plane_value))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
