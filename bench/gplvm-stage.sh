#!/usr/bin/env bash
# The gplvm stage on dragon-face, several times in one run on this machine, each with the
# held-out check and one worker per core, then the wall-time ratios:
#   filing   the setting when issue #11 was filed, reproduced by flags: Netlab SCG with its
#            step tests, 300 iterations, raw latents, free length scale, exact connectivity
#            prior, no signal prior or noise floor (every label stops at the cap, NOT converged);
#   capped   the same cap with today's optimiser, L-BFGS on whitened latents (a stricter
#            yardstick: about one evaluation per iteration where SCG needs two);
#   default  the shipped pipeline's setting (every label fitted to convergence);
#   old      (only with a second argument) the stage binary of the code before #11, with
#            that code's pipeline.toml parameters: the setting and the code of the day.
# Needs the default pipeline's artifacts up to pca (`target/release/reprise run --to pca`).
#   bench/gplvm-stage.sh [ARTIFACT_DIR [OLD_TREE]]      (default artifacts/dragon-face)
# OLD_TREE: a checkout of the code before #11, built, e.g.
#   git worktree add /tmp/before-11 ea61edf && (cd /tmp/before-11 && cargo build --release --bin reprise-gplvm)
set -euo pipefail
cd "$(dirname "$0")/.."
dir=${1:-artifacts/dragon-face}
old_tree=${2:-}
bin=target/release/reprise-gplvm
[ -x "$bin" ] || { echo "$bin not found: cargo build --release"; exit 1; }
[ -f "$dir/pca_coords.parquet" ] || { echo "$dir/pca_coords.parquet not found: target/release/reprise run --to pca"; exit 1; }
if [ -n "$old_tree" ]; then
  old_bin=${OLD_BIN:-$old_tree/target/release/reprise-gplvm}
  [ -x "$old_bin" ] || { echo "$old_bin not found: build $old_tree (or set OLD_BIN)"; exit 1; }
fi
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
# A pipeline file's gplvm parameters, as flags.
params() {
  sed -n '/^\[stage.gplvm.params\]/,/^\[/p' "$1" | grep -E '^[a-z_]+ *=' |
    sed -E 's/ *#.*//; s/^([a-z_]+) *= *"?([^"]*)"?$/--\1 \2/; s/_/-/g'
}
run() {
  local name=$1 exe=$2; shift 2
  local start end
  start=$(date +%s.%N)
  "$exe" --coords "$dir/pca_coords.parquet" --labeled-frames "$dir/labeled_frames.parquet" \
    --pca-models "$dir/pca_models.parquet" --scales "$dir/scales.parquet" --controls "$dir/controls.parquet" \
    --latents "$out/$name-latents.parquet" --models "$out/$name-models.parquet" \
    --trace "$out/$name-trace.parquet" --fits "$out/$name-fits.parquet" "$@" 2>&1 | grep -v '^\[' >&2
  end=$(date +%s.%N)
  echo "$name: $(echo "$end - $start" | bc) s wall" >&2
  echo "$end - $start" | bc
}
cap="--heldout-every 10 --connectivity-path exact --signal-prior-sd 0 --noise-floor 0 --max-iters 300 --q 3"
echo "== filing: the setting when #11 was filed (SCG, Netlab tests, raw latents, 300 iterations) ==" >&2
# shellcheck disable=SC2086
t_filing=$(run filing "$bin" --optimizer scg --stop netlab --whiten false --fix-lengthscale false $cap)
echo "== capped: 300 iterations of L-BFGS on whitened latents ==" >&2
# shellcheck disable=SC2086
t_capped=$(run capped "$bin" --optimizer lbfgs $cap)
echo "== default pipeline setting: $(params pipeline.toml | tr '\n' ' ') ==" >&2
# shellcheck disable=SC2046
t_new=$(run default "$bin" $(params pipeline.toml))
if [ -n "$old_tree" ]; then
  echo "== old: the code before #11 with its own pipeline.toml ($(params "$old_tree/pipeline.toml" | tr '\n' ' ')) ==" >&2
  # shellcheck disable=SC2046
  t_old=$(run old "$old_bin" $(params "$old_tree/pipeline.toml"))
fi
ratio() { echo "scale=3; $1 / $2" | bc; }
echo "converged default / filing setting:  $(ratio "$t_new" "$t_filing")"
echo "converged default / capped L-BFGS:   $(ratio "$t_new" "$t_capped")"
[ -z "$old_tree" ] || echo "converged default / old code:         $(ratio "$t_new" "$t_old")"
echo "(wall times, same machine, same run)"
