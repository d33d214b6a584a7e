"""A camera for a camera-less glTF model, written into a copy that strata and Blender both load.

    python3 tools/peers/khronos_scene.py MODEL.gltf|.glb OUT.glb [--width 400] [--wide-width W]
        [--framing box|sphere]

Writes OUT.glb: the model (every buffer and image of a .gltf folded into the GLB's binary
chunk, so the copy stands alone) plus one perspective camera node added to the default scene.
Prints the render resolution "WxH" on stdout.

The camera is strata's camera for files without one (`Camera::framing`, src/scene/camera.rs):
it looks down -Z (from +Z, +Y up) with a 45 degree vertical field of view, at the centre of
the bounds of every vertex of the default scene in world space. Its distance:
- `--framing sphere`: strata's own rule: the bounding sphere of the box fits in the smaller
  of the two fields of view (distance = radius / sin(half fov)). Rendering OUT.glb is then the
  same as rendering MODEL without a camera.
- `--framing box` (default): the box's front face (z = max z) fits in both fields of view,
  with a 4 % margin, which frames long flat models (AlphaBlendModeTest is 3.6 times wider
  than tall) far tighter than a sphere does. Everything behind the front face lies inside
  its image, because the camera looks straight down -Z at the box's centre line.
The aspect ratio of the image is the box's width / height, clamped to [0.75, 3]; the width is
--width, or --wide-width for an image at least twice as wide as tall; the height is rounded to
an even number of pixels.

A model with one camera of its own (TransmissionTest) is copied with that camera and nothing
added, at the camera's aspect ratio (4:3 where it gives none) and --width.
"""
import argparse
import base64
import json
import math
import os
import struct
import sys

import numpy

GLB_MAGIC, JSON_CHUNK, BIN_CHUNK = 0x46546C67, 0x4E4F534A, 0x004E4942
YFOV = math.radians(45.0)
MARGIN = 1.04


def read_model(path):
    """(glTF JSON, binary chunk bytes) with every buffer of a .gltf folded into one."""
    raw = open(path, "rb").read()
    if raw[:4] == b"glTF":
        _, _, length = struct.unpack_from("<III", raw, 0)
        doc, binary, off = None, b"", 12
        while off < length:
            size, kind = struct.unpack_from("<II", raw, off)
            chunk = raw[off + 8:off + 8 + size]
            if kind == JSON_CHUNK:
                doc = json.loads(chunk)
            elif kind == BIN_CHUNK:
                binary = bytes(chunk)
            off += 8 + size
        return doc, binary
    doc = json.loads(raw)
    base = os.path.dirname(os.path.abspath(path))

    def load(uri):
        if uri.startswith("data:"):
            return base64.b64decode(uri.split(",", 1)[1])
        from urllib.parse import unquote
        return open(os.path.join(base, unquote(uri)), "rb").read()

    blob = bytearray()
    starts = []
    for buf in doc.get("buffers", []):
        blob.extend(b"\0" * (-len(blob) % 16))  # keep every accessor's alignment
        starts.append(len(blob))
        blob.extend(load(buf["uri"])[:buf["byteLength"]])
    for view in doc.get("bufferViews", []):
        view["byteOffset"] = view.get("byteOffset", 0) + starts[view["buffer"]]
        view["buffer"] = 0
    for image in doc.get("images", []):  # external images become buffer views too
        if "uri" in image:
            data = load(image["uri"])
            blob.extend(b"\0" * (-len(blob) % 16))
            doc.setdefault("bufferViews", []).append({"buffer": 0, "byteOffset": len(blob), "byteLength": len(data)})
            blob.extend(data)
            ext = image["uri"].lower().rsplit(".", 1)[-1]
            image["mimeType"] = image.get("mimeType", "image/png" if ext == "png" else "image/jpeg")
            image["bufferView"] = len(doc["bufferViews"]) - 1
            del image["uri"]
    if blob:
        doc["buffers"] = [{"byteLength": len(blob)}]
    return doc, bytes(blob)


def write_glb(path, doc, binary):
    js = json.dumps(doc, separators=(",", ":")).encode()
    js += b" " * (-len(js) % 4)
    binary += b"\0" * (-len(binary) % 4)
    chunks = struct.pack("<II", len(js), JSON_CHUNK) + js
    if binary:
        chunks += struct.pack("<II", len(binary), BIN_CHUNK) + binary
    tmp = path + ".tmp"
    with open(tmp, "wb") as f:
        f.write(struct.pack("<III", GLB_MAGIC, 2, 12 + len(chunks)) + chunks)
    os.replace(tmp, path)


def local_matrix(node):
    if "matrix" in node:
        return numpy.array(node["matrix"], dtype=numpy.float64).reshape(4, 4).T  # column-major
    t = node.get("translation", [0, 0, 0])
    x, y, z, w = node.get("rotation", [0, 0, 0, 1])
    s = node.get("scale", [1, 1, 1])
    r = numpy.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])
    m = numpy.eye(4)
    m[:3, :3] = r * numpy.array(s)
    m[:3, 3] = t
    return m


def positions(doc, binary, index):
    acc = doc["accessors"][index]
    if acc.get("sparse") or acc["componentType"] != 5126 or acc["type"] != "VEC3":
        sys.exit("khronos_scene: only plain float VEC3 positions are read")
    view = doc["bufferViews"][acc["bufferView"]]
    start = view.get("byteOffset", 0) + acc.get("byteOffset", 0)
    stride = view.get("byteStride", 12)
    rows = numpy.frombuffer(binary, dtype=numpy.uint8, count=stride * (acc["count"] - 1) + 12, offset=start)
    rows = numpy.lib.stride_tricks.as_strided(rows, shape=(acc["count"], 12), strides=(stride, 1))
    return numpy.ascontiguousarray(rows).view("<f4").reshape(-1, 3).astype(numpy.float64)


def world_bounds(doc, binary):
    """Bounds of every vertex of the default scene's meshes, in world space (strata's Scene::bounds)."""
    scene = doc["scenes"][doc.get("scene", 0)]
    lo, hi = numpy.full(3, numpy.inf), numpy.full(3, -numpy.inf)
    stack = [(n, numpy.eye(4)) for n in scene["nodes"]]
    while stack:
        index, parent = stack.pop()
        node = doc["nodes"][index]
        world = parent @ local_matrix(node)
        if "mesh" in node:
            for prim in doc["meshes"][node["mesh"]]["primitives"]:
                p = positions(doc, binary, prim["attributes"]["POSITION"])
                p = p @ world[:3, :3].T + world[:3, 3]
                lo, hi = numpy.minimum(lo, p.min(axis=0)), numpy.maximum(hi, p.max(axis=0))
        stack.extend((c, world) for c in node.get("children", []))
    return lo, hi


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("model")
    ap.add_argument("out")
    ap.add_argument("--width", type=int, default=400)
    ap.add_argument("--wide-width", type=int, help="the width instead when the image is at least twice as wide as tall")
    ap.add_argument("--framing", choices=["box", "sphere"], default="box")
    args = ap.parse_args()

    doc, binary = read_model(args.model)
    cameras = doc.get("cameras", [])
    if len(cameras) > 1:
        sys.exit(f"khronos_scene: {args.model} has {len(cameras)} cameras; this script takes one")
    if cameras:
        # The model's own camera (TransmissionTest): both renderers use it as it is, at its
        # aspect ratio (4:3 where it gives none).
        aspect = cameras[0].get("perspective", {}).get("aspectRatio") or 4 / 3
        write_glb(args.out, doc, binary)
        print(f"khronos_scene: {args.model}'s own camera, aspect ratio {aspect:.4f}", file=sys.stderr)
        print(f"{args.width}x{2 * round(args.width / aspect / 2)}")
        return
    lo, hi = world_bounds(doc, binary)
    size = hi - lo
    aspect = min(3.0, max(0.75, size[0] / max(size[1], 1e-9)))
    width = args.wide_width if args.wide_width and aspect >= 2 else args.width
    height = 2 * round(width / aspect / 2)
    aspect = width / height  # the one the renderers will see
    centre = 0.5 * (lo + hi)
    half_v = 0.5 * YFOV
    half_h = math.atan(math.tan(half_v) * aspect)
    if args.framing == "sphere":  # Camera::framing
        radius = max(0.5 * float(numpy.linalg.norm(size)), 1e-6)
        eye = centre + [0, 0, radius / math.sin(min(half_v, half_h))]
    else:
        d = MARGIN * max(0.5 * size[1] / math.tan(half_v), 0.5 * size[0] / math.tan(half_h))
        eye = [centre[0], centre[1], hi[2] + d]
    doc.setdefault("cameras", []).append({"type": "perspective", "name": f"{args.framing} framing",
                                          "perspective": {"yfov": YFOV, "znear": 1e-4 * float(numpy.linalg.norm(size))}})
    doc["nodes"].append({"name": "khronos_scene camera", "camera": len(doc["cameras"]) - 1,
                         "translation": [float(v) for v in eye]})
    doc["scenes"][doc.get("scene", 0)]["nodes"].append(len(doc["nodes"]) - 1)
    write_glb(args.out, doc, binary)
    print(f"khronos_scene: bounds {lo.round(4).tolist()} .. {hi.round(4).tolist()}, camera at "
          f"{[round(float(v), 4) for v in eye]} ({args.framing} framing)", file=sys.stderr)
    print(f"{width}x{height}")


main()
