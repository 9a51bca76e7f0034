#!/usr/bin/env python3
"""Writes the posed-scene test files into tests/data/anim/ with the world-space
positions a correct loader must give (tests/data/anim/expected.txt, read by
tests/test_animation.c), computed here in double precision from the same float32
accessor values, following the glTF 2.0 specification (3.5.3 node transforms,
3.7.2.2 morph targets, 3.7.3 skins, Appendix C interpolation).

    python3 tools/make_anim_scenes.py [OUTDIR]

Files:
  anim_triangle.gltf  a triangle with translation LINEAR, rotation LINEAR
                      (spherical, one pair of keys with a negative dot product),
                      scale STEP; its child with CUBICSPLINE translation and
                      rotation; an animated camera "Main", a camera "Side" on two
                      nodes, an animated point light; animations "move", "cubic"
  skin_strip.gltf     a two-bone strip (joints with inverse bind matrices, the
                      skinned node's own translation ignored): primitive 0 with
                      JOINTS_0 u8 and float WEIGHTS_0, primitive 1 with JOINTS_0 u16,
                      normalised u16 WEIGHTS_0, JOINTS_1 u8 and normalised u8
                      WEIGHTS_1 (8 influences)
  morph_quad.gltf     a quad with two morph targets (the second sparse, POSITION
                      only; the first with NORMAL deltas), mesh weights, a second
                      instance with node weights, weights animated LINEAR
                      ("blend") and CUBICSPLINE ("pulse")
  render_posed.gltf / render_static.gltf
                      a lit floor and a box posed by --at 0.25 (LINEAR, exact in
                      float) and the same written at that pose: the images must
                      be equal
  turntable.gltf      scenes/cornell_box.gltf with its spheres and block turning
                      once a second ("turn") and a camera "orbit" swinging
                      about the box ("orbit"), for frame sequences
  bad_*.gltf          one fault each, with the error text expected
Plain Python (json, struct, base64, math).
"""
import base64
import json
import math
import os
import struct
import sys

from gltf_doc import GltfDoc

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def f32(x):
    return struct.unpack("<f", struct.pack("<f", x))[0]


class Doc(GltfDoc):
    def __init__(self):
        super().__init__("tools/make_anim_scenes.py")

    def acc(self, values, atype, ctype=5126, normalized=False, minmax=False):
        """values: flat list. Returns (accessor index, the values as read back)."""
        index, data = self.accessor(values, atype, ctype, normalized, minmax)
        fmt = {5126: "f", 5121: "B", 5123: "H"}[ctype]
        back = list(struct.unpack("<%d%s" % (len(values), fmt), data))
        if ctype != 5126:
            back = [v / {5121: 255.0, 5123: 65535.0}[ctype] for v in back] if normalized else back
        return index, back


# ---- the reference arithmetic (glTF 2.0), in double ----

def mat_mul(a, b):  # 4x4 row-major lists
    return [[sum(a[r][k] * b[k][c] for k in range(4)) for c in range(4)] for r in range(4)]


def trs(t=(0, 0, 0), q=(0, 0, 0, 1), s=(1, 1, 1)):
    ql = math.sqrt(sum(c * c for c in q))
    x, y, z, w = (c / ql for c in q)
    R = [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
         [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
         [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]
    return [[R[r][0] * s[0], R[r][1] * s[1], R[r][2] * s[2], t[r]] for r in range(3)] + [[0, 0, 0, 1]]


def apply(M, p):
    return [sum(M[r][k] * p[k] for k in range(3)) + M[r][3] for r in range(3)]


def normal_by(M, n):
    """(M^-1)^T n for the upper 3x3, normalised (sign kept for det > 0)."""
    a = [[M[r][c] for c in range(3)] for r in range(3)]
    det = (a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1]) -
           a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0]) +
           a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0]))
    inv = [[(a[(c + 1) % 3][(r + 1) % 3] * a[(c + 2) % 3][(r + 2) % 3] -
             a[(c + 1) % 3][(r + 2) % 3] * a[(c + 2) % 3][(r + 1) % 3]) / det
            for c in range(3)] for r in range(3)]
    v = [sum(inv[k][r] * n[k] for k in range(3)) for r in range(3)]  # inverse transposed
    length = math.sqrt(sum(c * c for c in v))
    return [c / length for c in v]


def axis_angle(axis, deg):
    h = math.radians(deg) / 2
    return [f32(axis[0] * math.sin(h)), f32(axis[1] * math.sin(h)), f32(axis[2] * math.sin(h)),
            f32(math.cos(h))]


def sample(times, vals, nc, interp, t, quat=False):
    """Appendix C of glTF 2.0: vals flat; CUBICSPLINE as (a, v, b) triples."""
    n = len(times)
    cubic = interp == "CUBICSPLINE"

    def v(k):
        o = (3 * k + 1) * nc if cubic else k * nc
        return vals[o:o + nc]
    if t <= times[0]:
        return v(0)
    if t >= times[-1]:
        return v(n - 1)
    k = max(i for i in range(n) if times[i] <= t)
    td = times[k + 1] - times[k]
    s = (t - times[k]) / td
    if interp == "STEP":
        return v(k)
    if cubic:
        b = vals[(3 * k + 2) * nc:(3 * k + 3) * nc]
        a = vals[(3 * (k + 1)) * nc:(3 * (k + 1) + 1) * nc]
        p0, p1 = v(k), v(k + 1)
        out = [(2 * s ** 3 - 3 * s ** 2 + 1) * p0[c] + td * (s ** 3 - 2 * s ** 2 + s) * b[c] +
               (-2 * s ** 3 + 3 * s ** 2) * p1[c] + td * (s ** 3 - s ** 2) * a[c] for c in range(nc)]
        if quat:
            ln = math.sqrt(sum(c * c for c in out))
            out = [c / ln for c in out]
        return out
    p0, p1 = v(k), v(k + 1)
    if quat:
        d = sum(p0[c] * p1[c] for c in range(4))
        a = math.acos(min(1.0, abs(d)))
        sg = 1.0 if d >= 0 else -1.0
        return [math.sin(a * (1 - s)) / math.sin(a) * p0[c] + sg * math.sin(a * s) / math.sin(a) * p1[c]
                for c in range(4)]
    return [(1 - s) * p0[c] + s * p1[c] for c in range(nc)]


class Anim:
    """Collects channels: (node, path, times, values, nc, interp)."""

    def __init__(self, doc, name):
        self.doc, self.a = doc, {"name": name, "channels": [], "samplers": []}
        self.ch = []
        doc.doc.setdefault("animations", []).append(self.a)

    def channel(self, node, path, times, values, interp="LINEAR", atype="VEC3", nc=None):
        ti, tb = self.doc.acc([f32(x) for x in times], "SCALAR", minmax=True)
        vi, vb = self.doc.acc([f32(x) for x in values], atype)
        self.a["samplers"].append({"input": ti, "output": vi, "interpolation": interp})
        self.a["channels"].append({"sampler": len(self.a["samplers"]) - 1,
                                   "target": {"node": node, "path": path}})
        self.ch.append((node, path, tb, vb, nc or {"VEC3": 3, "VEC4": 4}[atype], interp))


def posed(nodes, anims, at, play):
    """Each node's (t, q, s, weights) at time `at` (None: rest)."""
    out = [dict(n) for n in nodes]
    if at is None:
        return out
    for ai, an in enumerate(anims):
        if play is not None and play != ai:
            continue
        for node, path, tb, vb, nc, interp in an.ch:
            val = sample(tb, vb, nc, interp, at, quat=path == "rotation")
            out[node][{"translation": "t", "rotation": "q", "scale": "s", "weights": "w"}[path]] = val
    return out


def world_of(nodes, parent, i):
    M = trs(nodes[i].get("t", (0, 0, 0)), nodes[i].get("q", (0, 0, 0, 1)), nodes[i].get("s", (1, 1, 1)))
    return mat_mul(world_of(nodes, parent, parent[i]), M) if parent[i] >= 0 else M


def tri_mesh(doc, pos, nrm, tris, extra_attrs=None, targets=None):
    pi, pb = doc.acc([f32(x) for x in pos], "VEC3", minmax=True)
    ni, nb = doc.acc([f32(x) for x in nrm], "VEC3")
    ii = doc.acc(tris, "SCALAR", 5123)[0]
    prim = {"attributes": {"POSITION": pi, "NORMAL": ni}, "indices": ii}
    prim["attributes"].update(extra_attrs or {})
    if targets:
        prim["targets"] = targets
    return prim, pb, nb


def emit(case, tris_pos, tris_nrm):
    case.append("tri %d %s" % (len(tris_pos) // 9, " ".join("%.9g" % v for v in tris_pos)))
    case.append("nrm %d %s" % (len(tris_nrm) // 9, " ".join("%.9g" % v for v in tris_nrm)))


# ---- anim_triangle.gltf ----

def anim_triangle(out, exp):
    d = Doc()
    pos = [0, 0, 0, 1, 0, 0, 0, 1, 0]
    nrm = [0, 0, 1] * 3
    prim, pb, nb = tri_mesh(d, pos, nrm, [0, 1, 2])
    d.doc["meshes"].append({"primitives": [prim]})
    cam_q = axis_angle((0, 1, 0), 30)
    nodes = [{"t": [0, 0, 0]}, {"t": [f32(0.5), 0, 0]}, {"t": [0, 0, 5], "q": cam_q},
             {"t": [0, 0, 10]}, {"t": [0, 0, 20]}, {"t": [0, 3, 0]}]
    d.doc["nodes"] = [{"name": "tri", "mesh": 0, "children": [1], "translation": [0, 0, 0]},
                    {"name": "cubic", "mesh": 0, "translation": [f32(0.5), 0, 0]},
                    {"name": "cam", "camera": 0, "translation": [0, 0, 5], "rotation": cam_q},
                    {"camera": 1, "translation": [0, 0, 10]},
                    {"camera": 1, "translation": [0, 0, 20]},
                    {"translation": [0, 3, 0], "extensions": {"KHR_lights_punctual": {"light": 0}}}]
    d.doc["scenes"][0]["nodes"] = [0, 2, 3, 4, 5]
    d.doc["cameras"] = [{"name": "Main", "type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.1}},
                      {"name": "Side", "type": "perspective", "perspective": {"yfov": 0.6, "znear": 0.1}}]
    d.doc["extensions"] = {"KHR_lights_punctual": {"lights": [{"type": "point", "intensity": 10}]}}
    d.doc["extensionsUsed"] = ["KHR_lights_punctual"]
    move = Anim(d, "move")
    move.channel(0, "translation", [0, 1, 2], [0, 0, 0, 1, 2, 0, 1, 2, 3])
    qa, qb = axis_angle((0, 1, 0), 0), axis_angle((0, 1, 0), 90)
    ln = math.sqrt(1 + 1 + 0.25)
    # negated: a negative dot product with qb, so the spherical interpolation
    # takes the short way (Appendix C: s = sign of the dot product)
    qc = [-c for c in axis_angle((1 / ln, 1 / ln, 0.5 / ln), 120)]
    move.channel(0, "rotation", [0, 1, 2], qa + qb + qc, atype="VEC4")
    move.channel(0, "scale", [0, 1, 2], [1, 1, 1, 2, 0.5, 1, 1, 3, 1], interp="STEP")
    move.channel(2, "translation", [0, 2], [0, 0, 5, 4, 0, 5])
    move.channel(5, "translation", [0.5, 1.5], [0, 3, 0, 0, 3, -2])
    cub = Anim(d, "cubic")
    # (in-tangent, value, out-tangent) per key
    cub.channel(1, "translation", [0, 1, 3],
                [0, 0, 0, 0.5, 0, 0, 1, 2, 0,
                 -1, 1, 0, 1.5, 1, 0, 2, 0, 1,
                 0, 0, 3, 2, 2, 2, 0, 0, 0], interp="CUBICSPLINE")
    q0, q1 = axis_angle((0, 0, 1), 10), axis_angle((0, 0, 1), 80)
    cub.channel(1, "rotation", [0, 2],
                [0, 0, 0, 0] + q0 + [0, 0, 0.3, 0] + [0, 0, 0.2, 0] + q1 + [0, 0, 0, 0],
                interp="CUBICSPLINE", atype="VEC4")
    path = os.path.join(out, "anim_triangle.gltf")
    d.write(path)
    anims = [move, cub]
    parent = [-1, 0, -1, -1, -1, -1]
    cases = [(None, None, None), (-0.5, None, None), (0.3, None, None), (1.0, None, None),
             (1.7, None, "Side"), (2.5, None, "1"), (0.6, "cubic", None), (1.3, "0", "Main")]
    for at, anim, cam in cases:
        play = None if anim is None else (1 if anim == "cubic" else int(anim))
        ps = posed(nodes, anims, at if at is not None or anim is None else 0.0, play)
        tp, tn = [], []
        for n in (0, 1):
            W = world_of(ps, parent, n)
            for v in range(3):
                tp += apply(W, pb[3 * v:3 * v + 3])
                tn += normal_by(W, nb[3 * v:3 * v + 3])
        case = ["case anim_triangle.gltf %s %s %s" % ("rest" if at is None else repr(at),
                                                      anim or "-", cam or "-")]
        emit(case, tp, tn)
        cn = 3 if cam in ("Side", "1") else 2
        C = world_of(ps, parent, cn)
        fwd = [-C[r][2] for r in range(3)]
        fl = math.sqrt(sum(c * c for c in fwd))
        case.append("cam %.9g %.9g %.9g %.9g %.9g %.9g" % tuple(
            [C[r][3] for r in range(3)] + [c / fl for c in fwd]))
        L = world_of(ps, parent, 5)
        case.append("light %.9g %.9g %.9g" % tuple(L[r][3] for r in range(3)))
        exp += case + ["end"]
    return d


# ---- skin_strip.gltf ----

def skin_strip(out, exp):
    d = Doc()
    rows = 5
    pos, nrm, tris, w = [], [], [], []
    for r in range(rows):
        for x in (-0.25, 0.25):
            pos += [x, 0.5 * r, 0]
            nrm += [0, 0, 1]
            w.append(r / (rows - 1))
    for r in range(rows - 1):
        a = 2 * r
        tris += [a, a + 1, a + 3, a, a + 3, a + 2]
    nv = len(pos) // 3
    j0 = d.acc([0, 1, 0, 0] * nv, "VEC4", 5121)[0]
    w0i, w0b = d.acc([f32(v) for k in range(nv) for v in (1 - w[k], w[k], 0, 0)], "VEC4")
    prim0, pb0, nb0 = tri_mesh(d, pos, nrm, tris, {"JOINTS_0": j0, "WEIGHTS_0": w0i})
    pos1 = [p + (1.0 if k % 3 == 0 else 0.0) for k, p in enumerate(pos)]
    j0b = d.acc([0, 1, 0, 0] * nv, "VEC4", 5123)[0]
    w0q = [v for k in range(nv) for v in (round(0.6 * (1 - w[k]) * 65535), round(0.6 * w[k] * 65535), 0, 0)]
    w0bi, w0bb = d.acc(w0q, "VEC4", 5123, normalized=True)
    j1 = d.acc([1, 0, 1, 1] * nv, "VEC4", 5121)[0]
    w1q = [v for k in range(nv) for v in (round(0.4 * w[k] * 255), round(0.4 * (1 - w[k]) * 255), 0, 0)]
    w1i, w1b = d.acc(w1q, "VEC4", 5121, normalized=True)
    prim1, pb1, nb1 = tri_mesh(d, pos1, nrm, tris, {"JOINTS_0": j0b, "WEIGHTS_0": w0bi,
                                                    "JOINTS_1": j1, "WEIGHTS_1": w1i})
    d.doc["meshes"].append({"primitives": [prim0, prim1]})
    ibm = [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1,
           1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, -1, 0, 1]  # column-major: identity, T(0,-1,0)
    ibi, ibb = d.acc(ibm, "MAT4")
    d.doc["skins"] = [{"joints": [1, 2], "inverseBindMatrices": ibi}]
    d.doc["nodes"] = [{"mesh": 0, "skin": 0, "translation": [5, 0, 0]},
                    {"children": [2]}, {"translation": [0, 1, 0]},
                    {"camera": 0, "translation": [0.5, 1, 6]}]
    d.doc["scenes"][0]["nodes"] = [0, 1, 3]
    d.doc["cameras"] = [{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.1}}]
    nodes = [{"t": [5, 0, 0]}, {}, {"t": [0, 1, 0]}]
    an = Anim(d, "bend")
    an.channel(1, "translation", [0, 1], [0, 0, 0, 0, 0, 1])
    an.channel(2, "rotation", [0, 1], axis_angle((1, 0, 0), 0) + axis_angle((1, 0, 0), 90), atype="VEC4")
    d.write(os.path.join(out, "skin_strip.gltf"))
    parent = [-1, -1, 1]
    ib = [[[ibb[16 * j + 4 * c + r] for c in range(4)] for r in range(4)] for j in range(2)]
    for at in (None, 0.5, 1.0):
        ps = posed(nodes, [an], at, None)
        J = [mat_mul(world_of(ps, parent, 1), ib[0]), mat_mul(world_of(ps, parent, 2), ib[1])]
        tp, tn = [], []
        for pb, nb, infl in ((pb0, nb0, lambda v: [(0, w0b[4 * v]), (1, w0b[4 * v + 1])]),
                             (pb1, nb1, lambda v: [(0, w0bb[4 * v]), (1, w0bb[4 * v + 1]),
                                                   (1, w1b[4 * v]), (0, w1b[4 * v + 1])])):
            for t in range(0, len(tris), 3):
                for v in tris[t:t + 3]:
                    M = [[sum(wt * J[j][r][c] for j, wt in infl(v)) for c in range(4)] for r in range(4)]
                    tp += apply(M, pb[3 * v:3 * v + 3])
                    tn += normal_by(M, nb[3 * v:3 * v + 3])
        case = ["case skin_strip.gltf %s - -" % ("rest" if at is None else repr(at))]
        emit(case, tp, tn)
        exp += case + ["end"]
    return d


# ---- morph_quad.gltf ----

def morph_quad(out, exp):
    d = Doc()
    pos = [0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0]
    nrm = [0, 0, 1] * 4
    tris = [0, 1, 2, 0, 2, 3]
    t0p, t0pb = d.acc([f32(x) for x in [0, 0, 0.5, 0, 0, 0, 0, 0, -0.5, 0.1, 0.2, 0]], "VEC3")
    t0n, t0nb = d.acc([f32(x) for x in [0.3, 0, 0, 0, 0.2, 0, -0.1, 0, 0, 0, 0, 0]], "VEC3")
    # target 1: sparse, no bufferView: vertices 1 and 3 move
    iv = d.view(struct.pack("<2H", 1, 3))
    vv = d.view(struct.pack("<6f", 0, 0, 1, 0.5, 0, 0))
    d.doc["accessors"].append({"componentType": 5126, "count": 4, "type": "VEC3",
                             "sparse": {"count": 2, "indices": {"bufferView": iv, "componentType": 5123},
                                        "values": {"bufferView": vv}}})
    t1p = len(d.doc["accessors"]) - 1
    t1pb = [0, 0, 0, 0, 0, 1, 0, 0, 0, 0.5, 0, 0]
    prim, pb, nb = tri_mesh(d, pos, nrm, tris, targets=[{"POSITION": t0p, "NORMAL": t0n}, {"POSITION": t1p}])
    d.doc["meshes"].append({"primitives": [prim], "weights": [0.5, 0.25]})
    d.doc["nodes"] = [{"mesh": 0}, {"mesh": 0, "translation": [3, 0, 0], "weights": [1, 0.5]},
                    {"camera": 0, "translation": [2, 0.5, 6]}]
    d.doc["scenes"][0]["nodes"] = [0, 1, 2]
    d.doc["cameras"] = [{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.1}}]
    nodes = [{"w": [0.5, 0.25]}, {"t": [3, 0, 0], "w": [1, 0.5]}]
    blend = Anim(d, "blend")
    blend.channel(0, "weights", [0, 1], [0, 0, 1, 1], atype="SCALAR", nc=2)
    pulse = Anim(d, "pulse")
    pulse.channel(1, "weights", [0, 2], [0, 0, 0.2, 0.1, 1, -1,
                                         0.5, 0.5, 1, 0, 0, 0], interp="CUBICSPLINE", atype="SCALAR", nc=2)
    d.write(os.path.join(out, "morph_quad.gltf"))
    for at, anim in ((None, None), (0.25, None), (0.25, "pulse"), (1.5, None), (3.0, None)):
        ps = posed(nodes, [blend, pulse], at, None if anim is None else 1)
        tp, tn = [], []
        for n in (0, 1):
            W = world_of(ps, [-1, -1], n)
            wt = ps[n]["w"]
            for v in tris:
                p = [pb[3 * v + c] + wt[0] * t0pb[3 * v + c] + wt[1] * t1pb[3 * v + c] for c in range(3)]
                q = [nb[3 * v + c] + wt[0] * t0nb[3 * v + c] for c in range(3)]
                tp += apply(W, p)
                tn += normal_by(W, q)
        case = ["case morph_quad.gltf %s %s -" % ("rest" if at is None else repr(at), anim or "-")]
        emit(case, tp, tn)
        exp += case + ["end"]
    return d


# ---- render_posed.gltf / render_static.gltf ----

def render_pair(out):
    for posed_file in (True, False):
        d = Doc()
        fl = [-2, 0, -2, 2, 0, -2, 2, 0, 2, -2, 0, 2]
        prim, _, _ = tri_mesh(d, fl, [0, 1, 0] * 4, [0, 2, 1, 0, 3, 2])
        prim["material"] = 0
        box = [-0.3, 0, 0, 0.3, 0, 0, 0.3, 0.6, 0, -0.3, 0.6, 0]
        bprim, _, _ = tri_mesh(d, box, [0, 0, 1] * 4, [0, 1, 2, 0, 2, 3])
        bprim["material"] = 1
        d.doc["meshes"] = [{"primitives": [prim]}, {"primitives": [bprim]}]
        d.doc["materials"] = [{"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1],
                                                      "metallicFactor": 0}},
                            {"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.2, 0.1, 1],
                                                      "metallicFactor": 0}, "doubleSided": True}]
        q = axis_angle((0, 1, 0), 20)
        d.doc["nodes"] = [{"mesh": 0},
                        {"mesh": 1, "translation": [0.5, 0, 0] if not posed_file else [0, 0, 0],
                         "rotation": q},
                        {"camera": 0, "translation": [0, 1.5, 4] if not posed_file else [0, 1.5, 6],
                         "rotation": axis_angle((1, 0, 0), -15)},
                        {"translation": [1, 3, 1], "extensions": {"KHR_lights_punctual": {"light": 0}}}]
        d.doc["scenes"][0]["nodes"] = [0, 1, 2, 3]
        d.doc["cameras"] = [{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.1}}]
        d.doc["extensions"] = {"KHR_lights_punctual": {"lights": [{"type": "point", "intensity": 40}]}}
        d.doc["extensionsUsed"] = ["KHR_lights_punctual"]
        if posed_file:
            an = Anim(d, "slide")
            # at 0.25: 0 + 0.25 * 2 = 0.5 and 6 - 0.25 * 8 = 4, exact in float
            an.channel(1, "translation", [0, 1], [0, 0, 0, 2, 0, 0])
            an.channel(2, "translation", [0, 1], [0, 1.5, 6, 0, 1.5, -2])
        d.write(os.path.join(out, "render_posed.gltf" if posed_file else "render_static.gltf"))


# ---- turntable.gltf: the Cornell box with its contents turning ----

def turntable(out):
    """scenes/cornell_box.gltf with the spheres and the block on a node that
    turns once a second about the vertical through the floor's centre
    ("turn": rotation LINEAR, a key every quarter turn), and a second camera
    "orbit" on a node swinging from -20 to +20 degrees about that vertical in
    the same second ("orbit"): a 24-frame turntable at 24 frames per second
    (tests/test_frames.c)."""
    with open(os.path.join(ROOT, "scenes", "cornell_box.gltf")) as f:
        src = json.load(f)
    d = Doc()
    d.bin += base64.b64decode(src["buffers"][0]["uri"].split(",", 1)[1])
    for key in ("nodes", "meshes", "materials", "accessors", "bufferViews", "cameras"):
        d.doc[key] = src[key]
    d.doc["extensionsUsed"] = src.get("extensionsUsed", [])
    names = [n.get("name") for n in d.doc["nodes"]]
    roots = [i for i in range(len(names)) if names[i] not in ("glass_sphere", "gold_sphere",
                                                               "tall_block")]
    turning = [names.index(k) for k in ("glass_sphere", "gold_sphere", "tall_block")]
    centre = [0.278, 0.0, 0.28]
    nodes = d.doc["nodes"]
    table = len(nodes)
    nodes.append({"name": "turntable", "translation": centre, "children": [table + 1]})
    nodes.append({"name": "turntable_origin", "translation": [-c for c in centre],
                  "children": turning})
    d.doc["cameras"].append({"name": "orbit", "type": "perspective",
                             "perspective": dict(d.doc["cameras"][0]["perspective"])})
    pivot = len(nodes)
    nodes.append({"name": "orbit_pivot", "translation": centre, "children": [pivot + 1]})
    nodes.append({"name": "orbit_camera", "camera": 1, "translation": [0.0, 0.273, -1.08],
                  "rotation": [0.0, 1.0, 0.0, 0.0]})
    d.doc["scenes"][0]["nodes"] = roots + [table, pivot]
    turn = Anim(d, "turn")
    keys = [0, 0.25, 0.5, 0.75, 1.0]
    turn.channel(table, "rotation", keys,
                 sum((axis_angle((0, 1, 0), 360 * k) for k in keys), []), atype="VEC4")
    orbit = Anim(d, "orbit")
    orbit.channel(pivot, "rotation", [0, 1],
                  axis_angle((0, 1, 0), -20) + axis_angle((0, 1, 0), 20), atype="VEC4")
    d.write(os.path.join(out, "turntable.gltf"))


# ---- bad files: (name, change to anim_triangle's JSON, pose, expected text) ----

def bad_files(out, exp, base):
    def variant(name, change, pose, text):
        j = json.loads(json.dumps(base.doc))
        change(j)
        with open(os.path.join(out, name), "w") as f:
            json.dump(j, f)
            f.write("\n")
        exp.append("bad %s %s %s" % (name, pose, text))

    def missing_node(j):
        j["animations"][0]["channels"][1]["target"]["node"] = 99

    def times_down(j):  # the input of sampler 0 read backwards: decreasing times
        s = j["animations"][0]["samplers"][0]["input"]
        j["accessors"].append(dict(j["accessors"][s]))
        j["bufferViews"].append(dict(j["bufferViews"][j["accessors"][s]["bufferView"]]))
        blob = base64.b64decode(j["buffers"][0]["uri"].split(",", 1)[1])
        bv = j["bufferViews"][-1]
        rev = struct.pack("<3f", 2, 1, 0)
        blob += bytes(-len(blob) % 4)
        bv["byteOffset"] = len(blob)
        blob += rev
        j["buffers"][0]["uri"] = "data:application/octet-stream;base64," + base64.b64encode(blob).decode()
        j["buffers"][0]["byteLength"] = len(blob)
        j["accessors"][-1]["bufferView"] = len(j["bufferViews"]) - 1
        j["accessors"][-1].pop("min", None), j["accessors"][-1].pop("max", None)
        j["animations"][0]["samplers"][0]["input"] = len(j["accessors"]) - 1

    def wrong_count(j):  # the rotation sampler given the translation's output (VEC3)
        j["animations"][0]["samplers"][1]["output"] = j["animations"][0]["samplers"][0]["output"]

    def cubic_count(j):  # CUBICSPLINE needs 3 values per key
        j["animations"][0]["samplers"][0]["interpolation"] = "CUBICSPLINE"

    def bad_path(j):
        j["animations"][0]["channels"][0]["target"]["path"] = "color"

    def matrix_node(j):
        n = j["nodes"][0]
        n.pop("translation")
        n["matrix"] = [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]

    variant("bad_anim_node.gltf", missing_node, "1 - -", "target.node: nodes[99] does not exist")
    variant("bad_anim_times.gltf", times_down, "1 - -", "strictly increasing")
    variant("bad_anim_type.gltf", wrong_count, "1 - -", "output (accessors[")
    variant("bad_anim_cubic.gltf", cubic_count, "1 - -", "of CUBICSPLINE triples")
    variant("bad_anim_path.gltf", bad_path, "1 - -", "'color' is not translation")
    variant("bad_anim_matrix.gltf", matrix_node, "1 - -", "has a matrix")
    exp.append("bad anim_triangle.gltf 1 - Nope --camera 'Nope': the file has no camera")
    exp.append("bad anim_triangle.gltf 1 walk - --animation 'walk': the file has no animation")
    exp.append("bad anim_triangle.gltf 1 2 - --animation '2': the file has no animation")


def bad_skin(out, exp):
    path = os.path.join(out, "skin_strip.gltf")
    j = json.load(open(path))

    def joints_range(j):
        j["skins"][0]["joints"] = [1]  # vertices name joint 1 of a one-joint skin
    for name, change, text in (("bad_skin_joint.gltf", joints_range, "names joint 1, but skins[0] has 1 joints"),):
        k = json.loads(json.dumps(j))
        change(k)
        with open(os.path.join(out, name), "w") as f:
            json.dump(k, f)
            f.write("\n")
        exp.append("bad %s rest - - %s" % (name, text))
    k = json.loads(json.dumps(j))
    k["nodes"][0]["weights"] = [1, 2, 3]
    k["meshes"][0]["primitives"][0]["targets"] = [{"POSITION": k["meshes"][0]["primitives"][0]["attributes"]["POSITION"]}]
    with open(os.path.join(out, "bad_morph_weights.gltf"), "w") as f:
        json.dump(k, f)
        f.write("\n")
    exp.append("bad bad_morph_weights.gltf rest - - nodes[0].weights: 3 morph weights for meshes[0]'s 1 targets")


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else os.path.join(ROOT, "tests", "data", "anim")
    os.makedirs(out, exist_ok=True)
    exp = ["# Written by tools/make_anim_scenes.py: each case is a file, --at (rest: none),",
           "# --animation and --camera (-: not given), then the triangles' world-space",
           "# positions and unit normals (9 per triangle, in the loader's order), the",
           "# camera's position and forward axis, the light's position; each bad line a",
           "# file, its pose and the text its error must contain."]
    base = anim_triangle(out, exp)
    skin_strip(out, exp)
    morph_quad(out, exp)
    render_pair(out)
    turntable(out)
    bad_files(out, exp, base)
    bad_skin(out, exp)
    with open(os.path.join(out, "expected.txt"), "w") as f:
        f.write("\n".join(exp) + "\n")


if __name__ == "__main__":
    main()
