#!/usr/bin/env bash
# Whole-frame camera samples/s of several realcam binaries on the peer scene, interleaved
# rounds so machine load hits all alike; prints the median of each.
#   benches/peers/milestones.sh ROUNDS BINARY...
# (the peer scene target/peers/${SCENE:-helmet}.glb is written by benches/peers/compare.py;
# SCENE=spheres for the 1M-triangle one)
set -euo pipefail
rounds=$1; shift
scene=target/peers/${SCENE:-helmet}.glb
out=$(mktemp -d)
for round in $(seq "$rounds"); do
  for binary in "$@"; do
    "$binary" render "$scene" --lens dgauss.50mm --aperture 8 --film-diagonal 35 \
      --look-from 0,0,4.5 --look-at 0,0,0 --env 1,1,1 --width 320 --height 320 --spp 64 \
      --max-depth 5 --out "$out/x.png" --stats "$out/s.json" 2>/dev/null
    python3 -c "import json,sys; print(sys.argv[1], json.load(open(sys.argv[2]))['samples_per_second'])" \
      "$(basename "$binary")" "$out/s.json" >> "$out/rates"
  done
done
python3 - "$out/rates" "$@" <<'PY'
import statistics, sys, os
rates = {}
for line in open(sys.argv[1]):
    name, rate = line.split()
    rates.setdefault(name, []).append(float(rate))
for binary in sys.argv[2:]:
    name = os.path.basename(binary)
    r = rates[name]
    print(f"{name:32} median {statistics.median(r)/1e6:6.3f} M samples/s  (runs: {', '.join(f'{x/1e6:.3f}' for x in r)})")
PY
