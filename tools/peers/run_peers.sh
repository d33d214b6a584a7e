#!/usr/bin/env bash
# strata against Mitsuba 3 (scalar_rgb, llvm_ad_rgb) and Blender Cycles: RMSE against the
# reference at a ladder of wall-clock times. Results in tools/peers/results/ (see README.md).
#
#   tools/peers/run_peers.sh [run_peers.py options]      # e.g. --jobs cornell-box.path --max-spp 256
#
# Needs: target/release/render (cargo build --release), Debian packages blender, python3-numpy,
# libllvm19 and openimageio-tools, and the pinned Mitsuba virtualenv of tools/references (made
# here on first use, as make_references.sh makes it).
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
repo="$(cd "$here/../.." && pwd)"
venv="${STRATA_REFS_VENV:-$HOME/.cache/strata/refs-venv}"

for cmd in blender oiiotool; do
    command -v "$cmd" >/dev/null || { echo "run_peers: $cmd not found (apt-get install blender python3-numpy openimageio-tools)" >&2; exit 1; }
done
[ -x "$repo/target/release/render" ] || { echo "run_peers: build strata first: cargo build --release" >&2; exit 1; }
# Dr.Jit's llvm backend needs LLVM's shared library; Debian 12's LLVM 15/16 abort, 19 works.
llvm=/usr/lib/x86_64-linux-gnu/libLLVM-19.so
if [ -z "${DRJIT_LIBLLVM_PATH:-}" ] && [ -e "$llvm" ]; then export DRJIT_LIBLLVM_PATH="$llvm"; fi
[ -n "${DRJIT_LIBLLVM_PATH:-}" ] || echo "run_peers: WARNING: libLLVM 19 not found (apt-get install libllvm19); mitsuba-llvm will fail" >&2

# the pinned virtualenv: make_references.sh creates it when missing or stale, then lists jobs
[ -x "$venv/bin/python" ] && cmp -s "$repo/tools/references/requirements.txt" "$venv/.strata-requirements" \
    || "$repo/tools/references/make_references.sh" --list >/dev/null
exec "$venv/bin/python" "$here/run_peers.py" "$@"
