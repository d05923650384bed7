"""Writes the scene of docs/tilt.png: a checkerboard ground receding from a camera 0.3 m above
it, as an embedded glTF. Usage: python3 docs/tilt-scene.py OUT.gltf

Rendered with (the ground is sharp from near to far once the film is tilted by
asin(f / h) = asin(50 mm / 300 mm) ≈ 9.6°, the hinge rule's tilt for a lens h above the plane):

    realcam render OUT.gltf --look-from 0,0.3,0 --look-at 0,0.3,-1 --env 1,1,1 \
        --lens dgauss.50mm --film-diagonal 43.3 --width 320 --height 200 --shift 0,-8 \
        --tilt 0,0 --focus-on 160,150 --spp 128 --max-depth 2 --exposure 1 --out tilt-0.png
    (the same with --tilt 9.6,0 --out tilt-9.6.png; the two side by side are docs/tilt.png)
"""
import base64, json, struct, sys

tiles = []  # (x0, z0, size, dark)
size = 0.25
for i in range(-12, 12):
    for j in range(1, 120):
        tiles.append((i * size, -j * size, size, (i + j) % 2 == 0))

positions, normals, indices = [], [], {True: [], False: []}
for x0, z0, s, dark in tiles:
    base = len(positions)
    for dx, dz in [(0, 0), (s, 0), (s, -s), (0, -s)]:
        positions.append((x0 + dx, 0.0, z0 + dz))
        normals.append((0.0, 1.0, 0.0))
    indices[dark] += [base, base + 1, base + 2, base, base + 2, base + 3]

blob = b"".join(struct.pack("<3f", *p) for p in positions)
blob += b"".join(struct.pack("<3f", *n) for n in normals)
idx_offset = len(blob)
idx = {k: b"".join(struct.pack("<I", i) for i in v) for k, v in indices.items()}
blob += idx[True] + idx[False]
n = len(positions)
xs = [p[0] for p in positions]; zs = [p[2] for p in positions]
gltf = {
    "asset": {"version": "2.0"},
    "buffers": [{"byteLength": len(blob), "uri": "data:application/octet-stream;base64," + base64.b64encode(blob).decode()}],
    "bufferViews": [
        {"buffer": 0, "byteOffset": 0, "byteLength": 12 * n},
        {"buffer": 0, "byteOffset": 12 * n, "byteLength": 12 * n},
        {"buffer": 0, "byteOffset": idx_offset, "byteLength": len(idx[True])},
        {"buffer": 0, "byteOffset": idx_offset + len(idx[True]), "byteLength": len(idx[False])},
    ],
    "accessors": [
        {"bufferView": 0, "componentType": 5126, "count": n, "type": "VEC3",
         "min": [min(xs), 0.0, min(zs)], "max": [max(xs), 0.0, max(zs)]},
        {"bufferView": 1, "componentType": 5126, "count": n, "type": "VEC3"},
        {"bufferView": 2, "componentType": 5125, "count": len(indices[True]), "type": "SCALAR"},
        {"bufferView": 3, "componentType": 5125, "count": len(indices[False]), "type": "SCALAR"},
    ],
    "materials": [
        {"pbrMetallicRoughness": {"baseColorFactor": [0.05, 0.05, 0.06, 1], "metallicFactor": 0, "roughnessFactor": 1}},
        {"pbrMetallicRoughness": {"baseColorFactor": [0.85, 0.8, 0.7, 1], "metallicFactor": 0, "roughnessFactor": 1}},
    ],
    "meshes": [{"primitives": [
        {"attributes": {"POSITION": 0, "NORMAL": 1}, "indices": 2, "material": 0},
        {"attributes": {"POSITION": 0, "NORMAL": 1}, "indices": 3, "material": 1},
    ]}],
    "nodes": [{"mesh": 0}],
    "scenes": [{"nodes": [0]}],
    "scene": 0,
}
json.dump(gltf, open(sys.argv[1], "w"))
