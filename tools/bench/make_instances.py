#!/usr/bin/env python3
"""Writes a glTF scene of one geodesic sphere placed COUNT times by EXT_mesh_gpu_instancing
(translations on a square grid 2.5 units apart, seen from above at an angle), for measuring
instancing against the flattened copy (tools/bench/instances.sh).

The sphere is an octahedron subdivided SUBDIVISIONS times (8 * 4^SUBDIVISIONS triangles,
vertices shared), its vertices pushed onto the unit sphere, with vertex normals.

Usage: make_instances.py OUT.gltf COUNT [SUBDIVISIONS]  (writes OUT.bin beside it)
"""
import json
import math
import struct
import sys
from pathlib import Path


def sphere(subdivisions):
    x, y, z = (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)
    neg = lambda v: tuple(-c for c in v)
    # Outward, counter-clockwise seen from outside.
    faces = [
        (x, y, z), (y, neg(x), z), (neg(x), neg(y), z), (neg(y), x, z),
        (y, x, neg(z)), (neg(x), y, neg(z)), (neg(y), neg(x), neg(z)), (x, neg(y), neg(z)),
    ]
    unit = lambda v: tuple(c / math.sqrt(sum(d * d for d in v)) for c in v)
    mid = lambda a, b: unit(tuple((p + q) / 2 for p, q in zip(a, b)))
    for _ in range(subdivisions):
        faces = [
            f
            for a, b, c in faces
            for f in (
                (a, mid(a, b), mid(c, a)),
                (mid(a, b), b, mid(b, c)),
                (mid(c, a), mid(b, c), c),
                (mid(a, b), mid(b, c), mid(c, a)),
            )
        ]
    index = {}
    vertices = []
    triangles = []
    for f in faces:
        tri = []
        for v in f:
            key = tuple(round(c, 12) for c in v)
            if key not in index:
                index[key] = len(vertices)
                vertices.append(v)
            tri.append(index[key])
        triangles.append(tri)
    return vertices, triangles


def main():
    out = Path(sys.argv[1])
    count = int(sys.argv[2])
    subdivisions = int(sys.argv[3]) if len(sys.argv) > 3 else 6
    vertices, triangles = sphere(subdivisions)
    side = math.ceil(math.sqrt(count))
    translations = [
        (2.5 * (k % side) - 1.25 * side, 0.0, -2.5 * (k // side)) for k in range(count)
    ]
    parts = [
        b"".join(struct.pack("<3f", *v) for v in vertices),
        b"".join(struct.pack("<3f", *v) for v in vertices),
        b"".join(struct.pack("<3I", *t) for t in triangles),
        b"".join(struct.pack("<3f", *t) for t in translations),
    ]
    views, blob = [], b""
    for p in parts:
        views.append({"buffer": 0, "byteOffset": len(blob), "byteLength": len(p)})
        blob += p
    out.with_suffix(".bin").write_bytes(blob)
    doc = {
        "asset": {"version": "2.0"},
        "extensionsUsed": ["EXT_mesh_gpu_instancing"],
        "extensionsRequired": ["EXT_mesh_gpu_instancing"],
        "scene": 0,
        "scenes": [{"nodes": [0, 1]}],
        "nodes": [
            {"mesh": 0, "extensions": {"EXT_mesh_gpu_instancing": {"attributes": {"TRANSLATION": 3}}}},
            # 15 degrees down, above the grid's near edge.
            {"camera": 0, "translation": [0.0, 12.0, 8.0], "rotation": [-0.2588, 0.0, 0.0, 0.9659]},
        ],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.01}}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1}, "indices": 2}]}],
        "buffers": [{"byteLength": len(blob), "uri": out.with_suffix(".bin").name}],
        "bufferViews": views,
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": len(vertices), "type": "VEC3",
             "min": [-1.0, -1.0, -1.0], "max": [1.0, 1.0, 1.0]},
            {"bufferView": 1, "componentType": 5126, "count": len(vertices), "type": "VEC3"},
            {"bufferView": 2, "componentType": 5125, "count": 3 * len(triangles), "type": "SCALAR"},
            {"bufferView": 3, "componentType": 5126, "count": count, "type": "VEC3"},
        ],
    }
    out.write_text(json.dumps(doc))


if __name__ == "__main__":
    main()
