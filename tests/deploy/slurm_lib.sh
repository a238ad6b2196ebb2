# Starts and stops a single-node Slurm (munged, slurmctld, slurmd) on this machine,
# everything under one folder, on ports of its own, so it never touches a Slurm the
# machine already runs. Sourced by slurm_workers_test.sh.
#   slurm_up DIR      -> exports SLURM_CONF; returns non-zero with a message on failure
#   slurm_down DIR

slurm_free_port() {
  python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])'
}

slurm_up() {
  local dir="$1" host
  host="$(hostname)"
  mkdir -p "$dir"/{state,spool,log,run,munge}
  mungekey --create --keyfile="$dir/munge.key" --force >/dev/null 2>&1 ||
    dd if=/dev/urandom of="$dir/munge.key" bs=1024 count=1 status=none
  chmod 600 "$dir/munge.key"
  munged --force -S "$dir/munge/munge.socket" --key-file="$dir/munge.key" \
    --log-file="$dir/log/munged.log" --pid-file="$dir/run/munged.pid" \
    --seed-file="$dir/munged.seed" || { echo "munged did not start"; return 1; }
  cat >"$dir/slurm.conf" <<CONF
ClusterName=dometest
SlurmctldHost=$host
SlurmctldPort=$(slurm_free_port)
SlurmdPort=$(slurm_free_port)
AuthType=auth/munge
AuthInfo=socket=$dir/munge/munge.socket
SlurmUser=root
SlurmdUser=root
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/run/slurmctld.pid
SlurmdPidFile=$dir/run/slurmd.pid
SlurmctldLogFile=$dir/log/slurmctld.log
SlurmdLogFile=$dir/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
MpiDefault=none
ReturnToService=2
NodeName=$host CPUs=$(nproc) State=UNKNOWN
PartitionName=dome Nodes=$host Default=YES MaxTime=INFINITE State=UP
CONF
  export SLURM_CONF="$dir/slurm.conf"
  slurmctld -f "$SLURM_CONF" || { echo "slurmctld did not start"; return 1; }
  slurmd -f "$SLURM_CONF" || { echo "slurmd did not start"; return 1; }
  local i
  for i in $(seq 1 60); do
    if sinfo -h -o '%t' 2>/dev/null | grep -q idle; then return 0; fi
    sleep 0.5
  done
  echo "the Slurm node did not become idle:"; sinfo; tail -5 "$dir/log/slurmctld.log"
  return 1
}

slurm_down() {
  local dir="$1" f i
  # Let cancelled jobs end first: slurmd stays up while a job step is alive.
  for i in $(seq 1 40); do
    [[ -z "$(squeue -h 2>/dev/null)" ]] && break
    sleep 0.25
  done
  scontrol shutdown >/dev/null 2>&1 || true
  sleep 0.5
  # Whatever is left of this Slurm (found by its own config path) is stopped hard.
  pkill -9 -f "slurmd -f $dir/slurm.conf|slurmctld -f $dir/slurm.conf" 2>/dev/null
  [[ -f "$dir/run/munged.pid" ]] && kill "$(cat "$dir/run/munged.pid")" 2>/dev/null
  return 0
}
