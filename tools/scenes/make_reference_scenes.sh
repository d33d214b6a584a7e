#!/usr/bin/env bash
# Regenerates the derived reference scenes from the third-party originals in shared/scenes
# (or $STRATA_SHARED_SCENES): scenes/cornell_box/CornellBox.{gltf,bin}, scenes/cornell-box.gltf,
# scenes/point-lights.gltf, scenes/suzanne.gltf and scenes/emissive-strength.gltf.
# The copied folders scenes/suzanne/ and scenes/emissive_strength/ are the originals, unmodified.
# Standard library Python only; the output is the same bytes on every run.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
repo="$(cd "$here/../.." && pwd)"
cd "$repo"
shared="${STRATA_SHARED_SCENES:-$repo/../shared/scenes}"

if [ -f "$shared/cornell_box_bevy/CornellBox.glb" ]; then
    python3 "$here/glb_to_gltf.py" "$shared/cornell_box_bevy/CornellBox.glb" scenes/cornell_box/CornellBox.gltf
else
    echo "make_reference_scenes: $shared/cornell_box_bevy/CornellBox.glb not found; keeping scenes/cornell_box/" >&2
fi
python3 "$here/add_camera.py" scenes/cornell_box/CornellBox.gltf scenes/cornell-box.gltf \
    --eye=-278,273,800 --target=-278,273,-280 --yfov 0.6911 --aspect 1
python3 "$here/edit_wrapper.py" scenes/cornell-box.gltf --single-sided-emitters

python3 "$here/make_point_lights.py" scenes/point-lights.gltf

python3 "$here/add_camera.py" scenes/suzanne/Suzanne.gltf scenes/suzanne.gltf \
    --eye=0,0.4,4.2 --target=0,-0.02,0 --yfov 0.56 --aspect 1.3333333
python3 "$here/edit_wrapper.py" scenes/suzanne.gltf --background 1,1,1

python3 "$here/add_camera.py" scenes/emissive_strength/EmissiveStrengthTest.gltf scenes/emissive-strength.gltf \
    --eye=0,2,16 --target=0,-0.3,0 --yfov 0.46 --aspect 2
python3 "$here/edit_wrapper.py" scenes/emissive-strength.gltf --single-sided-emitters
