#!/usr/bin/env bash
# The sparse-rig path (silhouettes, the hull's surface, photo carving) against exact
# truth, one command:
#
#   bench/silhouette/sparse_synth.sh BUILD_DIR WORK_DIR [CAMERAS...] [-- DOME_RUN_ARGS...]
#
# For each camera count (default: 6 and 10; the synthetic dome's cameras are then 70 and
# 41 degrees apart, both sparse by pipeline/derive.h): `dome synth --preset paper
# --cameras N --instants 2 --width 640 --height 490` (masks from its background plates),
# `dome run` with the default path (plus DOME_RUN_ARGS), then `batter_eval` against the
# truth meshes. Prints per camera count the derived volume and, per instant, the
# person's accuracy (median and 90th percentile, mm), completeness within 10 and 20 mm
# and the bat barrel's completeness within 10 mm. Panoptic has no truth mesh; this is
# the exact check of the same path (bench/silhouette/panoptic_loo.sh is the real one).
set -euo pipefail
if [[ $# -lt 2 ]]; then
  echo "usage: $0 BUILD_DIR WORK_DIR [CAMERAS...] [-- DOME_RUN_ARGS...]" >&2
  exit 2
fi
build=$(realpath "$1")
work=$2
shift 2
counts=()
while [[ $# -gt 0 && "$1" != "--" ]]; do
  counts+=("$1")
  shift
done
[[ "${1:-}" == "--" ]] && shift
run_args=("$@")
[[ ${#counts[@]} -gt 0 ]] || counts=(6 10)
dome=$build/bin/dome
for f in "$dome" "$build/bin/batter_eval"; do
  [[ -x "$f" ]] || { echo "$0: $f: missing" >&2; exit 2; }
done
mkdir -p "$work"
for n in "${counts[@]}"; do
  take=$work/take_$n
  out=$work/out_$n
  [[ -f "$take/rig.json" ]] ||
    "$dome" synth --preset paper --cameras "$n" --instants 2 --width 640 --height 490 \
      --out "$take" --overwrite >"$work/synth_$n.log" 2>&1 ||
    { echo "$0: dome synth of $n cameras failed, see $work/synth_$n.log" >&2; exit 1; }
  rm -rf "$out"
  "$dome" run "$take" --out "$out" "${run_args[@]}" >"$work/run_$n.log" 2>&1 ||
    { echo "$0: dome run of $n cameras failed, see $work/run_$n.log" >&2; exit 1; }
  "$build/bin/batter_eval" "$take" "$out" >"$work/eval_$n.json" 2>"$work/eval_$n.log" ||
    { echo "$0: batter_eval of $n cameras failed, see $work/eval_$n.log" >&2; exit 1; }
  /usr/bin/python3 - "$n" "$out/report.json" "$work/eval_$n.json" <<'PY'
import json, sys
n, report, evals = sys.argv[1:4]
v = json.load(open(report))["volume"]
lo = v["origin_mm"]
hi = [o + d * v["voxel_size_mm"] for o, d in zip(lo, v["dims"])]
print("%s cameras: volume [%s] .. [%s] mm, voxel %.2f mm" % (
    n, " ".join("%.0f" % x for x in lo), " ".join("%.0f" % x for x in hi), v["voxel_size_mm"]))
for line in open(evals):
    if not line.startswith("{"):
        continue
    r = json.loads(line)
    p, b = r["vs_truth_person_box"], r["bat_barrel"]
    print("  %s  accuracy %.2f / %.2f mm  completeness %.3f / %.3f  bat %.3f" % (
        r["instant"], p["acc_median_mm"], p["acc_p90_mm"], p["completeness@10mm"],
        p["completeness@20mm"], b["completeness@10mm"]))
PY
done
