#!/usr/bin/env bash
# Regenerates strata's POV-Ray reference images (scenes/references/<scene>.direct.povray.exr and
# scenes/references/povray-manifest.json): the converter's self-tests (analytic point-light
# radiometry, camera orientation and pixel alignment), then the renders (seconds on 2 cores).
#
#   tools/references/make_povray_reference.sh                 # every scene in povray_refs.py JOBS
#   tools/references/make_povray_reference.sh point-lights    # only these (the manifest is merged)
#
# Needs python3 (standard library only), POV-Ray 3.7 and oiiotool
# (Debian 12: apt-get install povray openimageio-tools). Not run by CI.
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
repo="$(cd "$here/../.." && pwd)"
python="${PYTHON:-python3}"

for tool in povray oiiotool; do
    command -v "$tool" >/dev/null || { echo "make_povray_reference: $tool not found (apt-get install povray openimageio-tools)" >&2; exit 1; }
done

cd "$repo"
check_dir="$(mktemp -d)"
trap 'rm -rf "$check_dir"' EXIT
"$python" "$here/povray_refs.py" --test "$check_dir"
"$python" "$here/povray_refs.py" "$@"
