#!/usr/bin/env python3
"""Writes a copy of a glTF file with one more perspective camera, as a new root node.

The copy references the original's buffers and images by relative URI (rewritten to stay
valid from the copy's folder), so large binaries are not duplicated. Usage:

    add_camera.py IN.gltf OUT.gltf --eye X,Y,Z --target X,Y,Z [--yfov RAD] [--aspect A]

The camera looks from `eye` toward `target` with +Y up (glTF cameras look down local -Z).
"""
import argparse
import json
import math
import os
import posixpath


def vec(text):
    v = [float(x) for x in text.split(",")]
    if len(v) != 3:
        raise argparse.ArgumentTypeError("expected X,Y,Z")
    return v


def look_at_quaternion(eye, target):
    """Rotation (x, y, z, w) taking local -Z to the view direction and local +Y toward world +Y."""
    f = [t - e for t, e in zip(target, eye)]
    n = math.sqrt(sum(c * c for c in f))
    f = [c / n for c in f]
    back = [-c for c in f]  # local +Z
    up = [0.0, 1.0, 0.0]
    right = [up[1] * back[2] - up[2] * back[1], up[2] * back[0] - up[0] * back[2], up[0] * back[1] - up[1] * back[0]]
    rn = math.sqrt(sum(c * c for c in right))
    right = [c / rn for c in right]
    true_up = [back[1] * right[2] - back[2] * right[1], back[2] * right[0] - back[0] * right[2], back[0] * right[1] - back[1] * right[0]]
    # Columns of the rotation matrix: right, true_up, back.
    m = [[right[0], true_up[0], back[0]], [right[1], true_up[1], back[1]], [right[2], true_up[2], back[2]]]
    trace = m[0][0] + m[1][1] + m[2][2]
    if trace > 0:
        s = 0.5 / math.sqrt(trace + 1.0)
        return [(m[2][1] - m[1][2]) * s, (m[0][2] - m[2][0]) * s, (m[1][0] - m[0][1]) * s, 0.25 / s]
    i = max(range(3), key=lambda k: m[k][k])
    j, k = (i + 1) % 3, (i + 2) % 3
    s = 2.0 * math.sqrt(1.0 + m[i][i] - m[j][j] - m[k][k])
    q = [0.0, 0.0, 0.0, 0.0]
    q[i] = 0.25 * s
    q[j] = (m[j][i] + m[i][j]) / s
    q[k] = (m[k][i] + m[i][k]) / s
    q[3] = (m[k][j] - m[j][k]) / s
    return q


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("input")
    ap.add_argument("output")
    ap.add_argument("--eye", type=vec, required=True)
    ap.add_argument("--target", type=vec, required=True)
    ap.add_argument("--yfov", type=float, default=math.radians(40))
    ap.add_argument("--aspect", type=float, default=4 / 3)
    args = ap.parse_args()

    with open(args.input) as f:
        doc = json.load(f)
    rel = os.path.relpath(os.path.dirname(os.path.abspath(args.input)), os.path.dirname(os.path.abspath(args.output)))
    rel = rel.replace(os.sep, "/")
    for item in doc.get("buffers", []) + doc.get("images", []):
        uri = item.get("uri")
        if uri and not uri.startswith("data:") and rel != ".":
            item["uri"] = posixpath.join(rel, uri)
    doc.setdefault("cameras", []).append(
        {"type": "perspective", "perspective": {"yfov": args.yfov, "aspectRatio": args.aspect, "znear": 0.01}}
    )
    doc.setdefault("nodes", []).append(
        {"name": "strata camera", "camera": len(doc["cameras"]) - 1, "translation": args.eye,
         "rotation": look_at_quaternion(args.eye, args.target)}
    )
    scene = doc["scenes"][doc.get("scene", 0)]
    scene["nodes"] = [len(doc["nodes"]) - 1] + scene["nodes"]
    doc["asset"]["generator"] = doc["asset"].get("generator", "") + " + strata tools/scenes/add_camera.py"
    with open(args.output, "w") as f:
        json.dump(doc, f, indent=1)
        f.write("\n")


if __name__ == "__main__":
    main()
