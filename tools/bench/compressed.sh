#!/usr/bin/env bash
# Load time and peak memory of each compressed variant of Suzanne (scenes/compressed/) against
# the plain file: for each, the best of N runs (default 5) of
#   render FILE --spp 1 --resolution 8x6 --stats --no-png --background 1,1,1
# under /usr/bin/time -v: strata's own "load" time (parse, buffers, decoding the geometry),
# its "materials and lights" time (where the path tracer decodes the textures), and the
# process's maximum resident set size. Prints a Markdown table.
# Usage: tools/bench/compressed.sh [RENDER_BINARY] [N]
set -euo pipefail
cd "$(dirname "$0")/../.."
bin="${1:-${CARGO_TARGET_DIR:-target}/release/render}"
runs="${2:-5}"
out=$(mktemp -d)
echo "| file | load (ms) | materials and lights (ms) | max RSS (MiB) |"
echo "|---|---|---|---|"
for f in suzanne.gltf suzanne-meshopt.glb suzanne-meshopt-float.glb suzanne-meshopt-fallback.glb \
    suzanne-draco.gltf suzanne-draco-sequential.gltf suzanne-webp.glb suzanne-etc1s.gltf \
    suzanne-uastc.gltf; do
    best_load=inf best_mat=inf best_rss=inf
    for _ in $(seq "$runs"); do
        /usr/bin/time -v "$bin" "scenes/compressed/$f" --spp 1 --resolution 8x6 --stats --no-png \
            --background 1,1,1 -o "$out/x.exr" >"$out/stdout" 2>"$out/stderr"
        load=$(grep -o 'load [0-9.]* s' "$out/stdout" | awk '{print $2 * 1000}')
        mat=$(grep -o 'materials and lights [0-9.]* s' "$out/stdout" | awk '{print $4 * 1000}')
        rss=$(grep 'Maximum resident' "$out/stderr" | awk '{print $6 / 1024}')
        best_load=$(echo "$best_load $load" | awk '{print ($2 < $1 || $1 == "inf") ? $2 : $1}')
        best_mat=$(echo "$best_mat $mat" | awk '{print ($2 < $1 || $1 == "inf") ? $2 : $1}')
        best_rss=$(echo "$best_rss $rss" | awk '{print ($2 < $1 || $1 == "inf") ? $2 : $1}')
    done
    printf '| `%s` | %.1f | %.0f | %.1f |\n' "$f" "$best_load" "$best_mat" "$best_rss"
done
rm -rf "$out"
