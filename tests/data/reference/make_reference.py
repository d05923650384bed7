#!/usr/bin/env python3
"""Independent reference numbers for realcam's Zemax import and aspheric tracing.

Command (re-runnable; writes /work/refs/reference.json and prints a summary):

    cd /work/refs && ./venv/bin/python make_reference.py

The venv holds rayoptics (PyPI) and its dependencies; see README.md for the exact
versions.  Program that produces the numbers: ray-optics (rayoptics) by Michael J.
Hayford, with its glass library opticalglass.  Inputs (read-only):
/work/shared/lenses-zmx/*.zmx and /work/shared/lenses-json/deeplens/*.json.

Conventions used in every output entry (stated once here, repeated in the JSON):
  * all lengths in millimetres (inch files are converted: 1 in = 25.4 mm exactly);
  * wavelength 587.5618 nm (d line) for everything, forced as rayoptics' reference
    wavelength whatever the file says (the as-read value is recorded too);
  * frame: origin at the vertex of surface 1 (the first surface after the object
    surface, even if it is a dummy plane), +z along the optical axis toward the
    image (for the mirror file: toward the first mirror);
  * direction vectors are unit vectors (direction cosines) in that frame;
  * refractive indices are relative to air; air is exactly 1.0 (as in rayoptics and
    OpticStudio).
"""
import datetime
import hashlib
import json
import math
import platform
import sys
import warnings
from pathlib import Path

import numpy as np

warnings.filterwarnings("ignore")

import opticalglass  # noqa: E402
import rayoptics  # noqa: E402
from rayoptics.environment import OpticalModel, open_model  # noqa: E402
from rayoptics.elem import profiles  # noqa: E402
from rayoptics.raytr import raytrace as rt  # noqa: E402
from rayoptics.raytr.opticalspec import PupilSpec, FieldSpec, WvlSpec  # noqa: E402
import rayoptics.optical.model_constants as mc  # noqa: E402
from opticalglass import modelglass as mg  # noqa: E402
from opticalglass import opticalmedium as om  # noqa: E402

HERE = Path(__file__).resolve().parent
ZMX_DIR = Path("/work/shared/lenses-zmx")
JSON_DIR = Path("/work/shared/lenses-json/deeplens")
PATCH_DIR = HERE / "patched"
OUT = HERE / "reference.json"

WVL_F, WVL_D, WVL_C = 486.1327, 587.5618, 656.2725
WVLS = [WVL_F, WVL_D, WVL_C]
INCH = 25.4

# DeepLens material table (singer-yang/DeepLens, deeplens/optics/materials_data.json,
# "MATERIAL_TABLE": [n_d, V_d]); only the names used by the lenses traced here.
DEEPLENS_MATERIALS = {
    "pmma": (1.4918, 57.44),
    "coc": (1.5337, 56.22),
    "polycarb": (1.5855, 29.91),
    "polystyr": (1.5904, 30.87),
    "okp4": (1.6328, 23.34),
}


# ----------------------------------------------------------------------------
# small helpers
# ----------------------------------------------------------------------------
def sha256(path):
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def f(x):
    """float for JSON (numpy -> python), full precision."""
    return None if x is None else float(x)


def vec(v, scale=1.0):
    return [float(c) * scale for c in v]


def read_text(path):
    raw = Path(path).read_bytes()
    if raw[:2] in (b"\xff\xfe", b"\xfe\xff"):
        return raw.decode("utf-16"), "utf-16 (BOM)"
    try:
        return raw.decode("utf-8"), "utf-8"
    except UnicodeDecodeError:
        return raw.decode("iso-8859-1"), "iso-8859-1"


def parse_zmx(text):
    """Minimal independent parse of the bits the reference needs to *report*
    (units, stop, apertures, glass flags); the optics come from rayoptics."""
    info = {"unit": "MM", "surfaces": {}, "aperture": None}
    cur = None
    for line in text.splitlines():
        s = line.strip()
        if not s:
            continue
        tok = s.split()
        cmd = tok[0]
        if cmd == "UNIT":
            info["unit"] = tok[1]
        elif cmd in ("FNUM", "ENPD", "OBNA", "FLOA"):
            info["aperture"] = [cmd] + tok[1:2]
        elif cmd == "SURF":
            cur = int(tok[1])
            info["surfaces"][cur] = {"type": "STANDARD"}
        elif cur is not None:
            d = info["surfaces"][cur]
            if cmd == "TYPE":
                d["type"] = tok[1]
            elif cmd == "STOP":
                d["stop"] = True
            elif cmd == "DIAM":
                d["diam"] = float(tok[1])
                d["diam_flag"] = int(tok[2]) if len(tok) > 2 else None
            elif cmd == "CLAP":
                d["clap"] = [float(tok[1]), float(tok[2])]
            elif cmd == "FLAP":
                d["flap"] = [float(tok[1]), float(tok[2])]
            elif cmd == "MEMA":
                d["mema"] = float(tok[1])
            elif cmd == "GLAS":
                d["glas"] = tok[1]
                d["glas_flag"] = int(tok[2]) if len(tok) > 2 else None
                if len(tok) > 5:
                    d["glas_nd_vd"] = [float(tok[4]), float(tok[5])]
    return info


# ----------------------------------------------------------------------------
# model preparation
# ----------------------------------------------------------------------------
def wavelengths_as_read(opm):
    wv = opm["optical_spec"]["wvls"]
    return {
        "wavelengths_nm": [float(w) for w in wv.wavelengths],
        "reference_index": int(wv.reference_wvl),
        "reference_wavelength_nm": float(wv.wavelengths[wv.reference_wvl]),
    }


def force_d_line(opm):
    opm["optical_spec"]["wvls"] = WvlSpec([(WVL_F, 1.0), (WVL_D, 1.0), (WVL_C, 1.0)], ref_wl=1)
    opm.update_model()
    wv = opm["optical_spec"]["wvls"]
    assert wv.wavelengths[wv.reference_wvl] == WVL_D


def paraxial_raw(opm):
    pm = opm["parax_model"]
    pd = opm["analysis_results"]["parax_data"]
    return pd.ax_ray, pd.pr_ray, pd.fod


def set_epd(opm, epd):
    opm["optical_spec"]["pupil"] = PupilSpec(opm["optical_spec"], key=("object", "epd"), value=epd)
    opm.update_model()


def epd_for_stop_semi_diameter(opm, stop_sd):
    """Float-by-stop-size: the EPD whose paraxial marginal ray fills the stop."""
    ax, pr, fod = paraxial_raw(opm)
    stop = opm["seq_model"].stop_surface
    return 2.0 * fod.enp_radius * stop_sd / abs(ax[stop][mc.ht])


def yu_trace(opm, y1, u0):
    """Paraxial y-u trace that starts AT surface 1 (height y1, slope u0 in object
    space), with rayoptics' own surface powers, indices and z_dir signs (the same
    refraction formula as rayoptics.parax.firstorder.paraxial_trace).  rayoptics'
    own chief ray starts on an object 1e10 lens units away, which loses ~1e-6
    (relative) in the pupil positions through cancellation; this does not."""
    sm = opm["seq_model"]
    path = list(sm.path(wl=WVL_D))
    n_before = path[0][mc.Indx] * (1 if path[0][mc.Zdir] > 0 else -1)
    y, u = y1, u0
    out = {}
    for i in range(1, len(sm.ifcs)):
        ifc, gap, _, rndx, z_dir = path[i]
        if i > 1:
            y = y + sm.gaps[i - 1].thi * u
        if ifc.interact_mode not in ("dummy", "phantom"):
            n_after = rndx if z_dir > 0 else -rndx
            u = (n_before * u - y * ifc.optical_power) / n_after
            n_before = n_after
        out[i] = (y, u)
    return out


def pupils(opm, epd):
    """Entrance pupil z (from surface 1), exit pupil z (from the last lens surface)
    and exit pupil diameter, object at infinity."""
    sm = opm["seq_model"]
    stop = sm.stop_surface
    k = len(sm.ifcs) - 2
    a = yu_trace(opm, 1.0, 0.0)
    b = yu_trace(opm, 0.0, 1.0)
    ya, yb = a[stop][0], b[stop][0]
    # chief ray: y1 = yb, u0 = -ya  -> height 0 at the stop
    chief = yu_trace(opm, yb, -ya)
    z_ep = -yb / -ya
    yk, uk = chief[k]
    z_xp = -yk / uk
    m = yu_trace(opm, epd / 2.0, 0.0)
    r_xp = abs(m[k][0] + m[k][1] * z_xp)
    return z_ep, z_xp, 2.0 * r_xp


def paraxial_data(opm, scale):
    sm = opm["seq_model"]
    ax, pr, fod = paraxial_raw(opm)
    k = len(sm.ifcs) - 2  # last interface before the image surface
    stop = sm.stop_surface
    epd = 2.0 * fod.enp_radius
    if fod.obj_dist > 1e9:
        z_ep, z_xp, d_xp = pupils(opm, epd)
        pupil_src = "own y-u trace from surface 1 with rayoptics' surface powers (see yu_trace)"
    else:  # finite conjugate: rayoptics' chief ray is fine (no 1e10 object distance)
        z_ep = fod.enp_dist
        z_xp = -pr[k][mc.ht] / pr[k][mc.slp]
        d_xp = 2.0 * abs(ax[k][mc.ht] + ax[k][mc.slp] * z_xp)
        pupil_src = "rayoptics' paraxial chief and marginal rays"
    r_xp = d_xp / 2.0
    first_refr = next(i for i in range(1, k + 1)
                      if sm.ifcs[i].interact_mode == "reflect" or type(sm.ifcs[i]).__name__ == "ThinLens"
                      or sm.central_rndx(i) != sm.central_rndx(i - 1))
    return {
        "z_first_optical_surface": f(sm.gbl_tfrms[first_refr][1][2] * scale),
        "first_optical_surface": first_refr,
        "efl": f(fod.efl * scale),
        "bfl": f(fod.bfl * scale),
        "bfl_definition": "z of the paraxial back focal point minus z of the last lens surface vertex (surface %d)" % k,
        "ffd": f(fod.ffl * scale),
        "ffd_definition": "z of the paraxial front focal point minus z of surface 1 (negative = in front)",
        "pupil_positions_from": pupil_src,
        "entrance_pupil_z": f(z_ep * scale),
        "entrance_pupil_z_definition": "relative to the vertex of surface 1",
        "epd": f(epd * scale),
        "exit_pupil_z": f(z_xp * scale),
        "exit_pupil_z_definition": "relative to the vertex of the last lens surface (surface %d): -y_chief/u_chief after that surface" % k,
        "exit_pupil_diameter": f(2.0 * r_xp * scale),
        "f_number": f(fod.efl / epd),
        "paraxial_image_distance_from_last_surface": f(fod.img_dist * scale),
        "principal_plane_front_z": f(fod.pp1 * scale),
        "principal_plane_rear_from_last_surface": f(fod.ppk * scale),
        "object_distance": f(fod.obj_dist * scale) if fod.obj_dist < 1e9 else "infinite",
        "stop_surface": stop,
        "stop_paraxial_marginal_semi_height": f(abs(ax[stop][mc.ht]) * scale),
        "rayoptics_fod_as_printed": {
            "efl": f(fod.efl * scale), "ffl": f(fod.ffl * scale), "bfl": f(fod.bfl * scale),
            "enp_dist": f(fod.enp_dist * scale), "enp_radius": f(fod.enp_radius * scale),
            "exp_dist": f(fod.exp_dist * scale), "exp_radius": f(fod.exp_radius * scale),
            "fno_working": f(fod.fno), "img_dist": f(fod.img_dist * scale),
            "note": "rayoptics' exp_dist is measured from the last interface but computed with the paraxial image distance in place of the last thickness; it equals exit_pupil_z only when the image surface is at the paraxial focus",
        },
    }


def paraxial_with_r2_term(opm, scale):
    """Paraxial data with the r^2 polynomial term folded into the curvature
    (c_parax = c + 2*a2).  Returns None when no surface has a2 != 0."""
    sm = opm["seq_model"]
    touched = []
    for ifc in sm.ifcs:
        p = getattr(ifc, "profile", None)
        if isinstance(p, profiles.EvenPolynomial) and p.coefs and p.coefs[0] != 0.0:
            touched.append((p, p.cv, list(p.coefs)))
    if not touched:
        return None
    for p, cv, coefs in touched:
        p.cv = cv + 2.0 * coefs[0]
        p.coefs[0] = 0.0
    opm.update_model()
    out = paraxial_data(opm, scale)
    out["computed_on"] = ("rayoptics model with c -> c + 2*a2 and a2 -> 0 on surfaces %s (paraxial only; the real-ray trace "
                          "uses the unmodified surfaces)" % [sm.ifcs.index(ifc) for ifc in sm.ifcs
                                                             if any(ifc is not None and getattr(ifc, 'profile', None) is t[0] for t in touched)])
    for p, cv, coefs in touched:
        p.cv = cv
        p.coefs = coefs
    opm.update_model()
    return out


def glass_table(opm):
    sm = opm["seq_model"]
    rows = []
    for i, g in enumerate(sm.gaps):
        m = g.medium
        if isinstance(m, om.Air) or m.name().lower() == "air":
            continue
        n = [float(m.rindex(w)) for w in WVLS]
        rows.append({
            "after_surface": i,
            "name": m.name(),
            "catalog": m.catalog_name(),
            "rayoptics_class": type(m).__name__,
            "n_F_486.1327": n[0], "n_d_587.5618": n[1], "n_C_656.2725": n[2],
            "V_from_these": (n[1] - 1.0) / (n[0] - n[2]),
        })
    return rows


def surface_table(opm, scale, file_surfs=None):
    sm = opm["seq_model"]
    rows = []
    for i, ifc in enumerate(sm.ifcs):
        if i == 0:
            continue
        row = {"surface": i, "interact_mode": ifc.interact_mode, "rayoptics_class": type(ifc).__name__}
        p = getattr(ifc, "profile", None)
        if p is not None:
            row["profile"] = type(p).__name__
            row["c"] = f(p.cv / scale)
            if hasattr(p, "cc"):
                row["k"] = f(p.cc)
            if isinstance(p, profiles.EvenPolynomial):
                # coefs[j] multiplies r^(2j+2); convert to mm: a * scale^(1-(2j+2))
                row["poly_coefs_r2_first"] = [f(a * scale ** (1 - (2 * j + 2))) for j, a in enumerate(p.coefs)]
        if type(ifc).__name__ == "ThinLens":
            row["thin_lens_power"] = f(ifc.optical_power / scale)
        row["z_vertex"] = f(sm.gbl_tfrms[i][1][2] * scale)
        if i < len(sm.gaps):
            row["thickness_after"] = f(sm.gaps[i].thi * scale)
            row["medium_after"] = sm.gaps[i].medium.name()
        if file_surfs is not None and i in file_surfs:
            fs = file_surfs[i]
            for key in ("type", "diam", "diam_flag", "clap", "flap", "mema", "glas", "glas_flag", "glas_nd_vd"):
                if key in fs:
                    v = fs[key]
                    if key in ("diam", "mema"):
                        v = v * scale
                    elif key in ("clap", "flap"):
                        v = [x * scale for x in v]
                    row["file_" + key] = v
        rows.append(row)
    return rows


# ----------------------------------------------------------------------------
# real rays
# ----------------------------------------------------------------------------
def trace_from_frame1(opm, pt0, dir0, wvl=WVL_D):
    """Trace a ray given in the surface-1 frame (native units of the model).

    rayoptics' trace_raw starts in the object-surface frame; the first path entry's
    transform is replaced by the identity so the starting point is read directly
    in the coordinates of surface 1.  Returns a list of (global point, global
    direction after the surface, surface index)."""
    sm = opm["seq_model"]
    path = [list(p) for p in sm.path(wl=wvl)]
    path[0][mc.Tfrm] = (np.identity(3), np.zeros(3))
    ray, _, _ = rt.trace_raw(iter(path), np.array(pt0, float), np.array(dir0, float), wvl,
                             intersect_obj=False, eps=1e-14)
    out = []
    for i, seg in enumerate(ray):
        if i == 0:
            out.append((np.array(pt0, float), np.array(dir0, float), 0))
            continue
        r, t = sm.gbl_tfrms[i]
        out.append((r.dot(seg[mc.p]) + t, r.dot(seg[mc.d]), i))
    return out


def stop_hit(opm, pt0, dir0):
    sm = opm["seq_model"]
    s = sm.stop_surface
    hits = trace_from_frame1(opm, pt0, dir0)
    r, t = sm.gbl_tfrms[s]
    local = r.T.dot(hits[s][0] - t)
    return local[:2]


def field_direction(theta_x_deg, theta_y_deg):
    d = np.array([math.tan(math.radians(theta_x_deg)), math.tan(math.radians(theta_y_deg)), 1.0])
    return d / np.linalg.norm(d)


def aim_ray(opm, d, target_xy, z_start, guess_xy):
    """Real-ray aiming: find the start point (x0, y0, z_start) of a ray with fixed
    direction d whose intersection with the stop surface is target_xy.

    Damped Newton (finite-difference Jacobian) with continuation: the target is
    approached from the stop centre in steps, each solve starting from the last, so
    that wide-angle lenses whose paraxial pupil guess is poor still converge."""
    target_xy = np.asarray(target_xy, float)
    scale = max(1.0, float(np.linalg.norm(target_xy)))

    def resid(x):
        return stop_hit(opm, np.array([x[0], x[1], z_start]), d) - tgt

    x = np.array(guess_xy, float)
    for frac in (0.0, 0.25, 0.5, 0.75, 1.0):
        tgt = frac * target_xy
        r = resid(x)
        for _ in range(60):
            if np.max(np.abs(r)) < 1e-13 * scale:
                break
            h = 1e-6 * scale
            J = np.zeros((2, 2))
            for j in range(2):
                dx = np.zeros(2)
                dx[j] = h
                J[:, j] = (resid(x + dx) - resid(x - dx)) / (2 * h)
            step = np.linalg.solve(J, r)
            lam = 1.0
            while True:
                try:
                    r_new = resid(x - lam * step)
                    if np.max(np.abs(r_new)) < np.max(np.abs(r)) or lam < 1e-3:
                        break
                except Exception:
                    if lam < 1e-3:
                        raise
                lam *= 0.5
            x = x - lam * step
            r = r_new
    p0 = np.array([x[0], x[1], z_start])
    return p0, float(np.max(np.abs(resid(x))))


def aperture_check(opm, hits, scale, apertures):
    """apertures: {surface: (semi_diameter_native, kind)}.  Returns exceedances."""
    sm = opm["seq_model"]
    bad = []
    for pt, _, i in hits[1:]:
        if i not in apertures:
            continue
        r, t = sm.gbl_tfrms[i]
        loc = r.T.dot(pt - t)
        rho = math.hypot(loc[0], loc[1])
        sd, kind = apertures[i]
        if rho > sd * (1 + 1e-9):
            bad.append({"surface": i, "ray_height": rho * scale, "semi_diameter": sd * scale, "aperture_kind": kind})
    return bad


DEFAULT_RAYS = [
    # (label, field fraction, field azimuth deg (0 = +y), pupil px, py as fractions of the stop radius)
    ("axial_py0.5", 0.0, 0.0, 0.0, 0.5),
    ("axial_py0.9", 0.0, 0.0, 0.0, 0.9),
    ("axial_skew", 0.0, 0.0, 0.6, -0.45),
    ("f0.5_chief", 0.5, 0.0, 0.0, 0.0),
    ("f0.5_upper", 0.5, 0.0, 0.0, 0.8),
    ("f0.5_lower", 0.5, 0.0, 0.0, -0.8),
    ("f0.5_sagittal", 0.5, 0.0, 0.8, 0.0),
    ("f0.85_chief", 0.85, 0.0, 0.0, 0.0),
    ("f0.85_upper", 0.85, 0.0, 0.0, 0.6),
    ("f0.85_skew", 0.85, 0.0, 0.5, -0.5),
    ("f0.7_diag_skew", 0.7, 45.0, 0.3, 0.4),
]


def make_rays(opm, scale, max_field_deg, apertures, z_start_mm=-5.0, ray_defs=DEFAULT_RAYS, self_check=True):
    sm = opm["seq_model"]
    ax, pr, fod = paraxial_raw(opm)
    stop = sm.stop_surface
    r_stop = abs(ax[stop][mc.ht])
    r_ep = fod.enp_radius
    z_ep = fod.enp_dist
    z_start = z_start_mm / scale
    k = len(sm.ifcs) - 2
    img = len(sm.ifcs) - 1
    rays = []
    for label, ffrac, az, px, py in ray_defs:
        theta = ffrac * max_field_deg
        tx = theta * math.sin(math.radians(az))
        ty = theta * math.cos(math.radians(az))
        d = field_direction(tx, ty)
        entry = {"label": label, "field_angle_deg": {"x": tx, "y": ty}, "requested_pupil_normalized": [px, py]}
        history = []
        factor = 1.0
        for attempt in range(25):
            qx, qy = px * factor, py * factor
            target = np.array([qx * r_stop, qy * r_stop])
            # guess: the ray through the centre of the paraxial entrance pupil; aim_ray first
            # solves the real chief ray from it, then walks out to the target
            ep = np.array([0.0, 0.0, z_ep])
            guess = (ep + (z_start - ep[2]) / d[2] * d)[:2]
            try:
                p0, resid = aim_ray(opm, d, target, z_start, guess)
                hits = trace_from_frame1(opm, p0, d)
                bad = aperture_check(opm, hits, scale, apertures)
                problem = bad if bad else None
            except Exception as e:  # TIR / missed surface / singular aiming
                problem = "%s at surface %s" % (type(e).__name__, getattr(e, "surf", "?"))
            if problem is None:
                break
            history.append({"pupil_normalized": [qx, qy], "problem": problem})
            factor *= 0.9
        else:
            entry["error"] = "no unvignetted ray found"
            entry["attempts"] = history
            rays.append(entry)
            continue
        entry["stop_target_normalized"] = [qx, qy]
        entry["stop_target"] = vec(target, scale)
        if history:
            entry["pupil_reduced_because"] = history
        if hits[1][0][2] < z_start or (hits[1][0] - p0).dot(d) < 0:
            entry["warning"] = "start plane is not in front of surface 1 for this ray"
        entry["start_point"] = vec(p0, scale)
        entry["start_direction"] = vec(d)
        entry["aim_residual"] = resid * scale
        entry["stop_hit"] = vec(hits[stop][0], scale)
        entry["last_lens_surface"] = {"surface": k, "point": vec(hits[k][0], scale), "direction_after": vec(hits[k][1])}
        entry["image_surface"] = {"surface": img, "point": vec(hits[img][0], scale)}
        entry["all_surfaces"] = [{"surface": i, "point": vec(p, scale), "direction_after": vec(dd)} for p, dd, i in hits[1:]]
        entry["passes_all_listed_apertures"] = True
        if self_check:
            chk = own_trace(opm, p0, d)
            if chk is not None:
                dp = max(np.max(np.abs(a[0] - b[0])) for a, b in zip(chk, hits[1:])) * scale
                dd = max(np.max(np.abs(a[1] - b[1])) for a, b in zip(chk, hits[1:]))
                entry["independent_numpy_check_max_abs_diff"] = {"point_mm": float(dp), "direction": float(dd)}
        rays.append(entry)
    return rays


def real_ray_efl(opm, scale, h_frac=1e-5):
    """EFL from a nearly paraxial real ray parallel to the axis: f = -h / tan(u')."""
    ax, pr, fod = paraxial_raw(opm)
    sm = opm["seq_model"]
    h = h_frac * fod.enp_radius
    hits = trace_from_frame1(opm, np.array([0.0, h, -1.0 / scale]), np.array([0.0, 0.0, 1.0]))
    k = len(sm.ifcs) - 2
    d = hits[k][1]
    return f(-h / (d[1] / d[2]) * scale), h * scale


# ----------------------------------------------------------------------------
# an independent (numpy) re-trace of centred refracting systems, used only to check
# that rayoptics was driven correctly (frames, indices, aspheric coefficient order)
# ----------------------------------------------------------------------------
def own_trace(opm, p0, d0, wvl=WVL_D):
    sm = opm["seq_model"]
    if any(ifc.interact_mode == "reflect" or type(ifc).__name__ == "ThinLens" for ifc in sm.ifcs):
        return None
    path = list(sm.path(wl=wvl))
    n_before = path[0][mc.Indx]
    p = np.array(p0, float)
    d = np.array(d0, float)
    out = []
    for i in range(1, len(sm.ifcs)):
        ifc = sm.ifcs[i]
        zv = sm.gbl_tfrms[i][1][2]
        prof = ifc.profile
        cv = prof.cv
        cc = getattr(prof, "cc", 0.0)
        coefs = list(prof.coefs) if isinstance(prof, profiles.EvenPolynomial) else []

        def sag_grad(x, y):
            r2 = x * x + y * y
            s = math.sqrt(1.0 - (1.0 + cc) * cv * cv * r2)
            z = cv * r2 / (1.0 + s)
            dz = cv / (2.0 * s) if cv != 0.0 else 0.0
            rp = r2
            for j, a in enumerate(coefs):
                z += a * rp
                dz += (j + 1) * a * (rp / r2 if r2 > 0 else (1.0 if j == 0 else 0.0))
                rp *= r2
            return z, dz

        # start from the closed-form base-conic intersection (local z = z - zv)
        pz = p[2] - zv
        A = cv * (d[0] ** 2 + d[1] ** 2 + (1.0 + cc) * d[2] ** 2)
        b = cv * (p[0] * d[0] + p[1] * d[1] + (1.0 + cc) * pz * d[2]) - d[2]
        C = cv * (p[0] ** 2 + p[1] ** 2 + (1.0 + cc) * pz ** 2) - 2.0 * pz
        t = C / (-b + math.sqrt(b * b - A * C))
        for _ in range(100):
            q = p + t * d
            z, dz = sag_grad(q[0], q[1])
            F = q[2] - zv - z
            # dF/dt = d_z - dz/dr2 * 2 (x dx + y dy)
            dF = d[2] - dz * 2.0 * (q[0] * d[0] + q[1] * d[1])
            step = F / dF
            t -= step
            if abs(step) < 1e-15 * max(1.0, abs(t)):
                break
        q = p + t * d
        z, dz = sag_grad(q[0], q[1])
        nrm = np.array([-2.0 * q[0] * dz, -2.0 * q[1] * dz, 1.0])
        nrm /= np.linalg.norm(nrm)
        n_after = path[i][mc.Indx]
        if ifc.interact_mode in ("dummy", "phantom") or n_after == n_before:
            dn = d
        else:
            mu = n_before / n_after
            ci = d.dot(nrm)
            if ci < 0:
                nrm = -nrm
                ci = -ci
            kk = 1.0 - mu * mu * (1.0 - ci * ci)
            dn = mu * d + (math.sqrt(kk) - mu * ci) * nrm
        out.append((q, dn))
        p, d, n_before = q, dn, n_after
    return out


def paraxial_surface_diagnostic(opm):
    """How rayoptics' ThinLens (its stand-in for a Zemax PARAXIAL surface) bends real
    rays: rays from one object point in the front focal plane should leave an ideal
    lens parallel (tan(u') = tan(u) - y/f).  Reports the directions after surface 1."""
    sm = opm["seq_model"]
    tl = sm.ifcs[1]
    f_len = 1.0 / tl.optical_power
    z_obj = -sm.gaps[0].thi
    out = {"focal_length": f_len, "object_plane_z": z_obj, "hologram_reference_wavelength_nm": tl.phase_element.ref_wl,
           "cases": []}
    for y_obj in (0.0, 19.0, 27.0):
        dirs = []
        for h in (-15.0, -5.0, 0.0, 5.0, 15.0):
            d = np.array([0.0, h - y_obj, -z_obj])
            d /= np.linalg.norm(d)
            hits = trace_from_frame1(opm, np.array([0.0, y_obj, z_obj]), d)
            dirs.append(hits[1][1])
        ideal_tan = -y_obj / f_len
        ang = [math.degrees(math.atan2(v[1], v[2])) for v in dirs]
        out["cases"].append({"object_height": y_obj, "ray_heights_on_surface_1": [-15, -5, 0, 5, 15],
                             "exit_angle_deg_rayoptics": ang,
                             "exit_angle_deg_ideal_paraxial_lens": math.degrees(math.atan(ideal_tan))})
    out["summary"] = ("an ideal paraxial lens sends every ray from an object point in its front focal plane out parallel "
                      "(one exit angle per object point); rayoptics' ThinLens does not at 587.5618 nm (spread of exit angles above)")
    return out


# ----------------------------------------------------------------------------
# the lenses
# ----------------------------------------------------------------------------
def load_zmx(name, patch=None):
    src = ZMX_DIR / name
    text, enc = read_text(src)
    patches = []
    path = src
    if patch is not None:
        new_text, patches = patch(text)
        PATCH_DIR.mkdir(exist_ok=True)
        path = PATCH_DIR / (name + ".patched.zmx")
        path.write_text(new_text, encoding="utf-8")
        text = new_text
    opm, info = open_model(path, info=True)
    return opm, info, text, enc, patches, path


def patch_bare_diam(text):
    """rayoptics 0.9.8 crashes (IndexError) on a DIAM line with only a value."""
    lines = text.splitlines()
    patches = []
    for i, l in enumerate(lines):
        tok = l.split()
        if tok and tok[0] == "DIAM" and len(tok) == 2:
            lines[i] = l.rstrip() + " 0 0 0 1 \"\""
            patches.append({"line": i + 1, "from": l, "to": lines[i]})
    return "\n".join(lines) + "\n", patches


def file_apertures(opm, file_surfs):
    ap = {}
    for i, fs in file_surfs.items():
        if i == 0 or i >= len(opm["seq_model"].ifcs) - 1:
            continue
        if "clap" in fs:
            ap[i] = (fs["clap"][1], "CLAP (hard circular aperture)")
        elif "flap" in fs and fs.get("diam", 0) > 0:
            ap[i] = (fs["diam"], "DIAM with FLAP (floating hard aperture)")
        elif fs.get("diam", 0) > 0:
            ap[i] = (fs["diam"], "DIAM flag %s (semi-diameter; not a hard aperture in OpticStudio unless FLAP/CLAP)" % fs.get("diam_flag"))
    return ap


def zmx_entry(name, *, patch=None, max_field_deg=None, float_stop_sd=None, float_stop_note=None,
              model_glass_from_file=False, entry_id=None, notes=(), rays=True, ray_defs=DEFAULT_RAYS,
              z_start_mm=-5.0, mutate=None):
    opm, info, text, enc, patches, path = load_zmx(name, patch)
    fz = parse_zmx(text)
    scale = INCH if fz["unit"].upper() == "IN" else 1.0
    sm = opm["seq_model"]
    osp = opm["optical_spec"]
    entry = {
        "id": entry_id or name,
        "source": {"kind": "zmx", "file": str(ZMX_DIR / name), "sha256": sha256(ZMX_DIR / name),
                   "encoding": enc, "unit_in_file": fz["unit"],
                   "units_out": "mm" + (" (converted from inches x25.4)" if scale != 1.0 else ""),
                   "file_aperture_keyword": fz["aperture"],
                   "rayoptics_loaded": str(path), "patches_before_loading": patches},
        "rayoptics_import_info": json.loads(json.dumps(info[0], default=str)),
        "rayoptics_glass_substitutions": json.loads(json.dumps(info[1], default=str)),
        "as_read": {"wavelengths": wavelengths_as_read(opm),
                    "pupil": [list(osp["pupil"].key), f(osp["pupil"].value)],
                    "field": [list(osp["fov"].key), f(osp["fov"].value)]},
        "wavelength_nm": WVL_D,
        "frame": "origin at vertex of surface 1 (first surface after the object surface), +z toward the image, mm",
        "notes": list(notes),
    }
    if model_glass_from_file:
        for i, fs in fz["surfaces"].items():
            if "glas_nd_vd" in fs and fs["glas"] not in ("MIRROR",):
                nd, vd = fs["glas_nd_vd"]
                sm.gaps[i].medium = mg.ModelGlass(nd, vd, fs["glas"] + "(model)")
        entry["notes"].append("glasses replaced by rayoptics ModelGlass(n_d, V_d) with the n_d/V_d written on the GLAS line (Zemax GLAS solve flag 1 = model glass)")
    file_surfs = fz["surfaces"]
    if mutate is not None:
        off = mutate(opm, entry) or 0
        if off:
            file_surfs = {i - off: fs for i, fs in fz["surfaces"].items() if i - off >= 1}
    force_d_line(opm)
    if fz["aperture"] and fz["aperture"][0] == "FLOA":
        before = paraxial_raw(opm)[2]
        entry["as_read"]["FLOA_handling"] = ("rayoptics ignores FLOA (logged as unsupported) and keeps its default pupil %s = %s; "
                                             "as loaded, EPD = %.6g, f/# = %.6g" % (list(osp["pupil"].key), osp["pupil"].value,
                                                                                     2 * before.enp_radius * scale, before.fno))
        if float_stop_sd is not None:
            epd = epd_for_stop_semi_diameter(opm, float_stop_sd / scale)
            set_epd(opm, epd)
            entry["aperture_used"] = {"rule": "float by stop size", "stop_semi_diameter": float_stop_sd,
                                      "source": float_stop_note, "epd": epd * scale}
    else:
        entry["aperture_used"] = {"rule": "from file", "keyword": fz["aperture"]}
    entry["surfaces"] = surface_table(opm, scale, file_surfs)
    entry["stop_surface"] = sm.stop_surface
    entry["paraxial"] = paraxial_data(opm, scale)
    entry["paraxial_check_real_ray_efl"] = dict(zip(("efl", "ray_height"), real_ray_efl(opm, scale))) if not any(
        type(i).__name__ == "ThinLens" for i in sm.ifcs) else None
    entry["glasses"] = glass_table(opm)
    if max_field_deg is None:
        max_field_deg = float(osp["fov"].value) if osp["fov"].key[1] == "angle" else float(paraxial_raw(opm)[2].obj_ang)
    entry["max_field_deg_used_for_rays"] = max_field_deg if rays else None
    if rays:
        entry["rays"] = make_rays(opm, scale, max_field_deg, file_apertures(opm, file_surfs), z_start_mm=z_start_mm, ray_defs=ray_defs)
        entry["ray_definition"] = ("object at infinity; direction d = normalize(tan(theta_x), tan(theta_y), 1); start point on the "
                                   "plane z = %g mm in front of surface 1; real-ray aimed so the ray meets the stop surface at "
                                   "stop_target = normalized pupil * paraxial marginal-ray height at the stop" % z_start_mm)
    return entry, opm


def json_lens_entry(name, rays=True, max_field_deg=None, ray_defs=DEFAULT_RAYS, z_start_mm=-5.0):
    src = JSON_DIR / name
    data = json.loads(src.read_text())
    opm = OpticalModel()
    sm = opm["seq_model"]
    osp = opm["optical_spec"]
    opm.radius_mode = False
    sm.gaps[0].thi = 1e10
    built = []
    apertures = {}
    for j, s in enumerate(data["surfaces"]):
        typ = s["type"]
        if "roc" in s:
            c = 0.0 if s["roc"] == 0 else 1.0 / s["roc"]
            c_src = "1/roc" if s["roc"] != 0 else "roc=0 -> flat"
        elif "c" in s:
            c = s["c"]
            c_src = "c (no roc key)"
        else:
            c = 0.0
            c_src = "flat (%s)" % typ
        if typ in ("Stop", "Aperture"):
            c = 0.0
            c_src = "flat (%s)" % typ
        mat = s.get("mat2", "air")
        if mat is None or mat.lower() in ("air", "vacuum"):
            medium = om.Air()
            mdesc = "air"
        elif "/" in mat:
            nd, vd = (float(x) for x in mat.split("/"))
            medium = mg.ModelGlass(nd, vd, mat)
            mdesc = "ModelGlass n_d=%s V_d=%s (from mat2 string)" % (nd, vd)
        else:
            nd, vd = DEEPLENS_MATERIALS[mat.lower()]
            medium = mg.ModelGlass(nd, vd, mat)
            mdesc = "ModelGlass n_d=%s V_d=%s (DeepLens MATERIAL_TABLE '%s')" % (nd, vd, mat)
        if typ in ("Stop", "Aperture"):
            medium = om.Air()
            mdesc = "air"
        sm.add_surface([c, s["d_next"], medium])
        idx = sm.cur_surface
        ifc = sm.ifcs[idx]
        desc = {"surface": idx, "json_index": j, "type": typ, "c": c, "c_source": c_src, "semi_aperture_r": s["r"],
                "d_next": s["d_next"], "medium_after": mdesc}
        if typ == "Aspheric":
            ai = list(s.get("ai", []))
            ifc.profile = profiles.EvenPolynomial(c=c, cc=s.get("k", 0.0), coefs=ai + [0.0] * max(0, 10 - len(ai)))
            desc.update({"k": s.get("k", 0.0), "ai_r2_first": ai,
                         "rayoptics_profile": "EvenPolynomial(c, cc=k, coefs=ai) -> sag = c r^2/(1+sqrt(1-(1+k)c^2 r^2)) + sum_j ai[j] r^(2j+2)"})
        if typ in ("Stop", "Aperture"):
            sm.set_stop()
        apertures[idx] = (s["r"], "JSON r (semi-aperture)")
        built.append(desc)
    force_d_line(opm)
    stop = sm.stop_surface
    stop_r = data["surfaces"][stop - 1]["r"]
    # field of view for rays and the pupil: float by stop size
    set_epd(opm, 1.0)
    epd = epd_for_stop_semi_diameter(opm, stop_r)
    set_epd(opm, epd)
    fod = paraxial_raw(opm)[2]
    r2_fod = paraxial_with_r2_term(opm, 1.0)
    efl_true = r2_fod["efl"] if r2_fod is not None else fod.efl
    if max_field_deg is None:
        max_field_deg = math.degrees(math.atan(data["r_sensor"] / efl_true)) if "r_sensor" in data else 20.0
    osp["fov"] = FieldSpec(osp, key=("object", "angle"), value=max_field_deg, flds=[0.0, 0.7, 1.0], is_relative=True)
    opm.update_model()
    entry = {
        "id": "deeplens/" + name,
        "source": {"kind": "deeplens-json", "file": str(src), "sha256": sha256(src),
                   "top_level": {k: v for k, v in data.items() if k != "surfaces"}, "units_out": "mm"},
        "built_in_rayoptics": built,
        "construction": ("OpticalModel(); object gap 1e10 (infinity); for each JSON surface sm.add_surface([c, d_next, medium]) in order "
                         "(surface 1 = first JSON surface); Stop/Aperture -> flat air surface + set_stop(); Aspheric -> "
                         "profiles.EvenPolynomial(c=c, cc=k, coefs=ai) (ai[0] = r^2 coefficient); the last d_next is the distance to "
                         "the image (sensor) surface; media: 'n/V' strings and DeepLens material names -> opticalglass ModelGlass(n_d, V_d)"),
        "wavelength_nm": WVL_D,
        "frame": "origin at vertex of surface 1 (first JSON surface), +z toward the image, mm",
        "aperture_used": {"rule": "float by stop size", "stop_surface": stop, "stop_semi_diameter": stop_r, "epd": epd},
        "notes": [],
    }
    entry["surfaces"] = surface_table(opm, 1.0)
    entry["stop_surface"] = stop
    entry["paraxial"] = paraxial_data(opm, 1.0)
    r2 = paraxial_with_r2_term(opm, 1.0)
    if r2 is not None:
        entry["paraxial_rayoptics_ignores_r2_term"] = entry["paraxial"]
        entry["paraxial"] = r2
        entry["notes"].append("Some surfaces have a2 != 0 (r^2 term). rayoptics' paraxial trace uses profile.cv only and ignores a2; "
                              "'paraxial' here is recomputed with c_parax = c + 2*a2 on those surfaces (the real-ray EFL check confirms "
                              "which is right); 'paraxial_rayoptics_ignores_r2_term' is rayoptics' unmodified output.")
        # the EPD (float by stop) and the ray aiming used rayoptics' paraxial marginal ray, which is only right
        # when no r^2 term precedes the stop: true for the lenses here (stop = surface 1); refuse otherwise
        first_a2 = min(r["surface"] for r in entry["surfaces"] if r.get("poly_coefs_r2_first", [0.0])[0] != 0.0)
        if first_a2 < stop:
            raise NotImplementedError("r^2 term before the stop: EPD/aiming would need the r2-corrected paraxial trace")
    entry["paraxial_check_real_ray_efl"] = dict(zip(("efl", "ray_height"), real_ray_efl(opm, 1.0)))
    entry["glasses"] = glass_table(opm)
    entry["max_field_deg_used_for_rays"] = max_field_deg
    if rays:
        entry["rays"] = make_rays(opm, 1.0, max_field_deg, apertures, z_start_mm=z_start_mm, ray_defs=ray_defs)
        entry["ray_definition"] = ("object at infinity; direction d = normalize(tan(theta_x), tan(theta_y), 1); start point on the "
                                   "plane z = %g mm in front of surface 1; real-ray aimed so the ray meets the stop surface at "
                                   "stop_target = normalized pupil * stop semi-aperture r (the paraxial marginal ray fills the stop)" % z_start_mm)
    return entry, opm


def main():
    lenses = []
    summary = []

    def add(e):
        lenses.append(e)
        p = e["paraxial"]
        summary.append((e["id"], p["efl"], p["bfl"], p["epd"], p["f_number"]))
        print("done", e["id"], flush=True)

    # --- lens1.zmx: Cooke triplet, GLAS with solve flag 1 (model) -----------------
    e, _ = zmx_entry("lens1.zmx", notes=[
        "GLAS lines carry solve flag 1 (model glass in OpticStudio) with n_d/V_d that differ from the catalogue "
        "(e.g. N-SK16 1.62070465/60.2795 vs SCHOTT 1.62041/60.32); rayoptics ignores the flag and looks the name up "
        "in the SCHOTT catalogue. See the entry 'lens1.zmx#model-glass' for the Zemax (model-glass) reading.",
        "no DIAM records: no file apertures to check"])
    add(e)
    e, _ = zmx_entry("lens1.zmx", entry_id="lens1.zmx#model-glass", model_glass_from_file=True)
    add(e)

    # --- US00583336-2-scaled.zmx: Rudolph double Gauss ----------------------------
    e, _ = zmx_entry("US00583336-2-scaled.zmx", notes=[
        "surface 1 is a dummy plane 4.5 mm in front of the first lens (frame origin is that dummy plane; first lens vertex at z = 4.5)",
        "DIAM records with solve flag 2 (pickup) on surfaces 8-12 are not understood by rayoptics ('ca_type_not_recognized'); "
        "it leaves those surfaces without a clear aperture; the file values are used for the aperture check here"])
    add(e)

    # --- US08427765-1.ZMX: phone lens with one EVENASPH ---------------------------
    e, _ = zmx_entry("US08427765-1.ZMX", notes=[
        "field type 3 (real image height 13.6 mm); rays use object angles up to the paraxial chief-ray angle obj_ang",
        "glass GLAS lines have solve flag 0 (catalogue) and placeholder n/V 1.5/40; rayoptics substitutes L-TIM28_MOLD -> S-TIM28 (Ohara)"])
    add(e)

    # --- circular_aperture_example_with_aperture.zmx: inches, UTF-16 ---------------
    e, _ = zmx_entry("circular_aperture_example_with_aperture.zmx", max_field_deg=50.0, notes=[
        "UNIT IN: every length in this entry is converted to mm (x25.4); the model was traced in inches",
        "UTF-16LE with BOM",
        "rayoptics as read takes the reference wavelength as wavelengths[len//2] = 656 nm (it ignores PWAV 1 = 587 nm); forced to 587.5618 here",
        "surface 1 is a dummy plane 0.5 in = 12.7 mm in front of the first lens; surface 10 has CLAP 0 0.45 in (hard aperture) ahead of the stop (11)",
        "rayoptics turns the DIAM 0 of surface 1 into a 1.0 (lens unit) clear aperture"])
    add(e)

    # --- ef35mm_f2.0.zmx: FLOA and a bare DIAM line ---------------------------------
    e, _ = zmx_entry("ef35mm_f2.0.zmx", patch=patch_bare_diam, max_field_deg=30.90523045170307,
                     float_stop_sd=9.8795, float_stop_note="stop semi-aperture r of the same design in /work/shared/lenses-json/deeplens/ef35mm_f2.0.json (the .zmx stop has no DIAM)",
                     notes=["rayoptics 0.9.8 raises IndexError on the image-surface line 'DIAM 21.106820931884467' (no flags); "
                            "a patched copy with ' 0 0 0 1 \"\"' appended to that line was loaded (nothing else changed)",
                            "FLOA (float by stop size) is not supported by rayoptics and the stop has no DIAM in the .zmx"])
    add(e)

    # --- HoO-V2C18Ex27.zmx: mirrors -------------------------------------------------
    def hoo_stop(opm, entry):
        sm = opm["seq_model"]
        entry["notes"].append("rayoptics 0.9.8 loses a STOP on surface 1 (SequentialModel.set_stop() refuses while fewer than 3 "
                              "interfaces exist, so stop_surface was %r after import); set to 1 here as in the file" % sm.stop_surface)
        sm.stop_surface = 1
        opm.update_model()
    e, _ = zmx_entry("HoO-V2C18Ex27.zmx", mutate=hoo_stop, notes=[
        "contains two MIRROR surfaces (4: concave conic mirror, 5: flat fold) -> catadioptric, not a refracting camera lens; "
        "rayoptics imports MIRROR as interact_mode 'reflect' and traces it (negative thickness after the first mirror); "
        "realcam is expected to refuse this file",
        "as read the only wavelength is 550 nm",
        "the global frame is surface 1's: after surface 4 the rays travel toward -z, after surface 5 toward +z again"],
        ray_defs=[r for r in DEFAULT_RAYS if r[1] in (0.0, 0.5, 0.85)], z_start_mm=-5.0)
    add(e)

    # --- zemax_double_gaussian.zmx: PARAXIAL surface ----------------------------------
    def dg_mutate(opm, entry):
        sm = opm["seq_model"]
        tl = sm.ifcs[1]
        entry["notes"].append("surface 1 TYPE PARAXIAL (PARM 1 = focal length 100, PARM 2 = 1): rayoptics replaces it with a ThinLens "
                              "of power 1/100 whose real-ray behaviour is a HolographicElement (sine-law grating recorded at %g nm; "
                              "its power scales with wavelength/%g). Paraxial data use the exact power 0.01/mm; real rays through it "
                              "would NOT match OpticStudio's ideal paraxial lens, so no real rays are given for this entry (see the "
                              "lens-only entry)." % (tl.phase_element.ref_wl, tl.phase_element.ref_wl))
    e, dg_opm = zmx_entry("zemax_double_gaussian.zmx", float_stop_sd=10.228835191,
                     float_stop_note="stop DIAM 10.228835191 (flag 1) in the file", mutate=dg_mutate, rays=False,
                     notes=["finite conjugate: object 100 mm in front of the PARAXIAL surface, fields are object heights 0/19/27 mm; "
                            "FLOA (float by stop size)",
                            "for this finite-conjugate system 'f_number' = EFL/EPD is not a working f-number and the entrance pupil "
                            "(seen through the f = 100 mm collimator from an object at its focal plane) is far away and large; the "
                            "numbers are rayoptics' paraxial values for the whole file, given for completeness only"])
    e["paraxial_surface_behaviour"] = paraxial_surface_diagnostic(dg_opm)
    add(e)

    def dg_lens_only_patch(text):
        """Drop the object-at-100-mm and PARAXIAL collimator (file surface 1); object at infinity."""
        out, patches, skip, surf = [], [], False, None
        for l in text.splitlines():
            tok = l.split()
            if tok and tok[0] == "SURF":
                surf = int(tok[1])
                skip = surf == 1
                if surf > 1:
                    l = "SURF %d" % (surf - 1)
            elif tok and tok[0] == "FTYP":
                l = "FTYP 0" + l[len("FTYP 1"):]
            elif tok and tok[0] == "YFLN":
                l = "YFLN 0 14 20"
            elif tok and tok[0] == "DISZ" and surf == 0:
                l = "  DISZ INFINITY"
            if not skip:
                out.append(l)
        patches.append({"what": "removed file SURF 1 (TYPE PARAXIAL, f = 100 mm) and renumbered SURF n -> n-1; object DISZ 100 -> "
                                "INFINITY; FTYP 1 (object height) -> 0 (angle); YFLN 0 19 27 -> 0 14 20 (deg)"})
        return "\n".join(out) + "\n", patches

    e, _ = zmx_entry("zemax_double_gaussian.zmx", entry_id="zemax_double_gaussian.zmx#lens-only-infinity", patch=dg_lens_only_patch,
                     float_stop_sd=10.228835191, float_stop_note="stop DIAM 10.228835191 (flag 1) in the file", max_field_deg=20.0,
                     notes=["LENS-ONLY VARIANT (a camera-lens reading of the file): the object at 100 mm and the PARAXIAL collimator "
                            "(file surface 1) are removed from a patched copy; object at infinity; surface n here is file surface n+1 "
                            "(surface 1 = file surface 2, stop 6 = file 7, image 12 = file 13); ray field angles up to 20 deg (chosen)"])
    add(e)

    # --- DeepLens JSON lenses ----------------------------------------------------------
    for name in ("cellphone68deg.json", "cellphone80deg.json", "rf50mm_f1.8.json", "rf16mm_f2.8.json", "ef35mm_f2.0.json"):
        e, _ = json_lens_entry(name)
        add(e)

    doc = {
        "generator": {
            "program": "ray-optics (rayoptics) %s with opticalglass %s" % (rayoptics.__version__, opticalglass.__version__),
            "numpy": np.__version__,
            "python": sys.version.split()[0],
            "platform": platform.platform(),
            "date_utc": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
            "command": "cd /work/refs && ./venv/bin/python make_reference.py",
            "script_sha256": sha256(__file__),
        },
        "conventions": {
            "units": "mm",
            "wavelength_nm": WVL_D,
            "frame": "origin at the vertex of surface 1 (first surface after the object surface), +z along the axis toward the image",
            "directions": "unit vectors (direction cosines) in that frame; 'direction_after' is after refraction/reflection at the surface",
            "air_index": 1.0,
            "surface_numbering": "as in the .zmx SURF numbers (0 = object); for JSON lenses 1..N in file order, image = N+1",
        },
        "summary": [{"id": s[0], "efl": s[1], "bfl": s[2], "epd": s[3], "f_number": s[4]} for s in summary],
        "lenses": lenses,
    }
    OUT.write_text(json.dumps(doc, indent=1))
    print("\n%-46s %12s %12s %10s %8s" % ("lens", "EFL mm", "BFL mm", "EPD mm", "f/#"))
    for s in summary:
        print("%-46s %12.6f %12.6f %10.6f %8.4f" % s)


if __name__ == "__main__":
    main()
