#!/usr/bin/env python3
"""Writes scenes/animated-box.gltf: a box that spins, hops and grows over a floor, for the
animation frames (render --frame/--frames) and the farm's Slurm leg.

Animation 0 ("hop", 2 s): the box turns a full circle about +Y (rotation, LINEAR: five key
frames 90 degrees apart, so each slerp takes the intended arc), hops once (translation,
CUBICSPLINE: y from 0.5 up to 1.5 at 1 s and back, zero tangents at the ground, so it eases
out and in) and grows by a quarter at 1 s (scale, STEP). Lit by a 2 x 2 emissive square
above; camera included; render at 160 x 120 (4:3). Standard library only.
"""

import base64
import json
import math
import struct
import sys
from pathlib import Path

OUT = Path(__file__).resolve().parents[2] / "scenes" / "animated-box.gltf"


def pack(fmt, values):
    return struct.pack("<" + fmt * len(values), *values)


def box(h):
    """A cube of half-size h: 24 vertices (flat normals), 36 indices, counter-clockwise."""
    pos, nrm, idx = [], [], []
    for axis in range(3):
        for sign in (1.0, -1.0):
            n = [0.0, 0.0, 0.0]
            n[axis] = sign
            u, v = (axis + 1) % 3, (axis + 2) % 3
            base = len(pos)
            for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
                p = [0.0, 0.0, 0.0]
                p[axis] = sign * h
                p[u] = a * h
                p[v] = b * h
                pos.append(p)
                nrm.append(n)
            quad = [0, 1, 2, 0, 2, 3] if sign > 0 else [0, 2, 1, 0, 3, 2]
            idx += [base + q for q in quad]
    return pos, nrm, idx


def quad(y, half, down):
    """A square in the plane y, facing down (-Y) or up (+Y)."""
    pos = [[-half, y, -half], [half, y, -half], [half, y, half], [-half, y, half]]
    n = [0.0, -1.0 if down else 1.0, 0.0]
    idx = [0, 1, 2, 0, 2, 3] if down else [0, 2, 1, 0, 3, 2]
    return pos, [n] * 4, idx


def main():
    bin_ = bytearray()
    views, accessors = [], []

    def add(data, count, typ, ctype=5126, minmax=None):
        views.append({"buffer": 0, "byteOffset": len(bin_), "byteLength": len(data)})
        bin_.extend(data)
        while len(bin_) % 4:
            bin_.append(0)
        a = {"bufferView": len(views) - 1, "componentType": ctype, "count": count, "type": typ}
        if minmax:
            a["min"], a["max"] = minmax
        accessors.append(a)
        return len(accessors) - 1

    def mesh(pos, nrm, idx):
        flat = [c for p in pos for c in p]
        lo = [min(p[k] for p in pos) for k in range(3)]
        hi = [max(p[k] for p in pos) for k in range(3)]
        p = add(pack("f", flat), len(pos), "VEC3", minmax=(lo, hi))
        n = add(pack("f", [c for v in nrm for c in v]), len(nrm), "VEC3")
        i = add(pack("I", idx), len(idx), "SCALAR", ctype=5125)
        return p, n, i

    meshes = []
    for (pos, nrm, idx), material in ((box(0.5), 0), (quad(0.0, 4.0, False), 1), (quad(3.0, 1.0, True), 2)):
        p, n, i = mesh(pos, nrm, idx)
        meshes.append({"primitives": [{"attributes": {"POSITION": p, "NORMAL": n}, "indices": i, "material": material}]})

    # Animation data.
    t5 = add(pack("f", [0.0, 0.5, 1.0, 1.5, 2.0]), 5, "SCALAR", minmax=([0.0], [2.0]))
    rot = []
    for k in range(5):
        half = k * math.pi / 4  # (k * 90 degrees) / 2
        rot += [0.0, math.sin(half), 0.0, math.cos(half)]
    r = add(pack("f", rot), 5, "VEC4")
    t3 = add(pack("f", [0.0, 1.0, 2.0]), 3, "SCALAR", minmax=([0.0], [2.0]))
    # CUBICSPLINE: (in-tangent, value, out-tangent) per key frame; zero tangents at the top,
    # launch and landing speeds of 2 units/s (twice the mean: the hop eases to its top).
    spline = [
        [0, 0, 0], [0, 0.5, 0], [0, 2.0, 0],
        [0, 0, 0], [0, 1.5, 0], [0, 0, 0],
        [0, -2.0, 0], [0, 0.5, 0], [0, 0, 0],
    ]
    tr = add(pack("f", [c for v in spline for c in v]), 9, "VEC3")
    t2 = add(pack("f", [0.0, 1.0]), 2, "SCALAR", minmax=([0.0], [1.0]))
    sc = add(pack("f", [1.0, 1.0, 1.0, 1.25, 1.25, 1.25]), 2, "VEC3")

    doc = {
        "asset": {"version": "2.0", "generator": "strata tools/scenes/make_animated_box.py"},
        "scene": 0,
        "scenes": [{"nodes": [0, 1, 2, 3]}],
        "nodes": [
            {"name": "box", "mesh": 0, "translation": [0.0, 0.5, 0.0]},
            {"name": "floor", "mesh": 1},
            {"name": "light", "mesh": 2},
            {"name": "camera", "camera": 0, "translation": [0.0, 2.0, 5.0],
             "rotation": [-math.sin(0.15), 0.0, 0.0, math.cos(0.15)]},
        ],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.7, "aspectRatio": 4 / 3, "znear": 0.1}}],
        "meshes": meshes,
        "materials": [
            {"name": "box", "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.3, 0.1, 1], "metallicFactor": 0, "roughnessFactor": 0.5}},
            {"name": "floor", "pbrMetallicRoughness": {"baseColorFactor": [0.6, 0.6, 0.6, 1], "metallicFactor": 0, "roughnessFactor": 1}},
            {"name": "light", "emissiveFactor": [1, 1, 1], "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 8}},
             "pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1]}},
        ],
        "extensionsUsed": ["KHR_materials_emissive_strength"],
        "animations": [{
            "name": "hop",
            "samplers": [
                {"input": t5, "output": r, "interpolation": "LINEAR"},
                {"input": t3, "output": tr, "interpolation": "CUBICSPLINE"},
                {"input": t2, "output": sc, "interpolation": "STEP"},
            ],
            "channels": [
                {"sampler": 0, "target": {"node": 0, "path": "rotation"}},
                {"sampler": 1, "target": {"node": 0, "path": "translation"}},
                {"sampler": 2, "target": {"node": 0, "path": "scale"}},
            ],
        }],
        "buffers": [{"byteLength": len(bin_), "uri": "data:application/octet-stream;base64," + base64.b64encode(bin_).decode()}],
        "bufferViews": views,
        "accessors": accessors,
    }
    OUT.write_text(json.dumps(doc, indent=1) + "\n")
    print(f"wrote {OUT}", file=sys.stderr)


if __name__ == "__main__":
    main()
