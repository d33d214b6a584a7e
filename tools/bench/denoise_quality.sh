#!/bin/sh
# Denoising at equal time (issue 30): see tools/bench/denoise_quality.py for what it measures.
# Needs ~/.cache/strata/denoise-venv (python3 -m venv; pip install numpy flip-evaluator OpenEXR)
# and a render built with: OIDN_DIR=~/.cache/strata/oidn-2.5.1 cargo build --release --features denoise
exec nice -n 19 "$HOME/.cache/strata/denoise-venv/bin/python" "$(dirname "$0")/denoise_quality.py" "$@"
