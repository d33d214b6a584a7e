"""Cycles side of tools/peers/khronos_side_by_side.sh: run as

    blender -b --factory-startup -P tools/peers/khronos_cycles.py -- \
        MODEL.glb ENV.hdr WxH SPP BOUNCES THREADS OUT.exr [--distribution GGX|MULTI_GGX]
        [--straight-alpha]

Imports MODEL.glb (a copy made by khronos_scene.py, holding the camera strata renders with)
with Blender's glTF importer, keeps the materials the importer makes (Principled BSDF), and
renders one linear float32 EXR with Cycles on the CPU. Prints one line "CYCLES_JSON {...}"
with Blender's version and the wall-clock and CPU seconds of the render call alone.

Set-up:
- world: an Environment Texture of ENV.hdr (equirectangular, default mapping, linear
  interpolation) into the Background, strength 1; strata's --env uses the same orientation;
- camera: the file's camera, vertical field of view forced (sensor fit VERTICAL,
  angle_y = yfov), WxH at 100 %;
- the scene is scaled to a unit box as cycles_worker.py does (normalise_scale: radiance does
  not change under a uniform scale; the camera moves with it);
- Principled BSDF distribution: MULTI_GGX by default (Cycles' multiple-scattering GGX, to
  set beside strata's energy-compensated default); the importer itself leaves GGX
  (single scattering), which --distribution GGX restores;
- textures: every image the importer loaded gets the alpha mode "Channel Packed": colour and
  alpha are independent, as glTF means them. With Blender's default ("Straight"), Cycles
  premultiplies the colour of an image by its alpha wherever the Alpha output is not used,
  so an OPAQUE material whose texture has an alpha channel renders dark where the alpha is
  low (AlphaBlendModeTest's OPAQUE cell, TextureSettingsTest's labels); --straight-alpha
  keeps Blender's default, for pictures of what the importer alone gives;
- alpha: the importer links glTF alpha into the Principled Alpha input for BLEND and MASK
  materials, and for MASK sets only the material's blend method and alpha threshold, which
  Cycles ignores (they are EEVEE's). So a MASK material's Alpha becomes
  1 - (alpha < alphaCutoff) here, a hard cut as glTF asks; BLEND keeps the fractional
  alpha (Cycles mixes in a Transparent BSDF: the same mean as strata's stochastic coverage);
- bounces: max_bounces, diffuse, glossy and transmission bounces = BOUNCES (strata's
  --max-depth - 1); transparent bounces 64 (strata's alpha pass-through is not a bounce);
- render settings of cycles_worker.render_settings (box filter of one pixel, no adaptive
  sampling, no denoising, no clamping, light threshold 0, Standard view transform).
Back faces: the importer turns doubleSided false into Blender's "Backface Culling", a
viewport (EEVEE/Workbench) setting: Cycles shades both sides, as strata does.
"""
import argparse
import json
import os
import resource
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import cycles_worker  # noqa: E402  (also applies the numpy.bool alias the 3.4 importer needs)

import bpy  # noqa: E402


def cpu_seconds():
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def hard_mask(mat):
    """Alpha -> 1 - (alpha < cutoff) in a MASK material (blend method CLIP)."""
    nt = mat.node_tree
    for node in [n for n in nt.nodes if n.type == "BSDF_PRINCIPLED"]:
        alpha = node.inputs["Alpha"]
        if not alpha.is_linked:
            alpha.default_value = 0.0 if alpha.default_value < mat.alpha_threshold else 1.0
            continue
        source = alpha.links[0].from_socket
        nt.links.remove(alpha.links[0])
        below = nt.nodes.new("ShaderNodeMath")
        below.operation = "LESS_THAN"
        below.inputs[1].default_value = mat.alpha_threshold
        keep = nt.nodes.new("ShaderNodeMath")
        keep.operation = "SUBTRACT"
        keep.inputs[0].default_value = 1.0
        nt.links.new(source, below.inputs[0])
        nt.links.new(below.outputs["Value"], keep.inputs[1])
        nt.links.new(keep.outputs["Value"], alpha)


def main():
    ap = argparse.ArgumentParser(prog="khronos_cycles.py")
    for name in ("model", "env", "resolution", "spp", "bounces", "threads", "out"):
        ap.add_argument(name)
    ap.add_argument("--distribution", choices=["MULTI_GGX", "GGX"], default="MULTI_GGX")
    ap.add_argument("--straight-alpha", action="store_true")
    args = ap.parse_args(sys.argv[sys.argv.index("--") + 1:])
    model, env, out, distribution = args.model, args.env, args.out, args.distribution
    width, height = (int(v) for v in args.resolution.split("x"))
    bounces = int(args.bounces)

    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.import_scene.gltf(filepath=model)
    s = bpy.context.scene

    # camera: the one khronos_scene.py wrote
    cams = [o for o in s.objects if o.type == "CAMERA"]
    if len(cams) != 1:
        sys.exit(f"khronos_cycles: expected one camera in {model}, found {len(cams)}")
    with open(model, "rb") as f:  # the GLB's JSON chunk, for yfov and znear
        f.seek(12)
        size = int.from_bytes(f.read(4), "little")
        f.read(4)
        persp = json.loads(f.read(size))["cameras"][-1]["perspective"]
    s.camera = cams[0]
    cams[0].data.sensor_fit = "VERTICAL"
    cams[0].data.angle_y = persp["yfov"]
    k = cycles_worker.normalise_scale(s)
    cams[0].data.clip_start = persp["znear"] * k
    cams[0].data.clip_end = 1e9

    # materials: the importer's, with the distribution chosen and MASK made a hard cut
    masks = []
    for mat in bpy.data.materials:
        if not mat.use_nodes:
            continue
        for node in mat.node_tree.nodes:
            if node.type == "BSDF_PRINCIPLED":
                node.distribution = distribution
        if mat.blend_method == "CLIP":
            hard_mask(mat)
            masks.append(f"{mat.name} (cutoff {mat.alpha_threshold:g})")

    # textures: glTF's colour is not premultiplied by its alpha
    if not args.straight_alpha:
        for image in bpy.data.images:
            image.alpha_mode = "CHANNEL_PACKED"

    # world: the environment map, default mapping, strength 1
    world = bpy.data.worlds.new("khronos_world")
    world.use_nodes = True
    nt = world.node_tree
    tex = nt.nodes.new("ShaderNodeTexEnvironment")
    tex.image = bpy.data.images.load(os.path.abspath(env))
    nt.links.new(tex.outputs["Color"], nt.nodes["Background"].inputs["Color"])
    nt.nodes["Background"].inputs["Strength"].default_value = 1.0
    s.world = world

    cycles_worker.render_settings(s, width, height, bounces, int(args.threads))
    cy = s.cycles
    cy.glossy_bounces = bounces
    cy.transmission_bounces = bounces
    cy.transparent_max_bounces = 64
    cy.samples = int(args.spp)
    cy.seed = 0

    c0, t0 = cpu_seconds(), time.perf_counter()
    bpy.ops.render.render()
    t1, c1 = time.perf_counter(), cpu_seconds()
    bpy.data.images["Render Result"].save_render(filepath=out, scene=s)
    print("CYCLES_JSON " + json.dumps({
        "blender": bpy.app.version_string, "seconds": round(t1 - t0, 2), "cpu_seconds": round(c1 - c0, 2),
        "spp": cy.samples, "max_bounces": cy.max_bounces, "distribution": distribution,
        "sampling_pattern": cy.sampling_pattern, "scale": k, "hard_masks": masks,
        "image_alpha": "straight" if args.straight_alpha else "channel packed"}), flush=True)


main()
