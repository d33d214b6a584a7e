#!/usr/bin/env bash
# strata against Embree's own tutorial renderers (Debian's embree-tools: `pathtracer` and
# `viewer`), on one scene both read: a 998k-triangle sphere on a plane, grey (albedo 0.5),
# lit by a constant environment of radiance 1, at 1024x1024, on 1 and 2 threads.
#
#   apt-get install embree-tools
#   cargo build --release
#   tools/bench/embree_tutorial.sh [RENDER_BINARY] [RUNS]
#
# The scene is written as OBJ+MTL (for the tutorials) and glTF (for strata) with the same
# triangles by tools/bench/make_sphere_plane.py, into ~/.cache/strata/sphere.
#
# Path tracing: Embree's pathtracer --max-path-length 4 with --ambientlight 1 1 1, 1 spp per
# frame (--benchmark 1 N prints frames/s and, from its ray counters, Mrays/s); strata's path
# integrator with --max-depth 4 (the same path length: 1 = direct lighting in both) and
# --background 1,1,1, 4 spp. AO: Embree's viewer --shader ao (one camera ray and 64 AO rays
# per pixel); strata's ao integrator with --ao-samples 64 (the same rays), 2 spp. Rows marked
# "robust off" run strata without RTC_SCENE_FLAG_ROBUST, as the tutorials do.
# Prints a Markdown table: samples/s (camera samples) and Mrays/s (every ray each renderer
# counts), the median of RUNS runs (default 3).
set -euo pipefail
cd "$(dirname "$0")/../.."
bin="${1:-target/release/render}"
runs="${2:-3}"
dir="$HOME/.cache/strata/sphere"
for tool in pathtracer viewer; do
    command -v "$tool" >/dev/null || { echo "error: '$tool' not found (apt-get install embree-tools)" >&2; exit 1; }
done
[ -f "$dir/sphere_plane.gltf" ] || python3 tools/bench/make_sphere_plane.py "$dir" >/dev/null
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT
size=1024
cam=(--vp 0 1.6 4 --vi 0 0.8 0 --vu 0 1 0 --fov 45)

median() { sort -g | awk '{a[NR]=$1} END {print a[int((NR+1)/2)]}'; }

# Embree tutorial: "fps mrays" of one --benchmark run.
tutorial() {
    local log
    log="$("$@" --size $size $size "${cam[@]}" --benchmark 1 6 2>&1)"
    awk '/^BENCHMARK_RENDER_AVG /{f=$2} /^BENCHMARK_RENDER_MRAYPS_AVG /{m=$2} END {print f, m}' <<<"$log"
}

# strata: "samples/s Mrays/s" of one render.
strata() {
    local spp="$1"; shift
    local log s tot
    log="$("$bin" "$dir/sphere_plane.gltf" -o "$out/s.exr" --no-png --resolution ${size}x${size} --spp "$spp" --stats "$@")"
    s=$(sed -n 's/^time: .* render \([0-9.]*\) s.*/\1/p' <<<"$log")
    tot=$(sed -n 's/^rays: .* \([0-9]*\) traced.*/\1/p' <<<"$log")
    python3 -c "print($size*$size*$spp/$s, $tot/$s/1e6)"
}

row() {
    local label="$1" threads="$2"; shift 2
    local samples=() mrays=()
    for _ in $(seq "$runs"); do
        read -r a b < <("$@")
        samples+=("$a"); mrays+=("$b")
    done
    local sm mm
    sm=$(printf '%s\n' "${samples[@]}" | median)
    mm=$(printf '%s\n' "${mrays[@]}" | median)
    python3 -c "print(f'| $label | $threads | {$sm/1e6:.2f} M | {$mm:.2f} |')"
}

fps_to_samples() { read -r f m; python3 -c "print($f*$size*$size, $m)"; }

echo "| renderer | threads | samples/s | Mrays/s |"
echo "|---|---|---|---|"
for t in 1 2; do
    row "Embree pathtracer, path length 4" "$t" bash -c "$(declare -f tutorial fps_to_samples); size=$size; cam=(${cam[*]}); tutorial pathtracer -i '$dir/sphere_plane.obj' --ambientlight 1 1 1 --spp 1 --max-path-length 4 --threads $t | fps_to_samples"
    row "strata path, max depth 4" "$t" strata 4 --integrator path --max-depth 4 --background 1,1,1 --threads "$t"
    row "strata path, max depth 4, random sampler, robust off" "$t" strata 4 --integrator path --max-depth 4 --background 1,1,1 --threads "$t" --sampler random --no-robust
done
for t in 1 2; do
    row "Embree viewer, AO shader" "$t" bash -c "$(declare -f tutorial fps_to_samples); size=$size; cam=(${cam[*]}); tutorial viewer -i '$dir/sphere_plane.obj' --shader ao --threads $t | fps_to_samples"
    row "strata ao, 64 AO rays per hit" "$t" strata 2 --integrator ao --ao-samples 64 --threads "$t"
    row "strata ao, 64 AO rays per hit, robust off" "$t" strata 2 --integrator ao --ao-samples 64 --threads "$t" --no-robust
done
