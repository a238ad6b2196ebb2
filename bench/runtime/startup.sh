#!/usr/bin/env bash
# How long each dome program takes to start, and what it maps, against another build:
#
#   bash bench/runtime/startup.sh BIN_A BIN_B [RUNS]
#
# BIN_A and BIN_B are two builds' bin/ folders (e.g. build/bin and an older checkout's
# build/bin). For each of dome, dome-worker and dome-master, RUNS (default 10) pairs of
# `PROGRAM --help`, A and B in turn after one warm-up each, timed with /usr/bin/time: the
# median wall seconds and peak resident memory of each side, the median of the pairs'
# wall ratios A/B, and the shared libraries each program loads (ldd). Start-up is what
# every command, worker and test process pays before its first line of work.
set -euo pipefail
[ $# -ge 2 ] || { echo "usage: startup.sh BIN_A BIN_B [RUNS]" >&2; exit 1; }
A=$(realpath "$1"); B=$(realpath "$2"); RUNS=${3:-10}
for p in dome dome-worker dome-master; do
  for side in "$A" "$B"; do
    [ -x "$side/$p" ] || { echo "startup.sh: $side/$p: not an executable" >&2; exit 1; }
  done
done
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
for p in dome dome-worker dome-master; do
  "$A/$p" --help > /dev/null 2>&1 || true
  "$B/$p" --help > /dev/null 2>&1 || true
  for ((i = 0; i < RUNS; ++i)); do
    for side in A B; do
      dir=$A; [ $side = B ] && dir=$B
      /usr/bin/time -f "%e %M" -o "$work/t" "$dir/$p" --help > /dev/null 2>&1 || true
      echo "$side $(cat "$work/t")" >> "$work/$p"
    done
  done
  /usr/bin/python3 - "$work/$p" "$p" "$(ldd "$A/$p" | wc -l)" \
    "$(ldd "$B/$p" | wc -l)" <<'PY'
import statistics, sys
rows = [line.split() for line in open(sys.argv[1])]
a = [(float(w), float(m)) for s, w, m in rows if s == "A"]
b = [(float(w), float(m)) for s, w, m in rows if s == "B"]
ratios = [x[0] / y[0] for x, y in zip(a, b) if y[0] > 0]
med = lambda v: statistics.median(v) if v else float("nan")
print(f"{sys.argv[2]:12s} A {med([w for w, _ in a]):.3f} s {med([m for _, m in a]) / 1024:.1f} MiB "
      f"{sys.argv[3]} libs | B {med([w for w, _ in b]):.3f} s {med([m for _, m in b]) / 1024:.1f} MiB "
      f"{sys.argv[4]} libs | A/B wall {med(ratios):.2f} ({min(ratios):.2f}..{max(ratios):.2f}, "
      f"{len(ratios)} pairs)")
PY
done
