#!/usr/bin/env python3
"""realcam against peer renderers, side by side, on the same scene and settings.

    python3 benches/peers/compare.py [--spp 64] [--size 320] [--repeat 1] [--skip-install]
                                     [--scenes helmet,spheres] [--device cpu[,gpu]] [--threads N]
                                     [--peers all|none|LIST] [--realcam PATH] [--work DIR]
                                     [--skip-convert] [--timeout SECONDS] [--results FILE]

Installs what it needs (idempotent): rs_pbrt (`cargo install rs_pbrt --locked`, a Rust port
of pbrt-v3 with its realistic camera), Mitsuba 3 (`pip install mitsuba`; its llvm variant
needs Debian's libllvm19), numpy and pygltflib. Converts each scene (DamagedHelmet, 15k
triangles; MetalRoughSpheresNoTextures, 1M triangles, centred and scaled to 2 m) to PLY
(peers) and a matte .glb (realcam), writes a pbrt-v3 scene, renders with each renderer and
prints camera samples per second (width × height × spp / render seconds, all cores), the
ratios, each renderer's fixed set-up time (scene, BVH, lens; excluded from the rate) and, for
realcam and Mitsuba, the scene load + BVH build alone.

realcam runs twice per device: as a user gets it (dgauss.50mm has glass data, so each camera
ray carries one wavelength through the dispersive lens: spectral) and with `--dispersion off`
(every ray at the lens file's n_d indices, RGB throughout like the peers). The thin-lens peers
render RGB with no lens at all, so `--dispersion off` is the like-for-like figure; the spectral
one is what the default costs. `--device cpu,gpu` renders each scene on both of realcam's
devices: rows "realcam" and "realcam --dispersion off" (the CPU, as before) and "realcam
--device gpu" and "realcam --device gpu --dispersion off"; `--device` is passed to realcam,
`--threads N` to its CPU renders. A device realcam cannot render on is reported per row and the
rest go on.

The settings: 320 × 320, 64 spp, path depth 5 (pbrt's maxdepth; Mitsuba's max_depth is one
more, as it counts the camera segment), matte albedo 0.5, a white uniform sky of radiance 1,
the camera 4.5 m in front of the helmet looking at it, focused at 4.5 m; dgauss.50mm at an
8 mm stop on a 35 mm-diagonal film for realcam and rs_pbrt; Mitsuba's thin lens gets the same
horizontal field of view and entrance pupil. The peers (`--peers all`, the default; `none` for
realcam alone; or a comma list of rs_pbrt, scalar_rgb, llvm_ad_rgb, cuda_ad_rgb): rs_pbrt,
Mitsuba's scalar_rgb and llvm_ad_rgb, and Mitsuba's cuda_ad_rgb (thin lens, the same settings
as the llvm row) where `mitsuba` imports, lists that variant and a CUDA device answers. A peer
that cannot be installed or run is reported as such and the rest go on.

For a machine without Rust, network or the shared scenes (a GPU machine): `--realcam PATH`
renders with that binary instead of running `cargo build --release`; `--work DIR` is where the
converted scenes are (default target/peers); `--skip-convert` uses the `<work>/<scene>.glb` an
earlier run wrote, with no numpy, pygltflib or shared scenes (`<scene>.ply`, read by the peers
alone, is written from the .glb where it is missing); `--timeout S` stops any one render after
S seconds, says so and goes on (once a realcam GPU render has timed out, the scene's remaining
GPU rows are skipped). Results (each row's median, the rows that failed and why, the settings)
go to `<work>/results.json`, or to `--results FILE`.
"""

import argparse
import json
import os
import shutil
import signal
import statistics
import struct
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
WORK = ROOT / "target" / "peers"  # --work replaces it
SHARED = Path(os.environ.get("REALCAM_SHARED", ROOT.parent / "shared"))
# name → (file under shared/scenes, longest side to fit the scene to in metres, or None to keep it)
SCENES = {
    "helmet": ("DamagedHelmet/DamagedHelmet.glb", None),
    "spheres": ("MetalRoughSpheresNoTextures/MetalRoughSpheresNoTextures.gltf", 2.0),
}
DEVICES = ("cpu", "gpu")
PEERS = ("rs_pbrt", "scalar_rgb", "llvm_ad_rgb", "cuda_ad_rgb")
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


class TimedOut(RuntimeError):
    """A render stopped at --timeout."""


def say(message: str) -> None:
    print(f"[peers] {message}", flush=True)


def run(command: list[str], **kwargs) -> subprocess.CompletedProcess:
    return subprocess.run(command, text=True, capture_output=True, **kwargs)


def run_render(command: list[str], timeout: float | None, what: str, **kwargs) -> subprocess.CompletedProcess:
    """`run` with --timeout: a render past it is killed, with whatever it started, and raises
    TimedOut."""
    with subprocess.Popen(command, text=True, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                          start_new_session=True, **kwargs) as process:
        RENDERING.add(process.pid)
        try:
            stdout, stderr = process.communicate(timeout=timeout)
        except subprocess.TimeoutExpired:
            os.killpg(process.pid, signal.SIGKILL)
            process.communicate()
            raise TimedOut(f"{what} timed out after {timeout:g} s (--timeout): stopped") from None
        finally:
            RENDERING.discard(process.pid)
    return subprocess.CompletedProcess(command, process.returncode, stdout, stderr)


RENDERING: set[int] = set()  # process groups of the renders under way


def stop_renders(signum: int, _frame) -> None:
    """Stopped from outside (`timeout`, Ctrl-C): the render under way goes too (it runs in a
    session of its own, which the signal does not reach)."""
    for group in list(RENDERING):
        try:
            os.killpg(group, signal.SIGKILL)
        except ProcessLookupError:
            pass
    sys.exit(128 + signum)


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


def mitsuba_variants() -> list[str] | None:
    """Mitsuba's variants, or None where `mitsuba` does not import (asked in a child process:
    a Mitsuba process holds one variant, and the renders run in their own)."""
    result = run([sys.executable, "-c", "import json, mitsuba; print(json.dumps(mitsuba.variants()))"])
    if result.returncode != 0:
        return None
    try:
        return json.loads(result.stdout.strip().splitlines()[-1])
    except (ValueError, IndexError):
        return None


def cuda_devices() -> int:
    """How many CUDA devices the driver reports (0 where there is no driver)."""
    import ctypes

    try:
        cuda = ctypes.CDLL("libcuda.so.1")
    except OSError:
        return 0
    count = ctypes.c_int(0)
    if cuda.cuInit(0) != 0 or cuda.cuDeviceGetCount(ctypes.byref(count)) != 0:
        return 0
    return count.value


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


def read_matte_glb(glb: Path) -> tuple[bytes, bytes, int]:
    """(positions as little-endian f32 triples, indices as little-endian u32, triangle count) of
    a .glb that convert.write_matte_glb wrote (one mesh: accessor 0 positions, 1 indices)."""
    data = glb.read_bytes()
    magic, _, _ = struct.unpack_from("<4sII", data, 0)
    json_length, json_type = struct.unpack_from("<I4s", data, 12)
    if magic != b"glTF" or json_type != b"JSON":
        raise ValueError(f"{glb} is not a binary glTF")
    document = json.loads(data[20:20 + json_length])
    binary_start = 20 + json_length + 8
    views, accessors = document["bufferViews"], document["accessors"]
    parts = []
    for accessor in accessors[:2]:
        view = views[accessor["bufferView"]]
        start = binary_start + view.get("byteOffset", 0) + accessor.get("byteOffset", 0)
        parts.append(data[start:start + view["byteLength"]])
    return parts[0], parts[1], accessors[1]["count"] // 3


def ply_from_glb(glb: Path, ply: Path) -> None:
    """The peers' PLY (as convert.write_ply writes it) from the converted .glb, without numpy."""
    positions, indices, triangles = read_matte_glb(glb)
    header = (
        "ply\nformat binary_little_endian 1.0\n"
        f"element vertex {len(positions) // 12}\nproperty float x\nproperty float y\nproperty float z\n"
        f"element face {triangles}\nproperty list uchar int vertex_indices\nend_header\n"
    )
    # Each face record: the count 3 (one byte), then its three indices (u32 < 2³¹, so as i32).
    faces = bytearray(13 * triangles)
    faces[0::13] = b"\x03" * triangles
    for byte in range(12):
        faces[1 + byte::13] = indices[byte::12]
    with open(ply, "wb") as out:
        out.write(header.encode("ascii"))
        out.write(positions)
        out.write(faces)


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


def time_rs_pbrt(rs_pbrt: str, ply: Path, size: int, spp: int, timeout: float | None) -> dict:
    """Two runs, at 1 spp and at `spp`: the difference is the sampling, the rest set-up."""
    seconds = {}
    for n in (1, spp):
        scene = WORK / f"{ply.stem}.rs_pbrt_{n}spp.pbrt"
        write_pbrt_scene(scene, ply, size, n)
        start = time.perf_counter()
        result = run_render([rs_pbrt, "--path", scene.name], timeout, "rs_pbrt", cwd=WORK)
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


def time_mitsuba(variant: str, ply: Path, size: int, spp: int, settings: dict, timeout: float | None) -> dict:
    env = dict(os.environ)
    if variant.startswith("llvm"):
        libllvm = find_libllvm()
        if not libllvm:
            raise RuntimeError("libLLVM 19 not found (apt-get install libllvm19)")
        env["DRJIT_LIBLLVM_PATH"] = libllvm
    result = run_render(
        [sys.executable, str(Path(__file__).with_name("mitsuba_run.py")), variant, str(ply),
         str(size), str(size), str(spp), str(DEPTH + 1), json.dumps(settings),
         str(ply.with_suffix(f".mitsuba_{variant}.exr"))],
        timeout, f"Mitsuba {variant}",
        env=env,
    )
    if result.returncode != 0:
        raise RuntimeError(f"Mitsuba {variant} failed: {result.stderr[-1500:]}")
    return json.loads(result.stdout.strip().splitlines()[-1])


def time_realcam(realcam: str, glb: Path, size: int, spp: int, dispersion: bool, device: str,
                 threads: int | None, timeout: float | None) -> dict:
    tag = f"{device}{'' if dispersion else '.rgb'}"
    stats = WORK / f"realcam_stats.{glb.stem}.{tag}.json"
    stats.unlink(missing_ok=True)
    look_from, look_at = ",".join(map(str, EYE)), ",".join(map(str, TARGET))
    command = [
        realcam, "render", str(glb), "--lens", LENS, "--aperture", str(STOP_MM),
        "--film-diagonal", str(FILM_DIAGONAL_MM), "--look-from", look_from, "--look-at", look_at,
        "--env", "1,1,1", "--width", str(size), "--height", str(size), "--spp", str(spp),
        "--max-depth", str(DEPTH), "--dispersion", "on" if dispersion else "off",
        "--out", str(glb.with_suffix(f".realcam.{tag}.png")), "--stats", str(stats),
    ]
    # The flag only where it matters: a realcam from before --device still renders the CPU rows.
    if device != "cpu":
        command += ["--device", device]
    if threads is not None and device == "cpu":
        command += ["--threads", str(threads)]
    what = f"realcam --device {device}"
    result = run_render(command, timeout, what)
    if result.returncode != 0:
        message = (result.stderr or result.stdout).strip()[-1500:]
        if "--device" in message and ("unexpected argument" in message or "invalid value" in message):
            message = f"this realcam ({realcam}) cannot render on {device}: {message}"
        raise RuntimeError(f"{what} failed (exit {result.returncode}): {message}")
    s = json.loads(stats.read_text())
    stage = s.get("stage_seconds", {})
    load = stage.get("load_scene", 0.0) + stage.get("build_bvh", 0.0)
    row = {
        "samples_per_second": s["samples_per_second"],
        "setup_seconds": load + s.get("lens_derivation", {}).get("seconds", 0.0),
        "load_seconds": load,
        "wall_seconds": s["wall_seconds"],
    }
    # Which device rendered (realcam's own report), to tell a GPU row from a silent fallback.
    for key in ("device", "gpu_adapter"):
        if s.get(key) is not None:
            row[key] = s[key]
    return row


def median_of(runs: list[dict]) -> dict:
    """Each number's median over the rounds; text fields (device, adapter) from the first."""
    return {
        key: statistics.median(r[key] for r in runs) if isinstance(runs[0][key], (int, float)) else runs[0][key]
        for key in runs[0]
    }


def print_table(title: str, results: dict, failures: dict) -> None:
    print()
    print(title)
    print(f"{'renderer':<40}{'camera':<34}{'M samples/s':>12}{'set-up s':>10}{'load+BVH s':>11}"
          f"{'realcam ÷ it':>14}{'rgb realcam ÷ it':>18}{'gpu realcam ÷ it':>18}")
    ours = results.get("realcam", {}).get("samples_per_second")
    ours_rgb = results.get("realcam --dispersion off", {}).get("samples_per_second")
    ours_gpu = results.get("realcam --device gpu", {}).get("samples_per_second")
    for name, r in results.items():
        ratio = f"{ours / r['samples_per_second']:.2f}×" if ours else "-"
        ratio_rgb = f"{ours_rgb / r['samples_per_second']:.2f}×" if ours_rgb else "-"
        ratio_gpu = f"{ours_gpu / r['samples_per_second']:.2f}×" if ours_gpu else "-"
        load = "-" if r["load_seconds"] != r["load_seconds"] else f"{r['load_seconds']:.2f}"
        print(f"{name:<40}{r['camera']:<34}{r['samples_per_second'] / 1e6:>12.3f}"
              f"{r['setup_seconds']:>10.2f}{load:>11}{ratio:>14}{ratio_rgb:>18}{ratio_gpu:>18}")
    for name, why in failures.items():
        print(f"{name:<40}{'no figure: ' + why.splitlines()[0][:200]}")
    adapters = {r["gpu_adapter"] for r in results.values() if r.get("gpu_adapter")}
    for adapter in sorted(adapters):
        print(f"realcam's GPU rows rendered on: {adapter}")


def comma_list(text: str, known: tuple[str, ...], option: str, parser: argparse.ArgumentParser) -> list[str]:
    items = [item.strip() for item in text.split(",") if item.strip()]
    unknown = [item for item in items if item not in known]
    if unknown or not items:
        parser.error(f"{option}: unknown {', '.join(unknown) or '(none given)'}; known: {', '.join(known)}")
    return list(dict.fromkeys(items))


def main() -> None:
    global WORK
    signal.signal(signal.SIGTERM, stop_renders)
    signal.signal(signal.SIGINT, stop_renders)
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--spp", type=int, default=64)
    parser.add_argument("--size", type=int, default=320)
    parser.add_argument("--repeat", type=int, default=1, help="runs per renderer (median)")
    parser.add_argument("--skip-install", action="store_true")
    parser.add_argument("--scenes", default="helmet,spheres",
                        help=f"comma-separated, of: {', '.join(SCENES)}")
    parser.add_argument("--device", default="cpu",
                        help=f"realcam's devices, comma-separated, of: {', '.join(DEVICES)} (default cpu)")
    parser.add_argument("--threads", type=int, help="realcam's CPU worker threads (default: all cores)")
    parser.add_argument("--peers", default="all",
                        help=f"all, none, or comma-separated, of: {', '.join(PEERS)} (default all)")
    parser.add_argument("--realcam", type=Path, help="a prebuilt realcam binary (no cargo build)")
    parser.add_argument("--work", type=Path, default=WORK,
                        help="where the converted scenes are written or read (default target/peers)")
    parser.add_argument("--skip-convert", action="store_true",
                        help="use <work>/<scene>.glb as converted earlier (no numpy, pygltflib or shared scenes)")
    parser.add_argument("--timeout", type=float, help="seconds any one render may take (default: no limit)")
    parser.add_argument("--results", type=Path, help="results JSON (default <work>/results.json)")
    args = parser.parse_args()
    scenes = comma_list(args.scenes, tuple(SCENES), "--scenes", parser)
    devices = comma_list(args.device, DEVICES, "--device", parser)
    if args.peers == "all":
        peers = list(PEERS)
    elif args.peers == "none":
        peers = []
    else:
        peers = comma_list(args.peers, PEERS, "--peers", parser)
    if args.threads is not None and args.threads < 1:
        parser.error("--threads: at least 1")
    if args.realcam is not None and not (args.realcam.is_file() and os.access(args.realcam, os.X_OK)):
        parser.error(f"--realcam: {args.realcam} is not an executable file")
    WORK = args.work.resolve()
    WORK.mkdir(parents=True, exist_ok=True)
    results_path = args.results or WORK / "results.json"

    if not args.skip_install:
        install_python_packages()
        if "llvm_ad_rgb" in peers:
            install_libllvm()
        if "rs_pbrt" in peers:
            install_rs_pbrt()
    realcam = str(args.realcam.resolve()) if args.realcam else build_realcam()
    convert = None
    if not args.skip_convert:
        sys.path.insert(0, str(Path(__file__).parent))
        from convert import convert

    settings = lens_settings(realcam)
    say(f"{args.size}² px, {args.spp} spp, depth {DEPTH}; thin lens fov {settings['fov_x_deg']:.2f}°, "
        f"aperture radius {settings['aperture_radius_m'] * 1000:.2f} mm; realcam {realcam} on "
        f"{', '.join(devices)}" + (f", {args.threads} CPU threads" if args.threads else ""))
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    rs_pbrt = cargo_bin("rs_pbrt") if "rs_pbrt" in peers else None
    if "rs_pbrt" in peers and not rs_pbrt:
        say("rs_pbrt is not installed (cargo install rs_pbrt --locked failed or was skipped): skipped")
        peers.remove("rs_pbrt")
    mitsuba_wanted = [p for p in peers if p.endswith("_rgb")]
    variants = mitsuba_variants() if mitsuba_wanted else []
    if mitsuba_wanted and variants is None:
        say("mitsuba does not import (pip install mitsuba, or --skip-install left it out): its rows skipped")
        peers = [p for p in peers if p not in mitsuba_wanted]
    elif "cuda_ad_rgb" in peers:
        if "cuda_ad_rgb" not in variants:
            say(f"this Mitsuba has no cuda_ad_rgb variant (it has {', '.join(variants)}): that row skipped")
            peers.remove("cuda_ad_rgb")
        elif not cuda_devices():
            say("no CUDA device (libcuda.so.1 absent or no device found): Mitsuba cuda_ad_rgb skipped")
            peers.remove("cuda_ad_rgb")
    devices_report = None
    if "gpu" in devices:
        try:
            devices_report = run_render([realcam, "devices"], 30, "realcam devices")
            say("realcam devices:\n" + (devices_report.stdout + devices_report.stderr).strip())
        except TimedOut as error:
            say(str(error))

    all_results = {}

    def write_results() -> None:
        """After every scene, so that a run stopped from outside keeps the scenes it finished."""
        results_path.parent.mkdir(parents=True, exist_ok=True)
        results_path.write_text(json.dumps(
            {"load_average": load, "size": args.size, "spp": args.spp, "depth": DEPTH,
             "devices": devices, "threads": args.threads, "cpus": os.cpu_count(), "realcam": realcam,
             "realcam_devices": (devices_report.stdout + devices_report.stderr) if devices_report else None,
             "settings": settings, "scenes": all_results}, indent=2))

    warmed_up: set[str] = set()  # the GPU renderers that rendered once, unmeasured
    for scene_name in scenes:
        source, fit = SCENES[scene_name]
        source = SHARED / "scenes" / source
        ply, glb = WORK / f"{scene_name}.ply", WORK / f"{scene_name}.glb"
        if args.skip_convert:
            if not glb.exists():
                say(f"{glb} not found (--skip-convert: run once without it, or copy the converted scenes "
                    f"into {WORK}): {scene_name} skipped")
                continue
            triangles = read_matte_glb(glb)[2]
            if peers and not ply.exists():
                say(f"{ply.name} missing: written from {glb.name}")
                ply_from_glb(glb, ply)
        else:
            if not source.exists():
                say(f"{source} not found (set REALCAM_SHARED to the shared data folder): {scene_name} skipped")
                continue
            triangles, _ = convert(source, ply, glb, ALBEDO, fit)
        say(f"{scene_name} ({source.stem}): {triangles} triangles")

        renderers = []
        for device in devices:
            prefix = "realcam" if device == "cpu" else f"realcam --device {device}"
            where = "" if device == "cpu" else f", {device}"
            for dispersion in (True, False):
                renderers.append((
                    prefix if dispersion else f"{prefix} --dispersion off",
                    f"real lens {LENS}, {'spectral' if dispersion else 'RGB'}{where}",
                    lambda device=device, dispersion=dispersion: time_realcam(
                        realcam, glb, args.size, args.spp, dispersion, device, args.threads, args.timeout),
                ))
        if "rs_pbrt" in peers:
            renderers.append(("rs_pbrt", f"realistic {LENS}",
                              lambda: time_rs_pbrt(rs_pbrt or "", ply, args.size, args.spp, args.timeout)))
        for variant in ("scalar_rgb", "llvm_ad_rgb", "cuda_ad_rgb"):
            if variant in peers:
                renderers.append((f"mitsuba {variant}", "thin lens" + (", gpu" if variant.startswith("cuda") else ""),
                                  lambda variant=variant: time_mitsuba(
                                      variant, ply, args.size, args.spp, settings, args.timeout)))
        # Rounds go through every renderer in turn, so a change in the machine's load hits all
        # of them alike; each renderer's median round is reported.
        runs: dict[str, list[dict]] = {name: [] for name, _, _ in renderers}
        failures: dict[str, str] = {}
        # The first GPU render on a freshly started machine ran at a third of the speed of the
        # next (H200, 2026-11-27: 95 and 80 against 280 M samples/s, realcam's pass time, set-up
        # excluded): the driver compiles and caches the kernels and the GPU clocks up. So each
        # GPU renderer renders once, unmeasured, before the rounds of the first scene.
        for name, _, measure in renderers:
            if "--device" in name and name not in warmed_up:
                warmed_up.add(name)
                try:
                    say(f"{scene_name}: warming up {name} (not measured)")
                    measure()
                except Exception as error:
                    say(f"{name}: warm-up failed: {error}")
        for round_index in range(args.repeat):
            for name, camera, measure in renderers:
                if name in failures:
                    continue
                try:
                    say(f"{scene_name}, round {round_index + 1}/{args.repeat}: rendering with {name}")
                    started = time.perf_counter()
                    runs[name].append(measure())
                    say(f"{name}: {runs[name][-1]['samples_per_second'] / 1e6:.3f} M samples/s "
                        f"({time.perf_counter() - started:.1f} s)")
                except Exception as error:  # a peer that fails is reported, the others go on
                    say(f"{name}: {error}")
                    failures[name] = str(error)
                    if isinstance(error, TimedOut) and name.startswith("realcam --device gpu"):
                        for other, _, _ in renderers:
                            if other.startswith("realcam --device gpu") and other not in failures:
                                failures[other] = f"skipped: {name} timed out on this scene"
                                say(f"{other}: {failures[other]}")
        results = {
            name: {"camera": camera, **median_of(runs[name])}
            for name, camera, _ in renderers
            if runs[name]
        }
        all_results[scene_name] = {"source": source.name, "triangles": triangles, "results": results,
                                   "failures": failures}
        write_results()
        print_table(
            f"{source.stem} ({triangles} triangles) {args.size}×{args.size}, {args.spp} spp, depth {DEPTH}, "
            f"matte {ALBEDO}, white sky; load average {load:.2f} at the start, on {os.cpu_count()} CPUs"
            + (f", realcam CPU on {args.threads} threads" if args.threads else ""),
            results, failures,
        )
    print()
    print("realcam ÷ it: spectral (the default with dgauss.50mm's glass data); rgb realcam ÷ it: "
          "--dispersion off, like for like with the RGB thin-lens peers; gpu realcam ÷ it: "
          "realcam --device gpu, spectral.")
    write_results()
    say(f"results: {results_path}")


if __name__ == "__main__":
    main()
