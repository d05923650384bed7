"""Makes docs/zoom-positions.png (the built-in scene at each zoom position of the Canon EF
28-80mm zoom) and docs/breathing.png (a unit-focused 85 mm against an internal-focus 85 mm,
focused at 0.9 m and at infinity), each as realcam's own contact sheet.

Usage: python3 docs/zoom.py REALCAM_BINARY DOCS_FOLDER

360×240 at 64 spp on the CPU (about 10 s each on 2 cores). The breathing sheet stops both
lenses down to f/11 so the framing, not the blur, shows; "focus at infinity" is the far end of
a focus sweep to 10⁹ m.
"""
import shutil, subprocess, sys, tempfile
from pathlib import Path

realcam, docs = sys.argv[1], Path(sys.argv[2])
small = ["--width", "360", "--height", "240", "--spp", "64"]
runs = {
    "zoom-positions.png": ["--lens", "canon-ef-28-80mm-f3.5-5.6-zoom", "--zoom-sweep"],
    "breathing.png": ["--lens", "canon-ef-85mm-f1.8", "--lens", "samyang-af-85mm-f1.4-if",
                      "--focus-sweep", "0.9:1e9:2", "--f-number", "11"],
}
with tempfile.TemporaryDirectory() as work:
    for name, options in runs.items():
        sheet = Path(work) / name
        subprocess.run([realcam, "render", *small, *options, "--out", str(Path(work) / "frame.png"),
                        "--contact-sheet", str(sheet)], check=True)
        shutil.copy(sheet, docs / name)
        print("wrote", docs / name)
