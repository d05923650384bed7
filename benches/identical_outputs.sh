#!/usr/bin/env bash
# Renders a fixed set of jobs with the realcam binary $1 into folder $2, so that two builds can
# be compared file by file (`cmp`): a refactor must leave every output byte-identical.
#   benches/identical_outputs.sh old/realcam /tmp/old; benches/identical_outputs.sh target/release/realcam /tmp/new
#   for f in /tmp/old/*; do cmp "$f" "/tmp/new/${f##*/}" && echo "same ${f##*/}"; done
set -euo pipefail
bin=$(realpath "$1"); out=$2; data=$(cd "$(dirname "$0")/../tests/data" && pwd)
mkdir -p "$out"; cd "$out"
"$bin" render --out default.png --exr default.exr 2>/dev/null
"$bin" render "$data/CornellBox/"*.gltf --spp 16 --width 160 --height 120 --out cornell.png --exr cornell.exr 2>/dev/null
"$bin" render "$data/Duck/Duck.gltf" --spp 8 --width 128 --height 128 --lens wide.22mm --f-number 4 --env 0.5,0.7,1 --out duck.png 2>/dev/null
"$bin" render "$data/BoxTextured/BoxTextured.gltf" --spp 4 --width 96 --height 64 --focus-sweep 0.5:5:3 --out box.png 2>/dev/null
"$bin" render --spp 4 --width 128 --height 128 --lens dgauss.50mm --lens telephoto.250mm --shift 1,2 --out two.png 2>/dev/null
"$bin" render --spp 4 --width 128 --height 128 --blades 6 --f-number 2.8 --dispersion off --seed 7 --out blades.png 2>/dev/null
ls
