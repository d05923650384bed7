"""Makes docs/colour-grain.png: a crop of the default render's floor and cones (512², 64 spp,
dgauss.50mm, enlarged 2×) with one wavelength per sample, with the default four, and with
`--dispersion off`. Usage: python3 docs/colour-grain.py REALCAM_BINARY OUT.png

The three renders (the same seed and exposure):

    realcam render --wavelengths 1 --exposure EV --out one.png
    realcam render --exposure EV --out four.png
    realcam render --dispersion off --exposure EV --out rgb.png
"""
import subprocess, sys, tempfile
from pathlib import Path

from PIL import Image, ImageDraw

EXPOSURE = "2.5"
CROP = (150, 250, 350, 420)  # left, top, right, bottom: the floor and a cone's foot
SCALE = 2


def main():
    realcam, out = sys.argv[1], Path(sys.argv[2])
    panels = []
    with tempfile.TemporaryDirectory() as tmp:
        for label, args in [
            ("--wavelengths 1", ["--wavelengths", "1"]),
            ("default (4 wavelengths)", []),
            ("--dispersion off", ["--dispersion", "off"]),
        ]:
            png = Path(tmp) / "render.png"
            subprocess.run([realcam, "render", "--exposure", EXPOSURE, "--out", str(png), *args],
                           check=True, capture_output=True)
            crop = Image.open(png).convert("RGB").crop(CROP)
            crop = crop.resize((crop.width * SCALE, crop.height * SCALE), Image.NEAREST)
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
