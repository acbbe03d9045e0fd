#!/usr/bin/env bash
# A crash soak: the default pipeline killed with SIGKILL at seeded random moments (1–40 s
# into each run) — the runner, or one of its stage processes (or a stage's rig
# evaluator), chosen at random — and rerun each time. After every kill: no reprise
# process of the project left running, no temporary file left; at the end every artifact
# is byte-identical to an uninterrupted run's, but for the wall-clock `seconds` columns of
# the GPLVM trace and fits, which differ between any two runs (compared column by column
# with pyarrow: `.ci/run` installs it into .venv).
#   bench/crash-soak.sh [KILLS] [SEED]      (default 20 kills, seed 1)
set -euo pipefail
cd "$(dirname "$0")/.."
kills=${1:-20}
seed=${2:-1}
bin=${REPRISE_BIN:-target/release/reprise}
[ -x "$bin" ] || { echo "$bin not found: cargo build --release"; exit 1; }
bin=$(realpath "$bin")
root=target/crash-soak
rm -rf "$root"
mkdir -p "$root"
root=$(realpath "$root")
project() {  # a copy of the shipped pipeline and its inputs in its own directory
  mkdir -p "$1/datasets/dragon-face"
  cp pipeline.toml "$1/"
  cp -r datasets/dragon-face/. "$1/datasets/dragon-face/"
}
project "$root/reference"
project "$root/soak"

echo "reference: an uninterrupted run"
(cd "$root/reference" && "$bin" run >run.log 2>&1)

# Processes of the project (stages and evaluators are `reprise-*`, the runner `reprise`),
# found by their working directory.
procs() {
  for p in /proc/[0-9]*; do
    local comm; comm=$(cat "$p/comm" 2>/dev/null) || continue
    [[ $comm == reprise* ]] || continue
    [[ $(readlink "$p/cwd" 2>/dev/null) == "$1" ]] || continue
    grep -q '^State:.*Z' "$p/status" 2>/dev/null && continue
    echo "${p#/proc/} $comm"
  done
}

RANDOM=$seed
passed=0
force=()
for ((i = 1; passed < kills; i++)); do
  (cd "$root/soak" && exec "$bin" run "${force[@]}" >>run.log 2>&1) &
  runner=$!
  force=()
  sleep "$(( RANDOM % 40 + 1 )).$(( RANDOM % 10 ))"
  if ! kill -0 "$runner" 2>/dev/null; then
    # The run finished first: the next one reruns every stage, to be killed again.
    wait "$runner" || true
    force=(--force ingest)
    continue
  fi
  mapfile -t stages < <(procs "$root/soak" | awk '$2 != "reprise" {print $1 " " $2}')
  if (( ${#stages[@]} > 0 && RANDOM % 2 == 0 )); then
    victim=${stages[RANDOM % ${#stages[@]}]}
  else
    victim="$runner reprise"
  fi
  kill -KILL "${victim%% *}" 2>/dev/null || true
  wait "$runner" 2>/dev/null || true
  # Whatever the victim, nothing of the project may outlive the runner for long.
  left=""
  for _ in $(seq 50); do
    left=$(procs "$root/soak")
    [ -z "$left" ] && break
    sleep 0.1
  done
  temps=$(find "$root/soak/artifacts" -name '*.tmp' 2>/dev/null || true)
  if [ -n "$left" ] || [ -n "$temps" ]; then
    echo "kill $((passed + 1)) (${victim#* }): FAILED"
    [ -n "$left" ] && echo "  still running: $left"
    [ -n "$temps" ] && echo "  temporary files: $temps"
    exit 1
  fi
  passed=$((passed + 1))
  echo "kill $passed: SIGKILL to ${victim#* } — nothing left running, no temporary file"
done

echo "final run to completion"
(cd "$root/soak" && "$bin" run >>run.log 2>&1)
python=python3
[ -x .venv/bin/python3 ] && python=.venv/bin/python3
"$python" - "$root/reference/artifacts" "$root/soak/artifacts" <<'PY' || exit 1
import os, sys, filecmp
import pyarrow.parquet as pq
ref, soak = sys.argv[1], sys.argv[2]
differ = 0
for d, _, files in os.walk(ref):
    for name in files:
        if name == "reprise.lock" or name.startswith("."):
            continue
        a = os.path.join(d, name)
        b = os.path.join(soak, os.path.relpath(a, ref))
        if filecmp.cmp(a, b, shallow=False):
            continue
        cols = []
        if name.endswith(".parquet"):
            ta, tb = pq.read_table(a), pq.read_table(b)
            cols = [c for c in ta.column_names if c not in tb.column_names or ta[c] != tb[c]]
            if ta.column_names == tb.column_names and cols == ["seconds"]:
                continue  # wall-clock time: differs between any two runs
        print(f"differs: {os.path.relpath(a, ref)} {cols}")
        differ += 1
if differ:
    sys.exit(f"{differ} artifact(s) differ from the uninterrupted run")
PY
echo "crash soak: $passed of $kills kills left nothing behind; every artifact identical to the uninterrupted run's"
