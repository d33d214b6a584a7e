#!/usr/bin/env python3
"""Markdown tables from the `convergence` tool's CSV files: per configuration, the RMSE at a
few sample counts, the fitted slope, and the samples and seconds needed to reach a target
RMSE (interpolated linearly in log-log between the two ladder points around it), with the
ratio to a baseline configuration.

    tools/bench/convergence_table.py docs/convergence/cornell-box.path/convergence.csv \
        [--target RMSE] [--baseline "random, mis"] [--at 16,256]

Standard library only. The target defaults to the worst configuration's RMSE at the
largest spp, so every configuration reaches it; points below 2x the reference's noise floor
(RMSE² < 4 × reference variance) are left out of the fit and the interpolation.
"""
import argparse
import csv
import math
import sys


def label(row):
    parts = [row["sampler"]]
    if row["hemisphere"]:
        parts.append(row["hemisphere"])
    if row["strategy"]:
        parts.append(row["strategy"])
    # Written since --emitter-samples.
    if row.get("emitter_samples"):
        parts.append(row["emitter_samples"] + " emitter rays")
    return ", ".join(parts)


def fit(points):
    pts = [(math.log(x), math.log(y)) for x, y in points if x > 0 and y > 0]
    if len(pts) < 2:
        return None
    mx = sum(p[0] for p in pts) / len(pts)
    my = sum(p[1] for p in pts) / len(pts)
    sxx = sum((p[0] - mx) ** 2 for p in pts)
    if sxx == 0:
        return None
    return sum((p[0] - mx) * (p[1] - my) for p in pts) / sxx


def reach(points, target):
    """First x where the piecewise log-log curve falls to target (points sorted by x)."""
    for (x0, y0), (x1, y1) in zip(points, points[1:]):
        if y0 >= target >= y1 and y0 > 0 and y1 > 0 and y0 != y1:
            t = (math.log(y0) - math.log(target)) / (math.log(y0) - math.log(y1))
            return math.exp(math.log(x0) + t * (math.log(x1) - math.log(x0)))
    if points and points[0][1] <= target:
        return points[0][0]
    return None


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("csv")
    ap.add_argument("--target", type=float)
    ap.add_argument("--baseline")
    ap.add_argument("--at", default="16,256")
    args = ap.parse_args()

    configs = {}
    with open(args.csv) as f:
        for row in csv.DictReader(f):
            c = configs.setdefault(label(row), [])
            c.append({k: float(row[k]) for k in ("spp", "seconds", "rmse", "reference_variance")})
    if not configs:
        sys.exit(f"{args.csv}: no rows")
    usable = {
        k: [p for p in v if p["rmse"] ** 2 >= 4 * p["reference_variance"]] for k, v in configs.items()
    }
    target = args.target
    if target is None:
        target = max(v[-1]["rmse"] for v in configs.values())
    baseline = args.baseline or next(iter(configs))
    at = [int(a) for a in args.at.split(",")]

    def by_spp(k):
        return [(p["spp"], p["rmse"]) for p in usable[k]]

    def by_time(k):
        return sorted((p["seconds"], p["rmse"]) for p in usable[k])

    base_spp = reach(by_spp(baseline), target) if baseline in usable else None
    base_sec = reach(by_time(baseline), target) if baseline in usable else None

    head = ["configuration"] + [f"RMSE at {a} spp" for a in at] + [
        "slope", f"spp to RMSE {target:.3g}", f"× fewer than {baseline}",
        f"seconds to RMSE {target:.3g}", f"× faster than {baseline}"]
    print("| " + " | ".join(head) + " |")
    print("|" + "---|" * len(head))
    for k, pts in configs.items():
        rm = {int(p["spp"]): p["rmse"] for p in pts}
        slope = fit(by_spp(k))
        spp = reach(by_spp(k), target)
        sec = reach(by_time(k), target)
        cells = [k] + [f"{rm[a]:.4g}" if a in rm else "–" for a in at]
        cells.append(f"{slope:+.2f}" if slope is not None else "–")
        cells.append(f"{spp:.3g}" if spp else "not reached")
        cells.append(f"{base_spp / spp:.2f}" if spp and base_spp else "–")
        cells.append(f"{sec:.3g}" if sec else "not reached")
        cells.append(f"{base_sec / sec:.2f}" if sec and base_sec else "–")
        print("| " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
