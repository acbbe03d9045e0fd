#!/bin/bash
# Start a one-node Slurm cluster (munged + slurmctld + slurmd) without systemd, for
# reprise's Slurm executor test (tests/e2e/slurm.rs) and for trying the executor by hand.
# Needs root and the Debian packages `slurm-wlm` and `munge` (installs nothing).
# Idempotent: re-running it while the cluster is up starts nothing new.
# Everything lives under $SLURM_LAB (required); clients must
# have SLURM_CONF=$SLURM_LAB/slurm.conf in their environment (see env.sh).
set -euo pipefail

LAB=${SLURM_LAB:?set SLURM_LAB to the directory holding the cluster state}
CTLD_PORT=${SLURM_LAB_CTLD_PORT:-6817}
SLURMD_PORT=${SLURM_LAB_SLURMD_PORT:-6818}
CONF=$LAB/slurm.conf
SOCK=$LAB/munge/munge.socket
export SLURM_CONF=$CONF

# pid file names a live process (a zombie, which PID 1 in containers may reap late, is dead)
alive() { [ -s "$1" ] && kill -0 "$(cat "$1")" 2>/dev/null &&
          ! grep -q '^[0-9]* ([^)]*) Z' "/proc/$(cat "$1")/stat" 2>/dev/null; }

for b in munged mungekey slurmctld slurmd sinfo; do
  command -v $b >/dev/null || { echo "missing $b: apt-get install -y slurm-wlm munge" >&2; exit 1; }
done

# munged demands: socket dir executable by all, key 0600 owned by the daemon user.
mkdir -p "$LAB"/munge "$LAB"/state "$LAB"/spool "$LAB"/log
chmod 755 "$LAB" "$LAB"/munge
[ -s "$LAB/munge/munge.key" ] || mungekey -c -k "$LAB/munge/munge.key"
chmod 600 "$LAB/munge/munge.key"

NODE=$(hostname -s)
# Real CPU/memory/topology of this machine, e.g.
# "NodeName=vm CPUs=2 Boards=1 SocketsPerBoard=1 CoresPerSocket=2 ThreadsPerCore=1 RealMemory=24105"
HW=$(slurmd -C | head -1 | sed 's/^NodeName=[^ ]* //')

cat > "$CONF.new" <<EOF
ClusterName=reprise
SlurmctldHost=$NODE(127.0.0.1)
SlurmctldPort=$CTLD_PORT
SlurmdPort=$SLURMD_PORT
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$SOCK
StateSaveLocation=$LAB/state
SlurmdSpoolDir=$LAB/spool
SlurmctldPidFile=$LAB/slurmctld.pid
SlurmdPidFile=$LAB/slurmd.pid
SlurmctldLogFile=$LAB/log/slurmctld.log
SlurmdLogFile=$LAB/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/filetxt
JobCompLoc=$LAB/log/jobcomp.log
MpiDefault=none
MailProg=/bin/true
ReturnToService=2
MinJobAge=3600
KillWait=5
SchedulerParameters=batch_sched_delay=0
NodeName=$NODE NodeAddr=127.0.0.1 $HW State=UNKNOWN
PartitionName=debug Nodes=ALL Default=YES MaxTime=INFINITE State=UP
EOF
if ! cmp -s "$CONF.new" "$CONF"; then mv "$CONF.new" "$CONF"; else rm -f "$CONF.new"; fi
echo "export SLURM_CONF=$CONF" > "$LAB/env.sh"

if ! alive "$LAB/munge/munged.pid"; then
  munged --key-file="$LAB/munge/munge.key" --socket="$SOCK" \
    --pid-file="$LAB/munge/munged.pid" --seed-file="$LAB/munge/munged.seed" \
    --log-file="$LAB/log/munged.log"
fi
alive "$LAB/slurmctld.pid" || slurmctld -f "$CONF"
alive "$LAB/slurmd.pid"    || slurmd -f "$CONF" -N "$NODE"

for i in $(seq 1 60); do
  state=$(sinfo -h -N -n "$NODE" -o %t 2>/dev/null || true)
  [ "$state" = idle ] && break
  sleep 0.5
done
if [ "$state" != idle ]; then
  echo "slurm node $NODE not idle after 30 s (state: '${state:-?}'); logs in $LAB/log" >&2
  tail -n 5 "$LAB"/log/*.log >&2 || true
  exit 1
fi
echo "slurm up: node $NODE idle ($(nproc) CPUs)."
echo "  clients: export SLURM_CONF=$CONF   (or: . $LAB/env.sh)"
echo "  stop:    $(dirname "$(readlink -f "$0")")/stop-slurm.sh [--purge]"
