#!/usr/bin/env bash
# tools/farm/missing-frames.sh OUT A B -- lists, as a Slurm --array list (e.g. "3,17-19"),
# the frames A..B whose EXR is missing, where OUT is the -o path the frames were rendered
# with (`shot.####.exr`, or `shot.exr` for shot.FFFF.exr; render --frame's naming). Prints
# nothing and exits 0 when all are there; exits 1 when some are missing. strata writes each
# EXR under a temporary name and renames it when complete, so a task that crashed or was
# killed leaves no file here: what exists is whole.
set -euo pipefail
# shellcheck source=tools/farm/array-list.sh
source "$(dirname "${BASH_SOURCE[0]}")/array-list.sh"
[[ $# -eq 3 ]] || { echo "usage: $0 OUT FIRST LAST" >&2; exit 2; }
out=$1 first=$2 last=$3
dir=$(dirname "$out")
name=$(basename "$out")
path_of() {  # the frame's path, as strata's frame_path names it
    local f=$1
    if [[ $name == *'#'* ]]; then
        local pre=${name%%#*} rest=${name#*#}
        local width=1
        while [[ $rest == '#'* ]]; do rest=${rest#'#'}; width=$((width + 1)); done
        printf '%s/%s%0*d%s\n' "$dir" "$pre" "$width" "$f" "$rest"
    elif [[ $name == *.* ]]; then
        printf '%s/%s.%04d.%s\n' "$dir" "${name%.*}" "$f" "${name##*.}"
    else
        printf '%s/%s.%04d\n' "$dir" "$name" "$f"
    fi
}
missing=()
for ((f = first; f <= last; f++)); do
    [[ -f $(path_of "$f") ]] || missing+=("$f")
done
((${#missing[@]})) || exit 0
array_list "${missing[@]}"
exit 1
