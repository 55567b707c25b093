"""Write materials.glb: a glTF 2.0 scene of the metallic-roughness materials tileraster draws.

Five rows of five spheres, metallic from 0 (left) to 1 (right) and roughness from 0 (top)
to 1 (bottom); a glowing sphere (emissiveFactor with KHR_materials_emissive_strength); a
double-sided, blended glass pane in front of the right column; and a masked fence (alphaMode
MASK, its alpha from COLOR_0) in front of the left one, which cuts it into bars.

    python examples/materials_scene.py tileraster-demo/materials.glb
    tileraster render tileraster-demo/materials.glb -o materials.png --size 960 720 --tone-map neutral --srgb

Standard library only.
"""

import json
import math
import os
import struct
import sys


def sphere(stacks=24, slices=40):
    """Unit sphere positions, normals and triangle indices (counter-clockwise from outside)."""
    positions, indices = [], []
    for i in range(stacks + 1):
        theta = math.pi * i / stacks
        for j in range(slices + 1):
            phi = 2 * math.pi * j / slices
            positions.append((math.sin(theta) * math.cos(phi), math.cos(theta), -math.sin(theta) * math.sin(phi)))
    for i in range(stacks):
        for j in range(slices):
            a, b = i * (slices + 1) + j, (i + 1) * (slices + 1) + j
            indices += [a, b, a + 1, a + 1, b, b + 1]
    return positions, positions, indices


def grid(x0, x1, y0, y1, z, n, alpha):
    """A quad in the plane z facing +z, cut n × n, each vertex's COLOR_0 alpha alpha(i, j)."""
    positions, colours, indices = [], [], []
    for j in range(n + 1):
        for i in range(n + 1):
            positions.append((x0 + (x1 - x0) * i / n, y0 + (y1 - y0) * j / n, z))
            colours.append((0.85, 0.85, 0.9, alpha(i, j)))
    for j in range(n):
        for i in range(n):
            a, b = j * (n + 1) + i, (j + 1) * (n + 1) + i
            indices += [a, a + 1, b + 1, a, b + 1, b]
    return positions, [(0.0, 0.0, 1.0)] * len(positions), colours, indices


class Writer:
    def __init__(self):
        self.bin, self.views, self.accessors = bytearray(), [], []

    def accessor(self, values, kind, component=5126):
        fmt = {5126: "f", 5125: "I"}[component]
        flat = [c for v in values for c in (v if isinstance(v, tuple) else (v,))]
        offset = len(self.bin)
        self.bin += struct.pack(f"<{len(flat)}{fmt}", *flat)
        self.views.append({"buffer": 0, "byteOffset": offset, "byteLength": len(self.bin) - offset})
        accessor = {"bufferView": len(self.views) - 1, "componentType": component, "count": len(values), "type": kind}
        if kind == "VEC3" and component == 5126:
            accessor["min"] = [min(v[k] for v in values) for k in range(3)]
            accessor["max"] = [max(v[k] for v in values) for k in range(3)]
        self.accessors.append(accessor)
        return len(self.accessors) - 1


def main(path):
    w = Writer()
    positions, normals, indices = sphere()
    sphere_attributes = {"POSITION": w.accessor(positions, "VEC3"), "NORMAL": w.accessor(normals, "VEC3")}
    sphere_indices = w.accessor(indices, "SCALAR", 5125)
    materials, meshes, nodes = [], [], []

    def add(primitive, material, translation=(0, 0, 0), scale=1.0):
        materials.append(material)
        meshes.append({"primitives": [dict(primitive, material=len(materials) - 1)]})
        nodes.append({"mesh": len(meshes) - 1, "translation": list(translation), "scale": [scale] * 3})

    for row in range(5):
        for column in range(5):
            pbr = {"baseColorFactor": [0.95, 0.64, 0.37, 1.0], "metallicFactor": column / 4, "roughnessFactor": row / 4}
            add({"attributes": sphere_attributes, "indices": sphere_indices}, {"pbrMetallicRoughness": pbr}, ((column - 2) * 2.2, (2 - row) * 2.2, 0), 0.9)
    glow = {"pbrMetallicRoughness": {"baseColorFactor": [0.1, 0.1, 0.1, 1]}, "emissiveFactor": [1.0, 0.45, 0.1],
            "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 1.5}}}
    add({"attributes": sphere_attributes, "indices": sphere_indices}, glow, (0, 6.4, 0), 0.6)
    for name, x0, alpha, material in [
        ("glass", 3.2, lambda i, j: 0.35,
         {"pbrMetallicRoughness": {"baseColorFactor": [0.6, 0.8, 1.0, 1.0], "metallicFactor": 0, "roughnessFactor": 0.05},
          "alphaMode": "BLEND", "doubleSided": True}),
        ("fence", -5.4, lambda i, j: float(i % 2),
         {"pbrMetallicRoughness": {"metallicFactor": 0.0, "roughnessFactor": 0.6}, "alphaMode": "MASK", "alphaCutoff": 0.5}),
    ]:
        p, n, c, ix = grid(x0, x0 + 2.2, -5.5, 5.5, 1.6, 10, alpha)
        attributes = {"POSITION": w.accessor(p, "VEC3"), "NORMAL": w.accessor(n, "VEC3"), "COLOR_0": w.accessor(c, "VEC4")}
        add({"attributes": attributes, "indices": w.accessor(ix, "SCALAR", 5125)}, dict(material, name=name))
    while len(w.bin) % 4:
        w.bin.append(0)
    document = {
        "asset": {"version": "2.0", "generator": "tileraster examples/materials_scene.py"},
        "extensionsUsed": ["KHR_materials_emissive_strength"],
        "scene": 0,
        "scenes": [{"nodes": list(range(len(nodes)))}],
        "nodes": nodes,
        "meshes": meshes,
        "materials": materials,
        "buffers": [{"byteLength": len(w.bin)}],
        "bufferViews": w.views,
        "accessors": w.accessors,
    }
    text = json.dumps(document).encode()
    text += b" " * (-len(text) % 4)
    total = 12 + 8 + len(text) + 8 + len(w.bin)
    os.makedirs(os.path.dirname(path) or ".", exist_ok=True)
    with open(path, "wb") as f:
        f.write(struct.pack("<4sII", b"glTF", 2, total))
        f.write(struct.pack("<I4s", len(text), b"JSON") + text)
        f.write(struct.pack("<I4s", len(w.bin), b"BIN\0") + bytes(w.bin))
    print(f"wrote {path}: {len(nodes)} meshes, {len(materials)} materials")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "materials.glb")
