#!/usr/bin/env python3
"""Writes tests/data/scenes/instancing_tangents.gltf, the tangent-frame scene of
tests/test_gltf_instances.c (docs/gltf.md, "Instancing" and "Tangents"): two
balls with TANGENT, each placed by several nodes (rotations, non-uniform
scales, mirroring negative scales, a rotated and scaled parent), so that they
load by reference and their tangents reach the world through each instance's
transform.

One ball is normal-mapped: a uniform normal texture tilting every normal about
42 degrees toward (0.5, 0.45) of the tangent frame, so the tangent's direction
and the bitangent's sign (TANGENT's w, negated by a mirroring transform: glTF
2.0 3.7.2.1) both decide which side of the ball faces the light. The other is
brushed metal (KHR_materials_anisotropy, strength 0.9, rotated 0.8 rad from
the tangent: its streak follows both). The tangents are the balls' dP/du
(u around the axis), w -1 (the bitangent toward decreasing v, the image's +Y).
A floor placed once stays flattened; two directional lights, no emitter."""
import base64
import math
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from gen_gltf_tests import png  # noqa: E402
from make_instancing_scene import Doc, ball, quat  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def tangent_ball(rings=10, segs=20, r=0.6):
    """make_instancing_scene's UV sphere (vertex i (segs + 1) + j at polar
    angle pi i / rings, azimuth 2 pi j / segs) with TEXCOORD_0 and TANGENT:
    positions, normals, uvs, tangents, indices."""
    pos, nrm, idx = ball(rings, segs, r)
    uv, tan = [], []
    for i in range(rings + 1):
        for j in range(segs + 1):
            ph = 2 * math.pi * j / segs
            uv += [j / segs, i / rings]
            tan += [-math.sin(ph), 0.0, math.cos(ph), -1.0]
    return pos, nrm, uv, tan, idx


def toward(d):
    """The rotation [x, y, z, w] taking +Z onto unit d (a light node's -Z then
    shines along -d)."""
    d = np.asarray(d, float) / np.linalg.norm(d)
    axis = np.cross([0, 0, 1], d)
    s = np.linalg.norm(axis)
    half = math.acos(max(-1.0, min(1.0, d[2]))) / 2
    return [*(axis / s * math.sin(half)), math.cos(half)]


def main():
    d = Doc()
    doc = d.doc
    doc["extensionsUsed"] = ["KHR_materials_anisotropy", "KHR_lights_punctual"]
    # Normal (0.5, 0.45, 0.74) as 8-bit (n + 1) / 2.
    nt = np.array([0.5, 0.45, 0.0])
    nt[2] = math.sqrt(1 - nt[0] ** 2 - nt[1] ** 2)
    texel = [int(round((c + 1) / 2 * 255)) for c in nt]
    doc["images"] = [{"uri": "data:image/png;base64," + base64.b64encode(
        png(2, 2, [texel * 2, texel * 2])).decode(), "mimeType": "image/png"}]
    doc["textures"] = [{"source": 0}]
    doc["materials"] = [
        {"name": "floor", "pbrMetallicRoughness": {"baseColorFactor": [0.6, 0.6, 0.6, 1],
                                                   "metallicFactor": 0, "roughnessFactor": 1}},
        {"name": "bumpy", "normalTexture": {"index": 0},
         "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.75, 0.7, 1], "metallicFactor": 0,
                                  "roughnessFactor": 0.6}},
        {"name": "brushed", "pbrMetallicRoughness": {"baseColorFactor": [0.95, 0.85, 0.7, 1],
                                                     "metallicFactor": 1, "roughnessFactor": 0.25},
         "extensions": {"KHR_materials_anisotropy": {"anisotropyStrength": 0.9,
                                                     "anisotropyRotation": 0.8}}},
    ]
    floor = d.mesh([-6, -1, -6, 6, -1, -6, 6, -1, 6, -6, -1, 6], [], [0, 2, 1, 0, 3, 2], 0)
    bp, bn, buv, bt, bi = tangent_ball()
    attrs = {"POSITION": d.acc(bp, "VEC3", minmax=True), "NORMAL": d.acc(bn, "VEC3"),
             "TEXCOORD_0": d.acc(buv, "VEC2"), "TANGENT": d.acc(bt, "VEC4")}
    ind = d.acc(bi, "SCALAR", 5123)
    meshes = []
    for mat in (1, 2):  # one geometry, two meshes
        doc["meshes"].append({"primitives": [{"attributes": attrs, "indices": ind, "material": mat}]})
        meshes.append(len(doc["meshes"]) - 1)
    bumpy, brushed = meshes

    roots = doc["scenes"][0]["nodes"]
    roots.append(d.node(mesh=floor))
    # Bumpy: a rotation, a rotation with a non-uniform scale, a mirror, a
    # mirror with a non-uniform scale, and one under a rotated, scaled parent.
    for kw in (dict(translation=[-2.1, -0.3, 1.3], rotation=quat([0, 1, 0], 50)),
               dict(translation=[-0.7, -0.3, 1.3], rotation=quat([1, 0, 1], 35), scale=[1.3, 0.7, 1]),
               dict(translation=[0.7, -0.3, 1.3], rotation=quat([0, 1, 0], -30), scale=[-1, 1, 1]),
               dict(translation=[2.1, -0.3, 1.3], rotation=quat([1, 0.3, 0], 60), scale=[1, -0.8, 1.2])):
        roots.append(d.node(mesh=bumpy, **kw))
    child = d.node(mesh=bumpy, translation=[0.6, 0, 0], rotation=quat([0, 0, 1], 70))
    roots.append(d.node(translation=[2.2, 0.3, -1.6], rotation=quat([1, 1, 1], 40), scale=[1.2, 1.2, 0.9],
                        children=[child]))
    # Brushed: a rotation, a mirror, a non-uniform scale with a mirror.
    for kw in (dict(translation=[-1.9, 0.4, -0.6], rotation=quat([1, 0, 0], 80)),
               dict(translation=[-0.4, 0.4, -0.9], rotation=quat([0, 1, 1], 45), scale=[1, 1, -1]),
               dict(translation=[1.1, 0.4, -0.6], rotation=quat([0, 0, 1], -50), scale=[-1.2, 0.8, 1])):
        roots.append(d.node(mesh=brushed, **kw))
    doc["extensions"] = {"KHR_lights_punctual": {"lights": [
        {"type": "directional", "intensity": 3.0},
        {"type": "directional", "intensity": 1.0, "color": [0.6, 0.7, 1.0]}]}}
    roots.append(d.node(rotation=toward([0.5, 0.8, 0.6]), extensions={"KHR_lights_punctual": {"light": 0}}))
    roots.append(d.node(rotation=toward([-0.7, 0.3, 0.4]), extensions={"KHR_lights_punctual": {"light": 1}}))
    doc["cameras"] = [{"type": "perspective", "perspective": {"yfov": 0.75, "znear": 0.1}}]
    roots.append(d.node(camera=0, translation=[0, 2.2, 6.0], rotation=quat([1, 0, 0], -18)))
    d.write(os.path.join(ROOT, "tests", "data", "scenes", "instancing_tangents.gltf"))


if __name__ == "__main__":
    main()
