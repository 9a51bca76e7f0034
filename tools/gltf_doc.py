"""The in-memory glTF document that the test-file generators build on
(tools/gen_gltf_tests.py, tools/make_anim_scenes.py): the JSON with empty lists
of the objects a scene needs, and one binary buffer that buffer views are
appended to, each 4-byte aligned as glTF 2.0 (3.6.2.4) asks of accessors."""


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
