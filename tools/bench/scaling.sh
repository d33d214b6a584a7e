#!/usr/bin/env bash
# Parallel scaling: each workload rendered at a ladder of thread counts, with the work grown
# in proportion to the threads (samples per pixel = threads x a fixed count), so every run
# takes about as long as the one-thread run and start-up costs weigh the same in each.
#
#   tools/bench/scaling.sh [RENDER_BINARY] [THREADS...]     (default: 1 2 and all cores)
#
# Environment: RUNS (runs per cell, the median is kept; default 3); ONLY (an extended regular
# expression: only the workloads whose label matches it); SPHERE_DIR (where
# tools/bench/make_sphere_plane.py wrote the 998k-triangle sphere on a plane; default
# ~/.cache/strata/sphere; its rows are skipped, with a note, when it is missing). When
# Embree's tutorial renderers `pathtracer` and `viewer` are on PATH (Debian's embree-tools)
# and the sphere's OBJ is there, they are measured too, on the same settings as
# tools/bench/embree_tutorial.sh.
#
# Prints a Markdown table: per workload and thread count the render time (loading and the
# BVH build not counted), camera samples/s, rays/s, and the speed-up and efficiency against
# the first thread count. Needs only bash, awk, sed and sort, so that it runs on a bare machine.
set -euo pipefail
cd "$(dirname "$0")/../.."
bin="${1:-target/release/render}"
shift || true
if [ $# -gt 0 ]; then threads=("$@"); else threads=(1 2 "$(nproc)"); fi
runs="${RUNS:-3}"
sphere="${SPHERE_DIR:-$HOME/.cache/strata/sphere}"
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT

# One strata render: prints "seconds samples rays".
strata_run() {
    local scene="$1" w="$2" h="$3" spp="$4"; shift 4
    local log s rays
    log="$("$bin" "$scene" -o "$out/s.exr" --no-png --resolution "${w}x${h}" --spp "$spp" --stats "$@")"
    s=$(sed -n 's/^time: .* render \([0-9.]*\) s.*/\1/p' <<<"$log")
    rays=$(sed -n 's/^rays: .* \([0-9]*\) traced.*/\1/p' <<<"$log")
    echo "$s $((w * h * spp)) $rays"
}

# One tutorial benchmark: prints "seconds samples rays" for FRAMES frames of 1 spp.
tutorial_run() {
    local w="$1" frames="$2"; shift 2
    local log
    log="$("$@" --size "$w" "$w" --vp 0 1.6 4 --vi 0 0.8 0 --vu 0 1 0 --fov 45 \
        --benchmark 1 "$frames" 2>&1)"
    awk -v px=$((w * w)) -v n="$frames" '
        /^BENCHMARK_RENDER_AVG /{fps=$2} /^BENCHMARK_RENDER_MRAYPS_AVG /{m=$2}
        END {s = n / fps; print s, px * n, m * 1e6 * s}' <<<"$log"
}

# The workloads: "LABEL|KIND|ARGS" where KIND is strata (ARGS: SCENE W H SPP_PER_THREAD
# render options) or tutorial (ARGS: W FRAMES_PER_THREAD binary and options).
workloads=(
    "helmet, ao, 1 ray per hit|strata|scenes/flight-helmet.gltf 640 480 64 --integrator ao"
    "helmet, ao, 16 rays per hit|strata|scenes/flight-helmet.gltf 640 480 16 --integrator ao --ao-samples 16"
    "Cornell box, path|strata|scenes/cornell-box.gltf 256 256 32 --integrator path"
    "Cornell box, path, Lambertian|strata|scenes/cornell-box.gltf 256 256 32 --integrator path --materials lambertian"
    "sphere grid, path, glTF BRDF|strata|scenes/sphere-grid.gltf 256 256 16 --integrator path"
    "helmet, path, textures, normal maps, alpha|strata|scenes/flight-helmet.gltf 640 480 16 --integrator path"
)
if [ -f "$sphere/sphere_plane.gltf" ]; then
    sph="$sphere/sphere_plane.gltf"
    workloads+=(
        "sphere, path, max depth 4|strata|$sph 1024 1024 4 --integrator path --max-depth 4 --background 1,1,1"
        "sphere, ao, 64 rays per hit|strata|$sph 512 512 1 --integrator ao --ao-samples 64"
        "sphere, ao, 1 ray per hit, obvhs|strata|$sph 1024 1024 4 --integrator ao --backend obvhs"
    )
else
    echo "note: $sphere/sphere_plane.gltf missing (tools/bench/make_sphere_plane.py writes it); sphere rows skipped" >&2
fi
if command -v pathtracer >/dev/null && command -v viewer >/dev/null && [ -f "$sphere/sphere_plane.obj" ]; then
    obj="$sphere/sphere_plane.obj"
    workloads+=(
        "sphere, Embree pathtracer, path length 4|tutorial|1024 4 pathtracer -i $obj --ambientlight 1 1 1 --spp 1 --max-path-length 4"
        "sphere, Embree viewer, ao shader (64 rays)|tutorial|512 2 viewer -i $obj --shader ao"
    )
else
    echo "note: Embree's pathtracer/viewer or the sphere's OBJ missing; tutorial rows skipped" >&2
fi

if [ -n "${ONLY:-}" ]; then
    kept=()
    for w in "${workloads[@]}"; do
        if grep -Eq -- "$ONLY" <<<"${w%%|*}"; then kept+=("$w"); fi
    done
    workloads=("${kept[@]}")
fi

# Runs are interleaved (run 1 of every cell, then run 2, ...), so that a slow spell of the
# machine spreads over all cells instead of spoiling one.
for run in $(seq "$runs"); do
    for w in "${!workloads[@]}"; do
        IFS='|' read -r _ kind args <<<"${workloads[$w]}"
        read -r -a a <<<"$args"
        for t in "${threads[@]}"; do
            if [ "$kind" = strata ]; then
                strata_run "${a[0]}" "${a[1]}" "${a[2]}" $((a[3] * t)) --threads "$t" "${a[@]:4}"
            else
                tutorial_run "${a[0]}" $((a[1] * t)) "${a[@]:2}" --threads "$t"
            fi >>"$out/cell_${w}_$t"
        done
    done
done

# The medians of each cell: seconds, samples/s, rays/s.
cell() {
    awk '{print $1, $2 / $1, $3 / $1}' "$out/cell_$1_$2" | sort -g -k3 |
        awk '{s[NR]=$1; p[NR]=$2; r[NR]=$3} END {m=int((NR+1)/2); print s[m], p[m], r[m]}'
}
echo "| workload | threads | render s | samples/s | Mrays/s | speed-up | efficiency |"
echo "|---|---|---|---|---|---|---|"
for w in "${!workloads[@]}"; do
    label="${workloads[$w]%%|*}"
    read -r _ _ base < <(cell "$w" "${threads[0]}")
    for t in "${threads[@]}"; do
        read -r s p r < <(cell "$w" "$t")
        awk -v l="$label" -v t="$t" -v t0="${threads[0]}" -v s="$s" -v p="$p" -v r="$r" -v b="$base" 'BEGIN {
            su = r / b; ef = 100 * su * t0 / t
            printf "| %s | %d | %.2f | %.3f M | %.2f | %.2f× | %.0f%% |\n", l, t, s, p / 1e6, r / 1e6, su, ef
        }'
    done
done
