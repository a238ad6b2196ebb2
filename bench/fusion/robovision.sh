#!/bin/bash
# Robovision scenes end to end, one `dome run` per scene:
#   bench/fusion/robovision.sh DOME OUT [SCENE...]
# For each scene of ../shared/data/robovision (default: all):
#   1. dome import halcon SCENE --out OUT/SCENE/take
#   2. OUT/SCENE/session.json (proto/runtime.proto Session), from the scene:
#      * volume: the reference's bounding box + MARGIN (default 10 %) on every side
#        (a stated choice: the reference only bounds the region; nothing else of it is
#        used), voxels of VOXEL_MM (default 0.15 mm);
#      * stereo: depth range = the nearest and farthest volume corner over all cameras
#        (+-2 mm); contrast normalisation (the images are dark); NEIGHBOURS (default 2)
#        nearest cameras, i.e. the two ring neighbours 30 degrees away (those 60 degrees
#        away see the surface too obliquely for square windows and take most pixels'
#        minima below the uniqueness margin); uniqueness margin UNIQ (default 0.1);
#        window(s) WINDOWS (default 17);
#      * fusion: truncation and free-space clamp TRUNC_VOXELS voxels (default 1.5);
#        optionally CONSISTENT other cameras must agree with a depth sample
#        (fusion/consistency.h) and voxels need MIN_WEIGHT images (both off by default);
#   3. dome run session.json --out OUT/SCENE/run (timed: the whole pipeline);
#   4. ../shared/tools/eval_cloud.py --recon-unit 1 of OUT/SCENE/run/<instant>/mesh.ply
#      against reference.ply.
# Prints one JSON line per scene (OUT/SCENE/result.json) and a table of every scene under
# OUT beside the best figures of the issue's baselines.
set -euo pipefail
DOME=$(realpath "$1"); OUT=$2; shift 2
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
DATA=${DATA:-$ROOT/../shared/data/robovision}
EVAL=$ROOT/../shared/tools/eval_cloud.py
VOXEL_MM=${VOXEL_MM:-0.15}
MARGIN=${MARGIN:-0.1}
UNIQ=${UNIQ:-0.1}
WINDOWS=${WINDOWS:-17}
NEIGHBOURS=${NEIGHBOURS:-2}
CONSISTENT=${CONSISTENT:-0}
TRUNC_VOXELS=${TRUNC_VOXELS:-1.5}
MIN_WEIGHT=${MIN_WEIGHT:-0}
WORKERS=${WORKERS:-2}
# Heartbeat intervals before an in-process worker is presumed lost (dome run
# --heartbeat-liveness; empty: dome's default). On a loaded machine the master can be
# busy for seconds writing a result, and a stereo job is then lost and redone.
LIVENESS=${LIVENESS-30}
SCENES=("$@")
if [ ${#SCENES[@]} -eq 0 ]; then SCENES=($(ls "$DATA")); fi
mkdir -p "$OUT"
for scene in "${SCENES[@]}"; do
  src=$DATA/$scene; dst=$OUT/$scene
  [ -f "$src/reference.ply" ] || continue
  rm -rf "$dst"; mkdir -p "$dst"
  "$DOME" import halcon "$src" --out "$dst/take" > "$dst/import.log" 2>&1
  /usr/bin/python3 - "$src/reference.ply" "$dst/take" "$dst/session.json" <<PY
import json, sys
import numpy as np
ply, take, session = sys.argv[1:4]
vox, margin = float("$VOXEL_MM"), float("$MARGIN")
lines = open(ply).read().splitlines()
n = next(int(l.split()[-1]) for l in lines if l.startswith("element vertex"))
start = lines.index("end_header") + 1
pts = np.array([[float(v) for v in l.split()[:3]] for l in lines[start:start + n]]) * 1000.0
lo, hi = pts.min(0), pts.max(0)
pad = margin * (hi - lo)
lo, hi = lo - pad, hi + pad
dims = np.ceil((hi - lo) / vox).astype(int)
corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
zs = []
for c in json.load(open(take + "/rig.json"))["cameras"]:
    R = np.array(c["rotation"]).reshape(3, 3); t = np.array(c["translation_mm"])
    zs.extend((corners @ R.T + t)[:, 2])
s = {"take": take, "out": "",
     "stereo": {"z_min_mm": max(1.0, min(zs) - 2), "z_max_mm": max(zs) + 2,
                "window_sizes_px": [int(w) for w in "$WINDOWS".split()],
                "normalize_contrast": True, "min_uniqueness": float("$UNIQ"),
                "max_neighbours": int("$NEIGHBOURS")},
     "volume": {"origin_mm": [float(v) for v in lo], "voxel_size_mm": vox,
                "dims": [int(d) for d in dims]},
     "fusion": {"truncation_mm": float("$TRUNC_VOXELS") * vox,
                "front_clamp_mm": float("$TRUNC_VOXELS") * vox},
     "slab_planes": int(dims[2] + 1) // 2 + 1, "decimate_ratio": 0.5, "texture": False,
     "write_previews": False}
# Only what is asked for: the fields stay readable by builds without them.
if int("$CONSISTENT") > 0: s["fusion"]["min_consistent_views"] = int("$CONSISTENT")
if float("$MIN_WEIGHT") > 0: s["fusion"]["min_weight"] = float("$MIN_WEIGHT")
json.dump(s, open(session, "w"), indent=1)
PY
  t0=$(date +%s.%N)
  if ! "$DOME" run "$dst/session.json" --out "$dst/run" --workers "$WORKERS" \
    ${LIVENESS:+--heartbeat-liveness "$LIVENESS"} > "$dst/run.log" 2>&1; then
    echo "{\"scene\": \"$scene\", \"error\": \"dome run failed, see $dst/run.log\"}" | tee "$dst/result.json"
    continue
  fi
  t1=$(date +%s.%N)
  mesh=$(ls "$dst"/run/*/mesh.ply | head -1)
  /usr/bin/python3 "$EVAL" "$mesh" "$src/reference.ply" --recon-unit 1 --thresholds 0.5 1 2 \
    > "$dst/eval.json" 2> "$dst/eval.log"
  /usr/bin/python3 - "$scene" "$dst/eval.json" "$t0" "$t1" "$dst/run/report.json" <<'PY' | tee "$dst/result.json"
import json, sys
scene, ev_path, t0, t1, report = sys.argv[1], sys.argv[2], float(sys.argv[3]), float(sys.argv[4]), sys.argv[5]
ev = json.loads(open(ev_path).read().strip().splitlines()[-1])
try:
    stages = {k: v.get("job_seconds") for k, v in json.load(open(report)).get("stages", {}).items()}
except Exception:
    stages = {}
print(json.dumps({"scene": scene, "eval": ev, "seconds": t1 - t0, "stages": stages}))
PY
done
# The issue's table: best p90 / F@0.5 / completeness@0.5 of any baseline column, and the
# full-resolution SGBM+TSDF mesh (completeness and time to beat).
/usr/bin/python3 - "$OUT"/*/result.json <<'PY'
import json, sys
best = {"2016_10_24__17_43_02": (0.29, 0.975, 0.958, 12.0), "2016_10_24__17_44_40": (0.33, 0.956, 0.940, 18.0),
        "2016_10_24__18_26_08": (0.37, 0.937, 0.946, 11.0), "2016_10_25__12_11_32": (0.67, 0.816, 0.540, 10.5)}
def find(ev, *names):
    for k in names:
        if k in ev: return ev[k]
    return float("nan")
print("| scene | p90 acc mm (best baseline) | F@0.5 (best) | compl@0.5 (TSDF full) | s (TSDF full) |")
print("|---|---|---|---|---|")
for path in sys.argv[1:]:
    r = json.loads(open(path).read().strip().splitlines()[-1]); b = best.get(r["scene"], (float("nan"),) * 4)
    if "eval" not in r:
        print("| %s | %s | | | |" % (r["scene"], r.get("error"))); continue
    ev = r["eval"]
    p90 = find(ev, "acc_p90_mm")
    f05 = find(ev, "fscore@0.5mm")
    c05 = find(ev, "completeness@0.5mm")
    print("| %s | %.2f (%.2f) | %.3f (%.3f) | %.3f (%.3f) | %.0f (%.1f) |" % (
        r["scene"], p90, b[0], f05, b[1], c05, b[2], r["seconds"], b[3]))
PY
