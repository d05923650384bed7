#!/bin/bash
# The time ratio of `cargo bench --bench colour_noise` measured more tightly: the bench's 64-spp
# renders (default scene, 256², tent filter, seed 3) through the four course lenses, three
# rounds interleaved, a binary BEFORE and AFTER a change side by side (spectral, three
# wavelengths) beside AFTER's RGB render (`--dispersion off`). Prints each render's wall
# seconds, then per lens the fastest of the rounds and spectral ÷ RGB for each binary.
#
#   bash benches/colour_noise_times.sh BEFORE AFTER     # two realcam binaries
set -euo pipefail
before=${1:?a realcam binary (before)}
after=${2:?a realcam binary (after)}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
lenses="dgauss.50mm wide.22mm telephoto.250mm fisheye.10mm"
for lens in $lenses; do
  for round in 1 2 3; do
    for run in "before:$before:--wavelengths 3" "after:$after:--wavelengths 3" "rgb:$after:--dispersion off"; do
      IFS=: read -r name binary flags <<<"$run"
      # shellcheck disable=SC2086 # the flags are two words
      "$binary" render --lens "$lens" --width 256 --height 256 --spp 64 --seed 3 --filter tent \
        $flags --out "$work/r.png" --stats "$work/s.json" >/dev/null 2>&1
      python3 -c "import json,sys; print(sys.argv[1], sys.argv[2], round(json.load(open(sys.argv[3]))['wall_seconds'], 3))" \
        "$lens" "$name" "$work/s.json"
    done
  done
done | tee "$work/times.txt"
python3 - "$work/times.txt" <<'PY'
import collections, sys
times = collections.defaultdict(list)
for line in open(sys.argv[1]):
    lens, name, seconds = line.split()
    times[lens, name].append(float(seconds))
print(f"{'lens':<16} {'before s':>9} {'after s':>9} {'rgb s':>9} {'before/rgb':>11} {'after/rgb':>10}")
for lens in dict.fromkeys(lens for lens, _ in times):
    b, a, r = (min(times[lens, n]) for n in ("before", "after", "rgb"))
    print(f"{lens:<16} {b:>9.3f} {a:>9.3f} {r:>9.3f} {b / r:>11.3f} {a / r:>10.3f}")
PY
