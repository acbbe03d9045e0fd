#!/usr/bin/env bash
# Inverse rig mapping's speed and accuracy on one core, in one run on this machine: for
# each character, `invrig-apply` maps held-out positions back to curves by every method,
# pinned to core 0 with one rayon thread, and prints the report's table. The reference
# measured in the same run is the report's last lines: one rig evaluation's milliseconds.
#   bench/invrig.sh [cmu|robot|dragon ...]    (default: all three; cmu and robot need ../shared)
# The dragon-face maps one roar take (roar_take01) so the computed Jacobian's row ends in
# about a minute; its pipeline's report maps all three.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release -q -p reprise
run() {  # name pipeline artifacts extra-args...
  local name=$1 pipeline=$2 dir=$3
  shift 3
  target/release/reprise run -p "$pipeline" --to positions >/dev/null 2>&1 \
    || { echo "## $name: the pipeline did not run (target/release/reprise run -p $pipeline)"; return; }
  local out bin
  out=$(mktemp -d)
  dir=$(realpath "$dir")
  bin=$(realpath target/release/reprise-invrig-apply)
  echo "## $name"
  # From the pipeline's directory, as the runner runs stages (the rig's paths are relative to it).
  (cd "$(dirname "$pipeline")" && RAYON_NUM_THREADS=1 taskset -c 0 "$bin" \
    --invrig "$dir/invrig.parquet" --positions "${POSITIONS:-$dir/positions.parquet}" \
    --controls "$dir/controls.parquet" --frames "$dir/frames.parquet" \
    --recovered "$out/frames.parquet" --errors "$out/errors.parquet" --report "$out/invrig.md" "$@" 2>"$out/log") \
    || { tail -3 "$out/log"; rm -rf "$out"; return 1; }
  sed -n '/^| method/,$p' "$out/invrig.md" | grep -v '^<!--'
  rm -rf "$out"
}
for which in "${@:-cmu robot dragon}"; do
  for w in $which; do
    case $w in
      cmu) run "CMU 131 (131_03 from 131_01 + 131_02)" datasets/cmu-131/pipeline.toml artifacts/cmu-131 ;;
      robot) run "RobotExpressive (Dance, Punch)" datasets/robot-expressive/invrig.toml artifacts/robot-expressive-invrig ;;
      dragon)
        dir=artifacts/dragon-face-invrig
        target/release/reprise run -p datasets/dragon-face-invrig/pipeline.toml --to positions >/dev/null 2>&1
        one=$(mktemp -d)
        target/release/reprise-positions --frames "$dir/frames.parquet" --controls "$dir/controls.parquet" \
          --invrig "$dir/invrig.parquet" --clips roar_take01 --positions "$one/positions.parquet" 2>/dev/null
        POSITIONS="$one/positions.parquet" run "dragon-face (roar_take01)" \
          datasets/dragon-face-invrig/pipeline.toml "$dir"
        rm -rf "$one" ;;
      *) echo "unknown: $w (cmu, robot or dragon)"; exit 2 ;;
    esac
  done
done
