#!/usr/bin/env bash
# What splitting one frame into shards costs on one machine: the whole render, then the same
# render as N shards run one after another (each loads the scene, builds its BVH, prepares
# its materials and writes its partial EXR) and their merge. Prints, per N, the summed wall
# time of the shards, the fixed costs per shard from --stats, the merge's time and the
# partial files' size, and checks the merged image against the whole one bit for bit.
#
#   tools/bench/shards.sh RENDER "RENDER ARGUMENTS" N...
#
# e.g. tools/bench/shards.sh target/release/render "scenes/flight-helmet.gltf \
#          --integrator path --spp 64 --resolution 320x240" 1 2 4 8
set -euo pipefail
bin=$1
args=$2
shift 2
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT
now() { date +%s.%N; }
# shellcheck disable=SC2086 # the arguments are split on purpose
t0=$(now); "$bin" $args -o "$out/whole.exr" --no-png >/dev/null 2>&1; t1=$(now)
whole=$(echo "$t1 - $t0" | bc)
printf 'whole render: %.2f s\n' "$whole"
printf '%3s %9s %9s %9s %9s %9s %9s %9s %9s\n' N shards_s overhead load_s build_s prep_s write_s merge_s part_MB
for n in "$@"; do
    rm -rf "$out/parts" && mkdir "$out/parts"
    t0=$(now)
    for i in $(seq 0 $((n - 1))); do
        # shellcheck disable=SC2086
        "$bin" $args -o "$out/parts/p.exr" --shard "$i/$n" --stats >>"$out/stats-$n" 2>&1
    done
    t1=$(now)
    "$bin" merge "$out"/parts/p.shard-*.exr -o "$out/merged.exr" --no-png >/dev/null
    t2=$(now)
    idiff -fail 0 -warn 0 "$out/whole.exr" "$out/merged.exr" >/dev/null ||
        { echo "N=$n: the merged image differs from the whole one" >&2; exit 1; }
    # Mean fixed costs per shard, from the --stats "time:" lines.
    phases=$(sed -n 's/^time: load \([0-9.]*\) s, BVH build \([0-9.]*\) s, materials and lights \([0-9.]*\) s, .* write \([0-9.]*\) s.*/\1 \2 \3 \4/p' "$out/stats-$n" |
        awk '{l+=$1; b+=$2; p+=$3; w+=$4; k++} END {printf "%.3f %.3f %.3f %.3f", l/k, b/k, p/k, w/k}')
    mb=$(du -cb "$out"/parts/*.exr | tail -1 | awk '{printf "%.1f", $1 / 1e6}')
    # shellcheck disable=SC2086
    printf '%3d %9.2f %8.1f%% %9s %9s %9s %9s %9.2f %9s\n' "$n" "$(echo "$t1 - $t0" | bc)" \
        "$(echo "100 * ($t1 - $t0 - $whole) / $whole" | bc -l)" $phases "$(echo "$t2 - $t1" | bc)" "$mb"
done
