#!/usr/bin/env bash
# The untuned Robovision path's time against the tuned session it replaced, side by side.
#
#   bash bench/fusion/robovision_time.sh build/bin/dome OUT [SCENE] [PAIRS]
#
# A: `dome import halcon SCENE` + `dome run TAKE` with no reconstruction options (the
#    default path; SAME=1 adds --decimate-ratio 1 --no-texture --no-preview: the tuned
#    session's output).
# B: the tuned session of the earlier bench/fusion/robovision.sh: its volume the
#    reference cloud's bounding box + 5 % a side (the reference is read here only to
#    build this baseline), frames cropped to that box at import, 0.15 mm voxels, window
#    11, uniqueness 0.02, two neighbours, speckle 20000 px / 0.3 mm, coarse to fine
#    clipped to the box, truncation one voxel, 10 smoothing iterations, no decimation,
#    texture or previews; run with 1 worker of 2 threads.
# Each path is what a user runs: its import, then `dome run`. PAIRS (default 5)
# alternating A B pairs of whole processes under /usr/bin/time (A's import and run, then
# B's import with the crop and run); prints each process and the medians of wall and CPU
# (user + system) seconds and of the per-pair ratios A/B, for `dome run` alone and for
# import + run. B's box is computed once, before (reading the reference is not counted).
set -euo pipefail
DOME=$(realpath "$1"); OUT=$2; SCENE=${3:-2016_10_24__17_43_02}; PAIRS=${4:-5}
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
SRC=${DATA:-$ROOT/../shared/data/robovision}/$SCENE
SAME=${SAME:-0}
[ -f "$SRC/reference.ply" ] || { echo "no scene at $SRC" >&2; exit 1; }
rm -rf "$OUT"; mkdir -p "$OUT"

"$DOME" import halcon "$SRC" --out "$OUT/take" > "$OUT/import.log" 2>&1
/usr/bin/python3 - "$SRC/reference.ply" > "$OUT/box.txt" <<'PY'
import sys
import numpy as np
lines = open(sys.argv[1], errors="replace").read().splitlines()
n = next(int(l.split()[-1]) for l in lines if l.startswith("element vertex"))
start = lines.index("end_header") + 1
pts = np.array([[float(v) for v in l.split()[:3]] for l in lines[start:start + n]]) * 1000.0
lo, hi = pts.min(0), pts.max(0)
pad = 0.05 * (hi - lo)
print(" ".join("%.4f" % v for v in list(lo - pad) + list(hi + pad)))
PY
"$DOME" import halcon "$SRC" --out "$OUT/tuned_take" --crop-box $(cat "$OUT/box.txt") \
  --crop-margin-px 16 > "$OUT/tuned_import.log" 2>&1
/usr/bin/python3 - "$OUT/box.txt" "$OUT/tuned_take" "$OUT/tuned_session.json" <<'PY'
import json, sys
import numpy as np
box, take, session = sys.argv[1:4]
vox = 0.15
b = np.array([float(v) for v in open(box).read().split()])
lo, hi = b[:3], b[3:]
corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
zs = []
for c in json.load(open(take + "/rig.json"))["cameras"]:
    R = np.array(c["rotation"]).reshape(3, 3); t = np.array(c["translation_mm"])
    zs.extend((corners @ R.T + t)[:, 2])
s = {"take": take, "out": "",
     "stereo": {"z_min_mm": max(1.0, min(zs) - 2), "z_max_mm": max(zs) + 2,
                "window_sizes_px": [11], "level_step_px": 1.0,
                "normalize_contrast": True, "sqrt_greys": True, "min_uniqueness": 0.02,
                "max_neighbours": 2, "speckle_area_px": 20000, "speckle_step_mm": 0.3,
                "coarse_to_fine": {
                    "coarse_factor": 4, "coarse_window_px": 7, "tile_px": 64,
                    "margin_levels": 2.0, "trim_fraction": 0.2, "min_coarse_depths": 8,
                    "coarse_min_uniqueness": 0.5, "fill_min_neighbours": 1,
                    "clip_min_mm": [float(v) for v in lo],
                    "clip_max_mm": [float(v) for v in hi], "clip_pad_mm": 2.0}},
     "volume": {"origin_mm": [float(v) for v in lo], "voxel_size_mm": vox,
                "dims": [int(d) for d in np.ceil((hi - lo) / vox)]},
     "fusion": {"truncation_mm": vox, "front_clamp_mm": vox},
     "slab_planes": 24, "decimate_ratio": 1.0, "texture": False, "smooth_iterations": 10,
     "write_previews": False}
json.dump(s, open(session, "w"), indent=1)
PY

extra=()
if [ "$SAME" = 1 ]; then extra=(--decimate-ratio 1 --no-texture --no-preview); fi
timed() {  # label, phase, command...
  local label=$1 phase=$2; shift 2
  /usr/bin/time -f "%e %U %S" -o "$OUT/time.txt" "$@" > "$OUT/$label-$phase.log" 2>&1
  awk -v l="$label" -v p="$phase" '{print l, p, $1, $2 + $3}' "$OUT/time.txt" | tee -a "$OUT/times.txt"
}
: > "$OUT/times.txt"
for ((i = 0; i < PAIRS; ++i)); do
  rm -rf "$OUT/take" "$OUT/a"
  timed A import "$DOME" import halcon "$SRC" --out "$OUT/take"
  timed A run "$DOME" run "$OUT/take" "${extra[@]}" --out "$OUT/a"
  rm -rf "$OUT/tuned_take" "$OUT/b"
  timed B import "$DOME" import halcon "$SRC" --out "$OUT/tuned_take" --crop-box $(cat "$OUT/box.txt") \
    --crop-margin-px 16
  timed B run "$DOME" run "$OUT/tuned_session.json" --workers 1 --threads 2 --out "$OUT/b"
done
/usr/bin/python3 - "$OUT/times.txt" <<'PY'
import statistics, sys
rows = [l.split() for l in open(sys.argv[1])]
med = statistics.median
def runs(label, phases):
    out = []
    for k in range(0, len(rows), 4):
        pair = [r for r in rows[k:k + 4] if r[0] == label and r[1] in phases]
        out.append((sum(float(r[2]) for r in pair), sum(float(r[3]) for r in pair)))
    return out
for name, phases in (("dome run", ("run",)), ("import + run", ("import", "run"))):
    a, b = runs("A", phases), runs("B", phases)
    print("%s: A (default path) wall %.2f s, CPU %.2f s; B (tuned) wall %.2f s, CPU %.2f s; "
          "A/B per pair, median: wall %.3fx, CPU %.3fx" % (
              name, med(x[0] for x in a), med(x[1] for x in a), med(x[0] for x in b),
              med(x[1] for x in b), med(x[0] / y[0] for x, y in zip(a, b)),
              med(x[1] / y[1] for x, y in zip(a, b))))
PY
