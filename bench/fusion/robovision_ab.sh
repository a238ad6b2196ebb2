#!/usr/bin/env bash
# Two dome binaries side by side on the default path of every shared Robovision scene.
#
#   bash bench/fusion/robovision_ab.sh BEFORE_DOME AFTER_DOME OUT [PAIRS]
#
# Each scene is imported once (`dome import halcon`, with AFTER_DOME); then PAIRS (default
# 3) alternating pairs of `dome run TAKE --out DIR` with no reconstruction options, before
# then after, each into a fresh DIR. Per run: the whole process's wall and CPU (user +
# system) seconds (/usr/bin/time) and report.json's session seconds and decimate job
# seconds; per scene: the medians of each and of the pairs' after / before wall ratios,
# and whether the two binaries' last mesh.ply are the same bytes (then the accuracy is the
# same: mesh.ply is what bench/fusion/robovision.sh scores).
# DATA (default: ../shared/data next to the source tree) holds robovision/.
set -euo pipefail
if [[ $# -lt 3 ]]; then
  echo "usage: $0 BEFORE_DOME AFTER_DOME OUT [PAIRS]" >&2
  exit 2
fi
BEFORE=$(realpath "$1"); AFTER=$(realpath "$2"); OUT=$3; PAIRS=${4:-3}
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
DATA=${DATA:-$ROOT/../shared/data}
for f in "$BEFORE" "$AFTER"; do [[ -x "$f" ]] || { echo "$0: $f: not an executable" >&2; exit 2; }; done
[[ -d "$DATA/robovision" ]] || { echo "$0: $DATA/robovision: missing" >&2; exit 2; }
mkdir -p "$OUT"
RESULTS=$OUT/runs.txt
: > "$RESULTS"
for src in "$DATA"/robovision/*/; do
  scene=$(basename "$src")
  "$AFTER" import halcon "$src" --out "$OUT/take_$scene" --overwrite > "$OUT/import_$scene.log" 2>&1 ||
    { echo "$0: import of $scene failed, see $OUT/import_$scene.log" >&2; exit 1; }
  for ((p = 1; p <= PAIRS; ++p)); do
    for side in before after; do
      bin=$BEFORE; [[ $side == after ]] && bin=$AFTER
      dir=$OUT/out_${scene}_$side
      rm -rf "$dir"
      /usr/bin/time -o "$OUT/time.txt" -f "%e %U %S" "$bin" run "$OUT/take_$scene" --out "$dir" \
        > "$OUT/run_${scene}_$side.log" 2>&1 ||
        { echo "$0: $side run of $scene failed, see $OUT/run_${scene}_$side.log" >&2; exit 1; }
      /usr/bin/python3 - "$scene" "$side" "$OUT/time.txt" "$dir/report.json" >> "$RESULTS" <<'PY'
import json, sys
scene, side, times, report = sys.argv[1:]
wall, user, system = (float(x) for x in open(times).read().split())
r = json.load(open(report))
print(scene, side, wall, user + system, r["seconds"], r["stages"]["decimate"]["job_seconds"])
PY
    done
  done
  if cmp -s "$OUT/out_${scene}_before/00-00-00-00/mesh.ply" "$OUT/out_${scene}_after/00-00-00-00/mesh.ply"; then
    echo "$scene same_mesh_ply" >> "$RESULTS"
  else
    echo "$scene different_mesh_ply" >> "$RESULTS"
  fi
done
/usr/bin/python3 - "$RESULTS" <<'PY'
import statistics, sys
runs, same = {}, {}
for line in open(sys.argv[1]):
    f = line.split()
    if len(f) == 2:
        same[f[0]] = f[1]
        continue
    runs.setdefault(f[0], {}).setdefault(f[1], []).append([float(x) for x in f[2:]])
print("%-22s %-6s %12s %12s %12s %14s" % ("scene", "side", "wall s", "CPU s", "session s", "decimate job s"))
for scene, sides in runs.items():
    for side in ("before", "after"):
        cols = list(zip(*sides[side]))
        print("%-22s %-6s %12.2f %12.2f %12.2f %14.3f" % ((scene, side) + tuple(statistics.median(c) for c in cols)))
    ratios = [a[0] / b[0] for b, a in zip(sides["before"], sides["after"])]
    print("%-22s wall after/before %.3f (pairs %s); mesh.ply %s" % (
        scene, statistics.median(ratios), " ".join("%.3f" % r for r in ratios), same.get(scene, "?")))
PY
