#!/usr/bin/env bash
# tools/farm/slurm/ci-frames.sh RENDER -- CI's farm leg: on a one-machine Slurm cluster
# (local-cluster.sh), an array of four frames of scenes/animated-box.gltf in which one task
# fails on purpose; missing-frames.sh names it; it is submitted again; every frame must then
# be bit-identical to the same frame rendered without Slurm. Needs root, slurm-wlm, munge
# and idiff (openimageio-tools).
set -euo pipefail
cd "$(dirname "$0")/../../.."
render=$(realpath "${1:?usage: $0 PATH_TO_RENDER}")
work=$(mktemp -d /tmp/strata-farm.XXXXXX)
state="$work/slurm"
log() { printf '[ci-frames] %s\n' "$*"; }
trap 'tools/farm/slurm/local-cluster.sh stop "$state" >/dev/null 2>&1 || true' EXIT

eval "$(tools/farm/slurm/local-cluster.sh start "$state")"
scene=$(realpath scenes/animated-box.gltf)
out="$work/frames/box.####.exr"
mkdir -p "$work/frames" "$work/local"
opts=(--spp 4 --resolution 64x48 --no-png)
export STRATA_RENDER=$render

# Task 2 fails once (a node lost mid-frame, say): a marker file makes the second try succeed.
log "submitting frames 0-3, task 2 failing on purpose"
sbatch --wait --array=0-3 --output="$work/task-%a.log" --wrap "
    if [ \"\$SLURM_ARRAY_TASK_ID\" = 2 ] && [ ! -e '$work/failed-once' ]; then
        touch '$work/failed-once'; echo 'task 2: failing on purpose' >&2; exit 1
    fi
    exec tools/farm/slurm/render-frames.sbatch '$scene' '$out' ${opts[*]}" || true
missing=$(tools/farm/missing-frames.sh "$out" 0 3 || true)
log "missing after the first submission: '$missing'"
[[ $missing == 2 ]] || { log "expected frame 2 to be missing"; exit 1; }
sbatch --wait --array="$missing" --output="$work/retry-%a.log" \
    tools/farm/slurm/render-frames.sbatch "$scene" "$out" "${opts[@]}"
tools/farm/missing-frames.sh "$out" 0 3 || { log "frames still missing"; exit 1; }

# The same frames without Slurm (and on another thread count): the same bits.
for f in 0 1 2 3; do
    "$render" "$scene" --frame "$f" -o "$work/local/box.####.exr" --threads 1 "${opts[@]}" >/dev/null
    name=$(printf 'box.%04d.exr' "$f")
    idiff -fail 0 -warn 0 "$work/frames/$name" "$work/local/$name" >/dev/null \
        || { log "frame $f differs from the local render"; exit 1; }
done
log "4 frames rendered on Slurm (one retried) are bit-identical to local renders"
# Stop the cluster before its state (pid files) goes.
tools/farm/slurm/local-cluster.sh stop "$state"
trap - EXIT
rm -rf "$work"
