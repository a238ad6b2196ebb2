#!/usr/bin/env bash
# Installs dependencies, builds dome and runs the demo on built-in data: a synthetic
# dome take (exact ground truth) and the real Robovision and Middlebury calibrations
# imported as takes, each validated by `dome info`. Outputs go to ./demo-out/.
# Run as root on Debian 12 from the repository root: `bash deploy/demo.sh`.
set -euo pipefail
cd "$(dirname "$0")/.."
bash deploy/install-deps.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release
cmake --build build -j"$(nproc)" --target dome dome-master dome-worker dome-capture
dome=build/bin/dome
out=demo-out
mkdir -p "$out"
# The seed's experiment with exact ground truth: 51 cameras, 11 instants at 6 Hz.
$dome synth --preset paper --out "$out/dome" --overwrite
$dome info "$out/dome"
data=../shared/data
if [ -d "$data/robovision" ]; then
  scene=$(ls "$data/robovision" | head -n 1)
  $dome import halcon "$data/robovision/$scene" --out "$out/robovision" --overwrite
  $dome info "$out/robovision"
fi
if [ -d "$data/middlebury-mv/templeSparseRing" ]; then
  $dome import middlebury "$data/middlebury-mv/templeSparseRing/templeSR_par.txt" \
    --out "$out/temple" --overwrite
  $dome info "$out/temple"
fi
