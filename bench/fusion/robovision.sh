#!/bin/bash
# Robovision scenes through the default path, one reconstruction per scene:
#   bench/fusion/robovision.sh DOME OUT [SCENE...]
# For each scene of ../shared/data/robovision (default: all):
#   1. dome import halcon SCENE --out OUT/SCENE/take (not timed);
#   2. dome run OUT/SCENE/take --out OUT/SCENE/run with no reconstruction options: the
#      volume, voxel, depth range, grey mapping and the rest are derived from the take
#      (pipeline/derive.h; OUT/SCENE/run/report.json "derived" says how), timed (wall,
#      and CPU as user + system);
#   3. ../shared/tools/eval_cloud.py --recon-unit 1 of OUT/SCENE/run/<instant>/mesh.ply
#      against reference.ply — the reference is used for nothing else but the table's
#      box column (its bounding box beside the derived volume).
# WORKERS embedded workers of THREADS threads (default 0 and 0: dome run's own choice,
# one worker of every thread for these one-instant takes). Prints one JSON line per scene (OUT/SCENE/result.json) and a table of every
# scene under OUT.
set -euo pipefail
DOME=$(realpath "$1"); OUT=$2; shift 2
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
DATA=${DATA:-$ROOT/../shared/data/robovision}
EVAL=$ROOT/../shared/tools/eval_cloud.py
WORKERS=${WORKERS:-0}
THREADS=${THREADS:-0}
SCENES=("$@")
if [ ${#SCENES[@]} -eq 0 ]; then SCENES=($(ls "$DATA")); fi
mkdir -p "$OUT"
for scene in "${SCENES[@]}"; do
  src=$DATA/$scene; dst=$OUT/$scene
  [ -f "$src/reference.ply" ] || continue
  rm -rf "$dst"; mkdir -p "$dst"
  "$DOME" import halcon "$src" --out "$dst/take" > "$dst/import.log" 2>&1
  t0=$(date +%s.%N)
  if ! /usr/bin/time -f "%U %S" -o "$dst/cpu.txt" "$DOME" run "$dst/take" --out "$dst/run" \
      --workers "$WORKERS" --threads "$THREADS" > "$dst/run.log" 2>&1; then
    echo "{\"scene\": \"$scene\", \"error\": \"dome run failed, see $dst/run.log\"}" | tee "$dst/result.json"
    continue
  fi
  t1=$(date +%s.%N)
  mesh=$(ls "$dst"/run/*/mesh.ply | head -1)
  /usr/bin/python3 "$EVAL" "$mesh" "$src/reference.ply" --recon-unit 1 --thresholds 0.5 1 2 \
    > "$dst/eval.json" 2> "$dst/eval.log"
  /usr/bin/python3 - "$scene" "$dst/eval.json" "$t0" "$t1" "$dst/run/report.json" "$dst/cpu.txt" \
      "$src/reference.ply" <<'PY' | tee "$dst/result.json"
import json, sys
import numpy as np
scene, ev_path, t0, t1, report, cpu_path, ref = sys.argv[1:8]
cpu = sum(float(v) for v in open(cpu_path).read().split()[-2:])  # user + system, s
ev = json.loads(open(ev_path).read().strip().splitlines()[-1])
r = json.load(open(report))
stages = {k: v.get("job_seconds") for k, v in r.get("stages", {}).items()}
v = r["volume"]
lo = np.array(v["origin_mm"]); hi = lo + v["voxel_size_mm"] * np.array(v["dims"])
lines = open(ref).read().splitlines()
n = next(int(l.split()[-1]) for l in lines if l.startswith("element vertex"))
start = lines.index("end_header") + 1
pts = np.array([[float(x) for x in l.split()[:3]] for l in lines[start:start + n]]) * 1000.0
print(json.dumps({"scene": scene, "eval": ev, "seconds": float(t1) - float(t0), "cpu_seconds": cpu,
                  "stages": stages, "volume_mm": [list(lo.round(1)), list(hi.round(1))],
                  "voxel_mm": v["voxel_size_mm"],
                  "reference_box_mm": [list(pts.min(0).round(1)), list(pts.max(0).round(1))]}))
PY
done
/usr/bin/python3 - "$OUT"/*/result.json <<'PY'
import json, sys
print("| scene | p90 acc mm | F@0.5 | compl@0.5 | wall s | CPU s | derived volume mm (voxel) | reference box mm |")
print("|---|---|---|---|---|---|---|---|")
for path in sys.argv[1:]:
    r = json.loads(open(path).read().strip().splitlines()[-1])
    if "eval" not in r:
        print("| %s | %s | | | | | | |" % (r["scene"], r.get("error"))); continue
    ev = r["eval"]
    box = lambda b: "%s .. %s" % (" ".join("%.1f" % x for x in b[0]), " ".join("%.1f" % x for x in b[1]))
    print("| %s | %.3f | %.4f | %.4f | %.1f | %.1f | %s (%.3f) | %s |" % (
        r["scene"], ev["acc_p90_mm"], ev["fscore@0.5mm"], ev["completeness@0.5mm"], r["seconds"],
        r["cpu_seconds"], box(r["volume_mm"]), r["voxel_mm"], box(r["reference_box_mm"])))
PY
