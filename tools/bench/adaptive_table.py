#!/usr/bin/env python3
"""Markdown table of an equal-time comparison from the `convergence` tool's CSV
(`--time-limits` with `--adaptive none,relative,absolute`): per time limit, the RMSE and
relative MSE of uniform sampling and of each adaptive mode, and the adaptive/uniform
ratio of the mean squared error (MSE ratio < 1: adaptive is better at equal time).

    tools/bench/adaptive_table.py docs/adaptive/cornell-box.path/convergence.csv [--corrected]

--corrected uses the RMSE with the reference's own noise removed (for references whose
noise is not far below the renders' error). Standard library only.
"""
import argparse
import csv
import sys


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("csv")
    ap.add_argument("--corrected", action="store_true")
    args = ap.parse_args()
    rows = list(csv.DictReader(open(args.csv)))
    if not rows or "time_limit" not in rows[0]:
        sys.exit(f"{args.csv}: no time_limit column (not a --time-limits run)")
    key = "rmse_corrected" if args.corrected else "rmse"
    by = {}
    for r in rows:
        by[(r["adaptive"] or "none", float(r["time_limit"]))] = r
    modes = [m for m in ("none", "relative", "absolute") if any(k[0] == m for k in by)]
    limits = sorted({k[1] for k in by})
    name = "RMSE (reference noise removed)" if args.corrected else "RMSE"
    head = ["seconds"]
    head += [f"{name}, {'uniform' if m == 'none' else m}" for m in modes]
    head += [f"relMSE, {'uniform' if m == 'none' else m}" for m in modes]
    head += [f"MSE ratio, {m}" for m in modes if m != "none"]
    head += [f"relMSE ratio, {m}" for m in modes if m != "none"]
    head += ["mean spp, " + ("uniform" if m == "none" else m) for m in modes]
    print("| " + " | ".join(head) + " |")
    print("|" + "---|" * len(head))
    for t in limits:
        cells = [f"{t:g}"]
        get = lambda m, f: float(by[(m, t)][f]) if (m, t) in by else float("nan")
        cells += [f"{get(m, key):.3e}" for m in modes]
        cells += [f"{get(m, 'relmse'):.3e}" for m in modes]
        cells += [f"{(get(m, key) / get('none', key)) ** 2:.2f}" for m in modes if m != "none"]
        cells += [f"{get(m, 'relmse') / get('none', 'relmse'):.2f}" for m in modes if m != "none"]
        cells += [f"{get(m, 'spp'):.0f}" for m in modes]
        print("| " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
