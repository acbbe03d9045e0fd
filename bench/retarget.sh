#!/usr/bin/env bash
# Face-capture retargeting's cost on one core, in one run on this machine: the Live Link
# Face take (328 frames of 68 noisy landmarks) onto the dragon face (protocol B). Prints
# the fit's seconds and the per-frame mapping's milliseconds (p50, p99, mean); the
# reference measured in the same run is one evaluation of the dragon's rig.
#   bench/retarget.sh        (needs ../shared: the take and the ARKit shapes)
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release -q -p reprise
target/release/reprise run -p datasets/live-link-face/pipeline.toml --to positions >/dev/null 2>&1 \
  || { echo "the capture did not run: target/release/reprise run -p datasets/live-link-face/pipeline.toml"; exit 1; }
target/release/reprise run -p datasets/live-link-face-dragon/pipeline.toml --to retarget-oracle >/dev/null 2>&1
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
a=$(realpath artifacts/live-link-face-dragon)
capture=$(realpath artifacts/live-link-face/positions.parquet)
one() { RAYON_NUM_THREADS=1 taskset -c 0 "$@"; }
(cd datasets/live-link-face-dragon && one ../../target/release/reprise-retarget-fit --capture "$capture" \
  --pairs "$a/pairs.parquet" --corpus "$a/frames.parquet" --scales "$a/scales.parquet" \
  --model "$out/retarget.parquet" --capture-noise 0.001 --target-poses 100 2>&1 | tail -1)
(cd datasets/live-link-face-dragon && one ../../target/release/reprise-retarget-apply --capture "$capture" \
  --model "$out/retarget.parquet" --controls "$a/controls.parquet" --truth "$a/truth.parquet" \
  --curves "$out/curves.parquet" --frames "$out/frames.parquet" --glb "$out/r.glb" --report "$out/r.md" \
  --player "$out/r.html" 2>&1 | tail -5)
sed -n '/^| per frame/,/^A frame takes/p' "$out/r.md"
