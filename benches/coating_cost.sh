#!/bin/bash
# Frame time of realcam on the peer scenes: lossless lens, coated without ghosts, coated with ghosts.
cd "$(dirname "$0")/.."
P="--lens dgauss.50mm --aperture 8 --film-diagonal 35 --look-from 0,0,4.5 --look-at 0,0,0 --env 1,1,1 --width 320 --height 320 --spp 64 --max-depth 5"
for scene in helmet spheres; do
  for rep in 1 2 3; do
    for v in "ideal:--coating ideal" "single-noflare:--flare off" "single-flare:"; do
      name=${v%%:*}; args=${v#*:}
      s=$(date +%s.%N)
      ./target/release/realcam render .peers/$scene.glb $P $args --out /tmp/cost.png >/dev/null 2>&1
      e=$(date +%s.%N)
      echo "$scene $name $rep $(echo "$e - $s" | bc)"
    done
  done
done
