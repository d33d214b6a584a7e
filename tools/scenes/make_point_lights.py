#!/usr/bin/env python3
"""Writes scenes/point-lights.gltf: a floor, a back wall and four diffuse boxes lit only by
three KHR_lights_punctual point lights (no emissive surfaces, black background).

Standard library only; the buffer is embedded as a base64 data URI and the output is the
same bytes on every run. After writing, the file is re-read and checked (accessor bounds,
POSITION min/max, counter-clockwise winding agrees with the normals of every triangle in
world space).

    python3 tools/scenes/make_point_lights.py [OUT.gltf]     # default <repo>/scenes/point-lights.gltf

Units are metres. Light intensities are glTF candela, i.e. radiant intensity
I = color x intensity in strata's radiometric convention (no 4pi or 683 factors).
Every material is Lambertian (metallic 0, roughness 1); the scene is meant for direct
lighting (strata `--integrator direct`, POV-Ray) as well as path tracing.
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

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

# name, base colour, translation (of the box's bottom centre), yaw in degrees, size (x, y, z)
BOXES = [
    ("tall white box", [0.75, 0.75, 0.75], [-1.5, 0.0, -1.2], 20.0, [0.8, 1.8, 0.8]),
    ("red cube", [0.70, 0.12, 0.08], [0.5, 0.0, -0.5], -15.0, [0.9, 0.9, 0.9]),
    ("blue slab", [0.10, 0.20, 0.65], [2.0, 0.0, 0.7], 10.0, [1.4, 0.4, 0.7]),
    ("yellow block", [0.80, 0.70, 0.15], [-0.4, 0.0, 1.3], 40.0, [0.5, 0.6, 0.5]),
]
# name, colour, intensity (cd), position
LIGHTS = [
    ("warm key", [1.0, 0.85, 0.7], 30.0, [-2.2, 3.2, 1.8]),
    ("cool fill", [0.6, 0.75, 1.0], 20.0, [2.6, 2.4, 2.2]),
    ("green rim", [0.4, 1.0, 0.5], 4.0, [0.6, 1.2, -1.9]),
]
CAMERA = {"eye": [0.0, 2.4, 6.3], "target": [0.2, 0.6, -0.5], "yfov": 0.7, "aspect": 4.0 / 3.0}
FLOOR = ([0.6, 0.6, 0.6], (-6.0, 6.0), (-3.0, 6.0))  # colour, x range, z range (y = 0)
WALL = ([0.55, 0.55, 0.5], (-6.0, 6.0), (0.0, 5.0))  # colour, x range, y range (z = -3)


class Builder:
    def __init__(self):
        self.data = bytearray()
        self.views = []
        self.accessors = []

    def _view(self, payload, target):
        while len(self.data) % 4:
            self.data.append(0)
        self.views.append({"buffer": 0, "byteOffset": len(self.data), "byteLength": len(payload), "target": target})
        self.data += payload
        return len(self.views) - 1

    def vec3(self, values):
        payload = b"".join(struct.pack("<3f", *v) for v in values)
        f32 = [struct.unpack("<3f", struct.pack("<3f", *v)) for v in values]
        view = self._view(payload, 34962)
        self.accessors.append({
            "bufferView": view, "componentType": 5126, "count": len(values), "type": "VEC3",
            "min": [min(v[i] for v in f32) for i in range(3)], "max": [max(v[i] for v in f32) for i in range(3)],
        })
        return len(self.accessors) - 1

    def indices(self, values):
        payload = struct.pack(f"<{len(values)}H", *values)
        view = self._view(payload, 34963)
        self.accessors.append({"bufferView": view, "componentType": 5123, "count": len(values), "type": "SCALAR"})
        return len(self.accessors) - 1


def quad(corners, normal):
    """Four corners in counter-clockwise order seen from the side `normal` points to."""
    return corners, [normal] * 4, [0, 1, 2, 0, 2, 3]


def unit_box():
    """The box [-0.5, 0.5] x [0, 1] x [-0.5, 0.5], 24 vertices with flat normals, CCW outward."""
    pos, nrm, idx = [], [], []
    for axis in range(3):
        for sign in (-1.0, 1.0):
            n = [0.0, 0.0, 0.0]
            n[axis] = sign
            u_axis, v_axis = (axis + 1) % 3, (axis + 2) % 3
            base = len(pos)
            for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
                p = [0.0, 0.0, 0.0]
                p[axis] = 0.5 * sign
                p[u_axis] = 0.5 * a
                p[v_axis] = 0.5 * b
                p[1] += 0.5  # bottom at y = 0
                pos.append(p)
                nrm.append(n)
            # (u, v, n) is right-handed, so (-1,-1),(1,-1),(1,1) is CCW seen from +n; flip for -n.
            tri = [0, 1, 2, 0, 2, 3] if sign > 0 else [0, 2, 1, 0, 3, 2]
            idx += [base + t for t in tri]
    return pos, nrm, idx


def yaw_quaternion(deg):
    h = math.radians(deg) / 2
    return [0.0, math.sin(h), 0.0, math.cos(h)]


def build():
    b = Builder()
    materials, meshes, nodes = [], [], []

    def material(name, color):
        materials.append({"name": name, "pbrMetallicRoughness": {
            "baseColorFactor": color + [1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0}})
        return len(materials) - 1

    def mesh(name, pos_acc, nrm_acc, idx_acc, mat):
        meshes.append({"name": name, "primitives": [{
            "attributes": {"POSITION": pos_acc, "NORMAL": nrm_acc}, "indices": idx_acc, "material": mat, "mode": 4}]})
        return len(meshes) - 1

    (x0, x1), (z0, z1) = FLOOR[1], FLOOR[2]
    p, n, i = quad([[x0, 0, z1], [x1, 0, z1], [x1, 0, z0], [x0, 0, z0]], [0.0, 1.0, 0.0])
    m = mesh("floor", b.vec3(p), b.vec3(n), b.indices(i), material("floor", FLOOR[0]))
    nodes.append({"name": "floor", "mesh": m})
    (x0, x1), (y0, y1) = WALL[1], WALL[2]
    p, n, i = quad([[x0, y0, -3.0], [x1, y0, -3.0], [x1, y1, -3.0], [x0, y1, -3.0]], [0.0, 0.0, 1.0])
    m = mesh("back wall", b.vec3(p), b.vec3(n), b.indices(i), material("back wall", WALL[0]))
    nodes.append({"name": "back wall", "mesh": m})

    p, n, i = unit_box()
    box_pos, box_nrm, box_idx = b.vec3(p), b.vec3(n), b.indices(i)
    for name, color, t, yaw, size in BOXES:
        m = mesh(name, box_pos, box_nrm, box_idx, material(name, color))
        nodes.append({"name": name, "mesh": m, "translation": t, "rotation": yaw_quaternion(yaw), "scale": size})

    lights = []
    for name, color, intensity, pos in LIGHTS:
        lights.append({"name": name, "type": "point", "color": color, "intensity": intensity})
        nodes.append({"name": name, "translation": pos, "extensions": {"KHR_lights_punctual": {"light": len(lights) - 1}}})

    cam = CAMERA
    nodes.insert(0, {"name": "camera", "camera": 0, "translation": cam["eye"],
                     "rotation": look_at_quaternion(cam["eye"], cam["target"])})
    doc = {
        "asset": {"version": "2.0", "generator": "strata tools/scenes/make_point_lights.py"},
        "extensionsUsed": ["KHR_lights_punctual"],
        "extensions": {"KHR_lights_punctual": {"lights": lights}},
        "scene": 0,
        "scenes": [{"name": "point lights", "nodes": list(range(len(nodes)))}],
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


# ---- verification -------------------------------------------------------------------------

def quat_matrix(q):
    x, y, z, w = q
    return [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]


def verify(path):
    with open(path) as f:
        doc = json.load(f)
    uri = doc["buffers"][0]["uri"]
    data = base64.b64decode(uri.split(",", 1)[1])
    assert len(data) == doc["buffers"][0]["byteLength"]

    def read(ai):
        a = doc["accessors"][ai]
        v = doc["bufferViews"][a["bufferView"]]
        assert v["byteOffset"] % 4 == 0 and v["byteOffset"] + v["byteLength"] <= len(data)
        if a["componentType"] == 5126:
            vals = [struct.unpack_from("<3f", data, v["byteOffset"] + 12 * k) for k in range(a["count"])]
            assert 12 * a["count"] <= v["byteLength"]
            if "min" in a:
                assert [min(p[i] for p in vals) for i in range(3)] == a["min"]
                assert [max(p[i] for p in vals) for i in range(3)] == a["max"]
            return vals
        vals = list(struct.unpack_from(f"<{a['count']}H", data, v["byteOffset"]))
        assert 2 * a["count"] <= v["byteLength"]
        return vals

    checked = 0
    for node in doc["nodes"]:
        if "mesh" not in node:
            continue
        r = quat_matrix(node.get("rotation", [0, 0, 0, 1]))
        s = node.get("scale", [1, 1, 1])
        t = node.get("translation", [0, 0, 0])
        for prim in doc["meshes"][node["mesh"]]["primitives"]:
            pos = read(prim["attributes"]["POSITION"])
            nrm = read(prim["attributes"]["NORMAL"])
            idx = read(prim["indices"])
            world = [[sum(r[i][j] * s[j] * p[j] for j in range(3)) + t[i] for i in range(3)] for p in pos]
            # normals: inverse transpose of R*S = R*S^-1
            wn = [[sum(r[i][j] * n[j] / s[j] for j in range(3)) for i in range(3)] for n in nrm]
            for k in range(0, len(idx), 3):
                a, b_, c = (world[q] for q in idx[k:k + 3])
                e1 = [b_[q] - a[q] for q in range(3)]
                e2 = [c[q] - a[q] for q in range(3)]
                cr = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]]
                for q in idx[k:k + 3]:
                    dot = sum(cr[i] * wn[q][i] for i in range(3))
                    assert dot > 0, f"{node['name']}: triangle {k // 3} winding disagrees with its normals"
                checked += 1
    assert checked == 2 + 2 + 12 * len(BOXES)
    for node in doc["nodes"]:
        if "extensions" in node:
            p = node["translation"]
            assert 0 < p[1] < 5 and -3 < p[2] < 6, "light outside the room"
    return checked


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else os.path.join(REPO, "scenes", "point-lights.gltf")
    doc = build()
    with open(out, "w") as f:
        json.dump(doc, f, indent=1)
        f.write("\n")
    n = verify(out)
    print(f"wrote {out}: {n} triangles checked")


if __name__ == "__main__":
    main()
