#!/usr/bin/env bash
# AO throughput of the render binary: rays/s at 1 and 2 threads (and with Embree's robust
# traversal off), median of N runs, on the bundled 95k-triangle flight helmet.
#
#   tools/bench/ao_throughput.sh [RENDER_BINARY] [RUNS]
#
# Prints a Markdown table row per configuration: total and AO (shadow, any-hit) rays/s.
set -euo pipefail
cd "$(dirname "$0")/../.."
bin="${1:-target/release/render}"
runs="${2:-5}"
scene=scenes/flight-helmet.gltf
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT

measure() {
    local label="$1"
    shift
    local totals=() aos=() secs=()
    for _ in $(seq "$runs"); do
        local log
        log="$("$bin" "$scene" -o "$out/b.exr" --no-png --integrator ao --spp 64 --resolution 640x480 --stats "$@")"
        local s total ao
        s=$(sed -n 's/^time: .* render \([0-9.]*\) s.*/\1/p' <<<"$log")
        total=$(sed -n 's/^rays: .* \([0-9]*\) total.*/\1/p' <<<"$log")
        ao=$(sed -n 's/^rays: .* \([0-9]*\) shadow.*/\1/p' <<<"$log")
        secs+=("$s")
        totals+=("$(python3 -c "print($total / $s / 1e6)")")
        aos+=("$(python3 -c "print($ao / $s / 1e6)")")
    done
    median() { printf '%s\n' "$@" | sort -g | awk '{a[NR]=$1} END {print a[int((NR+1)/2)]}'; }
    printf '| %s | %.2f | %.2f | %.2f |\n' "$label" "$(median "${secs[@]}")" "$(median "${totals[@]}")" "$(median "${aos[@]}")"
}

echo "| configuration | render s | Mrays/s (all) | Mrays/s (AO rays) |"
echo "|---|---|---|---|"
measure "1 thread" --threads 1
measure "2 threads" --threads 2
measure "2 threads, robust off" --threads 2 --no-robust
