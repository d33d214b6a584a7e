#!/usr/bin/env bash
# Adaptive sampling against uniform sampling at equal time: behind the journal's
# "Adaptive sampling at equal time". For each reference, renders with --time-limit at a ladder
# of budgets, uniformly and adaptively (relative and absolute error metric, with a target
# small enough that the time limit decides), and writes CSV + plots into OUT_DIR.
#
#   cargo build --release && tools/bench/adaptive.sh [OUT_DIR] [TIME_LIMITS] [SEEDS]
set -euo pipefail
cd "$(dirname "$0")/../.."
out="${1:-docs/adaptive}"
limits="${2:-1,2,4,8,16}"
seeds="${3:-3}"
bin=target/release/convergence
run() {
    local name="$1"; shift
    echo "== $name" >&2
    "$bin" --samplers sobol --adaptive none,relative,absolute --time-limits "$limits" --seeds "$seeds" \
        --out "$out/$name" "$@"
}
run cornell-box.path --reference scenes/references/cornell-box.path.exr
run suzanne.path --reference scenes/references/suzanne.path.exr
run flight-helmet.ao --reference scenes/references/flight-helmet.ao.exr --hemispheres cosine
