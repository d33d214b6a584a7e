"""Blender/Cycles side of tools/peers/run_peers.py: run as

    blender -b --factory-startup -P tools/peers/cycles_worker.py -- \
        SCENE.gltf MODE WxH BOUNCES THREADS [MATERIALS] [--env MAP.hdr --env-rotate DEG --env-intensity S]

MODE is 'ao' or 'shaded'; BOUNCES is Cycles' max_bounces; MATERIALS is the reference job's
material model, 'lambertian' (the default) or 'gltf'; --env and its options light a 'shaded'
scene with an environment map as strata's options of the same names. The scene is imported and set up
once (strata's contract, see below); then the worker reads one request per stdin line,
"SPP SEED OUT.exr", renders, writes a linear float32 EXR and answers with one line
"PEER_JSON {...}" holding the wall-clock and CPU seconds of the render call alone.

Set-up (strata's conventions, DESIGN.md / scenes/references/README.md):
- MATERIALS 'lambertian': every material becomes a Lambertian Diffuse BSDF (roughness 0)
  with the glTF base colour factor, plus, for emissive materials, an Emission of
  emissiveFactor x emissive strength that is zeroed on back faces (Geometry > Backfacing)
  unless the material is doubleSided: Cycles' mesh emission is two-sided, glTF's (and
  strata's) is front-face only;
- MATERIALS 'gltf': the importer's Principled BSDF is kept (what a Blender user gets from the
  file: Specular 0.5, i.e. F0 = 0.04, IOR 1.5), with its microfacet distribution set to plain
  "GGX" (single scattering, as strata's --energy-compensation off and the Mitsuba glTF
  reference; Cycles' "Multiscatter GGX" adds back the energy that GGX loses). The importer
  sets Emission = emissiveFactor and Emission Strength = KHR_materials_emissive_strength, the
  same radiance as the Lambertian set-up's Emission; the strength is zeroed on back faces as
  above. Principled is not the glTF BRDF (its diffuse part has a retro-reflection term, its
  metal and specular mixing differ), so Cycles converges to its own image: run_peers.py
  measures it against its own converged render. Base colour and metallic-roughness
  textures are kept after checking that the importer wired them as glTF says (base colour
  sRGB; metallic = B, roughness = G, linear: check_texture_wiring); emissive, normal and
  occlusion textures, non-OPAQUE alpha, texture transforms and factors beside a texture are
  refused (not checked for this use);
- camera: the imported glTF camera with the vertical field of view forced (sensor fit
  VERTICAL, angle_y = yfov), the requested resolution at 100 %;
- max_bounces and the diffuse, glossy and transmission bounces = BOUNCES (Cycles' default
  of 4 glossy bounces would cut glossy paths short of strata's depth);
- box pixel filter of width 1 (a sample counts in its own pixel), no adaptive sampling,
  no denoising, no clamping, light threshold 0, no motion blur, CPU, fixed thread count;
- the scene is scaled uniformly to a unit bounding box (largest |coordinate| 1): Cycles 3.4
  samples triangle lights imprecisely at large coordinates (cornell-box is in millimetres:
  direct light on surfaces near its ceiling light came out 2-5 % dark, 0.7 % over the image;
  BSDF sampling alone agreed within its noise, the scene scaled by 1e-3 to 0.01 %). Radiance
  is invariant under a uniform scale while there are no punctual lights (refused here);
- 'shaded': with --env, the map as the world, turned and scaled as strata's --env-rotate and
  --env-intensity, seen by the camera (environment_world: the rotation's sign is derived
  there and was checked against strata); otherwise a black world unless
  extras.strata.background; 'ao': every surface white
  diffuse (rho = 1), no emission, a world of constant radiance 1 hidden from camera rays,
  so a pixel is (1/pi) * integral of V cos (the Mitsuba AO contract).
"""
import argparse
import json
import math
import os
import resource
import sys
import time

import numpy

numpy.bool = bool  # Blender 3.4's glTF importer still uses the removed numpy.bool alias

import bpy  # noqa: E402

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "references"))
from scene_hash import gltf_json  # noqa: E402  (a .gltf's or a .glb's JSON)
from mathutils import Matrix  # noqa: E402


def cpu_seconds():
    r = resource.getrusage(resource.RUSAGE_SELF)  # all threads of this process
    return r.ru_utime + r.ru_stime


def front_face_only(nt, strength):
    """Drives an unlinked emission strength socket by strength x (1 - Backfacing): Cycles'
    mesh emission leaves both faces, glTF's leaves the front face only."""
    geo = nt.nodes.new("ShaderNodeNewGeometry")
    front = nt.nodes.new("ShaderNodeMath")
    front.operation = "SUBTRACT"  # 1 - backfacing
    front.inputs[0].default_value = 1.0
    nt.links.new(geo.outputs["Backfacing"], front.inputs[1])
    scaled = nt.nodes.new("ShaderNodeMath")
    scaled.operation = "MULTIPLY"
    scaled.inputs[0].default_value = strength.default_value
    nt.links.new(front.outputs["Value"], scaled.inputs[1])
    nt.links.new(scaled.outputs["Value"], strength)


def diffuse_material(name, rgb, emission=None, double_sided=False):
    """Diffuse(rgb) [+ Emission(emission), front face only unless double_sided]."""
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    nt = m.node_tree
    nt.nodes.clear()
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    dif = nt.nodes.new("ShaderNodeBsdfDiffuse")
    dif.inputs["Color"].default_value = (*rgb, 1.0)
    dif.inputs["Roughness"].default_value = 0.0  # Lambert, not Oren-Nayar
    shader = dif.outputs["BSDF"]
    if emission is not None:
        em = nt.nodes.new("ShaderNodeEmission")
        em.inputs["Color"].default_value = (*emission, 1.0)
        em.inputs["Strength"].default_value = 1.0
        if not double_sided:
            front_face_only(nt, em.inputs["Strength"])
        add = nt.nodes.new("ShaderNodeAddShader")
        nt.links.new(shader, add.inputs[0])
        nt.links.new(em.outputs["Emission"], add.inputs[1])
        shader = add.outputs["Shader"]
    nt.links.new(shader, out.inputs["Surface"])
    return m


def gltf_materials(doc, mode):
    """glTF material name -> our Blender material."""
    out = {}
    for i, mat in enumerate(doc.get("materials", [])):
        name = mat.get("name", f"material{i}")
        pbr = mat.get("pbrMetallicRoughness", {})
        if mode == "ao":
            out[name] = diffuse_material("peer_white", (1.0, 1.0, 1.0))
            continue
        if "baseColorTexture" in pbr or "emissiveTexture" in mat:
            sys.exit(f"cycles_worker: material '{name}': textures are not supported by this set-up")
        rgb = tuple(pbr.get("baseColorFactor", [1, 1, 1, 1])[:3])
        strength = mat.get("extensions", {}).get("KHR_materials_emissive_strength", {}).get("emissiveStrength", 1.0)
        e = [c * strength for c in mat.get("emissiveFactor", [0, 0, 0])]
        out[name] = diffuse_material("peer_" + name, rgb, e if any(c > 0 for c in e) else None,
                                     mat.get("doubleSided", False))
    return out


def principled_default_material():
    """glTF's default material (no material on a primitive): base colour 1, metallic 1,
    roughness 1, as a Principled BSDF like the importer's."""
    m = bpy.data.materials.new("peer_gltf_default")
    m.use_nodes = True
    p = m.node_tree.nodes["Principled BSDF"]
    p.inputs["Base Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    p.inputs["Metallic"].default_value = 1.0
    p.inputs["Roughness"].default_value = 1.0
    p.inputs["IOR"].default_value = 1.5
    return m


def refuse_unchecked(name, mat):
    """MATERIALS 'gltf': exits on what the importer's output was not checked for here:
    emissive, normal and occlusion textures, non-OPAQUE alpha, texture transforms or a second
    UV set, and a factor beside a texture (the importer then adds multiply nodes)."""
    pbr = mat.get("pbrMetallicRoughness", {})
    unchecked = [k for k in ("emissiveTexture", "normalTexture", "occlusionTexture") if k in mat]
    if mat.get("alphaMode", "OPAQUE") != "OPAQUE":
        unchecked.append(f"alphaMode {mat['alphaMode']}")
    for key, factors in (("baseColorTexture", {"baseColorFactor": [1, 1, 1, 1]}),
                         ("metallicRoughnessTexture", {"metallicFactor": 1, "roughnessFactor": 1})):
        info = pbr.get(key)
        if info is None:
            continue
        if info.get("texCoord", 0) != 0 or info.get("extensions"):
            unchecked.append(f"{key} with texCoord or extensions")
        unchecked += [f"{f} beside {key}" for f, one in factors.items() if pbr.get(f, one) != one]
    if unchecked:
        sys.exit(f"cycles_worker: material '{name}': not checked for 'gltf' materials: {', '.join(unchecked)}")


def check_texture_wiring(m, mat, doc):
    """Verifies that the importer wired the material's textures as glTF 2.0 means them
    (DESIGN.md's material model) and returns what it found; exits otherwise:
    - baseColorTexture: an Image Texture in sRGB, its Color straight into Base Color;
    - metallicRoughnessTexture: an Image Texture in Non-Color (linear data) into a Separate
      Color in RGB mode, Blue into Metallic, Green into Roughness;
    - both: the default UV map (TEXCOORD_0), flat projection, linear interpolation and the
      extension that the glTF sampler's wrap asks for (REPEAT for repeat; others not checked).
    Images get the alpha mode "Channel Packed": glTF's colour is not premultiplied by its
    alpha, and with Blender's default ("Straight") Cycles darkens colour where alpha < 1."""
    pbr = mat.get("pbrMetallicRoughness", {})
    nt = m.node_tree
    p = next(n for n in nt.nodes if n.type == "BSDF_PRINCIPLED")

    def source(socket):
        return (socket.links[0].from_node, socket.links[0].from_socket.name) if socket.is_linked else (None, None)

    def image_node(node, info, colorspace):
        texture = doc["textures"][info["index"]]
        sampler = doc["samplers"][texture["sampler"]] if "sampler" in texture else {}  # none: repeat
        wrap = {sampler.get("wrapS", 10497), sampler.get("wrapT", 10497)}
        ok = (node is not None and node.type == "TEX_IMAGE" and node.image is not None
              and node.image.colorspace_settings.name == colorspace and not node.inputs["Vector"].is_linked
              and node.projection == "FLAT" and node.interpolation == "Linear"
              and wrap == {10497} and node.extension == "REPEAT")
        if ok:
            node.image.alpha_mode = "CHANNEL_PACKED"
        return ok

    found = {}
    if "baseColorTexture" in pbr:
        node, out = source(p.inputs["Base Color"])
        if out != "Color" or not image_node(node, pbr["baseColorTexture"], "sRGB"):
            sys.exit(f"cycles_worker: material '{m.name}': base colour texture not wired as glTF asks")
        found["base_color"] = f"{node.image.name} (sRGB) -> Base Color"
    if "metallicRoughnessTexture" in pbr:
        sep_m, out_m = source(p.inputs["Metallic"])
        sep_r, out_r = source(p.inputs["Roughness"])
        ok = (sep_m is not None and sep_m == sep_r and sep_m.type == "SEPARATE_COLOR" and sep_m.mode == "RGB"
              and (out_m, out_r) == ("Blue", "Green"))
        if ok:
            node, out = source(sep_m.inputs["Color"])
            ok = out == "Color" and image_node(node, pbr["metallicRoughnessTexture"], "Non-Color")
        if not ok:
            sys.exit(f"cycles_worker: material '{m.name}': metallic-roughness texture not wired as glTF asks "
                     "(B -> Metallic, G -> Roughness, linear)")
        found["metallic_roughness"] = f"{node.image.name} (Non-Color) -> B: Metallic, G: Roughness"
    return found


def keep_principled(doc, s, distribution="GGX"):
    """MATERIALS 'gltf': keeps the importer's Principled BSDF materials, sets their
    distribution, checks their textures' wiring (check_texture_wiring), makes emission
    front-face only unless doubleSided, and gives primitives without a material glTF's
    default one. Returns a summary for the worker's report."""
    gltf = {m.get("name", f"material{i}"): m for i, m in enumerate(doc.get("materials", []))}
    for name, mat in gltf.items():
        refuse_unchecked(name, mat)
    textures = {}
    default = None  # made when a primitive has no material
    seen, emissive = set(), {}
    for ob in s.objects:
        if ob.type != "MESH":
            continue
        if not ob.material_slots:
            default = default or principled_default_material()
            ob.data.materials.append(default)
        for slot in ob.material_slots:
            if slot.material is None:
                default = default or principled_default_material()
                slot.material = default
            m = slot.material
            if m.name in seen:
                continue
            seen.add(m.name)
            if m.name not in gltf and m is not default:
                sys.exit(f"cycles_worker: no glTF material named '{m.name}'")
            nodes = [n for n in m.node_tree.nodes if n.type == "BSDF_PRINCIPLED"]
            if len(nodes) != 1:
                sys.exit(f"cycles_worker: material '{m.name}': expected one Principled BSDF, found {len(nodes)}")
            p = nodes[0]
            p.distribution = distribution
            if m.name in gltf:
                wiring = check_texture_wiring(m, gltf[m.name], doc)
                if wiring:
                    textures[m.name] = wiring
            # emitted radiance = Emission x Emission Strength (the importer's factor x strength)
            strength = p.inputs["Emission Strength"]
            radiance = [c * strength.default_value for c in p.inputs["Emission"].default_value[:3]]
            if any(c > 0 for c in radiance):
                emissive[m.name] = {"radiance": [round(c, 6) for c in radiance]}
                if not gltf.get(m.name, {}).get("doubleSided", False):
                    front_face_only(m.node_tree, strength)
                    emissive[m.name]["front_face_only"] = True
    return {"distribution": distribution, "emissive": emissive, "textures": textures,
            "default_material_used": default is not None}


def normalise_scale(s):
    """Bakes every mesh into world space scaled by k = 1 / (largest |world coordinate| of the
    meshes and the camera), moves the camera by k, and returns k."""
    obs = [o for o in s.objects if o.type in ("MESH", "CAMERA")]
    world = {o.name: o.matrix_world.copy() for o in obs}
    extent = 0.0
    for o in obs:
        extent = max(extent, *(abs(c) for c in world[o.name].translation))
        if o.type == "MESH" and len(o.data.vertices):
            co = numpy.empty(3 * len(o.data.vertices))
            o.data.vertices.foreach_get("co", co)
            m = numpy.array(world[o.name])
            extent = max(extent, float(numpy.abs(co.reshape(-1, 3) @ m[:3, :3].T + m[:3, 3]).max()))
    k = 1.0 / extent if extent > 0 else 1.0
    for o in obs:
        o.parent = None
        if o.type == "MESH":
            o.data = o.data.copy()  # single user: a shared mesh must not be transformed twice
            o.data.transform(Matrix.Scale(k, 4) @ world[o.name])
            o.matrix_world = Matrix.Identity(4)
        else:
            loc, rot, _ = world[o.name].decompose()
            o.matrix_world = Matrix.Translation(loc * k) @ rot.to_matrix().to_4x4()
    return k


def environment_world(path, rotate_degrees, intensity):
    """A world lit and seen through the equirectangular map at `path` as strata's --env FILE
    --env-rotate DEG --env-intensity S: Texture Coordinate (Generated: the ray's direction) ->
    Mapping -> Environment Texture (linear interpolation, the map's linear radiance as stored:
    colour space "Linear", i.e. no conversion) -> Background of strength S. Camera rays see it
    (Cycles' default; strata's too when --background is not given).

    Rotation. The importer turns glTF (x, y, z) into Blender (x, -z, y), a proper rotation, so a
    turn by a about glTF +Y is the turn by a about Blender +Z, both counter-clockwise by the
    right-hand rule. Unrotated, both look a direction up at the same texel (envmap.rs: strata
    follows Blender). strata turns the map by +DEG: the radiance along d is the unrotated map's
    along R(-DEG) d. A Mapping node of type POINT hands the texture R(angle) d, so its Z angle
    is -DEG. Verified against strata by rendering both signs (tools/peers/README.md)."""
    world = bpy.data.worlds.new("peer_env_world")
    world.use_nodes = True
    nt = world.node_tree
    coords = nt.nodes.new("ShaderNodeTexCoord")
    mapping = nt.nodes.new("ShaderNodeMapping")
    mapping.vector_type = "POINT"
    mapping.inputs["Rotation"].default_value = (0.0, 0.0, -math.radians(rotate_degrees))
    tex = nt.nodes.new("ShaderNodeTexEnvironment")
    tex.image = bpy.data.images.load(path)
    tex.image.colorspace_settings.name = "Linear"  # scene linear Rec.709: radiance unchanged
    tex.interpolation = "Linear"
    tex.projection = "EQUIRECTANGULAR"
    nt.links.new(coords.outputs["Generated"], mapping.inputs["Vector"])
    nt.links.new(mapping.outputs["Vector"], tex.inputs["Vector"])
    bg = nt.nodes["Background"]
    nt.links.new(tex.outputs["Color"], bg.inputs["Color"])
    bg.inputs["Strength"].default_value = intensity
    return world


def render_settings(s, width, height, bounces, threads):
    """Cycles set up to strata's contract: CPU path tracing with max_bounces = strata's
    --max-depth - 1, a box filter of one pixel, no adaptive sampling, denoising, clamping,
    light threshold or motion blur, a fixed thread count, the Standard view transform
    (linear radiance in, plain sRGB out) and a linear float32 EXR as the output format."""
    s.render.engine = "CYCLES"
    cy = s.cycles
    cy.device = "CPU"
    cy.use_adaptive_sampling = False
    cy.use_denoising = False
    cy.use_preview_denoising = False
    cy.sample_clamp_direct = 0.0
    cy.sample_clamp_indirect = 0.0
    cy.light_sampling_threshold = 0.0
    cy.pixel_filter_type = "BOX"
    cy.filter_width = 1.0
    cy.max_bounces = bounces
    cy.diffuse_bounces = bounces
    cy.glossy_bounces = bounces  # Cycles' default is 4: glossy paths would end early
    cy.transmission_bounces = bounces
    cy.caustics_reflective = True
    cy.caustics_refractive = True
    cy.blur_glossy = 0.0
    cy.use_auto_tile = False
    s.render.use_motion_blur = False
    s.render.threads_mode = "FIXED"
    s.render.threads = threads
    s.render.resolution_x, s.render.resolution_y = width, height
    s.render.resolution_percentage = 100
    s.render.pixel_aspect_x = s.render.pixel_aspect_y = 1.0
    s.render.film_transparent = False
    s.view_settings.view_transform = "Standard"
    s.view_settings.look = "None"
    s.view_settings.exposure = 0.0
    s.view_settings.gamma = 1.0
    im = s.render.image_settings
    im.file_format = "OPEN_EXR"
    im.color_mode = "RGB"
    im.color_depth = "32"
    im.exr_codec = "ZIP"


def replace_materials(doc, s, mode):
    """MATERIALS 'lambertian' (and AO): every slot gets our diffuse material of the same glTF
    name; primitives without a material get white (glTF's default base colour)."""
    ours = gltf_materials(doc, mode)
    white = diffuse_material("peer_default", (1.0, 1.0, 1.0))  # glTF's default material
    for ob in s.objects:
        if ob.type != "MESH":
            continue
        if not ob.material_slots:
            ob.data.materials.append(white)
        for slot in ob.material_slots:
            if slot.material is None:
                slot.material = white
            elif slot.material.name in ours:
                slot.material = ours[slot.material.name]
            elif not slot.material.name.startswith("peer_"):
                sys.exit(f"cycles_worker: no glTF material named '{slot.material.name}'")


def setup(scene_path, mode, width, height, bounces, threads, materials="lambertian", environment=None):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.import_scene.gltf(filepath=scene_path, convert_lighting_mode="COMPAT")
    doc = gltf_json(scene_path)
    if doc.get("extensions", {}).get("KHR_lights_punctual") and mode != "ao":
        sys.exit("cycles_worker: punctual lights are not set up here (only emissive meshes)")
    s = bpy.context.scene

    # materials: the importer's Principled BSDF for the glTF model (made GGX, emission front
    # face only); otherwise (and for AO, whatever the model) replace what the importer made
    # by ours, matched by name
    if materials not in ("lambertian", "gltf"):
        sys.exit(f"cycles_worker: unknown material model '{materials}'")
    if materials == "gltf" and mode != "ao":
        s["peer_materials"] = json.dumps(keep_principled(doc, s))
    else:
        replace_materials(doc, s, mode)
        s["peer_materials"] = json.dumps({"diffuse": "Lambertian override (see the docstring)"})

    # camera: the first glTF camera; force the vertical fov (aspect from the resolution)
    cams = [o for o in s.objects if o.type == "CAMERA"]
    if not cams:
        sys.exit("cycles_worker: the scene has no camera")
    gcam = doc["cameras"][0]["perspective"]
    s.camera = cams[0]
    cams[0].data.sensor_fit = "VERTICAL"
    cams[0].data.angle_y = gcam["yfov"]
    k = normalise_scale(s)
    cams[0].data.clip_start = gcam.get("znear", 0.01) * k
    cams[0].data.clip_end = 1e9
    if len(cams) > 1:
        print("cycles_worker: several cameras; using", cams[0].name, file=sys.stderr)

    # world: for 'shaded' with an environment map, the map in place of the document's
    # background (as strata's --env and the Mitsuba reference's envmap)
    if mode == "shaded" and environment is not None:
        s.world = environment_world(*environment)
    else:
        world = bpy.data.worlds.new("peer_world")
        world.use_nodes = True
        bg = world.node_tree.nodes["Background"]
        if mode == "ao":
            bg.inputs["Color"].default_value = (1, 1, 1, 1)
            world.cycles_visibility.camera = False  # camera rays that miss give 0
        else:
            c = doc.get("extras", {}).get("strata", {}).get("background", [0, 0, 0])
            bg.inputs["Color"].default_value = (*c, 1)
        bg.inputs["Strength"].default_value = 1.0
        s.world = world

    # renderer
    render_settings(s, width, height, bounces, threads)
    s.render.use_persistent_data = True  # keep the synced scene and BVH between renders
    s["peer_scale"] = k
    return s


def main():
    ap = argparse.ArgumentParser(prog="cycles_worker.py")
    ap.add_argument("scene")
    ap.add_argument("mode", choices=["ao", "shaded"])
    ap.add_argument("resolution", help="WxH")
    ap.add_argument("bounces", type=int)
    ap.add_argument("threads", type=int)
    ap.add_argument("materials", nargs="?", default="lambertian")
    ap.add_argument("--env", help="equirectangular map lighting a 'shaded' scene (strata's --env)")
    ap.add_argument("--env-rotate", type=float, default=0.0, help="degrees about glTF +Y (strata's --env-rotate)")
    ap.add_argument("--env-intensity", type=float, default=1.0, help="radiance scale (strata's --env-intensity)")
    args = ap.parse_args(sys.argv[sys.argv.index("--") + 1:])
    width, height = (int(v) for v in args.resolution.split("x"))
    environment = None if args.env is None else (os.path.abspath(args.env), args.env_rotate, args.env_intensity)
    s = setup(args.scene, args.mode, width, height, args.bounces, args.threads, args.materials, environment)
    s.cycles.samples = 1
    t0 = time.perf_counter()
    bpy.ops.render.render()  # warm-up: kernels, scene sync, BVH (kept: persistent data)
    warmup = time.perf_counter() - t0
    info = {"blender": bpy.app.version_string, "sampling_pattern": s.cycles.sampling_pattern,
            "max_bounces": s.cycles.max_bounces, "glossy_bounces": s.cycles.glossy_bounces,
            "threads": s.render.threads, "materials": json.loads(s["peer_materials"]),
            "scale": s["peer_scale"], "warmup_seconds": warmup,
            "environment": None if environment is None else {
                "file": environment[0], "rotate_degrees": environment[1], "intensity": environment[2],
                "mapping_rotation_z_degrees": -environment[1]}}
    print("PEER_JSON " + json.dumps({"ready": True, **info}), flush=True)
    for line in sys.stdin:
        if not line.strip():
            continue
        spp, seed, out = line.split(maxsplit=2)
        s.cycles.samples = int(spp)
        s.cycles.seed = int(seed)
        s.update_tag()  # without it, persistent data keeps the previous render's sample count
        c0, t0 = cpu_seconds(), time.perf_counter()
        bpy.ops.render.render()
        t1, c1 = time.perf_counter(), cpu_seconds()
        bpy.data.images["Render Result"].save_render(filepath=out.strip(), scene=s)
        print("PEER_JSON " + json.dumps({"seconds": t1 - t0, "cpu_seconds": c1 - c0}), flush=True)


if __name__ == "__main__":  # khronos_cycles.py imports this file's helpers
    main()
