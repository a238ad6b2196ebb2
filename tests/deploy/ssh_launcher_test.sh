#!/bin/bash
# deploy/ssh/dome-ssh-workers starts dome-workers through a real sshd on loopback
# (its own host key, user key and port); they finish a small session whose outputs
# equal the embedded run's; `status` and `stop` reach them; a bad hosts file is named.
#   ssh_launcher_test.sh SOURCE_DIR BINARY_DIR
set -uo pipefail
src="$1" bin="$2"
sshd_bin="$(command -v sshd || echo /usr/sbin/sshd)"
[[ -x "$sshd_bin" ]] || { echo "SKIP: sshd is not installed (Debian package openssh-server)"; exit 77; }
command -v ssh >/dev/null || { echo "SKIP: ssh is not installed (openssh-client)"; exit 77; }
work="$(mktemp -d)"
. "$src/tests/deploy/cluster_lib.sh"
launcher="$src/deploy/ssh/dome-ssh-workers"
cleanup() {
  [[ -n "${hosts:-}" ]] && "$launcher" stop "$hosts" "${ssh_args[@]}" >/dev/null 2>&1
  [[ -n "${sshd_pid:-}" ]] && kill "$sshd_pid" 2>/dev/null
  [[ -n "${master_pid:-}" ]] && kill "$master_pid" 2>/dev/null
  wait 2>/dev/null
  rm -rf "$work"
}
trap cleanup EXIT
mkdir -p "$work/ssh" && chmod 700 "$work/ssh"
ssh-keygen -q -t ed25519 -N '' -f "$work/ssh/host_key"
ssh-keygen -q -t ed25519 -N '' -f "$work/ssh/user_key"
cp "$work/ssh/user_key.pub" "$work/ssh/authorized_keys" && chmod 600 "$work/ssh/authorized_keys"
port="$(python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])')"
cat >"$work/ssh/sshd_config" <<CONF
Port $port
ListenAddress 127.0.0.1
HostKey $work/ssh/host_key
AuthorizedKeysFile $work/ssh/authorized_keys
PasswordAuthentication no
KbdInteractiveAuthentication no
PermitRootLogin prohibit-password
StrictModes no
UsePAM no
PidFile $work/ssh/sshd.pid
CONF
mkdir -p /run/sshd  # sshd's privilege-separation folder
"$sshd_bin" -D -e -f "$work/ssh/sshd_config" 2>"$work/sshd.log" &
sshd_pid=$!
user="$(id -un)"
ssh_args=(--ssh-opt -i --ssh-opt "$work/ssh/user_key" --ssh-opt -o
  --ssh-opt "UserKnownHostsFile=/dev/null" --ssh-opt -o --ssh-opt "StrictHostKeyChecking=no"
  --ssh-opt -o --ssh-opt "LogLevel=ERROR" --run-dir "$work/remote")
for i in $(seq 1 50); do
  ssh -p "$port" -i "$work/ssh/user_key" -o UserKnownHostsFile=/dev/null \
    -o StrictHostKeyChecking=no -o LogLevel=ERROR -o BatchMode=yes "$user@127.0.0.1" true \
    2>/dev/null && break
  sleep 0.2
done

# A malformed hosts file is refused line by line.
printf 'good-host 2\nbad host line here\n' >"$work/bad_hosts"
if err="$("$launcher" start "$work/bad_hosts" --master tcp://127.0.0.1:1 --insecure 2>&1)"; then
  echo "FAIL: a malformed hosts file was accepted"; exit 1
fi
grep -q "bad_hosts:2: expected" <<<"$err" || { echo "FAIL: unclear error: $err"; exit 1; }

make_small_take || exit 1
make_keys || exit 1
start_master || exit 1
hosts="$work/hosts"
printf '# one worker on this machine, reached through sshd\n%s@127.0.0.1:%s 1\n' "$user" "$port" >"$hosts"
# Without keys (nor --insecure) the launcher refuses to start anything.
if err="$("$launcher" start "$hosts" --master "$workers_ep" "${ssh_args[@]}" 2>&1)"; then
  echo "FAIL: start without keys was accepted"; exit 1
fi
grep -q -- "--master-key" <<<"$err" || { echo "FAIL: unclear error without keys: $err"; exit 1; }
"$launcher" start "$hosts" --master "$workers_ep" --worker "$bin/bin/dome-worker" \
  --master-key "$work/keys/master.pub" --key "$work/keys/worker.key" \
  --cache-mb 256 "${ssh_args[@]}" || { echo "FAIL: start"; cat "$work/sshd.log"; exit 1; }
"$launcher" status "$hosts" "${ssh_args[@]}" | grep -q running ||
  { echo "FAIL: status does not see the worker"; exit 1; }
run_and_compare || { cat "$work/remote/worker.log"; exit 1; }
"$launcher" stop "$hosts" "${ssh_args[@]}" | grep -q stopped || { echo "FAIL: stop"; exit 1; }
if "$launcher" status "$hosts" "${ssh_args[@]}" >/dev/null; then
  echo "FAIL: the worker still runs after stop"; exit 1
fi
echo "PASS: the ssh launcher's worker ran the session"
