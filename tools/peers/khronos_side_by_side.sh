#!/usr/bin/env bash
# Khronos glTF sample models that test materials, rendered by strata and by Blender's Cycles
# (glTF importer, Principled BSDF) under the same environment map and camera; one PNG per
# model, strata left and Cycles right (docs/khronos/<Name>.png), and a table of their
# differences on stdout. See docs/khronos.md.
#
#   tools/peers/khronos_side_by_side.sh [--scenes DIR] [--models "A B"] [--spp N] [--width 360]
#       [--wide-width 560] [--env FILE.hdr] [--threads N] [--work DIR] [--out DIR] [--strata BIN]
#       [--single-scattering]
#
# Needs: a release build of strata (cargo build --release), and the Debian packages blender
# (3.4), python3-numpy, openimageio-tools and fonts-dejavu-core.
#
# Per model:
#  1. khronos_scene.py writes WORK/<Name>.glb: the model plus a camera (strata's framing rule
#     for camera-less files, fitted to the bounding box; see its docstring) and prints WxH;
#  2. strata: --integrator path --env ENV --spp N (--max-depth 8, energy compensation on:
#     the defaults) -> WORK/<Name>.strata.exr;
#  3. Cycles: khronos_cycles.py (max_bounces 7, the same spp, Principled BSDF with Cycles'
#     multiple-scattering GGX, MASK as a hard cut, textures' alpha "Channel Packed"; see its
#     docstring) -> WORK/<Name>.cycles.exr;
#     --single-scattering: strata --energy-compensation off and Cycles' (single-scattering)
#     GGX, the distribution Blender's importer leaves, instead;
#  4. strata again with --seed 1 (the Monte Carlo noise in the differences: the same measure
#     between two strata renders), and a coverage mask (strata AO with an occlusion distance
#     of 1e-9: 1 where a camera ray meets the model, 0 where it sees the sky);
#  5. the PNG: each EXR clamped to [0, 1] and sRGB-encoded (no exposure, no tone curve),
#     labelled, side by side (a model at least twice as wide as tall is rendered --wide-width
#     wide and shown with strata above Cycles); and the differences: mean |strata - Cycles| /
#     mean Cycles over the image and over the model (mask), the same between strata's two
#     seeds over the model, and the ratio of strata's mean to Cycles' over the model.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
repo="$(cd "$here/../.." && pwd)"

scenes=/work/shared/scenes
models="NormalTangentTest NormalTangentMirrorTest AlphaBlendModeTest TextureSettingsTest MetalRoughSpheresNoTextures"
spp=256
width=360
wide_width=560
env=""
threads="$(nproc)"
work=/tmp/strata-khronos
out="$repo/docs/khronos"
strata="${CARGO_TARGET_DIR:-$repo/target}/release/render"
distribution=MULTI_GGX
strata_args=()
blender=blender
python=/usr/bin/python3
font=/usr/share/fonts/truetype/dejavu/DejaVuSans-Bold.ttf

usage() { sed -n '2,/^set -euo/p' "$0" | grep '^#' | sed 's/^# \{0,1\}//'; }
while [ $# -gt 0 ]; do
    case "$1" in
        --scenes) scenes="$2"; shift 2 ;;
        --models) models="$2"; shift 2 ;;
        --spp) spp="$2"; shift 2 ;;
        --width) width="$2"; shift 2 ;;
        --wide-width) wide_width="$2"; shift 2 ;;
        --env) env="$2"; shift 2 ;;
        --threads) threads="$2"; shift 2 ;;
        --work) work="$2"; shift 2 ;;
        --out) out="$2"; shift 2 ;;
        --strata) strata="$2"; shift 2 ;;
        --single-scattering) distribution=GGX; strata_args=(--energy-compensation off); shift ;;
        -h|--help) usage; exit 0 ;;
        *) echo "khronos_side_by_side: unknown option $1" >&2; usage >&2; exit 2 ;;
    esac
done

for cmd in "$blender" oiiotool "$python"; do
    command -v "$cmd" >/dev/null || { echo "khronos_side_by_side: $cmd not found (apt-get install blender python3-numpy openimageio-tools)" >&2; exit 1; }
done
[ -x "$strata" ] || { echo "khronos_side_by_side: no strata binary at $strata (cargo build --release, or --strata BIN)" >&2; exit 1; }
[ -f "$font" ] || { echo "khronos_side_by_side: no font $font (apt-get install fonts-dejavu-core)" >&2; exit 1; }
mkdir -p "$work" "$out"

# where each model lives under --scenes, and the environment it is shown in
model_path() {
    case "$1" in
        MetalRoughSpheresNoTextures) echo "$scenes/metal_rough_spheres_no_textures/MetalRoughSpheresNoTextures.gltf" ;;
        *) if [ -f "$scenes/khronos/$1/glTF-Binary/$1.glb" ]; then
               echo "$scenes/khronos/$1/glTF-Binary/$1.glb"
           else
               echo "$scenes/khronos/$1/glTF/$1.gltf"
           fi ;;
    esac
}
model_env() {
    if [ -n "$env" ]; then echo "$env"; return; fi
    case "$1" in
        TextureSettingsTest) echo "$scenes/env/studio_small_05_1k/studio_small_05_1k.hdr" ;;
        *) echo "$scenes/env/kloppenheim_05_1k/kloppenheim_05_1k.hdr" ;;
    esac
}
# "Stats Avg" of an image expression (oiiotool arguments), as three numbers
avg() { oiiotool "$@" --printstats | awk '/Stats Avg/ {print $3, $4, $5; exit}'; }
mean3() { awk '{print ($1 + $2 + $3) / 3}'; }
# an EXR as a labelled sRGB cell: clamp to [0, 1], sRGB encode, a 24-pixel strip above it
# holding the label (nothing of the picture is covered)
cell() {
    local w h
    read -r w h < <(oiiotool --info "$1" | sed -n 's/.*: *\([0-9]*\) x *\([0-9]*\),.*/\1 \2/p')
    oiiotool "$1" --ch R,G,B --clamp:min=0:max=1 --colorconvert linear sRGB \
        --crop "${w}x$((h + 24))+0-24" --origin +0+0 --fullpixels \
        --text:x=6:y=18:size=16:color=1,1,1:font="$font" "$2" -o "$3"
}

source=(src build.rs Cargo.toml Cargo.lock)  # what the strata binary is built from
echo "strata source at $(git -C "$repo" log -1 --format=%h -- "${source[@]}")$(git -C "$repo" diff --quiet HEAD -- "${source[@]}" || echo '+dirty') (checkout $(git -C "$repo" rev-parse --short HEAD)), $("$blender" --version 2>/dev/null | head -1), spp $spp, threads $threads, Principled $distribution, strata ${strata_args[*]:-defaults}" >&2
echo "| model | resolution | environment | strata s | Cycles s | mean abs diff / mean, image | same, model only | noise: strata seed 0 vs 1, model only | strata / Cycles mean, model only |"
echo "|---|---|---|---|---|---|---|---|---|"
for name in $models; do
    src="$(model_path "$name")"
    hdr="$(model_env "$name")"
    [ -f "$src" ] || { echo "khronos_side_by_side: $src not found (--scenes DIR)" >&2; exit 1; }
    glb="$work/$name.glb"
    res="$("$python" "$here/khronos_scene.py" "$src" "$glb" --width "$width" --wide-width "$wide_width")"

    t0=$(date +%s.%N)
    nice -n 10 "$strata" --integrator path --env "$hdr" --spp "$spp" --threads "$threads" --resolution "$res" \
        ${strata_args[@]+"${strata_args[@]}"} --no-png -o "$work/$name.strata.exr" "$glb" > "$work/$name.strata.log" 2>&1
    t1=$(date +%s.%N)
    nice -n 10 "$blender" -b --factory-startup -P "$here/khronos_cycles.py" -- \
        "$glb" "$hdr" "$res" "$spp" 7 "$threads" "$work/$name.cycles.exr" --distribution "$distribution" > "$work/$name.cycles.log" 2>&1 \
        || { tail -20 "$work/$name.cycles.log" >&2; exit 1; }
    t2=$(date +%s.%N)
    nice -n 10 "$strata" --integrator path --env "$hdr" --spp "$spp" --threads "$threads" --resolution "$res" \
        ${strata_args[@]+"${strata_args[@]}"} --seed 1 --no-png -o "$work/$name.strata-seed1.exr" "$glb" > /dev/null 2>&1
    nice -n 10 "$strata" --integrator ao --ao-distance 1e-9 --spp 4 --threads "$threads" --resolution "$res" \
        --no-png -o "$work/$name.mask.exr" "$glb" > /dev/null 2>&1

    # render times: strata's own (render phase) and Cycles' render call, plus each process's wall clock
    ts="$(awk '/ spp, / {for (i = 1; i <= NF; i++) if ($i == "s,") print $(i-1)}' "$work/$name.strata.log" | tail -1)"
    tc="$(sed -n 's/^CYCLES_JSON //p' "$work/$name.cycles.log" | "$python" -c 'import json, sys; print(json.load(sys.stdin)["seconds"])')"
    ws="$(echo "$t1 - $t0" | bc)"; wc="$(echo "$t2 - $t1" | bc)"

    s="$work/$name.strata.exr"; c="$work/$name.cycles.exr"; m="$work/$name.mask.exr"
    d_img="$(avg "$s" --ch R,G,B "$c" --ch R,G,B --absdiff | mean3)"
    c_img="$(avg "$c" --ch R,G,B | mean3)"
    d_mod="$(avg "$s" --ch R,G,B "$c" --ch R,G,B --absdiff "$m" --ch R,G,B --mul | mean3)"
    c_mod="$(avg "$c" --ch R,G,B "$m" --ch R,G,B --mul | mean3)"
    s_mod="$(avg "$s" --ch R,G,B "$m" --ch R,G,B --mul | mean3)"
    n_mod="$(avg "$s" --ch R,G,B "$work/$name.strata-seed1.exr" --ch R,G,B --absdiff "$m" --ch R,G,B --mul | mean3)"

    cell "$s" "strata, $spp spp" "$work/$name.strata.cell.exr"
    cell "$c" "Cycles, $("$blender" --version 2>/dev/null | head -1), $spp spp" "$work/$name.cycles.cell.exr"
    w="${res%x*}"; h="${res#*x}"
    layout=2x1; [ "$w" -ge $((2 * h)) ] && layout=1x2  # a wide model: strata above Cycles
    oiiotool "$work/$name.strata.cell.exr" "$work/$name.cycles.cell.exr" --mosaic:pad=4 "$layout" -d uint8 -o "$out/$name.png"

    printf '| %s | %s | %s | %.1f (%.1f) | %.1f (%.1f) | %.3f | %.3f | %.3f | %.3f |\n' "$name" "$res" "$(basename "$hdr" .hdr)" \
        "$ts" "$ws" "$tc" "$wc" "$(echo "$d_img / $c_img" | bc -l)" "$(echo "$d_mod / $c_mod" | bc -l)" \
        "$(echo "$n_mod / $s_mod" | bc -l)" "$(echo "$s_mod / $c_mod" | bc -l)"
done
echo "(times: the render alone, and in brackets the whole process: loading, BVH, kernels, writing; EXRs in $work)" >&2
