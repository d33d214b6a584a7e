#!/usr/bin/env python3
"""Writes one scene twice, as OBJ + MTL (for Embree's tutorial renderers) and as glTF (for
strata): a tessellated sphere resting on a square plane, both diffuse grey, seen by one
camera. The two files hold the same triangles in the same order, so the renderers trace the
same geometry.

Usage:

    make_sphere_plane.py OUT_DIR [--rings N] [--albedo A]

OUT_DIR receives sphere_plane.obj, sphere_plane.mtl, sphere_plane.gltf and sphere_plane.bin
and prints the camera arguments for Embree's tutorials. The sphere (centre (0, 1, 0),
radius 1) has N rings of 2N segments, 4N(N - 1) triangles (N = 500: 998 000); the plane
(y = 0, 20 × 20 units) has two. Standard library only.
"""
import argparse
import json
import math
import os
import struct

EYE = (0.0, 1.6, 4.0)
TARGET = (0.0, 0.8, 0.0)
YFOV_DEG = 45.0


def sphere(rings):
    """Latitude-longitude sphere: poles are single vertices, so no degenerate triangles."""
    seg = 2 * rings
    verts = [(0.0, 2.0, 0.0)]
    for i in range(1, rings):
        theta = math.pi * i / rings
        y = 1.0 + math.cos(theta)
        r = math.sin(theta)
        for j in range(seg):
            phi = 2.0 * math.pi * j / seg
            verts.append((r * math.cos(phi), y, -r * math.sin(phi)))
    verts.append((0.0, 0.0, 0.0))
    south = len(verts) - 1

    def ring(i, j):
        return 1 + (i - 1) * seg + (j % seg)

    tris = []
    for j in range(seg):  # north cap, counter-clockwise seen from outside
        tris.append((0, ring(1, j), ring(1, j + 1)))
    for i in range(1, rings - 1):
        for j in range(seg):
            a, b = ring(i, j), ring(i, j + 1)
            c, d = ring(i + 1, j), ring(i + 1, j + 1)
            tris.append((a, c, d))
            tris.append((a, d, b))
    for j in range(seg):  # south cap
        tris.append((south, ring(rings - 1, j + 1), ring(rings - 1, j)))
    return verts, tris


def look_at_matrix(eye, target):
    """Column-major 4×4 camera-to-world matrix; the glTF camera looks down its local -Z."""
    f = [t - e for t, e in zip(target, eye)]
    n = math.sqrt(sum(c * c for c in f))
    f = [c / n for c in f]
    up = (0.0, 1.0, 0.0)
    s = [f[1] * up[2] - f[2] * up[1], f[2] * up[0] - f[0] * up[2], f[0] * up[1] - f[1] * up[0]]
    n = math.sqrt(sum(c * c for c in s))
    s = [c / n for c in s]
    u = [s[1] * f[2] - s[2] * f[1], s[2] * f[0] - s[0] * f[2], s[0] * f[1] - s[1] * f[0]]
    back = [-c for c in f]
    return s + [0.0] + u + [0.0] + back + [0.0] + list(eye) + [1.0]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out_dir")
    ap.add_argument("--rings", type=int, default=500)
    ap.add_argument("--albedo", type=float, default=0.5)
    args = ap.parse_args()
    if args.rings < 2:
        raise SystemExit("--rings must be at least 2")
    os.makedirs(args.out_dir, exist_ok=True)

    verts, tris = sphere(args.rings)
    base = len(verts)
    verts += [(-10.0, 0.0, -10.0), (10.0, 0.0, -10.0), (10.0, 0.0, 10.0), (-10.0, 0.0, 10.0)]
    tris += [(base, base + 3, base + 2), (base, base + 2, base + 1)]  # facing +y

    stem = os.path.join(args.out_dir, "sphere_plane")
    a = args.albedo
    with open(stem + ".mtl", "w") as f:
        f.write(f"newmtl grey\nKd {a} {a} {a}\nKs 0 0 0\nd 1\n")
    with open(stem + ".obj", "w") as f:
        f.write("mtllib sphere_plane.mtl\nusemtl grey\n")
        f.writelines(f"v {x:.7g} {y:.7g} {z:.7g}\n" for x, y, z in verts)
        f.writelines(f"f {i + 1} {j + 1} {k + 1}\n" for i, j, k in tris)

    pos = struct.pack(f"<{3 * len(verts)}f", *(c for v in verts for c in v))
    idx = struct.pack(f"<{3 * len(tris)}I", *(i for t in tris for i in t))
    with open(stem + ".bin", "wb") as f:
        f.write(pos + idx)
    lo = [min(v[k] for v in verts) for k in range(3)]
    hi = [max(v[k] for v in verts) for k in range(3)]
    gltf = {
        "asset": {"version": "2.0", "generator": "strata tools/bench/make_sphere_plane.py"},
        "scene": 0,
        "scenes": [{"nodes": [0, 1]}],
        "nodes": [{"mesh": 0}, {"camera": 0, "matrix": look_at_matrix(EYE, TARGET)}],
        "cameras": [{"type": "perspective", "perspective": {
            "yfov": math.radians(YFOV_DEG), "aspectRatio": 1.0, "znear": 0.01}}],
        "materials": [{"name": "grey", "pbrMetallicRoughness": {
            "baseColorFactor": [a, a, a, 1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0}}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1, "material": 0}]}],
        "buffers": [{"uri": "sphere_plane.bin", "byteLength": len(pos) + len(idx)}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": len(pos), "target": 34962},
            {"buffer": 0, "byteOffset": len(pos), "byteLength": len(idx), "target": 34963},
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": len(verts), "type": "VEC3",
             "min": lo, "max": hi},
            {"bufferView": 1, "componentType": 5125, "count": 3 * len(tris), "type": "SCALAR"},
        ],
    }
    with open(stem + ".gltf", "w") as f:
        json.dump(gltf, f, indent=1)
    print(f"{len(tris)} triangles")
    print("embree camera: --vp {} {} {} --vi {} {} {} --vu 0 1 0 --fov {}".format(
        *EYE, *TARGET, YFOV_DEG))


if __name__ == "__main__":
    main()
