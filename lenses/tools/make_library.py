#!/usr/bin/env python3
"""Builds realcam's library of real lens designs: ``lenses/<name>.toml`` in realcam's lens
format, from the prescription data collected in the shared data folder (``lenses-json/`` and
``lenses-zmx/``), and copies the licence texts of those sources into ``lenses/licenses/``.

    python3 lenses/tools/make_library.py [--shared DIR] [--out DIR] [--check]

``--shared`` defaults to the ``shared`` folder next to the repository (or next to its parent,
for a git worktree in a subfolder); ``--out`` to the repository's
``lenses/``. ``--check`` writes nothing and fails if any generated file differs from the one
on disk (so a hand edit or a stale file is caught). Python 3 standard library only.

Every conversion choice is written into the lens file's ``notes``; the design table below says
where each published number comes from. Conventions of the sources (see the README files in
the shared folder):

* DeepLens JSON: ``r`` is the clear SEMI-aperture, ``roc`` the radius (0: a plane; when absent,
  ``c`` = 1/radius), ``d_next`` the distance to the next surface (the last one's: to the
  sensor), ``mat2`` the medium after the surface ("n_d/V_d", a glass or plastic name, "air"),
  ``k`` the conic constant and ``ai`` = [a2, a4, a6, ...] (r² first, as realcam's format).
  Its numbers are float32 values printed as float64 (28.25000010523945 is 28.25): radii,
  conics, coefficients and apertures are rounded to 7 significant digits (float32's
  precision), and thicknesses, which DeepLens derives from float32 cumulative positions, to
  0.1 µm.
* lentil ``lenses.json``: per surface ``radius``, ``thickness`` (to the next surface),
  ``ior``/``abbe`` of the medium after it, ``housing-radius`` (a SEMI-aperture),
  ``aspherical-equation`` = [A4, A6, A8, A10] (r⁴ first; no conic constant), and the element
  whose material is ``iris`` is the aperture stop. lentil marks planes with radii of 9999 and
  more. ``max-fstop-aperture-radius["unscaled"]`` is the iris radius at which lentil's own
  ray trace found the axial beam still unclipped by any housing (``fstop["unscaled"]`` is the
  f-number there): the design's full aperture, which we give the stop.
* Zemax ``.zmx``: ``CURV`` 1/radius, ``DISZ`` thickness, ``DIAM`` SEMI-diameter, ``GLAS``
  catalogue name, ``STOP``; ``FNUM`` is the paraxial f-number EFL / entrance-pupil diameter,
  which sizes the stop.
"""

import argparse
import json
import math
import re
import shutil
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
FULL_FRAME_DIAGONAL_MM = 43.27  # 36 x 24 mm

DEEPLENS = "singer-yang/DeepLens @ e15add06"
LENTIL = "zpelgrims/lentil @ 1492e9dc : polynomial-optics/database/lenses.json"
RAY_OPTICS = "mjhoptics/ray-optics @ 0b1dc26c"

# DeepLens's own plastic indices: deeplens/optics/materials_data.json, MATERIAL_TABLE
# ([n_d, V_d], "References: schott.com interactive Abbe diagram, refractiveindex.info").
DEEPLENS_PLASTICS = {
    "pmma": (1.4918, 57.44),
    "coc": (1.5337, 56.22),
    "okp4": (1.6328, 23.34),
    "polycarb": (1.5855, 29.91),
    "polystyr": (1.5904, 30.87),
}

# Catalogue names for the glass names DeepLens uses (checked by realcam's catalogue when the
# library loads).
DEEPLENS_GLASSES = {"n-sk16": "N-SK16", "f2": "F2"}

LICENCES = {
    "Apache-2.0": ("lenses-json/deeplens/LICENSE-Apache-2.0.txt", "DeepLens-Apache-2.0.txt"),
    "MIT": ("lenses-json/lentil/LICENSE-MIT.txt", "lentil-MIT.txt"),
    "BSD-3-Clause": ("lenses-zmx/licenses/ray-optics-LICENSE.txt", "ray-optics-BSD-3-Clause.txt"),
}

# ---------------------------------------------------------------------------------------------
# The designs. `focal` and `f_number` are the published (nominal) values, `basis` says whose
# they are; None where nothing is published. `film` is the image format's diagonal.

MARKETED = "the maker's marked focal length and f-number"

DESIGNS = [
    # --- DeepLens (Apache-2.0): camera lenses from patents, via photonstophotos.net ----------
    dict(
        name="canon-ef-35mm-f2",
        title="Canon EF 35mm f/2",
        deeplens="camera/ef35mm_f2.0.json",
        patent="JP 1992-015611 Example 1",
        year=1992,
        focal=35.0, f_number=2.0, basis=MARKETED,
    ),
    dict(
        name="canon-ef-40mm-f2.8",
        title="Canon EF 40mm f/2.8 STM",
        deeplens="camera/ef40mm_f2.8.json",
        patent="patent not recorded by DeepLens",
        focal=40.0, f_number=2.8, basis=MARKETED,
        notes="DeepLens names no patent for this file, only the product; six elements in four "
        "groups, one of its surfaces an even asphere.",
    ),
    dict(
        name="canon-ef-50mm-f1.8",
        title="Canon EF 50mm f/1.8",
        deeplens="camera/ef50mm_f1.8.json",
        patent="JP 1987-087922 Example 1",
        year=1987,
        focal=50.0, f_number=1.8, basis=MARKETED,
    ),
    dict(
        name="canon-ef-85mm-f1.8",
        title="Canon EF 85mm f/1.8 USM",
        deeplens="camera/ef85mm_f1.8.json",
        patent="JP 1993-157964 Example 1",
        year=1993,
        focal=85.0, f_number=1.8, basis=MARKETED,
    ),
    dict(
        name="canon-ef-100mm-f2.8-macro",
        title="Canon EF 100mm f/2.8 Macro",
        deeplens="camera/ef100mm_f2.8.json",
        patent="JP 1991-141313 Example 1",
        year=1991,
        focal=100.0, f_number=2.8, basis=MARKETED,
    ),
    dict(
        name="canon-rf-16mm-f2.8",
        title="Canon RF 16mm F2.8 STM",
        deeplens="camera/rf16mm_f2.8.json",
        patent="JP 2022-085382 Example 3",
        year=2022,
        focal=16.0, f_number=2.8, basis=MARKETED,
        notes="DeepLens's note: 'The original patent can not cover full-frame sensor'; its "
        "r_sensor of 18.2 mm gives the film diagonal 36.4 mm.",
    ),
    dict(
        name="canon-rf-24mm-f1.8-macro",
        title="Canon RF 24mm F1.8 Macro IS STM",
        deeplens="camera/rf24mm_f1.8.json",
        patent="US 2022/0019061 Example 3",
        year=2022,
        focal=24.0, f_number=1.8, basis=MARKETED,
        notes="DeepLens's foclen and fnum for this file (39.5 mm, f/5.2) are those of its EF 40mm "
        "file, not estimates for this lens.",
    ),
    dict(
        name="canon-rf-50mm-f1.8",
        title="Canon RF 50mm F1.8 STM",
        deeplens="camera/rf50mm_f1.8.json",
        patent="US 2021/0263286 Example 1",
        year=2021,
        focal=50.0, f_number=1.8, basis=MARKETED,
    ),
    dict(
        name="sigma-70mm-f2.8-macro",
        title="Sigma Macro 70mm F2.8 EX DG",
        deeplens="camera/sigma70mm_f2.8.json",
        patent="JP 2008-020656 Example 1",
        year=2008,
        focal=70.0, f_number=2.8, basis=MARKETED,
    ),
    dict(
        name="yongnuo-50mm-f1.8",
        title="Yongnuo YN 50mm F1.8",
        deeplens="camera/yongnuo_50mm_f1.8.json",
        patent="patent not recorded by DeepLens",
        focal=50.0, f_number=1.8, basis=MARKETED,
        notes="DeepLens names no patent for this file; its r_sensor is 22.5 mm (a 45 mm image "
        "circle, a little more than the 43.3 mm full-frame diagonal).",
    ),
    dict(
        name="cooke-triplet-50mm-f4",
        title="Cooke triplet 50 mm f/4",
        deeplens="cooke.json",
        patent="no source recorded by DeepLens",
        focal=50.0, f_number=4.0,
        basis="the design's nominal values, f = 50 mm at f/4 for a 40-degree field (DeepLens's "
        "r_sensor, 18.175 mm, is 50 mm x tan 20 degrees); DeepLens records no source, and its "
        "own estimate is 49.8 mm, f/4.0",
        notes="Glasses N-SK16 and F2 by catalogue name.",
    ),
    dict(
        name="deeplens-phone-68deg",
        title="DeepLens phone lens, 68-degree field",
        deeplens="cellphone/cellphone68deg.json",
        patent="a lens designed with DeepLens (Xinge Yang)",
        focal=None, f_number=None, fov=68.0,
        basis="DeepLens's own design; its published figure is the field of view in its name, 68 "
        "degrees on its 7.13 mm sensor diagonal",
        notes="Five plastic elements, all ten lens surfaces even aspheres with conic constants. "
        "DeepLens's info text for this file ('80deg FoV, F/2.0') is copied from its 80-degree "
        "design; its foclen 6.53 mm and fnum 3.26 are its own estimates (the paraxial focal "
        "length is 5.72 mm), so neither is taken as published.",
    ),
    dict(
        name="deeplens-phone-80deg",
        title="DeepLens phone lens, 80-degree field",
        deeplens="cellphone/cellphone80deg.json",
        patent="a lens designed with DeepLens (Xinge Yang)",
        focal=None, f_number=None, fov=80.0, deeplens_f_number=2.0,
        basis="DeepLens's own design; its published figures are '80deg FoV, F/2.0' on its 7.66 mm "
        "sensor diagonal",
        notes="Six plastic elements, all twelve lens surfaces even aspheres with conic constants. "
        "DeepLens defines its focal length as the sensor radius over the tangent of the real half "
        "field (3.83 / tan 41.4 degrees = 4.35 mm, its foclen) and F/2.0 as that over the 2.18 mm "
        "entrance pupil; the paraxial focal length is 5.10 mm (the lens has strong barrel "
        "distortion), so realcam reports f/2.34 for the same stop, which is kept.",
    ),
    # --- lentil (MIT): the production-ready designs of its lens database --------------------
    dict(
        name="angenieux-double-gauss-1953",
        title="Angenieux double Gauss (US 2,701,982)",
        lentil="0001",
        year=1953,
        focal=100.0, f_number=None,
        basis="lentil's focal-length-mm-patent (the patent's example is normalised to f = 100 mm); "
        "lentil records no published f-number",
    ),
    dict(
        name="meyer-primoplan-1936",
        title="Meyer-Optik Goerlitz Primoplan",
        lentil="0002",
        year=1936,
        focal=100.0, f_number=None,
        basis="lentil's focal-length-mm-patent (normalised to f = 100 mm); lentil's notes give the "
        "f-number both as 1:1.9 and as f/1.5, so none is taken as published",
    ),
    dict(
        name="nikon-retrofocus-wide-1971",
        title="Nikon retrofocus wide angle (US 3,583,791)",
        lentil="0004",
        year=1971,
        focal=100.0, f_number=2.8,
        basis="lentil's focal-length-mm-patent (normalised to f = 100 mm) and the patent's "
        "relative aperture F/2.8 quoted in lentil's notes (angle of field 75 degrees)",
    ),
    dict(
        name="kodak-petzval-1948",
        title="Kodak Petzval-type lens (US 2,500,046)",
        lentil="0006",
        year=1948,
        focal=100.0, f_number=None,
        basis="lentil's focal-length-mm-patent (f = 100 mm); lentil records no published f-number",
    ),
    dict(
        name="zeiss-biotar-1927",
        title="Zeiss Biotar (DE 485,798)",
        lentil="0009",
        year=1927,
        focal=100.0, f_number=None,
        basis="lentil's focal-length-mm-patent (normalised to f = 100 mm); lentil records no "
        "published f-number",
    ),
    dict(
        name="asahi-takumar-1969",
        title="Asahi Takumar (US 3,451,745)",
        lentil="0010",
        year=1969,
        focal=100.0, f_number=None,
        basis="lentil's focal-length-mm-patent (normalised to f = 100 mm); lentil records no "
        "published f-number",
    ),
    dict(
        name="asahi-takumar-1970",
        title="Asahi SMC Takumar f/2 (US 3,506,336)",
        lentil="0011",
        year=1970,
        focal=100.0, f_number=2.0,
        basis="lentil's focal-length-mm-patent (normalised to f = 100 mm) and the f/2.0 of "
        "lentil's notes ('SMC Takumar f2.0')",
    ),
    dict(
        name="aspheric-fisheye",
        title="Aspheric fisheye, 181-degree field (lentil database)",
        lentil="0014",
        focal=None, f_number=None, fov=181.0,
        basis="the 181-degree field of lentil's notes and of its source file "
        "polynomial-optics/lenses/fisheye-aspherical.fx (a Japanese patent, number not given)",
        notes="lentil lists focal-length-mm-patent 6.0 and fstop 16.6, and the year 1954, but its "
        "own prescription contradicts all three: the paraxial focal length is 9.71 mm (lentil's "
        "ray-traced 5.48 mm comes from its asphere loader, which passes 1 as the conic and skips "
        "A6 and A10), the paraxial back focus, 14.01 mm, is the design's own image distance (14.0 "
        "mm), and its glasses (n_d 2.001/V_d 25.46, 2.003/19.32) are Hoya TAFD40 and E-FDS2, "
        "glasses of this century. None of the three is taken as published. The four aspheres have "
        "conic 0, as the .fx file says. The image is a circle about 28 mm across on the 35 mm frame.",
    ),
    dict(
        name="minolta-fisheye-16mm-f2.8",
        title="Minolta fisheye 16 mm f/2.8 (US 4,256,373)",
        lentil="0015",
        year=1978,
        scale=16.0,
        focal=16.0, f_number=2.8,
        basis="the patent's example at f = 1 (lentil's focal-length-mm-patent) scaled to 16 mm, the "
        "focal length lentil's notes expect the product to have had, and the patent's aperture "
        "ratio f/2.8 quoted in lentil's notes (field 180 degrees)",
    ),
    dict(
        name="canon-35mm-f1.8",
        title="Canon 35mm f/1.8 (US 2,854,890)",
        lentil="0016",
        year=1956,
        scale=35.0,
        focal=35.0, f_number=1.8,
        basis="the patent's example at f = 1 (lentil's focal-length-mm-patent) scaled to 35 mm, the "
        "focal length and f/1.8 lentil's notes give for the product (Canon 35mm f/1.8 of 1956, "
        "field 60 degrees)",
    ),
    # --- ray-optics (BSD-3-Clause): a Zemax file -------------------------------------------
    dict(
        name="rudolph-double-gauss",
        title="Rudolph's double Gauss (US 583,336, Example 2)",
        zmx="US00583336-2-scaled.zmx",
        repo_path="src/rayoptics/zemax/tests/US00583336-2-scaled.zmx",
        patent="US 583,336 Example 2 (P. Rudolph)",
        year=1897,
        focal=49.4, f_number=4.5,
        basis="the file's scaling of the patent example: its EFLY operand targets a 49.4 mm focal "
        "length and its system aperture is FNUM 4.5",
        notes="The file's note: 'Nearest modern Schott glasses chosen' (N-BAK1, N-BALF4). Its "
        "surface 1, a plane in air 4.5 mm in front of the lens, is a dummy and is left out. The "
        "film diagonal is twice the image surface's semi-diameter (22.61 mm), the 24-degree half "
        "field of the file.",
    ),
]

# Left out, and why (lenses/README.md says the same):
# - lentil 0005, Canon retrofocus 14 mm f/2.8 (US 4,310,222): lentil replaced the patent's
#   printed radius 58.28 of surface 3 by 40.28 (focal length 15.32 mm, not the patent's 14.2);
#   the printed value gives 14.28 mm, but then real chief rays put the patent's 114-degree field
#   on a 33 mm image circle (-12 % distortion) and none reaches the 35 mm frame's corner, so some
#   other value is wrong too, which the data alone cannot tell.
# - lentil 0003 (Petzval, OPTI 517 course notes): its data give 86.2 mm, not the 100 mm listed;
#   lentil's own note says it was never scaled to 100 mm.
# - lentil 0007 (Cooke Speed Panchro, GB 157,040) and 0008 (Nikon f/1.25, US 8,721,094): the data
#   give 25.96 mm and 53.35 mm, not the patents' 25.4 mm and 51.6 mm (lentil's own ray trace
#   agrees with the data, 25.96 and 52.85), and no single plausible misprint restores them.
# - lentil 0012, 0013 (not production-ready: lentil's notes say the data are wrong), 2001-2004
#   and 9991 (cylindrical, anamorphic elements realcam cannot represent), 9992-9994 (tests).
# - lenses-zmx: HoO-V2C18Ex27 (mirrors), zemax_double_gaussian (an ideal PARAXIAL surface),
#   US08427765-1 (a moulded glass L-TIM28_MOLD not in any catalogue, and no published focal
#   length in the file), lens1 and the Laikin wide angle (no published focal length or source
#   design data), ef35mm_f2.0.zmx (the DeepLens JSON's design, converted from that instead).

# ---------------------------------------------------------------------------------------------
# Numbers


def sig(value, digits=7):
    """`value` rounded to `digits` significant digits (float32 noise removed)."""
    if value == 0 or not math.isfinite(value):
        return value
    return float(f"{value:.{digits - 1}e}")


def decimals(value, places=4):
    return round(value, places) + 0.0


def toml_number(value):
    """A float as TOML reads it back exactly (Python's shortest round-trip form, e.g. 1.5,
    1e-05, -0.25)."""
    return repr(float(value))


def toml_string(text):
    out = ['"']
    for ch in text:
        if ch == '"':
            out.append('\\"')
        elif ch == "\\":
            out.append("\\\\")
        elif ch == "\n":
            out.append("\\n")
        elif ord(ch) < 0x20:
            out.append(f"\\u{ord(ch):04X}")
        else:
            out.append(ch)
    out.append('"')
    return "".join(out)


# ---------------------------------------------------------------------------------------------
# A surface in realcam's format: radius (None: a plane), thickness, glass (None: air; a name;
# or (n_d, V_d)), full diameter, stop flag, conic, aspheric [A2, A4, ...].


def surface(radius, thickness, glass, diameter, stop=False, conic=0.0, aspheric=()):
    return dict(
        radius=radius,
        thickness=thickness,
        glass=glass,
        diameter=diameter,
        stop=stop,
        conic=conic,
        aspheric=list(aspheric),
    )


def paraxial(surfaces):
    """Effective focal length and the paraxial height at each surface of a ray parallel to the
    axis at unit height (y–nu trace; an asphere's vertex curvature includes 2·A2)."""
    n_before = 1.0
    y, nu = 1.0, 0.0
    heights = []
    for i, s in enumerate(surfaces):
        c = 0.0 if s["radius"] is None else 1.0 / s["radius"]
        if s["aspheric"]:
            c += 2.0 * s["aspheric"][0]
        n_after = glass_index(s["glass"])
        heights.append(y)
        nu = nu - y * (n_after - n_before) * c
        if i + 1 < len(surfaces):
            y = y + s["thickness"] * nu / n_after
        n_before = n_after
    return -1.0 / nu, heights


def glass_index(glass):
    if glass is None:
        return 1.0
    if isinstance(glass, tuple):
        return glass[0]
    return CATALOGUE_N_D[glass]


# n_d of the catalogue glasses used here, only for this script's own paraxial stop sizing of
# the Zemax design (Schott data sheets); realcam itself reads them from its catalogue.
CATALOGUE_N_D = {"N-BAK1": 1.57250, "N-BALF4": 1.57956, "N-SK16": 1.62041, "F2": 1.62004}


def sag(s, r):
    """The surface's sag at height r (None where it is undefined)."""
    c = 0.0 if s["radius"] is None else 1.0 / s["radius"]
    arg = 1.0 - (1.0 + s["conic"]) * c * c * r * r
    if arg < 0.0:
        return None
    z = c * r * r / (1.0 + math.sqrt(arg))
    for i, a in enumerate(s["aspheric"]):
        z += a * r ** (2 * i + 2)
    return z


def sag_limit(s):
    """Largest height at which the base conic is defined (inf for planes and hyperbolas)."""
    if s["radius"] is None or 1.0 + s["conic"] <= 0.0:
        return math.inf
    return abs(s["radius"]) / math.sqrt(1.0 + s["conic"])


def trim_apertures(surfaces):
    """Clear apertures no surface can have: beyond where its conic is defined, or beyond the
    circle where it meets the next surface (an element's edge, or two elements touching at
    their rims). Each such aperture is reduced to that height, rounded down to a micrometre.
    Returns what was changed, for the notes."""
    changes = []

    def reduce(i, limit, why):
        new = math.floor(limit * 2000.0) / 1000.0  # a diameter, rounded down to 1 µm
        if surfaces[i]["diameter"] > new:
            changes.append(f"surface {i + 1}: clear diameter {surfaces[i]['diameter']:g} -> {new:g} mm ({why})")
            surfaces[i]["diameter"] = new

    for i, s in enumerate(surfaces):
        limit = sag_limit(s)
        if s["diameter"] / 2.0 >= limit:
            reduce(i, limit * (1.0 - 1e-6), "wider than its surface, which ends there")
    for i in range(len(surfaces) - 1):
        front, back = surfaces[i], surfaces[i + 1]
        semi = min(front["diameter"], back["diameter"]) / 2.0

        def gap(r):
            a, b = sag(front, r), sag(back, r)
            return front["thickness"] + b - a

        steps = 2000
        previous = 0.0
        for k in range(1, steps + 1):
            r = semi * k / steps
            if gap(r) < 0.0:
                lo, hi = previous, r
                for _ in range(60):
                    mid = 0.5 * (lo + hi)
                    if gap(mid) < 0.0:
                        hi = mid
                    else:
                        lo = mid
                what = "glass" if front["glass"] is not None else "air gap"
                why = f"surfaces {i + 1} and {i + 2} meet there: the {what} between them would be {gap(semi) * 1000:.1f} µm thick at the source's aperture"
                reduce(i, lo, why)
                reduce(i + 1, lo, why)
                break
            previous = r
    return changes


# ---------------------------------------------------------------------------------------------
# Readers


def read_deeplens(path):
    data = json.loads(path.read_text())
    surfaces = []
    plastics = set()
    for i, s in enumerate(data["surfaces"]):
        kind = s["type"]
        diameter = sig(2.0 * s["r"])
        thickness = decimals(s["d_next"])
        if kind in ("Aperture", "Stop"):
            if s.get("roc") or s.get("c"):
                raise SystemExit(f"{path}: surface {i + 1}: a curved stop")
            surfaces.append(surface(None, thickness, None, diameter, stop=True))
            continue
        if kind not in ("Spheric", "Aspheric", "Plane"):
            raise SystemExit(f"{path}: surface {i + 1}: type {kind} is not convertible")
        if "roc" in s:
            radius = None if s["roc"] == 0 else sig(s["roc"])
        else:
            radius = None if s["c"] == 0 else sig(1.0 / s["c"])
        material = s["mat2"]
        if material in (None, "air"):
            glass = None
        elif "/" in material:
            n_d, v_d = material.split("/")
            glass = (float(n_d), float(v_d))
        elif material in DEEPLENS_PLASTICS:
            glass = DEEPLENS_PLASTICS[material]
            plastics.add(material)
        elif material in DEEPLENS_GLASSES:
            glass = DEEPLENS_GLASSES[material]
        else:
            raise SystemExit(f"{path}: surface {i + 1}: unknown material {material!r}")
        conic = sig(s.get("k") or 0.0)
        aspheric = [sig(a) for a in (s.get("ai") or [])] if kind == "Aspheric" else []
        while aspheric and aspheric[-1] == 0.0:
            aspheric.pop()
        surfaces.append(surface(radius, thickness, glass, diameter, conic=conic, aspheric=aspheric))
    return data, surfaces, sorted(plastics)


LENTIL_PLANE = 9999.0


def read_lentil(entry, scale):
    surfaces = []
    for i, e in enumerate(entry["optical-elements-patent"]):
        if e["lens-geometry"] not in ("spherical", "aspherical"):
            raise SystemExit(f"lentil element {i + 1}: {e['lens-geometry']} is not rotationally symmetric")
        radius = None if abs(e["radius"]) >= LENTIL_PLANE else sig(e["radius"] * scale)
        thickness = sig(e["thickness"] * scale)
        diameter = sig(2.0 * e["housing-radius"] * scale)
        if e["material"].lower() == "iris":
            aperture = entry.get("max-fstop-aperture-radius", {}).get("unscaled")
            if aperture:
                diameter = sig(2.0 * aperture * scale)
            surfaces.append(surface(None, thickness, None, diameter, stop=True))
            continue
        if e["material"] == "air" or e["ior"] in (None, 1.0):
            glass = None
        else:
            glass = (sig(e["ior"]), sig(e["abbe"], 4))
        aspheric = []
        if e["lens-geometry"] == "aspherical":
            # [A4, A6, A8, A10] in the design's units; realcam's list starts at A2. Under a
            # scale s, A_2k scales by s^(1 - 2k).
            aspheric = [0.0] + [
                sig(a * scale ** (1 - 2 * (k + 2))) for k, a in enumerate(e["aspherical-equation"])
            ]
        surfaces.append(surface(radius, thickness, glass, diameter, aspheric=aspheric))
    return surfaces


def read_zmx(path):
    raw = path.read_bytes()
    if raw[:2] in (b"\xff\xfe", b"\xfe\xff"):
        text = raw.decode("utf-16")
    else:
        text = raw.decode("utf-8", errors="strict")
    system = {}
    blocks = []
    for line in text.splitlines():
        words = line.split()
        if not words:
            continue
        if words[0] == "SURF":
            blocks.append({"STOP": False})
            continue
        if not blocks:
            system[words[0]] = words[1:]
            continue
        block = blocks[-1]
        if words[0] == "STOP":
            block["STOP"] = True
        elif words[0] == "PARM":
            block.setdefault("PARM", {})[int(words[1])] = float(words[2])
        else:
            block[words[0]] = words[1:]
    if system.get("UNIT", ["MM"])[0] != "MM":
        raise SystemExit(f"{path}: only UNIT MM is converted here")
    lens = blocks[1:-1]  # the object and the image surface are not lens surfaces
    surfaces = []
    for b in lens:
        kind = b.get("TYPE", ["STANDARD"])[0]
        if kind not in ("STANDARD", "EVENASPH"):
            raise SystemExit(f"{path}: surface type {kind}")
        curvature = float(b["CURV"][0])
        glass = b["GLAS"][0] if "GLAS" in b else None
        aspheric = []
        if kind == "EVENASPH":
            parms = b.get("PARM", {})
            aspheric = [parms.get(i, 0.0) for i in range(1, 9)]
            while aspheric and aspheric[-1] == 0.0:
                aspheric.pop()
        surfaces.append(
            surface(
                None if curvature == 0 else 1.0 / curvature,
                float(b["DISZ"][0]),
                glass,
                2.0 * float(b["DIAM"][0]),
                stop=b["STOP"],
                conic=float(b.get("CONI", ["0"])[0]),
                aspheric=aspheric,
            )
        )
    image_semi = float(blocks[-1]["DIAM"][0])
    return system, surfaces, image_semi


# ---------------------------------------------------------------------------------------------
# Writing


def write_toml(design, surfaces):
    lines = [
        "# realcam lens file: lengths in mm, surfaces front (scene) to back (film); the format",
        "# is described in lenses/README.md.",
        "# Generated by lenses/tools/make_library.py from the source named below: edit the",
        "# script and regenerate rather than editing this file.",
        'format = "realcam-lens/1"',
        f"name = {toml_string(design['name'])}",
        f"title = {toml_string(design['title'])}",
        f"source = {toml_string(design['source'])}",
        f"licence = {toml_string(design['licence'])}",
    ]
    if design.get("year"):
        lines.append(f"year = {design['year']}")
    if design["focal"] is not None:
        lines.append(f"focal_length_mm = {toml_number(design['focal'])}")
    if design["f_number"] is not None:
        lines.append(f"f_number = {toml_number(design['f_number'])}")
    lines.append(f"film_diagonal_mm = {toml_number(design['film_diagonal_mm'])}")
    lines.append(f"notes = {toml_string(design['notes_text'])}")
    lines.append("surfaces = [")
    for s in surfaces:
        fields = []
        if not (s["stop"] and s["radius"] is None):
            fields.append('radius = "inf"' if s["radius"] is None else f"radius = {toml_number(s['radius'])}")
        if s["stop"]:
            fields.append("stop = true")
        fields.append(f"thickness = {toml_number(s['thickness'])}")
        glass = s["glass"]
        if isinstance(glass, tuple):
            fields.append(f"glass = {{ n_d = {toml_number(glass[0])}, v_d = {toml_number(glass[1])} }}")
        elif glass is not None:
            fields.append(f"glass = {toml_string(glass)}")
        fields.append(f"diameter = {toml_number(s['diameter'])}")
        if s["conic"]:
            fields.append(f"conic = {toml_number(s['conic'])}")
        if s["aspheric"]:
            fields.append("aspheric = [" + ", ".join(toml_number(a) for a in s["aspheric"]) + "]")
        lines.append("  { " + ", ".join(fields) + " },")
    lines.append("]")
    return "\n".join(lines) + "\n"


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    default_shared = next(
        (p / "shared" for p in (REPO.parent, REPO.parent.parent) if (p / "shared" / "lenses-json").is_dir()),
        REPO.parent / "shared",
    )
    parser.add_argument("--shared", type=Path, default=default_shared)
    parser.add_argument("--out", type=Path, default=REPO / "lenses")
    parser.add_argument("--check", action="store_true")
    args = parser.parse_args()
    if not (args.shared / "lenses-json").is_dir():
        sys.exit(f"{args.shared}: not the shared data folder (no lenses-json/ in it); give --shared DIR")
    outputs = {}
    for design in DESIGNS:
        surfaces = build(design, args.shared)
        outputs[f"{design['name']}.toml"] = write_toml(design, surfaces)
        published = "-" if design["focal"] is None else f"{design['focal']:g}"
        print(f"{design['name']:34} paraxial EFL {design['paraxial_efl']:9.3f} mm   published {published}")
    for licence, (source, target) in LICENCES.items():
        outputs[f"licenses/{target}"] = (args.shared / source).read_text()
    write_outputs(outputs, args.out, args.check, "lenses/tools/make_library.py")


def write_outputs(outputs, out, check, tool):
    """Writes each `relative path: text` of `outputs` under `out`; with `check`, writes nothing
    and exits with the list of files that differ from `outputs` (naming `tool` to run)."""
    stale = []
    for rel, text in outputs.items():
        path = out / rel
        if check:
            if not path.exists() or path.read_text() != text:
                stale.append(rel)
            continue
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    if stale:
        sys.exit(f"out of date (run {tool}): " + ", ".join(stale))
    print(f"{'checked' if check else 'wrote'} {len(outputs)} files in {out}")


def build(design, shared):
    """The surfaces and the filled-in design record (source, licence, notes, film diagonal)."""
    notes = []
    if "deeplens" in design:
        path = shared / "lenses-json" / "deeplens" / Path(design["deeplens"]).name
        data, surfaces, plastics = read_deeplens(path)
        design["source"] = f"{design['patent']}; {DEEPLENS} : datasets/lenses/{design['deeplens']}"
        design["licence"] = "Apache-2.0"
        design["film_diagonal_mm"] = sig(2.0 * data["r_sensor"])
        notes.append(
            "Converted from DeepLens's JSON by lenses/tools/make_library.py: clear diameters are "
            "twice DeepLens's semi-apertures r; DeepLens's float32 noise is rounded off (7 "
            "significant digits; thicknesses to 0.1 µm); glasses given as n_d/V_d are model "
            "glasses; the film diagonal is twice DeepLens's r_sensor (its image-circle radius)."
        )
        if plastics:
            values = ", ".join(f"{p} {DEEPLENS_PLASTICS[p][0]}/{DEEPLENS_PLASTICS[p][1]}" for p in plastics)
            notes.append(
                f"Plastics as model glasses with DeepLens's own n_d/V_d (deeplens/optics/"
                f"materials_data.json, MATERIAL_TABLE): {values}."
            )
        source_stop_note = "DeepLens's stop"
    elif "lentil" in design:
        database = json.loads((shared / "lenses-json" / "lentil" / "lenses.json").read_text())
        entry = database[design["lentil"]]
        scale = design.get("scale", 1.0)
        raw = entry["optical-elements-patent"]
        for index, field, old, new, why in design.get("fixes", []):
            if raw[index][field] != old:
                raise SystemExit(f"lentil {design['lentil']}: element {index + 1} {field} is not {old}")
            raw[index][field] = new
            notes.append(why[0].upper() + why[1:] + ".")
        surfaces = read_lentil(entry, scale)
        patent = entry.get("patent-number") or "patent number not recorded by lentil"
        design["source"] = f"{patent}; {LENTIL}, id {design['lentil']} (optical-elements-patent)"
        design["licence"] = "MIT"
        design["film_diagonal_mm"] = FULL_FRAME_DIAGONAL_MM
        notes.append(
            f"Converted from lentil's lenses.json (id {design['lentil']}) by lenses/tools/"
            "make_library.py: clear diameters are twice lentil's housing radii; the element of "
            "material 'iris' is the stop; ior/abbe are model glasses; lentil's placeholder radii "
            "(9999 and more) are planes. lentil gives no image format: the film diagonal is the "
            "full frame's, 43.27 mm (36 x 24 mm)."
        )
        if scale != 1.0:
            notes.append(f"Every length is the patent example's times {scale:g} (it is normalised to f = 1).")
        source_stop_note = "lentil's max-fstop-aperture-radius (the iris radius its ray trace found unclipped)"
    else:
        system, surfaces, image_semi = read_zmx(shared / "lenses-zmx" / design["zmx"])
        dummy = surfaces[0]
        if dummy["radius"] is None and dummy["glass"] is None and not dummy["stop"]:
            surfaces = surfaces[1:]
        design["source"] = f"{design['patent']}; {RAY_OPTICS} : {design['repo_path']}"
        design["licence"] = "BSD-3-Clause"
        design["film_diagonal_mm"] = sig(2.0 * image_semi)
        notes.append(
            "Converted from the Zemax file by lenses/tools/make_library.py: clear diameters are "
            "twice its DIAM semi-diameters; catalogue glasses by name."
        )
        source_stop_note = "the file's stop DIAM"

    changes = trim_apertures(surfaces)
    if changes:
        notes.append("Clear apertures the source gives too wide: " + "; ".join(changes) + ".")

    stop = next(i for i, s in enumerate(surfaces) if s["stop"])
    efl, heights = paraxial(surfaces)
    source_f_number = efl * heights[stop] / surfaces[stop]["diameter"]
    if design["f_number"] is not None:
        diameter = sig(efl / design["f_number"] * heights[stop])
        ratio = surfaces[stop]["diameter"] / diameter
        if not 0.85 < ratio < 1.15:
            raise SystemExit(
                f"{design['name']}: the source's stop gives f/{source_f_number:.3f}, too far from "
                f"the published f/{design['f_number']} to be the same aperture: check the conversion"
            )
        notes.append(
            f"The stop is where the source puts it, sized for the published f/{design['f_number']:g} "
            f"(paraxial EFL / entrance-pupil diameter, as a patent's or a Zemax file's f-number): "
            f"diameter {diameter:g} mm; {source_stop_note}, {surfaces[stop]['diameter']:g} mm, "
            f"would give f/{source_f_number:.3f}."
        )
        surfaces[stop]["diameter"] = diameter
        if trim_apertures(surfaces):
            raise SystemExit(f"{design['name']}: the stop sized for f/{design['f_number']} crosses a neighbouring surface")
    else:
        notes.append(
            f"No published f-number: the stop keeps {source_stop_note}, "
            f"{surfaces[stop]['diameter']:g} mm (paraxial f/{source_f_number:.3f})."
        )
    if design.get("notes"):
        notes.append(design["notes"])
    focal = design["focal"]
    published = f"Published figures: {design.get('basis', MARKETED)}"
    notes.insert(0, published + ".")
    design["notes_text"] = " ".join(notes)
    design["paraxial_efl"] = efl
    return surfaces

if __name__ == "__main__":
    main()
