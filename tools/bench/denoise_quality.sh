#!/bin/sh
# Denoising at equal time (issue 30): see tools/bench/denoise_quality.py for what it measures.
# Needs ~/.cache/strata/denoise-venv (python3 -m venv; pip install numpy flip-evaluator OpenEXR)
# and Open Image Denoise where render finds it: tools/oidn-prefix.sh (README, "Denoising")
exec nice -n 19 "$HOME/.cache/strata/denoise-venv/bin/python" "$(dirname "$0")/denoise_quality.py" "$@"
