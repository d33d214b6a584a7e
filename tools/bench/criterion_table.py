#!/usr/bin/env python3
"""Turns the text output of `cargo bench --bench backends` into Markdown tables per mesh
(medians: criterion's middle estimate): BENCHMARKS.md's "BVH backends per mesh" condenses
them, and docs/journal/benchmarks-2026-11.md has them in full.

    cargo bench --bench backends 2>&1 | tee bench.log; python3 tools/bench/criterion_table.py bench.log
"""
import re
import sys
from collections import OrderedDict

UNIT = {"ns": 1e-9, "µs": 1e-6, "us": 1e-6, "ms": 1e-3, "s": 1.0}


def main(path):
    lines = open(path, encoding="utf-8").read().splitlines()
    results = OrderedDict()
    name = None
    for i, line in enumerate(lines):
        m = re.match(r"^((?:build|trace)/.+)$", line.strip())
        if m and not line.startswith("Benchmarking") and i + 1 < len(lines) and "time:" in lines[i + 1]:
            name = m.group(1)
            continue
        if name and "time:" in line:
            v = re.findall(r"([\d.]+) (ns|µs|us|ms|s)\b", line)
            results.setdefault(name, {})["time"] = float(v[1][0]) * UNIT[v[1][1]]
        elif name and "thrpt:" in line:
            v = re.findall(r"([\d.]+) (Kelem|Melem|Gelem|elem)/s", line)
            scale = {"elem": 1e-6, "Kelem": 1e-3, "Melem": 1.0, "Gelem": 1e3}[v[1][1]]
            results[name]["mrays"] = float(v[1][0]) * scale
            name = None
    meshes = OrderedDict()
    for key, r in results.items():
        kind, mesh, bench = key.split("/", 2)
        meshes.setdefault(mesh, {"build": {}, "trace": {}})[kind][bench] = r
    for mesh, d in meshes.items():
        print(f"\n### {mesh}\n")
        print("| BVH build | 1 thread | all threads |\n|---|---|---|")
        for backend in ("embree", "obvhs"):
            cells = [d["build"].get(f"{backend}/{t}") for t in ("1 threads", "2 threads")]
            print(f"| {backend} | " + " | ".join(f"{c['time'] * 1e3:.1f} ms" if c else "–" for c in cells) + " |")
        print("\n| Mrays/s | 1 thread | all threads |\n|---|---|---|")
        for backend in ("embree", "obvhs"):
            for q in ("closest", "any"):
                for k in ("coherent", "incoherent"):
                    cells = [d["trace"].get(f"{backend} {q}/{k}, {t}") for t in ("1 thread", "all threads")]
                    print(f"| {backend} {q}-hit, {k} | " + " | ".join(f"{c['mrays']:.2f}" if c else "–" for c in cells) + " |")


if __name__ == "__main__":
    main(sys.argv[1])
