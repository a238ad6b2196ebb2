#!/bin/bash
# deploy/slurm/dome-workers.sbatch submitted to a real single-node Slurm started
# here: its workers connect to a dome-master on loopback and finish a small session
# whose outputs equal the embedded run's.
#   slurm_workers_test.sh SOURCE_DIR BINARY_DIR
set -uo pipefail
src="$1" bin="$2"
for exe in slurmctld slurmd munged sbatch; do
  command -v "$exe" >/dev/null ||
    { echo "SKIP: $exe is not installed (Debian packages slurm-wlm and munge)"; exit 77; }
done
work="$(mktemp -d)"
. "$src/tests/deploy/slurm_lib.sh"
. "$src/tests/deploy/cluster_lib.sh"
cleanup() {
  [[ -n "${job:-}" ]] && scancel "$job" 2>/dev/null
  [[ -n "${master_pid:-}" ]] && kill "$master_pid" 2>/dev/null
  slurm_down "$work/slurm"
  wait 2>/dev/null
  rm -rf "$work"
}
trap cleanup EXIT
make_small_take || exit 1
make_keys || exit 1
slurm_up "$work/slurm" || { echo "FAIL: could not start Slurm"; exit 1; }
start_master || exit 1
# Without keys the script refuses before submitting anything to srun.
if err="$(DOME_MASTER="$workers_ep" bash "$src/deploy/slurm/dome-workers.sbatch" 2>&1)"; then
  echo "FAIL: the batch script ran without keys"; exit 1
fi
grep -q "DOME_KEY" <<<"$err" || { echo "FAIL: unclear error without keys: $err"; exit 1; }
out="$(DOME_MASTER="$workers_ep" DOME_WORKER="$bin/bin/dome-worker" DOME_CACHE_MB=256 \
  DOME_MASTER_KEY="$work/keys/master.pub" DOME_KEY="$work/keys/worker.key" \
  sbatch --parsable --nodes=1 --cpus-per-task="$(nproc)" --chdir="$work" \
  "$src/deploy/slurm/dome-workers.sbatch" 2>&1)" || { echo "FAIL: sbatch: $out"; exit 1; }
job="${out%%;*}"
echo "submitted Slurm job $job"
run_and_compare || { cat "$work"/dome-workers-*.log 2>/dev/null | tail -20; exit 1; }
state="$(squeue -h -j "$job" -o %T)"
[[ "$state" == RUNNING ]] || { echo "FAIL: the Slurm job is '$state', expected RUNNING"; exit 1; }
scancel "$job"
echo "PASS: Slurm job $job ran the session"
