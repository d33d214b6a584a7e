#!/usr/bin/env python3
"""What path guiding could gain on the Cornell box's path tracing: a bound from a probe.

Behind BENCHMARKS.md's "Path guiding: what it could gain". Applies guiding_bound.patch (a
throwaway guide that is not part of strata: src/integrators/guide.rs in the patch) to a
scratch checkout of HEAD, builds it once per bin count B, trains a guide with a separate
render of TRAIN spp (its samples are not used in the image), and renders SEEDS seeds at SPP
with and without it on one thread (the one-path tracer, --no-path-lanes, in both arms).

For each arm it prints the squared error against the Mitsuba reference (net of the
reference's own noise), the per-pixel variance across seeds, the mean difference from the
reference (guiding must not bias the image), the median render seconds, and the squared
error × seconds (lower is better) relative to the unguided arm.

Run with the references' virtualenv (it reads EXR with Mitsuba's Bitmap, as tools/peers):

    ~/.cache/strata/refs-venv/bin/python tools/bench/guiding_bound.py
"""
import argparse
import os
import subprocess
import tempfile

import numpy as np
import mitsuba as mi

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.abspath(os.path.join(HERE, "..", ".."))
mi.set_variant("scalar_rgb")
SCENE = "scenes/cornell-box.gltf"
REF = "scenes/references/cornell-box.path"
ARGS = ["--integrator", "path", "--max-depth", "8", "--resolution", "160x160", "--no-png", "--no-path-lanes"]


def read(path):
    return np.array(mi.Bitmap(path), dtype=np.float64)[..., :3]


def build(src, target, bins):
    path = os.path.join(src, "src/integrators/guide.rs")
    with open(path) as f:
        text = f.read()
    start = text.index("pub const B: usize = ")
    end = text.index(";", start)
    with open(path, "w") as f:
        f.write(text[:start] + f"pub const B: usize = {bins}" + text[end:])
    subprocess.run(["cargo", "build", "--release", "--quiet", "--bin", "render"], cwd=src, check=True,
                   env={**os.environ, "CARGO_TARGET_DIR": target})
    return os.path.join(target, "release", "render")


def evaluate(render, src, spp, seeds, scratch, guide=None):
    ref, refvar = read(os.path.join(REPO, REF + ".exr")), read(os.path.join(REPO, REF + ".var.exr"))
    env = dict(os.environ)
    if guide:
        env["STRATA_GUIDE"] = guide
    images, seconds = [], []
    for seed in range(seeds):
        out = os.path.join(scratch, f"eval{seed}.exr")
        r = subprocess.run([render, os.path.join(src, SCENE)] + ARGS + [
            "--spp", str(spp), "--seed", str(seed), "--threads", "1", "--stats", "-o", out],
            env=env, capture_output=True, text=True, check=True)
        line = next(l for l in (r.stdout + r.stderr).splitlines() if l.startswith("time:"))
        seconds.append(float(line.split("render ")[1].split(" s")[0]))
        images.append(read(out))
    images = np.array(images)
    mse = np.mean([((im - ref) ** 2).mean() for im in images]) - refvar.mean()
    return {"mse": mse, "var": images.var(axis=0, ddof=1).mean(), "bias": (images.mean(0) - ref).mean(),
            "seconds": float(np.median(seconds))}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--spp", type=int, default=256)
    ap.add_argument("--seeds", type=int, default=4)
    ap.add_argument("--train", default="64,1024", help="training spp, comma-separated")
    ap.add_argument("--bins", default="16,32", help="bins per angular axis, comma-separated")
    ap.add_argument("--target-dir", default=os.path.expanduser("~/.cache/strata/guiding-target"))
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as scratch:
        src = os.path.join(scratch, "src")
        subprocess.run(["git", "worktree", "add", "--quiet", "--detach", src, "HEAD"], cwd=REPO, check=True)
        try:
            subprocess.run(["git", "apply", os.path.join(HERE, "guiding_bound.patch")], cwd=src, check=True)
            print(f"Cornell box, path, 160x160, {args.spp} spp, {args.seeds} seeds, 1 thread")
            print(f"{'arm':<28} {'MSE (net)':>10} {'variance':>10} {'mean diff':>10} {'seconds':>8} "
                  f"{'var ratio':>9} {'MSE x s ratio':>13}")
            base = None
            for bins in [int(b) for b in args.bins.split(",")]:
                render = build(src, args.target_dir, bins)
                if base is None:
                    base = evaluate(render, src, args.spp, args.seeds, scratch)
                    report("cosine (no guide)", base, base)
                for train in [int(t) for t in args.train.split(",")]:
                    guide = os.path.join(scratch, f"guide-{bins}-{train}.bin")
                    subprocess.run([render, os.path.join(src, SCENE)] + ARGS + [
                        "--spp", str(train), "--seed", "1000", "-o", os.path.join(scratch, "train.exr")],
                        env={**os.environ, "STRATA_GUIDE_TRAIN": guide}, check=True, capture_output=True)
                    report(f"guide B={bins}, trained {train} spp",
                           evaluate(render, src, args.spp, args.seeds, scratch, guide), base)
        finally:
            subprocess.run(["git", "worktree", "remove", "--force", src], cwd=REPO, check=True)


def report(name, arm, base):
    print(f"{name:<28} {arm['mse']:>10.3e} {arm['var']:>10.3e} {arm['bias']:>+10.1e} {arm['seconds']:>8.2f} "
          f"{arm['var'] / base['var']:>9.2f} {arm['mse'] * arm['seconds'] / (base['mse'] * base['seconds']):>13.2f}")


if __name__ == "__main__":
    main()
