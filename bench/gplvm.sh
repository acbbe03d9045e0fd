#!/usr/bin/env bash
# The GPLVM objective benchmark: reprise against GPy, one thread each, in the same run.
# GPy comes from ../shared/bench/gpy_ref (its gplvm_ref.py) in a virtualenv this script
# makes under target/ (about 25 s, wheels only); without either, GPy is skipped and said so.
#   bench/gplvm.sh            # N = 200, 400, 800, 1600; D = 40; q = 3
set -uo pipefail
cd "$(dirname "$0")/.."
ref=../shared/bench/gpy_ref
venv=target/venv-gpy
json=target/gpy_timing.json
rm -f "$json"
if [ -f "$ref/gplvm_ref.py" ]; then
  if [ ! -x "$venv/bin/python" ]; then
    python3 -m venv "$venv" && "$venv/bin/pip" install --quiet --disable-pip-version-check \
      "gpy>=1.15,<1.16" numpy scipy pyarrow threadpoolctl || echo "GPy could not be installed: skipping it"
  fi
  if [ -x "$venv/bin/python" ] && "$venv/bin/python" -c "import GPy" 2>/dev/null; then
    echo "timing GPy (one thread) ..." >&2
    "$venv/bin/python" "$ref/gplvm_ref.py" --mode timing --ns 200,400,800,1600 --ds 40 --reps 5 \
      --json-out "$json" >/dev/null || echo "GPy timing failed: skipping it"
  fi
else
  echo "$ref not found: GPy skipped"
fi
[ -f "$json" ] && export REPRISE_GPY_TIMING="$PWD/$json"
cargo test --release -p reprise-numerics --test gplvm_timing -- --ignored --nocapture 2>&1 | grep -v "^test \|^running\|^$"
