#!/usr/bin/env bash
# This machine's build against an AVX2-only build of the same source, side by side:
#
#   bash bench/runtime/avx2_side_by_side.sh BUILD/bin/dome OUT [PAIRS]
#
# Builds `dome` for x86-64-v3 (AVX2, FMA, no AVX-512) in OUT/build-avx2 (DOME_NATIVE off)
# and runs it with DOME_MAX_SIMD=avx2, so that the cost kernel, whose paths are chosen at
# run time, takes its AVX2 path as well. What it does not hold back: OpenCV's and the C
# library's own run-time choices (resizes, PNG inflate, memcpy) and the CPU itself (an
# AVX2 CPU of another generation has other clocks, caches and memory), so the figures
# are the AVX2 code paths on this machine, not an AVX2 machine's.
# Then PAIRS (default 2) alternating pairs of whole processes on two takes:
#   - the paper take (`dome synth --preset paper`, made once in OUT/paper), `dome run
#     TAKE --workers 2` (two embedded workers of one thread, the default options);
#   - Robovision 2016_10_24__17_43_02 (`dome import halcon`), `dome run TAKE`.
# Prints wall and CPU seconds (user + system) and the session's seconds per instant of
# each process, and whether the two builds' meshes are the same bytes.
set -euo pipefail
[ $# -ge 2 ] || { echo "usage: avx2_side_by_side.sh BUILD/bin/dome OUT [PAIRS]" >&2; exit 1; }
NATIVE=$(realpath "$1"); OUT=$(realpath -m "$2"); PAIRS=${3:-2}
[ -x "$NATIVE" ] || { echo "avx2_side_by_side.sh: $1 is not an executable dome" >&2; exit 1; }
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
DATA=${DATA:-$ROOT/../shared/data}
SCENE="$DATA/robovision/2016_10_24__17_43_02"
[ -d "$SCENE" ] || { echo "avx2_side_by_side.sh: no Robovision scene at $SCENE (set DATA)" >&2; exit 1; }
mkdir -p "$OUT"
cmake -S "$ROOT" -B "$OUT/build-avx2" -DCMAKE_BUILD_TYPE=Release -DDOME_NATIVE=OFF \
  -DCMAKE_CXX_FLAGS="-march=x86-64-v3" > "$OUT/build-avx2.log"
cmake --build "$OUT/build-avx2" -j"$(nproc)" --target dome >> "$OUT/build-avx2.log"
AVX2="$OUT/build-avx2/bin/dome"

[ -d "$OUT/paper" ] || "$NATIVE" synth --preset paper --out "$OUT/paper" > "$OUT/synth.log"
[ -d "$OUT/robovision" ] || "$NATIVE" import halcon "$SCENE" --out "$OUT/robovision" > "$OUT/import.log"

run() {  # label, dome, take, out, extra args...
  local label=$1 dome=$2 take=$3 out=$4; shift 4
  rm -rf "$out"
  if [ "$label" = avx2 ]; then
    DOME_MAX_SIMD=avx2 /usr/bin/time -f "%e %U %S" -o "$out.time" "$dome" run "$take" --out "$out" "$@" > "$out.log" 2>&1
  else
    /usr/bin/time -f "%e %U %S" -o "$out.time" "$dome" run "$take" --out "$out" "$@" > "$out.log" 2>&1
  fi
  local per
  per=$(/usr/bin/python3 -c "import json,sys; print('%.3f' % json.load(open(sys.argv[1]))['seconds_per_instant'])" "$out/report.json")
  awk -v l="$label" -v t="$(basename "$out")" -v p="$per" \
    '{printf "%s %s wall %.2f s, CPU %.2f s, %s s per instant\n", t, l, $1, $2 + $3, p}' "$out.time"
}
for i in $(seq 1 "$PAIRS"); do
  for take in paper robovision; do
    extra=()
    [ "$take" = paper ] && extra=(--workers 2)
    run native "$NATIVE" "$OUT/$take" "$OUT/$take-native-$i" "${extra[@]}"
    run avx2 "$AVX2" "$OUT/$take" "$OUT/$take-avx2-$i" "${extra[@]}"
  done
done
for take in paper robovision; do
  same=yes
  for m in "$OUT/$take-native-1"/*/mesh.ply; do
    cmp -s "$m" "${m/$take-native-1/$take-avx2-1}" || same=no
  done
  echo "$take: the two builds' mesh.ply files the same bytes: $same"
done
