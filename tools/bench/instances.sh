#!/usr/bin/env bash
# Memory and build time of instanced scenes against their flattened copies: a 32 768-triangle
# sphere placed COUNT times by EXT_mesh_gpu_instancing (tools/bench/make_instances.py), for
# COUNT in 10^3..10^6, rendered by ambient occlusion (2 spp, 320x240) with
#   render SCENE --integrator ao --spp 2 --resolution 320x240 --stats [--backend B]
#          [--flatten-instances]
# on each backend, instanced, and flattened where the copy fits in memory (10^3: 32.8 million
# triangles). Reports strata's own load and BVH build times, the BVH memory the backend
# reports, the process's peak resident memory (/proc VmHWM, as --stats prints it) and the
# render's rays per second. Prints a Markdown table.
# Usage: tools/bench/instances.sh [RENDER_BINARY] [COUNTS...]
set -euo pipefail
cd "$(dirname "$0")/../.."
bin="${1:-${CARGO_TARGET_DIR:-target}/release/render}"
shift || true
counts=("$@")
if [ ${#counts[@]} -eq 0 ]; then counts=(1000 10000 100000 1000000); fi
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
echo "| instances | triangles placed | backend | stored as | load (s) | BVH build (s) | BVH (MiB) | peak resident (MiB) | Mrays/s |"
echo "|---|---|---|---|---|---|---|---|---|"
for count in "${counts[@]}"; do
    python3 tools/bench/make_instances.py "$out/s.gltf" "$count" 6
    modes=(instances)
    if [ "$count" -le 1000 ]; then modes+=(copies); fi
    for backend in embree obvhs; do
        for mode in "${modes[@]}"; do
            extra=()
            if [ "$mode" = copies ]; then extra=(--flatten-instances); fi
            "$bin" "$out/s.gltf" --integrator ao --spp 2 --resolution 320x240 --stats --no-png \
                --max-memory none --backend "$backend" "${extra[@]}" -o "$out/x.exr" \
                >"$out/stdout" 2>"$out/stderr"
            load=$(grep -o 'load [0-9.]* s' "$out/stdout" | awk '{print $2}')
            build=$(grep -o 'BVH build [0-9.]* s' "$out/stdout" | awk '{print $3}')
            bvh=$(grep -o 'memory: BVH [0-9.]* MiB' "$out/stdout" | awk '{print $3}')
            peak=$(grep 'peak resident memory' "$out/stdout" | awk '{v=$4; if ($5=="GiB") v*=1024; if ($5=="KiB") v/=1024; print v}')
            mrays=$(grep -o '[0-9.]* Mrays/s traced' "$out/stdout" | awk '{print $1}')
            printf '| %s | %s | %s | %s | %.2f | %.2f | %.1f | %.0f | %s |\n' "$count" \
                "$((count * 32768))" "$backend" "$mode" "$load" "$build" "$bvh" "$peak" "$mrays"
        done
    done
done
