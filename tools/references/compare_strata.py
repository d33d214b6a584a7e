#!/usr/bin/env python3
"""Renders strata at the settings of each reference in scenes/references/manifest.json and
compares it with the Mitsuba reference (a diagnostic, not a test; run it in the refs venv):

    ~/.cache/strata/refs-venv/bin/python tools/references/compare_strata.py \
        [--render target/release/render] [--spp 256] [--seeds 4] [--out /tmp/strata-compare] [JOB ...]

For each job it renders `--seeds` images with different seeds (spp each), takes their mean m and
their per-pixel variance of the mean v_s (sample variance / seeds), and reports against the
reference r (variance of the mean v_r, from the .var.exr):
- ratio: mean(m) / mean(r) over all pixels and channels (an overall bias shows here first),
- mean |m - r| / mean(r) (the "mean relative difference"; includes both images' noise),
- z: the per-pixel (m - r) / sqrt(v_s + v_r), pooled over RGB: mean z (should be ~0), the
  fraction of pixels with |z| > 3 (~0.3% for pure noise; the variance estimates are themselves
  noisy, so a few times that is not alarming), and the same on 4x4-pixel block means
  (localised bias shows up there),
- idiff's verdict on m vs r with -fail 0.05 -failpercent 1 (printed, informative only).
Pixels whose normals mask (scenes/references/<scene>.mask.exr) has R > 0 are left out of the
z statistics and the ratio (see normals_mask() in mitsuba_refs.py); their count is printed.
"""
import argparse
import json
import os
import subprocess
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))

import mitsuba as mi  # noqa: E402


def read_exr(path):
    return np.array(mi.Bitmap(path), dtype=np.float64)[..., :3]


def block(a, k):
    h, w = a.shape[0] // k * k, a.shape[1] // k * k
    return a[:h, :w].reshape(h // k, k, w // k, k, -1).mean(axis=(1, 3))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("jobs", nargs="*")
    ap.add_argument("--render", default=os.path.join(REPO, "target", "release", "render"))
    ap.add_argument("--spp", type=int, default=256)
    ap.add_argument("--seeds", type=int, default=4)
    ap.add_argument("--threads", type=int, default=0)
    ap.add_argument("--out", default="/tmp/strata-compare")
    args = ap.parse_args()
    mi.set_variant("scalar_rgb")
    with open(os.path.join(REPO, "scenes", "references", "manifest.json")) as f:
        manifest = json.load(f)
    os.makedirs(args.out, exist_ok=True)
    for e in manifest["references"]:
        name = os.path.basename(e["reference"])[:-4]
        if args.jobs and name not in args.jobs:
            continue
        imgs = []
        for seed in range(args.seeds):
            out = os.path.join(args.out, f"{name}.seed{seed}.exr")
            cmd = [args.render, os.path.join(REPO, e["scene"]), "-o", out, "--spp", str(args.spp),
                   "--seed", str(1000 + seed), "--threads", str(args.threads), "--no-png"] + e["strata_args"]
            r = subprocess.run(cmd, capture_output=True, text=True)
            if r.returncode != 0:
                print(f"{name}: strata failed: {' '.join(cmd)}\n{r.stderr.strip()}")
                break
            imgs.append(read_exr(out))
        if len(imgs) != args.seeds:
            continue
        stack = np.stack(imgs)
        m = stack.mean(axis=0)
        vs = stack.var(axis=0, ddof=1) / args.seeds if args.seeds > 1 else np.zeros_like(m)
        ref = read_exr(os.path.join(REPO, e["reference"]))
        vr = read_exr(os.path.join(REPO, e["variance"]))
        keep = np.ones(ref.shape[:2], dtype=bool)
        if e.get("mask") and os.path.exists(os.path.join(REPO, e["mask"])):
            keep = read_exr(os.path.join(REPO, e["mask"]))[..., 0] <= 0
        mi.Bitmap(m.astype(np.float32), mi.Bitmap.PixelFormat.RGB).write(os.path.join(args.out, f"{name}.strata.exr"))
        mean_ref = ref.mean()
        ratio = m[keep].mean() / ref[keep].mean()
        mrd = np.abs(m - ref).mean() / mean_ref
        denom = np.sqrt(vs + vr)
        valid = (denom > 0) & keep[..., None]
        z = np.where(valid, (m - ref) / np.where(valid, denom, 1), 0.0)
        # blocks: variance of a block mean = mean of variances / k^2 (pixels independent)
        k = 4
        bz_den = np.sqrt(block(vs + vr, k) / (k * k))
        bvalid = (bz_den > 0) & (block(keep[..., None].astype(float), k) == 1)
        bz = np.where(bvalid, (block(m, k) - block(ref, k)) / np.where(bvalid, bz_den, 1), 0.0)
        # zero-variance pixels (background, directly seen emitters) must agree up to float rounding
        exact0 = (denom == 0) & (np.abs(m - ref) > 1e-5 * np.maximum(np.abs(ref), 1e-30))
        idiff = subprocess.run(["idiff", "-fail", "0.05", "-failpercent", "1", "-warn", "0.02",
                                os.path.join(args.out, f"{name}.strata.exr"), os.path.join(REPO, e["reference"])],
                               capture_output=True, text=True)
        verdict = (idiff.stdout.strip().splitlines() or ["?"])[-1]
        print(f"{name}: masked {int((~keep).sum())} px  ratio {ratio:.5f}  mean|rel diff| {mrd:.4f}  z mean {z[valid].mean():+.3f} "
              f"|z|>3 {np.mean(np.abs(z[valid]) > 3) * 100:.2f}%  4x4 blocks: z mean {bz[bvalid].mean():+.2f} "
              f"|z|>3 {np.mean(np.abs(bz[bvalid]) > 3) * 100:.2f}% |z|max {np.abs(bz).max():.1f}  "
              f"zero-variance values differing by >1e-5 rel.: {int(exact0.sum())}  idiff: {verdict}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
