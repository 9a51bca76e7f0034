"""The in-memory glTF document that the test-file generators build on
(tools/gen_gltf_tests.py, tools/make_anim_scenes.py): the JSON with empty lists
of the objects a scene needs, and one binary buffer that buffer views are
appended to, each 4-byte aligned as glTF 2.0 (3.6.2.4) asks of accessors.
accessor() adds an accessor over a new view of packed values; write() saves
the document with its buffer as a data URI."""
import base64
import json
import struct


class GltfDoc:
    """doc: the JSON object; bin: the bytes of buffer 0."""

    def __init__(self, generator):
        self.doc = {"asset": {"version": "2.0", "generator": generator},
                    "scene": 0, "scenes": [{"nodes": []}], "nodes": [], "meshes": [],
                    "accessors": [], "bufferViews": [], "buffers": []}
        self.bin = bytearray()

    def view(self, data, stride=None):
        """Appends data as a new buffer view; returns its index."""
        while len(self.bin) % 4:
            self.bin.append(0)
        v = {"buffer": 0, "byteOffset": len(self.bin), "byteLength": len(data)}
        if stride:
            v["byteStride"] = stride
        self.bin += data
        self.doc["bufferViews"].append(v)
        return len(self.doc["bufferViews"]) - 1

    def accessor(self, values, atype, ctype=5126, normalized=False, minmax=False):
        """values: flat list, packed as ctype. Returns (accessor index, the packed bytes)."""
        n = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT4": 16}[atype]
        fmt = {5126: "f", 5120: "b", 5121: "B", 5122: "h", 5123: "H"}[ctype]
        data = struct.pack("<%d%s" % (len(values), fmt), *values)
        a = {"bufferView": self.view(data), "componentType": ctype,
             "count": len(values) // n, "type": atype}
        if normalized:
            a["normalized"] = True
        if minmax:
            a["min"] = [min(values[k::n]) for k in range(n)]
            a["max"] = [max(values[k::n]) for k in range(n)]
        self.doc["accessors"].append(a)
        return len(self.doc["accessors"]) - 1, data

    def write(self, path):
        self.doc["buffers"] = [{"byteLength": len(self.bin), "uri":
                                "data:application/octet-stream;base64," +
                                base64.b64encode(bytes(self.bin)).decode()}]
        with open(path, "w") as f:
            json.dump(self.doc, f, indent=1)
            f.write("\n")
