#!/usr/bin/env bash
# The pipeline on a many-label character of our own making: the dragon-face corpus cut into
# 48 labels (each usable take its own label, the 16 longest halved), with the shipped
# pipeline's parameters. Prints per stage its seconds and peak memory (from the run's lock
# file), beside the default 8-label pipeline's where its lock is present (same machine:
# run `target/release/reprise run` first for a reference of the same run), and the size of
# the artifacts.
#   bench/many-labels.sh [LABELS]      (default 48)
set -euo pipefail
cd "$(dirname "$0")/.."
want=${1:-48}
bin=${REPRISE_BIN:-target/release/reprise}  # REPRISE_BIN: binaries copied elsewhere, to rebuild meanwhile
[ -x "$bin" ] || { echo "$bin not found: cargo build --release"; exit 1; }
dir=target/many-labels
mkdir -p "$dir/scripts"
sed -e "s|^name = \"dragon-face\"|name = \"many-labels\"|" \
    -e "s|^artifacts = \"artifacts/dragon-face\"|artifacts = \"artifacts\"|" \
    -e "s|^inputs.labels = .*|inputs.labels = \"labels.toml\"|" \
    -e "s|^inputs.scripts = .*|inputs.scripts = \"scripts/demo.toml\"|" \
    pipeline.toml > "$dir/pipeline.toml"
# Ingest first: the labels are cut from its clips.
printf '[[rule]]\npattern = "*"\nlabel = "all"\n' > "$dir/labels.toml"
"$bin" run --pipeline "$dir/pipeline.toml" --to ingest >/dev/null
"$bin" inspect --head 1000 --columns clip,frames "$dir/artifacts/clips.parquet" > "$dir/clips.txt"
python3 - "$dir" "$want" <<'PY'
import sys
d, want = sys.argv[1], int(sys.argv[2])
clips = []
for line in open(f"{d}/clips.txt"):
    cells = [c.strip() for c in line.strip().strip("|").split("|")]
    if len(cells) == 2 and cells[1].isdigit():
        clips.append((cells[0], int(cells[1])))
excluded = {"curious_take04", "surprise_take04"}  # as the shipped labels file excludes them
usable = [c for c in clips if c[0] not in excluded]
split = {c[0] for c in sorted(usable, key=lambda c: -c[1])[: max(0, want - len(usable))]}
out = ["# bench/many-labels.sh: every usable dragon-face take its own label, the longest halved."]
first = None
for name, n in usable:
    parts = [(0, n // 2 - 1, f"{name}_a"), (n // 2, n - 1, f"{name}_b")] if name in split else [(0, n - 1, name)]
    for start, end, label in parts:
        first = first or (label, name, start)
        out.append(f'[[range]]\nclip = "{name}"\nstart = {start}\nend = {end}\nlabel = "{label}"')
out.append('[[exclude]]\nclip = "neutral_take01"\nstart = 121\nend = 150\nreason = "off-screen"')
open(f"{d}/labels.toml", "w").write("\n".join(out) + "\n")
label, clip, frame = first
open(f"{d}/scripts/demo.toml", "w").write(
    f'[[script]]\nname = "demo"\nseed = 1\nstart = {{ label = "{label}", clip = "{clip}", frame = {frame} }}\n\n'
    '[[script.command]]\ntype = "idle"\nduration = 1.0\n')
labels = sum(2 if n in split else 1 for n, _ in usable)
print(f"{labels} labels from {len(usable)} takes")
PY
start=$(date +%s)
"$bin" run --pipeline "$dir/pipeline.toml" > "$dir/run.log" 2>&1 || { tail -20 "$dir/run.log"; exit 1; }
echo "whole pipeline: $(( $(date +%s) - start )) s wall (see $dir/run.log)"
python3 - "$dir/artifacts/reprise.lock" artifacts/dragon-face/reprise.lock <<'PY'
import json, os, sys
many = json.load(open(sys.argv[1]))["stages"]
ref = json.load(open(sys.argv[2]))["stages"] if os.path.exists(sys.argv[2]) else {}
print(f"{'stage':<14} {'seconds':>9} {'peak MB':>8}   {'8 labels: s':>11} {'MB':>6} {'ratio s':>8}")
for name, e in many.items():
    r = ref.get(name, {})
    ratio = f"{e['seconds'] / r['seconds']:.1f}" if r.get("seconds") else "-"
    mb = lambda x: f"{x:.0f}" if x is not None else "-"
    print(f"{name:<14} {e['seconds']:>9.1f} {mb(e.get('peak_rss_mb')):>8}   {r.get('seconds', float('nan')):>11.1f} {mb(r.get('peak_rss_mb')):>6} {ratio:>8}")
PY
du -sh "$dir/artifacts" | awk '{print "artifacts: " $1}'
