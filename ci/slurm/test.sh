#!/usr/bin/env bash
# make test-slurm: runs ci/slurm/submit-reference.sh on a real, single-node Slurm cluster started
# here (Debian's slurm daemons and munge, installed if missing; needs root or sudo), and checks
# that the reference its array and merge jobs produce is bit-identical to one `vplgi reference`.
# The cluster lives in target/slurm-test (configuration, state, logs) and is shut down on exit.
# Usage: ci/slurm/test.sh VPLGI_BINARY
set -euo pipefail
vplgi=$(realpath "${1:?usage: ci/slurm/test.sh VPLGI_BINARY}")
root=$(cd "$(dirname "$0")/../.." && pwd)
work="$root/target/slurm-test"
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi

missing=()
for p in slurmctld slurmd slurm-client munge python3-yaml; do  # python3-yaml: the Kubernetes check after this
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ "${#missing[@]}" -gt 0 ]; then
  echo "test-slurm: installing ${missing[*]}"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq -o DPkg::Lock::Timeout=120 "${missing[@]}" >/dev/null
fi

# munge authenticates Slurm's messages; the package made its key. Without systemd, start it here.
if ! pgrep -x munged >/dev/null; then
  $SUDO install -d -o munge -g munge -m 0755 /run/munge
  $SUDO runuser -u munge -- /usr/sbin/munged
fi

rm -rf "$work"
mkdir -p "$work/state" "$work/spool" "$work/log" "$work/jobs"
host=$(hostname -s)
cpus=$(nproc)
user=$(id -un)
cat > "$work/slurm.conf" <<CONF
ClusterName=vplgi-test
SlurmctldHost=$host
SlurmUser=$user
SlurmdUser=root
AuthType=auth/munge
StateSaveLocation=$work/state
SlurmdSpoolDir=$work/spool
SlurmctldPidFile=$work/slurmctld.pid
SlurmdPidFile=$work/slurmd.pid
SlurmctldLogFile=$work/log/slurmctld.log
SlurmdLogFile=$work/log/slurmd.log
SlurmctldPort=16817
SlurmdPort=16818
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
MpiDefault=none
SwitchType=switch/none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
ReturnToService=2
MinJobAge=600
NodeName=$host CPUs=$cpus State=UNKNOWN
PartitionName=test Nodes=$host Default=YES MaxTime=INFINITE State=UP
CONF
export SLURM_CONF="$work/slurm.conf"

cleanup() {
  scontrol shutdown >/dev/null 2>&1 || true
  sleep 1
  for p in "$work/slurmd.pid" "$work/slurmctld.pid"; do
    [ -f "$p" ] && $SUDO kill "$(cat "$p")" 2>/dev/null || true
  done
}
trap cleanup EXIT
slurmctld -f "$SLURM_CONF"
$SUDO env SLURM_CONF="$SLURM_CONF" slurmd -f "$SLURM_CONF"
for _ in $(seq 1 60); do
  state=$(sinfo -h -N -o %t 2>/dev/null || true)
  case "$state" in idle*|mix*) break;; esac
  sleep 1
done
case "${state:-}" in idle*|mix*) ;; *) echo "test-slurm: the node did not come up (state '${state:-none}'); logs in $work/log" >&2; exit 1;; esac
echo "test-slurm: single-node cluster up ($host, $cpus CPUs)"

# The same small reference as an array of 3 tiles plus the merge, and as one run.
args=(--width 48 --height 36 --vpls 400 --seeds 3)
VPLGI="$vplgi" "$root/ci/slurm/submit-reference.sh" 3 "$work/jobs" "${args[@]}" | tee "$work/submit.txt"
merge=$(sed -n 's/.*merge: job \([0-9]*\).*/\1/p' "$work/submit.txt")
for _ in $(seq 1 300); do
  state=$(scontrol show job "$merge" 2>/dev/null | sed -n 's/.*JobState=\([A-Z_]*\).*/\1/p')
  case "$state" in COMPLETED|FAILED|CANCELLED|TIMEOUT|NODE_FAIL|OUT_OF_MEMORY) break;; esac
  sleep 1
done
if [ "$state" != COMPLETED ]; then
  echo "test-slurm: the merge job ended $state; logs in $work/jobs/logs and $work/log" >&2
  tail -n 5 "$work"/jobs/logs/*.log >&2 || true
  exit 1
fi
"$vplgi" reference "${args[@]}" --out "$work/single" >/dev/null
for f in mean.exr variance.exr; do
  if ! cmp -s "$work/jobs/merged/$f" "$work/single/$f"; then
    echo "test-slurm: $f of the Slurm reference differs from the single run's" >&2
    exit 1
  fi
done
echo "test-slurm: passed: 3 array tasks and the dependent merge on Slurm gave a reference bit-identical to one run ($work/jobs/merged)"
