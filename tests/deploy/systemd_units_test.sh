#!/bin/bash
# Checks deploy/systemd/*.service with `systemd-analyze verify`, with ExecStart
# pointing at the binaries of this build (verify insists they exist).
#   systemd_units_test.sh SOURCE_DIR BINARY_DIR
set -euo pipefail
src="$1" bin="$2"
if ! command -v systemd-analyze >/dev/null; then
  echo "SKIP: systemd-analyze is not installed (Debian package systemd)"; exit 77
fi
work="$(mktemp -d)"; trap 'rm -rf "$work"' EXIT
for unit in "$src"/deploy/systemd/*.service; do
  name="$(basename "$unit")"
  # A template unit is verified as one of its instances.
  [[ "$name" == *@.service ]] && name="${name%@.service}@c01.service"
  sed "s|/usr/local/bin/|$bin/bin/|g" "$unit" >"$work/$name"
done
for exe in dome-master dome-worker dome-capture; do
  [[ -x "$bin/bin/$exe" ]] || { echo "FAIL: $bin/bin/$exe was not built"; exit 1; }
done
# verify prints a line for each problem; any output is a failure (it does not
# always set a non-zero status for warnings such as unknown keys).
out="$(cd "$work" && systemd-analyze verify ./*.service 2>&1)" || { echo "$out"; exit 1; }
if [[ -n "$out" ]]; then echo "FAIL: systemd-analyze verify reported:"; echo "$out"; exit 1; fi
# A broken unit must be caught: the check itself can fail.
printf '[Service]\nExecStart=%s/bin/dome-worker\nRestart=sometimes\n' "$bin" >"$work/broken.service"
if out="$(cd "$work" && systemd-analyze verify ./broken.service 2>&1)" && [[ -z "$out" ]]; then
  echo "FAIL: a unit with Restart=sometimes passed verification"; exit 1
fi
echo "PASS: $(ls "$src"/deploy/systemd/*.service | wc -l) units verified"
