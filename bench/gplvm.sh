#!/usr/bin/env bash
# The GPLVM objective benchmark: reprise against GPy, one thread each, in the same run.
# GPy comes from ../shared/bench/gpy_ref (its gplvm_ref.py) in a virtualenv this script
# makes under target/ (about 25 s, wheels only); without either, GPy is skipped and said so.
#   bench/gplvm.sh            # N = 200, 400, 800, 1600; D = 40; q = 3
# Then the connectivity prior's paths (exact against the coarse graph of 2- and 3-frame runs and the subset of every other frame: time
# and error per evaluation, N = 200 … 1600), and the GPy anchor: L-BFGS and SCG from
# GPy's PCA start to GPy's L-BFGS-B objective on the 600 × 40 reference, against GPy's
# own L-BFGS-B fit timed in the same run (skipped, with the recorded 32 s, without GPy).
set -uo pipefail
cd "$(dirname "$0")/.."
ref=../shared/bench/gpy_ref
venv=target/venv-gpy
json=target/gpy_timing.json
fitjson=target/gpy_fit_lbfgsb.json
rm -f "$json" "$fitjson"
if [ -f "$ref/gplvm_ref.py" ]; then
  if [ ! -x "$venv/bin/python" ]; then
    python3 -m venv "$venv" && "$venv/bin/pip" install --quiet --disable-pip-version-check \
      "gpy>=1.15,<1.16" numpy scipy pyarrow threadpoolctl || echo "GPy could not be installed: skipping it"
  fi
  if [ -x "$venv/bin/python" ] && "$venv/bin/python" -c "import GPy" 2>/dev/null; then
    echo "timing GPy (one thread) ..." >&2
    "$venv/bin/python" "$ref/gplvm_ref.py" --mode timing --ns 200,400,800,1600 --ds 40 --reps 5 \
      --json-out "$json" >/dev/null || echo "GPy timing failed: skipping it"
    echo "fitting with GPy's L-BFGS-B (one thread, about 30 s) ..." >&2
    "$venv/bin/python" "$ref/gplvm_ref.py" --mode fit --data "$ref/reference/gplvm_synth_n600_d40.parquet" \
      --optimizer lbfgsb --iters 1000 --json-out "$fitjson" >/dev/null || echo "GPy fit failed: using the recorded time"
  fi
else
  echo "$ref not found: GPy skipped"
fi
[ -f "$json" ] && export REPRISE_GPY_TIMING="$PWD/$json"
[ -f "$fitjson" ] && export REPRISE_GPY_FIT="$PWD/$fitjson"
cargo test --release -p reprise-numerics --test gplvm_timing -- --ignored --nocapture --test-threads 1 2>&1 | grep -v "^test \|^running\|^$"
cargo test --release -p reprise-numerics --test gplvm_gpy optimisers_reach -- --ignored --nocapture 2>&1 | grep -v "^test \|^running\|^$"
