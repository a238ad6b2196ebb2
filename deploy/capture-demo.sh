#!/usr/bin/env bash
# The capture path on a synthetic take, as deployed: a dome-master hosting the frame
# ingest (--capture-bind, --take) on the loopback, one dome-capture agent per camera
# playing the camera's tape (FFV1 with VITC, `dome-capture make-tapes`) on a simulated
# deck whose digitizer keeps 10 frames a second (so several rewind-play passes), and
# `dome watch --capture` showing each camera's progress from the master's status
# events. Checks that every camera completed and the new take holds every frame once.
#
#   bash deploy/capture-demo.sh BIN_DIR SYNTH_TAKE OUT_TAKE
# BIN_DIR holds dome, dome-master, dome-capture; SYNTH_TAKE is a `dome synth` take
# (its tape/<instant>/ frames; instants every 5 frames, the seed's 6 Hz).
set -euo pipefail
bin=$1 synth=$2 out=$3
start=$(date +%s.%N)
if ! ls "$synth"/tape/*.avi >/dev/null 2>&1; then
  "$bin/dome-capture" make-tapes --take "$synth"
fi
mapfile -t cameras < <(ls "$synth/tape" | sed -n 's/\.avi$//p')
mapfile -t instants < <(ls "$synth/frames")
tc() { echo "${1:0:2}:${1:3:2}:${1:6:2}:${1:9:2}"; }
range="$(tc "${instants[0]}")-$(tc "${instants[-1]}")"
rm -rf "$out" "$out.logs"
mkdir -p "$out.logs"
port() { python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])'; }
control=tcp://127.0.0.1:$(port)
capture=tcp://127.0.0.1:$(port)
"$bin/dome-master" --bind "tcp://127.0.0.1:$(port)" --control "$control" \
  --events "tcp://127.0.0.1:$(port)" --capture-bind "$capture" --take "$out" --insecure \
  --log-level warn >"$out.logs/master.log" 2>&1 &
master=$!
trap 'kill $master 2>/dev/null || true' EXIT
for _ in $(seq 100); do
  grep -qs "^capture " "$out.logs/master.log" && break
  sleep 0.1
done
events=$(sed -n 's/^events //p' "$out.logs/master.log")
"$bin/dome" watch --capture --cameras "${#cameras[@]}" --timeout 600 --master "$control" \
  --events "$events" --insecure >"$out.logs/watch.log" &
watch=$!
sleep 0.5  # the status subscription joins before the first event
pids=()
for cam in "${cameras[@]}"; do
  "$bin/dome-capture" --camera "$cam" --deck "sim:$synth/tape/$cam.avi" --digitizer sim \
    --range "$range" --every 5 --keep-per-second 10 --master "$capture" --insecure \
    --spool "$out.logs/spool" >"$out.logs/$cam.log" 2>&1 &
  pids+=($!)
done
failed=0
for pid in "${pids[@]}"; do wait "$pid" || failed=$((failed + 1)); done
wait "$watch" || failed=$((failed + 1))
kill "$master"
wait "$master" || true
frames=$(find "$out/frames" -name '*.png' | wc -l)
wanted=$((${#cameras[@]} * ${#instants[@]}))
for cam in "${cameras[@]:0:3}"; do grep "^capture $cam " "$out.logs/watch.log" | tail -n 1; done
echo "... (dome watch --capture: $out.logs/watch.log)"
echo "agents by passes needed:"
for cam in "${cameras[@]}"; do grep -h "^captured .* passes$" "$out.logs/$cam.log"; done | sort | uniq -c
printf 'capture: %d cameras x %d instants through dome-master: %d of %d frames in %s, %d failures, %.1f s\n' \
  "${#cameras[@]}" "${#instants[@]}" "$frames" "$wanted" "$out" "$failed" \
  "$(awk -v a="$start" -v b="$(date +%s.%N)" 'BEGIN { print b - a }')"
[ "$failed" -eq 0 ] && [ "$frames" -eq "$wanted" ]
