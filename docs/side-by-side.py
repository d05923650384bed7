"""Makes the README's side-by-side crops from renders of the default scene.

Usage: python3 docs/side-by-side.py REALCAM_BINARY FIGURE OUT.png, FIGURE one of:

  colour-grain    docs/colour-grain.png: the default render's floor (512², 64 spp,
                  dgauss.50mm; a crop enlarged 2×) with one wavelength per sample and the
                  box filter (the estimator before issue 25), four wavelengths and the box,
                  the default (three, tent filter), and --dispersion off.
  lateral-colour  docs/lateral-colour.png: the lower left of the default scene through
                  fisheye.10mm (--film-diagonal 30, 480×320, 64 spp; a crop enlarged 3×) with
                  --dispersion off and on.

Each panel is `realcam render` with the figure's arguments, the panel's, and a fixed exposure.
"""
import subprocess, sys, tempfile
from pathlib import Path

from PIL import Image, ImageDraw

FIGURES = {
    "colour-grain": {
        "args": ["--exposure", "2.5"],
        "crop": (150, 250, 350, 420),  # left, top, right, bottom
        "scale": 2,
        "panels": [
            ("--wavelengths 1 --filter box", ["--wavelengths", "1", "--filter", "box"]),
            ("--filter box (4 wavelengths)", ["--filter", "box"]),
            ("default (3 wavelengths, tent)", []),
            ("--dispersion off", ["--dispersion", "off"]),
        ],
    },
    "lateral-colour": {
        "args": ["--lens", "fisheye.10mm", "--film-diagonal", "30", "--width", "480",
                 "--height", "320", "--spp", "64", "--exposure", "4.5"],
        "crop": (20, 195, 140, 285),
        "scale": 3,
        "panels": [
            ("--dispersion off", ["--dispersion", "off"]),
            ("--dispersion on", []),
        ],
    },
}


def main():
    realcam, figure, out = sys.argv[1], FIGURES[sys.argv[2]], Path(sys.argv[3])
    panels = []
    with tempfile.TemporaryDirectory() as tmp:
        for label, args in figure["panels"]:
            png = Path(tmp) / "render.png"
            subprocess.run([realcam, "render", *figure["args"], *args, "--out", str(png)],
                           check=True, capture_output=True)
            crop = Image.open(png).convert("RGB").crop(figure["crop"])
            scale = figure["scale"]
            crop = crop.resize((crop.width * scale, crop.height * scale), Image.NEAREST)
            panels.append((label, crop))
    gap, caption = 8, 22
    width = sum(p.width for _, p in panels) + gap * (len(panels) - 1)
    height = panels[0][1].height + caption
    sheet = Image.new("RGB", (width, height), "white")
    draw = ImageDraw.Draw(sheet)
    x = 0
    for label, panel in panels:
        sheet.paste(panel, (x, caption))
        draw.text((x + 4, 4), label, fill="black")
        x += panel.width + gap
    sheet.save(out)


if __name__ == "__main__":
    main()
