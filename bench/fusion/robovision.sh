#!/bin/bash
# Robovision scenes end to end, one reconstruction per scene (the issue's table):
#   bench/fusion/robovision.sh DOME OUT [SCENE...]
# For each scene of ../shared/data/robovision (default: all):
#   1. the volume box: the reference's bounding box + MARGIN (default 5 %) of its size on
#      every side (a stated choice: the reference only bounds the region; nothing else
#      of it is used);
#   2. dome import halcon SCENE --out OUT/SCENE/take, with CROP=1 (default) every frame
#      cut to where the box projects, CROP_MARGIN_PX (default 16) pixels around it
#      (pipeline/take_crop.h: nothing the volume can hold is lost);
#   3. OUT/SCENE/session.json (proto/runtime.proto Session): voxels of VOXEL_MM (default
#      0.15 mm) over the box; stereo depth range = the nearest and farthest box corner
#      over all cameras (+-2 mm), level step STEP_PX (default 1 px), contrast
#      normalisation (the images are dark), with SQRT_GREYS=1 (default) the square roots
#      of the greys matched (multi_baseline.h sqrt_greys: shot noise levelled),
#      NEIGHBOURS (default 2) nearest cameras, i.e. the two ring neighbours 30 degrees
#      away, uniqueness margin UNIQ (default 0.02),
#      depth pieces of fewer than SPECKLE_AREA px (default 20000, about 3 % of a cropped
#      frame) dropped, a piece's 4-neighbours within SPECKLE_STEP_MM (default 0.3 mm,
#      two voxels) of each other (stereo/speckle.h),
#      window(s) WINDOWS (default 11); fusion truncation and free-space clamp
#      TRUNC_VOXELS voxels (default 1.0), optionally CONSISTENT other cameras must agree
#      with a depth sample to CONSISTENCY_MM (default one voxel; fusion/consistency.h)
#      and voxels need MIN_WEIGHT images;
#   4. the reconstruction, timed (wall and CPU seconds, user + system; the import is
#      not timed):
#      * STEREO=run (default): dome run session.json --out OUT/SCENE/run --workers WORKERS
#        (default 1) --threads THREADS (default 2), SLAB_PLANES (24) planes per fusion
#        job, SMOOTH (default 10) Taubin lambda|mu pairs on mesh.ply (mesh/smooth.h),
#        decimation ratio DECIMATE (default 1: none, mesh.ply is what is evaluated);
#        with C2F=1 (default) the session's stereo.coarse_to_fine block holds the C2F_*
#        values below and the volume box as clip box (each camera's depth range: its
#        nearest and farthest box corner +-2 mm); C2F=0: the full-range search;
#        (coarse to fine, stereo/coarse_to_fine.h: images reduced C2F_FACTOR (4) times
#        and matched with window C2F_WINDOW (7) and uniqueness C2F_UNIQ (0.5); tiles of
#        C2F_TILE (64) px with at least C2F_MIN_COARSE (8) coarse depths around them
#        search those depths (C2F_TRIM (0.2) of them dropped at each end) +- C2F_MARGIN
#        (2) coarse levels, tiles with fewer but at least C2F_FILL (1) searched tiles
#        around them the union of those tiles' depths (0: none); EXACT_WARP=1: no
#        pre-warped neighbours);
#      * STEREO=c2f: the same stereo options (OUT/SCENE/stereo.json, the session's
#        "stereo" object) through `dome stereo --options`, then `dome fuse --depth-dir`
#        with the session's volume and fusion options: the commands' path, which must
#        give what dome run gives;
#   5. ../shared/tools/eval_cloud.py --recon-unit 1 of OUT/SCENE/run/<instant>/mesh.ply
#      against reference.ply.
# Prints one JSON line per scene (OUT/SCENE/result.json) and a table of every scene under
# OUT beside the best figures of the issue's baselines.
set -euo pipefail
DOME=$(realpath "$1"); OUT=$2; shift 2
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
DATA=${DATA:-$ROOT/../shared/data/robovision}
EVAL=$ROOT/../shared/tools/eval_cloud.py
VOXEL_MM=${VOXEL_MM:-0.15}
MARGIN=${MARGIN:-0.05}
UNIQ=${UNIQ:-0.02}
SQRT_GREYS=${SQRT_GREYS:-1}
SPECKLE_AREA=${SPECKLE_AREA:-20000}
SPECKLE_STEP_MM=${SPECKLE_STEP_MM:-0.3}
WINDOWS=${WINDOWS:-11}
NEIGHBOURS=${NEIGHBOURS:-2}
CONSISTENT=${CONSISTENT:-0}
TRUNC_VOXELS=${TRUNC_VOXELS:-1.0}
CLAMP_VOXELS=${CLAMP_VOXELS:-$TRUNC_VOXELS}
MIN_WEIGHT=${MIN_WEIGHT:-0}
CONSISTENCY_MM=${CONSISTENCY_MM:-0}
STEP_PX=${STEP_PX:-1}
STEREO=${STEREO:-run}
C2F=${C2F:-1}
EXACT_WARP=${EXACT_WARP:-}
C2F_FACTOR=${C2F_FACTOR:-4}
C2F_WINDOW=${C2F_WINDOW:-7}
C2F_TILE=${C2F_TILE:-64}
C2F_MARGIN=${C2F_MARGIN:-2}
C2F_MIN_COARSE=${C2F_MIN_COARSE:-8}
C2F_TRIM=${C2F_TRIM:-0.2}
C2F_UNIQ=${C2F_UNIQ:-0.5}
C2F_FILL=${C2F_FILL:-1}
CROP=${CROP:-1}
CROP_MARGIN_PX=${CROP_MARGIN_PX:-16}
# One take instant: one in-process worker with both threads keeps every stage parallel
# (its slab jobs share one set of fusion tables); several workers pay off over instants.
WORKERS=${WORKERS:-1}
THREADS=${THREADS:-2}
SLAB_PLANES=${SLAB_PLANES:-24}
# The evaluated mesh is mesh.ply; 1 leaves it undecimated (the baselines do not decimate).
DECIMATE=${DECIMATE:-1}
# Taubin smoothing of mesh.ply (mesh/smooth.h), lambda|mu pairs; 0: none.
SMOOTH=${SMOOTH:-10}
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
  # The volume box: the reference's bounding box + MARGIN of its size on every side.
  /usr/bin/python3 - "$src/reference.ply" > "$dst/box.txt" <<PY
import sys
import numpy as np
lines = open(sys.argv[1]).read().splitlines()
n = next(int(l.split()[-1]) for l in lines if l.startswith("element vertex"))
start = lines.index("end_header") + 1
pts = np.array([[float(v) for v in l.split()[:3]] for l in lines[start:start + n]]) * 1000.0
lo, hi = pts.min(0), pts.max(0)
pad = float("$MARGIN") * (hi - lo)
print(" ".join("%.4f" % v for v in list(lo - pad) + list(hi + pad)))
PY
  crop=()
  if [ "$CROP" = 1 ]; then
    crop=(--crop-box $(cat "$dst/box.txt") --crop-margin-px "$CROP_MARGIN_PX")
  fi
  "$DOME" import halcon "$src" --out "$dst/take" "${crop[@]}" > "$dst/import.log" 2>&1
  /usr/bin/python3 - "$dst/box.txt" "$dst/take" "$dst/session.json" <<PY
import json, sys
import numpy as np
box, take, session = sys.argv[1:4]
vox = float("$VOXEL_MM")
b = np.array([float(v) for v in open(box).read().split()])
lo, hi = b[:3], b[3:]
dims = np.ceil((hi - lo) / vox).astype(int)
corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
zs = []
for c in json.load(open(take + "/rig.json"))["cameras"]:
    R = np.array(c["rotation"]).reshape(3, 3); t = np.array(c["translation_mm"])
    zs.extend((corners @ R.T + t)[:, 2])
s = {"take": take, "out": "",
     "stereo": {"z_min_mm": max(1.0, min(zs) - 2), "z_max_mm": max(zs) + 2,
                "window_sizes_px": [int(w) for w in "$WINDOWS".split()],
                "level_step_px": float("$STEP_PX"),
                "normalize_contrast": True, "sqrt_greys": "$SQRT_GREYS" == "1",
                "min_uniqueness": float("$UNIQ"),
                "max_neighbours": int("$NEIGHBOURS"),
                "speckle_area_px": int("$SPECKLE_AREA"),
                "speckle_step_mm": float("$SPECKLE_STEP_MM")},
     "volume": {"origin_mm": [float(v) for v in lo], "voxel_size_mm": vox,
                "dims": [int(d) for d in dims]},
     "fusion": {"truncation_mm": float("$TRUNC_VOXELS") * vox,
                "front_clamp_mm": float("$CLAMP_VOXELS") * vox},
     "slab_planes": int("$SLAB_PLANES"), "decimate_ratio": float("$DECIMATE"), "texture": False,
     "smooth_iterations": int("$SMOOTH"),
     "write_previews": False}
# Only what is asked for: the fields stay readable by builds without them.
if int("$CONSISTENT") > 0: s["fusion"]["min_consistent_views"] = int("$CONSISTENT")
if float("$CONSISTENCY_MM") > 0: s["fusion"]["consistency_tolerance_mm"] = float("$CONSISTENCY_MM")
if float("$MIN_WEIGHT") > 0: s["fusion"]["min_weight"] = float("$MIN_WEIGHT")
if "$C2F" == "1":
    # Coarse to fine; each camera's depth range clipped to the volume box's corners
    # (+-2 mm).
    s["stereo"]["coarse_to_fine"] = {
        "coarse_factor": int("$C2F_FACTOR"), "coarse_window_px": int("$C2F_WINDOW"),
        "tile_px": int("$C2F_TILE"), "margin_levels": float("$C2F_MARGIN"),
        "trim_fraction": float("$C2F_TRIM"), "min_coarse_depths": int("$C2F_MIN_COARSE"),
        "coarse_min_uniqueness": float("$C2F_UNIQ"),
        "fill_min_neighbours": int("$C2F_FILL"),
        "clip_min_mm": [float(v) for v in lo], "clip_max_mm": [float(v) for v in hi],
        "clip_pad_mm": 2.0}
if "$EXACT_WARP" != "": s["stereo"]["prewarp_neighbours"] = False  # EXACT_WARP=1
json.dump(s, open(session, "w"), indent=1)
json.dump(s["stereo"], open(session.replace("session.json", "stereo.json"), "w"), indent=1)
PY
  t0=$(date +%s.%N)
  if [ "$STEREO" = c2f ]; then
    # The same stereo options through `dome stereo`, the same volume and fusion options
    # through `dome fuse`.
    fuse_args=($(/usr/bin/python3 -c "
import json; s = json.load(open('$dst/session.json')); v = s['volume']; f = s['fusion']
print(' '.join(['--voxel-mm', str(v['voxel_size_mm']), '--origin'] + [str(x) for x in v['origin_mm']]
               + ['--dims'] + [str(x) for x in v['dims']] + ['--slab-planes', str(s['slab_planes']),
               '--truncation-mm', str(f['truncation_mm']), '--clamp-mm', str(f['front_clamp_mm']),
               '--decimate-ratio', str(s['decimate_ratio']),
               '--smooth-iterations', str(s['smooth_iterations'])]
               + ['--consistent-views', str(f.get('min_consistent_views', 0)),
                  '--consistency-mm', str(f.get('consistency_tolerance_mm', v['voxel_size_mm'])),
                  '--min-weight', str(f.get('min_weight', 0))]))"))
    if ! /usr/bin/time -f "%U %S" -o "$dst/cpu_stereo.txt" "$DOME" stereo "$dst/take" \
        --options "$dst/stereo.json" --threads "$THREADS" --no-preview --out "$dst/depth" \
        > "$dst/stereo.log" 2>&1 ||
      ! /usr/bin/time -f "%U %S" -o "$dst/cpu_fuse.txt" "$DOME" fuse "$dst/take" \
        --depth-dir "$dst/depth" --out "$dst/run" --threads "$THREADS" "${fuse_args[@]}" \
        > "$dst/run.log" 2>&1; then
      echo "{\"scene\": \"$scene\", \"error\": \"dome stereo or dome fuse failed, see $dst\"}" |
        tee "$dst/result.json"
      continue
    fi
    t_stereo=$(awk '{print $1 + $2}' "$dst/cpu_stereo.txt")
    cat "$dst/cpu_stereo.txt" "$dst/cpu_fuse.txt" | awk '{u += $1; s += $2} END {print u, s}' \
      > "$dst/cpu.txt"
    echo "{\"stages\": {\"stereo_cpu\": $t_stereo, \"fuse_cpu\": $(awk '{print $1 + $2}' "$dst/cpu_fuse.txt")}}" \
      > "$dst/c2f_report.json"
  elif ! /usr/bin/time -f "%U %S" -o "$dst/cpu.txt" "$DOME" run "$dst/session.json" \
    --out "$dst/run" --workers "$WORKERS" --threads "$THREADS" ${LIVENESS:+--heartbeat-liveness "$LIVENESS"} \
    > "$dst/run.log" 2>&1; then
    echo "{\"scene\": \"$scene\", \"error\": \"dome run failed, see $dst/run.log\"}" | tee "$dst/result.json"
    continue
  fi
  t1=$(date +%s.%N)
  mesh=$(ls "$dst"/run/*/mesh.ply | head -1)
  /usr/bin/python3 "$EVAL" "$mesh" "$src/reference.ply" --recon-unit 1 --thresholds 0.5 1 2 \
    > "$dst/eval.json" 2> "$dst/eval.log"
  /usr/bin/python3 - "$scene" "$dst/eval.json" "$t0" "$t1" "$( [ "$STEREO" = c2f ] && echo "$dst/c2f_report.json" || echo "$dst/run/report.json")" "$dst/cpu.txt" <<'PY' | tee "$dst/result.json"
import json, sys
scene, ev_path, t0, t1, report = sys.argv[1], sys.argv[2], float(sys.argv[3]), float(sys.argv[4]), sys.argv[5]
cpu = sum(float(v) for v in open(sys.argv[6]).read().split()[-2:])  # user + system, s
ev = json.loads(open(ev_path).read().strip().splitlines()[-1])
try:
    stages = {k: v.get("job_seconds") if isinstance(v, dict) else v
              for k, v in json.load(open(report)).get("stages", {}).items()}
except Exception:
    stages = {}
print(json.dumps({"scene": scene, "eval": ev, "seconds": t1 - t0, "cpu_seconds": cpu,
                  "stages": stages}))
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
print("| scene | p90 acc mm (best baseline) | F@0.5 (best) | compl@0.5 (TSDF full) | s (TSDF full) | CPU s |")
print("|---|---|---|---|---|---|")
for path in sys.argv[1:]:
    r = json.loads(open(path).read().strip().splitlines()[-1]); b = best.get(r["scene"], (float("nan"),) * 4)
    if "eval" not in r:
        print("| %s | %s | | | |" % (r["scene"], r.get("error"))); continue
    ev = r["eval"]
    p90 = find(ev, "acc_p90_mm")
    f05 = find(ev, "fscore@0.5mm")
    c05 = find(ev, "completeness@0.5mm")
    print("| %s | %.2f (%.2f) | %.3f (%.3f) | %.3f (%.3f) | %.0f (%.1f) | %.0f |" % (
        r["scene"], p90, b[0], f05, b[1], c05, b[2], r["seconds"], b[3],
        r.get("cpu_seconds", float("nan"))))
PY
