#!/bin/bash
# Stop the cluster started by start-slurm.sh: cancel jobs, stop slurmctld,
# slurmd and munged by their pid files. --purge also deletes $SLURM_LAB.
set -uo pipefail

LAB=${SLURM_LAB:?set SLURM_LAB to the directory holding the cluster state}
export SLURM_CONF=$LAB/slurm.conf

alive() { [ -s "$1" ] && running "$(cat "$1")"; }
# A dead daemon may linger as a zombie (PID 1 in containers may reap late): not running.
running() { kill -0 "$1" 2>/dev/null && ! grep -q '^[0-9]* ([^)]*) Z' "/proc/$1/stat" 2>/dev/null; }

if alive "$LAB/slurmctld.pid"; then
  jobs=$(squeue -h -o %F 2>/dev/null | sort -u)
  if [ -n "$jobs" ]; then
    scancel $jobs
    for i in $(seq 1 40); do [ -z "$(squeue -h 2>/dev/null)" ] && break; sleep 0.25; done
  fi
fi

for p in slurmd slurmctld munge/munged; do
  f=$LAB/$p.pid
  alive "$f" || continue
  pid=$(cat "$f")
  kill -TERM "$pid"
  for i in $(seq 1 40); do running "$pid" || break; sleep 0.1; done
  running "$pid" && { echo "$p ($pid) ignored TERM, killing" >&2; kill -KILL "$pid"; }
done
rm -f "$LAB"/slurmd.pid "$LAB"/slurmctld.pid "$LAB"/munge/munged.pid

if [ "${1:-}" = --purge ]; then rm -rf "$LAB"; echo "slurm stopped; $LAB removed"
else echo "slurm stopped (state kept in $LAB; --purge removes it)"; fi
