#!/usr/bin/env python3
"""Writes tests/data/scenes/instancing.gltf, the scene of tests/test_gltf_instances.c
(docs/gltf.md, "Instancing"), and instancing_expected.txt: each instance the
loader is to make, as numpy composes the glTF transforms (node T R S matrices
multiplied down the hierarchy, EXT_mesh_gpu_instancing's T R S on the right,
normalised integer rotations decoded as glTF 2.0 3.11 says: max(c / 127, -1)).

The scene: a floor (placed once: flattened), an emitting quad placed twice
(emitting meshes stay flattened), a smooth ball placed by five nodes (a
rotation, a non-uniform scale, a mirroring negative scale, and two nested
under a rotated and scaled parent), and a card with bent normals placed by two
EXT_mesh_gpu_instancing nodes: one with float rotations and translations, one
under a rotated parent with normalised byte rotations and scales, one of them
negative."""
import math
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from gltf_doc import GltfDoc  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


class Doc(GltfDoc):
    def __init__(self):
        super().__init__("tools/make_instancing_scene.py")

    def acc(self, values, atype, ctype=5126, normalized=False, minmax=False):
        return self.accessor(values, atype, ctype, normalized, minmax)[0]

    def mesh(self, pos, nrm, idx, material):
        attrs = {"POSITION": self.acc(pos, "VEC3", minmax=True)}
        if nrm:
            attrs["NORMAL"] = self.acc(nrm, "VEC3")
        prim = {"attributes": attrs, "indices": self.acc(idx, "SCALAR", 5123), "material": material}
        self.doc["meshes"].append({"primitives": [prim]})
        return len(self.doc["meshes"]) - 1

    def node(self, **kw):
        self.doc["nodes"].append(kw)
        return len(self.doc["nodes"]) - 1


def quat(axis, deg):
    a = np.asarray(axis, float)
    a /= np.linalg.norm(a)
    h = math.radians(deg) / 2
    return [*(a * math.sin(h)), math.cos(h)]


def trs(t=(0, 0, 0), q=(0, 0, 0, 1), s=(1, 1, 1)):
    x, y, z, w = np.asarray(q, float) / np.linalg.norm(q)
    r = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                  [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                  [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
    m = np.eye(4)
    m[:3, :3] = r @ np.diag(s)
    m[:3, 3] = t
    return m


def ball(rings=8, segs=16, r=0.6):
    pos, nrm, idx = [], [], []
    for i in range(rings + 1):
        th = math.pi * i / rings
        for j in range(segs + 1):
            ph = 2 * math.pi * j / segs
            n = [math.sin(th) * math.cos(ph), math.cos(th), math.sin(th) * math.sin(ph)]
            nrm += n
            pos += [r * c for c in n]
    for i in range(rings):
        for j in range(segs):
            a, b = i * (segs + 1) + j, (i + 1) * (segs + 1) + j
            if i:
                idx += [a, a + 1, b]
            if i < rings - 1:
                idx += [a + 1, b + 1, b]
    return pos, nrm, idx


def main():
    d = Doc()
    doc = d.doc
    doc["extensionsUsed"] = ["EXT_mesh_gpu_instancing"]
    doc["materials"] = [
        {"name": "floor", "pbrMetallicRoughness": {"baseColorFactor": [0.6, 0.6, 0.6, 1],
                                                   "metallicFactor": 0, "roughnessFactor": 1}},
        {"name": "light", "emissiveFactor": [1, 1, 1],
         "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 6}},
         "pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1], "metallicFactor": 0}},
        {"name": "ball", "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.7, 0.4, 1],
                                                  "metallicFactor": 0, "roughnessFactor": 0.4}},
        {"name": "card", "doubleSided": True,
         "pbrMetallicRoughness": {"baseColorFactor": [0.9, 0.25, 0.1, 1], "metallicFactor": 0,
                                  "roughnessFactor": 0.7}},
    ]
    doc["extensionsUsed"].append("KHR_materials_emissive_strength")
    floor = d.mesh([-6, -1, -6, 6, -1, -6, 6, -1, 6, -6, -1, 6], [], [0, 2, 1, 0, 3, 2], 0)
    light = d.mesh([-0.6, 0, -0.6, 0.6, 0, -0.6, 0.6, 0, 0.6, -0.6, 0, 0.6], [],
                   [0, 1, 2, 0, 2, 3], 1)  # faces -y
    bp, bn, bi = ball()
    ballm = d.mesh(bp, bn, bi, 2)
    cq = [-0.5, -0.5, 0, 0.5, -0.5, 0, 0.5, 0.5, 0, -0.5, 0.5, 0]
    cn = []
    for k in range(4):
        n = np.array([0.3 * cq[3 * k], 0.3 * cq[3 * k + 1], 1.0])
        cn += list(n / np.linalg.norm(n))
    card = d.mesh(cq, cn, [0, 1, 2, 0, 2, 3], 3)

    want = []  # (scene mesh, 4x4 world) in any order
    roots = doc["scenes"][0]["nodes"]
    roots.append(d.node(mesh=floor))
    roots.append(d.node(mesh=light, translation=[-1.2, 3, 0]))
    roots.append(d.node(mesh=light, translation=[1.2, 3, 0]))
    # The ball (scene mesh 0): five placements.
    placed = [dict(translation=[-2, -0.3, 0], rotation=quat([0, 1, 0], 30)),
              dict(translation=[2, -0.2, 0.3], rotation=quat([1, 0, 0], 20), scale=[1, 0.6, 1.6]),
              dict(translation=[0, 0.1, -1.8], rotation=quat([1, 1, 0], 25), scale=[-1, 1.2, 1])]
    for kw in placed:
        roots.append(d.node(mesh=ballm, **kw))
        want.append((0, trs(kw["translation"], kw["rotation"], kw.get("scale", (1, 1, 1)))))
    pt, pq, ps = [0.5, 0.2, 1.5], quat([0, 0, 1], 15), [0.8, 0.8, 0.8]
    ct, cq2 = [0.6, 0, 0], quat([0, 1, 0], -40)
    child = d.node(mesh=ballm, translation=ct, rotation=cq2)
    inner = d.node(mesh=ballm, translation=[-1.5, 0, 0], scale=[0.5, 0.5, 0.5])
    parent = d.node(translation=pt, rotation=pq, scale=ps, children=[child, inner])
    roots.append(parent)
    want.append((0, trs(pt, pq, ps) @ trs(ct, cq2)))
    want.append((0, trs(pt, pq, ps) @ trs([-1.5, 0, 0], s=[0.5, 0.5, 0.5])))
    # The card (scene mesh 1), float rotations and translations.
    ft = [-1.0, 0.5, 2.2, 0.0, 0.9, 2.0, 1.0, 0.4, 2.3]
    fq = quat([0, 1, 0], 20) + quat([1, 0, 0], -30) + quat([0.3, 1, 0.2], 70)
    ext = {"attributes": {"TRANSLATION": d.acc(ft, "VEC3"), "ROTATION": d.acc(fq, "VEC4")}}
    nt = [0, 0, 0.4]
    roots.append(d.node(mesh=card, translation=nt,
                        extensions={"EXT_mesh_gpu_instancing": ext}))
    for i in range(3):
        want.append((1, trs(nt) @ trs(ft[3 * i:3 * i + 3], fq[4 * i:4 * i + 4])))
    # Normalised byte rotations and scales (one mirrored) under a rotated parent.
    bq = [max(-127, min(127, round(127 * c))) for c in
          quat([0, 0, 1], 35) + quat([1, 0.5, 0], -60) + quat([0, 1, 0], 90)]
    bs = [1, 1, 1, -0.7, 1.1, 1, 1.3, 0.6, 1]
    btr = [-1.4, 0, 0, 0, -0.2, 0.2, 1.4, 0, 0]
    ext = {"attributes": {"TRANSLATION": d.acc(btr, "VEC3"),
                          "ROTATION": d.acc(bq, "VEC4", 5120, normalized=True),
                          "SCALE": d.acc(bs, "VEC3")}}
    gpu = d.node(mesh=card, extensions={"EXT_mesh_gpu_instancing": ext})
    gt, gq = [0, 0.2, -0.6], quat([0, 1, 0], 25)
    roots.append(d.node(translation=gt, rotation=gq, children=[gpu]))
    for i in range(3):
        q = [max(c / 127.0, -1.0) for c in bq[4 * i:4 * i + 4]]
        want.append((1, trs(gt, gq) @ trs(btr[3 * i:3 * i + 3], q, bs[3 * i:3 * i + 3])))
    # The camera, looking down at the scene from +z.
    doc["cameras"] = [{"type": "perspective", "perspective": {"yfov": 0.9, "znear": 0.1}}]
    roots.append(d.node(camera=0, translation=[0, 2.8, 6.5], rotation=quat([1, 0, 0], -22)))

    out = os.path.join(ROOT, "tests", "data", "scenes")
    d.write(os.path.join(out, "instancing.gltf"))
    with open(os.path.join(out, "instancing_expected.txt"), "w") as f:
        f.write("# tools/make_instancing_scene.py: per instance the scene mesh and the 3x4 rows\n")
        for m, w in want:
            f.write("%d %s\n" % (m, " ".join("%.9g" % v for v in w[:3].reshape(-1))))


if __name__ == "__main__":
    main()
