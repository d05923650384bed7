#!/usr/bin/env python3
"""Builds realcam's bundled zoom lenses and focus-group primes: ``lenses/<name>.toml`` in
realcam's lens format, from patent prescriptions typed into this script (the tables below), with
``[zoom]`` and ``[focus]`` tables; and ``lenses/licenses/patent-facts.txt``.

    python3 lenses/tools/make_patent_lenses.py [--out DIR] [--check]

``--out`` defaults to the repository's ``lenses/``. ``--check`` writes nothing and fails if any
generated file differs from the one on disk. Python 3 standard library only; the number
formatting, sag and aperture-trimming helpers are make_library.py's.

What is typed here, and only that, is what each patent publishes: radii, axial thicknesses,
n_d and v_d, the variable gaps at each zoom position or focus state, the stated focal lengths,
F-numbers, close-focus distance and back focus. The numbers were read from the transcriptions
in ronbuening/LensVisualizer (src/lens-data/*.data.ts, each file's header saying which numbers
are its patent's and which its transcriber inferred); that repository states no licence, so
nothing else of it is used: not its semi-diameters, stop diameters, glass names or back-focus
reconstructions, nor any of its code or prose. Each design's ``notes`` say where its numbers
come from and which (if any) the patent's table does not give.

Clear apertures are computed here, not taken from anywhere (``apertures``): a surface's clear
semi-diameter is first the paraxial marginal-ray height (the stop sized for the published
F-number at that position) plus the paraxial chief-ray height to the corner of the image (the
patent's image height, else the full frame's 21.63 mm), the larger over every zoom position and
focus state (infinity and the close focus), plus MARGIN; then, at every position and focus state,
reduced where a sphere ends, where an element's edge would be thinner than MIN_EDGE or two
elements would touch (make_library.trim_apertures), and to the widest real ray (exact meridional
trace) of those beams (any field up to the image corner, the whole stop) that the other
apertures let through. The result is checked: every element's edge at least MIN_EDGE, the axial
beam at the published F-number unclipped at infinity, the chief ray to the image corner passing
at every position and focus state.
"""

import argparse
import math
import sys
from pathlib import Path

sys.dont_write_bytecode = True  # no __pycache__ in lenses/tools/ from importing make_library
sys.path.insert(0, str(Path(__file__).resolve().parent))
from make_library import (  # noqa: E402
    FULL_FRAME_DIAGONAL_MM,
    REPO,
    sag,
    toml_number,
    toml_string,
    trim_apertures,
    write_outputs,
)

LENS_VISUALIZER = "ronbuening/LensVisualizer @ bf55b14f"
LICENCE = "none (facts from patent tables)"
LICENCE_FILE = "patent-facts.txt"

# A full-frame (36 x 24 mm) image's half diagonal, for a patent that states no image height.
FULL_FRAME_IMAGE_HEIGHT = 21.63
# Added to the computed clear semi-diameters: 2 %.
MARGIN = 0.02
# The beams whose real rays the clear apertures are reduced to: fields (fractions of the image
# height) and points across the stop (fractions of its radius), in the meridional plane.
FIELDS = [k / 10.0 for k in range(11)]
PUPILS = [k / 20.0 - 1.0 for k in range(41)]
# The thinnest edge an element is given, mm: where its surfaces would come closer at the rim of
# the computed aperture, the aperture is reduced to where its edge is this thick.
MIN_EDGE = 0.3

# ---------------------------------------------------------------------------------------------
# The designs. Each surface row is (radius, thickness after, n_d, v_d) as the patent's table gives
# it, front to back: radius None for a plane, n_d and v_d None for air after the surface;
# ("stop", thickness) is the aperture stop. The thicknesses are those of the first zoom position,
# at infinity focus (checked against the zoom and focus tables). The last surface's thickness,
# the distance to the image, is computed (the paraxial back focus; tests/lens/library.rs checks
# realcam's film distance against the patent's back focus where it gives one).
#
# zoom: surfaces (numbered from 1 as realcam counts them, the stop included) whose following gap
# changes, and per position (published focal length, published F-number, gaps).
# focus: close focus (metres, object to image), the surfaces whose gaps change, and those gaps at
# infinity and at the close focus.

DESIGNS = [
    dict(
        name="nikon-af-s-600mm-f4e-fl-if",
        title="Nikon AF-S Nikkor 600mm f/4E FL ED VR (US 2018/0031811 A1, Example 4)",
        patent="US 2018/0031811 A1 (Nikon, S. Miwa and M. Yamashita), Example 4, Table 4",
        path="src/lens-data/nikon/NikonAFSNikkor600mmf4EFLEDVR.data.ts",
        year=2018,
        focal=587.80,
        f_number=4.08,
        image_height=21.60,
        surfaces=[
            (1200.5127, 5.0, 1.5168, 63.88),  # 1: the protective meniscus HG
            (1199.6476, 1.0, None, None),  # 2
            (225.0, 16.4, 1.43385, 95.25),  # 3
            (-1939.6468, 80.0, None, None),  # 4
            (161.4252, 16.6, 1.43385, 95.25),  # 5
            (-625.3189, 2.15, None, None),  # 6
            (-566.2858, 6.0, 1.61266, 44.46),  # 7
            (350.3515, 104.8, None, None),  # 8
            (70.3762, 3.5, 1.7725, 49.62),  # 9
            (47.5154, 10.8, 1.49782, 82.57),  # 10
            (243.3331, 17.545, None, None),  # 11: d11 changes with focus
            (None, 3.0, 1.92286, 20.88),  # 12
            (-206.782, 2.5, 1.83481, 42.73),  # 13
            (82.7523, 45.385, None, None),  # 14: d14 changes with focus
            ("stop", 13.2),  # 15: the aperture stop S
            (125.8462, 1.8, 1.90265, 35.73),  # 16
            (46.604, 6.0, 1.59319, 67.9),  # 17
            (-146.6583, 10.0, None, None),  # 18
            (-252.0989, 3.2, 1.78472, 25.72),  # 19
            (-68.001, 2.0, 1.49782, 82.57),  # 20
            (67.9727, 1.7, None, None),  # 21
            (None, 1.8, 1.816, 46.59),  # 22
            (75.4444, 4.5, None, None),  # 23
            (46.959, 7.4, 1.61266, 44.46),  # 24
            (-46.959, 1.15, None, None),  # 25
            (-46.224, 1.7, 1.92286, 20.88),  # 26
            (-75.1558, 7.4, None, None),  # 27
            (-59.2874, 2.45, 1.59319, 67.9),  # 28
            (42.619, 1.95, None, None),  # 29
            (51.7215, 5.4, 1.67003, 47.14),  # 30
            (-154.5582, None, None, None),  # 31: then the low-pass filter FL (left out)
        ],
        focus=dict(close_m=4.4, surfaces=[11, 14], infinity=[17.545, 45.385], close=[33.104, 29.826]),
        published="the patent's Table 4 for Example 4: f = 587.80 mm, FNO 4.08, 2 omega 4.19 "
        "degrees, image height Y = 21.60 mm; focusing by moving the cemented negative G2 (surfaces "
        "12-14) toward the image, d11 17.545 -> 33.104 mm and d14 45.385 -> 29.826 mm, to the close "
        "state with the object d0 = 3930.900 mm in front of surface 1 (with the total length TL = "
        "469.10 mm, 4.400 m from the image) at magnification -0.145; back focus (air-converted) "
        "BF = 82.26 mm",
        notes="The stop is the patent's surface 15 (S), 13.2 mm before surface 16 (its diameter is "
        "not published). The patent's surface 1-2 protective meniscus HG is kept; its low-pass "
        "filter FL (surfaces 32-33, a 1.50 mm plate of n_d 1.51680) is left out, as realcam's film "
        "has no filter: the patent's air-converted back focus is the distance to the image without "
        "it, which the tests check. Close focus 4.4 m is the patent's d0 + TL, object to image "
        "with the plate (0.5 mm longer than without it).",
    ),
    dict(
        name="samyang-af-85mm-f1.4-if",
        title="Samyang AF 85mm F1.4 FE (WO 2021/085655 A1, Example 3)",
        patent="WO 2021/085655 A1 (Samyang Optics, Kim Moon-Kyung), Example 3, Tables 5-7",
        path="src/lens-data/samyang/SamyangAF85mmf14.data.ts",
        year=2021,
        focal=84.0,
        f_number=1.47,
        image_height=None,
        surfaces=[
            (58.93, 7.67, 2.00069, 25.46),  # 1
            (235.051, 1.232, None, None),  # 2
            (40.211, 10.395, 1.497, 81.61),  # 3
            (None, 1.9, 1.84666, 23.78),  # 4
            (29.846, 3.637, None, None),  # 5
            (35.905, 6.862, 1.7725, 49.62),  # 6
            (225.077, 1.94373, None, None),  # 7: D1 changes with focus
            (656.333, 1.0, 1.713, 53.94),  # 8
            (31.93, 9.91877, None, None),  # 9: D2 changes with focus
            ("stop", 4.197),  # 10: STOP
            (541.689, 1.9, 1.7552, 27.53),  # 11
            (19.223, 10.447, 1.713, 53.94),  # 12
            (-94.886, 2.331, None, None),  # 13
            (-44.171, 1.5, 1.7552, 27.53),  # 14
            (33.915, 6.366, 1.92286, 20.88),  # 15
            (-167.037, 4.428, None, None),  # 16
            (145.893, 4.589, 2.001, 29.13),  # 17
            (-65.755, 16.474, None, None),  # 18
            (-36.344, 1.5, 1.94595, 17.98),  # 19
            (-64.119, None, None, None),  # 20: then the filter / cover plate (left out)
        ],
        focus=dict(close_m=0.9, surfaces=[7, 9], infinity=[1.94373, 9.91877], close=[6.99684, 4.86565]),
        published="the patent's Tables 5-7 for Example 3: f = 84 mm, F/1.47, half field 14.46 "
        "degrees; focusing to 0.90 m by moving the single negative element (surfaces 8-9) toward "
        "the image, D1 1.94373 -> 6.99684 mm and D2 9.91877 -> 4.86565 mm; the back focus 'in Air' "
        "(without the patent's filter plate, surfaces 21-22) 16.854 mm at infinity and 17.045 mm at "
        "0.90 m",
        notes="The stop is the patent's surface 10 (STOP), 4.197 mm before surface 11. The patent's "
        "filter / sensor-cover plate (2.5 mm, n_d 1.5168, surfaces 21-22) is left out: realcam's film "
        "has no cover glass, and the patent gives the back focus without it ('in Air'), which the "
        "tests check. The patent's STOP row gives a semi-diameter of 16.097 mm, which with its f = 84 "
        "mm table would be about f/1.44 and goes with the f = 85.86 mm its text quotes for this "
        "example; the stop here is sized for the tabulated F/1.47 at f = 84 mm. The patent's object "
        "distance D0 = 784 mm at close focus is from surface 1, about 0.90 m object to image.",
    ),
    dict(
        name="canon-ef-28-80mm-f3.5-5.6-zoom",
        title="Canon EF 28-80mm f/3.5-5.6 II (US 5,899,585, Numerical Example 1)",
        patent="US 5,899,585 (Canon, H. Ogawa), Numerical Example 1",
        path="src/lens-data/canon/CanonEF2880mmf3556II.data.ts",
        year=1999,
        image_height=None,
        surfaces=[
            (117.525, 2.7, 1.51633, 64.1),  # 1
            (689.019, 0.15, None, None),  # 2
            (57.304, 1.5, 1.70154, 41.2),  # 3
            (17.459, 9.79, None, None),  # 4
            (-64.591, 1.3, 1.62299, 58.2),  # 5
            (54.489, 0.17, None, None),  # 6
            (31.274, 3.82, 1.76182, 26.5),  # 7
            (160.062, 32.88, None, None),  # 8: D8 changes with zoom
            (32.699, 2.98, 1.63854, 55.4),  # 9
            (-89.601, 0.99, None, None),  # 10
            ("stop", 0.2),  # 11: the stop
            (22.321, 2.17, 1.66672, 48.3),  # 12
            (58.77, 0.98, None, None),  # 13
            (-122.838, 10.46, 1.78472, 25.7),  # 14
            (17.636, 0.89, None, None),  # 15
            (34.854, 2.67, 1.58144, 40.8),  # 16
            (-37.818, 3.01, None, None),  # 17: D17 changes with zoom
            (-64.438, 1.3, 1.63854, 55.4),  # 18
            (83.202, 1.94, None, None),  # 19
            (-709.402, 2.77, 1.66672, 48.3),  # 20
            (-42.415, None, None, None),  # 21
        ],
        zoom=dict(
            surfaces=[8, 17],
            positions=[
                (28.98, 3.46, [32.88, 3.01]),
                (50.00, 4.51, [11.61, 17.95]),
                (77.08, 5.88, [1.31, 37.21]),
            ],
        ),
        published="the patent's Numerical Example 1 (Table 1): f = 28.98, 50.00 and 77.08 mm at "
        "F/3.46, 4.51 and 5.88, zoomed by D8 = 32.88, 11.61, 1.31 mm and D17 = 3.01, 17.95, 37.21 mm",
        notes="The stop is the patent's surface r11, 0.2 mm before r12. The patent gives no "
        "distance from r21 to the image (the back focus): realcam focuses by itself, and the "
        "design's image distance here is the paraxial back focus at the wide end. The first unit "
        "focuses (the patent says so), but the patent tabulates no close-focus spacings: the "
        "zoom positions are at infinity focus, and realcam focuses the lens as a whole.",
    ),
    dict(
        name="canon-ef-70-300mm-f4-5.6-zoom",
        title="Canon EF 70-300mm f/4-5.6L IS USM (JP 2013-140404 A, Numerical Example 1)",
        patent="JP 2013-140404 A (Canon, S. Sugita), Numerical Example 1",
        path="src/lens-data/canon/CanonEF70300mmf4556L.data.ts",
        year=2013,
        image_height=21.64,
        surfaces=[
            (92.444, 6.5, 1.48749, 70.2),  # 1
            (54691.362, 0.15, None, None),  # 2
            (97.867, 2.4, 1.6134, 44.3),  # 3
            (43.715, 9.82, 1.497, 81.5),  # 4
            (337.72, 2.78, None, None),  # 5: D5 changes with zoom
            (-358.052, 1.3, 1.83481, 42.7),  # 6
            (48.879, 3.36, None, None),  # 7
            (-47.573, 1.2, 1.63854, 55.4),  # 8
            (57.047, 2.9, 1.84666, 23.8),  # 9
            (-351.696, 26.47, None, None),  # 10: D10 changes with zoom
            (119.293, 4.28, 1.497, 81.5),  # 11
            (-55.282, 0.15, None, None),  # 12
            (79.913, 4.69, 1.60311, 60.6),  # 13
            (-46.795, 1.3, 1.85026, 32.3),  # 14
            (-361.577, 1.0, None, None),  # 15
            ("stop", 6.01),  # 16: the stop; D16 changes with zoom
            (-40.084, 1.2, 1.70154, 41.2),  # 17
            (37.914, 3.81, 1.80518, 25.4),  # 18
            (-151.434, 16.39, None, None),  # 19: D19 changes with zoom
            (-236.025, 2.9, 1.6968, 55.5),  # 20
            (-45.412, 0.15, None, None),  # 21
            (91.423, 4.77, 1.60311, 60.6),  # 22
            (-33.874, 1.2, 1.84666, 23.8),  # 23
            (-204.484, 0.15, None, None),  # 24
            (56.181, 2.32, 1.7725, 49.6),  # 25
            (166.987, 11.97, None, None),  # 26: D26 changes with zoom
            (105.084, 1.2, 1.883, 40.8),  # 27
            (30.346, 4.69, None, None),  # 28
            (-141.521, 2.99, 1.80518, 25.4),  # 29
            (-35.789, 3.64, None, None),  # 30
            (-31.158, 1.2, 1.883, 40.8),  # 31
            (177.055, 2.14, None, None),  # 32
            (62.632, 3.42, 1.69895, 30.1),  # 33
            (-205.77, None, None, None),  # 34: BF changes with zoom (checked, not set)
        ],
        zoom=dict(
            surfaces=[5, 10, 16, 19, 26],
            positions=[
                (72.20, 4.20, [2.78, 26.47, 6.01, 16.39, 11.97]),
                (135.00, 4.67, [32.18, 14.15, 24.56, 10.16, 10.82]),
                (290.00, 5.86, [56.78, 1.28, 44.99, 2.60, 1.30]),
            ],
        ),
        published="the patent's Numerical Example 1: f = 72.20, 135.00 and 290.00 mm at Fno 4.20, "
        "4.67 and 5.86, half field 16.68, 9.10 and 4.27 degrees, image height 21.64 mm, back focus "
        "46.74, 47.82 and 57.41 mm",
        notes="The stop is the patent's surface 16, sized here for each position's Fno. The back "
        "focus changes with zoom; it is not a zoom gap here (realcam sets the film distance by "
        "focusing), and the tests check realcam's film distance against the patent's BF. The "
        "patent tabulates no close-focus spacings: the zoom positions are at infinity focus, and "
        "realcam focuses the lens as a whole. The patent's table of effective diameters is not used.",
    ),
]

# Rejected candidates (lenses/README.md says the same; the traces are this script's `trace`):
# - Nikon AF-I Nikkor 300mm f/2.8D IF-ED (JP H04-294310 A, Example 1), all spherical, with its
#   focus gaps published (d9 5.1340 -> 16.0229, d14 15.8406 -> 4.9517 mm at R = 2.5 m) and a
#   paraxial EFL of 293.957 mm against the published 293.9647: its stop S is drawn behind the last
#   lens (Fig. 1; no distance or diameter in the table), and realcam refuses a stop as the last
#   surface (the rear element must be glass). Its table's back focus is also 0.685 mm shorter
#   than the patent's Bf 114.1141 mm.
# - Nikon AF-S VR Zoom-Nikkor 70-200mm f/2.8G (US 2003/0133200 A1, Example 1): its Table 1 prints
#   f = 194.0 mm at the tele end; the prescription gives 196.0 mm (1.03 % off; the same table's
#   conditions use 196.0).
# - Nikon AF-S Zoom-Nikkor 80-200mm f/2.8D: the transcription's tele 194 mm against 196.0 mm traced
#   (1.03 %).
# - Nikon AI Zoom-Nikkor 35-105mm and 35-200mm, Vivitar Series 1 35-85mm, Canon PowerShot G1 X
#   Mark II, Canon FD 150-600mm: zoom positions 1.2 % to 7 % from their stated focal lengths as
#   transcribed.
# - Nikon AF-S Nikkor 300mm f/2.8D IF-ED (US 5,745,306 A, Example 1): the transcription leaves out
#   the patent's front protective plate and rear filter and field-stop planes (not typed there),
#   and its close state's d0 + track is 2515.3 mm against the R = 2500 mm label.


# ---------------------------------------------------------------------------------------------
# Paraxial optics (y-nu trace) of a list of surfaces: dicts with radius, thickness, glass
# ((n_d, v_d) or None) as make_library's.


def index(glass):
    return 1.0 if glass is None else glass[0]


def trace(surfaces, y, nu):
    """Heights at each surface of the ray entering surface 1 at height y, reduced angle nu (in
    air), and (y, nu) just after the last surface."""
    n = 1.0
    heights = []
    for i, s in enumerate(surfaces):
        c = 0.0 if s["radius"] is None else 1.0 / s["radius"]
        n_after = index(s["glass"])
        heights.append(y)
        nu -= y * (n_after - n) * c
        if i + 1 < len(surfaces):
            y += s["thickness"] * nu / n_after
        n = n_after
    return heights, y, nu


def efl_and_back_focus(surfaces):
    _, y, nu = trace(surfaces, 1.0, 0.0)
    return -1.0 / nu, -y / nu


def image_distance(surfaces, object_distance):
    """Distance behind the last surface of the paraxial image of an axial point
    `object_distance` in front of surface 1."""
    _, y, nu = trace(surfaces, object_distance, 1.0)
    return -y / nu


def object_for(surfaces, metres):
    """Distance in front of surface 1 of the object whose image lies `metres` from it (object to
    image, as realcam's focus distance is measured from the film), and the image distance."""
    track = sum(s["thickness"] for s in surfaces[:-1])
    total = metres * 1000.0

    def error(s):
        return s + track + image_distance(surfaces, s) - total

    lo, hi = 0.5 * total, total - track
    # The object-to-image distance falls from the far end and rises again past 4f: search from
    # the far end inward for the conjugate that is a real image.
    a, b = hi, hi
    while error(a) > 0.0:
        a = lo + 0.5 * (a - lo)
        if a - lo < 1e-9:
            raise SystemExit(f"no object at {metres} m from the image")
    for _ in range(200):
        mid = 0.5 * (a + b)
        if error(mid) > 0.0:
            b = mid
        else:
            a = mid
    s = 0.5 * (a + b)
    return s, image_distance(surfaces, s)


# ---------------------------------------------------------------------------------------------


def base_surfaces(design):
    """realcam surfaces (make_library's dicts) with the table's gaps; the image distance not yet
    set."""
    surfaces = []
    for row in design["surfaces"]:
        if row[0] == "stop":
            surfaces.append(dict(radius=None, thickness=row[1], glass=None, diameter=0.0, stop=True, conic=0.0, aspheric=[]))
            continue
        radius, thickness, n_d, v_d = row
        glass = None if n_d is None else (n_d, v_d)
        surfaces.append(dict(radius=radius, thickness=thickness, glass=glass, diameter=0.0, stop=False, conic=0.0, aspheric=[]))
    return surfaces


def states(design):
    """Every state the lens is in: (zoom position index or None, focus 'infinity'/'close',
    the gaps {surface index (0-based): thickness})."""
    zoom = design.get("zoom")
    focus = design.get("focus")
    positions = [None] if zoom is None else list(range(len(zoom["positions"])))
    out = []
    for p in positions:
        gaps = {} if p is None else {s - 1: t for s, t in zip(zoom["surfaces"], zoom["positions"][p][2])}
        out.append((p, "infinity", dict(gaps)))
        if focus:
            close = dict(gaps)
            close.update({s - 1: t for s, t in zip(focus["surfaces"], focus["close"])})
            out.append((p, "close", close))
    return out


def at(surfaces, gaps):
    copy = [dict(s) for s in surfaces]
    for i, t in gaps.items():
        copy[i]["thickness"] = t
    return copy


def build(design):
    surfaces = base_surfaces(design)
    stop = next(i for i, s in enumerate(surfaces) if s["stop"])
    zoom, focus = design.get("zoom"), design.get("focus")
    # The table's gaps are the first position's at infinity.
    first = states(design)[0][2]
    if focus:
        first.update({s - 1: t for s, t in zip(focus["surfaces"], focus["infinity"])})
    for i, t in first.items():
        if surfaces[i]["thickness"] != t:
            raise SystemExit(f"{design['name']}: surface {i + 1}'s thickness is not the first position's gap")
    image_height = design["image_height"] or FULL_FRAME_IMAGE_HEIGHT
    # The last thickness: 0 while tracing (it is after the last surface).
    surfaces[-1]["thickness"] = 0.0

    # The stop per zoom position, sized for its published F-number at infinity: the entrance
    # pupil is EFL / N across, and a ray parallel to the axis at unit height crosses the stop at
    # heights[stop].
    published = (
        [(design["focal"], design["f_number"])]
        if zoom is None
        else [(f, n) for f, n, _ in zoom["positions"]]
    )
    stop_diameters = []
    efls = []
    back_focus = []
    for p, (focal, f_number) in enumerate(published):
        gaps = states(design)[2 * p if focus else p][2]
        lens = at(surfaces, gaps)
        efl, bfl = efl_and_back_focus(lens)
        heights, _, _ = trace(lens, 1.0, 0.0)
        diameter = round(abs(efl / f_number * heights[stop]), 4)
        stop_diameters.append(diameter)
        efls.append(efl)
        back_focus.append(bfl)
        if abs(efl / focal - 1.0) > 0.01:
            raise SystemExit(f"{design['name']}: position {p + 1}: paraxial EFL {efl:.3f} mm, published {focal} mm")

    surfaces[stop]["diameter"] = max(stop_diameters)
    changes, thinnest, clipped = apertures(design, surfaces, stop, stop_diameters, image_height)

    # The surfaces list is the lens at the zoom position whose stop opens widest (the first such),
    # so that the stop's diameter, the widest, is that position's own.
    # Its image distance is that position's paraxial back focus at infinity.
    written = stop_diameters.index(max(stop_diameters))
    if zoom:
        for s, t in zip(zoom["surfaces"], zoom["positions"][written][2]):
            surfaces[s - 1]["thickness"] = t
    surfaces[-1]["thickness"] = round(back_focus[written], 4)
    design["computed"] = dict(
        efl=efls,
        back_focus=back_focus,
        stop_diameters=stop_diameters,
        thinnest=thinnest,
        clipped=clipped,
        written=written,
    )
    design["notes_text"] = notes(design, surfaces, changes, image_height)
    return surfaces


# ---------------------------------------------------------------------------------------------
# Real rays (exact meridional trace through spheres and planes), for the beams the clear
# apertures must pass: the paraxial rays overestimate or underestimate ray heights far off axis
# (a wide angle's front group, with its distortion).


def real_trace(lens, y, z, dy, dz):
    """Heights at each surface of the ray from (y, z) along the unit (dy, dz) (z along the
    axis, 0 at the first vertex), and its point and direction after the last surface; None
    where it misses a surface or is totally reflected."""
    vertex, n = 0.0, 1.0
    heights = []
    for s in lens:
        n2 = index(s["glass"])
        if s["radius"] is None:
            t = (vertex - z) / dz
            y, z = y + t * dy, vertex
            ny, nz = 0.0, -1.0
        else:
            r = s["radius"]
            oy, oz = y, z - (vertex + r)
            b = oy * dy + oz * dz
            disc = b * b - (oy * oy + oz * oz - r * r)
            if disc < 0.0:
                return None
            t = -b - math.copysign(math.sqrt(disc), r)
            y, z = y + t * dy, z + t * dz
            ny, nz = y / r, (z - vertex - r) / r
        if ny * dy + nz * dz > 0.0:
            ny, nz = -ny, -nz
        mu = n / n2
        cos_i = -(ny * dy + nz * dz)
        k = 1.0 - mu * mu * (1.0 - cos_i * cos_i)
        if k < 0.0:
            return None
        cos_t = math.sqrt(k)
        dy, dz = mu * dy + (mu * cos_i - cos_t) * ny, mu * dz + (mu * cos_i - cos_t) * nz
        heights.append(y)
        vertex += s["thickness"]
        n = n2
    return heights, (y, z, dy, dz)


def solve(f, target, x0, x1):
    """x with f(x) = target (f monotonic near the root, None where undefined), by secant steps
    from x0 and x1, a step that lands where f is undefined halved back; None if not found."""
    f0, f1 = f(x0), f(x1)
    for _ in range(100):
        if f0 is None or f1 is None or f1 == f0:
            return None
        if abs(f1 - target) < 1e-10:
            return x1
        step = (target - f1) * (x1 - x0) / (f1 - f0)
        for _ in range(40):
            f2 = f(x1 + step)
            if f2 is not None:
                break
            step *= 0.5
        else:
            return None
        x0, f0, x1, f1 = x1, f1, x1 + step, f2
    return None


def real_beams(lens, stop, rho, image, object_distance, image_height, fields, pupils):
    """Heights at every surface of real rays through the stop at pupil * rho (its radius) from
    the points whose chief ray meets the image plane (`image` behind the last surface) at field
    * image_height: a list of (field, pupil, heights or None). The object is at infinity
    (object_distance None) or that far in front of surface 1."""
    start = -100.0  # in front of every surface

    def ray(a, b):
        """Infinity: a = angle, b = height at the start plane; finite: a = object height,
        b = angle from the object point."""
        if object_distance is None:
            return real_trace(lens, b, start, math.sin(a), math.cos(a))
        return real_trace(lens, a, -object_distance, math.sin(b), math.cos(b))

    def at_stop(a, b):
        r = ray(a, b)
        return None if r is None else r[0][stop]

    def image_at(a, b):
        r = ray(a, b)
        if r is None:
            return None
        y, z, dy, dz = r[1]
        return y + (sum(s["thickness"] for s in lens[:-1]) + image - z) * dy / dz

    small = 1e-4 if object_distance is None else 1e-6

    def aim(a, target, b0):
        """The b that sends the ray of `a` through the stop at `target`, from a guess b0."""
        return solve(lambda b: at_stop(a, b), target, b0, b0 + small)

    chief = {}

    def chief_image(a):
        b = aim(a, 0.0, chief.get("b", 0.0))
        if b is None:
            return None
        chief["b"] = b
        return image_at(a, b)

    out = []
    # Out along the field, each solution the next one's start (the angle for an object at
    # infinity, the object height for a near one; both 0 on the axis).
    a = 0.0
    for field in fields:
        if field > 0.0:
            a = solve(chief_image, -field * image_height, a, a + small)
        b_chief = None if a is None else aim(a, 0.0, chief.get("b", 0.0))
        for pupil in pupils:
            b = None if b_chief is None else aim(a, pupil * rho, b_chief)
            r = None if b is None else ray(a, b)
            out.append((field, pupil, None if r is None else r[0]))
        if a is None:
            a = 0.0
    return out


def rays(design, surfaces, stop, stop_diameters, image_height):
    """Per state (zoom position, focus state, gaps): per surface, the paraxial marginal-ray
    height (the axial beam filling the stop at that position's published F-number; from the axial
    object point at the close focus) and the paraxial chief-ray height (through the stop's centre
    to the image height on the image plane); and the real rays of the beams (``real_beams``)."""
    focus = design.get("focus")
    out = []
    for p, focus_state, gaps in states(design):
        lens = at(surfaces, gaps)
        lens[-1]["thickness"] = 0.0
        s = None
        rho = stop_diameters[p or 0] / 2.0
        if focus_state == "infinity":
            _, image = efl_and_back_focus(lens)
            marginal, _, _ = trace(lens, 1.0, 0.0)
        else:
            s, image = object_for(lens, focus["close_m"])
            marginal, _, _ = trace(lens, s, 1.0)
        scale = rho / abs(marginal[stop])
        # The chief ray is a*P + b*Q (P entering at unit height parallel to the axis, Q at the
        # vertex at unit angle): through the stop's centre, and at the image height on the image.
        hp, yp, nup = trace(lens, 1.0, 0.0)
        hq, yq, nuq = trace(lens, 0.0, 1.0)
        p_img, q_img = yp + image * nup, yq + image * nuq
        det = hp[stop] * q_img - hq[stop] * p_img
        a = -hq[stop] * image_height / det
        b = hp[stop] * image_height / det
        chief = [a * hp[i] + b * hq[i] for i in range(len(lens))]
        lens[-1]["thickness"] = image
        real = real_beams(
            lens, stop, rho, image, None if focus_state == "infinity" else s, image_height, FIELDS, PUPILS
        )
        out.append((p, focus_state, gaps, [scale * m for m in marginal], chief, real))
    return out


def apertures(design, surfaces, stop, stop_diameters, image_height):
    """Sets every surface's clear diameter but the stop's (see the module's docstring); returns
    what was reduced and why, the thinnest element edge, and the surfaces that clip the axial
    beam at the close focus (none may at infinity)."""
    beams = rays(design, surfaces, stop, stop_diameters, image_height)
    n = len(surfaces)
    # The unvignetted beam: marginal plus chief-ray height, the larger over every state.
    needed = [max(abs(m[i]) + abs(c[i]) for _, _, _, m, c, _ in beams) for i in range(n)]
    for i, s in enumerate(surfaces):
        if not s["stop"]:
            s["diameter"] = math.ceil(2.0 * needed[i] * (1.0 + MARGIN) * 100.0) / 100.0
    first = [s["diameter"] for s in surfaces]
    reasons = [[] for _ in range(n)]

    def trim():
        """make_library's trim in every state: a surface beyond where its sphere ends, or beyond
        where it meets its neighbour (for an element, where its edge would be thinner than
        MIN_EDGE; two elements touching), is reduced to that height."""
        while True:
            changed = False
            for _, _, gaps, _, _, _ in beams:
                lens = at(surfaces, gaps)
                # An element's surfaces "meet" where its edge would be thinner than MIN_EDGE.
                for s in lens:
                    if s["glass"] is not None:
                        s["thickness"] -= MIN_EDGE
                for message in trim_apertures(lens):
                    changed = True
                    i = int(message.split(":")[0].split()[1]) - 1
                    if "which ends there" in message:
                        why = "its sphere ends there"
                    else:
                        j, k = (int(w) for w in message.split("surfaces ")[1].split(" meet")[0].split(" and "))
                        other = k if j == i + 1 else j
                        if "the glass" in message:
                            why = f"its edge with surface {other} would be thinner than {MIN_EDGE:g} mm"
                        else:
                            why = f"it meets surface {other} there"
                    if why not in reasons[i]:
                        reasons[i].append(why)
                for s, t in zip(surfaces, lens):
                    s["diameter"] = t["diameter"]
            if not changed:
                return

    # Every real ray of every state's beams, with its heights.
    real = [h for _, _, _, _, _, r in beams for _, _, h in r if h is not None]
    for p, focus_state, _, _, _, r in beams:
        if any(h is None for field, pupil, h in r if pupil == 0.0):
            raise SystemExit(f"{design['name']}: a chief ray cannot be traced ({p}, {focus_state})")

    def blocked(heights, skip=None):
        return [
            j
            for j in range(n)
            if j != skip and not surfaces[j]["stop"] and abs(heights[j]) > surfaces[j]["diameter"] / 2.0 + 1e-9
        ]

    while True:
        trim()
        # A surface need be no wider than the real rays of those beams (every field up to the
        # image height, the full stop, in every state) that the other clear apertures let through.
        stopped = [blocked(h) for h in real]
        reach = [0.0] * n
        for h, where in zip(real, stopped):
            if len(where) > 1:
                continue
            for i in range(n):
                if (not where or where == [i]) and abs(h[i]) > reach[i]:
                    reach[i] = abs(h[i])
        reduced = False
        for i, s in enumerate(surfaces):
            if s["stop"]:
                continue
            diameter = math.ceil(2.0 * reach[i] * (1.0 + MARGIN) * 100.0) / 100.0
            if diameter < s["diameter"] - 1e-9:
                s["diameter"] = diameter
                reduced = True
                why = "no wider than the real rays the other apertures pass"
                if why not in reasons[i]:
                    reasons[i].append(why)
        if not reduced:
            break
    if surfaces[stop]["diameter"] != max(stop_diameters):
        raise SystemExit(f"{design['name']}: the stop meets a neighbouring surface")
    # Every element's edge at least MIN_EDGE, every air gap at least touching at the rim, in
    # every state.
    thinnest = math.inf
    for _, _, gaps, _, _, _ in beams:
        lens = at(surfaces, gaps)
        for i in range(n - 1):
            front, back = lens[i], lens[i + 1]
            r = min(front["diameter"], back["diameter"]) / 2.0
            edge = front["thickness"] + sag(back, r) - sag(front, r)
            if front["glass"] is not None:
                thinnest = min(thinnest, edge)
                if edge < MIN_EDGE - 1e-3:
                    raise SystemExit(f"{design['name']}: element at surface {i + 1}: edge {edge} mm")
            elif edge < 0.0:
                raise SystemExit(f"{design['name']}: the air gap after surface {i + 1} is {edge} mm at the rim")
    # The axial beam at the published F-number passes every clear aperture at infinity focus, and
    # the chief ray to the corner of the image every aperture in every state; at the close focus,
    # where the axial beam fills the same stop from a near object, the front may clip it.
    clipped = set()
    for p, focus_state, _, _, _, r in beams:
        for field, pupil, h in r:
            if field == 1.0 and pupil == 0.0 and blocked(h):
                raise SystemExit(f"{design['name']}: the chief ray to the corner is blocked ({p}, {focus_state})")
            if field == 0.0 and abs(pupil) == 1.0:
                if h is None:
                    raise SystemExit(f"{design['name']}: an axial rim ray cannot be traced")
                where = blocked(h)
                if where and focus_state == "infinity":
                    raise SystemExit(f"{design['name']}: surface {where[0] + 1} clips the axial beam at infinity")
                clipped.update(j + 1 for j in where)
    changes = [
        f"surface {i + 1} {first[i]:g} -> {surfaces[i]['diameter']:g} mm ({'; '.join(reasons[i])})"
        for i in range(n)
        if surfaces[i]["diameter"] != first[i]
    ]
    return changes, thinnest, sorted(clipped)


def notes(design, surfaces, changes, image_height):
    computed = design["computed"]
    zoom, focus = design.get("zoom"), design.get("focus")
    text = [f"Published figures: {design['published']}."]
    text.append(
        "Typed by lenses/tools/make_patent_lenses.py from the patent's table as transcribed in "
        f"{LENS_VISUALIZER} : {design['path']}, taking only what the patent publishes (radii, "
        "thicknesses, n_d and v_d as model glasses, variable gaps, focal lengths, F-numbers, close "
        "focus, back focus); that repository states no licence, and none of its inferred numbers "
        "(semi-diameters, stop diameter, glass names) is used."
    )
    text.append(design["notes"])
    traced = ", ".join(f"{f:.3f}" for f in computed["efl"])
    text.append(f"Paraxial EFL of this table: {traced} mm.")
    if zoom:
        stops = ", ".join(f"{d:g}" for d in computed["stop_diameters"])
        text.append(
            "The stop is sized at each zoom position for its published F-number (paraxial EFL / "
            f"entrance-pupil diameter): {stops} mm (each position's stop_diameter). The surfaces "
            f"list is the lens at zoom position {computed['written'] + 1}, whose stop opens widest: "
            "the stop's diameter is the widest position's, and the lens as written (no "
            "--zoom-position) is that position."
        )
    else:
        text.append(
            f"The stop is sized for the published F-number (paraxial EFL / entrance-pupil "
            f"diameter): {computed['stop_diameters'][0]:g} mm."
        )
    height = "the patent's image height" if design["image_height"] else "the full frame's half diagonal"
    states_text = "every zoom position" if zoom else "infinity"
    if focus:
        states_text += " and the close focus" if not zoom else ", at infinity and at the close focus"
    text.append(
        "Clear apertures are computed, not published: each surface's is first the paraxial "
        f"marginal-ray height (the stop at its published F-number) plus the chief-ray height to "
        f"{height}, {image_height:g} mm, the larger at {states_text}, plus {MARGIN * 100:g} %, "
        "rounded up to 0.01 mm; then, at all of them, reduced where a surface's sphere ends, where "
        f"an element's edge would be thinner than {MIN_EDGE:g} mm or two elements would touch, and "
        "to the widest real ray (exact meridional trace) of "
        "those beams (any field up to that image height, the full pupil) that the other apertures "
        "let through."
    )
    if changes:
        text.append("Reduced (diameters, mm): " + "; ".join(changes) + ".")
    axial = "The axial beam at the published F-number passes every aperture unclipped at infinity"
    if computed["clipped"]:
        where = ", ".join(str(i) for i in computed["clipped"])
        axial += (
            f"; at the close focus, filling the same stop from the near object, its rim is clipped "
            f"by surface(s) {where}, as far as those elements' edges allow"
        )
    elif focus:
        axial += " and at the close focus"
    text.append(
        f"{axial}; the thinnest element edge is {computed['thinnest']:.3f} mm. The last thickness "
        "is the paraxial back focus at infinity focus."
    )
    return " ".join(text)


# ---------------------------------------------------------------------------------------------
# Writing


def write_toml(design, surfaces):
    zoom, focus = design.get("zoom"), design.get("focus")
    written = design["computed"]["written"]
    focal = design["focal"] if zoom is None else zoom["positions"][written][0]
    f_number = design["f_number"] if zoom is None else zoom["positions"][written][1]
    image_height = design["image_height"]
    film_diagonal = FULL_FRAME_DIAGONAL_MM if image_height is None else round(2.0 * image_height, 2)
    lines = [
        "# realcam lens file: lengths in mm, surfaces front (scene) to back (film); the format",
        "# is described in lenses/README.md.",
        "# Generated by lenses/tools/make_patent_lenses.py from the patent table typed in it:",
        "# edit the script and regenerate rather than editing this file.",
        'format = "realcam-lens/1"',
        f"name = {toml_string(design['name'])}",
        f"title = {toml_string(design['title'])}",
        f"source = {toml_string(design['patent'] + '; ' + LENS_VISUALIZER + ' : ' + design['path'])}",
        f"licence = {toml_string(LICENCE)}",
        f"year = {design['year']}",
        f"focal_length_mm = {toml_number(focal)}",
        f"f_number = {toml_number(f_number)}",
        f"film_diagonal_mm = {toml_number(film_diagonal)}",
        f"notes = {toml_string(design['notes_text'])}",
        "surfaces = [",
    ]
    for s in surfaces:
        fields = []
        if s["stop"]:
            fields.append("stop = true")
        else:
            fields.append('radius = "inf"' if s["radius"] is None else f"radius = {toml_number(s['radius'])}")
        fields.append(f"thickness = {toml_number(s['thickness'])}")
        if s["glass"] is not None:
            fields.append(f"glass = {{ n_d = {toml_number(s['glass'][0])}, v_d = {toml_number(s['glass'][1])} }}")
        fields.append(f"diameter = {toml_number(s['diameter'])}")
        lines.append("  { " + ", ".join(fields) + " },")
    lines.append("]")
    if zoom:
        stops = design["computed"]["stop_diameters"]
        lines += ["", "[zoom]", f"surfaces = [{', '.join(str(s) for s in zoom['surfaces'])}]", "positions = ["]
        for (f, _, gaps), d in zip(zoom["positions"], stops):
            gap_text = ", ".join(toml_number(g) for g in gaps)
            lines.append(
                f"  {{ focal_length_mm = {toml_number(f)}, gaps = [{gap_text}], stop_diameter = {toml_number(d)} }},"
            )
        lines.append("]")
    if focus:
        lines += [
            "",
            "[focus]",
            f"close_focus_m = {toml_number(focus['close_m'])}",
            f"surfaces = [{', '.join(str(s) for s in focus['surfaces'])}]",
            f"infinity = [{', '.join(toml_number(t) for t in focus['infinity'])}]",
            f"close = [{', '.join(toml_number(t) for t in focus['close'])}]",
        ]
    return "\n".join(lines) + "\n"


LICENCE_TEXT = """\
The lenses generated by lenses/tools/make_patent_lenses.py (their files say
licence = "none (facts from patent tables)") are numerical examples published in patent
documents: radii, thicknesses, refractive indices and Abbe numbers, variable gaps, focal
lengths, F-numbers, close-focus distances and back focus, as each patent's tables print them.
They are facts about the designs, published so that anyone may read them.

They were read from the transcriptions of those tables in ronbuening/LensVisualizer
(src/lens-data/), which states no licence (no LICENSE file; package.json is "private" and names
none). Nothing of that repository beyond the patents' own numbers is used: not its code, its
prose, nor the numbers its transcribers inferred (semi-diameters, stop diameters, glass
names, back-focus reconstructions). Each lens's clear apertures and stop diameters are computed
by make_patent_lenses.py, as each file's notes describe.
"""


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=REPO / "lenses")
    parser.add_argument("--check", action="store_true")
    args = parser.parse_args()
    outputs = {}
    for design in DESIGNS:
        surfaces = build(design)
        outputs[f"{design['name']}.toml"] = write_toml(design, surfaces)
        computed = design["computed"]
        if design.get("zoom"):
            published = [f for f, _, _ in design["zoom"]["positions"]]
        else:
            published = [design["focal"]]
        pairs = "  ".join(f"{e:.3f} ({p:g})" for e, p in zip(computed["efl"], published))
        print(f"{design['name']:34} paraxial EFL (published) {pairs}")
    outputs[f"licenses/{LICENCE_FILE}"] = LICENCE_TEXT
    write_outputs(outputs, args.out, args.check, "lenses/tools/make_patent_lenses.py")


if __name__ == "__main__":
    main()
