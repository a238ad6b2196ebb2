#!/bin/bash
# Robovision scenes end to end, one command:
#   bench/fusion/robovision.sh DOME OUT [SCENE...]
# For each scene of ../shared/data/robovision (default: all): dome import halcon ->
# dome stereo --profile real (contrast normalisation; depth range from the cameras and
# the reference's box) -> dome fuse (volume: the reference's bounding box + 10 %, voxel
# VOXEL_MM, default 0.5 mm) -> dome mesh (decimation inside fuse) ->
# ../shared/tools/eval_cloud.py --recon-unit 1 against reference.ply. Prints one JSON
# line per scene: p90 accuracy, F-score@0.5 mm, completeness@0.5 mm and seconds per stage.
set -euo pipefail
DOME=$(realpath "$1"); OUT=$2; shift 2
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
DATA=$ROOT/../shared/data/robovision
VOXEL_MM=${VOXEL_MM:-0.5}
THREADS=${THREADS:-2}
SCENES=("$@")
if [ ${#SCENES[@]} -eq 0 ]; then SCENES=($(ls "$DATA")); fi
mkdir -p "$OUT"
for scene in "${SCENES[@]}"; do
  src=$DATA/$scene; dst=$OUT/$scene
  [ -f "$src/reference.ply" ] || continue
  rm -rf "$dst"; mkdir -p "$dst"
  t0=$(date +%s.%N)
  "$DOME" import halcon "$src" --out "$dst/take" > "$dst/import.log" 2>&1
  t1=$(date +%s.%N)
  # Volume and depth range from the reference (metres -> mm) and the cameras.
  read -r ORIGIN DIMS ZMIN ZMAX < <(/usr/bin/python3 - "$src/reference.ply" "$dst/take/rig.json" "$VOXEL_MM" <<'PY'
import json, sys
import numpy as np
ply, rig, vox = sys.argv[1], sys.argv[2], float(sys.argv[3])
lines = open(ply).read().splitlines()
n = next(int(l.split()[-1]) for l in lines if l.startswith("element vertex"))
start = lines.index("end_header") + 1
pts = np.array([[float(v) for v in l.split()[:3]] for l in lines[start:start + n]]) * 1000.0
lo, hi = pts.min(0), pts.max(0)
pad = 0.1 * (hi - lo)
lo, hi = lo - pad, hi + pad
dims = np.ceil((hi - lo) / vox).astype(int)
zs = []
for c in json.load(open(rig))["cameras"]:
    R = np.array(c["rotation"]).reshape(3, 3); t = np.array(c["translation_mm"])
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    zs.extend((corners @ R.T + t)[:, 2])
print("%.3f,%.3f,%.3f %d,%d,%d %.1f %.1f" % (*lo, *dims, max(1.0, min(zs) - 5), max(zs) + 5))
PY
)
  "$DOME" stereo "$dst/take" --profile real --z-min "$ZMIN" --z-max "$ZMAX" --out "$dst/stereo" > "$dst/stereo.log" 2>&1
  t2=$(date +%s.%N)
  "$DOME" fuse "$dst/take" --depth-dir "$dst/stereo" --out "$dst/fused" --voxel-mm "$VOXEL_MM" \
    --origin ${ORIGIN//,/ } --dims ${DIMS//,/ } --threads "$THREADS" --decimate-ratio 0.5 \
    > "$dst/fuse.json" 2> "$dst/fuse.log"
  t3=$(date +%s.%N)
  mesh=$(ls "$dst"/fused/*/mesh.ply | head -1)
  /usr/bin/python3 "$ROOT/../shared/tools/eval_cloud.py" "$mesh" "$src/reference.ply" \
    --recon-unit 1 --thresholds 0.5 1 2 > "$dst/eval.json" 2> "$dst/eval.log"
  /usr/bin/python3 - "$scene" "$dst/eval.json" "$t0" "$t1" "$t2" "$t3" <<'PY'
import json, sys
scene, ev, t0, t1, t2, t3 = sys.argv[1], json.loads(open(sys.argv[2]).read().strip().splitlines()[-1]), *map(float, sys.argv[3:])
print(json.dumps({"scene": scene, "eval": ev, "seconds": {"import": t1 - t0, "stereo": t2 - t1,
                  "fuse_mesh": t3 - t2, "total": t3 - t0}}))
PY
done
