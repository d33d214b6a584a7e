#!/usr/bin/env python3
"""Writes scenes/glass.gltf and scenes/thin-glass.gltf, the glass scenes of the Mitsuba
references (issue 32, KHR material extensions).

Both stand on a checkered floor (0.5 m tiles, light grey and dark blue) before a striped back
wall (0.25 m stripes, orange and off-white, 1.8 m high, so the top of the view shows the sky),
lit by a constant pale-blue sky (the document's `extras.strata.background`, which the reference
conversion turns into Mitsuba's `constant` emitter and strata's `--background R,G,B`). The floor
and wall are the glTF metallic-roughness material (metallic 0, roughness 1): the structure that
the glass bends, blurs, tints and darkens.

- glass.gltf: three spheres of radius 0.5 bounding volumes (KHR_materials_transmission 1,
  KHR_materials_volume thicknessFactor 1, KHR_materials_ior 1.5), left to right: smooth and
  clear; rough (roughness 0.4, GGX alpha 0.16) and tinted (base colour (1, 0.9, 0.75)); smooth
  and absorbing (attenuationColor (0.85, 0.6, 0.35) at attenuationDistance 1 m). strata renders
  them as `Bsdf::Glass`; the reference as Mitsuba's `dielectric`, the rough interface plugin
  and a `homogeneous` interior medium (tools/references/mitsuba_refs.py).
- thin-glass.gltf (--thin): four thin-walled panels, 0.7 x 1.1 m, standing 5 cm above the
  floor and turned about +Y (transmission 1, ior 1.5, no volume), left to right: smooth and
  clear; smooth and tinted (0.95, 0.75, 0.45); rough 0.4 and clear; rough 0.3 and tinted
  (0.45, 0.7, 0.95). strata renders them as `Bsdf::ThinGlass`.

Every glass material has metallic 0 and transmission 1: no mixture of glass and the glTF BRDF
(the reference conversion refuses those). The spheres are smooth-shaded UV spheres of 64 x 32
segments (make_sphere_grid.uv_sphere).

Standard library only; the buffer is embedded as a base64 data URI and the output is the same
bytes on every run.

    python3 tools/scenes/make_glass.py [--thin] [OUT.gltf]
        # default <repo>/scenes/glass.gltf, with --thin <repo>/scenes/thin-glass.gltf

Units are metres; the sky's radiance is linear RGB from every direction.
"""
import base64
import json
import math
import os
import sys

sys.dont_write_bytecode = True  # no __pycache__ in the source tree
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from add_camera import look_at_quaternion  # noqa: E402
from make_point_lights import Builder, yaw_quaternion  # noqa: E402
from make_sphere_grid import uv_sphere  # noqa: E402

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

SKY = [0.8, 0.9, 1.0]
CAMERA = {"eye": [0.0, 1.6, 4.2], "target": [0.0, 0.55, 0.0], "yfov": 0.65, "aspect": 4.0 / 3.0}
FLOOR = {"x": (-4.0, 4.0), "z": (-1.5, 4.5), "tile": 0.5,
         "colours": ([0.75, 0.75, 0.7], [0.12, 0.16, 0.35])}
WALL = {"x": (-4.0, 4.0), "z": -1.5, "height": 1.8, "stripe": 0.25,
        "colours": ([0.8, 0.35, 0.12], [0.85, 0.85, 0.8])}
IOR = 1.5
RADIUS = 0.5
SPHERE_SEGMENTS, SPHERE_RINGS = 64, 32
# name, x, roughness, base colour, attenuation (colour, distance) or None
SPHERES = [
    ("smooth clear glass", -1.15, 0.0, [1.0, 1.0, 1.0], None),
    ("rough tinted glass", 0.0, 0.4, [1.0, 0.9, 0.75], None),
    ("smooth absorbing glass", 1.15, 0.0, [1.0, 1.0, 1.0], ([0.85, 0.6, 0.35], 1.0)),
]
PANEL = {"width": 0.7, "height": 1.1, "lift": 0.05}
# name, x, yaw (degrees about +Y), roughness, base colour
PANELS = [
    ("smooth clear sheet", -1.35, 35.0, 0.0, [1.0, 1.0, 1.0]),
    ("smooth tinted sheet", -0.45, -20.0, 0.0, [0.95, 0.75, 0.45]),
    ("rough clear sheet", 0.45, 20.0, 0.4, [1.0, 1.0, 1.0]),
    ("rough tinted sheet", 1.35, -35.0, 0.3, [0.45, 0.7, 0.95]),
]


def tiles(x_range, z_range, size):
    """The floor's tiles (y = 0, facing +Y) as two lists of quads, the checker's two colours."""
    quads = ([], [])
    nx = round((x_range[1] - x_range[0]) / size)
    nz = round((z_range[1] - z_range[0]) / size)
    for i in range(nx):
        for k in range(nz):
            x0, z0 = x_range[0] + i * size, z_range[0] + k * size
            x1, z1 = x0 + size, z0 + size
            # Counter-clockwise seen from +Y.
            quads[(i + k) % 2].append([[x0, 0.0, z1], [x1, 0.0, z1], [x1, 0.0, z0], [x0, 0.0, z0]])
    return quads


def stripes(x_range, z, height, width):
    """The wall's vertical stripes (z = const, facing +Z), two lists of quads alternating."""
    quads = ([], [])
    n = round((x_range[1] - x_range[0]) / width)
    for i in range(n):
        x0 = x_range[0] + i * width
        x1 = x0 + width
        quads[i % 2].append([[x0, 0.0, z], [x1, 0.0, z], [x1, height, z], [x0, height, z]])
    return quads


def quads_mesh(quads, normal):
    pos, nrm, idx = [], [], []
    for q in quads:
        base = len(pos)
        pos += q
        nrm += [normal] * 4
        idx += [base, base + 1, base + 2, base, base + 2, base + 3]
    return pos, nrm, idx


def glass_material(name, roughness, base, volume, attenuation=None):
    """transmission 1, metallic 0, ior IOR; a volume (thicknessFactor 1) when `volume`, with
    `attenuation` = (colour, distance) when given."""
    ext = {"KHR_materials_transmission": {"transmissionFactor": 1.0}, "KHR_materials_ior": {"ior": IOR}}
    if volume:
        vol = {"thicknessFactor": 1.0}
        if attenuation is not None:
            vol["attenuationColor"], vol["attenuationDistance"] = attenuation
        ext["KHR_materials_volume"] = vol
    return {"name": name, "pbrMetallicRoughness": {"baseColorFactor": base + [1.0], "metallicFactor": 0.0,
                                                   "roughnessFactor": roughness},
            "extensions": ext}


def build(thin=False):
    b = Builder()
    materials, meshes, nodes = [], [], []

    def diffuse(name, colour):
        materials.append({"name": name, "pbrMetallicRoughness": {
            "baseColorFactor": colour + [1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0}})
        return len(materials) - 1

    def primitive(p, n, i, mat):
        return {"attributes": {"POSITION": b.vec3(p), "NORMAL": b.vec3(n)}, "indices": b.indices(i),
                "material": mat, "mode": 4}

    # The floor and the wall: one mesh each, one primitive per colour.
    for name, quads, normal, colours in (
            ("floor", tiles(FLOOR["x"], FLOOR["z"], FLOOR["tile"]), [0.0, 1.0, 0.0], FLOOR["colours"]),
            ("wall", stripes(WALL["x"], WALL["z"], WALL["height"], WALL["stripe"]), [0.0, 0.0, 1.0],
             WALL["colours"])):
        prims = [primitive(*quads_mesh(q, normal), diffuse(f"{name} {k}", c))
                 for k, (q, c) in enumerate(zip(quads, colours))]
        meshes.append({"name": name, "primitives": prims})
        nodes.append({"name": name, "mesh": len(meshes) - 1})

    used = ["KHR_materials_transmission", "KHR_materials_ior"]
    if not thin:
        used.append("KHR_materials_volume")
        sp, sn, si = uv_sphere(SPHERE_SEGMENTS, SPHERE_RINGS)
        pos, nrm, idx = b.vec3(sp), b.vec3(sn), b.indices(si)
        for name, x, roughness, base, attenuation in SPHERES:
            materials.append(glass_material(name, roughness, base, True, attenuation))
            meshes.append({"name": name, "primitives": [{
                "attributes": {"POSITION": pos, "NORMAL": nrm}, "indices": idx,
                "material": len(materials) - 1, "mode": 4}]})
            nodes.append({"name": name, "mesh": len(meshes) - 1, "translation": [x, RADIUS + 0.02, 0.0],
                          "scale": [RADIUS] * 3})
    else:
        w, h, lift = PANEL["width"] / 2, PANEL["height"], PANEL["lift"]
        p, n, i = quads_mesh([[[-w, lift, 0.0], [w, lift, 0.0], [w, lift + h, 0.0], [-w, lift + h, 0.0]]],
                             [0.0, 0.0, 1.0])
        pos, nrm, idx = b.vec3(p), b.vec3(n), b.indices(i)
        for name, x, yaw, roughness, base in PANELS:
            materials.append(glass_material(name, roughness, base, False))
            meshes.append({"name": name, "primitives": [{
                "attributes": {"POSITION": pos, "NORMAL": nrm}, "indices": idx,
                "material": len(materials) - 1, "mode": 4}]})
            nodes.append({"name": name, "mesh": len(meshes) - 1, "translation": [x, 0.0, 0.0],
                          "rotation": yaw_quaternion(yaw)})

    cam = CAMERA
    nodes.insert(0, {"name": "camera", "camera": 0, "translation": cam["eye"],
                     "rotation": look_at_quaternion(cam["eye"], cam["target"])})
    generator = "strata tools/scenes/make_glass.py" + (" --thin" if thin else "")
    doc = {
        "asset": {"version": "2.0", "generator": generator},
        "extensionsUsed": used,
        "extras": {"strata": {"background": SKY}},
        "scene": 0,
        "scenes": [{"name": "thin-walled glass panels" if thin else "glass spheres",
                    "nodes": list(range(len(nodes)))}],
        "nodes": nodes,
        "cameras": [{"type": "perspective", "perspective": {
            "yfov": cam["yfov"], "aspectRatio": cam["aspect"], "znear": 0.01}}],
        "meshes": meshes,
        "materials": materials,
        "accessors": b.accessors,
        "bufferViews": b.views,
        "buffers": [{"byteLength": len(b.data),
                     "uri": "data:application/octet-stream;base64," + base64.b64encode(bytes(b.data)).decode()}],
    }
    return doc


def main():
    args = sys.argv[1:]
    thin = "--thin" in args
    args = [a for a in args if a != "--thin"]
    if len(args) > 1 or any(a.startswith("-") for a in args):
        sys.exit("usage: make_glass.py [--thin] [OUT.gltf]")
    default = "thin-glass.gltf" if thin else "glass.gltf"
    out = args[0] if args else os.path.join(REPO, "scenes", default)
    with open(out, "w") as f:
        json.dump(build(thin), f, indent=1)
        f.write("\n")
    print(out)


if __name__ == "__main__":
    main()
