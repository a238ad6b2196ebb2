# Helpers shared by the deployment tests: a small take, a dome-master on loopback,
# and the check that a session run by remote workers matches the embedded run.
# Expects $bin (the build folder) and $work (a scratch folder) to be set.

# Synthesizes the small take once into $work/take.
make_small_take() {
  "$bin/bin/dome" synth --preset small --instants 1 --out "$work/take" >"$work/synth.log" 2>&1 ||
    { echo "FAIL: dome synth"; cat "$work/synth.log"; return 1; }
}

# CURVE keys as a lab sets them up (README "Security and keys"): the master's pair in
# $work/keys (master.key, master.pub), a worker's and a client's pair, and the
# allow-list $work/keys/allowed_keys with the worker's and the client's public keys.
make_keys() {
  mkdir -p "$work/keys" && chmod 700 "$work/keys"
  local args
  # The master's own key has no role; each other key's .pub line names its role.
  for args in "master" "worker --role worker" "client --role client"; do
    # shellcheck disable=SC2086 # the role flags split on purpose
    "$bin/bin/dome" keygen "$work/keys/"$args >"$work/keygen.log" 2>&1 ||
      { echo "FAIL: dome keygen"; cat "$work/keygen.log"; return 1; }
  done
  cat "$work/keys/worker.pub" "$work/keys/client.pub" >"$work/keys/allowed_keys"
}

# Starts a secure dome-master (make_keys first) on free loopback ports; sets
# master_pid, workers_ep, control_ep, events_ep.
start_master() {
  "$bin/bin/dome-master" --bind tcp://127.0.0.1:0 --control tcp://127.0.0.1:0 \
    --events tcp://127.0.0.1:0 --endpoints-file "$work/endpoints" --keys "$work/keys" \
    >"$work/master.log" 2>&1 &
  master_pid=$!
  local i
  for i in $(seq 1 100); do
    [[ -s "$work/endpoints" ]] && break
    sleep 0.1
  done
  [[ -s "$work/endpoints" ]] || { echo "FAIL: dome-master did not start"; cat "$work/master.log"; return 1; }
  { read -r workers_ep; read -r control_ep; read -r events_ep; } <"$work/endpoints"
}

# Runs the take as a session on the master (the remote workers do the work), then
# the same take on the embedded cluster, and compares every output byte for byte.
run_and_compare() {
  timeout 300 "$bin/bin/dome" run "$work/take" --out "$work/out-remote" \
    --master "$control_ep" --events "$events_ep" \
    --master-key "$work/keys/master.pub" --key "$work/keys/client.key" \
    >"$work/run-remote.log" 2>&1 ||
    { echo "FAIL: the session on the remote workers"; cat "$work/run-remote.log";
      tail -20 "$work/master.log"; return 1; }
  timeout 300 "$bin/bin/dome" run "$work/take" --out "$work/out-embedded" \
    >"$work/run-embedded.log" 2>&1 ||
    { echo "FAIL: the embedded run"; cat "$work/run-embedded.log"; return 1; }
  local n=0 f
  while IFS= read -r f; do
    [[ "$f" == report.json || "$f" == session.json || "$f" == *.log || "$f" == journal* ]] && continue
    cmp -s "$work/out-embedded/$f" "$work/out-remote/$f" ||
      { echo "FAIL: $f differs between the remote and the embedded run"; return 1; }
    n=$((n + 1))
  done < <(cd "$work/out-embedded" && find . -type f -printf '%P\n' | sort)
  [[ $n -gt 0 ]] || { echo "FAIL: the embedded run wrote no outputs"; return 1; }
  ls "$work"/out-remote/*/mesh.ply >/dev/null 2>&1 ||
    { echo "FAIL: no mesh.ply in the remote run's output"; return 1; }
  echo "$n output files identical to the embedded run"
}
