#!/usr/bin/env bash
# tools/farm/slurm/ci-shards.sh RENDER -- CI's shards leg: on a one-machine Slurm cluster
# (local-cluster.sh), one frame of scenes/cornell-box.gltf split into four shards of samples
# (render-shards.sbatch, one CPU per task, two at a time) of which one fails on purpose;
# `render merge --check` and merge-shards.sbatch must name exactly that shard;
# missing-shards.sh lists it; it is submitted again with the merge depending on it; the merged
# EXR (every pass) must then be bit-identical to the frame rendered without Slurm on another
# thread count. Needs root, slurm-wlm, munge and idiff (openimageio-tools).
set -euo pipefail
cd "$(dirname "$0")/../../.."
render=$(realpath "${1:?usage: $0 PATH_TO_RENDER}")
work=$(mktemp -d /tmp/strata-shards.XXXXXX)
state="$work/slurm"
log() { printf '[ci-shards %3ds] %s\n' "$SECONDS" "$*"; }
fail() { log "FAIL: $*"; exit 1; }
cleanup() { tools/farm/slurm/local-cluster.sh stop "$state" >/dev/null 2>&1 || true; }
trap cleanup EXIT

# Not eval "$(...)" alone: a failed start would leave SLURM_CONF unset and go on.
cluster_env=$(tools/farm/slurm/local-cluster.sh start "$state")
eval "$cluster_env"
scene=$(realpath scenes/cornell-box.gltf)
out="$work/shards/cornell.exr"
shards=4
mkdir -p "$work/shards" "$work/local"
opts=(--integrator path --spp 32 --resolution 96x72 --passes 'albedo,normal,depth,object_id')
# One CPU per task, at most two at once; --time so that a hung task cannot hang CI.
job=(--cpus-per-task=1 --time=10)
export STRATA_RENDER=$render

# Shard 2 fails once (a node lost mid-render, say): a marker file makes the second try succeed.
log "submitting shards 0-3 of $shards, two at a time, shard 2 failing on purpose"
sbatch --wait --array=0-3%2 "${job[@]}" --output="$work/task-%a.log" --wrap "
    if [ \"\$SLURM_ARRAY_TASK_ID\" = 2 ] && [ ! -e '$work/failed-once' ]; then
        touch '$work/failed-once'; echo 'shard 2: failing on purpose' >&2; exit 1
    fi
    exec tools/farm/slurm/render-shards.sbatch '$scene' '$out' $shards ${opts[*]}" || true

# merge --check names the gap and its shard, exactly, with status 3 (incomplete).
status=0
report=$("$render" merge --check "$work"/shards/cornell.shard-*-of-4.exr) || status=$?
printf '%s\n' "$report" | sed 's/^/    /'
expected="3 part(s) hold 24 of the 32 samples per pixel
missing samples 16..24: shard 2/4"
[[ $status -eq 3 ]] || fail "merge --check exited $status, expected 3 (incomplete)"
[[ $report == "$expected" ]] || fail "merge --check should name shard 2/4 alone"

# The merge job refuses the incomplete set, naming the shard, and writes nothing.
status=0
sbatch --wait "${job[@]}" --output="$work/merge-early.log" \
    tools/farm/slurm/merge-shards.sbatch "$out" $shards --no-png || status=$?
[[ $status -ne 0 ]] || fail "merge-shards.sbatch succeeded with shard 2 missing"
grep -q 'missing samples 16..24: shard 2/4' "$work/merge-early.log" ||
    fail "merge-shards.sbatch's log does not name shard 2/4: $(cat "$work/merge-early.log")"
[[ ! -e $out ]] || fail "merge-shards.sbatch wrote $out from an incomplete set"
log "merge --check and merge-shards.sbatch name shard 2/4 (status 3, merge job failed)"

missing=$(tools/farm/missing-shards.sh "$out" $shards) && fail "missing-shards.sh found nothing missing"
log "missing after the first submission: '$missing'"
[[ $missing == 2 ]] || fail "expected shard 2 to be missing"

# The resubmission, and the merge as a job that depends on it.
retry=$(sbatch --parsable --array="$missing" "${job[@]}" --output="$work/retry-%a.log" \
    tools/farm/slurm/render-shards.sbatch "$scene" "$out" $shards "${opts[@]}")
retry=${retry%;*}
sbatch --wait --dependency=afterok:"$retry" --kill-on-invalid-dep=yes "${job[@]}" \
    --output="$work/merge.log" tools/farm/slurm/merge-shards.sbatch "$out" $shards --no-png ||
    fail "the merge job failed: $(cat "$work/merge.log")"
missing=$(tools/farm/missing-shards.sh "$out" $shards) || fail "shards still missing: $missing"
log "shard 2 resubmitted (job $retry); merged after it: $(tail -n 1 "$work/merge.log")"

# The same frame without Slurm, on another thread count: the same bits, every pass.
"$render" "$scene" -o "$work/local/cornell.exr" --threads 2 --no-png "${opts[@]}" >/dev/null
idiff -fail 0 -warn 0 "$out" "$work/local/cornell.exr" >/dev/null ||
    fail "the merged frame differs from the local render"
log "the merge of $shards shards rendered on Slurm (one retried) is bit-identical to a local render"

# Stop the cluster (jobs, then daemons) before its state (pid files) goes, and check that
# nothing of it still runs (zombies aside: init reaps them in its own time).
trap - EXIT
tools/farm/slurm/local-cluster.sh stop "$state"
if pgrep -r D,R,S,T,t -a slurm >&2 || pgrep -r D,R,S,T,t -a -f -- "$state/" >&2; then
    fail "Slurm or munge processes outlived the cluster (above)"
fi
rm -rf "$work"
log "done"
