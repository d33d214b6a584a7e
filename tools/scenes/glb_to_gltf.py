#!/usr/bin/env python3
"""Converts a binary glTF (.glb) into a .gltf (JSON) plus one external .bin buffer.

Standard library only. The JSON and the binary chunk are copied unchanged, except that
buffer 0 (the GLB's BIN chunk) gets `"uri": "<OUT stem>.bin"` and, optionally, the winding
of listed primitives is flipped (see --flip-winding). The .gltf is written with stable
formatting (indent=1), so repeated runs give identical bytes.

    glb_to_gltf.py IN.glb OUT.gltf [--flip-winding MESH/PRIM ...]

--flip-winding MESH/PRIM swaps the 2nd and 3rd index of every triangle of primitive PRIM of
mesh MESH (indexed TRIANGLES with UNSIGNED_SHORT/UNSIGNED_INT indices only); use it only
when a primitive's counter-clockwise face points the wrong way, and say so in SOURCE.md.
"""
import argparse
import json
import os
import struct

GLB_MAGIC = 0x46546C67
CHUNK_JSON = 0x4E4F534A
CHUNK_BIN = 0x004E4942


def read_glb(path):
    with open(path, "rb") as f:
        data = f.read()
    magic, version, length = struct.unpack_from("<III", data, 0)
    if magic != GLB_MAGIC or version != 2:
        raise SystemExit(f"{path}: not a glTF 2.0 binary file")
    if length != len(data):
        raise SystemExit(f"{path}: header length {length} != file size {len(data)}")
    off = 12
    doc = None
    binary = None
    while off < length:
        clen, ctype = struct.unpack_from("<II", data, off)
        chunk = data[off + 8: off + 8 + clen]
        if ctype == CHUNK_JSON and doc is None:
            doc = json.loads(chunk.decode("utf-8"))
        elif ctype == CHUNK_BIN and binary is None:
            binary = bytearray(chunk)
        off += 8 + clen
    if doc is None:
        raise SystemExit(f"{path}: no JSON chunk")
    return doc, binary


def flip_winding(doc, binary, mesh_index, prim_index):
    prim = doc["meshes"][mesh_index]["primitives"][prim_index]
    if prim.get("mode", 4) != 4 or "indices" not in prim:
        raise SystemExit(f"mesh {mesh_index} primitive {prim_index}: only indexed TRIANGLES can be flipped")
    acc = doc["accessors"][prim["indices"]]
    view = doc["bufferViews"][acc["bufferView"]]
    if view.get("buffer", 0) != 0:
        raise SystemExit("indices not in the GLB's binary chunk")
    fmt = {5123: "H", 5125: "I"}.get(acc["componentType"])
    if fmt is None:
        raise SystemExit("indices must be UNSIGNED_SHORT or UNSIGNED_INT")
    size = struct.calcsize(fmt)
    base = view.get("byteOffset", 0) + acc.get("byteOffset", 0)
    for t in range(acc["count"] // 3):
        o1 = base + (3 * t + 1) * size
        o2 = base + (3 * t + 2) * size
        i1 = struct.unpack_from("<" + fmt, binary, o1)[0]
        i2 = struct.unpack_from("<" + fmt, binary, o2)[0]
        struct.pack_into("<" + fmt, binary, o1, i2)
        struct.pack_into("<" + fmt, binary, o2, i1)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("input")
    ap.add_argument("output")
    ap.add_argument("--flip-winding", action="append", default=[], metavar="MESH/PRIM")
    args = ap.parse_args()

    doc, binary = read_glb(args.input)
    buffers = doc.get("buffers", [])
    if binary is not None:
        if not buffers or "uri" in buffers[0]:
            raise SystemExit("GLB has a BIN chunk but buffer 0 is not the GLB-stored buffer")
        if buffers[0]["byteLength"] > len(binary):
            raise SystemExit("buffer 0 is longer than the BIN chunk")
        binary = binary[: buffers[0]["byteLength"]]
        for spec in args.flip_winding:
            m, p = (int(x) for x in spec.split("/"))
            flip_winding(doc, binary, m, p)
        stem = os.path.splitext(os.path.basename(args.output))[0]
        buffers[0]["uri"] = stem + ".bin"
        with open(os.path.join(os.path.dirname(os.path.abspath(args.output)), stem + ".bin"), "wb") as f:
            f.write(binary)
    elif args.flip_winding:
        raise SystemExit("--flip-winding needs a GLB with a BIN chunk")
    with open(args.output, "w") as f:
        json.dump(doc, f, indent=1)
        f.write("\n")


if __name__ == "__main__":
    main()
