# shellcheck shell=bash
# Sourced by missing-frames.sh and missing-shards.sh.
# array_list N... -- prints ascending indices as a Slurm --array list, runs compressed:
# 3 4 5 9 -> 3-5,9.
array_list() {
    local list="" start=$1 prev=$1 i
    shift
    for i in "$@" ""; do
        if [[ -n $i && $i -eq $((prev + 1)) ]]; then prev=$i; continue; fi
        [[ -n $list ]] && list+=","
        if [[ $start -eq $prev ]]; then list+="$start"; else list+="$start-$prev"; fi
        [[ -n $i ]] && start=$i prev=$i
    done
    echo "$list"
}
