#!/usr/bin/env bash
# Whether two builds of `render` give the same image, bit for bit, on every bundled scene
# with each integrator and the options that change the light transport's code paths
# (a background, the Lambertian model and its uniform hemisphere sampling, the glTF model
# without energy compensation, light sampling alone, one camera ray at a time). Prints one
# line per render that differs; exits 1 if any does. The options must exist in both builds.
#
#   tools/bench/same_images.sh BINARY_A BINARY_B
set -uo pipefail
cd "$(dirname "$0")/../.."
a=$1
b=$2
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT
fail=0
n=0
for scene in scenes/*.gltf; do
    for args in "--integrator ao" "--integrator direct" "--integrator path" \
        "--integrator path --background 0.3,0.5,0.8" \
        "--integrator path --materials lambertian --hemisphere uniform --background 0.2,0.2,0.2" \
        "--integrator path --materials lambertian" "--integrator path --energy-compensation off" \
        "--integrator direct --strategy light --background 0.4,0.4,0.4" \
        "--integrator path --no-camera-packets" "--integrator ao --no-camera-packets"; do
        for bin in "$a" "$b"; do
            # shellcheck disable=SC2086 # the arguments are split on purpose
            "$bin" "$scene" $args --spp 16 --resolution 96x72 --seed 3 \
                -o "$out/$([ "$bin" = "$a" ] && echo a || echo b).exr" --no-png >/dev/null 2>&1
        done
        n=$((n + 1))
        if ! r=$(idiff -fail 0 -warn 0 "$out/a.exr" "$out/b.exr" 2>&1 | tail -1) || [ "$r" != PASS ]; then
            echo "differs: $scene $args: $r"
            fail=1
        fi
    done
done
echo "$n renders compared"
exit $fail
