"""glTF 2.0 -> the same triangles for every renderer in the peer comparison.

Reads every triangle primitive of the default scene (node transforms applied, so the
triangles are in world space), and writes:

* a binary little-endian PLY (positions and faces only: every renderer shades the
  geometric normal, so no smoothing differs between them), for rs_pbrt and Mitsuba;
* a .glb with the same triangles and one matte material of albedo 0.5, for realcam.

Only pygltflib and numpy are needed.
"""

import json
import struct
import sys
from pathlib import Path

import numpy as np
import pygltflib

COMPONENT_TYPES = {
    5120: np.int8,
    5121: np.uint8,
    5122: np.int16,
    5123: np.uint16,
    5125: np.uint32,
    5126: np.float32,
}
COMPONENT_COUNTS = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT4": 16}


def read_accessor(gltf: pygltflib.GLTF2, blob: bytes, index: int) -> np.ndarray:
    """The accessor's elements as an (count, components) array (no sparse accessors)."""
    accessor = gltf.accessors[index]
    view = gltf.bufferViews[accessor.bufferView]
    dtype = np.dtype(COMPONENT_TYPES[accessor.componentType])
    components = COMPONENT_COUNTS[accessor.type]
    start = (view.byteOffset or 0) + (accessor.byteOffset or 0)
    stride = view.byteStride or dtype.itemsize * components
    # One strided view over the buffer (a million-triangle mesh in one step, not row by row).
    rows = np.lib.stride_tricks.as_strided(
        np.frombuffer(blob, dtype, offset=start, count=components + (accessor.count - 1) * stride // dtype.itemsize)
        if accessor.count else np.zeros(0, dtype),
        shape=(accessor.count, components),
        strides=(stride, dtype.itemsize),
        writeable=False,
    )
    return np.array(rows)


def node_matrix(node: pygltflib.Node) -> np.ndarray:
    """The node's local transform (column vectors)."""
    if node.matrix:
        return np.array(node.matrix, dtype=np.float64).reshape(4, 4).T
    t = np.eye(4)
    if node.translation:
        t[:3, 3] = node.translation
    r = np.eye(4)
    if node.rotation:
        x, y, z, w = node.rotation
        r[:3, :3] = [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    s = np.eye(4)
    if node.scale:
        s[0, 0], s[1, 1], s[2, 2] = node.scale
    return t @ r @ s


def world_triangles(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """(positions (n, 3) float32, faces (m, 3) uint32) of every triangle list in the scene."""
    gltf = pygltflib.GLTF2().load(str(path))
    blob = gltf.binary_blob()
    if blob is None:
        blob = (path.parent / gltf.buffers[0].uri).read_bytes()
    positions, faces, base = [], [], 0

    def visit(node_index: int, parent: np.ndarray) -> None:
        nonlocal base
        node = gltf.nodes[node_index]
        world = parent @ node_matrix(node)
        if node.mesh is not None:
            for primitive in gltf.meshes[node.mesh].primitives:
                if primitive.mode not in (None, 4):
                    continue  # only triangle lists
                p = read_accessor(gltf, blob, primitive.attributes.POSITION).astype(np.float64)
                p = (world @ np.c_[p, np.ones(len(p))].T).T[:, :3]
                if primitive.indices is not None:
                    f = read_accessor(gltf, blob, primitive.indices).reshape(-1, 3)
                else:
                    f = np.arange(len(p)).reshape(-1, 3)
                if np.linalg.det(world[:3, :3]) < 0:
                    f = f[:, ::-1]  # a mirroring transform flips the winding
                positions.append(p.astype(np.float32))
                faces.append(f.astype(np.uint32) + base)
                base += len(p)
        for child in node.children or []:
            visit(child, world)

    scene = gltf.scenes[gltf.scene or 0]
    for root in scene.nodes:
        visit(root, np.eye(4))
    return np.concatenate(positions), np.concatenate(faces)


def write_ply(path: Path, positions: np.ndarray, faces: np.ndarray) -> None:
    header = (
        "ply\nformat binary_little_endian 1.0\n"
        f"element vertex {len(positions)}\nproperty float x\nproperty float y\nproperty float z\n"
        f"element face {len(faces)}\nproperty list uchar int vertex_indices\nend_header\n"
    )
    face_records = np.zeros(len(faces), dtype=[("n", "u1"), ("v", "<i4", 3)])
    face_records["n"] = 3
    face_records["v"] = faces
    with open(path, "wb") as out:
        out.write(header.encode("ascii"))
        out.write(positions.astype("<f4").tobytes())
        out.write(face_records.tobytes())


def write_matte_glb(path: Path, positions: np.ndarray, faces: np.ndarray, albedo: float) -> None:
    """One mesh, one matte material (metallic 0, roughness 1, base colour `albedo`)."""
    vertex_bytes = positions.astype("<f4").tobytes()
    index_bytes = faces.astype("<u4").tobytes()
    document = {
        "asset": {"version": "2.0", "generator": "realcam benches/peers/convert.py"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0, "name": "converted"}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1, "material": 0}]}],
        "materials": [
            {
                "name": "matte",
                "pbrMetallicRoughness": {
                    "baseColorFactor": [albedo, albedo, albedo, 1.0],
                    "metallicFactor": 0.0,
                    "roughnessFactor": 1.0,
                },
            }
        ],
        "buffers": [{"byteLength": len(vertex_bytes) + len(index_bytes)}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": len(vertex_bytes), "target": 34962},
            {"buffer": 0, "byteOffset": len(vertex_bytes), "byteLength": len(index_bytes), "target": 34963},
        ],
        "accessors": [
            {
                "bufferView": 0,
                "componentType": 5126,
                "count": len(positions),
                "type": "VEC3",
                "min": positions.min(axis=0).tolist(),
                "max": positions.max(axis=0).tolist(),
            },
            {"bufferView": 1, "componentType": 5125, "count": faces.size, "type": "SCALAR"},
        ],
    }
    json_bytes = json.dumps(document).encode("utf-8")
    json_bytes += b" " * (-len(json_bytes) % 4)
    binary = vertex_bytes + index_bytes
    binary += b"\0" * (-len(binary) % 4)
    total = 12 + 8 + len(json_bytes) + 8 + len(binary)
    with open(path, "wb") as out:
        out.write(struct.pack("<4sII", b"glTF", 2, total))
        out.write(struct.pack("<I4s", len(json_bytes), b"JSON") + json_bytes)
        out.write(struct.pack("<I4s", len(binary), b"BIN\0") + binary)


def convert(
    source: Path, ply: Path, glb: Path, albedo: float = 0.5, fit_metres: float | None = None
) -> tuple[int, np.ndarray]:
    """Writes `ply` and `glb` from `source`; returns the triangle count and the world bounds
    ((2, 3): minimum and maximum corner). With `fit_metres`, the scene is first centred on the
    origin and scaled uniformly so that its longest side is that long (MetalRoughSpheres is
    7 mm across, too close for any camera lens to focus on)."""
    positions, faces = world_triangles(source)
    if fit_metres is not None:
        low, high = positions.min(axis=0), positions.max(axis=0)
        scale = fit_metres / float((high - low).max())
        positions = ((positions - (low + high) / 2) * scale).astype(np.float32)
    write_ply(ply, positions, faces)
    write_matte_glb(glb, positions, faces, albedo)
    return len(faces), np.array([positions.min(axis=0), positions.max(axis=0)])


if __name__ == "__main__":
    if len(sys.argv) != 4:
        sys.exit("usage: convert.py SCENE.gltf|glb OUT.ply OUT.glb")
    count, bounds = convert(Path(sys.argv[1]), Path(sys.argv[2]), Path(sys.argv[3]))
    print(f"{count} triangles, bounds {bounds[0]} to {bounds[1]}")
