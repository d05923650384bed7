#!/usr/bin/env python3
"""Writes assets/bokeh/bokeh-lights.gltf: small bright emitters at several depths in front of
and behind a subject, for looking at bokeh (the diaphragm's shape in out-of-focus highlights).

Deterministic (no randomness, fixed float formatting): `python3 make_bokeh_scene.py` rewrites
the committed file byte for byte. Units: metres, glTF's +Y up; the camera at (0, 0.15, 3)
looks down -Z and focuses (extras.realcam.focus_distance_m) on the subject's front, 1.38 m away.
Emitters are discs facing the camera, 3 cm in radius, 4000 nits (KHR_materials_emissive_strength).
"""

import base64
import json
import math
import struct
from pathlib import Path

OUT = Path(__file__).with_name("bokeh-lights.gltf")

buffer = bytearray()
root = {
    "asset": {"version": "2.0", "generator": "realcam assets/bokeh/make_bokeh_scene.py"},
    "extensionsUsed": ["KHR_materials_emissive_strength"],
    "accessors": [], "bufferViews": [], "meshes": [], "materials": [], "nodes": [],
}


def view(data, target):
    while len(buffer) % 4:
        buffer.append(0)
    root["bufferViews"].append({"buffer": 0, "byteOffset": len(buffer), "byteLength": len(data), "target": target})
    buffer.extend(data)
    return len(root["bufferViews"]) - 1


def accessor(values, kind, bounds=False):
    flat = [v for p in values for v in p] if kind != "SCALAR" else values
    if kind == "SCALAR":
        data = struct.pack(f"<{len(flat)}I", *flat)
        acc = {"bufferView": view(data, 34963), "componentType": 5125, "count": len(values), "type": kind}
    else:
        data = struct.pack(f"<{len(flat)}f", *flat)
        acc = {"bufferView": view(data, 34962), "componentType": 5126, "count": len(values), "type": kind}
        if bounds:
            rounded = [[struct.unpack("<f", struct.pack("<f", c))[0] for c in p] for p in values]
            acc["min"] = [min(p[i] for p in rounded) for i in range(3)]
            acc["max"] = [max(p[i] for p in rounded) for i in range(3)]
    root["accessors"].append(acc)
    return len(root["accessors"]) - 1


def material(name, base, emission=None, strength=None):
    m = {"name": name, "pbrMetallicRoughness": {"baseColorFactor": base + [1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0}}
    if emission:
        m["emissiveFactor"] = emission
        m["extensions"] = {"KHR_materials_emissive_strength": {"emissiveStrength": strength}}
    root["materials"].append(m)
    return len(root["materials"]) - 1


def mesh(name, positions, normals, triangles, mat):
    prim = {
        "attributes": {"POSITION": accessor(positions, "VEC3", True), "NORMAL": accessor(normals, "VEC3")},
        "indices": accessor([i for t in triangles for i in t], "SCALAR"),
        "material": mat,
    }
    root["meshes"].append({"name": name, "primitives": [prim]})
    return len(root["meshes"]) - 1


def node(name, mesh_index=None, translation=None, **extra):
    n = {"name": name}
    if mesh_index is not None:
        n["mesh"] = mesh_index
    if translation:
        n["translation"] = translation
    n.update(extra)
    root["nodes"].append(n)
    return len(root["nodes"]) - 1


def disc(radius, segments=24):
    """A disc in the z = 0 plane facing +Z."""
    positions = [[0.0, 0.0, 0.0]] + [
        [radius * math.cos(2 * math.pi * k / segments), radius * math.sin(2 * math.pi * k / segments), 0.0]
        for k in range(segments)
    ]
    triangles = [[0, 1 + k, 1 + (k + 1) % segments] for k in range(segments)]
    return positions, [[0.0, 0.0, 1.0]] * len(positions), triangles


def box(half):
    positions, normals, triangles = [], [], []
    for axis in range(3):
        for sign in (-1.0, 1.0):
            n = [0.0, 0.0, 0.0]
            n[axis] = sign
            u, v = [(axis + 1) % 3, (axis + 2) % 3]
            base = len(positions)
            for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
                p = [0.0, 0.0, 0.0]
                p[axis] = sign * half
                p[u] = a * half
                p[v] = b * half
                positions.append(p)
                normals.append(n)
            quad = [[base, base + 1, base + 2], [base, base + 2, base + 3]]
            if sign < 0:
                quad = [[t[0], t[2], t[1]] for t in quad]
            triangles += quad
    return positions, normals, triangles


def plane(half, y, facing):
    positions = [[-half, y, -half], [half, y, -half], [half, y, half], [-half, y, half]]
    triangles = [[0, 2, 1], [0, 3, 2]] if facing > 0 else [[0, 1, 2], [0, 2, 3]]
    return positions, [[0.0, facing, 0.0]] * 4, triangles


nodes = []
ground = material("Ground", [0.18, 0.18, 0.18])
nodes.append(node("Ground", mesh("Ground", *plane(30.0, -0.12, 1.0), ground)))
subject = material("Subject", [0.7, 0.25, 0.2])
nodes.append(node("Subject", mesh("Subject", *box(0.12), subject), [0.0, 0.0, 1.5]))
sky = material("Overhead light", [0.0, 0.0, 0.0], [1.0, 1.0, 1.0], 2.0)
nodes.append(node("Overhead light", mesh("Overhead light", *plane(3.0, 6.0, -1.0), sky)))

colours = {"warm": [1.0, 0.78, 0.5], "white": [1.0, 1.0, 1.0], "blue": [0.55, 0.7, 1.0]}
lamp_materials = {name: material(f"Lamp {name}", [0.0, 0.0, 0.0], rgb, 4000.0) for name, rgb in colours.items()}
lamp_meshes = {name: mesh(f"Lamp {name}", *disc(0.03), m) for name, m in lamp_materials.items()}
# Behind the subject: rows at 6, 10 and 14 m from the camera; in front: a few 0.7 m from it.
lamps = []
for row, (z, spread, count) in enumerate([(-3.0, 1.3, 7), (-7.0, 2.2, 9), (-11.0, 3.2, 11)]):
    for k in range(count):
        x = -spread + 2 * spread * k / (count - 1)
        y = 0.3 + 0.3 * math.sin(1.7 * k + row) + 0.35 * row
        colour = ["warm", "white", "blue"][(k + row) % 3]
        lamps.append((colour, [round(x, 4), round(y, 4), z]))
for k, (x, y) in enumerate([(-0.2, 0.22), (0.17, 0.02), (0.05, 0.3)]):
    lamps.append((["warm", "blue", "white"][k], [x, y, 2.3]))
for i, (colour, position) in enumerate(lamps):
    nodes.append(node(f"Lamp {i}", lamp_meshes[colour], position))

root["cameras"] = [{
    "name": "Bokeh camera",
    "type": "perspective",
    "perspective": {"aspectRatio": 1.5, "yfov": 2 * math.atan(12.0 / 50.0), "znear": 0.01},
    "extras": {"realcam": {"focus_distance_m": 1.38, "film_diagonal_mm": 43.27, "width": 600, "height": 400}},
}]
nodes.append(node("Camera", translation=[0.0, 0.15, 3.0], camera=0))
root["scenes"] = [{"name": "bokeh lights", "nodes": nodes}]
root["scene"] = 0
while len(buffer) % 4:
    buffer.append(0)
root["buffers"] = [{"byteLength": len(buffer), "uri": "data:application/octet-stream;base64," + base64.b64encode(bytes(buffer)).decode()}]
OUT.write_text(json.dumps(root, indent=1) + "\n")
print(f"wrote {OUT} ({len(lamps)} lamps)")
