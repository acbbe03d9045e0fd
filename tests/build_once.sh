#!/usr/bin/env bash
# From a fresh clone: the README's first command, then its second, then `reprise run`
# again — which must do no stage work (the stage binaries keep their code identity
# through the test build, so the cache holds). Slow (a cold build, the default run and
# the whole test suite): run it by hand or in CI, not from `cargo test`.
#   tests/build_once.sh [CLONE_DIR]
set -euo pipefail
src="$(cd "$(dirname "$0")/.." && pwd)"
dir="${1:-$(mktemp -d)/reprise}"
git clone --quiet "$src" "$dir"
cd "$dir"
# ../shared is where the tests find the public datasets; give the clone the same view.
if [ -d "$src/../shared" ] && [ ! -e ../shared ]; then ln -s "$src/../shared" ../shared; fi
cargo build --release && target/release/reprise run
ids() {
  for b in target/release/reprise-*; do
    if [ -f "$b" ] && [ -x "$b" ]; then { grep -aoE 'reprise-code-id=[0-9a-f]{64};' "$b" || true; } | sort -u; fi
  done
}
before="$(ids)"
cargo test --workspace --release
after="$(ids)"
[ "$before" = "$after" ] || { echo "build_once: the test build changed a stage's code identity"; exit 1; }
out="$(target/release/reprise run 2>&1)"
echo "$out"
if grep -q "^ *running " <<<"$out"; then
  echo "build_once: FAILED — the run after the tests did stage work"
  exit 1
fi
echo "build_once: ok — the run after the tests did no stage work"
