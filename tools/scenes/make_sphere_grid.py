#!/usr/bin/env python3
"""Writes scenes/sphere-grid.gltf: sixteen spheres of the glTF metallic-roughness material,
metallic 0, 1/3, 2/3, 1 (rows, bottom to top) x roughness 0.15, 0.4, 0.7, 1 (columns, left to
right), one gold-ish base colour, standing on a grey rough floor in front of a grey wall, lit
by one square emissive area light above and in front of them. The glossy test scene of
issue 28: its Mitsuba references render the glTF BRDF plugin, and the peers run times it.

With --sky it writes scenes/sphere-grid-sky.gltf instead: the same spheres, floor and camera
under a constant pale-blue sky (the document's `extras.strata.background`, which the reference
conversion turns into Mitsuba's `constant` emitter and strata's `--background R,G,B`), with no
area light and no wall. The wall would fill the camera's view and hide the half of the sky
behind the spheres; without it the camera sees the sky above the floor's far edge, and the
metals reflect sky, floor and that edge, so paths that leave the scene after BSDF sampling
(weighted against sampling the sky as a light) make most of the image.

Standard library only; the buffer is embedded as a base64 data URI and the output is the
same bytes on every run (the spheres share one mesh; each node has its own material).

    python3 tools/scenes/make_sphere_grid.py [--sky] [OUT.gltf]
        # default <repo>/scenes/sphere-grid.gltf, with --sky <repo>/scenes/sphere-grid-sky.gltf

Units are metres. The light's emission is emissiveFactor x KHR_materials_emissive_strength,
radiance, on its front (downward) face only; the sky's is radiance from every direction.
"""
import base64
import json
import math
import os
import struct
import sys

sys.dont_write_bytecode = True  # no __pycache__ in the source tree
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from add_camera import look_at_quaternion  # noqa: E402
from make_point_lights import Builder, quad  # noqa: E402

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

METALLIC = [0.0, 1.0 / 3.0, 2.0 / 3.0, 1.0]
ROUGHNESS = [0.15, 0.4, 0.7, 1.0]
BASE = [0.9, 0.65, 0.3]
RADIUS = 0.4
SPACING = 1.0
SEGMENTS, RINGS = 32, 16
CAMERA = {"eye": [0.0, 2.0, 6.0], "target": [0.0, 1.9, 0.0], "yfov": 0.75, "aspect": 4.0 / 3.0}
LIGHT = {"centre": [0.0, 5.0, 2.5], "half": 1.0, "radiance": 12.0}
# Linear RGB radiance of the --sky variant's background: coloured, so that a channel mixed up
# anywhere shows, and about as bright on the spheres as the area light is.
SKY = [0.6, 0.75, 1.0]


def uv_sphere(segments=SEGMENTS, rings=RINGS):
    """A unit sphere: (rings + 1) x (segments + 1) vertices with smooth normals, CCW outward."""
    pos, idx = [], []
    for r in range(rings + 1):
        theta = math.pi * r / rings
        for s in range(segments + 1):
            phi = 2.0 * math.pi * s / segments
            pos.append([math.sin(theta) * math.cos(phi), math.cos(theta), -math.sin(theta) * math.sin(phi)])
    w = segments + 1
    for r in range(rings):
        for s in range(segments):
            a, b, c, d = r * w + s, (r + 1) * w + s, (r + 1) * w + s + 1, r * w + s + 1
            if r > 0:
                idx += [a, b, d]
            if r < rings - 1:
                idx += [d, b, c]
    return pos, [list(p) for p in pos], idx


def build(sky=False):
    """The glTF document: lit by the area light in front of a wall, or with `sky` by a constant
    background alone."""
    b = Builder()
    materials, meshes, nodes = [], [], []

    def mesh(name, p, n, i, mat):
        meshes.append({"name": name, "primitives": [{
            "attributes": {"POSITION": b.vec3(p), "NORMAL": b.vec3(n)}, "indices": b.indices(i),
            "material": mat, "mode": 4}]})
        return len(meshes) - 1

    def material(name, color, metallic, roughness):
        materials.append({"name": name, "pbrMetallicRoughness": {
            "baseColorFactor": color + [1.0], "metallicFactor": metallic, "roughnessFactor": roughness}})
        return len(materials) - 1

    p, n, i = quad([[-6.0, 0.0, 4.0], [6.0, 0.0, 4.0], [6.0, 0.0, -3.0], [-6.0, 0.0, -3.0]], [0.0, 1.0, 0.0])
    nodes.append({"name": "floor", "mesh": mesh("floor", p, n, i, material("floor", [0.5, 0.5, 0.5], 0.0, 1.0))})
    if not sky:
        p, n, i = quad([[-6.0, 0.0, -3.0], [6.0, 0.0, -3.0], [6.0, 6.0, -3.0], [-6.0, 6.0, -3.0]], [0.0, 0.0, 1.0])
        nodes.append({"name": "wall", "mesh": mesh("wall", p, n, i, material("wall", [0.4, 0.4, 0.4], 0.0, 1.0))})

    sp, sn, si = uv_sphere()
    sphere_pos, sphere_nrm, sphere_idx = b.vec3(sp), b.vec3(sn), b.indices(si)
    for row, metallic in enumerate(METALLIC):
        for col, roughness in enumerate(ROUGHNESS):
            name = f"metallic {metallic:.2f} roughness {roughness:.2f}"
            mat = material(name, BASE, metallic, roughness)
            meshes.append({"name": name, "primitives": [{
                "attributes": {"POSITION": sphere_pos, "NORMAL": sphere_nrm}, "indices": sphere_idx,
                "material": mat, "mode": 4}]})
            x = (col - 1.5) * SPACING
            y = RADIUS + 0.1 + row * SPACING
            nodes.append({"name": name, "mesh": len(meshes) - 1, "translation": [x, y, 0.0],
                          "scale": [RADIUS, RADIUS, RADIUS]})

    if not sky:
        cx, cy, cz = LIGHT["centre"]
        h = LIGHT["half"]
        # Facing down: counter-clockwise seen from below.
        p, n, i = quad([[cx - h, cy, cz - h], [cx + h, cy, cz - h], [cx + h, cy, cz + h], [cx - h, cy, cz + h]],
                       [0.0, -1.0, 0.0])
        materials.append({"name": "light", "emissiveFactor": [1.0, 1.0, 1.0],
                          "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": LIGHT["radiance"]}},
                          "pbrMetallicRoughness": {"baseColorFactor": [0.0, 0.0, 0.0, 1.0], "metallicFactor": 0.0,
                                                   "roughnessFactor": 1.0}})
        nodes.append({"name": "light", "mesh": mesh("light", p, n, i, len(materials) - 1)})

    cam = CAMERA
    nodes.insert(0, {"name": "camera", "camera": 0, "translation": cam["eye"],
                     "rotation": look_at_quaternion(cam["eye"], cam["target"])})
    doc = {
        "asset": {"version": "2.0", "generator": "strata tools/scenes/make_sphere_grid.py"},
        "extensionsUsed": ["KHR_materials_emissive_strength"],
        "scene": 0,
        "scenes": [{"name": "sphere grid", "nodes": list(range(len(nodes)))}],
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
    if sky:
        # No emissive material is left to use the extension.
        del doc["extensionsUsed"]
        doc["scenes"][0]["name"] = "sphere grid under a constant sky"
        doc["extras"] = {"strata": {"background": SKY}}
    return doc


def main():
    args = sys.argv[1:]
    sky = "--sky" in args
    args = [a for a in args if a != "--sky"]
    if len(args) > 1 or any(a.startswith("-") for a in args):
        sys.exit("usage: make_sphere_grid.py [--sky] [OUT.gltf]")
    default = "sphere-grid-sky.gltf" if sky else "sphere-grid.gltf"
    out = args[0] if args else os.path.join(REPO, "scenes", default)
    with open(out, "w") as f:
        json.dump(build(sky), f, indent=1)
        f.write("\n")
    print(out)


if __name__ == "__main__":
    main()
