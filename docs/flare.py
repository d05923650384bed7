"""Makes docs/flare.png: a bright lamp at night through two lenses, bare and single-coated, and
the same lamp just outside the frame (veiling glare).

Usage: python3 docs/flare.py REALCAM_BINARY OUT.png

The scene (written here as an embedded glTF) is a dim wall 6 m ahead with a row of grey
pillars before it and one small, very bright lamp (a 25 cm square at 20 000 nits). Each panel
is `realcam render` of it with the row's lens and aim, the column's `--coating`, and a fixed
exposure; 320×200 at 2048 spp on the CPU.
"""
import base64, json, struct, subprocess, sys, tempfile
from pathlib import Path

from PIL import Image, ImageDraw


def quad(centre, size, normal_z=1.0):
    x, y, z = centre
    h = size / 2
    return [(x - h, y - h, z), (x + h, y - h, z), (x + h, y + h, z), (x - h, y + h, z)]


def box(x0, x1, y0, y1, z0, z1):
    """Four upright faces of a pillar (front, back, left, right)."""
    return [
        [(x0, y0, z1), (x1, y0, z1), (x1, y1, z1), (x0, y1, z1)],
        [(x1, y0, z0), (x0, y0, z0), (x0, y1, z0), (x1, y1, z0)],
        [(x0, y0, z0), (x0, y0, z1), (x0, y1, z1), (x0, y1, z0)],
        [(x1, y0, z1), (x1, y0, z0), (x1, y1, z0), (x1, y1, z1)],
    ]


def scene(path):
    groups = {  # material index -> list of quads
        0: [quad((0, 1.5, -6.0), 14.0)],  # the wall
        1: [],  # pillars
        2: [quad((0.55, 1.05, -5.9), 0.25)],  # the lamp
    }
    groups[0].append([(-7, 0, 0), (7, 0, 0), (7, 0, -6), (-7, 0, -6)])  # the ground
    for i in range(-4, 5):
        x = i * 0.8
        groups[1] += box(x - 0.1, x + 0.1, 0.0, 2.2, -4.6, -4.4)
    blob, views, accessors, primitives = b"", [], [], []
    for material, quads in groups.items():
        positions, normals, indices = [], [], []
        for q in quads:
            a, b, c = q[0], q[1], q[2]
            u = [b[k] - a[k] for k in range(3)]
            v = [c[k] - a[k] for k in range(3)]
            n = [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]]
            length = sum(x * x for x in n) ** 0.5
            base = len(positions)
            positions += q
            normals += [[x / length for x in n]] * 4
            indices += [base, base + 1, base + 2, base, base + 2, base + 3]
        for data, kind, count, extra in [
            (b"".join(struct.pack("<3f", *p) for p in positions), "VEC3", len(positions),
             {"min": [min(p[k] for p in positions) for k in range(3)],
              "max": [max(p[k] for p in positions) for k in range(3)]}),
            (b"".join(struct.pack("<3f", *n) for n in normals), "VEC3", len(normals), {}),
            (b"".join(struct.pack("<I", i) for i in indices), "SCALAR", len(indices), {}),
        ]:
            views.append({"buffer": 0, "byteOffset": len(blob), "byteLength": len(data)})
            component = 5125 if kind == "SCALAR" else 5126
            accessors.append({"bufferView": len(views) - 1, "componentType": component,
                              "count": count, "type": kind, **extra})
            blob += data
        k = len(accessors)
        primitives.append({"attributes": {"POSITION": k - 3, "NORMAL": k - 2},
                           "indices": k - 1, "material": material})
    gltf = {
        "asset": {"version": "2.0"},
        "extensionsUsed": ["KHR_materials_emissive_strength"],
        "buffers": [{"byteLength": len(blob),
                     "uri": "data:application/octet-stream;base64," + base64.b64encode(blob).decode()}],
        "bufferViews": views,
        "accessors": accessors,
        "materials": [
            {"pbrMetallicRoughness": {"baseColorFactor": [0.3, 0.3, 0.32, 1], "metallicFactor": 0, "roughnessFactor": 1}},
            {"pbrMetallicRoughness": {"baseColorFactor": [0.6, 0.55, 0.5, 1], "metallicFactor": 0, "roughnessFactor": 1}},
            {"pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1]}, "emissiveFactor": [1.0, 0.9, 0.75],
             "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 20000.0}}},
        ],
        "meshes": [{"primitives": primitives}],
        "nodes": [{"mesh": 0}],
        "scenes": [{"nodes": [0]}],
        "scene": 0,
    }
    Path(path).write_text(json.dumps(gltf))


ROWS = [
    ("dgauss.50mm, lamp in frame", ["--lens", "dgauss.50mm", "--look-at", "0,1.3,-6"]),
    ("wide.22mm, lamp in frame", ["--lens", "wide.22mm", "--look-at", "0,1.3,-6"]),
    ("dgauss.50mm, lamp just outside", ["--lens", "dgauss.50mm", "--look-at", "-1.4,1.3,-6"]),
]
COLUMNS = [("--coating none", ["--coating", "none"]), ("single-coated (default)", [])]
COMMON = ["--look-from", "0,1.3,0", "--env", "0.02,0.02,0.03", "--width", "320", "--height",
          "200", "--spp", "2048", "--max-depth", "3", "--exposure", "-3", "--focus-distance", "6"]


def main():
    realcam, out = sys.argv[1], Path(sys.argv[2])
    with tempfile.TemporaryDirectory() as tmp:
        gltf = Path(tmp) / "flare.gltf"
        scene(gltf)
        panels = []
        for row_label, row in ROWS:
            line = []
            for column_label, column in COLUMNS:
                png = Path(tmp) / "render.png"
                subprocess.run([realcam, "render", str(gltf), *COMMON, *row, *column, "--out", str(png)],
                               check=True, capture_output=True)
                line.append((f"{row_label}, {column_label}", Image.open(png).convert("RGB")))
            panels.append(line)
    gap, caption = 8, 22
    w, h = panels[0][0][1].size
    sheet = Image.new("RGB", (2 * w + gap, len(panels) * (h + caption + gap) - gap), "white")
    draw = ImageDraw.Draw(sheet)
    for r, line in enumerate(panels):
        for c, (label, image) in enumerate(line):
            x, y = c * (w + gap), r * (h + caption + gap)
            draw.text((x + 4, y + 5), label, fill="black")
            sheet.paste(image, (x, y + caption))
    sheet.save(out, optimize=True)


if __name__ == "__main__":
    main()
