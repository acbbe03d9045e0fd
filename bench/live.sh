#!/usr/bin/env bash
# The live server's speed, in one run on this machine:
#   1. each system's step and the rig's evaluation, one character on one core (live_bench);
#   2. `reprise-serve` pinned to core 0, one session of four systems side by side, the
#      client pinned to core 1 (frames per second, gaps between frames, command to frame);
#   3. the same server with 32 sessions at once (the sessions' limit), then the most
#      sessions that all hold the corpus rate, doubling from 32 while they do;
#   4. with CHROMIUM=1, command to changed pixels in headless Chromium (the page's own
#      measure, printed by the game's browser test on a short-fitted pipeline).
# Needs the default pipeline's artifacts (`target/release/reprise run`).
#   bench/live.sh [ARTIFACT_DIR [SECONDS]]       (default artifacts/dragon-face, 20)
set -euo pipefail
cd "$(dirname "$0")/.."
dir=${1:-artifacts/dragon-face}
seconds=${2:-20}
[ -f "$dir/bridges.parquet" ] && [ -f "$dir/mg_edges.parquet" ] \
  || { echo "$dir has no bridges or Motion Graph: target/release/reprise run"; exit 1; }
cargo build --release -q -p reprise --bin reprise-serve && cargo build --release -q -p reprise-serve --example load
cargo build --release -q -p reprise-live --example live_bench
cores=$(nproc)
pin() { if [ "$cores" -ge 2 ]; then taskset -c "$1" "${@:2}"; else "${@:2}"; fi; }
[ "$cores" -ge 2 ] || echo "one core: server and client share it (the figures are pessimistic)"
echo "## Steps, one core"
pin 0 target/release/examples/live_bench "$dir" "$seconds"
records=$(mktemp -d)
trap 'kill "$server" 2>/dev/null || true; rm -rf "$records"' EXIT
# Starts the server on core 0 with at most $1 sessions; sets $server and $addr.
start() {
  kill "${server:-}" 2>/dev/null || true
  local log="$records/serve-$1.log"
  pin 0 target/release/reprise-serve --artifacts "$dir" --listen 127.0.0.1:0 --max-sessions "$1" \
    --record-dir "$records" >"$log" 2>&1 &
  server=$!
  for _ in $(seq 600); do
    addr=$(sed -n 's|.*http://\([0-9.:]*\)/.*|\1|p' "$log" | head -1)
    [ -n "$addr" ] && return 0
    sleep 0.1
  done
  echo "reprise-serve did not start:"; cat "$log"; exit 1
}
echo; echo "## One session, four systems side by side (server on core 0, client on core 1)"
start 1
pin 1 target/release/examples/load "$addr" 1 "$seconds"
echo; echo "## 32 sessions"
start 32
pin 1 target/release/examples/load "$addr" 32 "$seconds"
n=64
while [ "$n" -le 512 ]; do
  echo; echo "## $n sessions"
  start "$n"
  out=$(pin 1 target/release/examples/load "$addr" "$n" "$seconds")
  echo "$out"
  echo "$out" | grep -q "sessions below [0-9.]*: 0$" || break
  n=$((n * 2))
done
if [ "${CHROMIUM:-0}" = 1 ]; then
  echo; echo "## Command to changed pixels, headless Chromium"
  cargo test --release -q --test e2e the_game_plays_in_chromium -- --nocapture 2>&1 | grep -E "command to pixels|SKIPPED|panicked" || true
fi
