#!/usr/bin/env python3
"""Plots lens-tracing rays/s against SoA batch size, from `realcam bench --sweep --json`.

    cargo build --release
    ./target/release/realcam bench --sweep --json > target/lens-sweep.json
    python3 benches/plot_lens_batch_sizes.py target/lens-sweep.json benches/lens_batch_sizes.png

Needs matplotlib (pip install matplotlib).
"""

import json
import sys
from collections import defaultdict

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

LABELS = {
    ("auto-vectorised", "baseline"): "SoA, auto-vectorised, baseline SSE2 (4 lanes)",
    ("auto-vectorised", "avx2"): "SoA, auto-vectorised, AVX2 (8 lanes)",
    ("auto-vectorised", "avx512"): "SoA, auto-vectorised, AVX-512 (16 lanes)",
}


def main() -> None:
    if len(sys.argv) != 3:
        sys.exit("usage: plot_lens_batch_sizes.py SWEEP.json OUT.png")
    report = json.load(open(sys.argv[1]))
    series = defaultdict(list)
    for entry in report["sweep"]:
        key = (entry["kernel"], entry["isa"])
        series[key].append((entry["batch"], entry["rays_per_s"] / 1e6))
    fig, ax = plt.subplots(figsize=(7.5, 5.5), dpi=120)
    for key, points in sorted(series.items()):
        points.sort()
        wide = "AVX, 8 lanes" if report["wide_uses_avx"] else "2 × 128-bit"
        label = LABELS.get(key, f"SoA, explicit wide::f32x8 ({wide})" if key[0] == "simd" else str(key))
        ax.plot([b for b, _ in points], [r for _, r in points], marker="o", label=label)
    scalar = report["scalar_rays_per_s"] / 1e6
    ax.axhline(scalar, color="black", linestyle="--", label="scalar per-ray (f32, AoS)")
    ax.axhline(4 * scalar, color="grey", linestyle=":", label="target: 4 × scalar")
    ax.set_xscale("log", base=2)
    ax.set_xlabel("rays per SoA batch")
    ax.set_ylabel("M rays / CPU-second, one thread")
    ax.set_ylim(bottom=0)
    ax.set_title(
        f"Lens tracing, {report['lens']} ({report['surfaces']} surfaces), film → scene"
    )
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=2)
    fig.tight_layout()
    fig.savefig(sys.argv[2])


if __name__ == "__main__":
    main()
