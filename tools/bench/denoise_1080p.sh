#!/bin/sh
# How long Open Image Denoise takes at 1920x1080 (issue 30): one 1-spp render of the Flight
# Helmet under studio_small_05_1k with the albedo and normal passes, then `render denoise` on
# it RUNS times with the prefilter on and RUNS times off, --threads THREADS. Prints each run's
# denoise seconds (what `render denoise` reports: the filters, with their set-up, not the EXR
# read and write) and the whole command's wall seconds, then best and median per setting and
# the best per megapixel. Needs Open Image Denoise where render finds it (tools/oidn-prefix.sh).
#   tools/bench/denoise_1080p.sh [RENDER] [RUNS] [THREADS]
set -eu
R=${1:-target/release/render}; RUNS=${2:-3}; T=${3:-2}
D=$(mktemp -d); trap 'rm -rf "$D"' EXIT
nice -n 19 "$R" scenes/flight-helmet.gltf --integrator path \
    --env scenes/env/studio_small_05_1k/studio_small_05_1k.hdr --resolution 1920x1080 \
    --spp 1 --seed 1000 --passes albedo,normal --threads "$T" --no-png -o "$D/in.exr" >/dev/null
for pre in on off; do
    : > "$D/$pre.txt"
    i=0
    while [ $i -lt "$RUNS" ]; do
        t0=$(date +%s.%N)
        s=$(nice -n 19 "$R" denoise "$D/in.exr" -o "$D/out.exr" --denoise-prefilter $pre --threads "$T" --no-png \
            | sed -n 's/.* in \([0-9.]*\) s.*/\1/p')
        t1=$(date +%s.%N)
        echo "$s $(echo "$t1 - $t0" | bc)" >> "$D/$pre.txt"
        echo "prefilter $pre run $((i + 1)): denoise $s s, command $(echo "$t1 - $t0" | bc) s"
        i=$((i + 1))
    done
    sort -n "$D/$pre.txt" | awk -v pre=$pre -v n="$RUNS" '{a[NR]=$1; w[NR]=$2} END {
        m = (n % 2) ? a[(n + 1) / 2] : (a[n / 2] + a[n / 2 + 1]) / 2;
        printf "prefilter %s: best %.3f s, median %.3f s, best per megapixel %.3f s (1920x1080 = 2.0736 MP); command wall at the best %.3f s\n",
            pre, a[1], m, a[1] / 2.0736, w[1] }'
done
