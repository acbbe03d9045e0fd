#!/usr/bin/env bash
# Renders a report in headless Chromium and saves a full-page screenshot, to check that
# every figure is present in a real browser. Installs Debian's chromium if it is missing.
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
  --screenshot="$out" "file://$PWD/$page" 2>/dev/null
rm -rf "$profile"
echo "screenshot: $out"
