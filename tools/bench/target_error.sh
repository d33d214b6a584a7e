#!/usr/bin/env bash
# Adaptive sampling to a target error, with the two-halves error estimate (the default) and
# with the sample variance alone (`render --sample-variance-error`): behind "A target error,
# estimated from two halves" in "Adaptive sampling at equal time" (in
# docs/journal/benchmarks-2026-11.md, with the full table). For each case: render time, mean
# and most samples per pixel, pixels that hit the --spp cap, and the RMSE against the reference net
# of the reference's own noise. Prints a Markdown table.
#
#   cargo build --release && tools/bench/target_error.sh
# Needs python3 with numpy and oiiotool (openimageio-tools).
set -euo pipefail
cd "$(dirname "$0")/../.."
bin=target/release/render
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT

# RMSE of $1 against reference $2 net of the reference's noise (mean of its .var.exr).
net_rmse() {
    python3 - "$1" "$2" <<'PY'
import subprocess, sys
import numpy as np
def read(path):
    # oiiotool prints every pixel's channels; R, G, B are the first three.
    text = subprocess.run(["oiiotool", "--dumpdata", path], capture_output=True,
                          text=True, check=True).stdout
    rows = [l.split(":", 1)[1].split()[:3] for l in text.splitlines() if l.strip().startswith("Pixel")]
    return np.array(rows, dtype=np.float64)
img, ref, var = read(sys.argv[1]), read(sys.argv[2]), read(sys.argv[2].replace(".exr", ".var.exr"))
mse = np.mean((img - ref) ** 2) - np.mean(var)
print(f"{np.sqrt(max(mse, 0.0)):.3e}")
PY
}

echo "| scene | target | estimate | seconds | mean spp | most spp | pixels at the cap | RMSE net of the reference's noise |"
echo "|---|---|---|---|---|---|---|---|"
case_() {
    local name="$1" scene="$2" target="$3" metric="$4"; shift 4
    for estimate in halves sample-variance; do
        local flag=()
        [ "$estimate" = sample-variance ] && flag=(--sample-variance-error)
        local log
        log="$("$bin" "$scene" "$@" --spp 16384 --target-error "$target" --error-metric "$metric" \
            "${flag[@]}" --stats --no-png -o "$out/img.exr" 2>&1)"
        local secs mean most capped
        secs=$(sed -n 's/^time: .* render \([0-9.]*\) s.*/\1/p' <<<"$log")
        mean=$(sed -n 's/.*(mean \([0-9.]*\)) spp.*/\1/p' <<<"$log" | head -1)
        most=$(sed -n 's/.*, [0-9]*-\([0-9]*\) (mean.*/\1/p' <<<"$log" | head -1)
        capped=$(sed -n 's/.*; \([0-9]*\) took the most.*/\1/p' <<<"$log")
        echo "| $name | $metric $target | $estimate | $secs | $mean | $most | ${capped:-0} | $(net_rmse "$out/img.exr" "scenes/references/$name.exr") |"
    done
}
case_ cornell-box.path scenes/cornell-box.gltf 0.03 absolute --integrator path --max-depth 8 --resolution 160x160
case_ cornell-box.path scenes/cornell-box.gltf 0.05 relative --integrator path --max-depth 8 --resolution 160x160
case_ suzanne.path scenes/suzanne.gltf 0.02 relative --integrator path --max-depth 8 --background 1,1,1 --resolution 192x144
case_ flight-helmet.ao scenes/flight-helmet.gltf 0.05 relative --integrator ao --resolution 192x144
