#!/usr/bin/env python3
"""Peak resident memory and load + BVH time of realcam binaries on large meshes, side by side.

Writes two synthetic meshes of 2 M triangles (a 1000 × 1000 vertex grid, indexed: 1 M vertices;
the same triangles as a soup: 6 M vertices), the calibration points of the scene memory guard
(`src/scene/gltf_loader/budget.rs`), and renders each, plus any scene given with --scene, with
each binary in turn at 64², 1 spp, reading each process's peak resident size from the kernel
(`wait4`) and its load + BVH seconds from `--stats`.

    python3 benches/memory_peak.py BIN1,BIN2 [--rounds 2] [--threads 2] [--scene .peers/spheres.glb]
"""

import argparse
import array
import json
import os
import random
import struct
import subprocess
import sys
import tempfile


def write_glb(path, positions, indices):
    """A glTF binary of one mesh: `positions` (flat floats), `indices` (flat u32) or None."""
    position_bytes = positions.tobytes()
    index_bytes = indices.tobytes() if indices is not None else b""
    xs, ys, zs = positions[0::3], positions[1::3], positions[2::3]
    accessors = [{"bufferView": 0, "componentType": 5126, "count": len(positions) // 3,
                  "type": "VEC3", "min": [min(xs), min(ys), min(zs)], "max": [max(xs), max(ys), max(zs)]}]
    views = [{"buffer": 0, "byteOffset": 0, "byteLength": len(position_bytes)}]
    primitive = {"attributes": {"POSITION": 0}}
    if indices is not None:
        accessors.append({"bufferView": 1, "componentType": 5125, "count": len(indices), "type": "SCALAR"})
        views.append({"buffer": 0, "byteOffset": len(position_bytes), "byteLength": len(index_bytes)})
        primitive["indices"] = 1
    binary = position_bytes + index_bytes
    gltf = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
            "meshes": [{"primitives": [primitive]}], "buffers": [{"byteLength": len(binary)}],
            "bufferViews": views, "accessors": accessors}
    text = json.dumps(gltf).encode()
    text += b" " * (-len(text) % 4)
    binary += b"\0" * (-len(binary) % 4)
    with open(path, "wb") as out:
        out.write(struct.pack("<III", 0x46546C67, 2, 12 + 8 + len(text) + 8 + len(binary)))
        out.write(struct.pack("<II", len(text), 0x4E4F534A) + text)
        out.write(struct.pack("<II", len(binary), 0x004E4942) + binary)


def meshes(folder, n=1000):
    """The indexed grid and its soup, in `folder`; their paths."""
    rng = random.Random(1)
    positions = array.array("f")
    for y in range(n):
        for x in range(n):
            positions.extend((x / n * 2 - 1, y / n * 2 - 1, rng.random() * 0.01))
    indices = array.array("I")
    for y in range(n - 1):
        for x in range(n - 1):
            q = y * n + x
            indices.extend((q, q + 1, q + n, q + 1, q + n + 1, q + n))
    soup = array.array("f")
    for i in indices:
        soup.extend(positions[3 * i:3 * i + 3])
    paths = [os.path.join(folder, "grid-indexed.glb"), os.path.join(folder, "grid-soup.glb")]
    write_glb(paths[0], positions, indices)
    write_glb(paths[1], soup, None)
    return paths


def measure(binary, scene, threads, folder):
    stats = os.path.join(folder, "stats.json")
    command = [binary, "render", scene, "--look-from", "0,0,4.5", "--look-at", "0,0,0", "--width", "64",
               "--height", "64", "--spp", "1", "--threads", str(threads),
               "--out", os.path.join(folder, "out.png"), "--stats", stats]
    process = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _, status, usage = os.wait4(process.pid, 0)
    if os.waitstatus_to_exitcode(status) != 0:
        raise RuntimeError(f"{binary} on {scene} failed: {process.stderr.read().decode()[-500:]}")
    seconds = json.load(open(stats))["stage_seconds"]
    return usage.ru_maxrss / 1024, seconds.get("load_scene", 0) + seconds.get("build_bvh", 0)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("binaries", help="comma-separated realcam binaries")
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--scene", action="append", default=[], help="another scene to measure")
    args = parser.parse_args()
    binaries = args.binaries.split(",")
    with tempfile.TemporaryDirectory() as folder:
        scenes = args.scene + meshes(folder)
        rows = {}
        for _ in range(args.rounds):
            for scene in scenes:
                for binary in binaries:
                    rows.setdefault((scene, binary), []).append(measure(binary, scene, args.threads, folder))
        print(f"{'scene':<18} {'binary':<28} {'peak MB':>8} {'load+BVH s':>11}  (each round)")
        for (scene, binary), runs in rows.items():
            peaks = ", ".join(f"{peak:.0f}" for peak, _ in runs)
            times = ", ".join(f"{t:.2f}" for _, t in runs)
            print(f"{os.path.basename(scene):<18} {binary[-28:]:<28} {max(p for p, _ in runs):8.0f} "
                  f"{min(t for _, t in runs):11.2f}  ({peaks}; {times})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
