#!/usr/bin/env bash
# Installs dependencies, builds dome and runs the demo on built-in data: a synthetic
# dome take (exact ground truth) reconstructed instant by instant on the embedded
# cluster, and the real Robovision and Middlebury calibrations imported as takes, each
# validated by `dome info`. Outputs go to ./demo-out/.
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
# The capture path (seed §2.1): each camera's tape (FFV1 with VITC) on a simulated deck,
# its own dome-capture agent publishing the frames into a dome-master that stores them
# into a new take, progress from the master's status events (deploy/capture-demo.sh).
bash deploy/capture-demo.sh build/bin "$out/dome" "$out/dome-captured"
# Every instant reconstructed on the embedded cluster (a master and two workers in this
# process, the same scheduler and messages as dome-master): stereo, fusion slabs,
# marching cubes, decimation, texture, with a live progress display.
rm -rf "$out/dome-run"
$dome run "$out/dome" --out "$out/dome-run" --workers 2
python3 - "$out/dome-run/report.json" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
print(f"reconstructed {r['instants']} instants in {r['seconds']:.1f} s "
      f"({r['seconds_per_instant']:.1f} s per instant)")
PY
echo "outputs: $out/dome-run/<instant>/ (depth/, mesh.ply, mesh_decimated.ply," \
  "textured.obj/.png, textured.glb); timings: $out/dome-run/report.json;" \
  "look at them with: $dome view $out/dome-run --take $out/dome"
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
