#!/usr/bin/env bash
# tools/farm/missing-shards.sh OUT N -- lists, as a Slurm --array list (e.g. "1,3-5"), the
# shards of N whose samples are missing, where OUT is the -o path the shards were rendered
# with (render --shard I/N writes OUT with `.shard-I-of-N` before `.exr`). Prints nothing and
# exits 0 when all are there; exits 1 when some are missing, as missing-frames.sh does; exits 2
# when the shards there do not belong together (another scene, settings or seed: `render
# merge --check` says which files). strata writes each EXR under a temporary name and renames
# it when complete, so what exists is whole. `render` is $STRATA_RENDER, else the one on PATH.
set -euo pipefail
# shellcheck source=tools/farm/array-list.sh
source "$(dirname "${BASH_SOURCE[0]}")/array-list.sh"
[[ $# -eq 2 ]] || { echo "usage: $0 OUT N" >&2; exit 2; }
out=$1 shards=$2
[[ $shards =~ ^[1-9][0-9]*$ ]] || { echo "missing-shards: N='$shards' is not a number of shards" >&2; exit 2; }
[[ $out == *.* ]] || { echo "missing-shards: OUT='$out' is not an .exr path" >&2; exit 2; }
render=${STRATA_RENDER:-render}

# This N's shards only (shards of another N in the same folder are not ours).
shopt -s nullglob
parts=("${out%.*}".shard-*-of-"$shards"."${out##*.}")
missing=()
if ((${#parts[@]} == 0)); then
    # Nothing for merge --check to read: every shard is missing.
    for ((s = 0; s < shards; s++)); do missing+=("$s"); done
else
    status=0
    report=$("$render" merge --check "${parts[@]}") || status=$?
    case $status in
        0) exit 0 ;;
        3) ;;
        *) echo "missing-shards: render merge --check failed (status $status)" >&2; exit 2 ;;
    esac
    # "missing samples 16..32: shard 2/4, 3/4": the indices before "/N".
    while IFS= read -r line; do
        [[ $line == 'missing samples '* ]] || continue
        if [[ $line != *": shard "* ]]; then
            echo "missing-shards: a gap that is no whole shard of $shards: $line" >&2
            exit 2
        fi
        IFS=', ' read -r -a named <<<"${line#*: shard }"
        for s in "${named[@]}"; do
            [[ $s == */"$shards" ]] || { echo "missing-shards: unexpected shard '$s' in: $line" >&2; exit 2; }
            missing+=($((10#${s%/*})))
        done
    done <<<"$report"
    ((${#missing[@]})) || { printf 'missing-shards: incomplete, yet no shard named:\n%s\n' "$report" >&2; exit 2; }
fi

array_list "${missing[@]}"
exit 1
