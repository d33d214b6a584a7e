#!/usr/bin/env python3
"""strata against its peers: RMSE against the Mitsuba reference at a ladder of wall-clock times.

Run through tools/peers/run_peers.sh (it makes the pinned Mitsuba virtualenv and checks the
system packages). For each reference job (e.g. cornell-box.path) every renderer renders the
same glTF scene at the reference's resolution at 1, 2, 4, ... spp:

  strata          target/release/render with the manifest's strata_args (Sobol, the default);
                  time = the `render` phase of --stats (no start-up, loading or writing)
  strata-adaptive the same with adaptive sampling (--error-metric absolute --target-error 1e-4)
                  and --time-limit set to the time strata itself just took at this rung:
                  strata's two sampling modes at equal time (needs strata in --renderers)
  mitsuba-scalar  Mitsuba 3 scalar_rgb, scene from tools/references/mitsuba_refs.convert();
  mitsuba-llvm    ... llvm_ad_rgb (Dr.Jit needs LLVM's shared library: Debian's libllvm19);
                  time = the mi.render() call, after a warm-up render; llvm: the replay of a render
                  already recorded at that spp (tracing and compiling excluded, reported apart)
  cycles          Blender 3.4 Cycles on the CPU, set up by tools/peers/cycles_worker.py;
                  time = the bpy.ops.render.render() call, after a warm-up render (persistent data)

The jobs are rows of scenes/references/manifest.json, or of another references' manifest given
by --manifest (e.g. ~/.cache/strata/races/references/manifest.json, which
`make_references.sh --manifest tools/peers/hdri-races.json` writes: the HDRI races on real
assets, whose scenes and references live in a cache, named by absolute paths).

Jobs lit by an environment map (the manifest row's `environment`, e.g. suzanne-studio.path) get
it in every renderer: strata through its strata_args (--env, --env-rotate, --env-intensity),
Mitsuba through the reference's own envmap emitter (mitsuba_refs.convert), Cycles as a world
environment texture turned to match (cycles_worker.environment_world); see environment().

The renderers take turns at each rung of the ladder (strata 1 spp, Mitsuba 1 spp, ..., strata
2 spp, ...), so load from other work on the machine spreads over all of them. A renderer leaves
the ladder after a render slower than --time-cap. Every renderer uses --threads threads.

Error = RMSE over all pixels and channels against the reference (as target/release/convergence
computes it), plus the same with the reference's own noise removed (MSE - mean reference
variance). The reference is the job's Mitsuba reference, except for Cycles on glTF-model jobs
(e.g. sphere-grid.path): Cycles' Principled BSDF is not the glTF BRDF, so it converges to its
own image, and it is measured against its own converged render (--cycles-ref-spp, two
independent halves whose difference estimates its variance; cached under --cache). Writes,
under --out: <job>.csv (the raw curves) and RESULTS.md (tables; equal-time RMSE and
time-to-equal-RMSE by log-log interpolation between rungs).
"""
import argparse
import csv
import hashlib
import json
import math
import os
import platform
import re
import resource
import shlex
import shutil
import subprocess
import sys
import tempfile
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
sys.dont_write_bytecode = True
sys.path.insert(0, os.path.join(REPO, "tools", "references"))
import mitsuba_refs  # noqa: E402  (the glTF -> Mitsuba conversion of the references)
import scene_hash  # noqa: E402  (the manifest's scene_sha256: the scene and the files it names)
import mitsuba as mi  # noqa: E402

RENDERERS = ["strata", "strata-adaptive", "mitsuba-scalar", "mitsuba-llvm", "cycles"]
SEED = 1000  # the references used seeds 0..31: stay clear of them (Mitsuba would repeat a pass)
MITSUBA_RR_DEPTH = 5  # Mitsuba's own default (the references turn roulette off with 100)


# ---------------------------------------------------------------------------------------
# workers: a long-lived process per peer, one request per line: "SPP SEED OUT.exr"
# ---------------------------------------------------------------------------------------

def mitsuba_worker(variant, job, threads):
    """Runs inside a child process: load the converted scene once, then serve render requests."""
    import drjit as dr
    mi.set_variant(variant)
    mi.set_log_level(mi.LogLevel.Error)  # llvm: quiet the "multi-pass rendering" notice
    dr.set_thread_count(threads)
    ref = manifest_entry(job)
    w, h = ref["resolution"]
    mode = "ao" if ref["integrator"] == "ao" else "shaded"
    # The reference's material model (the glTF BRDF plugin for the glTF references).
    materials = ref.get("materials", {}).get("model", "lambertian")
    # The reference's own conversion, environment map included (the same envmap emitter: map
    # resampled to 2H + 1 rows, turned 90 + DEG about +Y), so the dict is the reference's.
    scene_dict, _ = mitsuba_refs.convert(os.path.join(REPO, ref["scene"]), mode, (w, h), ref["mitsuba_max_depth"],
                                         materials, environment(job))
    scene_dict["integrator"]["rr_depth"] = MITSUBA_RR_DEPTH
    scene = mi.load_dict(scene_dict)
    t0 = time.perf_counter()
    np.array(mi.render(scene, spp=1, seed=0))  # warm-up: JIT compilation (llvm), caches
    info = {"ready": True, "variant": variant, "warmup_seconds": time.perf_counter() - t0,
            "sampler": scene_dict["sensor"]["sampler"]["type"], "integrator": scene_dict["integrator"]}
    llvm = sorted({l.split()[-1] for l in open("/proc/self/maps") if "libLLVM" in l})
    if llvm and variant.startswith("llvm"):
        info["libLLVM"] = llvm[0]
    print("PEER_JSON " + json.dumps(info), flush=True)
    seen = set()
    for line in sys.stdin:
        if not line.strip():
            continue
        spp, seed, out = (int(v) if i < 2 else v.strip() for i, v in enumerate(line.split(maxsplit=2)))
        answer = {}
        if variant != "scalar_rgb" and spp not in seen:
            # Mitsuba's JIT variants record (trace and compile) the render once per spp value
            # and replay it afterwards: time the replay, report the first call beside it.
            t0 = time.perf_counter()
            np.array(mi.render(scene, spp=spp, seed=seed + 1))
            answer["first_call_seconds"] = time.perf_counter() - t0
            seen.add(spp)
        c0, t0 = cpu_seconds(resource.RUSAGE_SELF), time.perf_counter()
        img = np.array(mi.render(scene, spp=spp, seed=seed))  # numpy forces evaluation
        t1, c1 = time.perf_counter(), cpu_seconds(resource.RUSAGE_SELF)
        mi.Bitmap(np.ascontiguousarray(img[..., :3], dtype=np.float32), mi.Bitmap.PixelFormat.RGB).write(out)
        print("PEER_JSON " + json.dumps({"seconds": t1 - t0, "cpu_seconds": c1 - c0, **answer}), flush=True)


class Worker:
    """A peer process speaking the request/answer protocol above."""

    def __init__(self, name, argv, log_path):
        self.name = name
        self.log = open(log_path, "w")
        self.proc = subprocess.Popen(argv, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=self.log,
                                     text=True, cwd=REPO)
        self.info = self.answer()

    def answer(self):
        for line in self.proc.stdout:  # Blender also prints progress lines: skip them
            if line.startswith("PEER_JSON "):
                return json.loads(line[len("PEER_JSON "):])
        self.log.flush()
        with open(self.log.name) as f:
            tail = "".join(f.readlines()[-15:])
        raise RuntimeError(f"{self.name} exited (status {self.proc.wait()}); its stderr ends with:\n{tail}")

    def render(self, spp, seed, out):
        self.proc.stdin.write(f"{spp} {seed} {out}\n")
        self.proc.stdin.flush()
        return self.answer()

    def close(self):
        self.proc.stdin.close()
        self.proc.wait()
        self.log.close()


class Strata:
    """strata is a fresh process per render; its --stats line gives the render phase alone."""

    def __init__(self, binary, job, threads):
        ref = manifest_entry(job)
        self.base = [binary, os.path.join(REPO, ref["scene"])] + ref["strata_args"] + [
            "--threads", str(threads), "--no-png", "--stats"]
        self.info = {"version": subprocess.run([binary, "--version"], capture_output=True, text=True).stdout.strip(),
                     "args": ref["strata_args"]}

    def sampling_args(self, spp):
        return ["--spp", str(spp)]

    def render(self, spp, seed, out):
        c0 = cpu_seconds(resource.RUSAGE_CHILDREN)
        r = subprocess.run(self.base + self.sampling_args(spp) + ["--seed", str(seed), "-o", out],
                           capture_output=True, text=True)
        c1 = cpu_seconds(resource.RUSAGE_CHILDREN)
        if r.returncode != 0:
            raise RuntimeError(f"strata failed: {r.stderr.strip()}")
        m = re.search(r"render ([0-9.]+) s", r.stdout + r.stderr)
        mean = re.search(r"\(mean ([0-9.]+)\) spp", r.stdout)
        return {"seconds": float(m.group(1)), "cpu_seconds": c1 - c0,  # cpu: whole process
                "mean_spp": float(mean.group(1)) if mean else spp}

    def close(self):
        pass


class StrataAdaptive(Strata):
    """strata with adaptive sampling in the absolute error metric (what RMSE measures), given
    the time uniform strata took at the same rung (`time_limit`, set before each render)."""

    def __init__(self, binary, job, threads):
        super().__init__(binary, job, threads)
        self.time_limit = None
        self.info["adaptive"] = "--error-metric absolute --target-error 1e-4 --time-limit <strata's seconds>"

    def sampling_args(self, spp):
        if self.time_limit is None:
            raise RuntimeError("strata-adaptive needs strata's time at the rung: list strata first in --renderers")
        # strata's --stats gives the render phase to the microsecond; a render too short to
        # register still gets a positive limit (the flag refuses 0).
        limit = max(self.time_limit, 1e-6)
        return ["--error-metric", "absolute", "--target-error", "1e-4", "--time-limit", f"{limit:.6g}"]


def cycles_settings(job):
    """What cycles_worker.py is told about a job (all of it changes the image; threads do not)."""
    ref = manifest_entry(job)
    w, h = ref["resolution"]
    # Cycles' max_bounces counts bounces after the first hit: strata's B - 1 (0 = direct
    # light only, which is what AO needs); checked against the references (README.md).
    settings = {"mode": "ao" if ref["integrator"] == "ao" else "shaded", "resolution": f"{w}x{h}",
                "bounces": 0 if ref["integrator"] == "ao" else ref["max_depth"] - 1, "materials": material_model(job)}
    env = environment(job)
    if env is not None:
        # the map's hash too: it is part of the image (and of the cache key of Cycles' reference)
        settings["environment"] = dict(env, sha256=ref["environment"]["sha256"])
    return settings


def environment(job):
    """The job's environment map as an entry of mitsuba_refs.ENVIRONMENTS ({"file", "rotate",
    "intensity"}, file relative to the repository), or None for a job without one.

    Read from the manifest row (the record of what the reference was made with) and checked
    against the row's strata_args (what strata renders with) and against the file on disk, so
    the three renderers cannot be handed different maps or turns."""
    ref = manifest_entry(job)
    rec = ref.get("environment")
    if rec is None:
        if "--env" in ref["strata_args"]:
            raise RuntimeError(f"{job}: strata_args name --env but the manifest row records no environment")
        return None
    env = {"file": rec["file"], "rotate": float(rec["rotate_degrees"]), "intensity": float(rec["intensity"])}
    args = ref["strata_args"]

    def strata_value(flag, default):
        return args[args.index(flag) + 1] if flag in args else default

    said = (strata_value("--env", None), float(strata_value("--env-rotate", 0.0)),
            float(strata_value("--env-intensity", 1.0)))
    if said != (env["file"], env["rotate"], env["intensity"]):
        raise RuntimeError(f"{job}: strata_args give the environment {said}, the manifest row {env}")
    with open(os.path.join(REPO, env["file"]), "rb") as f:
        if hashlib.sha256(f.read()).hexdigest() != rec["sha256"]:
            raise RuntimeError(f"{job}: {env['file']} is not the map the reference was made with (sha256)")
    return env


def cpu_seconds(who):
    r = resource.getrusage(who)
    return r.ru_utime + r.ru_stime


def start(name, job, args, logdir):
    ref = manifest_entry(job)
    if name == "strata":
        return Strata(args.strata, job, args.threads)
    if name == "strata-adaptive":
        return StrataAdaptive(args.strata, job, args.threads)
    if name.startswith("mitsuba-"):
        variant = {"mitsuba-scalar": "scalar_rgb", "mitsuba-llvm": "llvm_ad_rgb"}[name]
        argv = [sys.executable, os.path.abspath(__file__), "--mitsuba-worker", variant, job, str(args.threads)]
        if MANIFEST != DEFAULT_MANIFEST:
            argv += ["--manifest", MANIFEST]
        return Worker(name, argv, os.path.join(logdir, f"{job}.{name}.log"))
    if name == "cycles":
        c = cycles_settings(job)
        argv = [args.blender, "-b", "--factory-startup", "-P", os.path.join(HERE, "cycles_worker.py"), "--",
                os.path.join(REPO, ref["scene"]), c["mode"], c["resolution"], str(c["bounces"]), str(args.threads),
                c["materials"]]
        if "environment" in c:
            env = c["environment"]
            argv += ["--env", os.path.join(REPO, env["file"]), "--env-rotate", repr(env["rotate"]),
                     "--env-intensity", repr(env["intensity"])]
        return Worker(name, argv, os.path.join(logdir, f"{job}.{name}.log"))
    raise ValueError(name)


# ---------------------------------------------------------------------------------------
# images and errors
# ---------------------------------------------------------------------------------------

_manifest = None
DEFAULT_MANIFEST = os.path.join(REPO, "scenes", "references", "manifest.json")
MANIFEST = DEFAULT_MANIFEST  # --manifest: the references' manifest whose jobs run


def manifest_entry(job):
    global _manifest
    if _manifest is None:
        with open(MANIFEST) as f:
            _manifest = {os.path.basename(e["reference"])[:-4]: e for e in json.load(f)["references"]}
    return _manifest[job]


def material_model(job):
    """The job's material model: 'lambertian' (every material diffuse) or 'gltf' (the glTF
    metallic-roughness BRDF, which only strata and the Mitsuba plugin implement exactly)."""
    return manifest_entry(job).get("materials", {}).get("model", "lambertian")


def read_rgb(path):
    return np.array(mi.Bitmap(path), dtype=np.float64)[..., :3]


class Reference:
    """What a renderer's RMSE is measured against: the converged image, the per-pixel variance
    of that image's mean (its own Monte Carlo noise, subtracted in rmse_corrected), and words
    for the tables."""

    def __init__(self, key, label, img, var):
        self.key, self.label, self.img, self.var = key, label, img, var
        # RMS over pixels and channels of the reference's standard error: the floor below
        # which a renderer's raw RMSE cannot go, whatever its spp
        self.noise_rms = math.sqrt(float(np.mean(var)))


def mitsuba_reference(job):
    e = manifest_entry(job)
    return Reference("mitsuba", f"the Mitsuba reference `{e['reference']}` ({e['spp']} spp, {e['variant']}; variance "
                     f"from its {e['passes']} passes)",
                     read_rgb(os.path.join(REPO, e["reference"])), read_rgb(os.path.join(REPO, e["variance"])))


CYCLES_REF_SEEDS = (2000, 2001)  # the two halves; clear of the ladder's SEED


def cycles_own_reference(worker, job, spp, cache_root, workdir):
    """Cycles' converged image of a glTF-model job: Principled BSDF is not the glTF BRDF, so
    Cycles converges to its own image and its RMSE is measured against this, not against
    Mitsuba's reference.

    Rendered as two independent halves of spp/2 each (seeds CYCLES_REF_SEEDS) and averaged:
    the mean of two independent estimates A, B has per-pixel variance E[(A - B)^2] / 4, so
    (A - B)^2 / 4 is an unbiased (if noisy per pixel) variance image, whose mean over the
    image is what rmse_corrected subtracts, as the Mitsuba references' var.exr is.

    Cached under cache_root/<job>.cycles.<key>/, the key hashing everything that changes the
    image: the scene (the manifest's scene_sha256), the job's settings as the worker receives
    them, spp and seeds, Blender's version and cycles_worker.py itself (any edit of the set-up
    renders afresh; threads are left out: they do not change Cycles' image)."""
    e = manifest_entry(job)
    with open(os.path.join(HERE, "cycles_worker.py"), "rb") as f:
        worker_sha = hashlib.sha256(f.read()).hexdigest()
    settings = {"scene_sha256": mitsuba_refs.scene_sha256(os.path.join(REPO, e["scene"])), **cycles_settings(job),
                "spp": spp, "seeds": list(CYCLES_REF_SEEDS), "blender": worker.info.get("blender"),
                "cycles_worker_sha256": worker_sha}
    key = hashlib.sha256(json.dumps(settings, sort_keys=True).encode()).hexdigest()[:16]
    folder = os.path.join(cache_root, f"{job}.cycles.{key}")
    halves = [os.path.join(folder, f"half{i}.exr") for i in (0, 1)]
    meta_path = os.path.join(folder, "meta.json")
    if os.path.exists(meta_path):
        print(f"[{job}] cycles: own reference from the cache, {folder}", file=sys.stderr, flush=True)
        with open(meta_path) as f:
            meta = json.load(f)
    else:
        tmp = tempfile.mkdtemp(prefix="cycles-ref-", dir=workdir)
        seconds = 0.0
        for i, seed in enumerate(CYCLES_REF_SEEDS):
            print(f"[{job}] cycles: rendering its own reference, half {i + 1} of 2 ({spp // 2} spp)",
                  file=sys.stderr, flush=True)
            seconds += worker.render(spp // 2, seed, os.path.join(tmp, f"half{i}.exr"))["seconds"]
        meta = {"settings": settings, "render_seconds": round(seconds, 2),
                "made": time.strftime("%Y-%m-%d %H:%M:%S")}
        with open(os.path.join(tmp, "meta.json"), "w") as f:
            json.dump(meta, f, indent=1)
        os.makedirs(cache_root, exist_ok=True)
        shutil.rmtree(folder, ignore_errors=True)
        shutil.move(tmp, folder)  # complete folders only: meta.json is written last
    a, b = (read_rgb(p) for p in halves)
    return Reference("cycles-own", f"Cycles' own converged render ({spp} spp, two halves of seeds "
                    f"{CYCLES_REF_SEEDS[0]} and {CYCLES_REF_SEEDS[1]}, variance estimated from their difference; "
                    f"cached in `{folder}`, {meta['render_seconds']:.0f} s to render)", (a + b) / 2, (a - b) ** 2 / 4)


def references_for(job, names, workers, args, workdir):
    """Each renderer's reference, and Mitsuba's: Mitsuba's for all, except Cycles on a
    glTF-model job (its Principled BSDF converges elsewhere), which gets its own converged
    render."""
    mitsuba = mitsuba_reference(job)
    refs = {name: mitsuba for name in names}
    if "cycles" in workers and material_model(job) != "lambertian":
        refs["cycles"] = cycles_own_reference(workers["cycles"], job, args.cycles_ref_spp, args.cache, workdir)
    return refs, mitsuba


def errors(img, ref):
    """RMSE against a Reference, raw and with the reference's own noise removed: for independent
    noise, E[MSE] = (the render's error)^2 + mean variance of the reference."""
    mse = float(np.mean((img - ref.img) ** 2))
    corrected = mse - ref.noise_rms ** 2
    return math.sqrt(mse), math.sqrt(corrected) if corrected > 0 else 0.0


def agreement(img, ref):
    """Converged-image checks: the ratio of image means over all pixels and over the surfaces
    (pixels not brighter than 10x the median lit pixel: emitters seen directly are exact in
    both and would dominate the mean), and the RMSE of 8x8-block means (noise shrinks 8x,
    a bias does not)."""
    lum = ref.mean(axis=2)
    surfaces = lum <= 10 * np.median(lum[lum > 0])
    h, w = (ref.shape[0] // 8) * 8, (ref.shape[1] // 8) * 8

    def blocks(a):
        return a[:h, :w].reshape(h // 8, 8, w // 8, 8, 3).mean(axis=(1, 3))

    return {"mean_ratio": float(img.mean() / ref.mean()),
            "surface_mean_ratio": float(img[surfaces].mean() / ref[surfaces].mean()),
            "block8_rmse": float(np.sqrt(np.mean((blocks(img) - blocks(ref)) ** 2)))}


# ---------------------------------------------------------------------------------------
# log-log interpolation along a ladder (rungs in spp order)
# ---------------------------------------------------------------------------------------

def interp_log(x0, y0, x1, y1, x):
    f = (math.log(x) - math.log(x0)) / (math.log(x1) - math.log(x0))
    return math.exp(math.log(y0) + f * (math.log(y1) - math.log(y0)))


def rmse_at(rows, seconds, key="seconds"):
    """RMSE at a time budget: between the first two consecutive rungs that bracket it."""
    for a, b in zip(rows, rows[1:]):
        if min(a[key], b[key]) <= seconds <= max(a[key], b[key]) and a[key] != b[key]:
            return interp_log(a[key], a["rmse"], b[key], b["rmse"], seconds)
    return None


def time_to(rows, target, key="seconds", metric="rmse"):
    """Seconds to reach an RMSE (or rmse_corrected): where the ladder first crosses it."""
    rows = [r for r in rows if r[metric] > 0]  # a corrected RMSE can reach 0 (noise estimate)
    for a, b in zip(rows, rows[1:]):
        if b[metric] <= target <= a[metric] and a[metric] != b[metric]:
            return interp_log(a[metric], a[key], b[metric], b[key], target)
    return None


def slope(rows, key="seconds"):
    """Least-squares slope of log RMSE against log seconds over rungs of >= 0.1 s."""
    pts = [(math.log(r[key]), math.log(r["rmse"])) for r in rows if r[key] >= 0.1 and r["rmse"] > 0]
    if len(pts) < 2:
        return None
    x, y = np.array(pts).T
    return float(np.polyfit(x, y, 1)[0])


def nice_values(lo, hi, per_decade=(1, 2, 5)):
    """1-2-5 values strictly inside (lo, hi)."""
    out = []
    for k in range(math.floor(math.log10(lo)) - 1, math.ceil(math.log10(hi)) + 1):
        out += [m * 10.0 ** k for m in per_decade if lo < m * 10.0 ** k < hi]
    return out


def fmt(v, digits=3):
    return "—" if v is None else f"{v:.{digits}g}"


# ---------------------------------------------------------------------------------------
# the run
# ---------------------------------------------------------------------------------------

def run_job(job, args, workdir):
    workers, infos = {}, {}
    for name in args.renderers:
        print(f"[{job}] starting {name}", file=sys.stderr, flush=True)
        try:
            workers[name] = start(name, job, args, workdir)
            infos[name] = workers[name].info
        except Exception as e:  # a peer that cannot run is reported, the others go on
            print(f"[{job}] {name} CANNOT RUN: {e}", file=sys.stderr, flush=True)
            infos[name] = {"error": str(e)}
    refs, mitsuba = references_for(job, list(workers), workers, args, workdir)
    rows, last = [], {}
    active = list(workers)
    spp = 1
    while active and spp <= args.max_spp:
        times = {name: [] for name in active}
        for _ in range(args.repeats):  # the same image each time (same seed): timing only
            for name in active:
                out = os.path.join(workdir, f"{job}.{name}.{spp}.exr")
                if name == "strata-adaptive":
                    workers[name].time_limit = times["strata"][-1]["seconds"] if times.get("strata") else None
                times[name].append(workers[name].render(spp, SEED, out))
        for name in list(active):
            t = times[name]
            img = read_rgb(os.path.join(workdir, f"{job}.{name}.{spp}.exr"))
            ref = refs[name]
            rmse, corrected = errors(img, ref)
            seconds = min(x["seconds"] for x in t)  # the least disturbed of the repeats
            rows.append({"job": job, "renderer": name, "spp": spp, "seconds": round(seconds, 5),
                         "cpu_seconds": round(min(x["cpu_seconds"] for x in t), 4),
                         "mean_spp": round(min(x.get("mean_spp", spp) for x in t), 2),
                         "rmse": rmse, "rmse_corrected": corrected, "mean_ratio": float(img.mean() / ref.img.mean()),
                         "reference": ref.key, "reference_noise_rms": ref.noise_rms,
                         "all_seconds": ";".join(f"{x['seconds']:.4g}" for x in t),
                         "first_call_seconds": round(t[0].get("first_call_seconds", t[0]["seconds"]), 5)})
            last[name] = (spp, img)
            print(f"[{job}] {name:15s} {spp:6d} spp {seconds:9.3f} s  RMSE {rmse:.5f}", file=sys.stderr, flush=True)
            if seconds > args.time_cap:
                active.remove(name)
        spp *= 2
    for name in workers:
        workers[name].close()
    checks = {name: dict(spp=s, **agreement(img, refs[name].img)) for name, (s, img) in last.items()}
    # how far a peer's own converged image is from the Mitsuba reference: the model's
    # difference (e.g. Principled BSDF against the glTF BRDF), not noise
    for name, ref in refs.items():
        if ref.key != "mitsuba":
            checks[name]["own_reference_vs_mitsuba"] = agreement(ref.img, mitsuba.img)
    return rows, infos, checks, refs


def write_csv(path, rows):
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        for r in rows:
            w.writerow({k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in r.items()})


def job_tables(job, rows, checks, refs, renderers):
    by = {n: [r for r in rows if r["renderer"] == n] for n in renderers}
    by = {n: v for n, v in by.items() if v}
    ours = [n for n in by if n.startswith("strata")]
    peers = [n for n in by if n not in ours]
    lines = [f"### {job}", ""]
    ref_entry = manifest_entry(job)
    lines += [f"Scene `{ref_entry['scene']}`, {ref_entry['resolution'][0]}×{ref_entry['resolution'][1]}, material "
              f"model `{material_model(job)}`; strata `{' '.join(ref_entry['strata_args'])}`.", ""]
    # which reference each curve is measured against, and that reference's own noise
    lines += ["Each renderer's RMSE is measured against its reference (noise: the reference's standard error, RMS "
              "over pixels and channels; the raw RMSE cannot fall below it, `rmse_corrected` removes it):", ""]
    for ref in {r.key: r for n, r in refs.items() if n in by}.values():
        names = ", ".join(n for n in by if refs[n].key == ref.key)
        lines.append(f"- {names}: {ref.label}; noise {ref.noise_rms:.3g}.")
    lines.append("")
    lines += ["Converged agreement (each renderer's highest-spp render against its reference):", "",
              "| renderer | against | spp | seconds | mean ratio | mean ratio, surfaces | RMSE of 8×8 block means "
              "| RMSE | RMSE, reference noise removed |",
              "|---|---|---|---|---|---|---|---|---|"]
    for n, rs in by.items():
        c, top = checks[n], rs[-1]
        lines.append(f"| {n} | {refs[n].key} | {c['spp']} | {top['seconds']:.2f} | {c['mean_ratio']:.4f} "
                     f"| {c['surface_mean_ratio']:.4f} | {c['block8_rmse']:.4g} | {top['rmse']:.4g} "
                     f"| {top['rmse_corrected']:.4g} |")
    for n in by:
        if "own_reference_vs_mitsuba" in checks[n]:
            o = checks[n]["own_reference_vs_mitsuba"]
            lines += ["", f"{n}'s own reference against the Mitsuba reference (what its material model changes; "
                      f"not an error of the timing): mean ratio {o['mean_ratio']:.4f}, surfaces "
                      f"{o['surface_mean_ratio']:.4f}, RMSE of 8×8 block means {o['block8_rmse']:.4g}."]
    lines += equal_time(by, ours, peers, "seconds", "RMSE at equal wall-clock time, each against its reference "
                        "(log-log interpolation between rungs; ratio < 1: strata is better):")
    lines += equal_error(by, ours, peers, "seconds", "Wall-clock seconds to reach an RMSE, each against its "
                         "reference (ratio < 1: strata is faster):")
    lines += equal_error(by, ours, peers, "seconds", "The same with each reference's own noise removed "
                         "(`rmse_corrected`; the fair one where the references' noise differs):", "rmse_corrected")
    lines += equal_error(by, ours, peers, "cpu_seconds", "Seconds to reach an RMSE in CPU seconds (user + system, "
                         "all threads; less sensitive to other work on the machine):")
    lines += ["", "Fitted slope of log RMSE against log seconds (rungs of 0.1 s or more): "
              + ", ".join(f"{n} {fmt(slope(rs), 3)}" for n, rs in by.items()) + ".", ""]
    return lines


def header(by, ours, peers, first):
    pairs = [(o, p) for o in ours for p in peers]
    return ["| " + first + " | " + " | ".join(by) + " | " + " | ".join(f"{o} / {p}" for o, p in pairs) + " |",
            "|---" * (1 + len(by) + len(pairs)) + "|"]


def ratio_cells(v, ours, peers):
    return [None if v.get(o) is None or v[p] is None else v[o] / v[p] for o in ours for p in peers]


def equal_time(by, ours, peers, key, title):
    """Budgets (1-2-5 values) inside every renderer's range of times."""
    lo = max(min(r[key] for r in rs) for rs in by.values())
    hi = min(max(r[key] for r in rs) for rs in by.values())
    lines = ["", title, ""] + header(by, ours, peers, key.replace("_", " "))
    for b in (nice_values(lo, hi) if lo < hi else []):
        v = {n: rmse_at(rs, b, key) for n, rs in by.items()}
        lines.append(f"| {b:g} | " + " | ".join(fmt(v[n], 4) for n in by) + " | "
                     + " | ".join(fmt(x, 3) for x in ratio_cells(v, ours, peers)) + " |")
    return lines


def equal_error(by, ours, peers, key, title, metric="rmse"):
    """Targets (1-2-5 values) inside every renderer's range of RMSE (or rmse_corrected)."""
    positive = {n: [r[metric] for r in rs if r[metric] > 0] for n, rs in by.items()}
    if not all(positive.values()):
        return ["", title, "", "(no renderer range to compare)"]
    lo = max(min(v) for v in positive.values())
    hi = min(max(v) for v in positive.values())
    lines = ["", title, ""] + header(by, ours, peers, metric.replace("_", " "))
    for t in (sorted(nice_values(lo, hi), reverse=True) if lo < hi else []):
        v = {n: time_to(rs, t, key, metric) for n, rs in by.items()}
        lines.append(f"| {t:g} | " + " | ".join(fmt(v[n], 3) for n in by) + " | "
                     + " | ".join(fmt(x, 3) for x in ratio_cells(v, ours, peers)) + " |")
    return lines


def versions(args, infos):
    v = {"python": platform.python_version(), "mitsuba": mi.__version__}
    import drjit
    v["drjit"] = drjit.__version__
    for name, info in infos.items():
        if name == "strata" and "version" in info:
            v["strata"] = info["version"]
        if name == "cycles" and "blender" in info:
            v["blender"] = info["blender"] + f" (Cycles sampling pattern {info['sampling_pattern']})"
    try:
        v["checkout HEAD"] = subprocess.run(["git", "-C", REPO, "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
        dirty = subprocess.run(["git", "-C", REPO, "status", "--porcelain", "--untracked-files=no"], capture_output=True, text=True).stdout
        v["checkout HEAD"] += " (tracked files modified)" if dirty.strip() else ""
    except OSError:
        pass
    if "libLLVM" in infos.get("mitsuba-llvm", {}):
        v["libLLVM (loaded by Dr.Jit)"] = infos["mitsuba-llvm"]["libLLVM"]
    return v


def machine():
    model = next((l.split(":", 1)[1].strip() for l in open("/proc/cpuinfo") if l.startswith("model name")), "?")
    mem = next((int(l.split()[1]) for l in open("/proc/meminfo") if l.startswith("MemTotal")), 0) / 2 ** 20
    return f"{model}, {os.cpu_count()} logical CPUs, {mem:.0f} GiB, {platform.platform()}"


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--mitsuba-worker", nargs=3, metavar=("VARIANT", "JOB", "THREADS"), help=argparse.SUPPRESS)
    ap.add_argument("--manifest", default=DEFAULT_MANIFEST,
                    help="the references' manifest (default scenes/references/manifest.json), e.g. "
                         "~/.cache/strata/races/references/manifest.json made by make_references.sh --manifest "
                         "tools/peers/hdri-races.json")
    ap.add_argument("--jobs", default=None,
                    help="reference jobs of the manifest, comma-separated (default cornell-box.path,cornell-box.ao,"
                         "ao-wall.ao; with another --manifest, all of its jobs)")
    ap.add_argument("--renderers", default=",".join(RENDERERS))
    ap.add_argument("--max-spp", type=int, default=4096)
    ap.add_argument("--time-cap", type=float, default=20.0, help="a renderer leaves the ladder after a render slower than this")
    ap.add_argument("--repeats", type=int, default=2, help="renders per rung and renderer; the fastest counts")
    ap.add_argument("--threads", type=int, default=os.cpu_count())
    ap.add_argument("--strata", default=os.path.join(REPO, "target", "release", "render"))
    ap.add_argument("--blender", default="blender")
    ap.add_argument("--out", default=os.path.join(HERE, "results"))
    ap.add_argument("--keep-images", action="store_true", help="keep the EXRs (in OUT/images)")
    ap.add_argument("--cycles-ref-spp", type=int, default=8192,
                    help="spp of Cycles' own reference on glTF-model jobs (two halves; even)")
    ap.add_argument("--cache", default=os.path.join(os.path.expanduser("~"), ".cache", "strata", "peers"),
                    help="where Cycles' own references are kept between runs")
    args = ap.parse_args()
    global MANIFEST
    MANIFEST = os.path.abspath(os.path.expanduser(args.manifest))
    if args.jobs is None:
        if MANIFEST == DEFAULT_MANIFEST:
            args.jobs = "cornell-box.path,cornell-box.ao,ao-wall.ao"
        else:
            with open(MANIFEST) as f:
                args.jobs = ",".join(os.path.basename(e["reference"])[:-4] for e in json.load(f)["references"])
    if args.mitsuba_worker:
        variant, job, threads = args.mitsuba_worker
        return mitsuba_worker(variant, job, int(threads))
    mi.set_variant("scalar_rgb")  # for reading EXRs only
    args.renderers = args.renderers.split(",")
    if args.cycles_ref_spp < 2 or args.cycles_ref_spp % 2:
        ap.error("--cycles-ref-spp must be even (it is rendered as two halves)")
    os.makedirs(args.out, exist_ok=True)
    # renders and worker logs go to a private folder (or OUT/images with --keep-images), and so
    # does a copy of strata's binary: others may rebuild target/release during the run
    private = tempfile.mkdtemp(prefix="strata-peers-")
    workdir = os.path.join(args.out, "images") if args.keep_images else private
    os.makedirs(workdir, exist_ok=True)
    shutil.copy2(args.strata, os.path.join(private, "render"))
    with open(args.strata, "rb") as f:
        binary_sha = hashlib.sha256(f.read()).hexdigest()[:12]
    args.strata = os.path.join(private, "render")
    load0 = os.getloadavg()
    started = time.strftime("%Y-%m-%d %H:%M:%S")
    all_infos, sections = {}, []
    for job in args.jobs.split(","):
        rows, infos, checks, refs = run_job(job, args, workdir)
        write_csv(os.path.join(args.out, f"{job}.csv"), rows)
        all_infos.update({k: v for k, v in infos.items() if "error" not in v})
        sections += job_tables(job, rows, checks, refs, args.renderers)
        for name, info in infos.items():
            if "error" in info:
                sections += [f"**{name} could not run on {job}:** {info['error']}", ""]
        sections += ["Peer set-up as run: " + "; ".join(
            f"{n}: `{json.dumps(i)}`" for n, i in infos.items() if n != "strata"), ""]
    shutil.rmtree(private)
    head = ["# Peers side by side: raw results", "",
            f"Made by `{' '.join(shlex.quote(a) for a in sys.argv)}` ({started}, "
            f"load average {load0[0]:.2f} at the start, {os.getloadavg()[0]:.2f} at the end).", "",
            f"Machine: {machine()}. Threads per renderer: {args.threads}. Ladder: 1, 2, 4, ... spp up to "
            f"{args.max_spp}, a renderer stopping after a render slower than {args.time_cap:g} s; each rung rendered "
            f"{args.repeats}× per renderer, renderers taking turns, the fastest time kept.", "",
            "Versions: " + ", ".join(f"{k} {v}" for k, v in versions(args, all_infos).items())
            + f", strata binary sha256 {binary_sha}.", "",
            "Seconds are the wall-clock time of the render alone (strata: the `render` phase of `--stats`; "
            "Mitsuba: the `mi.render` call after a warm-up render; llvm: the replay of a render already recorded "
            "at that spp (the first call, which traces and compiles, is in the CSV as first_call_seconds); Cycles: the `bpy.ops.render.render` call "
            "after a warm-up render, with persistent data). RMSE is over all pixels and channels against each "
            "renderer's reference, named in each job's section (the `reference` column of the CSV): the Mitsuba "
            "reference, except for Cycles on glTF-model jobs, measured against its own converged render because "
            "its Principled BSDF is not the glTF BRDF. Raw curves: the CSV files beside this one.", ""]
    with open(os.path.join(args.out, "RESULTS.md"), "w") as f:
        f.write("\n".join(head + sections))
    print(f"wrote {args.out}/RESULTS.md and {len(args.jobs.split(','))} CSV files", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
