#!/usr/bin/env bash
# Renders a report in headless Chromium and saves a full-page screenshot, to check that
# every figure is present in a real browser, plus one of the transition player opened
# 12 frames after the first shown request is asked (<out>-player.png). Installs Debian's
# chromium if it is missing. The automated checks are the evaluate crate's browser tests
# (REPRISE_REPORT_PAGE=<page> cargo test --release -p reprise-evaluate report_page).
#   bench/report-screenshot.sh [reports/dragon-face/index.html] [out.png]
set -euo pipefail
cd "$(dirname "$0")/.."
page=${1:-reports/dragon-face/index.html}
out=${2:-target/report-screenshot.png}
[ -f "$page" ] || { echo "$page not found: run the pipeline first (target/release/reprise run)"; exit 1; }
if ! command -v chromium >/dev/null; then
  apt-get install -y -q chromium >/dev/null
fi
profile=$(mktemp -d)
chromium --headless --no-sandbox --disable-gpu --disable-quic --no-first-run --disable-background-networking \
  --disable-component-update --disable-sync --user-data-dir="$profile" --window-size=1280,4000 \
  --virtual-time-budget=10000 --screenshot="$out" "file://$PWD/$page" 2>/dev/null
chromium --headless --no-sandbox --disable-gpu --disable-quic --no-first-run --disable-background-networking \
  --disable-component-update --disable-sync --user-data-dir="$profile" --window-size=1280,1000 \
  --virtual-time-budget=10000 --screenshot="${out%.png}-player.png" "file://$PWD/$page#transition-player=0,12" 2>/dev/null
rm -rf "$profile"
echo "screenshots: $out ${out%.png}-player.png"
