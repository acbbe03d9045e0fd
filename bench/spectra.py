#!/usr/bin/env python3
"""PCA spectra per label, scaled and unscaled: the table in datasets/dragon-face/README.md.

    bench/spectra.sh ARTIFACTS_DIR [NAME]

reads `labeled_frames.parquet` and (when present) `scales.parquet` of a pipeline's
artifacts directory and prints a Markdown table: per label, the frames, the number of
components d needed to explain 0.85 / 0.95 / 0.99 of the variance on the scaled controls
(z_i = w_i (p_i - mean_i), the pca stage's input) and on the raw controls, and the share of
the first component in each. Uses the same frames and controls as the pca stage: the used
controls of `scales` (scaled), or every control that moves in the label (unscaled, and
scaled when there is no rig).
"""
import sys

import numpy as np
import polars as pl

META = {"label", "segment_id", "clip", "frame", "time"}
THRESHOLDS = (0.85, 0.95, 0.99)


def spectrum(z):
    z = z - z.mean(axis=0)
    s = np.linalg.svd(z, compute_uv=False)
    v = s**2
    return v / v.sum()


def dims(ratio):
    c = np.cumsum(ratio)
    return [int(np.searchsorted(c, t - 1e-12) + 1) for t in THRESHOLDS]


def main():
    root = sys.argv[1].rstrip("/")
    name = sys.argv[2] if len(sys.argv) > 2 else root
    frames = pl.read_parquet(f"{root}/labeled_frames.parquet")
    controls = [c for c in frames.columns if c not in META]
    try:
        scales = pl.read_parquet(f"{root}/scales.parquet")
    except FileNotFoundError:
        scales = None
    print(f"**{name}**\n")
    print("| label | frames | d 0.85 / 0.95 / 0.99 scaled | first (scaled) | d 0.85 / 0.95 / 0.99 unscaled | first (unscaled) |")
    print("|---|---|---|---|---|---|")
    for label in frames["label"].unique(maintain_order=True):
        rows = frames.filter(pl.col("label") == label)
        p = rows.select(controls).to_numpy().astype(float)
        moving = p.std(axis=0) > 0
        raw = spectrum(p[:, moving])
        if scales is not None:
            s = scales.filter((pl.col("label") == label) & pl.col("used"))
            cols = [controls.index(c) for c in s["control"]]
            sc = spectrum(p[:, cols] * s["weight"].to_numpy())
            scaled = " / ".join(map(str, dims(sc)))
            first = f"{sc[0]:.2f}"
        else:
            scaled, first = "no rig", "–"
        print(
            f"| {label} | {len(rows)} | {scaled} | {first} | {' / '.join(map(str, dims(raw)))} | {raw[0]:.2f} |"
        )
    print()


if __name__ == "__main__":
    main()
