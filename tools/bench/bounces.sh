#!/usr/bin/env bash
# Bounces drawn from one Sobol sequence (the default) against bounces padded apart
# (`render --padded-bounces`): behind docs/journal/benchmarks-2026-11.md's "Bounces stratified jointly". For each
# path-tracing reference, an spp ladder of both layouts averaged over several seeds; CSV and
# plots into OUT_DIR/<reference>, and a table of the squared error net of the reference's
# noise, joint ÷ padded, on standard output.
#
#   cargo build --release && tools/bench/bounces.sh [OUT_DIR]
set -euo pipefail
cd "$(dirname "$0")/../.."
out="${1:-/tmp/strata-bounces}"
bin=target/release/convergence
run() {
    local name="$1" max_spp="$2" seeds="$3"
    echo "== $name" >&2
    "$bin" --reference "scenes/references/$name.exr" --samplers sobol --bounces joint,padded \
        --max-spp "$max_spp" --seeds "$seeds" --out "$out/$name" >&2
    python3 - "$out/$name/convergence.csv" "$name" <<'PY'
import csv, sys
rows = list(csv.DictReader(open(sys.argv[1])))
err = {(r["bounces"], round(float(r["spp"]))): float(r["rmse_corrected"]) for r in rows}
secs = {(r["bounces"], round(float(r["spp"]))): float(r["seconds"]) for r in rows}
for spp in sorted({s for _, s in err}):
    j, p = err.get(("joint", spp)), err.get(("padded", spp))
    if j and p and spp >= 16:
        print(f"| {sys.argv[2]} | {spp} | {j:.4e} | {p:.4e} | {(j / p) ** 2:.3f} | "
              f"{secs[('joint', spp)] / secs[('padded', spp)]:.2f} |")
PY
}
echo "| reference | spp | RMSE net, joint | RMSE net, padded | squared error, joint ÷ padded | seconds, joint ÷ padded |"
echo "|---|---|---|---|---|---|"
run cornell-box.path 1024 8
run point-lights.path 256 6
run suzanne.path 256 6
run emissive-strength.path 256 6
