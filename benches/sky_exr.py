"""Writes a synthetic equirectangular sky, 2048 × 1024 float EXR: a blue gradient brightest at the
zenith and a small sun of 5000 nits, the kind of HDR environment a user lights a scene with.
Used to time environment-map lighting (BENCHMARKS.md, twelfth session).

    python3 benches/sky_exr.py OUT.exr      # needs numpy and OpenEXR (pip install numpy OpenEXR)
"""
import sys

import Imath
import numpy as np
import OpenEXR

WIDTH, HEIGHT = 2048, 1024


def main() -> None:
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    y, x = np.mgrid[0:HEIGHT, 0:WIDTH]
    theta = (y + 0.5) / HEIGHT * np.pi
    sky = np.clip(np.cos(theta), 0, 1)[..., None] * np.array([0.4, 0.6, 1.0]) + 0.05
    distance = np.hypot((x - 1400) / WIDTH * 2 * np.pi * np.sin(theta), theta - 0.6)
    sun = (distance < 0.03)[..., None] * np.array([5000.0, 4500.0, 4000.0])
    image = (sky + sun).astype(np.float32)
    header = OpenEXR.Header(WIDTH, HEIGHT)
    channel = Imath.Channel(Imath.PixelType(Imath.PixelType.FLOAT))
    header["channels"] = {"R": channel, "G": channel, "B": channel}
    out = OpenEXR.OutputFile(sys.argv[1], header)
    out.writePixels({c: image[..., i].tobytes() for i, c in enumerate("RGB")})
    out.close()


if __name__ == "__main__":
    main()
