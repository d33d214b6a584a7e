#!/usr/bin/env bash
# Render time of several builds of `render`, runs interleaved so that a slower machine
# slows each alike: the minimum and mean of each binary's "render" time from --stats.
#
#   tools/bench/ab.sh REPS "RENDER ARGUMENTS" BINARY...
#
# e.g. tools/bench/ab.sh 5 "scenes/cornell-box.gltf --integrator path --spp 128 \
#          --resolution 160x160 --threads 1" /tmp/render-before target/release/render
set -euo pipefail
reps=$1
args=$2
shift 2
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT
for _ in $(seq "$reps"); do
    for b in "$@"; do
        # shellcheck disable=SC2086 # the arguments are split on purpose
        s=$("$b" $args -o "$out/ab.exr" --no-png --stats 2>&1 |
            sed -n 's/^time: .* render \([0-9.]*\) s.*/\1/p')
        echo "$b $s"
    done
done | awk '{a[$1]=a[$1]" "$2; s[$1]+=$2; n[$1]++; if(!($1 in m)||$2<m[$1])m[$1]=$2}
    END{for(k in a) printf "%-40s min %.3f mean %.3f :%s\n",k,m[k],s[k]/n[k],a[k]}'
