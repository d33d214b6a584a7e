#!/usr/bin/env python3
"""Denoising at equal time (issue 30): raw path tracing against Open Image Denoise.

    tools/bench/denoise_quality.sh [--jobs cornell,spheres,helmet] [--out DIR]   # the wrapper:
    # nice -n 19, ~/.cache/strata/denoise-venv's python (numpy, flip-evaluator, OpenEXR)

Needs Open Image Denoise where `render` loads it from (README, "Denoising"):
    tools/oidn-prefix.sh && cargo build --release

For each job a ladder of 1, 2, 4, ... spp (up to the job's cap), at a fixed seed and --threads 2,
every rung rendered
  raw          `render ... --spp N`                       (time: the --stats line's render seconds)
  denoised     `render ... --spp N --denoise`             (render seconds, with the albedo and
               normal passes, + the --stats line's denoise seconds; prefilter on, the default)
  prefilter off  `render denoise <the denoised EXR> --denoise-prefilter off` (the same render's
               seconds + its own denoise seconds, from the EXR header)
each --repeats times (the same image each time: the seed is fixed), the fastest time kept
(render and denoise seconds each their minimum). Scene loading and writing are left out of every
time. Errors against the job's reference, over all pixels and channels:
  rmse         root mean square error
  rmse_surf    the same over the pixels whose reference is < 2 in every channel (leaves out
               emitters seen directly: OIDN rings around the Cornell box's light, radiance ~100,
               which dominates the plain RMSE)
  relmse       mean of (x - y)^2 / (y^2 + 0.01)
  flip         mean HDR-FLIP (flip-evaluator, exposures chosen from the reference)
Equal-time tables: at budgets between the rungs, each metric of raw and of denoised (denoised
seconds = render + denoise) by log-log interpolation between the two rungs that bracket the
budget, and their ratio raw / denoised (> 1: denoising wins).

Jobs: cornell (cornell-box.path against its Mitsuba reference), spheres (sphere-grid.path,
glossy, against its Mitsuba reference), helmet (the Flight Helmet under studio_small_05_1k,
320x240, against strata's own render at --helmet-ref-spp, as two halves of different seeds:
their RMSE / 2 is the reference's own noise, reported).
Output: DIR/<job>.csv (one row per rung and variant), DIR/RESULTS.md (tables), DIR/meta.json.
Images go to --work (not kept in the repository).
"""
import argparse
import csv
import json
import math
import os
import re
import subprocess
import sys
import time

import numpy as np
import OpenEXR
import flip_evaluator as flip

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SEED = 1000  # the Mitsuba references used seeds 0..31
REF_SEEDS = (9001, 9002)  # the helmet's reference halves
EPS = 0.01  # relMSE's epsilon
SURFACE_LIMIT = 2.0
ENV = "scenes/env/studio_small_05_1k/studio_small_05_1k.hdr"


def manifest_row(name):
    with open(os.path.join(REPO, "scenes/references/manifest.json")) as f:
        for r in json.load(f)["references"]:
            if r["reference"] == f"scenes/references/{name}.exr":
                return r
    raise KeyError(name)


def jobs(args):
    out = {}
    for key, name, cap in (("cornell", "cornell-box.path", args.cornell_max_spp),
                           ("spheres", "sphere-grid.path", args.spheres_max_spp)):
        r = manifest_row(name)
        out[key] = {"scene": r["scene"], "args": r["strata_args"], "max_spp": cap,
                    "reference": {"kind": "mitsuba", "path": r["reference"], "var": r["variance"],
                                  "spp": r["spp"], "variant": r["variant"]}}
    out["helmet"] = {"scene": "scenes/flight-helmet.gltf",
                     "args": ["--integrator", "path", "--env", ENV, "--resolution", "320x240"],
                     "max_spp": args.helmet_max_spp,
                     "reference": {"kind": "strata", "spp": args.helmet_ref_spp, "seeds": list(REF_SEEDS)}}
    return out


def read_exr(path):
    """{layer: H x W x 3 float64}: '' is the beauty (R, G, B), 'noisy' the raw one."""
    ch = OpenEXR.File(path, separate_channels=False).channels()
    layers = {}
    for k, v in ch.items():
        a = np.asarray(v.pixels, dtype=np.float64)
        if k in ("RGB", "RGBA"):
            layers[""] = a[..., :3]
        elif a.ndim == 3 and a.shape[2] >= 3:
            layers[k] = a[..., :3]
    if "" not in layers:  # channels stored apart
        layers[""] = np.stack([np.asarray(ch[c].pixels, dtype=np.float64) for c in "RGB"], axis=-1)
    return layers


def header_float(path, key):
    v = OpenEXR.File(path).header().get(key)
    return None if v is None else float(v)


def run(cmd):
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)}: {r.stderr.strip()}")
    return r.stdout + r.stderr


def render(args, job, spp, seed, out, denoise=False):
    cmd = [args.render, os.path.join(REPO, job["scene"])] + job["args"] + [
        "--spp", str(spp), "--seed", str(seed), "--threads", str(args.threads), "--no-png", "--stats", "-o", out]
    if denoise:
        cmd.append("--denoise")
    text = run(cmd)
    r = float(re.search(r"render ([0-9.]+) s", text).group(1))
    d = re.search(r"denoise ([0-9.]+) s", text)
    return r, float(d.group(1)) if d else 0.0


def denoise_file(args, src, out, prefilter):
    text = run([args.render, "denoise", src, "-o", out, "--denoise-prefilter", prefilter,
                "--threads", str(args.threads), "--no-png"])
    return float(re.search(r"denoised.* in ([0-9.]+) s", text).group(1))


class Reference:
    def __init__(self, img, noise_rms, label):
        self.img, self.noise_rms, self.label = img, noise_rms, label
        self.surface = np.all(img < SURFACE_LIMIT, axis=2)
        self.flip_ref = np.ascontiguousarray(np.maximum(img, 0).astype(np.float32))
        self.flip_params = None

    def metrics(self, x):
        d2 = (x - self.img) ** 2
        test = np.ascontiguousarray(np.maximum(x, 0).astype(np.float32))
        _, mean_flip, params = flip.evaluate(self.flip_ref, test, "HDR", applyMagma=False,
                                             parameters=dict(self.flip_params or {}))
        if self.flip_params is None:  # the exposures FLIP picked from the reference, kept for all
            self.flip_params = {k: params[k] for k in ("startExposure", "stopExposure", "numExposures")
                                if k in params}
        return {"rmse": math.sqrt(float(d2.mean())),
                "rmse_surf": math.sqrt(float(d2[self.surface].mean())),
                "relmse": float((d2 / (self.img ** 2 + EPS)).mean()),
                "flip": float(mean_flip)}


def reference(args, key, job, work):
    ref = job["reference"]
    if ref["kind"] == "mitsuba":
        img = read_exr(os.path.join(REPO, ref["path"]))[""]
        var = read_exr(os.path.join(REPO, ref["var"]))[""]
        noise = math.sqrt(float(var.mean()))
        return Reference(img, noise, f"Mitsuba {ref['variant']}, {ref['spp']} spp (`{ref['path']}`)"), {}
    halves, seconds = [], []
    for seed in REF_SEEDS:
        out = os.path.join(work, f"{key}.ref.{ref['spp']}.{seed}.exr")
        if not os.path.exists(out):
            print(f"[{key}] reference half, {ref['spp'] // 2} spp, seed {seed}", file=sys.stderr, flush=True)
            t, _ = render(args, job, ref["spp"] // 2, seed, out + ".tmp.exr")
            os.rename(out + ".tmp.exr", out)
            seconds.append(t)
        halves.append(read_exr(out)[""])
    img = (halves[0] + halves[1]) / 2
    noise = math.sqrt(float(np.mean((halves[0] - halves[1]) ** 2))) / 2
    info = {"half_render_seconds": seconds, "halves_rmse_over_2": noise}
    return Reference(img, noise, f"strata, {ref['spp']} spp as two halves (seeds {REF_SEEDS[0]}, "
                                 f"{REF_SEEDS[1]})"), info


def interp_log(x0, y0, x1, y1, x):
    f = (math.log(x) - math.log(x0)) / (math.log(x1) - math.log(x0))
    return math.exp(math.log(y0) + f * (math.log(y1) - math.log(y0)))


def at_time(rows, seconds, metric):
    for a, b in zip(rows, rows[1:]):
        if a["total_s"] <= seconds <= b["total_s"] and a["total_s"] < b["total_s"] and a[metric] > 0 and b[metric] > 0:
            return interp_log(a["total_s"], a[metric], b["total_s"], b[metric], seconds)
    return None


def budgets(lo, hi):
    out = []
    for k in range(math.floor(math.log10(lo)) - 1, math.ceil(math.log10(hi)) + 1):
        out += [m * 10.0 ** k for m in (1, 2, 5) if lo <= m * 10.0 ** k <= hi]
    return out


def fmt(v, d=3):
    return "—" if v is None else f"{v:.{d}g}"


def run_job(args, key, job, work):
    ref, ref_info = reference(args, key, job, work)
    print(f"[{key}] reference: {ref.label}; its noise (RMS) {ref.noise_rms:.3g}", file=sys.stderr, flush=True)
    rows = []
    spp = 1
    while spp <= job["max_spp"]:
        raw_out = os.path.join(work, f"{key}.{spp}.raw.exr")
        dn_out = os.path.join(work, f"{key}.{spp}.dn.exr")
        off_out = os.path.join(work, f"{key}.{spp}.dnoff.exr")
        raw_t, dn_r, dn_d, off_d = [], [], [], []
        for _ in range(args.repeats):  # taking turns, so load from other work falls on both
            raw_t.append(render(args, job, spp, SEED, raw_out)[0])
            r, d = render(args, job, spp, SEED, dn_out, denoise=True)
            dn_r.append(r)
            dn_d.append(d)
            off_d.append(denoise_file(args, dn_out, off_out, "off"))
        raw = read_exr(raw_out)[""]
        dn = read_exr(dn_out)
        same = bool(np.array_equal(dn["noisy"], raw))
        for variant, img, r, d in (("raw", raw, min(raw_t), 0.0),
                                   ("denoised", dn[""], min(dn_r), min(dn_d)),
                                   ("prefilter-off", read_exr(off_out)[""], min(dn_r), min(off_d))):
            row = {"job": key, "spp": spp, "variant": variant, "render_s": r, "denoise_s": d,
                   "total_s": r + d, **ref.metrics(img), "noisy_equals_raw": same}
            rows.append(row)
            print(f"[{key}] {spp:5d} spp {variant:13s} {r:8.3f} + {d:6.3f} s  rmse {row['rmse']:.4g} "
                  f"surf {row['rmse_surf']:.4g} relmse {row['relmse']:.4g} flip {row['flip']:.4f}",
                  file=sys.stderr, flush=True)
        if min(raw_t) > args.time_cap:
            break
        spp *= 2
    return ref, ref_info, rows


METRICS = ("rmse", "rmse_surf", "relmse", "flip")


def tables(key, job, ref, ref_info, rows):
    lines = [f"## {key}: `{job['scene']}` {' '.join(job['args'])}", "",
             f"Reference: {ref.label}; its own noise (RMS over pixels and channels) {ref.noise_rms:.3g}"
             + (f" (halves' RMSE / 2; each half {', '.join(f'{s:.1f}' for s in ref_info.get('half_render_seconds', []))} s)"
                if ref_info else "") + f"; surface pixels (reference < {SURFACE_LIMIT:g} in every channel): "
             f"{int(ref.surface.sum())} of {ref.surface.size}.", "",
             "| spp | raw s | raw RMSE | RMSE surf | relMSE | FLIP | denoised s (render + denoise) | RMSE | RMSE surf | relMSE | FLIP "
             "| prefilter off: denoise s | RMSE | RMSE surf | relMSE | FLIP |",
             "|" + "---|" * 16]
    by = {}
    for r in rows:
        by.setdefault(r["spp"], {})[r["variant"]] = r
    for spp, v in sorted(by.items()):
        a, b, c = v["raw"], v["denoised"], v["prefilter-off"]
        lines.append(f"| {spp} | {a['total_s']:.3g} | " + " | ".join(fmt(a[m]) for m in METRICS)
                     + f" | {b['render_s']:.3g} + {b['denoise_s']:.3g} | " + " | ".join(fmt(b[m]) for m in METRICS)
                     + f" | {c['denoise_s']:.3g} | " + " | ".join(fmt(c[m]) for m in METRICS) + " |")
    raw = [r for r in rows if r["variant"] == "raw"]
    dn = [r for r in rows if r["variant"] == "denoised"]
    off = [r for r in rows if r["variant"] == "prefilter-off"]
    lo = max(raw[0]["total_s"], dn[0]["total_s"])
    hi = min(raw[-1]["total_s"], dn[-1]["total_s"])
    lines += ["", "Equal time: raw ÷ denoised (prefilter on; in brackets prefilter off) per metric, "
              "and the raw and denoised values (> 1: denoising wins).", "",
              "| budget s | RMSE raw, dn | ratio | RMSE surf raw, dn | ratio | relMSE raw, dn | ratio | FLIP raw, dn | ratio |",
              "|" + "---|" * 9]
    for t in budgets(lo, hi):
        cells = []
        for m in METRICS:
            x, y, z = at_time(raw, t, m), at_time(dn, t, m), at_time(off, t, m)
            ratio = None if x is None or y is None else x / y
            ratio_off = None if x is None or z is None else x / z
            cells.append(f"{fmt(x)}, {fmt(y)} | {fmt(ratio)} ({fmt(ratio_off)})")
        lines.append(f"| {t:g} | " + " | ".join(cells) + " |")
    return lines


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--render", default=os.path.join(REPO, "target/release/render"))
    p.add_argument("--jobs", default="cornell,spheres,helmet")
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--repeats", type=int, default=2)
    p.add_argument("--cornell-max-spp", type=int, default=1024)
    p.add_argument("--spheres-max-spp", type=int, default=1024)
    p.add_argument("--helmet-max-spp", type=int, default=512)
    p.add_argument("--helmet-ref-spp", type=int, default=4096)
    p.add_argument("--time-cap", type=float, default=60.0, help="stop a ladder after a raw rung slower than this")
    p.add_argument("--out", default=os.path.join(REPO, "tools/bench/results/denoise"))
    p.add_argument("--work", default=os.path.expanduser("~/.cache/strata/denoise-bench"))
    args = p.parse_args()
    os.makedirs(args.out, exist_ok=True)
    os.makedirs(args.work, exist_ok=True)
    all_jobs = jobs(args)
    commit = subprocess.run(["git", "-C", REPO, "rev-parse", "--short", "HEAD"], capture_output=True,
                            text=True).stdout.strip()
    md = ["# Denoising at equal time", "",
          f"`tools/bench/denoise_quality.py --jobs {args.jobs}` at {commit}, {time.strftime('%d %b %H:%M')}, "
          f"{args.threads} threads, seed {SEED}, fastest of {args.repeats}; relMSE epsilon {EPS}; "
          f"load average at the start {os.getloadavg()[0]:.1f}.", ""]
    meta = {"commit": commit, "threads": args.threads, "repeats": args.repeats, "seed": SEED, "eps": EPS,
            "version": run([args.render, "--version"]).strip(), "jobs": {}}
    for key in args.jobs.split(","):
        job = all_jobs[key]
        t0 = time.time()
        ref, ref_info, rows = run_job(args, key, job, args.work)
        with open(os.path.join(args.out, f"{key}.csv"), "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows(rows)
        md += tables(key, job, ref, ref_info, rows)
        meta["jobs"][key] = {"scene": job["scene"], "args": job["args"], "reference": job["reference"],
                             "reference_noise_rms": ref.noise_rms, **ref_info, "flip_params": ref.flip_params,
                             "wall_seconds": time.time() - t0}
        md += ["", f"Load average after {key}: {os.getloadavg()[0]:.1f}; its wall time {time.time() - t0:.0f} s.", ""]
        with open(os.path.join(args.out, "RESULTS.md"), "w") as f:
            f.write("\n".join(md))
        with open(os.path.join(args.out, "meta.json"), "w") as f:
            json.dump(meta, f, indent=1)


if __name__ == "__main__":
    main()
