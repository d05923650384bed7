#!/usr/bin/env python3
"""realcam against peer renderers, side by side, on the same scene and settings.

    python3 benches/peers/compare.py [--spp 64] [--size 320] [--repeat 1] [--skip-install]
                                     [--scenes helmet,spheres]

Installs what it needs (idempotent): rs_pbrt (`cargo install rs_pbrt --locked`, a Rust port
of pbrt-v3 with its realistic camera), Mitsuba 3 (`pip install mitsuba`; its llvm variant
needs Debian's libllvm19), numpy and pygltflib. Converts each scene (DamagedHelmet, 15k
triangles; MetalRoughSpheresNoTextures, 1M triangles, centred and scaled to 2 m) to PLY
(peers) and a matte .glb (realcam), writes a pbrt-v3 scene, renders with each renderer and
prints camera samples per second (width × height × spp / render seconds, all cores), the
ratios, each renderer's fixed set-up time (scene, BVH, lens; excluded from the rate) and, for
realcam and Mitsuba, the scene load + BVH build alone.

realcam runs twice: as a user gets it (dgauss.50mm has glass data, so each camera ray carries
one wavelength through the dispersive lens: spectral) and with `--dispersion off` (every ray at
the lens file's n_d indices, RGB throughout like the peers). The thin-lens peers render RGB
with no lens at all, so `--dispersion off` is the like-for-like figure; the spectral one is
what the default costs.

The settings: 320 × 320, 64 spp, path depth 5 (pbrt's maxdepth; Mitsuba's max_depth is one
more, as it counts the camera segment), matte albedo 0.5, a white uniform sky of radiance 1,
the camera 4.5 m in front of the helmet looking at it, focused at 4.5 m; dgauss.50mm at an
8 mm stop on a 35 mm-diagonal film for realcam and rs_pbrt; Mitsuba's thin lens gets the same
horizontal field of view and entrance pupil. A peer that cannot be installed or run is
reported as such and the rest go on. Results also go to target/peers/results.json.
"""

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
WORK = ROOT / "target" / "peers"
SHARED = Path(os.environ.get("REALCAM_SHARED", ROOT.parent / "shared"))
# name → (file under shared/scenes, longest side to fit the scene to in metres, or None to keep it)
SCENES = {
    "helmet": ("DamagedHelmet/DamagedHelmet.glb", None),
    "spheres": ("MetalRoughSpheresNoTextures/MetalRoughSpheresNoTextures.gltf", 2.0),
}
LENS = "dgauss.50mm"
STOP_MM = 8.0
FILM_DIAGONAL_MM = 35.0
EYE = [0.0, 0.0, 4.5]
TARGET = [0.0, 0.0, 0.0]
DEPTH = 5
ALBEDO = 0.5
LLVM_CANDIDATES = [
    "/usr/lib/x86_64-linux-gnu/libLLVM-19.so",
    "/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1",
    "/usr/lib/aarch64-linux-gnu/libLLVM-19.so",
    "/usr/lib/llvm-19/lib/libLLVM.so",
]


def say(message: str) -> None:
    print(f"[peers] {message}", flush=True)


def run(command: list[str], **kwargs) -> subprocess.CompletedProcess:
    return subprocess.run(command, text=True, capture_output=True, **kwargs)


def cargo_bin(name: str) -> str | None:
    found = shutil.which(name)
    if found:
        return found
    candidate = Path.home() / ".cargo" / "bin" / name
    return str(candidate) if candidate.exists() else None


# ---------------------------------------------------------------- installation


def install_python_packages() -> None:
    missing = []
    for module, package in [("numpy", "numpy"), ("pygltflib", "pygltflib"), ("mitsuba", "mitsuba")]:
        try:
            __import__(module)
        except ImportError:
            missing.append(package)
    if missing:
        say(f"pip install {' '.join(missing)}")
        result = run([sys.executable, "-m", "pip", "install", *missing])
        if result.returncode != 0 and "externally-managed" in result.stderr:
            # Debian's own python3 (PEP 668): install next to it anyway, for this user.
            result = run([sys.executable, "-m", "pip", "install", "--user",
                          "--break-system-packages", *missing])
        if result.returncode != 0:
            say(f"pip install failed:\n{result.stderr[-2000:]}")


def find_libllvm() -> str | None:
    if os.environ.get("DRJIT_LIBLLVM_PATH") and Path(os.environ["DRJIT_LIBLLVM_PATH"]).exists():
        return os.environ["DRJIT_LIBLLVM_PATH"]
    return next((p for p in LLVM_CANDIDATES if Path(p).exists()), None)


def install_libllvm() -> None:
    if find_libllvm():
        return
    if not shutil.which("apt-get") or os.geteuid() != 0:
        say("libllvm19 missing and apt-get (as root) unavailable: Mitsuba's llvm variant will be skipped")
        return
    say("apt-get install -y libllvm19 (for Mitsuba's llvm variant)")
    run(["apt-get", "update"])
    result = run(["apt-get", "install", "-y", "libllvm19"])
    if result.returncode != 0:
        say(f"apt-get install libllvm19 failed:\n{result.stderr[-2000:]}")


def install_rs_pbrt() -> None:
    if cargo_bin("rs_pbrt"):
        return
    say("cargo install rs_pbrt --locked (compiles for several minutes)")
    result = subprocess.run(["cargo", "install", "rs_pbrt", "--locked"])
    if result.returncode != 0:
        say("cargo install rs_pbrt failed: rs_pbrt will be skipped")


def build_realcam() -> str:
    say("cargo build --release (realcam)")
    subprocess.run(["cargo", "build", "--release", "--quiet"], cwd=ROOT, check=True)
    return str(ROOT / "target" / "release" / "realcam")


# ---------------------------------------------------------------- scene set-up


def lens_settings(realcam: str) -> dict:
    """Thin-lens equivalents of the real lens, from realcam's own first-order report."""
    report = json.loads(
        run(
            [realcam, "lens", LENS, "--aperture", str(STOP_MM), "--film-diagonal", str(FILM_DIAGONAL_MM),
             "--focus-distance", str(distance(EYE, TARGET)), "--json"],
            check=True,
        ).stdout
    )
    import math

    half_diagonal = math.radians(report["field_of_view_deg"] / 2)
    # A square film: the horizontal half-width is the half-diagonal over √2.
    fov_x = 2 * math.degrees(math.atan(math.tan(half_diagonal) / math.sqrt(2)))
    return {
        "fov_x_deg": fov_x,
        "aperture_radius_m": report["entrance_pupil"]["diameter_mm"] / 2 / 1000,
        "focus_distance_m": distance(EYE, TARGET),
        "eye": EYE,
        "target": TARGET,
        "f_number": report["f_number"],
    }


def distance(a: list[float], b: list[float]) -> float:
    return sum((x - y) ** 2 for x, y in zip(a, b)) ** 0.5


def write_pbrt_scene(path: Path, ply: Path, size: int, spp: int) -> None:
    shutil.copy(ROOT / "lenses" / f"{LENS}.dat", path.parent / f"{LENS}.dat")
    eye, target = " ".join(map(str, EYE)), " ".join(map(str, TARGET))
    # pbrt's camera space is left-handed: mirroring x gives glTF's (unmirrored) image.
    path.write_text(
        f"""Scale -1 1 1
LookAt {eye}  {target}  0 1 0
Camera "realistic" "string lensfile" "{LENS}.dat" "float aperturediameter" {STOP_MM}
       "float focusdistance" {distance(EYE, TARGET)}
Film "image" "integer xresolution" {size} "integer yresolution" {size}
     "float diagonal" {FILM_DIAGONAL_MM} "string filename" "{ply.stem}.rs_pbrt.png"
Sampler "random" "integer pixelsamples" {spp}
Integrator "path" "integer maxdepth" {DEPTH}
WorldBegin
LightSource "infinite" "rgb L" [1 1 1]
Material "matte" "rgb Kd" [{ALBEDO} {ALBEDO} {ALBEDO}]
Shape "plymesh" "string filename" "{ply.name}"
WorldEnd
"""
    )


# ---------------------------------------------------------------- renderers


def time_rs_pbrt(rs_pbrt: str, ply: Path, size: int, spp: int) -> dict:
    """Two runs, at 1 spp and at `spp`: the difference is the sampling, the rest set-up."""
    seconds = {}
    for n in (1, spp):
        scene = WORK / f"{ply.stem}.rs_pbrt_{n}spp.pbrt"
        write_pbrt_scene(scene, ply, size, n)
        start = time.perf_counter()
        result = run([rs_pbrt, "--path", scene.name], cwd=WORK)
        seconds[n] = time.perf_counter() - start
        if result.returncode != 0:
            raise RuntimeError(f"rs_pbrt failed: {(result.stderr or result.stdout)[-1500:]}")
    per_sample = (seconds[spp] - seconds[1]) / (size * size * (spp - 1))
    return {
        "samples_per_second": 1 / per_sample,
        "setup_seconds": seconds[1] - per_sample * size * size,
        "load_seconds": float("nan"),  # not separable from the exit-pupil bounds
        "wall_seconds": seconds[spp],
    }


def time_mitsuba(variant: str, ply: Path, size: int, spp: int, settings: dict) -> dict:
    env = dict(os.environ)
    if variant.startswith("llvm"):
        libllvm = find_libllvm()
        if not libllvm:
            raise RuntimeError("libLLVM 19 not found (apt-get install libllvm19)")
        env["DRJIT_LIBLLVM_PATH"] = libllvm
    result = run(
        [sys.executable, str(Path(__file__).with_name("mitsuba_run.py")), variant, str(ply),
         str(size), str(size), str(spp), str(DEPTH + 1), json.dumps(settings),
         str(ply.with_suffix(f".mitsuba_{variant}.exr"))],
        env=env,
    )
    if result.returncode != 0:
        raise RuntimeError(f"Mitsuba {variant} failed: {result.stderr[-1500:]}")
    return json.loads(result.stdout.strip().splitlines()[-1])


def time_realcam(realcam: str, glb: Path, size: int, spp: int, dispersion: bool) -> dict:
    stats = WORK / "realcam_stats.json"
    look_from, look_at = ",".join(map(str, EYE)), ",".join(map(str, TARGET))
    result = run(
        [realcam, "render", str(glb), "--lens", LENS, "--aperture", str(STOP_MM),
         "--film-diagonal", str(FILM_DIAGONAL_MM), "--look-from", look_from, "--look-at", look_at,
         "--env", "1,1,1", "--width", str(size), "--height", str(size), "--spp", str(spp),
         "--max-depth", str(DEPTH), "--dispersion", "on" if dispersion else "off",
         "--out", str(glb.with_suffix(".realcam.png")), "--stats", str(stats)],
    )
    if result.returncode != 0:
        raise RuntimeError(f"realcam failed: {result.stderr[-1500:]}")
    s = json.loads(stats.read_text())
    stage = s["stage_seconds"]
    return {
        "samples_per_second": s["samples_per_second"],
        "setup_seconds": stage["load_scene"] + stage["build_bvh"] + s["lens_derivation"]["seconds"],
        "load_seconds": stage["load_scene"] + stage["build_bvh"],
        "wall_seconds": s["wall_seconds"],
    }


def median_of(runs: list[dict]) -> dict:
    return {key: statistics.median(r[key] for r in runs) for key in runs[0]}


def print_table(title: str, results: dict) -> None:
    print()
    print(title)
    print(f"{'renderer':<30}{'camera':<34}{'M samples/s':>12}{'set-up s':>10}{'load+BVH s':>11}"
          f"{'realcam ÷ it':>14}{'rgb realcam ÷ it':>18}")
    ours = results.get("realcam", {}).get("samples_per_second")
    ours_rgb = results.get("realcam --dispersion off", {}).get("samples_per_second")
    for name, r in results.items():
        ratio = f"{ours / r['samples_per_second']:.2f}×" if ours else "-"
        ratio_rgb = f"{ours_rgb / r['samples_per_second']:.2f}×" if ours_rgb else "-"
        load = "-" if r["load_seconds"] != r["load_seconds"] else f"{r['load_seconds']:.2f}"
        print(f"{name:<30}{r['camera']:<34}{r['samples_per_second'] / 1e6:>12.3f}"
              f"{r['setup_seconds']:>10.2f}{load:>11}{ratio:>14}{ratio_rgb:>18}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--spp", type=int, default=64)
    parser.add_argument("--size", type=int, default=320)
    parser.add_argument("--repeat", type=int, default=1, help="runs per renderer (median)")
    parser.add_argument("--skip-install", action="store_true")
    parser.add_argument("--scenes", default="helmet,spheres",
                        help=f"comma-separated, of: {', '.join(SCENES)}")
    args = parser.parse_args()
    scenes = [name.strip() for name in args.scenes.split(",") if name.strip()]
    unknown = [name for name in scenes if name not in SCENES]
    if unknown or not scenes:
        parser.error(f"--scenes: unknown scene {', '.join(unknown) or '(none)'}; known: {', '.join(SCENES)}")
    WORK.mkdir(parents=True, exist_ok=True)

    if not args.skip_install:
        install_python_packages()
        install_libllvm()
        install_rs_pbrt()
    realcam = build_realcam()
    sys.path.insert(0, str(Path(__file__).parent))
    from convert import convert

    settings = lens_settings(realcam)
    say(f"{args.size}² px, {args.spp} spp, depth {DEPTH}; thin lens fov {settings['fov_x_deg']:.2f}°, "
        f"aperture radius {settings['aperture_radius_m'] * 1000:.2f} mm")
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    rs_pbrt = cargo_bin("rs_pbrt")
    if not rs_pbrt:
        say("rs_pbrt is not installed (cargo install rs_pbrt --locked failed or was skipped): skipped")

    all_results = {}
    for scene_name in scenes:
        source, fit = SCENES[scene_name]
        source = SHARED / "scenes" / source
        if not source.exists():
            say(f"{source} not found (set REALCAM_SHARED to the shared data folder): {scene_name} skipped")
            continue
        ply, glb = WORK / f"{scene_name}.ply", WORK / f"{scene_name}.glb"
        triangles, _ = convert(source, ply, glb, ALBEDO, fit)
        say(f"{scene_name} ({source.stem}): {triangles} triangles")

        renderers = [
            ("realcam", f"real lens {LENS}, spectral",
             lambda: time_realcam(realcam, glb, args.size, args.spp, True)),
            ("realcam --dispersion off", f"real lens {LENS}, RGB",
             lambda: time_realcam(realcam, glb, args.size, args.spp, False)),
            ("rs_pbrt", f"realistic {LENS}",
             lambda: time_rs_pbrt(rs_pbrt or "", ply, args.size, args.spp)),
            ("mitsuba scalar_rgb", "thin lens",
             lambda: time_mitsuba("scalar_rgb", ply, args.size, args.spp, settings)),
            ("mitsuba llvm_ad_rgb", "thin lens",
             lambda: time_mitsuba("llvm_ad_rgb", ply, args.size, args.spp, settings)),
        ]
        if not rs_pbrt:
            renderers = [r for r in renderers if r[0] != "rs_pbrt"]
        # Rounds go through every renderer in turn, so a change in the machine's load hits all
        # of them alike; each renderer's median round is reported.
        runs: dict[str, list[dict]] = {name: [] for name, _, _ in renderers}
        failed: set[str] = set()
        for round_index in range(args.repeat):
            for name, camera, measure in renderers:
                if name in failed:
                    continue
                try:
                    say(f"{scene_name}, round {round_index + 1}/{args.repeat}: rendering with {name}")
                    runs[name].append(measure())
                except Exception as error:  # a peer that fails is reported, the others go on
                    say(f"{name}: {error}")
                    failed.add(name)
        results = {
            name: {"camera": camera, **median_of(runs[name])}
            for name, camera, _ in renderers
            if runs[name]
        }
        all_results[scene_name] = {"source": source.name, "triangles": triangles, "results": results}
        print_table(
            f"{source.stem} ({triangles} triangles) {args.size}×{args.size}, {args.spp} spp, depth {DEPTH}, "
            f"matte {ALBEDO}, white sky; load average {load:.2f} at the start, on {os.cpu_count()} CPUs",
            results,
        )
    print()
    print("realcam ÷ it: spectral (the default with dgauss.50mm's glass data); rgb realcam ÷ it: "
          "--dispersion off, like for like with the RGB thin-lens peers.")
    (WORK / "results.json").write_text(json.dumps(
        {"load_average": load, "size": args.size, "spp": args.spp, "depth": DEPTH,
         "settings": settings, "scenes": all_results}, indent=2))


if __name__ == "__main__":
    main()
