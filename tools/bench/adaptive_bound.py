#!/usr/bin/env python3
"""How much adaptive sampling could gain on one reference, and what its error estimate sees.

Behind "What adaptive sampling could gain on the Cornell box" in "Adaptive sampling at equal
time" (docs/journal/benchmarks-2026-11.md, with the full table). For a
reference of scenes/references/manifest.json, renders SEEDS seeds at SPP/2 and SPP samples
per pixel (the same sample sequences: a pixel's first SPP/2 samples are the SPP/2 render) and
compares, per pixel, against the reference (net of its own noise, from its variance image):

- the true squared error of the pixel's mean (averaged over the seeds);
- the estimate adaptive sampling uses, the sample variance over n (render --variance);
- a two-halves estimate, (a - b)^2 / 4 for the means a and b of the first and second half;

by bands of the reference's brightness. Then the gain in squared error that spreading the
same number of samples in proportion to each estimate (smoothed over 5 x 5 pixels) would
bring if each pixel's error fell as 1/n, against uniform sampling; "true" is the ideal.

Run with the references' virtualenv (it reads EXR with Mitsuba's Bitmap, as tools/peers):

    cargo build --release
    ~/.cache/strata/refs-venv/bin/python tools/bench/adaptive_bound.py cornell-box.path
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile

import numpy as np
import mitsuba as mi

REPO = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
mi.set_variant("scalar_rgb")


def read(path):
    return np.array(mi.Bitmap(path), dtype=np.float64)[..., :3]


def box(a, k):
    """Mean over each pixel's k x k neighbourhood (edges repeated)."""
    r = k // 2
    p = np.pad(a, r, mode="edge")
    return np.lib.stride_tricks.sliding_window_view(p, (k, k)).mean(axis=(-1, -2))


def gain(true, estimate):
    """Squared error of uniform sampling over that of n proportional to sqrt(estimate)."""
    n = np.sqrt(np.maximum(box(estimate, 5), 1e-30))
    n /= n.mean()
    return true.mean() / (true / n).mean()


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("job", help="reference name, e.g. cornell-box.path")
    ap.add_argument("--spp", type=int, default=256)
    ap.add_argument("--seeds", type=int, default=8)
    ap.add_argument("--render", default=os.path.join(REPO, "target/release/render"))
    args = ap.parse_args()
    manifest = json.load(open(os.path.join(REPO, "scenes/references/manifest.json")))
    entry = next(r for r in manifest["references"]
                 if os.path.basename(r["reference"]) == args.job + ".exr")
    ref = read(os.path.join(REPO, entry["reference"]))
    ref_var = read(os.path.join(REPO, entry["variance"]))
    base = [args.render, os.path.join(REPO, entry["scene"])] + entry["strata_args"] + ["--no-png"]
    true, sigma, halves = [], [], []
    with tempfile.TemporaryDirectory() as tmp:
        for seed in range(args.seeds):
            full, half, var = (os.path.join(tmp, f) for f in ("full.exr", "half.exr", "var.exr"))
            run = lambda spp, out, *extra: subprocess.run(
                base + ["--spp", str(spp), "--seed", str(seed), "-o", out, *extra],
                check=True, capture_output=True)
            run(args.spp, full, "--variance", var)
            run(args.spp // 2, half)
            img, a = read(full), read(half)
            b = 2 * img - a
            true.append(((img - ref) ** 2 - ref_var).sum(-1))
            sigma.append(read(var).sum(-1))
            halves.append(((a - b) ** 2 / 4).sum(-1))
    true = np.maximum(np.mean(true, 0), 0)
    sigma_mean, halves_mean = np.mean(sigma, 0), np.mean(halves, 0)
    lum = ref.mean(-1)
    edges = [0, *np.quantile(lum, [0.25, 0.5, 0.75, 0.95]), np.inf]
    print(f"{args.job}, {args.spp} spp, {args.seeds} seeds: squared error of the pixel means "
          f"(sum over RGB), per pixel, by the reference's brightness")
    print()
    print("| pixels by brightness | share of the pixels | share of the error | "
          "sample variance / n ÷ true | two halves ÷ true |")
    print("|---|---|---|---|---|")
    names = ["darkest quarter", "second quarter", "third quarter", "next 20%", "brightest 5%"]
    for name, lo, hi in zip(names, edges[:-1], edges[1:]):
        sel = (lum >= lo) & (lum < hi)
        print(f"| {name} | {sel.mean():.2f} | {true[sel].sum() / true.sum():.2f} | "
              f"{sigma_mean[sel].mean() / true[sel].mean():.1f} | "
              f"{halves_mean[sel].mean() / true[sel].mean():.2f} |")
    print(f"| all | 1 | 1 | {sigma_mean.mean() / true.mean():.1f} | "
          f"{halves_mean.mean() / true.mean():.2f} |")
    print()
    print("Squared error, uniform ÷ samples in proportion to the estimate (5 × 5 smoothing, "
          "error falling as 1/n):")
    print()
    print("| allocation by | gain |")
    print("|---|---|")
    print(f"| the true error (the ideal) | {gain(true, true):.2f} |")
    print(f"| sample variance / n, one seed | {gain(true, sigma[0]):.2f} |")
    print(f"| two halves, one seed | {gain(true, halves[0]):.2f} |")


if __name__ == "__main__":
    sys.exit(main())
