#!/usr/bin/env bash
# realcam's GPU path (issue 26) against its CPU path and Mitsuba 3 on a GPU machine: the one
# script to run there, from the repository root, in one short run (about 8 minutes at most).
#
#   REALCAM=.bin/realcam OUT=/some/folder benches/gpu/device_run.sh
#
# Needs in the working tree (ignored folders, copied along): the release binary at $REALCAM
# (default .bin/realcam, built elsewhere: nothing can be built there), the converted peer scenes
# in .peers/ (helmet.glb, spheres.glb, as benches/peers/compare.py writes them; the .ply files
# are written from them when a peer needs them), the Vulkan loader and GL vendor libraries as
# Debian packages in .gl/ (../shared/notes/gpu-device.md), and optionally Mitsuba 3 + Dr.Jit
# wheels in .whl/ (then the Mitsuba cuda_ad_rgb rows run). Python 3 with the standard library is
# enough. In order, most important first, each step skipped once the time is nearly spent:
#   1. compare.py, realcam --device cpu and gpu (and Mitsuba cuda_ad_rgb where it can), both
#      scenes, 640² at 64 spp (plus realcam's images, as images_640.tar);
#   2. the same on the GPU alone (and Mitsuba cuda_ad_rgb) at 1280², 256 spp, for the scenes
#      whose step-1 GPU rate says they finish in time;
#   3. the CPU path's thread scaling, both scenes: 1 thread and all cores (16), 640² at 16 spp;
#   4. `realcam bench --device gpu`: the lens-tracing workload on the GPU beside the CPU kernels;
#   5. the live lab's first image after a change at 1024² on the GPU (live_latency.py);
#   6. the CPU path's scaling stage by stage: 1, 2, 4, 8 and all cores, both scenes, ${SIZE}² at
#      $SPP spp (all cores three times), each render's --stats (wall and busy seconds per stage)
#      kept in scaling.tar;
#   7. the GPU's cost of the wavelengths a sample carries: `--wavelengths 1`, the default and
#      `--dispersion off`, both scenes, ${SIZE}² at $SPP spp, three rounds (gpu_wavelengths.tar);
#   8. benches/gpu/variants.py once per file named in $VARIANT_FILES (its arguments, one a line:
#      variants of the binary side by side, e.g. benches/gpu/probes/), results variants_*.json;
#   9. the machine's ceiling: the same one-thread work (the lens kernel's bench, then a render of
#      each scene at ${SIZE}², $SCALE_SPP spp) alone and as $THREADS_MAX copies at once, beside
#      one $THREADS_MAX-thread render (ceiling.tar);
#   0. (first, when $TESTS names the library's unit-test binary, built here with
#      `cargo test --release --lib --no-run`) the GPU unit tests against the CPU, on this GPU.
# STEPS picks which run (default "0 1 2 3 4 5"; step 0 only with $TESTS).
# then a summary of M camera samples/s per row. Each render stops after $GPU_TIMEOUT seconds
# (default 120), says so, and the rest go on; sizes and budget are the variables below (a
# quick try elsewhere: SIZE=64 SPP=4 BIG_SIZE=128 BIG_SPP=8 SCALE_SPP=2). Everything lands in
# $OUT (at most 8 files): log.txt, results_*.json, images_640.tar, summary.txt.
set -uo pipefail
cd "$(dirname "$0")/../.."
REALCAM=${REALCAM:-.bin/realcam}
OUT=${OUT:-target/device_run}
GPU_TIMEOUT=${GPU_TIMEOUT:-120}
BUDGET=${BUDGET:-450}          # seconds for the whole script; a step is skipped once it is spent
THREADS_MAX=${THREADS_MAX:-$(nproc)}
WORK=${WORK:-.peers}
SIZE=${SIZE:-640} SPP=${SPP:-64}                  # step 1
BIG_SIZE=${BIG_SIZE:-1280} BIG_SPP=${BIG_SPP:-256}  # step 2
SCALE_SPP=${SCALE_SPP:-16}                      # step 3, at $SIZE
LADDER=${LADDER:-1 2 4 8 $THREADS_MAX $THREADS_MAX $THREADS_MAX}  # step 6's thread counts, in order
STEPS=${STEPS:-0 1 2 3 4 5}
REPEAT=${REPEAT:-1}                             # rounds per renderer in steps 1–3 (median)
TESTS=${TESTS:-}
want() { [[ " $STEPS " == *" $1 "* ]]; }
mkdir -p "$OUT"
exec > >(tee "$OUT/log.txt") 2>&1
tee_pid=$!
export PYTHONUNBUFFERED=1
left() { echo $((BUDGET - SECONDS)); }
step() { echo; echo "=== [$SECONDS s] $*"; }

step "set-up"
# The Vulkan loader and the GL vendor libraries, as the notes say; only on the GPU machine (the
# NVIDIA driver mounted at /usr/local/nvidia), never on a development machine's /.
if [ -d /usr/local/nvidia ] && [ -d .gl ] && ! ldconfig -p | grep -q 'libvulkan.so.1 '; then
  for f in .gl/libvulkan1*.deb .gl/libegl1*.deb .gl/libglvnd0*.deb .gl/libopengl0*.deb \
           .gl/libgl1*.deb .gl/libglx0*.deb .gl/libgles2*.deb; do dpkg -x "$f" /; done
  mkdir -p /tmp/x; for f in .gl/libx*.deb .gl/libbsd*.deb .gl/libmd*.deb; do dpkg -x "$f" /tmp/x; done
  ldconfig
  export LD_LIBRARY_PATH=/tmp/x/usr/lib/x86_64-linux-gnu:/tmp/x/lib/x86_64-linux-gnu${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}
  echo "unpacked .gl (Vulkan loader, glvnd, X libraries)"
fi
icd=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
[ -f "$icd" ] && export VK_DRIVER_FILES=$icd
egl=/usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json
[ -f "$egl" ] && export __EGL_VENDOR_LIBRARY_FILENAMES=$egl
export XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-/tmp/xdg-runtime}; mkdir -p -m 700 "$XDG_RUNTIME_DIR"
if compgen -G '.whl/*.whl' >/dev/null; then
  python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade --target /tmp/site .whl/*.whl \
    && export PYTHONPATH=/tmp/site${PYTHONPATH:+:$PYTHONPATH} && echo "installed .whl into /tmp/site"
fi
nvidia-smi -L 2>&1 || echo "nvidia-smi: not available"
lscpu 2>/dev/null | grep -E '^(Model name|CPU\(s\)|Thread|Core|Socket|NUMA node\(s\)|L3|CPU max MHz)' || true
nproc; python3 --version
if [ ! -x "$REALCAM" ]; then echo "no realcam binary at $REALCAM (set REALCAM)"; exit 2; fi
sha256sum "$REALCAM"; "$REALCAM" --version
timeout 30 "$REALCAM" devices 2>&1 || echo "realcam devices failed or timed out"
python3 -c 'import mitsuba; print("mitsuba", mitsuba.__version__, mitsuba.variants())' 2>&1 | tail -1
ls -la "$WORK"

compare() { # compare.py with the common options; the outer timeout keeps the budget
  local limit; limit=$(left)
  [ "$limit" -gt 10 ] || { echo "skipped: the time budget ($BUDGET s) is spent"; return 1; }
  timeout -k 5 "$limit" python3 benches/peers/compare.py --skip-install --skip-convert \
    --realcam "$REALCAM" --work "$WORK" --timeout "$GPU_TIMEOUT" --repeat "$REPEAT" "$@"
  local rc=$?; [ $rc -eq 124 ] && echo "compare.py stopped at the time budget"; return 0
}

if want 0 && [ -n "$TESTS" ]; then
  step "0. the GPU unit tests (gpu::) on this GPU"
  # The tests read tests/data at the path they were built in (CARGO_MANIFEST_DIR).
  REALCAM_REQUIRE_GPU=1 timeout 120 "$TESTS" gpu:: 2>&1 | tail -25
fi

if want 1; then
step "1. realcam cpu and gpu (and Mitsuba cuda_ad_rgb where present), ${SIZE}², $SPP spp"
first=$OUT/results_${SIZE}_${SPP}spp.json
rm -f "$WORK"/*.realcam.*.png
compare --device cpu,gpu --peers cuda_ad_rgb --size "$SIZE" --spp "$SPP" --results "$first"
(cd "$WORK" && tar -cf - *.realcam.*.png) > "$OUT/images_$SIZE.tar" 2>/dev/null || echo "no images to keep"
fi

if want 2; then
step "2. realcam gpu (and Mitsuba cuda_ad_rgb), ${BIG_SIZE}², $BIG_SPP spp"
# Only the scenes whose 640² GPU rate says both GPU renders finish within the per-render
# timeout and the time left (16× the work of step 1).
scenes=$(python3 - "$first" "$GPU_TIMEOUT" "$(left)" "$BIG_SIZE" "$BIG_SPP" <<'PY'
import json, sys
try:
    scenes = json.load(open(sys.argv[1]))["scenes"]
except (OSError, ValueError, KeyError):
    sys.exit(0)
timeout, left = float(sys.argv[2]), float(sys.argv[3]) - 30
samples = int(sys.argv[4]) ** 2 * int(sys.argv[5])
chosen, total = [], 0.0
for name, scene in scenes.items():
    rows = scene["results"]
    rates = [rows[r]["samples_per_second"] for r in ("realcam --device gpu", "realcam --device gpu --dispersion off") if r in rows]
    if len(rates) < 2:
        continue
    seconds = [samples / rate for rate in rates]
    setup = max(rows[r]["setup_seconds"] for r in rows if r.startswith("realcam --device gpu"))
    if max(seconds) + setup < 0.8 * timeout and total + sum(seconds) + 2 * setup < left:
        chosen.append(name)
        total += sum(seconds) + 2 * setup
    else:
        print(f"{name}: the GPU rate predicts {max(seconds):.0f} s a render: skipped at this size", file=sys.stderr)
print(",".join(chosen))
PY
)
if [ -n "$scenes" ]; then
  compare --device gpu --peers cuda_ad_rgb --scenes "$scenes" --size "$BIG_SIZE" --spp "$BIG_SPP" \
    --results "$OUT/results_${BIG_SIZE}_${BIG_SPP}spp.json"
else
  echo "skipped: no scene's GPU rows in step 1 were fast enough (see above)"
fi
fi

if want 3; then
step "3. the CPU path's thread scaling: 1 and $THREADS_MAX threads, ${SIZE}², $SCALE_SPP spp"
for threads in 1 "$THREADS_MAX"; do
  compare --device cpu --threads "$threads" --peers none --size "$SIZE" --spp "$SCALE_SPP" --results "$OUT/results_threads$threads.json"
done
fi

# One render with compare.py's peer settings; its --stats to $1 (the remaining arguments are
# added to the command line). Its image and errors go to files of its own process, so that
# renders run at once (step 9) do not share them.
render_peer() {
  local stats=$1 glb=$2; shift 2
  timeout -k 5 "$GPU_TIMEOUT" "$REALCAM" render "$WORK/$glb.glb" --lens dgauss.50mm --aperture 8 \
    --film-diagonal 35 --look-from 0,0,4.5 --look-at 0,0,0 --env 1,1,1 --width "$SIZE" \
    --height "$SIZE" --spp "$SPP" --max-depth 5 --out "/tmp/render.$BASHPID.png" --stats "$stats" "$@" \
    >/dev/null 2>"/tmp/render.$BASHPID.err" || { echo "render failed: $*"; tail -3 "/tmp/render.$BASHPID.err"; }
}

if want 6; then
  step "6. the CPU path's scaling stage by stage, ${SIZE}², $SPP spp"
  rm -rf /tmp/scaling; mkdir -p /tmp/scaling
  for scene in helmet spheres; do
    for threads in $LADDER; do
      [ "$(left)" -gt 30 ] || { echo "skipped: the time budget is spent"; break 2; }
      n=$(ls /tmp/scaling | grep -c "^$scene.t$threads\." || true)
      render_peer "/tmp/scaling/$scene.t$threads.$n.json" "$scene" --threads "$threads"
    done
    for threads in 1 "$THREADS_MAX"; do
      render_peer "/tmp/scaling/$scene.rgb.t$threads.0.json" "$scene" --threads "$threads" --dispersion off
    done
  done
  (cd /tmp/scaling && tar -cf - *.json) > "$OUT/scaling.tar"
  python3 - /tmp/scaling <<'PY'
import glob, json, os, sys
rows = {}
for path in sorted(glob.glob(os.path.join(sys.argv[1], "*.json"))):
    name = os.path.basename(path)[:-len(".json")]
    key = name.rsplit(".", 1)[0]
    rows.setdefault(key, []).append(json.load(open(path)))
def pick(runs):  # the median run by pass rate
    return sorted(runs, key=lambda s: s["samples_per_second"])[len(runs) // 2]
for key in sorted(rows, key=lambda k: (k.split(".t")[0], int(k.split(".t")[1]))):
    s = pick(rows[key]); wall = s["stage_seconds"]; busy = s.get("stage_busy_seconds", {})
    threads = s.get("threads", 0) or 1
    rates = ", ".join(f"{r['samples_per_second'] / 1e6:.2f}" for r in rows[key])
    print(f"{key:<16} {s['samples_per_second'] / 1e6:7.2f} M/s (runs {rates}); wall {s['wall_seconds']:.2f} s;"
          f" load {wall.get('load_scene', 0):.2f} bvh {wall.get('build_bvh', 0):.2f}")
    for stage in ("generate_rays", "trace", "shade", "land_companions", "weight", "write_film"):
        if stage in wall and wall[stage] > 0:
            b = busy.get(stage, 0.0)
            print(f"    {stage:<14} wall {wall[stage]:7.3f} s  busy {b:7.3f} s  busy/(wall×threads) {b / (wall[stage] * threads):.2f}")
for scene in ("helmet", "spheres", "helmet.rgb", "spheres.rgb"):
    one = rows.get(f"{scene}.t1")
    if not one:
        continue
    for key in rows:
        if key.startswith(scene + ".t") and key != f"{scene}.t1":
            print(f"scaling {scene}: {key.split('.t')[-1]} threads ÷ 1 = {pick(rows[key])['samples_per_second'] / pick(one)['samples_per_second']:.2f}×")
PY
fi

if want 7; then
  step "7. the GPU's cost of the wavelengths a sample carries, ${SIZE}², $SPP spp"
  rm -rf /tmp/gpuw; mkdir -p /tmp/gpuw
  for round in 0 1 2; do
    for scene in helmet spheres; do
      [ "$(left)" -gt 20 ] || { echo "skipped: the time budget is spent"; break 2; }
      render_peer "/tmp/gpuw/$scene.w1.$round.json" "$scene" --device gpu --wavelengths 1
      render_peer "/tmp/gpuw/$scene.default.$round.json" "$scene" --device gpu
      render_peer "/tmp/gpuw/$scene.rgb.$round.json" "$scene" --device gpu --dispersion off
    done
  done
  (cd /tmp/gpuw && tar -cf - *.json) > "$OUT/gpu_wavelengths.tar"
  python3 - /tmp/gpuw <<'PY'
import glob, json, os, statistics, sys
rates = {}
for path in glob.glob(os.path.join(sys.argv[1], "*.json")):
    key = os.path.basename(path).rsplit(".", 2)[0]
    rates.setdefault(key, []).append(json.load(open(path))["samples_per_second"] / 1e6)
for key in sorted(rates):
    print(f"{key:<18} median {statistics.median(rates[key]):8.1f} M/s  runs {', '.join(f'{r:.1f}' for r in sorted(rates[key]))}")
for scene in ("helmet", "spheres"):
    if f"{scene}.w1" in rates and f"{scene}.default" in rates:
        w1, d = statistics.median(rates[f"{scene}.w1"]), statistics.median(rates[f"{scene}.default"])
        print(f"{scene}: default ÷ --wavelengths 1 time = {w1 / d:.2f}×")
PY
fi

if want 8; then
  for args in ${VARIANT_FILES:-}; do
    step "8. variants side by side: $args"
    [ "$(left)" -gt 20 ] || { echo "skipped: the time budget is spent"; break; }
    timeout -k 5 "$(left)" python3 benches/gpu/variants.py "@$args" --work "$WORK" \
      --budget "$(( $(left) - 15 ))" --results "$OUT/variants_$(basename "$args" .args).json"
  done
fi

if want 9; then
  # What one core does when every core is busy, whatever realcam's threading does: the same
  # one-thread work run alone and as $THREADS_MAX copies at once (separate processes: no shared
  # state, no barrier). The copies' summed rate is the ceiling a $THREADS_MAX-thread render can
  # reach on this machine; the render's own rate against it is what realcam's threading loses.
  step "9. the machine's ceiling: one-thread work alone and as $THREADS_MAX copies at once, ${SIZE}², $SCALE_SPP spp"
  rm -rf /tmp/ceiling; mkdir -p /tmp/ceiling
  at_once() { # $1 count, then a command run that many times at once, each with its index added
    local count=$1 pids=(); shift
    for k in $(seq 1 "$count"); do "$@" "$k" & pids+=($!); done
    wait "${pids[@]}" # by name: a bare `wait` would wait for the log's tee too
  }
  kernel_bench() { # $1 label, $2 index
    "$REALCAM" bench --json --rays 65536 --rounds 3 >"/tmp/ceiling/kernel.$1.$2.out" 2>/dev/null
  }
  one_thread_render() { # $1 scene, $2 label, $3 index
    SPP=$SCALE_SPP render_peer "/tmp/ceiling/$1.$2.$3.json" "$1" --threads 1
  }
  for round in 0 1; do
    [ "$(left)" -gt 60 ] || { echo "skipped: the time budget is spent"; break; }
    at_once 1 kernel_bench "alone.r$round"
    at_once "$THREADS_MAX" kernel_bench "copies.r$round"
    for scene in helmet spheres; do
      [ "$(left)" -gt 45 ] || { echo "skipped: the time budget is spent"; break 2; }
      at_once 1 one_thread_render "$scene" "alone.r$round"
      at_once "$THREADS_MAX" one_thread_render "$scene" "copies.r$round"
      SPP=$SCALE_SPP render_peer "/tmp/ceiling/$scene.threads.r$round.json" "$scene" --threads "$THREADS_MAX"
    done
  done
  (cd /tmp/ceiling && tar -cf - *) > "$OUT/ceiling.tar"
  python3 - /tmp/ceiling "$THREADS_MAX" <<'PY'
import glob, json, os, statistics, sys
folder, n = sys.argv[1], int(sys.argv[2])
def rate(path):
    text = open(path).read()
    if not text.strip():
        return None
    data = json.loads(text)
    return data.get("samples_per_second") or data.get("soa_rays_per_s")
def rounds(pattern):  # per round: the list of rates of that round's processes
    out = {}
    for path in glob.glob(os.path.join(folder, pattern)):
        r = rate(path)
        if r:
            out.setdefault(os.path.basename(path).split(".r")[1].split(".")[0], []).append(r)
    return out
for name, ext, unit in (("kernel", "out", "M rays/s (lens kernel, avx512)"), ("helmet", "json", "M samples/s"), ("spheres", "json", "M samples/s")):
    alone, copies = rounds(f"{name}.alone.r*.{ext}"), rounds(f"{name}.copies.r*.{ext}")
    threads = rounds(f"{name}.threads.r*.{ext}")
    for r in sorted(alone):
        a = alone[r][0] / 1e6
        c = copies.get(r, [])
        line = f"{name:<8} round {r}: alone {a:7.2f} {unit}"
        if len(c) == n:
            per, total = statistics.median(c) / 1e6, sum(c) / 1e6
            line += f"; {n} copies: each {per:.2f} (median, {per / a:.2f}× alone), together {total:.2f} = {total / a:.2f}× one"
        elif c:
            line += f"; only {len(c)} of {n} copies reported"
        if r in threads:
            t = threads[r][0] / 1e6
            line += f"; {n} threads {t:.2f} = {t / a:.2f}× one"
            if len(c) == n:
                line += f", {t / (sum(c) / 1e6):.2f}× the copies"
        print(line)
PY
fi

if want 4; then
  step "4. realcam bench --device gpu (the lens-tracing workload)"
  timeout 120 "$REALCAM" bench --device gpu 2>&1
fi

if want 5; then
  step "5. the live lab on the GPU: first image after a change, 1024²"
  timeout 120 python3 benches/gpu/live_latency.py --realcam "$REALCAM" --device gpu --size 1024 --changes 12 2>&1
fi

step "summary"
python3 - "$OUT" <<'PY' | tee "$OUT/summary.txt"
import glob, json, os, sys
print(f"{'run':<28}{'scene':<9}{'row':<40}{'M samples/s':>12}  device / note")
rates = {}
for path in sorted(glob.glob(os.path.join(sys.argv[1], "results_*.json"))):
    run = os.path.basename(path)[len("results_"):-len(".json")]
    data = json.load(open(path))
    for scene, s in data["scenes"].items():
        for row, r in s["results"].items():
            rates[run, scene, row] = r["samples_per_second"]
            note = r.get("gpu_adapter") or r.get("device") or ""
            print(f"{run:<28}{scene:<9}{row:<40}{r['samples_per_second'] / 1e6:>12.3f}  {note}")
        for row, why in s.get("failures", {}).items():
            print(f"{run:<28}{scene:<9}{row:<40}{'-':>12}  {why.splitlines()[0][:120]}")
print()
for (run, scene, row), rate in sorted(rates.items()):
    if not row.startswith("realcam --device gpu"):
        continue
    cpu = "realcam --dispersion off" if row.endswith("--dispersion off") else "realcam"
    for base in (cpu, "mitsuba cuda_ad_rgb"):
        if (run, scene, base) in rates:
            print(f"{run} {scene}: {row} ÷ {base} = {rate / rates[run, scene, base]:.2f}×")
for key in sorted(k for k in rates if k[0] == "threads1"):
    many = [k for k in rates if k[0].startswith("threads") and k[0] != "threads1" and k[1:] == key[1:]]
    for other in many:
        print(f"scaling {key[1]} {key[2]}: {other[0][len('threads'):]} threads ÷ 1 thread = {rates[other] / rates[key]:.2f}×")
PY
echo "done in $SECONDS s"
exec >&- 2>&-
wait "$tee_pid" 2>/dev/null
