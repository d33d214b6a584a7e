#!/usr/bin/env python3
"""Writes scenes/coat.gltf, the clear-coat scene of the Mitsuba references
(KHR_materials_clearcoat).

The set of the glass scenes (tools/scenes/make_glass.py): a checkered floor before a striped
back wall under a constant pale-blue sky (the document's `extras.strata.background`, Mitsuba's
`constant` emitter and strata's `--background R,G,B`), plus one square emissive light above
and in front of the spheres, out of the camera's view, so that the coats show a highlight as
well as the sky, the floor and the wall's stripes. Four spheres of radius 0.4, left to right:

1. no coat: a red dielectric (base colour (0.7, 0.06, 0.05), metallic 0, roughness 0.5), the
   control the second is compared with;
2. the same red dielectric under a smooth coat (clearcoatFactor 1, clearcoatRoughnessFactor 0):
   a mirror of weight Fc (4% at normal incidence, all of it at grazing angles);
3. a half-weight coat (clearcoatFactor 0.5, smooth) over a smooth green dielectric (base colour
   (0.08, 0.45, 0.15), roughness 0): two mirrors in the same direction, the coat's and the
   base's own specular lobe under it;
4. a rough coat (clearcoatFactor 1, clearcoatRoughnessFactor 0.3, GGX alpha 0.09) over a rough
   blue metal (base colour (0.3, 0.5, 0.9), metallic 1, roughness 0.6).

No textures, no clearcoatNormalTexture (the coat's normal is the vertex normal), no other
material extension: the reference conversion refuses what it does not convert exactly. The
floor and wall are the glTF metallic-roughness material (metallic 0, roughness 1). The spheres
are smooth-shaded UV spheres of 64 x 32 segments (make_sphere_grid.uv_sphere).

Standard library only; the buffer is embedded as a base64 data URI and the output is the same
bytes on every run.

    python3 tools/scenes/make_coat.py [OUT.gltf]     # default <repo>/scenes/coat.gltf

Units are metres; the sky's and the light's radiance are linear RGB.
"""
import base64
import json
import os
import sys

sys.dont_write_bytecode = True  # no __pycache__ in the source tree
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from add_camera import look_at_quaternion  # noqa: E402
from make_glass import CAMERA, FLOOR, SKY, WALL, quads_mesh, stripes, tiles  # noqa: E402
from make_point_lights import Builder  # noqa: E402
from make_sphere_grid import uv_sphere  # noqa: E402

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

RADIUS = 0.4
SPHERE_SEGMENTS, SPHERE_RINGS = 64, 32
# A square light facing down, above the camera's view: centre, half side, radiance.
LIGHT = {"centre": [0.0, 3.0, 2.0], "half": 0.5, "radiance": 16.0}
RED = [0.7, 0.06, 0.05]
# name, x, base colour, metallic, roughness, clear coat (factor, roughness) or None
SPHERES = [
    ("uncoated red dielectric", -1.425, RED, 0.0, 0.5, None),
    ("smooth coat over red dielectric", -0.475, RED, 0.0, 0.5, (1.0, 0.0)),
    ("half smooth coat over smooth green dielectric", 0.475, [0.08, 0.45, 0.15], 0.0, 0.0, (0.5, 0.0)),
    ("rough coat over rough blue metal", 1.425, [0.3, 0.5, 0.9], 1.0, 0.6, (1.0, 0.3)),
]


def sphere_material(name, base, metallic, roughness, coat):
    m = {"name": name, "pbrMetallicRoughness": {"baseColorFactor": base + [1.0], "metallicFactor": metallic,
                                                "roughnessFactor": roughness}}
    if coat is not None:
        m["extensions"] = {"KHR_materials_clearcoat": {"clearcoatFactor": coat[0],
                                                       "clearcoatRoughnessFactor": coat[1]}}
    return m


def build():
    b = Builder()
    materials, meshes, nodes = [], [], []

    def diffuse(name, colour):
        materials.append({"name": name, "pbrMetallicRoughness": {
            "baseColorFactor": colour + [1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0}})
        return len(materials) - 1

    def primitive(p, n, i, mat):
        return {"attributes": {"POSITION": b.vec3(p), "NORMAL": b.vec3(n)}, "indices": b.indices(i),
                "material": mat, "mode": 4}

    # The floor and the wall of the glass scenes: one mesh each, one primitive per colour.
    for name, quads, normal, colours in (
            ("floor", tiles(FLOOR["x"], FLOOR["z"], FLOOR["tile"]), [0.0, 1.0, 0.0], FLOOR["colours"]),
            ("wall", stripes(WALL["x"], WALL["z"], WALL["height"], WALL["stripe"]), [0.0, 0.0, 1.0],
             WALL["colours"])):
        prims = [primitive(*quads_mesh(q, normal), diffuse(f"{name} {k}", c))
                 for k, (q, c) in enumerate(zip(quads, colours))]
        meshes.append({"name": name, "primitives": prims})
        nodes.append({"name": name, "mesh": len(meshes) - 1})

    sp, sn, si = uv_sphere(SPHERE_SEGMENTS, SPHERE_RINGS)
    pos, nrm, idx = b.vec3(sp), b.vec3(sn), b.indices(si)
    for name, x, base, metallic, roughness, coat in SPHERES:
        materials.append(sphere_material(name, base, metallic, roughness, coat))
        meshes.append({"name": name, "primitives": [{
            "attributes": {"POSITION": pos, "NORMAL": nrm}, "indices": idx,
            "material": len(materials) - 1, "mode": 4}]})
        nodes.append({"name": name, "mesh": len(meshes) - 1, "translation": [x, RADIUS + 0.02, 0.0],
                      "scale": [RADIUS] * 3})

    # The light: counter-clockwise seen from below (its front, the emitting side, faces -Y).
    cx, cy, cz = LIGHT["centre"]
    h = LIGHT["half"]
    p, n, i = quads_mesh([[[cx - h, cy, cz - h], [cx + h, cy, cz - h], [cx + h, cy, cz + h], [cx - h, cy, cz + h]]],
                         [0.0, -1.0, 0.0])
    materials.append({"name": "light", "emissiveFactor": [1.0, 1.0, 1.0],
                      "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": LIGHT["radiance"]}},
                      "pbrMetallicRoughness": {"baseColorFactor": [0.0, 0.0, 0.0, 1.0], "metallicFactor": 0.0,
                                               "roughnessFactor": 1.0}})
    meshes.append({"name": "light", "primitives": [primitive(p, n, i, len(materials) - 1)]})
    nodes.append({"name": "light", "mesh": len(meshes) - 1})

    cam = CAMERA
    nodes.insert(0, {"name": "camera", "camera": 0, "translation": cam["eye"],
                     "rotation": look_at_quaternion(cam["eye"], cam["target"])})
    return {
        "asset": {"version": "2.0", "generator": "strata tools/scenes/make_coat.py"},
        "extensionsUsed": ["KHR_materials_clearcoat", "KHR_materials_emissive_strength"],
        "extras": {"strata": {"background": SKY}},
        "scene": 0,
        "scenes": [{"name": "clear-coated spheres", "nodes": list(range(len(nodes)))}],
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


def main():
    args = sys.argv[1:]
    if len(args) > 1 or any(a.startswith("-") for a in args):
        sys.exit("usage: make_coat.py [OUT.gltf]")
    out = args[0] if args else os.path.join(REPO, "scenes", "coat.gltf")
    with open(out, "w") as f:
        json.dump(build(), f, indent=1)
        f.write("\n")
    print(out)


if __name__ == "__main__":
    main()
