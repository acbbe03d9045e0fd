#!/usr/bin/env bash
# The gplvm stage on dragon-face, twice in one run on this machine: the 300-iteration
# setting shipped before convergence was reached (exact connectivity prior, no signal
# prior or noise floor, every label stopped at the cap, NOT converged) and the default
# pipeline's setting (every label fitted to convergence), both with the held-out check and
# one worker per core. Prints each run's per-label table and wall time, then the ratio.
# Needs the default pipeline's artifacts up to pca (`target/release/reprise run --to pca`).
#   bench/gplvm-stage.sh [ARTIFACT_DIR]      (default artifacts/dragon-face)
set -euo pipefail
cd "$(dirname "$0")/.."
dir=${1:-artifacts/dragon-face}
bin=target/release/reprise-gplvm
[ -x "$bin" ] || { echo "$bin not found: cargo build --release"; exit 1; }
[ -f "$dir/pca_coords.parquet" ] || { echo "$dir/pca_coords.parquet not found: target/release/reprise run --to pca"; exit 1; }
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
# The default pipeline's gplvm parameters, as flags.
defaults=$(sed -n '/^\[stage.gplvm.params\]/,/^\[/p' pipeline.toml | grep -E '^[a-z_]+ *=' |
  sed -E 's/ *#.*//; s/^([a-z_]+) *= *"?([^"]*)"?$/--\1 \2/; s/_/-/g')
run() {
  local name=$1; shift
  local start end
  start=$(date +%s.%N)
  "$bin" --coords "$dir/pca_coords.parquet" --labeled-frames "$dir/labeled_frames.parquet" \
    --pca-models "$dir/pca_models.parquet" --scales "$dir/scales.parquet" --controls "$dir/controls.parquet" \
    --latents "$out/$name-latents.parquet" --models "$out/$name-models.parquet" \
    --trace "$out/$name-trace.parquet" --fits "$out/$name-fits.parquet" "$@" 2>&1 | grep -v '^\[' >&2
  end=$(date +%s.%N)
  echo "$name: $(echo "$end - $start" | bc) s wall" >&2
  echo "$end - $start" | bc
}
echo "== 300-iteration setting (before convergence) ==" >&2
t_old=$(run capped --heldout-every 10 --optimizer lbfgs --connectivity-path exact --signal-prior-sd 0 \
  --noise-floor 0 --max-iters 300 --q 3)
echo "== default pipeline setting: $(echo $defaults) ==" >&2
# shellcheck disable=SC2086
t_new=$(run default $defaults)
echo "converged default / 300-iteration setting: $(echo "scale=3; $t_new / $t_old" | bc) (wall time, same machine, same run)"
