#!/usr/bin/env python3
"""Renders one of spectrace's glTF scenes with Mitsuba 3 (spectral), for comparison.

    python3 tools/scene_to_mitsuba.py scenes/cornell_box.gltf --spp 64 --max-depth 8 \
        --size 256 -o /tmp/cbox_mitsuba.exr

Reads the glTF with json + numpy (no other glTF library) and supports what the
project's scenes use: triangle meshes (mode 4) under node transforms (matrix or
TRS; a mirroring transform flips the winding back to counter-clockwise), with
their NORMALs as Mitsuba vertex normals (else flat faces); one-sided emission
(emissiveFactor * KHR_materials_emissive_strength as an RGB illuminant, or
extras.spectrace.emission [[nm, v]] / a named SPD); KHR_lights_punctual point
lights; the first perspective camera (yfov, znear); and the materials that have
an exact Mitsuba counterpart (material_to_mitsuba):

  glTF material                                           Mitsuba plugin
  metallic 0, KHR_materials_specular specularFactor 0     diffuse (baseColorFactor
                                                          or extras reflectance)
  metallic 1, extras.spectrace.conductor "Au"/"Ag"/"Cu"/"Al"  conductor (roughness 0)
                                                          or roughconductor (ggx,
                                                          alpha = roughness^2,
                                                          sample_visible) with that
                                                          material's measured eta, k
  metallic 1, baseColorFactor white, no conductor         the same with material
                                                          "none" (Schlick with F0 = 1
                                                          is exactly 1)
  metallic 0, KHR_materials_transmission 1, white,        dielectric / roughdielectric
  KHR_materials_ior (default 1.5)                         (int_ior = ior, ext_ior 1,
                                                          ggx, alpha = roughness^2)

KHR_materials_dispersion: Mitsuba's dielectrics have one ior, and a Mitsuba path
carries 4 wavelengths that must take one direction, so a dispersive glass is
rendered in wavelength bands (--dispersion-bands, default 24 over 360-830 nm):
band k restricts the sensor's spectral response (`srf`) to [a_k, b_k], gives
every dispersive glass the ior of the extension's formula at the band's middle,
n(l) = n_d + (n_d - 1) / V_d (523655 / l^2 - 1.5168) with V_d = 20 / dispersion,
and the image is the sum of the bands (each at spp / bands samples, so the cost
is about one render). Exact up to the ior's variation inside a band (under
0.01 at dispersion 2 for 20 nm bands). With --approx the ior is constant (n_d).

Anything else (glTF's 4% specular layer over diffuse, coloured Schlick metals,
metallic or transmission between 0 and 1, volumes, textures, unlit, clearcoat,
sheen) is refused with an error naming the material; with --approx it is
converted to the nearest of the above and a warning says how.

Lights: with no emissive material and no punctual light, spectrace lights the
scene with a uniform D65 sky of film Y = 1; so does this converter (a Mitsuba
`constant` emitter), unless --background says otherwise (black, or R,G,B).
A point light of intensity Iv candela and linear RGB colour c becomes a Mitsuba
`point` emitter of RGB intensity c Iv (an RGB illuminant, D65 times the
upsampled colour; the film's unit is the nit: kernels/light/lights.h). A
spot light becomes 32 nested Mitsuba `spot`s of the same intensity whose sum
is glTF's recommended falloff between the cones (t^2 with t linear in the
cosine; Mitsuba's own is linear in the angle) interpolated linearly in the
angle (light_to_mitsuba); --approx makes it one `spot` with beam_width =
innerConeAngle and cutoff_angle = outerConeAngle. Directional lights are
refused.

Conventions matched with spectrace: Mitsuba's path integrator max_depth counts
path segments from the camera (1 = emitters only, -1 = unlimited); RGB
emission is D65 times the upsampled spectrum; spectral tables are piecewise
linear and zero outside their range; images are linear sRGB. Colour (--colour,
"Colour" below): by default Mitsuba gets spectrace's observer (the CIE 1931 1 nm
table on a specfilm) and every RGB colour as the 1 nm table of its exact
sigmoid upsampling, computed here; --colour mitsuba uses Mitsuba's own.

Variant: llvm_ad_spectral when libLLVM 16+ is found (DRJIT_LIBLLVM_PATH, or
/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1 etc.; apt-get install libllvm19),
else scalar_spectral. Needs `pip install mitsuba numpy`.
"""
import argparse
import base64
import glob
import json
import math
import os
import sys
import tempfile
import time

try:
    import numpy as np
except ImportError:  # pragma: no cover
    np = None

MITSUBA_MISSING = ("mitsuba (and numpy) are not installed: `pip install mitsuba numpy` "
                   "to render with Mitsuba 3")


# ---------------------------------------------------------------------------
# glTF reading
# ---------------------------------------------------------------------------
_CTYPES = {5120: "i1", 5121: "u1", 5122: "<i2", 5123: "<u2", 5125: "<u4", 5126: "<f4"}
_NCOMP = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT4": 16}


def _load_buffers(doc, folder):
    out = []
    for b in doc.get("buffers", []):
        uri = b.get("uri")
        if uri is None:
            raise ValueError("GLB binary chunks are not supported by this converter (use .gltf)")
        if uri.startswith("data:"):
            out.append(base64.b64decode(uri.split(",", 1)[1]))
        else:
            from urllib.parse import unquote
            with open(os.path.join(folder, unquote(uri)), "rb") as f:
                out.append(f.read())
    return out


def _accessor(doc, bufs, i):
    acc = doc["accessors"][i]
    n = _NCOMP[acc["type"]]
    dt = np.dtype(_CTYPES[acc["componentType"]])
    count = acc["count"]
    if "bufferView" not in acc:
        return np.zeros((count, n), dt)
    bv = doc["bufferViews"][acc["bufferView"]]
    data = bufs[bv["buffer"]]
    off = bv.get("byteOffset", 0) + acc.get("byteOffset", 0)
    stride = bv.get("byteStride", 0) or n * dt.itemsize
    raw = np.frombuffer(data, np.uint8, count=(count - 1) * stride + n * dt.itemsize, offset=off)
    rows = np.lib.stride_tricks.as_strided(raw, (count, n * dt.itemsize), (stride, 1))
    return np.ascontiguousarray(rows).view(dt).reshape(count, n)


def _quat_to_mat(q):
    x, y, z, w = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def _node_matrix(node):
    if "matrix" in node:
        return np.array(node["matrix"], dtype=np.float64).reshape(4, 4).T  # column-major
    m = np.eye(4)
    s = np.array(node.get("scale", [1, 1, 1]), dtype=np.float64)
    m[:3, :3] = _quat_to_mat(node.get("rotation", [0, 0, 0, 1])) * s[None, :]
    m[:3, 3] = node.get("translation", [0, 0, 0])
    return m


def load_gltf(path):
    """The scene as plain numpy data: {'shapes': [(name, positions (N,3), faces
    (F,3), material index)], 'materials': [...], 'camera': {...} or None,
    'warnings': [...]}; positions in world space, faces counter-clockwise."""
    with open(path) as f:
        doc = json.load(f)
    bufs = _load_buffers(doc, os.path.dirname(os.path.abspath(path)))
    warnings = []
    shapes, camera, lights = [], None, []
    scene = doc.get("scenes", [{}])[doc.get("scene", 0)] if doc.get("scenes") else {
        "nodes": list(range(len(doc.get("nodes", []))))}
    stack = [(n, np.eye(4)) for n in scene.get("nodes", [])]
    seen = set()
    while stack:
        ni, parent = stack.pop()
        if ni in seen:
            raise ValueError("node %d is visited twice (loop or two parents)" % ni)
        seen.add(ni)
        node = doc["nodes"][ni]
        world = parent @ _node_matrix(node)
        stack.extend((c, world) for c in node.get("children", []))
        if "extensions" in node and "KHR_lights_punctual" in node["extensions"]:
            li = node["extensions"]["KHR_lights_punctual"]["light"]
            light = doc["extensions"]["KHR_lights_punctual"]["lights"][li]
            lights.append({"index": li, "node": ni, "light": light, "position": world[:3, 3].copy(),
                           "direction": -world[:3, 2] / np.linalg.norm(world[:3, 2])})
        if "camera" in node and camera is None:
            cam = doc["cameras"][node["camera"]]
            if cam.get("type") == "perspective":
                p = cam["perspective"]
                camera = {"origin": world[:3, 3].copy(),
                          "forward": -world[:3, 2] / np.linalg.norm(world[:3, 2]),
                          "up": world[:3, 1] / np.linalg.norm(world[:3, 1]),
                          "yfov": float(p["yfov"]), "aspect": p.get("aspectRatio"),
                          "znear": float(p.get("znear", 1e-3))}
            else:
                warnings.append("cameras[%d]: orthographic camera not converted" % node["camera"])
        if "mesh" not in node:
            continue
        mirror = np.linalg.det(world[:3, :3]) < 0
        mesh = doc["meshes"][node["mesh"]]
        for pi, prim in enumerate(mesh["primitives"]):
            where = "meshes[%d].primitives[%d]" % (node["mesh"], pi)
            if prim.get("mode", 4) != 4:
                warnings.append("%s: mode %d skipped (triangles only)" % (where, prim.get("mode")))
                continue
            pos = _accessor(doc, bufs, prim["attributes"]["POSITION"]).astype(np.float64)
            pos = pos @ world[:3, :3].T + world[:3, 3]
            if "indices" in prim:
                idx = _accessor(doc, bufs, prim["indices"]).astype(np.int64).reshape(-1)
            else:
                idx = np.arange(len(pos))
            faces = idx[: len(idx) // 3 * 3].reshape(-1, 3)
            if mirror:
                faces = faces[:, ::-1]
            nrm = None
            if "NORMAL" in prim["attributes"]:
                nrm = _accessor(doc, bufs, prim["attributes"]["NORMAL"]).astype(np.float64)
                nrm = nrm @ np.linalg.inv(world[:3, :3])   # (M^-T n) as rows
                nrm /= np.maximum(np.linalg.norm(nrm, axis=1, keepdims=True), 1e-30)
            # Drop degenerate triangles (Mitsuba would keep them; they have no area).
            v0, v1, v2 = pos[faces[:, 0]], pos[faces[:, 1]], pos[faces[:, 2]]
            area = np.linalg.norm(np.cross(v1 - v0, v2 - v0), axis=1)
            faces = faces[np.isfinite(area) & (area > 0)]
            name = "%s_%d_%d" % (mesh.get("name", "mesh"), ni, pi)
            shapes.append((name, pos.astype(np.float32), faces.astype(np.uint32), prim.get("material", -1),
                           None if nrm is None else nrm.astype(np.float32)))
    mats = doc.get("materials", [])
    return {"shapes": shapes, "materials": mats, "camera": camera, "lights": lights,
            "warnings": warnings, "doc": doc}


# ---------------------------------------------------------------------------
# Mitsuba
# ---------------------------------------------------------------------------
LLVM_CANDIDATES = ["/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1", "/usr/lib/x86_64-linux-gnu/libLLVM-19.so",
                   "/usr/lib/x86_64-linux-gnu/libLLVM-18.so", "/usr/lib/x86_64-linux-gnu/libLLVM-17.so",
                   "/usr/lib/x86_64-linux-gnu/libLLVM-16.so"]


def import_mitsuba(variant="auto"):
    """Imports mitsuba and sets a spectral variant; returns the module or None."""
    if variant in ("auto", "llvm_ad_spectral") and "DRJIT_LIBLLVM_PATH" not in os.environ:
        for c in LLVM_CANDIDATES + sorted(glob.glob("/usr/lib/llvm-1[6-9]/lib/libLLVM*.so*")):
            if os.path.exists(c):
                os.environ["DRJIT_LIBLLVM_PATH"] = c
                break
    try:
        import mitsuba as mi
    except ImportError:
        return None
    if np is None:
        return None
    order = ["llvm_ad_spectral", "scalar_spectral"] if variant == "auto" else [variant]
    for v in order:
        try:
            mi.set_variant(v)
            return mi
        except Exception as e:  # noqa: BLE001 (drjit raises several types when LLVM is missing)
            last = e
    raise RuntimeError("cannot set Mitsuba variant %s: %s" % (variant, last))


def _spectrum_table(table):
    table = sorted((float(a), float(b)) for a, b in table)
    return {"type": "irregular", "wavelengths": ", ".join("%.9g" % a for a, _ in table),
            "values": ", ".join("%.9g" % b for _, b in table)}


def _named_spd(name, warnings):
    n = name.strip().lower()
    if n == "d65":
        return {"type": "d65"}
    if n.startswith("blackbody:"):
        warnings.append("named SPD %r: Mitsuba blackbody (Planck, W/(m^2 sr nm)); "
                        "check spectrace uses the same scale" % name)
        return {"type": "blackbody", "temperature": float(n.split(":", 1)[1])}
    if n == "a":
        # CIE illuminant A by its defining formula, 100 at 560 nm.
        wl = np.arange(360.0, 831.0, 5.0)
        c2 = 1.435e7
        v = 100.0 * (560.0 / wl) ** 5 * (math.exp(c2 / (2848 * 560.0)) - 1) / (np.exp(c2 / (2848 * wl)) - 1)
        warnings.append("named SPD 'A': CIE formula, 100 at 560 nm; check spectrace uses the same scale")
        return _spectrum_table(zip(wl, v))
    raise ValueError("named SPD %r is not supported by scene_to_mitsuba.py" % name)


def _spd(value, warnings):
    return _named_spd(value, warnings) if isinstance(value, str) else _spectrum_table(value)


# ---------------------------------------------------------------------------
# Colour: the observer and the RGB upsampling
# ---------------------------------------------------------------------------
# --colour exact (default) gives Mitsuba spectrace's colour definitions, computed
# here independently: the CIE 1931 2-degree observer of kernels/spectrum/cie_data.h (the
# CIE's 1 nm table, normalised by the sum of ybar) as the response of a Mitsuba
# `specfilm` (XYZ, converted to linear sRGB with the matrix of docs/architecture.md),
# and every RGB colour as a 1 nm table of the Jakob-Hanika sigmoid spectrum whose
# colour under D65 (Y = 1) is exactly that RGB under the same observer (greys as
# constant spectra; an illuminant RGB c as 2 max(c) * D65 * the reflectance
# spectrum of c / (2 max(c))). --colour mitsuba keeps Mitsuba's own: its
# built-in observer (CIE tables at 5 nm, normalised by a fixed constant 0.09%
# off their integral) on an `hdrfilm`, and its `srgb` / `d65` upsampling tables
# (trilinear in coefficients, so a colour comes back up to a few tenths of a
# percent off in a small channel). Either way the renderers see the same scene;
# exact makes a block-by-block comparison measure light transport, not two
# colour conventions.
XYZ_TO_SRGB = [[3.2406, -1.5372, -0.4986], [-0.9689, 1.8758, 0.0415], [0.0557, -0.2040, 1.0570]]
_OBSERVER = None


def observer():
    """{'nm', 'x', 'y', 'z', 'd65'} 1 nm arrays over 360..830 from kernels/spectrum/cie_data.h,
    and 'y_integral' (the sum of ybar)."""
    global _OBSERVER
    if _OBSERVER is None:
        import re
        root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
        path = os.path.join(root, "kernels", "spectrum", "cie_data.h")
        if not os.path.exists(path):
            raise ValueError("kernels/spectrum/cie_data.h not found (the observer of --colour exact)")
        with open(path) as f:
            text = f.read()
        obs = {}
        for key, name in (("x", "SPT_CIE_X"), ("y", "SPT_CIE_Y"), ("z", "SPT_CIE_Z"), ("d65", "SPT_D65_NORM")):
            body = re.search(r"float %s\[SPT_CIE_SAMPLES\] = \{(.*?)\};" % name, text, re.S).group(1)
            obs[key] = np.array([float(v.strip().rstrip("f")) for v in body.split(",") if v.strip()])
        obs["nm"] = 360.0 + np.arange(len(obs["x"]))
        obs["y_integral"] = float(obs["y"].sum())
        m = np.array(XYZ_TO_SRGB)
        # Linear sRGB weight of each 1 nm sample of a reflectance under D65 (Y = 1).
        obs["w"] = (m @ np.stack([obs["x"], obs["y"], obs["z"]])) * obs["d65"] / obs["y_integral"]
        _OBSERVER = obs
    return _OBSERVER


def _sigmoid(a, t):
    x = (a[0] * t + a[1]) * t + a[2]
    return 0.5 + x / (2.0 * np.sqrt(1.0 + x * x))


def reflectance_spectrum(rgb):
    """The 1 nm values (360..830) of the sigmoid spectrum whose colour under D65 is
    rgb (clamped to [0, 1]): Levenberg-Marquardt in t = (nm - 360) / 470, walking
    from the grey of the same mean to rgb in 16 steps (each fit starting from the
    last, as Jakob and Hanika fill their table), to 1e-9; least squares where
    no sigmoid reaches rgb."""
    obs = observer()
    rgb = np.clip(np.nan_to_num(np.asarray(rgb, dtype=np.float64)), 0.0, 1.0)
    n = len(obs["nm"])
    if rgb[0] == rgb[1] == rgb[2]:
        return np.full(n, rgb[0])
    t = np.arange(n) / (n - 1.0)
    w = obs["w"]
    grey = np.full(3, min(max(rgb.mean(), 1e-3), 1 - 1e-3))
    a = np.array([0.0, 0.0, (grey[0] - 0.5) / math.sqrt(grey[0] * (1 - grey[0]))])

    def colour(a):
        x = (a[0] * t + a[1]) * t + a[2]
        q = 1.0 / np.sqrt(1.0 + x * x)
        s = 0.5 + 0.5 * x * q
        ds = 0.5 * q ** 3
        return w @ s, w @ (ds[:, None] * np.stack([t * t, t, np.ones(n)], axis=1))

    for k in range(1, 17):
        target = grey + (rgb - grey) * (k / 16.0)
        mu = 1e-3
        col, jac = colour(a)
        err = float(((col - target) ** 2).sum())
        for _ in range(100):
            if err < 1e-18:
                break
            jtj, jtr = jac.T @ jac, jac.T @ (col - target)
            for _ in range(30):
                d = np.linalg.solve(jtj + mu * np.diag(np.diag(jtj) + 1e-30), jtr)
                na = a - d
                ncol, njac = colour(na)
                nerr = float(((ncol - target) ** 2).sum())
                if nerr < err:
                    a, col, jac, err = na, ncol, njac, nerr
                    mu = max(mu * 0.1, 1e-12)
                    break
                mu *= 10.0
            else:
                break
    return _sigmoid(a, t)


def _table(values):
    obs = observer()
    return {"type": "irregular", "wavelengths": ", ".join("%g" % v for v in obs["nm"]),
            "values": ", ".join("%.9g" % max(float(v), 0.0) for v in values)}


def rgb_reflectance(rgb, colour="exact"):
    """A Mitsuba spectrum for a reflectance given as linear sRGB."""
    if colour == "mitsuba":
        return {"type": "rgb", "value": [float(c) for c in rgb]}
    if not max(float(c) for c in rgb) > 0:
        # Black (an emitter's base colour): Mitsuba refuses a table of zeros.
        return {"type": "uniform", "value": 0.0}
    return _table(reflectance_spectrum(rgb))


def rgb_illuminant(rgb, colour="exact"):
    """A Mitsuba spectrum for an emitter's linear sRGB (any scale): D65 times the
    upsampled colour, as spectrace's rgb_illuminant_coeffs defines it."""
    rgb = [max(float(c), 0.0) for c in rgb]
    if colour == "mitsuba":
        return {"type": "rgb", "value": rgb}
    m = max(rgb)
    if not m > 0:
        return {"type": "uniform", "value": 0.0}
    scale = 2.0 * m
    return _table(scale * reflectance_spectrum([c / scale for c in rgb]) * observer()["d65"])


def xyz_film(width, height, window=None):
    """A Mitsuba specfilm whose three channels are the CIE 1931 xbar, ybar, zbar
    of kernels/spectrum/cie_data.h (optionally zero outside the wavelength window (a, b)):
    each pixel gets the integral of radiance times each function, in nm."""
    obs = observer()
    film = {"type": "specfilm", "width": int(width), "height": int(height), "component_format": "float32",
            "rfilter": {"type": "box"}}
    for name in ("x", "y", "z"):
        nm, v = obs["nm"], np.maximum(obs[name], 0.0)
        if window is not None:
            a, b = window
            inside = (nm > a) & (nm < b)
            nm = np.concatenate([[a - 1e-3, a], nm[inside], [b, b + 1e-3]])
            v = np.concatenate([[0.0, np.interp(a, obs["nm"], v)], v[inside], [np.interp(b, obs["nm"], v), 0.0]])
            if not v.any():
                # Mitsuba refuses a response without mass (zbar past 650 nm):
                # 1e-20 inside the window leaves that channel 0 to 1e-20.
                v[1:-1] = 1e-20
        film["cie_" + name] = {"type": "irregular", "wavelengths": ", ".join("%.6f" % q for q in nm),
                               "values": ", ".join("%.9g" % q for q in v)}
    return film


def film_to_srgb(img):
    """Linear sRGB of a specfilm image (H x W x 3 integrals against xbar, ybar, zbar)."""
    xyz = np.asarray(img, dtype=np.float64)[..., :3] / observer()["y_integral"]
    return xyz @ np.array(XYZ_TO_SRGB).T


class NotExact(ValueError):
    """A material, light or setting without an exact Mitsuba counterpart."""


CONDUCTORS = ("Au", "Ag", "Cu", "Al")
# Extensions that change nothing the converter maps (or that it checks itself).
_MAPPED_EXTENSIONS = {"KHR_materials_emissive_strength", "KHR_materials_specular", "KHR_materials_transmission",
                      "KHR_materials_ior", "KHR_materials_dispersion", "KHR_materials_volume"}


def _microfacet(kind, roughness):
    """Mitsuba's smooth plugin for roughness 0, else the rough one with GGX and
    alpha = roughness^2 (glTF's convention) and visible-normal sampling."""
    if roughness == 0.0:
        return {"type": kind}
    return {"type": "rough" + kind, "distribution": "ggx", "alpha": float(roughness) ** 2, "sample_visible": True}


def material_to_mitsuba(m, warnings, where="material", approx=False, colour="exact"):
    """(bsdf dict, emitter dict or None) for one glTF material. A material that
    Mitsuba cannot render exactly the way spectrace does raises NotExact naming
    it, or, with approx, is converted to the nearest plugin with a warning."""
    def inexact(msg):
        msg = "%s '%s': %s" % (where, m.get("name", ""), msg)
        if not approx:
            raise NotExact(msg + " (no exact Mitsuba counterpart; --approx converts it anyway)")
        warnings.append(msg)

    spec = m.get("extras", {}).get("spectrace", {}) if isinstance(m.get("extras"), dict) else {}
    pbr = m.get("pbrMetallicRoughness", {})
    ext = m.get("extensions", {})
    for key in ("normalTexture", "occlusionTexture", "emissiveTexture"):
        if key in m:
            inexact("%s not converted" % key)
    for key in ("baseColorTexture", "metallicRoughnessTexture"):
        if key in pbr:
            inexact("%s not converted (the factor is used)" % key)
    for e in ext:
        if e not in _MAPPED_EXTENSIONS:
            inexact("%s not converted" % e)
    base = [float(c) for c in pbr.get("baseColorFactor", [1, 1, 1, 1])[:3]]
    metallic = float(pbr.get("metallicFactor", 1.0))
    roughness = float(pbr.get("roughnessFactor", 1.0))
    transmission = float(ext.get("KHR_materials_transmission", {}).get("transmissionFactor", 0.0))
    ior = float(ext.get("KHR_materials_ior", {}).get("ior", 1.5))
    dispersion = float(ext.get("KHR_materials_dispersion", {}).get("dispersion", 0.0))
    specular = float(ext.get("KHR_materials_specular", {}).get("specularFactor", 1.0))
    volume = ext.get("KHR_materials_volume", {})
    conductor = spec.get("conductor")
    white = all(c == 1.0 for c in base)

    if metallic not in (0.0, 1.0):
        inexact("metallicFactor %g (only 0 or 1 map exactly)" % metallic)
        metallic = round(metallic)
    if conductor is not None and conductor not in CONDUCTORS:
        raise NotExact("%s '%s': conductor %r is not one of %s" % (where, m.get("name", ""), conductor,
                                                                  ", ".join(CONDUCTORS)))
    if metallic == 1.0:
        if conductor is None:
            if not white:
                inexact("a coloured Schlick metal (baseColorFactor %s) is not Mitsuba's exact Fresnel; "
                        "converted as a perfect reflector" % base)
            conductor = "none"
        bsdf = _microfacet("conductor", roughness)
        bsdf["material"] = conductor
    elif transmission > 0.0:
        if transmission != 1.0:
            inexact("transmissionFactor %g (only 1 maps exactly)" % transmission)
        if not white:
            inexact("tinted transmission (baseColorFactor %s) not converted" % base)
        if dispersion != 0.0 and approx:
            inexact("dispersion %g converted as a constant ior %g (the value at 587.56 nm)" % (dispersion, ior))
        if specular != 1.0:
            inexact("specularFactor %g on a dielectric not converted" % specular)
        if volume.get("attenuationDistance") is not None or volume.get("attenuationColor") not in (None, [1, 1, 1]):
            inexact("KHR_materials_volume attenuation not converted")
        bsdf = _microfacet("dielectric", roughness)
        bsdf.update({"int_ior": ior, "ext_ior": 1.0})
        if dispersion != 0.0 and not approx:
            bsdf["_dispersion"] = (ior, dispersion)   # resolved per band by render()
        return bsdf, _emitter(m, spec, warnings, colour)
    else:
        if conductor is not None:
            inexact("extras.spectrace.conductor on a material with metallicFactor 0 is unused")
        if specular != 0.0:
            inexact("glTF's dielectric specular layer (F0 0.04 x specularFactor %g) over the diffuse base "
                    "converted as plain diffuse (KHR_materials_specular specularFactor 0 makes it exact)"
                    % specular)
        if "reflectance" in spec:
            refl = _spd(spec["reflectance"], warnings)
        else:
            refl = rgb_reflectance(base, colour)
        bsdf = {"type": "diffuse", "reflectance": refl}
    if m.get("doubleSided"):
        bsdf = {"type": "twosided", "bsdf": bsdf}
    return bsdf, _emitter(m, spec, warnings, colour)


def _emitter(m, spec, warnings, colour="exact"):
    """The area emitter of a material, or None."""
    emitter = None
    if "emission" in spec:
        emitter = {"type": "area", "radiance": _spd(spec["emission"], warnings)}
    else:
        e = [float(c) for c in m.get("emissiveFactor", [0, 0, 0])]
        s = float(m.get("extensions", {}).get("KHR_materials_emissive_strength", {}).get("emissiveStrength", 1.0))
        if max(e) * s > 0:
            emitter = {"type": "area", "radiance": rgb_illuminant([c * s for c in e], colour)}
    return emitter


# Film Y of 1 cd/m^2 (kernels/light/lights.h SPT_LIGHT_FILM_Y_PER_NIT): 1, the nit.
FILM_Y_PER_NIT = 1.0


# Linear ramps per spot light (light_to_mitsuba).
SPOT_RAMPS = 32


def light_to_mitsuba(entry, approx=False, warnings=None, colour="exact"):
    """A Mitsuba emitter for one KHR_lights_punctual light (point and spot lights)."""
    light = entry["light"]
    kind = light.get("type")
    where = "lights[%d] '%s'" % (entry["index"], light.get("name", ""))
    if kind not in ("point", "spot"):
        raise NotExact("%s: %s lights are not converted" % (where, kind))
    col = [float(c) for c in light.get("color", [1, 1, 1])]
    k = float(light.get("intensity", 1.0)) * FILM_Y_PER_NIT
    if kind == "point":
        return {"type": "point", "position": [float(x) for x in entry["position"]],
                "intensity": rgb_illuminant([c * k for c in col], colour)}
    import mitsuba as mi
    spot = light.get("spot", {})
    inner = float(spot.get("innerConeAngle", 0.0))
    outer = float(spot.get("outerConeAngle", math.pi / 4))
    o = np.asarray(entry["position"], dtype=float)
    dvec = np.asarray(entry["direction"], dtype=float)
    up = [0.0, 1.0, 0.0] if abs(dvec[1]) < 0.9 else [0.0, 0.0, 1.0]
    to_world = mi.ScalarTransform4f().look_at(origin=o.tolist(), target=(o + dvec).tolist(), up=up)
    intensity = rgb_illuminant([c * k for c in col], colour)
    if outer <= inner or approx:
        if approx and outer > inner:
            msg = ("%s: spot cones %.4g and %.4g rad: glTF's falloff between the cones (t^2, t linear in the "
                   "cosine) is not Mitsuba's (linear in the angle)" % (where, inner, outer))
            if warnings is not None:
                warnings.append(msg + "; converted with Mitsuba's falloff")
        return {"type": "spot", "intensity": intensity, "cutoff_angle": math.degrees(outer),
                "beam_width": math.degrees(min(inner, outer)), "to_world": to_world}
    # glTF's falloff g = t^2, t = (x_out - x) / (x_out - x_in) in x = 1 - cos,
    # as the sum of SPOT_RAMPS nested Mitsuba spots: spot j is full out to
    # knot j-1, falls linearly in the angle to 0 at knot j (knots equally
    # spaced in the angle from inner to outer) and has weight g(knot j-1) -
    # g(knot j), so the sum is g at every knot and linear in the angle between
    # (its flux within 1e-4 of glTF's for cones 1.5 and 2 degrees, 5e-4 for
    # 0 and 20 degrees; one Mitsuba spot would be 8.8% and 0.4% over). Each
    # spot's sampling weight is about its flux, so light paths start from the
    # spots in proportion to the light they carry.
    def one_minus_cos(a):
        return 2.0 * math.sin(0.5 * a) ** 2

    def g(a):
        return ((one_minus_cos(outer) - one_minus_cos(a)) / (one_minus_cos(outer) - one_minus_cos(inner))) ** 2

    knots = [inner + (outer - inner) * j / SPOT_RAMPS for j in range(SPOT_RAMPS + 1)]
    spots = []
    for j in range(1, SPOT_RAMPS + 1):
        w = g(knots[j - 1]) - (g(knots[j]) if j < SPOT_RAMPS else 0.0)
        spots.append({"type": "spot", "intensity": rgb_illuminant([c * k * w for c in col], colour),
                      "cutoff_angle": math.degrees(knots[j]), "beam_width": math.degrees(knots[j - 1]),
                      "sampling_weight": w * one_minus_cos(knots[j]), "to_world": to_world})
    return spots


def parse_background(text):
    """None (the default sky), [] (black) or [r, g, b] from --background."""
    if text is None:
        return None
    if text.strip().lower() == "black":
        return []
    try:
        v = [float(x) for x in text.split(",")]
    except ValueError:
        v = []
    if len(v) != 3 or min(v) < 0:
        raise ValueError("--background: want black or R,G,B (got %r)" % text)
    return v


def _write_ply(path, pos, faces, normals=None):
    with open(path, "wb") as f:
        f.write(("ply\nformat binary_little_endian 1.0\nelement vertex %d\n"
                 "property float x\nproperty float y\nproperty float z\n%s"
                 "element face %d\nproperty list uchar uint vertex_indices\nend_header\n"
                 % (len(pos), "property float nx\nproperty float ny\nproperty float nz\n" if normals is not None
                    else "", len(faces))).encode("ascii"))
        data = pos if normals is None else np.concatenate([pos, normals], axis=1)
        f.write(np.ascontiguousarray(data, "<f4").tobytes())
        rec = np.zeros(len(faces), dtype=[("n", "u1"), ("i", "<u4", 3)])
        rec["n"] = 3
        rec["i"] = faces
        f.write(rec.tobytes())


def scene_dict(mi, scene, width, height, spp, max_depth, tmpdir, seed=0, approx=False, background=None,
               colour="exact", integrator="path"):
    """The Mitsuba scene dictionary (meshes written as PLY files into tmpdir).
    Raises NotExact for what has no exact counterpart unless approx.
    background: None (spectrace's default), [] (black) or [r, g, b]."""
    warnings = scene["warnings"]
    d = {"type": "scene", "integrator": {"type": integrator, "max_depth": int(max_depth)}}
    mats = [material_to_mitsuba(m, warnings, "materials[%d]" % i, approx, colour)
            for i, m in enumerate(scene["materials"])]
    # glTF's default material is metallic 1, roughness 1, white: a rough perfect reflector.
    default = material_to_mitsuba({"name": "(default)"}, warnings, "the default material", approx, colour)
    emitting = False
    for k, (name, pos, faces, mat, nrm) in enumerate(scene["shapes"]):
        if len(faces) == 0:
            continue
        ply = os.path.join(tmpdir, "shape%04d.ply" % k)
        _write_ply(ply, pos, faces, nrm)
        bsdf, emitter = mats[mat] if mat >= 0 else default
        sh = {"type": "ply", "filename": ply, "face_normals": nrm is None, "bsdf": bsdf}
        if emitter is not None:
            sh["emitter"] = emitter
            emitting = True
        d["shape%04d" % k] = sh
    for k, entry in enumerate(scene.get("lights", [])):
        emitters = light_to_mitsuba(entry, approx, warnings, colour)
        for j, one in enumerate(emitters if isinstance(emitters, list) else [emitters]):
            d["light%03d_%02d" % (k, j)] = one
        emitting = True
    if background is None and not emitting:
        background = [1.0, 1.0, 1.0]   # spectrace's default sky: D65 at film Y = 1
    if background:
        d["background"] = {"type": "constant", "radiance": rgb_illuminant(background, colour)}
    cam = scene["camera"]
    if cam is None:
        # As spectrace's default: frame the bounds from +Z looking toward -Z, yfov 45.
        allp = np.concatenate([s[1] for s in scene["shapes"]]) if scene["shapes"] else np.zeros((1, 3))
        lo, hi = allp.min(0), allp.max(0)
        c, r = (lo + hi) / 2, max(np.linalg.norm(hi - lo) / 2, 1e-3)
        dist = r / math.tan(math.radians(22.5))
        cam = {"origin": c + np.array([0, 0, dist + (hi[2] - lo[2]) / 2]), "forward": np.array([0, 0, -1.0]),
               "up": np.array([0, 1.0, 0]), "yfov": math.radians(45), "znear": 1e-3}
        warnings.append("no camera in the file: made a default one (may differ from spectrace's)")
    o = [float(x) for x in cam["origin"]]
    t = [float(x) for x in cam["origin"] + cam["forward"]]
    u = [float(x) for x in cam["up"]]
    d["sensor"] = {
        "type": "perspective", "fov_axis": "y", "fov": math.degrees(cam["yfov"]),
        "near_clip": max(cam.get("znear", 1e-3), 1e-5), "far_clip": 1e5,
        "to_world": mi.ScalarTransform4f().look_at(origin=o, target=t, up=u),
        "sampler": {"type": "independent", "sample_count": int(spp), "seed": int(seed)},
        "film": xyz_film(width, height) if colour == "exact" else
                {"type": "hdrfilm", "width": int(width), "height": int(height), "pixel_format": "rgb",
                 "component_format": "float32", "rfilter": {"type": "box"}},
    }
    return d


def dispersion_ior(n_d, dispersion, nm):
    """KHR_materials_dispersion: the ior at wavelength nm (Abbe number 20 / dispersion)."""
    v_d = 20.0 / dispersion
    return n_d + (n_d - 1.0) / v_d * (523655.0 / (nm * nm) - 1.5168)


def band_scenes(d, bands, lo=360.0, hi=830.0):
    """[(scene dict, (a, b))]: d itself when no BSDF is dispersive, else one copy
    per wavelength band with the sensor's response restricted to the band and the
    dispersive dielectrics' int_ior at its middle."""
    import copy
    disp = [k for k, v in d.items() if isinstance(v, dict) and "_dispersion" in v.get("bsdf", {})]
    if not disp:
        return [(d, None)]
    out = []
    edges = np.linspace(lo, hi, bands + 1)
    for a, b in zip(edges, edges[1:]):
        db = copy.copy(d)
        for k in disp:
            sh = dict(d[k])
            bsdf = dict(sh["bsdf"])
            n_d, disp_k = bsdf.pop("_dispersion")
            bsdf["int_ior"] = float(dispersion_ior(n_d, disp_k, 0.5 * (a + b)))
            sh["bsdf"] = bsdf
            db[k] = sh
        db["sensor"] = dict(d["sensor"])
        if d["sensor"]["film"]["type"] == "specfilm":   # the XYZ responses cut to the band
            db["sensor"]["film"] = xyz_film(d["sensor"]["film"]["width"], d["sensor"]["film"]["height"], (a, b))
        else:
            db["sensor"]["srf"] = {"type": "irregular", "values": "0, 1, 1, 0",
                                   "wavelengths": "%.6f, %.6f, %.6f, %.6f" % (a, a + 1e-3, b - 1e-3, b)}
        out.append((db, (float(a), float(b))))
    return out


def render(scene_path, width, height, spp, max_depth, variant="auto", seed=0, pass_samples=1 << 24,
           verbose=True, warmup=False, approx=False, background=None, dispersion_bands=24, colour="exact",
           integrator="path"):
    """Renders scene_path with Mitsuba; returns (image HxWx3 float64 linear sRGB,
    info dict). The spp are split into passes of at most pass_samples paths
    (different seeds) to bound the memory of the LLVM wavefront; info carries
    the per-pass means, the standard error of the mean and the timing. A scene
    with a dispersive glass is rendered as the sum of dispersion_bands
    wavelength bands (band_scenes), each pass's spp split among them.
    integrator: Mitsuba's `path` or `ptracer` (particle tracing from the
    lights: what renders caustics of punctual lights through glass)."""
    mi = import_mitsuba(variant)
    if mi is None:
        raise ImportError(MITSUBA_MISSING)
    if integrator == "ptracer" and colour == "exact":
        # Measured with Mitsuba 3.9.1: ptracer's splats on a specfilm come out
        # about 100x too dim and tinted (a point light over a plane), while
        # on an hdrfilm they match the path integrator within the noise.
        raise NotExact("--integrator ptracer needs --colour mitsuba (Mitsuba's ptracer splats a specfilm wrongly)")
    scene = load_gltf(scene_path)
    per_pass = max(1, min(spp, pass_samples // (width * height)))
    passes = []
    n = spp
    while n > 0:
        passes.append(min(per_pass, n))
        n -= passes[-1]
    acc = np.zeros((height, width, 3))
    means, pass_blocks = [], []
    with tempfile.TemporaryDirectory(prefix="spt_mitsuba_") as tmp:
        t0 = time.time()
        d = scene_dict(mi, scene, width, height, passes[0], max_depth, tmp, approx=approx, background=background,
                       colour=colour, integrator=integrator)
        to_rgb = film_to_srgb if colour == "exact" else (lambda x: x[..., :3])
        bands = band_scenes(d, dispersion_bands)
        mscs = [mi.load_dict(db) for db, _ in bands]
        t_load = time.time() - t0
        if len(bands) > 1:
            scene["warnings"].append("dispersive glass: rendered as the sum of %d wavelength bands over %g-%g nm"
                                     % (len(bands), bands[0][1][0], bands[-1][1][1]))
        if warmup:   # compile the kernel outside the timed passes
            t0 = time.time()
            for msc in mscs:
                np.array(mi.render(msc, seed=999999, spp=1))
            if verbose:
                print("  warm-up (1 spp, kernel compilation): %.2f s" % (time.time() - t0), file=sys.stderr)
        for w in scene["warnings"]:
            print("warning: %s" % w, file=sys.stderr)
        t0, c0 = time.time(), time.process_time()
        for k, s in enumerate(passes):
            # Each band's image is the integral over its wavelengths; they add up.
            sb = max(1, int(round(s / len(mscs))))
            img = sum(to_rgb(np.array(mi.render(msc, seed=seed * 100003 + k, spp=sb if len(mscs) > 1 else s),
                                      dtype=np.float64)) for msc in mscs)
            acc += img * s
            means.append((s, img.mean(axis=(0, 1))))
            pass_blocks.append(np.array(block_means(img)))
            if verbose and len(passes) > 1:
                print("  pass %d/%d: %d spp, mean %s" % (k + 1, len(passes), s,
                                                       " ".join("%.5f" % v for v in img.mean(axis=(0, 1)))),
                      file=sys.stderr)
        t_render = time.time() - t0
        c_render = time.process_time() - c0
    img = acc / spp
    info = {"variant": mi.variant(), "mitsuba_version": mi.__version__, "spp": spp, "width": width, "colour": colour,
            "height": height, "max_depth": max_depth, "integrator": integrator, "passes": len(passes), "load_s": t_load,
            "warnings": list(scene["warnings"]),
            "dispersion_bands": len(bands) if len(bands) > 1 else 0,
            "render_s": t_render, "paths_per_s": width * height * spp / t_render,
            "cpu_s": c_render, "paths_per_cpu_s": width * height * spp / max(c_render, 1e-9),
            "mean": img.mean(axis=(0, 1)).tolist()}
    if len(passes) >= 4 and len(set(s for s, _ in means)) == 1:
        pm = np.array([m for _, m in means])
        info["stderr_of_mean"] = (pm.std(axis=0, ddof=1) / math.sqrt(len(pm))).tolist()
        pb = np.array(pass_blocks)
        info["block_stderr_4x4"] = (pb.std(axis=0, ddof=1) / math.sqrt(len(pb))).tolist()
    return img, info


def write_exr(mi, path, img):
    mi.Bitmap(np.ascontiguousarray(img, dtype=np.float32), pixel_format=mi.Bitmap.PixelFormat.RGB).write(path)


def block_means(img, n=4):
    """n x n grid of per-channel block means, row 0 at the top of the image."""
    h, w = img.shape[:2]
    return [[[round(float(v), 6) for v in img[i * h // n:(i + 1) * h // n, j * w // n:(j + 1) * w // n]
              .mean(axis=(0, 1))] for j in range(n)] for i in range(n)]


def _compact_json(obj):
    """indent=1 JSON with lists of numbers on one line."""
    import re
    text = json.dumps(obj, indent=1)
    return re.sub(r"\[\s*([-0-9.e+,\s]+?)\s*\]", lambda m: "[" + ", ".join(m.group(1).split()).replace(",,", ",") + "]",
                  text)


def record_means(path, scene_path, info, args, img):
    """Adds info as entry 'max_depth_D' of the JSON file at path (created if absent)."""
    import platform
    doc = {}
    if os.path.exists(path):
        with open(path) as f:
            doc = json.load(f)
    doc.setdefault("about", "Mitsuba 3 reference image means (linear sRGB, per channel) of %s, for tests "
                   "that compare spectrace without Mitsuba installed; block_means_4x4[row][column] are the "
                   "means of a 4 x 4 grid of blocks, row 0 at the top (they catch a mirrored image). Written by tools/scene_to_mitsuba.py "
                   "--means-json; each entry records its exact command." % scene_path)
    doc["scene"] = scene_path
    entry = {k: info[k] for k in ("width", "height", "spp", "max_depth", "variant", "mitsuba_version")}
    entry.update({"integrator": "%s (rr_depth 5), %s box filter, independent sampler"
                                % (info.get("integrator", "path"),
                                   "specfilm (CIE 1931 1 nm XYZ)" if info.get("colour") == "exact" else "hdrfilm"),
                  "colour": info.get("colour", "mitsuba"),
                  "mean": [round(v, 7) for v in info["mean"]],
                  "block_means_4x4": block_means(img)})
    if info.get("dispersion_bands"):
        entry["dispersion_bands"] = info["dispersion_bands"]
        entry["spp_per_band"] = "spp / dispersion_bands per pass (rounded); the bands' images are summed"
    if info.get("warnings"):
        entry["converter_warnings"] = info["warnings"]
    if "stderr_of_mean" in info:
        entry["stderr_of_mean"] = [float("%.3g" % v) for v in info["stderr_of_mean"]]
        entry["relative_stderr"] = [float("%.3g" % (e / m)) if m else None
                                    for e, m in zip(info["stderr_of_mean"], info["mean"])]
    if "block_stderr_4x4" in info:
        entry["block_stderr_4x4"] = [[[float("%.3g" % v) for v in b] for b in row]
                                     for row in info["block_stderr_4x4"]]
    entry.update({"passes": info["passes"], "render_s": round(info["render_s"], 2),
                  "paths_per_s": float("%.4g" % info["paths_per_s"]),
                  "machine": "%s, %d logical CPUs (shared)" % (platform.machine(), os.cpu_count() or 0),
                  "command": "python3 tools/scene_to_mitsuba.py " + " ".join(args)})
    doc["max_depth_%d" % info["max_depth"]] = entry
    tmp = path + ".tmp"
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    with open(tmp, "w") as f:
        f.write(_compact_json(doc) + "\n")
    os.replace(tmp, path)


def main(argv=None):
    ap = argparse.ArgumentParser(description="Render a spectrace glTF scene with Mitsuba 3 (spectral).")
    ap.add_argument("scene", help="a .gltf file")
    ap.add_argument("-o", "--output", help="write the image as an EXR (linear sRGB)")
    ap.add_argument("--size", type=int, default=256, help="width and height (default 256)")
    ap.add_argument("--width", type=int, help="width (overrides --size)")
    ap.add_argument("--height", type=int, help="height (overrides --size)")
    ap.add_argument("--spp", type=int, default=64, help="samples per pixel (default 64)")
    ap.add_argument("--max-depth", type=int, default=-1,
                    help="path segments from the camera, Mitsuba/spectrace convention (default -1 = unlimited)")
    ap.add_argument("--variant", default="auto",
                    help="Mitsuba variant: auto (llvm_ad_spectral if libLLVM 16+, else scalar_spectral)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--pass-samples", type=int, default=1 << 24,
                    help="at most this many paths per mi.render call (default 16777216; 0 = one pass)")
    ap.add_argument("--benchmark", action="store_true",
                    help="time paths/s: a 1 spp warm-up render first, then all spp in one pass")
    ap.add_argument("--approx", action="store_true",
                    help="convert materials without an exact Mitsuba counterpart to the nearest one (warned) "
                         "instead of refusing them")
    ap.add_argument("--background", metavar="black|R,G,B",
                    help="uniform sky as spectrace's --background (default: spectrace's rule, a D65 sky of "
                         "film Y = 1 when the scene has no light)")
    ap.add_argument("--dispersion-bands", type=int, default=24,
                    help="wavelength bands for a dispersive glass (default 24; each gets spp / bands samples)")
    ap.add_argument("--colour", choices=("exact", "mitsuba"), default="exact",
                    help="exact (default): spectrace's observer (CIE 1931, 1 nm) on a specfilm and RGB colours as "
                         "exactly upsampled 1 nm spectra; mitsuba: Mitsuba's built-in observer and srgb tables")
    ap.add_argument("--integrator", choices=("path", "ptracer"), default="path",
                    help="Mitsuba's integrator: path (default) or ptracer, particle tracing from the lights "
                         "(caustics of punctual lights seen on diffuse surfaces; sees no specular surface "
                         "from the camera)")
    ap.add_argument("--json", action="store_true", help="print the result (means, timing) as JSON")
    ap.add_argument("--means-json", metavar="FILE",
                    help="record the means (with settings, timing and this command) in FILE under the key "
                         "'max_depth_D', keeping the file's other entries (reference figures for tests)")
    a = ap.parse_args(argv)
    w, h = a.width or a.size, a.height or a.size
    try:
        one_pass = a.pass_samples <= 0 or a.benchmark
        img, info = render(a.scene, w, h, a.spp, a.max_depth, a.variant, a.seed,
                           w * h * a.spp if one_pass else a.pass_samples, warmup=a.benchmark,
                           approx=a.approx, background=parse_background(a.background),
                           dispersion_bands=a.dispersion_bands, colour=a.colour, integrator=a.integrator)
    except ImportError:
        print("skip: " + MITSUBA_MISSING)
        return 0
    except ValueError as e:   # NotExact, a bad --background, an unsupported SPD
        print("error: %s: %s" % (a.scene, e), file=sys.stderr)
        return 3
    if a.output:
        import mitsuba as mi
        write_exr(mi, a.output, img)
        info["output"] = a.output
    if a.means_json:
        record_means(a.means_json, a.scene, info, argv if argv is not None else sys.argv[1:], img)
    if a.json:
        print(json.dumps(info, indent=1))
    else:
        print("%s (%s, Mitsuba %s): %dx%d, %d spp, max depth %d" % (a.scene, info["variant"], info["mitsuba_version"],
                                                                    w, h, a.spp, a.max_depth))
        print("mean linear sRGB: %.6f %.6f %.6f" % tuple(info["mean"]))
        if "stderr_of_mean" in info:
            print("standard error:   %.6f %.6f %.6f" % tuple(info["stderr_of_mean"]))
        print("render %.2f s (%d passes, load %.2f s): %.3f M paths/s; CPU time %.2f s: %.3f M paths per CPU-second"
              % (info["render_s"], info["passes"], info["load_s"], info["paths_per_s"] / 1e6, info["cpu_s"],
                 info["paths_per_cpu_s"] / 1e6))
    return 0


if __name__ == "__main__":
    sys.exit(main())
