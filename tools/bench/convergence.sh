#!/usr/bin/env bash
# The convergence runs behind BENCHMARKS.md's "Run time against error" section: CSV and
# plots per reference, into OUT_DIR (default docs/convergence).
#
#   cargo build --release && tools/bench/convergence.sh [OUT_DIR] [MAX_SPP]
set -euo pipefail
cd "$(dirname "$0")/../.."
out="${1:-docs/convergence}"
max="${2:-1024}"
bin=target/release/convergence
run() { local name="$1"; shift; echo "== $name" >&2; "$bin" --max-spp "$max" --out "$out/$name" "$@"; }

run ao-wall.ao --reference scenes/references/ao-wall.ao.exr
run cornell-box.ao --reference scenes/references/cornell-box.ao.exr
run cornell-box.direct --reference scenes/references/cornell-box.direct.exr --strategies mis,light,bsdf
run cornell-box.path --reference scenes/references/cornell-box.path.exr
