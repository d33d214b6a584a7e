#!/usr/bin/env bash
# Path tracing on the Cornell box: throughput at 256x256, and RMSE against the Mitsuba
# reference (scenes/references/cornell-box.path.exr, 160x160) at 64, 256 and 1024 spp.
#
#   tools/bench/path_cornell.sh [RENDER_BINARY]
#
# Prints Markdown tables. RMSE is idiff's "RMS error" over all pixels and channels.
set -euo pipefail
cd "$(dirname "$0")/../.."
bin="${1:-target/release/render}"
scene=scenes/cornell-box.gltf
ref=scenes/references/cornell-box.path.exr
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT

echo "| spp | resolution | render s | samples/s | Mrays/s | camera | extension | shadow |"
echo "|---|---|---|---|---|---|---|---|"
for spp in 64 256 1024; do
    log="$("$bin" "$scene" -o "$out/t.exr" --no-png --integrator path --spp "$spp" --resolution 256x256 --stats)"
    s=$(sed -n 's/^time: .* render \([0-9.]*\) s.*/\1/p' <<<"$log")
    read -r cam ext sha tot < <(sed -n 's/^rays: \([0-9]*\) camera, \([0-9]*\) extension, \([0-9]*\) shadow, [0-9]* total, \([0-9]*\) traced.*/\1 \2 \3 \4/p' <<<"$log")
    python3 -c "
s=$s; n=256*256*$spp
print(f'| $spp | 256x256 | {s:.2f} | {n/s/1e6:.2f} M | {$tot/s/1e6:.2f} | {$cam/s/1e6:.2f} M/s | {$ext/s/1e6:.2f} M/s | {$sha/s/1e6:.2f} M/s |')"
done

echo
echo "| spp | sampler | render s | RMSE vs Mitsuba |"
echo "|---|---|---|---|"
for spp in 64 256 1024; do
    for sampler in random sobol; do
        log="$("$bin" "$scene" -o "$out/r.exr" --no-png --integrator path --spp "$spp" --resolution 160x160 --sampler "$sampler" --stats)"
        s=$(sed -n 's/^time: .* render \([0-9.]*\) s.*/\1/p' <<<"$log")
        rmse=$( (idiff "$out/r.exr" "$ref" 2>/dev/null || true) | sed -n "s/.*RMS error = \([0-9.e+-]*\).*/\1/p" | head -1)
        echo "| $spp | $sampler | $s | $rmse |"
    done
done
