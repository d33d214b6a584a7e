#!/usr/bin/env bash
# Converts the large benchmark meshes of the shared scene collection to GLB once, into
# ~/.cache/strata/meshes (or $STRATA_BENCH_MESHES), for `cargo bench --bench backends`.
#
#   tools/bench/prepare_meshes.sh [SHARED_SCENES_DIR]     # default: ../shared/scenes
#
# conference_room (OBJ, 331k triangles, camera inside the room), stanford_armadillo (PLY,
# 346k), stanford_bunny (PLY, 69k), metal_rough_spheres_no_textures (glTF, 1.04M triangles
# after flattening its instanced meshes; copied as is, it has no camera: strata frames it).
set -euo pipefail
cd "$(dirname "$0")/../.."
shared="${1:-../shared/scenes}"
out="${STRATA_BENCH_MESHES:-$HOME/.cache/strata/meshes}"
mkdir -p "$out"
convert() {
    local in="$1" name="$2"
    shift 2
    if [ -f "$out/$name.glb" ]; then
        echo "$out/$name.glb exists"
    else
        python3 tools/scenes/mesh_to_glb.py "$shared/$in" "$out/$name.glb" "$@"
    fi
}
convert conference_room/conference.obj conference_room --eye=332.8,350,500 --target=332.8,250,-400
convert stanford_armadillo/Armadillo.ply stanford_armadillo --camera
convert stanford_bunny/bunny.ply stanford_bunny --camera
cp -n "$shared"/metal_rough_spheres_no_textures/MetalRoughSpheresNoTextures.{gltf,bin} "$out"/
ls -l "$out"
