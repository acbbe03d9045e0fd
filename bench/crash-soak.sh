#!/usr/bin/env bash
# A crash soak: the default pipeline killed with SIGKILL at seeded random moments — the
# runner, or one of its stage processes (or a stage's rig evaluator), chosen at random —
# and rerun each time. After every kill: no reprise process of the project left running,
# no temporary file left; at the end the artifacts are byte-identical to an uninterrupted
# run's (the run lock and the stages' timing records aside).
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
for ((i = 1; i <= kills; i++)); do
  (cd "$root/soak" && exec "$bin" run >>run.log 2>&1) &
  runner=$!
  sleep "$(( RANDOM % 12 + 1 )).$(( RANDOM % 10 ))"
  if ! kill -0 "$runner" 2>/dev/null; then
    echo "kill $i: the run had already finished; nothing to kill"
    wait "$runner" || true
    passed=$((passed + 1))
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
    echo "kill $i (${victim#* }): FAILED"
    [ -n "$left" ] && echo "  still running: $left"
    [ -n "$temps" ] && echo "  temporary files: $temps"
    exit 1
  fi
  passed=$((passed + 1))
  echo "kill $i: SIGKILL to ${victim#* } — nothing left running, no temporary file"
done

echo "final run to completion"
(cd "$root/soak" && "$bin" run >>run.log 2>&1)
differ=0
while IFS= read -r f; do
  rel=${f#"$root/reference/"}
  if ! cmp -s "$f" "$root/soak/$rel"; then
    echo "differs: $rel"
    differ=$((differ + 1))
  fi
done < <(find "$root/reference/artifacts" -type f ! -name 'reprise.lock' ! -name '.*')
[ "$differ" -eq 0 ] || { echo "$differ artifact(s) differ from the uninterrupted run"; exit 1; }
echo "crash soak: $passed of $kills kills left nothing behind; every artifact byte-identical to the uninterrupted run"
