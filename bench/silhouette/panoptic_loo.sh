#!/usr/bin/env bash
# Leave-one-camera-out evaluation on the Panoptic excerpt (issue 23), one command:
#
#   bench/silhouette/panoptic_loo.sh [--reuse] BUILD_DIR WORK_DIR [-- DOME_RUN_ARGS...]
#
# For each of the excerpt's cameras c: import a take of the other cameras
# (`dome import panoptic --cameras`), reconstruct it with `dome run` (the default path,
# plus DOME_RUN_ARGS, e.g. a mask switch), then `silhouette_loo` renders each instant's
# mesh into c and scores it against c's mask and image (bench/silhouette/loo.cc prints
# the table and writes WORK_DIR/preview/). --reuse keeps reconstructions already in
# WORK_DIR (an out_<c>/report.json) instead of running them again.
# DOME_DATA (default: ../shared/data next to the source tree) holds panoptic/.
set -euo pipefail
reuse=0
if [[ "${1:-}" == "--reuse" ]]; then
  reuse=1
  shift
fi
if [[ $# -lt 2 ]]; then
  echo "usage: $0 [--reuse] BUILD_DIR WORK_DIR [-- DOME_RUN_ARGS...]" >&2
  exit 2
fi
build=$(realpath "$1")
work=$2
shift 2
[[ "${1:-}" == "--" ]] && shift
run_args=("$@")
source_dir=$(cd "$(dirname "$0")/../.." && pwd)
data=${DOME_DATA:-$source_dir/../shared/data}
panoptic=$data/panoptic
dome=$build/bin/dome
for f in "$dome" "$build/bin/silhouette_loo" "$panoptic/camera_parameters.json"; do
  [[ -e "$f" ]] || { echo "$0: $f: missing" >&2; exit 2; }
done
mkdir -p "$work"
# Every camera with a frame folder.
cameras=()
for d in "$panoptic"/hd/*/; do cameras+=("$(basename "$d")"); done
[[ ${#cameras[@]} -ge 3 ]] || { echo "$0: $panoptic/hd: fewer than 3 camera folders" >&2; exit 2; }

# The whole take: the left-out camera's frames, rig and masks come from it.
[[ $reuse -eq 1 && -f "$work/all/rig.json" ]] ||
  "$dome" import panoptic "$panoptic" --out "$work/all" --overwrite >/dev/null
for c in "${cameras[@]}"; do
  others=()
  for o in "${cameras[@]}"; do [[ "$o" == "$c" ]] || others+=("$o"); done
  if [[ $reuse -eq 1 && -f "$work/out_$c/report.json" ]]; then
    echo "without $c: reusing $work/out_$c"
    continue
  fi
  "$dome" import panoptic "$panoptic" --cameras "${others[@]}" --out "$work/take_$c" \
    --overwrite >/dev/null
  rm -rf "$work/out_$c"
  echo "without $c: dome run ${run_args[*]:-}"
  /usr/bin/time -f "without $c: %e s wall, %U s user, %S s sys, %M KB max RSS" \
    "$dome" run "$work/take_$c" --out "$work/out_$c" "${run_args[@]}" >"$work/run_$c.log" 2>&1 ||
    { echo "$0: dome run without $c failed, see $work/run_$c.log" >&2; exit 1; }
done
"$build/bin/silhouette_loo" --take "$work/all" --work "$work" --preview "$work/preview"
