#!/usr/bin/env python3
"""The expected image of a textured plane of tools/make_texture_scenes.py, computed
from the glTF's PNG and the camera alone, against a render of it.

    python3 tools/texture_expected.py SCENE.gltf IMAGE.exr [--save-expected X.npy]

The head-on scenes (base_*, texcoord1, alpha_opaque, emissive, filter_*) frame a
2 x 2 m plane exactly with an orthographic camera, so pixel (x, y) of a W x H image
covers texture coordinates [x / W, (x + 1) / W] x [y / H, (y + 1) / H] (v grows
downward: uv (0, 0) is the image's upper-left corner). A Lambertian plane under the
default sky of radiance 1 shows its albedo; an emissive one under a black sky its
emission. So each pixel's expected value is the mean over its area of the
texture as the sampler filters it, times the material's factors:

- texel i of N covers [i / N, (i + 1) / N] and has its value at its centre;
- magFilter NEAREST: the texel under each point; otherwise bilinear between the
  four nearest texel centres, neighbours by the wrap mode (REPEAT,
  MIRRORED_REPEAT, CLAMP_TO_EDGE); every scene here magnifies its texture
  (mip level 0);
- "linear": the sRGB transfer function decoded before the interpolation (glTF
  2.0); "encoded": interpolated on the 8-bit values and decoded afterwards
  (what Cycles does with an 8-bit sRGB image).

Prints the image's channel means, the two expectations' means and the RMS and
largest pixel difference against each. Exit 0; 2 for unreadable input; 3 for a
scene not of this kind. Reads the EXR with Mitsuba 3 (mitsuba) or Blender (bpy),
whichever is installed ("skip:" and exit 0 without either); numpy.
"""
import argparse
import base64
import json
import os
import struct
import sys
import zlib

REPEAT, MIRRORED, CLAMP, NEAREST = 10497, 33648, 33071, 9728


def decode_png(data, np):
    """An 8-bit non-interlaced PNG (every filter type) as an H x W x C array of 0..255."""
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        raise ValueError("not a PNG")
    p, idat, w = 8, b"", None
    while p < len(data):
        n, = struct.unpack(">I", data[p:p + 4])
        tag, body = data[p + 4:p + 8], data[p + 8:p + 8 + n]
        p += 12 + n
        if tag == b"IHDR":
            w, h, depth, ctype, _, _, interlace = struct.unpack(">IIBBBBB", body)
            if depth != 8 or interlace or ctype not in (0, 2, 4, 6):
                raise ValueError("only 8-bit non-interlaced grey, RGB and RGBA PNGs")
        elif tag == b"IDAT":
            idat += body
    ch = {0: 1, 4: 2, 2: 3, 6: 4}[ctype]
    raw, stride = zlib.decompress(idat), w * ch
    out = np.zeros((h, stride), dtype=np.int64)
    prev = np.zeros(stride, dtype=np.int64)
    for y in range(h):
        f = raw[y * (stride + 1)]
        line = np.frombuffer(raw, np.uint8, stride, y * (stride + 1) + 1).astype(np.int64)
        cur = np.zeros(stride, dtype=np.int64)
        for i in range(stride):
            a = cur[i - ch] if i >= ch else 0
            b = prev[i]
            c = prev[i - ch] if i >= ch else 0
            if f == 0:
                pred = 0
            elif f == 1:
                pred = a
            elif f == 2:
                pred = b
            elif f == 3:
                pred = (a + b) // 2
            else:
                pa, pb, pc = abs(b - c), abs(a - c), abs(a + b - 2 * c)
                pred = a if pa <= pb and pa <= pc else b if pb <= pc else c
            cur[i] = (line[i] + pred) & 255
        out[y], prev = cur, cur
    img = out.reshape(h, w, ch).astype(np.float64)
    if ch < 3:
        img = np.concatenate([np.repeat(img[..., :1], 3, axis=2), img[..., 1:]], axis=2)
    return img


def srgb_decode(np, c):
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def wrap(np, i, n, mode):
    if mode == CLAMP:
        return np.clip(i, 0, n - 1)
    if mode == MIRRORED:
        p = np.mod(i, 2 * n)
        return np.where(p < n, p, 2 * n - 1 - p)
    return np.mod(i, n)


def filtered(np, tex, u, v, nearest, ws, wt):
    """The texture (H x W x 3) at coordinates u, v as the sampler filters it."""
    h, w = tex.shape[:2]
    if nearest:
        return tex[wrap(np, np.floor(v * h).astype(int), h, wt), wrap(np, np.floor(u * w).astype(int), w, ws)]
    tu, tv = u * w - 0.5, v * h - 0.5
    i0, j0 = np.floor(tu).astype(int), np.floor(tv).astype(int)
    fu, fv = (tu - i0)[..., None], (tv - j0)[..., None]
    i1, j1 = wrap(np, i0 + 1, w, ws), wrap(np, j0 + 1, h, wt)
    i0, j0 = wrap(np, i0, w, ws), wrap(np, j0, h, wt)
    return (tex[j0, i0] * (1 - fu) * (1 - fv) + tex[j0, i1] * fu * (1 - fv)
            + tex[j1, i0] * (1 - fu) * fv + tex[j1, i1] * fu * fv)


def scene_texture(doc):
    """(texture dict, RGB scale) of the one material: its emissive texture when the
    base colour is black, else its base colour texture."""
    m = doc["materials"][0]
    pbr = m.get("pbrMetallicRoughness", {})
    base = pbr.get("baseColorFactor", [1, 1, 1, 1])
    if "emissiveTexture" in m and max(base[:3]) == 0:
        s = m.get("extensions", {}).get("KHR_materials_emissive_strength", {}).get("emissiveStrength", 1.0)
        return m["emissiveTexture"], [f * s for f in m.get("emissiveFactor", [0, 0, 0])]
    if "baseColorTexture" not in pbr:
        raise ValueError("its material has neither a base colour nor an emissive texture")
    return pbr["baseColorTexture"], base[:3]


def expected(np, doc, w, h, space, ss=8):
    ref, scale = scene_texture(doc)
    t = doc["textures"][ref["index"]]
    uri = doc["images"][t["source"]]["uri"]
    if not uri.startswith("data:"):
        raise ValueError("the image is not embedded")
    png = decode_png(base64.b64decode(uri.split(",", 1)[1]), np)[..., :3] / 255.0
    samp = doc["samplers"][t["sampler"]] if "sampler" in t else {}
    nearest = samp.get("magFilter") == NEAREST
    ws, wt = samp.get("wrapS", REPEAT), samp.get("wrapT", REPEAT)
    tex = srgb_decode(np, png) if space == "linear" else png
    o = (np.arange(ss) + 0.5) / ss
    xs = (np.arange(w)[:, None] + o[None, :]).reshape(-1) / w
    ys = (np.arange(h)[:, None] + o[None, :]).reshape(-1) / h
    u, v = np.meshgrid(xs, ys)
    c = filtered(np, tex, u, v, nearest, ws, wt)
    if space == "encoded":
        c = srgb_decode(np, c)
    return c.reshape(h, ss, w, ss, 3).mean(axis=(1, 3)) * np.array(scale, dtype=np.float64)


def read_exr(path, np):
    try:
        import mitsuba as mi
        sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
        import mitsuba_compare as mc
        mi.set_variant("scalar_rgb")
        return mc.read_exr_rgb(mi, np, path)
    except ImportError:
        pass
    try:
        import bpy
        import blender_compare as bc
    except ImportError:
        return None
    return bc.read_exr(bpy, np, path)


def main(argv=None):
    ap = argparse.ArgumentParser(description="A texture scene's expected image against a render of it.")
    ap.add_argument("scene", help="a head-on plane of tools/make_texture_scenes.py")
    ap.add_argument("image", help="its render (linear EXR)")
    ap.add_argument("--save-expected", metavar="NPY", help="write the linear-value expectation (H x W x 3)")
    a = ap.parse_args(argv)
    try:
        import numpy as np
    except ImportError:
        print("skip: numpy is not installed")
        return 0
    try:
        with open(a.scene) as f:
            doc = json.load(f)
    except (OSError, ValueError) as e:
        print("error: %s: %s" % (a.scene, e), file=sys.stderr)
        return 2
    cams = doc.get("cameras") or []
    if not cams or cams[0].get("type") != "orthographic":
        print("error: %s: not a head-on plane (no orthographic camera)" % a.scene, file=sys.stderr)
        return 3
    if not os.path.isfile(a.image):
        print("error: %s: no such file" % a.image, file=sys.stderr)
        return 2
    img = read_exr(a.image, np)
    if img is None:
        print("skip: neither mitsuba nor bpy is installed to read %s" % a.image)
        return 0
    h, w = img.shape[:2]
    try:
        exp = {s: expected(np, doc, w, h, s) for s in ("linear", "encoded")}
    except (KeyError, IndexError, ValueError) as e:
        print("error: %s: %s" % (a.scene, e), file=sys.stderr)
        return 3
    if a.save_expected:
        np.save(a.save_expected, exp["linear"])
    print("%s (%dx%d) against %s" % (a.image, w, h, a.scene))
    print("  image mean                       %.5f %.5f %.5f" % tuple(img.mean(axis=(0, 1))))
    for s, e in exp.items():
        d = img - e
        rel = img.mean(axis=(0, 1)) / e.mean(axis=(0, 1)) - 1
        print("  expected, filtering %-8s mean %.5f %.5f %.5f  image relative %+.4f %+.4f %+.4f  "
              "RMS %.4f  largest %.4f" % ((s,) + tuple(e.mean(axis=(0, 1))) + tuple(rel)
                                        + (np.sqrt((d ** 2).mean()), np.abs(d).max())))
    return 0


if __name__ == "__main__":
    sys.exit(main())
