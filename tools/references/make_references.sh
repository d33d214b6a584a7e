#!/usr/bin/env bash
# Regenerates strata's Mitsuba reference images (scenes/references/*.exr, manifest.json).
#
#   tools/references/make_references.sh                 # checks, then every reference (about 20 min on 2 cores)
#   tools/references/make_references.sh cornell-box.path ao-wall.ao   # only these; the manifest is merged
#   tools/references/make_references.sh --list          # job names, spp, passes
#   tools/references/make_references.sh --materials gltf [jobs...]   # shaded jobs with the glTF BRDF
#   tools/references/make_references.sh --manifest tools/peers/hdri-races.json --materials gltf [jobs...]
#                                       # another job manifest's references, into its out_dir (or --out-dir)
#
# Makes (once) a virtualenv with the pinned packages of requirements.txt beside this script, in
# $STRATA_REFS_VENV (default ~/.cache/strata/refs-venv), then runs the conversion's own checks
# (textured-quad orientation, camera handedness, point-light and emission radiometry) and the
# renders. Needs python3 (3.11) and oiiotool (Debian: openimageio-tools). Not run by CI.
# STRATA_MITSUBA_VARIANT picks the Mitsuba variant (default scalar_rgb). With --materials gltf the
# checks of the glTF BRDF plugin (check_gltf_bsdf.py), of the glass BSDFs (check_glass_bsdf.py) and
# of the clear-coat plugin (check_coat_bsdf.py) run first too; their chi-square tests need the
# llvm_ad_rgb variant, which needs Debian's libllvm19.
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
repo="$(cd "$here/../.." && pwd)"
venv="${STRATA_REFS_VENV:-$HOME/.cache/strata/refs-venv}"
python="${PYTHON:-python3}"

command -v oiiotool >/dev/null || { echo "make_references: oiiotool not found (apt-get install openimageio-tools)" >&2; exit 1; }

stamp="$venv/.strata-requirements"
if [ ! -x "$venv/bin/python" ] || ! cmp -s "$here/requirements.txt" "$stamp"; then
    echo "make_references: creating $venv" >&2
    rm -rf "$venv"
    "$python" -m venv "$venv"
    "$venv/bin/pip" install --quiet --upgrade pip
    "$venv/bin/pip" install --quiet -r "$here/requirements.txt"
    cp "$here/requirements.txt" "$stamp"
fi

cd "$repo"
if [ "${1:-}" = "--list" ]; then
    exec "$venv/bin/python" "$here/mitsuba_refs.py" --list
fi
check_dir="$(mktemp -d)"
trap 'rm -rf "$check_dir"' EXIT
"$venv/bin/python" "$here/mitsuba_refs.py" --check "$check_dir"
prev=""
for arg in "$@"; do
    if [ "$arg" = "--materials=gltf" ] || { [ "$prev" = "--materials" ] && [ "$arg" = "gltf" ]; }; then
        (cd "$check_dir" && "$venv/bin/python" "$here/check_gltf_bsdf.py")
        (cd "$check_dir" && "$venv/bin/python" "$here/check_glass_bsdf.py")
        (cd "$check_dir" && "$venv/bin/python" "$here/check_coat_bsdf.py")
        break
    fi
    prev="$arg"
done
"$venv/bin/python" "$here/mitsuba_refs.py" "$@"
